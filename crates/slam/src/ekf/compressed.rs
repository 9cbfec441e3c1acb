//! The compressed EKF of Guivant & Nebot (2001, "Optimization of the simultaneous
//! localization and map-building algorithm for real-time implementation", IEEE T-RA
//! 17(3)): while only the robot and the landmarks of a local area (the *active*
//! states `A`) are observed, only the sub-filter of `A` is updated, at O(N_A^2) per
//! update, and three auxiliary matrices accumulate what the updates do to the rest
//! (the *passive* states `B`). With `P_AB = phi P_AB0`:
//!
//! - prediction `x_r <- f(x_r)`: `phi_r <- F_x phi_r` (the robot rows);
//! - update with gain `K_A` and `H` touching `A` only:
//!   `psi += (H phi)^T S^-1 (H phi)`, `theta += (H phi)^T S^-1 nu`,
//!   `phi <- (I - K_A H) phi` (the prior `phi` on the right);
//!
//! and one global update restores the full filter exactly:
//! `P_AB = phi P_AB0`, `P_BB = P_BB0 - P_BA0 psi P_AB0`, `x_B = x_B0 + P_BA0 theta`.
//! The result equals the full EKF's up to round-off, whatever the number of updates,
//! as long as no update touches a passive state.
//!
//! Two operations (ours, exact by the same algebra) let the active set grow without a
//! global update:
//! a landmark *initialised* in the sub-filter from the robot (`l = g(x_r, z)`) has
//! `P_lB = G_r P_rB`, so its row of `phi` is `G_r phi_r`; and a passive landmark
//! `j` is *activated* by extending the basis `A0` with it: its current mean, own
//! covariance and cross-covariance with `A` come from the formulas above, its row of
//! `phi` is `[-P_jA0 psi, I]` (so `P_jB' = P_jB'0 - P_jA0 psi P_A0B'`), and `psi` and
//! `theta` grow by zeros.

use nalgebra::{
    DMatrix, DMatrixView, DMatrixViewMut, DVector, Matrix2, Matrix3, Matrix3x2, Point2,
};

use rperc_core::{cholesky_lower, lower_inverse};

use super::{Ekf, SparseJacobian, Update, add_lower_product_now};
use crate::error::{Result, SlamError};

/// A matrix in a buffer with spare rows and columns, so that growing it a landmark
/// at a time (the sub-filter by admissions and activations, the basis by
/// activations) costs amortised O(size of the new block), not a copy of the whole.
/// Entries past its size are zero.
#[derive(Debug, Clone, PartialEq)]
struct Spare {
    buf: DMatrix<f64>,
    rows: usize,
    cols: usize,
}

impl Spare {
    fn new(m: DMatrix<f64>) -> Self {
        let (rows, cols) = m.shape();
        Self { buf: m, rows, cols }
    }

    fn view(&self) -> DMatrixView<'_, f64> {
        self.buf.view((0, 0), (self.rows, self.cols))
    }

    fn view_mut(&mut self) -> DMatrixViewMut<'_, f64> {
        self.buf.view_mut((0, 0), (self.rows, self.cols))
    }

    /// Grows to `rows x cols` (never shrinks); the new entries are zero.
    fn grow(&mut self, rows: usize, cols: usize) {
        let (cap_r, cap_c) = self.buf.shape();
        if rows > cap_r || cols > cap_c {
            let new_r = if rows > cap_r {
                rows.max(cap_r + cap_r / 2)
            } else {
                cap_r
            };
            let new_c = if cols > cap_c {
                cols.max(cap_c + cap_c / 2)
            } else {
                cap_c
            };
            let mut buf = DMatrix::zeros(new_r, new_c);
            buf.view_mut((0, 0), (self.rows, self.cols))
                .copy_from(&self.view());
            self.buf = buf;
        }
        (self.rows, self.cols) = (self.rows.max(rows), self.cols.max(cols));
    }
}

/// A passive landmark, as the screening of an association needs it: where its mean
/// was at the last refresh ([`Compressed::refresh`]), how far it may have moved since
/// (`reach` times [`Compressed::drift_scale`]), and the trace of its own covariance
/// at the last global update.
#[derive(Debug, Clone, PartialEq)]
pub struct Passive {
    /// The landmark's id.
    pub id: u64,
    /// Its state offset in the full filter.
    offset: usize,
    /// Its first row of `P_BA0`.
    row: usize,
    /// Its mean at the last refresh (exact then).
    pub mean: [f64; 2],
    /// The trace of its own covariance at the last global update: an upper bound of
    /// the current one (updates only remove uncertainty).
    pub trace: f64,
    /// `|P_jA0|_F`: its mean has moved by at most `reach` times the drift scale since
    /// the last refresh (`|P_jA0 (theta - theta_ref)| <= |P_jA0|_F |theta - theta_ref|`).
    pub reach: f64,
}

/// The auxiliary state of a compressed filter (see the [module docs](self)): the full
/// filter at the last global update, and `phi`, `psi`, `theta` since.
#[derive(Debug, Clone, PartialEq)]
pub struct Compressed {
    /// The full filter at the last global update; its passive entries are current
    /// only after [`Compressed::decompress`].
    global: Ekf,
    /// State offsets in `global` of the basis `A0` (the columns of `phi`).
    basis: Vec<usize>,
    /// The passive landmarks.
    passive: Vec<Passive>,
    /// `P_A0B` (transposed, so that a landmark's entries are contiguous): a row per
    /// basis entry, two columns per landmark passive at the compression (those
    /// activated since are unused).
    ut: Spare,
    /// `d_A x a0`: `P_AB = phi P_A0B`.
    phi: Spare,
    /// `a0 x a0`, symmetric: `P_BB = P_BB0 - P_BA0 psi P_A0B`.
    psi: Spare,
    /// `a0`: `x_B = x_B0 + P_BA0 theta`.
    theta: DVector<f64>,
    /// `theta` at the last refresh of the passive means.
    theta_ref: DVector<f64>,
    /// Landmarks admitted to the sub-filter since the compression.
    admitted: usize,
}

impl Ekf {
    /// Splits the filter into the sub-filter of the robot and the landmarks `active`
    /// (ids; in state order whatever their order here), which the caller updates,
    /// and the [`Compressed`] state that [`Compressed::decompress`] merges back.
    /// Only a planar filter (robot 3, landmarks 2) without consider states (their
    /// zero gain rows break `phi`) can be compressed.
    pub fn compress(self, active: &[u64]) -> Result<(Ekf, Compressed)> {
        if !self.consider.is_empty() || self.robot_dim != 3 || self.landmark_dim != 2 {
            return Err(SlamError::invalid(
                "compression",
                "only a planar filter without consider states can be compressed".into(),
            ));
        }
        let mut js = active
            .iter()
            .map(|&id| {
                self.landmark_index(id).ok_or_else(|| {
                    SlamError::invalid("active", format!("landmark {id} is not in the state"))
                })
            })
            .collect::<Result<Vec<usize>>>()?;
        js.sort_unstable();
        js.dedup();
        let (r, m) = (self.robot_dim, self.landmark_dim);
        let basis: Vec<usize> = (0..r)
            .chain(js.iter().flat_map(|&j| r + j * m..r + (j + 1) * m))
            .collect();
        let local = self.sub_filter(&basis, &js);
        let mut active_mask = vec![false; self.num_landmarks()];
        js.iter().for_each(|&j| active_mask[j] = true);
        let passive_js: Vec<usize> = (0..self.num_landmarks())
            .filter(|&j| !active_mask[j])
            .collect();
        let ut = DMatrix::from_fn(basis.len(), m * passive_js.len(), |c, i| {
            self.cov_at(r + passive_js[i / m] * m + i % m, basis[c])
        });
        let passive = passive_js
            .iter()
            .enumerate()
            .map(|(k, &j)| {
                let off = r + j * m;
                Passive {
                    id: self.ids[j],
                    offset: off,
                    row: k * m,
                    mean: [self.x[off], self.x[off + 1]],
                    trace: (0..m).map(|i| self.cov_at(off + i, off + i)).sum(),
                    reach: ut.columns(k * m, m).norm(),
                }
            })
            .collect();
        let a0 = basis.len();
        let aux = Compressed {
            global: self,
            basis,
            passive,
            ut: Spare::new(ut),
            phi: Spare::new(DMatrix::identity(a0, a0)),
            psi: Spare::new(DMatrix::zeros(a0, a0)),
            theta: DVector::zeros(a0),
            theta_ref: DVector::zeros(a0),
            admitted: 0,
        };
        Ok((local, aux))
    }

    /// The marginal filter of the state entries `rows` (the robot's, then those of
    /// the landmarks `js`, in order).
    fn sub_filter(&self, rows: &[usize], js: &[usize]) -> Ekf {
        let a0 = rows.len();
        let mut cov = DMatrix::zeros(a0, a0);
        for c in 0..a0 {
            for i in c..a0 {
                cov[(i, c)] = self.cov_at(rows[i], rows[c]);
            }
        }
        let ids: Vec<u64> = js.iter().map(|&j| self.ids[j]).collect();
        Ekf {
            x: DVector::from_fn(a0, |i, _| self.x[rows[i]]),
            cov,
            robot_dim: self.robot_dim,
            landmark_dim: self.landmark_dim,
            angles: self.angles.clone(),
            index: ids.iter().enumerate().map(|(k, &id)| (id, k)).collect(),
            ids,
            next_id: self.next_id,
            consider: Vec::new(),
        }
    }
}

impl Compressed {
    /// The passive landmarks.
    pub fn passive(&self) -> &[Passive] {
        &self.passive
    }

    /// Whether landmark `id` is in the full filter (active, passive, or admitted to
    /// the sub-filter `local` since the compression).
    pub fn contains(&self, local: &Ekf, id: u64) -> bool {
        local.landmark_index(id).is_some() || self.global.landmark_index(id).is_some()
    }

    /// Number of landmarks of the full filter (passive plus those of `local`).
    pub fn num_landmarks(&self, local: &Ekf) -> usize {
        self.passive.len() + local.num_landmarks()
    }

    /// Size of the basis `A0` (the columns of `phi`).
    pub fn basis_len(&self) -> usize {
        self.basis.len()
    }

    /// `|theta - theta_ref|`: a passive landmark's mean is within its `reach` times
    /// this of its [`Passive::mean`].
    pub fn drift_scale(&self) -> f64 {
        (&self.theta - &self.theta_ref).norm()
    }

    /// Makes every [`Passive::mean`] current, `x_j0 + P_jA0 theta` (O(n_B a0)).
    pub fn refresh(&mut self) {
        let dx = self.ut.view().tr_mul(&self.theta);
        let m = self.global.landmark_dim;
        for p in &mut self.passive {
            for i in 0..m {
                p.mean[i] = self.global.x[p.offset + i] + dx[p.row + i];
            }
        }
        self.theta_ref.copy_from(&self.theta);
    }

    /// Passive landmark `k`'s current mean, `x_j0 + P_jA0 theta` (O(a0), no
    /// allocation).
    pub fn passive_mean(&self, k: usize) -> Point2<f64> {
        let p = &self.passive[k];
        let a0 = self.theta.len();
        let drift = |i: usize| self.ut.buf.view((0, p.row + i), (a0, 1)).dot(&self.theta);
        Point2::new(
            self.global.x[p.offset] + drift(0),
            self.global.x[p.offset + 1] + drift(1),
        )
    }

    /// Passive landmark `k`'s current cross-covariance with the robot, `(phi
    /// P_A0j)_r` (3x2), and its own covariance at the last global update (an upper
    /// bound of the current one, in the PSD order). O(a0), no allocation.
    pub fn passive_covariance(&self, k: usize) -> (Matrix3x2<f64>, Matrix2<f64>) {
        let p = &self.passive[k];
        let mut robot = Matrix3x2::zeros();
        for c in 0..self.basis.len() {
            let u = [self.ut.buf[(c, p.row)], self.ut.buf[(c, p.row + 1)]];
            for i in 0..3 {
                let phi = self.phi.buf[(i, c)];
                robot[(i, 0)] += phi * u[0];
                robot[(i, 1)] += phi * u[1];
            }
        }
        (robot, self.passive_own(k))
    }

    /// Passive landmark `k`'s own covariance at the last global update (an upper
    /// bound of the current one, in the PSD order). O(1).
    pub fn passive_own(&self, k: usize) -> Matrix2<f64> {
        let off = self.passive[k].offset;
        Matrix2::from_fn(|i, j| self.global.cov_at(off + i, off + j))
    }

    /// The own covariance at the last global update of the passive entries at
    /// state offset `off` (`m x m`).
    fn stale_own(&self, off: usize) -> DMatrix<f64> {
        let m = self.global.landmark_dim;
        DMatrix::from_fn(m, m, |i, j| self.global.cov_at(off + i, off + j))
    }

    /// Prediction of the sub-filter with the robot Jacobian `fx` (its eq. 12 for the
    /// robot rows of `phi`); call it with every prediction of the sub-filter.
    pub fn predict_planar(&mut self, fx: &Matrix3<f64>) {
        for mut col in self.phi.view_mut().column_iter_mut() {
            let moved = fx * nalgebra::Vector3::new(col[0], col[1], col[2]);
            col.fixed_rows_mut::<3>(0).copy_from(&moved);
        }
    }

    /// An update of the sub-filter, `observations` as given to
    /// [`Ekf::update_batch`] (or one of them to [`Ekf::update`]) and `update` what
    /// it returned: `psi`, `theta` and `phi` follow it.
    pub fn update(
        &mut self,
        observations: &[(DVector<f64>, SparseJacobian, DMatrix<f64>)],
        update: &Update,
    ) -> Result<()> {
        let a0 = self.basis.len();
        let rows = update.innovation.len();
        // H phi (m x a0), a column of phi at a time: each row of H has a few non-zero
        // entries (its blocks' rows), gathered once with their columns.
        let mut entries: Vec<(usize, usize, usize, [f64; 3])> = Vec::new();
        let mut first = 0;
        for (nu, h, _) in observations {
            for b in &h.blocks {
                for i in 0..b.h.nrows() {
                    let mut coeffs = [0.0; 3];
                    let n = b.h.ncols().min(3);
                    (0..n).for_each(|k| coeffs[k] = b.h[(i, k)]);
                    entries.push((first + b.row + i, b.col, n, coeffs));
                }
                if b.h.ncols() > 3 {
                    return Err(SlamError::dimension(
                        "a planar block has at most 3 columns".into(),
                    ));
                }
            }
            first += nu.len();
        }
        let mut h_phi = DMatrix::zeros(rows, a0);
        let cap = self.phi.buf.nrows();
        let phi = &self.phi.buf.as_slice()[..a0 * cap];
        for (col, mut out) in phi.chunks_exact(cap).zip(h_phi.column_iter_mut()) {
            for &(row, at, n, coeffs) in &entries {
                let x = &col[at..at + n];
                out[row] += x.iter().zip(&coeffs).map(|(x, c)| x * c).sum::<f64>();
            }
        }
        // With S = L L^T and Y = L^-1 H phi: psi += Y^T Y, theta += Y^T L^-1 nu. L^-1 is
        // small (m x m): Y is then one product, not a substitution (a division per
        // entry) through the a0 columns of H phi.
        let factor = cholesky_lower(&update.innovation_cov)?
            .ok_or_else(|| SlamError::SingularInnovation("compressed update: S".into()))?;
        let l_inv = lower_inverse(&factor);
        let y = &l_inv * &h_phi;
        let w = &l_inv * &update.innovation;
        let y_t = y.transpose();
        self.psi.view_mut().gemm(1.0, &y_t, &y, 1.0);
        self.theta.gemv(1.0, &y_t, &w, 1.0);
        self.phi.view_mut().gemm(-1.0, &update.gain, &h_phi, 1.0);
        Ok(())
    }

    /// A landmark initialised in the sub-filter from the robot with Jacobian
    /// `g_robot` (`m x r`), after [`Ekf::add_landmark_with_id`]: its row of `phi` is
    /// `G_r phi_r`. Room for it in the full filter is reserved now, so that the
    /// global update cannot fail.
    pub fn admitted(&mut self, g_robot: &DMatrix<f64>) -> Result<()> {
        self.admitted += 1;
        let need = self.global.dim() + self.admitted * self.global.landmark_dim;
        self.global.reserve(need)?;
        let (d, a0) = (self.phi.rows, self.phi.cols);
        let row = g_robot * self.phi.buf.view((0, 0), (g_robot.ncols(), a0));
        self.phi.grow(d + row.nrows(), a0);
        self.phi
            .buf
            .view_mut((d, 0), (row.nrows(), a0))
            .copy_from(&row);
        Ok(())
    }

    /// Moves passive landmark `k` into the sub-filter `local` with its current mean
    /// and covariance (see the [module docs](self)); returns its id.
    pub fn activate(&mut self, local: &mut Ekf, k: usize) -> Result<u64> {
        let p = self.passive.swap_remove(k);
        let m = self.global.landmark_dim;
        let (d, a0) = (self.phi.rows, self.phi.cols);
        // P_A0j (a0 x m, contiguous columns): the products below run down columns
        // of psi and phi (psi is symmetric: psi P_A0j = (P_jA0 psi)^T).
        let u = self.ut.buf.view((0, p.row), (a0, m));
        let mean = self.global.x.rows(p.offset, m) + u.tr_mul(&self.theta);
        let psi_u = self.psi.view() * u;
        let own = self.stale_own(p.offset) - u.tr_mul(&psi_u);
        let cross = (self.phi.view() * u).transpose(); // P_jA, m x d_A
        local.append_landmark(p.id, &mean, &cross, &own)?;
        // The basis grows by the landmark: phi = [[phi, 0], [-P_jA0 psi, I]].
        self.phi.grow(d + m, a0 + m);
        self.phi
            .buf
            .view_mut((d, 0), (m, a0))
            .tr_copy_from(&(-psi_u));
        self.phi.buf.view_mut((d, a0), (m, m)).fill_with_identity();
        self.psi.grow(a0 + m, a0 + m);
        self.ut.grow(a0 + m, self.ut.cols);
        for v in [&mut self.theta, &mut self.theta_ref] {
            *v = std::mem::take(v).resize_vertically(a0 + m, 0.0);
        }
        // P_Bj0, the new columns of P_BA0.
        for q in &mut self.passive {
            let mut added = 0.0;
            for (i, c) in (0..m).flat_map(|i| (0..m).map(move |c| (i, c))) {
                let v = self.global.cov_at(q.offset + i, p.offset + c);
                self.ut.buf[(a0 + c, q.row + i)] = v;
                added += v * v;
            }
            q.reach = (q.reach * q.reach + added).sqrt();
        }
        self.basis.extend(p.offset..p.offset + m);
        Ok(p.id)
    }

    /// The global update: the full filter, equal to the one every
    /// update would have given, with the landmarks admitted to `local` appended in
    /// its order. O(N_B^2 a0).
    pub fn decompress(self, local: Ekf) -> Ekf {
        let Compressed {
            mut global,
            passive,
            ut: all_ut,
            phi,
            psi,
            theta,
            ..
        } = self;
        let m = global.landmark_dim;
        let dg = global.dim();
        // U = P_BA0 in the full filter's rows (zero on the active ones), so that
        // P_BB -= U psi U^T is one blocked product over P's columns in place; its
        // active rows and columns get zero and are overwritten below.
        // Built as U^T (a column per state: contiguous copies), transposed once.
        let a0 = all_ut.rows;
        let mut ut = DMatrix::zeros(a0, dg);
        for p in &passive {
            for i in 0..m {
                ut.column_mut(p.offset + i)
                    .copy_from(&all_ut.buf.view((0, p.row + i), (a0, 1)));
            }
        }
        let u = ut.transpose();
        global.x += &u * &theta;
        let minus_psi = (psi.view() + psi.view().transpose()) * -0.5;
        let minus_w = &u * &minus_psi; // dg x a0
        let p_ba = &u * phi.view().transpose(); // P_BA = (phi P_A0B)^T, rows of B
        add_lower_product_now(&mut global.cov, dg, &minus_w, &ut);
        let rows_b: Vec<usize> = passive
            .iter()
            .flat_map(|p| p.offset..p.offset + m)
            .collect();
        // The sub-filter's entries, its new landmarks appended to the full filter.
        let rows_a = global.adopt(&local);
        for (i, &gi) in rows_a.iter().enumerate() {
            for &gc in &rows_b {
                global.set_cov(gi, gc, p_ba[(gc, i)]);
            }
        }
        for c in 0..rows_a.len() {
            for i in c..rows_a.len() {
                global.set_cov(rows_a[i], rows_a[c], local.cov[(i, c)]);
            }
            global.x[rows_a[c]] = local.x[c];
        }
        global.wrap_angles();
        global
    }
}

impl Ekf {
    /// A planar filter with no landmarks and a zero state (a placeholder while the
    /// working filter is swapped).
    pub(crate) fn empty_planar() -> Self {
        Ekf {
            x: DVector::zeros(3),
            cov: DMatrix::zeros(3, 3),
            robot_dim: 3,
            landmark_dim: 2,
            angles: Vec::new(),
            ids: Vec::new(),
            index: Default::default(),
            next_id: 0,
            consider: Vec::new(),
        }
    }

    /// Writes `P[i, j]` (and so `P[j, i]`) into the stored lower triangle.
    fn set_cov(&mut self, i: usize, j: usize, v: f64) {
        let (a, b) = if i >= j { (i, j) } else { (j, i) };
        self.cov[(a, b)] = v;
    }

    /// Appends landmark `id` with mean `mean`, cross-covariance `cross` with the
    /// current state (`m x d`) and own covariance `own` (`m x m`, symmetrised).
    fn append_landmark(
        &mut self,
        id: u64,
        mean: &DVector<f64>,
        cross: &DMatrix<f64>,
        own: &DMatrix<f64>,
    ) -> Result<()> {
        let (d, m) = (self.dim(), self.landmark_dim);
        self.reserve(d + m)?;
        self.cov.view_mut((d, 0), (m, d)).copy_from(cross);
        let own = (own + own.transpose()) * 0.5;
        self.cov.view_mut((d, d), (m, m)).copy_from(&own);
        let x = std::mem::replace(&mut self.x, DVector::zeros(0));
        self.x = x.resize_vertically(d + m, 0.0);
        self.x.rows_mut(d, m).copy_from(mean);
        self.index.insert(id, self.ids.len());
        self.ids.push(id);
        Ok(())
    }

    /// Makes room for the landmarks of `local` that this filter lacks (appended in
    /// `local`'s order, entries zero) and returns the state offset here of each of
    /// `local`'s entries.
    fn adopt(&mut self, local: &Ekf) -> Vec<usize> {
        let (r, m) = (self.robot_dim, self.landmark_dim);
        let new: Vec<u64> = local
            .ids
            .iter()
            .copied()
            .filter(|id| !self.index.contains_key(id))
            .collect();
        let (d, n) = (self.dim(), new.len());
        // Reserved by `Compressed::admitted`, checked against the allocation limit.
        if d + m * n > self.cov.nrows() {
            self.grow(d + m * n);
        }
        let x = std::mem::replace(&mut self.x, DVector::zeros(0));
        self.x = x.resize_vertically(d + m * n, 0.0);
        for id in new {
            self.index.insert(id, self.ids.len());
            self.ids.push(id);
        }
        self.next_id = self.next_id.max(local.next_id);
        let mut rows: Vec<usize> = (0..r).collect();
        for id in &local.ids {
            let off = r + self.index[id] * m;
            rows.extend(off..off + m);
        }
        rows
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix3x2, Vector3};
    use proptest::prelude::*;
    use rand::{Rng, SeedableRng, rngs::StdRng};

    /// A planar filter of `n` landmarks with a dense random covariance.
    fn filter(n: usize, rng: &mut StdRng) -> Ekf {
        let d = 3 + 2 * n;
        let x = DVector::from_fn(d, |_, _| rng.random_range(-20.0..20.0));
        let a = DMatrix::from_fn(d, d, |_, _| rng.random_range(-1.0..1.0));
        let p = &a * a.transpose() * 0.1 + DMatrix::identity(d, d) * 0.05;
        Ekf::new(x, p, 3, 2).unwrap().with_wrapped_angle(2).unwrap()
    }

    fn random(rows: usize, cols: usize, rng: &mut StdRng) -> DMatrix<f64> {
        DMatrix::from_fn(rows, cols, |_, _| rng.random_range(-1.0..1.0))
    }

    /// One step applied to both filters: the full one and the compressed pair.
    fn step(
        full: &mut Ekf,
        local: &mut Ekf,
        aux: &mut Compressed,
        rng: &mut StdRng,
        next_id: &mut u64,
    ) {
        match rng.random_range(0..4) {
            0 => predict_both(full, local, aux, rng),
            1 if local.num_landmarks() > 0 => update_both(full, local, aux, rng),
            2 => {
                admit_both(full, local, aux, rng, *next_id);
                *next_id += 1;
            }
            _ if !aux.passive().is_empty() => activate_checked(full, local, aux, rng),
            _ => {}
        }
    }

    fn predict_both(full: &mut Ekf, local: &mut Ekf, aux: &mut Compressed, rng: &mut StdRng) {
        let mean = Vector3::from_fn(|_, _| rng.random_range(-5.0..5.0));
        let fx = nalgebra::Matrix3::identity()
            + nalgebra::Matrix3::from_fn(|_, _| rng.random_range(-0.1..0.1));
        let fv = Matrix3x2::from_fn(|_, _| rng.random_range(-0.5..0.5));
        let v = Matrix2::new(0.02, 0.0, 0.0, 0.01);
        full.predict_planar(&mean, &fx, &fv, &v).unwrap();
        local.predict_planar(&mean, &fx, &fv, &v).unwrap();
        aux.predict_planar(&fx);
    }

    /// A batch of observations of active landmarks (and the robot).
    fn update_both(full: &mut Ekf, local: &mut Ekf, aux: &mut Compressed, rng: &mut StdRng) {
        let obs: Vec<_> = (0..rng.random_range(1..4))
            .map(|_| {
                let j = rng.random_range(0..local.num_landmarks());
                let id = local.landmark_id(j).unwrap();
                (id, random(2, 3, rng), random(2, 2, rng), random(2, 1, rng))
            })
            .collect();
        let stack = |ekf: &Ekf| -> Vec<_> {
            obs.iter()
                .map(|(id, hr, hl, nu)| {
                    let off = 3 + 2 * ekf.landmark_index(*id).unwrap();
                    let h = SparseJacobian::new(2)
                        .with_block(0, 0, hr.clone())
                        .with_block(0, off, hl.clone());
                    (nu.column(0).into_owned(), h, DMatrix::identity(2, 2) * 0.3)
                })
                .collect()
        };
        full.update_batch(&stack(full)).unwrap();
        let items = stack(local);
        let up = local.update_batch(&items).unwrap();
        aux.update(&items, &up).unwrap();
    }

    fn admit_both(
        full: &mut Ekf,
        local: &mut Ekf,
        aux: &mut Compressed,
        rng: &mut StdRng,
        id: u64,
    ) {
        let mean = DVector::from_fn(2, |_, _| rng.random_range(-20.0..20.0));
        let (g_r, g_z) = (random(2, 3, rng), random(2, 2, rng));
        let r = DMatrix::identity(2, 2) * 0.2;
        full.add_landmark_with_id(id, &mean, &g_r, &g_z, &r)
            .unwrap();
        local
            .add_landmark_with_id(id, &mean, &g_r, &g_z, &r)
            .unwrap();
        aux.admitted(&g_r).unwrap();
    }

    /// Activates a passive landmark after checking its readers against the full
    /// filter.
    fn activate_checked(full: &Ekf, local: &mut Ekf, aux: &mut Compressed, rng: &mut StdRng) {
        let k = rng.random_range(0..aux.passive().len());
        let j = full.landmark_index(aux.passive()[k].id).unwrap();
        let off = 3 + 2 * j;
        let mean = aux.passive_mean(k);
        assert!((mean.coords - full.state().rows(off, 2)).amax() < 1e-9);
        let (robot, own) = aux.passive_covariance(k);
        let want = full.covariance_block(0, off, 3, 2).unwrap();
        assert!((DMatrix::from_column_slice(3, 2, robot.as_slice()) - want).amax() < 1e-9);
        // The last global own covariance bounds the current one (PSD order).
        let now = full.covariance_block(off, off, 2, 2).unwrap();
        let gap = DMatrix::from_column_slice(2, 2, own.as_slice()) - now;
        assert!(gap.symmetric_eigenvalues().min() > -1e-9);
        aux.activate(local, k).unwrap();
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// Guivant & Nebot's exactness: any sequence of predictions, updates of
        /// active states, admissions and activations, then one global update, gives
        /// the full EKF's state and covariance (the full filter, updated at every
        /// step, is the oracle); the passive readers give its current values.
        #[test]
        fn the_global_update_restores_the_full_filter(
            seed in 0u64..10_000,
            n in 0usize..12,
            active in 0usize..12,
            steps in 1usize..40,
        ) {
            let mut rng = StdRng::seed_from_u64(seed);
            let mut full = filter(n, &mut rng);
            let ids: Vec<u64> = full.landmark_ids()[..active.min(n)].to_vec();
            let (mut local, mut aux) = full.clone().compress(&ids).unwrap();
            let mut next_id = 100;
            for _ in 0..steps {
                step(&mut full, &mut local, &mut aux, &mut rng, &mut next_id);
            }
            // Means and covariances are O(10): compare relative to that scale.
            let merged = aux.decompress(local);
            prop_assert_eq!(merged.landmark_ids(), full.landmark_ids());
            let scale = full.covariance().amax().max(1.0);
            prop_assert!((merged.covariance() - full.covariance()).amax() < 1e-9 * scale);
            prop_assert!((merged.state() - full.state()).amax() < 1e-9 * full.state().amax().max(1.0));
        }
    }

    #[test]
    fn only_a_planar_filter_without_consider_states_compresses() {
        let mut rng = StdRng::seed_from_u64(3);
        let mut ekf = filter(2, &mut rng);
        ekf.set_consider(0).unwrap();
        assert!(ekf.compress(&[]).is_err());
        let other = Ekf::new(DVector::zeros(4), DMatrix::identity(4, 4), 2, 2).unwrap();
        assert!(other.compress(&[]).is_err());
        let ekf = filter(2, &mut rng);
        assert!(ekf.compress(&[7]).is_err(), "an id not in the state");
    }
}
