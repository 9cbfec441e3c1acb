//! The Douglas-Peucker algorithm of seed 000, Table 1, run with an explicit stack so
//! that a deep split sequence (a 10^6-point zig-zag) cannot overflow the call stack.

use std::cmp::Ordering;

use nalgebra::Point2;
use rperc_core::interrupt::Work;

use crate::Result;
use crate::metric::{Extent, LineChord, Metric, SegmentChord, SegmentFormula};

rperc_core::named_enum! {
    /// Which vertex splits a chord when several are equally far from it, and, for
    /// [`Metric::Segment`], whose arithmetic decides "equally far".
    ///
    /// - [`Metric::Line`] (ours, and the only metric of path hulls): distances are compared
    ///   exactly, so "equally far" means exactly equal distance to the chord's line, and
    ///   the rule picks the smallest or the largest index among those vertices. Plain DP
    ///   and path hulls return the same indices under either rule.
    /// - [`Metric::Segment`]: `First` reproduces GEOS (shapely) and `Last` reproduces geo
    ///   (the `simplification` Python package) index for index: each rule computes the
    ///   distance with its peer's formula (`sqrt` for GEOS, `hypot` for geo) and compares
    ///   the rounded values as the peer does. Under `Last`, epsilon 0 keeps every vertex,
    ///   as geo does.
    #[derive(Default)]
    pub enum Tie: "tie" {
        /// The first (smallest index) of the farthest vertices, as GEOS does.
        #[default]
        First = "first",
        /// The last (largest index) of the farthest vertices, as geo does.
        Last = "last",
    }
}

impl Tie {
    /// The preferred of two indices of equally far vertices.
    #[inline]
    pub(crate) fn pick(self, a: usize, b: usize) -> usize {
        match self {
            Tie::First => a.min(b),
            Tie::Last => a.max(b),
        }
    }

    pub(crate) fn segment_formula(self) -> SegmentFormula {
        match self {
            Tie::First => SegmentFormula::Geos,
            Tie::Last => SegmentFormula::Geo,
        }
    }
}

/// FindSplit, seed 000 Table 2, for the line metric: the vertex strictly between `i`
/// and `j` with the largest exact distance to the chord's line, `tie` choosing among
/// equals. Returns an index in `i + 1..j` (requires `j >= i + 2`).
///
/// One floating-point pass finds the largest key and the runner-up. When they are
/// further apart than the keys' round-off the largest is the answer; otherwise a
/// second pass compares exactly every vertex whose key is close to the largest.
pub(crate) fn find_split_line(
    points: &[Point2<f64>],
    i: usize,
    j: usize,
    chord: &LineChord,
    tie: Tie,
) -> usize {
    debug_assert!(j >= i + 2);
    let t = 3.0 * chord.tol();
    let (f, best, second) = if chord.is_degenerate() {
        largest_two(points, i, j, |p| chord.point_key(p))
    } else {
        largest_two(points, i, j, |p| chord.line_key(p).abs())
    };
    if best > second + t {
        return f;
    }
    // Near-ties: every vertex within the round-off of the largest key is a candidate.
    let floor = best - t;
    let mut win = f;
    let mut win_key = chord.key(&points[f]);
    for (k, p) in (i + 1..j).zip(&points[i + 1..j]) {
        let key = chord.key(p);
        if k == win || key.abs() < floor {
            continue;
        }
        match chord.cmp_abs(p, key, &points[win], win_key) {
            Ordering::Greater => (win, win_key) = (k, key),
            Ordering::Equal if tie.pick(k, win) == k => (win, win_key) = (k, key),
            _ => {}
        }
    }
    win
}

/// The index of the largest `key` strictly between `i` and `j` (the first if several),
/// the largest value and the runner-up (the largest of the others).
#[inline(always)]
fn largest_two(
    points: &[Point2<f64>],
    i: usize,
    j: usize,
    key: impl Fn(&Point2<f64>) -> f64,
) -> (usize, f64, f64) {
    let (mut best, mut second, mut f) = (f64::NEG_INFINITY, f64::NEG_INFINITY, i + 1);
    for (k, p) in (i + 1..j).zip(&points[i + 1..j]) {
        let d = key(p);
        // The runner-up without a second branch: the smaller of d and the old best.
        let lower = if d < best { d } else { best };
        second = if lower > second { lower } else { second };
        if d > best {
            best = d;
            f = k;
        }
    }
    (f, best, second)
}

/// FindSplit for the segment metric: the rounded peer distance, compared as the peer
/// compares it (`>` keeps the first maximum, `>=` the last). Returns the index, in
/// `i + 1..j`, and its key.
pub(crate) fn find_split_segment(
    points: &[Point2<f64>],
    i: usize,
    j: usize,
    chord: &SegmentChord,
    tie: Tie,
) -> (usize, f64) {
    debug_assert!(j >= i + 2);
    let mut best = (i + 1, chord.key(&points[i + 1]));
    let inner = (i + 2..j).zip(&points[i + 2..j]);
    match tie {
        Tie::First => {
            for (k, p) in inner {
                let d = chord.key(p);
                if d > best.1 {
                    best = (k, d);
                }
            }
        }
        Tie::Last => {
            for (k, p) in inner {
                let d = chord.key(p);
                if d >= best.1 {
                    best = (k, d);
                }
            }
        }
    }
    best
}

/// The split vertex of `i..=j` if Douglas-Peucker splits there (the farthest vertex is
/// farther than epsilon), for either metric.
pub(crate) fn split_at(
    points: &[Point2<f64>],
    i: usize,
    j: usize,
    epsilon: f64,
    metric: Metric,
    tie: Tie,
    extent: &Extent,
) -> Option<usize> {
    match metric {
        Metric::Line => {
            let chord = LineChord::new(points[i], points[j], extent);
            let f = find_split_line(points, i, j, &chord, tie);
            chord.exceeds(&points[f], epsilon).then_some(f)
        }
        Metric::Segment => {
            let chord = SegmentChord::new(points[i], points[j], extent, tie.segment_formula());
            let (f, key) = find_split_segment(points, i, j, &chord, tie);
            (key > chord.epsilon(epsilon)).then_some(f)
        }
    }
}

/// Marks in `keep` the vertices that Douglas-Peucker retains. `stack` is scratch space
/// reused across calls.
///
/// Termination: every popped range either stops or is split at `f` with `i < f < j`
/// into two strictly shorter ranges.
pub(crate) fn dp_mark(
    points: &[Point2<f64>],
    epsilon: f64,
    metric: Metric,
    tie: Tie,
    keep: &mut [bool],
    stack: &mut Vec<(usize, usize)>,
) -> Result<()> {
    let n = points.len();
    if metric == Metric::Segment && tie == Tie::Last && epsilon == 0.0 {
        keep.fill(true); // geo returns its input unchanged at epsilon 0
        return Ok(());
    }
    let extent = Extent::of(points)?;
    split_ranges(n, keep, stack, usize::MAX, |i, j| {
        split_at(points, i, j, epsilon, metric, tie, &extent)
    })
}

/// Douglas-Peucker's explicit stack over a chain of `n` vertices: each range taken from
/// `ranges` is split where `split(i, j)` says, that vertex marked in `keep`, until no
/// range is left or the ranges taken span more than `budget` vertices; then the range
/// taken last is back on `ranges` for the caller to finish another way.
pub(crate) fn split_ranges(
    n: usize,
    keep: &mut [bool],
    ranges: &mut Vec<(usize, usize)>,
    budget: usize,
    mut split: impl FnMut(usize, usize) -> Option<usize>,
) -> Result<()> {
    // Adversarial chains make this quadratic (minutes at 10^6 points): let Ctrl-C in.
    let mut meter = Work::new();
    let mut work = 0usize;
    ranges.clear();
    ranges.push((0, n - 1));
    while let Some((i, j)) = ranges.pop() {
        if j <= i + 1 {
            continue;
        }
        meter.advance((j - i) as u64)?;
        work = work.saturating_add(j - i - 1);
        if work > budget {
            ranges.push((i, j));
            break;
        }
        if let Some(f) = split(i, j) {
            keep[f] = true;
            // Left part on top: the output order does not depend on it, but it keeps
            // the traversal identical to the recursive Table 1.
            ranges.push((f, j));
            ranges.push((i, f));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use crate::{Method, Metric, Simplifier, Tie};
    use nalgebra::Point2;

    /// (1, 1) and (2, 1) are both at distance 1 from the chord on the x axis; whichever
    /// splits, the other is 1/sqrt(5) from its new chord, so it is dropped at eps 0.8.
    #[test]
    fn tie_rule_picks_first_or_last_of_equally_far_vertices() {
        let pts = [
            Point2::new(0.0, 0.0),
            Point2::new(1.0, 1.0),
            Point2::new(2.0, 1.0),
            Point2::new(3.0, 0.0),
        ];
        for metric in [Metric::Line, Metric::Segment] {
            for method in [Method::Dp, Method::Hull] {
                if method == Method::Hull && metric == Metric::Segment {
                    continue;
                }
                let first = Simplifier::new(method, metric).indices(&pts, 0.8).unwrap();
                let last = Simplifier::new(method, metric)
                    .with_tie(Tie::Last)
                    .indices(&pts, 0.8)
                    .unwrap();
                assert_eq!(first, vec![0, 1, 3]);
                assert_eq!(last, vec![0, 2, 3]);
            }
        }
    }
}
