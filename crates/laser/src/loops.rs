//! Loop closures: a key scan matched against the key scans of an earlier visit.
//!
//! The earlier place's key scans form a submap in the world frame. The match starts
//! with a correlative search (Olson 2009) over a window around the current estimate
//! that grows with the path travelled since: every candidate pose is scored by the
//! share of the scan's points that fall within a hit distance of the submap, first
//! on a coarse grid of poses; the best few then start point-to-line ICP. A match is
//! a closure only when it is verified: enough of the scan's points paired, a small
//! residual, and information in every direction (a corridor seen end-on cannot place
//! the robot along it). The caller adds a closure only when a second one, from the
//! next attempt, implies the same correction (joint consistency).

use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};
use rperc_core::{Pose2, wrap_angle};

use crate::error::{LaserError, Result};
use crate::grid::MapIndex;
use crate::icp::{IcpConfig, Match, Prior, match_scan};
use crate::scan::ScanPoints;

/// Settings of the loop-closure search.
#[derive(Debug, Clone, Copy, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(default, deny_unknown_fields)]
pub struct LoopConfig {
    /// Whether to look for closures at all.
    pub enabled: bool,
    /// A place is a candidate only after this much path since it, m (> 0).
    pub min_path: f64,
    /// The search window spans this many standard deviations of the current key
    /// scan's pose relative to the place (from the chain of the graph), (> 0).
    pub sigmas: f64,
    /// A place is a candidate when it may lie within this of the current key scan,
    /// m (> 0), the window's reach included: the scans of two poses this far apart
    /// still overlap.
    pub overlap: f64,
    /// The window's radius is at least this, m (> 0), ...
    pub radius: f64,
    /// ... and at most this along any axis, m (>= radius).
    pub max_radius: f64,
    /// The heading window is at least this, rad (> 0), ...
    pub angle: f64,
    /// ... and at most this, rad (in [angle, pi]).
    pub max_angle: f64,
    /// Key scans on each side of the candidate that make its submap (>= 0).
    pub submap_keys: usize,
    /// A closure is tried at every this many key scans (>= 1), and at the next one
    /// while a closure waits for its confirmation.
    pub every_keys: usize,
    /// After a confirmed pair of closures, no closure is tried for this many key scans
    /// (>= 0): the place is closed, and each attempt costs a correlative search.
    pub cooldown_keys: usize,
    /// Coarse search step in x and y, m (> 0).
    pub coarse_step: f64,
    /// A point scores when within this of the submap, m (> 0).
    pub hit_distance: f64,
    /// Best coarse poses refined by ICP (>= 1).
    pub refine: usize,
    /// A closure pairs at least this share of the scan's points (in (0, 1]).
    pub min_inlier_share: f64,
    /// ... with at most this RMS distance to their lines, m (> 0).
    pub max_rms: f64,
    /// ... and at least this information in its weakest direction (the smallest
    /// eigenvalue of the scan's information in m and rad units, > 0).
    pub min_information: f64,
    /// Two closures confirm each other when their corrections agree within this,
    /// m (> 0), ...
    pub agree_distance: f64,
    /// ... and this, rad (> 0).
    pub agree_angle: f64,
    /// After each optimisation the closure with the largest squared error (by its
    /// own information) is removed while that error exceeds this (> 0): a closure
    /// that disagrees with the chain and the other closures is a wrong one.
    pub max_chi2: f64,
}

impl Default for LoopConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            min_path: 8.0,
            sigmas: 3.0,
            overlap: 2.0,
            radius: 0.5,
            max_radius: 30.0,
            angle: 5f64.to_radians(),
            max_angle: 30f64.to_radians(),
            submap_keys: 6,
            every_keys: 3,
            cooldown_keys: 10,
            coarse_step: 0.15,
            hit_distance: 0.15,
            refine: 4,
            min_inlier_share: 0.5,
            max_rms: 0.06,
            min_information: 1e3,
            agree_distance: 0.2,
            agree_angle: 2f64.to_radians(),
            max_chi2: 50.0,
        }
    }
}

fn positive(name: &'static str, v: f64) -> Result<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(LaserError::invalid(
            name,
            format!("must be finite and > 0, got {v}"),
        ))
    }
}

impl LoopConfig {
    /// Refuses bad values with the parameter's name.
    pub fn validate(&self) -> Result<()> {
        for (name, v) in [
            ("min_path", self.min_path),
            ("sigmas", self.sigmas),
            ("overlap", self.overlap),
            ("radius", self.radius),
            ("angle", self.angle),
            ("coarse_step", self.coarse_step),
            ("hit_distance", self.hit_distance),
            ("max_rms", self.max_rms),
            ("min_information", self.min_information),
            ("agree_distance", self.agree_distance),
            ("agree_angle", self.agree_angle),
            ("max_chi2", self.max_chi2),
        ] {
            positive(name, v)?;
        }
        if !(self.max_radius.is_finite()
            && self.max_radius >= self.radius
            && self.max_radius <= 100.0)
        {
            return Err(LaserError::invalid(
                "max_radius",
                format!("must be in [radius, 100], got {}", self.max_radius),
            ));
        }
        if !(self.max_angle >= self.angle && self.max_angle <= std::f64::consts::PI) {
            return Err(LaserError::invalid(
                "max_angle",
                format!("must be in [angle, pi], got {}", self.max_angle),
            ));
        }
        if !(self.min_inlier_share > 0.0 && self.min_inlier_share <= 1.0) {
            let s = self.min_inlier_share;
            return Err(LaserError::invalid(
                "min_inlier_share",
                format!("must be in (0, 1], got {s}"),
            ));
        }
        if !(1..=1000).contains(&self.every_keys)
            || !(1..=100).contains(&self.refine)
            || self.submap_keys > 1000
        {
            return Err(LaserError::invalid(
                "every_keys",
                format!(
                    "every_keys must be in 1..=1000, refine in 1..=100, submap_keys <= 1000; got {}, {}, {}",
                    self.every_keys, self.refine, self.submap_keys
                ),
            ));
        }
        if self.coarse_step < 1e-3 {
            return Err(LaserError::invalid(
                "coarse_step",
                format!("must be at least 1 mm, got {}", self.coarse_step),
            ));
        }
        Ok(())
    }

    /// The search window around the current estimate when its pose relative to the
    /// place has covariance `relative` (world axes): `sigmas` standard deviations,
    /// within the configured radius and angle limits.
    pub fn window(&self, relative: &Matrix3<f64>) -> Window {
        let k2 = self.sigmas * self.sigmas;
        let floor = Matrix2::identity() * (self.radius * self.radius);
        let xy: Matrix2<f64> = relative.fixed_view::<2, 2>(0, 0) * k2 + floor;
        // Cap every axis at max_radius, keeping the ellipse's orientation.
        let eig = xy.symmetric_eigen();
        let capped = eig
            .eigenvalues
            .map(|v| v.clamp(0.0, self.max_radius * self.max_radius));
        let xy = eig.eigenvectors * Matrix2::from_diagonal(&capped) * eig.eigenvectors.transpose();
        let sd = relative[(2, 2)].max(0.0).sqrt();
        let angle = (self.sigmas * sd).clamp(self.angle, self.max_angle);
        Window { xy, angle }
    }
}

/// Where a closure is searched for: an ellipse `d^T xy^-1 d <= 1` around the current
/// estimate (world axes, m^2) and a heading window of +- `angle` rad.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Window {
    /// The ellipse's matrix.
    pub xy: Matrix2<f64>,
    /// The heading half-window, rad.
    pub angle: f64,
}

impl Window {
    /// Whether an offset lies inside the ellipse (`inverse` is `xy`'s).
    fn contains(&self, d: &Vector2<f64>, inverse: &Matrix2<f64>) -> bool {
        (d.transpose() * inverse * d)[(0, 0)] <= 1.0 + 1e-9
    }

    /// The half-extent of the ellipse along x and y.
    fn extent(&self) -> Vector2<f64> {
        Vector2::new(self.xy[(0, 0)].sqrt(), self.xy[(1, 1)].sqrt())
    }
}

/// A grid of the cells within `hit` of a submap point, for scoring poses.
struct HitGrid {
    origin: Vector2<f64>,
    cell: f64,
    cols: usize,
    rows: usize,
    hit: Vec<bool>,
}

impl HitGrid {
    /// Cells of `cell` m, hit when within `hit` of a point.
    fn new(points: &[Vector2<f64>], hit: f64, cell: f64) -> Self {
        let (mut lo, mut hi) = (
            Vector2::repeat(f64::INFINITY),
            Vector2::repeat(f64::NEG_INFINITY),
        );
        for p in points {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        let pad = Vector2::repeat(hit + cell);
        let (lo, hi) = (lo - pad, hi + pad);
        let cols = ((hi.x - lo.x) / cell).ceil().max(1.0) as usize;
        let rows = ((hi.y - lo.y) / cell).ceil().max(1.0) as usize;
        let mut grid = HitGrid {
            origin: lo,
            cell,
            cols,
            rows,
            hit: vec![false; cols * rows],
        };
        let reach = (hit / cell).ceil() as i64;
        for p in points {
            let (ci, cj) = grid.coords(p);
            for dj in -reach..=reach {
                for di in -reach..=reach {
                    let c =
                        Vector2::new((ci + di) as f64 + 0.5, (cj + dj) as f64 + 0.5) * cell + lo;
                    if (c - p).norm() <= hit {
                        grid.set(ci + di, cj + dj);
                    }
                }
            }
        }
        grid
    }

    fn coords(&self, p: &Vector2<f64>) -> (i64, i64) {
        let d = (p - self.origin) / self.cell;
        // Truncation is floor for the grid's own (non-negative) coordinates; points
        // left of or below it stay outside (-1).
        let cell = |v: f64| if v >= 0.0 { v as i64 } else { -1 };
        (cell(d.x), cell(d.y))
    }

    fn set(&mut self, i: i64, j: i64) {
        if i >= 0 && j >= 0 && (i as usize) < self.cols && (j as usize) < self.rows {
            self.hit[j as usize * self.cols + i as usize] = true;
        }
    }

    fn is_hit_cell(&self, i: i64, j: i64) -> bool {
        i >= 0
            && j >= 0
            && (i as usize) < self.cols
            && (j as usize) < self.rows
            && self.hit[j as usize * self.cols + i as usize]
    }
}

/// At most this many of a scan's points score a pose: the score is a share, and
/// more points only cost time.
const SCORED_POINTS: usize = 60;

/// At most about this many positions in a coarse search: a wider window gets a
/// coarser step, so an attempt never costs more than a few hundred thousand look-ups.
const MAX_POSITIONS: f64 = 3000.0;

/// Submap points farther than this from the search centre are not scored, m: it
/// bounds the hit grids (cells of a few centimetres) to some tens of megabytes.
const MAX_REACH: f64 = 250.0;

/// The best `keep` poses (with their scores) on a grid of `steps` cells of `grid`
/// and `dth` rad around `centre`, within `window`, scored by the share of `points`
/// (laser frame) that land on `grid`'s hits. Translations are whole cells, so each
/// heading moves the points to cells once and every translation is an integer
/// offset.
fn grid_search(
    points: &[Vector2<f64>],
    grid: &HitGrid,
    centre: &Pose2,
    window: &Window,
    steps: i64,
    dth: f64,
    keep: usize,
) -> Vec<(f64, Pose2)> {
    let step = steps as f64 * grid.cell;
    let nth = (window.angle / dth).round() as i64;
    let reach = window.extent();
    let (nx, ny) = (
        (reach.x / step).round() as i64,
        (reach.y / step).round() as i64,
    );
    let inverse = window.xy.try_inverse().unwrap_or_else(Matrix2::zeros);
    let mut best: Vec<(f64, Pose2)> = Vec::new();
    let mut cells = vec![(0i64, 0i64); points.len()];
    for a in -nth..=nth {
        let th = centre.theta + a as f64 * dth;
        let (s, c) = th.sin_cos();
        for (cell, p) in cells.iter_mut().zip(points) {
            let r = Vector2::new(c * p.x - s * p.y, s * p.x + c * p.y);
            *cell = grid.coords(&(r + centre.translation()));
        }
        for j in -ny..=ny {
            for i in -nx..=nx {
                let d = Vector2::new(i as f64, j as f64) * step;
                if !window.contains(&d, &inverse) {
                    continue;
                }
                let (di, dj) = (i * steps, j * steps);
                let hits = cells
                    .iter()
                    .filter(|&&(ci, cj)| grid.is_hit_cell(ci + di, cj + dj))
                    .count();
                let score = hits as f64 / points.len().max(1) as f64;
                let t = centre.translation() + d;
                keep_best(
                    &mut best,
                    (score, Pose2::new(t.x, t.y, wrap_angle(th))),
                    keep,
                );
            }
        }
    }
    best
}

/// Coarse to fine: the window searched on a coarse grid of poses against hits
/// dilated to the coarse step, then the best few searched again on a fine grid
/// around them.
fn coarse_search(
    points: &[Vector2<f64>],
    submap: &[Vector2<f64>],
    centre: &Pose2,
    window: &Window,
    cfg: &LoopConfig,
) -> Vec<(f64, Pose2)> {
    let stride = points.len().div_ceil(SCORED_POINTS).max(1);
    let pts: Vec<Vector2<f64>> = points.iter().step_by(stride).copied().collect();
    // Only the submap points the scan can reach from inside the window score; this
    // also bounds the hit grids' size whatever the log's ranges (at most 250 m).
    let reach_scan = pts.iter().map(|p| p.norm()).fold(0.0, f64::max);
    let limit = (window.extent().max() + reach_scan + 2.0 * cfg.hit_distance).min(MAX_REACH);
    let near: Vec<Vector2<f64>> = submap
        .iter()
        .filter(|p| (*p - centre.translation()).norm() <= limit)
        .copied()
        .collect();
    let submap = &near[..];
    if submap.is_empty() {
        return Vec::new();
    }
    // The heading step moves a point at the median range by about one step; farther
    // points land within the fine search and ICP's reach.
    let mut ranges: Vec<f64> = pts.iter().map(|p| p.norm()).collect();
    ranges.sort_by(f64::total_cmp);
    let far = ranges
        .get(ranges.len() / 2)
        .copied()
        .unwrap_or(1.0)
        .max(1.0);
    // Coarse: steps of twice the fine step (more for a wide window), hits dilated to
    // match; fine: cells of half a step. Both move the points by two whole cells.
    let area = std::f64::consts::PI * window.xy.determinant().max(0.0).sqrt();
    let coarse_cell = cfg.coarse_step.max((area / MAX_POSITIONS).sqrt() / 2.0);
    let coarse = 2.0 * coarse_cell;
    let dth_coarse = (coarse / far).clamp(0.5f64.to_radians(), 3f64.to_radians());
    let wide = HitGrid::new(submap, cfg.hit_distance.max(coarse), coarse_cell);
    let first = grid_search(&pts, &wide, centre, window, 2, dth_coarse, 2 * cfg.refine);
    let fine = HitGrid::new(submap, cfg.hit_distance, cfg.coarse_step / 2.0);
    let dth = (cfg.coarse_step / far).clamp(0.25f64.to_radians(), 2f64.to_radians());
    let around = Window {
        xy: Matrix2::identity() * (coarse * coarse),
        angle: dth_coarse,
    };
    let mut best = Vec::new();
    for (_, start) in first {
        for item in grid_search(&pts, &fine, &start, &around, 2, dth, cfg.refine) {
            keep_best(&mut best, item, cfg.refine);
        }
    }
    best
}

fn keep_best(best: &mut Vec<(f64, Pose2)>, item: (f64, Pose2), keep: usize) {
    if best.len() < keep || item.0 > best[best.len() - 1].0 {
        let at = best.partition_point(|b| b.0 >= item.0);
        best.insert(at, item);
        best.truncate(keep);
    }
}

/// A verified match of a key scan against a submap: the scan's pose in the world and
/// the scan's information about it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Closure {
    /// The matched pose.
    pub pose: Pose2,
    /// The scan's information about it (the ICP Hessian, inflated as ICP's).
    pub information: Matrix3<f64>,
    /// Share of the scan's points paired.
    pub inlier_share: f64,
    /// RMS distance to the lines, m.
    pub rms: f64,
}

/// Why an attempt gave no closure.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rejection {
    /// Too few points paired.
    Inliers = 0,
    /// Too large a residual.
    Residual,
    /// Too little information in some direction.
    Degenerate,
}

/// Matches `scan` against `submap` around `estimate`, in the window after `path`
/// metres; the verified closure, or why it failed.
pub fn close_loop(
    scan: &ScanPoints,
    submap: &MapIndex,
    estimate: &Pose2,
    window: &Window,
    icp: &IcpConfig,
    cfg: &LoopConfig,
) -> Result<std::result::Result<Closure, Rejection>> {
    let lines: Vec<Vector2<f64>> = scan
        .points
        .iter()
        .zip(&scan.normals)
        .filter(|(_, n)| n.is_some())
        .map(|(p, _)| *p)
        .collect();
    if lines.len() < icp.min_inliers || submap.is_empty() {
        return Ok(Err(Rejection::Inliers));
    }
    let starts = coarse_search(&lines, submap.points(), estimate, window, cfg);
    // A weak prior keeps ICP's normal equations regular where the scan sees nothing;
    // only the scan's own information goes into the closure.
    let weak = Matrix3::from_diagonal(&Vector3::new(1e-6, 1e-6, 1e-6));
    let mut best: Option<Match> = None;
    for (_, start) in starts {
        let m = match_scan(
            scan,
            submap,
            start,
            &Prior {
                mean: start,
                information: weak,
            },
            icp,
        )?;
        if m.accepted && best.is_none_or(|b| m.inliers > b.inliers) {
            best = Some(m);
        }
    }
    let Some(m) = best else {
        return Ok(Err(Rejection::Inliers));
    };
    let share = m.inliers as f64 / lines.len() as f64;
    if share < cfg.min_inlier_share {
        return Ok(Err(Rejection::Inliers));
    }
    if m.rms > cfg.max_rms {
        return Ok(Err(Rejection::Residual));
    }
    // A place seen along a featureless corridor cannot place the robot along it:
    // such a closure is refused rather than trusted in its other directions (tried:
    // its poorly determined directions zeroed, it still let along-corridor guesses
    // in; the robot NEES on the infinite corridor went from 20 to 12,000).
    if m.information.symmetric_eigenvalues().min() < cfg.min_information {
        return Ok(Err(Rejection::Degenerate));
    }
    Ok(Ok(Closure {
        pose: m.pose,
        information: m.information,
        inlier_share: share,
        rms: m.rms,
    }))
}

/// Whether two closures agree (joint consistency): the first closure's pose moved by
/// the front end's motion between the two scans lands where the second closure puts
/// the second scan. `(estimate, closure)` pairs, the earlier first.
pub fn agree(first: (&Pose2, &Closure), second: (&Pose2, &Closure), cfg: &LoopConfig) -> bool {
    let predicted = first.1.pose.compose(&first.0.between(second.0));
    let d = predicted.between(&second.1.pose);
    d.translation().norm() <= cfg.agree_distance && wrap_angle(d.theta).abs() <= cfg.agree_angle
}
