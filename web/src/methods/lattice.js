// Lattice FFD (Sederberg-Parry / B-spline, Hsu et al.) in the editor, with
// its variants (docs/lattice-variants.md): an interpolation per axis with
// tension and continuity, and cylindrical / spherical lattices.

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
const INTERPOLATIONS = [
  ['bspline', 'Cubic B-spline'], ['bernstein', 'Bernstein (Bézier)'], ['linear', 'Linear'],
  ['catmull-rom', 'Catmull-Rom'], ['cardinal', 'Cardinal (tension, continuity)'],
];
const COORDINATES = [['cartesian', 'Box (cartesian)'], ['cylindrical', 'Cylinder (r, θ, z)'], ['spherical', 'Sphere (r, θ, φ)']];
const AXES = { cartesian: ['x', 'y', 'z'], cylindrical: ['r', 'θ', 'z'], spherical: ['r', 'θ', 'φ'] };
const labelOf = (list, v) => (list.find(([k]) => k === v) || [v, v])[1];

/** The rig's "basis": one string when the axes agree, else an array of three. */
export const basisOf = (interp) => (interp.every((b) => b === interp[0]) ? interp[0] : [...interp]);

/** The lattice indices (i, j, k) of control id, k fastest (lattice_session.c), in its own lattice. */
function ijkOf(id, c) {
  const l = latticeOf(id, c) || { first: 0, resolution: c.resolution };
  const r = l.resolution || c.resolution;
  const local = id - (l.first || 0);
  return { l, r, i: Math.floor(local / (r[1] * r[2])), j: Math.floor(local / r[2]) % r[1], k: local % r[2] };
}

/** Every control of the lattices of `ids` whose indices satisfy keep(a, b) (a: a selected point's, b: the candidate's). */
function gridSelect(c, ids, keep) {
  const out = new Set();
  const byLattice = new Map();
  for (const id of ids) {
    const a = ijkOf(id, c);
    const key = a.l.first || 0;
    if (!byLattice.has(key)) byLattice.set(key, { l: a.l, r: a.r, picks: [] });
    byLattice.get(key).picks.push(a);
  }
  for (const { l, r, picks } of byLattice.values()) {
    const first = l.first || 0, n = r[0] * r[1] * r[2];
    for (let local = 0; local < n; local++) {
      const b = { i: Math.floor(local / (r[1] * r[2])), j: Math.floor(local / r[2]) % r[1], k: local % r[2] };
      if (picks.some((a) => keep(a, b))) out.add(first + local);
    }
  }
  return [...out];
}
const IDX = ['i', 'j', 'k'];

export default {
  name: 'lattice',
  label: 'Lattice (B-spline / Bernstein / linear / cardinal; box, cylinder, sphere)',
  form: {
    resolution: [5, 5, 5], basis: 'bspline', margin: 0.05,
    interp: ['bspline', 'bspline', 'bspline'], tension: 0, continuity: 0, coordinates: 'cartesian',
  },

  createFields(p) {
    if (!p.interp) p.interp = [p.basis, p.basis, p.basis];
    const axes = AXES[p.coordinates || 'cartesian'];
    return [resolutionRow('lattice', p),
      h('div', { class: 'row' }, h('label', {}, 'Lattice'),
        h('select', { name: 'coordinates', title: 'The lattice’s shape: a box, or a cylinder or sphere around the model (for bending round things)', onchange: (e) => { p.coordinates = e.target.value; } },
          COORDINATES.map(([v, t]) => h('option', { value: v, selected: p.coordinates === v }, t)))),
      h('div', { class: 'row' }, h('label', {}, 'Basis (all axes)'),
        h('select', {
          name: 'basis', title: 'How control points blend, on every axis: B-spline (smooth, local), Bernstein (smooth, global), linear, or Catmull-Rom / cardinal (through the points)',
          onchange: (e) => {
            p.basis = e.target.value;
            p.interp = [p.basis, p.basis, p.basis];
            const form = e.target.closest('section');
            if (form) form.querySelectorAll('select[name^="interp-"]').forEach((sel) => { sel.value = p.basis; });
          },
        }, INTERPOLATIONS.map(([v, t]) => h('option', { value: v, selected: basisOf(p.interp) === v }, t)))),
      ...[0, 1, 2].map((a) => h('div', { class: 'row' }, h('label', {}, `Interpolation ${axes[a]}`),
        h('select', {
          name: `interp-${a}`, title: `How control points blend along ${axes[a]}`,
          onchange: (e) => { p.interp[a] = e.target.value; p.basis = p.interp[0]; },
        }, INTERPOLATIONS.map(([v, t]) => h('option', { value: v, selected: p.interp[a] === v }, t))))),
      numberRow('lattice', 'Tension', p, 'tension', { min: -1, max: 0.99, step: 0.05, title: 'Cardinal axes: how tight the curve is through the points, from -1 (loose) to just under 1 (tight)' }),
      numberRow('lattice', 'Continuity', p, 'continuity', { min: -1, max: 1, step: 0.05, title: 'Cardinal axes: how sharp the curve turns at the points, from -1 (sharp) to 1 (round)' }),
      numberRow('lattice', 'Margin', p, 'margin', { min: 0, step: 0.01, title: 'Room between the mesh and the lattice, as a share of the model’s size' })];
  },

  createBody(p) {
    const interp = p.interp || [p.basis, p.basis, p.basis];
    const body = { resolution: p.resolution, basis: basisOf(interp), margin: p.margin };
    if (interp.includes('cardinal')) Object.assign(body, { tension: p.tension, continuity: p.continuity });
    if (p.coordinates && p.coordinates !== 'cartesian') Object.assign(body, { coordinates: p.coordinates, frame: 'auto' });
    return body;
  },

  section(panel, s, c) {
    const ed = panel.ed;
    const kids = (c.lattices || []).slice(1);
    const params = s.params || {};
    const coords = params.coordinates || 'cartesian';
    const interp = params.interpolation || [c.basis, c.basis, c.basis];
    const axes = AXES[coords] || AXES.cartesian;
    const perAxis = interp.map((b, a) => `${axes[a]}: ${labelOf(INTERPOLATIONS, b)}`).join(', ');
    return h('section', {}, h('h3', {}, 'Lattice'),
      h('div', { class: 'hint-text' }, `${(c.resolution || []).join(' × ')} control points, ${labelOf(COORDINATES, coords)}; ${perAxis}. `,
        'Change the resolution, lattice or interpolation above and press Re-create.'),
      kids.length ? h('div', { class: 'hint-text' }, `${kids.length} child lattice${kids.length > 1 ? 's' : ''} (drawn by depth in their own colour; a child's points follow its parent, dragging one moves that child only): `,
        ...kids.map((l, k) => h('a', { href: '#', style: 'color:inherit', onclick: (e) => { e.preventDefault(); ed.setSelection(Array.from({ length: l.count }, (_, j) => l.first + j)); } },
          ` #${k + 1} ${l.resolution.join('×')} (depth ${l.depth})`))) : null,
      h('div', { class: 'row buttons' },
        h('button', { title: 'Select every control point (A)', onclick: () => ed.selectAll() }, 'Select all'),
        h('button', { 'data-need-sel': true, title: 'Select nothing (Esc)', onclick: () => ed.setSelection([]) }, 'Clear selection')));
  },

  /** Selection helpers (select.js): axis 0, 1, 2 = the lattice's i, j, k (x, y, z for a box). */
  select: {
    /** The rows along `axis` through the selected points (the other two indices fixed). */
    row: (c, ids, axis) => gridSelect(c, ids, (a, b) => IDX.every((x, t) => t === axis || a[x] === b[x])),
    /** The layers of constant index `axis` through the selected points (a plane of the lattice). */
    layer: (c, ids, axis) => gridSelect(c, ids, (a, b) => a[IDX[axis]] === b[IDX[axis]]),
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
        v.addLines(g, levelColor(depth), 0.8, 12);
      }
    },
  },
};
