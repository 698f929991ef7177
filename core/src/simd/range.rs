//! When a packet's Möller–Trumbore tests cannot overflow f32 in a scene, so that the packet walk
//! needs no per-test check that sends overflowing lanes to the f64 kernel ([`crate::far`]).
//!
//! The packet kernel ([`super::kernels::intersect_triangle_prepared`]) redoes a lane in f64 when
//! the ray is not parallel to the triangle yet `α + β` or `t` came out infinite or NaN: some
//! product overflowed. Checking that costs eight or so instructions a test, on every triangle a
//! packet meets (12 % of the instructions of the bunny's 8-wide primary packets). Whether it can
//! happen at all is known once per packet from bounds on its rays and on the scene:
//!
//! - every hittable triangle lies in the header's box (validated), so each vertex coordinate is
//!   at most `M` in magnitude and each edge coordinate at most `2M`;
//! - each active lane's origin and direction coordinates are at most `O` and `D` in magnitude, so
//!   each coordinate of `s = o − v0` is at most `S = O + M`;
//! - then `p = d × e2` is at most `4DM` a coordinate, `det = e1·p` at most `24DM²`, `s·p` and
//!   `d·q` at most `12SDM`, `q = s × e1` at most `4SM` and `e2·q` at most `24SM²`; `K`, twice the
//!   largest, covers the roundings on the way (each well under a part in a million);
//! - a lane that passes `det² > min_det2` has `|det| ≥ τ`, the square root of the smallest finite
//!   threshold in the scene, so `1/det` is at most `1/τ` (finite: `τ` is checked to be normal),
//!   and `α`, `β`, `t` and `α + β` are at most `3K/τ`.
//!
//! When `K` and `3K/τ` stay below `1e38` nothing can overflow, and the unchecked kernel
//! ([`super::kernels::intersect_triangle_in_range`]) gives the checked one's bits. The packet walk
//! traces the other packets (an infinite coordinate, rays from very far, huge or sliver
//! triangles) lane by lane with the single-ray walk, whose kernel checks only on a miss. The bound
//! is taken lane by lane in f32: one that overflows, or is NaN, fails.

use super::lanes::Lanes;
use super::packet::RayPacket;
use glam::Vec3;

/// Below `f32::MAX` (3.4e38), with room for the roundings of the bound itself.
const LIMIT: f32 = 1.0e38;

/// The smallest `τ` for which `1/τ` is finite and normal in f32, with a margin.
const TAU_MIN: f32 = 1.0e-36;

/// What [`cannot_overflow`] needs of a scene, worked out once when it is loaded.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneRange {
    /// `M`: the largest magnitude of a coordinate of the header's box.
    m: f32,
    /// `LIMIT·τ/3` (at most `LIMIT`), or 0 when `τ` is too small for any packet to pass.
    limit_over_inv: f32,
}

impl SceneRange {
    /// The range of a scene whose hittable triangles lie in `bounds` and whose smallest finite
    /// threshold [`crate::Triangle::min_det2`] is `min_threshold` (`+inf` when there is none).
    pub fn new(bounds: [Vec3; 2], min_threshold: f32) -> Self {
        // In f32 (the core has no f64 square root): `τ` rounded by a part in 2²⁴.
        let tau = f64::from(crate::math::sqrt(min_threshold));
        let limit_over_inv = if tau > f64::from(TAU_MIN) {
            (f64::from(LIMIT) * tau / 3.0).min(f64::from(LIMIT)) as f32
        } else {
            0.0
        };
        Self {
            m: bounds[0].abs().max(bounds[1].abs()).max_element(),
            limit_over_inv,
        }
    }
}

/// Whether no f32 Möller–Trumbore test of the active lanes of `rays` against any hittable
/// triangle of a scene of range `range` can overflow. See the module docs. Lane by lane in f32:
/// a bound that itself overflows, or a NaN one, fails.
#[inline]
pub fn cannot_overflow<L: Lanes>(rays: &RayPacket<L>, range: &SceneRange) -> bool {
    let largest = |v: &super::lanes::Vec3x<L>| v.x.abs().max(v.y.abs()).max(v.z.abs());
    let m = L::splat(range.m);
    let (o, d) = (largest(&rays.origin), largest(&rays.dir));
    let s = o + m;
    let k = L::splat(48.0) * (d * m * m).max(s * m * m) + L::splat(24.0) * s * d * m;
    let fine = k.lt(L::splat(range.limit_over_inv));
    (fine | !rays.active).all()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ray::Ray;
    use crate::simd::f32x8;
    use crate::simd::lanes::Lanes;

    const UNIT: [Vec3; 2] = [Vec3::splat(-1.0), Vec3::splat(1.0)];
    const NEAR: Vec3 = Vec3::new(0.0, 0.0, 5.0);

    fn packet(origin: Vec3, dir: Vec3) -> RayPacket<f32x8> {
        RayPacket::from_rays(&[Ray::new(origin, dir); 8])
    }

    fn ok(rays: &RayPacket<f32x8>, bounds: [Vec3; 2], min_threshold: f32) -> bool {
        cannot_overflow(rays, &SceneRange::new(bounds, min_threshold))
    }

    #[test]
    fn ordinary_packets_need_no_check() {
        assert!(ok(&packet(NEAR, -Vec3::Z), UNIT, 1e-20));
        // No hittable triangle at all.
        assert!(ok(
            &packet(Vec3::splat(1e10), -Vec3::Z),
            UNIT,
            f32::INFINITY
        ));
    }

    #[test]
    fn far_origins_large_scenes_slivers_and_infinities_need_it() {
        let far = Vec3::new(0.0, 0.0, 1e30);
        assert!(!ok(&packet(far, -Vec3::Z), UNIT, 1e-20));
        let huge = [Vec3::splat(-1e19), Vec3::splat(1e19)];
        assert!(!ok(&packet(NEAR, -Vec3::Z), huge, 1.0));
        assert!(!ok(&packet(NEAR, -Vec3::Z * 1e37), UNIT, 1.0));
        // Slivers: the smallest threshold bounds 1/det. Rays from 1e16 away fit a scene whose
        // thresholds are 1 and not one with a subnormal threshold (τ = 1e-22).
        let away = Vec3::new(0.0, 0.0, 1e16);
        assert!(ok(&packet(away, -Vec3::Z), UNIT, 1.0));
        assert!(!ok(&packet(away, -Vec3::Z), UNIT, 1e-44));
        assert!(ok(&packet(NEAR, -Vec3::Z), UNIT, 1e-44));
        // The largest finite origin.
        assert!(!ok(
            &packet(Vec3::new(f32::MAX, 0.0, 0.0), -Vec3::Z),
            UNIT,
            1.0
        ));
    }

    #[test]
    fn inactive_lanes_do_not_count() {
        let mut rays = [Ray::new(NEAR, -Vec3::Z); 8];
        rays[7].origin = Vec3::splat(1e30);
        let mut p = RayPacket::<f32x8>::from_rays(&rays);
        assert!(!ok(&p, UNIT, 1e-20));
        p.active = f32x8::mask_from_bits(0b0111_1111);
        assert!(ok(&p, UNIT, 1e-20));
    }
}
