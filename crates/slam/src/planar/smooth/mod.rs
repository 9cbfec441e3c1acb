//! Batch smoothing of a wall-SLAM run: every scan's pose, every wall and the control
//! biases estimated together from all of the run's data, with the filter's data
//! association (full SLAM, solved by Levenberg-Marquardt).
//!
//! The EKF's trajectory is causal: each pose uses only the scans before it, so the
//! drift of a long first loop stays in the trajectory after the loop closes. The same
//! sightings, used both ways in time, support a much better trajectory. The
//! smoother keeps the filter's models term for term:
//! - **odometry**: the controls between two scans (times the config's
//!   `bias.control_scale`, as the filter takes them), integrated with the filter's
//!   motion model and biases (`u0 (1 - s)`, `u1 - b`), give the relative pose
//!   `R(theta_k)^T (p_{k+1} - p_k), theta_{k+1} - theta_k` with the covariance of the
//!   control noise propagated along the way (at zero bias);
//! - **walls**: each paired detection's segment middle, on the detected line, placed
//!   by its scan's pose, lies on its wall: offset `n(alpha) . (m_w - o) - rho` and angle
//!   `alpha_z + theta - alpha` (the filter's `segment` innovation), with the
//!   detection's covariance at the middle plus, with `wall_shared_sd`, the shared
//!   straightness floor times `sqrt(n)` for its `n` earlier sightings of the same
//!   stretch (placed with the starting poses);
//! - **points**: each paired range-bearing detection measures its landmark from its
//!   pose ([`point`]), optionally through a Huber kernel;
//! - **biases**: zero-mean priors of `control_bias_sd`; the first pose: the start's
//!   prior (its sd floored at [`START_SD_FLOOR`]).
//!
//! The returned covariances are the inverse of the Gauss-Newton information at the
//! optimum (the Laplace approximation). Walls are unknowns about their own reference
//! points (the middle of their first sighting), which keeps the problem well
//! conditioned far from the world's origin.

mod point;

use std::collections::HashMap;

use std::ops::AddAssign;

use nalgebra::{DVector, Matrix2, Matrix2x3, Matrix3, Matrix3x2, Point2, Vector2, Vector3};
use rperc_core::{Pose2, wrap_angle};

use self::point::{PointSighting, huber, point_residual, point_sightings};
use super::PlanarConfig;
use super::arrow::Arrow;
use crate::error::{Result, SlamError, ensure_finite};
use crate::motion::MotionModel;

/// The first pose's prior sd (m, rad) when the start is given exactly: a fixed start
/// would leave a zero pivot.
pub const START_SD_FLOOR: f64 = 1e-4;

/// The floor (m, rad) of each relative pose's sd. Within one segment of constant
/// controls the unicycle's noise has rank 2 (the sideways drift is the turn's), so a
/// step driven with one control would be an exact constraint; 1 mm and 1 mrad, far
/// below odometry's own errors, keep the normal equations well conditioned.
pub const LINK_SD_FLOOR: f64 = 1e-3;

/// How the smoother iterates.
#[derive(
    Debug, Clone, Copy, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema,
)]
#[serde(default, deny_unknown_fields)]
pub struct SmootherConfig {
    /// At most this many Levenberg-Marquardt iterations (>= 1).
    pub max_iterations: usize,
    /// Converged when an accepted step lowers the cost by less than this fraction.
    pub tolerance: f64,
    /// Huber's threshold (> 0) on a point sighting's whitened residual norm, in
    /// standard deviations: beyond it the sighting's cost grows linearly, so a few
    /// wrong sightings (which the filter's gate would refuse) cannot bend the path.
    /// `None`: plain least squares.
    pub point_huber: Option<f64>,
    /// Seconds (>= 0) over which the errors of one landmark's sightings stay
    /// correlated (a camera that misjudges a target keeps misjudging it while the
    /// view barely changes): each point sighting's information is divided by the
    /// number of that landmark's sightings within this time of it, itself included,
    /// so that a burst of them counts as about one. 0: every sighting independent.
    pub point_correlation_time: f64,
}

impl Default for SmootherConfig {
    fn default() -> Self {
        Self {
            max_iterations: 100,
            tolerance: 1e-9,
            point_huber: None,
            point_correlation_time: 0.0,
        }
    }
}

impl SmootherConfig {
    /// Refuses zero iterations and a tolerance that is negative or not finite.
    pub fn validate(&self) -> Result<()> {
        if self.max_iterations == 0 {
            return Err(SlamError::invalid("max_iterations", "must be >= 1".into()));
        }
        rperc_core::ensure_non_negative("tolerance", self.tolerance)?;
        if let Some(k) = self.point_huber {
            rperc_core::ensure_positive("point_huber", k)?;
        }
        rperc_core::ensure_non_negative("point_correlation_time", self.point_correlation_time)?;
        Ok(())
    }
}

/// A run to smooth: what the filter was given, its association and its estimates
/// (the starting point).
#[derive(Debug, Clone, Copy)]
pub struct FilterRun<'a> {
    /// The filter's configuration (motion model and noise, start, biases,
    /// `wall_shared_sd`).
    pub config: &'a PlanarConfig,
    /// Control rows `(t, u0, u1)`, sorted by time, each held until the next.
    pub controls: &'a [[f64; 3]],
    /// The times of the poses to estimate, increasing; the first is the start, where
    /// `config.initial_pose` (with `initial_pose_variance`) is the prior.
    pub times: &'a [f64],
    /// The filter's pose at each of `times`: where the iterations start.
    pub poses: &'a [[f64; 3]],
    /// Wall detections `(t, rho, alpha, var_rho, cov, var_alpha, x0, y0, x1, y1)` in
    /// the sensor frame, each at one of `times`.
    pub walls: &'a [[f64; 10]],
    /// For each detection, its wall's id, or `None` (not used).
    pub pairing: &'a [Option<u64>],
    /// The filter's final walls `(id, rho, alpha)` in the world frame: every paired
    /// id must be here.
    pub map: &'a [(u64, [f64; 2])],
    /// Point detections `(t, range, bearing)` as measured (the config's biases are
    /// removed here, as the filter removes them), each at one of `times`.
    pub points: &'a [[f64; 3]],
    /// For each point detection, its landmark's id, or `None` (not used).
    pub point_pairing: &'a [Option<u64>],
    /// The filter's final landmarks `(id, (x, y))`: every paired id must be here.
    pub landmarks: &'a [(u64, [f64; 2])],
}

/// The smoothed run.
#[derive(Debug, Clone, PartialEq)]
pub struct SmoothedRun {
    /// The pose at each of the run's times.
    pub pose: Vec<[f64; 3]>,
    /// Its marginal covariance, row-major 3x3.
    pub covariance: Vec<[f64; 9]>,
    /// The walls, sorted by id.
    pub walls: Vec<SmoothedWall>,
    /// The point landmarks, sorted by id.
    pub landmarks: Vec<SmoothedLandmark>,
    /// The control biases `(s, b)` (zeros without `control_bias_sd`).
    pub bias: [f64; 2],
    /// Iterations taken, and the final cost (the sum of squared whitened residuals).
    pub iterations: usize,
    /// See `iterations`.
    pub cost: f64,
    /// The number of residuals (their expected sum at the optimum is about this
    /// minus the number of unknowns).
    pub residuals: usize,
}

/// A smoothed wall, in the world frame.
#[derive(Debug, Clone, PartialEq)]
pub struct SmoothedWall {
    /// The wall's id (the filter's).
    pub id: u64,
    /// `(rho, alpha)`, `rho >= 0`.
    pub line: [f64; 2],
    /// Its covariance, row-major 2x2.
    pub covariance: [f64; 4],
    /// The seen extent: the end points of its sightings, placed with the smoothed
    /// poses, projected on the line.
    pub ends: [[f64; 2]; 2],
}

/// A smoothed point landmark, in the world frame.
#[derive(Debug, Clone, PartialEq)]
pub struct SmoothedLandmark {
    /// The landmark's id (the filter's).
    pub id: u64,
    /// `(x, y)`.
    pub mean: [f64; 2],
    /// Its covariance, row-major 2x2.
    pub covariance: [f64; 4],
}

/// One step of odometry: the controls between two poses, and the inverse square
/// root of its covariance.
struct Link {
    segments: Vec<(Vector2<f64>, f64)>,
    whiten: Matrix3<f64>,
}

/// One paired detection.
struct Sighting {
    node: usize,
    wall: usize,
    /// The seen segment's middle on the detected line, sensor frame.
    mid: Vector2<f64>,
    /// The seen segment's end points, sensor frame (for the wall's extent).
    ends: [Point2<f64>; 2],
    alpha: f64,
    cov: Matrix2<f64>,
}

/// The unknowns.
#[derive(Clone)]
struct Estimate {
    poses: Vec<Vector3<f64>>,
    /// `(rho, alpha)` about `origins[j]`.
    lines: Vec<Vector2<f64>>,
    /// The point landmarks, world frame.
    points: Vec<Vector2<f64>>,
    bias: Vector2<f64>,
}

/// The fixed parts of the problem.
struct Problem {
    motion: MotionModel,
    links: Vec<Link>,
    sightings: Vec<Sighting>,
    origins: Vec<Point2<f64>>,
    ids: Vec<u64>,
    points: Vec<PointSighting>,
    point_ids: Vec<u64>,
    /// `1 / sd` of a point detection's range and bearing.
    point_whiten: Vector2<f64>,
    point_huber: Option<f64>,
    start: Vector3<f64>,
    start_whiten: Matrix3<f64>,
    /// `1 / control_bias_sd`, or `None`: biases not estimated.
    bias_whiten: Option<Vector2<f64>>,
}

/// Smooths a SLAM run with walls, point landmarks or both (see the [module
/// docs](self)).
///
/// # Examples
/// ```
/// use slam::planar::PlanarConfig;
/// use slam::planar::smooth::{FilterRun, SmootherConfig, smooth};
///
/// // Driving 1 m/s along a wall 2 m to the left, seen at both scans.
/// let config = PlanarConfig::default();
/// let controls = [[0.0, 1.0, 0.0]];
/// let wall = |t: f64| [t, 2.0, std::f64::consts::FRAC_PI_2, 1e-4, 0.0, 1e-4, -1.0, 2.0, 1.0, 2.0];
/// let run = FilterRun {
///     config: &config,
///     controls: &controls,
///     times: &[0.0, 1.0],
///     poses: &[[0.0, 0.0, 0.0], [1.1, 0.1, 0.0]],
///     walls: &[wall(0.0), wall(1.0)],
///     pairing: &[Some(0), Some(0)],
///     map: &[(0, [2.0, std::f64::consts::FRAC_PI_2])],
///     points: &[],
///     point_pairing: &[],
///     landmarks: &[],
/// };
/// let out = smooth(&run, &SmootherConfig::default()).unwrap();
/// // The wall holds the robot's y at 0; the odometry its x at 1 m.
/// assert!((out.pose[1][0] - 1.0).abs() < 1e-6 && out.pose[1][1].abs() < 1e-6);
/// ```
pub fn smooth(run: &FilterRun<'_>, options: &SmootherConfig) -> Result<SmoothedRun> {
    options.validate()?;
    let (problem, start) = Problem::new(run, options)?;
    let (est, iterations, cost) = problem.minimise(start, options)?;
    problem.result(&est, iterations, cost)
}

impl Problem {
    fn new(run: &FilterRun<'_>, options: &SmootherConfig) -> Result<(Self, Estimate)> {
        check_run(run)?;
        let config = run.config;
        let poses: Vec<Vector3<f64>> = run.poses.iter().map(|p| Vector3::from(*p)).collect();
        // The controls as the filter uses them: scaled by the calibrated control_scale.
        let controls: Vec<[f64; 3]> = run
            .controls
            .iter()
            .map(|c| {
                let u = config.bias.correct_control([c[1], c[2]]);
                [c[0], u[0], u[1]]
            })
            .collect();
        let links = links(&config.motion, &controls, run.times)?;
        let (sightings, origins, ids, lines) = sightings(run, &poses)?;
        let (points, point_ids, means) = point_sightings(run, options.point_correlation_time)?;
        check_size(poses.len(), 2 * (origins.len() + point_ids.len()) + 2)?;
        let var = config.initial_pose_variance;
        let floor = START_SD_FLOOR * START_SD_FLOOR;
        let start_whiten =
            Matrix3::from_diagonal(&Vector3::from_fn(|i, _| 1.0 / var[i].max(floor).sqrt()));
        let problem = Self {
            motion: config.motion,
            links,
            sightings,
            origins,
            ids,
            points,
            point_ids,
            point_whiten: Vector2::new(
                1.0 / config.range_variance.sqrt(),
                1.0 / config.bearing_variance.sqrt(),
            ),
            point_huber: options.point_huber,
            start: Vector3::from(config.initial_pose),
            start_whiten,
            bias_whiten: config
                .control_bias_sd
                .map(|sd| Vector2::new(1.0 / sd[0], 1.0 / sd[1])),
        };
        let est = Estimate {
            poses,
            lines,
            points: means,
            bias: Vector2::zeros(),
        };
        Ok((problem, est))
    }
}

/// The most numbers the solver's dense border may hold (`3 S g` for `S` poses and `g`
/// wall and bias unknowns, twice): 2^27, 1 GiB of `f64`.
pub const MAX_BORDER: usize = 1 << 27;

/// The most wall and bias unknowns: their Schur complement is dense and factored
/// whole (4096: 128 MiB, seconds per factorisation).
pub const MAX_GLOBAL: usize = 4096;

/// Refuses a run whose dense parts would not fit, before allocating them.
fn check_size(poses: usize, global: usize) -> Result<()> {
    let need = 3usize.saturating_mul(poses).saturating_mul(global);
    if need > MAX_BORDER || global > MAX_GLOBAL {
        return Err(SlamError::invalid(
            "times",
            format!(
                "{poses} poses with {global} wall and bias unknowns exceed the smoother's \
                 dense limits ({MAX_BORDER} border numbers, {MAX_GLOBAL} unknowns): smooth \
                 the run in parts"
            ),
        ));
    }
    Ok(())
}

fn check_run(run: &FilterRun<'_>) -> Result<()> {
    run.config.validate()?;
    if !matches!(run.config.motion, MotionModel::Unicycle(_)) {
        return Err(SlamError::invalid(
            "motion",
            "smoothing models the unicycle (the sensor at the robot's origin) only".into(),
        ));
    }
    let n = run.times.len();
    if n == 0 || run.poses.len() != n {
        return Err(SlamError::invalid(
            "poses",
            format!(
                "needs one pose per time, at least one: {} poses, {n} times",
                run.poses.len()
            ),
        ));
    }
    if run.pairing.len() != run.walls.len() {
        return Err(SlamError::invalid(
            "pairing",
            format!(
                "{} entries for {} wall rows",
                run.pairing.len(),
                run.walls.len()
            ),
        ));
    }
    ensure_finite("times", run.times.iter())?;
    ensure_finite("poses", run.poses.iter().flatten())?;
    ensure_finite("controls", run.controls.iter().flatten())?;
    ensure_finite("walls", run.walls.iter().flatten())?;
    if run.point_pairing.len() != run.points.len() {
        return Err(SlamError::invalid(
            "point_pairing",
            format!(
                "{} entries for {} point rows",
                run.point_pairing.len(),
                run.points.len()
            ),
        ));
    }
    ensure_finite("points", run.points.iter().flatten())?;
    ensure_finite("landmarks", run.landmarks.iter().flat_map(|l| &l.1))?;
    if let Some(k) = (1..n).find(|&k| run.times[k] <= run.times[k - 1]) {
        return Err(SlamError::invalid(
            "times",
            format!("must increase, not at index {k}"),
        ));
    }
    if let Some(k) = (1..run.controls.len()).find(|&k| run.controls[k][0] < run.controls[k - 1][0])
    {
        return Err(SlamError::invalid(
            "controls",
            format!("must be sorted by time, not at row {k}"),
        ));
    }
    Ok(())
}

/// The controls between each pair of consecutive times, as the engine integrates
/// them: a row applies from its time until the next row's (zero before the first).
fn links(motion: &MotionModel, controls: &[[f64; 3]], times: &[f64]) -> Result<Vec<Link>> {
    let mut i = 0;
    let mut u = Vector2::zeros();
    let mut out = Vec::with_capacity(times.len().saturating_sub(1));
    for w in times.windows(2) {
        let (mut t, end) = (w[0], w[1]);
        while i < controls.len() && controls[i][0] <= t {
            u = Vector2::new(controls[i][1], controls[i][2]);
            i += 1;
        }
        let mut segments = Vec::new();
        while i < controls.len() && controls[i][0] < end {
            if controls[i][0] > t {
                segments.push((u, controls[i][0] - t));
            }
            t = controls[i][0];
            u = Vector2::new(controls[i][1], controls[i][2]);
            i += 1;
        }
        segments.push((u, end - t));
        let whiten = link_whitening(motion, &segments)?;
        out.push(Link { segments, whiten });
    }
    Ok(out)
}

/// `L^-1` of the relative pose's covariance `L L^T` (the control noise carried along
/// the segments at zero bias), with a floor of [`LINK_SD_FLOOR`].
fn link_whitening(motion: &MotionModel, segments: &[(Vector2<f64>, f64)]) -> Result<Matrix3<f64>> {
    let v = motion.control_noise();
    let mut pose = Pose2::identity();
    let mut q = Matrix3::zeros();
    for &(u, dt) in segments {
        let p = motion.predict(&pose, u, dt)?;
        q = p.fx * q * p.fx.transpose() + p.fv * v * p.fv.transpose();
        pose = p.pose();
    }
    q += Matrix3::identity() * (LINK_SD_FLOOR * LINK_SD_FLOOR);
    let l = q
        .cholesky()
        .ok_or_else(|| SlamError::Diverged("an odometry covariance".into()))?
        .l();
    l.try_inverse()
        .ok_or_else(|| SlamError::Diverged("an odometry covariance".into()))
}

/// The relative pose the controls give at bias `b`, and its Jacobian in `b`.
fn link_mean(
    motion: &MotionModel,
    link: &Link,
    bias: &Vector2<f64>,
) -> Result<(Vector3<f64>, Matrix3x2<f64>)> {
    let mut pose = Pose2::identity();
    let mut gb = Matrix3x2::zeros();
    for &(u, dt) in &link.segments {
        let p = super::bias::predict_biased(motion, &pose, u, *bias, dt)?;
        gb = p.fx * gb + p.fb;
        pose = Pose2::from_vector(&p.mean);
    }
    Ok((Vector3::new(pose.x, pose.y, pose.theta), gb))
}

type Sightings = (Vec<Sighting>, Vec<Point2<f64>>, Vec<u64>, Vec<Vector2<f64>>);

/// The paired detections; each wall's reference point (the middle of its first
/// sighting, placed with the starting pose) and its starting line about it.
fn sightings(run: &FilterRun<'_>, poses: &[Vector3<f64>]) -> Result<Sightings> {
    let map: HashMap<u64, [f64; 2]> = run.map.iter().copied().collect();
    let mut index: HashMap<u64, usize> = HashMap::new();
    let (mut out, mut origins, mut ids, mut lines) = (vec![], vec![], vec![], vec![]);
    let mut parts: Vec<Vec<(f64, f64)>> = Vec::new();
    for (i, (row, id)) in run.walls.iter().zip(run.pairing).enumerate() {
        let Some(id) = *id else { continue };
        let node = node_of(run.times, "walls", i, row[0])?;
        let pose = Pose2::from_vector(&poses[node]);
        let z = Vector2::new(row[1], row[2]);
        let ends = [Point2::new(row[6], row[7]), Point2::new(row[8], row[9])];
        let (mid, jac) = segment_middle(&z, &ends);
        let world = pose.transform_point(&Point2::from(mid));
        let admitted = !index.contains_key(&id);
        let j = match index.get(&id) {
            Some(&j) => j,
            None => {
                let line = map.get(&id).ok_or_else(|| {
                    SlamError::invalid("map", format!("wall {id} (row {i}) is not in the map"))
                })?;
                let n = Vector2::new(line[1].cos(), line[1].sin());
                index.insert(id, ids.len());
                origins.push(world);
                lines.push(Vector2::new(line[0] - n.dot(&world.coords), line[1]));
                ids.push(id);
                parts.push(Vec::new());
                ids.len() - 1
            }
        };
        let r = Matrix2::new(row[3], row[4], row[4], row[5]);
        let mut cov = jac * r * jac.transpose();
        let sigma = run.config.wall_shared_sd;
        // The admitting sighting is not among the repeats, as in the filter.
        if sigma > 0.0 && !admitted {
            let floor = shared_floor(&mut parts[j], lines[j].y, &pose, &z, &ends, sigma);
            cov += jac * floor * jac.transpose();
        }
        if cov.cholesky().is_none() {
            return Err(SlamError::invalid(
                "walls",
                format!("row {i}: the covariance is not positive definite"),
            ));
        }
        out.push(Sighting {
            node,
            wall: j,
            mid,
            ends,
            alpha: z.y,
            cov,
        });
    }
    Ok((out, origins, ids, lines))
}

/// The pose index of the time `t` of row `i` of the input `what`, which must be one
/// of `times`.
fn node_of(times: &[f64], what: &'static str, i: usize, t: f64) -> Result<usize> {
    times.binary_search_by(|x| x.total_cmp(&t)).map_err(|_| {
        SlamError::invalid(
            what,
            format!("row {i}: time {t} is not one of the poses' times"),
        )
    })
}

/// The shared straightness floor of a repeated sighting (`wall_shared_sd`, as the
/// filter counts it): `sqrt(n)` times the floor's `(rho, alpha)` covariance, `n` the
/// wall's earlier stretches in `parts` (its latest `WALL_PARTS_KEPT`) overlapping
/// this one by more than half. The stretch is placed with `pose` on the wall's
/// starting line (angle `alpha`) and kept.
fn shared_floor(
    parts: &mut Vec<(f64, f64)>,
    alpha: f64,
    pose: &Pose2,
    z: &Vector2<f64>,
    ends: &[Point2<f64>; 2],
    sigma: f64,
) -> Matrix2<f64> {
    let t = Vector2::new(-alpha.sin(), alpha.cos());
    let [a, b] = ends.map(|p| t.dot(&pose.transform_point(&p).coords));
    let part = (a.min(b), a.max(b));
    let repeats = super::walls::overlapping(parts, part) as f64;
    parts.push(part);
    if parts.len() > super::wall_map::WALL_PARTS_KEPT {
        parts.remove(0);
    }
    crate::wall::straightness_covariance(z, ends, sigma) * repeats.sqrt()
}

/// The seen segment's middle on the detected line (sensor frame), and the Jacobian
/// `[[1, -t], [0, 1]]` that takes the detection's `(rho, alpha)` covariance to the
/// offset and angle there (`t` the middle's coordinate along the line).
fn segment_middle(z: &Vector2<f64>, ends: &[Point2<f64>; 2]) -> (Vector2<f64>, Matrix2<f64>) {
    let n = Vector2::new(z.y.cos(), z.y.sin());
    let mid = (ends[0].coords + ends[1].coords) * 0.5;
    let m = mid - n * (n.dot(&mid) - z.x);
    let t = Vector2::new(-n.y, n.x).dot(&m);
    (m, Matrix2::new(1.0, -t, 0.0, 1.0))
}

/// A whitened residual with its Jacobians (pose `k`, pose `k + 1`, biases).
type LinkResidual = (Vector3<f64>, [Matrix3<f64>; 2], Matrix3x2<f64>);

/// The Gauss-Newton normal equations `J^T J`, `J^T r`.
type Normal = (Arrow, DVector<f64>);

/// A link's whitened residual and Jacobians (pose `k`, pose `k + 1`, biases).
fn link_residual(
    motion: &MotionModel,
    link: &Link,
    a: &Vector3<f64>,
    b: &Vector3<f64>,
    bias: &Vector2<f64>,
) -> Result<LinkResidual> {
    let (g, gb) = link_mean(motion, link, bias)?;
    let (s, c) = a.z.sin_cos();
    let d = b.xy() - a.xy();
    let local = Vector3::new(c * d.x + s * d.y, -s * d.x + c * d.y, wrap_angle(b.z - a.z));
    let mut e = local - g;
    e.z = wrap_angle(e.z);
    let ja = Matrix3::new(
        -c,
        -s,
        -s * d.x + c * d.y,
        s,
        -c,
        -c * d.x - s * d.y,
        0.0,
        0.0,
        -1.0,
    );
    let jb = Matrix3::new(c, s, 0.0, -s, c, 0.0, 0.0, 0.0, 1.0);
    let w = link.whiten;
    Ok((w * e, [w * ja, w * jb], -(w * gb)))
}

/// A sighting's whitened residual and Jacobians (its pose, its wall's line).
fn sighting_residual(
    s: &Sighting,
    pose: &Vector3<f64>,
    line: &Vector2<f64>,
    origin: &Point2<f64>,
) -> Result<(Vector2<f64>, Matrix2x3<f64>, Matrix2<f64>)> {
    let (sn, cs) = pose.z.sin_cos();
    let rm = Vector2::new(cs * s.mid.x - sn * s.mid.y, sn * s.mid.x + cs * s.mid.y);
    let drm = Vector2::new(-rm.y, rm.x); // d(R m)/d(theta)
    let rel = pose.xy() + rm - origin.coords;
    let n = Vector2::new(line.y.cos(), line.y.sin());
    let offset = n.dot(&rel) - line.x;
    let mut angle = wrap_angle(s.alpha + pose.z - line.y);
    let mut cov = s.cov;
    // The detection may have the line's other normal: its offset's sign turns, so its
    // correlation with the angle does.
    if angle.abs() > std::f64::consts::FRAC_PI_2 {
        angle = wrap_angle(angle - std::f64::consts::PI);
        cov[(0, 1)] = -cov[(0, 1)];
        cov[(1, 0)] = -cov[(1, 0)];
    }
    let jx = Matrix2x3::new(n.x, n.y, n.dot(&drm), 0.0, 0.0, 1.0);
    let jl = Matrix2::new(-1.0, Vector2::new(-n.y, n.x).dot(&rel), 0.0, -1.0);
    let w = cov
        .cholesky()
        .ok_or_else(|| {
            SlamError::invalid(
                "walls",
                "a detection's covariance is not positive definite".into(),
            )
        })?
        .l()
        .try_inverse()
        .ok_or_else(|| {
            SlamError::invalid("walls", "a detection's covariance is singular".into())
        })?;
    Ok((w * Vector2::new(offset, angle), w * jx, w * jl))
}

impl Problem {
    /// The global unknowns: the walls, then the points, then the biases.
    fn global_dim(&self) -> usize {
        self.bias_at() + if self.bias_whiten.is_some() { 2 } else { 0 }
    }

    /// Where point landmark `j` sits among the global unknowns.
    fn point_at(&self, j: usize) -> usize {
        2 * self.origins.len() + 2 * j
    }

    /// Where the biases sit among the global unknowns.
    fn bias_at(&self) -> usize {
        self.point_at(self.point_ids.len())
    }

    fn residual_count(&self) -> usize {
        3 + 3 * self.links.len()
            + 2 * (self.sightings.len() + self.points.len())
            + if self.bias_whiten.is_some() { 2 } else { 0 }
    }

    /// The cost, and with `normal` the Gauss-Newton normal equations `J^T J` and
    /// `J^T r` (poses first, then walls, then biases).
    fn linearise(&self, est: &Estimate, normal: bool) -> Result<(f64, Option<Normal>)> {
        let s = est.poses.len();
        let mut h = normal.then(|| {
            (
                Arrow::zeros(s, self.global_dim()),
                DVector::zeros(3 * s + self.global_dim()),
            )
        });
        let mut e0 = est.poses[0] - self.start;
        e0.z = wrap_angle(e0.z);
        let r0 = self.start_whiten * e0;
        let mut cost = r0.norm_squared();
        if let Some((a, grad)) = h.as_mut() {
            let w = self.start_whiten;
            a.diag[0] += w.transpose() * w;
            grad.rows_mut(0, 3).add_assign(w.transpose() * r0);
        }
        cost += self.add_links(est, h.as_mut())?;
        cost += self.add_sightings(est, h.as_mut())?;
        cost += self.add_points(est, h.as_mut())?;
        if let Some(wb) = self.bias_whiten {
            let r = est.bias.component_mul(&wb);
            cost += r.norm_squared();
            if let Some((a, grad)) = h.as_mut() {
                let (at, w) = (self.bias_at(), Matrix2::from_diagonal(&wb));
                a.global.view_mut((at, at), (2, 2)).add_assign(w * w);
                grad.rows_mut(3 * s + at, 2).add_assign(w * r);
            }
        }
        Ok((cost, h))
    }

    /// The odometry terms: their cost, added to the normal equations when given.
    fn add_links(&self, est: &Estimate, mut h: Option<&mut Normal>) -> Result<f64> {
        let s = est.poses.len();
        let at = self.bias_at();
        let mut cost = 0.0;
        for (k, link) in self.links.iter().enumerate() {
            let (a, b) = (&est.poses[k], &est.poses[k + 1]);
            let (r, [ja, jb], jbias) = link_residual(&self.motion, link, a, b, &est.bias)?;
            cost += r.norm_squared();
            let Some((a, grad)) = h.as_deref_mut() else {
                continue;
            };
            a.diag[k] += ja.transpose() * ja;
            a.diag[k + 1] += jb.transpose() * jb;
            a.upper[k] += ja.transpose() * jb;
            grad.rows_mut(3 * k, 3).add_assign(ja.transpose() * r);
            grad.rows_mut(3 * k + 3, 3).add_assign(jb.transpose() * r);
            if self.bias_whiten.is_some() {
                a.border[k]
                    .view_mut((0, at), (3, 2))
                    .add_assign(ja.transpose() * jbias);
                a.border[k + 1]
                    .view_mut((0, at), (3, 2))
                    .add_assign(jb.transpose() * jbias);
                a.global
                    .view_mut((at, at), (2, 2))
                    .add_assign(jbias.transpose() * jbias);
                grad.rows_mut(3 * s + at, 2)
                    .add_assign(jbias.transpose() * r);
            }
        }
        Ok(cost)
    }

    /// The wall terms: their cost, added to the normal equations when given.
    fn add_sightings(&self, est: &Estimate, mut h: Option<&mut Normal>) -> Result<f64> {
        let s = est.poses.len();
        let mut cost = 0.0;
        for sg in &self.sightings {
            let (k, j) = (sg.node, sg.wall);
            let (r, jx, jl) =
                sighting_residual(sg, &est.poses[k], &est.lines[j], &self.origins[j])?;
            cost += r.norm_squared();
            if let Some(h) = h.as_deref_mut() {
                add_pose_global(h, s, (k, 2 * j), &r, &jx, &jl);
            }
        }
        Ok(cost)
    }

    /// The point terms (through Huber's kernel when set): their cost, added to the
    /// normal equations (reweighted) when given.
    fn add_points(&self, est: &Estimate, mut h: Option<&mut Normal>) -> Result<f64> {
        let s = est.poses.len();
        let mut cost = 0.0;
        for sg in &self.points {
            let (k, j) = (sg.node, sg.landmark);
            let found = point_residual(sg, &self.point_whiten, &est.poses[k], &est.points[j]);
            let (r, jx, jl) = match (found, h.is_some()) {
                (Ok(terms), _) => terms,
                // A trial step that puts a landmark on a pose is a step to refuse.
                (Err(_), false) => return Ok(f64::INFINITY),
                (Err(e), true) => return Err(e),
            };
            // Huber's threshold is in the sighting's own standard deviations: its
            // correlation weight scales the cost, not the residual's size.
            let (rho, weight) = huber(r.norm() / sg.weight, self.point_huber);
            cost += sg.weight * sg.weight * rho;
            if let Some(h) = h.as_deref_mut() {
                let (r, jx, jl) = (r * weight, jx * weight, jl * weight);
                add_pose_global(h, s, (k, self.point_at(j)), &r, &jx, &jl);
            }
        }
        Ok(cost)
    }

    /// Levenberg-Marquardt (Marquardt's scaling: the damping is `lambda diag(H)`).
    fn minimise(
        &self,
        mut est: Estimate,
        options: &SmootherConfig,
    ) -> Result<(Estimate, usize, f64)> {
        let mut lambda = 1e-4;
        let mut iterations = 0;
        let (mut cost, _) = self.linearise(&est, false)?;
        while iterations < options.max_iterations {
            // Ctrl-C from Python stops here, between iterations.
            rperc_core::interrupt::checkpoint()?;
            iterations += 1;
            let (_, normal) = self.linearise(&est, true)?;
            let (h, grad) = normal.expect("asked for the normal equations");
            let mut improved = false;
            while lambda <= 1e12 {
                let step = damped(&h, lambda).solve(&(-&grad))?;
                let next = self.stepped(&est, &step);
                let (next_cost, _) = self.linearise(&next, false)?;
                if next_cost.is_finite() && next_cost < cost {
                    let gain = (cost - next_cost) / cost.max(f64::MIN_POSITIVE);
                    est = next;
                    cost = next_cost;
                    lambda = (lambda * 0.1).max(1e-12);
                    improved = gain >= options.tolerance;
                    break;
                }
                lambda *= 10.0;
            }
            if !improved {
                break;
            }
        }
        Ok((est, iterations, cost))
    }

    fn stepped(&self, est: &Estimate, step: &DVector<f64>) -> Estimate {
        let s = est.poses.len();
        let mut next = est.clone();
        for (k, p) in next.poses.iter_mut().enumerate() {
            *p += step.fixed_rows::<3>(3 * k);
            p.z = wrap_angle(p.z);
        }
        for (j, l) in next.lines.iter_mut().enumerate() {
            *l += step.fixed_rows::<2>(3 * s + 2 * j);
            l.y = wrap_angle(l.y);
        }
        for (j, p) in next.points.iter_mut().enumerate() {
            *p += step.fixed_rows::<2>(3 * s + self.point_at(j));
        }
        if self.bias_whiten.is_some() {
            next.bias += step.fixed_rows::<2>(3 * s + self.bias_at());
        }
        next
    }

    fn result(&self, est: &Estimate, iterations: usize, cost: f64) -> Result<SmoothedRun> {
        let (_, normal) = self.linearise(est, true)?;
        let (h, _) = normal.expect("asked for the normal equations");
        let (poses, global) = h.covariances()?;
        let extents = self.extents(est);
        let mut walls: Vec<SmoothedWall> = Vec::with_capacity(self.ids.len());
        for (j, (&id, line)) in self.ids.iter().zip(&est.lines).enumerate() {
            let c: Matrix2<f64> = global.fixed_view::<2, 2>(2 * j, 2 * j).into();
            let (w, cw) = world_line(line, &self.origins[j], &c);
            let (n, t) = (
                Vector2::new(w.y.cos(), w.y.sin()),
                Vector2::new(-w.y.sin(), w.y.cos()),
            );
            let ends = extents[j].map(|u| {
                let p = n * w.x + t * u;
                [p.x, p.y]
            });
            walls.push(SmoothedWall {
                id,
                line: [w.x, w.y],
                covariance: [cw[(0, 0)], cw[(0, 1)], cw[(1, 0)], cw[(1, 1)]],
                ends,
            });
        }
        walls.sort_by_key(|w| w.id);
        let mut landmarks: Vec<SmoothedLandmark> = (self.point_ids.iter().zip(&est.points))
            .enumerate()
            .map(|(j, (&id, p))| {
                let at = self.point_at(j);
                let c = global.fixed_view::<2, 2>(at, at);
                SmoothedLandmark {
                    id,
                    mean: [p.x, p.y],
                    covariance: [c[(0, 0)], c[(0, 1)], c[(1, 0)], c[(1, 1)]],
                }
            })
            .collect();
        landmarks.sort_by_key(|l| l.id);
        Ok(SmoothedRun {
            pose: est.poses.iter().map(|p| [p.x, p.y, p.z]).collect(),
            covariance: poses.iter().map(row_major).collect(),
            walls,
            landmarks,
            bias: [est.bias.x, est.bias.y],
            iterations,
            cost,
            residuals: self.residual_count(),
        })
    }

    /// Each wall's seen extent `[from, to]` along its smoothed world line (the
    /// coordinate along `(-sin alpha, cos alpha)`): its sightings' end points placed
    /// with the smoothed poses.
    fn extents(&self, est: &Estimate) -> Vec<[f64; 2]> {
        let mut out = vec![[f64::INFINITY, f64::NEG_INFINITY]; self.ids.len()];
        for sg in &self.sightings {
            let pose = Pose2::from_vector(&est.poses[sg.node]);
            let alpha = est.lines[sg.wall].y;
            let t = Vector2::new(-alpha.sin(), alpha.cos());
            for e in &sg.ends {
                let u = t.dot(&pose.transform_point(e).coords);
                let ext = &mut out[sg.wall];
                *ext = [ext[0].min(u), ext[1].max(u)];
            }
        }
        out
    }
}

/// Adds a 2-row term in pose `k` and the global unknowns at `at` (residual `r`,
/// Jacobians `jx` and `jg`) to the normal equations of `s` poses.
fn add_pose_global(
    (a, grad): &mut Normal,
    s: usize,
    (k, at): (usize, usize),
    r: &Vector2<f64>,
    jx: &Matrix2x3<f64>,
    jg: &Matrix2<f64>,
) {
    a.diag[k] += jx.transpose() * jx;
    a.border[k]
        .view_mut((0, at), (3, 2))
        .add_assign(jx.transpose() * jg);
    a.global
        .view_mut((at, at), (2, 2))
        .add_assign(jg.transpose() * jg);
    grad.rows_mut(3 * k, 3).add_assign(jx.transpose() * r);
    grad.rows_mut(3 * s + at, 2).add_assign(jg.transpose() * r);
}

fn row_major(c: &Matrix3<f64>) -> [f64; 9] {
    let t = c.transpose();
    let mut out = [0.0; 9];
    out.copy_from_slice(t.as_slice());
    out
}

/// `H + lambda diag(H)`.
fn damped(h: &Arrow, lambda: f64) -> Arrow {
    let mut d = h.clone();
    for b in &mut d.diag {
        for i in 0..3 {
            b[(i, i)] *= 1.0 + lambda;
        }
    }
    for i in 0..d.global.nrows() {
        d.global[(i, i)] *= 1.0 + lambda;
    }
    d
}

/// A line about `origin` in the world frame (`rho >= 0`), with its covariance:
/// `rho_w = rho + n(alpha) . o`, `J = [[1, n'(alpha) . o], [0, 1]]`.
fn world_line(
    line: &Vector2<f64>,
    origin: &Point2<f64>,
    c: &Matrix2<f64>,
) -> (Vector2<f64>, Matrix2<f64>) {
    let (s, co) = line.y.sin_cos();
    let rho = line.x + co * origin.x + s * origin.y;
    let j = Matrix2::new(1.0, -s * origin.x + co * origin.y, 0.0, 1.0);
    let mut cw = j * c * j.transpose();
    if rho < 0.0 {
        cw[(0, 1)] = -cw[(0, 1)];
        cw[(1, 0)] = -cw[(1, 0)];
        return (
            Vector2::new(-rho, wrap_angle(line.y + std::f64::consts::PI)),
            cw,
        );
    }
    (Vector2::new(rho, line.y), cw)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::Unicycle;
    use proptest::prelude::*;

    fn unicycle() -> MotionModel {
        MotionModel::Unicycle(Unicycle::default())
    }

    proptest! {
        /// The odometry residual's Jacobians against central differences.
        #[test]
        fn link_jacobians_match_central_differences(
            a in prop::array::uniform3(-3.0..3.0f64), b in prop::array::uniform3(-3.0..3.0f64),
            v in -1.0..1.0f64, w in -0.5..0.5f64, s in -0.05..0.05f64, bw in -0.02..0.02f64,
        ) {
            let motion = unicycle();
            let segments = vec![(Vector2::new(0.0, w), 0.3), (Vector2::new(v, 0.1), 1.2)];
            let whiten = link_whitening(&motion, &segments).unwrap();
            let link = Link { segments, whiten };
            let x = [Vector3::from(a), Vector3::from(b)];
            let bias = Vector2::new(s, bw);
            let (_, jx, jb) = link_residual(&motion, &link, &x[0], &x[1], &bias).unwrap();
            let h = 1e-6;
            for which in 0..2 {
                for i in 0..3 {
                    let (mut p, mut m) = (x, x);
                    p[which][i] += h;
                    m[which][i] -= h;
                    let rp = link_residual(&motion, &link, &p[0], &p[1], &bias).unwrap().0;
                    let rm = link_residual(&motion, &link, &m[0], &m[1], &bias).unwrap().0;
                    let fd = (rp - rm) / (2.0 * h);
                    prop_assert!((fd - jx[which].column(i)).amax() < 1e-5 * (1.0 + fd.amax()));
                }
            }
            for i in 0..2 {
                let (mut p, mut m) = (bias, bias);
                p[i] += h;
                m[i] -= h;
                let rp = link_residual(&motion, &link, &x[0], &x[1], &p).unwrap().0;
                let rm = link_residual(&motion, &link, &x[0], &x[1], &m).unwrap().0;
                let fd = (rp - rm) / (2.0 * h);
                prop_assert!((fd - jb.column(i)).amax() < 1e-5 * (1.0 + fd.amax()));
            }
        }

        /// The wall residual's Jacobians against central differences, both normals.
        #[test]
        fn sighting_jacobians_match_central_differences(
            pose in prop::array::uniform3(-3.0..3.0f64), rho in -2.0..2.0f64,
            alpha in -3.0..3.0f64, za in -3.0..3.0f64, mid in prop::array::uniform2(-3.0..3.0f64),
            origin in prop::array::uniform2(-5.0..5.0f64),
        ) {
            let s = Sighting {
                node: 0, wall: 0, mid: Vector2::from(mid),
                ends: [Point2::origin(); 2], alpha: za,
                cov: Matrix2::new(4e-4, 1e-5, 1e-5, 1e-4),
            };
            let (x, l, o) = (Vector3::from(pose), Vector2::new(rho, alpha), Point2::from(origin));
            let angle = wrap_angle(za + pose[2] - alpha).abs();
            // Away from the switch between the two normals, where the residual jumps.
            prop_assume!((angle - std::f64::consts::FRAC_PI_2).abs() > 1e-3);
            let (_, jx, jl) = sighting_residual(&s, &x, &l, &o).unwrap();
            let h = 1e-6;
            for i in 0..3 {
                let (mut p, mut m) = (x, x);
                p[i] += h;
                m[i] -= h;
                let fd = (sighting_residual(&s, &p, &l, &o).unwrap().0
                    - sighting_residual(&s, &m, &l, &o).unwrap().0) / (2.0 * h);
                prop_assert!((fd - jx.column(i)).amax() < 1e-4 * (1.0 + fd.amax()));
            }
            for i in 0..2 {
                let (mut p, mut m) = (l, l);
                p[i] += h;
                m[i] -= h;
                let fd = (sighting_residual(&s, &x, &p, &o).unwrap().0
                    - sighting_residual(&s, &x, &m, &o).unwrap().0) / (2.0 * h);
                prop_assert!((fd - jl.column(i)).amax() < 1e-4 * (1.0 + fd.amax()));
            }
        }

        /// A line about its reference point and in the world frame are the same line,
        /// and the covariance maps by the Jacobian of that change (central differences).
        #[test]
        fn world_lines_are_the_same_line(
            rho in -3.0..3.0f64, alpha in -3.0..3.0f64, origin in prop::array::uniform2(-5.0..5.0f64),
        ) {
            let o = Point2::from(origin);
            let local = Vector2::new(rho, alpha);
            let (w, cw) = world_line(&local, &o, &Matrix2::identity());
            // A point on the local line: o + rho n + t n'.
            let n = Vector2::new(alpha.cos(), alpha.sin());
            let q = o.coords + n * rho + Vector2::new(-n.y, n.x) * 0.7;
            prop_assert!((Vector2::new(w.y.cos(), w.y.sin()).dot(&q) - w.x).abs() < 1e-9);
            prop_assert!(w.x >= 0.0);
            // Away from the flip at rho_w = 0, the covariance is J J^T for the
            // central differences J of the world line.
            prop_assume!(w.x > 1e-3);
            let h = 1e-6;
            let mut j = Matrix2::zeros();
            for i in 0..2 {
                let (mut p, mut m) = (local, local);
                p[i] += h;
                m[i] -= h;
                let d = world_line(&p, &o, &Matrix2::identity()).0 - world_line(&m, &o, &Matrix2::identity()).0;
                j.set_column(i, &(Vector2::new(d.x, wrap_angle(d.y)) / (2.0 * h)));
            }
            prop_assert!((cw - j * j.transpose()).amax() < 1e-5 * (1.0 + cw.amax()));
        }
    }

    /// Controls held until the next row, zero before the first, and a row at a pose's
    /// time applying after it (as the engine integrates them).
    #[test]
    fn a_run_too_large_for_the_border_is_refused_by_size() {
        assert!(check_size(1000, 2000).is_ok());
        let err = check_size(100_000, 1_000).unwrap_err().to_string();
        assert!(err.contains("smooth the run in parts"), "{err}");
        assert!(check_size(2, MAX_GLOBAL + 1).is_err());
        assert!(check_size(usize::MAX, usize::MAX).is_err());
    }

    #[test]
    fn links_split_the_controls_at_the_poses_times() {
        let controls = [[0.5, 1.0, 0.0], [1.5, 2.0, 0.1], [2.0, 3.0, 0.0]];
        let l = links(&unicycle(), &controls, &[0.0, 1.0, 2.0, 3.0]).unwrap();
        let segs: Vec<Vec<(f64, f64)>> = l
            .iter()
            .map(|k| k.segments.iter().map(|(u, dt)| (u.x, *dt)).collect())
            .collect();
        assert_eq!(
            segs,
            vec![
                vec![(0.0, 0.5), (1.0, 0.5)],
                vec![(1.0, 0.5), (2.0, 0.5)],
                vec![(3.0, 1.0)],
            ]
        );
    }
}
