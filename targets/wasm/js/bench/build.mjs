// Build times only, kdray against three-mesh-bvh in Node, one thread, the same meshes:
// kdray's Scene.build at both qualities (options.quality) with index-list leaves (the default)
// and with triangle groups (options.leaves), three-mesh-bvh's default (CENTER) and SAH builds.
//
//   node bench/build.mjs [--rounds N] [--meshes bunny,torusknot,dragon]
//
// Meshes: the bunny (host/scenes/meshes/bunny.ply.gz, 3,674 triangles), three.js's
// TorusKnotGeometry(1, 0.3, 512, 100) (102,400 triangles) and the fetched dragon (data/dragon.ply,
// 871,414 triangles; `bash scripts/fetch-meshes.sh`, left out when absent). Each round builds
// every variant once, alternating them so that a busy machine slows all alike; the table gives
// medians and each kdray build's ratio to three-mesh-bvh's builds. Everything is warmed up on the
// bunny first (V8 tiers WebAssembly and JavaScript up while they run).
import { performance } from 'node:perf_hooks';
import os from 'node:os';
import { MeshBVH, SAH, CENTER } from 'three-mesh-bvh';
import { Scene, moduleVariant, init } from '../src/index.js';
import { geometryOf, meshByName } from './meshes.mjs';

const args = process.argv.slice(2);
const opt = (name, dflt) => { const i = args.indexOf(`--${name}`); return i < 0 ? dflt : args[i + 1]; };
const rounds = +opt('rounds', 5);
const meshNames = opt('meshes', 'bunny,torusknot,dragon').split(',');
const median = (xs) => { const s = [...xs].sort((a, b) => a - b); return s.length % 2 ? s[(s.length - 1) / 2] : (s[s.length / 2 - 1] + s[s.length / 2]) / 2; };

const variants = {
  'kdray fast': async (m) => (await Scene.build(m.positions, m.indices, { quality: 'fast' })).dispose(),
  'kdray high': async (m) => (await Scene.build(m.positions, m.indices, { quality: 'high' })).dispose(),
  'kdray fast, groups': async (m) => (await Scene.build(m.positions, m.indices, { quality: 'fast', leaves: 'groups' })).dispose(),
  'kdray high, groups': async (m) => (await Scene.build(m.positions, m.indices, { quality: 'high', leaves: 'groups' })).dispose(),
  'three-mesh-bvh CENTER': async (m) => { const g = geometryOf(m); const t0 = performance.now(); new MeshBVH(g, { strategy: CENTER }); return performance.now() - t0; },
  'three-mesh-bvh SAH': async (m) => { const g = geometryOf(m); const t0 = performance.now(); new MeshBVH(g, { strategy: SAH }); return performance.now() - t0; },
};

await init();
{
  const m = meshByName('bunny');
  for (let w = 0; w < 10; w++) for (const f of Object.values(variants)) await f(m);
}
const rows = [];
for (const name of meshNames) {
  const mesh = meshByName(name);
  if (!mesh) { console.error(`bench: leaving out ${name} (bash scripts/fetch-meshes.sh fetches it)`); continue; }
  const tris = mesh.indices.length / 3;
  const times = Object.fromEntries(Object.keys(variants).map((k) => [k, []]));
  const n = tris > 500000 ? Math.min(rounds, 3) : rounds;
  for (let r = 0; r < n; r++) {
    for (const [k, f] of Object.entries(variants)) {
      const t0 = performance.now();
      const inner = await f(mesh);
      // three-mesh-bvh's figure leaves out copying the arrays into a geometry of its own.
      times[k].push(typeof inner === 'number' ? inner : performance.now() - t0);
    }
  }
  rows.push({ name, tris, ms: Object.fromEntries(Object.entries(times).map(([k, v]) => [k, median(v)])), n });
}
const cpu = os.cpus()[0]?.model ?? 'unknown CPU';
console.log(`Node ${process.version}, ${cpu} (${os.cpus().length} cores, load ${os.loadavg().map((x) => x.toFixed(1)).join(' ')}), module ${moduleVariant()}, medians of ${rounds} rounds (3 for the dragon)`);
console.log('| mesh | kdray fast ms | kdray high ms | fast, groups ms | high, groups ms | three-mesh-bvh CENTER ms | three-mesh-bvh SAH ms | fast ÷ CENTER | fast ÷ SAH | high ÷ SAH |');
console.log('|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|');
for (const { name, tris, ms } of rows) {
  const [f, h, fg, hg, c, s] = ['kdray fast', 'kdray high', 'kdray fast, groups', 'kdray high, groups', 'three-mesh-bvh CENTER', 'three-mesh-bvh SAH'].map((k) => ms[k]);
  console.log(`| ${name} (${tris.toLocaleString('en')} tris) | ${f.toFixed(1)} | ${h.toFixed(1)} | ${fg.toFixed(1)} | ${hg.toFixed(1)} | ${c.toFixed(1)} | ${s.toFixed(1)} | ${(f / c).toFixed(2)} | ${(f / s).toFixed(2)} | ${(h / s).toFixed(2)} |`);
}
