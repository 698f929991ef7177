// 'kdray/core': the API without the inlined modules, for those who load the .wasm files
// ('kdray/kdray_simd128.wasm', 'kdray/kdray_scalar.wasm') themselves, before any other call:
//   await init({ simd128: import.meta.resolve('kdray/kdray_simd128.wasm'),    // Node: file: URLs,
//                scalar: import.meta.resolve('kdray/kdray_scalar.wasm') });  // paths or bytes
import { Scene, initWith, setDefaultInit, simdSupported, moduleVariant, compiledModule } from './core.js';

/** Loads the module from `source` (see core.js initWith). */
export function init(source) {
  if (source === undefined) throw new Error('kdray/core: init(source) needs the module: a URL, a path (Node), bytes, a Response or { simd128, scalar }');
  const p = initWith(source);
  setDefaultInit(() => p);
  return p;
}

export { Scene, simdSupported, moduleVariant, compiledModule };
export { InstancedScene } from './instanced.js';
