// What a user who times once sees: each call's first runs in a fresh Node process, against the
// same calls warm. V8 runs a WebAssembly module through its baseline compiler (Liftoff) at
// first and tiers hot functions up to the optimizing one (TurboFan) while they run, so the first
// calls are slower; bench.mjs warms both engines up before it measures.
//
//   node bench/first-call.mjs [--processes N]
//
// Each of N fresh processes (default 5) times, on the bunny and 65,536 primary rays (256×256):
// loading the module (`await init()`: compiling the inlined simd128 module), the first
// Scene.build, then `raycast` (one call a ray) and `raycastMany` (one call) over all the rays,
// five passes each; the table gives the medians over the processes of pass 1 and of pass 5.
import { execFileSync } from 'node:child_process';
import { fileURLToPath } from 'node:url';
import { performance } from 'node:perf_hooks';
import os from 'node:os';

const args = process.argv.slice(2);
const median = (xs) => { const s = [...xs].sort((a, b) => a - b); return s.length % 2 ? s[(s.length - 1) / 2] : (s[s.length / 2 - 1] + s[s.length / 2]) / 2; };

if (args[0] === '--child') {
  const t0 = performance.now();
  const { Scene, init } = await import('../src/index.js');
  await init();
  const initMs = performance.now() - t0;
  const { bunny } = await import('../test/meshes.mjs');
  const { primaryRays } = await import('./primary.mjs');
  const mesh = bunny();
  const rays = primaryRays(mesh.positions, 256);
  const n = rays.length / 8;
  let t = performance.now();
  const scene = await Scene.build(mesh.positions, mesh.indices);
  const buildMs = performance.now() - t;
  const single = [], many = [];
  const hits = new Float32Array(4 * n);
  for (let pass = 0; pass < 5; pass++) {
    t = performance.now();
    for (let i = 0; i < n; i++) scene.raycast(rays.subarray(8 * i, 8 * i + 3), rays.subarray(8 * i + 3, 8 * i + 6));
    single.push(n / (performance.now() - t) / 1e3);
    t = performance.now();
    scene.raycastMany(rays, hits);
    many.push(n / (performance.now() - t) / 1e3);
  }
  console.log(JSON.stringify({ initMs, buildMs, single, many }));
} else {
  const i = args.indexOf('--processes');
  const processes = i < 0 ? 5 : +args[i + 1];
  const runs = [];
  for (let p = 0; p < processes; p++) {
    runs.push(JSON.parse(execFileSync(process.execPath, [fileURLToPath(import.meta.url), '--child'], { encoding: 'utf8' })));
  }
  const m = (f) => median(runs.map(f)).toFixed(2);
  console.log(`Node ${process.version}, ${os.cpus()[0].model}, load average ${os.loadavg()[0].toFixed(1)}; medians of ${processes} fresh processes; bunny, 65,536 primary rays`);
  console.log(`| | pass 1 (first calls) | pass 5 (warm) |\n|---|---:|---:|`);
  console.log(`| await init() ms (compile the module) | ${m((r) => r.initMs)} | |`);
  console.log(`| first Scene.build ms | ${m((r) => r.buildMs)} | |`);
  console.log(`| raycast Mrays/s | ${m((r) => r.single[0])} | ${m((r) => r.single[4])} |`);
  console.log(`| raycastMany Mrays/s | ${m((r) => r.many[0])} | ${m((r) => r.many[4])} |`);
}
