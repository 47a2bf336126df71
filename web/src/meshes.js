// Several meshes in one session (a character and its clothes), deformed by the
// one deformer: the server concatenates their vertices (state.meshes gives each
// mesh's range, docs/editor.md "Several meshes"). The page draws each as its
// own object: the viewport's one geometry gets a draw group per mesh with its
// own material (colour), and a hidden mesh has no group (neither drawn nor
// picked). The panel's "Meshes" section lists them: visibility, export alone,
// remove, and "Add mesh" from the server's files or an upload.

import * as THREE from 'three';
import { api } from './api.js';
import { h, fmtInt } from './dom.js';

// the first mesh keeps the viewport's own colour; the others get these
const COLOURS = [0xd9d5cc, 0x8fb8de, 0xe2a676, 0x9ccc8f, 0xc9a2dc, 0xe6d27a, 0x7fcfc6, 0xe59aa8];

export class MeshList {
  constructor(editor) {
    this.ed = editor;
    this.meshes = [];        // state.meshes: {name, first, vertices, faces}
    this.hidden = new Set(); // names of hidden meshes (a view setting: kept across re-binds)
    this.materials = [];
    this.appliedTo = null;   // the viewport mesh the groups were set up on
    this.appliedKey = '';
    this.addFile = '';
    editor.on('state', (s) => this.onState(s));
    // the part materials follow the viewport's material (influence map, X-ray, ...) but their colour
    editor.vp.onBeforeRender.push(() => this.syncMaterials());
  }

  colour(i) { return COLOURS[i % COLOURS.length]; }

  onState(s) {
    const before = JSON.stringify(this.meshes);
    this.meshes = (s && s.meshes) || [];
    for (const name of [...this.hidden]) if (!this.meshes.some((m) => m.name === name)) this.hidden.delete(name);
    this.apply();
    if (JSON.stringify(this.meshes) !== before) this.ed.panel.render(); // the panel drew before this state reached us
  }

  /** Sets up (or removes) the per-mesh draw groups on the viewport's mesh. */
  apply() {
    const vp = this.ed.vp;
    if (!vp.mesh || !vp.geometry) return;
    const key = JSON.stringify([this.meshes.map((m) => [m.first, m.vertices]), [...this.hidden]]);
    if (vp.mesh === this.appliedTo && key === this.appliedKey) return;
    this.appliedTo = vp.mesh;
    this.appliedKey = key;
    const g = vp.geometry;
    g.clearGroups();
    if (this.meshes.length < 2) {
      vp.mesh.material = vp.material;
      if (vp.wire) vp.wire.material = vp.wireMaterial;
      vp.requestRender();
      return;
    }
    // the triangles come in mesh order (the server concatenates each mesh's faces)
    const tri = vp.triangles;
    const T = tri.length / 3;
    let t = 0;
    while (this.materials.length < this.meshes.length) this.materials.push(vp.material.clone());
    this.meshes.forEach((m, i) => {
      const begin = t;
      const end = m.first + m.vertices;
      while (t < T && tri[3 * t] < end) t++;
      if (!this.hidden.has(m.name) && t > begin) g.addGroup(3 * begin, 3 * (t - begin), i);
    });
    vp.mesh.material = this.materials.slice(0, this.meshes.length);
    if (vp.wire) vp.wire.material = this.meshes.map(() => vp.wireMaterial);
    this.synced = null;
    this.syncMaterials();
    vp.requestRender();
  }

  syncMaterials() {
    const vp = this.ed.vp;
    if (this.meshes.length < 2 || !vp.mesh || !Array.isArray(vp.mesh.material)) return;
    const base = vp.material;
    // three compiles a program per vertexColors/transparent; copy only on a change
    const key = [base.vertexColors, base.transparent, base.opacity, base.wireframe, base.depthWrite, base.visible, base.color.getHex()].join();
    if (key === this.synced) return;
    this.synced = key;
    this.materials.forEach((mat, i) => {
      mat.copy(base);
      if (!base.vertexColors) mat.color.setHex(this.colour(i));
      mat.needsUpdate = true;
    });
  }

  setVisible(name, on) {
    if (on) this.hidden.delete(name); else this.hidden.add(name);
    this.appliedKey = '';
    this.apply();
    this.ed.panel.render();
  }

  /** Points the camera at mesh i as it is now (the view's frame, F, takes them all). */
  frame(i) {
    const m = this.meshes[i];
    const vp = this.ed.vp;
    if (!m || !vp.geometry) return;
    const p = vp.geometry.attributes.position.array;
    const box = new THREE.Box3();
    const v = new THREE.Vector3();
    for (let k = m.first; k < m.first + m.vertices; k++) box.expandByPoint(v.set(p[3 * k], p[3 * k + 1], p[3 * k + 2]));
    const s = box.getBoundingSphere(new THREE.Sphere());
    const dir = vp.camera.position.clone().sub(vp.orbit.target);
    if (dir.lengthSq() < 1e-12) dir.set(0.5, 0.35, 1);
    dir.normalize();
    const dist = Math.max(s.radius, 1e-9) / Math.sin(THREE.MathUtils.degToRad(vp.camera.fov / 2)) * 1.05;
    vp.orbit.target.copy(s.center);
    vp.camera.position.copy(s.center).addScaledVector(dir, dist);
    vp.camera.near = Math.max(dist * 0.001, 1e-6);
    vp.camera.far = dist * 100;
    vp.camera.updateProjectionMatrix();
    vp.orbit.update();
    vp.requestRender();
  }

  async add(path) {
    if (!path) { this.ed.info('Choose a mesh on the server first'); return; }
    try {
      const st = await api.post('/api/open?add=1', { path }, 'Adding mesh…');
      await this.added(st, path);
    } catch (e) { this.ed.error(e); }
  }

  async uploadBytes(file) {
    try {
      await this.added(await api.addMeshUpload(file.name, await file.arrayBuffer()), file.name);
    } catch (e) { this.ed.error(e); }
  }

  async added(state, name) {
    await this.ed.applyState(typeof state === 'object' && state ? state : await api.state(), { forceFrame: true });
    const n = (this.ed.state.mesh || {}).vertices;
    const method = this.ed.state.method;
    this.ed.info(`Added ${name.split('/').pop()}: ${method ? `the ${method} now binds` : 'the session holds'} ${fmtInt(n)} vertices in ${this.meshes.length} meshes (undo history cleared)`);
    this.ed.frame();
  }

  async remove(i) {
    const m = this.meshes[i];
    if (!m) return;
    if (!window.confirm(`Remove ${m.name} from the session?\nThe deformer keeps its shape; the undo history is cleared.`)) return;
    await this.ed.run('remove_mesh', { mesh: i });
  }

  /** Downloads mesh i alone, deformed (the Export section's format). */
  async download(i) {
    const m = this.meshes[i];
    const ex = (this.ed.panel.form && this.ed.panel.form.export) || {};
    const ext = (m.name.match(/\.([^.]+)$/) || [])[1] || 'ply';
    const format = ex.format || '';
    const q = new URLSearchParams({ mesh: String(i) });
    if (format) q.set('format', format);
    // OBJ and OFF are text only: their encoding stays as read
    if (ex.encoding && !['obj', 'off'].includes((format || ext).toLowerCase())) q.set('encoding', ex.encoding);
    try {
      const blob = await api.blob(`/api/export?${q}`, 'Preparing download…');
      const a = document.createElement('a');
      a.href = URL.createObjectURL(blob.data);
      a.download = blob.name || `${m.name.replace(/\.[^.]*$/, '')}-deformed.${format || ext}`;
      document.body.appendChild(a);
      a.click();
      a.remove();
      setTimeout(() => URL.revokeObjectURL(a.href), 10000);
    } catch (e) { this.ed.error(e); }
  }

  /** The panel's "Meshes" section. */
  section(panel) {
    const files = (panel.files && panel.files.meshes) || [];
    const many = this.meshes.length > 1;
    const fileInput = h('input', {
      type: 'file', accept: '.obj,.ply,.off,.stl,.gltf,.glb', hidden: true,
      onchange: async (e) => { const f = e.target.files[0]; if (f) await this.uploadBytes(f); e.target.value = ''; },
    });
    const sel = h('select', { name: 'mesh-add-file', style: 'flex:1', title: 'A mesh file under the server root', onchange: (e) => { this.addFile = e.target.value; } },
      h('option', { value: '' }, files.length ? 'Mesh to add…' : 'No meshes under the root'),
      files.map((f) => h('option', { value: f, selected: f === this.addFile }, f)));
    return h('section', { class: 'meshes' },
      h('h3', {}, 'Meshes', h('span', { class: 'badge', title: 'Meshes in this session, all deformed by the one deformer' }, String(Math.max(1, this.meshes.length)))),
      many ? h('div', { class: 'list mesh-list' }, this.meshes.map((m, i) => h('div', { class: 'item', dataset: { mesh: String(i) } },
        h('span', { class: 'swatch', style: `background:#${this.colour(i).toString(16).padStart(6, '0')}`, title: 'Its colour in the view' }),
        h('input', {
          type: 'checkbox', name: `mesh-visible-${i}`, checked: !this.hidden.has(m.name),
          title: 'Show or hide this mesh (the view only: it is still deformed and exported)',
          onchange: (e) => this.setVisible(m.name, e.target.checked),
        }),
        h('span', { class: 'name', title: `${m.name}: vertices ${fmtInt(m.first)} to ${fmtInt(m.first + m.vertices - 1)} of the session` }, m.name),
        h('span', { class: 'hint-text' }, `${fmtInt(m.vertices)} v`),
        h('button', { title: 'Frame this mesh (point the view at it; F frames them all)', onclick: () => this.frame(i) }, '◉'),
        h('button', { title: 'Download this mesh alone, deformed, in the Export format (below): exactly what ffd deform writes for its file', onclick: () => this.download(i) }, '⇩'),
        h('button', { title: 'Remove this mesh from the session (the undo history is cleared)', onclick: () => this.remove(i) }, '×')))) : null,
      h('div', { class: 'row' }, sel,
        h('button', { title: 'Add the chosen mesh to this session: the deformer binds it too, as a character and its clothes (clears the undo history)', onclick: () => this.add(this.addFile) }, '+ Add')),
      h('div', { class: 'row buttons' },
        h('button', { title: 'Add a mesh from this computer to this session (the deformer binds it too)', onclick: () => fileInput.click() }, '⇪ Add mesh from file…'), fileInput),
      many ? h('div', { class: 'hint-text' }, 'One deformer moves all meshes; each exports alone (⇩). Re-creating an automatic deformer fits it to all of them.') : null,
    );
  }
}
