//! The threads batch work runs on: rayon pools the package makes, kept between calls, never
//! rayon's global pool.
//!
//! - **Bounded.** One pool of a thread a core (calls without `threads`), and one pool for the
//!   last other `threads=k`, replaced when a call asks for another `k`: its threads are told to
//!   end and, unless another call is still using it, waited for. A pool per distinct `k`, kept
//!   for ever, once held 813 threads after `k` = 1 … 40. `k` is at most [`max_threads`] (16 a
//!   core, as the command line's `--threads`).
//! - **Fork-safe.** A forked child (Python's `multiprocessing` with `fork`) inherits the pools'
//!   memory but not their threads: a job handed to them would wait for ever. Each pool records
//!   the process that built it; in another process it is abandoned (leaked: dropping it would
//!   wake threads that do not exist here) and built again. rayon's global pool cannot be
//!   rebuilt, so no batch, check or build may use it: work runs inside [`on_pool`], and the
//!   calling thread's fast path for small batches makes no parallel call.

use crate::stop::Stop;
use rayon::ThreadPool;
use std::sync::{Arc, Condvar, Mutex};

/// A pool, the process that built it, and its threads still running.
struct Kept {
    pid: u32,
    threads: usize,
    pool: Arc<ThreadPool>,
    live: Arc<Live>,
}

/// A pool's threads that have not ended yet (counted down by each as it ends).
struct Live {
    count: Mutex<usize>,
    ended: Condvar,
}

impl Live {
    fn wait_for_all(&self) {
        let mut n = self.count.lock().unwrap_or_else(|e| e.into_inner());
        while *n > 0 {
            n = self.ended.wait(n).unwrap_or_else(|e| e.into_inner());
        }
    }
}

/// The pool of a thread a core, and the one for another thread count.
static PER_CORE: Mutex<Option<Kept>> = Mutex::new(None);
static OTHER: Mutex<Option<Kept>> = Mutex::new(None);

/// The machine's cores (at least 1).
pub fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, usize::from)
}

/// The largest `threads=` accepted: 16 a core.
pub fn max_threads() -> usize {
    16 * cores()
}

/// The pool for `threads` (`None`: a thread a core), built if this process has none of that
/// size.
///
/// # Errors
/// `threads` is 0 or above [`max_threads`]; the threads cannot be started.
pub fn get(threads: Option<usize>) -> Result<Arc<ThreadPool>, Stop> {
    let n = threads.unwrap_or_else(cores);
    if !(1..=max_threads()).contains(&n) {
        return Err(Stop::Value(format!(
            "threads={n}: it must be from 1 to {} (16 a core)",
            max_threads()
        )));
    }
    let slot = if n == cores() { &PER_CORE } else { &OTHER };
    let mut kept = slot.lock().unwrap_or_else(|e| e.into_inner());
    let pid = std::process::id();
    if let Some(k) = kept.take() {
        if k.pid != pid {
            // Built before a fork: its threads are not in this process.
            std::mem::forget(k.pool);
        } else if k.threads == n {
            let pool = k.pool.clone();
            *kept = Some(k);
            return Ok(pool);
        } else if let Ok(pool) = Arc::try_unwrap(k.pool) {
            // No call is using it: its threads end now, and are waited for.
            drop(pool);
            k.live.wait_for_all();
        }
        // Otherwise its threads end once the calls using it are done.
    }
    let live = Arc::new(Live {
        count: Mutex::new(n),
        ended: Condvar::new(),
    });
    let ending = live.clone();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .thread_name(|i| format!("kdray-{i}"))
        .exit_handler(move |_| {
            let mut count = ending.count.lock().unwrap_or_else(|e| e.into_inner());
            *count -= 1;
            ending.ended.notify_all();
        })
        .build()
        .map_err(|e| Stop::Value(format!("threads={n}: the threads cannot be started: {e}")))?;
    let pool = Arc::new(pool);
    *kept = Some(Kept {
        pid,
        threads: n,
        pool: pool.clone(),
        live,
    });
    Ok(pool)
}

/// Runs `f` on the pool for `threads` ([`get`]), waiting for it.
///
/// # Errors
/// As [`get`].
pub fn on_pool<T: Send>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> Result<T, Stop> {
    Ok(get(threads)?.install(f))
}
