// Messages to the user: toasts in a corner of the view (never over its
// centre), and the lasting "offline" banner with its reconnection.
//
// - info toasts go away by themselves after a few seconds;
// - errors stay until closed, at most MAX_ERRORS shown: older ones collapse
//   into one "+N more" line (click it to see them all again);
// - a message equal to the newest toast of its kind merges into it with a
//   count (×3) instead of stacking.
// The banner: when a request cannot reach the server the page shows
// "Offline — reconnecting…", polls the server with a growing delay (1 s,
// 2 s, 4 s, … at most 10 s; "Retry now" polls at once), and when the server
// answers hides the banner and calls onBack (the editor reloads its state).

import { h } from './dom.js';
import { onConnection, ping } from './api.js';

export const MAX_ERRORS = 3;
export const INFO_MS = 4000;
const BACKOFF_MS = [1000, 2000, 4000, 8000, 10000];
const HEARTBEAT_MS = 5000;

export class Toasts {
  constructor(box) {
    this.box = box;
    this.expanded = false;
    this.more = h('button', {
      class: 'toast-more', title: 'Show the older messages (they stay until closed)',
      onclick: () => { this.expanded = !this.expanded; this.layout(); },
    });
  }

  /** Shows msg; kind 'error' (stays) or 'info' (goes after INFO_MS). */
  show(msg, kind = 'error') {
    const last = [...this.box.querySelectorAll(`.toast.${kind}`)].pop();
    if (last && last.dataset.msg === msg) {
      const n = Number(last.dataset.count || 1) + 1;
      last.dataset.count = n;
      last.querySelector('.count').textContent = `×${n}`;
      this.box.appendChild(last); // newest last
      if (kind === 'info') this.expire(last);
      this.layout();
      return last;
    }
    const el = h('div', { class: `toast ${kind}`, role: kind === 'error' ? 'alert' : 'status', dataset: { msg, count: 1 } },
      h('span', { class: 'msg' }, msg),
      h('span', { class: 'count', title: 'How many times this message came' }),
      h('button', { class: 'close', title: 'Dismiss', onclick: () => { el.remove(); this.layout(); } }, '×'));
    this.box.appendChild(el);
    if (kind === 'info') this.expire(el);
    this.layout();
    return el;
  }

  expire(el) {
    clearTimeout(el.expireTimer);
    el.expireTimer = setTimeout(() => { el.remove(); this.layout(); }, INFO_MS);
  }

  /** Hides all but the newest MAX_ERRORS errors behind the "+N more" line. */
  layout() {
    const errors = [...this.box.querySelectorAll('.toast.error')];
    const hidden = this.expanded ? 0 : Math.max(0, errors.length - MAX_ERRORS);
    errors.forEach((e, i) => { e.hidden = i < hidden; });
    if (errors.length <= MAX_ERRORS) this.expanded = false;
    if (errors.length > MAX_ERRORS) {
      this.more.textContent = this.expanded ? 'Show fewer' : `+${hidden} more`;
      this.box.prepend(this.more);
    } else {
      this.more.remove();
    }
  }

  clear() { this.box.replaceChildren(); this.expanded = false; }
}

export class OfflineBanner {
  /** el: the banner element; onBack(): called when the server answers again. */
  constructor(el, onBack) {
    this.el = el;
    this.onBack = onBack;
    this.offline = false;
    this.attempt = 0;
    this.timer = 0;
    this.label = h('span', { class: 'msg' });
    this.retry = h('button', { title: 'Try to reach the server now', onclick: () => this.poll() }, 'Retry now');
    el.replaceChildren(h('span', { class: 'dot' }), this.label, this.retry);
    onConnection((up) => { if (!up) this.down(); });
    // a heartbeat while idle, so that a server stopped between requests shows too
    setInterval(() => {
      if (!this.offline && !this.beating && document.visibilityState !== 'hidden') {
        this.beating = true;
        ping().then((ok) => { this.beating = false; if (!ok) this.down(); });
      }
    }, HEARTBEAT_MS);
  }

  down() {
    if (this.offline) return;
    this.offline = true;
    this.attempt = 0;
    this.el.hidden = false;
    document.body.classList.add('offline');
    this.schedule();
  }

  schedule() {
    clearTimeout(this.timer);
    const ms = BACKOFF_MS[Math.min(this.attempt, BACKOFF_MS.length - 1)];
    this.label.textContent = `Offline — the server does not answer. Reconnecting in ${Math.round(ms / 1000)} s…`;
    this.timer = setTimeout(() => this.poll(), ms);
  }

  async poll() {
    if (!this.offline) return;
    clearTimeout(this.timer);
    this.label.textContent = 'Offline — reconnecting…';
    if (await ping()) {
      this.offline = false;
      this.el.hidden = true;
      document.body.classList.remove('offline');
      await this.onBack();
      return;
    }
    this.attempt++;
    this.schedule();
  }
}
