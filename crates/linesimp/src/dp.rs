//! The Douglas-Peucker algorithm of seed 000, Table 1, run with an explicit stack so
//! that a deep split sequence (a 10^6-point zig-zag) cannot overflow the call stack.

use nalgebra::Point2;

use crate::metric::{Chord, Metric};

/// FindSplit, seed 000 Table 2: the vertex strictly between `i` and `j` farthest from
/// the chord, with its key. Ties keep the first such vertex (strict `>`), as GEOS does.
#[inline]
pub(crate) fn find_split(
    points: &[Point2<f64>],
    i: usize,
    j: usize,
    chord: &Chord,
) -> (usize, f64) {
    let mut best = (i, f64::NEG_INFINITY);
    for (k, p) in points.iter().enumerate().take(j).skip(i + 1) {
        let d = chord.key(p);
        if d > best.1 {
            best = (k, d);
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
        let (f, key) = find_split(points, i, j, &chord);
        if chord.exceeds(key, epsilon) {
            keep[f] = true;
            // Left part on top: the output order does not depend on it, but it keeps
            // the traversal identical to the recursive Table 1.
            stack.push((f, j));
            stack.push((i, f));
        }
    }
}
