//! The torus knot the npm package's benchmarks build (three.js's `TorusKnotGeometry(1, 0.3, 512,
//! 100)`, the mesh three-mesh-bvh's own benchmarks use: 102,400 triangles), made here for the
//! native benchmarks by three.js's construction — each vertex computed in f64 as JavaScript
//! computes it and stored as f32, triangles in its index order — so that `front torusknot` builds
//! the mesh `node bench/build.mjs` builds.

use glam::{DVec3, Vec3};
use kdray::geometry::Geometry;

/// The name that stands for the knot where a mesh path is expected.
pub const NAME: &str = "torusknot";

/// A point of the (p, q) torus knot's curve of radius `radius` at parameter `u`
/// (three.js's `calculatePositionOnCurve`).
fn on_curve(u: f64, p: f64, q: f64, radius: f64) -> DVec3 {
    let quo = q / p * u;
    let cs = quo.cos();
    DVec3::new(
        radius * (2.0 + cs) * 0.5 * u.cos(),
        radius * (2.0 + cs) * u.sin() * 0.5,
        radius * quo.sin() * 0.5,
    )
}

/// `TorusKnotGeometry(radius, tube, tubular, radial)` with three.js's default `p = 2`, `q = 3`.
pub fn torus_knot(radius: f64, tube: f64, tubular: usize, radial: usize) -> Geometry {
    let (p, q) = (2.0, 3.0);
    let mut vertices = Vec::with_capacity((tubular + 1) * (radial + 1));
    for j in 0..=tubular {
        let u = j as f64 / tubular as f64 * p * core::f64::consts::TAU;
        let p1 = on_curve(u, p, q, radius);
        let p2 = on_curve(u + 0.01, p, q, radius);
        let t = p2 - p1;
        let n = p2 + p1;
        let b = t.cross(n);
        let n = b.cross(t).normalize();
        let b = b.normalize();
        for i in 0..=radial {
            let v = i as f64 / radial as f64 * core::f64::consts::TAU;
            let (cx, cy) = (-tube * v.cos(), tube * v.sin());
            vertices.push((p1 + cx * n + cy * b).as_vec3());
        }
    }
    let at = |j: usize, i: usize| vertices[(radial + 1) * j + i];
    let mut triangles: Vec<[Vec3; 3]> = Vec::with_capacity(2 * tubular * radial);
    for j in 1..=tubular {
        for i in 1..=radial {
            let (a, b, c, d) = (at(j - 1, i - 1), at(j, i - 1), at(j, i), at(j - 1, i));
            triangles.push([a, b, d]);
            triangles.push([b, c, d]);
        }
    }
    Geometry {
        triangles,
        ..Geometry::default()
    }
}

/// The benchmarks' knot: `TorusKnotGeometry(1, 0.3, 512, 100)`.
pub fn benchmark_knot() -> Geometry {
    torus_knot(1.0, 0.3, 512, 100)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_benchmark_knot_has_three_js_counts_and_a_closed_tube() {
        let g = benchmark_knot();
        assert_eq!(g.triangles.len(), 102_400);
        // Every vertex lies `tube` from the curve's point of its ring: the first ring's
        // vertices are 0.3 from the curve's point at u = 0, (1.5, 0, 0).
        let centre = Vec3::new(1.5, 0.0, 0.0);
        for t in g.triangles[..200].iter().step_by(2) {
            let d = (t[0] - centre).length();
            assert!((d - 0.3).abs() < 1e-5, "{d}");
        }
        // Triangles 0, 12,345 and the last as three.js 0.187 makes them (read from its
        // `position` and `index` attributes in Node): all three vertices, in its order, to f32
        // rounding of the f64 math.
        let three: [(usize, [[f64; 3]; 3]); 3] = [
            (
                0,
                [
                    [
                        1.2000092267990112,
                        -0.002099963603541255,
                        -0.0010499992640689015,
                    ],
                    [
                        1.1995302438735962,
                        0.02439998835325241,
                        0.012200361117720604,
                    ],
                    [
                        1.2006011009216309,
                        0.0063285245560109615,
                        -0.017896335572004318,
                    ],
                ],
            ),
            (
                12_345,
                [
                    [-0.0776594877243042, 0.5749834179878235, 0.6397854089736938],
                    [-0.06572430580854416, 0.5604362487792969, 0.638727068901062],
                    [-0.03764911741018295, 0.5719476938247681, 0.6535686254501343],
                ],
            ),
            (
                102_399,
                [
                    [
                        1.2006011009216309,
                        -0.010520163923501968,
                        0.015800481662154198,
                    ],
                    [
                        1.2000092267990112,
                        -0.002099963603541255,
                        -0.0010499992640689015,
                    ],
                    [
                        1.1993498802185059,
                        -0.028596600517630577,
                        -0.014299695380032063,
                    ],
                ],
            ),
        ];
        for (k, want) in three {
            for (c, v) in want.into_iter().enumerate() {
                let got = g.triangles[k][c];
                let d = (got.as_dvec3() - DVec3::from(v)).abs().max_element();
                assert!(d < 1e-6, "triangle {k} vertex {c}: {got} against {v:?}");
            }
        }
        // The tube closes: the last ring repeats the first (u = 4π is u = 0 on the curve).
        let (first, last) = (g.triangles[0][0], g.triangles[g.triangles.len() - 200][1]);
        assert!((first - last).length() < 1e-5, "{first} {last}");
    }
}
