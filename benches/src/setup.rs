//! The benchmark protocol's workload (docs/BENCHMARKS.md, "Protocol"), shared by the criterion
//! benches and the `compare` table: a mesh, kdray's tree over it built single-threaded, and for
//! each camera framing ([`Framing`]) its primary rays in 2×4 tiles and one cosine-weighted
//! diffuse bounce per primary hit.

use crate::framing::{Framing, loose_camera, tight_camera};
use glam::Vec3;
use kdray::build::{BuildParams, build};
use kdray::flat::{Layout, Leaves, serialize, serialize_as};
use kdray::rays::{diffuse_rays, primary_rays};
use kdray_core::camera::Camera;
use kdray_core::simd::f32x8;
use kdray_core::{Hit, Ray, Scene};
use std::path::Path;
use std::time::Instant;

/// The rays of one framing.
pub struct RaySets {
    pub framing: Framing,
    /// The camera's rays, one per pixel, tile by tile ([`primary_rays`]).
    pub primary: Vec<Ray>,
    /// How many of `primary` hit the mesh.
    pub primary_hits: usize,
    /// One bounce per primary hit ([`diffuse_rays`], seed 1).
    pub diffuse: Vec<Ray>,
}

impl RaySets {
    /// The share of primary rays that hit the mesh, in `[0, 1]`.
    pub fn hit_fraction(&self) -> f64 {
        self.primary_hits as f64 / self.primary.len().max(1) as f64
    }

    fn new(scene: &Scene, framing: Framing, camera: &impl Camera, size: (u32, u32)) -> Self {
        let primary = primary_rays(camera, size.0, size.1);
        let mut hits = vec![Hit::MISS; primary.len()];
        trace_packets::<f32x8>(scene, &primary, &mut hits);
        let diffuse = diffuse_rays(scene, &primary, &hits, 1);
        Self {
            framing,
            primary_hits: hits.iter().filter(|h| h.is_hit()).count(),
            primary,
            diffuse,
        }
    }
}

/// Everything a benchmark of one mesh needs.
pub struct Workload {
    pub triangles: Vec<[Vec3; 3]>,
    /// kdray's flat scene.
    pub words: Vec<u32>,
    /// kdray's single-threaded build time.
    pub build_ms: f64,
    /// kdray's tree with its leaves in triangle groups (`kdray build --leaves groups`: the SAH
    /// priced in groups, `BuildParams::grouped`), and its single-threaded build time (the
    /// serialization included, as above).
    pub grouped_words: Vec<u32>,
    pub grouped_build_ms: f64,
    /// The grouped tree with its wide section (`kdray build --leaves groups --layout wide`),
    /// which the single-ray queries walk eight cells at a time.
    pub wide_words: Vec<u32>,
    /// One entry per framing, in [`Framing::ALL`]'s order (loose, then tight).
    pub framings: Vec<RaySets>,
}

impl Workload {
    /// Loads `mesh` and prepares both framings' ray sets for a `width × height` image.
    ///
    /// # Errors
    /// The loader's message, naming the file; a scene no camera can frame.
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
        let start = Instant::now();
        let grouped = BuildParams {
            parallel: false,
            ..BuildParams::grouped()
        };
        let tree = build(&geom, &grouped, None)?;
        let grouped_words = serialize_as(&tree, &geom, 0.0, Layout::Nodes, Leaves::Groups)?;
        let grouped_build_ms = start.elapsed().as_secs_f64() * 1e3;
        let wide_words = serialize_as(&tree, &geom, 0.0, Layout::Wide, Leaves::Groups)?;
        let scene = Scene::from_words(&words).map_err(|e| e.to_string())?;
        let cannot = |framing: Framing| {
            format!("{}: no {} camera frames it", mesh.display(), framing.name())
        };
        let size = (width, height);
        let framings = Framing::ALL
            .iter()
            .map(|&framing| {
                Ok(match framing {
                    Framing::Loose => {
                        let camera = loose_camera(scene.bounds()).ok_or_else(|| cannot(framing))?;
                        RaySets::new(&scene, framing, &camera, size)
                    }
                    Framing::Tight => {
                        let camera = tight_camera(scene.bounds(), &geom.triangles)
                            .ok_or_else(|| cannot(framing))?;
                        RaySets::new(&scene, framing, &camera, size)
                    }
                })
            })
            .collect::<Result<_, String>>()?;
        Ok(Self {
            triangles: geom.triangles,
            words,
            build_ms,
            grouped_words,
            grouped_build_ms,
            wide_words,
            framings,
        })
    }

    /// The validated scene view.
    pub fn scene(&self) -> Scene<'_> {
        Scene::from_words(&self.words).expect("the writer's output validates")
    }

    /// The validated view of the grouped tree.
    pub fn grouped_scene(&self) -> Scene<'_> {
        Scene::from_words(&self.grouped_words).expect("the writer's output validates")
    }

    /// The validated view of the grouped tree with its wide section.
    pub fn wide_scene(&self) -> Scene<'_> {
        Scene::from_words(&self.wide_words).expect("the writer's output validates")
    }
}

pub use kdray::rays::{to_input_ids, trace_packets, trace_scalar};
