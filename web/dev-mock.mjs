#!/usr/bin/env node
// A stand-in for `ffd serve` for front-end development: serves web/dist and
// fakes the session API of docs/editor.md well enough to click and drag.
// No dependencies. Not used by the real server or the build.
//
//   node dev-mock.mjs [--port 8090] [--verts 3000] [--delay 0]
//
// The deformers are toys (a Bernstein lattice for "lattice" and "tspline",
// Gaussian bumps for "pbffd" and "gffd"), the direct-manipulation solve is the
// minimum-norm least-squares one of Hsu et al. on those weights.

import http from 'node:http';
import { readFile, stat } from 'node:fs/promises';
import { dirname, join, normalize, extname } from 'node:path';
import { fileURLToPath } from 'node:url';

const here = dirname(fileURLToPath(import.meta.url));
const args = Object.fromEntries(process.argv.slice(2).join(' ').split('--').filter(Boolean)
  .map((a) => a.trim().split(/\s+/)).map(([k, v]) => [k, v ?? '1']));
const PORT = Number(args.port ?? 8090);
const DELAY = Number(args.delay ?? 0);
const DIST = join(here, 'dist');

// --- meshes -------------------------------------------------------------------

/** A bumpy, slightly elongated sphere with about `n` vertices. */
function blob(n, name) {
  const rings = Math.max(4, Math.round(Math.sqrt(n / 2)));
  const segs = Math.max(6, Math.round(n / rings));
  const pos = [];
  const tris = [];
  pos.push(0, 1.25, 0);
  for (let i = 1; i < rings; i++) {
    const th = (Math.PI * i) / rings;
    for (let j = 0; j < segs; j++) {
      const ph = (2 * Math.PI * j) / segs;
      const r = 1 + 0.12 * Math.sin(3 * th) * Math.cos(2 * ph) + 0.05 * Math.sin(7 * ph) * Math.sin(th);
      pos.push(r * Math.sin(th) * Math.cos(ph) * 0.85, r * Math.cos(th) * 1.25, r * Math.sin(th) * Math.sin(ph) * 0.7);
    }
  }
  pos.push(0, -1.25, 0);
  const last = pos.length / 3 - 1;
  const id = (i, j) => 1 + (i - 1) * segs + (j % segs);
  for (let j = 0; j < segs; j++) tris.push(0, id(1, j + 1), id(1, j));
  for (let i = 1; i < rings - 1; i++) {
    for (let j = 0; j < segs; j++) {
      const a = id(i, j), b = id(i, j + 1), c = id(i + 1, j), d = id(i + 1, j + 1);
      tris.push(a, b, d, a, d, c);
    }
  }
  for (let j = 0; j < segs; j++) tris.push(last, id(rings - 1, j), id(rings - 1, j + 1));
  const rest = new Float32Array(pos);
  const min = [Infinity, Infinity, Infinity], max = [-Infinity, -Infinity, -Infinity];
  for (let v = 0; v < rest.length; v += 3) for (let k = 0; k < 3; k++) { min[k] = Math.min(min[k], rest[v + k]); max[k] = Math.max(max[k], rest[v + k]); }
  return { name, V: rest.length / 3, F: tris.length / 3, rest, tris: new Uint32Array(tris), min, max };
}

// --- the session ----------------------------------------------------------------

let S = null;

function newSession(mesh) {
  S = { revision: 1, mesh, method: null, params: null, ctl: null, pins: [], drag: null, undo: [], redo: [], busy: 0, bindKey: '' };
  S.cur = new Float32Array(mesh.rest);
}

const diag = () => Math.hypot(...S.mesh.max.map((x, k) => x - S.mesh.min[k]));

/** Controls for a method: {rest, pos, edges, extra, kind} */
function makeControls(method, p) {
  const m = S.mesh;
  if (method === 'lattice' || method === 'tspline') {
    const res = p.resolution || (method === 'lattice' ? [5, 5, 5] : [6, 6, 6]);
    const [l, mm, n] = res.map((x) => Math.max(2, Math.min(12, x | 0)));
    const margin = method === 'lattice' ? (p.margin ?? 0.05) : (p.padding ?? 0) + 0.02;
    const lo = m.min.map((x, k) => x - margin * (m.max[k] - m.min[k]));
    const hi = m.max.map((x, k) => x + margin * (m.max[k] - m.min[k]));
    const rest = [];
    const edges = [];
    const idx = (i, j, k) => (i * mm + j) * n + k;
    for (let i = 0; i < l; i++) for (let j = 0; j < mm; j++) for (let k = 0; k < n; k++) {
      rest.push(lo[0] + (hi[0] - lo[0]) * i / (l - 1), lo[1] + (hi[1] - lo[1]) * j / (mm - 1), lo[2] + (hi[2] - lo[2]) * k / (n - 1));
      if (i + 1 < l) edges.push([idx(i, j, k), idx(i + 1, j, k)]);
      if (j + 1 < mm) edges.push([idx(i, j, k), idx(i, j + 1, k)]);
      if (k + 1 < n) edges.push([idx(i, j, k), idx(i, j, k + 1)]);
    }
    const ctl = { kind: 'bernstein', res: [l, mm, n], lo, hi, rest: new Float64Array(rest), edges };
    if (method === 'tspline') {
      // proxy: the lattice's boundary quads, outward
      const faces = [];
      const quad = (a, b, c, d) => faces.push([a, b, c, d]);
      for (let j = 0; j + 1 < mm; j++) for (let k = 0; k + 1 < n; k++) {
        quad(idx(0, j, k), idx(0, j, k + 1), idx(0, j + 1, k + 1), idx(0, j + 1, k));
        quad(idx(l - 1, j, k), idx(l - 1, j + 1, k), idx(l - 1, j + 1, k + 1), idx(l - 1, j, k + 1));
      }
      for (let i = 0; i + 1 < l; i++) for (let k = 0; k + 1 < n; k++) {
        quad(idx(i, 0, k), idx(i + 1, 0, k), idx(i + 1, 0, k + 1), idx(i, 0, k + 1));
        quad(idx(i, mm - 1, k), idx(i, mm - 1, k + 1), idx(i + 1, mm - 1, k + 1), idx(i + 1, mm - 1, k));
      }
      for (let i = 0; i + 1 < l; i++) for (let j = 0; j + 1 < mm; j++) {
        quad(idx(i, j, 0), idx(i, j + 1, 0), idx(i + 1, j + 1, 0), idx(i + 1, j, 0));
        quad(idx(i, j, n - 1), idx(i + 1, j, n - 1), idx(i + 1, j + 1, n - 1), idx(i, j + 1, n - 1));
      }
      const pts = new Set(faces.flat());
      ctl.proxy = { faces, points: [...pts].sort((a, b) => a - b) };
      ctl.frozen = [];
      ctl.refinements = 0;
    }
    return ctl;
  }
  if (method === 'pbffd') {
    const count = Math.max(4, Math.min(200, ((p.interior ?? 60) + (p.exterior ?? 60)) / 4 | 0));
    const levels = Math.max(1, p.levels ?? 1);
    const rest = [];
    const ebfs = [];
    const d = diag();
    // points on a Fibonacci sphere scaled to the box, slightly inside
    for (let i = 0; i < count; i++) {
      const y = 1 - (2 * (i + 0.5)) / count, r = Math.sqrt(1 - y * y), ph = i * 2.399963;
      const c = m.min.map((x, k) => (x + m.max[k]) / 2);
      const h = m.max.map((x, k) => (x - m.min[k]) / 2 * 0.8);
      rest.push(c[0] + h[0] * r * Math.cos(ph), c[1] + h[1] * y, c[2] + h[2] * r * Math.sin(ph));
      const a = Math.atan2(y, r * Math.cos(ph));
      ebfs.push({ radius: [0.22 * d, 0.16 * d, 0.13 * d], frame: [[Math.cos(a), Math.sin(a), 0], [-Math.sin(a), Math.cos(a), 0], [0, 0, 1]], enabled: true });
    }
    return { kind: 'gauss', rest: new Float64Array(rest), edges: [], ebfs, levels, level: 0, curves: [] };
  }
  if (method === 'gffd') {
    const d = diag();
    const c = m.min.map((x, k) => (x + m.max[k]) / 2);
    const ext = m.max.map((x, k) => x - m.min[k]);
    const ax = ext.indexOf(Math.max(...ext));
    const rest = [];
    for (let i = 0; i < 5; i++) {
      const q = [...c];
      q[ax] = m.min[ax] + ext[ax] * (0.1 + 0.8 * i / 4);
      rest.push(...q);
    }
    return {
      kind: 'gauss', rest: new Float64Array(rest), edges: [[0, 1], [1, 2], [2, 3], [3, 4]],
      primitives: [{ type: 'polyline', radius: 0.3 * d, offset: 0, count: 5, faces: [] }],
    };
  }
  throw Object.assign(new Error(`unknown method "${method}"`), { http: 400, status: 'invalid' });
}

// binding: per-vertex parameters for the Bernstein lattice
function bind() {
  const c = S.ctl;
  if (!c) return;
  const key = JSON.stringify([S.mesh.name, S.method, c.res, c.lo, c.hi, c.rest.length]);
  if (S.bindKey === key) return;
  S.bindKey = key;
  if (c.kind !== 'bernstein') return;
  const V = S.mesh.V, r = S.mesh.rest;
  const [l, m, n] = c.res;
  c.B = [new Float32Array(V * l), new Float32Array(V * m), new Float32Array(V * n)];
  for (let v = 0; v < V; v++) {
    for (let a = 0; a < 3; a++) {
      const deg = c.res[a] - 1;
      const t = (r[3 * v + a] - c.lo[a]) / (c.hi[a] - c.lo[a]);
      for (let i = 0; i <= deg; i++) c.B[a][v * (deg + 1) + i] = binom(deg, i) * t ** i * (1 - t) ** (deg - i);
    }
  }
}
const binom = (n, k) => { let r = 1; for (let i = 1; i <= k; i++) r = (r * (n - k + i)) / i; return r; };

function gaussRadius(i) {
  const c = S.ctl;
  if (c.ebfs) { if (i < c.ebfs.length) return c.ebfs[i].radius[0]; const cv = c.curves.find((q) => i >= q.offset && i < q.offset + q.count); return cv ? cv.radius : diag() * 0.1; }
  const p = c.primitives.find((q) => i >= q.offset && i < q.offset + q.count);
  return p ? p.radius : diag() * 0.2;
}

/** Weight of control i at rest point x (rows for the solve and influence). */
function weightsAt(v) {
  const c = S.ctl, C = c.rest.length / 3, w = new Float64Array(C), r = S.mesh.rest;
  if (c.kind === 'bernstein') {
    const [l, m, n] = c.res;
    for (let i = 0; i < l; i++) for (let j = 0; j < m; j++) for (let k = 0; k < n; k++)
      w[(i * m + j) * n + k] = c.B[0][v * l + i] * c.B[1][v * m + j] * c.B[2][v * n + k];
  } else {
    for (let i = 0; i < C; i++) {
      const d2 = (r[3 * v] - c.rest[3 * i]) ** 2 + (r[3 * v + 1] - c.rest[3 * i + 1]) ** 2 + (r[3 * v + 2] - c.rest[3 * i + 2]) ** 2;
      const s = gaussRadius(i);
      w[i] = Math.exp(-d2 / (s * s));
    }
  }
  return w;
}

/** Deformed positions: rest + sum_i w_i (P_i - rest_i). */
function evaluate() {
  const out = S.cur, r = S.mesh.rest, V = S.mesh.V;
  out.set(r);
  const c = S.ctl;
  if (!c) return out;
  bind();
  const C = c.rest.length / 3;
  const d = new Float64Array(3 * C);
  let any = false;
  for (let i = 0; i < 3 * C; i++) { d[i] = c.pos[i] - c.rest[i]; if (d[i]) any = true; }
  if (!any) return out;
  if (c.kind === 'bernstein') {
    const [l, m, n] = c.res;
    const B0 = c.B[0], B1 = c.B[1], B2 = c.B[2];
    for (let v = 0; v < V; v++) {
      let x = 0, y = 0, z = 0;
      for (let i = 0; i < l; i++) {
        const bi = B0[v * l + i];
        if (bi < 1e-9) continue;
        for (let j = 0; j < m; j++) {
          const bij = bi * B1[v * m + j];
          if (bij < 1e-9) continue;
          for (let k = 0; k < n; k++) {
            const w = bij * B2[v * n + k];
            const q = 3 * ((i * m + j) * n + k);
            x += w * d[q]; y += w * d[q + 1]; z += w * d[q + 2];
          }
        }
      }
      out[3 * v] += x; out[3 * v + 1] += y; out[3 * v + 2] += z;
    }
  } else {
    const moved = [];
    for (let i = 0; i < C; i++) if (d[3 * i] || d[3 * i + 1] || d[3 * i + 2]) moved.push(i);
    for (let v = 0; v < V; v++) {
      for (const i of moved) {
        const d2 = (r[3 * v] - c.rest[3 * i]) ** 2 + (r[3 * v + 1] - c.rest[3 * i + 1]) ** 2 + (r[3 * v + 2] - c.rest[3 * i + 2]) ** 2;
        const s = gaussRadius(i);
        const w = Math.exp(-d2 / (s * s));
        out[3 * v] += w * d[3 * i]; out[3 * v + 1] += w * d[3 * i + 1]; out[3 * v + 2] += w * d[3 * i + 2];
      }
    }
  }
  return out;
}

// --- state and binary replies -------------------------------------------------------

function stateJSON() {
  const c = S.ctl;
  const controls = c ? { count: c.rest.length / 3, edges: c.edges } : { count: 0, edges: [] };
  if (S.method === 'lattice') Object.assign(controls, { resolution: c.res, basis: S.params.basis || 'bspline' });
  if (S.method === 'pbffd') Object.assign(controls, { level: c.level, levels: c.levels, ebfs: c.ebfs, curves: c.curves });
  if (S.method === 'gffd') Object.assign(controls, { primitives: c.primitives, influenced: S.mesh.V });
  if (S.method === 'tspline') {
    const [l, m, n] = c.res;
    Object.assign(controls, {
      proxy: c.proxy, frozen: c.frozen, cells: (l - 1) * (m - 1) * (n - 1), faces: c.proxy.faces.length,
      edges_count: c.edges.length, max_weight_deviation: 1e-15, refinements: c.refinements,
    });
  }
  const m = S.mesh;
  return {
    revision: S.revision,
    mesh: { name: m.name, vertices: m.V, faces: m.F, min: m.min, max: m.max },
    method: S.method, params: S.params, controls, pins: S.pins,
    drag: S.drag ? { mode: S.drag.mode || 'vertex' } : null,
    undo: S.undo.length, redo: S.redo.length, busy_ms: S.busy,
  };
}

function frameBuf(residuals = []) {
  const V = S.mesh.V, C = S.ctl ? S.ctl.rest.length / 3 : 0, R = residuals.length;
  const buf = Buffer.alloc(20 + 4 * (3 * V + 3 * C + R));
  buf.write('FFDF', 0, 'latin1');
  buf.writeUInt32LE(S.revision, 4); buf.writeUInt32LE(V, 8); buf.writeUInt32LE(C, 12); buf.writeUInt32LE(R, 16);
  const f = new Float32Array(buf.buffer, buf.byteOffset + 20, 3 * V + 3 * C + R);
  f.set(S.cur, 0);
  if (C) f.set(S.ctl.pos, 3 * V);
  f.set(residuals, 3 * V + 3 * C);
  return buf;
}

function topologyBuf() {
  const m = S.mesh;
  const buf = Buffer.alloc(16 + 12 * m.V + 12 * m.F);
  buf.write('FFDT', 0, 'latin1');
  buf.writeUInt32LE(S.revision, 4); buf.writeUInt32LE(m.V, 8); buf.writeUInt32LE(m.F, 12);
  new Float32Array(buf.buffer, buf.byteOffset + 16, 3 * m.V).set(m.rest);
  new Uint32Array(buf.buffer, buf.byteOffset + 16 + 12 * m.V, 3 * m.F).set(m.tris);
  return buf;
}

// --- operations ------------------------------------------------------------------------

const fail = (msg, http = 400, status = 'invalid') => { throw Object.assign(new Error(msg), { http, status }); };
const snapshot = () => structuredClone({ method: S.method, params: S.params, ctl: S.ctl && { ...S.ctl, B: undefined }, pins: S.pins });
function restore(s) {
  S.method = s.method; S.params = s.params; S.pins = s.pins;
  const B = S.ctl && S.ctl.B;
  S.ctl = s.ctl;
  if (S.ctl && B && S.ctl.kind === 'bernstein') S.ctl.B = B; // same binding if the same lattice
  S.bindKey = '';
}
function commit(before) { S.undo.push(before); S.redo = []; S.revision++; }
const needMethod = () => { if (!S.method) fail('no deformer: create one first', 409, 'state'); };

function transform(pos, start, ids, body, center) {
  pos.set(start);
  const [cx, cy, cz] = center;
  for (const i of ids) {
    let x = start[3 * i] - cx, y = start[3 * i + 1] - cy, z = start[3 * i + 2] - cz;
    if (body.delta) { x += body.delta[0]; y += body.delta[1]; z += body.delta[2]; }
    if (body.scale) { x *= body.scale[0]; y *= body.scale[1]; z *= body.scale[2]; }
    if (body.axis) {
      const [ax, ay, az] = body.axis, len = Math.hypot(ax, ay, az) || 1;
      const ux = ax / len, uy = ay / len, uz = az / len, a = body.angle || 0, co = Math.cos(a), si = Math.sin(a);
      const dot = ux * x + uy * y + uz * z;
      const rx = x * co + (uy * z - uz * y) * si + ux * dot * (1 - co);
      const ry = y * co + (uz * x - ux * z) * si + uy * dot * (1 - co);
      const rz = z * co + (ux * y - uy * x) * si + uz * dot * (1 - co);
      x = rx; y = ry; z = rz;
    }
    pos[3 * i] = x + cx; pos[3 * i + 1] = y + cy; pos[3 * i + 2] = z + cz;
  }
}

/** Minimum-norm solve for vertex constraints (pins + dragged), from the lattice `start`. */
function solvePins(start, cons) {
  const c = S.ctl, C = c.rest.length / 3, k = cons.length;
  c.pos.set(start);
  if (!k) return [];
  evaluate();
  const rows = cons.map((q) => weightsAt(q.vertex));
  const D = cons.map((q) => [0, 1, 2].map((a) => q.target[a] - S.cur[3 * q.vertex + a]));
  const M = rows.map((ri) => rows.map((rj) => { let s = 0; for (let t = 0; t < C; t++) s += ri[t] * rj[t]; return s; }));
  const tr = M.reduce((s, r, i) => s + r[i], 0) / k;
  for (let i = 0; i < k; i++) M[i][i] += 1e-7 * tr;
  const lam = gauss(M, D);
  for (let t = 0; t < C; t++) for (let i = 0; i < k; i++) for (let a = 0; a < 3; a++) c.pos[3 * t + a] += rows[i][t] * lam[i][a];
  evaluate();
  return cons.map((q) => Math.hypot(...[0, 1, 2].map((a) => q.target[a] - S.cur[3 * q.vertex + a])));
}
function gauss(A, B) {
  const n = A.length, a = A.map((r, i) => [...r, ...B[i]]);
  for (let i = 0; i < n; i++) {
    let p = i; for (let r = i + 1; r < n; r++) if (Math.abs(a[r][i]) > Math.abs(a[p][i])) p = r;
    [a[i], a[p]] = [a[p], a[i]];
    for (let r = 0; r < n; r++) if (r !== i) { const f = a[r][i] / a[i][i]; for (let cc = i; cc < n + 3; cc++) a[r][cc] -= f * a[i][cc]; }
  }
  return a.map((r, i) => r.slice(n).map((x) => x / a[i][i]));
}

function resolvePins() {
  const start = Float64Array.from(S.ctl.pos);
  const res = solvePins(start, S.pins);
  S.pins.forEach((p, i) => { p.residual = res[i]; });
}

const ops = {
  create(body) {
    // a rig's creation keys ("deformer", PB-FFD placement inside "controls"), or the old form
    const { method, deformer, controls, ...rest } = body;
    const placement = controls && typeof controls === 'object' && !Array.isArray(controls) ? controls : {};
    const b = { ...placement, ...rest, method: deformer || method };
    const before = snapshot();
    S.method = b.method;
    S.params = { ...b };
    delete S.params.method;
    S.ctl = makeControls(b.method, b);
    S.ctl.pos = Float64Array.from(S.ctl.rest);
    S.pins = [];
    bind();
    commit(before);
  },
  drag_begin(b) {
    needMethod();
    if (S.drag) fail('a drag is in progress', 409, 'state');
    const C = S.ctl.rest.length / 3;
    if (b.vertex !== undefined) {
      if (!(b.vertex >= 0 && b.vertex < S.mesh.V)) fail('vertex out of range', 400, 'range');
      S.drag = { vertex: b.vertex, before: snapshot(), start: Float64Array.from(S.ctl.pos) };
      return;
    }
    if (!Array.isArray(b.points) || !b.points.length) fail('points: expected control ids');
    for (const i of b.points) if (!(i >= 0 && i < C)) fail(`control ${i} out of range`, 400, 'range');
    const pts = b.points.filter((i) => !(S.ctl.frozen || []).includes(i));
    let center = b.center;
    if (!center) { center = [0, 0, 0]; for (const i of pts) for (let a = 0; a < 3; a++) center[a] += S.ctl.pos[3 * i + a] / pts.length; }
    S.drag = { points: pts, mode: b.mode || 'translate', center, before: snapshot(), start: Float64Array.from(S.ctl.pos) };
  },
  drag(b) {
    if (!S.drag) fail('drag without drag_begin', 409, 'state');
    S.revision++;
    if (S.drag.vertex !== undefined) {
      if (!b.target) fail('target: expected [x,y,z]');
      const cons = [...S.pins.filter((p) => p.vertex !== S.drag.vertex), { vertex: S.drag.vertex, target: b.target }];
      return { frame: solvePins(S.drag.start, cons) };
    }
    transform(S.ctl.pos, S.drag.start, S.drag.points, b, S.drag.center);
    evaluate();
    return { frame: [] };
  },
  drag_end() {
    if (!S.drag) fail('no drag', 409, 'state');
    const before = S.drag.before;
    S.drag = null;
    if (S.pins.length) resolvePinsResidualsOnly();
    commit(before);
  },
  drag_cancel() {
    if (!S.drag) fail('no drag', 409, 'state');
    restore(S.drag.before);
    S.drag = null;
    S.revision++;
  },
  move(b) {
    ops.drag_begin({ points: b.points, mode: 'translate' });
    ops.drag(b);
    ops.drag_end();
  },
  pin(b) {
    needMethod();
    if (!(b.vertex >= 0 && b.vertex < S.mesh.V)) fail('vertex out of range', 400, 'range');
    const before = snapshot();
    const target = b.target || [0, 1, 2].map((a) => S.cur[3 * b.vertex + a]);
    S.pins = S.pins.filter((p) => p.vertex !== b.vertex);
    S.pins.push({ vertex: b.vertex, target, residual: 0 });
    resolvePins();
    commit(before);
  },
  unpin(b) {
    const before = snapshot();
    if (b.all) S.pins = []; else S.pins = S.pins.filter((p) => p.vertex !== b.vertex);
    commit(before);
  },
  reset() {
    needMethod();
    const before = snapshot();
    S.ctl.pos = Float64Array.from(S.ctl.rest);
    S.pins = [];
    commit(before);
  },
  undo() {
    if (!S.undo.length) fail('nothing to undo', 409, 'state');
    S.redo.push(snapshot()); restore(S.undo.pop()); S.revision++;
  },
  redo() {
    if (!S.redo.length) fail('nothing to redo', 409, 'state');
    S.undo.push(snapshot()); restore(S.redo.pop()); S.revision++;
  },
  level(b) {
    if (S.method !== 'pbffd') fail('level: not a PB-FFD', 409, 'state');
    if (!(b.level >= 0 && b.level < S.ctl.levels)) fail('level out of range', 400, 'range');
    const before = snapshot(); S.ctl.level = b.level; commit(before);
  },
  frame(b) {
    if (S.method !== 'pbffd') fail('frame: not a PB-FFD', 409, 'state');
    const before = snapshot();
    for (const i of b.points || []) {
      const e = S.ctl.ebfs[i];
      if (!e) continue;
      if (b.scale) e.radius = e.radius.map((r, k) => r * b.scale[k]);
      if (b.axis) {
        const tmp = new Float64Array(3 * 3);
        e.frame.forEach((f, k) => tmp.set(f, 3 * k));
        transform(tmp, Float64Array.from(tmp), [0, 1, 2], { axis: b.axis, angle: b.angle }, [0, 0, 0]);
        e.frame = [0, 1, 2].map((k) => [tmp[3 * k], tmp[3 * k + 1], tmp[3 * k + 2]]);
      }
    }
    commit(before);
  },
  curve(b) {
    if (S.method !== 'pbffd') fail('curve: not a PB-FFD', 409, 'state');
    if (!Array.isArray(b.points) || b.points.length < 2) fail('curve: at least two points');
    const before = snapshot();
    const n = Math.max(2, Math.min(b.samples || 8, 12));
    const pts = [];
    for (let s = 0; s < n; s++) {
      const t = (s / (n - 1)) * (b.points.length - 1), i = Math.min(b.points.length - 2, Math.floor(t)), f = t - i;
      pts.push(...[0, 1, 2].map((a) => b.points[i][a] * (1 - f) + b.points[i + 1][a] * f));
    }
    const o = S.ctl.rest.length / 3;
    S.ctl.rest = Float64Array.from([...S.ctl.rest, ...pts]);
    S.ctl.pos = Float64Array.from([...S.ctl.pos, ...pts]);
    for (let s = 0; s + 1 < n; s++) S.ctl.edges.push([o + s, o + s + 1]);
    S.ctl.curves.push({ offset: o, count: n, radius: b.radius || diag() * 0.1 });
    commit(before);
  },
  primitive(b) {
    if (S.method !== 'gffd') fail('primitive: not a GFFD', 409, 'state');
    const before = snapshot();
    const c = S.ctl;
    if (b.add) {
      const o = c.rest.length / 3;
      c.rest = Float64Array.from([...c.rest, ...b.add.position]);
      c.pos = Float64Array.from([...c.pos, ...b.add.position]);
      c.primitives.push({ type: b.add.type || 'point', radius: b.add.radius || diag() * 0.1, offset: o, count: 1, faces: [] });
    } else if (b.remove !== undefined) {
      const p = c.primitives[b.remove];
      if (!p) fail('primitive index out of range', 400, 'range');
      const keep = (i) => i < p.offset || i >= p.offset + p.count;
      const C = c.rest.length / 3;
      const map = []; let k = 0;
      for (let i = 0; i < C; i++) map.push(keep(i) ? k++ : -1);
      const pick = (arr) => Float64Array.from([...Array(C).keys()].filter(keep).flatMap((i) => [arr[3 * i], arr[3 * i + 1], arr[3 * i + 2]]));
      c.rest = pick(c.rest); c.pos = pick(c.pos);
      c.edges = c.edges.filter(([a, bb]) => keep(a) && keep(bb)).map(([a, bb]) => [map[a], map[bb]]);
      c.primitives.splice(b.remove, 1);
      for (const q of c.primitives) if (q.offset > p.offset) q.offset -= p.count;
    } else if (b.radius !== undefined) {
      const p = c.primitives[b.index];
      if (!p) fail('primitive index out of range', 400, 'range');
      if (!(b.radius > 0)) fail('radius must be positive');
      p.radius = b.radius;
    } else fail('primitive: expected add, remove or radius');
    commit(before);
  },
  refine(b) {
    if (S.method !== 'tspline') fail('refine: not a T-spline', 409, 'state');
    if (!Array.isArray(b.insertions) || !b.insertions.length) fail('insertions: expected a list');
    const before = snapshot();
    S.ctl.refinements += b.insertions.length;
    commit(before);
  },
  freeze(b) {
    if (S.method !== 'tspline') fail('freeze: not a T-spline', 409, 'state');
    const before = snapshot();
    const f = new Set(S.ctl.frozen);
    for (const i of b.points || []) { if (b.frozen === false) f.delete(i); else f.add(i); }
    S.ctl.frozen = [...f].sort((a, bb) => a - bb);
    commit(before);
  },
};
function resolvePinsResidualsOnly() {
  evaluate();
  for (const p of S.pins) p.residual = Math.hypot(...[0, 1, 2].map((a) => p.target[a] - S.cur[3 * p.vertex + a]));
}

// --- HTTP ---------------------------------------------------------------------------------

const MIME = { '.html': 'text/html; charset=utf-8', '.js': 'text/javascript', '.css': 'text/css', '.map': 'application/json', '.txt': 'text/plain' };
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

async function body(req) {
  const chunks = [];
  for await (const c of req) chunks.push(c);
  return Buffer.concat(chunks);
}

function send(res, code, data, type = 'application/json', extra = {}) {
  res.writeHead(code, { 'Content-Type': type, 'Cache-Control': 'no-store', ...extra });
  res.end(data);
}
const sendState = (res) => send(res, 200, JSON.stringify(stateJSON()));

const FILES = { 'blob.obj': 3000, 'blob-100k.obj': 100000, 'blob-20k.obj': 20000 };

async function api(req, res, url) {
  const t0 = performance.now();
  const path = url.pathname.slice(5);
  if (DELAY) await sleep(DELAY);
  if (req.method === 'GET') {
    if (path === 'state') return sendState(res);
    if (path === 'frame') { evaluate(); return send(res, 200, frameBuf(S.drag ? [] : []), 'application/octet-stream'); }
    if (path === 'topology') return send(res, 200, topologyBuf(), 'application/octet-stream');
    if (path === 'files') return send(res, 200, JSON.stringify({ root: '/mock/', meshes: Object.keys(FILES), rigs: ['bend.json'] }));
    if (path === 'rig') {
      needMethod();
      return send(res, 200, JSON.stringify({ version: 1, deformer: S.method, ...S.params }, null, 2), 'application/json',
        { 'Content-Disposition': 'attachment; filename="rig.json"' });
    }
    if (path === 'export') {
      evaluate();
      let s = '';
      for (let v = 0; v < S.mesh.V; v++) s += `v ${S.cur[3 * v]} ${S.cur[3 * v + 1]} ${S.cur[3 * v + 2]}\n`;
      for (let f = 0; f < S.mesh.F; f++) s += `f ${S.mesh.tris[3 * f] + 1} ${S.mesh.tris[3 * f + 1] + 1} ${S.mesh.tris[3 * f + 2] + 1}\n`;
      return send(res, 200, s, 'text/plain', { 'Content-Disposition': 'attachment; filename="deformed.obj"' });
    }
    return fail('unknown URL', 404, 'not_found');
  }
  if (req.method !== 'POST') return fail('method not allowed', 405, 'invalid');
  const raw = await body(req);
  if (path === 'upload') { newSession(blob(3000, url.searchParams.get('name') || 'upload.obj')); return sendState(res); }
  if (path === 'rig/upload' || path === 'rig/load') { ops.create({ method: 'lattice', resolution: [4, 4, 4], basis: 'bspline' }); return sendState(res); }
  let b;
  try { b = raw.length ? JSON.parse(raw.toString('utf8')) : {}; } catch { return fail('malformed JSON', 400, 'parse'); }
  if (path === 'open') {
    if (!(b.path in FILES)) return fail(`no such file: ${b.path}`, 404, 'not_found');
    newSession(blob(FILES[b.path], b.path));
    return sendState(res);
  }
  if (path === 'rig/save' || path === 'export/save') return send(res, 200, JSON.stringify({ path: b.path }));
  if (path === 'influence') {
    needMethod();
    bind();
    const V = S.mesh.V, buf = Buffer.alloc(16 + 4 * V);
    buf.write('FFDI', 0, 'latin1');
    buf.writeUInt32LE(S.revision, 4); buf.writeUInt32LE(V, 8); buf.writeUInt32LE(0, 12);
    const w = new Float32Array(buf.buffer, buf.byteOffset + 16, V);
    const pts = b.points || [];
    for (let v = 0; v < V; v++) { const row = weightsAt(v); let s = 0; for (const i of pts) s += row[i] || 0; w[v] = Math.min(1, s * (S.ctl.kind === 'bernstein' ? 1 : 1)); }
    return send(res, 200, buf, 'application/octet-stream');
  }
  const op = ops[path];
  if (!op) return fail('unknown URL', 404, 'not_found');
  if (path === 'create' && (b.deformer || b.method) === 'pbffd') await sleep(1500); // automatic placement takes a while
  const r = op(b);
  S.busy = performance.now() - t0;
  if (r && r.frame) return send(res, 200, frameBuf(r.frame), 'application/octet-stream');
  return sendState(res);
}

const server = http.createServer(async (req, res) => {
  const url = new URL(req.url, 'http://x');
  try {
    if (url.pathname.startsWith('/api/')) return await api(req, res, url);
    let p = normalize(decodeURIComponent(url.pathname)).replace(/^(\.\.[/\\])+/, '');
    if (p === '/' || p === '') p = '/index.html';
    const file = join(DIST, p);
    if (!file.startsWith(DIST)) return send(res, 403, '{"error":"forbidden"}');
    await stat(file);
    send(res, 200, await readFile(file), MIME[extname(file)] || 'application/octet-stream');
  } catch (e) {
    const code = e.http || (e.code === 'ENOENT' ? 404 : 500);
    if (code === 500) console.error(e);
    send(res, code, JSON.stringify({ error: e.message, status: e.status || 'error' }));
  }
});

newSession(blob(Number(args.verts ?? 3000), 'blob.obj'));
server.listen(PORT, '127.0.0.1', () => console.log(`ffd serve: http://127.0.0.1:${server.address().port}/`));
