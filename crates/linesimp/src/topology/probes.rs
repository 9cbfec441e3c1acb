//! One probe point per component, for the jump check: a point of the component that a
//! chord of another component must not move to its other side. Before a component is
//! simplified its probe is its second vertex; afterwards, the first vertex of its
//! result (GEOS's rule since JTS #1096: the input vertex may have been dropped, and a
//! dropped vertex says nothing about where the component now lies).

use std::cmp::Ordering;
use std::collections::BTreeSet;

use nalgebra::Point2;

type P = Point2<f64>;

/// A probe ordered by x (then component), for range queries on x.
#[derive(Debug, Clone, Copy)]
struct Key {
    x: f64,
    y: f64,
    component: u32,
}

impl Ord for Key {
    fn cmp(&self, other: &Self) -> Ordering {
        self.x
            .total_cmp(&other.x)
            .then(self.component.cmp(&other.component))
    }
}

impl PartialOrd for Key {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl PartialEq for Key {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}

impl Eq for Key {}

/// `total_cmp` orders -0.0 before 0.0; adding 0.0 maps -0.0 to 0.0 so that equal
/// coordinates compare equal.
fn canonical(v: f64) -> f64 {
    v + 0.0
}

/// The probes, searchable by bounding box and movable.
#[derive(Debug, Default)]
pub(crate) struct Probes {
    by_x: BTreeSet<Key>,
    of: Vec<Option<Key>>,
}

impl Probes {
    /// One slot per component; `None` for components without a probe.
    pub fn new(points: impl IntoIterator<Item = Option<P>>) -> Self {
        let mut probes = Self::default();
        for (c, p) in points.into_iter().enumerate() {
            probes.of.push(None);
            if let Some(p) = p {
                probes.set(c, p);
            }
        }
        probes
    }

    /// Moves the probe of component `c` to `p`.
    pub fn set(&mut self, c: usize, p: P) {
        if let Some(old) = self.of[c].take() {
            self.by_x.remove(&old);
        }
        let key = Key {
            x: canonical(p.x),
            y: p.y,
            component: c as u32,
        };
        self.by_x.insert(key);
        self.of[c] = Some(key);
    }

    /// The probes inside the box `lo`-`hi` (bounds included) that do not belong to
    /// component `skip`.
    pub fn inside(&self, lo: &P, hi: &P, skip: usize) -> impl Iterator<Item = P> + '_ {
        let from = Key {
            x: canonical(lo.x),
            y: 0.0,
            component: 0,
        };
        let to = Key {
            x: canonical(hi.x),
            y: 0.0,
            component: u32::MAX,
        };
        let (y0, y1) = (lo.y, hi.y);
        self.by_x
            .range(from..=to)
            .filter(move |k| k.component as usize != skip && k.y >= y0 && k.y <= y1)
            .map(|k| P::new(k.x, k.y))
    }
}
