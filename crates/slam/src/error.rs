//! The one error type of the crate; the Python bridge maps each variant to an exception.

use rperc_core::CoreError;

/// Everything that can go wrong in `slam`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SlamError {
    /// The innovation covariance S is singular, not positive definite or not finite.
    /// The filter state was left unchanged.
    #[error("innovation covariance S is singular or not positive definite: {0}")]
    SingularInnovation(String),
    /// A matrix or vector argument has the wrong size.
    #[error("dimension mismatch: {0}")]
    Dimension(String),
    /// A value was NaN or infinite.
    #[error("non-finite value in {0}")]
    NonFinite(&'static str),
    /// A parameter was out of its valid range.
    #[error("invalid parameter '{name}': {reason}")]
    InvalidParameter {
        /// The parameter's name as documented.
        name: &'static str,
        /// Why the value was refused.
        reason: String,
    },
    /// From the shared core: a covariance that is not symmetric PSD, an unknown
    /// option name, a bad chi-square argument.
    #[error(transparent)]
    Core(#[from] CoreError),
}

/// Result alias for this crate.
pub type Result<T> = std::result::Result<T, SlamError>;

/// Refuses a non-finite matrix or vector.
pub(crate) fn ensure_finite<'a>(
    what: &'static str,
    values: impl IntoIterator<Item = &'a f64>,
) -> Result<()> {
    if values.into_iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(SlamError::NonFinite(what))
    }
}

impl SlamError {
    /// Whether the caller passed something wrong or the numerics failed.
    pub fn class(&self) -> rperc_core::ErrorClass {
        match self {
            SlamError::SingularInnovation(_) => rperc_core::ErrorClass::Numerical,
            _ => rperc_core::ErrorClass::InvalidInput,
        }
    }
}
