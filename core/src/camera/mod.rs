//! Cameras: each gives the ray through a point of a `W×H` image.
//!
//! Image coordinates are continuous: pixel `(i, j)` covers `[i, i+1) × [j, j+1)`, its centre is
//! `(i + 0.5, j + 0.5)`, `i` runs left to right and `j` top to bottom. [`Camera::pixel_ray`] gives
//! the centre's ray; a renderer jitters inside the pixel and calls [`Camera::sample`], which a
//! camera with an aperture ([`ThickLens`]) overrides to pick a point on its lens.
//!
//! Kinds: [`Pinhole`]; Rukin's [`Fisheye`] (§3.2) and [`Parallel`] (§3.3); Rukin's lenses,
//! [`ThickLens`] ("Rays from a thin lens", `thick_lens.rs`) and [`LensArray`] ("lens array",
//! `lens_array.rs`).

mod lens_array;
mod thick_lens;

pub use lens_array::LensArray;
pub use thick_lens::{LensShape, ThickLens};

use crate::math;
use crate::ray::Ray;
use crate::sampling::Pcg32;
use glam::Vec3;

/// Anything that maps an image point to a ray.
pub trait Camera {
    /// The ray through the continuous image point `(x, y)` of a `width × height` image (for a
    /// camera with an aperture, its chief ray: the one through the aperture's centre).
    fn ray(&self, x: f32, y: f32, width: u32, height: u32) -> Ray;

    /// The ray through the centre of pixel `(i, j)`.
    #[inline]
    fn pixel_ray(&self, i: u32, j: u32, width: u32, height: u32) -> Ray {
        self.ray(i as f32 + 0.5, j as f32 + 0.5, width, height)
    }

    /// One sample of the image point `(x, y)`: a ray and the weight its radiance counts with, or
    /// `None` when the sample carries no light (a lens dropped it: a sample of zero). A camera with
    /// an aperture draws its lens point from `rng`; the default is [`Camera::ray`] with weight 1
    /// and draws nothing, so a pinhole's image does not depend on this method.
    #[inline]
    fn sample(
        &self,
        x: f32,
        y: f32,
        width: u32,
        height: u32,
        rng: &mut Pcg32,
    ) -> Option<(Ray, f32)> {
        let _ = rng;
        Some((self.ray(x, y, width, height), 1.0))
    }
}

/// Where a camera stands and how it is turned: a right-handed frame, `forward` the viewing
/// direction, `right` the image's left-to-right and `up` its bottom-to-top direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    pub eye: Vec3,
    pub forward: Vec3,
    pub right: Vec3,
    pub up: Vec3,
}

impl Frame {
    /// Looking from `eye` at `target`, `up` giving the image's up direction.
    ///
    /// # Errors
    /// [`CameraError::Degenerate`] for a non-finite `eye`, `eye == target` or `up` parallel to the
    /// view direction.
    pub fn look_at(eye: Vec3, target: Vec3, up: Vec3) -> Result<Self, CameraError> {
        let forward = (target - eye)
            .try_normalize()
            .ok_or(CameraError::Degenerate)?;
        let right = forward
            .cross(up)
            .try_normalize()
            .ok_or(CameraError::Degenerate)?;
        if !eye.is_finite() {
            return Err(CameraError::Degenerate);
        }
        Ok(Self {
            eye,
            forward,
            right,
            up: right.cross(forward),
        })
    }

    /// The local vector `(x, y, z)` (right, up, forward) in world space.
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        v.x * self.right + v.y * self.up + v.z * self.forward
    }
}

/// Why a camera description was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraError {
    /// A `{start, middle, end}` triple whose middle is not the midpoint.
    MiddleNotMidpoint,
    /// A non-finite value, or a zero-length / parallel set of pinhole vectors.
    Degenerate,
    /// A lens that cannot be built: see [`LensShape::new`].
    BadLens,
    /// A focus distance the lens cannot focus at (not farther than its focal length).
    CannotFocus,
}

/// An angle or offset range given as Rukin's `{start, middle, end}`: pixel centres are spaced
/// evenly from `start` (first pixel) to `end` (last pixel), so the middle pixel of an odd count
/// lands on the middle value (correcting Rukin §3.2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Span {
    pub start: f32,
    pub end: f32,
}

impl Span {
    /// From Rukin's `{start, middle, end}`; the middle must be the midpoint (to 1e-4 of the
    /// span's length), since Rukin uses it only as documentation of the range.
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

/// Rukin's direction from spherical angles (equation (3)), in degrees:
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
    frame: Frame,
    tan_half_vfov: f32,
}

impl Pinhole {
    /// Looking from `eye` at `target`, `up` giving the image's up direction, `vfov_deg` the
    /// vertical field of view in degrees (in `(0, 180)`).
    pub fn look_at(eye: Vec3, target: Vec3, up: Vec3, vfov_deg: f32) -> Result<Self, CameraError> {
        let frame = Frame::look_at(eye, target, up)?;
        Ok(Self {
            frame,
            tan_half_vfov: tan_half_angle(vfov_deg)?,
        })
    }

    /// The eye point.
    pub fn eye(&self) -> Vec3 {
        self.frame.eye
    }
}

/// `tan(fov/2)` of a field of view in degrees, which must lie in `(0, 180)`.
fn tan_half_angle(fov_deg: f32) -> Result<f32, CameraError> {
    if !(fov_deg > 0.0 && fov_deg < 180.0) {
        return Err(CameraError::Degenerate);
    }
    Ok(math::sin(math::radians(0.5 * fov_deg)) / math::cos(math::radians(0.5 * fov_deg)))
}

impl Camera for Pinhole {
    #[inline]
    fn ray(&self, x: f32, y: f32, width: u32, height: u32) -> Ray {
        let (w, h) = (width.max(1) as f32, height.max(1) as f32);
        let sx = (2.0 * x / w - 1.0) * self.tan_half_vfov * (w / h);
        let sy = (1.0 - 2.0 * y / h) * self.tan_half_vfov;
        let f = &self.frame;
        let dir = (f.forward + sx * f.right + sy * f.up).normalize();
        Ray::new(f.eye, dir)
    }
}

/// Rukin's fisheye camera (§3.2): one origin, directions evenly spaced in φ (horizontal, left to
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

/// Rukin's parallel (orthographic) camera (§3.3): one direction `d(φ, θ)`, origins shifted along
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
