//! Walls in the planar engine, the second landmark kind: each scan's walls are
//! paired with the map by a Mahalanobis gate plus segment overlap (the innovation
//! taken at the seen segment or at the sensor's foot, `wall_innovation`),
//! applied in one batch update with the observation model of [`crate::wall`], and the
//! rest admitted with their full covariance (the inverse model, with the robot's
//! covariance and cross-covariances). Freezing and the anchor follow the config
//! shared with the points. A wall's seen extent is kept outside the state: grown as
//! the wall is seen, it draws the map and decides overlap.
//!
//! Each wall's state is its line `(rho, alpha)` about its own reference point, the
//! middle of the segment that first showed it (fixed, outside the state), not about
//! the world origin. About the world origin, `d rho / d alpha` is the robot's
//! distance along the wall from the origin's foot, tens of metres in a building:
//! an angle error of a few degrees, which a short wall carries, then makes the
//! linearised update wrong by centimetres to decimetres in `rho`, every update, and
//! the filter turns overconfident and pairs walls wrongly (Rodriguez-Losada et al.
//! 2007 trace EKF-SLAM's inconsistency indoors to this lever). About the wall's own
//! point the lever is the robot's offset along the wall from where it was first
//! seen, a few metres, and the result no longer depends on where the world origin
//! is (tested: a simulated room far from the origin).

use std::f64::consts::PI;

use nalgebra::{DVector, Matrix2, Matrix2x3, Matrix3, Matrix3x2, Point2, Vector2};
use rperc_core::{Definiteness, Pose2, check_covariance, chi2_gate, wrap_angle};

use super::associate::{Pairing, Scene, Target};
use super::wall_map::{Extent, FixedWall, along, covering, gap};
use super::{PlanarSlam, WallDetection, WallEstimate, WallInnovation};
use crate::ekf::dyn_mat;
use crate::error::{Result, SlamError, ensure_finite};
use crate::wall::{
    WallJacobians, observe_wall, segment_innovation, segment_middle, straightness_covariance,
    wall_innovation, wall_to_world,
};

/// The sensor as seen from a wall's reference point: the pose moved by `-origin`,
/// so that [`observe_wall`] and [`wall_to_world`] work about that point (their
/// Jacobians with respect to the pose are unchanged by a constant shift).
fn about(sensor: &Pose2, origin: &Point2<f64>) -> Pose2 {
    Pose2::new(sensor.x - origin.x, sensor.y - origin.y, sensor.theta)
}

/// A line `(rho, alpha)` about `origin` as a line about the frame's origin.
fn in_frame(line: &Vector2<f64>, origin: &Point2<f64>) -> Vector2<f64> {
    let (s, c) = line.y.sin_cos();
    Vector2::new(line.x + c * origin.x + s * origin.y, line.y)
}

/// A checked wall detection: `z = (rho, alpha)`, its noise `r`, and the seen
/// segment's end points in the sensor frame.
struct Seen {
    z: Vector2<f64>,
    r: Matrix2<f64>,
    local: [Point2<f64>; 2],
    /// Where the innovation is taken ([`WallInnovation::Segment`]): the middle of
    /// the seen segment, on its line; `None` at the sensor's foot.
    mid: Option<Point2<f64>>,
}

fn checked(i: usize, d: &WallDetection) -> Result<Seen> {
    let values = [d.rho, d.alpha]
        .into_iter()
        .chain(d.covariance)
        .chain(d.start)
        .chain(d.end)
        .collect::<Vec<_>>();
    ensure_finite("wall", values.iter())?;
    if d.rho < 0.0 {
        return Err(SlamError::invalid(
            "rho",
            format!("wall {i}: must be >= 0, got {}", d.rho),
        ));
    }
    let r = Matrix2::from_row_slice(&d.covariance);
    check_covariance("wall covariance", &dyn_mat(&r), Definiteness::Positive)?;
    Ok(Seen {
        z: Vector2::new(d.rho, wrap_angle(d.alpha)),
        r,
        local: [Point2::from(d.start), Point2::from(d.end)],
        mid: None,
    })
}

/// A map wall a detection may be paired with: a state wall, or a fixed one with its
/// covariance; `line` is about the extent's reference point.
struct WallTarget<'a> {
    target: Target,
    line: Vector2<f64>,
    /// Where the observation is linearised: `line`, or the wall's first estimate
    /// (`first_estimates`).
    linearised: Vector2<f64>,
    fixed: Option<&'a Matrix2<f64>>,
    extent: &'a Extent,
    /// The stretches its earlier paired detections covered.
    parts: &'a [(f64, f64)],
}

/// The stretch `(from, to)` of `line` (frame form) that detection `seen` covers,
/// placed with `sensor`.
fn part_on(line: &Vector2<f64>, sensor: &Pose2, seen: &Seen) -> (f64, f64) {
    let [a, b] = seen
        .local
        .map(|p| along(line, &sensor.transform_point(&p)).1);
    (a.min(b), a.max(b))
}

/// How many of `parts` overlap `part` by more than half of the shorter of the two.
pub(super) fn overlapping(parts: &[(f64, f64)], (lo, hi): (f64, f64)) -> usize {
    parts
        .iter()
        .filter(|(a, b)| hi.min(*b) - lo.max(*a) > 0.5 * (hi - lo).min(b - a))
        .count()
}

/// The pairing of detection `det` with `wall`, seen from the sensor (with its
/// Jacobian with respect to the robot). The prediction's Jacobians take the other
/// form of the line when the innovation does ([`wall_innovation`]).
fn wall_pairing(
    scene: &Scene<'_>,
    (sensor, j_sensor): &(Pose2, Matrix3<f64>),
    det: usize,
    seen: &Seen,
    wall: &WallTarget<'_>,
    shared_sd: f64,
) -> Option<Pairing> {
    let (target, fixed) = (wall.target, wall.fixed);
    let from = about(sensor, &wall.extent.origin);
    let pred = observe_wall(&from, &wall.line)?;
    let (mut nu, sign) = wall_innovation(&seen.z, &pred.wall);
    let jac = linearised_at(&from, &pred, &wall.linearised)?;
    let mut h_robot = jac.d_pose * j_sensor;
    let mut h_l = jac.d_wall;
    let mut r = seen.r;
    if shared_sd > 0.0 {
        let line = in_frame(&wall.line, &wall.extent.origin);
        let repeats = overlapping(wall.parts, part_on(&line, sensor, seen)) as f64;
        r += straightness_covariance(&seen.z, &seen.local, shared_sd) * repeats.sqrt();
    }
    if sign < 0.0 {
        h_robot.row_mut(0).neg_mut();
        h_l.row_mut(0).neg_mut();
    }
    if let Some(mid) = &seen.mid {
        let form = if sign < 0.0 {
            Vector2::new(-pred.wall.x, wrap_angle(pred.wall.y + PI))
        } else {
            pred.wall
        };
        let at = segment_innovation(&seen.z, &form, mid);
        nu = at.nu;
        h_robot = at.j_predicted * h_robot;
        h_l = at.j_predicted * h_l;
        r = at.j_seen * r * at.j_seen.transpose();
    }
    let (h_landmark, r, offset) = match (target, fixed) {
        (Target::State(j), _) => (h_l, r, Some(scene.ekf.robot_dim() + 2 * j)),
        (_, Some(c)) => (Matrix2::zeros(), r + h_l * c * h_l.transpose(), None),
        _ => return None,
    };
    scene.scored(det, target, nu, (h_robot, h_landmark, offset), r)
}

/// The Jacobians of the observation `pred` of a wall from `from`, evaluated at the
/// line `at` instead (its first estimate), in the same form as `pred` (rho rows
/// negated alike when the line seen from `from` had to be flipped).
fn linearised_at(from: &Pose2, pred: &WallJacobians, at: &Vector2<f64>) -> Option<WallJacobians> {
    let mut jac = observe_wall(from, at)?;
    if jac.d_wall[(0, 0)] != pred.d_wall[(0, 0)] {
        jac.d_pose.row_mut(0).neg_mut();
        jac.d_wall.row_mut(0).neg_mut();
    }
    Some(jac)
}

impl PlanarSlam {
    /// The state offset of landmark `j` (after the robot block).
    fn offset_of(&self, j: usize) -> usize {
        self.ekf.robot_dim() + 2 * j
    }

    fn sensor(&self) -> (Pose2, Matrix3<f64>) {
        let (sensor, j_robot, _) = self.robot().compose_with_jacobians(&self.mount);
        (sensor, j_robot)
    }

    /// `seen` with the point its innovation is taken at, when configured.
    fn with_mid(&self, seen: Seen) -> Seen {
        let mid = (self.config.wall_innovation == WallInnovation::Segment)
            .then(|| segment_middle(&seen.z, &seen.local));
        Seen { mid, ..seen }
    }

    /// A wall scan: association, one batch update, extents grown, new walls admitted.
    pub(super) fn wall_scan(&mut self, detections: &[WallDetection]) -> Result<()> {
        let seen = detections
            .iter()
            .enumerate()
            .map(|(i, d)| checked(i, d))
            .map(|s| s.map(|s| self.with_mid(s)))
            .collect::<Result<Vec<_>>>()?;
        // Detections with a loose angle are left out (`wall_max_angle_sd`): no
        // options, never admitted, paired with `None`.
        let limit = self.config.wall_max_angle_sd.powi(2);
        let vague: Vec<bool> = seen.iter().map(|s| s.r[(1, 1)] > limit).collect();
        self.stats.walls_vague += vague.iter().filter(|&&v| v).count() as u64;
        self.association.begin_scan(seen.len())?;
        let new_gate = chi2_gate(2, self.config.wall_admission_confidence)?;
        let (mut options, near) = self.wall_options(&seen, new_gate);
        for (o, _) in options.iter_mut().zip(&vague).filter(|(_, v)| **v) {
            o.clear();
        }
        let pairings = self.choose(&options);
        self.wall_map.start_scan(seen.len());
        if !pairings.is_empty() {
            let ids: Vec<u64> = pairings.iter().map(|p| self.target_id(p.target)).collect();
            let zs: Vec<Vector2<f64>> = seen.iter().map(|s| s.z).collect();
            // The stretches seen, placed before the update moves the walls, as
            // their pairings were made.
            let parts = self.parts_seen(&pairings, &ids, &seen);
            self.apply(&pairings, &zs)?;
            for (id, part) in ids.iter().zip(parts) {
                self.wall_map.keep_part(*id, part);
            }
            self.stats.walls_accepted += pairings.len() as u64;
            for (p, id) in pairings.iter().zip(ids) {
                self.extend(id, &seen[p.det]);
                self.wall_map.pair(p.det, id);
            }
        }
        for (i, opts) in options.iter().enumerate() {
            if self.wall_map.is_paired(i) || vague[i] {
                continue;
            }
            if opts.is_empty() && !near[i] {
                let id = self.fresh_id();
                self.admit_wall(id, &seen[i])?;
                self.wall_map.pair(i, id);
            } else {
                // Compatible with a wall but left out, or outside the gate of an
                // overlapping wall but inside the admission gate (the gate's tail:
                // it would otherwise duplicate a wall every few scans): ambiguous,
                // not new.
                self.stats.walls_rejected += 1;
            }
        }
        self.wall_map.end_scan();
        Ok(())
    }

    /// The stretch of its wall each pairing's detection covers (`None` for a wall
    /// no longer in the map).
    fn parts_seen(
        &self,
        pairings: &[Pairing],
        ids: &[u64],
        seen: &[Seen],
    ) -> Vec<Option<(f64, f64)>> {
        let (sensor, _) = self.sensor();
        pairings
            .iter()
            .zip(ids)
            .map(|(p, id)| {
                let (line, _, _) = self.wall_line(*id)?;
                let origin = self.wall_map.extent(*id)?.origin;
                Some(part_on(&in_frame(&line, &origin), &sensor, &seen[p.det]))
            })
            .collect()
    }

    /// Every wall (state or fixed) whose extent overlaps the detection's segment
    /// within `wall_overlap_gap` and whose pairing passes the gate, by NIS; and
    /// whether some overlapping wall is within `new_gate`, the wider gate a detection
    /// must fail for every wall to become a new one.
    fn wall_options(&self, seen: &[Seen], new_gate: f64) -> (Vec<Vec<Pairing>>, Vec<bool>) {
        let scene = self.scene();
        let sensor = self.sensor();
        let targets = self.wall_targets();
        let shared_sd = self.config.wall_shared_sd;
        seen.iter()
            .enumerate()
            .map(|(i, s)| {
                let ends = s.local.map(|p| sensor.0.transform_point(&p));
                let mut o: Vec<Pairing> = targets
                    .iter()
                    .filter(|w| {
                        let line = in_frame(&w.line, &w.extent.origin);
                        gap(&line, w.extent, &ends) <= self.config.wall_overlap_gap
                    })
                    .filter_map(|w| wall_pairing(&scene, &sensor, i, s, w, shared_sd))
                    .filter(|p| p.nis <= new_gate)
                    .collect();
                let near = !o.is_empty();
                o.retain(|p| p.nis <= self.association.gates().individual());
                o.sort_by(|a, b| a.nis.total_cmp(&b.nis));
                (o, near)
            })
            .unzip()
    }

    /// The walls of the map: in the state, then fixed.
    fn wall_targets(&self) -> Vec<WallTarget<'_>> {
        let x = self.ekf.state();
        let mut targets = Vec::new();
        for (j, id) in self.ekf.landmark_ids().iter().enumerate() {
            if let Some(extent) = self.wall_map.extent(*id) {
                let line = Vector2::new(x[self.offset_of(j)], x[self.offset_of(j) + 1]);
                let first = self
                    .wall_map
                    .first_estimate(*id)
                    .filter(|_| self.config.first_estimates);
                targets.push(WallTarget {
                    target: Target::State(j),
                    line,
                    linearised: first.copied().unwrap_or(line),
                    fixed: None,
                    extent,
                    parts: self.wall_map.parts(*id),
                });
            }
        }
        for (k, (f, id)) in self.wall_map.fixed().enumerate() {
            if let Some(extent) = self.wall_map.extent(id) {
                targets.push(WallTarget {
                    target: Target::FixedWall(k),
                    line: f.line,
                    linearised: f.line,
                    fixed: Some(&f.cov),
                    extent,
                    parts: self.wall_map.parts(id),
                });
            }
        }
        targets
    }

    /// JCBB when configured (one detection per wall), otherwise each detection its
    /// nearest wall: unlike a point, a wall is often seen as two segments in one
    /// scan (split by an occluding object), and each is a sighting of it with its
    /// own noise (walls carry no ids).
    fn choose(&mut self, options: &[Vec<Pairing>]) -> Vec<Pairing> {
        let nearest = |o: &[Vec<Pairing>]| o.iter().filter_map(|o| o.first().cloned()).collect();
        let (pairings, truncated) = self.association.choose(&self.scene(), options, nearest);
        self.stats.jcbb_truncated += u64::from(truncated);
        pairings
    }

    /// Wall `id`'s line, covariance and whether it is frozen, from the state or the
    /// fixed walls (internal frame).
    fn wall_line(&self, id: u64) -> Option<(Vector2<f64>, Matrix2<f64>, bool)> {
        if let Some(j) = self.ekf.landmark_index(id) {
            let off = self.offset_of(j);
            let x = self.ekf.state();
            let c = self.ekf.covariance_block_fixed::<2, 2>(off, off)?;
            return Some((Vector2::new(x[off], x[off + 1]), c, self.ekf.is_consider(j)));
        }
        let f = self.wall_map.fixed_wall(id)?;
        Some((f.line, f.cov, true))
    }

    /// Grows wall `id`'s extent by the detection's segment, placed with the updated
    /// pose and projected on the updated line.
    fn extend(&mut self, id: u64, seen: &Seen) {
        let (sensor, _) = self.sensor();
        let Some((line, _, _)) = self.wall_line(id) else {
            return;
        };
        if let Some(e) = self.wall_map.extent_mut(id) {
            let [a, b] = seen.local.map(|p| sensor.transform_point(&p));
            *e = covering(
                &in_frame(&line, &e.origin),
                &[e.start, e.end, a, b],
                e.origin,
            );
        }
    }

    /// A new wall from detection `seen`: `l = g(robot, z)` about the middle of the
    /// seen segment (its reference point), with the full cross-covariance; the first
    /// landmark becomes the anchor when that variant is on.
    fn admit_wall(&mut self, id: u64, seen: &Seen) -> Result<()> {
        let (sensor, j_sensor) = self.sensor();
        let ends = seen.local.map(|p| sensor.transform_point(&p));
        let origin = Point2::from((ends[0].coords + ends[1].coords) * 0.5);
        let w = wall_to_world(&about(&sensor, &origin), &seen.z)
            .ok_or_else(|| SlamError::invalid("wall", "is not finite".into()))?;
        // With first estimates the robot's position is linearised at its prediction
        // (the updates of this scan moved it by `update_shift`), as every observation
        // of this scan was: the new wall then moves with the map's unobservable
        // rotation exactly as the others do.
        let w_lin = if self.config.first_estimates {
            let prior = Pose2::new(
                sensor.x - self.update_shift.x,
                sensor.y - self.update_shift.y,
                sensor.theta,
            );
            let mut lin = wall_to_world(&about(&prior, &origin), &seen.z)
                .ok_or_else(|| SlamError::invalid("wall", "is not finite".into()))?;
            // About its own point a wall's rho is near zero: keep the mean's form.
            if lin.d_wall[(0, 0)] != w.d_wall[(0, 0)] {
                lin.d_pose.row_mut(0).neg_mut();
                lin.d_wall.row_mut(0).neg_mut();
            }
            lin
        } else {
            w
        };
        let g_robot = w_lin.d_pose * j_sensor;
        // The anchor leaves the filter at once: it has no first estimate.
        let anchors = self.config.anchor && self.anchor.is_none() && self.ekf.num_landmarks() == 0;
        let first = if anchors {
            self.make_wall_anchor(id, &w, &g_robot, &seen.r, &origin)?;
            None
        } else {
            self.ekf.add_landmark_with_id(
                id,
                &DVector::from_column_slice(w.wall.as_slice()),
                &self.robot_block(&g_robot),
                &dyn_mat(&w_lin.d_wall),
                &dyn_mat(&seen.r),
            )?;
            Some(w.wall)
        };
        let extent = covering(&in_frame(&w.wall, &origin), &ends, origin);
        self.wall_map.add(id, extent, first);
        self.revisions.insert(id, 0);
        self.stats.walls_new += 1;
        Ok(())
    }

    /// The first wall as the global reference (the wall form of eqs. 24-25): it is
    /// fixed at its first estimate `w^` (about its reference point `o`), and the
    /// robot is re-expressed in the frame where the true wall sits there. That frame
    /// is the world rotated about `o` by `alpha^ - alpha` and moved along the normal
    /// by `rho^ - rho`, so to first order the robot's error becomes `J_r e + J_z e_z`
    /// with `J_r = I + M G_r`, `J_z = M G_z`, and `M`'s columns the robot's motion per
    /// unit of the wall's rho and alpha: `(-cos a, -sin a, 0)` and
    /// `(y - o_y, o_x - x, -1)`. The distance to the wall and the heading then carry
    /// only the sighting's noise; the position along the wall keeps its prior
    /// uncertainty.
    fn make_wall_anchor(
        &mut self,
        id: u64,
        w: &WallJacobians,
        g_robot: &Matrix2x3<f64>,
        r: &Matrix2<f64>,
        origin: &Point2<f64>,
    ) -> Result<()> {
        let robot = self.robot();
        let (s, c) = w.wall.y.sin_cos();
        let (x, y) = (robot.x - origin.x, robot.y - origin.y);
        let m = Matrix3x2::new(-c, y, -s, -x, 0.0, -1.0);
        let j_r = Matrix3::identity() + m * g_robot;
        let j_z = m * w.d_wall;
        let pose = self.ekf.state().fixed_rows::<3>(0).into_owned();
        self.reanchor(&pose, &j_r, &(j_z * r * j_z.transpose()))?;
        let line = w.wall;
        let cov = Matrix2::zeros();
        self.wall_map.fix(id, FixedWall { line, cov });
        self.anchored_at(id);
        Ok(())
    }
}

/// The wall map and the last scan's pairing.
impl PlanarSlam {
    /// The walls in the world frame, sorted by id.
    pub fn walls(&self) -> Vec<WallEstimate> {
        let mut out: Vec<WallEstimate> = self
            .wall_map
            .extents()
            .filter_map(|(id, e)| {
                let (line, cov, frozen) = self.wall_line(id)?;
                Some(self.wall_estimate(id, line, cov, frozen, e))
            })
            .collect();
        out.sort_by_key(|w| w.id);
        out
    }

    /// For each wall of the last wall scan, the wall it was paired with or admitted
    /// as (`None`: compatible with some wall but left out).
    pub fn last_wall_pairing(&self) -> &[Option<u64>] {
        self.wall_map.last_pairing()
    }

    /// A wall (about its reference point) in the world frame: about the world's
    /// origin (the reference point shifted by a point anchor's offset, `p`),
    /// `rho_w = rho + n(alpha) . p` with covariance `J C J^T`,
    /// `J = [[1, n'(alpha) . p], [0, 1]]`; written with `rho >= 0`: the flip
    /// `(-rho, alpha + pi)` negates the covariance's off-diagonal.
    fn wall_estimate(
        &self,
        id: u64,
        line: Vector2<f64>,
        cov: Matrix2<f64>,
        frozen: bool,
        e: &Extent,
    ) -> WallEstimate {
        let o = self.offset;
        let p = e.origin + o;
        let (s, c) = line.y.sin_cos();
        let j = Matrix2::new(1.0, -s * p.x + c * p.y, 0.0, 1.0);
        let cov = j * cov * j.transpose();
        let rho = in_frame(&line, &p).x;
        let (rho, alpha, sign) = if rho < 0.0 {
            (-rho, line.y + PI, -1.0)
        } else {
            (rho, line.y, 1.0)
        };
        let anchor = Some(id) == self.anchor;
        let (a, b) = (e.start, e.end);
        WallEstimate {
            id,
            line: [rho, wrap_angle(alpha)],
            covariance: [
                cov[(0, 0)],
                sign * cov[(0, 1)],
                sign * cov[(1, 0)],
                cov[(1, 1)],
            ],
            start: [a.x + o.x, a.y + o.y],
            end: [b.x + o.x, b.y + o.y],
            origin: [p.x, p.y],
            revisions: self.revisions.get(&id).copied().unwrap_or(0),
            frozen: frozen && !anchor,
            anchor,
        }
    }
}
