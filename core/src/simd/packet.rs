//! Ray and hit packets: `W` rays or hits in struct-of-arrays lanes, with an active mask.

use super::lanes::{Lanes, Vec3x, set_lanes};
use crate::ray::{Hit, Ray};

/// Up to `W` rays in struct-of-arrays lanes.
///
/// A lane is *active* when it holds a ray that the kernels can give a meaningful answer for:
/// present (`i < rays.len()`) and finite ([`Ray::is_finite`]). Kernels compute every lane, but only
/// active lanes are ever recorded ([`record_closest`](super::kernels::record_closest)) or written
/// back ([`HitPacket::write_active`]), so a non-finite ray stays a miss, as in scalar traversal.
#[derive(Clone, Copy, Debug)]
pub struct RayPacket<L> {
    pub origin: Vec3x<L>,
    pub dir: Vec3x<L>,
    /// `1 / dir` by true division: `±inf` where a component is `±0`.
    pub inv_dir: Vec3x<L>,
    pub tmin: L,
    /// The open interval's upper end; the closest-hit update shrinks it to the nearest hit.
    pub tmax: L,
    /// Mask of active lanes.
    pub active: L,
}

impl<L: Lanes> RayPacket<L> {
    /// The packet of `rays[..W]`; lanes past `rays.len()` are inactive, and so is every ray that
    /// is not finite. Rays beyond the first `W` are ignored: feed `rays.chunks(W)`.
    ///
    /// An absent lane holds origin 0, direction 0 and the empty interval `(+inf, −inf)`, which no
    /// kernel hits (a zero direction is parallel to everything), so it is inert even unmasked.
    /// A present but non-finite ray keeps its values: the kernels compute it exactly as the scalar
    /// kernels would, and the active mask keeps it out of the results.
    #[inline]
    pub fn from_rays(rays: &[Ray]) -> Self {
        if let Some([ox, oy, oz, dx, dy, dz, tmin, tmax]) = L::ray_columns(rays) {
            // A whole packet: a register transpose, and `Ray::is_finite` lane-wise.
            let inf = L::splat(f32::INFINITY);
            let finite = |x: L| x.abs().lt(inf);
            let active = finite(ox)
                & finite(oy)
                & finite(oz)
                & finite(dx)
                & finite(dy)
                & finite(dz)
                & !tmin.is_nan()
                & !tmax.is_nan();
            let dir = Vec3x {
                x: dx,
                y: dy,
                z: dz,
            };
            return Self {
                origin: Vec3x {
                    x: ox,
                    y: oy,
                    z: oz,
                },
                dir,
                inv_dir: dir.recip(),
                tmin,
                tmax,
                active,
            };
        }
        const ABSENT: Ray = Ray {
            origin: glam::Vec3::ZERO,
            dir: glam::Vec3::ZERO,
            tmin: f32::INFINITY,
            tmax: f32::NEG_INFINITY,
        };
        let ray = |i: usize| rays.get(i).unwrap_or(&ABSENT);
        let dir = Vec3x::from_fn(|i| ray(i).dir);
        let mut active = 0u32;
        for (i, r) in rays.iter().take(L::WIDTH).enumerate() {
            active |= u32::from(r.is_finite()) << i;
        }
        Self {
            origin: Vec3x::from_fn(|i| ray(i).origin),
            dir,
            inv_dir: dir.recip(),
            tmin: L::from_fn(|i| ray(i).tmin),
            tmax: L::from_fn(|i| ray(i).tmax),
            active: L::mask_from_bits(active),
        }
    }

    /// The number of lanes, `W`.
    #[inline]
    pub fn width(&self) -> usize {
        L::WIDTH
    }

    /// Ray `i` as stored (with its current `tmax`).
    ///
    /// # Panics
    /// If `i >= W`.
    #[inline]
    pub fn ray(&self, i: usize) -> Ray {
        Ray {
            origin: self.origin.lane(i),
            dir: self.dir.lane(i),
            tmin: self.tmin.to_array().as_ref()[i],
            tmax: self.tmax.to_array().as_ref()[i],
        }
    }
}

/// The closest hits found so far for a [`RayPacket`], lane by lane; a lane with no hit holds
/// [`Hit::MISS`].
#[derive(Clone, Copy, Debug)]
pub struct HitPacket<L: Lanes> {
    pub t: L,
    pub prim: L::Index,
    pub u: L,
    pub v: L,
}

impl<L: Lanes> Default for HitPacket<L> {
    fn default() -> Self {
        Self::miss()
    }
}

impl<L: Lanes> HitPacket<L> {
    /// Every lane a miss ([`Hit::MISS`]).
    #[inline]
    pub fn miss() -> Self {
        Self {
            t: L::splat(Hit::MISS.t),
            prim: L::splat_index(Hit::MISS.prim),
            u: L::splat(Hit::MISS.u),
            v: L::splat(Hit::MISS.v),
        }
    }

    /// Lane `i` as a [`Hit`].
    ///
    /// # Panics
    /// If `i >= W`.
    #[inline]
    pub fn hit(&self, i: usize) -> Hit {
        Hit {
            t: self.t.to_array().as_ref()[i],
            prim: L::index_to_array(self.prim).as_ref()[i],
            u: self.u.to_array().as_ref()[i],
            v: self.v.to_array().as_ref()[i],
        }
    }

    /// Writes lane `i` to `out[i]` for each active lane of `rays` with `i < out.len()`; every
    /// other element of `out` is left untouched (so a caller that wants non-finite rays reported
    /// as misses fills `out` with [`Hit::MISS`] first).
    #[inline]
    pub fn write_active(&self, rays: &RayPacket<L>, out: &mut [Hit]) {
        let (t, prim, u, v) = (
            self.t.to_array(),
            L::index_to_array(self.prim),
            self.u.to_array(),
            self.v.to_array(),
        );
        for i in set_lanes(rays.active.bitmask()) {
            if let Some(slot) = out.get_mut(i) {
                *slot = Hit {
                    t: t.as_ref()[i],
                    prim: prim.as_ref()[i],
                    u: u.as_ref()[i],
                    v: v.as_ref()[i],
                };
            }
        }
    }
}
