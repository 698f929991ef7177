//! The benchmark protocol's two camera framings (docs/BENCHMARKS.md, "Protocol").
//!
//! - [`Framing::Loose`]: [`kdray::rays::framing_camera`], a 45° pinhole on the scene's +z side
//!   whose field of view holds the bounding sphere. On a long, thin mesh most of its rays miss
//!   (about 78 % on the Stanford dragon), so its primary-ray figures say more about empty space
//!   than about the mesh. Its rays are those of every earlier `compare` table.
//! - [`Framing::Tight`]: [`tight_camera`], the same eye and view direction, with the image window
//!   shrunk to the mesh's projected bounds, so that the mesh spans the image edge to edge.

use glam::{DVec3, Vec3};
use kdray::rays::framing_camera;
use kdray_core::Ray;
use kdray_core::camera::{Camera, Frame, Pinhole};

/// Which camera frames the mesh.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Framing {
    Loose,
    Tight,
}

impl Framing {
    /// Both framings, loose first (the order of `compare`'s tables).
    pub const ALL: [Framing; 2] = [Framing::Loose, Framing::Tight];

    /// The name the tables print.
    pub fn name(self) -> &'static str {
        match self {
            Framing::Loose => "loose",
            Framing::Tight => "tight",
        }
    }

    /// One line saying how the camera is placed.
    pub fn description(self) -> &'static str {
        match self {
            Framing::Loose => "bounding sphere in a 45° field of view",
            Framing::Tight => "the mesh's projected bounds fill the image",
        }
    }
}

/// A pinhole whose image is an arbitrary window of its image plane: the point `(x, y)` of a
/// `W×H` image looks along `forward + s·right + t·up`, `s` running from `s[0]` at the left edge
/// to `s[1]` at the right one, `t` from `t[1]` at the top edge to `t[0]` at the bottom one.
///
/// [`Pinhole`] is the special case of a window centred on the view direction with square pixels;
/// this one may be off-centre and its pixels need not be square (the window's aspect is the
/// mesh's, the image's is the caller's).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WindowPinhole {
    frame: Frame,
    s: [f32; 2],
    t: [f32; 2],
}

impl Camera for WindowPinhole {
    #[inline]
    fn ray(&self, x: f32, y: f32, width: u32, height: u32) -> Ray {
        let (w, h) = (width.max(1) as f32, height.max(1) as f32);
        let s = self.s[0] + (self.s[1] - self.s[0]) * (x / w);
        let t = self.t[1] - (self.t[1] - self.t[0]) * (y / h);
        let f = &self.frame;
        Ray::new(f.eye, (f.forward + s * f.right + t * f.up).normalize())
    }
}

/// The loose framing's camera ([`framing_camera`]).
pub fn loose_camera(bounds: [Vec3; 2]) -> Option<Pinhole> {
    framing_camera(bounds)
}

/// The tight framing's camera: the loose camera's eye and orientation, its window the bounding
/// rectangle of every vertex of `triangles` projected onto the image plane (the projection of
/// the mesh itself, not of its bounding box, which would leave empty corners). Pixel edges, not
/// centres, lie on the rectangle's sides.
///
/// `None` where the loose camera is `None`, for no triangles, or when a vertex is not in front of
/// the eye (which the loose camera's placement rules out for a mesh inside `bounds`).
pub fn tight_camera(bounds: [Vec3; 2], triangles: &[[Vec3; 3]]) -> Option<WindowPinhole> {
    if triangles.is_empty() {
        return None;
    }
    let loose = loose_camera(bounds)?;
    let center = 0.5 * (bounds[0] + bounds[1]);
    let frame = Frame::look_at(loose.eye(), center, Vec3::Y).ok()?;
    let (eye, axes) = (
        frame.eye.as_dvec3(),
        [frame.right, frame.up, frame.forward].map(Vec3::as_dvec3),
    );
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in triangles.iter().flatten() {
        let d: DVec3 = p.as_dvec3() - eye;
        let depth = d.dot(axes[2]);
        if depth.is_nan() || depth <= 0.0 {
            return None;
        }
        for (k, axis) in axes[..2].iter().enumerate() {
            let q = d.dot(*axis) / depth;
            lo[k] = lo[k].min(q);
            hi[k] = hi[k].max(q);
        }
    }
    // A flat mesh seen edge-on projects to a line: give the window some extent.
    for k in 0..2 {
        if hi[k] <= lo[k] {
            let pad = 1e-6 * (1.0 + lo[k].abs());
            (lo[k], hi[k]) = (lo[k] - pad, hi[k] + pad);
        }
    }
    let window = WindowPinhole {
        frame,
        s: [lo[0] as f32, hi[0] as f32],
        t: [lo[1] as f32, hi[1] as f32],
    };
    (window.s.iter().chain(&window.t).all(|v| v.is_finite())).then_some(window)
}

#[cfg(test)]
mod tests {
    use super::*;
    use kdray::rays::primary_rays;

    /// A unit square in the z = 0 plane, off-centre in the bounds the tests give (which a scene
    /// with more in it than the square would have).
    fn square() -> Vec<[Vec3; 3]> {
        let [a, b, c, d] = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        vec![[a, b, c], [a, c, d]]
    }

    /// Where `ray` crosses the plane z = 0.
    fn on_plane(ray: &Ray) -> Vec3 {
        ray.at(-ray.origin.z / ray.dir.z)
    }

    #[test]
    fn the_window_is_the_projected_bounds() {
        let bounds = [Vec3::new(-1.0, -1.0, -1.0), Vec3::new(1.0, 1.0, 1.0)];
        let camera = tight_camera(bounds, &square()).expect("camera");
        // The image's corners, as continuous coordinates, land on the square's corners.
        for (x, y, want) in [
            (0.0, 0.0, Vec3::new(0.0, 1.0, 0.0)),
            (8.0, 0.0, Vec3::new(1.0, 1.0, 0.0)),
            (0.0, 4.0, Vec3::new(0.0, 0.0, 0.0)),
            (8.0, 4.0, Vec3::new(1.0, 0.0, 0.0)),
        ] {
            let p = on_plane(&camera.ray(x, y, 8, 4));
            assert!((p - want).length() < 1e-5, "({x}, {y}): {p} != {want}");
        }
        // Every pixel centre's ray hits the square, none of the loose camera's corners does.
        for ray in primary_rays(&camera, 8, 4) {
            let p = on_plane(&ray);
            assert!(
                (0.0..=1.0).contains(&p.x) && (0.0..=1.0).contains(&p.y),
                "{p}"
            );
        }
        let loose = loose_camera(bounds).expect("camera");
        let p = on_plane(&loose.pixel_ray(0, 0, 8, 4));
        assert!(p.x < 0.0 && p.y > 1.0, "{p}");
    }

    #[test]
    fn tight_shares_the_loose_eye() {
        let bounds = [Vec3::new(-1.0, -1.0, -1.0), Vec3::new(1.0, 1.0, 1.0)];
        let tight = tight_camera(bounds, &square()).expect("camera");
        let loose = loose_camera(bounds).expect("camera");
        assert_eq!(tight.ray(3.0, 2.0, 8, 4).origin, loose.eye());
    }

    #[test]
    fn degenerate_inputs_give_none_or_a_finite_window() {
        let bounds = [Vec3::ZERO, Vec3::ONE];
        assert!(tight_camera(bounds, &[]).is_none());
        // A triangle behind the eye.
        let behind = [[Vec3::new(0.0, 0.0, 1e3); 3]];
        assert!(tight_camera(bounds, &behind).is_none());
        // A segment seen edge-on: still a camera, with finite rays.
        let edge_on = [[Vec3::ZERO, Vec3::ZERO, Vec3::new(0.0, 0.0, 1.0)]];
        let camera = tight_camera(bounds, &edge_on).expect("camera");
        assert!(camera.ray(0.5, 0.5, 1, 1).dir.is_finite());
    }
}
