//! A robust start for the front end's ICP where the odometry prior is loose.
//!
//! ICP converges only from within about its pairing distance of the answer. Where
//! the odometry step is long (a log with a scan every two metres and 30 degrees), its
//! three-sigma reach at the scan's typical range exceeds that, and ICP started at the
//! odometry's pose settles on the wrong wall. Then the scan's pose is searched first,
//! by the correlative search of the loop closures (Olson 2009: a coarse-to-fine grid
//! of poses over the prior's three-sigma window, scored by the scan points landing
//! near the local map's), and ICP runs from the best few poses as well as from the
//! odometry's. The match kept is the one of least truncated cost (see
//! [`objective`]), so a start that only fits clutter cannot win over the prior.

use nalgebra::{Matrix2, Matrix3, Vector2};

use crate::correlative::{SearchSteps, Window, coarse_search};
use crate::error::{LaserError, Result};
use crate::grid::MapIndex;
use crate::icp::{IcpConfig, Match, Prior, match_scan, scan_cost};
use crate::scan::ScanPoints;

/// The widest window searched, m: a prior looser than this is searched only this far
/// (the local map's extent; beyond it the scan could not land on it anyway).
const MAX_RADIUS: f64 = 3.0;
/// The widest heading window searched, rad.
const MAX_ANGLE: f64 = 0.5;

/// Settings of the robust start (the front end's come from its
/// [`LocalMapConfig`](crate::frontend::LocalMapConfig)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StartSearch {
    /// The search runs when the prior's reach exceeds this, m.
    pub reach: f64,
    /// The window spans this many standard deviations of the prior.
    pub sigmas: f64,
    /// The search's translation step and hit distance, m.
    pub step: f64,
    /// How many of the best poses ICP starts from.
    pub starts: usize,
    /// ... but only when ICP from the prior's mean paired less than this share of
    /// the scan's points on lines (or was refused), ...
    pub share: f64,
    /// ... or left an RMS distance to the lines above this, m.
    pub rms: f64,
}

/// How far the prior's `sigmas` ellipse can move a point at range `far`: its largest
/// position deviation plus its heading deviation swept over `far`, m.
pub fn prior_reach(covariance: &Matrix3<f64>, far: f64, sigmas: f64) -> f64 {
    let xy: Matrix2<f64> = covariance.fixed_view::<2, 2>(0, 0).into();
    let position = xy.symmetric_eigenvalues().max().max(0.0).sqrt();
    let heading = covariance[(2, 2)].max(0.0).sqrt();
    sigmas * (position + heading * far)
}

/// The median range of the scan's points on lines (1 m when it has none).
fn median_range(lines: &[Vector2<f64>]) -> f64 {
    let mut r: Vec<f64> = lines.iter().map(|p| p.norm()).collect();
    r.sort_by(f64::total_cmp);
    r.get(r.len() / 2).copied().unwrap_or(1.0)
}

/// The prior's window, capped at [`MAX_RADIUS`] and [`MAX_ANGLE`] (the ellipse's
/// orientation kept).
fn window(covariance: &Matrix3<f64>, sigmas: f64, step: f64) -> Window {
    let xy: Matrix2<f64> = covariance.fixed_view::<2, 2>(0, 0) * (sigmas * sigmas);
    let eig = xy.symmetric_eigen();
    let capped = eig
        .eigenvalues
        .map(|v| v.clamp(step * step, MAX_RADIUS * MAX_RADIUS));
    Window {
        xy: eig.eigenvectors * Matrix2::from_diagonal(&capped) * eig.eigenvectors.transpose(),
        angle: (sigmas * covariance[(2, 2)].max(0.0).sqrt()).min(MAX_ANGLE),
    }
}

/// The scan matched to `map` under `prior`: ICP from the prior's mean, and where the
/// prior is looser than `search.reach`, also from the correlative search's best
/// poses; the match of least [`objective`].
pub fn match_robustly(
    scan: &ScanPoints,
    map: &MapIndex,
    prior: &Prior,
    icp: &IcpConfig,
    search: &StartSearch,
) -> Result<Match> {
    let plain = match_scan(scan, map, prior.mean, prior, icp)?;
    // The usual case first, and cheaply: ICP paired most of the scan, closely.
    let share = plain.inliers as f64 / scan.with_normals().max(1) as f64;
    if (plain.accepted && share >= search.share && plain.rms <= search.rms) || map.is_empty() {
        return Ok(plain);
    }
    let covariance = prior
        .information
        .try_inverse()
        .ok_or_else(|| LaserError::Numerical("the prior's information is singular".into()))?;
    let lines = scan.on_lines();
    if prior_reach(&covariance, median_range(&lines), search.sigmas) <= search.reach {
        return Ok(plain);
    }
    let steps = SearchSteps {
        hit_distance: search.step,
        coarse_step: search.step,
        refine: search.starts,
    };
    let win = window(&covariance, search.sigmas, search.step);
    let mut best = (objective(scan, map, &plain, prior, icp), plain);
    for (_, start) in coarse_search(&lines, map.points(), &prior.mean, &win, &steps) {
        let m = match_scan(scan, map, start, prior, icp)?;
        let cost = objective(scan, map, &m, prior, icp);
        if cost < best.0 {
            best = (cost, m);
        }
    }
    Ok(best.1)
}

/// A match's cost, comparable between starts: ICP's weighted squared distances with
/// every point on a line that found no partner charged the pairing distance
/// (truncated least squares), plus the prior's Mahalanobis term.
pub(crate) fn objective(
    scan: &ScanPoints,
    map: &MapIndex,
    m: &Match,
    prior: &Prior,
    icp: &IcpConfig,
) -> f64 {
    let e = crate::icp::prior_error(&m.pose, prior);
    scan_cost(scan, map, &m.pose, icp) + (e.transpose() * prior.information * e)[(0, 0)]
}
