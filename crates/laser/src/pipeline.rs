//! The whole run over a log: odometry steps, the front end at every scan, a pose
//! graph over the key scans with the front end's chain and verified loop closures,
//! and every scan's final pose with its covariance.
//!
//! The causal path is what the run knew at each scan: the front end's pose, moved
//! whenever a confirmed closure re-optimised the graph. The final path is the graph's
//! optimum over all closures, each scan placed from its key scan by the front end's
//! motion since; its covariance is the key scan's marginal (Takahashi) plus that
//! motion's.

use nalgebra::{Matrix3, Vector2};
use rperc_core::Pose2;
use slam::motion::Unicycle;

use crate::error::{LaserError, Result};
use crate::frontend::{FrontEnd, KeyScan, LocalMapConfig, world_map};
use crate::graph::{Edge, PoseGraph};
use crate::icp::IcpConfig;
use crate::loops::{Closure, LoopConfig, agree, close_loop};
use crate::odometry::{Step, steps};
use crate::scan::{BeamDirections, Beams, ScanConfig, ScanPoints, check_beams, scan_points_with};
use crate::walls::{Extractor, WallConfig, WallMap};

/// Every setting of a run.
#[derive(
    Debug, Clone, Copy, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema,
)]
#[serde(default, deny_unknown_fields)]
pub struct LaserConfig {
    /// Scans to points.
    pub scan: ScanConfig,
    /// Scan matching.
    pub icp: IcpConfig,
    /// The front end's local map.
    pub local_map: LocalMapConfig,
    /// Loop closures.
    pub loops: LoopConfig,
    /// Walls as landmarks of the pose graph.
    pub walls: WallConfig,
    /// The odometry's control noise (the same model as the EKF's motion).
    pub motion: Unicycle,
    /// The first scan's pose.
    pub initial_pose: [f64; 3],
    /// Gauss-Newton iterations of the pose graph at most (>= 1).
    pub graph_iterations: usize,
    /// ... stopped when a step moves no pose more than this, m or rad (> 0).
    pub graph_tolerance: f64,
    /// The front end's motion covariances are multiplied by this in the pose graph's
    /// chain (>= 1): consecutive matches against one local map share its errors, so
    /// the chain drifts more than independent steps would. Chosen for consistency by
    /// leave-one-log-out over the corpus logs on seeds 10-12 (never the reported
    /// seeds 0-2): `benchmarks/laser_chain_inflation.py` prints each log's choice.
    pub chain_inflation: f64,
}

impl Default for LaserConfig {
    fn default() -> Self {
        Self {
            scan: ScanConfig::default(),
            icp: IcpConfig::default(),
            local_map: LocalMapConfig::default(),
            loops: LoopConfig::default(),
            walls: WallConfig::default(),
            motion: Unicycle::default(),
            initial_pose: [0.0; 3],
            graph_iterations: 10,
            graph_tolerance: 1e-5,
            chain_inflation: 1.5,
        }
    }
}

impl LaserConfig {
    /// Refuses bad values with the parameter's name.
    pub fn validate(&self) -> Result<()> {
        self.scan.validate()?;
        self.icp.validate()?;
        self.local_map.validate(&self.icp)?;
        self.loops.validate()?;
        self.walls.validate()?;
        self.motion.validate()?;
        rperc_core::ensure_finite("initial_pose", &self.initial_pose)?;
        // A count of work, not of memory: nothing is allocated per iteration.
        rperc_core::ensure_count("graph_iterations", self.graph_iterations, 1, 1000, 0)?;
        if !(self.chain_inflation.is_finite() && (1.0..=1e6).contains(&self.chain_inflation)) {
            let c = self.chain_inflation;
            return Err(LaserError::invalid(
                "chain_inflation",
                format!("must be in [1, 1e6], got {c}"),
            ));
        }
        rperc_core::ensure_positive("graph_tolerance", self.graph_tolerance)?;
        Ok(())
    }
}

/// A log's scans: `width` readings per row of `ranges` (row-major, NaN-padded),
/// `counts[s]` of them real, with each scan's beam geometry and maximum range.
#[derive(Debug, Clone, Copy)]
pub struct ScanLog<'a> {
    /// `S x width` readings, m.
    pub ranges: &'a [f64],
    /// Readings per row.
    pub width: usize,
    /// Real readings per scan.
    pub counts: &'a [usize],
    /// First beam's angle per scan, rad.
    pub angle_min: &'a [f64],
    /// Angle between beams per scan, rad.
    pub angle_increment: &'a [f64],
    /// Maximum range per scan, m.
    pub max_range: &'a [f64],
}

impl ScanLog<'_> {
    fn len(&self) -> usize {
        self.counts.len()
    }

    fn check(&self) -> Result<()> {
        let s = self.len();
        if self.ranges.len() != s * self.width
            || [
                self.angle_min.len(),
                self.angle_increment.len(),
                self.max_range.len(),
            ]
            .iter()
            .any(|&n| n != s)
        {
            return Err(LaserError::dimension(format!(
                "{s} scans of {} readings: the arrays disagree",
                self.width
            )));
        }
        for (k, &c) in self.counts.iter().enumerate() {
            check_beams(&self.ranges[k * self.width..(k + 1) * self.width], c, k)?;
        }
        Ok(())
    }

    fn points(&self, k: usize, cfg: &ScanConfig, cache: &mut BeamDirections) -> Result<ScanPoints> {
        let row = &self.ranges[k * self.width..k * self.width + self.counts[k]];
        let beams = Beams {
            ranges: row,
            angle_min: self.angle_min[k],
            angle_increment: self.angle_increment[k],
            max_range: self.max_range[k],
        };
        scan_points_with(&beams, cfg, cache).map_err(|e| LaserError::AtScan {
            index: k,
            source: Box::new(e),
        })
    }
}

/// What a run gives.
#[derive(Debug, Clone, Default)]
pub struct LaserRun {
    /// Every scan's final pose.
    pub pose: Vec<Pose2>,
    /// Its covariance.
    pub covariance: Vec<Matrix3<f64>>,
    /// Every scan's pose as the run knew it then (the online path).
    pub causal_pose: Vec<Pose2>,
    /// Whether each scan's match was used (the first scan's: true).
    pub matched: Vec<bool>,
    /// Points of each scan paired with the local map (0 for the first).
    pub inliers: Vec<usize>,
    /// Their RMS distance to the map's lines, m (NaN where the match was refused).
    pub rms: Vec<f64>,
    /// The key scans' indices.
    pub keys: Vec<usize>,
    /// Closures in the final graph: (earlier key scan, later key scan).
    pub closures: Vec<(usize, usize)>,
    /// Their squared errors at the final optimum (by their own information).
    pub closure_chi2: Vec<f64>,
    /// Closure matches refused by verification or joint consistency, or removed for
    /// disagreeing with the graph.
    pub closures_rejected: usize,
    /// Closure attempts made.
    pub closure_attempts: usize,
    /// Refusals by reason: too few pairs, too large a residual, degenerate, not
    /// confirmed by the next attempt, removed for disagreeing with the graph.
    pub rejections: [usize; 5],
    /// The wall landmarks of the final graph, world segments `(x0, y0, x1, y1)` over
    /// the extent the key scans saw.
    pub walls: Vec<[f64; 4]>,
    /// Wall sightings in the final graph.
    pub wall_factors: usize,
    /// Wall sightings removed for disagreeing with the optimised graph.
    pub wall_factors_pruned: usize,
}

/// Wall sightings pruned at most after an optimisation (each removal is followed by
/// another optimisation).
const PRUNE_ROUNDS: usize = 5;

/// A key scan of the graph.
struct Key {
    scan: usize,
    node: usize,
    path: f64,
    shape: KeyScan,
}

/// A closure waiting for a second one to confirm it.
struct Pending {
    key: usize,
    candidate: usize,
    estimate: Pose2,
    closure: Closure,
}

/// The motion since the last key scan, accumulated.
#[derive(Clone, Copy)]
struct SinceKey {
    node: usize,
    motion: Pose2,
    covariance: Matrix3<f64>,
}

impl SinceKey {
    fn at(node: usize) -> Self {
        SinceKey {
            node,
            motion: Pose2::identity(),
            covariance: Matrix3::zeros(),
        }
    }

    fn then(&self, motion: &Pose2, cov: &Matrix3<f64>) -> Self {
        let (m, j1, j2) = self.motion.compose_with_jacobians(motion);
        let c = j1 * self.covariance * j1.transpose() + j2 * cov * j2.transpose();
        SinceKey {
            node: self.node,
            motion: m,
            covariance: (c + c.transpose()) * 0.5,
        }
    }
}

struct Run<'a> {
    cfg: &'a LaserConfig,
    log: &'a ScanLog<'a>,
    walls: WallMap,
    extractor: Extractor,
    front: FrontEnd,
    graph: PoseGraph,
    keys: Vec<Key>,
    /// The chain's steps between consecutive keys and their covariances.
    chain: Vec<(Pose2, Matrix3<f64>)>,
    since: SinceKey,
    path: f64,
    pending: Option<Pending>,
    /// The key index before which no closure is tried (after a confirmed pair).
    quiet_until: usize,
    out: LaserRun,
    placed: Vec<SinceKey>,
}

/// Runs the pipeline over `log` with odometry `controls` `(t, v, omega)` and the
/// scans' `times`.
pub fn run<'a>(
    log: &'a ScanLog<'a>,
    controls: &[[f64; 3]],
    times: &[f64],
    cfg: &LaserConfig,
) -> Result<LaserRun> {
    cfg.validate()?;
    log.check()?;
    if times.len() != log.len() || log.len() == 0 {
        return Err(LaserError::dimension(format!(
            "{} scan times for {} scans",
            times.len(),
            log.len()
        )));
    }
    rperc_core::check_allocation("scans", log.len() as u128, 512)?;
    let odometry = steps(controls, times, &cfg.motion)?;
    let start = Pose2::new(
        cfg.initial_pose[0],
        cfg.initial_pose[1],
        cfg.initial_pose[2],
    );
    let mut run = Run {
        cfg,
        log,
        walls: WallMap::default(),
        extractor: Extractor::new(cfg.walls),
        front: FrontEnd::new(start, cfg.icp, cfg.local_map)?,
        // The start is known: 0.1 mm and 0.1 mrad, loose enough for the factorisation.
        graph: PoseGraph::new(start, Matrix3::identity() * 1e8),
        keys: Vec::new(),
        chain: Vec::new(),
        since: SinceKey::at(0),
        path: 0.0,
        pending: None,
        quiet_until: 0,
        out: LaserRun::default(),
        placed: Vec::with_capacity(log.len()),
    };
    let mut directions = BeamDirections::default();
    let first = log.points(0, &cfg.scan, &mut directions)?;
    run.front.first(0, &first)?;
    run.keys.push(Key {
        scan: 0,
        node: 0,
        path: 0.0,
        shape: KeyScan::new(0, start, &first),
    });
    run.map_walls(0, 0)?;
    run.record(start, None);
    for k in 1..log.len() {
        rperc_core::interrupt::checkpoint()?;
        let scan = log.points(k, &cfg.scan, &mut directions)?;
        run.step(k, &scan, &odometry[k - 1])
            .map_err(|e| LaserError::AtScan {
                index: k,
                source: Box::new(e),
            })?;
    }
    run.finish()
}

impl Run<'_> {
    fn record(&mut self, pose: Pose2, matched: Option<&crate::icp::Match>) {
        self.out.causal_pose.push(pose);
        self.out.matched.push(matched.is_none_or(|m| m.accepted));
        self.out.inliers.push(matched.map_or(0, |m| m.inliers));
        self.out.rms.push(matched.map_or(f64::NAN, |m| m.rms));
        self.placed.push(self.since);
    }

    fn step(&mut self, k: usize, scan: &ScanPoints, odo: &Step) -> Result<()> {
        let tracked = self.front.track(k, scan, odo)?;
        self.path += tracked.motion.translation().norm();
        let cov = tracked.motion_covariance * self.cfg.chain_inflation;
        self.since = self.since.then(&tracked.motion, &cov);
        if tracked.key {
            self.add_key(k, tracked.pose, scan)?;
        }
        self.record(self.front.pose(), Some(&tracked.matched));
        Ok(())
    }

    fn add_key(&mut self, k: usize, pose: Pose2, scan: &ScanPoints) -> Result<()> {
        let node = self.graph.add_pose(pose);
        let information =
            self.since.covariance.try_inverse().ok_or_else(|| {
                LaserError::Numerical("a key step's covariance is singular".into())
            })?;
        let edge = Edge {
            from: self.since.node,
            to: node,
            measurement: self.since.motion,
            information,
            robust: None,
        };
        self.graph.add_edge(edge)?;
        self.chain.push((self.since.motion, self.since.covariance));
        self.since = SinceKey::at(node);
        self.keys.push(Key {
            scan: k,
            node,
            path: self.path,
            shape: KeyScan::new(k, pose, scan),
        });
        self.map_walls(k, node)?;
        let key = self.keys.len() - 1;
        let due = key >= self.quiet_until
            && (key.is_multiple_of(self.cfg.loops.every_keys) || self.pending.is_some());
        if self.cfg.loops.enabled && due {
            self.try_closure(scan)?;
        }
        Ok(())
    }

    /// Pairs key scan `k`'s walls (graph node `node`) with the wall map.
    fn map_walls(&mut self, k: usize, node: usize) -> Result<()> {
        if !self.cfg.walls.enabled {
            return Ok(());
        }
        let log = self.log;
        let row = &log.ranges[k * log.width..k * log.width + log.counts[k]];
        let max_range = log.max_range[k] - self.cfg.scan.max_range_margin;
        let sightings = self.extractor.sightings(
            row,
            log.angle_min[k],
            log.angle_increment[k],
            (self.cfg.scan.min_range, max_range),
        )?;
        self.walls.observe(
            node,
            self.path,
            &sightings,
            &mut self.graph,
            &self.cfg.walls,
        )
    }

    /// The covariance of the latest key's pose relative to each earlier key, from the
    /// chain alone (the key steps composed backwards, in world axes): an upper bound,
    /// since closures only shrink it, of how far the graph can have drifted since.
    fn relative_covariances(&self) -> Vec<Matrix3<f64>> {
        let n = self.keys.len();
        let mut out = vec![Matrix3::zeros(); n];
        let (mut rel, mut cov) = (Pose2::identity(), Matrix3::zeros());
        for k in (0..n - 1).rev() {
            let (z, z_cov) = self.chain[k];
            let (r, j1, j2) = z.compose_with_jacobians(&rel);
            cov = j1 * z_cov * j1.transpose() + j2 * cov * j2.transpose();
            rel = r;
            // Into world axes with the earlier key's heading.
            let (sin, cos) = self.graph.poses[self.keys[k].node].theta.sin_cos();
            let rot = Matrix3::new(cos, -sin, 0.0, sin, cos, 0.0, 0.0, 0.0, 1.0);
            out[k] = rot * cov * rot.transpose();
        }
        out
    }

    /// The earlier key most likely to overlap the latest one: far enough back along
    /// the path, and within `overlap` of it up to `sigmas` standard deviations of the
    /// chain's drift since; with the covariance that sets the search window.
    fn candidate(&self) -> Option<(usize, Matrix3<f64>)> {
        let me = self.keys.last()?;
        let here = self.graph.poses[me.node].translation();
        let cfg = &self.cfg.loops;
        let covs = self.relative_covariances();
        self.keys
            .iter()
            .enumerate()
            .filter(|(_, c)| me.path - c.path > cfg.min_path)
            .filter_map(|(i, c)| {
                let d = here - self.graph.poses[c.node].translation();
                let dist = d.norm();
                let u = if dist > 1e-9 { d / dist } else { Vector2::x() };
                let sd = (u.transpose() * covs[i].fixed_view::<2, 2>(0, 0) * u)[(0, 0)]
                    .max(0.0)
                    .sqrt();
                let gap = (dist - cfg.overlap).max(0.0);
                (gap <= cfg.sigmas * sd).then_some((i, gap / sd.max(1e-9), dist, covs[i]))
            })
            // The least surprising place first; among places that may overlap (no
            // gap), the nearest.
            .min_by(|a, b| a.1.total_cmp(&b.1).then(a.2.total_cmp(&b.2)))
            .map(|(i, _, _, cov)| (i, cov))
    }

    fn try_closure(&mut self, scan: &ScanPoints) -> Result<()> {
        let Some((c, relative)) = self.candidate() else {
            self.pending = None;
            return Ok(());
        };
        let window = self.cfg.loops.window(&relative);
        self.out.closure_attempts += 1;
        let w = self.cfg.loops.submap_keys;
        let around = &self.keys[c.saturating_sub(w)..(c + w + 1).min(self.keys.len())];
        let submap = world_map(
            around
                .iter()
                .map(|k| (self.graph.poses[k.node], &k.shape.points, &k.shape.normals)),
            self.cfg.local_map.cell,
        )?;
        let me = self.keys.len() - 1;
        let estimate = self.graph.poses[self.keys[me].node];
        match close_loop(
            scan,
            &submap,
            &estimate,
            &window,
            &self.cfg.icp,
            &self.cfg.loops,
        )? {
            Err(why) => {
                self.out.closures_rejected += 1;
                self.out.rejections[why as usize] += 1;
                self.pending = None;
            }
            Ok(closure) => self.confirm(Pending {
                key: me,
                candidate: c,
                estimate,
                closure,
            })?,
        }
        Ok(())
    }

    /// A closure joins the graph once a second one agrees with it.
    fn confirm(&mut self, new: Pending) -> Result<()> {
        let Some(old) = self.pending.take() else {
            self.pending = Some(new);
            return Ok(());
        };
        if !agree(
            (&old.estimate, &old.closure),
            (&new.estimate, &new.closure),
            &self.cfg.loops,
        ) {
            self.out.closures_rejected += 1;
            self.out.rejections[3] += 1;
            self.pending = Some(new);
            return Ok(());
        }
        for p in [old, new] {
            self.add_closure(&p)?;
        }
        self.settle()?;
        self.quiet_until = self.keys.len() + self.cfg.loops.cooldown_keys;
        let poses = &self.graph.poses;
        let by_scan: std::collections::HashMap<usize, Pose2> =
            self.keys.iter().map(|k| (k.scan, poses[k.node])).collect();
        let latest = poses[self.keys[self.keys.len() - 1].node];
        self.front.relocate(latest, |s| by_scan.get(&s).copied())
    }

    fn add_closure(&mut self, p: &Pending) -> Result<()> {
        let (from, to) = (self.keys[p.candidate].node, self.keys[p.key].node);
        // The closure places the key scan in the world with the submap's poses as
        // they were: as a measurement from the candidate's pose.
        let anchor = self.graph.poses[from];
        let (z, information) = p.closure.relative_to(&anchor, self.cfg.loops.inflation)?;
        self.graph.add_edge(Edge {
            from,
            to,
            measurement: z,
            information,
            robust: None,
        })?;
        Ok(())
    }

    /// Optimises the graph, removing the closures that disagree with it (see
    /// [`PoseGraph::optimize_consistent`]; the chain's edges join consecutive keys).
    fn settle(&mut self) -> Result<()> {
        let cfg = self.cfg;
        let removed = self.graph.optimize_consistent(
            cfg.graph_iterations,
            cfg.graph_tolerance,
            cfg.loops.max_chi2,
            |e| e.to != e.from + 1,
        )?;
        self.out.closures_rejected += removed.len();
        self.out.rejections[4] += removed.len();
        if self.cfg.walls.enabled {
            let gate = rperc_core::chi2_gate(2, cfg.walls.gate)?;
            for _ in 0..PRUNE_ROUNDS {
                if !self.graph.prune_wall_factor(gate)? {
                    break;
                }
                self.out.wall_factors_pruned += 1;
                self.graph
                    .optimize(cfg.graph_iterations, cfg.graph_tolerance)?;
            }
            // The walls' lines, extents and cells follow the optimised poses.
            self.walls.refresh(&self.graph);
        }
        Ok(())
    }

    fn finish(mut self) -> Result<LaserRun> {
        self.settle()?;
        let marginals = self.graph.marginals()?;
        for placed in &self.placed {
            let (pose, j1, j2) =
                self.graph.poses[placed.node].compose_with_jacobians(&placed.motion);
            let c = j1 * marginals[placed.node] * j1.transpose()
                + j2 * placed.covariance * j2.transpose();
            self.out.pose.push(pose);
            self.out.covariance.push((c + c.transpose()) * 0.5);
        }
        self.out.keys = self.keys.iter().map(|k| k.scan).collect();
        let closures: Vec<usize> = (0..self.graph.edges.len())
            .filter(|&k| self.graph.edges[k].to != self.graph.edges[k].from + 1)
            .collect();
        self.out.closures = closures
            .iter()
            .map(|&k| {
                (
                    self.keys[self.graph.edges[k].from].scan,
                    self.keys[self.graph.edges[k].to].scan,
                )
            })
            .collect();
        self.out.closure_chi2 = closures.iter().map(|&k| self.graph.chi2(k)).collect();
        self.out.walls = self.walls.segments(&self.graph);
        self.out.wall_factors = self.graph.wall_factors.len();
        Ok(self.out)
    }
}
