// The side panel: mesh and files, deformer creation, method-specific tools,
// direct-manipulation pins, edit, view, rig and export.

import { api } from './api.js';
import { h, fmtInt } from './dom.js';
import { METHODS, methodOf } from './methods/index.js';

export { h, fmtInt };


export class Panel {
  constructor(editor, root) {
    this.ed = editor;
    this.root = root;
    // the creation form and tool settings of every method (methods/*.js "form"), then export
    this.form = {
      method: METHODS[0].name,
      ...Object.fromEntries(METHODS.map((m) => [m.name, structuredClone(m.form)])),
      export: { format: '', encoding: 'binary' },
      meshFile: '',
      rigFile: '',
    };
    this.files = { meshes: [], rigs: [], root: '' };
    this.key = '';
    this.loadFiles();
  }

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
      c.cells, c.faces, c.edges_count, this.ed.opts,
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
      this.createSection(s),
      this.methodSection(s),
      this.dmSection(s),
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
    const sel = h('select', { name: 'mesh-file', style: 'flex:1', onchange: (e) => { this.form.meshFile = e.target.value; } },
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
        h('select', { name: 'method', style: 'flex:1', onchange: (e) => { f.method = e.target.value; this.render(); } },
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
    this.ed.setSelection([]);
    await this.ed.run('create', body, { label: `Creating ${name}…` });
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
    return h('section', {}, h('h3', {}, 'Direct manipulation'),
      h('div', { class: 'hint-text' }, 'Mesh tool (M): drag a point of the surface. Alt/Ctrl+click or P pins a vertex; Delete unpins.'),
      h('div', { class: 'row' },
        h('label', { class: 'check' }, h('input', { type: 'checkbox', name: 'pin-after', checked: ed.dm.pinAfterDrag, onchange: (e) => { ed.dm.pinAfterDrag = e.target.checked; } }), 'Pin dragged points')),
      pins.length ? h('div', { class: 'list' }, pins.map((p) => h('div', { class: `item${ed.dm.selectedPin === p.vertex ? ' sel' : ''}` },
        h('span', { class: 'swatch', style: `background:${p.residual > tol ? 'var(--danger)' : 'var(--ok)'}` }),
        h('span', { class: 'name' }, h('a', { href: '#', style: 'color:inherit', onclick: (e) => { e.preventDefault(); ed.dm.selectedPin = p.vertex; ed.dm.redraw(); this.render(); } }, `vertex ${p.vertex}`)),
        h('span', { class: 'hint-text', title: 'residual' }, p.residual > tol ? `Δ ${(+p.residual).toExponential(2)}` : 'reached'),
        h('button', { title: 'Unpin', onclick: () => ed.dm.unpin(p.vertex) }, '×')))) : null,
      h('div', { class: 'row buttons' },
        h('button', { disabled: !pins.length, onclick: () => ed.run('unpin', { all: true }), title: 'Remove every pin — undo with Ctrl+Z' }, 'Unpin all')),
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
      h('div', { class: 'row' }, check('Wireframe (W)', 'wireframe', (v) => ed.setWireframe(v))),
      h('div', { class: 'row' }, check('Controls', 'controls', (v) => ed.setControlsVisible(v))),
      h('div', { class: 'row' }, check('ROIs / radii', 'rois', (v) => ed.setRois(v), 'EBF ellipsoids, skeleton radii')),
      h('div', { class: 'row' }, check('Influence map (I)', 'influence', (v) => ed.setInfluence(v), 'How strongly each vertex follows the selection')),
      o.influence ? h('div', { class: 'legend', id: 'influence-legend' }, '0', h('span', { class: 'bar' }), h('span', { class: 'max' }, fmtW(ed.vp.influenceMax))) : null,
      h('div', { class: 'row buttons' }, h('button', { onclick: () => ed.frame() }, '⌖ Frame mesh (F)')),
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
    const rigSel = h('select', { name: 'rig-file', style: 'flex:1', onchange: (e) => { f.rigFile = e.target.value; } },
      h('option', { value: '' }, this.files.rigs.length ? 'Rig on the server…' : 'No rigs under the root'),
      this.files.rigs.map((r) => h('option', { value: r, selected: r === f.rigFile }, r)));
    const fmtSel = h('select', { name: 'export-format', onchange: (e) => { f.export.format = e.target.value; } },
      h('option', { value: '' }, `as read (${ext})`), ['obj', 'ply', 'off', 'stl', 'gltf'].map((x) => h('option', { value: x, selected: f.export.format === x }, x.toUpperCase())));
    const encSel = h('select', { name: 'export-encoding', onchange: (e) => { f.export.encoding = e.target.value; } },
      ['binary', 'ascii'].map((x) => h('option', { value: x, selected: f.export.encoding === x }, x)));
    const exportUrl = () => {
      const q = new URLSearchParams();
      if (f.export.format) q.set('format', f.export.format);
      q.set('encoding', f.export.encoding);
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
        h('button', { onclick: () => download(exportUrl(), `${base}-deformed.${f.export.format || ext}`, ed), title: 'Download the deformed mesh' }, '⇩ Download'),
        h('button', {
          title: 'Write the deformed mesh under the server root',
          onclick: async () => {
            const path = window.prompt('Save the deformed mesh under the server root as:', `${base}-deformed.${f.export.format || ext}`);
            if (path) { if (await ed.post('/api/export/save', { path, encoding: f.export.encoding }, 'Exporting…')) { ed.info(`Saved: ${path}`); this.loadFiles(); } }
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

const fmtW = (x) => (x === undefined ? '1' : `max ${(+x).toPrecision(3)}`);

