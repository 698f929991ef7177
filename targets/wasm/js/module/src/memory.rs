//! The module's allocator: std's (on wasm32 `dlmalloc`), wrapped to remember the last allocation
//! that failed. An allocation failure in code that cannot recover from it (the builder's
//! vectors) aborts, which in WebAssembly is a trap; the package then reads
//! [`kdj_failed_alloc`](crate::kdj_failed_alloc) from the trapped instance (its memory and
//! globals stay readable) to say "out of memory" with the size instead of "unreachable". The
//! package builds in an instance of its own, so such a trap never reaches the scenes' instance.
//!
//! Calls that can recover (`kdj_alloc`, `kdj_load`, `kdj_raycast_many`) reserve with
//! [`try_reserve`] and return [`OUT_OF_MEMORY`] instead.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicU32, Ordering};

/// The failure code of a call that could not get the memory it needs.
pub const OUT_OF_MEMORY: i32 = -4;

static FAILED: AtomicU32 = AtomicU32::new(0);

/// The size in bytes of the last allocation that failed (saturated at `u32::MAX`), or 0.
pub fn failed() -> u32 {
    FAILED.load(Ordering::Relaxed)
}

/// Forgets an earlier failure (of a call that recovered from it), before work that may abort.
pub fn clear_failed() {
    FAILED.store(0, Ordering::Relaxed);
}

struct Recording;

fn record(p: *mut u8, size: usize) -> *mut u8 {
    if p.is_null() {
        FAILED.store(u32::try_from(size).unwrap_or(u32::MAX), Ordering::Relaxed);
    }
    p
}

// SAFETY: every call is forwarded to `System` unchanged; only a null result is noted.
unsafe impl GlobalAlloc for Recording {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller's contract, forwarded.
        record(unsafe { System.alloc(layout) }, layout.size())
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: as above.
        record(unsafe { System.alloc_zeroed(layout) }, layout.size())
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: as above.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: as above.
        record(unsafe { System.realloc(ptr, layout, new_size) }, new_size)
    }
}

#[global_allocator]
static ALLOCATOR: Recording = Recording;

/// Makes room for `n` more elements in `v`, or says how much memory `what` needed.
pub fn try_reserve<T>(v: &mut Vec<T>, n: usize, what: &str) -> Result<(), (i32, String)> {
    v.try_reserve(n.saturating_sub(v.len())).map_err(|_| {
        let bytes = (n as u64).saturating_mul(size_of::<T>() as u64);
        (
            OUT_OF_MEMORY,
            format!(
                "out of memory: {what} need {bytes} bytes more of the module's memory \
                 (WebAssembly's limit: 4 GiB)"
            ),
        )
    })
}
