//! Bindings of the `slam` crate: the EKF and the monobot study.

use nalgebra::{DMatrix, DVector, Matrix2, Vector2};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayDyn};
use pyo3::prelude::*;
use slam::monobot::{self, MeasurementModel, MonobotConfig, RunErrors};

use crate::arrays::{float_vector, frozen_array, matrix, read_only, tensor, to_numpy};
use crate::errors::{Error, detached, detached_parallel, exclusive, shared};

fn vector(obj: &Bound<'_, PyAny>, name: &str) -> Result<DVector<f64>, Error> {
    Ok(DVector::from_vec(float_vector(obj, name)?))
}

/// What one measurement update did, frozen, arrays read-only: the `innovation` it
/// used, its covariance `innovation_cov` (`S`, eq. 8), the `gain` (`K`, eq. 7) and
/// the `nis`.
#[pyclass(name = "KalmanUpdate", module = "rperc._rperc", frozen, get_all)]
pub struct PyKalmanUpdate {
    innovation: Py<PyArrayDyn<f64>>,
    innovation_cov: Py<PyArray2<f64>>,
    gain: Py<PyArray2<f64>>,
    nis: f64,
}

impl PyKalmanUpdate {
    fn new(py: Python<'_>, up: &slam::Update) -> PyResult<Self> {
        let nu = up.innovation.as_slice().to_vec();
        Ok(Self {
            innovation: frozen_array(py, nu, &[up.innovation.len()])?,
            innovation_cov: read_only(to_numpy(py, &up.innovation_cov))?,
            gain: read_only(to_numpy(py, &up.gain))?,
            nis: up.nis,
        })
    }
}

/// The eigen-decomposition of a Fisher information matrix, frozen, arrays
/// read-only: `eigenvalues` ascending, `eigenvectors` as columns, and the `rank`.
#[pyclass(name = "InformationSpectrum", module = "rperc._rperc", frozen, get_all)]
pub struct PyInformationSpectrum {
    eigenvalues: Py<PyArrayDyn<f64>>,
    eigenvectors: Py<PyArray2<f64>>,
    rank: usize,
}

/// An extended Kalman filter over a robot block and landmark blocks.
#[pyclass(name = "Ekf", module = "rperc._rperc")]
pub struct PyEkf {
    inner: slam::Ekf,
}

#[pymethods]
impl PyEkf {
    #[new]
    #[pyo3(signature = (state, covariance, robot_dim, landmark_dim))]
    fn new(
        state: &Bound<'_, PyAny>,
        covariance: &Bound<'_, PyAny>,
        robot_dim: usize,
        landmark_dim: usize,
    ) -> PyResult<Self> {
        let inner = slam::Ekf::new(
            vector(state, "state")?,
            matrix(covariance, "covariance")?,
            robot_dim,
            landmark_dim,
        )
        .map_err(Error::from)?;
        Ok(Self { inner })
    }

    /// The state estimate (a copy).
    #[getter]
    fn state<'py>(slf: &Bound<'py, Self>, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let this = shared(slf)?;
        Ok(this.inner.state().as_slice().to_vec().into_pyarray(py))
    }

    /// Replaces the state estimate (same size, finite); the covariance is kept.
    #[setter]
    fn set_state(slf: &Bound<'_, Self>, state: &Bound<'_, PyAny>) -> PyResult<()> {
        let mut this = exclusive(slf)?;
        let x = vector(state, "state")?;
        Ok(this.inner.set_state(x).map_err(Error::from)?)
    }

    /// The state covariance (a copy).
    #[getter]
    fn covariance<'py>(
        slf: &Bound<'py, Self>,
        py: Python<'py>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let this = shared(slf)?;
        Ok(to_numpy(py, &this.inner.covariance()))
    }

    #[getter]
    fn robot_dim(&self) -> usize {
        self.inner.robot_dim()
    }

    #[getter]
    fn landmark_dim(&self) -> usize {
        self.inner.landmark_dim()
    }

    #[getter]
    fn num_landmarks(&self) -> usize {
        self.inner.num_landmarks()
    }

    /// Prediction: robot block to `robot_mean`, `P <- Fx P Fx^T + Fv V Fv^T`.
    fn predict(
        slf: &Bound<'_, Self>,
        py: Python<'_>,
        robot_mean: &Bound<'_, PyAny>,
        fx: &Bound<'_, PyAny>,
        fv: &Bound<'_, PyAny>,
        v: &Bound<'_, PyAny>,
    ) -> PyResult<()> {
        let mut this = exclusive(slf)?;
        let (mean, fx, fv, v) = (
            vector(robot_mean, "robot_mean")?,
            matrix(fx, "Fx")?,
            matrix(fv, "Fv")?,
            matrix(v, "V")?,
        );
        let ekf = &mut this.inner;
        detached(py, || Ok(ekf.predict(&mean, &fx, &fv, &v)?))
    }

    /// Update with `innovation`, a sparse `H` given as `[(row, col, block), ...]`,
    /// and noise `R`.
    fn update<'py>(
        slf: &Bound<'_, Self>,
        py: Python<'py>,
        innovation: &Bound<'py, PyAny>,
        blocks: Vec<(usize, usize, Bound<'py, PyAny>)>,
        r: &Bound<'py, PyAny>,
    ) -> PyResult<PyKalmanUpdate> {
        let mut this = exclusive(slf)?;
        let nu = vector(innovation, "innovation")?;
        let r = matrix(r, "R")?;
        let mut h = slam::SparseJacobian::new(nu.len());
        for (k, (row, col, block)) in blocks.iter().enumerate() {
            h.blocks.push(slam::JacobianBlock {
                row: *row,
                col: *col,
                h: matrix(block, &format!("blocks[{k}]"))?,
            });
        }
        let ekf = &mut this.inner;
        let up = detached(py, || Ok(ekf.update(&nu, &h, &r)?))?;
        PyKalmanUpdate::new(py, &up)
    }

    /// Range-bearing update of landmark `j` (planar robot, point landmarks); the
    /// bearing innovation is wrapped.
    fn update_range_bearing<'py>(
        slf: &Bound<'_, Self>,
        py: Python<'py>,
        j: usize,
        z: &Bound<'py, PyAny>,
        r: &Bound<'py, PyAny>,
    ) -> PyResult<PyKalmanUpdate> {
        let mut this = exclusive(slf)?;
        let (z, r) = range_bearing(z, r)?;
        let ekf = &mut this.inner;
        let up = detached(py, || Ok(ekf.update_range_bearing(j, &z, &r)?))?;
        PyKalmanUpdate::new(py, &up)
    }

    /// Adds a landmark from the inverse observation model; returns its index.
    fn add_landmark(
        slf: &Bound<'_, Self>,
        mean: &Bound<'_, PyAny>,
        g_robot: &Bound<'_, PyAny>,
        g_z: &Bound<'_, PyAny>,
        r: &Bound<'_, PyAny>,
    ) -> PyResult<usize> {
        let mut this = exclusive(slf)?;
        let (mean, gr, gz, r) = (
            vector(mean, "mean")?,
            matrix(g_robot, "G_robot")?,
            matrix(g_z, "G_z")?,
            matrix(r, "R")?,
        );
        Ok(this
            .inner
            .add_landmark(&mean, &gr, &gz, &r)
            .map_err(Error::from)?)
    }

    /// Adds a point landmark first seen at range-bearing `z`; returns its index.
    fn add_landmark_range_bearing(
        slf: &Bound<'_, Self>,
        z: &Bound<'_, PyAny>,
        r: &Bound<'_, PyAny>,
    ) -> PyResult<usize> {
        let mut this = exclusive(slf)?;
        let (z, r) = range_bearing(z, r)?;
        Ok(this
            .inner
            .add_landmark_range_bearing(&z, &r)
            .map_err(Error::from)?)
    }

    fn __repr__(&self) -> String {
        format!(
            "Ekf(robot_dim={}, landmark_dim={}, landmarks={}, state_dim={})",
            self.inner.robot_dim(),
            self.inner.landmark_dim(),
            self.inner.num_landmarks(),
            self.inner.state().len()
        )
    }
}

/// A range-bearing detection `z` (2 entries) and its noise `R` (2x2).
fn range_bearing(
    z: &Bound<'_, PyAny>,
    r: &Bound<'_, PyAny>,
) -> Result<(Vector2<f64>, Matrix2<f64>), Error> {
    let (z, r) = (vector(z, "z")?, matrix(r, "R")?);
    if z.len() != 2 || r.shape() != (2, 2) {
        return Err(Error::Value("z must have 2 entries and R be 2x2".into()));
    }
    Ok((
        Vector2::new(z[0], z[1]),
        Matrix2::from_iterator(r.iter().copied()),
    ))
}

fn parse_model(model: &str) -> Result<MeasurementModel, Error> {
    Ok(model.parse()?)
}

/// The monobot configuration from a dict of `MonobotConfig` fields, validated.
fn monobot_config(config: Option<&Bound<'_, PyAny>>) -> Result<MonobotConfig, Error> {
    let config: MonobotConfig = crate::config::from_python(config, "monobot")?;
    config.validate()?;
    Ok(config)
}

/// One monobot run, frozen, arrays read-only: the true and estimated states `(k+1,
/// d)` with the estimate's standard deviations, the measurements and innovations
/// with their covariances, the Kalman gains, the predicted covariances, the NEES,
/// the total Fisher information (eq. 14) and its first entry over time, and each
/// landmark's first-observation error.
#[pyclass(name = "MonobotRun", module = "rperc._rperc", frozen, get_all)]
pub struct PyMonobotRun {
    truth: Py<PyArrayDyn<f64>>,
    estimate: Py<PyArrayDyn<f64>>,
    std: Py<PyArrayDyn<f64>>,
    initial_measurement: Py<PyArrayDyn<f64>>,
    measurement: Py<PyArrayDyn<f64>>,
    innovation: Py<PyArrayDyn<f64>>,
    innovation_cov: Py<PyArrayDyn<f64>>,
    gain: Py<PyArrayDyn<f64>>,
    predicted_cov: Py<PyArrayDyn<f64>>,
    nees: Py<PyArrayDyn<f64>>,
    fisher: Py<PyArray2<f64>>,
    fisher_00: Py<PyArrayDyn<f64>>,
    first_observation_error: Py<PyArrayDyn<f64>>,
}

impl PyMonobotRun {
    fn new(py: Python<'_>, run: monobot::MonobotRun) -> PyResult<Self> {
        let (d, p, k) = (run.dim, run.obs_dim, run.steps);
        Ok(Self {
            truth: frozen_array(py, run.truth, &[k + 1, d])?,
            estimate: frozen_array(py, run.estimate, &[k + 1, d])?,
            std: frozen_array(py, run.std, &[k + 1, d])?,
            initial_measurement: frozen_array(py, run.initial_measurement, &[d - 1])?,
            measurement: frozen_array(py, run.measurement, &[k, p])?,
            innovation: frozen_array(py, run.innovation, &[k, p])?,
            innovation_cov: frozen_array(py, run.innovation_cov, &[k, p, p])?,
            gain: frozen_array(py, run.gain, &[k, d, p])?,
            predicted_cov: frozen_array(py, run.predicted_cov, &[k, d, d])?,
            nees: frozen_array(py, run.nees, &[k + 1])?,
            fisher: read_only(to_numpy(py, &run.fisher))?,
            fisher_00: frozen_array(py, run.fisher_00, &[k])?,
            first_observation_error: frozen_array(py, run.first_observation_error, &[d - 1])?,
        })
    }
}

/// Run `run` of the experiment seeded with `seed` (GIL released).
#[pyfunction]
#[pyo3(signature = (model, seed, run = 0, config = None))]
pub fn monobot_simulate<'py>(
    py: Python<'py>,
    model: &str,
    seed: u64,
    run: usize,
    config: Option<&Bound<'py, PyAny>>,
) -> PyResult<PyMonobotRun> {
    let model = parse_model(model)?;
    let cfg = monobot_config(config)?;
    let run = detached(py, || Ok(monobot::simulate_run(&cfg, model, seed, run)?))?;
    PyMonobotRun::new(py, run)
}

/// The errors of Monte Carlo runs, stacked, frozen, arrays read-only: NEES `(runs,
/// steps+1)`, robot error `(runs, steps+1)`, landmark errors `(runs, steps+1, n)` and
/// first-observation errors `(runs, n)`.
#[pyclass(name = "MonobotErrors", module = "rperc._rperc", frozen, get_all)]
pub struct PyMonobotErrors {
    nees: Py<PyArrayDyn<f64>>,
    robot_error: Py<PyArrayDyn<f64>>,
    landmark_error: Py<PyArrayDyn<f64>>,
    first_observation_error: Py<PyArrayDyn<f64>>,
}

/// The errors of `runs` Monte Carlo runs on all cores (GIL released), stacked. Run
/// `i` draws from stream `i` of `seed`.
#[pyfunction]
#[pyo3(signature = (model, runs, seed, config = None))]
pub fn monobot_monte_carlo<'py>(
    py: Python<'py>,
    model: &str,
    runs: usize,
    seed: u64,
    config: Option<&Bound<'py, PyAny>>,
) -> PyResult<PyMonobotErrors> {
    let model = parse_model(model)?;
    let cfg = monobot_config(config)?;
    let landmarks = cfg.landmarks;
    let steps = cfg.steps;
    let errors = detached_parallel(py, || {
        Ok(monobot::monte_carlo(&cfg, model, runs, seed)?
            .iter()
            .map(|r| r.errors())
            .collect::<Vec<_>>())
    })?;
    let (n, len) = (landmarks, steps + 1);
    let mut nees = Vec::with_capacity(runs * len);
    let mut robot = Vec::with_capacity(runs * len);
    let mut lm = Vec::with_capacity(runs * len * n);
    let mut first = Vec::with_capacity(runs * n);
    for e in errors {
        nees.extend(e.nees);
        robot.extend(e.robot_error);
        lm.extend(e.landmark_error);
        first.extend(e.first_observation_error);
    }
    Ok(PyMonobotErrors {
        nees: frozen_array(py, nees, &[runs, len])?,
        robot_error: frozen_array(py, robot, &[runs, len])?,
        landmark_error: frozen_array(py, lm, &[runs, len, n])?,
        first_observation_error: frozen_array(py, first, &[runs, n])?,
    })
}

/// Summary statistics of Monte Carlo runs, frozen, arrays read-only: the
/// run-averaged NEES and its band, the landmark and robot errors' mean and spread
/// over time, each run's final and first-observation landmark errors, and the
/// sensitivity (slope) and correlation of the final on the first.
#[pyclass(name = "MonobotSummary", module = "rperc._rperc", frozen, get_all)]
pub struct PyMonobotSummary {
    runs: usize,
    nees: Py<PyArray1<f64>>,
    nees_band: (f64, f64),
    nees_in_band: f64,
    landmark_error_mean: Py<PyArray1<f64>>,
    landmark_error_std: Py<PyArray1<f64>>,
    robot_error_mean: Py<PyArray1<f64>>,
    robot_error_std: Py<PyArray1<f64>>,
    final_landmark_error: Py<PyArrayDyn<f64>>,
    first_observation_error: Py<PyArrayDyn<f64>>,
    sensitivity: f64,
    correlation: f64,
}

/// The stacked run errors as `RunErrors`, checked for consistent shapes.
fn run_errors(
    nees: &Bound<'_, PyAny>,
    robot_error: &Bound<'_, PyAny>,
    landmark_error: &Bound<'_, PyAny>,
    first_observation_error: &Bound<'_, PyAny>,
) -> Result<Vec<RunErrors>, Error> {
    let nees = matrix(nees, "nees")?;
    let robot = matrix(robot_error, "robot_error")?;
    let first = matrix(first_observation_error, "first_observation_error")?;
    let (runs, len) = nees.shape();
    let n = first.ncols();
    let (lm_shape, lm) = tensor(landmark_error, "landmark_error", 3)?;
    if robot.shape() != (runs, len) || first.nrows() != runs || lm_shape != [runs, len, n] {
        return Err(Error::Value(
            "run error arrays have inconsistent shapes".into(),
        ));
    }
    Ok((0..runs)
        .map(|i| RunErrors {
            landmarks: n,
            nees: nees.row(i).iter().copied().collect(),
            robot_error: robot.row(i).iter().copied().collect(),
            landmark_error: lm[i * len * n..(i + 1) * len * n].to_vec(),
            first_observation_error: first.row(i).iter().copied().collect(),
        })
        .collect())
}

/// Summary statistics of stacked run errors (the arrays of a `MonobotErrors`).
#[pyfunction]
#[pyo3(signature = (nees, robot_error, landmark_error, first_observation_error, confidence = 0.95))]
pub fn monobot_summarize<'py>(
    py: Python<'py>,
    nees: &Bound<'py, PyAny>,
    robot_error: &Bound<'py, PyAny>,
    landmark_error: &Bound<'py, PyAny>,
    first_observation_error: &Bound<'py, PyAny>,
    confidence: f64,
) -> PyResult<PyMonobotSummary> {
    let per_run = run_errors(nees, robot_error, landmark_error, first_observation_error)?;
    let n = per_run.first().map_or(0, |r| r.landmarks);
    let s = monobot::summarize(&per_run, confidence).map_err(Error::from)?;
    let runs = s.runs;
    Ok(PyMonobotSummary {
        runs,
        nees: read_only(s.nees.into_pyarray(py))?,
        nees_band: s.nees_band,
        nees_in_band: s.nees_in_band,
        landmark_error_mean: read_only(s.landmark_error_mean.into_pyarray(py))?,
        landmark_error_std: read_only(s.landmark_error_std.into_pyarray(py))?,
        robot_error_mean: read_only(s.robot_error_mean.into_pyarray(py))?,
        robot_error_std: read_only(s.robot_error_std.into_pyarray(py))?,
        final_landmark_error: frozen_array(py, s.final_landmark_error, &[runs, n])?,
        first_observation_error: frozen_array(py, s.first_observation_error, &[runs, n])?,
        sensitivity: s.sensitivity,
        correlation: s.correlation,
    })
}

/// Rank of the monobot's observability matrix.
#[pyfunction]
pub fn monobot_observability_rank(model: &str, landmarks: usize) -> PyResult<usize> {
    Ok(monobot::observability_rank(parse_model(model)?, landmarks).map_err(Error::from)?)
}

/// Eigenvalues (ascending), eigenvectors (columns) and rank of a symmetric matrix.
#[pyfunction]
pub fn information_spectrum<'py>(
    py: Python<'py>,
    j: &Bound<'py, PyAny>,
    tol: f64,
) -> PyResult<PyInformationSpectrum> {
    let j: DMatrix<f64> = matrix(j, "J")?;
    let spec = monobot::information_spectrum(&j, tol).map_err(Error::from)?;
    let values = spec.eigenvalues.as_slice().to_vec();
    Ok(PyInformationSpectrum {
        eigenvalues: frozen_array(py, values.clone(), &[values.len()])?,
        eigenvectors: read_only(to_numpy(py, &spec.eigenvectors))?,
        rank: spec.rank,
    })
}

/// The band of the run-averaged NEES.
#[pyfunction]
pub fn nees_bounds(dof: usize, runs: usize, confidence: f64) -> PyResult<(f64, f64)> {
    Ok(rperc_core::nees_band(dof, runs, confidence).map_err(Error::from)?)
}
