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

/// The fields of `line` split at ASCII white space: how many there are, and `count`
/// of them from field `first` on, read as [`parse_floats`] reads each. `None` when the
/// line holds a byte that is not ASCII, or white space that only Python's `str.split`
/// splits at, has fewer fields, or one of those is not a plain decimal number: then
/// the caller splits and reads the line itself, and names what is wrong. A scan line
/// read this way makes no Python string per reading, which was most of its cost.
#[pyfunction]
pub fn parse_line_floats<'py>(
    py: Python<'py>,
    line: &str,
    first: usize,
    count: usize,
) -> Option<(usize, Bound<'py, PyArray1<f64>>)> {
    let mut out = Vec::with_capacity(count.min(line.len()));
    let fields = line_floats(line, first, count, &mut out)?;
    Some((fields, out.into_pyarray(py)))
}

/// [`parse_line_floats`] over every line of `lines` (a list of `str`): each line's
/// field count, and the `(lines, count)` numbers row by row; `None` when any line
/// does not read (the caller then reads them one by one).
#[pyfunction]
pub fn parse_lines_floats<'py>(
    py: Python<'py>,
    lines: &Bound<'py, PyList>,
    first: usize,
    count: usize,
) -> PyResult<Option<LinesRead<'py>>> {
    let mut fields = Vec::with_capacity(lines.len());
    let mut values = Vec::with_capacity(lines.len().saturating_mul(count.min(64)));
    for line in lines.iter() {
        let Ok(text) = line.cast::<PyString>() else {
            return Ok(None);
        };
        let Some(n) = text
            .to_str()
            .ok()
            .and_then(|t| line_floats(t, first, count, &mut values))
        else {
            return Ok(None);
        };
        fields.push(n as i64);
    }
    let table = crate::arrays::shaped(py, values, &[fields.len(), count])?;
    Ok(Some((fields.into_pyarray(py), table)))
}

/// What [`parse_lines_floats`] returns: field counts and the table of numbers.
type LinesRead<'py> = (
    Bound<'py, PyArray1<i64>>,
    Bound<'py, numpy::PyArrayDyn<f64>>,
);

/// Appends `count` numbers of `line` from field `first` on to `out` and returns the
/// line's field count; `None` (with `out` partly written) as [`parse_line_floats`].
fn line_floats(line: &str, first: usize, count: usize, out: &mut Vec<f64>) -> Option<usize> {
    // Python's `str.split` also splits at the vertical tab, the ASCII separators
    // 0x1c-0x1f and non-ASCII white space; Rust's splits at none of them.
    if !line
        .bytes()
        .all(|b| b.is_ascii() && !matches!(b, 0x0b | 0x1c..=0x1f))
    {
        return None;
    }
    let mut fields = 0usize;
    let mut read = 0usize;
    for token in line.split_ascii_whitespace() {
        if fields >= first && read < count {
            out.push(token.parse::<f64>().ok()?);
            read += 1;
        }
        fields += 1;
    }
    (read == count).then_some(fields)
}
