//! Exact geometric predicates for the topology checks: the sign of an orientation, the
//! "interior intersection" test of two segments and the ray-crossing parity used to
//! detect a chord jumping over another component.
//!
//! A wrong sign here would let a simplified chord cross another segment, so the
//! orientation is exact: a floating-point filter (Shewchuk's error bound) answers the
//! easy cases and an exact expansion sum the near-degenerate ones.

use nalgebra::Point2;

type P = Point2<f64>;

/// Shewchuk's bound `(3 + 16u) u` on the relative error of the filtered determinant,
/// with `u = 2^-53`.
const ORIENT_ERRBOUND: f64 = (3.0 + 16.0 * (f64::EPSILON / 2.0)) * (f64::EPSILON / 2.0);

/// Sign of twice the signed area of (a, b, c): `1` when `c` is left of `a -> b`
/// (counter-clockwise), `-1` when right, `0` when the three are exactly collinear.
pub(crate) fn orientation(a: &P, b: &P, c: &P) -> i8 {
    let left = (a.x - c.x) * (b.y - c.y);
    let right = (a.y - c.y) * (b.x - c.x);
    let det = left - right;
    if det.abs() >= ORIENT_ERRBOUND * (left.abs() + right.abs()) {
        return sign(det);
    }
    exact_orientation(a, b, c)
}

fn sign(v: f64) -> i8 {
    if v > 0.0 {
        1
    } else if v < 0.0 {
        -1
    } else {
        0
    }
}

/// `x + y` as an unevaluated sum `(s, e)` with `s = fl(x + y)` (Knuth's TwoSum).
fn two_sum(x: f64, y: f64) -> (f64, f64) {
    let s = x + y;
    let yv = s - x;
    let xv = s - yv;
    (s, (x - xv) + (y - yv))
}

/// `x * y` exactly as `(p, e)` with `p = fl(x * y)`; the fused multiply-add gives the
/// rounding error exactly.
fn two_product(x: f64, y: f64) -> (f64, f64) {
    let p = x * y;
    (p, x.mul_add(y, -p))
}

/// The determinant expanded into six products of input coordinates (the `c.x * c.y`
/// terms cancel), each split exactly in two, summed exactly by growing a nonoverlapping
/// expansion (Shewchuk's Grow-Expansion). The sign of an expansion is the sign of its
/// largest nonzero component, which Grow-Expansion keeps last.
fn exact_orientation(a: &P, b: &P, c: &P) -> i8 {
    let products = [
        two_product(a.x, b.y),
        two_product(-a.x, c.y),
        two_product(-c.x, b.y),
        two_product(-a.y, b.x),
        two_product(a.y, c.x),
        two_product(c.y, b.x),
    ];
    let mut expansion = [0.0f64; 12];
    let mut len = 0;
    for (p, e) in products {
        for term in [e, p] {
            let mut carry = term;
            for slot in expansion.iter_mut().take(len) {
                let (s, err) = two_sum(carry, *slot);
                *slot = err;
                carry = s;
            }
            expansion[len] = carry;
            len += 1;
        }
    }
    expansion[..len]
        .iter()
        .rev()
        .find(|v| **v != 0.0)
        .map_or(0, |v| sign(*v))
}

fn in_envelope(p: &P, a: &P, b: &P) -> bool {
    p.x >= a.x.min(b.x) && p.x <= a.x.max(b.x) && p.y >= a.y.min(b.y) && p.y <= a.y.max(b.y)
}

fn envelopes_meet(a0: &P, a1: &P, b0: &P, b1: &P) -> bool {
    a0.x.min(a1.x) <= b0.x.max(b1.x)
        && b0.x.min(b1.x) <= a0.x.max(a1.x)
        && a0.y.min(a1.y) <= b0.y.max(b1.y)
        && b0.y.min(b1.y) <= a0.y.max(a1.y)
}

/// Whether the segments `a0 a1` and `b0 b1` meet anywhere except at a point that is
/// an end point of both (GEOS's `isInteriorIntersection`): crossing, touching one in
/// its interior, or overlapping along a stretch all count; sharing an end point does
/// not. Degenerate (zero-length) segments are points.
pub(crate) fn interior_intersection(a0: &P, a1: &P, b0: &P, b1: &P) -> bool {
    if !envelopes_meet(a0, a1, b0, b1) {
        return false;
    }
    let (pq0, pq1) = (orientation(a0, a1, b0), orientation(a0, a1, b1));
    if pq0 * pq1 > 0 {
        return false;
    }
    let (qp0, qp1) = (orientation(b0, b1, a0), orientation(b0, b1, a1));
    if qp0 * qp1 > 0 {
        return false;
    }
    let end_of_both = |x: &P| (x == a0 || x == a1) && (x == b0 || x == b1);
    if pq0 == 0 && pq1 == 0 && qp0 == 0 && qp1 == 0 {
        // Collinear: the common points are the end points lying in the other segment.
        return [(b0, a0, a1), (b1, a0, a1), (a0, b0, b1), (a1, b0, b1)]
            .iter()
            .any(|(x, s0, s1)| in_envelope(x, s0, s1) && !end_of_both(x));
    }
    // Not collinear: one common point. If it is an end point on the other line, it is
    // that end point; otherwise the crossing is proper, inside both segments.
    let touching = if pq0 == 0 {
        b0
    } else if pq1 == 0 {
        b1
    } else if qp0 == 0 {
        a0
    } else if qp1 == 0 {
        a1
    } else {
        return true;
    };
    !end_of_both(touching)
}

/// Whether the segments are the same, in either direction.
pub(crate) fn same_segment(a0: &P, a1: &P, b0: &P, b1: &P) -> bool {
    (a0 == b0 && a1 == b1) || (a0 == b1 && a1 == b0)
}

/// Whether the segment `a b` crosses the ray from `p` towards +x, with the half-open
/// rule of point-in-polygon tests (a segment counts when one end is strictly above `p`
/// and the other is not) and segments through `p` not counted. The parity of the count
/// over a closed chain tells whether `p` is inside it.
pub(crate) fn crosses_ray(p: &P, a: &P, b: &P) -> bool {
    if a.x < p.x && b.x < p.x {
        return false;
    }
    if (a.y > p.y) == (b.y > p.y) {
        return false;
    }
    // Orient the segment upwards; it is right of `p` when `p` is on its left.
    let o = if b.y > a.y {
        orientation(a, b, p)
    } else {
        orientation(b, a, p)
    };
    o > 0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(x: f64, y: f64) -> P {
        P::new(x, y)
    }

    #[test]
    fn orientation_is_exact_where_the_naive_determinant_is_not() {
        // Points on the line y = x with coordinates that round: the naive formula
        // gives nonzero noise for some of them; the exact one returns 0 or the true
        // sign, checked against a rational evaluation in i128 of scaled integers.
        let base = 0.5f64;
        for i in 0..200 {
            for j in 0..200 {
                let a = p(
                    base + i as f64 * f64::EPSILON,
                    base + j as f64 * f64::EPSILON,
                );
                let b = p(12.0, 12.0);
                let c = p(24.0, 24.0);
                // Scale by 2^53: every coordinate becomes an integer.
                let s = (1u64 << 53) as f64;
                let q = |v: f64| (v * s) as i128;
                let det =
                    (q(a.x) - q(c.x)) * (q(b.y) - q(c.y)) - (q(a.y) - q(c.y)) * (q(b.x) - q(c.x));
                assert_eq!(orientation(&a, &b, &c), det.signum() as i8, "{i} {j}");
            }
        }
    }

    #[test]
    fn interior_intersection_cases() {
        let (o, x, y, xy) = (p(0.0, 0.0), p(2.0, 0.0), p(0.0, 2.0), p(2.0, 2.0));
        assert!(interior_intersection(&o, &xy, &x, &y)); // proper crossing
        assert!(!interior_intersection(&o, &x, &o, &y)); // shared end point
        assert!(interior_intersection(&o, &x, &p(1.0, 0.0), &p(1.0, 1.0))); // T
        assert!(interior_intersection(&o, &x, &p(1.0, 0.0), &p(3.0, 0.0))); // overlap
        assert!(!interior_intersection(&o, &p(1.0, 0.0), &p(1.0, 0.0), &x)); // collinear chain
        assert!(!interior_intersection(&o, &x, &y, &xy)); // disjoint
        assert!(!interior_intersection(&o, &x, &p(3.0, 0.0), &p(4.0, 0.0))); // collinear apart
        assert!(interior_intersection(&o, &x, &p(1.0, 0.0), &p(1.0, 0.0))); // point inside
        assert!(!interior_intersection(&o, &x, &x, &x)); // point at an end
        assert!(!interior_intersection(&o, &x, &p(1.0, 1.0), &p(1.0, 1.0))); // point off
        assert!(same_segment(&o, &x, &x, &o) && !same_segment(&o, &x, &o, &y));
    }

    #[test]
    fn ray_crossings_give_point_in_polygon_parity() {
        let square = [
            p(0.0, 0.0),
            p(4.0, 0.0),
            p(4.0, 4.0),
            p(0.0, 4.0),
            p(0.0, 0.0),
        ];
        let count = |q: P| {
            square
                .windows(2)
                .filter(|w| crosses_ray(&q, &w[0], &w[1]))
                .count()
        };
        assert_eq!(count(p(1.0, 1.0)) % 2, 1);
        assert_eq!(count(p(5.0, 1.0)) % 2, 0);
        assert_eq!(count(p(-1.0, 1.0)) % 2, 0);
        assert_eq!(count(p(1.0, 0.0)) % 2, 1); // on the bottom edge: half-open rule
        assert_eq!(count(p(1.0, 5.0)) % 2, 0);
    }
}
