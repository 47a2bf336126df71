// Drawing of the deformer's control structure, per method.

import * as THREE from 'three';

const COL = {
  point: new THREE.Color(0xff8a1f),
  selected: new THREE.Color(0xffe14d),
  frozen: new THREE.Color(0x62c8ff),
  disabled: new THREE.Color(0x7a7a7a),
  curve: new THREE.Color(0xff5fa2),
  skeleton: new THREE.Color(0x48d17a),
  edge: 0x9aa0a8,
  proxy: 0x4f8dff,
  skeletonEdge: 0x3fcf74,
};
// EBF ellipsoids by hierarchy level
const LEVEL_COLORS = [0x58a6ff, 0xb07cff, 0x3fd0b6, 0xffb347, 0xff6b8b, 0xc8e06a];
export const levelColor = (k) => LEVEL_COLORS[((k % LEVEL_COLORS.length) + LEVEL_COLORS.length) % LEVEL_COLORS.length];

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
    this.ellipsoids = null;
    this.key = '';
  }

  /** A key that changes when the drawing must be rebuilt. */
  static structureKey(state) {
    const c = state.controls || {};
    return JSON.stringify([
      state.method, c.count, (c.edges || []).length, c.level,
      (c.ebfs || []).length, (c.curves || []).length, (c.primitives || []).map((p) => [p.offset, p.count]),
      c.proxy ? [c.proxy.faces.length, c.proxy.points.length] : null, c.refinements, c.cells,
    ]);
  }

  clear() {
    for (const o of [...this.group.children]) {
      this.group.remove(o);
      o.traverse((x) => { if (x.geometry) x.geometry.dispose(); if (x.material && x.material !== this.pointMat) x.material.dispose(); });
    }
    this.ellipsoids = null;
    this.skelSpheres = null;
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

    const edges = c.edges || [];
    const edgeColor = this.method === 'gffd' ? COL.skeletonEdge : COL.edge;

    if (this.method === 'tspline') {
      // proxy faces: translucent blue, proxy edges from the face polygons
      const faces = (c.proxy && c.proxy.faces) || [];
      const tri = [];
      const pe = [];
      for (const f of faces) {
        for (let i = 1; i + 1 < f.length; i++) tri.push(f[0], f[i], f[i + 1]);
        for (let i = 0; i < f.length; i++) pe.push(f[i], f[(i + 1) % f.length]);
      }
      const fg = new THREE.BufferGeometry();
      fg.setAttribute('position', this.positions);
      fg.setIndex(tri);
      this.proxyMesh = new THREE.Mesh(fg, new THREE.MeshBasicMaterial({
        color: COL.proxy, transparent: true, opacity: 0.16, side: THREE.DoubleSide, depthWrite: false,
      }));
      this.proxyMesh.frustumCulled = false;
      this.proxyMesh.renderOrder = 5;
      this.group.add(this.proxyMesh);
      const eg = new THREE.BufferGeometry();
      eg.setAttribute('position', this.positions);
      eg.setIndex(pe);
      this.proxyEdges = new THREE.LineSegments(eg, new THREE.LineBasicMaterial({
        color: 0x7fb0ff, transparent: true, opacity: 0.85, depthTest: false,
      }));
      this.proxyEdges.frustumCulled = false;
      this.proxyEdges.renderOrder = 11;
      this.group.add(this.proxyEdges);
    }

    if (edges.length) {
      const idx = new (C < 65536 ? Uint16Array : Uint32Array)(edges.length * 2);
      edges.forEach((e, i) => { idx[2 * i] = e[0]; idx[2 * i + 1] = e[1]; });
      const g = new THREE.BufferGeometry();
      g.setAttribute('position', this.positions);
      g.setIndex(new THREE.BufferAttribute(idx, 1));
      this.edges = new THREE.LineSegments(g, new THREE.LineBasicMaterial({
        color: edgeColor, transparent: true, opacity: this.method === 'gffd' ? 0.95 : 0.45, depthTest: false,
      }));
      this.edges.frustumCulled = false;
      this.edges.renderOrder = 11;
      this.group.add(this.edges);
    } else this.edges = null;

    if (this.method === 'pbffd') this.buildEllipsoids(c);
    if (this.method === 'gffd') this.buildSkeletonSpheres(c);

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

  buildEllipsoids(c) {
    const ebfs = c.ebfs || [];
    if (!ebfs.length) return;
    const sg = new THREE.SphereGeometry(1, 16, 10);
    const mat = new THREE.MeshBasicMaterial({
      wireframe: true, transparent: true, opacity: ebfs.length > 40 ? 0.07 : 0.11, depthWrite: false, color: 0xffffff,
    });
    const im = new THREE.InstancedMesh(sg, mat, ebfs.length);
    im.frustumCulled = false;
    im.renderOrder = 6;
    const col = new THREE.Color(levelColor(c.level || 0));
    ebfs.forEach((e, i) => im.setColorAt(i, e.enabled === false ? COL.disabled : col));
    this.ellipsoids = im;
    this.group.add(im);
  }

  buildSkeletonSpheres(c) {
    const prims = c.primitives || [];
    const n = prims.reduce((s, p) => s + (p.count || 0), 0);
    if (!n) return;
    const sg = new THREE.SphereGeometry(1, 12, 8);
    const mat = new THREE.MeshBasicMaterial({
      wireframe: true, transparent: true, opacity: 0.05, depthWrite: false, color: COL.skeletonEdge,
    });
    const im = new THREE.InstancedMesh(sg, mat, n);
    im.frustumCulled = false;
    this.skelSpheres = im;
    this.group.add(im);
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
    if (this.method === 'tspline' && !this.showLattice && c.proxy && c.proxy.points) {
      for (const id of c.proxy.points) if (id < C) mask[id] = 1;
    } else mask.fill(1);
    this.visibleMask = mask;
    this.visibleIds = [];
    for (let i = 0; i < C; i++) if (mask[i]) this.visibleIds.push(i);
    if (this.points) {
      const all = this.visibleIds.length === C;
      this.pointGeom.setIndex(all ? null : this.visibleIds);
    }
    if (this.edges) this.edges.visible = this.method !== 'tspline' || this.showLattice;
    if (this.proxyMesh) { this.proxyMesh.visible = !this.showLattice; this.proxyEdges.visible = !this.showLattice; }
    if (this.ellipsoids) this.ellipsoids.visible = this.showRois;
    if (this.skelSpheres) this.skelSpheres.visible = this.showRois;
    this.vp.requestRender();
  }

  updateColors(selection) {
    if (!this.count) return;
    const c = (this.state && this.state.controls) || {};
    const frozen = new Set(c.frozen || []);
    const col = this.colors.array;
    const nEbf = (c.ebfs || []).length;
    for (let i = 0; i < this.count; i++) {
      let k = COL.point;
      if (this.method === 'gffd') k = COL.skeleton;
      if (this.method === 'pbffd') {
        if (i >= nEbf) k = COL.curve;
        else if (c.ebfs[i] && c.ebfs[i].enabled === false) k = COL.disabled;
      }
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
    const m = new THREE.Matrix4();
    const p = this.positions ? this.positions.array : null;
    if (this.ellipsoids && p) {
      const ebfs = c.ebfs || [];
      const a = new THREE.Vector3(), b = new THREE.Vector3(), d = new THREE.Vector3();
      ebfs.forEach((e, i) => {
        if (i >= this.ellipsoids.count) return;
        const r = e.radius || [1, 1, 1];
        const f = e.frame || [[1, 0, 0], [0, 1, 0], [0, 0, 1]];
        a.fromArray(f[0]).multiplyScalar(r[0]);
        b.fromArray(f[1]).multiplyScalar(r[1]);
        d.fromArray(f[2]).multiplyScalar(r[2]);
        m.makeBasis(a, b, d).setPosition(p[3 * i], p[3 * i + 1], p[3 * i + 2]);
        this.ellipsoids.setMatrixAt(i, m);
      });
      this.ellipsoids.instanceMatrix.needsUpdate = true;
    }
    if (this.skelSpheres && p) {
      let k = 0;
      for (const pr of c.primitives || []) {
        for (let j = 0; j < pr.count; j++) {
          const id = pr.offset + j;
          const r = pr.radius || 0;
          m.makeScale(r, r, r).setPosition(p[3 * id], p[3 * id + 1], p[3 * id + 2]);
          if (k < this.skelSpheres.count) this.skelSpheres.setMatrixAt(k++, m);
        }
      }
      this.skelSpheres.instanceMatrix.needsUpdate = true;
    }
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
