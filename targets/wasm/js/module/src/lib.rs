//! # kdray-js
//!
//! The WebAssembly module behind the npm package `kdray` (`targets/wasm/js/`): the host
//! library's SAH builder (`kdray` without its `cli` feature: no threads, no images) and
//! `kdray-core`'s traversal, behind plain exported functions that the package's hand-written ES
//! module calls — no wasm-bindgen. Unlike the page's module (`targets/wasm/src`), this one has an
//! allocator (std's, on wasm32 `dlmalloc`): building a tree allocates.
//!
//! Protocol (the package's `src/core.js`): JavaScript asks for a buffer with [`kdj_alloc`],
//! writes positions/indices (or `.kdt` bytes) there, calls [`kdj_build`] (or [`kdj_load`]),
//! which returns a scene handle (> 0) and takes ownership of nothing; queries name the handle.
//! Every export returns an `i32`: ≥ 0 success (or a count), < 0 a failure whose text
//! [`kdj_error`] holds. Pointers are checked against the live buffers from [`kdj_alloc`]; no
//! input makes the module trap.
//!
//! Memory may grow on any call that allocates ([`kdj_alloc`], [`kdj_build`], [`kdj_load`],
//! [`kdj_raycast_many`], [`kdj_intersect_all`]): JavaScript's views of `memory.buffer` must be
//! made again after those.

pub mod instances;
mod memory;
pub mod mesh;
mod unit;

use core::cell::RefCell;
use glam::Vec3;
use kdray::build::Quality;
use kdray::crossings as all;
use kdray::flat::{Layout, Leaves};
use kdray_core::format::contents;
use kdray_core::traverse::Mode;
use kdray_core::traverse::stream::{self, Config};
use kdray_core::{Hit, Ray, Scene};
use memory::try_reserve;
use std::collections::BTreeMap;

/// Failure codes (negative returns).
const BAD_ARGUMENT: i32 = -1;
const BAD_INPUT: i32 = -2;
const NO_SCENE: i32 = -3;

/// A scene and the words it views, which it owns: the words are leaked into a `&'static` slice
/// so that the validated [`Scene`] can be kept (validation is a pass over every word, too slow per
/// query), and taken back in `Drop`.
struct Owned {
    scene: Option<Scene<'static>>,
    words: *mut [u32],
    /// Top levels that place this scene ([`instances`]): while any does, disposing it only
    /// marks it `disposed`, and the last top level to go frees it.
    pins: u32,
    disposed: bool,
}

impl Owned {
    /// `built`: the words are this package's builder's own ([`Scene::from_built_words`]: the
    /// header, sections and tree shape checked, not the checksum or the geometry), else they come
    /// from outside ([`Scene::from_words`]).
    fn new(words: Vec<u32>, built: bool) -> Result<Self, String> {
        let words: &'static mut [u32] = Box::leak(words.into_boxed_slice());
        let ptr: *mut [u32] = words;
        // SAFETY: `ptr` was just made from the leaked box and nothing else refers to it; the
        // shared slice lives until `drop`, which first drops the scene that borrows it.
        let shared: &'static [u32] = unsafe { &*ptr };
        let opened = if built {
            Scene::from_built_words(shared)
        } else {
            Scene::from_words(shared)
        };
        match opened {
            Ok(scene) => Ok(Self {
                scene: Some(scene),
                words: ptr,
                pins: 0,
                disposed: false,
            }),
            Err(e) => {
                // SAFETY: the box leaked above; `shared` is not used again.
                drop(unsafe { Box::from_raw(ptr) });
                Err(e.to_string())
            }
        }
    }

    fn scene(&self) -> &Scene<'static> {
        self.scene.as_ref().expect("set until drop")
    }

    fn words(&self) -> &[u32] {
        // SAFETY: the box lives until `drop`; only shared views of it exist.
        unsafe { &*self.words }
    }
}

impl Drop for Owned {
    fn drop(&mut self) {
        // The scene (the only other view of the words) goes first.
        self.scene = None;
        // SAFETY: `words` came from `Box::leak` in `new` and is freed only here.
        drop(unsafe { Box::from_raw(self.words) });
    }
}

#[derive(Default)]
struct State {
    /// Live buffers from `kdj_alloc`: start → length in bytes.
    buffers: BTreeMap<usize, usize>,
    /// Scenes by handle − 1.
    scenes: Vec<Option<Owned>>,
    error: String,
    /// One closest hit: t, input id (as bits), u, v — read by JavaScript at `kdj_result`.
    result: [u32; 4],
    /// Reused by the ray-stream calls.
    rays: Vec<Ray>,
    hits: Vec<Hit>,
    scratch: Vec<u64>,
    /// The length of each ray's direction in fast mode (`unit`), to scale its `t` back.
    lens: Vec<f32>,
    /// `intersectAll`'s hits, 5 words each (t, input id, u, v, facing), read at `kdj_all`.
    all: Vec<all::AllHit>,
    all_words: Vec<u32>,
    /// Top levels of scenes of many meshes by handle − 1 ([`instances`]).
    tops: Vec<Option<instances::Top>>,
    /// One closest hit of a top level, read by JavaScript at `kdj_top_result`.
    top_result: [u32; 8],
}

thread_local! {
    // wasm32 without the `atomics` feature has one thread: a plain global.
    static STATE: RefCell<State> = RefCell::new(State::default());
}

fn with_state(f: impl FnOnce(&mut State) -> Result<i32, (i32, String)>) -> i32 {
    // A failed allocation noted before belongs to a call that recovered from it.
    memory::clear_failed();
    STATE.with_borrow_mut(|state| match f(state) {
        Ok(n) => n,
        Err((code, msg)) => {
            state.error = msg;
            code
        }
    })
}

fn bad(msg: impl Into<String>) -> (i32, String) {
    (BAD_INPUT, msg.into())
}

impl State {
    /// `len` values of `T` at `ptr`, checked to lie in one live buffer and be aligned.
    fn slice<T: Copy>(&self, ptr: u32, len: u32) -> Result<&'static [T], (i32, String)> {
        let (start, len) = self.checked::<T>(ptr, len)?;
        // SAFETY: [start, start + len·size) lies inside one live allocation of `kdj_alloc`
        // (zeroed at allocation, and T is f32 or u32 — every bit pattern valid), aligned for T;
        // the module never holds another reference into a buffer across calls.
        Ok(unsafe { core::slice::from_raw_parts(start as *const T, len) })
    }

    fn slice_mut<T: Copy>(&self, ptr: u32, len: u32) -> Result<&'static mut [T], (i32, String)> {
        let (start, len) = self.checked::<T>(ptr, len)?;
        // SAFETY: as in `slice`; each export writes one buffer and checks it against its inputs
        // (`disjoint`).
        Ok(unsafe { core::slice::from_raw_parts_mut(start as *mut T, len) })
    }

    fn checked<T>(&self, ptr: u32, len: u32) -> Result<(usize, usize), (i32, String)> {
        let start = ptr as usize;
        let bytes = (len as usize)
            .checked_mul(size_of::<T>())
            .ok_or((BAD_ARGUMENT, "length overflows".to_string()))?;
        let inside = self
            .buffers
            .range(..=start)
            .next_back()
            .is_some_and(|(&a, &n)| start + bytes <= a + n);
        if !inside || !start.is_multiple_of(align_of::<T>()) {
            return Err((
                BAD_ARGUMENT,
                format!("internal: a buffer at {ptr} of {bytes} bytes is not one the module gave"),
            ));
        }
        Ok((start, len as usize))
    }

    fn scene(&self, handle: u32) -> Result<&Owned, (i32, String)> {
        self.scenes
            .get((handle as usize).wrapping_sub(1))
            .and_then(Option::as_ref)
            .filter(|o| !o.disposed)
            .ok_or((NO_SCENE, "the scene was disposed".to_string()))
    }

    /// Pins (`true`) or unpins a live scene for a top level; the last unpin of a disposed scene
    /// frees it.
    fn pin(&mut self, handle: u32, on: bool) {
        let Some(slot) = self.scenes.get_mut((handle as usize).wrapping_sub(1)) else {
            return;
        };
        if let Some(o) = slot.as_mut() {
            if on {
                o.pins += 1;
            } else {
                o.pins = o.pins.saturating_sub(1);
                if o.pins == 0 && o.disposed {
                    *slot = None;
                }
            }
        }
    }

    /// Disposes a scene: frees it, or marks it disposed while top levels pin it.
    fn drop_scene(&mut self, handle: u32) {
        if let Some(slot) = self.scenes.get_mut((handle as usize).wrapping_sub(1)) {
            match slot.as_mut() {
                Some(o) if o.pins > 0 => o.disposed = true,
                _ => *slot = None,
            }
        }
    }

    /// Stores `words` (opened as [`Owned::new`] says) as a new scene; returns its handle.
    fn add(&mut self, words: Vec<u32>, built: bool) -> Result<i32, (i32, String)> {
        let owned = Owned::new(words, built).map_err(bad)?;
        if owned.scene().contents() & contents::SPHERES != 0 {
            return Err(bad(
                "the scene holds spheres: this package traces triangle meshes only",
            ));
        }
        let slot = match self.scenes.iter().position(Option::is_none) {
            Some(i) => i,
            None => {
                self.scenes.push(None);
                self.scenes.len() - 1
            }
        };
        self.scenes[slot] = Some(owned);
        Ok(slot as i32 + 1)
    }
}

fn disjoint<A, B>(a: &[A], b: &[B]) -> Result<(), (i32, String)> {
    let (a0, a1) = (a.as_ptr() as usize, a.as_ptr() as usize + size_of_val(a));
    let (b0, b1) = (b.as_ptr() as usize, b.as_ptr() as usize + size_of_val(b));
    if a1 <= b0 || b1 <= a0 {
        Ok(())
    } else {
        Err((BAD_ARGUMENT, "internal: output overlaps input".to_string()))
    }
}

const ALIGN: usize = 16;

/// A zeroed buffer of `bytes` bytes (16-byte aligned); 0 when memory cannot grow that far.
#[unsafe(no_mangle)]
pub extern "C" fn kdj_alloc(bytes: u32) -> u32 {
    let Ok(layout) = std::alloc::Layout::from_size_align((bytes as usize).max(1), ALIGN) else {
        return 0;
    };
    // SAFETY: the layout's size is > 0.
    let p = unsafe { std::alloc::alloc_zeroed(layout) };
    if p.is_null() {
        return 0;
    }
    STATE.with_borrow_mut(|s| s.buffers.insert(p as usize, layout.size()));
    p as u32
}

/// Frees a buffer from [`kdj_alloc`] (anything else is ignored).
#[unsafe(no_mangle)]
pub extern "C" fn kdj_free(ptr: u32) {
    if let Some(size) = STATE.with_borrow_mut(|s| s.buffers.remove(&(ptr as usize))) {
        let layout = std::alloc::Layout::from_size_align(size, ALIGN).expect("as allocated");
        // SAFETY: allocated by `kdj_alloc` with this layout, and removed from the live list.
        unsafe { std::alloc::dealloc(ptr as *mut u8, layout) };
    }
}

/// Builds a scene from `n_pos` floats of positions at `pos_ptr` and `n_idx` indices at `idx_ptr`
/// (`idx_ptr = 0`: no indices, every 9 floats a triangle); `layout`: 0 nodes, 1 with wide
/// nodes; `leaves`: 0 index lists, 1 triangle groups (built with the SAH priced in groups);
/// `quality`: 0 `high`, 1 `fast` ([`kdray::build::Quality`]).
/// Returns the scene's handle (> 0) or a failure.
#[unsafe(no_mangle)]
pub extern "C" fn kdj_build(
    pos_ptr: u32,
    n_pos: u32,
    idx_ptr: u32,
    n_idx: u32,
    layout: u32,
    leaves: u32,
    quality: u32,
) -> i32 {
    with_state(|s| {
        let positions = if n_pos == 0 {
            &[][..]
        } else {
            s.slice::<f32>(pos_ptr, n_pos)?
        };
        let indices = match (idx_ptr, n_idx) {
            (0, _) => None,
            (_, 0) => Some(&[][..]),
            _ => Some(s.slice::<u32>(idx_ptr, n_idx)?),
        };
        let layout = match layout {
            0 => Layout::Nodes,
            1 => Layout::Wide,
            _ => return Err((BAD_ARGUMENT, "layout must be 0 or 1".into())),
        };
        let leaves = match leaves {
            0 => Leaves::List,
            1 => Leaves::Groups,
            _ => return Err((BAD_ARGUMENT, "leaves must be 0 or 1".into())),
        };
        let quality = match quality {
            0 => Quality::High,
            1 => Quality::Fast,
            _ => return Err((BAD_ARGUMENT, "quality must be 0 or 1".into())),
        };
        let tris = mesh::triangles(positions, indices).map_err(bad)?;
        let words = mesh::build_words(tris, layout, leaves, quality).map_err(bad)?;
        s.add(words, true)
    })
}

/// Loads a scene from `n_bytes` bytes of a `.kdt` at `ptr` (copied), validated. Returns its
/// handle.
#[unsafe(no_mangle)]
pub extern "C" fn kdj_load(ptr: u32, n_bytes: u32) -> i32 {
    load(ptr, n_bytes, false)
}

/// [`kdj_load`] for the words [`kdj_build`] just wrote in the package's builder instance (the
/// same module), which `src/core.js` copies here: opened with [`Scene::from_built_words`], not
/// validated again. Never for bytes from outside the package.
#[unsafe(no_mangle)]
pub extern "C" fn kdj_load_built(ptr: u32, n_bytes: u32) -> i32 {
    load(ptr, n_bytes, true)
}

fn load(ptr: u32, n_bytes: u32, built: bool) -> i32 {
    with_state(|s| {
        let bytes = s.slice::<u8>(ptr, n_bytes)?;
        if !bytes.len().is_multiple_of(4) {
            return Err(bad(format!(
                "{} bytes: a .kdt is a whole number of 4-byte words (truncated?)",
                bytes.len()
            )));
        }
        let mut words = Vec::new();
        try_reserve(&mut words, bytes.len() / 4, "the .kdt's words")?;
        words.extend(
            bytes
                .chunks_exact(4)
                .map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]])),
        );
        s.add(words, built)
    })
}

/// Forgets a scene (once no top level of [`instances`] places it).
#[unsafe(no_mangle)]
pub extern "C" fn kdj_drop(handle: u32) {
    STATE.with_borrow_mut(|s| s.drop_scene(handle));
}

/// The address of a scene's words (little-endian u32, the `.kdt` bytes); their count is
/// [`kdj_word_count`].
#[unsafe(no_mangle)]
pub extern "C" fn kdj_words(handle: u32) -> i32 {
    with_state(|s| Ok(s.scene(handle)?.words().as_ptr() as i32))
}

/// The number of words of a scene.
#[unsafe(no_mangle)]
pub extern "C" fn kdj_word_count(handle: u32) -> i32 {
    with_state(|s| Ok(s.scene(handle)?.words().len() as i32))
}

/// Writes 10 words about a scene at `out_ptr`: triangles, nodes, depth, then the bounds'
/// min and max (6 f32 bits), and 1 if this build uses simd128.
#[unsafe(no_mangle)]
pub extern "C" fn kdj_info(handle: u32, out_ptr: u32) -> i32 {
    with_state(|s| {
        let out = s.slice_mut::<u32>(out_ptr, 10)?;
        let scene = s.scene(handle)?.scene();
        let [lo, hi] = scene.bounds();
        out.copy_from_slice(&[
            scene.tri_count(),
            scene.node_count(),
            scene.depth(),
            lo.x.to_bits(),
            lo.y.to_bits(),
            lo.z.to_bits(),
            hi.x.to_bits(),
            hi.y.to_bits(),
            hi.z.to_bits(),
            u32::from(cfg!(target_feature = "simd128")),
        ]);
        Ok(0)
    })
}

fn mode(watertight: u32) -> Mode {
    if watertight != 0 {
        Mode::Watertight
    } else {
        Mode::Fast
    }
}

/// The address of the last [`kdj_raycast`] result: f32 t, u32 triangle (input order), f32 u,
/// f32 v.
#[unsafe(no_mangle)]
pub extern "C" fn kdj_result() -> i32 {
    STATE.with_borrow(|s| s.result.as_ptr() as i32)
}

/// The closest hit of one ray in `(tmin, tmax)`: 1 (written at [`kdj_result`]), 0 for a miss.
/// The ray's numbers are arguments, so a call copies nothing through memory.
#[unsafe(no_mangle)]
#[allow(clippy::too_many_arguments)]
pub extern "C" fn kdj_raycast(
    handle: u32,
    watertight: u32,
    ox: f32,
    oy: f32,
    oz: f32,
    dx: f32,
    dy: f32,
    dz: f32,
    tmin: f32,
    tmax: f32,
) -> i32 {
    with_state(|s| {
        let scene = s.scene(handle)?.scene();
        let (ray, len) = unit::ray(watertight != 0, [ox, oy, oz], [dx, dy, dz], tmin, tmax);
        let hit = scene.intersect_in(mode(watertight), &ray);
        if !hit.is_hit() {
            return Ok(0);
        }
        let id = scene.input_id(hit.prim);
        let t = unit::t_back(hit.t, len);
        s.result = [t.to_bits(), id, hit.u.to_bits(), hit.v.to_bits()];
        Ok(1)
    })
}

/// Whether anything lies along the ray in `(tmin, tmax)`: 1 or 0.
#[unsafe(no_mangle)]
#[allow(clippy::too_many_arguments)]
pub extern "C" fn kdj_occluded(
    handle: u32,
    watertight: u32,
    ox: f32,
    oy: f32,
    oz: f32,
    dx: f32,
    dy: f32,
    dz: f32,
    tmin: f32,
    tmax: f32,
) -> i32 {
    with_state(|s| {
        let scene = s.scene(handle)?.scene();
        let (ray, _) = unit::ray(watertight != 0, [ox, oy, oz], [dx, dy, dz], tmin, tmax);
        Ok(i32::from(scene.occluded_in(mode(watertight), &ray)))
    })
}

/// Closest hits of `n` rays at `rays_ptr` (8 f32 each: origin, direction, tmin, tmax — the
/// rays-file layout) through the core's ray stream, into `hits_ptr` (4 words each: f32 t, u32
/// triangle in input order, f32 u, f32 v; a miss is t = +inf, triangle 0xFFFFFFFF — the
/// hits-file layout). Returns the number of hits.
#[unsafe(no_mangle)]
pub extern "C" fn kdj_raycast_many(
    handle: u32,
    watertight: u32,
    rays_ptr: u32,
    n: u32,
    hits_ptr: u32,
) -> i32 {
    with_state(|s| {
        let input = s.slice::<[f32; 8]>(rays_ptr, n)?;
        let out = s.slice_mut::<[u32; 4]>(hits_ptr, n)?;
        disjoint(input, out)?;
        let mut rays = core::mem::take(&mut s.rays);
        let mut hits = core::mem::take(&mut s.hits);
        let mut scratch = core::mem::take(&mut s.scratch);
        let mut lens = core::mem::take(&mut s.lens);
        let result = (|| {
            let n = input.len();
            let what = format!("{n} rays");
            rays.clear();
            lens.clear();
            try_reserve(&mut rays, n, &what)?;
            try_reserve(&mut hits, n, &what)?;
            try_reserve(&mut scratch, stream::scratch_words(n), &what)?;
            rays.extend(input.iter().map(|w| Ray {
                origin: Vec3::new(w[0], w[1], w[2]),
                dir: Vec3::new(w[3], w[4], w[5]),
                tmin: w[6],
                tmax: w[7],
            }));
            if watertight == 0 && !rays.iter().all(|r| unit::near_unit(r.dir)) {
                try_reserve(&mut lens, n, &what)?;
                unit::make_unit(&mut rays, &mut lens);
            }
            hits.clear();
            hits.resize(n, Hit::MISS);
            scratch.resize(stream::scratch_words(n), 0);
            let scene = s.scene(handle)?.scene();
            let config = Config {
                mode: mode(watertight),
                ..Config::default()
            };
            stream::intersect(scene, &config, &rays, &mut hits, &mut scratch)
                .map_err(|e| (BAD_ARGUMENT, format!("internal: {e}")))?;
            let mut count = 0;
            for (i, (h, w)) in hits.iter().zip(out.iter_mut()).enumerate() {
                count += i32::from(h.is_hit());
                let id = if h.is_hit() {
                    scene.input_id(h.prim)
                } else {
                    u32::MAX
                };
                let t = match lens.get(i) {
                    Some(&len) if h.is_hit() => unit::t_back(h.t, len),
                    _ => h.t,
                };
                *w = [t.to_bits(), id, h.u.to_bits(), h.v.to_bits()];
            }
            Ok(count)
        })();
        // After a failure the vectors are dropped, so that a batch too large leaves no memory
        // reserved behind it.
        if result.is_ok() {
            (s.rays, s.hits, s.scratch, s.lens) = (rays, hits, scratch, lens);
        }
        result
    })
}

/// Every hit of one ray in `(tmin, tmax)`, sorted by t (`kdray::crossings`: in watertight mode exact on
/// shared edges and vertices, so the count's parity is inside/outside for a closed mesh).
/// Returns the count; the hits are at [`kdj_all`], 5 words each: f32 t, u32 triangle (input
/// order), f32 u, f32 v, i32 facing (+1: the triangle's front faces the ray's origin).
#[unsafe(no_mangle)]
#[allow(clippy::too_many_arguments)]
pub extern "C" fn kdj_intersect_all(
    handle: u32,
    watertight: u32,
    ox: f32,
    oy: f32,
    oz: f32,
    dx: f32,
    dy: f32,
    dz: f32,
    tmin: f32,
    tmax: f32,
) -> i32 {
    with_state(|s| {
        let (ray, len) = unit::ray(watertight != 0, [ox, oy, oz], [dx, dy, dz], tmin, tmax);
        let mut found = core::mem::take(&mut s.all);
        let mut words = core::mem::take(&mut s.all_words);
        let scene = s.scene(handle)?.scene();
        all::all_hits(scene, &ray, watertight != 0, &mut found);
        words.clear();
        for h in &found {
            words.extend_from_slice(&[
                unit::t_back(h.t, len).to_bits(),
                scene.input_id(h.prim),
                h.u.to_bits(),
                h.v.to_bits(),
                h.facing as u32,
            ]);
        }
        let n = found.len() as i32;
        (s.all, s.all_words) = (found, words);
        Ok(n)
    })
}

/// The address of [`kdj_intersect_all`]'s hits.
#[unsafe(no_mangle)]
pub extern "C" fn kdj_all() -> i32 {
    STATE.with_borrow(|s| s.all_words.as_ptr() as i32)
}

/// The address of the last failure's text (UTF-8, [`kdj_error_len`] bytes), read in place:
/// reading it allocates nothing, even with the memory full.
#[unsafe(no_mangle)]
pub extern "C" fn kdj_error() -> i32 {
    STATE.with_borrow(|s| s.error.as_ptr() as i32)
}

/// The size in bytes of the last allocation that failed (0: none): read from an instance that
/// trapped, it tells an out-of-memory abort from a bug.
#[unsafe(no_mangle)]
pub extern "C" fn kdj_failed_alloc() -> u32 {
    memory::failed()
}

/// The length in bytes of the last failure's text.
#[unsafe(no_mangle)]
pub extern "C" fn kdj_error_len() -> i32 {
    STATE.with_borrow(|s| s.error.len() as i32)
}
