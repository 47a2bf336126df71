// T-spline FFD with a proxy (Zhang et al.) in the editor: the proxy drawn
// over the T-lattice, ARAP drags, refinement, frozen points.

import * as THREE from 'three';
import { h, fmtInt } from '../dom.js';
import { COL } from '../palette.js';
import { num, resolutionRow, numberRow } from './ui.js';

export default {
  name: 'tspline',
  label: 'T-spline (proxy)',
  form: { resolution: [6, 6, 6], padding: 0, refine: { kind: 'cell', ratio: 0.5 } },

  createFields(p) { return [resolutionRow('tspline', p), numberRow('tspline', 'Padding', p, 'padding', { min: 0, step: 0.01 })]; },

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
        `${fmtInt(c.count)} points · ${fmtInt(c.cells ?? 0)} cells · ${fmtInt(c.faces ?? 0)} faces · ${fmtInt(c.edges_count ?? 0)} edges · ${c.refinements ?? 0} refinements`
        + (c.max_weight_deviation !== undefined ? ` · max weight dev. ${(+c.max_weight_deviation).toExponential(1)}` : '')),
      h('div', { class: 'row' },
        h('label', { class: 'check' }, h('input', { type: 'checkbox', name: 'full-lattice', checked: ed.controlsView.showLattice, onchange: (e) => ed.setShowLattice(e.target.checked) }), 'Show full T-lattice')),
      h('div', { class: 'row' },
        h('label', { class: 'check', title: 'Dragged points are ARAP handles (§3.4); off: they move alone' },
          h('input', { type: 'checkbox', name: 'arap', checked: ed.opts.arap, onchange: (e) => { ed.opts.arap = e.target.checked; } }), 'ARAP drag (selection = handles)')),
      h('div', { class: 'hint-text' }, 'Refine at the selection’s centroid (rest space):'),
      h('div', { class: 'row buttons' },
        h('button', { 'data-need-sel': true, onclick: () => near('cell') }, 'Cell'),
        h('button', { 'data-need-sel': true, onclick: () => near('face') }, 'Face'),
        h('button', { 'data-need-sel': true, onclick: () => near('edge') }, 'Edge'),
        h('input', { type: 'number', name: 'edge-ratio', class: 'narrow', min: 0.05, max: 0.95, step: 0.05, value: f.ratio, title: 'edge split ratio', onchange: (e) => { f.ratio = num(e.target.value, 0.5); } })),
      h('div', { class: 'row' },
        h('select', { name: 'refine-kind', onchange: (e) => { f.kind = e.target.value; } },
          ['cell', 'face', 'edge'].map((k) => h('option', { value: k, selected: f.kind === k }, k))),
        h('button', { class: refining ? 'active' : '', style: 'flex:1', onclick: () => ed.setTool(refining ? 'controls' : 'refine') },
          refining ? 'Click the mesh…' : 'Refine at a mesh point')),
      h('div', { class: 'row buttons' },
        h('button', { onclick: () => ed.run('refine', { insertions: [{ cells: 'proxy' }] }, { label: 'Refining…' }) }, 'Refine all proxy cells')),
      h('div', { class: 'row buttons' },
        h('button', { 'data-need-sel': true, onclick: () => ed.run('freeze', { points: ed.selection, frozen: true }) }, '❄ Freeze'),
        h('button', { 'data-need-sel': true, onclick: () => ed.run('freeze', { points: ed.selection, frozen: false }) }, 'Unfreeze')),
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
