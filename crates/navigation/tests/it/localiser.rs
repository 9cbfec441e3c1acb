//! The pose filter of the visual memory against independent oracles: its observation
//! Jacobians against finite differences, its covariance against the chi-square
//! distribution of the NEES over Monte Carlo runs of its own noise model (the robot
//! localised against a fixed mosaic, and the mosaic built while mapping), and its
//! gate against a planted outlier.

use nalgebra::{Matrix3, Vector3};
use navigation::memory::{ImageScale, LocaliserParams, ModelSighting, PoseFilter, observe};
use rperc_core::rng::{normal, stream};
use rperc_core::{Pose2, chi2_quantile, nees_band, wrap_angle};

const SCALE: ImageScale = ImageScale {
    metres_per_pixel: 0.01,
    principal: [160.0, 120.0],
};

/// Models around the robot's path, in the mosaic frame (x, y, theta).
const MODELS: [[f64; 3]; 4] = [
    [0.6, 0.3, 0.4],
    [0.2, -0.5, -1.0],
    [1.1, -0.2, 2.0],
    [0.9, 0.6, 0.0],
];

fn pose(p: [f64; 3]) -> Pose2 {
    Pose2::new(p[0], p[1], p[2])
}

#[test]
fn observation_jacobians_match_finite_differences() {
    let robot = Pose2::new(0.3, -0.2, 0.7);
    let model = Pose2::new(1.1, 0.4, -2.5);
    let (_, h_robot, h_model) = observe(&SCALE, &robot, &model);
    let eps = 1e-6;
    for i in 0..3 {
        let mut d = [0.0; 3];
        d[i] = eps;
        let shift = |p: &Pose2| Pose2::new(p.x + d[0], p.y + d[1], p.theta + d[2]);
        let numeric = |a: Vector3<f64>, b: Vector3<f64>| {
            let mut v = (a - b) / (2.0 * eps);
            v[2] = wrap_angle(a[2] - b[2]) / (2.0 * eps);
            v
        };
        let back = |p: &Pose2| Pose2::new(p.x - d[0], p.y - d[1], p.theta - d[2]);
        let dr = numeric(
            observe(&SCALE, &shift(&robot), &model).0,
            observe(&SCALE, &back(&robot), &model).0,
        );
        let dm = numeric(
            observe(&SCALE, &robot, &shift(&model)).0,
            observe(&SCALE, &robot, &back(&model)).0,
        );
        for r in 0..3 {
            assert!((dr[r] - h_robot[(r, i)]).abs() < 1e-5, "robot d{r}/d{i}");
            assert!((dm[r] - h_model[(r, i)]).abs() < 1e-5, "model d{r}/d{i}");
        }
    }
}

/// A tracker state of `model` seen from `robot` with the filter's own noise.
fn sighting<R: rand::Rng>(
    id: usize,
    robot: &Pose2,
    model: &Pose2,
    p: &LocaliserParams,
    rng: &mut R,
) -> ModelSighting {
    let rotation_sigma = p.rotation_pixel_sigma / 20.0;
    let (z, _, _) = observe(&SCALE, robot, model);
    ModelSighting {
        id,
        model_in_mosaic: *model,
        model_covariance: Matrix3::zeros(),
        state: [
            z[0] + p.pixel_sigma * normal(rng),
            z[1] + p.pixel_sigma * normal(rng),
            z[2] + rotation_sigma * normal(rng),
            1.0,
        ],
        rotation_sigma,
    }
}

/// The odometry's reading of a true step, with the filter's own noise model.
fn odometry<R: rand::Rng>(step: &Pose2, p: &LocaliserParams, rng: &mut R) -> Pose2 {
    let [k_d, k_t, floor_d, floor_t] = p.odometry_sigma;
    let sd = k_d * step.x.hypot(step.y) + floor_d;
    let st = k_t * step.theta.abs() + floor_t;
    Pose2::new(
        step.x + sd * normal(rng),
        step.y + sd * normal(rng),
        step.theta + st * normal(rng),
    )
}

fn nees(e: Vector3<f64>, cov: &Matrix3<f64>) -> f64 {
    (e.transpose() * cov.try_inverse().expect("invertible") * e)[0]
}

fn error(estimate: &Pose2, truth: &Pose2) -> Vector3<f64> {
    Vector3::new(
        estimate.x - truth.x,
        estimate.y - truth.y,
        wrap_angle(estimate.theta - truth.theta),
    )
}

/// One run: the robot drives an arc past the fixed models, each frame predicted
/// by a noisy odometry and corrected by two of them; the NEES of the last frame.
fn localisation_run(seed: u64, p: &LocaliserParams) -> f64 {
    let mut rng = stream(seed, 1);
    drive_arc(&mut rng, p, PoseFilter::new)
}

/// The robot drives an arc past the models from a start off by 5 cm and 0.05 rad
/// (1 sigma of the filter's start, which `make` builds), each frame predicted by a
/// noisy odometry and corrected by two of the models; the NEES of the last frame
/// against the truth.
fn drive_arc<R: rand::Rng>(
    rng: &mut R,
    p: &LocaliserParams,
    make: impl FnOnce(Pose2, Matrix3<f64>) -> PoseFilter,
) -> f64 {
    let mut truth = Pose2::new(0.0, 0.0, 0.1);
    let guess = Matrix3::from_diagonal_element(0.05f64.powi(2));
    let start = Pose2::new(
        truth.x + 0.05 * normal(rng),
        truth.y + 0.05 * normal(rng),
        truth.theta + 0.05 * normal(rng),
    );
    let mut filter = make(start, guess);
    let step = Pose2::new(0.03, 0.0, 0.015);
    for k in 0..40 {
        truth = truth.compose(&step);
        filter.predict(&odometry(&step, p, rng), p, 1.0);
        for id in [k % 4, (k + 1) % 4] {
            let s = sighting(id, &truth, &pose(MODELS[id]), p, rng);
            assert!(filter.update(&SCALE, &s, p.pixel_sigma));
        }
    }
    nees(error(&filter.pose(), &truth), &filter.pose_covariance())
}

#[test]
fn the_localisation_covariance_is_honest_over_monte_carlo_runs() {
    // The odometry model is applied to the true step in the simulation and to the
    // measured one in the filter; the difference is second order.
    let p = LocaliserParams::default();
    let runs = 200;
    let mean = (0..runs as u64)
        .map(|s| localisation_run(s, &p))
        .sum::<f64>()
        / runs as f64;
    let (lo, hi) = nees_band(3, runs, 0.99).unwrap();
    assert!(
        lo <= mean && mean <= hi,
        "mean NEES {mean} outside [{lo}, {hi}]"
    );
}

/// One mapping run: model 0 (exact) is in view at the start, models 1-3 are placed
/// by eq. 3 as the robot reaches them and corrected by every later sighting; the
/// NEES of each placed model at the end.
fn mapping_run(seed: u64, p: &LocaliserParams) -> Vec<f64> {
    let mut rng = stream(seed, 2);
    let mut truth = Pose2::new(0.0, 0.0, 0.0);
    let mut filter = PoseFilter::new(truth, Matrix3::from_diagonal_element(1e-12));
    let step = Pose2::new(0.03, 0.0, 0.01);
    let models: Vec<Pose2> = MODELS.iter().map(|m| pose(*m)).collect();
    let mut placed = vec![0];
    for k in 1..60 {
        truth = truth.compose(&step);
        filter.predict(&odometry(&step, p, &mut rng), p, 1.0);
        if k % 15 == 0 && placed.len() < models.len() {
            let id = placed.len();
            // The model's frame is its window at creation: C T_i is exact then.
            let c_t_i = truth.between(&models[id]);
            filter.add_model(id, &c_t_i);
            placed.push(id);
            continue;
        }
        for &id in placed.iter().rev().take(2) {
            let s = sighting(id, &truth, &models[id], p, &mut rng);
            assert!(filter.update(&SCALE, &s, p.pixel_sigma));
        }
    }
    // Each placed model is compared with its own frame: the true model pose (its
    // frame at creation) expressed in the mosaic frame of model 0.
    (1..models.len())
        .map(|id| {
            let (m, cov) = filter.model(id).expect("mapped");
            nees(error(&m, &models[id]), &cov)
        })
        .collect()
}

#[test]
fn mapped_models_carry_honest_covariances() {
    let p = LocaliserParams::default();
    let runs = 150;
    let all: Vec<Vec<f64>> = (0..runs as u64).map(|s| mapping_run(s, &p)).collect();
    let (lo, hi) = nees_band(3, runs, 0.99).unwrap();
    for id in 0..all[0].len() {
        let mean = all.iter().map(|r| r[id]).sum::<f64>() / runs as f64;
        assert!(
            lo <= mean && mean <= hi,
            "model {}: mean NEES {mean} outside [{lo}, {hi}]",
            id + 1
        );
    }
}

#[test]
fn a_sighting_a_pattern_away_is_refused_by_the_gate() {
    let p = LocaliserParams::default();
    let mut rng = stream(7, 3);
    let truth = Pose2::new(0.2, 0.1, 0.3);
    let cov = Matrix3::from_diagonal(&Vector3::new(1e-4, 1e-4, 1e-4));
    let filter = PoseFilter::new(truth, cov);
    let gate = chi2_quantile(p.gate_probability, 3.0).unwrap();
    let model = pose(MODELS[0]);
    let good = sighting(0, &truth, &model, &p, &mut rng);
    assert!(filter.nis(&SCALE, &good, p.pixel_sigma).unwrap() < gate);
    // A tracker locked on a repeat of the pattern 12 pixels away.
    let mut bad = good;
    bad.state[0] += 12.0;
    assert!(filter.nis(&SCALE, &bad, p.pixel_sigma).unwrap() > gate);
}

#[test]
fn a_stored_mosaics_shared_error_is_not_averaged_away() {
    // Two models that share one position error of sigma (fully correlated): the robot
    // located from both is no better than sigma, where two independent models would
    // give sigma / sqrt(2) (closed forms, with near-exact sightings).
    let sigma2 = 0.02f64.powi(2);
    let models = [(1, pose(MODELS[0])), (2, pose(MODELS[1]))];
    let mut joint = nalgebra::DMatrix::zeros(6, 6);
    for (r, c) in [
        (0, 0),
        (0, 3),
        (3, 0),
        (3, 3),
        (1, 1),
        (1, 4),
        (4, 1),
        (4, 4),
    ] {
        joint[(r, c)] = sigma2;
    }
    for k in [2, 5] {
        joint[(k, k)] = 1e-12;
    }
    let robot = Pose2::new(0.0, 0.0, 0.0);
    let wide = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, 1e-12));
    let pixel = 1e-4;
    let sighting = |id: usize, m: &Pose2, cov: Matrix3<f64>| {
        let (z, _, _) = observe(&SCALE, &robot, m);
        ModelSighting {
            id,
            model_in_mosaic: *m,
            model_covariance: cov,
            state: [z[0], z[1], z[2], 1.0],
            rotation_sigma: 1e-6,
        }
    };
    let mut shared = PoseFilter::with_map(robot, wide, &models, &joint);
    let mut independent = PoseFilter::new(robot, wide);
    let marginal = Matrix3::from_diagonal(&Vector3::new(sigma2, sigma2, 1e-12));
    for (id, m) in models {
        assert!(shared.update(&SCALE, &sighting(id, &m, Matrix3::zeros()), pixel));
        assert!(independent.update(&SCALE, &sighting(id, &m, marginal), pixel));
    }
    let (s, i) = (shared.pose_covariance(), independent.pose_covariance());
    assert!(
        (s[(0, 0)] / sigma2 - 1.0).abs() < 1e-3,
        "shared {}",
        s[(0, 0)] / sigma2
    );
    assert!(
        (i[(0, 0)] / sigma2 - 0.5).abs() < 1e-3,
        "independent {}",
        i[(0, 0)] / sigma2
    );
    let (ids, map) = shared.map();
    assert_eq!(ids, vec![1, 2]);
    assert!(
        (map[(0, 3)] - map[(0, 0)]).abs() < 1e-9 * sigma2,
        "still one shared error"
    );
}

/// The covariance after one sighting by the information form, `(P^-1 + H^T R^-1
/// H)^-1`: an oracle independent of the gain the filter computes.
fn information_form(prior: &Matrix3<f64>, h: &Matrix3<f64>, noise: &Matrix3<f64>) -> Matrix3<f64> {
    let info = prior.try_inverse().unwrap() + h.transpose() * noise.try_inverse().unwrap() * h;
    info.try_inverse().unwrap()
}

#[test]
fn the_update_equals_the_information_form_and_stays_positive_definite() {
    // From a prior of metres and radians to sightings of micro-pixels: the plain
    // `P - K S K^T` cancels almost everything there; the Joseph form keeps every
    // variance positive and equal to the information form's.
    let robot = Pose2::new(0.3, -0.2, 0.7);
    let model = pose(MODELS[2]);
    for (prior_sigma, pixel, rotation) in [
        (0.1f64, 0.3f64, 0.05f64),
        (10.0, 1e-6, 1e-7),
        (1e-3, 5.0, 1.0),
    ] {
        let prior = Matrix3::from_diagonal(&Vector3::new(
            prior_sigma * prior_sigma,
            (2.0 * prior_sigma).powi(2),
            prior_sigma * prior_sigma,
        ));
        let mut filter = PoseFilter::new(robot, prior);
        let (z, h, _) = observe(&SCALE, &robot, &model);
        let s = ModelSighting {
            id: 0,
            model_in_mosaic: model,
            model_covariance: Matrix3::zeros(),
            state: [z[0], z[1], z[2], 1.0],
            rotation_sigma: rotation,
        };
        assert!(filter.update(&SCALE, &s, pixel));
        let noise = Matrix3::from_diagonal(&Vector3::new(
            pixel * pixel,
            pixel * pixel,
            rotation * rotation,
        ));
        let oracle = information_form(&prior, &h, &noise);
        let got = filter.pose_covariance();
        for r in 0..3 {
            assert!(got[(r, r)] > 0.0, "variance {r} {}", got[(r, r)]);
            for c in 0..3 {
                let tol = 1e-6 * (oracle[(r, r)] * oracle[(c, c)]).sqrt();
                assert!(
                    (got[(r, c)] - oracle[(r, c)]).abs() <= tol,
                    "prior {prior_sigma}: P[{r}{c}] {} vs {}",
                    got[(r, c)],
                    oracle[(r, c)]
                );
            }
        }
        assert!(got.symmetric_eigenvalues().min() > 0.0);
    }
}

/// A stored mosaic of the four models with independent errors of `sigma` metres
/// (and a tenth of that in radians) on each coordinate: its joint covariance.
fn stored_map(sigma: f64) -> nalgebra::DMatrix<f64> {
    let mut c = nalgebra::DMatrix::zeros(12, 12);
    for k in 0..4 {
        for (d, s) in [sigma, sigma, 0.1 * sigma].into_iter().enumerate() {
            c[(3 * k + d, 3 * k + d)] = s * s;
        }
    }
    c
}

/// One replay-like run against a stored mosaic whose models sit off their truth by
/// an error drawn from its covariance (one draw per run, shared by every frame):
/// the NEES of the last frame, relative to the true models.
fn stored_map_run(seed: u64, p: &LocaliserParams) -> f64 {
    let mut rng = stream(seed, 4);
    let sigma = 0.02;
    let map = stored_map(sigma);
    let stored: Vec<(usize, Pose2)> = MODELS
        .iter()
        .enumerate()
        .map(|(id, m)| {
            let s = [sigma, sigma, 0.1 * sigma].map(|s| s * normal(&mut rng));
            (id, Pose2::new(m[0] + s[0], m[1] + s[1], m[2] + s[2]))
        })
        .collect();
    drive_arc(&mut rng, p, |start, guess| {
        PoseFilter::with_map(start, guess, &stored, &map)
    })
}

#[test]
fn a_rigid_stored_mosaic_is_never_corrected_and_stays_honest() {
    // Against a stored mosaic the models are consider states (Schmidt-Kalman): a
    // sighting moves the robot alone and leaves the mosaic's means and covariance as
    // they were; the robot's covariance after the first sighting is the information
    // form's with the model's covariance counted as sighting noise.
    let p = LocaliserParams::default();
    let map = stored_map(0.02);
    let models: Vec<(usize, Pose2)> = MODELS
        .iter()
        .enumerate()
        .map(|(i, m)| (i, pose(*m)))
        .collect();
    let robot = Pose2::new(0.1, 0.05, 0.2);
    let prior = Matrix3::from_diagonal_element(0.05f64.powi(2));
    let mut filter = PoseFilter::with_map(robot, prior, &models, &map);
    let mut loose = filter.clone();
    loose.set_rigid_map(false);
    let mut rng = stream(5, 6);
    let s = sighting(
        1,
        &Pose2::new(0.12, 0.04, 0.21),
        &pose(MODELS[1]),
        &p,
        &mut rng,
    );
    assert!(filter.update(&SCALE, &s, p.pixel_sigma));
    assert!(loose.update(&SCALE, &s, p.pixel_sigma));
    let (_, h_robot, h_model) = observe(&SCALE, &robot, &pose(MODELS[1]));
    let r = Matrix3::from_diagonal(&Vector3::new(
        p.pixel_sigma.powi(2),
        p.pixel_sigma.powi(2),
        s.rotation_sigma.powi(2),
    ));
    let m = map.fixed_view::<3, 3>(3, 3).into_owned();
    let expected = information_form(&prior, &h_robot, &(r + h_model * m * h_model.transpose()));
    let got = filter.pose_covariance();
    assert!(
        (got - expected).abs().max() < 1e-9 * expected.abs().max(),
        "{got} vs {expected}"
    );
    for (id, model) in &models {
        let (mean, _) = filter.model(*id).expect("stored");
        assert_eq!(error(&mean, model), Vector3::zeros(), "model {id} moved");
    }
    assert_eq!(filter.map().1, map, "the mosaic's covariance changed");
    // Corrected as in mapping, the sighted model moves and its covariance shrinks.
    let (moved, shrunk) = loose.model(1).expect("stored");
    assert!(error(&moved, &models[1].1).norm() > 0.0 && shrunk[(0, 0)] < m[(0, 0)]);
    // Over Monte Carlo runs against mosaics drawn from their covariance, the robot's
    // NEES lies in the chi-square band.
    let runs = 200;
    let mean = (0..runs as u64).map(|s| stored_map_run(s, &p)).sum::<f64>() / runs as f64;
    let (lo, hi) = nees_band(3, runs, 0.99).unwrap();
    assert!(
        lo <= mean && mean <= hi,
        "mean NEES {mean} outside [{lo}, {hi}]"
    );
}

/// The prediction's Jacobian with respect to the odometry's scale errors, against
/// central finite differences: with no per-step noise and a pose known exactly, the
/// predicted pose covariance is `J Sigma_k J^T` alone, and its cross-covariance with
/// the scales is `J Sigma_k`.
#[test]
fn prediction_through_the_scales_matches_finite_differences() {
    let p = LocaliserParams {
        odometry_sigma: [0.0; 4],
        ..LocaliserParams::default()
    };
    let start = Pose2::new(0.4, -0.3, 0.9);
    let motion = Pose2::new(0.05, 0.01, 0.04);
    let sigma = [0.05, 0.03];
    let mut filter = PoseFilter::new(start, Matrix3::zeros());
    filter.set_odometry_scale_sigma(sigma);
    filter.predict(&motion, &p, 1.0);
    let moved = |k_d: f64, k_t: f64| {
        start.compose(&Pose2::new(
            motion.x * (1.0 + k_d),
            motion.y * (1.0 + k_d),
            motion.theta * (1.0 + k_t),
        ))
    };
    let eps = 1e-6;
    let mut j = nalgebra::Matrix3x2::zeros();
    for (c, (a, b)) in [
        (moved(eps, 0.0), moved(-eps, 0.0)),
        (moved(0.0, eps), moved(0.0, -eps)),
    ]
    .into_iter()
    .enumerate()
    {
        let d = Vector3::new(a.x - b.x, a.y - b.y, wrap_angle(a.theta - b.theta)) / (2.0 * eps);
        j.set_column(c, &d);
    }
    let prior = nalgebra::Matrix2::new(sigma[0].powi(2), 0.0, 0.0, sigma[1].powi(2));
    let expected = j * prior * j.transpose();
    assert!((filter.pose_covariance() - expected).amax() < 1e-12);
    assert!((filter.pose().to_vector() - moved(0.0, 0.0).to_vector()).amax() < 1e-15);
    let (scales, cov) = filter.odometry_scales();
    assert_eq!(scales, [0.0, 0.0]);
    assert!((cov - prior).amax() < 1e-18);
}

/// A run along an arc whose odometry reads every step scaled by a constant drawn
/// from the filter's prior (an uncalibrated wheel odometry, here with no per-step
/// noise at all) and corrected by one model of no rotation lever every 10 frames:
/// the final NEES, with the scales estimated (`with_scales`) or left out.
fn scaled_odometry_run(seed: u64, with_scales: bool) -> f64 {
    let mut rng = stream(seed, 3);
    let p = LocaliserParams {
        odometry_scale_sigma: [0.05, 0.05],
        ..LocaliserParams::default()
    };
    let [s_d, s_t] = p.odometry_scale_sigma;
    let (k_d, k_t) = (s_d * normal(&mut rng), s_t * normal(&mut rng));
    let mut truth = Pose2::new(0.0, 0.0, 0.1);
    let mut filter = PoseFilter::new(truth, Matrix3::from_diagonal_element(1e-10));
    if with_scales {
        filter.set_odometry_scale_sigma(p.odometry_scale_sigma);
    }
    let step = Pose2::new(0.03, 0.0, 0.02);
    // The odometry reads the true step divided by (1 + k): the robot moved 1 + k
    // times the reading.
    let read = Pose2::new(step.x / (1.0 + k_d), 0.0, step.theta / (1.0 + k_t));
    for k in 1..=60 {
        truth = truth.compose(&step);
        filter.predict(&odometry(&read, &p, &mut rng), &p, 1.0);
        if k % 10 == 0 {
            let mut s = sighting(k % 4, &truth, &pose(MODELS[k % 4]), &p, &mut rng);
            s.rotation_sigma = 1.0;
            s.state[2] = observe(&SCALE, &truth, &pose(MODELS[k % 4])).0[2];
            assert!(filter.update(&SCALE, &s, p.pixel_sigma));
        }
    }
    nees(error(&filter.pose(), &truth), &filter.pose_covariance())
}

#[test]
fn a_scaled_odometry_is_honest_only_with_the_scale_states() {
    let runs = 200;
    let mean = |with: bool| {
        (0..runs as u64)
            .map(|s| scaled_odometry_run(s, with))
            .sum::<f64>()
            / runs as f64
    };
    let (lo, hi) = nees_band(3, runs, 0.99).unwrap();
    let with = mean(true);
    assert!(
        lo <= with && with <= hi,
        "with the scales: mean NEES {with} outside [{lo}, {hi}]"
    );
    let without = mean(false);
    assert!(
        without > hi,
        "without them the filter should be overconfident: {without}"
    );
}
