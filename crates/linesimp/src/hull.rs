//! Hershberger-Snoeyink path hulls: Douglas-Peucker in O(n log n).
//!
//! A path hull stores the convex hull of the chain `v_i ..= v_j` as two halves that
//! grow outward from a middle vertex, the *tag*. Each half is a Melkman deque whose
//! every change is logged, so splitting the chain at `f` only rolls one half back to
//! "hull of tag..f" instead of rebuilding it. The farthest vertex from the chord is an
//! extreme point of the hull in the chord's normal direction, found by binary search
//! on each half (Hershberger & Snoeyink 1992, cited as [15] in seed 000, section 2.1).
//!
//! Exactness: orientation tests and distance comparisons are exact (see
//! `metric::exact`), and each half records the duplicates and collinear vertices on its
//! boundary (see [`half`]). The farthest set of the hull is then exactly the farthest
//! set of plain DP, and the tie rule picks the same index from it, so path hulls return
//! plain DP's indices on every input, under both tie rules.

mod half;

use std::cmp::Ordering;

use nalgebra::Point2;
use rperc_core::interrupt::Work;

use crate::Result;
use crate::dp::{Tie, find_split_line, split_at, split_ranges};
use crate::metric::{Extent, LineChord, Metric};
use half::{Far, HalfHull};

/// A path hull over the chain `i..=j`, split at the tag.
#[derive(Debug, Default)]
pub(crate) struct PathHull {
    left: HalfHull,
    right: HalfHull,
    tag: usize,
    tie: Tie,
}

impl PathHull {
    /// Builds the path hull of `points[i..=j]` with the tag at the middle.
    /// `grid`: see `Extent::grid`.
    pub fn build(&mut self, points: &[Point2<f64>], i: usize, j: usize, tie: Tie, grid: bool) {
        self.tag = i + (j - i) / 2;
        self.tie = tie;
        self.left.reset(self.tag - i + 1, tie, grid);
        self.right.reset(j - self.tag + 1, tie, grid);
        for k in (i..=self.tag).rev() {
            self.left.insert(points, k as u32);
        }
        for k in self.tag..=j {
            self.right.insert(points, k as u32);
        }
    }

    pub fn tag(&self) -> usize {
        self.tag
    }

    /// The vertex of the current chain farthest from the chord's line, the tie rule
    /// choosing among exactly equal distances (the ends have distance 0).
    pub fn farthest(&self, points: &[Point2<f64>], chord: &LineChord) -> usize {
        let mut best: Option<Far> = None;
        for half in [&self.left, &self.right] {
            for sign in [1, -1] {
                let Some(c) = half.farthest(points, chord, sign) else {
                    continue;
                };
                best = Some(match best {
                    None => c,
                    Some(b) => {
                        let (pc, pb) = (&points[c.rep as usize], &points[b.rep as usize]);
                        match chord.cmp_abs(pc, c.key, pb, b.key) {
                            Ordering::Greater => c,
                            Ordering::Less => b,
                            Ordering::Equal => Far {
                                best: self.tie.pick(b.best as usize, c.best as usize) as u32,
                                ..b
                            },
                        }
                    }
                });
            }
        }
        best.map_or(self.tag, |b| b.best as usize)
    }

    /// After splitting at `f`, keep the hull of the part that still holds the tag:
    /// `f..=j` when `f <= tag`, `i..=f` otherwise.
    pub fn split(&mut self, f: usize) {
        if f <= self.tag {
            self.left.undo_to(self.tag - f + 1);
        } else {
            self.right.undo_to(f - self.tag + 1);
        }
    }

    /// Test support: the two halves.
    #[cfg(test)]
    fn halves(&self) -> (&HalfHull, &HalfHull) {
        (&self.left, &self.right)
    }
}

/// A pending Douglas-Peucker range; `fresh` ranges need a new path hull.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Task {
    i: usize,
    j: usize,
    fresh: bool,
}

/// Plain-DP work allowed per level of a balanced split tree before path hulls take
/// over. Real data stays below it, so path hulls run only where plain DP would turn
/// quadratic.
pub(crate) const DP_BUDGET_PER_LEVEL: usize = 4;

/// Douglas-Peucker with the line metric in O(n log n) worst case, marking kept vertices.
///
/// Plain DP scans are several times cheaper per vertex than path-hull upkeep, and on
/// real data (coastlines, random walks, scans) they finish in O(n log n). So, as
/// introsort does for quicksort, we run plain DP under a work budget of
/// `dp_budget_per_level * n * log2(n)` distance evaluations and hand whatever ranges
/// remain to path hulls only when the budget runs out (zig-zags and other
/// adversarial chains). Both phases split at the same vertex (exactly the farthest,
/// `tie` choosing among equals), so the result does not depend on where the
/// hand-over happens.
#[allow(clippy::too_many_arguments)]
pub(crate) fn hull_mark(
    points: &[Point2<f64>],
    epsilon: f64,
    tie: Tie,
    keep: &mut [bool],
    ranges: &mut Vec<(usize, usize)>,
    tasks: &mut Vec<Task>,
    hull: &mut PathHull,
    dp_budget_per_level: usize,
) -> Result<()> {
    let n = points.len();
    let extent = Extent::of(points)?;
    let budget = dp_budget_per_level
        .saturating_mul(n)
        .saturating_mul((usize::BITS - n.leading_zeros()) as usize);
    split_ranges(n, keep, ranges, budget, |i, j| {
        split_at(points, i, j, epsilon, Metric::Line, tie, &extent)
    })?;
    if ranges.is_empty() {
        return Ok(());
    }
    tasks.clear();
    tasks.extend(ranges.drain(..).map(|(i, j)| Task { i, j, fresh: true }));
    path_hull_mark(points, epsilon, tie, &extent, keep, tasks, hull)
}

/// Douglas-Peucker with path hulls on the pending `tasks`, marking kept vertices.
/// The part of a split that holds the tag is processed first with the rolled-back
/// hull (it sits on top of the stack); the other part is rebuilt afterwards.
///
/// Termination: a task either stops or splits at `f` with `i < f < j` (the ends are at
/// distance 0 from their chord, so a vertex farther than epsilon is inside).
pub(crate) fn path_hull_mark(
    points: &[Point2<f64>],
    epsilon: f64,
    tie: Tie,
    extent: &Extent,
    keep: &mut [bool],
    tasks: &mut Vec<Task>,
    hull: &mut PathHull,
) -> Result<()> {
    let mut meter = Work::new();
    while let Some(Task { i, j, fresh }) = tasks.pop() {
        if j <= i + 1 {
            continue;
        }
        if fresh {
            meter.advance((j - i) as u64)?;
            hull.build(points, i, j, tie, extent.grid);
        } else {
            // A rolled-back hull answers in O(log n): count it as a few units.
            meter.advance(16)?;
        }
        let chord = LineChord::new(points[i], points[j], extent);
        let f = if chord.is_degenerate() {
            // Farthest from a point is no extreme in a direction: scan this range.
            find_split_line(points, i, j, &chord, tie)
        } else {
            hull.farthest(points, &chord)
        };
        if !chord.exceeds(&points[f], epsilon) {
            continue;
        }
        debug_assert!(i < f && f < j, "split {f} outside ({i}, {j})");
        keep[f] = true;
        let keeps_left_part = f > hull.tag();
        hull.split(f);
        let (first, second) = if keeps_left_part {
            ((f, j), (i, f))
        } else {
            ((i, f), (f, j))
        };
        tasks.push(Task {
            i: first.0,
            j: first.1,
            fresh: true,
        });
        tasks.push(Task {
            i: second.0,
            j: second.1,
            fresh: false,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metric::orient_on;

    /// Checks the invariants of both halves against brute force over the chain they
    /// hold: strictly convex corners, and records equal to the preferred index among
    /// the chain vertices on each corner and inside each edge.
    fn check_half(points: &[Point2<f64>], half: &half::HalfHull, chain: &[usize], tie: Tie) {
        let (corners, edges) = half.snapshot();
        let m = corners.len();
        let p = |k: u32| &points[k as usize];
        if m >= 3 {
            for s in 0..m {
                let (a, b, c) = (corners[s], corners[(s + 1) % m], corners[(s + 2) % m]);
                assert_eq!(
                    orient_on(false, p(a), p(b), p(c)),
                    1,
                    "not strictly convex at {s}"
                );
            }
        }
        let prefer = |v: &[usize]| match tie {
            Tie::First => v.iter().min().copied(),
            Tie::Last => v.iter().max().copied(),
        };
        for s in 0..m {
            let same: Vec<usize> = chain
                .iter()
                .copied()
                .filter(|&k| points[k] == *p(corners[s]))
                .collect();
            assert_eq!(
                Some(corners[s] as usize),
                prefer(&same),
                "corner record {s}"
            );
            if m >= 2 {
                let (u, w) = (p(corners[s]), p(corners[(s + 1) % m]));
                let inner: Vec<usize> = chain
                    .iter()
                    .copied()
                    .filter(|&k| {
                        let q = &points[k];
                        q != u
                            && q != w
                            && orient_on(false, u, w, q) == 0
                            && u.x.min(w.x) <= q.x
                            && q.x <= u.x.max(w.x)
                            && u.y.min(w.y) <= q.y
                            && q.y <= u.y.max(w.y)
                    })
                    .collect();
                let rec = (edges[s] != half::NONE).then_some(edges[s] as usize);
                assert_eq!(rec, prefer(&inner), "edge record {s}");
            }
        }
    }

    fn lattice(n: usize, seed: u64) -> Vec<Point2<f64>> {
        // A small deterministic generator: many duplicates, collinear runs, crossings.
        let mut s = seed;
        let mut p = Point2::new(0.0, 0.0);
        (0..n)
            .map(|_| {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let (dx, dy) = (((s >> 33) % 3) as f64 - 1.0, ((s >> 40) % 3) as f64 - 1.0);
                p += nalgebra::Vector2::new(dx, dy);
                p
            })
            .collect()
    }

    #[test]
    fn halves_keep_their_invariants_through_inserts_and_undos() {
        for seed in 0..200u64 {
            let pts = lattice(40, seed);
            for (tie, grid) in [(Tie::First, false), (Tie::Last, false), (Tie::First, true)] {
                let mut hull = PathHull::default();
                hull.build(&pts, 0, pts.len() - 1, tie, grid);
                let tag = hull.tag();
                let (l, r) = hull.halves();
                check_half(&pts, l, &(0..=tag).collect::<Vec<_>>(), tie);
                check_half(&pts, r, &(tag..pts.len()).collect::<Vec<_>>(), tie);
                // Roll the right half back step by step, the left half too.
                for f in (tag + 1..pts.len()).rev() {
                    hull.split(f);
                    check_half(&pts, hull.halves().1, &(tag..=f).collect::<Vec<_>>(), tie);
                }
                for f in 0..=tag {
                    hull.split(f);
                    check_half(&pts, hull.halves().0, &(f..=tag).collect::<Vec<_>>(), tie);
                }
            }
        }
    }
}
