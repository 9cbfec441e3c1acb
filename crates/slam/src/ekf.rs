//! The EKF-SLAM core: a robot block plus landmark blocks with a full covariance,
//! seed 000 equations (3) to (9).
//!
//! Prediction touches only the robot rows and columns (O(n)). The update exploits
//! the sparse observation Jacobian: `H` is a few dense blocks (the robot and one
//! landmark, say), so `P H^T` costs O(n p) and the Joseph form, expanded as
//! `P - K (P H^T)^T + (K S - P H^T) K^T`, costs one pass over `P` (O(n^2 p)).
//!
//! `P` is symmetric, so only its upper triangle (with the diagonal) is kept up to
//! date: the update reads and writes half the matrix, which is what bounds its speed
//! (memory bandwidth). [`Ekf::covariance`] returns the full matrix.

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

use rperc_core::{Definiteness, check_covariance};

use crate::error::{Result, SlamError, ensure_finite};

/// One dense block of a sparse observation Jacobian `H`: rows `row..row + h.nrows()`
/// and columns `col..col + h.ncols()` of `H` equal `h`; everything else is zero.
#[derive(Debug, Clone, PartialEq)]
pub struct JacobianBlock {
    /// First row of the block in `H`.
    pub row: usize,
    /// First column of the block in `H` (the state index).
    pub col: usize,
    /// The block's entries.
    pub h: DMatrix<f64>,
}

/// An observation Jacobian with `rows` rows stored as dense blocks (blocks may
/// overlap; overlapping entries add).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SparseJacobian {
    /// Number of rows of `H` (the observation size).
    pub rows: usize,
    /// The non-zero blocks.
    pub blocks: Vec<JacobianBlock>,
}

impl SparseJacobian {
    /// A Jacobian with `rows` rows and no blocks yet.
    pub fn new(rows: usize) -> Self {
        Self {
            rows,
            blocks: Vec::new(),
        }
    }

    /// Adds the block `h` at `(row, col)`.
    pub fn with_block(mut self, row: usize, col: usize, h: DMatrix<f64>) -> Self {
        self.blocks.push(JacobianBlock { row, col, h });
        self
    }

    /// The dense `rows x cols` matrix (for tests and small problems).
    pub fn to_dense(&self, cols: usize) -> DMatrix<f64> {
        let mut dense = DMatrix::zeros(self.rows, cols);
        for b in &self.blocks {
            let mut view = dense.view_mut((b.row, b.col), (b.h.nrows(), b.h.ncols()));
            view += &b.h;
        }
        dense
    }

    fn validate(&self, state_dim: usize) -> Result<()> {
        for b in &self.blocks {
            if b.row + b.h.nrows() > self.rows || b.col + b.h.ncols() > state_dim {
                return Err(SlamError::dimension(format!(
                    "Jacobian block {}x{} at ({}, {}) does not fit a {}x{} H",
                    b.h.nrows(),
                    b.h.ncols(),
                    b.row,
                    b.col,
                    self.rows,
                    state_dim
                )));
            }
            ensure_finite("Jacobian", b.h.iter())?;
        }
        Ok(())
    }
}

/// What one measurement update did.
#[derive(Debug, Clone, PartialEq)]
pub struct Update {
    /// The innovation `z - h(x)` it used.
    pub innovation: DVector<f64>,
    /// Innovation covariance `S = H P H^T + R`, eq. (8).
    pub innovation_cov: DMatrix<f64>,
    /// Kalman gain `K = P H^T S^-1`, eq. (7), `d x p`.
    pub gain: DMatrix<f64>,
    /// Normalised innovation squared `nu^T S^-1 nu`.
    pub nis: f64,
}

/// States at least this large update `P` on all cores; below it, threads cost more
/// than they save.
const PARALLEL_MIN_DIM: usize = 384;

/// Refuses a noise covariance (`V`, `R`) that is not symmetric positive
/// semi-definite: a negative variance would make `P` indefinite without any error
/// further down. Zero noise is allowed.
fn check_noise(name: &'static str, c: &DMatrix<f64>) -> Result<()> {
    Ok(check_covariance(name, c, Definiteness::SemiPositive)?)
}

/// An extended Kalman filter over a robot block of size `robot_dim` followed by
/// landmark blocks of size `landmark_dim`. The state covariance is `P` in the seed's
/// equations and `covariance` in the API.
///
/// # Examples
/// ```
/// use nalgebra::{DMatrix, DVector};
/// use slam::{Ekf, SparseJacobian};
///
/// // A 1-D robot at 0 (variance 1) and a landmark at 2 (variance 4).
/// let mut ekf = Ekf::new(DVector::from_vec(vec![0.0, 2.0]),
///                        DMatrix::from_diagonal(&DVector::from_vec(vec![1.0, 4.0])), 1, 1).unwrap();
/// // Observe the landmark relative to the robot: z = l - x = 2.5, noise variance 1.
/// let h = SparseJacobian::new(1)
///     .with_block(0, 0, DMatrix::from_element(1, 1, -1.0))
///     .with_block(0, 1, DMatrix::from_element(1, 1, 1.0));
/// let up = ekf.update(&DVector::from_vec(vec![0.5]), &h, &DMatrix::identity(1, 1)).unwrap();
/// assert!((up.innovation_cov[(0, 0)] - 6.0).abs() < 1e-12); // 1 + 4 + 1
/// assert!((ekf.state()[1] - (2.0 + 4.0 / 6.0 * 0.5)).abs() < 1e-12);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Ekf {
    x: DVector<f64>,
    /// `P`: only the upper triangle (with the diagonal) is kept current.
    cov: DMatrix<f64>,
    robot_dim: usize,
    landmark_dim: usize,
}

impl Ekf {
    /// A filter with state `x` and covariance `covariance` (symmetric positive
    /// semi-definite: a zero block is a perfectly known start): a robot block of
    /// `robot_dim` entries, then landmark blocks of `landmark_dim` entries each.
    pub fn new(
        x: DVector<f64>,
        covariance: DMatrix<f64>,
        robot_dim: usize,
        landmark_dim: usize,
    ) -> Result<Self> {
        let d = x.len();
        if covariance.nrows() != d || covariance.ncols() != d {
            return Err(SlamError::dimension(format!(
                "state has {d} entries but covariance is {}x{}",
                covariance.nrows(),
                covariance.ncols()
            )));
        }
        if robot_dim == 0
            || landmark_dim == 0
            || d < robot_dim
            || !(d - robot_dim).is_multiple_of(landmark_dim)
        {
            return Err(SlamError::dimension(format!(
                "a state of {d} entries is not a robot block of {robot_dim} plus blocks of {landmark_dim}"
            )));
        }
        ensure_finite("state", x.iter())?;
        check_covariance("covariance", &covariance, Definiteness::SemiPositive)?;
        Ok(Self {
            x,
            cov: covariance,
            robot_dim,
            landmark_dim,
        })
    }

    /// The state estimate.
    pub fn state(&self) -> &DVector<f64> {
        &self.x
    }

    /// Replaces the state estimate (same size, every entry finite); the covariance is
    /// kept. For resetting a filter or moving it to a new frame.
    pub fn set_state(&mut self, x: DVector<f64>) -> Result<()> {
        if x.len() != self.x.len() {
            return Err(SlamError::dimension(format!(
                "state has {} entries, got {}",
                self.x.len(),
                x.len()
            )));
        }
        ensure_finite("state", x.iter())?;
        self.x = x;
        Ok(())
    }

    /// The state covariance `P` (the full symmetric matrix, built from the stored
    /// upper triangle: O(n^2)).
    pub fn covariance(&self) -> DMatrix<f64> {
        let mut full = self.cov.clone();
        full.fill_lower_triangle_with_upper_triangle();
        full
    }

    /// Entry `(i, j)` of `P` read from the stored upper triangle.
    #[inline]
    fn cov_at(&self, i: usize, j: usize) -> f64 {
        if i <= j {
            self.cov[(i, j)]
        } else {
            self.cov[(j, i)]
        }
    }

    /// Column `c` of `P`.
    fn covariance_column(&self, c: usize) -> DVector<f64> {
        DVector::from_fn(self.cov.nrows(), |i, _| self.cov_at(i, c))
    }

    /// The robot rows `P[0..r, :]` in full.
    fn robot_rows(&self) -> DMatrix<f64> {
        DMatrix::from_fn(self.robot_dim, self.cov.nrows(), |i, j| self.cov_at(i, j))
    }

    /// Size of the robot block.
    pub fn robot_dim(&self) -> usize {
        self.robot_dim
    }

    /// Size of each landmark block.
    pub fn landmark_dim(&self) -> usize {
        self.landmark_dim
    }

    /// Number of landmarks in the state.
    pub fn num_landmarks(&self) -> usize {
        (self.x.len() - self.robot_dim) / self.landmark_dim
    }

    /// State index of landmark `j`'s first entry.
    pub fn landmark_offset(&self, j: usize) -> Result<usize> {
        if j >= self.num_landmarks() {
            return Err(SlamError::dimension(format!(
                "landmark {j} does not exist ({} in the map)",
                self.num_landmarks()
            )));
        }
        Ok(self.robot_dim + j * self.landmark_dim)
    }

    /// Prediction, eqs. (3) and (5): the robot block moves to `robot_mean` and
    /// `P <- Fx P Fx^T + Fv V Fv^T` with `Fx` acting on the robot block only
    /// (landmarks are static). O(n).
    pub fn predict(
        &mut self,
        robot_mean: &DVector<f64>,
        fx: &DMatrix<f64>,
        fv: &DMatrix<f64>,
        v: &DMatrix<f64>,
    ) -> Result<()> {
        let r = self.robot_dim;
        let q = v.nrows();
        if robot_mean.len() != r
            || fx.shape() != (r, r)
            || fv.shape() != (r, q)
            || v.shape() != (q, q)
        {
            return Err(SlamError::dimension(format!(
                "prediction needs robot mean {r}, Fx {r}x{r}, Fv {r}x{q}, V {q}x{q}; got {}, {:?}, {:?}, {:?}",
                robot_mean.len(),
                fx.shape(),
                fv.shape(),
                v.shape()
            )));
        }
        ensure_finite("robot mean", robot_mean.iter())?;
        ensure_finite("Fx", fx.iter())?;
        ensure_finite("Fv", fv.iter())?;
        check_noise("V", v)?;
        let d = self.x.len();
        let rows = self.robot_rows();
        let prr = rows.columns(0, r);
        let new_rr = fx * prr * fx.transpose() + fv * v * fv.transpose();
        let cross = fx * rows.columns(r, d - r);
        // Check before writing, so a diverged prediction leaves the filter as it was.
        let finite = new_rr.iter().chain(cross.iter()).all(|v| v.is_finite());
        if !finite || new_rr.diagonal().iter().any(|&v| v < 0.0) {
            return Err(SlamError::Diverged(
                "predict: the predicted robot covariance is not finite or has a negative variance"
                    .into(),
            ));
        }
        if d > r {
            // Rows 0..r of the landmark columns lie in the upper triangle.
            self.cov.view_mut((0, r), (r, d - r)).copy_from(&cross);
        }
        self.cov
            .view_mut((0, 0), (r, r))
            .copy_from(&((&new_rr + new_rr.transpose()) * 0.5));
        self.x.rows_mut(0, r).copy_from(robot_mean);
        Ok(())
    }

    /// `L = P H^T` (d x m), touching only the columns of `P` that `H`'s blocks select.
    fn cross_covariance(&self, h: &SparseJacobian) -> DMatrix<f64> {
        let mut l = DMatrix::<f64>::zeros(self.x.len(), h.rows);
        for b in &h.blocks {
            for c in 0..b.h.ncols() {
                let column = self.covariance_column(b.col + c);
                for a in 0..b.h.nrows() {
                    let coeff = b.h[(a, c)];
                    if coeff != 0.0 {
                        l.column_mut(b.row + a).axpy(coeff, &column, 1.0);
                    }
                }
            }
        }
        l
    }

    /// The diagonal the Joseph update would write, `P_ii - (K L^T)_ii + (M K^T)_ii`, must
    /// be finite and non-negative (up to round-off); checked in O(n m) before writing.
    fn check_updated_diagonal(
        &self,
        gain: &DMatrix<f64>,
        l: &DMatrix<f64>,
        ks_minus_l: &DMatrix<f64>,
    ) -> Result<()> {
        for i in 0..self.x.len() {
            let old = self.cov[(i, i)];
            let mut new = old;
            for a in 0..gain.ncols() {
                new += gain[(i, a)] * (ks_minus_l[(i, a)] - l[(i, a)]);
            }
            if !new.is_finite() || new < -1e-9 * old.abs().max(f64::MIN_POSITIVE) {
                return Err(SlamError::Diverged(format!(
                    "update: the variance of state {i} would become {new:.3e} (was {old:.3e})"
                )));
            }
        }
        Ok(())
    }

    /// Measurement update, eqs. (6) to (9), with the Joseph form in O(n^2 m) for a
    /// sparse `H` of `m` rows. On error (sizes, NaN, a singular `S`) the state is
    /// unchanged.
    pub fn update(
        &mut self,
        innovation: &DVector<f64>,
        h: &SparseJacobian,
        r: &DMatrix<f64>,
    ) -> Result<Update> {
        let m = h.rows;
        if innovation.len() != m || r.shape() != (m, m) || m == 0 {
            return Err(SlamError::dimension(format!(
                "update needs an innovation of {m} > 0 entries and R {m}x{m}; got {} and {:?}",
                innovation.len(),
                r.shape()
            )));
        }
        h.validate(self.x.len())?;
        ensure_finite("innovation", innovation.iter())?;
        check_noise("R", r)?;
        let l = self.cross_covariance(h);
        let s = innovation_covariance(h, &l, r);
        let (gain, nis) = gain_and_nis(&s, &l, innovation)?;
        let dx = &gain * innovation;
        if !dx.iter().all(|v| v.is_finite()) {
            return Err(SlamError::SingularInnovation(
                "the state correction is not finite".into(),
            ));
        }
        // Joseph form, eq. (9), expanded for the sparse H:
        // (I - K H) P (I - K H)^T + K R K^T = P - K L^T - L K^T + K S K^T
        //                                   = P - K L^T + (K S - L) K^T.
        let ks_minus_l = &gain * &s - &l;
        self.check_updated_diagonal(&gain, &l, &ks_minus_l)?;
        joseph_columns(&mut self.cov, &gain, &l, &ks_minus_l);
        self.x += dx;
        Ok(Update {
            innovation: innovation.clone(),
            innovation_cov: s,
            gain,
            nis,
        })
    }

    /// Several observations stacked into one update (one `S`, one pass over `P`).
    /// Each item is `(innovation, H, R)` for the same state; rows are renumbered.
    pub fn update_batch(
        &mut self,
        observations: &[(DVector<f64>, SparseJacobian, DMatrix<f64>)],
    ) -> Result<Update> {
        let p: usize = observations.iter().map(|o| o.0.len()).sum();
        let mut innovation = DVector::zeros(p);
        let mut h = SparseJacobian::new(p);
        let mut r = DMatrix::zeros(p, p);
        let mut row = 0;
        for (nu, hi, ri) in observations {
            let k = nu.len();
            if hi.rows != k || ri.shape() != (k, k) {
                return Err(SlamError::dimension(format!(
                    "an observation of {k} entries needs H with {k} rows and R {k}x{k}"
                )));
            }
            innovation.rows_mut(row, k).copy_from(nu);
            r.view_mut((row, row), (k, k)).copy_from(ri);
            h.blocks.extend(hi.blocks.iter().map(|b| JacobianBlock {
                row: row + b.row,
                col: b.col,
                h: b.h.clone(),
            }));
            row += k;
        }
        self.update(&innovation, &h, &r)
    }

    /// Observations one after another, each linearised at the state the previous one
    /// left: `observe(state, i)` returns `(innovation, H, R)` for observation `i`.
    pub fn update_sequential<F>(&mut self, count: usize, mut observe: F) -> Result<Vec<Update>>
    where
        F: FnMut(&DVector<f64>, usize) -> Result<(DVector<f64>, SparseJacobian, DMatrix<f64>)>,
    {
        (0..count)
            .map(|i| {
                let (nu, h, r) = observe(&self.x, i)?;
                self.update(&nu, &h, &r)
            })
            .collect()
    }

    /// Appends a landmark initialised from an observation through the inverse
    /// observation model `l = g(x_robot, z)`: mean `mean`, Jacobians `G_robot =
    /// dg/dx_robot` and `G_z = dg/dz`, observation noise `R`. The new rows get the
    /// full cross-covariance `G_robot P_robot,:`. Returns the landmark's index.
    pub fn add_landmark(
        &mut self,
        mean: &DVector<f64>,
        g_robot: &DMatrix<f64>,
        g_z: &DMatrix<f64>,
        r: &DMatrix<f64>,
    ) -> Result<usize> {
        let (rd, m) = (self.robot_dim, self.landmark_dim);
        let q = r.nrows();
        if mean.len() != m
            || g_robot.shape() != (m, rd)
            || g_z.shape() != (m, q)
            || r.shape() != (q, q)
        {
            return Err(SlamError::dimension(format!(
                "a landmark needs mean {m}, G_robot {m}x{rd}, G_z {m}x{q}, R {q}x{q}"
            )));
        }
        for (what, values) in [
            ("landmark mean", mean.as_slice()),
            ("G_robot", g_robot.as_slice()),
            ("G_z", g_z.as_slice()),
        ] {
            ensure_finite(what, values.iter())?;
        }
        check_noise("R", r)?;
        let d = self.x.len();
        let rows = self.robot_rows();
        let cross = g_robot * &rows; // m x d
        let prr = rows.columns(0, rd);
        let pll = g_robot * prr * g_robot.transpose() + g_z * r * g_z.transpose();
        let pll = (&pll + pll.transpose()) * 0.5;
        // Checked before writing: a huge range times a huge R overflows to inf, which
        // would otherwise enter P and poison every later step.
        let finite = pll.iter().chain(cross.iter()).all(|v| v.is_finite());
        if !finite || pll.diagonal().iter().any(|&v| v < 0.0) {
            return Err(SlamError::Diverged(
                "add_landmark: the new landmark's covariance is not finite or has a negative \
                 variance"
                    .into(),
            ));
        }
        let old = std::mem::replace(&mut self.cov, DMatrix::zeros(0, 0));
        let mut cov = old.resize(d + m, d + m, 0.0);
        // The new columns' upper part; the block below the diagonal is never read.
        cov.view_mut((0, d), (d, m)).copy_from(&cross.transpose());
        cov.view_mut((d, d), (m, m)).copy_from(&pll);
        self.cov = cov;
        let x = std::mem::replace(&mut self.x, DVector::zeros(0));
        self.x = x.resize_vertically(d + m, 0.0);
        self.x.rows_mut(d, m).copy_from(mean);
        Ok(self.num_landmarks() - 1)
    }
}

/// `S = H L + R` (eq. 8) with `L = P H^T`, symmetrised.
fn innovation_covariance(h: &SparseJacobian, l: &DMatrix<f64>, r: &DMatrix<f64>) -> DMatrix<f64> {
    let m = h.rows;
    let mut s = r.clone();
    for b in &h.blocks {
        for a in 0..b.h.nrows() {
            for c in 0..b.h.ncols() {
                let coeff = b.h[(a, c)];
                if coeff != 0.0 {
                    for k in 0..m {
                        s[(b.row + a, k)] += coeff * l[(b.col + c, k)];
                    }
                }
            }
        }
    }
    (&s + s.transpose()) * 0.5
}

/// The gain `K = L S^-1` (eq. 7, from `S K^T = L^T`) and the NIS `nu^T S^-1 nu`;
/// an error when `S` has no Cholesky factor or the gain is not finite.
fn gain_and_nis(
    s: &DMatrix<f64>,
    l: &DMatrix<f64>,
    innovation: &DVector<f64>,
) -> Result<(DMatrix<f64>, f64)> {
    if !s.iter().all(|v| v.is_finite()) {
        return Err(SlamError::SingularInnovation("S is not finite".into()));
    }
    let chol = s.clone().cholesky().ok_or_else(|| {
        SlamError::SingularInnovation(format!("S = {s:.3e} has no Cholesky factor"))
    })?;
    let gain = chol.solve(&l.transpose()).transpose();
    if !gain.iter().all(|v| v.is_finite()) {
        return Err(SlamError::SingularInnovation(
            "the gain is not finite (S is numerically singular)".into(),
        ));
    }
    Ok((gain, innovation.dot(&chol.solve(innovation))))
}

/// `P <- P - K L^T + M K^T` on the upper triangle, one column prefix `P[0..=j, j]` at
/// a time (contiguous in nalgebra's column-major storage), on all cores for large
/// states. Every entry is computed by the same operations whatever the thread count,
/// so results are bit-identical.
fn joseph_columns(p: &mut DMatrix<f64>, k: &DMatrix<f64>, l: &DMatrix<f64>, m: &DMatrix<f64>) {
    let d = p.nrows();
    let obs = k.ncols();
    let (ks, ls, ms) = (k.as_slice(), l.as_slice(), m.as_slice());
    let update_column = |j: usize, col: &mut [f64]| {
        let upper = &mut col[..=j];
        for a in 0..obs {
            let (ka, ma) = (&ks[a * d..a * d + j + 1], &ms[a * d..a * d + j + 1]);
            let (alpha, beta) = (-ls[a * d + j], ks[a * d + j]);
            for ((c, &kv), &mv) in upper.iter_mut().zip(ka).zip(ma) {
                *c += alpha * kv + beta * mv;
            }
        }
    };
    let data = p.as_mut_slice();
    if d >= PARALLEL_MIN_DIM {
        data.par_chunks_mut(d)
            .with_min_len(8)
            .enumerate()
            .for_each(|(j, col)| update_column(j, col));
    } else {
        data.chunks_mut(d)
            .enumerate()
            .for_each(|(j, col)| update_column(j, col));
    }
}
