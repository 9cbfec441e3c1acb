//! Planar EKF-SLAM (`slam::planar`): one call runs a whole recording given as columnar
//! numpy arrays, with the GIL released, and returns the trajectory and the map as
//! arrays moved into numpy.

use numpy::{IntoPyArray, PyArray1, PyArrayDyn, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyTuple;
use slam::planar::sim::{SimConfig, check_runs, parallel_runs, run_nees};
use slam::planar::{
    Event, EventArrays, PlanarConfig, PlanarResult, PlanarSlam, Statistics, WallEstimate,
};
use std::sync::Mutex;

use crate::arrays::{column, float_vector, frozen_array, point_rows, read_only, shaped, tensor};
use crate::errors::{Error, Result, detached, detached_parallel};

/// Reads an `(N, K)` float array named `name` as rows; `None` is no rows.
pub(crate) fn rows<const K: usize>(
    obj: Option<&Bound<'_, PyAny>>,
    name: &str,
) -> Result<Vec<[f64; K]>> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else {
        return Ok(Vec::new());
    };
    let (shape, data) = tensor(obj, name, 2)?;
    if shape[1] != K {
        return Err(Error::Value(format!(
            "{name} must have shape (N, {K}), got {shape:?}"
        )));
    }
    Ok(data
        .chunks_exact(K)
        .map(|r| std::array::from_fn(|k| r[k]))
        .collect())
}

/// Reads the detections' ids (int64, one per detection; negative: unknown).
fn ids(obj: Option<&Bound<'_, PyAny>>, detections: usize) -> Result<Option<Vec<i64>>> {
    obj.filter(|o| !o.is_none())
        .map(|o| int_rows(o, "detection_ids", detections))
        .transpose()
}

/// Runs planar EKF-SLAM over a recording (GIL released): `controls` rows `(t, u0, u1)`,
/// `detections` rows `(t, range, bearing)` (equal times form one scan), optional
/// `detection_ids` (int64), `fixes` rows `(t, x, y, var_x, cov_xy, var_y)`, `walls`
/// rows `(t, rho, alpha, var_rho, cov, var_alpha, x0, y0, x1, y1)` (sensor frame,
/// equal times form one scan). Returns a [`PyPlanarRun`]: the robot after every event
/// and the final maps. `progress(done, total)`, when given, is called with the rows
/// consumed about every 1 % (with the GIL); an exception it raises stops the run and
/// is raised again.
#[pyfunction]
#[pyo3(signature = (controls, detections, detection_ids = None, fixes = None, config = None, walls = None, progress = None))]
#[allow(clippy::too_many_arguments)]
pub fn planar_slam_run<'py>(
    py: Python<'py>,
    controls: &Bound<'py, PyAny>,
    detections: &Bound<'py, PyAny>,
    detection_ids: Option<&Bound<'py, PyAny>>,
    fixes: Option<&Bound<'py, PyAny>>,
    config: Option<&Bound<'py, PyAny>>,
    walls: Option<&Bound<'py, PyAny>>,
    progress: Option<Py<PyAny>>,
) -> PyResult<PyPlanarRun> {
    let config: PlanarConfig = crate::config::from_python(config, "planar")?;
    config.validate().map_err(Error::from)?;
    let controls = rows::<3>(Some(controls), "controls")?;
    let detections = rows::<3>(Some(detections), "detections")?;
    let ids = ids(detection_ids, detections.len())?;
    let fixes = rows::<6>(fixes, "fixes")?;
    let walls = rows::<10>(walls, "walls")?;
    let raised: Mutex<Option<PyErr>> = Mutex::new(None);
    let report = |done: usize, total: usize| {
        let Some(callback) = &progress else {
            return true;
        };
        let called = Python::attach(|py| callback.call1(py, (done, total)).map(drop));
        let keep = |e| *raised.lock().unwrap_or_else(|p| p.into_inner()) = Some(e);
        called.map_err(keep).is_ok()
    };
    let result = detached(py, || {
        let mut engine = PlanarSlam::new(config)?;
        let arrays = EventArrays {
            controls: &controls,
            detections: &detections,
            detection_ids: ids.as_deref(),
            fixes: &fixes,
            walls: &walls,
        };
        engine.run_arrays_with(&arrays, report)?;
        Ok(engine.finish())
    });
    if let Some(e) = raised.lock().unwrap_or_else(|p| p.into_inner()).take() {
        return Err(e);
    }
    PyPlanarRun::new(py, result?)
}

/// What [`planar_slam_run`] returns, frozen: the robot after every event (`t`,
/// `kind` 0 control, 1 scan, 2 fix, `pose`, `covariance` of the pose, `seconds` each
/// event took), the point map (`landmark_*`), the wall map (`wall_*`, empty without
/// walls) with each wall detection's pairing (-1: left out), each point detection's
/// pairing (`point_pairing`, -1: rejected or a candidate), the association counts
/// and the anchor. Its arrays are read-only.
#[pyclass(name = "PlanarRun", module = "rperc._rperc", frozen, get_all)]
pub struct PyPlanarRun {
    t: Py<PyArray1<f64>>,
    kind: Py<PyArray1<u8>>,
    pose: Py<PyArrayDyn<f64>>,
    covariance: Py<PyArrayDyn<f64>>,
    seconds: Py<PyArray1<f64>>,
    landmark_id: Py<PyArray1<u64>>,
    landmark_mean: Py<PyArrayDyn<f64>>,
    landmark_covariance: Py<PyArrayDyn<f64>>,
    landmark_revisions: Py<PyArray1<u32>>,
    landmark_frozen: Py<PyArray1<bool>>,
    landmark_anchor: Py<PyArray1<bool>>,
    wall_id: Py<PyArray1<u64>>,
    wall_line: Py<PyArrayDyn<f64>>,
    wall_covariance: Py<PyArrayDyn<f64>>,
    wall_ends: Py<PyArrayDyn<f64>>,
    wall_revisions: Py<PyArray1<u32>>,
    wall_frozen: Py<PyArray1<bool>>,
    wall_anchor: Py<PyArray1<bool>>,
    wall_pairing: Py<PyArray1<i64>>,
    point_pairing: Py<PyArray1<i64>>,
    statistics: Py<PyPlanarStatistics>,
    anchor: Option<(f64, f64)>,
    anchor_time: Option<f64>,
}

#[pymethods]
impl PyPlanarRun {
    fn __repr__(&self, py: Python<'_>) -> String {
        let s = self.statistics.get();
        format!(
            "PlanarRun({} events, {} landmarks, {} walls; {} sightings accepted, {} rejected)",
            self.kind.bind(py).as_any().len().unwrap_or(0),
            self.landmark_id.bind(py).as_any().len().unwrap_or(0),
            self.wall_id.bind(py).as_any().len().unwrap_or(0),
            s.counts.accepted,
            s.counts.rejected
        )
    }
}

/// A pairing per detection, -1 for one left out (ids are admission counters or
/// data-set ids, far below `i64::MAX`).
fn pairing_column(pairing: &[Option<u64>]) -> Vec<i64> {
    pairing
        .iter()
        .map(|p| p.map_or(-1, |id| id as i64))
        .collect()
}

impl PyPlanarRun {
    fn new(py: Python<'_>, r: PlanarResult) -> PyResult<Self> {
        let tr = r.trajectory;
        let n = tr.t.len();
        let kind: Vec<u8> = tr.kind.iter().map(|&k| k as u8).collect();
        let lm = &r.landmarks;
        let k = lm.len();
        let walls = WallArrays::new(py, &r.walls)?;
        // -1: a detection left out (ids are admission counters, far below i64::MAX).
        let pairing = pairing_column(&r.wall_pairing);
        let point_pairing = pairing_column(&r.point_pairing);
        Ok(Self {
            t: read_only(tr.t.into_pyarray(py))?,
            kind: read_only(kind.into_pyarray(py))?,
            pose: frozen_array(py, tr.pose.concat(), &[n, 3])?,
            covariance: frozen_array(py, tr.covariance.concat(), &[n, 3, 3])?,
            seconds: read_only(tr.seconds.into_pyarray(py))?,
            landmark_id: column(py, lm, |l| l.id)?,
            landmark_mean: frozen_array(py, lm.iter().flat_map(|l| l.mean).collect(), &[k, 2])?,
            landmark_covariance: frozen_array(
                py,
                lm.iter().flat_map(|l| l.covariance).collect(),
                &[k, 2, 2],
            )?,
            landmark_revisions: column(py, lm, |l| l.revisions)?,
            landmark_frozen: column(py, lm, |l| l.frozen)?,
            landmark_anchor: column(py, lm, |l| l.anchor)?,
            wall_id: walls.id,
            wall_line: walls.line,
            wall_covariance: walls.covariance,
            wall_ends: walls.ends,
            wall_revisions: walls.revisions,
            wall_frozen: walls.frozen,
            wall_anchor: walls.anchor,
            wall_pairing: read_only(pairing.into_pyarray(py))?,
            point_pairing: read_only(point_pairing.into_pyarray(py))?,
            statistics: Py::new(
                py,
                PyPlanarStatistics {
                    counts: r.statistics,
                },
            )?,
            anchor: r.anchor.map(|a| (a[0], a[1])),
            anchor_time: r.anchor_time,
        })
    }
}

/// The wall map's arrays, read-only.
struct WallArrays {
    id: Py<PyArray1<u64>>,
    line: Py<PyArrayDyn<f64>>,
    covariance: Py<PyArrayDyn<f64>>,
    ends: Py<PyArrayDyn<f64>>,
    revisions: Py<PyArray1<u32>>,
    frozen: Py<PyArray1<bool>>,
    anchor: Py<PyArray1<bool>>,
}

impl WallArrays {
    fn new(py: Python<'_>, walls: &[WallEstimate]) -> PyResult<Self> {
        let k = walls.len();
        let ends: Vec<f64> = walls
            .iter()
            .flat_map(|w| [w.start, w.end].concat())
            .collect();
        Ok(Self {
            id: column(py, walls, |w| w.id)?,
            line: frozen_array(py, walls.iter().flat_map(|w| w.line).collect(), &[k, 2])?,
            covariance: frozen_array(
                py,
                walls.iter().flat_map(|w| w.covariance).collect(),
                &[k, 2, 2],
            )?,
            ends: frozen_array(py, ends, &[k, 2, 2])?,
            revisions: column(py, walls, |w| w.revisions)?,
            frozen: column(py, walls, |w| w.frozen)?,
            anchor: column(py, walls, |w| w.anchor)?,
        })
    }
}

/// The association counts of a planar run, frozen, by name (`names` lists them).
#[pyclass(name = "PlanarStatistics", module = "rperc._rperc", frozen)]
pub struct PyPlanarStatistics {
    counts: Statistics,
}

/// Every count of [`Statistics`] with its name, in one order.
fn statistics_items(s: &Statistics) -> [(&'static str, u64); 15] {
    [
        ("accepted", s.accepted),
        ("rejected", s.rejected),
        ("new", s.new),
        ("candidate", s.candidate),
        ("frozen", s.frozen),
        ("fixes_applied", s.fixes_applied),
        ("fixes_rejected", s.fixes_rejected),
        ("fixes_ignored", s.fixes_ignored),
        ("jcbb_truncated", s.jcbb_truncated),
        ("walls_accepted", s.walls_accepted),
        ("walls_rejected", s.walls_rejected),
        ("walls_new", s.walls_new),
        ("walls_vague", s.walls_vague),
        ("compressions", s.compressions),
        ("activations", s.activations),
    ]
}

#[pymethods]
impl PyPlanarStatistics {
    /// The counts' names, in the order of `values`.
    #[classattr]
    fn names(py: Python<'_>) -> PyResult<Bound<'_, PyTuple>> {
        PyTuple::new(py, statistics_items(&Statistics::default()).map(|(n, _)| n))
    }

    /// The counts, in the order of `names`.
    #[getter]
    fn values<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        PyTuple::new(py, statistics_items(&self.counts).map(|(_, v)| v))
    }

    fn __repr__(&self) -> String {
        let items: Vec<String> = statistics_items(&self.counts)
            .iter()
            .map(|(n, v)| format!("{n}={v}"))
            .collect();
        format!("PlanarStatistics({})", items.join(", "))
    }
}

fn sim_config(obj: Option<&Bound<'_, PyAny>>) -> Result<SimConfig> {
    let sim: SimConfig = crate::config::from_python(obj, "planar sim")?;
    sim.validate()?;
    Ok(sim)
}

/// The filter config that matches a simulated world (same noise, same start), as a
/// dict for the caller to change (the variants) before a Monte Carlo.
#[pyfunction]
#[pyo3(signature = (sim = None))]
pub fn planar_sim_slam_config<'py>(
    py: Python<'py>,
    sim: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let cfg = sim_config(sim)?.slam_config();
    serde_pyobject::to_pyobject(py, &cfg).map_err(PyErr::from)
}

/// Checks the world, the filter and `runs` as [`planar_sim_nees`] would, without running
/// anything: a caller that sends the runs elsewhere (an executor) is refused at once.
#[pyfunction]
#[pyo3(signature = (sim, slam, runs))]
pub fn planar_sim_check(
    sim: Option<&Bound<'_, PyAny>>,
    slam: Option<&Bound<'_, PyAny>>,
    runs: u64,
) -> PyResult<()> {
    let sim = sim_config(sim)?;
    let slam: PlanarConfig = crate::config::from_python(slam, "planar")?;
    slam.validate().map_err(Error::from)?;
    let runs = usize::try_from(runs).unwrap_or(usize::MAX);
    Ok(check_runs(runs, sim.steps).map_err(Error::from)?)
}

/// The robot NEES after each scan of runs `first..first + runs` of the simulated world
/// seeded by `seed` (run `i` draws from stream `i`), as a `(runs, steps)` array; the
/// runs go in parallel on all cores with the GIL released.
#[pyfunction]
#[pyo3(signature = (sim, slam, seed, first, runs))]
pub fn planar_sim_nees<'py>(
    py: Python<'py>,
    sim: Option<&Bound<'py, PyAny>>,
    slam: Option<&Bound<'py, PyAny>>,
    seed: u64,
    first: u64,
    runs: u64,
) -> PyResult<Bound<'py, numpy::PyArrayDyn<f64>>> {
    let sim = sim_config(sim)?;
    let slam: PlanarConfig = crate::config::from_python(slam, "planar")?;
    slam.validate().map_err(Error::from)?;
    let steps = sim.steps;
    let runs = usize::try_from(runs).unwrap_or(usize::MAX);
    let nees = detached_parallel(py, || {
        let per_run = parallel_runs(first, runs, steps, |r| run_nees(&sim, &slam, seed, r))?;
        Ok(per_run.concat())
    })?;
    Ok(shaped(py, nees, &[runs, steps])?)
}

/// Run `run` of the simulated world seeded by `seed` as the columnar arrays
/// `PlanarSlam` reads (`controls`, `detections`, `detection_ids`, `fixes`), with the
/// true pose after every event (`truth`, rows `t, x, y, theta`) and the true
/// `landmarks` (landmark `i` has id `i`).
#[pyfunction]
#[pyo3(signature = (sim, seed, run = 0))]
pub fn planar_simulate<'py>(
    py: Python<'py>,
    sim: Option<&Bound<'py, PyAny>>,
    seed: u64,
    run: u64,
) -> PyResult<PySimulatedWorld> {
    let sim = sim_config(sim)?;
    let data = detached(py, || Ok(slam::planar::sim::simulate(&sim, seed, run)?))?;
    let (mut controls, mut detections, mut ids, mut fixes, mut truth) = (
        Vec::new(),
        Vec::new(),
        Vec::<i64>::new(),
        Vec::new(),
        Vec::new(),
    );
    for (event, pose) in data.events.iter().zip(&data.truth) {
        truth.extend([event.time(), pose.x, pose.y, pose.theta]);
        match event {
            Event::Control { t, control } => controls.extend([*t, control[0], control[1]]),
            Event::Scan { t, detections: ds } => {
                for d in ds {
                    detections.extend([*t, d.range, d.bearing]);
                    ids.push(d.id.map_or(-1, |i| i as i64));
                }
            }
            Event::Fix { t, xy, covariance } => {
                fixes.extend([*t, xy[0], xy[1]]);
                fixes.extend(covariance);
            }
            // The point-landmark simulator makes no wall scans.
            Event::Walls { .. } => {}
        }
    }
    let rows = |v: &Vec<f64>, k: usize| v.len() / k;
    let marks: Vec<f64> = data.landmarks.iter().flat_map(|p| [p.x, p.y]).collect();
    Ok(PySimulatedWorld {
        controls: frozen_array(py, controls.clone(), &[rows(&controls, 3), 3])?,
        detections: frozen_array(py, detections.clone(), &[rows(&detections, 3), 3])?,
        detection_ids: read_only(ids.into_pyarray(py))?,
        fixes: frozen_array(py, fixes.clone(), &[rows(&fixes, 6), 6])?,
        truth: frozen_array(py, truth.clone(), &[rows(&truth, 4), 4])?,
        landmarks: frozen_array(py, marks, &[data.landmarks.len(), 2])?,
    })
}

/// One simulated recording ([`planar_simulate`]), frozen, arrays read-only: the
/// columnar `controls` `(t, v, omega)`, `detections` `(t, range, bearing)` with their
/// `detection_ids`, `fixes` `(t, x, y, var_x, cov_xy, var_y)`, the true pose after
/// every event `truth` `(t, x, y, theta)` and the true `landmarks` `(n, 2)`.
#[pyclass(name = "SimulatedWorld", module = "rperc._rperc", frozen, get_all)]
pub struct PySimulatedWorld {
    controls: Py<PyArrayDyn<f64>>,
    detections: Py<PyArrayDyn<f64>>,
    detection_ids: Py<PyArray1<i64>>,
    fixes: Py<PyArrayDyn<f64>>,
    truth: Py<PyArrayDyn<f64>>,
    landmarks: Py<PyArrayDyn<f64>>,
}

/// [`slam::wall::straightness_covariance`] of each sensor-frame wall `(rho[k],
/// alpha[k])` seen from `start[k]` to `end[k]` ((K, 2) each), as a (K, 2, 2) array.
#[pyfunction]
pub fn wall_straightness_covariance<'py>(
    py: Python<'py>,
    rho: &Bound<'py, PyAny>,
    alpha: &Bound<'py, PyAny>,
    start: &Bound<'py, PyAny>,
    end: &Bound<'py, PyAny>,
    sigma: f64,
) -> PyResult<Bound<'py, numpy::PyArrayDyn<f64>>> {
    use nalgebra::Vector2;
    let (rho, alpha) = (float_vector(rho, "rho")?, float_vector(alpha, "alpha")?);
    let (start, end) = (point_rows(start, "start")?, point_rows(end, "end")?);
    let (start, end) = (start.as_points(), end.as_points());
    let k = rho.len();
    if alpha.len() != k || start.len() != k || end.len() != k {
        return Err(Error::Value(format!(
            "rho, alpha, start and end must have one row per wall, got {k}, {}, {} and {}",
            alpha.len(),
            start.len(),
            end.len()
        ))
        .into());
    }
    if !(sigma.is_finite() && sigma >= 0.0) {
        return Err(Error::Value(format!("sigma must be finite and >= 0, got {sigma}")).into());
    }
    let values = rho.iter().chain(&alpha);
    let points = start.iter().chain(end).flat_map(|p| [p.x, p.y]);
    if !values.copied().chain(points).all(f64::is_finite) {
        return Err(Error::Value("rho, alpha, start and end must be finite".into()).into());
    }
    let mut out = Vec::with_capacity(4 * k);
    for i in 0..k {
        let ends = [start[i], end[i]];
        let c = slam::wall::straightness_covariance(&Vector2::new(rho[i], alpha[i]), &ends, sigma);
        out.extend([c[(0, 0)], c[(0, 1)], c[(1, 0)], c[(1, 1)]]);
    }
    Ok(shaped(py, out, &[k, 2, 2])?)
}

/// Reads an int64 array of `n` entries named `name`.
pub(crate) fn int_rows(obj: &Bound<'_, PyAny>, name: &str, n: usize) -> Result<Vec<i64>> {
    let a: PyReadonlyArray1<'_, i64> = obj
        .extract()
        .map_err(|_| Error::Type(format!("{name} must be a 1-D int64 numpy array")))?;
    let a = a.as_array().to_vec();
    if a.len() != n {
        return Err(Error::Value(format!(
            "{name} has {} entries for {n} rows",
            a.len()
        )));
    }
    Ok(a)
}
/// Smooths a SLAM run ([`slam::planar::smooth::smooth`], GIL released): the filter's
/// `controls`, `walls` and `points` rows and `config`, the pose `times` with the
/// filter's `poses` there `(S, 3)`; for walls, `pairing` (int64 per wall row, -1:
/// unused) and the final map `map_id` (int64) with `map_line` `(W, 2)`; for points,
/// `point_pairing` (int64 per point row, -1: unused) and the final landmarks
/// `landmark_id` (int64) with `landmark_mean` `(L, 2)`. Returns a [`PySmoothedRun`].
#[pyfunction]
#[pyo3(signature = (controls, times, poses, walls, pairing, map_id, map_line, points, point_pairing, landmark_id, landmark_mean, config = None, options = None))]
#[allow(clippy::too_many_arguments)]
pub fn planar_smooth<'py>(
    py: Python<'py>,
    controls: &Bound<'py, PyAny>,
    times: &Bound<'py, PyAny>,
    poses: &Bound<'py, PyAny>,
    walls: &Bound<'py, PyAny>,
    pairing: &Bound<'py, PyAny>,
    map_id: &Bound<'py, PyAny>,
    map_line: &Bound<'py, PyAny>,
    points: &Bound<'py, PyAny>,
    point_pairing: &Bound<'py, PyAny>,
    landmark_id: &Bound<'py, PyAny>,
    landmark_mean: &Bound<'py, PyAny>,
    config: Option<&Bound<'py, PyAny>>,
    options: Option<&Bound<'py, PyAny>>,
) -> PyResult<PySmoothedRun> {
    use slam::planar::smooth::{FilterRun, SmootherConfig, smooth};
    let config: PlanarConfig = crate::config::from_python(config, "planar")?;
    let options: SmootherConfig = crate::config::from_python(options, "smoother")?;
    let controls = rows::<3>(Some(controls), "controls")?;
    let times = float_vector(times, "times")?;
    let poses = rows::<3>(Some(poses), "poses")?;
    let walls = rows::<10>(Some(walls), "walls")?;
    let pairing = optional_ids(pairing, "pairing", walls.len())?;
    let map = id_rows(map_id, "map_id", map_line, "map_line")?;
    let points = rows::<3>(Some(points), "points")?;
    let point_pairing = optional_ids(point_pairing, "point_pairing", points.len())?;
    let landmarks = id_rows(landmark_id, "landmark_id", landmark_mean, "landmark_mean")?;
    let out = detached(py, || {
        let run = FilterRun {
            config: &config,
            controls: &controls,
            times: &times,
            poses: &poses,
            walls: &walls,
            pairing: &pairing,
            map: &map,
            points: &points,
            point_pairing: &point_pairing,
            landmarks: &landmarks,
        };
        Ok(smooth(&run, &options)?)
    })?;
    PySmoothedRun::new(py, out)
}

/// One id per row (int64), a negative one read as `None` (unused).
fn optional_ids(ids: &Bound<'_, PyAny>, name: &str, n: usize) -> PyResult<Vec<Option<u64>>> {
    let ids = int_rows(ids, name, n)?;
    Ok(ids.iter().map(|&p| u64::try_from(p).ok()).collect())
}

/// Ids (int64, `>= 0`) paired with `(N, 2)` rows.
fn id_rows(
    ids: &Bound<'_, PyAny>,
    id_name: &str,
    values: &Bound<'_, PyAny>,
    name: &str,
) -> PyResult<Vec<(u64, [f64; 2])>> {
    let values = rows::<2>(Some(values), name)?;
    let ids = int_rows(ids, id_name, values.len())?;
    let out = ids
        .iter()
        .zip(&values)
        .map(|(&id, v)| {
            u64::try_from(id)
                .map(|id| (id, *v))
                .map_err(|_| Error::Value(format!("{id_name} must be >= 0, got {id}")))
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(out)
}

/// What [`planar_smooth`] returns, frozen, arrays read-only: every time's smoothed
/// pose `(S, 3)` and marginal covariance `(S, 3, 3)`, the wall map (`wall_id`,
/// `wall_line` `(W, 2)`, `wall_covariance` `(W, 2, 2)`, `wall_ends` `(W, 2, 2)`), the
/// point landmarks (`landmark_id`, `landmark_mean` `(L, 2)`, `landmark_covariance`
/// `(L, 2, 2)`), the odometry bias `(s, b)` (zeros without bias states), and the Levenberg-Marquardt
/// iterations, final cost and residual count.
#[pyclass(name = "SmoothedRun", module = "rperc._rperc", frozen, get_all)]
pub struct PySmoothedRun {
    pose: Py<PyArrayDyn<f64>>,
    covariance: Py<PyArrayDyn<f64>>,
    wall_id: Py<PyArray1<i64>>,
    wall_line: Py<PyArrayDyn<f64>>,
    wall_covariance: Py<PyArrayDyn<f64>>,
    wall_ends: Py<PyArrayDyn<f64>>,
    landmark_id: Py<PyArray1<i64>>,
    landmark_mean: Py<PyArrayDyn<f64>>,
    landmark_covariance: Py<PyArrayDyn<f64>>,
    bias: (f64, f64),
    iterations: usize,
    cost: f64,
    residuals: usize,
}

#[pymethods]
impl PySmoothedRun {
    fn __repr__(&self) -> String {
        format!(
            "SmoothedRun(cost {:.6e} over {} residuals after {} iterations)",
            self.cost, self.residuals, self.iterations
        )
    }
}

impl PySmoothedRun {
    fn new(py: Python<'_>, out: slam::planar::smooth::SmoothedRun) -> PyResult<Self> {
        let (s, w) = (out.pose.len(), out.walls.len());
        let walls = &out.walls;
        let ids: Vec<i64> = walls.iter().map(|w| w.id as i64).collect();
        let (marks, l) = (&out.landmarks, out.landmarks.len());
        let mark_ids: Vec<i64> = marks.iter().map(|m| m.id as i64).collect();
        Ok(Self {
            pose: frozen_array(py, out.pose.concat(), &[s, 3])?,
            covariance: frozen_array(py, out.covariance.concat(), &[s, 3, 3])?,
            wall_id: read_only(ids.into_pyarray(py))?,
            wall_line: frozen_array(py, walls.iter().flat_map(|w| w.line).collect(), &[w, 2])?,
            wall_covariance: frozen_array(
                py,
                walls.iter().flat_map(|w| w.covariance).collect(),
                &[w, 2, 2],
            )?,
            wall_ends: frozen_array(
                py,
                walls.iter().flat_map(|w| w.ends.concat()).collect(),
                &[w, 2, 2],
            )?,
            landmark_id: read_only(mark_ids.into_pyarray(py))?,
            landmark_mean: frozen_array(py, marks.iter().flat_map(|m| m.mean).collect(), &[l, 2])?,
            landmark_covariance: frozen_array(
                py,
                marks.iter().flat_map(|m| m.covariance).collect(),
                &[l, 2, 2],
            )?,
            bias: (out.bias[0], out.bias[1]),
            iterations: out.iterations,
            cost: out.cost,
            residuals: out.residuals,
        })
    }
}
