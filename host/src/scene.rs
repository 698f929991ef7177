//! Scene files: a TOML description of a camera, render settings, materials and the geometry
//! (meshes from files, inline triangles, spheres). The schema is documented, with an example, in
//! `docs/SCENE.md`; the built-in default scene is `host/scenes/default.toml`.
//!
//! [`load_scene`] parses and validates the whole description — every reference resolved, every
//! number in its range, the camera built once — so that errors come with the scene file's line.
//! [`SceneFile::geometry`] then loads the meshes and assembles one [`Geometry`](crate::Geometry).

mod assemble;
mod camera;
mod desc;
mod instances;
mod meshes;
mod placement;

pub use camera::{CameraDesc, DEFAULT_LENS, Focus, SceneCamera};
pub use desc::{
    InstanceDesc, MaterialDesc, MaterialKind, MeshDesc, RenderDesc, Scale, SphereDesc, TriangleDesc,
};
pub use instances::{InstancedGeometry, MAX_COPIES};

use crate::error::{Error, Result};
use serde::Deserialize;
use serde::de::IgnoredAny;
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use toml::Spanned;

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
    #[serde(default)]
    instance: Vec<InstanceDesc>,
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
    #[serde(default)]
    instance: Vec<Spanned<IgnoredAny>>,
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
    instance: Vec<usize>,
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
    /// Copies of named meshes (`docs/SCENE.md`, "Instances"); empty in a scene of one mesh.
    pub instances: Vec<InstanceDesc>,
    lines: Lines,
    /// Meshes held in the binary, by the `path` a `[[mesh]]` gives: used instead of files (the
    /// built-in default scene's, so that it renders wherever the binary is).
    embedded: &'static [(&'static str, &'static [u8])],
}

/// The largest emission or background a scene may give, per channel. A pixel's sums of samples
/// and of their squares are f32 (the core's, bit for bit on every target): with radiance up to
/// 1e10, a million samples' squares sum to 1e26, twelve orders of magnitude inside f32's 3.4e38
/// for what lights' geometry and many bounces multiply them by. (Daylight's sun is about 2e7 in
/// watts per square metre and steradian.) A render whose sums overflow anyway is refused
/// (`kdray::progressive::Film::overflowed`).
pub const MAX_RADIANCE: f32 = 1e10;

/// Whether `c` is a radiance a scene may give: in `[0, MAX_RADIANCE]` (so not NaN).
fn radiance_ok(c: f32) -> bool {
    (0.0..=MAX_RADIANCE).contains(&c)
}

/// The built-in default scene's text.
pub const DEFAULT_SCENE_TOML: &str = include_str!("../scenes/default.toml");

/// The meshes the built-in default scene refers to, embedded (the same files lie beside
/// `host/scenes/default.toml`, so that it also loads as a file).
const DEFAULT_SCENE_MESHES: &[(&str, &[u8])] = &[(
    "meshes/bunny.ply.gz",
    include_bytes!("../scenes/meshes/bunny.ply.gz"),
)];

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
    /// light, the Stanford bunny (embedded in the binary), a mirror and a glass sphere; it needs
    /// no files.
    pub fn default_scene() -> Self {
        let scene = Self::from_toml_str(DEFAULT_SCENE_TOML, Path::new("<built-in default scene>"))
            .expect("the built-in default scene is valid");
        Self {
            embedded: DEFAULT_SCENE_MESHES,
            ..scene
        }
    }

    /// The embedded bytes of the mesh a `[[mesh]]` entry names, if the scene has them.
    pub(crate) fn embedded_mesh(&self, path: &Path) -> Option<&'static [u8]> {
        self.embedded
            .iter()
            .find(|(name, _)| Path::new(name) == path)
            .map(|(_, bytes)| *bytes)
    }

    /// Parses and validates scene text; `path` names it in errors and anchors mesh paths.
    ///
    /// # Errors
    /// A TOML syntax or schema error (unknown fields are refused) with the line it is at; an
    /// unknown or duplicate material name; a non-finite number; a radius, scale, field of view,
    /// size or sample count out of range; a camera the core refuses.
    pub fn from_toml_str(text: &str, path: &Path) -> Result<Self> {
        let toml_error = |e: toml::de::Error| {
            let msg = e.message().trim_end();
            match e.span() {
                Some(span) => {
                    let line = crate::load::line_of_offset(text.as_bytes(), span.start);
                    let msg = match key_before(text, span.start) {
                        Some(key) if !msg.contains(&format!("`{key}`")) => {
                            format!("`{key}`: {msg}")
                        }
                        _ => msg.to_string(),
                    };
                    Error::at_line(path, line, msg)
                }
                None => Error::new(path, msg),
            }
        };
        let doc: Document = toml::from_str(text).map_err(toml_error)?;
        let spans: Spans = toml::from_str(text).unwrap_or_default();
        // One index for all entries: a scan from the start per entry was quadratic.
        let index = crate::load::LineIndex::new(text.as_bytes());
        let line = |s: &Spanned<IgnoredAny>| index.line(s.span().start);
        let lines = Lines {
            camera: spans.camera.as_ref().map(line),
            render: spans.render.as_ref().map(line),
            material: spans.material.iter().map(line).collect(),
            mesh: spans.mesh.iter().map(line).collect(),
            triangle: spans.triangle.iter().map(line).collect(),
            sphere: spans.sphere.iter().map(line).collect(),
            instance: spans.instance.iter().map(line).collect(),
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
            instances: doc.instance,
            lines,
            embedded: &[],
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

    /// [`Self::material_index`] for many entries: the names looked up in a map built once (a
    /// search of the list per entry was quadratic in a scene of many materials and entries).
    pub(crate) fn material_resolver(&self) -> impl Fn(Option<&str>) -> Option<u32> + '_ {
        let mut by_name = HashMap::with_capacity(self.materials.len());
        for (i, m) in self.materials.iter().enumerate() {
            by_name.entry(m.name.as_str()).or_insert(i as u32);
        }
        move |name| match name {
            None => Some(0),
            Some(name) => by_name.get(name).copied(),
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
        if !r.background.iter().all(|&c| radiance_ok(c)) {
            return Err(at_render(&format!(
                "background {:?} must be >= 0 and at most {MAX_RADIANCE:e}",
                r.background
            )));
        }
        self.check_materials()?;
        self.check_entries()?;
        self.check_instances()
    }

    fn check_materials(&self) -> Result<()> {
        let mut seen = HashSet::with_capacity(self.materials.len());
        for (i, m) in self.materials.iter().enumerate() {
            let line = self.lines.material.get(i).copied();
            let problem = if !seen.insert(m.name.as_str()) {
                "the name is used twice".to_string()
            } else if !m.albedo.iter().all(|c| (0.0..=1.0).contains(c)) {
                format!("albedo {:?} must lie in [0, 1]", m.albedo)
            } else if !m.emission.iter().all(|&c| radiance_ok(c)) {
                format!(
                    "emission {:?} must be >= 0 and at most {MAX_RADIANCE:e}",
                    m.emission
                )
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
        let resolve = self.material_resolver();
        let material = |name: &Option<String>, line: Option<usize>, what: &str| {
            if resolve(name.as_deref()).is_some() {
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
            placement::transform(m).map_err(|msg| self.error(line, format!("{what}: {msg}")))?;
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

/// The key of a `key = value` line whose value starts at byte `offset` of `text`: what a TOML
/// type error is about, which the parser's message (`invalid type: sequence, expected f32`)
/// does not say.
fn key_before(text: &str, offset: usize) -> Option<&str> {
    let head = text.get(..offset)?;
    let line = &head[head.rfind('\n').map_or(0, |i| i + 1)..];
    let (key, rest) = line.split_once('=')?;
    let key = key.trim();
    let bare = |c: char| c.is_ascii_alphanumeric() || c == '_' || c == '-';
    (rest.trim().is_empty() && !key.is_empty() && key.chars().all(bare)).then_some(key)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::load::SCANNED;

    /// `n` spheres, each with its own material, and the last sphere's radius `last_radius`.
    fn many_entries(n: usize, last_radius: f32) -> String {
        let mut text =
            String::from("[camera]\nkind = \"pinhole\"\neye = [0, 0, 5]\ntarget = [0, 0, 0]\n");
        for i in 0..n {
            text.push_str(&format!(
                "\n[[material]]\nname = \"m{i}\"\nkind = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\n"
            ));
        }
        for i in 0..n {
            let r = if i + 1 == n { last_radius } else { 0.5 };
            let m = n - 1 - i;
            text.push_str(&format!(
                "\n[[sphere]]\ncenter = [{i}, 0, 0]\nradius = {r}\nmaterial = \"m{m}\"\n"
            ));
        }
        text
    }

    /// Issue 20: a scene of 40,000 `[[sphere]]` tables took 12 s to load, each entry's line found
    /// by reading the text from its start. The bytes the line-number helpers read while loading
    /// (and reporting an error on the last line) now stay within one pass plus one error's
    /// scan, whatever the number of entries: 2,000 spheres read 2,000 times as much before.
    #[test]
    fn line_numbers_cost_one_pass_over_the_text() {
        let n = 2000;
        let text = many_entries(n, 0.5);
        SCANNED.with(|c| c.set(0));
        let scene = SceneFile::from_toml_str(&text, Path::new("many.toml")).unwrap();
        let scanned = SCANNED.with(|c| c.get());
        assert!(
            scanned <= text.len(),
            "{scanned} bytes read for {}",
            text.len()
        );
        assert_eq!(scene.lines.sphere.len(), n);
        let last_line = text.lines().count() - 3; // `[[sphere]]` of the last entry
        assert_eq!(scene.lines.sphere[n - 1], last_line);
        let g = scene.geometry().unwrap();
        assert_eq!(g.sphere_materials[0], (n - 1) as u32);

        let bad = many_entries(n, -1.0);
        SCANNED.with(|c| c.set(0));
        let err = SceneFile::from_toml_str(&bad, Path::new("many.toml")).unwrap_err();
        let scanned = SCANNED.with(|c| c.get());
        assert!(
            scanned <= 2 * bad.len(),
            "{scanned} bytes read for {}",
            bad.len()
        );
        assert!(err.to_string().contains(&format!(":{last_line}")), "{err}");
    }
}
