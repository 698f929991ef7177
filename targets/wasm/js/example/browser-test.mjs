// The example page in headless Chromium: stages it (index.html, example.js, the package's src/
// and dist/, three's and three-mesh-bvh's modules from node_modules, the bunny), serves it with
// targets/wasm/serve.mjs, and checks that kdray/three's raycast under a grid of mouse positions
// agrees with three-mesh-bvh's (hit or miss, distance within 1e-5 relative), that the SIMD
// module was chosen, and that moving the mouse updates the overlay.
//
//   node example/browser-test.mjs [--chromium /usr/bin/chromium] [--stage DIR]
//
// --stage DIR only stages the page into DIR (serve it with `node ../serve.mjs DIR`).
// Prints `npm-kdray-chromium picks= hits= agree= variant= webgl= match=yes|no`; exits 1 on no.
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import zlib from 'node:zlib';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const pkg = path.join(here, '..');
const args = process.argv.slice(2);
const opt = (name, dflt) => { const i = args.indexOf(`--${name}`); return i < 0 ? dflt : args[i + 1]; };

function stage(dir) {
  fs.mkdirSync(dir, { recursive: true });
  for (const f of ['index.html', 'example.js']) fs.copyFileSync(path.join(here, f), path.join(dir, f));
  fs.cpSync(path.join(pkg, 'src'), path.join(dir, 'kdray/src'), { recursive: true });
  fs.cpSync(path.join(pkg, 'dist'), path.join(dir, 'kdray/dist'), { recursive: true });
  fs.cpSync(path.join(pkg, 'node_modules/three/build'), path.join(dir, 'three/build'), { recursive: true });
  fs.cpSync(path.join(pkg, 'node_modules/three-mesh-bvh/src'), path.join(dir, 'three-mesh-bvh/src'), { recursive: true });
  // The bunny as bunny.bin: u32 vertices, u32 triangles, positions, indices.
  const { positions, indices } = readPly(path.join(pkg, '../../../host/scenes/meshes/bunny.ply.gz'));
  const head = new Uint32Array([positions.length / 3, indices.length / 3]);
  fs.writeFileSync(path.join(dir, 'bunny.bin'), Buffer.concat([Buffer.from(head.buffer), Buffer.from(positions.buffer), Buffer.from(indices.buffer)]));
}

// The test helpers' PLY reader, without importing test code into the page's staging.
function readPly(file) {
  const buf = zlib.gunzipSync(fs.readFileSync(file));
  const end = buf.indexOf('end_header\n');
  const header = buf.subarray(0, end).toString('latin1');
  const nv = +header.match(/element vertex (\d+)/)[1];
  const nf = +header.match(/element face (\d+)/)[1];
  let o = end + 11;
  const positions = new Float32Array(3 * nv);
  for (let i = 0; i < 3 * nv; i++, o += 4) positions[i] = buf.readFloatLE(o);
  const indices = new Uint32Array(3 * nf);
  for (let f = 0; f < nf; f++) {
    if (buf[o++] !== 3) throw new Error('bunny: a face that is not a triangle');
    for (let k = 0; k < 3; k++, o += 4) indices[3 * f + k] = buf.readInt32LE(o);
  }
  return { positions, indices };
}

if (opt('stage')) {
  stage(opt('stage'));
  console.log(`staged the example page in ${opt('stage')}`);
  process.exit(0);
}

const { chromium } = await import('playwright-core');
const { serve } = await import('../../serve.mjs');
const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'kdray-example-'));
let server, browser, ok = false;
try {
  stage(dir);
  server = await serve(dir);
  browser = await chromium.launch({ executablePath: opt('chromium', '/usr/bin/chromium'), args: ['--no-sandbox', '--headless=new'] });
  const page = await browser.newPage({ viewport: { width: 800, height: 600 } });
  const errors = [];
  page.on('pageerror', (e) => errors.push(String(e)));
  page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
  await page.goto(`http://127.0.0.1:${server.address().port}/`);
  await page.waitForFunction(() => window.kdrayExample?.ready === true, null, { timeout: 120_000 });
  const result = await page.evaluate(() => {
    const ex = window.kdrayExample;
    let picks = 0, hits = 0, agree = 0;
    const bad = [];
    for (let i = 0; i < 21; i++) for (let j = 0; j < 21; j++) {
      const { kdray, bvh } = ex.pick(-1 + i / 10, -1 + j / 10);
      picks++;
      if (kdray) hits++;
      const same = (kdray === null && bvh === null) || (kdray && bvh && Math.abs(kdray.distance - bvh.distance) <= 1e-5 * bvh.distance);
      if (same) agree++; else bad.push([i, j, kdray, bvh]);
    }
    return { picks, hits, agree, bad: bad.slice(0, 3), variant: ex.variant, webgl: ex.webgl };
  });
  await page.mouse.move(400, 330);
  await page.waitForFunction(() => /under the mouse: face \d+/.test(window.kdrayExample.overlay()), null, { timeout: 30_000 });
  const overlay = await page.evaluate(() => window.kdrayExample.overlay());
  ok = errors.length === 0 && result.agree === result.picks && result.hits > 20 && result.variant === 'simd128' && /ns a ray: raycast \d+/.test(overlay);
  if (errors.length) console.error('page errors:', errors);
  if (result.bad.length) console.error('disagreements:', JSON.stringify(result.bad));
  console.error(overlay);
  console.log(`npm-kdray-chromium picks=${result.picks} hits=${result.hits} agree=${result.agree} variant=${result.variant} webgl=${result.webgl} match=${ok ? 'yes' : 'no'}`);
} finally {
  await browser?.close();
  server?.close();
  fs.rmSync(dir, { recursive: true, force: true });
}
process.exit(ok ? 0 : 1);
