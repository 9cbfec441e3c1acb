//! Normal equations with the structure of a smoothed run: the poses form a chain
//! (block tridiagonal, 3x3 blocks: odometry links each pose to the next only) and
//! every pose may also touch a dense "global" block (the walls and the biases).
//! Eliminating the chain first (an O(n) block LDL^T, as the RTS smoother does) and
//! solving the global block's Schur complement densely costs O(S g^2 + g^3) for `S`
//! poses and `g` global unknowns, with no fill between poses that see the same wall.

use nalgebra::{DMatrix, DVector, Matrix3};

use crate::error::{Result, SlamError};

/// `H = [[A, B], [B^T, C]]`, `A` block tridiagonal (`diag[k]`, `upper[k]` between
/// pose `k` and `k + 1`), `B` stored as one `3 x g` row block per pose.
#[derive(Debug, Clone)]
pub(crate) struct Arrow {
    pub diag: Vec<Matrix3<f64>>,
    pub upper: Vec<Matrix3<f64>>,
    pub border: Vec<DMatrix<f64>>,
    pub global: DMatrix<f64>,
}

/// The chain's pivots, `Y = A^-1 B` and the Schur complement's Cholesky factor.
type Factored = (
    Chain,
    Vec<DMatrix<f64>>,
    Option<nalgebra::Cholesky<f64, nalgebra::Dyn>>,
);

/// The chain eliminated: `d[k]^-1` of the pivots `d[k] = D_k - E_{k-1}^T d[k-1]^-1 E_{k-1}`.
struct Chain {
    pivot_inv: Vec<Matrix3<f64>>,
}

fn not_positive(what: &str) -> SlamError {
    SlamError::SingularInnovation(format!(
        "the smoother's normal equations are not positive definite ({what}): some \
         pose, wall or bias is not constrained"
    ))
}

impl Arrow {
    /// Zeros for `poses` poses and `g` global unknowns.
    pub fn zeros(poses: usize, g: usize) -> Self {
        Self {
            diag: vec![Matrix3::zeros(); poses],
            upper: vec![Matrix3::zeros(); poses.saturating_sub(1)],
            border: vec![DMatrix::zeros(3, g); poses],
            global: DMatrix::zeros(g, g),
        }
    }

    fn global_dim(&self) -> usize {
        self.global.nrows()
    }

    fn eliminate(&self) -> Result<Chain> {
        let mut pivot_inv: Vec<Matrix3<f64>> = Vec::with_capacity(self.diag.len());
        for (k, d) in self.diag.iter().enumerate() {
            let mut p = *d;
            if k > 0 {
                let e = &self.upper[k - 1];
                p -= e.transpose() * pivot_inv[k - 1] * e;
            }
            let p = 0.5 * (p + p.transpose());
            let inv = p
                .cholesky()
                .ok_or_else(|| not_positive("a pose"))?
                .inverse();
            pivot_inv.push(inv);
        }
        Ok(Chain { pivot_inv })
    }

    /// `A^-1 R` for a right-hand side given as one `3 x c` row block per pose.
    fn chain_solve(&self, chain: &Chain, rhs: &[DMatrix<f64>]) -> Vec<DMatrix<f64>> {
        let n = rhs.len();
        let mut fwd: Vec<DMatrix<f64>> = Vec::with_capacity(n);
        for k in 0..n {
            let mut r = rhs[k].clone();
            if k > 0 {
                let e_t = self.upper[k - 1].transpose() * chain.pivot_inv[k - 1];
                let back = e_t * &fwd[k - 1];
                r -= DMatrix::from_column_slice(3, back.ncols(), back.as_slice());
            }
            fwd.push(r);
        }
        let mut out: Vec<DMatrix<f64>> = vec![DMatrix::zeros(0, 0); n];
        for k in (0..n).rev() {
            let mut r = fwd[k].clone();
            if k + 1 < n {
                let next = self.upper[k] * &out[k + 1];
                r -= DMatrix::from_column_slice(3, next.ncols(), next.as_slice());
            }
            let solved = chain.pivot_inv[k] * r;
            out[k] = DMatrix::from_column_slice(3, solved.ncols(), solved.as_slice());
        }
        out
    }

    /// Solves `H x = b` (`b` poses first, then the global unknowns); with the
    /// Schur complement's Cholesky factor kept for [`Arrow::covariances`].
    pub fn solve(&self, b: &DVector<f64>) -> Result<DVector<f64>> {
        let (chain, y, schur) = self.factor()?;
        let s = self.diag.len();
        let g = self.global_dim();
        let rhs_p: Vec<DMatrix<f64>> = (0..s)
            .map(|k| DMatrix::from_column_slice(3, 1, &b.as_slice()[3 * k..3 * k + 3]))
            .collect();
        let x_p = self.chain_solve(&chain, &rhs_p);
        let mut rhs_g = DVector::from_column_slice(&b.as_slice()[3 * s..3 * s + g]);
        for (bk, xk) in self.border.iter().zip(&x_p) {
            rhs_g -= bk.transpose() * xk.column(0);
        }
        let x_g = match &schur {
            Some(c) => c.solve(&rhs_g),
            None => DVector::zeros(0),
        };
        let mut out = DVector::zeros(3 * s + g);
        for k in 0..s {
            let xk = x_p[k].column(0) - &y[k] * &x_g;
            out.rows_mut(3 * k, 3).copy_from(&xk);
        }
        out.rows_mut(3 * s, g).copy_from(&x_g);
        Ok(out)
    }

    /// The chain's pivots, `Y = A^-1 B` and the Cholesky factor of the Schur
    /// complement `C - B^T Y` (`None` without global unknowns).
    fn factor(&self) -> Result<Factored> {
        let chain = self.eliminate()?;
        let y = self.chain_solve(&chain, &self.border);
        if self.global_dim() == 0 {
            return Ok((chain, y, None));
        }
        let mut schur = self.global.clone();
        for (bk, yk) in self.border.iter().zip(&y) {
            // B_k is sparse (a pose sees a few walls): only its nonzero columns.
            for (c, col) in bk.column_iter().enumerate() {
                if col.iter().any(|v| *v != 0.0) {
                    let row = col.transpose() * yk;
                    let mut target = schur.row_mut(c);
                    target -= row;
                }
            }
        }
        let schur = 0.5 * (&schur + schur.transpose());
        let c = schur.cholesky().ok_or_else(|| not_positive("the walls"))?;
        Ok((chain, y, Some(c)))
    }

    /// The marginal covariances of `H^-1`: each pose's 3x3 block, and the global
    /// block (`g x g`).
    pub fn covariances(&self) -> Result<(Vec<Matrix3<f64>>, DMatrix<f64>)> {
        let (chain, y, schur) = self.factor()?;
        let s = self.diag.len();
        // (A^-1)_kk backwards, as in the RTS smoother: the chain's own part.
        let mut poses = vec![Matrix3::zeros(); s];
        for k in (0..s).rev() {
            let d = chain.pivot_inv[k];
            poses[k] = if k + 1 < s {
                let g = d * self.upper[k];
                d + g * poses[k + 1] * g.transpose()
            } else {
                d
            };
        }
        let Some(c) = schur else {
            return Ok((poses, DMatrix::zeros(0, 0)));
        };
        let global = c.inverse();
        // The walls' uncertainty reaches every pose through Y = A^-1 B: the diagonal
        // blocks of Y S^-1 Y^T, with Y stacked for one large product.
        let g = self.global_dim();
        let mut stacked = DMatrix::zeros(3 * s, g);
        for (k, yk) in y.iter().enumerate() {
            stacked.rows_mut(3 * k, 3).copy_from(yk);
        }
        let spread = &stacked * &global;
        for (k, p) in poses.iter_mut().enumerate() {
            let add = spread.rows(3 * k, 3) * stacked.rows(3 * k, 3).transpose();
            *p += Matrix3::from_iterator(add.iter().copied());
        }
        Ok((poses, global))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A random SPD matrix with the arrow's pattern, and the arrow.
    fn random(s: usize, g: usize, seed: u64) -> (DMatrix<f64>, Arrow) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let n = 3 * s + g;
        // J^T J of a random J with the pattern: rows linking k, k+1 and the globals.
        let mut j = DMatrix::<f64>::zeros(4 * s, n);
        for k in 0..s {
            for r in 4 * k..4 * k + 4 {
                for c in 3 * k..(3 * k + 6).min(3 * s) {
                    j[(r, c)] = rng.random_range(-1.0..1.0);
                }
                for c in 3 * s..n {
                    if rng.random_bool(0.3) {
                        j[(r, c)] = rng.random_range(-1.0..1.0);
                    }
                }
            }
        }
        let h = j.transpose() * &j + DMatrix::identity(n, n) * 0.1;
        let mut a = Arrow::zeros(s, g);
        for k in 0..s {
            a.diag[k] = h.fixed_view::<3, 3>(3 * k, 3 * k).into();
            if k + 1 < s {
                a.upper[k] = h.fixed_view::<3, 3>(3 * k, 3 * k + 3).into();
            }
            a.border[k] = h.view((3 * k, 3 * s), (3, g)).into();
        }
        a.global = h.view((3 * s, 3 * s), (g, g)).into();
        (h, a)
    }

    #[test]
    fn solve_and_marginals_match_the_dense_inverse() {
        for (s, g, seed) in [(1, 0, 1), (5, 0, 2), (7, 4, 3), (20, 9, 4), (2, 6, 5)] {
            let (h, a) = random(s, g, seed);
            let b = DVector::from_fn(3 * s + g, |i, _| (i as f64 * 0.7).sin());
            let x = a.solve(&b).unwrap();
            let dense = h.clone().cholesky().unwrap();
            let want = dense.solve(&b);
            assert!((&x - &want).amax() < 1e-9 * want.amax().max(1.0), "{s} {g}");
            let inv = dense.inverse();
            let (poses, global) = a.covariances().unwrap();
            for (k, p) in poses.iter().enumerate() {
                let w: Matrix3<f64> = inv.fixed_view::<3, 3>(3 * k, 3 * k).into();
                assert!((p - w).amax() < 1e-9 * w.amax(), "pose {k} of {s}, g {g}");
            }
            let wg = inv.view((3 * s, 3 * s), (g, g));
            assert!((&global - wg).amax() <= 1e-9 * wg.amax().max(1e-300));
        }
    }

    #[test]
    fn an_unconstrained_pose_is_an_error_not_a_nan() {
        let (_, mut a) = random(4, 2, 7);
        a.diag[2] = Matrix3::zeros();
        a.upper[1] = Matrix3::zeros();
        a.upper[2] = Matrix3::zeros();
        a.border[2].fill(0.0);
        let err = a.solve(&DVector::zeros(14)).unwrap_err();
        assert!(err.to_string().contains("not constrained"), "{err}");
    }
}
