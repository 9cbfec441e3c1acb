//! PL-ICP against ray-cast truth: exact recovery without noise, an honest covariance
//! (NEES over Monte Carlo runs with range noise), and no false information along a
//! featureless corridor.

use laser::scan::{Beams, ScanConfig, ScanPoints, scan_points};
use laser::sim::{Segment, cluttered_room, corridor, ray_cast};
use laser::start::{StartSearch, match_robustly};
use laser::{IcpConfig, MapIndex, Prior, match_scan};
use nalgebra::{Matrix3, Vector2, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use rperc_core::{Pose2, wrap_angle};

const MAX_RANGE: f64 = 30.0;

fn angles() -> Vec<f64> {
    (0..361)
        .map(|i| (-90.0 + 0.5 * i as f64).to_radians())
        .collect()
}

/// The scan points (laser frame) of `walls` seen from `pose`, ranges with noise.
fn scan(walls: &[Segment], pose: &Pose2, noise: f64, rng: &mut ChaCha8Rng) -> laser::ScanPoints {
    let a = angles();
    let normal = Normal::new(0.0, noise.max(1e-300)).unwrap();
    let ranges: Vec<f64> = ray_cast(walls, pose, &a, MAX_RANGE)
        .into_iter()
        .map(|r| {
            if noise > 0.0 && r < MAX_RANGE {
                r + normal.sample(rng)
            } else {
                r
            }
        })
        .collect();
    let beams = Beams {
        ranges: &ranges,
        angle_min: a[0],
        angle_increment: a[1] - a[0],
        max_range: MAX_RANGE,
    };
    scan_points(&beams, &ScanConfig::default()).unwrap()
}

/// A map made of a scan taken at `pose` (known exactly), in the world frame.
fn map_from(walls: &[Segment], pose: &Pose2, noise: f64, rng: &mut ChaCha8Rng) -> MapIndex {
    let s = scan(walls, pose, noise, rng);
    let (mut pts, mut nrm) = (Vec::new(), Vec::new());
    for (p, n) in s.points.iter().zip(&s.normals) {
        if let Some(n) = n {
            pts.push(pose.transform_point(&(*p).into()).coords);
            nrm.push(pose.rotation() * n);
        }
    }
    MapIndex::new(pts, nrm, 0.3).unwrap()
}

fn error(est: &Pose2, truth: &Pose2) -> Vector3<f64> {
    Vector3::new(
        est.x - truth.x,
        est.y - truth.y,
        wrap_angle(est.theta - truth.theta),
    )
}

fn loose_prior(mean: Pose2) -> Prior {
    Prior {
        mean,
        information: Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, 10.0)),
    }
}

/// A noise-free map of the cluttered room from one pose, and a noise-free scan from a
/// pose near it (the truth returned).
fn noise_free_room() -> (MapIndex, laser::ScanPoints, Pose2) {
    let walls = cluttered_room(12.0, 8.0);
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let map = map_from(&walls, &Pose2::new(4.0, 3.0, 0.2), 0.0, &mut rng);
    let truth = Pose2::new(4.3, 3.1, 0.25);
    let s = scan(&walls, &truth, 0.0, &mut rng);
    (map, s, truth)
}

#[test]
fn noise_free_match_recovers_the_pose() {
    let (map, s, truth) = noise_free_room();
    let start = Pose2::new(4.36, 3.05, 0.25 + 2f64.to_radians());
    let cfg = IcpConfig {
        covariance_scale: 1.0,
        ..Default::default()
    };
    let m = match_scan(&s, &map, start, &loose_prior(start), &cfg).unwrap();
    assert!(m.accepted);
    let e = error(&m.pose, &truth);
    // The loose prior pulls by at most its weight against the scan's points (worth
    // `independent_pairs` of them at most).
    assert!(
        e.x.abs() < 2e-3 && e.y.abs() < 2e-3 && e.z.abs() < 2e-4,
        "error {e:?}"
    );
}

/// Over Monte Carlo runs with 1 cm range noise in the map and the scan, the NEES of
/// the match against the truth stays below the chi-square band's top: the default
/// covariance is not overconfident.
#[test]
fn covariance_is_not_overconfident() {
    let walls = cluttered_room(12.0, 8.0);
    let scale: f64 = std::env::var("SCALE")
        .map(|v| v.parse().unwrap())
        .unwrap_or(IcpConfig::default().covariance_scale);
    let cfg = IcpConfig {
        covariance_scale: scale,
        ..Default::default()
    };
    let mut nees = Vec::new();
    for run in 0..60 {
        let mut rng = ChaCha8Rng::seed_from_u64(100 + run);
        let from = Pose2::new(2.0 + 0.03 * run as f64, 1.2, 0.1);
        let map = map_from(&walls, &from, 0.01, &mut rng);
        let truth = from.compose(&Pose2::new(0.3, 0.05, 0.05));
        let s = scan(&walls, &truth, 0.01, &mut rng);
        // The prior: the truth moved by a draw from the prior's own covariance.
        let sd = Vector3::new(0.05, 0.05, 0.02);
        let draw = |rng: &mut ChaCha8Rng, k: usize| Normal::new(0.0, sd[k]).unwrap().sample(rng);
        let mean = Pose2::new(
            truth.x + draw(&mut rng, 0),
            truth.y + draw(&mut rng, 1),
            truth.theta + draw(&mut rng, 2),
        );
        let prior = Prior {
            mean,
            information: Matrix3::from_diagonal(&sd.map(|v| 1.0 / (v * v))),
        };
        let m = match_scan(&s, &map, mean, &prior, &cfg).unwrap();
        assert!(m.accepted, "run {run}: {m:?}");
        let e = error(&m.pose, &truth);
        nees.push((e.transpose() * m.covariance.try_inverse().unwrap() * e)[(0, 0)]);
    }
    let mean = nees.iter().sum::<f64>() / nees.len() as f64;
    eprintln!("NEES mean {mean}");
    // 60 runs of 3 dof: the mean of chi2(180)/60 stays below 3.8 with 99 % probability.
    assert!(
        mean < 3.8,
        "NEES mean {mean} (3 expected for an exact covariance)"
    );
    // And the covariance is not uselessly loose either.
    assert!(mean > 0.05, "NEES mean {mean}");
}

/// Beyond `independent_pairs` paired points the scan's information is the uncapped
/// one times `independent_pairs / pairs` (the closed form), at the same pose; at or
/// under it nothing changes.
#[test]
fn information_stops_growing_beyond_the_independent_pairs() {
    let (map, s, truth) = noise_free_room();
    let with_cap = |cap: usize| {
        let cfg = IcpConfig {
            independent_pairs: cap,
            ..Default::default()
        };
        match_scan(&s, &map, truth, &loose_prior(truth), &cfg).unwrap()
    };
    let free = with_cap(usize::MAX);
    let pairs = free.inliers;
    assert!(pairs > 100, "{pairs} pairs");
    for cap in [pairs / 4, pairs / 2] {
        let m = with_cap(cap);
        assert_eq!(m.inliers, pairs);
        let expected = free.information * (cap as f64 / pairs as f64);
        let gap = (m.information - expected).norm() / expected.norm();
        assert!(gap < 1e-6, "cap {cap}: relative gap {gap}");
    }
    assert_eq!(with_cap(pairs).information, free.information);
    assert!(
        IcpConfig {
            independent_pairs: 0,
            ..Default::default()
        }
        .validate()
        .is_err()
    );
}

/// With `angle_sigma`, a point at range `r` weighs `1 / (sigma^2 + (r angle_sigma)^2)`:
/// one straight wall at `x = d` seen from the origin gives each of its points the
/// Jacobian `(1, 0, -y)` (normal `x`), so the information's `xx` entry is the sum of
/// those weights over the scan's line points (closed form, noise-free, every point
/// paired, no cap and a covariance scale of 1).
#[test]
fn far_points_weigh_less_with_the_beams_angular_noise() {
    let walls = [Segment::new(6.0, -25.0, 6.0, 25.0)];
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let origin = Pose2::identity();
    let map = map_from(&walls, &origin, 0.0, &mut rng);
    let s = scan(&walls, &origin, 0.0, &mut rng);
    for angle_sigma in [0.0, 0.002, 0.01] {
        let cfg = IcpConfig {
            angle_sigma,
            covariance_scale: 1.0,
            independent_pairs: usize::MAX,
            ..Default::default()
        };
        let m = match_scan(&s, &map, origin, &loose_prior(origin), &cfg).unwrap();
        let on_lines: Vec<_> = s
            .points
            .iter()
            .zip(&s.normals)
            .filter(|(_, n)| n.is_some())
            .collect();
        assert_eq!(m.inliers, on_lines.len());
        let var0 = cfg.sigma * cfg.sigma;
        let expected: f64 = on_lines
            .iter()
            .map(|(p, _)| 1.0 / (var0 + (p.norm() * angle_sigma).powi(2)))
            .sum();
        let got = m.information[(0, 0)];
        assert!(
            (got - expected).abs() < 1e-9 * expected,
            "{angle_sigma}: {got} vs {expected}"
        );
    }
    let bad = IcpConfig {
        angle_sigma: -0.1,
        ..Default::default()
    };
    assert!(
        bad.validate()
            .unwrap_err()
            .to_string()
            .contains("angle_sigma")
    );
}

/// ICP weighs the scan against the prior with the same capped scale as the
/// information it returns: from a tight prior, on noise-free data, the fused pose is
/// the information-weighted mean of the scan's own optimum `x_s` (matched with a
/// prior of almost no weight) and the prior's mean:
/// `x_s + (I_s + Lambda)^-1 Lambda (mu - x_s)`, with and without the cap.
#[test]
fn the_fused_pose_weighs_the_scan_by_its_capped_information() {
    let (map, s, truth) = noise_free_room();
    let lambda = Matrix3::from_diagonal(&Vector3::new(0.02, 0.02, 0.005).map(|v| 1.0 / (v * v)));
    let offset = Vector3::new(0.02, -0.01, 0.002);
    let prior = Prior {
        mean: Pose2::new(
            truth.x + offset.x,
            truth.y + offset.y,
            truth.theta + offset.z,
        ),
        information: lambda,
    };
    let faint = Prior {
        information: Matrix3::identity() * 1e-9,
        ..prior
    };
    let own = match_scan(&s, &map, prior.mean, &faint, &IcpConfig::default()).unwrap();
    let mut errors = Vec::new();
    for cap in [usize::MAX, own.inliers / 4] {
        let cfg = IcpConfig {
            independent_pairs: cap,
            ..Default::default()
        };
        let m = match_scan(&s, &map, prior.mean, &prior, &cfg).unwrap();
        let pull = error(&prior.mean, &own.pose);
        let expected = (m.information + lambda).try_inverse().unwrap() * lambda * pull;
        let e = error(&m.pose, &own.pose);
        // First order in the pull: its neglected terms are a thousandth of it.
        assert!(
            (e - expected).norm() < 1e-3 * expected.norm(),
            "cap {cap}: {e:?} against {expected:?}"
        );
        errors.push(e.norm());
    }
    // The capped scan pulls less: the fused pose lies farther from the scan's own.
    assert!(errors[1] > 1.5 * errors[0], "{errors:?}");
}

/// In a corridor along x the scan fixes y and the heading only: the match keeps the
/// prior's x and its variance, and corrects y.
#[test]
fn a_featureless_corridor_gives_no_information_along_it() {
    let walls = corridor(200.0, 3.0);
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let map = map_from(&walls, &Pose2::new(-0.5, 0.1, 0.0), 0.0, &mut rng);
    let truth = Pose2::new(0.0, 0.2, 0.02);
    let s = scan(&walls, &truth, 0.0, &mut rng);
    let prior_mean = Pose2::new(0.25, 0.27, 0.0);
    let sd = [0.3, 0.3, 0.05];
    let prior = Prior {
        mean: prior_mean,
        information: Matrix3::from_diagonal(&Vector3::new(
            1.0 / (sd[0] * sd[0]),
            1.0 / (sd[1] * sd[1]),
            1.0 / (sd[2] * sd[2]),
        )),
    };
    let m = match_scan(&s, &map, prior_mean, &prior, &IcpConfig::default()).unwrap();
    assert!(m.accepted);
    assert!(
        (m.pose.y - truth.y).abs() < 2e-3,
        "cross-corridor {}",
        m.pose.y
    );
    assert!(
        (m.pose.theta - truth.theta).abs() < 1e-3,
        "heading {}",
        m.pose.theta
    );
    // Along the corridor: the prior's x, and the prior's variance (no information).
    assert!((m.pose.x - prior_mean.x).abs() < 1e-3, "along {}", m.pose.x);
    let var_x = m.covariance[(0, 0)];
    assert!(
        (var_x / (sd[0] * sd[0]) - 1.0).abs() < 1e-3,
        "var x {var_x}"
    );
    assert!(m.covariance[(1, 1)] < 1e-2 * sd[1] * sd[1], "{m:?}");
}

#[test]
fn too_few_pairs_refuse_the_match_and_keep_the_prior() {
    let walls = cluttered_room(12.0, 8.0);
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let map = map_from(&walls, &Pose2::new(4.0, 3.0, 0.0), 0.0, &mut rng);
    // A scan from far outside the room pairs with nothing.
    let s = scan(
        &[Segment::new(100.0, -5.0, 100.0, 5.0)],
        &Pose2::new(98.0, 0.0, 0.0),
        0.0,
        &mut rng,
    );
    let prior = loose_prior(Pose2::new(4.0, 3.0, 0.0));
    let m = match_scan(&s, &map, prior.mean, &prior, &IcpConfig::default()).unwrap();
    assert!(!m.accepted);
    assert_eq!(m.pose, prior.mean);
    assert!((m.covariance - prior.information.try_inverse().unwrap()).norm() < 1e-12);
    let _ = Vector2::<f64>::zeros();
}

/// The `k`-th of eight odometry errors (x, y, theta) around a pose: 0.7 m in the
/// direction `k` eighths of a turn, and 15 degrees, inside a loose prior's three
/// sigma but beyond ICP's basin.
fn odometry_offset(k: usize) -> Vector3<f64> {
    let a = k as f64 * std::f64::consts::TAU / 8.0;
    Vector3::new(
        0.7 * a.cos(),
        0.7 * a.sin(),
        15f64.to_radians() * a.sin().signum(),
    )
}

/// The robust start's scene: the cluttered room's map seen from (4, 3, 0.2), a scan
/// at the truth (4.4, 3.2, 0.3), and a loose prior's information (0.4 m, 8 degrees).
fn loose_prior_scene() -> (MapIndex, Pose2, ScanPoints, Matrix3<f64>) {
    let walls = cluttered_room(12.0, 8.0);
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let map = map_from(&walls, &Pose2::new(4.0, 3.0, 0.2), 0.0, &mut rng);
    let truth = Pose2::new(4.4, 3.2, 0.3);
    let s = scan(&walls, &truth, 0.0, &mut rng);
    let sd = Vector3::new(0.4, 0.4, 8f64.to_radians());
    (
        map,
        truth,
        s,
        Matrix3::from_diagonal(&sd.map(|v| 1.0 / (v * v))),
    )
}

/// The robust start's settings of these tests (the front end's defaults) with the
/// given share and RMS rules.
fn start_search(share: f64, rms: f64) -> StartSearch {
    StartSearch {
        reach: 0.3,
        sigmas: 3.0,
        step: 0.1,
        starts: 4,
        share,
        rms,
    }
}

/// The robust start: where the odometry is off by 0.7 m and 15 degrees (inside the
/// prior's three sigma), ICP from the prior's mean can settle on the wrong stretch of
/// wall; with the correlative search's starts every one of eight offsets finds the
/// ray-cast truth.
#[test]
fn a_loose_prior_is_searched_before_icp() {
    let (map, truth, s, information) = loose_prior_scene();
    let search = start_search(0.5, f64::INFINITY);
    let cfg = IcpConfig::default();
    let mut plain_failed = 0;
    for k in 0..8 {
        let off = odometry_offset(k);
        let mean = Pose2::new(truth.x + off.x, truth.y + off.y, truth.theta + off.z);
        let prior = Prior { mean, information };
        let plain = match_scan(&s, &map, mean, &prior, &cfg).unwrap();
        if error(&plain.pose, &truth).xy().norm() > 0.1 {
            plain_failed += 1;
        }
        let m = match_robustly(&s, &map, &prior, &cfg, &search).unwrap();
        let e = error(&m.pose, &truth);
        // The prior still pulls (it is the odometry): by its weight against hundreds
        // of points, millimetres.
        assert!(m.accepted, "offset {k}");
        assert!(
            e.xy().norm() < 0.02 && e.z.abs() < 0.005,
            "offset {k}: error {e:?}"
        );
    }
    // The case is a real one: from some of these starts ICP alone slides along a
    // wall to a pose tens of centimetres off (three of the eight when written).
    assert!(
        plain_failed >= 2,
        "ICP alone failed from only {plain_failed} of 8"
    );
}

/// A tight prior (the usual case) is never searched: the match is ICP's from the
/// prior's mean, bit for bit.
#[test]
fn a_tight_prior_is_not_searched() {
    let walls = cluttered_room(12.0, 8.0);
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let map = map_from(&walls, &Pose2::new(4.0, 3.0, 0.2), 0.01, &mut rng);
    let truth = Pose2::new(4.3, 3.1, 0.25);
    let s = scan(&walls, &truth, 0.01, &mut rng);
    let mean = Pose2::new(4.33, 3.08, 0.26);
    let sd = Vector3::new(0.02, 0.02, 0.3f64.to_radians());
    let prior = Prior {
        mean,
        information: Matrix3::from_diagonal(&sd.map(|v| 1.0 / (v * v))),
    };
    let search = start_search(1.0, f64::INFINITY);
    let cfg = IcpConfig::default();
    let plain = match_scan(&s, &map, mean, &prior, &cfg).unwrap();
    let robust = match_robustly(&s, &map, &prior, &cfg, &search).unwrap();
    assert_eq!(plain, robust);
}

/// The front end searches as its config says: with `search_share` 0 it keeps ICP from
/// the prior's mean whenever that was accepted, with 1 it searches wherever the prior
/// is loose; each is `match_robustly` with that share, from the same map and prior.
#[test]
fn the_front_end_searches_by_its_configured_share() {
    use laser::frontend::{FrontEnd, LocalMapConfig, prior_after};
    use laser::odometry::Step;
    let walls = cluttered_room(12.0, 8.0);
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let start = Pose2::new(4.0, 3.0, 0.2);
    let first = scan(&walls, &start, 0.0, &mut rng);
    let truth = Pose2::new(4.4, 3.2, 0.3);
    let second = scan(&walls, &truth, 0.0, &mut rng);
    let sd = Vector3::new(0.4, 0.4, 8f64.to_radians());
    let mut differ = 0;
    for k in 0..8 {
        let o = odometry_offset(k);
        let off = Pose2::new(o.x, o.y, o.z);
        let step = Step {
            motion: start.between(&truth.compose(&off)),
            covariance: Matrix3::from_diagonal(&sd.map(|v| v * v)),
        };
        let prior = prior_after(&start, &step).unwrap();
        let mut found = Vec::new();
        for share in [0.0, 1.0] {
            let local = LocalMapConfig {
                search_share: share,
                ..LocalMapConfig::default()
            };
            let mut front = FrontEnd::new(start, IcpConfig::default(), local).unwrap();
            front.first(0, &first).unwrap();
            let tracked = front.track(1, &second, &step).unwrap();
            let map = map_from(&walls, &start, 0.0, &mut rng);
            let search = StartSearch {
                reach: local.search_reach,
                sigmas: 3.0,
                step: local.search_step,
                starts: local.search_starts,
                share,
                rms: local.search_rms,
            };
            let want = match_robustly(&second, &map, &prior, &IcpConfig::default(), &search);
            assert_eq!(tracked.matched, want.unwrap(), "offset {k}, share {share}");
            found.push(tracked.matched);
        }
        differ += usize::from(found[0] != found[1]);
    }
    // The case is a real one: the share decides the match from some offsets.
    assert!(differ >= 1, "the share changed no match");
}

/// The RMS rule: a match that paired enough of the scan is searched again exactly
/// when its RMS distance exceeds `rms`. With the threshold at the plain match's own
/// RMS the plain match stands; one float below it, the answer is the one the share
/// rule's search gives (with a share above any match's, 2), not the plain match.
#[test]
fn a_loose_fit_is_searched_by_its_rms() {
    let (map, truth, s, information) = loose_prior_scene();
    let cfg = IcpConfig::default();
    let mut searched = 0;
    for k in 0..8 {
        let o = odometry_offset(k);
        let mean = truth.compose(&Pose2::new(o.x, o.y, o.z));
        let prior = Prior { mean, information };
        let plain = match_scan(&s, &map, mean, &prior, &cfg).unwrap();
        if !plain.accepted {
            continue;
        }
        let at = |rms: f64| match_robustly(&s, &map, &prior, &cfg, &start_search(0.0, rms));
        assert_eq!(at(plain.rms).unwrap(), plain, "offset {k}");
        let by_share = match_robustly(&s, &map, &prior, &cfg, &start_search(2.0, f64::INFINITY));
        let below = at(plain.rms.next_down()).unwrap();
        assert_eq!(below, by_share.unwrap(), "offset {k}");
        searched += usize::from(below != plain);
    }
    assert!(searched >= 1, "the RMS rule changed no match");
}

/// Range noise must not turn the scan: along a straight corridor, matching a noisy
/// scan to a noisy map from the pose one metre back, started at the truth, gives
/// heading errors that average to zero. Thinning that kept a reading by its own gap
/// to the last kept one chose readings by their noise, and the kept points of each
/// wall leant off it by a slant-dependent bias, and every match turned the same way.
#[test]
fn range_noise_leaves_no_heading_bias_along_a_corridor() {
    let walls = corridor(400.0, 2.4);
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let sd = Vector3::new(0.05, 0.05, 1f64.to_radians());
    let information = Matrix3::from_diagonal(&sd.map(|v| 1.0 / (v * v)));
    let trials = 200;
    let mut errors = Vec::with_capacity(trials);
    for k in 0..trials {
        let before = Pose2::new(-150.0 + k as f64, 0.3, 0.0);
        let truth = Pose2::new(before.x + 1.0, 0.3, 0.0);
        let map = map_from(&walls, &before, 0.01, &mut rng);
        let s = scan(&walls, &truth, 0.01, &mut rng);
        let prior = Prior {
            mean: truth,
            information,
        };
        let m = match_scan(&s, &map, truth, &prior, &IcpConfig::default()).unwrap();
        assert!(m.accepted, "trial {k}");
        errors.push(error(&m.pose, &truth).z);
    }
    let n = trials as f64;
    let mean = errors.iter().sum::<f64>() / n;
    let sd_mean = (errors.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (n - 1.0) / n).sqrt();
    // Four standard errors: a true zero mean fails one run in about 16,000.
    assert!(
        mean.abs() < 4.0 * sd_mean,
        "mean heading error {} deg per match, standard error {} deg",
        mean.to_degrees(),
        sd_mean.to_degrees()
    );
}
