//! Closed meshes and the rays that stress their seams: the stiff cases of watertight mode.
//!
//! - [`icosphere`]: a subdivided icosahedron on the unit sphere (subdivision 4: 2,562 vertices,
//!   7,680 edges, 5,120 triangles), and [`skinny_box`]: the cube `[−1, 1]³` whose faces are two
//!   large triangles each or fans of long, skinny ones. Both are closed: every edge is shared by
//!   exactly two triangles, which hold bit-identical copies of its two vertices.
//! - [`Mesh::transformed`]: each vertex moved once (`v·scale + offset` in f32), so shared vertices
//!   stay bit-identical; at 1e7 the unit mesh snaps to a lattice of spacing 1. [`Mesh::mapped`]
//!   the same for any map (stretches by 10⁶ along one axis, random affine maps).
//! - [`Mesh::seam_rays`]: from a point inside, a ray to every vertex and to 4 points on every edge
//!   (33,282 rays for the icosphere, the count). With [`Aim::Exact`] the direction is
//!   `target − origin` times a power of two, exact in f32, so the ray passes exactly through the
//!   target (when `origin` is the centre); [`Aim::Normalized`] normalizes it, as a rays file does.

use glam::Vec3;
use std::collections::HashMap;

/// An indexed triangle mesh.
#[derive(Clone, Debug)]
pub struct Mesh {
    pub vertices: Vec<Vec3>,
    pub faces: Vec<[u32; 3]>,
    /// The point the rays start from: the centre, inside the mesh.
    pub centre: Vec3,
}

/// How [`Mesh::seam_rays`] sets a ray's direction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Aim {
    /// `target − origin` scaled by a power of two into `[0.5, 1)` of length: exact.
    Exact,
    /// `(target − origin).normalize()`: what a rays file holds.
    Normalized,
}

impl Mesh {
    /// The triangles as vertex triples (the builder's input).
    pub fn triangles(&self) -> Vec<[Vec3; 3]> {
        self.faces
            .iter()
            .map(|f| f.map(|i| self.vertices[i as usize]))
            .collect()
    }

    /// The mesh built (default SAH parameters, one thread) and serialized into flat words.
    ///
    /// # Panics
    /// If the build or the serializer refuses the mesh, which the meshes made here never are.
    pub fn scene_words(&self) -> Vec<u32> {
        let geom = crate::Geometry {
            triangles: self.triangles(),
            ..crate::Geometry::default()
        };
        let params = crate::build::BuildParams {
            parallel: false,
            ..crate::build::BuildParams::default()
        };
        let tree = crate::build::build(&geom, &params, None).expect("a closed mesh builds");
        crate::flat::serialize(&tree, &geom, 0.0).expect("and serializes")
    }

    /// Every edge once, as sorted vertex index pairs.
    pub fn edges(&self) -> Vec<(u32, u32)> {
        let mut edges: Vec<(u32, u32)> = self
            .faces
            .iter()
            .flat_map(|f| [(f[0], f[1]), (f[1], f[2]), (f[2], f[0])])
            .map(|(a, b)| (a.min(b), a.max(b)))
            .collect();
        edges.sort_unstable();
        edges.dedup();
        edges
    }

    /// True when every edge is shared by exactly two faces.
    pub fn is_closed(&self) -> bool {
        let mut count: HashMap<(u32, u32), u32> = HashMap::new();
        for f in &self.faces {
            for (a, b) in [(f[0], f[1]), (f[1], f[2]), (f[2], f[0])] {
                *count.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        count.values().all(|&n| n == 2)
    }

    /// Each vertex (and the centre) mapped once to `v·scale + offset` in f32.
    pub fn transformed(&self, scale: f32, offset: Vec3) -> Mesh {
        Mesh {
            vertices: self.vertices.iter().map(|&v| v * scale + offset).collect(),
            faces: self.faces.clone(),
            centre: self.centre * scale + offset,
        }
    }

    /// Each vertex (and the centre) mapped once by `f` (an affine stretch, say): shared vertices
    /// stay bit-identical, so a closed mesh stays closed.
    pub fn mapped(&self, f: impl Fn(Vec3) -> Vec3) -> Mesh {
        Mesh {
            vertices: self.vertices.iter().map(|&v| f(v)).collect(),
            faces: self.faces.clone(),
            centre: f(self.centre),
        }
    }

    /// Every vertex, then 4 points on every edge (at 1/5 … 4/5, `a + (b − a)·f` in f32).
    pub fn seam_targets(&self) -> Vec<Vec3> {
        let mut targets = self.vertices.clone();
        for (a, b) in self.edges() {
            let (a, b) = (self.vertices[a as usize], self.vertices[b as usize]);
            targets.extend((1..5).map(|k| a + (b - a) * (k as f32 / 5.0)));
        }
        targets
    }

    /// How many of the edge points of [`Mesh::seam_targets`] lie exactly on their edge's line (the
    /// rest were moved off it by the rounding of `a + (b − a)·f`), by the cross product in f64:
    /// differences of f32 are exact there, and their products are unless they need more than 53
    /// bits (coordinates of very different magnitudes), so the count is exact up to such rare
    /// roundings.
    pub fn edge_targets_on_edge(&self) -> usize {
        let d = |p: Vec3, q: Vec3| [0, 1, 2].map(|i| f64::from(p[i]) - f64::from(q[i]));
        self.edges()
            .into_iter()
            .flat_map(|(a, b)| {
                let (a, b) = (self.vertices[a as usize], self.vertices[b as usize]);
                (1..5).map(move |k| (a, b, a + (b - a) * (k as f32 / 5.0)))
            })
            .filter(|&(a, b, p)| {
                let (u, v) = (d(p, a), d(b, a));
                u[1] * v[2] == u[2] * v[1]
                    && u[2] * v[0] == u[0] * v[2]
                    && u[0] * v[1] == u[1] * v[0]
            })
            .count()
    }

    /// A ray from `origin` to each of [`Mesh::seam_targets`], `tmin = 0`, `tmax = ∞`.
    pub fn seam_rays(&self, origin: Vec3, aim: Aim) -> Vec<kdray_core::Ray> {
        self.seam_targets()
            .into_iter()
            .map(|p| {
                let d = p - origin;
                let d = match aim {
                    Aim::Exact => d * pow2_scale(d),
                    Aim::Normalized => d.normalize(),
                };
                kdray_core::Ray::new(origin, d)
            })
            .collect()
    }
}

/// `2^k` with `|d|·2^k` in `[0.5, 2)`: multiplying by it is exact (no overflow or subnormals for
/// the meshes here).
fn pow2_scale(d: Vec3) -> f32 {
    let m = d.abs().max_element();
    let exp = ((m.to_bits() >> 23) & 0xFF) as i32 - 127;
    f32::from_bits(((127 - exp) as u32) << 23)
}

/// A unit icosphere: the icosahedron, each triangle split into four `levels` times, every new
/// vertex pushed onto the sphere (computed in f64, rounded once); shared midpoints are computed
/// once, so the mesh is closed.
pub fn icosphere(levels: u32) -> Mesh {
    let p = (1.0 + 5f64.sqrt()) / 2.0;
    let mut verts: Vec<[f64; 3]> = [
        [-1.0, p, 0.0],
        [1.0, p, 0.0],
        [-1.0, -p, 0.0],
        [1.0, -p, 0.0],
        [0.0, -1.0, p],
        [0.0, 1.0, p],
        [0.0, -1.0, -p],
        [0.0, 1.0, -p],
        [p, 0.0, -1.0],
        [p, 0.0, 1.0],
        [-p, 0.0, -1.0],
        [-p, 0.0, 1.0],
    ]
    .iter()
    .map(|v| unit(*v))
    .collect();
    let mut faces: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let mut midpoint = |a: u32, b: u32, verts: &mut Vec<[f64; 3]>| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let (p, q) = (verts[a as usize], verts[b as usize]);
                verts.push(unit([p[0] + q[0], p[1] + q[1], p[2] + q[2]]));
                verts.len() as u32 - 1
            })
        };
        faces = faces
            .iter()
            .flat_map(|&[a, b, c]| {
                let ab = midpoint(a, b, &mut verts);
                let bc = midpoint(b, c, &mut verts);
                let ca = midpoint(c, a, &mut verts);
                [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
            })
            .collect();
    }
    Mesh {
        vertices: verts
            .iter()
            .map(|v| Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32))
            .collect(),
        faces,
        centre: Vec3::ZERO,
    }
}

fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [v[0] / n, v[1] / n, v[2] / n]
}

/// The cube `[−1, 1]³`: the three faces at `−1` are two large triangles each; the three at `+1`
/// are fans of `2·fan` skinny triangles (from the two corners off a diagonal to `fan + 1` points
/// along it, about `fan / 2` times longer than wide). Face boundaries are the cube's edges, whole,
/// so the mesh is closed.
pub fn skinny_box(fan: u32) -> Mesh {
    let corner = |i: u32| {
        Vec3::new(
            if i & 1 != 0 { 1.0 } else { -1.0 },
            if i & 2 != 0 { 1.0 } else { -1.0 },
            if i & 4 != 0 { 1.0 } else { -1.0 },
        )
    };
    let mut vertices: Vec<Vec3> = (0..8).map(corner).collect();
    let mut faces = Vec::new();
    // Each face as a cycle of corner indices (bit `axis` fixed).
    for axis in 0..3 {
        let (u, v) = (1 << ((axis + 1) % 3), 1 << ((axis + 2) % 3));
        for side in [0u32, 1 << axis] {
            let [a, b, c, d] = [side, side | u, side | u | v, side | v];
            if side == 0 {
                faces.push([a, b, c]);
                faces.push([a, c, d]);
                continue;
            }
            // Diagonal a → c with fan − 1 points between, computed in f32.
            let (pa, pc) = (vertices[a as usize], vertices[c as usize]);
            let mut diag = vec![a];
            for k in 1..fan {
                vertices.push(pa + (pc - pa) * (k as f32 / fan as f32));
                diag.push(vertices.len() as u32 - 1);
            }
            diag.push(c);
            for w in diag.windows(2) {
                faces.push([b, w[1], w[0]]);
                faces.push([d, w[0], w[1]]);
            }
        }
    }
    Mesh {
        vertices,
        faces,
        centre: Vec3::ZERO,
    }
}
