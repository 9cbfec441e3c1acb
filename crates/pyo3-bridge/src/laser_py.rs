//! Laser SLAM (`laser` crate): a log's scans and odometry in, every scan's pose out.

use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::arrays::{float_vector, shaped, tensor};
use crate::errors::{Error, Result, detached};
use crate::planar_py::{int_rows, rows};
use laser::{LaserConfig, ScanLog};

/// The default laser SLAM settings as a dict (nested by part).
#[pyfunction]
pub fn laser_defaults(py: Python<'_>) -> PyResult<Bound<'_, PyAny>> {
    Ok(serde_pyobject::to_pyobject(py, &LaserConfig::default())?)
}

fn poses(v: &[rperc_core::Pose2]) -> Vec<f64> {
    v.iter().flat_map(|p| [p.x, p.y, p.theta]).collect()
}

/// Runs laser SLAM (GIL released): `ranges` `(S, n)` (NaN-padded), `counts` (int64,
/// readings per scan), per-scan `angle_min`, `angle_increment`, `max_range`,
/// odometry `controls` rows `(t, v, omega)` and the scans' `times`. Returns a dict of
/// arrays: `pose`, `covariance`, `causal_pose`, `matched`, `keys`, `closures`,
/// `closure_chi2` and the closure counts.
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
) -> PyResult<Bound<'py, PyDict>> {
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
    let d = PyDict::new(py);
    d.set_item("pose", shaped(py, poses(&out.pose), &[s, 3])?)?;
    let cov: Vec<f64> = out
        .covariance
        .iter()
        .flat_map(|c| c.transpose().iter().copied().collect::<Vec<_>>())
        .collect();
    d.set_item("covariance", shaped(py, cov, &[s, 3, 3])?)?;
    d.set_item("causal_pose", shaped(py, poses(&out.causal_pose), &[s, 3])?)?;
    d.set_item("matched", out.matched.into_pyarray(py))?;
    let inliers: Vec<i64> = out.inliers.iter().map(|&k| k as i64).collect();
    d.set_item("inliers", inliers.into_pyarray(py))?;
    d.set_item("rms", out.rms.into_pyarray(py))?;
    let keys: Vec<i64> = out.keys.iter().map(|&k| k as i64).collect();
    d.set_item("keys", keys.into_pyarray(py))?;
    let closures: Vec<f64> = out
        .closures
        .iter()
        .flat_map(|&(a, b)| [a as f64, b as f64])
        .collect();
    d.set_item("closures", shaped(py, closures, &[out.closures.len(), 2])?)?;
    d.set_item("closure_chi2", out.closure_chi2.into_pyarray(py))?;
    d.set_item("closures_rejected", out.closures_rejected)?;
    d.set_item("closure_attempts", out.closure_attempts)?;
    let reasons = [
        "inliers",
        "residual",
        "degenerate",
        "unconfirmed",
        "disagreeing",
    ];
    let why = PyDict::new(py);
    for (name, count) in reasons.iter().zip(out.rejections) {
        why.set_item(name, count)?;
    }
    d.set_item("rejections", why)?;
    Ok(d)
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
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
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
    Ok((
        shaped(py, pts, &[n, 2])?.into_any(),
        shaped(py, nrm, &[n, 2])?.into_any(),
    ))
}
