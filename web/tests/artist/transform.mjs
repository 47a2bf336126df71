// Artist stage "transform": Blender-style modal transforms of lattice control
// points on the bunny with real keys and mouse (G/R/S, X/Y/Z, typed amounts,
// Enter / Esc / right click), mirror editing, proportional editing, the
// numeric panel, one undo step per operation.

import {
  page, ed, check, must, note, shot, settle, click, createViaPanel, pickableControls, visibleVertices, state, frame, replay, OUT, gizmoArrow, mouseDrag, pointDist,
} from '../harness.mjs';
import path from 'node:path';

const RES = 5;
const idOf = (i, j, k) => (i * RES + j) * RES + k;
const ctl = (f, id) => [f.controls[3 * id], f.controls[3 * id + 1], f.controls[3 * id + 2]];
const same = (a, b) => a.length === b.length && a.every((x, i) => Object.is(x, b[i]));
/** Controls (other than `except`) whose float32 position changed in any bit. */
const changed = (f0, f1, except = new Set()) => {
  const out = [];
  for (let c = 0; c < f0.C; c++) if (!except.has(c) && !same(ctl(f0, c), ctl(f1, c))) out.push(c);
  return out;
};
const header = () => ed(() => { const e = document.querySelector('.transform-header'); return e && !e.hidden ? e.querySelector('.transform-value').textContent : null; });
/** Selects control c ({id, x, y} on screen) by clicking it, and leaves the pointer on it. The
 * selection is cleared first (Esc): a click on a control under the gizmo's handles would drag the gizmo. */
async function selectByClick(c) {
  const sel = await ed(() => window.ffdEditor.selection);
  if (sel.length === 1 && sel[0] === c.id) { await page.mouse.move(c.x, c.y); return; }
  if (sel.length) { await page.mouse.move(c.x, c.y); await page.keyboard.press('Escape'); await settle(); }
  await click(c);
  await settle();
  const now = await ed(() => window.ffdEditor.selection);
  must(now.length === 1 && now[0] === c.id, `click selects control ${c.id} (${JSON.stringify(now)})`);
}
const keys = async (...ks) => { for (const k of ks) await page.keyboard.press(k); };

/** Moves the pointer over the view, on an empty spot near its top-left (no control under it). */
async function pointerToView() {
  const r = await ed(() => { const b = window.ffdEditor.editor.vp.renderer.domElement.getBoundingClientRect(); return { x: b.left + 60, y: b.top + 90 }; });
  await page.mouse.move(r.x, r.y);
  return r;
}

async function undoCheck(fBefore, what) {
  const s0 = await state();
  await pointerToView();
  await page.keyboard.press('Control+z');
  await settle();
  const s1 = await state();
  const f = await frame();
  const back = same(Array.from(f.controls), Array.from(fBefore.controls)) && same(Array.from(f.positions), Array.from(fBefore.positions));
  check(s1.undo === s0.undo - 1 && back, `${what}: Ctrl+Z undoes it in one step (undo ${s0.undo} -> ${s1.undo}), every bit back`);
}

export async function stage() {
  // bunny.obj, a fresh 5x5x5 lattice
  await page.selectOption('select[name=mesh-file]', 'bunny.obj');
  await page.click('#panel button:text-is("Open")');
  await page.waitForFunction(() => window.ffdEditor.state && window.ffdEditor.state.mesh.name === 'bunny.obj' && !window.ffdEditor.state.method, null, { timeout: 30000 });
  await settle();
  const st0 = await createViaPanel('lattice', { 'res-lattice-0': RES, 'res-lattice-1': RES, 'res-lattice-2': RES });
  must(st0.controls.count === RES ** 3, `transform: lattice ${RES}x${RES}x${RES} on the bunny (${st0.controls.count} controls)`);
  const diag = Math.hypot(...st0.mesh.max.map((x, i) => x - st0.mesh.min[i]));

  // --- G X 0.5 Enter on one clicked control -------------------------------------
  const cands = [];
  for (const i of [2, 1, 3]) for (const k of [2, 1, 3, 4, 0]) cands.push(idOf(i, 3, k));
  const pick = await pickableControls(cands);
  must(pick.length > 0, `transform: a pickable control (${pick.length} of ${cands.length})`);
  const c1 = pick[0];
  await selectByClick(c1);
  check(JSON.stringify(await ed(() => window.ffdEditor.selection)) === JSON.stringify([c1.id]), `transform: click selects control ${c1.id}`);
  const f0 = await frame();
  const u0 = (await state()).undo;
  await keys('g');
  const started = await ed(() => window.ffdEditor.dragging);
  check(started && (await header()) !== null, `G with a selection and the pointer over the view starts a modal grab (header "${await header()}")`);
  await keys('x');
  await page.keyboard.type('0.5');
  const hx = await header();
  check(hx === 'Grab X: 0.5', `X then 0.5 typed: the header reads "${hx}"`);
  await shot('artist-transform-grab-typed');
  await keys('Enter');
  await settle();
  const f1 = await frame();
  const p0 = ctl(f0, c1.id), p1 = ctl(f1, c1.id);
  const want = Math.fround(p0[0] + 0.5);
  check(p1[0] === want && p1[1] === p0[1] && p1[2] === p0[2],
    `Enter: control ${c1.id} moved by exactly +0.5 in x (x ${p0[0]} -> ${p1[0]}, float32(x + 0.5) = ${want}; y, z bits kept)`);
  const others1 = changed(f0, f1, new Set([c1.id]));
  check(others1.length === 0, `no other control moved (${others1.length})`);
  check((await state()).undo === u0 + 1, 'the modal grab is one undo step');
  await undoCheck(f0, 'grab');

  // --- Esc and right click cancel: every bit back ----------------------------------
  await selectByClick(c1);
  const fc = await frame();
  const uc = (await state()).undo;
  await keys('g');
  await page.mouse.move(c1.x + 70, c1.y - 40, { steps: 6 });
  await page.waitForFunction(() => { const m = window.ffdEditor.editor.transform.modal; return m && m.session.steps >= 1; }, null, { timeout: 10000 });
  await ed(() => window.ffdEditor.editor.activeDrag.idle());
  const fm = await frame();
  check(!same(ctl(fm, c1.id), ctl(fc, c1.id)), `the grab follows the mouse live (control ${c1.id} at ${ctl(fm, c1.id).map((x) => x.toFixed(3))})`);
  await keys('Escape');
  await settle();
  // Shift held: the same mouse move moves a tenth as far
  await page.mouse.move(c1.x, c1.y);
  await keys('g');
  await page.keyboard.down('Shift');
  await page.mouse.move(c1.x + 70, c1.y - 40, { steps: 6 });
  await page.keyboard.up('Shift');
  await page.waitForFunction(() => { const m = window.ffdEditor.editor.transform.modal; return m && m.session.steps >= 1; }, null, { timeout: 10000 });
  await ed(() => window.ffdEditor.editor.activeDrag.idle());
  const fsh = await frame();
  const full = pointDist(fm.controls, c1.id, fc.controls), fine = pointDist(fsh.controls, c1.id, fc.controls);
  check(Math.abs(fine / full - 0.1) < 0.02, `Shift held during a grab: a tenth of the move (${fine.toFixed(4)} vs ${full.toFixed(4)})`);
  await keys('Escape');
  await settle();
  const fe = await frame();
  check(same(Array.from(fe.controls), Array.from(fc.controls)) && same(Array.from(fe.positions), Array.from(fc.positions)) && (await state()).undo === uc,
    'Esc cancels: controls and mesh back bit for bit, no undo step');
  await page.mouse.move(c1.x, c1.y);
  await keys('s');
  await page.mouse.move(c1.x + 120, c1.y + 60, { steps: 5 });
  await page.waitForTimeout(200);
  await page.mouse.click(c1.x + 120, c1.y + 60, { button: 'right' });
  await settle();
  const fr = await frame();
  check(same(Array.from(fr.controls), Array.from(fc.controls)) && !(await ed(() => window.ffdEditor.dragging)),
    'right click cancels a modal scale: every bit back');

  // --- R Z 90 and S 2 on the top layer, about its median ----------------------------
  const layer = [];
  for (let i = 0; i < RES; i++) for (let k = 0; k < RES; k++) layer.push(idOf(i, RES - 1, k));
  await ed((ids) => window.ffdEditor.select(ids), layer);
  // the mouse turning a quarter counter-clockwise round the pivot turns the layer so on screen
  const pc = await ed(() => window.ffdEditor.gizmoCenter());
  const onScreen = () => ed((ids) => ids.map((id) => window.ffdEditor.screenOfControl(id)), layer);
  const s0 = await onScreen();
  await page.mouse.move(pc.x + 150, pc.y);
  await keys('r');
  for (let deg = 10; deg <= 90; deg += 10) await page.mouse.move(pc.x + 150 * Math.cos(deg * Math.PI / 180), pc.y - 150 * Math.sin(deg * Math.PI / 180));
  await page.waitForFunction(() => { const m = window.ffdEditor.editor.transform.modal; return m && m.session.steps >= 1; }, null, { timeout: 10000 });
  await ed(() => window.ffdEditor.editor.activeDrag.idle());
  await page.waitForTimeout(100);
  const s1 = await onScreen();
  const turn = s0.reduce((sum, p, i) => {
    let d = Math.atan2(-(s1[i].y - pc.y), s1[i].x - pc.x) - Math.atan2(-(p.y - pc.y), p.x - pc.x);
    while (d > Math.PI) d -= 2 * Math.PI;
    while (d < -Math.PI) d += 2 * Math.PI;
    return sum + d;
  }, 0) / layer.length * 180 / Math.PI;
  const hr = await header();
  const hd = /^Rotate: (-?[\d.]+)°$/.exec(hr || '');
  check(turn > 60 && turn < 110 && hd && Math.abs(+hd[1] - 90) < 2, `R and a quarter turn of the mouse round the pivot turn the layer ${turn.toFixed(1)}° on screen, live ("${hr}")`);
  await keys('Escape');
  await settle();
  await pointerToView();
  const fl = await frame();
  check(same(Array.from(fl.controls), Array.from(fc.controls)), 'Esc cancels the rotation: every bit back');
  const med = [0, 1, 2].map((a) => layer.reduce((s, id) => s + fl.controls[3 * id + a], 0) / layer.length);
  await keys('r', 'z');
  await page.keyboard.type('90');
  check((await header()) === 'Rotate Z: 90°', `R Z 90: the header reads "${await header()}"`);
  await keys('Enter');
  await settle();
  const fR = await frame();
  let errR = 0;
  for (const id of layer) {
    const [x, y, z] = ctl(fl, id);
    const q = ctl(fR, id);
    const expect = [med[0] - (y - med[1]), med[1] + (x - med[0]), z]; // +90° about Z through the median
    errR = Math.max(errR, ...expect.map((e, a) => Math.abs(e - q[a])));
  }
  check(errR < 1e-5 * diag, `R Z 90 Enter: the top layer turned 90° about Z through its median (max error ${errR.toExponential(2)})`);
  check(changed(fl, fR, new Set(layer)).length === 0, 'R: the other layers did not move');
  await keys('s');
  await page.keyboard.type('2');
  await keys('Enter');
  await settle();
  const fS = await frame();
  let errS = 0;
  for (const id of layer) {
    const q = ctl(fR, id), r = ctl(fS, id);
    errS = Math.max(errS, ...[0, 1, 2].map((a) => Math.abs(med[a] + 2 * (q[a] - med[a]) - r[a])));
  }
  check(errS < 1e-5 * diag, `S 2 Enter: the layer doubled about its median (max error ${errS.toExponential(2)})`);
  await shot('artist-transform-rotate-scale-layer');
  await replay('bunny.obj', 1e-4, 'R Z 90 + S 2 on a layer');
  await undoCheck(fR, 'scale');
  await undoCheck(fl, 'rotate');

  // --- mirror X: the counterpart moves mirrored; a control on the plane stays on it ---
  await page.check('[name=tf-mirror]');
  check(await ed(() => window.ffdEditor.editor.transform.opt.mirror), 'the panel\'s Mirror box turns mirror editing on (X plane by default)');
  const side = await pickableControls([idOf(1, 3, 2), idOf(1, 3, 3), idOf(1, 2, 2), idOf(1, 3, 1), idOf(0, 3, 2), idOf(1, 2, 3)]);
  must(side.length > 0, 'a pickable control on the -X side');
  const a = side[0];
  const ai = Math.floor(a.id / (RES * RES)), aj = Math.floor(a.id / RES) % RES, ak = a.id % RES;
  const partner = idOf(RES - 1 - ai, aj, ak);
  await selectByClick(a);
  const fM0 = await frame();
  await keys('g', 'y');
  await page.keyboard.type('0.4');
  await keys('x', 'x', 'x'); // X: global, again local, again off -> no constraint...
  await keys('Shift+Z'); // ...then the plane XY
  const hM = await header();
  check(hM === 'Grab XY: 0.4', `X three times clears the constraint, Shift+Z constrains to the XY plane (header "${hM}")`);
  await keys('Backspace', 'Backspace', 'Backspace');
  await page.keyboard.type('-0.6');
  await shot('artist-transform-mirror');
  await keys('Enter');
  await settle();
  const fM1 = await frame();
  const da = ctl(fM1, a.id).map((x, k) => x - ctl(fM0, a.id)[k]);
  const dp = ctl(fM1, partner).map((x, k) => x - ctl(fM0, partner)[k]);
  check(Math.abs(da[0] + 0.6) < 1e-5 && Math.abs(da[1]) < 1e-6 && Math.abs(dp[0] - 0.6) < 1e-5 && Math.abs(dp[1]) < 1e-6 && Math.abs(dp[2] - da[2]) < 1e-6,
    `mirror X: control ${a.id} moved ${da.map((x) => x.toFixed(3))}, its counterpart ${partner} ${dp.map((x) => x.toFixed(3))} (mirrored)`);
  check(changed(fM0, fM1, new Set([a.id, partner])).length === 0, 'mirror: nothing else moved');
  await undoCheck(fM0, 'mirrored grab');
  // the gizmo's arrow honours the mirror too
  await page.waitForTimeout(200);
  const arrow = await gizmoArrow('X');
  must(!!arrow, 'the gizmo\'s X arrow on screen');
  await mouseDrag(arrow.from, { x: arrow.from.x + arrow.dir.x * 60, y: arrow.from.y + arrow.dir.y * 60 }, 10);
  const fM2 = await frame();
  const ga = ctl(fM2, a.id)[0] - ctl(fM0, a.id)[0], gp = ctl(fM2, partner)[0] - ctl(fM0, partner)[0];
  check(Math.abs(ga) > 1e-3 && Math.abs(ga + gp) < 1e-5 && changed(fM0, fM2, new Set([a.id, partner])).length === 0,
    `mirror X with the gizmo: dragging control ${a.id}'s X arrow moves it ${ga.toFixed(4)} and its counterpart ${gp.toFixed(4)}`);
  await undoCheck(fM0, 'mirrored gizmo drag');
  const mid = await pickableControls([idOf(2, 3, 2), idOf(2, 3, 3), idOf(2, 3, 1), idOf(2, 2, 2), idOf(2, 4, 2)]);
  if (mid.length) {
    await selectByClick(mid[0]);
    const fP0 = await frame();
    await keys('g');
    await page.keyboard.type('0.3'); // unconstrained typed: along X, across the plane
    const uP = (await state()).undo;
    await keys('Enter');
    await settle();
    const fP1 = await frame();
    check(same(ctl(fP1, mid[0].id), ctl(fP0, mid[0].id)),
      `mirror: control ${mid[0].id} on the mirror plane stays on it when moved across (x ${ctl(fP1, mid[0].id)[0]})`);
    if ((await state()).undo === uP + 1) await undoCheck(fP0, 'grab on the mirror plane');
  } else note('mirror: no pickable control on the plane (skipped)');
  await page.uncheck('[name=tf-mirror]');

  // --- proportional editing: O, the wheel resizes the radius, smooth falloff -------------
  await selectByClick(c1);
  await keys('o');
  check(await ed(() => window.ffdEditor.editor.transform.opt.proportional && document.getElementById('btn-proportional').classList.contains('active')),
    'O turns proportional editing on (the tool bar\'s Prop switch lit)');
  const spacing = (st0.mesh.max[1] - st0.mesh.min[1]) / (RES - 1);
  await page.fill('[name=tf-radius]', String(+(1.6 * spacing).toFixed(3)));
  await page.dispatchEvent('[name=tf-radius]', 'change');
  const fO0 = await frame();
  await page.mouse.move(c1.x, c1.y);
  await keys('g', 'y');
  const r0 = await ed(() => window.ffdEditor.editor.transform.radius);
  await page.mouse.wheel(0, -100);
  await page.mouse.wheel(0, 100);
  const r1 = await ed(() => window.ffdEditor.editor.transform.radius);
  check(Math.abs(r1 - r0) < 1e-9 * r0, `the wheel during a transform resizes the radius and back (${r0.toFixed(3)} -> ${r1.toFixed(3)})`);
  await page.mouse.wheel(0, -100);
  const r2 = await ed(() => window.ffdEditor.editor.transform.radius);
  check(r2 > r0 * 1.05, `wheel up grows the radius (${r0.toFixed(3)} -> ${r2.toFixed(3)})`);
  await page.mouse.wheel(0, 100);
  await page.keyboard.type('0.5');
  await page.waitForTimeout(200);
  await shot('artist-transform-proportional');
  // the view alone, for docs/editor.md (docs/img/editor-transform.png)
  await page.screenshot({ path: path.join(OUT, 'artist-transform-proportional-view.png'), clip: { x: 0, y: 40, width: 960, height: 540 } });
  await keys('Enter');
  await settle();
  const fO1 = await frame();
  const radius = await ed(() => window.ffdEditor.editor.transform.radius);
  const dy = (id) => fO1.controls[3 * id + 1] - fO0.controls[3 * id + 1];
  let inside = 0, beyondMoved = 0, falloffErr = 0, lessOk = true;
  for (let c = 0; c < fO0.C; c++) {
    if (c === c1.id) continue;
    const d = Math.hypot(...[0, 1, 2].map((k) => fO0.controls[3 * c + k] - fO0.controls[3 * c1.id + k]));
    if (d >= radius) { if (!same(ctl(fO0, c), ctl(fO1, c))) beyondMoved++; continue; }
    inside++;
    const t = 1 - d / radius;
    falloffErr = Math.max(falloffErr, Math.abs(dy(c) - 0.5 * t * t * (3 - 2 * t)));
    if (!(dy(c) > 0 && dy(c) < 0.5)) lessOk = false;
  }
  check(Math.abs(dy(c1.id) - 0.5) < 1e-6, `proportional: the selected control moved 0.5 in y (${dy(c1.id).toFixed(6)})`);
  check(inside > 0 && lessOk && falloffErr < 1e-5, `proportional: ${inside} neighbours within ${radius.toFixed(3)} moved less, by 0.5·(3t²−2t³) (max error ${falloffErr.toExponential(2)})`);
  check(beyondMoved === 0, `proportional: controls beyond the radius did not move (${beyondMoved})`);
  await undoCheck(fO0, 'proportional grab');
  await pointerToView();
  await keys('o');

  // --- snapping: Ctrl held during a grab snaps it to increments of the step ------------------
  await selectByClick(c1);
  const step = await ed(() => window.ffdEditor.editor.transform.step);
  const fG0 = await frame();
  await keys('g', 'x');
  await page.keyboard.down('Control');
  await page.mouse.move(c1.x + 57, c1.y + 3, { steps: 5 });
  await page.waitForTimeout(150);
  const hs = await header();
  await page.keyboard.up('Control');
  await page.mouse.move(c1.x + 57, c1.y + 4); // Control released: free again...
  await page.keyboard.down('Control');
  await page.mouse.move(c1.x + 57, c1.y + 3); // ...and held again for the confirming click
  await page.mouse.click(c1.x + 57, c1.y + 3);
  await page.keyboard.up('Control');
  await settle();
  const fG1 = await frame();
  const dxs = ctl(fG1, c1.id)[0] - ctl(fG0, c1.id)[0];
  const k = Math.round(dxs / step);
  check(k !== 0 && Math.abs(dxs - k * step) < 1e-5 && ctl(fG1, c1.id)[1] === ctl(fG0, c1.id)[1],
    `Ctrl held during G X snaps the move to the increment ${step} (moved ${dxs.toFixed(6)} = ${k} steps; header "${hs}"); a left click confirms`);
  await undoCheck(fG0, 'snapped grab');

  // --- grid snapping: the moved pivot lands on the grid ----------------------------------
  await page.check('[name=tf-snap]');
  await page.selectOption('[name=tf-snap-kind]', 'grid');
  await selectByClick(c1);
  await keys('g', 'x');
  await page.mouse.move(c1.x + 43, c1.y, { steps: 4 });
  await page.mouse.click(c1.x + 43, c1.y);
  await settle();
  const gx = ctl(await frame(), c1.id)[0];
  check(Math.abs(gx / step - Math.round(gx / step)) < 1e-4 && gx !== ctl(fG0, c1.id)[0],
    `grid snapping: control ${c1.id} lands on x = ${gx.toFixed(6)}, a multiple of ${step}`);
  await undoCheck(fG0, 'grid-snapped grab');
  await page.uncheck('[name=tf-snap]');

  // --- active element: the last clicked control stays, the other scales away from it ------
  const two = (await pickableControls([idOf(1, 3, 2), idOf(3, 3, 2), idOf(1, 3, 3), idOf(3, 3, 3)])).slice(0, 2);
  if (two.length === 2) {
    await page.selectOption('[name=tf-pivot]', 'active');
    await selectByClick(two[0]);
    await click(two[1], ['Shift']);
    await settle();
    const fA0 = await frame();
    await keys('s');
    await page.keyboard.type('2');
    await keys('Enter');
    await settle();
    const fA1 = await frame();
    const act = ctl(fA0, two[1].id), oth = ctl(fA0, two[0].id);
    const errA = Math.max(...[0, 1, 2].map((j) => Math.abs(act[j] + 2 * (oth[j] - act[j]) - ctl(fA1, two[0].id)[j])));
    const stay = Math.max(...[0, 1, 2].map((j) => Math.abs(ctl(fA1, two[1].id)[j] - act[j])));
    check(stay < 1e-5 * diag && errA < 1e-5 * diag,
      `pivot active element: S 2 keeps the last clicked control ${two[1].id} (moved ${stay.toExponential(1)}) and doubles control ${two[0].id}'s offset from it (error ${errA.toExponential(2)})`);
    await undoCheck(fA0, 'scale about the active element');
    await page.selectOption('[name=tf-pivot]', 'median');
  } else note('active element: two pickable controls not found (skipped)');

  // --- the 3D cursor (Shift+right click on the mesh) as the pivot ---------------------
  const vis = await visibleVertices();
  must(vis.length > 0, 'a visible mesh vertex for the 3D cursor');
  const vtx = vis[Math.floor(vis.length / 2)];
  await page.keyboard.down('Shift');
  await page.mouse.click(vtx.x, vtx.y, { button: 'right' });
  await page.keyboard.up('Shift');
  await page.waitForTimeout(100);
  const cur = await ed(() => window.ffdEditor.editor.transform.cursor && window.ffdEditor.editor.transform.cursor.toArray());
  const vpos = await ed((v) => window.ffdEditor.editor.vp.vertex(v).toArray(), vtx.v);
  check(!!cur && Math.hypot(...cur.map((x, i) => x - vpos[i])) < 0.05 * diag && (await ed(() => window.ffdEditor.editor.transform.cursorObj.visible)),
    `Shift+right click on the mesh places the 3D cursor there (${cur && cur.map((x) => x.toFixed(3))}, vertex ${vtx.v} at ${vpos.map((x) => x.toFixed(3))}), drawn as a crosshair`);
  await page.selectOption('[name=tf-pivot]', 'cursor');
  await selectByClick(c1);
  const fK0 = await frame();
  await keys('s');
  await page.keyboard.type('2');
  await shot('artist-transform-cursor-pivot');
  await keys('Enter');
  await settle();
  const fK1 = await frame();
  const errK = Math.max(...[0, 1, 2].map((a) => Math.abs(cur[a] + 2 * (ctl(fK0, c1.id)[a] - cur[a]) - ctl(fK1, c1.id)[a])));
  check(errK < 1e-5 * diag, `pivot 3D cursor: S 2 scales control ${c1.id} away from the cursor (error ${errK.toExponential(2)})`);
  await undoCheck(fK0, 'scale about the 3D cursor');

  // --- individual origins: two rows each turn about their own centre -------------------
  await page.selectOption('[name=tf-pivot]', 'individual');
  const rowA = [0, 1, 2, 3, 4].map((i) => idOf(i, RES - 1, 0)), rowB = [0, 1, 2, 3, 4].map((i) => idOf(i, RES - 1, RES - 1));
  await ed((ids) => window.ffdEditor.select(ids), [...rowA, ...rowB]);
  await pointerToView();
  const fI0 = await frame();
  await keys('r', 'y');
  await page.keyboard.type('90');
  await keys('Enter');
  await settle();
  const fI1 = await frame();
  let errI = 0;
  for (const row of [rowA, rowB]) {
    const m = [0, 1, 2].map((a) => row.reduce((sum, id) => sum + fI0.controls[3 * id + a], 0) / row.length);
    for (const id of row) {
      const [x, y, z] = ctl(fI0, id), r = ctl(fI1, id);
      const e = [m[0] + (z - m[2]), y, m[2] - (x - m[0])];
      errI = Math.max(errI, ...e.map((v, j) => Math.abs(v - r[j])));
    }
  }
  check(errI < 1e-5 * diag, `pivot individual origins: R Y 90 turns each of two lattice rows about its own centre (max error ${errI.toExponential(2)})`);
  await undoCheck(fI0, 'individual origins');
  await page.selectOption('[name=tf-pivot]', 'median');

  // --- the numeric panel: location (exact), rotate by ------------------------------
  await selectByClick(c1);
  const fN0 = await frame();
  const shownX = await page.inputValue('[name=tf-loc-x]');
  check(Math.fround(+shownX) === ctl(fN0, c1.id)[0], `the panel shows control ${c1.id}'s exact x (${shownX})`);
  await page.fill('[name=tf-loc-x]', '1.25');
  await page.press('[name=tf-loc-x]', 'Enter');
  await settle();
  const fN1 = await frame();
  const q = ctl(fN1, c1.id);
  check(Math.abs(q[0] - 1.25) < 1e-6 && q[1] === ctl(fN0, c1.id)[1] && q[2] === ctl(fN0, c1.id)[2],
    `typing x = 1.25 in the panel moves control ${c1.id} there (x ${q[0]}), y and z kept`);
  check(changed(fN0, fN1, new Set([c1.id])).length === 0, 'the panel edit moved nothing else');
  await page.press('[name=tf-loc-x]', 'Escape').catch(() => {});
  await shot('artist-transform-panel');
  await undoCheck(fN0, 'panel location edit');
  await ed((ids) => window.ffdEditor.select(ids), layer);
  await page.waitForTimeout(150);
  await page.fill('[name=tf-rot-y]', '90');
  await page.press('[name=tf-rot-y]', 'Enter');
  await settle();
  const fN2 = await frame();
  let errY = 0;
  for (const id of layer) {
    const [x, y, z] = ctl(fN0, id), r = ctl(fN2, id);
    const e = [med[0] + (z - med[2]), y, med[2] - (x - med[0])]; // +90° about Y
    errY = Math.max(errY, ...e.map((v, k) => Math.abs(v - r[k])));
  }
  check(errY < 1e-5 * diag, `the panel's Rotate Y 90 turns the layer about Y through its median (max error ${errY.toExponential(2)})`);
  await undoCheck(fN0, 'panel rotate');

  // --- local orientation: X pressed twice follows the lattice's own (turned) X axis -------
  await pointerToView();
  const fL0 = await frame();
  await keys('a', 'r', 'z');
  await page.keyboard.type('30');
  await keys('Enter');
  await settle();
  const fL1 = await frame();
  await ed((id) => window.ffdEditor.select([id]), c1.id);
  await pointerToView();
  await keys('g', 'x', 'x');
  await page.keyboard.type('0.5');
  const hl = await header();
  await keys('Enter');
  await settle();
  const fL2 = await frame();
  const dl = ctl(fL2, c1.id).map((x, j) => x - ctl(fL1, c1.id)[j]);
  const wantL = [0.5 * Math.cos(Math.PI / 6), 0.5 * Math.sin(Math.PI / 6), 0];
  check(hl === 'Grab local X: 0.5' && dl.every((x, j) => Math.abs(x - wantL[j]) < 1e-5),
    `after turning the lattice 30° about Z, G X X 0.5 ("${hl}") moves along its own X axis (${dl.map((x) => x.toFixed(4))})`);
  await undoCheck(fL1, 'local grab');
  await undoCheck(fL0, 'turning the whole lattice');

  // --- individual origins on PB-FFD EBFs: each frame turns about its own centre ------------
  const sp = await createViaPanel('pbffd', {});
  must(sp.controls.ebfs && sp.controls.ebfs.length >= 8, `PB-FFD on the bunny (${sp.controls.count} EBFs)`);
  await ed(() => window.ffdEditor.select([3, 7]));
  await page.selectOption('[name=tf-pivot]', 'individual');
  await pointerToView();
  const fE0 = await frame();
  await keys('r', 'z');
  await page.keyboard.type('45');
  await keys('Enter');
  await settle();
  const sE1 = await state();
  const fE1 = await frame();
  const c45 = Math.SQRT1_2;
  const turned = [3, 7].every((e) => {
    const [r0] = sp.controls.ebfs[e].frame, [r1] = sE1.controls.ebfs[e].frame;
    const want = [c45 * r0[0] - c45 * r0[1], c45 * r0[0] + c45 * r0[1], r0[2]]; // the first axis turned 45° about Z
    return want.every((v, k) => Math.abs(v - r1[k]) < 1e-9);
  });
  check(turned && same(Array.from(fE1.controls), Array.from(fE0.controls)) && sE1.undo === sp.undo + 1,
    `pivot individual origins on EBFs: R Z 45 turns each selected frame about its own centre, the centres stay (one undo step: ${sp.undo} -> ${sE1.undo})`);
  await page.selectOption('[name=tf-pivot]', 'median');
  await ed(() => window.ffdEditor.select([]));
}
