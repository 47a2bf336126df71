// Artist stage "panel" (issue 21): the panel, messages, help and vertex
// weights as an artist meets them, with real mouse and keyboard events:
//  - the first-run card, shown once, closed for good;
//  - export with the defaults works; OBJ offers text only; the choices
//    (format, encoding, pin after drag) survive a reload;
//  - toasts: five errors show at most three (+N more), repeats merge, info
//    toasts go by themselves, none covers the view's centre;
//  - plain words in the panel (no raw numbers outside Details), a tooltip on
//    every control, the help overlay's groups;
//  - the Weights tool: a stroke painted on a lattice session, the colour map,
//    one undo step; a control dragged: the painted region follows less
//    (exactly w times the unweighted move); `ffd deform --rig` replays it;
//  - last: the server stopped (the offline banner) and started again (the
//    page reconnects by itself and reloads the state).

import path from 'node:path';
import { readFile } from 'node:fs/promises';
import {
  page, ed, shot, settle, check, must, note, state, api, frame, replay, createViaPanel, pickableControls,
  mouseDrag, expectHttp, consoleErrors, stopServer, startServerAgain, TMP, OUT,
} from '../harness.mjs';

const center = async (sel) => { const b = await page.locator(sel).first().boundingBox(); return { x: b.x + b.width / 2, y: b.y + b.height / 2 }; };
const clickOn = async (sel) => { await page.locator(sel).first().scrollIntoViewIfNeeded(); const c = await center(sel); await page.mouse.click(c.x, c.y); };
const reload = async () => {
  await page.reload();
  await page.waitForSelector('body[data-ready="1"]', { timeout: 30000 });
  await settle();
};

async function openBunny() {
  if ((await state()).mesh.name === 'bunny.obj') return;
  await page.selectOption('select[name=mesh-file]', 'bunny.obj');
  await clickOn('#panel button:text-is("Open")');
  await page.waitForFunction(() => window.ffdEditor.state && window.ffdEditor.state.mesh.name === 'bunny.obj', null, { timeout: 20000 });
  await settle();
}

async function firstRun() {
  // a first visit: a session without a deformer (earlier stages made some; a
  // session with one means the user has started, and the card closes itself)
  if ((await state()).method) {
    await page.selectOption('select[name=mesh-file]', 'elephant.off');
    await clickOn('#panel button:text-is("Open")');
    await page.waitForFunction(() => window.ffdEditor.state && window.ffdEditor.state.mesh.name === 'elephant.off', null, { timeout: 20000 });
    await settle();
  }
  await ed(() => localStorage.removeItem('ffd-editor.first-run-done'));
  await reload();
  const card = await page.locator('#first-run').isVisible();
  check(card, 'first visit: the "Getting started" card is shown');
  const text = card ? await page.locator('#first-run').innerText() : '';
  check(/Create/.test(text) && /Drag a handle/.test(text) && /Mesh tool/.test(text) && /\bH\b/.test(text),
    'the card says how to start: create a deformer, drag a handle, the mesh tool, H for help');
  const c = await center('#first-run');
  const v = await center('#view');
  check(Math.hypot(c.x - v.x, c.y - v.y) > 200, 'the card stays clear of the view\'s centre');
  await shot('artist-panel-first-run');
  await clickOn('#first-run button:text-is("Got it")');
  check(!(await page.locator('#first-run').count()), '"Got it" closes the card');
  await reload();
  check(!(await page.locator('#first-run').count()), 'after a reload the card does not come back (remembered)');
}

async function exportAndPrefs() {
  // the defaults: the format the mesh was opened in, its encoding
  const encOpts = () => ed(() => [...document.querySelectorAll('select[name=export-encoding] option')].map((o) => o.value));
  const fmt = () => ed(() => document.querySelector('select[name=export-format]').value);
  note(`export defaults: format "${await fmt()}", encodings ${JSON.stringify(await encOpts())}`);
  let dl = page.waitForEvent('download', { timeout: 20000 });
  await clickOn('#panel button[name=export-download]');
  let d = await dl.catch(() => null);
  let file = d && path.join(TMP, `panel-default-${d.suggestedFilename()}`);
  if (d) await d.saveAs(file);
  let text = file ? await readFile(file, 'utf8') : '';
  const vs = (t) => t.split('\n').filter((l) => l.startsWith('v ')).length;
  check(d && /\.obj$/.test(d.suggestedFilename()) && vs(text) === 1839,
    `export with the defaults downloads an OBJ of the 1839 vertices (${d ? d.suggestedFilename() : 'no download'}, ${vs(text)} v lines)`);
  // OBJ: text only
  await page.selectOption('select[name=export-format]', 'obj');
  check(JSON.stringify(await encOpts()) === '["ascii"]', `OBJ offers only the text encoding: ${JSON.stringify(await encOpts())}`);
  dl = page.waitForEvent('download', { timeout: 20000 });
  await clickOn('#panel button[name=export-download]');
  d = await dl.catch(() => null);
  check(!!d && !(await page.locator('#toasts .toast.error').count()), `export as OBJ works (${d && d.suggestedFilename()}), no error toast`);
  // PLY offers binary and text; choose text, and pin after drag: both remembered
  await page.selectOption('select[name=export-format]', 'ply');
  const ply = await encOpts();
  check(ply.includes('binary') && ply.includes('ascii'), `PLY offers binary and text: ${JSON.stringify(ply)}`);
  await page.selectOption('select[name=export-encoding]', 'ascii');
  const pinBefore = await page.locator('input[name=pin-after]').isChecked();
  await clickOn('input[name=pin-after]');
  await shot('artist-panel-export');
  await reload();
  const after = await ed(() => ({
    format: document.querySelector('select[name=export-format]').value,
    encoding: document.querySelector('select[name=export-encoding]').value,
    pin: document.querySelector('input[name=pin-after]').checked,
    pinAfterDrag: window.ffdEditor.editor.dm.pinAfterDrag,
  }));
  check(after.format === 'ply' && after.encoding === 'ascii', `after a reload the export choice is remembered: ${after.format} ${after.encoding}`);
  check(after.pin === !pinBefore && after.pinAfterDrag === !pinBefore, 'after a reload "Pin dragged points" is remembered');
  dl = page.waitForEvent('download', { timeout: 20000 });
  await clickOn('#panel button[name=export-download]');
  d = await dl.catch(() => null);
  file = d && path.join(TMP, `panel-${d.suggestedFilename()}`);
  if (d) await d.saveAs(file);
  text = file ? await readFile(file, 'latin1') : '';
  check(/^ply\nformat ascii/.test(text), `the remembered PLY text export downloads a text PLY (${d && d.suggestedFilename()})`);
  // back to the defaults for the stages after this one
  await clickOn('input[name=pin-after]');
  await page.selectOption('select[name=export-format]', '');
}

async function toasts() {
  await ed(() => window.ffdEditor.editor.toasts.clear());
  expectHttp(true);
  // five different errors: broken rigs uploaded through the panel
  for (let i = 1; i <= 5; i++) {
    await page.setInputFiles('#panel input[type=file][accept=".json,.prm"]', { name: `broken-${i}.json`, mimeType: 'application/json', buffer: Buffer.from(`{"version": 1, "deformer": ${'['.repeat(i)}`) });
    await page.waitForFunction((n) => document.querySelectorAll('#toasts .toast.error').length >= n, i, { timeout: 10000 });
  }
  const t = await ed(() => ({
    all: document.querySelectorAll('#toasts .toast.error').length,
    shown: [...document.querySelectorAll('#toasts .toast.error')].filter((e) => !e.hidden).length,
    more: (document.querySelector('#toasts .toast-more') || {}).textContent || '',
  }));
  check(t.shown === 3 && t.all === 5 && t.more === '+2 more', `5 errors: ${t.shown} shown, the older collapsed into "${t.more}"`);
  // none covers the view's centre
  const v = await center('#view');
  const boxes = await ed(() => [...document.querySelectorAll('#toasts > *')].filter((e) => !e.hidden).map((e) => { const r = e.getBoundingClientRect(); return [r.left, r.top, r.right, r.bottom]; }));
  check(boxes.every(([l, tp, r, b]) => !(l <= v.x && v.x <= r && tp <= v.y && v.y <= b)), 'no toast covers the centre of the view');
  await shot('artist-panel-toasts');
  // the same error again merges with a count
  await page.setInputFiles('#panel input[type=file][accept=".json,.prm"]', { name: 'broken-5.json', mimeType: 'application/json', buffer: Buffer.from('{"version": 1, "deformer": [[[[[') });
  await page.waitForFunction(() => /×2/.test((document.querySelector('#toasts .toast.error:last-of-type .count') || {}).textContent || ''), null, { timeout: 10000 }).catch(() => {});
  const merged = await ed(() => ({ n: document.querySelectorAll('#toasts .toast.error').length, count: [...document.querySelectorAll('#toasts .toast.error .count')].map((e) => e.textContent) }));
  check(merged.n === 5 && merged.count.includes('×2'), `the same error twice is one toast "×2" (${merged.n} toasts, counts ${JSON.stringify(merged.count)})`);
  expectHttp(false);
  // "+2 more" shows them all; closing with × removes them
  await clickOn('#toasts .toast-more');
  const expanded = await ed(() => [...document.querySelectorAll('#toasts .toast.error')].filter((e) => !e.hidden).length);
  check(expanded === 5, `"+2 more" shows all five (${expanded})`);
  for (let i = 0; i < 5; i++) {
    const b = page.locator('#toasts .toast.error:not([hidden]) button.close').first();
    if (!(await b.count())) break;
    const bb = await b.boundingBox();
    await page.mouse.click(bb.x + bb.width / 2, bb.y + bb.height / 2);
  }
  check(await page.locator('#toasts .toast.error').count() === 0, 'the × of each error closes it');
  // an info toast goes by itself
  await ed(() => window.ffdEditor.editor.info('Saved: test'));
  const gone = await page.waitForFunction(() => !document.querySelector('#toasts .toast.info'), null, { timeout: 8000 }).then(() => true, () => false);
  check(gone, 'an info toast disappears by itself after a few seconds');
}

async function helpAndTooltips() {
  // every control of the panel and the tool bar has a tooltip (a title, or its label's)
  const untitled = () => ed(() => [...document.querySelectorAll('#panel button, #panel input, #panel select, #toolbar button, #first-run button')]
    .filter((e) => !(e.type === 'file') && !e.title && !(e.closest('label') && e.closest('label').title))
    .map((e) => `${e.tagName.toLowerCase()}[${e.name || e.textContent.trim().slice(0, 24)}]`));
  let missing = [];
  const methods = await ed(() => [...document.querySelectorAll('select[name=method] option')].map((o) => o.value));
  const chosen = await ed(() => document.querySelector('select[name=method]').value);
  for (const m of methods) { await page.selectOption('select[name=method]', m); missing = missing.concat((await untitled()).map((x) => `${m}: ${x}`)); }
  await page.selectOption('select[name=method]', chosen);
  await page.keyboard.press('v');
  missing = missing.concat(await untitled());
  await page.keyboard.press('Escape');
  check(missing.length === 0, `every control of the panel and tool bar has a tooltip${missing.length ? `: missing ${[...new Set(missing)].join(', ')}` : ''}`);
  // no raw exponents outside Details
  const raw = await ed(() => [...document.querySelectorAll('#panel .hint-text, #status span')].map((e) => e.textContent).filter((t) => /\d\.?\d*e[-+]\d/.test(t) || /\bdev\./.test(t)));
  check(raw.length === 0, `no raw numbers like 3.8e-1 in the panel's text or the status bar${raw.length ? `: ${raw.join(' | ')}` : ''}`);
  // the help overlay: H, its groups, every tool bar key listed
  await page.keyboard.press('h');
  const help = await ed(() => ({
    visible: !document.getElementById('help').hidden,
    groups: [...document.querySelectorAll('#help tbody[id^=help-]')].map((b) => b.id),
    text: document.getElementById('help').textContent,
    keys: [...document.querySelectorAll('#toolbar kbd')].map((k) => k.textContent.trim()),
  }));
  check(help.visible, 'H shows the help overlay');
  const want = ['help-view', 'help-selection', 'help-transform', 'help-mesh', 'help-weights', 'help-files'];
  check(want.every((g) => help.groups.includes(g)), `the help is grouped: ${help.groups.join(', ')}`);
  const unlisted = help.keys.filter((k) => !help.text.includes(k));
  check(unlisted.length === 0, `every key of the tool bar is in the help${unlisted.length ? `: missing ${unlisted.join(' ')}` : ''}`);
  check(/Wheel/.test(help.text) && /Right drag/.test(help.text) && /Shift\+drag|Shift.*drag/.test(help.text), 'the help lists the mouse actions (drag, wheel, modifiers)');
  await shot('artist-panel-help');
  await page.keyboard.press('Escape');
  check(await ed(() => document.getElementById('help').hidden), 'Esc closes the help');
}

async function weights() {
  await openBunny();
  await createViaPanel('lattice', { 'res-lattice-0': 4, 'res-lattice-1': 4, 'res-lattice-2': 4 });
  const st0 = await state();
  const rest = (await frame()).positions.slice();
  await page.keyboard.press('v');
  must(await ed(() => window.ffdEditor.tool) === 'weights', 'V: the Weights tool');
  await page.waitForFunction(() => window.ffdEditor.editor.weights.weights !== null && window.ffdEditor.editor.vp.material.vertexColors, null, { timeout: 10000 });
  await settle();
  const red = await ed(() => { const c = window.ffdEditor.editor.vp.geometry.attributes.color.array; return c[0] > 0.8 && c[2] < 0.3 && window.ffdEditor.editor.vp.material.vertexColors; });
  check(red, 'the colour map shows: every vertex red (weight 1) before painting');
  await clickOn('#panel button[name=weights-subtract]');
  check(await ed(() => window.ffdEditor.editor.weights.mode) === 'subtract', 'the Subtract brush chosen in the panel');
  // a stroke across the upper part of the bunny (its ears and head)
  const vis = await ed(() => {
    const e = window.ffdEditor.editor;
    const r = e.vp.renderer.domElement.getBoundingClientRect();
    const out = [];
    for (let fy = 0.15; fy <= 0.6; fy += 0.03) {
      for (let fx = 0.3; fx <= 0.7; fx += 0.03) {
        const h = e.vp.pickMesh({ clientX: r.left + r.width * fx, clientY: r.top + r.height * fy });
        if (h) out.push({ x: r.left + r.width * fx, y: r.top + r.height * fy, v: h.vertex });
      }
    }
    return out;
  });
  must(vis.length > 10, `points of the mesh on screen (${vis.length})`);
  // two strokes between points on the mesh near its top (the ears)
  const topY = Math.min(...vis.map((p) => p.y));
  const row = vis.filter((p) => p.y < topY + 50).sort((a, b) => a.x - b.x);
  const from = row[0], to = row[row.length - 1];
  const row2 = vis.filter((p) => p.y > topY + 50 && p.y < topY + 110).sort((a, b) => a.x - b.x);
  must(row.length > 1 && row2.length > 1, 'two rows of mesh points for two strokes');
  // full strength: a click at the right end of the Strength slider
  await page.locator('#panel input[name=weights-strength]').scrollIntoViewIfNeeded();
  const sb = await page.locator('#panel input[name=weights-strength]').boundingBox();
  await page.mouse.click(sb.x + sb.width - 2, sb.y + sb.height / 2);
  check(await ed(() => window.ffdEditor.editor.weights.strength) === 1, 'the Strength slider set to 100% with the mouse');
  // wheel over the mesh: a larger brush
  await page.mouse.move(from.x, from.y);
  const r0 = await ed(() => window.ffdEditor.editor.weights.brushRadius());
  await page.mouse.wheel(0, -100);
  await page.mouse.wheel(0, -100);
  const r1 = await ed(() => window.ffdEditor.editor.weights.brushRadius());
  check(r1 > r0 * 1.15, `the wheel over the mesh resizes the brush (${r0.toFixed(2)} → ${r1.toFixed(2)}), no zoom`);
  const undo0 = (await state()).undo;
  await mouseDrag(from, to, 14);
  await mouseDrag(row2[row2.length - 1], row2[0], 14);
  await page.waitForFunction(() => !window.ffdEditor.editor.weights.stroke && !window.ffdEditor.editor.weights.sending, null, { timeout: 10000 });
  await settle();
  const st1 = await state();
  check(st1.undo === undo0 + 2, `two strokes are two undo steps (${undo0} → ${st1.undo}: "${st1.undo_label}")`);
  const wbuf = await api('POST', '/api/weights_values', {});
  const w = new Float32Array(wbuf.buffer.slice(wbuf.byteOffset + 16, wbuf.byteOffset + wbuf.length));
  const painted = [...w.keys()].filter((i) => w[i] < 0.5);
  check(w[from.v] < 1 && w[to.v] < 1 && w[row2[0].v] < 1, `each stroke painted from its first point to its last (weights ${w[from.v].toFixed(2)}, ${w[to.v].toFixed(2)}, ${w[row2[0].v].toFixed(2)})`);
  check(painted.length > 20, `the strokes lowered weights: ${painted.length} vertices below 0.5`);
  const local = await ed(() => Array.from(window.ffdEditor.editor.weights.weights));
  check(local.every((x, i) => Math.abs(x - w[i]) < 1e-6), 'the page\'s weights equal the server\'s');
  const map = await ed((ids) => { const c = window.ffdEditor.editor.vp.geometry.attributes.color.array; return ids.every((i) => c[3 * i + 2] > c[3 * i]); }, painted.slice(0, 50));
  check(map, 'painted vertices are drawn blue-ish (the colour map follows the weights)');
  const legend = await page.locator('#weights-legend').isVisible();
  check(legend, 'the weights legend (0 stays … 1 follows) is shown');
  await page.mouse.move(to.x, to.y + 20);
  await shot('artist-panel-weights-paint');
  // leave the tool, keep the colours on, and drag the top layer of the lattice up with the gizmo
  await page.keyboard.press('Escape');
  await clickOn('input[name=weights-map]');
  const top = [];
  for (let i = 0; i < 4; i++) for (let k = 0; k < 4; k++) top.push((i * 4 + 3) * 4 + k); // j = 3: the top layer (y)
  // the top control nearest the painted ears, dragged up with the mouse
  const cands = await pickableControls(top);
  must(cands.length > 0, `top-layer control points to pick on screen (${cands.length})`);
  cands.sort((p, q) => Math.hypot(p.x - from.x, p.y - from.y) - Math.hypot(q.x - from.x, q.y - from.y));
  const c0 = cands[0];
  await page.mouse.click(c0.x, c0.y);
  await settle();
  check((await ed(() => window.ffdEditor.selection)).join() === String(c0.id), `control ${c0.id} selected by a click`);
  await mouseDrag({ x: c0.x, y: c0.y }, { x: c0.x + 10, y: c0.y - 80 }, 12);
  check((await state()).undo === st1.undo + 1, 'the control drag is one more undo step');
  const fw = (await frame()).positions.slice();
  // the same move without the weights: clear them (a step), compare, undo
  await api('POST', '/api/weights', { clear: true });
  const f1 = (await frame()).positions.slice();
  await api('POST', '/api/undo', {});
  await ed(() => window.ffdEditor.editor.refresh());
  let worst = 0, less = 0, moved = 0;
  for (let i = 0; i < w.length; i++) {
    for (let a = 0; a < 3; a++) worst = Math.max(worst, Math.abs((fw[3 * i + a] - rest[3 * i + a]) - w[i] * (f1[3 * i + a] - rest[3 * i + a])));
    const dw = Math.hypot(fw[3 * i] - rest[3 * i], fw[3 * i + 1] - rest[3 * i + 1], fw[3 * i + 2] - rest[3 * i + 2]);
    const d1 = Math.hypot(f1[3 * i] - rest[3 * i], f1[3 * i + 1] - rest[3 * i + 1], f1[3 * i + 2] - rest[3 * i + 2]);
    if (w[i] < 0.5 && d1 > 1e-3) { moved++; if (dw < 0.5 * d1 + 1e-6) less++; }
  }
  check(moved > 10 && less === moved, `the painted region follows less: ${less} of ${moved} painted, moved vertices move under half as far`);
  check(worst < 1e-4, `each vertex moves its weight times the unweighted move (max |diff| ${worst.toExponential(2)})`);
  await settle();
  await page.waitForFunction(() => window.ffdEditor.editor.weights.weights !== null, null, { timeout: 10000 });
  await shot('artist-panel-weights-drag');
  await replay('bunny.obj', 1e-4, 'painted weights and a gizmo drag');
  const rig = await api('GET', '/api/rig');
  check(rig.weights && Array.isArray(rig.weights.values) && rig.weights.values.length === 1839, 'the rig holds the painted weights (weights.values, 1839)');
  // Ctrl+Z: the drag, then the second stroke, each one step
  await page.keyboard.press('Control+z');
  await settle();
  await page.keyboard.press('Control+z');
  await settle();
  const wb = await api('POST', '/api/weights_values', {});
  const w2 = new Float32Array(wb.buffer.slice(wb.byteOffset + 16, wb.byteOffset + wb.length));
  const stillPainted = [...w2.keys()].filter((i) => w2[i] < 1).length;
  const firstStroke = stillPainted > 0 && stillPainted < [...w.keys()].filter((i) => w[i] < 1).length;
  check(firstStroke, `Ctrl+Z twice undoes the drag and the second stroke only (${stillPainted} vertices still painted)`);
  // Re-create at another resolution: the painted weights stay (they belong to the mesh)
  const u0r = (await state()).undo;
  await createViaPanel('lattice', { 'res-lattice-0': 3, 'res-lattice-1': 3, 'res-lattice-2': 3 });
  await page.waitForFunction((u) => window.ffdEditor.state.undo >= u + 2, u0r, { timeout: 10000 }).catch(() => {});
  await settle();
  const wr = await api('POST', '/api/weights_values', {});
  const w4 = new Float32Array(wr.buffer.slice(wr.byteOffset + 16, wr.byteOffset + wr.length));
  check((await state()).controls.count === 27 && w4.every((x, i) => Math.abs(x - w2[i]) < 1e-6),
    `Re-create (3×3×3) keeps the painted weights (${[...w4].filter((x) => x < 1).length} vertices below 1)`);
  await page.keyboard.press('Control+z');
  await page.keyboard.press('Control+z');
  await settle();
  check((await state()).controls.count === 64, 'Ctrl+Z twice: back to the 4×4×4 lattice');
  // a weights file uploaded through the panel: every vertex 0.5, one undo step
  const u1 = (await state()).undo;
  await page.setInputFiles('#panel input[type=file][accept=".txt,.w,.csv"]', { name: 'half.txt', mimeType: 'text/plain', buffer: Buffer.from('# half\n' + '0.5\n'.repeat(1839)) });
  await page.waitForFunction((u) => window.ffdEditor.state.undo === u + 1, u1, { timeout: 10000 }).catch(() => {});
  await settle();
  const wh = await api('POST', '/api/weights_values', {});
  const w3 = new Float32Array(wh.buffer.slice(wh.byteOffset + 16, wh.byteOffset + wh.length));
  check(w3.every((x) => x === 0.5) && (await state()).undo === u1 + 1, 'a weights file uploaded in the panel sets every weight (0.5), one undo step');
  await page.keyboard.press('Control+z');
  await settle();
  await clickOn('input[name=weights-map]');
  void st0;
}

async function offline() {
  const errorsBefore = consoleErrors.length;
  await stopServer();
  await clickOn('#panel button[title="Refresh the file list"]');
  const shown = await page.waitForSelector('#offline:not([hidden])', { timeout: 12000 }).then(() => true, () => false);
  check(shown, 'the server stopped: the "Offline — reconnecting…" banner shows');
  const text = shown ? await page.locator('#offline').innerText() : '';
  check(/Offline/.test(text) && /Retry now/.test(text), `the banner says so and offers "Retry now": ${JSON.stringify(text.replace(/\s+/g, ' '))}`);
  check(!(await page.locator('#toasts .toast.error').count()), 'no error toast for it: the banner says it');
  await shot('artist-panel-offline');
  await clickOn('#offline button');
  await page.waitForTimeout(300);
  check(await page.locator('#offline').isVisible(), '"Retry now" with the server still down: the banner stays');
  await startServerAgain('bunny.obj');
  const back = await page.waitForSelector('#offline', { state: 'hidden', timeout: 15000 }).then(() => true, () => false);
  check(back, 'the server back: the page reconnects by itself and the banner goes');
  await settle();
  const s = await state();
  const mine = await ed(() => ({ rev: window.ffdEditor.state.revision, method: window.ffdEditor.state.method }));
  // the new server resumed the autosaved session (docs/editor.md "Work is never lost"): the page shows what it holds
  check(mine.rev === s.revision && mine.method === s.method, `the state is reloaded from the new server (revision ${mine.rev}, deformer ${s.method})`);
  await shot('artist-panel-reconnected');
  // the browser logs the refused connections while the server was down: expected here
  for (let i = consoleErrors.length - 1; i >= errorsBefore; i--) if (/ERR_CONNECTION_REFUSED|Failed to fetch|ERR_EMPTY_RESPONSE|ERR_CONNECTION_RESET/.test(consoleErrors[i])) consoleErrors.splice(i, 1);
}

export async function stage() {
  await openBunny();
  await firstRun();
  await openBunny();
  await exportAndPrefs();
  await toasts();
  await helpAndTooltips();
  await weights();
  await offline(); // last: the server is a new one after it
  void OUT;
}
