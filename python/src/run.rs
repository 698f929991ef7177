//! Batch work without the GIL that Ctrl-C can stop.
//!
//! Python runs a signal's handler (Ctrl-C's raises `KeyboardInterrupt`) only on the main thread,
//! and only when that thread runs Python code or calls `PyErr_CheckSignals`. A batch call
//! releases the GIL and waits for the pool: before this module, Ctrl-C waited until the batch
//! ended (53 s for `count_intersections` of 600 K rays). Now the calling thread hands the work
//! to the pool and, while waiting for it, takes the GIL back every [`POLL`] to check for
//! signals; when a handler raises, the work's `cancel` flag is set, the walks stop at their next
//! ray or piece (they test it between rays and pieces), and the call raises what the handler
//! raised. Its outputs are dropped: a stopped call has no answer.

use crate::pool;
use crate::stop::Stop;
use pyo3::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::time::Duration;

/// How often the waiting thread checks for signals.
const POLL: Duration = Duration::from_millis(20);

/// Whether the work should stop: Ctrl-C (or another signal whose handler raised).
pub type Cancel = AtomicBool;

/// Whether `cancel` is set.
#[inline]
pub fn cancelled(cancel: &Cancel) -> bool {
    cancel.load(Ordering::Relaxed)
}

/// Runs `work` on the pool for `threads` without the GIL, checking for signals while it runs
/// (module doc).
///
/// # Errors
/// `work`'s; [`Stop::Signal`] with the handler's exception if a signal's handler raised; the
/// pool's ([`pool::get`]).
pub fn detached<T: Send>(
    py: Python<'_>,
    threads: Option<usize>,
    work: impl FnOnce(&Cancel) -> Result<T, Stop> + Send,
) -> Result<T, Stop> {
    let cancel = Cancel::new(false);
    py.detach(|| {
        let pool = pool::get(threads)?;
        let (tx, rx) = mpsc::channel();
        let cancel = &cancel;
        pool.in_place_scope(|s| {
            s.spawn(move |_| {
                let _ = tx.send(work(cancel));
            });
            loop {
                match rx.recv_timeout(POLL) {
                    Ok(answer) => return answer,
                    Err(mpsc::RecvTimeoutError::Timeout) => {
                        if let Err(e) = Python::attach(|py| py.check_signals()) {
                            cancel.store(true, Ordering::Relaxed);
                            return Err(Stop::Signal(e));
                        }
                    }
                    // The work panicked: the scope's end carries the panic on.
                    Err(mpsc::RecvTimeoutError::Disconnected) => {
                        return Err(Stop::Value("the work stopped".to_string()));
                    }
                }
            }
        })
    })
}
