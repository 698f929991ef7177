//! The subcommands behind `main`.

mod accuracy;
mod build;
mod converge;
mod hits;
mod merge;
mod render;
mod trace;
mod trace_instanced;

pub use accuracy::{AccuracyArgs, accuracy};
pub use build::{BuildArgs, build, info};
pub use converge::{ConvergeArgs, converge};
pub use hits::{HitsArgs, hits};
pub use merge::merge;
pub use render::{RenderArgs, render};
pub use trace::{RayKind, TraceArgs, rays, trace};

use kdray::error::{Error, Result};
use std::path::Path;

/// Runs `work` on its own thread while this one updates `bar` from `position()` every 20 ms,
/// once the work has taken more than half a second (short jobs show no bar); clears the bar and
/// returns what `work` returned.
fn with_progress<T: Send>(
    bar: &indicatif::ProgressBar,
    position: impl Fn() -> u64,
    work: impl FnOnce() -> T + Send,
) -> T {
    use core::time::Duration;
    let start = std::time::Instant::now();
    let result = std::thread::scope(|s| {
        let worker = s.spawn(work);
        while !worker.is_finished() {
            std::thread::sleep(Duration::from_millis(20));
            if start.elapsed() > Duration::from_millis(500) {
                bar.set_position(position());
            }
        }
        worker.join().expect("worker thread panicked")
    });
    bar.finish_and_clear();
    result
}

/// The most pixels an image (or a `kdray rays` set: 2²⁶ rays, 2 GiB) may have.
pub(crate) use kdray::image::MAX_PIXELS;

/// Parses `WxH`.
pub fn parse_size(s: &str) -> core::result::Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("expected WxH, got '{s}'"))?;
    let parse = |v: &str| {
        v.trim()
            .parse::<u32>()
            .ok()
            .filter(|&n| (1..=65536).contains(&n))
    };
    match (parse(w), parse(h)) {
        (Some(w), Some(h)) if u64::from(w) * u64::from(h) <= MAX_PIXELS => Ok((w, h)),
        (Some(w), Some(h)) => Err(format!(
            "{w}x{h} is {} pixels; at most {MAX_PIXELS} (a {} MiB ray file) are written",
            u64::from(w) * u64::from(h),
            (MAX_PIXELS * 32) >> 20
        )),
        _ => Err(format!(
            "sizes must be whole numbers from 1 to 65536, got '{s}'"
        )),
    }
}

/// Threads per core `--threads` accepts: more only adds switching (and 100,000 threads take
/// minutes to start).
const THREADS_PER_CORE: usize = 16;

/// Parses `--threads`: 1 to [`THREADS_PER_CORE`] times the cores (a usage error otherwise).
pub fn parse_threads(s: &str) -> core::result::Result<usize, String> {
    let cores = std::thread::available_parallelism().map_or(1, usize::from);
    let max = THREADS_PER_CORE * cores;
    match s.trim().parse::<usize>() {
        Ok(n) if (1..=max).contains(&n) => Ok(n),
        _ => Err(format!(
            "threads must be a whole number from 1 to {max} ({THREADS_PER_CORE} per core), got '{s}'"
        )),
    }
}

/// A thread pool of `threads` workers (default: all cores; `--threads` is checked by
/// [`parse_threads`]); `path` names the input in errors.
pub(crate) fn pool(path: &Path, threads: Option<usize>) -> Result<rayon::ThreadPool> {
    let mut b = rayon::ThreadPoolBuilder::new();
    if let Some(n) = threads {
        b = b.num_threads(n);
    }
    b.build()
        .map_err(|e| Error::new(path, format!("cannot start threads: {e}")))
}
