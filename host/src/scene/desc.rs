//! The plain descriptions a scene file is made of (everything but the camera, which has its own
//! module): render settings, materials, mesh placements, inline triangles and spheres, as serde
//! reads them. No checks here beyond types; `SceneFile::from_toml_str` validates.

use serde::Deserialize;
use std::path::PathBuf;

/// Image and integrator settings (the command line may override size and samples).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct RenderDesc {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel.
    pub spp: u32,
    /// Longest path, in bounces.
    pub max_depth: u32,
    /// Radiance of rays that leave the scene, linear RGB.
    pub background: [f32; 3],
    /// Trace in watertight mode (no ray slips through a seam of a closed mesh; slower).
    pub watertight: bool,
}

impl Default for RenderDesc {
    fn default() -> Self {
        Self {
            width: 512,
            height: 512,
            spp: 16,
            max_depth: 8,
            background: [0.0; 3],
            watertight: false,
        }
    }
}

/// The kinds of surface the renderer knows.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum MaterialKind {
    /// Lambertian, reflecting `albedo`.
    Diffuse,
    /// Perfect specular reflection tinted by `albedo`.
    Mirror,
    /// A smooth dielectric of index `ior` (Fresnel-weighted reflection and refraction), tinted
    /// by `albedo`.
    Glass,
    /// A light: emits `emission` (and reflects like `diffuse` with `albedo`).
    Emissive,
}

/// A named material; geometry refers to it by name, the [`crate::Geometry`] by its index in
/// [`SceneFile::materials`](super::SceneFile::materials).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MaterialDesc {
    pub name: String,
    pub kind: MaterialKind,
    /// Reflectance (or tint) in `[0, 1]` per channel; also spelled `color`. Default 0.8 grey.
    #[serde(default = "default_albedo", alias = "color")]
    pub albedo: [f32; 3],
    /// Index of refraction for `glass`; default 1.5.
    #[serde(default = "default_ior")]
    pub ior: f32,
    /// Emitted radiance, linear RGB, `≥ 0`; default black.
    #[serde(default)]
    pub emission: [f32; 3],
    /// Whether a light emits from both sides of its surfaces; default `false`: only from the side
    /// a triangle's normal `(v1 − v0) × (v2 − v0)` faces (a sphere's outside).
    #[serde(default)]
    pub two_sided: bool,
}

fn default_albedo() -> [f32; 3] {
    [0.8; 3]
}
fn default_ior() -> f32 {
    1.5
}

impl MaterialDesc {
    /// The core's material for this description.
    pub fn to_core(&self) -> kdray_core::render::Material {
        use kdray_core::render::{self, Material};
        Material {
            kind: match self.kind {
                MaterialKind::Diffuse => render::MaterialKind::Diffuse,
                MaterialKind::Mirror => render::MaterialKind::Mirror,
                MaterialKind::Glass => render::MaterialKind::Glass,
                MaterialKind::Emissive => render::MaterialKind::Emissive,
            },
            albedo: glam::Vec3::from(self.albedo),
            emission: glam::Vec3::from(self.emission),
            ior: self.ior,
            two_sided: self.two_sided,
        }
    }

    /// The material used when a scene declares none: diffuse 0.8 grey, named `default`.
    pub fn fallback() -> Self {
        Self {
            name: "default".into(),
            kind: MaterialKind::Diffuse,
            albedo: default_albedo(),
            ior: default_ior(),
            emission: [0.0; 3],
            two_sided: false,
        }
    }
}

/// A uniform or per-axis scale factor.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq)]
#[serde(untagged)]
pub enum Scale {
    Uniform(f32),
    PerAxis([f32; 3]),
}

/// A mesh file placed in the scene by `p' = translate + Rz·Ry·Rx·(scale ⊙ p)`: scaled first, then
/// rotated about x, then y, then z (degrees), then translated.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MeshDesc {
    /// `.ply`, `.ply.gz`, `.obj` or `.tri`, relative to the scene file's folder.
    pub path: PathBuf,
    /// With a name, the mesh is not placed by itself: `[[instance]]` entries place copies of it
    /// (its own transform applied first).
    #[serde(default)]
    pub name: Option<String>,
    /// Material name; the first material when omitted.
    pub material: Option<String>,
    pub translate: Option<[f32; 3]>,
    pub scale: Option<Scale>,
    pub rotate_deg: Option<[f32; 3]>,
}

/// Copies of a named `[[mesh]]`: each placed by the entry's transform (`translate`, `scale`,
/// `rotate_deg` as for a mesh, or a 3×4 `matrix`), then moved by its cell of the optional
/// `grid`: copy `(i, j, k)` by `(i·dx, j·dy, k·dz)` with `spacing = [dx, dy, dz]`.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct InstanceDesc {
    /// The `name` of a `[[mesh]]` entry.
    pub mesh: String,
    pub translate: Option<[f32; 3]>,
    pub scale: Option<Scale>,
    pub rotate_deg: Option<[f32; 3]>,
    /// Object → world, three rows `[a, b, c, t]`: `p' = A·p + t`. Not with the three above.
    pub matrix: Option<[[f32; 4]; 3]>,
    /// Copies along x, y and z, each ≥ 1 (default one).
    pub grid: Option<[u32; 3]>,
    /// The offset between neighbouring copies of the grid (required with `grid`).
    pub spacing: Option<[f32; 3]>,
}

/// One triangle given in the scene file.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TriangleDesc {
    pub v0: [f32; 3],
    pub v1: [f32; 3],
    pub v2: [f32; 3],
    pub material: Option<String>,
}

/// A sphere.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SphereDesc {
    pub center: [f32; 3],
    /// Finite and `> 0`.
    pub radius: f32,
    pub material: Option<String>,
}
