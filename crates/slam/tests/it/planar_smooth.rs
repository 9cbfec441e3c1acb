//! The wall smoother on a simulated square room whose truth is known: the robot drives
//! a loop with noisy, biased controls and sees the four walls with noise of the stated
//! covariance, paired by their true ids. Oracles: the truth itself (a noise-free run
//! is recovered exactly) and the chi-square distribution of the smoothed poses' NEES
//! over Monte Carlo runs (the covariance claimed must be the error's).

use std::f64::consts::{FRAC_PI_2, PI};

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use rperc_core::{Pose2, chi2_quantile, wrap_angle};
use slam::motion::{MotionModel, Unicycle};
use slam::planar::PlanarConfig;
use slam::planar::smooth::{FilterRun, SmootherConfig, smooth as smooth_run};

/// Walls `(rho, alpha)` of a 10 m square room centred on the origin.
const WALLS: [[f64; 2]; 4] = [[5.0, 0.0], [5.0, FRAC_PI_2], [5.0, PI], [5.0, -FRAC_PI_2]];
const V: f64 = 0.5;
const SPEED_SD: f64 = 0.05;
const TURN_SD: f64 = 0.02;
const BIAS_SD: [f64; 2] = [0.02, 0.01];

fn config() -> PlanarConfig {
    PlanarConfig {
        motion: MotionModel::Unicycle(Unicycle {
            speed_variance: SPEED_SD * SPEED_SD,
            turn_rate_variance: TURN_SD * TURN_SD,
        }),
        initial_pose: [-2.0, -2.0, 0.0],
        control_bias_sd: Some(BIAS_SD),
        ..PlanarConfig::default()
    }
}

struct Sim {
    controls: Vec<[f64; 3]>,
    times: Vec<f64>,
    truth: Vec<[f64; 3]>,
    dead_reckoning: Vec<[f64; 3]>,
    walls: Vec<[f64; 10]>,
    pairing: Vec<Option<u64>>,
}

fn normal(rng: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(rng)
}

/// A 4 m square driven twice: 1 s steps, a quarter turn at each corner; `noise`
/// scales every noise (0: exact data).
fn simulate(seed: u64, noise: f64) -> Sim {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let motion = config().motion;
    let bias = [
        noise * BIAS_SD[0] * normal(&mut rng),
        noise * BIAS_SD[1] * normal(&mut rng),
    ];
    let (r_sd, a_sd) = (0.02, 0.01);
    let mut sim = Sim {
        controls: vec![],
        times: vec![0.0],
        truth: vec![config().initial_pose],
        dead_reckoning: vec![config().initial_pose],
        walls: vec![],
        pairing: vec![],
    };
    let (mut truth, mut dr) = (
        Pose2::from_vector(&config().initial_pose.into()),
        Pose2::from_vector(&config().initial_pose.into()),
    );
    for k in 0..64 {
        let w = if k % 8 == 7 {
            std::f64::consts::FRAC_PI_2
        } else {
            0.0
        };
        let v = if w == 0.0 { V } else { 0.0 };
        // Odometry reports the commanded control through the bias (the truth is
        // `u0 (1 - s)`, `u1 - b`); the robot moves with that plus the control noise.
        let measured = [v / (1.0 - bias[0]), w + bias[1]];
        let true_u = nalgebra::Vector2::new(
            v + noise * SPEED_SD * normal(&mut rng),
            w + noise * TURN_SD * normal(&mut rng),
        );
        let t = k as f64;
        sim.controls.push([t, measured[0], measured[1]]);
        truth = motion.predict(&truth, true_u, 1.0).unwrap().pose();
        dr = motion.predict(&dr, measured.into(), 1.0).unwrap().pose();
        sim.times.push(t + 1.0);
        sim.truth.push([truth.x, truth.y, truth.theta]);
        sim.dead_reckoning.push([dr.x, dr.y, dr.theta]);
        for (id, wall) in WALLS.iter().enumerate() {
            // The wall in the sensor frame; its foot is the seen segment's middle.
            let n = nalgebra::Vector2::new(wall[1].cos(), wall[1].sin());
            let rho = wall[0] - n.dot(&nalgebra::Vector2::new(truth.x, truth.y));
            let alpha = wrap_angle(wall[1] - truth.theta);
            let (rho, alpha) = (
                rho + noise * r_sd * normal(&mut rng),
                alpha + noise * a_sd * normal(&mut rng),
            );
            let (nx, ny) = (alpha.cos(), alpha.sin());
            let foot = [rho * nx, rho * ny];
            sim.walls.push([
                t + 1.0,
                rho,
                alpha,
                r_sd * r_sd,
                0.0,
                a_sd * a_sd,
                foot[0] + ny,
                foot[1] - nx,
                foot[0] - ny,
                foot[1] + nx,
            ]);
            sim.pairing.push(Some(id as u64));
        }
    }
    sim
}

/// The run to smooth: the simulation's data, from dead reckoning and `map`.
fn run_of<'a>(sim: &'a Sim, config: &'a PlanarConfig, map: &'a [(u64, [f64; 2])]) -> FilterRun<'a> {
    FilterRun {
        config,
        controls: &sim.controls,
        times: &sim.times,
        poses: &sim.dead_reckoning,
        walls: &sim.walls,
        pairing: &sim.pairing,
        map,
        points: &[],
        point_pairing: &[],
        landmarks: &[],
    }
}

fn smooth(sim: &Sim, map: &[(u64, [f64; 2])]) -> slam::planar::smooth::SmoothedRun {
    let config = config();
    smooth_run(&run_of(sim, &config, map), &SmootherConfig::default()).unwrap()
}

fn true_map() -> Vec<(u64, [f64; 2])> {
    WALLS
        .iter()
        .enumerate()
        .map(|(i, w)| (i as u64, *w))
        .collect()
}

#[test]
fn exact_data_is_recovered_from_dead_reckoning_and_a_wrong_map() {
    let sim = simulate(1, 0.0);
    let map: Vec<(u64, [f64; 2])> = true_map()
        .iter()
        .map(|(i, w)| (*i, [w[0] + 0.3, w[1] + 0.05]))
        .collect();
    let out = smooth(&sim, &map);
    for (p, t) in out.pose.iter().zip(&sim.truth) {
        assert!(
            (p[0] - t[0]).abs() < 1e-6 && (p[1] - t[1]).abs() < 1e-6,
            "{p:?} {t:?}"
        );
        assert!(wrap_angle(p[2] - t[2]).abs() < 1e-7);
    }
    for (w, t) in out.walls.iter().zip(WALLS) {
        let l = w.line;
        assert!(
            (l[0] - t[0]).abs() < 1e-6 && wrap_angle(l[1] - t[1]).abs() < 1e-7,
            "{l:?}"
        );
        // The extent: the sightings' end points (1 m either side of the robot's foot
        // on the wall), placed with the true poses, lie on the true wall.
        for e in w.ends {
            let n = nalgebra::Vector2::new(t[1].cos(), t[1].sin());
            assert!(
                (n.dot(&nalgebra::Vector2::from(e)) - t[0]).abs() < 1e-6,
                "{e:?}"
            );
        }
        assert!(nalgebra::distance(&w.ends[0].into(), &w.ends[1].into()) > 2.0);
    }
}

#[test]
fn smoothed_poses_and_walls_are_consistent_over_monte_carlo_runs() {
    let runs = 40;
    let (mut sum, mut count, mut better) = (0.0, 0usize, 0);
    let mut wall_sum = 0.0;
    for seed in 0..runs {
        let sim = simulate(100 + seed, 1.0);
        let out = smooth(&sim, &true_map());
        for (w, t) in out.walls.iter().zip(WALLS) {
            let e = nalgebra::Vector2::new(w.line[0] - t[0], wrap_angle(w.line[1] - t[1]));
            let cov = nalgebra::Matrix2::from_row_slice(&w.covariance);
            wall_sum += e.dot(&(cov.try_inverse().unwrap() * e));
        }
        let (mut sq, mut sq_dr) = (0.0, 0.0);
        for ((p, c), (t, d)) in out
            .pose
            .iter()
            .zip(&out.covariance)
            .zip(sim.truth.iter().zip(&sim.dead_reckoning))
            .skip(1)
        {
            let e = nalgebra::Vector3::new(p[0] - t[0], p[1] - t[1], wrap_angle(p[2] - t[2]));
            let cov = nalgebra::Matrix3::from_row_slice(c);
            sum += e.dot(&(cov.try_inverse().unwrap() * e));
            count += 1;
            sq += e.xy().norm_squared();
            sq_dr += (d[0] - t[0]).powi(2) + (d[1] - t[1]).powi(2);
        }
        better += usize::from(sq < sq_dr);
    }
    // The mean NEES of N = runs x poses draws (correlated along a run, so the band is
    // that of the runs' count, 3 dof each): two-sided 99 %.
    let n = runs as f64;
    let (lo, hi) = (
        chi2_quantile(0.005, 3.0 * n).unwrap() / n,
        chi2_quantile(0.995, 3.0 * n).unwrap() / n,
    );
    let mean = sum / count as f64;
    assert!(
        mean > lo && mean < hi,
        "mean NEES {mean:.2} outside [{lo:.2}, {hi:.2}]"
    );
    assert_eq!(
        better, runs as usize,
        "smoothing must beat dead reckoning on every run"
    );
    // The walls' NEES (2 dof), the band again that of the runs' count.
    let wall_mean = wall_sum / (runs as f64 * WALLS.len() as f64);
    let (lo, hi) = (
        chi2_quantile(0.005, 2.0 * n).unwrap() / n,
        chi2_quantile(0.995, 2.0 * n).unwrap() / n,
    );
    assert!(
        wall_mean > lo && wall_mean < hi,
        "mean wall NEES {wall_mean:.2} outside [{lo:.2}, {hi:.2}]"
    );
}

#[test]
fn bad_runs_are_errors_that_name_the_input() {
    let sim = simulate(3, 1.0);
    let config = config();
    let mut map = true_map();
    map.pop();
    let run = run_of(&sim, &config, &map);
    let err = smooth_run(&run, &SmootherConfig::default())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("wall 3") && err.contains("not in the map"),
        "{err}"
    );
    let mut walls = sim.walls.clone();
    walls[5][0] = 0.5;
    let run = FilterRun {
        walls: &walls,
        map: &true_map(),
        ..run
    };
    let err = smooth_run(&run, &SmootherConfig::default())
        .unwrap_err()
        .to_string();
    assert!(err.contains("row 5"), "{err}");
    let mut poses = sim.dead_reckoning.clone();
    poses[2][1] = f64::NAN;
    let run = FilterRun {
        poses: &poses,
        walls: &sim.walls,
        ..run
    };
    assert!(smooth_run(&run, &SmootherConfig::default()).is_err());
    let run = FilterRun {
        poses: &sim.dead_reckoning,
        ..run
    };
    let zero = SmootherConfig {
        max_iterations: 0,
        ..SmootherConfig::default()
    };
    assert!(
        smooth_run(&run, &zero)
            .unwrap_err()
            .to_string()
            .contains("max_iterations")
    );
}
