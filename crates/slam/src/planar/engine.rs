//! [`PlanarSlam`]: the event loop, association, batch update, candidates, anchor,
//! external fix and freezing.

use std::collections::HashMap;
use std::time::Instant;

use nalgebra::{DMatrix, DVector, Matrix2, Matrix3, Point2, Vector2};
use rperc_core::{Definiteness, Pose2, check_covariance};

use super::active_area::ActiveArea;
use super::associate::{FixedPoint, Pairing, Scene, Target};
use super::associator::Associator;
use super::candidates::{Candidates, Sighting};
use super::observe::{anchor_frame, anchor_observation, cartesian, fix_observation, landmark_from};
use super::point_map::PointMap;
use super::wall_map::{FixedWall, WallMap};
use super::{
    Detection, Event, EventArrays, EventKind, FreezeMode, LandmarkEstimate, PlanarConfig,
    PlanarResult, Statistics, Trajectory, WallDetection,
};
use crate::ekf::{Ekf, Gated, SparseJacobian, dyn_mat};
use crate::error::{Result, SlamError, ensure_finite};
use crate::motion::MotionModel;

/// The planar EKF-SLAM engine (see the [module docs](super)).
///
/// # Examples
/// ```
/// use slam::planar::{Detection, Event, PlanarConfig, PlanarSlam};
///
/// let mut slam = PlanarSlam::new(PlanarConfig::default()).unwrap();
/// // Drive straight at 1 m/s for 2 s, seeing landmark 7 ahead, then 1 m closer.
/// let seen = |t: f64, range: f64| Event::Scan {
///     t,
///     detections: vec![Detection { range, bearing: 0.0, id: Some(7) }],
/// };
/// let events = [
///     Event::Control { t: 0.0, control: [1.0, 0.0] },
///     seen(0.0, 5.0),
///     seen(1.0, 4.0),
///     Event::Control { t: 2.0, control: [0.0, 0.0] },
/// ];
/// slam.run(&events).unwrap();
/// let result = slam.finish();
/// assert_eq!(result.landmarks.len(), 1);
/// assert!((result.landmarks[0].mean[0] - 5.0).abs() < 1e-9);
/// assert!((result.trajectory.pose.last().unwrap()[0] - 2.0).abs() < 1e-9);
/// assert_eq!(result.statistics.accepted, 1);
/// ```
#[derive(Debug, Clone)]
pub struct PlanarSlam {
    pub(super) config: PlanarConfig,
    /// The working filter: the full one, or while compressed the sub-filter of the
    /// robot and the active landmarks.
    pub(super) ekf: Ekf,
    /// The compressed EKF's active area (Guivant & Nebot 2001).
    pub(super) area: ActiveArea,
    /// The detection noise `W` (eq. 8).
    w: Matrix2<f64>,
    pub(super) mount: Pose2,
    /// The association: its rule and its chi-square gates.
    pub(super) association: Associator,
    pub(super) time: Option<f64>,
    control: Vector2<f64>,
    /// The internal frame's origin in the world (the anchor's position; zero without).
    pub(super) offset: Vector2<f64>,
    pub(super) anchor: Option<u64>,
    /// When the anchor was made (before it, the state is in the world frame).
    pub(super) anchor_time: Option<f64>,
    /// The points outside the state: frozen ones and the anchor, and first estimates.
    points: PointMap,
    /// The walls: their extents, first estimates, frozen ones and pairings.
    pub(super) wall_map: WallMap,
    /// How often each landmark (point or wall) was updated, for `freeze_after`.
    pub(super) revisions: HashMap<u64, u32>,
    /// How far the updates since the last prediction moved the robot's position
    /// (the pose's first estimate is its prediction: `first_estimates`).
    pub(super) update_shift: Vector2<f64>,
    candidates: Candidates,
    /// For every point detection so far, in the order given: the landmark it updated
    /// or admitted, `None` when it was rejected or is still a candidate.
    point_pairing: Vec<Option<u64>>,
    next_id: u64,
    events: usize,
    /// Work done since the last interrupt checkpoint (Ctrl-C from Python).
    meter: rperc_core::interrupt::Work,
    trajectory: Trajectory,
    pub(super) stats: Statistics,
}

/// Where the sensor sits on the robot: at its origin for the unicycle, at the laser
/// mount for the Ackermann vehicle.
fn sensor_mount(motion: &MotionModel) -> Pose2 {
    match motion {
        MotionModel::Unicycle(_) => Pose2::identity(),
        MotionModel::Ackermann(a) => Pose2::new(a.laser_forward, a.laser_left, 0.0),
    }
}

impl PlanarSlam {
    /// An engine at `config.initial_pose` with an empty map.
    pub fn new(config: PlanarConfig) -> Result<Self> {
        config.validate()?;
        let bias_var = config
            .control_bias_sd
            .map(|sd| [sd[0] * sd[0], sd[1] * sd[1]]);
        let x: Vec<f64> = config
            .initial_pose
            .iter()
            .copied()
            .chain(bias_var.iter().flat_map(|_| [0.0, 0.0]))
            .collect();
        let var: Vec<f64> = config
            .initial_pose_variance
            .iter()
            .copied()
            .chain(bias_var.into_iter().flatten())
            .collect();
        let rd = x.len();
        let p = DMatrix::from_diagonal(&DVector::from_vec(var));
        let ekf = Ekf::new(DVector::from_vec(x), p, rd, 2)?.with_wrapped_angle(2)?;
        let area = ActiveArea::new(&config);
        let association = Associator::new(
            config.association,
            config.gate_confidence,
            config.jcbb_max_nodes,
        )?;
        Ok(Self {
            w: Matrix2::new(config.range_variance, 0.0, 0.0, config.bearing_variance),
            mount: sensor_mount(&config.motion),
            association,
            config,
            ekf,
            area,
            time: None,
            control: Vector2::zeros(),
            offset: Vector2::zeros(),
            anchor: None,
            anchor_time: None,
            points: PointMap::default(),
            wall_map: WallMap::default(),
            revisions: HashMap::new(),
            update_shift: Vector2::zeros(),
            candidates: Candidates::default(),
            point_pairing: Vec::new(),
            next_id: 0,
            events: 0,
            meter: rperc_core::interrupt::Work::new(),
            trajectory: Trajectory::default(),
            stats: Statistics::default(),
        })
    }

    /// The configuration.
    pub fn config(&self) -> &PlanarConfig {
        &self.config
    }

    /// The working filter (its state is in the internal frame: the world shifted by
    /// the anchor's position, see [`PlanarSlam::anchor`]). While the filter is
    /// compressed ([`super::Compression`]) this is the sub-filter of the robot and
    /// the active landmarks; [`PlanarSlam::full_filter`] gives the whole one.
    pub fn ekf(&self) -> &Ekf {
        &self.ekf
    }

    /// The whole filter, after the global update of a compressed one (O(n^2 a),
    /// `a` the active states; the engine then runs on until it compresses again).
    pub fn full_filter(&mut self) -> &Ekf {
        self.area.decompress(&mut self.ekf);
        &self.ekf
    }

    pub(super) fn robot(&self) -> Pose2 {
        let x = self.ekf.state();
        Pose2::new(x[0], x[1], x[2])
    }

    /// The robot pose in the world frame.
    pub fn pose(&self) -> Pose2 {
        let r = self.robot();
        Pose2::new(r.x + self.offset.x, r.y + self.offset.y, r.theta)
    }

    /// The robot covariance `P_rr` (relative to the anchor when there is one).
    pub fn pose_covariance(&self) -> Matrix3<f64> {
        self.ekf.robot_covariance_planar()
    }

    /// The anchor's id and world position, once the anchor variant has one.
    pub fn anchor(&self) -> Option<(u64, Point2<f64>)> {
        self.anchor.map(|id| (id, Point2::from(self.offset)))
    }

    /// Counts so far.
    pub fn statistics(&self) -> &Statistics {
        &self.stats
    }

    /// The robot after every event so far.
    pub fn trajectory(&self) -> &Trajectory {
        &self.trajectory
    }

    /// Processes one event; an error names the event's index and time, and the
    /// events before it stay applied.
    pub fn process(&mut self, event: &Event) -> Result<()> {
        let started = Instant::now();
        let index = self.events;
        let t = event.time();
        let kind = self.dispatch(event).map_err(|e| SlamError::AtEvent {
            index,
            time: t,
            source: Box::new(e),
        })?;
        self.events += 1;
        self.record(t, kind, started.elapsed().as_secs_f64());
        // An event costs about the state size (prediction) times its detections (update).
        let detections = match event {
            Event::Scan { detections, .. } => detections.len(),
            Event::Walls { walls, .. } => walls.len(),
            _ => 0,
        };
        let cost = self.ekf.state().len() * (1 + detections);
        self.meter.advance(cost as u64)?;
        Ok(())
    }

    fn dispatch(&mut self, event: &Event) -> Result<EventKind> {
        match event {
            Event::Control { t, control } => {
                ensure_finite("control", control.iter())?;
                self.predict_to(*t)?;
                self.control = Vector2::from(self.config.bias.correct_control(*control));
                Ok(EventKind::Control)
            }
            Event::Scan { t, detections } => {
                self.predict_to(*t)?;
                self.scan(*t, detections)?;
                Ok(EventKind::Scan)
            }
            Event::Walls { t, walls } => {
                self.predict_to(*t)?;
                // Walls are associated against every wall: no compression with them.
                self.area.decompress(&mut self.ekf);
                self.wall_scan(walls)?;
                Ok(EventKind::Walls)
            }
            Event::Fix { t, xy, covariance } => {
                self.predict_to(*t)?;
                self.fix(xy, covariance)?;
                Ok(EventKind::Fix)
            }
        }
    }

    /// Processes `events` in order; an empty slice is an error.
    pub fn run(&mut self, events: &[Event]) -> Result<()> {
        if events.is_empty() {
            return Err(SlamError::invalid("events", "is empty".into()));
        }
        let ids = events.iter().flat_map(|e| match e {
            Event::Scan { detections, .. } => detections.iter().filter_map(|d| d.id).collect(),
            _ => Vec::new(),
        });
        self.check_known_landmarks(ids)?;
        events.iter().try_for_each(|e| self.process(e))
    }

    /// Refuses at once a run whose known landmark ids would need a covariance over
    /// the allocation limit: found only as the state grew, the error came seconds into
    /// the run and named a state dimension the caller never set (issue 38).
    fn check_known_landmarks(&self, ids: impl Iterator<Item = u64>) -> Result<()> {
        if !self.association.by_id() {
            return Ok(());
        }
        let landmarks = ids.collect::<std::collections::HashSet<u64>>().len() as u128;
        let dim = self.ekf.robot_dim() as u128 + 2 * landmarks;
        Ok(rperc_core::check_bytes(
            "landmarks",
            landmarks,
            dim * dim * 8,
        )?)
    }

    fn record(&mut self, t: f64, kind: EventKind, seconds: f64) {
        let pose = self.pose();
        let p = self.pose_covariance();
        let tr = &mut self.trajectory;
        tr.t.push(t);
        tr.kind.push(kind);
        tr.pose.push([pose.x, pose.y, pose.theta]);
        tr.covariance
            .push(std::array::from_fn(|k| p[(k / 3, k % 3)]));
        tr.seconds.push(seconds);
    }

    /// Eqs. (3) and (5): the robot moves from the last event's time to `t` under the
    /// control in force. Time going backwards is an error.
    fn predict_to(&mut self, t: f64) -> Result<()> {
        if !t.is_finite() {
            return Err(SlamError::invalid("t", format!("must be finite, got {t}")));
        }
        let Some(t0) = self.time else {
            self.time = Some(t);
            return Ok(());
        };
        if t < t0 {
            return Err(SlamError::invalid(
                "t",
                format!("time went backwards, from {t0} to {t}"),
            ));
        }
        if t > t0 && self.ekf.robot_dim() == 5 {
            self.predict_biased(t - t0)?;
        } else if t > t0 {
            let pred = self
                .config
                .motion
                .predict(&self.robot(), self.control, t - t0)?;
            let v = self.config.motion.control_noise();
            let fx = self.first_estimate_fx(pred.fx);
            self.ekf.predict_planar(&pred.mean, &fx, &pred.fv, &v)?;
            self.area.follow_prediction(&fx);
        }
        self.time = Some(t);
        Ok(())
    }

    /// The motion Jacobian `Fx` at the first estimates (Huang et al. 2008, eq. 14):
    /// its heading column is the displacement turned by 90 degrees (any motion model
    /// that commutes with rigid motions of the world), and FEJ takes the displacement
    /// from the previous pose's first estimate, its prediction, instead of the
    /// updated estimate: the updates since then moved it by `update_shift`.
    fn first_estimate_fx(&mut self, mut fx: Matrix3<f64>) -> Matrix3<f64> {
        if self.config.first_estimates {
            fx[(0, 2)] -= self.update_shift.y;
            fx[(1, 2)] += self.update_shift.x;
        }
        self.update_shift = Vector2::zeros();
        fx
    }

    /// Runs an update and records how far it moved the robot's position.
    fn shifting<T>(&mut self, update: impl FnOnce(&mut Self) -> Result<T>) -> Result<T> {
        let before = Vector2::new(self.ekf.state()[0], self.ekf.state()[1]);
        let out = update(self)?;
        let after = Vector2::new(self.ekf.state()[0], self.ekf.state()[1]);
        self.update_shift += after - before;
        Ok(out)
    }

    /// The prediction with control-bias states (`control_bias_sd`): the robot block
    /// `(x, y, theta, s, b)` moves with `F = [[Fx, Fb], [0, I]]`.
    fn predict_biased(&mut self, dt: f64) -> Result<()> {
        let x = self.ekf.state();
        let bias = Vector2::new(x[3], x[4]);
        let p = super::bias::predict_biased(
            &self.config.motion,
            &self.robot(),
            self.control,
            bias,
            dt,
        )?;
        let mut f = DMatrix::identity(5, 5);
        f.view_mut((0, 0), (3, 3))
            .copy_from(&self.first_estimate_fx(p.fx));
        f.view_mut((0, 3), (3, 2)).copy_from(&p.fb);
        let mut g = DMatrix::zeros(5, 2);
        g.view_mut((0, 0), (3, 2)).copy_from(&p.fv);
        let m = DVector::from_vec(vec![p.mean.x, p.mean.y, p.mean.z, bias.x, bias.y]);
        let v = dyn_mat(&self.config.motion.control_noise());
        self.ekf.predict(&m, &f, &g, &v)
    }

    /// A robot Jacobian `(rows x 3)` widened to the robot block (zero for the bias
    /// states), for a new landmark's cross-covariance.
    pub(super) fn robot_block<const R: usize>(
        &self,
        g: &nalgebra::SMatrix<f64, R, 3>,
    ) -> DMatrix<f64> {
        let mut out = DMatrix::zeros(R, self.ekf.robot_dim());
        out.view_mut((0, 0), (R, 3)).copy_from(g);
        out
    }

    /// The filter re-expressed in an anchor's frame (eqs. 24-25): the pose becomes
    /// `moved` with covariance `J_r P_rr J_r^T + extra`; the bias states (if any)
    /// keep their mean and covariance, their cross-covariance becomes `J_r P_rb`.
    pub(super) fn reanchor(
        &mut self,
        moved: &nalgebra::Vector3<f64>,
        j_r: &Matrix3<f64>,
        extra: &Matrix3<f64>,
    ) -> Result<()> {
        let rd = self.ekf.robot_dim();
        let prr = self.ekf.robot_covariance();
        let mut j = DMatrix::identity(rd, rd);
        j.view_mut((0, 0), (3, 3)).copy_from(j_r);
        let mut p = &j * prr * j.transpose();
        let e = p.view((0, 0), (3, 3)) + extra;
        p.view_mut((0, 0), (3, 3)).copy_from(&e);
        let p = (&p + p.transpose()) * 0.5;
        let mut x = self.ekf.state().rows(0, rd).into_owned();
        x.rows_mut(0, 3).copy_from(moved);
        self.ekf = Ekf::new(x, p, rd, 2)?.with_wrapped_angle(2)?;
        self.update_shift = Vector2::zeros();
        Ok(())
    }

    /// Eqs. (26)-(27): an xy fix of the robot, behind its chi-square gate.
    fn fix(&mut self, xy: &[f64; 2], cov: &[f64; 3]) -> Result<()> {
        ensure_finite("fix", xy.iter().chain(cov.iter()))?;
        let r = DMatrix::from_row_slice(2, 2, &[cov[0], cov[1], cov[1], cov[2]]);
        check_covariance("fix covariance", &r, Definiteness::Positive)?;
        if !self.config.external_fix {
            self.stats.fixes_ignored += 1;
            return Ok(());
        }
        let lever = Vector2::from(self.config.fix_lever_arm);
        let (h, jac) = fix_observation(&self.robot(), &self.offset, &lever);
        let nu = DVector::from_vec(vec![xy[0] - h.x, xy[1] - h.y]);
        let hs = SparseJacobian::new(2).with_block(0, 0, dyn_mat(&jac));
        let gate = self.association.gates().individual();
        match self.shifting(|slam| slam.ekf.update_gated(&nu, &hs, &r, gate))? {
            Gated::Applied(update) => {
                self.area.follow_update(&[(nu, hs, r)], &update)?;
                self.stats.fixes_applied += 1;
            }
            Gated::Rejected { .. } => self.stats.fixes_rejected += 1,
        }
        Ok(())
    }
}

/// The scan: association, one batch update, freezing, candidates.
impl PlanarSlam {
    fn scan(&mut self, t: f64, detections: &[Detection]) -> Result<()> {
        let mut zs = Vec::with_capacity(detections.len());
        for d in detections {
            ensure_finite("detection", [d.range, d.bearing].iter())?;
            // The calibrated biases come off first; the range must be positive after.
            let (range, bearing) = self.config.bias.correct_detection(d.range, d.bearing)?;
            if range <= 0.0 {
                return Err(SlamError::invalid(
                    "range",
                    format!("must be > 0, got {} ({range} unbiased)", d.range),
                ));
            }
            zs.push(Vector2::new(range, bearing));
        }
        // Ids are the association only when it is 'known'; otherwise they are ignored
        // (a data set's labels must not leak into NN or JCBB).
        let known = self.association.by_id();
        let ids: Vec<Option<u64>> = detections.iter().map(|d| d.id.filter(|_| known)).collect();
        self.localise(&zs, &ids)?;
        let (pairings, unmatched) = self.associate(&zs, &ids)?;
        let base = self.point_pairing.len();
        self.point_pairing.resize(base + zs.len(), None);
        for p in &pairings {
            self.point_pairing[base + p.det] = Some(self.target_id(p.target));
        }
        if !pairings.is_empty() {
            self.apply(&pairings, &zs)?;
            self.stats.accepted += pairings.len() as u64;
        }
        self.candidates
            .forget_older_than(t, self.config.candidate_window);
        for i in unmatched {
            self.point_pairing[base + i] = self.sighting(t, &zs[i], ids[i])?;
        }
        Ok(())
    }

    /// Pairs the detections; returns the pairings and the detections that no
    /// landmark explains (for the candidate list).
    fn associate(
        &mut self,
        zs: &[Vector2<f64>],
        ids: &[Option<u64>],
    ) -> Result<(Vec<Pairing>, Vec<usize>)> {
        self.association.begin_scan(zs.len())?;
        let scene = self.scene();
        let found = if self.association.by_id() {
            let targets = self.named_targets(ids)?;
            self.association.known(&scene, zs, &targets)
        } else {
            self.association.search(&scene, zs)
        };
        self.stats.rejected += found.rejected;
        self.stats.jcbb_truncated += u64::from(found.truncated);
        Ok((found.pairings, found.unmatched))
    }

    /// The prior the association works against, with the walls marked.
    pub(super) fn scene(&self) -> Scene<'_> {
        // No wall map at all (point landmarks only): nothing to look up per landmark.
        let walls = if self.wall_map.is_empty() {
            Vec::new()
        } else {
            let ids = self.ekf.landmark_ids().iter();
            ids.map(|&id| self.wall_map.contains(id)).collect()
        };
        let first = if self.config.first_estimates {
            let ids = self.ekf.landmark_ids().iter();
            ids.map(|&id| self.points.first_estimate(id)).collect()
        } else {
            Vec::new()
        };
        Scene::new(&self.ekf, self.mount, self.w, self.points.fixed())
            .with_walls(walls)
            .with_first_estimates(first)
    }

    /// The landmark each detection's id names (`None`: an id not in the map, a
    /// candidate). A detection without an id, or with a wall's, is an error.
    fn named_targets(&self, ids: &[Option<u64>]) -> Result<Vec<Option<Target>>> {
        let named = |(i, id): (usize, &Option<u64>)| {
            let id = id.ok_or_else(|| {
                SlamError::invalid(
                    "id",
                    format!("detection {i} has no id (association 'known')"),
                )
            })?;
            if self.wall_map.contains(id) {
                return Err(SlamError::invalid(
                    "id",
                    format!("detection {i} has id {id}, which is a wall's"),
                ));
            }
            Ok(match self.ekf.landmark_index(id) {
                Some(j) => Some(Target::State(j)),
                None => self.points.fixed_index(id).map(Target::Fixed),
            })
        };
        ids.iter().enumerate().map(named).collect()
    }

    pub(super) fn target_id(&self, target: Target) -> u64 {
        match target {
            Target::State(j) => self.ekf.landmark_ids()[j],
            Target::Fixed(k) => self.points.fixed_id(k),
            Target::FixedWall(k) => self.wall_map.fixed_id(k),
        }
    }

    /// All pairings of the scan in one stacked update (eqs. 6-9, Joseph form). An
    /// anchor sighting uses eq. (24) as a Cartesian point with its Jacobian (25).
    pub(super) fn apply(&mut self, pairings: &[Pairing], zs: &[Vector2<f64>]) -> Result<()> {
        let robot = self.robot();
        let mut stacked = Vec::with_capacity(pairings.len());
        for p in pairings {
            // A wall anchor is a fixed wall like a frozen one: only a point anchor
            // is observed through eq. (24).
            let is_anchor = matches!(p.target, Target::Fixed(_))
                && self.anchor.is_some_and(|a| self.target_id(p.target) == a);
            let mut h = SparseJacobian::new(2);
            let (nu, r) = if is_anchor {
                let (zc, wc) = cartesian(&zs[p.det], &self.w);
                let (pred, jac) = anchor_observation(&robot, &self.mount);
                h = h.with_block(0, 0, dyn_mat(&jac));
                (zc - pred, wc)
            } else {
                h = h.with_block(0, 0, dyn_mat(&p.h_robot));
                if let Some(off) = p.offset {
                    h = h.with_block(0, off, dyn_mat(&p.h_landmark));
                }
                (p.nu, p.r)
            };
            stacked.push((DVector::from_column_slice(nu.as_slice()), h, dyn_mat(&r)));
        }
        let ids: Vec<u64> = pairings.iter().map(|p| self.target_id(p.target)).collect();
        self.shifting(|slam| slam.update_stacked(&stacked))?;
        for id in ids {
            let n = self.revisions.entry(id).or_insert(0);
            *n += 1;
            let revised = *n;
            if self
                .config
                .freeze_after
                .is_some_and(|limit| revised > limit)
            {
                self.freeze(id)?;
            }
        }
        Ok(())
    }

    /// Text under Fig. 7: a landmark revised more than N times leaves the state
    /// (marginalised) but stays in the map; its later sightings update the rest with
    /// the landmark known at its frozen mean and covariance.
    fn freeze(&mut self, id: u64) -> Result<()> {
        if self.ekf.landmark_index(id).is_none() {
            return Ok(()); // already frozen, or the anchor
        }
        // Removal reaches every state: the global update first.
        self.area.decompress(&mut self.ekf);
        let Some(j) = self.ekf.landmark_index(id) else {
            return Ok(());
        };
        if self.config.freeze_mode == FreezeMode::Consider {
            if !self.ekf.is_consider(j) {
                self.ekf.set_consider(j)?;
                self.stats.frozen += 1;
            }
            return Ok(());
        }
        let off = self.ekf.landmark_offset(j)?;
        let mean = Vector2::new(self.ekf.state()[off], self.ekf.state()[off + 1]);
        let cov = Matrix2::from_column_slice(self.ekf.landmark_covariance(j)?.as_slice());
        self.ekf.remove_landmark(j)?;
        if self.wall_map.contains(id) {
            self.wall_map.fix(id, FixedWall { line: mean, cov });
        } else {
            let mean = Point2::from(mean);
            self.points.fix(id, FixedPoint { mean, cov });
        }
        self.stats.frozen += 1;
        Ok(())
    }
}

/// New landmarks: the candidate list and admission, and the anchor.
impl PlanarSlam {
    /// An unexplained detection: joins a consistent candidate (by id, or the nearest
    /// within the Mahalanobis gate) or starts one; after `candidate_sightings`
    /// consistent sightings the landmark enters the map.
    /// A detection no landmark explains: a candidate, or once seen often enough a new
    /// landmark (its id returned).
    fn sighting(&mut self, t: f64, z: &Vector2<f64>, id: Option<u64>) -> Result<Option<u64>> {
        let (l, g_r, g_z) = landmark_from(&self.robot(), &self.mount, z);
        let prr = self.pose_covariance();
        let cov = g_r * prr * g_r.transpose() + g_z * self.w * g_z.transpose();
        let sighting = Sighting {
            id,
            mean: l,
            cov,
            time: t,
        };
        let by_id = self.association.by_id();
        let needed = self.config.candidate_sightings;
        if self.candidates.sight(
            &sighting,
            by_id,
            self.association.gates().individual(),
            needed,
        ) < needed
        {
            self.stats.candidate += 1;
            return Ok(None);
        }
        let id = id.unwrap_or_else(|| self.fresh_id());
        self.admit(id, z)?;
        Ok(Some(id))
    }

    pub(super) fn fresh_id(&mut self) -> u64 {
        while self.area.contains(&self.ekf, self.next_id)
            || self.points.fixed_index(self.next_id).is_some()
            || self.wall_map.contains(self.next_id)
        {
            self.next_id += 1;
        }
        self.next_id += 1;
        self.next_id - 1
    }

    /// Initialises landmark `id` from detection `z` with its full cross-covariance;
    /// the first one becomes the anchor when that variant is on.
    fn admit(&mut self, id: u64, z: &Vector2<f64>) -> Result<()> {
        self.stats.new += 1;
        self.revisions.insert(id, 0);
        if self.config.anchor && self.anchor.is_none() && self.landmarks_in_state() == 0 {
            return self.make_anchor(id, z);
        }
        let (l, g_r, g_z) = landmark_from(&self.robot(), &self.mount, z);
        if self.config.first_estimates {
            self.points.set_first_estimate(id, l);
        }
        let g_r = self.robot_block(&g_r);
        self.ekf.add_landmark_with_id(
            id,
            &DVector::from_vec(vec![l.x, l.y]),
            &g_r,
            &dyn_mat(&g_z),
            &dyn_mat(&self.w),
        )?;
        self.area.follow_admission(&g_r)
    }

    /// Eqs. (24)-(25): the landmark becomes the global reference. The map (here only
    /// the robot: the anchor is the first landmark) is re-expressed relative to it,
    /// `t' = t - a`, with `P' = J_r P_rr J_r^T + J_z W J_z^T`; the anchor then sits at
    /// the origin with no uncertainty and leaves the state.
    fn make_anchor(&mut self, id: u64, z: &Vector2<f64>) -> Result<()> {
        let (moved, j_r, j_z, a) = anchor_frame(&self.robot(), &self.mount, z);
        self.reanchor(&moved, &j_r, &(j_z * self.w * j_z.transpose()))?;
        self.offset += a.coords;
        self.candidates.shift_origin(&a.coords);
        let (mean, cov) = (Point2::origin(), Matrix2::zeros());
        self.points.fix(id, FixedPoint { mean, cov });
        self.anchored_at(id);
        Ok(())
    }

    /// Landmark `id` (a point or a wall) is the anchor from now on.
    pub(super) fn anchored_at(&mut self, id: u64) {
        self.anchor = Some(id);
        self.anchor_time = self.time;
    }
}

/// Results and the bulk entry point.
impl PlanarSlam {
    /// The map in the world frame, sorted by id (a compressed filter is read
    /// through a global update of a copy: O(n^2 a)).
    pub fn landmarks(&self) -> Vec<LandmarkEstimate> {
        let ekf = self.area.full(&self.ekf);
        let mut out = Vec::new();
        for (j, &id) in ekf.landmark_ids().iter().enumerate() {
            if self.wall_map.contains(id) {
                continue;
            }
            let off = ekf.landmark_offset(j).expect("landmark index");
            let x = ekf.state();
            let c = ekf
                .covariance_block(off, off, 2, 2)
                .expect("landmark block");
            let frozen = ekf.is_consider(j);
            out.push(self.estimate(id, Point2::new(x[off], x[off + 1]), &c, frozen));
        }
        for (id, f) in self.points.fixed_with_ids() {
            out.push(self.estimate(id, f.mean, &dyn_mat(&f.cov), Some(id) != self.anchor));
        }
        out.sort_by_key(|l| l.id);
        out
    }

    fn estimate(
        &self,
        id: u64,
        mean: Point2<f64>,
        c: &DMatrix<f64>,
        frozen: bool,
    ) -> LandmarkEstimate {
        LandmarkEstimate {
            id,
            mean: [mean.x + self.offset.x, mean.y + self.offset.y],
            covariance: [c[(0, 0)], c[(0, 1)], c[(1, 0)], c[(1, 1)]],
            revisions: self.revisions.get(&id).copied().unwrap_or(0),
            frozen,
            anchor: Some(id) == self.anchor,
        }
    }

    /// The trajectory, the map and the statistics (after the global update of a
    /// compressed filter).
    pub fn finish(mut self) -> PlanarResult {
        self.area.decompress(&mut self.ekf);
        let landmarks = self.landmarks();
        let walls = self.walls();
        let point_anchor = self.anchor.filter(|&id| !self.wall_map.contains(id));
        PlanarResult {
            anchor: point_anchor.map(|_| [self.offset.x, self.offset.y]),
            walls,
            anchor_time: self.anchor_time,
            trajectory: self.trajectory,
            landmarks,
            statistics: self.stats,
            wall_pairing: self.wall_map.into_pairings(),
            point_pairing: self.point_pairing,
        }
    }

    /// Processes a whole run given as columnar arrays ([`EventArrays`]): each array
    /// must be sorted by time (an error names the array and row otherwise), and at
    /// least one event is required.
    pub fn run_arrays(&mut self, arrays: &EventArrays<'_>) -> Result<()> {
        self.run_arrays_with(arrays, |_, _| true)
    }

    /// [`PlanarSlam::run_arrays`] that calls `report(done, total)` (rows of the arrays
    /// consumed, of all) after about every 1 % of the rows and at the end: a progress
    /// bar. `report` returning `false` stops the run with an error.
    pub fn run_arrays_with(
        &mut self,
        arrays: &EventArrays<'_>,
        mut report: impl FnMut(usize, usize) -> bool,
    ) -> Result<()> {
        check_arrays(arrays)?;
        let ids = arrays.detection_ids.unwrap_or(&[]).iter();
        self.check_known_landmarks(ids.filter_map(|&id| u64::try_from(id).ok()))?;
        let mut cursor = Cursor::new(arrays);
        let total = cursor.total();
        let step = total.div_ceil(100);
        let mut next_report = step;
        let stopped = |at: usize| {
            SlamError::invalid(
                "report",
                format!("the progress report stopped the run at row {at} of {total}"),
            )
        };
        while let Some(event) = cursor.next_event() {
            self.process(&event)?;
            let done = cursor.consumed();
            if done >= next_report && done < total {
                next_report = done + step;
                if !report(done, total) {
                    return Err(stopped(done));
                }
            }
        }
        if report(total, total) {
            Ok(())
        } else {
            Err(stopped(total))
        }
    }
}

/// Walks the four time-sorted arrays of an [`EventArrays`] as one stream of events:
/// at equal times controls first, then a scan's detections, then its walls, then
/// fixes.
struct Cursor<'a, 'b> {
    arrays: &'b EventArrays<'a>,
    /// The next row of the controls, detections, fixes and walls.
    next: [usize; 4],
}

impl<'a, 'b> Cursor<'a, 'b> {
    fn new(arrays: &'b EventArrays<'a>) -> Self {
        Self {
            arrays,
            next: [0; 4],
        }
    }

    fn total(&self) -> usize {
        let a = self.arrays;
        a.controls.len() + a.detections.len() + a.fixes.len() + a.walls.len()
    }

    fn consumed(&self) -> usize {
        self.next.iter().sum()
    }

    /// The rows from `start` on that share its time stamp: one scan.
    fn same_time<const N: usize>(rows: &[[f64; N]], start: usize) -> usize {
        let t = rows[start][0];
        start + rows[start..].iter().take_while(|r| r[0] == t).count()
    }

    fn next_event(&mut self) -> Option<Event> {
        let a = self.arrays;
        let [i, j, k, l] = self.next;
        let tc = a.controls.get(i).map_or(f64::INFINITY, |r| r[0]);
        let td = a.detections.get(j).map_or(f64::INFINITY, |r| r[0]);
        let tf = a.fixes.get(k).map_or(f64::INFINITY, |r| r[0]);
        let tw = a.walls.get(l).map_or(f64::INFINITY, |r| r[0]);
        if tc.min(td).min(tf).min(tw) == f64::INFINITY {
            return None;
        }
        Some(if tc <= td && tc <= tf && tc <= tw {
            self.next[0] += 1;
            let r = a.controls[i];
            Event::Control {
                t: tc,
                control: [r[1], r[2]],
            }
        } else if td <= tf && td <= tw {
            self.next[1] = Self::same_time(a.detections, j);
            Event::Scan {
                t: td,
                detections: scan_rows(a, j, self.next[1]),
            }
        } else if tw <= tf {
            self.next[3] = Self::same_time(a.walls, l);
            Event::Walls {
                t: tw,
                walls: a.walls[l..self.next[3]].iter().map(wall_row).collect(),
            }
        } else {
            self.next[2] += 1;
            let r = a.fixes[k];
            Event::Fix {
                t: tf,
                xy: [r[1], r[2]],
                covariance: [r[3], r[4], r[5]],
            }
        })
    }
}

fn wall_row(r: &[f64; 10]) -> WallDetection {
    WallDetection {
        rho: r[1],
        alpha: r[2],
        covariance: [r[3], r[4], r[4], r[5]],
        start: [r[6], r[7]],
        end: [r[8], r[9]],
    }
}

fn scan_rows(arrays: &EventArrays<'_>, start: usize, end: usize) -> Vec<Detection> {
    (start..end)
        .map(|r| Detection {
            range: arrays.detections[r][1],
            bearing: arrays.detections[r][2],
            id: arrays
                .detection_ids
                .and_then(|ids| u64::try_from(ids[r]).ok()),
        })
        .collect()
}

/// Sizes and time order of the arrays, checked before anything runs.
fn check_arrays(a: &EventArrays<'_>) -> Result<()> {
    if a.controls.is_empty() && a.detections.is_empty() && a.fixes.is_empty() && a.walls.is_empty()
    {
        return Err(SlamError::invalid("events", "all arrays are empty".into()));
    }
    if let Some(ids) = a.detection_ids
        && ids.len() != a.detections.len()
    {
        return Err(SlamError::dimension(format!(
            "{} detection ids for {} detections",
            ids.len(),
            a.detections.len()
        )));
    }
    let times: [(&'static str, Vec<f64>); 4] = [
        ("controls", a.controls.iter().map(|r| r[0]).collect()),
        ("detections", a.detections.iter().map(|r| r[0]).collect()),
        ("fixes", a.fixes.iter().map(|r| r[0]).collect()),
        ("walls", a.walls.iter().map(|r| r[0]).collect()),
    ];
    // Fix positions are world coordinates: the one range check of a coordinate.
    rperc_core::ensure_coordinates("fixes", a.fixes.iter().flat_map(|r| &r[1..3]))?;
    for (name, t) in times {
        ensure_finite(name, t.iter())?;
        if let Some(row) = t.windows(2).position(|w| w[1] < w[0]) {
            return Err(SlamError::invalid(
                name,
                format!("row {}: time {} is before {}", row + 1, t[row + 1], t[row]),
            ));
        }
    }
    Ok(())
}
