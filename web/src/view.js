// Orientation and navigation of the view (docs/editor.md "View"): the mesh's
// up axis (detected on open, the user's choice remembered per mesh), the front
// view on open, view presets (numpad 1 / 3 / 7, Ctrl for the opposite side;
// numpad 4 / 6 / 8 / 2 turn the view by 15°),
// orthographic / perspective (5), frame selected (numpad . or F with a
// selection) and all (Home), the ground grid, X-ray (Alt+Z), the PB-FFD "all
// ROIs" switch, and selecting rows / layers through the selection (L, Shift+L).

import * as THREE from 'three';
import { h } from './dom.js';

const STORE = 'ffd.view.up:';
const STORE_FRONT = 'ffd.view.front:';
const ROW_OF = { 0: 'X', 1: 'Y', 2: 'Z' };

/**
 * The up axis of a mesh, from its file name and its bounding box:
 *  - glTF / GLB are Y-up by the format's definition;
 *  - STL is the CAD exchange format, and CAD is Z-up: Z, unless the part rests
 *    on the plane y = 0 and not on z = 0;
 *  - OBJ, PLY, OFF and the rest: Y (the convention of OBJ and of the
 *    graphics scans), unless the model rests on the plane z = 0 (its lowest z
 *    within 1% of its height there) and not on y = 0, as a part exported
 *    from a CAD (Z-up) tool does.
 * Returns {axis: 'y' | 'z', reason}.
 */
export function detectUp(name, min, max) {
  const ext = ((name || '').match(/\.([^.]+)$/) || [])[1];
  const e = (ext || '').toLowerCase();
  if (e === 'gltf' || e === 'glb') return { axis: 'y', reason: 'glTF is Y-up' };
  if (!min || !max) return { axis: 'y', reason: 'no bounding box' };
  const restsOn = (a) => Math.abs(min[a]) <= 0.01 * Math.max(max[a] - min[a], 1e-12);
  const onY = restsOn(1), onZ = restsOn(2);
  if (e === 'stl') {
    return onY && !onZ ? { axis: 'y', reason: 'STL resting on y = 0' } : { axis: 'z', reason: 'STL (CAD) is Z-up' };
  }
  if (onZ && !onY) return { axis: 'z', reason: 'rests on z = 0' };
  return { axis: 'y', reason: e ? `${e.toUpperCase()} is Y-up` : 'Y-up by default' };
}

function stored(name, prefix = STORE) {
  try { return window.localStorage.getItem(prefix + name); } catch { return null; }
}
function store(name, value, prefix = STORE) {
  try { window.localStorage.setItem(prefix + name, value); } catch { /* private mode: not remembered */ }
}

export class ViewNav {
  constructor(editor) {
    this.ed = editor;
    this.meshKey = '';
    this.upReason = '';
    this.upChosen = false;
    Object.assign(editor.opts, { up: 'y', front: 1, ortho: false, grid: true, xray: false, allRois: false });
    editor.keyHandlers.push((ev) => this.key(ev));
    editor.on('state', (s) => this.onState(s));
    editor.vp.onCameraChange.push((cam) => { editor.gizmo.tc.camera = cam; });
    dimGizmoCentre(editor.gizmo.tc);
  }

  /** A new mesh: its up axis, then the front view with the whole model in it. */
  onState(s) {
    const m = (s && s.mesh) || {};
    const key = JSON.stringify([m.name, m.vertices, m.faces]);
    if (key === this.meshKey || !m.name) return;
    this.meshKey = key;
    const det = detectUp(m.name, m.min, m.max);
    let mine = stored(m.name);
    if (mine !== 'y' && mine !== 'z') mine = null;
    this.upChosen = !!mine;
    this.ed.vp.frontSign = stored(m.name, STORE_FRONT) === '-1' ? -1 : 1;
    this.ed.opts.front = this.ed.vp.frontSign;
    this.upReason = mine ? 'your choice for this mesh' : `detected: ${det.reason}`;
    this.applyUp(mine || det.axis);
    this.preset('front');
    this.ed.frame();
  }

  applyUp(axis) {
    this.ed.opts.up = axis;
    this.ed.vp.setUp(axis);
    this.ed.panel.update();
  }

  /** The user's up axis for this mesh (remembered in the browser). */
  chooseUp(axis) {
    const name = this.ed.state && this.ed.state.mesh && this.ed.state.mesh.name;
    if (name) store(name, axis);
    this.upChosen = true;
    this.upReason = 'your choice for this mesh';
    this.applyUp(axis);
    this.preset('front');
    this.ed.frame();
  }

  /** The model faces the other way: its front view becomes the conventional back one (remembered per mesh). */
  flipFront() {
    const vp = this.ed.vp;
    vp.frontSign = -vp.frontSign;
    this.ed.opts.front = vp.frontSign;
    const name = this.ed.state && this.ed.state.mesh && this.ed.state.mesh.name;
    if (name) store(name, String(vp.frontSign), STORE_FRONT);
    this.preset('front');
    this.ed.panel.update();
  }

  preset(name) { this.ed.vp.viewFrom(name); this.ed.emit('view', name); }

  setOrtho(on) { this.ed.vp.setOrtho(on); this.ed.opts.ortho = this.ed.vp.ortho; this.ed.gizmo.update(); this.ed.panel.update(); }

  setGrid(on) { this.ed.opts.grid = !!on; this.ed.vp.setGrid(on); this.ed.panel.update(); }

  setXray(on) {
    this.ed.opts.xray = !!on;
    this.ed.controlsView.setXray(on);
    this.ed.panel.update();
  }

  setAllRois(on) { this.ed.opts.allRois = !!on; this.ed.controlsView.setAllRois(on); this.ed.panel.update(); }

  /** Frames the selected control points (numpad ., F with a selection). */
  frameSelected() {
    const ed = this.ed;
    if (!ed.selection.length) { ed.frame(); return; }
    const box = new THREE.Box3();
    const v = new THREE.Vector3();
    for (const id of ed.selection) box.expandByPoint(ed.controlsView.position(id, v));
    // a single point: a view around it a tenth of the model across
    const r = Math.max(box.getSize(v).length() / 2, 0.15 * ed.vp.diag);
    box.expandByScalar(r - box.getSize(v).length() / 2);
    ed.vp.frameBox(box);
  }

  frameAll() { this.ed.frame(); }

  /** The detection rule (tests). */
  static detectUp(name, min, max) { return detectUp(name, min, max); }

  /** Keys of the view (help overlay "View"); digits are left to a running transform. */
  key(ev) {
    const ed = this.ed;
    const code = ev.code || '';
    const ctrl = ev.ctrlKey || ev.metaKey;
    if (ev.altKey && !ctrl && code === 'KeyZ') { this.setXray(!ed.opts.xray); return true; }
    if (ed.activeDrag || ev.altKey || ev.shiftKey && !(ev.key === 'l' || ev.key === 'L')) return false;
    const digit = (code.match(/^(?:Numpad|Digit)([0-9])$/) || [])[1];
    if (digit === '1') { this.preset(ctrl ? 'back' : 'front'); return true; }
    if (digit === '3') { this.preset(ctrl ? 'left' : 'right'); return true; }
    if (digit === '7') { this.preset(ctrl ? 'bottom' : 'top'); return true; }
    if (ctrl) return false;
    const step = Math.PI / 12; // Blender's 15° per numpad 4 / 6 / 8 / 2
    if (code === 'Numpad4') { this.ed.vp.orbitBy(-step, 0); return true; }
    if (code === 'Numpad6') { this.ed.vp.orbitBy(step, 0); return true; }
    if (code === 'Numpad8') { this.ed.vp.orbitBy(0, step); return true; }
    if (code === 'Numpad2') { this.ed.vp.orbitBy(0, -step); return true; }
    if (digit === '5') { this.setOrtho(!ed.opts.ortho); return true; }
    if (code === 'NumpadDecimal') { this.frameSelected(); return true; }
    if (code === 'Home') { this.frameAll(); return true; }
    if ((ev.key === 'f' || ev.key === 'F') && ed.selection.length && ed.tool === 'controls') { this.frameSelected(); return true; }
    if (ev.key === 'l' || ev.key === 'L') {
      // layer: normal to the constrained axis (none: the up axis); row: along it (none: X)
      const ax = ed.gizmo.axis;
      const axis = ax ? 'XYZ'.indexOf(ax) : (ev.shiftKey ? 0 : (ed.opts.up === 'z' ? 2 : 1));
      return ed.selector.selectLayer(axis, { row: ev.shiftKey });
    }
    return false;
  }

  // --- panel ---------------------------------------------------------------------

  /** Rows of the panel's View section. */
  panelRows() {
    const ed = this.ed;
    const o = ed.opts;
    const btn = (label, title, onclick, active = false, name = '') => h('button', { title, onclick, class: active ? 'active' : '', name }, label);
    const check = (label, key, fn, title) => h('label', { class: 'check', title },
      h('input', { type: 'checkbox', name: `view-${key}`, checked: !!o[key], onchange: (e) => fn(e.target.checked) }), label);
    return [
      h('div', { class: 'row' }, h('label', { title: 'The mesh\'s up axis: camera up, ground grid and view presets follow it' }, 'Up'),
        h('span', { class: 'seg' },
          btn('Y', `Y is up (OBJ, glTF, scans)${o.up === 'y' ? ` — ${this.upReason}` : ''}`, () => this.chooseUp('y'), o.up === 'y', 'view-up-y'),
          btn('Z', `Z is up (CAD, STL)${o.up === 'z' ? ` — ${this.upReason}` : ''}`, () => this.chooseUp('z'), o.up === 'z', 'view-up-z')),
        btn('⇄ Front', `The model faces the other way: turn the front view around (remembered for this mesh). Front view now looks from ${frontName(o.up, o.front)}`, () => this.flipFront(), o.front < 0, 'view-flip-front'),
        h('span', { class: 'hint-text', title: 'How the up axis was chosen; your choice is remembered for this mesh name in this browser' }, this.upReason)),
      h('div', { class: 'row buttons view-presets' },
        btn('Front', 'Front view (numpad 1 or 1; Ctrl: back)', () => this.preset('front'), false, 'view-front'),
        btn('Right', 'Right view (numpad 3 or 3; Ctrl: left)', () => this.preset('right'), false, 'view-right'),
        btn('Top', 'Top view (numpad 7 or 7; Ctrl: bottom)', () => this.preset('top'), false, 'view-top'),
        btn('Ortho', `Orthographic (parallel) projection on / off (numpad 5 or 5); now ${o.ortho ? 'orthographic' : 'perspective'}`, () => this.setOrtho(!o.ortho), o.ortho, 'view-ortho')),
      h('div', { class: 'row buttons view-presets' },
        btn('Back', 'Back view (Ctrl+numpad 1)', () => this.preset('back'), false, 'view-back'),
        btn('Left', 'Left view (Ctrl+numpad 3)', () => this.preset('left'), false, 'view-left'),
        btn('Bottom', 'Bottom view (Ctrl+numpad 7)', () => this.preset('bottom'), false, 'view-bottom')),
      h('div', { class: 'row buttons' },
        h('button', { 'data-need-sel': true, name: 'view-frame-selected', onclick: () => this.frameSelected(), title: 'Frame the selected control points (numpad . or F)' }, 'Frame selected (.)'),
        h('button', { name: 'view-frame-all', onclick: () => this.frameAll(), title: 'Frame the whole mesh and its deformer, keeping the view direction (Home; F with nothing selected)' }, 'Frame all (Home)')),
      h('div', { class: 'row' },
        check('Grid', 'grid', (v) => this.setGrid(v), 'The ground grid, on the plane the model rests on'),
        check('X-ray (Alt+Z)', 'xray', (v) => this.setXray(v), 'Show the control points and lines hidden behind the mesh at full strength, and let clicks and box select take them; off: hidden ones are faint and cannot be picked')),
      h('div', { class: 'row' },
        check('All ROIs', 'allRois', (v) => this.setAllRois(v), 'PB-FFD: draw every EBF\'s region of influence; off: only those of the selected and hovered control points')),
    ];
  }

  /** The panel's Select section: rows and layers through the selection. */
  selectSection(s) {
    const ed = this.ed;
    if (!s.method) return document.createDocumentFragment();
    const sel = ed.selector;
    const grid = s.method === 'lattice';
    const axisName = (a) => (grid ? ['i (x)', 'j (y)', 'k (z)'][a] : ROW_OF[a]);
    return h('section', { class: 'select-tools' }, h('h3', {}, 'Select'),
      h('div', { class: 'row buttons' },
        h('button', { onclick: () => ed.selectAll(), title: 'Select every control point shown (A)' }, 'All'),
        h('button', { 'data-need-sel': true, onclick: () => ed.setSelection([]), title: 'Clear the selection (Esc)' }, 'None')),
      h('div', { class: 'row buttons' }, h('label', { title: grid ? 'The planes of constant lattice index through the selected points (L)' : 'The control points at the same height along the axis as a selected one (L)' }, 'Layer'),
        [0, 1, 2].map((a) => h('button', {
          'data-need-sel': true, name: `select-layer-${a}`, onclick: () => sel.selectLayer(a),
          title: `Select the layer${grid ? ` of constant ${axisName(a)}` : ` normal to ${ROW_OF[a]}`} through each selected point (L; X/Y/Z choose the axis, none: the up axis)`,
        }, ROW_OF[a]))),
      h('div', { class: 'row buttons' }, h('label', { title: 'The lines of control points through the selection (Shift+L)' }, 'Row'),
        [0, 1, 2].map((a) => h('button', {
          'data-need-sel': true, name: `select-row-${a}`, onclick: () => sel.selectLayer(a, { row: true }),
          title: `Select the row along ${grid ? axisName(a) : ROW_OF[a]} through each selected point (Shift+L; X/Y/Z choose the axis, none: X)`,
        }, ROW_OF[a]))));
  }
}

const frontName = (up, sign) => (up === 'z' ? (sign < 0 ? '+Y' : '-Y') : (sign < 0 ? '-Z' : '+Z'));

/** The gizmo's centre handle (free move / uniform scale) is drawn faint so that it does not hide the selected point under it. */
function dimGizmoCentre(tc) {
  const g = tc && tc._gizmo;
  if (!g || !g.gizmo) return;
  for (const mode of ['translate', 'scale']) {
    for (const o of (g.gizmo[mode] && g.gizmo[mode].children) || []) {
      if (o.name !== 'XYZ' || !o.material) continue;
      o.material = o.material.clone();
      o.material.opacity = o.material._opacity = 0.12;
    }
  }
}
