//! The page's progressive render (`targets/wasm/www/`): one sample of every pixel per frame, added
//! into a sum the page owns, so the canvas sharpens while the user watches.
//!
//! Exactness: `render_rows` sums a pixel's samples one by one in sample order, starting from 0,
//! then divides by spp. Adding sample `k` alone with `Frame::add_samples(x, y, k..k + 1, sums)` to the running sum
//! of samples `0..k` repeats those additions in the same order, so `kd_to_rgba(sum, n)` after samples `0..n` is `kdray render --spp n`, bit for bit.

use crate::{Status, disjoint, with_state};
use glam::Vec3;
use kdray_core::render::{Frame, SampleSums};

/// Adds sample `sample` of every pixel in rows `first_row .. first_row + rows` of a
/// `width × height` image (0, 0: the description's size) to the sums at `sums_ptr`
/// (`rows · width` pixels, 3 f32 each: linear RGB, the layout [`crate::kd_to_rgba`] reads).
/// Every ray goes through the scalar walk (with one sample a pixel, 8-wide packets would run one
/// live lane; the image is the same either way), with the traversal kernel of this build's
/// contents (`Prims`). Returns the number of rays traced — camera,
/// bounce and shadow rays, saturated at `i32::MAX` — or a negative [`Status`].
#[unsafe(no_mangle)]
pub extern "C" fn kd_accumulate(
    first_row: u32,
    rows: u32,
    width: u32,
    height: u32,
    sample: u32,
    sums_ptr: u32,
) -> i32 {
    with_state(|state| {
        let loaded = state.loaded.as_ref().ok_or(Status::NotLoaded)?;
        let s = loaded.settings(width, height);
        let end_row = first_row.checked_add(rows).ok_or(Status::BadArgument)?;
        let end_sample = sample.checked_add(1).ok_or(Status::BadArgument)?;
        if s.width == 0 || s.height == 0 || end_row > s.height {
            return Err(Status::BadArgument);
        }
        let floats = rows
            .checked_mul(s.width)
            .and_then(|p| p.checked_mul(3))
            .ok_or(Status::BadArgument)?;
        let out = state.regions.slice_mut::<f32>(sums_ptr, floats)?;
        disjoint(out, &loaded.inputs)?;
        let d = &loaded.desc;
        let frame = Frame {
            scene: &loaded.scene,
            camera: &loaded.camera,
            materials: d.materials(),
            lights: d.lights(),
            settings: &s,
        };
        let mut rays = 0u64;
        let (pixels, _) = out.as_chunks_mut::<3>();
        for (k, px) in pixels.iter_mut().enumerate() {
            let k = k as u32;
            let (x, y) = (k % s.width, first_row + k / s.width);
            // Cannot fail: the size is not empty and (x, y) lies inside the image (checked above).
            let mut sums = SampleSums {
                sum: Vec3::from_array(*px),
                ..SampleSums::default()
            };
            frame
                .add_samples_with::<crate::Prims, false>(x, y, sample..end_sample, &mut sums)
                .map_err(|_| Status::BadArgument)?;
            *px = sums.sum.to_array();
            rays += sums.rays;
        }
        Ok(i32::try_from(rays).unwrap_or(i32::MAX))
    })
}
