//! A prebuilt tree compiled into the program and traced the way firmware does it: no allocation,
//! no file system, nothing but `kdray_core` (`no_std`). The `main` here prints with `std`; the
//! function [`trace`] would compile unchanged in a `#![no_std]` crate.
//!
//! `data/cube.kdt` is a unit cube ([0, 1]³, 12 triangles) that the host tool built from
//! `data/cube.obj`:
//! ```sh
//! kdray build core/examples/data/cube.obj -o core/examples/data/cube.kdt --layout nodes --leaves list
//! ```
//! (again after a format version change: `Scene::from_words` then refuses the old file and asks
//! for exactly that.) Run with `cargo run -p kdray-core --example trace_kdt`.

use glam::Vec3;
use kdray_core::words::from_bytes;
use kdray_core::{FormatError, Hit, Ray, Scene, include_words};

/// The tree's bytes in the program image, on a 4-byte boundary so that they can be viewed as
/// words in place (on a microcontroller: in flash, never copied to RAM).
static CUBE_KDT: &[u8] = include_words!("data/cube.kdt");

/// Traces `rays` into `hits` (same length) through the scene in `bytes`. Allocation-free: the
/// caller owns every buffer, the scene borrows the bytes. Returns the number of hits.
fn trace(bytes: &[u8], rays: &[Ray], hits: &mut [Hit]) -> Result<usize, &'static str> {
    let words = from_bytes(bytes).map_err(|_| "not a word array")?;
    // Validates everything once (linear time, never panics); every query after it relies on it.
    let scene = Scene::from_words(words).map_err(|e| match e {
        FormatError::UnsupportedVersion(_) => "written by another kdray version",
        _ => "not a valid kdray tree",
    })?;
    let mut count = 0;
    for (ray, hit) in rays.iter().zip(hits.iter_mut()) {
        *hit = scene.intersect(ray);
        count += usize::from(hit.is_hit());
    }
    Ok(count)
}

fn main() {
    // Four rays from outside the cube towards its centre, one beside it.
    let centre = Vec3::splat(0.5);
    let origins = [
        Vec3::new(0.5, 0.5, 3.0),
        Vec3::new(-2.0, 0.5, 0.5),
        Vec3::new(0.2, 4.0, 0.7),
        Vec3::new(2.0, 2.0, 2.0),
    ];
    let mut rays = [Ray::new(Vec3::ZERO, Vec3::X); 5];
    for (ray, o) in rays.iter_mut().zip(origins) {
        *ray = Ray::new(o, (centre - o).normalize());
    }
    rays[4] = Ray::new(Vec3::new(3.0, 3.0, 3.0), Vec3::X);
    let mut hits = [Hit::MISS; 5];
    match trace(CUBE_KDT, &rays, &mut hits) {
        Ok(n) => {
            for (ray, hit) in rays.iter().zip(&hits) {
                if hit.is_hit() {
                    println!(
                        "ray from {}: hits triangle {} at {}",
                        ray.origin,
                        hit.prim,
                        ray.at(hit.t)
                    );
                } else {
                    println!("ray from {}: miss", ray.origin);
                }
            }
            println!("{n} of {} rays hit the cube", rays.len());
        }
        Err(e) => {
            eprintln!("data/cube.kdt: {e}; rebuild it (see this example's doc)");
            std::process::exit(1);
        }
    }
}
