//! The scene file's `[camera]` table: read key by key (so that an error names the key it is
//! about), and turned into one of the core's cameras.
//!
//! serde's internally tagged enums (`#[serde(tag = "kind")]`) buffer the table before they know
//! which variant it is, and their type errors lose the key (`invalid type: sequence, expected
//! f32`); reading the table ourselves costs a few lines and gives `` `phi`: invalid type: … ``.

use glam::Vec3;
use kdray_core::camera::{
    CameraError, Fisheye, Frame, LensArray, LensShape, Parallel, Pinhole, Span, ThickLens,
};
use kdray_core::description::AnyCamera;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Deserializer};

/// How the image is looked at (`docs/SCENE.md`, "\[camera\]"). Angles in degrees;
/// `[start, middle, end]` triples follow Rukin (the middle must be the midpoint).
#[derive(Clone, Debug, PartialEq)]
pub enum CameraDesc {
    /// A perspective camera at `eye` looking at `target`.
    Pinhole {
        eye: [f32; 3],
        target: [f32; 3],
        /// The image's up direction; default `[0, 1, 0]`.
        up: [f32; 3],
        /// Vertical field of view in degrees, in (0, 180); default 40.
        vfov: f32,
    },
    /// Rukin's fisheye: one origin, φ across the width and θ down the height.
    Fisheye {
        origin: [f32; 3],
        phi: [f32; 3],
        theta: [f32; 3],
    },
    /// Rukin's parallel camera: direction `d(φ, θ)`, origins offset by `horizontal` along
    /// `(−sinφ, cosφ, 0)` and `vertical` along `(cosθ cosφ, cosθ sinφ, −sinθ)`.
    Parallel {
        origin: [f32; 3],
        phi: f32,
        theta: f32,
        horizontal: [f32; 3],
        vertical: [f32; 3],
    },
    /// Rukin's thick lens centred at `eye`, its axis towards `target`, focused by `focus` (a
    /// distance from `eye`) or placed by `sensor` (the sensor's distance behind the front vertex).
    ThickLens {
        eye: [f32; 3],
        target: [f32; 3],
        up: [f32; 3],
        vfov: f32,
        lens: [f32; 6],
        focus: Focus,
    },
    /// Rukin's lens array at `eye` facing `target`: the elemental images behind it.
    LensArray {
        eye: [f32; 3],
        target: [f32; 3],
        up: [f32; 3],
        size: [f32; 2],
        pitch: [f32; 2],
        gap: f32,
    },
}

/// How a thick lens is focused.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Focus {
    /// The distance from the lens's centre that is in focus.
    Distance(f32),
    /// The sensor's distance behind the lens's front vertex.
    Sensor(f32),
}

/// The default thick lens `[r1, r2, l1, l2, ior, aperture]`: a biconvex 52 mm lens at f/2.6.
pub const DEFAULT_LENS: [f32; 6] = [0.05, 0.05, 0.005, 0.005, 1.5, 0.01];

/// A camera table's keys, taken one by one; what is left at the end is unknown.
struct Keys {
    kind: String,
    table: toml::Table,
}

impl Keys {
    fn take<T: DeserializeOwned>(&mut self, key: &str) -> Result<Option<T>, String> {
        match self.table.remove(key) {
            None => Ok(None),
            Some(v) => v.try_into().map(Some).map_err(|e| {
                let msg = e.to_string();
                format!("`{key}`: {}", msg.trim_end())
            }),
        }
    }

    fn required<T: DeserializeOwned>(&mut self, key: &str) -> Result<T, String> {
        match self.take(key)? {
            Some(v) => Ok(v),
            None => Err(format!("a {} camera needs `{key}`", self.kind)),
        }
    }

    fn or<T: DeserializeOwned>(&mut self, key: &str, default: T) -> Result<T, String> {
        Ok(self.take(key)?.unwrap_or(default))
    }

    fn finish(self, desc: CameraDesc) -> Result<CameraDesc, String> {
        match self.table.keys().next() {
            None => Ok(desc),
            Some(key) => Err(format!("unknown key `{key}` for a {} camera", self.kind)),
        }
    }
}

impl CameraDesc {
    /// Reads a `[camera]` table.
    ///
    /// # Errors
    /// A message naming the key that is missing, unknown or of the wrong type, or the kind.
    pub fn from_table(mut table: toml::Table) -> Result<Self, String> {
        let kind = match table.remove("kind") {
            Some(toml::Value::String(kind)) => kind,
            Some(other) => return Err(format!("`kind` must be a string, not {other}")),
            None => return Err("missing key `kind`".into()),
        };
        let mut k = Keys { kind, table };
        let up = [0.0, 1.0, 0.0];
        let desc = match k.kind.as_str() {
            "pinhole" => Self::Pinhole {
                eye: k.required("eye")?,
                target: k.required("target")?,
                up: k.or("up", up)?,
                vfov: k.or("vfov", 40.0)?,
            },
            "fisheye" => Self::Fisheye {
                origin: k.required("origin")?,
                phi: k.required("phi")?,
                theta: k.required("theta")?,
            },
            "parallel" => Self::Parallel {
                origin: k.required("origin")?,
                phi: k.required("phi")?,
                theta: k.required("theta")?,
                horizontal: k.required("horizontal")?,
                vertical: k.required("vertical")?,
            },
            "thick_lens" => {
                let mut lens = DEFAULT_LENS;
                for (i, key) in ["r1", "r2", "l1", "l2", "ior", "aperture"]
                    .iter()
                    .enumerate()
                {
                    lens[i] = k.or(key, lens[i])?;
                }
                let focus = match (k.take("focus")?, k.take("sensor")?) {
                    (Some(d), None) => Focus::Distance(d),
                    (None, Some(s)) => Focus::Sensor(s),
                    _ => return Err("a thick_lens camera needs one of `focus`, `sensor`".into()),
                };
                Self::ThickLens {
                    eye: k.required("eye")?,
                    target: k.required("target")?,
                    up: k.or("up", up)?,
                    vfov: k.or("vfov", 40.0)?,
                    lens,
                    focus,
                }
            }
            "lens_array" => Self::LensArray {
                eye: k.required("eye")?,
                target: k.required("target")?,
                up: k.or("up", up)?,
                size: k.required("size")?,
                pitch: k.required("pitch")?,
                gap: k.required("gap")?,
            },
            other => {
                return Err(format!(
                    "unknown camera kind `{other}`, expected one of `pinhole`, `fisheye`, \
                     `parallel`, `thick_lens`, `lens_array`"
                ));
            }
        };
        k.finish(desc)
    }
}

impl<'de> Deserialize<'de> for CameraDesc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        Self::from_table(toml::Table::deserialize(d)?).map_err(serde::de::Error::custom)
    }
}

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
                _ => format!("{name} = {v:?} must be finite"),
            })
        };
        let finite = |name: &str, v: &[f32]| match v.iter().all(|x| x.is_finite()) {
            true => Ok(()),
            false => Err(format!("{name} must be finite")),
        };
        let frame = |eye: [f32; 3], target: [f32; 3], up: [f32; 3]| {
            finite("eye, target and up", &[eye, target, up].concat())?;
            Frame::look_at(Vec3::from(eye), Vec3::from(target), Vec3::from(up)).map_err(|_| {
                "eye and target must differ, and up must not be parallel to the view direction"
                    .to_string()
            })
        };
        Ok(match *self {
            Self::Pinhole {
                eye,
                target,
                up,
                vfov,
            } => {
                frame(eye, target, up)?;
                let cam =
                    Pinhole::look_at(Vec3::from(eye), Vec3::from(target), Vec3::from(up), vfov);
                SceneCamera::Pinhole(cam.map_err(|_| "vfov must lie in (0, 180)".to_string())?)
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
            Self::ThickLens {
                eye,
                target,
                up,
                vfov,
                lens,
                focus,
            } => {
                let frame = frame(eye, target, up)?;
                let [r1, r2, l1, l2, ior, aperture] = lens;
                let shape = LensShape::new(r1, r2, l1, l2, ior, aperture).map_err(|_| {
                    format!(
                        "thick_lens: r1 = {r1}, r2 = {r2}, l1 = {l1}, l2 = {l2}, ior = {ior}, \
                         aperture = {aperture} is no lens: r1, r2 > 0, l1, l2 >= 0 (not both \
                         0), ior > 1, 0 < aperture < min(r1, r2), and the glass must still be \
                         thicker than 0 at the aperture's rim"
                    )
                })?;
                // A lens the checks above admit can still be beyond f32: an ior of 1e30 gives a
                // focal length of 1e-31, which vanishes next to the lens's thickness when the
                // sensor is placed, and the camera's own check then fails on the sensor. Blame the
                // lens (ior first: the usual culprit), not the field of view or the focus.
                let (h1, h2) = shape.principal_planes();
                let f = shape.focal_length();
                let size = r1.max(r2).max(l1 + l2);
                if !(f.is_finite() && f.abs() > 1e-6 * size && h1.is_finite() && h2.is_finite()) {
                    return Err(format!(
                        "thick_lens: ior = {ior} (with r1 = {r1}, r2 = {r2}, l1 = {l1}, \
                         l2 = {l2}) gives a focal length of {f:e}, beyond what f32 can place a \
                         sensor for (it must be finite and more than 1e-6 of the lens's size)"
                    ));
                }
                let cam = match focus {
                    Focus::Distance(d) => ThickLens::focused(frame, shape, d, vfov),
                    Focus::Sensor(s) => ThickLens::new(frame, shape, s, vfov),
                };
                SceneCamera::ThickLens(cam.map_err(|e| match (e, focus) {
                    (CameraError::CannotFocus, Focus::Distance(d)) => format!(
                        "thick_lens: cannot focus at {d}: the lens's focal length is {:.4}, and \
                         the focus must lie farther than that in front of it",
                        shape.focal_length()
                    ),
                    _ if !(vfov > 0.0 && vfov < 180.0) => {
                        format!("thick_lens: vfov = {vfov} must lie in (0, 180)")
                    }
                    (_, Focus::Sensor(s)) => format!(
                        "thick_lens: sensor = {s} must be finite, above 0 and behind the lens's \
                         sensor-side principal plane"
                    ),
                    (_, Focus::Distance(d)) => format!(
                        "thick_lens: focus = {d} puts the sensor in front of the lens (focal length \
                         {:.4})",
                        shape.focal_length()
                    ),
                })?)
            }
            Self::LensArray {
                eye,
                target,
                up,
                size,
                pitch,
                gap,
            } => {
                let frame = frame(eye, target, up)?;
                SceneCamera::LensArray(LensArray::new(frame, size, pitch, gap).map_err(|_| {
                    "lens_array: size, pitch and gap must be finite and > 0".to_string()
                })?)
            }
        })
    }
}
