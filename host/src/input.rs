//! What `kdray build` and `trace` accept as input: a mesh file or a scene file. The one place that
//! knows both the loaders ([`crate::load`]) and the scenes ([`crate::scene`]), so that neither
//! needs the other's way in.

use crate::error::Result;
use crate::geometry::Geometry;
use crate::load::load_mesh;
use crate::scene::load_scene;
use std::path::Path;

/// Loads a mesh (see [`load_mesh`]) or a `.toml` scene file, whose meshes, inline triangles and
/// spheres are assembled by [`crate::scene::SceneFile::geometry`].
///
/// # Errors
/// As [`load_mesh`] and [`load_scene`].
pub fn load_input(path: &Path) -> Result<Geometry> {
    let is_toml = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("toml"));
    if is_toml {
        load_scene(path)?.geometry()
    } else {
        load_mesh(path)
    }
}
