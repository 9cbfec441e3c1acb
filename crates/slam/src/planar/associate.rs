//! Data association for the planar engine: individual compatibility (a Mahalanobis
//! chi-square gate on each detection-landmark pairing), nearest neighbour, and joint
//! compatibility branch and bound (JCBB, Neira & Tardos 2001) searched with an
//! explicit stack and a bound on the number of nodes visited.

use nalgebra::{Matrix2, Matrix2x3, Matrix3, Matrix3x2, Point2, Vector2};
use rperc_core::{Pose2, wrap_angle};

use super::observe::observe_from;
use crate::ekf::Ekf;

/// What a detection is paired with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Target {
    /// Landmark `j` of the filter's state.
    State(usize),
    /// Entry `k` of the fixed points (frozen landmarks, the anchor).
    Fixed(usize),
    /// Entry `k` of the fixed walls (frozen walls, a wall anchor).
    FixedWall(usize),
}

/// A point the filter no longer estimates (a frozen landmark, or the anchor with a
/// zero covariance): it is observed as known, its covariance added to the noise.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct FixedPoint {
    pub mean: Point2<f64>,
    pub cov: Matrix2<f64>,
}

/// One detection-target pairing linearised at the prior state.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Pairing {
    pub det: usize,
    pub target: Target,
    /// Innovation `z - h(x)`, bearing wrapped.
    pub nu: Vector2<f64>,
    pub h_robot: Matrix2x3<f64>,
    /// Zero for a fixed point.
    pub h_landmark: Matrix2<f64>,
    /// State offset of the landmark (State targets).
    pub offset: Option<usize>,
    /// Noise `W`, plus `H_l P_f H_l^T` for a fixed point.
    pub r: Matrix2<f64>,
    /// The pairing's own NIS.
    pub nis: f64,
}

/// The prior the association works against.
pub(crate) struct Scene<'a> {
    pub ekf: &'a Ekf,
    pub robot: Pose2,
    pub mount: Pose2,
    pub w: Matrix2<f64>,
    pub fixed: &'a [FixedPoint],
    prr: Matrix3<f64>,
    /// The sensor's pose (`robot` composed with `mount`) and its Jacobian wrt the
    /// robot, made once for every landmark tested against the scan.
    sensor: Pose2,
    j_sensor: Matrix3<f64>,
    /// `walls[j]`: state landmark `j` is a wall (empty: no walls), so point
    /// detections are never tried against it.
    walls: Vec<bool>,
    /// `first[j]`: where state point `j` entered the map, the point its observation
    /// is linearised at with `first_estimates` (empty: at the current estimates).
    first: Vec<Option<Point2<f64>>>,
}

impl<'a> Scene<'a> {
    pub fn new(ekf: &'a Ekf, mount: Pose2, w: Matrix2<f64>, fixed: &'a [FixedPoint]) -> Self {
        let x = ekf.state();
        let robot = Pose2::new(x[0], x[1], x[2]);
        // The pose block (a robot block with bias states is longer).
        let prr = ekf
            .covariance_block_fixed::<3, 3>(0, 0)
            .unwrap_or_else(Matrix3::zeros);
        let (sensor, j_sensor, _) = robot.compose_with_jacobians(&mount);
        Self {
            ekf,
            robot,
            mount,
            sensor,
            j_sensor,
            w,
            fixed,
            prr,
            walls: Vec::new(),
            first: Vec::new(),
        }
    }

    /// Linearises each state point `j` with `first[j]` at that first estimate
    /// (Huang, Mourikis & Roumeliotis 2008) instead of its current one.
    pub fn with_first_estimates(mut self, first: Vec<Option<Point2<f64>>>) -> Self {
        self.first = first;
        self
    }

    /// Marks which state landmarks are walls (see [`Scene::is_wall`]).
    pub fn with_walls(mut self, walls: Vec<bool>) -> Self {
        self.walls = walls;
        self
    }

    /// Whether state landmark `j` is a wall.
    pub fn is_wall(&self, j: usize) -> bool {
        self.walls.get(j).copied().unwrap_or(false)
    }

    /// A point target's position and state offset; `None` for a wall.
    fn landmark(&self, target: Target) -> Option<(Point2<f64>, Option<usize>)> {
        match target {
            Target::State(j) if !self.is_wall(j) => {
                let off = self.ekf.robot_dim() + 2 * j;
                let x = self.ekf.state();
                Some((Point2::new(x[off], x[off + 1]), Some(off)))
            }
            Target::Fixed(k) => Some((self.fixed[k].mean, None)),
            _ => None,
        }
    }

    /// The pairing of detection `det` (measured `z`) with `target`; `None` when the
    /// target sits on the sensor or `S` is singular.
    pub fn pairing(&self, det: usize, z: &Vector2<f64>, target: Target) -> Option<Pairing> {
        self.linearise(target)?.pairing(det, z)
    }

    /// What a pairing with `target` needs before any detection: the linearisation at
    /// the prior and `S^-1`; `None` when the target sits on the sensor or `S` is
    /// singular.
    fn linearise(&self, target: Target) -> Option<Linearised> {
        let (l, offset) = self.landmark(target)?;
        let (predicted, mut h_robot, mut h_l) = observe_from(&self.sensor, &self.j_sensor, &l)?;
        // First estimates: the Jacobians at the point's first estimate, the predicted
        // detection at its current one (the innovation stays the EKF's).
        if let Target::State(j) = target
            && let Some(Some(first)) = self.first.get(j)
        {
            (_, h_robot, h_l) = observe_from(&self.sensor, &self.j_sensor, first)?;
        }
        let (h_landmark, r) = match target {
            // Frozen: the landmark is known with its frozen covariance (text under Fig. 7).
            Target::Fixed(k) => (
                Matrix2::zeros(),
                self.w + h_l * self.fixed[k].cov * h_l.transpose(),
            ),
            _ => (h_l, self.w),
        };
        let template = Pairing {
            det: 0,
            target,
            nu: Vector2::zeros(),
            h_robot,
            h_landmark,
            offset,
            r,
            nis: 0.0,
        };
        let s = self.cross(&template, &template) + template.r;
        Some(Linearised {
            s_inv: s.try_inverse()?,
            predicted,
            template,
        })
    }

    /// The pairing of detection `det` with `target` from its innovation, its
    /// Jacobians `(H_robot, H_landmark, landmark offset)` and noise, with its NIS
    /// `nu^T S^-1 nu`, `S = H P H^T + R` (points and walls alike); `None` when `S`
    /// is singular or the NIS is not finite.
    pub fn scored(
        &self,
        det: usize,
        target: Target,
        nu: Vector2<f64>,
        (h_robot, h_landmark, offset): (Matrix2x3<f64>, Matrix2<f64>, Option<usize>),
        r: Matrix2<f64>,
    ) -> Option<Pairing> {
        let mut p = Pairing {
            det,
            target,
            nu,
            h_robot,
            h_landmark,
            offset,
            r,
            nis: 0.0,
        };
        let s = self.cross(&p, &p) + p.r;
        p.nis = nu.dot(&(s.try_inverse()? * nu));
        p.nis.is_finite().then_some(p)
    }

    /// `H_a P H_b^T` from the robot, landmark and cross blocks of `P` (read as
    /// fixed-size blocks, no allocation: JCBB calls this at every node).
    pub fn cross(&self, a: &Pairing, b: &Pairing) -> Matrix2<f64> {
        let block = |r: usize, c: usize| -> Matrix3x2<f64> {
            self.ekf
                .covariance_block_fixed::<3, 2>(r, c)
                .expect("landmark offset inside the state")
        };
        let mut s = a.h_robot * self.prr * b.h_robot.transpose();
        if let Some(ob) = b.offset {
            s += a.h_robot * block(0, ob) * b.h_landmark.transpose();
        }
        if let Some(oa) = a.offset {
            s += a.h_landmark * block(0, oa).transpose() * b.h_robot.transpose();
            if let Some(ob) = b.offset {
                let pab = self
                    .ekf
                    .covariance_block_fixed::<2, 2>(oa, ob)
                    .expect("landmark offsets inside the state");
                s += a.h_landmark * pab * b.h_landmark.transpose();
            }
        }
        s
    }
}

/// A target linearised at the prior (see [`Scene::linearise`]): the pairings of
/// several detections with it share it.
struct Linearised {
    template: Pairing,
    predicted: Vector2<f64>,
    s_inv: Matrix2<f64>,
}

impl Linearised {
    /// The pairing of detection `det` (measured `z`); `None` when its NIS is not finite.
    fn pairing(&self, det: usize, z: &Vector2<f64>) -> Option<Pairing> {
        let nu = Vector2::new(z.x - self.predicted.x, wrap_angle(z.y - self.predicted.y));
        let nis = nu.dot(&(self.s_inv * nu));
        nis.is_finite().then(|| Pairing {
            det,
            nu,
            nis,
            ..self.template.clone()
        })
    }
}

/// A cheap, conservative screen of one target: its predicted range and bearing and
/// upper bounds of the diagonal of `S` for any detection of it.
///
/// For any SPD `S`, `nu^T S^-1 nu >= nu_i^2 / S_ii` (Cauchy-Schwarz), and for the PSD
/// joint covariance of robot and landmark, `h P h^T <= 2 (|h_r|^2 tr P_rr + |h_l|^2
/// tr P_ll)`. With `|dr/d robot|^2 <= 1 + |m|^2`, `|dr/dl| = 1`, `|db/d robot|^2 <=
/// 1/r^2 + (1 + |m|/r)^2` and `|db/dl| = 1/r` (`m` the sensor mount), a detection whose
/// range or bearing innovation exceeds `gate * bound` cannot be individually
/// compatible: the screen never drops a pairing the full test would keep.
struct Screen {
    range: f64,
    bearing: f64,
    range_bound: f64,
    bearing_bound: f64,
}

impl Scene<'_> {
    fn screen(&self, target: Target) -> Option<Screen> {
        let (l, offset) = self.landmark(target)?;
        let tr_landmark = match (target, offset) {
            (Target::State(_), Some(o)) => {
                let x = self.ekf.covariance_block_fixed::<2, 2>(o, o)?;
                x.trace()
            }
            (Target::Fixed(k), _) => self.fixed[k].cov.trace(),
            _ => 0.0,
        };
        self.screen_point(&l, tr_landmark)
    }

    /// The screen of a point at `l` whose own covariance has a trace of at most
    /// `tr_landmark` (a larger trace only widens the bounds).
    fn screen_point(&self, l: &Point2<f64>, tr_landmark: f64) -> Option<Screen> {
        let sensor = &self.sensor;
        let (dx, dy) = (l.x - sensor.x, l.y - sensor.y);
        let r = dx.hypot(dy);
        // A landmark on the sensor (or a NaN) has no bearing: `pairing` refuses it too.
        if r.is_nan() || r <= 0.0 {
            return None;
        }
        let tr_robot = self.prr.trace();
        let m = self.mount.translation().norm();
        let range_bound = self.range_bound(tr_landmark);
        let hb = 1.0 / (r * r) + (1.0 + m / r).powi(2);
        let bearing_bound = 2.0 * (hb * tr_robot + tr_landmark / (r * r)) + self.w[(1, 1)];
        Some(Screen {
            range: r,
            bearing: wrap_angle(dy.atan2(dx) - sensor.theta),
            range_bound,
            bearing_bound,
        })
    }
}

impl Screen {
    fn may_pass(&self, z: &Vector2<f64>, gate: f64) -> bool {
        let (er, eb) = (z.x - self.range, wrap_angle(z.y - self.bearing));
        er * er <= gate * self.range_bound && eb * eb <= gate * self.bearing_bound
    }
}

impl Scene<'_> {
    /// Whether a landmark at `l`, whose own covariance has a trace of at most
    /// `tr_landmark`, may be individually compatible with one of `detections` (the
    /// exact [`Screen`]: `false` only when the gate would refuse every pairing).
    pub fn may_observe(
        &self,
        l: &Point2<f64>,
        tr_landmark: f64,
        detections: &[Vector2<f64>],
        gate: f64,
    ) -> bool {
        self.screen_point(l, tr_landmark)
            .is_some_and(|s| detections.iter().any(|z| s.may_pass(z, gate)))
    }

    /// Whether a landmark at `l` may be individually compatible with one of
    /// `detections`, given its cross-covariance with the robot `p_rl` and an upper
    /// bound `p_ll` (PSD order) of its own covariance: the `S` built with the bound is
    /// at least the true one, so its NIS is at most the true NIS, and `false` only
    /// when the gate refuses every pairing. Without `p_rl` (`None`, the cheap test
    /// before reading it), `S` is bounded by `2 H_r P_rr H_r^T + 2 H_l p_ll H_l^T + W`
    /// (`(a + b)(a + b)^T <= 2 a a^T + 2 b b^T` in the PSD order for the joint
    /// covariance of robot and landmark), still at least the true one.
    pub fn may_pair(
        &self,
        l: &Point2<f64>,
        p_rl: Option<&Matrix3x2<f64>>,
        p_ll: &Matrix2<f64>,
        detections: &[Vector2<f64>],
        gate: f64,
    ) -> bool {
        let Some((zp, hr, hl)) = observe_from(&self.sensor, &self.j_sensor, l) else {
            return false; // on the sensor: `pairing` refuses it too
        };
        let robot = hr * self.prr * hr.transpose();
        let own = hl * p_ll * hl.transpose();
        let s = match p_rl {
            Some(p_rl) => {
                let cross = hr * p_rl * hl.transpose();
                robot + cross + cross.transpose() + own + self.w
            }
            None => (robot + own) * 2.0 + self.w,
        };
        let Some(inv) = s.try_inverse() else {
            return true;
        };
        detections.iter().any(|z| {
            let nu = Vector2::new(z.x - zp.x, wrap_angle(z.y - zp.y));
            let nis = nu.dot(&(inv * nu));
            nis <= gate || nis.is_nan()
        })
    }

    /// The largest range innovation that can pass `gate` for a landmark whose own
    /// covariance has a trace of at most `tr_landmark`, m (the [`Screen`]'s range
    /// bound: a cheap first test by distance alone).
    pub fn range_reach(&self, tr_landmark: f64, gate: f64) -> f64 {
        (gate * self.range_bound(tr_landmark)).sqrt()
    }

    /// The [`Screen`]'s bound of `S_rr`.
    fn range_bound(&self, tr_landmark: f64) -> f64 {
        let m = self.mount.translation().norm();
        2.0 * ((1.0 + m * m) * self.prr.trace() + tr_landmark) + self.w[(0, 0)]
    }
}

/// Every pairing of each detection with each target whose NIS is within `gate`
/// (individual compatibility), sorted by NIS. Targets are first screened by
/// [`Screen`] (exact: it only skips pairings that would fail the gate), so the
/// full linearisation is made only for the landmarks near each detection.
pub(crate) fn compatible(
    scene: &Scene<'_>,
    detections: &[Vector2<f64>],
    gate: f64,
) -> Vec<Vec<Pairing>> {
    let targets: Vec<(Target, Screen)> = (0..scene.ekf.num_landmarks())
        .map(Target::State)
        .chain((0..scene.fixed.len()).map(Target::Fixed))
        .filter_map(|t| scene.screen(t).map(|s| (t, s)))
        .collect();
    let mut options = vec![Vec::new(); detections.len()];
    for (t, screen) in targets {
        // Linearised once, when a first detection passes the screen.
        let mut linearised: Option<Option<Linearised>> = None;
        for (i, z) in detections.iter().enumerate() {
            if !screen.may_pass(z, gate) {
                continue;
            }
            let lin = linearised.get_or_insert_with(|| scene.linearise(t));
            if let Some(p) = lin.as_ref().and_then(|l| l.pairing(i, z))
                && p.nis <= gate
            {
                options[i].push(p);
            }
        }
    }
    for o in &mut options {
        o.sort_by(|a, b| a.nis.total_cmp(&b.nis));
    }
    options
}

/// Nearest neighbour: each detection takes its most compatible target; when two
/// want the same target, the one with the smaller NIS keeps it and the other takes
/// its next choice (greedy over all pairings by increasing NIS).
pub(crate) fn nearest_neighbour(options: &[Vec<Pairing>]) -> Vec<Pairing> {
    let mut all: Vec<&Pairing> = options.iter().flatten().collect();
    all.sort_by(|a, b| a.nis.total_cmp(&b.nis));
    let mut taken_det = vec![false; options.len()];
    let mut taken_target = Vec::new();
    let mut chosen = Vec::new();
    for p in all {
        if !taken_det[p.det] && !taken_target.contains(&p.target) {
            taken_det[p.det] = true;
            taken_target.push(p.target);
            chosen.push(p.clone());
        }
    }
    chosen
}

/// The outcome of a JCBB search.
pub(crate) struct JcbbOutcome {
    pub pairings: Vec<Pairing>,
    /// The node budget ran out: the best hypothesis found so far is returned.
    pub truncated: bool,
}

/// The Cholesky factor of the joint innovation covariance `S_H` of the current
/// hypothesis, grown by two rows per pairing and shrunk by forgetting them, so a
/// node of the search costs O(k^2) (one forward substitution) instead of the O(k^3)
/// of a new factorisation. Buffers are sized once per scan: no allocation per node.
struct JointFactor<'s> {
    /// Row-major lower-triangular factor, `dim x dim`.
    chol: Vec<f64>,
    /// `y = chol^-1 nu_H`: the joint NIS is `|y|^2`.
    y: Vec<f64>,
    /// `nis[k]`: the joint NIS of the first `k` pairings.
    nis: Vec<f64>,
    /// The pairings of the hypothesis, in order.
    hyp: Vec<&'s Pairing>,
    /// Scratch: the two new columns of `S_H` and their forward substitution.
    x: Vec<[f64; 2]>,
    dim: usize,
}

impl<'s> JointFactor<'s> {
    fn new(max_pairings: usize) -> Self {
        let dim = 2 * max_pairings;
        Self {
            chol: vec![0.0; dim * dim],
            y: vec![0.0; dim],
            nis: {
                let mut v = Vec::with_capacity(max_pairings + 1);
                v.push(0.0);
                v
            },
            hyp: Vec::with_capacity(max_pairings),
            x: vec![[0.0; 2]; dim],
            dim,
        }
    }

    fn len(&self) -> usize {
        self.hyp.len()
    }

    fn joint_nis(&self) -> f64 {
        self.nis[self.len()]
    }

    /// Appends `p` when the extended hypothesis has a Cholesky factor and its joint
    /// NIS is within `gate`; `false` (and nothing changed) otherwise.
    fn push(&mut self, scene: &Scene<'_>, p: &'s Pairing, gate: f64) -> bool {
        let n = 2 * self.len();
        // New columns B = S_H[0..n, new] and their forward substitution X = L^-1 B.
        for (i, q) in self.hyp.iter().enumerate() {
            let b = scene.cross(q, p);
            self.x[2 * i] = [b[(0, 0)], b[(0, 1)]];
            self.x[2 * i + 1] = [b[(1, 0)], b[(1, 1)]];
        }
        for r in 0..n {
            let row = &self.chol[r * self.dim..r * self.dim + r + 1];
            for c in 0..2 {
                let dot: f64 = (0..r).map(|k| row[k] * self.x[k][c]).sum();
                self.x[r][c] = (self.x[r][c] - dot) / row[r];
            }
        }
        // The new 2x2 diagonal block: chol(D - X^T X).
        let mut d = scene.cross(p, p) + p.r;
        let mut rhs = p.nu;
        for r in 0..n {
            let xr = self.x[r];
            for (i, j) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
                d[(i, j)] -= xr[i] * xr[j];
            }
            rhs[0] -= xr[0] * self.y[r];
            rhs[1] -= xr[1] * self.y[r];
        }
        let l00 = d[(0, 0)].sqrt();
        let l10 = d[(1, 0)] / l00;
        let l11 = (d[(1, 1)] - l10 * l10).sqrt();
        // Not positive definite (or NaN): no factor, so not jointly compatible.
        let positive = l00 > 0.0 && l11 > 0.0 && l10.is_finite();
        if !positive {
            return false;
        }
        let y0 = rhs[0] / l00;
        let y1 = (rhs[1] - l10 * y0) / l11;
        let nis = self.joint_nis() + y0 * y0 + y1 * y1;
        if nis.is_nan() || nis > gate {
            return false;
        }
        for (r, diag) in [(n, [l00, 0.0]), (n + 1, [l10, l11])] {
            let row = &mut self.chol[r * self.dim..r * self.dim + n + 2];
            for (k, v) in row[..n].iter_mut().enumerate() {
                *v = self.x[k][r - n];
            }
            row[n..n + 2].copy_from_slice(&diag);
        }
        (self.y[n], self.y[n + 1]) = (y0, y1);
        self.nis.push(nis);
        self.hyp.push(p);
        true
    }

    fn pop(&mut self) {
        self.hyp.pop();
        self.nis.pop();
    }
}

/// JCBB (Neira & Tardos 2001): among the hypotheses (each detection paired with one
/// of its individually compatible targets, or with none; each target used at most
/// once) whose joint NIS is within the chi-square gate of its dimension
/// (`joint_gates[k]` for `k` pairings), the one with the most pairings, ties broken
/// by the smaller joint NIS. Depth first over the detections that have options, with
/// an explicit stack and the factor of `S_H` grown incrementally ([`JointFactor`]);
/// a branch is cut when even pairing every remaining detection could not beat the
/// best (the joint NIS only grows as pairings are added). At most `max_nodes`
/// joint-compatibility tests are made.
pub(crate) fn jcbb(
    scene: &Scene<'_>,
    options: &[Vec<Pairing>],
    joint_gates: &[f64],
    max_nodes: usize,
) -> JcbbOutcome {
    let levels: Vec<&[Pairing]> = options
        .iter()
        .filter(|o| !o.is_empty())
        .map(Vec::as_slice)
        .collect();
    let n = levels.len();
    let mut factor = JointFactor::new(n);
    // `next[level]`: the next option to try (`len()`: the null pairing); `paired[level]`:
    // whether the level took a pairing on the current path.
    let mut next = vec![0usize; n + 1];
    let mut paired: Vec<bool> = Vec::with_capacity(n);
    let mut best: Vec<&Pairing> = Vec::new();
    let mut best_nis = f64::INFINITY;
    let (mut nodes, mut truncated) = (0usize, false);
    loop {
        let level = paired.len();
        let (pairs, nis) = (factor.len(), factor.joint_nis());
        let reach = pairs + (n - level);
        let hopeless =
            reach < best.len() || (reach == best.len() && !best.is_empty() && nis >= best_nis);
        if level == n || hopeless {
            if level == n && (pairs > best.len() || (pairs == best.len() && nis < best_nis)) {
                best.clone_from(&factor.hyp);
                best_nis = nis;
            }
            if !backtrack(&mut paired, &mut factor) {
                break;
            }
            continue;
        }
        let k = next[level];
        next[level] += 1;
        if k < levels[level].len() {
            let candidate = &levels[level][k];
            if factor.hyp.iter().any(|q| q.target == candidate.target) {
                continue;
            }
            nodes += 1;
            if nodes > max_nodes {
                truncated = true;
                break;
            }
            if factor.push(scene, candidate, joint_gates[pairs + 1]) {
                paired.push(true);
                next[level + 1] = 0;
            }
        } else if k == levels[level].len() {
            paired.push(false);
            next[level + 1] = 0;
        } else if !backtrack(&mut paired, &mut factor) {
            break;
        }
    }
    JcbbOutcome {
        pairings: best.into_iter().cloned().collect(),
        truncated,
    }
}

/// Leaves the current level for the one above; `false` when the search is over.
fn backtrack(paired: &mut Vec<bool>, factor: &mut JointFactor<'_>) -> bool {
    match paired.pop() {
        Some(true) => {
            factor.pop();
            true
        }
        Some(false) => true,
        None => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector};
    use rand::{Rng, SeedableRng, rngs::StdRng};
    use rperc_core::chi2_gate;

    /// A robot with a large lateral uncertainty before three known landmarks; A at
    /// (5, 0), B at (5, 2) and C at (5, 2.6).
    fn scene_ekf() -> Ekf {
        let x = DVector::from_vec(vec![0.0, 0.0, 0.0, 5.0, 0.0, 5.0, 2.0, 5.0, 2.6]);
        let mut p = DMatrix::identity(9, 9) * 1e-6;
        p[(1, 1)] = 1.0;
        Ekf::new(x, p, 3, 2).unwrap().with_wrapped_angle(2).unwrap()
    }

    fn rb(x: f64, y: f64) -> Vector2<f64> {
        Vector2::new(x.hypot(y), y.atan2(x))
    }

    fn gates(n: usize) -> Vec<f64> {
        (0..=n)
            .map(|k| {
                if k == 0 {
                    0.0
                } else {
                    chi2_gate(2 * k, 0.99).unwrap()
                }
            })
            .collect()
    }

    /// The oracle: every assignment of detections to compatible targets or none,
    /// its joint NIS computed from the dense `H P H^T + R` and a fresh inverse; the
    /// jointly compatible hypothesis with the most pairings wins, ties broken by the
    /// smaller joint NIS. Returns its `(detection, target)` pairs, sorted.
    /// The joint NIS of a hypothesis (dense, from the whole covariance).
    fn joint_nis(p: &DMatrix<f64>, hyp: &[&Pairing]) -> f64 {
        let k = hyp.len();
        let mut h = DMatrix::zeros(2 * k, p.nrows());
        let mut r = DMatrix::zeros(2 * k, 2 * k);
        let mut nu = DVector::zeros(2 * k);
        for (i, a) in hyp.iter().enumerate() {
            h.view_mut((2 * i, 0), (2, 3)).copy_from(&a.h_robot);
            if let Some(o) = a.offset {
                h.view_mut((2 * i, o), (2, 2)).copy_from(&a.h_landmark);
            }
            r.view_mut((2 * i, 2 * i), (2, 2)).copy_from(&a.r);
            nu.rows_mut(2 * i, 2).copy_from(&a.nu);
        }
        let s = &h * p * h.transpose() + r;
        nu.dot(&(s.try_inverse().unwrap() * &nu))
    }

    fn brute_force(ekf: &Ekf, options: &[Vec<Pairing>], gates: &[f64]) -> Vec<(usize, Target)> {
        let p = ekf.covariance();
        let mut best: (usize, f64, Vec<(usize, Target)>) = (0, f64::INFINITY, Vec::new());
        let mut choice = vec![0usize; options.len()];
        loop {
            let hyp: Vec<&Pairing> = choice
                .iter()
                .enumerate()
                .filter(|(i, c)| **c < options[*i].len())
                .map(|(i, c)| &options[i][*c])
                .collect();
            let distinct = hyp
                .iter()
                .enumerate()
                .all(|(i, a)| hyp[i + 1..].iter().all(|b| b.target != a.target));
            if distinct && !hyp.is_empty() {
                // JCBB's hypotheses are those whose every prefix (in observation order)
                // is jointly compatible, as Neira and Tardos grow them.
                let k = hyp.len();
                let nis = joint_nis(&p, &hyp);
                let prefixes = (1..k).all(|j| joint_nis(&p, &hyp[..j]) <= gates[j]);
                if prefixes && nis <= gates[k] && (k > best.0 || (k == best.0 && nis < best.1)) {
                    let mut pairs: Vec<_> = hyp.iter().map(|a| (a.det, a.target)).collect();
                    pairs.sort_by_key(|p| p.0);
                    best = (k, nis, pairs);
                }
            }
            // Next assignment (odometer over options + the null choice).
            let mut i = 0;
            while i < choice.len() {
                choice[i] += 1;
                if choice[i] <= options[i].len() {
                    break;
                }
                choice[i] = 0;
                i += 1;
            }
            if i == choice.len() {
                return best.2;
            }
        }
    }

    fn sorted(out: &JcbbOutcome) -> Vec<(usize, Target)> {
        let mut got: Vec<_> = out.pairings.iter().map(|p| (p.det, p.target)).collect();
        got.sort_by_key(|p| p.0);
        got
    }

    /// A random small world: a robot with an uncertain pose, `n` landmarks in a
    /// cluster (so that several are individually compatible with one detection),
    /// a dense random SPD covariance, and detections of some landmarks plus clutter.
    fn random_case(rng: &mut StdRng) -> (Ekf, Vec<Vector2<f64>>) {
        let n = rng.random_range(2..6);
        let d = 3 + 2 * n;
        let mut x = DVector::zeros(d);
        x[2] = rng.random_range(-0.3..0.3);
        for j in 0..n {
            x[3 + 2 * j] = rng.random_range(4.0..8.0);
            x[4 + 2 * j] = rng.random_range(-2.0..2.0);
        }
        let a = DMatrix::from_fn(d, d, |_, _| rng.random_range(-0.15..0.15));
        let p = &a * a.transpose() + DMatrix::identity(d, d) * 0.01;
        let ekf = Ekf::new(x.clone(), p, 3, 2)
            .unwrap()
            .with_wrapped_angle(2)
            .unwrap();
        let mut dets = Vec::new();
        for j in 0..n {
            if rng.random_bool(0.8) {
                let lx = x[3 + 2 * j] + rng.random_range(-0.3..0.3);
                let ly = x[4 + 2 * j] + rng.random_range(-0.3..0.3);
                let (c, s) = (x[2].cos(), x[2].sin());
                dets.push(rb(c * lx + s * ly, -s * lx + c * ly));
            }
        }
        if rng.random_bool(0.5) {
            dets.push(rb(rng.random_range(4.0..8.0), rng.random_range(-2.0..2.0)));
        }
        (ekf, dets)
    }

    /// JCBB (incremental factor, branch and bound) returns exactly the hypothesis of
    /// the exhaustive search, on random small cases with ambiguous detections.
    #[test]
    fn jcbb_equals_brute_force_on_random_cases() {
        let mut rng = StdRng::seed_from_u64(10);
        let w = Matrix2::new(0.02, 0.0, 0.0, 1e-3);
        let mut ambiguous = 0;
        for _ in 0..300 {
            let (ekf, dets) = random_case(&mut rng);
            let scene = Scene::new(&ekf, Pose2::new(0.5, 0.2, 0.0), w, &[]);
            let options = compatible(&scene, &dets, chi2_gate(2, 0.99).unwrap());
            ambiguous += usize::from(options.iter().any(|o| o.len() > 1));
            let g = gates(dets.len());
            let out = jcbb(&scene, &options, &g, 1_000_000);
            assert!(!out.truncated);
            assert_eq!(sorted(&out), brute_force(&ekf, &options, &g));
        }
        // The cases exercise the search, not only unambiguous pairings.
        assert!(ambiguous > 50, "{ambiguous}");
    }

    /// The screen in `compatible` is exact: it keeps every pairing whose full NIS is
    /// within the gate (compared with linearising every detection-target pair).
    #[test]
    fn screening_keeps_every_compatible_pairing() {
        let mut rng = StdRng::seed_from_u64(11);
        let w = Matrix2::new(0.02, 0.0, 0.0, 1e-3);
        let gate = chi2_gate(2, 0.99).unwrap();
        for _ in 0..300 {
            let (ekf, dets) = random_case(&mut rng);
            let scene = Scene::new(&ekf, Pose2::new(0.5, 0.2, 0.0), w, &[]);
            let screened = compatible(&scene, &dets, gate);
            for (i, z) in dets.iter().enumerate() {
                let mut all: Vec<Target> = (0..ekf.num_landmarks())
                    .map(Target::State)
                    .filter(|&t| scene.pairing(i, z, t).is_some_and(|p| p.nis <= gate))
                    .collect();
                let mut got: Vec<Target> = screened[i].iter().map(|p| p.target).collect();
                all.sort_by_key(|t| format!("{t:?}"));
                got.sort_by_key(|t| format!("{t:?}"));
                assert_eq!(got, all);
            }
        }
    }

    /// Detection 0 sees A where it is (pinning the robot at y = 0); detection 1 is
    /// a spurious echo at (5, 2.5). Alone, it is compatible with both B and C (the
    /// robot may be anywhere laterally) and nearest neighbour takes C; jointly with
    /// detection 0 neither fits, and JCBB leaves it unpaired.
    #[test]
    fn jcbb_rejects_a_planted_false_association_that_nn_accepts() {
        let ekf = scene_ekf();
        let w = Matrix2::new(1e-4, 0.0, 0.0, 1e-6);
        let scene = Scene::new(&ekf, Pose2::identity(), w, &[]);
        let dets = [rb(5.0, 0.0), rb(5.0, 2.5)];
        let options = compatible(&scene, &dets, chi2_gate(2, 0.99).unwrap());
        assert!(options[1].iter().any(|p| p.target == Target::State(2)));
        let nn = nearest_neighbour(&options);
        assert!(
            nn.iter()
                .any(|p| p.det == 1 && p.target == Target::State(2))
        );
        let g = gates(2);
        let out = jcbb(&scene, &options, &g, 10_000);
        assert!(!out.truncated);
        assert_eq!(out.pairings.len(), 1);
        assert_eq!(
            (out.pairings[0].det, out.pairings[0].target),
            (0, Target::State(0))
        );
        assert_eq!(sorted(&out), brute_force(&ekf, &options, &g));
    }

    /// With honest detections of all three, JCBB pairs each with its own landmark,
    /// and the size of its hypothesis equals the brute-force optimum.
    #[test]
    fn jcbb_finds_the_true_association_and_matches_brute_force() {
        let ekf = scene_ekf();
        let w = Matrix2::new(1e-4, 0.0, 0.0, 1e-6);
        let scene = Scene::new(&ekf, Pose2::identity(), w, &[]);
        // The robot is truly 0.3 m to the left: every landmark appears 0.3 m lower.
        let dets = [rb(5.0, 2.3), rb(5.0, -0.3), rb(5.0, 1.7)];
        let options = compatible(&scene, &dets, chi2_gate(2, 0.99).unwrap());
        let g = gates(3);
        let out = jcbb(&scene, &options, &g, 10_000);
        let mut got: Vec<_> = out.pairings.iter().map(|p| (p.det, p.target)).collect();
        got.sort_by_key(|p| p.0);
        assert_eq!(
            got,
            vec![
                (0, Target::State(2)),
                (1, Target::State(0)),
                (2, Target::State(1))
            ]
        );
        assert_eq!(got, brute_force(&ekf, &options, &g));
        // A budget of one node stops the search and says so.
        assert!(jcbb(&scene, &options, &g, 1).truncated);
    }
}
