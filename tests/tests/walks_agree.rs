//! One ray's answer is a function of the ray and the tree alone (issue 39, item 4): every walk
//! ([`kdray_tests::walks`]: wide nodes, binary nodes, 4- and 8-wide packets of consecutive rays,
//! the stream), with index lists and with triangle groups, gives the same `t`, bit for bit, on
//! rays aimed at the seams of a closed icosphere — the rays where walks part if any do — in fast
//! and in watertight mode, at the origin and moved to 10⁶. The primitive may differ only in a
//! tie: then the kernel gives the other walk's primitive exactly the same `t` for that ray.
//!
//! Before issue 39, fast mode's binary-node walk (packets, and the Python package's camera
//! tiles) took plain split-plane distances while the wide walk's boxes were conservative, and on
//! these rays the two differed on 34 distances and 49 triangles: a ray's answer depended on
//! whether its neighbours in a batch made it a packet.

use glam::Vec3;
use kdray_core::traverse::{Mode, Triangles, Watertight};
use kdray_core::{Hit, Ray, Scene};
use kdray_tests::closed::{Aim, Mesh, icosphere};
use kdray_tests::walks::{WALKS, trace_all, wide_words};

/// Whether `scene`'s kernel in `mode` hits `ray` with `prim` at exactly `t`.
fn hits_at(scene: &Scene, mode: Mode, ray: &Ray, prim: u32, t: f32) -> bool {
    let got = match mode {
        Mode::Fast => scene.intersect_prim::<Triangles>(prim, ray),
        Mode::Watertight => scene.intersect_prim::<Watertight<Triangles>>(prim, ray),
    };
    got.is_some_and(|h| h.0 == t)
}

/// Compares every walk of `mesh` (both layouts) with the wide walk over index lists, ray by ray;
/// returns (rays, ties: rays whose primitive differs between walks at the same `t`).
fn compare(name: &str, mesh: &Mesh, rays: &[Ray], mode: Mode) -> (usize, usize) {
    let lists = wide_words(mesh.triangles(), false);
    let groups = wide_words(mesh.triangles(), true);
    let scenes = [&lists, &groups].map(|w| Scene::from_words(w).expect("valid scene"));
    let reference: Vec<Hit> = trace_all(&scenes[0], rays, mode)[0].clone();
    let mut tied = vec![false; rays.len()];
    for (layout, scene) in ["lists", "groups"].iter().zip(&scenes) {
        for (walk, hits) in WALKS.iter().zip(trace_all(scene, rays, mode)) {
            for (i, (got, want)) in hits.iter().zip(&reference).enumerate() {
                let ray = &rays[i];
                assert_eq!(
                    got.t.to_bits(),
                    want.t.to_bits(),
                    "{name}, {mode:?}, {walk} over {layout}: ray {i} {ray:?}: {got:?}, wide \
                     walk over lists {want:?}"
                );
                // Storage order differs between the layouts: compare input ids.
                if scene.input_id(got.prim) != scenes[0].input_id(want.prim) {
                    assert!(
                        hits_at(scene, mode, ray, got.prim, got.t)
                            && hits_at(&scenes[0], mode, ray, want.prim, want.t),
                        "{name}, {mode:?}, {walk} over {layout}: ray {i} {ray:?}: triangle {} \
                         against {}, not a tie",
                        scene.input_id(got.prim),
                        scenes[0].input_id(want.prim)
                    );
                    tied[i] = true;
                }
            }
        }
    }
    (rays.len(), tied.iter().filter(|&&t| t).count())
}

/// The unit icosphere (5,120 triangles) at the origin and moved to (10⁶, 10⁶, 10⁶), rays from
/// its centre and from a point off it to every vertex and edge point (33,282 each), exact and
/// normalized. Expectation: in both modes every walk gives every ray the same `t` bits, and a
/// different primitive only in a tie (their number is printed: `-- --nocapture`).
#[test]
fn every_walk_gives_a_seam_ray_the_same_answer() {
    for (name, mesh) in [
        ("icosphere", icosphere(4)),
        (
            "icosphere at 1e6",
            icosphere(4).transformed(1.0, Vec3::splat(1.0e6)),
        ),
    ] {
        let off = mesh.centre + Vec3::new(0.21, -0.33, 0.17);
        let mut rays = mesh.seam_rays(mesh.centre, Aim::Exact);
        rays.extend(mesh.seam_rays(mesh.centre, Aim::Normalized));
        rays.extend(mesh.seam_rays(off, Aim::Normalized));
        for mode in [Mode::Fast, Mode::Watertight] {
            let (n, ties) = compare(name, &mesh, &rays, mode);
            println!("{name}, {mode:?}: {n} rays, the same t in every walk; {ties} ties");
        }
    }
}
