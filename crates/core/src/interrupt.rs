//! Cooperative interruption of long native loops, so that Ctrl-C reaches a Python caller
//! while rperc works with the GIL released.
//!
//! Python handles a signal only when the main thread runs Python code; a Rust loop that
//! holds the thread for a minute would defer KeyboardInterrupt to its end. Long loops
//! therefore report their progress to a [`Work`] meter, which every
//! [`CHECK_EVERY_UNITS`] units of work calls [`checkpoint`]. The checkpoint reads the
//! thread's [`Interrupt`] (installed by [`run_polled`] or [`run_with`]) and, on the thread
//! that installed a poll, calls that poll at most every [`POLL_INTERVAL`]. A poll that
//! reports a pending signal stops the token; every thread sharing it then returns
//! [`CoreError::Interrupted`] from its next checkpoint.
//!
//! A thread with no token installed (plain Rust use) is never interrupted, and a
//! checkpoint costs one thread-local read.
//!
//! # Examples
//! ```
//! use rperc_core::interrupt::{Work, run_polled};
//!
//! // A poll that reports a signal at once: the loop stops at its first checkpoint.
//! let result = run_polled(|| true, || {
//!     let mut work = Work::new();
//!     for _ in 0..u64::MAX {
//!         work.advance(1_000)?;
//!     }
//!     Ok::<_, rperc_core::CoreError>(())
//! });
//! assert!(matches!(result, Err(rperc_core::CoreError::Interrupted)));
//! ```

use std::cell::RefCell;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use crate::error::CoreError;

/// How often the polling thread asks for pending signals: well inside the 100 ms a
/// user expects Ctrl-C to take.
pub const POLL_INTERVAL: Duration = Duration::from_millis(20);

/// Units of work (about one point-distance evaluation each) between two checkpoints:
/// a few tens of microseconds, so that the checkpoint's own cost is invisible.
pub const CHECK_EVERY_UNITS: u64 = 1 << 15;

/// A stop flag shared by every thread working on one call.
#[derive(Debug, Default)]
pub struct Interrupt {
    stopped: AtomicBool,
}

impl Interrupt {
    /// A token that has not been stopped.
    pub fn new() -> Self {
        Self::default()
    }

    /// Asks every thread sharing this token to stop at its next checkpoint.
    pub fn stop(&self) {
        self.stopped.store(true, Ordering::Relaxed);
    }

    /// Whether [`Self::stop`] was called.
    pub fn is_stopped(&self) -> bool {
        self.stopped.load(Ordering::Relaxed)
    }
}

/// What a thread has installed: the shared token and, on the polling thread, the poll.
struct Installed {
    token: Arc<Interrupt>,
    poll: Option<Box<dyn FnMut() -> bool>>,
    last_poll: Instant,
}

thread_local! {
    static CURRENT: RefCell<Option<Installed>> = const { RefCell::new(None) };
}

/// Restores the previously installed token when a run ends, also by unwinding.
struct Restore(Option<Installed>);

impl Drop for Restore {
    fn drop(&mut self) {
        let previous = self.0.take();
        CURRENT.with(|c| *c.borrow_mut() = previous);
    }
}

fn install<R>(installed: Installed, work: impl FnOnce() -> R) -> R {
    let previous = CURRENT.with(|c| c.borrow_mut().replace(installed));
    let _restore = Restore(previous);
    work()
}

/// Runs `work` on this thread with a fresh token; checkpoints on this thread call
/// `poll` at most every [`POLL_INTERVAL`], and a `true` from it stops the token.
pub fn run_polled<R>(poll: impl FnMut() -> bool + 'static, work: impl FnOnce() -> R) -> R {
    let installed = Installed {
        token: Arc::new(Interrupt::new()),
        poll: Some(Box::new(poll)),
        last_poll: Instant::now(),
    };
    install(installed, work)
}

/// Runs `work` on this thread under `token` (a worker of a call whose token another
/// thread stops); `None` runs it uninterruptible.
pub fn run_with<R>(token: Option<Arc<Interrupt>>, work: impl FnOnce() -> R) -> R {
    match token {
        Some(token) => install(
            Installed {
                token,
                poll: None,
                last_poll: Instant::now(),
            },
            work,
        ),
        None => work(),
    }
}

/// The token of this thread's call, to hand to the threads it starts.
pub fn current() -> Option<Arc<Interrupt>> {
    CURRENT.with(|c| c.borrow().as_ref().map(|i| Arc::clone(&i.token)))
}

/// Returns [`CoreError::Interrupted`] if this thread's call was asked to stop, polling
/// for signals first when this is the polling thread and the interval has passed.
pub fn checkpoint() -> Result<(), CoreError> {
    // The poll may run Python signal handlers, which may call rperc again on this
    // thread: it runs with the slot released, taken out and put back afterwards.
    let due = CURRENT.with(|c| {
        let mut slot = c.borrow_mut();
        let installed = slot.as_mut()?;
        if installed.poll.is_none() || installed.last_poll.elapsed() < POLL_INTERVAL {
            return None;
        }
        installed.last_poll = Instant::now();
        installed.poll.take()
    });
    let signalled = due.map(|mut poll| {
        let hit = poll();
        CURRENT.with(|c| {
            if let Some(installed) = c.borrow_mut().as_mut() {
                installed.poll = Some(poll);
            }
        });
        hit
    });
    CURRENT.with(|c| {
        let slot = c.borrow();
        let Some(installed) = slot.as_ref() else {
            return Ok(());
        };
        if signalled == Some(true) {
            installed.token.stop();
        }
        match installed.token.is_stopped() {
            true => Err(CoreError::Interrupted),
            false => Ok(()),
        }
    })
}

/// Counts the work a loop has done and calls [`checkpoint`] every
/// [`CHECK_EVERY_UNITS`] units, so loops of any granularity pay the same small cost.
#[derive(Debug, Clone, Default)]
pub struct Work {
    since_check: u64,
}

impl Work {
    /// A meter with nothing counted yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Records `units` of work; at the threshold, checks for an interrupt.
    #[inline]
    pub fn advance(&mut self, units: u64) -> Result<(), CoreError> {
        self.since_check = self.since_check.saturating_add(units);
        if self.since_check < CHECK_EVERY_UNITS {
            return Ok(());
        }
        self.since_check = 0;
        checkpoint()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::AtomicUsize;

    #[test]
    fn without_a_token_nothing_is_interrupted() {
        let mut work = Work::new();
        for _ in 0..1000 {
            work.advance(CHECK_EVERY_UNITS).unwrap();
        }
        assert!(current().is_none());
    }

    #[test]
    fn the_poll_is_rate_limited_and_restored_after_the_run() {
        let calls = Arc::new(AtomicUsize::new(0));
        let seen = Arc::clone(&calls);
        let out = run_polled(
            move || {
                seen.fetch_add(1, Ordering::Relaxed);
                false
            },
            || {
                // Many checkpoints well inside one interval: at most one poll.
                for _ in 0..10_000 {
                    checkpoint().unwrap();
                }
                current().is_some()
            },
        );
        assert!(out);
        assert!(calls.load(Ordering::Relaxed) <= 1);
        assert!(current().is_none(), "the token must not outlive its run");
    }

    #[test]
    fn a_stopped_token_stops_worker_threads() {
        let token = Arc::new(Interrupt::new());
        token.stop();
        let shared = Some(Arc::clone(&token));
        let r = std::thread::spawn(move || run_with(shared, checkpoint))
            .join()
            .unwrap();
        assert!(matches!(r, Err(CoreError::Interrupted)));
    }

    #[test]
    fn a_panic_inside_a_run_restores_the_previous_token() {
        let r = std::panic::catch_unwind(|| run_polled(|| false, || panic!("boom")));
        assert!(r.is_err());
        assert!(current().is_none());
    }
}
