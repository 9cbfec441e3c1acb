//! A map of points with normals, indexed by a uniform grid for nearest-neighbour
//! look-ups. The cells are hashed into a table of about twice as many buckets as
//! points (spatial hashing, Teschner et al. 2003), stored as one sorted index array
//! with per-bucket offsets (counting sort): building costs the points, not the map's
//! area (a campus local map spans 160 m, 280,000 cells of 0.3 m, rebuilt at every key
//! scan), and a query reads the buckets of the 3 x 3 cells around the point, whose
//! points include any of another cell hashed alike (farther than the cell, so the
//! distance test drops them).

use nalgebra::Vector2;

use crate::error::{LaserError, Result};

/// The hash table has at least this many buckets.
const MIN_BUCKETS: usize = 1 << 10;

/// Points with unit normals (the map's lines), indexed for [`MapIndex::nearest`].
#[derive(Debug, Clone, Default)]
pub struct MapIndex {
    points: Vec<Vector2<f64>>,
    normals: Vec<Vector2<f64>>,
    origin: Vector2<f64>,
    cell: f64,
    /// The number of buckets less one (a power of two less one).
    mask: usize,
    /// `order[start[b]..start[b + 1]]` are the points of bucket `b`.
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
        rperc_core::ensure_positive("cell", cell)?;
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
        let mut lo = self.points[0];
        for p in &self.points {
            lo = lo.inf(p);
        }
        self.origin = lo;
        self.mask = (2 * self.points.len()).next_power_of_two().max(MIN_BUCKETS) - 1;
        let buckets: Vec<usize> = self
            .points
            .iter()
            .map(|p| {
                let (i, j) = self.coords(p);
                self.bucket(i, j)
            })
            .collect();
        let mut start = vec![0u32; self.mask + 2];
        for &b in &buckets {
            start[b + 1] += 1;
        }
        for b in 0..=self.mask {
            start[b + 1] += start[b];
        }
        let mut fill = start.clone();
        let mut order = vec![0u32; self.points.len()];
        for (i, &b) in buckets.iter().enumerate() {
            order[fill[b] as usize] = i as u32;
            fill[b] += 1;
        }
        self.by_cell = order.iter().map(|&k| self.points[k as usize]).collect();
        self.start = start;
        self.order = order;
    }

    /// The bucket of cell `(i, j)` (any integers: cells left of or below the origin,
    /// or far beyond the points, hash like the others).
    fn bucket(&self, i: i64, j: i64) -> usize {
        let h = (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
            ^ (j as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
        ((h ^ (h >> 29)) as usize) & self.mask
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
        // The best squared distance so far, and a strict bound that admits a point at
        // exactly `limit` until one is found (then the first of equals wins): one
        // comparison a point, which the compiler turns into conditional moves.
        let mut bound = (limit * limit).next_up();
        let mut best = usize::MAX;
        for (di, dj) in NEIGHBOURS {
            let edge = gap(di, inside.x).powi(2) + gap(dj, inside.y).powi(2);
            if edge >= bound {
                continue;
            }
            // Wrapping: a query far outside the map saturates its cell, and the
            // neighbour of the last cell must not overflow (its bucket is as good).
            let b = self.bucket(ci.wrapping_add(di), cj.wrapping_add(dj));
            let (from, to) = (self.start[b] as usize, self.start[b + 1] as usize);
            for (slot, p) in (from..to).zip(&self.by_cell[from..to]) {
                let d2 = (p - q).norm_squared();
                if d2 < bound {
                    bound = d2;
                    best = slot;
                }
            }
        }
        (best != usize::MAX)
            .then(|| (self.order[best] as usize, bound))
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

    /// A point exactly at the pairing reach is found (the bound is `d <= reach`), and
    /// not when the reach is one float shorter. The numbers are exact in binary.
    #[test]
    fn a_point_exactly_at_the_reach_is_found() {
        let pts = vec![Vector2::new(0.25, 0.0), Vector2::new(3.0, 3.0)];
        let map = MapIndex::new(pts, vec![Vector2::new(1.0, 0.0); 2], 0.5).unwrap();
        let q = Vector2::new(0.0, 0.0);
        let found = map.nearest(&q, 0.25).map(|n| (n.index, n.distance2));
        assert_eq!(found, Some((0, 0.0625)));
        assert!(map.nearest(&q, 0.25f64.next_down()).is_none());
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

    /// A map spanning a million metres costs its points, not its area, and still
    /// finds its far point (and nothing near an empty spot).
    #[test]
    fn a_huge_span_costs_its_points_only() {
        let pts = vec![Vector2::new(0.0, 0.0), Vector2::new(1e6, 1e6)];
        let map = MapIndex::new(pts, vec![Vector2::new(0.0, 1.0); 2], 0.1).unwrap();
        assert_eq!(map.start.len(), MIN_BUCKETS + 1);
        assert_eq!(map.nearest(&Vector2::new(1e6, 1e6), 0.1).unwrap().index, 1);
        assert!(map.nearest(&Vector2::new(5e5, 5e5), 0.1).is_none());
        // A query beyond every cell index (saturated) finds nothing and does not
        // overflow.
        assert!(map.nearest(&Vector2::new(1e300, -1e300), 0.1).is_none());
    }
}
