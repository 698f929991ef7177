// Loads a scene the WASM module must refuse, and checks that its error names the reason.
//
//   node refusal.mjs MODULE.wasm SCENE.kdt PATTERN
//
// Prints `<module> refuses SCENE: <the error>`; exits 1 if the scene loads or the error does not
// match PATTERN (a regular expression).
import { readFileSync } from "node:fs";
import { basename } from "node:path";

const [wasmPath, kdtPath, pattern] = process.argv.slice(2);
const { instance } = await WebAssembly.instantiate(readFileSync(wasmPath), {});
const kd = instance.exports;

const scene = readFileSync(kdtPath);
const ptr = kd.kd_alloc(scene.length);
if (ptr === 0) throw new Error(`kd_alloc(${scene.length}) failed`);
new Uint8Array(kd.memory.buffer, ptr, scene.length).set(scene);
const status = kd.kd_load(ptr, scene.length / 4, 0, 0);
const name = `${basename(wasmPath, ".wasm")} refuses ${basename(kdtPath)}`;
if (status >= 0) {
  console.log(`${name}: no, it loaded`);
  process.exit(1);
}
const buf = kd.kd_alloc(256);
const n = kd.kd_error(buf, 256);
const text = n > 0 ? new TextDecoder().decode(new Uint8Array(kd.memory.buffer, buf, n)) : "";
const ok = new RegExp(pattern).test(text);
console.log(`${name}: ${ok ? "yes" : "no"} (status ${status}: ${text})`);
process.exit(ok ? 0 : 1);
