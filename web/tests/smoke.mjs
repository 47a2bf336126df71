#!/usr/bin/env node
// Drives the page in headless Chromium against a running server (the real
// `ffd serve` or `node dev-mock.mjs`): creates deformers, drags control points
// and mesh points, pins, undoes, and takes screenshots. It expects a fresh
// session (bunny.obj for the real server); the checked end-to-end test against
// the library is e2e.mjs. The over-constrained direct-manipulation case pins 8
// vertices of a 2x2x2 Bernstein lattice (trilinear: 8 unknowns per axis) and
// drags a 9th, so that the residuals are really nonzero.
//
//   node tests/smoke.mjs [URL] [--out DIR] [--chromium PATH] [--only lattice|pbffd|gffd|tspline]
//
// Exits non-zero on a console error or a failed check.

import { chromium } from 'playwright-core';
import { mkdir } from 'node:fs/promises';
import { existsSync } from 'node:fs';

const argv = process.argv.slice(2);
const opt = (name, dflt) => { const i = argv.indexOf(`--${name}`); return i >= 0 ? argv[i + 1] : dflt; };
const URL_ = argv.find((a) => a.startsWith('http')) || 'http://127.0.0.1:8090/';
const OUT = opt('out', '/tmp/ffd-web');
const exe = opt('chromium', ['/usr/bin/chromium', '/usr/bin/chromium-browser', '/usr/bin/google-chrome'].find(existsSync));
const only = opt('only', '');

await mkdir(OUT, { recursive: true });
const browser = await chromium.launch({
  executablePath: exe, headless: true,
  args: ['--no-sandbox', '--use-gl=angle', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist'],
});
const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
const errors = [];
page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
page.on('pageerror', (e) => errors.push(String(e)));
let failures = 0;
const check = (ok, what) => { console.log(`${ok ? 'ok  ' : 'FAIL'} ${what}`); if (!ok) failures++; };
const shot = async (name, wait = 150) => { await page.waitForTimeout(wait); await page.screenshot({ path: `${OUT}/${name}.png` }); console.log(`     screenshot ${OUT}/${name}.png`); };
const ed = (fn, arg) => page.evaluate(fn, arg);
const settle = async () => {
  await page.waitForFunction(() => !window.ffdEditor.dragging);
  await page.waitForFunction(() => window.ffdEditor.state && window.ffdEditor.lastFrameRevision === window.ffdEditor.state.revision, null, { timeout: 10000 }).catch(() => {});
  await page.waitForTimeout(100);
};
async function drag(from, to, steps = 12, mods = []) {
  for (const m of mods) await page.keyboard.down(m);
  await page.mouse.move(from.x, from.y);
  await page.mouse.down();
  for (let i = 1; i <= steps; i++) {
    await page.mouse.move(from.x + (to.x - from.x) * i / steps, from.y + (to.y - from.y) * i / steps);
    await page.waitForTimeout(16);
  }
  await page.mouse.up();
  for (const m of mods) await page.keyboard.up(m);
  await settle();
}
async function create(method, fill = {}, busyShot = '', selects = {}) {
  await page.selectOption('select[name=method]', method);
  for (const [k, v] of Object.entries(fill)) await page.fill(`[name="${k}"]`, String(v)).then(() => page.dispatchEvent(`[name="${k}"]`, 'change'));
  for (const [k, v] of Object.entries(selects)) await page.selectOption(`select[name="${k}"]`, v);
  await page.click('#panel button.primary');
  if (busyShot) {
    // the overlay appears after 400 ms: the mock's delay shows it, the real
    // server may finish first (then there is nothing to check)
    const shown = await page.waitForSelector('#busy:not([hidden])', { timeout: 3000 }).then(() => true, () => false);
    const done = await page.evaluate((m) => window.ffdEditor.state && window.ffdEditor.state.method === m, method);
    if (shown || !done) check(shown, 'busy overlay shown');
    else console.log(`     busy overlay not shown: ${method} was created before its 400 ms delay`);
    await shot(busyShot, 0);
  }
  await page.waitForFunction((m) => window.ffdEditor.state && window.ffdEditor.state.method === m, method, { timeout: 15000 });
  await settle();
}

await page.goto(URL_);
await page.waitForSelector('body[data-ready="1"]', { timeout: 20000 });
check(true, 'page ready');
await shot('01-start');

if (!only || only === 'lattice') {
  // a small Bernstein lattice: few degrees of freedom, so that the
  // over-constrained direct-manipulation case below is really unreachable
  await create('lattice', { 'res-lattice-0': 3, 'res-lattice-1': 3, 'res-lattice-2': 3 }, '', { basis: 'bernstein' });
  const st = await ed(() => window.ffdEditor.state);
  check(st.controls.count === 27 && st.controls.basis === 'bernstein', `lattice 3x3x3 ${st.controls.basis} has ${st.controls.count} controls`);
  await shot('02-lattice');

  // drag the top-middle control point by its sprite
  const top = (2 * 3 + 1) * 3 + 1; // i=0? pick the (1,2,1) point: index (i*m+j)*n+k
  const id = (1 * 3 + 2) * 3 + 1;
  void top;
  const p = await ed((i) => window.ffdEditor.screenOfControl(i), id);
  const rev0 = await ed(() => window.ffdEditor.state.revision);
  await drag(p, { x: p.x + 60, y: p.y - 70 });
  const sel = await ed(() => window.ffdEditor.selection);
  check(sel.length === 1 && sel[0] === id, `picked control ${id} (selection ${JSON.stringify(sel)})`);
  const st2 = await ed(() => window.ffdEditor.state);
  check(st2.revision > rev0 && st2.undo >= 2, `drag made an undo entry (rev ${rev0} -> ${st2.revision}, undo ${st2.undo})`);
  await shot('03-lattice-dragged');

  // gizmo: drag along the X arrow of the gizmo (the pivot is at the selected point)
  const c = await ed(() => window.ffdEditor.gizmoCenter());
  const before = await ed((i) => window.ffdEditor.screenOfControl(i), id);
  // the X arrow lies to the right of the centre in this view: grab a point on it
  await drag({ x: c.x + 45, y: c.y + 2 }, { x: c.x + 110, y: c.y + 2 });
  const after = await ed((i) => window.ffdEditor.screenOfControl(i), id);
  check(Math.hypot(after.x - before.x, after.y - before.y) > 5, `gizmo moved the control (${before.x.toFixed(0)},${before.y.toFixed(0)}) -> (${after.x.toFixed(0)},${after.y.toFixed(0)})`);

  // box select everything with shift-drag on empty space
  await drag({ x: 20, y: 60 }, { x: 940, y: 760 }, 6, ['Shift']);
  const nsel = (await ed(() => window.ffdEditor.selection)).length;
  check(nsel > 20, `box select picked ${nsel} controls`);

  // influence map of a single control
  await ed(() => window.ffdEditor.select([13]));
  await page.keyboard.press('i');
  await page.waitForTimeout(400);
  await shot('04-influence');
  await page.keyboard.press('i');

  // undo / redo
  const u = await ed(() => window.ffdEditor.state.undo);
  await page.keyboard.press('Control+z');
  await settle();
  check((await ed(() => window.ffdEditor.state.undo)) === u - 1, 'undo');
  await page.keyboard.press('Control+Shift+z');
  await settle();
  check((await ed(() => window.ffdEditor.state.undo)) === u, 'redo');

  // direct manipulation: pin two vertices, drag a third
  await page.keyboard.press('Escape');
  await page.keyboard.press('m');
  const V = (await ed(() => window.ffdEditor.state.mesh.vertices));
  const vis = async (v) => ed((x) => window.ffdEditor.screenOfVertex(x), v);
  // find front-facing vertices near the image centre via the page
  const probe = await page.evaluate(() => {
    const e = window.ffdEditor.editor;
    const r = e.vp.renderer.domElement.getBoundingClientRect();
    const pick = (fx, fy) => {
      for (let d = 0; d < 0.2; d += 0.01) for (const s of [1, -1]) {
        const h = e.vp.pickMesh({ clientX: r.left + r.width * (fx + s * d), clientY: r.top + r.height * fy });
        if (h) return h.vertex;
      }
      return -1;
    };
    return { a: pick(0.5, 0.45), b: pick(0.42, 0.75), c: pick(0.58, 0.75) };
  });
  check(probe.a >= 0 && probe.b >= 0 && probe.c >= 0, `mesh picks ${JSON.stringify(probe)} of ${V}`);
  for (const v of [probe.b, probe.c]) {
    const s = await vis(v);
    await page.keyboard.down('Alt');
    await page.mouse.click(s.x, s.y);
    await page.keyboard.up('Alt');
    await settle();
  }
  check((await ed(() => window.ffdEditor.state.pins.length)) === 2, 'two pins');
  const sa = await vis(probe.a);
  await drag(sa, { x: sa.x + 120, y: sa.y - 90 }, 20);
  const pa = await vis(probe.a);
  check(Math.hypot(pa.x - sa.x, pa.y - sa.y) > 20, `dragged vertex moved on screen by ${Math.hypot(pa.x - sa.x, pa.y - sa.y).toFixed(0)} px`);
  await shot('05-direct-manipulation');
  // over-constrained: the real solve (minimum norm, Hsu et al.) meets any few
  // pins exactly, even two adjacent vertices pulled apart. A 2x2x2 Bernstein
  // lattice (trilinear: 8 unknowns per axis) is fully fixed by 8 pins in
  // general position, so a 9th dragged point cannot be met: residuals.
  await page.keyboard.press('Control+z');
  await settle();
  await page.click('text=Unpin all');
  await settle();
  await page.keyboard.press('c');
  await create('lattice', { 'res-lattice-0': 2, 'res-lattice-1': 2, 'res-lattice-2': 2 }, '', { basis: 'bernstein' });
  await page.keyboard.press('m');
  const spread = await page.evaluate(() => {
    const e = window.ffdEditor.editor;
    const r = e.vp.renderer.domElement.getBoundingClientRect();
    const picks = [];
    for (let fy = 0.15; fy <= 0.85; fy += 0.035) for (let fx = 0.15; fx <= 0.85; fx += 0.035) {
      const h = e.vp.pickMesh({ clientX: r.left + r.width * fx, clientY: r.top + r.height * fy });
      if (!h) continue;
      const s = window.ffdEditor.screenOfVertex(h.vertex);
      const h2 = e.vp.pickMesh({ clientX: s.x, clientY: s.y });
      if (h2 && h2.vertex === h.vertex) picks.push({ v: h.vertex, x: s.x, y: s.y });
    }
    // farthest-point sampling on screen: 9 well-spread vertices
    const cx = picks.reduce((a, p) => a + p.x, 0) / picks.length, cy = picks.reduce((a, p) => a + p.y, 0) / picks.length;
    picks.sort((p, q) => Math.hypot(p.x - cx, p.y - cy) - Math.hypot(q.x - cx, q.y - cy));
    const out = picks.length ? [picks[0]] : [];
    while (out.length < 9 && out.length < picks.length) {
      let best = null, bd = -1;
      for (const p of picks) {
        const d = Math.min(...out.map((o) => Math.hypot(o.x - p.x, o.y - p.y)));
        if (d > bd) { bd = d; best = p; }
      }
      if (bd < 20) break;
      out.push(best);
    }
    return out;
  });
  check(spread.length === 9, `9 spread vertices to pin and drag (${spread.length})`);
  if (spread.length === 9) {
    for (const p of spread.slice(1)) {
      await page.keyboard.down('Alt');
      await page.mouse.click(p.x, p.y);
      await page.keyboard.up('Alt');
      await settle();
    }
    check((await ed(() => window.ffdEditor.state.pins.length)) === 8, '8 pins');
    const d = spread[0];
    await drag({ x: d.x, y: d.y }, { x: d.x + 90, y: d.y - 70 }, 16);
  }
  const res = await ed(() => window.ffdEditor.editor.dm.residuals || []);
  const pins = await ed(() => window.ffdEditor.state.pins);
  // the state's pin residuals; the real server's frame also carries them (the pins, then the dragged point)
  check(pins.some((p) => p.residual > 1e-3) && (res.length === 0 || (res.length === 9 && Math.max(...res) > 1e-3)),
    `over-constrained residuals > 1e-3: frame ${res.map((r) => r.toExponential(1)).join(', ')}; state pins max ${Math.max(...pins.map((p) => +p.residual)).toExponential(2)}`);
  const labels = await page.locator('.pin-label').count();
  check(labels > 0, `${labels} residual labels shown`);
  await shot('06-residuals');
  await page.click('text=Unpin all');
  await settle();
  await page.keyboard.press('c');
}

if (!only || only === 'pbffd') {
  await create('pbffd', { 'pbffd-interior': 40, 'pbffd-exterior': 40, 'pbffd-levels': 2 }, '07a-busy');
  const st = await ed(() => window.ffdEditor.state);
  check(st.controls.ebfs.length === st.controls.count, `pbffd: ${st.controls.count} EBFs`);
  await ed(() => window.ffdEditor.select([0, 1]));
  await shot('07-pbffd');
  // draw a curve
  await page.click('text=Draw curve');
  const r = await page.evaluate(() => { const c = window.ffdEditor.editor.vp.renderer.domElement.getBoundingClientRect(); return { x: c.left, y: c.top, w: c.width, h: c.height }; });
  for (const [fx, fy] of [[0.45, 0.3], [0.5, 0.45], [0.55, 0.6]]) { await page.mouse.click(r.x + r.w * fx, r.y + r.h * fy); await page.waitForTimeout(50); }
  await page.keyboard.press('Enter');
  await settle();
  const st2 = await ed(() => window.ffdEditor.state);
  check(st2.controls.curves.length === 1, 'pbffd: curve created');
  await shot('08-pbffd-curve');
}

if (!only || only === 'gffd') {
  await create('gffd');
  await ed(() => window.ffdEditor.select([4]));
  // the gizmo's modes from the tool bar (with a selection and the pointer over the view, R and G start Blender's modal transforms)
  await page.click('[data-mode=rotate]');
  await shot('09-gffd');
  const p = await ed(() => window.ffdEditor.screenOfControl(4));
  await page.click('[data-mode=translate]');
  await drag(p, { x: p.x + 80, y: p.y + 20 });
  await shot('10-gffd-bent');
}

if (!only || only === 'tspline') {
  await create('tspline', { 'res-tspline-0': 4, 'res-tspline-1': 4, 'res-tspline-2': 4 });
  await ed(() => window.ffdEditor.select([0, 1, 4, 5]));
  await page.click('#panel button:text-is("Cell")');
  await settle();
  check((await ed(() => window.ffdEditor.state.controls.refinements)) === 1, 'tspline: refine');
  await page.click('text=❄ Freeze');
  await settle();
  await shot('11-tspline');
  await page.check('[name=full-lattice]');
  await shot('12-tspline-lattice');
  await page.uncheck('[name=full-lattice]');
}

// help overlay, error toast
await page.keyboard.press('h');
await shot('13-help');
await page.keyboard.press('Escape');
await page.evaluate(() => window.ffdEditor.editor.run('level', { level: 3 }));
await page.waitForSelector('.toast');
await shot('14-error-toast');
errors.splice(0, errors.length, ...errors.filter((e) => !/status of 409|status of 400/.test(e)));

check(errors.length === 0, `no console errors${errors.length ? `: ${errors.join(' | ')}` : ''}`);
await browser.close();
process.exit(failures ? 1 : 0);
