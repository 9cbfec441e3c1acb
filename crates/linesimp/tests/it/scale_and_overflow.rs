//! Scale safety: results do not change when the input and epsilon are scaled together
//! by any power of two from 2^-500 to 2^500 (both metrics, both tie rules, plain DP and
//! path hulls); extreme inputs neither overflow, loop nor silently drop points; spans
//! that cannot be represented are a clear error.

use linesimp::{LineSimpError, Method, Metric, Simplifier, Tie};
use nalgebra::Point2;
use proptest::prelude::*;

fn walk(steps: &[(f64, f64)]) -> Vec<Point2<f64>> {
    let mut p = Point2::new(0.0, 0.0);
    steps
        .iter()
        .map(|&(dx, dy)| {
            p += nalgebra::Vector2::new(dx, dy);
            p
        })
        .collect()
}

/// Every method / metric / tie / budget combination, labelled.
fn configs() -> Vec<(String, Simplifier)> {
    let mut out = Vec::new();
    for tie in [Tie::First, Tie::Last] {
        for metric in [Metric::Line, Metric::Segment] {
            out.push((
                format!("dp {metric:?} {tie:?}"),
                Simplifier::new(Method::Dp, metric).with_tie(tie),
            ));
        }
        for budget in [0, 4] {
            out.push((
                format!("hull budget {budget} {tie:?}"),
                Simplifier::new(Method::Hull, Metric::Line)
                    .with_tie(tie)
                    .with_dp_budget(budget),
            ));
        }
    }
    out
}

fn scaled(points: &[Point2<f64>], s: f64) -> Vec<Point2<f64>> {
    points
        .iter()
        .map(|p| Point2::new(p.x * s, p.y * s))
        .collect()
}

fn assert_scale_invariant(points: &[Point2<f64>], eps: f64, exponents: &[i32]) {
    for (name, mut s) in configs() {
        let base = s.indices(points, eps).unwrap();
        for &k in exponents {
            let f = 2f64.powi(k);
            let got = s.indices(&scaled(points, f), eps * f).unwrap();
            assert_eq!(got, base, "{name}: scale 2^{k}, eps {eps}");
        }
    }
}

const EXPONENTS: [i32; 8] = [-500, -431, -250, -1, 1, 250, 377, 500];

proptest! {
    #![proptest_config(ProptestConfig::with_cases(150))]

    #[test]
    fn random_walks_are_scale_invariant(steps in prop::collection::vec((-1.0..1.0f64, -1.0..1.0f64), 3..300), eps in prop_oneof![Just(0.0), 0.0..3.0f64]) {
        assert_scale_invariant(&walk(&steps), eps, &EXPONENTS);
    }

    #[test]
    fn lattice_walks_are_scale_invariant(steps in prop::collection::vec((-2i32..=2, -2i32..=2), 3..200), eps in prop_oneof![Just(0.0), Just(1.0), 0.0..3.0f64]) {
        let steps: Vec<(f64, f64)> = steps.iter().map(|&(x, y)| (x as f64, y as f64)).collect();
        assert_scale_invariant(&walk(&steps), eps, &EXPONENTS);
    }
}

#[test]
fn walks_at_decimal_extremes_keep_their_shape() {
    // The issue: the line metric returned only the ends beyond 1e80 and below 1e-84.
    // A walk multiplied by 10^k (rounded) must simplify exactly as the same rounded
    // points brought back near 1 by a power of two.
    let steps: Vec<(f64, f64)> = (0..2000)
        .map(|k| {
            (
                ((k * 7919) % 13) as f64 - 6.0,
                ((k * 104_729) % 11) as f64 - 5.0,
            )
        })
        .collect();
    let base = walk(&steps);
    for k in [-300, -160, -84, 80, 153, 300] {
        let s = 10f64.powi(k);
        let big = scaled(&base, s);
        let back_exp = -(s.log2().round() as i32);
        let back = scaled(&big, 2f64.powi(back_exp));
        for (name, mut simp) in configs() {
            let eps = 3.0 * s;
            let kept = simp.indices(&big, eps).unwrap();
            let expected = simp.indices(&back, eps * 2f64.powi(back_exp)).unwrap();
            assert_eq!(kept, expected, "{name} at 1e{k}");
            assert!(kept.len() > 50, "{name} at 1e{k}: only {} kept", kept.len());
        }
    }
}

#[test]
fn far_point_is_kept_and_nothing_loops() {
    // The infinite loop: distances overflowed to NaN and plain DP pushed the
    // same range forever; path hulls dropped the far point that GEOS keeps.
    let p = [
        Point2::new(0.0, 0.0),
        Point2::new(1e300, 1.0001e300),
        Point2::new(1e150, 1e150),
    ];
    for (name, mut s) in configs() {
        assert_eq!(s.indices(&p, 1.0).unwrap(), vec![0, 1, 2], "{name}");
    }
}

#[test]
fn coordinates_near_the_limits_work() {
    // Spans up to 2^1020 are accepted: every difference and key stays finite.
    let big = 2f64.powi(1019);
    let p = [
        Point2::new(-big, 0.0),
        Point2::new(0.0, big * 0.5),
        Point2::new(big * 0.25, -big),
        Point2::new(big, 0.0),
    ];
    for (name, mut s) in configs() {
        assert_eq!(
            s.indices(&p, big * 1e-3).unwrap(),
            vec![0, 1, 2, 3],
            "{name}"
        );
        assert_eq!(s.indices(&p, big * 4.0).unwrap(), vec![0, 3], "{name}");
    }
    // Subnormal coordinates: no panic, and every configuration agrees with plain DP.
    // Not `2f64.powi(-1060)`: unoptimised builds evaluate powi as `1 / 2^1060`, which
    // overflows to 0 (release builds fold the constant exactly). Both factors are
    // normal and their product, 2^-1060, is exact.
    let tiny = 2f64.powi(-530) * 2f64.powi(-530);
    assert!(tiny > 0.0);
    let q: Vec<_> = (0..50)
        .map(|k| Point2::new(k as f64 * tiny, ((k * k) % 7) as f64 * tiny))
        .collect();
    let expected = Simplifier::new(Method::Dp, Metric::Line)
        .indices(&q, tiny)
        .unwrap();
    for tie in [Tie::First, Tie::Last] {
        let hull = Simplifier::new(Method::Hull, Metric::Line)
            .with_tie(tie)
            .with_dp_budget(0)
            .indices(&q, tiny)
            .unwrap();
        let dp = Simplifier::new(Method::Dp, Metric::Line)
            .with_tie(tie)
            .indices(&q, tiny)
            .unwrap();
        assert_eq!(hull, dp, "{tie:?}");
    }
    assert!(expected.len() > 2);
}

#[test]
fn unrepresentable_spans_are_refused() {
    let p = [
        Point2::new(-1e308, 0.0),
        Point2::new(0.0, 1.0),
        Point2::new(1e308, 0.0),
    ];
    for (name, mut s) in configs() {
        match s.indices(&p, 1.0) {
            Err(LineSimpError::InvalidParameter {
                name: "points",
                reason,
            }) => {
                assert!(reason.contains("2^1020"), "{name}: {reason}")
            }
            other => panic!("{name}: expected an error, got {other:?}"),
        }
    }
}
