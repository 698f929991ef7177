//! # kdray-wasm
//!
//! `kdray-core` as a `no_std` WebAssembly module without an allocator: a page (or Node) asks for
//! regions of linear memory with [`kd_alloc`], writes a scene's words (`.kdt`) and its render
//! description (`.kdr`) into them, [`kd_load`]s them, then renders rows ([`kd_render`],
//! [`kd_to_rgba`]; progressively, one sample a call, with `page::kd_accumulate`) or traces a ray
//! buffer ([`kd_trace`]). Every export returns a status (0 or a
//! positive count = success, negative = [`Status`]) and never traps on bad input; [`kd_error`]
//! gives the last error's text. See `README.md` for the JavaScript side.
//!
//! Memory: [`kd_alloc`] grows linear memory by whole pages and hands out the new pages, so a
//! region never overlaps the module's own data or stack; every pointer an export takes must lie
//! inside one region from [`kd_alloc`], and a buffer an export writes must not overlap the loaded
//! scene or description. This file holds the only `unsafe` of the module: turning such a checked
//! region into a slice (`Regions::slice`, `Regions::slice_mut`), and declaring the single-threaded state `Sync`.
#![no_std]
#![deny(unsafe_op_in_unsafe_fn)]

use core::arch::wasm32;
use core::cell::RefCell;
use core::fmt::Write;
use glam::Vec3;
use kdray_core::description::Description;
use kdray_core::render::{self, Settings};
use kdray_core::simd::{RayPacket, f32x4, f32x8};
use kdray_core::{Hit, Ray, Scene, color};

mod page;

// `Prims` (the traversal kernel) and `Cam` (the camera) from this crate's features.
kdray_core::target_types!();

/// What an export returns when it fails (as a negative `i32`).
#[repr(i32)]
#[derive(Clone, Copy, Debug)]
pub enum Status {
    /// A pointer or length outside the regions from `kd_alloc`, misaligned, or overlapping the
    /// loaded scene.
    BadRegion = -1,
    /// The scene words are not a valid scene.
    BadScene = -2,
    /// The description is not valid for the scene, or its camera is not.
    BadDescription = -3,
    /// Nothing is loaded yet.
    NotLoaded = -4,
    /// A size, sample count, packet width or row range out of range.
    BadArgument = -5,
    /// Linear memory cannot grow that far, or too many regions.
    OutOfMemory = -6,
}

const PAGE: usize = 65536;
/// The most regions `kd_alloc` hands out before `kd_reset`.
const MAX_REGIONS: usize = 64;

/// A loaded scene and what renders it.
struct Loaded {
    scene: Scene<'static>,
    /// Byte ranges of the scene's and description's words, which no output may overlap.
    inputs: [(usize, usize); 2],
    desc: Description<'static>,
    camera: Cam,
}

impl Loaded {
    /// The description's settings, for a `width × height` image (0, 0: the description's size).
    fn settings(&self, width: u32, height: u32) -> Settings {
        let mut s = self.desc.settings();
        if width != 0 || height != 0 {
            (s.width, s.height) = (width, height);
        }
        s
    }
}

/// Regions handed out by `kd_alloc`: `[start, end)` byte ranges of linear memory.
struct Regions {
    list: heapless::Vec<(usize, usize), MAX_REGIONS>,
}

struct State {
    regions: Regions,
    loaded: Option<Loaded>,
    error: heapless::String<256>,
}

struct Global(RefCell<State>);
// SAFETY: without the `atomics` target feature a wasm32 module has exactly one thread, so the
// state is never touched from two threads.
#[cfg(not(target_feature = "atomics"))]
unsafe impl Sync for Global {}

static STATE: Global = Global(RefCell::new(State {
    regions: Regions {
        list: heapless::Vec::new(),
    },
    loaded: None,
    error: heapless::String::new(),
}));

/// Runs `f` on the state, or returns `BadRegion` if it is already borrowed (it never is: exports
/// do not call each other).
fn with_state(f: impl FnOnce(&mut State) -> Result<i32, Status>) -> i32 {
    let Ok(mut state) = STATE.0.try_borrow_mut() else {
        return Status::BadArgument as i32;
    };
    match f(&mut state) {
        Ok(n) => n,
        Err(status) => status as i32,
    }
}

impl Regions {
    /// Whether `[start, start + bytes)` lies inside one region.
    fn contains(&self, start: usize, bytes: usize) -> bool {
        let Some(end) = start.checked_add(bytes) else {
            return false;
        };
        self.list.iter().any(|&(a, b)| a <= start && end <= b)
    }

    /// The byte range of `len` values of `T` at address `ptr`, checked to lie inside one region
    /// and to be aligned for `T`.
    fn checked<T>(&self, ptr: u32, len: u32) -> Result<(usize, usize), Status> {
        let (start, len) = (ptr as usize, len as usize);
        let bytes = len
            .checked_mul(core::mem::size_of::<T>())
            .ok_or(Status::BadRegion)?;
        if ptr == 0
            || !start.is_multiple_of(core::mem::align_of::<T>())
            || !self.contains(start, bytes)
        {
            return Err(Status::BadRegion);
        }
        Ok((start, len))
    }

    /// `len` values of `T` at byte address `ptr`, read only (inputs may overlap each other).
    fn slice<T: Copy>(&self, ptr: u32, len: u32) -> Result<&'static [T], Status> {
        let (start, len) = self.checked::<T>(ptr, len)?;
        // SAFETY: see `slice_mut`; a shared view may overlap other shared views.
        Ok(unsafe { core::slice::from_raw_parts(start as *const T, len) })
    }

    /// `len` values of `T` at byte address `ptr`, to write. The caller checks with `disjoint`
    /// that it overlaps no other slice it holds.
    fn slice_mut<T: Copy>(&self, ptr: u32, len: u32) -> Result<&'static mut [T], Status> {
        let (start, len) = self.checked::<T>(ptr, len)?;
        // SAFETY: `[start, start + bytes)` lies inside pages that `kd_alloc` grew linear memory
        // by (memory never shrinks), so it is valid, initialized (fresh pages are zero; `T` is
        // plain data: f32, u32, u8 or arrays of them, for which every bit pattern is valid) and
        // aligned for `T`; Rust code places nothing there. Each export checks that the one slice
        // it writes overlaps none of the slices it reads (`disjoint`), and the loaded scene's
        // words are never written (outputs are checked against `Loaded::inputs`).
        Ok(unsafe { core::slice::from_raw_parts_mut(start as *mut T, len) })
    }
}

/// Whether the byte range of `out` overlaps none of `others`.
fn disjoint<T>(out: &[T], others: &[(usize, usize)]) -> Result<(), Status> {
    let a = out.as_ptr() as usize;
    let b = a + core::mem::size_of_val(out);
    if others.iter().all(|&(c, d)| b <= c || d <= a) {
        Ok(())
    } else {
        Err(Status::BadRegion)
    }
}

fn range_of<T>(s: &[T]) -> (usize, usize) {
    let a = s.as_ptr() as usize;
    (a, a + core::mem::size_of_val(s))
}

/// Records `msg` as the last error and returns `status`.
fn fail(state: &mut State, status: Status, msg: impl core::fmt::Display) -> Status {
    state.error.clear();
    // A message longer than the buffer is cut: the status still says what failed.
    let _ = write!(state.error, "{msg}");
    status
}

/// A fresh, zeroed region of at least `bytes` bytes (a whole number of 64 KiB pages, 16-byte
/// aligned); returns its address, or 0 when memory cannot grow.
#[unsafe(no_mangle)]
pub extern "C" fn kd_alloc(bytes: u32) -> u32 {
    let pages = (bytes as usize).div_ceil(PAGE).max(1);
    with_state(|state| {
        if state.regions.list.is_full() {
            return Ok(0);
        }
        let old = wasm32::memory_grow(0, pages);
        if old == usize::MAX {
            return Ok(0);
        }
        let start = old * PAGE;
        let _ = state.regions.list.push((start, start + pages * PAGE));
        Ok(start as i32)
    }) as u32
}

/// Validates and loads a scene (`scene_words` words at `scene_ptr`) and its render description
/// (`desc_words` words at `desc_ptr`; `desc_words = 0`: the framing description, for a bare
/// `.kdt`). Returns 0, or a negative [`Status`] (the text from [`kd_error`]).
#[unsafe(no_mangle)]
pub extern "C" fn kd_load(scene_ptr: u32, scene_words: u32, desc_ptr: u32, desc_words: u32) -> i32 {
    with_state(|state| {
        state.loaded = None;
        let words: &'static [u32] = state.regions.slice::<u32>(scene_ptr, scene_words)?;
        let scene = match Scene::from_words(words) {
            Ok(s) => s,
            Err(e) => return Err(fail(state, Status::BadScene, e)),
        };
        if !render::kernel_fits::<Prims>(&scene) {
            let msg = "the scene holds primitives this build leaves out";
            return Err(fail(state, Status::BadScene, msg));
        }
        let (desc, desc_range) = if desc_words == 0 {
            (Description::framing(&scene), (0, 0))
        } else {
            let d: &'static [u32] = state.regions.slice::<u32>(desc_ptr, desc_words)?;
            match Description::from_words(d, &scene, words) {
                Ok(desc) => (desc, range_of(d)),
                Err(e) => return Err(fail(state, Status::BadDescription, e)),
            }
        };
        let camera = match desc.camera::<Cam>() {
            Ok(c) => c,
            Err(e) => return Err(fail(state, Status::BadDescription, e)),
        };
        state.loaded = Some(Loaded {
            scene,
            inputs: [range_of(words), desc_range],
            desc,
            camera,
        });
        Ok(0)
    })
}

/// Writes 12 words at `out_ptr` about the loaded scene: width, height, spp, max_depth, seed low,
/// seed high (the description's settings), triangles, spheres, lights, camera kind, nodes, and
/// 1 if this build uses `simd128` (else 0). Returns 0 or a negative [`Status`].
#[unsafe(no_mangle)]
pub extern "C" fn kd_info(out_ptr: u32) -> i32 {
    with_state(|state| {
        let loaded = state.loaded.as_ref().ok_or(Status::NotLoaded)?;
        let out = state.regions.slice_mut::<u32>(out_ptr, 12)?;
        disjoint(out, &loaded.inputs)?;
        let s = loaded.desc.settings();
        let scene = &loaded.scene;
        out.copy_from_slice(&[
            s.width,
            s.height,
            s.spp,
            s.max_depth,
            s.seed as u32,
            (s.seed >> 32) as u32,
            scene.tri_count(),
            scene.sphere_count(),
            loaded.desc.lights().len() as u32,
            loaded.desc.camera_kind(),
            scene.node_count(),
            u32::from(cfg!(target_feature = "simd128")),
        ]);
        Ok(0)
    })
}

/// Renders rows `first_row .. first_row + rows` of a `width × height` image (0, 0: the
/// description's size) with `spp` samples per pixel (0: the description's) and the given seed,
/// the bounce rays as 8-wide packets (`single = 0`) or one by one through the scalar walk
/// (`single = 1`, the same image), into `out_ptr`: `rows · width` pixels of mean linear RGB,
/// 3 f32 each. The pixels equal those of `kdray render` with the same size, spp and seed.
/// Returns 0 or a negative [`Status`].
#[unsafe(no_mangle)]
#[allow(clippy::too_many_arguments)]
pub extern "C" fn kd_render(
    first_row: u32,
    rows: u32,
    width: u32,
    height: u32,
    spp: u32,
    seed_lo: u32,
    seed_hi: u32,
    single: u32,
    out_ptr: u32,
) -> i32 {
    with_state(|state| {
        let loaded = state.loaded.as_ref().ok_or(Status::NotLoaded)?;
        let mut s = loaded.settings(width, height);
        if spp != 0 {
            s.spp = spp;
        }
        s.seed = u64::from(seed_hi) << 32 | u64::from(seed_lo);
        // The kernel with 8-wide packet bounces, or every ray through the scalar walk.
        let render = match single {
            0 => render::render_rows_with::<Prims, Cam, true>,
            1 => render::render_rows_with::<Prims, Cam, false>,
            _ => return Err(Status::BadArgument),
        };
        let pixels = rows.checked_mul(s.width).ok_or(Status::BadArgument)?;
        let floats = pixels.checked_mul(3).ok_or(Status::BadArgument)?;
        let out = state.regions.slice_mut::<f32>(out_ptr, floats)?;
        disjoint(out, &loaded.inputs)?;
        let (out, _) = out.as_chunks_mut::<3>();
        let d = &loaded.desc;
        match render(
            &loaded.scene,
            &loaded.camera,
            d.materials(),
            d.lights(),
            &s,
            first_row,
            out,
        ) {
            Ok(()) => Ok(0),
            Err(e) => Err(fail(state, Status::BadArgument, e)),
        }
    })
}

/// Converts `pixels` linear RGB pixels (3 f32 each, at `src_ptr`), each divided by `samples`
/// (1 for `kd_render`'s means; `n` for a sum of `n` samples), to opaque 8-bit sRGB RGBA at `dst_ptr` (4 bytes a
/// pixel, the layout of a canvas `ImageData`), rounding exactly as the host's PNG does. Returns 0
/// or a negative [`Status`].
#[unsafe(no_mangle)]
pub extern "C" fn kd_to_rgba(src_ptr: u32, pixels: u32, samples: f32, dst_ptr: u32) -> i32 {
    with_state(|state| {
        let src = state
            .regions
            .slice::<f32>(src_ptr, pixels.checked_mul(3).ok_or(Status::BadArgument)?)?;
        let dst = state
            .regions
            .slice_mut::<u8>(dst_ptr, pixels.checked_mul(4).ok_or(Status::BadArgument)?)?;
        let mut inputs: heapless::Vec<(usize, usize), 3> = heapless::Vec::new();
        let _ = inputs.push(range_of(src));
        if let Some(loaded) = &state.loaded {
            let _ = inputs.extend_from_slice(&loaded.inputs);
        }
        disjoint(dst, &inputs)?;
        for (rgb, rgba) in src
            .as_chunks::<3>()
            .0
            .iter()
            .zip(dst.as_chunks_mut::<4>().0)
        {
            *rgba = color::rgba8(*rgb, samples);
        }
        Ok(0)
    })
}

/// Traces `n` rays (8 f32 each at `rays_ptr`: ox oy oz dx dy dz tmin tmax, the rays file layout)
/// through the loaded scene, `packet` consecutive rays at a time (1: the scalar walk; 4 or 8:
/// packets), and writes their closest hits at `hits_ptr` (4 words each: f32 t, u32 primitive in
/// input order, f32 u, f32 v; a miss is t = +inf, primitive = 0xFFFFFFFF; the hits file layout).
/// Returns the number of hits, or a negative [`Status`].
#[unsafe(no_mangle)]
pub extern "C" fn kd_trace(rays_ptr: u32, n: u32, hits_ptr: u32, packet: u32) -> i32 {
    with_state(|state| {
        let loaded = state.loaded.as_ref().ok_or(Status::NotLoaded)?;
        let rays = state.regions.slice::<[f32; 8]>(rays_ptr, n)?;
        let hits = state.regions.slice_mut::<[u32; 4]>(hits_ptr, n)?;
        disjoint(hits, &loaded.inputs)?;
        disjoint(hits, &[range_of(rays)])?;
        let scene = &loaded.scene;
        let mut count = 0i32;
        for (r, h) in rays.chunks(8).zip(hits.chunks_mut(8)) {
            let mut batch = [Ray::new(Vec3::ZERO, Vec3::Z); 8];
            for (ray, w) in batch.iter_mut().zip(r) {
                *ray = Ray {
                    origin: Vec3::new(w[0], w[1], w[2]),
                    dir: Vec3::new(w[3], w[4], w[5]),
                    tmin: w[6],
                    tmax: w[7],
                };
            }
            let batch = &batch[..r.len()];
            let mut found = [Hit::MISS; 8];
            match packet {
                1 => batch
                    .iter()
                    .zip(&mut found)
                    .for_each(|(ray, hit)| *hit = scene.intersect_with::<Prims>(ray)),
                4 => {
                    for (rs, hs) in batch.chunks(4).zip(found.chunks_mut(4)) {
                        let p = RayPacket::<f32x4>::from_rays(rs);
                        let hits = scene.intersect_packet_with::<Prims, f32x4>(&p);
                        hits.write_active(&p, hs);
                    }
                }
                8 => {
                    let p = RayPacket::<f32x8>::from_rays(batch);
                    let hits = scene.intersect_packet_with::<Prims, f32x8>(&p);
                    hits.write_active(&p, &mut found[..batch.len()]);
                }
                _ => return Err(Status::BadArgument),
            }
            for (hit, w) in found.iter().zip(h) {
                count += i32::from(hit.is_hit());
                *w = [
                    hit.t.to_bits(),
                    scene.input_id(hit.prim),
                    hit.u.to_bits(),
                    hit.v.to_bits(),
                ];
            }
        }
        Ok(count)
    })
}

/// Copies the last error's text (UTF-8) to `dst_ptr`, at most `cap` bytes; returns its length in
/// bytes (what was copied), or a negative [`Status`].
#[unsafe(no_mangle)]
pub extern "C" fn kd_error(dst_ptr: u32, cap: u32) -> i32 {
    with_state(|state| {
        let text = state.error.as_bytes();
        let n = text.len().min(cap as usize);
        let dst = state.regions.slice_mut::<u8>(dst_ptr, n as u32)?;
        dst.copy_from_slice(&text[..n]);
        Ok(n as i32)
    })
}

/// Forgets every region and the loaded scene; later `kd_alloc`s grow memory again (WASM memory
/// never shrinks: reload the module to give memory back).
#[unsafe(no_mangle)]
pub extern "C" fn kd_reset() {
    with_state(|state| {
        state.loaded = None;
        state.regions.list.clear();
        Ok(0)
    });
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    // The core never panics on any input; should anything else, trap.
    wasm32::unreachable()
}
