// Scene, camera, lights, orbit controls and the deformed mesh.

import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
import { NormalsWorker, WORKER_MIN_TRIANGLES } from './normals.js';
import { COL } from './palette.js';

const FOV = 40;

export class Viewport {
  constructor(container) {
    this.container = container;
    this.renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
    this.renderer.setClearColor(0x1d1f23, 1);
    this.renderer.domElement.className = 'gl';
    container.appendChild(this.renderer.domElement);

    this.scene = new THREE.Scene();
    this.camera = new THREE.PerspectiveCamera(FOV, 1, 0.01, 1000);
    this.camera.position.set(3, 2, 5);
    // orthographic twin (key 5): the same view with parallel projection
    this.perspCamera = this.camera;
    this.orthoCamera = new THREE.OrthographicCamera(-1, 1, 1, -1, 0.01, 1000);
    this.ortho = false;
    this.frontSign = 1;     // -1: the model faces the other way (its front view is the conventional back)
    this.up = 'y';          // the mesh's up axis ('y' | 'z'): camera up, ground grid, view presets
    this.onCameraChange = []; // fn(camera) after the ortho / perspective switch

    const hemi = new THREE.HemisphereLight(0xf2f4ff, 0x3a3630, 1.6);
    this.scene.add(hemi);
    this.keyLight = new THREE.DirectionalLight(0xffffff, 1.9);
    this.keyLight.position.set(0.6, 1.0, 0.8);
    this.camera.add(this.keyLight); // the key light follows the camera
    this.scene.add(this.camera);
    this.scene.add(this.orthoCamera);

    this.grid = null;
    this.gridOn = true;
    this.extentMin = new THREE.Vector3(-1, -1, -1);
    this.extentMax = new THREE.Vector3(1, 1, 1);
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

    this.buildAxesTriad();
    this.dirty = true;
    this.onBeforeRender = [];
    (this.onAfterRender ||= []).push(() => this.renderAxesTriad());
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
    this.perspCamera.aspect = w / h;
    this.perspCamera.updateProjectionMatrix();
    this.updateOrthoFrustum();
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
    this.extentMin.copy(a);
    this.extentMax.copy(b);
    this.diag = Math.max(a.distanceTo(b), 1e-9);
    this.center.copy(a).add(b).multiplyScalar(0.5);
    this.camera.near = this.diag * 0.002;
    this.camera.far = this.diag * 200;
    this.camera.updateProjectionMatrix();
    this.buildGrid();
  }

  /** Points the camera at the mesh (key F; Home), keeping the view direction. */
  frameMesh(extra) {
    this.updateBounds();
    let box = null;
    if (this.geometry && this.geometry.boundingBox) {
      box = this.geometry.boundingBox.clone();
      if (extra && !extra.isEmpty()) box.union(extra);
    }
    this.frameBox(box);
  }

  /**
   * Frames a box (null: the mesh's extent) from direction dir (the unit vector
   * from the target to the camera; default: the current one), the whole box in view.
   */
  frameBox(box, dir = null) {
    let c = this.center.clone();
    let r = this.diag / 2;
    if (box && !box.isEmpty()) {
      const s = box.getBoundingSphere(new THREE.Sphere());
      c = s.center;
      r = Math.max(s.radius, 1e-3 * this.diag);
    }
    if (!dir) dir = this.camera.position.clone().sub(this.orbit.target);
    if (dir.lengthSq() < 1e-12) dir = this.presetDirection('front');
    dir = dir.clone().normalize();
    const dist = r / Math.sin(THREE.MathUtils.degToRad(FOV / 2)) * 1.05;
    this.orbit.target.copy(c);
    for (const cam of [this.perspCamera, this.orthoCamera]) {
      cam.position.copy(c).addScaledVector(dir, dist);
      cam.near = Math.max(dist * 0.001, 1e-6);
      cam.far = dist * 100;
      cam.zoom = 1;
    }
    this.orthoHalfHeight = r * 1.05;
    this.perspCamera.updateProjectionMatrix();
    this.updateOrthoFrustum();
    this.orbit.update();
    this.requestRender();
  }

  // --- camera: up axis, view presets, orthographic (web/src/view.js drives them) ---

  /** The up axis as a vector. */
  upVector() { return this.up === 'z' ? new THREE.Vector3(0, 0, 1) : new THREE.Vector3(0, 1, 0); }

  /** The front axis: from the model towards a viewer in front of it (Y-up: +Z; Z-up: -Y, as in Blender; frontSign -1 turns it). */
  frontVector() { return (this.up === 'z' ? new THREE.Vector3(0, -1, 0) : new THREE.Vector3(0, 0, 1)).multiplyScalar(this.frontSign); }

  /** Sets the up axis ('y' | 'z'): camera up, orbit, ground grid. */
  setUp(axis) {
    this.up = axis === 'z' ? 'z' : 'y';
    const up = this.upVector();
    for (const cam of [this.perspCamera, this.orthoCamera]) cam.up.copy(up);
    // OrbitControls turns about camera.up, captured at construction
    if (this.orbit._quat) {
      this.orbit._quat.setFromUnitVectors(up, new THREE.Vector3(0, 1, 0));
      this.orbit._quatInverse.copy(this.orbit._quat).invert();
    }
    this.buildGrid();
    this.orbit.update();
    this.requestRender();
  }

  /**
   * Unit vector from the target to the camera for a view preset: front, back,
   * right, left, top, bottom (Blender's numpad 1 / 3 / 7, Ctrl for the opposite).
   * Top and bottom lean by a hair towards the front so that the screen's up is
   * defined (top view: the front at the bottom of the screen, as in Blender).
   */
  presetDirection(name) {
    const up = this.upVector(), front = this.frontVector();
    const right = new THREE.Vector3().crossVectors(up, front); // Y-up: +X; Z-up: +X
    switch (name) {
      case 'front': return front;
      case 'back': return front.negate();
      case 'right': return right;
      case 'left': return right.negate();
      case 'top': return up.addScaledVector(front, 1e-4).normalize();
      case 'bottom': return up.negate().addScaledVector(front, 1e-4).normalize();
      default: throw new Error(`unknown view preset ${name}`);
    }
  }

  /** Turns the camera to a preset about the orbit target, keeping its distance. */
  viewFrom(name) {
    const dir = this.presetDirection(name);
    const dist = this.camera.position.distanceTo(this.orbit.target) || this.diag * 2;
    for (const cam of [this.perspCamera, this.orthoCamera]) cam.position.copy(this.orbit.target).addScaledVector(dir, dist);
    this.orbit.update();
    this.requestRender();
  }

  /**
   * Turns the view about the orbit target (numpad 4 / 6 / 8 / 2): yaw about the
   * up axis, pitch about the screen's horizontal axis, in radians (positive
   * yaw: the camera moves to the right around the model; positive pitch: up).
   */
  orbitBy(yaw, pitch) {
    const t = this.orbit.target;
    const off = this.camera.position.clone().sub(t);
    const up = this.upVector();
    off.applyAxisAngle(up, yaw);
    const right = new THREE.Vector3().crossVectors(up, off);
    if (right.lengthSq() < 1e-12) right.set(1, 0, 0).applyQuaternion(this.camera.quaternion);
    right.normalize();
    // stop short of the poles (OrbitControls clamps there too)
    const polar = off.angleTo(up);
    const p = Math.min(Math.max(-pitch, 1e-4 - polar), Math.PI - 1e-4 - polar);
    off.applyAxisAngle(right, p);
    for (const cam of [this.perspCamera, this.orthoCamera]) cam.position.copy(t).add(off);
    this.orbit.update();
    this.requestRender();
  }

  /** Orthographic (true) or perspective projection, keeping what is seen at the target's distance. */
  setOrtho(on) {
    on = !!on;
    if (on === this.ortho) return;
    const from = this.camera;
    const to = on ? this.orthoCamera : this.perspCamera;
    const dist = from.position.distanceTo(this.orbit.target);
    if (on) {
      // the perspective view's height at the target, seen in parallel
      this.orthoHalfHeight = dist * Math.tan(THREE.MathUtils.degToRad(FOV / 2));
      to.zoom = 1;
    } else if (from.zoom !== 1) {
      // the ortho zoom becomes a dolly
      const d = dist / from.zoom;
      to.position.copy(this.orbit.target).addScaledVector(from.position.clone().sub(this.orbit.target).normalize(), d);
      from.zoom = 1;
    }
    if (on) to.position.copy(from.position);
    to.quaternion.copy(from.quaternion);
    to.up.copy(from.up);
    // near / far: each camera keeps its own (frameBox sets both; the ortho's near is -far)
    this.ortho = on;
    this.camera = to;
    to.add(this.keyLight);
    this.updateOrthoFrustum();
    this.perspCamera.updateProjectionMatrix();
    this.orbit.object = to;
    this.orbit.update();
    for (const fn of this.onCameraChange) fn(to);
    this.requestRender();
  }

  updateOrthoFrustum() {
    const cam = this.orthoCamera;
    const hh = this.orthoHalfHeight || this.diag / 2;
    const aspect = this.perspCamera.aspect || 1;
    cam.top = hh; cam.bottom = -hh;
    cam.left = -hh * aspect; cam.right = hh * aspect;
    // a parallel view may look at parts behind the camera's spot
    cam.near = -cam.far;
    cam.updateProjectionMatrix();
  }

  /** The ground grid: on the plane through the mesh's lowest point, normal to the up axis. */
  buildGrid() {
    if (this.grid) { this.scene.remove(this.grid); this.grid.geometry.dispose(); this.grid.material.dispose(); }
    const span = 2.5 * this.diag;
    const step = 10 ** Math.floor(Math.log10(span / 10));     // a round cell size
    const cells = Math.max(2, Math.min(60, Math.ceil(span / step / 2) * 2));
    const g = new THREE.GridHelper(cells * step, cells, COL.gridMajor, COL.gridMinor);
    g.material.transparent = true;
    g.material.opacity = 0.75;
    g.material.depthWrite = false;
    const c = this.center;
    if (this.up === 'z') {
      g.rotation.x = Math.PI / 2;
      g.position.set(snap(c.x, step), snap(c.y, step), this.extentMin.z);
    } else g.position.set(snap(c.x, step), this.extentMin.y, snap(c.z, step));
    g.renderOrder = -1;
    g.visible = this.gridOn;
    g.userData.step = step;
    this.grid = g;
    this.scene.add(g);
    this.requestRender();
  }

  setGrid(on) { this.gridOn = !!on; if (this.grid) this.grid.visible = this.gridOn; this.requestRender(); }

  /** The axes indicator: a small XYZ triad in the bottom-left corner turning with the view. */
  buildAxesTriad() {
    const s = new THREE.Scene();
    const cols = [COL.axisX, COL.axisY, COL.axisZ];
    for (let a = 0; a < 3; a++) {
      const d = new THREE.Vector3().setComponent(a, 1);
      const pos = new THREE.Float32BufferAttribute([0, 0, 0, ...d.clone().multiplyScalar(0.78).toArray()], 3);
      const line = new THREE.Line(new THREE.BufferGeometry().setAttribute('position', pos),
        new THREE.LineBasicMaterial({ color: cols[a], depthTest: false }));
      const neg = new THREE.Line(new THREE.BufferGeometry().setAttribute('position',
        new THREE.Float32BufferAttribute([0, 0, 0, ...d.clone().multiplyScalar(-0.5).toArray()], 3)),
      new THREE.LineBasicMaterial({ color: cols[a], transparent: true, opacity: 0.3, depthTest: false }));
      const label = new THREE.Sprite(new THREE.SpriteMaterial({ map: letterTexture('XYZ'[a], cols[a]), depthTest: false }));
      label.position.copy(d);
      label.scale.setScalar(0.42);
      s.add(line, neg, label);
    }
    this.axesScene = s;
    this.axesCamera = new THREE.OrthographicCamera(-1.25, 1.25, 1.25, -1.25, 0.1, 10);
    this.axesSize = 84; // CSS pixels
  }

  renderAxesTriad() {
    if (!this.axesScene) return;
    const r = this.renderer;
    const cam = this.axesCamera;
    cam.quaternion.copy(this.camera.quaternion);
    cam.position.set(0, 0, 4).applyQuaternion(cam.quaternion);
    const size = this.axesSize;
    const prev = r.autoClear;
    r.autoClear = false;
    r.setViewport(6, 30, size, size);
    r.setScissor(6, 30, size, size);
    r.setScissorTest(true);
    r.clearDepth();
    r.render(this.axesScene, cam);
    r.setScissorTest(false);
    const w = Math.max(1, this.container.clientWidth), h = Math.max(1, this.container.clientHeight);
    r.setViewport(0, 0, w, h);
    r.autoClear = prev;
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

const snap = (x, step) => Math.round(x / step) * step;

function letterTexture(ch, color) {
  const c = document.createElement('canvas');
  c.width = c.height = 64;
  const g = c.getContext('2d');
  g.font = 'bold 44px sans-serif';
  g.textAlign = 'center';
  g.textBaseline = 'middle';
  g.fillStyle = `#${new THREE.Color(color).getHexString()}`;
  g.fillText(ch, 32, 34);
  const t = new THREE.CanvasTexture(c);
  t.colorSpace = THREE.SRGBColorSpace;
  return t;
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
