//! The machine a run is on, for the figures a user compares: the CPU's model name and the best
//! instruction set of [`kdray_core::isa::name`]'s ladder that the CPU supports, detected at run
//! time. `kdray_core::isa::name` is what the build was compiled for (`wide` picks its lanes at
//! compile time); when the two differ, a build for this CPU would be faster (README, "Building
//! from source": the default source build compiles for the CPU that builds it).

/// The best of `avx512f`, `avx2+fma`, `avx2`, `avx`, `sse4.1`, `sse2` that this x86 CPU supports, `neon` on
/// AArch64; elsewhere (wasm32, other architectures) what the build has,
/// [`kdray_core::isa::name`].
pub fn isa() -> &'static str {
    #[cfg(any(target_arch = "x86", target_arch = "x86_64"))]
    {
        use std::arch::is_x86_feature_detected as has;
        if has!("avx512f") && has!("avx2") && has!("fma") {
            return "avx512f";
        } else if has!("avx2") && has!("fma") {
            return "avx2+fma";
        } else if has!("avx2") {
            return "avx2";
        } else if has!("avx") {
            return "avx";
        } else if has!("sse4.1") {
            return "sse4.1";
        } else if has!("sse2") {
            return "sse2";
        }
    }
    #[cfg(target_arch = "aarch64")]
    if std::arch::is_aarch64_feature_detected!("neon") {
        return "neon";
    }
    kdray_core::isa::name()
}

/// The CPU's model name (`model name` in `/proc/cpuinfo`, e.g. `AMD EPYC`), where the system
/// says it; `None` elsewhere.
pub fn model() -> Option<String> {
    let text = std::fs::read_to_string("/proc/cpuinfo").ok()?;
    text.lines()
        .filter_map(|line| line.split_once(':'))
        .find(|(key, _)| key.trim() == "model name")
        .map(|(_, value)| value.trim().to_string())
        .filter(|model| !model.is_empty())
}

/// One line for `kdray --version` and the benchmark reports: what the build uses and what the CPU
/// has, e.g. `isa=avx2+fma (this CPU: AMD EPYC, avx2+fma)`, with a hint when the build uses
/// less than the CPU has.
pub fn describe() -> String {
    let (build, cpu) = (kdray_core::isa::name(), isa());
    let model = model().unwrap_or_else(|| "model unknown".to_string());
    let hint = if build == cpu {
        ""
    } else {
        "; a build for this CPU is faster: README, \"Building from source\""
    };
    format!("isa={build} (this CPU: {model}, {cpu}{hint})")
}

/// The CPU time the process (all its threads, user and system) has used, in ms to the kernel's
/// tick (10 ms), from Linux's `/proc/self/stat`; `None` elsewhere. On a loaded machine a serial
/// build's CPU time varies less than its wall time.
pub fn process_ms() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // The fields after the command name (in parentheses, which may hold spaces): state is the
    // 3rd field of the line, utime and stime the 14th and 15th, in ticks of 1/100 s (USER_HZ).
    let fields: Vec<&str> = stat.rsplit_once(')')?.1.split_whitespace().collect();
    let ticks = |i: usize| fields.get(i)?.parse::<u64>().ok();
    Some((ticks(11)? + ticks(12)?) as f64 * 10.0)
}
