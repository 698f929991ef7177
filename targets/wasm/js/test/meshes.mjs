// Meshes for the tests and the benchmark: the repository's small Stanford bunny
// (host/scenes/meshes/bunny.ply.gz, 3,674 triangles), the fetched bunny and dragon
// (scripts/fetch-meshes.sh, data/), seeded random triangle soups, and rays.
import { readFileSync, existsSync } from 'node:fs';
import { gunzipSync } from 'node:zlib';
import { fileURLToPath } from 'node:url';
import { dirname, join } from 'node:path';

export const root = join(dirname(fileURLToPath(import.meta.url)), '../../../..');

/** Positions and indices of a binary little-endian PLY (x, y, z floats; uchar/int face lists) — the
 *  format scripts/convert-mesh.mjs writes; anything else throws. */
export function readPly(path) {
  let buf = readFileSync(path);
  if (path.endsWith('.gz')) buf = gunzipSync(buf);
  const end = buf.indexOf('end_header\n');
  const header = buf.subarray(0, end).toString('latin1');
  if (!header.includes('format binary_little_endian')) throw new Error(`${path}: not a binary little-endian PLY`);
  const nv = +header.match(/element vertex (\d+)/)[1];
  const nf = +header.match(/element face (\d+)/)[1];
  const props = header.split('element face')[0].match(/property float \w+/g).length;
  let o = end + 'end_header\n'.length;
  const positions = new Float32Array(3 * nv);
  for (let i = 0; i < nv; i++, o += 4 * props) {
    for (let k = 0; k < 3; k++) positions[3 * i + k] = buf.readFloatLE(o + 4 * k);
  }
  const indices = [];
  for (let f = 0; f < nf; f++) {
    const n = buf[o++];
    const v = [];
    for (let k = 0; k < n; k++, o += 4) v.push(buf.readInt32LE(o));
    for (let k = 1; k + 1 < n; k++) indices.push(v[0], v[k], v[k + 1]);
  }
  return { positions, indices: Uint32Array.from(indices) };
}

export function bunny() {
  return readPly(join(root, 'host/scenes/meshes/bunny.ply.gz'));
}

/** A fetched mesh from data/ (scripts/fetch-meshes.sh), or null. */
export function fetched(name) {
  for (const f of [`${name}.ply.gz`, `${name}.ply`]) {
    const p = join(root, 'data', f);
    if (existsSync(p)) return readPly(p);
  }
  return null;
}

/** A seeded generator of floats in [0, 1) (mulberry32). */
export function rng(seed) {
  let a = seed >>> 0;
  return () => {
    a = (a + 0x6d2b79f5) >>> 0;
    let t = a;
    t = Math.imul(t ^ (t >>> 15), t | 1);
    t ^= t + Math.imul(t ^ (t >>> 7), t | 61);
    return ((t ^ (t >>> 14)) >>> 0) / 4294967296;
  };
}

/** `n` random triangles in the unit cube, each with edges up to `size`, non-indexed. */
export function soup(n, seed, size = 0.2) {
  const r = rng(seed);
  const p = new Float32Array(9 * n);
  for (let t = 0; t < n; t++) {
    const c = [r(), r(), r()];
    for (let v = 0; v < 3; v++) for (let k = 0; k < 3; k++) p[9 * t + 3 * v + k] = c[k] + (r() - 0.5) * size;
  }
  return p;
}

function bounds(positions) {
  const min = [Infinity, Infinity, Infinity], max = [-Infinity, -Infinity, -Infinity];
  for (let i = 0; i < positions.length; i += 3) {
    for (let k = 0; k < 3; k++) {
      min[k] = Math.min(min[k], positions[i + k]);
      max[k] = Math.max(max[k], positions[i + k]);
    }
  }
  return { min, max };
}

/** `n` rays (8 floats each, unit directions, near 0, far Infinity): from random points on a sphere
 *  around the mesh's box towards random points inside it (most hit), seeded. */
export function rays(positions, n, seed) {
  const r = rng(seed);
  const { min, max } = bounds(positions);
  const c = [0, 1, 2].map((k) => (min[k] + max[k]) / 2);
  const radius = Math.hypot(max[0] - min[0], max[1] - min[1], max[2] - min[2]);
  const out = new Float32Array(8 * n);
  for (let i = 0; i < n; i++) {
    const z = 2 * r() - 1, a = 2 * Math.PI * r(), s = Math.sqrt(1 - z * z);
    const o = [c[0] + radius * s * Math.cos(a), c[1] + radius * s * Math.sin(a), c[2] + radius * z];
    const target = [0, 1, 2].map((k) => min[k] + r() * (max[k] - min[k]));
    const d = target.map((t, k) => t - o[k]);
    const len = Math.hypot(...d);
    out.set([...o, ...d.map((x) => x / len), 0, Infinity], 8 * i);
  }
  return out;
}
