//! The packets' cull ([`super::cull`]) against their lane tests ([`super::packet`]): a test
//! module of its own, as it imports both (the cull is below the packet walk).

use super::cull::Cull;
use crate::instance::packet::{PacketSlabs, finite_lanes};
use crate::instance::{NODE_WORDS, WIDTH, node};
use crate::ray::Ray;
use crate::simd::f32x8;
use crate::simd::lanes::Lanes;
use crate::simd::packet::RayPacket;
use glam::Vec3;

/// xorshift64*: the core has no random crate, and this needs none.
struct Rng(u64);

impl Rng {
    fn unit(&mut self) -> f32 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 40) as f32 / (1u64 << 24) as f32
    }
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.unit()
    }
    fn vec(&mut self, lo: f32, hi: f32) -> Vec3 {
        Vec3::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }
}

/// The cull never leaves out a slot that some lane's own test enters, on packets of one
/// origin or spread ones, narrow or wide cones, and boxes placed to graze the rays (a corner
/// on a ray, at its origin or where it starts; zero-sized boxes; boxes before `tmin` or past
/// `tmax`); and it does leave out slots (it is not a mask of every slot). Checked to fail
/// with the origin bounds swapped and without the widening.
#[test]
fn the_cull_keeps_every_slot_a_lane_enters() {
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let (mut kept, mut culled) = (0u32, 0u32);
    for case in 0..20_000 {
        let spread = [0.0, 1e-3, 0.5][case % 3];
        let cone = [1e-3, 0.2, 0.9][case / 3 % 3];
        let signs = Vec3::new(
            if rng.unit() < 0.5 { -1.0 } else { 1.0 },
            if rng.unit() < 0.5 { -1.0 } else { 1.0 },
            if rng.unit() < 0.5 { -1.0 } else { 1.0 },
        );
        let base = rng.vec(0.05, 1.0) * signs;
        let origin = rng.vec(-4.0, 4.0);
        let rays: [Ray; 8] = core::array::from_fn(|_| {
            let d = (base + rng.vec(-cone, cone)).abs() * signs;
            let mut r = Ray::new(origin + rng.vec(-spread, spread), d.normalize());
            r.tmin = [0.0, rng.range(0.0, 2.0)][case % 2];
            r.tmax = [f32::INFINITY, rng.range(2.0, 20.0)][case / 2 % 2];
            r
        });
        let packet = RayPacket::<f32x8>::from_rays(&rays);
        let live = finite_lanes(&packet);
        let Some(cull) = Cull::new(&packet, live) else {
            continue;
        };
        let mut nd = [0u32; NODE_WORDS];
        for s in 0..WIDTH {
            let r = &rays[s];
            // Some boxes touch the ray where it starts or at the origin itself.
            let t = match s % 4 {
                0 => 0.0,
                1 => r.tmin,
                _ => rng.range(-1.0, 22.0),
            };
            let corner = r.origin + r.dir * t;
            let size = if rng.unit() < 0.2 {
                Vec3::ZERO
            } else {
                rng.vec(0.0, 1.0)
            };
            let shift = rng.vec(-1.0, 1.0) * size;
            let (lo, hi) = (corner + shift - size, corner + shift);
            for a in 0..3 {
                nd[node::BOXES + 16 * a + s] = lo[a].to_bits();
                nd[node::BOXES + 16 * a + 8 + s] = hi[a].to_bits();
            }
        }
        nd[node::COUNT] = WIDTH as u32;
        let slabs = PacketSlabs::new(&packet);
        let mask = cull.slots(&nd);
        for s in 0..WIDTH {
            let words = crate::instance::slot_words(&nd, s);
            let (m, _) = slabs.enter(&words, packet.tmax, f32x8::mask_from_bits(live));
            let entered = m.bitmask() != 0;
            assert!(
                !entered || mask & 1 << s != 0,
                "case {case}: slot {s} entered by lanes {:#b} but culled",
                m.bitmask()
            );
            if mask & 1 << s != 0 {
                kept += 1;
            } else {
                culled += 1;
            }
        }
    }
    assert!(
        kept > 10_000 && culled > 10_000,
        "{kept} kept, {culled} culled"
    );
}
