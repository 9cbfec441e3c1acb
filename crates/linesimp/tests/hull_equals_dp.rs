//! Path hulls return exactly plain Douglas-Peucker's indices, under both tie rules,
//! whatever the DP budget (0: pure path hulls; 1: early hand-over; default), on inputs
//! full of exact ties: duplicates, collinear runs, lattice walks, closed rings, convex
//! zig-zags followed by other data, epsilon 0 and epsilon equal to vertex distances.
//!
//! The oracle is Douglas-Peucker written here in exact integer arithmetic: inputs are
//! integers times a power of two, so `(b - a) x (p - a)` is an exact `i128`.

use linesimp::{Method, Metric, Simplifier, Tie};
use nalgebra::Point2;
use proptest::prelude::*;

/// Exact DP on integer coordinates (line metric). `eps_units` is epsilon in grid
/// units; `None` means epsilon 0 (keep every vertex off its chord's line).
fn oracle(xy: &[(i64, i64)], eps_units: Option<f64>, tie: Tie) -> Vec<usize> {
    let n = xy.len();
    if n < 3 {
        return (0..n).collect();
    }
    let mut keep = vec![false; n];
    keep[0] = true;
    keep[n - 1] = true;
    let mut stack = vec![(0usize, n - 1)];
    while let Some((i, j)) = stack.pop() {
        if j <= i + 1 {
            continue;
        }
        let (a, b) = (xy[i], xy[j]);
        let (dx, dy) = ((b.0 - a.0) as i128, (b.1 - a.1) as i128);
        // |F| for a proper chord, squared distance to `a` for a degenerate one.
        let key = |p: (i64, i64)| -> i128 {
            let (px, py) = ((p.0 - a.0) as i128, (p.1 - a.1) as i128);
            if dx == 0 && dy == 0 {
                px * px + py * py
            } else {
                (dx * py - dy * px).abs()
            }
        };
        let mut f = i + 1;
        for k in i + 2..j {
            let (kk, kf) = (key(xy[k]), key(xy[f]));
            if kk > kf || (kk == kf && tie == Tie::Last) {
                f = k;
            }
        }
        let kf = key(xy[f]);
        let split = match eps_units {
            None => kf != 0,
            Some(e) if dx == 0 && dy == 0 => (kf as f64).sqrt() > e,
            Some(e) => kf as f64 / ((dx * dx + dy * dy) as f64).sqrt() > e,
        };
        if split {
            keep[f] = true;
            stack.push((f, j));
            stack.push((i, f));
        }
    }
    (0..n).filter(|&k| keep[k]).collect()
}

/// Every configuration that must agree: plain DP, and path hulls with the default
/// budget, an early hand-over and none at all.
fn all_line_results(points: &[Point2<f64>], eps: f64, tie: Tie) -> Vec<(&'static str, Vec<usize>)> {
    let run = |method, budget: Option<usize>| {
        let mut s = Simplifier::new(method, Metric::Line).with_tie(tie);
        if let Some(b) = budget {
            s = s.with_dp_budget(b);
        }
        s.indices(points, eps).unwrap()
    };
    vec![
        ("dp", run(Method::Dp, None)),
        ("hull", run(Method::Hull, None)),
        ("hull budget 1", run(Method::Hull, Some(1))),
        ("pure hull", run(Method::Hull, Some(0))),
    ]
}

fn to_points(xy: &[(i64, i64)], unit: f64) -> Vec<Point2<f64>> {
    xy.iter()
        .map(|&(x, y)| Point2::new(x as f64 * unit, y as f64 * unit))
        .collect()
}

/// Checks all configurations against the oracle, for both tie rules.
fn check(xy: &[(i64, i64)], unit: f64, eps_units: Option<f64>) {
    let pts = to_points(xy, unit);
    let eps = eps_units.map_or(0.0, |e| e * unit);
    for tie in [Tie::First, Tie::Last] {
        let expected = oracle(xy, eps_units, tie);
        for (name, got) in all_line_results(&pts, eps, tie) {
            assert_eq!(got, expected, "{name}, {tie:?}, eps {eps}, n {}", xy.len());
        }
    }
}

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
