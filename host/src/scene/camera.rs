//! The scene file's camera description turned into one of the core's cameras.

use super::CameraDesc;
use glam::Vec3;
use kdray_core::camera::{CameraError, Fisheye, Parallel, Pinhole, Span};
use kdray_core::description::AnyCamera;

/// Any of the cameras a scene file can describe: the core's [`AnyCamera`], which a target
/// decodes from a render description.
pub type SceneCamera = AnyCamera;

impl CameraDesc {
    /// Builds the camera, with the core's checks.
    ///
    /// # Errors
    /// A message saying which value the core refused.
    pub fn build(&self) -> Result<SceneCamera, String> {
        let span = |name: &str, v: [f32; 3]| {
            Span::from_triple(v).map_err(|e| match e {
                CameraError::MiddleNotMidpoint => {
                    format!(
                        "{name} = {v:?}: the middle value must be the midpoint of start and end"
                    )
                }
                CameraError::Degenerate => format!("{name} = {v:?} must be finite"),
            })
        };
        let finite = |name: &str, v: &[f32]| match v.iter().all(|x| x.is_finite()) {
            true => Ok(()),
            false => Err(format!("{name} must be finite")),
        };
        Ok(match *self {
            Self::Pinhole {
                eye,
                target,
                up,
                vfov,
            } => {
                finite("eye, target and up", &[eye, target, up].concat())?;
                let cam =
                    Pinhole::look_at(Vec3::from(eye), Vec3::from(target), Vec3::from(up), vfov);
                SceneCamera::Pinhole(cam.map_err(|_| {
                    "pinhole: eye and target must differ, up must not be parallel to the view \
                     direction, and vfov must lie in (0, 180)"
                        .to_string()
                })?)
            }
            Self::Fisheye { origin, phi, theta } => {
                finite("origin", &origin)?;
                SceneCamera::Fisheye(Fisheye {
                    origin: Vec3::from(origin),
                    phi: span("phi", phi)?,
                    theta: span("theta", theta)?,
                })
            }
            Self::Parallel {
                origin,
                phi,
                theta,
                horizontal,
                vertical,
            } => {
                finite(
                    "origin, phi and theta",
                    &[origin[0], origin[1], origin[2], phi, theta],
                )?;
                SceneCamera::Parallel(Parallel::new(
                    Vec3::from(origin),
                    phi,
                    theta,
                    span("horizontal", horizontal)?,
                    span("vertical", vertical)?,
                ))
            }
        })
    }
}
