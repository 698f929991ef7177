//! Rays and hits (Rukin §3.1, equation (2)): `r(t) = o + t·d` with `d` normalized, so `t` is a
//! distance.

use glam::Vec3;

/// A ray `o + t·d` restricted to the open interval `tmin < t < tmax`.
///
/// `dir` must be normalized (docs/FORMATS.md's rays file says so, and `kdray trace` refuses a
/// ray file whose finite directions are not, within 1e-3). The kernels then report `t` as a distance. An
/// unnormalized direction breaks nothing in memory or time, and `t` is then in units of `|dir|`,
/// but the triangle kernels' parallel test compares `det²` with a threshold set for unit
/// directions: a direction shorter than about 2e-7 counts every triangle as parallel and misses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
    pub tmin: f32,
    pub tmax: f32,
}

impl Ray {
    /// A ray over `(0, +inf)`.
    #[inline]
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Self {
            origin,
            dir,
            tmin: 0.0,
            tmax: f32::INFINITY,
        }
    }

    /// The same ray over `(tmin, tmax)`.
    #[inline]
    pub fn with_range(self, tmin: f32, tmax: f32) -> Self {
        Self { tmin, tmax, ..self }
    }

    /// The point at parameter `t`.
    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + t * self.dir
    }

    /// True when every component is finite and the interval is not NaN: the only rays traversal
    /// can give a meaningful answer for. Anything else is reported as a miss.
    ///
    /// An infinite bound is traced as it says: `tmin = −∞` asks for the whole line behind the
    /// origin too (the walk starts where the line enters the scene box, and the closest hit may
    /// lie behind the origin), and an empty interval (`tmin ≥ tmax`) is a miss. Callers that
    /// read rays from a file should refuse these rather than trace them: the host's rays files
    /// accept only finite origins, directions and `tmin`, and `tmin ≤ tmax`
    /// (`kdray::rays::check_rays`).
    #[inline]
    pub fn is_finite(&self) -> bool {
        self.origin.is_finite()
            && self.dir.is_finite()
            && !self.tmin.is_nan()
            && !self.tmax.is_nan()
    }
}

/// The closest intersection found along a ray.
///
/// `u`, `v` are the barycentric coordinates of a triangle hit, `p = v0 + u·(v1 − v0) + v·(v2 − v0)`;
/// for a sphere they are 0.
///
/// `prim` is the primitive's id in the scene's **storage order** (triangles first, then spheres):
/// the id every accessor of [`Scene`](crate::Scene) takes (`triangle`, `material`, …). The
/// builder stores triangles in the order its leaves reach them, so this is not the mesh's
/// order: [`Scene::input_id`](crate::Scene::input_id)`(hit.prim)` is the triangle's index in
/// the builder's input (the mesh's triangle order), what the hits file, the Python and the
/// JavaScript packages report. The two agree where
/// [`Scene::reorders_triangles`](crate::Scene::reorders_triangles) is false (and for spheres).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    pub prim: u32,
    pub u: f32,
    pub v: f32,
}

impl Hit {
    /// The primitive index of a miss in the hits file format.
    pub const MISS_PRIM: u32 = u32::MAX;

    /// The record of a miss: `t = +inf`, `prim = 0xFFFF_FFFF`.
    pub const MISS: Hit = Hit {
        t: f32::INFINITY,
        prim: Self::MISS_PRIM,
        u: 0.0,
        v: 0.0,
    };

    /// True unless this is [`Hit::MISS`].
    #[inline]
    pub fn is_hit(&self) -> bool {
        self.prim != Self::MISS_PRIM
    }
}
