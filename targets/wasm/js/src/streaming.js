// 'kdray/core': the API without the inlined modules, for those who serve the .wasm files
// ('kdray/kdray_simd128.wasm', 'kdray/kdray_scalar.wasm') themselves:
//   await init({ simd128: new URL('kdray/kdray_simd128.wasm', import.meta.url),
//                scalar: new URL('kdray/kdray_scalar.wasm', import.meta.url) });
import { Scene, initWith, setDefaultInit, simdSupported, moduleVariant, compiledModule } from './core.js';

/** Loads the module from `source` (see core.js initWith). */
export function init(source) {
  if (source === undefined) throw new Error('kdray/core: init(source) needs the module: a URL, bytes, a Response or { simd128, scalar }');
  const p = initWith(source);
  setDefaultInit(() => p);
  return p;
}

export { Scene, simdSupported, moduleVariant, compiledModule };
