//! The front end: each scan matched against a local map of recent key scans, with
//! the odometry step as the prior (see [`crate::icp`]). It gives every scan a pose
//! and the relative motion from the previous scan with its covariance: the chain of
//! the pose graph, and the motion a filter can predict with.

use std::collections::VecDeque;

use nalgebra::{Matrix3, Vector2};
use rperc_core::Pose2;

use crate::error::{LaserError, Result};
use crate::grid::MapIndex;
use crate::icp::{IcpConfig, Match, Prior};
use crate::odometry::Step;
use crate::scan::ScanPoints;
use crate::start::{StartSearch, match_robustly};

/// Settings of the local map.
#[derive(
    Debug, Clone, Copy, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema,
)]
#[serde(default, deny_unknown_fields)]
pub struct LocalMapConfig {
    /// A scan becomes a key scan when the robot has moved this far from the last
    /// one, m (> 0).
    pub key_distance: f64,
    /// ... or turned this much, rad (> 0).
    pub key_angle: f64,
    /// The local map holds the points of this many latest key scans (>= 1).
    pub key_scans: usize,
    /// Cell of the map's grid, m (> 0; at least ICP's pairing distance).
    pub cell: f64,
    /// Where the odometry prior's three-sigma reach (its position deviation plus its
    /// heading deviation at the scan's median range) exceeds this, m (> 0), ICP also
    /// starts from the best poses of a correlative search over that window (a robust
    /// start: ICP's basin is about its pairing distance).
    pub search_reach: f64,
    /// The search's translation step, m (> 0).
    pub search_step: f64,
    /// ICP starts from this many of the search's best poses (1..=64).
    pub search_starts: usize,
    /// The search runs only when ICP from the prior's mean was refused, paired
    /// less than this share of the scan's points on lines (in [0, 1]; 1 searches
    /// wherever the prior is loose), ...
    pub search_share: f64,
    /// ... or left its pairs this far from their lines, RMS, m (> 0; at least ICP's
    /// `max_distance`: never for this reason). A match that paired most of the scan
    /// but fits it worse than nearly every match of its log (the 99th percentile is
    /// 6-10 cm on the corpus) may have settled in a wrong basin. Default 0.08 m,
    /// chosen by leave-one-log-out over the nine corpus logs on seeds 10-19 (see
    /// `docs/decisions.md`); without it one odometry seed in ten (seed 5) lost the
    /// Freiburg campus.
    pub search_rms: f64,
}

impl Default for LocalMapConfig {
    fn default() -> Self {
        Self {
            key_distance: 0.3,
            key_angle: 10f64.to_radians(),
            key_scans: 20,
            cell: 0.3,
            search_reach: 0.3,
            search_step: 0.1,
            search_starts: 4,
            search_share: 0.5,
            search_rms: 0.08,
        }
    }
}

impl LocalMapConfig {
    /// Refuses bad values with the parameter's name.
    pub fn validate(&self, icp: &IcpConfig) -> Result<()> {
        for (name, v) in [
            ("key_distance", self.key_distance),
            ("key_angle", self.key_angle),
            ("cell", self.cell),
            ("search_reach", self.search_reach),
            ("search_step", self.search_step),
            ("search_rms", self.search_rms),
        ] {
            rperc_core::ensure_positive(name, v)?;
        }
        // Counts of work, not of memory: nothing is allocated per unit.
        rperc_core::ensure_count("key_scans", self.key_scans, 1, 10_000, 0)?;
        if !(0.0..=1.0).contains(&self.search_share) {
            let v = self.search_share;
            return Err(LaserError::invalid(
                "search_share",
                format!("must be in [0, 1], got {v}"),
            ));
        }
        rperc_core::ensure_count("search_starts", self.search_starts, 1, 64, 0)?;
        if self.cell < icp.max_distance {
            return Err(LaserError::invalid(
                "cell",
                format!(
                    "must be at least ICP's max_distance ({}), got {}",
                    icp.max_distance, self.cell
                ),
            ));
        }
        Ok(())
    }
}

/// A key scan: its index, its pose when it was taken, and its points with normals
/// in its own frame.
#[derive(Debug, Clone)]
pub struct KeyScan {
    /// Index of the scan in the log.
    pub index: usize,
    /// Its pose as the front end estimated it.
    pub pose: Pose2,
    /// Points on lines, laser frame.
    pub points: Vec<Vector2<f64>>,
    /// Their normals, laser frame.
    pub normals: Vec<Vector2<f64>>,
}

impl KeyScan {
    /// Scan `index` at `pose`: its points that lie on lines, with their normals.
    pub fn new(index: usize, pose: Pose2, scan: &ScanPoints) -> Self {
        let (points, normals) = scan
            .points
            .iter()
            .zip(&scan.normals)
            .filter_map(|(p, n)| n.map(|n| (*p, n)))
            .unzip();
        KeyScan {
            index,
            pose,
            points,
            normals,
        }
    }
}

/// One scan's result.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tracked {
    /// The scan's pose.
    pub pose: Pose2,
    /// The motion from the previous scan's pose, in that pose's frame.
    pub motion: Pose2,
    /// Its covariance.
    pub motion_covariance: Matrix3<f64>,
    /// The match (its `accepted` says whether the scan was used).
    pub matched: Match,
    /// Whether the scan became a key scan.
    pub key: bool,
}

/// The front end's state: the latest pose and the key scans of the local map.
#[derive(Debug, Clone)]
pub struct FrontEnd {
    icp: IcpConfig,
    local: LocalMapConfig,
    pose: Pose2,
    keys: VecDeque<KeyScan>,
    map: MapIndex,
}

/// Points of key scans moved to the world by their poses, indexed.
pub fn world_map(
    keys: impl IntoIterator<
        Item = (
            Pose2,
            impl AsRef<[Vector2<f64>]>,
            impl AsRef<[Vector2<f64>]>,
        ),
    >,
    cell: f64,
) -> Result<MapIndex> {
    let (mut pts, mut nrm) = (Vec::new(), Vec::new());
    for (pose, points, normals) in keys {
        let r = pose.rotation();
        let t = pose.translation();
        pts.extend(points.as_ref().iter().map(|p| r * p + t));
        nrm.extend(normals.as_ref().iter().map(|n| r * n));
    }
    MapIndex::new(pts, nrm, cell)
}

impl FrontEnd {
    /// A front end whose first scan is at `start`.
    pub fn new(start: Pose2, icp: IcpConfig, local: LocalMapConfig) -> Result<Self> {
        icp.validate()?;
        local.validate(&icp)?;
        Ok(FrontEnd {
            icp,
            local,
            pose: start,
            keys: VecDeque::new(),
            map: MapIndex::default(),
        })
    }

    /// The latest pose.
    pub fn pose(&self) -> Pose2 {
        self.pose
    }

    /// The first scan: it starts the map where the front end was placed.
    pub fn first(&mut self, index: usize, scan: &ScanPoints) -> Result<()> {
        self.add_key(KeyScan::new(index, self.pose, scan))
    }

    /// Tracks scan `index` after the odometry `step` from the previous scan.
    pub fn track(&mut self, index: usize, scan: &ScanPoints, step: &Step) -> Result<Tracked> {
        let prior = prior_after(&self.pose, step)?;
        let search = StartSearch {
            reach: self.local.search_reach,
            sigmas: 3.0,
            step: self.local.search_step,
            starts: self.local.search_starts,
            share: self.local.search_share,
            rms: self.local.search_rms,
        };
        let matched = match_robustly(scan, &self.map, &prior, &self.icp, &search)?;
        let (motion, motion_covariance) = relative(&self.pose, &matched.pose, &matched.covariance);
        self.pose = matched.pose;
        let key = self.is_key(&matched.pose);
        if key {
            self.add_key(KeyScan::new(index, matched.pose, scan))?;
        }
        Ok(Tracked {
            pose: matched.pose,
            motion,
            motion_covariance,
            matched,
            key,
        })
    }

    /// Moves the front end after the back end corrected the map: the latest pose and
    /// every key scan whose new pose `corrected(index)` gives.
    pub fn relocate(
        &mut self,
        pose: Pose2,
        corrected: impl Fn(usize) -> Option<Pose2>,
    ) -> Result<()> {
        self.pose = pose;
        for k in self.keys.iter_mut() {
            if let Some(p) = corrected(k.index) {
                k.pose = p;
            }
        }
        self.map = world_map(
            self.keys.iter().map(|k| (k.pose, &k.points, &k.normals)),
            self.local.cell,
        )?;
        Ok(())
    }

    fn is_key(&self, pose: &Pose2) -> bool {
        let Some(last) = self.keys.back() else {
            return true;
        };
        let d = last.pose.between(pose);
        d.translation().norm() >= self.local.key_distance || d.theta.abs() >= self.local.key_angle
    }

    fn add_key(&mut self, key: KeyScan) -> Result<()> {
        self.keys.push_back(key);
        while self.keys.len() > self.local.key_scans {
            self.keys.pop_front();
        }
        self.map = world_map(
            self.keys.iter().map(|k| (k.pose, &k.points, &k.normals)),
            self.local.cell,
        )?;
        Ok(())
    }
}

/// The prior of the next pose: the odometry step from `pose`, its covariance moved
/// to the world frame (`J Sigma J^T`, `J` the composition's Jacobian in the step).
pub fn prior_after(pose: &Pose2, step: &Step) -> Result<Prior> {
    let (mean, _, j) = pose.compose_with_jacobians(&step.motion);
    let cov = j * step.covariance * j.transpose();
    let information = cov
        .try_inverse()
        .filter(|m| m.iter().all(|v| v.is_finite()))
        .ok_or_else(|| LaserError::Numerical("an odometry step's covariance is singular".into()))?;
    Ok(Prior {
        mean,
        information: (information + information.transpose()) * 0.5,
    })
}

/// The motion from `from` to `to` in `from`'s frame, and its covariance when `to`'s
/// world covariance is `cov` and `from` is held fixed.
pub fn relative(from: &Pose2, to: &Pose2, cov: &Matrix3<f64>) -> (Pose2, Matrix3<f64>) {
    let (motion, _, j) = from.between_with_jacobians(to);
    let c = j * cov * j.transpose();
    (motion, (c + c.transpose()) * 0.5)
}
