//! A simulated room of walls for Monte Carlo consistency of the wall landmarks (the
//! wall counterpart of [`super::sim`]): a robot drives laps of a circle inside a
//! room, with noisy odometry, and sees every wall segment within range as a line
//! `(rho, alpha)` drawn from exactly the noise the detection reports, so what
//! inconsistency is left is the EKF's own. The room has two collinear walls (the two
//! sides of a doorway), which only segment overlap tells apart.

use std::f64::consts::{FRAC_PI_2, PI};

use nalgebra::{Point2, Vector2};
use rperc_core::{Pose2, angle_diff, rng, wrap_angle};

use super::sim::{Circle, Drive, MonteCarlo, average_runs, gauss, pose_nees};
use super::{Association, Event, EventKind, PlanarConfig, PlanarResult, PlanarSlam, WallDetection};
use crate::error::{Result, SlamError};
use crate::wall::observe_wall;

/// The simulated room and its noise (the filter built by
/// [`RoomConfig::slam_config`] uses the same variances).
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct RoomConfig {
    /// Wall segments `(x0, y0, x1, y1)`, m.
    pub walls: Vec<[f64; 4]>,
    /// Radius of the circle the robot drives, m.
    pub radius: f64,
    /// Centre of that circle, m (the walls are given in the world frame).
    pub centre: [f64; 2],
    /// Forward speed, m/s.
    pub speed: f64,
    /// Time between controls (and scans), s.
    pub dt: f64,
    /// Number of control steps.
    pub steps: usize,
    /// Sensor range, m: a wall is seen where it lies within it.
    pub max_range: f64,
    /// A wall whose part within range is shorter is not seen, m.
    pub min_length: f64,
    /// Speed noise variance per step, m^2/s^2.
    pub speed_variance: f64,
    /// Turn-rate noise variance per step, rad^2/s^2.
    pub turn_rate_variance: f64,
    /// Variance of a seen wall's rho, m^2.
    pub rho_variance: f64,
    /// Variance of a seen wall's alpha, rad^2.
    pub alpha_variance: f64,
    /// Start pose variances (the true start is drawn from them).
    pub initial_pose_variance: [f64; 3],
}

impl Default for RoomConfig {
    fn default() -> Self {
        Self {
            // A 12 x 8 m room and, 1 m inside its lower wall, a partition with a
            // 4 m doorway: two collinear walls.
            walls: vec![
                [-6.0, -4.0, 6.0, -4.0],
                [6.0, -4.0, 6.0, 4.0],
                [6.0, 4.0, -6.0, 4.0],
                [-6.0, 4.0, -6.0, -4.0],
                [-5.0, -3.0, -2.0, -3.0],
                [2.0, -3.0, 5.0, -3.0],
            ],
            radius: 2.0,
            centre: [0.0; 2],
            speed: 1.0,
            dt: 0.1,
            steps: 300,
            max_range: 5.0,
            min_length: 0.3,
            speed_variance: 0.01,
            turn_rate_variance: 1e-3,
            rho_variance: 4e-4,
            alpha_variance: 3e-4,
            initial_pose_variance: [1e-4, 1e-4, 1e-5],
        }
    }
}

/// One simulated run.
#[derive(Debug, Clone, PartialEq)]
pub struct RoomRun {
    /// Time-ordered events (controls and wall scans).
    pub events: Vec<Event>,
    /// The true robot pose at each event's time.
    pub truth: Vec<Pose2>,
    /// For each event, the true wall (index into `walls`) of each of its detections.
    pub seen: Vec<Vec<usize>>,
}

impl RoomConfig {
    /// Refuses bad values with the field's name.
    pub fn validate(&self) -> Result<()> {
        self.drive().check()?;
        rperc_core::ensure_fields(
            &[
                ("max_range", self.max_range),
                ("rho_variance", self.rho_variance),
                ("alpha_variance", self.alpha_variance),
            ],
            &[("min_length", self.min_length)],
        )?;
        rperc_core::ensure_finite("walls", self.walls.iter().flatten())?;
        rperc_core::ensure_finite("centre", self.centre.iter())?;
        if self.steps == 0 || self.walls.is_empty() {
            return Err(SlamError::invalid(
                "steps",
                "steps and walls must be >= 1".into(),
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

    /// The filter settings that match this room: same noise, same start, nearest
    /// neighbour association.
    pub fn slam_config(&self) -> PlanarConfig {
        PlanarConfig {
            association: Association::NearestNeighbour,
            ..self.drive().slam_config(self.centre)
        }
    }

    /// The walls' lines `(rho, alpha)` in the world frame.
    pub fn lines(&self) -> Vec<Vector2<f64>> {
        self.walls
            .iter()
            .filter_map(|w| {
                let d = Vector2::new(w[2] - w[0], w[3] - w[1]).try_normalize(0.0)?;
                let n = Vector2::new(d.y, -d.x);
                let rho = n.x * w[0] + n.y * w[1];
                let (rho, n) = if rho < 0.0 { (-rho, -n) } else { (rho, n) };
                Some(Vector2::new(rho, n.y.atan2(n.x)))
            })
            .collect()
    }
}

/// The part of segment `w` within `range` of `c`, or `None`.
fn within(w: &[f64; 4], c: &Point2<f64>, range: f64) -> Option<[Point2<f64>; 2]> {
    let (a, b) = (Point2::new(w[0], w[1]), Point2::new(w[2], w[3]));
    let d = b - a;
    let f = a - c;
    // |f + t d|^2 = range^2: t^2 (d.d) + 2 t (f.d) + f.f - range^2 = 0.
    let (qa, qb, qc) = (d.dot(&d), f.dot(&d), f.dot(&f) - range * range);
    let disc = qb * qb - qa * qc;
    if qa <= 0.0 || disc <= 0.0 {
        return None;
    }
    let (t0, t1) = ((-qb - disc.sqrt()) / qa, (-qb + disc.sqrt()) / qa);
    let (t0, t1) = (t0.max(0.0), t1.min(1.0));
    (t0 < t1).then(|| [a + d * t0, a + d * t1])
}

fn scan(
    cfg: &RoomConfig,
    pose: &Pose2,
    lines: &[Vector2<f64>],
    rng: &mut rng::RngStream,
) -> (Vec<WallDetection>, Vec<usize>) {
    let to_robot = pose.inverse();
    let (mut walls, mut which) = (Vec::new(), Vec::new());
    for (i, (w, line)) in cfg.walls.iter().zip(lines).enumerate() {
        let Some(ends) = within(w, &Point2::new(pose.x, pose.y), cfg.max_range) else {
            continue;
        };
        let Some(z) = observe_wall(pose, line) else {
            continue;
        };
        if (ends[1] - ends[0]).norm() < cfg.min_length {
            continue;
        }
        let [a, b] = ends.map(|p| to_robot.transform_point(&p));
        let rho = z.wall.x + gauss(rng, cfg.rho_variance);
        let alpha = z.wall.y + gauss(rng, cfg.alpha_variance);
        // Noise across rho = 0 writes the line in its other form.
        let (rho, alpha) = if rho < 0.0 {
            (-rho, alpha + PI)
        } else {
            (rho, alpha)
        };
        walls.push(WallDetection {
            rho,
            alpha: wrap_angle(alpha),
            covariance: [cfg.rho_variance, 0.0, 0.0, cfg.alpha_variance],
            start: [a.x, a.y],
            end: [b.x, b.y],
        });
        which.push(i);
    }
    (walls, which)
}

/// Run `run` of the room seeded by `seed` (stream `run` of `seed`).
pub fn simulate_room(cfg: &RoomConfig, seed: u64, run: u64) -> RoomRun {
    let mut rng = rng::stream(seed, run);
    let lines = cfg.lines();
    let mut robot = Circle::new(&mut rng, cfg.slam_config().initial_pose, &cfg.drive());
    let mut out = RoomRun {
        events: Vec::new(),
        truth: Vec::new(),
        seen: Vec::new(),
    };
    for k in 0..cfg.steps {
        let (control, before) = robot.step(k, &mut rng);
        out.events.push(control);
        out.truth.push(before);
        out.seen.push(Vec::new());
        let pose = robot.pose;
        let (walls, which) = scan(cfg, &pose, &lines, &mut rng);
        out.events.push(Event::Walls {
            t: (k + 1) as f64 * cfg.dt,
            walls,
        });
        out.truth.push(pose);
        out.seen.push(which);
    }
    out
}

/// The rigid motion taking the world to the frame of a wall anchor: the true anchor
/// line `truth` moved onto its estimate `est` (both world lines) by a rotation about
/// the anchor's reference point `pivot` by `alpha_est - alpha_true`, then a shift
/// along the estimate's normal (the gauge the engine linearises, see its wall
/// anchor).
pub fn wall_anchor_gauge(truth: &Vector2<f64>, est: &Vector2<f64>, pivot: &Point2<f64>) -> Pose2 {
    let (rho, alpha) = if angle_diff(est.y, truth.y).abs() > FRAC_PI_2 {
        (-truth.x, truth.y + PI)
    } else {
        (truth.x, truth.y)
    };
    let delta = angle_diff(est.y, alpha);
    // Rotating about the pivot: R p + (p - R p); the rotated line's rho is then
    // rho + n' . (p - R p), and the shift along n' makes it est's.
    let turn = Pose2::new(0.0, 0.0, delta);
    let p = pivot.coords;
    let t = p - turn.transform_point(pivot).coords;
    let n = Vector2::new(est.y.cos(), est.y.sin());
    let shift = n * (est.x - rho - n.dot(&t));
    Pose2::new(t.x + shift.x, t.y + shift.y, delta)
}

/// The robot-pose NEES after every event. With a wall anchor the truth is first
/// taken to the anchor's frame by [`wall_anchor_gauge`]; the anchor's true line is the
/// room's line nearest to the anchor's estimate.
pub fn room_nees(result: &PlanarResult, truth: &[Pose2], lines: &[Vector2<f64>]) -> Vec<f64> {
    let gauge = result.walls.iter().find(|w| w.anchor).and_then(|a| {
        let est = Vector2::from(a.line);
        let nearest = lines.iter().min_by(|p, q| {
            let d = |l: &Vector2<f64>| (l.x - est.x).abs() + angle_diff(l.y, est.y).abs();
            d(p).total_cmp(&d(q))
        })?;
        Some(wall_anchor_gauge(nearest, &est, &Point2::from(a.origin)))
    });
    let tr = &result.trajectory;
    tr.pose
        .iter()
        .zip(&tr.covariance)
        .zip(truth)
        .map(|((p, c), t)| pose_nees(p, c, &gauge.map_or(*t, |g| g.compose(t))))
        .collect()
}

/// Run `run` of `seed` through `slam`: the robot NEES after each wall scan.
pub fn room_run_nees(
    room: &RoomConfig,
    slam: &PlanarConfig,
    seed: u64,
    run: u64,
) -> Result<Vec<f64>> {
    let data = simulate_room(room, seed, run);
    let mut engine = PlanarSlam::new(slam.clone())?;
    engine.run(&data.events)?;
    let result = engine.finish();
    let nees = room_nees(&result, &data.truth, &room.lines());
    Ok(result
        .trajectory
        .kind
        .iter()
        .zip(nees)
        .filter(|(k, _)| **k == EventKind::Walls)
        .map(|(_, n)| n)
        .collect())
}

/// `runs` simulated runs of `slam` in `room` (streams `0..runs` of `seed`, in
/// parallel), with the run-averaged robot NEES after each wall scan and its 95 % band.
pub fn room_monte_carlo(
    room: &RoomConfig,
    slam: &PlanarConfig,
    runs: usize,
    seed: u64,
) -> Result<MonteCarlo> {
    room.validate()?;
    average_runs(runs, room.steps, |r| room_run_nees(room, slam, seed, r))
}
