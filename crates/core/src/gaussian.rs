//! Gaussians `N(mean, cov)`: Mahalanobis distance (NEES, NIS, gating) and the
//! symmetric positive (semi-)definite checks every filter applies to its covariances.

use nalgebra::{DMatrix, DVector};

use crate::error::{CoreError, Result, ensure_finite};

/// Relative tolerance of the symmetry and definiteness checks: round-off of the
/// caller's algebra passes, a wrong sign or a transposed block does not.
pub const COVARIANCE_RTOL: f64 = 1e-9;

/// What a covariance must be.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Definiteness {
    /// Positive definite: a state covariance whose inverse is used (P0, S).
    Positive,
    /// Positive semi-definite: a noise covariance that may be zero in some direction.
    SemiPositive,
}

impl Definiteness {
    fn describe(self) -> &'static str {
        match self {
            Definiteness::Positive => "symmetric positive definite",
            Definiteness::SemiPositive => "symmetric positive semi-definite",
        }
    }
}

/// Largest `|C - C^T|` entry relative to the largest `|C|` entry.
pub fn asymmetry(c: &DMatrix<f64>) -> f64 {
    // Divided first: the difference of two entries near f64::MAX overflows.
    let scale = c.amax().max(f64::MIN_POSITIVE);
    (c / scale - c.transpose() / scale).amax()
}

/// Smallest eigenvalue of the symmetric part of `C`, relative to the largest `|C|`.
pub fn min_relative_eigenvalue(c: &DMatrix<f64>) -> f64 {
    if c.is_empty() {
        return 0.0;
    }
    // Normalised before the sum, which would overflow near f64::MAX.
    let scale = c.amax().max(f64::MIN_POSITIVE);
    if c.shape() == (2, 2) {
        // Closed form (the noise blocks of a planar filter are 2x2, checked at every
        // step): the eigenvalues of [[a, b], [b, d]] are m -+ r. For m < 0, m - r does
        // not cancel; for m >= 0 the smaller is det / (m + r), which does not either.
        let (a, d) = (c[(0, 0)] / scale, c[(1, 1)] / scale);
        let b = (c[(0, 1)] / scale + c[(1, 0)] / scale) * 0.5;
        let (m, r) = ((a + d) * 0.5, ((a - d) * 0.5).hypot(b));
        return if m < 0.0 {
            m - r
        } else if m + r > 0.0 {
            (a * d - b * b) / (m + r)
        } else {
            0.0
        };
    }
    let sym = (c / scale + c.transpose() / scale) * 0.5;
    sym.symmetric_eigenvalues().min()
}

/// Checks that `c` (named `name` in the error) is square, finite, symmetric and
/// positive (semi-)definite within [`COVARIANCE_RTOL`]. An empty matrix passes.
///
/// # Examples
/// ```
/// use nalgebra::DMatrix;
/// use rperc_core::{Definiteness, check_covariance};
///
/// let p = DMatrix::from_row_slice(2, 2, &[0.01, 0.0, 0.0, -0.01]);
/// let err = check_covariance("P0", &p, Definiteness::Positive).unwrap_err();
/// assert!(err.to_string().contains("P0"));
/// assert!(check_covariance("V", &DMatrix::zeros(2, 2), Definiteness::SemiPositive).is_ok());
/// ```
pub fn check_covariance(name: &'static str, c: &DMatrix<f64>, kind: Definiteness) -> Result<()> {
    let fail = |reason: String| CoreError::NotPositiveDefinite {
        name,
        requirement: kind.describe(),
        reason,
    };
    if !c.is_square() {
        return Err(CoreError::Dimension(format!(
            "covariance '{name}' must be square, got {}x{}",
            c.nrows(),
            c.ncols()
        )));
    }
    ensure_finite(name, c.iter())?;
    if c.is_empty() {
        return Ok(());
    }
    let asym = asymmetry(c);
    if asym > COVARIANCE_RTOL {
        return Err(fail(format!("relative asymmetry {asym:.2e}")));
    }
    if let Some(reason) = entrywise_violation(c) {
        return Err(fail(reason));
    }
    let min = min_relative_eigenvalue(c);
    let ok = match kind {
        // Strictly positive, and a Cholesky factor must exist (the inverse is used).
        Definiteness::Positive => min > 0.0 && c.clone().cholesky().is_some(),
        Definiteness::SemiPositive => min >= -COVARIANCE_RTOL,
    };
    if ok {
        Ok(())
    } else {
        Err(fail(format!(
            "smallest eigenvalue {:.3e} (relative {min:.2e})",
            min * c.amax()
        )))
    }
}

/// What a PSD matrix satisfies entry by entry, with a tolerance relative to each row's
/// own scale (the eigenvalue test above is relative to the largest entry, so a
/// variance of -0.01 next to one of 1e20 passes it): every variance is >= 0, and every
/// covariance obeys Cauchy-Schwarz, `|c_ij| <= sqrt(c_ii c_jj)`.
fn entrywise_violation(c: &DMatrix<f64>) -> Option<String> {
    let n = c.nrows();
    let row_scale: Vec<f64> = (0..n).map(|i| c.row(i).amax()).collect();
    for i in 0..n {
        if c[(i, i)] < -COVARIANCE_RTOL * row_scale[i] {
            return Some(format!("variance {i} is negative ({:e})", c[(i, i)]));
        }
    }
    for i in 0..n {
        for j in i + 1..n {
            // The geometric mean as a product of roots: the product of the variances
            // underflows to 0 below 1e-154 and overflows to inf above 1e154.
            let bound = c[(i, i)].max(0.0).sqrt() * c[(j, j)].max(0.0).sqrt()
                + COVARIANCE_RTOL * row_scale[i].max(row_scale[j]);
            let cij = c[(i, j)].abs().max(c[(j, i)].abs());
            if cij > bound * (1.0 + COVARIANCE_RTOL) {
                return Some(format!(
                    "entry ({i}, {j}) = {cij:e} exceeds sqrt(variance {i} * variance {j})"
                ));
            }
        }
    }
    None
}

/// The nearest usable covariance: the symmetric part of `c` with its eigenvalues
/// raised to at least `floor` (absolute). For a covariance that drifted indefinite
/// through round-off; a NaN or a non-square matrix is still an error.
pub fn repair_covariance(name: &'static str, c: &DMatrix<f64>, floor: f64) -> Result<DMatrix<f64>> {
    if !c.is_square() {
        return Err(CoreError::Dimension(format!(
            "covariance '{name}' must be square"
        )));
    }
    ensure_finite(name, c.iter())?;
    crate::error::ensure_non_negative("floor", floor)?;
    let eig = ((c + c.transpose()) * 0.5).symmetric_eigen();
    let clipped = eig.eigenvalues.map(|v| v.max(floor));
    let q = &eig.eigenvectors;
    let fixed = q * DMatrix::from_diagonal(&clipped) * q.transpose();
    Ok((&fixed + fixed.transpose()) * 0.5)
}

/// Columns of a Cholesky factorisation between two Ctrl-C checkpoints (about 0.1 s at
/// n = 3000).
const FACTOR_COLUMNS: usize = 32;

/// The lower Cholesky factor `F` of `s = F F^T` (nalgebra's left-looking algorithm,
/// column by column), `None` when `s` is not positive definite. It polls
/// [`crate::interrupt::checkpoint`] every few columns: a state of thousands runs for
/// seconds, and nalgebra's own factorisation cannot be stopped.
///
/// # Errors
/// [`CoreError::Interrupted`] when the caller's work was stopped.
pub fn cholesky_lower(s: &DMatrix<f64>) -> Result<Option<DMatrix<f64>>> {
    let n = s.nrows();
    let mut f = s.clone();
    for j in 0..n {
        for k in 0..j {
            let factor = -f[(j, k)];
            let (mut col_j, col_k) = f.columns_range_pair_mut(j, k);
            col_j
                .rows_range_mut(j..)
                .axpy(factor, &col_k.rows_range(j..), 1.0);
        }
        let diag = f[(j, j)];
        if !(diag > 0.0 && diag.is_finite()) {
            return Ok(None);
        }
        let root = diag.sqrt();
        f[(j, j)] = root;
        f.view_range_mut(j + 1.., j).unscale_mut(root);
        if j % FACTOR_COLUMNS == FACTOR_COLUMNS - 1 {
            crate::interrupt::checkpoint()?;
        }
    }
    f.fill_upper_triangle(0.0, 1);
    Ok(Some(f))
}

/// `b <- S^-1 b` from the lower factor `S = F F^T` of [`cholesky_lower`]: two
/// triangular solves (infallible for its positive diagonal).
pub fn cholesky_solve_mut(factor: &DMatrix<f64>, b: &mut DMatrix<f64>) {
    factor.solve_lower_triangular_mut(b);
    factor.tr_solve_lower_triangular_mut(b);
}

/// `S^-1 = F^-T F^-1` from the lower factor `S = F F^T` of [`cholesky_lower`]
/// (infallible for its positive diagonal): `F^-1` ([`lower_inverse`], `n^3 / 6`),
/// then one matrix product. Two solves against the identity
/// ([`cholesky_solve_mut`]) cost `n^3` scalar operations, the bulk of an EKF
/// update's gain for a scan of a few detections.
pub fn cholesky_inverse(factor: &DMatrix<f64>) -> DMatrix<f64> {
    let w = lower_inverse(factor);
    w.transpose() * w
}

/// `F^-1` of a lower-triangular `F` with a non-zero diagonal (lower triangular too):
/// forward substitution of each column of the identity from its diagonal on, by
/// columns of `F` (`n^3 / 6`).
pub fn lower_inverse(factor: &DMatrix<f64>) -> DMatrix<f64> {
    let n = factor.nrows();
    let f = factor.as_slice();
    let mut w = DMatrix::<f64>::zeros(n, n);
    for (j, col) in w.as_mut_slice().chunks_exact_mut(n.max(1)).enumerate() {
        col[j] = 1.0;
        // F y = e_j: y_i = b_i / F_ii, then b -= y_i F[i+1.., i].
        for i in j..n {
            let fi = &f[i * n..(i + 1) * n];
            let coeff = col[i] / fi[i];
            col[i] = coeff;
            for (y, l) in col[i + 1..].iter_mut().zip(&fi[i + 1..]) {
                *y -= coeff * l;
            }
        }
    }
    w
}

/// `Err(Dimension)` unless the covariance `cov` is `n x n` for a vector of `n` entries;
/// `names` are the vector's and the covariance's in the message.
fn check_sizes(names: [&str; 2], n: usize, cov: &DMatrix<f64>) -> Result<()> {
    if cov.shape() == (n, n) {
        return Ok(());
    }
    let [vector, covariance] = names;
    Err(CoreError::Dimension(format!(
        "{vector} has {n} entries but {covariance} is {}x{}",
        cov.nrows(),
        cov.ncols()
    )))
}

/// `e^T C^-1 e` through a Cholesky factorisation; an error when `C` is not positive
/// definite. With the estimation error this is the NEES; with the innovation, the NIS.
pub fn mahalanobis2(e: &DVector<f64>, cov: &DMatrix<f64>) -> Result<f64> {
    check_sizes(["vector", "the covariance"], e.len(), cov)?;
    let factor = cholesky_lower(cov)?.ok_or_else(|| CoreError::NotPositiveDefinite {
        name: "covariance",
        requirement: Definiteness::Positive.describe(),
        reason: "no Cholesky factor".into(),
    })?;
    let mut whitened = DMatrix::from_column_slice(e.len(), 1, e.as_slice());
    factor.solve_lower_triangular_mut(&mut whitened);
    Ok(whitened.norm_squared())
}

/// A multivariate Gaussian `N(mean, cov)` with a checked covariance.
///
/// # Examples
/// ```
/// use nalgebra::{DMatrix, DVector};
/// use rperc_core::Gaussian;
///
/// let g = Gaussian::new(DVector::from_vec(vec![1.0, 2.0]),
///                       DMatrix::from_diagonal(&DVector::from_vec(vec![4.0, 1.0]))).unwrap();
/// // (3 - 1)^2 / 4 + (2 - 2)^2 / 1 = 1
/// assert!((g.mahalanobis2(&DVector::from_vec(vec![3.0, 2.0])).unwrap() - 1.0).abs() < 1e-12);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Gaussian {
    /// Mean vector.
    pub mean: DVector<f64>,
    /// Covariance matrix (symmetric positive definite).
    pub cov: DMatrix<f64>,
}

impl Gaussian {
    /// A Gaussian after checking sizes, finiteness and positive definiteness.
    pub fn new(mean: DVector<f64>, cov: DMatrix<f64>) -> Result<Self> {
        check_sizes(["mean", "cov"], mean.len(), &cov)?;
        ensure_finite("mean", mean.iter())?;
        check_covariance("cov", &cov, Definiteness::Positive)?;
        Ok(Self { mean, cov })
    }

    /// Squared Mahalanobis distance of `x` from the mean (the NEES of a true state).
    pub fn mahalanobis2(&self, x: &DVector<f64>) -> Result<f64> {
        mahalanobis2(&(x - &self.mean), &self.cov)
    }
}

/// Square roots of the eigenvalues of the 2 x 2 covariance `[[xx, xy], [xy, yy]]`,
/// largest first, each >= 0: the spreads along the principal axes (in closed form;
/// a slightly negative eigenvalue from rounding gives 0).
///
/// ```
/// let [major, minor] = rperc_core::gaussian::covariance_spreads(4.0, 1.0, 0.0);
/// assert_eq!([major, minor], [2.0, 1.0]);
/// ```
pub fn covariance_spreads(xx: f64, yy: f64, xy: f64) -> [f64; 2] {
    let (mean, half) = ((xx + yy) / 2.0, ((xx - yy) / 2.0).hypot(xy));
    [(mean + half).max(0.0).sqrt(), (mean - half).max(0.0).sqrt()]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The 2x2 closed form against the symmetric eigen-decomposition, on matrices
    /// from positive definite through singular to indefinite, at any scale.
    #[test]
    fn the_2x2_smallest_eigenvalue_matches_the_decomposition() {
        use rand::{Rng, SeedableRng, rngs::StdRng};
        let mut rng = StdRng::seed_from_u64(7);
        for k in 0..20_000 {
            let scale = 10f64.powi(rng.random_range(-150..150));
            let (a, d): (f64, f64) = (rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
            // Every fourth exactly singular: b^2 = a d.
            let b = if k % 4 == 0 && a * d >= 0.0 {
                (a * d).sqrt()
            } else {
                rng.random_range(-1.0..1.0)
            };
            let c = DMatrix::from_row_slice(2, 2, &[a, b, b, d]) * scale;
            let s = c.amax().max(f64::MIN_POSITIVE);
            let want = (&c / s).symmetric_eigenvalues().min();
            let got = min_relative_eigenvalue(&c);
            assert!(
                (got - want).abs() < 1e-12,
                "{a} {b} {d} {scale:e}: {got} vs {want}"
            );
        }
    }

    #[test]
    fn checks_catch_sign_and_symmetry_errors() {
        let pd = DMatrix::from_row_slice(2, 2, &[2.0, 0.5, 0.5, 1.0]);
        assert!(check_covariance("P", &pd, Definiteness::Positive).is_ok());
        let asym = DMatrix::from_row_slice(2, 2, &[2.0, 0.5, 0.4, 1.0]);
        assert!(check_covariance("P", &asym, Definiteness::SemiPositive).is_err());
        let singular = DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 1.0, 1.0]);
        assert!(check_covariance("V", &singular, Definiteness::SemiPositive).is_ok());
        assert!(check_covariance("P", &singular, Definiteness::Positive).is_err());
        let nan = DMatrix::from_row_slice(1, 1, &[f64::NAN]);
        assert_eq!(
            check_covariance("R", &nan, Definiteness::SemiPositive),
            Err(CoreError::NonFinite("R"))
        );
    }

    /// Found by the fuzz suite: the eigenvalue test is relative to the largest entry,
    /// so a small negative variance or an impossible covariance hid next to a huge one.
    #[test]
    fn entries_are_checked_at_their_own_scale() {
        let neg = DMatrix::from_diagonal(&DVector::from_vec(vec![-0.01, 0.0, 1e20]));
        let err = check_covariance("P0", &neg, Definiteness::SemiPositive).unwrap_err();
        assert!(err.to_string().contains("variance 0 is negative"), "{err}");
        let cs = DMatrix::from_row_slice(3, 3, &[0., 1., 0., 1., 0., 0., 0., 0., 1e20]);
        let err = check_covariance("P0", &cs, Definiteness::SemiPositive).unwrap_err();
        assert!(err.to_string().contains("entry (0, 1)"), "{err}");
        // A PSD matrix of wildly different scales, with round-off, still passes.
        let j = DMatrix::from_row_slice(3, 2, &[1e10, 1.0, 3.0, -2.0, 1e-8, 5.0]);
        let p = &j * DMatrix::from_row_slice(2, 2, &[2.0, 0.3, 0.3, 1.0]) * j.transpose();
        let p = (&p + p.transpose()) * 0.5;
        assert!(check_covariance("P", &p, Definiteness::SemiPositive).is_ok());
    }

    /// Oracle: nalgebra's own factorisation, and the solve against the inverse.
    #[test]
    fn interruptible_cholesky_matches_nalgebra() {
        let a = DMatrix::from_fn(70, 70, |i, j| ((i * 31 + j * 17) % 13) as f64 - 6.0);
        let s = &a * a.transpose() + DMatrix::identity(70, 70);
        let f = cholesky_lower(&s).unwrap().unwrap();
        let reference = s.clone().cholesky().unwrap().unpack();
        assert!((&f - &reference).amax() < 1e-12 * reference.amax());
        let mut b = DMatrix::from_fn(70, 3, |i, j| (i + j) as f64);
        let expected = s.clone().try_inverse().unwrap() * &b;
        cholesky_solve_mut(&f, &mut b);
        assert!((&b - &expected).amax() < 1e-9 * expected.amax());
        let indefinite = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 1.0]);
        assert_eq!(cholesky_lower(&indefinite).unwrap(), None);
        let nan = DMatrix::from_row_slice(1, 1, &[f64::NAN]);
        assert_eq!(cholesky_lower(&nan).unwrap(), None);
    }

    /// Oracle: nalgebra's inverse of `S`, for sizes from none to a few dozen.
    #[test]
    fn cholesky_inverse_is_the_inverse() {
        for n in [0, 1, 2, 5, 14, 37] {
            let a = DMatrix::from_fn(n, n, |i, j| ((i * 7 + j * 3) % 11) as f64 / 3.0 - 1.5);
            let s = &a * a.transpose() + DMatrix::identity(n, n) * 0.7;
            let f = cholesky_lower(&s).unwrap().unwrap();
            let got = cholesky_inverse(&f);
            let expected = s.clone().try_inverse().unwrap();
            assert_eq!(got.shape(), (n, n));
            assert!(
                (&got - &expected).amax() <= 1e-12 * expected.amax().max(1.0),
                "n = {n}"
            );
        }
    }

    #[test]
    fn repair_clips_negative_eigenvalues_only() {
        // Eigenvalues 3 and -1 (eigenvectors (1, 1) and (1, -1) / sqrt 2).
        let c = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 1.0]);
        let fixed = repair_covariance("P", &c, 1e-3).unwrap();
        let mut eig: Vec<f64> = fixed.symmetric_eigenvalues().iter().copied().collect();
        eig.sort_by(f64::total_cmp);
        assert!((eig[0] - 1e-3).abs() < 1e-12 && (eig[1] - 3.0).abs() < 1e-12);
        // An SPD matrix comes back unchanged.
        let pd = DMatrix::from_row_slice(2, 2, &[2.0, 0.5, 0.5, 1.0]);
        assert!((repair_covariance("P", &pd, 0.0).unwrap() - &pd).amax() < 1e-12);
    }

    #[test]
    fn covariance_spreads_match_the_symmetric_eigen_solver() {
        let mut state = 7u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 * 4.0 - 2.0
        };
        for _ in 0..200 {
            let (a, b) = (next(), next());
            let (xx, yy, xy) = (a * a + b * b, next().powi(2), a * next());
            let eig = DMatrix::from_row_slice(2, 2, &[xx, xy, xy, yy]).symmetric_eigenvalues();
            let (hi, lo) = (eig.max().max(0.0).sqrt(), eig.min().max(0.0).sqrt());
            let [major, minor] = covariance_spreads(xx, yy, xy);
            assert!((major - hi).abs() < 1e-9 && (minor - lo).abs() < 1e-9);
        }
    }
}
