// PB-FFD (McDonnell & Qin: ellipsoidal basis functions) in the editor:
// levels, frames, curves; EBF ellipsoids drawn at the controls.

import * as THREE from 'three';
import { h } from '../dom.js';
import { COL, levelColor } from '../palette.js';
import { num, numberRow } from './ui.js';

const AXES = { x: [1, 0, 0], y: [0, 1, 0], z: [0, 0, 1] };

/** Selection helpers (select.js): "all of this level" = every EBF drawn (the
 * state lists the current level's EBFs, then the curve points). */
const SELECT = {
  level: (c) => Array.from({ length: (c.ebfs || []).length }, (_, i) => i),
  curves: (c) => Array.from({ length: Math.max(0, (c.count || 0) - (c.ebfs || []).length) }, (_, k) => (c.ebfs || []).length + k),
};

export default {
  name: 'pbffd',
  label: 'PB-FFD (ellipsoidal basis)',
  form: { interior: 60, exterior: 60, levels: 1, sigma: 3, curve: { radius: 0, samples: 32 }, frame: { axis: 'z', angle: 15, scale: [1.2, 1, 1] } },

  createFields(p) {
    return [numberRow('pbffd', 'Interior', p, 'interior', { min: 0, step: 1, title: 'Control points placed inside the model' }), numberRow('pbffd', 'Exterior', p, 'exterior', { min: 0, step: 1, title: 'Control points placed around the model' }),
      numberRow('pbffd', 'Levels', p, 'levels', { min: 1, max: 8, step: 1, title: 'Coarse-to-fine levels of control points (edit one level at a time)' }), numberRow('pbffd', 'Sigma', p, 'sigma', { min: 0, step: 0.1, title: 'How far each control point reaches: larger = smoother, wider moves' }),
      h('div', { class: 'hint-text' }, 'Automatic placement of EBF control points (interior / exterior counts), then binding.')];
  },

  createBody(p) { return { controls: { interior: p.interior, exterior: p.exterior }, levels: p.levels, sigma: p.sigma }; },

  status(c) { return c.level !== undefined ? ` · level <b>${c.level}</b>` : ''; },

  section(panel, s, c) {
    const ed = panel.ed;
    const f = panel.form.pbffd;
    const levels = Math.max(1, c.levels || 1);
    const drawing = ed.tool === 'curve';
    if (!f.curve.radius) f.curve.radius = +(0.15 * ed.vp.diag).toPrecision(3);
    return h('section', {}, h('h3', {}, 'PB-FFD'),
      h('div', { class: 'row' }, h('label', {}, 'Level'),
        h('select', {
          name: 'level', title: 'The level of control points shown and edited (0: coarsest)', onchange: (e) => ed.run('level', { level: Number(e.target.value) }),
        }, Array.from({ length: levels }, (_, k) => h('option', { value: k, selected: k === (c.level || 0) }, `Level ${k}`))),
        h('span', { class: 'swatch', style: `background:#${levelColor(c.level || 0).toString(16).padStart(6, '0')}` }),
        h('span', { class: 'hint-text', title: 'EBFs: the ellipsoidal control points of PB-FFD, each moving the mesh inside its region' }, `${(c.ebfs || []).length} control points (EBFs)`)),
      h('div', { class: 'row buttons' },
        h('button', { onclick: () => ed.setSelection(SELECT.level(c)), title: 'Select every EBF of the level shown (its ROIs are drawn)' }, 'Select level'),
        h('button', { disabled: !(c.curves || []).length, onclick: () => ed.setSelection(SELECT.curves(c)), title: 'Select every curve point (the squares)' }, 'Select curve points')),
      h('div', { class: 'hint-text' }, 'Turn or stretch the regions of the selected control points (a twist, a stretch):'),
      h('div', { class: 'row' }, h('label', {}, 'Rotate'),
        h('select', { name: 'frame-axis', title: 'The axis the selected EBFs’ regions turn about', onchange: (e) => { f.frame.axis = e.target.value; } },
          ['x', 'y', 'z'].map((a) => h('option', { value: a, selected: f.frame.axis === a }, a.toUpperCase()))),
        h('input', { type: 'number', name: 'frame-angle', value: f.frame.angle, step: 5, title: 'Turn angle in degrees', onchange: (e) => { f.frame.angle = num(e.target.value, 15); } }),
        h('span', { class: 'hint-text' }, '°'),
        h('button', {
          'data-need-sel': true, title: 'Turn the selected EBFs’ regions (a twist)',
          onclick: () => ed.run('frame', { points: ed.selection, axis: AXES[f.frame.axis], angle: f.frame.angle * Math.PI / 180 }),
        }, 'Apply')),
      h('div', { class: 'row' }, h('label', {}, 'Scale'),
        [0, 1, 2].map((i) => h('input', {
          type: 'number', class: 'narrow', step: 0.1, value: f.frame.scale[i], name: `frame-scale-${i}`, title: `Stretch of the regions along their ${['first', 'second', 'third'][i]} axis (1: unchanged)`,
          onchange: (e) => { f.frame.scale[i] = num(e.target.value, 1); },
        })),
        h('button', { 'data-need-sel': true, title: 'Stretch the selected EBFs’ regions', onclick: () => ed.run('frame', { points: ed.selection, scale: f.frame.scale }) }, 'Apply')),
      h('div', { class: 'hint-text' }, `Deformation curves: ${(c.curves || []).length} — draw one on the mesh, then drag its points`),
      h('div', { class: 'row' }, h('label', {}, 'Radius'),
        h('input', { type: 'number', name: 'curve-radius', step: 'any', min: 0, title: 'How far a new curve reaches around it', value: f.curve.radius, onchange: (e) => { f.curve.radius = num(e.target.value, f.curve.radius); } }),
        h('label', { style: 'min-width:0' }, 'Samples'),
        h('input', { type: 'number', name: 'curve-samples', class: 'narrow', min: 2, step: 1, title: 'Points along a new curve', value: f.curve.samples, onchange: (e) => { f.curve.samples = Math.round(num(e.target.value, 32)); } })),
      h('div', { class: 'row buttons' },
        h('button', { class: drawing ? 'active' : '', onclick: () => ed.setTool(drawing ? 'controls' : 'curve'), title: 'Click points on the mesh, Enter to create' },
          drawing ? `✎ Drawing… (${ed.sketch.length} pts)` : '✎ Draw curve'),
        drawing ? h('button', { class: 'primary', title: 'Create the curve through the clicked points (Enter)', disabled: ed.sketch.length < 2, onclick: () => ed.finishTool() }, 'Create ⏎') : null),
    );
  },

  busy: { curve: 'Binding curve…' },

  select: SELECT,

  tools: {
    /** A Catmull-Rom curve through points clicked on the mesh (§3.5). */
    curve: {
      hint: 'Draw curve: click points on the mesh · Enter creates · Esc cancels',
      sketch: true,
      pick(ed, hit) { ed.addSketchPoint(hit.point); },
      async finish(ed) {
        if (ed.sketch.length < 2) { ed.info('A curve needs at least two points.'); return; }
        const f = ed.panel.form.pbffd.curve;
        const body = { points: ed.sketch.map((p) => p.toArray()), radius: f.radius, samples: f.samples };
        const st = await ed.run('curve', body);
        if (st) { ed.clearSketch(); ed.setTool('controls'); }
      },
    },
  },

  view: {
    /** EBFs of the level drawn; then curve points. */
    pointColor(i, c) {
      const nEbf = (c.ebfs || []).length;
      if (i >= nEbf) return COL.curve;
      if (c.ebfs[i] && c.ebfs[i].enabled === false) return COL.disabled;
      return COL.ebf;
    },
    /** EBFs are discs, curve points squares (a curve is not an EBF). */
    pointShape: (i, c) => (i >= (c.ebfs || []).length ? 'square' : 'disc'),
    structureKey: (c) => [c.level, (c.ebfs || []).length, (c.curves || []).length],
    /** One wireframe ellipsoid per EBF (its ROI), shown with "ROIs / radii": by
     * default only the selected and hovered EBFs' (120 ellipsoids bury the
     * model), every one with "All ROIs". */
    build(v, c) {
      const ebfs = c.ebfs || [];
      if (!ebfs.length) return;
      const sg = new THREE.SphereGeometry(1, 16, 10);
      const mat = new THREE.MeshBasicMaterial({
        wireframe: true, transparent: true, opacity: 0.16, depthWrite: false, color: 0xffffff,
      });
      const im = new THREE.InstancedMesh(sg, mat, ebfs.length);
      im.frustumCulled = false;
      im.renderOrder = 6;
      for (let i = 0; i < ebfs.length; i++) im.setColorAt(i, COL.disabled);
      im.count = 0;
      v.rois = im;
      v.group.add(im);
    },
    updateInstances(v, c, p) {
      if (!v.rois) return;
      const m = new THREE.Matrix4();
      const a = new THREE.Vector3(), b = new THREE.Vector3(), d = new THREE.Vector3();
      const ebfs = c.ebfs || [];
      const col = new THREE.Color(levelColor(c.level || 0));
      const ids = v.roiIds(Math.min(ebfs.length, v.rois.instanceMatrix.count));
      v.rois.count = ids.length;
      ids.forEach((i, slot) => {
        const e = ebfs[i];
        const r = e.radius || [1, 1, 1];
        const f = e.frame || [[1, 0, 0], [0, 1, 0], [0, 0, 1]];
        a.fromArray(f[0]).multiplyScalar(r[0]);
        b.fromArray(f[1]).multiplyScalar(r[1]);
        d.fromArray(f[2]).multiplyScalar(r[2]);
        m.makeBasis(a, b, d).setPosition(p[3 * i], p[3 * i + 1], p[3 * i + 2]);
        v.rois.setMatrixAt(slot, m);
        v.rois.setColorAt(slot, e.enabled === false ? COL.disabled : col);
      });
      v.rois.instanceMatrix.needsUpdate = true;
      if (v.rois.instanceColor) v.rois.instanceColor.needsUpdate = true;
    },
  },
};
