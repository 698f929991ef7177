// The kdray WASM module behind a small class, for the page (app.js) and for Node
// (bench/wasm-trace.mjs): instantiation, the page-owned memory regions the exports work on, and
// the calls themselves. The exports are documented in targets/wasm/src/lib.rs.

/** A tiny module that uses one SIMD instruction: `WebAssembly.validate` says whether simd128 is there. */
const SIMD_PROBE = new Uint8Array([
  0, 97, 115, 109, 1, 0, 0, 0, 1, 5, 1, 96, 0, 1, 123, 3, 2, 1, 0, 10, 10, 1, 8, 0, 65, 0, 253, 15, 253, 98, 11,
]);

export function simdSupported() {
  return WebAssembly.validate(SIMD_PROBE);
}

/** Statuses of the module's exports (targets/wasm/src/lib.rs, `Status`). */
const STATUS = {
  '-1': 'bad memory region',
  '-2': 'not a valid scene',
  '-3': 'not a valid render description for this scene',
  '-4': 'nothing loaded',
  '-5': 'bad argument',
  '-6': 'out of memory',
};

export class Engine {
  /**
   * Instantiates the module: `bytes` if given (Node), else fetched next to the page — the simd128
   * build where the browser has WASM SIMD, the scalar build otherwise.
   */
  static async create(bytes = null, name = null) {
    let instance;
    if (bytes) {
      ({ instance } = await WebAssembly.instantiate(bytes, {}));
    } else {
      name = simdSupported() ? 'kdray_wasm_simd128.wasm' : 'kdray_wasm_scalar.wasm';
      const response = await fetch(name);
      if (!response.ok) throw new Error(`${name}: HTTP ${response.status}`);
      ({ instance } = await WebAssembly.instantiateStreaming(response, {}));
    }
    return new Engine(instance, name || 'module');
  }

  constructor(instance, name) {
    this.x = instance.exports;
    this.name = name;
    this.width = 0;
    this.height = 0;
  }

  /** The module's memory as bytes (a new view: growing memory detaches the old one). */
  bytes() {
    return new Uint8Array(this.x.memory.buffer);
  }

  /** A new zeroed region of `n` bytes in the module's memory; returns its address. */
  alloc(n) {
    const at = this.x.kd_alloc(n);
    if (at === 0) throw new Error(`out of memory (asking for ${n} bytes)`);
    return at;
  }

  /** Copies `data` (bytes) into a new region; returns its address. */
  put(data) {
    const at = this.alloc(data.length);
    this.bytes().set(data, at);
    return at;
  }

  /** Throws the module's own text for a negative status. */
  check(status) {
    if (status >= 0) return status;
    const n = this.x.kd_error(this.scratch, 1024);
    const text = n > 0 ? new TextDecoder().decode(this.bytes().slice(this.scratch, this.scratch + n)) : '';
    throw new Error(text || STATUS[status] || `error ${status}`);
  }

  /**
   * Loads a scene's words (`kdt`, bytes) and its render description (`kdr`, bytes, or null for
   * the module's framing view of a bare .kdt); `size` ([w, h] or null) overrides the
   * description's image size. Forgets the previous scene and its memory. Returns
   * { width, height, spp }; throws an Error with the module's reason if the data is refused.
   */
  load(kdt, kdr, size) {
    this.x.kd_reset();
    this.scratch = this.alloc(1024);
    for (const [what, data] of [['scene', kdt], ['render description', kdr]]) {
      if (data && data.length % 4 !== 0) throw new Error(`the ${what} has ${data.length} bytes, not a whole number of 32-bit words`);
    }
    this.kdt = { at: this.put(kdt), words: kdt.length / 4 };
    this.check(this.x.kd_load(this.kdt.at, this.kdt.words, kdr ? this.put(kdr) : 0, kdr ? kdr.length / 4 : 0));
    this.check(this.x.kd_info(this.scratch));
    const info = new Uint32Array(this.x.memory.buffer, this.scratch, 12);
    const [w, h] = size || [info[0], info[1]];
    const spp = info[2];
    this.width = w;
    this.height = h;
    this.acc = this.alloc(12 * w * h);
    this.rgba = this.alloc(4 * w * h);
    return { width: w, height: h, spp, simd128: info[11] === 1 };
  }

  /** Adds sample `sample` of every pixel in rows `row0 .. row0 + rows`; returns the rays traced. */
  accumulate(row0, rows, sample) {
    const acc = this.acc + 12 * this.width * row0;
    return this.check(this.x.kd_accumulate(row0, rows, this.width, this.height, sample, acc));
  }

  /** Rows `row0 .. row0 + rows` as RGBA8 of the accumulated sum divided by `n` (a copy). */
  resolve(row0, rows, n) {
    const pixels = this.width * rows;
    this.check(this.x.kd_to_rgba(this.acc + 12 * this.width * row0, pixels, n, this.rgba));
    return new Uint8ClampedArray(this.x.memory.buffer.slice(this.rgba, this.rgba + 4 * pixels));
  }

  /** Copies `rays` (Float32Array, 8 floats a ray) into the module for trace(); returns a handle. */
  putRays(rays) {
    const n = rays.length / 8;
    const at = this.put(new Uint8Array(rays.buffer, rays.byteOffset, rays.byteLength));
    return { at, n, hits: this.alloc(16 * n) };
  }

  /** Traces prepared rays, `packet` 1 (scalar walk), 4 or 8 (packets); returns the hit count. */
  trace(handle, packet) {
    return this.check(this.x.kd_trace(handle.at, handle.n, handle.hits, packet));
  }

  /** The hits of the last trace(), in the hits file layout (16 bytes a ray, a copy). */
  hits(handle) {
    return this.bytes().slice(handle.hits, handle.hits + 16 * handle.n);
  }
}
