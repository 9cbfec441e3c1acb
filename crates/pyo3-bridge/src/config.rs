//! The one path from Python keyword arguments to a core crate's typed config struct.
//!
//! Every config derives serde's `Deserialize` with defaults and `deny_unknown_fields`.
//! A dict (or dataclass) of keywords is read by serde-pyobject into a generic serde
//! value (which keeps NaN and infinities), then deserialised into the config through
//! `serde_path_to_error`, so every message names the field (`appearance.bins`), and no
//! binding has code per field. The caller then runs the config's `validate()`.

use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use serde::de::DeserializeOwned;

use rperc_core::{QUOTE_LIMIT, clip};

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
    let obj = plain(obj, what)?;
    // serde-pyobject panics on Python types it does not know; `plain` refuses those
    // first, and the guard stays for anything it missed.
    let value = guarded(|| {
        serde_pyobject::from_pyobject::<serde_value::Value, _>(obj.clone()).map_err(|e| {
            let msg = e.0.value(obj.py()).to_string();
            Error::Type(format!("{what}: {}", clip(&msg, 4 * QUOTE_LIMIT)))
        })
    })?;
    serde_path_to_error::deserialize::<_, T>(value).map_err(|e| {
        let (field, msg) = (e.path().to_string(), e.inner().to_string());
        // serde quotes the value it refused: never a whole 5 MB string (issue 38).
        let text = format!(
            "{what}: {}: {}",
            clip(&field, QUOTE_LIMIT),
            clip(&msg, 4 * QUOTE_LIMIT)
        );
        let lower = msg.to_lowercase();
        if lower.starts_with("unknown field") || lower.starts_with("invalid type") {
            Error::Type(text)
        } else {
            Error::Value(text)
        }
    })
}

/// `obj` with numpy scalars (`np.float32(0.5)`, `np.int64(3)`) turned into Python
/// numbers, inside dicts, lists and tuples; a leaf of any other type serde-pyobject
/// cannot read (a complex, bytes, a set) is a `TypeError`, an int beyond i64 a
/// `ValueError`, each naming its field. Objects
/// with attributes (dataclasses) pass through: serde-pyobject reads those.
fn plain<'py>(obj: &Bound<'py, PyAny>, path: &str) -> Result<Bound<'py, PyAny>> {
    let py = obj.py();
    // serde-pyobject reads ints as i64 and its overflow error names no field.
    // The size, not the digits: repr refuses ints over 4300 digits, and a message
    // quotes no more than a few dozen characters of its input.
    if obj.is_instance_of::<PyInt>() && obj.extract::<i64>().is_err() {
        let bits: u64 = obj.call_method0("bit_length")?.extract()?;
        return Err(Error::Value(format!(
            "{}: an integer of {bits} bits is out of range (a signed 64-bit integer: \
             -2^63 to 2^63 - 1)",
            clip(path, QUOTE_LIMIT)
        )));
    }
    if obj.is_none()
        || obj.is_instance_of::<PyBool>()
        || obj.is_instance_of::<PyInt>()
        || obj.is_instance_of::<PyFloat>()
        || obj.is_instance_of::<PyString>()
    {
        return Ok(obj.clone());
    }
    if let Ok(dict) = obj.cast::<PyDict>() {
        let out = PyDict::new(py);
        for (key, value) in dict.iter() {
            out.set_item(&key, plain(&value, &format!("{path}.{key}"))?)?;
        }
        return Ok(out.into_any());
    }
    if obj.is_instance_of::<PyList>() || obj.is_instance_of::<PyTuple>() {
        let items = obj
            .try_iter()?
            .enumerate()
            .map(|(k, item)| plain(&item?, &format!("{path}[{k}]")))
            .collect::<Result<Vec<_>>>()?;
        return Ok(PyList::new(py, items)?.into_any());
    }
    if obj.hasattr("dtype")? && obj.hasattr("item")? && obj.getattr("ndim")?.extract::<i64>()? == 0
    {
        let item = obj.call_method0("item")?;
        if !item.is_instance_of::<PyInt>()
            && !item.is_instance_of::<PyFloat>()
            && !item.is_instance_of::<PyBool>()
        {
            return Err(Error::Type(format!(
                "{}: expected a number, got {}",
                clip(path, QUOTE_LIMIT),
                obj.repr()?
            )));
        }
        return Ok(item);
    }
    if obj.hasattr("__dict__")? || obj.hasattr("__slots__")? {
        return Ok(obj.clone());
    }
    Err(Error::Type(format!(
        "{}: unsupported type {}",
        clip(path, QUOTE_LIMIT),
        obj.get_type().name()?
    )))
}

/// The default config `T`, as a dict: what the typed Python layer shows as defaults.
pub fn defaults<'py, T: serde::Serialize + Default>(
    py: Python<'py>,
) -> PyResult<Bound<'py, PyAny>> {
    serde_pyobject::to_pyobject(py, &T::default()).map_err(PyErr::from)
}
