//! The subcommands behind `main`.

mod build;
mod render;
mod trace;

pub use build::{BuildArgs, build, info};
pub use render::{RenderArgs, render};
pub use trace::{RayKind, TraceArgs, parse_size, rays, trace};

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
