//! The live segments of the simplification (input segments not yet replaced, and the
//! chords that replaced them) bucketed in a uniform grid, so that "which segments
//! could touch this chord" looks at the cells along the chord instead of every
//! segment. All output vertices are input vertices, so the bounding box of the input
//! bounds every segment ever stored and the grid never has to grow.

use nalgebra::Point2;

type P = Point2<f64>;

/// What a stored segment is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Origin {
    /// Segment `index` (from vertex `index` to `index + 1`) of component `component`.
    Input { component: u32, index: u32 },
    /// A chord that replaced a section.
    Output,
}

/// A stored segment.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Segment {
    pub a: P,
    pub b: P,
    pub origin: Origin,
}

/// The grid. Cells hold segment ids; removal only clears the `alive` flag, and queries
/// skip dead ids (a segment is never re-inserted, so ids are not reused).
#[derive(Debug)]
pub(crate) struct SegmentGrid {
    origin: P,
    cell: f64,
    inv_cell: f64,
    /// Slack added around every cover so that rounding in the cell arithmetic can only
    /// add cells, never miss one.
    pad: f64,
    nx: usize,
    ny: usize,
    cells: Vec<Vec<u32>>,
    segments: Vec<Segment>,
    alive: Vec<bool>,
    /// Per segment, the last query that saw it, to report each segment once per query.
    seen: Vec<u32>,
    query: u32,
}

impl SegmentGrid {
    /// A grid over the box `lo`-`hi` sized for `expected` segments of total length
    /// `total_length`: about two cells per segment, and cells no smaller than the mean
    /// segment, so that a typical segment touches one to three cells.
    pub fn new(lo: P, hi: P, expected: usize, total_length: f64) -> Self {
        let (w, h) = (hi.x - lo.x, hi.y - lo.y);
        let target = 2 * expected.max(1);
        let mean = total_length / expected.max(1) as f64;
        let mut cell = (w * h / target as f64)
            .sqrt()
            .max(mean)
            .max(w.max(h) / target as f64);
        let usable = cell.is_finite() && cell > 0.0 && w.is_finite() && h.is_finite();
        if !usable {
            // All points equal, or an extent that overflows: one cell holds everything.
            cell = f64::INFINITY;
        }
        let count = |c: f64, extent: f64| {
            if c.is_finite() {
                (extent / c) as usize + 1
            } else {
                1
            }
        };
        while count(cell, w).saturating_mul(count(cell, h)) > 4 * target + 16 {
            cell *= 2.0;
        }
        let (nx, ny) = (count(cell, w), count(cell, h));
        let magnitude = lo.x.abs().max(lo.y.abs()).max(hi.x.abs()).max(hi.y.abs());
        Self {
            origin: lo,
            cell,
            inv_cell: if cell.is_finite() { 1.0 / cell } else { 0.0 },
            pad: if cell.is_finite() {
                1e-7 * cell + 1e-13 * magnitude
            } else {
                0.0
            },
            nx,
            ny,
            cells: vec![Vec::new(); nx * ny],
            segments: Vec::with_capacity(expected),
            alive: Vec::with_capacity(expected),
            seen: Vec::with_capacity(expected),
            query: 0,
        }
    }

    /// Stores a segment and returns its id.
    pub fn insert(&mut self, segment: Segment) -> u32 {
        let id = self.segments.len() as u32;
        self.segments.push(segment);
        self.alive.push(true);
        self.seen.push(0);
        let g = self.geometry();
        let cells = &mut self.cells;
        Self::cover_cells(g, &segment.a, &segment.b, &mut |c| cells[c].push(id));
        id
    }

    /// Removes a segment (queries stop reporting it).
    pub fn remove(&mut self, id: u32) {
        self.alive[id as usize] = false;
    }

    /// Whether `hit` holds for some live segment in a cell the segment `a b` passes
    /// through. Every live segment that intersects `a b` is offered (once); others
    /// nearby may be too.
    pub fn any_near(&mut self, a: &P, b: &P, mut hit: impl FnMut(&Segment) -> bool) -> bool {
        self.query = self.query.wrapping_add(1);
        if self.query == 0 {
            self.seen.fill(0);
            self.query = 1;
        }
        let g = self.geometry();
        let mut found = false;
        let Self {
            cells,
            segments,
            alive,
            seen,
            query,
            ..
        } = self;
        let this = &*cells;
        let mut visit = |c: usize| {
            if found {
                return;
            }
            for &id in &this[c] {
                let k = id as usize;
                if alive[k] && seen[k] != *query {
                    seen[k] = *query;
                    if hit(&segments[k]) {
                        found = true;
                        return;
                    }
                }
            }
        };
        Self::cover_cells(g, a, b, &mut visit);
        found
    }

    fn geometry(&self) -> Geometry {
        Geometry {
            origin: self.origin,
            inv_cell: self.inv_cell,
            cell: self.cell,
            pad: self.pad,
            nx: self.nx,
            ny: self.ny,
        }
    }

    /// Calls `visit` for every cell the segment `a b` may pass through: column by
    /// column, the cells between the segment's lowest and highest point inside that
    /// column, widened by the padding.
    fn cover_cells(g: Geometry, a: &P, b: &P, visit: &mut impl FnMut(usize)) {
        let (x_lo, x_hi) = (a.x.min(b.x), a.x.max(b.x));
        let (y_lo, y_hi) = (a.y.min(b.y), a.y.max(b.y));
        let (c0, c1) = (g.col(x_lo - g.pad), g.col(x_hi + g.pad));
        let slope = (b.y - a.y) / (b.x - a.x);
        for cx in c0..=c1 {
            let (ya, yb) = if a.x == b.x || !slope.is_finite() || c0 == c1 {
                (y_lo, y_hi)
            } else {
                let xs = (g.origin.x + cx as f64 * g.cell).clamp(x_lo, x_hi);
                let xe = (g.origin.x + (cx + 1) as f64 * g.cell).clamp(x_lo, x_hi);
                let y = |x: f64| (a.y + (x - a.x) * slope).clamp(y_lo, y_hi);
                (y(xs), y(xe))
            };
            let (r0, r1) = (g.row(ya.min(yb) - g.pad), g.row(ya.max(yb) + g.pad));
            for cy in r0..=r1 {
                visit(cy * g.nx + cx);
            }
        }
    }
}

/// The numbers that place a point in a cell (copied out so that queries can borrow
/// the cells mutably alongside).
#[derive(Debug, Clone, Copy)]
struct Geometry {
    origin: P,
    inv_cell: f64,
    cell: f64,
    pad: f64,
    nx: usize,
    ny: usize,
}

impl Geometry {
    fn col(&self, x: f64) -> usize {
        Self::clamp_index((x - self.origin.x) * self.inv_cell, self.nx)
    }

    fn row(&self, y: f64) -> usize {
        Self::clamp_index((y - self.origin.y) * self.inv_cell, self.ny)
    }

    fn clamp_index(v: f64, n: usize) -> usize {
        // `as` saturates: negative and NaN become 0.
        (v.floor() as usize).min(n - 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::topology::predicates::interior_intersection;

    /// Every stored segment that meets a query segment is offered, checked against a
    /// scan of all segments, on random segments of mixed lengths.
    #[test]
    fn queries_offer_every_intersecting_segment() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut segs = Vec::new();
        for k in 0..400 {
            let a = P::new(next() * 100.0, next() * 50.0);
            let len = if k % 10 == 0 { 60.0 } else { 3.0 };
            let b = P::new(a.x + (next() - 0.5) * len, a.y + (next() - 0.5) * len);
            segs.push((a, b));
        }
        let total: f64 = segs.iter().map(|(a, b)| (b - a).norm()).sum();
        let mut grid = SegmentGrid::new(P::new(-40.0, -40.0), P::new(140.0, 90.0), 400, total);
        for (k, (a, b)) in segs.iter().enumerate() {
            let origin = Origin::Input {
                component: 0,
                index: k as u32,
            };
            grid.insert(Segment {
                a: *a,
                b: *b,
                origin,
            });
        }
        for (a, b) in &segs {
            let expected = segs
                .iter()
                .filter(|(c, d)| interior_intersection(a, b, c, d))
                .count();
            let mut offered = 0;
            grid.any_near(a, b, |s| {
                offered += usize::from(interior_intersection(a, b, &s.a, &s.b));
                false
            });
            assert_eq!(offered, expected);
        }
    }
}
