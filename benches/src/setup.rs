//! The benchmark protocol's workload (DESIGN.md, "Benchmark protocol"), shared by the criterion
//! benches and the `compare` table: a mesh, kdray's tree over it built single-threaded, the
//! framing camera's primary rays in 2×4 tiles, and one cosine-weighted diffuse bounce per
//! primary hit.

use glam::Vec3;
use kdray::build::{BuildParams, build};
use kdray::flat::serialize;
use kdray::rays::{diffuse_rays, framing_camera, primary_rays};
use kdray_core::simd::f32x8;
use kdray_core::{Hit, Ray, Scene};
use std::path::Path;
use std::time::Instant;

/// Everything a benchmark of one mesh needs.
pub struct Workload {
    pub triangles: Vec<[Vec3; 3]>,
    /// kdray's flat scene.
    pub words: Vec<u32>,
    /// kdray's single-threaded build time.
    pub build_ms: f64,
    pub primary: Vec<Ray>,
    pub diffuse: Vec<Ray>,
}

impl Workload {
    /// Loads `mesh` and prepares the ray sets for a `width × height` image.
    ///
    /// # Errors
    /// The loader's message, naming the file.
    pub fn load(mesh: &Path, width: u32, height: u32) -> Result<Self, String> {
        let geom = kdray::load::load_mesh(mesh).map_err(|e| e.to_string())?;
        let start = Instant::now();
        let params = BuildParams {
            parallel: false,
            ..BuildParams::default()
        };
        let tree = build(&geom, &params, None)?;
        let build_ms = start.elapsed().as_secs_f64() * 1e3;
        let words = serialize(&tree, &geom, build_ms as f32)?;
        let scene = Scene::from_words(&words).map_err(|e| e.to_string())?;
        let camera = framing_camera(scene.bounds()).ok_or("scene too large to frame")?;
        let primary = primary_rays(&camera, width, height);
        let mut hits = vec![Hit::MISS; primary.len()];
        trace_packets::<f32x8>(&scene, &primary, &mut hits);
        let diffuse = diffuse_rays(&scene, &primary, &hits, 1);
        Ok(Self {
            triangles: geom.triangles,
            words,
            build_ms,
            primary,
            diffuse,
        })
    }

    /// The validated scene view.
    pub fn scene(&self) -> Scene<'_> {
        Scene::from_words(&self.words).expect("the writer's output validates")
    }
}

pub use kdray::rays::{to_input_ids, trace_packets, trace_scalar};
