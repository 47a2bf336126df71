// A drag against the server: drag_begin once, `drag` steps with at most one
// request in flight (latest wins), then drag_end (or drag_cancel).

import { api, revisionAfter } from './api.js';

export class DragSession {
  /**
   * @param editor   the editor (applyFrame, applyState, error, stats)
   * @param begin    the drag_begin body
   * @param planned  true: the steps are final (the modal transforms plan their own);
   *                 else a control drag (gizmo, point) with mirror or proportional
   *                 editing on also moves the counterparts and neighbours: its points
   *                 grow and each step becomes their moves (transform.js dragPlan)
   */
  constructor(editor, begin, { planned = false } = {}) {
    this.editor = editor;
    this.plan = !planned && begin.points && editor.transform ? editor.transform.dragPlan(begin) : null;
    this.pending = null;     // latest step body not yet sent
    this.inflight = null;    // promise of the step being sent
    this.lastSent = null;
    this.failed = false;
    this.closed = false;
    this.steps = 0;
    this.begun = api.op('drag_begin', begin).then(
      (state) => { this.editor.applyState(state, { frame: false }); return true; },
      (err) => { this.failed = true; this.editor.error(err); return false; },
    );
  }

  /** Queues a step; only the latest queued body is sent when the wire is free. */
  update(body) {
    if (this.closed || this.failed) return;
    this.pending = this.plan ? this.plan(body) : body;
    this.pump();
  }

  /**
   * Sends queued steps one at a time. When a frame arrives and a newer step is
   * queued, that step is sent before the frame is applied, so the server's
   * solve overlaps the page's mesh update (still one request in flight).
   */
  async pump() {
    if (this.pumping) return;
    this.pumping = true;
    try {
      if (!(await this.begun)) return;
      // base: the revision the geometry will hold when the reply is applied (delta frames)
      const start = (base) => {
        const body = this.pending;
        this.pending = null;
        this.lastSent = body;
        const t0 = performance.now();
        this.inflight = api.dragStep(body, base).then((frame) => ({ frame, ms: performance.now() - t0 }));
        return this.inflight;
      };
      let req = this.pending && !this.failed ? start(this.editor.lastFrameRevision) : null;
      while (req) {
        let res;
        try {
          res = await req;
        } catch (err) {
          this.failed = true;
          this.inflight = null;
          this.editor.error(err);
          return;
        }
        req = this.pending && !this.failed ? start(revisionAfter(res.frame, this.editor.lastFrameRevision)) : null;
        if (!req) this.inflight = null;
        this.steps++;
        this.editor.onDragFrame(res.frame, res.ms);
      }
    } finally {
      this.pumping = false;
    }
  }

  /** Resolves once nothing is queued or in flight. */
  async idle() {
    await this.begun;
    for (;;) {
      if (this.inflight) { try { await this.inflight; } catch { /* reported */ } }
      await new Promise((r) => setTimeout(r, 0));
      if (this.failed) return;
      if (this.pending && !this.pumping) this.pump();
      if (!this.inflight && !this.pumping && !this.pending) return;
    }
  }

  /** Ends the drag: one undo entry. Resolves to the new state (or null). */
  async end() {
    if (this.closed) return null;
    this.closed = true;
    const ok = await this.begun;
    if (!ok) return null;
    await this.idle();
    try {
      const state = await api.op('drag_end', {});
      await this.editor.applyState(state);
      return state;
    } catch (err) {
      this.editor.error(err);
      this.editor.refresh();
      return null;
    }
  }

  /** Abandons the drag and restores the state before it. */
  async cancel() {
    if (this.closed) return null;
    this.closed = true;
    this.pending = null;
    const ok = await this.begun;
    if (!ok) return null;
    await this.idle();
    try {
      const state = await api.op('drag_cancel', {});
      await this.editor.applyState(state, { forceFrame: true });
      return state;
    } catch (err) {
      this.editor.error(err);
      this.editor.refresh();
      return null;
    }
  }
}
