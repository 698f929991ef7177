//! What `kdray build` and `trace` accept as input: a mesh file or a scene file. The one place that
//! knows both the loaders ([`crate::load`]) and the scenes ([`crate::scene`]), so that neither
//! needs the other's way in.

use crate::error::Result;
use crate::geometry::Geometry;
use crate::load::load_mesh;
use crate::scene::load_scene;
use std::path::Path;

/// Whether `path` names a scene file (`.toml`) rather than a mesh.
pub fn is_scene_file(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("toml"))
}

/// Loads a mesh (see [`load_mesh`]) or a `.toml` scene file, whose meshes, inline triangles and
/// spheres are assembled by [`crate::scene::SceneFile::geometry`]. A command's `outputs` are
/// checked against the meshes a scene file includes before they are loaded (the command checked
/// them against its own inputs already, [`crate::files::check_outputs`]).
///
/// # Errors
/// As [`load_mesh`] and [`load_scene`]; an output is a mesh the scene includes.
pub fn load_input(path: &Path, outputs: &[&Path]) -> Result<Geometry> {
    if is_scene_file(path) {
        let scene = load_scene(path)?;
        crate::files::check_not_inputs(&scene.mesh_files(), outputs)?;
        scene.geometry()
    } else {
        load_mesh(path)
    }
}
