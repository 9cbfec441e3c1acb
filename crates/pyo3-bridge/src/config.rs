//! The one path from Python keyword arguments to a core crate's typed config struct.
//!
//! Every config derives serde's `Deserialize` with defaults and `deny_unknown_fields`.
//! A dict (or dataclass) of keywords is read by serde-pyobject into a generic serde
//! value (which keeps NaN and infinities), then deserialised into the config through
//! `serde_path_to_error`, so every message names the field (`appearance.bins`), and no
//! binding has code per field. The caller then runs the config's `validate()`.

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
    let value = guarded(|| {
        serde_pyobject::from_pyobject::<serde_value::Value, _>(obj.clone())
            .map_err(|e| Error::Type(format!("{what}: {}", e.0.value(obj.py()))))
    })?;
    serde_path_to_error::deserialize::<_, T>(value).map_err(|e| {
        let (field, msg) = (e.path().to_string(), e.inner().to_string());
        let text = format!("{what}: {field}: {msg}");
        let lower = msg.to_lowercase();
        if lower.starts_with("unknown field") || lower.starts_with("invalid type") {
            Error::Type(text)
        } else {
            Error::Value(text)
        }
    })
}

/// The default config `T`, as a dict: what the typed Python layer shows as defaults.
pub fn defaults<'py, T: serde::Serialize + Default>(
    py: Python<'py>,
) -> PyResult<Bound<'py, PyAny>> {
    serde_pyobject::to_pyobject(py, &T::default()).map_err(PyErr::from)
}
