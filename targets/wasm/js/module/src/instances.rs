//! Scenes of many meshes: the package's `InstancedScene` (`src/core.js`) and its three.js
//! adapter (`src/hierarchy.js`). A top level holds the handles of the bottom scenes it places
//! (each a scene of [`crate::kdj_build`] or [`crate::kdj_load`], pinned so that disposing one
//! from JavaScript while a top level uses it frees it only when that top level goes), and the
//! top level that the host's [`TopLevel`] builds and the core's
//! [`InstancedScene::from_built_words`] opens. Placing instances again ([`kdj_top_place`])
//! refits the top level when as many are placed as before ([`TopLevel::move_to`]; built anew
//! once refits have loosened it) and otherwise builds it anew; the bottom scenes stay as they
//! are.
//!
//! Placements are 14 words each: the object → world transform as 12 f32 (a 3×4 row-major
//! matrix, the core's [`Affine`]), the bottom scene's index in the list given to
//! [`kdj_top_new`] (u32) and the instance's user id (u32), which hits report. A transform that
//! is not finite is refused, naming the placement; one that the core cannot invert (a scale of
//! zero: three.js applications hide instances that way) places nothing and is counted.

use crate::memory::try_reserve;
use crate::{NO_SCENE, State, bad, disjoint, mode, unit, with_state};
use glam::Vec3;
use kdray::instances::{Placement, TopLevel};
use kdray_core::format::Scene;
use kdray_core::instance::{Affine, InstancedScene};

/// Words of one placement.
const PLACEMENT_WORDS: usize = 14;

/// A top level: the pinned bottom scenes' handles, copies of their views, the top level's words
/// and the opened top level over them (both `None` while nothing is placed). The bottoms' views
/// are leaked into a `&'static` slice, taken back in `Drop`; the opened top level views the
/// words of `level` as `&'static`, so it is dropped before `level` changes or goes
/// ([`Top::clear`], [`Top::open`]).
pub struct Top {
    handles: Vec<u32>,
    bottoms: *mut [Scene<'static>],
    level: Option<TopLevel>,
    top: Option<InstancedScene<'static, 'static>>,
}

impl Top {
    fn bottoms(&self) -> &'static [Scene<'static>] {
        // SAFETY: leaked in `kdj_top_new`, freed only in `drop`; only shared views exist.
        unsafe { &*self.bottoms }
    }

    /// Drops the top level (the only view of its words), then its words.
    fn clear(&mut self) {
        self.top = None;
        self.level = None;
    }

    /// Opens the words of `level` (built or refitted by this module just now: opened as the
    /// builder's own words, the tree's shape and the bottom indices checked, not the checksum
    /// and the records' f64 checks) and keeps both.
    fn open(&mut self, level: TopLevel) -> Result<(), (i32, String)> {
        self.top = None;
        let level = self.level.insert(level);
        let words: *const [u32] = level.built_words();
        // SAFETY: the words live in `self.level`, which is neither changed nor dropped while
        // `self.top` views them: `clear` and the next `open` drop the view first.
        let shared: &'static [u32] = unsafe { &*words };
        let top = InstancedScene::from_built_words(shared, self.bottoms())
            .map_err(|e| bad(format!("internal: the top level was refused: {e}")))?;
        self.top = Some(top);
        Ok(())
    }

    /// Builds the top level of `placements`; returns how many were placed (the rest were not
    /// invertible).
    ///
    /// # Errors
    /// A transform that is not finite or a mesh index out of range (naming the placement), or
    /// the host's refusal ([`TopLevel`]); the top level placed before is then kept.
    fn place(&mut self, placements: &[[u32; PLACEMENT_WORDS]]) -> Result<i32, (i32, String)> {
        let bottoms = self.bottoms();
        let mut list = Vec::new();
        try_reserve(&mut list, placements.len(), "the placements")?;
        for (i, p) in placements.iter().enumerate() {
            let mut w = [0u32; 12];
            w.copy_from_slice(&p[..12]);
            let transform = Affine::from_words(&w);
            if !transform.is_finite() {
                return Err(bad(format!("instance {i}: its transform is not finite")));
            }
            let bottom = p[12];
            if bottom as usize >= bottoms.len() {
                return Err(bad(format!(
                    "instance {i}: mesh {bottom} out of range ({} meshes)",
                    bottoms.len()
                )));
            }
            if transform.inverse().is_none() {
                continue; // flattened to nothing: nothing to hit
            }
            list.push(Placement {
                bottom,
                transform,
                user_id: p[13],
            });
        }
        if list.is_empty() {
            self.clear();
            return Ok(0);
        }
        // A placed top level moves in place (`move_to` refits it, or builds it anew for another
        // count; a refusal leaves its words as they were, opened again); else a first build.
        match self.level.take() {
            Some(mut level) => {
                self.top = None; // the view goes before its words change
                let moved = level.move_to(bottoms, &list);
                self.open(level)?;
                moved.map_err(bad)?;
            }
            None => {
                let level = TopLevel::build(bottoms, &list).map_err(bad)?;
                self.open(level)?;
            }
        }
        Ok(list.len() as i32)
    }
}

impl Drop for Top {
    fn drop(&mut self) {
        self.clear();
        // SAFETY: leaked in `kdj_top_new`; the top level viewing it went in `clear`.
        drop(unsafe { Box::from_raw(self.bottoms) });
    }
}

impl State {
    fn top(&self, handle: u32) -> Result<&Top, (i32, String)> {
        self.tops
            .get((handle as usize).wrapping_sub(1))
            .and_then(Option::as_ref)
            .ok_or((NO_SCENE, "the instanced scene was disposed".to_string()))
    }

    /// [`kdj_top_new`] over the handles.
    fn top_new(&mut self, handles: &[u32]) -> Result<i32, (i32, String)> {
        let mut views = Vec::new();
        try_reserve(&mut views, handles.len(), "the meshes")?;
        for (i, &h) in handles.iter().enumerate() {
            let owned = self
                .scene(h)
                .map_err(|_| bad(format!("mesh {i} was disposed")))?;
            views.push(*owned.scene());
        }
        for &h in handles {
            self.pin(h, true);
        }
        let bottoms: *mut [Scene<'static>] = Box::leak(views.into_boxed_slice());
        let top = Top {
            handles: handles.to_vec(),
            bottoms,
            level: None,
            top: None,
        };
        let slot = match self.tops.iter().position(Option::is_none) {
            Some(i) => i,
            None => {
                self.tops.push(None);
                self.tops.len() - 1
            }
        };
        self.tops[slot] = Some(top);
        Ok(slot as i32 + 1)
    }

    /// [`kdj_top_place`] with the placements.
    fn top_place(
        &mut self,
        top: u32,
        placements: &[[u32; PLACEMENT_WORDS]],
    ) -> Result<i32, (i32, String)> {
        self.top(top)?;
        let t = self.tops[top as usize - 1].as_mut().expect("checked");
        t.place(placements)
    }

    /// [`kdj_top_drop`].
    fn top_drop(&mut self, top: u32) {
        let Some(slot) = self.tops.get_mut((top as usize).wrapping_sub(1)) else {
            return;
        };
        if let Some(t) = slot.take() {
            let handles = t.handles.clone();
            drop(t);
            for h in handles {
                self.pin(h, false);
            }
        }
    }

    /// [`kdj_top_raycast`]: the result's 8 words, or `None` for a miss.
    fn top_raycast(
        &self,
        top: u32,
        watertight: u32,
        o: [f32; 3],
        d: [f32; 3],
        tmin: f32,
        tmax: f32,
    ) -> Result<Option<[u32; 8]>, (i32, String)> {
        let Some(scene) = self.top(top)?.top else {
            return Ok(None);
        };
        let (ray, len) = unit::ray(watertight != 0, o, d, tmin, tmax);
        let hit = scene.intersect_in(mode(watertight), &ray);
        if !hit.is_hit() {
            return Ok(None);
        }
        let n = scene.geometric_normal(&hit, &ray);
        let id = scene.bottom_of(hit.instance).input_id(hit.prim);
        let t = unit::t_back(hit.t, len);
        Ok(Some([
            t.to_bits(),
            id,
            hit.u.to_bits(),
            hit.v.to_bits(),
            hit.user_id,
            n.x.to_bits(),
            n.y.to_bits(),
            n.z.to_bits(),
        ]))
    }

    /// [`kdj_top_occluded`].
    fn top_occluded(
        &self,
        top: u32,
        watertight: u32,
        o: [f32; 3],
        d: [f32; 3],
        tmin: f32,
        tmax: f32,
    ) -> Result<bool, (i32, String)> {
        let Some(scene) = self.top(top)?.top else {
            return Ok(false);
        };
        let (ray, _) = unit::ray(watertight != 0, o, d, tmin, tmax);
        Ok(scene.occluded_in(mode(watertight), &ray))
    }
}

/// A top level over the `n` scenes whose handles are at `handles_ptr` (u32 each), nothing
/// placed yet. Returns its handle (> 0).
#[unsafe(no_mangle)]
pub extern "C" fn kdj_top_new(handles_ptr: u32, n: u32) -> i32 {
    with_state(|s| {
        let handles = if n == 0 {
            &[][..]
        } else {
            s.slice::<u32>(handles_ptr, n)?
        };
        s.top_new(handles)
    })
}

/// Places `n` instances (14 words each at `ptr`, the module doc) in top level `top`, replacing
/// what it held: builds its top level. Returns the number placed.
#[unsafe(no_mangle)]
pub extern "C" fn kdj_top_place(top: u32, ptr: u32, n: u32) -> i32 {
    with_state(|s| {
        let placements = if n == 0 {
            &[][..]
        } else {
            s.slice::<[u32; PLACEMENT_WORDS]>(ptr, n)?
        };
        s.top_place(top, placements)
    })
}

/// Forgets a top level and unpins its bottom scenes (freeing those disposed meanwhile).
#[unsafe(no_mangle)]
pub extern "C" fn kdj_top_drop(top: u32) {
    with_state(|s| {
        s.top_drop(top);
        Ok(0)
    });
}

/// The address of the last [`kdj_top_raycast`] result, 8 words: f32 t, u32 triangle (input
/// order in its mesh), f32 u, f32 v, u32 user id, the world geometric normal (3 f32, not
/// normalized, `e1 × e2` of the triangle as placed: negated under a mirroring transform).
#[unsafe(no_mangle)]
pub extern "C" fn kdj_top_result() -> i32 {
    crate::STATE.with_borrow(|s| s.top_result.as_ptr() as i32)
}

/// The closest hit of one world ray in `(tmin, tmax)` over top level `top`: 1 (written at
/// [`kdj_top_result`]), 0 for a miss.
#[unsafe(no_mangle)]
#[allow(clippy::too_many_arguments)]
pub extern "C" fn kdj_top_raycast(
    top: u32,
    watertight: u32,
    ox: f32,
    oy: f32,
    oz: f32,
    dx: f32,
    dy: f32,
    dz: f32,
    tmin: f32,
    tmax: f32,
) -> i32 {
    with_state(|s| {
        match s.top_raycast(top, watertight, [ox, oy, oz], [dx, dy, dz], tmin, tmax)? {
            Some(r) => {
                s.top_result = r;
                Ok(1)
            }
            None => Ok(0),
        }
    })
}

/// Whether anything lies along the world ray in `(tmin, tmax)`: 1 or 0.
#[unsafe(no_mangle)]
#[allow(clippy::too_many_arguments)]
pub extern "C" fn kdj_top_occluded(
    top: u32,
    watertight: u32,
    ox: f32,
    oy: f32,
    oz: f32,
    dx: f32,
    dy: f32,
    dz: f32,
    tmin: f32,
    tmax: f32,
) -> i32 {
    with_state(|s| {
        let r = s.top_occluded(top, watertight, [ox, oy, oz], [dx, dy, dz], tmin, tmax)?;
        Ok(i32::from(r))
    })
}

/// Closest hits of `n` world rays at `rays_ptr` (8 f32 each: origin, direction, tmin, tmax)
/// over top level `top`, one at a time, into `hits_ptr` (5 words each: f32 t, u32 triangle in
/// its mesh's input order, f32 u, f32 v, u32 user id; a miss is t = +inf and both ids
/// 0xFFFFFFFF). Returns the number of hits.
#[unsafe(no_mangle)]
pub extern "C" fn kdj_top_raycast_many(
    top: u32,
    watertight: u32,
    rays_ptr: u32,
    n: u32,
    hits_ptr: u32,
) -> i32 {
    with_state(|s| {
        let input = s.slice::<[f32; 8]>(rays_ptr, n)?;
        let out = s.slice_mut::<[u32; 5]>(hits_ptr, n)?;
        disjoint(input, out)?;
        s.top(top)?;
        let mut count = 0;
        for (w, h) in input.iter().zip(out.iter_mut()) {
            let (o, d) = ([w[0], w[1], w[2]], [w[3], w[4], w[5]]);
            *h = match s.top_raycast(top, watertight, o, d, w[6], w[7])? {
                Some(r) => {
                    count += 1;
                    [r[0], r[1], r[2], r[3], r[4]]
                }
                None => [f32::INFINITY.to_bits(), u32::MAX, 0, 0, u32::MAX],
            };
        }
        Ok(count)
    })
}

/// Writes 9 words about top level `top` at `out_ptr`: instances placed, nodes, depth, then the
/// world bounds (6 f32 bits; +inf, -inf while nothing is placed). Returns 0.
#[unsafe(no_mangle)]
pub extern "C" fn kdj_top_info(top: u32, out_ptr: u32) -> i32 {
    with_state(|s| {
        let out = s.slice_mut::<u32>(out_ptr, 9)?;
        let (n, nodes, depth, [lo, hi]) = match s.top(top)?.top {
            Some(t) => (t.instance_count(), t.node_count(), t.depth(), t.bounds()),
            None => (0, 0, 0, [Vec3::INFINITY, Vec3::NEG_INFINITY]),
        };
        out.copy_from_slice(&[
            n,
            nodes,
            depth,
            lo.x.to_bits(),
            lo.y.to_bits(),
            lo.z.to_bits(),
            hi.x.to_bits(),
            hi.y.to_bits(),
            hi.z.to_bits(),
        ]);
        Ok(0)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use kdray::build::Quality;
    use kdray::flat::{Layout, Leaves};

    fn square(s: &mut State) -> u32 {
        let pos = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
        let tris = crate::mesh::triangles(&pos, None).unwrap();
        let words =
            crate::mesh::build_words(tris, Layout::Wide, Leaves::List, Quality::Fast).unwrap();
        s.add(words, true).unwrap() as u32
    }

    fn placement(m: [f32; 12], bottom: u32, id: u32) -> [u32; PLACEMENT_WORDS] {
        let mut o = [0u32; PLACEMENT_WORDS];
        o[..12].copy_from_slice(&m.map(f32::to_bits));
        o[12] = bottom;
        o[13] = id;
        o
    }

    const ID: [f32; 12] = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0];
    const INF: f32 = f32::INFINITY;

    #[test]
    fn copies_singular_ones_left_out_and_a_pinned_bottom() {
        let mut s = State::default();
        let mesh = square(&mut s);
        let top = s.top_new(&[mesh]).unwrap() as u32;
        let mut moved = ID;
        moved[11] = -2.0; // 2 below
        let list = [
            placement(ID, 0, 7),
            placement(moved, 0, 9),
            placement([0.0; 12], 0, 11),
        ];
        assert_eq!(
            s.top_place(top, &list).unwrap(),
            2,
            "the singular one is left out"
        );
        // From above the copy at z = 0 first, from below the one at z = -2; a direction of
        // length 2 gives t in its lengths.
        let r = s.top_raycast(top, 0, [0.25, 0.25, 5.0], [0.0, 0.0, -1.0], 0.0, INF);
        let r = r.unwrap().unwrap();
        assert_eq!((f32::from_bits(r[0]), r[1], r[4]), (5.0, 0, 7));
        assert!(f32::from_bits(r[7]) > 0.0, "e1 x e2 of the square is +z");
        let r = s.top_raycast(top, 0, [0.25, 0.25, -5.0], [0.0, 0.0, 2.0], 0.0, INF);
        let r = r.unwrap().unwrap();
        assert_eq!((f32::from_bits(r[0]), r[4]), (1.5, 9));
        assert_eq!(
            s.top_raycast(top, 1, [2.0, 2.0, 5.0], [0.0, 0.0, -1.0], 0.0, INF),
            Ok(None)
        );
        // Disposing the mesh while the top level holds it: the top level still answers, a new
        // one cannot take it, and it is freed with the top level.
        s.drop_scene(mesh);
        assert_eq!(
            s.top_occluded(top, 0, [0.25, 0.25, 5.0], [0.0, 0.0, -1.0], 0.0, INF),
            Ok(true)
        );
        let e = s.top_new(&[mesh]).unwrap_err();
        assert!(e.1.contains("mesh 0 was disposed"), "{}", e.1);
        s.top_drop(top);
        assert!(s.scenes.iter().all(Option::is_none));
        assert!(s.top(top).is_err());
    }

    #[test]
    fn bad_placements_are_refused_by_number() {
        let mut s = State::default();
        let mesh = square(&mut s);
        let top = s.top_new(&[mesh]).unwrap() as u32;
        assert_eq!(s.top_place(top, &[placement(ID, 0, 3)]).unwrap(), 1);
        let mut nan = ID;
        nan[3] = f32::NAN;
        let e = s
            .top_place(top, &[placement(ID, 0, 1), placement(nan, 0, 2)])
            .unwrap_err();
        assert!(
            e.1.contains("instance 1") && e.1.contains("not finite"),
            "{}",
            e.1
        );
        let e = s.top_place(top, &[placement(ID, 1, 1)]).unwrap_err();
        assert!(e.1.contains("mesh 1 out of range"), "{}", e.1);
        // A refusal keeps what was placed.
        let r = s.top_raycast(top, 0, [0.25, 0.25, 5.0], [0.0, 0.0, -1.0], 0.0, INF);
        assert_eq!(r.unwrap().unwrap()[4], 3);
        // Nothing placed: every ray misses.
        assert_eq!(s.top_place(top, &[]).unwrap(), 0);
        assert_eq!(
            s.top_raycast(top, 0, [0.25, 0.25, 5.0], [0.0, 0.0, -1.0], 0.0, INF),
            Ok(None)
        );
    }
}
