//! Numbers from text, for the dataset readers: the one step of reading a log that
//! Python is slow at (a CARMEN scan line holds hundreds of numbers).

use numpy::{IntoPyArray, PyArray1};
use pyo3::prelude::*;
use pyo3::types::{PyList, PyString};

/// The tokens of `tokens` (a list of `str`) as floats, or `None` when one of them is
/// not a plain decimal number (then the caller's own parser decides, and names the
/// token). Rust reads a subset of what Python's `float()` reads (no `_` digit
/// separators, no non-ASCII digits), to the same correctly rounded value, so a token
/// read here reads the same in Python.
#[pyfunction]
pub fn parse_floats<'py>(
    py: Python<'py>,
    tokens: &Bound<'py, PyList>,
) -> PyResult<Option<Bound<'py, PyArray1<f64>>>> {
    let mut out = Vec::with_capacity(tokens.len());
    for token in tokens.iter() {
        let Ok(text) = token.cast::<PyString>() else {
            return Ok(None);
        };
        match text.to_str().ok().and_then(|s| s.parse::<f64>().ok()) {
            Some(v) => out.push(v),
            None => return Ok(None),
        }
    }
    Ok(Some(out.into_pyarray(py)))
}
