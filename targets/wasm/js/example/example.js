// The example page: the bunny in a three.js scene, a raycast under the mouse through kdray/three
// (a marker where it hits), and an overlay timing kdray against three-mesh-bvh on the same mesh
// and the same rays: each frame casts a batch of rays around the mouse ray through both.
// window.kdrayExample is what the headless test (browser-test.mjs) drives.
import * as THREE from 'three';
import { MeshBVH } from 'three-mesh-bvh';
import { computeBoundsTree, acceleratedRaycast, init } from 'kdray/three';
import { moduleVariant } from 'kdray';

const overlay = document.getElementById('overlay');
const BATCH = 2000;

async function loadBunny() {
  // bunny.bin: u32 vertices, u32 triangles, then the positions (f32) and indices (u32).
  const buf = await (await fetch('./bunny.bin')).arrayBuffer();
  const [nv, nf] = new Uint32Array(buf, 0, 2);
  return { positions: new Float32Array(buf, 8, 3 * nv), indices: new Uint32Array(buf, 8 + 12 * nv, 3 * nf) };
}

await init();
const { positions, indices } = await loadBunny();
const geometry = new THREE.BufferGeometry();
geometry.setAttribute('position', new THREE.BufferAttribute(positions, 3));
geometry.setIndex(new THREE.BufferAttribute(indices, 1));
geometry.computeVertexNormals();
geometry.computeBoundsTree = computeBoundsTree;
let t0 = performance.now();
geometry.computeBoundsTree();
const kdBuildMs = performance.now() - t0;
const mesh = new THREE.Mesh(geometry, new THREE.MeshNormalMaterial({ side: THREE.DoubleSide }));
mesh.raycast = acceleratedRaycast;
mesh.rotation.y = 0.4;
mesh.updateMatrixWorld(true);

// three-mesh-bvh on its own copy (it reorders the index in place), SAH like kdray.
const peerGeometry = new THREE.BufferGeometry();
peerGeometry.setAttribute('position', new THREE.BufferAttribute(positions.slice(), 3));
peerGeometry.setIndex(new THREE.BufferAttribute(indices.slice(), 1));
t0 = performance.now();
const bvh = new MeshBVH(peerGeometry, { strategy: 2 /* SAH */ });
const bvhBuildMs = performance.now() - t0;

const camera = new THREE.PerspectiveCamera(45, innerWidth / innerHeight, 0.1, 200);
camera.position.set(0, 5, 28);
camera.lookAt(0, 4.5, 0);
camera.updateMatrixWorld(true);
const scene = new THREE.Scene();
scene.add(mesh);
const marker = new THREE.Mesh(new THREE.SphereGeometry(0.15), new THREE.MeshBasicMaterial({ color: 0xff3030 }));
marker.visible = false;
scene.add(marker);

let renderer = null;
try {
  renderer = new THREE.WebGLRenderer({ antialias: true });
  renderer.setSize(innerWidth, innerHeight);
  document.body.appendChild(renderer.domElement);
} catch (e) {
  // Headless without WebGL: the raycasting and the timings still run.
  renderer = null;
}

const raycaster = new THREE.Raycaster();
raycaster.firstHitOnly = true;
const inverse = new THREE.Matrix4().copy(mesh.matrixWorld).invert();
const localRay = new THREE.Ray();

/** kdray's and three-mesh-bvh's closest hit under normalized device coordinates (x, y). */
function pick(x, y) {
  raycaster.setFromCamera(new THREE.Vector2(x, y), camera);
  const ours = raycaster.intersectObject(mesh)[0] ?? null;
  localRay.copy(raycaster.ray).applyMatrix4(inverse);
  const peer = bvh.raycastFirst(localRay, THREE.DoubleSide) ?? null;
  return {
    kdray: ours && { distance: ours.distance, faceIndex: ours.faceIndex, point: ours.point.toArray() },
    bvh: peer && { distance: peer.distance, point: peer.point.clone().applyMatrix4(mesh.matrixWorld).toArray() },
  };
}

// A batch of rays around the mouse ray, in the mesh's space, through both engines: ns a ray.
const rays = new Float32Array(8 * BATCH);
const tray = Array.from({ length: BATCH }, () => new THREE.Ray());
function timeBatch(x, y) {
  for (let i = 0; i < BATCH; i++) {
    const a = (i * 2.399963) % (2 * Math.PI), r = 0.2 * Math.sqrt(i / BATCH);
    raycaster.setFromCamera(new THREE.Vector2(x + r * Math.cos(a), y + r * Math.sin(a)), camera);
    tray[i].copy(raycaster.ray).applyMatrix4(inverse);
    const { origin: o, direction: d } = tray[i];
    rays.set([o.x, o.y, o.z, d.x, d.y, d.z, 0, Infinity], 8 * i);
  }
  const kd = geometry.boundsTree.scene;
  let t = performance.now();
  let a = 0;
  for (let i = 0; i < BATCH; i++) if (kd.raycast(tray[i].origin, tray[i].direction)) a++;
  const single = performance.now() - t;
  t = performance.now();
  kd.raycastMany(rays);
  const many = performance.now() - t;
  t = performance.now();
  let b = 0;
  for (let i = 0; i < BATCH; i++) if (bvh.raycastFirst(tray[i], THREE.DoubleSide)) b++;
  const peer = performance.now() - t;
  return { single: (single * 1e6) / BATCH, many: (many * 1e6) / BATCH, peer: (peer * 1e6) / BATCH, hits: [a, b] };
}

let mouse = { x: 0, y: 0.1 };
let last = null;
addEventListener('pointermove', (e) => {
  mouse = { x: (e.clientX / innerWidth) * 2 - 1, y: -(e.clientY / innerHeight) * 2 + 1 };
});

function frame() {
  const hit = pick(mouse.x, mouse.y);
  marker.visible = hit.kdray !== null;
  if (hit.kdray) marker.position.fromArray(hit.kdray.point);
  last = timeBatch(mouse.x, mouse.y);
  overlay.textContent =
    `kdray (${moduleVariant()}) against three-mesh-bvh, bunny, ${indices.length / 3} triangles\n` +
    `build: kdray ${kdBuildMs.toFixed(1)} ms, three-mesh-bvh (SAH) ${bvhBuildMs.toFixed(1)} ms\n` +
    `${BATCH} rays around the mouse, ns a ray: raycast ${last.single.toFixed(0)}, raycastMany ${last.many.toFixed(0)}, ` +
    `three-mesh-bvh ${last.peer.toFixed(0)} (${(last.peer / last.single).toFixed(1)}× and ${(last.peer / last.many).toFixed(1)}×)\n` +
    (hit.kdray ? `under the mouse: face ${hit.kdray.faceIndex} at ${hit.kdray.distance.toFixed(3)}` : 'under the mouse: nothing');
  if (renderer) renderer.render(scene, camera);
  requestAnimationFrame(frame);
}
frame();

window.kdrayExample = { ready: true, variant: moduleVariant(), pick, timeBatch, webgl: renderer !== null, overlay: () => overlay.textContent };
