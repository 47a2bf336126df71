#!/usr/bin/env node
// Drag rate of the editor (`ffd serve` + the page) on big meshes, and the
// page's main-thread time per frame.
//
//   node bench/editor_drag.mjs --ffd build/ffd [--vertices 100000,500000] [--mesh a.obj,b.ply]
//                              [--steps 60] [--chromium PATH] [--no-browser]
//
// Meshes: --mesh files, else bumpy UV spheres of --vertices vertices written
// by bench/gen_sphere.mjs into a temporary folder (big meshes are never
// committed). For each mesh, a server of its own:
// 1. HTTP only (Node's fetch): drag_begin, then --steps sequential `drag`
//    requests, each awaited with its whole binary reply, then drag_end; a
//    5x5x5 and a 9x9x9 B-spline lattice's top middle control point with
//    full frames (FFDF) and with delta frames (FFDD: POST /api/drag?base=REV,
//    the vertices that changed and the normals around them, or the full
//    frame where that is smaller); a mesh vertex of the 5x5x5 lattice (direct
//    manipulation, two pins) and, up to 200K vertices, a 12x12x12 T-spline
//    proxy point (ARAP), both asking for delta frames.
// 2. The page in headless Chromium, the 9x9x9 lattice's top control point:
//    window.ffdEditor.benchDrag(steps), the gizmo's code path (DragSession: one request in flight, the latest step
//    wins, each frame applied to the geometry, drawn by the render loop),
//    with full and with delta frames, drawing on (SwiftShader: software GL,
//    far slower than any GPU) and off. The page's main-thread cost per frame
//    comes from its performance measures around the frame-apply path
//    (Viewport.setPositions / applyDelta, `ffd:frame-apply:*`) and around
//    each draw (renderer.render, which uploads the changed buffer ranges).
// Prints Markdown tables.

import { spawn, execFileSync } from 'node:child_process';
import { existsSync, mkdtempSync, rmSync } from 'node:fs';
import { createRequire } from 'node:module';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const REPO = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..');
const argv = process.argv.slice(2);
const opt = (name, dflt) => { const i = argv.indexOf(`--${name}`); return i >= 0 ? argv[i + 1] : dflt; };
const FFD = path.resolve(opt('ffd', path.join(REPO, 'build', 'ffd')));
const STEPS = Number(opt('steps', 60));
const EXE = opt('chromium', ['/usr/bin/chromium', '/usr/bin/chromium-browser', '/usr/bin/google-chrome'].find(existsSync));
const WEB = path.join(REPO, 'web', 'dist');
const browserOn = !argv.includes('--no-browser');

if (!existsSync(FFD)) { console.error(`no ffd binary at ${FFD} (--ffd)`); process.exit(2); }
let tmp = null;
let meshes = opt('mesh', '') ? opt('mesh').split(',').map((m) => path.resolve(m)) : [];
if (!meshes.length) {
  tmp = mkdtempSync(path.join(os.tmpdir(), 'ffd-editor-drag-'));
  for (const n of opt('vertices', '100000,500000').split(',').map(Number)) {
    const out = path.join(tmp, `sphere${Math.round(n / 1000)}k.obj`);
    execFileSync(process.execPath, [path.join(REPO, 'bench', 'gen_sphere.mjs'), '--vertices', String(n), '--out', out], { stdio: ['ignore', 'ignore', 'inherit'] });
    meshes.push(out);
  }
}
for (const m of meshes) if (!existsSync(m)) { console.error(`no mesh at ${m}`); process.exit(2); }

const stats = (ms) => {
  if (!ms.length) return {};
  const s = [...ms].sort((a, b) => a - b);
  const q = (p) => s[Math.min(s.length - 1, Math.floor(p * s.length))];
  const mean = s.reduce((a, b) => a + b, 0) / s.length;
  return { median: q(0.5), p90: q(0.9), max: s[s.length - 1], mean, ups: 1000 / mean };
};
const fmt = (x, d = 1) => (x === undefined || Number.isNaN(x) ? '—' : x.toFixed(d));

/** One server on mesh; resolves to {base, post, stop}. */
function startServer(mesh) {
  return new Promise((resolve, reject) => {
    const server = spawn(FFD, ['serve', mesh, '--port', '0', '--web', WEB, '--no-autosave'], { stdio: ['ignore', 'pipe', 'inherit'] });
    let out = '', base = '';
    server.stdout.on('data', (d) => {
      out += d;
      const m = out.match(/^ffd serve: (http:\/\/\S+?)\/?\n/);
      if (m && !base) {
        base = m[1];
        const post = async (op, body, query = '') => {
          const res = await fetch(`${base}/api/${op}${query}`, { method: 'POST', body: JSON.stringify(body), headers: { 'Content-Type': 'application/json' } });
          if (!res.ok) throw new Error(`${op}: HTTP ${res.status} ${await res.text()}`);
          return res.headers.get('Content-Type').includes('json') ? res.json() : res.arrayBuffer();
        };
        resolve({ base, post, stop: () => server.kill('SIGTERM') });
      }
    });
    server.on('exit', (c) => { if (!base) reject(new Error(`ffd serve exited ${c}`)); });
  });
}

/** N sequential drag steps over HTTP; each awaits its reply. delta: chain ?base= from the replies. */
async function httpDrag(srv, begin, stepBody, delta) {
  const st = await srv.post('drag_begin', begin);
  let rev = st.revision;
  const ms = [], bytes = [], changed = [];
  for (let i = 1; i <= STEPS + 3; i++) {
    const t0 = performance.now();
    const buf = await srv.post('drag', stepBody(i), delta ? `?base=${rev}` : '');
    const t = performance.now() - t0;
    const dv = new DataView(buf);
    rev = dv.getUint32(4, true);
    if (i > 3) { // the first steps warm caches
      ms.push(t);
      bytes.push(buf.byteLength);
      if (String.fromCharCode(dv.getUint8(0), dv.getUint8(1), dv.getUint8(2), dv.getUint8(3)) === 'FFDD') changed.push(dv.getUint32(16, true));
    }
  }
  await srv.post('drag_end', {});
  return { ...stats(ms), bytes: stats(bytes).median, changed: changed.length ? stats(changed).median : undefined };
}

const httpRows = [], pageRows = [];
let browser = null;
const tStart = performance.now();
try {
  if (browserOn) {
    const require = createRequire(path.join(REPO, 'web', 'package.json'));
    const { chromium } = require('playwright-core');
    browser = await chromium.launch({
      executablePath: EXE, headless: true,
      args: ['--no-sandbox', '--use-gl=angle', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist'],
    });
  }
  for (const mesh of meshes) {
    const srv = await startServer(mesh);
    try {
      let st = await (await fetch(`${srv.base}/api/state`)).json();
      const V = st.mesh.vertices, name = `${path.basename(mesh)} (${V.toLocaleString('en-US')} v)`;
      const diag = Math.hypot(...st.mesh.max.map((x, i) => x - st.mesh.min[i]));
      const d = 0.05 * diag;
      const wave = (i) => [d * Math.sin(i / 7), 0.5 * d * (1 - Math.cos(i / 7)), 0];
      console.error(`${name}, ${st.mesh.faces} faces; ${STEPS} steps per case`);

      // B-spline lattices n×n×n, the top middle control point ((n-1)/2, n-1, (n-1)/2)
      const lattice = (n) => ({ method: 'lattice', resolution: [n, n, n], basis: 'bspline', margin: 0.05 });
      const topOf = (n) => { const m = (n - 1) / 2; return (m * n + n - 1) * n + m; };
      for (const n of [5, 9]) {
        st = await srv.post('create', lattice(n));
        for (const delta of [false, true]) {
          const r = await httpDrag(srv, { points: [topOf(n)], mode: 'translate' }, (i) => ({ delta: wave(i) }), delta);
          httpRows.push([name, `lattice ${n}×${n}×${n}, control point, ${delta ? 'delta' : 'full'} frames`, r]);
        }
      }
      st = await srv.post('create', lattice(5));
      // direct manipulation of the top vertex, two pins held
      const f = new Float32Array(await (await fetch(`${srv.base}/api/frame`)).arrayBuffer(), 20, 3 * V);
      let vTop = 0, vLo = 0, vHi = 0;
      for (let v = 0; v < V; v++) {
        if (f[3 * v + 1] > f[3 * vTop + 1]) vTop = v;
        if (f[3 * v] < f[3 * vLo]) vLo = v;
        if (f[3 * v] > f[3 * vHi]) vHi = v;
      }
      await srv.post('pin', { vertex: vLo });
      await srv.post('pin', { vertex: vHi });
      const p0 = [f[3 * vTop], f[3 * vTop + 1], f[3 * vTop + 2]];
      httpRows.push([name, 'lattice 5×5×5, mesh vertex (2 pins), delta frames',
        await httpDrag(srv, { vertex: vTop }, (i) => ({ target: p0.map((x, k) => x + wave(i)[k]) }), true)]);
      await srv.post('unpin', { all: true });
      if (V <= 200000) {
        st = await srv.post('create', { method: 'tspline', resolution: [12, 12, 12], padding: 0 });
        const cf = new Float32Array(await (await fetch(`${srv.base}/api/frame`)).arrayBuffer(), 20 + 12 * V, 3 * st.controls.count);
        let pTop = st.controls.proxy.points[0];
        for (const id of st.controls.proxy.points) if (cf[3 * id + 1] > cf[3 * pTop + 1]) pTop = id;
        httpRows.push([name, `T-spline 12×12×12 (${st.controls.count} points), proxy point, ARAP, delta frames`,
          await httpDrag(srv, { points: [pTop], mode: 'translate' }, (i) => ({ delta: wave(i) }), true)]);
      }
      const N = 9, top = topOf(N);
      await srv.post('create', lattice(N));

      if (browser) {
        const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
        page.on('pageerror', (e) => console.error('page error:', e));
        await page.goto(`${srv.base}/`);
        await page.waitForSelector('body[data-ready="1"]', { timeout: 300000 });
        await page.waitForFunction(() => window.ffdEditor.state.method === 'lattice' && window.ffdEditor.lastFrameRevision === window.ffdEditor.state.revision, null, { timeout: 300000 });
        await page.evaluate((id) => window.ffdEditor.select([id]), top);
        await page.waitForTimeout(500);
        for (const delta of [false, true]) {
          for (const render of [true, false]) {
            const r = await page.evaluate(async ({ n, on, delta: dl }) => {
              const ed = window.ffdEditor;
              ed.api.deltaFrames = dl;
              ed.setRenderEnabled(on);
              const vp = ed.editor.vp;
              vp.timing = true;
              performance.clearMeasures();
              const renderMs = [];
              let t0 = 0;
              const before = () => { t0 = performance.now(); };
              const after = () => { renderMs.push(performance.now() - t0); };
              vp.onBeforeRender.unshift(before);
              vp.onAfterRender = [...(vp.onAfterRender || []), after];
              const out = await ed.benchDrag(n);
              vp.onBeforeRender.splice(vp.onBeforeRender.indexOf(before), 1);
              vp.onAfterRender.splice(vp.onAfterRender.indexOf(after), 1);
              vp.timing = false;
              const measures = performance.getEntriesByType('measure');
              const apply = measures.filter((m) => m.name === `ffd:frame-apply:${dl ? 'delta' : 'full'}`).map((m) => m.duration);
              const other = measures.filter((m) => m.name.startsWith('ffd:frame-apply:') && m.name !== `ffd:frame-apply:${dl ? 'delta' : 'full'}`).map((m) => m.duration);
              performance.clearMeasures();
              ed.api.deltaFrames = true;
              ed.setRenderEnabled(true);
              return { ...out, apply, other, renderMs };
            }, { n: STEPS, on: render, delta });
            const s = stats(r.requestMs.slice(3));
            const a = stats(r.apply.slice(3));
            if (r.other.length) console.error(`  ${name}, ${delta ? 'delta' : 'full'} frames: ${r.other.length} frame(s) of the other kind applied (${r.other.map((x) => x.toFixed(1)).join(', ')} ms)`);
            const dr = stats(r.renderMs);
            pageRows.push([name, `lattice ${N}×${N}×${N}, ${delta ? 'delta' : 'full'} frames, drawing ${render ? 'on (SwiftShader)' : 'off'}`,
              { median: s.median, ups: r.updatesPerSecond, apply: a.median, applyMax: a.max, render: render ? dr.median : undefined, drawn: render ? r.drawnPerSecond : undefined }]);
          }
        }
        await page.close();
      }
    } finally {
      srv.stop();
    }
  }

  const cpu = os.cpus()[0];
  console.log(`\nEditor drag steps, ${STEPS} steps per case; ${os.cpus().length} × ${cpu ? cpu.model.trim() : '?'}; `
    + `OMP_NUM_THREADS=${process.env.OMP_NUM_THREADS || '(unset)'}; load average ${os.loadavg().map((x) => x.toFixed(1)).join(' ')}; `
    + `${((performance.now() - tStart) / 1000).toFixed(0)} s in all.\n`);
  console.log('| mesh | drag over HTTP | step median (ms) | step p90 (ms) | updates/s | reply (KB) | changed vertices |');
  console.log('|---|---|---:|---:|---:|---:|---:|');
  for (const [m, what, r] of httpRows) {
    console.log(`| ${m} | ${what} | ${fmt(r.median)} | ${fmt(r.p90)} | ${fmt(r.ups)} | ${fmt(r.bytes / 1024, 0)} | ${r.changed === undefined ? '— (full frames)' : r.changed.toLocaleString('en-US')} |`);
  }
  if (pageRows.length) {
    console.log('\n| mesh | page: control point | step median (ms) | updates/s | frame apply median (ms) | frame apply max (ms) | draw median (ms) | frames drawn/s |');
    console.log('|---|---|---:|---:|---:|---:|---:|---:|');
    for (const [m, what, r] of pageRows) {
      console.log(`| ${m} | ${what} | ${fmt(r.median)} | ${fmt(r.ups)} | ${fmt(r.apply, 2)} | ${fmt(r.applyMax, 2)} | ${fmt(r.render)} | ${fmt(r.drawn)} |`);
    }
  }
  console.log('\nHTTP: sequential requests from Node\'s fetch, each awaiting its reply. page: window.ffdEditor.benchDrag, the gizmo\'s path'
    + ' (one request in flight, the latest step wins; a new step every 4 ms, so one is always queued); "step" is the request\'s round trip;'
    + ' "frame apply" is the page\'s main-thread work on a frame (full: copy the positions and recompute every normal, or hand them to the'
    + ' normals worker from 150,000 triangles on, whose answers are applied apart; delta: write the changed positions and the normals the'
    + ' server sent); "draw" is renderer.render (uploading the changed buffer ranges, SwiftShader drawing),'
    + ' in headless Chromium, which shares the CPU with the server.');
} finally {
  if (browser) await browser.close().catch(() => {});
  if (tmp) rmSync(tmp, { recursive: true, force: true });
}
