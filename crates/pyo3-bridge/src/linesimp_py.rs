//! Bindings of the `linesimp` crate: Douglas-Peucker simplification.

use linesimp::{Component, Method, Metric, Simplifier, Tie};
use numpy::{IntoPyArray, PyArray1, PyArrayDyn};
use pyo3::prelude::*;

use crate::arrays::{frozen_array, point_rows, read_only};
use crate::errors::{Error, detached, detached_parallel};

/// The configured simplifier for the option names Python passes.
fn simplifier(method: &str, metric: &str, tie: &str) -> Result<Simplifier, Error> {
    Ok(
        Simplifier::new(method.parse::<Method>()?, metric.parse::<Metric>()?)
            .with_tie(tie.parse::<Tie>()?),
    )
}

/// numpy's index type, so the result indexes arrays directly.
fn to_intp(indices: Vec<usize>) -> Vec<isize> {
    // In-place collect: same size and alignment, so the buffer is reused.
    indices.into_iter().map(|k| k as isize).collect()
}

/// Indices kept by Douglas-Peucker, as an int array (GIL released).
#[pyfunction]
#[pyo3(signature = (points, epsilon, method = "auto", metric = "line", tie = "first"))]
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
#[pyo3(signature = (polylines, epsilon, method = "auto", metric = "line", tie = "first", threads = None))]
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
    let results = detached_parallel(py, || {
        crate::parallel::with_threads(threads, || simplifier.indices_many(&slices, epsilon))?
            .into_iter()
            .enumerate()
            .map(|(k, r)| r.map_err(|e| polyline_error(k, e)))
            .collect::<Result<Vec<_>, Error>>()
    })?;
    Ok(results
        .into_iter()
        .map(|kept| to_intp(kept).into_pyarray(py))
        .collect())
}

/// An error of polyline `k` of a batch, named by its index; an interrupt stays one.
fn polyline_error(k: usize, err: linesimp::LineSimpError) -> Error {
    match err.class() {
        rperc_core::ErrorClass::Interrupted => Error::LineSimp(err),
        _ => Error::Value(format!("polylines[{k}]: {err}")),
    }
}

/// Topology-preserving Douglas-Peucker of the components of one geometry (GIL
/// released): `rings[k]` marks polygon rings. Kept indices per component, in output
/// order.
#[pyfunction]
#[pyo3(signature = (components, rings, epsilon, method = "auto", metric = "line", tie = "first"))]
pub fn simplify_topology_indices<'py>(
    py: Python<'py>,
    components: Vec<Bound<'py, PyAny>>,
    rings: Vec<bool>,
    epsilon: f64,
    method: &str,
    metric: &str,
    tie: &str,
) -> PyResult<Vec<Bound<'py, PyArray1<isize>>>> {
    if !matches!(
        method.parse::<Method>().map_err(Error::from)?,
        Method::Auto | Method::Dp
    ) {
        return Err(Error::Value(format!(
            "preserve_topology runs Douglas-Peucker section by section: method must be \
             'auto' or 'dp', got '{method}'"
        ))
        .into());
    }
    let metric: Metric = metric.parse().map_err(Error::from)?;
    let tie: Tie = tie.parse().map_err(Error::from)?;
    if rings.len() != components.len() {
        return Err(Error::Value(format!(
            "rings has {} flags for {} components",
            rings.len(),
            components.len()
        ))
        .into());
    }
    let rows = components
        .iter()
        .enumerate()
        .map(|(k, p)| point_rows(p, &format!("components[{k}]")))
        .collect::<Result<Vec<_>, _>>()?;
    let parts: Vec<Component<'_>> = rows
        .iter()
        .zip(&rings)
        .map(|(r, &ring)| Component {
            points: r.as_points(),
            ring,
        })
        .collect();
    let kept = detached(py, || {
        Ok(linesimp::simplify_preserving_topology(
            &parts, epsilon, metric, tie,
        )?)
    })?;
    Ok(kept
        .into_iter()
        .map(|k| to_intp(k).into_pyarray(py))
        .collect())
}

/// The walls of one scan ([`extract_lines`]), frozen, arrays read-only: `rho` (K),
/// `alpha` (K), `cov` (K, 2, 2) of `(rho, alpha)`, the end points `start` and `end`
/// (K, 2), and the fitted readings' indices back to back, `flat_indices` (M), with
/// wall `k`'s at `flat_indices[offsets[k]:offsets[k + 1]]` (`offsets` K + 1).
#[pyclass(name = "ScanWalls", module = "rperc._rperc", frozen, get_all)]
pub struct PyScanWalls {
    rho: Py<PyArrayDyn<f64>>,
    alpha: Py<PyArrayDyn<f64>>,
    cov: Py<PyArrayDyn<f64>>,
    start: Py<PyArrayDyn<f64>>,
    end: Py<PyArrayDyn<f64>>,
    flat_indices: Py<PyArray1<isize>>,
    offsets: Py<PyArray1<isize>>,
}

/// Walls of one laser scan (GIL released); `params` holds `ScanParams` fields.
#[pyfunction]
#[pyo3(signature = (ranges, angles, params = None))]
pub fn extract_lines<'py>(
    py: Python<'py>,
    ranges: &Bound<'py, PyAny>,
    angles: &Bound<'py, PyAny>,
    params: Option<&Bound<'py, PyAny>>,
) -> PyResult<PyScanWalls> {
    let ranges = crate::arrays::float_vector(ranges, "ranges")?;
    let angles = crate::arrays::float_vector(angles, "angles")?;
    let params: linesimp::ScanParams = crate::config::from_python(params, "extract_lines")?;
    params.validate().map_err(Error::from)?;
    let walls = detached(py, || {
        Ok(linesimp::extract_lines(&ranges, &angles, &params)?)
    })?;
    let k = walls.len();
    let mut rho = Vec::with_capacity(k);
    let mut alpha = Vec::with_capacity(k);
    let mut cov = Vec::with_capacity(4 * k);
    let mut ends = [Vec::with_capacity(2 * k), Vec::with_capacity(2 * k)];
    let mut indices = Vec::new();
    let mut offsets = Vec::with_capacity(k + 1);
    offsets.push(0isize);
    for w in &walls {
        rho.push(w.rho);
        alpha.push(w.alpha);
        // Row-major 2 x 2 for numpy (nalgebra is column-major; cov is symmetric anyway).
        cov.extend([w.cov[(0, 0)], w.cov[(0, 1)], w.cov[(1, 0)], w.cov[(1, 1)]]);
        ends[0].extend([w.start.x, w.start.y]);
        ends[1].extend([w.end.x, w.end.y]);
        indices.extend(w.indices.iter().map(|&i| i as isize));
        offsets.push(indices.len() as isize);
    }
    let [start, end] = ends;
    Ok(PyScanWalls {
        rho: frozen_array(py, rho, &[k])?,
        alpha: frozen_array(py, alpha, &[k])?,
        cov: frozen_array(py, cov, &[k, 2, 2])?,
        start: frozen_array(py, start, &[k, 2])?,
        end: frozen_array(py, end, &[k, 2])?,
        flat_indices: read_only(indices.into_pyarray(py))?,
        offsets: read_only(offsets.into_pyarray(py))?,
    })
}
