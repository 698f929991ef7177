//! Triangles → kd-tree → rays: the whole way through the two crates in one file.
//!
//! `kdray` (this crate, `std`) builds the SAH kd-tree over a mesh and serializes it into the flat
//! array of `u32` words; `kdray_core` (`no_std`, no allocation) validates those words once and
//! traces rays through them. Run with `cargo run --release -p kdray --example triangles`.

use glam::Vec3;
use kdray::Geometry;
use kdray::build::{BuildParams, build};
use kdray::flat;
use kdray_core::{Ray, Scene};

fn main() -> Result<(), Box<dyn core::error::Error>> {
    // A unit square in the z = 0 plane (two triangles) and a sphere behind it.
    let geom = Geometry {
        triangles: vec![
            [
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(1.0, 1.0, 0.0),
            ],
            [
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::new(0.0, 1.0, 0.0),
            ],
        ],
        spheres: vec![(Vec3::new(0.5, 0.5, -3.0), 0.5)],
        ..Geometry::default()
    };

    // Build the tree (on all cores; `None`: no progress counter) and flatten it into words:
    // this is what `kdray build` writes into a .kdt file.
    let tree = build(&geom, &BuildParams::default(), None)?;
    let words: Vec<u32> = flat::serialize(&tree, &geom, 0.0)?;

    // The core side: validate once, then trace. `Scene` borrows the words, allocation-free.
    let scene = Scene::from_words(&words).map_err(|e| e.to_string())?;
    println!(
        "scene: {} triangles, {} spheres, {} nodes, {} words",
        scene.tri_count(),
        scene.sphere_count(),
        scene.node_count(),
        words.len()
    );
    let rays = [
        (
            "through the square",
            Ray::new(Vec3::new(0.25, 0.5, 1.0), Vec3::NEG_Z),
        ),
        (
            "beside it, onto the sphere",
            Ray::new(Vec3::new(0.5, 0.5, -1.0), Vec3::NEG_Z),
        ),
        (
            "past everything",
            Ray::new(Vec3::new(5.0, 5.0, 1.0), Vec3::NEG_Z),
        ),
    ];
    for (what, ray) in rays {
        // Closest hit. `prim` numbers the primitives in storage order: triangles, then spheres
        // (`Scene::input_id` maps a triangle back to its input index).
        let hit = scene.intersect(&ray);
        if hit.is_hit() {
            println!(
                "{what}: t = {}, primitive {} at {}, barycentrics ({}, {})",
                hit.t,
                hit.prim,
                ray.at(hit.t),
                hit.u,
                hit.v
            );
        } else {
            println!("{what}: miss");
        }
    }
    // Any hit, for shadow rays: is anything between the origin and t = 2?
    let shadow = Ray::new(Vec3::new(0.5, 0.5, 1.0), Vec3::NEG_Z).with_range(0.0, 2.0);
    println!("occluded within t < 2: {}", scene.occluded(&shadow));
    Ok(())
}
