//! The one mapping from core-crate errors to Python exceptions.
//!
//! Bad values raise `ValueError`, wrong dtypes `TypeError` (both checked in
//! [`crate::arrays`]), and everything else an `rperc.RpercError` subclass.

use pyo3::exceptions::{PyException, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::{PyErr, create_exception};

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
    /// From the line-simplification crate.
    #[error(transparent)]
    LineSimp(#[from] linesimp::LineSimpError),
    /// From the SLAM crate.
    #[error(transparent)]
    Slam(#[from] slam::SlamError),
    /// From the tracking crate.
    #[error(transparent)]
    Tracking(#[from] tracking::TrackingError),
    /// A Rust panic caught at the boundary: a bug, reported rather than crashing Python.
    #[error("internal error in rperc (please report it): {0}")]
    Panic(String),
}

impl From<Error> for PyErr {
    fn from(err: Error) -> PyErr {
        let msg = err.to_string();
        match err {
            Error::Value(_) => PyValueError::new_err(msg),
            Error::Type(_) => PyTypeError::new_err(msg),
            // Every linesimp error is a bad input value.
            Error::LineSimp(_) => PyValueError::new_err(msg),
            Error::Slam(e) => match e {
                slam::SlamError::SingularInnovation(_) => NumericalError::new_err(msg),
                _ => PyValueError::new_err(msg),
            },
            Error::Tracking(e) => match e {
                tracking::TrackingError::Io { .. } => RpercError::new_err(msg),
                _ => PyValueError::new_err(msg),
            },
            Error::Panic(_) => RpercError::new_err(msg),
        }
    }
}

/// Result alias of the bridge.
pub type Result<T> = std::result::Result<T, Error>;

/// Runs heavy work with the GIL released, catching panics so none crosses into Python.
/// Every bridge call that does real work goes through here.
pub fn detached<T, F>(py: Python<'_>, work: F) -> PyResult<T>
where
    T: Send,
    F: FnOnce() -> Result<T> + Send,
{
    py.detach(|| {
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(work)).unwrap_or_else(|payload| {
            let what = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".to_owned());
            Err(Error::Panic(what))
        })
    })
    .map_err(PyErr::from)
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
                    Error::Slam(slam::SlamError::Dimension("d".into())),
                    py.get_type::<PyValueError>(),
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
    fn a_panic_becomes_an_rperc_error() {
        Python::initialize();
        Python::attach(|py| {
            let err = detached::<(), _>(py, || panic!("boom")).unwrap_err();
            assert!(err.get_type(py).is(py.get_type::<RpercError>()));
            assert!(err.value(py).to_string().contains("boom"));
        });
    }
}
