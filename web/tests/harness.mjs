// The end-to-end tests' shared harness: the real `ffd serve` in a temporary
// root, the page in headless Chromium (playwright-core), checks, and the page
// helpers (real mouse drags, picking, settling, replaying the rig with
// `ffd deform`). web/tests/e2e.mjs (the methods) and web/tests/e2e_artist.mjs
// (the artist's workflows, web/tests/artist/*.mjs) run on it.

import { chromium } from 'playwright-core';
import { spawn, execFile } from 'node:child_process';
import { mkdir, mkdtemp, copyFile, writeFile, readFile, rm } from 'node:fs/promises';
import { existsSync } from 'node:fs';
import { tmpdir } from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

export const T_START = Date.now();
export const REPO = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..', '..');
export const argv = process.argv.slice(2);
export const opt = (name, dflt) => { const i = argv.indexOf(`--${name}`); return i >= 0 ? argv[i + 1] : dflt; };
export const FFD = path.resolve(opt('ffd', path.join(REPO, 'build', 'ffd')));
export const OUT = path.resolve(opt('out', path.join(tmpdir(), 'ffd-e2e')));
export const EXE = opt('chromium', ['/usr/bin/chromium', '/usr/bin/chromium-browser', '/usr/bin/google-chrome'].find(existsSync));
export const METHODS = opt('methods', 'lattice,tspline,pbffd,gffd,cage,kelvinlet').split(',');
export const KEEP = argv.includes('--keep');
export const WEB = path.join(REPO, 'web', 'dist');
export const LIMIT_S = Number(opt('limit', 170));

export let failures = 0;
export const elapsed = () => ((Date.now() - T_START) / 1000).toFixed(1);
export const check = (ok, what) => { console.log(`${ok ? 'ok  ' : 'FAIL'} ${what}`); if (!ok) failures++; return ok; };
export const note = (msg) => console.log(`     ${msg}`);
export class Fatal extends Error {}
export const must = (ok, what) => { if (!check(ok, what)) throw new Fatal(what); };

// --- server --------------------------------------------------------------------

export let server = null;
let serverErr = '';
export let BASE = '';

export function startServer(mesh, root) {
  return new Promise((resolve, reject) => {
    const p = spawn(FFD, ['serve', mesh, '--port', '0', '--root', root, '--web', WEB], { stdio: ['ignore', 'pipe', 'pipe'] });
    server = p;
    let out = '';
    const timer = setTimeout(() => reject(new Error(`ffd serve printed no URL in 20 s: ${out} ${serverErr}`)), 20000);
    p.stderr.on('data', (d) => { serverErr += d; });
    p.stdout.on('data', (d) => {
      out += d;
      const nl = out.indexOf('\n');
      if (nl >= 0 && !BASE) {
        const m = out.slice(0, nl).match(/^ffd serve: (http:\/\/\S+?)\/?$/);
        clearTimeout(timer);
        if (!m) { reject(new Error(`unexpected first line: ${out.slice(0, nl)}`)); return; }
        BASE = m[1];
        resolve(BASE);
      }
    });
    p.on('exit', (code, sig) => { clearTimeout(timer); if (!BASE) reject(new Error(`ffd serve exited (${code ?? sig}): ${serverErr}`)); });
    p.on('error', (e) => { clearTimeout(timer); reject(e); });
  });
}

export async function api(method, p, body) {
  const init = { method };
  if (body !== undefined) { init.body = JSON.stringify(body); init.headers = { 'Content-Type': 'application/json' }; }
  const res = await fetch(BASE + p, init);
  const ct = res.headers.get('Content-Type') || '';
  const data = ct.includes('json') ? await res.json() : Buffer.from(await res.arrayBuffer());
  if (!res.ok) throw new Error(`${method} ${p}: HTTP ${res.status} ${JSON.stringify(data)}`);
  return data;
}
export const state = () => api('GET', '/api/state');

/** GET /api/frame, parsed (docs/editor.md: FFDF, rev, V, C, R, float32 data). */
export async function frame() {
  const buf = await api('GET', '/api/frame');
  if (buf.toString('latin1', 0, 4) !== 'FFDF') throw new Error('not a frame');
  const revision = buf.readUInt32LE(4), V = buf.readUInt32LE(8), C = buf.readUInt32LE(12), R = buf.readUInt32LE(16);
  if (buf.length !== 20 + 4 * (3 * V + 3 * C + R)) throw new Error(`frame of ${buf.length} bytes for V ${V} C ${C} R ${R}`);
  const f = new Float32Array(buf.buffer.slice(buf.byteOffset + 20, buf.byteOffset + buf.length));
  return { revision, V, C, R, positions: f.subarray(0, 3 * V), controls: f.subarray(3 * V, 3 * V + 3 * C), residuals: f.subarray(3 * V + 3 * C) };
}

export const maxAbsDiff = (a, b) => {
  if (a.length !== b.length) return Infinity;
  let m = 0;
  for (let i = 0; i < a.length; i++) { const d = Math.abs(a[i] - b[i]); if (!(d <= m)) m = d; }
  return m;
};
export const pointDist = (a, i, b, j = i) => Math.hypot(a[3 * i] - b[3 * j], a[3 * i + 1] - b[3 * j + 1], a[3 * i + 2] - b[3 * j + 2]);
export const maxDisplacement = (a, b) => { let m = 0; for (let i = 0; i < a.length / 3; i++) m = Math.max(m, pointDist(a, i, b)); return m; };

export function run(cmd, args) {
  return new Promise((resolve, reject) => {
    execFile(cmd, args, { maxBuffer: 64 << 20 }, (err, stdout, stderr) => {
      if (err) reject(new Error(`${cmd} ${args.join(' ')}: ${err.message} ${stderr}`)); else resolve(stdout);
    });
  });
}

export async function readObjVertices(file) {
  const text = await readFile(file, 'utf8');
  const v = [];
  for (const line of text.split('\n')) {
    if (line.startsWith('v ')) { const p = line.trim().split(/\s+/); v.push(+p[1], +p[2], +p[3]); }
  }
  return Float64Array.from(v);
}

let replays = 0;
/**
 * Replays a rig with `ffd deform` on the mesh TMP/meshName and compares the
 * result with the server's current frame. rigFile: a rig already under TMP,
 * else GET /api/rig is written first.
 */
export async function replay(meshName, tol, what, rigFile = null) {
  const n = ++replays;
  if (!rigFile) {
    const rig = await api('GET', '/api/rig');
    rigFile = path.join(TMP, `rig-${n}.json`);
    await writeFile(rigFile, JSON.stringify(rig, null, 1));
  }
  const out = path.join(TMP, `replay-${n}.obj`);
  const f = await frame();
  await run(FFD, ['deform', path.join(TMP, meshName), '-o', out, '--rig', rigFile]);
  const v = await readObjVertices(out);
  const d = maxAbsDiff(v, f.positions);
  check(d < tol, `${what}: ffd deform --rig ${path.basename(rigFile)} replays the frame (max |diff| ${d.toExponential(2)} < ${tol.toExponential(1)})`);
  return d;
}

// --- browser -------------------------------------------------------------------

export let browser = null;
export let page = null;
export const consoleErrors = [];
let expectHttpErrors = false;
/** While on, HTTP 4xx console errors of the page are expected (an error path under test). */
export function expectHttp(on) { expectHttpErrors = on; }

export const ed = (fn, arg) => page.evaluate(fn, arg);
export const shot = async (name, wait = 200) => {
  await page.waitForTimeout(wait);
  const file = path.join(OUT, `${name}.png`);
  await page.screenshot({ path: file });
  note(`screenshot ${file}`);
};
/** Waits for the page to be idle: no drag, no request in flight, the state's revision drawn,
 * and still so 150 ms later (a click's request may be answered after the first look). */
export const idle = () => {
  const e = window.ffdEditor;
  return !e.dragging && e.pendingRequests === 0 && !!e.state && e.lastFrameRevision === e.state.revision;
};
export const settle = async () => {
  const deadline = Date.now() + 60000;
  for (;;) {
    const left = deadline - Date.now();
    if (left <= 0) throw new Error(`settle: page not idle after 60 s (${JSON.stringify(await ed(() => ({
      dragging: window.ffdEditor.dragging, pending: window.ffdEditor.pendingRequests,
      revision: window.ffdEditor.state && window.ffdEditor.state.revision, drawn: window.ffdEditor.lastFrameRevision })))})`);
    await page.waitForFunction(idle, null, { timeout: left });
    const rev = (await state()).revision;
    await page.waitForTimeout(150);
    if (await ed(idle) && (await state()).revision === rev
      && await ed((r) => window.ffdEditor.state.revision === r, rev)) return;
  }
};
/** A real mouse drag in small steps. */
export async function mouseDrag(from, to, steps = 12, mods = []) {
  for (const m of mods) await page.keyboard.down(m);
  await page.mouse.move(from.x, from.y);
  await page.mouse.down();
  for (let i = 1; i <= steps; i++) {
    await page.mouse.move(from.x + (to.x - from.x) * i / steps, from.y + (to.y - from.y) * i / steps);
    await page.waitForTimeout(20);
  }
  await page.mouse.up();
  for (const m of mods) await page.keyboard.up(m);
  await settle();
}
export async function click(p, mods = []) {
  for (const m of mods) await page.keyboard.down(m);
  await page.mouse.click(p.x, p.y);
  for (const m of mods) await page.keyboard.up(m);
}

/** Creates a deformer through the panel: method, form fields, the Create button. */
export async function createViaPanel(method, fill = {}) {
  await page.selectOption('select[name=method]', method);
  for (const [k, v] of Object.entries(fill)) {
    await page.fill(`[name="${k}"]`, String(v));
    await page.dispatchEvent(`[name="${k}"]`, 'change');
  }
  const rev = (await state()).revision;
  await ed(() => document.querySelectorAll('#toasts .toast').forEach((t) => t.remove()));
  await page.click('#panel button.primary');
  // the new deformer, or the server's refusal as an error toast
  await page.waitForFunction(([m, r]) => (window.ffdEditor.state && window.ffdEditor.state.method === m && window.ffdEditor.state.revision > r)
    || document.querySelector('#toasts .toast.error'), [method, rev], { timeout: 60000 });
  const err = await ed(() => { const t = document.querySelector('#toasts .toast.error .msg'); return t ? t.textContent : null; });
  if (err) {
    check(false, `create ${method} via the panel: the server refused: ${err}`);
    throw new Fatal(err);
  }
  await settle();
  return state();
}

/** Control ids (of the given candidates) whose on-screen spot picks exactly that control. */
export async function pickableControls(ids) {
  return ed((cands) => {
    const e = window.ffdEditor.editor;
    const r = e.vp.renderer.domElement.getBoundingClientRect();
    const out = [];
    for (const id of cands) {
      if (!e.controlsView.isVisible(id)) continue;
      const s = window.ffdEditor.screenOfControl(id);
      if (s.x < r.left + 30 || s.x > r.right - 30 || s.y < r.top + 30 || s.y > r.bottom - 30) continue;
      if (e.selector.pick({ clientX: s.x, clientY: s.y }) !== id) continue;
      // keep clear of the other points: 12 px
      let near = false;
      for (const o of e.controlsView.visibleIds) {
        if (o === id) continue;
        const t = window.ffdEditor.screenOfControl(o);
        if (Math.hypot(t.x - s.x, t.y - s.y) < 12) { near = true; break; }
      }
      if (!near) out.push({ id, x: s.x, y: s.y });
    }
    return out;
  }, ids);
}

/**
 * Mesh vertices on the visible side: a grid of screen points is ray-picked,
 * and a vertex counts when a pick at its own screen position returns it.
 */
export async function visibleVertices() {
  return ed(() => {
    const e = window.ffdEditor.editor;
    const r = e.vp.renderer.domElement.getBoundingClientRect();
    const out = [];
    const seen = new Set();
    for (let fy = 0.2; fy <= 0.8; fy += 0.05) {
      for (let fx = 0.25; fx <= 0.75; fx += 0.05) {
        const h = e.vp.pickMesh({ clientX: r.left + r.width * fx, clientY: r.top + r.height * fy });
        if (!h || seen.has(h.vertex)) continue;
        seen.add(h.vertex);
        const s = window.ffdEditor.screenOfVertex(h.vertex);
        if (s.x < r.left + 40 || s.x > r.right - 40 || s.y < r.top + 40 || s.y > r.bottom - 40) continue;
        const h2 = e.vp.pickMesh({ clientX: s.x, clientY: s.y });
        if (h2 && h2.vertex === h.vertex) out.push({ v: h.vertex, x: s.x, y: s.y });
      }
    }
    return out;
  });
}

/**
 * A point on the gizmo's translate arrow `axis` ('X'|'Y'|'Z'): walks outwards
 * from the pivot along the axis' screen direction and asks TransformControls
 * which handle is under each spot. Returns {from, dir} (dir: unit screen vector).
 */
export async function gizmoArrow(axis) {
  return ed((ax) => {
    const e = window.ffdEditor.editor;
    const g = e.gizmo;
    const c = window.ffdEditor.gizmoCenter();
    const w = g.pivot.position.clone();
    w.setComponent('XYZ'.indexOf(ax), w.getComponent('XYZ'.indexOf(ax)) + 0.05 * e.vp.diag);
    const s = e.screenOf(w);
    let dx = s.x - c.x, dy = s.y - c.y;
    const l = Math.hypot(dx, dy) || 1;
    dx /= l; dy /= l;
    const hits = [];
    for (let d = 6; d < 260; d += 2) {
      const p = { clientX: c.x + dx * d, clientY: c.y + dy * d, button: 0 };
      if (g.hitTest(p) && g.tc.axis === ax) hits.push(d);
    }
    g.tc.axis = null;
    if (!hits.length) return null;
    const d = hits[Math.floor(hits.length * 0.6)];
    return { from: { x: c.x + dx * d, y: c.y + dy * d }, dir: { x: dx, y: dy }, screenLen: l, hits: hits.length };
  }, axis);
}

// --- the test ------------------------------------------------------------------

export let TMP = '';

/** Runs a stage; a failure inside it is reported and the test goes on. */
export async function guarded(name, fn) {
  try { await fn(); } catch (e) {
    if (!(e instanceof Fatal)) check(false, `${name}: ${e.message.split('\n')[0]}`);
    await shot(`${name}-failed`).catch(() => {});
    await page.evaluate(() => window.ffdEditor.editor.cancelDrag()).catch(() => {});
  }
}


/**
 * Starts the test: a temporary root holding `files` (repository paths, copied
 * by their base name), `ffd serve` on the first of them, headless Chromium on
 * the page, ready. Returns the page.
 */
export async function launch(files) {
  await mkdir(OUT, { recursive: true });
  TMP = await mkdtemp(path.join(tmpdir(), 'ffd-e2e-'));
  for (const f of files) await copyFile(path.join(REPO, f), path.join(TMP, path.basename(f)));
  must(existsSync(FFD), `ffd binary ${FFD}`);
  must(existsSync(path.join(WEB, 'index.html')), `built page ${WEB} (cd web && npm run build)`);
  await startServer(path.join(TMP, path.basename(files[0])), TMP);
  check(true, `ffd serve listening at ${BASE}/`);

  browser = await chromium.launch({
    executablePath: EXE, headless: true,
    args: ['--no-sandbox', '--use-gl=angle', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist'],
  });
  page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
  page.on('console', (m) => {
    if (m.type() !== 'error') return;
    const t = m.text();
    if (expectHttpErrors && /status of 4\d\d/.test(t)) return;
    consoleErrors.push(t);
    console.log(`     console error: ${t}`);
  });
  page.on('pageerror', (e) => { consoleErrors.push(String(e)); console.log(`     page error: ${e}`); });
  page.on('dialog', (d) => d.dismiss());

  await page.goto(`${BASE}/`);
  await page.waitForSelector('body[data-ready="1"]', { timeout: 30000 });
  check(true, 'page ready (body[data-ready="1"])');
  return page;
}

let cleaned = false;
async function cleanup() {
  if (cleaned) return;
  cleaned = true;
  if (browser) await browser.close().catch(() => {});
  if (server && server.exitCode === null) {
    server.kill('SIGTERM');
    await new Promise((r) => { const t = setTimeout(() => { server.kill('SIGKILL'); r(); }, 3000); server.on('exit', () => { clearTimeout(t); r(); }); });
  }
  if (TMP && !KEEP) await rm(TMP, { recursive: true, force: true }).catch(() => {});
  else if (TMP) note(`kept ${TMP}`);
}

/** Runs `main` under the time limit, reports, cleans up and exits 1 on any failure or page error. */
export async function runTest(main, name = 'e2e') {
  const watchdog = setTimeout(() => {
    console.log(`FAIL time limit: ${LIMIT_S} s`);
    failures++;
    cleanup().finally(() => process.exit(1));
  }, LIMIT_S * 1000);
  try {
    await main();
  } catch (e) {
    if (!(e instanceof Fatal)) { failures++; console.log(`FAIL ${e.stack || e}`); }
    if (page) await shot('zz-failure').catch(() => {});
  } finally {
    if (page) check(consoleErrors.length === 0, `no console errors on the page${consoleErrors.length ? `: ${consoleErrors.join(' | ')}` : ''}`);
    await cleanup();
    clearTimeout(watchdog);
    if (/Sanitizer|runtime error/.test(serverErr)) check(false, `server stderr: ${serverErr}`);
    console.log(`${failures ? 'FAIL' : 'ok  '} ${name}: ${failures} failure(s) in ${elapsed()} s; screenshots in ${OUT}`);
  }
  process.exit(failures ? 1 : 0);
}

// --- stopping and restarting the server (the artist's panel stage: offline) ----

/** Stops `ffd serve` (SIGTERM) and waits until it has exited. */
export async function stopServer() {
  if (!server || server.exitCode !== null) return;
  const p = server;
  await new Promise((r) => { p.on('exit', r); p.kill('SIGTERM'); });
}

/** Starts `ffd serve` again on the same port and root, with TMP/meshName: a new session, the page's origin unchanged. */
export function startServerAgain(meshName = 'bunny.obj') {
  const port = new URL(BASE).port;
  return new Promise((resolve, reject) => {
    const p = spawn(FFD, ['serve', path.join(TMP, meshName), '--port', port, '--root', TMP, '--web', WEB], { stdio: ['ignore', 'pipe', 'pipe'] });
    server = p;
    let out = '';
    const timer = setTimeout(() => reject(new Error(`ffd serve (again) printed no URL in 20 s: ${out}`)), 20000);
    p.stderr.on('data', (d) => { serverErr += d; });
    p.stdout.on('data', (d) => {
      out += d;
      if (out.includes('\n')) { clearTimeout(timer); resolve(BASE); }
    });
    p.on('exit', (code, sig) => { clearTimeout(timer); reject(new Error(`ffd serve (again) exited (${code ?? sig}): ${serverErr.slice(-300)}`)); });
  });
}

/**
 * Kills the server (SIGKILL by default: no chance to write anything more)
 * and starts `ffd serve` again on the same root and port with TMP/meshName
 * (extra: more arguments). Resolves with what the new server printed on
 * stderr while starting (its resume line, for one).
 */
export async function restartServer(meshName = 'bunny.obj', { signal = 'SIGKILL', extra = [] } = {}) {
  const port = new URL(BASE).port;
  if (server && server.exitCode === null && server.signalCode === null) {
    const gone = new Promise((r) => server.once('exit', r));
    server.kill(signal);
    await gone;
  }
  const errStart = serverErr.length;
  await new Promise((resolve, reject) => {
    const p = spawn(FFD, ['serve', path.join(TMP, meshName), '--port', port, '--root', TMP, '--web', WEB, ...extra], { stdio: ['ignore', 'pipe', 'pipe'] });
    server = p;
    let out = '';
    const timer = setTimeout(() => reject(new Error(`ffd serve (restarted) printed no URL in 20 s: ${out} ${serverErr.slice(errStart)}`)), 20000);
    p.stderr.on('data', (d) => { serverErr += d; });
    p.stdout.on('data', (d) => {
      out += d;
      if (out.includes('\n')) { clearTimeout(timer); resolve(); }
    });
    p.on('exit', (code, sig) => { clearTimeout(timer); reject(new Error(`ffd serve (restarted) exited (${code ?? sig}): ${serverErr.slice(errStart)}`)); });
    p.on('error', (e) => { clearTimeout(timer); reject(e); });
  });
  await new Promise((r) => setTimeout(r, 150)); // stderr's lines may follow stdout's
  return serverErr.slice(errStart);
}
