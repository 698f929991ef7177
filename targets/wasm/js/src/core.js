// kdray's JavaScript API over the WebAssembly module (module/src/lib.rs: plain exports, no
// wasm-bindgen). This file knows nothing about where the module's bytes come from: index.js
// passes the inlined base64, or a user calls init() with a URL, bytes or a compiled module.

import { buildFlags, loadOptions, meshArgs, vec3, checkSize, interval } from './args.js';

export { buildFlags };

// A module with one SIMD instruction (i8x16.splat of i32.const 0, then drop): it validates only
// where WebAssembly SIMD is supported; a module with SIMD fails to load anywhere else (Safari
// before 16.4), and WebAssembly has no run-time feature detection.
const SIMD_PROBE = new Uint8Array([
  0, 97, 115, 109, 1, 0, 0, 0, 1, 4, 1, 96, 0, 0, 3, 2, 1, 0, 10, 9, 1, 7, 0, 65, 0, 253, 15, 26, 11,
]);

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
 * array), a `Response` or promise of one, or a URL (string or `URL`) to fetch — in Node a
 * `file:` URL or a path is read from the disk; with `{ scalar, simd128 }` of any of these, the
 * one this engine runs is taken.
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
    if (typeof s === 'string' || s instanceof URL) s = fetchOrRead(s);
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

// A URL's or path's bytes: in Node a path or a `file:` URL (what `import.meta.resolve` gives)
// is read from the disk, as Node's fetch cannot; anything else is fetched.
async function fetchOrRead(s) {
  if (typeof process === 'object' && process.versions?.node) {
    const scheme = /^([a-z][a-z0-9+.-]+):/i.exec(String(s))?.[1].toLowerCase();
    if (scheme === undefined || scheme === 'file') {
      const name = 'node:fs/promises'; // in a variable, so that bundlers leave it alone
      const { readFile } = await import(/* @vite-ignore */ /* webpackIgnore: true */ name);
      return readFile(scheme ? new URL(s) : s);
    }
  }
  return fetch(s);
}

/** The same, synchronously from bytes (Node, workers; browsers limit synchronous compiles). */
export function initSyncWith(bytes) {
  if (!wasm) fromModule(new WebAssembly.Module(bytes));
}

/** The scenes' instance's memory (the tests' window on it; not exported by the package). */
export function moduleMemory() {
  return wasm?.memory ?? null;
}

/** Which module is in use: 'simd128', 'scalar', or null before loading. */
export function moduleVariant() {
  return wasm ? variant ?? (wasm.kdj_alloc && 'custom') : null;
}

export function setVariant(v) {
  variant = v;
}

function exportsOrThrow() {
  if (!wasm) syncInit();
  return wasm;
}

// What a synchronous call does when the module is not loaded: the default entry compiles its
// inlined module there and then (index.js); kdray/core, which has no source, throws.
let syncInit = () => {
  throw new Error('kdray: the WebAssembly module is not loaded yet: `await init(source)` first (kdray/core)');
};

export function setSyncInit(f) {
  syncInit = f;
}

// The module's failure code when it could not get the memory a call needs (module/src/memory.rs).
const OUT_OF_MEMORY = -4;

// The module's last failure, as an Error.
function failure(kd, code, what) {
  const n = kd.kdj_error_len();
  const text = n > 0 ? new TextDecoder().decode(new Uint8Array(kd.memory.buffer, kd.kdj_error() >>> 0, n).slice()) : `error ${code}`;
  return new Error(`kdray: ${what}: ${text}`);
}

// Copies a typed array into a fresh module buffer; returns its address (unsigned: past 2 GiB
// an i32 export's result reads negative).
function put(kd, array, what) {
  const bytes = new Uint8Array(array.buffer, array.byteOffset, array.byteLength);
  checkSize(bytes.length, what);
  const p = kd.kdj_alloc(bytes.length) >>> 0;
  if (p === 0) throw outOfMemory(kd, `${what} (${bytes.length} bytes)`);
  new Uint8Array(kd.memory.buffer, p, bytes.length).set(bytes);
  return p;
}

function outOfMemory(kd, what) {
  const mib = (kd.memory.buffer.byteLength / 2 ** 20).toFixed(0);
  return new Error(`kdray: out of memory for ${what}: the module's memory is at ${mib} MiB and cannot grow enough (WebAssembly's limit: 4 GiB)`);
}

// Builds run in an instance of their own (of the same compiled module), never in the scenes':
// the builder's vectors cannot recover from a failed allocation, and an allocation failure
// there aborts — in WebAssembly a trap that leaves the instance unusable. A trapped builder is
// dropped and the next build makes another; the scenes never notice. The tree's words are then
// copied into the scenes' instance. A builder whose memory grew past BUILDER_KEEP is dropped
// too, so a large build's peak is not kept for the page's life.
let builder = null;
const BUILDER_KEEP = 256 * 2 ** 20;

function buildWords(kd, positions, indices, [layout, leaves, quality]) {
  const b = builder ?? (builder = new WebAssembly.Instance(compiled, {}).exports);
  let pos = 0, idx = 0, handle = 0;
  try {
    pos = positions.length ? put(b, positions, 'the positions') : 0;
    idx = indices ? put(b, indices.length ? indices : new Uint32Array(1), 'the indices') : 0;
    handle = b.kdj_build(pos, positions.length, idx, indices ? indices.length : 0, layout, leaves, quality);
    if (handle < 0) throw failure(b, handle, 'cannot build the mesh');
  } catch (e) {
    if (!(e instanceof WebAssembly.RuntimeError)) throw e;
    builder = null;
    const triangles = (indices ? indices.length : positions.length / 3) / 3;
    const failed = b.kdj_failed_alloc() >>> 0;
    if (failed === 0) throw new Error(`kdray: cannot build the mesh: the module failed (${e.message}): please report this mesh (${triangles} triangles)`);
    throw outOfMemory(b, `building ${triangles} triangles (an allocation of ${failed} bytes failed)`);
  } finally {
    if (builder === b) {
      if (pos) b.kdj_free(pos);
      if (idx) b.kdj_free(idx);
    }
  }
  try {
    const words = new Uint8Array(b.memory.buffer, b.kdj_words(handle) >>> 0, 4 * b.kdj_word_count(handle));
    return guarded(() => load(kd, words, 'the built tree', true), 'cannot load the built tree');
  } finally {
    b.kdj_drop(handle);
    if (b.memory.buffer.byteLength > BUILDER_KEEP) builder = null;
  }
}

// Loads .kdt bytes into the scenes' instance; returns the scene's handle. `built`: the words the
// builder instance just wrote (opened without validating them again), never bytes from outside.
function load(kd, bytes, what, built = false) {
  const p = put(kd, bytes.length ? bytes : new Uint8Array(1), what);
  let handle;
  try {
    handle = built ? kd.kdj_load_built(p, bytes.length) : kd.kdj_load(p, bytes.length);
  } finally {
    kd.kdj_free(p);
  }
  if (handle < 0) throw failure(kd, handle, handle === OUT_OF_MEMORY ? `cannot load ${what}` : 'not a valid .kdt');
  return handle;
}

// What a scene holds in the module: its handle, where its words lie (they never move: the
// module leaks them until the scene is dropped) and raycastMany's buffers. The registry frees all
// of it when a scene is collected without dispose() (it holds this record, not the scene).
const live = new Set(); // the records of the scenes not disposed

function attach(h, handle) {
  h.handle = handle;
  h.words = wasm.kdj_words(handle) >>> 0;
  h.count = wasm.kdj_word_count(handle);
  h.rays = h.hits = h.cap = 0;
}

function held(handle) {
  const h = { handle: 0, words: 0, count: 0, rays: 0, hits: 0, cap: 0, lost: false };
  attach(h, handle);
  live.add(h);
  return h;
}

function release(kd, h) {
  if (h.rays) kd.kdj_free(h.rays);
  if (h.hits) kd.kdj_free(h.hits);
  kd.kdj_drop(h.handle);
  h.rays = h.hits = h.cap = h.handle = 0;
  live.delete(h);
}

const registry = typeof FinalizationRegistry === 'function'
  ? new FinalizationRegistry((h) => { if (wasm && h.handle) release(wasm, h); })
  : null;

// The scenes' instance is replaced when a call traps in it (an allocation that cannot fail
// gracefully, with the memory full to the byte): its memory stays readable, so every live
// scene's words are copied out and loaded into a fresh instance of the same module; views of
// the old memory are refreshed by `generation`. raycastMany's buffers start again empty.
let generation = 0;

function recover() {
  const dead = wasm;
  const saved = [...live].map((h) => [h, new Uint8Array(dead.memory.buffer, h.words, 4 * h.count).slice()]);
  fromModule(compiled);
  generation++;
  for (const [h, bytes] of saved) {
    try {
      attach(h, load(wasm, bytes, 'a scene'));
    } catch {
      h.handle = 0;
      h.lost = true;
      live.delete(h);
    }
  }
}

// Runs a call into the scenes' instance; a trap there becomes an Error (after recover()).
function guarded(f, what) {
  try {
    return f();
  } catch (e) {
    throw trapped(e, what);
  }
}

function trapped(e, what) {
  if (!(e instanceof WebAssembly.RuntimeError)) return e;
  const failed = wasm.kdj_failed_alloc() >>> 0;
  recover();
  const why = failed ? `out of memory (an allocation of ${failed} bytes failed)` : `the module failed (${e.message})`;
  return new Error(`kdray: ${what}: ${why}; the module was started again with every scene reloaded`);
}

// What instanced.js needs of this module's state (not exported by the package).
let handleOf = null;

/** Internal: the scenes' instance and its helpers, for instanced.js. */
export const internal = {
  exports: () => exportsOrThrow(),
  generation: () => generation,
  handle: (scene) => handleOf(scene),
  failure,
  outOfMemory,
  guarded,
  trapped,
};

/** A triangle mesh's kd-tree, in the WebAssembly module's memory. */
export class Scene {
  static {
    // The live handle of a scene (throws for a disposed one): InstancedScene passes it to the
    // module, which pins the scene while a top level places it.
    handleOf = (scene) => {
      if (!(scene instanceof Scene)) return 0;
      scene.#kd();
      return scene.#held.handle;
    };
  }

  #watertight;
  #f32 = null; // views of the module's memory, made again when it grows
  #u32 = null;
  #i32 = null;
  #held; // the handle, the words and raycastMany's buffers (held())
  #generation = -1; // of the instance the views above are of
  #inView = null; // cached views of those buffers for the last n (no allocation per call)
  #outView = null;
  #viewN = -1;
  #viewBuffer = null;

  constructor(handle, options) {
    this.#held = held(handle);
    this.#watertight = !!options?.watertight;
    registry?.register(this, this.#held, this);
  }

  /** Builds the SAH kd-tree of a mesh. Resolves when the module is loaded and the tree built. */
  static async build(positions, indices, options) {
    await defaultInit();
    return Scene.buildSync(positions, indices, options);
  }

  /** Scene.build once the module is loaded (`await init()`). */
  static buildSync(positions, indices, options) {
    [positions, indices, options] = meshArgs(positions, indices, options);
    const flags = buildFlags(options);
    const kd = exportsOrThrow();
    return new Scene(buildWords(kd, positions, indices, flags), options);
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
    options = loadOptions(options);
    const kd = exportsOrThrow();
    const u8 = new Uint8Array(bytes.buffer, bytes.byteOffset, bytes.byteLength);
    return new Scene(guarded(() => load(kd, u8, 'the .kdt bytes'), 'Scene.fromBytes'), options);
  }

  #kd() {
    const h = this.#held;
    if (h.handle === 0) {
      throw new Error(h.lost ? 'kdray: the scene was lost: the module ran out of memory reloading it after a failure' : 'kdray: the scene was disposed');
    }
    const kd = wasm;
    // Growing the module's memory detaches the old buffer (its views read as length 0), so a
    // live view is current unless the instance was replaced; asking `memory.buffer` each call
    // cost ~30 ns of a ~200 ns raycast.
    if (this.#f32 === null || this.#f32.byteLength === 0 || this.#generation !== generation) {
      this.#f32 = new Float32Array(kd.memory.buffer);
      this.#u32 = new Uint32Array(kd.memory.buffer);
      this.#i32 = new Int32Array(kd.memory.buffer);
      this.#generation = generation;
    }
    return kd;
  }

  /** The `.kdt` bytes (a copy): `Scene.fromBytes` loads them again, `kdray info` reads them. */
  toBytes() {
    const kd = this.#kd();
    const h = this.#held;
    return new Uint8Array(kd.memory.buffer, h.words, 4 * h.count).slice();
  }

  /** Frees the tree (the scene cannot be used afterwards). */
  dispose() {
    if (this.#held.handle !== 0 && wasm) {
      registry?.unregister(this);
      release(wasm, this.#held);
    }
  }

  /** Whether queries use the watertight kernel. */
  get watertight() {
    return this.#watertight;
  }

  /** triangles, nodes, depth, bounds: { min: [x, y, z], max: [x, y, z] }. */
  get info() {
    const kd = this.#kd();
    const p = guarded(() => kd.kdj_alloc(40) >>> 0, 'scene.info');
    if (p === 0) throw outOfMemory(kd, 'scene.info');
    try {
      kd.kdj_info(this.#held.handle, p);
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
    if (typeof near !== 'number' || typeof far !== 'number' || near !== near || far !== far) interval(near, far);
    let r;
    try {
      r = kd.kdj_raycast(this.#held.handle, this.#watertight ? 1 : 0, ox, oy, oz, dx, dy, dz, near, far);
    } catch (e) {
      throw trapped(e, 'raycast');
    }
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
    interval(near, far);
    const r = guarded(() => kd.kdj_occluded(this.#held.handle, this.#watertight ? 1 : 0, o[0], o[1], o[2], d[0], d[1], d[2], near, far), 'occluded');
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
    // Sizes are checked here: 32·n and 16·n would wrap as the export's i32 arguments.
    checkSize(48 * n, `${n} rays and their hits`);
    if (hits !== undefined && (!(hits instanceof Float32Array) || hits.length < 4 * n)) {
      throw new TypeError(`kdray: hits must be a Float32Array of at least ${4 * n} floats (4 a ray)`);
    }
    this.#kd();
    hits ??= new Float32Array(4 * n);
    if (n === 0) return hits;
    return guarded(() => this.#many(rays, hits, n), 'raycastMany');
  }

  #many(rays, hits, n) {
    let kd = this.#kd();
    const h = this.#held;
    if (n > h.cap) {
      // The old buffers go first (the new ones may need their memory); if the new ones cannot
      // be had, the scene is left without buffers, as a new scene is.
      if (h.rays) kd.kdj_free(h.rays);
      if (h.hits) kd.kdj_free(h.hits);
      h.cap = h.rays = h.hits = 0;
      this.#viewN = -1;
      const r = kd.kdj_alloc(32 * n) >>> 0;
      const o = r ? kd.kdj_alloc(16 * n) >>> 0 : 0;
      if (o === 0) {
        if (r) kd.kdj_free(r);
        throw outOfMemory(kd, `${n} rays (${48 * n} bytes of buffers)`);
      }
      [h.rays, h.hits, h.cap] = [r, o, n];
    }
    kd = this.#kd();
    if (this.#viewN !== n || this.#viewBuffer !== kd.memory.buffer) {
      this.#inView = new Float32Array(kd.memory.buffer, h.rays, 8 * n);
      this.#outView = new Float32Array(kd.memory.buffer, h.hits, 4 * n);
      this.#viewN = n;
      this.#viewBuffer = kd.memory.buffer;
    }
    this.#inView.set(rays);
    const r = kd.kdj_raycast_many(h.handle, this.#watertight ? 1 : 0, h.rays, n, h.hits);
    if (r < 0) throw failure(kd, r, 'raycastMany');
    if (this.#viewBuffer !== kd.memory.buffer) {
      // The stream's scratch grew the memory: the views are detached.
      this.#viewBuffer = kd.memory.buffer;
      this.#inView = new Float32Array(kd.memory.buffer, h.rays, 8 * n);
      this.#outView = new Float32Array(kd.memory.buffer, h.hits, 4 * n);
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
    interval(near, far);
    const [n, at] = guarded(() => {
      const count = kd.kdj_intersect_all(this.#held.handle, this.#watertight ? 1 : 0, o[0], o[1], o[2], d[0], d[1], d[2], near, far);
      if (count < 0) throw failure(kd, count, 'intersectAll');
      return [count, kd.kdj_all() >>> 2];
    }, 'intersectAll');
    this.#kd();
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
    interval(near, far);
    return guarded(() => {
      const n = kd.kdj_intersect_all(this.#held.handle, this.#watertight ? 1 : 0, o[0], o[1], o[2], d[0], d[1], d[2], near, far);
      if (n < 0) throw failure(kd, n, 'crossings');
      return n;
    }, 'crossings');
  }

  /** Whether `point` is inside the closed mesh: odd crossings of a watertight ray along +x. */
  contains(point) {
    const p = vec3(point, 'point');
    const kd = this.#kd();
    return guarded(() => {
      const n = kd.kdj_intersect_all(this.#held.handle, 1, p[0], p[1], p[2], 1, 0, 0, 0, Infinity);
      if (n < 0) throw failure(kd, n, 'contains');
      return n % 2 === 1;
    }, 'contains');
  }
}

let defaultInit = () => Promise.reject(new Error('kdray: no module source: import "kdray" or call init(source)'));

export function setDefaultInit(f) {
  defaultInit = f;
}
