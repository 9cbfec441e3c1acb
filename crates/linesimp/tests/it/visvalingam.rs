//! Visvalingam-Whyatt against a brute-force reference written here: recompute every
//! effective area, remove the smallest (ties: the smallest index), repeat while the
//! smallest is `<= epsilon`. O(n^2) per removal sweep, obviously correct.

use linesimp::{Method, Metric, Simplifier, simplify_many};
use nalgebra::Point2;
use proptest::prelude::*;

/// Triangle area of (a, p, b), written as the crate documents it (half the cross
/// product of p - a and b - a), so that equal inputs give bit-equal areas.
fn area(a: &Point2<f64>, p: &Point2<f64>, b: &Point2<f64>) -> f64 {
    0.5 * ((p.x - a.x) * (b.y - a.y) - (p.y - a.y) * (b.x - a.x)).abs()
}

fn brute_force(points: &[Point2<f64>], epsilon: f64) -> Vec<usize> {
    let mut alive: Vec<usize> = (0..points.len()).collect();
    while alive.len() > 2 {
        let (pos, smallest) = (1..alive.len() - 1)
            .map(|k| {
                let a = area(
                    &points[alive[k - 1]],
                    &points[alive[k]],
                    &points[alive[k + 1]],
                );
                (k, a)
            })
            // Strictly smaller wins, so among equal areas the first (smallest index) stays.
            .fold(
                (0, f64::INFINITY),
                |best, (k, a)| {
                    if a < best.1 { (k, a) } else { best }
                },
            );
        if pos == 0 || smallest > epsilon {
            break;
        }
        alive.remove(pos);
    }
    alive
}

fn vw(points: &[Point2<f64>], epsilon: f64) -> Vec<usize> {
    Simplifier::new(Method::Visvalingam, Metric::Line)
        .indices(points, epsilon)
        .unwrap()
}

fn walk() -> impl Strategy<Value = Vec<Point2<f64>>> {
    prop::collection::vec((-5.0..5.0f64, -5.0..5.0f64), 0..300).prop_map(|steps| {
        let mut p = Point2::new(0.0, 0.0);
        steps
            .into_iter()
            .map(|(dx, dy)| {
                p += nalgebra::Vector2::new(dx, dy);
                p
            })
            .collect()
    })
}

/// Small integer coordinates: many exactly equal areas, repeated and collinear points.
fn lattice() -> impl Strategy<Value = Vec<Point2<f64>>> {
    prop::collection::vec((-3i32..=3, -3i32..=3), 0..120).prop_map(|v| {
        v.into_iter()
            .map(|(x, y)| Point2::new(f64::from(x), f64::from(y)))
            .collect()
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn equals_brute_force_on_random_walks(points in walk(), epsilon in 0.0..40.0f64) {
        prop_assert_eq!(vw(&points, epsilon), brute_force(&points, epsilon));
    }

    #[test]
    fn equals_brute_force_with_ties(points in lattice(), epsilon in 0u8..12) {
        let epsilon = f64::from(epsilon) / 2.0; // areas are multiples of 0.5: exact hits
        prop_assert_eq!(vw(&points, epsilon), brute_force(&points, epsilon));
    }

    #[test]
    fn closed_rings_keep_both_ends(mut points in walk(), epsilon in 0.0..40.0f64) {
        if let Some(&first) = points.first() {
            points.push(first);
        }
        let kept = vw(&points, epsilon);
        prop_assert_eq!(&kept, &brute_force(&points, epsilon));
        if points.len() >= 2 {
            prop_assert_eq!(kept[0], 0);
            prop_assert_eq!(*kept.last().unwrap(), points.len() - 1);
        }
    }

    /// The elimination order does not depend on the threshold (always the current
    /// smallest area); the threshold only says where it stops. So the kept sets are
    /// nested: a larger threshold keeps a subset.
    #[test]
    fn larger_thresholds_keep_subsets(points in walk(), a in 0.0..20.0f64, b in 0.0..20.0f64) {
        let (small, large) = (a.min(b), a.max(b));
        let fine = vw(&points, small);
        let coarse = vw(&points, large);
        prop_assert!(coarse.iter().all(|k| fine.contains(k)));
    }

    #[test]
    fn many_equals_one_by_one(lines in prop::collection::vec(walk(), 0..8), epsilon in 0.0..20.0f64) {
        let many = simplify_many(&lines, epsilon, Method::Visvalingam, Metric::Line);
        for (line, kept) in lines.iter().zip(many) {
            prop_assert_eq!(kept.unwrap(), brute_force(line, epsilon));
        }
    }
}

#[test]
fn bad_input_is_an_error() {
    let pts = [
        Point2::new(0.0, 0.0),
        Point2::new(f64::NAN, 1.0),
        Point2::new(2.0, 0.0),
    ];
    let mut s = Simplifier::new(Method::Visvalingam, Metric::Line);
    assert!(s.indices(&pts, 1.0).is_err());
    let ok = [
        Point2::new(0.0, 0.0),
        Point2::new(1.0, 1.0),
        Point2::new(2.0, 0.0),
    ];
    assert!(s.indices(&ok, -1.0).is_err());
    assert!(s.indices(&ok, f64::NAN).is_err());
}
