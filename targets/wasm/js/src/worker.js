// kdray/worker: builds a large mesh's tree off the main thread. The worker is made from a Blob
// URL (in Node: worker_threads with its source as a string), so no bundler has to find, copy or
// rewrite a worker file; it gets the already compiled WebAssembly.Module in its first message
// (modules can be posted), builds, and hands the tree's bytes back as a transferable buffer —
// or, where the page is cross-origin isolated, in a SharedArrayBuffer that several query
// workers can load without a copy each (Scene.fromBytes(shared) in each).
import { Scene, init, compiledModule } from './index.js';
import { buildFlags, meshArgs } from './args.js';

// The worker: the module's build protocol in a few lines (src/core.js is the full one).
const SOURCE = `
const port = typeof self !== 'undefined' ? self : require('node:worker_threads').parentPort;
const on = (f) => (typeof self !== 'undefined' ? (self.onmessage = (e) => f(e.data)) : port.on('message', f));
on(async ({ module, positions, indices, layout, leaves, quality, shared }) => {
  try {
    const kd = (await WebAssembly.instantiate(module, {})).exports;
    const put = (a) => { const b = new Uint8Array(a.buffer, a.byteOffset, a.byteLength); const p = kd.kdj_alloc(b.length || 1) >>> 0; if (!p) throw new Error('out of memory for ' + b.length + ' bytes of input'); new Uint8Array(kd.memory.buffer, p, b.length).set(b); return p; };
    const pos = put(positions);
    const idx = indices ? put(indices) : 0;
    let h;
    try {
      h = kd.kdj_build(pos, positions.length, idx, indices ? indices.length : 0, layout, leaves, quality);
    } catch (e) {
      const failed = kd.kdj_failed_alloc() >>> 0;
      if (!(e instanceof WebAssembly.RuntimeError) || failed === 0) throw e;
      throw new Error('out of memory building ' + (indices ? indices.length : positions.length / 3) / 3 + ' triangles (an allocation of ' + failed + ' bytes failed; a WebAssembly memory holds at most 4 GiB)');
    }
    if (h < 0) {
      throw new Error(new TextDecoder().decode(new Uint8Array(kd.memory.buffer, kd.kdj_error() >>> 0, kd.kdj_error_len()).slice()));
    }
    const words = new Uint8Array(kd.memory.buffer, kd.kdj_words(h) >>> 0, 4 * kd.kdj_word_count(h));
    const out = new Uint8Array(shared ? new SharedArrayBuffer(words.length) : new ArrayBuffer(words.length));
    out.set(words);
    port.postMessage({ bytes: out }, shared ? [] : [out.buffer]);
  } catch (e) {
    port.postMessage({ error: String(e && e.message || e) });
  }
});
`;

async function spawn() {
  if (typeof Worker === 'function' && typeof Blob === 'function' && typeof URL?.createObjectURL === 'function') {
    const url = URL.createObjectURL(new Blob([SOURCE], { type: 'text/javascript' }));
    const w = new Worker(url);
    return {
      post: (m, t) => w.postMessage(m, t),
      once: (f) => { w.onmessage = (e) => f(e.data); w.onerror = (e) => f({ error: e.message || 'the worker failed' }); },
      end: () => { w.terminate(); URL.revokeObjectURL(url); },
    };
  }
  // Node: a specifier in a variable, so that bundlers leave it alone.
  const name = 'node:worker_threads';
  const { Worker: NodeWorker } = await import(/* @vite-ignore */ /* webpackIgnore: true */ name);
  const w = new NodeWorker(SOURCE, { eval: true });
  return {
    post: (m, t) => w.postMessage(m, t),
    once: (f) => { w.once('message', f); w.once('error', (e) => f({ error: e.message })); },
    end: () => w.terminate(),
  };
}

/**
 * Scene.build on a worker: resolves to `{ scene, bytes }` — the scene (loaded on this thread
 * from the worker's bytes) and the `.kdt` bytes, in a SharedArrayBuffer when `crossOriginIsolated`
 * (give them to other workers' Scene.fromBytes), else in an ArrayBuffer. `positions` and
 * `indices` are copied to the worker, not transferred: the caller keeps them.
 */
export async function buildInWorker(positions, indices, options) {
  [positions, indices, options] = meshArgs(positions, indices, options);
  const [layout, leaves, quality] = buildFlags(options);
  await init();
  const shared = typeof SharedArrayBuffer === 'function' && globalThis.crossOriginIsolated === true;
  const worker = await spawn();
  try {
    const reply = await new Promise((resolve) => {
      worker.once(resolve);
      worker.post({ module: compiledModule(), positions, indices: indices ?? null, layout, leaves, quality, shared });
    });
    if (reply.error) throw new Error(`kdray: cannot build the mesh: ${reply.error}`);
    const scene = await Scene.fromBytes(reply.bytes, options?.watertight === undefined ? undefined : { watertight: options.watertight });
    return { scene, bytes: reply.bytes };
  } finally {
    worker.end();
  }
}
