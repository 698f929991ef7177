// The kdray page: loads the WASM module and a scene (`.kdt` + its render description `.kdr`),
// then renders progressively into the canvas — frame k adds sample k to every pixel and the
// canvas shows the running mean — with a frame counter and the rays per second.
//
// Work is time-sliced on the main thread: each animation frame renders rows for ~25 ms, so the
// page stays responsive; the rows are shown as soon as they are done.
//
// URL parameters (the headless test uses them): `scene=NAME` picks an example, `frames=N` stops
// after N frames (default: the description's spp), `size=WxH` overrides the image size.
// `window.kdrayPage` exposes the state: { scene, width, height, frames, target, done, error, rays, ms }.

import { Engine } from './engine.js';

const $ = (id) => document.getElementById(id);
const params = new URLSearchParams(location.search);
const state = (window.kdrayPage = {
  scene: null, width: 0, height: 0, frames: 0, target: 0, done: false, error: null, rays: 0, ms: 0,
});

let engine = null;
let job = 0; // bumped on every new scene: a stale render loop stops
let paused = false;

function status(text, isError = false) {
  const el = $('status');
  el.textContent = text;
  el.classList.toggle('error', isError);
}

function fail(message) {
  state.error = message;
  state.done = true;
  status(message, true);
}

/** Parses `WxH`, or null. */
function parseSize(s) {
  const m = /^(\d{1,5})x(\d{1,5})$/.exec(s || '');
  if (!m) return null;
  const [w, h] = [Number(m[1]), Number(m[2])];
  return w >= 1 && h >= 1 && w * h <= 1 << 22 ? [w, h] : null;
}

async function fetchBytes(url) {
  const r = await fetch(url);
  if (!r.ok) throw new Error(`${url}: HTTP ${r.status}`);
  return new Uint8Array(await r.arrayBuffer());
}

/** Starts rendering `kdt` (+ `kdr`, may be null) named `name`. */
function start(name, kdt, kdr) {
  const id = ++job;
  Object.assign(state, { scene: name, frames: 0, done: false, error: null, rays: 0, ms: 0 });
  let info;
  try {
    info = engine.load(kdt, kdr, parseSize(params.get('size')));
  } catch (e) {
    fail(`${name}: ${e.message}`);
    return;
  }
  const { width, height } = info;
  const frames = Number(params.get('frames'));
  const target = Number.isInteger(frames) && frames > 0 ? frames : info.spp;
  Object.assign(state, { width, height, target });
  const canvas = $('canvas');
  canvas.width = width;
  canvas.height = height;
  // Small images are shown enlarged (pixelated); the canvas itself keeps one pixel per pixel.
  canvas.style.width = `${Math.max(width, Math.min(512, 4 * width))}px`;
  const ctx = canvas.getContext('2d');
  ctx.clearRect(0, 0, width, height);
  let row = 0;
  const tick = () => {
    if (id !== job) return;
    if (paused) {
      requestAnimationFrame(tick);
      return;
    }
    const t0 = performance.now();
    const first = row;
    // Render rows until the slice's time is up (at least one row) or the frame ends.
    while (row < height && (row === first || performance.now() - t0 < 25)) {
      state.rays += engine.accumulate(row, 1, state.frames);
      row++;
    }
    state.ms += performance.now() - t0;
    // The finished rows hold one sample more than the rest of the image.
    ctx.putImageData(new ImageData(engine.resolve(first, row - first, state.frames + 1), width), 0, first);
    if (row === height) {
      row = 0;
      state.frames++;
    }
    const mrays = state.ms > 0 ? state.rays / state.ms / 1e3 : 0;
    status(`${name}: ${width}×${height}, frame ${state.frames} / ${state.target}, ` +
      `${mrays.toFixed(2)} Mrays/s, ${(state.ms / 1e3).toFixed(1)} s`);
    if (state.frames >= state.target) {
      state.done = true;
      status(`${$('status').textContent} — done`);
      return;
    }
    requestAnimationFrame(tick);
  };
  requestAnimationFrame(tick);
}

async function loadExample(scene) {
  try {
    const kdt = await fetchBytes(`scenes/${scene.kdt}`);
    const kdr = scene.kdr ? await fetchBytes(`scenes/${scene.kdr}`) : null;
    start(scene.name, kdt, kdr);
  } catch (e) {
    fail(`${scene.name}: ${e.message}`);
  }
}

async function loadPicked(files) {
  const list = [...files];
  const kdtFile = list.find((f) => f.name.toLowerCase().endsWith('.kdt'));
  const kdrFile = list.find((f) => f.name.toLowerCase().endsWith('.kdr'));
  if (!kdtFile) {
    fail('pick a .kdt file (and optionally its .kdr render description)');
    return;
  }
  const bytes = async (f) => new Uint8Array(await f.arrayBuffer());
  start(kdtFile.name, await bytes(kdtFile), kdrFile ? await bytes(kdrFile) : null);
}

async function main() {
  try {
    engine = await Engine.create();
  } catch (e) {
    fail(`cannot load the WASM module: ${e.message}`);
    return;
  }
  $('module').textContent = `module: ${engine.name}`;
  let scenes = [];
  try {
    scenes = await (await fetch('scenes/scenes.json')).json();
  } catch (e) {
    fail(`cannot load the scene list scenes/scenes.json: ${e.message}`);
    return;
  }
  const select = $('scene');
  for (const s of scenes) select.add(new Option(s.name, s.name));
  select.onchange = () => loadExample(scenes.find((s) => s.name === select.value));
  $('file').onchange = (e) => loadPicked(e.target.files);
  $('pause').onclick = () => {
    paused = !paused;
    $('pause').textContent = paused ? 'Resume' : 'Pause';
  };
  const wanted = scenes.find((s) => s.name === params.get('scene')) || scenes[0];
  if (!wanted) {
    fail('scenes/scenes.json lists no scenes');
    return;
  }
  select.value = wanted.name;
  loadExample(wanted);
}

main();
