//! Walls as landmarks of the pose graph: the key scans' walls (seed 000 section 2.1,
//! `linesimp`'s split-and-merge extraction), paired with the walls mapped so far.
//!
//! A wall seen again after the robot has moved on ties the key scans that saw it, as
//! a loop closure does, but also along a corridor where no closure is tried and
//! across places that overlap too little for a scan match. The front end already
//! uses every scan's points, so a sighting becomes a factor only after
//! `every_path` metres of path since the wall's last one: within that reach the ICP
//! chain holds the same information, and counting it twice would make the graph
//! over-confident. A wall enters the graph only with its second factor: alone, one
//! sighting just places the wall and tells nothing about the poses.

use std::collections::HashMap;

use linesimp::{LineExtractor, ScanParams, WallSegment};
use nalgebra::{Matrix2, Point2, Vector2};
use rperc_core::Pose2;
use slam::wall::{straightness_covariance, wall_to_world};

use crate::error::{LaserError, Result};
use crate::graph::PoseGraph;
use crate::wall_factor::{WallFactor, innovation_covariance, linearise_wall};

/// Settings of the wall landmarks.
#[derive(
    Debug, Clone, Copy, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema,
)]
#[serde(default, deny_unknown_fields)]
pub struct WallConfig {
    /// Whether key scans' walls become landmarks of the pose graph. Off by default:
    /// on the corpus logs they win on some and lose on others, raise fhw's robot
    /// NEES, and cost speed (`rperc bench laser --variants laser,laser-walls`; see
    /// `straightness`).
    pub enabled: bool,
    /// Range noise of the extraction, m (>= 0).
    pub sigma_range: f64,
    /// The extraction splits where a reading is farther than this from the chord, m
    /// (> 0).
    pub split_epsilon: f64,
    /// Shorter walls are not used, m (> 0): a short segment is a door jamb or a
    /// piece of furniture as often as a wall.
    pub min_length: f64,
    /// Readings farther than this make no wall, m (> 0): far away the beams are
    /// spread too thin for a line fit to tell a facade from the objects before it
    /// (without it, freiburg-campus's robot NEES mean was 22 on seeds 10-12).
    pub max_range: f64,
    /// Each end of a seen wall lies off the ideal straight wall by this much, m
    /// (>= 0; `slam::wall::straightness_covariance`): added to the fit's covariance,
    /// which shrinks with the number of readings and would claim millimetres.
    /// With `every_path`, `min_length` and `max_range`, chosen on the nine corpus
    /// logs, seeds 10-12 (never the reported 0-2), among 0.05-0.4 m, 3-20 m, 1-2 m
    /// and 8 m to unlimited: the lowest geometric-mean ATE among the settings whose
    /// NEES mean is at most 6 on six logs. Left out in turn, each log's choice was
    /// this one or (0.4 m, 20 m); held out, the walls won on four logs and lost on
    /// four, which is why they are off by default.
    pub straightness: f64,
    /// A sighting pairs with a wall inside this chi-square confidence (2 dof, in
    /// (0, 1)) ...
    pub gate: f64,
    /// ... with the key pose's error relative to the wall taken as this offset, m,
    /// (> 0) ...
    pub drift_offset: f64,
    /// ... and this angle, rad (> 0), ...
    pub drift_angle: f64,
    /// ... and when the gap between the seen segment and the wall's extent along the
    /// line is at most this, m (0 to 5, the lookup grid's cell).
    pub max_gap: f64,
    /// A sighting becomes a factor after this much path since the wall's last one, m
    /// (> 0).
    pub every_path: f64,
    /// The factors' robust kernel `phi` (dynamic covariance scaling, > 0): a wrong
    /// pairing fades out instead of bending the map.
    pub robust: f64,
}

impl Default for WallConfig {
    fn default() -> Self {
        Self {
            enabled: false,
            sigma_range: 0.01,
            split_epsilon: 0.05,
            min_length: 1.0,
            max_range: 12.0,
            straightness: 0.2,
            gate: 0.99,
            drift_offset: 0.1,
            drift_angle: 0.03,
            max_gap: 1.0,
            every_path: 10.0,
            robust: 5.0,
        }
    }
}

impl WallConfig {
    /// Refuses bad values with the parameter's name.
    pub fn validate(&self) -> Result<()> {
        rperc_core::ensure_fields(
            &[
                ("split_epsilon", self.split_epsilon),
                ("min_length", self.min_length),
                ("max_range", self.max_range),
                ("drift_offset", self.drift_offset),
                ("drift_angle", self.drift_angle),
                ("every_path", self.every_path),
                ("robust", self.robust),
            ],
            &[
                ("sigma_range", self.sigma_range),
                ("straightness", self.straightness),
            ],
        )?;
        // The grid lookup reads the cells next to the seen segment's: a wall farther
        // than a cell from it is never found.
        rperc_core::ensure_in_range("max_gap", self.max_gap, 0.0, CELL)?;
        if !(self.gate > 0.0 && self.gate < 1.0) {
            return Err(LaserError::invalid(
                "gate",
                format!("must be in (0, 1), got {}", self.gate),
            ));
        }
        // The extraction's own limits (a `sigma_range` whose square overflows), here
        // rather than at the first key scan.
        self.extraction(0.0, self.max_range)
            .validate()
            .map_err(|e| match e {
                linesimp::LineSimpError::InvalidParameter { name, reason } => {
                    LaserError::invalid(name, reason)
                }
                other => LaserError::Numerical(other.to_string()),
            })
    }

    fn extraction(&self, min_range: f64, max_range: f64) -> ScanParams {
        ScanParams {
            min_range,
            max_range,
            sigma_range: self.sigma_range,
            split_epsilon: self.split_epsilon,
            min_length: self.min_length,
            ..ScanParams::default()
        }
    }
}

/// A wall seen in a key scan, laser frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sighting {
    /// The line `(rho, alpha)`.
    pub z: Vector2<f64>,
    /// The seen segment's ends.
    pub ends: [Point2<f64>; 2],
    /// The covariance of the segment innovation (fit plus straightness).
    pub covariance: Matrix2<f64>,
}

impl Sighting {
    fn new(w: &WallSegment, straightness: f64) -> Self {
        let z = Vector2::new(w.rho, w.alpha);
        let ends = [w.start, w.end];
        let r = w.cov + straightness_covariance(&z, &ends, straightness);
        Sighting {
            z,
            ends,
            covariance: innovation_covariance(&z, &Self::middle(&ends), &r),
        }
    }

    fn middle(ends: &[Point2<f64>; 2]) -> Point2<f64> {
        Point2::from((ends[0].coords + ends[1].coords) * 0.5)
    }

    /// The middle of the seen segment.
    pub fn mid(&self) -> Point2<f64> {
        Self::middle(&self.ends)
    }
}

/// The walls of one scan: `ranges[k]` at bearing `angle_min + k angle_increment`.
pub struct Extractor {
    cfg: WallConfig,
    line: LineExtractor,
    angles: Vec<f64>,
}

impl Extractor {
    /// An extractor for `cfg` (checked by the caller).
    pub fn new(cfg: WallConfig) -> Self {
        Extractor {
            cfg,
            line: LineExtractor::new(cfg.extraction(0.0, f64::INFINITY)),
            angles: Vec::new(),
        }
    }

    /// The scan's walls at least `min_length` long; readings at or under
    /// `min_range` or at or over `max_range` are no wall.
    pub fn sightings(
        &mut self,
        ranges: &[f64],
        angle_min: f64,
        angle_increment: f64,
        (min_range, max_range): (f64, f64),
    ) -> Result<Vec<Sighting>> {
        let max_range = max_range.min(self.cfg.max_range);
        let params = self
            .cfg
            .extraction(min_range, max_range.max(min_range + 1e-9));
        if *self.line.params() != params {
            self.line = LineExtractor::new(params);
        }
        self.angles.clear();
        self.angles
            .extend((0..ranges.len()).map(|k| angle_min + k as f64 * angle_increment));
        let segments = self
            .line
            .extract(ranges, &self.angles)
            .map_err(|e| LaserError::Numerical(format!("wall extraction: {e}")))?;
        Ok(segments
            .iter()
            .map(|w| Sighting::new(w, self.cfg.straightness))
            .collect())
    }
}

/// A wall of the map.
#[derive(Debug, Clone)]
struct Mapped {
    /// Its seen extent along the line (world, along `(-sin alpha, cos alpha)`), from
    /// the graph's poses of the key scans that saw it.
    extent: (f64, f64),
    /// Each paired sighting's key scan (graph node) and seen ends, laser frame: the
    /// extent is recomputed from them whenever the graph moves those poses.
    seen: Vec<(usize, [Point2<f64>; 2])>,
    /// Its index among the graph's walls, once it has two factors.
    node: Option<usize>,
    /// Its first factor, kept until the second one.
    first: Option<WallFactor>,
    /// The path at its last factor, m.
    last_path: f64,
}

/// Grid cells, m: a wall is listed in every cell its extent crosses.
const CELL: f64 = 5.0;

/// The walls mapped so far, with a grid of the cells they cross.
#[derive(Debug, Default)]
pub struct WallMap {
    walls: Vec<Mapped>,
    cells: HashMap<(i64, i64), Vec<usize>>,
    /// Factors added to the graph.
    pub factors: usize,
}

/// Coordinate along the line `(rho, alpha)` of world point `p`.
fn along(line: &Vector2<f64>, p: &Point2<f64>) -> f64 {
    let (s, c) = line.y.sin_cos();
    -s * p.x + c * p.y
}

/// The world point at coordinate `t` along `line`.
fn at(line: &Vector2<f64>, t: f64) -> Point2<f64> {
    let (s, c) = line.y.sin_cos();
    Point2::new(line.x * c - t * s, line.x * s + t * c)
}

fn cell(p: &Point2<f64>) -> (i64, i64) {
    ((p.x / CELL).floor() as i64, (p.y / CELL).floor() as i64)
}

/// The cells a segment crosses (sampled at half a cell).
fn cells_of(a: &Point2<f64>, b: &Point2<f64>) -> Vec<(i64, i64)> {
    let steps = ((b - a).norm() / (0.5 * CELL)).ceil().min(1e4) as usize + 1;
    let mut out: Vec<(i64, i64)> = (0..=steps)
        .map(|k| cell(&(a + (b - a) * (k as f64 / steps as f64))))
        .collect();
    out.sort_unstable();
    out.dedup();
    out
}

impl WallMap {
    /// The map's walls in the world, as segments `(x0, y0, x1, y1)`: the graph's
    /// estimate of each wall in the graph, over its seen extent.
    pub fn segments(&self, graph: &PoseGraph) -> Vec<[f64; 4]> {
        self.walls
            .iter()
            .filter_map(|w| {
                let line = *graph.walls.get(w.node?)?;
                let (a, b) = (at(&line, w.extent.0), at(&line, w.extent.1));
                Some([a.x, a.y, b.x, b.y])
            })
            .collect()
    }

    /// Wall `k`'s world line: the graph's estimate once it is in the graph, before
    /// that its first sighting from that key scan's pose as the graph has it now (a
    /// line fixed at the first sighting would keep the pose of that moment, from
    /// before any closure moved it). `None` for a node outside `graph`.
    fn line(&self, graph: &PoseGraph, k: usize) -> Option<Vector2<f64>> {
        let w = &self.walls[k];
        match (w.node, &w.first) {
            (Some(n), _) => graph.walls.get(n).copied(),
            (None, Some(f)) => wall_to_world(graph.poses.get(f.pose)?, &f.z).map(|l| l.wall),
            (None, None) => None,
        }
    }

    /// Wall `k`'s extent along `line` from its sightings' poses in `graph`.
    fn extent(&self, graph: &PoseGraph, k: usize, line: &Vector2<f64>) -> (f64, f64) {
        let mut out = (f64::INFINITY, f64::NEG_INFINITY);
        for (node, ends) in &self.walls[k].seen {
            let Some(pose) = graph.poses.get(*node) else {
                continue;
            };
            for end in ends {
                let t = along(line, &pose.transform_point(end));
                out = (out.0.min(t), out.1.max(t));
            }
        }
        out
    }

    fn register(&mut self, k: usize, graph: &PoseGraph) {
        let Some(line) = self.line(graph, k) else {
            return;
        };
        let (t0, t1) = self.walls[k].extent;
        for c in cells_of(&at(&line, t0), &at(&line, t1)) {
            let list = self.cells.entry(c).or_default();
            if !list.contains(&k) {
                list.push(k);
            }
        }
    }

    /// Recomputes every wall's extent and the lookup grid from `graph`'s poses and
    /// walls: after an optimisation has moved them (a loop closure), the lines, the
    /// extents and the cells they cross move with them.
    pub fn refresh(&mut self, graph: &PoseGraph) {
        self.cells.clear();
        for k in 0..self.walls.len() {
            if let Some(line) = self.line(graph, k) {
                let (lo, hi) = self.extent(graph, k, &line);
                // No sighting's pose in the graph (never so from `observe`): keep it.
                if lo <= hi {
                    self.walls[k].extent = (lo, hi);
                }
            }
            self.register(k, graph);
        }
    }

    /// The wall that sighting `s` from `pose` pairs with: inside the gate (squared
    /// Mahalanobis distance by `information`, the sighting's with the drift
    /// allowance), within `max_gap` of its extent, the nearest.
    fn pair(
        &self,
        s: &Sighting,
        pose: &Pose2,
        graph: &PoseGraph,
        (information, gate): (&Matrix2<f64>, f64),
        max_gap: f64,
    ) -> Option<usize> {
        let (a, b) = (
            pose.transform_point(&s.ends[0]),
            pose.transform_point(&s.ends[1]),
        );
        // Every cell along the seen segment and its neighbours: a wall may lie
        // within `max_gap` of any part of it, not only of its ends.
        let mut near: Vec<usize> = cells_of(&a, &b)
            .iter()
            .flat_map(|&(x, y)| {
                (-1..=1).flat_map(move |i: i64| {
                    (-1..=1).map(move |j: i64| (x.saturating_add(i), y.saturating_add(j)))
                })
            })
            .filter_map(|c| self.cells.get(&c))
            .flatten()
            .copied()
            .collect();
        near.sort_unstable();
        near.dedup();
        near.into_iter()
            .filter_map(|k| {
                let line = self.line(graph, k)?;
                let (e, _, _) = linearise_wall(pose, &line, &s.z, &s.mid())?;
                let d2 = (e.transpose() * information * e)[(0, 0)];
                let (ta, tb) = (along(&line, &a), along(&line, &b));
                let (lo, hi) = self.walls[k].extent;
                let gap = (ta.min(tb) - hi).max(lo - ta.max(tb));
                (d2 <= gate && gap <= max_gap).then_some((k, d2))
            })
            .min_by(|x, y| x.1.total_cmp(&y.1))
            .map(|(k, _)| k)
    }

    /// Pairs the sightings of the key scan at graph node `node` (at `path` m) with
    /// the map, adds the factors that are due to `graph`, and maps the new walls.
    pub fn observe(
        &mut self,
        node: usize,
        path: f64,
        sightings: &[Sighting],
        graph: &mut PoseGraph,
        cfg: &WallConfig,
    ) -> Result<()> {
        let gate = rperc_core::chi2_gate(2, cfg.gate)?;
        let pose = *graph.poses.get(node).ok_or_else(|| {
            LaserError::dimension(format!(
                "key scan node {node} of a graph of {} poses",
                graph.poses.len()
            ))
        })?;
        // The key pose's error relative to a wall, as an error of the seen line
        // `(rho, alpha)`: carried to the seen segment's middle like the fit's own
        // covariance, so that a heading error moves a far middle by its lever arm.
        let drift = Matrix2::new(cfg.drift_offset.powi(2), 0.0, 0.0, cfg.drift_angle.powi(2));
        for s in sightings {
            // A degenerate or non-finite fit has no information to give.
            let Some(information) = finite_information(s) else {
                continue;
            };
            let factor = WallFactor {
                pose: node,
                wall: 0,
                z: s.z,
                mid: s.mid(),
                information,
                robust: Some(cfg.robust),
            };
            let allowance = innovation_covariance(&s.z, &s.mid(), &drift);
            let Some(gated) = (s.covariance + allowance).try_inverse() else {
                continue;
            };
            match self.pair(s, &pose, graph, (&gated, gate), cfg.max_gap) {
                Some(k) => self.revisit(k, s, &pose, path, factor, graph, cfg)?,
                None => self.add(s, &pose, path, factor, graph)?,
            }
        }
        Ok(())
    }

    #[allow(clippy::too_many_arguments)]
    fn revisit(
        &mut self,
        k: usize,
        s: &Sighting,
        pose: &Pose2,
        path: f64,
        factor: WallFactor,
        graph: &mut PoseGraph,
        cfg: &WallConfig,
    ) -> Result<()> {
        let line = self
            .line(graph, k)
            .ok_or_else(|| LaserError::Numerical(format!("wall {k} has no line")))?;
        let w = &mut self.walls[k];
        for end in &s.ends {
            let t = along(&line, &pose.transform_point(end));
            w.extent = (w.extent.0.min(t), w.extent.1.max(t));
        }
        w.seen.push((factor.pose, s.ends));
        if path - w.last_path >= cfg.every_path {
            w.last_path = path;
            let node = match w.node {
                Some(n) => n,
                None => {
                    let n = graph.add_wall(line)?;
                    // A wall outside the graph keeps its first sighting until now.
                    let first = w.first.take().ok_or_else(|| {
                        LaserError::Numerical(format!("wall {k} lost its first sighting"))
                    })?;
                    graph.add_wall_factor(WallFactor { wall: n, ..first })?;
                    self.factors += 1;
                    w.node = Some(n);
                    n
                }
            };
            graph.add_wall_factor(WallFactor {
                wall: node,
                ..factor
            })?;
            self.factors += 1;
        }
        self.register(k, graph);
        Ok(())
    }

    fn add(
        &mut self,
        s: &Sighting,
        pose: &Pose2,
        path: f64,
        factor: WallFactor,
        graph: &PoseGraph,
    ) -> Result<()> {
        let Some(world) = wall_to_world(pose, &s.z) else {
            return Err(LaserError::Core(rperc_core::CoreError::NonFinite(
                "wall sighting",
            )));
        };
        let line = world.wall;
        let (ta, tb) = (
            along(&line, &pose.transform_point(&s.ends[0])),
            along(&line, &pose.transform_point(&s.ends[1])),
        );
        self.walls.push(Mapped {
            extent: (ta.min(tb), ta.max(tb)),
            seen: vec![(factor.pose, s.ends)],
            node: None,
            first: Some(factor),
            last_path: path,
        });
        self.register(self.walls.len() - 1, graph);
        Ok(())
    }
}

/// The information of sighting `s`'s innovation; `None` when the sighting or its
/// information is not finite (a degenerate fit tells nothing).
fn finite_information(s: &Sighting) -> Option<Matrix2<f64>> {
    let finite = s.z.iter().all(|v| v.is_finite())
        && s.ends.iter().all(|e| e.iter().all(|v| v.is_finite()))
        && s.covariance.iter().all(|v| v.is_finite());
    let information = s.covariance.try_inverse().filter(|_| finite)?;
    information
        .iter()
        .all(|v| v.is_finite())
        .then_some(information)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix3;

    /// A long sighting pairs with a short wall in its middle, far from its ends,
    /// and the wall then enters the graph with both sightings.
    #[test]
    fn a_wall_inside_a_long_sighting_is_found() {
        let cfg = WallConfig {
            enabled: true,
            ..WallConfig::default()
        };
        let start = Pose2::new(10.0, 0.0, 0.0);
        let mut graph = PoseGraph::new(start, Matrix3::identity() * 1e8);
        let mut map = WallMap::default();
        map.observe(
            0,
            0.0,
            &[seen_from(&start, 9.0, 11.0, 1e-4)],
            &mut graph,
            &cfg,
        )
        .unwrap();
        let later = Pose2::new(10.0, 0.5, 0.0);
        graph.add_pose(later);
        let long = seen_from(&later, -10.0, 30.0, 1e-4);
        map.observe(1, 20.0, &[long], &mut graph, &cfg).unwrap();
        assert_eq!(map.walls.len(), 1, "paired, not a new wall");
        assert_eq!((graph.walls.len(), graph.wall_factors.len()), (1, 2));
        // Along (-sin alpha, cos alpha) = (-1, 0): from x = 30 to x = -10.
        let (lo, hi) = map.walls[0].extent;
        assert!(
            (lo + 30.0).abs() < 1e-9 && (hi - 10.0).abs() < 1e-9,
            "{lo} {hi}"
        );
    }

    /// The wall y = 3 between x = `from` and x = `to`, seen from the true pose
    /// `truth`, with a fit covariance of `var` on `(rho, alpha)`: the line through
    /// the two ends in the laser frame, written with `rho >= 0`.
    fn seen_from(truth: &Pose2, from: f64, to: f64, var: f64) -> Sighting {
        let (s, c) = truth.theta.sin_cos();
        let local = |x: f64| {
            let (dx, dy) = (x - truth.x, 3.0 - truth.y);
            Point2::new(c * dx + s * dy, -s * dx + c * dy)
        };
        let ends = [local(from), local(to)];
        let d = ends[1] - ends[0];
        let mut n = Vector2::new(-d.y, d.x).normalize();
        if n.dot(&ends[0].coords) < 0.0 {
            n = -n;
        }
        let z = Vector2::new(n.dot(&ends[0].coords), n.y.atan2(n.x));
        let r = Matrix2::new(var, 0.0, 0.0, var);
        Sighting {
            z,
            ends,
            covariance: innovation_covariance(&z, &Sighting::middle(&ends), &r),
        }
    }

    /// A graph started at `start` and a map of the wall y = 3 seen from there between
    /// x = `from` and x = `to` (fit variance `var`), with the default settings.
    fn seen_once(start: Pose2, (from, to): (f64, f64), var: f64) -> (PoseGraph, WallMap) {
        let mut graph = PoseGraph::new(start, Matrix3::identity() * 1e8);
        let mut map = WallMap::default();
        let s = seen_from(&start, from, to, var);
        map.observe(0, 0.0, &[s], &mut graph, &WallConfig::default())
            .unwrap();
        (graph, map)
    }

    /// The walls a second key scan's sighting leaves in the map when the graph puts
    /// that scan's heading `heading_error` off the truth. The wall's seen middle is
    /// 10 m along it from the sensor's foot.
    fn walls_after_heading_error(heading_error: f64) -> usize {
        let cfg = WallConfig::default();
        let (mut graph, mut map) = seen_once(Pose2::identity(), (8.0, 12.0), 1e-8);
        let truth = Pose2::new(0.5, 0.0, 0.0);
        graph.add_pose(Pose2::new(0.5, 0.0, heading_error));
        let s = seen_from(&truth, 8.0, 12.0, 1e-8);
        map.observe(1, 1.0, &[s], &mut graph, &cfg).unwrap();
        map.walls.len()
    }

    /// A heading error of exactly `drift_angle` moves a far sighting's middle by the
    /// lever arm (0.3 m at 10 m), which the allowance carries: with a negligible fit
    /// the squared distance is `(error / drift_angle)^2`, 1 here (paired), 16 at four
    /// times the error (beyond the 99 % gate, 9.21: a new wall).
    #[test]
    fn the_drift_allowance_carries_a_heading_error_to_far_walls() {
        let drift = WallConfig::default().drift_angle;
        assert_eq!(walls_after_heading_error(drift), 1, "paired");
        assert_eq!(walls_after_heading_error(4.0 * drift), 2, "a new wall");
    }

    /// When the graph moves the key scan that saw a wall (an optimisation after a
    /// closure), the wall's line and extent move with it: a wall seen once follows
    /// its sighting's pose, and `refresh` recomputes the extent and the cells.
    #[test]
    fn a_wall_follows_the_poses_that_saw_it() {
        let cfg = WallConfig::default();
        let (mut graph, mut map) = seen_once(Pose2::new(10.0, 0.0, 0.0), (9.0, 11.0), 1e-6);
        // The optimiser moves that key scan 2 m along the wall and 0.5 m towards it.
        graph.poses[0] = Pose2::new(12.0, 0.5, 0.0);
        map.refresh(&graph);
        let line = map.line(&graph, 0).unwrap();
        assert!(
            (line.x - 3.5).abs() < 1e-9,
            "the wall y = 3 moved to y = 3.5: {line}"
        );
        // Along (-sin alpha, cos alpha) = (-1, 0): from x = 13 to x = 11.
        let (lo, hi) = map.walls[0].extent;
        assert!(
            (lo + 13.0).abs() < 1e-9 && (hi + 11.0).abs() < 1e-9,
            "{lo} {hi}"
        );
        // A scan at the moved pose sees the moved wall where the map now has it.
        let moved = Pose2::new(12.0, 0.5, 0.0);
        graph.add_pose(moved);
        let again = seen_from(&Pose2::new(12.0, 0.0, 0.0), 11.0, 13.0, 1e-6);
        map.observe(1, 1.0, &[again], &mut graph, &cfg).unwrap();
        assert_eq!(map.walls.len(), 1, "paired with the moved wall");
    }

    /// A sighting with a NaN in it is skipped, not an error of the run; a node the
    /// graph does not have is an error, not a panic.
    #[test]
    fn bad_sightings_are_skipped_and_bad_nodes_refused() {
        let cfg = WallConfig::default();
        let start = Pose2::new(0.0, 0.0, 0.0);
        let mut graph = PoseGraph::new(start, Matrix3::identity() * 1e8);
        let mut map = WallMap::default();
        let mut bad = seen_from(&start, 1.0, 3.0, 1e-6);
        bad.ends[1].x = f64::NAN;
        map.observe(0, 0.0, &[bad], &mut graph, &cfg).unwrap();
        assert!(map.walls.is_empty());
        let good = seen_from(&start, 1.0, 3.0, 1e-6);
        assert!(map.observe(5, 0.0, &[good], &mut graph, &cfg).is_err());
    }

    /// An extraction setting linesimp refuses is refused when the config is checked.
    #[test]
    fn the_extractions_limits_are_checked_up_front() {
        let cfg = WallConfig {
            sigma_range: 1e200,
            ..WallConfig::default()
        };
        let err = cfg.validate().unwrap_err().to_string();
        assert!(err.contains("sigma_range"), "{err}");
    }

    #[test]
    fn a_gap_beyond_the_grid_is_refused() {
        let cfg = WallConfig {
            max_gap: CELL + 1.0,
            ..WallConfig::default()
        };
        assert!(cfg.validate().is_err());
    }
}
