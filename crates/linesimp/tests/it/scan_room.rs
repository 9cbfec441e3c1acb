//! Wall extraction against analytic scans: a ray caster written here simulates a
//! rectangular room with a box in it, seen from a known pose, and the walls it hits
//! are the oracle. Noise-free scans must give the walls to round-off; noisy scans
//! must give them within their predicted covariance, and that covariance must be
//! consistent (normalised estimation error squared ~ chi-square with 2 dof).

use std::f64::consts::PI;

use linesimp::{LineExtractor, ScanParams, WallSegment};
use nalgebra::{Matrix2, Point2, SymmetricEigen, Vector2};
use proptest::prelude::*;
use rand::{SeedableRng, rngs::StdRng};
use rand_distr::{Distribution, Normal};

/// A 10 m x 6 m room with a 1 m x 1 m box; world frame, segments `(a, b)`.
fn room() -> Vec<(Point2<f64>, Point2<f64>)> {
    let p = Point2::new;
    vec![
        (p(0.0, 0.0), p(10.0, 0.0)),
        (p(10.0, 0.0), p(10.0, 6.0)),
        (p(10.0, 6.0), p(0.0, 6.0)),
        (p(0.0, 6.0), p(0.0, 0.0)),
        (p(6.0, 1.5), p(7.0, 1.5)),
        (p(7.0, 1.5), p(7.0, 2.5)),
        (p(7.0, 2.5), p(6.0, 2.5)),
        (p(6.0, 2.5), p(6.0, 1.5)),
    ]
}

/// One simulated scan: readings, nominal bearings, and which wall each beam hit.
struct Scan {
    ranges: Vec<f64>,
    angles: Vec<f64>,
    wall: Vec<Option<usize>>,
}

const MAX_RANGE: f64 = 30.0;

/// `n` beams over 180 degrees from `pose = (x, y, theta)`. Each beam leaves along its
/// nominal bearing plus `bearing_noise[k]` (the scanner reports the nominal one), and
/// `range_noise[k]` is added to its range. Beams that hit nothing, or nothing closer
/// than `MAX_RANGE`, read `MAX_RANGE`, as real scanners do.
fn ray_cast(
    walls: &[(Point2<f64>, Point2<f64>)],
    pose: (f64, f64, f64),
    n: usize,
    mut noise: impl FnMut() -> (f64, f64),
) -> Scan {
    let origin = Point2::new(pose.0, pose.1);
    let mut scan = Scan {
        ranges: Vec::with_capacity(n),
        angles: Vec::with_capacity(n),
        wall: Vec::with_capacity(n),
    };
    for k in 0..n {
        let phi = -PI / 2.0 + PI * k as f64 / (n - 1) as f64;
        let (dr, dphi) = noise();
        let heading = pose.2 + phi + dphi;
        let d = Vector2::new(heading.cos(), heading.sin());
        let mut best = (f64::INFINITY, None);
        for (id, (a, b)) in walls.iter().enumerate() {
            // origin + t d = a + s (b - a), by Cramer's rule.
            let e = b - a;
            let w = a - origin;
            let det = d.x * e.y - d.y * e.x;
            if det.abs() < 1e-15 {
                continue;
            }
            let t = (w.x * e.y - w.y * e.x) / det;
            let s = (w.x * d.y - w.y * d.x) / det;
            if t > 0.0 && (0.0..=1.0).contains(&s) && t < best.0 {
                best = (t, Some(id));
            }
        }
        let (range, wall) = if best.0 < MAX_RANGE {
            (best.0 + dr, best.1)
        } else {
            (MAX_RANGE, None)
        };
        scan.ranges.push(range);
        scan.angles.push(phi);
        scan.wall.push(wall);
    }
    scan
}

/// Hessian form `(rho, alpha)` of a world segment's line in the sensor frame.
fn sensor_line(seg: &(Point2<f64>, Point2<f64>), pose: (f64, f64, f64)) -> (f64, f64) {
    let (s, c) = pose.2.sin_cos();
    let to_sensor = |p: &Point2<f64>| {
        let v = p - Point2::new(pose.0, pose.1);
        Vector2::new(c * v.x + s * v.y, -s * v.x + c * v.y)
    };
    let (a, b) = (to_sensor(&seg.0), to_sensor(&seg.1));
    let t = (b - a).normalize();
    let mut n = Vector2::new(-t.y, t.x);
    let mut rho = n.dot(&a);
    if rho < 0.0 {
        n = -n;
        rho = -rho;
    }
    (rho, n.y.atan2(n.x))
}

fn angle_diff(a: f64, b: f64) -> f64 {
    (a - b + PI).rem_euclid(2.0 * PI) - PI
}

/// A wall the extractor must find: a maximal run of consecutive beams on one true
/// wall, long enough, with enough beams, and seen at an incidence well above the
/// breakpoint detector's lambda (at grazing incidence the detector splits by design).
struct Expected {
    wall: usize,
    beams: std::ops::Range<usize>,
    rho: f64,
    alpha: f64,
}

fn expected_walls(
    scan: &Scan,
    walls: &[(Point2<f64>, Point2<f64>)],
    pose: (f64, f64, f64),
    params: &ScanParams,
) -> Vec<Expected> {
    let mut out = Vec::new();
    let mut k = 0;
    while k < scan.wall.len() {
        let Some(id) = scan.wall[k] else {
            k += 1;
            continue;
        };
        let start = k;
        while k < scan.wall.len() && scan.wall[k] == Some(id) {
            k += 1;
        }
        let (a, b) = walls[id];
        let along = (b - a).normalize();
        let point = |j: usize| {
            let h = pose.2 + scan.angles[j];
            Vector2::new(h.cos(), h.sin()) * scan.ranges[j]
        };
        let grazing = (start..k).any(|j| {
            let h = pose.2 + scan.angles[j];
            let sin_incidence = (h.cos() * along.y - h.sin() * along.x).abs();
            sin_incidence < (2.0 * params.breakpoint_lambda).sin()
        });
        let length = (point(k - 1) - point(start)).norm();
        if k - start >= 2 * params.min_points && length >= 2.0 * params.min_length && !grazing {
            let (rho, alpha) = sensor_line(&walls[id], pose);
            out.push(Expected {
                wall: id,
                beams: start..k,
                rho,
                alpha,
            });
        }
    }
    out
}

/// The extracted wall that shares the most readings with `e`, if any.
fn best_match<'a>(found: &'a [WallSegment], e: &Expected) -> Option<&'a WallSegment> {
    found
        .iter()
        .map(|w| (w, w.indices.iter().filter(|k| e.beams.contains(k)).count()))
        .filter(|&(_, shared)| shared > 0)
        .max_by_key(|&(_, shared)| shared)
        .map(|(w, _)| w)
}

/// Normalised estimation error squared of a wall against the true line.
fn nees(w: &WallSegment, e: &Expected) -> f64 {
    let err = Vector2::new(w.rho - e.rho, angle_diff(w.alpha, e.alpha));
    let inv = w.cov.try_inverse().expect("regular covariance");
    err.dot(&(inv * err))
}

const POSES: [(f64, f64, f64); 3] = [(3.0, 2.0, 0.2), (8.5, 4.5, -2.0), (2.0, 4.0, -0.6)];

#[test]
fn noise_free_scans_recover_every_visible_wall_to_round_off() {
    let walls = room();
    for beams in [180, 361] {
        for pose in POSES {
            let scan = ray_cast(&walls, pose, beams, || (0.0, 0.0));
            let params = ScanParams {
                max_range: MAX_RANGE,
                ..ScanParams::default()
            };
            let found = LineExtractor::new(params)
                .extract(&scan.ranges, &scan.angles)
                .unwrap();
            let expected = expected_walls(&scan, &walls, pose, &params);
            assert!(expected.len() >= 3, "pose {pose:?}: too few walls in view");
            for e in &expected {
                let w = best_match(&found, e)
                    .unwrap_or_else(|| panic!("{beams} beams, {pose:?}: wall {} missed", e.wall));
                assert!(
                    (w.rho - e.rho).abs() < 1e-9 && angle_diff(w.alpha, e.alpha).abs() < 1e-9,
                    "{beams} beams, {pose:?}, wall {}: ({}, {}) vs true ({}, {})",
                    e.wall,
                    w.rho,
                    w.alpha,
                    e.rho,
                    e.alpha
                );
                // Every reading of the run is in the wall, and nothing else is.
                let got: Vec<usize> = w.indices.clone();
                let want: Vec<usize> = e.beams.clone().collect();
                assert_eq!(got, want, "{beams} beams, {pose:?}, wall {}", e.wall);
                // End points are the first and last hit (they lie on the true line).
                let hit = |j: usize| {
                    Point2::new(
                        scan.ranges[j] * scan.angles[j].cos(),
                        scan.ranges[j] * scan.angles[j].sin(),
                    )
                };
                assert!((w.start - hit(e.beams.start)).norm() < 1e-9);
                assert!((w.end - hit(e.beams.end - 1)).norm() < 1e-9);
            }
            // No invented walls: every reading of every wall lies on the true line of
            // the wall it hit, and all of them hit the same wall.
            for w in &found {
                let id = scan.wall[w.indices[0]].expect("a wall reading hit a wall");
                assert!(w.indices.iter().all(|&k| scan.wall[k] == Some(id)));
                let (rho, alpha) = sensor_line(&walls[id], pose);
                assert!((w.rho - rho).abs() < 1e-9 && angle_diff(w.alpha, alpha).abs() < 1e-9);
            }
        }
    }
}

/// Monte Carlo: over seeded noisy scans the normalised error of every recovered wall
/// must follow chi-square with 2 dof. Its mean is 2 with standard deviation
/// 2 / sqrt(n); 5.99 is its 95 % quantile.
fn check_consistency(sigma_range: f64, sigma_bearing: f64, seed: u64) {
    let walls = room();
    let mut rng = StdRng::seed_from_u64(seed);
    let range_noise = Normal::new(0.0, sigma_range).unwrap();
    let bearing_noise = Normal::new(0.0, sigma_bearing).unwrap();
    let params = ScanParams {
        max_range: MAX_RANGE,
        sigma_range,
        sigma_bearing,
        ..ScanParams::default()
    };
    let mut extractor = LineExtractor::new(params);
    let (mut sum, mut count, mut above_95, mut missed) = (0.0, 0usize, 0usize, 0usize);
    for trial in 0..300 {
        let pose = POSES[trial % POSES.len()];
        let scan = ray_cast(&walls, pose, 180, || {
            (range_noise.sample(&mut rng), bearing_noise.sample(&mut rng))
        });
        let found = extractor.extract(&scan.ranges, &scan.angles).unwrap();
        // The expected walls come from the beams' true hits, not from the noisy scan.
        let clean = ray_cast(&walls, pose, 180, || (0.0, 0.0));
        for e in expected_walls(&clean, &walls, pose, &params) {
            let Some(w) = best_match(&found, &e) else {
                missed += 1;
                continue;
            };
            let d = nees(w, &e);
            // Tolerance derived from the noise: within the chi-square 99.9 % bound.
            if d > 13.82 {
                missed += 1;
                continue;
            }
            sum += d;
            count += 1;
            above_95 += usize::from(d > 5.991);
        }
    }
    let n = count as f64;
    let mean = sum / n;
    assert!(
        missed as f64 <= 0.01 * (n + missed as f64),
        "{missed} of {} walls missed or off by more than the 99.9 % bound",
        count + missed
    );
    assert!(
        (mean - 2.0).abs() < 4.0 * 2.0 / n.sqrt(),
        "mean NEES {mean} over {count} walls, expected 2 +- {}",
        4.0 * 2.0 / n.sqrt()
    );
    let frac = above_95 as f64 / n;
    let band = 4.0 * (0.05f64 * 0.95 / n).sqrt();
    assert!(
        (frac - 0.05).abs() < band,
        "{frac} of NEES above the 95 % quantile, expected 0.05 +- {band}"
    );
}

#[test]
fn range_noise_covariance_is_consistent() {
    check_consistency(0.01, 0.0, 7);
}

#[test]
fn range_and_bearing_noise_covariance_is_consistent() {
    check_consistency(0.005, 0.002, 11);
}

/// Independent total least squares: the normal is the eigenvector of the scatter
/// matrix with the smaller eigenvalue.
fn tls(ranges: &[f64], angles: &[f64]) -> (f64, f64) {
    let pts: Vec<Vector2<f64>> = ranges
        .iter()
        .zip(angles)
        .map(|(r, a)| Vector2::new(r * a.cos(), r * a.sin()))
        .collect();
    let c = pts.iter().sum::<Vector2<f64>>() / pts.len() as f64;
    let scatter = pts
        .iter()
        .map(|p| (p - c) * (p - c).transpose())
        .sum::<Matrix2<f64>>();
    let eig = SymmetricEigen::new(scatter);
    let k = eig.eigenvalues.imin();
    let mut n = eig.eigenvectors.column(k).into_owned();
    if n.dot(&c) < 0.0 {
        n = -n;
    }
    (n.dot(&c), n.y.atan2(n.x))
}

#[test]
fn covariance_equals_first_order_propagation_through_an_independent_fit() {
    // One wall, x cos(0.4) + y sin(0.4) = 3, seen by 50 beams with some noise so the
    // residuals are not zero. J diag(sigma^2) J^T with J by central differences of
    // the eigenvector fit above.
    let (rho, alpha) = (3.0, 0.4);
    let mut rng = StdRng::seed_from_u64(3);
    let noise = Normal::new(0.0, 0.02).unwrap();
    let angles: Vec<f64> = (0..50).map(|k| -0.3 + 0.015 * k as f64).collect();
    let ranges: Vec<f64> = angles
        .iter()
        .map(|a| rho / (a - alpha).cos() + noise.sample(&mut rng))
        .collect();
    let (sr, sb) = (0.02, 0.004);
    let params = ScanParams {
        sigma_range: sr,
        sigma_bearing: sb,
        split_epsilon: 1.0,
        model_error: false, // the propagation alone; the floor is tested on its own
        ..ScanParams::default()
    };
    let walls = linesimp::extract_lines(&ranges, &angles, &params).unwrap();
    assert_eq!(walls.len(), 1);
    let w = &walls[0];
    let base = tls(&ranges, &angles);
    assert!((w.rho - base.0).abs() < 1e-12 && angle_diff(w.alpha, base.1).abs() < 1e-12);
    let h = 1e-6;
    let mut cov = Matrix2::zeros();
    for k in 0..50 {
        for (which, sigma) in [(0, sr), (1, sb)] {
            let shifted = |delta: f64| {
                let (mut r, mut a) = (ranges.clone(), angles.clone());
                if which == 0 {
                    r[k] += delta;
                } else {
                    a[k] += delta;
                }
                tls(&r, &a)
            };
            let (plus, minus) = (shifted(h), shifted(-h));
            let j = Vector2::new(
                (plus.0 - minus.0) / (2.0 * h),
                angle_diff(plus.1, minus.1) / (2.0 * h),
            );
            cov += j * j.transpose() * sigma * sigma;
        }
    }
    let rel = (w.cov - cov).norm() / cov.norm();
    assert!(
        rel < 1e-5,
        "extractor {} vs finite differences {}",
        w.cov,
        cov
    );
}

#[test]
fn sample_covariance_of_a_single_wall_matches_the_prediction() {
    // 2000 seeded scans of one wall: the spread of the fitted (rho, alpha) must match
    // the predicted covariance. A variance estimated from n samples has relative
    // standard deviation sqrt(2 / n) (3.2 % here); allow 4 of them. A split_epsilon
    // far above the noise keeps iterative end-point fit from splitting the wall, so
    // this measures the covariance alone, not the segmentation (with the default
    // 0.05 m, 12 of these 2000 scans come back as two walls).
    let (rho, alpha) = (2.5, -0.3);
    let angles: Vec<f64> = (0..91).map(|k| (k as f64 - 45.0).to_radians()).collect();
    let (sr, sb) = (0.01, 0.003);
    let params = ScanParams {
        sigma_range: sr,
        sigma_bearing: sb,
        split_epsilon: 1.0,
        ..ScanParams::default()
    };
    let mut extractor = LineExtractor::new(params);
    let mut rng = StdRng::seed_from_u64(5);
    let (nr, nb) = (Normal::new(0.0, sr).unwrap(), Normal::new(0.0, sb).unwrap());
    let trials = 2000;
    let mut errors = Vec::with_capacity(trials);
    let mut predicted = Matrix2::zeros();
    let mut ranges = vec![0.0; angles.len()];
    for _ in 0..trials {
        for (r, a) in ranges.iter_mut().zip(&angles) {
            // The beam really leaves at a + db; the scanner reports a.
            let db = nb.sample(&mut rng);
            *r = rho / (a + db - alpha).cos() + nr.sample(&mut rng);
        }
        let walls = extractor.extract(&ranges, &angles).unwrap();
        assert_eq!(walls.len(), 1);
        errors.push(Vector2::new(
            walls[0].rho - rho,
            angle_diff(walls[0].alpha, alpha),
        ));
        predicted += walls[0].cov / trials as f64;
    }
    let mean = errors.iter().sum::<Vector2<f64>>() / trials as f64;
    let sample = errors
        .iter()
        .map(|e| (e - mean) * (e - mean).transpose())
        .sum::<Matrix2<f64>>()
        / (trials - 1) as f64;
    let band = 4.0 * (2.0 / trials as f64).sqrt();
    for i in 0..2 {
        let ratio = sample[(i, i)] / predicted[(i, i)];
        assert!(
            (ratio - 1.0).abs() < band,
            "variance {i}: sample {} vs predicted {}",
            sample[(i, i)],
            predicted[(i, i)]
        );
    }
    // The correlation too: its estimate has standard deviation (1 - c^2) / sqrt(n).
    let corr = |m: &Matrix2<f64>| m[(0, 1)] / (m[(0, 0)] * m[(1, 1)]).sqrt();
    let c = corr(&predicted);
    assert!(
        (corr(&sample) - c).abs() < 4.0 * (1.0 - c * c) / (trials as f64).sqrt(),
        "correlation: sample {} vs predicted {c}",
        corr(&sample)
    );
    // And no bias beyond the standard error of the mean.
    for i in 0..2 {
        assert!(mean[i].abs() < 4.0 * (predicted[(i, i)] / trials as f64).sqrt());
    }
}

/// Readings of an extracted wall that hit a true wall other than the one most of
/// them hit, and that wall.
fn strays(w: &WallSegment, scan: &Scan) -> (usize, Vec<usize>) {
    let mut counts = std::collections::BTreeMap::new();
    for &k in &w.indices {
        *counts.entry(scan.wall[k]).or_insert(0usize) += 1;
    }
    let (&majority, _) = counts
        .iter()
        .max_by_key(|&(_, &c)| c)
        .expect("a wall has readings");
    let majority = majority.expect("only valid readings are fitted");
    let positions = (0..w.indices.len())
        .filter(|&i| scan.wall[w.indices[i]] != Some(majority))
        .collect();
    (majority, positions)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    /// From any pose inside the room, facing anywhere, noise free:
    /// - each wall's (rho, alpha) is the total-least-squares line of its readings
    ///   (independent eigenvector fit);
    /// - its readings are consecutive valid readings;
    /// - they hit one true wall, except possibly a few at either end: a reading
    ///   just round a corner that is within split_epsilon of the line cannot be told
    ///   apart by iterative end-point fit (about 1 % of walls; such a "corner stray"
    ///   moves the fit by up to a few cm on short walls);
    /// - a wall without corner strays is its true wall's line to round-off;
    /// - every clearly visible wall is found.
    #[test]
    fn any_pose_noise_free(
        x in 0.5..9.5f64,
        y in 0.5..5.5f64,
        theta in -PI..PI,
        beams in 90usize..400,
    ) {
        let walls = room();
        // Not inside the box.
        prop_assume!(!((5.9..7.1).contains(&x) && (1.4..2.6).contains(&y)));
        let pose = (x, y, theta);
        let scan = ray_cast(&walls, pose, beams, || (0.0, 0.0));
        let params = ScanParams { max_range: MAX_RANGE, ..ScanParams::default() };
        let found = LineExtractor::new(params).extract(&scan.ranges, &scan.angles).unwrap();
        for w in &found {
            let ranges: Vec<f64> = w.indices.iter().map(|&k| scan.ranges[k]).collect();
            let angles: Vec<f64> = w.indices.iter().map(|&k| scan.angles[k]).collect();
            let (rho, alpha) = tls(&ranges, &angles);
            prop_assert!((w.rho - rho).abs() < 1e-9 * (1.0 + rho));
            prop_assert!(angle_diff(w.alpha, alpha).abs() < 1e-9);
            let (first, last) = (w.indices[0], w.indices[w.indices.len() - 1]);
            prop_assert_eq!(w.indices.len(), (first..=last).filter(|&k| scan.wall[k].is_some()).count());
            let (id, stray) = strays(w, &scan);
            let n = w.indices.len();
            let at_ends = stray.iter().all(|&i| i < stray.len() || i + stray.len() >= n);
            prop_assert!(at_ends, "stray readings inside a wall: {:?} of {}", stray, n);
            if stray.is_empty() {
                let (rho, alpha) = sensor_line(&walls[id], pose);
                prop_assert!((w.rho - rho).abs() < 1e-9 && angle_diff(w.alpha, alpha).abs() < 1e-9);
            }
        }
        for e in expected_walls(&scan, &walls, pose, &params) {
            prop_assert!(best_match(&found, &e).is_some(), "wall {} missed", e.wall);
        }
    }
}
