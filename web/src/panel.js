// The side panel: mesh and files, deformer creation, method-specific tools,
// direct-manipulation pins, edit, view, rig and export.

import { api } from './api.js';
import { levelColor } from './controls.js';

/** Tiny DOM builder: h('div', {class: 'x', onclick}, child, 'text', ...) */
export function h(tag, props = {}, ...children) {
  const el = document.createElement(tag);
  for (const [k, v] of Object.entries(props || {})) {
    if (v === undefined || v === null || v === false) continue;
    if (k.startsWith('on')) el.addEventListener(k.slice(2), v);
    else if (k === 'class') el.className = v;
    else if (k === 'dataset') Object.assign(el.dataset, v);
    else if (k === 'style') el.style.cssText = v;
    else if (k in el && typeof v !== 'string') el[k] = v;
    else el.setAttribute(k, v === true ? '' : v);
  }
  for (const c of children.flat()) if (c !== null && c !== undefined && c !== false) el.append(c);
  return el;
}

const METHODS = [
  ['lattice', 'Lattice (B-spline / Bernstein)'],
  ['pbffd', 'PB-FFD (ellipsoidal basis)'],
  ['gffd', 'GFFD (skeleton)'],
  ['tspline', 'T-spline (proxy)'],
];

const num = (v, d) => { const x = Number(v); return Number.isFinite(x) ? x : d; };

export class Panel {
  constructor(editor, root) {
    this.ed = editor;
    this.root = root;
    this.form = {
      method: 'lattice',
      lattice: { resolution: [5, 5, 5], basis: 'bspline', margin: 0.05 },
      pbffd: { interior: 60, exterior: 60, levels: 1, sigma: 3 },
      gffd: { unit: '' },
      tspline: { resolution: [6, 6, 6], padding: 0 },
      curve: { radius: 0, samples: 32 },
      frame: { axis: 'z', angle: 15, scale: [1.2, 1, 1] },
      point: { radius: 0, offset: 0.05 },
      refine: { kind: 'cell', ratio: 0.5 },
      export: { format: '', encoding: 'binary' },
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
      this.ed.selection.length, this.ed.tool, this.ed.curvePoints.length, c.refinements, (c.frozen || []).length,
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
      type: 'file', accept: '.obj,.ply,.off,.stl', hidden: true,
      onchange: async (e) => {
        const f = e.target.files[0];
        if (!f) return;
        await this.ed.openUpload(f);
        e.target.value = '';
      },
    });
    const sel = h('select', { name: 'mesh-file', style: 'flex:1' },
      h('option', { value: '' }, this.files.meshes.length ? 'Mesh on the server…' : 'No meshes under the root'),
      this.files.meshes.map((f) => h('option', { value: f }, f)));
    return h('section', {},
      h('h3', {}, 'Mesh'),
      h('div', { class: 'row' }, h('b', {}, m.name || '—'),
        h('span', { class: 'hint-text' }, m.vertices !== undefined ? `${fmtInt(m.vertices)} vertices · ${fmtInt(m.faces)} faces` : '')),
      h('div', { class: 'row' }, sel,
        h('button', { onclick: () => sel.value && this.ed.openPath(sel.value), title: 'Open the chosen mesh (a new session)' }, 'Open'),
        h('button', { onclick: () => this.loadFiles(), title: 'Refresh the file list' }, '⟲')),
      h('div', { class: 'row buttons' },
        h('button', { onclick: () => fileInput.click(), title: 'Upload a mesh from this computer' }, '⇪ Upload mesh…'), fileInput),
    );
  }

  createSection(s) {
    const f = this.form;
    const method = f.method;
    const p = f[method];
    const fields = [];
    const resRow = (obj) => h('div', { class: 'row' }, h('label', {}, 'Resolution'),
      [0, 1, 2].map((i) => h('input', {
        type: 'number', class: 'narrow', min: 2, max: 64, step: 1, value: obj.resolution[i], name: `res-${method}-${i}`,
        title: ['l (x)', 'm (y)', 'n (z)'][i],
        onchange: (e) => { obj.resolution[i] = Math.max(2, Math.round(num(e.target.value, obj.resolution[i]))); },
      })));
    const numRow = (label, obj, key, attrs = {}) => h('div', { class: 'row' }, h('label', {}, label),
      h('input', {
        type: 'number', value: obj[key], name: `${method}-${key}`, ...attrs,
        onchange: (e) => { obj[key] = num(e.target.value, obj[key]); },
      }));
    if (method === 'lattice') {
      fields.push(resRow(p),
        h('div', { class: 'row' }, h('label', {}, 'Basis'),
          h('select', { name: 'basis', onchange: (e) => { p.basis = e.target.value; } },
            h('option', { value: 'bspline', selected: p.basis === 'bspline' }, 'Cubic B-spline'),
            h('option', { value: 'bernstein', selected: p.basis === 'bernstein' }, 'Bernstein (Bézier)'))),
        numRow('Margin', p, 'margin', { min: 0, step: 0.01 }));
    } else if (method === 'pbffd') {
      fields.push(numRow('Interior', p, 'interior', { min: 0, step: 1 }), numRow('Exterior', p, 'exterior', { min: 0, step: 1 }),
        numRow('Levels', p, 'levels', { min: 1, max: 8, step: 1 }), numRow('Sigma', p, 'sigma', { min: 0, step: 0.1 }),
        h('div', { class: 'hint-text' }, 'Automatic placement of EBF control points (interior / exterior counts), then binding.'));
    } else if (method === 'gffd') {
      fields.push(h('div', { class: 'row' }, h('label', {}, 'Unit'),
        h('input', { type: 'text', value: p.unit, placeholder: 'auto', name: 'gffd-unit', style: 'width:70px', onchange: (e) => { p.unit = e.target.value; } })),
      h('div', { class: 'hint-text' }, 'Starts with one polyline along the longest axis; edit the skeleton below.'));
    } else if (method === 'tspline') {
      fields.push(resRow(p), numRow('Padding', p, 'padding', { min: 0, step: 0.01 }));
    }
    return h('section', {},
      h('h3', {}, 'Deformer', s.method ? h('span', { class: `badge ${s.method}` }, s.method) : h('span', { class: 'badge' }, 'none')),
      h('div', { class: 'row' },
        h('select', { name: 'method', style: 'flex:1', onchange: (e) => { f.method = e.target.value; this.render(); } },
          METHODS.map(([v, t]) => h('option', { value: v, selected: v === method }, t)))),
      fields,
      h('div', { class: 'row buttons' },
        h('button', { class: 'primary', onclick: () => this.create(), title: 'Create the deformer (undoable)' }, s.method ? '↻ Re-create' : '＋ Create')),
    );
  }

  async create() {
    const f = this.form;
    const m = f.method;
    const p = f[m];
    let body;
    if (m === 'lattice') body = { method: m, resolution: p.resolution, basis: p.basis, margin: p.margin };
    else if (m === 'pbffd') body = { method: m, interior: p.interior, exterior: p.exterior, levels: p.levels, sigma: p.sigma };
    else if (m === 'gffd') { body = { method: m }; if (p.unit !== '' && Number.isFinite(Number(p.unit))) body.unit = Number(p.unit); }
    else body = { method: m, resolution: p.resolution, padding: p.padding };
    this.ed.setSelection([]);
    await this.ed.run('create', body, { label: `Creating ${m}…` });
    this.ed.vp.requestRender();
  }

  methodSection(s) {
    const c = s.controls || {};
    const ed = this.ed;
    if (s.method === 'lattice') {
      return h('section', {}, h('h3', {}, 'Lattice'),
        h('div', { class: 'hint-text' }, `${(c.resolution || []).join(' × ')} control points, ${c.basis === 'bernstein' ? 'Bernstein (Bézier)' : 'cubic B-spline'} basis. `,
          'Change the resolution or basis above and press Re-create.'),
        h('div', { class: 'row buttons' },
          h('button', { onclick: () => ed.selectAll() }, 'Select all'),
          h('button', { 'data-need-sel': true, onclick: () => ed.setSelection([]) }, 'Clear selection')));
    }
    if (s.method === 'pbffd') return this.pbffdSection(s, c);
    if (s.method === 'gffd') return this.gffdSection(s, c);
    if (s.method === 'tspline') return this.tsplineSection(s, c);
    return h('section', {}, h('h3', {}, 'Tools'), h('div', { class: 'hint-text' }, 'Create a deformer to edit the mesh.'));
  }

  pbffdSection(s, c) {
    const ed = this.ed;
    const f = this.form;
    const levels = Math.max(1, c.levels || 1);
    const drawing = ed.tool === 'curve';
    const axisVec = { x: [1, 0, 0], y: [0, 1, 0], z: [0, 0, 1] };
    if (!f.curve.radius) f.curve.radius = +(0.15 * ed.vp.diag).toPrecision(3);
    return h('section', {}, h('h3', {}, 'PB-FFD'),
      h('div', { class: 'row' }, h('label', {}, 'Level'),
        h('select', {
          name: 'level', onchange: (e) => ed.run('level', { level: Number(e.target.value) }),
        }, Array.from({ length: levels }, (_, k) => h('option', { value: k, selected: k === (c.level || 0) }, `Level ${k}`))),
        h('span', { class: 'swatch', style: `background:#${levelColor(c.level || 0).toString(16).padStart(6, '0')}` }),
        h('span', { class: 'hint-text' }, `${(c.ebfs || []).length} EBFs`)),
      h('div', { class: 'hint-text' }, 'Selected EBFs: rotate or stretch their ROI frames.'),
      h('div', { class: 'row' }, h('label', {}, 'Rotate'),
        h('select', { name: 'frame-axis', onchange: (e) => { f.frame.axis = e.target.value; } },
          ['x', 'y', 'z'].map((a) => h('option', { value: a, selected: f.frame.axis === a }, a.toUpperCase()))),
        h('input', { type: 'number', name: 'frame-angle', value: f.frame.angle, step: 5, title: 'degrees', onchange: (e) => { f.frame.angle = num(e.target.value, 15); } }),
        h('span', { class: 'hint-text' }, '°'),
        h('button', {
          'data-need-sel': true,
          onclick: () => ed.run('frame', { points: ed.selection, axis: axisVec[f.frame.axis], angle: f.frame.angle * Math.PI / 180 }),
        }, 'Apply')),
      h('div', { class: 'row' }, h('label', {}, 'Scale'),
        [0, 1, 2].map((i) => h('input', {
          type: 'number', class: 'narrow', step: 0.1, value: f.frame.scale[i], name: `frame-scale-${i}`, title: ['a', 'b', 'c'][i],
          onchange: (e) => { f.frame.scale[i] = num(e.target.value, 1); },
        })),
        h('button', { 'data-need-sel': true, onclick: () => ed.run('frame', { points: ed.selection, scale: f.frame.scale }) }, 'Apply')),
      h('div', { class: 'hint-text' }, `Curves: ${(c.curves || []).length}`),
      h('div', { class: 'row' }, h('label', {}, 'Radius'),
        h('input', { type: 'number', name: 'curve-radius', step: 'any', min: 0, value: f.curve.radius, onchange: (e) => { f.curve.radius = num(e.target.value, f.curve.radius); } }),
        h('label', { style: 'min-width:0' }, 'Samples'),
        h('input', { type: 'number', name: 'curve-samples', class: 'narrow', min: 2, step: 1, value: f.curve.samples, onchange: (e) => { f.curve.samples = Math.round(num(e.target.value, 32)); } })),
      h('div', { class: 'row buttons' },
        h('button', { class: drawing ? 'active' : '', onclick: () => ed.setTool(drawing ? 'controls' : 'curve'), title: 'Click points on the mesh, Enter to create' },
          drawing ? `✎ Drawing… (${ed.curvePoints.length} pts)` : '✎ Draw curve'),
        drawing ? h('button', { class: 'primary', disabled: ed.curvePoints.length < 2, onclick: () => ed.finishCurve() }, 'Create ⏎') : null),
    );
  }

  gffdSection(s, c) {
    const ed = this.ed;
    const f = this.form;
    const prims = c.primitives || [];
    if (!f.point.radius) f.point.radius = +(0.15 * ed.vp.diag).toPrecision(3);
    const placing = ed.tool === 'addpoint';
    const selPrims = new Set();
    prims.forEach((p, i) => { for (const id of ed.selection) if (id >= p.offset && id < p.offset + p.count) selPrims.add(i); });
    return h('section', {}, h('h3', {}, 'GFFD skeleton'),
      h('div', { class: 'list' }, prims.length ? prims.map((p, i) => h('div', { class: `item${selPrims.has(i) ? ' sel' : ''}` },
        h('span', { class: 'name', title: `controls ${p.offset}..${p.offset + p.count - 1}` },
          h('a', { href: '#', style: 'color:inherit', onclick: (e) => { e.preventDefault(); ed.setSelection(range(p.offset, p.count)); } }, `#${i} ${p.type}`),
          h('span', { class: 'hint-text' }, ` ${p.count} pt${p.count === 1 ? '' : 's'}`)),
        h('input', {
          type: 'number', name: `prim-radius-${i}`, step: 'any', min: 0, value: +(+p.radius).toPrecision(4), title: 'radius',
          onchange: (e) => ed.run('primitive', { radius: num(e.target.value, p.radius), index: i }),
        }),
        h('button', { title: 'Remove this primitive', class: 'danger', onclick: () => ed.run('primitive', { remove: i }) }, '×'),
      )) : h('div', { class: 'item hint-text' }, 'No primitives')),
      h('div', { class: 'row' }, h('label', {}, 'New point'),
        h('input', { type: 'number', name: 'point-radius', step: 'any', min: 0, value: f.point.radius, title: 'radius', onchange: (e) => { f.point.radius = num(e.target.value, f.point.radius); } }),
        h('label', { style: 'min-width:0' }, 'offset'),
        h('input', { type: 'number', name: 'point-offset', class: 'narrow', step: 0.01, value: f.point.offset, title: 'offset from the surface along its normal (fraction of the diagonal; negative: inside)', onchange: (e) => { f.point.offset = num(e.target.value, 0.05); } })),
      h('div', { class: 'row buttons' },
        h('button', { class: placing ? 'active' : '', onclick: () => ed.setTool(placing ? 'controls' : 'addpoint') },
          placing ? '⊕ Click the mesh…' : '⊕ Add point primitive')),
      h('div', { class: 'hint-text' }, `${fmtInt(c.influenced || 0)} vertices influenced. Select skeleton vertices and use the gizmo to bend.`),
    );
  }

  tsplineSection(s, c) {
    const ed = this.ed;
    const f = this.form;
    const frozen = new Set(c.frozen || []);
    const refining = ed.tool === 'refine';
    const near = (kind) => {
      const p = ed.controlsView.centroid(ed.selection).toArray();
      const ins = { [kind]: { near: p } };
      if (kind === 'edge') ins.ratio = f.refine.ratio;
      return ed.run('refine', { insertions: [ins] }, { label: 'Refining…' });
    };
    return h('section', {}, h('h3', {}, 'T-spline'),
      h('div', { class: 'hint-text' },
        `${fmtInt(c.count)} points · ${fmtInt(c.cells ?? 0)} cells · ${fmtInt(c.faces ?? 0)} faces · ${fmtInt(c.edges_count ?? 0)} edges · ${c.refinements ?? 0} refinements`
        + (c.max_weight_deviation !== undefined ? ` · max weight dev. ${(+c.max_weight_deviation).toExponential(1)}` : '')),
      h('div', { class: 'row' },
        h('label', { class: 'check' }, h('input', { type: 'checkbox', name: 'full-lattice', checked: ed.controlsView.showLattice, onchange: (e) => ed.setShowLattice(e.target.checked) }), 'Show full T-lattice')),
      h('div', { class: 'row' },
        h('label', { class: 'check', title: 'Dragged points are ARAP handles (§3.4); off: they move alone' },
          h('input', { type: 'checkbox', name: 'arap', checked: ed.opts.arap, onchange: (e) => { ed.opts.arap = e.target.checked; } }), 'ARAP drag (selection = handles)')),
      h('div', { class: 'hint-text' }, 'Refine at the selection’s centroid (rest space):'),
      h('div', { class: 'row buttons' },
        h('button', { 'data-need-sel': true, onclick: () => near('cell') }, 'Cell'),
        h('button', { 'data-need-sel': true, onclick: () => near('face') }, 'Face'),
        h('button', { 'data-need-sel': true, onclick: () => near('edge') }, 'Edge'),
        h('input', { type: 'number', name: 'edge-ratio', class: 'narrow', min: 0.05, max: 0.95, step: 0.05, value: f.refine.ratio, title: 'edge split ratio', onchange: (e) => { f.refine.ratio = num(e.target.value, 0.5); } })),
      h('div', { class: 'row' },
        h('select', { name: 'refine-kind', onchange: (e) => { f.refine.kind = e.target.value; } },
          ['cell', 'face', 'edge'].map((k) => h('option', { value: k, selected: f.refine.kind === k }, k))),
        h('button', { class: refining ? 'active' : '', style: 'flex:1', onclick: () => ed.setTool(refining ? 'controls' : 'refine') },
          refining ? 'Click the mesh…' : 'Refine at a mesh point')),
      h('div', { class: 'row buttons' },
        h('button', { onclick: () => ed.run('refine', { insertions: [{ cells: 'proxy' }] }, { label: 'Refining…' }) }, 'Refine all proxy cells')),
      h('div', { class: 'row buttons' },
        h('button', { 'data-need-sel': true, onclick: () => ed.run('freeze', { points: ed.selection, frozen: true }) }, '❄ Freeze'),
        h('button', { 'data-need-sel': true, onclick: () => ed.run('freeze', { points: ed.selection, frozen: false }) }, 'Unfreeze')),
      h('div', { class: 'hint-text' }, `${frozen.size} frozen`),
    );
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
        h('button', { disabled: !pins.length, onclick: () => ed.run('unpin', { all: true }) }, 'Unpin all')),
    );
  }

  editSection(s) {
    const ed = this.ed;
    return h('section', {}, h('h3', {}, 'Edit'),
      h('div', { class: 'row buttons' },
        h('button', { disabled: !s.undo, onclick: () => ed.undo(), title: 'Ctrl+Z' }, `↶ Undo${s.undo ? ` (${s.undo})` : ''}`),
        h('button', { disabled: !s.redo, onclick: () => ed.redo(), title: 'Ctrl+Shift+Z / Ctrl+Y' }, `↷ Redo${s.redo ? ` (${s.redo})` : ''}`),
        h('button', { 'data-need-method': true, onclick: () => ed.run('reset', {}), title: 'Every control back at rest (undoable)' }, '⟲ Reset')),
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
    const rigSel = h('select', { name: 'rig-file', style: 'flex:1' },
      h('option', { value: '' }, this.files.rigs.length ? 'Rig on the server…' : 'No rigs under the root'),
      this.files.rigs.map((r) => h('option', { value: r }, r)));
    const fmtSel = h('select', { name: 'export-format', onchange: (e) => { f.export.format = e.target.value; } },
      h('option', { value: '' }, `as read (${ext})`), ['obj', 'ply', 'off', 'stl'].map((x) => h('option', { value: x, selected: f.export.format === x }, x.toUpperCase())));
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
        h('button', { onclick: () => rigSel.value && ed.loadRigPath(rigSel.value) }, 'Load')),
      h('div', { class: 'row buttons' }, h('button', { onclick: () => rigInput.click() }, '⇪ Upload rig…'), rigInput),
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

export function fmtInt(n) { return n === undefined || n === null ? '—' : Number(n).toLocaleString('en-US'); }
const range = (o, n) => Array.from({ length: n }, (_, i) => o + i);
