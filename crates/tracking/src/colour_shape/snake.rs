//! The affine snake: Kass et al.'s contour restricted, as in seed 000 section 3.1, to
//! affine deformations of the previous contour `r_{t-1}`. Each iteration searches along
//! the current contour's normals for the nearest edge and refits the affine map from
//! `r_{t-1}` to those edge points by least squares.

use nalgebra::{Matrix2, Vector2};
pub use rperc_core::gaussian::covariance_spreads;

/// A closed contour, points in frame pixel coordinates (pixel centres at integers).
pub type Contour = Vec<[f64; 2]>;

/// An affine map `p -> a p + t` of the image plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Affine {
    /// Linear part.
    pub a: Matrix2<f64>,
    /// Translation.
    pub t: Vector2<f64>,
}

impl Affine {
    /// A pure translation.
    pub fn translation(dx: f64, dy: f64) -> Self {
        Self {
            a: Matrix2::identity(),
            t: Vector2::new(dx, dy),
        }
    }

    /// Image of one point.
    #[inline]
    pub fn apply(&self, p: [f64; 2]) -> [f64; 2] {
        (self.a * Vector2::from(p) + self.t).into()
    }

    /// Writes the image of `contour` into `out` (reused).
    pub fn apply_all(&self, contour: &[[f64; 2]], out: &mut Contour) {
        out.clear();
        out.extend(contour.iter().map(|&p| self.apply(p)));
    }
}

/// Closed-form least-squares affine map taking `src[i]` to `dst[i]` over the indices with
/// `use_point[i]`: centre both sets, then `A = (sum q p^T)(sum p p^T)^-1`,
/// `t = q_mean - A p_mean`. `None` with fewer than 3 points or collinear ones.
#[cfg(test)]
pub fn fit_affine(src: &[[f64; 2]], dst: &[[f64; 2]], use_point: &[bool]) -> Option<Affine> {
    fit_affine_stiff(src, dst, use_point, Matrix2::identity(), 0.0)
}

/// [`fit_affine`] with the snake's stiffness: the linear part is drawn towards `a0` by
/// adding `kappa ||A - a0||^2` to the squared residuals, so
/// `A = (sum q p^T + kappa a0)(sum p p^T + kappa I)^-1` (ridge regression); the
/// translation stays free. `kappa = 0` is the plain fit.
pub fn fit_affine_stiff(
    src: &[[f64; 2]],
    dst: &[[f64; 2]],
    use_point: &[bool],
    a0: Matrix2<f64>,
    kappa: f64,
) -> Option<Affine> {
    let pairs = || {
        src.iter()
            .zip(dst)
            .zip(use_point)
            .filter(|(_, u)| **u)
            .map(|((p, q), _)| (Vector2::from(*p), Vector2::from(*q)))
    };
    let n = pairs().count();
    if n < 3 {
        return None;
    }
    let (sp, sq) = pairs().fold((Vector2::zeros(), Vector2::zeros()), |(a, b), (p, q)| {
        (a + p, b + q)
    });
    let (pm, qm) = (sp / n as f64, sq / n as f64);
    let (mut spp, mut sqp) = (Matrix2::zeros(), Matrix2::zeros());
    for (p, q) in pairs() {
        let (p, q) = (p - pm, q - qm);
        spp += p * p.transpose();
        sqp += q * p.transpose();
    }
    // Collinear points leave the linear part undetermined without a prior.
    if kappa <= 0.0 && spp.determinant().abs() <= 1e-9 * spp.norm_squared().max(1e-300) {
        return None;
    }
    let a = (sqp + a0 * kappa) * (spp + Matrix2::identity() * kappa).try_inverse()?;
    Some(Affine { a, t: qm - a * pm })
}

/// Unit outward-or-inward normals of a closed contour by central differences (the sign
/// does not matter: the edge search looks both ways).
pub fn normals(contour: &[[f64; 2]], out: &mut Vec<[f64; 2]>) {
    let n = contour.len();
    out.clear();
    for i in 0..n {
        let a = contour[(i + n - 1) % n];
        let b = contour[(i + 1) % n];
        let (tx, ty) = (b[0] - a[0], b[1] - a[1]);
        let len = tx.hypot(ty);
        out.push(if len > 0.0 {
            [ty / len, -tx / len]
        } else {
            [0.0, 0.0]
        });
    }
}

/// Settings of the affine snake.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SnakeParams {
    /// How far along each normal to look for an edge in the first iteration, pixels.
    /// Each later iteration halves it, down to `min_search`: the first pulls the
    /// snake in, the later ones fit only the points whose edge is near the fitted
    /// contour, so an edge that no affine map of `r_{t-1}` reaches (a touching
    /// distractor's) stops pulling the fit.
    pub search: usize,
    /// The narrowest search, pixels.
    pub min_search: usize,
    /// Fit iterations.
    pub iterations: usize,
    /// A point "lies on" the edges when its last search found one within this distance.
    pub on_edge_tolerance: f64,
    /// Resistance of the contour's shape to change, against the edges pulling it: the
    /// linear part of the affine map is drawn towards the initial one with a weight of
    /// `stiffness` times a whole contour's worth of data (see [`fit_affine_stiff`]). 0
    /// is the plain least-squares fit.
    pub stiffness: f64,
}

/// Buffers of one snake fit, reused across samples.
#[derive(Debug, Clone, Default)]
pub struct SnakeScratch {
    current: Contour,
    normals: Vec<[f64; 2]>,
    targets: Contour,
    found: Vec<bool>,
    distance: Vec<f64>,
}

/// Result of [`fit_snake`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SnakeFit {
    /// The affine map from `r_{t-1}` to the fitted contour.
    pub affine: Affine,
    /// Fraction of contour points within the tolerance of an edge: the seed's
    /// `Phi_affine`, the mean of `grad S` along the fitted snake.
    pub on_edge: f64,
}

/// Fits an affine snake: starting from `init` applied to `reference` (`r_{t-1}`), moves
/// each point to the nearest pixel along its normal where `is_edge(x, y)` holds, and
/// refits the affine map from `reference` to those points. The fitted contour is left in
/// `scratch` (see [`SnakeScratch::contour`]).
pub fn fit_snake(
    reference: &[[f64; 2]],
    init: Affine,
    params: &SnakeParams,
    is_edge: impl Fn(i64, i64) -> bool,
    scratch: &mut SnakeScratch,
) -> SnakeFit {
    let mut affine = init;
    affine.apply_all(reference, &mut scratch.current);
    let mut reach = params.search;
    let kappa = params.stiffness * spread(reference);
    for _ in 0..params.iterations.max(1) {
        search_edges(reach, &is_edge, scratch);
        match fit_affine_stiff(reference, &scratch.targets, &scratch.found, init.a, kappa) {
            Some(next) => affine = next,
            None => break,
        }
        affine.apply_all(reference, &mut scratch.current);
        reach = (reach / 2).max(params.min_search);
    }
    search_edges(reach, &is_edge, scratch);
    let tol = params.on_edge_tolerance;
    let hits = scratch.distance.iter().filter(|d| **d <= tol).count();
    SnakeFit {
        affine,
        on_edge: hits as f64 / reference.len().max(1) as f64,
    }
}

/// `sum |p - p_mean|^2 / 2` over a contour: the scale of `sum p p^T` per axis.
fn spread(contour: &[[f64; 2]]) -> f64 {
    let n = contour.len().max(1) as f64;
    let [mx, my] = contour
        .iter()
        .fold([0.0, 0.0], |a, p| [a[0] + p[0] / n, a[1] + p[1] / n]);
    contour
        .iter()
        .map(|p| (p[0] - mx).powi(2) + (p[1] - my).powi(2))
        .sum::<f64>()
        / 2.0
}

/// For each point of the current contour, the nearest edge pixel along its normal
/// (distance 0, then +1/2, -1/2, +1, ...), up to `search` pixels.
fn search_edges(search: usize, is_edge: &impl Fn(i64, i64) -> bool, s: &mut SnakeScratch) {
    normals(&s.current, &mut s.normals);
    s.targets.clear();
    s.found.clear();
    s.distance.clear();
    for (c, n) in s.current.iter().zip(&s.normals) {
        let mut hit = None;
        // Half-pixel steps: a one-pixel-thin, 8-connected boundary cannot be stepped over.
        'search: for k in 0..=2 * search as i64 {
            for sign in [1i64, -1] {
                let d = (sign * k) as f64 * 0.5;
                let q = [c[0] + d * n[0], c[1] + d * n[1]];
                if is_edge(nearest(q[0]), nearest(q[1])) {
                    hit = Some((q, d.abs()));
                    break 'search;
                }
                if k == 0 {
                    break;
                }
            }
        }
        s.targets.push(hit.map_or(*c, |h| h.0));
        s.found.push(hit.is_some());
        s.distance.push(hit.map_or(f64::INFINITY, |h| h.1));
    }
}

/// The nearest integer, without a libm call: `round` was a tenth of the snake's cost.
/// Exact for |v| < 2^20, far beyond any frame; halves round up.
#[inline]
fn nearest(v: f64) -> i64 {
    const OFFSET: f64 = 1_048_576.0;
    (v + OFFSET + 0.5) as i64 - OFFSET as i64
}

impl SnakeScratch {
    /// The contour of the last fit.
    pub fn contour(&self) -> &[[f64; 2]] {
        &self.current
    }
}

/// Kass et al.'s snake let go of the affine constraint for one small step, so that a
/// non-rigid target's outline can change shape over time: each point of `contour`
/// moves along its normal to the nearest edge within `reach` pixels, then the
/// displacements are smoothed along the contour `passes` times with the kernel
/// (1, 2, 1) / 4 (the snake's elasticity). Points with no edge in reach move only by
/// the smoothing. The result is resampled evenly by arc length.
pub fn relax(
    contour: &[[f64; 2]],
    reach: usize,
    passes: usize,
    is_edge: impl Fn(i64, i64) -> bool,
    scratch: &mut SnakeScratch,
) -> Contour {
    scratch.current.clear();
    scratch.current.extend_from_slice(contour);
    search_edges(reach, &is_edge, scratch);
    let n = contour.len();
    let d: Vec<[f64; 2]> = (0..n)
        .map(|i| {
            if scratch.found[i] {
                let (t, c) = (scratch.targets[i], contour[i]);
                [t[0] - c[0], t[1] - c[1]]
            } else {
                [0.0, 0.0]
            }
        })
        .collect();
    smoothly_moved(contour, d, passes)
}

/// Moves each point of `contour` that may not stay (`stay` false) towards `centre` to
/// the first pixel inside the target (`inside`), in half-pixel steps. The moves are
/// smoothed along the contour `passes` times with (1, 2, 1) / 4, as in [`relax`], and
/// the result resampled evenly. A point with no inside pixel on its way stays.
pub fn pull_radially(
    contour: &[[f64; 2]],
    centre: [f64; 2],
    passes: usize,
    stay: impl Fn(i64, i64) -> bool,
    inside: impl Fn(i64, i64) -> bool,
) -> Contour {
    let d: Vec<[f64; 2]> = contour
        .iter()
        .map(|p| {
            if stay(nearest(p[0]), nearest(p[1])) {
                return [0.0, 0.0];
            }
            let (dx, dy) = (centre[0] - p[0], centre[1] - p[1]);
            let steps = (2.0 * dx.hypot(dy)).ceil() as usize;
            (1..=steps)
                .map(|k| k as f64 / steps as f64)
                .find(|t| inside(nearest(p[0] + t * dx), nearest(p[1] + t * dy)))
                .map_or([0.0, 0.0], |t| [t * dx, t * dy])
        })
        .collect();
    smoothly_moved(contour, d, passes)
}

/// `contour` moved by the displacements `d` smoothed `passes` times along it (the
/// snake's elasticity), resampled evenly to as many points.
fn smoothly_moved(contour: &[[f64; 2]], mut d: Vec<[f64; 2]>, passes: usize) -> Contour {
    smooth_closed(&mut d, passes);
    let moved: Contour = contour
        .iter()
        .zip(&d)
        .map(|(p, v)| [p[0] + v[0], p[1] + v[1]])
        .collect();
    resample_closed(&moved, contour.len())
}

/// `passes` rounds of (1, 2, 1) / 4 smoothing of values along a closed contour.
fn smooth_closed(d: &mut Vec<[f64; 2]>, passes: usize) {
    let n = d.len();
    let mut next = d.clone();
    for _ in 0..passes {
        for i in 0..n {
            let (a, b, c) = (d[(i + n - 1) % n], d[i], d[(i + 1) % n]);
            next[i] = [
                (a[0] + 2.0 * b[0] + c[0]) / 4.0,
                (a[1] + 2.0 * b[1] + c[1]) / 4.0,
            ];
        }
        std::mem::swap(d, &mut next);
    }
}

/// `n` points spaced evenly by arc length along a closed polygon.
pub fn resample_closed(poly: &[[f64; 2]], n: usize) -> Contour {
    let m = poly.len();
    let seg = |i: usize| {
        let (a, b) = (poly[i], poly[(i + 1) % m]);
        (b[0] - a[0]).hypot(b[1] - a[1])
    };
    let total: f64 = (0..m).map(seg).sum();
    if total <= 0.0 {
        return vec![poly[0]; n];
    }
    let (mut out, mut i, mut start) = (Vec::with_capacity(n), 0, 0.0);
    for k in 0..n {
        let s = total * k as f64 / n as f64;
        while start + seg(i) < s && i + 1 < m {
            start += seg(i);
            i += 1;
        }
        let (a, b) = (poly[i], poly[(i + 1) % m]);
        let f = if seg(i) > 0.0 {
            (s - start) / seg(i)
        } else {
            0.0
        };
        out.push([a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])]);
    }
    out
}

/// Area enclosed by a closed polygon (shoelace formula), always >= 0.
pub fn polygon_area(poly: &[[f64; 2]]) -> f64 {
    let n = poly.len();
    let twice: f64 = (0..n)
        .map(|i| {
            let (a, b) = (poly[i], poly[(i + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum();
    twice.abs() / 2.0
}

/// Points of an axis-aligned ellipse inscribed in a box: the seed's initial snake.
pub fn ellipse_contour(cx: f64, cy: f64, rx: f64, ry: f64, n: usize) -> Contour {
    (0..n)
        .map(|i| {
            let t = std::f64::consts::TAU * i as f64 / n as f64;
            [cx + rx * t.cos(), cy + ry * t.sin()]
        })
        .collect()
}

/// The principal spreads (standard deviations along the principal axes, largest first)
/// of the region a closed polygon encloses, from its area moments by Green's theorem:
/// a shape signature that tells a compact blob from a bar or a ring of the same area.
/// Zero for a degenerate polygon.
pub fn polygon_spreads(poly: &[[f64; 2]]) -> [f64; 2] {
    let n = poly.len();
    let (mut a, mut mx, mut my, mut ixx, mut iyy, mut ixy) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for i in 0..n {
        let ([x0, y0], [x1, y1]) = (poly[i], poly[(i + 1) % n]);
        let c = x0 * y1 - x1 * y0;
        a += c / 2.0;
        mx += (x0 + x1) * c / 6.0;
        my += (y0 + y1) * c / 6.0;
        ixx += (x0 * x0 + x0 * x1 + x1 * x1) * c / 12.0;
        iyy += (y0 * y0 + y0 * y1 + y1 * y1) * c / 12.0;
        ixy += (x0 * y1 + 2.0 * x0 * y0 + 2.0 * x1 * y1 + x1 * y0) * c / 24.0;
    }
    // Both orientations: every sum changes sign with the area, so the ratios do not.
    if a.abs() < 1e-12 {
        return [0.0, 0.0];
    }
    let (cx, cy) = (mx / a, my / a);
    covariance_spreads(ixx / a - cx * cx, iyy / a - cy * cy, ixy / a - cx * cy)
}

/// Rasterises a closed polygon into a 0/255 mask of the window with top-left `(x0, y0)`
/// (even-odd rule, a pixel is in when its centre is). `mask` keeps its size.
pub fn fill_polygon(poly: &[[f64; 2]], x0: f64, y0: f64, mask: &mut image::GrayImage) {
    let (w, h) = (mask.width() as usize, mask.height() as usize);
    mask.iter_mut().for_each(|p| *p = 0);
    let n = poly.len();
    let mut xs: Vec<f64> = Vec::with_capacity(8);
    for row in 0..h {
        let y = y0 + row as f64;
        xs.clear();
        for i in 0..n {
            let (a, b) = (poly[i], poly[(i + 1) % n]);
            // Half-open in y so a vertex on the scan line is counted once.
            if (a[1] <= y) != (b[1] <= y) {
                xs.push(a[0] + (y - a[1]) * (b[0] - a[0]) / (b[1] - a[1]));
            }
        }
        xs.sort_by(f64::total_cmp);
        for pair in xs.chunks_exact(2) {
            let lo = (pair[0] - x0).ceil().max(0.0);
            let hi = (pair[1] - x0).floor().min(w as f64 - 1.0);
            if lo > hi {
                continue;
            }
            mask.as_mut()[row * w + lo as usize..=row * w + hi as usize].fill(255);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector};

    /// Oracle: the affine least-squares problem stacked as a 2N x 6 linear system and
    /// solved by SVD, independent of the centred normal equations.
    fn affine_by_svd(src: &[[f64; 2]], dst: &[[f64; 2]]) -> [f64; 6] {
        let n = src.len();
        let mut m = DMatrix::zeros(2 * n, 6);
        let mut b = DVector::zeros(2 * n);
        for (i, (p, q)) in src.iter().zip(dst).enumerate() {
            m[(2 * i, 0)] = p[0];
            m[(2 * i, 1)] = p[1];
            m[(2 * i, 4)] = 1.0;
            m[(2 * i + 1, 2)] = p[0];
            m[(2 * i + 1, 3)] = p[1];
            m[(2 * i + 1, 5)] = 1.0;
            b[2 * i] = q[0];
            b[2 * i + 1] = q[1];
        }
        let x = m.svd(true, true).solve(&b, 1e-12).unwrap();
        [x[0], x[1], x[2], x[3], x[4], x[5]]
    }

    #[test]
    fn affine_fit_matches_stacked_least_squares() {
        let src = ellipse_contour(40.0, 30.0, 12.0, 7.0, 40);
        let mut s = 7u64;
        let dst: Contour = src
            .iter()
            .map(|p| {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1);
                let e = ((s >> 40) as f64 / (1u64 << 24) as f64 - 0.5) * 0.8;
                [
                    1.1 * p[0] + 0.2 * p[1] + 3.0 + e,
                    -0.1 * p[0] + 0.9 * p[1] - 2.0 - e,
                ]
            })
            .collect();
        let fit = fit_affine(&src, &dst, &vec![true; src.len()]).unwrap();
        let o = affine_by_svd(&src, &dst);
        let got = [
            fit.a[(0, 0)],
            fit.a[(0, 1)],
            fit.a[(1, 0)],
            fit.a[(1, 1)],
            fit.t[0],
            fit.t[1],
        ];
        for (g, w) in got.iter().zip(o) {
            assert!((g - w).abs() < 1e-9, "{got:?} vs {o:?}");
        }
        assert!(fit_affine(&src[..2], &dst[..2], &[true, true]).is_none());
    }

    #[test]
    fn snake_recovers_an_affine_ellipse_from_its_edges() {
        // Edges: the boundary of a rotated, sheared, shifted ellipse drawn as a mask.
        let truth = Affine {
            a: Matrix2::new(1.2, 0.3, -0.1, 0.8),
            t: Vector2::new(4.0, -3.0),
        };
        let reference = ellipse_contour(50.0, 40.0, 15.0, 10.0, 64);
        let mut target = Vec::new();
        truth.apply_all(&reference, &mut target);
        let mut mask = image::GrayImage::new(100, 80);
        fill_polygon(&target, 0.0, 0.0, &mut mask);
        let mut edges = image::GrayImage::new(1, 1);
        let sides = crate::colour_shape::segment::FrameSides { sides: [true; 4] };
        let all = [0, 0, 100, 80];
        crate::colour_shape::segment::boundary(&mask, &mask, sides, all, &mut edges);
        let is_edge = |x: i64, y: i64| {
            x >= 0 && y >= 0 && x < 100 && y < 80 && edges.get_pixel(x as u32, y as u32)[0] != 0
        };
        let params = SnakeParams {
            search: 8,
            min_search: 8,
            iterations: 15,
            on_edge_tolerance: 1.0,
            stiffness: 0.0,
        };
        let mut scratch = SnakeScratch::default();
        // Started as the tracker starts it: r_{t-1} translated onto the blob's centroid.
        let init = Affine::translation(26.0, -16.0);
        let fit = fit_snake(&reference, init, &params, is_edge, &mut scratch);
        // Every fitted point lies on the true curve (densely sampled), up to the pixel
        // grid: boundary pixels lie up to one pixel inside it.
        let dense = ellipse_contour(50.0, 40.0, 15.0, 10.0, 2000);
        let mut curve = Vec::new();
        truth.apply_all(&dense, &mut curve);
        for p in scratch.contour() {
            let d = curve
                .iter()
                .map(|q| (p[0] - q[0]).hypot(p[1] - q[1]))
                .fold(f64::INFINITY, f64::min);
            assert!(d < 1.5, "{p:?} is {d} px off the curve");
        }
        let area = polygon_area(scratch.contour());
        let want = polygon_area(&target);
        assert!((area - want).abs() / want < 0.1, "{area} vs {want}");
        assert!(fit.on_edge > 0.9, "{}", fit.on_edge);
    }

    #[test]
    fn polygon_spreads_match_the_closed_form_and_the_raster() {
        // Closed form: a solid ellipse of semi-axes (a, b) has variances a^2/4, b^2/4
        // along its axes, whatever its rotation or the polygon's orientation.
        let (a, b) = (30.0, 12.0);
        let mut e = ellipse_contour(0.0, 0.0, a, b, 2000);
        let (c, s) = (0.6f64.cos(), 0.6f64.sin());
        e.iter_mut()
            .for_each(|p| *p = [50.0 + c * p[0] - s * p[1], 40.0 + s * p[0] + c * p[1]]);
        let got = polygon_spreads(&e);
        assert!(
            (got[0] - a / 2.0).abs() < 1e-3 && (got[1] - b / 2.0).abs() < 1e-3,
            "{got:?}"
        );
        e.reverse();
        let rev = polygon_spreads(&e);
        assert!((rev[0] - got[0]).abs() < 1e-9 && (rev[1] - got[1]).abs() < 1e-9);
        // Raster oracle: the moments of the filled mask's pixel centres, on an L shape.
        // Half-integer corners: the pixel centres inside tile the region exactly.
        let l = [
            [1.5, 1.5],
            [40.5, 1.5],
            [40.5, 12.5],
            [14.5, 12.5],
            [14.5, 50.5],
            [1.5, 50.5],
        ];
        let mut mask = image::GrayImage::new(60, 60);
        fill_polygon(&l, 0.0, 0.0, &mut mask);
        let pts: Vec<(f64, f64)> = mask
            .enumerate_pixels()
            .filter(|(_, _, v)| v[0] != 0)
            .map(|(x, y, _)| (f64::from(x), f64::from(y)))
            .collect();
        let n = pts.len() as f64;
        let (mx, my) = pts
            .iter()
            .fold((0.0, 0.0), |s, p| (s.0 + p.0 / n, s.1 + p.1 / n));
        let m = |f: &dyn Fn(&(f64, f64)) -> f64| pts.iter().map(f).sum::<f64>() / n;
        let want = covariance_spreads(
            m(&|p| (p.0 - mx).powi(2)),
            m(&|p| (p.1 - my).powi(2)),
            m(&|p| (p.0 - mx) * (p.1 - my)),
        );
        let got = polygon_spreads(&l);
        // Pixel centres sample the region: their variance is the region's less 1/12 per
        // axis, which moves spreads over 5 px by under 0.01.
        for k in 0..2 {
            assert!((got[k] - want[k]).abs() < 0.01, "{got:?} vs {want:?}");
        }
    }

    #[test]
    fn polygon_area_and_fill_agree_with_closed_forms() {
        let square = [[2.0, 2.0], [12.0, 2.0], [12.0, 7.0], [2.0, 7.0]];
        assert_eq!(polygon_area(&square), 50.0);
        let mut m = image::GrayImage::new(20, 10);
        fill_polygon(&square, 0.0, 0.0, &mut m);
        // Centres with 2 <= x < 12... the half-open rule in y, closed in x: 11 x 5.
        assert_eq!(m.iter().filter(|p| **p != 0).count(), 11 * 5);
        let e = ellipse_contour(0.0, 0.0, 10.0, 5.0, 2000);
        assert!((polygon_area(&e) - std::f64::consts::PI * 50.0).abs() < 0.01);
    }
}
