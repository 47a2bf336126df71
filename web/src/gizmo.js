// Translate / rotate / scale gizmo (three's TransformControls) on a pivot at
// the transform pivot (transform.js: the selection's centroid by default);
// drags are sent as totals relative to their start.

import * as THREE from 'three';
import { TransformControls } from 'three/examples/jsm/controls/TransformControls.js';

export class Gizmo {
  constructor(editor) {
    this.ed = editor;
    const vp = editor.vp;
    this.pivot = new THREE.Object3D();
    vp.scene.add(this.pivot);
    this.tc = new TransformControls(vp.camera, vp.renderer.domElement);
    this.tc.setSpace('world');
    this.tc.setSize(0.85);
    this.helper = this.tc.getHelper();
    vp.scene.add(this.helper);
    this.mode = 'translate';
    this.axis = null; // 'X' | 'Y' | 'Z' | null
    this.session = null;
    this.startPos = new THREE.Vector3();
    this.tc.addEventListener('change', () => vp.requestRender());
    this.tc.addEventListener('dragging-changed', (e) => { vp.orbit.enabled = !e.value; });
    this.tc.addEventListener('mouseDown', () => this.begin());
    this.tc.addEventListener('objectChange', () => this.step());
    this.tc.addEventListener('mouseUp', () => this.finish());
  }

  /** Whether a pointer event lands on a gizmo handle. */
  hitTest(ev) {
    if (!this.tc.object || !this.helper.visible || !this.tc.enabled) return false;
    const n = this.ed.vp.ndc(ev);
    this.tc.pointerHover({ x: n.x, y: n.y, button: ev.button });
    return this.tc.axis !== null;
  }

  get dragging() { return this.tc.dragging || !!this.session; }

  /** Re-places the pivot at the selection's centroid (not during a drag). */
  update() {
    if (this.session) return;
    const ed = this.ed;
    const ids = ed.selection;
    const show = ids.length > 0 && ed.tool === 'controls' && ed.controlsView.group.visible;
    if (!show) {
      if (this.tc.object) this.tc.detach();
      this.helper.visible = false;
      ed.vp.requestRender();
      return;
    }
    // at the transform pivot (panel: median, active element, 3D cursor)
    this.pivot.position.copy(ed.transform ? ed.transform.pivotPoint(ids) : ed.controlsView.centroid(ids));
    this.pivot.quaternion.identity();
    this.pivot.scale.set(1, 1, 1);
    this.pivot.updateMatrixWorld();
    if (this.tc.object !== this.pivot) this.tc.attach(this.pivot);
    this.helper.visible = true;
    ed.vp.requestRender();
  }

  /** Moves the pivot along with a drag that does not use the gizmo. */
  followDelta(d) {
    if (!this.tc.object) return;
    this.pivot.position.copy(this.startPos).add(d);
    this.ed.vp.requestRender();
  }

  setMode(mode) {
    this.mode = mode;
    this.tc.setMode(mode);
    this.tc.setSpace(mode === 'scale' ? 'local' : 'world');
    this.ed.emit('tool');
    this.ed.vp.requestRender();
  }

  /** X/Y/Z: constrain to one axis; the same key again releases it. */
  toggleAxis(a) {
    this.axis = this.axis === a ? null : a;
    this.tc.showX = !this.axis || this.axis === 'X';
    this.tc.showY = !this.axis || this.axis === 'Y';
    this.tc.showZ = !this.axis || this.axis === 'Z';
    this.ed.emit('tool');
    this.ed.vp.requestRender();
  }

  begin() {
    this.startPos.copy(this.pivot.position);
    this.session = this.ed.beginControlDrag(this.tc.mode, this.pivot.position.toArray());
    if (!this.session) this.tc.dragging = false;
  }

  step() {
    if (!this.session) return;
    const mode = this.tc.mode;
    if (mode === 'translate') {
      const d = this.pivot.position.clone().sub(this.startPos);
      if (this.axis) for (const k of ['x', 'y', 'z']) if (k.toUpperCase() !== this.axis) d[k] = 0;
      this.session.update({ delta: d.toArray() });
    } else if (mode === 'rotate') {
      const q = this.pivot.quaternion.clone().normalize();
      if (q.w < 0) { q.x = -q.x; q.y = -q.y; q.z = -q.z; q.w = -q.w; }
      const angle = 2 * Math.acos(Math.min(1, q.w));
      const s = Math.sqrt(Math.max(0, 1 - q.w * q.w));
      const axis = s < 1e-9 ? [1, 0, 0] : [q.x / s, q.y / s, q.z / s];
      this.session.update({ axis, angle });
    } else {
      const s = this.pivot.scale;
      const sc = [s.x, s.y, s.z].map((v) => (Math.abs(v) < 1e-6 ? 1e-6 : v));
      this.session.update({ scale: sc });
    }
  }

  async finish() {
    const s = this.session;
    if (!s) return;
    await this.ed.endControlDrag(s);
  }

  /** Called by the editor when any control drag is over. */
  dragOver() {
    this.session = null;
    this.update();
  }
}
