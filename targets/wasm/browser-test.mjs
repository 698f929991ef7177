// The page test: serves a staged page on 127.0.0.1, drives headless Chromium to it, lets it render
// a scene progressively for N frames (N samples per pixel) and compares the canvas, pixel by
// pixel, with the host's render of the same scene (`kdray render --spp N --size WxH`).
//
//   node browser-test.mjs --www DIR --reference HOST.png --scene NAME --frames N --size WxH
//                         [--bare SCENE.kdt] [--screenshot OUT.png] [--chromium /usr/bin/chromium]
//                         [--timeout-s 300]
//
// Prints one line `wasm-chromium scene= size= frames= module= checksum= host= max_diff= mrays_s=
// match=yes|no` (checksum: FNV-1a 32 of the RGB bytes, row-major) and a line on each file then
// given to the page's file picker: one that is not a scene must be refused with a message, and
// `--bare` (a .kdt without its .kdr) must render with the module's framing view. Exits 1 on a
// mismatch or when the page misbehaves, 2 on a usage error.
//
// The host PNG is decoded by Chromium itself, with colour-space conversion off, so both images
// are compared as the 8-bit values they hold.

import fs from 'node:fs';
import path from 'node:path';
import { chromium } from 'playwright-core';
import { serve } from './serve.mjs';

function usage(msg) {
  console.error(`browser-test: ${msg}`);
  console.error('usage: browser-test.mjs --www DIR --reference HOST.png --scene NAME --frames N --size WxH [--bare SCENE.kdt] [--screenshot OUT.png] [--chromium PATH] [--timeout-s S]');
  process.exit(2);
}

function parseArgs(argv) {
  const o = { chromium: '/usr/bin/chromium', timeoutS: 300, screenshot: null, bare: null };
  const keys = { '--bare': 'bare', '--www': 'www', '--reference': 'reference', '--scene': 'scene', '--frames': 'frames', '--size': 'size', '--screenshot': 'screenshot', '--chromium': 'chromium', '--timeout-s': 'timeoutS' };
  for (let i = 0; i < argv.length; i += 2) {
    const k = keys[argv[i]];
    if (!k || i + 1 >= argv.length) usage(`bad argument ${argv[i]}`);
    o[k] = argv[i + 1];
  }
  for (const k of ['www', 'reference', 'scene', 'frames', 'size']) if (!o[k]) usage(`--${k} is required`);
  o.frames = Number(o.frames);
  o.timeoutS = Number(o.timeoutS);
  if (!Number.isInteger(o.frames) || o.frames < 1) usage('--frames must be a whole number ≥ 1');
  if (!/^\d+x\d+$/.test(o.size)) usage('--size must be WxH');
  if (!fs.existsSync(path.join(o.www, 'index.html'))) usage(`${o.www} has no index.html (stage it with page.sh)`);
  if (!fs.existsSync(o.reference)) usage(`${o.reference} does not exist`);
  return o;
}

/** FNV-1a (32-bit) of the RGB bytes of RGBA pixels. */
function checksumRgb(rgba) {
  let h = 0x811c9dc5;
  for (let i = 0; i < rgba.length; i++) {
    if (i % 4 === 3) continue;
    h = Math.imul(h ^ rgba[i], 0x01000193) >>> 0;
  }
  return `0x${h.toString(16).padStart(8, '0')}`;
}

const o = parseArgs(process.argv.slice(2));
// The reference sits beside the page so that the browser can fetch and decode it.
fs.copyFileSync(o.reference, path.join(o.www, 'reference.png'));
const server = await serve(o.www);
const url = `http://127.0.0.1:${server.address().port}/`;
const browser = await chromium.launch({
  executablePath: o.chromium,
  headless: true,
  // Playwright starts Chromium with a new empty profile of its own (--user-data-dir in a temp dir).
  args: ['--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run', '--disable-background-networking',
    '--disable-component-update', '--disable-sync', '--force-color-profile=srgb'],
});
let code = 0;
try {
  const page = await browser.newPage();
  const logs = [];
  page.on('console', (m) => logs.push(`console.${m.type()}: ${m.text()}`));
  page.on('pageerror', (e) => logs.push(`page error: ${e.message}`));
  await page.goto(`${url}index.html?scene=${encodeURIComponent(o.scene)}&frames=${o.frames}&size=${o.size}`);
  try {
    await page.waitForFunction(() => window.kdrayPage && window.kdrayPage.done, null, { timeout: o.timeoutS * 1e3, polling: 200 });
  } catch (e) {
    const st = await page.evaluate(() => JSON.stringify(window.kdrayPage)).catch(() => 'unavailable');
    throw new Error(`the page did not finish in ${o.timeoutS} s (state ${st}); ${logs.join('; ')}`);
  }
  const st = await page.evaluate(() => window.kdrayPage);
  if (st.error) throw new Error(`the page reported: ${st.error}; ${logs.join('; ')}`);
  if (o.screenshot) await page.screenshot({ path: o.screenshot, fullPage: true });
  const result = await page.evaluate(async () => {
    const canvas = document.getElementById('canvas');
    const { width, height } = canvas;
    const got = canvas.getContext('2d').getImageData(0, 0, width, height).data;
    const blob = await (await fetch('reference.png')).blob();
    const bmp = await createImageBitmap(blob, { colorSpaceConversion: 'none', premultiplyAlpha: 'none' });
    if (bmp.width !== width || bmp.height !== height) {
      return { error: `the host image is ${bmp.width}×${bmp.height}, the canvas ${width}×${height}` };
    }
    const off = new OffscreenCanvas(width, height);
    const octx = off.getContext('2d');
    octx.drawImage(bmp, 0, 0);
    const want = octx.getImageData(0, 0, width, height).data;
    let maxDiff = 0;
    let differing = 0;
    for (let i = 0; i < got.length; i += 4) {
      let d = 0;
      for (let c = 0; c < 3; c++) d = Math.max(d, Math.abs(got[i + c] - want[i + c]));
      if (d > 0) differing++;
      maxDiff = Math.max(maxDiff, d);
    }
    return { got: Array.from(got), want: Array.from(want), maxDiff, differing, width, height };
  });
  if (result.error) throw new Error(result.error);
  const match = result.maxDiff === 0;
  const mrays = st.ms > 0 ? st.rays / st.ms / 1e3 : 0;
  const module = await page.evaluate(() => document.getElementById('module').textContent.replace('module: ', ''));
  console.log(`wasm-chromium scene=${o.scene} size=${result.width}x${result.height} frames=${st.frames} module=${module} ` +
    `checksum=${checksumRgb(result.got)} host=${checksumRgb(result.want)} max_diff=${result.maxDiff} ` +
    `differing_pixels=${result.differing} mrays_s=${mrays.toFixed(2)} match=${match ? 'yes' : 'no'}`);
  if (!match) code = 1;

  // A file that is not a scene: the page must say so, not throw or hang.
  await page.setInputFiles('#file', { name: 'garbage.kdt', mimeType: 'application/octet-stream', buffer: Buffer.from('not a kd-tree, just text\n') });
  await page.waitForFunction(() => window.kdrayPage.scene === 'garbage.kdt' && window.kdrayPage.done, null, { timeout: 30e3 });
  const bad = await page.evaluate(() => window.kdrayPage.error);
  const rejected = typeof bad === 'string' && bad.startsWith('garbage.kdt:');
  console.log(`wasm-chromium bad-file: ${rejected ? `rejected with "${bad}"` : `NOT rejected (${bad})`}`);
  if (!rejected) code = 1;

  if (o.bare) {
    // A bare .kdt: the module frames it itself; one frame must render without an error.
    const name = path.basename(o.bare);
    await page.setInputFiles('#file', o.bare);
    await page.waitForFunction((n) => window.kdrayPage.scene === n && (window.kdrayPage.frames >= 1 || window.kdrayPage.error),
      name, { timeout: o.timeoutS * 1e3, polling: 200 });
    const bare = await page.evaluate(() => window.kdrayPage);
    const ok = !bare.error && bare.frames >= 1;
    console.log(`wasm-chromium bare-kdt: ${ok ? `${name} rendered ${bare.frames} frame(s) at ${bare.width}x${bare.height} with the framing view` : `FAILED (${bare.error})`}`);
    if (!ok) code = 1;
  }
  if (logs.some((l) => l.startsWith('page error'))) {
    console.error(logs.join('\n'));
    code = 1;
  }
} catch (e) {
  console.log(`wasm-chromium scene=${o.scene} error="${e.message}" match=no`);
  code = 1;
} finally {
  await browser.close();
  server.close();
}
process.exit(code);
