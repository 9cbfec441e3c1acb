//! Laser SLAM (`laser` crate): a log's scans and odometry in, every scan's pose out.

use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayDyn};
use pyo3::prelude::*;
use pyo3::types::PyTuple;

use crate::arrays::{float_vector, frozen_array, read_only, shaped, tensor};
use crate::errors::{Error, Result, detached};
use crate::planar_py::{int_rows, rows};
use laser::{LaserConfig, ScanLog};

fn poses(v: &[rperc_core::Pose2]) -> Vec<f64> {
    v.iter().flat_map(|p| [p.x, p.y, p.theta]).collect()
}

/// What [`laser_run`] returns, frozen: every scan's final pose `(S, 3)` and
/// covariance `(S, 3, 3)`, the online (causal) path, the front end's match statistics,
/// the key scans, the accepted loop closures `(K, 2)` (key scan pairs, as scan
/// indices) with their chi-square in the final graph, the closures rejected by
/// reason, and the wall landmarks `(W, 4)` (world segments `x0, y0, x1, y1`) with
/// the number of wall sightings in the graph and of those pruned for disagreeing
/// with it. Its arrays are read-only.
#[pyclass(name = "LaserRun", module = "rperc._rperc", frozen)]
pub struct PyLaserRun {
    #[pyo3(get)]
    pose: Py<PyArrayDyn<f64>>,
    #[pyo3(get)]
    covariance: Py<PyArrayDyn<f64>>,
    #[pyo3(get)]
    causal_pose: Py<PyArrayDyn<f64>>,
    #[pyo3(get)]
    matched: Py<PyArray1<bool>>,
    #[pyo3(get)]
    inliers: Py<PyArray1<i64>>,
    #[pyo3(get)]
    rms: Py<PyArray1<f64>>,
    #[pyo3(get)]
    keys: Py<PyArray1<i64>>,
    #[pyo3(get)]
    closures: Py<PyArray2<i64>>,
    #[pyo3(get)]
    closure_chi2: Py<PyArray1<f64>>,
    #[pyo3(get)]
    closure_attempts: usize,
    #[pyo3(get)]
    closures_rejected: usize,
    #[pyo3(get)]
    walls: Py<PyArrayDyn<f64>>,
    #[pyo3(get)]
    wall_factors: usize,
    #[pyo3(get)]
    wall_factors_pruned: usize,
    /// Rejected closures by reason, in [`REJECTION_REASONS`]' order.
    rejections: [usize; 5],
    /// Scans, key scans and accepted closures (for the repr).
    counts: [usize; 3],
}

/// Why a closure was rejected, in the order of `LaserRun::rejections`.
const REJECTION_REASONS: [&str; 5] = [
    "inliers",
    "residual",
    "degenerate",
    "unconfirmed",
    "disagreeing",
];

#[pymethods]
impl PyLaserRun {
    /// The reasons a closure can be rejected, in the order of `rejected`.
    #[classattr]
    fn rejection_reasons(py: Python<'_>) -> PyResult<Bound<'_, PyTuple>> {
        PyTuple::new(py, REJECTION_REASONS)
    }

    /// How many closures were rejected for each of `rejection_reasons`.
    #[getter]
    fn rejected<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        PyTuple::new(py, self.rejections)
    }

    fn __repr__(&self) -> String {
        let [scans, keys, closures] = self.counts;
        format!(
            "LaserRun({scans} scans, {keys} key scans, {closures} closures accepted, {} rejected \
             of {} attempts)",
            self.closures_rejected, self.closure_attempts
        )
    }
}

impl PyLaserRun {
    fn new(py: Python<'_>, out: laser::LaserRun, s: usize) -> PyResult<Self> {
        let cov: Vec<f64> = out
            .covariance
            .iter()
            .flat_map(|c| c.transpose().iter().copied().collect::<Vec<_>>())
            .collect();
        let closures: Vec<i64> = out
            .closures
            .iter()
            .flat_map(|&(a, b)| [a as i64, b as i64])
            .collect();
        let closures = numpy::ndarray::Array2::from_shape_vec((out.closures.len(), 2), closures)
            .map_err(|e| Error::Value(format!("internal shape error: {e}")))?;
        let ints = |v: &[usize]| v.iter().map(|&k| k as i64).collect::<Vec<i64>>();
        let counts = [s, out.keys.len(), out.closures.len()];
        Ok(Self {
            counts,
            pose: read_only(shaped(py, poses(&out.pose), &[s, 3])?)?,
            covariance: read_only(shaped(py, cov, &[s, 3, 3])?)?,
            causal_pose: read_only(shaped(py, poses(&out.causal_pose), &[s, 3])?)?,
            matched: read_only(out.matched.into_pyarray(py))?,
            inliers: read_only(ints(&out.inliers).into_pyarray(py))?,
            rms: read_only(out.rms.into_pyarray(py))?,
            keys: read_only(ints(&out.keys).into_pyarray(py))?,
            closures: read_only(closures.into_pyarray(py))?,
            closure_chi2: read_only(out.closure_chi2.into_pyarray(py))?,
            closure_attempts: out.closure_attempts,
            closures_rejected: out.closures_rejected,
            rejections: out.rejections,
            walls: read_only(shaped(
                py,
                out.walls.iter().flatten().copied().collect(),
                &[out.walls.len(), 4],
            )?)?,
            wall_factors: out.wall_factors,
            wall_factors_pruned: out.wall_factors_pruned,
        })
    }
}

/// Runs laser SLAM (GIL released): `ranges` `(S, n)` (NaN-padded), `counts` (int64,
/// readings per scan), per-scan `angle_min`, `angle_increment`, `max_range`,
/// odometry `controls` rows `(t, v, omega)` and the scans' `times`. Returns a
/// [`PyLaserRun`].
#[pyfunction]
#[pyo3(signature = (ranges, counts, angle_min, angle_increment, max_range, controls, times, config = None))]
#[allow(clippy::too_many_arguments)]
pub fn laser_run<'py>(
    py: Python<'py>,
    ranges: &Bound<'py, PyAny>,
    counts: &Bound<'py, PyAny>,
    angle_min: &Bound<'py, PyAny>,
    angle_increment: &Bound<'py, PyAny>,
    max_range: &Bound<'py, PyAny>,
    controls: &Bound<'py, PyAny>,
    times: &Bound<'py, PyAny>,
    config: Option<&Bound<'py, PyAny>>,
) -> PyResult<PyLaserRun> {
    let config: LaserConfig = crate::config::from_python(config, "laser")?;
    config.validate().map_err(Error::from)?;
    let (shape, ranges) = tensor(ranges, "ranges", 2)?;
    let s = shape[0];
    let counts = int_rows(counts, "counts", s)?
        .into_iter()
        .map(|c| {
            usize::try_from(c).map_err(|_| Error::Value(format!("counts must be >= 0, got {c}")))
        })
        .collect::<Result<Vec<usize>>>()?;
    let angle_min = float_vector(angle_min, "angle_min")?;
    let angle_increment = float_vector(angle_increment, "angle_increment")?;
    let max_range = float_vector(max_range, "max_range")?;
    let controls = rows::<3>(Some(controls), "controls")?;
    let times = float_vector(times, "times")?;
    let out = detached(py, || {
        let log = ScanLog {
            ranges: &ranges,
            width: shape[1],
            counts: &counts,
            angle_min: &angle_min,
            angle_increment: &angle_increment,
            max_range: &max_range,
        };
        Ok(laser::run(&log, &controls, &times, &config)?)
    })?;
    PyLaserRun::new(py, out, s)
}

/// One scan's points ([`laser_scan_points`]), frozen, arrays read-only: the kept
/// `points` (n, 2) in the laser frame and their unit `normals` (n, 2), NaN where a
/// point is on no line.
#[pyclass(name = "LaserScanPoints", module = "rperc._rperc", frozen, get_all)]
pub struct PyLaserScanPoints {
    points: Py<PyArrayDyn<f64>>,
    normals: Py<PyArrayDyn<f64>>,
}

/// One scan's points (laser frame) and their normals (NaN where a point is on no
/// line), with the `scan` part of a laser SLAM config.
#[pyfunction]
#[pyo3(signature = (ranges, angle_min, angle_increment, max_range, config = None))]
pub fn laser_scan_points<'py>(
    py: Python<'py>,
    ranges: &Bound<'py, PyAny>,
    angle_min: f64,
    angle_increment: f64,
    max_range: f64,
    config: Option<&Bound<'py, PyAny>>,
) -> PyResult<PyLaserScanPoints> {
    let config: laser::ScanConfig = crate::config::from_python(config, "scan")?;
    config.validate().map_err(Error::from)?;
    let ranges = float_vector(ranges, "ranges")?;
    let beams = laser::Beams {
        ranges: &ranges,
        angle_min,
        angle_increment,
        max_range,
    };
    let scan = laser::scan_points(&beams, &config).map_err(Error::from)?;
    let n = scan.points.len();
    let pts: Vec<f64> = scan.points.iter().flat_map(|p| [p.x, p.y]).collect();
    let nrm: Vec<f64> = scan
        .normals
        .iter()
        .flat_map(|v| v.map_or([f64::NAN; 2], |v| [v.x, v.y]))
        .collect();
    Ok(PyLaserScanPoints {
        points: frozen_array(py, pts, &[n, 2])?,
        normals: frozen_array(py, nrm, &[n, 2])?,
    })
}
