//! What the `traversal` target found, replayed: every `fuzz/seeds/traversal/regression-*` file
//! (kept there so that the fuzzer starts from it too) goes through the target's checks
//! ([`kdray_fuzz::traversal::check`]), which must pass. (`fuzz/run.sh`, in CI too, replays them as
//! well: libFuzzer runs every seed file before it mutates.)
//!
//! - `regression-origin-on-face`: a ray starting on the box face `y = 2` and leaving it, `tmin =
//!   0`: the exact hit is at `t = 0 = tmin`, outside the open range. Möller–Trumbore computes
//!   `t = 0` exactly and rejects it; the watertight kernel computes `t = 8.7e-9` (its shear
//!   rounds) and accepts it. The check counted that as "one mode misses a clear hit"; a hit
//!   within rounding of `tmin` or `tmax` is a tie either mode may break, and is no longer clear
//!   (see [`kdray_fuzz::traversal::clear_scale`]).
//! - `regression-t-zero`: a ray starting on the same face, range `(-4, 4)`: both modes hit at
//!   exact `t = 0`, fast mode at `-0.0`, watertight mode at `-6e-8`; the check compared `t`
//!   relative to `t` itself, which is 0. The kernels' `t` errors scale with the primitive's
//!   distance from the origin (`L/|d|`), which is what the check now compares against.

use std::path::Path;

/// Every seed passes too (edge-aimed and random rays), and at least one regression file exists.
#[test]
fn traversal_seeds_and_regressions_pass_the_checks() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("seeds/traversal");
    let mut regressions = 0;
    for file in std::fs::read_dir(&dir).unwrap() {
        let path = file.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        regressions += usize::from(name.starts_with("regression-"));
        let data = std::fs::read(&path).unwrap();
        let replay = std::panic::catch_unwind(|| kdray_fuzz::traversal::check(&data));
        assert!(replay.is_ok(), "{name} fails the traversal checks");
    }
    assert!(regressions >= 1, "no regression files in {}", dir.display());
}
