//! The point landmarks the engine knows outside the filter's state: the points it no
//! longer estimates (frozen, or the anchor) and each point's first estimate. Pure
//! bookkeeping, as the wall map is: the engine owns one [`PointMap`] and reads and
//! writes it only through its methods.

use std::collections::HashMap;

use nalgebra::Point2;

use super::associate::FixedPoint;
use super::fixed::Fixed;

/// Frozen points and the anchor, and the points' first estimates.
#[derive(Debug, Clone, Default)]
pub(super) struct PointMap {
    /// Frozen points and a point anchor, with their ids.
    fixed: Fixed<FixedPoint>,
    /// Each point's first estimate (its position when admitted), where its
    /// observation is linearised with `first_estimates`.
    first_estimates: HashMap<u64, Point2<f64>>,
}

impl PointMap {
    /// The points the filter no longer estimates, in the order they left it (what
    /// association reads as `Target::Fixed(k)`).
    pub fn fixed(&self) -> &[FixedPoint] {
        self.fixed.items()
    }

    /// The id of fixed point `k`.
    pub fn fixed_id(&self, k: usize) -> u64 {
        self.fixed.id(k)
    }

    /// The index among the fixed points of landmark `id`, if it is one.
    pub fn fixed_index(&self, id: u64) -> Option<usize> {
        self.fixed.index_of(id)
    }

    /// Point `id` leaves the filter's estimation: it is observed as known from now on.
    pub fn fix(&mut self, id: u64, point: FixedPoint) {
        self.fixed.push(id, point);
    }

    /// Every fixed point with its id, in the order they were fixed.
    pub fn fixed_with_ids(&self) -> impl Iterator<Item = (u64, &FixedPoint)> {
        self.fixed.iter()
    }

    /// Point `id`'s first estimate, if it was recorded.
    pub fn first_estimate(&self, id: u64) -> Option<Point2<f64>> {
        self.first_estimates.get(&id).copied()
    }

    /// Records point `id`'s first estimate, its position when admitted.
    pub fn set_first_estimate(&mut self, id: u64, at: Point2<f64>) {
        self.first_estimates.insert(id, at);
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::Matrix2;

    use super::*;

    #[test]
    fn fixed_points_and_first_estimates_are_kept_by_id() {
        let mut map = PointMap::default();
        let at = |x: f64| FixedPoint {
            mean: Point2::new(x, -x),
            cov: Matrix2::identity() * x,
        };
        map.fix(7, at(1.0));
        map.fix(3, at(2.0));
        assert_eq!(map.fixed(), &[at(1.0), at(2.0)]);
        assert_eq!(
            (map.fixed_id(1), map.fixed_index(7), map.fixed_index(5)),
            (3, Some(0), None)
        );
        let listed: Vec<_> = map.fixed_with_ids().map(|(id, p)| (id, p.mean.x)).collect();
        assert_eq!(listed, [(7, 1.0), (3, 2.0)]);
        assert_eq!(map.first_estimate(4), None);
        map.set_first_estimate(4, Point2::new(0.5, 0.25));
        assert_eq!(map.first_estimate(4), Some(Point2::new(0.5, 0.25)));
    }
}
