//! Exact signs of small polynomials in the coordinates, for the decisions that must
//! not depend on round-off: which of two vertices is farther from a chord, and on
//! which side of a hull edge a vertex lies.
//!
//! Every quantity here is a sum of products of coordinate differences. A difference of
//! two doubles is held exactly as an unevaluated pair `hi + lo` (Knuth's two-sum), a
//! product of two doubles exactly as a pair (Dekker's split product), and the sign of
//! the resulting sum of at most [`CAP`] terms is read off a non-overlapping expansion
//! (Shewchuk 1997, "Adaptive precision floating-point arithmetic", grow-expansion with
//! zero elimination). Callers first try a floating-point evaluation with a proven
//! error bound and come here only when it cannot decide.
//!
//! The arithmetic is exact as long as no partial product underflows. Each difference
//! vector is rescaled by a power of two (which changes no sign) so that its largest
//! part is about 1; a product then underflows only when one coordinate difference is
//! below 2^-900 times another one of the same comparison.

use nalgebra::Point2;

/// Most terms a comparison produces (two expanded cross products of pairs).
pub(crate) const CAP: usize = 32;

/// Unit round-off of `f64`: every rounded operation has relative error at most `U`.
pub(crate) const U: f64 = f64::EPSILON / 2.0;

/// Smallest positive subnormal: the absolute error of an operation that underflows.
pub(crate) const ETA: f64 = f64::from_bits(1);

#[inline(always)]
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bv = s - a;
    let av = s - bv;
    (s, (a - av) + (b - bv))
}

/// `a - b` exactly as `hi + lo`.
#[inline(always)]
pub(crate) fn two_diff(a: f64, b: f64) -> [f64; 2] {
    let d = a - b;
    let bv = a - d;
    let av = d + bv;
    [d, (a - av) + (bv - b)]
}

/// Veltkamp's split: `a = hi + lo` with both halves of at most 26 significant bits.
#[inline(always)]
fn split(a: f64) -> (f64, f64) {
    let c = 134_217_729.0 * a; // 2^27 + 1
    let hi = c - (c - a);
    (hi, a - hi)
}

/// `a * b` exactly as `p + e` (Dekker), without relying on a hardware FMA.
#[inline(always)]
fn two_prod(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    let (ah, al) = split(a);
    let (bh, bl) = split(b);
    let e = al * bl - (((p - ah * bh) - al * bh) - ah * bl);
    (p, e)
}

/// A bounded list of terms whose exact sum's sign is wanted.
pub(crate) struct Terms {
    t: [f64; CAP],
    len: usize,
}

impl Terms {
    pub(crate) fn new() -> Self {
        Self {
            t: [0.0; CAP],
            len: 0,
        }
    }

    /// Adds `sign * x * y` for every pair of parts of the expansions `x` and `y`.
    pub(crate) fn add_products(&mut self, x: &[f64], y: &[f64], sign: f64) {
        for &a in x {
            for &b in y {
                let (p, e) = two_prod(a, b);
                self.t[self.len] = sign * p;
                self.t[self.len + 1] = sign * e;
                self.len += 2;
            }
        }
    }

    /// The exact sum as a non-overlapping expansion, increasing in magnitude, without
    /// zeros: grow-expansion adds one term at a time with two-sums.
    fn expansion(&self) -> ([f64; CAP], usize) {
        let mut e = [0.0f64; CAP];
        let mut len = 0;
        for &b in &self.t[..self.len] {
            let mut q = b;
            let mut k = 0;
            for i in 0..len {
                let (s, err) = two_sum(q, e[i]);
                if err != 0.0 {
                    e[k] = err;
                    k += 1;
                }
                q = s;
            }
            if q != 0.0 {
                e[k] = q;
                k += 1;
            }
            len = k;
        }
        (e, len)
    }

    /// The sign of the exact sum: -1, 0 or 1 (that of the largest component).
    pub(crate) fn sign(&self) -> i8 {
        let (e, len) = self.expansion();
        match len {
            0 => 0,
            _ if e[len - 1] > 0.0 => 1,
            _ => -1,
        }
    }

    /// The exact sum rounded to within an ulp: the components, smallest first.
    pub(crate) fn estimate(&self) -> f64 {
        let (e, len) = self.expansion();
        e[..len].iter().sum()
    }
}

/// `2^k` for `k` in the normal exponent range.
#[inline]
fn pow2(k: i32) -> f64 {
    debug_assert!((-1022..=1023).contains(&k));
    f64::from_bits(((k + 1023) as u64) << 52)
}

/// Binary exponent of a finite non-zero `x`: `x = m * 2^e` with `1 <= |m| < 2`.
#[inline]
pub(crate) fn exponent(x: f64) -> i32 {
    let bits = x.abs().to_bits();
    let biased = (bits >> 52) as i32;
    if biased != 0 {
        biased - 1023
    } else {
        // Subnormal: the leading one sits below the implicit bit.
        -1011 - (bits.leading_zeros() as i32)
    }
}

/// Multiplies `x` by `2^k` in at most three exact steps (each factor is normal).
#[inline]
pub(crate) fn ldexp(mut x: f64, mut k: i32) -> f64 {
    while k > 1000 {
        x *= pow2(1000);
        k -= 1000;
    }
    while k < -1000 {
        x *= pow2(-1000);
        k += 1000;
    }
    x * pow2(k)
}

/// Rescales the parts in place by one power of two, `2^k`, so that the largest is in
/// [1, 2), and returns `k`. Signs of cross products and comparisons of squared norms
/// do not change.
pub(crate) fn normalize(parts: &mut [f64]) -> i32 {
    let m = parts.iter().fold(0.0f64, |m, &v| m.max(v.abs()));
    if m == 0.0 {
        return 0;
    }
    let k = -exponent(m);
    if k != 0 {
        parts.iter_mut().for_each(|v| *v = ldexp(*v, k));
    }
    k
}

/// Exact sign of `(w - u) x (p - u)`: positive when `p` is left of `u -> w`.
/// A floating-point evaluation with Shewchuk's error bound decides almost always.
#[inline]
pub(crate) fn orient(u: &Point2<f64>, w: &Point2<f64>, p: &Point2<f64>) -> i8 {
    let l = (w.x - u.x) * (p.y - u.y);
    let r = (w.y - u.y) * (p.x - u.x);
    let det = l - r;
    // (3 + 16 u) u (|l| + |r|) bounds the error without underflow; 4 ETA covers it.
    let bound = (3.0 + 16.0 * U) * U * (l.abs() + r.abs()) + 4.0 * ETA;
    if det > bound {
        1
    } else if -det > bound {
        -1
    } else {
        orient_exact(u, w, p)
    }
}

#[cold]
fn orient_exact(u: &Point2<f64>, w: &Point2<f64>, p: &Point2<f64>) -> i8 {
    let mut v = [two_diff(w.x, u.x), two_diff(w.y, u.y)].concat();
    let mut q = [two_diff(p.x, u.x), two_diff(p.y, u.y)].concat();
    let _ = (normalize(&mut v), normalize(&mut q));
    let mut t = Terms::new();
    t.add_products(&v[..2], &q[2..], 1.0);
    t.add_products(&v[2..], &q[..2], -1.0);
    t.sign()
}

/// The exact `d x v`, for a direction held as pairs `dx = [hi, lo]`, `dy` and a vector
/// whose components are expansions of equal length (2 or 4 parts), as terms of
/// `2^k (d x v)`; `v` is rescaled by `2^k` to keep the products clear of underflow.
fn cross_terms(dx: &[f64; 2], dy: &[f64; 2], vx: &[f64], vy: &[f64]) -> (Terms, i32) {
    let n = vx.len();
    let mut v = [0.0f64; 8];
    v[..n].copy_from_slice(vx);
    v[n..2 * n].copy_from_slice(vy);
    let k = normalize(&mut v[..2 * n]);
    let mut t = Terms::new();
    t.add_products(dx, &v[n..2 * n], 1.0);
    t.add_products(dy, &v[..n], -1.0);
    (t, k)
}

/// Exact sign of `d x v` (see [`cross_terms`]).
pub(crate) fn cross_sign(dx: &[f64; 2], dy: &[f64; 2], vx: &[f64], vy: &[f64]) -> i8 {
    cross_terms(dx, dy, vx, vy).0.sign()
}

/// `d x v` rounded to within an ulp (see [`cross_terms`]).
pub(crate) fn cross_value(dx: &[f64; 2], dy: &[f64; 2], vx: &[f64], vy: &[f64]) -> f64 {
    let (t, k) = cross_terms(dx, dy, vx, vy);
    ldexp(t.estimate(), -k)
}

/// Exact sign of `|p - a|^2 - |q - a|^2`.
pub(crate) fn compare_squared_distances(a: &Point2<f64>, p: &Point2<f64>, q: &Point2<f64>) -> i8 {
    let mut v = [
        two_diff(p.x, a.x),
        two_diff(p.y, a.y),
        two_diff(q.x, a.x),
        two_diff(q.y, a.y),
    ]
    .concat();
    let _ = normalize(&mut v);
    let mut t = Terms::new();
    for (k, sign) in [(0, 1.0), (2, 1.0), (4, -1.0), (6, -1.0)] {
        let part = [v[k], v[k + 1]];
        t.add_products(&part, &part, sign);
    }
    t.sign()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orient_decides_what_rounding_cannot() {
        // Three points on the line y = x through huge and tiny offsets: exactly collinear.
        let u = Point2::new(0.1, 0.1);
        let w = Point2::new(1e17 + 0.1, 1e17 + 0.1);
        let p = Point2::new(0.3, 0.3);
        assert_eq!(orient(&u, &w, &p), orient_exact(&u, &w, &p));
        // A nudge of one ulp in y moves p off the line, to the left.
        let p2 = Point2::new(0.5, f64::from_bits(0.5f64.to_bits() + 1));
        let u2 = Point2::new(0.0, 0.0);
        let w2 = Point2::new(1.0, 1.0);
        assert_eq!(orient(&u2, &w2, &p2), 1);
        assert_eq!(orient(&u2, &w2, &Point2::new(0.5, 0.5)), 0);
        let below = Point2::new(0.5, f64::from_bits(0.5f64.to_bits() - 1));
        assert_eq!(orient(&u2, &w2, &below), -1);
    }

    #[test]
    fn expansions_cancel_exactly() {
        let mut t = Terms::new();
        t.add_products(&[1e300, 1.0], &[1.0], 1.0);
        t.add_products(&[1e300], &[1.0], -1.0);
        assert_eq!(t.sign(), 1);
        let mut z = Terms::new();
        z.add_products(&[3.0, 1e-30], &[7.0], 1.0);
        z.add_products(&[21.0], &[1.0], -1.0);
        z.add_products(&[7e-30], &[1.0], -1.0);
        assert_eq!(z.sign(), 0);
    }

    #[test]
    fn exponent_and_ldexp_cover_subnormals() {
        assert_eq!(exponent(1.0), 0);
        assert_eq!(exponent(3.0), 1);
        assert_eq!(exponent(0.75), -1);
        assert_eq!(exponent(f64::MIN_POSITIVE), -1022);
        assert_eq!(exponent(ETA), -1074);
        assert_eq!(ldexp(ETA, 1074), 1.0);
        assert_eq!(ldexp(1.0, -1074), ETA);
        assert_eq!(ldexp(3.0, 1000), 3.0 * 2f64.powi(1000));
    }

    #[test]
    fn squared_distances_compare_exactly() {
        let a = Point2::new(0.0, 0.0);
        // A 3-4-5 triangle: equal distances, then one ulp apart.
        assert_eq!(
            compare_squared_distances(&a, &Point2::new(3.0, 4.0), &Point2::new(5.0, 0.0)),
            0
        );
        let just_over = Point2::new(0.0, f64::from_bits(5f64.to_bits() + 1));
        assert_eq!(
            compare_squared_distances(&a, &Point2::new(3.0, 4.0), &just_over),
            -1
        );
        // Offsets that round differently in p - a still compare exactly.
        let b = Point2::new(0.1, 0.2);
        let p = Point2::new(0.1 + 3.0, 0.2);
        assert_eq!(compare_squared_distances(&b, &p, &p), 0);
        assert_eq!(compare_squared_distances(&b, &p, &b), 1);
    }
}
