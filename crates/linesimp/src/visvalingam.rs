//! Visvalingam-Whyatt simplification (Visvalingam & Whyatt 1993): repeatedly remove
//! the vertex whose triangle with its two current neighbours (its *effective area*) is
//! smallest, until every remaining area exceeds the threshold.
//!
//! A binary heap with lazy deletion keeps it O(n log n): when a vertex goes, its two
//! neighbours get fresh heap entries and their old ones are skipped when popped (an
//! entry is current only while the vertex's neighbours are still the ones it was
//! computed with).
//!
//! Conventions, chosen to match the `simplification` Python package (geo's
//! `SimplifyVwIdx`) so that it can serve as a test peer:
//! - the effective area is the triangle area, half the cross product;
//! - a vertex goes when its area is `<= epsilon` (not strictly below), so `epsilon = 0`
//!   removes exactly collinear and repeated vertices;
//! - a recomputed area is not raised to the last eliminated one (the paper's rule for
//!   ranking every vertex does not apply once a threshold is given);
//! - both end points stay, also when they coincide (a closed ring keeps its closing
//!   vertex, and may collapse to those two points).
//!
//! Ties (equal areas) go smallest vertex index first, which makes the result
//! reproducible; the peer leaves them to its heap's order.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use nalgebra::Point2;

/// "No neighbour": the end points have only one.
const NONE: u32 = u32::MAX;

/// A heap entry: vertex `vertex` has area `area` with neighbours `prev` and `next`.
#[derive(Debug, Clone, Copy)]
struct Candidate {
    area: f64,
    vertex: u32,
    prev: u32,
    next: u32,
}

impl Ord for Candidate {
    /// Reversed, so that `BinaryHeap` (a max-heap) pops the smallest area, and among
    /// equal areas the smallest index.
    fn cmp(&self, other: &Self) -> Ordering {
        other
            .area
            .total_cmp(&self.area)
            .then_with(|| other.vertex.cmp(&self.vertex))
    }
}

impl PartialOrd for Candidate {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl PartialEq for Candidate {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}

impl Eq for Candidate {}

/// Buffers reused across calls: the doubly linked list of surviving vertices and the
/// heap.
#[derive(Debug, Default)]
pub(crate) struct Scratch {
    prev: Vec<u32>,
    next: Vec<u32>,
    heap: Vec<Candidate>,
}

/// Effective area of `p` between `a` and `b`: the area of the triangle (a, p, b).
#[inline]
pub(crate) fn effective_area(a: &Point2<f64>, p: &Point2<f64>, b: &Point2<f64>) -> f64 {
    0.5 * ((p.x - a.x) * (b.y - a.y) - (p.y - a.y) * (b.x - a.x)).abs()
}

fn candidate(points: &[Point2<f64>], prev: u32, vertex: u32, next: u32) -> Candidate {
    let at = |k: u32| &points[k as usize];
    Candidate {
        area: effective_area(at(prev), at(vertex), at(next)),
        vertex,
        prev,
        next,
    }
}

/// Sets `keep[k]` for the vertices that survive `epsilon` (an area). `points` has at
/// least three vertices and fewer than `u32::MAX` (checked by the caller).
pub(crate) fn vw_mark(
    points: &[Point2<f64>],
    epsilon: f64,
    keep: &mut [bool],
    scratch: &mut Scratch,
) {
    let n = points.len();
    debug_assert!(n >= 3 && n < NONE as usize);
    let last = (n - 1) as u32;
    keep.fill(true);
    let Scratch { prev, next, heap } = scratch;
    prev.clear();
    next.clear();
    prev.extend((0..n as u32).map(|k| k.checked_sub(1).unwrap_or(NONE)));
    next.extend((1..=n as u32).map(|k| if k > last { NONE } else { k }));
    heap.clear();
    heap.extend((1..last).map(|k| candidate(points, k - 1, k, k + 1)));
    // `from` heapifies in O(n); the vector's buffer comes back for the next call.
    let mut queue = BinaryHeap::from(std::mem::take(heap));
    while let Some(c) = queue.pop() {
        // NaN (from overflowing coordinates) sorts last and is never `<= epsilon`.
        if c.area.is_nan() || c.area > epsilon {
            break;
        }
        let v = c.vertex as usize;
        if !keep[v] || prev[v] != c.prev || next[v] != c.next {
            continue; // stale: a neighbour went since this entry was pushed
        }
        keep[v] = false;
        let (p, q) = (c.prev as usize, c.next as usize);
        next[p] = c.next;
        prev[q] = c.prev;
        if prev[p] != NONE {
            queue.push(candidate(points, prev[p], c.prev, c.next));
        }
        if next[q] != NONE {
            queue.push(candidate(points, c.prev, c.next, next[q]));
        }
    }
    *heap = queue.into_vec();
}

#[cfg(test)]
mod tests {
    use nalgebra::Point2;

    use crate::{Method, Metric, Simplifier};

    fn vw(points: &[Point2<f64>], epsilon: f64) -> Vec<usize> {
        Simplifier::new(Method::Visvalingam, Metric::Line)
            .indices(points, epsilon)
            .unwrap()
    }

    /// Areas: (1,1) 1.0, (2,0) 1.5, (3,2) 2.0. Once (1,1) is gone, (2,0) has area 2.0
    /// between (0,0) and (3,2): a tie with (3,2) that the smaller index wins; (3,2) then
    /// has area 4.0 between (0,0) and (4,0).
    #[test]
    fn threshold_is_inclusive_and_ties_go_by_index() {
        let pts = [
            Point2::new(0.0, 0.0),
            Point2::new(1.0, 1.0),
            Point2::new(2.0, 0.0),
            Point2::new(3.0, 2.0),
            Point2::new(4.0, 0.0),
        ];
        assert_eq!(vw(&pts, 0.0), vec![0, 1, 2, 3, 4]);
        assert_eq!(vw(&pts, 0.99), vec![0, 1, 2, 3, 4]);
        assert_eq!(vw(&pts, 1.0), vec![0, 2, 3, 4]);
        assert_eq!(vw(&pts, 2.0), vec![0, 3, 4]);
        assert_eq!(vw(&pts, 3.99), vec![0, 3, 4]);
        assert_eq!(vw(&pts, 4.0), vec![0, 4]);
    }

    #[test]
    fn closed_ring_keeps_both_ends_and_may_collapse() {
        let ring = [
            Point2::new(0.0, 0.0),
            Point2::new(1.0, 0.0),
            Point2::new(1.0, 1.0),
            Point2::new(0.0, 1.0),
            Point2::new(0.0, 0.0),
        ];
        assert_eq!(vw(&ring, 0.4), vec![0, 1, 2, 3, 4]);
        assert_eq!(vw(&ring, 1e9), vec![0, 4]);
    }

    #[test]
    fn exact_duplicates_and_collinear_vertices_go_at_zero() {
        let pts = [
            Point2::new(0.0, 0.0),
            Point2::new(0.0, 0.0),
            Point2::new(1.0, 1.0),
            Point2::new(2.0, 2.0),
            Point2::new(2.0, 3.0),
        ];
        assert_eq!(vw(&pts, 0.0), vec![0, 3, 4]);
    }

    #[test]
    fn segment_metric_is_refused() {
        let pts = [Point2::new(0.0, 0.0); 3];
        let err = Simplifier::new(Method::Visvalingam, Metric::Segment)
            .indices(&pts, 1.0)
            .unwrap_err();
        assert!(err.to_string().contains("metric"), "{err}");
    }
}
