// The panel's Transform section: the selection's location (its median, or a
// single control's exact coordinates) as editable numbers, rotate-by and
// scale-by fields applied about the pivot, and the transform settings the
// modal G / R / S use (pivot, orientation, mirror, snapping, proportional
// editing, the 3D cursor). Each edit is one `move` request: one undo step.

import * as THREE from 'three';
import { h } from './dom.js';
import { PIVOTS, ORIENTATIONS } from './transform.js';

const AXES = ['X', 'Y', 'Z'];

/** The shortest decimal that reads back as the same float32 (a control's exact coordinate as drawn). */
export function f32Text(v) {
  for (let p = 6; p <= 9; p++) { const t = +v.toPrecision(p); if (Math.fround(t) === v) return String(t); }
  return String(v);
}

export class NumericPanel {
  constructor(tool) {
    this.tool = tool;
    this.ed = tool.ed;
    this.el = h('section', { class: 'transform-panel' });
    this.key = '';
    // the values follow drags and every state change; cheap when nothing changed
    setInterval(() => this.refresh(), 200);
  }

  /** The section element (the panel re-appends it on every render). */
  section() { this.refresh(true); return this.el; }

  refresh(force = false) {
    const ed = this.ed;
    const cv = ed.controlsView;
    const sel = ed.selection;
    const P = cv.positions && cv.count ? cv.positions.array : null;
    const pos = sel.length && P ? sel.slice(0, 64).map((id) => [P[3 * id], P[3 * id + 1], P[3 * id + 2]]) : [];
    const key = JSON.stringify([sel, pos, this.tool.opt, this.tool.cursor && this.tool.cursor.toArray(), ed.state && ed.state.method, !!ed.activeDrag]);
    if (!force && key === this.key) return;
    // keep what the user is typing
    if (!force && this.el.contains(document.activeElement) && document.activeElement.tagName === 'INPUT') return;
    this.key = key;
    this.el.replaceChildren(...this.content());
  }

  /** The selection's location: a single control's float32 position, or the median (float64 of them). */
  location() {
    const ed = this.ed;
    const cv = ed.controlsView;
    const sel = ed.selection;
    if (!sel.length || !cv.positions) return null;
    const P = cv.positions.array;
    if (sel.length === 1) return [0, 1, 2].map((a) => P[3 * sel[0] + a]);
    const m = [0, 0, 0];
    for (const id of sel) for (let a = 0; a < 3; a++) m[a] += P[3 * id + a];
    return m.map((x) => x / sel.length);
  }

  content() {
    const ed = this.ed;
    const tool = this.tool;
    const o = tool.opt;
    const s = ed.state || {};
    const sel = ed.selection;
    const out = [h('h3', {}, 'Transform')];
    if (!s.method) {
      out.push(h('div', { class: 'hint-text' }, 'Create a deformer, select control points, then G / R / S or the fields below.'));
    } else if (!sel.length) {
      out.push(h('div', { class: 'hint-text' }, 'Select control points: G move, R rotate, S scale (then X/Y/Z, a number, Enter), or type their location here.'));
    } else {
      const loc = this.location();
      const single = sel.length === 1;
      out.push(h('div', { class: 'row tf-caption' },
        h('b', {}, single ? `Control ${sel[0]}` : `Median of ${sel.length}`),
        h('span', { class: 'hint-text' }, single ? 'exact position' : `active: ${sel[sel.length - 1]}`)));
      out.push(...AXES.map((ax, a) => h('div', { class: 'row tf-fields' }, h('label', { class: 'tf-field' }, h('span', { class: 'tf-label' }, h('span', { class: `ax ax-${ax}` }, ax), ' location'),
        h('input', {
          type: 'number', step: 'any', name: `tf-loc-${ax.toLowerCase()}`, value: single ? f32Text(loc[a]) : String(+loc[a].toFixed(5)),
          title: `${single ? 'The control point\'s' : 'The selection\'s median'} ${ax} coordinate: type a value to move the selection there along ${ax} (one undo step)`,
          onchange: (e) => this.moveTo(a, e.target, loc[a]),
        })))));
      out.push(h('div', { class: 'row tf-fields' }, h('span', { class: 'tf-label', title: `Rotate the selection by degrees about the ${o.orientation} axis through the pivot (${o.pivot})` }, 'Rotate °'),
        AXES.map((ax, a) => h('label', { class: 'tf-field' }, h('span', { class: `ax ax-${ax}` }, ax),
          h('input', {
            type: 'number', step: 'any', name: `tf-rot-${ax.toLowerCase()}`, value: '0',
            title: `Degrees to rotate the selection about ${o.orientation === 'local' ? 'the local' : 'the'} ${ax} axis through the pivot, counter-clockwise looking down the axis (one undo step)`,
            onchange: (e) => this.rotate(a, e.target),
          })))));
      out.push(h('div', { class: 'row tf-fields' }, h('span', { class: 'tf-label', title: 'Scale the selection about the pivot' }, 'Scale ×'),
        AXES.map((ax, a) => h('label', { class: 'tf-field' }, h('span', { class: `ax ax-${ax}` }, ax),
          h('input', {
            type: 'number', step: 'any', name: `tf-scale-${ax.toLowerCase()}`, value: '1',
            title: `Factor to scale the selection by along ${o.orientation === 'local' ? 'the local' : 'the'} ${ax} axis, about the pivot (one undo step)`,
            onchange: (e) => this.scale([a], e.target),
          }))),
        h('label', { class: 'tf-field' }, h('span', { class: 'ax' }, 'all'),
          h('input', {
            type: 'number', step: 'any', name: 'tf-scale-all', value: '1',
            title: 'Factor to scale the selection by along every axis, about the pivot (one undo step)',
            onchange: (e) => this.scale([0, 1, 2], e.target),
          }))));
    }
    const select = (name, value, options, title, onchange) => h('select', { name, title, onchange: (e) => onchange(e.target.value) },
      options.map(([v, label, tip]) => h('option', { value: v, selected: v === value, title: tip || '' }, label)));
    const check = (name, on, label, title, onchange) => h('label', { class: 'check', title },
      h('input', { type: 'checkbox', name, checked: on, onchange: (e) => onchange(e.target.checked) }), label);
    const number = (name, value, title, onchange) => h('input', {
      type: 'number', step: 'any', min: '0', name, value: String(+value.toPrecision(4)), title, class: 'tf-num',
      onchange: (e) => { const v = parseFloat(e.target.value); if (v > 0 && Number.isFinite(v)) onchange(v); else { ed.error(new Error(`${title.split(':')[0]}: expected a positive number, got "${e.target.value}"`)); this.refresh(true); } },
    });
    const pivots = PIVOTS;
    const orients = ORIENTATIONS;
    out.push(h('div', { class: 'row' }, h('span', { class: 'tf-label' }, 'Pivot'),
      select('tf-pivot', o.pivot, pivots, 'The point rotations and scales turn about: ' + pivots.map((p) => `${p[1]}: ${p[2]}`).join('; '), (v) => { tool.setOption('pivot', v); tool.drawCursor(); })));
    out.push(h('div', { class: 'row' }, h('span', { class: 'tf-label' }, 'Orientation'),
      select('tf-orientation', o.orientation, orients, 'The axes X / Y / Z constrain to and the fields use: ' + orients.map((p) => `${p[1]}: ${p[2]}`).join('; '), (v) => tool.setOption('orientation', v))));
    out.push(h('div', { class: 'row' },
      check('tf-mirror', o.mirror, 'Mirror', 'Mirror editing: moving a control point also moves its counterpart on the other side of the plane through the mesh\'s centre, mirrored (a point on the plane stays on it)', (v) => tool.setOption('mirror', v)),
      select('tf-mirror-axis', String(o.mirrorAxis), AXES.map((ax, a) => [String(a), `${ax} plane`, `Mirror across the plane normal to ${ax}`]), 'The mirror plane: normal to this axis, through the mesh\'s centre', (v) => tool.setOption('mirrorAxis', +v))));
    out.push(h('div', { class: 'row' },
      check('tf-snap', o.snap, 'Snap', 'Snapping while transforming (hold Ctrl during a transform to toggle it): moves in steps of the increment, or the pivot onto the grid; rotations in 5° steps; scales in 0.1 steps', (v) => tool.setOption('snap', v)),
      select('tf-snap-kind', o.snapKind, [['increment', 'Increment', 'Move in steps of the step'], ['grid', 'Grid', 'Put the moved selection\'s pivot on a grid of the step']], 'What a move snaps to', (v) => tool.setOption('snapKind', v)),
      number('tf-snap-step', tool.step, 'Snap step: the increment and grid spacing, in mesh units', (v) => tool.setOption('snapStep', v))));
    out.push(h('div', { class: 'row' },
      check('tf-proportional', o.proportional, 'Proportional (O)', 'Proportional editing: unselected control points within the radius of the selection follow it with a smooth falloff (3t² − 2t³ of their distance to the nearest selected point); the wheel resizes the radius during G / R / S', (v) => tool.setOption('proportional', v)),
      number('tf-radius', tool.radius, 'Proportional radius: how far from the selection other control points follow it, in mesh units (wheel during a transform)', (v) => tool.setOption('radius', v))));
    const c = tool.cursorPosition();
    out.push(h('div', { class: 'row' }, h('span', { class: 'tf-label', title: 'The 3D cursor: Shift+right click on the mesh places it; a pivot choice' }, '3D cursor'),
      h('span', { class: 'hint-text tf-cursor', title: 'The 3D cursor\'s position (Shift+right click on the mesh places it)' }, `${+c.x.toFixed(3)}, ${+c.y.toFixed(3)}, ${+c.z.toFixed(3)}`)));
    out.push(h('div', { class: 'row buttons' },
      h('button', { title: 'Put the 3D cursor at the selection\'s median', disabled: !sel.length, onclick: () => { const l = this.location(); if (l) tool.setCursor(new THREE.Vector3(...l)); } }, 'Cursor to selection'),
      h('button', { title: 'Put the 3D cursor back at the mesh\'s centre', onclick: () => tool.setCursor(null) }, 'Cursor to centre')));
    return out;
  }

  /** The location field of axis a: moves the selection by the difference (one undo step). */
  async moveTo(a, input, was) {
    const v = parseFloat(input.value);
    if (!Number.isFinite(v)) { this.ed.error(new Error(`Location ${AXES[a]}: expected a number, got "${input.value}"`)); this.refresh(true); return; }
    const t = new THREE.Vector3();
    t.setComponent(a, v - was);
    if (t.lengthSq() === 0) return;
    await this.tool.apply(() => ({ mode: 'translate', t }));
    this.refresh(true);
  }

  async rotate(a, input) {
    const deg = parseFloat(input.value);
    if (!Number.isFinite(deg)) { this.ed.error(new Error(`Rotate ${AXES[a]}: expected degrees, got "${input.value}"`)); this.refresh(true); return; }
    if (deg === 0) return;
    await this.tool.apply((snap) => ({ mode: 'rotate', axis: snap.frame[a].clone().normalize(), angle: THREE.MathUtils.degToRad(deg) }));
    this.refresh(true);
  }

  async scale(axes, input) {
    const f = parseFloat(input.value);
    if (!Number.isFinite(f)) { this.ed.error(new Error(`Scale: expected a factor, got "${input.value}"`)); this.refresh(true); return; }
    if (f === 1) return;
    const s = [1, 1, 1];
    for (const a of axes) s[a] = f;
    await this.tool.apply(() => ({ mode: 'scale', s }));
    this.refresh(true);
  }
}
