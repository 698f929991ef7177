//! Embree 3 as a benchmark peer (feature `embree`; Debian's `libembree-dev`).
//!
//! ```no_run
//! # fn demo(triangles: &[[glam::Vec3; 3]], rays: &[kdray_core::Ray]) -> Result<(), kdray_benches::peer_embree::EmbreeError> {
//! use kdray_benches::peer_embree::EmbreeDevice;
//! let device = EmbreeDevice::new()?; // single-threaded, outside the timed build
//! let scene = device.build(triangles)?; // time this: buffers + rtcCommitScene
//! let hits = scene.trace8(rays); // or trace1, or trace1m(rays, Coherence::Incoherent)
//! # Ok(()) }
//! ```
//!
//! How the scene is set up, so that figures can be read correctly:
//! - one `RTC_GEOMETRY_TYPE_TRIANGLE` geometry over the triangle soup as given (3 vertices per
//!   triangle, no vertex sharing), scene build quality `RTC_BUILD_QUALITY_HIGH`, default scene
//!   flags (not `ROBUST`), default intersect context (`rtcInitIntersectContext`: incoherent);
//! - [`EmbreeDevice::new`] passes `threads=1` so that the build runs on one thread, as the
//!   benchmark protocol asks; [`EmbreeDevice::with_config`] takes any Embree config string;
//! - a ray's `tmin`, `tmax` become `tnear`, `tfar`. Embree accepts `tnear <= t <= tfar`, kdray
//!   `tmin < t < tmax`: they differ only for hits exactly at an end of the interval. `tmin` must be
//!   `>= 0` (Embree's precondition). Rays that are not finite ([`Ray::is_finite`]) are misses and
//!   are not passed to Embree, whose behaviour on NaN depends on a build option;
//! - Embree reports `u`, `v` with the same meaning as [`Hit`] (`p = v0 + u·e1 + v·e2`) and
//!   `primID` in input order.
//!
//! Threads: "API calls to the same object are not thread safe in general […] However, the
//! rtcIntersect/rtcOccluded calls can be invoked from multiple threads" (Embree maintainers,
//! RenderKit/embree#207). So an [`EmbreeScene`], whose only operations after the build are
//! intersections, is `Sync`; an [`EmbreeDevice`] is `Send` but not `Sync`.

mod ffi;

use core::ffi::c_uint;
use core::fmt;
use core::marker::PhantomData;
use core::ptr::NonNull;
use std::ffi::CString;

use glam::Vec3;
use kdray_core::{Hit, Ray};

use ffi::*;

/// The config string of [`EmbreeDevice::new`].
pub const SINGLE_THREAD_CONFIG: &str = "threads=1";

/// An Embree build quality ([`EmbreeDevice::build_at`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quality {
    /// `RTC_BUILD_QUALITY_MEDIUM`.
    Medium,
    /// `RTC_BUILD_QUALITY_HIGH`, what [`EmbreeDevice::build`] uses.
    High,
}

/// An Embree call that failed: what was being done and the `RTCError` code.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EmbreeError {
    pub stage: &'static str,
    pub code: u32,
}

impl fmt::Display for EmbreeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // The names of enum RTCError (rtcore_device.h).
        let name = match self.code {
            0 => "RTC_ERROR_NONE",
            1 => "RTC_ERROR_UNKNOWN",
            2 => "RTC_ERROR_INVALID_ARGUMENT",
            3 => "RTC_ERROR_INVALID_OPERATION",
            4 => "RTC_ERROR_OUT_OF_MEMORY",
            5 => "RTC_ERROR_UNSUPPORTED_CPU",
            6 => "RTC_ERROR_CANCELLED",
            _ => "unknown RTCError",
        };
        write!(f, "embree: {} failed: {name} ({})", self.stage, self.code)
    }
}

impl core::error::Error for EmbreeError {}

/// An Embree device (`RTCDevice`); scenes borrow it.
#[derive(Debug)]
pub struct EmbreeDevice {
    raw: NonNull<RTCDeviceTy>,
}

// SAFETY: an RTCDevice is not tied to the thread that created it; moving the handle moves the
// only way to use it. Not `Sync`: concurrent calls on one device are not promised to be safe.
unsafe impl Send for EmbreeDevice {}

impl EmbreeDevice {
    /// A device that builds on one thread ([`SINGLE_THREAD_CONFIG`]).
    ///
    /// # Errors
    /// When Embree cannot create the device (for example `RTC_ERROR_UNSUPPORTED_CPU`) or the
    /// library is not Embree 3.
    pub fn new() -> Result<Self, EmbreeError> {
        Self::with_config(SINGLE_THREAD_CONFIG)
    }

    /// A device from an Embree config string (`"threads=4,verbose=1"`, …; see `rtcNewDevice`).
    ///
    /// # Errors
    /// As [`new`](Self::new), and `RTC_ERROR_INVALID_ARGUMENT` for a config with a NUL byte.
    pub fn with_config(config: &str) -> Result<Self, EmbreeError> {
        let config = CString::new(config).map_err(|_| EmbreeError {
            stage: "rtcNewDevice (config contains NUL)",
            code: 2,
        })?;
        // SAFETY: `config` is a NUL-terminated string that outlives the call; Embree copies what
        // it parses.
        let raw = unsafe { rtcNewDevice(config.as_ptr()) };
        let Some(raw) = NonNull::new(raw) else {
            // SAFETY: a null device asks for the error of the last failed device creation, the
            // documented way to learn why rtcNewDevice returned null.
            let code = unsafe { rtcGetDeviceError(core::ptr::null_mut()) };
            return Err(EmbreeError {
                stage: "rtcNewDevice",
                code,
            });
        };
        let device = Self { raw };
        // The FFI layouts are Embree 3's; refuse anything else.
        let version = device.property(RTC_DEVICE_PROPERTY_VERSION);
        if !(30000..40000).contains(&version) {
            return Err(EmbreeError {
                stage: "rtcNewDevice (library is not Embree 3)",
                code: 1,
            });
        }
        Ok(device)
    }

    fn property(&self, prop: RTCDeviceProperty) -> isize {
        // SAFETY: `self.raw` is a live device; properties are plain integer queries.
        unsafe { rtcGetDeviceProperty(self.raw.as_ptr(), prop) }
    }

    /// The library version, e.g. `"3.13.5"`.
    pub fn version(&self) -> String {
        let v = self.property(RTC_DEVICE_PROPERTY_VERSION);
        format!("{}.{}.{}", v / 10000, v / 100 % 100, v % 100)
    }

    /// True when the library was built with native 8-wide packets (AVX): `rtcIntersect8` then
    /// runs one packet traversal rather than emulating it.
    pub fn native_ray8(&self) -> bool {
        self.property(RTC_DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED) != 0
    }

    /// True when the library was built with back-face culling (it would then miss hits that kdray
    /// reports); Debian's build has it off.
    pub fn backface_culling(&self) -> bool {
        self.property(RTC_DEVICE_PROPERTY_BACKFACE_CULLING_ENABLED) != 0
    }

    /// The first error since the last check, as an `Err` naming `stage`.
    fn check(&self, stage: &'static str) -> Result<(), EmbreeError> {
        // SAFETY: `self.raw` is a live device; the call reads and clears its error slot.
        let code = unsafe { rtcGetDeviceError(self.raw.as_ptr()) };
        if code == RTC_ERROR_NONE {
            Ok(())
        } else {
            Err(EmbreeError { stage, code })
        }
    }

    /// Builds a scene over `triangles`: fills Embree's vertex and index buffers and commits the
    /// scene at high build quality. Everything the build costs happens in this call.
    ///
    /// # Errors
    /// An Embree error at any step (out of memory, too many triangles for Embree's 32-bit
    /// indices).
    pub fn build(&self, triangles: &[[Vec3; 3]]) -> Result<EmbreeScene<'_>, EmbreeError> {
        self.build_at(triangles, Quality::High)
    }

    /// [`build`](Self::build) at another build quality (`RTC_BUILD_QUALITY_MEDIUM`: Embree's
    /// binned SAH BVH without spatial splits; `HIGH`: with them).
    ///
    /// # Errors
    /// As [`build`](Self::build).
    pub fn build_at(
        &self,
        triangles: &[[Vec3; 3]],
        quality: Quality,
    ) -> Result<EmbreeScene<'_>, EmbreeError> {
        let quality = match quality {
            Quality::Medium => RTC_BUILD_QUALITY_MEDIUM,
            Quality::High => RTC_BUILD_QUALITY_HIGH,
        };
        let dev = self.raw.as_ptr();
        // SAFETY: `dev` is a live device.
        let scene = NonNull::new(unsafe { rtcNewScene(dev) }).ok_or(EmbreeError {
            stage: "rtcNewScene",
            code: 1,
        })?;
        // Owns the scene from here on, so that an early return releases it.
        let out = EmbreeScene {
            raw: scene,
            len: triangles.len(),
            device: PhantomData,
        };
        self.check("rtcNewScene")?;
        // SAFETY: `scene` is live; the quality is a valid enum value.
        unsafe { rtcSetSceneBuildQuality(scene.as_ptr(), quality) };
        self.check("rtcSetSceneBuildQuality")?;
        if !triangles.is_empty() {
            self.attach_triangles(scene.as_ptr(), triangles)?;
        }
        // SAFETY: `scene` is live and no other thread uses it during the commit.
        unsafe { rtcCommitScene(scene.as_ptr()) };
        self.check("rtcCommitScene")?;
        Ok(out)
    }

    fn attach_triangles(
        &self,
        scene: RTCScene,
        triangles: &[[Vec3; 3]],
    ) -> Result<(), EmbreeError> {
        let too_many = EmbreeError {
            stage: "rtcSetNewGeometryBuffer (more than u32::MAX vertices)",
            code: 2,
        };
        let n = triangles.len();
        let nv = n.checked_mul(3).ok_or_else(|| too_many.clone())?;
        u32::try_from(nv).map_err(|_| too_many)?;
        // SAFETY: `self.raw` is a live device, the type a valid enum value.
        let geom = unsafe { rtcNewGeometry(self.raw.as_ptr(), RTC_GEOMETRY_TYPE_TRIANGLE) };
        let Some(geom) = NonNull::new(geom) else {
            self.check("rtcNewGeometry")?;
            return Err(EmbreeError {
                stage: "rtcNewGeometry",
                code: 1,
            });
        };
        // From here on every path reaches the release at the end.
        let filled = self
            .check("rtcNewGeometry")
            .and_then(|()| self.fill_buffers(geom.as_ptr(), triangles, nv));
        if filled.is_ok() {
            // SAFETY: `geom` is live and its buffers are filled.
            unsafe { rtcCommitGeometry(geom.as_ptr()) };
        }
        let attached = filled
            .and_then(|()| self.check("rtcCommitGeometry"))
            .and_then(|()| {
                // SAFETY: `scene` and `geom` are live and belong to this device.
                unsafe { rtcAttachGeometry(scene, geom.as_ptr()) };
                self.check("rtcAttachGeometry")
            });
        // SAFETY: drops our reference; an attached geometry stays alive through the scene's.
        unsafe { rtcReleaseGeometry(geom.as_ptr()) };
        attached
    }

    fn fill_buffers(
        &self,
        geom: RTCGeometry,
        triangles: &[[Vec3; 3]],
        nv: usize,
    ) -> Result<(), EmbreeError> {
        // SAFETY: `geom` is live; FLOAT3 with a 12-byte stride is the documented vertex layout.
        // Embree allocates the buffer (16-byte aligned, padded so that the last vertex can be read
        // as 16 bytes) and returns it, or null with an error set.
        let vptr = unsafe {
            rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 12, nv)
        };
        self.check("rtcSetNewGeometryBuffer (vertices)")?;
        // SAFETY: as above, for UINT3 indices, one triple per triangle.
        let iptr = unsafe {
            rtcSetNewGeometryBuffer(
                geom,
                RTC_BUFFER_TYPE_INDEX,
                0,
                RTC_FORMAT_UINT3,
                12,
                triangles.len(),
            )
        };
        self.check("rtcSetNewGeometryBuffer (indices)")?;
        if vptr.is_null() || iptr.is_null() {
            return Err(EmbreeError {
                stage: "rtcSetNewGeometryBuffer (null buffer)",
                code: 4,
            });
        }
        // SAFETY: `vptr` points to a fresh, exclusively ours buffer of at least `nv` items of 12
        // bytes (3 f32 each), aligned for f32, that lives as long as `geom`, which outlives this
        // function's use of the slice.
        let verts = unsafe { core::slice::from_raw_parts_mut(vptr.cast::<f32>(), 3 * nv) };
        // SAFETY: the same for `iptr`: `triangles.len()` items of 3 u32.
        let idx =
            unsafe { core::slice::from_raw_parts_mut(iptr.cast::<u32>(), 3 * triangles.len()) };
        // Vertex 3k + c is corner c of triangle k. `3 · len` fits u32 (checked by the caller), so
        // the u32 arithmetic cannot overflow.
        for (first, (tri, (v, i))) in (0u32..).step_by(3).zip(
            triangles
                .iter()
                .zip(verts.chunks_exact_mut(9).zip(idx.chunks_exact_mut(3))),
        ) {
            for (c, p) in tri.iter().enumerate() {
                v[3 * c..3 * c + 3].copy_from_slice(&p.to_array());
            }
            i.copy_from_slice(&[first, first + 1, first + 2]);
        }
        Ok(())
    }
}

impl Drop for EmbreeDevice {
    fn drop(&mut self) {
        // SAFETY: we own one reference to the device; scenes borrow it, so none outlives it.
        unsafe { rtcReleaseDevice(self.raw.as_ptr()) };
    }
}

/// A committed Embree scene over a triangle soup.
#[derive(Debug)]
pub struct EmbreeScene<'d> {
    raw: NonNull<RTCSceneTy>,
    len: usize,
    /// The scene must not outlive its device; it does not use it after the build.
    device: PhantomData<&'d EmbreeDevice>,
}

// SAFETY: the scene is committed before `build` returns and never modified afterwards; its
// `&self` methods only call rtcIntersect1/8, which Embree allows from several threads at once
// (module doc), and it keeps no handle to the device. Drop needs ownership.
unsafe impl Send for EmbreeScene<'_> {}
// SAFETY: as for `Send`.
unsafe impl Sync for EmbreeScene<'_> {}

impl Drop for EmbreeScene<'_> {
    fn drop(&mut self) {
        // SAFETY: we own the one reference handed out by rtcNewScene.
        unsafe { rtcReleaseScene(self.raw.as_ptr()) };
    }
}

fn rtc_ray(ray: &Ray) -> RTCRay {
    RTCRay {
        org_x: ray.origin.x,
        org_y: ray.origin.y,
        org_z: ray.origin.z,
        tnear: ray.tmin,
        dir_x: ray.dir.x,
        dir_y: ray.dir.y,
        dir_z: ray.dir.z,
        time: 0.0,
        tfar: ray.tmax,
        mask: c_uint::MAX,
        id: 0,
        flags: 0,
    }
}

const NO_HIT: RTCHit = RTCHit {
    ng_x: 0.0,
    ng_y: 0.0,
    ng_z: 0.0,
    u: 0.0,
    v: 0.0,
    prim_id: RTC_INVALID_GEOMETRY_ID,
    geom_id: RTC_INVALID_GEOMETRY_ID,
    inst_id: [RTC_INVALID_GEOMETRY_ID; RTC_MAX_INSTANCE_LEVEL_COUNT],
};

/// The hint a stream call ([`EmbreeScene::trace1m`]) gives Embree through its intersect context's
/// flags: `RTC_INTERSECT_CONTEXT_FLAG_COHERENT` lets Embree trace a stream's rays in packets,
/// `…_INCOHERENT` (the default context's) one by one after sorting them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Coherence {
    Coherent,
    Incoherent,
}

/// Rays a stream call hands Embree at once: [`EmbreeScene::trace1m`] converts the rays into
/// `RTCRayHit`s this many at a time (80 bytes each, 320 KiB), so that its memory does not grow
/// with the ray count. Embree itself works on much smaller groups inside a stream (it sorts by
/// octant into packets of at most 64 rays), so a bigger batch would not change what it does.
pub const STREAM_BATCH: usize = 4096;

impl EmbreeScene<'_> {
    /// The number of triangles.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when built over no triangles.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The closest hit of each ray, one `rtcIntersect1` call per ray.
    pub fn trace1(&self, rays: &[Ray]) -> Vec<Hit> {
        let mut hits = vec![Hit::MISS; rays.len()];
        self.trace1_into(rays, &mut hits);
        hits
    }

    /// [`trace1`](Self::trace1) into a caller's buffer.
    ///
    /// # Panics
    /// If `hits.len() != rays.len()`.
    pub fn trace1_into(&self, rays: &[Ray], hits: &mut [Hit]) {
        assert_eq!(rays.len(), hits.len(), "one hit record per ray");
        let mut ctx = rtc_init_intersect_context();
        for (ray, out) in rays.iter().zip(hits.iter_mut()) {
            *out = Hit::MISS;
            if !ray.is_finite() {
                continue;
            }
            let mut rh = RTCRayHit {
                ray: rtc_ray(ray),
                hit: NO_HIT,
            };
            // SAFETY: the scene is committed and live; `ctx` and `rh` are valid, properly aligned
            // (RTCRayHit is 16-byte aligned by its type) and exclusively borrowed for the call.
            unsafe { rtcIntersect1(self.raw.as_ptr(), &mut ctx, &mut rh) };
            if rh.hit.geom_id != RTC_INVALID_GEOMETRY_ID {
                *out = Hit {
                    t: rh.ray.tfar,
                    prim: rh.hit.prim_id,
                    u: rh.hit.u,
                    v: rh.hit.v,
                };
            }
        }
    }

    /// The closest hit of each ray through Embree's stream call `rtcIntersect1M`, [`STREAM_BATCH`]
    /// rays a call, with the context flag `coherence`. Non-finite rays are misses and are passed as
    /// rays with an empty interval (`tnear = 1`, `tfar = 0`), which Embree skips.
    pub fn trace1m(&self, rays: &[Ray], coherence: Coherence) -> Vec<Hit> {
        let mut hits = vec![Hit::MISS; rays.len()];
        self.trace1m_into(rays, &mut hits, coherence);
        hits
    }

    /// [`trace1m`](Self::trace1m) into a caller's buffer.
    ///
    /// # Panics
    /// If `hits.len() != rays.len()`.
    pub fn trace1m_into(&self, rays: &[Ray], hits: &mut [Hit], coherence: Coherence) {
        assert_eq!(rays.len(), hits.len(), "one hit record per ray");
        let mut ctx = rtc_init_intersect_context();
        if coherence == Coherence::Coherent {
            ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
        }
        let empty = Ray {
            tmin: 1.0,
            tmax: 0.0,
            ..Ray::new(glam::Vec3::ZERO, glam::Vec3::Z)
        };
        let mut batch: Vec<RTCRayHit> = Vec::with_capacity(STREAM_BATCH.min(rays.len()));
        for (chunk, out) in rays.chunks(STREAM_BATCH).zip(hits.chunks_mut(STREAM_BATCH)) {
            batch.clear();
            batch.extend(chunk.iter().map(|ray| RTCRayHit {
                ray: rtc_ray(if ray.is_finite() { ray } else { &empty }),
                hit: NO_HIT,
            }));
            // `chunk.len() <= STREAM_BATCH`, which fits a c_uint.
            let m = chunk.len() as c_uint;
            // SAFETY: the scene is committed and live; `batch` holds `m` initialized, 16-byte
            // aligned RTCRayHit records laid out `size_of::<RTCRayHit>()` bytes apart, exclusively
            // borrowed for the call; `ctx` is a valid context.
            unsafe {
                rtcIntersect1M(
                    self.raw.as_ptr(),
                    &mut ctx,
                    batch.as_mut_ptr(),
                    m,
                    size_of::<RTCRayHit>(),
                )
            };
            for (rh, o) in batch.iter().zip(out.iter_mut()) {
                *o = if rh.hit.geom_id != RTC_INVALID_GEOMETRY_ID {
                    Hit {
                        t: rh.ray.tfar,
                        prim: rh.hit.prim_id,
                        u: rh.hit.u,
                        v: rh.hit.v,
                    }
                } else {
                    Hit::MISS
                };
            }
        }
    }

    /// The closest hit of each ray, 8 consecutive rays a packet through `rtcIntersect8` (the
    /// benchmark protocol orders primary rays so that a packet is a 2×4 pixel tile). The last
    /// packet is padded with inactive lanes; non-finite rays are inactive lanes.
    pub fn trace8(&self, rays: &[Ray]) -> Vec<Hit> {
        let mut hits = vec![Hit::MISS; rays.len()];
        self.trace8_into(rays, &mut hits);
        hits
    }

    /// [`trace8`](Self::trace8) into a caller's buffer.
    ///
    /// # Panics
    /// If `hits.len() != rays.len()`.
    pub fn trace8_into(&self, rays: &[Ray], hits: &mut [Hit]) {
        assert_eq!(rays.len(), hits.len(), "one hit record per ray");
        let mut ctx = rtc_init_intersect_context();
        for (packet, out) in rays.chunks(8).zip(hits.chunks_mut(8)) {
            let mut valid = Valid8([0; 8]);
            let mut rh = RTCRayHit8 {
                ray: RTCRay8 {
                    org_x: [0.0; 8],
                    org_y: [0.0; 8],
                    org_z: [0.0; 8],
                    tnear: [0.0; 8],
                    dir_x: [0.0; 8],
                    dir_y: [0.0; 8],
                    dir_z: [1.0; 8],
                    time: [0.0; 8],
                    tfar: [0.0; 8],
                    mask: [c_uint::MAX; 8],
                    id: [0; 8],
                    flags: [0; 8],
                },
                hit: RTCHit8 {
                    ng_x: [0.0; 8],
                    ng_y: [0.0; 8],
                    ng_z: [0.0; 8],
                    u: [0.0; 8],
                    v: [0.0; 8],
                    prim_id: [RTC_INVALID_GEOMETRY_ID; 8],
                    geom_id: [RTC_INVALID_GEOMETRY_ID; 8],
                    inst_id: [[RTC_INVALID_GEOMETRY_ID; 8]; RTC_MAX_INSTANCE_LEVEL_COUNT],
                },
            };
            for (i, ray) in packet.iter().enumerate() {
                if !ray.is_finite() {
                    continue;
                }
                valid.0[i] = -1;
                let r = &mut rh.ray;
                (r.org_x[i], r.org_y[i], r.org_z[i]) = (ray.origin.x, ray.origin.y, ray.origin.z);
                (r.dir_x[i], r.dir_y[i], r.dir_z[i]) = (ray.dir.x, ray.dir.y, ray.dir.z);
                (r.tnear[i], r.tfar[i]) = (ray.tmin, ray.tmax);
            }
            // SAFETY: the scene is committed and live; `valid` and `rh` are 32-byte aligned by
            // their types as rtcIntersect8 requires, fully initialized, and exclusively borrowed
            // for the call; `ctx` is a valid context.
            unsafe { rtcIntersect8(valid.0.as_ptr(), self.raw.as_ptr(), &mut ctx, &mut rh) };
            for (i, o) in out.iter_mut().enumerate() {
                *o = if valid.0[i] != 0 && rh.hit.geom_id[i] != RTC_INVALID_GEOMETRY_ID {
                    Hit {
                        t: rh.ray.tfar[i],
                        prim: rh.hit.prim_id[i],
                        u: rh.hit.u[i],
                        v: rh.hit.v[i],
                    }
                } else {
                    Hit::MISS
                };
            }
        }
    }
}
