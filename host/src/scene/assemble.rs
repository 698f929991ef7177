//! Assembling a scene's [`Geometry`]: meshes loaded and placed, then the inline triangles, then
//! the spheres, each primitive tagged with its material's index.

use super::{MeshDesc, Scale, SceneFile};
use crate::error::Result;
use crate::geometry::{Geometry, TriNormals, TriUvs};
use crate::load::load_mesh;
use glam::{Mat3, Vec2, Vec3};
use std::path::Path;

/// A mesh's placement: `p' = linear·p + translate`; normals go through `normal` (the inverse
/// transpose of `linear`) and are renormalized.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Transform {
    linear: Mat3,
    normal: Mat3,
    translate: Vec3,
}

/// The transform a mesh entry asks for, `None` when it gives none (the mesh is used verbatim).
///
/// # Errors
/// Non-finite values or a zero scale factor, as a message.
pub(super) fn transform(m: &MeshDesc) -> core::result::Result<Option<Transform>, String> {
    if m.translate.is_none() && m.scale.is_none() && m.rotate_deg.is_none() {
        return Ok(None);
    }
    let scale = match m.scale {
        None => Vec3::ONE,
        Some(Scale::Uniform(s)) => Vec3::splat(s),
        Some(Scale::PerAxis(s)) => Vec3::from(s),
    };
    let translate = Vec3::from(m.translate.unwrap_or_default());
    let rotate = Vec3::from(m.rotate_deg.unwrap_or_default());
    if !(scale.is_finite() && translate.is_finite() && rotate.is_finite()) {
        return Err("translate, scale and rotate_deg must be finite".into());
    }
    if scale.cmpeq(Vec3::ZERO).any() {
        return Err("scale factors must not be 0".into());
    }
    let r = rotate * (core::f32::consts::PI / 180.0);
    let linear = Mat3::from_rotation_z(r.z)
        * Mat3::from_rotation_y(r.y)
        * Mat3::from_rotation_x(r.x)
        * Mat3::from_diagonal(scale);
    // Rotation is orthonormal, so (R·S)^-T = R·S^-1 exactly; no general inverse needed.
    let normal = Mat3::from_rotation_z(r.z)
        * Mat3::from_rotation_y(r.y)
        * Mat3::from_rotation_x(r.x)
        * Mat3::from_diagonal(scale.recip());
    if !(linear.is_finite() && normal.is_finite()) {
        return Err("the scale is too small or too large to invert".into());
    }
    Ok(Some(Transform {
        linear,
        normal,
        translate,
    }))
}

impl Transform {
    fn apply(&self, g: &mut Geometry) {
        for v in g.triangles.iter_mut().flatten() {
            *v = self.linear * *v + self.translate;
        }
        for n in g.normals.iter_mut().flatten().flatten() {
            *n = (self.normal * *n).normalize_or_zero();
        }
    }
}

/// The unit normal of a triangle's plane by its winding (zero when degenerate): what a triangle
/// without vertex normals is shaded with, when other triangles of the scene have them.
fn face_normals(t: &[Vec3; 3]) -> TriNormals {
    [(t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero(); 3]
}

/// Texture coordinates for a triangle without any: its barycentric corners.
const CORNER_UVS: TriUvs = [Vec2::ZERO, Vec2::X, Vec2::Y];

/// Appends `part`'s triangles to `out`, all with `material`. Normals and texture coordinates
/// survive when any part has them; triangles that lack them get face normals and corner uvs.
fn append(out: &mut Geometry, part: Geometry, material: u32) {
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
    /// mesh's triangles in `[[mesh]]` order, then the `[[triangle]]` entries, then the
    /// `[[sphere]]` entries, with `tri_materials` and `sphere_materials` filled in. Normals and
    /// texture coordinates are kept when any mesh has them (see `docs/SCENE.md`).
    ///
    /// # Errors
    /// A mesh that cannot be opened (naming the scene file and line) or loaded (naming the mesh
    /// file), or an unresolved material (only possible if the fields were edited after
    /// [`super::load_scene`] validated them).
    pub fn geometry(&self) -> Result<Geometry> {
        let base = self.path.parent().unwrap_or(Path::new(""));
        let mut out = Geometry::default();
        let material = |name: Option<&str>, line: Option<usize>| {
            self.material_index(name).ok_or_else(|| {
                self.error(line, format!("unknown material `{}`", name.unwrap_or("")))
            })
        };
        for (i, m) in self.meshes.iter().enumerate() {
            let line = self.lines.mesh.get(i).copied();
            let index = material(m.material.as_deref(), line)?;
            let file = base.join(&m.path);
            if let Err(e) = std::fs::metadata(&file) {
                let msg = format!("mesh `{}` ({}): {e}", m.path.display(), file.display());
                return Err(self.error(line, msg));
            }
            let mut part = load_mesh(&file)?;
            let placement = transform(m).map_err(|msg| self.error(line, msg))?;
            if let Some(t) = placement {
                t.apply(&mut part);
            }
            append(&mut out, part, index);
        }
        for (i, t) in self.triangles.iter().enumerate() {
            let line = self.lines.triangle.get(i).copied();
            let index = material(t.material.as_deref(), line)?;
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
                .push(material(s.material.as_deref(), line)?);
        }
        if out.prim_count() == 0 {
            return Err(self.error(None, "the scene has no triangles or spheres".into()));
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn mesh(
        scale: Option<Scale>,
        rotate_deg: Option<[f32; 3]>,
        translate: Option<[f32; 3]>,
    ) -> MeshDesc {
        MeshDesc {
            path: PathBuf::from("m.tri"),
            material: None,
            translate,
            scale,
            rotate_deg,
        }
    }

    #[test]
    fn no_transform_is_none() {
        assert_eq!(transform(&mesh(None, None, None)), Ok(None));
    }

    #[test]
    fn order_is_scale_then_x_y_z_then_translate() {
        // Scale x by 2, rotate 90° about z: x → y; then translate.
        let t = transform(&mesh(
            Some(Scale::PerAxis([2.0, 1.0, 1.0])),
            Some([0.0, 0.0, 90.0]),
            Some([0.0, 0.0, 5.0]),
        ))
        .unwrap()
        .unwrap();
        let p = t.linear * Vec3::X + t.translate;
        assert!((p - Vec3::new(0.0, 2.0, 5.0)).length() < 1e-6, "{p}");
        // Rotating about x first, then y: z → -y (about x by 90°) → -y (y-rotation keeps y).
        let t = transform(&mesh(None, Some([90.0, 90.0, 0.0]), None))
            .unwrap()
            .unwrap();
        let p = t.linear * Vec3::Z;
        assert!((p - Vec3::new(0.0, -1.0, 0.0)).length() < 1e-6, "{p}");
    }

    #[test]
    fn normals_use_the_inverse_transpose() {
        // A plane x + y = 0 squashed along x: its normal (1,1,0)/√2 becomes ∝ (1/s, 1, 0).
        let t = transform(&mesh(Some(Scale::PerAxis([0.5, 1.0, 1.0])), None, None))
            .unwrap()
            .unwrap();
        let mut g = Geometry {
            triangles: vec![[
                Vec3::new(1.0, -1.0, 0.0),
                Vec3::new(1.0, -1.0, 1.0),
                Vec3::new(-1.0, 1.0, 0.0),
            ]],
            normals: Some(vec![[Vec3::new(1.0, 1.0, 0.0).normalize(); 3]]),
            ..Geometry::default()
        };
        t.apply(&mut g);
        let n = g.normals.unwrap()[0][0];
        let edge = g.triangles[0][2] - g.triangles[0][0];
        assert!(
            n.dot(edge).abs() < 1e-6,
            "normal {n} not perpendicular to {edge}"
        );
        assert!((n.length() - 1.0).abs() < 1e-6);
    }

    #[test]
    fn zero_or_non_finite_transforms_are_refused() {
        assert!(transform(&mesh(Some(Scale::Uniform(0.0)), None, None)).is_err());
        assert!(transform(&mesh(Some(Scale::PerAxis([1.0, 0.0, 1.0])), None, None)).is_err());
        assert!(transform(&mesh(None, Some([f32::NAN, 0.0, 0.0]), None)).is_err());
        assert!(transform(&mesh(None, None, Some([f32::INFINITY, 0.0, 0.0]))).is_err());
        assert!(transform(&mesh(Some(Scale::Uniform(1e-39)), None, None)).is_err());
    }

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
