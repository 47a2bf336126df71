// Artist stage 'perf' (issue 21, "Live on big meshes"): a lattice drag on
// elephant.off sends delta frames (only the vertices that moved, with the
// normals around them, docs/editor.md "Delta frames"); after the drag the
// drawn geometry equals the server's full frame bit for bit and the drawn
// normals equal normals recomputed from scratch. A long step shows the busy
// overlay with its running time.

import {
  check, must, note, page, ed, shot, settle, mouseDrag, createViaPanel, pickableControls, gizmoArrow, frame, state,
} from '../harness.mjs';

/** Opens a mesh of the root through the panel (select + Open). */
async function openMesh(name) {
  await page.selectOption('select[name=mesh-file]', name);
  await page.click('#panel button:text-is("Open")');
  await page.waitForFunction((n) => window.ffdEditor.state && window.ffdEditor.state.mesh.name === n, name, { timeout: 60000 });
  await settle();
}

/** Area-weighted vertex normals of the drawn triangles, from scratch (double sums). */
function normalsFromScratch(p, tri) {
  const n = new Float64Array(p.length);
  for (let f = 0; f < tri.length; f += 3) {
    const a = 3 * tri[f], b = 3 * tri[f + 1], c = 3 * tri[f + 2];
    const e1 = [p[b] - p[a], p[b + 1] - p[a + 1], p[b + 2] - p[a + 2]];
    const e2 = [p[c] - p[a], p[c + 1] - p[a + 1], p[c + 2] - p[a + 2]];
    const x = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
    for (const v of [a, b, c]) { n[v] += x[0]; n[v + 1] += x[1]; n[v + 2] += x[2]; }
  }
  for (let i = 0; i < n.length; i += 3) {
    const l = Math.hypot(n[i], n[i + 1], n[i + 2]);
    if (l > 0) { n[i] /= l; n[i + 1] /= l; n[i + 2] /= l; } else { n[i] = 0; n[i + 1] = 1; n[i + 2] = 0; }
  }
  return n;
}

/** The drawn geometry equals GET /api/frame bit for bit, its normals those recomputed from scratch. */
async function drawnIsServerFrame(when) {
  const f1 = await frame();
  const drawn = await ed(() => {
    const g = window.ffdEditor.editor.vp.geometry;
    return {
      bits: Array.from(new Uint32Array(g.attributes.position.array.buffer.slice(0))),
      normals: Array.from(g.attributes.normal.array),
      index: Array.from(g.index.array),
      revision: window.ffdEditor.lastFrameRevision,
    };
  });
  const serverBits = new Uint32Array(f1.positions.buffer.slice(f1.positions.byteOffset, f1.positions.byteOffset + f1.positions.byteLength));
  let differ = 0;
  for (let i = 0; i < serverBits.length; i++) if (serverBits[i] !== drawn.bits[i]) differ++;
  check(drawn.bits.length === serverBits.length && differ === 0 && drawn.revision === f1.revision,
    `perf: ${when}, the drawn positions equal GET /api/frame bit for bit (${differ} of ${serverBits.length} floats differ; rev ${drawn.revision} / ${f1.revision})`);
  const p = new Float32Array(new Uint32Array(drawn.bits).buffer);
  const ref = normalsFromScratch(p, drawn.index);
  let worst = 0;
  for (let i = 0; i < ref.length; i++) worst = Math.max(worst, Math.abs(ref[i] - drawn.normals[i]));
  check(worst <= 1e-5, `perf: ${when}, the drawn normals equal normals recomputed from scratch (max |diff| ${worst.toExponential(2)})`);
}

export async function stage() {
  await openMesh('elephant.off');
  const V = (await state()).mesh.vertices;
  must(V === 2775, `perf: elephant.off open (${V} vertices)`);
  // a fine lattice: one control moves a part of the mesh
  const st = await createViaPanel('lattice', { 'res-lattice-0': 7, 'res-lattice-1': 7, 'res-lattice-2': 7 });
  must(st.method === 'lattice' && st.controls.count === 343, `perf: lattice 7x7x7 created via the panel (${st.controls.count} controls)`);
  // an upper control the mouse can pick alone
  const cands = [];
  for (const j of [5, 4]) for (const i of [3, 2, 4, 1, 5]) for (const k of [3, 2, 4]) cands.push((i * 7 + j) * 7 + k);
  // then any other: with X-ray off only the handles in front of the mesh pick (the view's up axis decides which are 'upper')
  for (let c = 0; c < 343; c++) if (!cands.includes(c)) cands.push(c);
  const pickable = await pickableControls(cands);
  must(pickable.length > 0, `perf: a pickable control among ${cands.length} candidates (${pickable.length})`);
  const ctl = pickable[0];
  await page.mouse.click(ctl.x, ctl.y);
  await page.waitForTimeout(350); // the gizmo is placed on the next frame
  const sel = await ed(() => window.ffdEditor.selection);
  check(sel.length === 1 && sel[0] === ctl.id, `perf: clicking control ${ctl.id} selects it (${JSON.stringify(sel)})`);
  const arrow = await gizmoArrow('Y');
  must(!!arrow, 'perf: the gizmo\'s Y arrow found on screen');

  // record the drag's frames as the page receives them
  await ed(() => {
    const e = window.ffdEditor.editor;
    const log = [];
    window.__perfFrames = log;
    e.onDragFrame = function onDragFrame(f, ms) {
      log.push({ delta: !!f.delta, K: f.delta ? f.K : f.V, M: f.delta ? f.M : 0, base: f.base, rev: f.revision });
      return Object.getPrototypeOf(e).onDragFrame.call(e, f, ms);
    };
  });
  const rev0 = (await state()).revision;
  await mouseDrag(arrow.from, { x: arrow.from.x - arrow.dir.x * 110, y: arrow.from.y - arrow.dir.y * 110 }, 14);
  const log = await ed(() => { delete window.ffdEditor.editor.onDragFrame; return window.__perfFrames; });
  const st1 = await state();
  check(st1.revision > rev0 && st1.drag === null, `perf: the drag ended (rev ${rev0} -> ${st1.revision})`);
  const deltas = log.filter((f) => f.delta);
  const sparse = deltas.filter((f) => f.K > 0 && f.K < V);
  note(`drag frames: ${log.length}, delta ${deltas.length}; changed vertices per delta ${deltas.map((f) => f.K).join(' ')}`);
  check(log.length > 0 && deltas.length === log.length, `perf: every drag step came as a delta frame (${deltas.length} of ${log.length})`);
  check(sparse.length > 0, `perf: the deltas carry a part of the mesh (${sparse.length} with 0 < changed < ${V})`);

  await drawnIsServerFrame('after the drag');
  await shot('artist-perf-delta-drag');

  // undo (Ctrl+Z): the page asks for the frame as a delta against the one it holds
  await ed(() => {
    const vp = window.ffdEditor.editor.vp;
    window.__perfDeltas = [];
    vp.applyDelta = function applyDelta(f, held) {
      window.__perfDeltas.push({ K: f.K, ok: f.base === held });
      return Object.getPrototypeOf(vp).applyDelta.call(vp, f, held);
    };
  });
  const undo0 = (await state()).undo;
  await page.mouse.move(5, 300); // over the viewport's empty corner, not a text field
  await page.keyboard.press('Control+z');
  await page.waitForFunction((u) => window.ffdEditor.state.undo < u, undo0, { timeout: 10000 });
  await settle();
  const undone = await ed(() => { delete window.ffdEditor.editor.vp.applyDelta; return window.__perfDeltas; });
  check(undone.length >= 1 && undone.every((d) => d.ok) && undone.some((d) => d.K > 0 && d.K < V),
    `perf: Ctrl+Z brings the frame back as a delta (${undone.map((d) => d.K).join(', ')} vertices changed)`);
  await drawnIsServerFrame('after undo');

  // a long step (the export, held back 1.8 s here): the busy overlay names it and shows its running time
  const isExport = (u) => u.pathname === '/api/export';
  await page.route(isExport, async (route) => { await new Promise((r) => setTimeout(r, 1800)); await route.continue(); });
  // the stage and fraction as GET /api/progress reports a long library stage
  // (test_serve.sh checks the real endpoint during a T-spline refinement)
  const isProgress = (u) => u.pathname === '/api/progress';
  await page.route(isProgress, (route) => route.fulfill({ contentType: 'application/json',
    body: JSON.stringify({ op: 'export', seconds: 1, stage: 'writing', fraction: 0.42, stage_seconds: 0.5 }) }));
  const download = page.waitForEvent('download', { timeout: 30000 });
  await page.selectOption('select[name=export-encoding]', 'ascii');
  await page.click('#panel button[name=export-download]');
  await page.waitForFunction(() => !document.getElementById('busy').hidden, null, { timeout: 5000 });
  await page.waitForTimeout(900);
  const busy = await ed(() => ({ label: document.getElementById('busy-label').textContent, time: document.getElementById('busy-time').textContent }));
  const secs2 = parseFloat(busy.time.split(' · ').pop());
  check(/download/i.test(busy.label) && /^writing 42% · \d+\.\d s$/.test(busy.time) && secs2 >= 0.9,
    `perf: the busy overlay shows the step, its stage and fraction and its running time ("${busy.label}" ${busy.time})`);
  await shot('artist-perf-busy', 0);
  const dl = await download;
  const dlPath = await dl.path();
  check(!!dlPath && /elephant.*deformed/.test(dl.suggestedFilename()), `perf: the export downloads as ${dl.suggestedFilename()}`);
  await page.unroute(isExport);
  await page.unroute(isProgress);
  await page.waitForFunction(() => document.getElementById('busy').hidden, null, { timeout: 30000 });
  await settle();

  // a big mesh's full frames: normals from the Web Worker (normals.js; here
  // for every mesh), then deltas again; the drawn normals stay right
  await ed(() => { window.ffdEditor.editor.vp.workerMinTriangles = 0; });
  await openMesh('bunny.obj');
  await openMesh('elephant.off');
  must(await ed(() => !!window.ffdEditor.editor.vp.normalsWorker), 'perf: the normals worker runs for the opened mesh');
  const st2 = await createViaPanel('lattice', { 'res-lattice-0': 3, 'res-lattice-1': 3, 'res-lattice-2': 3 });
  must(st2.controls.count === 27, `perf: lattice 3x3x3 created (${st2.controls.count} controls)`);
  const pick2 = await pickableControls([22, 21, 23, 19, 25, 13]);
  must(pick2.length > 0, `perf: a pickable control of the 3x3x3 lattice (${pick2.length})`);
  await page.mouse.click(pick2[0].x, pick2[0].y);
  await page.waitForTimeout(350);
  const arrow2 = await gizmoArrow('X');
  must(!!arrow2, 'perf: the gizmo\'s X arrow found on screen (3x3x3)');
  await ed(() => { window.__perfKinds = []; const e = window.ffdEditor.editor; e.onDragFrame = function onDragFrame(f, ms) { window.__perfKinds.push(f.delta ? 'delta' : 'full'); return Object.getPrototypeOf(e).onDragFrame.call(e, f, ms); }; });
  await mouseDrag(arrow2.from, { x: arrow2.from.x + arrow2.dir.x * 80, y: arrow2.from.y + arrow2.dir.y * 80 }, 10);
  const kinds = await ed(() => { delete window.ffdEditor.editor.onDragFrame; return window.__perfKinds; });
  check(kinds.length > 0 && kinds.every((k) => k === 'full'), `perf: a 3x3x3 control moves most of the mesh: full frames, smaller than deltas (${kinds.join(' ')})`);
  await page.waitForFunction(() => !window.ffdEditor.editor.vp.normalsWorker.pending, null, { timeout: 10000 });
  await drawnIsServerFrame('after full frames with worker normals');
  await shot('artist-perf-worker-normals');
  await ed(() => { window.ffdEditor.editor.vp.workerMinTriangles = 150000; });

  // leave the page as it started
  await openMesh('bunny.obj');
}
