#!/usr/bin/env node
// Drag-rate check: opens a large mesh (default: the mock's blob-100k.obj),
// creates a 5x5x5 lattice, drags one control point with a steady stream of
// pointer moves for a few seconds and reports drag updates per second.
//
//   node tests/perf.mjs [URL] [--mesh blob-100k.obj] [--seconds 4] [--res 5] [--no-render] [--chromium PATH]
//
// Headless Chromium draws with SwiftShader (software GL): a 200K-triangle
// frame costs it hundreds of milliseconds, which a GPU does in about one.
// --no-render skips drawing to measure request, solve, transfer and mesh update.

import { chromium } from 'playwright-core';
import { existsSync } from 'node:fs';

const argv = process.argv.slice(2);
const opt = (name, dflt) => { const i = argv.indexOf(`--${name}`); return i >= 0 ? argv[i + 1] : dflt; };
const URL_ = argv.find((a) => a.startsWith('http')) || 'http://127.0.0.1:8090/';
const mesh = opt('mesh', 'blob-100k.obj');
const seconds = Number(opt('seconds', 4));
const res = Number(opt('res', 5));
const exe = opt('chromium', ['/usr/bin/chromium', '/usr/bin/chromium-browser', '/usr/bin/google-chrome'].find(existsSync));

const browser = await chromium.launch({
  executablePath: exe, headless: true,
  args: ['--no-sandbox', '--use-gl=angle', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist'],
});
const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
page.on('pageerror', (e) => console.error('page error:', e));
await page.goto(URL_);
await page.waitForSelector('body[data-ready="1"]', { timeout: 30000 });
if (mesh) await page.evaluate((p) => window.ffdEditor.editor.openPath(p), mesh);
await page.evaluate((n) => window.ffdEditor.editor.run('create', { method: 'lattice', resolution: [n, n, n], basis: 'bspline', margin: 0.05 }), res);
await page.waitForFunction(() => window.ffdEditor.state.method === 'lattice' && window.ffdEditor.lastFrameRevision === window.ffdEditor.state.revision);
const V = await page.evaluate(() => window.ffdEditor.state.mesh.vertices);
const noRender = argv.includes('--no-render');
if (noRender) await page.evaluate(() => window.ffdEditor.setRenderEnabled(false));
const mid = Math.floor(res / 2);
const id = (mid * res + res - 1) * res + mid;
const p = await page.evaluate((i) => window.ffdEditor.screenOfControl(i), id);
await page.mouse.move(p.x, p.y);
await page.mouse.down();
const t0 = Date.now();
let i = 0;
const samples = [];
while (Date.now() - t0 < seconds * 1000) {
  const a = (i++ / 30) * Math.PI;
  await page.mouse.move(p.x + 60 * Math.sin(a), p.y + 40 * (1 - Math.cos(a)));
  if (i % 20 === 0) samples.push(await page.evaluate(() => window.ffdEditor.dragStats));
}
await page.mouse.up();
await page.waitForFunction(() => !window.ffdEditor.dragging, null, { timeout: 30000 });
const ups = samples.slice(2).map((s) => s.updatesPerSecond);
const mean = ups.reduce((a, b) => a + b, 0) / Math.max(1, ups.length);
const last = samples[samples.length - 1] || {};
if (noRender) await page.evaluate(() => window.ffdEditor.setRenderEnabled(true));
console.log(`mesh ${mesh}: ${V} vertices; pointer moves ${i} in ${seconds} s${noRender ? ' (drawing off)' : ''}`);
console.log(`drag updates/s: mean ${mean.toFixed(1)}, min ${Math.min(...ups)}, max ${Math.max(...ups)}; last step ${last.stepMs?.toFixed(1)} ms request + ${last.applyMs?.toFixed(1)} ms mesh update`);
await page.screenshot({ path: opt('shot', '/tmp/ffd-web/perf.png') });
await browser.close();
