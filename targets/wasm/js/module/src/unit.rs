//! Fast mode's rays with a unit direction. Möller–Trumbore (the fast kernel) compares its
//! determinant, which scales with the direction's length, against a fixed epsilon, so a short
//! direction such as (0, 0, −1e−7) misses what a unit one hits. The package promises distances
//! in lengths of the direction, for any length: fast-mode queries trace the ray with its
//! direction divided by its length and `tmin`, `tmax` multiplied by it, and divide the hit's `t`
//! by it again. The watertight kernel is scale-free and gets the ray as given (its exactness on
//! shared edges depends on the direction's exact bits).

use glam::Vec3;
use kdray_core::Ray;

/// A ray for the kernel of `watertight`, and the factor that turns its `t` back into lengths of
/// the given direction (1 when the ray is unchanged).
pub fn ray(watertight: bool, o: [f32; 3], d: [f32; 3], tmin: f32, tmax: f32) -> (Ray, f32) {
    let given = Ray {
        origin: Vec3::from_array(o),
        dir: Vec3::from_array(d),
        tmin,
        tmax,
    };
    if watertight || near_unit(given.dir) {
        return (given, 1.0);
    }
    // In f64: the squares of a subnormal f32 component do not underflow there.
    let [x, y, z] = d.map(f64::from);
    let len = (x * x + y * y + z * z).sqrt();
    if (len - 1.0).abs() < 1e-6 || len == 0.0 || !len.is_finite() {
        return (given, 1.0);
    }
    // `t_back` divides by the length in f32 (for a direction shorter than f32's smallest normal,
    // a subnormal of fewer bits): the interval is scaled by that same length, and ends where a
    // `t` would pass f32's range once divided back (issue 39: a direction of length 10⁻³⁸
    // reported a hit at `Infinity`).
    let len32 = len as f32;
    let ray = Ray {
        origin: given.origin,
        dir: Vec3::new((x / len) as f32, (y / len) as f32, (z / len) as f32),
        tmin: (f64::from(tmin) * f64::from(len32)) as f32,
        tmax: (f64::from(tmax).min(LARGEST_T) * f64::from(len32)) as f32,
    };
    (ray, len32)
}

/// The largest `t` a fast-mode hit may have, in lengths of the given direction: f32's largest
/// value less 2⁻²⁰ of it. The traced `tmax`, this times the length rounded to f32 (up by at most
/// 2⁻²⁴), then leaves every [`t_back`] finite.
const LARGEST_T: f64 = f32::MAX as f64 * (1.0 - 1.0 / (1u64 << 20) as f64);

/// Whether a direction is of unit length up to f32 rounding: such rays are traced as given, bit
/// for bit as `kdray trace` traces them (the common case, decided without f64).
#[inline]
pub fn near_unit(d: Vec3) -> bool {
    (d.length_squared() - 1.0).abs() < 2e-6
}

/// Fast mode's rays made unit in place ([`ray`] for each), with each one's factor pushed to
/// `lens`, which must have room for `rays.len()` of them (the caller skips this when every
/// direction is [`near_unit`]).
pub fn make_unit(rays: &mut [Ray], lens: &mut Vec<f32>) {
    for r in rays.iter_mut() {
        let (unit, len) = ray(false, r.origin.to_array(), r.dir.to_array(), r.tmin, r.tmax);
        *r = unit;
        lens.push(len);
    }
}

/// `t` of the unit ray, in lengths of the given direction.
pub fn t_back(t: f32, len: f32) -> f32 {
    if len == 1.0 {
        t
    } else {
        (f64::from(t) / f64::from(len)) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_and_long_directions_become_unit() {
        let (r, len) = ray(false, [0.0; 3], [0.0, 0.0, -1e-7], 0.0, 1e9);
        assert_eq!(r.dir, Vec3::new(0.0, 0.0, -1.0));
        assert!((len - 1e-7).abs() < 1e-13);
        assert!((r.tmax - 100.0).abs() < 1e-4);
        assert!((t_back(0.5, len) - 5e6).abs() < 1.0);
        let (r, len) = ray(false, [0.0; 3], [1e-39, 0.0, 0.0], 0.0, f32::INFINITY);
        assert_eq!(r.dir, Vec3::X);
        // Past this, `t` in lengths of the direction would pass f32's range (issue 39).
        assert!(r.tmax.is_finite() && len > 0.0);
        let (r, len) = ray(true, [0.0; 3], [0.0, 0.0, -1e-7], 0.0, 1.0);
        assert_eq!((r.dir.z, len), (-1e-7, 1.0));
        assert_eq!(ray(false, [0.0; 3], [0.0, 0.0, 0.0], 0.0, 1.0).1, 1.0);
        let (r, len) = ray(false, [0.0; 3], [0.6, 0.8, 1e-8], 0.0, 1.0);
        assert_eq!((r.dir, len), (Vec3::new(0.6, 0.8, 1e-8), 1.0));
    }

    /// Issue 39: a hit's `t` in lengths of the direction is finite, for directions down to the
    /// smallest subnormal.
    #[test]
    fn hits_of_short_directions_have_finite_distances() {
        for d in [1e-30f32, 1e-36, 1e-37, 2e-38, 1.2e-38, 1e-38, 1e-40, 1e-45] {
            let (r, len) = ray(false, [0.0; 3], [0.0, 0.0, -d], 0.0, f32::INFINITY);
            assert!(r.tmax > r.tmin, "|d| = {d:e}: {r:?}");
            // The largest `t` the traced ray can hit: just below its `tmax`.
            let t = f32::from_bits(r.tmax.to_bits() - 1);
            let back = t_back(t, len);
            assert!(back.is_finite(), "|d| = {d:e}: t {t} comes back as {back}");
        }
    }
}
