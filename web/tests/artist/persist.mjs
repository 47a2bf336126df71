// Artist stage "persist" (issue 21, "Work is never lost"): a few edits (a
// lattice, a gizmo drag, a pinned vertex in the mesh tool); the History
// section names them; a reloaded page shows the server's session; a click
// on an earlier step gives that step's frame and a click on the last one
// comes back; the server killed (SIGKILL) and started again on the same
// root resumes the autosaved session (state, pins, history), says so on
// stderr and in the page, and `ffd deform --rig` of its rig (pins in it)
// replays the frame; an autosave of another version of the mesh is not
// applied and the page says why; Re-create says it puts the mesh back at rest and is
// undone by Ctrl+Z; the Undo/Redo counts follow every change; opening
// another mesh and this one again starts anew and "Resume it" brings the
// earlier session back.

import {
  page, ed, check, must, note, shot, settle, mouseDrag, click, createViaPanel, pickableControls,
  visibleVertices, gizmoArrow, replay, state, frame, maxAbsDiff, TMP, restartServer, api,
} from '../harness.mjs';
import { existsSync, readFileSync, writeFileSync, copyFileSync } from 'node:fs';
import path from 'node:path';

async function openBunny() {
  if ((await state()).mesh.name === 'bunny.obj') return;
  await page.waitForFunction(() => [...document.querySelectorAll('select[name=mesh-file] option')].some((o) => o.value === 'bunny.obj'), null, { timeout: 10000 });
  await page.selectOption('select[name=mesh-file]', 'bunny.obj');
  await page.click('#panel button:text-is("Open")');
  await page.waitForFunction(() => window.ffdEditor.state && window.ffdEditor.state.mesh.name === 'bunny.obj', null, { timeout: 20000 });
  await settle();
}

/** The History section as the page shows it: names, the highlighted step. */
const shownHistory = () => ed(() => {
  const items = [...document.querySelectorAll('.history-list .history-step')];
  return { names: items.map((li) => li.querySelector('.name').textContent), current: items.findIndex((li) => li.classList.contains('current')) };
});

const sameFrame = (a, b) => Math.max(maxAbsDiff(a.positions, b.positions), maxAbsDiff(a.controls, b.controls));

async function clickStep(index) {
  const li = page.locator(`.history-list .history-step[data-index="${index}"]`);
  await li.scrollIntoViewIfNeeded();
  const box = await li.boundingBox();
  await page.mouse.click(box.x + box.width / 2, box.y + box.height / 2);
  await page.waitForFunction((i) => window.ffdEditor.state.history.current === i, index, { timeout: 20000 });
  await settle();
}

async function undoCounts() {
  const s = await state();
  const b = await ed(() => [...document.querySelectorAll('[data-history]')].map((x) => ({ which: x.dataset.history, text: x.textContent, disabled: x.disabled, title: x.title })));
  const undo = b.find((x) => x.which === 'undo'), redo = b.find((x) => x.which === 'redo');
  const want = (n, word) => `${word}${n ? ` (${n})` : ''}`;
  return {
    ok: !!undo && !!redo && undo.text.endsWith(want(s.undo, 'Undo')) && redo.text.endsWith(want(s.redo, 'Redo'))
      && undo.disabled === !s.undo && redo.disabled === !s.redo
      && (!s.undo || undo.title.includes(`“${s.history.steps[s.history.current]}”`)),
    text: `${undo && undo.text} / ${redo && redo.text} for undo ${s.undo}, redo ${s.redo}; tooltip ${JSON.stringify(undo && undo.title)}`,
  };
}

export async function stage() {
  await openBunny();
  await ed(() => document.querySelectorAll('#toasts .toast').forEach((t) => t.remove()));

  // --- a few edits: a lattice, a gizmo drag, a pin ---------------------------------
  const s1 = await createViaPanel('lattice', { 'res-lattice-0': 4, 'res-lattice-1': 4, 'res-lattice-2': 4 });
  must(s1.method === 'lattice' && s1.controls.count === 64, `lattice 4×4×4 created (${s1.controls.count} controls)`);
  const f1 = await frame();
  const cands = [];
  for (const i of [1, 2]) for (const k of [1, 2, 0, 3]) cands.push((i * 4 + 3) * 4 + k);
  const pickable = await pickableControls(cands);
  must(pickable.length > 0, `a pickable top control (${pickable.length} of ${cands.length})`);
  await click(pickable[0]);
  await page.waitForTimeout(300);
  const arrow = await gizmoArrow('Y');
  must(!!arrow, "the gizmo's Y arrow on screen");
  await ed(() => { document.getElementById('panel').scrollTop = 0; });
  await mouseDrag(arrow.from, { x: arrow.from.x + arrow.dir.x * 70, y: arrow.from.y + arrow.dir.y * 70 }, 12);
  const panelTop = await ed(() => document.getElementById('panel').scrollTop);
  check(panelTop === 0, `the History section's update does not scroll the panel (scrollTop ${panelTop})`);
  const s2 = await state();
  const f2 = await frame();
  check(s2.undo === s1.undo + 1 && sameFrame(f1, f2) > 1e-4, `gizmo drag of control ${pickable[0].id}: one step (undo ${s1.undo} -> ${s2.undo})`);
  await page.click('[data-tool=mesh]');
  const verts = await visibleVertices();
  must(verts.length > 0, `pickable vertices (${verts.length})`);
  const v = verts[Math.floor(verts.length / 2)];
  await click(v, ['Alt']);
  await page.waitForFunction((n) => window.ffdEditor.state.pins.length === n, 1 + s2.pins.length, { timeout: 10000 });
  await settle();
  const s3 = await state();
  const f3 = await frame();
  check(s3.pins.some((p) => p.vertex === v.v), `Alt+click in the mesh tool pinned vertex ${v.v}`);
  await page.click('[data-tool=controls]');

  // --- the History section names the steps, the present one highlighted ------------
  const names = s3.history.steps;
  const n = names.length;
  const last3 = names.slice(-3);
  check(last3[0] === 'Create lattice 4×4×4' && /^Drag control \d+$/.test(last3[1]) && last3[2] === `Pin vertex ${v.v}` && s3.history.current === n - 1,
    `the history names the steps: ${JSON.stringify(last3)} (current ${s3.history.current} of ${n})`);
  const shown = await shownHistory();
  check(JSON.stringify(shown.names) === JSON.stringify(names) && shown.current === n - 1,
    `the History section lists them, the last one highlighted (${shown.names.length} steps, current ${shown.current})`);
  const counts = await undoCounts();
  check(counts.ok, `the Undo/Redo buttons follow the state: ${counts.text}`);
  await ed(() => document.querySelector('section.history').scrollIntoView({ block: 'center' }));
  await shot('artist-persist-history');

  // --- a reloaded page shows exactly the server's session --------------------------
  await page.reload();
  await page.waitForSelector('body[data-ready="1"]', { timeout: 30000 });
  await settle();
  const r = await state();
  const rf = await frame();
  const mine = await ed(() => window.ffdEditor.state);
  const drawn = await ed(() => Array.from(window.ffdEditor.editor.vp.geometry.attributes.position.array));
  check(r.revision === s3.revision && JSON.stringify(r.history) === JSON.stringify(s3.history) && JSON.stringify(r.pins) === JSON.stringify(s3.pins),
    `reloaded: the server's session unchanged (revision ${r.revision}, ${r.history.steps.length} steps, ${r.pins.length} pins)`);
  check(JSON.stringify(mine.history) === JSON.stringify(r.history) && JSON.stringify(mine.pins) === JSON.stringify(r.pins) && maxAbsDiff(drawn, rf.positions) === 0,
    'reloaded: the page shows it (history, pins, the drawn frame)');
  check(JSON.stringify((await shownHistory()).names) === JSON.stringify(names), 'reloaded: the History section lists the same steps');

  // --- a click on an earlier step gives that step's frame; the last one comes back --
  await clickStep(n - 3);
  const g1 = await frame();
  const sg = await state();
  check(sameFrame(g1, f1) < 1e-6 && sg.pins.length === s1.pins.length && sg.undo === n - 3 && sg.redo === 2,
    `click on "${names[n - 3]}": that step's frame (max |diff| ${sameFrame(g1, f1).toExponential(1)}), undo ${sg.undo}, redo ${sg.redo}`);
  const shownBack = await shownHistory();
  check(shownBack.current === n - 3, `the History section highlights step ${n - 3} (${shownBack.current})`);
  const countsBack = await undoCounts();
  check(countsBack.ok, `the Undo/Redo buttons follow the jump: ${countsBack.text}`);
  await ed(() => document.querySelector('section.history').scrollIntoView({ block: 'center' }));
  await shot('artist-persist-history-back');
  await clickStep(n - 1);
  const g3 = await frame();
  check(sameFrame(g3, f3) < 1e-6 && (await state()).pins.some((p) => p.vertex === v.v), `click on the last step: its frame and pin back (max |diff| ${sameFrame(g3, f3).toExponential(1)})`);

  // --- the server killed and started again resumes the autosave ---------------------
  const record = path.join(TMP, '.ffd', 'autosave-bunny.obj.json');
  await page.waitForTimeout(800); // the autosave's quiet time
  check(existsSync(record), `the session is autosaved under the root (${path.relative(TMP, record)})`);
  const saved = existsSync(record) ? JSON.parse(readFileSync(record, 'utf8')) : {};
  check(saved.history && saved.history.steps.length === n && saved.rig && Array.isArray(saved.rig.pins),
    `the record holds the history (${saved.history && saved.history.steps.length} steps, each with its rig) and the rig with its pins`);
  const stderr = await restartServer('bunny.obj');
  check(/resumed your session of bunny\.obj from/.test(stderr), `the restarted server says so on stderr: ${JSON.stringify(stderr.trim())}`);
  await page.reload();
  await page.waitForSelector('body[data-ready="1"]', { timeout: 30000 });
  await settle();
  const q = await state();
  const qf = await frame();
  check(JSON.stringify(q.history) === JSON.stringify(s3.history) && q.undo === s3.undo && q.redo === s3.redo,
    `resumed: the history (${q.history.steps.length} steps, current ${q.history.current}, undo ${q.undo})`);
  check(JSON.stringify(q.pins.map((p) => [p.vertex, p.target])) === JSON.stringify(s3.pins.map((p) => [p.vertex, p.target])), `resumed: the pins (${q.pins.map((p) => p.vertex)})`);
  check(sameFrame(qf, f3) < 1e-5, `resumed: the frame (max |diff| ${sameFrame(qf, f3).toExponential(1)})`);
  const toast = await page.waitForSelector('#toasts .toast.info', { timeout: 5000 }).then((t) => t.textContent(), () => '');
  check(/Resumed your session from/.test(toast), `the page says so: ${JSON.stringify(toast)}`);
  const status = await ed(() => (document.querySelector('.history-status') || {}).textContent || '');
  check(/Autosaved after each change to \.ffd\/autosave-bunny\.obj\.json/.test(status), `the History section says where work goes: ${JSON.stringify(status)}`);
  await ed(() => document.querySelector('section.history').scrollIntoView({ block: 'center' }));
  await shot('artist-persist-resumed');
  await replay('bunny.obj', 1e-4, 'resumed session (its rig with pins)');
  const rig = await api('GET', '/api/rig');
  check(Array.isArray(rig.pins) && rig.pins.some((p) => p.vertex === v.v), `GET /api/rig carries the pins (${JSON.stringify(rig.pins.map((p) => p.vertex))})`);

  // the resumed history undoes like the original: Ctrl+Z takes the pin off
  await page.mouse.move(5, 400);
  await page.keyboard.press('Control+z');
  await page.waitForFunction((u) => window.ffdEditor.state.undo === u, q.undo - 1, { timeout: 10000 });
  await settle();
  const u = await frame();
  check(sameFrame(u, f2) < 1e-5 && (await state()).pins.length === s2.pins.length, `resumed: Ctrl+Z undoes "${names[n - 1]}" (max |diff| to before it ${sameFrame(u, f2).toExponential(1)})`);
  await page.keyboard.press('Control+Shift+z');
  await page.waitForFunction((u2) => window.ffdEditor.state.undo === u2, q.undo, { timeout: 10000 });
  await settle();

  // --- Re-create puts the mesh back at rest, says so, and Ctrl+Z undoes it ----------
  const title = await page.locator('#panel button.primary').getAttribute('title');
  check(/Re-create puts the mesh back at rest — undo with Ctrl\+Z/.test(title || ''), `the Re-create button says what it does: ${JSON.stringify(title)}`);
  await ed(() => document.querySelectorAll('#toasts .toast').forEach((t) => t.remove()));
  const sr = await createViaPanel('lattice', { 'res-lattice-0': 3, 'res-lattice-1': 3, 'res-lattice-2': 3 });
  const said = await page.waitForSelector('#toasts .toast.info', { timeout: 5000 }).then((t) => t.textContent(), () => '');
  check(sr.controls.count === 27 && /back at rest — undo with Ctrl\+Z/.test(said), `re-created at 3×3×3: the toast says how to undo it: ${JSON.stringify(said)}`);
  await page.mouse.move(5, 400);
  await page.keyboard.press('Control+z');
  await page.waitForFunction((c) => window.ffdEditor.state.controls && window.ffdEditor.state.controls.count === c, 64, { timeout: 10000 });
  await settle();
  const back = await frame();
  check(sameFrame(back, f3) < 1e-6 && (await state()).pins.length === s3.pins.length, `Ctrl+Z undoes the Re-create: the edits and the pin are back (max |diff| ${sameFrame(back, f3).toExponential(1)})`);
  note(`history: ${JSON.stringify((await state()).history.steps.slice(-4))}`);

  // --- an autosave of another version of the mesh is not applied, and the page says why ---
  await page.waitForTimeout(800); // the autosave's quiet time
  const lines = readFileSync(path.join(TMP, 'bunny.obj'), 'utf8').split('\n');
  const v0 = lines.findIndex((l) => l.startsWith('v '));
  lines[v0] = 'v 0 0 0'; // the file changed: one vertex moved
  writeFileSync(path.join(TMP, 'persist-moved.obj'), lines.join('\n'));
  copyFileSync(record, path.join(TMP, '.ffd', 'autosave-persist-moved.obj.json'));
  const refusal = await restartServer('persist-moved.obj');
  check(/your autosaved session was not applied: .*saved for another version of persist-moved\.obj/.test(refusal), `a changed mesh file: stderr says the autosave was not applied: ${JSON.stringify(refusal.trim().slice(0, 160))}`);
  await page.reload();
  await page.waitForSelector('body[data-ready="1"]', { timeout: 30000 });
  await settle();
  const m = await state();
  const why = await page.waitForSelector('#toasts .toast.error', { timeout: 5000 }).then((t) => t.textContent(), () => '');
  const line = await ed(() => (document.querySelector('.history-status') || {}).textContent || '');
  check(m.method === null && m.history.steps.length === 1 && /not applied: .*another version/.test(why) && /kept as \.ffd\/autosave-persist-moved\.obj\.not-applied\.json/.test(line),
    `…and the page says why (a toast, and in History: ${JSON.stringify(line.slice(0, 120))}…), the session untouched`);
  check(existsSync(path.join(TMP, '.ffd', 'autosave-persist-moved.obj.not-applied.json')), 'the record not applied is kept aside');
  await ed(() => document.querySelector('section.history').scrollIntoView({ block: 'center' }));
  await shot('artist-persist-not-applied');
  await restartServer('bunny.obj'); // back on bunny.obj, resumed
  await page.reload();
  await page.waitForSelector('body[data-ready="1"]', { timeout: 30000 });
  await settle();
  await ed(() => document.querySelectorAll('#toasts .toast').forEach((t) => t.remove()));

  // --- another mesh opened, then this one again: a new session, the earlier one offered -----
  const before = await state();
  await page.selectOption('select[name=mesh-file]', 'cow.off');
  await page.click('#panel button:text-is("Open")');
  await page.waitForFunction(() => window.ffdEditor.state.mesh.name === 'cow.off', null, { timeout: 20000 });
  await settle();
  await page.selectOption('select[name=mesh-file]', 'bunny.obj');
  await page.click('#panel button:text-is("Open")');
  await page.waitForFunction(() => window.ffdEditor.state.mesh.name === 'bunny.obj', null, { timeout: 20000 });
  await settle();
  const fresh = await state();
  check(fresh.method === null && fresh.undo === 0 && fresh.autosave && fresh.autosave.previous && fresh.autosave.previous.steps === before.history.steps.length,
    `bunny.obj opened again: a new session, the earlier one kept (${JSON.stringify(fresh.autosave && fresh.autosave.previous)})`);
  const offer = page.locator('button[name=resume-earlier]');
  await offer.scrollIntoViewIfNeeded();
  await shot('artist-persist-earlier');
  const ob = await offer.boundingBox();
  await page.mouse.click(ob.x + ob.width / 2, ob.y + ob.height / 2);
  await page.waitForFunction(() => window.ffdEditor.state.method === 'lattice', null, { timeout: 20000 });
  await settle();
  const again = await state();
  const fa = await frame();
  check(JSON.stringify(again.history) === JSON.stringify(before.history) && again.pins.length === before.pins.length && sameFrame(fa, f3) < 1e-5 && !(again.autosave || {}).previous,
    `"Resume it" brings the earlier session back: ${again.history.steps.length} steps, current ${again.history.current}, ${again.pins.length} pin (max |diff| ${sameFrame(fa, f3).toExponential(1)})`);
}
