// The peer in the WASM throughput table: three-mesh-bvh, the BVH that three.js applications use
// for raycasting, tracing a `kdray rays` file against the same mesh in Node, closest hit only.
//
//   node three-mesh-bvh.mjs MESH.tri RAYS.bin [--repeat N] [--strategy sah|center] [--api bvh|raycaster]
//                                              [--hits OUT.bin]
//
// MESH.tri is the triangle soup that scripts/fetch-meshes.sh writes next to each .ply (u32 n, then
// n × 9 f32), so triangle i here is input triangle i in kdray. RAYS.bin is `kdray rays` output
// (n × 8 f32: origin, direction, tmin, tmax).
//
// How the peer is driven, and why:
// - the BVH is built with `strategy: SAH` by default (kdray's tree is an SAH kd-tree too); the
//   library's own default is CENTER, measured with `--strategy center`;
// - `--api bvh` (default) calls `MeshBVH.raycastFirst(ray, DoubleSide, near, far)`, the closest-hit
//   query underneath `Raycaster.firstHitOnly`, without three's per-call object and matrix overhead,
//   which favours the peer; `--api raycaster` goes through `Mesh.raycast` with `acceleratedRaycast`
//   and `raycaster.firstHitOnly = true`, as a three.js application would;
// - DoubleSide, because kdray's triangles have no back-face culling;
// - three's distances are Euclidean along a normalized direction: each ray's direction is
//   normalized and its [tmin, tmax] scaled by the direction's length, so a hit's distance divided
//   by that length is kdray's `t`. One `THREE.Ray` is reused; filling it is part of the timed loop
//   (a caller has to).
//
// Prints one line: `engine=three-mesh-bvh api= strategy= mesh= rays= hits= build_ms= trace_ms=
// mrays_s=` where trace_ms is the best of --repeat runs. --hits writes kdray's hits layout
// (f32 t, u32 input triangle, f32 u, f32 v; u = v = 0 here) to compare against `kdray trace`.

import fs from 'node:fs';
import path from 'node:path';
import { performance } from 'node:perf_hooks';
import * as THREE from 'three';
import { MeshBVH, SAH, CENTER, acceleratedRaycast } from 'three-mesh-bvh';

function fail(msg, code = 1) {
  console.error(`three-mesh-bvh: error: ${msg}`);
  process.exit(code);
}

function parseArgs(argv) {
  const opts = { repeat: 3, strategy: 'sah', api: 'bvh', hits: null, files: [] };
  for (let i = 0; i < argv.length; i++) {
    const a = argv[i];
    const value = () => {
      if (i + 1 >= argv.length) fail(`${a} needs a value`, 2);
      return argv[++i];
    };
    if (a === '--repeat') {
      opts.repeat = Number(value());
      if (!Number.isInteger(opts.repeat) || opts.repeat < 1) fail('--repeat must be a whole number ≥ 1', 2);
    } else if (a === '--strategy') {
      opts.strategy = value();
      if (!['sah', 'center'].includes(opts.strategy)) fail('--strategy must be sah or center', 2);
    } else if (a === '--api') {
      opts.api = value();
      if (!['bvh', 'raycaster'].includes(opts.api)) fail('--api must be bvh or raycaster', 2);
    } else if (a === '--hits') {
      opts.hits = value();
    } else if (a.startsWith('--')) {
      fail(`unknown option ${a}`, 2);
    } else {
      opts.files.push(a);
    }
  }
  if (opts.files.length !== 2) fail('usage: three-mesh-bvh.mjs MESH.tri RAYS.bin [--repeat N] [--strategy sah|center] [--api bvh|raycaster] [--hits OUT.bin]', 2);
  return opts;
}

/** Reads a .tri file into a Float32Array of 9 floats per triangle. */
export function readTri(file) {
  const buf = fs.readFileSync(file);
  if (buf.length < 4) fail(`${file}: too short for a .tri header`);
  const n = buf.readUInt32LE(0);
  if (buf.length !== 4 + 36 * n) fail(`${file}: header says ${n} triangles but the file has ${buf.length} bytes`);
  // Copy (the Buffer may be unaligned); the files are little-endian, as is every host Node runs on here.
  return new Float32Array(buf.buffer.slice(buf.byteOffset + 4, buf.byteOffset + buf.length));
}

/** Reads a `kdray rays` file into a Float32Array of 8 floats per ray. */
export function readRays(file) {
  const buf = fs.readFileSync(file);
  if (buf.length % 32 !== 0) fail(`${file}: ${buf.length} bytes is not a whole number of 32-byte rays`);
  return new Float32Array(buf.buffer.slice(buf.byteOffset, buf.byteOffset + buf.length));
}

function main() {
  const opts = parseArgs(process.argv.slice(2));
  const [meshFile, raysFile] = opts.files;
  const positions = readTri(meshFile);
  const rays = readRays(raysFile);
  const n = rays.length / 8;

  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute('position', new THREE.BufferAttribute(positions, 3));
  const t0 = performance.now();
  const bvh = new MeshBVH(geometry, { strategy: opts.strategy === 'sah' ? SAH : CENTER });
  const buildMs = performance.now() - t0;
  geometry.boundsTree = bvh;

  // The raycaster path: a mesh at the origin with three's accelerated raycast.
  const mesh = new THREE.Mesh(geometry, new THREE.MeshBasicMaterial({ side: THREE.DoubleSide }));
  mesh.raycast = acceleratedRaycast;
  mesh.updateMatrixWorld(true);
  const raycaster = new THREE.Raycaster();
  raycaster.firstHitOnly = true;
  const found = [];

  const ray = new THREE.Ray();
  const t = new Float32Array(n);
  const prim = new Uint32Array(n);
  const traceOnce = () => {
    let hits = 0;
    for (let i = 0; i < n; i++) {
      const o = 8 * i;
      const dx = rays[o + 3], dy = rays[o + 4], dz = rays[o + 5];
      const len = Math.sqrt(dx * dx + dy * dy + dz * dz);
      const near = rays[o + 6] * len, far = rays[o + 7] * len;
      let hit = null;
      // A ray kdray would reject (zero or non-finite direction, empty interval) is a miss.
      if (len > 0 && Number.isFinite(len) && near <= far) {
        ray.origin.set(rays[o], rays[o + 1], rays[o + 2]);
        ray.direction.set(dx / len, dy / len, dz / len);
        if (opts.api === 'bvh') {
          hit = bvh.raycastFirst(ray, THREE.DoubleSide, near, far);
        } else {
          raycaster.ray.copy(ray);
          raycaster.near = near;
          raycaster.far = far;
          found.length = 0;
          raycaster.intersectObject(mesh, false, found);
          hit = found.length > 0 ? found[0] : null;
        }
      }
      if (hit) {
        t[i] = hit.distance / len;
        // The BVH reorders the index buffer it generates, so faceIndex is its own order; the
        // soup's vertex 3k, 3k + 1, 3k + 2 is input triangle k.
        prim[i] = Math.floor(hit.face.a / 3);
        hits++;
      } else {
        t[i] = Infinity;
        prim[i] = 0xffffffff;
      }
    }
    return hits;
  };

  let best = Infinity;
  let hits = 0;
  for (let r = 0; r < opts.repeat; r++) {
    const start = performance.now();
    hits = traceOnce();
    best = Math.min(best, performance.now() - start);
  }
  if (opts.hits) {
    const out = Buffer.alloc(16 * n);
    for (let i = 0; i < n; i++) {
      out.writeFloatLE(t[i], 16 * i);
      out.writeUInt32LE(prim[i], 16 * i + 4);
    }
    fs.writeFileSync(opts.hits, out);
  }
  console.log(
    `engine=three-mesh-bvh api=${opts.api} strategy=${opts.strategy} mesh=${path.basename(meshFile)} rays=${n} hits=${hits} ` +
      `build_ms=${buildMs.toFixed(1)} trace_ms=${best.toFixed(1)} mrays_s=${(n / best / 1e3).toFixed(3)}`,
  );
}

main();
