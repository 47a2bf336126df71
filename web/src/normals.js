// Vertex normals of a whole big mesh computed off the main thread (a Web
// Worker), for the frames that are not deltas: the first frame of a mesh and
// a client's resync. Drag steps carry their normals (delta frames,
// docs/editor.md), so this runs rarely; it keeps the page's main thread free
// of the full recomputation, which costs tens of milliseconds at 500K
// vertices.

// The worker's code (an inline module: no second bundle to serve). Area-
// weighted normals, the sums in double, as Viewport.computeNormals.
const SOURCE = `
let tri = null;
onmessage = (e) => {
  const m = e.data;
  if (m.triangles) { tri = m.triangles; return; }
  const p = m.positions, s = new Float64Array(p.length);
  for (let i = 0, T = tri.length; i < T; i += 3) {
    const a = 3 * tri[i], b = 3 * tri[i + 1], c = 3 * tri[i + 2];
    const ax = p[a], ay = p[a + 1], az = p[a + 2];
    const e1x = p[b] - ax, e1y = p[b + 1] - ay, e1z = p[b + 2] - az;
    const e2x = p[c] - ax, e2y = p[c + 1] - ay, e2z = p[c + 2] - az;
    const nx = e1y * e2z - e1z * e2y, ny = e1z * e2x - e1x * e2z, nz = e1x * e2y - e1y * e2x;
    s[a] += nx; s[a + 1] += ny; s[a + 2] += nz;
    s[b] += nx; s[b + 1] += ny; s[b + 2] += nz;
    s[c] += nx; s[c + 1] += ny; s[c + 2] += nz;
  }
  const n = new Float32Array(p.length);
  for (let i = 0, N = n.length; i < N; i += 3) {
    const l = Math.hypot(s[i], s[i + 1], s[i + 2]);
    if (l > 0) { n[i] = s[i] / l; n[i + 1] = s[i + 1] / l; n[i + 2] = s[i + 2] / l; } else { n[i + 1] = 1; }
  }
  postMessage({ seq: m.seq, normals: n }, [n.buffer]);
};`;

/** Meshes with at least this many triangles get their full normals from the worker. */
export const WORKER_MIN_TRIANGLES = 150000;

export class NormalsWorker {
  /** @param triangles  the mesh's triangle corners (copied to the worker) */
  constructor(triangles) {
    const url = URL.createObjectURL(new Blob([SOURCE], { type: 'text/javascript' }));
    this.worker = new Worker(url);
    URL.revokeObjectURL(url);
    this.seq = 0;
    this.waiting = null;
    this.worker.onmessage = (e) => {
      const w = this.waiting;
      if (w && e.data.seq === w.seq) { this.waiting = null; w.done(e.data.normals); }
    };
    const t = triangles.slice();
    this.worker.postMessage({ triangles: t }, [t.buffer]);
  }

  /** Computes the normals of positions (copied); done(normals) runs for the latest request only. */
  request(positions, done) {
    const seq = ++this.seq;
    const p = positions.slice();
    this.waiting = { seq, done };
    this.worker.postMessage({ seq, positions: p }, [p.buffer]);
  }

  get pending() { return !!this.waiting; }

  terminate() { this.worker.terminate(); this.waiting = null; }
}
