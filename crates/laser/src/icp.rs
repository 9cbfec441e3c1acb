//! Point-to-line ICP (Censi 2008) with a Gaussian prior on the pose.
//!
//! Each scan point `p` (laser frame), moved by the pose to `q = R p + t`, is paired
//! with the nearest map point `m` within a gate and contributes the residual
//! `r = n^T (q - m)`, its distance to the map's line through `m` with normal `n`.
//! The prior (the odometry step from the previous pose) adds `e^T Lambda e`, `e` the
//! pose's difference from the prior mean. Gauss-Newton minimises the sum, with Huber
//! weights on the residuals (clutter and moved furniture). At the optimum the scan's
//! information `H_s = sum w J^T J / sigma^2` (Censi 2007's Hessian approximation),
//! inflated by `covariance_scale` for the residuals' correlation (neighbouring
//! points share the map's and the wall's errors), and the prior's `Lambda` give the
//! fused covariance `(H_s / scale + Lambda)^-1`. The correlation grows with the
//! pairs: beyond `independent_pairs` of them the scale grows in proportion, so the
//! information stops growing (a scan of 300 points on a few walls knows the pose
//! no better than one of 100: their errors are the walls', shared). Where the scan
//! sees nothing (along a featureless corridor) `H_s` is zero and the estimate and
//! its variance stay the prior's: the odometry's.

use nalgebra::{Matrix3, Vector2, Vector3};
use rperc_core::{Pose2, wrap_angle};

use crate::error::{LaserError, Result};
use crate::grid::MapIndex;
use crate::scan::ScanPoints;

/// Settings of [`match_scan`].
#[derive(
    Debug, Clone, Copy, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema,
)]
#[serde(default, deny_unknown_fields)]
pub struct IcpConfig {
    /// Gauss-Newton iterations at most (>= 1).
    pub iterations: usize,
    /// A point pairs with a map point at most this far away, m (> 0).
    pub max_distance: f64,
    /// Standard deviation of a point's distance to its line, m (> 0): range noise
    /// and the map's own thickness.
    pub sigma: f64,
    /// The beam's angular noise, rad (>= 0): a point at range `r` lies `r *
    /// angle_sigma` off its beam's nominal direction, so its distance to its line has
    /// variance `sigma^2 + (r * angle_sigma)^2` and far points weigh less. Default 0
    /// (off): leave-one-log-out by ATE chose 0 in every fold; it lowers the NEES and
    /// costs ATE where far walls carry the match (figures: `docs/decisions.md`).
    pub angle_sigma: f64,
    /// Residuals beyond this many standard deviations are down-weighted (Huber), (> 0).
    pub huber: f64,
    /// The scan's covariance is inflated by this factor (>= 1) for the correlation
    /// of its residuals.
    pub covariance_scale: f64,
    /// A match with fewer paired points is refused (>= 3).
    pub min_inliers: usize,
    /// Beyond this many paired points (>= 1) the scan's information stops growing:
    /// `covariance_scale` is multiplied by `pairs / independent_pairs`. Chosen by
    /// leave-one-log-out over the nine corpus logs (see the laser guide).
    pub independent_pairs: usize,
    /// Iterations stop when a step moves less than this, m or rad (> 0).
    pub tolerance: f64,
    /// A point pairs only with a map point whose normal is within this
    /// angle of its own, rad (in (0, pi]): near a corner the nearest map point often
    /// lies on the other wall, and its line would pull the pose askew.
    pub max_normal_angle: f64,
}

impl Default for IcpConfig {
    fn default() -> Self {
        Self {
            iterations: 20,
            max_distance: 0.3,
            sigma: 0.03,
            angle_sigma: 0.0,
            huber: 2.0,
            covariance_scale: 3.0,
            min_inliers: 10,
            independent_pairs: 70,
            tolerance: 1e-5,
            max_normal_angle: 30f64.to_radians(),
        }
    }
}

impl IcpConfig {
    /// Refuses bad values with the parameter's name.
    pub fn validate(&self) -> Result<()> {
        // A count of work, not of memory: nothing is allocated per iteration.
        rperc_core::ensure_count("iterations", self.iterations, 1, 1000, 0)?;
        rperc_core::ensure_non_negative("angle_sigma", self.angle_sigma)?;
        for (name, v) in [
            ("max_distance", self.max_distance),
            ("sigma", self.sigma),
            ("huber", self.huber),
            ("tolerance", self.tolerance),
        ] {
            rperc_core::ensure_positive(name, v)?;
        }
        if !(self.covariance_scale.is_finite() && self.covariance_scale >= 1.0) {
            let s = self.covariance_scale;
            return Err(LaserError::invalid(
                "covariance_scale",
                format!("must be finite and >= 1, got {s}"),
            ));
        }
        let a = self.max_normal_angle;
        if !(a > 0.0 && a <= std::f64::consts::PI) {
            return Err(LaserError::invalid(
                "max_normal_angle",
                format!("must be in (0, pi], got {a}"),
            ));
        }
        if self.min_inliers < 3 {
            return Err(LaserError::invalid(
                "min_inliers",
                format!("must be >= 3, got {}", self.min_inliers),
            ));
        }
        // A count, not an allocation: nothing is sized by it.
        rperc_core::ensure_count(
            "independent_pairs",
            self.independent_pairs,
            1,
            usize::MAX,
            0,
        )?;
        Ok(())
    }

    /// The factor a scan's Hessian over `pairs` paired points is divided by:
    /// `covariance_scale`, times `pairs / independent_pairs` beyond that many.
    pub fn scale_for(&self, pairs: usize) -> f64 {
        let excess = pairs as f64 / self.independent_pairs as f64;
        self.covariance_scale * excess.max(1.0)
    }
}

/// A Gaussian prior on a pose: its mean and information (inverse covariance) over
/// `(x, y, theta)` in the world frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prior {
    /// The prior mean.
    pub mean: Pose2,
    /// Its information matrix (symmetric positive semi-definite).
    pub information: Matrix3<f64>,
}

/// What a match found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Match {
    /// The fused pose (the prior's mean when the match was refused).
    pub pose: Pose2,
    /// Its covariance: `(H_s / scale + Lambda)^-1` ([`IcpConfig::scale_for`]), or
    /// the prior's.
    pub covariance: Matrix3<f64>,
    /// The scan's information `H_s / scale` (zero when refused).
    pub information: Matrix3<f64>,
    /// Points paired with the map in the last iteration.
    pub inliers: usize,
    /// Points matched.
    pub points: usize,
    /// RMS distance of the paired points to their lines, m.
    pub rms: f64,
    /// Gauss-Newton iterations made.
    pub iterations: usize,
    /// Whether the scan was used (enough pairs, a finite solution).
    pub accepted: bool,
}

/// The normal equations of the scan's residuals at `pose`, their pair count and the
/// sum of the squared residuals of the pairs.
struct Normal {
    h: Matrix3<f64>,
    g: Vector3<f64>,
    pairs: usize,
    sum_r2: f64,
    /// The sum of the squared residuals in units of `sigma`: `sum r^2 sigma^2 / var`.
    sum_w2: f64,
    /// The line points that found no partner, each counted `sigma^2 / var` (1 with
    /// `angle_sigma` at 0): what the truncated cost charges the pairing distance.
    unpaired: f64,
}

fn scan_terms(scan: &ScanPoints, map: &MapIndex, pose: &Pose2, cfg: &IcpConfig) -> Normal {
    let (s, c) = pose.theta.sin_cos();
    let t = Vector2::new(pose.x, pose.y);
    let var0 = cfg.sigma * cfg.sigma;
    let (inv_var0, k0) = (1.0 / var0, cfg.huber * cfg.sigma);
    let min_cos = cfg.max_normal_angle.cos();
    let rotate = |v: &Vector2<f64>| Vector2::new(c * v.x - s * v.y, s * v.x + c * v.y);
    let mut out = Normal {
        h: Matrix3::zeros(),
        g: Vector3::zeros(),
        pairs: 0,
        sum_r2: 0.0,
        sum_w2: 0.0,
        unpaired: 0.0,
    };
    // A point's share of the constant variance, `sigma^2 / var` (1 when off).
    let share = |p: &Vector2<f64>| {
        let range_sd = p.norm() * cfg.angle_sigma;
        var0 / (var0 + range_sd * range_sd)
    };
    for (p, own) in scan.points.iter().zip(&scan.normals) {
        // Only points on a line of their own: a point without one (a corner, clutter,
        // a far reading between sparse beams) pairs as easily with the wall round the
        // corner as with its own, and that wall's line pulls the pose askew.
        let Some(own) = own else { continue };
        let rp = rotate(p);
        let q = rp + t;
        let nb = map
            .nearest(&q, cfg.max_distance)
            .filter(|nb| rotate(own).dot(&nb.normal) >= min_cos);
        let Some(nb) = nb else {
            out.unpaired += if cfg.angle_sigma > 0.0 { share(p) } else { 1.0 };
            continue;
        };
        let n = nb.normal;
        let r = n.dot(&(q - nb.point));
        // d(R p)/d theta = (-(R p)_y, (R p)_x).
        let j = Vector3::new(n.x, n.y, n.x * -rp.y + n.y * rp.x);
        let (inv_var, k, w2) = if cfg.angle_sigma > 0.0 {
            let range_sd = p.norm() * cfg.angle_sigma;
            let var = var0 + range_sd * range_sd;
            (1.0 / var, cfg.huber * var.sqrt(), r * r * var0 / var)
        } else {
            // The default: one variance for every point, no root per point, and the
            // squared residual as it is (the cost bit for bit as without the option).
            (inv_var0, k0, r * r)
        };
        let w = if r.abs() <= k { 1.0 } else { k / r.abs() };
        out.h += j * j.transpose() * (w * inv_var);
        out.g += j * (w * r * inv_var);
        out.pairs += 1;
        out.sum_r2 += r * r;
        out.sum_w2 += w2;
    }
    out
}

/// The scan's truncated least-squares cost at `pose`: the squared distances of the
/// paired points to their lines, every point on a line that found no partner charged
/// the pairing distance, each over its own variance (`sigma^2`, plus the beam's
/// angular noise at its range with `angle_sigma`), and over the covariance scale of
/// all the scan's line points ([`IcpConfig::scale_for`]). That scale is the same at
/// every pose, so the robust start's candidates compare fairly; it is at least ICP's
/// own (which counts only the pairs), so against a prior the cost leans on the prior
/// a little more than ICP does.
pub(crate) fn scan_cost(scan: &ScanPoints, map: &MapIndex, pose: &Pose2, cfg: &IcpConfig) -> f64 {
    truncated_cost(&scan_terms(scan, map, pose, cfg), scan, cfg)
}

/// [`scan_cost`] from the terms already summed at the pose.
fn truncated_cost(terms: &Normal, scan: &ScanPoints, cfg: &IcpConfig) -> f64 {
    let d2 = cfg.max_distance * cfg.max_distance;
    let scale = cfg.scale_for(scan.with_normals());
    (terms.sum_w2 + terms.unpaired * d2) / (cfg.sigma * cfg.sigma) / scale
}

pub(crate) fn prior_error(pose: &Pose2, prior: &Prior) -> Vector3<f64> {
    Vector3::new(
        pose.x - prior.mean.x,
        pose.y - prior.mean.y,
        wrap_angle(pose.theta - prior.mean.theta),
    )
}

/// Matches `scan` (laser frame) to `map` from `start`, fused with `prior`.
pub fn match_scan(
    scan: &ScanPoints,
    map: &MapIndex,
    start: Pose2,
    prior: &Prior,
    cfg: &IcpConfig,
) -> Result<Match> {
    let prior_cov = prior
        .information
        .try_inverse()
        .filter(|m| m.iter().all(|v| v.is_finite()));
    let refused = |inliers: usize, iterations: usize| -> Result<Match> {
        let cov = prior_cov
            .ok_or_else(|| LaserError::Numerical("the prior's information is singular".into()))?;
        Ok(Match {
            pose: prior.mean,
            covariance: cov,
            information: Matrix3::zeros(),
            inliers,
            points: scan.points.len(),
            rms: f64::NAN,
            iterations,
            accepted: false,
        })
    };
    let mut pose = start;
    let mut iterations = 0;
    // The pose of the iteration before, with its cost: see `returns_to`.
    let mut before: Option<(Pose2, f64)> = None;
    for _ in 0..cfg.iterations {
        iterations += 1;
        let terms = scan_terms(scan, map, &pose, cfg);
        if terms.pairs < cfg.min_inliers {
            return refused(terms.pairs, iterations);
        }
        let scale = cfg.scale_for(terms.pairs);
        let error = prior_error(&pose, prior);
        let h = terms.h / scale + prior.information;
        let g = terms.g / scale + prior.information * error;
        let Some(chol) = h.cholesky() else {
            return refused(terms.pairs, iterations);
        };
        let step = -chol.solve(&g);
        if !step.iter().all(|v| v.is_finite()) {
            return refused(terms.pairs, iterations);
        }
        let next = Pose2::new(
            pose.x + step.x,
            pose.y + step.y,
            wrap_angle(pose.theta + step.z),
        );
        if step.x.abs().max(step.y.abs()) < cfg.tolerance && step.z.abs() < cfg.tolerance {
            pose = next;
            break;
        }
        let cost = truncated_cost(&terms, scan, cfg) + error.dot(&(prior.information * error));
        // A limit cycle: the step goes back to the pose of the iteration before. A
        // point between two map points pairs with one at each pose, and each pairing
        // moves the pose towards the other (on the Freiburg campus 280 of 2,821 scans
        // alternated so to the iteration cap, 0.1-0.3 mm apart): the better of the two
        // poses is kept.
        if let Some((back, back_cost)) =
            before.filter(|(back, _)| within(back, &next, cfg.tolerance))
        {
            if back_cost < cost {
                pose = back;
            }
            break;
        }
        before = Some((pose, cost));
        pose = next;
    }
    finish(scan, map, pose, prior, cfg, iterations, refused)
}

/// Whether two poses differ by less than `tolerance` in each coordinate (m, rad).
fn within(a: &Pose2, b: &Pose2, tolerance: f64) -> bool {
    (a.x - b.x).abs().max((a.y - b.y).abs()) < tolerance
        && wrap_angle(a.theta - b.theta).abs() < tolerance
}

/// The covariance and statistics at the final pose.
fn finish(
    scan: &ScanPoints,
    map: &MapIndex,
    pose: Pose2,
    prior: &Prior,
    cfg: &IcpConfig,
    iterations: usize,
    refused: impl Fn(usize, usize) -> Result<Match>,
) -> Result<Match> {
    let terms = scan_terms(scan, map, &pose, cfg);
    if terms.pairs < cfg.min_inliers {
        return refused(terms.pairs, iterations);
    }
    let information = terms.h / cfg.scale_for(terms.pairs);
    let Some(covariance) = (information + prior.information).try_inverse() else {
        return refused(terms.pairs, iterations);
    };
    Ok(Match {
        pose,
        covariance: (covariance + covariance.transpose()) * 0.5,
        information,
        inliers: terms.pairs,
        points: scan.points.len(),
        rms: (terms.sum_r2 / terms.pairs as f64).sqrt(),
        iterations,
        accepted: true,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scan::{Beams, ScanConfig, scan_points};
    use crate::sim::{cluttered_room, ray_cast};

    /// A scan's points from ranges at evenly spaced `angles`, 20 m at most.
    fn points_from(ranges: &[f64], angles: &[f64]) -> ScanPoints {
        let beams = Beams {
            ranges,
            angle_min: angles[0],
            angle_increment: angles[1] - angles[0],
            max_range: 20.0,
        };
        scan_points(&beams, &ScanConfig::default()).unwrap()
    }

    /// With `angle_sigma`, a line point that finds no partner is charged the pairing
    /// distance over its own variance: against a map far from every point, the cost
    /// is `sum_i d^2 / (sigma^2 + (r_i angle_sigma)^2) / scale` over the scan's line
    /// points (closed form); with `angle_sigma` 0, `n d^2 / sigma^2 / scale`.
    #[test]
    fn an_unpaired_point_is_charged_over_its_own_variance() {
        let walls = cluttered_room(12.0, 8.0);
        let angles: Vec<f64> = (0..361)
            .map(|i| (-90.0 + 0.5 * i as f64).to_radians())
            .collect();
        let pose = Pose2::new(4.0, 3.0, 0.2);
        let scan = points_from(&ray_cast(&walls, &pose, &angles, 20.0), &angles);
        let far = nalgebra::Vector2::new(1e4, 1e4);
        let map = MapIndex::new(vec![far], vec![nalgebra::Vector2::new(1.0, 0.0)], 0.3).unwrap();
        for angle_sigma in [0.0, 0.01] {
            let cfg = IcpConfig {
                angle_sigma,
                ..Default::default()
            };
            let var0 = cfg.sigma * cfg.sigma;
            let d2 = cfg.max_distance * cfg.max_distance;
            let expected: f64 = scan
                .points
                .iter()
                .zip(&scan.normals)
                .filter(|(_, n)| n.is_some())
                .map(|(p, _)| d2 / (var0 + (p.norm() * angle_sigma).powi(2)))
                .sum::<f64>()
                / cfg.scale_for(scan.with_normals());
            let got = scan_cost(&scan, &map, &pose, &cfg);
            assert!(
                (got - expected).abs() < 1e-9 * expected,
                "{angle_sigma}: {got} vs {expected}"
            );
        }
    }

    /// Gauss-Newton as `match_scan` iterates it, without the limit-cycle stop: every
    /// iterate from `start`, `cap` steps or until a step is under the tolerance.
    fn plain_iterates(
        scan: &ScanPoints,
        map: &MapIndex,
        start: Pose2,
        prior: &Prior,
        cfg: &IcpConfig,
    ) -> Vec<Pose2> {
        let mut out = vec![start];
        for _ in 0..cfg.iterations {
            let pose = *out.last().unwrap();
            let terms = scan_terms(scan, map, &pose, cfg);
            let scale = cfg.scale_for(terms.pairs);
            let h = terms.h / scale + prior.information;
            let g = terms.g / scale + prior.information * prior_error(&pose, prior);
            let step = -h.cholesky().unwrap().solve(&g);
            out.push(Pose2::new(
                pose.x + step.x,
                pose.y + step.y,
                wrap_angle(pose.theta + step.z),
            ));
            if step.x.abs().max(step.y.abs()) < cfg.tolerance && step.z.abs() < cfg.tolerance {
                break;
            }
        }
        out
    }

    /// Against the plain iteration (the oracle): where it converges, `match_scan`
    /// returns its pose bit for bit; where it alternates between two poses to the
    /// cap, `match_scan` stops early at one of the two, the one of lower cost. A
    /// sparse map (one beam every 1.5 degrees) under noisy scans of 0.5-degree beams
    /// makes pairings flip between neighbours: 2 of the 60 starts cycle, and the
    /// test fails if none does.
    #[test]
    fn a_limit_cycle_stops_at_the_better_of_its_two_poses() {
        let walls = cluttered_room(12.0, 8.0);
        let beams_at = |count: usize| -> Vec<f64> {
            let step = 360.0 / count as f64;
            (0..count)
                .map(|i| (-180.0 + step * i as f64).to_radians())
                .collect()
        };
        // Ranges with 2 cm of deterministic noise (a hash of the beam and the pose).
        let scan_at = |pose: &Pose2, angles: &[f64]| {
            let mut ranges = ray_cast(&walls, pose, angles, 20.0);
            for (i, r) in ranges.iter_mut().enumerate() {
                let u = ((i as f64 * 12.9898 + pose.x * 78.233 + pose.y * 37.719).sin()
                    * 43758.5453)
                    .fract();
                *r += 0.04 * (u - 0.5);
            }
            points_from(&ranges, angles)
        };
        let from = Pose2::new(6.0, 4.0, 0.0);
        let map_scan = scan_at(&from, &beams_at(240));
        let map = MapIndex::new(
            map_scan
                .on_lines()
                .iter()
                .map(|p| from.rotation() * p + from.translation())
                .collect(),
            map_scan
                .normals
                .iter()
                .flatten()
                .map(|n| from.rotation() * n)
                .collect(),
            0.3,
        )
        .unwrap();
        let cfg = IcpConfig::default();
        let angles = beams_at(720);
        let (mut cycles, mut converged) = (0, 0);
        for k in 0..60 {
            let a = k as f64;
            let truth = Pose2::new(
                6.0 + 0.8 * (a * 0.71).sin(),
                4.0 + 0.6 * (a * 1.37).cos(),
                0.05 * (a * 2.3).sin(),
            );
            let scan = scan_at(&truth, &angles);
            let start = Pose2::new(truth.x + 0.05, truth.y - 0.04, truth.theta + 0.01);
            let prior = Prior {
                mean: start,
                information: Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, 10.0)),
            };
            let plain = plain_iterates(&scan, &map, start, &prior, &cfg);
            let got = match_scan(&scan, &map, start, &prior, &cfg).unwrap();
            let n = plain.len() - 1;
            if n < cfg.iterations {
                converged += 1;
                assert_eq!(got.pose, plain[n], "start {k}");
                assert_eq!(got.iterations, n, "start {k}");
                continue;
            }
            let cost = |p: &Pose2| {
                let e = prior_error(p, &prior);
                scan_cost(&scan, &map, p, &cfg) + e.dot(&(prior.information * e))
            };
            // The last two iterates of the cap, when the plain iteration has settled
            // on a two-pose cycle.
            let (a_pose, b_pose) = (plain[n], plain[n - 1]);
            if !within(&plain[n - 2], &a_pose, cfg.tolerance) {
                continue;
            }
            cycles += 1;
            assert!(got.iterations < cfg.iterations, "start {k}");
            let near = |p: &Pose2| within(p, &got.pose, 1e-3);
            assert!(near(&a_pose) || near(&b_pose), "start {k}: {:?}", got.pose);
            let other = if near(&a_pose) { b_pose } else { a_pose };
            assert!(cost(&got.pose) <= cost(&other) + 1e-9, "start {k}");
        }
        assert!(
            cycles > 0 && converged > 0,
            "{cycles} cycles, {converged} converged"
        );
    }

    /// The robust start's cost divides by the scale of all the scan's line points,
    /// the same at every pose: with the cap under them it is the uncapped cost times
    /// `independent_pairs / with_normals` (closed form), also at a pose where many
    /// points pair with nothing.
    #[test]
    fn the_cost_is_scaled_by_all_the_scans_line_points() {
        let walls = cluttered_room(12.0, 8.0);
        let angles: Vec<f64> = (0..361)
            .map(|i| (-90.0 + 0.5 * i as f64).to_radians())
            .collect();
        let points_at = |pose: &Pose2| {
            let ranges = ray_cast(&walls, pose, &angles, 20.0);
            points_from(&ranges, &angles)
        };
        let from = Pose2::new(4.0, 3.0, 0.2);
        let map_scan = points_at(&from);
        // The map's points and normals in the world frame, as the local map holds them.
        let (rotation, shift) = (from.rotation(), from.translation());
        let map = MapIndex::new(
            map_scan
                .on_lines()
                .iter()
                .map(|p| rotation * p + shift)
                .collect(),
            map_scan
                .normals
                .iter()
                .flatten()
                .map(|n| rotation * n)
                .collect(),
            0.3,
        )
        .unwrap();
        let truth = Pose2::new(4.3, 3.1, 0.25);
        let scan = points_at(&truth);
        let lines = scan.with_normals();
        let cap = lines / 3;
        let capped = IcpConfig {
            independent_pairs: cap,
            ..Default::default()
        };
        let free = IcpConfig {
            independent_pairs: usize::MAX,
            ..Default::default()
        };
        // At the truth every line point pairs; half a metre off, many do not.
        for pose in [truth, Pose2::new(4.8, 3.3, 0.3)] {
            let expected = scan_cost(&scan, &map, &pose, &free) * cap as f64 / lines as f64;
            let got = scan_cost(&scan, &map, &pose, &capped);
            assert!(
                (got - expected).abs() <= 1e-12 * expected.abs(),
                "{got} against {expected}"
            );
        }
    }
}
