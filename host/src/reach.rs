//! How far from a scene a ray may start before the triangle kernels' f32 products overflow.
//!
//! Möller–Trumbore's `t` is `e2·(s × e1) / det` with `s = o − v0`, and the watertight kernel's
//! `T` sums the edge functions (each up to `|e1|·|e2|`, together `det`) times the vertices'
//! sheared depths (up to `|s|` plus an edge): both stay below `√3·|e1|·|e2|·(|s| + |e|)`. Past
//! f32's 3.4e38 the product is `inf` or NaN and the ray misses a triangle it passes through (the
//! issue's (±3e12, …) triangle got no hit from the rays `kdray rays` makes for it). So, with
//! [`PRODUCT_MAX`] a quarter of f32's range:
//!
//! - `kdray build` refuses a scene whose largest `|e1|·|e2|` times twice its box's diagonal passes
//!   [`PRODUCT_MAX`] ([`check_scene`]), so that rays from up to a diagonal away (the framing
//!   camera of `kdray rays` is 1.3 diagonals from the centre) are always traced right;
//! - `kdray trace` refuses a ray whose origin lies farther from the scene than its largest
//!   triangle allows ([`check_rays`]), naming the ray.

use crate::error::{Error, Result};
use crate::geometry::Geometry;
use glam::{DVec3, Vec3};
use kdray_core::{Ray, Scene};
use std::path::Path;

/// The most `|e1|·|e2|·|o − v0|` may reach: f32's largest value over 4 (for the `√3` of a dot
/// product and the triangle's own extent).
pub const PRODUCT_MAX: f64 = f32::MAX as f64 / 4.0;

/// `|e1|·|e2|` of a triangle's vertices, in f64.
fn edge_product(t: &[Vec3; 3]) -> f64 {
    let [a, b, c] = t.map(|v| v.as_dvec3());
    (b - a).length() * (c - a).length()
}

/// The centre and radius of the sphere around the box `[lo, hi]`, in f64.
fn sphere_of(lo: DVec3, hi: DVec3) -> (DVec3, f64) {
    (0.5 * (lo + hi), 0.5 * (hi - lo).length())
}

/// Refuses geometry whose largest triangle, seen from twice its box's diagonal, would overflow
/// the kernels' products (module doc).
///
/// # Errors
/// The triangle with the largest `|e1|·|e2|`, by index, with the bound.
pub fn check_scene(path: &Path, g: &Geometry) -> Result<()> {
    let Some((i, product)) = g
        .triangles
        .iter()
        .map(edge_product)
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(&b.1))
    else {
        return Ok(());
    };
    let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for v in g.triangles.iter().flatten() {
        (lo, hi) = (lo.min(v.as_dvec3()), hi.max(v.as_dvec3()));
    }
    for &(c, r) in &g.spheres {
        let (c, r) = (c.as_dvec3(), f64::from(r));
        (lo, hi) = (lo.min(c - r), hi.max(c + r));
    }
    let diagonal = (hi - lo).length();
    if product * 2.0 * diagonal <= PRODUCT_MAX {
        return Ok(());
    }
    let msg = format!(
        "triangle {i} is too large for a scene this size in f32 arithmetic: its edges' lengths \
         multiply to {product:.3e}, which times twice the scene's diagonal ({diagonal:.3e}) \
         passes {PRODUCT_MAX:.3e} (docs/ROBUSTNESS.md); scale the scene down"
    );
    Err(Error::new(path, msg))
}

/// Refuses the first of `rays` whose origin is too far from `scene` for its largest triangle
/// (module doc): `(|o − c| + r)·max |e1|·|e2|` must stay within [`PRODUCT_MAX`], with `c`, `r`
/// the sphere around the scene's box.
///
/// # Errors
/// The ray's index, its distance and the most the scene allows, naming `path` (the rays file).
pub fn check_rays(path: &Path, scene: &Scene, rays: &[Ray]) -> Result<()> {
    let product = (0..scene.tri_count())
        .map(|i| edge_product(&scene.triangle(i).vertices()))
        .fold(0.0, f64::max);
    if product == 0.0 {
        return Ok(());
    }
    let [lo, hi] = scene.bounds();
    let (centre, radius) = sphere_of(lo.as_dvec3(), hi.as_dvec3());
    let reach = PRODUCT_MAX / product;
    let far = rays
        .iter()
        .position(|r| (r.origin.as_dvec3() - centre).length() + radius > reach);
    match far {
        None => Ok(()),
        Some(i) => {
            let distance = (rays[i].origin.as_dvec3() - centre).length();
            let msg = format!(
                "ray {i}: its origin is {distance:.3e} from the scene's centre; with the scene's \
                 largest triangle (edges' lengths multiplying to {product:.3e}) rays must start \
                 within {:.3e} of it, or the kernels' f32 products overflow (docs/ROBUSTNESS.md)",
                (reach - radius).max(0.0)
            );
            Err(Error::new(path, msg))
        }
    }
}
