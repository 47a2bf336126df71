// The side panel: mesh and files, deformer creation, method-specific tools,
// direct-manipulation pins, edit, view, rig and export.

import { api } from './api.js';
import { h, fmtInt } from './dom.js';
import { METHODS, methodOf } from './methods/index.js';
import { details } from './methods/ui.js';
import { MODES as BRUSH_MODES } from './weights.js';

export { h, fmtInt };

// --- the panel's remembered choices (localStorage, across loads) ---------------

const PREFS_KEY = 'ffd-editor.panel';
export function loadPrefs() {
  try { const p = JSON.parse(localStorage.getItem(PREFS_KEY)); return p && typeof p === 'object' ? p : {}; } catch { return {}; }
}
function savePrefs(p) { try { localStorage.setItem(PREFS_KEY, JSON.stringify(p)); } catch { /* private mode: not remembered */ } }

// --- export formats and the encodings each writer has (src/mesh/mesh_*.c) -------

export const EXPORT_FORMATS = {
  obj: { label: 'OBJ', encodings: ['ascii'] },
  off: { label: 'OFF', encodings: ['ascii'] },
  ply: { label: 'PLY', encodings: ['binary', 'ascii', 'binary-be'] },
  stl: { label: 'STL', encodings: ['binary', 'ascii'] },
  gltf: { label: 'glTF', encodings: ['binary', 'ascii'] },
};
const SOURCE_FORMAT = { obj: 'obj', off: 'off', ply: 'ply', stl: 'stl', gltf: 'gltf', glb: 'gltf' };
const ENCODING_TEXT = {
  '': ['as the file', 'The encoding the opened file had'],
  ascii: ['text (ASCII)', 'Readable text: larger files, any tool reads it'],
  binary: ['binary', 'Compact binary (little-endian): smaller and faster to load'],
  'binary-be': ['binary, big-endian', 'Binary with big-endian numbers (old tools)'],
};
/** The encodings of format ('' : the opened file's, ext its extension); the first is the default. */
export function encodingsOf(format, ext) {
  if (format) return EXPORT_FORMATS[format].encodings;
  const src = SOURCE_FORMAT[ext];
  return src ? ['', ...EXPORT_FORMATS[src].encodings] : [''];
}


export class Panel {
  constructor(editor, root) {
    this.ed = editor;
    this.root = root;
    // the creation form and tool settings of every method (methods/*.js "form"), then export
    this.form = {
      method: METHODS[0].name,
      ...Object.fromEntries(METHODS.map((m) => [m.name, structuredClone(m.form)])),
      export: { format: '', encoding: '' },
      meshFile: '',
      rigFile: '',
    };
    // the user's choices of earlier visits: the method, the export format and
    // encoding, pin after drag (each checked: a stale value is dropped)
    this.prefs = loadPrefs();
    const pr = this.prefs;
    if (METHODS.some((m) => m.name === pr.method)) this.form.method = pr.method;
    if (pr.export && (pr.export.format === '' || EXPORT_FORMATS[pr.export.format])) this.form.export.format = pr.export.format;
    if (pr.export && typeof pr.export.encoding === 'string') this.form.export.encoding = pr.export.encoding;
    if (typeof pr.pinAfterDrag === 'boolean') editor.dm.pinAfterDrag = pr.pinAfterDrag;
    this.files = { meshes: [], rigs: [], root: '' };
    this.key = '';
    this.loadFiles();
  }

  /** Remembers a choice of the panel (key: method, export, pinAfterDrag). */
  remember(key, value) { this.prefs[key] = value; savePrefs(this.prefs); }

  async loadFiles() {
    try { this.files = await api.files(); } catch { /* the files list is optional */ }
    this.key = '';
    this.render();
  }

  /** Re-renders when the panel's structure changes, else refreshes in place. */
  update() {
    const s = this.ed.state || {};
    const c = s.controls || {};
    const key = JSON.stringify([
      s.method, s.mesh && s.mesh.name, s.mesh && s.mesh.vertices, c.levels, c.level, c.count,
      (c.primitives || []).map((p) => [p.radius, p.count]), (s.pins || []).map((p) => [p.vertex, p.residual]),
      this.ed.selection.length, this.ed.tool, this.ed.sketch.length, c.refinements, (c.frozen || []).length,
      c.cells, c.faces, c.edges_count, this.ed.opts, this.weightsKey(), s.undo, s.redo,
    ]);
    if (key !== this.key) { this.key = key; this.render(); }
    this.refreshButtons();
  }

  refreshButtons() {
    const s = this.ed.state || {};
    for (const b of document.querySelectorAll('[data-need-method]')) b.disabled = !s.method;
    for (const b of document.querySelectorAll('[data-need-sel]')) b.disabled = !this.ed.selection.length;
  }

  render() {
    const ed = this.ed;
    const s = ed.state || {};
    const focusedName = document.activeElement && document.activeElement.name;
    this.root.replaceChildren(
      this.meshSection(s),
      this.ed.meshList.section(this),
      this.createSection(s),
      this.methodSection(s),
      this.ed.viewNav.selectSection(s),
      this.ed.transform.numeric.section(),
      this.dmSection(s),
      this.weightsSection(s),
      this.editSection(s),
      this.ed.history.section(s),
      this.viewSection(s),
      this.rigSection(s),
    );
    if (focusedName) {
      const el = this.root.querySelector(`[name="${focusedName}"]`);
      if (el) el.focus();
    }
    this.refreshButtons();
  }

  // --- sections -------------------------------------------------------------

  meshSection(s) {
    const m = s.mesh || {};
    const fileInput = h('input', {
      type: 'file', accept: '.obj,.ply,.off,.stl,.gltf,.glb', hidden: true,
      onchange: async (e) => {
        const f = e.target.files[0];
        if (!f) return;
        await this.ed.openUpload(f);
        e.target.value = '';
      },
    });
    // the choice lives in the form, not in the element: a re-render (a state
    // update arriving between choosing and clicking Open) keeps it
    const sel = h('select', { name: 'mesh-file', style: 'flex:1', title: 'Meshes in the server’s folder (--root); choose one, then Open', onchange: (e) => { this.form.meshFile = e.target.value; } },
      h('option', { value: '' }, this.files.meshes.length ? 'Mesh on the server…' : 'No meshes under the root'),
      this.files.meshes.map((f) => h('option', { value: f, selected: f === this.form.meshFile }, f)));
    return h('section', {},
      h('h3', {}, 'Mesh'),
      h('div', { class: 'row' }, h('b', {}, m.name || '—'),
        h('span', { class: 'hint-text' }, m.vertices !== undefined ? `${fmtInt(m.vertices)} vertices · ${fmtInt(m.faces)} faces` : '')),
      h('div', { class: 'row' }, sel,
        h('button', { onclick: () => this.form.meshFile && this.ed.openPath(this.form.meshFile), title: 'Open the chosen mesh: a new session (this one is autosaved: open its mesh again and History ▸ Resume it brings it back)' }, 'Open'),
        h('button', { onclick: () => this.loadFiles(), title: 'Refresh the file list' }, '⟲')),
      h('div', { class: 'row buttons' },
        h('button', { onclick: () => fileInput.click(), title: 'Upload a mesh from this computer: a new session (an uploaded mesh is not autosaved)' }, '⇪ Upload mesh…'), fileInput),
    );
  }

  createSection(s) {
    const f = this.form;
    const method = methodOf(f.method);
    return h('section', {},
      h('h3', {}, 'Deformer', s.method ? h('span', { class: `badge ${s.method}` }, s.method) : h('span', { class: 'badge' }, 'none')),
      h('div', { class: 'row' },
        h('select', { name: 'method', style: 'flex:1', title: 'The deformation method to create', onchange: (e) => { f.method = e.target.value; this.remember('method', f.method); this.render(); } },
          METHODS.map((m) => h('option', { value: m.name, selected: m.name === f.method }, m.label)))),
      method.createFields(f[f.method]),
      h('div', { class: 'row buttons' },
        h('button', { class: 'primary', onclick: () => this.create(), title: s.method ? 'Re-create puts the mesh back at rest — undo with Ctrl+Z' : 'Create the deformer (undo with Ctrl+Z)' }, s.method ? '↻ Re-create' : '＋ Create')),
    );
  }

  async create() {
    const name = this.form.method;
    // the creation part of a rig of the method (docs/editor.md "Operations")
    const body = { deformer: name, ...methodOf(name).createBody(this.form[name]) };
    // painted weights belong to the mesh, as vertex groups do: the new
    // deformer gets them too (a second undo step)
    let kept = null;
    if (this.ed.state && this.ed.state.method) {
      try { const w = await api.weights(); if (w.some((x) => x !== 1)) kept = Array.from(w); } catch { /* none to keep */ }
    }
    this.ed.setSelection([]);
    const st = await this.ed.run('create', body, { label: `Creating ${name}…` });
    if (st && kept && await this.ed.run('weights', { values: kept })) {
      this.ed.info('The painted weights apply to the new deformer too (Ctrl+Z once: without them)');
    }
    this.ed.vp.requestRender();
  }

  methodSection(s) {
    const method = methodOf(s.method);
    if (method.section) return method.section(this, s, s.controls || {});
    return h('section', {}, h('h3', {}, 'Tools'), h('div', { class: 'hint-text' }, 'Create a deformer to edit the mesh.'));
  }

  dmSection(s) {
    const ed = this.ed;
    const pins = s.pins || [];
    const tol = 1e-6 * ed.vp.diag;
    const missed = pins.filter((p) => p.residual > tol);
    // a miss in words: a share of the model's size
    const share = (r) => { const x = (100 * r) / (ed.vp.diag || 1); return x < 0.1 ? 'less than 0.1%' : `${x < 10 ? x.toFixed(1) : Math.round(x)}%`; };
    return h('section', {}, h('h3', {}, 'Direct manipulation'),
      h('div', { class: 'hint-text' }, 'Mesh tool (M): drag a point of the surface. Alt/Ctrl+click or P pins a vertex; Delete unpins. Pins hold exactly; a drag they do not allow comes up short.'),
      ((sf) => h('div', { id: 'dm-shortfall', class: `dm-shortfall${sf.text ? ' warn' : ''}`, title: sf.title }, sf.text))(ed.dm.shortfallText()),
      h('div', { class: 'row' },
        h('label', { class: 'check', title: 'After a mesh drag, the dragged point stays pinned where you let go' }, h('input', {
          type: 'checkbox', name: 'pin-after', checked: ed.dm.pinAfterDrag,
          onchange: (e) => { ed.dm.pinAfterDrag = e.target.checked; this.remember('pinAfterDrag', e.target.checked); },
        }), 'Pin dragged points')),
      pins.length && missed.length ? h('div', { class: 'hint-text warn' },
        `${missed.length === pins.length ? 'No pin is' : `${missed.length} of ${pins.length} pins are not`} held exactly: the deformer cannot reach every pin and the drag at once. Red pins show how far off they are.`) : null,
      pins.length ? h('div', { class: 'list' }, pins.map((p) => h('div', { class: `item${ed.dm.selectedPin === p.vertex ? ' sel' : ''}` },
        h('span', { class: 'swatch', style: `background:${p.residual > tol ? 'var(--danger)' : 'var(--ok)'}` }),
        h('span', { class: 'name' }, h('a', { href: '#', style: 'color:inherit', title: 'Select this pin (Delete unpins it)', onclick: (e) => { e.preventDefault(); ed.dm.selectedPin = p.vertex; ed.dm.redraw(); this.render(); } }, `vertex ${p.vertex}`)),
        h('span', { class: 'hint-text', title: p.residual > tol ? `This pin is off its target by ${share(p.residual)} of the model’s size (${(+p.residual).toPrecision(3)} units)` : 'The pinned point is exactly where it was pinned' },
          p.residual > tol ? `off by ${share(p.residual)}` : 'held'),
        h('button', { title: 'Unpin this vertex', onclick: () => ed.dm.unpin(p.vertex) }, '×')))) : null,
      pins.length ? details(pins.map((p) => [`Pin ${p.vertex} residual`, (+p.residual).toExponential(2),
        'The distance (in model units) between where the pinned point is and where it was pinned: 0 when held exactly'])) : null,
      h('div', { class: 'row buttons' },
        h('button', { disabled: !pins.length, onclick: () => ed.run('unpin', { all: true }), title: 'Remove every pin — undo with Ctrl+Z' }, 'Unpin all')),
    );
  }

  weightsKey() {
    const w = this.ed.weights;
    const sum = w.summary();
    return [w.active, w.showMap, w.mode, sum && sum.below, sum && sum.min];
  }

  /** Vertex-group weights: the Weights tool's brush, the colour map, loading and clearing (weights.js). */
  weightsSection(s) {
    const ed = this.ed;
    const w = ed.weights;
    const sum = w.summary();
    const input = h('input', {
      type: 'file', accept: '.txt,.w,.csv', hidden: true,
      onchange: async (e) => { const f = e.target.files[0]; if (f) await w.load(f); e.target.value = ''; },
    });
    const said = !s.method ? 'Create a deformer first: the weights scale its effect on each vertex.'
      : !sum ? '' : sum.below === 0 ? 'Every vertex follows the deformer fully (weight 1). Paint lower weights where the mesh should stay put.'
        : `${fmtInt(sum.below)} of ${fmtInt(sum.n)} vertices follow the deformer less than fully (0 = not at all).`;
    const diag = ed.vp.diag || 1;
    return h('section', { class: 'weights' }, h('h3', {}, 'Vertex weights'),
      h('div', { class: 'row buttons' },
        h('button', { name: 'weights-tool', class: w.active ? 'active' : '', 'data-need-method': true, title: 'Paint how strongly each part of the mesh follows the deformer (V); Esc when done', onclick: () => w.toggle() },
          w.active ? '✓ Painting weights (V)' : '✎ Paint weights (V)')),
      said ? h('div', { class: 'hint-text' }, said) : null,
      w.active ? [
        h('div', { class: 'row seg', role: 'radiogroup', title: 'What a stroke does' }, BRUSH_MODES.map((m) => h('button', {
          name: `weights-${m.name}`, class: w.mode === m.name ? 'active' : '', title: m.title, onclick: () => w.setMode(m.name),
        }, m.label))),
        h('div', { class: 'row' }, h('label', { title: 'Brush radius as a share of the model’s size (mouse wheel over the mesh)' }, 'Radius'),
          h('input', { type: 'range', name: 'weights-radius', min: 1, max: 50, step: 1, value: Math.round((100 * w.brushRadius()) / diag), title: 'Brush radius as a share of the model’s size (mouse wheel over the mesh)', oninput: (e) => w.setRadius((+e.target.value / 100) * diag) }),
          h('span', { class: 'hint-text' }, `${Math.round((100 * w.brushRadius()) / diag)}%`)),
        h('div', { class: 'row' }, h('label', { title: 'How much one dab changes the weights (Shift+wheel over the mesh)' }, 'Strength'),
          h('input', { type: 'range', name: 'weights-strength', min: 1, max: 100, step: 1, value: Math.round(100 * w.strength), title: 'How much one dab changes the weights (Shift+wheel over the mesh)', oninput: (e) => w.setStrength(+e.target.value / 100) }),
          h('span', { class: 'hint-text' }, `${Math.round(100 * w.strength)}%`)),
      ] : null,
      s.method ? h('div', { class: 'row' }, h('label', { class: 'check', title: 'Colour the mesh by its weights outside the Weights tool too' },
        h('input', { type: 'checkbox', name: 'weights-map', checked: w.showMap || w.active, disabled: w.active, onchange: (e) => w.setShowMap(e.target.checked) }), 'Show weight colours')) : null,
      (w.active || w.showMap) && s.method ? h('div', { class: 'legend', id: 'weights-legend', title: 'Weight colours: blue 0 (the vertex stays at rest), red 1 (it follows the deformer fully)' },
        '0 stays', h('span', { class: 'bar' }), '1 follows') : null,
      s.method ? h('div', { class: 'row buttons' },
        h('button', { title: 'Load weights from a text file: one number in [0, 1] per vertex, in vertex order (# lines skipped) — as `ffd deform` reads a rig’s weights file', onclick: () => input.click() }, '⇪ Upload…'), input,
        h('button', {
          title: 'Load a weights file from the server’s folder (--root), by its path there',
          onclick: () => { const path = window.prompt('Weights file under the server root (one number per vertex):', 'weights.txt'); if (path) w.loadFromServer(path); },
        }, '⇩ From server…'),
        h('button', { title: 'Every vertex back to weight 1 (undoable)', disabled: !sum || sum.below === 0, onclick: () => w.clear() }, 'Clear')) : null,
      sum && sum.below ? details([
        ['Vertices below 1', fmtInt(sum.below), 'How many vertices follow the deformer less than fully'],
        ['Lowest weight', sum.min.toFixed(3), 'The smallest weight: 0 means that vertex does not move at all'],
        ['Highest weight', sum.max.toFixed(3), 'The largest weight: 1 means that vertex follows the deformer fully'],
      ]) : null,
    );
  }

  editSection(s) {
    const ed = this.ed;
    return h('section', {}, h('h3', {}, 'Edit'),
      h('div', { class: 'row buttons' },
        h('button', { disabled: !s.undo, 'data-history': 'undo', onclick: () => ed.undo(), title: ed.history.undoTitle(s) }, `↶ Undo${s.undo ? ` (${s.undo})` : ''}`),
        h('button', { disabled: !s.redo, 'data-history': 'redo', onclick: () => ed.redo(), title: ed.history.redoTitle(s) }, `↷ Redo${s.redo ? ` (${s.redo})` : ''}`),
        h('button', { 'data-need-method': true, onclick: () => ed.run('reset', {}), title: 'Every control back at rest — undo with Ctrl+Z' }, '⟲ Reset')),
    );
  }

  viewSection() {
    const ed = this.ed;
    const o = ed.opts;
    const check = (label, key, fn, title) => h('label', { class: 'check', title },
      h('input', { type: 'checkbox', name: `view-${key}`, checked: o[key], onchange: (e) => fn(e.target.checked) }), label);
    return h('section', {}, h('h3', {}, 'View'),
      ...ed.viewNav.panelRows(),
      h('div', { class: 'row' }, check('Wireframe (W)', 'wireframe', (v) => ed.setWireframe(v), 'Draw the mesh’s edges over its surface (W)')),
      h('div', { class: 'row' }, check('Controls', 'controls', (v) => ed.setControlsVisible(v), 'Show the deformer’s control points and lines')),
      h('div', { class: 'row' }, check('Regions of influence', 'rois', (v) => ed.setRois(v), 'Show how far each handle reaches: PB-FFD ellipsoids, skeleton and brush radii')),
      h('div', { class: 'row' }, check('Influence map (I)', 'influence', (v) => ed.setInfluence(v), 'Colour the mesh by how strongly each part follows the selected controls (I)')),
      o.influence ? h('div', { class: 'legend', id: 'influence-legend', title: 'Blue: does not follow the selection; red: follows it the most (the strongest pull, as a share of the selection’s own move)' },
        'none', h('span', { class: 'bar' }), h('span', { class: 'max' }, fmtW(ed.vp.influenceMax))) : null,
    );
  }

  rigSection(s) {
    const ed = this.ed;
    const f = this.form;
    const m = (s.mesh && s.mesh.name) || 'mesh.obj';
    const base = m.replace(/\.[^.]*$/, '');
    const ext = (m.match(/\.([^.]+)$/) || [])[1] || 'obj';
    const rigInput = h('input', {
      type: 'file', accept: '.json,.prm', hidden: true,
      onchange: async (e) => {
        const file = e.target.files[0];
        if (!file) return;
        await ed.loadRigUpload(file);
        e.target.value = '';
      },
    });
    const rigSel = h('select', { name: 'rig-file', style: 'flex:1', title: 'Rigs in the server’s folder (--root); choose one, then Load', onchange: (e) => { f.rigFile = e.target.value; } },
      h('option', { value: '' }, this.files.rigs.length ? 'Rig on the server…' : 'No rigs under the root'),
      this.files.rigs.map((r) => h('option', { value: r, selected: r === f.rigFile }, r)));
    // only the encodings the chosen format has (OBJ and OFF: text only); a
    // remembered encoding the format lacks gives way to the format's default
    const encodings = encodingsOf(f.export.format, ext.toLowerCase());
    if (!encodings.includes(f.export.encoding)) f.export.encoding = encodings[0];
    const fmtSel = h('select', {
      name: 'export-format', title: 'The file format of the exported mesh',
      onchange: (e) => { f.export.format = e.target.value; this.remember('export', { ...f.export }); this.render(); },
    },
    h('option', { value: '' }, `as opened (${ext})`),
    Object.entries(EXPORT_FORMATS).map(([x, d]) => h('option', { value: x, selected: f.export.format === x }, d.label)));
    const encSel = h('select', {
      name: 'export-encoding', disabled: encodings.length < 2,
      title: encodings.length < 2 ? `${f.export.format ? EXPORT_FORMATS[f.export.format].label : ext.toUpperCase()} has one encoding: ${ENCODING_TEXT[encodings[0]][0]}` : 'Text or binary: what the format offers',
      onchange: (e) => { f.export.encoding = e.target.value; this.remember('export', { ...f.export }); },
    }, encodings.map((x) => h('option', { value: x, selected: f.export.encoding === x, title: ENCODING_TEXT[x][1] }, ENCODING_TEXT[x][0])));
    const outExt = () => (f.export.format === 'gltf' && f.export.encoding === 'binary' ? 'glb' : f.export.format || ext);
    const exportUrl = () => {
      const q = new URLSearchParams();
      if (f.export.format) q.set('format', f.export.format);
      if (f.export.encoding) q.set('encoding', f.export.encoding);
      return `/api/export?${q}`;
    };
    return h('section', {}, h('h3', {}, 'Rig'),
      h('div', { class: 'row buttons' },
        h('button', { 'data-need-method': true, onclick: () => download('/api/rig', `${base}-rig.json`, ed), title: 'Download the session as a rig (JSON)' }, '⇩ Download'),
        h('button', {
          'data-need-method': true, title: 'Write the rig under the server root',
          onclick: async () => {
            const path = window.prompt('Save the rig under the server root as:', `${base}-rig.json`);
            if (path) { if (await ed.post('/api/rig/save', { path }, 'Saving rig…')) { ed.info(`Rig saved: ${path}`); this.loadFiles(); } }
          },
        }, '💾 Save on server…')),
      h('div', { class: 'row' }, rigSel,
        h('button', { onclick: () => f.rigFile && ed.loadRigPath(f.rigFile), title: 'Load the chosen rig: it replaces the deformer (with its pins) — undo with Ctrl+Z' }, 'Load')),
      h('div', { class: 'row buttons' }, h('button', { onclick: () => rigInput.click(), title: 'Upload a rig from this computer: it replaces the deformer (with its pins) — undo with Ctrl+Z' }, '⇪ Upload rig…'), rigInput),
      h('h3', { style: 'margin-top:12px' }, 'Export'),
      h('div', { class: 'row' }, fmtSel, encSel),
      h('div', { class: 'row buttons' },
        h('button', { name: 'export-download', onclick: () => download(exportUrl(), `${base}-deformed.${outExt()}`, ed), title: 'Download the deformed mesh in the chosen format' }, '⇩ Download'),
        h('button', {
          title: 'Write the deformed mesh under the server root',
          onclick: async () => {
            const path = window.prompt('Save the deformed mesh under the server root as:', `${base}-deformed.${outExt()}`);
            const body = f.export.encoding ? { path, encoding: f.export.encoding } : { path };
            if (path) { if (await ed.post('/api/export/save', body, 'Exporting…')) { ed.info(`Saved: ${path}`); this.loadFiles(); } }
          },
        }, '💾 Save on server…')),
    );
  }
}

/** Fetches a download (so that a server error becomes a toast), then saves it. */
async function download(url, fallbackName, ed) {
  try {
    const blob = await api.blob(url, 'Preparing download…');
    const a = document.createElement('a');
    a.href = URL.createObjectURL(blob.data);
    a.download = blob.name || fallbackName;
    document.body.appendChild(a);
    a.click();
    a.remove();
    setTimeout(() => URL.revokeObjectURL(a.href), 10000);
  } catch (e) {
    ed.error(e);
  }
}

const fmtW = (x) => (x === undefined ? 'full' : `${Math.round(100 * x)}%`);


// --- first visit ------------------------------------------------------------------

const FIRST_RUN_KEY = 'ffd-editor.first-run-done';

/** A card over the view on the first visit saying how to start; dismissed for good. */
export function firstRunCard(ed) {
  let done = false;
  try { done = localStorage.getItem(FIRST_RUN_KEY) === '1'; } catch { /* private mode: shown each time */ }
  if (done) return null;
  const close = () => { try { localStorage.setItem(FIRST_RUN_KEY, '1'); } catch { /* ignore */ } card.remove(); };
  const card = h('div', { id: 'first-run', class: 'first-run', role: 'dialog', 'aria-label': 'Getting started' },
    h('button', { class: 'close', title: 'Close this card (it will not come back)', onclick: close }, '×'),
    h('h2', {}, 'Getting started'),
    h('ol', {},
      h('li', {}, h('b', {}, 'Create a deformer: '), 'pick a method in the panel on the right (a lattice is a good start) and press ', h('b', {}, 'Create'), '.'),
      h('li', {}, h('b', {}, 'Drag a handle: '), 'click a control point, then drag the gizmo’s arrows — or press ', h('kbd', {}, 'G'), ' to move, ', h('kbd', {}, 'R'), ' rotate, ', h('kbd', {}, 'S'), ' scale.'),
      h('li', {}, h('b', {}, 'Or grab the mesh itself: '), 'the Mesh tool ', h('kbd', {}, 'M'), ' drags a point of the surface; ', h('kbd', {}, 'P'), ' pins one in place.'),
      h('li', {}, h('b', {}, 'Paint weights: '), h('kbd', {}, 'V'), ' paints where the mesh follows less.'),
      h('li', {}, h('kbd', {}, 'H'), ' lists every key and mouse action; hover any button for what it does.')),
    h('div', { class: 'row buttons' },
      h('button', { title: 'Show every key and mouse action (H)', onclick: () => { document.getElementById('help').hidden = false; } }, 'Show all keys'),
      h('button', { class: 'ok', name: 'first-run-ok', title: 'Close this card (it will not come back)', onclick: close }, 'Got it')));
  ed.container.appendChild(card);
  // a deformer made: the user has started; the card has done its job
  ed.on('state', (st) => { if (st && st.method && card.isConnected) close(); });
  return card;
}
