//! Times loading a saved tree: `Scene::from_words` on a `.kdt` file's words, the validation every
//! file from outside goes through (issue 38: at most 10 % of the same tree's build time). The
//! file is read and aligned once, untimed; each repeat validates the same words.
//!
//! ```sh
//! cargo run --release -p kdray --example load -- dragon.kdt 7
//! ```
//! prints each repeat's milliseconds, their median and the median of the process's CPU time per
//! load (`kdray build` prints `build_ms` and `cpu_ms` alike; on a busy machine the CPU time is
//! the steadier of the two). With a repeat count of 1 it is the
//! program to run under `valgrind --tool=callgrind` (the instructions of one load, plus reading
//! the file).

use kdray_core::Scene;
use std::time::Instant;

fn main() -> Result<(), Box<dyn core::error::Error>> {
    let mut args = std::env::args().skip(1);
    let path = args.next().ok_or("usage: load FILE.kdt [REPEATS]")?;
    let repeats: usize = args.next().map_or(Ok(5), |s| s.parse())?;
    let bytes = std::fs::read(&path)?;
    if !bytes.len().is_multiple_of(4) {
        return Err(format!("{path}: not a whole number of words").into());
    }
    let words: Vec<u32> = bytes
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    drop(bytes);
    // As `kdray trace` holds them: the wide section on cache lines.
    let words = kdray::flat::Aligned::new(&words);
    let (mut ms, mut cpu) = (Vec::with_capacity(repeats), Vec::with_capacity(repeats));
    for _ in 0..repeats {
        let (start, cpu_start) = (Instant::now(), kdray::cpu::process_ms());
        let scene = Scene::from_words(&words).map_err(|e| format!("{path}: {e}"))?;
        ms.push(start.elapsed().as_secs_f64() * 1e3);
        cpu.push(kdray::cpu::process_ms().zip(cpu_start).map(|(b, a)| b - a));
        core::hint::black_box(&scene);
    }
    let line: Vec<String> = ms.iter().map(|m| format!("{m:.1}")).collect();
    ms.sort_by(f64::total_cmp);
    let mut cpu: Vec<_> = cpu.into_iter().flatten().collect();
    cpu.sort_by(f64::total_cmp);
    println!(
        "{path}: {} words, load_ms {} (median {:.1}), cpu_ms median {}",
        words.len(),
        line.join(" "),
        ms[ms.len() / 2],
        cpu.get(cpu.len() / 2)
            .map_or("-".to_string(), |c| format!("{c:.0}")),
    );
    Ok(())
}
