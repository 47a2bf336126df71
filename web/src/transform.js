// Blender-style transforms of the selected control points (docs/editor.md
// "Transforms"): the modal grab / rotate / scale started by G / R / S with
// the pointer over the view (X/Y/Z constraints, Shift for planes, typed
// amounts, Enter or click confirms, Esc or right click cancels), and the
// settings they share with the numeric panel (numeric.js): pivot point,
// transform orientation, mirror editing, snapping, proportional editing and
// the 3D cursor (Shift+right click on the mesh).
//
// Every transform runs through the server's drag (drag.js: drag_begin, one
// `drag` step in flight with the total change, drag_end: one undo step).
// A rigid motion of the whole selection about one pivot is sent in its own
// form (delta, axis/angle, scale); anything else — mirror counterparts,
// proportional neighbours, islands about their own origins, a scale along
// local axes — as each control's own change: {"moves": [[id, dx, dy, dz]]}.

import * as THREE from 'three';
import { DragSession } from './drag.js';
import { methodOf } from './methods/index.js';
import { NumericPanel } from './numeric.js';

export const PIVOTS = [
  ['median', 'Median point', 'About the mean of the selected control points'],
  ['active', 'Active element', 'About the last clicked control point'],
  ['cursor', '3D cursor', 'About the 3D cursor (Shift+right click on the mesh places it)'],
  ['individual', 'Individual origins', 'Each connected group of selected points (joined by lattice lines) about its own centre; a lone point turns or scales about itself, so it stays put'],
];
export const ORIENTATIONS = [
  ['global', 'Global', 'The world axes X, Y, Z'],
  ['local', 'Local', "The lattice's own axes (its edges); a selected EBF's frame; otherwise the principal axes of the control points"],
];
const MODE_NAMES = { translate: 'Grab', rotate: 'Rotate', scale: 'Scale' };
const AXES = ['X', 'Y', 'Z'];
const AXIS_COLORS = [0xff3352, 0x8bdc00, 0x2890ff];

/**
 * Blender's "smooth" proportional falloff: the weight of a control at distance
 * d from the nearest selected one, radius r: with t = 1 - d/r (clamped to
 * [0, 1]), 3t² − 2t³ — 1 at the selection, 0 at the radius, flat at both ends.
 */
export function smoothFalloff(d, r) {
  if (!(r > 0)) return 0;
  const t = Math.min(1, Math.max(0, 1 - d / r));
  return t * t * (3 - 2 * t);
}

/** A "nice" step near x: 1, 2 or 5 times a power of ten. */
function niceStep(x) {
  const p = 10 ** Math.floor(Math.log10(x));
  const m = x / p;
  return (m < 1.5 ? 1 : m < 3.5 ? 2 : m < 7.5 ? 5 : 10) * p;
}

const fmt = (x, digits = 4) => {
  const v = Math.abs(x) < 1e-12 ? 0 : x;
  return String(+v.toFixed(digits));
};

export class TransformTool {
  constructor(editor) {
    this.ed = editor;
    this.opt = {
      pivot: 'median',
      orientation: 'global',
      mirror: false,
      mirrorAxis: 0,
      snap: false,
      snapKind: 'increment', // 'increment' | 'grid'
      snapStep: 0,           // 0: from the mesh's size (niceStep(diag / 50))
      proportional: false,
      radius: 0,             // 0: a fifth of the mesh's diagonal
    };
    this.cursor = null;      // THREE.Vector3; null: the mesh's centre
    this.modal = null;
    this.numeric = new NumericPanel(this);
    this.buildOverlays();
    editor.keyHandlers.push((ev) => this.onKey(ev));
    // Shift+right click on the mesh places the 3D cursor (capture: before the
    // orbit controls' pan)
    editor.container.addEventListener('pointerdown', (ev) => {
      if (ev.button !== 2 || !ev.shiftKey || this.modal || ev.target !== editor.vp.renderer.domElement) return;
      const hit = editor.vp.pickMesh(ev);
      if (!hit) return;
      ev.stopPropagation();
      ev.preventDefault();
      this.setCursor(hit.point);
    }, true);
    editor.container.addEventListener('contextmenu', (ev) => ev.preventDefault());
    editor.on('state', () => { this.drawCursor(); });
    // the tool bar's switches
    for (const [id, key] of [['btn-proportional', 'proportional'], ['btn-mirror', 'mirror'], ['btn-snap', 'snap']]) {
      const b = document.getElementById(id);
      if (b) b.addEventListener('click', () => this.setOption(key, !this.opt[key]));
    }
    this.syncToolbar();
  }

  syncToolbar() {
    for (const [id, key] of [['btn-proportional', 'proportional'], ['btn-mirror', 'mirror'], ['btn-snap', 'snap']]) {
      const b = document.getElementById(id);
      if (b) b.classList.toggle('active', !!this.opt[key]);
    }
  }

  get diag() { return this.ed.vp.diag || 1; }
  get step() { return this.opt.snapStep > 0 ? this.opt.snapStep : niceStep(this.diag / 50); }
  get radius() { return this.opt.radius > 0 ? this.opt.radius : +(this.diag / 5).toPrecision(2); }

  /** Where the gizmo sits for a selection: the pivot (individual origins: the median). */
  pivotPoint(ids) {
    const cv = this.ed.controlsView;
    if (this.opt.pivot === 'cursor') return this.cursorPosition();
    if (this.opt.pivot === 'active' && ids.length) return cv.position(ids[ids.length - 1]);
    return cv.centroid(ids);
  }

  setOption(key, value) {
    this.opt[key] = value;
    this.syncToolbar();
    if (key === 'pivot' && !this.ed.activeDrag) this.ed.gizmo.update();
    if (this.modal) this.refreshModal(key === 'proportional' || key === 'mirror' || key === 'mirrorAxis');
    this.numeric.refresh(true);
  }

  // --- the 3D cursor -------------------------------------------------------

  cursorPosition() {
    if (this.cursor) return this.cursor.clone();
    const m = (this.ed.state && this.ed.state.mesh) || {};
    return m.min && m.max ? new THREE.Vector3(...m.min).add(new THREE.Vector3(...m.max)).multiplyScalar(0.5) : new THREE.Vector3();
  }

  setCursor(p) {
    this.cursor = p ? p.clone() : null;
    this.drawCursor();
    if (this.opt.pivot === 'cursor' && !this.ed.activeDrag) this.ed.gizmo.update();
    this.numeric.refresh(true);
  }

  buildOverlays() {
    const vp = this.ed.vp;
    // drawn after the control structure (its group's order is 10): on top of the lattice lines
    const layer = new THREE.Group();
    layer.renderOrder = 40;
    vp.overlays.add(layer);
    // the 3D cursor: a red and white ring with a crosshair, always in front
    const ring = [];
    for (let i = 0; i <= 32; i++) ring.push(new THREE.Vector3(Math.cos(i * Math.PI / 16), Math.sin(i * Math.PI / 16), 0));
    const ringGeom = new THREE.BufferGeometry().setFromPoints(ring);
    const cols = [];
    for (let i = 0; i <= 32; i++) { const red = Math.floor(i / 4) % 2 === 0; cols.push(red ? 1 : 1, red ? 0.2 : 1, red ? 0.2 : 1); }
    ringGeom.setAttribute('color', new THREE.Float32BufferAttribute(cols, 3));
    const mat = (color) => new THREE.LineBasicMaterial({ color, depthTest: false, transparent: true, vertexColors: color === undefined });
    const cross = new THREE.BufferGeometry().setFromPoints([
      new THREE.Vector3(-1.8, 0, 0), new THREE.Vector3(-0.6, 0, 0), new THREE.Vector3(0.6, 0, 0), new THREE.Vector3(1.8, 0, 0),
      new THREE.Vector3(0, -1.8, 0), new THREE.Vector3(0, -0.6, 0), new THREE.Vector3(0, 0.6, 0), new THREE.Vector3(0, 1.8, 0),
    ]);
    this.cursorObj = new THREE.Group();
    this.cursorObj.add(new THREE.Line(ringGeom, mat()), new THREE.LineSegments(cross, mat(0x111111)));
    this.cursorObj.renderOrder = 30;
    for (const o of this.cursorObj.children) o.renderOrder = 30;
    this.cursorObj.visible = false;
    layer.add(this.cursorObj);
    // proportional editing's radius: a circle facing the camera about the pivot
    const circle = [];
    for (let i = 0; i <= 64; i++) circle.push(new THREE.Vector3(Math.cos(i * Math.PI / 32), Math.sin(i * Math.PI / 32), 0));
    this.radiusObj = new THREE.Line(new THREE.BufferGeometry().setFromPoints(circle),
      new THREE.LineDashedMaterial({ color: 0xd8d8d8, dashSize: 0.06, gapSize: 0.04, depthTest: false, transparent: true, opacity: 0.85 }));
    this.radiusObj.computeLineDistances();
    this.radiusObj.renderOrder = 30;
    this.radiusObj.visible = false;
    layer.add(this.radiusObj);
    // the constraint: a line through the pivot along each constrained axis
    this.axisLines = AXIS_COLORS.map((color) => {
      const l = new THREE.Line(new THREE.BufferGeometry().setFromPoints([new THREE.Vector3(-1, 0, 0), new THREE.Vector3(1, 0, 0)]),
        new THREE.LineBasicMaterial({ color, depthTest: false, transparent: true, opacity: 0.9 }));
      l.renderOrder = 29;
      l.visible = false;
      layer.add(l);
      return l;
    });
    vp.onBeforeRender.push(() => this.faceCamera());
    this.header = document.createElement('div');
    this.header.className = 'transform-header';
    this.header.hidden = true;
    this.header.setAttribute('role', 'status');
    this.ed.container.appendChild(this.header);
  }

  drawCursor() {
    const show = !!(this.ed.state && this.ed.state.mesh) && (this.cursor !== null || this.opt.pivot === 'cursor');
    this.cursorObj.visible = show;
    if (show) this.cursorObj.position.copy(this.cursorPosition());
    this.ed.vp.requestRender();
  }

  /** Keeps the cursor and the radius circle facing the camera, the cursor a constant size on screen. */
  faceCamera() {
    const cam = this.ed.vp.camera;
    for (const o of [this.cursorObj, this.radiusObj]) if (o.visible) o.quaternion.copy(cam.quaternion);
    if (this.cursorObj.visible) {
      const d = cam.position.distanceTo(this.cursorObj.position);
      const s = d * Math.tan(THREE.MathUtils.degToRad(cam.fov / 2)) * 0.035;
      this.cursorObj.scale.setScalar(s);
    }
    if (this.radiusObj.visible) {
      const r = this.modal ? this.radius : 0;
      this.radiusObj.scale.setScalar(r);
      this.radiusObj.material.dashSize = 0.05;
      this.radiusObj.material.gapSize = 0.035;
    }
  }

  // --- what a transform starts from -----------------------------------------

  /** The controls' positions now (float64 copy of the drawn float32 ones). */
  positions() {
    const cv = this.ed.controlsView;
    return Float64Array.from(cv.positions ? cv.positions.array.subarray(0, 3 * cv.count) : []);
  }

  /** Orthonormal columns [u, v, w] of the orientation (global or local). */
  orientation(kind, P, sel) {
    const I = [new THREE.Vector3(1, 0, 0), new THREE.Vector3(0, 1, 0), new THREE.Vector3(0, 0, 1)];
    if (kind !== 'local') return I;
    const c = (this.ed.state && this.ed.state.controls) || {};
    const at = (id) => new THREE.Vector3(P[3 * id], P[3 * id + 1], P[3 * id + 2]);
    let axes = null;
    if (Array.isArray(c.resolution) && c.resolution.length === 3) {
      // a lattice: control (i, j, k) is (i*m + j)*n + k; its edges from the first corner
      const [l, m, n] = c.resolution;
      if (l * m * n <= this.ed.controlsView.count && l > 1 && m > 1 && n > 1) {
        const o = at(0);
        axes = [at((l - 1) * m * n).sub(o), at((m - 1) * n).sub(o), at(n - 1).sub(o)];
      }
    } else if (Array.isArray(c.ebfs) && sel.length === 1 && c.ebfs[sel[0]] && c.ebfs[sel[0]].frame) {
      const f = c.ebfs[sel[0]].frame; // rows: the ellipsoid's unit directions
      axes = f.map((r) => new THREE.Vector3(...r));
    }
    if (!axes) axes = principalAxes(this.ed.controlsView.visibleIds.map(at));
    return axes ? orthonormal(axes) || I : I;
  }

  /** Groups of selected controls joined by the structure's edges (individual origins). */
  islands(sel) {
    const c = (this.ed.state && this.ed.state.controls) || {};
    const parent = new Map(sel.map((id) => [id, id]));
    const find = (x) => { while (parent.get(x) !== x) { parent.set(x, parent.get(parent.get(x))); x = parent.get(x); } return x; };
    for (const [a, b] of c.edges || []) if (parent.has(a) && parent.has(b)) parent.set(find(a), find(b));
    const groups = new Map();
    for (const id of sel) { const r = find(id); if (!groups.has(r)) groups.set(r, []); groups.get(r).push(id); }
    return [...groups.values()];
  }

  /**
   * Everything a transform of the selection needs, taken once at its start:
   * positions, pivot(s), orientation, mirror counterparts, proportional
   * distances. opts: {proportional} overrides the setting (the numeric panel
   * does not use it).
   */
  snapshot({ proportional = this.opt.proportional } = {}) {
    const ed = this.ed;
    const cv = ed.controlsView;
    const sel = [...ed.selection];
    const P = this.positions();
    const at = (id) => new THREE.Vector3(P[3 * id], P[3 * id + 1], P[3 * id + 2]);
    const median = new THREE.Vector3();
    for (const id of sel) median.add(at(id));
    median.multiplyScalar(1 / Math.max(1, sel.length));
    const pivotKind = this.opt.pivot;
    let pivot = median.clone();
    if (pivotKind === 'active' && sel.length) pivot = at(sel[sel.length - 1]);
    else if (pivotKind === 'cursor') pivot = this.cursorPosition();
    const frame = this.orientation(this.opt.orientation, P, sel);
    // each selected control's own centre (individual origins: its island's median)
    const centerOf = new Map();
    if (pivotKind === 'individual') {
      for (const g of this.islands(sel)) {
        const c = new THREE.Vector3();
        for (const id of g) c.add(at(id));
        c.multiplyScalar(1 / g.length);
        for (const id of g) centerOf.set(id, c);
      }
    }
    // proportional: distance of every other visible control to the nearest selected one
    const selSet = new Set(sel);
    const near = new Map(); // id -> [distance, nearest selected id]
    if (proportional) {
      for (const id of cv.visibleIds) {
        if (selSet.has(id)) continue;
        let best = Infinity, who = -1;
        for (const s of sel) {
          const d = Math.hypot(P[3 * id] - P[3 * s], P[3 * id + 1] - P[3 * s + 1], P[3 * id + 2] - P[3 * s + 2]);
          if (d < best) { best = d; who = s; }
        }
        near.set(id, [best, who]);
      }
    }
    const snap = { sel, selSet, P, median, pivot, pivotKind, frame, centerOf, near, proportional, mirror: null };
    if (this.opt.mirror) snap.mirror = this.mirrorMap(P, this.opt.mirrorAxis);
    // the controls the drag may move
    const points = new Set(sel);
    if (proportional) for (const id of cv.visibleIds) points.add(id);
    if (snap.mirror) for (const id of [...points]) { const j = snap.mirror.partner(id); if (j >= 0) points.add(j); }
    snap.points = [...points];
    return snap;
  }

  /** Mirror counterparts about the plane through the mesh's centre, normal to the axis: found by position. */
  mirrorMap(P, axis) {
    const cv = this.ed.controlsView;
    const m = (this.ed.state && this.ed.state.mesh) || {};
    const center = m.min && m.max ? 0.5 * (m.min[axis] + m.max[axis]) : 0;
    const tol = 1e-4 * this.diag;
    const key = (x, y, z) => `${Math.round(x / tol)},${Math.round(y / tol)},${Math.round(z / tol)}`;
    const grid = new Map();
    for (const id of cv.visibleIds) {
      const k = key(P[3 * id], P[3 * id + 1], P[3 * id + 2]);
      if (!grid.has(k)) grid.set(k, []);
      grid.get(k).push(id);
    }
    const cache = new Map();
    const partner = (id) => {
      if (cache.has(id)) return cache.get(id);
      const q = [P[3 * id], P[3 * id + 1], P[3 * id + 2]];
      q[axis] = 2 * center - q[axis];
      const gx = Math.round(q[0] / tol), gy = Math.round(q[1] / tol), gz = Math.round(q[2] / tol);
      let best = -1, bd = tol;
      for (let a = -1; a <= 1; a++) for (let b = -1; b <= 1; b++) for (let c = -1; c <= 1; c++) {
        for (const j of grid.get(`${gx + a},${gy + b},${gz + c}`) || []) {
          const d = Math.hypot(P[3 * j] - q[0], P[3 * j + 1] - q[1], P[3 * j + 2] - q[2]);
          if (d <= bd) { bd = d; best = j; }
        }
      }
      cache.set(id, best);
      return best;
    };
    return { axis, center, partner };
  }

  /**
   * The drag step of a transform xf from snapshot snap:
   *   {mode: 'translate', t: Vector3}
   *   {mode: 'rotate', axis: unit Vector3, angle: radians}
   *   {mode: 'scale', s: [su, sv, sw] along snap.frame's columns}
   * Returns {body, moves} (moves: Map id -> [dx, dy, dz], the change of each control).
   */
  plan(snap, xf) {
    const { sel, P, pivot, frame, centerOf, near, selSet } = snap;
    const radius = this.radius;
    const moves = new Map();
    const rot = new THREE.Quaternion();
    const v = new THREE.Vector3();
    const change = (id, w, c) => {
      const p = new THREE.Vector3(P[3 * id], P[3 * id + 1], P[3 * id + 2]);
      if (xf.mode === 'translate') return xf.t.clone().multiplyScalar(w);
      v.copy(p).sub(c);
      if (xf.mode === 'rotate') {
        rot.setFromAxisAngle(xf.axis, xf.angle * w);
        return v.clone().applyQuaternion(rot).sub(v);
      }
      const out = new THREE.Vector3();
      frame.forEach((e, k) => out.addScaledVector(e, v.dot(e) * (1 + w * (xf.s[k] - 1))));
      return out.sub(v);
    };
    for (const id of sel) moves.set(id, change(id, 1, centerOf.get(id) || pivot));
    const weight = new Map(sel.map((id) => [id, 1]));
    for (const [id, [d, who]] of near) {
      const w = smoothFalloff(d, radius);
      if (w <= 0) continue;
      moves.set(id, change(id, w, centerOf.get(who) || pivot));
      weight.set(id, w);
    }
    const mirror = snap.mirror;
    let mirrored = false;
    if (mirror) {
      const a = mirror.axis;
      for (const [id, d] of [...moves]) {
        const j = mirror.partner(id);
        if (j < 0) continue;
        if (j === id) { d.setComponent(a, 0); mirrored = true; continue; } // on the plane: stays on it
        if (selSet.has(j) || (weight.get(j) || 0) > weight.get(id)) continue; // its own move wins
        const m = d.clone();
        m.setComponent(a, -m.getComponent(a));
        moves.set(j, m);
        weight.set(j, weight.get(id));
        mirrored = true;
      }
    }
    // one rigid (or global-axes) motion of the whole selection about one pivot: its own form
    const rigid = !mirrored && snap.points.length === sel.length && snap.pivotKind !== 'individual';
    const method = methodOf(this.ed.state && this.ed.state.method);
    let body = null;
    if (rigid && xf.mode === 'rotate') body = { axis: xf.axis.toArray(), angle: xf.angle };
    else if (rigid && xf.mode === 'scale' && frame.every((e, k) => Math.abs(e.getComponent(k) - 1) < 1e-12)) body = { scale: [...xf.s] };
    else if (rigid && xf.mode === 'translate' && method.rigidDrags) body = { delta: xf.t.toArray() };
    if (!body) body = { moves: [...moves].map(([id, d]) => [id, d.x, d.y, d.z]) };
    return { body, moves };
  }

  // --- the modal operator ------------------------------------------------------

  onKey(ev) {
    if (this.modal) return this.modalKey(ev);
    if (ev.ctrlKey || ev.metaKey || ev.altKey) return false;
    const k = ev.key.toLowerCase();
    if (k === 'o' && !ev.shiftKey) { this.setOption('proportional', !this.opt.proportional); this.ed.info(`Proportional editing ${this.opt.proportional ? 'on' : 'off'}`); return true; }
    const mode = { g: 'translate', r: 'rotate', s: 'scale' }[k];
    if (!mode || ev.shiftKey || ev.repeat) return false;
    const ed = this.ed;
    // without a selection (or away from the view) the keys keep choosing the gizmo's mode
    if (!ed.selection.length || ed.tool !== 'controls' || !ed.hover || ed.activeDrag || !ed.state || !ed.state.method) return false;
    this.start(mode);
    return true;
  }

  /** Starts a modal transform of the selection from the pointer's position. */
  start(mode) {
    const ed = this.ed;
    const h = ed.hover;
    this.modal = {
      mode, axis: -1, plane: false, space: null, typed: '', ctrl: false,
      mouse0: { x: h.clientX, y: h.clientY }, mouse: { x: h.clientX, y: h.clientY }, last: { x: h.clientX, y: h.clientY },
      turn: 0, lastAngle: null, session: null, snap: null, restarting: null,
    };
    this.listen(true);
    ed.gizmo.helper.visible = false;
    this.begin();
    this.update();
  }

  /**
   * Individual origins on controls that carry frames (PB-FFD EBFs): a rotation
   * or scale turns or stretches each one's frame about its own centre — the
   * method's `frame` op at confirm (one undo step); the points stay put.
   */
  framesOnly(snap, mode) {
    const c = (this.ed.state && this.ed.state.controls) || {};
    return snap.pivotKind === 'individual' && mode !== 'translate' && Array.isArray(c.ebfs)
      && snap.sel.every((id) => id < c.ebfs.length);
  }

  begin() {
    const ed = this.ed;
    const mo = this.modal;
    mo.snap = this.snapshot();
    mo.framesOnly = this.framesOnly(mo.snap, mo.mode);
    mo.pivotScreen = ed.screenOf(mo.snap.median);
    if (mo.framesOnly) { mo.session = null; return; }
    const body = { points: mo.snap.points, mode: mo.mode, center: mo.snap.pivot.toArray() };
    if (ed.state) methodOf(ed.state.method).dragBody(ed, body);
    const s = new DragSession(ed, body, { planned: true });
    ed.gizmo.session = s;
    ed.gizmo.startPos.copy(ed.gizmo.pivot.position);
    ed.dragStarted(s);
    mo.session = s;
    // where the pivot is on screen, and the pointer's grab plane through it
    mo.pivotScreen = ed.screenOf(mo.snap.pivot);
    if (mo.snap.pivotKind === 'individual' || mo.snap.pivotKind === 'active') mo.pivotScreen = ed.screenOf(mo.snap.median);
  }

  /** Restarts the drag from the start (a setting that changes which controls move changed). */
  async refreshModal(restart) {
    const mo = this.modal;
    if (!mo) return;
    if (!restart) { this.update(); return; }
    if (mo.restarting) return;
    mo.restarting = (async () => {
      const ed = this.ed;
      const s = mo.session;
      if (s) {
        await s.cancel();
        if (ed.activeDrag === s) ed.activeDrag = null;
        ed.gizmo.session = null;
      }
      if (this.modal !== mo) return;
      this.begin();
      mo.restarting = null;
      this.update();
    })();
  }

  listen(on) {
    const f = on ? 'addEventListener' : 'removeEventListener';
    if (on) {
      this.handlers = {
        move: (ev) => {
          const mo = this.modal;
          if (!mo) return;
          // the amount follows a virtual pointer: Shift held moves it a tenth as fast (precision)
          const f = ev.shiftKey ? 0.1 : 1;
          mo.mouse = { x: mo.mouse.x + f * (ev.clientX - mo.last.x), y: mo.mouse.y + f * (ev.clientY - mo.last.y) };
          mo.last = { x: ev.clientX, y: ev.clientY };
          mo.ctrl = ev.ctrlKey;
          this.update();
        },
        down: (ev) => {
          if (!this.modal) return;
          ev.stopPropagation(); ev.preventDefault();
          // the click that follows ends here too (a button under the pointer is not pressed)
          const swallow = (e) => { e.stopPropagation(); e.preventDefault(); };
          window.addEventListener('click', swallow, { capture: true, once: true });
          setTimeout(() => window.removeEventListener('click', swallow, { capture: true }), 400);
          if (ev.button === 0) this.confirm(); else if (ev.button === 2) this.cancel();
        },
        up: (ev) => { if (this.modal) { ev.stopPropagation(); } },
        wheel: (ev) => {
          if (!this.modal) return;
          ev.stopPropagation(); ev.preventDefault();
          if (!this.opt.proportional) return;
          this.opt.radius = this.radius * (ev.deltaY < 0 ? 1.1 : 1 / 1.1);
          this.update();
          this.numeric.refresh(true);
        },
        keyup: (ev) => { if (this.modal && ev.key === 'Control') { this.modal.ctrl = false; this.update(); } },
        menu: (ev) => { if (this.modal) ev.preventDefault(); },
      };
    }
    const hd = this.handlers;
    window[f]('pointermove', hd.move, true);
    window[f]('pointerdown', hd.down, true);
    window[f]('pointerup', hd.up, true);
    window[f]('wheel', hd.wheel, { capture: true, passive: false });
    window[f]('keyup', hd.keyup, true);
    window[f]('contextmenu', hd.menu, true);
  }

  modalKey(ev) {
    const mo = this.modal;
    const k = ev.key;
    if (k === 'Escape') { this.cancel(); return true; }
    if (k === 'Enter') { this.confirm(); return true; }
    if (k === 'Control') { mo.ctrl = true; this.update(); return true; }
    if (ev.ctrlKey || ev.metaKey || ev.altKey) return true;
    const lower = k.toLowerCase();
    const a = AXES.indexOf(k.toUpperCase());
    if (a >= 0) { this.constrain(a, ev.shiftKey); return true; }
    if (/^[0-9]$/.test(k) || k === '.' || k === ',') {
      if ((k === '.' || k === ',') && mo.typed.includes('.')) return true;
      mo.typed += k === ',' ? '.' : k;
      this.update();
      return true;
    }
    if (k === '-') { mo.typed = mo.typed.startsWith('-') ? mo.typed.slice(1) : `-${mo.typed}`; this.update(); return true; }
    if (k === 'Backspace') { mo.typed = mo.typed.slice(0, -1); this.update(); return true; }
    const mode = { g: 'translate', r: 'rotate', s: 'scale' }[lower];
    if (mode && mode !== mo.mode) {
      mo.mode = mode; mo.typed = ''; mo.turn = 0; mo.lastAngle = null;
      mo.mouse0 = { ...mo.mouse };
      this.refreshModal(true);
      return true;
    }
    if (lower === 'o') { this.setOption('proportional', !this.opt.proportional); return true; }
    return true; // every other key waits for the transform to end
  }

  /** X / Y / Z: the axis, again its local orientation (or the global one after local), again off; Shift: the plane without it. */
  constrain(a, plane) {
    const mo = this.modal;
    const first = this.opt.orientation === 'local' ? 'local' : 'global';
    const second = first === 'local' ? 'global' : 'local';
    if (mo.axis !== a || mo.plane !== plane) { mo.axis = a; mo.plane = plane; mo.space = first; }
    else if (mo.space === first) mo.space = second;
    else { mo.axis = -1; mo.plane = false; mo.space = null; }
    this.update();
  }

  /** The constraint's axes (unit world vectors) in its orientation. */
  constraintFrame() {
    const mo = this.modal;
    const snap = mo.snap;
    const local = mo.axis < 0 ? this.opt.orientation === 'local' : mo.space === 'local';
    if (!local) return [new THREE.Vector3(1, 0, 0), new THREE.Vector3(0, 1, 0), new THREE.Vector3(0, 0, 1)];
    if (!snap.local) snap.local = this.orientation('local', snap.P, snap.sel);
    return snap.local;
  }

  /** The transform now: from the typed amount, else the pointer; snapped. */
  current() {
    const mo = this.modal;
    const vp = this.ed.vp;
    const B = this.constraintFrame();
    const free = mo.axis < 0 ? [0, 1, 2] : mo.plane ? [0, 1, 2].filter((k) => k !== mo.axis) : [mo.axis];
    const snapping = this.opt.snap !== mo.ctrl;
    // a typed number sets the amount; '-' alone negates the mouse's
    const neg = mo.typed === '-' ? -1 : 1;
    const typed = mo.typed !== '' ? parseFloat(mo.typed) : NaN;
    const value = Number.isNaN(typed) ? null : typed;
    const camDir = vp.camera.getWorldDirection(new THREE.Vector3());
    const c = mo.snap.pivot;
    if (mo.mode === 'translate') {
      const t = new THREE.Vector3();
      let shown;
      if (value !== null) {
        t.addScaledVector(B[free[0]], value);
        shown = mo.typed;
      } else {
        t.copy(this.grabDelta(B, free, camDir));
        if (snapping) {
          const tb = B.map((e) => t.dot(e));
          const cb = B.map((e) => c.dot(e));
          const s = this.step;
          for (const k of free) tb[k] = this.opt.snapKind === 'grid' ? Math.round((cb[k] + tb[k]) / s) * s - cb[k] : Math.round(tb[k] / s) * s;
          t.set(0, 0, 0);
          B.forEach((e, k) => t.addScaledVector(e, tb[k]));
        }
        t.multiplyScalar(neg);
        shown = free.length === 1 ? fmt(t.dot(B[free[0]])) : free.map((k) => fmt(t.dot(B[k]))).join(', ');
      }
      return { xf: { mode: 'translate', t }, shown };
    }
    if (mo.mode === 'rotate') {
      let axis = mo.axis >= 0 ? B[mo.axis].clone() : camDir.clone().negate();
      let angle;
      if (value !== null) angle = THREE.MathUtils.degToRad(value);
      else {
        const a = Math.atan2(-(mo.mouse.y - mo.pivotScreen.y), mo.mouse.x - mo.pivotScreen.x);
        const a0 = Math.atan2(-(mo.mouse0.y - mo.pivotScreen.y), mo.mouse0.x - mo.pivotScreen.x);
        let d = a - a0 - mo.turn;
        // unwrap: follow the pointer round and round
        if (mo.lastAngle !== null) {
          while (d - mo.lastAngle > Math.PI) { d -= 2 * Math.PI; mo.turn += 2 * Math.PI; }
          while (d - mo.lastAngle < -Math.PI) { d += 2 * Math.PI; mo.turn -= 2 * Math.PI; }
        }
        mo.lastAngle = d;
        // turning the pointer counter-clockwise on screen turns counter-clockwise as seen
        angle = axis.dot(camDir) > 0 ? -d : d;
        if (snapping) angle = THREE.MathUtils.degToRad(Math.round(THREE.MathUtils.radToDeg(angle) / 5) * 5);
        angle *= neg;
      }
      if (axis.lengthSq() < 1e-12) axis = new THREE.Vector3(0, 0, 1);
      const shown = value !== null ? `${mo.typed}°` : `${fmt(THREE.MathUtils.radToDeg(angle), 2)}°`;
      return { xf: { mode: 'rotate', axis: axis.normalize(), angle }, shown };
    }
    let f;
    if (value !== null) f = value;
    else {
      const r0 = Math.hypot(mo.mouse0.x - mo.pivotScreen.x, mo.mouse0.y - mo.pivotScreen.y);
      const r = Math.hypot(mo.mouse.x - mo.pivotScreen.x, mo.mouse.y - mo.pivotScreen.y);
      f = r0 > 1 ? r / r0 : 1;
      if (snapping) f = Math.round(f * 10) / 10;
      f *= neg;
    }
    const s = [1, 1, 1];
    for (const k of free) s[k] = f;
    // the scale's frame: the constraint's orientation
    mo.snap.frame = B;
    return { xf: { mode: 'scale', s }, shown: value !== null ? mo.typed : fmt(f, 3) };
  }

  /** The pointer's move since the start as a world vector, constrained. */
  grabDelta(B, free, camDir) {
    const mo = this.modal;
    const vp = this.ed.vp;
    const c = mo.snap.pivot;
    const ray = new THREE.Raycaster();
    const rayAt = (m) => { ray.setFromCamera(vp.ndc({ clientX: m.x, clientY: m.y }), vp.camera); return ray.ray.clone(); };
    const r0 = rayAt(mo.mouse0), r1 = rayAt(mo.mouse);
    const onPlane = (n) => {
      const plane = new THREE.Plane().setFromNormalAndCoplanarPoint(n, c);
      const a = r0.intersectPlane(plane, new THREE.Vector3()), b = r1.intersectPlane(plane, new THREE.Vector3());
      return a && b ? b.sub(a) : new THREE.Vector3();
    };
    if (free.length === 3) return onPlane(camDir);
    if (free.length === 1) {
      const u = B[free[0]];
      if (Math.abs(u.dot(camDir)) > 0.985) { const d = onPlane(camDir); return u.clone().multiplyScalar(d.dot(u)); }
      // the point of the axis line nearest the pointer's ray
      const param = (r) => {
        const w0 = c.clone().sub(r.origin);
        const b = u.dot(r.direction), d = u.dot(w0), e = r.direction.dot(w0);
        const den = 1 - b * b;
        return den < 1e-9 ? 0 : (b * e - d) / den;
      };
      return u.clone().multiplyScalar(param(r1) - param(r0));
    }
    const n = B[mo.axis];
    if (Math.abs(n.dot(camDir)) < 0.05) { const d = onPlane(camDir); return d.sub(n.clone().multiplyScalar(d.dot(n))); }
    return onPlane(n);
  }

  update() {
    const mo = this.modal;
    if (!mo || !mo.snap || mo.restarting) return;
    const { xf, shown } = this.current();
    mo.xf = xf;
    if (mo.session) mo.session.update(this.plan(mo.snap, xf).body);
    // the pivot follows a grab
    this.drawModal(xf, shown);
  }

  drawModal(xf, shown) {
    const mo = this.modal;
    const label = mo.axis < 0 ? '' : `${mo.space === 'local' ? ' local' : ''} ${mo.plane ? AXES.filter((_, k) => k !== mo.axis).join('') : AXES[mo.axis]}`;
    const snapping = this.opt.snap !== mo.ctrl;
    const extras = [
      snapping ? `snap ${this.opt.snapKind === 'grid' ? 'to grid' : 'increment'} ${xf.mode === 'translate' ? fmt(this.step) : xf.mode === 'rotate' ? '5°' : '0.1'}` : '',
      this.opt.proportional ? `proportional ${fmt(this.radius, 3)} (wheel)` : '',
      this.opt.mirror ? `mirror ${AXES[this.opt.mirrorAxis]}` : '',
      mo.framesOnly ? 'each EBF\'s frame about its own centre (on confirm)' : '',
    ].filter(Boolean).join(' · ');
    this.header.hidden = false;
    this.header.replaceChildren();
    const main = document.createElement('b');
    main.className = 'transform-value';
    main.textContent = `${MODE_NAMES[mo.mode]}${label}: ${shown}`;
    const more = document.createElement('span');
    more.textContent = `${extras ? `${extras} · ` : ''}Enter/click: confirm · Esc/right click: cancel · X Y Z: axis (Shift: plane) · type a value · Ctrl: snap · Shift: precision`;
    this.header.append(main, more);
    // constraint lines and the radius circle about the pivot
    const c = mo.snap.pivot.clone();
    if (xf.mode === 'translate') c.add(xf.t);
    const B = this.constraintFrame();
    this.axisLines.forEach((l, k) => {
      const on = mo.axis >= 0 && (mo.plane ? k !== mo.axis : k === mo.axis);
      l.visible = on;
      if (on) {
        const L = 1.5 * this.diag; // long enough to read, short of the camera
        const pos = l.geometry.attributes.position;
        const e = B[k];
        pos.setXYZ(0, c.x - e.x * L, c.y - e.y * L, c.z - e.z * L);
        pos.setXYZ(1, c.x + e.x * L, c.y + e.y * L, c.z + e.z * L);
        pos.needsUpdate = true;
        l.geometry.computeBoundingSphere();
        l.frustumCulled = false;
      }
    });
    this.radiusObj.visible = this.opt.proportional;
    this.radiusObj.position.copy(c);
    this.ed.vp.requestRender();
  }

  clearModal() {
    this.listen(false);
    this.header.hidden = true;
    for (const l of this.axisLines) l.visible = false;
    this.radiusObj.visible = false;
    this.modal = null;
    this.ed.vp.requestRender();
  }

  async confirm() {
    const mo = this.modal;
    if (!mo) return;
    if (mo.restarting) await mo.restarting;
    this.clearModal();
    if (mo.framesOnly) await this.applyFrames(mo);
    else await this.ed.endControlDrag(mo.session);
    this.numeric.refresh(true);
  }

  /** The frames' turn or stretch of a frames-only transform (framesOnly). */
  async applyFrames(mo) {
    const xf = mo.xf;
    const body = { points: [...mo.snap.sel] };
    if (!xf || (xf.mode === 'rotate' && !xf.angle) || (xf.mode === 'scale' && xf.s.every((f) => f === 1))) { this.ed.gizmo.update(); return; }
    if (xf.mode === 'rotate') Object.assign(body, { axis: xf.axis.toArray(), angle: xf.angle });
    else body.scale = [...xf.s];
    await this.ed.run('frame', body);
    this.ed.gizmo.update();
  }

  async cancel() {
    const mo = this.modal;
    if (!mo) return;
    if (mo.restarting) await mo.restarting;
    this.clearModal();
    if (mo.framesOnly) this.ed.gizmo.update();
    else await this.ed.cancelDrag();
    this.numeric.refresh(true);
  }

  /**
   * A gizmo or point drag (DragSession) with mirror or proportional editing on,
   * or about individual origins: adds the counterparts and neighbours to
   * begin.points and returns the map from a step body (delta, axis/angle,
   * scale about begin.center along the world axes) to the step that moves
   * them all; null when none of these is on.
   */
  dragPlan(begin) {
    if ((!this.opt.mirror && !this.opt.proportional && this.opt.pivot !== 'individual') || this.modal) return null;
    const ed = this.ed;
    if (begin.points.length !== ed.selection.length || begin.points.some((id, i) => id !== ed.selection[i])) return null;
    const snap = this.snapshot();
    if (begin.center) snap.pivot = new THREE.Vector3(...begin.center);
    snap.frame = [new THREE.Vector3(1, 0, 0), new THREE.Vector3(0, 1, 0), new THREE.Vector3(0, 0, 1)];
    begin.points = snap.points;
    return (body) => {
      let xf = null;
      if (body.delta) xf = { mode: 'translate', t: new THREE.Vector3(...body.delta) };
      else if (body.axis) xf = { mode: 'rotate', axis: new THREE.Vector3(...body.axis).normalize(), angle: body.angle };
      else if (body.scale) xf = { mode: 'scale', s: [...body.scale] };
      return xf ? this.plan(snap, xf).body : body;
    };
  }

  // --- one-shot transforms (the numeric panel) -----------------------------------

  /** Applies xf to the selection in one request (`move`: one undo step), with mirror, without proportional editing. */
  async apply(xfOf) {
    const ed = this.ed;
    if (!ed.selection.length || ed.activeDrag || this.modal) return null;
    const snap = this.snapshot({ proportional: false });
    const xf = xfOf(snap);
    const { body } = this.plan(snap, xf);
    const req = { points: snap.points, ...body };
    if (body.axis || body.scale) req.center = snap.pivot.toArray();
    if (ed.state) methodOf(ed.state.method).dragBody(ed, req);
    return ed.run('move', req);
  }
}

/** Principal axes of points (the eigenvectors of their covariance), or null. */
function principalAxes(pts) {
  if (pts.length < 3) return null;
  const c = new THREE.Vector3();
  for (const p of pts) c.add(p);
  c.multiplyScalar(1 / pts.length);
  const C = [[0, 0, 0], [0, 0, 0], [0, 0, 0]];
  for (const p of pts) {
    const d = [p.x - c.x, p.y - c.y, p.z - c.z];
    for (let i = 0; i < 3; i++) for (let j = 0; j < 3; j++) C[i][j] += d[i] * d[j];
  }
  // Jacobi rotations on the symmetric 3x3
  const V = [[1, 0, 0], [0, 1, 0], [0, 0, 1]];
  for (let sweep = 0; sweep < 30; sweep++) {
    let off = 0;
    for (const [p, q] of [[0, 1], [0, 2], [1, 2]]) {
      off += C[p][q] ** 2;
      if (Math.abs(C[p][q]) < 1e-18) continue;
      const th = 0.5 * Math.atan2(2 * C[p][q], C[q][q] - C[p][p]);
      const cs = Math.cos(th), sn = Math.sin(th);
      for (let k = 0; k < 3; k++) {
        const a = C[k][p], b = C[k][q];
        C[k][p] = cs * a - sn * b; C[k][q] = sn * a + cs * b;
      }
      for (let k = 0; k < 3; k++) {
        const a = C[p][k], b = C[q][k];
        C[p][k] = cs * a - sn * b; C[q][k] = sn * a + cs * b;
      }
      for (let k = 0; k < 3; k++) {
        const a = V[k][p], b = V[k][q];
        V[k][p] = cs * a - sn * b; V[k][q] = sn * a + cs * b;
      }
    }
    if (off < 1e-24) break;
  }
  // order the axes as near the world X, Y, Z as they come (an axis-aligned box keeps X, Y, Z)
  const cols = [0, 1, 2].map((k) => new THREE.Vector3(V[0][k], V[1][k], V[2][k]));
  const out = [];
  for (let a = 0; a < 3; a++) {
    let best = 0, bv = -1;
    cols.forEach((v, k) => { if (v && Math.abs(v.getComponent(a)) > bv) { bv = Math.abs(v.getComponent(a)); best = k; } });
    const v = cols[best];
    cols[best] = null;
    out.push(v.getComponent(a) < 0 ? v.negate() : v);
  }
  return out;
}

/** Gram–Schmidt on three vectors (a right-handed frame), or null when degenerate. */
function orthonormal([a, b]) {
  const u = a.clone();
  if (u.lengthSq() < 1e-24) return null;
  u.normalize();
  const v = b.clone().addScaledVector(u, -b.dot(u));
  if (v.lengthSq() < 1e-24) return null;
  v.normalize();
  return [u, v, new THREE.Vector3().crossVectors(u, v)];
}
