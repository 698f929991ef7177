//! The ray sets `kdray accuracy` measures every kernel on.
//!
//! A set is a list of [`Case`]s: eight rays that share their candidate triangles and one sphere,
//! so that the scalar kernels take them one by one and the packet kernels as one 8-wide or two
//! 4-wide packets, on exactly the same tests.

use crate::closed::{Mesh, icosphere};
use core::ops::Range;
use glam::Vec3;
use kdray_core::{Ray, Sphere};

/// Rays per case: one 8-wide packet.
pub const LANES: usize = 8;

/// Eight rays, the candidate triangles they are tested against (a range of [`RaySet::tris`]) and
/// a sphere.
#[derive(Clone, Debug)]
pub struct Case {
    pub rays: [Ray; LANES],
    pub tris: Range<usize>,
    pub sphere: Sphere,
}

/// A named list of cases over one list of triangles (as vertex triples, the exact input every
/// kernel and the f64 reference start from).
#[derive(Clone, Debug)]
pub struct RaySet {
    pub name: &'static str,
    pub tris: Vec<[Vec3; 3]>,
    pub cases: Vec<Case>,
}

impl RaySet {
    /// All rays, case by case.
    pub fn rays(&self) -> impl Iterator<Item = &Ray> {
        self.cases.iter().flat_map(|c| c.rays.iter())
    }

    /// Ray–triangle tests in one pass over the set.
    pub fn tri_tests(&self) -> usize {
        self.cases.iter().map(|c| LANES * c.tris.len()).sum()
    }

    /// Ray–sphere tests in one pass over the set.
    pub fn sphere_tests(&self) -> usize {
        self.cases.len() * LANES
    }
}

/// Knuth's MMIX linear congruential generator: a fixed sequence, so the sets are the same on every
/// run.
struct Lcg(u64);

impl Lcg {
    /// Uniform in `[0, 1)` on the 2⁻²⁴ grid.
    fn next_f32(&mut self) -> f32 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 40) as f32 * (1.0 / 16_777_216.0)
    }

    fn uniform(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.next_f32()
    }

    fn vec3(&mut self, lo: f32, hi: f32) -> Vec3 {
        Vec3::new(
            self.uniform(lo, hi),
            self.uniform(lo, hi),
            self.uniform(lo, hi),
        )
    }
}

/// `cases` random triangles (vertices uniform in `[−1, 1]³`), each with eight rays from origins
/// uniform in `[−4, 4]³` aimed at points `v0 + a·e1 + b·e2` with `a, b` uniform in
/// `[−0.25, 1.25]` (about a third hit, many near an edge), normalized directions. The sphere is
/// centred on the triangle's centroid with the mean distance of its vertices as radius.
pub fn random(cases: usize) -> RaySet {
    let mut rng = Lcg(0x006b_6472_6179);
    let mut set = RaySet {
        name: "random",
        tris: Vec::with_capacity(cases),
        cases: Vec::with_capacity(cases),
    };
    while set.cases.len() < cases {
        let v = [
            rng.vec3(-1.0, 1.0),
            rng.vec3(-1.0, 1.0),
            rng.vec3(-1.0, 1.0),
        ];
        let (e1, e2) = (v[1] - v[0], v[2] - v[0]);
        let mut rays = [Ray::new(Vec3::ZERO, Vec3::Z); LANES];
        for ray in &mut rays {
            loop {
                let origin = rng.vec3(-4.0, 4.0);
                let (a, b) = (rng.uniform(-0.25, 1.25), rng.uniform(-0.25, 1.25));
                if let Some(d) = (v[0] + a * e1 + b * e2 - origin).try_normalize() {
                    *ray = Ray::new(origin, d);
                    break;
                }
            }
        }
        let centre = (v[0] + v[1] + v[2]) / 3.0;
        let radius = v.iter().map(|&p| (p - centre).length()).sum::<f32>() / 3.0;
        let k = set.tris.len();
        set.tris.push(v);
        set.cases.push(Case {
            rays,
            tris: k..k + 1,
            sphere: Sphere {
                center: centre,
                radius,
            },
        });
    }
    set
}

/// Where the eight rays of a seam case start, relative to the mesh's centre: the centre itself and
/// seven points a quarter of the way to the surface.
const SEAM_ORIGINS: [Vec3; LANES] = [
    Vec3::ZERO,
    Vec3::new(0.25, 0.0, 0.0),
    Vec3::new(0.0, -0.25, 0.0),
    Vec3::new(0.0, 0.0, 0.25),
    Vec3::new(0.144, 0.144, -0.144),
    Vec3::new(-0.144, 0.144, 0.144),
    Vec3::new(-0.2, -0.15, 0.0),
    Vec3::new(0.0, 0.15, -0.2),
];

/// The closed unit icosphere (`levels` subdivisions; 4 gives the 5,120 triangles) with
/// one case per seam target: each vertex and 4 points on each edge ([`Mesh::seam_targets`], the
/// issue's 33,282), aimed at from eight points inside (normalized directions, as a rays file holds
/// them), against the triangles that share that vertex or edge, and the unit sphere.
pub fn seams(levels: u32) -> RaySet {
    let mesh = icosphere(levels);
    seams_of(&mesh, "seams")
}

/// [`seams`] for any closed mesh.
pub fn seams_of(mesh: &Mesh, name: &'static str) -> RaySet {
    let tris = mesh.triangles();
    // The faces around each vertex, and the two faces of each edge.
    let mut around: Vec<Vec<usize>> = vec![Vec::new(); mesh.vertices.len()];
    for (f, face) in mesh.faces.iter().enumerate() {
        for &i in face {
            around[i as usize].push(f);
        }
    }
    let mut candidates: Vec<Vec<usize>> = around.clone();
    for (a, b) in mesh.edges() {
        let shared: Vec<usize> = around[a as usize]
            .iter()
            .copied()
            .filter(|f| around[b as usize].contains(f))
            .collect();
        candidates.extend(core::iter::repeat_n(shared, 4));
    }
    let targets = mesh.seam_targets();
    debug_assert_eq!(targets.len(), candidates.len());
    let mut set = RaySet {
        name,
        tris: Vec::new(),
        cases: Vec::with_capacity(targets.len()),
    };
    let scale = mesh
        .vertices
        .iter()
        .map(|v| (*v - mesh.centre).length())
        .fold(0.0f32, f32::max);
    for (target, faces) in targets.iter().zip(&candidates) {
        let start = set.tris.len();
        set.tris.extend(faces.iter().map(|&f| tris[f]));
        let rays = SEAM_ORIGINS.map(|o| {
            let origin = mesh.centre + o * scale;
            Ray::new(origin, (*target - origin).normalize())
        });
        set.cases.push(Case {
            rays,
            tris: start..set.tris.len(),
            sphere: Sphere {
                center: mesh.centre,
                radius: scale,
            },
        });
    }
    set
}
