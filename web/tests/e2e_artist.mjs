#!/usr/bin/env node
// End-to-end test of the editor as an artist uses it (issue 21): real mouse
// and keyboard events in headless Chromium against the real `ffd serve`, one
// stage per workflow in web/tests/artist/*.mjs (each exports `stage`, run in
// the order below on the same page; a failing stage is reported and the next
// one goes on). Screenshots go to --out.
//
//   node web/tests/e2e_artist.mjs --ffd build/ffd --out DIR [--stages a,b] [--keep]

import { launch, runTest, guarded, argv } from './harness.mjs';

// one line per stage module: [name, file under web/tests/artist/]
const STAGES = [
  ['view', 'view.mjs'],
  ['transform', 'transform.mjs'],
  ['panel', 'panel.mjs'],
  ['dm', 'dm.mjs'],
  ['perf', 'perf.mjs'],
  ['persist', 'persist.mjs'],
];

const only = (() => { const i = argv.indexOf('--stages'); return i >= 0 ? argv[i + 1].split(',') : null; })();

async function main() {
  await launch(['examples/lattice/bunny.obj', 'data/hinge.stl', 'data/elephant.off', 'examples/tspline/cow.off']);
  for (const [name, file] of STAGES) {
    if (only && !only.includes(name)) continue;
    const mod = await import(new URL(`./artist/${file}`, import.meta.url));
    await guarded(name, mod.stage);
  }
}

await runTest(main, 'e2e_artist');
