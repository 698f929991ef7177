//! Rukin's lens array ("lens array", as corrected here): the elemental images an
//! integral-imaging display shows behind a planar array of identical lenslets.
//!
//! Lens-array coordinates are the camera's [`Frame`]: `x` right, `y` up, `z` the viewing
//! direction; the array lies in the plane `z = 0` centred on `eye`, a lenslet centred at every
//! `k·t_h + l·t_v` with `t_h = (p_h, 0)`, `t_v = (0, p_v)` (the pitches), and the display (the
//! image) at `z = −g` behind it, `g` the gap (the lenslets' focal length, so each lenslet images
//! infinity onto the display). The image spans `size = (w, h)` of the display, centred on the axis.
//!
//! Rukin's small-angle model: a pixel sees through the one lenslet in front of it, whose index
//! is `k = round(x / t_h.x)`, `l = round(y / t_v.y)` (correcting Rukin), and a lenslet acts as a pinhole at
//! its centre `c`: the pixel at display point `q` shows what lies along the ray from `c` in
//! direction `(c − q, g)`. Each lenslet's patch of the display is therefore a small inverted
//! picture of the scene from that lenslet's place: the elemental image.

use super::{Camera, CameraError, Frame};
use crate::math;
use crate::ray::Ray;
use glam::{Vec2, Vec3};

/// A lens array in front of a display (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LensArray {
    frame: Frame,
    size: Vec2,
    pitch: Vec2,
    gap: f32,
}

impl LensArray {
    /// The array at `frame.eye`, facing `frame.forward`: an image of `size = [w, h]` (scene units)
    /// on the display, lenslets `pitch = [p_h, p_v]` apart, the display `gap` behind the array.
    ///
    /// # Errors
    /// [`CameraError::Degenerate`] unless every value is finite and `> 0`.
    pub fn new(
        frame: Frame,
        size: [f32; 2],
        pitch: [f32; 2],
        gap: f32,
    ) -> Result<Self, CameraError> {
        let ok = [size[0], size[1], pitch[0], pitch[1], gap]
            .iter()
            .all(|v| *v > 0.0 && v.is_finite());
        if !ok {
            return Err(CameraError::Degenerate);
        }
        Ok(Self {
            frame,
            size: Vec2::from(size),
            pitch: Vec2::from(pitch),
            gap,
        })
    }

    /// The display point (array coordinates `x`, `y`) of image point `(x, y)`.
    #[inline]
    pub fn display_point(&self, x: f32, y: f32, width: u32, height: u32) -> Vec2 {
        let (w, h) = (width.max(1) as f32, height.max(1) as f32);
        Vec2::new((x / w - 0.5) * self.size.x, (0.5 - y / h) * self.size.y)
    }

    /// The centre of the lenslet in front of display point `q`: `(k·p_h, l·p_v)` with
    /// `k = round(q.x / p_h)`, `l = round(q.y / p_v)`.
    #[inline]
    pub fn lenslet_center(&self, q: Vec2) -> Vec2 {
        Vec2::new(
            math::round(q.x / self.pitch.x) * self.pitch.x,
            math::round(q.y / self.pitch.y) * self.pitch.y,
        )
    }
}

impl Camera for LensArray {
    #[inline]
    fn ray(&self, x: f32, y: f32, width: u32, height: u32) -> Ray {
        let q = self.display_point(x, y, width, height);
        let c = self.lenslet_center(q);
        let f = &self.frame;
        let origin = f.eye + f.to_world(Vec3::new(c.x, c.y, 0.0));
        let dir = f
            .to_world(Vec3::new(c.x - q.x, c.y - q.y, self.gap))
            .normalize();
        Ray::new(origin, dir)
    }
}
