//! A 2-D pose graph: poses joined by relative-pose measurements, solved by
//! Gauss-Newton on the sparse normal equations ([`crate::sparse`]).
//!
//! An edge from `i` to `j` measures `z = x_i^-1 (+) x_j` with information `Omega`;
//! its error is `e = z^-1 (+) (x_i^-1 (+) x_j)` as `(x, y, theta)`. Loop closures
//! carry a robust kernel, dynamic covariance scaling (Agarwal et al. 2013): at each
//! iteration a closure's information is scaled by `s^2`, `s = min(1, 2 phi / (phi +
//! chi2))`, so a closure that disagrees with the rest of the graph fades out instead
//! of bending the map.

use std::collections::HashMap;

use nalgebra::{Matrix3, Vector3};
use rperc_core::{Pose2, wrap_angle};

use crate::error::{LaserError, Result};
use crate::sparse::{Factor, Pattern};

/// A relative-pose measurement between two poses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Edge {
    /// The pose it starts from.
    pub from: usize,
    /// The pose it measures.
    pub to: usize,
    /// `to` seen from `from`.
    pub measurement: Pose2,
    /// Information (inverse covariance) of the measurement.
    pub information: Matrix3<f64>,
    /// The robust kernel's `phi` (dynamic covariance scaling), `None` for a plain
    /// Gaussian edge.
    pub robust: Option<f64>,
}

/// What an optimisation did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Solved {
    /// Gauss-Newton iterations.
    pub iterations: usize,
    /// The weighted squared error at the end.
    pub chi2: f64,
}

/// Poses, edges and a prior on the first pose.
#[derive(Debug, Clone, Default)]
pub struct PoseGraph {
    /// The poses' current estimates.
    pub poses: Vec<Pose2>,
    /// The measurements.
    pub edges: Vec<Edge>,
    /// Information of the first pose's prior (its estimate is the prior's mean).
    pub anchor_information: Matrix3<f64>,
    anchor: Pose2,
    /// The elimination pattern and the structure version it was made for.
    pattern: Option<(u64, Pattern)>,
    /// Bumped whenever a pose or an edge is added or removed.
    version: u64,
}

/// The error of an edge measuring `z` between `from` and `to`, and its Jacobians in
/// `from` and `to`.
pub fn linearise(
    from: &Pose2,
    to: &Pose2,
    z: &Pose2,
) -> (Vector3<f64>, Matrix3<f64>, Matrix3<f64>) {
    let (ij, j_from, j_to) = from.between_with_jacobians(to);
    let (e, _, j_e) = z.between_with_jacobians(&ij);
    let mut ev = e.to_vector();
    ev.z = wrap_angle(ev.z);
    (ev, j_e * j_from, j_e * j_to)
}

/// Dynamic covariance scaling's weight for an edge with error `chi2`.
pub fn dcs_scale(phi: f64, chi2: f64) -> f64 {
    (2.0 * phi / (phi + chi2)).min(1.0)
}

impl PoseGraph {
    /// A graph whose first pose is `start`, held by a prior of `anchor_information`.
    pub fn new(start: Pose2, anchor_information: Matrix3<f64>) -> Self {
        PoseGraph {
            poses: vec![start],
            anchor: start,
            anchor_information,
            ..Default::default()
        }
    }

    /// Adds a pose and returns its index.
    pub fn add_pose(&mut self, pose: Pose2) -> usize {
        self.version += 1;
        self.poses.push(pose);
        self.poses.len() - 1
    }

    /// Adds an edge (both ends must exist).
    pub fn add_edge(&mut self, edge: Edge) -> Result<()> {
        let n = self.poses.len();
        if edge.from >= n || edge.to >= n || edge.from == edge.to {
            return Err(LaserError::dimension(format!(
                "edge {} -> {} in a graph of {n} poses",
                edge.from, edge.to
            )));
        }
        if !edge.information.iter().all(|v| v.is_finite()) {
            return Err(LaserError::Core(rperc_core::CoreError::NonFinite(
                "edge information",
            )));
        }
        self.version += 1;
        self.edges.push(edge);
        Ok(())
    }

    /// Removes edge `k` and returns it.
    pub fn remove_edge(&mut self, k: usize) -> Edge {
        self.version += 1;
        self.edges.remove(k)
    }

    /// Edge `k`'s squared error weighted by its own information (no kernel).
    pub fn chi2(&self, k: usize) -> f64 {
        let e = &self.edges[k];
        let (err, _, _) = linearise(&self.poses[e.from], &self.poses[e.to], &e.measurement);
        (err.transpose() * e.information * err)[(0, 0)]
    }

    /// Optimises, then while the worst of the edges `suspect` picks has a squared
    /// error above `gate`, removes it and optimises again: a closure that disagrees
    /// with the rest of the graph (the chain and the other closures) is the one left
    /// with the largest error once the graph has settled. Returns the removed edges.
    pub fn optimize_consistent(
        &mut self,
        iterations: usize,
        tolerance: f64,
        gate: f64,
        suspect: impl Fn(&Edge) -> bool,
    ) -> Result<Vec<Edge>> {
        let mut removed = Vec::new();
        loop {
            self.optimize(iterations, tolerance)?;
            let worst = (0..self.edges.len())
                .filter(|&k| suspect(&self.edges[k]))
                .map(|k| (k, self.chi2(k)))
                .max_by(|a, b| a.1.total_cmp(&b.1));
            match worst {
                Some((k, chi2)) if chi2 > gate => removed.push(self.remove_edge(k)),
                _ => return Ok(removed),
            }
        }
    }

    /// The weight of edge `k` at the current estimates (1 for a plain edge).
    pub fn weight(&self, k: usize) -> f64 {
        let e = &self.edges[k];
        let Some(phi) = e.robust else { return 1.0 };
        let (err, _, _) = linearise(&self.poses[e.from], &self.poses[e.to], &e.measurement);
        let chi2 = (err.transpose() * e.information * err)[(0, 0)];
        dcs_scale(phi, chi2).powi(2)
    }

    /// The elimination pattern, made again only when poses or edges were added.
    fn ensure_pattern(&mut self) -> Result<()> {
        if self
            .pattern
            .as_ref()
            .is_none_or(|(v, _)| *v != self.version)
        {
            let pairs: Vec<(usize, usize)> = self.edges.iter().map(|e| (e.from, e.to)).collect();
            self.pattern = Some((self.version, Pattern::new(self.poses.len(), &pairs)?));
        }
        Ok(())
    }

    /// The factor of the normal equations at the current estimates, and the gradient.
    ///
    /// Information matrices that span many orders of magnitude (a robot standing
    /// still next to a long chain) can leave a pivot block that rounding makes
    /// indefinite; then a Levenberg-Marquardt damping, growing tenfold, is added to
    /// the diagonal until the factorisation succeeds (a shorter step, same optimum).
    fn factor(&self) -> Result<(Factor<'_>, Vec<Vector3<f64>>)> {
        let (mut diag, off, grad, _) = self.normal_equations();
        let pattern = &self.pattern.as_ref().expect("ensure_pattern first").1;
        let scale = diag.iter().map(|d| d.diagonal().max()).fold(0.0, f64::max);
        let mut damping = 0.0;
        for _ in 0..12 {
            match Factor::new(pattern, &diag, &off) {
                Ok(f) => return Ok((f, grad)),
                Err(LaserError::Numerical(_)) => {
                    let next = if damping == 0.0 {
                        1e-12 * scale
                    } else {
                        10.0 * damping
                    };
                    for d in diag.iter_mut() {
                        *d += Matrix3::identity() * (next - damping);
                    }
                    damping = next;
                }
                Err(e) => return Err(e),
            }
        }
        Err(LaserError::Numerical(
            "the pose graph stays indefinite under damping".into(),
        ))
    }

    /// The normal equations at the current estimates: diagonal and off-diagonal
    /// blocks, the gradient and the weighted squared error.
    #[allow(clippy::type_complexity)]
    fn normal_equations(
        &self,
    ) -> (
        Vec<Matrix3<f64>>,
        HashMap<(usize, usize), Matrix3<f64>>,
        Vec<Vector3<f64>>,
        f64,
    ) {
        let n = self.poses.len();
        let mut diag = vec![Matrix3::zeros(); n];
        let mut grad = vec![Vector3::zeros(); n];
        let mut off: HashMap<(usize, usize), Matrix3<f64>> =
            HashMap::with_capacity(self.edges.len());
        let e0 = {
            let d = self.poses[0].to_vector() - self.anchor.to_vector();
            Vector3::new(d.x, d.y, wrap_angle(d.z))
        };
        diag[0] += self.anchor_information;
        grad[0] += self.anchor_information * e0;
        let mut chi2 = (e0.transpose() * self.anchor_information * e0)[(0, 0)];
        for (k, e) in self.edges.iter().enumerate() {
            let (err, ja, jb) = linearise(&self.poses[e.from], &self.poses[e.to], &e.measurement);
            let omega = e.information * self.weight(k);
            chi2 += (err.transpose() * omega * err)[(0, 0)];
            diag[e.from] += ja.transpose() * omega * ja;
            diag[e.to] += jb.transpose() * omega * jb;
            grad[e.from] += ja.transpose() * omega * err;
            grad[e.to] += jb.transpose() * omega * err;
            let (a, b, block) = if e.from > e.to {
                (e.from, e.to, ja.transpose() * omega * jb)
            } else {
                (e.to, e.from, jb.transpose() * omega * ja)
            };
            *off.entry((a, b)).or_insert_with(Matrix3::zeros) += block;
        }
        (diag, off, grad, chi2)
    }

    /// Gauss-Newton until a step moves no pose by more than `tolerance` (m or rad),
    /// at most `iterations` times.
    pub fn optimize(&mut self, iterations: usize, tolerance: f64) -> Result<Solved> {
        let mut done = 0;
        for _ in 0..iterations {
            done += 1;
            self.ensure_pattern()?;
            let step = {
                let (factor, grad) = self.factor()?;
                factor.solve(&grad)
            };
            let mut largest: f64 = 0.0;
            for (p, s) in self.poses.iter_mut().zip(&step) {
                if !s.iter().all(|v| v.is_finite()) {
                    return Err(LaserError::Numerical(
                        "a pose graph step is not finite".into(),
                    ));
                }
                *p = Pose2::new(p.x - s.x, p.y - s.y, wrap_angle(p.theta - s.z));
                largest = largest.max(s.x.abs()).max(s.y.abs()).max(s.z.abs());
            }
            if largest < tolerance {
                break;
            }
        }
        let chi2 = self.normal_equations().3;
        Ok(Solved {
            iterations: done,
            chi2,
        })
    }

    /// Every pose's marginal covariance at the current estimates.
    pub fn marginals(&mut self) -> Result<Vec<Matrix3<f64>>> {
        self.ensure_pattern()?;
        Ok(self.factor()?.0.marginals())
    }
}
