// Picking of control points in screen space, click / shift-click / box select,
// and a free (screen-plane) drag of the selection by its points.

import * as THREE from 'three';
import { DragSession } from './drag.js';
import { methodOf } from './methods/index.js';

const PICK_PX = 10;

export class Selector {
  constructor(editor) {
    this.ed = editor;
    this.box = document.createElement('div');
    this.box.className = 'select-box';
    this.box.hidden = true;
    editor.container.appendChild(this.box);
    this.boxArmed = false; // key B
    // hover highlight: the handle under the pointer (controls tool, no button held)
    let queued = null;
    editor.container.addEventListener('pointermove', (ev) => {
      if (queued) { queued = ev; return; }
      queued = ev;
      requestAnimationFrame(() => { const e = queued; queued = null; this.hoverAt(e); });
    });
    editor.container.addEventListener('pointerleave', () => this.ed.controlsView.setHover(-1));
  }

  hoverAt(ev) {
    const ed = this.ed;
    const over = ev.target === ed.vp.renderer.domElement;
    const id = over && !ev.buttons && ed.tool === 'controls' && !ed.activeDrag ? this.pick(ev) : -1;
    ed.controlsView.setHover(id);
  }

  /** Handles that can be picked now: the visible ones, and with X-ray off only those in front of the mesh. */
  candidates() {
    const cv = this.ed.controlsView;
    if (cv.xray) return cv.visibleIds;
    const hidden = cv.occlusion();
    return cv.visibleIds.filter((id) => !hidden[id]);
  }

  /** The method's rows / layers through the selection (lattice: by index), else by position. */
  selectLayer(axis, { row = false } = {}) {
    const ed = this.ed;
    if (!ed.selection.length || !ed.state || !ed.state.method) return false;
    const c = ed.state.controls || {};
    const sel = methodOf(ed.state.method).select || {};
    const fn = row ? sel.row : sel.layer;
    const ids = fn ? fn(c, ed.selection, axis) : this.byPosition(axis, row);
    const cv = ed.controlsView;
    ed.setSelection(ids.filter((id) => cv.isVisible(id)));
    return true;
  }

  /**
   * Methods without a grid (T-spline proxy, cage, ...): the visible handles on
   * the plane (layer: same coordinate along axis) or on the line (row: same
   * other two coordinates) through each selected handle, within 2% of the mesh size.
   */
  byPosition(axis, row) {
    const cv = this.ed.controlsView;
    const tol = 0.02 * this.ed.vp.diag;
    const a = new THREE.Vector3(), b = new THREE.Vector3();
    const picks = this.ed.selection.map((id) => cv.position(id, new THREE.Vector3()));
    return cv.visibleIds.filter((id) => {
      cv.position(id, b);
      return picks.some((p) => {
        a.copy(p).sub(b);
        const d = [Math.abs(a.x), Math.abs(a.y), Math.abs(a.z)];
        return row ? d.every((x, t) => t === axis || x <= tol) : d[axis] <= tol;
      });
    });
  }

  /** Nearest visible control within PICK_PX of the pointer (ties: nearest the camera). */
  pick(ev) {
    const cv = this.ed.controlsView;
    if (!cv.count || !cv.group.visible) return -1;
    const rect = this.ed.vp.renderer.domElement.getBoundingClientRect();
    const mx = ev.clientX - rect.left, my = ev.clientY - rect.top;
    const v = new THREE.Vector3();
    const cam = this.ed.vp.camera;
    let best = -1, bd = PICK_PX * PICK_PX, bz = Infinity;
    for (const id of this.candidates()) {
      cv.position(id, v).project(cam);
      if (v.z < -1 || v.z > 1) continue;
      const x = (v.x + 1) / 2 * rect.width, y = (1 - v.y) / 2 * rect.height;
      const d = (x - mx) ** 2 + (y - my) ** 2;
      if (d < bd - 1e-6 || (Math.abs(d - bd) <= 1e-6 && v.z < bz)) { best = id; bd = d; bz = v.z; }
    }
    return best;
  }

  /** Pointer-down with the controls tool. Returns true when consumed. */
  pointerDown(ev) {
    const ed = this.ed;
    const id = this.pick(ev);
    if (id >= 0) {
      const sel = new Set(ed.selection);
      if (ev.shiftKey || ev.ctrlKey || ev.metaKey) { // Ctrl+click toggles too (never pins here)
        if (sel.has(id)) sel.delete(id); else sel.add(id);
        ed.setSelection([...sel]);
        return true;
      }
      // a click on a selected point makes it the active one (the last)
      if (!sel.has(id)) ed.setSelection([id]);
      else if (ed.selection[ed.selection.length - 1] !== id) ed.setSelection([...ed.selection.filter((x) => x !== id), id]);
      this.startPointDrag(ev, id);
      return true;
    }
    if (this.boxArmed || ev.shiftKey) {
      this.startBox(ev);
      return true;
    }
    // empty click (no drag) clears the selection; a drag orbits
    const x0 = ev.clientX, y0 = ev.clientY;
    const up = (e) => {
      window.removeEventListener('pointerup', up);
      if (Math.hypot(e.clientX - x0, e.clientY - y0) < 3 && ed.selection.length) ed.setSelection([]);
    };
    window.addEventListener('pointerup', up);
    return false;
  }

  startBox(ev) {
    const rect = this.ed.container.getBoundingClientRect();
    const x0 = ev.clientX - rect.left, y0 = ev.clientY - rect.top;
    const add = ev.shiftKey;
    const b = this.box;
    const place = (x1, y1) => {
      b.style.left = `${Math.min(x0, x1)}px`; b.style.top = `${Math.min(y0, y1)}px`;
      b.style.width = `${Math.abs(x1 - x0)}px`; b.style.height = `${Math.abs(y1 - y0)}px`;
    };
    place(x0, y0);
    b.hidden = false;
    const move = (e) => place(e.clientX - rect.left, e.clientY - rect.top);
    const up = (e) => {
      window.removeEventListener('pointermove', move);
      window.removeEventListener('pointerup', up);
      b.hidden = true;
      this.boxArmed = false;
      this.ed.emit('tool');
      const x1 = e.clientX - rect.left, y1 = e.clientY - rect.top;
      const ids = this.inRect(Math.min(x0, x1), Math.min(y0, y1), Math.max(x0, x1), Math.max(y0, y1));
      const sel = add ? new Set([...this.ed.selection, ...ids]) : new Set(ids);
      this.ed.setSelection([...sel]);
    };
    window.addEventListener('pointermove', move);
    window.addEventListener('pointerup', up);
  }

  /** Pickable controls (candidates()) inside a rectangle in container CSS pixels. */
  inRect(x0, y0, x1, y1) {
    const cv = this.ed.controlsView;
    const rect = this.ed.vp.renderer.domElement.getBoundingClientRect();
    const crect = this.ed.container.getBoundingClientRect();
    const ox = rect.left - crect.left, oy = rect.top - crect.top;
    const v = new THREE.Vector3();
    const out = [];
    for (const id of this.candidates()) {
      cv.position(id, v).project(this.ed.vp.camera);
      if (v.z < -1 || v.z > 1) continue;
      const x = ox + (v.x + 1) / 2 * rect.width, y = oy + (1 - v.y) / 2 * rect.height;
      if (x >= x0 && x <= x1 && y >= y0 && y <= y1) out.push(id);
    }
    return out;
  }

  /** Pressing on a control point and moving drags the selection in the view plane. */
  startPointDrag(ev, id) {
    const ed = this.ed;
    const vp = ed.vp;
    const x0 = ev.clientX, y0 = ev.clientY;
    const anchor = ed.controlsView.position(id);
    const normal = vp.camera.getWorldDirection(new THREE.Vector3());
    const plane = new THREE.Plane().setFromNormalAndCoplanarPoint(normal, anchor);
    const ray = new THREE.Raycaster();
    const hitOf = (e) => {
      ray.setFromCamera(vp.ndc(e), vp.camera);
      return ray.ray.intersectPlane(plane, new THREE.Vector3());
    };
    const start = hitOf(ev) || anchor.clone();
    let session = null;
    const move = (e) => {
      if (!session) {
        if (Math.hypot(e.clientX - x0, e.clientY - y0) < 3) return;
        session = ed.beginControlDrag('translate');
        if (!session) return;
      }
      const h = hitOf(e);
      if (!h) return;
      const d = h.sub(start);
      const ax = ed.gizmo.axis;
      if (ax) {
        const u = new THREE.Vector3(ax === 'X' ? 1 : 0, ax === 'Y' ? 1 : 0, ax === 'Z' ? 1 : 0);
        d.copy(u.multiplyScalar(d.dot(u)));
      }
      session.update({ delta: d.toArray() });
      ed.gizmo.followDelta(d);
    };
    const up = async () => {
      window.removeEventListener('pointermove', move);
      window.removeEventListener('pointerup', up);
      if (session) await ed.endControlDrag(session);
      // a click (no drag) on a point of a larger selection selects it alone, as in Blender
      else if (!ev.shiftKey && ed.selection.length > 1 && ed.selection.includes(id)) ed.setSelection([id]);
    };
    window.addEventListener('pointermove', move);
    window.addEventListener('pointerup', up);
  }
}
