// ffdkit editor page: boot, state handling, pointer and keyboard dispatch.

import * as THREE from 'three';
import { api, ApiError, onActivity, oldestPendingMs, pendingCount, pendingLabel, stats } from './api.js';
import { Viewport } from './viewport.js';
import { ControlsView } from './controls.js';
import { Selector } from './select.js';
import { Gizmo } from './gizmo.js';
import { DirectManip } from './dm.js';
import { TransformTool } from './transform.js';
import { MeshList } from './meshes.js';
import { DragSession } from './drag.js';
import { ViewNav } from './view.js';
import { Panel, fmtInt, h } from './panel.js';
import { History } from './history.js';
import { methodOf, PICK_TOOLS, BUSY } from './methods/index.js';
import { Toasts, OfflineBanner } from './toasts.js';
import { WeightPaint } from './weights.js';
import { firstRunCard } from './panel.js';
import { busyProgress, progressDone } from './progress.js';

const $ = (id) => document.getElementById(id);

class Editor {
  constructor() {
    this.container = $('view');
    this.vp = new Viewport(this.container);
    this.state = null;
    this.selection = [];
    this.tool = 'controls';
    this.opts = { wireframe: false, controls: true, rois: true, influence: false, arap: true };
    this.sketch = []; // points clicked on the mesh by a sketching pick tool (methods/*.js tools)
    this.meshKey = '';
    this.lastFrameRevision = -1;
    this.opSeq = 0; // ops sent, and the newest whose reply was applied (run)
    this.appliedOpSeq = 0;
    this.frameSeq = 0;
    this.listeners = {};
    this.hover = null;       // last pointer event over the canvas
    this.dragTimes = [];     // timestamps of drag frames (updates / s)
    this.activeDrag = null;
    this.ready = false;
    // modules with keys of their own (modal transforms, view presets, ...) see
    // each key first: fn(ev) returns true when it handled the key
    this.keyHandlers = [];

    this.controlsView = new ControlsView(this.vp);
    this.gizmo = new Gizmo(this); // before OrbitControls' listeners matter: see pointerDown
    this.selector = new Selector(this);
    this.dm = new DirectManip(this);
    this.transform = new TransformTool(this); // modal G/R/S, pivot, mirror, snapping, proportional
    this.toasts = new Toasts($('toasts'));
    this.offline = new OfflineBanner($('offline'), async () => { this.meshKey = ''; await this.refresh(); this.panel.loadFiles(); this.info('Reconnected to the server'); });
    this.weights = new WeightPaint(this);
    this.meshList = new MeshList(this); // several meshes in one session
    this.history = new History(this); // the History section, Undo/Redo counts, autosave notes
    this.panel = new Panel(this, $('panel'));
    this.viewNav = new ViewNav(this); // up axis, view presets, ortho, grid, X-ray, rows / layers (view.js)
    firstRunCard(this);
    this.sketchGroup = new THREE.Group();
    this.vp.overlays.add(this.sketchGroup);

    this.bindPointer();
    this.bindKeys();
    this.bindToolbar();
    this.bindStatus();
    this.on('tool', () => this.syncToolbar());
  }

  on(name, fn) { (this.listeners[name] ||= []).push(fn); }
  emit(name, ...a) { for (const fn of this.listeners[name] || []) fn(...a); }

  // --- state -------------------------------------------------------------------

  async boot() {
    try {
      const state = await api.state();
      await this.applyState(state, { forceFrame: true });
      this.frame();
    } catch (e) {
      this.error(e);
    }
  }

  /** Applies a state reply: topology if the mesh changed, control drawing, then the frame. */
  async applyState(state, { frame = true, forceFrame = false } = {}) {
    if (!state || typeof state !== 'object') return;
    const prev = this.state;
    this.state = state;
    const m = state.mesh || {};
    const meshKey = JSON.stringify([m.name, m.vertices, m.faces]);
    let meshChanged = false;
    if (meshKey !== this.meshKey) {
      this.meshKey = meshKey;
      meshChanged = true;
      if (m.min && m.max) this.vp.setExtent(m.min, m.max);
      const topo = await api.topology();
      this.vp.setTopology(topo);
      this.lastFrameRevision = -1; // the geometry holds the rest positions, no frame
      if (prev) this.frame();
      this.influenceWeights = null;
    }
    const key = ControlsView.structureKey(state);
    const structureChanged = key !== this.controlsView.key || meshChanged;
    if (structureChanged) {
      const c = state.controls || {};
      if (!prev || prev.method !== state.method || meshChanged) this.selection = [];
      else this.selection = this.selection.filter((id) => id < (c.count || 0));
      this.controlsView.rebuild(state);
    }
    this.controlsView.refresh(state, new Set(this.selection));
    this.dm.setPins(state.pins);
    const needFrame = forceFrame || meshChanged || structureChanged || state.revision !== this.lastFrameRevision;
    if (frame && needFrame) await this.refreshFrame();
    if (structureChanged && (!prev || prev.method !== state.method)) this.frame();
    if (structureChanged && this.opts.influence) this.updateInfluence();
    this.gizmo.update();
    this.panel.update();
    this.updateStatus();
    this.emit('state', state);
  }

  /** Frames the mesh and the control structure (key F). */
  frame() {
    const cv = this.controlsView;
    const box = new THREE.Box3();
    if (cv.count && cv.group.visible) {
      const v = new THREE.Vector3();
      for (const id of cv.visibleIds) box.expandByPoint(cv.position(id, v));
      const size = box.getSize(v).length();
      if (!(size < 4 * this.vp.diag)) box.makeEmpty();
    }
    this.vp.frameMesh(box);
  }

  async refreshFrame() {
    const seq = ++this.frameSeq;
    const frame = await api.frame(this.lastFrameRevision);
    if (seq !== this.frameSeq) return; // a newer frame request superseded this one
    this.applyFrame(frame);
  }

  applyFrame(frame) {
    // a delta frame applies to the frame it was made against only; else the whole frame is fetched
    if (frame.delta && !this.vp.applyDelta(frame, this.lastFrameRevision)) { this.refreshFrame(); return; }
    if (!frame.delta) this.vp.setPositions(frame.positions);
    if (frame.C === this.controlsView.count) this.controlsView.setPositions(frame.controls);
    this.lastFrameRevision = frame.revision;
    this.dm.setFrameResiduals(frame.residuals);
    if (!this.ready) {
      this.ready = true;
      requestAnimationFrame(() => requestAnimationFrame(() => { document.body.dataset.ready = '1'; }));
    }
  }

  onDragFrame(frame, ms) {
    const t0 = performance.now();
    this.applyFrame(frame);
    this.lastApplyMs = performance.now() - t0;
    const now = performance.now();
    this.dragTimes.push(now);
    while (this.dragTimes.length && now - this.dragTimes[0] > 1000) this.dragTimes.shift();
    this.lastDragMs = ms;
    this.updateStatus();
  }

  /** Runs an op replying with a state; errors become a toast. Returns the state or null.
   * Ops may overlap (Ctrl+Z pressed twice quickly) and their replies arrive in any order:
   * a reply older than one already applied is not applied (it would put an older state
   * over the newer one, with the newer frame drawn). */
  async run(op, body = {}, { label } = {}) {
    if (this.activeDrag) return null;
    const seq = ++this.opSeq;
    try {
      const state = await api.op(op, body);
      if (label) void label;
      if (seq < this.appliedOpSeq) return state;
      this.appliedOpSeq = seq;
      await this.applyState(state);
      return state;
    } catch (e) {
      this.error(e);
      return null;
    }
  }

  /** A POST whose reply is not a state (save): true on success. */
  async post(path, body, label) {
    try { await api.post(path, body, label); return true; } catch (e) { this.error(e); return false; }
  }

  async refresh() {
    try { await this.applyState(await api.state(), { forceFrame: true }); } catch (e) { this.error(e); }
  }

  undo() { return this.run('undo'); }
  redo() { return this.run('redo'); }

  async openPath(path) {
    if (!this.history.confirmReplace(path)) return;
    this.setSelection([]);
    await this.run('open', { path });
  }

  async openUpload(file) {
    if (!this.history.confirmReplace(file.name)) return;
    try {
      this.setSelection([]);
      const state = await api.upload(file.name, await file.arrayBuffer());
      await this.applyState(typeof state === 'object' ? state : await api.state(), { forceFrame: true });
    } catch (e) { this.error(e); }
  }

  async loadRigPath(path) {
    try {
      this.setSelection([]);
      const st = await api.post('/api/rig/load', { path }, 'Loading rig…');
      await this.applyState(typeof st === 'object' && st.revision !== undefined ? st : await api.state(), { forceFrame: true });
    } catch (e) { this.error(e); }
  }

  async loadRigUpload(file) {
    try {
      this.setSelection([]);
      const st = await api.uploadRig(file.name, await file.arrayBuffer());
      await this.applyState(typeof st === 'object' && st.revision !== undefined ? st : await api.state(), { forceFrame: true });
    } catch (e) { this.error(e); }
  }

  // --- selection, tools, view ---------------------------------------------------

  setSelection(ids) {
    const cv = this.controlsView;
    const uniq = [...new Set(ids)].filter((id) => Number.isInteger(id) && id >= 0 && id < cv.count);
    const same = uniq.length === this.selection.length && uniq.every((id, i) => id === this.selection[i]);
    this.selection = uniq;
    cv.updateColors(new Set(uniq));
    this.gizmo.update();
    if (!same && this.opts.influence) this.updateInfluence();
    this.panel.update();
    this.updateStatus();
  }

  selectAll() { this.setSelection([...this.controlsView.visibleIds]); }

  /** The tools: controls, mesh, and the pick tools of the methods (methods/*.js "tools"). */
  setTool(name) {
    const pick = PICK_TOOLS[name];
    if (name !== 'controls' && name !== 'mesh' && name !== 'weights' && !pick) return;
    if (this.tool !== name && PICK_TOOLS[this.tool] && PICK_TOOLS[this.tool].sketch) this.clearSketch();
    this.tool = name;
    this.container.classList.toggle('tool-mesh', name === 'mesh');
    this.container.classList.toggle('tool-pick', !!pick);
    this.container.classList.toggle('tool-weights', name === 'weights');
    const hints = {
      controls: '',
      mesh: 'Mesh tool: drag a point of the surface · Alt/Ctrl+click pins · P pins under the pointer',
      weights: 'Weights: paint on the mesh (blue 0 → red 1) · Ctrl subtracts · Shift smooths · wheel: brush size · Shift+wheel: strength · Esc: done',
    };
    $('hint').textContent = pick ? pick.hint : hints[name];
    this.gizmo.update();
    this.emit('tool');
    this.panel.update();
  }

  setWireframe(on) { this.opts.wireframe = on; this.vp.setWireframe(on); this.panel.update(); }
  setControlsVisible(on) { this.opts.controls = on; this.controlsView.setVisible(on); this.gizmo.update(); this.panel.update(); }
  setRois(on) { this.opts.rois = on; this.controlsView.showRois = on; this.controlsView.updateVisibility(); this.panel.update(); }
  setShowLattice(on) {
    this.controlsView.showLattice = on;
    this.controlsView.updateVisibility();
    this.setSelection(this.selection.filter((id) => this.controlsView.isVisible(id)));
  }

  setInfluence(on) {
    this.opts.influence = on;
    this.updateInfluence();
    this.panel.update();
  }

  async updateInfluence() {
    const seq = (this.influenceSeq = (this.influenceSeq || 0) + 1);
    if (!this.opts.influence || !this.selection.length || !this.state || !this.state.method) {
      this.vp.setInfluence(null);
      return;
    }
    try {
      const inf = await api.influence(this.selection);
      if (seq !== this.influenceSeq || !this.opts.influence) return;
      this.vp.setInfluence(inf.weights);
      const m = document.querySelector('#influence-legend .max');
      if (m) m.textContent = `${Math.round(100 * this.vp.influenceMax)}%`;
    } catch (e) { this.error(e); }
  }

  // --- drags -----------------------------------------------------------------------

  /** Starts a drag of the selected controls (gizmo or point drag). */
  beginControlDrag(mode, center) {
    if (this.activeDrag || !this.selection.length) return null;
    const body = { points: [...this.selection], mode };
    body.center = center || this.controlsView.centroid(this.selection).toArray();
    if (this.state) methodOf(this.state.method).dragBody(this, body);
    const s = new DragSession(this, body);
    this.gizmo.session = s;
    this.gizmo.startPos.copy(this.gizmo.pivot.position);
    this.dragStarted(s);
    return s;
  }

  async endControlDrag(session) {
    const st = await this.endDrag(session);
    this.gizmo.dragOver();
    return st;
  }

  dragStarted(session) {
    this.activeDrag = session;
    this.dragTimes = [];
    this.updateStatus();
  }

  async endDrag(session) {
    const st = await session.end();
    if (this.activeDrag === session) this.activeDrag = null;
    this.updateStatus();
    return st;
  }

  async cancelDrag() {
    const s = this.activeDrag;
    if (!s) return false;
    if (this.gizmo.tc.dragging) { this.gizmo.tc.dragging = false; this.gizmo.tc.axis = null; this.vp.orbit.enabled = true; }
    await s.cancel();
    if (this.activeDrag === s) this.activeDrag = null;
    this.dm.drag = null;
    this.gizmo.dragOver();
    this.dm.redraw();
    return true;
  }

  // --- pick tools: click the mesh (methods/*.js "tools") ---------------------------

  addSketchPoint(p) {
    this.sketch.push(p.clone());
    this.drawSketch();
    this.panel.update();
  }

  drawSketch() {
    for (const o of [...this.sketchGroup.children]) { this.sketchGroup.remove(o); o.geometry.dispose(); o.material.dispose(); }
    if (!this.sketch.length) { this.vp.requestRender(); return; }
    const g = new THREE.BufferGeometry().setFromPoints(this.sketch);
    const pts = new THREE.Points(g, new THREE.PointsMaterial({ color: 0xff5fa2, size: 9, sizeAttenuation: false, depthTest: false }));
    const line = new THREE.Line(g.clone(), new THREE.LineBasicMaterial({ color: 0xff5fa2, depthTest: false }));
    pts.renderOrder = line.renderOrder = 25;
    this.sketchGroup.add(line, pts);
    this.vp.requestRender();
  }

  clearSketch() { this.sketch = []; this.drawSketch(); }

  /** Enter: the current pick tool's finishing action (a sketched curve is created). */
  async finishTool() {
    const pick = PICK_TOOLS[this.tool];
    if (pick && pick.finish) await pick.finish(this);
  }

  async pickAction(ev) {
    const hit = this.vp.pickMesh(ev);
    const pick = PICK_TOOLS[this.tool];
    if (hit && pick) await pick.pick(this, hit);
  }

  // --- input -------------------------------------------------------------------------

  bindPointer() {
    const el = this.container;
    el.addEventListener('pointermove', (ev) => { this.hover = ev; }, true);
    el.addEventListener('pointerleave', () => { this.hover = null; });
    // capture phase: runs before OrbitControls / TransformControls on the canvas
    el.addEventListener('pointerdown', (ev) => {
      if (ev.target !== this.vp.renderer.domElement) return;
      if (ev.button !== 0 || this.activeDrag) return;
      const consume = () => { ev.stopPropagation(); ev.preventDefault(); };
      if (this.tool === 'controls' && this.gizmo.hitTest(ev)) return; // the gizmo takes it
      if (this.tool === 'mesh' && (ev.altKey || ev.ctrlKey || ev.metaKey)) { // pins: Mesh tool only
        const hit = this.vp.pickMesh(ev);
        if (hit) { consume(); this.dm.pinVertex(hit.vertex); return; }
      }
      if (PICK_TOOLS[this.tool]) {
        const hit = this.vp.pickMesh(ev);
        if (hit) { consume(); this.pickAction(ev); }
        return;
      }
      if (this.tool === 'mesh') {
        const pin = this.dm.pickPin(ev);
        if (pin >= 0) { this.dm.selectedPin = pin; this.dm.redraw(); this.panel.render(); }
        if (!this.state || !this.state.method) return;
        const hit = this.vp.pickMesh(ev);
        if (hit) { consume(); this.dm.start(ev, hit); }
        return;
      }
      if (this.tool === 'controls') {
        if (this.selector.pointerDown(ev)) consume();
      }
    }, true);
  }

  bindKeys() {
    window.addEventListener('keydown', (ev) => {
      const t = ev.target;
      const typing = t && (t.tagName === 'SELECT' || t.tagName === 'TEXTAREA' || t.isContentEditable
        || (t.tagName === 'INPUT' && !['checkbox', 'radio', 'button', 'file', 'range'].includes(t.type)));
      if (typing) {
        if (ev.key === 'Escape') t.blur();
        return;
      }
      for (const fn of this.keyHandlers) if (fn(ev)) { ev.preventDefault(); return; }
      const k = ev.key;
      const ctrl = ev.ctrlKey || ev.metaKey;
      const help = $('help');
      if (!help.hidden && (k === 'Escape' || k === 'h' || k === 'H' || k === '?')) { help.hidden = true; ev.preventDefault(); return; }
      if (ctrl && (k === 'z' || k === 'Z')) { ev.preventDefault(); if (ev.shiftKey) this.redo(); else this.undo(); return; }
      if (ctrl && (k === 'y' || k === 'Y')) { ev.preventDefault(); this.redo(); return; }
      if (ctrl || ev.altKey) return;
      switch (k) {
        case 'g': case 'G': this.gizmo.setMode('translate'); break;
        case 'r': case 'R': this.gizmo.setMode('rotate'); break;
        case 's': case 'S': this.gizmo.setMode('scale'); break;
        case 'x': case 'X': this.gizmo.toggleAxis('X'); break;
        case 'y': case 'Y': this.gizmo.toggleAxis('Y'); break;
        case 'z': case 'Z': this.gizmo.toggleAxis('Z'); break;
        case 'm': case 'M': this.setTool('mesh'); break;
        case 'c': case 'C': this.setTool('controls'); break;
        case 'b': case 'B': this.setTool('controls'); this.selector.boxArmed = !this.selector.boxArmed; this.emit('tool'); break;
        case 'a': case 'A': this.selectAll(); break;
        case 'w': case 'W': this.setWireframe(!this.opts.wireframe); break;
        case 'i': case 'I': this.setInfluence(!this.opts.influence); break;
        case 'f': case 'F': this.frame(); break;
        case 'h': case 'H': case '?': help.hidden = false; break;
        case 'p': case 'P': this.pinUnderPointer(); break;
        case 'Delete': case 'Backspace': this.unpinKey(); break;
        case 'Enter': this.finishTool(); break;
        case 'Escape': this.escape(); break;
        default: return;
      }
      ev.preventDefault();
    });
  }

  async escape() {
    if (await this.cancelDrag()) return;
    if (this.selector.boxArmed) { this.selector.boxArmed = false; this.emit('tool'); return; }
    if (this.tool !== 'controls' && this.tool !== 'mesh') { this.setTool('controls'); return; }
    if (this.gizmo.axis) { this.gizmo.toggleAxis(this.gizmo.axis); }
    this.dm.selectedPin = -1;
    this.dm.redraw();
    this.setSelection([]);
  }

  pinUnderPointer() {
    if (this.tool !== 'mesh') { this.info('Pins are set with the Mesh tool: press M, then P over the surface'); return; }
    if (!this.hover) return;
    const hit = this.vp.pickMesh(this.hover);
    if (hit) this.dm.pinVertex(hit.vertex);
  }

  unpinKey() {
    let v = this.dm.selectedPin;
    if (v < 0 && this.hover) v = this.dm.pickPin(this.hover);
    if (v >= 0) this.dm.unpin(v);
  }

  bindToolbar() {
    for (const b of document.querySelectorAll('[data-tool]')) b.addEventListener('click', () => this.setTool(b.dataset.tool));
    for (const b of document.querySelectorAll('[data-mode]')) b.addEventListener('click', () => this.gizmo.setMode(b.dataset.mode));
    for (const b of document.querySelectorAll('[data-axis]')) b.addEventListener('click', () => this.gizmo.toggleAxis(b.dataset.axis));
    $('btn-box').addEventListener('click', () => { this.setTool('controls'); this.selector.boxArmed = !this.selector.boxArmed; this.emit('tool'); });
    $('btn-undo').addEventListener('click', () => this.undo());
    $('btn-redo').addEventListener('click', () => this.redo());
    $('btn-help').addEventListener('click', () => { $('help').hidden = false; });
    $('help-close').addEventListener('click', () => { $('help').hidden = true; });
    $('help').addEventListener('click', (e) => { if (e.target.id === 'help') $('help').hidden = true; });
    this.syncToolbar();
  }

  syncToolbar() {
    for (const b of document.querySelectorAll('[data-tool]')) b.classList.toggle('active', b.dataset.tool === this.tool);
    for (const b of document.querySelectorAll('[data-mode]')) b.classList.toggle('active', b.dataset.mode === this.gizmo.mode);
    for (const b of document.querySelectorAll('[data-axis]')) b.classList.toggle('active', b.dataset.axis === this.gizmo.axis);
    $('btn-box').classList.toggle('active', this.selector.boxArmed);
    const s = this.state || {};
    $('btn-undo').disabled = !s.undo;
    $('btn-redo').disabled = !s.redo;
  }

  // --- status, toasts, busy ------------------------------------------------------------

  bindStatus() {
    onActivity(() => this.updateStatus());
    const busy = $('busy');
    setInterval(() => {
      const show = oldestPendingMs() > 400;
      if (show !== !busy.hidden) busy.hidden = !show;
      if (show) $('busy-label').textContent = busyText(pendingLabel());
      if (show) $('busy-time').textContent = busyProgress(oldestPendingMs()); else progressDone();
      if (this.activeDrag) this.updateStatus();
    }, 100);
  }

  updateStatus() {
    const s = this.state || {};
    const c = s.controls || {};
    const m = s.mesh || {};
    const set = (id, html) => { const e = $(id); if (e.innerHTML !== html) e.innerHTML = html; };
    set('st-method', `Method <b>${s.method || 'none'}</b>`);
    set('st-mesh', m.name ? `${esc(m.name)} <b>${fmtInt(m.vertices)}</b> v · <b>${fmtInt(m.faces)}</b> f` : '');
    set('st-controls', s.method ? `Controls <b>${fmtInt(c.count)}</b>${methodOf(s.method).status(c)}` : '');
    set('st-sel', `Selected <b>${this.selection.length}</b>`);
    set('st-pins', (s.pins || []).length ? `Pins <b>${s.pins.length}</b>` : '');
    set('st-rev', s.revision !== undefined ? `History <b>${s.undo || 0}</b> step${s.undo === 1 ? '' : 's'}${s.redo ? ` · ${s.redo} to redo` : ''}` : '');
    const revTitle = `Steps Ctrl+Z can undo, and Ctrl+Y redo (revision ${s.revision ?? '—'}: the server's change counter)`;
    if ($('st-rev').title !== revTitle) $('st-rev').title = revTitle;
    const now = performance.now();
    const recent = this.dragTimes.filter((t) => now - t <= 1000);
    set('st-ups', this.activeDrag || (recent.length && now - recent[recent.length - 1] < 1500)
      ? `Drag <b>${recent.length}</b> updates/s · step ${(this.lastDragMs || 0).toFixed(0)} ms (+${(this.lastApplyMs || 0).toFixed(0)} ms mesh update)` : '');
    set('st-req', `Response <b>${Math.round(stats.lastMs)}</b> ms`);
    const reqTitle = `How long the server took to answer the last request: ${stats.lastMs.toFixed(1)} ms in all${s.busy_ms !== undefined ? `, ${(+s.busy_ms).toFixed(1)} ms of it computing` : ''}`;
    if ($('st-req').title !== reqTitle) $('st-req').title = reqTitle;
    this.syncToolbar();
  }

  error(e) {
    console.warn('ffd editor:', e);
    const msg = e instanceof ApiError ? e.message : (e && e.message) || String(e);
    if (e instanceof ApiError && e.status === 'network') return; // the offline banner says it
    this.toast(msg, 'error');
  }

  info(msg) { this.toast(msg, 'info', 3500); }

  /** A toast (toasts.js): errors stay until closed, info goes by itself. */
  toast(msg, kind = 'error') { return this.toasts.show(msg, kind); }

  // --- test handle ------------------------------------------------------------------------

  screenOf(v) {
    const s = this.vp.toScreen(v);
    return { x: s.rect.left + s.x, y: s.rect.top + s.y };
  }
}

function esc(s) { return String(s).replace(/[&<>"]/g, (c) => ({ '&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;' }[c])); }
function busyText(label) {
  const names = {
    create: 'Creating the deformer…', topology: 'Loading the mesh…', frame: 'Evaluating…', influence: 'Computing influence…',
    'upload mesh': 'Uploading and binding…', 'upload rig': 'Loading rig…', open: 'Opening mesh…',
    drag: 'Solving…', drag_begin: 'Preparing drag…', ...BUSY,
  };
  return names[label] || (label && !label.startsWith('/') ? label : 'Working…');
}

/**
 * Benchmark (bench/editor_drag.mjs): drags the selected controls through the
 * same path as a gizmo or point drag (DragSession: drag_begin, `drag` steps with
 * one request in flight and the latest queued step winning, each frame applied
 * to the geometry with its normals, drawn by the render loop, drag_end), fed
 * with a new step every 4 ms so that the pipeline never waits for input. Resolves
 * to {steps, ms, updatesPerSecond, framesDrawn, drawnPerSecond, requestMs[],
 * applyMs[]} (per-frame samples: the request's round trip, the mesh update).
 */
async function benchDrag(n = 100, { amplitude = 0.05 } = {}) {
  if (!editor.selection.length) throw new Error('benchDrag: select controls first');
  const s = editor.beginControlDrag('translate');
  if (!s) throw new Error('benchDrag: a drag is already running');
  let drawn = 0;
  const count = () => { drawn++; };
  editor.vp.onBeforeRender.push(count);
  const requestMs = [], applyMs = [];
  const d = amplitude * editor.vp.diag;
  let i = 0;
  const next = () => { i++; s.update({ delta: [d * Math.sin(i / 7), 0.5 * d * (1 - Math.cos(i / 7)), 0] }); };
  let done;
  const finished = new Promise((r) => { done = r; });
  editor.onDragFrame = (frame, ms) => {
    Editor.prototype.onDragFrame.call(editor, frame, ms);
    requestMs.push(ms);
    applyMs.push(editor.lastApplyMs);
    if (s.steps >= n) done();
  };
  if (!(await s.begun)) { delete editor.onDragFrame; throw new Error('benchDrag: drag_begin failed'); }
  const t0 = performance.now();
  const drawn0 = drawn;
  // pointer moves every 4 ms (a mouse gives one per display frame): a step is
  // always queued when a frame arrives, so the server never waits for input
  next();
  const input = setInterval(() => { if (s.failed) done(); else next(); }, 4);
  await finished;
  clearInterval(input);
  delete editor.onDragFrame;
  const ms = performance.now() - t0;
  // let the render loop draw the last frame
  await new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r)));
  const framesDrawn = drawn - drawn0;
  editor.vp.onBeforeRender.splice(editor.vp.onBeforeRender.indexOf(count), 1);
  await editor.endControlDrag(s);
  if (s.failed) throw new Error('benchDrag: a drag step failed');
  return {
    steps: s.steps, ms, updatesPerSecond: (1000 * s.steps) / ms,
    framesDrawn, drawnPerSecond: (1000 * framesDrawn) / ms, requestMs, applyMs,
  };
}

const editor = new Editor();
window.ffdEditor = {
  get state() { return editor.state; },
  get selection() { return [...editor.selection]; },
  get ready() { return editor.ready; },
  get lastFrameRevision() { return editor.lastFrameRevision; },
  get tool() { return editor.tool; },
  get dragging() { return !!editor.activeDrag; },
  /** Requests sent to the server and not yet answered. */
  get pendingRequests() { return pendingCount(); },
  get dragStats() {
    const now = performance.now();
    return { updatesPerSecond: editor.dragTimes.filter((t) => now - t <= 1000).length, stepMs: editor.lastDragMs, applyMs: editor.lastApplyMs };
  },
  select(ids) { editor.setSelection(ids); },
  screenOfControl(id) { return editor.screenOf(editor.controlsView.position(id)); },
  screenOfVertex(v) { return editor.screenOf(editor.vp.vertex(v)); },
  setTool(name) { editor.setTool(name); },
  /** Tests: skip drawing (software GL in headless browsers is far slower than a GPU). */
  setRenderEnabled(on) { editor.vp.renderDisabled = !on; editor.vp.requestRender(); },
  setGizmoMode(mode) { editor.gizmo.setMode(mode); },
  gizmoCenter() { return editor.screenOf(editor.gizmo.pivot.position); },
  benchDrag(n, opts) { return benchDrag(n, opts); },
  /** Benchmarks: api.deltaFrames = false makes drag steps ask for full frames. */
  api,
  editor,
  THREE, // tests: independent checks (a ray cast) with the page's own three
};
editor.boot();
