//! The EKF-SLAM core: a robot block plus landmark blocks with a full covariance,
//! seed 000 equations (3) to (9).
//!
//! Prediction touches only the robot rows and columns (O(n)). The update exploits
//! the sparse observation Jacobian: `H` is a few dense blocks (the robot and one
//! landmark, say), so `P H^T` costs O(n p) and the Joseph form, expanded as
//! `P - K (P H^T)^T + (K S - P H^T) K^T`, costs one pass over `P` (O(n^2 p)).
//!
//! `P` is symmetric, so only its lower triangle (with the diagonal) is kept up to
//! date: the update reads and writes half the matrix, which is what bounds its speed
//! (memory bandwidth), and the robot columns the prediction touches are contiguous.
//! [`Ekf::covariance`] returns the full matrix; the block readers return one block.

use std::collections::HashMap;

use nalgebra::{DMatrix, DVector, Matrix2, Matrix3, Matrix3x2, Vector3};
use rayon::prelude::*;

use rperc_core::{
    Definiteness, check_allocation, check_covariance, cholesky_inverse, cholesky_lower,
    cholesky_solve_mut, wrap_angle,
};

use crate::error::{Result, SlamError, ensure_finite};

mod compressed;
pub use compressed::{Compressed, Passive};

/// A fixed-size block as the dynamic matrix a [`SparseJacobian`] block or a noise
/// covariance is given as.
pub(crate) fn dyn_mat<const R: usize, const C: usize>(
    m: &nalgebra::SMatrix<f64, R, C>,
) -> DMatrix<f64> {
    DMatrix::from_column_slice(R, C, m.as_slice())
}

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
            ensure_finite("Jacobian", b.h.as_slice().iter())?;
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

/// State rows per block of the O(n m^2) products of an update, between which a Ctrl-C
/// is heard (about 10 ms per block at m = 3000).
pub(crate) const INTERRUPTIBLE_ROWS: usize = 256;

/// Joseph updates of more multiply-adds than this (about 0.1 s) go through a copy of
/// `P` so that Ctrl-C can stop them without leaving `P` half written.
const INTERRUPTIBLE_JOSEPH_FLOPS: usize = 100_000_000;

/// The finite inputs of a prediction: the robot's new mean and the Jacobians.
fn check_prediction<'a>(
    robot_mean: impl IntoIterator<Item = &'a f64>,
    fx: impl IntoIterator<Item = &'a f64>,
    fv: impl IntoIterator<Item = &'a f64>,
) -> Result<()> {
    ensure_finite("robot mean", robot_mean)?;
    ensure_finite("Fx", fx)?;
    ensure_finite("Fv", fv)?;
    Ok(())
}

/// `Err(Diverged)` unless the predicted covariance entries `values` are finite and
/// its `variances` (the diagonal) not negative.
fn check_predicted<'a>(
    mut values: impl Iterator<Item = &'a f64>,
    mut variances: impl Iterator<Item = &'a f64>,
) -> Result<()> {
    if values.all(|v| v.is_finite()) && !variances.any(|&v| v < 0.0) {
        return Ok(());
    }
    Err(SlamError::Diverged(
        "predict: the predicted robot covariance is not finite or has a negative variance".into(),
    ))
}

/// Refuses a noise covariance (`V`, `R`) that is not symmetric positive
/// semi-definite: a negative variance would make `P` indefinite without any error
/// further down. Zero noise is allowed.
fn check_noise(name: &'static str, c: &DMatrix<f64>) -> Result<()> {
    Ok(check_covariance(name, c, Definiteness::SemiPositive)?)
}

/// What a gated update did: applied, or refused because its NIS exceeded the gate
/// (the filter is then unchanged).
#[derive(Debug, Clone, PartialEq)]
pub enum Gated {
    /// The NIS was within the gate and the update was applied.
    Applied(Update),
    /// The NIS `nu^T S^-1 nu` exceeded `gate`; nothing was changed.
    Rejected {
        /// The innovation's NIS at the prior state.
        nis: f64,
        /// The chi-square gate it was compared with.
        gate: f64,
    },
}

/// The parts of an update computed before anything is written.
struct Prepared {
    l: DMatrix<f64>,
    s: DMatrix<f64>,
    gain: DMatrix<f64>,
    nis: f64,
}

/// An extended Kalman filter over a robot block of size `robot_dim` followed by
/// landmark blocks of size `landmark_dim`. The state covariance is `P` in the seed's
/// equations and `covariance` in the API. Each landmark carries an id (`u64`); the
/// filter maps ids to state indices and removes landmarks (marginalisation).
///
/// `P` lives in a buffer with spare capacity that grows geometrically, so adding `n`
/// landmarks one by one costs amortised O(n) per landmark, not a reallocation of the
/// whole matrix each time. Only its lower triangle is current: the robot columns
/// `P[:, 0..r]` are then contiguous in nalgebra's column-major storage, which is what
/// the O(n) prediction reads and writes.
///
/// # Examples
/// ```
/// use nalgebra::{DMatrix, DVector, Matrix2, Matrix3, Matrix3x2, Vector3};
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
    /// `P` in a `cap x cap` buffer: the lower triangle (with the diagonal) of its
    /// leading `d x d` block is current, the rest is never read.
    cov: DMatrix<f64>,
    robot_dim: usize,
    landmark_dim: usize,
    /// State indices holding angles, wrapped to (-pi, pi] after every update.
    angles: Vec<usize>,
    /// `ids[j]` is landmark `j`'s id; `index` is the inverse map.
    ids: Vec<u64>,
    index: HashMap<u64, usize>,
    next_id: u64,
    /// Ids of the landmarks held as consider states (Schmidt): zero gain, so their
    /// means and own covariances stay fixed while their cross-covariances stay exact.
    consider: Vec<u64>,
}

impl Ekf {
    /// A filter with state `x` and covariance `covariance` (symmetric positive
    /// semi-definite: a zero block is a perfectly known start): a robot block of
    /// `robot_dim` entries, then landmark blocks of `landmark_dim` entries each.
    /// The landmarks get ids `0, 1, ...`.
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
        let n = (d - robot_dim) / landmark_dim;
        let ids: Vec<u64> = (0..n as u64).collect();
        let index = ids.iter().map(|&id| (id, id as usize)).collect();
        Ok(Self {
            x,
            cov: covariance,
            robot_dim,
            landmark_dim,
            angles: Vec::new(),
            ids,
            index,
            next_id: n as u64,
            consider: Vec::new(),
        })
    }

    /// Marks state entry `index` (inside the robot block) as an angle: it is wrapped
    /// to (-pi, pi] after every update, so a heading never drifts out of range.
    pub fn with_wrapped_angle(mut self, index: usize) -> Result<Self> {
        if index >= self.robot_dim {
            return Err(SlamError::invalid(
                "index",
                format!("an angle must be in the robot block (< {})", self.robot_dim),
            ));
        }
        self.angles.push(index);
        self.wrap_angles();
        Ok(self)
    }

    /// Marks entry `index` as an angle if it is not yet (for the planar helpers).
    pub(crate) fn ensure_wrapped_angle(&mut self, index: usize) {
        if !self.angles.contains(&index) {
            self.angles.push(index);
            self.wrap_angles();
        }
    }

    fn wrap_angles(&mut self) {
        for &i in &self.angles {
            self.x[i] = wrap_angle(self.x[i]);
        }
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
        self.wrap_angles();
        Ok(())
    }

    fn dim(&self) -> usize {
        self.x.len()
    }

    /// The state covariance `P` (the full symmetric matrix, built from the stored
    /// lower triangle: O(n^2)). Prefer the block readers when a block is enough.
    pub fn covariance(&self) -> DMatrix<f64> {
        let d = self.dim();
        let mut full = self.cov.view((0, 0), (d, d)).into_owned();
        full.fill_upper_triangle_with_lower_triangle();
        full
    }

    /// Entry `(i, j)` of `P` read from the stored lower triangle.
    #[inline]
    fn cov_at(&self, i: usize, j: usize) -> f64 {
        if i >= j {
            self.cov[(i, j)]
        } else {
            self.cov[(j, i)]
        }
    }

    /// The block `P[row..row + nrows, col..col + ncols]`, read without copying the
    /// rest of the matrix.
    pub fn covariance_block(
        &self,
        row: usize,
        col: usize,
        nrows: usize,
        ncols: usize,
    ) -> Result<DMatrix<f64>> {
        let d = self.dim();
        if row + nrows > d || col + ncols > d {
            return Err(SlamError::dimension(format!(
                "block {nrows}x{ncols} at ({row}, {col}) does not fit a {d}x{d} covariance"
            )));
        }
        Ok(DMatrix::from_fn(nrows, ncols, |i, j| {
            self.cov_at(row + i, col + j)
        }))
    }

    /// The block `P[row..row + R, col..col + C]` as a fixed-size matrix, read from
    /// the stored lower triangle without allocating (the association reads many
    /// 2x2 and 3x2 blocks per scan); `None` when it does not fit.
    pub fn covariance_block_fixed<const R: usize, const C: usize>(
        &self,
        row: usize,
        col: usize,
    ) -> Option<nalgebra::SMatrix<f64, R, C>> {
        let d = self.dim();
        (row + R <= d && col + C <= d)
            .then(|| nalgebra::SMatrix::from_fn(|i, j| self.cov_at(row + i, col + j)))
    }

    /// The robot block `P_rr` (`robot_dim x robot_dim`).
    pub fn robot_covariance(&self) -> DMatrix<f64> {
        let r = self.robot_dim;
        DMatrix::from_fn(r, r, |i, j| self.cov_at(i, j))
    }

    /// The planar robot block as a fixed-size matrix (the top-left 3x3 of `P`;
    /// with a smaller robot block, the rows and columns past it are zero).
    pub fn robot_covariance_planar(&self) -> Matrix3<f64> {
        let r = self.robot_dim.min(3);
        Matrix3::from_fn(|i, j| {
            if i < r && j < r {
                self.cov_at(i, j)
            } else {
                0.0
            }
        })
    }

    /// Landmark `j`'s own block `P_jj` (`landmark_dim x landmark_dim`).
    pub fn landmark_covariance(&self, j: usize) -> Result<DMatrix<f64>> {
        let off = self.landmark_offset(j)?;
        let m = self.landmark_dim;
        self.covariance_block(off, off, m, m)
    }

    /// The robot-landmark cross block `P_rj` (`robot_dim x landmark_dim`).
    pub fn robot_landmark_covariance(&self, j: usize) -> Result<DMatrix<f64>> {
        let off = self.landmark_offset(j)?;
        self.covariance_block(0, off, self.robot_dim, self.landmark_dim)
    }

    /// Column `c` of `P` into `out`: the part on and below the diagonal is one
    /// contiguous slice, the part above comes from row `c`.
    fn covariance_column_into(&self, c: usize, out: &mut [f64]) {
        let d = self.dim();
        for (i, o) in out.iter_mut().enumerate().take(c) {
            *o = self.cov[(c, i)];
        }
        out[c..d].copy_from_slice(&self.cov.column(c).as_slice()[c..d]);
    }

    /// The robot columns `P[:, 0..r]` in full (`d x r`).
    fn robot_columns(&self) -> DMatrix<f64> {
        DMatrix::from_fn(self.dim(), self.robot_dim, |i, j| self.cov_at(i, j))
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

    /// The index of the landmark with id `id`, if it is in the state.
    pub fn landmark_index(&self, id: u64) -> Option<usize> {
        self.index.get(&id).copied()
    }

    /// The id of landmark `j`.
    pub fn landmark_id(&self, j: usize) -> Result<u64> {
        self.landmark_offset(j)?;
        Ok(self.ids[j])
    }

    /// The ids of the landmarks in state order.
    pub fn landmark_ids(&self) -> &[u64] {
        &self.ids
    }

    /// Prediction, eqs. (3) and (5): the robot block moves to `robot_mean` and
    /// `P <- Fx P Fx^T + Fv V Fv^T` with `Fx` acting on the robot block only
    /// (landmarks are static). O(n): it reads and writes the robot columns, which
    /// are contiguous in the stored lower triangle.
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
        check_prediction(robot_mean.iter(), fx.iter(), fv.iter())?;
        check_noise("V", v)?;
        let d = self.dim();
        let prr = self.robot_covariance();
        let new_rr = fx * prr * fx.transpose() + fv * v * fv.transpose();
        // P_lr <- P_lr Fx^T: the landmark rows of the robot columns (contiguous).
        let cross = self.cov.view((r, 0), (d - r, r)) * fx.transpose();
        // Check before writing, so a diverged prediction leaves the filter as it was.
        check_predicted(new_rr.iter().chain(cross.iter()), new_rr.diagonal().iter())?;
        self.cov.view_mut((r, 0), (d - r, r)).copy_from(&cross);
        self.cov
            .view_mut((0, 0), (r, r))
            .copy_from(&((&new_rr + new_rr.transpose()) * 0.5));
        self.x.rows_mut(0, r).copy_from(robot_mean);
        self.wrap_angles();
        Ok(())
    }

    /// [`Ekf::predict`] for a planar robot (`robot_dim == 3`) with fixed-size
    /// Jacobians and no allocation: `P_lr <- P_lr Fx^T` is done in place, row by row
    /// over the three contiguous robot columns. The path of a long odometry stream.
    pub fn predict_planar(
        &mut self,
        robot_mean: &Vector3<f64>,
        fx: &Matrix3<f64>,
        fv: &Matrix3x2<f64>,
        v: &Matrix2<f64>,
    ) -> Result<()> {
        if self.robot_dim != 3 {
            return Err(SlamError::dimension(format!(
                "predict_planar needs a robot block of 3, not {}",
                self.robot_dim
            )));
        }
        check_prediction(robot_mean.iter(), fx.iter(), fv.iter())?;
        check_noise("V", &DMatrix::from_column_slice(2, 2, v.as_slice()))?;
        let prr = Matrix3::from_fn(|i, j| self.cov_at(i, j));
        let new_rr = fx * prr * fx.transpose() + fv * v * fv.transpose();
        check_predicted(new_rr.iter(), new_rr.diagonal().iter())?;
        let (d, cap) = (self.dim(), self.cov.nrows());
        let data = self.cov.as_mut_slice();
        let (c0, rest) = data.split_at_mut(cap);
        let (c1, c2) = rest.split_at_mut(cap);
        for i in 3..d {
            let row = Vector3::new(c0[i], c1[i], c2[i]);
            let moved = fx * row;
            (c0[i], c1[i], c2[i]) = (moved.x, moved.y, moved.z);
        }
        let sym = (new_rr + new_rr.transpose()) * 0.5;
        for j in 0..3 {
            for i in j..3 {
                self.cov[(i, j)] = sym[(i, j)];
            }
        }
        self.x.fixed_rows_mut::<3>(0).copy_from(robot_mean);
        self.wrap_angles();
        Ok(())
    }

    /// `L = P H^T` (d x m), touching only the columns of `P` that `H`'s blocks select.
    fn cross_covariance(&self, h: &SparseJacobian) -> DMatrix<f64> {
        let d = self.dim();
        let mut l = DMatrix::<f64>::zeros(d, h.rows);
        let mut column = DVector::<f64>::zeros(d);
        for b in &h.blocks {
            for c in 0..b.h.ncols() {
                self.covariance_column_into(b.col + c, column.as_mut_slice());
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
        let d = self.x.len();
        let mut change = vec![0.0; d];
        // Down the columns (contiguous), the sum over them in the same order as a row.
        for a in 0..gain.ncols() {
            let (g, m, l) = (gain.column(a), ks_minus_l.column(a), l.column(a));
            for (i, c) in change.iter_mut().enumerate() {
                *c += g[i] * (m[i] - l[i]);
            }
        }
        for (i, c) in change.into_iter().enumerate() {
            let old = self.cov[(i, i)];
            let new = old + c;
            if !new.is_finite() || new < -1e-9 * old.abs().max(f64::MIN_POSITIVE) {
                return Err(SlamError::Diverged(format!(
                    "update: the variance of state {i} would become {new:.3e} (was {old:.3e})"
                )));
            }
        }
        Ok(())
    }

    /// Checks the inputs and computes `L = P H^T`, `S` (eq. 8), `K` (eq. 7) and the
    /// NIS, writing nothing.
    fn prepare(
        &self,
        innovation: &DVector<f64>,
        h: &SparseJacobian,
        r: &DMatrix<f64>,
        r_checked: bool,
    ) -> Result<Prepared> {
        let m = h.rows;
        if innovation.len() != m || r.shape() != (m, m) || m == 0 {
            return Err(SlamError::dimension(format!(
                "update needs an innovation of {m} > 0 entries and R {m}x{m}; got {} and {:?}",
                innovation.len(),
                r.shape()
            )));
        }
        h.validate(self.x.len())?;
        ensure_finite("innovation", innovation.as_slice().iter())?;
        if !r_checked {
            check_noise("R", r)?;
        }
        let l = self.cross_covariance(h);
        let s = innovation_covariance(h, &l, r);
        let (mut gain, nis) = gain_and_nis(&s, &l, innovation)?;
        for id in &self.consider {
            let off = self.robot_dim + self.index[id] * self.landmark_dim;
            gain.rows_mut(off, self.landmark_dim).fill(0.0);
        }
        Ok(Prepared { l, s, gain, nis })
    }

    /// Applies a prepared update: eq. (6) for the mean, the Joseph form (9) for `P`.
    fn apply(&mut self, p: Prepared, innovation: &DVector<f64>) -> Result<Update> {
        let dx = &p.gain * innovation;
        if !dx.as_slice().iter().all(|v| v.is_finite()) {
            return Err(SlamError::SingularInnovation(
                "the state correction is not finite".into(),
            ));
        }
        // Joseph form, eq. (9), expanded for the sparse H:
        // (I - K H) P (I - K H)^T + K R K^T = P - K L^T - L K^T + K S K^T
        //                                   = P - K L^T + (K S - L) K^T.
        let ks_minus_l = ks_minus_l(&p)?;
        self.check_updated_diagonal(&p.gain, &p.l, &ks_minus_l)?;
        let d = self.dim();
        joseph_columns(&mut self.cov, d, &p.gain, &p.l, &ks_minus_l)?;
        self.x += dx;
        self.wrap_angles();
        Ok(Update {
            innovation: innovation.clone(),
            innovation_cov: p.s,
            gain: p.gain,
            nis: p.nis,
        })
    }

    /// Measurement update, eqs. (6) to (9), with the Joseph form in O(n^2 m) for a
    /// sparse `H` of `m` rows. On error (sizes, NaN, a singular `S`) the state is
    /// unchanged. Angles marked with [`Ekf::with_wrapped_angle`] are wrapped after.
    pub fn update(
        &mut self,
        innovation: &DVector<f64>,
        h: &SparseJacobian,
        r: &DMatrix<f64>,
    ) -> Result<Update> {
        let prepared = self.prepare(innovation, h, r, false)?;
        self.apply(prepared, innovation)
    }

    /// The update of [`Ekf::update`] behind a chi-square validation gate: the NIS is
    /// computed at the prior state and, when it exceeds `gate`, nothing is applied
    /// and the rejection is returned with its NIS.
    pub fn update_gated(
        &mut self,
        innovation: &DVector<f64>,
        h: &SparseJacobian,
        r: &DMatrix<f64>,
        gate: f64,
    ) -> Result<Gated> {
        if gate.is_nan() || gate <= 0.0 {
            return Err(SlamError::invalid(
                "gate",
                format!("must be > 0, got {gate}"),
            ));
        }
        let prepared = self.prepare(innovation, h, r, false)?;
        if prepared.nis > gate {
            return Ok(Gated::Rejected {
                nis: prepared.nis,
                gate,
            });
        }
        Ok(Gated::Applied(self.apply(prepared, innovation)?))
    }

    /// Several observations stacked into one update (one `S`, one pass over `P`).
    /// Each item is `(innovation, H, R)` for the same state; rows are renumbered.
    pub fn update_batch(
        &mut self,
        observations: &[(DVector<f64>, SparseJacobian, DMatrix<f64>)],
    ) -> Result<Update> {
        // Each R on its own: the stacked R is block diagonal, so it is PSD exactly
        // when every block is, and checking the whole (an eigen-decomposition) would
        // cost O(m^3) per scan.
        for (_, _, r) in observations {
            check_noise("R", r)?;
        }
        let (innovation, h, r) = stack_observations(observations)?;
        let prepared = self.prepare(&innovation, &h, &r, true)?;
        self.apply(prepared, &innovation)
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

    /// Grows the covariance buffer to hold a state of `need` entries, by at least
    /// half its size so that `n` additions cost O(n^2) copying in total, not O(n^3).
    fn reserve(&mut self, need: usize) -> Result<()> {
        let cap = self.cov.nrows();
        if need <= cap {
            return Ok(());
        }
        let new_cap = need.max(cap + cap / 2).max(16);
        // The count is the dimension itself (not its square, which no caller set).
        check_allocation("state dimension", new_cap as u128, new_cap as u128 * 8)?;
        self.grow(new_cap);
        Ok(())
    }

    /// Moves `P` into a `new_cap x new_cap` buffer (unchecked: see [`Ekf::reserve`]).
    fn grow(&mut self, new_cap: usize) {
        let d = self.dim();
        let mut grown = DMatrix::zeros(new_cap, new_cap);
        grown
            .view_mut((0, 0), (d, d))
            .copy_from(&self.cov.view((0, 0), (d, d)));
        self.cov = grown;
    }

    /// Appends a landmark initialised from an observation through the inverse
    /// observation model `l = g(x_robot, z)`: mean `mean`, Jacobians `G_robot =
    /// dg/dx_robot` and `G_z = dg/dz`, observation noise `R`. The new rows get the
    /// full cross-covariance `G_robot P_robot,:`. Returns the landmark's index; its id
    /// is the next unused one.
    pub fn add_landmark(
        &mut self,
        mean: &DVector<f64>,
        g_robot: &DMatrix<f64>,
        g_z: &DMatrix<f64>,
        r: &DMatrix<f64>,
    ) -> Result<usize> {
        while self.index.contains_key(&self.next_id) {
            self.next_id += 1;
        }
        self.add_landmark_with_id(self.next_id, mean, g_robot, g_z, r)
    }

    /// [`Ekf::add_landmark`] with the landmark's id given; an error when a landmark
    /// with this id is already in the state.
    pub fn add_landmark_with_id(
        &mut self,
        id: u64,
        mean: &DVector<f64>,
        g_robot: &DMatrix<f64>,
        g_z: &DMatrix<f64>,
        r: &DMatrix<f64>,
    ) -> Result<usize> {
        if self.index.contains_key(&id) {
            return Err(SlamError::invalid(
                "id",
                format!("landmark {id} is already in the state"),
            ));
        }
        self.check_landmark_inputs(mean, g_robot, g_z, r)?;
        let (rd, m, d) = (self.robot_dim, self.landmark_dim, self.dim());
        let cols = self.robot_columns();
        let cross = g_robot * cols.transpose(); // m x d
        let prr = cols.rows(0, rd);
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
        self.reserve(d + m)?;
        // The new rows below the old block, and the new diagonal block.
        self.cov.view_mut((d, 0), (m, d)).copy_from(&cross);
        self.cov.view_mut((d, d), (m, m)).copy_from(&pll);
        let x = std::mem::replace(&mut self.x, DVector::zeros(0));
        self.x = x.resize_vertically(d + m, 0.0);
        self.x.rows_mut(d, m).copy_from(mean);
        let j = self.ids.len();
        self.ids.push(id);
        self.index.insert(id, j);
        Ok(j)
    }

    fn check_landmark_inputs(
        &self,
        mean: &DVector<f64>,
        g_robot: &DMatrix<f64>,
        g_z: &DMatrix<f64>,
        r: &DMatrix<f64>,
    ) -> Result<()> {
        let (rd, m, q) = (self.robot_dim, self.landmark_dim, r.nrows());
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
        check_noise("R", r)
    }

    /// Holds landmark `j` as a consider state (the Schmidt-Kalman filter): from now
    /// on no update changes its mean or its own covariance (its rows of the gain are
    /// zero), while the Joseph form keeps every cross-covariance exact for that gain.
    /// The landmark still informs the rest of the state through its correlations, so
    /// a landmark treated as known stays honest about what it is not known to.
    pub fn set_consider(&mut self, j: usize) -> Result<()> {
        let id = self.landmark_id(j)?;
        if !self.consider.contains(&id) {
            self.consider.push(id);
        }
        Ok(())
    }

    /// Whether landmark `j` is a consider state (see [`Ekf::set_consider`]).
    pub fn is_consider(&self, j: usize) -> bool {
        self.ids.get(j).is_some_and(|id| self.consider.contains(id))
    }

    /// Removes landmark `j` from the state (marginalisation: its rows and columns
    /// are dropped, the rest of `P` is exact). Later landmarks move down one index.
    /// Returns the removed landmark's id. O(n^2) memory moves, no allocation.
    pub fn remove_landmark(&mut self, j: usize) -> Result<u64> {
        let off = self.landmark_offset(j)?;
        let (m, d, cap) = (self.landmark_dim, self.dim(), self.cov.nrows());
        let data = self.cov.as_mut_slice();
        // Columns left of the landmark: close the gap in their rows.
        for c in 0..off {
            let base = c * cap;
            data.copy_within(base + off + m..base + d, base + off);
        }
        // Columns right of it move left by m, their lower parts up by m.
        for c in off + m..d {
            let (src, dst) = (c * cap + c, (c - m) * cap + (c - m));
            data.copy_within(src..src + (d - c), dst);
        }
        let x = std::mem::replace(&mut self.x, DVector::zeros(0));
        self.x = x.remove_rows(off, m);
        let id = self.ids.remove(j);
        self.index.remove(&id);
        self.consider.retain(|&c| c != id);
        for (k, other) in self.ids.iter().enumerate().skip(j) {
            self.index.insert(*other, k);
        }
        Ok(id)
    }
}

/// Stacks `(innovation, H, R)` items into one observation with renumbered rows and a
/// block-diagonal `R` (the items' noises are independent).
fn stack_observations(
    observations: &[(DVector<f64>, SparseJacobian, DMatrix<f64>)],
) -> Result<(DVector<f64>, SparseJacobian, DMatrix<f64>)> {
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
    Ok((innovation, h, r))
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

/// `K S - L`, a block of state rows at a time with a Ctrl-C checkpoint between
/// blocks (O(n m^2); nothing is written to the filter yet, so stopping is safe).
fn ks_minus_l(p: &Prepared) -> Result<DMatrix<f64>> {
    let mut out = p.l.clone();
    out.as_mut_slice().iter_mut().for_each(|v| *v = -*v);
    for start in (0..out.nrows()).step_by(INTERRUPTIBLE_ROWS) {
        let rows = INTERRUPTIBLE_ROWS.min(out.nrows() - start);
        let mut block = out.rows_mut(start, rows);
        block.gemm(1.0, &p.gain.rows(start, rows), &p.s, 1.0);
        rperc_core::interrupt::checkpoint()?;
    }
    Ok(out)
}

/// The gain `K = L S^-1` (eq. 7, from `S K^T = L^T`) and the NIS `nu^T S^-1 nu`;
/// an error when `S` has no Cholesky factor or the gain is not finite.
fn gain_and_nis(
    s: &DMatrix<f64>,
    l: &DMatrix<f64>,
    innovation: &DVector<f64>,
) -> Result<(DMatrix<f64>, f64)> {
    if !s.as_slice().iter().all(|v| v.is_finite()) {
        return Err(SlamError::SingularInnovation("S is not finite".into()));
    }
    let factor = cholesky_lower(s)?.ok_or_else(|| {
        SlamError::SingularInnovation(format!("S = {s:.3e} has no Cholesky factor"))
    })?;
    // `S^-1` is small (m x m): `K = L S^-1` is then a matrix product, much faster than
    // m triangular solves against the d columns of `L^T`. It runs a block of state
    // rows at a time: with every landmark observed (monobot) it is O(n^3), seconds at
    // n = 3000, and Ctrl-C is heard between blocks.
    let s_inv = cholesky_inverse(&factor);
    let mut gain = DMatrix::<f64>::zeros(l.nrows(), l.ncols());
    for start in (0..l.nrows()).step_by(INTERRUPTIBLE_ROWS) {
        let rows = INTERRUPTIBLE_ROWS.min(l.nrows() - start);
        let mut block = gain.rows_mut(start, rows);
        block.gemm(1.0, &l.rows(start, rows), &s_inv, 0.0);
        rperc_core::interrupt::checkpoint()?;
    }
    if !gain.as_slice().iter().all(|v| v.is_finite()) {
        return Err(SlamError::SingularInnovation(
            "the gain is not finite (S is numerically singular)".into(),
        ));
    }
    let mut whitened = DMatrix::from_column_slice(innovation.len(), 1, innovation.as_slice());
    cholesky_solve_mut(&factor, &mut whitened);
    Ok((gain, innovation.dot(&whitened.column(0))))
}

/// Width of the column blocks of the Joseph update: each block is one matrix product
/// `[K M] [-L K]^T` restricted to the rows on and below the block, so `K` and `M`
/// are streamed once per block rather than once per column.
const JOSEPH_BLOCK: usize = 48;

/// Joseph column blocks between two Ctrl-C checkpoints of a large update.
const JOSEPH_BLOCKS_PER_CHECKPOINT: usize = 5;

/// `P <- P - K L^T + M K^T` on the lower triangle of the leading `d x d` block, as
/// `P[j0.., J] += [K M][j0.., :] [-L K][J, :]^T` for column blocks `J = j0..j0 + w`
/// (cache-blocked products; the diagonal blocks also write the part of the block
/// above the diagonal, which is never read), on all cores for large states. Every
/// entry is computed by the same operations whatever the thread count, so results
/// are bit-identical.
///
/// A large update (seconds with thousands of observations at once) is written to a
/// copy, a few blocks at a time with a Ctrl-C checkpoint between them, and copied
/// back only when complete: an interrupted update leaves `P` as it was.
fn joseph_columns(
    p: &mut DMatrix<f64>,
    d: usize,
    k: &DMatrix<f64>,
    l: &DMatrix<f64>,
    m: &DMatrix<f64>,
) -> Result<()> {
    let obs = k.ncols();
    // Column-major `d x obs` matrices are contiguous: `A = [K M]` is the two slices
    // one after the other.
    let a =
        DMatrix::<f64>::from_iterator(d, 2 * obs, k.as_slice().iter().chain(m.as_slice()).copied());
    // `B^T = [-L K]^T` stored so that the block product reads contiguous columns.
    let mut bt = DMatrix::<f64>::zeros(2 * obs, d);
    let (ls, ks) = (l.as_slice(), k.as_slice());
    for (i, col) in bt.as_mut_slice().chunks_exact_mut(2 * obs).enumerate() {
        for j in 0..obs {
            col[j] = -ls[j * d + i];
            col[obs + j] = ks[j * d + i];
        }
    }
    add_lower_product(p, d, &a, &bt)
}

/// `P += A B^T` on the lower triangle of the leading `d x d` block of `P` (`A`,
/// `B` `d x k`; `bt` is `B^T`, `k x d`), by column blocks (see [`joseph_columns`]);
/// a large product goes through a copy with Ctrl-C checkpoints, so that an
/// interrupted update leaves `P` as it was.
fn add_lower_product(
    p: &mut DMatrix<f64>,
    d: usize,
    a: &DMatrix<f64>,
    bt: &DMatrix<f64>,
) -> Result<()> {
    let cap = p.nrows();
    let data = &mut p.as_mut_slice()[..d * cap];
    // Half the inner size: the observation rows of a Joseph update (its threshold).
    let obs = a.ncols().div_ceil(2);
    if (d * d / 2).saturating_mul(obs) < INTERRUPTIBLE_JOSEPH_FLOPS {
        lower_product_blocks(data, cap, d, 0, a, bt);
        return Ok(());
    }
    check_allocation("covariance copy of a large update", (d * cap) as u128, 8)?;
    let mut copy = data.to_vec();
    let step = JOSEPH_BLOCK * JOSEPH_BLOCKS_PER_CHECKPOINT;
    for first in (0..d).step_by(step) {
        let cols = step.min(d - first);
        let chunk = &mut copy[first * cap..(first + cols) * cap];
        lower_product_blocks(chunk, cap, d, first / JOSEPH_BLOCK, a, bt);
        rperc_core::interrupt::checkpoint()?;
    }
    data.copy_from_slice(&copy);
    Ok(())
}

/// `P += A B^T` on the lower triangle of the leading `d x d` block of `P` at once
/// (no checkpoint: for a global update of a compressed filter, which must not stop
/// half way).
pub(crate) fn add_lower_product_now(
    p: &mut DMatrix<f64>,
    d: usize,
    a: &DMatrix<f64>,
    bt: &DMatrix<f64>,
) {
    let cap = p.nrows();
    lower_product_blocks(&mut p.as_mut_slice()[..d * cap], cap, d, 0, a, bt);
}

/// The column blocks of `P += A B^T` held in `cols` (whole blocks of `P`'s columns,
/// `cap` rows each, the first of them block `first`): each block is one product
/// restricted to the rows on and below it, on all cores for large states, every entry
/// computed by the same operations whatever the thread count.
fn lower_product_blocks(
    cols: &mut [f64],
    cap: usize,
    d: usize,
    first: usize,
    a: &DMatrix<f64>,
    bt: &DMatrix<f64>,
) {
    // Block `b` of columns, `block` starting at row 0 of its first column.
    let update_block = |b: usize, block: &mut [f64]| {
        let j0 = b * JOSEPH_BLOCK;
        let w = JOSEPH_BLOCK.min(d - j0);
        let mut c = nalgebra::DMatrixViewMut::from_slice_with_strides_mut(
            &mut block[j0..],
            d - j0,
            w,
            1,
            cap,
        );
        c.gemm(1.0, &a.rows(j0, d - j0), &bt.columns(j0, w), 1.0);
    };
    if d >= PARALLEL_MIN_DIM {
        cols.par_chunks_mut(cap * JOSEPH_BLOCK)
            .enumerate()
            .for_each(|(b, block)| update_block(first + b, block));
    } else {
        cols.chunks_mut(cap * JOSEPH_BLOCK)
            .enumerate()
            .for_each(|(b, block)| update_block(first + b, block));
    }
}
