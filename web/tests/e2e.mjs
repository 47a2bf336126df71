#!/usr/bin/env node
// End-to-end test of the editor: the real `ffd serve` and the page in headless
// Chromium (Debian's chromium driven by playwright-core). Drags happen through
// real mouse events; every result is checked against the library through the
// API and by replaying the session's rig with `ffd deform`.
//
//   node web/tests/e2e.mjs --ffd build/ffd --out DIR [--chromium PATH]
//                          [--methods lattice,tspline,pbffd,gffd,cage,kelvinlet] [--keep]
//
// Stages: (a) lattice: create via the panel, click-select a control, drag it
// with the gizmo's translate arrow; (b) mesh tool: pin two vertices (Alt+click)
// and drag a third; (c) Ctrl+Z / Ctrl+Shift+Z; (d) rig save + replay;
// (e) cow.off from the file list, T-spline: ARAP drag of a proxy point, refine
// by clicking the mesh, undo; (f) PB-FFD: drag an EBF; GFFD: drag a skeleton
// vertex; cage: drag a vertex of the "auto" cage; (g) help overlay, influence map, an error toast. Screenshots of each
// stage go to DIR. Prints "ok"/"FAIL" lines; exits 1 on a failed check or a
// console error of the page.

import { writeFile, readFile } from 'node:fs/promises';
import { existsSync } from 'node:fs';
import path from 'node:path';
import {
  REPO, TMP, FFD, METHODS, page, api, state, frame, check, must, note, Fatal, ed, shot, settle, mouseDrag, click,
  createViaPanel, pickableControls, visibleVertices, gizmoArrow, replay, maxAbsDiff, pointDist, maxDisplacement,
  guarded, expectHttp, launch, runTest, run, readObjVertices,
} from './harness.mjs';

// --- the test ------------------------------------------------------------------

async function main() {
  await launch(['examples/lattice/bunny.obj', 'examples/tspline/cow.off', 'examples/lattice/nested.json']);
  const st0 = await ed(() => window.ffdEditor.state);
  check(st0.mesh.name === 'bunny.obj' && st0.method === null, `page shows ${st0.mesh.name}, ${st0.mesh.vertices} vertices, no deformer`);
  const rest = (await frame()).positions.slice();
  const diag = Math.hypot(...st0.mesh.max.map((x, i) => x - st0.mesh.min[i]));
  await shot('01-start');

  if (METHODS.includes('lattice')) await latticeStages(rest, diag);
  if (METHODS.includes('lattice')) await guarded('lattice-cylinder', latticeVariantStage);
  if (METHODS.includes('tspline')) await tsplineStage();
  if (METHODS.includes('pbffd')) await guarded('pbffd', pbffdStage);
  if (METHODS.includes('gffd')) await guarded('gffd', gffdStage);
  if (METHODS.includes('cage')) await guarded('cage', cageStage);
  if (METHODS.includes('kelvinlet')) await guarded('kelvinlet', kelvinletStage);
  if (METHODS.includes('lattice')) await guarded('nested', nestedStage);
  await uiStage();
}


async function latticeStages(rest, diag) {
  // (a) lattice through the panel, click-select a control, drag the gizmo's arrow
  const st = await createViaPanel('lattice', { 'res-lattice-0': 5, 'res-lattice-1': 5, 'res-lattice-2': 5 });
  check(st.method === 'lattice' && st.controls.count === 125, `(a) lattice 5x5x5 created via the panel (${st.controls.count} controls)`);
  await shot('02-lattice');
  // an upper interior control (i, j=3, k) that the mouse can pick alone
  const cands = [];
  for (const i of [2, 1, 3]) for (const k of [2, 1, 3, 4, 0]) cands.push((i * 5 + 3) * 5 + k);
  const pickable = await pickableControls(cands);
  must(pickable.length > 0, `(a) a pickable control among ${cands.length} candidates (${pickable.length})`);
  const ctl = pickable[0];
  await click(ctl);
  await page.waitForTimeout(150);
  const sel = await ed(() => window.ffdEditor.selection);
  check(sel.length === 1 && sel[0] === ctl.id, `(a) clicking control ${ctl.id} selects it (selection ${JSON.stringify(sel)})`);
  await page.waitForTimeout(200); // the gizmo is drawn (its pickers placed) on the next frame
  const arrow = await gizmoArrow('X');
  must(!!arrow, '(a) the gizmo\'s X arrow found on screen');
  const f0 = await frame();
  const rev0 = (await state()).revision;
  await mouseDrag(arrow.from, { x: arrow.from.x + arrow.dir.x * 90, y: arrow.from.y + arrow.dir.y * 90 }, 15);
  const st1 = await state();
  const f1 = await frame();
  check(st1.revision > rev0 && st1.undo >= 2 && st1.drag === null, `(a) gizmo drag ended with an undo entry (rev ${rev0} -> ${st1.revision}, undo ${st1.undo})`);
  const cm = [0, 1, 2].map((k) => f1.controls[3 * ctl.id + k] - f0.controls[3 * ctl.id + k]);
  check(Math.abs(cm[0]) > 1e-3 && Math.abs(cm[1]) < 1e-6 && Math.abs(cm[2]) < 1e-6,
    `(a) control ${ctl.id} moved along X only (${cm.map((x) => x.toFixed(4)).join(', ')})`);
  let others = 0;
  for (let c = 0; c < f1.C; c++) if (c !== ctl.id && pointDist(f1.controls, c, f0.controls) > 1e-7) others++;
  check(others === 0, `(a) no other control moved (${others})`);
  const md = maxDisplacement(f1.positions, rest);
  check(md > 1e-3, `(a) the mesh moved (max displacement ${md.toFixed(4)})`);
  const shown = await ed(() => Array.from(window.ffdEditor.editor.vp.geometry.attributes.position.array));
  check(maxAbsDiff(shown, f1.positions) === 0, '(a) the page draws the server\'s frame');
  await replay('bunny.obj', 1e-4, '(a) lattice control drag');
  await shot('03-lattice-gizmo-drag');

  // (b) mesh tool: pin two vertices, drag a third
  await page.click('[data-tool=mesh]');
  check((await ed(() => window.ffdEditor.tool)) === 'mesh', '(b) mesh tool on');
  const verts = await visibleVertices();
  must(verts.length >= 3, `(b) ${verts.length} pickable vertices on the visible side`);
  // the dragged vertex near the centre of the picks, pins far from it
  const cx = verts.reduce((a, v) => a + v.x, 0) / verts.length, cy = verts.reduce((a, v) => a + v.y, 0) / verts.length;
  verts.sort((p, q) => Math.hypot(p.x - cx, p.y - cy) - Math.hypot(q.x - cx, q.y - cy));
  const a = verts[0];
  const far = verts.slice(1).sort((p, q) => Math.hypot(q.x - a.x, q.y - a.y) - Math.hypot(p.x - a.x, p.y - a.y));
  const b = far[0];
  const c = far.find((v) => Math.hypot(v.x - b.x, v.y - b.y) > 60 && Math.hypot(v.x - a.x, v.y - a.y) > 60) || far[1];
  note(`vertices: drag ${a.v}, pins ${b.v}, ${c.v}`);
  for (const p of [b, c]) { await click(p, ['Alt']); await settle(); }
  let sp = await state();
  check(sp.pins.length === 2 && sp.pins.some((p) => p.vertex === b.v) && sp.pins.some((p) => p.vertex === c.v),
    `(b) Alt+click pinned vertices ${b.v} and ${c.v} (state pins ${JSON.stringify(sp.pins.map((p) => p.vertex))})`);
  const fPre = await frame();
  const sPre = await state();
  const as = await ed((v) => window.ffdEditor.screenOfVertex(v), a.v);
  await mouseDrag(as, { x: as.x + 70, y: as.y - 50 }, 15);
  const fDm = await frame();
  sp = await state();
  const moved = pointDist(fDm.positions, a.v, fPre.positions);
  check(moved > 1e-3 * diag, `(b) dragged vertex ${a.v} moved ${moved.toFixed(4)} (diag ${diag.toFixed(2)})`);
  check(sp.undo === sPre.undo + 1 && sp.pins.length === 2, `(b) the drag is one undo entry (undo ${sPre.undo} -> ${sp.undo}), pins kept`);
  check(fDm.R === 3 && [...fDm.residuals].every((r) => Number.isFinite(r) && r >= 0),
    `(b) frame residuals: R ${fDm.R} (2 pins + the dragged point): ${[...fDm.residuals].map((r) => r.toExponential(1)).join(', ')}`);
  const pinMove = Math.max(pointDist(fDm.positions, b.v, fPre.positions), pointDist(fDm.positions, c.v, fPre.positions));
  check(pinMove < 1e-3, `(b) pinned vertices held (moved ${pinMove.toExponential(2)}), state residuals ${sp.pins.map((p) => (+p.residual).toExponential(1)).join(', ')}`);
  await replay('bunny.obj', 1e-4, '(b) direct manipulation with pins');
  await shot('04-direct-manipulation');

  // (c) undo / redo from the keyboard
  await page.mouse.move(5, 400); // off the canvas; keys go to the window
  await page.keyboard.press('Control+z');
  await settle();
  const su = await state();
  const fu = await frame();
  check(su.undo === sp.undo - 1 && su.redo === sp.redo + 1 && su.revision > sp.revision,
    `(c) Ctrl+Z: undo ${sp.undo} -> ${su.undo}, redo ${sp.redo} -> ${su.redo}, revision ${sp.revision} -> ${su.revision}`);
  check(maxAbsDiff(fu.positions, fPre.positions) < 1e-6, `(c) positions back to before the drag (max |diff| ${maxAbsDiff(fu.positions, fPre.positions).toExponential(2)})`);
  const pageRev = await ed(() => window.ffdEditor.lastFrameRevision);
  check(pageRev === su.revision, `(c) the page drew the undone frame (rev ${pageRev})`);
  await shot('05-undo');
  await page.keyboard.press('Control+Shift+z');
  await settle();
  const sr = await state();
  const fr = await frame();
  check(sr.undo === sp.undo && sr.redo === sp.redo, `(c) Ctrl+Shift+Z: undo ${sr.undo}, redo ${sr.redo}`);
  check(maxAbsDiff(fr.positions, fDm.positions) < 1e-6, `(c) redo restores the dragged positions (max |diff| ${maxAbsDiff(fr.positions, fDm.positions).toExponential(2)})`);

  // (d) save the rig on the server and replay it
  await api('POST', '/api/rig/save', { path: 'edit.json' });
  check(existsSync(path.join(TMP, 'edit.json')), '(d) POST /api/rig/save wrote edit.json under the root');
  await replay('bunny.obj', 1e-4, '(d) saved rig', path.join(TMP, 'edit.json'));
  await page.click('text=Unpin all');
  await settle();
  check((await state()).pins.length === 0, '(d) Unpin all');
  await page.click('[data-tool=controls]');
}

async function tsplineStage() {
  // (e) cow.off from the panel's file list, T-spline, ARAP drag, refine, undo
  await page.click('#panel button[title="Refresh the file list"]');
  await page.waitForFunction(() => [...document.querySelectorAll('select[name=mesh-file] option')].some((o) => o.value === 'cow.off'), null, { timeout: 10000 });
  await page.selectOption('select[name=mesh-file]', 'cow.off');
  await page.click('#panel button:text-is("Open")');
  await page.waitForFunction(() => window.ffdEditor.state && window.ffdEditor.state.mesh.name === 'cow.off', null, { timeout: 20000 });
  await settle();
  const sc = await state();
  check(sc.mesh.name === 'cow.off' && sc.method === null && sc.undo === 0, `(e) opened cow.off from the file list (${sc.mesh.vertices} vertices, a new session)`);
  const cowRest = (await frame()).positions.slice();
  const st = await createViaPanel('tspline', { 'res-tspline-0': 5, 'res-tspline-1': 5, 'res-tspline-2': 5 });
  check(st.method === 'tspline' && st.controls.proxy && st.controls.proxy.points.length > 0,
    `(e) T-spline 5x5x5 created via the panel (${st.controls.count} points, ${st.controls.proxy.points.length} proxy points)`);
  await shot('06-tspline');
  // anchor the bottom layer of the proxy (the panel's Freeze button): one handle
  // alone would only translate everything rigidly
  const fr = await frame();
  const ys = st.controls.proxy.points.map((id) => fr.controls[3 * id + 1]);
  const ymin = Math.min(...ys), ymax = Math.max(...ys);
  const bottom = st.controls.proxy.points.filter((id, i) => ys[i] < ymin + 0.1 * (ymax - ymin));
  await ed((ids) => window.ffdEditor.select(ids), bottom);
  await page.click('#panel button:text-is("❄ Freeze")');
  await page.waitForFunction((n) => (window.ffdEditor.state.controls.frozen || []).length === n, bottom.length, { timeout: 10000 }).catch(() => {});
  await settle();
  const stf = await state();
  check((stf.controls.frozen || []).length === bottom.length, `(e) froze the proxy's bottom layer via the panel (${(stf.controls.frozen || []).length} of ${bottom.length})`);
  const top = st.controls.proxy.points.filter((id, i) => ys[i] > ymax - 0.1 * (ymax - ymin));
  const pickable = await pickableControls(top);
  must(pickable.length > 0, `(e) a pickable proxy point on top (${pickable.length} of ${top.length})`);
  pickable.sort((p, q) => p.x - q.x);
  const pp = pickable[Math.floor(pickable.length / 2)];
  const f0 = await frame();
  const rev0 = stf.revision;
  await mouseDrag(pp, { x: pp.x + 60, y: pp.y - 40 }, 12);
  const st1 = await state();
  const f1 = await frame();
  check(st1.revision > rev0 && st1.undo === stf.undo + 1, `(e) ARAP drag of proxy point ${pp.id} by the mouse (undo ${stf.undo} -> ${st1.undo})`);
  const hm = pointDist(f1.controls, pp.id, f0.controls);
  let others = 0;
  for (let c = 0; c < f1.C; c++) if (c !== pp.id && pointDist(f1.controls, c, f0.controls) > 1e-6) others++;
  const frozenMove = Math.max(...bottom.map((id) => pointDist(f1.controls, id, f0.controls)));
  let dmin = Infinity, dmax = 0;
  for (let v = 0; v < f1.V; v++) { const d = pointDist(f1.positions, v, cowRest); dmin = Math.min(dmin, d); dmax = Math.max(dmax, d); }
  check(hm > 1e-3 && others > 0, `(e) the handle moved ${hm.toFixed(4)}, ARAP moved ${others} other points`);
  check(frozenMove < 1e-9, `(e) frozen points stayed (${frozenMove.toExponential(1)})`);
  check(dmax > 1e-3 && dmin < 0.5 * dmax, `(e) the mesh bent, not just translated (displacement ${dmin.toFixed(4)} .. ${dmax.toFixed(4)})`);
  await replay('cow.off', 1e-4, '(e) T-spline ARAP drag');
  await shot('07-tspline-arap');

  // refine: the panel's "Refine at a mesh point" tool, then a click on the mesh
  await page.click('#panel button:text-is("Refine at a mesh point")');
  check((await ed(() => window.ffdEditor.tool)) === 'refine', '(e) refine tool on');
  const verts = await visibleVertices();
  must(verts.length > 0, '(e) a point of the mesh to click');
  const target = verts[Math.floor(verts.length / 2)];
  const before = await frame();
  const nBefore = st1.controls.count;
  await click(target);
  await page.waitForFunction((r) => window.ffdEditor.state.controls.refinements > r, st1.controls.refinements || 0, { timeout: 20000 });
  await settle();
  const st2 = await state();
  const f2 = await frame();
  check(st2.controls.count > nBefore && st2.controls.refinements === (st1.controls.refinements || 0) + 1,
    `(e) refinement by clicking the mesh: ${nBefore} -> ${st2.controls.count} points, refinements ${st2.controls.refinements}`);
  const inv = maxAbsDiff(f2.positions, before.positions);
  check(inv < 1e-4, `(e) refinement leaves the shape unchanged (max |diff| ${inv.toExponential(2)})`);
  check(f2.C === st2.controls.count, `(e) the frame carries the new control count (${f2.C})`);
  await replay('cow.off', 1e-4, '(e) refined T-spline');
  await shot('08-tspline-refined');
  await page.keyboard.press('Escape'); // back to the controls tool
  await page.mouse.move(5, 400);
  await page.keyboard.press('Control+z');
  await page.waitForFunction((n) => window.ffdEditor.state.controls.count === n, nBefore, { timeout: 20000 }).catch(() => {});
  await settle();
  const st3 = await state();
  const f3 = await frame();
  check(st3.controls.count === nBefore && st3.redo === 1, `(e) Ctrl+Z undoes the refinement (${st3.controls.count} points, redo ${st3.redo})`);
  check(maxAbsDiff(f3.positions, before.positions) < 1e-4, '(e) positions unchanged by the undo');
  await replay('cow.off', 1e-4, '(e) T-spline after undo');
}

async function openBunny() {
  const s = await state();
  if (s.mesh.name === 'bunny.obj') return;
  await page.selectOption('select[name=mesh-file]', 'bunny.obj');
  await page.click('#panel button:text-is("Open")');
  await page.waitForFunction(() => window.ffdEditor.state && window.ffdEditor.state.mesh.name === 'bunny.obj', null, { timeout: 20000 });
  await settle();
}

/** (a2) A cylindrical lattice with an interpolation per axis (docs/lattice-variants.md)
 * through the panel: its parameters, its closed theta rings drawn, a control dragged, replayed. */
async function latticeVariantStage() {
  await openBunny();
  await page.selectOption('select[name=method]', 'lattice');
  await page.selectOption('select[name="coordinates"]', 'cylindrical');
  await page.selectOption('select[name="interp-0"]', 'linear');
  await page.selectOption('select[name="interp-1"]', 'cardinal');
  await page.selectOption('select[name="interp-2"]', 'bspline');
  const st = await createViaPanel('lattice', { 'res-lattice-0': 3, 'res-lattice-1': 6, 'res-lattice-2': 4, 'lattice-tension': 0.2 });
  const p = st.params || {};
  check(p.coordinates === 'cylindrical' && (p.interpolation || []).join() === 'linear,cardinal,bspline' && p.tension[1] === 0.2
    && st.controls.count === 72, `(a2) cylindrical lattice ${p.coordinates} ${(p.interpolation || []).join('/')} T ${(p.tension || []).join()} (${st.controls.count} controls)`);
  // 3 x 6 x 4 grid: r and z edges, plus 6 theta edges per (i, k) ring, closed
  const edges = (st.controls.edges || []).length;
  check(edges === 2 * 6 * 4 + 3 * 6 * 4 + 3 * 6 * 3, `(a2) the lattice's edges, theta rings closed (${edges})`);
  const rest = (await frame()).positions.slice();
  await shot('02b-lattice-cylinder');
  const outer = [];
  for (const j of [0, 1, 2, 3, 4, 5]) for (const k of [1, 2]) outer.push((2 * 6 + j) * 4 + k);
  const ids = await pickableControls(outer);
  must(ids.length > 0, `(a2) a pickable outer control (${ids.length})`);
  const r = await dragControl(ids[0].id, 40, -30);
  must(!!r, '(a2) control drag');
  check(r.s1.undo === r.s0.undo + 1 && pointDist(r.f1.controls, ids[0].id, r.f0.controls) > 1e-3, `(a2) control ${ids[0].id} dragged`);
  check(maxDisplacement(r.f1.positions, rest) > 1e-3, `(a2) the cylindrical lattice moved the mesh (max ${maxDisplacement(r.f1.positions, rest).toFixed(4)})`);
  await replay('bunny.obj', 1e-4, '(a2) cylindrical lattice');
  await page.selectOption('select[name="coordinates"]', 'cartesian');
  await page.selectOption('select[name="basis"]', 'bspline');
}

/** Drags control `id` by pressing on it and moving the mouse; returns frames before/after. */
async function dragControl(id, dx, dy) {
  const [p] = await pickableControls([id]);
  if (!p) return null;
  const f0 = await frame();
  const s0 = await state();
  await mouseDrag(p, { x: p.x + dx, y: p.y + dy }, 12);
  const s1 = await state();
  return { f0, f1: await frame(), s0, s1 };
}

async function pbffdStage() {
  await openBunny();
  const st = await createViaPanel('pbffd', { 'pbffd-interior': 20, 'pbffd-exterior': 20, 'pbffd-levels': 1 });
  check(st.method === 'pbffd' && st.controls.count > 0 && (st.controls.ebfs || []).length > 0, `(f) PB-FFD created via the panel (${st.controls.count} EBFs)`);
  const rest = (await frame()).positions.slice();
  await shot('09-pbffd');
  const ids = (await pickableControls([...Array(st.controls.count).keys()]));
  must(ids.length > 0, `(f) a pickable EBF (${ids.length})`);
  // the EBF whose drag moves the mesh the most is not known; take one near the middle of the view
  ids.sort((p, q) => Math.hypot(p.x - 640, p.y - 400) - Math.hypot(q.x - 640, q.y - 400));
  const r = await dragControl(ids[0].id, 50, -40);
  must(!!r, '(f) EBF drag');
  check(r.s1.undo === r.s0.undo + 1 && pointDist(r.f1.controls, ids[0].id, r.f0.controls) > 1e-3, `(f) EBF ${ids[0].id} dragged (undo ${r.s1.undo})`);
  check(maxDisplacement(r.f1.positions, rest) > 1e-3, `(f) PB-FFD moved the mesh (max ${maxDisplacement(r.f1.positions, rest).toFixed(4)})`);
  await replay('bunny.obj', 1e-4, '(f) PB-FFD');
  await shot('10-pbffd-dragged');
}

async function gffdStage() {
  await openBunny();
  const st = await createViaPanel('gffd');
  const prims = st.controls.primitives || [];
  check(st.method === 'gffd' && prims.length === 1 && prims[0].count === 5, `(f) GFFD created via the panel with the default skeleton (${prims.map((p) => `${p.type} ${p.count}`).join(', ')})`);
  const diag = Math.hypot(...st.mesh.max.map((x, i) => x - st.mesh.min[i]));
  const rest = (await frame()).positions.slice();
  await shot('11-gffd');
  const o = prims[0].offset;
  const ids = await pickableControls([o + 3, o + 1, o + 4, o + 0, o + 2]);
  must(ids.length > 0, `(f) a pickable skeleton vertex (${ids.length})`);
  const r = await dragControl(ids[0].id, 60, -30);
  must(!!r, '(f) skeleton drag');
  check(r.s1.undo === r.s0.undo + 1 && pointDist(r.f1.controls, ids[0].id, r.f0.controls) > 1e-3, `(f) skeleton vertex ${ids[0].id} dragged (undo ${r.s1.undo})`);
  check(maxDisplacement(r.f1.positions, rest) > 1e-3, `(f) GFFD moved the mesh (max ${maxDisplacement(r.f1.positions, rest).toFixed(4)})`);
  await replay('bunny.obj', 1e-3 * diag, '(f) GFFD (tracking tolerance 1e-3 x diagonal)');
  await shot('12-gffd-dragged');
}

async function cageStage() {
  // the "auto" cage (the bounding box, 8 vertices) with mean value coordinates:
  // its wireframe drawn, a vertex picked and dragged, the rig replayed
  await openBunny();
  const st = await createViaPanel('cage');
  check(st.method === 'cage' && st.controls.count === 8 && (st.controls.edges || []).length === 18,
    `(f) cage created via the panel (${st.controls.count} vertices, ${(st.controls.edges || []).length} edges)`);
  const rest = (await frame()).positions.slice();
  const ids = await pickableControls([...Array(st.controls.count).keys()]);
  must(ids.length > 0, `(f) a pickable cage vertex (${ids.length})`);
  const r = await dragControl(ids[0].id, 50, -40);
  must(!!r, '(f) cage vertex drag');
  check(r.s1.undo === r.s0.undo + 1 && pointDist(r.f1.controls, ids[0].id, r.f0.controls) > 1e-3, `(f) cage vertex ${ids[0].id} dragged (undo ${r.s1.undo})`);
  check(maxDisplacement(r.f1.positions, rest) > 1e-3, `(f) the cage moved the mesh (max ${maxDisplacement(r.f1.positions, rest).toFixed(4)})`);
  await replay('bunny.obj', 1e-4, '(f) cage');
  await shot('13-cage-dragged');
}

async function kelvinletStage() {
  // Kelvinlet brushes: created without brushes, a grab placed by clicking the
  // mesh (the panel's tool), its handle dragged, the rig replayed by ffd deform
  await openBunny();
  const st = await createViaPanel('kelvinlet');
  check(st.method === 'kelvinlet' && (st.controls.brushes || []).length === 0, '(k) Kelvinlet created via the panel, no brushes');
  const rest = (await frame()).positions.slice();
  const diag = Math.hypot(...st.mesh.max.map((x, i) => x - st.mesh.min[i]));
  await ed(() => window.ffdEditor.editor.setTool('addbrush'));
  const rev = (await state()).revision;
  await page.mouse.click(470, 470); // the bunny's body in the 960-wide viewport
  await page.waitForFunction((r) => window.ffdEditor.state.revision > r, rev, { timeout: 20000 });
  await settle();
  const s1 = await state();
  check((s1.controls.brushes || []).length === 1 && s1.controls.count === 1, `(k) a grab brush placed by clicking the mesh (${(s1.controls.brushes || []).length} brushes)`);
  await shot('k1-kelvinlet');
  const r = await dragControl(0, 50, -40);
  must(!!r, '(k) grab handle drag');
  check(pointDist(r.f1.controls, 0, r.f0.controls) > 1e-3, '(k) the grab handle dragged');
  check(maxDisplacement(r.f1.positions, rest) > 1e-3, `(k) the brush moved the mesh (max ${maxDisplacement(r.f1.positions, rest).toFixed(4)})`);
  await replay('bunny.obj', 1e-6 * diag, '(k) Kelvinlet (float32 frame)');
  await shot('k2-kelvinlet-dragged');
}

async function nestedStage() {
  // (h) nested lattices: a rig with children loaded from the root, a child's
  // point dragged; the root's points stay, the rig replays
  await openBunny();
  await page.selectOption('select[name=rig-file]', 'nested.json');
  await page.click('#panel button:text-is("Load")');
  await page.waitForFunction(() => { const s = window.ffdEditor.state; return s && s.method === 'lattice' && (s.controls.lattices || []).length === 3; }, null, { timeout: 20000 });
  await settle();
  const st = await state();
  const L = st.controls.lattices;
  check(st.controls.count === 155 && L[1].first === 64 && L[2].depth === 2, `(h) nested rig loaded: ${L.map((l) => `${l.count}@${l.depth}`).join(', ')} controls`);
  await shot('12a-nested');
  const child = [...Array(L[1].count).keys()].map((k) => L[1].first + k);
  const ids = await pickableControls(child);
  must(ids.length > 0, `(h) a pickable child control (${ids.length})`);
  ids.sort((p, q) => Math.hypot(p.x - 640, p.y - 400) - Math.hypot(q.x - 640, q.y - 400));
  const r = await dragControl(ids[0].id, 40, -30);
  must(!!r, '(h) child control drag');
  let rootMoved = 0;
  for (let c = 0; c < L[1].first; c++) if (pointDist(r.f1.controls, c, r.f0.controls) > 0) rootMoved++;
  check(r.s1.undo === r.s0.undo + 1 && pointDist(r.f1.controls, ids[0].id, r.f0.controls) > 1e-3 && rootMoved === 0,
    `(h) child control ${ids[0].id} dragged, the root's ${L[1].first} points unchanged (undo ${r.s1.undo})`);
  await replay('bunny.obj', 1e-4, '(h) nested lattices');
  await shot('12b-nested-dragged');
}

async function uiStage() {
  // (g) help overlay, influence map, a server error as a red toast
  await page.mouse.move(5, 400);
  await page.keyboard.press('Escape');
  await page.keyboard.press('h');
  const helpShown = await page.waitForSelector('#help:not([hidden])', { timeout: 3000 }).then(() => true, () => false);
  check(helpShown, '(g) H opens the help overlay');
  await shot('13-help');
  await page.keyboard.press('Escape');
  check(await page.locator('#help').isHidden(), '(g) Escape closes it');

  const s = await state();
  if (s.method) {
    const ids = await ed(() => [...window.ffdEditor.editor.controlsView.visibleIds]);
    await ed((i) => window.ffdEditor.select([i]), ids[Math.floor(ids.length / 2)]);
    await page.keyboard.press('i');
    const on = await page.waitForFunction(() => window.ffdEditor.editor.opts.influence && window.ffdEditor.editor.vp.material.vertexColors, null, { timeout: 10000 })
      .then(() => true, () => false);
    const legend = await page.locator('#influence-legend').isVisible().catch(() => false);
    check(on && legend, `(g) I turns the influence map on (colours ${on}, legend ${legend})`);
    await shot('14-influence');
    await page.keyboard.press('i');
    const off = await page.waitForFunction(() => !window.ffdEditor.editor.opts.influence && !window.ffdEditor.editor.vp.material.vertexColors, null, { timeout: 5000 })
      .then(() => true, () => false);
    check(off, '(g) I again turns it off');
  }

  // a malformed rig through the panel's upload input: the server's 400 becomes a red toast
  const before = await state();
  expectHttp(true);
  await page.setInputFiles('#panel input[type=file][accept=".json,.prm"]', { name: 'broken.json', mimeType: 'application/json', buffer: Buffer.from('{"version": 1, "deformer": ') });
  const toast = await page.waitForSelector('.toast.error', { timeout: 10000 }).then((el) => el.textContent(), () => null);
  check(!!toast, `(g) malformed rig upload shows a red toast: ${JSON.stringify(toast && toast.replace(/×$/, ''))}`);
  const color = toast ? await page.locator('.toast.error').first().evaluate((el) => getComputedStyle(el).borderColor + ' ' + getComputedStyle(el).backgroundColor) : '';
  note(`toast colours: ${color}`);
  await shot('15-error-toast');
  expectHttp(false);
  const after = await state();
  check(after.revision === before.revision && after.method === before.method, '(g) the session is unchanged by the failed upload');

  // a binary glTF through the mesh upload input: the server reads it (world
  // space, every primitive) and the page draws exactly the server's vertices
  const glb = await readFile(path.join(REPO, 'tests', 'data', 'mesh', 'cube_nodes.glb'));
  await page.setInputFiles('#panel input[type=file][accept=".obj,.ply,.off,.stl,.gltf,.glb"]', { name: 'cube_nodes.glb', mimeType: 'model/gltf-binary', buffer: glb });
  const opened = await page.waitForFunction(() => (document.querySelector('#panel b') || {}).textContent === 'cube_nodes.glb', null, { timeout: 15000 })
    .then(() => true, () => false);
  const sg = await state();
  const fg = await frame();
  const drawn = await ed(() => Array.from(window.ffdEditor.editor.vp.geometry.attributes.position.array));
  check(opened && sg.mesh && sg.mesh.vertices === 11 && sg.mesh.faces === 13,
    `(g) .glb upload opens cube_nodes.glb (${sg.mesh && sg.mesh.vertices} vertices, ${sg.mesh && sg.mesh.faces} faces; ffd reads 11 and 13)`);
  check(drawn.length === 33 && maxAbsDiff(drawn, fg.positions) === 0, '(g) the page draws the .glb\'s world-space vertices');
  await shot('16-glb-upload');
}

await runTest(main, 'e2e');
