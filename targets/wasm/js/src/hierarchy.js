// kdray/three's raycast of a whole Object3D hierarchy in one call: every Mesh, InstancedMesh
// and BatchedMesh under the root becomes instances of one InstancedScene (instanced.js), whose
// meshes are kd-trees built once per geometry (per geometry of a BatchedMesh) and kept until the
// geometry's vertices or indices change (their `version`) or it is disposed. A call collects
// the hierarchy's world matrices and builds the top level again only when they changed, casts
// the ray once through it, and returns three's Intersection objects. Objects of other kinds
// (Points, Line, Sprite, SkinnedMesh, meshes with morph targets or a projective world matrix)
// are cast by their own `raycast`, and their intersections merged.
import { Matrix4, Vector3, Vector2, DoubleSide, BackSide } from 'three';
import { Scene } from './index.js';
import { InstancedScene, placeWords } from './instanced.js';

const WORDS = 14; // words of one placement (instanced.js)

const _m = new Matrix4();
const _w = new Matrix4();
const _a = new Vector3();
const _b = new Vector3();
const _c = new Vector3();

// Whether a column-major 4×4 matrix is affine (last row 0, 0, 0, 1); a projective one is left
// to three's own raycast.
function affine(e) {
  return e[3] === 0 && e[7] === 0 && e[11] === 0 && e[15] === 1;
}

/** A raycaster of whole hierarchies with its caches (trees by geometry, the last top level). */
export class HierarchyRaycaster {
  /**
   * `options.includeHidden`: cast objects whose `visible` is false (and their descendants), as
   * three's Raycaster does; by default they are skipped, as the renderer skips them.
   * `options.build`: Scene.build's options for the trees (default: its defaults).
   */
  constructor(options = {}) {
    this.includeHidden = !!options.includeHidden;
    this.buildOptions = options.build;
    this.trees = new WeakMap(); // geometry → { scene, version, batches: Map }
    this.top = null; // the InstancedScene of the last call
    this.meshes = []; // its meshes (Scenes)
    this.words = new Uint32Array(0); // its placements
    this.scratch = new Uint32Array(1024);
    this.sources = []; // [{ object, kind, base, geometry, bottomOf }] of the last collect
  }

  /** Frees the top level (the trees stay with their geometries until those are disposed). */
  dispose() {
    this.top?.dispose();
    this.top = null;
    this.meshes = [];
    this.words = new Uint32Array(0);
  }

  /** As three's `raycaster.intersectObject(object, recursive, intersects)`. */
  intersectObject(raycaster, object, recursive = true, intersects = []) {
    return this.intersectObjects(raycaster, [object], recursive, intersects);
  }

  /** As three's `raycaster.intersectObjects(objects, recursive, intersects)`. */
  intersectObjects(raycaster, objects, recursive = true, intersects = []) {
    const others = [];
    const sources = [];
    let words = this.scratch;
    let n = 0;
    const meshes = [];
    const meshIndex = new Map();
    const bottom = (scene) => {
      let i = meshIndex.get(scene);
      if (i === undefined) {
        i = meshes.length;
        meshes.push(scene);
        meshIndex.set(scene, i);
      }
      return i;
    };
    const f32 = () => new Float32Array(words.buffer);
    let f = f32();
    const push = (m, mesh, id, what) => {
      if (WORDS * (n + 1) > words.length) {
        const grown = new Uint32Array(2 * words.length);
        grown.set(words);
        words = grown;
        f = f32();
      }
      const e = m.elements;
      const at = WORDS * n;
      f[at] = e[0]; f[at + 1] = e[4]; f[at + 2] = e[8]; f[at + 3] = e[12];
      f[at + 4] = e[1]; f[at + 5] = e[5]; f[at + 6] = e[9]; f[at + 7] = e[13];
      f[at + 8] = e[2]; f[at + 9] = e[6]; f[at + 10] = e[10]; f[at + 11] = e[14];
      for (let k = 0; k < 12; k++) {
        if (!Number.isFinite(f[at + k])) throw new RangeError(`kdray/three: ${what} has a world matrix that is not finite (elements ${[...e]})`);
      }
      words[at + 12] = mesh;
      words[at + 13] = id;
      n++;
    };
    let nextId = 0;
    const visit = (object) => {
      if (!this.includeHidden && object.visible === false) return;
      if (object.layers.test(raycaster.layers)) {
        const kind = this.#kind(object);
        if (kind === null) others.push(object);
        else if (kind !== 'skip') {
          const base = nextId;
          const src = { object, kind, base, count: 0 };
          const type = kind === 'instanced' ? 'InstancedMesh' : kind === 'batched' ? 'BatchedMesh' : object.type;
          const name = `${type} ${JSON.stringify(object.name)} (${object.uuid})`;
          const w = object.matrixWorld;
          if (kind === 'mesh') {
            push(w, bottom(this.#tree(object.geometry)), base, name);
            src.count = 1;
          } else if (kind === 'instanced') {
            const mesh = bottom(this.#tree(object.geometry));
            for (let i = 0; i < object.count; i++) {
              object.getMatrixAt(i, _m);
              push(_w.multiplyMatrices(w, _m), mesh, base + i, `${name}'s instance ${i}`);
            }
            src.count = object.count;
          } else {
            const info = object._instanceInfo;
            for (let i = 0; i < info.length; i++) {
              if (!info[i].visible || !info[i].active) continue;
              const g = info[i].geometryIndex;
              object.getMatrixAt(i, _m);
              push(_w.multiplyMatrices(w, _m), bottom(this.#batchTree(object, g)), base + i, `${name}'s instance ${i}`);
            }
            src.count = info.length;
          }
          nextId += src.count;
          sources.push(src);
        }
      }
      if (recursive) for (const child of object.children) visit(child);
    };
    for (const object of objects) visit(object);
    this.scratch = words;
    this.sources = sources;

    const found = [];
    if (n > 0) {
      this.#update(meshes, words, n);
      this.#cast(raycaster, found);
    }
    for (const object of others) object.raycast(raycaster, found);
    found.sort((x, y) => x.distance - y.distance);
    for (const hit of found) intersects.push(hit);
    return intersects;
  }

  // 'mesh', 'instanced', 'batched' for what the top level takes; null for three's own raycast;
  // 'skip' for what three's raycast would not hit (no material, no triangles).
  #kind(object) {
    if (!object.isMesh || object.isSkinnedMesh) return null; // Object3D's raycast finds nothing
    const g = object.geometry;
    if (object.material === undefined || !g?.attributes?.position) return 'skip';
    if (g.morphAttributes?.position?.length || !affine(object.matrixWorld.elements)) return null;
    if (object.isBatchedMesh) return 'batched';
    const corners = g.index ? g.index.count : g.attributes.position.count;
    if (corners < 3) return 'skip';
    return object.isInstancedMesh ? 'instanced' : 'mesh';
  }

  // The tree of a geometry, built now or kept from before.
  #tree(geometry) {
    const pos = geometry.attributes.position;
    const idx = geometry.index;
    let t = this.trees.get(geometry);
    const version = `${pos.version}/${idx?.version}/${pos.count}/${idx?.count}`;
    if (t?.scene && t.version === version && t.pos === pos && t.idx === idx) return t.scene;
    if (!t) {
      t = { batches: new Map() };
      this.trees.set(geometry, t);
      geometry.addEventListener('dispose', () => this.#forget(geometry));
    }
    t.scene?.dispose();
    t.scene = Scene.buildSync(positionsOf(pos, 0, pos.count), idx ? Uint32Array.from(idx.array.subarray(0, idx.count)) : undefined, this.buildOptions);
    Object.assign(t, { version, pos, idx });
    return t.scene;
  }

  // The tree of geometry `g` of a BatchedMesh: its vertices and its index range (indices made
  // relative to its first vertex), so that faces count from its range's start.
  #batchTree(batched, g) {
    const geometry = batched.geometry;
    const pos = geometry.attributes.position;
    const idx = geometry.index;
    const info = batched._geometryInfo[g];
    const version = `${pos.version}/${idx?.version}/${info.start}/${info.count}/${info.vertexStart}/${info.vertexCount}`;
    let t = this.trees.get(geometry);
    if (!t) {
      t = { batches: new Map() };
      this.trees.set(geometry, t);
      geometry.addEventListener('dispose', () => this.#forget(geometry));
    }
    const kept = t.batches.get(g);
    if (kept && kept.version === version) return kept.scene;
    kept?.scene.dispose();
    let scene;
    if (idx) {
      const indices = new Uint32Array(info.count);
      for (let i = 0; i < info.count; i++) indices[i] = idx.getX(info.start + i) - info.vertexStart;
      scene = Scene.buildSync(positionsOf(pos, info.vertexStart, info.vertexCount), indices, this.buildOptions);
    } else {
      scene = Scene.buildSync(positionsOf(pos, info.start, info.count), undefined, this.buildOptions);
    }
    t.batches.set(g, { scene, version });
    return scene;
  }

  #forget(geometry) {
    const t = this.trees.get(geometry);
    if (!t) return;
    this.trees.delete(geometry);
    this.dispose(); // the top level may place the trees; it is made again on the next call
    t.scene?.dispose();
    for (const b of t.batches.values()) b.scene.dispose();
  }

  // The top level of these meshes and placements: kept when both are the last call's.
  #update(meshes, words, n) {
    const same = meshes.length === this.meshes.length && meshes.every((m, i) => m === this.meshes[i]);
    if (!same) {
      this.top?.dispose();
      this.top = new InstancedScene(meshes);
      this.meshes = meshes;
      this.words = new Uint32Array(0);
    }
    const old = this.words;
    let changed = old.length !== WORDS * n;
    for (let i = 0; !changed && i < old.length; i++) changed = old[i] !== words[i];
    if (changed) {
      this.words = words.slice(0, WORDS * n);
      placeWords(this.top, this.words);
    }
  }

  // The closest hit (raycaster.firstHitOnly) or every hit along the ray, stepping over hits
  // that three's raycast would not report (the material's side, a face outside the groups or the
  // draw range).
  #cast(raycaster, found) {
    const { origin, direction } = raycaster.ray;
    const o = [origin.x, origin.y, origin.z];
    const d = [direction.x, direction.y, direction.z];
    let from = raycaster.near;
    for (;;) {
      const hit = this.top.raycast(o, d, from, raycaster.far);
      if (hit === null) return;
      from = hit.distance;
      const out = this.#intersection(hit, d);
      if (out === null) continue;
      found.push(out);
      if (raycaster.firstHitOnly === true) return;
    }
  }

  // three's Intersection for a hit, or null when three's raycast would not report it.
  #intersection(hit, d) {
    const src = findSource(this.sources, hit.id);
    const object = src.object;
    const instance = hit.id - src.base;
    const geometry = object.geometry;
    let face = hit.faceIndex;
    let material = object.material;
    let materialIndex = 0;
    if (src.kind === 'batched') {
      face += object._geometryInfo[object._instanceInfo[instance].geometryIndex].start / 3;
    } else {
      const range = drawn(geometry, Array.isArray(material) ? material : null, face);
      if (range === null) return null;
      if (Array.isArray(material)) [material, materialIndex] = [material[range], range];
    }
    // Facing as three decides it, in object space: the placed normal's side of the ray, turned
    // back for a mirroring matrix (the core's normal follows the placed winding).
    if (material.side !== DoubleSide) {
      const dot = hit.normal[0] * d[0] + hit.normal[1] * d[1] + hit.normal[2] * d[2];
      const front = (dot < 0) !== (worldMatrix(src, instance, _w).determinant() < 0);
      if (material.side === BackSide ? front : !front) return null;
    }
    const abc = corners(geometry, face);
    const pos = geometry.attributes.position;
    _a.fromBufferAttribute(pos, abc[0]);
    _b.fromBufferAttribute(pos, abc[1]);
    _c.fromBufferAttribute(pos, abc[2]);
    const normal = new Vector3().subVectors(_c, _b).cross(_a.sub(_b)).normalize();
    const w = [1 - hit.u - hit.v, hit.u, hit.v];
    const out = {
      distance: hit.distance,
      point: new Vector3(hit.point[0], hit.point[1], hit.point[2]),
      object,
      face: { a: abc[0], b: abc[1], c: abc[2], normal, materialIndex },
      faceIndex: face,
      barycoord: new Vector3(w[0], w[1], w[2]),
    };
    const uv = geometry.attributes.uv;
    if (uv) {
      out.uv = new Vector2().fromBufferAttribute(uv, abc[0]).multiplyScalar(w[0])
        .addScaledVector(new Vector2().fromBufferAttribute(uv, abc[1]), w[1])
        .addScaledVector(new Vector2().fromBufferAttribute(uv, abc[2]), w[2]);
    }
    if (src.kind === 'instanced') out.instanceId = instance;
    if (src.kind === 'batched') out.batchId = instance;
    return out;
  }
}

// The source whose ids hold `id` (sources are in id order).
function findSource(sources, id) {
  let lo = 0, hi = sources.length - 1;
  while (lo < hi) {
    const mid = (lo + hi + 1) >> 1;
    if (sources[mid].base <= id) lo = mid;
    else hi = mid - 1;
  }
  return sources[lo];
}

// The world matrix of instance `i` of a source.
function worldMatrix(src, i, target) {
  const object = src.object;
  if (src.kind === 'mesh') return target.copy(object.matrixWorld);
  object.getMatrixAt(i, _m);
  return target.multiplyMatrices(object.matrixWorld, _m);
}

// Whether three's Mesh.raycast draws face `face` of a geometry: within its draw range and, with
// an array of materials, within a group (then the group's materialIndex, else 0); null if not.
function drawn(geometry, materials, face) {
  const first = 3 * face;
  const total = geometry.index ? geometry.index.count : geometry.attributes.position.count;
  const { start, count } = geometry.drawRange;
  const inRange = (a, b) => first >= Math.max(a, start) && first + 3 <= Math.min(b, start + count, total);
  if (!materials) return inRange(0, Infinity) ? 0 : null;
  for (const g of geometry.groups) {
    if (materials[g.materialIndex] && inRange(g.start, g.start + g.count)) return g.materialIndex;
  }
  return null;
}

function corners(geometry, face) {
  const idx = geometry.index;
  return idx ? [idx.getX(3 * face), idx.getX(3 * face + 1), idx.getX(3 * face + 2)] : [3 * face, 3 * face + 1, 3 * face + 2];
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

let shared = null;

/**
 * `Raycaster.prototype.intersectObject` over a shared HierarchyRaycaster:
 * `THREE.Raycaster.prototype.intersectObject = acceleratedIntersectObject;`
 */
export function acceleratedIntersectObject(object, recursive = true, intersects = []) {
  shared ??= new HierarchyRaycaster();
  return shared.intersectObject(this, object, recursive, intersects);
}

/** `Raycaster.prototype.intersectObjects` over the same shared HierarchyRaycaster. */
export function acceleratedIntersectObjects(objects, recursive = true, intersects = []) {
  shared ??= new HierarchyRaycaster();
  return shared.intersectObjects(this, objects, recursive, intersects);
}
