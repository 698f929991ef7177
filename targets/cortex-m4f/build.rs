//! Puts `memory.x` where the linker finds it, writes `settings.rs` (the image size and samples
//! from `KDRAY_FW_SIZE` = `WxH` and `KDRAY_FW_SPP`, default 32x32 and 2), and rebuilds when the
//! embedded scene changes.
use std::{env, fs, path::PathBuf};

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    fs::copy("memory.x", out.join("memory.x")).expect("copy memory.x");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=memory.x");
    println!("cargo:rerun-if-env-changed=KDRAY_FW_SCENE");
    println!("cargo:rerun-if-env-changed=KDRAY_FW_SIZE");
    println!("cargo:rerun-if-env-changed=KDRAY_FW_SPP");
    let size = env::var("KDRAY_FW_SIZE").unwrap_or_else(|_| "32x32".into());
    let (w, h) = size
        .split_once('x')
        .and_then(|(w, h)| Some((w.parse::<u32>().ok()?, h.parse::<u32>().ok()?)))
        .expect("KDRAY_FW_SIZE must be WxH");
    let spp: u32 = env::var("KDRAY_FW_SPP")
        .unwrap_or_else(|_| "2".into())
        .parse()
        .expect("KDRAY_FW_SPP must be a number");
    let settings = format!(
        "pub const WIDTH: u32 = {w};\npub const HEIGHT: u32 = {h};\npub const SPP: u32 = {spp};\n"
    );
    fs::write(out.join("settings.rs"), settings).expect("write settings.rs");
    if let Some(dir) = env::var_os("KDRAY_FW_SCENE") {
        let dir = PathBuf::from(dir);
        for f in ["scene.kdt", "scene.kdr", "settings.txt"] {
            println!("cargo:rerun-if-changed={}", dir.join(f).display());
        }
    }
}
