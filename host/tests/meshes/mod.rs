//! Meshes the builder's tests generate.

use glam::Vec3;

/// A UV sphere of `n × n` quads around `center`: its poles are fans of thin triangles sharing one
/// vertex, a dense spot that the cost model wants to split past pbrt-v3's depth limit.
pub fn uv_sphere(n: u32, center: Vec3, radius: f32) -> Vec<[Vec3; 3]> {
    let point = |i: u32, j: u32| {
        let (theta, phi) = (
            core::f32::consts::PI * i as f32 / n as f32,
            core::f32::consts::TAU * j as f32 / n as f32,
        );
        center
            + radius
                * Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                )
    };
    let mut triangles = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let (a, b, c, d) = (
                point(i, j),
                point(i + 1, j),
                point(i + 1, j + 1),
                point(i, j + 1),
            );
            triangles.extend([[a, b, c], [a, c, d]]);
        }
    }
    triangles
}
