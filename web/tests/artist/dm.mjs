// Artist stage "dm": direct manipulation as an artist expects it, and several
// meshes in one session (issue 21).
//  (a) pins hard, drag soft: eight pins hold a Bernstein lattice of eight
//      control points; a ninth vertex dragged with the mouse comes up short,
//      the pins stay exactly put, the page says "Drag short by …";
//  (b) Ctrl+click in the Controls tool toggles the selection and never pins;
//  (c) Esc during a mesh drag, then the mouse released: no page error, the
//      mesh back where it was;
//  (d) the elephant added to the bunny's session, a lattice around both, a
//      control dragged: both meshes move; the bunny hidden, an elephant vertex
//      dragged; each mesh's file replayed alone with `ffd deform` gives its
//      range of the frame, and its export alone is that replay.

import path from 'node:path';
import { writeFile } from 'node:fs/promises';
import {
  page, ed, check, must, note, shot, settle, state, frame, api, run, FFD, TMP, click,
  createViaPanel, pickableControls, visibleVertices, readObjVertices, pointDist, consoleErrors,
} from '../harness.mjs';

async function open(name) {
  await page.click('#panel button[title="Refresh the file list"]');
  await page.waitForFunction((n) => [...document.querySelectorAll('select[name=mesh-file] option')].some((o) => o.value === n), name, { timeout: 10000 });
  await page.selectOption('select[name=mesh-file]', name);
  await page.click('#panel button:text-is("Open")');
  await page.waitForFunction((n) => window.ffdEditor.state && window.ffdEditor.state.mesh.name === n
    && (window.ffdEditor.state.meshes || []).length <= 1 && window.ffdEditor.state.undo === 0, name, { timeout: 20000 });
  await settle();
}

/** Visible vertices spread over the screen: greedy farthest-point picks. */
function spread(verts, k) {
  const out = [verts[0]];
  while (out.length < k && out.length < verts.length) {
    let best = null, bd = -1;
    for (const v of verts) {
      const d = Math.min(...out.map((o) => Math.hypot(o.x - v.x, o.y - v.y)));
      if (d > bd) { bd = d; best = v; }
    }
    out.push(best);
  }
  return out;
}

/** Replays the session's rig on one mesh file with `ffd deform`; max |diff| to the frame's range. */
async function replayMesh(file, first, what, tol = 1e-4) {
  const rig = await api('GET', '/api/rig');
  const rigFile = path.join(TMP, `dm-rig-${file}.json`);
  await writeFile(rigFile, JSON.stringify(rig));
  const out = path.join(TMP, `dm-replay-${file}.obj`);
  await run(FFD, ['deform', path.join(TMP, file), '-o', out, '--rig', rigFile]);
  const v = await readObjVertices(out);
  const f = await frame();
  let d = 0;
  for (let i = 0; i < v.length; i++) d = Math.max(d, Math.abs(v[i] - f.positions[3 * first + i]));
  check(d < tol, `(d) ${what}: ffd deform ${file} --rig alone gives its range of the frame (max |diff| ${d.toExponential(2)})`);
  return v;
}

export async function stage() {
  const errors0 = consoleErrors.length;
  await open('bunny.obj');

  // (a) pins hard, drag soft -------------------------------------------------
  await page.selectOption('select[name=method]', 'lattice');
  await page.selectOption('select[name=basis]', 'bernstein');
  const st0 = await createViaPanel('lattice', { 'res-lattice-0': 2, 'res-lattice-1': 2, 'res-lattice-2': 2 });
  must(st0.method === 'lattice' && st0.controls.count === 8, `(a) a Bernstein lattice of 2 x 2 x 2 control points (${st0.controls.count})`);
  await page.keyboard.press('m');
  const verts = await visibleVertices();
  must(verts.length >= 12, `(a) ${verts.length} visible vertices to pin and drag`);
  const picks = spread(verts, 9);
  const dragged = picks.pop();
  for (const p of picks) { await click(p, ['Alt']); await settle(); }
  let s = await state();
  check(s.pins.length === 8, `(a) Alt+click in the Mesh tool pinned 8 vertices (${s.pins.length})`);
  const diag = Math.hypot(...s.mesh.max.map((x, i) => x - s.mesh.min[i]));
  const before = (await frame()).positions.slice();
  // drag the ninth with the mouse; the screenshot mid-drag shows what the artist sees
  await page.mouse.move(dragged.x, dragged.y);
  await page.mouse.down();
  for (let i = 1; i <= 10; i++) { await page.mouse.move(dragged.x + 7 * i, dragged.y - 5 * i); await page.waitForTimeout(25); }
  await page.waitForFunction(() => /Drag short by/.test(document.getElementById('st-dm').textContent), null, { timeout: 10000 }).catch(() => {});
  await shot('artist-dm-pins-hard-drag-soft');
  const live = await ed(() => ({ status: document.getElementById('st-dm').textContent, title: document.getElementById('st-dm').title, label: [...document.querySelectorAll('.pin-label.drag-short')].map((e) => e.textContent) }));
  await page.mouse.up();
  await settle();
  s = await state();
  const worstPin = Math.max(...s.pins.map((p) => p.residual));
  check(worstPin <= 1e-9 * diag, `(a) every pin held exactly during the over-constrained drag (max pin residual ${worstPin.toExponential(2)}, diagonal ${diag.toFixed(2)})`);
  check(s.manip && s.manip.pins_met === true && s.manip.drag_residual > 1e-3 * diag,
    `(a) state.manip: pins met, the drag short by ${s.manip && (+s.manip.drag_residual).toPrecision(3)}`);
  check(/^Drag short by \d/.test(live.status) && /pins stay exactly/.test(live.title), `(a) the status bar says "${live.status}" with a plain-words tooltip`);
  check(live.label.some((t) => /^short by/.test(t)), `(a) the dragged point's label says "${live.label[0] || ''}"`);
  const panelSays = await ed(() => document.getElementById('dm-shortfall') && document.getElementById('dm-shortfall').textContent);
  check(/Drag short by/.test(panelSays || ''), `(a) the panel's direct-manipulation section says "${panelSays}"`);
  let moved = 0;
  const after = (await frame()).positions;
  for (const p of picks) moved = Math.max(moved, pointDist(after, p.v, before));
  check(moved <= 1e-5 * diag, `(a) the pinned vertices did not slide (max ${moved.toExponential(2)})`);

  // (b) Ctrl+click in the Controls tool: selection, never a pin ---------------
  await page.keyboard.press('c');
  await ed(() => window.ffdEditor.editor.setControlsVisible(true));
  await settle();
  const pins0 = (await state()).pins.length;
  const meshSpot = verts.find((v) => !picks.includes(v) && v !== dragged) || verts[0];
  await click(meshSpot, ['Control']);
  await page.waitForTimeout(300);
  await settle();
  check((await state()).pins.length === pins0, `(b) Ctrl+click on the mesh in the Controls tool pinned nothing (${pins0} pins)`);
  const corners = await pickableControls([...Array(8).keys()]);
  if (check(corners.length >= 2, `(b) two control points to Ctrl+click (${corners.length} pickable)`)) {
    const [a, b] = corners;
    await ed(() => window.ffdEditor.select([]));
    await click(a, ['Control']);
    await click(b, ['Control']);
    const both = await ed(() => window.ffdEditor.selection);
    await click(b, ['Control']); // again: out of the selection (the gizmo sits between them)
    const one = await ed(() => window.ffdEditor.selection);
    check(both.length === 2 && both.includes(a.id) && both.includes(b.id) && one.length === 1 && one[0] === a.id,
      `(b) Ctrl+click toggles control points in and out of the selection (${JSON.stringify(both)} then ${JSON.stringify(one)})`);
    check((await state()).pins.length === pins0, '(b) still no new pin');
  }

  // (c) Esc during a mesh drag, then the mouse released -----------------------
  await page.click('text=Unpin all');
  await settle();
  await page.keyboard.press('m');
  const rest = (await frame()).positions.slice();
  const v = verts[Math.floor(verts.length / 2)];
  const errors1 = consoleErrors.length;
  await page.mouse.move(v.x, v.y);
  await page.mouse.down();
  for (let i = 1; i <= 6; i++) { await page.mouse.move(v.x + 8 * i, v.y + 4 * i); await page.waitForTimeout(25); }
  await page.waitForFunction(() => window.ffdEditor.dragging, null, { timeout: 5000 }).catch(() => {});
  await page.keyboard.press('Escape');
  await page.waitForTimeout(100);
  await page.mouse.move(v.x + 70, v.y + 40);
  await page.mouse.up();
  await settle();
  const back = (await frame()).positions;
  let diff = 0;
  for (let i = 0; i < rest.length; i++) diff = Math.max(diff, Math.abs(back[i] - rest[i]));
  check(consoleErrors.length === errors1, `(c) Esc mid-drag then mouse up: no page error (${consoleErrors.slice(errors1).join(' | ') || 'none'})`);
  check((await state()).drag === null && diff < 1e-6, `(c) the drag is cancelled and the mesh is back (max |diff| ${diff.toExponential(2)})`);

  // (d) several meshes: the elephant joins the bunny's session ----------------
  await page.keyboard.press('c');
  await page.click('#panel button[title="Refresh the file list"]');
  await page.waitForFunction(() => [...document.querySelectorAll('select[name=mesh-add-file] option')].some((o) => o.value === 'elephant.off'), null, { timeout: 10000 });
  await page.selectOption('select[name=mesh-add-file]', 'elephant.off');
  await page.click('#panel button:text-is("+ Add")');
  await page.waitForFunction(() => (window.ffdEditor.state.meshes || []).length === 2, null, { timeout: 20000 });
  await settle();
  s = await state();
  const [bunny, elephant] = s.meshes;
  check(bunny.name === 'bunny.obj' && elephant.name === 'elephant.off' && elephant.first === bunny.vertices
    && s.mesh.vertices === bunny.vertices + elephant.vertices,
  `(d) "Add mesh": the session holds bunny.obj (${bunny.vertices} v) and elephant.off (${elephant.vertices} v from ${elephant.first})`);
  const listed = await ed(() => [...document.querySelectorAll('.mesh-list .item .name')].map((e) => e.textContent));
  check(listed.join() === 'bunny.obj,elephant.off', `(d) the panel lists both meshes (${listed.join(', ')})`);
  await page.selectOption('select[name=basis]', 'bspline');
  await createViaPanel('lattice', { 'res-lattice-0': 4, 'res-lattice-1': 4, 'res-lattice-2': 4 });
  s = await state();
  check(s.controls.count === 64, `(d) a 4 x 4 x 4 lattice around both meshes (${s.controls.count} control points)`);
  const rest2 = (await frame()).positions.slice();
  // the control nearest the elephant (inside the bunny's base) moves both
  const c = await ed(([first, count]) => {
    const e = window.ffdEditor.editor;
    const p = e.vp.geometry.attributes.position.array;
    const ctr = [0, 0, 0];
    for (let i = first; i < first + count; i++) for (let a = 0; a < 3; a++) ctr[a] += p[3 * i + a] / count;
    const ids = [...e.controlsView.visibleIds];
    const v3 = e.controlsView.position(ids[0]).clone();
    return ids.map((id) => { e.controlsView.position(id, v3); return { id, d: Math.hypot(v3.x - ctr[0], v3.y - ctr[1], v3.z - ctr[2]) }; })
      .sort((a, b) => a.d - b.d).map((o) => o.id);
  }, [elephant.first, elephant.vertices]);
  const targets = await pickableControls(c.slice(0, 16));
  must(targets.length > 0, '(d) a control near the elephant to drag');
  const t = targets[0];
  await ed(() => window.ffdEditor.select([]));
  await page.mouse.move(t.x, t.y);
  await page.mouse.down();
  for (let i = 1; i <= 10; i++) { await page.mouse.move(t.x + 6 * i, t.y - 9 * i); await page.waitForTimeout(25); }
  await page.mouse.up();
  await settle();
  const f2 = (await frame()).positions;
  let mb = 0, me = 0;
  for (let i = 0; i < bunny.vertices; i++) mb = Math.max(mb, pointDist(f2, i, rest2));
  for (let i = elephant.first; i < elephant.first + elephant.vertices; i++) me = Math.max(me, pointDist(f2, i, rest2));
  check(mb > 1e-3 * diag && me > 1e-3, `(d) dragging control ${t.id} moved both meshes (bunny by up to ${mb.toPrecision(3)}, elephant by up to ${me.toPrecision(3)})`);
  await shot('artist-dm-two-meshes');
  await replayMesh('bunny.obj', 0, 'lattice, bunny');
  const ev = await replayMesh('elephant.off', elephant.first, 'lattice, elephant');
  // the elephant exported alone is that replay
  const exp = await fetch(`${(await page.evaluate(() => location.origin))}/api/export?mesh=1&format=obj`).then((r) => r.text());
  const xs = exp.split('\n').filter((l) => l.startsWith('v ')).flatMap((l) => l.trim().split(/\s+/).slice(1, 4).map(Number));
  let dx = xs.length === ev.length ? 0 : Infinity;
  for (let i = 0; dx !== Infinity && i < xs.length; i++) dx = Math.max(dx, Math.abs(xs[i] - ev[i]));
  check(dx < 1e-5, `(d) GET /api/export?mesh=1 is the elephant alone, deformed (${xs.length / 3} vertices, max |diff| to the replay ${dx.toExponential(2)})`);

  // hide the bunny (the view only), drag an elephant vertex with the Mesh tool
  await page.uncheck('input[name=mesh-visible-0]');
  await page.waitForTimeout(200);
  await ed(() => window.ffdEditor.editor.setControlsVisible(false));
  await page.click('.mesh-list .item[data-mesh="1"] button[title^="Frame this mesh"]');
  await page.keyboard.press('m');
  const seen = await visibleVertices();
  const ev2 = seen.filter((x) => x.v >= elephant.first);
  const onlyElephant = seen.every((x) => x.v >= elephant.first);
  check(onlyElephant && ev2.length > 0, `(d) with the bunny hidden only elephant vertices are picked (${ev2.length} visible)`);
  if (ev2.length) {
    const d0 = (await frame()).positions.slice();
    const w = ev2[Math.floor(ev2.length / 3)];
    await page.mouse.move(w.x, w.y);
    await page.mouse.down();
    for (let i = 1; i <= 8; i++) { await page.mouse.move(w.x + 5 * i, w.y - 4 * i); await page.waitForTimeout(25); }
    await page.mouse.up();
    await settle();
    const d1 = (await frame()).positions;
    check(pointDist(d1, w.v, d0) > 1e-4, `(d) the dragged elephant vertex ${w.v} moved ${pointDist(d1, w.v, d0).toPrecision(3)}`);
    await shot('artist-dm-elephant-alone');
    await replayMesh('bunny.obj', 0, 'direct manipulation, bunny');
    await replayMesh('elephant.off', elephant.first, 'direct manipulation, elephant');
  }
  await page.check('input[name=mesh-visible-0]');
  await ed(() => window.ffdEditor.editor.setControlsVisible(true));
  await page.keyboard.press('c');
  await page.keyboard.press('f');
  await shot('artist-dm-both-visible');
  check(consoleErrors.length === errors0, `(dm) no page error in the stage (${consoleErrors.slice(errors0).join(' | ') || 'none'})`);
  // leave a usable page: the bunny alone again
  await open('bunny.obj');
  note(`dm stage done; pins ${s.pins.length}`);
}
