//! Wall (line segment) extraction from one 2-D laser scan, seed 000 section 2.1 and
//! Fig. 1b: split-and-merge with iterative end-point fit.
//!
//! 1. drop invalid readings (NaN, at or below `min_range`, at or beyond `max_range`);
//! 2. split at range discontinuities with the adaptive breakpoint detector of Borges &
//!    Aldon (2004);
//! 3. split each run with iterative end-point fit, i.e. Douglas-Peucker on the scan
//!    points (path hulls, line metric);
//! 4. fit each piece by total least squares in Hessian form `x cos a + y sin a = rho`;
//! 5. give each line the 2 x 2 covariance of `(rho, alpha)` propagated to first order
//!    from the range and bearing noise of its points, inflated when the residuals show
//!    model error (a rough or bent wall, range quantisation, noise above its sigma);
//! 6. merge neighbours whose lines agree under a chi-square test, refitting, also
//!    across breakpoints between readings that are neighbours in bearing, where a
//!    run too short to be a wall joins a wall whose line its readings lie on;
//! 7. project the end points onto the line;
//! 8. drop segments with too few points or too short a length.

use std::f64::consts::PI;

use nalgebra::{Matrix2, Point2, Vector2};
use rperc_core::wrap_angle;

use crate::error::{LineSimpError, Result};
use crate::{Method, Metric, Simplifier};

/// Parameters of [`LineExtractor`]. Lengths in metres, angles in radians.
#[derive(
    Debug, Clone, Copy, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema,
)]
#[serde(default, deny_unknown_fields)]
pub struct ScanParams {
    /// Readings at or below this are invalid (0 is "no return" on most scanners).
    pub min_range: f64,
    /// Readings at or beyond this are invalid (no return). Default: infinite.
    // JSON has no infinity (serde_json writes null): the schema spells it as text.
    #[schemars(extend("default" = "inf"))]
    pub max_range: f64,
    /// Standard deviation of the range noise (default 0.01 m).
    pub sigma_range: f64,
    /// Standard deviation of the bearing noise (default 0: bearings are exact).
    pub sigma_bearing: f64,
    /// Smallest incidence angle between a beam and a wall that still counts as one
    /// surface, lambda of the adaptive breakpoint detector (default 10 degrees).
    pub breakpoint_lambda: f64,
    /// Iterative end-point fit splits where a point is farther than this from the
    /// chord (default 0.05 m).
    pub split_epsilon: f64,
    /// Neighbouring lines merge when the Mahalanobis distance of their difference is
    /// below the chi-square (2 dof) quantile of this confidence (default 0.99).
    pub merge_confidence: f64,
    /// Fewest points a wall may have (default 6; at least 2).
    pub min_points: usize,
    /// Shortest wall kept (default 0.3 m).
    pub min_length: f64,
    /// Inflate a line's covariance when its fit residuals show more scatter, or more
    /// correlation from point to point, than the range and bearing noise explain
    /// (default true; see `LineExtractor::model_error_factor`).
    pub model_error: bool,
}

impl Default for ScanParams {
    fn default() -> Self {
        Self {
            min_range: 0.0,
            max_range: f64::INFINITY,
            sigma_range: 0.01,
            sigma_bearing: 0.0,
            breakpoint_lambda: 10f64.to_radians(),
            split_epsilon: 0.05,
            merge_confidence: 0.99,
            min_points: 6,
            min_length: 0.3,
            model_error: true,
        }
    }
}

impl ScanParams {
    /// Refuses NaN and out-of-range values with the parameter's name.
    pub fn validate(&self) -> Result<()> {
        let bad = |name: &'static str, value: f64, rule: &str| {
            Err(LineSimpError::InvalidParameter {
                name,
                reason: format!("must be {rule}, got {value}"),
            })
        };
        let finite_nonneg = [
            ("min_range", self.min_range),
            ("sigma_range", self.sigma_range),
            ("sigma_bearing", self.sigma_bearing),
            ("split_epsilon", self.split_epsilon),
            ("min_length", self.min_length),
        ];
        for (name, v) in finite_nonneg {
            if !(v.is_finite() && v >= 0.0) {
                return bad(name, v, "finite and >= 0");
            }
        }
        // The covariance uses the variances: an infinite sigma^2 times a zero
        // Jacobian entry made a NaN covariance (sigma_range = 1e300, fuzz suite).
        for (name, v) in [
            ("sigma_range", self.sigma_range),
            ("sigma_bearing", self.sigma_bearing),
        ] {
            if !(v * v).is_finite() {
                return bad(name, v, "small enough that its square is finite (< 1e154)");
            }
        }
        if self.max_range.is_nan() || self.max_range <= self.min_range {
            return bad("max_range", self.max_range, "greater than min_range");
        }
        if !(0.0..PI / 2.0).contains(&self.breakpoint_lambda) || self.breakpoint_lambda == 0.0 {
            return bad(
                "breakpoint_lambda",
                self.breakpoint_lambda,
                "in (0, pi/2) radians",
            );
        }
        if !(self.merge_confidence > 0.0 && self.merge_confidence < 1.0) {
            return bad("merge_confidence", self.merge_confidence, "in (0, 1)");
        }
        if self.min_points < 2 {
            return bad("min_points", self.min_points as f64, ">= 2");
        }
        Ok(())
    }
}

/// One extracted wall, in the sensor frame.
#[derive(Debug, Clone, PartialEq)]
pub struct WallSegment {
    /// Distance from the sensor to the line, >= 0.
    pub rho: f64,
    /// Direction of the line's normal, in (-pi, pi].
    pub alpha: f64,
    /// Covariance of `(rho, alpha)`.
    pub cov: Matrix2<f64>,
    /// First end point, projected onto the line.
    pub start: Point2<f64>,
    /// Last end point, projected onto the line.
    pub end: Point2<f64>,
    /// Indices of the fitted readings in the input scan, increasing.
    pub indices: Vec<usize>,
}

impl WallSegment {
    /// Length of the segment.
    pub fn length(&self) -> f64 {
        (self.end - self.start).norm()
    }
}

/// A total-least-squares line fit with its first-order covariance.
#[derive(Debug, Clone, Copy)]
struct LineFit {
    rho: f64,
    alpha: f64,
    cov: Matrix2<f64>,
    /// `sum e_k^2 / mean s_k^2`: the residuals against the noise model, chi-square
    /// with `N - 2` dof when the model holds (0 when it predicts no noise).
    scatter: f64,
}

/// Wall extractor with buffers reused from scan to scan (no allocation per point).
///
/// # Examples
/// ```
/// use linesimp::{LineExtractor, ScanParams};
///
/// // A wall 2 m in front of the sensor (the line x = 2), seen by 91 beams.
/// let angles: Vec<f64> = (0..91).map(|k| (k as f64 - 45.0).to_radians()).collect();
/// let ranges: Vec<f64> = angles.iter().map(|a| 2.0 / a.cos()).collect();
/// let walls = LineExtractor::new(ScanParams::default()).extract(&ranges, &angles).unwrap();
/// assert_eq!(walls.len(), 1);
/// assert!((walls[0].rho - 2.0).abs() < 1e-9 && walls[0].alpha.abs() < 1e-9);
/// ```
#[derive(Debug, Default)]
pub struct LineExtractor {
    params: ScanParams,
    points: Vec<Point2<f64>>,
    ranges: Vec<f64>,
    bearings: Vec<f64>,
    /// `(cos, sin)` of each bearing, computed once: every fit needs them.
    beams: Vec<Vector2<f64>>,
    source: Vec<usize>,
    simplifier: Simplifier,
    /// Point ranges `[a, b)` of the pieces of the current run.
    pieces: Vec<(usize, usize, LineFit)>,
    /// Scatter statistic and reading count of each wall of the current scan.
    scatter: Vec<(f64, usize)>,
}

impl LineExtractor {
    /// An extractor with the given parameters (checked on every call to `extract`).
    pub fn new(params: ScanParams) -> Self {
        Self {
            params,
            simplifier: Simplifier::new(Method::Hull, Metric::Line),
            ..Self::default()
        }
    }

    /// The parameters in use.
    pub fn params(&self) -> &ScanParams {
        &self.params
    }

    /// Walls of one scan: `ranges[k]` measured along bearing `angles[k]` (sensor
    /// frame, increasing). Invalid readings are skipped, never an error; NaN bearings,
    /// mismatched lengths and bad parameters are.
    pub fn extract(&mut self, ranges: &[f64], angles: &[f64]) -> Result<Vec<WallSegment>> {
        let p = self.params;
        p.validate()?;
        if ranges.len() != angles.len() {
            return Err(LineSimpError::LengthMismatch {
                what: format!(
                    "ranges has length {} but angles has length {}",
                    ranges.len(),
                    angles.len()
                ),
            });
        }
        if let Some(k) = angles.iter().position(|a| !a.is_finite()) {
            return Err(LineSimpError::InvalidParameter {
                name: "angles",
                reason: format!("angle {k} is not finite ({})", angles[k]),
            });
        }
        check_monotonic(angles)?;
        self.collect_valid(ranges, angles);
        let mut walls = Vec::new();
        self.scatter.clear();
        self.pieces.clear();
        let n = self.points.len();
        let mut start = 0;
        for k in 1..=n {
            if k == n || self.is_breakpoint(k) {
                self.split_run(start, k);
                start = k;
            }
        }
        self.merge_pieces();
        self.emit_walls(&mut walls);
        if self.params.model_error {
            let factor = pooled_scatter_factor(&self.scatter);
            for w in &mut walls {
                w.cov *= factor;
            }
        }
        Ok(walls)
    }

    /// Step 1: the valid readings as points, with their polar coordinates and indices.
    fn collect_valid(&mut self, ranges: &[f64], angles: &[f64]) {
        let p = &self.params;
        self.points.clear();
        self.ranges.clear();
        self.bearings.clear();
        self.beams.clear();
        self.source.clear();
        for (k, (&r, &a)) in ranges.iter().zip(angles).enumerate() {
            if r.is_finite() && r > p.min_range && r > 0.0 && r < p.max_range {
                let (s, c) = a.sin_cos();
                self.points.push(Point2::new(r * c, r * s));
                self.ranges.push(r);
                self.bearings.push(a);
                self.beams.push(Vector2::new(c, s));
                self.source.push(k);
            }
        }
    }

    /// Step 2, Borges & Aldon's adaptive breakpoint detector: consecutive points
    /// farther apart than `r sin(dphi) / sin(lambda - dphi) + 3 sigma_r` lie on
    /// different surfaces. Gaps wider than lambda always break.
    fn is_breakpoint(&self, k: usize) -> bool {
        let p = &self.params;
        let dphi = (self.bearings[k] - self.bearings[k - 1]).abs();
        if dphi >= p.breakpoint_lambda {
            return true;
        }
        let d_max = self.ranges[k - 1] * dphi.sin() / (p.breakpoint_lambda - dphi).sin()
            + 3.0 * p.sigma_range;
        (self.points[k] - self.points[k - 1]).norm() > d_max
    }

    /// Step 3: iterative end-point fit of the run of valid points `[a, b)`, appended
    /// to `self.pieces` (a run of one reading is a piece of one point, which only a
    /// merge can keep). A split vertex sits near a corner and may belong to either
    /// wall: the pieces are fitted without it, then it goes to the piece whose line it
    /// is closer to.
    fn split_run(&mut self, a: usize, b: usize) {
        let base = self.pieces.len();
        if b - a < 2 {
            let fit = self.fit(a, b);
            self.pieces.push((a, b, fit));
            return;
        }
        let Ok(kept) = self
            .simplifier
            .indices(&self.points[a..b], self.params.split_epsilon)
        else {
            return; // unreachable: points are finite and epsilon was checked
        };
        let last = kept.len() - 2;
        for (w, pair) in kept.windows(2).enumerate() {
            let lo = a + pair[0] + usize::from(w > 0);
            let hi = a + pair[1] + usize::from(w == last);
            let fit = self.fit(lo, hi);
            self.pieces.push((lo, hi, fit));
        }
        for w in base + 1..self.pieces.len() {
            self.assign_split_vertex(w);
        }
        let mut w = base;
        while w < self.pieces.len() {
            if self.pieces[w].1 - self.pieces[w].0 < 2 {
                self.pieces.remove(w);
            } else {
                w += 1;
            }
        }
    }

    /// Gives the vertex between pieces `w - 1` and `w` to the one whose line fits it.
    fn assign_split_vertex(&mut self, w: usize) {
        let vertex = self.pieces[w].0 - 1;
        let q = self.points[vertex].coords;
        let residual = |f: &LineFit| (q.x * f.alpha.cos() + q.y * f.alpha.sin() - f.rho).abs();
        let (before, after) = (self.pieces[w - 1], self.pieces[w]);
        let to_before = match (before.1 - before.0 >= 2, after.1 - after.0 >= 2) {
            (true, true) => residual(&before.2) <= residual(&after.2),
            (ok_before, _) => ok_before,
        };
        if to_before {
            self.pieces[w - 1].1 += 1;
            self.pieces[w - 1].2 = self.fit(before.0, before.1 + 1);
        } else {
            self.pieces[w].0 -= 1;
            self.pieces[w].2 = self.fit(after.0 - 1, after.1);
        }
    }

    /// Step 6: merge neighbouring pieces, within a run and across breakpoints, until
    /// none merge. The confidence was checked by `validate`, so the gates exist.
    fn merge_pieces(&mut self) {
        let conf = self.params.merge_confidence;
        let gate_line = rperc_core::chi2_gate(2, conf).unwrap_or(f64::INFINITY);
        let gate_point = rperc_core::chi2_gate(1, conf).unwrap_or(f64::INFINITY);
        let mut k = 0;
        while k + 1 < self.pieces.len() {
            if self.may_merge(k, gate_line, gate_point) {
                let (lo, hi) = (self.pieces[k].0, self.pieces[k + 1].1);
                self.pieces[k] = (lo, hi, self.fit(lo, hi));
                self.pieces.remove(k + 1);
                k = k.saturating_sub(1);
            } else {
                k += 1;
            }
        }
    }

    /// Whether pieces `k` and `k + 1` are one wall. Within a run: their lines agree
    /// under the chi-square test (2 dof). Across a breakpoint (a range jump: a
    /// dropout, a mixed reading, a grazing beam), only between readings that are
    /// neighbours in bearing (a gap of lambda or more is an opening, not a wall):
    /// two pieces of at least `min_points` by the same line test; a shorter piece,
    /// too short to be a wall of its own, when each of its readings lies on the other
    /// piece's line under the chi-square test (1 dof) of its residual, whose variance
    /// is the reading's noise along the normal plus the line's own uncertainty there.
    fn may_merge(&self, k: usize, gate_line: f64, gate_point: f64) -> bool {
        let ((lo1, hi1, f1), (lo2, hi2, f2)) = (self.pieces[k], self.pieces[k + 1]);
        if hi1 != lo2 {
            return false; // a dropped split vertex lies between them
        }
        if !self.is_breakpoint(lo2) {
            return same_line(&f1, &f2) < gate_line;
        }
        if (self.bearings[lo2] - self.bearings[hi1 - 1]).abs() >= self.params.breakpoint_lambda {
            return false;
        }
        let long = self.params.min_points.max(3);
        match (hi1 - lo1 >= long, hi2 - lo2 >= long) {
            (true, true) => same_line(&f1, &f2) < gate_line,
            (true, false) => self.readings_on_line(&f1, lo2, hi2, gate_point),
            (false, true) => self.readings_on_line(&f2, lo1, hi1, gate_point),
            (false, false) => false,
        }
    }

    /// Every reading of `[lo, hi)` passes the residual test against the line `fit`.
    fn readings_on_line(&self, fit: &LineFit, lo: usize, hi: usize, gate: f64) -> bool {
        if !(fit.cov.iter().all(|v| v.is_finite()) && fit.rho.is_finite()) {
            return false;
        }
        let (sa, ca) = fit.alpha.sin_cos();
        let (var_r, var_b) = (
            self.params.sigma_range.powi(2),
            self.params.sigma_bearing.powi(2),
        );
        (lo..hi).all(|k| {
            let q = self.points[k].coords;
            let e = q.x * ca + q.y * sa - fit.rho;
            // e = n(alpha).q - rho: de/drho = -1, de/dalpha = t.q.
            let j = Vector2::new(-1.0, -q.x * sa + q.y * ca);
            let (cb, sb) = (self.beams[k].x, self.beams[k].y);
            let (along, across) = (ca * cb + sa * sb, -ca * sb + sa * cb);
            let noise = var_r * along * along + var_b * (self.ranges[k] * across).powi(2);
            let var = j.dot(&(fit.cov * j)) + noise;
            var > 0.0 && e * e < gate * var
        })
    }

    /// Steps 7 and 8: end points projected onto the lines; short or sparse walls dropped.
    fn emit_walls(&mut self, walls: &mut Vec<WallSegment>) {
        for w in 0..self.pieces.len() {
            let (lo, hi, fit) = self.pieces[w];
            if hi - lo < self.params.min_points {
                continue;
            }
            let n = Vector2::new(fit.alpha.cos(), fit.alpha.sin());
            let project = |q: &Point2<f64>| q - n * (n.dot(&q.coords) - fit.rho);
            let wall = WallSegment {
                rho: fit.rho,
                alpha: fit.alpha,
                cov: fit.cov,
                start: project(&self.points[lo]),
                end: project(&self.points[hi - 1]),
                indices: self.source[lo..hi].to_vec(),
            };
            if wall.length() >= self.params.min_length {
                walls.push(wall);
                self.scatter.push((fit.scatter, hi - lo));
            }
        }
    }

    /// Steps 4 and 5: total least squares on points `[lo, hi)` and the first-order
    /// covariance of `(rho, alpha)` from the polar noise of each point.
    fn fit(&self, lo: usize, hi: usize) -> LineFit {
        if hi < lo + 2 {
            // No line through fewer than two points; such pieces are dropped.
            return LineFit {
                rho: f64::NAN,
                alpha: f64::NAN,
                cov: Matrix2::from_diagonal_element(f64::INFINITY),
                scatter: 0.0,
            };
        }
        let pts = &self.points[lo..hi];
        let count = pts.len() as f64;
        let c = pts.iter().fold(Vector2::zeros(), |s, q| s + q.coords) / count;
        let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
        for q in pts {
            let d = q.coords - c;
            sxx += d.x * d.x;
            syy += d.y * d.y;
            sxy += d.x * d.y;
        }
        // The normal minimising the squared residuals: smallest eigenvector of the
        // scatter matrix.
        let mut alpha = 0.5 * (-2.0 * sxy).atan2(syy - sxx);
        let mut rho = c.x * alpha.cos() + c.y * alpha.sin();
        if rho < 0.0 {
            rho = -rho;
            alpha += PI;
        }
        alpha = wrap_angle(alpha);
        let (cov, scatter) = self.fit_covariance(lo, hi, rho, alpha);
        LineFit {
            rho,
            alpha,
            cov,
            scatter,
        }
    }

    /// Implicit-function first-order propagation. With normal `n`, tangent `t`, and
    /// residuals `e_i = n.p_i - rho`, the fit zeroes `g = (-sum e_i, sum e_i t.p_i)`;
    /// so `d(rho, alpha)/dp_i = -H^-1 dg/dp_i` with
    /// `H = [[N, -sum t.p_i], [-sum t.p_i, sum (t.p_i)^2 - sum e_i n.p_i]]` and
    /// `dg/dp_i = [-n^T; (t.p_i) n^T + e_i t^T]`. Each point's covariance comes from
    /// its range and bearing noise through `p = r (cos phi, sin phi)`.
    fn fit_covariance(&self, lo: usize, hi: usize, rho: f64, alpha: f64) -> (Matrix2<f64>, f64) {
        let (sa, ca) = alpha.sin_cos();
        let n = Vector2::new(ca, sa);
        let t = Vector2::new(-sa, ca);
        let (mut sum_tp, mut sum_tp2, mut sum_enp) = (0.0, 0.0, 0.0);
        for q in &self.points[lo..hi] {
            let (tp, np) = (t.dot(&q.coords), n.dot(&q.coords));
            sum_tp += tp;
            sum_tp2 += tp * tp;
            sum_enp += (np - rho) * np;
        }
        let h = Matrix2::new((hi - lo) as f64, -sum_tp, -sum_tp, sum_tp2 - sum_enp);
        let Some(h_inv) = h.try_inverse() else {
            return (Matrix2::from_diagonal_element(f64::INFINITY), 0.0);
        };
        let (var_r, var_b) = (
            self.params.sigma_range.powi(2),
            self.params.sigma_bearing.powi(2),
        );
        let mut cov = Matrix2::zeros();
        for k in lo..hi {
            let q = self.points[k].coords;
            let (tp, e) = (t.dot(&q), n.dot(&q) - rho);
            // Rows: d g1 / d p = -n^T, d g2 / d p = tp n^T + e t^T.
            let dg = Matrix2::new(-n.x, -n.y, tp * n.x + e * t.x, tp * n.y + e * t.y);
            let a = -h_inv * dg;
            let (cb, sb) = (self.beams[k].x, self.beams[k].y);
            let r = self.ranges[k];
            let d_range = a * Vector2::new(cb, sb);
            let d_bearing = a * Vector2::new(-r * sb, r * cb);
            cov +=
                d_range * d_range.transpose() * var_r + d_bearing * d_bearing.transpose() * var_b;
        }
        let (factor, scatter) = self.model_error_factor(lo, hi, rho, n);
        let factor = if self.params.model_error { factor } else { 1.0 };
        (0.5 * factor * (cov + cov.transpose()), scatter)
    }

    /// The floor for model and discretisation error, from the fit's own residuals
    /// `e_k = n.p_k - rho` (in scan order). The noise model predicts each residual's
    /// variance `s_k^2 = var_r (n.u_k)^2 + var_b r_k^2 (n.u_k')^2` (`u_k` the beam,
    /// `u_k'` its normal). Returns the line's correlation factor and its scatter
    /// statistic `sum e_k^2 / mean s_k^2` (chi-square with `N - 2` dof under the
    /// model), which `extract` pools over the scan (see `pooled_scatter_factor`).
    ///
    /// Correlation: the lag-1 autocorrelation `r1` of the residuals above
    /// `1.645 / sqrt(N)` (its 95 % point for white residuals) scales the covariance by
    /// `(1 + r1) / (1 - r1)`, the loss of effective sample size under an AR(1) error
    /// (a bent or wavy wall, a bias that drifts along it), with `r1` capped at 0.9.
    /// Residuals below chi-square's 5 % point (a noise-free simulation: round-off)
    /// say nothing about correlation and leave the factor at 1.
    ///
    /// Rules and thresholds were checked on simulated rooms with range quantisation,
    /// wavy walls and noise above its sigma (`tests/test_walls.py`,
    /// `test_model_error_floor_on_simulated_rooms`), never on the
    /// logs that report the score.
    fn model_error_factor(&self, lo: usize, hi: usize, rho: f64, n: Vector2<f64>) -> (f64, f64) {
        let count = hi - lo;
        let (var_r, var_b) = (
            self.params.sigma_range.powi(2),
            self.params.sigma_bearing.powi(2),
        );
        let (mut sum_e2, mut sum_lag, mut sum_s2, mut last) = (0.0, 0.0, 0.0, None);
        for k in lo..hi {
            let e = n.dot(&self.points[k].coords) - rho;
            let (cb, sb) = (self.beams[k].x, self.beams[k].y);
            let (along, across) = (n.x * cb + n.y * sb, -n.x * sb + n.y * cb);
            sum_s2 += var_r * along * along + var_b * (self.ranges[k] * across).powi(2);
            sum_e2 += e * e;
            if let Some(prev) = last {
                sum_lag += e * prev;
            }
            last = Some(e);
        }
        let mean_s2 = sum_s2 / count as f64;
        if count < 4 || mean_s2 <= 0.0 {
            return (1.0, 0.0);
        }
        let scatter = sum_e2 / mean_s2;
        let dof = (count - 2) as f64;
        let mut factor = 1.0;
        if scatter > chi2_quantile_wh(dof, -Z_95) {
            let r1 = (sum_lag / sum_e2).min(0.9);
            if r1 > Z_95 / (count as f64).sqrt() {
                factor = (1.0 + r1) / (1.0 - r1);
            }
        }
        (factor, scatter)
    }
}

/// Scatter: the walls' statistics `scatter_w` (chi-square with `N_w - 2` dof each under
/// the noise model) pooled over the scan. When their sum is above the 95 % quantile
/// of chi-square with the summed dof, the noise is larger than its sigma (range
/// quantisation, a rough surface, a mis-set sigma) and every wall's covariance is
/// scaled by `sum scatter_w / sum (N_w - 2)`, the a-posteriori variance factor of least
/// squares. Pooling matters: from one short wall (6 to 10 readings) the factor is too
/// noisy to use (on simulated rooms with twice the assumed noise, walls of under 10
/// readings kept a mean NEES of 27 with per-wall factors).
fn pooled_scatter_factor(stats: &[(f64, usize)]) -> f64 {
    let (sum, dof) = stats
        .iter()
        .filter(|&&(_, n)| n >= 4)
        .fold((0.0, 0usize), |(s, d), &(x, n)| (s + x, d + n - 2));
    if dof > 0 && sum > chi2_quantile_wh(dof as f64, Z_95) {
        sum / dof as f64
    } else {
        1.0
    }
}

/// The standard normal's 95 % quantile.
const Z_95: f64 = 1.644_853_6;

/// The chi-square quantile with `dof` degrees of freedom at the normal quantile `z`
/// (`Z_95` for 95 %, `-Z_95` for 5 %) by the Wilson-Hilferty cube-root approximation
/// (within 3 % for dof >= 1, under 0.5 % for dof >= 10): called on every fit, where an
/// exact inverse would cost more than the fit.
fn chi2_quantile_wh(dof: f64, z: f64) -> f64 {
    let v = 2.0 / (9.0 * dof);
    dof * (1.0 - v + z * v.sqrt()).max(0.0).powi(3)
}

/// Breakpoints and the fit assume that neighbours in the scan are neighbours in angle:
/// bearings must be strictly increasing or strictly decreasing (a clockwise scanner).
fn check_monotonic(angles: &[f64]) -> Result<()> {
    let increasing = angles.len() < 2 || angles[1] > angles[0];
    let out_of_order = angles.windows(2).position(|w| {
        if increasing {
            w[1] <= w[0]
        } else {
            w[1] >= w[0]
        }
    });
    match out_of_order {
        None => Ok(()),
        Some(k) => Err(LineSimpError::InvalidParameter {
            name: "angles",
            reason: format!(
                "bearings must be strictly monotonic, but angle {} ({}) follows angle {k} ({})",
                k + 1,
                angles[k + 1],
                angles[k]
            ),
        }),
    }
}

/// Mahalanobis distance between two independent line estimates, taking the
/// equivalent form `(-rho, alpha + pi)` into account for lines near the sensor.
fn same_line(a: &LineFit, b: &LineFit) -> f64 {
    let Some(inv) = (a.cov + b.cov).try_inverse() else {
        return f64::INFINITY;
    };
    let d1 = Vector2::new(a.rho - b.rho, wrap_angle(a.alpha - b.alpha));
    let d2 = Vector2::new(a.rho + b.rho, wrap_angle(a.alpha - b.alpha - PI));
    d1.dot(&(inv * d1)).min(d2.dot(&(inv * d2)))
}

/// [`LineExtractor::extract`] for a single scan.
///
/// # Examples
/// ```
/// use linesimp::{ScanParams, extract_lines};
///
/// let angles: Vec<f64> = (0..61).map(|k| (k as f64 - 30.0).to_radians()).collect();
/// let ranges: Vec<f64> = angles.iter().map(|a| 3.0 / (a - 0.2).cos()).collect();
/// let walls = extract_lines(&ranges, &angles, &ScanParams::default()).unwrap();
/// assert!((walls[0].rho - 3.0).abs() < 1e-9 && (walls[0].alpha - 0.2).abs() < 1e-9);
/// ```
pub fn extract_lines(
    ranges: &[f64],
    angles: &[f64],
    params: &ScanParams,
) -> Result<Vec<WallSegment>> {
    LineExtractor::new(*params).extract(ranges, angles)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn beams(n: usize, from_deg: f64, to_deg: f64) -> Vec<f64> {
        (0..n)
            .map(|k| (from_deg + (to_deg - from_deg) * k as f64 / (n - 1) as f64).to_radians())
            .collect()
    }

    /// Range to the line `x cos(alpha) + y sin(alpha) = rho` along bearing `phi`.
    fn range_to(rho: f64, alpha: f64, phi: f64) -> f64 {
        rho / (phi - alpha).cos()
    }

    #[test]
    fn a_corner_gives_two_walls_meeting_at_right_angles() {
        // Walls x = 2 (alpha 0) and y = 2 (alpha pi/2) meet at (2, 2), bearing 45 deg.
        let angles = beams(181, -30.0, 120.0);
        let ranges: Vec<f64> = angles
            .iter()
            .map(|&a| {
                range_to(2.0, 0.0, a)
                    .abs()
                    .min(range_to(2.0, PI / 2.0, a).abs())
            })
            .map(|r| {
                if r.is_finite() && r > 0.0 {
                    r
                } else {
                    f64::NAN
                }
            })
            .collect();
        let walls = extract_lines(&ranges, &angles, &ScanParams::default()).unwrap();
        assert_eq!(walls.len(), 2, "{walls:?}");
        assert!((walls[0].rho - 2.0).abs() < 1e-9 && walls[0].alpha.abs() < 1e-9);
        assert!((walls[1].rho - 2.0).abs() < 1e-9 && (walls[1].alpha - PI / 2.0).abs() < 1e-9);
        // Both walls end at the corner.
        assert!((walls[0].end - Point2::new(2.0, 2.0)).norm() < 0.1);
        assert!((walls[1].start - Point2::new(2.0, 2.0)).norm() < 0.1);
    }

    #[test]
    fn collinear_walls_across_a_gap_stay_apart() {
        // The wall x = 2 with a doorway: beams between -5 and 5 degrees see nothing.
        let angles = beams(121, -30.0, 30.0);
        let ranges: Vec<f64> = angles
            .iter()
            .map(|&a| {
                if a.to_degrees().abs() < 5.0 {
                    f64::NAN
                } else {
                    range_to(2.0, 0.0, a)
                }
            })
            .collect();
        let walls = extract_lines(&ranges, &angles, &ScanParams::default()).unwrap();
        assert_eq!(walls.len(), 2);
    }

    #[test]
    fn covariance_matches_finite_differences() {
        // An independent check of the analytic Jacobian: perturb each range and
        // refit, accumulating J diag(var) J^T numerically.
        let angles = beams(40, -20.0, 25.0);
        let ranges: Vec<f64> = angles
            .iter()
            .enumerate()
            .map(|(k, &a)| range_to(3.0, 0.3, a) + 0.004 * ((k * 7919 % 13) as f64 - 6.0))
            .collect();
        let params = ScanParams {
            sigma_range: 0.02,
            sigma_bearing: 0.003,
            split_epsilon: 1.0,
            model_error: false, // this checks the propagation alone
            ..ScanParams::default()
        };
        let mut ex = LineExtractor::new(params);
        ex.collect_valid(&ranges, &angles);
        let base = ex.fit(0, 40);
        let h = 1e-6;
        let mut cov = Matrix2::zeros();
        for k in 0..40 {
            for (which, var) in [(0, 0.02f64.powi(2)), (1, 0.003f64.powi(2))] {
                let mut r = ranges.clone();
                let mut a = angles.clone();
                if which == 0 {
                    r[k] += h;
                } else {
                    a[k] += h;
                }
                ex.collect_valid(&r, &a);
                let f = ex.fit(0, 40);
                let d = Vector2::new((f.rho - base.rho) / h, wrap_angle(f.alpha - base.alpha) / h);
                cov += d * d.transpose() * var;
            }
        }
        let rel = (cov - base.cov).norm() / base.cov.norm();
        assert!(rel < 1e-4, "analytic {} vs numeric {}", base.cov, cov);
    }

    #[test]
    fn wilson_hilferty_quantile_is_close_to_the_exact_one() {
        for dof in [1usize, 2, 4, 10, 50, 178] {
            let exact = rperc_core::chi2_gate(dof, 0.95).unwrap();
            let approx = chi2_quantile_wh(dof as f64, Z_95);
            let tol = if dof >= 10 { 0.005 } else { 0.03 };
            assert!(
                (approx / exact - 1.0).abs() < tol,
                "{dof}: {approx} vs {exact}"
            );
        }
        for dof in [4usize, 10, 50, 178] {
            let exact = rperc_core::chi2_gate(dof, 0.05).unwrap();
            let approx = chi2_quantile_wh(dof as f64, -Z_95);
            let tol = if dof >= 10 { 0.01 } else { 0.05 };
            assert!(
                (approx / exact - 1.0).abs() < tol,
                "{dof}: {approx} vs {exact}"
            );
        }
    }

    #[test]
    fn model_error_factors_are_one_for_plain_noise_and_grow_with_a_bent_wall() {
        // Residuals that are exactly the noise model's size and alternate in sign: no
        // excess scatter, negative lag-1 correlation, so no inflation.
        let angles = beams(60, -30.0, 30.0);
        let plain: Vec<f64> = angles
            .iter()
            .enumerate()
            .map(|(k, &a)| range_to(3.0, 0.0, a) + if k % 2 == 0 { 0.01 } else { -0.01 })
            .collect();
        let mut ex = LineExtractor::new(ScanParams::default());
        ex.collect_valid(&plain, &angles);
        let fit = ex.fit(0, 60);
        let n = Vector2::new(fit.alpha.cos(), fit.alpha.sin());
        let (factor, scatter) = ex.model_error_factor(0, 60, fit.rho, n);
        assert_eq!(factor, 1.0);
        // Every residual is one sigma: the scatter statistic is N = 60 (less the two
        // the fit absorbs, to within the alternation's leftover).
        assert!((scatter - 60.0).abs() < 2.5, "{scatter}");
        assert_eq!(pooled_scatter_factor(&[(scatter, 60)]), 1.0);
        assert!(
            (pooled_scatter_factor(&[(4.0 * scatter, 60)]) - 4.0 * scatter / 58.0).abs() < 1e-12
        );
        // A wall bowed by 3 cm (a parabola along it): residuals far above 1 cm and
        // smooth from point to point, so both tests fire.
        let bent: Vec<f64> = angles
            .iter()
            .map(|&a| {
                let y = 3.0 * a.tan();
                (3.0 + 0.03 * (1.0 - (y / 1.7).powi(2))) / a.cos()
            })
            .collect();
        ex.collect_valid(&bent, &angles);
        let fit = ex.fit(0, 60);
        let n = Vector2::new(fit.alpha.cos(), fit.alpha.sin());
        let (factor, _) = ex.model_error_factor(0, 60, fit.rho, n);
        assert!(factor > 18.9, "{factor}"); // r1 capped at 0.9 gives 19
    }

    #[test]
    fn bad_parameters_are_refused_by_name() {
        for (params, name) in [
            (
                ScanParams {
                    sigma_range: -1.0,
                    ..ScanParams::default()
                },
                "sigma_range",
            ),
            (
                ScanParams {
                    sigma_range: 1e300,
                    ..ScanParams::default()
                },
                "sigma_range",
            ),
            (
                ScanParams {
                    sigma_bearing: 1e200,
                    ..ScanParams::default()
                },
                "sigma_bearing",
            ),
            (
                ScanParams {
                    split_epsilon: f64::NAN,
                    ..ScanParams::default()
                },
                "split_epsilon",
            ),
            (
                ScanParams {
                    min_points: 1,
                    ..ScanParams::default()
                },
                "min_points",
            ),
            (
                ScanParams {
                    breakpoint_lambda: 2.0,
                    ..ScanParams::default()
                },
                "breakpoint_lambda",
            ),
        ] {
            let err = extract_lines(&[1.0; 3], &[0.0, 0.1, 0.2], &params).unwrap_err();
            assert!(err.to_string().contains(name), "{err}");
        }
        let err = extract_lines(&[1.0; 3], &[0.0, 0.1], &ScanParams::default()).unwrap_err();
        assert!(matches!(err, LineSimpError::LengthMismatch { .. }));
    }
}
