// Traces a rays file with the kdray WASM module under Node (scalar walk, 4- and 8-wide packets)
// and compares the hits byte for byte with the host's `kdray trace` hits file.
//
//   node trace-compare.mjs MODULE.wasm SCENE.kdt RAYS.bin HOST_HITS.bin
//
// Prints `<module> trace rays=N hits=N packet1=yes packet4=yes packet8=yes`; exits 1 on a mismatch.
import { readFileSync } from "node:fs";
import { basename } from "node:path";

const [wasmPath, kdtPath, raysPath, hitsPath] = process.argv.slice(2);
const { instance } = await WebAssembly.instantiate(readFileSync(wasmPath), {});
const kd = instance.exports;

function place(bytes) {
  const ptr = kd.kd_alloc(bytes.length);
  if (ptr === 0) throw new Error(`kd_alloc(${bytes.length}) failed`);
  new Uint8Array(kd.memory.buffer, ptr, bytes.length).set(bytes);
  return ptr;
}

const scene = readFileSync(kdtPath);
const rays = readFileSync(raysPath);
const host = readFileSync(hitsPath);
const n = rays.length / 32;
if (kd.kd_load(place(scene), scene.length / 4, 0, 0) < 0) throw new Error("kd_load failed");
const raysPtr = place(rays);
const hitsPtr = kd.kd_alloc(n * 16);
let ok = true;
let hits = 0;
const parts = [];
for (const packet of [1, 4, 8]) {
  hits = kd.kd_trace(raysPtr, n, hitsPtr, packet);
  if (hits < 0) throw new Error(`kd_trace status ${hits}`);
  const ours = new Uint8Array(kd.memory.buffer, hitsPtr, n * 16);
  const same = Buffer.compare(Buffer.from(ours), host) === 0;
  ok &&= same;
  parts.push(`packet${packet}=${same ? "yes" : "no"}`);
}
console.log(`${basename(wasmPath, ".wasm")} trace rays=${n} hits=${hits} ${parts.join(" ")}`);
process.exit(ok ? 0 : 1);
