// Drawing of the deformer's control structure: points, edges, and what the
// method's module adds (methods/*.js "view": ellipsoids, spheres, a proxy).

import * as THREE from 'three';
import { COL } from './palette.js';
import { methodOf } from './methods/index.js';

function discTexture() {
  const s = 64;
  const c = document.createElement('canvas');
  c.width = c.height = s;
  const g = c.getContext('2d');
  g.beginPath();
  g.arc(s / 2, s / 2, s / 2 - 5, 0, Math.PI * 2);
  g.fillStyle = '#ffffff';
  g.fill();
  g.lineWidth = 5;
  g.strokeStyle = 'rgba(20,20,20,0.9)';
  g.stroke();
  const t = new THREE.CanvasTexture(c);
  t.colorSpace = THREE.NoColorSpace;
  return t;
}

export class ControlsView {
  constructor(viewport) {
    this.vp = viewport;
    this.group = new THREE.Group();
    this.group.renderOrder = 10;
    viewport.overlays.add(this.group);
    this.tex = discTexture();
    this.count = 0;
    this.method = null;
    this.positions = null; // BufferAttribute, C*3
    this.colors = null;
    this.visibleIds = [];
    this.visibleMask = new Uint8Array(0);
    this.showLattice = false; // T-spline: the full T-lattice instead of the proxy
    this.showRois = true;
    this.state = null;
    this.rois = null; // the method's ROI / radius drawing, shown with "ROIs / radii"
    this.proxy = null;
    this.key = '';
  }

  get view() { return methodOf(this.method).view; }

  /** A key that changes when the drawing must be rebuilt. */
  static structureKey(state) {
    const c = state.controls || {};
    const view = methodOf(state.method).view;
    return JSON.stringify([state.method, c.count, (c.edges || []).length, view.structureKey ? view.structureKey(c) : null]);
  }

  clear() {
    for (const o of [...this.group.children]) {
      this.group.remove(o);
      o.traverse((x) => { if (x.geometry) x.geometry.dispose(); if (x.material && x.material !== this.pointMat) x.material.dispose(); });
    }
    this.rois = null;
    this.proxy = null;
  }

  rebuild(state) {
    this.clear();
    this.state = state;
    this.method = state.method;
    const c = state.controls || { count: 0, edges: [] };
    const C = this.method ? c.count : 0;
    this.count = C;
    this.positions = new THREE.BufferAttribute(new Float32Array(3 * Math.max(C, 1)), 3);
    this.positions.setUsage(THREE.DynamicDrawUsage);
    this.colors = new THREE.BufferAttribute(new Float32Array(3 * Math.max(C, 1)), 3);
    this.key = ControlsView.structureKey(state);
    if (!C) { this.visibleIds = []; this.visibleMask = new Uint8Array(0); this.vp.requestRender(); return; }

    const view = this.view;
    const edges = c.edges || [];
    const edgeColor = view.edgeColor ?? COL.edge;

    if (edges.length) {
      const idx = new (C < 65536 ? Uint16Array : Uint32Array)(edges.length * 2);
      edges.forEach((e, i) => { idx[2 * i] = e[0]; idx[2 * i + 1] = e[1]; });
      const g = new THREE.BufferGeometry();
      g.setAttribute('position', this.positions);
      g.setIndex(new THREE.BufferAttribute(idx, 1));
      this.edges = new THREE.LineSegments(g, new THREE.LineBasicMaterial({
        color: edgeColor, transparent: true, opacity: view.edgeOpacity ?? 0.45, depthTest: false,
      }));
      this.edges.frustumCulled = false;
      this.edges.renderOrder = 11;
      this.group.add(this.edges);
    } else this.edges = null;

    if (view.build) view.build(this, c);

    const pg = new THREE.BufferGeometry();
    pg.setAttribute('position', this.positions);
    pg.setAttribute('color', this.colors);
    this.pointGeom = pg;
    this.points = new THREE.Points(pg, new THREE.PointsMaterial({
      size: 11, sizeAttenuation: false, map: this.tex, vertexColors: true,
      transparent: true, alphaTest: 0.4, depthTest: false,
    }));
    this.points.frustumCulled = false;
    this.points.renderOrder = 20;
    this.group.add(this.points);
    this.updateVisibility();
    this.vp.requestRender();
  }

  /** Per-state attributes that do not need a rebuild (frozen, EBF shapes, selection). */
  refresh(state, selection) {
    this.state = state;
    this.updateColors(selection);
    this.updateInstances();
  }

  isVisible(id) { return id >= 0 && id < this.count && this.visibleMask[id] === 1; }

  updateVisibility() {
    const C = this.count;
    const c = (this.state && this.state.controls) || {};
    const mask = new Uint8Array(C);
    const view = this.view;
    if (!(view.visible && view.visible(this, c, mask))) mask.fill(1);
    this.visibleMask = mask;
    this.visibleIds = [];
    for (let i = 0; i < C; i++) if (mask[i]) this.visibleIds.push(i);
    if (this.points) {
      const all = this.visibleIds.length === C;
      this.pointGeom.setIndex(all ? null : this.visibleIds);
    }
    if (this.edges) this.edges.visible = true;
    if (this.rois) this.rois.visible = this.showRois;
    if (view.updateVisibility) view.updateVisibility(this);
    this.vp.requestRender();
  }

  updateColors(selection) {
    if (!this.count) return;
    const c = (this.state && this.state.controls) || {};
    const frozen = new Set(c.frozen || []);
    const col = this.colors.array;
    const pointColor = this.view.pointColor;
    for (let i = 0; i < this.count; i++) {
      let k = (pointColor && pointColor(i, c)) || COL.point;
      if (frozen.has(i)) k = COL.frozen;
      if (selection && selection.has(i)) k = COL.selected;
      col[3 * i] = k.r; col[3 * i + 1] = k.g; col[3 * i + 2] = k.b;
    }
    this.colors.needsUpdate = true;
    this.vp.requestRender();
  }

  setPositions(arr) {
    if (!this.count || !arr || arr.length !== 3 * this.count) return;
    this.positions.array.set(arr);
    this.positions.needsUpdate = true;
    this.updateInstances();
    this.vp.requestRender();
  }

  updateInstances() {
    const c = (this.state && this.state.controls) || {};
    if (this.positions && this.view.updateInstances) this.view.updateInstances(this, c, this.positions.array);
  }

  position(id, target = new THREE.Vector3()) {
    const p = this.positions.array;
    return target.set(p[3 * id], p[3 * id + 1], p[3 * id + 2]);
  }

  centroid(ids) {
    const c = new THREE.Vector3();
    const v = new THREE.Vector3();
    for (const id of ids) c.add(this.position(id, v));
    return ids.length ? c.multiplyScalar(1 / ids.length) : c;
  }

  setVisible(on) { this.group.visible = on; this.vp.requestRender(); }
}
