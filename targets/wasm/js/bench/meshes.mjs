// The benchmarks' meshes by name: `bunny` (host/scenes/meshes/bunny.ply.gz, 3,674 triangles),
// `torusknot` (three.js's TorusKnotGeometry(1, 0.3, 512, 100), 102,400 triangles, the mesh
// three-mesh-bvh's own benchmarks use) and any mesh fetched into data/ (`dragon`: 871,414
// triangles; `bash scripts/fetch-meshes.sh`), or null when a fetched mesh is absent.
import * as THREE from 'three';
import { bunny, fetched } from '../test/meshes.mjs';

export function torusKnot() {
  const g = new THREE.TorusKnotGeometry(1, 0.3, 512, 100);
  return { positions: g.getAttribute('position').array, indices: Uint32Array.from(g.index.array) };
}

export function meshByName(name) {
  if (name === 'bunny') return bunny();
  if (name === 'torusknot') return torusKnot();
  return fetched(name);
}

// A geometry of its own for each BVH: three-mesh-bvh reorders the index buffer in place.
export function geometryOf({ positions, indices }) {
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.BufferAttribute(positions.slice(), 3));
  g.setIndex(new THREE.BufferAttribute(indices.slice(), 1));
  return g;
}
