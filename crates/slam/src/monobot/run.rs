//! One simulated monobot run: truth, EKF estimate, innovations, gains and the Fisher
//! information accumulated along the way.

use nalgebra::{DMatrix, DVector};
use rperc_core::CoreError;
use rperc_core::rng::{RngStream, normal, stream};

use super::model::{MeasurementModel, MonobotConfig};
use crate::ekf::{Ekf, INTERRUPTIBLE_ROWS, SparseJacobian, Update};
use crate::error::{Result, SlamError};

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
    fn with_capacity(d: usize, p: usize, steps: usize) -> Self {
        Self {
            dim: d,
            obs_dim: p,
            steps,
            truth: Vec::with_capacity((steps + 1) * d),
            estimate: Vec::with_capacity((steps + 1) * d),
            std: Vec::with_capacity((steps + 1) * d),
            initial_measurement: Vec::with_capacity(d - 1),
            measurement: Vec::with_capacity(steps * p),
            innovation: Vec::with_capacity(steps * p),
            innovation_cov: Vec::with_capacity(steps * p * p),
            gain: Vec::with_capacity(steps * d * p),
            predicted_cov: Vec::with_capacity(steps * d * d),
            nees: Vec::with_capacity(steps + 1),
            fisher: DMatrix::zeros(d, d),
            fisher_00: Vec::with_capacity(steps),
            first_observation_error: Vec::with_capacity(d - 1),
        }
    }

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

/// Simulates one run of the monobot with `model`, seeded by `seed` (stream 0).
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
    simulate_run(config, model, seed, 0)
}

/// Run `run` of a Monte Carlo seeded with `seed`: it draws from stream `run` of
/// `seed`, so it is the same whichever worker runs it.
pub fn simulate_run(
    config: &MonobotConfig,
    model: MeasurementModel,
    seed: u64,
    run: usize,
) -> Result<MonobotRun> {
    config.validate()?;
    let mut sim = Simulation::start(config, model, stream(seed, run as u64))?;
    for k in 0..config.steps {
        rperc_core::interrupt::checkpoint()?;
        sim.step(k)?;
    }
    Ok(sim.run)
}

/// The state of one simulation: truth, filter, random stream and the record so far.
struct Simulation<'a> {
    config: &'a MonobotConfig,
    model: MeasurementModel,
    rng: RngStream,
    x_true: f64,
    ekf: Ekf,
    h: SparseJacobian,
    h_dense: DMatrix<f64>,
    run: MonobotRun,
}

fn scalar(v: f64) -> DMatrix<f64> {
    DMatrix::from_element(1, 1, v)
}

impl<'a> Simulation<'a> {
    /// The robot drawn from `N(start, P0)`, and each landmark initialised from the
    /// first observation with `l = x + z` (`G_robot = G_z = 1`).
    fn start(
        config: &'a MonobotConfig,
        model: MeasurementModel,
        mut rng: RngStream,
    ) -> Result<Self> {
        let n = config.landmarks;
        let (d, p, steps) = (n + 1, model.observation_dim(n), config.steps);
        let x_true = config.start + config.initial_variance.sqrt() * normal(&mut rng);
        let ekf = Ekf::new(
            DVector::from_element(1, config.start),
            scalar(config.initial_variance),
            1,
            1,
        )?;
        let h = model.jacobian(n);
        let h_dense = h.to_dense(d);
        let mut sim = Self {
            config,
            model,
            rng,
            x_true,
            ekf,
            h,
            h_dense,
            run: MonobotRun::with_capacity(d, p, steps),
        };
        sim.initialise_landmarks()?;
        sim.record()?;
        Ok(sim)
    }

    fn initialise_landmarks(&mut self) -> Result<()> {
        let c = self.config;
        let w = c
            .measurement_noise
            .variance(c.landmark_position - c.planned_position(0), c.noise_floor);
        for _ in 0..c.landmarks {
            // Each addition grows P: thousands of landmarks take minutes.
            rperc_core::interrupt::checkpoint()?;
            let z = c.landmark_position - self.x_true + w.sqrt() * normal(&mut self.rng);
            let x_hat = self.ekf.state()[0];
            self.ekf.add_landmark(
                &DVector::from_element(1, x_hat + z),
                &scalar(1.0),
                &scalar(1.0),
                &scalar(w),
            )?;
            self.run.initial_measurement.push(z);
            self.run
                .first_observation_error
                .push(x_hat + z - c.landmark_position);
        }
        Ok(())
    }

    /// Step `k`: prediction with the commanded motion (eqs. 3, 5, 19), then the update
    /// with every measurement, and the Fisher information (eq. 14).
    fn step(&mut self, k: usize) -> Result<()> {
        let c = self.config;
        let u = c.planned_position(k + 1) - c.planned_position(k);
        let v = c.plant_noise.variance(u, c.noise_floor);
        self.x_true += u + v.sqrt() * normal(&mut self.rng);
        let x_hat = self.ekf.state()[0] + u;
        self.ekf.predict(
            &DVector::from_element(1, x_hat),
            &scalar(1.0),
            &scalar(1.0),
            &scalar(v),
        )?;
        self.run
            .predicted_cov
            .extend(row_major(&self.ekf.covariance()));
        let (z, r) = self.observe(c.planned_position(k + 1));
        let innovation = &z - &self.h_dense * self.ekf.state();
        let update = self.ekf.update(&innovation, &self.h, &r)?;
        self.accumulate_fisher(&update)?;
        self.run.measurement.extend(z.iter());
        self.run.innovation.extend(innovation.iter());
        self.run
            .innovation_cov
            .extend(row_major(&update.innovation_cov));
        self.run.gain.extend(row_major(&update.gain));
        self.record()
    }

    /// The measurement vector and its noise. Noise levels follow the nominal geometry
    /// (planned position, nominal landmark position), known to the simulation and the
    /// filter alike, so `W` is exact.
    fn observe(&mut self, x_nominal: f64) -> (DVector<f64>, DMatrix<f64>) {
        let c = self.config;
        let n = c.landmarks;
        let p = self.model.observation_dim(n);
        let offset = p - n;
        let (mut z, mut r) = (DVector::zeros(p), DMatrix::zeros(p, p));
        if offset == 1 {
            // The anchor sits at the origin (z_0 = 0 - x); the external sensor reads x.
            let truth = match self.model {
                MeasurementModel::Anchor => -self.x_true,
                _ => self.x_true,
            };
            r[(0, 0)] = c.reference_noise.variance(x_nominal, c.noise_floor);
            z[0] = truth + r[(0, 0)].sqrt() * normal(&mut self.rng);
        }
        let w = c
            .measurement_noise
            .variance(c.landmark_position - x_nominal, c.noise_floor);
        for i in 0..n {
            r[(offset + i, offset + i)] = w;
            z[offset + i] = c.landmark_position - self.x_true + w.sqrt() * normal(&mut self.rng);
        }
        (z, r)
    }

    /// Eq. (14): `J += H^T S^-1 H = W^T W` with `W = F^-1 H` (`S = F F^T`). Both
    /// products are O(n^3) with every landmark observed, so they run a block of
    /// columns at a time, with a Ctrl-C checkpoint between blocks.
    fn accumulate_fisher(&mut self, update: &Update) -> Result<()> {
        let factor = rperc_core::cholesky_lower(&update.innovation_cov)?
            .ok_or_else(|| SlamError::SingularInnovation("S lost definiteness".into()))?;
        let mut w = self.h_dense.clone();
        let d = w.ncols();
        for start in (0..d).step_by(INTERRUPTIBLE_ROWS) {
            let cols = INTERRUPTIBLE_ROWS.min(d - start);
            let mut block = w.columns_mut(start, cols);
            factor.solve_lower_triangular_mut(&mut block);
            rperc_core::interrupt::checkpoint()?;
        }
        for start in (0..d).step_by(INTERRUPTIBLE_ROWS) {
            let cols = INTERRUPTIBLE_ROWS.min(d - start);
            let mut fisher = self.run.fisher.columns_mut(start, cols);
            fisher.gemm_tr(1.0, &w, &w.columns(start, cols), 1.0);
            rperc_core::interrupt::checkpoint()?;
        }
        self.run.fisher_00.push(self.run.fisher[(0, 0)]);
        Ok(())
    }

    /// Truth, estimate, standard deviations and NEES of the current step.
    fn record(&mut self) -> Result<()> {
        let est = self.ekf.state();
        let cov = self.ekf.covariance();
        let mut err = DVector::zeros(est.len());
        for i in 0..est.len() {
            let t = if i == 0 {
                self.x_true
            } else {
                self.config.landmark_position
            };
            self.run.truth.push(t);
            self.run.estimate.push(est[i]);
            self.run.std.push(cov[(i, i)].max(0.0).sqrt());
            err[i] = est[i] - t;
        }
        // P is PSD by construction; it loses definiteness only when the variances
        // differ by more than double precision holds (a robot variance of 1e18 swallows
        // a landmark's 1e-2), so say which parameters set them.
        let nees = rperc_core::mahalanobis2(&err, &cov).map_err(|e| match e {
            CoreError::NotPositiveDefinite { .. } => SlamError::Diverged(format!(
                "the covariance of step {}: numerically singular, so the NEES is undefined; \
                 initial_variance, plant_noise and measurement_noise span more than double \
                 precision holds (keep their ratios under about 1e12)",
                self.run.nees.len()
            )),
            other => other.into(),
        })?;
        self.run.nees.push(nees);
        Ok(())
    }
}

fn row_major(m: &DMatrix<f64>) -> impl Iterator<Item = f64> + '_ {
    (0..m.nrows()).flat_map(move |i| (0..m.ncols()).map(move |j| m[(i, j)]))
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
