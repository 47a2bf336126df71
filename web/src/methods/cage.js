// Cage deformation (mean value coordinates, Ju et al. 2005; harmonic
// coordinates, Joshi et al. 2007) in the editor: the cage is drawn as a
// wireframe (its edges) and its vertices are the control points, picked and
// dragged like any other; the "auto" cage is the mesh's bounding box.

import { h } from '../dom.js';
import { numberRow } from './ui.js';

export default {
  name: 'cage',
  label: 'Cage (mean value / harmonic)',
  form: { coordinates: 'mean_value', resolution: 24, margin: 0.05 },

  createFields(p) {
    return [h('div', { class: 'row' }, h('label', {}, 'Coordinates'),
      h('select', { name: 'coordinates', title: 'How the cage moves the mesh: mean value (fast, exact at the cage) or harmonic (smoother, no negative weights; computed on a grid)', onchange: (e) => { p.coordinates = e.target.value; } },
        h('option', { value: 'mean_value', selected: p.coordinates === 'mean_value' }, 'Mean value'),
        h('option', { value: 'harmonic', selected: p.coordinates === 'harmonic' }, 'Harmonic (grid)'))),
    numberRow('cage', 'Grid cells', p, 'resolution', { min: 4, max: 96, step: 1, title: 'harmonic coordinates: grid cells along the longest side' }),
    numberRow('cage', 'Margin', p, 'margin', { min: 0, step: 0.01, title: 'Room between the mesh and the automatic cage, as a share of the model’s size' })];
  },

  createBody(p) {
    const body = { cage: 'auto', margin: p.margin, coordinates: p.coordinates };
    if (p.coordinates === 'harmonic') body.resolution = Math.max(4, Math.round(p.resolution));
    return body;
  },

  section(panel, s, c) {
    const ed = panel.ed;
    return h('section', {}, h('h3', {}, 'Cage'),
      h('div', { class: 'hint-text' }, `${c.count || 0} cage vertices, ${(c.triangles || []).length} triangles, `,
        c.coordinates === 'harmonic' ? 'harmonic coordinates. ' : 'mean value coordinates. ',
        'Drag a cage vertex to deform; load a rig with a cage file for a fitted cage.'),
      h('div', { class: 'row buttons' },
        h('button', { title: 'Select every control point (A)', onclick: () => ed.selectAll() }, 'Select all'),
        h('button', { 'data-need-sel': true, title: 'Select nothing (Esc)', onclick: () => ed.setSelection([]) }, 'Clear selection')));
  },
};
