//! The render description: what a target needs besides a scene's words to render it — the
//! camera, the image settings, the material table and the list of emitting primitives (the flat
//! scene format stores only material ids; [`render_rows`](crate::render::render_rows) takes
//! materials and lights from its caller). The host writes it next to the scene
//! (`kdray build SCENE.toml -o SCENE.kdt --description SCENE.kdr`); firmware embeds both, a WASM
//! page fetches both. [`Description::from_words`] validates it against the scene once, without
//! allocating and without panicking on any input.
//!
//! # Layout (little-endian words, like the scene)
//! ```text
//!  0  MAGIC          0x4452_444B, "KDRD" as a little-endian u32
//!  1  VERSION        2 (1: before one-sided lights and the lens cameras)
//!  2  TOTAL_WORDS    length of the whole array in words
//!  3  SCENE_WORDS    TOTAL_WORDS of the scene it belongs to
//!  4  SCENE_HASH     scene_hash() of that scene's words (BUILD_MS, CHECKSUM counted as 0)
//!  5  WIDTH          image width, ≥ 1
//!  6  HEIGHT         image height, ≥ 1 (WIDTH · HEIGHT ≤ 2²⁶)
//!  7  SPP            samples per pixel, 1 ..= 2²⁰
//!  8  MAX_DEPTH      most surface hits of a path, ≤ 1024
//!  9..12 BACKGROUND  radiance of escaping rays, linear RGB f32, finite and ≥ 0
//! 12  SEED_LO        the samples' seed, low word
//! 13  SEED_HI        … high word
//! 14  CAMERA_KIND    see `camera_kind::*`
//! 15  CAMERA_WORDS   n, the camera's parameter words that follow (≤ MAX_CAMERA_WORDS)
//! 16 ..              n camera words (per kind, see below)
//!     MATERIAL_COUNT m ≤ MAX_MATERIALS, then m × 8 words:
//!                    kind (bits 0..8: 0 diffuse, 1 mirror, 2 glass, 3 emissive; bit 8: the
//!                    light emits from both sides, `two_sided`; no other bit set),
//!                    albedo rgb in [0, 1], emission rgb ≥ 0, ior > 0 (f32)
//!     LIGHT_COUNT    k, then k primitive ids (storage order): exactly the primitives whose
//!                    material emits, ascending ([`crate::render::emitters`])
//! ```
//! Camera words (f32, angles in degrees, `[start, middle, end]` triples as in `docs/SCENE.md`):
//! - pinhole (0), 10 words: eye xyz, target xyz, up xyz, vertical field of view;
//! - fisheye (1), 9 words: origin xyz, φ triple, θ triple;
//! - parallel (2), 11 words: origin xyz, φ, θ, horizontal triple, vertical triple;
//! - thick lens (3), 17 words: eye xyz, target xyz, up xyz, vertical field of view, then the lens
//!   r1, r2, l1, l2, ior, aperture, and the sensor's distance behind the front vertex (the host
//!   resolves a scene's `focus` into it);
//! - lens array (4), 14 words: eye xyz, target xyz, up xyz, size w h, pitch h v, gap.
//!
//! A camera is decoded only when asked for, as the type the caller names
//! ([`Description::camera`]): firmware that renders through a [`Pinhole`] links the pinhole's
//! decoder alone, and a page that takes any camera names [`AnyCamera`].

use crate::camera::{
    Camera, Fisheye, Frame, LensArray, LensShape, Parallel, Pinhole, Span, ThickLens,
};
use crate::format::Scene;
use crate::math;
use crate::ray::Ray;
use crate::render::{Bounces, Material, MaterialKind, Settings};
use crate::sampling::Pcg32;
use crate::traverse::Mode;
use crate::words::Fnv1a;
use glam::Vec3;

/// "KDRD" as a little-endian word.
pub const MAGIC: u32 = u32::from_le_bytes(*b"KDRD");
/// The version this core reads and the host writes.
pub const VERSION: u32 = 2;
/// Words before the camera's parameters.
pub const HEADER_WORDS: usize = 16;
/// The most camera parameter words.
pub const MAX_CAMERA_WORDS: usize = 32;
/// The most materials a description holds (each is copied into the parsed description).
pub const MAX_MATERIALS: usize = 64;
/// Words per material.
pub const MATERIAL_WORDS: usize = 8;
/// The most pixels, samples per pixel and path depth a description may ask for (as `kdray
/// render` accepts).
pub const MAX_PIXELS: u64 = 1 << 26;
pub const MAX_SPP: u32 = 1 << 20;
pub const MAX_PATH_DEPTH: u32 = 1024;

/// Header word indices.
pub mod header {
    pub const MAGIC: usize = 0;
    pub const VERSION: usize = 1;
    pub const TOTAL_WORDS: usize = 2;
    pub const SCENE_WORDS: usize = 3;
    pub const SCENE_HASH: usize = 4;
    pub const WIDTH: usize = 5;
    pub const HEIGHT: usize = 6;
    pub const SPP: usize = 7;
    pub const MAX_DEPTH: usize = 8;
    pub const BACKGROUND: usize = 9;
    pub const SEED_LO: usize = 12;
    pub const SEED_HI: usize = 13;
    pub const CAMERA_KIND: usize = 14;
    pub const CAMERA_WORDS: usize = 15;
}

/// CAMERA_KIND values.
pub mod camera_kind {
    pub const PINHOLE: u32 = 0;
    pub const FISHEYE: u32 = 1;
    pub const PARALLEL: u32 = 2;
    pub const THICK_LENS: u32 = 3;
    pub const LENS_ARRAY: u32 = 4;
}

/// Why words are not a render description for a scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DescError {
    /// Fewer words than the header, or than the counts in it say.
    TooShort,
    BadMagic,
    UnsupportedVersion(u32),
    /// TOTAL_WORDS differs from the array's length.
    LengthMismatch {
        header: u32,
        actual: usize,
    },
    /// SCENE_WORDS or SCENE_HASH do not match the scene given.
    OtherScene,
    /// Width, height, spp or depth out of range, or a background not finite and ≥ 0.
    BadSettings,
    /// The camera's kind is unknown or its words are too many, too few or not a valid camera.
    BadCamera,
    /// The description holds a valid camera of another kind than the one asked for.
    WrongCamera {
        kind: u32,
    },
    TooManyMaterials,
    /// Material `index` has an unknown kind or a value out of range.
    BadMaterial {
        index: u32,
    },
    /// The light list is not exactly the scene's emitting primitives, ascending.
    BadLights,
}

impl core::fmt::Display for DescError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::TooShort => write!(f, "render description is truncated"),
            Self::BadMagic => write!(f, "not a kdray render description (bad magic)"),
            Self::UnsupportedVersion(v) => write!(
                f,
                "render description version {v}, this build reads {VERSION} (rebuild it with \
                 `kdray build SCENE.toml -o SCENE.kdt --description SCENE.kdr`)"
            ),
            Self::LengthMismatch { header, actual } => write!(
                f,
                "render description says {header} words, the data has {actual}"
            ),
            Self::OtherScene => write!(f, "the render description belongs to another scene"),
            Self::BadSettings => write!(f, "render settings out of range"),
            Self::BadCamera => write!(f, "the camera is not valid"),
            Self::WrongCamera { kind } => {
                write!(
                    f,
                    "the description's camera is of kind {kind}, not the one asked for"
                )
            }
            Self::TooManyMaterials => write!(f, "more than {MAX_MATERIALS} materials"),
            Self::BadMaterial { index } => write!(f, "material {index} is not valid"),
            Self::BadLights => write!(f, "the light list is not the scene's emitting primitives"),
        }
    }
}

/// [`Fnv1a`] of the scene words, the header's BUILD_MS word (a timing, different at every build
/// of the same scene) and the CHECKSUM words (which cover BUILD_MS) counted as 0: ties a
/// description to its scene, and still to the same scene rebuilt.
pub fn scene_hash(words: &[u32]) -> u32 {
    let mut h = Fnv1a::default();
    use crate::format::header::{BUILD_MS, CHECKSUM};
    for (i, &w) in words.iter().enumerate() {
        let varies = i == BUILD_MS || i == CHECKSUM || i == CHECKSUM + 1;
        h.word(if varies { 0 } else { w });
    }
    h.0
}

/// A validated render description. Materials are copied out of the words; the lights borrow
/// them.
#[derive(Clone, Debug)]
pub struct Description<'a> {
    settings: Settings,
    camera_kind: u32,
    camera: heapless::Vec<u32, MAX_CAMERA_WORDS>,
    materials: heapless::Vec<Material, MAX_MATERIALS>,
    lights: &'a [u32],
}

/// Sequential reads that fail instead of running past the end.
struct Reader<'w> {
    words: &'w [u32],
    at: usize,
}

impl<'w> Reader<'w> {
    fn take(&mut self, n: usize) -> Result<&'w [u32], DescError> {
        let end = self.at.checked_add(n).ok_or(DescError::TooShort)?;
        let s = self.words.get(self.at..end).ok_or(DescError::TooShort)?;
        self.at = end;
        Ok(s)
    }

    fn word(&mut self) -> Result<u32, DescError> {
        Ok(self.take(1)?[0])
    }
}

fn vec3(w: &[u32]) -> Vec3 {
    Vec3::new(
        f32::from_bits(w[0]),
        f32::from_bits(w[1]),
        f32::from_bits(w[2]),
    )
}

impl<'a> Description<'a> {
    /// Validates `words` as the render description of `scene` (whose words were `scene_words`).
    /// Runs in time linear in both and never panics. The camera is checked when it is decoded
    /// ([`Self::camera`]), so that only the camera type a target names is linked.
    ///
    /// # Errors
    /// The first problem found, as a [`DescError`].
    pub fn from_words(
        words: &'a [u32],
        scene: &Scene,
        scene_words: &[u32],
    ) -> Result<Self, DescError> {
        let mut r = Reader { words, at: 0 };
        let h = r.take(HEADER_WORDS)?;
        if h[header::MAGIC] != MAGIC {
            return Err(DescError::BadMagic);
        }
        if h[header::VERSION] != VERSION {
            return Err(DescError::UnsupportedVersion(h[header::VERSION]));
        }
        if h[header::TOTAL_WORDS] as usize != words.len() {
            return Err(DescError::LengthMismatch {
                header: h[header::TOTAL_WORDS],
                actual: words.len(),
            });
        }
        if h[header::SCENE_WORDS] as usize != scene_words.len()
            || h[header::SCENE_HASH] != scene_hash(scene_words)
        {
            return Err(DescError::OtherScene);
        }
        let settings = Settings {
            width: h[header::WIDTH],
            height: h[header::HEIGHT],
            spp: h[header::SPP],
            max_depth: h[header::MAX_DEPTH],
            background: vec3(&h[header::BACKGROUND..]),
            seed: u64::from(h[header::SEED_HI]) << 32 | u64::from(h[header::SEED_LO]),
            bounces: Bounces::default(),
            // The description does not carry a mode: targets trace in fast mode.
            mode: Mode::default(),
        };
        check_settings(&settings)?;
        let n_camera = h[header::CAMERA_WORDS] as usize;
        if n_camera > MAX_CAMERA_WORDS {
            return Err(DescError::BadCamera);
        }
        let mut camera = heapless::Vec::new();
        camera
            .extend_from_slice(r.take(n_camera)?)
            .map_err(|_| DescError::BadCamera)?;
        let n_materials = r.word()? as usize;
        if n_materials > MAX_MATERIALS {
            return Err(DescError::TooManyMaterials);
        }
        let mut materials = heapless::Vec::new();
        for index in 0..n_materials {
            let m = material(r.take(MATERIAL_WORDS)?).ok_or(DescError::BadMaterial {
                index: index as u32,
            })?;
            // Cannot fail: n_materials ≤ the capacity.
            let _ = materials.push(m);
        }
        let n_lights = r.word()? as usize;
        let lights = r.take(n_lights)?;
        if r.at != words.len() {
            return Err(DescError::LengthMismatch {
                header: h[header::TOTAL_WORDS],
                actual: r.at,
            });
        }
        let desc = Self {
            settings,
            camera_kind: h[header::CAMERA_KIND],
            camera,
            materials,
            lights,
        };
        desc.check_lights(scene)?;
        Ok(desc)
    }

    /// A description for a scene that comes without one: the benchmark protocol's framing
    /// pinhole (looking along −z at the bounds' centre, the bounding sphere filling a 45°
    /// vertical field of view), 512×512, 16 spp, depth 8, a white background as the only light,
    /// and no materials (every primitive gets [`Material::FALLBACK`]).
    pub fn framing(scene: &Scene) -> Description<'static> {
        let [lo, hi] = scene.bounds();
        let center = 0.5 * (lo + hi);
        let radius = (0.5 * (hi - lo).length()).max(1e-3);
        let vfov = 45.0f32;
        let eye = center + Vec3::new(0.0, 0.0, radius / math::sin(math::radians(0.5 * vfov)));
        let mut camera = heapless::Vec::new();
        for v in [eye, center, Vec3::Y] {
            let _ = camera.extend_from_slice(&v.to_array().map(f32::to_bits));
        }
        let _ = camera.push(vfov.to_bits());
        Description {
            settings: Settings {
                width: 512,
                height: 512,
                spp: 16,
                max_depth: 8,
                background: Vec3::ONE,
                seed: 1,
                bounces: Bounces::default(),
                mode: Mode::default(),
            },
            camera_kind: camera_kind::PINHOLE,
            camera,
            materials: heapless::Vec::new(),
            lights: &[],
        }
    }

    /// The image settings (with [`Bounces::default`]; a target picks its own).
    pub fn settings(&self) -> Settings {
        self.settings
    }

    /// The material table, indexed by the scene's material ids.
    pub fn materials(&self) -> &[Material] {
        &self.materials
    }

    /// The emitting primitives, in storage order.
    pub fn lights(&self) -> &[u32] {
        self.lights
    }

    /// CAMERA_KIND.
    pub fn camera_kind(&self) -> u32 {
        self.camera_kind
    }

    /// The camera, decoded as `C` (e.g. [`Pinhole`], or [`AnyCamera`] for whichever it is).
    ///
    /// # Errors
    /// [`DescError::WrongCamera`] when the description holds another kind than `C` decodes,
    /// [`DescError::BadCamera`] when its words are not a valid camera.
    pub fn camera<C: FromDescription>(&self) -> Result<C, DescError> {
        C::from_description(self.camera_kind, &self.camera)
    }

    /// Every light is an emitting primitive, each emitting primitive is listed, ascending.
    fn check_lights(&self, scene: &Scene) -> Result<(), DescError> {
        let mut next = self.lights.iter();
        for prim in 0..scene.prim_count() {
            let m = self
                .materials
                .get(scene.material(prim) as usize)
                .unwrap_or(&Material::FALLBACK);
            if m.emission.max_element() > 0.0 && next.next() != Some(&prim) {
                return Err(DescError::BadLights);
            }
        }
        match next.next() {
            None => Ok(()),
            Some(_) => Err(DescError::BadLights),
        }
    }
}

fn check_settings(s: &Settings) -> Result<(), DescError> {
    let pixels = u64::from(s.width) * u64::from(s.height);
    let ok = s.width >= 1
        && s.height >= 1
        && pixels <= MAX_PIXELS
        && (1..=MAX_SPP).contains(&s.spp)
        && s.max_depth <= MAX_PATH_DEPTH
        && s.background.is_finite()
        && s.background.min_element() >= 0.0;
    if ok {
        Ok(())
    } else {
        Err(DescError::BadSettings)
    }
}

/// One material's 8 words, or `None` when a value is out of range.
fn material(w: &[u32]) -> Option<Material> {
    if w[0] & !(TWO_SIDED | 0xff) != 0 {
        return None;
    }
    let kind = match w[0] & 0xff {
        0 => MaterialKind::Diffuse,
        1 => MaterialKind::Mirror,
        2 => MaterialKind::Glass,
        3 => MaterialKind::Emissive,
        _ => return None,
    };
    let (albedo, emission, ior) = (vec3(&w[1..4]), vec3(&w[4..7]), f32::from_bits(w[7]));
    let in_unit = albedo.min_element() >= 0.0 && albedo.max_element() <= 1.0;
    let emits_ok = emission.is_finite() && emission.min_element() >= 0.0;
    (in_unit && emits_ok && ior.is_finite() && ior > 0.0).then_some(Material {
        kind,
        albedo,
        emission,
        ior,
        two_sided: w[0] & TWO_SIDED != 0,
    })
}

/// The material kind word's flag for [`Material::two_sided`].
const TWO_SIDED: u32 = 1 << 8;

/// A material's words (the layout [`Description::from_words`] reads).
pub fn material_words(m: &Material) -> [u32; MATERIAL_WORDS] {
    let kind = match m.kind {
        MaterialKind::Diffuse => 0,
        MaterialKind::Mirror => 1,
        MaterialKind::Glass => 2,
        MaterialKind::Emissive => 3,
    };
    let [ar, ag, ab] = m.albedo.to_array().map(f32::to_bits);
    let [er, eg, eb] = m.emission.to_array().map(f32::to_bits);
    let kind = kind | if m.two_sided { TWO_SIDED } else { 0 };
    [kind, ar, ag, ab, er, eg, eb, m.ior.to_bits()]
}

/// A camera type that a description's camera words decode to.
pub trait FromDescription: Sized {
    /// Decodes camera words of kind `kind`.
    ///
    /// # Errors
    /// [`DescError::WrongCamera`] for a kind this type is not, [`DescError::BadCamera`] for words
    /// that are not a valid camera of its kind.
    fn from_description(kind: u32, words: &[u32]) -> Result<Self, DescError>;
}

/// `words` as exactly `N` finite floats of camera kind `want`.
fn camera_floats<const N: usize>(
    kind: u32,
    want: u32,
    words: &[u32],
) -> Result<[f32; N], DescError> {
    if kind != want {
        return Err(DescError::WrongCamera { kind });
    }
    let w: &[u32; N] = words.try_into().map_err(|_| DescError::BadCamera)?;
    let f = w.map(f32::from_bits);
    if f.iter().all(|x| x.is_finite()) {
        Ok(f)
    } else {
        Err(DescError::BadCamera)
    }
}

fn span(v: &[f32]) -> Result<Span, DescError> {
    Span::from_triple([v[0], v[1], v[2]]).map_err(|_| DescError::BadCamera)
}

impl FromDescription for Pinhole {
    fn from_description(kind: u32, words: &[u32]) -> Result<Self, DescError> {
        let f = camera_floats::<10>(kind, camera_kind::PINHOLE, words)?;
        let v = |i: usize| Vec3::new(f[i], f[i + 1], f[i + 2]);
        Pinhole::look_at(v(0), v(3), v(6), f[9]).map_err(|_| DescError::BadCamera)
    }
}

impl FromDescription for Fisheye {
    fn from_description(kind: u32, words: &[u32]) -> Result<Self, DescError> {
        let f = camera_floats::<9>(kind, camera_kind::FISHEYE, words)?;
        Ok(Fisheye {
            origin: Vec3::new(f[0], f[1], f[2]),
            phi: span(&f[3..6])?,
            theta: span(&f[6..9])?,
        })
    }
}

impl FromDescription for Parallel {
    fn from_description(kind: u32, words: &[u32]) -> Result<Self, DescError> {
        let f = camera_floats::<11>(kind, camera_kind::PARALLEL, words)?;
        Ok(Parallel::new(
            Vec3::new(f[0], f[1], f[2]),
            f[3],
            f[4],
            span(&f[5..8])?,
            span(&f[8..11])?,
        ))
    }
}

impl FromDescription for ThickLens {
    fn from_description(kind: u32, words: &[u32]) -> Result<Self, DescError> {
        let f = camera_floats::<17>(kind, camera_kind::THICK_LENS, words)?;
        let v = |i: usize| Vec3::new(f[i], f[i + 1], f[i + 2]);
        let frame = Frame::look_at(v(0), v(3), v(6)).map_err(|_| DescError::BadCamera)?;
        let lens = LensShape::new(f[10], f[11], f[12], f[13], f[14], f[15])
            .map_err(|_| DescError::BadCamera)?;
        ThickLens::new(frame, lens, f[16], f[9]).map_err(|_| DescError::BadCamera)
    }
}

impl FromDescription for LensArray {
    fn from_description(kind: u32, words: &[u32]) -> Result<Self, DescError> {
        let f = camera_floats::<14>(kind, camera_kind::LENS_ARRAY, words)?;
        let v = |i: usize| Vec3::new(f[i], f[i + 1], f[i + 2]);
        let frame = Frame::look_at(v(0), v(3), v(6)).map_err(|_| DescError::BadCamera)?;
        LensArray::new(frame, [f[9], f[10]], [f[11], f[12]], f[13])
            .map_err(|_| DescError::BadCamera)
    }
}

/// Whichever camera a description holds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AnyCamera {
    Pinhole(Pinhole),
    Fisheye(Fisheye),
    Parallel(Parallel),
    ThickLens(ThickLens),
    LensArray(LensArray),
}

impl FromDescription for AnyCamera {
    fn from_description(kind: u32, words: &[u32]) -> Result<Self, DescError> {
        match kind {
            camera_kind::PINHOLE => Pinhole::from_description(kind, words).map(Self::Pinhole),
            camera_kind::FISHEYE => Fisheye::from_description(kind, words).map(Self::Fisheye),
            camera_kind::PARALLEL => Parallel::from_description(kind, words).map(Self::Parallel),
            camera_kind::THICK_LENS => {
                ThickLens::from_description(kind, words).map(Self::ThickLens)
            }
            camera_kind::LENS_ARRAY => {
                LensArray::from_description(kind, words).map(Self::LensArray)
            }
            _ => Err(DescError::BadCamera),
        }
    }
}

impl Camera for AnyCamera {
    #[inline]
    fn ray(&self, x: f32, y: f32, width: u32, height: u32) -> Ray {
        match self {
            Self::Pinhole(c) => c.ray(x, y, width, height),
            Self::Fisheye(c) => c.ray(x, y, width, height),
            Self::Parallel(c) => c.ray(x, y, width, height),
            Self::ThickLens(c) => c.ray(x, y, width, height),
            Self::LensArray(c) => c.ray(x, y, width, height),
        }
    }

    /// Each camera's own [`Camera::sample`]: the thick lens draws its lens point here.
    #[inline]
    fn sample(
        &self,
        x: f32,
        y: f32,
        width: u32,
        height: u32,
        rng: &mut Pcg32,
    ) -> Option<(Ray, f32)> {
        match self {
            Self::Pinhole(c) => c.sample(x, y, width, height, rng),
            Self::Fisheye(c) => c.sample(x, y, width, height, rng),
            Self::Parallel(c) => c.sample(x, y, width, height, rng),
            Self::ThickLens(c) => c.sample(x, y, width, height, rng),
            Self::LensArray(c) => c.sample(x, y, width, height, rng),
        }
    }
}

/// Declares the two types a target names at compile time, from the *calling* crate's cargo
/// features, so that firmware and WASM modules share one convention:
/// - `Prims`, the [`Contents`](crate::traverse::Contents) of its traversal kernel: feature
///   `mixed` ([`Mixed`](crate::traverse::Mixed)), else `triangles`, else `spheres`;
/// - `Cam`, its camera: feature `any-camera` ([`AnyCamera`]), else `pinhole` ([`Pinhole`]).
///
/// A crate using it declares those features (`[features] triangles = [] …`) and enables one of
/// each group.
#[macro_export]
macro_rules! target_types {
    () => {
        #[cfg(feature = "mixed")]
        type Prims = $crate::traverse::Mixed;
        #[cfg(all(feature = "triangles", not(feature = "mixed")))]
        type Prims = $crate::traverse::Triangles;
        #[cfg(all(
            feature = "spheres",
            not(feature = "mixed"),
            not(feature = "triangles")
        ))]
        type Prims = $crate::traverse::Spheres;

        #[cfg(feature = "any-camera")]
        type Cam = $crate::description::AnyCamera;
        #[cfg(all(feature = "pinhole", not(feature = "any-camera")))]
        type Cam = $crate::camera::Pinhole;
    };
}
