// Direct manipulation (Hsu et al. 1992): drag points of the mesh surface,
// pin vertices, show each pin's residual when the deformer cannot reach it.

import * as THREE from 'three';
import { DragSession } from './drag.js';
import { api } from './api.js';
import { COL } from './palette.js';

export class DirectManip {
  constructor(editor) {
    this.ed = editor;
    this.group = new THREE.Group();
    editor.vp.overlays.add(this.group);
    this.labels = document.createElement('div');
    this.labels.className = 'pin-labels';
    editor.container.appendChild(this.labels);
    this.sphereGeom = new THREE.SphereGeometry(1, 16, 12);
    this.okMat = new THREE.MeshBasicMaterial({ color: COL.pin, depthTest: false, transparent: true });
    this.badMat = new THREE.MeshBasicMaterial({ color: COL.pinMissed, depthTest: false, transparent: true });
    this.selMat = new THREE.MeshBasicMaterial({ color: COL.pinSelected, depthTest: false, transparent: true });
    this.targetMat = new THREE.MeshBasicMaterial({ color: 0xffffff, wireframe: true, depthTest: false, transparent: true, opacity: 0.8 });
    this.pins = [];            // from the state: {vertex, target, residual}
    this.residuals = null;     // from the latest frame (pins, then the dragged vertex)
    this.drag = null;          // {vertex, target:Vector3}
    this.selectedPin = -1;     // vertex id
    this.pinAfterDrag = false;
    editor.vp.onBeforeRender.push(() => this.placeLabels());
  }

  tolerance() { return 1e-6 * this.ed.vp.diag; }

  setPins(pins) {
    this.pins = pins || [];
    if (!this.pins.some((p) => p.vertex === this.selectedPin)) this.selectedPin = -1;
    this.residuals = null;
    this.redraw();
  }

  setFrameResiduals(res) {
    this.residuals = res && res.length ? Array.from(res) : null;
    this.redraw();
  }

  /** Rebuilds the pin markers (few objects; cheap). */
  redraw() {
    const vp = this.ed.vp;
    for (const o of [...this.group.children]) { this.group.remove(o); if (o.isLine) o.geometry.dispose(); }
    this.labels.replaceChildren();
    this.labelItems = [];
    if (!vp.geometry) return;
    const r = vp.diag * 0.008;
    const tol = this.tolerance();
    const items = this.pins.map((p, i) => ({
      vertex: p.vertex, target: new THREE.Vector3(...p.target),
      residual: this.residuals && i < this.residuals.length ? this.residuals[i] : p.residual,
      pin: true,
    }));
    if (this.drag) {
      const i = this.pins.length;
      items.push({
        vertex: this.drag.vertex, target: this.drag.target.clone(),
        residual: this.residuals && i < this.residuals.length ? this.residuals[i] : 0, pin: false,
      });
    }
    for (const it of items) {
      if (it.vertex >= vp.vertexCount) continue;
      const at = vp.vertex(it.vertex);
      const bad = (it.residual || 0) > tol;
      const mat = it.vertex === this.selectedPin ? this.selMat : bad ? this.badMat : this.okMat;
      const s = new THREE.Mesh(this.sphereGeom, it.pin ? mat : this.selMat);
      s.position.copy(at);
      s.scale.setScalar(it.pin ? r : r * 1.2);
      s.renderOrder = 30;
      this.group.add(s);
      if (at.distanceTo(it.target) > r) {
        const t = new THREE.Mesh(this.sphereGeom, this.targetMat);
        t.position.copy(it.target);
        t.scale.setScalar(r * 0.8);
        t.renderOrder = 30;
        this.group.add(t);
      }
      const lg = new THREE.BufferGeometry().setFromPoints([at, it.target]);
      const line = new THREE.Line(lg, new THREE.LineBasicMaterial({
        color: bad ? 0xff6b6b : 0xdddddd, depthTest: false, transparent: true, opacity: 0.9,
      }));
      line.renderOrder = 29;
      this.group.add(line);
      if (bad) {
        const el = document.createElement('div');
        el.className = it.pin ? 'pin-label' : 'pin-label drag-short';
        el.textContent = it.pin ? `Δ ${fmt(it.residual)}` : `short by ${fmt(it.residual)}`;
        el.title = it.pin
          ? `vertex ${it.vertex}: the deformer cannot reach the target (residual ${it.residual})`
          : `The pins hold; the dragged point stays ${fmt(it.residual)} from where you dragged it`;
        this.labels.appendChild(el);
        this.labelItems.push({ el, at: at.clone() });
      }
    }
    vp.requestRender();
    this.showShortfall();
  }

  /**
   * Pins hard, drag soft: the server holds the pins exactly and brings the
   * dragged point as close as they allow. Returns {drag, pinsHeld}: how far
   * the dragged point still is from where it was dragged (null: no drag
   * solved), and whether every pin is held.
   */
  shortfall() {
    const tol = this.tolerance();
    const n = this.pins.length;
    if (this.drag && this.residuals) {
      return {
        drag: this.residuals.length > n ? this.residuals[n] : null,
        pinsHeld: this.residuals.slice(0, n).every((r) => r <= tol),
      };
    }
    const m = (this.ed.state || {}).manip;
    if (!m) return { drag: null, pinsHeld: true };
    return { drag: m.drag_residual === undefined ? null : m.drag_residual, pinsHeld: m.pins_met !== false };
  }

  /** What the status bar and the panel say: {text, title} ("drag short by …", plain words in the tooltip). */
  shortfallText() {
    const { drag, pinsHeld } = this.shortfall();
    const short = drag !== null && drag > this.tolerance();
    let text = '', title = '';
    if (!pinsHeld) {
      text = 'Pins conflict: held as closely as possible';
      title = 'The pins ask for more than the deformer can do at once (too many pins close together, or pins pulled apart), '
        + 'so none of them is exactly where it should be: each is as close as the others allow. Unpin one, or use a finer deformer.';
    } else if (short) {
      text = `Drag short by ${fmt(drag)}`;
      title = `The pins stay exactly where they are; the dragged point could only come within ${fmt(drag)} (scene units) of where you dragged it, `
        + 'because the deformer has no freedom left near it that would not move a pin. Unpin a nearby vertex, or use a finer deformer, to reach it.';
    }
    return { text, title };
  }

  showShortfall() {
    const { text, title } = this.shortfallText();
    for (const id of ['st-dm', 'dm-shortfall']) {
      const el = document.getElementById(id);
      if (!el) continue;
      if (el.textContent !== text) el.textContent = text;
      el.title = title;
      el.classList.toggle('warn', !!text);
    }
  }

  placeLabels() {
    if (!this.labelItems) return;
    for (const { el, at } of this.labelItems) {
      const s = this.ed.vp.toScreen(at);
      el.style.transform = `translate(${Math.round(s.x + 8)}px, ${Math.round(s.y - 22)}px)`;
      el.style.display = s.z > 1 ? 'none' : '';
    }
  }

  /** Pin under the pointer (screen distance to the pinned vertex), or -1. */
  pickPin(ev) {
    const vp = this.ed.vp;
    const rect = vp.renderer.domElement.getBoundingClientRect();
    let best = -1, bd = 12 * 12;
    for (const p of this.pins) {
      if (p.vertex >= vp.vertexCount) continue;
      const s = vp.toScreen(vp.vertex(p.vertex));
      const d = (s.x - (ev.clientX - rect.left)) ** 2 + (s.y - (ev.clientY - rect.top)) ** 2;
      if (d < bd) { bd = d; best = p.vertex; }
    }
    return best;
  }

  async pinVertex(vertex, target) {
    const body = { vertex };
    if (target) body.target = target;
    const st = await this.ed.run('pin', body);
    if (st) this.selectedPin = vertex;
    this.redraw();
  }

  async unpin(vertex) {
    if (vertex < 0) return;
    await this.ed.run('unpin', { vertex });
    if (this.selectedPin === vertex) this.selectedPin = -1;
  }

  /** Pointer-down on the mesh with the mesh tool: drag its nearest vertex. */
  start(ev, hit) {
    const ed = this.ed;
    const vp = ed.vp;
    const pinHit = this.pickPin(ev);
    const vertex = pinHit >= 0 ? pinHit : hit.vertex;
    if (pinHit >= 0) { this.selectedPin = pinHit; }
    const startPos = vp.vertex(vertex);
    const normal = vp.camera.getWorldDirection(new THREE.Vector3());
    const plane = new THREE.Plane().setFromNormalAndCoplanarPoint(normal, startPos);
    const ray = new THREE.Raycaster();
    const hitOf = (e) => {
      ray.setFromCamera(vp.ndc(e), vp.camera);
      return ray.ray.intersectPlane(plane, new THREE.Vector3());
    };
    const origin = hitOf(ev) || startPos.clone();
    const x0 = ev.clientX, y0 = ev.clientY;
    let session = null;
    const pinned = this.pins.find((p) => p.vertex === vertex);
    // Esc (Editor.cancelDrag) ends the drag on the server and clears this.drag:
    // the pointer's later moves and its release then have nothing to do
    const cancelled = () => session && (session.closed || ed.activeDrag !== session || !this.drag);
    const move = (e) => {
      if (cancelled()) { detach(); return; }
      if (!session) {
        if (Math.hypot(e.clientX - x0, e.clientY - y0) < 3) return;
        session = new DragSession(ed, { vertex });
        ed.dragStarted(session);
        this.drag = { vertex, target: startPos.clone() };
      }
      const h = hitOf(e);
      if (!h) return;
      const target = startPos.clone().add(h.sub(origin));
      this.drag.target.copy(target);
      session.update({ target: target.toArray() });
      this.redraw();
    };
    const detach = () => {
      window.removeEventListener('pointermove', move);
      window.removeEventListener('pointerup', up);
    };
    const up = async () => {
      detach();
      if (!session || cancelled()) { this.redraw(); return; }
      const target = this.drag.target.toArray();
      const st = await ed.endDrag(session);
      this.drag = null;
      // a dragged pin keeps its new target; with "pin dragged points" so does any vertex
      if (st && (pinned || this.pinAfterDrag)) await this.pinVertex(vertex, target);
      this.redraw();
    };
    window.addEventListener('pointermove', move);
    window.addEventListener('pointerup', up);
  }
}

function fmt(x) {
  if (x === undefined || x === null) return '?';
  const a = Math.abs(x);
  return a >= 100 || a < 1e-3 ? x.toExponential(2) : x.toPrecision(3);
}

