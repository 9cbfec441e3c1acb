//! Property tests: path hulls against plain Douglas-Peucker (always equal, both tie
//! rules), and both against an oracle written here from the seed's Tables 1 and 2 that
//! also reports near-ties, for the line metric and for the segment metric (with a
//! point-to-segment distance written here, not the crate's).

use linesimp::{LineSimpError, Method, Metric, Simplifier, Tie, simplify_indices};
use nalgebra::Point2;
use proptest::prelude::*;

/// Recursive DP straight from Table 1, with the distance computed independently of the
/// crate (`|cross| / |chord|`, or point distance for a degenerate chord). Returns the
/// kept indices and whether any split decision involved a near-tie for the farthest
/// vertex, where two correct implementations may legitimately differ.
fn line_distance(p: &Point2<f64>, a: &Point2<f64>, b: &Point2<f64>) -> f64 {
    let d = b - a;
    let len = d.norm();
    if len == 0.0 {
        (p - a).norm()
    } else {
        (d.x * (p.y - a.y) - d.y * (p.x - a.x)).abs() / len
    }
}

/// Distance from `p` to the closed segment `a b`, by brute force: project onto the
/// segment's line, clamp the parameter to [0, 1], measure to that point.
fn segment_distance(p: &Point2<f64>, a: &Point2<f64>, b: &Point2<f64>) -> f64 {
    let d = b - a;
    let len2 = d.norm_squared();
    if len2 == 0.0 {
        return (p - a).norm();
    }
    let t = ((p - a).dot(&d) / len2).clamp(0.0, 1.0);
    (p - (a + d * t)).norm()
}

type Dist = fn(&Point2<f64>, &Point2<f64>, &Point2<f64>) -> f64;

fn oracle(points: &[Point2<f64>], eps: f64) -> (Vec<usize>, bool) {
    oracle_with(points, eps, line_distance)
}

fn oracle_with(points: &[Point2<f64>], eps: f64, dist: Dist) -> (Vec<usize>, bool) {
    fn rec(
        dist: Dist,
        pts: &[Point2<f64>],
        i: usize,
        j: usize,
        eps: f64,
        keep: &mut Vec<bool>,
        tie: &mut bool,
    ) {
        if j <= i + 1 {
            return;
        }
        let ds: Vec<f64> = (i + 1..j)
            .map(|k| dist(&pts[k], &pts[i], &pts[j]))
            .collect();
        let dmax = ds.iter().cloned().fold(0.0, f64::max);
        let f = i + 1 + ds.iter().position(|&d| d == dmax).unwrap();
        let tol = 1e-9 * (1.0 + dmax);
        if (dmax - eps).abs() <= tol {
            *tie = true; // threshold decision within round-off
        }
        if dmax > eps {
            if ds.iter().filter(|&&d| (dmax - d).abs() <= tol).count() > 1 {
                *tie = true;
            }
            keep[f] = true;
            rec(dist, pts, i, f, eps, keep, tie);
            rec(dist, pts, f, j, eps, keep, tie);
        }
    }
    let n = points.len();
    if n < 3 {
        return ((0..n).collect(), false);
    }
    let mut keep = vec![false; n];
    keep[0] = true;
    keep[n - 1] = true;
    let mut tie = false;
    rec(dist, points, 0, n - 1, eps, &mut keep, &mut tie);
    ((0..n).filter(|&k| keep[k]).collect(), tie)
}

fn pts(xy: &[(f64, f64)]) -> Vec<Point2<f64>> {
    xy.iter().map(|&(x, y)| Point2::new(x, y)).collect()
}

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

/// Validity with a distance written here: every dropped vertex is within epsilon
/// (plus round-off) of the chord that replaces it.
fn valid(points: &[Point2<f64>], kept: &[usize], eps: f64, dist: Dist) -> bool {
    if points.len() < 2 {
        return kept.len() == points.len();
    }
    if kept.first() != Some(&0) || kept.last() != Some(&(points.len() - 1)) {
        return false;
    }
    kept.windows(2).all(|w| {
        let (a, b) = (points[w[0]], points[w[1]]);
        let scale = 1.0 + a.coords.amax().max(b.coords.amax());
        points[w[0] + 1..w[1]]
            .iter()
            .all(|p| dist(p, &a, &b) <= eps + 1e-9 * scale)
    })
}

fn check_all(points: &[Point2<f64>], eps: f64) {
    let (expected, tie) = oracle(points, eps);
    for rule in [Tie::First, Tie::Last] {
        let run = |method, budget: Option<usize>| {
            let mut s = Simplifier::new(method, Metric::Line).with_tie(rule);
            if let Some(b) = budget {
                s = s.with_dp_budget(b);
            }
            s.indices(points, eps).unwrap()
        };
        let dp = run(Method::Dp, None);
        assert!(valid(points, &dp, eps, line_distance), "dp invalid");
        // Path hulls from the first split, after a tiny plain-DP phase, and with the
        // default budget: all equal plain DP on every input, ties included.
        for (name, budget) in [
            ("hull", None),
            ("pure hull", Some(0)),
            ("early hull", Some(1)),
        ] {
            assert_eq!(
                run(Method::Hull, budget),
                dp,
                "{name} differs from dp ({rule:?})"
            );
        }
        if !tie {
            assert_eq!(dp, expected, "dp differs from the oracle ({rule:?})");
        }
    }
}

fn eps_strategy() -> impl Strategy<Value = f64> {
    prop_oneof![Just(0.0), 0.0..0.01f64, 0.01..2.0f64, 2.0..20.0f64]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn random_walks(steps in prop::collection::vec((-1.0..1.0f64, -1.0..1.0f64), 0..400), eps in eps_strategy()) {
        check_all(&walk(&steps), eps);
    }

    #[test]
    fn circles_and_spirals(n in 3usize..600, turns in 0.2..6.0f64, growth in 0.0..3.0f64, noise in prop::collection::vec(-1e-3..1e-3f64, 600), eps in eps_strategy()) {
        let p: Vec<_> = (0..n).map(|k| {
            let t = turns * std::f64::consts::TAU * k as f64 / n as f64;
            let r = 10.0 + growth * t + noise[k];
            Point2::new(r * t.cos(), r * t.sin())
        }).collect();
        check_all(&p, eps);
    }

    #[test]
    fn zigzags(amps in prop::collection::vec(0.0..5.0f64, 2..500), grow in any::<bool>(), eps in eps_strategy()) {
        let n = amps.len();
        let p: Vec<_> = (0..n).map(|k| {
            let a = if grow { amps[k] * (1.0 + k as f64) } else { amps[k] };
            Point2::new(k as f64, if k % 2 == 0 { a } else { -a })
        }).collect();
        check_all(&p, eps);
    }

    #[test]
    fn lattice_walks_with_ties(steps in prop::collection::vec((-2i32..=2, -2i32..=2), 0..300), eps in prop_oneof![Just(0.0), Just(1.0), 0.0..3.0f64]) {
        // Integer coordinates: collinear runs, duplicates, revisits and exact ties.
        let p = walk(&steps.iter().map(|&(x, y)| (x as f64, y as f64)).collect::<Vec<_>>());
        check_all(&p, eps);
    }

    #[test]
    fn closed_rings(n in 4usize..300, seed in prop::collection::vec(0.5..1.5f64, 300), eps in eps_strategy()) {
        let mut p: Vec<_> = (0..n).map(|k| {
            let t = std::f64::consts::TAU * k as f64 / n as f64;
            Point2::new(10.0 * seed[k] * t.cos(), 10.0 * seed[k] * t.sin())
        }).collect();
        p.push(p[0]);
        check_all(&p, eps);
    }

    #[test]
    fn collinear_and_duplicates(ts in prop::collection::vec(-10.0..10.0f64, 0..200), dup in prop::collection::vec(any::<bool>(), 200), eps in eps_strategy()) {
        let mut p = Vec::new();
        for (k, &t) in ts.iter().enumerate() {
            p.push(Point2::new(2.0 * t + 1.0, -t));
            if dup[k] { p.push(Point2::new(2.0 * t + 1.0, -t)); }
        }
        check_all(&p, eps);
    }

    #[test]
    fn segment_metric_dp_matches_definition(steps in prop::collection::vec((-1.0..1.0f64, -1.0..1.0f64), 0..200), eps in eps_strategy()) {
        let p = walk(&steps);
        let (expected, tie) = oracle_with(&p, eps, segment_distance);
        for rule in [Tie::First, Tie::Last] {
            let kept = Simplifier::new(Method::Dp, Metric::Segment).with_tie(rule).indices(&p, eps).unwrap();
            prop_assert!(valid(&p, &kept, eps, segment_distance));
            if eps == 0.0 && rule == Tie::Last {
                // geo's rule: epsilon 0 returns the input unchanged.
                prop_assert_eq!(kept, (0..p.len()).collect::<Vec<_>>());
            } else if !tie {
                prop_assert_eq!(&kept, &expected);
            }
        }
    }
}

#[test]
fn all_identical_points_keep_the_ends() {
    let p = vec![Point2::new(3.0, -1.0); 50];
    for method in [Method::Hull, Method::Dp] {
        assert_eq!(
            simplify_indices(&p, 0.0, method, Metric::Line).unwrap(),
            vec![0, 49]
        );
    }
}

#[test]
fn short_inputs_come_back_unchanged() {
    for n in 0..3 {
        let p: Vec<_> = (0..n)
            .map(|k| Point2::new(k as f64, (k * k) as f64))
            .collect();
        let expected: Vec<usize> = if n < 2 { (0..n).collect() } else { vec![0, 1] };
        assert_eq!(
            simplify_indices(&p, 0.0, Method::Hull, Metric::Line).unwrap(),
            expected
        );
    }
}

#[test]
fn bad_input_is_refused() {
    let good = pts(&[(0.0, 0.0), (1.0, 1.0), (2.0, 0.0)]);
    for eps in [-1.0, f64::NAN, f64::INFINITY] {
        assert!(matches!(
            simplify_indices(&good, eps, Method::Dp, Metric::Line),
            Err(LineSimpError::InvalidEpsilon(_))
        ));
    }
    let bad = pts(&[(0.0, 0.0), (f64::NAN, 1.0), (2.0, 0.0)]);
    assert!(matches!(
        simplify_indices(&bad, 1.0, Method::Hull, Metric::Line),
        Err(LineSimpError::NonFinitePoint { index: 1, .. })
    ));
    let bad = pts(&[(0.0, 0.0), (1.0, 1.0), (2.0, f64::NEG_INFINITY)]);
    assert!(matches!(
        simplify_indices(&bad, 1.0, Method::Dp, Metric::Segment),
        Err(LineSimpError::NonFinitePoint { index: 2, .. })
    ));
    assert_eq!(
        simplify_indices(&good, 1.0, Method::Hull, Metric::Segment),
        Err(LineSimpError::UnsupportedMetric)
    );
}

#[test]
fn deep_zigzag_runs_without_recursion() {
    // Every chord's farthest vertex sits next to its end: a recursive DP would nest
    // n levels deep. Both methods must keep every vertex at eps = 0.
    let n = 100_000;
    let p: Vec<_> = (0..n)
        .map(|i| Point2::new(i as f64, if i % 2 == 0 { i as f64 } else { -(i as f64) }))
        .collect();
    let kept = Simplifier::new(Method::Hull, Metric::Line)
        .indices(&p, 0.0)
        .unwrap();
    assert_eq!(kept.len(), n);
    let small = &p[..3000];
    let kept = Simplifier::new(Method::Dp, Metric::Line)
        .indices(small, 0.0)
        .unwrap();
    assert_eq!(kept.len(), 3000);
}

#[test]
fn simplifier_reuse_gives_the_same_answer() {
    let a = walk(
        &(0..500)
            .map(|k| {
                (
                    ((k * 7919) % 13) as f64 - 6.0,
                    ((k * 104729) % 11) as f64 - 5.0,
                )
            })
            .collect::<Vec<_>>(),
    );
    let mut s = Simplifier::new(Method::Hull, Metric::Line);
    let first = s.indices(&a, 2.0).unwrap();
    let _ = s.indices(&a[..100], 0.5).unwrap();
    assert_eq!(s.indices(&a, 2.0).unwrap(), first);
}

#[test]
fn generic_inputs_are_tie_free_so_equality_is_really_checked() {
    // Guards the properties above: if the oracle flagged ties everywhere, the
    // hull == dp assertion would never run.
    use rand::{Rng, SeedableRng, rngs::StdRng};
    let mut rng = StdRng::seed_from_u64(42);
    let steps: Vec<(f64, f64)> = (0..2000)
        .map(|_| (rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)))
        .collect();
    let p = walk(&steps);
    for eps in [1e-3, 0.3, 3.0] {
        let (_, tie) = oracle(&p, eps);
        assert!(!tie, "a generic walk should have no ties at eps {eps}");
        check_all(&p, eps);
    }
}
