// Counts the rays (camera, bounce and shadow) a render traces, with the WASM module's
// kd_accumulate: the same paths as `kdray render` and the firmware (every sample is the same
// whichever target renders it), so the firmware's instruction count can be divided by it.
//
//   node count-rays.mjs MODULE.wasm SCENE.kdt SCENE.kdr WxH SPP
//
// Prints `rays= pixels= spp=`.

import fs from 'node:fs';
import path from 'node:path';
import { Engine } from '../www/engine.js';

const [modFile, kdtFile, kdrFile, size, sppText] = process.argv.slice(2);
const m = /^(\d+)x(\d+)$/.exec(size || '');
const spp = Number(sppText);
if (!m || !Number.isInteger(spp) || spp < 1) {
  console.error('usage: count-rays.mjs MODULE.wasm SCENE.kdt SCENE.kdr WxH SPP');
  process.exit(2);
}
const read = (f) => new Uint8Array(fs.readFileSync(f));
const engine = await Engine.create(read(modFile), path.basename(modFile));
const [w, h] = [Number(m[1]), Number(m[2])];
try {
  engine.load(read(kdtFile), read(kdrFile), [w, h]);
  let rays = 0;
  for (let s = 0; s < spp; s++) rays += engine.accumulate(0, h, s);
  console.log(`rays=${rays} pixels=${w * h} spp=${spp}`);
} catch (e) {
  console.error(`count-rays: error: ${kdtFile}: ${e.message}`);
  process.exit(1);
}
