//! Path hulls return exactly plain Douglas-Peucker's indices, under both tie rules,
//! whatever the DP budget (0: pure path hulls; 1: early hand-over; default), on inputs
//! full of exact ties: duplicates, collinear runs, lattice walks, closed rings, convex
//! zig-zags followed by other data, epsilon 0 and epsilon equal to vertex distances.
//!
//! The oracle (`common::oracle`) is Douglas-Peucker in exact integer arithmetic: inputs are
//! integers times a power of two, so `(b - a) x (p - a)` is an exact `i128`.

use crate::common::{all_line_results, check, to_points};
use linesimp::{Method, Metric, Simplifier, Tie};
use proptest::prelude::*;

fn lattice_walk(steps: &[(i64, i64)]) -> Vec<(i64, i64)> {
    let mut p = (0, 0);
    steps
        .iter()
        .map(|&(dx, dy)| {
            p = (p.0 + dx, p.1 + dy);
            p
        })
        .collect()
}

/// A zig-zag whose peaks lie on two convex curves: every chord's farthest vertex is
/// next to its end, so path hulls take over at once under any budget.
fn convex_zigzag(n: usize) -> Vec<(i64, i64)> {
    (0..n as i64)
        .map(|k| (k, if k % 2 == 0 { k * k } else { -k * k }))
        .collect()
}

fn eps_units() -> impl Strategy<Value = Option<f64>> {
    prop_oneof![
        Just(None),
        Just(Some(1.0)),
        Just(Some(2.0)),
        (0.01..6.0f64).prop_map(Some)
    ]
}

/// Grid units: exact powers of two, including extreme ones.
fn unit() -> impl Strategy<Value = f64> {
    prop_oneof![
        Just(1.0),
        Just(0.125),
        Just(2f64.powi(-30)),
        Just(2f64.powi(40)),
        Just(2f64.powi(-480)),
        Just(2f64.powi(480))
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn lattice_walks(steps in prop::collection::vec((-2i64..=2, -2i64..=2), 0..300), e in eps_units(), u in unit()) {
        check(&lattice_walk(&steps), u, e);
    }

    #[test]
    fn fine_random_walks(steps in prop::collection::vec((-1_000_000i64..=1_000_000, -1_000_000i64..=1_000_000), 0..400), e in (0.0..3e6f64).prop_map(Some), u in unit()) {
        check(&lattice_walk(&steps), u, e);
    }

    #[test]
    fn duplicates_and_collinear_runs(ts in prop::collection::vec(-20i64..20, 0..200), reps in prop::collection::vec(1usize..4, 200), e in eps_units()) {
        // Points on the line (2t + 1, -t), each repeated: every distance ties at 0.
        let mut xy = Vec::new();
        for (k, &t) in ts.iter().enumerate() {
            for _ in 0..reps[k] { xy.push((2 * t + 1, -t)); }
        }
        check(&xy, 1.0, e);
        // The same with a few vertices off the line.
        for k in (0..xy.len()).step_by(7) { xy[k].1 += (k % 3) as i64 - 1; }
        check(&xy, 1.0, e);
    }

    #[test]
    fn convex_zigzag_then_lattice(n in 3usize..120, steps in prop::collection::vec((-3i64..=3, -3i64..=3), 0..120), e in eps_units()) {
        let mut xy = convex_zigzag(n);
        let last = *xy.last().unwrap();
        xy.extend(lattice_walk(&steps).into_iter().map(|(x, y)| (x + last.0, y + last.1)));
        check(&xy, 1.0, e);
    }

    #[test]
    fn closed_lattice_rings(steps in prop::collection::vec((-2i64..=2, -2i64..=2), 2..200), e in eps_units()) {
        let mut xy = lattice_walk(&steps);
        xy.push(xy[0]);
        check(&xy, 1.0, e);
        // Start and end repeated, as in rings written with a doubled closing vertex.
        xy.insert(0, xy[0]);
        xy.push(xy[0]);
        check(&xy, 1.0, e);
    }

    #[test]
    fn epsilon_equal_to_a_vertex_distance(steps in prop::collection::vec((-3i64..=3, -3i64..=3), 3..150), pick in 0usize..1000, tie_last in any::<bool>()) {
        // Epsilon is the computed distance of some vertex to the full chord, so the
        // threshold decision lands exactly on it. All configurations must agree.
        let xy = lattice_walk(&steps);
        let pts = to_points(&xy, 1.0);
        let n = pts.len();
        let k = 1 + pick % (n - 2);
        let eps = linesimp::chord_distance(&pts[k], &pts[0], &pts[n - 1], Metric::Line);
        let tie = if tie_last { Tie::Last } else { Tie::First };
        let results = all_line_results(&pts, eps, tie);
        for (name, got) in &results[1..] {
            prop_assert_eq!(got, &results[0].1, "{} vs dp at eps {}", name, eps);
        }
    }
}

/// Integers `(s, t)` with `a s + b t = gcd(a, b)`.
fn egcd(a: i128, b: i128) -> (i128, i128, i128) {
    if b == 0 {
        (a, 1, 0)
    } else {
        let (g, s, t) = egcd(b, a % b);
        (g, t, s - (a / b) * t)
    }
}

/// Vertices whose exact distances to the chord `(0, 0) -> (d, e)` are `t + delta_k`
/// over `|(d, e)|`: consecutive distances differ by less than the round-off of a
/// floating-point key (about 2^-13 of a unit here), so only exact comparison orders them.
fn near_ties(d: i64, e: i64, t: i64, deltas: &[i64]) -> Vec<(i64, i64)> {
    let (_, s, r) = egcd(d as i128, e as i128); // d s + e r = 1
    let mut xy = vec![(0, 0)];
    for &delta in deltas {
        let f = (t + delta) as i128; // want d y - e x = f
        let (x0, y0) = (-r * f, s * f);
        let k = (-x0).div_euclid(d as i128);
        let (x, y) = (x0 + k * d as i128, y0 + k * e as i128);
        xy.push((x as i64, y as i64));
    }
    xy.push((d, e));
    xy
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn near_ties_below_round_off(
        d in (1i64 << 35)..(1i64 << 40),
        e in (1i64 << 34)..(1i64 << 39),
        t in (1i64 << 40)..(1i64 << 41),
        deltas in prop::collection::vec(-3i64..=3, 1..60),
        frac in 0.0..1.0f64,
    ) {
        prop_assume!(egcd(d as i128, e as i128).0 == 1);
        let xy = near_ties(d, e, t, &deltas);
        let len = ((d as f64).powi(2) + (e as f64).powi(2)).sqrt();
        for eps in [None, Some(frac * t as f64 / len), Some(0.3 + frac)] {
            check(&xy, 1.0, eps);
        }
    }
}

#[test]
fn issue_examples_convex_zigzag_with_a_backtracking_tail() {
    // From the issue: a convex zig-zag followed by a tail that doubles back on itself.
    for n in [20, 80, 81] {
        let mut xy = convex_zigzag(n);
        let last = *xy.last().unwrap();
        for (x, y) in [(3, 3), (5, 1), (7, 0), (7, 3), (7, 0), (8, 3)] {
            xy.push((last.0 + x, last.1 + y));
        }
        for e in [None, Some(1.0), Some(0.5), Some(3.0)] {
            check(&xy, 1.0, e);
        }
    }
}

#[test]
fn deep_convex_zigzag_keeps_every_vertex_in_all_modes() {
    let xy: Vec<(i64, i64)> = (0..20_000i64)
        .map(|k| (k, if k % 2 == 0 { k } else { -k }))
        .collect();
    let pts = to_points(&xy, 1.0);
    for tie in [Tie::First, Tie::Last] {
        for budget in [0, 1, 4] {
            let kept = Simplifier::new(Method::Hull, Metric::Line)
                .with_tie(tie)
                .with_dp_budget(budget)
                .indices(&pts, 0.0)
                .unwrap();
            assert_eq!(kept.len(), xy.len());
        }
    }
}
