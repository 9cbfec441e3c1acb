//! A 2-D pose graph: poses joined by relative-pose measurements, solved by
//! Gauss-Newton on the sparse normal equations ([`crate::sparse`]).
//!
//! An edge from `i` to `j` measures `z = x_i^-1 (+) x_j` with information `Omega`;
//! its error is `e = z^-1 (+) (x_i^-1 (+) x_j)` as `(x, y, theta)`. Loop closures
//! carry a robust kernel, dynamic covariance scaling (Agarwal et al. 2013): at each
//! iteration a closure's information is scaled by `s^2`, `s = min(1, 2 phi / (phi +
//! chi2))`, so a closure that disagrees with the rest of the graph fades out instead
//! of bending the map.
//!
//! Wall landmarks ([`crate::wall_factor`]) are nodes too, after the poses: a wall's
//! `(rho, alpha)` fills the first two entries of its 3 x 3 block, whose third is an
//! unused unit (no factor touches it, so its step is zero).

use std::collections::HashMap;

use nalgebra::{Matrix2, Matrix2x3, Matrix3, Vector2, Vector3};
use rperc_core::{Pose2, wrap_angle};

use crate::error::{LaserError, Result};
use crate::sparse::{Factor, Pattern};
use crate::wall_factor::{WallFactor, linearise_wall};

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

/// The normal equations in 3 x 3 blocks: diagonal and off-diagonal blocks (row
/// node > column node), the gradient and the weighted squared error.
struct Normal {
    diag: Vec<Matrix3<f64>>,
    off: HashMap<(usize, usize), Matrix3<f64>>,
    grad: Vec<Vector3<f64>>,
    chi2: f64,
}

impl Normal {
    fn new(nodes: usize, edges: usize) -> Self {
        Normal {
            diag: vec![Matrix3::zeros(); nodes],
            off: HashMap::with_capacity(edges),
            grad: vec![Vector3::zeros(); nodes],
            chi2: 0.0,
        }
    }

    /// Adds a factor between nodes `a` and `b` with error `err` (any dimension `D`),
    /// Jacobians `ja` and `jb` (D x 3) and information `omega`.
    fn add<D: nalgebra::DimName>(
        &mut self,
        a: usize,
        b: usize,
        ja: &nalgebra::OMatrix<f64, D, nalgebra::U3>,
        jb: &nalgebra::OMatrix<f64, D, nalgebra::U3>,
        omega: &nalgebra::OMatrix<f64, D, D>,
        err: &nalgebra::OVector<f64, D>,
    ) where
        nalgebra::DefaultAllocator: nalgebra::allocator::Allocator<D, nalgebra::U3>
            + nalgebra::allocator::Allocator<D, D>
            + nalgebra::allocator::Allocator<D>
            + nalgebra::allocator::Allocator<nalgebra::U3, D>,
    {
        let (wa, wb) = (ja.transpose() * omega, jb.transpose() * omega);
        self.chi2 += err.dot(&(omega * err));
        self.diag[a] += &wa * ja;
        self.diag[b] += &wb * jb;
        self.grad[a] += &wa * err;
        self.grad[b] += &wb * err;
        let (row, col, block) = if a > b {
            (a, b, wa * jb)
        } else {
            (b, a, wb * ja)
        };
        *self.off.entry((row, col)).or_insert_with(Matrix3::zeros) += block;
    }
}

/// Poses, edges and a prior on the first pose.
#[derive(Debug, Clone, Default)]
pub struct PoseGraph {
    /// The poses' current estimates.
    pub poses: Vec<Pose2>,
    /// The measurements.
    pub edges: Vec<Edge>,
    /// The wall landmarks' current estimates, world `(rho, alpha)`.
    pub walls: Vec<Vector2<f64>>,
    /// The wall sightings.
    pub wall_factors: Vec<WallFactor>,
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

    /// Adds a wall landmark at world line `wall` and returns its index.
    pub fn add_wall(&mut self, wall: Vector2<f64>) -> Result<usize> {
        if !wall.iter().all(|v| v.is_finite()) {
            return Err(LaserError::Core(rperc_core::CoreError::NonFinite("wall")));
        }
        self.version += 1;
        self.walls.push(wall);
        Ok(self.walls.len() - 1)
    }

    /// Adds a wall sighting (its pose and wall must exist).
    pub fn add_wall_factor(&mut self, factor: WallFactor) -> Result<()> {
        if factor.pose >= self.poses.len() || factor.wall >= self.walls.len() {
            return Err(LaserError::dimension(format!(
                "a sighting of wall {} from pose {} in a graph of {} walls and {} poses",
                factor.wall,
                factor.pose,
                self.walls.len(),
                self.poses.len()
            )));
        }
        let finite = factor
            .z
            .iter()
            .chain(factor.mid.iter())
            .all(|v| v.is_finite())
            && factor.information.iter().all(|v| v.is_finite());
        if !finite {
            return Err(LaserError::Core(rperc_core::CoreError::NonFinite(
                "wall sighting",
            )));
        }
        self.version += 1;
        self.wall_factors.push(factor);
        Ok(())
    }

    /// Wall sighting `k`'s error and Jacobians at the current estimates.
    fn wall_linearised(&self, k: usize) -> Result<(Vector2<f64>, Matrix2x3<f64>, Matrix2<f64>)> {
        let f = &self.wall_factors[k];
        linearise_wall(&self.poses[f.pose], &self.walls[f.wall], &f.z, &f.mid).ok_or(
            LaserError::Core(rperc_core::CoreError::NonFinite("wall estimate")),
        )
    }

    /// Wall sighting `k`'s squared error by its own information, and its robust
    /// weight (1 for a plain factor).
    pub fn wall_chi2(&self, k: usize) -> Result<(f64, f64)> {
        let f = &self.wall_factors[k];
        let e = self.wall_linearised(k)?.0;
        let chi2 = (e.transpose() * f.information * e)[(0, 0)];
        Ok((
            chi2,
            f.robust.map_or(1.0, |phi| dcs_scale(phi, chi2).powi(2)),
        ))
    }

    /// Removes the wall sighting of largest squared error (by its own information)
    /// when that is above `gate` and its wall keeps another sighting: a sighting
    /// paired with the wrong wall is the one left with the largest error once the
    /// graph has settled (one at a time, as for closures: a wrong one bends the
    /// graph and raises its neighbours' errors too). Returns whether one was removed.
    pub fn prune_wall_factor(&mut self, gate: f64) -> Result<bool> {
        let mut seen = vec![0usize; self.walls.len()];
        for f in &self.wall_factors {
            seen[f.wall] += 1;
        }
        let mut worst: Option<(usize, f64)> = None;
        for k in 0..self.wall_factors.len() {
            let chi2 = self.wall_chi2(k)?.0;
            let shared = seen[self.wall_factors[k].wall] >= 2;
            if shared && chi2 > gate && worst.is_none_or(|(_, c)| chi2 > c) {
                worst = Some((k, chi2));
            }
        }
        let Some((k, _)) = worst else {
            return Ok(false);
        };
        self.wall_factors.remove(k);
        self.version += 1;
        Ok(true)
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
            let n = self.poses.len();
            let pairs: Vec<(usize, usize)> = self
                .edges
                .iter()
                .map(|e| (e.from, e.to))
                .chain(self.wall_factors.iter().map(|f| (f.pose, n + f.wall)))
                .collect();
            self.pattern = Some((self.version, Pattern::new(n + self.walls.len(), &pairs)?));
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
        let Normal {
            mut diag,
            off,
            grad,
            ..
        } = self.normal_equations()?;
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

    /// The normal equations at the current estimates (poses, then walls).
    fn normal_equations(&self) -> Result<Normal> {
        let n = self.poses.len();
        let mut ne = Normal::new(n + self.walls.len(), self.edges.len());
        let e0 = {
            let d = self.poses[0].to_vector() - self.anchor.to_vector();
            Vector3::new(d.x, d.y, wrap_angle(d.z))
        };
        ne.diag[0] += self.anchor_information;
        ne.grad[0] += self.anchor_information * e0;
        ne.chi2 += (e0.transpose() * self.anchor_information * e0)[(0, 0)];
        for (k, e) in self.edges.iter().enumerate() {
            let (err, ja, jb) = linearise(&self.poses[e.from], &self.poses[e.to], &e.measurement);
            ne.add(
                e.from,
                e.to,
                &ja,
                &jb,
                &(e.information * self.weight(k)),
                &err,
            );
        }
        for k in 0..self.wall_factors.len() {
            let f = &self.wall_factors[k];
            let (err, jp, jw) = self.wall_linearised(k)?;
            let omega = f.information * self.wall_chi2(k)?.1;
            // The wall's 2 x 2 Jacobian padded to its 3-entry block.
            let jw3 = Matrix2x3::new(jw[(0, 0)], jw[(0, 1)], 0.0, jw[(1, 0)], jw[(1, 1)], 0.0);
            ne.add(f.pose, n + f.wall, &jp, &jw3, &omega, &err);
        }
        for d in &mut ne.diag[n..] {
            d[(2, 2)] += 1.0; // the walls' unused entry
        }
        Ok(ne)
    }

    /// Gauss-Newton until a step moves no pose or wall by more than `tolerance` (m or
    /// rad), at most `iterations` times.
    pub fn optimize(&mut self, iterations: usize, tolerance: f64) -> Result<Solved> {
        let mut done = 0;
        for _ in 0..iterations {
            done += 1;
            self.ensure_pattern()?;
            let step = {
                let (factor, grad) = self.factor()?;
                factor.solve(&grad)
            };
            if !step.iter().all(|s| s.iter().all(|v| v.is_finite())) {
                return Err(LaserError::Numerical(
                    "a pose graph step is not finite".into(),
                ));
            }
            let n = self.poses.len();
            for (p, s) in self.poses.iter_mut().zip(&step) {
                *p = Pose2::new(p.x - s.x, p.y - s.y, wrap_angle(p.theta - s.z));
            }
            for (w, s) in self.walls.iter_mut().zip(&step[n..]) {
                *w = Vector2::new(w.x - s.x, wrap_angle(w.y - s.y));
            }
            let largest = step.iter().map(|s| s.amax()).fold(0.0, f64::max);
            if largest < tolerance {
                break;
            }
        }
        let chi2 = self.normal_equations()?.chi2;
        Ok(Solved {
            iterations: done,
            chi2,
        })
    }

    /// Every pose's marginal covariance at the current estimates.
    pub fn marginals(&mut self) -> Result<Vec<Matrix3<f64>>> {
        self.ensure_pattern()?;
        let mut all = self.factor()?.0.marginals();
        all.truncate(self.poses.len());
        Ok(all)
    }
}
