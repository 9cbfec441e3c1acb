//! Shared by the integration tests: an exact Douglas-Peucker oracle on integer
//! coordinates, the configurations that must agree with it, and the real data.
#![allow(dead_code)] // each test binary uses its own subset

use std::path::PathBuf;

use linesimp::{Method, Metric, Simplifier, Tie};
use nalgebra::Point2;

/// Exact DP on integer coordinates (line metric). `eps_units` is epsilon in grid
/// units; `None` means epsilon 0 (keep every vertex off its chord's line).
pub fn oracle(xy: &[(i64, i64)], eps_units: Option<f64>, tie: Tie) -> Vec<usize> {
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
pub fn all_line_results(
    points: &[Point2<f64>],
    eps: f64,
    tie: Tie,
) -> Vec<(&'static str, Vec<usize>)> {
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

pub fn to_points(xy: &[(i64, i64)], unit: f64) -> Vec<Point2<f64>> {
    xy.iter()
        .map(|&(x, y)| Point2::new(x as f64 * unit, y as f64 * unit))
        .collect()
}

/// Checks all configurations against the oracle, for both tie rules; then again with
/// one vertex off the grid appended (when coordinates allow), so that the same exact
/// ties go through the filtered floating-point path and the exact expansions instead
/// of the shortcut for grid data.
pub fn check(xy: &[(i64, i64)], unit: f64, eps_units: Option<f64>) {
    check_once(xy, unit, eps_units);
    // Refine the grid by 2^shift, keeping every coordinate below 2^50 (exact in f64).
    let max = xy
        .iter()
        .map(|&(x, y)| x.abs().max(y.abs()))
        .max()
        .unwrap_or(0);
    let shift = 50 - (64 - max.leading_zeros() as i32);
    if !xy.is_empty() && shift >= 8 {
        let mut off: Vec<(i64, i64)> = xy.iter().map(|&(x, y)| (x << shift, y << shift)).collect();
        let last = off[off.len() - 1];
        off.push((last.0 + 1, last.1 + 3));
        let fine = 2f64.powi(shift);
        check_once(&off, unit / fine, eps_units.map(|e| e * fine));
    }
}

fn check_once(xy: &[(i64, i64)], unit: f64, eps_units: Option<f64>) {
    let pts = to_points(xy, unit);
    let eps = eps_units.map_or(0.0, |e| e * unit);
    for tie in [Tie::First, Tie::Last] {
        let expected = oracle(xy, eps_units, tie);
        for (name, got) in all_line_results(&pts, eps, tie) {
            assert_eq!(got, expected, "{name}, {tie:?}, eps {eps}, n {}", xy.len());
        }
    }
}

/// The shared data folder (`RPERC_DATA`, else `../shared/data` next to the
/// repository), or `None` with a note on stderr when it is absent.
pub fn data_dir() -> Option<PathBuf> {
    let dir = std::env::var_os("RPERC_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"));
    if dir.join("polylines").is_dir() {
        Some(dir)
    } else {
        eprintln!(
            "skipped: no polylines in {} (set RPERC_DATA)",
            dir.display()
        );
        None
    }
}

/// Every ring and line string of a WKT file: each innermost parenthesised list of
/// `x y` pairs. Panics with the file name on anything else (test data must parse).
pub fn read_wkt_rings(path: &std::path::Path) -> Vec<Vec<Point2<f64>>> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut rings = Vec::new();
    let mut rest = text.as_str();
    while let Some(close) = rest.find(')') {
        let open = rest[..close]
            .rfind('(')
            .unwrap_or_else(|| panic!("{}: unbalanced", path.display()));
        let body = &rest[open + 1..close];
        if !body.trim().is_empty() {
            let ring: Vec<Point2<f64>> = body
                .split(',')
                .map(|pair| {
                    let v: Vec<f64> = pair
                        .split_whitespace()
                        .map(|t| {
                            t.parse()
                                .unwrap_or_else(|e| panic!("{}: {t:?}: {e}", path.display()))
                        })
                        .collect();
                    assert!(v.len() >= 2, "{}: bad pair {pair:?}", path.display());
                    Point2::new(v[0], v[1])
                })
                .collect();
            rings.push(ring);
        }
        rest = &rest[close + 1..];
    }
    rings
}

/// All rings of every WKT file in the data folder, with their file names.
pub fn all_rings(dir: &std::path::Path) -> Vec<(String, Vec<Point2<f64>>)> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir.join("polylines"))
        .expect("polylines folder")
        .map(|e| e.expect("dir entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == "wkt"))
        .collect();
    files.sort();
    let mut out = Vec::new();
    for f in files {
        let name = f.file_name().unwrap().to_string_lossy().into_owned();
        for (k, ring) in read_wkt_rings(&f).into_iter().enumerate() {
            out.push((format!("{name}#{k}"), ring));
        }
    }
    out
}
