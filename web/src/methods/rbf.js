// RBF morphing (PyGeM's RBF: radial kernels plus a linear polynomial) in the
// editor: the control points are drawn as points and dragged; every drag
// interpolates them exactly (docs/rbf-idw.md).

import { h } from '../dom.js';
import { numberRow } from './ui.js';

const KERNELS = [
  ['gaussian_spline', 'Gaussian'],
  ['multi_quadratic_biharmonic_spline', 'Multiquadric'],
  ['inv_multi_quadratic_biharmonic_spline', 'Inverse multiquadric'],
  ['thin_plate_spline', 'Thin-plate spline'],
  ['beckert_wendland_c2_basis', 'Wendland C² (compact)'],
  ['polyharmonic_spline', 'Polyharmonic'],
];

export default {
  name: 'rbf',
  label: 'RBF morphing (PyGeM kernels)',
  form: { kernel: 'gaussian_spline', radius: 0, power: 2 },

  createFields(p) {
    return [h('div', { class: 'row' }, h('label', {}, 'Kernel'),
      h('select', { name: 'rbf-kernel', title: 'The radial function: how a control point’s pull fades with distance', onchange: (e) => { p.kernel = e.target.value; } },
        KERNELS.map(([v, t]) => h('option', { value: v, selected: p.kernel === v }, t)))),
    numberRow('rbf', 'Radius', p, 'radius', { min: 0, step: 'any', title: 'How far each control point reaches (0: half the model’s size)' }),
    numberRow('rbf', 'Power k', p, 'power', { min: 1, max: 64, step: 1, title: 'The kernel’s power (polyharmonic kernels)' }),
    h('div', { class: 'hint-text' }, '27 control points on a grid around the mesh; drag them, or pin the mesh (direct manipulation).')];
  },

  createBody(p) {
    const body = { kernel: p.kernel, power: Math.max(1, Math.round(p.power)) };
    if (p.radius > 0) body.radius = p.radius;
    return body;
  },

  section(panel, s, c) {
    const ed = panel.ed;
    const name = (KERNELS.find(([v]) => v === c.kernel) || [c.kernel, c.kernel])[1];
    return h('section', {}, h('h3', {}, 'RBF'),
      h('div', { class: 'hint-text' }, `${c.count || 0} control points, ${name} kernel. The mesh follows the control points exactly where they are.`),
      h('div', { class: 'row buttons' },
        h('button', { title: 'Select every control point (A)', onclick: () => ed.selectAll() }, 'Select all'),
        h('button', { 'data-need-sel': true, title: 'Select nothing (Esc)', onclick: () => ed.setSelection([]) }, 'Clear selection')));
  },
};
