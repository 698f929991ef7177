// Compares two hits files (kdray's layout: n × (f32 t, u32 prim, f32 u, f32 v), a miss is t = +inf)
// so the throughput table says whether the engines it times found the same hits.
//
//   node compare-hits.mjs REFERENCE.bin OTHER.bin [--prims]
//
// Prints `rays= hit_miss_disagree= prim_disagree= max_rel_t= identical=yes|no`: rays where one file
// hits and the other misses, hits on different primitives (only with --prims: both files must hold
// input-order triangle ids), the largest relative difference of t where both hit, and whether the
// files are byte for byte equal. Exits 1 if the files differ in length.

import fs from 'node:fs';

const args = process.argv.slice(2);
const prims = args.includes('--prims');
const files = args.filter((a) => a !== '--prims');
if (files.length !== 2) {
  console.error('usage: compare-hits.mjs REFERENCE.bin OTHER.bin [--prims]');
  process.exit(2);
}
const [a, b] = files.map((f) => fs.readFileSync(f));
if (a.length !== b.length || a.length % 16 !== 0) {
  console.error(`compare-hits: error: ${files[0]} has ${a.length} bytes, ${files[1]} has ${b.length}`);
  process.exit(1);
}
const n = a.length / 16;
let hitMiss = 0;
let primDiff = 0;
let maxRel = 0;
for (let i = 0; i < n; i++) {
  const ta = a.readFloatLE(16 * i);
  const tb = b.readFloatLE(16 * i);
  const ha = Number.isFinite(ta);
  if (ha !== Number.isFinite(tb)) {
    hitMiss++;
  } else if (ha) {
    maxRel = Math.max(maxRel, Math.abs(ta - tb) / Math.abs(ta));
    if (prims && a.readUInt32LE(16 * i + 4) !== b.readUInt32LE(16 * i + 4)) primDiff++;
  }
}
console.log(
  `rays=${n} hit_miss_disagree=${hitMiss} prim_disagree=${prims ? primDiff : '-'} ` +
    `max_rel_t=${maxRel.toExponential(2)} identical=${a.equals(b) ? 'yes' : 'no'}`,
);
