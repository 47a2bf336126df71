// The busy overlay's progress line: how long the running request has taken
// and, for the library's long stages (T-spline set-up, binding, placement,
// reading and writing meshes, ARAP), the stage and its fraction done, as
// GET /api/progress reports them (docs/editor.md). Polled while the overlay
// shows, a few times a second, outside the pending-request count.

const POLL_MS = 250;
let last = null;      // the latest reply
let lastAt = 0;       // when it was asked for
let asking = false;

function elapsed(ms) {
  return ms < 60000 ? `${(ms / 1000).toFixed(1)} s` : `${Math.floor(ms / 60000)} min ${Math.floor(ms / 1000) % 60} s`;
}

function poll() {
  if (asking || performance.now() - lastAt < POLL_MS) return;
  asking = true;
  lastAt = performance.now();
  fetch('/api/progress').then((r) => (r.ok ? r.json() : null)).then(
    (p) => { last = p; asking = false; },
    () => { last = null; asking = false; },
  );
}

/** Text for the overlay: "T-spline set-up 42% · 3.1 s", or the elapsed time alone. */
export function busyProgress(pendingMs) {
  poll();
  const stage = last && last.op && last.stage ? `${last.stage} ${Math.floor(100 * last.fraction)}% · ` : '';
  return stage + elapsed(pendingMs);
}

/** Forgets the last reply (the overlay closed). */
export function progressDone() { last = null; }
