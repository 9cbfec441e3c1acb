//! The one path from Python keyword arguments to a core crate's typed config struct.
//!
//! Every config derives serde's `Deserialize` with defaults and `deny_unknown_fields`;
//! a dict (or dataclass) of keywords is deserialised field by field by serde-pyobject,
//! so no binding has code per field. The caller then runs the config's `validate()`.

use pyo3::prelude::*;
use serde::de::DeserializeOwned;

use crate::errors::{Error, Result, guarded};

/// Reads `obj` (a dict of keywords, a dataclass, or `None` for all defaults) as `T`.
/// Unknown or mistyped fields are a `TypeError`, bad values a `ValueError`, and each
/// message names the config and the field.
pub fn from_python<T: DeserializeOwned + Default>(
    obj: Option<&Bound<'_, PyAny>>,
    what: &str,
) -> Result<T> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else {
        return Ok(T::default());
    };
    // serde-pyobject panics on Python types it does not know (numpy scalars...).
    guarded(|| {
        serde_pyobject::from_pyobject::<T, _>(obj.clone()).map_err(|e| {
            let msg = e.0.value(obj.py()).to_string();
            let text = format!("{what}: {msg}");
            if msg.starts_with("unknown field")
                || msg.starts_with("invalid type")
                || msg.contains("cannot be converted")
            {
                Error::Type(text)
            } else {
                Error::Value(text)
            }
        })
    })
}

/// The default config `T`, as a dict: what the typed Python layer shows as defaults.
pub fn defaults<'py, T: serde::Serialize + Default>(
    py: Python<'py>,
) -> PyResult<Bound<'py, PyAny>> {
    serde_pyobject::to_pyobject(py, &T::default()).map_err(PyErr::from)
}
