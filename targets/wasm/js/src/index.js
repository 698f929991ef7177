// The package's default entry: both modules inlined as base64 (dist/inline.js), so it works with
// no bundler set-up and no .wasm file to serve; the one this engine runs is chosen by
// WebAssembly.validate on a one-instruction SIMD probe (core.js). Those who stream the .wasm
// files themselves import 'kdray/core' and call init() with their URLs.
import { scalar, simd128 } from '../dist/inline.js';
import { Scene, initWith, initSyncWith, setDefaultInit, setSyncInit, setVariant, simdSupported, moduleVariant, compiledModule } from './core.js';

function bytes(b64) {
  if (typeof Buffer === 'function') return Buffer.from(b64, 'base64');
  const s = atob(b64);
  const out = new Uint8Array(s.length);
  for (let i = 0; i < s.length; i++) out[i] = s.charCodeAt(i);
  return out;
}

function chosen() {
  const v = simdSupported() ? 'simd128' : 'scalar';
  setVariant(v);
  return bytes(v === 'simd128' ? simd128 : scalar);
}

/** Loads the module (once; later calls return the same promise). */
export function init() {
  return initWith(chosen);
}

/** Loads the module synchronously (Node and workers; a browser's main thread may refuse). */
export function initSync() {
  if (moduleVariant()) return;
  try {
    initSyncWith(chosen());
  } catch (e) {
    if (!(e instanceof RangeError)) throw e;
    throw new Error(`kdray: this engine does not compile the module synchronously here (${e.message}): \`await init()\` first`);
  }
}

setDefaultInit(init);
// The synchronous calls (Scene.buildSync, fromBytesSync, kdray/three's computeBoundsTree)
// compile the inlined module on first use when init() has not loaded it.
setSyncInit(initSync);

export { Scene, simdSupported, moduleVariant, compiledModule };
export { InstancedScene } from './instanced.js';
