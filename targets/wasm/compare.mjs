// Renders a scene with the kdray WASM module under Node and compares it with the host's render:
// the checksum of the linear pixels (FNV-1a of their f32 bits, what `kdray render --checksum`
// prints) and every byte of the 8-bit sRGB image against the host's PNG.
//
//   node compare.mjs MODULE.wasm SCENE.kdt SCENE.kdr HOST.png WIDTH HEIGHT SPP HOST_CHECKSUM
//
// Prints one line: `<module> checksum=… host=… pixels=N differing=N match=yes|no`; exits 1 on no.
// No npm packages: the PNG is decoded with node:zlib.
import { readFileSync } from "node:fs";
import { inflateSync } from "node:zlib";
import { basename } from "node:path";

const [wasmPath, kdtPath, kdrPath, pngPath, w, h, s, hostSum] = process.argv.slice(2);
const [width, height, spp] = [w, h, s].map(Number);

const { instance } = await WebAssembly.instantiate(readFileSync(wasmPath), {});
const kd = instance.exports;
const mem = () => kd.memory.buffer;

/** Copies a file's bytes into a fresh kd_alloc region; returns [address, words]. */
function place(path) {
  const bytes = readFileSync(path);
  const ptr = kd.kd_alloc(bytes.length);
  if (ptr === 0) throw new Error(`kd_alloc(${bytes.length}) failed`);
  new Uint8Array(mem(), ptr, bytes.length).set(bytes);
  return [ptr, bytes.length / 4];
}

function check(status, what) {
  if (status >= 0) return status;
  const buf = kd.kd_alloc(256);
  const n = kd.kd_error(buf, 256);
  const text = n > 0 ? new TextDecoder().decode(new Uint8Array(mem(), buf, n)) : "";
  throw new Error(`${what}: status ${status} ${text}`);
}

const [scenePtr, sceneWords] = place(kdtPath);
const [descPtr, descWords] = place(kdrPath);
check(kd.kd_load(scenePtr, sceneWords, descPtr, descWords), "kd_load");
const info = kd.kd_alloc(48);
check(kd.kd_info(info), "kd_info");
const [, , , , seedLo, seedHi] = new Uint32Array(mem(), info, 12);

const pixels = width * height;
const linear = kd.kd_alloc(pixels * 12);
const rgba = kd.kd_alloc(pixels * 4);
// Row bands as a page would render them progressively; packets (single = 0).
const band = 8;
for (let row = 0; row < height; row += band) {
  const rows = Math.min(band, height - row);
  const out = linear + row * width * 12;
  check(kd.kd_render(row, rows, width, height, spp, seedLo, seedHi, 0, out), "kd_render");
}
check(kd.kd_to_rgba(linear, pixels, 1.0, rgba), "kd_to_rgba");

// FNV-1a over the f32 bits, little-endian bytes (kdray_core::words::Fnv1a::pixels).
let hash = 0x811c9dc5;
for (const byte of new Uint8Array(mem(), linear, pixels * 12)) {
  hash = Math.imul(hash ^ byte, 0x01000193) >>> 0;
}
const sum = hash.toString(16).padStart(8, "0");

const host = decodePng(readFileSync(pngPath));
const ours = new Uint8Array(mem(), rgba, pixels * 4);
let differing = 0;
if (host.width !== width || host.height !== height) {
  differing = pixels;
} else {
  for (let p = 0; p < pixels; p++) {
    for (let c = 0; c < 3; c++) {
      if (ours[p * 4 + c] !== host.rgb[p * 3 + c]) {
        differing++;
        break;
      }
    }
  }
}
const match = sum === hostSum && differing === 0;
console.log(
  `${basename(wasmPath, ".wasm")} checksum=${sum} host=${hostSum} pixels=${pixels} ` +
    `differing=${differing} match=${match ? "yes" : "no"}`,
);
process.exit(match ? 0 : 1);

/** An 8-bit RGB, non-interlaced PNG (what `kdray render` writes): { width, height, rgb }. */
function decodePng(buf) {
  let at = 8;
  let width = 0, height = 0;
  const idat = [];
  while (at < buf.length) {
    const len = buf.readUInt32BE(at);
    const type = buf.toString("latin1", at + 4, at + 8);
    const data = buf.subarray(at + 8, at + 8 + len);
    if (type === "IHDR") {
      width = data.readUInt32BE(0);
      height = data.readUInt32BE(4);
      if (data[8] !== 8 || data[9] !== 2 || data[12] !== 0) {
        throw new Error("expected an 8-bit RGB non-interlaced PNG");
      }
    } else if (type === "IDAT") {
      idat.push(data);
    }
    at += 12 + len;
  }
  // Undo the per-row filters (PNG spec §9.2), 3 bytes per pixel.
  const raw = inflateSync(Buffer.concat(idat));
  const stride = width * 3;
  const rgb = new Uint8Array(stride * height);
  for (let y = 0; y < height; y++) {
    const filter = raw[y * (stride + 1)];
    const line = raw.subarray(y * (stride + 1) + 1, (y + 1) * (stride + 1));
    for (let x = 0; x < stride; x++) {
      const a = x >= 3 ? rgb[y * stride + x - 3] : 0;
      const b = y > 0 ? rgb[(y - 1) * stride + x] : 0;
      const c = x >= 3 && y > 0 ? rgb[(y - 1) * stride + x - 3] : 0;
      let pred = 0;
      if (filter === 1) pred = a;
      else if (filter === 2) pred = b;
      else if (filter === 3) pred = (a + b) >> 1;
      else if (filter === 4) {
        const p = a + b - c;
        const [pa, pb, pc] = [Math.abs(p - a), Math.abs(p - b), Math.abs(p - c)];
        pred = pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
      }
      rgb[y * stride + x] = (line[x] + pred) & 0xff;
    }
  }
  return { width, height, rgb };
}
