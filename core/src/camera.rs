//! Cameras: each gives the ray through a point of a `W×H` image.
//!
//! Image coordinates are continuous: pixel `(i, j)` covers `[i, i+1) × [j, j+1)`, its centre is
//! `(i + 0.5, j + 0.5)`, `i` runs left to right and `j` top to bottom. [`Camera::pixel_ray`] gives
//! the centre's ray; a renderer jitters inside the pixel with [`Camera::ray`].

use crate::math;
use crate::ray::Ray;
use glam::Vec3;

/// Anything that maps an image point to a ray.
pub trait Camera {
    /// The ray through the continuous image point `(x, y)` of a `width × height` image.
    fn ray(&self, x: f32, y: f32, width: u32, height: u32) -> Ray;

    /// The ray through the centre of pixel `(i, j)`.
    #[inline]
    fn pixel_ray(&self, i: u32, j: u32, width: u32, height: u32) -> Ray {
        self.ray(i as f32 + 0.5, j as f32 + 0.5, width, height)
    }
}

/// Why a camera description was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraError {
    /// A `{start, middle, end}` triple whose middle is not the midpoint.
    MiddleNotMidpoint,
    /// A non-finite value, or a zero-length / parallel set of pinhole vectors.
    Degenerate,
}

/// An angle or offset range given as the seed's `{start, middle, end}`: pixel centres are spaced
/// evenly from `start` (first pixel) to `end` (last pixel), so the middle pixel of an odd count
/// lands on the middle value (NOTES.md §3.2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Span {
    pub start: f32,
    pub end: f32,
}

impl Span {
    /// From the seed's `{start, middle, end}`; the middle must be the midpoint (to 1e-4 of the
    /// span's length), since the seed uses it only as documentation of the range.
    pub fn from_triple(v: [f32; 3]) -> Result<Self, CameraError> {
        let [start, middle, end] = v;
        if !(start.is_finite() && middle.is_finite() && end.is_finite()) {
            return Err(CameraError::Degenerate);
        }
        let tol = 1e-4 * (end - start).abs().max(1.0);
        if (middle - 0.5 * (start + end)).abs() > tol {
            return Err(CameraError::MiddleNotMidpoint);
        }
        Ok(Self { start, end })
    }

    /// The value at continuous coordinate `x` of `n` pixels: `start` at the first pixel's centre,
    /// `end` at the last one's; the middle for a single pixel.
    #[inline]
    pub fn at(&self, x: f32, n: u32) -> f32 {
        if n <= 1 {
            return 0.5 * (self.start + self.end);
        }
        self.start + (self.end - self.start) * ((x - 0.5) / (n - 1) as f32)
    }
}

/// The seed's direction from spherical angles (equation (3)), in degrees:
/// `(sinθ cosφ, sinθ sinφ, cosθ)`.
#[inline]
pub fn spherical_dir(phi_deg: f32, theta_deg: f32) -> Vec3 {
    let (sp, cp) = math::sin_cos(math::radians(phi_deg));
    let (st, ct) = math::sin_cos(math::radians(theta_deg));
    Vec3::new(st * cp, st * sp, ct)
}

/// A pinhole perspective camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pinhole {
    eye: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    tan_half_vfov: f32,
}

impl Pinhole {
    /// Looking from `eye` at `target`, `up` giving the image's up direction, `vfov_deg` the
    /// vertical field of view in degrees (in `(0, 180)`).
    pub fn look_at(eye: Vec3, target: Vec3, up: Vec3, vfov_deg: f32) -> Result<Self, CameraError> {
        let forward = (target - eye)
            .try_normalize()
            .ok_or(CameraError::Degenerate)?;
        let right = forward
            .cross(up)
            .try_normalize()
            .ok_or(CameraError::Degenerate)?;
        if !(eye.is_finite() && vfov_deg > 0.0 && vfov_deg < 180.0) {
            return Err(CameraError::Degenerate);
        }
        let up = right.cross(forward);
        let tan_half_vfov =
            math::sin(math::radians(0.5 * vfov_deg)) / math::cos(math::radians(0.5 * vfov_deg));
        Ok(Self {
            eye,
            forward,
            right,
            up,
            tan_half_vfov,
        })
    }

    /// The eye point.
    pub fn eye(&self) -> Vec3 {
        self.eye
    }
}

impl Camera for Pinhole {
    #[inline]
    fn ray(&self, x: f32, y: f32, width: u32, height: u32) -> Ray {
        let (w, h) = (width.max(1) as f32, height.max(1) as f32);
        let sx = (2.0 * x / w - 1.0) * self.tan_half_vfov * (w / h);
        let sy = (1.0 - 2.0 * y / h) * self.tan_half_vfov;
        let dir = (self.forward + sx * self.right + sy * self.up).normalize();
        Ray::new(self.eye, dir)
    }
}

/// The seed's fisheye camera (§3.2): one origin, directions evenly spaced in φ (horizontal, left to
/// right) and θ (vertical, top to bottom), `d = (sinθ cosφ, sinθ sinφ, cosθ)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fisheye {
    pub origin: Vec3,
    /// φ in degrees across the image's width.
    pub phi: Span,
    /// θ in degrees down the image's height.
    pub theta: Span,
}

impl Camera for Fisheye {
    #[inline]
    fn ray(&self, x: f32, y: f32, width: u32, height: u32) -> Ray {
        Ray::new(
            self.origin,
            spherical_dir(self.phi.at(x, width), self.theta.at(y, height)),
        )
    }
}

/// The seed's parallel (orthographic) camera (§3.3): one direction `d(φ, θ)`, origins shifted along
/// `vec2 = (−sinφ, cosφ, 0)` across the width and `vec1 = (cosθ cosφ, cosθ sinφ, −sinθ)` down the
/// height (equations (4)–(5)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Parallel {
    origin: Vec3,
    dir: Vec3,
    vec1: Vec3,
    vec2: Vec3,
    horizontal: Span,
    vertical: Span,
}

impl Parallel {
    /// `phi_deg`, `theta_deg`: the rotation; `horizontal` and `vertical`: the offset ranges along
    /// `vec2` and `vec1`.
    pub fn new(
        origin: Vec3,
        phi_deg: f32,
        theta_deg: f32,
        horizontal: Span,
        vertical: Span,
    ) -> Self {
        let (sp, cp) = math::sin_cos(math::radians(phi_deg));
        let (st, ct) = math::sin_cos(math::radians(theta_deg));
        Self {
            origin,
            dir: Vec3::new(st * cp, st * sp, ct),
            vec1: Vec3::new(ct * cp, ct * sp, -st),
            vec2: Vec3::new(-sp, cp, 0.0),
            horizontal,
            vertical,
        }
    }

    /// The shared direction of every ray.
    pub fn dir(&self) -> Vec3 {
        self.dir
    }

    /// The horizontal (`vec2`) and vertical (`vec1`) shift axes.
    pub fn axes(&self) -> (Vec3, Vec3) {
        (self.vec2, self.vec1)
    }
}

impl Camera for Parallel {
    #[inline]
    fn ray(&self, x: f32, y: f32, width: u32, height: u32) -> Ray {
        let o = self.origin
            + self.horizontal.at(x, width) * self.vec2
            + self.vertical.at(y, height) * self.vec1;
        Ray::new(o, self.dir)
    }
}
