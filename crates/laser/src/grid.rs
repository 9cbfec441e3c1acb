//! A map of points with normals, indexed by a uniform grid for nearest-neighbour
//! look-ups: the cells are stored as one sorted index array with per-cell offsets
//! (counting sort), so building it allocates three vectors and a query touches the
//! 3 x 3 cells around the point.

use nalgebra::Vector2;

use crate::error::{LaserError, Result};

/// At most this many cells: a map spanning more gets coarser cells (a campus log
/// with 80 m readings would otherwise ask for millions).
const MAX_CELLS: usize = 1 << 22;

/// Points with unit normals (the map's lines), indexed for [`MapIndex::nearest`].
#[derive(Debug, Clone, Default)]
pub struct MapIndex {
    points: Vec<Vector2<f64>>,
    normals: Vec<Vector2<f64>>,
    origin: Vector2<f64>,
    cell: f64,
    cols: usize,
    rows: usize,
    /// `order[start[c]..start[c + 1]]` are the points of cell `c`.
    start: Vec<u32>,
    order: Vec<u32>,
    /// The points in `order`'s order: a query reads its cells' points from one
    /// contiguous run instead of gathering them from all over `points`.
    by_cell: Vec<Vector2<f64>>,
}

/// A map point found near a query: its index, position, normal and squared distance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Neighbour {
    /// Index of the point in the map.
    pub index: usize,
    /// The map point.
    pub point: Vector2<f64>,
    /// Its unit normal.
    pub normal: Vector2<f64>,
    /// Squared distance from the query, m^2.
    pub distance2: f64,
}

impl MapIndex {
    /// Indexes `points` with their `normals` in cells of at least `cell` metres; a
    /// query finds every point within `cell` of it.
    pub fn new(points: Vec<Vector2<f64>>, normals: Vec<Vector2<f64>>, cell: f64) -> Result<Self> {
        if points.len() != normals.len() {
            return Err(LaserError::dimension(format!(
                "{} map points but {} normals",
                points.len(),
                normals.len()
            )));
        }
        if !(cell.is_finite() && cell > 0.0) {
            return Err(LaserError::invalid(
                "cell",
                format!("must be finite and > 0, got {cell}"),
            ));
        }
        if points.len() >= u32::MAX as usize {
            return Err(LaserError::invalid(
                "points",
                format!("{} is too many map points", points.len()),
            ));
        }
        let finite = |p: &Vector2<f64>| p.x.is_finite() && p.y.is_finite();
        if !points.iter().all(finite) || !normals.iter().all(finite) {
            return Err(LaserError::Core(rperc_core::CoreError::NonFinite(
                "map points",
            )));
        }
        let mut map = MapIndex {
            points,
            normals,
            cell,
            ..Default::default()
        };
        map.build();
        Ok(map)
    }

    fn build(&mut self) {
        if self.points.is_empty() {
            return;
        }
        let (mut lo, mut hi) = (self.points[0], self.points[0]);
        for p in &self.points {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        let span = hi - lo;
        // Coarser cells when the span would need too many (queries stay correct).
        let mut cell = self.cell;
        while ((span.x / cell) as usize + 1) * ((span.y / cell) as usize + 1) > MAX_CELLS {
            cell *= 2.0;
        }
        self.cell = cell;
        self.origin = lo;
        self.cols = (span.x / cell) as usize + 1;
        self.rows = (span.y / cell) as usize + 1;
        let cells: Vec<usize> = self.points.iter().map(|p| self.cell_of(p)).collect();
        let mut start = vec![0u32; self.cols * self.rows + 1];
        for &c in &cells {
            start[c + 1] += 1;
        }
        for c in 0..self.cols * self.rows {
            start[c + 1] += start[c];
        }
        let mut fill = start.clone();
        let mut order = vec![0u32; self.points.len()];
        for (i, &c) in cells.iter().enumerate() {
            order[fill[c] as usize] = i as u32;
            fill[c] += 1;
        }
        self.by_cell = order.iter().map(|&k| self.points[k as usize]).collect();
        self.start = start;
        self.order = order;
    }

    fn cell_of(&self, p: &Vector2<f64>) -> usize {
        let (i, j) = self.coords(p);
        j as usize * self.cols + i as usize
    }

    fn coords(&self, p: &Vector2<f64>) -> (i64, i64) {
        let d = (p - self.origin) / self.cell;
        (floor_index(d.x), floor_index(d.y))
    }

    /// The number of map points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether the map has no point.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The side of the cells, m (at least the one asked for).
    pub fn cell(&self) -> f64 {
        self.cell
    }

    /// The map's points.
    pub fn points(&self) -> &[Vector2<f64>] {
        &self.points
    }

    /// The map's normals.
    pub fn normals(&self) -> &[Vector2<f64>] {
        &self.normals
    }

    /// The nearest map point within `max_distance` (at most the cell size) of `q`.
    ///
    /// The query's own cell is searched first; a neighbouring cell only when its
    /// nearest edge is closer than the best point so far. On a dense map the best
    /// point is a few centimetres away, so most queries read one or two cells of
    /// nine.
    pub fn nearest(&self, q: &Vector2<f64>, max_distance: f64) -> Option<Neighbour> {
        if self.points.is_empty() || !(q.x.is_finite() && q.y.is_finite()) {
            return None;
        }
        let (ci, cj) = self.coords(q);
        let limit = max_distance.min(self.cell);
        // The query's offset inside its cell, m.
        let inside = (q - self.origin) - Vector2::new(ci as f64, cj as f64) * self.cell;
        let gap = |d: i64, f: f64| match d {
            -1 => f,
            1 => self.cell - f,
            _ => 0.0,
        };
        let mut best: Option<(usize, f64)> = None;
        for (di, dj) in NEIGHBOURS {
            let (i, j) = (ci + di, cj + dj);
            if i < 0 || j < 0 || i >= self.cols as i64 || j >= self.rows as i64 {
                continue;
            }
            let edge = gap(di, inside.x).powi(2) + gap(dj, inside.y).powi(2);
            if edge > best.map_or(limit * limit, |(_, b)| b) {
                continue;
            }
            let c = j as usize * self.cols + i as usize;
            let (from, to) = (self.start[c] as usize, self.start[c + 1] as usize);
            for (slot, p) in self.by_cell[from..to].iter().enumerate() {
                let d2 = (p - q).norm_squared();
                if d2 <= limit * limit && best.is_none_or(|(_, b)| d2 < b) {
                    best = Some((from + slot, d2));
                }
            }
        }
        best.map(|(slot, distance2)| (self.order[slot] as usize, distance2))
            .map(|(index, distance2)| Neighbour {
                index,
                point: self.points[index],
                normal: self.normals[index],
                distance2,
            })
    }
}

/// `x.floor() as i64` without libm's `floor` call (the baseline x86-64 target has no
/// rounding instruction, and cell look-ups are the ICP's inner loop): truncate, then
/// one less for a negative non-integer. Saturates and maps NaN to 0 as `as` does.
pub(crate) fn floor_index(x: f64) -> i64 {
    let t = x as i64;
    t.saturating_sub(i64::from((t as f64) > x))
}

/// The cells a query reads, its own first, then those sharing an edge, then the
/// corners: the nearer cells tighten the bound that lets the farther be skipped.
const NEIGHBOURS: [(i64, i64); 9] = [
    (0, 0),
    (-1, 0),
    (1, 0),
    (0, -1),
    (0, 1),
    (-1, -1),
    (1, -1),
    (-1, 1),
    (1, 1),
];

#[cfg(test)]
mod tests {
    use super::*;

    /// The grid's nearest neighbour equals a brute-force search (the oracle).
    #[test]
    fn nearest_equals_brute_force() {
        let mut pts = Vec::new();
        for k in 0..500 {
            let a = k as f64 * 0.37;
            pts.push(Vector2::new(10.0 * (a * 1.3).sin(), 7.0 * (a * 0.7).cos()));
        }
        let normals = vec![Vector2::new(1.0, 0.0); pts.len()];
        let map = MapIndex::new(pts.clone(), normals, 0.5).unwrap();
        // Queries on a line across the map, and scattered near its points, at the
        // full radius and a smaller one.
        let queries = (0..300)
            .map(|k| Vector2::new(-11.0 + 0.073 * k as f64, 8.0 - 0.055 * k as f64))
            .chain(pts.iter().enumerate().map(|(k, p)| {
                p + Vector2::new(0.3 * (k as f64 * 2.1).sin(), 0.3 * (k as f64 * 1.7).cos())
            }));
        for q in queries {
            for radius in [0.5, 0.17] {
                let brute = pts
                    .iter()
                    .map(|p| (p - q).norm_squared())
                    .filter(|&d2| d2 <= radius * radius)
                    .min_by(f64::total_cmp);
                let found = map.nearest(&q, radius).map(|n| n.distance2);
                assert_eq!(found, brute, "query {q:?}, radius {radius}");
            }
        }
    }

    /// Equals `floor() as i64` (the oracle) on integers, halves, tiny offsets either
    /// side of them, the extremes and NaN.
    #[test]
    fn floor_index_equals_floor() {
        let mut xs = vec![f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 1e300, -1e300];
        xs.extend([i64::MAX as f64, i64::MIN as f64, -0.0, f64::MIN_POSITIVE]);
        for k in -2000..2000 {
            let x = k as f64 * 0.5;
            xs.extend([x, x + 1e-12, x - 1e-12, x.next_up(), x.next_down()]);
        }
        for x in xs {
            assert_eq!(floor_index(x), x.floor() as i64, "x = {x:e}");
        }
    }

    #[test]
    fn a_huge_span_gets_coarser_cells() {
        let pts = vec![Vector2::new(0.0, 0.0), Vector2::new(1e6, 1e6)];
        let map = MapIndex::new(pts, vec![Vector2::new(0.0, 1.0); 2], 0.1).unwrap();
        assert!(map.cols * map.rows <= MAX_CELLS);
        assert_eq!(map.nearest(&Vector2::new(1e6, 1e6), 0.1).unwrap().index, 1);
    }
}
