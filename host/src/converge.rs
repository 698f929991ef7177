//! Error against run time (`kdray converge`): the white furnace with its analytic radiance, the
//! RMSE of an image against a reference, medians of repeated measurements and the log-log slope.
//!
//! For an unbiased Monte Carlo estimator the error's standard deviation falls as `1/√n` in the
//! samples `n`, so with time proportional to samples `RMSE ∝ t^(−1/2)`: the least-squares line
//! through `(ln t, ln RMSE)` has slope −0.5 (Veach 1997, thesis §2.4, "the variance ... decreases
//! linearly with N"). A biased estimator flattens towards its bias; overhead that does not grow
//! with the samples steepens the first points.

use crate::error::{Error, Result};
use crate::scene::SceneFile;
use std::io::Write;
use std::path::Path;

/// The white furnace (`kdray converge` without a scene): inside a sphere of radius 1 floats a
/// sphere of radius 0.35, both of one material, diffuse with albedo a = 0.5 and emitting
/// Le = 0.5 from both sides, so the radiance everywhere is Le / (1 − a) = 1 (up to the cut after
/// `max_depth` hits, see [`furnace_radiance`]). The camera, inside the big sphere, sees both.
///
/// Why this shape: next-event estimation picks a point on an emitter by area, and where two
/// surfaces meet at an angle (a cube's edges, even the shallow ones of a triangulated sphere) the
/// estimate grows like `1/d²` towards the edge, which gives it infinite variance: the error then
/// falls slower than `1/√n` (measured: a 320-triangle icosphere gave a slope of −0.445, a cube's
/// pixels had 3.6 times the squared error their variance estimate predicted). Here every term is
/// bounded: within the big sphere the estimate is exact (`cosθ·cosθ'/d² = 1/4R²`), towards the
/// small one the distance is at least the gap between them, and the noise comes from which
/// sphere is picked and from the small sphere hiding parts of the big one.
const FURNACE_TOML: &str = r#"
[camera]
kind = "pinhole"
eye = [0.0, 0.0, 0.55]
target = [0.1, -0.1, -1.0]
up = [0.0, 1.0, 0.0]
vfov = 90.0

[render]
width = 32
height = 32
spp = 64
max_depth = 8
background = [0.0, 0.0, 0.0]

[[material]]
name = "furnace"
kind = "emissive"
albedo = [0.5, 0.5, 0.5]
emission = [0.5, 0.5, 0.5]
# The big sphere emits from its inside, the back of its outward normal.
two_sided = true

[[sphere]]
center = [0.0, 0.0, 0.0]
radius = 1.0

[[sphere]]
center = [0.15, -0.1, -0.3]
radius = 0.35
"#;

/// The built-in white furnace scene (`FURNACE_TOML`'s doc says why this shape).
pub fn furnace_scene() -> SceneFile {
    SceneFile::from_toml_str(FURNACE_TOML, Path::new("<built-in white furnace>"))
        .expect("the built-in furnace scene is valid")
}

/// The radiance everywhere in a closed enclosure of albedo `a` and emission `le` whose paths
/// stop after `max_depth` hits: the camera ray's hit sees `le`, and the k-th hit's next-event
/// estimate adds `aᵏ·le` on average, so `le·(1 − a^(D+1))/(1 − a)`, which tends to `le/(1 − a)`.
pub fn furnace_radiance(a: f64, le: f64, max_depth: u32) -> f64 {
    (0..=max_depth).map(|k| le * a.powi(k as i32)).sum()
}

/// The root mean square difference of two images over every pixel and channel, f64.
pub fn rmse(image: &[[f32; 3]], reference: &[[f32; 3]]) -> f64 {
    mse(image, reference).sqrt()
}

/// The mean squared difference of two images over every pixel and channel.
pub fn mse(image: &[[f32; 3]], reference: &[[f32; 3]]) -> f64 {
    let sum: f64 = image
        .iter()
        .flatten()
        .zip(reference.iter().flatten())
        .map(|(&a, &b)| (f64::from(a) - f64::from(b)).powi(2))
        .sum();
    sum / (3 * image.len().max(1)) as f64
}

/// The median of `v` (the mean of the middle two for an even count); NaN for none.
pub fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    match s.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => s[n / 2],
        n => 0.5 * (s[n / 2 - 1] + s[n / 2]),
    }
}

/// The least-squares slope of `ln y` against `ln x` over the points with both positive; NaN for
/// fewer than two distinct `x`.
pub fn log_log_slope(points: &[(f64, f64)]) -> f64 {
    let logs: Vec<(f64, f64)> = points
        .iter()
        .filter(|(x, y)| *x > 0.0 && *y > 0.0)
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    let n = logs.len() as f64;
    let mx = logs.iter().map(|p| p.0).sum::<f64>() / n;
    let my = logs.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = logs.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = logs.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    if logs.len() < 2 || sxx <= 0.0 {
        f64::NAN
    } else {
        sxy / sxx
    }
}

/// The repeated measurements at one sample count of one sampling mode.
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    /// `uniform` or `adaptive`.
    pub mode: &'static str,
    /// Samples per pixel (the mean over the image, for adaptive sampling).
    pub spp: f64,
    /// Wall seconds of each repeat's render (the tree build excluded).
    pub seconds: Vec<f64>,
    /// RMSE against the reference of each repeat's image.
    pub rmse: Vec<f64>,
}

impl Point {
    /// `(median seconds, median RMSE)`.
    pub fn medians(&self) -> (f64, f64) {
        (median(&self.seconds), median(&self.rmse))
    }
}

/// Renders shorter than this (median) are left out of the slope when at least two others
/// remain: their time is mostly fixed overhead (thread wake-ups, the first pass's allocations),
/// not samples.
pub const MIN_FIT_SECONDS: f64 = 0.05;

/// The log-log slope of median RMSE against median seconds of the points of `mode` (those of
/// at least [`MIN_FIT_SECONDS`], if two or more are).
pub fn slope(points: &[Point], mode: &str) -> f64 {
    let xy: Vec<(f64, f64)> = points
        .iter()
        .filter(|p| p.mode == mode)
        .map(Point::medians)
        .collect();
    let long: Vec<(f64, f64)> = xy
        .iter()
        .copied()
        .filter(|p| p.0 >= MIN_FIT_SECONDS)
        .collect();
    log_log_slope(if long.len() >= 2 { &long } else { &xy })
}

/// Writes the report: one row per point, `mode,spp,seconds,rmse` (medians) then the spread.
///
/// # Errors
/// The file cannot be written, naming it.
pub fn write_csv(path: &Path, points: &[Point]) -> Result<()> {
    let mut text = Vec::new();
    let io = |e: std::io::Error| Error::io(path, e);
    writeln!(
        text,
        "mode,spp,seconds,rmse,seconds_min,seconds_max,rmse_min,rmse_max,repeats"
    )
    .map_err(io)?;
    for p in points {
        let (t, e) = p.medians();
        let lo_hi = |v: &[f64]| {
            let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            (lo, hi)
        };
        let ((t0, t1), (e0, e1)) = (lo_hi(&p.seconds), lo_hi(&p.rmse));
        writeln!(
            text,
            "{},{},{t:.6},{e:.6e},{t0:.6},{t1:.6},{e0:.6e},{e1:.6e},{}",
            p.mode,
            p.spp,
            p.seconds.len()
        )
        .map_err(io)?;
    }
    std::fs::write(path, text).map_err(io)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn medians_and_slopes_of_known_data() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), 2.5);
        assert!(median(&[]).is_nan());
        // y = 5 x^-0.5 exactly, and y = 2 x^1.5.
        let pts: Vec<(f64, f64)> = [1.0, 2.0, 4.0, 8.0].map(|x| (x, 5.0 / f64::sqrt(x))).into();
        assert!((log_log_slope(&pts) + 0.5).abs() < 1e-12);
        let pts: Vec<(f64, f64)> = [0.5f64, 3.0, 7.0].map(|x| (x, 2.0 * x * x.sqrt())).into();
        assert!((log_log_slope(&pts) - 1.5).abs() < 1e-12);
        assert!(log_log_slope(&[(1.0, 1.0)]).is_nan());
    }

    #[test]
    fn furnace_radiance_sums_the_bounces() {
        // a = 0.5, Le = 0.5: 0.5 (1 + 0.5 + 0.25) at depth 2, 1 in the limit.
        assert_eq!(furnace_radiance(0.5, 0.5, 2), 0.875);
        assert!((furnace_radiance(0.5, 0.5, 60) - 1.0).abs() < 1e-15);
        let s = furnace_scene();
        assert_eq!(s.materials.len(), 1);
        assert_eq!(s.spheres.len(), 2);
    }
}
