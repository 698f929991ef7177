// The kd-trees of kdray/three's HierarchyRaycaster, one per BufferGeometry (one per geometry of
// a BatchedMesh), built on first use and kept until the geometry's positions or index change
// (the attribute replaced, or its `version` moved by `needsUpdate`) or the geometry is disposed.
import { Scene } from './index.js';

export class GeometryTrees {
  /** `options`: Scene.build's; `onForget`: called when a geometry's trees are freed. */
  constructor(options, onForget) {
    this.options = options;
    this.onForget = onForget;
    // On the geometry under a symbol of this cache's (a property load, not a WeakMap lookup):
    // { scene, pos, idx, posVersion, idxVersion, batches }.
    this.key = Symbol('kdray trees');
  }

  #entry(geometry) {
    let t = geometry[this.key];
    if (!t) {
      t = { scene: null, batches: new Map() };
      geometry[this.key] = t;
      geometry.addEventListener('dispose', () => this.forget(geometry));
    }
    return t;
  }

  /** The tree of a whole geometry. */
  of(geometry) {
    const pos = geometry.attributes.position;
    const idx = geometry.index;
    const t = this.#entry(geometry);
    if (t.scene && t.pos === pos && t.idx === idx && t.posVersion === pos.version && t.idxVersion === idx?.version) {
      return t.scene;
    }
    t.scene?.dispose();
    t.scene = null;
    const indices = idx ? Uint32Array.from(idx.array.subarray(0, idx.count)) : undefined;
    t.scene = Scene.buildSync(positionsOf(pos, 0, pos.count), indices, this.options);
    Object.assign(t, { pos, idx, posVersion: pos.version, idxVersion: idx?.version });
    return t.scene;
  }

  /**
   * The tree of geometry `g` of a BatchedMesh: its vertices and its index range (indices made
   * relative to its first vertex), so that its faces count from the start of its range.
   */
  ofBatch(batched, g) {
    const geometry = batched.geometry;
    const pos = geometry.attributes.position;
    const idx = geometry.index;
    const info = batched._geometryInfo[g];
    const version = [pos, idx, pos.version, idx?.version, info.start, info.count, info.vertexStart, info.vertexCount];
    const t = this.#entry(geometry);
    const kept = t.batches.get(g);
    if (kept && kept.version.every((x, i) => x === version[i])) return kept.scene;
    kept?.scene.dispose();
    t.batches.delete(g);
    let scene;
    if (idx) {
      const indices = new Uint32Array(info.count);
      for (let i = 0; i < info.count; i++) indices[i] = idx.getX(info.start + i) - info.vertexStart;
      scene = Scene.buildSync(positionsOf(pos, info.vertexStart, info.vertexCount), indices, this.options);
    } else {
      scene = Scene.buildSync(positionsOf(pos, info.start, info.count), undefined, this.options);
    }
    t.batches.set(g, { scene, version });
    return scene;
  }

  /** Frees a geometry's trees (its 'dispose' event calls this). */
  forget(geometry) {
    const t = geometry[this.key];
    if (!t) return;
    delete geometry[this.key];
    this.onForget(); // a top level may place the trees: it goes first
    t.scene?.dispose();
    for (const b of t.batches.values()) b.scene.dispose();
  }
}

// Float32 positions of vertices `first .. first + count` (a view where the attribute is a plain
// Float32Array of 3 a vertex, else a copy).
function positionsOf(pos, first, count) {
  if (!pos.isInterleavedBufferAttribute && pos.array instanceof Float32Array && pos.itemSize === 3) {
    return pos.array.subarray(3 * first, 3 * (first + count));
  }
  const out = new Float32Array(3 * count);
  for (let i = 0; i < count; i++) {
    out[3 * i] = pos.getX(first + i);
    out[3 * i + 1] = pos.getY(first + i);
    out[3 * i + 2] = pos.getZ(first + i);
  }
  return out;
}
