// kdray's JavaScript API over the WebAssembly module (module/src/lib.rs: plain exports, no
// wasm-bindgen). This file knows nothing about where the module's bytes come from: index.js
// passes the inlined base64, or a user calls init() with a URL, bytes or a compiled module.

// A module with one SIMD instruction (i8x16.splat of i32.const 0, then drop): it validates only
// where WebAssembly SIMD is supported; a module with SIMD fails to load anywhere else (Safari
// before 16.4), and WebAssembly has no run-time feature detection.
const SIMD_PROBE = new Uint8Array([
  0, 97, 115, 109, 1, 0, 0, 0, 1, 4, 1, 96, 0, 0, 3, 2, 1, 0, 10, 9, 1, 7, 0, 65, 0, 253, 15, 26, 11,
]);

/**
 * kdj_build's `layout` and `leaves` arguments from a build's options: `layout` 'nodes' (default)
 * or 'blocked'; `leaves` 'groups' (default: triangles four to a SIMD group, tested at once) or
 * 'list' (index lists: about half the memory, slower single rays). Anything else throws.
 */
export function buildFlags(options) {
  const layout = options?.layout ?? 'nodes';
  const leaves = options?.leaves ?? 'groups';
  if (layout !== 'nodes' && layout !== 'blocked') {
    throw new TypeError(`kdray: options.layout must be 'nodes' or 'blocked', not ${JSON.stringify(layout)}`);
  }
  if (leaves !== 'groups' && leaves !== 'list') {
    throw new TypeError(`kdray: options.leaves must be 'groups' or 'list', not ${JSON.stringify(leaves)}`);
  }
  return [layout === 'blocked' ? 1 : 0, leaves === 'groups' ? 1 : 0];
}

/** Whether this engine runs WebAssembly SIMD (simd128). */
export function simdSupported() {
  return typeof WebAssembly === 'object' && WebAssembly.validate(SIMD_PROBE);
}

let wasm = null; // the instance's exports once loaded
let loading = null;
let variant = null;

let resultAt = 0; // kdj_result's address in f32s (a static: it never moves)
let compiled = null;

/** The compiled module once loaded (for workers: a WebAssembly.Module can be posted to them). */
export function compiledModule() {
  return compiled;
}

function fromModule(module) {
  compiled = module;
  const instance = new WebAssembly.Instance(module, {});
  wasm = instance.exports;
  resultAt = wasm.kdj_result() >>> 2;
  return wasm;
}

/**
 * Loads the module once. `source`: a `WebAssembly.Module`, bytes (`ArrayBuffer` or a typed
 * array), a `Response` or promise of one, or a URL (string or `URL`) to fetch; with
 * `{ scalar, simd128 }` of any of these, the one this engine runs is taken.
 */
export function initWith(source) {
  if (wasm) return Promise.resolve();
  if (loading) return loading;
  loading = (async () => {
    let s = source;
    if (s && typeof s === 'object' && 'scalar' in s && 'simd128' in s) {
      variant = simdSupported() ? 'simd128' : 'scalar';
      s = s[variant];
    }
    if (typeof s === 'function') s = s();
    if (typeof s === 'string' || s instanceof URL) s = fetch(s);
    s = await s;
    let module;
    if (s instanceof WebAssembly.Module) module = s;
    else if (typeof Response !== 'undefined' && s instanceof Response) {
      module = await WebAssembly.compile(await s.arrayBuffer());
    } else module = await WebAssembly.compile(s);
    fromModule(module);
  })();
  loading.catch(() => { loading = null; });
  return loading;
}

/** The same, synchronously from bytes (Node, workers; browsers limit synchronous compiles). */
export function initSyncWith(bytes) {
  if (!wasm) fromModule(new WebAssembly.Module(bytes));
}

/** Which module is in use: 'simd128', 'scalar', or null before loading. */
export function moduleVariant() {
  return wasm ? variant ?? (wasm.kdj_alloc && 'custom') : null;
}

export function setVariant(v) {
  variant = v;
}

function exportsOrThrow() {
  if (!wasm) {
    throw new Error('kdray: the WebAssembly module is not loaded yet: `await init()` (or `await Scene.build(...)`) first');
  }
  return wasm;
}

// The module's last failure, as an Error.
function failure(kd, code, what) {
  const n = kd.kdj_error_len();
  let text = `error ${code}`;
  if (n > 0) {
    const p = kd.kdj_alloc(n);
    kd.kdj_error(p, n);
    text = new TextDecoder().decode(new Uint8Array(kd.memory.buffer, p, n).slice());
    kd.kdj_free(p);
  }
  return new Error(`kdray: ${what}: ${text}`);
}

// Copies a typed array into a fresh module buffer; returns its address.
function put(kd, array) {
  const bytes = new Uint8Array(array.buffer, array.byteOffset, array.byteLength);
  const p = kd.kdj_alloc(bytes.length);
  if (p === 0) throw new Error(`kdray: out of memory (${bytes.length} bytes)`);
  new Uint8Array(kd.memory.buffer, p, bytes.length).set(bytes);
  return p;
}

function vec3(v, name) {
  if (v == null || typeof v !== 'object') throw new TypeError(`kdray: ${name} must be an array of 3 numbers or {x, y, z}`);
  if ('x' in v) return [v.x, v.y, v.z];
  if (v.length !== 3) throw new TypeError(`kdray: ${name} must have 3 numbers, not ${v.length}`);
  return v;
}

const registry = typeof FinalizationRegistry === 'function'
  ? new FinalizationRegistry((handle) => { if (wasm) wasm.kdj_drop(handle); })
  : null;

/** A triangle mesh's kd-tree, in the WebAssembly module's memory. */
export class Scene {
  #handle;
  #watertight;
  #f32 = null; // views of the module's memory, made again when it grows
  #u32 = null;
  #i32 = null;
  #rays = 0; // raycastMany's buffers in the module, and their size in rays
  #hits = 0;
  #cap = 0;
  #inView = null; // cached views of those buffers for the last n (no allocation per call)
  #outView = null;
  #viewN = -1;
  #viewBuffer = null;

  constructor(handle, options) {
    this.#handle = handle;
    this.#watertight = !!options?.watertight;
    registry?.register(this, handle, this);
  }

  /** Builds the SAH kd-tree of a mesh. Resolves when the module is loaded and the tree built. */
  static async build(positions, indices, options) {
    await defaultInit();
    return Scene.buildSync(positions, indices, options);
  }

  /** Scene.build once the module is loaded (`await init()`). */
  static buildSync(positions, indices, options) {
    if (indices != null && !(indices instanceof Uint32Array || indices instanceof Uint16Array)) {
      if (typeof indices === 'object' && !ArrayBuffer.isView(indices) && options === undefined) {
        options = indices; // Scene.build(positions, options)
        indices = undefined;
      } else {
        throw new TypeError('kdray: indices must be a Uint32Array or Uint16Array (or omitted)');
      }
    }
    if (!(positions instanceof Float32Array)) {
      throw new TypeError('kdray: positions must be a Float32Array (x, y, z a vertex)');
    }
    const [layout, leaves] = buildFlags(options);
    const kd = exportsOrThrow();
    if (indices instanceof Uint16Array) indices = Uint32Array.from(indices);
    const pos = positions.length ? put(kd, positions) : 0;
    const idx = indices ? put(kd, indices.length ? indices : new Uint32Array(1)) : 0;
    let handle;
    try {
      handle = kd.kdj_build(pos, positions.length, idx, indices ? indices.length : 0, layout, leaves);
    } finally {
      if (pos) kd.kdj_free(pos);
      if (idx) kd.kdj_free(idx);
    }
    if (handle < 0) throw failure(kd, handle, 'cannot build the mesh');
    return new Scene(handle, options);
  }

  /** A scene from the bytes of a `.kdt` (`kdray build`, or `scene.toBytes()`). */
  static async fromBytes(bytes, options) {
    await defaultInit();
    return Scene.fromBytesSync(bytes, options);
  }

  static fromBytesSync(bytes, options) {
    if (bytes instanceof ArrayBuffer || (typeof SharedArrayBuffer === 'function' && bytes instanceof SharedArrayBuffer)) {
      bytes = new Uint8Array(bytes);
    }
    if (!ArrayBuffer.isView(bytes)) throw new TypeError('kdray: fromBytes takes a Uint8Array or ArrayBuffer');
    const kd = exportsOrThrow();
    const u8 = new Uint8Array(bytes.buffer, bytes.byteOffset, bytes.byteLength);
    const p = put(kd, u8.length ? u8 : new Uint8Array(1));
    let handle;
    try {
      handle = kd.kdj_load(p, u8.length);
    } finally {
      kd.kdj_free(p);
    }
    if (handle < 0) throw failure(kd, handle, 'not a valid .kdt');
    return new Scene(handle, options);
  }

  #kd() {
    if (this.#handle === 0) throw new Error('kdray: the scene was disposed');
    const kd = wasm ?? exportsOrThrow();
    // Growing the module's memory detaches the old buffer (its views read as length 0), so a
    // live view is current; asking `memory.buffer` each call cost ~30 ns of a ~200 ns raycast.
    if (this.#f32 === null || this.#f32.byteLength === 0) {
      this.#f32 = new Float32Array(kd.memory.buffer);
      this.#u32 = new Uint32Array(kd.memory.buffer);
      this.#i32 = new Int32Array(kd.memory.buffer);
    }
    return kd;
  }

  /** The `.kdt` bytes (a copy): `Scene.fromBytes` loads them again, `kdray info` reads them. */
  toBytes() {
    const kd = this.#kd();
    const p = kd.kdj_words(this.#handle);
    const n = kd.kdj_word_count(this.#handle);
    return new Uint8Array(kd.memory.buffer, p, 4 * n).slice();
  }

  /** Frees the tree (the scene cannot be used afterwards). */
  dispose() {
    if (this.#handle !== 0 && wasm) {
      registry?.unregister(this);
      if (this.#rays) wasm.kdj_free(this.#rays);
      if (this.#hits) wasm.kdj_free(this.#hits);
      wasm.kdj_drop(this.#handle);
    }
    this.#handle = 0;
  }

  /** Whether queries use the watertight kernel. */
  get watertight() {
    return this.#watertight;
  }

  /** triangles, nodes, depth, bounds: { min: [x, y, z], max: [x, y, z] }. */
  get info() {
    const kd = this.#kd();
    const p = kd.kdj_alloc(40);
    try {
      kd.kdj_info(this.#handle, p);
      const u = new Uint32Array(kd.memory.buffer, p, 10);
      const f = new Float32Array(kd.memory.buffer, p, 10);
      return { triangles: u[0], nodes: u[1], depth: u[2], bounds: { min: [f[3], f[4], f[5]], max: [f[6], f[7], f[8]] }, simd128: u[9] === 1 };
    } finally {
      kd.kdj_free(p);
    }
  }

  /**
   * The closest hit along `origin + t·direction` with near < t < far: `{ distance, faceIndex,
   * point, u, v }` (distance = t, in lengths of `direction`; u, v the barycentrics of the
   * triangle's 2nd and 3rd vertices), or null.
   */
  raycast(origin, direction, near = 0, far = Infinity) {
    // The hot path of per-ray callers: no allocation but the answer, one call into the module
    // (the ray as arguments), and the memory views checked only because a call that allocates
    // may have replaced the buffer (this one never allocates).
    const kd = this.#kd();
    let ox, oy, oz, dx, dy, dz;
    if (origin?.length === 3) [ox, oy, oz] = [origin[0], origin[1], origin[2]];
    else [ox, oy, oz] = vec3(origin, 'origin');
    if (direction?.length === 3) [dx, dy, dz] = [direction[0], direction[1], direction[2]];
    else [dx, dy, dz] = vec3(direction, 'direction');
    const r = kd.kdj_raycast(this.#handle, this.#watertight ? 1 : 0, ox, oy, oz, dx, dy, dz, near, far);
    if (r <= 0) {
      if (r < 0) throw failure(kd, r, 'raycast');
      return null;
    }
    const at = resultAt;
    const f32 = this.#f32;
    const t = f32[at];
    return {
      distance: t,
      faceIndex: this.#u32[at + 1],
      point: [ox + t * dx, oy + t * dy, oz + t * dz],
      u: f32[at + 2],
      v: f32[at + 3],
    };
  }

  /** Whether anything lies along the ray with near < t < far. */
  occluded(origin, direction, near = 0, far = Infinity) {
    const kd = this.#kd();
    const o = vec3(origin, 'origin');
    const d = vec3(direction, 'direction');
    const r = kd.kdj_occluded(this.#handle, this.#watertight ? 1 : 0, o[0], o[1], o[2], d[0], d[1], d[2], near, far);
    if (r < 0) throw failure(kd, r, 'occluded');
    return r === 1;
  }

  /**
   * Closest hits of many rays in one call. `rays`: 8 floats a ray (origin, direction, near,
   * far). Returns `hits` (or a new Float32Array of 4 floats a ray): distance (Infinity for a
   * miss), the face index as u32 bits (0xFFFFFFFF for a miss: read it through
   * `new Uint32Array(hits.buffer, hits.byteOffset, hits.length)`), u, v. With the same `hits`
   * and ray count each call, nothing is allocated.
   */
  raycastMany(rays, hits) {
    if (!(rays instanceof Float32Array) || rays.length % 8 !== 0) {
      throw new TypeError('kdray: rays must be a Float32Array of 8 floats a ray (origin, direction, near, far)');
    }
    const n = rays.length / 8;
    if (hits === undefined) hits = new Float32Array(4 * n);
    else if (!(hits instanceof Float32Array) || hits.length < 4 * n) {
      throw new TypeError(`kdray: hits must be a Float32Array of at least ${4 * n} floats (4 a ray)`);
    }
    if (n === 0) return hits;
    let kd = this.#kd();
    if (n > this.#cap) {
      if (this.#rays) kd.kdj_free(this.#rays);
      if (this.#hits) kd.kdj_free(this.#hits);
      this.#rays = kd.kdj_alloc(32 * n);
      this.#hits = kd.kdj_alloc(16 * n);
      if (!this.#rays || !this.#hits) throw new Error(`kdray: out of memory for ${n} rays`);
      this.#cap = n;
      this.#viewN = -1;
    }
    kd = this.#kd();
    if (this.#viewN !== n || this.#viewBuffer !== kd.memory.buffer) {
      this.#inView = new Float32Array(kd.memory.buffer, this.#rays, 8 * n);
      this.#outView = new Float32Array(kd.memory.buffer, this.#hits, 4 * n);
      this.#viewN = n;
      this.#viewBuffer = kd.memory.buffer;
    }
    this.#inView.set(rays);
    const r = kd.kdj_raycast_many(this.#handle, this.#watertight ? 1 : 0, this.#rays, n, this.#hits);
    if (r < 0) throw failure(kd, r, 'raycastMany');
    if (this.#viewBuffer !== kd.memory.buffer) {
      // The stream's scratch grew the memory: the views are detached.
      this.#viewBuffer = kd.memory.buffer;
      this.#inView = new Float32Array(kd.memory.buffer, this.#rays, 8 * n);
      this.#outView = new Float32Array(kd.memory.buffer, this.#hits, 4 * n);
    }
    hits.set(this.#outView);
    return hits;
  }

  /**
   * Every hit along the ray, nearest first: `[{ distance, faceIndex, point, u, v, facing }]`
   * (facing +1 where the triangle's front, counter-clockwise side, faces the origin). In
   * watertight mode a ray through an edge or a vertex that triangles share meets each crossing
   * of the surface once, so the count's parity tells inside from outside of a closed mesh.
   */
  intersectAll(origin, direction, near = 0, far = Infinity) {
    const kd = this.#kd();
    const o = vec3(origin, 'origin');
    const d = vec3(direction, 'direction');
    const n = kd.kdj_intersect_all(this.#handle, this.#watertight ? 1 : 0, o[0], o[1], o[2], d[0], d[1], d[2], near, far);
    if (n < 0) throw failure(kd, n, 'intersectAll');
    this.#kd();
    const at = kd.kdj_all() >>> 2;
    const out = [];
    for (let i = 0; i < n; i++) {
      const k = at + 5 * i;
      const t = this.#f32[k];
      out.push({
        distance: t,
        faceIndex: this.#u32[k + 1],
        point: [o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]],
        u: this.#f32[k + 2],
        v: this.#f32[k + 3],
        facing: this.#i32[k + 4],
      });
    }
    return out;
  }

  /** How many times the ray crosses the surface (intersectAll's length, without the objects). */
  crossings(origin, direction, near = 0, far = Infinity) {
    const kd = this.#kd();
    const o = vec3(origin, 'origin');
    const d = vec3(direction, 'direction');
    const n = kd.kdj_intersect_all(this.#handle, this.#watertight ? 1 : 0, o[0], o[1], o[2], d[0], d[1], d[2], near, far);
    if (n < 0) throw failure(kd, n, 'crossings');
    return n;
  }

  /** Whether `point` is inside the closed mesh: odd crossings of a watertight ray along +x. */
  contains(point) {
    const p = vec3(point, 'point');
    const kd = this.#kd();
    const n = kd.kdj_intersect_all(this.#handle, 1, p[0], p[1], p[2], 1, 0, 0, 0, Infinity);
    if (n < 0) throw failure(kd, n, 'contains');
    return n % 2 === 1;
  }
}

let defaultInit = () => Promise.reject(new Error('kdray: no module source: import "kdray" or call init(source)'));

export function setDefaultInit(f) {
  defaultInit = f;
}
