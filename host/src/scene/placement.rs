//! Where a `[[mesh]]` goes: its `translate`, `scale` and `rotate_deg` as one affine transform,
//! checked when the scene is loaded and applied when its geometry is assembled.

use super::desc::{MeshDesc, Scale};
use crate::geometry::Geometry;
use glam::{Mat3, Vec3};
use kdray_core::instance::Affine;

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
    transform_of(m.translate, m.scale, m.rotate_deg)
}

/// The transform of `translate`, `scale` and `rotate_deg` (as a `[[mesh]]` or an `[[instance]]`
/// gives them), `None` when none is given.
///
/// # Errors
/// Non-finite values or a zero scale factor, as a message.
pub(super) fn transform_of(
    translate: Option<[f32; 3]>,
    scale: Option<Scale>,
    rotate_deg: Option<[f32; 3]>,
) -> core::result::Result<Option<Transform>, String> {
    if translate.is_none() && scale.is_none() && rotate_deg.is_none() {
        return Ok(None);
    }
    let scale = match scale {
        None => Vec3::ONE,
        Some(Scale::Uniform(s)) => Vec3::splat(s),
        Some(Scale::PerAxis(s)) => Vec3::from(s),
    };
    let translate = Vec3::from(translate.unwrap_or_default());
    let rotate = Vec3::from(rotate_deg.unwrap_or_default());
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
    /// The same transform as the core's 3×4 row-major [`Affine`].
    pub(super) fn to_affine(self) -> Affine {
        let (m, t) = (self.linear, self.translate);
        let r = |i: usize| m.row(i);
        let (r0, r1, r2) = (r(0), r(1), r(2));
        Affine([
            r0.x, r0.y, r0.z, t.x, r1.x, r1.y, r1.z, t.y, r2.x, r2.y, r2.z, t.z,
        ])
    }

    pub(super) fn apply(&self, g: &mut Geometry) {
        for v in g.triangles.iter_mut().flatten() {
            *v = self.linear * *v + self.translate;
        }
        for n in g.normals.iter_mut().flatten().flatten() {
            *n = (self.normal * *n).normalize_or_zero();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use std::path::PathBuf;

    fn mesh(
        scale: Option<Scale>,
        rotate_deg: Option<[f32; 3]>,
        translate: Option<[f32; 3]>,
    ) -> MeshDesc {
        MeshDesc {
            path: PathBuf::from("m.tri"),
            name: None,
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
}
