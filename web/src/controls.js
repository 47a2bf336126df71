// Drawing of the deformer's control structure: points, edges, and what the
// method's module adds (methods/*.js "view": ellipsoids, spheres, a proxy).

import * as THREE from 'three';
import { COL } from './palette.js';
import { methodOf } from './methods/index.js';

/** Handle sprites: a white shape with a dark outline, tinted by the point colour. */
function spriteTexture(shape) {
  const s = 64;
  const c = document.createElement('canvas');
  c.width = c.height = s;
  const g = c.getContext('2d');
  g.beginPath();
  if (shape === 'square') g.rect(9, 9, s - 18, s - 18);
  else if (shape === 'diamond') { g.moveTo(s / 2, 4); g.lineTo(s - 4, s / 2); g.lineTo(s / 2, s - 4); g.lineTo(4, s / 2); g.closePath(); } else g.arc(s / 2, s / 2, s / 2 - 5, 0, Math.PI * 2);
  if (shape === 'ring') {
    g.lineWidth = 7;
    g.strokeStyle = '#ffffff';
    g.stroke();
  } else {
    g.fillStyle = '#ffffff';
    g.fill();
    g.lineWidth = 5;
    g.strokeStyle = 'rgba(20,20,20,0.9)';
    g.stroke();
  }
  const t = new THREE.CanvasTexture(c);
  t.colorSpace = THREE.NoColorSpace;
  return t;
}

// Depth cue: handles and lattice lines in front of the mesh are drawn bright
// (depth-tested), the hidden ones faint (a second pass without the depth test);
// X-ray draws both at full strength.
const HIDDEN_POINT_OPACITY = 0.35;
const HIDDEN_EDGE_OPACITY = 0.12;
// A handle within this fraction of the mesh size behind the surface still
// counts as visible (points on the surface: PB-FFD curves, T-spline proxies),
// for the drawing (the depth-tested pass is pulled towards the camera by it)
// and for picking (occlusion()) alike.
export const DEPTH_TOLERANCE = 0.006;

/** Pulls a Points material's vertices towards the camera by bias.value (view units) along the view ray: same pixel, nearer depth. */
function withDepthBias(mat, bias) {
  mat.onBeforeCompile = (sh) => {
    sh.uniforms.depthBias = bias;
    sh.vertexShader = sh.vertexShader
      .replace('void main() {', 'uniform float depthBias;\nvoid main() {')
      .replace('#include <project_vertex>', `#include <project_vertex>
  if (isPerspectiveMatrix(projectionMatrix)) mvPosition.xyz -= depthBias * normalize(mvPosition.xyz); else mvPosition.z += depthBias;
  gl_Position = projectionMatrix * mvPosition;`);
  };
  mat.customProgramCacheKey = () => 'depth-bias';
  return mat;
}

export class ControlsView {
  constructor(viewport) {
    this.vp = viewport;
    this.group = new THREE.Group();
    this.group.renderOrder = 10;
    viewport.overlays.add(this.group);
    this.tex = { disc: spriteTexture('disc'), square: spriteTexture('square'), diamond: spriteTexture('diamond') };
    this.ringTex = spriteTexture('ring');
    this.xray = false;
    this.hover = -1;           // the handle under the pointer
    this.selection = new Set();
    this.allRois = false;      // PB-FFD: every ROI, not only the selected / hovered handles'
    this.occlusionCache = null;
    this.depthBias = { value: 0 };
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
    this.pointSets = [];
    this.hiddenPasses = [];
    this.hoverMarker = null;
    this.hover = -1;
    this.occlusionCache = null;
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
    this.depthBias.value = DEPTH_TOLERANCE * this.vp.diag;
    const edges = c.edges || [];
    const edgeColor = view.edgeColor ?? COL.edge;

    if (edges.length) {
      const idx = new (C < 65536 ? Uint16Array : Uint32Array)(edges.length * 2);
      edges.forEach((e, i) => { idx[2 * i] = e[0]; idx[2 * i + 1] = e[1]; });
      const g = new THREE.BufferGeometry();
      g.setAttribute('position', this.positions);
      g.setIndex(new THREE.BufferAttribute(idx, 1));
      this.edges = this.addLines(g, edgeColor, view.edgeOpacity ?? 0.55, 11);
    } else this.edges = null;

    if (view.build) view.build(this, c);

    // one Points per handle shape (methods/*.js view.pointShape), each in two
    // passes: hidden (faint, no depth test) under visible (depth-tested)
    for (const shape of ['disc', 'square', 'diamond']) {
      const pg = new THREE.BufferGeometry();
      pg.setAttribute('position', this.positions);
      pg.setAttribute('color', this.colors);
      const mat = (hidden) => new THREE.PointsMaterial({
        size: 11, sizeAttenuation: false, map: this.tex[shape], vertexColors: true,
        // (alphaTest compares the alpha after opacity: the faint pass needs a lower one)
        transparent: true, alphaTest: hidden ? 0.1 : 0.4, depthTest: !hidden, depthWrite: false, opacity: hidden ? HIDDEN_POINT_OPACITY : 1,
      });
      const pts = new THREE.Points(pg, withDepthBias(mat(false), this.depthBias));
      pts.frustumCulled = false;
      pts.renderOrder = 20;
      const hid = new THREE.Points(pg, mat(true));
      hid.frustumCulled = false;
      hid.renderOrder = 19;
      hid.userData.fullOpacity = 1;
      hid.userData.hiddenOpacity = HIDDEN_POINT_OPACITY;
      this.hiddenPasses.push(hid);
      this.pointSets.push({ shape, geom: pg, points: pts, hidden: hid });
      this.group.add(hid, pts);
    }
    this.points = this.pointSets[0].points;
    this.pointGeom = this.pointSets[0].geom;
    const hg = new THREE.BufferGeometry();
    hg.setAttribute('position', new THREE.BufferAttribute(new Float32Array(3), 3));
    this.hoverMarker = new THREE.Points(hg, new THREE.PointsMaterial({
      size: 21, sizeAttenuation: false, map: this.ringTex, color: COL.hover, transparent: true, alphaTest: 0.3, depthTest: false, depthWrite: false,
    }));
    this.hoverMarker.frustumCulled = false;
    this.hoverMarker.renderOrder = 21;
    this.hoverMarker.visible = false;
    this.group.add(this.hoverMarker);
    this.setXray(this.xray);
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
    if (this.pointSets && this.pointSets.length) {
      const shapeOf = view.pointShape;
      for (const ps of this.pointSets) {
        const ids = shapeOf ? this.visibleIds.filter((i) => (shapeOf(i, c) || 'disc') === ps.shape) : (ps.shape === 'disc' ? this.visibleIds : []);
        ps.geom.setIndex(ids.length === C && ps.shape === 'disc' ? null : ids);
        ps.points.visible = ps.hidden.visible = ids.length > 0;
      }
    }
    if (this.hover >= 0 && !mask[this.hover]) this.setHover(-1);
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
    if (selection) this.selection = selection;
    const sel = this.selection;
    // the active point: the last one picked (a Set keeps insertion order)
    let active = -1;
    for (const id of sel) active = id;
    for (let i = 0; i < this.count; i++) {
      let k = (pointColor && pointColor(i, c)) || COL.point;
      if (frozen.has(i)) k = COL.frozen;
      if (sel.has(i)) k = i === active ? COL.active : COL.selected;
      col[3 * i] = k.r; col[3 * i + 1] = k.g; col[3 * i + 2] = k.b;
    }
    this.colors.needsUpdate = true;
    this.updateInstances();
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

  /**
   * Lines over the controls' positions with the depth cue: the part in front
   * of the mesh at `opacity`, the hidden part faint (full with X-ray). Adds
   * both to the group; returns the visible pass (its hidden twin: .userData.hidden).
   */
  addLines(geometry, color, opacity, renderOrder = 11) {
    const vis = new THREE.LineSegments(geometry, new THREE.LineBasicMaterial({ color, transparent: true, opacity, depthTest: true, depthWrite: false }));
    const hid = new THREE.LineSegments(geometry, new THREE.LineBasicMaterial({
      color, transparent: true, opacity: this.xray ? opacity : HIDDEN_EDGE_OPACITY, depthTest: false, depthWrite: false,
    }));
    vis.frustumCulled = hid.frustumCulled = false;
    vis.renderOrder = renderOrder;
    hid.renderOrder = renderOrder - 1;
    hid.userData.fullOpacity = opacity;
    hid.userData.hiddenOpacity = HIDDEN_EDGE_OPACITY;
    vis.userData.hidden = hid;
    // the hidden twin follows the visible pass's visibility (methods toggle that one)
    Object.defineProperty(hid, 'visible', { get: () => vis.visible, set: () => {}, configurable: true });
    this.hiddenPasses.push(hid);
    this.group.add(hid, vis);
    return vis;
  }

  /** X-ray: hidden handles and lines at full strength (and selectable: select.js). */
  setXray(on) {
    this.xray = !!on;
    for (const o of this.hiddenPasses || []) {
      o.material.opacity = this.xray ? o.userData.fullOpacity : o.userData.hiddenOpacity;
    }
    this.vp.requestRender();
  }

  /** The handle under the pointer (-1: none): a white ring, and its ROI shown. */
  setHover(id) {
    if (!(id >= 0 && id < this.count)) id = -1;
    if (id === this.hover) return;
    this.hover = id;
    if (this.hoverMarker) {
      this.hoverMarker.visible = id >= 0;
      if (id >= 0) {
        const a = this.hoverMarker.geometry.attributes.position;
        this.position(id, new THREE.Vector3()).toArray(a.array);
        a.needsUpdate = true;
      }
    }
    this.updateInstances();
    this.vp.requestRender();
  }

  /** The handles whose ROI / radius is drawn: all, or the selection and the hovered handle. */
  roiIds(n) {
    if (this.allRois) return Array.from({ length: n }, (_, i) => i);
    const ids = [...this.selection].filter((i) => i < n);
    if (this.hover >= 0 && this.hover < n && !this.selection.has(this.hover)) ids.push(this.hover);
    return ids;
  }

  setAllRois(on) { this.allRois = !!on; this.updateInstances(); this.vp.requestRender(); }

  /**
   * Which handles are hidden behind the mesh from the current camera:
   * Uint8Array(count), 1 = occluded. The mesh's view depth is rendered once
   * into an offscreen target (a 24-bit linear depth in RGB) and read back, and
   * each handle's depth is compared with the mesh's at its pixel. Cached until
   * the camera, the mesh or the handles move.
   */
  occlusion() {
    const vp = this.vp;
    const C = this.count;
    if (!C || !vp.mesh) return new Uint8Array(C);
    const cam = vp.camera;
    cam.updateMatrixWorld();
    const key = [...cam.matrixWorld.elements, ...cam.projectionMatrix.elements, C,
      vp.geometry.attributes.position.version, this.positions.version, vp.geometry.id].join(',');
    if (this.occlusionCache && this.occlusionCache.key === key) return this.occlusionCache.mask;
    const rect = vp.renderer.domElement.getBoundingClientRect();
    const w = Math.max(1, Math.round(rect.width)), h = Math.max(1, Math.round(rect.height));
    const far = cam.far;
    const depth = readMeshDepth(vp, w, h, far);
    const mask = new Uint8Array(C);
    const v = new THREE.Vector3(), e = new THREE.Vector3();
    const tol = DEPTH_TOLERANCE * vp.diag;
    for (let i = 0; i < C; i++) {
      this.position(i, v);
      e.copy(v).applyMatrix4(cam.matrixWorldInverse);
      // the same pull towards the camera as the drawing's (withDepthBias)
      if (cam.isPerspectiveCamera) e.addScaledVector(e.clone().normalize(), -tol); else e.z += tol;
      v.project(cam);
      if (v.z < -1 || v.z > 1) continue;
      const x = Math.floor((v.x + 1) / 2 * w), y = Math.floor((v.y + 1) / 2 * h); // GL rows: bottom up
      if (x < 0 || y < 0 || x >= w || y >= h) continue;
      const d = depth(y * w + x);
      if (d >= 0 && d < -e.z) mask[i] = 1;
    }
    this.occlusionCache = { key, mask };
    return mask;
  }
}

/** depthAt(pixel index, GL rows bottom up): view-space distance (0 .. far) of the mesh there, -1 where there is none. */
function readMeshDepth(vp, w, h, far) {
  const r = vp.renderer;
  if (!vp.depthTarget || vp.depthTarget.width !== w || vp.depthTarget.height !== h) {
    if (vp.depthTarget) vp.depthTarget.dispose();
    vp.depthTarget = new THREE.WebGLRenderTarget(w, h, { depthBuffer: true });
  }
  if (!vp.depthMaterial) {
    vp.depthMaterial = new THREE.ShaderMaterial({
      uniforms: { far: { value: 1 } },
      side: THREE.DoubleSide,
      vertexShader: 'varying float vz; void main() { vec4 mv = modelViewMatrix * vec4(position, 1.0); vz = -mv.z; gl_Position = projectionMatrix * mv; }',
      fragmentShader: `uniform float far; varying float vz;
        void main() {
          float d = clamp(vz / far, 0.0, 1.0);
          vec3 enc = fract(d * vec3(1.0, 255.0, 65025.0));
          enc -= enc.yzz * vec3(1.0 / 255.0, 1.0 / 255.0, 0.0);
          gl_FragColor = vec4(enc, 1.0);
        }`,
    });
  }
  vp.depthMaterial.uniforms.far.value = far;
  const mesh = vp.mesh;
  const mat = mesh.material;
  const prevTarget = r.getRenderTarget();
  const prevColor = r.getClearColor(new THREE.Color());
  const prevAlpha = r.getClearAlpha();
  mesh.material = vp.depthMaterial;
  r.setRenderTarget(vp.depthTarget);
  r.setClearColor(0x000000, 0);
  r.clear(true, true, true);
  r.render(mesh, vp.camera);
  const buf = new Uint8Array(4 * w * h);
  r.readRenderTargetPixels(vp.depthTarget, 0, 0, w, h, buf);
  r.setRenderTarget(prevTarget);
  r.setClearColor(prevColor, prevAlpha);
  mesh.material = mat;
  // decoded on demand: only the handles' pixels are read
  return (i) => {
    const o = 4 * i;
    return buf[o + 3] < 128 ? -1 : (buf[o] / 255 + buf[o + 1] / 65025 + buf[o + 2] / 16581375) * far;
  };
}
