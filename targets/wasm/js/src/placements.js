// The placements of one object of a hierarchy for kdray/three's HierarchyRaycaster: a segment
// of InstancedScene's packed placements (14 words each: the world transform as a 3×4 row-major
// f32 matrix, then two words the caster fills in — the tree's slot and the id), kept per object
// and computed again only when what it depends on changed: the object's world matrix and tree,
// and for an InstancedMesh its `count` and `instanceMatrix` (the array, or its `version`, which
// `needsUpdate = true` moves — as three.js requires to draw moved instances), for a BatchedMesh
// its matrices texture's version (`setMatrixAt` moves it) and which instances are visible and
// active, with which geometry.

export const WORDS = 14;

const same16 = (a, b) => {
  for (let k = 0; k < 16; k++) if (a[k] !== b[k]) return false;
  return true;
};

// Writes the rows of W·I (W, I column-major 4×4 at offsets 0 and `o`; I affine) as placement
// `at` of `f`; false if a number is not finite.
function rows(f, at, w, a, o) {
  for (let r = 0; r < 3; r++) {
    for (let c = 0; c < 4; c++) {
      const x = w[r] * a[o + 4 * c] + w[4 + r] * a[o + 4 * c + 1] + w[8 + r] * a[o + 4 * c + 2] + w[12 + r] * a[o + 4 * c + 3];
      if (!Number.isFinite(x)) return false;
      f[at + 4 * r + c] = x;
    }
  }
  return true;
}

const IDENTITY = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1];
const affine = (a, o) => a[o + 3] === 0 && a[o + 7] === 0 && a[o + 11] === 0 && a[o + 15] === 1;

// The object (and instance) a matrix that is not finite belongs to, named for the error.
function notFinite(object, type, instance, e) {
  const what = `${type} ${JSON.stringify(object.name)} (${object.uuid})${instance === null ? '' : `'s instance ${instance}`}`;
  return new RangeError(`kdray/three: ${what} has a world matrix that is not finite (elements ${[...e]})`);
}

/** Segments by object, kept between calls. */
export class Segments {
  constructor() {
    // Kept on the object under a symbol of this caster's: a property load where a WeakMap
    // lookup cost a measurable share of a call over a thousand objects.
    this.key = Symbol('kdray segment');
  }

  /**
   * The segment of a Mesh placing `scene`: `{ object, kind, words, scenes, locals, count }` —
   * with one tree (a Mesh, an InstancedMesh) `scene` is it and placement j is instance j; else
   * (a BatchedMesh) `scenes[j]` is placement j's tree and `locals[j]` its instance (batchId);
   * `count` the ids the object spans. Kept while unchanged (then the same object).
   */
  mesh(object, scene) {
    const e = object.matrixWorld.elements;
    const s = object[this.key];
    if (s && s.scene === scene && same16(s.world, e)) return s;
    const words = new Uint32Array(WORDS);
    if (!rows(new Float32Array(words.buffer), 0, e, IDENTITY, 0)) throw notFinite(object, object.type, null, e);
    const seg = { object, kind: 'mesh', scene, world: Float64Array.from(e), words, scenes: [scene], locals: [0], count: 1 };
    object[this.key] = seg;
    return seg;
  }

  /** The segment of an InstancedMesh (as `mesh`), or null if an instance matrix is projective. */
  instanced(object, scene) {
    const e = object.matrixWorld.elements;
    const im = object.instanceMatrix;
    const n = object.count;
    const s = object[this.key];
    if (s && s.scene === scene && s.array === im.array && s.version === im.version && s.n === n && same16(s.world, e)) return s;
    const words = new Uint32Array(WORDS * n);
    const f = new Float32Array(words.buffer);
    const a = im.array;
    for (let i = 0; i < n; i++) {
      if (!affine(a, 16 * i)) return null;
      if (!rows(f, WORDS * i, e, a, 16 * i)) throw notFinite(object, 'InstancedMesh', i, combined(e, a, 16 * i));
    }
    const seg = { object, kind: 'instanced', scene, world: Float64Array.from(e), array: a, version: im.version, n, words, scenes: [scene], locals: null, count: n };
    object[this.key] = seg;
    return seg;
  }

  /**
   * The segment of a BatchedMesh's visible, active instances (`trees`: GeometryTrees),
   * kept while its world matrix, its matrices texture's version and every instance's tree stay.
   */
  batched(object, trees) {
    const e = object.matrixWorld.elements;
    const info = object._instanceInfo;
    const texture = object._matricesTexture;
    const scenes = [], locals = [];
    for (let i = 0; i < info.length; i++) {
      if (!info[i].visible || !info[i].active) continue;
      scenes.push(trees.ofBatch(object, info[i].geometryIndex));
      locals.push(i);
    }
    const s = object[this.key];
    if (s && s.version === texture.version && s.data === texture.image.data && s.count === info.length && same16(s.world, e)
        && s.scenes.length === scenes.length && s.scenes.every((x, k) => x === scenes[k] && s.locals[k] === locals[k])) {
      return s;
    }
    const a = texture.image.data;
    const words = new Uint32Array(WORDS * scenes.length);
    const f = new Float32Array(words.buffer);
    for (let k = 0; k < locals.length; k++) {
      const i = locals[k];
      if (!affine(a, 16 * i)) return null;
      if (!rows(f, WORDS * k, e, a, 16 * i)) throw notFinite(object, 'BatchedMesh', i, combined(e, a, 16 * i));
    }
    const seg = { object, kind: 'batched', world: Float64Array.from(e), version: texture.version, data: a, words, scenes, locals, count: info.length };
    object[this.key] = seg;
    return seg;
  }
}

// The column-major product W·I (for the message of a matrix that is not finite).
function combined(w, a, o) {
  const out = [];
  for (let c = 0; c < 4; c++) for (let r = 0; r < 4; r++) out.push(w[r] * a[o + 4 * c] + w[4 + r] * a[o + 4 * c + 1] + w[8 + r] * a[o + 4 * c + 2] + w[12 + r] * a[o + 4 * c + 3]);
  return out;
}
