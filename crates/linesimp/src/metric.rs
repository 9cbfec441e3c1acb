//! Distances from a point to a chord: the seed's line metric (Table 2) and the
//! point-to-segment metric used by GEOS/shapely and geo.
//!
//! Both are evaluated in a frame rescaled by a power of two chosen from the chord (and
//! the polyline's extent), never from the absolute scale of the input. Multiplying by
//! a power of two is exact, so no square overflows or underflows, and scaling the input
//! and epsilon together by any power of two leaves every decision bit-for-bit unchanged.

mod exact;

use std::cmp::Ordering;

use nalgebra::Point2;

use crate::{LineSimpError, Result};
pub(crate) use exact::orient;
use exact::{ETA, U, cross_sign, cross_value, exponent, ldexp, pow2, two_diff};

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

/// Which peer's point-to-segment arithmetic [`Metric::Segment`] reproduces.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum SegmentFormula {
    /// GEOS `Distance::pointToSegment`: `sqrt` of sums of squares.
    Geos,
    /// geo `line_segment_distance`: `hypot`.
    Geo,
}

/// Coordinates may span at most this much in x and in y: then every difference of two
/// coordinates, and every cross product of a normalised direction with one, is finite.
pub(crate) const MAX_SPAN: f64 = f64::from_bits(2043 << 52); // 2^1020

/// The spans of a polyline's bounding box: they bound every coordinate difference,
/// hence the round-off of every key, and fix the scale of the metric frames.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Extent {
    x: f64,
    y: f64,
    /// Binary exponent of the larger span (0 for a single repeated point).
    exp: i32,
    /// Every coordinate is a multiple of one power of two `2^g` and the spans are below
    /// `2^(g + 26)`: then coordinate differences, their products and the cross products
    /// of two such differences are all exact in floating point (at most 53 bits), so
    /// orientation tests and key comparisons need no error bound (integer data).
    pub grid: bool,
}

impl Extent {
    /// Scans the points once; refuses spans beyond [`MAX_SPAN`] with a clear error.
    pub fn of(points: &[Point2<f64>]) -> Result<Self> {
        let (mut lo, mut hi) = (points[0], points[0]);
        for p in points {
            lo.x = lo.x.min(p.x);
            lo.y = lo.y.min(p.y);
            hi.x = hi.x.max(p.x);
            hi.y = hi.y.max(p.y);
        }
        let (x, y) = (hi.x - lo.x, hi.y - lo.y);
        if !(x <= MAX_SPAN && y <= MAX_SPAN) {
            return Err(LineSimpError::InvalidParameter {
                name: "points",
                reason: format!(
                    "coordinates span x [{:e}, {:e}] and y [{:e}, {:e}]; spans above \
                     2^1020 (about 1.1e307) are not supported, rescale the points",
                    lo.x, hi.x, lo.y, hi.y
                ),
            });
        }
        let m = x.max(y);
        let exp = if m > 0.0 { exponent(m) } else { 0 };
        let grid = m > 0.0 && on_grid(points, exp - 25);
        Ok(Self { x, y, exp, grid })
    }
}

/// Whether every coordinate is an integer multiple of `2^g` (conservatively false for
/// multiples beyond 2^62, and for `g` so extreme that a product of two differences,
/// a multiple of `2^2g` below `2^(2g + 52)`, could underflow or overflow).
fn on_grid(points: &[Point2<f64>], g: i32) -> bool {
    if !(-520..=480).contains(&g) {
        return false;
    }
    let s = ldexp(1.0, -g);
    let whole = |v: f64| {
        let t = v * s;
        t.abs() < 4.6e18 && (t as i64) as f64 == t
    };
    points.iter().all(|p| whole(p.x) && whole(p.y))
}

/// Exact sign of `(w - u) x (p - u)`; on a grid (see [`Extent::grid`]) the
/// floating-point determinant is exact and is used as it is.
#[inline(always)]
pub(crate) fn orient_on(grid: bool, u: &Point2<f64>, w: &Point2<f64>, p: &Point2<f64>) -> i8 {
    if grid {
        let det = (w.x - u.x) * (p.y - u.y) - (w.y - u.y) * (p.x - u.x);
        (det > 0.0) as i8 - (det < 0.0) as i8
    } else {
        orient(u, w, p)
    }
}

/// `2^-k` with `k` clamped to the normal range (the frames never need more).
#[inline]
fn inv_pow2(k: i32) -> f64 {
    ldexp(1.0, -k.clamp(-1022, 1022))
}

/// `|(x, y)|` without overflow or underflow: rescaled by the larger component's
/// binary exponent, so the result is the same for every power-of-two scaling.
#[inline]
pub(crate) fn scaled_norm(x: f64, y: f64) -> f64 {
    let m = x.abs().max(y.abs());
    if m == 0.0 {
        return 0.0;
    }
    let k = exponent(m);
    let (xs, ys) = (ldexp(x, -k), ldexp(y, -k));
    ldexp((xs * xs + ys * ys).sqrt(), k)
}

/// The line metric for one chord `a b`, in the form the split search needs.
///
/// For `a != b` the exact quantity compared is `F(p) = (b - a) x (p - a)` divided by a
/// power of two (the chord's binary exponent): `|F(p)| / |b - a|` is the distance of
/// Table 2. [`Self::key`] evaluates it in floating point, within [`Self::tol`] of the
/// exact value for every point of the polyline, so comparisons of keys further apart
/// than that are decided without further work and closer ones exactly. The kept
/// vertex therefore depends only on exact geometry and the index rule, never on
/// round-off, and plain DP and path hulls, which compare different pairs of points,
/// agree. For `a == b` the quantity is `|p - a|^2`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct LineChord {
    pub a: Point2<f64>,
    /// `fl(b - a)` divided by `2^e`, `e` the exponent of its larger component.
    dx: f64,
    dy: f64,
    /// The exact `b - a` divided by `2^e`, as `[hi, lo]` pairs (`hi` is `dx`, `dy`).
    ex: [f64; 2],
    ey: [f64; 2],
    /// `|(dx, dy)|`, in [1, 2 sqrt 2).
    norm: f64,
    /// Bound on `|key(p) - F(p)|` for every point of the polyline.
    tol: f64,
    /// For `a == b`: the power of two that brings the extent to [1, 2).
    point_scale: f64,
    degenerate: bool,
    /// Keys are exact (grid data): equal keys are equal distances.
    exact: bool,
}

impl LineChord {
    pub fn new(a: Point2<f64>, b: Point2<f64>, extent: &Extent) -> Self {
        let (bx, by) = (two_diff(b.x, a.x), two_diff(b.y, a.y));
        let m = bx[0].abs().max(by[0].abs());
        if m == 0.0 {
            let point_scale = inv_pow2(extent.exp);
            let (sx, sy) = (extent.x * point_scale, extent.y * point_scale);
            return Self {
                a,
                dx: 0.0,
                dy: 0.0,
                ex: [0.0; 2],
                ey: [0.0; 2],
                norm: 0.0,
                tol: 8.0 * U * (sx * sx + sy * sy) + 8.0 * ETA,
                point_scale,
                degenerate: true,
                exact: false,
            };
        }
        let k = -exponent(m);
        let scale = |v: f64| match k {
            -1022..=1023 => v * pow2(k),
            _ => ldexp(v, k),
        };
        let ex = [scale(bx[0]), scale(bx[1])];
        let ey = [scale(by[0]), scale(by[1])];
        let (dx, dy) = (ex[0], ey[0]);
        // fl(b - a), fl(p - a), two products and a difference: at most 4 roundings of
        // relative size U on |dx| |p.y - a.y| + |dy| |p.x - a.x|, plus underflow.
        let tol = match extent.grid {
            true => 0.0,
            false => 8.0 * U * (dx.abs() * extent.y + dy.abs() * extent.x) + 8.0 * ETA,
        };
        Self {
            a,
            dx,
            dy,
            ex,
            ey,
            norm: (dx * dx + dy * dy).sqrt(),
            tol,
            point_scale: 1.0,
            degenerate: false,
            exact: extent.grid,
        }
    }

    /// True when both ends coincide: the distance is then to that point.
    #[inline]
    pub fn is_degenerate(&self) -> bool {
        self.degenerate
    }

    /// `F(p)` in floating point, signed (for `a == b`: `|p - a|^2`, rescaled).
    #[inline(always)]
    pub fn key(&self, p: &Point2<f64>) -> f64 {
        if self.degenerate {
            self.point_key(p)
        } else {
            self.line_key(p)
        }
    }

    /// [`Self::key`] of a proper chord.
    #[inline(always)]
    pub fn line_key(&self, p: &Point2<f64>) -> f64 {
        self.dx * (p.y - self.a.y) - self.dy * (p.x - self.a.x)
    }

    /// [`Self::key`] of a degenerate chord.
    #[inline(always)]
    pub fn point_key(&self, p: &Point2<f64>) -> f64 {
        let (x, y) = (
            (p.x - self.a.x) * self.point_scale,
            (p.y - self.a.y) * self.point_scale,
        );
        x * x + y * y
    }

    /// The round-off bound of [`Self::key`] (keys closer than `3 * tol` are compared
    /// exactly).
    #[inline(always)]
    pub fn tol(&self) -> f64 {
        self.tol
    }

    /// Exact sign of `F(p)`, given its key.
    pub fn sign(&self, p: &Point2<f64>, key: f64) -> i8 {
        if self.degenerate {
            return i8::from(*p != self.a);
        }
        if key.abs() > self.tol || self.exact {
            return (key > 0.0) as i8 - (key < 0.0) as i8;
        }
        let (vx, vy) = (two_diff(p.x, self.a.x), two_diff(p.y, self.a.y));
        cross_sign(&self.ex, &self.ey, &vx, &vy)
    }

    /// Exact comparison of `F(p)` with `F(q)` (signed; non-degenerate chords).
    pub fn cmp_signed(&self, p: &Point2<f64>, kp: f64, q: &Point2<f64>, kq: f64) -> Ordering {
        if let Some(order) = self.order_by_keys(kp, kq) {
            return order;
        }
        let (vx, vy) = (two_diff(p.x, q.x), two_diff(p.y, q.y));
        cross_sign(&self.ex, &self.ey, &vx, &vy).cmp(&0)
    }

    /// The order of two keys where the floats alone settle it: keys more than their
    /// error bound apart (each is within `tol` of its exact value, so `3 tol` leaves
    /// room), or any keys when they are exact. `None`: only exact arithmetic can tell.
    fn order_by_keys(&self, a: f64, b: f64) -> Option<Ordering> {
        use std::cmp::Ordering::*;
        let t = 3.0 * self.tol;
        if a > b + t {
            Some(Greater)
        } else if b > a + t {
            Some(Less)
        } else if self.exact {
            Some(Equal)
        } else {
            None
        }
    }

    /// Exact comparison of `|F(p)|` with `|F(q)|`: which of two points is farther.
    pub fn cmp_abs(&self, p: &Point2<f64>, kp: f64, q: &Point2<f64>, kq: f64) -> Ordering {
        use std::cmp::Ordering::*;
        if let Some(order) = self.order_by_keys(kp.abs(), kq.abs()) {
            return order;
        }
        if self.degenerate {
            return exact::compare_squared_distances(&self.a, p, q).cmp(&0);
        }
        let (sp, sq) = (self.sign(p, kp), self.sign(q, kq));
        match (sp, sq) {
            (0, 0) => return Equal,
            (0, _) => return Less,
            (_, 0) => return Greater,
            _ => {}
        }
        // |F(p)| - |F(q)| = sp (F(p) - F(q)) when the signs agree, and
        // sp (F(p) + F(q)) = sp (b - a) x ((p - a) + (q - a)) when they differ.
        let s = if sp == sq {
            let (vx, vy) = (two_diff(p.x, q.x), two_diff(p.y, q.y));
            cross_sign(&self.ex, &self.ey, &vx, &vy)
        } else {
            let a = &self.a;
            let ([px, qx], [py, qy]) = (
                [two_diff(p.x, a.x), two_diff(q.x, a.x)],
                [two_diff(p.y, a.y), two_diff(q.y, a.y)],
            );
            let vx = [px[0], px[1], qx[0], qx[1]];
            let vy = [py[0], py[1], qy[0], qy[1]];
            cross_sign(&self.ex, &self.ey, &vx, &vy)
        };
        (sp * s).cmp(&0)
    }

    /// The distance from `p` to the chord's line: `|F(p)| / |b - a|` with `F(p)`
    /// computed exactly and rounded, so within 4 ulps of the true distance, and 0
    /// exactly when `p` is on the line.
    pub fn distance(&self, p: &Point2<f64>) -> f64 {
        if self.degenerate {
            return scaled_norm(p.x - self.a.x, p.y - self.a.y);
        }
        let (vx, vy) = (two_diff(p.x, self.a.x), two_diff(p.y, self.a.y));
        cross_value(&self.ex, &self.ey, &vx, &vy).abs() / self.norm
    }

    /// Whether `p` is farther than `epsilon`: exactly `distance(p) > epsilon`, decided
    /// from the floating-point key whenever its error bound allows (the key alone can
    /// lose every digit to cancellation for a vertex close to a long chord).
    pub fn exceeds(&self, p: &Point2<f64>, epsilon: f64) -> bool {
        if !self.degenerate {
            // distance = |F| / |D|: |key| is within tol of |F| (plus 2 U of rounding
            // here) and norm within 2 U of |D|; `distance` is within 4 ulps. Compare
            // |key| with epsilon * norm, without a division, with margins for all that.
            let k = self.key(p).abs();
            let e = epsilon * self.norm;
            if k * (1.0 - 8.0 * U) - self.tol > e * (1.0 + 24.0 * U) {
                return true;
            }
            if k * (1.0 + 8.0 * U) + self.tol < e * (1.0 - 24.0 * U) {
                return false;
            }
        }
        self.distance(p) > epsilon
    }
}

/// The segment metric for one chord, evaluated exactly as GEOS (or geo) does but in a
/// frame scaled by `2^-e`: the same operations on scaled operands give the scaled
/// result bit for bit wherever the peer itself neither overflows nor underflows.
#[derive(Debug, Clone, Copy)]
pub(crate) struct SegmentChord {
    a: Point2<f64>,
    b: Point2<f64>,
    scale: f64,
    dx: f64,
    dy: f64,
    len2: f64,
    /// GEOS: `sqrt(len2)`; geo: `hypot(dx, dy)`.
    len: f64,
    /// The chord is a point at this scale (both ends equal, or a chord more than
    /// 2^800 times shorter than the polyline's extent): distance to `a`.
    point_like: bool,
    formula: SegmentFormula,
}

impl SegmentChord {
    pub fn new(a: Point2<f64>, b: Point2<f64>, extent: &Extent, formula: SegmentFormula) -> Self {
        let (bx, by) = (b.x - a.x, b.y - a.y);
        let m = bx.abs().max(by.abs());
        // Frame exponent: the chord's own, but never so small that a coordinate
        // difference (at most the extent) exceeds 2^501 in the frame.
        let e = if m > 0.0 {
            exponent(m).max(extent.exp - 500)
        } else {
            extent.exp
        };
        let scale = inv_pow2(e);
        let (dx, dy) = (bx * scale, by * scale);
        let len2 = dx * dx + dy * dy;
        let len = match formula {
            SegmentFormula::Geos => len2.sqrt(),
            SegmentFormula::Geo => dx.hypot(dy),
        };
        Self {
            a,
            b,
            scale,
            dx,
            dy,
            len2,
            len,
            point_like: m == 0.0 || len2 < 2f64.powi(-600),
            formula,
        }
    }

    /// Epsilon in the frame (may round to 0 or infinity, consistently for all keys).
    #[inline]
    pub fn epsilon(&self, epsilon: f64) -> f64 {
        epsilon * self.scale
    }

    #[inline(always)]
    fn point_distance(&self, x: f64, y: f64) -> f64 {
        match self.formula {
            SegmentFormula::Geos => (x * x + y * y).sqrt(),
            SegmentFormula::Geo => x.hypot(y),
        }
    }

    /// Distance from `p` to the segment in the frame, with the peer's operation order:
    /// projection parameter `r`, end-point distances outside [0, 1], else `|s| len`.
    #[inline(always)]
    pub fn key(&self, p: &Point2<f64>) -> f64 {
        let s = self.scale;
        let (px, py) = ((p.x - self.a.x) * s, (p.y - self.a.y) * s);
        if self.point_like {
            return self.point_distance(px, py);
        }
        let (dx, dy) = (self.dx, self.dy);
        let r = (px * dx + py * dy) / self.len2;
        if r <= 0.0 {
            return self.point_distance(px, py);
        }
        if r >= 1.0 {
            return self.point_distance((p.x - self.b.x) * s, (p.y - self.b.y) * s);
        }
        // (a.y - p.y) dx - (a.x - p.x) dy, as both peers write it.
        let (ay_py, ax_px) = ((self.a.y - p.y) * s, (self.a.x - p.x) * s);
        let sn = (ay_py * dx - ax_px * dy) / self.len2;
        sn.abs() * self.len
    }
}

/// Distance from `p` to the chord `a b` in the given metric, in length units (the
/// GEOS formula for [`Metric::Segment`]), without overflow or underflow.
pub fn chord_distance(p: &Point2<f64>, a: &Point2<f64>, b: &Point2<f64>, metric: Metric) -> f64 {
    let Ok(extent) = Extent::of(&[*p, *a, *b]) else {
        return f64::INFINITY; // a span beyond 2^1020: farther than any tolerance
    };
    match metric {
        Metric::Line => LineChord::new(*a, *b, &extent).distance(p),
        Metric::Segment => {
            let chord = SegmentChord::new(*a, *b, &extent, SegmentFormula::Geos);
            chord.key(p) / chord.scale
        }
    }
}
