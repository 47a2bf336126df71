// HTTP API of `ffd serve` (docs/editor.md): JSON operations and the binary
// frame / topology / influence replies.

export class ApiError extends Error {
  constructor(message, httpStatus, status) {
    super(message);
    this.name = 'ApiError';
    this.httpStatus = httpStatus;
    this.status = status || '';
  }
}

// --- pending-request tracking (busy overlay, last request time) ------------

const listeners = new Set();
const pending = new Map(); // id -> {start, label}
let nextId = 1;
export const stats = { lastMs: 0, lastOp: '' };

export function onActivity(fn) { listeners.add(fn); }
function notify() { for (const fn of listeners) fn(); }

// --- connection (the offline banner, toasts.js) -------------------------------

const connection = new Set();
/** fn(false) when a request cannot reach the server (network error). */
export function onConnection(fn) { connection.add(fn); }
function lost() { for (const fn of connection) fn(false); }

/** True when the server answers GET /api/state within ms (not counted as a pending request). */
export async function ping(ms = 3000) {
  const ctl = new AbortController();
  const t = setTimeout(() => ctl.abort(), ms);
  try {
    const res = await fetch('/api/state', { cache: 'no-store', signal: ctl.signal });
    return res.ok;
  } catch {
    return false;
  } finally {
    clearTimeout(t);
  }
}

/** Time (ms) the oldest pending request has been waiting, 0 when none. */
export function oldestPendingMs() {
  let oldest = Infinity;
  for (const p of pending.values()) if (p.start < oldest) oldest = p.start;
  return oldest === Infinity ? 0 : performance.now() - oldest;
}
/** Number of requests sent and not yet answered. */
export function pendingCount() { return pending.size; }
export function pendingLabel() {
  let best = null;
  for (const p of pending.values()) if (!best || p.start < best.start) best = p;
  return best ? best.label : '';
}

async function request(method, path, { json, body, binary = false, label } = {}) {
  const id = nextId++;
  const start = performance.now();
  pending.set(id, { start, label: label || path });
  notify();
  try {
    const init = { method, headers: {} };
    if (json !== undefined) {
      init.headers['Content-Type'] = 'application/json';
      init.body = JSON.stringify(json);
    } else if (body !== undefined) {
      init.headers['Content-Type'] = 'application/octet-stream';
      init.body = body;
    }
    let res;
    try {
      res = await fetch(path, init);
    } catch (e) {
      lost();
      throw new ApiError(`cannot reach the server (${e.message})`, 0, 'network');
    }
    if (!res.ok) {
      let msg = `${res.status} ${res.statusText}`;
      let status = '';
      try {
        const text = await res.text();
        try {
          const j = JSON.parse(text);
          if (j && j.error) { msg = j.error; status = j.status || ''; }
        } catch { if (text) msg += `: ${text.slice(0, 200)}`; }
      } catch { /* ignore */ }
      throw new ApiError(msg, res.status, status);
    }
    if (binary === 'blob') {
      const cd = res.headers.get('Content-Disposition') || '';
      const m = cd.match(/filename\*?=(?:UTF-8'')?"?([^";]+)"?/i);
      return { data: await res.blob(), name: m ? decodeURIComponent(m[1]) : '' };
    }
    if (binary) return await res.arrayBuffer();
    const ct = res.headers.get('Content-Type') || '';
    if (ct.includes('json')) return await res.json();
    const text = await res.text();
    try { return JSON.parse(text); } catch { return text; }
  } finally {
    pending.delete(id);
    stats.lastMs = performance.now() - start;
    stats.lastOp = label || path;
    notify();
  }
}

// --- binary parsing ---------------------------------------------------------

function magic(view) {
  return String.fromCharCode(view.getUint8(0), view.getUint8(1), view.getUint8(2), view.getUint8(3));
}

/** Frame: FFDF, rev, V, C, R, positions V*3, controls C*3, residuals R. */
export function parseFrame(buf) {
  const dv = new DataView(buf);
  if (buf.byteLength < 20 || magic(dv) !== 'FFDF') throw new ApiError('bad frame from the server', 0, 'parse');
  const revision = dv.getUint32(4, true);
  const V = dv.getUint32(8, true);
  const C = dv.getUint32(12, true);
  const R = dv.getUint32(16, true);
  const need = 20 + 4 * (3 * V + 3 * C + R);
  if (buf.byteLength < need) throw new ApiError(`short frame (${buf.byteLength} < ${need} bytes)`, 0, 'parse');
  let off = 20;
  const positions = new Float32Array(buf, off, 3 * V); off += 12 * V;
  const controls = new Float32Array(buf, off, 3 * C); off += 12 * C;
  const residuals = new Float32Array(buf, off, R);
  return { revision, V, C, R, positions, controls, residuals };
}

/**
 * Delta frame (a drag step's or a frame's reply when the request names the
 * frame the page holds, ?base=REV; docs/editor.md "Delta frames"): FFDD, rev,
 * base, V, K, M, C, R, 0; then K vertex ids (uint32) and their K*3
 * positions, M ids and their M*3 normals, controls C*3, residuals R.
 * Returns an object like parseFrame's with delta: true, base, indices,
 * normalIndices and normals.
 */
export function parseDeltaFrame(buf) {
  const dv = new DataView(buf);
  if (buf.byteLength < 36 || magic(dv) !== 'FFDD') throw new ApiError('bad delta frame from the server', 0, 'parse');
  const [revision, base, V, K, M, C, R, flags] = [1, 2, 3, 4, 5, 6, 7, 8].map((i) => dv.getUint32(4 * i, true));
  const need = 36 + 16 * K + 16 * M + 12 * C + 4 * R;
  if (flags !== 0 || buf.byteLength !== need) throw new ApiError(`delta frame of ${buf.byteLength} bytes (flags ${flags}), expected ${need} (flags 0)`, 0, 'parse');
  let off = 36;
  const indices = new Uint32Array(buf, off, K); off += 4 * K;
  const positions = new Float32Array(buf, off, 3 * K); off += 12 * K;
  const normalIndices = new Uint32Array(buf, off, M); off += 4 * M;
  const normals = new Float32Array(buf, off, 3 * M); off += 12 * M;
  const controls = new Float32Array(buf, off, 3 * C); off += 12 * C;
  const residuals = new Float32Array(buf, off, R);
  return { delta: true, revision, base, V, K, M, C, R, indices, positions, normalIndices, normals, controls, residuals };
}

/** A drag reply: a full frame or a delta frame. */
export function parseAnyFrame(buf) {
  return buf.byteLength >= 4 && magic(new DataView(buf)) === 'FFDD' ? parseDeltaFrame(buf) : parseFrame(buf);
}

/**
 * The revision the page's geometry will have once `frame` is applied to a
 * geometry of revision `held`: a delta applies only to the frame it was made
 * against (else the page drops it and asks for the whole frame).
 */
export function revisionAfter(frame, held) {
  return !frame.delta || frame.base === held ? frame.revision : held;
}

/** Topology: FFDT, rev, V, T, rest positions V*3, triangles T*3 (uint32). */
export function parseTopology(buf) {
  const dv = new DataView(buf);
  if (buf.byteLength < 16 || magic(dv) !== 'FFDT') throw new ApiError('bad topology from the server', 0, 'parse');
  const revision = dv.getUint32(4, true);
  const V = dv.getUint32(8, true);
  const T = dv.getUint32(12, true);
  const need = 16 + 12 * V + 12 * T;
  if (buf.byteLength < need) throw new ApiError(`short topology (${buf.byteLength} < ${need} bytes)`, 0, 'parse');
  const rest = new Float32Array(buf, 16, 3 * V);
  const triangles = new Uint32Array(buf, 16 + 12 * V, 3 * T);
  return { revision, V, T, rest, triangles };
}

/** Influence: FFDI, rev, V, 0, weights V. */
export function parseInfluence(buf) {
  const dv = new DataView(buf);
  if (buf.byteLength < 16 || magic(dv) !== 'FFDI') throw new ApiError('bad influence from the server', 0, 'parse');
  const revision = dv.getUint32(4, true);
  const V = dv.getUint32(8, true);
  if (buf.byteLength < 16 + 4 * V) throw new ApiError('short influence reply', 0, 'parse');
  return { revision, V, weights: new Float32Array(buf, 16, V) };
}

/** Weights: FFDW, rev, V, 0, float32 weights V. */
export function parseWeights(buf) {
  const dv = new DataView(buf);
  if (buf.byteLength < 16 || magic(dv) !== 'FFDW') throw new ApiError('bad weights from the server', 0, 'parse');
  const V = dv.getUint32(8, true);
  if (buf.byteLength < 16 + 4 * V) throw new ApiError('short weights reply', 0, 'parse');
  return new Float32Array(buf, 16, V);
}

// --- endpoints --------------------------------------------------------------

/** "?base=REV" (the revision of the frame the page holds; "none": no frame), or "" for full frames only. */
function baseQuery(base) {
  if (base === undefined || !api.deltaFrames) return '';
  return `?base=${base >= 0 ? base : 'none'}`;
}

export const api = {
  state: () => request('GET', '/api/state', { label: 'state' }),
  /** The current frame; with `base` (the revision the geometry holds) a delta frame where the server holds it. */
  frame: async (base) => parseAnyFrame(await request('GET', `/api/frame${baseQuery(base)}`, { binary: true, label: 'frame' })),
  topology: async () => parseTopology(await request('GET', '/api/topology', { binary: true, label: 'topology' })),
  files: () => request('GET', '/api/files', { label: 'files' }),
  /** A JSON operation replying with the new state. */
  op: (name, body = {}) => request('POST', `/api/${name}`, { json: body, label: name }),
  /**
   * One drag step: replies with a frame; with `base` (the revision of the
   * frame the geometry holds when the reply is applied) a delta frame of the
   * vertices that changed since it, where the server holds that frame.
   */
  dragStep: async (body, base) => parseAnyFrame(await request('POST', `/api/drag${baseQuery(base)}`, { json: body, binary: true, label: 'drag' })),
  /** Drag steps ask for delta frames (benchmarks compare with full frames). */
  deltaFrames: true,
  influence: async (points) =>
    parseInfluence(await request('POST', '/api/influence', { json: { points }, binary: true, label: 'influence' })),
  upload: (name, data) =>
    request('POST', `/api/upload?name=${encodeURIComponent(name)}`, { body: data, label: 'upload mesh' }),
  /** Adds an uploaded mesh to the session (several meshes): replies with the state. */
  addMeshUpload: (name, data) =>
    request('POST', `/api/upload?add=1&name=${encodeURIComponent(name)}`, { body: data, label: 'Adding mesh…' }),
  uploadRig: (name, data) =>
    request('POST', `/api/rig/upload?name=${encodeURIComponent(name)}`, { body: data, label: 'upload rig' }),
  post: (path, json, label) => request('POST', path, { json, label }),
  /** A GET download: {data: Blob, name: from Content-Disposition}. */
  blob: (path, label) => request('GET', path, { binary: 'blob', label }),
  /** Every vertex's vertex-group weight (the "weights_values" op): Float32Array. */
  weights: async () => parseWeights(await request('POST', '/api/weights_values', { json: {}, binary: true, label: 'weights' })),
};
