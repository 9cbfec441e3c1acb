//! Distances from a point to a chord: the seed's line metric (Table 2) and the
//! point-to-segment metric used by GEOS/shapely and geo.

use nalgebra::Point2;

rperc_core::named_enum! {
    /// How the distance from a point to the chord `v_i v_j` is measured.
    #[derive(Default)]
    pub enum Metric: "metric" {
        /// Distance to the infinite line through the chord (seed 000, Table 2).
        #[default]
        Line = "line",
        /// Distance to the closed segment (what GEOS and geo use).
        Segment = "segment",
    }
}

/// Twice the signed area of the triangle (a, b, p): the homogeneous determinant
/// `|a~ b~ p~|` of seed 000, Table 2. Positive when `p` is left of `a -> b`.
#[inline(always)]
pub(crate) fn cross(a: &Point2<f64>, b: &Point2<f64>, p: &Point2<f64>) -> f64 {
    (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x)
}

#[inline(always)]
fn dist(a: &Point2<f64>, b: &Point2<f64>) -> f64 {
    let (dx, dy) = (a.x - b.x, a.y - b.y);
    (dx * dx + dy * dy).sqrt()
}

/// Point-to-segment distance, written in the same arithmetic order as GEOS so that
/// ties and threshold decisions agree with shapely bit for bit.
#[inline(always)]
pub(crate) fn segment_distance(p: &Point2<f64>, a: &Point2<f64>, b: &Point2<f64>) -> f64 {
    if a == b {
        return dist(p, a);
    }
    let (dx, dy) = (b.x - a.x, b.y - a.y);
    let len2 = dx * dx + dy * dy;
    let r = ((p.x - a.x) * dx + (p.y - a.y) * dy) / len2;
    if r <= 0.0 {
        return dist(p, a);
    }
    if r >= 1.0 {
        return dist(p, b);
    }
    let s = ((a.y - p.y) * dx - (a.x - p.x) * dy) / len2;
    s.abs() * len2.sqrt()
}

/// The per-chord distance in a form that is cheap to compare: within one chord a
/// larger key means a farther point, and `exceeds` tells whether a key is beyond
/// epsilon. For the line metric the key is `|cross|`, so no division or square root
/// runs in the inner loop.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Chord {
    pub a: Point2<f64>,
    pub b: Point2<f64>,
    metric: Metric,
    /// Squared chord length; zero for a degenerate chord (first point equals last).
    len2: f64,
}

impl Chord {
    #[inline]
    pub fn new(a: Point2<f64>, b: Point2<f64>, metric: Metric) -> Self {
        let len2 = (b - a).norm_squared();
        Self { a, b, metric, len2 }
    }

    /// True when both ends coincide: every metric becomes the distance to that point.
    #[inline]
    pub fn is_degenerate(&self) -> bool {
        self.len2 == 0.0
    }

    #[inline(always)]
    pub fn key(&self, p: &Point2<f64>) -> f64 {
        match self.metric {
            Metric::Segment => segment_distance(p, &self.a, &self.b),
            Metric::Line if self.len2 == 0.0 => (p - self.a).norm_squared(),
            Metric::Line => cross(&self.a, &self.b, p).abs(),
        }
    }

    /// Whether a point with this key lies farther than `epsilon` from the chord.
    #[inline(always)]
    pub fn exceeds(&self, key: f64, epsilon: f64) -> bool {
        match self.metric {
            Metric::Segment => key > epsilon,
            Metric::Line if self.len2 == 0.0 => key > epsilon * epsilon,
            // |cross| / |b - a| > eps, squared to avoid the root.
            Metric::Line => key * key > epsilon * epsilon * self.len2,
        }
    }

    /// Distance in length units for a key (used to report errors, not in loops).
    pub fn distance(&self, key: f64) -> f64 {
        match self.metric {
            Metric::Segment => key,
            Metric::Line if self.len2 == 0.0 => key.sqrt(),
            Metric::Line => key / self.len2.sqrt(),
        }
    }
}

/// Distance from `p` to the chord `a b` in the given metric, in length units.
pub fn chord_distance(p: &Point2<f64>, a: &Point2<f64>, b: &Point2<f64>, metric: Metric) -> f64 {
    let chord = Chord::new(*a, *b, metric);
    chord.distance(chord.key(p))
}
