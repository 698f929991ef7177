//! Assembling a scene's [`Geometry`]: meshes loaded and placed, then the inline triangles, then
//! the spheres, each primitive tagged with its material's index.

use super::SceneFile;
use super::placement::transform;
use crate::error::Result;
use crate::geometry::{Geometry, TriNormals, TriUvs};
use crate::load::{MeshFormat, decode_mesh, load_mesh};
use glam::{Vec2, Vec3};

/// The unit normal of a triangle's plane by its winding (zero when degenerate): what a triangle
/// without vertex normals is shaded with, when other triangles of the scene have them.
fn face_normals(t: &[Vec3; 3]) -> TriNormals {
    [(t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero(); 3]
}

/// Texture coordinates for a triangle without any: its barycentric corners.
const CORNER_UVS: TriUvs = [Vec2::ZERO, Vec2::X, Vec2::Y];

/// Appends `part`'s triangles to `out`, all with `material`. Normals and texture coordinates
/// survive when any part has them; triangles that lack them get face normals and corner uvs.
pub(super) fn append(out: &mut Geometry, part: Geometry, material: u32) {
    let before = out.triangles.len();
    let n = part.triangles.len();
    match (&mut out.normals, part.normals) {
        (Some(all), Some(mine)) => all.extend(mine),
        (Some(all), None) => all.extend(part.triangles.iter().map(face_normals)),
        (None, Some(mine)) => {
            let mut all: Vec<TriNormals> = out.triangles.iter().map(face_normals).collect();
            all.extend(mine);
            out.normals = Some(all);
        }
        (None, None) => {}
    }
    match (&mut out.uvs, part.uvs) {
        (Some(all), Some(mine)) => all.extend(mine),
        (Some(all), None) => all.extend(core::iter::repeat_n(CORNER_UVS, n)),
        (None, Some(mine)) => {
            let mut all = vec![CORNER_UVS; before];
            all.extend(mine);
            out.uvs = Some(all);
        }
        (None, None) => {}
    }
    out.triangles.extend(part.triangles);
    out.tri_materials.extend(core::iter::repeat_n(material, n));
}

impl SceneFile {
    /// Loads the meshes (relative to the scene file's folder) and assembles the scene: every
    /// mesh's triangles in `[[mesh]]` order, then the `[[triangle]]` entries, then the copies that
    /// `[[instance]]` entries make of named meshes (copy by copy), then the `[[sphere]]` entries,
    /// with `tri_materials` and `sphere_materials` filled in. Normals and texture coordinates are
    /// kept when any mesh has them (see `docs/SCENE.md`). A scene with instances comes out
    /// flattened, one mesh; `kdray render` and `trace` use [`Self::instanced_geometry`] instead.
    ///
    /// # Errors
    /// A mesh that cannot be opened or loaded (naming the scene file and line, and the mesh
    /// file and its line where known), meshes too large together (`check_meshes`), or an
    /// unresolved material (only possible if the fields were edited after
    /// [`super::load_scene`] validated them).
    pub fn geometry(&self) -> Result<Geometry> {
        self.check_meshes()?;
        let mut out = self.base_geometry()?;
        if self.has_instances() {
            let spheres = core::mem::take(&mut out.spheres);
            let sphere_materials = core::mem::take(&mut out.sphere_materials);
            self.flattened_copies(&mut out)?;
            out.spheres = spheres;
            out.sphere_materials = sphere_materials;
        }
        if out.prim_count() == 0 {
            return Err(self.error(None, "the scene has no triangles or spheres".into()));
        }
        Ok(out)
    }

    /// The material index a `material` name at `line` resolves to, by `resolve` (a
    /// [`Self::material_resolver`], built once for many entries).
    fn resolved(
        &self,
        resolve: &impl Fn(Option<&str>) -> Option<u32>,
        name: Option<&str>,
        line: Option<usize>,
    ) -> Result<u32> {
        resolve(name)
            .ok_or_else(|| self.error(line, format!("unknown material `{}`", name.unwrap_or(""))))
    }

    /// `[[mesh]]` entry `i` loaded (or taken from the binary), placed by its own transform, every
    /// triangle with its material (resolved by `resolve`).
    pub(super) fn mesh_part(
        &self,
        i: usize,
        resolve: &impl Fn(Option<&str>) -> Option<u32>,
    ) -> Result<Geometry> {
        let m = &self.meshes[i];
        let line = self.lines.mesh.get(i).copied();
        let index = self.resolved(resolve, m.material.as_deref(), line)?;
        let mut part = match self.embedded_mesh(&m.path) {
            Some(bytes) => {
                let format = MeshFormat::from_path(&m.path).unwrap_or(MeshFormat::Ply);
                decode_mesh(format, &m.path, bytes)?
            }
            None => load_mesh(&self.mesh_file(&m.path))
                .map_err(|e| self.error(line, format!("mesh `{}`: {e}", m.path.display())))?,
        };
        let placement = transform(m).map_err(|msg| self.error(line, msg))?;
        if let Some(t) = placement {
            t.apply(&mut part);
        }
        part.tri_materials = vec![index; part.triangles.len()];
        Ok(part)
    }

    /// The scene without the copies of instances: the meshes without a name, the `[[triangle]]`
    /// and the `[[sphere]]` entries (possibly nothing). The caller checks the meshes first.
    pub(super) fn base_geometry(&self) -> Result<Geometry> {
        let mut out = Geometry::default();
        let resolve = self.material_resolver();
        for (i, m) in self.meshes.iter().enumerate() {
            if m.name.is_some() {
                continue;
            }
            let mut part = self.mesh_part(i, &resolve)?;
            let index = part.tri_materials.first().copied().unwrap_or(0);
            part.tri_materials.clear();
            append(&mut out, part, index);
        }
        for (i, t) in self.triangles.iter().enumerate() {
            let line = self.lines.triangle.get(i).copied();
            let index = self.resolved(&resolve, t.material.as_deref(), line)?;
            let tri = [t.v0, t.v1, t.v2].map(Vec3::from);
            append(
                &mut out,
                Geometry {
                    triangles: vec![tri],
                    ..Geometry::default()
                },
                index,
            );
        }
        for (i, s) in self.spheres.iter().enumerate() {
            let line = self.lines.sphere.get(i).copied();
            out.spheres.push((Vec3::from(s.center), s.radius));
            out.sphere_materials
                .push(self.resolved(&resolve, s.material.as_deref(), line)?);
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn append_fills_missing_attributes() {
        let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let mut out = Geometry::default();
        append(
            &mut out,
            Geometry {
                triangles: vec![tri],
                ..Geometry::default()
            },
            3,
        );
        let smooth = Geometry {
            triangles: vec![tri],
            normals: Some(vec![[Vec3::X; 3]]),
            uvs: Some(vec![[Vec2::ONE; 3]]),
            ..Geometry::default()
        };
        append(&mut out, smooth, 1);
        append(
            &mut out,
            Geometry {
                triangles: vec![tri],
                ..Geometry::default()
            },
            0,
        );
        assert_eq!(out.tri_materials, vec![3, 1, 0]);
        let normals = out.normals.unwrap();
        assert_eq!(normals, vec![[Vec3::Z; 3], [Vec3::X; 3], [Vec3::Z; 3]]);
        assert_eq!(
            out.uvs.unwrap(),
            vec![CORNER_UVS, [Vec2::ONE; 3], CORNER_UVS]
        );
    }
}
