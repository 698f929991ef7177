//! The order a stream's rays are traced in, and which neighbours are coherent enough to share a
//! packet.
//!
//! Sort key (64 bits, most significant first): the direction's octant (3 bits, the signs the
//! packet walk splits by), a Morton code of the origin in the scene's box ([`ORIGIN_BITS`] per
//! axis), then a Morton code of the direction ([`DIR_BITS`] per axis). Rays of one octant from
//! nearby origins end up next to each other, and among rays from one point (a pinhole's) those of
//! nearby directions; this is the binning of Pharr et al. 1997 ("Rendering Complex Scenes with
//! Memory-Coherent Ray Tracing") and of Garanzha & Loop 2010 ("Fast Ray Sorting and
//! Breadth-First Packet Traversal for GPU Ray Tracing", §3: origin cell and direction quantized
//! into one key), with the octant first as Wald's packet walk needs one direction sign per packet.

use crate::ray::Ray;
use glam::Vec3;

/// Bits per axis of the origin's Morton code.
pub const ORIGIN_BITS: u32 = 10;
/// Bits per axis of the direction's Morton code.
pub const DIR_BITS: u32 = 10;

const _: () = assert!(3 + 3 * ORIGIN_BITS + 3 * DIR_BITS <= 64);

/// The direction's octant: bit `k` set when component `k` is negative (−0 included, as the walks
/// count it by the sign of `1/d`).
#[inline(always)]
pub fn octant(dir: Vec3) -> u32 {
    u32::from(dir.x.is_sign_negative())
        | u32::from(dir.y.is_sign_negative()) << 1
        | u32::from(dir.z.is_sign_negative()) << 2
}

/// The sort key of `ray` in a scene whose box starts at `lo` and whose `scale` is
/// `2^ORIGIN_BITS / extent` per axis. Total for any input (a NaN quantizes to 0).
#[inline(always)]
pub fn key(ray: &Ray, lo: Vec3, scale: Vec3) -> u64 {
    let cell = |x: f32, bits: u32| -> u64 {
        let max = ((1u32 << bits) - 1) as f32;
        // `as` saturates, and maps NaN to 0.
        x.clamp(0.0, max) as u64
    };
    let o = (ray.origin - lo) * scale;
    let d = (ray.dir + Vec3::ONE) * (0.5 * (1u32 << DIR_BITS) as f32);
    let origin = morton3(
        cell(o.x, ORIGIN_BITS),
        cell(o.y, ORIGIN_BITS),
        cell(o.z, ORIGIN_BITS),
    );
    let dir = morton3(
        cell(d.x, DIR_BITS),
        cell(d.y, DIR_BITS),
        cell(d.z, DIR_BITS),
    );
    u64::from(octant(ray.dir)) << (3 * (ORIGIN_BITS + DIR_BITS)) | origin << (3 * DIR_BITS) | dir
}

/// The per-axis scale of [`key`] for the box `[lo, hi]` (0 on a flat axis).
#[inline]
pub fn origin_scale(lo: Vec3, hi: Vec3) -> Vec3 {
    let cells = (1u32 << ORIGIN_BITS) as f32;
    let extent = hi - lo;
    Vec3::select(extent.cmpgt(Vec3::ZERO), cells / extent, Vec3::ZERO)
}

/// Interleaves the low 21 bits of three numbers, `x` lowest: a 3-D Morton code (Morton 1966;
/// the shift-and-mask spreading of Baert, Lagae & Dutré 2013, "Out-of-Core Construction of
/// Sparse Voxel Octrees", §4.1).
#[inline(always)]
pub fn morton3(x: u64, y: u64, z: u64) -> u64 {
    spread(x) | spread(y) << 1 | spread(z) << 2
}

/// The low 21 bits of `v`, two zero bits after each.
#[inline(always)]
fn spread(v: u64) -> u64 {
    let mut v = v & 0x1f_ffff;
    v = (v | v << 32) & 0x001f_0000_0000_ffff;
    v = (v | v << 16) & 0x001f_0000_ff00_00ff;
    v = (v | v << 8) & 0x100f_00f0_0f00_f00f;
    v = (v | v << 4) & 0x10c3_0c30_c30c_30c3;
    v = (v | v << 2) & 0x1249_2492_4924_9249;
    v
}

/// When rays may share a packet: the same octant, directions within a cone, origins close.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coherence {
    /// Smallest cosine between the first ray's direction and another's (−1: any direction of the
    /// octant; 1: only equal directions).
    pub min_cos: f32,
    /// Largest distance between the first ray's origin and another's, as a fraction of the scene
    /// box's diagonal (+∞: any).
    pub max_origin: f32,
}

impl Coherence {
    /// Whether `b` may join a packet led by `a` (`max_origin2`: the squared largest distance in
    /// scene units). Both must be finite.
    #[inline(always)]
    pub(crate) fn admits(&self, a: &Ray, b: &Ray, max_origin2: f32) -> bool {
        b.is_finite()
            && octant(a.dir) == octant(b.dir)
            && a.dir.dot(b.dir) >= self.min_cos
            && a.origin.distance_squared(b.origin) <= max_origin2
    }
}
