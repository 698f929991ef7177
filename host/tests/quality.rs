//! Both build qualities (`high`: the exact event sweep; `fast`: binned planes, the exact sweep on
//! small nodes) on the repository's meshes and on the binning's edge
//! cases: every tree validates and hits what brute force over all triangles hits, and a build
//! gives the same tree whatever the number of threads.

use glam::Vec3;
use kdray::build::fast::FastParams;
use kdray::build::{BuildNode, BuildParams, Quality, build};
use kdray::flat::serialize;
use kdray::geometry::Geometry;
use kdray::input::load_input;
use kdray_core::traverse::{Mixed, Mode, Watertight};
use kdray_core::{Hit, Ray, Scene};
use std::path::Path;

mod meshes;
use meshes::uv_sphere;

/// `fast` with every node binned (and never clipped exactly), so that the small test scenes go
/// through the binned search at every level.
fn binned_everywhere(bins: usize) -> BuildParams {
    BuildParams {
        fast: FastParams {
            bins,
            bin_min: 0,
            clip_min: usize::MAX,
        },
        ..BuildParams::default().with_quality(Quality::Fast)
    }
}

/// The parameter sets every scene is built with.
fn variants() -> Vec<(&'static str, BuildParams)> {
    let serial = |p: BuildParams| BuildParams {
        parallel: false,
        ..p
    };
    vec![
        ("high", serial(BuildParams::default())),
        (
            "fast",
            serial(BuildParams::default().with_quality(Quality::Fast)),
        ),
        (
            "fast, perfect splits everywhere",
            serial(BuildParams {
                fast: FastParams {
                    clip_min: 0,
                    ..FastParams::default()
                },
                ..BuildParams::default().with_quality(Quality::Fast)
            }),
        ),
        ("fast, 32 bins at every node", serial(binned_everywhere(32))),
        ("fast, 3 bins at every node", serial(binned_everywhere(3))),
        (
            "fast groups",
            serial(BuildParams::grouped().with_quality(Quality::Fast)),
        ),
    ]
}

/// A deterministic generator (SplitMix64) for rays.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// Rays from points around the scene's box towards points inside it, some axis-parallel.
fn rays(geom: &Geometry, count: usize) -> Vec<Ray> {
    let (lo, hi) = geom
        .triangles
        .iter()
        .flatten()
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(*v), hi.max(*v))
        });
    // A flat scene gets some thickness, so that the rays cross its plane at an angle.
    let d = (hi - lo).max(Vec3::splat((hi - lo).max_element() * 1e-3));
    let c = (lo + hi) * 0.5;
    let mut rng = Rng(7);
    let mut point = |spread: f32| {
        c + d * spread * Vec3::new(rng.next() - 0.5, rng.next() - 0.5, rng.next() - 0.5)
    };
    (0..count)
        .filter_map(|i| {
            let (o, t) = (point(2.0), point(1.0));
            let mut dir = t - o;
            if i % 5 == 0 {
                // Axis-parallel: along the largest component only.
                let a = dir.abs().max_position();
                let mut along = Vec3::ZERO;
                along[a] = dir[a];
                dir = along;
            }
            Some(Ray::new(o, dir.try_normalize()?))
        })
        .collect()
}

/// The closest hit over every primitive with the walk's kernels.
fn brute_force(scene: &Scene, ray: &Ray) -> Hit {
    let mut best = Hit::MISS;
    for prim in 0..scene.prim_count() {
        if let Some((t, u, v)) = scene.intersect_prim::<Watertight<Mixed>>(prim, ray)
            && t < best.t
        {
            best = Hit { t, prim, u, v };
        }
    }
    best
}

/// Builds `geom` with `params`, validates the words and checks the walk against brute force.
fn check(name: &str, variant: &str, geom: &Geometry, params: &BuildParams, ray_count: usize) {
    let tree = build(geom, params, None).unwrap_or_else(|e| panic!("{name}, {variant}: {e}"));
    let words = serialize(&tree, geom, 0.0).unwrap();
    let scene = Scene::from_words(&words)
        .unwrap_or_else(|e| panic!("{name}, {variant}: the tree does not validate: {e}"));
    for ray in rays(geom, ray_count) {
        let expect = brute_force(&scene, &ray);
        let got = scene.intersect_in(Mode::Watertight, &ray);
        assert!(
            got.t == expect.t,
            "{name}, {variant}: ray {ray:?} hit {got:?}, brute force {expect:?}"
        );
    }
}

fn geometry(triangles: Vec<[Vec3; 3]>) -> Geometry {
    Geometry {
        triangles,
        ..Geometry::default()
    }
}

fn mesh(file: &str) -> Geometry {
    load_input(&Path::new(env!("CARGO_MANIFEST_DIR")).join(file), &[]).unwrap()
}

#[test]
fn every_quality_builds_the_meshes_into_trees_that_hit_as_brute_force() {
    let meshes = [
        ("bunny", mesh("scenes/meshes/bunny.ply.gz")),
        ("tiles", mesh("scenes/meshes/tiles-dark.obj")),
        ("sphere", geometry(uv_sphere(24, Vec3::ZERO, 1.0))),
    ];
    for (name, geom) in &meshes {
        for (variant, params) in variants() {
            check(name, variant, geom, &params, 300);
        }
    }
}

#[test]
fn fast_without_binning_and_with_perfect_splits_is_the_high_tree() {
    // The two builders share the SAH and the rules; only the search and the clipping differ
    // (and `fast`'s reference budget and depth rule, set by `with_quality`, left out here).
    let geom = mesh("scenes/meshes/bunny.ply.gz");
    let high = BuildParams {
        parallel: false,
        ..BuildParams::default()
    };
    let exact_fast = BuildParams {
        fast: FastParams {
            bin_min: usize::MAX,
            clip_min: 0,
            ..FastParams::default()
        },
        // `with_quality(Fast)` also sets its budget and drops the deep levels: put back `high`'s.
        quality: Quality::Fast,
        ..high
    };
    // The event builder lists a leaf's straddlers last, the fast one in its parent's order.
    fn sorted(node: BuildNode) -> BuildNode {
        match node {
            BuildNode::Leaf(mut ids) => {
                ids.sort_unstable();
                BuildNode::Leaf(ids)
            }
            BuildNode::Interior {
                axis,
                split,
                children,
            } => {
                let [b, a] = *children;
                BuildNode::Interior {
                    axis,
                    split,
                    children: Box::new([sorted(b), sorted(a)]),
                }
            }
        }
    }
    let tree = |p: &BuildParams| sorted(build(&geom, p, None).unwrap().into_root());
    assert!(tree(&high) == tree(&exact_fast));
}

/// Scenes that put the binning at its edges.
fn edge_cases() -> Vec<(&'static str, Geometry)> {
    let tri = |o: Vec3, s: f32| [o, o + Vec3::new(s, 0.0, 0.0), o + Vec3::new(0.0, s, s)];
    // Everything in one bin: a tight cluster and one far triangle that stretches the box.
    let mut cluster: Vec<_> = (0..200)
        .map(|i| tri(Vec3::new(i as f32 * 1e-4, 0.0, 0.0), 1e-4))
        .collect();
    cluster.push(tri(Vec3::splat(100.0), 1.0));
    // Flat: every triangle in the plane z = 0, so the nodes have no depth.
    let flat: Vec<_> = (0..300)
        .map(|i| {
            let o = Vec3::new((i % 20) as f32, (i / 20) as f32, 0.0);
            [o, o + Vec3::X, o + Vec3::Y]
        })
        .collect();
    // Planar triangles (flat on x) exactly on the borders of 32 and of 3 bins over [0, 96], and
    // one spanning the box.
    let mut on_borders: Vec<_> = (0..=96)
        .map(|i| {
            let x = i as f32;
            [
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x, 1.0, 0.0),
                Vec3::new(x, 0.0, 1.0),
            ]
        })
        .collect();
    on_borders.push([
        Vec3::ZERO,
        Vec3::new(96.0, 1.0, 0.0),
        Vec3::new(96.0, 0.0, 1.0),
    ]);
    // Coincident triangles: no plane separates them.
    let coincident = vec![tri(Vec3::ZERO, 1.0); 64];
    let scaled = |s: f32| -> Vec<[Vec3; 3]> {
        uv_sphere(12, Vec3::splat(3.0 * s), s)
            .into_iter()
            .chain(uv_sphere(12, Vec3::ZERO, s))
            .collect()
    };
    vec![
        ("all in one bin", geometry(cluster)),
        ("flat", geometry(flat)),
        ("planar on bin borders", geometry(on_borders)),
        ("coincident", geometry(coincident)),
        ("huge coordinates", geometry(scaled(1e11))),
        ("tiny coordinates", geometry(scaled(1e-18))),
        ("huge offset", {
            let mut t = uv_sphere(12, Vec3::splat(3e7), 1.0);
            t.extend(uv_sphere(12, Vec3::splat(-3e7), 1.0));
            geometry(t)
        }),
    ]
}

#[test]
fn binning_edge_cases_build_trees_that_hit_as_brute_force() {
    for (name, geom) in &edge_cases() {
        for (variant, params) in variants() {
            check(name, variant, geom, &params, 400);
        }
    }
}

/// The tree of `geom` built on a rayon pool of `threads` threads.
fn build_on(threads: usize, geom: &Geometry, params: &BuildParams) -> BuildNode {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| build(geom, params, None).unwrap().into_root())
}

#[test]
fn a_build_is_the_same_tree_whatever_the_thread_count() {
    // 72,200 triangles: enough for the fast builder's parallel binning (64 K references) and for
    // subtrees built in parallel.
    let big = geometry(uv_sphere(190, Vec3::ZERO, 1.0));
    let bunny = mesh("scenes/meshes/bunny.ply.gz");
    let cases = [
        ("bunny", &bunny, BuildParams::default()),
        (
            "bunny",
            &bunny,
            BuildParams::default().with_quality(Quality::Fast),
        ),
        (
            "sphere",
            &big,
            BuildParams::default().with_quality(Quality::Fast),
        ),
    ];
    for (name, geom, params) in cases {
        let serial = build(
            geom,
            &BuildParams {
                parallel: false,
                ..params
            },
            None,
        )
        .unwrap()
        .into_root();
        for threads in [1, 2, 3, 8] {
            assert!(
                build_on(threads, geom, &params) == serial,
                "{name}, {:?}: {threads} threads built another tree than one",
                params.quality
            );
        }
    }
}
