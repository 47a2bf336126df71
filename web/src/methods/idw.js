// Inverse-distance weighting (PyGeM's IDW, Shepard) in the editor: the
// control points are drawn as points and dragged (docs/rbf-idw.md).

import { h } from '../dom.js';
import { numberRow } from './ui.js';

export default {
  name: 'idw',
  label: 'Inverse-distance weighting (IDW)',
  form: { power: 2, weighting: 'pygem' },

  createFields(p) {
    return [numberRow('idw', 'Power p', p, 'power', { min: 0.1, step: 0.5, title: 'How quickly a control point’s pull fades with distance: higher = more local' }),
      h('div', { class: 'row' }, h('label', {}, 'Weights'),
        h('select', { name: 'idw-weighting', title: 'The distance weighting formula (PyGeM’s or Shepard’s)', onchange: (e) => { p.weighting = e.target.value; } },
          h('option', { value: 'pygem', selected: p.weighting === 'pygem' }, '1 / |x − c|ₚ (PyGeM)'),
          h('option', { value: 'shepard', selected: p.weighting === 'shepard' }, '1 / |x − c|ᵖ (Shepard)'))),
      h('div', { class: 'hint-text' }, '27 control points on a grid around the mesh; drag them.')];
  },

  createBody(p) { return { power: p.power > 0 ? p.power : 2, weighting: p.weighting }; },

  section(panel, s, c) {
    const ed = panel.ed;
    return h('section', {}, h('h3', {}, 'IDW'),
      h('div', { class: 'hint-text' }, `${c.count || 0} control points; each point moves by the weighted mean of their moves.`),
      h('div', { class: 'row buttons' },
        h('button', { title: 'Select every control point (A)', onclick: () => ed.selectAll() }, 'Select all'),
        h('button', { 'data-need-sel': true, title: 'Select nothing (Esc)', onclick: () => ed.setSelection([]) }, 'Clear selection')));
  },
};
