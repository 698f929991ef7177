//! Why a call stopped without an answer, and the Python exception each reason becomes.
//!
//! Most refusals are a sentence about the input (`ValueError`). Two are not about the input:
//! memory that cannot be had for a size the input asks for (`MemoryError`: the allocation is made
//! with `try_reserve`, so it fails instead of aborting the interpreter), and Ctrl-C while the
//! work ran (the `KeyboardInterrupt` that Python's signal check raised, `run::detached`).

use pyo3::PyErr;
use pyo3::exceptions::{PyMemoryError, PyValueError};

/// A call's failure (module doc).
#[derive(Debug)]
pub enum Stop {
    /// The input is refused: the sentence says why, naming the argument.
    Value(String),
    /// `bytes` of memory for `what` could not be allocated.
    Memory { what: String, bytes: u64 },
    /// A signal handler raised this (`KeyboardInterrupt` for Ctrl-C) while the work ran.
    Signal(PyErr),
}

impl From<String> for Stop {
    fn from(msg: String) -> Self {
        Stop::Value(msg)
    }
}

impl From<Stop> for PyErr {
    fn from(stop: Stop) -> Self {
        match stop {
            Stop::Value(msg) => PyValueError::new_err(msg),
            Stop::Memory { what, bytes } => PyMemoryError::new_err(format!(
                "{what}: {} MiB of memory needed, which cannot be allocated here (out of \
                 memory, or an address-space limit)",
                bytes.div_ceil(1 << 20)
            )),
            Stop::Signal(e) => e,
        }
    }
}

/// A vector of `n` copies of `x`, or [`Stop::Memory`] naming `what` if it cannot be allocated.
///
/// # Errors
/// The allocator refuses `n` elements.
pub fn filled<T: Clone>(n: usize, x: T, what: &str) -> Result<Vec<T>, Stop> {
    let mut v = Vec::new();
    reserve(&mut v, n, what)?;
    v.resize(n, x);
    Ok(v)
}

/// Reserves room for `n` more elements in `v`, or [`Stop::Memory`] naming `what`.
///
/// # Errors
/// The allocator refuses.
pub fn reserve<T>(v: &mut Vec<T>, n: usize, what: &str) -> Result<(), Stop> {
    v.try_reserve_exact(n).map_err(|_| Stop::Memory {
        what: what.to_string(),
        bytes: (n as u64).saturating_mul(size_of::<T>() as u64),
    })
}

/// Checks that `bytes` can be allocated now for `what` (a probe, as the host's
/// `memory::ensure`: a fresh mapping, never touched, freed at once), for work whose peak is
/// known from its size but made of allocations that cannot all be fallible (the builder's).
///
/// # Errors
/// The allocator refuses `bytes`.
pub fn probe(bytes: u64, what: &str) -> Result<(), Stop> {
    let fits = usize::try_from(bytes)
        .ok()
        .is_some_and(|n| Vec::<u8>::new().try_reserve_exact(n).is_ok());
    if fits {
        Ok(())
    } else {
        Err(Stop::Memory {
            what: what.to_string(),
            bytes,
        })
    }
}
