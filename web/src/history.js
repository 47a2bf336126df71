// Work is never lost (docs/editor.md "Work is never lost"): the History panel
// section (the session's named steps, the present one highlighted, a click
// jumps to any of them through POST /api/history/goto), the Undo/Redo
// buttons' counts and step names kept in step with every state, the resume
// toast of an autosaved session, and the word an artist needs before or
// after a destructive action (asked when it cannot be undone, a toast saying
// how to undo it when it can).

import { api } from './api.js';
import { h } from './dom.js';

/** Steps whose change replaces or resets work, and what the toast says after them. */
const UNDOABLE = [
  [/^Create /, (name, prev) => (prev && prev.method ? `${name}: the deformer was re-created and the mesh is back at rest — undo with Ctrl+Z` : null)],
  [/^Load rig /, (name) => `${name}: the previous deformer was replaced — undo with Ctrl+Z`],
  [/^Reset to rest$/, () => 'Every control is back at rest — undo with Ctrl+Z'],
  [/^Unpin all /, (name) => `${name} — undo with Ctrl+Z`],
];

export class History {
  constructor(editor) {
    this.ed = editor;
    this.list = null;      // the section's list element, refreshed in place
    this.status = null;
    this.prev = null;      // the state before the last one
    this.noted = false;    // the resume note was shown
    this.going = false;
    editor.on('state', (s) => this.sync(s));
  }

  /** The panel's History section (panel.js render()). */
  section(s) {
    this.list = h('ol', { class: 'history-list', 'aria-label': 'History steps' });
    this.status = h('div', { class: 'hint-text history-status' });
    this.earlier = h('div', { class: 'history-earlier', hidden: true });
    const sec = h('section', { class: 'history' },
      h('h3', { title: 'Every change is a named step: click one to go back to it (or forward again). A new change after going back drops the steps after it, like Undo.' }, 'History'),
      this.list, this.status, this.earlier);
    this.fill(s);
    requestAnimationFrame(() => this.showCurrent()); // once the panel holds it
    return sec;
  }

  /** The present step in view inside the list only (never scrolls the panel). */
  showCurrent() {
    const cur = this.list && this.list.querySelector('.current');
    if (!cur) return;
    const l = this.list.getBoundingClientRect(), c = cur.getBoundingClientRect();
    if (c.top < l.top) this.list.scrollTop -= l.top - c.top;
    else if (c.bottom > l.bottom) this.list.scrollTop += c.bottom - l.bottom;
  }

  /** Every state: the list, the counts, the resume note and the after-action toasts. */
  sync(s) {
    this.fill(s);
    this.counts(s);
    this.resumeNote(s);
    this.afterAction(s, this.prev);
    this.prev = s;
  }

  fill(s) {
    if (!this.list) return;
    const hist = s.history || { steps: [], current: 0 };
    const key = JSON.stringify([hist.steps, hist.current]);
    if (this.list.dataset.key !== key) {
      this.list.dataset.key = key;
      this.list.replaceChildren(...hist.steps.map((name, i) => {
        const kind = i === hist.current ? 'current' : i < hist.current ? 'done' : 'undone';
        const how = i === hist.current ? 'The present step' : i < hist.current ? 'Go back to this step (undoes the steps after it; Redo or a click brings them back)' : 'Go forward to this step (redoes the steps up to it)';
        return h('li', {
          class: `history-step ${kind}`, 'data-index': i, title: `${name} — ${how}`, tabindex: 0, role: 'button',
          'aria-current': i === hist.current ? 'step' : null,
          onclick: () => this.goto(i),
          onkeydown: (e) => { if (e.key === 'Enter' || e.key === ' ') { e.preventDefault(); this.goto(i); } },
        }, h('span', { class: 'n' }, String(i)), h('span', { class: 'name' }, name));
      }));
      this.showCurrent();
    }
    if (this.status) {
      const a = s.autosave || {};
      const text = a.error
        ? `Autosave failed: ${a.error} — save the rig to keep your work`
        : a.resumed === false
        ? `Your autosave was not applied: ${a.reason}`
        : a.file ? `Autosaved after each change to ${a.file}` : 'Autosave is off: this session lives in the server only (ffd serve --no-autosave, or an uploaded mesh)';
      if (this.status.textContent !== text) {
        this.status.textContent = text;
        this.status.classList.toggle('warn', a.resumed === false || !a.file || !!a.error);
        this.status.title = a.file ? 'A restarted ffd serve on this mesh resumes this session: state, pins and history' : '';
      }
    }
    if (this.earlier) {
      const p = (s.autosave || {}).previous;
      const key = p ? JSON.stringify([p.file, p.saved_unix, !!(s.undo || s.redo)]) : '';
      if (this.earlier.dataset.key !== key) {
        this.earlier.dataset.key = key;
        this.earlier.hidden = !p;
        this.earlier.replaceChildren(...(p ? [
          h('span', { class: 'hint-text' }, `An earlier session of ${s.mesh && s.mesh.name} is kept (${p.steps} steps, saved ${when(p.saved_unix, p.saved)})`),
          h('button', {
            name: 'resume-earlier', onclick: () => this.resumeEarlier(),
            title: `Bring back the earlier session of this mesh (${p.file}): its deformer, pins and history${s.undo || s.redo ? '. This session’s steps are replaced: you will be asked first' : ''}`,
          }, '⟲ Resume it'),
        ] : []));
      }
    }
  }

  /** POST /api/autosave/resume: the earlier session kept when the mesh was opened. */
  async resumeEarlier() {
    const s = this.ed.state || {};
    if ((s.undo || s.redo) && !window.confirm(`Resume the earlier session of ${s.mesh && s.mesh.name}?\n\nThe ${s.undo + s.redo} steps of this session are replaced and cannot be undone.`)) return;
    try {
      const st = await api.post('/api/autosave/resume', {}, 'Resuming…');
      await this.ed.applyState(st, { forceFrame: true }); // its autosave note makes the toast
    } catch (e) {
      this.ed.error(e);
    }
  }

  async goto(index) {
    const s = this.ed.state || {};
    if (this.going || this.ed.activeDrag || !s.history || index === s.history.current) return;
    this.going = true;
    try {
      const st = await api.post('/api/history/goto', { index }, 'History…');
      await this.ed.applyState(st, { forceFrame: true });
    } catch (e) {
      this.ed.error(e);
    } finally {
      this.going = false;
    }
  }

  /** The Undo button's tooltip: the step it undoes. */
  undoTitle(s) {
    const hist = s.history || { steps: [], current: 0 };
    const name = s.undo ? hist.steps[hist.current] : '';
    return name ? `Undo “${name}” (Ctrl+Z)` : 'Nothing to undo (Ctrl+Z)';
  }

  /** The Redo button's tooltip: the step it redoes. */
  redoTitle(s) {
    const hist = s.history || { steps: [], current: 0 };
    const name = s.redo ? hist.steps[hist.current + 1] : '';
    return name ? `Redo “${name}” (Ctrl+Shift+Z / Ctrl+Y)` : 'Nothing to redo (Ctrl+Shift+Z / Ctrl+Y)';
  }

  /** The Undo/Redo buttons (panel and toolbar): counts and the step each one undoes or redoes. */
  counts(s) {
    const set = (el, text, title) => {
      if (!el) return;
      if (text !== null && el.textContent !== text) el.textContent = text;
      if (el.title !== title) el.title = title;
    };
    for (const b of document.querySelectorAll('[data-history="undo"]')) b.disabled = !s.undo;
    for (const b of document.querySelectorAll('[data-history="redo"]')) b.disabled = !s.redo;
    for (const b of document.querySelectorAll('[data-history="undo"]')) set(b, `↶ Undo${s.undo ? ` (${s.undo})` : ''}`, this.undoTitle(s));
    for (const b of document.querySelectorAll('[data-history="redo"]')) set(b, `↷ Redo${s.redo ? ` (${s.redo})` : ''}`, this.redoTitle(s));
    set(document.getElementById('btn-undo'), null, this.undoTitle(s));
    set(document.getElementById('btn-redo'), null, this.redoTitle(s));
  }

  /** Once per resumed record: where the session came from, or why it did not come back. */
  resumeNote(s) {
    const a = s.autosave;
    if (a && a.previous) {
      const key = `ffd-previous-${a.previous.file}-${a.previous.saved_unix}`;
      if (this.notedPrevious !== key) {
        this.notedPrevious = key;
        this.ed.toast(`An earlier session of ${s.mesh && s.mesh.name} is kept (${a.previous.steps} steps, saved ${when(a.previous.saved_unix, a.previous.saved)}): History ▸ Resume it`, 'info', 8000);
      }
    }
    if (!a || a.resumed === undefined) return;
    const key = `ffd-resume-${s.mesh && s.mesh.name}-${a.saved_unix}-${a.resumed}`;
    if (this.noted === key) return;
    this.noted = key;
    try { if (sessionStorage.getItem(key)) return; sessionStorage.setItem(key, '1'); } catch { /* storage off: show it */ }
    if (a.resumed) {
      this.ed.toast(`Resumed your session from ${when(a.saved_unix, a.saved)} (${a.steps} history steps)`, 'info', 8000);
    } else {
      this.ed.toast(`Your autosaved session was not applied: ${a.reason}`, 'error');
    }
  }

  /** After an undoable step that replaced or reset work: how to get it back. */
  afterAction(s, prev) {
    if (!prev || !s.history || !prev.history || this.going) return;
    if (s.undo !== prev.undo + 1 || s.history.steps.length < 2) return;
    if ((s.mesh && s.mesh.name) !== (prev.mesh && prev.mesh.name)) return;
    const name = s.history.steps[s.history.current];
    for (const [re, say] of UNDOABLE) {
      if (!re.test(name)) continue;
      const msg = say(name, prev);
      if (msg) this.ed.info(msg);
      return;
    }
  }

  /**
   * Before replacing the session by another mesh: says where the work goes,
   * and asks when it would be lost (autosave off). Returns true to go on.
   */
  confirmReplace(what) {
    const s = this.ed.state || {};
    if (!s.undo && !s.redo) return true;
    const mesh = (s.mesh && s.mesh.name) || 'this mesh';
    const a = s.autosave || {};
    if (a.file) {
      this.ed.info(`${mesh}: your session is autosaved (${a.file}) — open ${mesh} again and History ▸ Resume it brings it back`);
      return true;
    }
    return window.confirm(`Open ${what}?\n\nYour session of ${mesh} (${s.undo} steps) is not autosaved and will be lost: save its rig first (Rig ▸ Save on server) to keep it.`);
  }
}

/** A saved time in the reader's local time. */
function when(unix, text) { return unix ? new Date(unix * 1000).toLocaleString() : text || '?'; }
