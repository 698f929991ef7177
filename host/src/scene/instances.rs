//! `[[instance]]` entries: copies of a named `[[mesh]]`, each placed by an affine transform,
//! checked when the scene is loaded and expanded into the two-level scene's bottoms and
//! placements ([`InstancedGeometry`], built by `kdray render` and `kdray trace` into one tree per
//! mesh under [`crate::instances::top_level`]) or flattened into one [`Geometry`] (what `kdray
//! build` and the other commands take).
//!
//! Copies are numbered from 0 in file order, an entry's grid `x` fastest, then `y`, then `z`;
//! that number is the copy's user id ([`Placement::user_id`]), which `kdray trace` reports with
//! each hit. The scene's other geometry (meshes without a name, triangles, spheres) is one more
//! instance after the copies, placed where it is, with the next id.

use super::desc::InstanceDesc;
use super::placement::transform_of;
use super::{Error, Result, SceneFile};
use crate::geometry::Geometry;
use crate::instances::Placement;
use glam::Vec3;
use kdray_core::instance::Affine;
use std::collections::HashMap;

/// The most copies all `[[instance]]` entries of a scene may make together.
pub const MAX_COPIES: u64 = 1 << 20;

/// A scene of instances: the meshes (bottom scenes' geometry, each built into its own tree) and
/// where their copies go.
#[derive(Clone, Debug, Default)]
pub struct InstancedGeometry {
    /// One per named mesh that an `[[instance]]` places, in order of first use, then the scene's
    /// other geometry when it has any.
    pub bottoms: Vec<Geometry>,
    /// Every copy, in id order, then the other geometry's identity placement.
    pub placements: Vec<Placement>,
}

/// One copy of a named mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Copy {
    /// The `[[instance]]` entry it comes from.
    pub entry: usize,
    /// The `[[mesh]]` entry it places.
    pub mesh: usize,
    /// Object → world (after the mesh's own transform).
    pub transform: Affine,
}

impl SceneFile {
    /// Whether the scene has `[[instance]]` entries.
    pub fn has_instances(&self) -> bool {
        !self.instances.is_empty()
    }

    /// The `[[mesh]]` entry named `name`.
    fn named_mesh(&self, name: &str) -> Option<usize> {
        self.meshes
            .iter()
            .position(|m| m.name.as_deref() == Some(name))
    }

    /// An error about `[[instance]]` entry `i`, at its line.
    fn instance_error(&self, i: usize, msg: &str) -> Error {
        let what = format!("instance of `{}`", self.instances[i].mesh);
        self.error(
            self.lines.instance.get(i).copied(),
            format!("{what}: {msg}"),
        )
    }

    /// Checks the mesh names and every `[[instance]]` entry (see [`Self::copies`]).
    ///
    /// # Errors
    /// A mesh name used twice; an entry's problem, at its line.
    pub(super) fn check_instances(&self) -> Result<()> {
        let mut names = HashMap::new();
        for (i, m) in self.meshes.iter().enumerate() {
            let Some(name) = &m.name else { continue };
            if names.insert(name.as_str(), i).is_some() {
                let line = self.lines.mesh.get(i).copied();
                return Err(self.error(line, format!("mesh `{name}`: the name is used twice")));
            }
        }
        self.copies().map(|_| ())
    }

    /// Every copy the `[[instance]]` entries make, in id order.
    ///
    /// # Errors
    /// At the entry's line: an unknown mesh name, a `matrix` given with `translate`, `scale` or
    /// `rotate_deg`, a non-finite or singular transform, a zero grid count, `grid` without
    /// `spacing` (or the reverse), a copy moved beyond f32, more than [`MAX_COPIES`] copies.
    pub(super) fn copies(&self) -> Result<Vec<Copy>> {
        let mut out = Vec::new();
        for (i, inst) in self.instances.iter().enumerate() {
            let fail = |msg: &str| self.instance_error(i, msg);
            let mesh = self.named_mesh(&inst.mesh).ok_or_else(|| {
                fail("no [[mesh]] has this name (a mesh that instances place needs `name`)")
            })?;
            let base = entry_transform(inst).map_err(|m| fail(&m))?;
            if !base.is_invertible() {
                return Err(fail("the transform is singular or nearly so"));
            }
            let (grid, spacing) = match (inst.grid, inst.spacing) {
                (None, None) => ([1, 1, 1], Vec3::ZERO),
                (Some(g), Some(s)) => (g, Vec3::from(s)),
                _ => return Err(fail("`grid` and `spacing` go together")),
            };
            if grid.contains(&0) {
                return Err(fail("grid counts must be at least 1"));
            }
            if !spacing.is_finite() {
                return Err(fail("spacing must be finite"));
            }
            let count = grid.iter().map(|&n| u64::from(n)).product::<u64>();
            if out.len() as u64 + count > MAX_COPIES {
                return Err(fail(&format!(
                    "the [[instance]] entries up to this one make more than {MAX_COPIES} copies"
                )));
            }
            for k in 0..grid[2] {
                for j in 0..grid[1] {
                    for i_x in 0..grid[0] {
                        let cell = spacing * Vec3::new(i_x as f32, j as f32, k as f32);
                        let mut m = base;
                        m.0[3] += cell.x;
                        m.0[7] += cell.y;
                        m.0[11] += cell.z;
                        if !m.is_finite() {
                            return Err(fail("a copy of the grid lies beyond f32's range"));
                        }
                        out.push(Copy {
                            entry: i,
                            mesh,
                            transform: m,
                        });
                    }
                }
            }
        }
        Ok(out)
    }

    /// Loads the meshes and lays the scene out in two levels: one bottom per named mesh that
    /// instances place, one for the other geometry (if any), and every copy's placement (see the
    /// module doc for the ids).
    ///
    /// # Errors
    /// As [`Self::geometry`]; a copy whose mesh, placed, lies beyond f32's range (at its entry).
    pub fn instanced_geometry(&self) -> Result<InstancedGeometry> {
        self.check_meshes()?;
        let copies = self.copies()?;
        let mut out = InstancedGeometry::default();
        let mut bottom_of: HashMap<usize, (u32, [Vec3; 2])> = HashMap::new();
        let resolve = self.material_resolver();
        for (id, c) in copies.iter().enumerate() {
            let (bottom, bounds) = match bottom_of.get(&c.mesh) {
                Some(&b) => b,
                None => {
                    let g = self.mesh_part(c.mesh, &resolve)?;
                    let b = (out.bottoms.len() as u32, bounds(&g));
                    out.bottoms.push(g);
                    bottom_of.insert(c.mesh, b);
                    b
                }
            };
            if c.transform.world_box(bounds).is_none() {
                return Err(self.instance_error(c.entry, "a copy lies beyond f32's range"));
            }
            out.placements.push(Placement {
                bottom,
                transform: c.transform,
                user_id: id as u32,
            });
        }
        let rest = self.base_geometry()?;
        if rest.prim_count() > 0 {
            out.placements.push(Placement {
                bottom: out.bottoms.len() as u32,
                transform: Affine::IDENTITY,
                user_id: copies.len() as u32,
            });
            out.bottoms.push(rest);
        }
        if out.placements.is_empty() {
            return Err(self.error(None, "the scene has no triangles or spheres".into()));
        }
        Ok(out)
    }

    /// The copies flattened: each named mesh's triangles moved by every copy's transform, in
    /// id order (what [`Self::geometry`] appends after the scene's other triangles).
    pub(super) fn flattened_copies(&self, out: &mut Geometry) -> Result<()> {
        let copies = self.copies()?;
        let mut parts: HashMap<usize, Geometry> = HashMap::new();
        let resolve = self.material_resolver();
        for c in &copies {
            if let std::collections::hash_map::Entry::Vacant(e) = parts.entry(c.mesh) {
                e.insert(self.mesh_part(c.mesh, &resolve)?);
            }
        }
        // Flattening multiplies the meshes: ask for the memory before making the copies.
        let triangles: u64 = copies
            .iter()
            .map(|c| parts[&c.mesh].triangles.len() as u64)
            .sum();
        crate::memory::ensure(
            &self.path,
            triangles * FLAT_BYTES_PER_TRIANGLE,
            &format!(
                "flattening {} copies into {triangles} triangles",
                copies.len()
            ),
            "`kdray render` and `kdray trace` keep one copy of each mesh (two levels)",
        )?;
        for c in &copies {
            let mut part = parts[&c.mesh].clone();
            place(&mut part, &c.transform);
            let material = part.tri_materials.first().copied().unwrap_or(0);
            part.tri_materials.clear();
            super::assemble::append(out, part, material);
        }
        Ok(())
    }
}

/// What a flattened triangle holds at most: its vertices, normals and texture coordinates
/// (36 + 36 + 24 bytes) and its material (4).
const FLAT_BYTES_PER_TRIANGLE: u64 = 100;

/// The entry's own transform: its `matrix`, or its `translate`, `scale` and `rotate_deg`.
fn entry_transform(inst: &InstanceDesc) -> core::result::Result<Affine, String> {
    let trs = inst.translate.is_some() || inst.scale.is_some() || inst.rotate_deg.is_some();
    match inst.matrix {
        Some(_) if trs => Err("`matrix` replaces translate, scale and rotate_deg: give one".into()),
        Some([a, b, c]) => {
            let m = Affine([
                a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3], c[0], c[1], c[2], c[3],
            ]);
            if m.is_finite() {
                Ok(m)
            } else {
                Err("matrix entries must be finite".into())
            }
        }
        None => Ok(transform_of(inst.translate, inst.scale, inst.rotate_deg)?
            .map_or(Affine::IDENTITY, |t| t.to_affine())),
    }
}

/// `g`'s triangles moved by `m`, each keeping its winding, so that its geometric normal
/// `(v1 − v0) × (v2 − v0)` turns over under a mirroring `m`; vertex normals go through the inverse
/// transpose and, under a mirroring `m`, turn over with it (as the two-level scene shades them,
/// `kdray_core::render`), then are renormalized.
fn place(g: &mut Geometry, m: &Affine) {
    for v in g.triangles.iter_mut().flatten() {
        *v = m.point(*v);
    }
    let sign = if m.determinant() < 0.0 { -1.0 } else { 1.0 };
    if let Some(inv) = m.inverse() {
        let i = &inv.0;
        for n in g.normals.iter_mut().flatten().flatten() {
            let col = |j: usize| i[j] * n.x + i[4 + j] * n.y + i[8 + j] * n.z;
            *n = (sign * Vec3::new(col(0), col(1), col(2))).normalize_or_zero();
        }
    }
}

/// The box around `g`'s triangles and spheres.
fn bounds(g: &Geometry) -> [Vec3; 2] {
    let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    for v in g.triangles.iter().flatten() {
        (lo, hi) = (lo.min(*v), hi.max(*v));
    }
    for &(c, r) in &g.spheres {
        (lo, hi) = (lo.min(c - r), hi.max(c + r));
    }
    [lo, hi]
}
