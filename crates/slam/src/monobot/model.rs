//! The monobot's measurement models, noise models and experiment configuration.

use std::f64::consts::PI;

use nalgebra::DMatrix;

use crate::ekf::SparseJacobian;
use crate::error::{Result, SlamError};

rperc_core::named_enum! {
    /// Which measurement model the monobot uses.
    #[derive(Default)]
    pub enum MeasurementModel: "model" {
        /// Landmarks relative to the robot only: `H = [-1, I]` (unobservable).
        #[default]
        Relative = "relative",
        /// Plus a global reference landmark at the origin, eq. (20).
        Anchor = "anchor",
        /// Plus an external sensor measuring the robot, eq. (23).
        External = "external",
    }
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

rperc_core::named_enum! {
    /// The kind of a [`Noise`] model, as spelled in configs: `("proportional", 0.1)`.
    pub enum NoiseKind: "noise model" {
        /// A constant variance.
        Constant = "constant",
        /// A standard deviation proportional to a length.
        Proportional = "proportional",
    }
}

/// A noise model: constant variance, or a standard deviation proportional to a
/// length (the motion command for the plant, the distance for a sensor). In configs it
/// is the pair `(kind, value)`, e.g. `("constant", 1.0)`.
#[derive(
    Debug, Clone, Copy, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema,
)]
#[serde(from = "(NoiseKind, f64)", into = "(NoiseKind, f64)")]
pub enum Noise {
    /// This variance at every step.
    Constant(f64),
    /// Standard deviation `k * length + floor` (floor from the config).
    Proportional(f64),
}

impl From<(NoiseKind, f64)> for Noise {
    fn from((kind, value): (NoiseKind, f64)) -> Self {
        match kind {
            NoiseKind::Constant => Noise::Constant(value),
            NoiseKind::Proportional => Noise::Proportional(value),
        }
    }
}

impl From<Noise> for (NoiseKind, f64) {
    fn from(n: Noise) -> Self {
        match n {
            Noise::Constant(v) => (NoiseKind::Constant, v),
            Noise::Proportional(v) => (NoiseKind::Proportional, v),
        }
    }
}

impl Noise {
    pub(crate) fn variance(self, length: f64, floor: f64) -> f64 {
        match self {
            Noise::Constant(v) => v,
            Noise::Proportional(k) => (k * length.abs() + floor).powi(2),
        }
    }

    fn validate(self, name: &'static str) -> Result<()> {
        let v = match self {
            Noise::Constant(v) | Noise::Proportional(v) => v,
        };
        rperc_core::ensure_non_negative(name, v)?;
        // A proportional k is a standard deviation per metre: its square is the scale.
        let variance = match self {
            Noise::Constant(v) => v,
            Noise::Proportional(k) => k * k,
        };
        if variance == 0.0 {
            return Ok(());
        }
        usable_variance(name, variance)
    }
}

/// The filter multiplies variances together (`P^2 / S` in the gain), so a variance
/// outside [`USABLE_VARIANCE`] under- or overflows inside the run; it is refused up
/// front with the parameter's name rather than as a singular matrix later.
pub const USABLE_VARIANCE: (f64, f64) = (1e-100, 1e100);

fn usable_variance(name: &'static str, variance: f64) -> Result<()> {
    let (lo, hi) = USABLE_VARIANCE;
    if (lo..=hi).contains(&variance) {
        return Ok(());
    }
    Err(SlamError::invalid(
        name,
        format!("gives a variance of {variance:e}, outside the usable [{lo:e}, {hi:e}]"),
    ))
}

/// The monobot experiment. Defaults are the paper's run (Figs. 4 to 6).
#[derive(
    Debug, Clone, Copy, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema,
)]
#[serde(default, deny_unknown_fields)]
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
        let bad = |name: &'static str, reason: String| Err(SlamError::invalid(name, reason));
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
        usable_variance("initial_variance", self.initial_variance)?;
        for (name, v) in [("noise_floor", self.noise_floor)] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(name, format!("must be finite and >= 0, got {v}"));
            }
        }
        self.check_record_size()?;
        self.plant_noise.validate("plant_noise")?;
        self.measurement_noise.validate("measurement_noise")?;
        self.reference_noise.validate("reference_noise")
    }

    /// Refuses a run whose record (predicted covariances, gains, innovation
    /// covariances per step, all O(steps n^2)) would exceed the allocation limit.
    fn check_record_size(&self) -> Result<()> {
        let d = self.landmarks as u128 + 1;
        let p = d; // the anchor and external models observe n + 1 values
        let per_step = p * p + d * p + d * d + 2 * p + 3 * d;
        let steps = self.steps as u128 + 1;
        rperc_core::check_allocation(
            "landmarks and steps",
            steps.saturating_mul(per_step) + d * d,
            8,
        )?;
        Ok(())
    }

    /// The commanded (noise-free) robot position at step `k`.
    pub fn planned_position(&self, k: usize) -> f64 {
        let phase = 2.0 * PI * k as f64 / self.steps as f64;
        self.start + self.amplitude * (1.0 - phase.cos()) / 2.0
    }
}
