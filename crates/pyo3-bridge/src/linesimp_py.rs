//! Bindings of the `linesimp` crate: Douglas-Peucker simplification.

use linesimp::{Method, Metric, Simplifier, Tie};
use numpy::{IntoPyArray, PyArray1};
use pyo3::prelude::*;

use crate::arrays::point_rows;
use crate::errors::{Error, detached};

fn parse_method(method: &str) -> Result<Method, Error> {
    match method {
        "hull" => Ok(Method::Hull),
        "dp" => Ok(Method::Dp),
        other => Err(Error::Value(format!(
            "method must be 'hull' or 'dp', got '{other}'"
        ))),
    }
}

fn parse_metric(metric: &str) -> Result<Metric, Error> {
    match metric {
        "line" => Ok(Metric::Line),
        "segment" => Ok(Metric::Segment),
        other => Err(Error::Value(format!(
            "metric must be 'line' or 'segment', got '{other}'"
        ))),
    }
}

fn parse_tie(tie: &str) -> Result<Tie, Error> {
    match tie {
        "first" => Ok(Tie::First),
        "last" => Ok(Tie::Last),
        other => Err(Error::Value(format!(
            "tie must be 'first' or 'last', got '{other}'"
        ))),
    }
}

/// The configured simplifier for the string options Python passes.
fn simplifier(method: &str, metric: &str, tie: &str) -> Result<Simplifier, Error> {
    Ok(Simplifier::new(parse_method(method)?, parse_metric(metric)?).with_tie(parse_tie(tie)?))
}

/// numpy's index type, so the result indexes arrays directly.
fn to_intp(indices: Vec<usize>) -> Vec<isize> {
    // In-place collect: same size and alignment, so the buffer is reused.
    indices.into_iter().map(|k| k as isize).collect()
}

/// Indices kept by Douglas-Peucker, as an int array (GIL released).
#[pyfunction]
#[pyo3(signature = (points, epsilon, method = "hull", metric = "line", tie = "first"))]
pub fn simplify_indices<'py>(
    py: Python<'py>,
    points: &Bound<'py, PyAny>,
    epsilon: f64,
    method: &str,
    metric: &str,
    tie: &str,
) -> PyResult<Bound<'py, PyArray1<isize>>> {
    let mut simplifier = simplifier(method, metric, tie)?;
    let rows = point_rows(points, "points")?;
    let pts = rows.as_points();
    let kept = detached(py, || Ok(simplifier.indices(pts, epsilon)?))?;
    Ok(to_intp(kept).into_pyarray(py))
}

/// Indices kept for each polyline of a list, simplified in parallel (GIL released).
#[pyfunction]
#[pyo3(signature = (polylines, epsilon, method = "hull", metric = "line", tie = "first", threads = None))]
pub fn simplify_many_indices<'py>(
    py: Python<'py>,
    polylines: Vec<Bound<'py, PyAny>>,
    epsilon: f64,
    method: &str,
    metric: &str,
    tie: &str,
    threads: Option<usize>,
) -> PyResult<Vec<Bound<'py, PyArray1<isize>>>> {
    let simplifier = simplifier(method, metric, tie)?;
    let rows = polylines
        .iter()
        .enumerate()
        .map(|(k, p)| point_rows(p, &format!("polylines[{k}]")))
        .collect::<Result<Vec<_>, _>>()?;
    let slices: Vec<&[nalgebra::Point2<f64>]> = rows.iter().map(|r| r.as_points()).collect();
    let results = detached(py, || {
        crate::parallel::with_threads(threads, || simplifier.indices_many(&slices, epsilon))?
            .into_iter()
            .enumerate()
            .map(|(k, r)| r.map_err(|e| Error::Value(format!("polylines[{k}]: {e}"))))
            .collect::<Result<Vec<_>, Error>>()
    })?;
    Ok(results
        .into_iter()
        .map(|kept| to_intp(kept).into_pyarray(py))
        .collect())
}
