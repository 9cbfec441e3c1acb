//! Thread-count control for the parallel entry points.

use crate::errors::{Error, Result};

/// Runs `work` on the global rayon pool (`threads = None`) or on a dedicated pool of
/// `threads` workers, so callers can measure scaling or leave cores free.
pub fn with_threads<T: Send>(threads: Option<usize>, work: impl FnOnce() -> T + Send) -> Result<T> {
    match threads {
        None => Ok(work()),
        Some(0) => Err(Error::Value("threads must be >= 1".to_owned())),
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map(|pool| pool.install(work))
            .map_err(|e| Error::Value(format!("cannot start {n} threads: {e}"))),
    }
}
