// T-spline FFD with a proxy (Zhang et al.) in the editor: the proxy drawn
// over the T-lattice, ARAP drags, refinement, frozen points.

import * as THREE from 'three';
import { h, fmtInt } from '../dom.js';
import { details } from './ui.js';
import { COL } from '../palette.js';
import { num, resolutionRow, numberRow } from './ui.js';

export default {
  name: 'tspline',
  label: 'T-spline (proxy)',
  form: { resolution: [6, 6, 6], padding: 0, refine: { kind: 'cell', ratio: 0.5 } },

  createFields(p) { return [resolutionRow('tspline', p), numberRow('tspline', 'Padding', p, 'padding', { min: 0, step: 0.01, title: 'Room between the mesh and the T-spline volume, as a share of the model’s size' })]; },

  createBody(p) { return { resolution: p.resolution, padding: p.padding }; },

  /** Dragged points are ARAP handles (§3.4) unless the panel turns it off. */
  dragBody(ed, body) { if (!ed.opts.arap) body.arap = false; },

  section(panel, s, c) {
    const ed = panel.ed;
    const f = panel.form.tspline.refine;
    const frozen = new Set(c.frozen || []);
    const refining = ed.tool === 'refine';
    const near = (kind) => {
      const p = ed.controlsView.centroid(ed.selection).toArray();
      const ins = { [kind]: { near: p } };
      if (kind === 'edge') ins.ratio = f.ratio;
      return ed.run('refine', { insertions: [ins] }, { label: 'Refining…' });
    };
    return h('section', {}, h('h3', {}, 'T-spline'),
      h('div', { class: 'hint-text' },
        `${fmtInt(c.count)} control points`
        + (c.refinements ? `, detail added ${c.refinements === 1 ? 'once' : `${c.refinements} times`}` : ', not refined yet')
        + (+c.max_weight_deviation > 1e-9 ? '; refining has made the lattice rational (see Details)' : '.')),
      details([
        ['Cells', fmtInt(c.cells ?? 0), 'Boxes of the T-lattice (each refinement splits some)'],
        ['Faces', fmtInt(c.faces ?? 0), 'Faces between the cells'],
        ['Edges', fmtInt(c.edges_count ?? 0), 'Lines of the full T-lattice'],
        ['Refinements', String(c.refinements ?? 0), 'How many times detail was added (cell, face or edge splits)'],
        c.max_weight_deviation !== undefined ? ['Max weight deviation', (+c.max_weight_deviation).toExponential(1),
          'How far the control points’ weights have drifted from 1 through refinements (0: a plain, polynomial T-spline; more: a rational one). The shape at rest does not change either way.'] : null,
      ]),
      h('div', { class: 'row' },
        h('label', { class: 'check', title: 'Draw every point and line of the T-lattice instead of the simpler proxy cage' }, h('input', { type: 'checkbox', name: 'full-lattice', checked: ed.controlsView.showLattice, onchange: (e) => ed.setShowLattice(e.target.checked) }), 'Show full T-lattice')),
      h('div', { class: 'row' },
        h('label', { class: 'check', title: 'On: the points you drag pull the rest of the lattice along, keeping its shape as rigid as possible (ARAP, §3.4 of the paper). Off: only the dragged points move.' },
          h('input', { type: 'checkbox', name: 'arap', checked: ed.opts.arap, onchange: (e) => { ed.opts.arap = e.target.checked; } }), 'Drag keeps the shape (ARAP)')),
      h('div', { class: 'hint-text' }, 'Add detail where the selected points are:'),
      h('div', { class: 'row buttons' },
        h('button', { 'data-need-sel': true, title: 'Split the lattice cell at the selection’s centre into smaller cells', onclick: () => near('cell') }, 'Cell'),
        h('button', { 'data-need-sel': true, title: 'Split the lattice face nearest the selection’s centre', onclick: () => near('face') }, 'Face'),
        h('button', { 'data-need-sel': true, title: 'Split the lattice edge nearest the selection’s centre at the ratio on the right', onclick: () => near('edge') }, 'Edge'),
        h('input', { type: 'number', name: 'edge-ratio', class: 'narrow', min: 0.05, max: 0.95, step: 0.05, value: f.ratio, title: 'Where an edge is split: 0.5 in the middle, 0.25 a quarter along it', onchange: (e) => { f.ratio = num(e.target.value, 0.5); } })),
      h('div', { class: 'row' },
        h('select', { name: 'refine-kind', title: 'What a click on the mesh splits: the cell, face or edge there', onchange: (e) => { f.kind = e.target.value; } },
          ['cell', 'face', 'edge'].map((k) => h('option', { value: k, selected: f.kind === k }, k))),
        h('button', { class: refining ? 'active' : '', style: 'flex:1', title: 'Click the mesh where you want more detail (Esc to stop)', onclick: () => ed.setTool(refining ? 'controls' : 'refine') },
          refining ? 'Click the mesh…' : 'Refine at a mesh point')),
      h('div', { class: 'row buttons' },
        h('button', { title: 'Split every cell of the proxy cage once: finer control everywhere', onclick: () => ed.run('refine', { insertions: [{ cells: 'proxy' }] }, { label: 'Refining…' }) }, 'Refine all proxy cells')),
      h('div', { class: 'row buttons' },
        h('button', { 'data-need-sel': true, title: 'Frozen points stay where they are when you drag others', onclick: () => ed.run('freeze', { points: ed.selection, frozen: true }) }, '❄ Freeze'),
        h('button', { 'data-need-sel': true, title: 'Let the selected points follow drags again', onclick: () => ed.run('freeze', { points: ed.selection, frozen: false }) }, 'Unfreeze')),
      h('div', { class: 'hint-text' }, `${frozen.size} frozen`),
    );
  },

  busy: { refine: 'Refining…' },

  tools: {
    /** Refines the element (cell, face or edge) at the clicked point's rest position. */
    refine: {
      hint: 'Click the mesh to refine the element there',
      async pick(ed, hit) {
        const f = ed.panel.form.tspline.refine;
        const ins = { [f.kind]: { near: hit.restPoint.toArray() } };
        if (f.kind === 'edge') ins.ratio = f.ratio;
        await ed.run('refine', { insertions: [ins] });
      },
    },
  },

  view: {
    structureKey: (c) => [c.proxy ? [c.proxy.faces.length, c.proxy.points.length] : null, c.refinements, c.cells],
    /** The proxy: translucent faces and its edges, over the control points. */
    build(v, c) {
      const faces = (c.proxy && c.proxy.faces) || [];
      const tri = [];
      const pe = [];
      for (const f of faces) {
        for (let i = 1; i + 1 < f.length; i++) tri.push(f[0], f[i], f[i + 1]);
        for (let i = 0; i < f.length; i++) pe.push(f[i], f[(i + 1) % f.length]);
      }
      const fg = new THREE.BufferGeometry();
      fg.setAttribute('position', v.positions);
      fg.setIndex(tri);
      const mesh = new THREE.Mesh(fg, new THREE.MeshBasicMaterial({
        color: COL.proxy, transparent: true, opacity: 0.16, side: THREE.DoubleSide, depthWrite: false,
      }));
      mesh.frustumCulled = false;
      mesh.renderOrder = 5;
      const eg = new THREE.BufferGeometry();
      eg.setAttribute('position', v.positions);
      eg.setIndex(pe);
      v.group.add(mesh);
      const edges = v.addLines(eg, 0x7fb0ff, 0.85, 11);
      v.proxy = [mesh, edges];
    },
    /** Only the proxy's points, unless the full T-lattice is shown. */
    visible(v, c, mask) {
      if (v.showLattice || !c.proxy || !c.proxy.points) return false;
      for (const id of c.proxy.points) if (id < mask.length) mask[id] = 1;
      return true;
    },
    updateVisibility(v) {
      if (v.edges) v.edges.visible = v.showLattice;
      for (const o of v.proxy || []) o.visible = !v.showLattice;
    },
  },
};
