//! kdray-core on a Cortex-M4F: renders a scene built on the host and embedded in the image, prints
//! a checksum of the pixels over semihosting, and exits with a status (0: rendered, 1: the
//! embedded data was refused). No allocator, no `unsafe`.
//!
//! `run.sh` builds the scene (`kdray build SCENE.toml --description`) into `$KDRAY_FW_SCENE`,
//! with `settings.rs` (image size and samples), and runs this under
//! `qemu-system-arm -machine mps2-an386`. The host renders the same scene with
//! `kdray render --checksum`; the two checksums must be equal.
//!
//! What the firmware names is what it links (cargo features): the primitive kinds of its scene
//! (`triangles`, `spheres` or `mixed`, the traversal kernel of [`render_rows_with`]) and its camera
//! (`pinhole`, or `any-camera` for every kind a description may hold).
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hprintln};
use kdray_core::Scene;
use kdray_core::description::Description;
use kdray_core::render::{kernel_fits, render_rows_with};
use kdray_core::words::{self, Fnv1a};

// `Prims` (the traversal kernel) and `Cam` (the camera) from this crate's features.
kdray_core::target_types!();

/// `WIDTH`, `HEIGHT`, `SPP`: written by `build.rs` from `KDRAY_FW_SIZE` and `KDRAY_FW_SPP`.
mod settings {
    include!(concat!(env!("OUT_DIR"), "/settings.rs"));
}

/// The widest image this firmware renders (one row of pixels lives on the stack).
const MAX_WIDTH: usize = 256;

static SCENE: &[u8] = kdray_core::include_words!(concat!(env!("KDRAY_FW_SCENE"), "/scene.kdt"));
static DESCRIPTION: &[u8] =
    kdray_core::include_words!(concat!(env!("KDRAY_FW_SCENE"), "/scene.kdr"));

#[entry]
fn main() -> ! {
    match render() {
        Ok((checksum, tris, spheres)) => {
            hprintln!(
                "checksum={:08x} size={}x{} spp={} triangles={} spheres={}",
                checksum,
                settings::WIDTH,
                settings::HEIGHT,
                settings::SPP,
                tris,
                spheres
            );
            debug::exit(debug::EXIT_SUCCESS);
        }
        Err(msg) => {
            hprintln!("error: {}", msg);
            debug::exit(debug::EXIT_FAILURE);
        }
    }
    // Not reached under QEMU (semihosting exit ends it); on a board, stop here.
    loop {
        cortex_m::asm::wfi();
    }
}

/// Renders the embedded scene row by row; returns the checksum of its linear pixels and its
/// triangle and sphere counts.
fn render() -> Result<(u32, u32, u32), &'static str> {
    let scene_words = words::from_bytes(SCENE).map_err(|_| "scene: not whole aligned words")?;
    let desc_words =
        words::from_bytes(DESCRIPTION).map_err(|_| "description: not whole aligned words")?;
    let scene = Scene::from_words(scene_words).map_err(|_| "scene: refused by from_words")?;
    if !kernel_fits::<Prims>(&scene) {
        return Err("scene: holds primitives this firmware leaves out");
    }
    let desc = Description::from_words(desc_words, &scene, scene_words)
        .map_err(|_| "description: refused")?;
    let camera: Cam = desc
        .camera()
        .map_err(|_| "description: not this firmware's camera")?;
    let mut settings = desc.settings();
    (settings.width, settings.height, settings.spp) =
        (settings::WIDTH, settings::HEIGHT, settings::SPP);
    if settings.width as usize > MAX_WIDTH {
        return Err("image wider than MAX_WIDTH");
    }
    let mut row = [[0.0f32; 3]; MAX_WIDTH];
    let row = &mut row[..settings.width as usize];
    let mut checksum = Fnv1a::default();
    #[cfg(feature = "ticks")]
    let mut ticks = ticks::Ticks::start().ok_or("SysTick already taken")?;
    for y in 0..settings.height {
        #[cfg(feature = "ticks")]
        let t0 = ticks::Ticks::now();
        // Every ray through the scalar walk (`Bounces::SingleRays`): on an M4F `wide` emulates
        // a packet's lanes in scalar code, and `PACKETS = false` links no packet code.
        render_rows_with::<Prims, Cam, false>(
            &scene,
            &camera,
            desc.materials(),
            desc.lights(),
            &settings,
            y,
            row,
        )
        .map_err(|_| "render_rows refused the settings")?;
        #[cfg(feature = "ticks")]
        ticks.add_since(t0);
        checksum.pixels(row);
    }
    #[cfg(feature = "ticks")]
    hprintln!("ticks={}", ticks.total);
    Ok((checksum.0, scene.tri_count(), scene.sphere_count()))
}

/// SysTick as a tick counter (feature `ticks`): the render's rows are timed in core-clock ticks.
/// Under QEMU with `-icount shift=0` the virtual clock advances 1 ns per instruction and the
/// mps2-an386's core clock is 25 MHz, so a tick is 40 instructions (`instructions.sh`).
#[cfg(feature = "ticks")]
mod ticks {
    use cortex_m::peripheral::SYST;
    use cortex_m::peripheral::syst::SystClkSource;

    /// The 24-bit down-counter's range.
    const MASK: u32 = 0x00FF_FFFF;

    pub struct Ticks {
        pub total: u64,
    }

    impl Ticks {
        /// Starts SysTick free-running on the core clock; `None` if the peripherals were taken.
        pub fn start() -> Option<Self> {
            let mut syst = cortex_m::Peripherals::take()?.SYST;
            syst.set_clock_source(SystClkSource::Core);
            syst.set_reload(MASK);
            syst.clear_current();
            syst.enable_counter();
            Some(Self { total: 0 })
        }

        pub fn now() -> u32 {
            SYST::get_current()
        }

        /// Adds the ticks since `t0` (a span shorter than one wrap, 2^24 ticks).
        pub fn add_since(&mut self, t0: u32) {
            self.total += u64::from(t0.wrapping_sub(Self::now()) & MASK);
        }
    }
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    // The core never panics on any input; should anything else, report it and stop.
    hprintln!("error: panic");
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}
