//! Every ring of the real data (`../shared/data/polylines`): path hulls equal plain
//! Douglas-Peucker index for index, under both tie rules, with pure path hulls
//! (budget 0), an early hand-over and the default budget; raw, snapped to grids (exact
//! ties everywhere, checked against the exact oracle as well) and behind a 1000-point
//! zig-zag that forces path hulls to take over. Skips with a note when the data folder
//! is absent.

use crate::common::{all_line_results, all_rings, check, data_dir, oracle};
use linesimp::{Metric, Tie, chord_distance};
use nalgebra::Point2;

/// Tolerances relative to the ring's size, plus 0 and the exact distances of a few
/// vertices to the full chord (the threshold then lands exactly on a vertex).
fn tolerances(ring: &[Point2<f64>]) -> Vec<f64> {
    let (mut lo, mut hi) = (ring[0], ring[0]);
    for p in ring {
        lo = lo.inf(p);
        hi = hi.sup(p);
    }
    let size = (hi - lo).amax();
    let mut eps = vec![0.0];
    eps.extend([1e-7, 1e-5, 1e-4, 1e-3, 1e-2, 0.1].map(|r| r * size));
    let n = ring.len();
    for k in [n / 7, n / 3, n / 2, 5 * n / 6] {
        if 0 < k && k + 1 < n {
            let (a, b) = (ring[0], ring[n - 1]);
            eps.push(chord_distance(&ring[k], &a, &b, Metric::Line));
            eps.push(chord_distance(
                &ring[k],
                &ring[k - 1],
                &ring[k + 1],
                Metric::Line,
            ));
        }
    }
    eps
}

fn assert_all_agree(name: &str, pts: &[Point2<f64>], eps: f64) -> usize {
    let mut checks = 0;
    for tie in [Tie::First, Tie::Last] {
        let results = all_line_results(pts, eps, tie);
        for (config, got) in &results[1..] {
            assert_eq!(
                got, &results[0].1,
                "{name}: {config} vs dp, {tie:?}, eps {eps:e}"
            );
            checks += 1;
        }
    }
    checks
}

/// The ring on a grid of `cells` cells across, as integers (duplicates and collinear
/// runs appear wherever the grid is coarser than the data).
fn snap(ring: &[Point2<f64>], cells: f64) -> Vec<(i64, i64)> {
    let (mut lo, mut hi) = (ring[0], ring[0]);
    for p in ring {
        lo = lo.inf(p);
        hi = hi.sup(p);
    }
    let cell = (hi - lo).amax() / cells;
    ring.iter()
        .map(|p| {
            (
                ((p.x - lo.x) / cell).round() as i64,
                ((p.y - lo.y) / cell).round() as i64,
            )
        })
        .collect()
}

fn zigzag_prefix(len: i64) -> Vec<(i64, i64)> {
    (0..len)
        .map(|k| (-len + k, if k % 2 == 0 { k } else { -k }))
        .collect()
}

#[test]
fn raw_rings_hull_equals_dp() {
    let Some(dir) = data_dir() else { return };
    let mut checks = 0;
    for (name, ring) in all_rings(&dir) {
        for eps in tolerances(&ring) {
            checks += assert_all_agree(&name, &ring, eps);
        }
    }
    assert!(checks > 100, "only {checks} checks ran");
}

#[test]
fn snapped_rings_match_the_exact_oracle() {
    let Some(dir) = data_dir() else { return };
    for (name, ring) in all_rings(&dir) {
        for cells in [100.0, 1e3, 1e4, 1e6] {
            let xy = snap(&ring, cells);
            for eps_units in [
                None,
                Some(0.5),
                Some(1.0),
                Some(std::f64::consts::SQRT_2),
                Some(7.3),
            ] {
                check(&xy, 1.0, eps_units);
                // The same behind a zig-zag, where plain DP runs out of budget at once.
                let mut zz = zigzag_prefix(1000);
                zz.extend(&xy);
                check(&zz, 1.0, eps_units);
            }
            let _ = &name;
        }
    }
}

#[test]
fn snapped_rings_at_vertex_distances() {
    let Some(dir) = data_dir() else { return };
    for (name, ring) in all_rings(&dir) {
        let xy = snap(&ring, 1e3);
        let pts: Vec<Point2<f64>> = xy
            .iter()
            .map(|&(x, y)| Point2::new(x as f64, y as f64))
            .collect();
        for eps in tolerances(&pts) {
            assert_all_agree(&format!("{name} snapped"), &pts, eps);
        }
        // Sanity: the oracle really keeps and drops vertices here.
        let kept = oracle(&xy, Some(2.0), Tie::First).len();
        assert!(
            2 < kept && kept < xy.len(),
            "{name}: {kept} of {}",
            xy.len()
        );
    }
}
