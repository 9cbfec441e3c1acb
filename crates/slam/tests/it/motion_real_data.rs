//! The motion models on real data and inside the EKF: dead reckoning of MR.CLAM robot
//! 1 against Vicon ground truth, the Ackermann model against Guivant & Nebot's
//! published laser-point equations on Victoria Park's inputs, and a prediction through
//! `Ekf::predict` against the covariance propagation written out densely.
//!
//! Tests that need the shared data (`RPERC_DATA`, else `../shared/data` beside the
//! repository) print why and return when it is absent.

use std::path::PathBuf;

use nalgebra::{DMatrix, DVector, Vector2};
use rperc_core::{Pose2, wrap_angle};
use slam::{Ackermann, Ekf, MotionModel, Unicycle, unicycle};

fn data_dir() -> Option<PathBuf> {
    let dir = match std::env::var_os("RPERC_DATA") {
        Some(d) => PathBuf::from(d),
        None => PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"),
    };
    dir.is_dir().then_some(dir)
}

/// The numeric rows of a `.dat` file (`#` comments skipped); a malformed row panics
/// with its line number, which is what a test should do with a corrupt fixture.
fn rows(path: PathBuf, columns: usize) -> Option<Vec<Vec<f64>>> {
    let text = std::fs::read_to_string(&path).ok()?;
    let mut out = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let row: Vec<f64> = line
            .split_whitespace()
            .map(|t| {
                t.parse()
                    .unwrap_or_else(|_| panic!("{path:?}:{}: {t}", n + 1))
            })
            .collect();
        assert_eq!(row.len(), columns, "{path:?}:{}", n + 1);
        out.push(row);
    }
    Some(out)
}

/// Same data and bound as `tests/test_slam_datasets.py` (measured there with an
/// independent numpy integration: 0.21 m and 0.008 rad after 3.7 m of path).
#[test]
fn mrclam_dead_reckoning_first_60_s() {
    let Some(dir) = data_dir() else {
        eprintln!("skipped: shared data not found (set RPERC_DATA)");
        return;
    };
    let odo = rows(dir.join("mrclam6/Robot1_Odometry.dat"), 3).unwrap();
    let truth = rows(dir.join("mrclam6/Robot1_Groundtruth.dat"), 4).unwrap();
    let at = |t: f64| truth.iter().find(|r| r[0] >= t).unwrap();
    let t0 = odo[0][0];
    let s = at(t0);
    let mut pose = Pose2::new(s[1], s[2], s[3]);
    let (mut k, mut path) = (0, 0.0);
    while odo[k + 1][0] <= t0 + 60.0 {
        let dt = odo[k + 1][0] - odo[k][0];
        pose = unicycle(&pose, odo[k][1], odo[k][2], dt).pose();
        path += (odo[k][1] * dt).abs();
        k += 1;
    }
    let e = at(odo[k][0]);
    let drift = (pose.translation() - Vector2::new(e[1], e[2])).norm();
    eprintln!("MR.CLAM 60 s: drift {drift:.3} m over {path:.2} m");
    assert!(drift < 0.1 * path, "{drift} vs path {path}");
    assert!(wrap_angle(pose.theta - e[3]).abs() < 0.1);
}

/// Our rear-axle arcs, seen at the laser, against Guivant & Nebot's Euler steps of the
/// laser point, over Victoria Park's first 60 s of inputs (dt = 25 ms). Euler's error
/// per step is ~ |a| dt^2 / 2 with the laser point's acceleration |a| <= v omega + a
/// omega^2 ~ 10 m/s^2 at most here: 3 mm per step, but these errors mostly cancel
/// between turns; we bound the gap by 1 % of the path plus 0.1 m.
#[test]
fn victoria_park_ackermann_matches_guivant_nebot() {
    let Some(dir) = data_dir() else {
        eprintln!("skipped: shared data not found (set RPERC_DATA)");
        return;
    };
    let inputs = rows(dir.join("victoria_park/inputs.dat"), 3).unwrap();
    let car = Ackermann::default();
    let (l, h, a, b) = (
        car.wheel_base,
        car.encoder_offset,
        car.laser_forward,
        car.laser_left,
    );
    let mut pose = Pose2::new(-a, -b, 0.0); // puts the laser at the origin, heading 0
    let (mut xl, mut yl, mut phi, mut path) = (0.0f64, 0.0f64, 0.0f64, 0.0);
    let (mut worst, mut largest) = (0.0f64, 0.0f64);
    for w in inputs.windows(2).take_while(|w| w[0][0] <= 60.0) {
        let (dt, speed, steer) = (w[1][0] - w[0][0], w[0][1], w[0][2]);
        pose = car
            .predict(&pose, Vector2::new(speed, steer), dt)
            .unwrap()
            .pose();
        let vc = speed / (1.0 - steer.tan() * h / l);
        let om = vc * steer.tan() / l;
        let (s, c) = phi.sin_cos();
        xl += dt * (vc * c - om * (a * s + b * c));
        yl += dt * (vc * s + om * (a * c - b * s));
        phi += dt * om;
        path += (vc * dt).abs();
        let laser = car.laser_pose(&pose).0;
        let gap = (laser.translation() - Vector2::new(xl, yl)).norm();
        largest = largest.max(gap);
        worst = worst.max(gap - 0.01 * path);
    }
    eprintln!(
        "Victoria Park 60 s: {path:.1} m, largest gap {largest:.4} m, worst excess {worst:.4} m"
    );
    assert!(path > 100.0 && worst < 0.1, "{worst}");
}

/// `Prediction::to_dynamic` feeds `Ekf::predict`: the robot block becomes
/// `Fx P Fx^T + Fv V Fv^T`, the robot-landmark block `Fx P_rl`, landmarks untouched.
#[test]
fn prediction_drives_the_ekf() {
    let model = MotionModel::Unicycle(Unicycle::default());
    let x = DVector::from_vec(vec![1.0, 2.0, 0.3, 4.0, -1.0]);
    let a = DMatrix::from_fn(5, 5, |i, j| ((i * 5 + j) as f64 * 0.37).sin());
    let p0 = &a * a.transpose() + DMatrix::identity(5, 5) * 0.1;
    let mut ekf = Ekf::new(x.clone(), p0.clone(), 3, 2).unwrap();
    let pose = Pose2::new(x[0], x[1], x[2]);
    let pred = model.predict(&pose, Vector2::new(0.5, 0.2), 0.1).unwrap();
    let (mean, fx, fv) = pred.to_dynamic();
    let v = DMatrix::from_column_slice(2, 2, model.control_noise().as_slice());
    ekf.predict(&mean, &fx, &fv, &v).unwrap();
    // Dense oracle: F = blockdiag(Fx, I), G = [Fv; 0].
    let mut f = DMatrix::identity(5, 5);
    f.view_mut((0, 0), (3, 3)).copy_from(&fx);
    let mut g = DMatrix::zeros(5, 2);
    g.view_mut((0, 0), (3, 2)).copy_from(&fv);
    let expected = &f * &p0 * f.transpose() + &g * &v * g.transpose();
    assert!((ekf.covariance() - expected).abs().max() < 1e-12);
    assert_eq!(ekf.state().rows(0, 3), mean.rows(0, 3));
    assert_eq!(ekf.state().rows(3, 2), x.rows(3, 2));
}
