//! The filter's motion model: linear-Gaussian dynamics (seed 000 section 3.3).

use nalgebra::{SMatrix, SVector};

use crate::error::{Result, TrackingError};

/// Linear-Gaussian dynamics `s_t = A s'_t + B w_t`, `w_t ~ N(0, I)` (seed 000 section 3.3):
/// `A` is the deterministic part, `B B^T` the process noise covariance.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearGaussian<const D: usize> {
    /// Deterministic part `A`.
    pub a: SMatrix<f64, D, D>,
    /// Noise gain `B`.
    pub b: SMatrix<f64, D, D>,
}

impl<const D: usize> LinearGaussian<D> {
    /// A random walk `s_t = s'_t + diag(sigma) w_t`.
    ///
    /// # Examples
    /// ```
    /// use nalgebra::Vector2;
    /// use tracking::LinearGaussian;
    ///
    /// let d = LinearGaussian::random_walk(Vector2::new(1.0, 2.0));
    /// assert_eq!(d.b[(1, 1)], 2.0);
    /// ```
    pub fn random_walk(sigma: SVector<f64, D>) -> Self {
        Self {
            a: SMatrix::identity(),
            b: SMatrix::from_diagonal(&sigma),
        }
    }

    pub(super) fn validate(&self) -> Result<()> {
        if self.a.iter().chain(self.b.iter()).all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err(TrackingError::InvalidParameter {
                name: "dynamics",
                reason: "A and B must be finite".into(),
            })
        }
    }
}
