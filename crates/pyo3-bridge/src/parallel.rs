//! Thread-count control for the parallel entry points.

use crate::errors::{Error, Result};

/// Runs `work` on the global rayon pool (`threads = None`) or on a dedicated pool of
/// `threads` workers, so callers can measure scaling or leave cores free. More than
/// four threads per core only adds start-up time and memory, so `threads` is capped
/// there (10,000 threads once took over 100 s to start).
pub fn with_threads<T: Send>(threads: Option<usize>, work: impl FnOnce() -> T + Send) -> Result<T> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    match threads {
        None => Ok(work()),
        Some(0) => Err(Error::Value("threads must be >= 1".to_owned())),
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n.min(4 * cores))
            .build()
            .map(|pool| {
                // `install` runs `work` on a pool thread: hand it the caller's token.
                let token = rperc_core::interrupt::current();
                pool.install(|| rperc_core::interrupt::run_with(token, work))
            })
            .map_err(|e| Error::Value(format!("cannot start {n} threads: {e}"))),
    }
}
