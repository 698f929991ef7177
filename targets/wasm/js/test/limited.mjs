// The package's module with a memory limit of its own: the same bytes, its memory section
// rewritten with a maximum, so that the tests can drive it out of memory in megabytes instead of
// WebAssembly's 4 GiB.
import { readFileSync } from 'node:fs';
import { fileURLToPath } from 'node:url';

const leb = (n) => {
  const out = [];
  do {
    let b = n & 0x7f;
    n >>>= 7;
    if (n) b |= 0x80;
    out.push(b);
  } while (n);
  return out;
};

function readLeb(bytes, at) {
  let n = 0, shift = 0, b;
  do {
    b = bytes[at++];
    n += (b & 0x7f) * 2 ** shift;
    shift += 7;
  } while (b & 0x80);
  return [n, at];
}

/** dist/kdray_simd128.wasm with its memory limited to `mib` MiB. */
export function limitedModule(mib) {
  const bytes = readFileSync(fileURLToPath(new URL('../dist/kdray_simd128.wasm', import.meta.url)));
  let at = 8;
  while (at < bytes.length) {
    const id = bytes[at];
    const [size, body] = readLeb(bytes, at + 1);
    if (id === 5) {
      let [count, p] = readLeb(bytes, body);
      if (count !== 1) throw new Error(`${count} memories`);
      const flags = bytes[p++];
      const [min] = readLeb(bytes, p);
      if (flags !== 0) throw new Error(`memory flags ${flags}: already limited`);
      const section = [1, 0x01, ...leb(min), ...leb(mib * 16)];
      return new Uint8Array([...bytes.subarray(0, at), 5, ...leb(section.length), ...section, ...bytes.subarray(body + size)]);
    }
    at = body + size;
  }
  throw new Error('no memory section');
}
