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

/// A bounded list of non-zero terms whose exact sum is wanted.
pub(crate) struct Terms {
    t: [f64; CAP],
    len: usize,
}

impl Terms {
    #[inline]
    pub(crate) fn new() -> Self {
        Self {
            t: [0.0; CAP],
            len: 0,
        }
    }

    #[inline(always)]
    fn push(&mut self, x: f64) {
        if x != 0.0 {
            self.t[self.len] = x;
            self.len += 1;
        }
    }

    /// Adds `sign * x * y` for every pair of non-zero parts of the expansions `x`, `y`
    /// (exact differences of doubles often have a zero low part).
    #[inline]
    pub(crate) fn add_products(&mut self, x: &[f64], y: &[f64], sign: f64) {
        for &a in x.iter().filter(|a| **a != 0.0) {
            for &b in y.iter().filter(|b| **b != 0.0) {
                let (p, e) = two_prod(a, b);
                self.push(sign * p);
                self.push(sign * e);
            }
        }
    }

    /// Grow-expansion with zero elimination: writes the exact sum into `e` as a
    /// non-overlapping expansion in increasing magnitude and returns its length.
    fn expansion(&self, e: &mut [f64; CAP]) -> usize {
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
        len
    }

    /// The sign of the exact sum: -1, 0 or 1 (that of the largest component).
    pub(crate) fn sign(&self) -> i8 {
        let top = match self.len {
            0 => 0.0,
            1 => self.t[0],
            _ => {
                let mut e = [0.0f64; CAP];
                let len = self.expansion(&mut e);
                if len == 0 { 0.0 } else { e[len - 1] }
            }
        };
        (top > 0.0) as i8 - (top < 0.0) as i8
    }

    /// The exact sum rounded to within an ulp: the components, smallest first.
    pub(crate) fn estimate(&self) -> f64 {
        let mut e = [0.0f64; CAP];
        let len = self.expansion(&mut e);
        e[..len].iter().sum()
    }
}

/// `2^k` for `k` in the normal exponent range.
#[inline]
pub(crate) fn pow2(k: i32) -> f64 {
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
/// [1, 2), and returns `k`; parts already between 2^-300 and 2^300 are left alone.
/// Either way no product of two parts underflows, and signs of cross products and
/// comparisons of squared norms do not change.
#[inline]
pub(crate) fn normalize(parts: &mut [f64]) -> i32 {
    let m = parts.iter().fold(0.0f64, |m, &v| m.max(v.abs()));
    if m == 0.0 || (SAFE_LO..=SAFE_HI).contains(&m) {
        return 0;
    }
    let k = -exponent(m);
    parts.iter_mut().for_each(|v| *v = ldexp(*v, k));
    k
}

const SAFE_LO: f64 = f64::from_bits((1023 - 300) << 52); // 2^-300
const SAFE_HI: f64 = f64::from_bits((1023 + 300) << 52); // 2^300

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
    if let Some(s) = exact_products_sign(
        [two_diff(w.x, u.x), two_diff(p.y, u.y)],
        [two_diff(w.y, u.y), two_diff(p.x, u.x)],
    ) {
        return s;
    }
    let ([vx, vy], [qx, qy]) = (
        [two_diff(w.x, u.x), two_diff(w.y, u.y)],
        [two_diff(p.x, u.x), two_diff(p.y, u.y)],
    );
    let mut v = [vx[0], vx[1], vy[0], vy[1]];
    let mut q = [qx[0], qx[1], qy[0], qy[1]];
    let _ = (normalize(&mut v), normalize(&mut q));
    let mut t = Terms::new();
    t.add_products(&v[..2], &q[2..], 1.0);
    t.add_products(&v[2..], &q[..2], -1.0);
    t.sign()
}

/// Sign of `a0 a1 - b0 b1` for pairs held as `[hi, lo]`, when the cheap route is
/// exact: every low part is zero (the differences were exact, as for data on a grid)
/// and both products are exact in floating point (their Dekker error is zero and no
/// factor is small enough to underflow). `None` sends the caller to full expansions.
#[inline]
fn exact_products_sign(a: [[f64; 2]; 2], b: [[f64; 2]; 2]) -> Option<i8> {
    let lows = a[0][1] == 0.0 && a[1][1] == 0.0 && b[0][1] == 0.0 && b[1][1] == 0.0;
    let in_range = |x: f64| x == 0.0 || (SAFE_LO..=SAFE_HI).contains(&x.abs());
    let his = [a[0][0], a[1][0], b[0][0], b[1][0]];
    if !lows || !his.iter().all(|&x| in_range(x)) {
        return None;
    }
    let (l, le) = two_prod(a[0][0], a[1][0]);
    let (r, re) = two_prod(b[0][0], b[1][0]);
    // Both products exact: l - r rounds to a value of the exact sign.
    (le == 0.0 && re == 0.0).then(|| {
        let d = l - r;
        (d > 0.0) as i8 - (d < 0.0) as i8
    })
}

/// Adds the exact `d x v` to `t`, for a direction held as pairs `dx = [hi, lo]`, `dy`
/// and a vector whose components are expansions of equal length (2 or 4 parts),
/// rescaled by `2^k` (returned) to keep the products clear of underflow.
#[inline]
fn cross_terms(dx: &[f64; 2], dy: &[f64; 2], vx: &[f64], vy: &[f64], t: &mut Terms) -> i32 {
    let n = vx.len();
    let mut v = [0.0f64; 8];
    v[..n].copy_from_slice(vx);
    v[n..2 * n].copy_from_slice(vy);
    let k = normalize(&mut v[..2 * n]);
    t.add_products(dx, &v[n..2 * n], 1.0);
    t.add_products(dy, &v[..n], -1.0);
    k
}

/// Exact sign of `d x v` (see [`cross_terms`]).
pub(crate) fn cross_sign(dx: &[f64; 2], dy: &[f64; 2], vx: &[f64], vy: &[f64]) -> i8 {
    if vx.len() == 2
        && let Some(s) = exact_products_sign([*dx, [vy[0], vy[1]]], [*dy, [vx[0], vx[1]]])
    {
        return s;
    }
    let mut t = Terms::new();
    cross_terms(dx, dy, vx, vy, &mut t);
    t.sign()
}

/// `d x v` rounded to within an ulp (see [`cross_terms`]).
pub(crate) fn cross_value(dx: &[f64; 2], dy: &[f64; 2], vx: &[f64], vy: &[f64]) -> f64 {
    let mut t = Terms::new();
    let k = cross_terms(dx, dy, vx, vy, &mut t);
    ldexp(t.estimate(), -k)
}

/// Exact sign of `|p - a|^2 - |q - a|^2`.
pub(crate) fn compare_squared_distances(a: &Point2<f64>, p: &Point2<f64>, q: &Point2<f64>) -> i8 {
    let d = [
        two_diff(p.x, a.x),
        two_diff(p.y, a.y),
        two_diff(q.x, a.x),
        two_diff(q.y, a.y),
    ];
    let mut v = [
        d[0][0], d[0][1], d[1][0], d[1][1], d[2][0], d[2][1], d[3][0], d[3][1],
    ];
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
