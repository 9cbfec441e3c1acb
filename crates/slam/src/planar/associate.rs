//! Data association for the planar engine: individual compatibility (a Mahalanobis
//! chi-square gate on each detection-landmark pairing), nearest neighbour, and joint
//! compatibility branch and bound (JCBB, Neira & Tardos 2001) searched with an
//! explicit stack and a bound on the number of nodes visited.

use nalgebra::{DMatrix, DVector, Matrix2, Matrix2x3, Matrix3, Matrix3x2, Point2, Vector2};
use rperc_core::{Pose2, wrap_angle};

use super::observe::observe;
use crate::ekf::Ekf;

/// What a detection is paired with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Target {
    /// Landmark `j` of the filter's state.
    State(usize),
    /// Entry `k` of the fixed points (frozen landmarks, the anchor).
    Fixed(usize),
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
}

fn fixed3x2(m: &DMatrix<f64>) -> Matrix3x2<f64> {
    Matrix3x2::from_column_slice(m.as_slice())
}

fn fixed2(m: &DMatrix<f64>) -> Matrix2<f64> {
    Matrix2::from_column_slice(m.as_slice())
}

impl<'a> Scene<'a> {
    pub fn new(ekf: &'a Ekf, mount: Pose2, w: Matrix2<f64>, fixed: &'a [FixedPoint]) -> Self {
        let x = ekf.state();
        let robot = Pose2::new(x[0], x[1], x[2]);
        let prr = Matrix3::from_column_slice(ekf.robot_covariance().as_slice());
        Self {
            ekf,
            robot,
            mount,
            w,
            fixed,
            prr,
        }
    }

    fn landmark(&self, target: Target) -> (Point2<f64>, Option<usize>) {
        match target {
            Target::State(j) => {
                let off = 3 + 2 * j;
                let x = self.ekf.state();
                (Point2::new(x[off], x[off + 1]), Some(off))
            }
            Target::Fixed(k) => (self.fixed[k].mean, None),
        }
    }

    /// The pairing of detection `det` (measured `z`) with `target`; `None` when the
    /// target sits on the sensor or `S` is singular.
    pub fn pairing(&self, det: usize, z: &Vector2<f64>, target: Target) -> Option<Pairing> {
        let (l, offset) = self.landmark(target);
        let (zp, h_robot, h_l) = observe(&self.robot, &self.mount, &l)?;
        let nu = Vector2::new(z.x - zp.x, wrap_angle(z.y - zp.y));
        let (h_landmark, r) = match target {
            Target::State(_) => (h_l, self.w),
            // Frozen: the landmark is known with its frozen covariance (text under Fig. 7).
            Target::Fixed(k) => (
                Matrix2::zeros(),
                self.w + h_l * self.fixed[k].cov * h_l.transpose(),
            ),
        };
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

    /// `H_a P H_b^T` from the robot, landmark and cross blocks of `P`.
    pub fn cross(&self, a: &Pairing, b: &Pairing) -> Matrix2<f64> {
        let mut s = a.h_robot * self.prr * b.h_robot.transpose();
        if let Some(ob) = b.offset {
            let prb = fixed3x2(&self.ekf.covariance_block(0, ob, 3, 2).expect("offset"));
            s += a.h_robot * prb * b.h_landmark.transpose();
        }
        if let Some(oa) = a.offset {
            let pra = fixed3x2(&self.ekf.covariance_block(0, oa, 3, 2).expect("offset"));
            s += a.h_landmark * pra.transpose() * b.h_robot.transpose();
            if let Some(ob) = b.offset {
                let pab = fixed2(&self.ekf.covariance_block(oa, ob, 2, 2).expect("offset"));
                s += a.h_landmark * pab * b.h_landmark.transpose();
            }
        }
        s
    }

    /// The joint NIS `nu_H^T S_H^-1 nu_H` of a hypothesis (eq. 8 stacked); `None`
    /// when `S_H` has no Cholesky factor.
    pub fn joint_nis(&self, hyp: &[&Pairing]) -> Option<f64> {
        let k = hyp.len();
        let mut s = DMatrix::zeros(2 * k, 2 * k);
        let mut nu = DVector::zeros(2 * k);
        for (i, a) in hyp.iter().enumerate() {
            nu.fixed_rows_mut::<2>(2 * i).copy_from(&a.nu);
            for (j, b) in hyp.iter().enumerate().skip(i) {
                let mut block = self.cross(a, b);
                if i == j {
                    block += a.r;
                }
                s.fixed_view_mut::<2, 2>(2 * i, 2 * j).copy_from(&block);
                s.fixed_view_mut::<2, 2>(2 * j, 2 * i)
                    .copy_from(&block.transpose());
            }
        }
        let chol = s.cholesky()?;
        Some(nu.dot(&chol.solve(&nu)))
    }
}

/// Every pairing of each detection with each target whose NIS is within `gate`
/// (individual compatibility), sorted by NIS.
pub(crate) fn compatible(
    scene: &Scene<'_>,
    detections: &[Vector2<f64>],
    gate: f64,
) -> Vec<Vec<Pairing>> {
    let targets: Vec<Target> = (0..scene.ekf.num_landmarks())
        .map(Target::State)
        .chain((0..scene.fixed.len()).map(Target::Fixed))
        .collect();
    detections
        .iter()
        .enumerate()
        .map(|(i, z)| {
            let mut options: Vec<Pairing> = targets
                .iter()
                .filter_map(|&t| scene.pairing(i, z, t))
                .filter(|p| p.nis <= gate)
                .collect();
            options.sort_by(|a, b| a.nis.total_cmp(&b.nis));
            options
        })
        .collect()
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

/// The search state of JCBB: one level per detection, each trying its compatible
/// targets in order of NIS and then "no target" (the null pairing).
struct Search<'s> {
    options: &'s [Vec<Pairing>],
    /// Next option to try at each level (`options[level].len()` is the null option).
    next: Vec<usize>,
    /// The option taken at each level on the current path (`None`: null).
    taken: Vec<Option<usize>>,
    best: Vec<(usize, usize)>,
}

impl Search<'_> {
    fn hypothesis(&self) -> Vec<&Pairing> {
        self.taken
            .iter()
            .enumerate()
            .filter_map(|(lvl, o)| o.map(|k| &self.options[lvl][k]))
            .collect()
    }

    fn used(&self, target: Target) -> bool {
        self.hypothesis().iter().any(|p| p.target == target)
    }
}

/// JCBB (Neira & Tardos 2001): the hypothesis with the most pairings whose joint NIS
/// is within the chi-square gate of its dimension (`joint_gates[k]` for `k`
/// pairings), found depth-first with an explicit stack; a branch is cut when even
/// pairing every remaining detection could not beat the best so far. At most
/// `max_nodes` joint-compatibility tests are made.
pub(crate) fn jcbb(
    scene: &Scene<'_>,
    options: &[Vec<Pairing>],
    joint_gates: &[f64],
    max_nodes: usize,
) -> JcbbOutcome {
    let n = options.len();
    let mut s = Search {
        options,
        next: vec![0; n + 1],
        taken: Vec::with_capacity(n),
        best: Vec::new(),
    };
    let (mut nodes, mut truncated) = (0usize, false);
    loop {
        let level = s.taken.len();
        let pairs = s.taken.iter().flatten().count();
        if level == n || pairs + (n - level) <= s.best.len() {
            if level == n && pairs > s.best.len() {
                s.best = s
                    .taken
                    .iter()
                    .enumerate()
                    .filter_map(|(l, o)| o.map(|k| (l, k)))
                    .collect();
            }
            if !backtrack(&mut s) {
                break;
            }
            continue;
        }
        let k = s.next[level];
        s.next[level] += 1;
        if k < options[level].len() {
            nodes += 1;
            if nodes > max_nodes {
                truncated = true;
                break;
            }
            if descend_if_compatible(scene, &mut s, level, k, joint_gates) {
                continue;
            }
        } else if k == options[level].len() {
            s.taken.push(None);
            s.next[level + 1] = 0;
        } else if !backtrack(&mut s) {
            break;
        }
    }
    let pairings = s.best.iter().map(|&(l, k)| options[l][k].clone()).collect();
    JcbbOutcome {
        pairings,
        truncated,
    }
}

/// Takes option `k` at `level` when its target is free and the extended hypothesis
/// is jointly compatible.
fn descend_if_compatible(
    scene: &Scene<'_>,
    s: &mut Search<'_>,
    level: usize,
    k: usize,
    joint_gates: &[f64],
) -> bool {
    let candidate = &s.options[level][k];
    if s.used(candidate.target) {
        return false;
    }
    let mut hyp = s.hypothesis();
    hyp.push(candidate);
    let ok = scene
        .joint_nis(&hyp)
        .is_some_and(|nis| nis <= joint_gates[hyp.len()]);
    if ok {
        s.taken.push(Some(k));
        s.next[level + 1] = 0;
    }
    ok
}

/// Leaves the current level for the one above; `false` when the search is over.
fn backtrack(s: &mut Search<'_>) -> bool {
    s.taken.pop().is_some()
}

#[cfg(test)]
mod tests {
    use super::*;
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
    /// its joint NIS computed from the dense `H P H^T + R`; the largest jointly
    /// compatible hypothesis wins.
    fn brute_force(ekf: &Ekf, options: &[Vec<Pairing>], gates: &[f64]) -> usize {
        let p = ekf.covariance();
        let mut best = 0;
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
                let s = &h * &p * h.transpose() + r;
                let nis = nu.dot(&(s.try_inverse().unwrap() * &nu));
                if nis <= gates[k] {
                    best = best.max(k);
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
                return best;
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
        assert_eq!(out.pairings.len(), brute_force(&ekf, &options, &g));
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
        assert_eq!(out.pairings.len(), brute_force(&ekf, &options, &g));
        // A budget of one node stops the search and says so.
        assert!(jcbb(&scene, &options, &g, 1).truncated);
    }
}
