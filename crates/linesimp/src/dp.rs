//! The Douglas-Peucker algorithm of seed 000, Table 1, run with an explicit stack so
//! that a deep split sequence (a 10^6-point zig-zag) cannot overflow the call stack.

use nalgebra::Point2;

use crate::metric::{Chord, Metric};

rperc_core::named_enum! {
    /// Which vertex splits a chord when several are equally far from it.
    ///
    /// The peers disagree: GEOS (shapely) splits at the first, geo (and so the
    /// `simplification` Python package) at the last. Either rule gives a valid result;
    /// pick the one whose output you must reproduce exactly.
    #[derive(Default)]
    pub enum Tie: "tie" {
        /// The first (smallest index) of the farthest vertices, as GEOS does.
        #[default]
        First = "first",
        /// The last (largest index) of the farthest vertices, as geo does.
        Last = "last",
    }
}

/// FindSplit, seed 000 Table 2: the vertex strictly between `i` and `j` farthest from
/// the chord, with its key; `tie` picks among equally far vertices.
#[inline]
pub(crate) fn find_split(
    points: &[Point2<f64>],
    i: usize,
    j: usize,
    chord: &Chord,
    tie: Tie,
) -> (usize, f64) {
    let mut best = (i, f64::NEG_INFINITY);
    let inner = points.iter().enumerate().take(j).skip(i + 1);
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

/// Marks in `keep` the vertices that Douglas-Peucker retains. `stack` is scratch space
/// reused across calls.
pub(crate) fn dp_mark(
    points: &[Point2<f64>],
    epsilon: f64,
    metric: Metric,
    tie: Tie,
    keep: &mut [bool],
    stack: &mut Vec<(usize, usize)>,
) {
    let n = points.len();
    stack.clear();
    stack.push((0, n - 1));
    while let Some((i, j)) = stack.pop() {
        if j <= i + 1 {
            continue;
        }
        let chord = Chord::new(points[i], points[j], metric);
        let (f, key) = find_split(points, i, j, &chord, tie);
        if chord.exceeds(key, epsilon) {
            keep[f] = true;
            // Left part on top: the output order does not depend on it, but it keeps
            // the traversal identical to the recursive Table 1.
            stack.push((f, j));
            stack.push((i, f));
        }
    }
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
            let first = Simplifier::new(Method::Dp, metric)
                .indices(&pts, 0.8)
                .unwrap();
            let last = Simplifier::new(Method::Dp, metric)
                .with_tie(Tie::Last)
                .indices(&pts, 0.8)
                .unwrap();
            assert_eq!(first, vec![0, 1, 3]);
            assert_eq!(last, vec![0, 2, 3]);
        }
    }
}
