// The checks on what users pass to the package's calls, before anything crosses into the
// WebAssembly module: its exports take i32 sizes and typed arrays, so a wrong type or a size
// past 2³² must be refused here, with the argument's name, not wrap or be taken for another
// argument.

/** WebAssembly's limit on a module's memory, in bytes (65,536 pages of 64 KiB). */
export const MEMORY_LIMIT = 2 ** 32;

const BUILD_OPTIONS = ['watertight', 'layout', 'leaves', 'quality'];
const LOAD_OPTIONS = ['watertight'];

function checkOptions(options, known, call) {
  if (options == null) return {};
  if (typeof options !== 'object' || Array.isArray(options) || ArrayBuffer.isView(options)) {
    throw new TypeError(`kdray: ${call}'s options must be an object such as { watertight: true }, not ${describe(options)}`);
  }
  for (const key of Object.keys(options)) {
    if (!known.includes(key)) {
      const where = BUILD_OPTIONS.includes(key) ? ` (${key} applies to Scene.build: a loaded .kdt keeps its own)` : '';
      throw new TypeError(`kdray: unknown option ${JSON.stringify(key)} for ${call}: the options are ${known.join(', ')}${where}`);
    }
  }
  const w = options.watertight;
  if (w !== undefined && typeof w !== 'boolean') {
    throw new TypeError(`kdray: options.watertight must be true or false, not ${describe(w)}`);
  }
  return options;
}

/** Scene.fromBytes's options, checked: `{ watertight }`. */
export function loadOptions(options) {
  return checkOptions(options, LOAD_OPTIONS, 'Scene.fromBytes');
}

/**
 * kdj_build's `layout`, `leaves` and `quality` arguments from a build's options: `layout`
 * 'wide' (default: the tree also as eight-wide nodes with tight boxes, faster single rays) or
 * 'nodes'; `leaves` 'list' (default: index lists, whose triangles the walk gathers four at a
 * time into a SIMD test) or 'groups' (the triangles copied into groups of four: faster single
 * rays, two to four times the memory); `quality` 'fast' (default: binned planes, at most two
 * references a triangle along a path, past the depth limit only nodes of more than 32
 * triangles split: the build for a first answer) or 'high' (the exact sweep at every node, every level: a slower build of a tree that
 * traces faster, for many millions of rays). Anything else throws.
 */
export function buildFlags(options) {
  checkOptions(options, BUILD_OPTIONS, 'Scene.build');
  // Only an absent option takes its default: null is a value, and refused.
  const given = (key, fallback) => (options?.[key] === undefined ? fallback : options[key]);
  const layout = given('layout', 'wide');
  const leaves = given('leaves', 'list');
  const quality = given('quality', 'fast');
  if (layout !== 'wide' && layout !== 'nodes') {
    const retired = layout === 'blocked' ? " ('blocked' was retired: 'wide' replaces it)" : '';
    throw new TypeError(`kdray: options.layout must be 'wide' or 'nodes', not ${JSON.stringify(layout)}${retired}`);
  }
  if (leaves !== 'groups' && leaves !== 'list') {
    throw new TypeError(`kdray: options.leaves must be 'groups' or 'list', not ${JSON.stringify(leaves)}`);
  }
  if (quality !== 'fast' && quality !== 'high') {
    throw new TypeError(`kdray: options.quality must be 'fast' or 'high', not ${JSON.stringify(quality)}`);
  }
  return [layout === 'wide' ? 1 : 0, leaves === 'groups' ? 1 : 0, quality === 'fast' ? 1 : 0];
}

function describe(x) {
  if (x === null) return 'null';
  if (ArrayBuffer.isView(x)) return `a ${x.constructor.name}`;
  if (Array.isArray(x)) return 'an Array';
  if (typeof x === 'object') return `an object (${x.constructor?.name ?? 'Object'})`;
  return `${typeof x} ${String(x)}`;
}

const isBufferAttribute = (x) => x?.isBufferAttribute === true || x?.isInterleavedBufferAttribute === true;

/**
 * The build's positions, indices and options from what a caller passed: `indices` may be a
 * Uint32Array, Uint16Array, an Array of vertex numbers or a three.js BufferAttribute (a
 * geometry's `index`); an object that is none of these, in its place, is the options
 * (`Scene.build(positions, options)`). Returns `[positions, indices (Uint32Array or
 * undefined), options]`; throws naming the argument for anything else.
 */
export function meshArgs(positions, indices, options) {
  if (!(positions instanceof Float32Array)) {
    throw new TypeError(`kdray: positions must be a Float32Array (x, y, z a vertex), not ${describe(positions)}`);
  }
  if (indices != null && options === undefined && typeof indices === 'object' && !Array.isArray(indices)
      && !ArrayBuffer.isView(indices) && !isBufferAttribute(indices)) {
    return [positions, undefined, indices]; // Scene.build(positions, options)
  }
  return [positions, indexArray(indices), options];
}

function indexArray(indices) {
  if (indices == null) return undefined;
  if (indices instanceof Uint32Array) return indices;
  if (indices instanceof Uint16Array) return Uint32Array.from(indices);
  if (isBufferAttribute(indices)) {
    if (indices.isInterleavedBufferAttribute || indices.itemSize !== 1) {
      throw new TypeError('kdray: indices: a BufferAttribute of indices has itemSize 1 and is not interleaved (a geometry\'s index)');
    }
    return indexArray(indices.array.subarray(0, indices.count));
  }
  if (Array.isArray(indices)) {
    const out = new Uint32Array(indices.length);
    for (let i = 0; i < indices.length; i++) {
      const v = indices[i];
      if (!Number.isInteger(v) || v < 0 || v >= 2 ** 32) {
        throw new TypeError(`kdray: indices[${i}] is ${describe(v)}: vertex numbers are integers from 0`);
      }
      out[i] = v;
    }
    return out;
  }
  throw new TypeError(`kdray: indices must be a Uint32Array, Uint16Array, Array or three.js BufferAttribute (or omitted), not ${describe(indices)}`);
}

/** A 3-vector argument as [x, y, z]. */
export function vec3(v, name) {
  if (v == null || typeof v !== 'object') throw new TypeError(`kdray: ${name} must be an array of 3 numbers or {x, y, z}`);
  if ('x' in v) return [v.x, v.y, v.z];
  if (v.length !== 3) throw new TypeError(`kdray: ${name} must have 3 numbers, not ${v.length}`);
  return v;
}

/**
 * Checks a ray's `near` and `far`: numbers (not null, strings or BigInts, which the module's f32
 * arguments would turn into 0, a number or a throw), not NaN. Throws a TypeError or RangeError
 * naming the argument.
 */
export function interval(near, far) {
  for (const [name, x] of [['near', near], ['far', far]]) {
    if (typeof x !== 'number') {
      throw new TypeError(`kdray: ${name} must be a number, not ${describe(x)}`);
    }
    if (Number.isNaN(x)) throw new RangeError(`kdray: ${name} is NaN`);
  }
}

/** Throws unless `bytes` more bytes can fit in a module's memory (`what` names them). */
export function checkSize(bytes, what) {
  if (bytes >= MEMORY_LIMIT) {
    throw new RangeError(`kdray: ${what} take ${bytes} bytes, more than a WebAssembly module's memory holds (4 GiB)`);
  }
}
