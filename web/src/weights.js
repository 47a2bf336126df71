// The Weights tool (V): vertex-group weights painted on the mesh with a
// brush, as in Blender's weight paint mode, shown as a colour map (blue 0 →
// red 1). The weights scale the deformer's effect per vertex (x' = x + w
// (f(x) - x), docs/constraints.md) and live in the rig's "weights" layer, so
// `ffd deform --rig` replays what is on screen.
//
// A stroke: press on the mesh and drag. Each dab changes the vertices under
// the brush (a smooth falloff to its radius): Add raises them toward 1,
// Subtract lowers them toward 0, Smooth pulls them toward their neighbours'
// mean; Ctrl inverts Add/Subtract and Shift smooths for the stroke. The wheel
// resizes the brush, Shift+wheel changes its strength. The changed weights go
// to the server as sparse "weights" ops with the stroke's id (one request in
// flight, the rest merged into the next), so the mesh follows live and the
// whole stroke is one undo step.

import * as THREE from 'three';
import { api } from './api.js';
import { ramp } from './viewport.js';

const BRUSH_KEY = 'ffd-editor.brush';

export const MODES = [
  { name: 'add', label: 'Add', title: 'Raise the weights under the brush toward 1 (Ctrl while painting: subtract)' },
  { name: 'subtract', label: 'Subtract', title: 'Lower the weights under the brush toward 0 (Ctrl while painting: add)' },
  { name: 'smooth', label: 'Smooth', title: 'Even out the weights under the brush with their neighbours (Shift while painting)' },
];

export class WeightPaint {
  constructor(editor) {
    this.ed = editor;
    this.weights = null;     // Float32Array, one per vertex (null: not fetched)
    this.mode = 'add';
    this.radiusShare = 0.1;  // the brush's radius as a share of the mesh's diagonal
    this.strength = 0.5;
    this.showMap = false;    // the colour map outside the tool
    this.stroke = null;      // {id, mode, last: Vector3}
    this.strokeId = 0;
    this.pending = new Map(); // vertex -> weight, not yet sent
    this.sending = null;     // the request in flight
    this.neighbours = null;  // CSR adjacency {start, list} for Smooth
    this.topoOf = null;
    this.cursor = document.createElement('div');
    this.cursor.className = 'brush-cursor';
    this.cursor.hidden = true;
    editor.container.appendChild(this.cursor);
    this.loadBrush();
    this.bind();
    editor.on('state', () => this.onState());
    editor.on('tool', () => this.onTool());
    editor.keyHandlers.push((ev) => this.key(ev));
  }

  get active() { return this.ed.tool === 'weights'; }

  // the brush (mode, strength, radius as a share of the model's size) is remembered across loads
  loadBrush() {
    try {
      const b = JSON.parse(localStorage.getItem(BRUSH_KEY)) || {};
      if (MODES.some((m) => m.name === b.mode)) this.mode = b.mode;
      if (b.strength > 0 && b.strength <= 1) this.strength = b.strength;
      if (b.radiusShare > 0 && b.radiusShare <= 1) this.radiusShare = b.radiusShare;
    } catch { /* nothing remembered */ }
  }

  saveBrush() {
    try { localStorage.setItem(BRUSH_KEY, JSON.stringify({ mode: this.mode, strength: this.strength, radiusShare: this.radiusShare })); } catch { /* private mode */ }
  }
  brushRadius() { return this.radiusShare * (this.ed.vp.diag || 1); }

  // --- the tool ------------------------------------------------------------------

  toggle() { this.ed.setTool(this.active ? 'controls' : 'weights'); }

  onTool() {
    this.cursor.hidden = true;
    this.paintMap(); // at once with the weights known, then the server's
    if (this.active) this.fetch();
  }

  async onState() {
    // undo/redo, a loaded rig or a new deformer may change the weights: fetch
    // them again (not during a stroke: the page's copy leads then)
    if ((this.active || this.showMap) && !this.stroke && !this.sending && !this.ed.activeDrag) await this.fetch();
  }

  async fetch() {
    try {
      const w = await api.weights();
      if (this.stroke || this.sending) return;
      this.weights = new Float32Array(w);
      this.paintMap();
      this.ed.panel.update();
    } catch (e) { this.ed.error(e); }
  }

  /** After the dabs of one pointer event: recolour what they changed, send it. */
  strokeStep() {
    if (this.dirty && this.dirty.size) this.paintMap(this.dirty);
    this.dirty = new Set();
    this.flush();
  }

  /**
   * Colours the mesh by the weights (absolute: 0 blue, 1 red), or gives it
   * back to the influence map. only: the vertices to recolour (a Set; all when absent).
   */
  paintMap(only = null) {
    const vp = this.ed.vp;
    if (!vp.geometry) return;
    if (!(this.active || this.showMap) || !this.weights || this.weights.length !== vp.geometry.attributes.position.count) {
      if (this.colored) { this.colored = false; this.ed.setInfluence(this.ed.opts.influence); }
      return;
    }
    const col = vp.geometry.attributes.color;
    const c = col.array;
    const paint = (i) => { const [r, g, b] = ramp(this.weights[i]); c[3 * i] = r; c[3 * i + 1] = g; c[3 * i + 2] = b; };
    if (only && this.colored) only.forEach(paint);
    else for (let i = 0; i < this.weights.length; i++) paint(i);
    col.needsUpdate = true;
    vp.material.vertexColors = true;
    vp.material.color.set(0xffffff);
    vp.material.needsUpdate = true;
    this.colored = true;
    vp.requestRender();
  }

  setShowMap(on) { this.showMap = on; if (on && !this.weights) this.fetch(); else this.paintMap(); this.ed.panel.update(); }
  setMode(m) { this.mode = m; this.saveBrush(); this.ed.panel.update(); }
  /** r: world units (kept as a share of the model's size, so that it suits the next mesh too). */
  setRadius(r) { if (r > 0 && Number.isFinite(r)) this.radiusShare = Math.min(1, r / (this.ed.vp.diag || 1)); this.saveBrush(); this.syncBrushUi(); }
  setStrength(s) { if (Number.isFinite(s)) this.strength = Math.min(1, Math.max(0, s)); this.saveBrush(); this.syncBrushUi(); }

  /** The panel's sliders follow the wheel in place (a re-render would end a slider drag). */
  syncBrushUi() {
    const diag = this.ed.vp.diag || 1;
    const set = (name, v) => {
      const el = document.querySelector(`#panel input[name=${name}]`);
      if (!el) return;
      if (document.activeElement !== el) el.value = v;
      const label = el.nextElementSibling;
      if (label) label.textContent = `${v}%`;
    };
    set('weights-radius', Math.round((100 * this.brushRadius()) / diag));
    set('weights-strength', Math.round(100 * this.strength));
  }

  // --- input -------------------------------------------------------------------------

  bind() {
    const el = this.ed.container;
    // capture on the view, registered before the editor's own: in the
    // Weights tool a press on the mesh paints instead of orbiting
    el.addEventListener('pointerdown', (ev) => {
      if (!this.active || ev.button !== 0 || ev.target !== this.ed.vp.renderer.domElement) return;
      const hit = this.ed.vp.pickMesh(ev);
      if (!hit) return; // empty space: orbit as usual
      ev.stopImmediatePropagation();
      ev.preventDefault();
      if (!this.ed.state || !this.ed.state.method) { this.ed.error(new Error('Create a deformer first: the weights scale its effect')); return; }
      if (!this.weights) return;
      el.setPointerCapture?.(ev.pointerId);
      const mode = ev.shiftKey ? 'smooth' : ev.ctrlKey || ev.metaKey ? (this.mode === 'subtract' ? 'add' : 'subtract') : this.mode;
      this.stroke = { id: ++this.strokeId, mode, last: hit.point.clone() };
      this.dab(hit.point, mode);
      this.strokeStep();
    }, true);
    el.addEventListener('pointermove', (ev) => {
      if (!this.active) return;
      // (during a stroke the view holds the pointer capture: events target it, not the canvas)
      const onCanvas = ev.target === this.ed.vp.renderer.domElement || (this.stroke && ev.target === el);
      const hit = onCanvas ? this.ed.vp.pickMesh(ev) : null;
      this.showCursor(ev, hit);
      if (!this.stroke || !hit) return;
      ev.stopImmediatePropagation();
      // dabs spaced a quarter radius apart along the pointer's path
      const r = this.brushRadius();
      const d = hit.point.distanceTo(this.stroke.last);
      const steps = Math.min(16, Math.floor(d / (0.25 * r)));
      for (let i = 1; i <= steps; i++) this.dab(this.stroke.last.clone().lerp(hit.point, i / steps), this.stroke.mode);
      if (steps) { this.stroke.last.copy(hit.point); this.strokeStep(); }
    }, true);
    const end = () => {
      if (!this.stroke) return;
      this.stroke.done = true;
      this.flush();
    };
    window.addEventListener('pointerup', end, true);
    window.addEventListener('pointercancel', end, true);
    el.addEventListener('pointerleave', () => { this.cursor.hidden = true; });
    el.addEventListener('wheel', (ev) => {
      if (!this.active) return;
      ev.stopImmediatePropagation();
      ev.preventDefault();
      const f = ev.deltaY > 0 ? 1 / 1.1 : 1.1;
      if (ev.shiftKey) this.setStrength(Math.round(100 * Math.min(1, Math.max(0.01, this.strength * f))) / 100);
      else this.setRadius(this.brushRadius() * f);
      this.showCursor(ev, this.ed.vp.pickMesh(ev));
    }, { capture: true, passive: false });
  }

  key(ev) {
    if (ev.ctrlKey || ev.metaKey || ev.altKey) return false;
    if (ev.key === 'v' || ev.key === 'V') { this.toggle(); return true; }
    return false;
  }

  showCursor(ev, hit) {
    if (!hit) { this.cursor.hidden = true; return; }
    const vp = this.ed.vp;
    const c = vp.toScreen(hit.point);
    const right = new THREE.Vector3().setFromMatrixColumn(vp.camera.matrixWorld, 0).multiplyScalar(this.brushRadius());
    const e = vp.toScreen(hit.point.clone().add(right));
    const px = Math.max(4, Math.hypot(e.x - c.x, e.y - c.y));
    const box = this.ed.container.getBoundingClientRect();
    const s = this.cursor.style;
    s.width = s.height = `${2 * px}px`;
    s.left = `${c.rect.left - box.left + c.x - px}px`;
    s.top = `${c.rect.top - box.top + c.y - px}px`;
    this.cursor.dataset.mode = this.stroke ? this.stroke.mode : (ev.shiftKey ? 'smooth' : ev.ctrlKey ? 'subtract' : this.mode);
    this.cursor.hidden = false;
  }

  // --- painting ----------------------------------------------------------------------

  /** One dab of the brush at world point p: a smooth falloff (1 - (d/r)^2)^2. */
  dab(p, mode) {
    const vp = this.ed.vp;
    const pos = vp.geometry.attributes.position.array;
    const w = this.weights;
    const r = this.brushRadius(), r2 = r * r;
    const s = this.strength;
    const changed = [];
    for (let i = 0; i < w.length; i++) {
      const dx = pos[3 * i] - p.x, dy = pos[3 * i + 1] - p.y, dz = pos[3 * i + 2] - p.z;
      const d2 = dx * dx + dy * dy + dz * dz;
      if (d2 < r2) changed.push(i, (1 - d2 / r2) ** 2);
    }
    if (mode === 'smooth') this.buildNeighbours();
    const next = [];
    for (let k = 0; k < changed.length; k += 2) {
      const i = changed[k], f = s * changed[k + 1];
      let v = w[i];
      if (mode === 'add') v += f * (1 - v);
      else if (mode === 'subtract') v -= f * v;
      else {
        const { start, list } = this.neighbours;
        let sum = 0, n = 0;
        for (let j = start[i]; j < start[i + 1]; j++) { sum += w[list[j]]; n++; }
        if (n) v += f * (sum / n - v);
      }
      // snap to the ends so that a few dabs reach exactly 0 or 1
      if (v > 0.999) v = 1; else if (v < 0.001) v = 0;
      next.push(i, Math.round(v * 1e6) / 1e6);
    }
    if (!this.dirty) this.dirty = new Set();
    for (let k = 0; k < next.length; k += 2) {
      if (w[next[k]] === next[k + 1]) continue;
      w[next[k]] = next[k + 1];
      this.pending.set(next[k], next[k + 1]);
      this.dirty.add(next[k]);
    }
  }

  /** Sends the pending weights (one request in flight; the stroke's id merges them into one undo step). */
  async flush() {
    if (this.sending) return;
    if (!this.pending.size) {
      if (this.stroke && this.stroke.done) { this.stroke = null; await this.fetch(); }
      return;
    }
    const vertices = Object.fromEntries(this.pending);
    this.pending.clear();
    const id = this.stroke ? this.stroke.id : ++this.strokeId;
    this.sending = this.ed.run('weights', { vertices, stroke: id });
    const st = await this.sending;
    this.sending = null;
    if (!st) { this.pending.clear(); this.stroke = null; await this.fetch(); return; } // refused: the server's weights
    this.flush();
  }

  buildNeighbours() {
    const tris = this.ed.vp.triangles;
    if (this.neighbours && this.topoOf === tris) return;
    const n = this.weights.length;
    const sets = Array.from({ length: n }, () => new Set());
    for (let t = 0; t < tris.length; t += 3) {
      const a = tris[t], b = tris[t + 1], c = tris[t + 2];
      sets[a].add(b); sets[a].add(c); sets[b].add(a); sets[b].add(c); sets[c].add(a); sets[c].add(b);
    }
    const start = new Uint32Array(n + 1);
    for (let i = 0; i < n; i++) start[i + 1] = start[i] + sets[i].size;
    const list = new Uint32Array(start[n]);
    for (let i = 0; i < n; i++) list.set([...sets[i]], start[i]);
    this.neighbours = { start, list };
    this.topoOf = tris;
  }

  // --- whole-mesh actions ---------------------------------------------------------------

  /** A text file of one weight per vertex (blank and # lines skipped), as `ffd deform` reads them. */
  async load(file) {
    const text = await file.text();
    const values = [];
    const lines = text.split(/\r?\n/);
    for (let i = 0; i < lines.length; i++) {
      const t = lines[i].trim();
      if (!t || t.startsWith('#')) continue;
      const v = Number(t);
      if (!Number.isFinite(v)) { this.ed.error(new Error(`${file.name}:${i + 1}: expected one weight (a number) per line, found '${t.slice(0, 20)}'`)); return; }
      values.push(v);
    }
    const n = this.ed.state && this.ed.state.mesh ? this.ed.state.mesh.vertices : 0;
    if (values.length !== n) { this.ed.error(new Error(`${file.name}: ${values.length} weights for ${n} vertices`)); return; }
    if (await this.ed.run('weights', { values })) { this.ed.info(`Weights loaded from ${file.name}`); await this.fetch(); }
  }

  /** A weights file under the server's root (POST /api/weights/load), named by its path. */
  async loadFromServer(path) {
    try {
      const st = await api.post('/api/weights/load', { path }, 'Loading weights…');
      await this.ed.applyState(st);
      this.ed.info(`Weights loaded from ${path}`);
      await this.fetch();
    } catch (e) { this.ed.error(e); }
  }

  async clear() {
    if (await this.ed.run('weights', { clear: true })) { this.ed.info('Weights cleared (every vertex 1) — Ctrl+Z brings them back'); await this.fetch(); }
  }

  /** Summary for the panel: how many vertices are below 1 and the range. */
  summary() {
    const w = this.weights;
    if (!w) return null;
    let below = 0, min = 1, max = 0;
    for (let i = 0; i < w.length; i++) { if (w[i] < 1) below++; if (w[i] < min) min = w[i]; if (w[i] > max) max = w[i]; }
    return { below, min, max, n: w.length };
  }
}
