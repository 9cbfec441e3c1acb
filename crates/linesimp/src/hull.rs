//! Hershberger-Snoeyink path hulls: Douglas-Peucker in O(n log n).
//!
//! A path hull stores the convex hull of the chain `v_i ..= v_j` as two halves that
//! grow outward from a middle vertex, the *tag*. Each half is a Melkman deque whose
//! every change is logged, so splitting the chain at `f` only rolls one half back to
//! "hull of tag..f" instead of rebuilding it. The farthest vertex from the chord is an
//! extreme point of the hull in the chord's normal direction, found by binary search
//! on each half (Hershberger & Snoeyink 1992, cited as [15] in seed 000, section 2.1).
//!
//! Melkman's algorithm assumes a simple chain. Real data (and random walks) cross
//! themselves, and then Melkman silently drops a vertex that leaves the hull away from
//! the deque ends. We therefore confirm every "inside" verdict with an O(log h)
//! point-in-hull test and, when it fails, rebuild that half from its hull vertices
//! with a monotone chain. The result is exact for any chain; on simple chains the
//! extra cost is the O(log h) test per discarded vertex.

use nalgebra::Point2;

use crate::metric::{Chord, cross};

/// Hull sizes up to this are scanned linearly: cheaper than a binary search and
/// immune to round-off in the unimodality argument.
const LINEAR_SCAN_MAX: usize = 8;

#[derive(Clone, Copy, Debug)]
enum Op {
    /// A vertex was pushed on both ends of the deque.
    Push,
    /// This vertex was popped from the top.
    PopTop(u32),
    /// This vertex was popped from the bottom.
    PopBot(u32),
    /// The deque was replaced wholesale; the old contents sit in `saved[from..]`.
    Replace { from: u32, bot: u32, top: u32 },
}

/// One half of a path hull: a Melkman deque `elt[bot..=top]` holding the hull's
/// vertices counter-clockwise, with the most recent hull vertex at both ends.
#[derive(Debug, Default)]
struct HalfHull {
    elt: Vec<u32>,
    bot: usize,
    top: usize,
    /// Undo log of deque operations.
    log: Vec<Op>,
    /// `starts[m]` is the log length before the m-th insertion.
    starts: Vec<u32>,
    saved: Vec<u32>,
    scratch: Vec<u32>,
    chain: Vec<u32>,
}

#[inline(always)]
fn pt(points: &[Point2<f64>], k: u32) -> &Point2<f64> {
    &points[k as usize]
}

impl HalfHull {
    /// Empties the hull, sizing the deque for up to `n` insertions.
    fn reset(&mut self, n: usize) {
        if self.elt.len() < 2 * n + 4 {
            self.elt.resize(2 * n + 4, 0);
        }
        // Empty is top == bot - 1; every insertion moves bot down by at most one and
        // top up by at most two, so `n + 2` leaves room both ways.
        self.bot = n + 2;
        self.top = n + 1;
        self.log.clear();
        self.starts.clear();
        self.saved.clear();
    }

    #[inline(always)]
    fn len(&self) -> usize {
        self.top + 1 - self.bot
    }

    /// Number of distinct hull vertices.
    #[inline(always)]
    fn distinct(&self) -> usize {
        self.len().saturating_sub(1)
    }

    #[inline(always)]
    fn vertex(&self, s: usize) -> u32 {
        self.elt[self.bot + s]
    }

    fn insert(&mut self, points: &[Point2<f64>], k: u32) {
        self.starts.push(self.log.len() as u32);
        if self.distinct() < 3 {
            self.rebuild(points, k);
            return;
        }
        let p = pt(points, k);
        let left_of = |a: u32, b: u32| cross(pt(points, a), pt(points, b), p) > 0.0;
        let (bot, top) = (self.bot, self.top);
        if left_of(self.elt[top - 1], self.elt[top]) && left_of(self.elt[bot], self.elt[bot + 1]) {
            // Melkman's test says "inside"; on a self-intersecting chain it may not be.
            if !self.contains(points, p) {
                self.rebuild(points, k);
            }
            return;
        }
        while self.top > self.bot + 1 && !left_of(self.elt[self.top - 1], self.elt[self.top]) {
            self.log.push(Op::PopTop(self.elt[self.top]));
            self.top -= 1;
        }
        while self.top > self.bot + 1 && !left_of(self.elt[self.bot], self.elt[self.bot + 1]) {
            self.log.push(Op::PopBot(self.elt[self.bot]));
            self.bot += 1;
        }
        self.bot -= 1;
        self.top += 1;
        self.elt[self.bot] = k;
        self.elt[self.top] = k;
        self.log.push(Op::Push);
    }

    /// Point-in-convex-polygon by binary search over the fan at `V_0`, assuming `p` is
    /// already strictly inside the wedge at `V_0`. Boundary counts as inside.
    fn contains(&self, points: &[Point2<f64>], p: &Point2<f64>) -> bool {
        let h = self.distinct();
        let v0 = pt(points, self.vertex(0));
        // Invariant: cross(V0, V_lo, p) >= 0 and cross(V0, V_hi, p) < 0.
        let (mut lo, mut hi) = (1, h - 1);
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if cross(v0, pt(points, self.vertex(mid)), p) >= 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        cross(
            pt(points, self.vertex(lo)),
            pt(points, self.vertex(lo + 1)),
            p,
        ) >= 0.0
    }

    /// Slow path for degenerate hulls (fewer than three vertices) and for vertices
    /// that leave the hull away from the deque ends: recompute the hull of the current
    /// vertices plus `k` (monotone chain) and put `k` at both ends.
    fn rebuild(&mut self, points: &[Point2<f64>], k: u32) {
        self.scratch.clear();
        if self.len() >= 2 {
            self.scratch
                .extend_from_slice(&self.elt[self.bot..self.top]);
        }
        self.scratch.push(k);
        // Sort by (x, y); among equal coordinates the old vertex wins, so a duplicate
        // of an existing vertex changes nothing.
        self.scratch.sort_unstable_by(|&a, &b| {
            let (pa, pb) = (pt(points, a), pt(points, b));
            pa.x.total_cmp(&pb.x)
                .then(pa.y.total_cmp(&pb.y))
                .then((a == k).cmp(&(b == k)))
        });
        self.scratch
            .dedup_by(|b, a| pt(points, *a) == pt(points, *b));
        monotone_chain(points, &self.scratch, &mut self.chain);
        let Some(at) = self.chain.iter().position(|&v| v == k) else {
            return; // `k` is inside or duplicates a vertex: the hull is unchanged.
        };
        self.chain.rotate_left(at);
        let from = self.saved.len() as u32;
        self.saved
            .extend_from_slice(&self.elt[self.bot..self.bot + self.len()]);
        self.log.push(Op::Replace {
            from,
            bot: self.bot as u32,
            top: self.top as u32,
        });
        let new_bot = if self.len() == 0 {
            self.bot
        } else {
            self.bot - 1
        };
        let m = self.chain.len();
        self.elt[new_bot..new_bot + m].copy_from_slice(&self.chain);
        self.elt[new_bot + m] = k;
        self.bot = new_bot;
        self.top = new_bot + m;
    }

    /// Rolls the hull back to its state after the first `m` insertions.
    fn undo_to(&mut self, m: usize) {
        let Some(&target) = self.starts.get(m) else {
            return;
        };
        while self.log.len() > target as usize {
            match self.log.pop().expect("log is longer than target") {
                Op::Push => {
                    self.bot += 1;
                    self.top -= 1;
                }
                Op::PopTop(v) => {
                    self.top += 1;
                    self.elt[self.top] = v;
                }
                Op::PopBot(v) => {
                    self.bot -= 1;
                    self.elt[self.bot] = v;
                }
                Op::Replace { from, bot, top } => {
                    let (from, bot, top) = (from as usize, bot as usize, top as usize);
                    let len = top + 1 - bot;
                    self.elt[bot..bot + len].copy_from_slice(&self.saved[from..from + len]);
                    self.saved.truncate(from);
                    self.bot = bot;
                    self.top = top;
                }
            }
        }
        self.starts.truncate(m);
    }

    /// The hull vertex farthest from the chord's line, as (point index, |cross|).
    /// Ties go to the smaller point index, like the first-wins rule of `find_split`.
    fn farthest(&self, points: &[Point2<f64>], chord: &Chord) -> Option<(usize, f64)> {
        let h = self.distinct();
        if h == 0 {
            return None;
        }
        let f = |s: usize| cross(&chord.a, &chord.b, pt(points, self.vertex(s % h)));
        let mut best: Option<(usize, f64)> = None;
        let mut consider = |s: usize| {
            let idx = self.vertex(s % h) as usize;
            let key = f(s).abs();
            match best {
                Some((bi, bk)) if key < bk || (key == bk && idx >= bi) => {}
                _ => best = Some((idx, key)),
            }
        };
        if h <= LINEAR_SCAN_MAX {
            (0..h).for_each(&mut consider);
        } else {
            for sign in [1.0, -1.0] {
                let s = argmax_cyclic(h, |s| sign * f(s));
                // Neighbours catch an exact plateau and the smaller index on ties.
                consider(s + h - 1);
                consider(s);
                consider(s + 1);
            }
        }
        best
    }
}

/// Andrew's monotone chain on vertices sorted by (x, y) without duplicates:
/// counter-clockwise, collinear points dropped, starting at the lowest-leftmost.
fn monotone_chain(points: &[Point2<f64>], sorted: &[u32], out: &mut Vec<u32>) {
    out.clear();
    if sorted.len() <= 2 {
        out.extend_from_slice(sorted);
        return;
    }
    let turns_left = |out: &[u32], c: u32| {
        let n = out.len();
        cross(
            pt(points, out[n - 2]),
            pt(points, out[n - 1]),
            pt(points, c),
        ) > 0.0
    };
    for &c in sorted {
        while out.len() >= 2 && !turns_left(out, c) {
            out.pop();
        }
        out.push(c);
    }
    let lower = out.len();
    for &c in sorted.iter().rev().skip(1) {
        while out.len() > lower && !turns_left(out, c) {
            out.pop();
        }
        out.push(c);
    }
    out.pop(); // the first vertex again
}

/// Index of the maximum of a cyclic unimodal sequence `f(0..h)` — the values of a
/// linear function around a strictly convex polygon — in O(log h), then polished by
/// local ascent in case round-off broke unimodality near a tie.
fn argmax_cyclic(h: usize, f: impl Fn(usize) -> f64) -> usize {
    let f0 = f(0);
    let up = |k: usize| f((k + 1) % h) > f(k);
    let mut s = if f(1) > f0 {
        // Rising from V_0: find the last k of the first rising run (f(k) >= f0).
        let (mut lo, mut hi) = (0, h);
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if up(mid) && f(mid) >= f0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        (lo + 1) % h
    } else if !(f(1) < f0 || up(1)) {
        0 // V_0 and V_1 share the maximum
    } else {
        // Falling from V_0: skip the descent (f < f0) and the climb after it.
        let (mut lo, mut hi) = (1, h);
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if f(mid) < f0 || up(mid) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        (lo + 1) % h
    };
    for _ in 0..h {
        let (next, prev) = ((s + 1) % h, (s + h - 1) % h);
        if f(next) > f(s) {
            s = next;
        } else if f(prev) > f(s) {
            s = prev;
        } else {
            break;
        }
    }
    s
}

/// A path hull over the chain `i..=j`, split at the tag.
#[derive(Debug, Default)]
pub(crate) struct PathHull {
    left: HalfHull,
    right: HalfHull,
    tag: usize,
}

impl PathHull {
    /// Builds the path hull of `points[i..=j]` with the tag at the middle.
    pub fn build(&mut self, points: &[Point2<f64>], i: usize, j: usize) {
        let n = j - i + 1;
        self.tag = i + (j - i) / 2;
        self.left.reset(n);
        self.right.reset(n);
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

    /// The vertex of the current chain farthest from the chord's line.
    pub fn farthest(&self, points: &[Point2<f64>], chord: &Chord) -> (usize, f64) {
        let l = self.left.farthest(points, chord);
        let r = self.right.farthest(points, chord);
        match (l, r) {
            (Some(l), Some(r)) if r.1 > l.1 || (r.1 == l.1 && r.0 < l.0) => r,
            (Some(l), _) => l,
            (None, Some(r)) => r,
            (None, None) => (self.tag, 0.0),
        }
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
}

/// A pending Douglas-Peucker range; `fresh` ranges need a new path hull.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Task {
    i: usize,
    j: usize,
    fresh: bool,
}

/// Douglas-Peucker with the line metric in O(n log n) worst case, marking kept vertices.
///
/// Plain DP scans are several times cheaper per vertex than path-hull upkeep, and on
/// real data (coastlines, random walks, scans) they finish in O(n log n). So, as
/// introsort does for quicksort, we run plain DP under a work budget of
/// `dp_budget_per_level * n * log2(n)` distance evaluations and hand whatever ranges
/// remain to path hulls only when the budget runs out (zig-zags and other
/// adversarial chains). Both phases split at the same vertex, the farthest, with the
/// first index winning ties, so the result does not depend on where the hand-over
/// happens.
pub(crate) fn hull_mark(
    points: &[Point2<f64>],
    epsilon: f64,
    keep: &mut [bool],
    ranges: &mut Vec<(usize, usize)>,
    tasks: &mut Vec<Task>,
    hull: &mut PathHull,
    dp_budget_per_level: usize,
) {
    let n = points.len();
    let budget = dp_budget_per_level * n * (usize::BITS - n.leading_zeros()) as usize;
    let mut work = 0usize;
    ranges.clear();
    ranges.push((0, n - 1));
    while let Some((i, j)) = ranges.pop() {
        if j <= i + 1 {
            continue;
        }
        work += j - i - 1;
        if work > budget {
            ranges.push((i, j));
            break;
        }
        let chord = Chord::new(points[i], points[j], crate::Metric::Line);
        let (f, key) = crate::dp::find_split(points, i, j, &chord, crate::dp::Tie::First);
        if chord.exceeds(key, epsilon) {
            keep[f] = true;
            ranges.push((f, j));
            ranges.push((i, f));
        }
    }
    if ranges.is_empty() {
        return;
    }
    tasks.clear();
    tasks.extend(ranges.drain(..).map(|(i, j)| Task { i, j, fresh: true }));
    path_hull_mark(points, epsilon, keep, tasks, hull);
}

/// Plain-DP work allowed per level of a balanced split tree before path hulls take
/// over. Real data stays below it, so path hulls run only where plain DP would turn
/// quadratic.
pub(crate) const DP_BUDGET_PER_LEVEL: usize = 4;

/// Douglas-Peucker with path hulls on the pending `tasks`, marking kept vertices.
/// The part of a split that holds the tag is processed first with the rolled-back
/// hull (it sits on top of the stack); the other part is rebuilt afterwards.
pub(crate) fn path_hull_mark(
    points: &[Point2<f64>],
    epsilon: f64,
    keep: &mut [bool],
    tasks: &mut Vec<Task>,
    hull: &mut PathHull,
) {
    while let Some(Task { i, j, fresh }) = tasks.pop() {
        if j <= i + 1 {
            continue;
        }
        if fresh {
            hull.build(points, i, j);
        }
        let chord = Chord::new(points[i], points[j], crate::Metric::Line);
        let (f, key) = if chord.is_degenerate() {
            // Farthest from a point is no extreme in a direction: scan this range.
            crate::dp::find_split(points, i, j, &chord, crate::dp::Tie::First)
        } else {
            hull.farthest(points, &chord)
        };
        if !chord.exceeds(key, epsilon) || f <= i || f >= j {
            continue;
        }
        keep[f] = true;
        let keeps_left_part = f > hull.tag();
        hull.split(f);
        if keeps_left_part {
            tasks.push(Task {
                i: f,
                j,
                fresh: true,
            });
            tasks.push(Task {
                i,
                j: f,
                fresh: false,
            });
        } else {
            tasks.push(Task {
                i,
                j: f,
                fresh: true,
            });
            tasks.push(Task {
                i: f,
                j,
                fresh: false,
            });
        }
    }
}
