//! The monobot study of seed 000, section 2.2: a 1-D robot among static landmarks,
//! eqs. (14) to (23), Figures 3 to 6.
//!
//! Plant (eq. 19): `x_{k+1} = x_k + u_k + v_k`. Three measurement models:
//! - [`MeasurementModel::Relative`]: `z_i = l_i - x + w_i`, `H = [-1, I]` (eq. 2 with
//!   the fully correlated Jacobian): the Fisher information is singular;
//! - [`MeasurementModel::Anchor`]: a landmark at the origin serves as a global
//!   reference, `z_0 = -x + w_0` (eq. 20);
//! - [`MeasurementModel::External`]: a fixed sensor measures the robot, `z_0 = x + w_0`
//!   (eq. 23).

use std::f64::consts::PI;

use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng, rngs::StdRng};
use rand_distr::StandardNormal;
use rayon::prelude::*;

use crate::ekf::{Ekf, SparseJacobian};
use crate::error::{Result, SlamError};

/// Which measurement model the monobot uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MeasurementModel {
    /// Landmarks relative to the robot only: `H = [-1, I]` (unobservable).
    Relative,
    /// Plus a global reference landmark at the origin, eq. (20).
    Anchor,
    /// Plus an external sensor measuring the robot, eq. (23).
    External,
}

impl MeasurementModel {
    /// Rows of `z_k`: the landmarks, plus the reference for the observable models.
    pub fn observation_dim(self, landmarks: usize) -> usize {
        match self {
            MeasurementModel::Relative => landmarks,
            _ => landmarks + 1,
        }
    }

    /// The observation Jacobian `H` over `[x_r, l_1..l_n]` (eqs. 2, 20, 23).
    pub fn jacobian(self, landmarks: usize) -> SparseJacobian {
        let n = landmarks;
        let identity = DMatrix::identity(n, n);
        match self {
            MeasurementModel::Relative => SparseJacobian::new(n)
                .with_block(0, 0, DMatrix::from_element(n, 1, -1.0))
                .with_block(0, 1, identity),
            MeasurementModel::Anchor | MeasurementModel::External => {
                let sign = if self == MeasurementModel::Anchor {
                    -1.0
                } else {
                    1.0
                };
                let mut robot = DMatrix::from_element(n + 1, 1, -1.0);
                robot[(0, 0)] = sign;
                SparseJacobian::new(n + 1)
                    .with_block(0, 0, robot)
                    .with_block(1, 1, identity)
            }
        }
    }
}

/// A noise model: constant variance, or a standard deviation proportional to a
/// length (the motion command for the plant, the distance for a sensor).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Noise {
    /// This variance at every step.
    Constant(f64),
    /// Standard deviation `k * length + floor` (floor from the config).
    Proportional(f64),
}

impl Noise {
    fn variance(self, length: f64, floor: f64) -> f64 {
        match self {
            Noise::Constant(v) => v,
            Noise::Proportional(k) => (k * length.abs() + floor).powi(2),
        }
    }

    fn validate(self, name: &'static str) -> Result<()> {
        let v = match self {
            Noise::Constant(v) | Noise::Proportional(v) => v,
        };
        if v.is_finite() && v >= 0.0 {
            Ok(())
        } else {
            Err(SlamError::InvalidParameter {
                name,
                reason: format!("must be finite and >= 0, got {v}"),
            })
        }
    }
}

/// The monobot experiment. Defaults are the paper's run (Figs. 4 to 6).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MonobotConfig {
    /// Number of landmarks (>= 1), all at `landmark_position`.
    pub landmarks: usize,
    /// Iterations after the first observation (paper: 100).
    pub steps: usize,
    /// Start and end of the sinusoidal trajectory (paper: -1 m).
    pub start: f64,
    /// How far the robot moves out and back: `x(t) = start + amplitude (1 - cos(2 pi
    /// t / steps)) / 2` (default 1 m).
    pub amplitude: f64,
    /// Where the landmarks are (paper: 1 m).
    pub landmark_position: f64,
    /// Initial robot variance `P_r,0|0`, > 0 (default 1e-6 m^2: the paper's robot
    /// starts at a known -1 m; exactly 0 would leave `P` singular and the NEES
    /// undefined).
    pub initial_variance: f64,
    /// Plant noise `V` (paper: proportional to the motion command; default 10 %).
    pub plant_noise: Noise,
    /// Landmark measurement noise `W` (paper: proportional to the distance; default
    /// 5 %). Distances are nominal: planned robot position to `landmark_position`.
    pub measurement_noise: Noise,
    /// Noise of the reference observation `z_0` (anchor or external sensor), as a
    /// function of the robot's nominal distance to the origin (default 5 %).
    pub reference_noise: Noise,
    /// Standard deviation added to proportional models, so that a robot at rest or
    /// next to a landmark still has some noise (default 1 mm).
    pub noise_floor: f64,
}

impl Default for MonobotConfig {
    fn default() -> Self {
        Self {
            landmarks: 1,
            steps: 100,
            start: -1.0,
            amplitude: 1.0,
            landmark_position: 1.0,
            initial_variance: 1e-6,
            plant_noise: Noise::Proportional(0.1),
            measurement_noise: Noise::Proportional(0.05),
            reference_noise: Noise::Proportional(0.05),
            noise_floor: 1e-3,
        }
    }
}

impl MonobotConfig {
    /// Fig. 3's setting: `P_r,0|0 = V = W = 1` and `n` landmarks.
    pub fn unit_noise(landmarks: usize) -> Self {
        Self {
            landmarks,
            initial_variance: 1.0,
            plant_noise: Noise::Constant(1.0),
            measurement_noise: Noise::Constant(1.0),
            reference_noise: Noise::Constant(1.0),
            ..Self::default()
        }
    }

    /// Refuses bad values with the parameter's name.
    pub fn validate(&self) -> Result<()> {
        let bad =
            |name: &'static str, reason: String| Err(SlamError::InvalidParameter { name, reason });
        if self.landmarks == 0 {
            return bad("landmarks", "must be >= 1".into());
        }
        if self.steps == 0 {
            return bad("steps", "must be >= 1".into());
        }
        for (name, v) in [
            ("start", self.start),
            ("amplitude", self.amplitude),
            ("landmark_position", self.landmark_position),
        ] {
            if !v.is_finite() {
                return bad(name, format!("must be finite, got {v}"));
            }
        }
        // The NEES of every step needs a positive-definite P, and with P_r,0|0 = 0 the
        // first landmarks are initialised fully correlated with the robot (P singular).
        if !(self.initial_variance.is_finite() && self.initial_variance > 0.0) {
            return bad(
                "initial_variance",
                format!(
                    "must be finite and > 0 (use e.g. 1e-6 for a known start), got {}",
                    self.initial_variance
                ),
            );
        }
        for (name, v) in [("noise_floor", self.noise_floor)] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(name, format!("must be finite and >= 0, got {v}"));
            }
        }
        self.plant_noise.validate("plant_noise")?;
        self.measurement_noise.validate("measurement_noise")?;
        self.reference_noise.validate("reference_noise")
    }

    /// The commanded (noise-free) robot position at step `k`.
    pub fn planned_position(&self, k: usize) -> f64 {
        let phase = 2.0 * PI * k as f64 / self.steps as f64;
        self.start + self.amplitude * (1.0 - phase.cos()) / 2.0
    }
}

/// One simulated run. Per-step arrays are row-major; index 0 is the state after the
/// first observation initialised the landmarks, index `k` after update `k`.
#[derive(Debug, Clone, PartialEq)]
pub struct MonobotRun {
    /// State size `d = 1 + landmarks`.
    pub dim: usize,
    /// Observation size `p`.
    pub obs_dim: usize,
    /// Number of updates.
    pub steps: usize,
    /// True state, `(steps + 1) x d`.
    pub truth: Vec<f64>,
    /// Estimated state, `(steps + 1) x d`.
    pub estimate: Vec<f64>,
    /// Standard deviation of each state entry, `(steps + 1) x d`.
    pub std: Vec<f64>,
    /// Landmark measurements of the initialisation, `landmarks`.
    pub initial_measurement: Vec<f64>,
    /// Measurements of each update, `steps x p`.
    pub measurement: Vec<f64>,
    /// Innovations, `steps x p`.
    pub innovation: Vec<f64>,
    /// Innovation covariances S, `steps x p x p`.
    pub innovation_cov: Vec<f64>,
    /// Kalman gains K, `steps x d x p`.
    pub gain: Vec<f64>,
    /// Predicted covariances before each update, `steps x d x d`.
    pub predicted_cov: Vec<f64>,
    /// NEES of the whole state, `steps + 1`.
    pub nees: Vec<f64>,
    /// Total Fisher information J of eq. (14) at the end, `d x d`.
    pub fisher: DMatrix<f64>,
    /// `J[0, 0]` after each update (Fig. 3), `steps`.
    pub fisher_00: Vec<f64>,
    /// Each landmark's error right after its initialisation, `landmarks`.
    pub first_observation_error: Vec<f64>,
}

impl MonobotRun {
    /// The errors a Monte Carlo summary needs.
    pub fn errors(&self) -> RunErrors {
        let d = self.dim;
        let n = d - 1;
        let mut robot = Vec::with_capacity(self.steps + 1);
        let mut landmark = Vec::with_capacity((self.steps + 1) * n);
        for k in 0..=self.steps {
            let row = k * d;
            robot.push(self.estimate[row] - self.truth[row]);
            for i in 1..d {
                landmark.push(self.estimate[row + i] - self.truth[row + i]);
            }
        }
        RunErrors {
            landmarks: n,
            nees: self.nees.clone(),
            robot_error: robot,
            landmark_error: landmark,
            first_observation_error: self.first_observation_error.clone(),
        }
    }
}

/// A deterministic, well-mixed seed for run `run` of a Monte Carlo with `seed`
/// (SplitMix64), so that run `i` is the same whatever runs it in parallel.
pub fn run_seed(seed: u64, run: usize) -> u64 {
    let mut z = seed ^ (run as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Simulates one run of the monobot with `model`, seeded by `seed`.
///
/// # Examples
/// ```
/// use slam::monobot::{MeasurementModel, MonobotConfig, simulate};
///
/// let run = simulate(&MonobotConfig::default(), MeasurementModel::Anchor, 7).unwrap();
/// assert_eq!(run.dim, 2);
/// assert_eq!(run.nees.len(), 101);
/// ```
pub fn simulate(config: &MonobotConfig, model: MeasurementModel, seed: u64) -> Result<MonobotRun> {
    config.validate()?;
    let mut rng = StdRng::seed_from_u64(seed);
    let mut gauss = move || -> f64 { rng.sample(StandardNormal) };
    let n = config.landmarks;
    let d = n + 1;
    let p = model.observation_dim(n);
    let steps = config.steps;
    let floor = config.noise_floor;
    let landmarks_true = vec![config.landmark_position; n];

    // Initial robot: estimate at `start`, truth drawn from N(start, P0).
    let mut x_true = config.start + config.initial_variance.sqrt() * gauss();
    let mut ekf = Ekf::new(
        DVector::from_element(1, config.start),
        DMatrix::from_element(1, 1, config.initial_variance),
        1,
        1,
    )?;

    let mut run = MonobotRun {
        dim: d,
        obs_dim: p,
        steps,
        truth: Vec::with_capacity((steps + 1) * d),
        estimate: Vec::with_capacity((steps + 1) * d),
        std: Vec::with_capacity((steps + 1) * d),
        initial_measurement: Vec::with_capacity(n),
        measurement: Vec::with_capacity(steps * p),
        innovation: Vec::with_capacity(steps * p),
        innovation_cov: Vec::with_capacity(steps * p * p),
        gain: Vec::with_capacity(steps * d * p),
        predicted_cov: Vec::with_capacity(steps * d * d),
        nees: Vec::with_capacity(steps + 1),
        fisher: DMatrix::zeros(d, d),
        fisher_00: Vec::with_capacity(steps),
        first_observation_error: Vec::with_capacity(n),
    };

    // First observation: each landmark initialised with l = x + z (G_robot = G_z = 1).
    let one = DMatrix::from_element(1, 1, 1.0);
    for &l in &landmarks_true {
        let w = config
            .measurement_noise
            .variance(config.landmark_position - config.planned_position(0), floor);
        let z = l - x_true + w.sqrt() * gauss();
        let x_hat = ekf.state()[0];
        ekf.add_landmark(
            &DVector::from_element(1, x_hat + z),
            &one,
            &one,
            &DMatrix::from_element(1, 1, w),
        )?;
        run.initial_measurement.push(z);
        run.first_observation_error.push(x_hat + z - l);
    }
    record(&mut run, &ekf, x_true, &landmarks_true)?;

    let h = model.jacobian(n);
    let h_dense = h.to_dense(d);
    for k in 0..steps {
        // Prediction with the commanded motion, eqs. (3), (5), (19).
        let u = config.planned_position(k + 1) - config.planned_position(k);
        let v = config.plant_noise.variance(u, floor);
        x_true += u + v.sqrt() * gauss();
        let x_hat = ekf.state()[0] + u;
        ekf.predict(
            &DVector::from_element(1, x_hat),
            &one,
            &one,
            &DMatrix::from_element(1, 1, v),
        )?;
        run.predicted_cov.extend(row_major(&ekf.covariance()));

        // Observation and its predicted value.
        // Noise levels follow the nominal geometry (planned position, nominal landmark
        // position), known to the simulation and the filter alike, so W is exact.
        let mut z = DVector::zeros(p);
        let mut r = DMatrix::zeros(p, p);
        let offset = p - n;
        let state = ekf.state().clone();
        let x_nominal = config.planned_position(k + 1);
        if offset == 1 {
            // The anchor sits at the origin (z_0 = 0 - x); the external sensor reads x.
            let truth_z = match model {
                MeasurementModel::Anchor => -x_true,
                _ => x_true,
            };
            r[(0, 0)] = config.reference_noise.variance(x_nominal, floor);
            z[0] = truth_z + r[(0, 0)].sqrt() * gauss();
        }
        let w = config
            .measurement_noise
            .variance(config.landmark_position - x_nominal, floor);
        for (i, &l) in landmarks_true.iter().enumerate() {
            r[(offset + i, offset + i)] = w;
            z[offset + i] = l - x_true + w.sqrt() * gauss();
        }
        let innovation = &z - &h_dense * &state;
        let update = ekf.update(&innovation, &h, &r)?;

        // Fisher information, eq. (14): J += H^T S^-1 H.
        let s_inv = update
            .s
            .clone()
            .cholesky()
            .ok_or_else(|| SlamError::SingularInnovation("S lost definiteness".into()))?
            .inverse();
        run.fisher += h_dense.transpose() * s_inv * &h_dense;
        run.fisher_00.push(run.fisher[(0, 0)]);
        run.measurement.extend(z.iter());
        run.innovation.extend(innovation.iter());
        run.innovation_cov.extend(row_major(&update.s));
        run.gain.extend(row_major(&update.gain));
        record(&mut run, &ekf, x_true, &landmarks_true)?;
    }
    Ok(run)
}

fn row_major(m: &DMatrix<f64>) -> impl Iterator<Item = f64> + '_ {
    (0..m.nrows()).flat_map(move |i| (0..m.ncols()).map(move |j| m[(i, j)]))
}

fn record(run: &mut MonobotRun, ekf: &Ekf, x_true: f64, landmarks: &[f64]) -> Result<()> {
    let est = ekf.state();
    let cov = &ekf.covariance();
    let mut err = DVector::zeros(est.len());
    for i in 0..est.len() {
        let t = if i == 0 { x_true } else { landmarks[i - 1] };
        run.truth.push(t);
        run.estimate.push(est[i]);
        run.std.push(cov[(i, i)].max(0.0).sqrt());
        err[i] = est[i] - t;
    }
    run.nees.push(crate::gaussian::mahalanobis2(&err, cov)?);
    Ok(())
}

/// [`simulate`] for run `run` of a Monte Carlo seeded with `seed`.
pub fn simulate_run(
    config: &MonobotConfig,
    model: MeasurementModel,
    seed: u64,
    run: usize,
) -> Result<MonobotRun> {
    simulate(config, model, run_seed(seed, run))
}

/// `runs` independent runs on all cores. Run `i` uses [`run_seed`]`(seed, i)`, so
/// the result does not depend on the number of threads.
pub fn monte_carlo(
    config: &MonobotConfig,
    model: MeasurementModel,
    runs: usize,
    seed: u64,
) -> Result<Vec<MonobotRun>> {
    if runs == 0 {
        return Err(SlamError::InvalidParameter {
            name: "runs",
            reason: "must be >= 1".into(),
        });
    }
    (0..runs)
        .into_par_iter()
        .map(|i| simulate_run(config, model, seed, i))
        .collect()
}

/// The errors of one run that a Monte Carlo summary needs (`(steps + 1) x landmarks`
/// row-major for the landmark errors).
#[derive(Debug, Clone, PartialEq)]
pub struct RunErrors {
    /// Number of landmarks.
    pub landmarks: usize,
    /// NEES per step.
    pub nees: Vec<f64>,
    /// Robot error per step.
    pub robot_error: Vec<f64>,
    /// Landmark errors per step.
    pub landmark_error: Vec<f64>,
    /// Landmark errors right after initialisation.
    pub first_observation_error: Vec<f64>,
}

/// Statistics over Monte Carlo runs, as the paper reports them.
#[derive(Debug, Clone, PartialEq)]
pub struct MonteCarloSummary {
    /// Number of runs.
    pub runs: usize,
    /// Run-averaged NEES of the whole state per step.
    pub nees: Vec<f64>,
    /// The 95 % (or requested) band for `nees`.
    pub nees_band: (f64, f64),
    /// Fraction of steps whose averaged NEES lies inside the band.
    pub nees_in_band: f64,
    /// Mean over runs (and landmarks) of the landmark error per step.
    pub landmark_error_mean: Vec<f64>,
    /// Standard deviation over runs (and landmarks) of the landmark error per step.
    pub landmark_error_std: Vec<f64>,
    /// Mean over runs of the robot error per step.
    pub robot_error_mean: Vec<f64>,
    /// Standard deviation over runs of the robot error per step.
    pub robot_error_std: Vec<f64>,
    /// Final (steady-state) landmark error of each run and landmark, `runs x landmarks`.
    pub final_landmark_error: Vec<f64>,
    /// Error right after initialisation, `runs x landmarks`.
    pub first_observation_error: Vec<f64>,
    /// Least-squares slope of the final error on the first-observation error: how
    /// much of the first observation's error the map keeps.
    pub sensitivity: f64,
    /// Correlation of final and first-observation errors.
    pub correlation: f64,
}

/// Summarises runs of one experiment (same config and model).
pub fn summarize(runs: &[RunErrors], confidence: f64) -> Result<MonteCarloSummary> {
    let Some(first) = runs.first() else {
        return Err(SlamError::InvalidParameter {
            name: "runs",
            reason: "need at least one run".into(),
        });
    };
    let (n, len) = (first.landmarks, first.nees.len());
    if runs.iter().any(|r| {
        r.landmarks != n
            || r.nees.len() != len
            || r.robot_error.len() != len
            || r.landmark_error.len() != len * n
            || r.first_observation_error.len() != n
    }) {
        return Err(SlamError::Dimension(
            "runs of different experiments cannot be summarised together".into(),
        ));
    }
    let count = runs.len() as f64;
    let mean_std = |values: &mut dyn Iterator<Item = f64>| {
        let (mut s, mut s2, mut c) = (0.0, 0.0, 0.0);
        for v in values {
            s += v;
            s2 += v * v;
            c += 1.0;
        }
        let mean = s / c;
        (
            mean,
            ((s2 / c - mean * mean).max(0.0) * c / (c - 1.0).max(1.0)).sqrt(),
        )
    };
    let mut nees = Vec::with_capacity(len);
    let (mut lm_mean, mut lm_std, mut r_mean, mut r_std) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for k in 0..len {
        nees.push(runs.iter().map(|r| r.nees[k]).sum::<f64>() / count);
        let (m, s) = mean_std(
            &mut runs
                .iter()
                .flat_map(|r| r.landmark_error[k * n..(k + 1) * n].iter().copied()),
        );
        lm_mean.push(m);
        lm_std.push(s);
        let (m, s) = mean_std(&mut runs.iter().map(|r| r.robot_error[k]));
        r_mean.push(m);
        r_std.push(s);
    }
    let band = crate::stats::nees_bounds(n + 1, runs.len(), confidence)?;
    let inside = nees.iter().filter(|&&v| v >= band.0 && v <= band.1).count();
    let final_err: Vec<f64> = runs
        .iter()
        .flat_map(|r| r.landmark_error[(len - 1) * n..].iter().copied())
        .collect();
    let first_err: Vec<f64> = runs
        .iter()
        .flat_map(|r| r.first_observation_error.iter().copied())
        .collect();
    let (slope, corr) = regression(&first_err, &final_err);
    Ok(MonteCarloSummary {
        runs: runs.len(),
        nees,
        nees_band: band,
        nees_in_band: inside as f64 / len as f64,
        landmark_error_mean: lm_mean,
        landmark_error_std: lm_std,
        robot_error_mean: r_mean,
        robot_error_std: r_std,
        final_landmark_error: final_err,
        first_observation_error: first_err,
        sensitivity: slope,
        correlation: corr,
    })
}

/// Slope and correlation of the least-squares line of `y` on `x`.
fn regression(x: &[f64], y: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
    for (&a, &b) in x.iter().zip(y) {
        sxx += (a - mx) * (a - mx);
        syy += (b - my) * (b - my);
        sxy += (a - mx) * (b - my);
    }
    (sxy / sxx, sxy / (sxx * syy).sqrt())
}

/// The observability matrix `O = [H; H A; ...; H A^(d-1)]` of the monobot with `A =
/// I` (static landmarks, the robot's own motion is the known input).
pub fn observability_matrix(model: MeasurementModel, landmarks: usize) -> DMatrix<f64> {
    let d = landmarks + 1;
    let h = model.jacobian(landmarks).to_dense(d);
    let p = h.nrows();
    let mut o = DMatrix::zeros(p * d, d);
    for k in 0..d {
        // A = I, so every block row is H itself.
        o.view_mut((k * p, 0), (p, d)).copy_from(&h);
    }
    o
}

/// Numerical rank: singular values above `tol` times the largest.
pub fn rank(m: &DMatrix<f64>, tol: f64) -> usize {
    let sv = m.clone().singular_values();
    let max = sv.max();
    sv.iter().filter(|&&s| s > tol * max).count()
}

/// Rank of the observability matrix for `model` with `landmarks` landmarks: `d - 1`
/// for the relative model, `d` for anchor and external.
pub fn observability_rank(model: MeasurementModel, landmarks: usize) -> Result<usize> {
    if landmarks == 0 {
        return Err(SlamError::InvalidParameter {
            name: "landmarks",
            reason: "must be >= 1".into(),
        });
    }
    Ok(rank(&observability_matrix(model, landmarks), 1e-10))
}

/// Eigen-decomposition of a symmetric information matrix.
#[derive(Debug, Clone, PartialEq)]
pub struct InformationSpectrum {
    /// Eigenvalues, ascending.
    pub eigenvalues: DVector<f64>,
    /// Matching unit eigenvectors as columns.
    pub eigenvectors: DMatrix<f64>,
    /// Number of eigenvalues above `tol * max`.
    pub rank: usize,
}

/// Eigenvalues, rank and eigenvectors of a symmetric `J`.
pub fn information_spectrum(j: &DMatrix<f64>, tol: f64) -> Result<InformationSpectrum> {
    if !j.is_square() || j.nrows() == 0 {
        return Err(SlamError::Dimension(format!(
            "J must be square, got {:?}",
            j.shape()
        )));
    }
    crate::error::ensure_finite("J", j.iter())?;
    if !(tol.is_finite() && tol >= 0.0) {
        return Err(SlamError::InvalidParameter {
            name: "tol",
            reason: format!("must be finite and >= 0, got {tol}"),
        });
    }
    let sym = (j + j.transpose()) * 0.5;
    let eig = sym.symmetric_eigen();
    let mut order: Vec<usize> = (0..eig.eigenvalues.len()).collect();
    order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
    let values = DVector::from_iterator(order.len(), order.iter().map(|&k| eig.eigenvalues[k]));
    let mut vectors = DMatrix::zeros(j.nrows(), order.len());
    for (c, &k) in order.iter().enumerate() {
        vectors.set_column(c, &eig.eigenvectors.column(k));
    }
    let max = values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let rank = values.iter().filter(|&&v| v > tol * max).count();
    Ok(InformationSpectrum {
        eigenvalues: values,
        eigenvectors: vectors,
        rank,
    })
}

/// A basis of the unobservable directions: eigenvectors of `J` whose eigenvalues are
/// at most `tol` times the largest, as columns (`d x k`).
pub fn unobservable_directions(j: &DMatrix<f64>, tol: f64) -> Result<DMatrix<f64>> {
    let spec = information_spectrum(j, tol)?;
    let k = j.nrows() - spec.rank;
    Ok(spec.eigenvectors.columns(0, k).clone_owned())
}

/// The closed form of eq. (17) for one landmark and the relative model:
/// `J = [[1, -1], [-1, 1]] * sum 1 / s_i` from the scalar innovation variances `s_i`.
pub fn one_landmark_fisher(innovation_variances: &[f64]) -> DMatrix<f64> {
    let total: f64 = innovation_variances.iter().map(|s| 1.0 / s).sum();
    DMatrix::from_row_slice(2, 2, &[1.0, -1.0, -1.0, 1.0]) * total
}
