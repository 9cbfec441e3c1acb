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

use nalgebra::{Matrix2, Matrix3, Vector3};
use rperc_core::{Pose2, wrap_angle};

pub use crate::correlative::Window;
use crate::correlative::{SearchSteps, coarse_search};
use crate::error::{LaserError, Result};
use crate::grid::MapIndex;
use crate::icp::{IcpConfig, Match, Prior, match_scan};
use crate::scan::ScanPoints;

/// Settings of the loop-closure search.
#[derive(
    Debug, Clone, Copy, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema,
)]
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
    /// Each closure's covariance is multiplied by this (>= 1) in the graph: a
    /// confirmed closure joins it with the one that confirmed it, both matched
    /// against the same place's key scans, whose errors they share, and the next
    /// pairs at that place match much of the same submap again. Default 3, chosen by
    /// leave-one-log-out over the nine corpus logs on seeds 10-19 (see
    /// `docs/decisions.md`).
    pub inflation: f64,
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
            inflation: 3.0,
        }
    }
}

impl LoopConfig {
    /// The correlative search's share of the settings.
    pub(crate) fn search_steps(&self) -> SearchSteps {
        SearchSteps {
            hit_distance: self.hit_distance,
            coarse_step: self.coarse_step,
            refine: self.refine,
        }
    }

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
            rperc_core::ensure_positive(name, v)?;
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
        if !(self.inflation.is_finite() && self.inflation >= 1.0) {
            return Err(LaserError::invalid(
                "inflation",
                format!("must be finite and >= 1, got {}", self.inflation),
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

impl Closure {
    /// The closure as a graph edge's measurement from `anchor` (the place's pose as
    /// the submap had it): the matched pose relative to it, and the information of
    /// that relative pose (the match's, carried through the Jacobian of
    /// `anchor.between`) with the covariance multiplied by `inflation`.
    pub fn relative_to(&self, anchor: &Pose2, inflation: f64) -> Result<(Pose2, Matrix3<f64>)> {
        let (z, _, j) = anchor.between_with_jacobians(&self.pose);
        let j_inv = j
            .try_inverse()
            .ok_or_else(|| LaserError::Numerical("closure Jacobian".into()))?;
        Ok((z, j_inv.transpose() * self.information * j_inv / inflation))
    }
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
    let lines = scan.on_lines();
    if lines.len() < icp.min_inliers || submap.is_empty() {
        return Ok(Err(Rejection::Inliers));
    }
    let starts = coarse_search(
        &lines,
        submap.points(),
        estimate,
        window,
        &cfg.search_steps(),
    );
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The edge's covariance is the match's carried through `between` by central
    /// differences (the oracle), times the inflation: `J Sigma J^T k`.
    #[test]
    fn a_closure_edge_carries_the_matchs_covariance_times_the_inflation() {
        let anchor = Pose2::new(3.0, -1.0, 2.5);
        let sigma = Matrix3::new(0.04, 0.01, 0.002, 0.01, 0.09, -0.003, 0.002, -0.003, 0.01);
        let closure = Closure {
            pose: Pose2::new(5.5, 2.0, -2.9),
            information: sigma.try_inverse().unwrap(),
            inlier_share: 1.0,
            rms: 0.01,
        };
        let h = 1e-6;
        let mut j = Matrix3::zeros();
        for c in 0..3 {
            let mut d = Vector3::zeros();
            d[c] = h;
            let at = |s: f64| {
                let p = &closure.pose;
                anchor.between(&Pose2::new(p.x + s * d.x, p.y + s * d.y, p.theta + s * d.z))
            };
            let (a, b) = (at(1.0), at(-1.0));
            let column = Vector3::new(a.x - b.x, a.y - b.y, wrap_angle(a.theta - b.theta));
            j.set_column(c, &(column / (2.0 * h)));
        }
        for inflation in [1.0, 3.0] {
            let (z, information) = closure.relative_to(&anchor, inflation).unwrap();
            assert_eq!(z, anchor.between(&closure.pose));
            let expected = j * sigma * j.transpose() * inflation;
            let got = information.try_inverse().unwrap();
            assert!(
                (got - expected).abs().max() < 1e-8,
                "{got} against {expected}"
            );
        }
    }
}
