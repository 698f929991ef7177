//! Scene files: a TOML description of a camera, render settings, materials and the geometry
//! (meshes from files, inline triangles, spheres). The schema is documented, with an example, in
//! `docs/SCENE.md`; the built-in default scene is `host/scenes/default.toml`.
//!
//! [`load_scene`] parses and validates the whole description — every reference resolved, every
//! number in its range, the camera built once — so that errors come with the scene file's line.
//! [`SceneFile::geometry`] then loads the meshes and assembles one [`Geometry`].

mod assemble;
mod camera;

pub use camera::SceneCamera;

use crate::error::{Error, Result};
use serde::Deserialize;
use serde::de::IgnoredAny;
use std::path::{Path, PathBuf};
use toml::Spanned;

/// How the image is looked at. Angles in degrees; `[start, middle, end]` triples follow the seed
/// document (the middle must be the midpoint).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(tag = "kind", rename_all = "lowercase", deny_unknown_fields)]
pub enum CameraDesc {
    /// A perspective camera at `eye` looking at `target`.
    Pinhole {
        eye: [f32; 3],
        target: [f32; 3],
        /// The image's up direction; default `[0, 1, 0]`.
        #[serde(default = "default_up")]
        up: [f32; 3],
        /// Vertical field of view in degrees, in (0, 180); default 40.
        #[serde(default = "default_vfov")]
        vfov: f32,
    },
    /// The seed's fisheye: one origin, φ across the width and θ down the height.
    Fisheye {
        origin: [f32; 3],
        phi: [f32; 3],
        theta: [f32; 3],
    },
    /// The seed's parallel camera: direction `d(φ, θ)`, origins offset by `horizontal` along
    /// `(−sinφ, cosφ, 0)` and `vertical` along `(cosθ cosφ, cosθ sinφ, −sinθ)`.
    Parallel {
        origin: [f32; 3],
        phi: f32,
        theta: f32,
        horizontal: [f32; 3],
        vertical: [f32; 3],
    },
}

fn default_up() -> [f32; 3] {
    [0.0, 1.0, 0.0]
}
fn default_vfov() -> f32 {
    40.0
}

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
}

impl Default for RenderDesc {
    fn default() -> Self {
        Self {
            width: 512,
            height: 512,
            spp: 16,
            max_depth: 8,
            background: [0.0; 3],
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
/// [`SceneFile::materials`].
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
    /// Material name; the first material when omitted.
    pub material: Option<String>,
    pub translate: Option<[f32; 3]>,
    pub scale: Option<Scale>,
    pub rotate_deg: Option<[f32; 3]>,
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

/// The document as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Document {
    camera: CameraDesc,
    #[serde(default)]
    render: RenderDesc,
    #[serde(default)]
    material: Vec<MaterialDesc>,
    #[serde(default)]
    mesh: Vec<MeshDesc>,
    #[serde(default)]
    triangle: Vec<TriangleDesc>,
    #[serde(default)]
    sphere: Vec<SphereDesc>,
}

/// Where each entry starts, read in a second pass over the same text, to give the line of
/// problems found after parsing (an unknown material, a negative radius).
#[derive(Debug, Default, Deserialize)]
struct Spans {
    camera: Option<Spanned<IgnoredAny>>,
    render: Option<Spanned<IgnoredAny>>,
    #[serde(default)]
    material: Vec<Spanned<IgnoredAny>>,
    #[serde(default)]
    mesh: Vec<Spanned<IgnoredAny>>,
    #[serde(default)]
    triangle: Vec<Spanned<IgnoredAny>>,
    #[serde(default)]
    sphere: Vec<Spanned<IgnoredAny>>,
}

/// Lines (1-based) of the entries of a parsed scene, when it came from text.
#[derive(Clone, Debug, Default, PartialEq)]
struct Lines {
    camera: Option<usize>,
    render: Option<usize>,
    material: Vec<usize>,
    mesh: Vec<usize>,
    triangle: Vec<usize>,
    sphere: Vec<usize>,
}

/// A parsed and validated scene file.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneFile {
    /// The file it was read from; relative mesh paths start at its folder.
    pub path: PathBuf,
    pub camera: CameraDesc,
    pub render: RenderDesc,
    /// Never empty: a scene without `[[material]]` gets [`MaterialDesc::fallback`].
    pub materials: Vec<MaterialDesc>,
    pub meshes: Vec<MeshDesc>,
    pub triangles: Vec<TriangleDesc>,
    pub spheres: Vec<SphereDesc>,
    lines: Lines,
}

/// The built-in default scene's text.
pub const DEFAULT_SCENE_TOML: &str = include_str!("../scenes/default.toml");

/// Reads, parses and validates the scene file at `path` (see [`SceneFile::from_toml_str`]).
///
/// # Errors
/// An I/O failure, a TOML or schema error (with its line), or a failed check.
pub fn load_scene(path: &Path) -> Result<SceneFile> {
    let text = crate::files::read_text(path)?;
    SceneFile::from_toml_str(&text, path)
}

impl SceneFile {
    /// The built-in default scene: a Cornell-box-like room of inline triangles with a ceiling
    /// light, a mirror and a glass sphere; it needs no files.
    pub fn default_scene() -> Self {
        Self::from_toml_str(DEFAULT_SCENE_TOML, Path::new("<built-in default scene>"))
            .expect("the built-in default scene is valid")
    }

    /// Parses and validates scene text; `path` names it in errors and anchors mesh paths.
    ///
    /// # Errors
    /// A TOML syntax or schema error (unknown fields are refused) with the line it is at; an
    /// unknown or duplicate material name; a non-finite number; a radius, scale, field of view,
    /// size or sample count out of range; a camera the core refuses.
    pub fn from_toml_str(text: &str, path: &Path) -> Result<Self> {
        let toml_error = |e: toml::de::Error| match e.span() {
            Some(span) => {
                let line = crate::load::line_of_offset(text.as_bytes(), span.start);
                Error::at_line(path, line, e.message().trim_end())
            }
            None => Error::new(path, e.message().trim_end()),
        };
        let doc: Document = toml::from_str(text).map_err(toml_error)?;
        let spans: Spans = toml::from_str(text).unwrap_or_default();
        let line =
            |s: &Spanned<IgnoredAny>| crate::load::line_of_offset(text.as_bytes(), s.span().start);
        let lines = Lines {
            camera: spans.camera.as_ref().map(line),
            render: spans.render.as_ref().map(line),
            material: spans.material.iter().map(line).collect(),
            mesh: spans.mesh.iter().map(line).collect(),
            triangle: spans.triangle.iter().map(line).collect(),
            sphere: spans.sphere.iter().map(line).collect(),
        };
        let mut materials = doc.material;
        if materials.is_empty() {
            materials.push(MaterialDesc::fallback());
        }
        let scene = Self {
            path: path.to_path_buf(),
            camera: doc.camera,
            render: doc.render,
            materials,
            meshes: doc.mesh,
            triangles: doc.triangle,
            spheres: doc.sphere,
            lines,
        };
        scene.validate()?;
        Ok(scene)
    }

    /// The index in [`Self::materials`] of the material called `name`; `None` names material 0.
    pub fn material_index(&self, name: Option<&str>) -> Option<u32> {
        match name {
            None => Some(0),
            Some(name) => self
                .materials
                .iter()
                .position(|m| m.name == name)
                .map(|i| i as u32),
        }
    }

    /// The camera, built and ready to make rays.
    ///
    /// # Errors
    /// When the core refuses the description (a degenerate pinhole, a `[start, middle, end]` whose
    /// middle is not the midpoint); [`load_scene`] has already checked this.
    pub fn camera(&self) -> Result<SceneCamera> {
        self.camera
            .build()
            .map_err(|msg| self.error(self.lines.camera, format!("[camera]: {msg}")))
    }

    /// An error about this scene file, at `line` when known.
    fn error(&self, line: Option<usize>, msg: String) -> Error {
        match line {
            Some(line) => Error::at_line(&self.path, line, msg),
            None => Error::new(&self.path, msg),
        }
    }

    /// Checks what serde cannot: see [`Self::from_toml_str`].
    fn validate(&self) -> Result<()> {
        if self.meshes.is_empty() && self.triangles.is_empty() && self.spheres.is_empty() {
            let msg = "the scene has no [[mesh]], [[triangle]] or [[sphere]] entries";
            return Err(self.error(None, msg.into()));
        }
        self.camera()?;
        let r = &self.render;
        let at_render = |msg: &str| self.error(self.lines.render, format!("[render]: {msg}"));
        if r.width == 0 || r.height == 0 || r.spp == 0 {
            return Err(at_render("width, height and spp must be at least 1"));
        }
        if !r.background.iter().all(|c| c.is_finite() && *c >= 0.0) {
            return Err(at_render("background must be finite and non-negative"));
        }
        self.check_materials()?;
        self.check_entries()
    }

    fn check_materials(&self) -> Result<()> {
        for (i, m) in self.materials.iter().enumerate() {
            let line = self.lines.material.get(i).copied();
            let problem = if self.materials[..i].iter().any(|n| n.name == m.name) {
                "the name is used twice".to_string()
            } else if !m.albedo.iter().all(|c| (0.0..=1.0).contains(c)) {
                format!("albedo {:?} must lie in [0, 1]", m.albedo)
            } else if !m.emission.iter().all(|c| c.is_finite() && *c >= 0.0) {
                format!("emission {:?} must be finite and >= 0", m.emission)
            } else if !(m.ior.is_finite() && m.ior > 0.0) {
                format!("ior {} must be finite and > 0", m.ior)
            } else {
                continue;
            };
            return Err(self.error(line, format!("material `{}`: {problem}", m.name)));
        }
        Ok(())
    }

    /// Meshes, triangles and spheres: materials resolve, numbers are finite and in range.
    fn check_entries(&self) -> Result<()> {
        let material = |name: &Option<String>, line: Option<usize>, what: &str| {
            if self.material_index(name.as_deref()).is_some() {
                return Ok(());
            }
            let name = name.as_deref().unwrap_or("");
            Err(self.error(line, format!("{what}: unknown material `{name}`")))
        };
        let finite = |v: &[f32], line: Option<usize>, what: &str| {
            if v.iter().all(|x| x.is_finite()) {
                return Ok(());
            }
            Err(self.error(line, format!("{what}: coordinates must be finite")))
        };
        for (i, m) in self.meshes.iter().enumerate() {
            let line = self.lines.mesh.get(i).copied();
            let what = format!("mesh `{}`", m.path.display());
            material(&m.material, line, &what)?;
            assemble::transform(m).map_err(|msg| self.error(line, format!("{what}: {msg}")))?;
        }
        for (i, t) in self.triangles.iter().enumerate() {
            let line = self.lines.triangle.get(i).copied();
            material(&t.material, line, "triangle")?;
            finite(&[t.v0, t.v1, t.v2].concat(), line, "triangle")?;
        }
        for (i, s) in self.spheres.iter().enumerate() {
            let line = self.lines.sphere.get(i).copied();
            material(&s.material, line, "sphere")?;
            finite(&s.center, line, "sphere")?;
            if !(s.radius.is_finite() && s.radius > 0.0) {
                let msg = format!("sphere: radius {} must be finite and > 0", s.radius);
                return Err(self.error(line, msg));
            }
        }
        Ok(())
    }
}
