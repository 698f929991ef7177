//! The `traversal` target (`fuzz_targets/traversal.rs`), kept here so that a finding replays as a
//! plain test (`fuzz/tests/findings.rs`): the fixed scene, the decoding of input bytes into rays,
//! and the checks, [`check`].

use glam::Vec3;
use kdray::Geometry;
use kdray::build::{BuildParams, build};
use kdray::flat::{Layout, Leaves, serialize_as};
use kdray_core::simd::{RayPacket, f32x8};
use kdray_core::traverse::Mode;
use kdray_core::{Hit, Ray, Scene};
use std::sync::OnceLock;

/// The words of the target's scene: a closed box of 12 triangles over `[-2, 2]³`, a fan of six
/// triangles sharing edges and vertices in the plane `z = 0.5`, and two spheres, all with
/// coordinates on a grid of 1/2. Built once.
pub fn scene_words() -> &'static [u32] {
    static WORDS: OnceLock<Vec<u32>> = OnceLock::new();
    WORDS.get_or_init(|| crate::build_and_validate("traversal scene", &geometry()))
}

fn geometry() -> Geometry {
    let v = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    let side = |bit: bool| if bit { 2.0 } else { -2.0 };
    let c: Vec<Vec3> = (0..8)
        .map(|i| v(side(i & 1 != 0), side(i & 2 != 0), side(i & 4 != 0)))
        .collect();
    let quads = [
        [0, 1, 3, 2],
        [4, 6, 7, 5],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 2, 6, 4],
        [1, 5, 7, 3],
    ];
    let mut triangles = Vec::new();
    for q in quads {
        triangles.push([c[q[0]], c[q[1]], c[q[2]]]);
        triangles.push([c[q[0]], c[q[2]], c[q[3]]]);
    }
    // A fan in the plane z = 0.5 around (0.5, 0, 0.5), inside the box.
    let centre = v(0.5, 0.0, 0.5);
    let rim = [
        v(1.5, 0.0, 0.5),
        v(1.0, 1.0, 0.5),
        v(-0.5, 1.0, 0.5),
        v(-0.5, -1.0, 0.5),
        v(0.5, -1.5, 0.5),
        v(1.5, -1.0, 0.5),
    ];
    for k in 0..6 {
        triangles.push([centre, rim[k], rim[(k + 1) % 6]]);
    }
    Geometry {
        triangles,
        spheres: vec![(v(-1.0, -1.0, -1.0), 0.5), (v(1.0, 1.0, -1.0), 1.0)],
        ..Geometry::default()
    }
}

/// The rays of an input: each 8 bytes give one ray (a trailing partial chunk is ignored), at
/// most 64. Byte by byte: an origin on a grid of 1/8 in `[-16, 16)` (bytes 0–2 as `i8 / 8`); a
/// direction with integer components in `[-8, 8]` and `-0.0` (bytes 3–5 mod 18, 17 being `-0.0`),
/// normalized when bit 0 of byte 6 is set; the band `(tmin, tmax)` from byte 7 mod 4: `(0, ∞)`,
/// `(1e-3, 8)`, `((byte 6 >> 2) / 4, ∞)` or `(-4, 4)`; and with bit 7 of byte 6 set and byte 7 =
/// `0xff`, an origin `x` of NaN, `+∞` or `-∞`. Snapping to these grids makes rays through
/// vertices, along edges and in split planes common instead of measure-zero.
pub fn rays(data: &[u8]) -> Vec<Ray> {
    data.chunks_exact(8).take(64).map(ray_of).collect()
}

fn ray_of(b: &[u8]) -> Ray {
    let o = |k: usize| f32::from(b[k] as i8) / 8.0;
    let d = |k: usize| match b[k] % 18 {
        17 => -0.0,
        n => f32::from(n) - 8.0,
    };
    let mut dir = Vec3::new(d(3), d(4), d(5));
    if b[6] & 1 == 1 {
        dir = dir.normalize_or_zero();
    }
    let mut origin = Vec3::new(o(0), o(1), o(2));
    if b[6] & 0x80 != 0 && b[7] == 0xff {
        origin.x = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY][usize::from(b[6] >> 1 & 3) % 3];
    }
    let (tmin, tmax) = match b[7] % 4 {
        0 => (0.0, f32::INFINITY),
        1 => (1e-3, 8.0),
        2 => (f32::from(b[6] >> 2) / 4.0, f32::INFINITY),
        _ => (-4.0, 4.0),
    };
    Ray::new(origin, dir).with_range(tmin, tmax)
}

/// The target's body: decodes `data` into [`rays`] and runs the checks on the fixed scene,
/// [`crate::packets_agree_with_scalar`], [`crate::stream_agrees_with_scalar`] and
/// [`fast_and_watertight_agree`]. Panics on a failure.
pub fn check(data: &[u8]) {
    let scene = Scene::from_words(scene_words()).expect("the fixed scene validates");
    let rays = rays(data);
    let scalar = crate::packets_agree_with_scalar(&scene, &rays);
    crate::stream_agrees_with_scalar(&scene, &rays, &scalar);
    fast_and_watertight_agree(&scene, &rays);
    groups_agree_with_list(&rays);
}

/// The scene's triangles alone, one tree priced in groups, stored with an index list and with
/// triangle groups (format v9). Built once.
fn grouped_pair() -> &'static [Vec<u32>; 2] {
    static WORDS: OnceLock<[Vec<u32>; 2]> = OnceLock::new();
    WORDS.get_or_init(|| {
        let geom = Geometry {
            spheres: Vec::new(),
            ..geometry()
        };
        let params = BuildParams {
            parallel: false,
            ..BuildParams::grouped()
        };
        let tree = build(&geom, &params, None).expect("the fixed triangles build");
        [Leaves::List, Leaves::Groups].map(|leaves| {
            serialize_as(&tree, &geom, 0.0, Layout::Nodes, leaves).expect("small trees fit")
        })
    })
}

/// Groups change how leaves are stored, not what is hit: the single-ray walk (its group kernels)
/// and the packets (which read the groups' lanes) return the index list's hits bit for bit, ties
/// included, closest and any hit, fast and watertight.
pub fn groups_agree_with_list(rays: &[Ray]) {
    let [list, grouped] = grouped_pair();
    let list = Scene::from_words(list).expect("validates");
    let grouped = Scene::from_words(grouped).expect("validates");
    assert!(grouped.has_groups());
    let bits = |h: Hit| [h.t.to_bits(), h.prim, h.u.to_bits(), h.v.to_bits()];
    for mode in [Mode::Fast, Mode::Watertight] {
        for ray in rays {
            let want = bits(list.intersect_in(mode, ray));
            assert_eq!(
                bits(grouped.intersect_in(mode, ray)),
                want,
                "{mode:?} {ray:?}"
            );
            assert_eq!(
                grouped.occluded_in(mode, ray),
                list.occluded_in(mode, ray),
                "{mode:?} {ray:?}"
            );
        }
        for chunk in rays.chunks(8) {
            let packet = RayPacket::<f32x8>::from_rays(chunk);
            let (mut a, mut b) = (vec![Hit::MISS; chunk.len()], vec![Hit::MISS; chunk.len()]);
            list.intersect_packet_in(mode, &packet)
                .write_active(&packet, &mut a);
            grouped
                .intersect_packet_in(mode, &packet)
                .write_active(&packet, &mut b);
            let key = |v: &[Hit]| v.iter().map(|h| bits(*h)).collect::<Vec<_>>();
            assert_eq!(key(&a), key(&b), "{mode:?} packet {chunk:?}");
        }
    }
}

/// Smallest barycentric of a "clear" triangle hit: farther than this from every edge.
pub const CLEAR_BARY: f32 = 1e-3;
/// Smallest `|cos|` between the ray and a "clear" triangle's normal: not grazing.
pub const CLEAR_COS: f32 = 1e-2;
/// Largest difference of the two modes' `t` on a clear hit, relative to the primitive's scale
/// along the ray (`L/|d|`, see [`clear_scale`]); also the margin, in the same unit, by which a
/// clear hit keeps off `tmin` and `tmax`.
pub const AGREE_T: f32 = 1e-4;

/// `L/|d|` when `hit` (of `ray` in `scene`) is clear, i.e. both modes must find it and agree on
/// its `t` to `AGREE_T · L/|d|`; `None` when it is not. `L` is the farthest distance from the
/// origin to the primitive (a vertex; `|c − o| + r` for a sphere). Clear means:
///
/// - a triangle hit farther than [`CLEAR_BARY`] (smallest barycentric) from every edge, and not
///   grazing (`|cos|` between the ray and the normal at least [`CLEAR_COS`]); a sphere hit is
///   never near an edge, and both modes use the same sphere kernel;
/// - and, for both kinds, `t` at least `AGREE_T · L/|d|` from `tmin` and from `tmax`.
///
/// Why `L/|d|` and not `t`: the two kernels round `t` differently (Möller–Trumbore divides
/// `e2·q` by `det`; the watertight kernel shears the vertices relative to the origin first,
/// Woop et al. 2013 §3.6), and the error of either is a few ULPs of the numbers it is computed
/// from, i.e. of `L/|d|` (PBR 3rd ed. §3.9), not of `t` itself: `t` can be 0 (an origin on the
/// triangle) while `L` is not. A hit always has `|t| ≤ L/|d|` (the hit point lies in the
/// primitive's convex hull), so this is never tighter than `AGREE_T` relative to `t`. For the
/// clear triangles of this scene (`|cos| ≥ 1e-2`, no needles) the bound on either error is far
/// below `AGREE_T · L/|d|`.
///
/// Why the margin at `tmin` and `tmax`: a hit whose exact `t` is within rounding of an end of
/// the range is a tie that each mode may break its own way. The first finding
/// (`fuzz/seeds/traversal/regression-origin-on-face`) is a ray starting on a box face, exact
/// `t = 0 = tmin`: Möller–Trumbore computes `t = 0` exactly and rejects it (`t > tmin` fails),
/// the watertight kernel computes 8.7e-9 and accepts it. Neither is wrong within its rounding
/// (1.7e-8 · L/|d| there), and neither mode promises exact `t`; spawned rays keep off their
/// surface by an error bound (`kdray_core::spawn`), not by `tmin`.
pub fn clear_scale(scene: &Scene, ray: &Ray, hit: &Hit) -> Option<f32> {
    let d = ray.dir.length();
    let (shape_clear, reach) = if hit.prim >= scene.tri_count() {
        let s = scene.sphere(hit.prim - scene.tri_count());
        (true, (s.center - ray.origin).length() + s.radius)
    } else {
        let verts = scene.vertices(hit.prim);
        let [a, b, c] = verts;
        let n = (b - a).cross(c - a);
        let cos = ray.dir.dot(n).abs() / (d * n.length());
        let bary = hit.u.min(hit.v).min(1.0 - hit.u - hit.v);
        let reach = verts
            .iter()
            .map(|v| (*v - ray.origin).length())
            .fold(0.0, f32::max);
        (bary >= CLEAR_BARY && cos >= CLEAR_COS, reach)
    };
    let scale = reach / d;
    let margin = AGREE_T * scale;
    let clear = shape_clear && hit.t - ray.tmin >= margin && ray.tmax - hit.t >= margin;
    clear.then_some(scale)
}

/// Panics unless fast and watertight mode agree on each finite ray of `rays` whose nearer hit
/// (in either mode) is clear ([`clear_scale`]): both hit, at `t` within `AGREE_T · L/|d|`.
/// Near an edge, grazing, or at the ends of the ray's range they may differ (the first two are
/// what watertight mode is for), so such rays are skipped, as are rays that both modes miss.
pub fn fast_and_watertight_agree(scene: &Scene, rays: &[Ray]) {
    for ray in rays.iter().filter(|r| r.is_finite()) {
        let fast = scene.intersect_in(Mode::Fast, ray);
        let tight = scene.intersect_in(Mode::Watertight, ray);
        let nearer = if fast.t <= tight.t { &fast } else { &tight };
        let Some(scale) = nearer
            .is_hit()
            .then(|| clear_scale(scene, ray, nearer))
            .flatten()
        else {
            continue;
        };
        assert!(
            fast.is_hit() && tight.is_hit(),
            "one mode misses a clear hit: fast {fast:?}, watertight {tight:?}, {ray:?}"
        );
        assert!(
            (fast.t - tight.t).abs() <= AGREE_T * scale,
            "the modes' t differ on a clear hit: fast {fast:?}, watertight {tight:?}, {ray:?}"
        );
    }
}
