//! Correlative scan matching (Olson 2009): every pose on a grid of headings and
//! translations is scored by the share of a scan's points that land within a hit
//! distance of a submap, coarse to fine.
//!
//! The hot loop is one table look-up per point and translation. For each heading the
//! points are placed in the hit grid once, as flat cell indices; a translation by
//! whole cells is then one integer offset added to every index. The grid keeps a
//! margin of empty cells around its hits twice as wide as the largest translation,
//! so an index plus an offset never leaves the table and a point that could leave it
//! can never score: the loop needs no bounds logic.

use nalgebra::{Matrix2, Vector2};
use rperc_core::{Pose2, wrap_angle};

use crate::grid::floor_index;

/// At most this many of a scan's points score a pose: the score is a share, and
/// more points only cost time.
const SCORED_POINTS: usize = 60;

/// At most about this many positions in a coarse search: a wider window gets a
/// coarser step, so an attempt never costs more than a few hundred thousand look-ups.
const MAX_POSITIONS: f64 = 3000.0;

/// Levels of the coarse search's branch and bound: its top blocks span up to 16 x 16
/// translations.
const DEPTH: u32 = 4;

/// Submap points farther than this from the search centre are not scored, m: it
/// bounds the hit grids (cells of a few centimetres) to some tens of megabytes.
const MAX_REACH: f64 = 250.0;

/// At most this many cells in a hit grid (16 MB).
const MAX_HIT_CELLS: f64 = (1u64 << 24) as f64;

/// A grid of the cells within `hit` of a submap point, for scoring poses, with an
/// empty margin of `margin` cells on every side.
pub(crate) struct HitGrid {
    origin: Vector2<f64>,
    cell: f64,
    cols: usize,
    rows: usize,
    margin: i64,
    hit: Vec<bool>,
}

impl HitGrid {
    /// Cells of `cell` m, hit when within `hit` of a point, searched with
    /// translations of up to `reach` m.
    pub(crate) fn new(points: &[Vector2<f64>], hit: f64, cell: f64, reach: f64) -> Self {
        let (mut lo, mut hi) = (
            Vector2::repeat(f64::INFINITY),
            Vector2::repeat(f64::NEG_INFINITY),
        );
        for p in points {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        // A grid that would need too many cells (a millimetre step over a 250 m
        // submap) gets coarser ones: the search then steps by them, and memory stays
        // bounded whatever the settings.
        let mut cell = cell;
        let (margin, lo, cols, rows) = loop {
            let margin = 2 * (reach / cell).ceil() as i64 + 1;
            let pad = Vector2::repeat(hit + cell + margin as f64 * cell);
            let (lo, hi) = (lo - pad, hi + pad);
            let cols = ((hi.x - lo.x) / cell).ceil().max(1.0);
            let rows = ((hi.y - lo.y) / cell).ceil().max(1.0);
            if cols * rows <= MAX_HIT_CELLS {
                break (margin, lo, cols as usize, rows as usize);
            }
            cell *= 2.0;
        };
        let mut grid = HitGrid {
            origin: lo,
            cell,
            cols,
            rows,
            margin,
            hit: vec![false; cols * rows],
        };
        let within = (hit / cell).ceil() as i64;
        let hit2 = hit * hit;
        for p in points {
            let (ci, cj) = grid.coords(p);
            // The point's offset from its own cell's centre, m.
            let d = p - (Vector2::new(ci as f64 + 0.5, cj as f64 + 0.5) * cell + lo);
            for dj in -within..=within {
                let dy = dj as f64 * cell - d.y;
                for di in -within..=within {
                    let dx = di as f64 * cell - d.x;
                    if dx * dx + dy * dy <= hit2 {
                        grid.set(ci + di, cj + dj);
                    }
                }
            }
        }
        grid
    }

    /// The cell of `p` (floor; saturating far outside).
    fn coords(&self, p: &Vector2<f64>) -> (i64, i64) {
        let d = (p - self.origin) / self.cell;
        (floor_index(d.x), floor_index(d.y))
    }

    /// Marks a cell hit; cells in the margin stay empty by construction.
    fn set(&mut self, i: i64, j: i64) {
        let inside = |v: i64, n: usize| v >= self.margin && v < n as i64 - self.margin;
        if inside(i, self.cols) && inside(j, self.rows) {
            self.hit[j as usize * self.cols + i as usize] = true;
        }
    }

    fn is_hit_cell(&self, i: i64, j: i64) -> bool {
        i >= 0
            && j >= 0
            && (i as usize) < self.cols
            && (j as usize) < self.rows
            && self.hit[j as usize * self.cols + i as usize]
    }
}

/// A scan's points in a hit grid at one heading, sorted by how they can score under
/// translations of up to `(ri, rj)` cells.
#[derive(Default)]
struct Placed {
    /// Flat indices of the points whose every translation stays in the table.
    fast: Vec<usize>,
    /// Cells of the points that may leave the table yet reach hits (only when the
    /// grid's margin is narrower than twice the reach).
    slow: Vec<(i64, i64)>,
}

impl Placed {
    fn fill(&mut self, grid: &HitGrid, cells: impl Iterator<Item = (i64, i64)>, r: (i64, i64)) {
        self.fast.clear();
        self.slow.clear();
        let (cols, rows) = (grid.cols as i64, grid.rows as i64);
        let (lo, hi) = (grid.margin, (cols - grid.margin, rows - grid.margin));
        for (i, j) in cells {
            if i - r.0 >= 0 && i + r.0 < cols && j - r.1 >= 0 && j + r.1 < rows {
                self.fast.push(j as usize * grid.cols + i as usize);
            } else if i + r.0 >= lo && i - r.0 < hi.0 && j + r.1 >= lo && j - r.1 < hi.1 {
                self.slow.push((i, j));
            }
        }
    }

    /// Points on hits after a translation of `(di, dj)` cells (flat: `offset`).
    fn hits(&self, grid: &HitGrid, di: i64, dj: i64, offset: isize) -> usize {
        let fast = self
            .fast
            .iter()
            .filter(|&&k| grid.hit[(k as isize + offset) as usize])
            .count();
        fast + self
            .slow
            .iter()
            .filter(|&&(i, j)| grid.is_hit_cell(i + di, j + dj))
            .count()
    }

    /// An upper bound of [`Placed::hits`] over a block of translations: points on
    /// the pyramid's level `h` at the block's first translation (flat `offset`);
    /// points on the slow path count as hits.
    fn bound(&self, pyramid: &Pyramid, h: u32, offset: isize) -> usize {
        let fast = self
            .fast
            .iter()
            .filter(|&&k| pyramid.marked(h, (k as isize + offset) as usize))
            .count();
        fast + self.slow.len()
    }
}

/// Max-pooled copies of a hit grid (Olson 2009's multi-resolution tables): level `h`
/// marks a cell when any of the `2^h x 2^h` cells at `steps` apart from it is hit,
/// so one look-up per point bounds the score of a block of `2^h x 2^h` translations.
///
/// Levels are bitsets over the grid's flat cell index, so a level is four shifted
/// ORs of the one below, 64 cells a word. A shift past a row's end reads the next
/// row's first cells: they lie in the empty margin, wider than any shift.
struct Pyramid {
    /// Levels 1, 2, ... (level 0 is the grid itself).
    levels: Vec<Vec<u64>>,
}

impl Pyramid {
    fn new(grid: &HitGrid, steps: i64, depth: u32) -> Self {
        let mut levels: Vec<Vec<u64>> = Vec::with_capacity(depth as usize);
        if depth == 0 {
            return Pyramid { levels };
        }
        let mut bits = vec![0u64; grid.hit.len().div_ceil(64)];
        for (k, _) in grid.hit.iter().enumerate().filter(|(_, h)| **h) {
            bits[k / 64] |= 1 << (k % 64);
        }
        for h in 1..=depth {
            let half = (1usize << (h - 1)) * steps as usize;
            let below = levels.last().unwrap_or(&bits);
            let mut next = below.clone();
            for shift in [half, half * grid.cols, half * grid.cols + half] {
                or_shifted(&mut next, below, shift);
            }
            levels.push(next);
        }
        Pyramid { levels }
    }

    /// Whether flat cell `k` is marked on level `h` (>= 1).
    fn marked(&self, h: u32, k: usize) -> bool {
        self.levels[h as usize - 1][k / 64] >> (k % 64) & 1 == 1
    }
}

/// `out[k] |= bits[k + shift]` over a bitset (bits past the end read as 0).
fn or_shifted(out: &mut [u64], bits: &[u64], shift: usize) {
    let (words, s) = (shift / 64, (shift % 64) as u32);
    let word = |i: usize| bits.get(i).copied().unwrap_or(0);
    for (i, o) in out.iter_mut().enumerate() {
        let lo = word(i + words) >> s;
        let hi = if s == 0 {
            0
        } else {
            word(i + words + 1) << (64 - s)
        };
        *o |= lo | hi;
    }
}

/// The translation grid of a search: `2 n + 1` steps of `steps` cells along each
/// axis, kept where inside the window's ellipse.
struct Moves {
    n: (i64, i64),
    steps: i64,
    step: f64,
    inverse: Matrix2<f64>,
    window: Window,
}

impl Moves {
    fn new(grid: &HitGrid, window: &Window, steps: i64) -> Self {
        let step = steps as f64 * grid.cell;
        let reach = window.extent();
        Moves {
            n: (
                (reach.x / step).round() as i64,
                (reach.y / step).round() as i64,
            ),
            steps,
            step,
            inverse: window.xy.try_inverse().unwrap_or_else(Matrix2::zeros),
            window: *window,
        }
    }

    /// The translation of grid index `(a, b)` (from the corner `-n`), in metres and
    /// cells, when it is on the grid and inside the window.
    fn at(&self, a: i64, b: i64) -> Option<(Vector2<f64>, i64, i64)> {
        let (i, j) = (a - self.n.0, b - self.n.1);
        if i.abs() > self.n.0 || j.abs() > self.n.1 {
            return None;
        }
        let d = Vector2::new(i as f64, j as f64) * self.step;
        self.window
            .contains(&d, &self.inverse)
            .then_some((d, i * self.steps, j * self.steps))
    }

    /// Levels of the pyramid so that the top blocks are at most `2^depth` wide.
    fn depth(&self, max: u32) -> u32 {
        let span = (2 * self.n.0.max(self.n.1) + 1) as u64;
        (u64::BITS - (span - 1).leading_zeros()).min(max)
    }
}

/// A block of `2^h x 2^h` translations from grid index `(a, b) 2^h`, with the bound
/// of its score.
#[derive(Clone, Copy)]
struct Block {
    h: u32,
    a: i64,
    b: i64,
    bound: usize,
}

/// The best `keep` poses (with their scores) on a grid of `steps` cells of `grid`
/// and `dth` rad around `centre`, within `window`, scored by the share of `points`
/// (laser frame) that land on `grid`'s hits.
///
/// Branch and bound over blocks of translations up to `2^depth` wide (depth 0: every
/// translation scored): a block is split only while its bound beats the `keep`-th
/// best score so far, so the answer is the exhaustive search's (up to ties).
#[allow(clippy::too_many_arguments)]
pub(crate) fn grid_search(
    points: &[Vector2<f64>],
    grid: &HitGrid,
    centre: &Pose2,
    window: &Window,
    steps: i64,
    dth: f64,
    keep: usize,
    depth: u32,
) -> Vec<(f64, Pose2)> {
    let moves = Moves::new(grid, window, steps);
    let depth = moves.depth(depth);
    let pyramid = Pyramid::new(grid, steps, depth);
    let top = 1i64 << depth;
    // Blocks cover whole multiples of the top width; a look-up reaches the far end.
    let span = |n: i64| ((2 * n + top) / top) * top;
    let reach = |n: i64| n.max(span(n) - 1 - n) * steps;
    let r = (reach(moves.n.0), reach(moves.n.1));
    let nth = (window.angle / dth).round() as i64;
    let total = points.len().max(1) as f64;
    let mut search = Search {
        grid,
        pyramid: &pyramid,
        moves: &moves,
        placed: Placed::default(),
        best: Vec::new(),
        keep,
        stack: Vec::new(),
    };
    let t = centre.translation();
    for k in -nth..=nth {
        let th = centre.theta + k as f64 * dth;
        let (s, c) = th.sin_cos();
        let cells = points
            .iter()
            .map(|p| grid.coords(&(Vector2::new(c * p.x - s * p.y, s * p.x + c * p.y) + t)));
        search.placed.fill(grid, cells, r);
        let rows = span(moves.n.1) / top;
        let tops = (0..span(moves.n.0) / top).flat_map(|a| (0..rows).map(move |b| (a, b)));
        search.descend(depth, tops, total, |hits, d| {
            let at = t + d;
            (hits as f64 / total, Pose2::new(at.x, at.y, wrap_angle(th)))
        });
    }
    search.best
}

/// One heading's branch and bound, with the best poses over all headings.
struct Search<'a> {
    grid: &'a HitGrid,
    pyramid: &'a Pyramid,
    moves: &'a Moves,
    placed: Placed,
    best: Vec<(f64, Pose2)>,
    keep: usize,
    stack: Vec<Block>,
}

impl Search<'_> {
    /// Whether no pose of a block with this bound can enter the best (the test of
    /// [`keep_best`]).
    fn beaten(&self, bound: usize, total: f64) -> bool {
        self.best.len() >= self.keep && bound as f64 / total <= self.best[self.best.len() - 1].0
    }

    fn descend(
        &mut self,
        depth: u32,
        tops: impl Iterator<Item = (i64, i64)>,
        total: f64,
        pose: impl Fn(usize, Vector2<f64>) -> (f64, Pose2),
    ) {
        self.stack.clear();
        for (a, b) in tops {
            self.push(depth, a, b);
        }
        while let Some(block) = self.stack.pop() {
            if self.beaten(block.bound, total) {
                continue;
            }
            if block.h == 0 {
                let Some((d, di, dj)) = self.moves.at(block.a, block.b) else {
                    continue;
                };
                let offset = dj as isize * self.grid.cols as isize + di as isize;
                let hits = self.placed.hits(self.grid, di, dj, offset);
                keep_best(&mut self.best, pose(hits, d), self.keep);
                continue;
            }
            // The children, the most promising popped first.
            let from = self.stack.len();
            for (u, v) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                self.push(block.h - 1, 2 * block.a + u, 2 * block.b + v);
            }
            self.stack[from..].sort_by_key(|c| c.bound);
        }
    }

    /// Pushes a block with its bound (a leaf's bound is its exact hit count).
    fn push(&mut self, h: u32, a: i64, b: i64) {
        let size = 1i64 << h;
        let (i, j) = (a * size - self.moves.n.0, b * size - self.moves.n.1);
        if i > self.moves.n.0 || j > self.moves.n.1 {
            return;
        }
        let (di, dj) = (i * self.moves.steps, j * self.moves.steps);
        let offset = dj as isize * self.grid.cols as isize + di as isize;
        let bound = if h == 0 {
            self.placed.hits(self.grid, di, dj, offset)
        } else {
            self.placed.bound(self.pyramid, h, offset)
        };
        self.stack.push(Block { h, a, b, bound });
    }
}

/// Where a closure is searched for: an ellipse `d^T xy^-1 d <= 1` around the current
/// estimate (world axes, m^2) and a heading window of +- `angle` rad.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Window {
    /// The ellipse's matrix.
    pub xy: Matrix2<f64>,
    /// The heading half-window, rad.
    pub angle: f64,
}

impl Window {
    /// Whether an offset lies inside the ellipse (`inverse` is `xy`'s).
    pub(crate) fn contains(&self, d: &Vector2<f64>, inverse: &Matrix2<f64>) -> bool {
        (d.transpose() * inverse * d)[(0, 0)] <= 1.0 + 1e-9
    }

    /// The half-extent of the ellipse along x and y.
    pub(crate) fn extent(&self) -> Vector2<f64> {
        Vector2::new(self.xy[(0, 0)].sqrt(), self.xy[(1, 1)].sqrt())
    }
}

/// The steps of a coarse-to-fine search (from [`crate::loops::LoopConfig`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct SearchSteps {
    /// A point scores when a submap point lies within this, m.
    pub hit_distance: f64,
    /// The fine grid's translation step, m.
    pub coarse_step: f64,
    /// How many of the best coarse poses are searched again finely.
    pub refine: usize,
}

/// Coarse to fine: the window searched on a coarse grid of poses against hits
/// dilated to the coarse step, then the best few searched again on a fine grid
/// around them.
pub(crate) fn coarse_search(
    points: &[Vector2<f64>],
    submap: &[Vector2<f64>],
    centre: &Pose2,
    window: &Window,
    cfg: &SearchSteps,
) -> Vec<(f64, Pose2)> {
    let stride = points.len().div_ceil(SCORED_POINTS).max(1);
    let pts: Vec<Vector2<f64>> = points.iter().step_by(stride).copied().collect();
    // Only the submap points the scan can reach from inside the window score; this
    // also bounds the hit grids' size whatever the log's ranges (at most 250 m).
    let reach_scan = pts.iter().map(|p| p.norm()).fold(0.0, f64::max);
    let limit = (window.extent().max() + reach_scan + 2.0 * cfg.hit_distance).min(MAX_REACH);
    let near: Vec<Vector2<f64>> = submap
        .iter()
        .filter(|p| (*p - centre.translation()).norm() <= limit)
        .copied()
        .collect();
    let submap = &near[..];
    if submap.is_empty() {
        return Vec::new();
    }
    // The heading step moves a point at the median range by about one step; farther
    // points land within the fine search and ICP's reach.
    let mut ranges: Vec<f64> = pts.iter().map(|p| p.norm()).collect();
    ranges.sort_by(f64::total_cmp);
    let far = ranges
        .get(ranges.len() / 2)
        .copied()
        .unwrap_or(1.0)
        .max(1.0);
    // Coarse: steps of twice the fine step (more for a wide window), hits dilated to
    // match; fine: cells of half a step. Both move the points by two whole cells.
    let area = std::f64::consts::PI * window.xy.determinant().max(0.0).sqrt();
    let coarse_cell = cfg.coarse_step.max((area / MAX_POSITIONS).sqrt() / 2.0);
    let coarse = 2.0 * coarse_cell;
    let dth_coarse = (coarse / far).clamp(0.5f64.to_radians(), 3f64.to_radians());
    // The branch and bound's top blocks reach past the window by up to a block.
    let reach = window.extent().max() + coarse * (1 << DEPTH) as f64;
    let wide = HitGrid::new(submap, cfg.hit_distance.max(coarse), coarse_cell, reach);
    let first = grid_search(
        &pts,
        &wide,
        centre,
        window,
        2,
        dth_coarse,
        2 * cfg.refine,
        DEPTH,
    );
    let fine = HitGrid::new(
        submap,
        cfg.hit_distance,
        cfg.coarse_step / 2.0,
        2.0 * coarse,
    );
    let dth = (cfg.coarse_step / far).clamp(0.25f64.to_radians(), 2f64.to_radians());
    let around = Window {
        xy: Matrix2::identity() * (coarse * coarse),
        angle: dth_coarse,
    };
    let mut best = Vec::new();
    for (_, start) in first {
        for item in grid_search(&pts, &fine, &start, &around, 2, dth, cfg.refine, 0) {
            keep_best(&mut best, item, cfg.refine);
        }
    }
    best
}

fn keep_best(best: &mut Vec<(f64, Pose2)>, item: (f64, Pose2), keep: usize) {
    if best.len() < keep || item.0 > best[best.len() - 1].0 {
        let at = best.partition_point(|b| b.0 >= item.0);
        best.insert(at, item);
        best.truncate(keep);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every pose scored the plain way: each point moved, its cell looked up with
    /// bounds checks (the oracle of the flat-index loop).
    fn reference(points: &[Vector2<f64>], grid: &HitGrid, pose: &Pose2) -> f64 {
        let hits = points
            .iter()
            .filter(|p| {
                let (i, j) = grid.coords(&(pose.rotation() * *p + pose.translation()));
                grid.is_hit_cell(i, j)
            })
            .count();
        hits as f64 / points.len() as f64
    }

    /// A millimetre cell over a 250 m submap would need 10^11 cells: the grid
    /// coarsens instead, and a search on it still finds the truth's cell.
    #[test]
    fn a_tiny_cell_over_a_huge_submap_stays_bounded() {
        let mut submap = room();
        submap.push(Vector2::new(250.0, 250.0));
        let grid = HitGrid::new(&submap, 0.15, 1e-3, 1.0);
        assert!((grid.cols * grid.rows) as f64 <= MAX_HIT_CELLS);
        assert!(grid.cell > 1e-3);
    }

    fn room() -> Vec<Vector2<f64>> {
        let mut pts = Vec::new();
        for k in 0..200 {
            let s = k as f64 * 0.05;
            pts.push(Vector2::new(s, 0.0));
            pts.push(Vector2::new(0.0, s * 0.6));
            pts.push(Vector2::new(10.0, s * 0.6));
        }
        pts
    }

    /// The flat-index scores equal the plain ones at every pose kept, with a margin
    /// as built and with one too narrow for the reach (the slow path).
    #[test]
    fn scores_equal_the_plain_count() {
        let submap = room();
        let scan: Vec<Vector2<f64>> = submap
            .iter()
            .step_by(7)
            .map(|p| Vector2::new(p.x - 4.0, p.y - 2.5))
            .collect();
        let centre = Pose2::new(4.3, 2.2, 0.05);
        let window = Window {
            xy: Matrix2::new(4.0, 0.5, 0.5, 2.0),
            angle: 0.1,
        };
        for reach in [3.0, 0.2] {
            let grid = HitGrid::new(&submap, 0.15, 0.1, reach);
            let best = grid_search(&scan, &grid, &centre, &window, 2, 0.02, 50, 0);
            assert_eq!(best.len(), 50);
            for (score, pose) in &best {
                assert_eq!(*score, reference(&scan, &grid, pose), "reach {reach}");
            }
            // Branch and bound keeps the exhaustive search's scores, at every depth.
            for depth in 1..=5 {
                let bb = grid_search(&scan, &grid, &centre, &window, 2, 0.02, 50, depth);
                let scores = |v: &[(f64, Pose2)]| v.iter().map(|b| b.0).collect::<Vec<_>>();
                assert_eq!(scores(&bb), scores(&best), "reach {reach}, depth {depth}");
                for (score, pose) in &bb {
                    assert_eq!(*score, reference(&scan, &grid, pose));
                }
            }
            // The truth (4, 2.5, 0) lies on the search grid's reach: the best pose is
            // within a cell and a heading step of it.
            let top = best[0].1;
            assert!(
                (top.translation() - Vector2::new(4.0, 2.5)).norm() < 0.25,
                "{top:?}"
            );
            assert!(top.theta.abs() < 0.03, "{top:?}");
        }
    }
}
