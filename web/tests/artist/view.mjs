// Artist stage "view" (issue 21): orientation (a Z-up CAD part stands up, a
// Y-up scan opens seen from the front), view presets by keyboard (numpad
// 1 / 3 / 7, Ctrl, 5, numpad ., Home), depth (box select takes only the
// handles in front of the mesh, X-ray takes the hidden ones too; checked
// against an independent ray cast), hover highlight, select layer / row, and
// PB-FFD ROIs drawn for the selection only.

import path from 'node:path';
import {
  page, ed, check, must, note, shot, settle, state, click, createViaPanel, pickableControls, OUT,
} from '../harness.mjs';

/** A screenshot of the view only, around the model (the pictures of docs/editor.md). */
async function viewShot(name, clip) {
  const file = path.join(OUT, `${name}.png`);
  await page.waitForTimeout(150);
  await page.screenshot({ path: file, clip });
  note(`screenshot ${file}`);
}

async function openMesh(name) {
  await page.click('#panel button[title="Refresh the file list"]');
  await page.waitForFunction((n) => [...document.querySelectorAll('select[name=mesh-file] option')].some((o) => o.value === n), name, { timeout: 10000 });
  await page.selectOption('select[name=mesh-file]', name);
  await page.click('#panel button:text-is("Open")');
  await page.waitForFunction((n) => window.ffdEditor.state && window.ffdEditor.state.mesh.name === n, name, { timeout: 20000 });
  await settle();
  await page.waitForTimeout(100);
}

/** The camera: unit direction target -> camera, screen-up in world, ortho, up axis. */
const camera = () => ed(() => {
  const vp = window.ffdEditor.editor.vp;
  const cam = vp.camera;
  cam.updateMatrixWorld();
  const d = cam.position.clone().sub(vp.orbit.target).normalize();
  const up = cam.up.clone().set(0, 1, 0).applyQuaternion(cam.quaternion);
  return { dir: d.toArray(), screenUp: up.toArray(), ortho: !!cam.isOrthographicCamera, up: vp.up, target: vp.orbit.target.toArray() };
});
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const near = (a, b, t = 0.01) => dot(a, b) >= 1 - t;

/** Whether every corner of the mesh's bounding box projects inside the canvas. */
const wholeInView = () => ed(() => {
  const e = window.ffdEditor.editor;
  const vp = e.vp;
  vp.updateBounds();
  const b = vp.geometry.boundingBox;
  const r = vp.renderer.domElement.getBoundingClientRect();
  for (let k = 0; k < 8; k++) {
    const p = b.min.clone();
    if (k & 1) p.x = b.max.x; if (k & 2) p.y = b.max.y; if (k & 4) p.z = b.max.z;
    const s = e.screenOf(p);
    if (s.x < r.left || s.x > r.right || s.y < r.top || s.y > r.bottom) return false;
  }
  return true;
});

/**
 * Controls hidden behind the mesh by an independent test: a ray from the
 * camera to the handle hits the mesh (three's ray cast) before it.
 */
const occludedByRay = (ids) => ed((list) => {
  const e = window.ffdEditor.editor;
  const vp = e.vp;
  const T = window.ffdEditor.THREE;
  const cam = vp.camera;
  const ray = new T.Raycaster();
  const out = [];
  for (const id of list) {
    const p = e.controlsView.position(id);
    const o = cam.isOrthographicCamera
      ? p.clone().sub(cam.getWorldDirection(new T.Vector3()).multiplyScalar(cam.far)) : cam.position.clone();
    const d = p.clone().sub(o);
    const len = d.length();
    ray.set(o, d.normalize());
    ray.far = len - 0.006 * vp.diag; // the editor's DEPTH_TOLERANCE (controls.js)
    if (ray.intersectObject(vp.mesh, false).length) out.push(id);
  }
  return out;
}, ids);

/** Screen rectangle (container px) around the given controls, with a margin. */
const screenRect = (ids, margin = 10) => ed(([list, m]) => {
  const e = window.ffdEditor.editor;
  let x0 = Infinity, y0 = Infinity, x1 = -Infinity, y1 = -Infinity;
  for (const id of list) {
    const s = window.ffdEditor.screenOfControl(id);
    x0 = Math.min(x0, s.x); y0 = Math.min(y0, s.y); x1 = Math.max(x1, s.x); y1 = Math.max(y1, s.y);
  }
  const inBox = e.controlsView.visibleIds.filter((id) => {
    const s = window.ffdEditor.screenOfControl(id);
    return s.x >= x0 - m && s.x <= x1 + m && s.y >= y0 - m && s.y <= y1 + m;
  });
  return { from: { x: x0 - m, y: y0 - m }, to: { x: x1 + m, y: y1 + m }, inBox };
}, [ids, margin]);

async function boxSelect(r) {
  await page.keyboard.press('b');
  await page.mouse.move(r.from.x, r.from.y);
  await page.mouse.down();
  for (let i = 1; i <= 8; i++) {
    await page.mouse.move(r.from.x + (r.to.x - r.from.x) * i / 8, r.from.y + (r.to.y - r.from.y) * i / 8);
    await page.waitForTimeout(15);
  }
  await page.mouse.up();
  await page.waitForTimeout(50);
  return ed(() => window.ffdEditor.selection);
}

export async function stage() {
  // (a) a Z-up CAD part: detected Z-up, it stands on the grid
  await openMesh('hinge.stl');
  let cam = await camera();
  check(cam.up === 'z' && (await ed(() => window.ffdEditor.editor.opts.up)) === 'z', `(view) hinge.stl opened Z-up (${await ed(() => window.ffdEditor.editor.viewNav.upReason)})`);
  check(near(cam.screenUp, [0, 0, 1], 0.05) && near(cam.dir, [0, -1, 0]), `(view) hinge seen from the front (-Y), world Z up on the screen (dir ${cam.dir.map((x) => x.toFixed(2))})`);
  check(await wholeInView(), '(view) the whole hinge in view');
  const grid = await ed(() => { const g = window.ffdEditor.editor.vp.grid; return { visible: g.visible, z: g.position.z, rx: g.rotation.x }; });
  check(grid.visible && Math.abs(grid.rx - Math.PI / 2) < 1e-6 && Math.abs(grid.z) < 1e-3, '(view) the grid lies on the plane z = 0 the hinge rests on');
  await shot('artist-view-hinge-zup');
  await viewShot('artist-view-hinge-zup-view', { x: 100, y: 250, width: 760, height: 480 });

  // the detection rule on boxes of each kind (docs/editor.md "Up axis")
  const rule = await ed(() => {
    const d = (n, min, max) => window.ffdEditor.editor.viewNav.constructor.detectUp(n, min, max).axis;
    return [d('part.stl', [0, -5, 0], [50, 25, 10]), d('part.stl', [0, 0, -3], [5, 9, 3]), d('scan.ply', [-1, 0, -1], [1, 2, 1]),
      d('part.ply', [-1, -1, 0], [1, 1, 3]), d('cow.off', [-0.5, -0.3, -0.16], [0.5, 0.3, 0.16]), d('model.glb', [-1, -1, 0], [1, 1, 3]),
      d('bunny.obj', [-5, 0, -3.7], [5, 9.7, 3.8])].join('');
  });
  check(rule === 'zyyzyyy', `(view) up-axis rule: STL z unless resting on y = 0; PLY/OFF/OBJ y unless resting on z = 0; glTF y (${rule})`);

  // (b) bunny.obj (Y-up): opened from the front, whole
  await openMesh('bunny.obj');
  cam = await camera();
  check(cam.up === 'y' && near(cam.dir, [0, 0, 1]) && near(cam.screenUp, [0, 1, 0], 0.05), `(view) bunny.obj opened Y-up, from the front: camera on +Z looking at -Z (dir ${cam.dir.map((x) => x.toFixed(2))})`);
  check(await wholeInView(), '(view) the whole bunny in view');
  await shot('artist-view-bunny-front');

  // (c) view presets by keyboard on the canvas
  const canvas = await ed(() => { const r = window.ffdEditor.editor.vp.renderer.domElement.getBoundingClientRect(); return { x: r.left + r.width / 2, y: r.top + r.height / 2 }; });
  await page.mouse.move(canvas.x, canvas.y);
  const presets = [['Numpad3', [1, 0, 0], 'right'], ['Numpad7', [0, 1, 0], 'top'], ['Control+Numpad1', [0, 0, -1], 'back'],
    ['Control+Numpad3', [-1, 0, 0], 'left'], ['Control+Numpad7', [0, -1, 0], 'bottom'], ['Digit3', [1, 0, 0], 'right (main-row 3)'], ['Numpad1', [0, 0, 1], 'front']];
  for (const [key, want, what] of presets) {
    await page.keyboard.press(key);
    cam = await camera();
    check(near(cam.dir, want, 1e-3), `(view) ${key}: ${what} view (dir ${cam.dir.map((x) => x.toFixed(3))})`);
  }
  await page.keyboard.press('Numpad6');
  cam = await camera();
  check(Math.abs(dot(cam.dir, [0, 0, 1]) - Math.cos(Math.PI / 12)) < 1e-3 && cam.dir[0] > 0 && Math.abs(cam.dir[1]) < 1e-6, `(view) Numpad6: the view turned 15° about the up axis, to the right (dir ${cam.dir.map((x) => x.toFixed(3))})`);
  await page.keyboard.press('Numpad8');
  cam = await camera();
  check(Math.abs(cam.dir[1] - Math.sin(Math.PI / 12)) < 1e-3, `(view) Numpad8: 15° up (dir ${cam.dir.map((x) => x.toFixed(3))})`);
  await page.keyboard.press('Numpad7');
  cam = await camera();
  check(near(cam.screenUp, [0, 0, -1], 1e-3), '(view) top view: the front (+Z) at the bottom of the screen');
  await page.keyboard.press('Numpad5');
  cam = await camera();
  check(cam.ortho && near(cam.dir, [0, 1, 0], 1e-3), '(view) Numpad5: orthographic, same direction');
  check(await wholeInView(), '(view) orthographic top view: the whole bunny in view');
  await shot('artist-view-bunny-top-ortho');
  // zoom in the parallel view (the wheel changes its zoom), then back to
  // perspective: the zoom becomes a dolly, the model keeps its size on screen
  // (the screen length of a segment of the model's size through the orbit target, along X)
  const width = () => ed(() => {
    const e = window.ffdEditor.editor;
    const t = e.vp.orbit.target;
    const d = e.vp.diag / 2;
    return e.screenOf(t.clone().setX(t.x + d)).x - e.screenOf(t.clone().setX(t.x - d)).x;
  });
  await page.mouse.move(canvas.x, canvas.y);
  const w0 = await width();
  await page.mouse.wheel(0, -300);
  await page.waitForTimeout(150);
  const wOrtho = await width();
  await page.keyboard.press('Numpad5');
  const wPersp = await width();
  check(wOrtho > 1.1 * w0 && Math.abs(wPersp / wOrtho - 1) < 0.02, `(view) the ortho zoom carried into perspective: the model's size ${wOrtho.toFixed(0)} px at the target in both`);
  await page.keyboard.press('Home');
  cam = await camera();
  check(!cam.ortho && await wholeInView() && (await ed(() => window.ffdEditor.editor.vp.camera.near)) > 0, '(view) Numpad5 again: perspective, the whole bunny in view');
  await page.keyboard.press('Numpad1');

  // (d) up-axis override from the View section, remembered per mesh
  await page.click('#panel button[name="view-up-z"]');
  cam = await camera();
  const stored = await ed(() => window.localStorage.getItem('ffd.view.up:bunny.obj'));
  check(cam.up === 'z' && stored === 'z' && near(cam.dir, [0, -1, 0]), '(view) Up: Z chosen in the panel: camera up Z, front view -Y, remembered for bunny.obj');
  await openMesh('bunny.obj');
  cam = await camera();
  check(cam.up === 'z' && /your choice/.test(await ed(() => window.ffdEditor.editor.viewNav.upReason)), '(view) bunny.obj opened again: Z-up, the remembered choice');
  await page.click('#panel button[name="view-up-y"]');
  cam = await camera();
  check(cam.up === 'y' && near(cam.dir, [0, 0, 1]) && (await ed(() => window.localStorage.getItem('ffd.view.up:bunny.obj'))) === 'y', '(view) Up: Y again');

  await page.click('#panel button[name="view-flip-front"]');
  cam = await camera();
  check(near(cam.dir, [0, 0, -1]) && (await ed(() => window.localStorage.getItem('ffd.view.front:bunny.obj'))) === '-1', '(view) ⇄ Front: the front view turned around (a model facing -Z), remembered');
  await page.keyboard.press('Numpad3');
  cam = await camera();
  check(near(cam.dir, [-1, 0, 0], 1e-3), '(view) ... and the right view follows it (-X)');
  await page.click('#panel button[name="view-flip-front"]');
  cam = await camera();
  check(near(cam.dir, [0, 0, 1]), '(view) ⇄ Front again: back to +Z');

  await page.locator('#panel button[name="view-front"]').scrollIntoViewIfNeeded();
  await shot('artist-view-panel');
  await page.uncheck('#panel input[name="view-grid"]');
  check(!(await ed(() => window.ffdEditor.editor.vp.grid.visible)), '(view) Grid off hides the ground grid');
  await page.check('#panel input[name="view-grid"]');
  check(await ed(() => window.ffdEditor.editor.vp.grid.visible), '(view) Grid on');

  // (e) lattice 5x5x5: depth-aware box select around the top layer
  await ed(() => window.ffdEditor.editor.viewNav.setXray(false));
  const st = await createViaPanel('lattice', { 'res-lattice-0': 5, 'res-lattice-1': 5, 'res-lattice-2': 5 });
  must(st.method === 'lattice' && st.controls.count === 125, '(view) lattice 5x5x5 on the bunny');
  // the artist's three-quarter view from above (an orbit drag from the front view)
  await page.keyboard.press('Numpad1');
  // (from an empty corner of the view: a press on a handle would drag it)
  const corner = await ed(() => { const r = window.ffdEditor.editor.vp.renderer.domElement.getBoundingClientRect(); return { x: r.left + 40, y: r.top + 60 }; });
  await page.mouse.move(corner.x, corner.y);
  await page.mouse.down();
  for (let i = 1; i <= 10; i++) { await page.mouse.move(corner.x - 0 * i, corner.y + 9 * i); await page.waitForTimeout(15); }
  await page.mouse.up();
  check((await state()).undo === 1, '(view) the orbit drag moved no handle');
  await settle();
  // the top layer: j = 4 (id = (i*5 + j)*5 + k)
  const top = [];
  for (let i = 0; i < 5; i++) for (let k = 0; k < 5; k++) top.push((i * 5 + 4) * 5 + k);
  const r = await screenRect(top, 8);
  const hiddenInBox = await occludedByRay(r.inBox);
  note(`box around the top layer holds ${r.inBox.length} of 125 points on screen, ${hiddenInBox.length} of them hidden by the mesh (ray cast)`);
  must(hiddenInBox.length > 0, '(view) the box around the top layer also covers handles hidden behind the mesh');
  const selOff = await boxSelect(r);
  const hiddenSel = selOff.filter((id) => hiddenInBox.includes(id));
  const visibleMissed = r.inBox.filter((id) => !hiddenInBox.includes(id) && !selOff.includes(id));
  const topVisible = top.filter((id) => !hiddenInBox.includes(id));
  check(hiddenSel.length === 0 && visibleMissed.length <= 1 && topVisible.every((id) => selOff.includes(id)),
    `(view) X-ray off: box select took the ${selOff.length} visible handles (all ${topVisible.length} visible of the top layer, ${hiddenSel.length} hidden, ${visibleMissed.length} visible missed), not the ${hiddenInBox.length} hidden`);
  await shot('artist-view-lattice-boxselect');
  await viewShot('artist-view-lattice-boxselect-view', { x: 170, y: 120, width: 620, height: 560 });
  await page.keyboard.press('Alt+KeyZ');
  check(await ed(() => window.ffdEditor.editor.opts.xray && window.ffdEditor.editor.controlsView.xray), '(view) Alt+Z: X-ray on');
  const selOn = await boxSelect(r);
  check(selOn.length === r.inBox.length && hiddenInBox.every((id) => selOn.includes(id)),
    `(view) X-ray on: the same box takes the hidden handles too (${selOn.length} of ${r.inBox.length})`);
  await shot('artist-view-lattice-xray');
  await page.keyboard.press('Alt+KeyZ');
  check(!(await ed(() => window.ffdEditor.editor.opts.xray)), '(view) Alt+Z again: X-ray off');

  // (f) hover highlight, click select, select layer / row
  const cand = await pickableControls(top);
  must(cand.length > 0, '(view) a top-layer point to point at');
  const p = cand[0];
  await page.mouse.move(p.x + 30, p.y + 30);
  await page.mouse.move(p.x, p.y, { steps: 3 });
  await page.waitForTimeout(120);
  const hov = await ed(() => ({ id: window.ffdEditor.editor.controlsView.hover, ring: window.ffdEditor.editor.controlsView.hoverMarker.visible }));
  check(hov.id === p.id && hov.ring, `(view) hover highlight on the point under the pointer (${hov.id}, ring ${hov.ring})`);
  await shot('artist-view-hover');
  await click(p);
  await page.waitForTimeout(80);
  check(JSON.stringify(await ed(() => window.ffdEditor.selection)) === JSON.stringify([p.id]), `(view) a click on a point of the selection selects it alone (${p.id})`);
  await page.click('#panel button[name="select-layer-1"]');
  let sel = await ed(() => window.ffdEditor.selection);
  check(sel.length === 25 && sel.every((id) => Math.floor(id / 5) % 5 === 4), `(view) Select layer Y: exactly the 25 points of the top layer (${sel.length})`);
  await ed((id) => window.ffdEditor.select([id]), p.id);
  await page.mouse.move(canvas.x + 200, canvas.y + 200);
  await page.keyboard.press('Shift+L');
  sel = await ed(() => window.ffdEditor.selection);
  const pj = Math.floor(p.id / 5) % 5, pk = p.id % 5;
  check(sel.length === 5 && sel.every((id) => id % 5 === pk && Math.floor(id / 5) % 5 === pj), `(view) Shift+L: the row along x (index i) through the point: 5 points (${sel.length})`);
  await ed((id) => window.ffdEditor.select([id]), p.id);
  await page.keyboard.press('l');
  sel = await ed(() => window.ffdEditor.selection);
  check(sel.length === 25, `(view) L: the layer normal to the up axis through the point (${sel.length})`);

  // (g) frame selected: numpad . centres the selection
  await ed((id) => window.ffdEditor.select([id]), p.id);
  await page.keyboard.press('NumpadDecimal');
  cam = await camera();
  const pos = await ed((id) => window.ffdEditor.editor.controlsView.position(id).toArray(), p.id);
  const diag = await ed(() => window.ffdEditor.editor.vp.diag);
  check(Math.hypot(...cam.target.map((x, i) => x - pos[i])) < 1e-6 * diag, '(view) numpad . frames the selected point (orbit target on it)');
  await shot('artist-view-frame-selected');
  await page.keyboard.press('Home');
  check(await wholeInView(), '(view) Home frames the whole bunny again');
  await ed(() => window.ffdEditor.select([]));

  // (h) PB-FFD: ROIs of the selection (and the hovered point) only, "All ROIs" on demand
  const sp = await createViaPanel('pbffd');
  must(sp.method === 'pbffd' && sp.controls.ebfs.length >= 60, `(view) PB-FFD on the bunny (${sp.controls.ebfs.length} EBFs)`);
  await page.keyboard.press('Numpad1');
  await page.mouse.move(5, 5);
  await page.waitForTimeout(100);
  const rois = () => ed(() => { const v = window.ffdEditor.editor.controlsView; return v.rois && v.rois.visible ? v.rois.count : -1; });
  check((await rois()) === 0, '(view) PB-FFD: no ROI drawn without a selection');
  const ebfCand = await pickableControls(Array.from({ length: sp.controls.ebfs.length }, (_, i) => i));
  must(ebfCand.length >= 2, '(view) two EBFs to click');
  await click(ebfCand[0]);
  await click(ebfCand[1], ['Shift']);
  await page.waitForTimeout(100);
  const two = await ed(() => window.ffdEditor.selection);
  note(`clicked EBFs ${ebfCand[0].id} at (${ebfCand[0].x.toFixed(0)}, ${ebfCand[0].y.toFixed(0)}) and ${ebfCand[1].id} at (${ebfCand[1].x.toFixed(0)}, ${ebfCand[1].y.toFixed(0)}); selection ${two}; hidden ${await ed((ids) => { const m = window.ffdEditor.editor.controlsView.occlusion(); return ids.map((i) => m[i]); }, two)}`);
  check(two.length === 2 && (await rois()) === 2, `(view) two EBFs selected: their 2 ROIs drawn (${await rois()})`);
  await shot('artist-view-pbffd-rois-selected');
  await viewShot('artist-view-pbffd-rois-selected-view', { x: 0, y: 190, width: 860, height: 560 });
  await page.check('#panel input[name="view-allRois"]');
  check((await rois()) === sp.controls.ebfs.length, `(view) All ROIs: every one drawn (${await rois()})`);
  await page.uncheck('#panel input[name="view-allRois"]');
  check((await rois()) === 2, '(view) All ROIs off: the selection\'s again');
  const shapes = await ed(() => window.ffdEditor.editor.controlsView.pointSets.map((s) => s.shape));
  check(shapes.includes('square') && shapes.includes('disc'), '(view) handle shapes: EBFs discs, curve points squares');
  await ed(() => window.ffdEditor.select([]));
  await settle();

  // (i) T-spline proxy: a layer by position (no grid indices on the proxy)
  const ts = await createViaPanel('tspline', { 'res-tspline-0': 4, 'res-tspline-1': 4, 'res-tspline-2': 4 });
  must(ts.method === 'tspline' && ts.controls.proxy.points.length > 0, `(view) T-spline 4x4x4 on the bunny (${ts.controls.proxy.points.length} proxy points)`);
  await page.keyboard.press('Numpad1');
  const tc = await pickableControls(ts.controls.proxy.points);
  must(tc.length > 0, '(view) a proxy point to click');
  await click(tc[0]);
  await page.waitForTimeout(80);
  await page.click('#panel button[name="select-layer-1"]');
  const layer = await ed((id) => {
    const e = window.ffdEditor.editor;
    const y0 = e.controlsView.position(id).y;
    const sel = window.ffdEditor.selection;
    return { n: sel.length, flat: sel.every((i) => Math.abs(e.controlsView.position(i).y - y0) <= 0.02 * e.vp.diag), shown: sel.every((i) => e.controlsView.isVisible(i)) };
  }, tc[0].id);
  check(layer.n >= 4 && layer.flat && layer.shown, `(view) T-spline: Layer Y takes the ${layer.n} proxy points at the clicked point's height`);
  await shot('artist-view-tspline-layer');
  await ed(() => window.ffdEditor.select([]));
}
