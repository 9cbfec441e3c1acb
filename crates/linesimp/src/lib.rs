#![doc = include_str!("../README.md")]
#![deny(missing_docs)]

mod dp;
mod error;
mod hull;
mod metric;
mod topology;
mod visvalingam;
mod walls;

use nalgebra::Point2;
use rayon::prelude::*;

pub use dp::Tie;
pub use error::{LineSimpError, Result};
pub use metric::{Metric, chord_distance};
pub use topology::{Component, simplify_preserving_topology};
pub use walls::{LineExtractor, ScanParams, WallSegment, extract_lines};

rperc_core::named_enum! {
    /// Which simplification algorithm runs.
    #[derive(Default)]
    pub enum Method: "method" {
        /// Douglas-Peucker, the fastest exact implementation for the metric:
        /// [`Method::Hull`] for [`Metric::Line`], [`Method::Dp`] for [`Metric::Segment`].
        #[default]
        Auto = "auto",
        /// Douglas-Peucker with Hershberger-Snoeyink path hulls: O(n log n) worst case,
        /// line metric only.
        Hull = "hull",
        /// The plain Douglas-Peucker of seed 000, Table 1 (explicit stack): O(n^2) worst
        /// case.
        Dp = "dp",
        /// Visvalingam-Whyatt effective-area elimination, O(n log n). `epsilon` is an
        /// *area*: vertices whose triangle with their current neighbours has area
        /// `<= epsilon` are removed, smallest first (ties: smallest index first), as the
        /// `simplification` package (geo) does. The metric does not apply; only
        /// [`Metric::Line`], the default, is accepted. Both end points stay, also for a
        /// closed ring.
        Visvalingam = "vw",
    }
}

impl Method {
    /// The method that actually runs for `metric`: [`Method::Auto`] resolved, the others
    /// unchanged.
    pub fn resolve(self, metric: Metric) -> Method {
        match (self, metric) {
            (Method::Auto, Metric::Line) => Method::Hull,
            (Method::Auto, Metric::Segment) => Method::Dp,
            (other, _) => other,
        }
    }
}

/// The algorithm that runs for a method/metric pair, once `Auto` is resolved and the
/// pair is known to be supported.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Engine {
    Hull,
    Dp,
    Visvalingam,
}

impl Engine {
    fn for_options(method: Method, metric: Metric) -> Result<Engine> {
        match (method.resolve(metric), metric) {
            (Method::Hull, Metric::Line) => Ok(Engine::Hull),
            (Method::Hull, Metric::Segment) => Err(LineSimpError::UnsupportedMetric),
            (Method::Dp, _) => Ok(Engine::Dp),
            (Method::Visvalingam, Metric::Line) => Ok(Engine::Visvalingam),
            (Method::Visvalingam, Metric::Segment) => Err(LineSimpError::InvalidParameter {
                name: "metric",
                reason: "method 'vw' ranks vertices by triangle area, not by a distance; \
                         leave metric at 'line'"
                    .to_owned(),
            }),
            // `resolve` never returns `Auto`; this arm only satisfies the match.
            (Method::Auto, _) => Ok(Engine::Dp),
        }
    }
}

/// Reusable simplification engine. Keeping one per thread avoids re-allocating the
/// path hull, the work stack and the keep mask on every polyline.
///
/// # Examples
/// ```
/// use linesimp::{Method, Metric, Simplifier};
/// use nalgebra::Point2;
///
/// let pts: Vec<Point2<f64>> = (0..=10).map(|i| Point2::new(i as f64, 0.0)).collect();
/// let mut s = Simplifier::new(Method::Hull, Metric::Line);
/// assert_eq!(s.indices(&pts, 0.1).unwrap(), vec![0, 10]);
/// ```
#[derive(Debug, Default)]
pub struct Simplifier {
    method: Method,
    metric: Metric,
    tie: Tie,
    dp_budget: Option<usize>,
    keep: Vec<bool>,
    ranges: Vec<(usize, usize)>,
    tasks: Vec<hull::Task>,
    hull: hull::PathHull,
    vw: visvalingam::Scratch,
}

impl Simplifier {
    /// A simplifier for one method/metric pair.
    pub fn new(method: Method, metric: Metric) -> Self {
        Self {
            method,
            metric,
            ..Self::default()
        }
    }

    /// Chooses which of several equally far vertices splits a chord; see [`Tie`] for
    /// exactly what each rule promises (Visvalingam-Whyatt has its own rule: the
    /// smallest index among equal areas). The default, [`Tie::First`], matches GEOS.
    pub fn with_tie(mut self, tie: Tie) -> Self {
        self.tie = tie;
        self
    }

    /// For [`Method::Hull`]: how much plain-DP work (distance evaluations per vertex
    /// per level of a balanced split) runs before path hulls take over. Plain DP is
    /// cheaper per vertex and finishes within the default budget on real data; the
    /// budget caps its quadratic worst case. `0` runs path hulls from the start. Both
    /// phases split at exactly the same vertex, so the result does not depend on it.
    pub fn with_dp_budget(mut self, per_level: usize) -> Self {
        self.dp_budget = Some(per_level);
        self
    }

    /// Indices of the vertices the method keeps, in increasing order. The first and
    /// last vertex are always kept; fewer than three points come back unchanged.
    ///
    /// Douglas-Peucker ties (several vertices equally far from a chord) split as
    /// [`Self::with_tie`] says: at the first of them by default, as GEOS does.
    /// Visvalingam-Whyatt removes the smallest area first, the smallest index among
    /// equal areas.
    ///
    /// # Examples
    /// ```
    /// use linesimp::{Method, Metric, Simplifier};
    /// use nalgebra::Point2;
    ///
    /// let pts = [Point2::new(0.0, 0.0), Point2::new(1.0, 0.1), Point2::new(2.0, 0.0)];
    /// // The default, `Auto`, runs plain DP for the segment metric.
    /// let mut dp = Simplifier::new(Method::Auto, Metric::Segment);
    /// assert_eq!(dp.indices(&pts, 0.2).unwrap(), vec![0, 2]);
    /// // The triangle (0,0) (1,0.1) (2,0) has area 0.1: removed at 0.1, kept below.
    /// let mut vw = Simplifier::new(Method::Visvalingam, Metric::Line);
    /// assert_eq!(vw.indices(&pts, 0.1).unwrap(), vec![0, 2]);
    /// assert_eq!(vw.indices(&pts, 0.09).unwrap(), vec![0, 1, 2]);
    /// ```
    pub fn indices(&mut self, points: &[Point2<f64>], epsilon: f64) -> Result<Vec<usize>> {
        validate(points, epsilon)?;
        let engine = Engine::for_options(self.method, self.metric)?;
        let n = points.len();
        if n < 3 {
            return Ok((0..n).collect());
        }
        self.keep.clear();
        self.keep.resize(n, false);
        self.keep[0] = true;
        self.keep[n - 1] = true;
        match engine {
            Engine::Dp => dp::dp_mark(
                points,
                epsilon,
                self.metric,
                self.tie,
                &mut self.keep,
                &mut self.ranges,
            )?,
            Engine::Hull => hull::hull_mark(
                points,
                epsilon,
                self.tie,
                &mut self.keep,
                &mut self.ranges,
                &mut self.tasks,
                &mut self.hull,
                self.dp_budget.unwrap_or(hull::DP_BUDGET_PER_LEVEL),
            )?,
            Engine::Visvalingam => {
                visvalingam::vw_mark(points, epsilon, &mut self.keep, &mut self.vw)
            }
        }
        Ok(self
            .keep
            .iter()
            .enumerate()
            .filter_map(|(k, &keep)| keep.then_some(k))
            .collect())
    }
}

impl Simplifier {
    /// [`Self::indices`] for many polylines in parallel, with this simplifier's
    /// settings; one result per input, in input order. See [`simplify_many`].
    pub fn indices_many<P>(&self, polylines: &[P], epsilon: f64) -> Vec<Result<Vec<usize>>>
    where
        P: AsRef<[Point2<f64>]> + Sync,
    {
        let (method, metric, tie, budget) = (self.method, self.metric, self.tie, self.dp_budget);
        // The pool's threads work under the caller's interrupt token (if any).
        let token = rperc_core::interrupt::current();
        polylines
            .par_iter()
            .map_init(
                || Simplifier {
                    dp_budget: budget,
                    ..Simplifier::new(method, metric).with_tie(tie)
                },
                |s, pl| {
                    rperc_core::interrupt::run_with(token.clone(), || {
                        s.indices(pl.as_ref(), epsilon)
                    })
                },
            )
            .collect()
    }
}

/// Checks the tolerance and every coordinate before any work starts.
fn validate(points: &[Point2<f64>], epsilon: f64) -> Result<()> {
    if !(epsilon.is_finite() && epsilon >= 0.0) {
        return Err(LineSimpError::InvalidEpsilon(epsilon));
    }
    if points.len() > u32::MAX as usize {
        return Err(LineSimpError::InvalidParameter {
            name: "points",
            reason: format!(
                "at most {} points are supported, got {}",
                u32::MAX,
                points.len()
            ),
        });
    }
    if let Some(index) = points
        .iter()
        .position(|p| !(p.x.is_finite() && p.y.is_finite()))
    {
        let p = points[index];
        return Err(LineSimpError::NonFinitePoint {
            index,
            x: p.x,
            y: p.y,
        });
    }
    Ok(())
}

/// Indices of the vertices kept by Douglas-Peucker with tolerance `epsilon`.
///
/// # Examples
/// ```
/// use linesimp::{Method, Metric, simplify_indices};
/// use nalgebra::Point2;
///
/// let pts = [Point2::new(0.0, 0.0), Point2::new(1.0, 0.05), Point2::new(2.0, 1.0), Point2::new(3.0, 1.0)];
/// // (2, 1) is 0.32 from the chord (0,0)-(3,1); (1, 0.05) is then 0.40 from (0,0)-(2,1).
/// assert_eq!(simplify_indices(&pts, 0.5, Method::Hull, Metric::Line).unwrap(), vec![0, 3]);
/// assert_eq!(simplify_indices(&pts, 0.3, Method::Dp, Metric::Line).unwrap(), vec![0, 1, 2, 3]);
/// ```
pub fn simplify_indices(
    points: &[Point2<f64>],
    epsilon: f64,
    method: Method,
    metric: Metric,
) -> Result<Vec<usize>> {
    Simplifier::new(method, metric).indices(points, epsilon)
}

/// The kept vertices themselves.
///
/// # Examples
/// ```
/// use linesimp::{Method, Metric, simplify};
/// use nalgebra::Point2;
///
/// let pts = [Point2::new(0.0, 0.0), Point2::new(1.0, 0.01), Point2::new(2.0, 0.0)];
/// assert_eq!(simplify(&pts, 0.1, Method::Hull, Metric::Line).unwrap(), vec![pts[0], pts[2]]);
/// ```
pub fn simplify(
    points: &[Point2<f64>],
    epsilon: f64,
    method: Method,
    metric: Metric,
) -> Result<Vec<Point2<f64>>> {
    Ok(simplify_indices(points, epsilon, method, metric)?
        .into_iter()
        .map(|k| points[k])
        .collect())
}

/// Simplifies many polylines in parallel, one result per input, in input order.
///
/// Each rayon task owns one [`Simplifier`], so buffers are reused across the
/// polylines it handles. Polylines are the unit of work: they are independent and
/// usually large enough that splitting finer would only add scheduling overhead.
///
/// # Examples
/// ```
/// use linesimp::{Method, Metric, simplify_many};
/// use nalgebra::Point2;
///
/// let a: Vec<Point2<f64>> = (0..5).map(|i| Point2::new(i as f64, 0.0)).collect();
/// let b = vec![Point2::new(0.0, 0.0), Point2::new(1.0, 5.0), Point2::new(2.0, 0.0)];
/// let out = simplify_many(&[a.as_slice(), b.as_slice()], 0.5, Method::Hull, Metric::Line);
/// assert_eq!(out[0].as_ref().unwrap(), &vec![0, 4]);
/// assert_eq!(out[1].as_ref().unwrap(), &vec![0, 1, 2]);
/// ```
pub fn simplify_many<P>(
    polylines: &[P],
    epsilon: f64,
    method: Method,
    metric: Metric,
) -> Vec<Result<Vec<usize>>>
where
    P: AsRef<[Point2<f64>]> + Sync,
{
    Simplifier::new(method, metric).indices_many(polylines, epsilon)
}

/// Whether every vertex dropped by `kept` lies within `epsilon` of the chord that
/// replaces it (with a small relative slack for round-off). The validity criterion
/// of any Douglas-Peucker result; useful as a test oracle.
pub fn is_valid_simplification(
    points: &[Point2<f64>],
    kept: &[usize],
    epsilon: f64,
    metric: Metric,
) -> bool {
    if points.len() < 2 {
        return kept.len() == points.len();
    }
    if kept.first() != Some(&0) || kept.last() != Some(&(points.len() - 1)) {
        return false;
    }
    kept.windows(2).all(|w| {
        let (a, b) = (points[w[0]], points[w[1]]);
        let scale = 1.0 + a.coords.amax().max(b.coords.amax());
        points[w[0] + 1..w[1]]
            .iter()
            .all(|p| chord_distance(p, &a, &b, metric) <= epsilon + 1e-9 * scale)
    })
}
