//! The point-landmark smoother on a simulated run whose truth is known: the robot
//! drives a square loop twice with noisy controls and sees six point landmarks through
//! a depth camera with MR.CLAM-like biases (offset, scale, depth `r cos b`), paired by
//! their true ids. Oracles: the truth itself (a noise-free run is recovered exactly
//! from dead reckoning and a wrong map) and the chi-square distribution of the
//! smoothed poses' and landmarks' NEES over Monte Carlo runs.

use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use rperc_core::{Pose2, chi2_quantile, wrap_angle};
use slam::motion::{MotionModel, Unicycle};
use slam::planar::smooth::{FilterRun, SmoothedRun, SmootherConfig, smooth};
use slam::planar::{PlanarConfig, SensorBias};

const LANDMARKS: [[f64; 2]; 6] = [
    [0.0, 0.0],
    [3.0, -1.0],
    [4.0, 3.0],
    [1.0, 4.0],
    [-1.5, 2.0],
    [2.0, 1.5],
];
const SPEED_SD: f64 = 0.05;
const TURN_SD: f64 = 0.03;
const RANGE_SD: f64 = 0.05;
const BEARING_SD: f64 = 0.02;
/// The camera sees landmarks within this range and +-60 degrees of its axis.
const REACH: f64 = 4.0;

fn bias() -> SensorBias {
    SensorBias {
        range_offset: 0.05,
        range_scale: 1.02,
        range_is_depth: true,
        bearing_offset: -0.01,
        bearing_scale: 0.98,
        control_scale: [1.0, 1.0],
    }
}

fn config() -> PlanarConfig {
    PlanarConfig {
        motion: MotionModel::Unicycle(Unicycle {
            speed_variance: SPEED_SD * SPEED_SD,
            turn_rate_variance: TURN_SD * TURN_SD,
        }),
        initial_pose: [-1.0, -1.0, 0.0],
        initial_pose_variance: [1e-4, 1e-4, 1e-4],
        range_variance: RANGE_SD * RANGE_SD,
        bearing_variance: BEARING_SD * BEARING_SD,
        bias: bias(),
        ..PlanarConfig::default()
    }
}

#[derive(Default)]
struct Sim {
    controls: Vec<[f64; 3]>,
    times: Vec<f64>,
    truth: Vec<[f64; 3]>,
    dead_reckoning: Vec<[f64; 3]>,
    points: Vec<[f64; 3]>,
    pairing: Vec<Option<u64>>,
}

fn normal(rng: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(rng)
}

/// The landmarks the camera sees from `truth`, as measured (biased, with `noise`
/// times the stated noise), at time `t`.
fn sight(sim: &mut Sim, rng: &mut ChaCha8Rng, truth: &Pose2, t: f64, noise: f64) {
    for (id, l) in LANDMARKS.iter().enumerate() {
        let (dx, dy) = (l[0] - truth.x, l[1] - truth.y);
        let (r, b) = (dx.hypot(dy), wrap_angle(dy.atan2(dx) - truth.theta));
        if r > REACH || b.abs() > 1.05 {
            continue;
        }
        let r = r + noise * RANGE_SD * normal(rng);
        let b = b + noise * BEARING_SD * normal(rng);
        let (rm, bm) = bias().distort_detection(r, b);
        sim.points.push([t, rm, bm]);
        sim.pairing.push(Some(id as u64));
    }
}

/// A 4 m square driven twice in 0.5 s steps, a quarter turn at each corner; `noise`
/// scales every noise (0: exact data). Every step sees the landmarks in reach.
fn simulate(seed: u64, noise: f64) -> Sim {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let motion = config().motion;
    let start = Pose2::from_vector(&config().initial_pose.into());
    let mut sim = Sim {
        times: vec![0.0],
        truth: vec![config().initial_pose],
        dead_reckoning: vec![config().initial_pose],
        ..Sim::default()
    };
    let (mut truth, mut dr) = (start, start);
    for k in 0..2 * 4 * 10 {
        let turn = k % 10 == 9;
        let u = if turn {
            [0.0, std::f64::consts::PI]
        } else {
            [0.8, 0.0]
        };
        let true_u = Vector2::new(
            u[0] + noise * SPEED_SD * normal(&mut rng),
            u[1] + noise * TURN_SD * normal(&mut rng),
        );
        let t = 0.5 * k as f64;
        sim.controls.push([t, u[0], u[1]]);
        truth = motion.predict(&truth, true_u, 0.5).unwrap().pose();
        dr = motion.predict(&dr, u.into(), 0.5).unwrap().pose();
        sim.times.push(t + 0.5);
        sim.truth.push([truth.x, truth.y, truth.theta]);
        sim.dead_reckoning.push([dr.x, dr.y, dr.theta]);
        sight(&mut sim, &mut rng, &truth, t + 0.5, noise);
    }
    sim
}

/// The run to smooth: the simulation's data, from dead reckoning and `landmarks`.
fn filter_run<'a>(
    sim: &'a Sim,
    config: &'a PlanarConfig,
    landmarks: &'a [(u64, [f64; 2])],
) -> FilterRun<'a> {
    FilterRun {
        config,
        controls: &sim.controls,
        times: &sim.times,
        poses: &sim.dead_reckoning,
        walls: &[],
        pairing: &[],
        map: &[],
        points: &sim.points,
        point_pairing: &sim.pairing,
        landmarks,
    }
}

fn run(sim: &Sim, landmarks: &[(u64, [f64; 2])], options: SmootherConfig) -> SmoothedRun {
    let config = config();
    smooth(&filter_run(sim, &config, landmarks), &options).unwrap()
}

fn true_map() -> Vec<(u64, [f64; 2])> {
    (0..LANDMARKS.len() as u64).zip(LANDMARKS).collect()
}

#[test]
fn exact_data_is_recovered_from_dead_reckoning_and_a_wrong_map() {
    let sim = simulate(1, 0.0);
    assert!(sim.points.len() > 100, "{} sightings", sim.points.len());
    let wrong: Vec<(u64, [f64; 2])> = true_map()
        .iter()
        .map(|(i, l)| (*i, [l[0] + 0.4, l[1] - 0.3]))
        .collect();
    let out = run(&sim, &wrong, SmootherConfig::default());
    for (p, t) in out.pose.iter().zip(&sim.truth) {
        assert!(
            (p[0] - t[0]).abs() < 1e-6 && (p[1] - t[1]).abs() < 1e-6,
            "{p:?} {t:?}"
        );
        assert!(wrap_angle(p[2] - t[2]).abs() < 1e-7);
    }
    assert_eq!(out.landmarks.len(), LANDMARKS.len());
    for (l, t) in out.landmarks.iter().zip(LANDMARKS) {
        assert!(
            (l.mean[0] - t[0]).abs() < 1e-6 && (l.mean[1] - t[1]).abs() < 1e-6,
            "{l:?}"
        );
    }
}

/// A sighting the filter refused (`None`) is left out: a wild one changes nothing.
/// Paired, it bends the path; through Huber's kernel, far less.
#[test]
fn unpaired_sightings_are_left_out_and_huber_bounds_a_paired_one() {
    let mut sim = simulate(2, 1.0);
    let clean = run(&sim, &true_map(), SmootherConfig::default());
    let t = sim.points[10][0];
    sim.points.insert(11, [t, 0.5, 0.9]);
    sim.pairing.insert(11, None);
    let with_outlier = run(&sim, &true_map(), SmootherConfig::default());
    assert_eq!(clean.pose, with_outlier.pose);
    sim.pairing[11] = Some(0);
    let shift = |out: &SmoothedRun| {
        out.pose
            .iter()
            .zip(&clean.pose)
            .map(|(a, b)| (a[0] - b[0]).hypot(a[1] - b[1]))
            .fold(0.0, f64::max)
    };
    let plain = shift(&run(&sim, &true_map(), SmootherConfig::default()));
    let robust = SmootherConfig {
        point_huber: Some(3.0),
        ..SmootherConfig::default()
    };
    let huber = shift(&run(&sim, &true_map(), robust));
    assert!(plain > 0.05, "the outlier moved the path by only {plain} m");
    assert!(huber < 0.2 * plain, "Huber: {huber} m against {plain} m");
}

/// A sighting of a landmark missing from the map, or at a time that is no pose's,
/// is an error that names it.
#[test]
fn bad_point_rows_are_errors_that_name_the_input() {
    let sim = simulate(3, 1.0);
    let config = config();
    let mut map = true_map();
    map.retain(|(id, _)| *id != 1);
    let mut run = filter_run(&sim, &config, &map);
    let err = smooth(&run, &SmootherConfig::default())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("landmark 1") && err.contains("not in the map"),
        "{err}"
    );
    let full = true_map();
    let mut points = sim.points.clone();
    points[4][0] += 0.25;
    run.landmarks = &full;
    run.points = &points;
    let err = smooth(&run, &SmootherConfig::default())
        .unwrap_err()
        .to_string();
    assert!(err.contains("points") && err.contains("row 4"), "{err}");
    run.points = &sim.points;
    run.point_pairing = &sim.pairing[1..];
    let err = smooth(&run, &SmootherConfig::default())
        .unwrap_err()
        .to_string();
    assert!(err.contains("point_pairing"), "{err}");
    // A depth that the bias correction leaves at or under zero (the filter refuses it).
    run.point_pairing = &sim.pairing;
    let mut near = sim.points.clone();
    near[3][1] = 0.01;
    run.points = &near;
    let err = smooth(&run, &SmootherConfig::default())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("row 3") && err.contains("range must be > 0"),
        "{err}"
    );
    let mut nan = sim.points.clone();
    nan[3][1] = f64::NAN;
    run.points = &nan;
    let err = smooth(&run, &SmootherConfig::default())
        .unwrap_err()
        .to_string();
    assert!(err.contains("points"), "{err}");
}

#[test]
fn smoothed_poses_and_landmarks_are_consistent_over_monte_carlo_runs() {
    let runs = 40u64;
    let (mut pose_sum, mut poses, mut mark_sum, mut better) = (0.0, 0usize, 0.0, 0u64);
    for seed in 0..runs {
        let sim = simulate(200 + seed, 1.0);
        let out = run(&sim, &true_map(), SmootherConfig::default());
        for (l, t) in out.landmarks.iter().zip(LANDMARKS) {
            let e = Vector2::new(l.mean[0] - t[0], l.mean[1] - t[1]);
            let cov = Matrix2::from_row_slice(&l.covariance);
            mark_sum += e.dot(&(cov.try_inverse().unwrap() * e));
        }
        let (mut sq, mut sq_dr) = (0.0, 0.0);
        let truth = sim.truth.iter().zip(&sim.dead_reckoning);
        for ((p, c), (t, d)) in out.pose.iter().zip(&out.covariance).zip(truth).skip(1) {
            let e = Vector3::new(p[0] - t[0], p[1] - t[1], wrap_angle(p[2] - t[2]));
            pose_sum += e.dot(&(Matrix3::from_row_slice(c).try_inverse().unwrap() * e));
            poses += 1;
            sq += e.xy().norm_squared();
            sq_dr += (d[0] - t[0]).powi(2) + (d[1] - t[1]).powi(2);
        }
        better += u64::from(sq < sq_dr);
    }
    // Mean NEES of draws correlated along a run: the band is that of the runs'
    // count (3 dof a pose, 2 a landmark), two-sided 99 %.
    let n = runs as f64;
    let band = |dof: f64| {
        (
            chi2_quantile(0.005, dof * n).unwrap() / n,
            chi2_quantile(0.995, dof * n).unwrap() / n,
        )
    };
    let mean = pose_sum / poses as f64;
    let (lo, hi) = band(3.0);
    assert!(
        mean > lo && mean < hi,
        "mean pose NEES {mean:.2} outside [{lo:.2}, {hi:.2}]"
    );
    let mean = mark_sum / (n * LANDMARKS.len() as f64);
    let (lo, hi) = band(2.0);
    assert!(
        mean > lo && mean < hi,
        "mean landmark NEES {mean:.2} outside [{lo:.2}, {hi:.2}]"
    );
    assert_eq!(
        better, runs,
        "smoothing must beat dead reckoning on every run"
    );
}

/// With odometry alone the smoothed path is the dead reckoning of the controls the
/// filter uses: scaled by the calibrated `control_scale` (closed-form arcs).
#[test]
fn odometry_alone_is_dead_reckoning_of_the_scaled_controls() {
    let config = PlanarConfig {
        bias: SensorBias {
            control_scale: [0.5, 0.8],
            ..SensorBias::default()
        },
        ..config()
    };
    let controls = [[0.0, 1.0, 0.1]];
    let times: Vec<f64> = (0..=10).map(f64::from).collect();
    let run = FilterRun {
        config: &config,
        controls: &controls,
        times: &times,
        poses: &vec![[0.0; 3]; times.len()],
        walls: &[],
        pairing: &[],
        map: &[],
        points: &[],
        point_pairing: &[],
        landmarks: &[],
    };
    let out = smooth(&run, &SmootherConfig::default()).unwrap();
    let (v, w) = (0.5, 0.08);
    let [x0, y0, th0] = config.initial_pose;
    for (p, t) in out.pose.iter().zip(&times) {
        let th = th0 + w * t;
        let (x, y) = (
            x0 + v / w * (th.sin() - th0.sin()),
            y0 - v / w * (th.cos() - th0.cos()),
        );
        assert!(
            (p[0] - x).abs() < 1e-6 && (p[1] - y).abs() < 1e-6,
            "{p:?} at {t}"
        );
        assert!(wrap_angle(p[2] - th).abs() < 1e-7);
    }
}
