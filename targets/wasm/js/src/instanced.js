// InstancedScene: a scene of many meshes — instances of built scenes (Scene objects, none
// copied) placed by affine transforms, each with an id its hits report — over the module's top
// level (module/src/instances.rs: the host's kdray::instances::top_level builds it, the core's
// InstancedScene walks it). Placing instances again rebuilds the top level only.

import { Scene, internal } from './core.js';
import { vec3, interval, checkSize } from './args.js';

// Words of one placement in the module: a 3×4 row-major transform (12 f32), the mesh's index
// and the id (u32).
const WORDS = 14;

const registry = typeof FinalizationRegistry === 'function'
  ? new FinalizationRegistry((h) => { if (h.handle && h.generation === internal.generation()) internal.exports().kdj_top_drop(h.handle); })
  : null;

/** Internal (kdray/three): places packed placements, 14 words each. */
export let placeWords = null;

/** A scene of many meshes: instances of `Scene`s placed by transforms, with ids. */
export class InstancedScene {
  #meshes;
  #watertight;
  #held = { handle: 0, generation: -1 }; // the top level's handle, of the instance it lives in
  #words = new Uint32Array(0); // the last placements, kept to place them again after a restart
  #placed = 0;
  #disposed = false;
  #f32 = null;
  #u32 = null;

  /**
   * `meshes`: the `Scene`s that instances place (an instance names one by its index here);
   * `options.watertight`: the watertight kernel for every query. Nothing is placed until
   * `setInstances`.
   */
  constructor(meshes, options) {
    if (!Array.isArray(meshes)) throw new TypeError('kdray: InstancedScene takes an Array of Scene objects');
    meshes.forEach((m, i) => {
      if (!(m instanceof Scene)) throw new TypeError(`kdray: meshes[${i}] is not a kdray Scene`);
    });
    if (options != null && (typeof options !== 'object' || Object.keys(options).some((k) => k !== 'watertight'))) {
      throw new TypeError('kdray: InstancedScene\'s options are { watertight }');
    }
    if (options?.watertight !== undefined && typeof options.watertight !== 'boolean') {
      throw new TypeError('kdray: options.watertight must be true or false');
    }
    this.#meshes = meshes.slice();
    this.#watertight = !!options?.watertight;
    this.#open();
    registry?.register(this, this.#held, this);
  }

  // A top level in the current instance over the meshes' handles, with the last placements.
  #open() {
    const kd = internal.exports();
    const handles = new Uint32Array(Math.max(1, this.#meshes.length));
    this.#meshes.forEach((m, i) => {
      try {
        handles[i] = internal.handle(m);
      } catch {
        throw new Error(`kdray: InstancedScene: meshes[${i}] was disposed`);
      }
    });
    const top = internal.guarded(() => withBuffer(kd, handles, (p) => kd.kdj_top_new(p, this.#meshes.length)), 'new InstancedScene');
    if (top < 0) throw internal.failure(kd, top, 'InstancedScene');
    this.#held.handle = top;
    this.#held.generation = internal.generation();
    if (this.#words.length) this.#place(this.#words);
  }

  #kd() {
    if (this.#disposed) throw new Error('kdray: the instanced scene was disposed');
    if (this.#held.generation !== internal.generation()) this.#open(); // the module restarted
    const kd = internal.exports();
    if (this.#f32 === null || this.#f32.byteLength === 0 || this.#f32.buffer !== kd.memory.buffer) {
      this.#f32 = new Float32Array(kd.memory.buffer);
      this.#u32 = new Uint32Array(kd.memory.buffer);
    }
    return kd;
  }

  /** Whether queries use the watertight kernel. */
  get watertight() {
    return this.#watertight;
  }

  /** The meshes, as given. */
  get meshes() {
    return this.#meshes.slice();
  }

  /**
   * Places the instances, replacing those placed before (the top level is built again; the
   * meshes' trees are not). `meshes`: each instance's mesh (an index into the constructor's
   * array); `transforms`: 12 numbers an instance, the object → world 3×4 matrix row by row
   * (m00 m01 m02 tx, m10 m11 m12 ty, m20 m21 m22 tz); `ids`: each instance's id (a u32; default:
   * its index). An instance whose transform has no inverse (a scale of 0) is left out. Returns
   * how many were placed.
   */
  setInstances({ meshes, transforms, ids } = {}) {
    const n = meshes?.length;
    if (!Number.isInteger(n)) throw new TypeError('kdray: setInstances needs meshes: an array of mesh indices');
    checkSize(WORDS * 4 * n, `${n} instances`);
    if (transforms?.length !== 12 * n) {
      throw new TypeError(`kdray: transforms must hold 12 numbers an instance (${12 * n} for ${n}), not ${transforms?.length}`);
    }
    if (ids != null && ids.length !== n) throw new TypeError(`kdray: ids must hold one id an instance (${n}), not ${ids.length}`);
    const words = new Uint32Array(WORDS * n);
    const f = new Float32Array(words.buffer);
    for (let i = 0; i < n; i++) {
      const m = meshes[i];
      if (!Number.isInteger(m) || m < 0 || m >= this.#meshes.length) {
        throw new RangeError(`kdray: meshes[${i}] is ${m}: an index into the ${this.#meshes.length} meshes`);
      }
      for (let k = 0; k < 12; k++) {
        const x = transforms[12 * i + k];
        if (typeof x !== 'number' || !Number.isFinite(x)) {
          throw new RangeError(`kdray: transforms[${12 * i + k}] is ${x} (instance ${i}): a transform must be finite`);
        }
        f[WORDS * i + k] = x;
      }
      words[WORDS * i + 12] = m;
      const id = ids == null ? i : ids[i];
      if (!Number.isInteger(id) || id < 0 || id >= 2 ** 32) throw new RangeError(`kdray: ids[${i}] is ${id}: ids are u32`);
      words[WORDS * i + 13] = id;
    }
    return this.#place(words);
  }

  // Places packed placements (14 words each; kdray/three's adapter packs them itself).
  #place(words) {
    const kd = this.#kd();
    const n = words.length / WORDS;
    const placed = internal.guarded(() => withBuffer(kd, words, (p) => kd.kdj_top_place(this.#held.handle, p, n)), 'setInstances');
    if (placed < 0) throw internal.failure(kd, placed, 'setInstances');
    this.#words = words;
    this.#placed = placed;
    return placed;
  }

  static {
    placeWords = (scene, words) => scene.#place(words);
  }

  /** instances (placed), nodes and depth of the tree over them, world bounds. */
  get info() {
    const kd = this.#kd();
    const out = new Uint32Array(9);
    internal.guarded(() => withBuffer(kd, out, (p) => {
      kd.kdj_top_info(this.#held.handle, p);
      out.set(new Uint32Array(kd.memory.buffer, p, 9));
    }), 'info');
    const f = new Float32Array(out.buffer);
    return { instances: out[0], nodes: out[1], depth: out[2], bounds: { min: [f[3], f[4], f[5]], max: [f[6], f[7], f[8]] } };
  }

  /**
   * The closest hit along `origin + t·direction` with near < t < far over every instance:
   * `{ distance, faceIndex, id, point, u, v, normal }` or null — `faceIndex` in its mesh's
   * input, `id` the instance's, `normal` the unit geometric normal of the triangle as placed
   * (its counter-clockwise side; mirrored transforms mirror it).
   */
  raycast(origin, direction, near = 0, far = Infinity) {
    const kd = this.#kd();
    const [ox, oy, oz] = vec3(origin, 'origin');
    const [dx, dy, dz] = vec3(direction, 'direction');
    if (typeof near !== 'number' || typeof far !== 'number' || near !== near || far !== far) interval(near, far);
    let r;
    try {
      r = kd.kdj_top_raycast(this.#held.handle, this.#watertight ? 1 : 0, ox, oy, oz, dx, dy, dz, near, far);
    } catch (e) {
      throw internal.trapped(e, 'raycast');
    }
    if (r <= 0) {
      if (r < 0) throw internal.failure(kd, r, 'raycast');
      return null;
    }
    const at = resultAt(kd);
    const f = this.#f32;
    const t = f[at];
    const [nx, ny, nz] = [f[at + 5], f[at + 6], f[at + 7]];
    const len = Math.hypot(nx, ny, nz) || 1;
    return {
      distance: t,
      faceIndex: this.#u32[at + 1],
      id: this.#u32[at + 4],
      point: [ox + t * dx, oy + t * dy, oz + t * dz],
      u: f[at + 2],
      v: f[at + 3],
      normal: [nx / len, ny / len, nz / len],
    };
  }

  /** Whether anything lies along the ray with near < t < far. */
  occluded(origin, direction, near = 0, far = Infinity) {
    const kd = this.#kd();
    const o = vec3(origin, 'origin');
    const d = vec3(direction, 'direction');
    interval(near, far);
    const r = internal.guarded(() => kd.kdj_top_occluded(this.#held.handle, this.#watertight ? 1 : 0, o[0], o[1], o[2], d[0], d[1], d[2], near, far), 'occluded');
    if (r < 0) throw internal.failure(kd, r, 'occluded');
    return r === 1;
  }

  /**
   * Closest hits of many rays: `rays` 8 floats a ray (origin, direction, near, far); returns
   * `hits` (or a new Float32Array) with 5 floats a ray: distance (Infinity for a miss), then as
   * u32 bits the face index, then u, v, then as u32 bits the instance's id (both ids 0xFFFFFFFF
   * for a miss).
   */
  raycastMany(rays, hits) {
    if (!(rays instanceof Float32Array) || rays.length % 8 !== 0) {
      throw new TypeError('kdray: rays must be a Float32Array of 8 floats a ray (origin, direction, near, far)');
    }
    const n = rays.length / 8;
    checkSize(52 * n, `${n} rays and their hits`);
    if (hits !== undefined && (!(hits instanceof Float32Array) || hits.length < 5 * n)) {
      throw new TypeError(`kdray: hits must be a Float32Array of at least ${5 * n} floats (5 a ray)`);
    }
    const kd = this.#kd();
    hits ??= new Float32Array(5 * n);
    if (n === 0) return hits;
    return internal.guarded(() => withBuffer(kd, rays, (r) => withBuffer(kd, new Uint8Array(20 * n), (h) => {
      const count = kd.kdj_top_raycast_many(this.#held.handle, this.#watertight ? 1 : 0, r, n, h);
      if (count < 0) throw internal.failure(kd, count, 'raycastMany');
      hits.set(new Float32Array(kd.memory.buffer, h, 5 * n));
      return hits;
    })), 'raycastMany');
  }

  /** Frees the top level (the meshes stay; each is freed by its own dispose()). */
  dispose() {
    if (this.#disposed) return;
    this.#disposed = true;
    registry?.unregister(this);
    if (this.#held.generation === internal.generation()) internal.exports().kdj_top_drop(this.#held.handle);
    this.#held.handle = 0;
  }
}

// kdj_top_result's address in f32s (a static of the instance: it moves only with a new one).
let resultInstance = null;
let resultWords = 0;
function resultAt(kd) {
  if (resultInstance !== kd) {
    resultInstance = kd;
    resultWords = kd.kdj_top_result() >>> 2;
  }
  return resultWords;
}

// Runs `f` with a module buffer holding a copy of `array`, freed afterwards.
function withBuffer(kd, array, f) {
  const bytes = new Uint8Array(array.buffer, array.byteOffset, array.byteLength);
  const p = kd.kdj_alloc(Math.max(1, bytes.length)) >>> 0;
  if (p === 0) throw internal.outOfMemory(kd, `${bytes.length} bytes`);
  try {
    new Uint8Array(kd.memory.buffer, p, bytes.length).set(bytes);
    return f(p);
  } finally {
    kd.kdj_free(p);
  }
}
