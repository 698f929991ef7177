// kdray/three's raycast of a whole Object3D hierarchy in one call: every Mesh, InstancedMesh
// and BatchedMesh under the root becomes instances of one InstancedScene (instanced.js), whose
// meshes are kd-trees built once per geometry (per geometry of a BatchedMesh) and kept until the
// geometry's vertices or indices change (their `version`) or it is disposed. A call collects
// the hierarchy's world matrices and builds the top level again only when they changed, casts
// the ray once through it, and returns three's Intersection objects. Objects of other kinds
// (Points, Line, Sprite, SkinnedMesh, meshes with morph targets or a projective world matrix)
// are cast by their own `raycast`, and their intersections merged.
import { Matrix4, Vector3, Vector2, DoubleSide, BackSide } from 'three';
import { InstancedScene, placeWords } from './instanced.js';
import { GeometryTrees } from './trees.js';
import { Segments, WORDS } from './placements.js';

const _m = new Matrix4();
const _w = new Matrix4();
const _a = new Vector3();
const _b = new Vector3();
const _c = new Vector3();

// How the caster takes an object: 'mesh', 'instanced', 'batched' through the top level; null
// for three's own raycast (other kinds, skinned or morphed meshes, a projective world matrix);
// 'skip' for what three's raycast would not hit either (no material, fewer than 3 corners).
function kindOf(object) {
  if (!object.isMesh || object.isSkinnedMesh) return null; // Object3D's raycast finds nothing
  const g = object.geometry;
  if (object.material === undefined || !g?.attributes?.position) return 'skip';
  const e = object.matrixWorld.elements;
  if (g.morphAttributes?.position?.length || e[3] !== 0 || e[7] !== 0 || e[11] !== 0 || e[15] !== 1) return null;
  if (object.isBatchedMesh) return 'batched';
  if ((g.index ? g.index.count : g.attributes.position.count) < 3) return 'skip';
  return object.isInstancedMesh ? 'instanced' : 'mesh';
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
    this.trees = new GeometryTrees(options.build, () => this.dispose());
    this.segments = new Segments();
    this.top = null; // the InstancedScene of the last call
    this.slots = new Map(); // its meshes: Scene → index
    this.placed = []; // the segments it places (placements.js), in id order
    this.placedBases = []; // the first id of each
    this.segs = []; // the segments and first ids of this call
    this.bases = [];
  }

  /** Frees the top level (the trees stay with their geometries until those are disposed). */
  dispose() {
    this.top?.dispose();
    this.top = null;
    this.slots = new Map();
    this.placed = [];
    this.placedBases = [];
  }

  /** As three's `raycaster.intersectObject(object, recursive, intersects)`. */
  intersectObject(raycaster, object, recursive = true, intersects = []) {
    return this.intersectObjects(raycaster, [object], recursive, intersects);
  }

  /** As three's `raycaster.intersectObjects(objects, recursive, intersects)`. */
  intersectObjects(raycaster, objects, recursive = true, intersects = []) {
    // Per call, only the two arrays below are filled (kept between calls, no object a mesh):
    // casting a ray is the point, collecting the hierarchy the overhead.
    const others = [];
    const segs = this.segs;
    const bases = this.bases;
    segs.length = 0;
    bases.length = 0;
    let nextId = 0;
    const { segments, trees, includeHidden } = this;
    const layers = raycaster.layers;
    const visit = (object) => {
      if (!includeHidden && object.visible === false) return;
      if (object.layers.test(layers)) {
        const kind = kindOf(object);
        let seg = null;
        if (kind === 'mesh') seg = segments.mesh(object, trees.of(object.geometry));
        else if (kind === 'instanced') seg = segments.instanced(object, trees.of(object.geometry));
        else if (kind === 'batched') seg = segments.batched(object, trees);
        if (seg) {
          segs.push(seg);
          bases.push(nextId);
          nextId += seg.count;
        } else if (kind !== 'skip') others.push(object);
      }
      if (recursive) {
        const children = object.children;
        for (let i = 0; i < children.length; i++) visit(children[i]);
      }
    };
    for (const object of objects) visit(object);
    if (nextId >= 2 ** 32) throw new RangeError(`kdray/three: ${nextId} instances, more than ids hold (2^32)`);
    const found = [];
    if (this.#update(segs, bases)) this.#cast(raycaster, found);
    for (const object of others) object.raycast(raycaster, found);
    if (found.length > 1) found.sort((x, y) => x.distance - y.distance);
    for (const hit of found) intersects.push(hit);
    return intersects;
  }

  // The top level of these segments: kept when they are the last placed (the same objects,
  // each unchanged); otherwise placed again (and made again with the trees in use when one is
  // new). Returns whether anything is placed.
  #update(segs, bases) {
    const last = this.placed;
    if (this.top && last.length === segs.length) {
      let same = true;
      for (let i = 0; same && i < segs.length; i++) same = segs[i] === last[i];
      if (same) return segs.length > 0;
    }
    if (segs.length === 0) {
      this.dispose();
      return false;
    }
    let fresh = !this.top;
    for (const seg of segs) {
      for (const scene of seg.scenes) fresh ||= !this.slots.has(scene);
    }
    if (fresh) {
      const slots = new Map();
      for (const seg of segs) for (const scene of seg.scenes) if (!slots.has(scene)) slots.set(scene, slots.size);
      const top = new InstancedScene([...slots.keys()]);
      this.dispose();
      [this.top, this.slots] = [top, slots];
    }
    let total = 0;
    for (const seg of segs) total += seg.words.length;
    const words = new Uint32Array(total);
    let at = 0;
    segs.forEach((seg, i) => {
      words.set(seg.words, at);
      const n = seg.words.length / WORDS;
      if (seg.scene) {
        // One tree, instances 0 … n − 1 (a Mesh, an InstancedMesh).
        const slot = this.slots.get(seg.scene);
        for (let j = 0; j < n; j++, at += WORDS) {
          words[at + 12] = slot;
          words[at + 13] = bases[i] + j;
        }
      } else {
        for (let j = 0; j < n; j++, at += WORDS) {
          words[at + 12] = this.slots.get(seg.scenes[j]);
          words[at + 13] = bases[i] + seg.locals[j];
        }
      }
    });
    placeWords(this.top, words);
    this.placed = segs.slice();
    this.placedBases = bases.slice();
    return true;
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
    const k = findSource(this.placedBases, hit.id);
    const src = this.placed[k];
    const object = src.object;
    const instance = hit.id - this.placedBases[k];
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

// The index of the segment whose ids hold `id` (`bases`: each one's first id, ascending).
function findSource(bases, id) {
  let lo = 0, hi = bases.length - 1;
  while (lo < hi) {
    const mid = (lo + hi + 1) >> 1;
    if (bases[mid] <= id) lo = mid;
    else hi = mid - 1;
  }
  return lo;
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
