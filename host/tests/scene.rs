//! Scene files: the built-in default, meshes placed by transforms, every camera kind, and errors
//! that name the scene file and line.

use core::sync::atomic::{AtomicUsize, Ordering};
use glam::Vec3;
use kdray::load::encode_tri;
use kdray::scene::{CameraDesc, DEFAULT_SCENE_TOML, MaterialKind, Scale, SceneFile, load_scene};
use kdray_core::camera::Camera;
use std::path::{Path, PathBuf};

/// A fresh folder in the system's temporary folder, removed on drop.
struct TempDir(PathBuf);

impl TempDir {
    fn new() -> Self {
        static NEXT: AtomicUsize = AtomicUsize::new(0);
        let n = NEXT.fetch_add(1, Ordering::Relaxed);
        let dir = std::env::temp_dir().join(format!("kdray-scene-{}-{n}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        Self(dir)
    }

    fn write(&self, name: &str, bytes: &[u8]) -> PathBuf {
        let path = self.0.join(name);
        std::fs::write(&path, bytes).unwrap();
        path
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

const CAMERA: &str = "[camera]\nkind = \"pinhole\"\neye = [0, 0, 5]\ntarget = [0, 0, 0]\n";

/// Parses `text` as `scene.toml` and returns the error, asserting it names the file and `line`.
fn error_of(text: &str, line: Option<usize>) -> String {
    let err = SceneFile::from_toml_str(text, Path::new("dir/scene.toml")).expect_err("accepted");
    let msg = err.to_string();
    assert!(msg.contains("scene.toml"), "{msg}");
    assert_eq!(err.line, line, "wrong line in: {msg}");
    msg
}

#[test]
fn default_scene_is_complete() {
    let s = SceneFile::default_scene();
    assert!(matches!(s.camera, CameraDesc::Pinhole { .. }));
    assert_eq!(s.materials.len(), 6);
    assert_eq!(s.materials[3].kind, MaterialKind::Emissive);
    let g = s.geometry().unwrap();
    // The bunny (embedded: the built-in scene needs no files), then the room's 12 triangles.
    let bunny = 3674;
    assert_eq!((g.triangles.len(), g.spheres.len()), (bunny + 12, 2));
    assert_eq!(g.tri_materials.len(), bunny + 12);
    assert_eq!(g.sphere_materials, vec![4, 5]);
    assert_eq!((g.normals, g.uvs), (None, None));
    for t in &g.triangles[..bunny] {
        for v in t {
            let inside = v.x.abs() < 1.0 && v.z.abs() < 1.0 && (-1e-3..2.0).contains(&v.y);
            assert!(inside, "the bunny leaves the room at {v}");
        }
    }
    // Every wall faces the room's centre; the light faces down, the one side it emits from.
    let centre = Vec3::new(0.0, 1.0, 0.0);
    for (t, m) in g.triangles.iter().zip(&g.tri_materials).skip(bunny) {
        let n = (t[1] - t[0]).cross(t[2] - t[0]);
        assert!(n.dot(centre - t[0]) > 0.0, "{t:?} faces away");
        if *m == 3 {
            assert!(n.y < 0.0 && n.x == 0.0 && n.z == 0.0, "the light faces {n}");
        }
    }
    assert!(!s.materials[3].two_sided);
    // The centre pixel looks down -z.
    let cam = s.camera().unwrap();
    let ray = cam.pixel_ray(256, 256, 512, 512);
    assert!(ray.dir.z < -0.99, "{:?}", ray.dir);
    // The same text read from a file gives the same scene.
    let dir = TempDir::new();
    let path = dir.write("default.toml", DEFAULT_SCENE_TOML.as_bytes());
    let loaded = load_scene(&path).unwrap();
    assert_eq!(
        (loaded.camera, loaded.materials, loaded.spheres),
        (s.camera, s.materials, s.spheres)
    );
}

#[test]
fn meshes_are_loaded_relative_to_the_scene_and_placed() {
    let dir = TempDir::new();
    std::fs::create_dir_all(dir.0.join("meshes")).unwrap();
    let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
    dir.write("meshes/one.tri", &encode_tri(&[tri]));
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n";
    dir.write("meshes/smooth.obj", obj.as_bytes());
    let text = format!(
        "{CAMERA}
[[material]]
name = \"a\"
kind = \"diffuse\"
color = [0.5, 0.5, 0.5]

[[material]]
name = \"b\"
kind = \"glass\"

[[mesh]]
path = \"meshes/one.tri\"
material = \"b\"
translate = [10, 0, 0]
scale = 2

[[mesh]]
path = \"meshes/smooth.obj\"
rotate_deg = [90, 0, 0]
scale = [1, 1, 3]

[[triangle]]
v0 = [0, 0, 0]
v1 = [0, 1, 0]
v2 = [1, 0, 0]
material = \"b\"

[[sphere]]
center = [0, 0, -1]
radius = 0.5
"
    );
    let path = dir.write("scene.toml", text.as_bytes());
    let s = load_scene(&path).unwrap();
    assert_eq!(s.materials[0].albedo, [0.5; 3]);
    assert_eq!(s.materials[1].ior, 1.5);
    assert_eq!(s.meshes[0].scale, Some(Scale::Uniform(2.0)));
    let g = s.geometry().unwrap();
    assert_eq!(g.triangles.len(), 3);
    assert_eq!(
        g.triangles[0],
        [
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(12.0, 0.0, 0.0),
            Vec3::new(10.0, 2.0, 0.0)
        ]
    );
    // Rotating 90° about x takes y to z; the normal (0,0,1) goes to (0,-1,0), unaffected by the
    // z scale, which acts before the rotation.
    let close = |a: Vec3, b: Vec3| (a - b).length() < 1e-6;
    assert!(close(g.triangles[1][2], Vec3::Z), "{:?}", g.triangles[1]);
    let normals = g.normals.unwrap();
    assert!(close(normals[1][0], -Vec3::Y), "{:?}", normals[1]);
    // The .tri mesh and the inline triangle have no normals: they get their face normal.
    assert_eq!(normals[0], [Vec3::Z; 3]);
    assert_eq!(normals[2], [-Vec3::Z; 3]);
    assert_eq!(g.tri_materials, vec![1, 0, 1]);
    assert_eq!(g.spheres, vec![(Vec3::new(0.0, 0.0, -1.0), 0.5)]);
    assert_eq!(g.sphere_materials, vec![0]);
}

#[test]
fn the_example_in_the_docs_is_valid() {
    let doc = include_str!("../../docs/SCENE.md");
    let start = doc
        .find("```toml\n")
        .expect("docs/SCENE.md has a TOML example")
        + 8;
    let len = doc[start..].find("```").unwrap();
    let s = SceneFile::from_toml_str(&doc[start..start + len], Path::new("docs/SCENE.md")).unwrap();
    assert_eq!(
        (s.meshes.len(), s.triangles.len(), s.spheres.len()),
        (1, 4, 1)
    );
    assert_eq!(s.render.background, [0.05, 0.05, 0.08]);
}

#[test]
fn every_camera_kind_parses_and_builds() {
    let fisheye = "[camera]\nkind = \"fisheye\"\norigin = [0, 0, 0]\nphi = [-90, 0, 90]\ntheta = [45, 90, 135]\n[[sphere]]\ncenter = [1, 0, 0]\nradius = 0.5\n";
    let s = SceneFile::from_toml_str(fisheye, Path::new("f.toml")).unwrap();
    assert_eq!(s.materials[0].name, "default");
    let ray = s.camera().unwrap().pixel_ray(1, 1, 3, 3);
    assert!((ray.dir - Vec3::X).length() < 1e-6, "{:?}", ray.dir);
    let parallel = "[camera]\nkind = \"parallel\"\norigin = [0, 0, -5]\nphi = 0\ntheta = 0\nhorizontal = [-1, 0, 1]\nvertical = [-1, 0, 1]\n[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\n";
    let s = SceneFile::from_toml_str(parallel, Path::new("p.toml")).unwrap();
    assert!(matches!(
        s.camera().unwrap(),
        kdray::scene::SceneCamera::Parallel(_)
    ));
}

#[test]
fn errors_name_the_scene_file_and_line() {
    let sphere = "[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\n";
    // TOML syntax.
    error_of(&format!("{CAMERA}\nradius = = 2\n"), Some(6));
    error_of("[camera]\nkind = \"pinhole\"\neye = [0, 0\n", Some(3));
    // Unknown fields, wrong types, unknown kinds.
    // Inside [camera] (an internally tagged enum, which serde buffers) the span is the table's.
    let t = error_of(&format!("{CAMERA}fov = 3\n{sphere}"), Some(1));
    assert!(t.contains("fov"), "{t}");
    error_of(&format!("{CAMERA}{sphere}colour = [1, 1, 1]\n"), Some(8));
    error_of(&format!("{CAMERA}{sphere}radius = \"big\"\n"), Some(8));
    error_of(
        &format!("{CAMERA}[[material]]\nname = \"m\"\nkind = \"plastic\"\n{sphere}"),
        Some(7),
    );
    error_of(sphere, Some(1));
    // Checks after parsing, at the entry's line.
    let t = error_of(&format!("{CAMERA}{sphere}material = \"gold\"\n"), Some(5));
    assert!(t.contains("unknown material `gold`"), "{t}");
    error_of(
        &format!("{CAMERA}\n[[sphere]]\ncenter = [0, 0, 0]\nradius = -1\n"),
        Some(6),
    );
    error_of(
        &format!("{CAMERA}[[sphere]]\ncenter = [0, 0, 0]\nradius = nan\n"),
        Some(5),
    );
    error_of(
        &format!("{CAMERA}[[triangle]]\nv0 = [0, 0, inf]\nv1 = [0, 0, 0]\nv2 = [0, 1, 0]\n"),
        Some(5),
    );
    let dup = "[[material]]\nname = \"m\"\nkind = \"mirror\"\n";
    error_of(&format!("{CAMERA}{dup}{dup}{sphere}"), Some(8));
    error_of(
        &format!(
            "{CAMERA}[[material]]\nname = \"m\"\nkind = \"diffuse\"\nalbedo = [2, 0, 0]\n{sphere}"
        ),
        Some(5),
    );
    error_of(&format!("{CAMERA}[render]\nspp = 0\n{sphere}"), Some(5));
    error_of(
        &format!("{CAMERA}[[mesh]]\npath = \"m.tri\"\nscale = 0\n"),
        Some(5),
    );
    error_of(
        &format!("{CAMERA}{sphere}[[mesh]]\npath = \"m.tri\"\nscale = [1, 2]\n"),
        Some(10),
    );
    // Cameras the core refuses.
    let bad_fov = CAMERA.replace("target", "vfov = 180\ntarget");
    error_of(&format!("{bad_fov}{sphere}"), Some(1));
    let fisheye = "[camera]\nkind = \"fisheye\"\norigin = [0, 0, 0]\nphi = [0, 10, 90]\ntheta = [0, 45, 90]\n";
    let t = error_of(&format!("{fisheye}{sphere}"), Some(1));
    assert!(t.contains("phi") && t.contains("midpoint"), "{t}");
    // Nothing to render.
    error_of(CAMERA, None);
}

#[test]
fn mesh_problems_name_the_right_file() {
    let dir = TempDir::new();
    let text = format!("{CAMERA}\n[[mesh]]\npath = \"missing.ply\"\n");
    let path = dir.write("scene.toml", text.as_bytes());
    let err = load_scene(&path).unwrap().geometry().unwrap_err();
    assert!(
        err.to_string().contains("scene.toml:6: ") && err.to_string().contains("missing.ply"),
        "{err}"
    );
    dir.write("broken.obj", b"v 0 0 0\nf 1 2 3\n");
    let text = format!("{CAMERA}\n[[mesh]]\npath = \"broken.obj\"\n");
    let path = dir.write("scene.toml", text.as_bytes());
    let err = load_scene(&path).unwrap().geometry().unwrap_err();
    assert!(err.to_string().contains("broken.obj:2: "), "{err}");
    let err = load_scene(&dir.0.join("nope.toml")).unwrap_err();
    assert!(err.to_string().contains("nope.toml"), "{err}");
    let invalid_utf8 = dir.write("bin.toml", b"\xff\xfe[camera]");
    assert!(
        load_scene(&invalid_utf8)
            .unwrap_err()
            .to_string()
            .contains("bin.toml")
    );
}

mod never_panic {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(scaled_cases(300)))]

        #[test]
        fn random_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
            let dir = TempDir::new();
            let path = dir.write("r.toml", &bytes);
            if let Err(e) = load_scene(&path) {
                prop_assert!(e.to_string().contains("r.toml"));
            }
        }

        /// Mutations of the default scene: a line dropped or replaced by a random one.
        #[test]
        fn mutated_default(drop in 0usize..200, junk in "[a-z_=\\[\\] 0-9.\"-]{0,20}") {
            let mut lines: Vec<&str> = DEFAULT_SCENE_TOML.lines().collect();
            let i = drop % lines.len();
            lines[i] = &junk;
            let text = lines.join("\n");
            match SceneFile::from_toml_str(&text, Path::new("m.toml")) {
                Ok(s) => { let _ = s.geometry(); }
                Err(e) => prop_assert!(e.to_string().contains("m.toml")),
            }
        }
    }
}

#[test]
fn lens_cameras_parse_and_build() {
    let sphere = "[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\n";
    let lens = "[camera]\nkind = \"thick_lens\"\neye = [0, 0, 5]\ntarget = [0, 0, 0]\nfocus = 5\n";
    let s = SceneFile::from_toml_str(&format!("{lens}{sphere}"), Path::new("l.toml")).unwrap();
    let kdray::scene::SceneCamera::ThickLens(cam) = s.camera().unwrap() else {
        panic!("not a thick lens: {:?}", s.camera());
    };
    // The default lens, focused by the helper.
    let [r1, r2, l1, l2, ior, a] = kdray::scene::DEFAULT_LENS;
    assert_eq!(
        *cam.lens(),
        kdray_core::camera::LensShape::new(r1, r2, l1, l2, ior, a).unwrap()
    );
    assert_eq!(Some(cam.sensor_distance()), cam.lens().sensor_distance(5.0));
    let placed = lens.replace("focus = 5", "sensor = 0.06\naperture = 0.005\nior = 1.6");
    let s = SceneFile::from_toml_str(&format!("{placed}{sphere}"), Path::new("l.toml")).unwrap();
    let kdray::scene::SceneCamera::ThickLens(cam) = s.camera().unwrap() else {
        panic!("not a thick lens");
    };
    assert_eq!(
        (cam.sensor_distance(), cam.lens().aperture, cam.lens().ior),
        (0.06, 0.005, 1.6)
    );
    let array = "[camera]\nkind = \"lens_array\"\neye = [0, 0, 5]\ntarget = [0, 0, 0]\nsize = [0.1, 0.1]\npitch = [0.01, 0.01]\ngap = 0.02\n";
    let s = SceneFile::from_toml_str(&format!("{array}{sphere}"), Path::new("a.toml")).unwrap();
    assert!(matches!(
        s.camera().unwrap(),
        kdray::scene::SceneCamera::LensArray(_)
    ));
    // Refusals name what is wrong.
    let t = error_of(
        &format!("{}{sphere}", lens.replace("focus = 5", "focus = 0.01")),
        Some(1),
    );
    assert!(
        t.contains("cannot focus at 0.01") && t.contains("focal length"),
        "{t}"
    );
    let t = error_of(
        &format!("{}{sphere}", lens.replace("focus = 5\n", "")),
        Some(1),
    );
    assert!(t.contains("`focus`") && t.contains("`sensor`"), "{t}");
    let t = error_of(
        &format!(
            "{}{sphere}",
            lens.replace("focus = 5", "focus = 5\nsensor = 1")
        ),
        Some(1),
    );
    assert!(t.contains("one of `focus`, `sensor`"), "{t}");
    let t = error_of(&format!("{}aperture = 0.06\n{sphere}", lens), Some(1));
    assert!(
        t.contains("is no lens") && t.contains("aperture = 0.06"),
        "{t}"
    );
    let t = error_of(
        &format!("{}{sphere}", array.replace("gap = 0.02", "gap = 0")),
        Some(1),
    );
    assert!(t.contains("gap"), "{t}");
}

/// A key of the wrong type is named, inside `[camera]` (which used to say only `invalid type:
/// sequence, expected f32`) and elsewhere.
#[test]
fn wrong_types_name_the_key() {
    let sphere = "[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\n";
    let parallel = "[camera]\nkind = \"parallel\"\norigin = [0, -1, 0]\nphi = [0, 0, 0]\ntheta = 110\nhorizontal = [-2, 0, 2]\nvertical = [-2, 0, 2]\n";
    let t = error_of(&format!("{parallel}{sphere}"), Some(1));
    assert!(
        t.contains("`phi`: invalid type: sequence, expected f32"),
        "{t}"
    );
    let t = error_of(&format!("{CAMERA}vfov = \"wide\"\n{sphere}"), Some(1));
    assert!(t.contains("`vfov`: invalid type"), "{t}");
    let t = error_of(
        &format!("{CAMERA}{sphere}[render]\nspp = \"many\"\n"),
        Some(9),
    );
    assert!(t.contains("`spp`: invalid type"), "{t}");
    let t = error_of(&format!("{CAMERA}kind2 = 1\n{sphere}"), Some(1));
    assert!(
        t.contains("unknown key `kind2` for a pinhole camera"),
        "{t}"
    );
    let t = error_of(&format!("[camera]\nkind = \"fish\"\n{sphere}"), Some(1));
    assert!(t.contains("unknown camera kind `fish`"), "{t}");
}

#[test]
fn lights_are_one_sided_unless_asked() {
    let sphere = "[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\n";
    let light = "[[material]]\nname = \"l\"\nkind = \"emissive\"\nemission = [1, 1, 1]\n";
    let s =
        SceneFile::from_toml_str(&format!("{CAMERA}{light}{sphere}"), Path::new("s.toml")).unwrap();
    assert!(!s.materials[0].two_sided);
    let two = format!("{CAMERA}{light}two_sided = true\n{sphere}");
    let s = SceneFile::from_toml_str(&two, Path::new("s.toml")).unwrap();
    assert!(s.materials[0].two_sided);
}

/// `[render] watertight` selects the trace mode: `true` and `false` parse, absent is `false`, and
/// anything but a boolean is an error at its line.
#[test]
fn render_watertight_key() {
    let sphere = "[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\n";
    let parse = |extra: &str| {
        SceneFile::from_toml_str(
            &format!("{CAMERA}[render]\n{extra}{sphere}"),
            Path::new("s.toml"),
        )
        .map(|s| s.render.watertight)
    };
    assert!(parse("watertight = true\n").unwrap());
    assert!(!parse("watertight = false\n").unwrap());
    assert!(!parse("").unwrap());
    // CAMERA is 4 lines and [render] the 5th: the bad value is on line 6.
    error_of(
        &format!("{CAMERA}[render]\nwatertight = 1\n{sphere}"),
        Some(6),
    );
}

/// `n` times `KDRAY_PROPTEST_SCALE` (default 1), as `kdray_tests::cases` does for the other
/// suites (this crate cannot depend on `kdray-tests`, which depends on it).
fn scaled_cases(n: u32) -> u32 {
    std::env::var("KDRAY_PROPTEST_SCALE").map_or(n, |v| {
        let k: u32 = v
            .trim()
            .parse()
            .expect("KDRAY_PROPTEST_SCALE: a positive whole number");
        n.saturating_mul(k.max(1))
    })
}
