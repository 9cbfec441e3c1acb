//! Wall extraction on degenerate and adversarial input: empty and invalid scans, bad
//! parameters, mismatched arrays, single walls, collinear walls that must stay apart,
//! and the symmetries a correct extractor has (reversed scan order, rotated sensor,
//! reused buffers).

use std::f64::consts::PI;

use linesimp::{LineExtractor, LineSimpError, ScanParams, WallSegment, extract_lines};
use nalgebra::{Point2, Vector2};

/// `n` bearings evenly from `from` to `to` degrees.
fn bearings(n: usize, from: f64, to: f64) -> Vec<f64> {
    (0..n)
        .map(|k| (from + (to - from) * k as f64 / (n - 1) as f64).to_radians())
        .collect()
}

/// Range along `phi` to the line `x cos(alpha) + y sin(alpha) = rho` (NaN behind).
fn range_to(rho: f64, alpha: f64, phi: f64) -> f64 {
    let r = rho / (phi - alpha).cos();
    if r > 0.0 { r } else { f64::NAN }
}

fn angle_diff(a: f64, b: f64) -> f64 {
    (a - b + PI).rem_euclid(2.0 * PI) - PI
}

fn on_line(w: &WallSegment, p: &Point2<f64>) -> f64 {
    (p.x * w.alpha.cos() + p.y * w.alpha.sin() - w.rho).abs()
}

#[test]
fn empty_scan_gives_no_walls() {
    assert_eq!(extract_lines(&[], &[], &ScanParams::default()), Ok(vec![]));
}

#[test]
fn all_invalid_readings_give_no_walls() {
    let angles = bearings(100, -45.0, 45.0);
    let params = ScanParams {
        min_range: 0.1,
        max_range: 30.0,
        ..ScanParams::default()
    };
    for bad in [
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        0.0,
        0.05,
        0.1,
        30.0,
        80.0,
        -2.0,
    ] {
        let ranges = vec![bad; angles.len()];
        assert_eq!(
            extract_lines(&ranges, &angles, &params),
            Ok(vec![]),
            "{bad}"
        );
    }
}

#[test]
fn readings_at_the_range_limits_are_dropped_and_indices_refer_to_the_input() {
    // The wall x = 2 seen over 61 beams; readings 0, 10, 20, 30 are set to the limits.
    let angles = bearings(61, -30.0, 30.0);
    let mut ranges: Vec<f64> = angles.iter().map(|&a| range_to(2.0, 0.0, a)).collect();
    let params = ScanParams {
        min_range: 0.5,
        max_range: 10.0,
        ..ScanParams::default()
    };
    ranges[0] = 0.5;
    ranges[10] = 10.0;
    ranges[20] = f64::NAN;
    ranges[30] = 0.0;
    let walls = extract_lines(&ranges, &angles, &params).unwrap();
    assert_eq!(walls.len(), 1);
    let want: Vec<usize> = (1..61).filter(|k| ![10, 20, 30].contains(k)).collect();
    assert_eq!(walls[0].indices, want);
}

#[test]
fn every_bad_parameter_is_refused_by_name() {
    let ok = ScanParams::default();
    let cases: Vec<(ScanParams, &str)> = vec![
        (
            ScanParams {
                min_range: f64::NAN,
                ..ok
            },
            "min_range",
        ),
        (
            ScanParams {
                min_range: -0.1,
                ..ok
            },
            "min_range",
        ),
        (
            ScanParams {
                max_range: f64::NAN,
                ..ok
            },
            "max_range",
        ),
        (
            ScanParams {
                max_range: 0.0,
                ..ok
            },
            "max_range",
        ),
        (
            ScanParams {
                min_range: 5.0,
                max_range: 4.0,
                ..ok
            },
            "max_range",
        ),
        (
            ScanParams {
                sigma_range: f64::NAN,
                ..ok
            },
            "sigma_range",
        ),
        (
            ScanParams {
                sigma_range: -0.01,
                ..ok
            },
            "sigma_range",
        ),
        (
            ScanParams {
                sigma_range: f64::INFINITY,
                ..ok
            },
            "sigma_range",
        ),
        (
            ScanParams {
                sigma_bearing: f64::NAN,
                ..ok
            },
            "sigma_bearing",
        ),
        (
            ScanParams {
                sigma_bearing: -1e-3,
                ..ok
            },
            "sigma_bearing",
        ),
        (
            ScanParams {
                breakpoint_lambda: f64::NAN,
                ..ok
            },
            "breakpoint_lambda",
        ),
        (
            ScanParams {
                breakpoint_lambda: 0.0,
                ..ok
            },
            "breakpoint_lambda",
        ),
        (
            ScanParams {
                breakpoint_lambda: -0.1,
                ..ok
            },
            "breakpoint_lambda",
        ),
        (
            ScanParams {
                breakpoint_lambda: PI / 2.0,
                ..ok
            },
            "breakpoint_lambda",
        ),
        (
            ScanParams {
                split_epsilon: f64::NAN,
                ..ok
            },
            "split_epsilon",
        ),
        (
            ScanParams {
                split_epsilon: -0.05,
                ..ok
            },
            "split_epsilon",
        ),
        (
            ScanParams {
                merge_confidence: f64::NAN,
                ..ok
            },
            "merge_confidence",
        ),
        (
            ScanParams {
                merge_confidence: 1.0,
                ..ok
            },
            "merge_confidence",
        ),
        (
            ScanParams {
                min_points: 0,
                ..ok
            },
            "min_points",
        ),
        (
            ScanParams {
                min_points: 1,
                ..ok
            },
            "min_points",
        ),
        (
            ScanParams {
                min_length: f64::NAN,
                ..ok
            },
            "min_length",
        ),
        (
            ScanParams {
                min_length: -1.0,
                ..ok
            },
            "min_length",
        ),
    ];
    let angles = bearings(20, -10.0, 10.0);
    let ranges = [2.0; 20];
    for (params, name) in cases {
        // Checked even when there is nothing to extract.
        for (r, a) in [(&ranges[..], &angles[..]), (&[][..], &[][..])] {
            match extract_lines(r, a, &params) {
                Err(LineSimpError::InvalidParameter { name: got, reason }) => {
                    assert_eq!(got, name, "{reason}");
                    assert!(!reason.is_empty());
                }
                other => panic!("{name}: expected an error, got {other:?}"),
            }
        }
    }
    assert_eq!(ok.validate(), Ok(()));
}

#[test]
fn mismatched_lengths_are_an_error_naming_both() {
    let err = extract_lines(&[1.0; 5], &[0.0; 4], &ScanParams::default()).unwrap_err();
    match err {
        LineSimpError::LengthMismatch { what } => {
            assert!(what.contains('5') && what.contains('4'), "{what}");
        }
        other => panic!("expected LengthMismatch, got {other:?}"),
    }
}

#[test]
fn non_finite_bearings_are_an_error_naming_the_reading() {
    let angles = [0.0, 0.01, f64::NAN, 0.03];
    let err = extract_lines(&[2.0; 4], &angles, &ScanParams::default()).unwrap_err();
    assert!(matches!(
        err,
        LineSimpError::InvalidParameter { name: "angles", .. }
    ));
    assert!(err.to_string().contains("angle 2"), "{err}");
}

#[test]
fn a_single_wall_is_its_line_with_its_end_readings() {
    // x cos(0.7) + y sin(0.7) = 4, seen from bearings 20 to 80 degrees.
    let (rho, alpha) = (4.0, 0.7);
    let angles = bearings(121, 20.0, 80.0);
    let ranges: Vec<f64> = angles.iter().map(|&a| range_to(rho, alpha, a)).collect();
    let walls = extract_lines(&ranges, &angles, &ScanParams::default()).unwrap();
    assert_eq!(walls.len(), 1);
    let w = &walls[0];
    assert!((w.rho - rho).abs() < 1e-12 && angle_diff(w.alpha, alpha).abs() < 1e-12);
    assert_eq!(w.indices, (0..121).collect::<Vec<_>>());
    let reading = |k: usize| Point2::new(ranges[k] * angles[k].cos(), ranges[k] * angles[k].sin());
    assert!((w.start - reading(0)).norm() < 1e-12);
    assert!((w.end - reading(120)).norm() < 1e-12);
    // Closed form: the readings at bearings phi lie rho tan(phi - alpha) along the
    // line from the foot of the normal, so the wall spans rho (tan(80 deg - alpha) -
    // tan(20 deg - alpha)).
    let span = rho * ((80f64.to_radians() - alpha).tan() - (20f64.to_radians() - alpha).tan());
    assert!((w.length() - span).abs() < 1e-9, "{} vs {span}", w.length());
    // The covariance is positive definite when there is range noise.
    assert!(w.cov[(0, 0)] > 0.0 && w.cov.determinant() > 0.0);
}

#[test]
fn a_wall_behind_the_sensor_has_positive_rho_and_its_normal_flipped() {
    // The wall x = -3 seen looking backwards (bearings 150 to 210 degrees).
    let angles = bearings(61, 150.0, 210.0);
    let ranges: Vec<f64> = angles.iter().map(|&a| range_to(3.0, PI, a)).collect();
    let walls = extract_lines(&ranges, &angles, &ScanParams::default()).unwrap();
    assert_eq!(walls.len(), 1);
    assert!((walls[0].rho - 3.0).abs() < 1e-12);
    // alpha = pi, wrapped into (-pi, pi].
    assert!((walls[0].alpha - PI).abs() < 1e-12, "{}", walls[0].alpha);
}

#[test]
fn too_few_points_or_too_short_walls_are_dropped() {
    let angles = bearings(61, -30.0, 30.0);
    let ranges: Vec<f64> = angles.iter().map(|&a| range_to(2.0, 0.0, a)).collect();
    // The wall is 61 readings and 2 tan(30 deg) * 2 = 2.31 m long.
    let length = 4.0 * 30f64.to_radians().tan();
    for (min_points, min_length, kept) in [
        (61, 0.0, true),
        (62, 0.0, false),
        (2, length - 1e-9, true),
        (2, length + 1e-9, false),
    ] {
        let params = ScanParams {
            min_points,
            min_length,
            ..ScanParams::default()
        };
        let walls = extract_lines(&ranges, &angles, &params).unwrap();
        assert_eq!(walls.len(), usize::from(kept), "{min_points} {min_length}");
    }
}

#[test]
fn collinear_walls_across_a_doorway_stay_apart() {
    // The wall y = 3 with a 1 m doorway at -0.5 < x < 0.5 through which the beams
    // reach a far wall y = 8: two walls on the same line, separated by breakpoints.
    let angles = bearings(181, 30.0, 150.0);
    let ranges: Vec<f64> = angles
        .iter()
        .map(|&a| {
            let near = range_to(3.0, PI / 2.0, a);
            if (near * a.cos()).abs() < 0.5 {
                range_to(8.0, PI / 2.0, a)
            } else {
                near
            }
        })
        .collect();
    let walls = extract_lines(&ranges, &angles, &ScanParams::default()).unwrap();
    let near: Vec<&WallSegment> = walls
        .iter()
        .filter(|w| (w.rho - 3.0).abs() < 1e-9)
        .collect();
    assert_eq!(near.len(), 2, "{walls:?}");
    assert!(
        near.iter()
            .all(|w| angle_diff(w.alpha, PI / 2.0).abs() < 1e-9)
    );
    // Neither spans the doorway.
    for w in &near {
        assert!(w.start.x.signum() == w.end.x.signum() && w.start.x.abs() >= 0.5 - 1e-9);
    }
    // The far wall seen through the doorway is a third segment.
    assert!(walls.iter().any(|w| (w.rho - 8.0).abs() < 1e-9));
}

#[test]
fn dropouts_split_a_wall_exactly_where_the_adaptive_breakpoint_formula_says() {
    // The wall x = 2 over 121 beams 0.5 degrees apart, with `gap` readings missing in
    // the middle (NaN: no valid return). Invalid readings are skipped, so the two
    // valid readings either side are neighbours `gap + 1` beams apart. Borges &
    // Aldon: they are on different surfaces when dphi >= lambda or when they are
    // farther apart than r sin(dphi) / sin(lambda - dphi) + 3 sigma_r.
    let params = ScanParams::default();
    let angles = bearings(121, -30.0, 30.0);
    let mut saw = [false; 2];
    for gap in 1..30 {
        let ranges: Vec<f64> = angles
            .iter()
            .enumerate()
            .map(|(k, &a)| {
                if (50..50 + gap).contains(&k) {
                    f64::NAN
                } else {
                    range_to(2.0, 0.0, a)
                }
            })
            .collect();
        let (before, after) = (49, 50 + gap);
        let dphi = angles[after] - angles[before];
        let reading =
            |k: usize| Vector2::new(ranges[k] * angles[k].cos(), ranges[k] * angles[k].sin());
        let d_max = ranges[before] * dphi.sin() / (params.breakpoint_lambda - dphi).sin()
            + 3.0 * params.sigma_range;
        let breakpoint =
            dphi >= params.breakpoint_lambda || (reading(after) - reading(before)).norm() > d_max;
        let walls = extract_lines(&ranges, &angles, &params).unwrap();
        let valid: Vec<usize> = (0..121).filter(|k| ranges[*k].is_finite()).collect();
        if breakpoint {
            assert_eq!(walls.len(), 2, "gap {gap}");
            assert_eq!(walls[0].indices, (0..50).collect::<Vec<_>>());
            assert_eq!(walls[1].indices, (50 + gap..121).collect::<Vec<_>>());
        } else {
            assert_eq!(walls.len(), 1, "gap {gap}");
            assert_eq!(walls[0].indices, valid);
        }
        saw[usize::from(breakpoint)] = true;
    }
    assert_eq!(saw, [true, true], "both outcomes occur over these gaps");
}

#[test]
fn an_angular_gap_wider_than_lambda_is_a_breakpoint() {
    // Beams skip 20 degrees (a blanked sector): the wall on either side is split.
    let mut angles = bearings(41, -40.0, -10.0);
    angles.extend(bearings(41, 10.0, 40.0));
    let ranges: Vec<f64> = angles.iter().map(|&a| range_to(2.0, 0.0, a)).collect();
    let walls = extract_lines(&ranges, &angles, &ScanParams::default()).unwrap();
    assert_eq!(walls.len(), 2);
}

/// Walls of a noise-free scan of a corner and a pillar, for the symmetry tests.
fn corner_scan() -> (Vec<f64>, Vec<f64>) {
    let angles = bearings(181, -60.0, 120.0);
    let ranges = angles
        .iter()
        .map(|&a| {
            let walls = [(3.0, 0.1), (2.5, PI / 2.0 + 0.1)];
            let mut r = walls
                .iter()
                .map(|&(rho, alpha)| range_to(rho, alpha, a))
                .filter(|r| r.is_finite())
                .fold(f64::INFINITY, f64::min);
            // A pillar face x = 1.5 for -1 < y < -0.4.
            let t = 1.5 / a.cos();
            if t > 0.0 && (-1.0..-0.4).contains(&(t * a.sin())) {
                r = r.min(t);
            }
            r
        })
        .collect();
    (ranges, angles)
}

#[test]
fn reversing_the_scan_order_gives_the_same_walls() {
    let (ranges, angles) = corner_scan();
    let forward = extract_lines(&ranges, &angles, &ScanParams::default()).unwrap();
    let (mut r, mut a) = (ranges.clone(), angles.clone());
    r.reverse();
    a.reverse();
    let backward = extract_lines(&r, &a, &ScanParams::default()).unwrap();
    // Both walls, the pillar, and the first wall again behind the pillar.
    assert_eq!(forward.len(), 4, "{forward:?}");
    assert_eq!(forward.len(), backward.len());
    let n = ranges.len();
    for (f, b) in forward.iter().zip(backward.iter().rev()) {
        assert!((f.rho - b.rho).abs() < 1e-12 && angle_diff(f.alpha, b.alpha).abs() < 1e-12);
        let mut mapped: Vec<usize> = b.indices.iter().map(|&k| n - 1 - k).collect();
        mapped.reverse();
        assert_eq!(f.indices, mapped);
        assert!((f.start - b.end).norm() < 1e-12 && (f.end - b.start).norm() < 1e-12);
    }
}

#[test]
fn rotating_the_sensor_rotates_alpha_and_keeps_rho() {
    let (ranges, angles) = corner_scan();
    let base = extract_lines(&ranges, &angles, &ScanParams::default()).unwrap();
    for delta in [0.3, -2.0, PI] {
        let rotated: Vec<f64> = angles.iter().map(|a| a + delta).collect();
        let walls = extract_lines(&ranges, &rotated, &ScanParams::default()).unwrap();
        assert_eq!(walls.len(), base.len());
        for (w, b) in walls.iter().zip(&base) {
            assert!((w.rho - b.rho).abs() < 1e-9);
            assert!(angle_diff(w.alpha, b.alpha + delta).abs() < 1e-9);
            assert_eq!(w.indices, b.indices);
            // The covariance of (rho, alpha) does not depend on the frame's heading.
            assert!((w.cov - b.cov).norm() < 1e-9 * b.cov.norm());
            let (s, c) = delta.sin_cos();
            let turn = |p: &Point2<f64>| Point2::new(c * p.x - s * p.y, s * p.x + c * p.y);
            assert!((w.start - turn(&b.start)).norm() < 1e-9);
        }
    }
}

#[test]
fn a_reused_extractor_gives_the_same_walls_as_a_fresh_one() {
    let (r1, a1) = corner_scan();
    let a2 = bearings(61, -30.0, 30.0);
    let r2: Vec<f64> = a2.iter().map(|&a| range_to(2.0, 0.0, a)).collect();
    let mut reused = LineExtractor::new(ScanParams::default());
    let first = reused.extract(&r1, &a1).unwrap();
    let second = reused.extract(&r2, &a2).unwrap();
    let empty = reused.extract(&[], &[]).unwrap();
    let again = reused.extract(&r1, &a1).unwrap();
    assert_eq!(first, again);
    assert!(empty.is_empty());
    assert_eq!(
        second,
        extract_lines(&r2, &a2, &ScanParams::default()).unwrap()
    );
    assert_eq!(
        first,
        extract_lines(&r1, &a1, &ScanParams::default()).unwrap()
    );
}

#[test]
fn end_points_lie_on_the_line_within_round_off() {
    let (ranges, angles) = corner_scan();
    for w in extract_lines(&ranges, &angles, &ScanParams::default()).unwrap() {
        assert!(on_line(&w, &w.start) < 1e-12 && on_line(&w, &w.end) < 1e-12);
        let n = Vector2::new(w.alpha.cos(), w.alpha.sin());
        // And they are the feet of the perpendiculars from the end readings.
        let reading =
            |k: usize| Point2::new(ranges[k] * angles[k].cos(), ranges[k] * angles[k].sin());
        let first = reading(w.indices[0]);
        let foot = first - n * (n.dot(&first.coords) - w.rho);
        assert!((w.start - foot).norm() < 1e-12);
    }
}

/// Bearings out of order (neither increasing nor decreasing) are refused with the
/// offending reading, instead of silently giving no walls.
#[test]
fn unsorted_bearings_are_an_error_naming_the_reading() {
    let mut angles = bearings(61, -30.0, 30.0);
    angles.swap(20, 21);
    let ranges: Vec<f64> = angles.iter().map(|&a| range_to(2.0, 0.0, a)).collect();
    let err = extract_lines(&ranges, &angles, &ScanParams::default()).unwrap_err();
    assert!(err.to_string().contains("angle 21"), "{err}");
    assert!(matches!(
        err,
        LineSimpError::InvalidParameter { name: "angles", .. }
    ));
}

#[test]
fn readings_at_grazing_incidence_extend_the_wall_they_lie_on() {
    // The wall y = 1 seen from 2 to 80 degrees, 1 degree apart. Borges & Aldon's
    // detector breaks between every two readings whose beams meet the wall at less than
    // lambda = 10 degrees (consecutive points are then farther apart than d_max), so
    // those readings are runs of one point. They lie on the wall's line, so the wall
    // takes them all.
    let angles = bearings(79, 2.0, 80.0);
    let ranges: Vec<f64> = angles.iter().map(|&a| range_to(1.0, PI / 2.0, a)).collect();
    let params = ScanParams::default();
    let reading = |k: usize| Vector2::new(ranges[k] * angles[k].cos(), ranges[k] * angles[k].sin());
    let d_max = |k: usize| {
        let dphi = angles[k] - angles[k - 1];
        ranges[k - 1] * dphi.sin() / (params.breakpoint_lambda - dphi).sin()
            + 3.0 * params.sigma_range
    };
    // The oracle of the premise: the formula breaks the first readings apart.
    assert!((reading(1) - reading(0)).norm() > d_max(1));
    let walls = extract_lines(&ranges, &angles, &params).unwrap();
    assert_eq!(walls.len(), 1, "{walls:?}");
    assert_eq!(walls[0].indices, (0..79).collect::<Vec<_>>());
    assert!((walls[0].rho - 1.0).abs() < 1e-9 && angle_diff(walls[0].alpha, PI / 2.0).abs() < 1e-9);
}

#[test]
fn a_short_run_off_the_wall_is_not_merged() {
    // A box corner 0.3 m in front of the wall x = 3: its few readings form their own
    // short run, off the wall's line, so the wall does not take them.
    let angles = bearings(121, -30.0, 30.0);
    let ranges: Vec<f64> = angles
        .iter()
        .enumerate()
        .map(|(k, &a)| {
            let wall = range_to(3.0, 0.0, a);
            if (100..104).contains(&k) {
                wall - 0.3
            } else {
                wall
            }
        })
        .collect();
    let walls = extract_lines(&ranges, &angles, &ScanParams::default()).unwrap();
    assert!(
        walls
            .iter()
            .all(|w| w.indices.iter().all(|k| !(100..104).contains(k)))
    );
    assert!((walls[0].rho - 3.0).abs() < 1e-9);
}
