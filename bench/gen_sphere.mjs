#!/usr/bin/env node
// Writes a bumpy UV sphere of about N vertices as an OBJ, for the editor's
// drag benchmark (bench/editor_drag.mjs) and big-mesh checks; big meshes are
// generated, never committed.
//
//   node bench/gen_sphere.mjs --vertices 100000 --out /tmp/sphere100k.obj
//
// Rows of latitude by columns of longitude plus the two poles; each quad is
// two triangles, so faces = 2 * vertices (about). The radius carries a few
// low-frequency bumps so that shading shows every change of the normals.

import { writeFileSync } from 'node:fs';

const argv = process.argv.slice(2);
const opt = (name, dflt) => { const i = argv.indexOf(`--${name}`); return i >= 0 ? argv[i + 1] : dflt; };
const N = Number(opt('vertices', 100000));
const out = opt('out', `/tmp/sphere${Math.round(N / 1000)}k.obj`);
if (!(N >= 8)) { console.error('--vertices: expected a number >= 8'); process.exit(2); }

// rows * cols + 2 = N, cols = 2 rows
const rows = Math.max(2, Math.round(Math.sqrt((N - 2) / 2)));
const cols = Math.max(3, Math.round((N - 2) / rows));
const lines = [`# bumpy UV sphere: ${rows} rows x ${cols} columns + 2 poles (bench/gen_sphere.mjs)`];
const radius = (th, ph) => 1 + 0.08 * Math.sin(3 * th) * Math.cos(4 * ph) + 0.04 * Math.sin(7 * ph + 2 * th);
const vtx = (th, ph) => {
  const r = radius(th, ph);
  return `v ${(r * Math.sin(th) * Math.cos(ph)).toFixed(6)} ${(r * Math.cos(th)).toFixed(6)} ${(r * Math.sin(th) * Math.sin(ph)).toFixed(6)}`;
};
lines.push(vtx(0, 0));
for (let i = 1; i <= rows; i++) {
  const th = (Math.PI * i) / (rows + 1);
  for (let j = 0; j < cols; j++) lines.push(vtx(th, (2 * Math.PI * j) / cols));
}
lines.push(vtx(Math.PI, 0));
const id = (i, j) => 2 + (i - 1) * cols + (j % cols); // 1-based OBJ ids; row i in 1..rows
const last = rows * cols + 2;
for (let j = 0; j < cols; j++) lines.push(`f 1 ${id(1, j + 1)} ${id(1, j)}`);
for (let i = 1; i < rows; i++)
  for (let j = 0; j < cols; j++) {
    lines.push(`f ${id(i, j)} ${id(i, j + 1)} ${id(i + 1, j + 1)}`);
    lines.push(`f ${id(i, j)} ${id(i + 1, j + 1)} ${id(i + 1, j)}`);
  }
for (let j = 0; j < cols; j++) lines.push(`f ${id(rows, j)} ${id(rows, j + 1)} ${last}`);
writeFileSync(out, lines.join('\n') + '\n');
console.log(`${out}: ${rows * cols + 2} vertices, ${2 * rows * cols} triangles`);
