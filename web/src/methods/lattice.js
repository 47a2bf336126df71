// Lattice FFD (Sederberg-Parry / B-spline, Hsu et al.) in the editor.

import * as THREE from 'three';
import { h } from '../dom.js';
import { levelColor } from '../palette.js';
import { resolutionRow, numberRow } from './ui.js';

// A nested rig (docs/lattice-variants.md): c.lattices lists the root, then
// each child depth-first ({first, count, depth, ...}); the lattice of control i.
function latticeOf(i, c) {
  const l = c.lattices || [];
  let k = 0;
  while (k + 1 < l.length && l[k + 1].first <= i) k++;
  return l[k];
}

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
    const kids = (c.lattices || []).slice(1);
    return h('section', {}, h('h3', {}, 'Lattice'),
      h('div', { class: 'hint-text' }, `${(c.resolution || []).join(' × ')} control points, ${c.basis === 'bernstein' ? 'Bernstein (Bézier)' : 'cubic B-spline'} basis. `,
        'Change the resolution or basis above and press Re-create.'),
      kids.length ? h('div', { class: 'hint-text' }, `${kids.length} child lattice${kids.length > 1 ? 's' : ''} (drawn by depth in their own colour; a child's points follow its parent, dragging one moves that child only): `,
        ...kids.map((l, k) => h('a', { href: '#', style: 'color:inherit', onclick: (e) => { e.preventDefault(); ed.setSelection(Array.from({ length: l.count }, (_, j) => l.first + j)); } },
          ` #${k + 1} ${l.resolution.join('×')} (depth ${l.depth})`))) : null,
      h('div', { class: 'row buttons' },
        h('button', { onclick: () => ed.selectAll() }, 'Select all'),
        h('button', { 'data-need-sel': true, onclick: () => ed.setSelection([]) }, 'Clear selection')));
  },

  view: {
    /** Children's points in the colour of their depth (the root's: the default). */
    pointColor(i, c) {
      const l = c.lattices && latticeOf(i, c);
      return l && l.depth > 0 ? new THREE.Color(levelColor(l.depth)) : null;
    },
    structureKey: (c) => (c.lattices || []).map((l) => l.count),
    /** The children's grid lines over the shared edges, in their depth's colour. */
    build(v, c) {
      const l = c.lattices || [];
      if (l.length < 2 || !c.edges) return;
      for (let depth = 1; l.some((x) => x.depth === depth); depth++) {
        const idx = [];
        for (const e of c.edges) if (latticeOf(e[0], c).depth === depth) idx.push(e[0], e[1]);
        const g = new THREE.BufferGeometry();
        g.setAttribute('position', v.positions);
        g.setIndex(idx);
        const lines = new THREE.LineSegments(g, new THREE.LineBasicMaterial({
          color: levelColor(depth), transparent: true, opacity: 0.8, depthTest: false,
        }));
        lines.frustumCulled = false;
        lines.renderOrder = 12;
        v.group.add(lines);
      }
    },
  },
};
