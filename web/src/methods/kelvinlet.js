// Kelvinlet brushes (de Goes & James 2017) in the editor: every brush drawn
// as a sphere of its radius at its center, the grab brushes' handles
// (center + displacement) dragged, new brushes placed by clicking the mesh.

import * as THREE from 'three';
import { h } from '../dom.js';
import { COL } from '../palette.js';
import { num, numberRow } from './ui.js';

const TYPES = ['grab', 'twist', 'scale', 'pinch'];

/** The body of a new brush of the form's type at point (and along the surface normal). */
function newBrush(f, point, normal, diag) {
  const b = { type: f.type, center: point.toArray(), radius: f.radius || 0.15 * diag };
  if (f.type === 'grab') b.displacement = [0, 0, 0];
  if (f.type === 'twist') { b.axis = normal.toArray(); b.angle = f.angle * Math.PI / 180; }
  if (f.type === 'scale') b.factor = f.factor;
  if (f.type === 'pinch') {
    // squeeze across the surface normal, stretch along it: n n^T - (I - n n^T) / 2, traceless
    const n = normal.toArray(), s = f.pinch;
    b.pinch = [0, 1, 2].map((i) => [0, 1, 2].map((j) => s * (1.5 * n[i] * n[j] - 0.5 * (i === j ? 1 : 0))));
  }
  return b;
}

export default {
  name: 'kelvinlet',
  label: 'Kelvinlet brushes',
  form: { poisson_ratio: 0.45, multiscale: 'single', brush: { type: 'grab', radius: 0, angle: 30, factor: 1.3, pinch: 0.3 } },

  createFields(p) {
    return [numberRow('kelvinlet', 'Poisson ratio', p, 'poisson_ratio', { min: 0, max: 0.5, step: 0.01, title: 'How the material keeps its volume: 0.5 like rubber (incompressible), lower: squashier' }),
      h('div', { class: 'row' }, h('label', {}, 'Falloff'),
        h('select', { name: 'multiscale', title: 'Falloff of the brushes: single, or a blend of two or three sizes for a longer tail', onchange: (e) => { p.multiscale = e.target.value; } },
          ['single', 'biscale', 'triscale'].map((m) => h('option', { value: m, selected: p.multiscale === m }, m)))),
      h('div', { class: 'hint-text' }, 'Starts without brushes: place them by clicking the mesh below.')];
  },

  createBody(p) { return { brushes: [], poisson_ratio: p.poisson_ratio, multiscale: p.multiscale }; },

  status(c) { return ` · ${(c.brushes || []).length} brushes`; },

  section(panel, s, c) {
    const ed = panel.ed;
    const f = panel.form.kelvinlet.brush;
    if (!f.radius) f.radius = +(0.15 * ed.vp.diag).toPrecision(3);
    const placing = ed.tool === 'addbrush';
    const brushes = c.brushes || [];
    return h('section', {}, h('h3', {}, 'Kelvinlet brushes'),
      h('div', { class: 'list' }, brushes.length ? brushes.map((b, i) => h('div', { class: 'item' },
        h('span', { class: 'name' },
          b.control !== undefined
            ? h('a', { href: '#', style: 'color:inherit', onclick: (e) => { e.preventDefault(); ed.setSelection([b.control]); } }, `#${i} ${b.type}`)
            : `#${i} ${b.type}`,
          h('span', { class: 'hint-text' }, ` r ${(+b.radius).toPrecision(3)}`)),
        h('button', { title: 'Remove this brush', class: 'danger', onclick: () => ed.run('brush', { remove: i }) }, '×'),
      )) : h('div', { class: 'item hint-text' }, 'No brushes')),
      h('div', { class: 'row' }, h('label', {}, 'New brush'),
        h('select', { name: 'brush-type', title: 'The kind of brush placed by the next click on the mesh', onchange: (e) => { f.type = e.target.value; } },
          TYPES.map((t) => h('option', { value: t, selected: f.type === t }, t))),
        h('input', { type: 'number', name: 'brush-radius', step: 'any', min: 0, value: f.radius, title: 'Radius of the new brush: how far it reaches', onchange: (e) => { f.radius = num(e.target.value, f.radius); } })),
      numberRow('kelvinlet-brush', 'Twist angle (°)', f, 'angle', { step: 5, title: 'Twist brushes: how far they turn the material about the surface normal' }),
      numberRow('kelvinlet-brush', 'Scale factor', f, 'factor', { min: 0.1, step: 0.05, title: 'Scale brushes: more than 1 swells, less than 1 shrinks' }),
      numberRow('kelvinlet-brush', 'Pinch', f, 'pinch', { step: 0.05, title: 'Pinch brushes: how strongly they pull the material together (negative: apart)' }),
      h('div', { class: 'row buttons' },
        h('button', { class: placing ? 'active' : '', title: 'Click the mesh to place a brush of the chosen kind there (Esc to stop)', onclick: () => ed.setTool(placing ? 'controls' : 'addbrush') },
          placing ? '⊕ Click the mesh…' : '⊕ Add brush')),
      h('div', { class: 'hint-text' }, 'Drag a grab brush\'s handle to pull the material; the material keeps its volume as the Poisson ratio nears 0.5.'),
    );
  },

  busy: { brush: 'Adding the brush…' },

  tools: {
    /** A brush of the form's type centred at the clicked surface point. */
    addbrush: {
      hint: 'Click the mesh to place a brush',
      async pick(ed, hit) {
        const f = ed.panel.form.kelvinlet.brush;
        const n = hit.normal.clone().normalize();
        const st = await ed.run('brush', { add: newBrush(f, hit.point.clone(), n, ed.vp.diag) });
        if (st) ed.setTool('controls');
      },
    },
  },

  view: {
    edgeColor: COL.skeletonEdge,
    edgeOpacity: 0.95,
    pointColor: () => COL.point,
    structureKey: (c) => (c.brushes || []).map((b) => [b.type, b.radius, ...b.center]),
    /** A wireframe sphere of each brush's radius at its center. */
    build(v, c) {
      const n = (c.brushes || []).length;
      if (!n) return;
      const sg = new THREE.SphereGeometry(1, 16, 10);
      const mat = new THREE.MeshBasicMaterial({
        wireframe: true, transparent: true, opacity: 0.12, depthWrite: false, color: COL.skeletonEdge,
      });
      const im = new THREE.InstancedMesh(sg, mat, n);
      im.frustumCulled = false;
      v.rois = im;
      v.group.add(im);
    },
    updateInstances(v, c) {
      if (!v.rois) return;
      const m = new THREE.Matrix4();
      (c.brushes || []).forEach((b, k) => {
        const r = b.radius || 0;
        m.makeScale(r, r, r).setPosition(b.center[0], b.center[1], b.center[2]);
        if (k < v.rois.count) v.rois.setMatrixAt(k, m);
      });
      v.rois.instanceMatrix.needsUpdate = true;
    },
  },
};
