// Lattice FFD (Sederberg-Parry / B-spline, Hsu et al.) in the editor.

import { h } from '../dom.js';
import { resolutionRow, numberRow } from './ui.js';

export default {
  name: 'lattice',
  label: 'Lattice (B-spline / Bernstein)',
  form: { resolution: [5, 5, 5], basis: 'bspline', margin: 0.05 },

  createFields(p) {
    return [resolutionRow('lattice', p),
      h('div', { class: 'row' }, h('label', {}, 'Basis'),
        h('select', { name: 'basis', onchange: (e) => { p.basis = e.target.value; } },
          h('option', { value: 'bspline', selected: p.basis === 'bspline' }, 'Cubic B-spline'),
          h('option', { value: 'bernstein', selected: p.basis === 'bernstein' }, 'Bernstein (Bézier)'))),
      numberRow('lattice', 'Margin', p, 'margin', { min: 0, step: 0.01 })];
  },

  createBody(p) { return { resolution: p.resolution, basis: p.basis, margin: p.margin }; },

  section(panel, s, c) {
    const ed = panel.ed;
    return h('section', {}, h('h3', {}, 'Lattice'),
      h('div', { class: 'hint-text' }, `${(c.resolution || []).join(' × ')} control points, ${c.basis === 'bernstein' ? 'Bernstein (Bézier)' : 'cubic B-spline'} basis. `,
        'Change the resolution or basis above and press Re-create.'),
      h('div', { class: 'row buttons' },
        h('button', { onclick: () => ed.selectAll() }, 'Select all'),
        h('button', { 'data-need-sel': true, onclick: () => ed.setSelection([]) }, 'Clear selection')));
  },
};
