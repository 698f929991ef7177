//! Single rays in turns against one by one: the ray stream with `Turns::Always` and
//! `Turns::Never` (no packets) over the same rays, taking turns chunk by chunk so that the slow
//! phases of a shared machine fall on both; prints each way's median nanoseconds a ray and the
//! median of the chunks' ratios, after checking that both give the same hits bit for bit.
//!
//! ```sh
//! cargo run --release -p kdray-benches --bin turns -- TREE.kdt RAYS.bin [CHUNK] [ROUNDS]
//! ```
//! `TREE.kdt` from `kdray build`, `RAYS.bin` from `kdray rays` (or any rays file); one thread.

use kdray_benches::median;
use kdray_core::format::Scene;
use kdray_core::ray::{Hit, Ray};
use kdray_core::traverse::stream::{self, Config, Packets, Turns};
use std::path::Path;
use std::time::Instant;

type Res<T> = Result<T, Box<dyn core::error::Error>>;

fn run(scene: &Scene, turns: Turns, rays: &[Ray], hits: &mut [Hit], scratch: &mut [u64]) -> f64 {
    let config = Config {
        packets: Packets::Off,
        turns,
        ..Config::default()
    };
    let start = Instant::now();
    if let Err(e) = stream::intersect(scene, &config, rays, hits, scratch) {
        panic!("sized by the caller: {e}");
    }
    start.elapsed().as_secs_f64() * 1e9 / rays.len().max(1) as f64
}

fn main() -> Res<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [tree, rays_path, rest @ ..] = args.as_slice() else {
        return Err("usage: turns TREE.kdt RAYS.bin [CHUNK] [ROUNDS]".into());
    };
    let chunk: usize = rest.first().map_or(Ok(50_000), |s| s.parse())?.max(1);
    let rounds: usize = rest.get(1).map_or(Ok(3), |s| s.parse())?;
    let words = kdray::flat::Aligned::new(&kdray::flat::read_kdt(Path::new(tree))?);
    let scene = Scene::from_words(&words).map_err(|e| format!("{tree}: {e}"))?;
    let rays = kdray::rays::read_rays(Path::new(rays_path))?;
    let mut scratch = vec![0u64; stream::scratch_words(chunk)];
    let (mut a, mut b) = (vec![Hit::MISS; chunk], vec![Hit::MISS; chunk]);
    let (mut one, mut turns, mut ratios) = (vec![], vec![], vec![]);
    let bits = |h: &Hit| (h.t.to_bits(), h.prim, h.u.to_bits(), h.v.to_bits());
    for round in 0..rounds {
        for c in rays.chunks(chunk) {
            let (a, b) = (&mut a[..c.len()], &mut b[..c.len()]);
            let (x, y) = if round % 2 == 0 {
                let x = run(&scene, Turns::Never, c, a, &mut scratch);
                (x, run(&scene, Turns::Always, c, b, &mut scratch))
            } else {
                let y = run(&scene, Turns::Always, c, b, &mut scratch);
                (run(&scene, Turns::Never, c, a, &mut scratch), y)
            };
            if a.iter().zip(b.iter()).any(|(a, b)| bits(a) != bits(b)) {
                return Err("the two ways gave different hits".into());
            }
            one.push(x);
            turns.push(y);
            ratios.push(y / x);
        }
    }
    println!(
        "{} rays, {} bytes walked, isa {}: one by one {:.1} ns a ray, in turns {:.1}; turns ÷ one by one {:.3} (median of {} chunks)",
        rays.len(),
        scene.walked_bytes(),
        kdray_core::isa::name(),
        median(one),
        median(turns),
        median(ratios.clone()),
        ratios.len()
    );
    Ok(())
}
