// Form helpers shared by the method modules' panel sections.

import { h } from '../dom.js';

export const num = (v, d) => { const x = Number(v); return Number.isFinite(x) ? x : d; };

/** Three integer inputs l, m, n (>= 2) editing obj.resolution. */
export const resolutionRow = (method, obj) => h('div', { class: 'row' }, h('label', {}, 'Resolution'),
  [0, 1, 2].map((i) => h('input', {
    type: 'number', class: 'narrow', min: 2, max: 64, step: 1, value: obj.resolution[i], name: `res-${method}-${i}`,
    title: ['l (x)', 'm (y)', 'n (z)'][i],
    onchange: (e) => { obj.resolution[i] = Math.max(2, Math.round(num(e.target.value, obj.resolution[i]))); },
  })));

/** A labelled number input editing obj[key]. */
export const numberRow = (method, label, obj, key, attrs = {}) => h('div', { class: 'row' }, h('label', {}, label),
  h('input', {
    type: 'number', value: obj[key], name: `${method}-${key}`, ...attrs,
    onchange: (e) => { obj[key] = num(e.target.value, obj[key]); },
  }));

// --- "Details": the raw numbers, out of the way -----------------------------

const DETAILS_KEY = 'ffd-editor.details-open';
const detailsOpen = () => { try { return localStorage.getItem(DETAILS_KEY) === '1'; } catch { return false; } };

/**
 * A collapsible "Details" block of raw numbers for the technically minded:
 * rows of [label, value, title]; each row's title says in plain words what
 * the number means (its tooltip). Open or closed is remembered.
 */
export function details(rows, summary = 'Details') {
  return h('details', {
    class: 'details', open: detailsOpen(),
    ontoggle: (e) => { try { localStorage.setItem(DETAILS_KEY, e.target.open ? '1' : '0'); } catch { /* private mode */ } },
  },
  h('summary', { title: 'The exact numbers behind the text above (hover one for what it means)' }, summary),
  h('dl', {}, rows.filter(Boolean).map(([label, value, title]) => [h('dt', { title }, label), h('dd', { title }, value)])));
}
