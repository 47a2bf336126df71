// GFFD (Qin et al.: skeleton primitives) in the editor: the skeleton's
// primitives, point primitives placed on the mesh, radii drawn as spheres.

import * as THREE from 'three';
import { h, fmtInt } from '../dom.js';
import { COL } from '../palette.js';
import { num } from './ui.js';

const range = (o, n) => Array.from({ length: n }, (_, i) => o + i);

export default {
  name: 'gffd',
  label: 'GFFD (skeleton)',
  rigidDrags: true, // a moved primitive keeps its turn: the session's translate edit (docs/editor.md drag_begin)
  form: { unit: '', point: { radius: 0, offset: 0.05 } },

  createFields(p) {
    return [h('div', { class: 'row' }, h('label', {}, 'Unit'),
      h('input', { type: 'text', value: p.unit, placeholder: 'auto', name: 'gffd-unit', style: 'width:70px', title: 'The field’s length unit (empty: automatic, from the model’s size)', onchange: (e) => { p.unit = e.target.value; } })),
    h('div', { class: 'hint-text' }, 'Starts with one polyline along the longest axis; edit the skeleton below.')];
  },

  createBody(p) {
    const body = {};
    if (p.unit !== '' && Number.isFinite(Number(p.unit))) body.unit = Number(p.unit);
    return body;
  },

  section(panel, s, c) {
    const ed = panel.ed;
    const f = panel.form.gffd.point;
    const prims = c.primitives || [];
    if (!f.radius) f.radius = +(0.15 * ed.vp.diag).toPrecision(3);
    const placing = ed.tool === 'addpoint';
    const selPrims = new Set();
    prims.forEach((p, i) => { for (const id of ed.selection) if (id >= p.offset && id < p.offset + p.count) selPrims.add(i); });
    return h('section', {}, h('h3', {}, 'GFFD skeleton'),
      h('div', { class: 'list' }, prims.length ? prims.map((p, i) => h('div', { class: `item${selPrims.has(i) ? ' sel' : ''}` },
        h('span', { class: 'name', title: `controls ${p.offset}..${p.offset + p.count - 1}` },
          h('a', { href: '#', style: 'color:inherit', onclick: (e) => { e.preventDefault(); ed.setSelection(range(p.offset, p.count)); } }, `#${i} ${p.type}`),
          h('span', { class: 'hint-text' }, ` ${p.count} pt${p.count === 1 ? '' : 's'}`)),
        h('input', {
          type: 'number', name: `prim-radius-${i}`, step: 'any', min: 0, value: +(+p.radius).toPrecision(4), title: 'How far this primitive’s influence reaches',
          onchange: (e) => ed.run('primitive', { radius: num(e.target.value, p.radius), index: i }),
        }),
        h('button', { title: 'Remove this primitive', class: 'danger', onclick: () => ed.run('primitive', { remove: i }) }, '×'),
      )) : h('div', { class: 'item hint-text' }, 'No primitives')),
      h('div', { class: 'row' }, h('label', {}, 'New point'),
        h('input', { type: 'number', name: 'point-radius', step: 'any', min: 0, value: f.radius, title: 'How far the new point primitive’s influence reaches', onchange: (e) => { f.radius = num(e.target.value, f.radius); } }),
        h('label', { style: 'min-width:0' }, 'offset'),
        h('input', { type: 'number', name: 'point-offset', class: 'narrow', step: 0.01, value: f.offset, title: 'offset from the surface along its normal (fraction of the diagonal; negative: inside)', onchange: (e) => { f.offset = num(e.target.value, 0.05); } })),
      h('div', { class: 'row buttons' },
        h('button', { class: placing ? 'active' : '', title: 'Click the mesh to add a point primitive there (Esc to stop)', onclick: () => ed.setTool(placing ? 'controls' : 'addpoint') },
          placing ? '⊕ Click the mesh…' : '⊕ Add point primitive')),
      h('div', { class: 'hint-text' }, `${fmtInt(c.influenced || 0)} vertices influenced. Select skeleton vertices and use the gizmo to bend.`),
    );
  },

  busy: { primitive: 'Re-binding skeleton…' },

  tools: {
    /** A point primitive at the clicked surface point, offset along its normal. */
    addpoint: {
      hint: 'Click the mesh to place a point primitive',
      async pick(ed, hit) {
        const f = ed.panel.form.gffd.point;
        const n = hit.normal.clone().normalize();
        const pos = hit.point.clone().addScaledVector(n, f.offset * ed.vp.diag);
        const st = await ed.run('primitive', { add: { type: 'point', position: pos.toArray(), radius: f.radius } });
        if (st) ed.setTool('controls');
      },
    },
  },

  view: {
    edgeColor: COL.skeletonEdge,
    edgeOpacity: 0.95,
    pointColor: () => COL.skeleton,
    structureKey: (c) => (c.primitives || []).map((p) => [p.offset, p.count]),
    /** A wireframe sphere of the primitive's radius at each skeleton vertex. */
    build(v, c) {
      const n = (c.primitives || []).reduce((s, p) => s + (p.count || 0), 0);
      if (!n) return;
      const sg = new THREE.SphereGeometry(1, 12, 8);
      const mat = new THREE.MeshBasicMaterial({
        wireframe: true, transparent: true, opacity: 0.05, depthWrite: false, color: COL.skeletonEdge,
      });
      const im = new THREE.InstancedMesh(sg, mat, n);
      im.frustumCulled = false;
      v.rois = im;
      v.group.add(im);
    },
    updateInstances(v, c, p) {
      if (!v.rois) return;
      const m = new THREE.Matrix4();
      let k = 0;
      for (const pr of c.primitives || []) {
        for (let j = 0; j < pr.count; j++) {
          const id = pr.offset + j;
          const r = pr.radius || 0;
          m.makeScale(r, r, r).setPosition(p[3 * id], p[3 * id + 1], p[3 * id + 2]);
          if (k < v.rois.count) v.rois.setMatrixAt(k++, m);
        }
      }
      v.rois.instanceMatrix.needsUpdate = true;
    },
  },
};
