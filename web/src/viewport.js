// Scene, camera, lights, orbit controls and the deformed mesh.

import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
import { NormalsWorker, WORKER_MIN_TRIANGLES } from './normals.js';

export class Viewport {
  constructor(container) {
    this.container = container;
    this.renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
    this.renderer.setClearColor(0x1d1f23, 1);
    this.renderer.domElement.className = 'gl';
    container.appendChild(this.renderer.domElement);

    this.scene = new THREE.Scene();
    this.camera = new THREE.PerspectiveCamera(40, 1, 0.01, 1000);
    this.camera.position.set(3, 2, 5);

    const hemi = new THREE.HemisphereLight(0xf2f4ff, 0x3a3630, 1.6);
    this.scene.add(hemi);
    this.keyLight = new THREE.DirectionalLight(0xffffff, 1.9);
    this.keyLight.position.set(0.6, 1.0, 0.8);
    this.camera.add(this.keyLight); // the key light follows the camera
    this.scene.add(this.camera);

    this.grid = null;
    this.overlays = new THREE.Group(); // controls, pins, gizmo helper etc.
    this.scene.add(this.overlays);

    this.mesh = null;
    this.wire = null;
    this.geometry = null;
    this.rest = null;
    this.triangles = null;
    this.boundsDirty = true;
    this.diag = 1;
    this.center = new THREE.Vector3();

    this.material = new THREE.MeshStandardMaterial({
      color: 0xd9d5cc, roughness: 0.82, metalness: 0.0, side: THREE.DoubleSide,
      polygonOffset: true, polygonOffsetFactor: 1, polygonOffsetUnits: 1,
    });
    this.wireMaterial = new THREE.MeshBasicMaterial({
      color: 0x15171a, wireframe: true, transparent: true, opacity: 0.28, depthWrite: false,
    });
    this.influenceOn = false;
    this.workerMinTriangles = WORKER_MIN_TRIANGLES; // meshes this big get their full normals from a worker

    this.orbit = new OrbitControls(this.camera, this.renderer.domElement);
    this.orbit.enableDamping = false;
    this.orbit.screenSpacePanning = true;
    this.orbit.addEventListener('change', () => this.requestRender());

    this.dirty = true;
    this.onBeforeRender = [];
    const ro = new ResizeObserver(() => this.resize());
    ro.observe(container);
    this.resize();
    const loop = () => {
      requestAnimationFrame(loop);
      if (!this.dirty || this.renderDisabled) return;
      this.dirty = false;
      for (const fn of this.onBeforeRender) fn();
      this.renderer.render(this.scene, this.camera);
      for (const fn of this.onAfterRender || []) fn();
    };
    requestAnimationFrame(loop);
  }

  requestRender() { this.dirty = true; }

  resize() {
    const w = Math.max(1, this.container.clientWidth);
    const h = Math.max(1, this.container.clientHeight);
    this.renderer.setSize(w, h, false);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    this.requestRender();
  }

  /** Builds the mesh from a topology reply. */
  setTopology(topo) {
    if (this.mesh) {
      this.scene.remove(this.mesh);
      this.scene.remove(this.wire);
      this.geometry.dispose();
    }
    const V = topo.V;
    const g = new THREE.BufferGeometry();
    const pos = new THREE.BufferAttribute(new Float32Array(topo.rest), 3);
    pos.setUsage(THREE.DynamicDrawUsage);
    const nrm = new THREE.BufferAttribute(new Float32Array(3 * V), 3);
    nrm.setUsage(THREE.DynamicDrawUsage);
    const col = new THREE.BufferAttribute(new Float32Array(3 * V).fill(1), 3);
    g.setAttribute('position', pos);
    g.setAttribute('normal', nrm);
    g.setAttribute('color', col);
    // three picks Uint16/Uint32 by the array type
    const index = V < 65536 ? new Uint16Array(topo.triangles) : new Uint32Array(topo.triangles);
    g.setIndex(new THREE.BufferAttribute(index, 1));
    this.geometry = g;
    this.rest = new Float32Array(topo.rest);
    this.triangles = new Uint32Array(topo.triangles);
    if (this.normalsWorker) this.normalsWorker.terminate();
    this.normalsWorker = topo.T >= this.workerMinTriangles && typeof Worker !== 'undefined' ? new NormalsWorker(this.triangles) : null;
    this.updateNormals();
    this.mesh = new THREE.Mesh(g, this.material);
    this.mesh.frustumCulled = false;
    this.wire = new THREE.Mesh(g, this.wireMaterial);
    this.wire.frustumCulled = false;
    this.wire.visible = !!this.wireOn;
    this.wire.raycast = () => {};
    this.scene.add(this.mesh);
    this.scene.add(this.wire);
    this.boundsDirty = true;
    this.updateBounds();
    this.requestRender();
  }

  get vertexCount() { return this.geometry ? this.geometry.attributes.position.count : 0; }

  /** Copies deformed positions in place (a full frame) and recomputes every normal. */
  setPositions(positions) {
    if (!this.geometry) return;
    const t0 = performance.now();
    const attr = this.geometry.attributes.position;
    if (positions.length !== attr.array.length) return;
    attr.array.set(positions);
    attr.clearUpdateRanges(); // the whole buffer goes to the GPU
    attr.needsUpdate = true;
    this.updateNormals();
    this.boundsDirty = true;
    this.requestRender();
    this.measureFrame(t0, 'full');
  }

  /**
   * Every normal from the current positions: on the main thread for a small
   * mesh; for a big one in the worker (normals.js), written when it answers,
   * except at the vertices whose normals a delta frame set meanwhile (those
   * are newer, and every normal a delta's positions affect comes with it).
   */
  updateNormals() {
    if (!this.normalsWorker) { this.computeNormals(); return; }
    const g = this.geometry, V = this.vertexCount;
    this.normalsTouched = null; // vertices given normals by deltas since the request
    this.normalsWorker.request(g.attributes.position.array, (normals) => {
      if (g !== this.geometry) return;
      const t0 = performance.now();
      const nAttr = g.attributes.normal, n = nAttr.array, touched = this.normalsTouched;
      if (!touched) n.set(normals);
      else for (let v = 0; v < V; v++) if (!touched[v]) { n[3 * v] = normals[3 * v]; n[3 * v + 1] = normals[3 * v + 1]; n[3 * v + 2] = normals[3 * v + 2]; }
      nAttr.clearUpdateRanges();
      nAttr.needsUpdate = true;
      this.requestRender();
      this.measureFrame(t0, 'normals');
    });
  }

  /**
   * Applies a delta frame (api.js parseDeltaFrame) made against the frame of
   * revision `held`: the changed positions and the normals the server
   * computed around them are written in place and only their ranges of the
   * buffers go to the GPU. Returns false, changing nothing, when the delta
   * was made against another frame or another mesh.
   */
  applyDelta(frame, held) {
    if (!this.geometry || frame.base !== held || frame.V !== this.vertexCount) return false;
    const t0 = performance.now();
    const pos = this.geometry.attributes.position, nrm = this.geometry.attributes.normal;
    scatter(pos, frame.indices, frame.positions);
    scatter(nrm, frame.normalIndices, frame.normals);
    if (this.normalsWorker && this.normalsWorker.pending) {
      // the worker's normals are older than these
      const t = this.normalsTouched || (this.normalsTouched = new Uint8Array(this.vertexCount));
      for (const v of frame.normalIndices) t[v] = 1;
    }
    if (frame.K) this.boundsDirty = true;
    if (frame.K || frame.M) this.requestRender();
    this.measureFrame(t0, 'delta');
    return true;
  }

  /** Frame-apply timing for bench/editor_drag.mjs: a performance measure per frame when timing is on. */
  measureFrame(t0, kind) {
    if (this.timing) performance.measure(`ffd:frame-apply:${kind}`, { start: t0, end: performance.now() });
  }

  /** Area-weighted vertex normals straight on the typed arrays (fast on 100K+ vertices). */
  computeNormals() {
    const p = this.geometry.attributes.position.array;
    const nAttr = this.geometry.attributes.normal;
    const n = nAttr.array;
    const t = this.triangles;
    n.fill(0);
    for (let i = 0, T = t.length; i < T; i += 3) {
      const a = 3 * t[i], b = 3 * t[i + 1], c = 3 * t[i + 2];
      const ax = p[a], ay = p[a + 1], az = p[a + 2];
      const e1x = p[b] - ax, e1y = p[b + 1] - ay, e1z = p[b + 2] - az;
      const e2x = p[c] - ax, e2y = p[c + 1] - ay, e2z = p[c + 2] - az;
      const nx = e1y * e2z - e1z * e2y, ny = e1z * e2x - e1x * e2z, nz = e1x * e2y - e1y * e2x;
      n[a] += nx; n[a + 1] += ny; n[a + 2] += nz;
      n[b] += nx; n[b + 1] += ny; n[b + 2] += nz;
      n[c] += nx; n[c + 1] += ny; n[c + 2] += nz;
    }
    for (let i = 0, N = n.length; i < N; i += 3) {
      const l = Math.hypot(n[i], n[i + 1], n[i + 2]);
      if (l > 0) { n[i] /= l; n[i + 1] /= l; n[i + 2] /= l; } else { n[i + 1] = 1; }
    }
    nAttr.clearUpdateRanges();
    nAttr.needsUpdate = true;
  }

  updateBounds() {
    if (!this.geometry || !this.boundsDirty) return;
    this.geometry.computeBoundingBox();
    this.geometry.computeBoundingSphere();
    this.boundsDirty = false;
  }

  /** Diagonal of the rest mesh's bounding box (set from the state). */
  setExtent(min, max) {
    const a = new THREE.Vector3(...min), b = new THREE.Vector3(...max);
    this.diag = Math.max(a.distanceTo(b), 1e-9);
    this.center.copy(a).add(b).multiplyScalar(0.5);
    this.camera.near = this.diag * 0.002;
    this.camera.far = this.diag * 200;
    this.camera.updateProjectionMatrix();
  }

  /** Points the camera at the mesh (key F). */
  frameMesh(extra) {
    this.updateBounds();
    let c = this.center.clone();
    let r = this.diag / 2;
    if (this.geometry && this.geometry.boundingBox) {
      const box = this.geometry.boundingBox.clone();
      if (extra && !extra.isEmpty()) box.union(extra);
      const s = box.getBoundingSphere(new THREE.Sphere());
      c = s.center;
      r = s.radius;
    }
    const dir = this.camera.position.clone().sub(this.orbit.target);
    if (dir.lengthSq() < 1e-12) dir.set(0.5, 0.35, 1);
    dir.normalize();
    const dist = r / Math.sin(THREE.MathUtils.degToRad(this.camera.fov / 2)) * 1.05;
    this.orbit.target.copy(c);
    this.camera.position.copy(c).addScaledVector(dir, dist);
    this.camera.near = Math.max(dist * 0.001, 1e-6);
    this.camera.far = dist * 100;
    this.camera.updateProjectionMatrix();
    this.orbit.update();
    this.requestRender();
  }

  setWireframe(on) {
    this.wireOn = on;
    if (this.wire) this.wire.visible = on;
    this.requestRender();
  }

  /** Weights in [0,1] per vertex, or null to turn the colour map off. */
  setInfluence(weights) {
    if (!this.geometry) return;
    if (!weights) {
      this.material.vertexColors = false;
      this.material.color.set(0xd9d5cc);
      this.material.needsUpdate = true;
      this.requestRender();
      return;
    }
    const col = this.geometry.attributes.color;
    const c = col.array;
    const V = Math.min(weights.length, col.count);
    // weights are in [0, 1]; a handle's weights are often far below 1, so the
    // ramp spans [0, max] (the panel's legend shows max)
    let max = 0;
    for (let i = 0; i < V; i++) if (weights[i] > max) max = weights[i];
    this.influenceMax = max;
    const scale = max > 0 ? 1 / max : 1;
    for (let i = 0; i < V; i++) {
      const [r, g, b] = ramp(weights[i] * scale);
      c[3 * i] = r; c[3 * i + 1] = g; c[3 * i + 2] = b;
    }
    col.needsUpdate = true;
    this.material.vertexColors = true;
    this.material.color.set(0xffffff);
    this.material.needsUpdate = true;
    this.requestRender();
  }

  /** CSS-pixel position of a world point relative to the canvas, and its depth. */
  toScreen(v) {
    const p = v.clone().project(this.camera);
    const rect = this.renderer.domElement.getBoundingClientRect();
    return { x: (p.x + 1) / 2 * rect.width, y: (1 - p.y) / 2 * rect.height, z: p.z, rect };
  }

  /** NDC from a pointer event. */
  ndc(ev) {
    const rect = this.renderer.domElement.getBoundingClientRect();
    return new THREE.Vector2(((ev.clientX - rect.left) / rect.width) * 2 - 1, -((ev.clientY - rect.top) / rect.height) * 2 + 1);
  }

  /** Raycast the mesh; returns {point, face, vertex (nearest corner), normal} or null. */
  pickMesh(ev) {
    if (!this.mesh) return null;
    this.updateBounds();
    const ray = new THREE.Raycaster();
    ray.setFromCamera(this.ndc(ev), this.camera);
    const hits = ray.intersectObject(this.mesh, false);
    if (!hits.length) return null;
    const h = hits[0];
    const p = this.geometry.attributes.position.array;
    const corners = [h.face.a, h.face.b, h.face.c];
    let best = corners[0], bd = Infinity;
    for (const v of corners) {
      const d = (p[3 * v] - h.point.x) ** 2 + (p[3 * v + 1] - h.point.y) ** 2 + (p[3 * v + 2] - h.point.z) ** 2;
      if (d < bd) { bd = d; best = v; }
    }
    // rest-space position of the hit (barycentric on the rest triangle)
    const tri = new THREE.Triangle(this.vertex(h.face.a), this.vertex(h.face.b), this.vertex(h.face.c));
    const bary = tri.getBarycoord(h.point, new THREE.Vector3());
    const restPoint = new THREE.Vector3();
    if (bary) {
      for (const [k, w] of [[h.face.a, bary.x], [h.face.b, bary.y], [h.face.c, bary.z]]) {
        restPoint.x += w * this.rest[3 * k]; restPoint.y += w * this.rest[3 * k + 1]; restPoint.z += w * this.rest[3 * k + 2];
      }
    } else {
      restPoint.set(this.rest[3 * best], this.rest[3 * best + 1], this.rest[3 * best + 2]);
    }
    const normal = h.face.normal.clone();
    return { point: h.point.clone(), vertex: best, face: h.face, normal, restPoint };
  }

  vertex(v, target = new THREE.Vector3()) {
    const p = this.geometry.attributes.position.array;
    return target.set(p[3 * v], p[3 * v + 1], p[3 * v + 2]);
  }
}

/**
 * Writes values (3 per id) at the vertices ids (ascending) of a
 * BufferAttribute and marks only the written ranges for upload: runs of ids
 * closer than RUN_GAP vertices share a range; past MAX_RANGES ranges (also
 * those of frames not yet drawn) one range spans them all.
 */
const RUN_GAP = 64, MAX_RANGES = 48;
function scatter(attr, ids, values) {
  const a = attr.array;
  const k = ids.length;
  if (!k) return;
  for (let i = 0; i < k; i++) {
    const o = 3 * ids[i], j = 3 * i;
    a[o] = values[j]; a[o + 1] = values[j + 1]; a[o + 2] = values[j + 2];
  }
  const ranges = attr.updateRanges;
  let lo = ids[0], hi = ids[0];
  for (let i = 1; i <= k; i++) {
    const v = i < k ? ids[i] : Infinity;
    if (v - hi <= RUN_GAP) { hi = v; continue; }
    ranges.push({ start: 3 * lo, count: 3 * (hi - lo + 1) });
    lo = hi = v;
  }
  if (ranges.length > MAX_RANGES) {
    let s = Infinity, e = 0;
    for (const r of ranges) { s = Math.min(s, r.start); e = Math.max(e, r.start + r.count); }
    attr.clearUpdateRanges();
    attr.addUpdateRange(s, e - s);
  }
  attr.needsUpdate = true;
}

/** Blue -> cyan -> green -> yellow -> red. */
export function ramp(w) {
  const t = Math.min(1, Math.max(0, w || 0));
  const stops = [
    [0.16, 0.22, 0.55], [0.10, 0.55, 0.85], [0.30, 0.78, 0.45], [0.98, 0.82, 0.20], [0.86, 0.18, 0.14],
  ];
  const s = t * (stops.length - 1);
  const i = Math.min(stops.length - 2, Math.floor(s));
  const f = s - i;
  const a = stops[i], b = stops[i + 1];
  return [a[0] + (b[0] - a[0]) * f, a[1] + (b[1] - a[1]) * f, a[2] + (b[2] - a[2]) * f];
}
