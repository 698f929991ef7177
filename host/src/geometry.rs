//! The geometry every loader produces and the builder consumes: flat lists of triangles and
//! spheres in input order (a primitive's index in these lists is the `prim` reported in hits;
//! spheres are numbered after all triangles).

use glam::{Vec2, Vec3};

/// Per-vertex attributes of one triangle, present for all triangles of a scene or for none.
pub type TriNormals = [Vec3; 3];
/// Texture coordinates of one triangle's vertices.
pub type TriUvs = [Vec2; 3];

/// A scene's primitives after loading and transforming, ready to build.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Geometry {
    /// Triangles as their three vertices, in input order.
    pub triangles: Vec<[Vec3; 3]>,
    /// Per-vertex normals, one entry per triangle, when every mesh supplied them.
    pub normals: Option<Vec<TriNormals>>,
    /// Texture coordinates, one entry per triangle, when every mesh supplied them.
    pub uvs: Option<Vec<TriUvs>>,
    /// Material index of each triangle (into the scene's material list); empty means "all 0".
    pub tri_materials: Vec<u32>,
    /// Spheres as (centre, radius), in input order.
    pub spheres: Vec<(Vec3, f32)>,
    /// Material index of each sphere; empty means "all 0".
    pub sphere_materials: Vec<u32>,
}

impl Geometry {
    /// Triangles plus spheres.
    pub fn prim_count(&self) -> usize {
        self.triangles.len() + self.spheres.len()
    }
}
