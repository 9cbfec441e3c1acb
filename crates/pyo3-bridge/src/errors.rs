//! The one mapping from core-crate errors to Python exceptions.
//!
//! The crates classify their own errors ([`rperc_core::ErrorClass`]); this module only
//! turns each class into an exception: a bad argument is `ValueError` (or `TypeError`
//! for a wrong type), a numerical failure `rperc.NumericalError`, an unreadable file
//! `OSError`, and a caught panic `rperc.RpercError`.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

use pyo3::exceptions::{
    PyException, PyKeyboardInterrupt, PyMemoryError, PyOSError, PyTypeError, PyValueError,
};
use pyo3::prelude::*;
use pyo3::{PyErr, create_exception};
use rperc_core::{ErrorClass, interrupt};

create_exception!(
    _rperc,
    RpercError,
    PyException,
    "Base class of rperc's own errors (those that are not a plain bad value or dtype)."
);
create_exception!(
    _rperc,
    NumericalError,
    RpercError,
    "A numerical failure: a singular or non-finite matrix, a filter that diverged."
);

/// Every error a bridge function can return before it becomes a Python exception.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A bad value: wrong shape, NaN, a negative tolerance, an unknown option.
    #[error("{0}")]
    Value(String),
    /// A wrong dtype or Python type.
    #[error("{0}")]
    Type(String),
    /// From the shared core.
    #[error(transparent)]
    Core(#[from] rperc_core::CoreError),
    /// From the line-simplification crate.
    #[error(transparent)]
    LineSimp(#[from] linesimp::LineSimpError),
    /// From the SLAM crate.
    #[error(transparent)]
    Slam(#[from] slam::SlamError),
    /// From the tracking crate.
    #[error(transparent)]
    Tracking(#[from] tracking::TrackingError),
    /// From the laser SLAM crate.
    #[error(transparent)]
    Laser(#[from] laser::LaserError),
    /// From the navigation crate (visual memory, ceiling world).
    #[error(transparent)]
    Navigation(#[from] navigation::NavigationError),
    /// A Python exception raised while reading the arguments; re-raised as it is.
    #[error("{0}")]
    Python(#[from] PyErr),
    /// A Rust panic caught at the boundary: a bug, reported rather than crashing Python.
    #[error("internal error in rperc (please report it): {0}")]
    Panic(String),
}

impl Error {
    fn class(&self) -> Option<ErrorClass> {
        match self {
            Error::Core(e) => Some(e.class()),
            Error::LineSimp(e) => Some(e.class()),
            Error::Slam(e) => Some(e.class()),
            Error::Tracking(e) => Some(e.class()),
            Error::Laser(e) => Some(e.class()),
            Error::Navigation(e) => Some(e.class()),
            Error::Value(_) => Some(ErrorClass::InvalidInput),
            Error::Type(_) | Error::Panic(_) | Error::Python(_) => None,
        }
    }
}

impl From<Error> for PyErr {
    fn from(err: Error) -> PyErr {
        if let Error::Python(e) = err {
            return e;
        }
        let msg = err.to_string();
        match (&err, err.class()) {
            (Error::Type(_), _) => PyTypeError::new_err(msg),
            (Error::Panic(_), _) => RpercError::new_err(msg),
            (_, Some(ErrorClass::Numerical)) => NumericalError::new_err(msg),
            (_, Some(ErrorClass::Io)) => PyOSError::new_err(msg),
            (_, Some(ErrorClass::Memory)) => PyMemoryError::new_err(msg),
            (_, Some(ErrorClass::Interrupted)) => PyKeyboardInterrupt::new_err(msg),
            _ => PyValueError::new_err(msg),
        }
    }
}

/// `count` items of `bytes_each` bytes as the core crates check them
/// ([`rperc_core::check_allocation`]): `MemoryError` naming `name` when over the
/// limit. The Python layer's own allocations (a fix every `fix_interval` seconds)
/// obey the same limit through this one check.
#[pyfunction]
pub fn check_allocation(name: &str, count: u128, bytes_each: u128) -> PyResult<()> {
    rperc_core::check_allocation("count", count, bytes_each).map_err(|e| match e {
        rperc_core::CoreError::TooLarge { bytes, limit, .. } => {
            PyMemoryError::new_err(rperc_core::too_large(name, count, bytes, limit))
        }
        other => Error::Core(other).into(),
    })
}

/// Exclusive access to a native object for a mutating call. PyO3 refuses a second
/// concurrent borrow with a bare "Already borrowed"; this says what to do instead.
pub fn exclusive<'py, T>(slf: &Bound<'py, T>) -> PyResult<pyo3::PyRefMut<'py, T>>
where
    T: pyo3::PyClass<Frozen = pyo3::pyclass::boolean_struct::False>,
{
    slf.try_borrow_mut().map_err(|_| in_use(slf.as_any()))
}

/// Shared access to a native object for a reading call (refused while another thread
/// is inside a mutating call).
pub fn shared<'py, T: pyo3::PyClass>(slf: &Bound<'py, T>) -> PyResult<pyo3::PyRef<'py, T>> {
    slf.try_borrow().map_err(|_| in_use(slf.as_any()))
}

fn in_use(obj: &Bound<'_, PyAny>) -> PyErr {
    let name = obj
        .get_type()
        .name()
        .map_or_else(|_| "object".to_owned(), |n| n.to_string());
    pyo3::exceptions::PyRuntimeError::new_err(format!(
        "this {name} is in use by another thread; create one per thread"
    ))
}

/// Result alias of the bridge.
pub type Result<T> = std::result::Result<T, Error>;

/// The message of a caught panic.
fn panic_message(payload: Box<dyn std::any::Any + Send>) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".to_owned())
}

/// Runs `work` (with the GIL held) so that a panic becomes `RpercError`.
pub fn guarded<T>(work: impl FnOnce() -> Result<T>) -> Result<T> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(work))
        .unwrap_or_else(|payload| Err(Error::Panic(panic_message(payload))))
}

/// A Python exception raised by a signal handler while native work ran (normally
/// `KeyboardInterrupt`), kept until the work has stopped and the GIL is back.
type Pending = Arc<Mutex<Option<PyErr>>>;

/// Asks Python for pending signals (briefly re-attaching to the interpreter); a raised
/// exception is kept in `pending` and reported as `true`.
fn signalled(pending: &Pending) -> bool {
    match Python::attach(|py| py.check_signals()) {
        Ok(()) => false,
        Err(err) => {
            let mut slot = pending.lock().unwrap_or_else(|e| e.into_inner());
            slot.get_or_insert(err);
            true
        }
    }
}

/// The work's result as a Python result. A signal handler's exception caught while
/// the work ran is raised whatever the work returned: the poll has consumed the
/// signal, so when the work ended before its next checkpoint, returning its result
/// lost the Ctrl-C (issue 38: a SIGINT at 1 s of a 2.5 s run, and the run completed).
fn finish<T>(out: Result<T>, pending: &Pending) -> PyResult<T> {
    if let Some(raised) = pending.lock().unwrap_or_else(|e| e.into_inner()).take() {
        return Err(raised);
    }
    match out {
        Ok(value) => Ok(value),
        Err(err) if err.class() == Some(ErrorClass::Interrupted) => {
            Err(PyKeyboardInterrupt::new_err("interrupted"))
        }
        Err(err) => Err(err.into()),
    }
}

/// Runs heavy work with the GIL released, catching panics so none crosses into Python.
/// Every bridge call that does real work goes through here. The work's checkpoints
/// (see [`rperc_core::interrupt`]) poll for signals on this thread, so Ctrl-C stops
/// a long loop with `KeyboardInterrupt` instead of waiting for its end.
pub fn detached<T, F>(py: Python<'_>, work: F) -> PyResult<T>
where
    T: Send,
    F: FnOnce() -> Result<T> + Send,
{
    let pending = Pending::default();
    let poll_pending = Arc::clone(&pending);
    let out = py
        .detach(move || interrupt::run_polled(move || signalled(&poll_pending), || guarded(work)));
    finish(out, &pending)
}

/// [`detached`] for work that runs on a thread pool: the pool's threads cannot ask
/// Python for signals, so the work runs on a scoped thread while this one polls every
/// [`interrupt::POLL_INTERVAL`] and stops the shared token on a signal.
pub fn detached_parallel<T, F>(py: Python<'_>, work: F) -> PyResult<T>
where
    T: Send,
    F: FnOnce() -> Result<T> + Send,
{
    let pending = Pending::default();
    let out = py.detach(|| {
        let token = Arc::new(interrupt::Interrupt::new());
        // Set before the unpark: the thread is not "finished" until it has returned,
        // so a caller woken by the unpark that asked `is_finished()` saw false and
        // slept a whole poll interval more (10 ms on every call).
        let done = AtomicBool::new(false);
        std::thread::scope(|scope| {
            let caller = std::thread::current();
            let worker_token = Some(Arc::clone(&token));
            let done = &done;
            let worker = scope.spawn(move || {
                let out = interrupt::run_with(worker_token, || guarded(work));
                done.store(true, Ordering::Release);
                caller.unpark();
                out
            });
            // `is_finished()` too: a worker that died without setting `done` must not
            // leave this thread polling forever.
            while !done.load(Ordering::Acquire) && !worker.is_finished() {
                std::thread::park_timeout(interrupt::POLL_INTERVAL);
                if !done.load(Ordering::Acquire) && !token.is_stopped() && signalled(&pending) {
                    token.stop();
                }
            }
            worker
                .join()
                .unwrap_or_else(|payload| Err(Error::Panic(panic_message(payload))))
        })
    });
    finish(out, &pending)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_error_maps_to_its_exception() {
        Python::initialize();
        Python::attach(|py| {
            let cases: Vec<(Error, Bound<'_, pyo3::types::PyType>)> = vec![
                (Error::Value("v".into()), py.get_type::<PyValueError>()),
                (Error::Type("t".into()), py.get_type::<PyTypeError>()),
                (
                    Error::LineSimp(linesimp::LineSimpError::InvalidEpsilon(-1.0)),
                    py.get_type::<PyValueError>(),
                ),
                (Error::Panic("p".into()), py.get_type::<RpercError>()),
                (
                    Error::Slam(slam::SlamError::SingularInnovation("S".into())),
                    py.get_type::<NumericalError>(),
                ),
                (
                    Error::Slam(slam::SlamError::Core(rperc_core::CoreError::Dimension(
                        "d".into(),
                    ))),
                    py.get_type::<PyValueError>(),
                ),
                (
                    Error::Tracking(tracking::TrackingError::Io {
                        path: "f".into(),
                        reason: "r".into(),
                    }),
                    py.get_type::<PyOSError>(),
                ),
                (
                    Error::Navigation(navigation::NavigationError::Tracking(
                        tracking::TrackingError::Io {
                            path: "f".into(),
                            reason: "r".into(),
                        },
                    )),
                    py.get_type::<PyOSError>(),
                ),
                (
                    Error::Navigation(navigation::NavigationError::InvalidParameter {
                        name: "p",
                        reason: "r".into(),
                    }),
                    py.get_type::<PyValueError>(),
                ),
                (
                    Error::Core(rperc_core::CoreError::NonFinite("x")),
                    py.get_type::<PyValueError>(),
                ),
                (
                    Error::LineSimp(rperc_core::CoreError::Interrupted.into()),
                    py.get_type::<PyKeyboardInterrupt>(),
                ),
            ];
            for (err, expected) in cases {
                let msg = err.to_string();
                let py_err = PyErr::from(err);
                assert!(py_err.get_type(py).is(&expected), "{msg}");
                assert_eq!(py_err.value(py).to_string(), msg);
            }
            assert!(
                py.get_type::<NumericalError>()
                    .is_subclass(&py.get_type::<RpercError>())
                    .unwrap()
            );
        });
    }

    #[test]
    fn a_signal_caught_as_the_work_ends_is_raised_not_lost() {
        Python::initialize();
        Python::attach(|py| {
            let pending = Pending::default();
            *pending.lock().unwrap() = Some(PyKeyboardInterrupt::new_err("from the handler"));
            let err = finish(Ok(7), &pending).unwrap_err();
            assert!(err.get_type(py).is(py.get_type::<PyKeyboardInterrupt>()));
            assert_eq!(err.value(py).to_string(), "from the handler");
            // Without a signal the result passes through.
            assert_eq!(finish(Ok(7), &Pending::default()).unwrap(), 7);
        });
    }

    #[test]
    fn a_panic_becomes_an_rperc_error() {
        Python::initialize();
        Python::attach(|py| {
            let err = detached::<(), _>(py, || panic!("boom")).unwrap_err();
            assert!(err.get_type(py).is(py.get_type::<RpercError>()));
            assert!(err.value(py).to_string().contains("boom"));
        });
    }
}
