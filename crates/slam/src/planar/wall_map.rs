//! The wall map: each wall's seen extent on its line, the stretches its detections
//! covered, its first estimate, the walls the filter no longer estimates, and which
//! wall each detection was paired with. Pure bookkeeping, without the filter: the
//! engine owns one [`WallMap`] and reads and writes it only through its methods, so
//! that what the wall map holds can change without touching the engine.

use std::collections::HashMap;

use nalgebra::{Matrix2, Point2, Vector2};

use super::fixed::Fixed;

/// How many of a wall's latest paired detections `wall_shared_sd` compares a new one
/// with: `n` in its `sqrt(n)` is at most this.
pub const WALL_PARTS_KEPT: usize = 256;

/// A wall the filter no longer estimates (frozen, or a wall anchor with a zero
/// covariance): observed as known, its covariance added to the noise.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct FixedWall {
    pub line: Vector2<f64>,
    pub cov: Matrix2<f64>,
}

/// A wall's seen extent, two points on its line, and its reference point, the
/// origin its state `(rho, alpha)` is measured from; all in the internal frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Extent {
    pub start: Point2<f64>,
    pub end: Point2<f64>,
    pub origin: Point2<f64>,
}

/// The walls the engine knows, outside the filter's state (the lines themselves are
/// in the state, or in [`FixedWall`]s once frozen).
#[derive(Debug, Clone, Default)]
pub(super) struct WallMap {
    /// Every wall's seen extent (state, frozen or anchor), in the internal frame; a
    /// landmark id is a wall's exactly when it has an extent here.
    extents: HashMap<u64, Extent>,
    /// The stretches `(from, to)` of each wall's line (coordinates along it, frame
    /// form) covered by its paired detections, for `wall_shared_sd`.
    parts: HashMap<u64, Vec<(f64, f64)>>,
    /// Each wall's first estimate, where its observation is linearised with
    /// `first_estimates`.
    first_estimates: HashMap<u64, Vector2<f64>>,
    /// Frozen walls and a wall anchor, with their ids.
    fixed: Fixed<FixedWall>,
    /// The last wall scan: each detection's wall id (paired or admitted), or `None`.
    pairing: Vec<Option<u64>>,
    /// Every wall detection so far, in the order processed: as `pairing`.
    pairings: Vec<Option<u64>>,
}

impl WallMap {
    /// Whether there is no wall at all (a run of point landmarks only).
    pub fn is_empty(&self) -> bool {
        self.extents.is_empty()
    }

    /// Whether landmark `id` is a wall.
    pub fn contains(&self, id: u64) -> bool {
        self.extents.contains_key(&id)
    }

    /// Wall `id`'s seen extent.
    pub fn extent(&self, id: u64) -> Option<&Extent> {
        self.extents.get(&id)
    }

    /// Every wall's extent, in the map's (unspecified) order.
    pub fn extents(&self) -> impl Iterator<Item = (u64, &Extent)> {
        self.extents.iter().map(|(&id, e)| (id, e))
    }

    /// Wall `id`'s extent, to grow it as the wall is seen again.
    pub fn extent_mut(&mut self, id: u64) -> Option<&mut Extent> {
        self.extents.get_mut(&id)
    }

    /// A new wall: its extent and, when the filter estimates it, its first estimate.
    pub fn add(&mut self, id: u64, extent: Extent, first: Option<Vector2<f64>>) {
        if let Some(line) = first {
            self.first_estimates.insert(id, line);
        }
        self.extents.insert(id, extent);
    }

    /// Wall `id`'s first estimate (its line when admitted).
    pub fn first_estimate(&self, id: u64) -> Option<&Vector2<f64>> {
        self.first_estimates.get(&id)
    }

    /// The stretches wall `id`'s paired detections covered.
    pub fn parts(&self, id: u64) -> &[(f64, f64)] {
        self.parts.get(&id).map_or(&[], Vec::as_slice)
    }

    /// Remembers the stretch a paired detection covered (if it was placed), keeping
    /// the latest [`WALL_PARTS_KEPT`]: so that a robot parked before a wall for
    /// hours neither grows the list nor slows each pairing (Intel's most is 136).
    pub fn keep_part(&mut self, id: u64, part: Option<(f64, f64)>) {
        let kept = self.parts.entry(id).or_default();
        kept.extend(part);
        if kept.len() > WALL_PARTS_KEPT {
            kept.remove(0);
        }
    }

    /// Wall `id` leaves the filter (frozen, or made the anchor): from now on it is
    /// known at `wall`.
    pub fn fix(&mut self, id: u64, wall: FixedWall) {
        self.fixed.push(id, wall);
    }

    /// The fixed walls with their ids, in the order fixed (`k` in
    /// `Target::FixedWall(k)`).
    pub fn fixed(&self) -> impl Iterator<Item = (&FixedWall, u64)> {
        self.fixed.iter().map(|(id, wall)| (wall, id))
    }

    /// The id of the `k`-th fixed wall.
    pub fn fixed_id(&self, k: usize) -> u64 {
        self.fixed.id(k)
    }

    /// Fixed wall `id`, if it is one.
    pub fn fixed_wall(&self, id: u64) -> Option<&FixedWall> {
        self.fixed.get(id)
    }

    /// A new wall scan of `n` detections, none paired yet.
    pub fn start_scan(&mut self, n: usize) {
        self.pairing = vec![None; n];
    }

    /// Detection `det` of this scan is (or became) wall `id`.
    pub fn pair(&mut self, det: usize, id: u64) {
        self.pairing[det] = Some(id);
    }

    /// Whether detection `det` of this scan has its wall.
    pub fn is_paired(&self, det: usize) -> bool {
        self.pairing[det].is_some()
    }

    /// The scan is done: its pairing joins the run's.
    pub fn end_scan(&mut self) {
        self.pairings.extend_from_slice(&self.pairing);
    }

    /// The last wall scan: each detection's wall id (paired or admitted), or `None`.
    pub fn last_pairing(&self) -> &[Option<u64>] {
        &self.pairing
    }

    /// Every wall detection's pairing so far, in the order processed.
    pub fn into_pairings(self) -> Vec<Option<u64>> {
        self.pairings
    }
}

/// The foot of `p` on `line` and its coordinate along the line.
pub(super) fn along(line: &Vector2<f64>, p: &Point2<f64>) -> (Point2<f64>, f64) {
    let (s, c) = line.y.sin_cos();
    let n = Vector2::new(c, s);
    (p - n * (n.dot(&p.coords) - line.x), -s * p.x + c * p.y)
}

/// The shortest extent on `line` (frame form) covering the feet of `points`, with
/// reference point `origin`.
pub(super) fn covering(line: &Vector2<f64>, points: &[Point2<f64>], origin: Point2<f64>) -> Extent {
    let feet: Vec<(Point2<f64>, f64)> = points.iter().map(|p| along(line, p)).collect();
    let lo = feet.iter().min_by(|a, b| a.1.total_cmp(&b.1));
    let hi = feet.iter().max_by(|a, b| a.1.total_cmp(&b.1));
    let (lo, hi) = (
        lo.map_or(Point2::origin(), |f| f.0),
        hi.map_or(Point2::origin(), |f| f.0),
    );
    Extent {
        start: lo,
        end: hi,
        origin,
    }
}

/// The gap between an extent and a segment, both projected on `line` (negative when
/// they overlap).
pub(super) fn gap(line: &Vector2<f64>, a: &Extent, b: &[Point2<f64>; 2]) -> f64 {
    let t = |p: &Point2<f64>| along(line, p).1;
    let (a0, a1, b0, b1) = (t(&a.start), t(&a.end), t(&b[0]), t(&b[1]));
    a0.min(a1).max(b0.min(b1)) - a0.max(a1).min(b0.max(b1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn extents_cover_and_gaps_measure_along_the_line() {
        // The line y = 2 (rho 2, alpha pi/2): along-coordinate is -x.
        let line = Vector2::new(2.0, PI / 2.0);
        let e = covering(
            &line,
            &[
                Point2::new(1.0, 2.1),
                Point2::new(-1.0, 1.9),
                Point2::new(0.0, 2.0),
            ],
            Point2::origin(),
        );
        assert!((e.start - Point2::new(1.0, 2.0)).norm() < 1e-12);
        assert!((e.end - Point2::new(-1.0, 2.0)).norm() < 1e-12);
        let seg = [Point2::new(3.0, 2.0), Point2::new(4.0, 2.0)];
        assert!((gap(&line, &e, &seg) - 2.0).abs() < 1e-12);
        let seg = [Point2::new(0.5, 2.0), Point2::new(4.0, 2.0)];
        assert!((gap(&line, &e, &seg) + 0.5).abs() < 1e-12);
    }
}
