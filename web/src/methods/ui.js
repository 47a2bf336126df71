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
