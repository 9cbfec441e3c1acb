//! The candidate list: sightings of landmarks not yet in the map, each the fused
//! estimate of the sightings that agree with it. A landmark enters the map after
//! `candidate_sightings` consistent sightings; the engine owns one [`Candidates`] and
//! admits what it hands over.

use nalgebra::{Matrix2, Point2, Vector2};

/// A sighting of a landmark not yet in the map.
#[derive(Debug, Clone, PartialEq)]
struct Candidate {
    id: Option<u64>,
    mean: Point2<f64>,
    cov: Matrix2<f64>,
    count: u32,
    last_seen: f64,
}

/// One unexplained detection as a landmark estimate, in the internal frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Sighting {
    /// The data set's label, when the association is by id.
    pub id: Option<u64>,
    pub mean: Point2<f64>,
    pub cov: Matrix2<f64>,
    pub time: f64,
}

/// The candidates, in no particular order.
#[derive(Debug, Clone, Default)]
pub(super) struct Candidates {
    list: Vec<Candidate>,
}

impl Candidates {
    /// Forgets the candidates not seen within `window` seconds before `t`.
    pub fn forget_older_than(&mut self, t: f64, window: f64) {
        self.list.retain(|c| t - c.last_seen <= window);
    }

    /// Moves every candidate by `-by` (the anchor moves the internal frame's origin).
    pub fn shift_origin(&mut self, by: &Vector2<f64>) {
        for c in &mut self.list {
            c.mean -= by;
        }
    }

    /// Adds a sighting. It joins a consistent candidate (the one with its id when
    /// `by_id`, else the nearest within the Mahalanobis `gate`) or replaces the
    /// inconsistent one it matched, or starts a new one. Returns how many sightings
    /// its candidate now has; one with `needed` leaves the list, to enter the map.
    pub fn sight(&mut self, s: &Sighting, by_id: bool, gate: f64, needed: u32) -> u32 {
        let k = match by_id {
            true => self.list.iter().position(|c| c.id == s.id),
            false => self.nearest(s, gate),
        };
        let count = match k {
            Some(k) if consistent(&self.list[k], s, gate) => {
                fuse(&mut self.list[k], s);
                self.list[k].count
            }
            _ => {
                if let Some(k) = k {
                    self.list.swap_remove(k);
                }
                self.list.push(Candidate {
                    id: s.id,
                    mean: s.mean,
                    cov: s.cov,
                    count: 1,
                    last_seen: s.time,
                });
                1
            }
        };
        if count >= needed {
            let k = k.filter(|_| count > 1).unwrap_or(self.list.len() - 1);
            self.list.swap_remove(k);
        }
        count
    }

    fn nearest(&self, s: &Sighting, gate: f64) -> Option<usize> {
        self.list
            .iter()
            .enumerate()
            .filter_map(|(k, c)| {
                let e = s.mean - c.mean;
                let d2 = e.dot(&((c.cov + s.cov).try_inverse()? * e));
                (d2 <= gate).then_some((k, d2))
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(k, _)| k)
    }
}

fn consistent(c: &Candidate, s: &Sighting, gate: f64) -> bool {
    let e = s.mean - c.mean;
    (c.cov + s.cov)
        .try_inverse()
        .is_some_and(|inv| e.dot(&(inv * e)) <= gate)
}

/// Fuses a new sighting into a candidate (information form: the two estimates
/// treated as independent, which is good enough for an admission test).
fn fuse(c: &mut Candidate, s: &Sighting) {
    if let (Some(a), Some(b)) = (c.cov.try_inverse(), s.cov.try_inverse())
        && let Some(sum) = (a + b).try_inverse()
    {
        c.mean = Point2::from(sum * (a * c.mean.coords + b * s.mean.coords));
        c.cov = sum;
    }
    c.count += 1;
    c.last_seen = s.time;
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(x: f64, id: Option<u64>, time: f64) -> Sighting {
        Sighting {
            id,
            mean: Point2::new(x, 0.0),
            cov: Matrix2::identity() * 0.01,
            time,
        }
    }

    #[test]
    fn agreeing_sightings_fuse_and_the_needed_one_leaves_the_list() {
        let gate = 9.21;
        let mut c = Candidates::default();
        assert_eq!(c.sight(&at(1.0, None, 0.0), false, gate, 3), 1);
        assert_eq!(c.sight(&at(5.0, None, 0.1), false, gate, 3), 1); // too far: a new one
        assert_eq!(c.sight(&at(1.02, None, 0.2), false, gate, 3), 2);
        // Two equal covariances fuse to their mean, with half the covariance.
        let fused = c.list.iter().find(|k| k.count == 2).unwrap();
        assert!((fused.mean.x - 1.01).abs() < 1e-12 && (fused.cov[(0, 0)] - 0.005).abs() < 1e-12);
        assert_eq!(c.sight(&at(1.0, None, 0.3), false, gate, 3), 3);
        assert_eq!(c.list.len(), 1); // the third sighting took its candidate away
        c.forget_older_than(0.5, 0.3);
        assert!(c.list.is_empty());
    }

    #[test]
    fn by_id_an_inconsistent_sighting_restarts_its_candidate() {
        let mut c = Candidates::default();
        c.sight(&at(1.0, Some(4), 0.0), true, 9.21, 3);
        assert_eq!(c.sight(&at(3.0, Some(4), 0.1), true, 9.21, 3), 1);
        assert_eq!((c.list.len(), c.list[0].mean.x), (1, 3.0));
        c.shift_origin(&Vector2::new(1.0, -1.0));
        assert_eq!(c.list[0].mean, Point2::new(2.0, 1.0));
    }
}
