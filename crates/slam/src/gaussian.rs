//! Gaussian helpers shared by the filters: Mahalanobis distance, NEES and the
//! symmetric positive semi-definite checks.

use nalgebra::{DMatrix, DVector};

use crate::error::{Result, SlamError};

/// A multivariate Gaussian `N(mean, cov)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Gaussian {
    /// Mean vector.
    pub mean: DVector<f64>,
    /// Covariance matrix.
    pub cov: DMatrix<f64>,
}

impl Gaussian {
    /// A Gaussian after checking that sizes agree and every value is finite.
    pub fn new(mean: DVector<f64>, cov: DMatrix<f64>) -> Result<Self> {
        if cov.nrows() != mean.len() || cov.ncols() != mean.len() {
            return Err(SlamError::Dimension(format!(
                "mean has {} entries but cov is {}x{}",
                mean.len(),
                cov.nrows(),
                cov.ncols()
            )));
        }
        crate::error::ensure_finite("mean", mean.iter())?;
        crate::error::ensure_finite("cov", cov.iter())?;
        Ok(Self { mean, cov })
    }

    /// Squared Mahalanobis distance of `x` from the mean. For the true state this is
    /// the normalised estimation error squared (NEES).
    pub fn mahalanobis2(&self, x: &DVector<f64>) -> Result<f64> {
        mahalanobis2(&(x - &self.mean), &self.cov)
    }
}

/// `e^T C^-1 e` through a Cholesky factorisation; an error when `C` is not positive
/// definite.
pub fn mahalanobis2(e: &DVector<f64>, cov: &DMatrix<f64>) -> Result<f64> {
    let chol = cov.clone().cholesky().ok_or_else(|| {
        SlamError::SingularInnovation("covariance is not positive definite".into())
    })?;
    Ok(e.dot(&chol.solve(e)))
}

/// Largest `|C - C^T|` entry relative to the largest `|C|` entry.
pub fn asymmetry(c: &DMatrix<f64>) -> f64 {
    let scale = c.amax().max(f64::MIN_POSITIVE);
    (c - c.transpose()).amax() / scale
}

/// Smallest eigenvalue of the symmetric part of `C`, relative to the largest `|C|`.
pub fn min_relative_eigenvalue(c: &DMatrix<f64>) -> f64 {
    let sym = (c + c.transpose()) * 0.5;
    let scale = c.amax().max(f64::MIN_POSITIVE);
    sym.symmetric_eigenvalues().min() / scale
}

/// Refuses a noise covariance (`V`, `R`) that is not symmetric positive
/// semi-definite: a negative variance would make `P` indefinite without any error
/// further down. Zero noise is allowed.
pub(crate) fn ensure_noise_covariance(name: &'static str, c: &DMatrix<f64>) -> Result<()> {
    crate::error::ensure_finite(name, c.iter())?;
    if c.is_empty() {
        return Ok(());
    }
    let scale = c.amax();
    // Relative tolerances: symmetric and PSD up to round-off of the caller's algebra.
    if asymmetry(c) > 1e-9 {
        return Err(SlamError::InvalidParameter {
            name,
            reason: format!("noise covariance must be symmetric, got {c:.3e}"),
        });
    }
    let min = ((c + c.transpose()) * 0.5).symmetric_eigenvalues().min();
    if min < -1e-12 * scale {
        return Err(SlamError::InvalidParameter {
            name,
            reason: format!(
                "noise covariance must be positive semi-definite (smallest eigenvalue {min:.3e})"
            ),
        });
    }
    Ok(())
}
