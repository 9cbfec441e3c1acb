//! The ceiling world's robot: a unicycle driven by `(v, omega)` commands, with wheel
//! odometry that drifts (a scale error on each wheel rate, as a worn or mis-sized
//! wheel gives, plus white noise per step), and its true path.

use rperc_core::Pose2;
use rperc_core::rng::{normal, stream};

use crate::error::{NavigationError, Result};

/// How the odometry errs.
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct OdometryNoise {
    /// Relative error of the measured speed (the odometry reads `v (1 + e)`).
    pub speed_scale_error: f64,
    /// Relative error of the measured turn rate.
    pub turn_scale_error: f64,
    /// White noise on each step's speed, m/s.
    pub speed_sigma: f64,
    /// White noise on each step's turn rate, rad/s.
    pub turn_sigma: f64,
    /// Seed of the noise.
    pub seed: u64,
}

impl Default for OdometryNoise {
    fn default() -> Self {
        Self {
            speed_scale_error: 0.03,
            turn_scale_error: -0.04,
            speed_sigma: 0.02,
            turn_sigma: 0.03,
            seed: 0,
        }
    }
}

impl OdometryNoise {
    /// Refuses bad values with the parameter's name.
    pub fn validate(&self) -> Result<()> {
        use rperc_core::{ensure_in_range, ensure_non_negative};
        ensure_in_range("speed_scale_error", self.speed_scale_error, -0.5, 0.5)?;
        ensure_in_range("turn_scale_error", self.turn_scale_error, -0.5, 0.5)?;
        ensure_non_negative("speed_sigma", self.speed_sigma)?;
        ensure_non_negative("turn_sigma", self.turn_sigma)?;
        Ok(())
    }
}

/// A drive: the true and the odometry poses before and after every command.
#[derive(Debug, Clone, PartialEq)]
pub struct Drive {
    /// True poses, one more than commands.
    pub truth: Vec<Pose2>,
    /// Dead-reckoned poses from the measured commands, starting at the true start.
    pub odometry: Vec<Pose2>,
    /// The commands as the odometry measured them, `(v, omega)`.
    pub measured: Vec<[f64; 2]>,
}

/// Drives `commands` (`(v, omega)`, each held for `dt` seconds) from `start`.
///
/// # Examples
/// ```
/// use rperc_core::Pose2;
/// use navigation::ceiling::{OdometryNoise, drive};
///
/// let commands = vec![[0.5, 0.0]; 10];       // 5 m/s... no: 0.5 m/s for 10 x 0.2 s
/// let run = drive(Pose2::identity(), &commands, 0.2, &OdometryNoise::default()).unwrap();
/// assert!((run.truth[10].x - 1.0).abs() < 1e-12);      // 1 m straight ahead
/// assert!(run.odometry[10].x > 1.0);                   // the odometry reads 3 % long
/// ```
pub fn drive(start: Pose2, commands: &[[f64; 2]], dt: f64, noise: &OdometryNoise) -> Result<Drive> {
    use rperc_core::{ensure_finite, ensure_positive};
    ensure_positive("dt", dt)?;
    ensure_finite("start", [start.x, start.y, start.theta].iter())?;
    ensure_finite("commands", commands.iter().flatten())?;
    noise.validate()?;
    if commands.is_empty() {
        return Err(NavigationError::InvalidParameter {
            name: "commands",
            reason: "needs at least one (v, omega) command".into(),
        });
    }
    let mut rng = stream(noise.seed, 0);
    let mut run = Drive {
        truth: Vec::with_capacity(commands.len() + 1),
        odometry: Vec::with_capacity(commands.len() + 1),
        measured: Vec::with_capacity(commands.len()),
    };
    let (mut truth, mut odometry) = (start, start);
    run.truth.push(truth);
    run.odometry.push(odometry);
    for &[v, w] in commands {
        let mv = v * (1.0 + noise.speed_scale_error) + noise.speed_sigma * normal(&mut rng);
        let mw = w * (1.0 + noise.turn_scale_error) + noise.turn_sigma * normal(&mut rng);
        truth = truth.advance(v, w, dt);
        odometry = odometry.advance(mv, mw, dt);
        let finite = |p: &Pose2| p.x.is_finite() && p.y.is_finite() && p.theta.is_finite();
        if !(finite(&truth) && finite(&odometry)) {
            return Err(NavigationError::InvalidParameter {
                name: "commands",
                reason: format!(
                    "the pose overflows at command {} (v * dt or omega * dt too large)",
                    run.measured.len()
                ),
            });
        }
        run.truth.push(truth);
        run.odometry.push(odometry);
        run.measured.push([mv, mw]);
    }
    Ok(run)
}
