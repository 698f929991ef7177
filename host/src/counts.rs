//! What a closest-hit walk does per ray, counted (`kdray trace --counts`): interior steps, leaf
//! visits, triangle groups and single primitive tests. The count runs the core's own single-ray
//! walk over the node section ([`kdray_core::traverse::steps::Stepper`]), one step at a time, with
//! a query that counts each leaf's work and hands it on to [`Closest`], so the walk counted is the
//! walk traced. A scene with wide nodes is counted on its wide walk
//! ([`kdray_core::traverse::wide::walk::walk_counted`]): its steps are wide nodes.

use kdray_core::format::LeafPrims;
use kdray_core::traverse::steps::{Closest, Progress, Query, Stepper};
use kdray_core::traverse::wide::walk::{WalkCounts, walk_counted};
use kdray_core::traverse::{Contents, Mixed, Spheres, Triangles};
use kdray_core::{Ray, Scene};

/// Totals over a set of rays.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Counts {
    pub rays: u64,
    /// Walk steps at interior nodes (including steps that only pop a pending node).
    pub interior: u64,
    /// Leaves whose primitives were tested.
    pub leaves: u64,
    /// Groups of four triangles tested ([`kdray_core::group`]).
    pub groups: u64,
    /// Primitives tested one at a time.
    pub singles: u64,
}

impl Counts {
    /// `name=value` pairs per ray, for the trace line.
    pub fn per_ray(&self) -> String {
        let per = |x: u64| x as f64 / self.rays.max(1) as f64;
        format!(
            "steps_per_ray={:.2} leaves_per_ray={:.2} groups_per_ray={:.2} single_tests_per_ray={:.2}",
            per(self.interior),
            per(self.leaves),
            per(self.groups),
            per(self.singles)
        )
    }
}

/// [`Closest`] with a count of what its leaves test.
struct Counting<'c> {
    inner: Closest,
    counts: &'c mut Counts,
}

impl Query for Counting<'_> {
    fn leaf<C: Contents>(&mut self, scene: &Scene, prims: LeafPrims) -> (f32, bool) {
        self.counts.leaves += 1;
        match prims {
            LeafPrims::Groups(g) => self.counts.groups += g.len() as u64,
            other => self.counts.singles += other.listed().len() as u64,
        }
        self.inner.leaf::<C>(scene, prims)
    }
}

/// Counts the fast-mode closest-hit walks of `rays` over `scene`'s nodes.
pub fn count(scene: &Scene, rays: &[Ray]) -> Counts {
    use kdray_core::format::contents as bits;
    let c = scene.contents();
    match (c & bits::TRIANGLES != 0, c & bits::SPHERES != 0) {
        (true, false) => count_with::<Triangles>(scene, rays),
        (false, true) => count_with::<Spheres>(scene, rays),
        _ => count_with::<Mixed>(scene, rays),
    }
}

fn count_with<C: Contents>(scene: &Scene, rays: &[Ray]) -> Counts {
    let mut counts = Counts {
        rays: rays.len() as u64,
        ..Counts::default()
    };
    if !scene.wide_nodes().is_empty() {
        for ray in rays {
            let mut walk = WalkCounts::default();
            let mut q = Counting {
                inner: Closest::new::<C>(ray),
                counts: &mut counts,
            };
            walk_counted::<C, _>(scene, scene.wide_nodes(), ray, &mut q, &mut walk);
            counts.interior += u64::from(walk.nodes);
        }
        return counts;
    }
    let mut state = <Scene as Stepper>::empty_state();
    for ray in rays {
        if !scene.begin::<C>(ray, &mut state) {
            continue;
        }
        let mut steps = 0u64;
        let leaves_before = counts.leaves;
        let mut q = Counting {
            inner: Closest::new::<C>(ray),
            counts: &mut counts,
        };
        while scene.step::<C, _>(&mut state, &mut q) != Progress::Done {
            steps += 1;
        }
        steps += 1; // the step that ended the walk
        counts.interior += steps - (counts.leaves - leaves_before);
    }
    counts
}
