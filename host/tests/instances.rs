//! Scene files with `[[instance]]` entries (docs/SCENE.md, "Instances"): the two-level scene
//! that `kdray render` and `kdray trace` build from them against the same copies placed by
//! `[[mesh]]` transforms in one tree, where the transforms are exact translations (so every
//! moved coordinate is exact and the two must find the same hits); materials per mesh entry;
//! errors that name the file and the entry.

mod common;

use common::{Scratch, dir, kdray, s};
use glam::Vec3;
use kdray::build::{BuildParams, build};
use kdray::instances::top_level;
use kdray::scene::SceneFile;
use kdray_core::instance::InstancedScene;
use kdray_core::render::{self, Bounces, Frame, InstanceLight, InstancedFrame, SampleSums};
use kdray_core::traverse::Mode;
use kdray_core::{Hit, Ray, Scene};
use std::path::{Path, PathBuf};

/// A closed octahedron of radius 1/2 around the origin, every coordinate a small dyadic number.
const OCTAHEDRON: &str = "v 0.5 0 0\nv -0.5 0 0\nv 0 0.5 0\nv 0 -0.5 0\nv 0 0 0.5\nv 0 0 -0.5\n\
f 1 3 5\nf 3 2 5\nf 2 4 5\nf 4 1 5\nf 3 1 6\nf 2 3 6\nf 4 2 6\nf 1 4 6\n";
const TRIS: usize = 8;

const HEAD: &str = "[camera]\nkind = \"pinhole\"\neye = [0.25, 6, 9]\ntarget = [0.125, 0, 0]\n\
vfov = 50\n\n[render]\nwidth = 24\nheight = 16\nspp = 8\nmax_depth = 4\nbackground = [0.2, 0.2, 0.2]\n\n\
[[material]]\nname = \"white\"\nkind = \"diffuse\"\n\n\
[[material]]\nname = \"red\"\nkind = \"diffuse\"\nalbedo = [0.7, 0.1, 0.1]\n\n\
[[material]]\nname = \"light\"\nkind = \"emissive\"\nemission = [3, 3, 3]\n";

/// The floor and the light, the same in both scenes (written after the meshes, so that the
/// merged scene numbers them after the copies).
const REST: &str = "\n[[triangle]]\nv0 = [-8, -1, -8]\nv1 = [-8, -1, 8]\nv2 = [8, -1, 8]\n\
\n[[triangle]]\nv0 = [-8, -1, -8]\nv1 = [8, -1, 8]\nv2 = [8, -1, -8]\n\
\n[[triangle]]\nv0 = [-2, 5, -2]\nv1 = [2, 5, 2]\nv2 = [-2, 5, 2]\nmaterial = \"light\"\n\
\n[[triangle]]\nv0 = [-2, 5, -2]\nv1 = [2, 5, -2]\nv2 = [2, 5, 2]\nmaterial = \"light\"\n";

/// The copies: (mesh material, translation), in id order.
fn copies() -> Vec<(&'static str, [i32; 3])> {
    let mut out = Vec::new();
    // The grid entry: 3 × 1 × 2 white copies, x fastest.
    for k in 0..2 {
        for i in 0..3 {
            out.push(("white", [-2 + 2 * i, 0, -1 + 2 * k]));
        }
    }
    out.push(("red", [1, 1, 3]));
    out.push(("white", [-3, 0, 3]));
    out
}

/// The scene with instances: two named mesh entries of the same file, a grid entry and two
/// single copies.
fn instanced_text() -> String {
    let mut t = String::from(HEAD);
    t += "\n[[mesh]]\nname = \"oct\"\npath = \"oct.obj\"\nmaterial = \"white\"\n";
    t += "\n[[mesh]]\nname = \"oct-red\"\npath = \"oct.obj\"\nmaterial = \"red\"\n";
    t += "\n[[instance]]\nmesh = \"oct\"\ntranslate = [-2, 0, -1]\ngrid = [3, 1, 2]\nspacing = [2, 0, 2]\n";
    t += "\n[[instance]]\nmesh = \"oct-red\"\ntranslate = [1, 1, 3]\n";
    t += "\n[[instance]]\nmesh = \"oct\"\nmatrix = [[1, 0, 0, -3], [0, 1, 0, 0], [0, 0, 1, 3]]\n";
    t + REST
}

/// The same copies as unnamed `[[mesh]]` entries, each with its `translate`.
fn merged_text() -> String {
    let mut t = String::from(HEAD);
    for (material, [x, y, z]) in copies() {
        t += &format!(
            "\n[[mesh]]\npath = \"oct.obj\"\nmaterial = \"{material}\"\ntranslate = [{x}, {y}, {z}]\n"
        );
    }
    t + REST
}

/// Writes the mesh and both scenes into a fresh folder: (the folder, instanced, merged).
fn scenes(name: &str) -> (Scratch, PathBuf, PathBuf) {
    let d = dir(name);
    std::fs::write(d.join("oct.obj"), OCTAHEDRON).unwrap();
    let (a, b) = (d.join("instanced.toml"), d.join("merged.toml"));
    std::fs::write(&a, instanced_text()).unwrap();
    std::fs::write(&b, merged_text()).unwrap();
    (d, a, b)
}

/// A tree's words for `g`.
fn words(g: &kdray::Geometry) -> Vec<u32> {
    let tree = build(g, &BuildParams::default(), None).unwrap();
    kdray::flat::serialize(&tree, g, 0.0).unwrap()
}

/// Rays from above the field in many directions: dyadic origins (so that moving them by an
/// integer translation is exact), pseudo-random directions.
fn rays() -> Vec<Ray> {
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    (0..4000)
        .map(|_| {
            let o = Vec3::new(
                (next() * 64.0).floor() / 8.0 - 4.0,
                3.0 + (next() * 8.0).floor() / 8.0,
                (next() * 64.0).floor() / 8.0 - 4.0,
            );
            let target = Vec3::new(next() * 8.0 - 4.0, next() * 2.0 - 1.0, next() * 8.0 - 4.0);
            Ray::new(o, (target - o).normalize())
        })
        .collect()
}

#[test]
fn instances_trace_as_the_same_meshes_placed_by_translations() {
    let (_folder, a, b) = scenes("trace-equal");
    let (a, b) = (
        kdray::scene::load_scene(&a).unwrap(),
        kdray::scene::load_scene(&b).unwrap(),
    );
    let merged_geom = b.geometry().unwrap();
    let merged_words = words(&merged_geom);
    let merged = Scene::from_words(&merged_words).unwrap();
    let two = a.instanced_geometry().unwrap();
    // One bottom per named mesh entry, one for the floor and light.
    assert_eq!(two.bottoms.len(), 3);
    let bottom_words: Vec<Vec<u32>> = two.bottoms.iter().map(words).collect();
    let bottoms: Vec<Scene> = bottom_words
        .iter()
        .map(|w| Scene::from_words(w).unwrap())
        .collect();
    let top_words = top_level(&bottoms, &two.placements).unwrap();
    let top = InstancedScene::from_words(&top_words, &bottoms).unwrap();
    let n_copies = copies().len();
    assert_eq!(top.instance_count() as usize, n_copies + 1);
    let mut hits = 0;
    for mode in [Mode::Fast, Mode::Watertight] {
        for ray in rays() {
            let one = merged.intersect_in(mode, &ray);
            let two = top.intersect_in(mode, &ray);
            assert_eq!(one.is_hit(), two.is_hit(), "{ray:?}");
            if !one.is_hit() {
                continue;
            }
            hits += 1;
            let prim = merged.input_id(one.prim) as usize;
            // The merged scene: copy c's triangles at c·TRIS.., then the floor and the light.
            let (id, local) = if prim < n_copies * TRIS {
                (prim / TRIS, prim % TRIS)
            } else {
                (n_copies, prim - n_copies * TRIS)
            };
            let bottom = top.bottom_of(two.instance);
            assert_eq!(two.user_id as usize, id, "{ray:?}");
            assert_eq!(bottom.input_id(two.prim) as usize, local, "{ray:?}");
            assert_eq!(one.t.to_bits(), two.t.to_bits(), "{ray:?}");
            assert_eq!((one.u, one.v), (two.u, two.v), "{ray:?}");
            assert_eq!(
                merged.material(one.prim),
                bottom.material(two.prim),
                "{ray:?}"
            );
        }
    }
    assert!(hits > 2000, "only {hits} of 8000 rays hit");
    // Flattened, the instanced scene is the merged one, the copies after the floor and light.
    let flat = a.geometry().unwrap();
    assert_eq!(flat.triangles.len(), merged_geom.triangles.len());
    assert_eq!(
        flat.triangles[4..],
        merged_geom.triangles[..n_copies * TRIS]
    );
}

/// Renders both scenes with the core's frames: the instanced one through the two-level walk,
/// the merged one one ray at a time. The two differ only where a spawned ray's origin, moved off
/// its surface by a bound computed in another frame, makes another choice, so the images agree
/// closely but not bit for bit.
#[test]
fn instances_render_as_the_same_meshes_placed_by_translations() {
    let (_folder, a, b) = scenes("render-equal");
    let (a, b) = (
        kdray::scene::load_scene(&a).unwrap(),
        kdray::scene::load_scene(&b).unwrap(),
    );
    let materials: Vec<render::Material> = a.materials.iter().map(|m| m.to_core()).collect();
    let camera = a.camera().unwrap();
    let settings = render::Settings {
        width: 24,
        height: 16,
        spp: 64,
        max_depth: 4,
        background: Vec3::splat(0.2),
        seed: 7,
        bounces: Bounces::SingleRays,
        mode: Mode::Fast,
    };
    let merged_words = words(&b.geometry().unwrap());
    let merged = Scene::from_words(&merged_words).unwrap();
    let mut lights = vec![0; render::emitters(&merged, &materials, &mut [])];
    render::emitters(&merged, &materials, &mut lights);
    let one = Frame {
        scene: &merged,
        camera: &camera,
        materials: &materials,
        lights: &lights,
        settings: &settings,
    };
    let two_geom = a.instanced_geometry().unwrap();
    let bottom_words: Vec<Vec<u32>> = two_geom.bottoms.iter().map(words).collect();
    let bottoms: Vec<Scene> = bottom_words
        .iter()
        .map(|w| Scene::from_words(w).unwrap())
        .collect();
    let top_words = top_level(&bottoms, &two_geom.placements).unwrap();
    let top = InstancedScene::from_words(&top_words, &bottoms).unwrap();
    let none = InstanceLight {
        instance: 0,
        prim: 0,
    };
    let mut ilights = vec![none; render::instanced_emitters(&top, &materials, &mut [])];
    render::instanced_emitters(&top, &materials, &mut ilights);
    assert_eq!(ilights.len(), lights.len(), "the light's two triangles");
    let two = InstancedFrame {
        scene: &top,
        camera: &camera,
        materials: &materials,
        lights: &ilights,
        settings: &settings,
    };
    let (mut diff, mut total, mut same) = (0.0f64, 0.0f64, 0);
    let pixels = settings.width * settings.height;
    for y in 0..settings.height {
        for x in 0..settings.width {
            let (mut s1, mut s2) = (SampleSums::default(), SampleSums::default());
            one.add_samples(x, y, 0..settings.spp, &mut s1).unwrap();
            two.add_samples(x, y, 0..settings.spp, &mut s2).unwrap();
            diff += f64::from((s1.sum - s2.sum).abs().element_sum());
            total += f64::from(s1.sum.element_sum());
            same +=
                usize::from((s1.sum - s2.sum).abs().max_element() <= 1e-3 * s1.sum.max_element());
        }
    }
    assert!(total > 0.0);
    assert!(
        diff <= 0.01 * total,
        "the images differ by {:.3} % of their sum",
        100.0 * diff / total
    );
    assert!(
        same * 10 >= pixels as usize * 9,
        "only {same} of {pixels} pixels agree"
    );
}

/// Every copy shows its mesh entry's material: a camera ray that lands on a copy of an
/// emissive mesh, with nothing else lit, gathers exactly that mesh entry's emission.
#[test]
fn each_copy_has_its_mesh_entrys_material() {
    let d = dir("materials");
    // A square facing +z (towards the camera), 2 × 2; copy `qa` fills the left pixel's view,
    // `qb` (in front, from x = 0) the right one's.
    std::fs::write(
        d.join("quad.obj"),
        "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3 4\n",
    )
    .unwrap();
    let text = "[camera]\nkind = \"pinhole\"\neye = [0, 0, 10]\ntarget = [0, 0, 0]\nvfov = 10\n\
[render]\nwidth = 2\nheight = 1\nspp = 1\nmax_depth = 1\n\
[[material]]\nname = \"a\"\nkind = \"emissive\"\nemission = [1, 2, 3]\nalbedo = [0, 0, 0]\n\
[[material]]\nname = \"b\"\nkind = \"emissive\"\nemission = [4, 0, 0.5]\nalbedo = [0, 0, 0]\n\
[[mesh]]\nname = \"qa\"\npath = \"quad.obj\"\nmaterial = \"a\"\n\
[[mesh]]\nname = \"qb\"\npath = \"quad.obj\"\nmaterial = \"b\"\n\
[[instance]]\nmesh = \"qa\"\ntranslate = [-2, 0, 0]\nscale = [2.1, 1, 1]\n\
[[instance]]\nmesh = \"qb\"\nscale = [2, 2.1, 1]\nrotate_deg = [0, 0, 90]\ntranslate = [2.1, 0, 0.5]\n";
    let path = d.join("m.toml");
    std::fs::write(&path, text).unwrap();
    let file = kdray::scene::load_scene(&path).unwrap();
    let materials: Vec<render::Material> = file.materials.iter().map(|m| m.to_core()).collect();
    let g = file.instanced_geometry().unwrap();
    let bottom_words: Vec<Vec<u32>> = g.bottoms.iter().map(words).collect();
    let bottoms: Vec<Scene> = bottom_words
        .iter()
        .map(|w| Scene::from_words(w).unwrap())
        .collect();
    let top_words = top_level(&bottoms, &g.placements).unwrap();
    let top = InstancedScene::from_words(&top_words, &bottoms).unwrap();
    let camera = file.camera().unwrap();
    let settings = render::Settings {
        width: 2,
        height: 1,
        spp: 4,
        max_depth: 1,
        background: Vec3::ZERO,
        seed: 1,
        bounces: Bounces::SingleRays,
        mode: Mode::Fast,
    };
    let frame = InstancedFrame {
        scene: &top,
        camera: &camera,
        materials: &materials,
        lights: &[],
        settings: &settings,
    };
    for (x, want) in [(0, Vec3::new(1.0, 2.0, 3.0)), (1, Vec3::new(4.0, 0.0, 0.5))] {
        let mut sums = SampleSums::default();
        frame.add_samples(x, 0, 0..4, &mut sums).unwrap();
        assert_eq!(sums.sum / 4.0, want, "pixel {x}");
    }
}

/// `kdray trace` on both scene files: the same hits, the instanced one's `prim` in its copy's
/// mesh and the copy's id in the `--instances` file, which `kdray hits --instances` prints.
#[test]
fn trace_writes_the_instance_of_each_hit() {
    let (d, a, b) = scenes("cli-trace");
    let rays_path = d.join("rays.bin");
    std::fs::write(&rays_path, kdray::rays::encode_rays(&rays())).unwrap();
    let run = |scene: &Path, out: &str, ids: Option<&str>| {
        let out = d.join(out);
        let ids = ids.map(|i| d.join(i));
        let mut args = vec![
            "trace".to_string(),
            s(scene).into(),
            "--rays".into(),
            s(&rays_path).into(),
            "--out".into(),
            s(&out).into(),
        ];
        if let Some(ids) = &ids {
            args.extend(["--instances".to_string(), s(ids).into()]);
        }
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = kdray(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let line = String::from_utf8(o.stdout).unwrap();
        (
            std::fs::read(out).unwrap(),
            ids.map(|i| std::fs::read(i).unwrap()),
            line,
        )
    };
    let (two, ids, line) = run(&a, "two.bin", Some("ids.bin"));
    assert!(line.contains(" instances=9 meshes=3"), "{line}");
    let (one, one_ids, _) = run(&b, "one.bin", Some("one-ids.bin"));
    let ids = ids.unwrap();
    let one_ids = one_ids.unwrap();
    assert_eq!(two.len(), one.len());
    assert_eq!(ids.len() * 4, two.len());
    let word = |b: &[u8], i: usize| u32::from_le_bytes(b[4 * i..4 * i + 4].try_into().unwrap());
    let n_copies = copies().len();
    for i in 0..two.len() / 16 {
        let (t1, p1, t2, p2) = (
            word(&one, 4 * i),
            word(&one, 4 * i + 1),
            word(&two, 4 * i),
            word(&two, 4 * i + 1),
        );
        assert_eq!(t1, t2, "ray {i}");
        let id = word(&ids, i);
        if p1 == Hit::MISS_PRIM {
            assert_eq!(
                (p2, id, word(&one_ids, i)),
                (Hit::MISS_PRIM, Hit::MISS_PRIM, Hit::MISS_PRIM)
            );
            continue;
        }
        assert_eq!(word(&one_ids, i), 0, "a scene of one mesh is instance 0");
        let p1 = p1 as usize;
        let want = if p1 < n_copies * TRIS {
            (p1 / TRIS, p1 % TRIS)
        } else {
            (n_copies, p1 - n_copies * TRIS)
        };
        assert_eq!((id as usize, p2 as usize), want, "ray {i}");
    }
    let o = kdray(&[
        "hits",
        s(&d.join("two.bin")),
        "--instances",
        s(&d.join("ids.bin")),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8(o.stdout).unwrap();
    let first_hit = (0..ids.len() / 4)
        .find(|&i| word(&ids, i) != Hit::MISS_PRIM)
        .unwrap();
    let line = text.lines().nth(first_hit).unwrap();
    assert!(
        line.ends_with(&format!(" instance={}", word(&ids, first_hit))),
        "{line}"
    );
    // Packets and the stream give the single rays' hits and instances, file for file.
    for flags in [
        &["--packet", "4"][..],
        &["--packet", "8"],
        &["--stream"],
        &["--stream", "--packet", "8"],
    ] {
        let (out, way_ids) = (d.join("way.bin"), d.join("way-ids.bin"));
        let mut args = vec![
            "trace",
            s(&a),
            "--rays",
            s(&rays_path),
            "--out",
            s(&out),
            "--instances",
            s(&way_ids),
        ];
        args.extend_from_slice(flags);
        let o = kdray(&args);
        assert!(
            o.status.success(),
            "{flags:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(std::fs::read(&out).unwrap() == two, "{flags:?}: other hits");
        assert!(
            std::fs::read(&way_ids).unwrap() == ids,
            "{flags:?}: other instances"
        );
    }
    // `--counts` counts a single-mesh walk's steps: refused for instances, with the reason.
    let o = kdray(&[
        "trace",
        s(&a),
        "--rays",
        s(&rays_path),
        "--out",
        s(&d.join("x.bin")),
        "--counts",
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("[[instance]]"));
}

/// Parses `text` as `dir/bad.toml` and returns its error, asserting that it names the file, the
/// line and the entry.
fn error_of(text: &str, line: usize) -> String {
    let full = format!("{HEAD}\n[[mesh]]\nname = \"oct\"\npath = \"oct.obj\"\n{text}");
    let err = SceneFile::from_toml_str(&full, Path::new("dir/bad.toml"))
        .expect_err("accepted")
        .to_string();
    let head_lines = HEAD.lines().count() + 4;
    let at = format!("dir/bad.toml:{}:", head_lines + line);
    assert!(err.contains(&at), "{err} (expected {at})");
    err
}

#[test]
fn bad_instance_entries_name_the_file_and_the_entry() {
    let cases: [(&str, &str); 9] = [
        (
            "[[instance]]\nmesh = \"cube\"\n",
            "no [[mesh]] has this name",
        ),
        (
            "[[instance]]\nmesh = \"oct\"\nmatrix = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0]]\ntranslate = [1, 0, 0]\n",
            "`matrix` replaces",
        ),
        (
            "[[instance]]\nmesh = \"oct\"\nmatrix = [[1, 0, 0, 0], [0, 1, 0, 0], [1, 0, 0, 0]]\n",
            "singular",
        ),
        (
            "[[instance]]\nmesh = \"oct\"\nmatrix = [[nan, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0]]\n",
            "finite",
        ),
        (
            "[[instance]]\nmesh = \"oct\"\ntranslate = [inf, 0, 0]\n",
            "finite",
        ),
        (
            "[[instance]]\nmesh = \"oct\"\nscale = 0\n",
            "scale factors must not be 0",
        ),
        (
            "[[instance]]\nmesh = \"oct\"\ngrid = [2, 0, 1]\nspacing = [1, 1, 1]\n",
            "at least 1",
        ),
        (
            "[[instance]]\nmesh = \"oct\"\ngrid = [2, 1, 1]\n",
            "`grid` and `spacing` go together",
        ),
        (
            "[[instance]]\nmesh = \"oct\"\ngrid = [1000000, 1, 1]\nspacing = [3e38, 0, 0]\n",
            "beyond f32",
        ),
    ];
    for (text, want) in cases {
        // The entry's first line follows a blank line.
        let err = error_of(&format!("\n{text}"), 2);
        assert!(err.contains("instance of `"), "{err}");
        assert!(err.contains(want), "{err} (expected {want})");
    }
    let err = SceneFile::from_toml_str(
        &format!("{HEAD}\n[[mesh]]\nname = \"x\"\npath = \"a.obj\"\n\n[[mesh]]\nname = \"x\"\npath = \"b.obj\"\n"),
        Path::new("dir/bad.toml"),
    )
    .expect_err("accepted")
    .to_string();
    assert!(
        err.contains("dir/bad.toml:") && err.contains("mesh `x`: the name is used twice"),
        "{err}"
    );
    // An unknown key is refused like everywhere else.
    let err = SceneFile::from_toml_str(
        &format!("{HEAD}\n[[mesh]]\nname = \"oct\"\npath = \"oct.obj\"\n\n[[instance]]\nmesh = \"oct\"\nrotate = [0, 1, 0]\n"),
        Path::new("dir/bad.toml"),
    )
    .expect_err("accepted")
    .to_string();
    assert!(err.contains("rotate"), "{err}");
}
