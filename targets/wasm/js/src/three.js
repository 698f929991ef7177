// kdray/three: three-mesh-bvh's extension functions in the same shape, over a kdray kd-tree, so
// that switching a project over is the import line:
//   import { computeBoundsTree, disposeBoundsTree, acceleratedRaycast } from 'kdray/three';
//   THREE.BufferGeometry.prototype.computeBoundsTree = computeBoundsTree;
//   THREE.BufferGeometry.prototype.disposeBoundsTree = disposeBoundsTree;
//   THREE.Mesh.prototype.raycast = acceleratedRaycast;
//   await init();                      // optional: loads the module ahead of the first build
//   geometry.computeBoundsTree();
// acceleratedRaycast returns three's Intersection objects, as Mesh.raycast does: it honours
// raycaster.firstHitOnly, near and far, the mesh's world matrix, the material's side and, with an
// array of materials, geometry.groups (and each face's materialIndex).
import { Mesh, Matrix4, Vector3, Vector2, DoubleSide, BackSide } from 'three';
import { Scene, init, initSync } from './index.js';

export { init };

// three's own Mesh.raycast, kept before anyone replaces it with acceleratedRaycast: the fallback
// for meshes without a tree (calling Mesh.prototype.raycast then would call acceleratedRaycast).
const threeRaycast = Mesh.prototype.raycast;

/** The kd-tree of a BufferGeometry, kept as `geometry.boundsTree`. */
export class KdTree {
  constructor(geometry, options = {}) {
    const pos = geometry.attributes.position;
    if (!pos) throw new Error('kdray/three: the geometry has no position attribute');
    let positions;
    if (pos.isInterleavedBufferAttribute || !(pos.array instanceof Float32Array) || pos.itemSize !== 3) {
      positions = new Float32Array(3 * pos.count);
      for (let i = 0; i < pos.count; i++) {
        positions[3 * i] = pos.getX(i);
        positions[3 * i + 1] = pos.getY(i);
        positions[3 * i + 2] = pos.getZ(i);
      }
    } else {
      positions = pos.array.subarray(0, 3 * pos.count);
    }
    initSync();
    this.scene = Scene.buildSync(positions, geometry.index ?? undefined, options);
    this.geometry = geometry;
  }

  dispose() {
    this.scene.dispose();
  }
}

/** Builds `this.boundsTree` (a BufferGeometry method, as in three-mesh-bvh). */
export function computeBoundsTree(options) {
  this.boundsTree?.dispose?.();
  this.boundsTree = new KdTree(this, options);
  return this.boundsTree;
}

/** Frees `this.boundsTree`. */
export function disposeBoundsTree() {
  this.boundsTree?.dispose?.();
  this.boundsTree = null;
}

const _inverse = new Matrix4();
const _o = new Vector3();
const _e = new Vector3();
const _a = new Vector3();
const _b = new Vector3();
const _c = new Vector3();

// The group (and its material) that holds triangle `face`, or null when it is drawn by none.
function groupOf(geometry, materials, face) {
  const first = 3 * face;
  for (const g of geometry.groups) {
    if (first >= g.start && first < g.start + g.count) {
      const m = materials[g.materialIndex];
      return m ? { material: m, materialIndex: g.materialIndex } : null;
    }
  }
  return null;
}

// Whether the material's side lets a hit on a face facing the ray that way count.
function sideAllows(side, frontFacing) {
  if (side === DoubleSide) return true;
  return side === BackSide ? !frontFacing : frontFacing;
}

function corners(geometry, face) {
  const idx = geometry.index;
  return idx ? [idx.getX(3 * face), idx.getX(3 * face + 1), idx.getX(3 * face + 2)] : [3 * face, 3 * face + 1, 3 * face + 2];
}

function interpolate(attr, [a, b, c], [wa, wb, wc], target) {
  target.fromBufferAttribute(attr, a).multiplyScalar(wa);
  target.addScaledVector(_a.fromBufferAttribute(attr, b), wb);
  target.addScaledVector(_a.fromBufferAttribute(attr, c), wc);
  return target;
}

// A three.js Intersection for a kdray hit in object space (t = world distance, module doc).
function intersection(mesh, hit, o, d, world, materialIndex) {
  const geometry = mesh.geometry;
  const abc = corners(geometry, hit.faceIndex);
  const pos = geometry.attributes.position;
  _a.fromBufferAttribute(pos, abc[0]);
  _b.fromBufferAttribute(pos, abc[1]);
  _c.fromBufferAttribute(pos, abc[2]);
  const normal = new Vector3().subVectors(_c, _b).cross(_a.clone().sub(_b)).normalize();
  const point = new Vector3(o[0] + hit.distance * d[0], o[1] + hit.distance * d[1], o[2] + hit.distance * d[2]).applyMatrix4(world);
  const w = [1 - hit.u - hit.v, hit.u, hit.v];
  const out = {
    distance: hit.distance,
    point,
    object: mesh,
    face: { a: abc[0], b: abc[1], c: abc[2], normal, materialIndex },
    faceIndex: hit.faceIndex,
    barycoord: new Vector3(w[0], w[1], w[2]),
  };
  const { uv, uv1, normal: vn } = geometry.attributes;
  if (uv) out.uv = interpolate(uv, abc, w, new Vector2());
  if (uv1) out.uv1 = interpolate(uv1, abc, w, new Vector2());
  if (vn) {
    out.normal = interpolate(vn, abc, w, new Vector3());
    if (out.normal.dot(_e.set(d[0], d[1], d[2])) > 0) out.normal.multiplyScalar(-1);
  }
  return out;
}

/**
 * Mesh.raycast over `geometry.boundsTree` (falls back to three's own without one). Distances are
 * world distances: the ray is taken into object space with its direction not renormalized, so
 * object-space t is the world distance and near/far apply unchanged.
 */
export function acceleratedRaycast(raycaster, intersects) {
  const tree = this.geometry?.boundsTree;
  if (!(tree instanceof KdTree) || this.material === undefined) {
    return threeRaycast.call(this, raycaster, intersects);
  }
  const { geometry, matrixWorld } = this;
  _inverse.copy(matrixWorld).invert();
  const ray = raycaster.ray;
  _o.copy(ray.origin).applyMatrix4(_inverse);
  _e.copy(ray.origin).add(ray.direction).applyMatrix4(_inverse).sub(_o);
  const o = [_o.x, _o.y, _o.z];
  const d = [_e.x, _e.y, _e.z];
  const scene = tree.scene;
  const materials = Array.isArray(this.material) ? this.material : null;
  const near = raycaster.near, far = raycaster.far;

  // The material (and group) a hit's face is drawn with, or null if it is not drawn.
  const drawnBy = (face) => {
    if (!materials) return { material: this.material, materialIndex: 0 };
    return geometry.groups.length ? groupOf(geometry, materials, face) : null;
  };
  const frontFacing = (face) => {
    const abc = corners(geometry, face);
    const pos = geometry.attributes.position;
    _a.fromBufferAttribute(pos, abc[0]);
    _b.fromBufferAttribute(pos, abc[1]).sub(_a);
    _c.fromBufferAttribute(pos, abc[2]).sub(_a);
    return _b.cross(_c).dot(_e) < 0;
  };

  if (raycaster.firstHitOnly === true) {
    // The closest hit; one the material's side (or a group without a material) skips is stepped
    // over by casting again from it.
    let from = near;
    for (;;) {
      const hit = scene.raycast(o, d, from, far);
      if (hit === null) return;
      const g = drawnBy(hit.faceIndex);
      if (g && sideAllows(g.material.side, frontFacing(hit.faceIndex))) {
        intersects.push(intersection(this, hit, o, d, matrixWorld, g.materialIndex));
        return;
      }
      from = hit.distance;
    }
  }
  for (const hit of scene.intersectAll(o, d, near, far)) {
    const g = drawnBy(hit.faceIndex);
    if (g && sideAllows(g.material.side, hit.facing === 1)) {
      intersects.push(intersection(this, hit, o, d, matrixWorld, g.materialIndex));
    }
  }
}

// A whole hierarchy in one call (Mesh, InstancedMesh and BatchedMesh through one top level):
//   THREE.Raycaster.prototype.intersectObject = acceleratedIntersectObject;
export { HierarchyRaycaster, acceleratedIntersectObject, acceleratedIntersectObjects } from './hierarchy.js';
