//! Rukin's lens camera ("Rays from a thin lens", as corrected here): a thick lens of
//! two spherical surfaces, and a sensor behind it.
//!
//! Lens coordinates: the optical axis is `z`, pointing at the scene; `x` is the image's right, `y`
//! its up ([`Frame`]); the origin is the lens's centre, which the camera's `eye` places. The seed's
//! surfaces, `R1, R2 > 0` the radii of curvature and `l1, l2` the half thicknesses:
//!
//! ```text
//! front (faces the sensor; a camera ray crosses it first):  z = R1 − sqrt(R1² − x² − y²) − l1
//! rear  (faces the scene):                                  z = sqrt(R2² − x² − y²) − R2 + l2
//! ```
//!
//! that is spheres of radius `R1` about `(0, 0, R1 − l1)` and `R2` about `(0, 0, l2 − R2)`: a
//! biconvex lens with vertices at `z = −l1` and `z = l2`, cut off at the aperture radius `a` (its
//! rim). The sensor is the plane `z = −l1 − s`, `s` the sensor distance from the front vertex.
//!
//! A sample picks a point on the sensor and a point on the front surface inside the rim, and
//! follows the ray between them: into the glass at the front surface (the smaller root), out at
//! the rear surface (the larger root), each time by [`optics::refract`]. A ray that meets a surface
//! outside the rim (or misses its sphere: Rukin's negative radicand) or is totally internally
//! reflected at the rear surface is dropped. The image on the sensor is upside down and mirrored;
//! the sensor point is taken from the point-reflected pixel so that the picture is upright.

use super::{Camera, CameraError, Frame, tan_half_angle};
use crate::math;
use crate::optics;
use crate::ray::Ray;
use crate::sampling::Pcg32;
use crate::sphere::Sphere;
use core::f32::consts::TAU;
use glam::Vec3;

/// The glass: two spherical surfaces, an index of refraction and an aperture (rim) radius.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LensShape {
    /// Radius of curvature of the front (sensor-side) surface, `> 0`.
    pub r1: f32,
    /// Radius of curvature of the rear (scene-side) surface, `> 0`.
    pub r2: f32,
    /// Half thickness in front of the centre: the front vertex is at `z = −l1`.
    pub l1: f32,
    /// Half thickness behind the centre: the rear vertex is at `z = l2`.
    pub l2: f32,
    /// Index of refraction, `> 1` (the lens sits in air, index 1).
    pub ior: f32,
    /// Aperture radius: both surfaces end at this distance from the axis.
    pub aperture: f32,
}

impl LensShape {
    /// A lens from Rukin's parameters, checked.
    ///
    /// # Errors
    /// [`CameraError::BadLens`] unless every value is finite, `r1, r2 > 0`, `l1, l2 ≥ 0` with
    /// `l1 + l2 > 0`, `ior > 1`, `0 < aperture < min(r1, r2)`, and the glass is still thicker than
    /// 0 at the rim (the two surfaces do not cross inside the aperture).
    pub fn new(
        r1: f32,
        r2: f32,
        l1: f32,
        l2: f32,
        ior: f32,
        aperture: f32,
    ) -> Result<Self, CameraError> {
        let lens = Self {
            r1,
            r2,
            l1,
            l2,
            ior,
            aperture,
        };
        let ok = r1 > 0.0
            && r2 > 0.0
            && l1 >= 0.0
            && l2 >= 0.0
            && l1 + l2 > 0.0
            && ior > 1.0
            && aperture > 0.0
            && aperture < r1
            && aperture < r2
            && [r1, r2, l1, l2, ior, aperture]
                .iter()
                .all(|v| v.is_finite())
            && lens.edge_thickness() > 0.0;
        if ok {
            Ok(lens)
        } else {
            Err(CameraError::BadLens)
        }
    }

    /// The glass's thickness at the rim: `l1 + l2` minus both surfaces' sag at the aperture.
    pub fn edge_thickness(&self) -> f32 {
        let sag = |r: f32| r - math::sqrt(r * r - self.aperture * self.aperture);
        self.l1 + self.l2 - sag(self.r1) - sag(self.r2)
    }

    /// The focal length by the lensmaker's equation for a thick lens in air (Hecht, *Optics*, 4th
    /// ed., §6.2, eq. 6.2): `1/f = (n − 1)(1/R_a − 1/R_b + (n − 1)d/(n R_a R_b))` with the signed
    /// radii of the surfaces in the order light crosses them. Here `R_a = R1`, `R_b = −R2` (the
    /// seed's radii are unsigned and the lens is biconvex), `d = l1 + l2`; the same either way
    /// through the lens.
    pub fn focal_length(&self) -> f32 {
        let (n, d) = (self.ior, self.l1 + self.l2);
        let power =
            (n - 1.0) * (1.0 / self.r1 + 1.0 / self.r2 - (n - 1.0) * d / (n * self.r1 * self.r2));
        1.0 / power
    }

    /// The `z` of the two principal planes, `(sensor side, scene side)` (Hecht §6.2, eqs. 6.3 and
    /// 6.4: `h1 = −f(n − 1)d/(n R_b)` from the first vertex, `h2 = −f(n − 1)d/(n R_a)` from the
    /// second, crossing from the sensor side).
    pub fn principal_planes(&self) -> (f32, f32) {
        let (n, d, f) = (self.ior, self.l1 + self.l2, self.focal_length());
        let h1 = f * (n - 1.0) * d / (n * self.r2);
        let h2 = -f * (n - 1.0) * d / (n * self.r1);
        (-self.l1 + h1, self.l2 + h2)
    }

    /// The focus helper: the sensor distance (from the front vertex) that brings the plane
    /// `focus` in front of the lens's centre into focus, from the Gaussian lens formula
    /// `1/s_o + 1/s_i = 1/f` with `s_o` measured from the scene-side principal plane and `s_i`
    /// from the sensor-side one. `None` when the plane is not farther than the focal length from
    /// the scene-side principal plane (no real image) or not finite.
    pub fn sensor_distance(&self, focus: f32) -> Option<f32> {
        let f = self.focal_length();
        let (h_sensor, h_scene) = self.principal_planes();
        let s_o = focus - h_scene;
        if !(s_o > f && s_o.is_finite()) {
            return None;
        }
        let s_i = 1.0 / (1.0 / f - 1.0 / s_o);
        let s = s_i - (h_sensor + self.l1);
        (s > 0.0 && s.is_finite()).then_some(s)
    }

    /// The front surface's sphere (centre `(0, 0, R1 − l1)`).
    fn front(&self) -> Sphere {
        Sphere {
            center: Vec3::new(0.0, 0.0, self.r1 - self.l1),
            radius: self.r1,
        }
    }

    /// The rear surface's sphere (centre `(0, 0, l2 − R2)`).
    fn rear(&self) -> Sphere {
        Sphere {
            center: Vec3::new(0.0, 0.0, self.l2 - self.r2),
            radius: self.r2,
        }
    }

    /// Whether a point lies inside the rim (`x² + y² ≤ a²`).
    fn inside_rim(&self, p: Vec3) -> bool {
        p.x * p.x + p.y * p.y <= self.aperture * self.aperture
    }

    /// Follows a ray (lens coordinates, unit `dir`) from the sensor side through the glass: the
    /// ray that leaves the rear surface, or `None` when it meets a surface outside the rim,
    /// misses one, or is totally internally reflected.
    pub fn refract_through(&self, origin: Vec3, dir: Vec3) -> Option<Ray> {
        // Seed eqs. (6)–(10): into the glass at the front surface's smaller root ...
        let front = self.front();
        let (t1, _) = front.roots(&Ray::new(origin, dir))?;
        let p1 = origin + t1 * dir;
        if !(t1 > 0.0 && self.inside_rim(p1)) {
            return None;
        }
        let d1 = optics::refract(dir, front.normal(p1), 1.0, self.ior)?.try_normalize()?;
        // ... and out at the rear surface's larger root (Rukin's "positive sign").
        let rear = self.rear();
        let (_, t2) = rear.roots(&Ray::new(p1, d1))?;
        let p2 = p1 + t2 * d1;
        if !(t2 > 0.0 && self.inside_rim(p2)) {
            return None;
        }
        let d2 = optics::refract(d1, rear.normal(p2), self.ior, 1.0)?.try_normalize()?;
        Some(Ray::new(p2, d2))
    }
}

/// A camera looking through a [`LensShape`] at a sensor `sensor_distance` behind its front vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThickLens {
    frame: Frame,
    lens: LensShape,
    sensor_distance: f32,
    /// Half the sensor's height.
    half_height: f32,
}

impl ThickLens {
    /// The lens centred at `frame.eye`, its axis along `frame.forward`, the sensor
    /// `sensor_distance` behind the front vertex. The sensor's height is set so that the paraxial
    /// field of view is `vfov_deg` (as a pinhole's): `2 s' tan(vfov/2)`, `s'` the distance from
    /// the sensor to the sensor-side principal plane.
    ///
    /// # Errors
    /// [`CameraError::Degenerate`] for a `vfov_deg` outside `(0, 180)`, a sensor distance that is
    /// not finite and `> 0`, or a sensor in front of the sensor-side principal plane.
    pub fn new(
        frame: Frame,
        lens: LensShape,
        sensor_distance: f32,
        vfov_deg: f32,
    ) -> Result<Self, CameraError> {
        let tan_half = tan_half_angle(vfov_deg)?;
        let (h_sensor, _) = lens.principal_planes();
        let s_image = sensor_distance + lens.l1 + h_sensor;
        if !(sensor_distance > 0.0 && sensor_distance.is_finite() && s_image > 0.0) {
            return Err(CameraError::Degenerate);
        }
        Ok(Self {
            frame,
            lens,
            sensor_distance,
            half_height: s_image * tan_half,
        })
    }

    /// The camera focused at `focus` (distance from the lens's centre along the axis), by
    /// [`LensShape::sensor_distance`].
    ///
    /// # Errors
    /// [`CameraError::CannotFocus`] when the lens cannot focus there; else as [`ThickLens::new`].
    pub fn focused(
        frame: Frame,
        lens: LensShape,
        focus: f32,
        vfov_deg: f32,
    ) -> Result<Self, CameraError> {
        let s = lens
            .sensor_distance(focus)
            .ok_or(CameraError::CannotFocus)?;
        Self::new(frame, lens, s, vfov_deg)
    }

    /// The lens.
    pub fn lens(&self) -> &LensShape {
        &self.lens
    }

    /// The sensor's distance behind the front vertex.
    pub fn sensor_distance(&self) -> f32 {
        self.sensor_distance
    }

    /// The sensor point (lens coordinates) that image point `(x, y)` records: the lens turns the
    /// image upside down, so the pixel right of and above the centre lies left of and below the
    /// axis.
    pub fn sensor_point(&self, x: f32, y: f32, width: u32, height: u32) -> Vec3 {
        let (w, h) = (width.max(1) as f32, height.max(1) as f32);
        let sx = (2.0 * x / w - 1.0) * (w / h);
        let sy = 1.0 - 2.0 * y / h;
        Vec3::new(
            -sx * self.half_height,
            -sy * self.half_height,
            -self.lens.l1 - self.sensor_distance,
        )
    }

    /// The ray (world space) from image point `(x, y)`'s sensor point through the front surface
    /// above `lens = (x, y)` (lens coordinates), with its weight; `None` when the point lies
    /// outside the aperture or the lens drops the ray.
    ///
    /// The weight. A pixel measures the irradiance `E = ∫ L cosθ dω` on the sensor over the
    /// solid angle the lens fills; we normalize it by the paraxial `A/s²` (aperture area `A = πa²`
    /// seen on axis from the sensor distance `s`), so that exposure does not change with the
    /// aperture and a sky of radiance `L` seen through a small aperture gives `L` at the centre.
    /// A lens point drawn uniformly on the disk `x² + y² ≤ a²` has area density `1/A`; the point
    /// `p` on the front surface above it, at distance `r = |p − s|` from the sensor point `s`, in
    /// the direction `ω` with `cosθ = ω·z`, covers the solid angle
    /// `dω = |n·ω| dA_surface / r² = |n·ω| / |n·z| · dA_disk / r²` (`n` the surface's normal:
    /// the disk is the surface's projection along `z`). So the estimator `L cosθ / pdf(ω)` is
    /// `L · A cosθ |n·ω| / (|n·z| r²)`, and divided by `A / s²` the weight is
    /// `cosθ · |n·ω| / |n·z| · s² / r²`: `cos⁴θ` for a flat front surface (natural vignetting),
    /// and rays the rim clips count zero (mechanical vignetting).
    pub fn ray_through(
        &self,
        x: f32,
        y: f32,
        width: u32,
        height: u32,
        lens: [f32; 2],
    ) -> Option<(Ray, f32)> {
        let l = &self.lens;
        let [ax, ay] = lens;
        let r2 = ax * ax + ay * ay;
        if !(r2 <= l.aperture * l.aperture) {
            return None;
        }
        let s = self.sensor_point(x, y, width, height);
        let p = Vec3::new(ax, ay, l.r1 - math::sqrt(l.r1 * l.r1 - r2) - l.l1);
        let to_p = p - s;
        let dist2 = to_p.length_squared();
        let dir = to_p.try_normalize()?;
        let n = l.front().normal(p);
        let weight = dir.z * n.dot(dir).abs() / n.z.abs()
            * (self.sensor_distance * self.sensor_distance / dist2);
        let out = l.refract_through(s, dir)?;
        let f = &self.frame;
        let ray = Ray::new(f.eye + f.to_world(out.origin), f.to_world(out.dir));
        (weight > 0.0 && weight.is_finite() && ray.is_finite()).then_some((ray, weight))
    }
}

impl Camera for ThickLens {
    /// The chief ray (through the front vertex); where the lens drops it, a ray with an empty
    /// range, which hits nothing.
    #[inline]
    fn ray(&self, x: f32, y: f32, width: u32, height: u32) -> Ray {
        match self.ray_through(x, y, width, height, [0.0, 0.0]) {
            Some((ray, _)) => ray,
            None => Ray::new(self.frame.eye, self.frame.forward).with_range(0.0, 0.0),
        }
    }

    /// A lens point drawn uniformly on the aperture disk (`r = a√u1`, `φ = 2πu2`).
    #[inline]
    fn sample(
        &self,
        x: f32,
        y: f32,
        width: u32,
        height: u32,
        rng: &mut Pcg32,
    ) -> Option<(Ray, f32)> {
        let (u1, u2) = (rng.next_f32(), rng.next_f32());
        let r = self.lens.aperture * math::sqrt(u1);
        let (sin, cos) = math::sin_cos(TAU * u2);
        self.ray_through(x, y, width, height, [r * cos, r * sin])
    }
}
