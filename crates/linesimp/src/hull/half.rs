//! One half of a path hull: the convex hull of a chain grown one vertex at a time from
//! the tag, with every change logged so that it can be rolled back.
//!
//! The hull is a Melkman deque `elt[bot..=top]` of its vertices in counter-clockwise
//! order, the most recent hull vertex at both ends. It is kept *strictly* convex with
//! exact orientation tests, and it remembers, for the tie rules, every chain vertex
//! that lies on its boundary without being a corner:
//!
//! - `elt[s]` is the preferred index (by the tie rule) among the chain vertices with
//!   exactly the coordinates of corner `s` (duplicates);
//! - `edge[s]` is the preferred index among the chain vertices strictly inside the edge
//!   from corner `s` to corner `s + 1` (collinear runs), or [`NONE`].
//!
//! A chain vertex strictly inside the hull can never again be farthest from a chord,
//! so these records are all a farthest-vertex query needs: the farthest set is a corner
//! or an edge, and the answer is the preferred index among its records.
//!
//! Melkman's algorithm assumes a simple chain. For other chains we classify each new
//! vertex exactly (inside, on a corner, on an edge, outside) and rebuild the hull when
//! it leaves away from the deque ends.

use std::cmp::Ordering;

use nalgebra::Point2;

use crate::dp::Tie;
use crate::metric::{LineChord, orient_on};

/// No vertex recorded.
pub(super) const NONE: u32 = u32::MAX;

/// Hulls up to this many corners are searched linearly.
const LINEAR_SCAN_MAX: usize = 8;

/// Where a vertex that adds no corner is recorded: with the corner it duplicates, or
/// with the edge it lies strictly inside.
#[derive(Clone, Copy, Debug)]
enum Slot {
    Corner,
    Edge,
}

/// One logged insertion (exactly one entry per inserted vertex).
#[derive(Clone, Copy, Debug)]
enum Op {
    /// Strictly inside, or a record that did not change.
    Nothing,
    /// The duplicate record of the corner at `pos` (both ends if it is the end corner)
    /// was `old`.
    Corner { pos: u32, old: u32 },
    /// The collinear record of the edge at `pos` (both sides of a two-corner hull)
    /// was `old`.
    Edge { pos: u32, old: u32 },
    /// Melkman: `ntop` and `nbot` pops, then a push that overwrote
    /// `elt[top' + 1], edge[top'], elt[bot' - 1], edge[bot' - 1]` (primes: after pops).
    Push {
        ntop: u32,
        nbot: u32,
        saved: [u32; 4],
    },
    /// Rebuilt: positions `lo..=hi` of `elt` then `edge` sit in `saved[from..]`.
    Replace {
        from: u32,
        lo: u32,
        hi: u32,
        bot: u32,
        top: u32,
    },
}

/// Where a point lies relative to a strictly convex polygon.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Loc {
    Inside,
    Corner(usize),
    Edge(usize),
    Outside,
}

/// A farthest set found by a query: a corner to compare with (`rep`), its key, and
/// the preferred index of the set.
#[derive(Clone, Copy, Debug)]
pub(super) struct Far {
    pub rep: u32,
    pub key: f64,
    pub best: u32,
}

#[inline(always)]
fn pt(points: &[Point2<f64>], k: u32) -> &Point2<f64> {
    &points[k as usize]
}

/// Whether `p`, known to be on the line through `u` and `w`, lies on the closed segment.
#[inline]
fn within(u: &Point2<f64>, w: &Point2<f64>, p: &Point2<f64>) -> bool {
    u.x.min(w.x) <= p.x && p.x <= u.x.max(w.x) && u.y.min(w.y) <= p.y && p.y <= u.y.max(w.y)
}

/// Locates `q` against the polygon `w` (m >= 3 corners, counter-clockwise) when `q`
/// is strictly inside the angle at `w[0]`: binary search over the fan of triangles.
fn locate_in_wedge(grid: bool, points: &[Point2<f64>], w: &[u32], q: &Point2<f64>) -> Loc {
    let w0 = pt(points, w[0]);
    // Invariant: orient(w0, w[lo], q) >= 0 > orient(w0, w[hi], q).
    let (mut lo, mut hi) = (1, w.len() - 1);
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        if orient_on(grid, w0, pt(points, w[mid]), q) >= 0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let (u, v) = (pt(points, w[lo]), pt(points, w[lo + 1]));
    match orient_on(grid, u, v, q) {
        1 => Loc::Inside,
        -1 => Loc::Outside,
        _ if q == u => Loc::Corner(lo),
        _ if q == v => Loc::Corner(lo + 1),
        _ => Loc::Edge(lo),
    }
}

/// Locates `q` against the polygon `w` (m >= 3 corners, counter-clockwise).
fn locate(grid: bool, points: &[Point2<f64>], w: &[u32], q: &Point2<f64>) -> Loc {
    let m = w.len();
    let (w0, w1, wl) = (pt(points, w[0]), pt(points, w[1]), pt(points, w[m - 1]));
    if q == w0 {
        return Loc::Corner(0);
    }
    let (o1, o2) = (orient_on(grid, w0, w1, q), orient_on(grid, wl, w0, q));
    if o1 < 0 || o2 < 0 {
        return Loc::Outside;
    }
    if o1 == 0 {
        return match within(w0, w1, q) {
            false => Loc::Outside,
            true if q == w1 => Loc::Corner(1),
            true => Loc::Edge(0),
        };
    }
    if o2 == 0 {
        return match within(wl, w0, q) {
            false => Loc::Outside,
            true if q == wl => Loc::Corner(m - 1),
            true => Loc::Edge(m - 1),
        };
    }
    locate_in_wedge(grid, points, w, q)
}

/// Andrew's monotone chain on vertices sorted by (x, y) without duplicate coordinates:
/// the strictly convex hull, counter-clockwise from the lowest-leftmost vertex.
fn monotone_chain(grid: bool, points: &[Point2<f64>], sorted: &[u32], out: &mut Vec<u32>) {
    out.clear();
    if sorted.len() <= 2 {
        out.extend_from_slice(sorted);
        return;
    }
    let turns_left = |out: &[u32], c: u32| {
        let n = out.len();
        orient_on(
            grid,
            pt(points, out[n - 2]),
            pt(points, out[n - 1]),
            pt(points, c),
        ) > 0
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

/// Index of a maximum of `f` over the corners of a strictly convex polygon with `m`
/// corners, where `cmp(a, b)` compares `f(a)` with `f(b)` exactly. Around the polygon
/// a linear function rises strictly to its maximum (a corner or an edge), falls
/// strictly to its minimum, and rises again, so each predicate below is monotone.
fn argmax_cyclic(m: usize, cmp: impl Fn(usize, usize) -> Ordering) -> usize {
    let up = |k: usize| cmp((k + 1) % m, k) == Ordering::Greater;
    // Last k of the rising run that starts at `from`.
    let climb = |from: usize, pred: &dyn Fn(usize) -> bool| {
        let (mut lo, mut hi) = (from, m);
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if pred(mid) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        (lo + 1) % m
    };
    match cmp(1, 0) {
        Ordering::Greater => climb(0, &|k| up(k) && cmp(k, 0) != Ordering::Less),
        Ordering::Equal if cmp(2, 1) == Ordering::Greater => climb(1, &up), // minimum edge
        Ordering::Equal => 0,                                               // maximum edge
        Ordering::Less => match cmp(m - 1, 0) {
            Ordering::Greater => climb(1, &|k| cmp(k, 0) == Ordering::Less || up(k)),
            _ => 0,
        },
    }
}

/// One half of a path hull. See the module documentation.
#[derive(Debug, Default)]
pub(super) struct HalfHull {
    elt: Vec<u32>,
    edge: Vec<u32>,
    bot: usize,
    top: usize,
    tie: Tie,
    /// Grid data: floating-point orientation tests are exact (see `Extent::grid`).
    grid: bool,
    log: Vec<Op>,
    saved: Vec<u32>,
    cand: Vec<u32>,
    chain: Vec<u32>,
    records: Vec<u32>,
    sorted: Vec<u32>,
}

impl HalfHull {
    /// Empties the hull, sizing the deque for up to `n` insertions.
    pub fn reset(&mut self, n: usize, tie: Tie, grid: bool) {
        // Every insertion moves bot down by at most one and top up by at most one
        // (two for the very first), so `n + 2` slots each way suffice.
        if self.elt.len() < 2 * n + 4 {
            self.elt.resize(2 * n + 4, 0);
            self.edge.resize(2 * n + 4, NONE);
        }
        self.bot = n + 2;
        self.top = n + 1;
        self.tie = tie;
        self.grid = grid;
        self.log.clear();
        // One entry per insertion: reserve it all now rather than double on the way.
        self.log.reserve(n);
        self.saved.clear();
    }

    /// Number of distinct corners.
    #[inline(always)]
    fn corners(&self) -> usize {
        (self.top + 1 - self.bot).saturating_sub(1)
    }

    /// The preferred of two recorded indices, either of which may be [`NONE`].
    #[inline]
    fn prefer(&self, a: u32, b: u32) -> u32 {
        match (a, b) {
            (NONE, _) => b,
            (_, NONE) => a,
            _ => self.tie.pick(a as usize, b as usize) as u32,
        }
    }

    /// Adds chain vertex `k` (vertices come in chain order from the tag outward).
    pub fn insert(&mut self, points: &[Point2<f64>], k: u32) {
        let grid = self.grid;
        let m = self.corners();
        if m < 3 {
            self.insert_small(points, k, m);
            return;
        }
        let p = pt(points, k);
        let (bot, top) = (self.bot, self.top);
        let o_top = orient_on(
            grid,
            pt(points, self.elt[top - 1]),
            pt(points, self.elt[top]),
            p,
        );
        let o_bot = orient_on(
            grid,
            pt(points, self.elt[bot]),
            pt(points, self.elt[bot + 1]),
            p,
        );
        if o_top > 0 && o_bot > 0 {
            // Inside the angle at the end corner: inside, on the boundary, or (only
            // for a chain that crosses itself) outside away from the ends.
            match locate_in_wedge(grid, points, &self.elt[bot..top], p) {
                Loc::Inside => self.log.push(Op::Nothing),
                Loc::Corner(s) => self.record(Slot::Corner, bot + s, k),
                Loc::Edge(s) => self.record(Slot::Edge, bot + s, k),
                Loc::Outside => self.rebuild(points, k),
            }
            return;
        }
        for (o, pos) in [(o_top, top - 1), (o_bot, bot)] {
            let (u, w) = (pt(points, self.elt[pos]), pt(points, self.elt[pos + 1]));
            if o == 0 && within(u, w, p) {
                match p {
                    _ if p == u => self.record(Slot::Corner, pos, k),
                    _ if p == w => self.record(Slot::Corner, pos + 1, k),
                    _ => self.record(Slot::Edge, pos, k),
                }
                return;
            }
        }
        // Strictly outside, and an edge at an end of the deque faces `p`.
        self.push(points, k, o_top, o_bot);
    }

    /// Insertion while the hull is empty, a point or a segment.
    fn insert_small(&mut self, points: &[Point2<f64>], k: u32, m: usize) {
        let grid = self.grid;
        let p = pt(points, k);
        let bot = self.bot;
        if m >= 1 && p == pt(points, self.elt[bot]) {
            return self.record(Slot::Corner, bot, k);
        }
        if m == 2 {
            let (u, w) = (pt(points, self.elt[bot]), pt(points, self.elt[bot + 1]));
            if orient_on(grid, u, w, p) == 0 && within(u, w, p) {
                return match p == w {
                    true => self.record(Slot::Corner, bot + 1, k),
                    false => self.record(Slot::Edge, bot, k),
                };
            }
        }
        self.rebuild(points, k);
    }

    /// `k` duplicates the corner at `pos` ([`Slot::Corner`]) or lies strictly inside
    /// the edge at `pos` ([`Slot::Edge`]): the slot takes the point [`Self::prefer`]
    /// picks, and the insertion is logged with what undoes it.
    fn record(&mut self, slot: Slot, pos: usize, k: u32) {
        let old = match slot {
            Slot::Corner => self.elt[pos],
            Slot::Edge => self.edge[pos],
        };
        let new = self.prefer(old, k);
        if new == old {
            self.log.push(Op::Nothing);
            return;
        }
        let at = pos as u32;
        match slot {
            Slot::Corner => {
                self.log.push(Op::Corner { pos: at, old });
                self.set_corner(pos, new);
            }
            Slot::Edge => {
                self.log.push(Op::Edge { pos: at, old });
                self.set_edge(pos, new);
            }
        }
    }

    fn set_corner(&mut self, pos: usize, v: u32) {
        if pos == self.bot || pos == self.top {
            self.elt[self.bot] = v;
            self.elt[self.top] = v;
        } else {
            self.elt[pos] = v;
        }
    }

    fn set_edge(&mut self, pos: usize, v: u32) {
        if self.corners() == 2 {
            // Both sides of a segment hold the same points.
            self.edge[self.bot] = v;
            self.edge[self.bot + 1] = v;
        } else {
            self.edge[pos] = v;
        }
    }

    /// Melkman's step for a vertex strictly outside: pop the corners that `p` sees
    /// from both ends, push `p` on both. The first pop tests are `o_top`, `o_bot`.
    fn push(&mut self, points: &[Point2<f64>], k: u32, o_top: i8, o_bot: i8) {
        let grid = self.grid;
        let p = pt(points, k);
        let (bot0, top0) = (self.bot, self.top);
        let (mut bot, mut top) = (bot0, top0);
        // The test that removed the last corner on each side (see `absorbed`).
        let (mut last_top, mut last_bot) = (1, 1);
        let mut o = o_top;
        while top > bot + 1 && o <= 0 {
            last_top = o;
            top -= 1;
            o = orient_on(
                grid,
                pt(points, self.elt[top - 1]),
                pt(points, self.elt[top]),
                p,
            );
        }
        let mut o = o_bot;
        while top > bot + 1 && o <= 0 {
            last_bot = o;
            bot += 1;
            o = orient_on(
                grid,
                pt(points, self.elt[bot]),
                pt(points, self.elt[bot + 1]),
                p,
            );
        }
        let tests = [o_top, last_top, o_bot, last_bot];
        let (agg_top, agg_bot) = self.absorbed((bot0, top0), (bot, top), tests);
        let saved = [
            self.elt[top + 1],
            self.edge[top],
            self.elt[bot - 1],
            self.edge[bot - 1],
        ];
        self.elt[top + 1] = k;
        self.edge[top] = agg_top;
        self.elt[bot - 1] = k;
        self.edge[bot - 1] = agg_bot;
        self.top = top + 1;
        self.bot = bot - 1;
        self.log.push(Op::Push {
            ntop: (top0 - top) as u32,
            nbot: (bot - bot0) as u32,
            saved,
        });
    }

    /// Records for the two new edges `T p` and `p B` after Melkman's pops.
    ///
    /// The removed corners run counter-clockwise from `T = elt[top]` to `B = elt[bot]`.
    /// A removed corner lies on a new edge only if it is adjacent to `T` (on `T p`) or
    /// to `B` (on `p B`): a corner further along would put its predecessor outside the
    /// new hull. Likewise only the edges `T x1` and `xr B` can stay on the boundary.
    /// Whether `x1` is on `T p` is whether `orient(T, x1, p)` was 0, a test the pops
    /// already made: `tests` holds the first and last pop tests on the top side, then
    /// on the bottom side.
    fn absorbed(
        &self,
        (bot0, top0): (usize, usize),
        (bot, top): (usize, usize),
        [first_top, last_top, first_bot, last_bot]: [i8; 4],
    ) -> (u32, u32) {
        let (ntop, nbot) = (top0 - top, bot - bot0);
        // (corner, edge to it from T or from it to B, pop test that decided it)
        let first = match (ntop, nbot) {
            (0, 0) => None,
            (0, _) => (bot > bot0 + 1).then_some((bot0 + 1, bot0, first_bot)),
            (_, 0) => (top + 1 < top0).then_some((top + 1, top, last_top)),
            _ => Some((top + 1, top, last_top)),
        };
        let last = match (ntop, nbot) {
            (0, 0) => None,
            (_, 0) => (top + 1 < top0).then_some((top0 - 1, top0 - 1, first_top)),
            (0, _) => (bot > bot0 + 1).then_some((bot - 1, bot - 1, last_bot)),
            _ => Some((bot - 1, bot - 1, last_bot)),
        };
        let record = |c: Option<(usize, usize, i8)>| match c {
            Some((x, e, 0)) => self.prefer(self.elt[x], self.edge[e]),
            _ => NONE,
        };
        (record(first), record(last))
    }

    /// Recomputes the hull from its corners, its records and `k` (slow path: degenerate
    /// hulls, and chains that cross themselves).
    fn rebuild(&mut self, points: &[Point2<f64>], k: u32) {
        let m = self.corners();
        let mut cand = std::mem::take(&mut self.cand);
        cand.clear();
        for s in self.bot..self.bot + m {
            cand.push(self.elt[s]);
            if self.edge[s] != NONE {
                cand.push(self.edge[s]);
            }
        }
        cand.push(k);
        // Sort by coordinates, preferred index first among equal ones, and merge those.
        let tie = self.tie;
        cand.sort_unstable_by(|&a, &b| {
            let (pa, pb) = (pt(points, a), pt(points, b));
            let by_index = match tie {
                Tie::First => a.cmp(&b),
                Tie::Last => b.cmp(&a),
            };
            pa.x.total_cmp(&pb.x)
                .then(pa.y.total_cmp(&pb.y))
                .then(by_index)
        });
        cand.dedup_by(|b, a| pt(points, *a) == pt(points, *b));
        let mut chain = std::mem::take(&mut self.chain);
        monotone_chain(self.grid, points, &cand, &mut chain);
        let Some(at) = chain.iter().position(|&v| v == k) else {
            debug_assert!(false, "a vertex outside the hull must be a corner");
            self.log.push(Op::Nothing);
            (self.cand, self.chain) = (cand, chain);
            return;
        };
        chain.rotate_left(at);
        let mut records = std::mem::take(&mut self.records);
        let mut sorted = std::mem::take(&mut self.sorted);
        let grid = self.grid;
        Self::edge_records(
            grid,
            points,
            &chain,
            &cand,
            &mut sorted,
            &mut records,
            |a, b| self.prefer(a, b),
        );
        self.replace(&chain, &records, k);
        (self.cand, self.chain, self.records, self.sorted) = (cand, chain, records, sorted);
    }

    /// The collinear record of each edge of the new hull `chain`, from candidates
    /// (corners, found by index in `sorted`, are skipped).
    fn edge_records(
        grid: bool,
        points: &[Point2<f64>],
        chain: &[u32],
        cand: &[u32],
        sorted: &mut Vec<u32>,
        records: &mut Vec<u32>,
        prefer: impl Fn(u32, u32) -> u32,
    ) {
        let m = chain.len();
        records.clear();
        records.resize(m, NONE);
        sorted.clear();
        sorted.extend_from_slice(chain);
        sorted.sort_unstable();
        for &c in cand {
            if sorted.binary_search(&c).is_ok() {
                continue;
            }
            let slot = match m {
                0 | 1 => None,
                2 => Some(0), // collinear: every candidate lies on the segment
                _ => match locate(grid, points, chain, pt(points, c)) {
                    Loc::Edge(s) => Some(s),
                    _ => None,
                },
            };
            if let Some(s) = slot {
                records[s] = prefer(records[s], c);
            }
        }
        if m == 2 {
            records[1] = records[0];
        }
    }

    /// Writes a new deque `chain` (starting at `k`) with its edge records, logging what
    /// it overwrites.
    fn replace(&mut self, chain: &[u32], records: &[u32], k: u32) {
        let m = chain.len();
        let (nb, nt) = (self.bot - 1, self.bot - 1 + m);
        let (lo, hi) = (nb, nt.max(self.top));
        let from = self.saved.len() as u32;
        self.saved.extend_from_slice(&self.elt[lo..=hi]);
        self.saved.extend_from_slice(&self.edge[lo..=hi]);
        self.log.push(Op::Replace {
            from,
            lo: lo as u32,
            hi: hi as u32,
            bot: self.bot as u32,
            top: self.top as u32,
        });
        self.elt[nb..nt].copy_from_slice(chain);
        self.elt[nt] = k;
        self.edge[nb..nt].copy_from_slice(records);
        self.edge[nt] = NONE;
        self.bot = nb;
        self.top = nt;
    }

    /// Rolls the hull back to its state after the first `m` insertions.
    pub fn undo_to(&mut self, m: usize) {
        while self.log.len() > m {
            match self.log.pop().expect("log is longer than m") {
                Op::Nothing => {}
                Op::Corner { pos, old } => self.set_corner(pos as usize, old),
                Op::Edge { pos, old } => self.set_edge(pos as usize, old),
                Op::Push { ntop, nbot, saved } => {
                    let (top, bot) = (self.top - 1, self.bot + 1);
                    self.elt[top + 1] = saved[0];
                    self.edge[top] = saved[1];
                    self.elt[bot - 1] = saved[2];
                    self.edge[bot - 1] = saved[3];
                    self.top = top + ntop as usize;
                    self.bot = bot - nbot as usize;
                }
                Op::Replace {
                    from,
                    lo,
                    hi,
                    bot,
                    top,
                } => {
                    let (from, lo, hi) = (from as usize, lo as usize, hi as usize);
                    let len = hi + 1 - lo;
                    self.elt[lo..=hi].copy_from_slice(&self.saved[from..from + len]);
                    self.edge[lo..=hi].copy_from_slice(&self.saved[from + len..from + 2 * len]);
                    self.saved.truncate(from);
                    self.bot = bot as usize;
                    self.top = top as usize;
                }
            }
        }
    }

    /// The set of chain vertices extreme for `sign * F` (`F` the chord's exact signed
    /// distance key): a corner or an edge of the hull, with its preferred index.
    pub fn farthest(&self, points: &[Point2<f64>], chord: &LineChord, sign: i8) -> Option<Far> {
        let m = self.corners();
        if m == 0 {
            return None;
        }
        let w = &self.elt[self.bot..=self.top];
        // Keys of small hulls are computed once; large hulls are binary searched.
        let mut small = [0.0f64; LINEAR_SCAN_MAX];
        if m <= LINEAR_SCAN_MAX {
            for (s, k) in small.iter_mut().enumerate().take(m) {
                *k = chord.line_key(pt(points, w[s]));
            }
        }
        let key = |s: usize| {
            if m <= LINEAR_SCAN_MAX {
                small[s]
            } else {
                chord.line_key(pt(points, w[s]))
            }
        };
        let cmp = |a: usize, b: usize| {
            let o = chord.cmp_signed(pt(points, w[a]), key(a), pt(points, w[b]), key(b));
            if sign > 0 { o } else { o.reverse() }
        };
        let s = match m {
            1 => {
                return Some(Far {
                    rep: w[0],
                    key: key(0),
                    best: w[0],
                });
            }
            _ if m <= LINEAR_SCAN_MAX => {
                (1..m).fold(0, |s, t| if cmp(t, s) == Ordering::Greater { t } else { s })
            }
            _ => argmax_cyclic(m, cmp),
        };
        let (prev, next) = ((s + m - 1) % m, s + 1);
        let edge = |a: usize| self.edge[self.bot + a];
        let best = if cmp(prev, s) == Ordering::Equal {
            self.prefer(self.prefer(w[prev], edge(prev)), w[s])
        } else if cmp(next % m, s) == Ordering::Equal {
            self.prefer(self.prefer(w[s], edge(s)), w[next])
        } else {
            w[s]
        };
        Some(Far {
            rep: w[s],
            key: key(s),
            best,
        })
    }

    /// Test support: the corners (counter-clockwise) and edge records.
    #[cfg(test)]
    pub fn snapshot(&self) -> (Vec<u32>, Vec<u32>) {
        let m = self.corners();
        (
            self.elt[self.bot..self.bot + m].to_vec(),
            self.edge[self.bot..self.bot + m].to_vec(),
        )
    }
}
