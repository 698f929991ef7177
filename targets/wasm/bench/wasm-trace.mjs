// Traces a `kdray rays` file with the kdray WASM module in Node and times it: the WASM rows of the
// throughput table (bench/throughput.sh).
//
//   node wasm-trace.mjs MODULE.wasm SCENE.kdt RAYS.bin [--packet 1|4|8] [--repeat N] [--hits OUT.bin]
//
// Prints `engine=wasm module= packet= rays= hits= trace_ms= mrays_s=` (trace_ms: the best of
// --repeat runs of the trace export alone; the rays are copied into the module's memory once,
// before). --hits writes the hits in kdray's hits layout (primitives in input order), to compare
// with `kdray trace`.

import fs from 'node:fs';
import path from 'node:path';
import { performance } from 'node:perf_hooks';
import { Engine } from '../www/engine.js';

function fail(msg, code = 1) {
  console.error(`wasm-trace: error: ${msg}`);
  process.exit(code);
}

const args = process.argv.slice(2);
const opts = { packet: 1, repeat: 3, hits: null, files: [] };
for (let i = 0; i < args.length; i++) {
  const a = args[i];
  if (a === '--packet' || a === '--repeat' || a === '--hits') {
    if (i + 1 >= args.length) fail(`${a} needs a value`, 2);
    opts[a.slice(2)] = args[++i];
  } else if (a.startsWith('--')) {
    fail(`unknown option ${a}`, 2);
  } else {
    opts.files.push(a);
  }
}
if (opts.files.length !== 3) fail('usage: wasm-trace.mjs MODULE.wasm SCENE.kdt RAYS.bin [--packet 1|4|8] [--repeat N] [--hits OUT.bin]', 2);
const packet = Number(opts.packet);
const repeat = Number(opts.repeat);
if (![1, 4, 8].includes(packet)) fail('--packet must be 1, 4 or 8', 2);
if (!Number.isInteger(repeat) || repeat < 1) fail('--repeat must be a whole number ≥ 1', 2);

const [modFile, kdtFile, raysFile] = opts.files;
const read = (f) => {
  try {
    return fs.readFileSync(f);
  } catch (e) {
    fail(`${f}: ${e.message}`);
  }
};
const engine = await Engine.create(read(modFile), path.basename(modFile));
try {
  engine.load(new Uint8Array(read(kdtFile)), null, [1, 1]);
} catch (e) {
  fail(`${kdtFile}: ${e.message}`);
}
const raw = read(raysFile);
if (raw.length % 32 !== 0) fail(`${raysFile}: ${raw.length} bytes is not a whole number of 32-byte rays`);
const rays = new Float32Array(raw.buffer.slice(raw.byteOffset, raw.byteOffset + raw.length));
const handle = engine.putRays(rays);
let best = Infinity;
let hits = 0;
for (let r = 0; r < repeat; r++) {
  const t0 = performance.now();
  hits = engine.trace(handle, packet);
  best = Math.min(best, performance.now() - t0);
}
if (opts.hits) fs.writeFileSync(opts.hits, engine.hits(handle));
console.log(
  `engine=wasm module=${engine.name} packet=${packet} rays=${handle.n} hits=${hits} ` +
    `trace_ms=${best.toFixed(1)} mrays_s=${(handle.n / best / 1e3).toFixed(3)}`,
);
