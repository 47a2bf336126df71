#!/usr/bin/env node
// Drag rate of the editor (`ffd serve` + the page) on a large mesh.
//
//   build/bench_session data --write /tmp/elephant100k.ply   # the 100K-vertex mesh
//   node bench/editor_drag.mjs --ffd build/ffd --mesh /tmp/elephant100k.ply [--steps 100]
//                              [--chromium PATH] [--no-browser]
//
// 1. HTTP only (a scripted client, Node's fetch): drag_begin, then --steps
//    sequential `drag` requests, each awaited with its whole binary frame
//    (request, solve, evaluate, transfer), then drag_end; for a 5x5x5 lattice
//    control point, a 12x12x12 T-spline proxy point (ARAP) and a mesh vertex of
//    the lattice (direct manipulation, two pins held).
// 2. The full loop in headless Chromium: the page creates the lattice and runs
//    window.ffdEditor.benchDrag(steps), the gizmo's code path (DragSession: one
//    request in flight, the latest step wins, each frame copied into the
//    geometry with its normals recomputed, drawn by the render loop), once with
//    drawing on (SwiftShader: software GL, far slower than any GPU) and once
//    with drawing off.
// Prints a Markdown table.

import { spawn } from 'node:child_process';
import { existsSync } from 'node:fs';
import { createRequire } from 'node:module';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const REPO = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..');
const argv = process.argv.slice(2);
const opt = (name, dflt) => { const i = argv.indexOf(`--${name}`); return i >= 0 ? argv[i + 1] : dflt; };
const FFD = path.resolve(opt('ffd', path.join(REPO, 'build', 'ffd')));
const MESH = path.resolve(opt('mesh', '/tmp/elephant100k.ply'));
const STEPS = Number(opt('steps', 100));
const EXE = opt('chromium', ['/usr/bin/chromium', '/usr/bin/chromium-browser', '/usr/bin/google-chrome'].find(existsSync));
const WEB = path.join(REPO, 'web', 'dist');

if (!existsSync(FFD)) { console.error(`no ffd binary at ${FFD} (--ffd)`); process.exit(2); }
if (!existsSync(MESH)) { console.error(`no mesh at ${MESH}: build/bench_session data --write ${MESH}`); process.exit(2); }

let server = null;
let BASE = '';
function startServer() {
  return new Promise((resolve, reject) => {
    server = spawn(FFD, ['serve', MESH, '--port', '0', '--web', WEB], { stdio: ['ignore', 'pipe', 'inherit'] });
    let out = '';
    server.stdout.on('data', (d) => {
      out += d;
      const m = out.match(/^ffd serve: (http:\/\/\S+?)\/?\n/);
      if (m && !BASE) { BASE = m[1]; resolve(); }
    });
    server.on('exit', (c) => { if (!BASE) reject(new Error(`ffd serve exited ${c}`)); });
  });
}
async function post(op, body) {
  const res = await fetch(`${BASE}/api/${op}`, { method: 'POST', body: JSON.stringify(body), headers: { 'Content-Type': 'application/json' } });
  if (!res.ok) throw new Error(`${op}: HTTP ${res.status} ${await res.text()}`);
  return res.headers.get('Content-Type').includes('json') ? res.json() : res.arrayBuffer();
}
const stats = (ms) => {
  const s = [...ms].sort((a, b) => a - b);
  const q = (p) => s[Math.min(s.length - 1, Math.floor(p * s.length))];
  const mean = s.reduce((a, b) => a + b, 0) / s.length;
  return { median: q(0.5), p90: q(0.9), mean, ups: 1000 / mean };
};

/** N sequential drag steps over HTTP; each awaits the whole frame. */
async function httpDrag(begin, stepBody) {
  await post('drag_begin', begin);
  const ms = [];
  let bytes = 0;
  for (let i = 1; i <= STEPS + 3; i++) {
    const t0 = performance.now();
    const buf = await post('drag', stepBody(i));
    const t = performance.now() - t0;
    bytes = buf.byteLength;
    if (i > 3) ms.push(t); // the first steps warm caches
  }
  await post('drag_end', {});
  return { ...stats(ms), bytes };
}

const rows = [];
const fmt = (x, d = 1) => (x === undefined ? '—' : x.toFixed(d));
let browser = null;

try {
  const tStart = performance.now();
  await startServer();
  let st = await (await fetch(`${BASE}/api/state`)).json();
  const V = st.mesh.vertices;
  const diag = Math.hypot(...st.mesh.max.map((x, i) => x - st.mesh.min[i]));
  const d = 0.05 * diag;
  const wave = (i) => [d * Math.sin(i / 7), 0.5 * d * (1 - Math.cos(i / 7)), 0];
  console.error(`mesh ${path.basename(MESH)}: ${V} vertices, ${st.mesh.faces} faces; ${STEPS} steps per case`);

  // lattice 5x5x5, the control (2, 4, 2) (top middle)
  let t0 = performance.now();
  st = await post('create', { method: 'lattice', resolution: [5, 5, 5], basis: 'bspline', margin: 0.05 });
  const createLattice = performance.now() - t0;
  const top = (2 * 5 + 4) * 5 + 2;
  const lat = await httpDrag({ points: [top], mode: 'translate' }, (i) => ({ delta: wave(i) }));
  rows.push(['HTTP', 'lattice 5×5×5, control point', lat]);

  // lattice, direct manipulation of a mesh vertex with two pins held
  const f = new Float32Array(await (await fetch(`${BASE}/api/frame`)).arrayBuffer(), 20, 3 * V);
  let vTop = 0, vLo = 0, vHi = 0;
  for (let v = 0; v < V; v++) {
    if (f[3 * v + 1] > f[3 * vTop + 1]) vTop = v;
    if (f[3 * v] < f[3 * vLo]) vLo = v;
    if (f[3 * v] > f[3 * vHi]) vHi = v;
  }
  await post('pin', { vertex: vLo });
  await post('pin', { vertex: vHi });
  const p0 = [f[3 * vTop], f[3 * vTop + 1], f[3 * vTop + 2]];
  const dm = await httpDrag({ vertex: vTop }, (i) => ({ target: p0.map((x, k) => x + wave(i)[k]) }));
  rows.push(['HTTP', 'lattice 5×5×5, mesh vertex (2 pins)', dm]);
  await post('unpin', { all: true });

  // T-spline 12x12x12, ARAP drag of a proxy point
  t0 = performance.now();
  st = await post('create', { method: 'tspline', resolution: [12, 12, 12], padding: 0 });
  const createTs = performance.now() - t0;
  const cf = new Float32Array(await (await fetch(`${BASE}/api/frame`)).arrayBuffer(), 20 + 12 * V, 3 * st.controls.count);
  let pTop = st.controls.proxy.points[0];
  for (const id of st.controls.proxy.points) if (cf[3 * id + 1] > cf[3 * pTop + 1]) pTop = id;
  const ts = await httpDrag({ points: [pTop], mode: 'translate' }, (i) => ({ delta: wave(i) }));
  rows.push(['HTTP', `T-spline 12×12×12 (${st.controls.count} points), proxy point, ARAP`, ts]);
  console.error(`create: lattice ${createLattice.toFixed(0)} ms, T-spline ${createTs.toFixed(0)} ms`);

  // the page in headless Chromium
  if (!argv.includes('--no-browser')) {
    const require = createRequire(path.join(REPO, 'web', 'package.json'));
    const { chromium } = require('playwright-core');
    browser = await chromium.launch({
      executablePath: EXE, headless: true,
      args: ['--no-sandbox', '--use-gl=angle', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist'],
    });
    const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
    page.on('pageerror', (e) => console.error('page error:', e));
    await page.goto(`${BASE}/`);
    await page.waitForSelector('body[data-ready="1"]', { timeout: 120000 });
    await page.evaluate(() => window.ffdEditor.editor.run('create', { method: 'lattice', resolution: [5, 5, 5], basis: 'bspline', margin: 0.05 }));
    await page.waitForFunction(() => window.ffdEditor.state.method === 'lattice' && window.ffdEditor.lastFrameRevision === window.ffdEditor.state.revision, null, { timeout: 120000 });
    await page.evaluate((id) => window.ffdEditor.select([id]), top);
    await page.waitForTimeout(500);
    for (const render of [true, false]) {
      await page.evaluate((on) => window.ffdEditor.setRenderEnabled(on), render);
      const r = await page.evaluate((n) => window.ffdEditor.benchDrag(n), STEPS);
      const s = stats(r.requestMs.slice(3));
      const a = stats(r.applyMs.slice(3));
      rows.push(['page', `lattice 5×5×5, control point, drawing ${render ? 'on (SwiftShader)' : 'off'}`,
        { median: s.median, p90: s.p90, ups: r.updatesPerSecond, apply: a.median, drawn: render ? r.drawnPerSecond : undefined }]);
    }
    await page.evaluate(() => window.ffdEditor.setRenderEnabled(true));
  }

  const cpu = os.cpus()[0];
  console.log(`\nEditor drag steps on ${path.basename(MESH)} (${V.toLocaleString('en-US')} vertices, ${st.mesh.faces.toLocaleString('en-US')} faces), `
    + `${STEPS} steps per case; ${os.cpus().length} × ${cpu ? cpu.model.trim() : '?'}; ${((performance.now() - tStart) / 1000).toFixed(0)} s in all.\n`);
  console.log('| client | drag | step median (ms) | step p90 (ms) | updates/s | mesh update (ms) | frames drawn/s |');
  console.log('|---|---|---:|---:|---:|---:|---:|');
  for (const [client, what, r] of rows) {
    console.log(`| ${client} | ${what} | ${fmt(r.median)} | ${fmt(r.p90)} | ${fmt(r.ups)} | ${fmt(r.apply)} | ${fmt(r.drawn)} |`);
  }
  console.log(`\nHTTP: sequential requests from Node's fetch, each awaiting its frame (${(rows[0][2].bytes / 1e6).toFixed(2)} MB float32).`
    + ' page: window.ffdEditor.benchDrag, the gizmo\'s path (one request in flight, the latest step wins; a new step every 4 ms, so one is always queued);'
    + ' "step" is the request\'s round trip, "mesh update" copies the frame into the geometry and recomputes normals;'
    + ' drawing uses SwiftShader (software GL) in headless Chromium, which shares the CPU with the server.');
} finally {
  if (browser) await browser.close().catch(() => {});
  if (server) server.kill('SIGTERM');
}
