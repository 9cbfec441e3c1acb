//! A simulated planar world for Monte Carlo consistency studies (Bailey et al. 2006):
//! a robot drives laps of a circle among point landmarks with noisy odometry and
//! range-bearing sightings drawn from exactly the models the filter assumes, so any
//! inconsistency left is the EKF's own (linearisation), not a modelling error.

use std::f64::consts::FRAC_PI_2;

use nalgebra::{DVector, Matrix3, Point2, Vector2};
use rayon::prelude::*;
use rperc_core::{Pose2, angle_diff, mahalanobis2, nees_band, rng};

use super::{Detection, Event, PlanarConfig, PlanarResult, PlanarSlam};
use crate::error::{Result, SlamError};
use crate::motion::{MotionModel, unicycle};

/// The simulated world and its noise (the truth uses the same variances as the
/// filter's [`PlanarConfig`] built by [`SimConfig::slam_config`]).
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct SimConfig {
    /// Radius of the circle the robot drives, m.
    pub radius: f64,
    /// Forward speed, m/s.
    pub speed: f64,
    /// Time between controls (and scans), s.
    pub dt: f64,
    /// Number of control steps.
    pub steps: usize,
    /// Landmarks on two rings, `radius - ring_gap` and `radius + ring_gap`.
    pub landmarks: usize,
    /// Half the distance between the landmark rings, m.
    pub ring_gap: f64,
    /// Sensor range, m.
    pub max_range: f64,
    /// Speed noise variance per step, m^2/s^2.
    pub speed_variance: f64,
    /// Turn-rate noise variance per step, rad^2/s^2.
    pub turn_rate_variance: f64,
    /// Range noise variance, m^2.
    pub range_variance: f64,
    /// Bearing noise variance, rad^2.
    pub bearing_variance: f64,
    /// Start pose variances (the true start is drawn from them).
    pub initial_pose_variance: [f64; 3],
    /// An external xy fix every this many steps (`None`: no fixes).
    pub fix_every: Option<usize>,
    /// Variance of each fix coordinate, m^2.
    pub fix_variance: f64,
}

impl Default for SimConfig {
    fn default() -> Self {
        Self {
            radius: 10.0,
            speed: 1.0,
            dt: 0.1,
            steps: 600,
            landmarks: 24,
            ring_gap: 3.0,
            max_range: 6.0,
            speed_variance: 0.01,
            turn_rate_variance: 1e-3,
            range_variance: 0.01,
            bearing_variance: 1e-4,
            initial_pose_variance: [1e-4, 1e-4, 1e-5],
            fix_every: None,
            fix_variance: 0.01,
        }
    }
}

/// One simulated run: the events for the engine and the true pose after each.
#[derive(Debug, Clone, PartialEq)]
pub struct SimRun {
    /// Time-ordered events (controls, scans, fixes).
    pub events: Vec<Event>,
    /// The true robot pose at each event's time.
    pub truth: Vec<Pose2>,
    /// The true landmarks (landmark `i` has id `i`).
    pub landmarks: Vec<Point2<f64>>,
}

impl SimConfig {
    /// Refuses bad values with the field's name.
    pub fn validate(&self) -> Result<()> {
        self.drive().check()?;
        rperc_core::ensure_fields(
            &[
                ("ring_gap", self.ring_gap),
                ("max_range", self.max_range),
                ("range_variance", self.range_variance),
                ("bearing_variance", self.bearing_variance),
                ("fix_variance", self.fix_variance),
            ],
            &[],
        )?;
        if self.steps == 0 || self.landmarks == 0 || self.fix_every == Some(0) {
            return Err(SlamError::invalid(
                "steps",
                "steps, landmarks and fix_every must be >= 1".into(),
            ));
        }
        // Sizes a caller sets are checked before anything is allocated: 10^9
        // landmarks aborted the process, 10^9 steps ran for minutes (issue 38). A
        // step holds a control, the true poses and a scan of the landmarks in range
        // (a handful in these worlds): a few hundred bytes.
        rperc_core::check_allocation("landmarks", self.landmarks as u128, 16)?;
        rperc_core::check_allocation("steps", self.steps as u128, 256)?;
        if self.ring_gap >= self.radius {
            return Err(SlamError::invalid(
                "ring_gap",
                format!("must be < radius {}, got {}", self.radius, self.ring_gap),
            ));
        }
        Ok(())
    }

    /// How its robot drives.
    pub(super) fn drive(&self) -> Drive {
        Drive {
            radius: self.radius,
            speed: self.speed,
            dt: self.dt,
            noise: [self.speed_variance, self.turn_rate_variance],
            start_variance: self.initial_pose_variance,
        }
    }

    /// The filter settings that match this world: same noise, same start.
    pub fn slam_config(&self) -> PlanarConfig {
        PlanarConfig {
            range_variance: self.range_variance,
            bearing_variance: self.bearing_variance,
            ..self.drive().slam_config([0.0; 2])
        }
    }

    /// The landmarks, evenly spaced on the two rings (alternating).
    pub fn world(&self) -> Vec<Point2<f64>> {
        (0..self.landmarks)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / self.landmarks as f64;
                let r = if i % 2 == 0 {
                    self.radius - self.ring_gap
                } else {
                    self.radius + self.ring_gap
                };
                Point2::new(r * a.cos(), r * a.sin())
            })
            .collect()
    }
}

/// A zero-mean Gaussian draw of `variance`.
pub(super) fn gauss(rng: &mut rng::RngStream, variance: f64) -> f64 {
    variance.sqrt() * rng::normal(rng)
}

/// The robot of the simulated worlds: laps of a circle at constant speed, its
/// odometry the true `(v, omega)` plus white noise of the filter's own variances.
pub(super) struct Circle {
    /// The true pose now.
    pub pose: Pose2,
    speed: f64,
    omega: f64,
    dt: f64,
    noise: [f64; 2],
}

/// How the robot of a simulated world drives, as its config sets it: laps of a circle
/// of `radius` at `speed`, a control every `dt` seconds, odometry noise `noise`
/// (speed, turn-rate variances) and the start's variances. The filter's motion model
/// has the same noise.
pub(super) struct Drive {
    pub radius: f64,
    pub speed: f64,
    pub dt: f64,
    pub noise: [f64; 2],
    pub start_variance: [f64; 3],
}

impl Drive {
    /// The settings checked by name: `(radius, speed, dt)` > 0, the noise variances
    /// and the start variances >= 0.
    pub fn check(&self) -> Result<()> {
        rperc_core::ensure_fields(
            &[
                ("radius", self.radius),
                ("speed", self.speed),
                ("dt", self.dt),
            ],
            &[
                ("speed_variance", self.noise[0]),
                ("turn_rate_variance", self.noise[1]),
            ],
        )?;
        self.start_variance
            .iter()
            .try_for_each(|&v| rperc_core::ensure_non_negative("initial_pose_variance", v))?;
        Ok(())
    }

    /// The filter's motion model with the drive's own odometry noise.
    pub fn motion(&self) -> MotionModel {
        MotionModel::Unicycle(crate::motion::Unicycle {
            speed_variance: self.noise[0],
            turn_rate_variance: self.noise[1],
        })
    }

    /// The filter settings that match this drive about `centre`: its motion noise,
    /// and the start on the circle's east point heading north, with its variances.
    pub fn slam_config(&self, centre: [f64; 2]) -> PlanarConfig {
        PlanarConfig {
            motion: self.motion(),
            initial_pose: [centre[0] + self.radius, centre[1], FRAC_PI_2],
            initial_pose_variance: self.start_variance,
            ..PlanarConfig::default()
        }
    }
}

impl Circle {
    /// The robot at `start` moved by a draw of the drive's start variances, to drive
    /// as `drive` says.
    pub fn new(rng: &mut rng::RngStream, start: [f64; 3], drive: &Drive) -> Self {
        let v = drive.start_variance;
        let pose = Pose2::new(
            start[0] + gauss(rng, v[0]),
            start[1] + gauss(rng, v[1]),
            start[2] + gauss(rng, v[2]),
        );
        Self {
            pose,
            speed: drive.speed,
            omega: drive.speed / drive.radius,
            dt: drive.dt,
            noise: drive.noise,
        }
    }

    /// Step `k`: the measured control event at `k dt`; the robot then moves to
    /// `(k + 1) dt`. Returns the event and the true pose before the move.
    pub fn step(&mut self, k: usize, rng: &mut rng::RngStream) -> (Event, Pose2) {
        let control = [
            self.speed + gauss(rng, self.noise[0]),
            self.omega + gauss(rng, self.noise[1]),
        ];
        let before = self.pose;
        self.pose = unicycle(&self.pose, self.speed, self.omega, self.dt).pose();
        (
            Event::Control {
                t: k as f64 * self.dt,
                control,
            },
            before,
        )
    }
}

/// The NEES `e^T P^-1 e` of a recorded pose `p` with covariance `c` (row-major)
/// against `truth` (`NaN` where `P` is singular).
pub(super) fn pose_nees(p: &[f64; 3], c: &[f64; 9], truth: &Pose2) -> f64 {
    let e = DVector::from_vec(vec![
        p[0] - truth.x,
        p[1] - truth.y,
        angle_diff(p[2], truth.theta),
    ]);
    let cov = Matrix3::from_row_slice(c);
    mahalanobis2(
        &e,
        &nalgebra::DMatrix::from_column_slice(3, 3, cov.as_slice()),
    )
    .unwrap_or(f64::NAN)
}

/// `runs` runs of `steps` NEES values each, from `nees_of(run)` in parallel,
/// averaged per step, with the 95 % band of the average.
pub(super) fn average_runs<F>(runs: usize, steps: usize, nees_of: F) -> Result<MonteCarlo>
where
    F: Fn(u64) -> Result<Vec<f64>> + Sync + Send,
{
    let per_run = parallel_runs(0, runs, steps, nees_of)?;
    let mean_nees = (0..steps)
        .map(|k| per_run.iter().map(|r| r[k]).sum::<f64>() / runs as f64)
        .collect();
    Ok(MonteCarlo {
        mean_nees,
        band: nees_band(3, runs, 0.95)?,
        runs,
    })
}

/// Refuses `runs` runs of `steps` NEES values each before any is run, when either is
/// 0 or their series would not fit the allocation limit (the error names `runs`, the
/// value the caller set): `runs = 10^9` ran on for minutes (issue 38).
pub fn check_runs(runs: usize, steps: usize) -> Result<()> {
    if runs == 0 || steps == 0 {
        return Err(SlamError::invalid(
            "runs",
            "runs and steps must be >= 1".into(),
        ));
    }
    Ok(rperc_core::check_allocation(
        "runs",
        runs as u128,
        steps as u128 * 8,
    )?)
}

/// `nees_of(r)` for the runs `first..first + runs` in parallel, after [`check_runs`].
/// The pool's threads work under the caller's interrupt token, so Ctrl-C stops every
/// run at its next checkpoint (without it only the calling thread saw the signal).
pub fn parallel_runs<F>(first: u64, runs: usize, steps: usize, nees_of: F) -> Result<Vec<Vec<f64>>>
where
    F: Fn(u64) -> Result<Vec<f64>> + Sync + Send,
{
    check_runs(runs, steps)?;
    let token = rperc_core::interrupt::current();
    (first..first + runs as u64)
        .into_par_iter()
        .map(|r| rperc_core::interrupt::run_with(token.clone(), || nees_of(r)))
        .collect()
}

fn detections(
    cfg: &SimConfig,
    pose: &Pose2,
    world: &[Point2<f64>],
    rng: &mut rng::RngStream,
) -> Vec<Detection> {
    world
        .iter()
        .enumerate()
        .filter_map(|(i, l)| {
            let (z, _, _) = crate::observation::range_bearing(pose, l)?;
            (z.x <= cfg.max_range).then(|| Detection {
                range: z.x + gauss(rng, cfg.range_variance),
                bearing: rperc_core::wrap_angle(z.y + gauss(rng, cfg.bearing_variance)),
                id: Some(i as u64),
            })
        })
        .collect()
}

/// Run `run` of the world seeded by `seed` (stream `run` of `seed`).
///
/// # Errors
/// [`SlamError::Core`] with `Interrupted` when the caller's interrupt token is stopped
/// (Ctrl-C from Python): a world of millions of steps or landmarks is a long loop.
pub fn simulate(cfg: &SimConfig, seed: u64, run: u64) -> Result<SimRun> {
    let mut meter = rperc_core::interrupt::Work::new();
    let mut rng = rng::stream(seed, run);
    let world = cfg.world();
    let mut robot = Circle::new(&mut rng, cfg.slam_config().initial_pose, &cfg.drive());
    let (mut events, mut truth) = (Vec::new(), Vec::new());
    for k in 0..cfg.steps {
        meter.advance(1 + world.len() as u64)?;
        let (control, before) = robot.step(k, &mut rng);
        events.push(control);
        truth.push(before);
        let pose = robot.pose;
        let t1 = (k + 1) as f64 * cfg.dt;
        events.push(Event::Scan {
            t: t1,
            detections: detections(cfg, &pose, &world, &mut rng),
        });
        truth.push(pose);
        if cfg.fix_every.is_some_and(|n| (k + 1) % n == 0) {
            let xy = [
                pose.x + gauss(&mut rng, cfg.fix_variance),
                pose.y + gauss(&mut rng, cfg.fix_variance),
            ];
            events.push(Event::Fix {
                t: t1,
                xy,
                covariance: [cfg.fix_variance, 0.0, cfg.fix_variance],
            });
            truth.push(pose);
        }
    }
    Ok(SimRun {
        events,
        truth,
        landmarks: world,
    })
}

/// The robot-pose NEES `e^T P_rr^-1 e` after every event (`NaN` where `P_rr` is
/// singular). With an anchor the filter estimates the pose relative to it, so the
/// error is taken relative to the anchor too: `(t - a)_est - (t - a)_true`.
pub fn robot_nees(result: &PlanarResult, truth: &[Pose2], landmarks: &[Point2<f64>]) -> Vec<f64> {
    let shift = result.anchor.and_then(|a| {
        let anchor = result.landmarks.iter().find(|l| l.anchor)?;
        let true_a = landmarks.get(anchor.id as usize)?;
        Some(Vector2::new(a[0] - true_a.x, a[1] - true_a.y))
    });
    let tr = &result.trajectory;
    tr.pose
        .iter()
        .zip(&tr.covariance)
        .zip(truth)
        .map(|((p, c), t)| {
            let s = shift.unwrap_or_else(Vector2::zeros);
            pose_nees(&[p[0] - s.x, p[1] - s.y, p[2]], c, t)
        })
        .collect()
}

/// Run `run` of `seed` (as [`simulate`]) through `slam`: the robot NEES after each
/// scan, one per control step. What one worker of a Monte Carlo computes.
pub fn run_nees(sim: &SimConfig, slam: &PlanarConfig, seed: u64, run: u64) -> Result<Vec<f64>> {
    let data = simulate(sim, seed, run)?;
    let mut engine = PlanarSlam::new(slam.clone())?;
    engine.run(&data.events)?;
    let result = engine.finish();
    let nees = robot_nees(&result, &data.truth, &data.landmarks);
    Ok(result
        .trajectory
        .kind
        .iter()
        .zip(nees)
        .filter(|(k, _)| **k == super::EventKind::Scan)
        .map(|(_, n)| n)
        .collect())
}

/// Monte Carlo consistency: the run-averaged robot NEES after every scan, and the
/// two-sided 95 % band of that average under consistency.
#[derive(Debug, Clone, PartialEq)]
pub struct MonteCarlo {
    /// Mean NEES over the runs after each scan (one entry per control step).
    pub mean_nees: Vec<f64>,
    /// The 95 % band of a 3-dof NEES averaged over `runs` runs.
    pub band: (f64, f64),
    /// Number of runs.
    pub runs: usize,
}

impl MonteCarlo {
    /// From step `from` on (the first steps, before the map holds anything, are
    /// often left out): the mean of `mean_nees` and the share of steps whose
    /// run-averaged NEES lies inside `band` (Bailey et al. 2006's consistency test).
    /// `(NaN, NaN)` when no step is left.
    ///
    /// ```
    /// use slam::planar::sim::MonteCarlo;
    /// let mc = MonteCarlo { mean_nees: vec![9.0, 2.0, 3.0, 5.0], band: (2.5, 4.0), runs: 50 };
    /// assert_eq!(mc.tail(1), (10.0 / 3.0, 1.0 / 3.0));
    /// ```
    pub fn tail(&self, from: usize) -> (f64, f64) {
        let tail = self.mean_nees.get(from..).unwrap_or(&[]);
        let n = tail.len() as f64;
        let inside = tail
            .iter()
            .filter(|v| (self.band.0..=self.band.1).contains(*v))
            .count() as f64;
        (tail.iter().sum::<f64>() / n, inside / n)
    }
}

/// `runs` simulated runs of `slam` in the world `sim` (seeded streams `0..runs` of
/// `seed`, in parallel), with the robot NEES after each scan.
pub fn monte_carlo(
    sim: &SimConfig,
    slam: &PlanarConfig,
    runs: usize,
    seed: u64,
) -> Result<MonteCarlo> {
    sim.validate()?;
    average_runs(runs, sim.steps, |r| run_nees(sim, slam, seed, r))
}
