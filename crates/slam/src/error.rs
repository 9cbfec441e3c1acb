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
    /// A prediction or update whose result would not be finite, or would have a
    /// negative variance: the filter diverged. The state was left unchanged.
    #[error("the filter diverged in {0}")]
    Diverged(String),
    /// A bad argument, from the shared core's checks: a wrong size
    /// ([`CoreError::Dimension`]), a NaN ([`CoreError::NonFinite`]), a value out of
    /// range ([`CoreError::InvalidParameter`]), a covariance that is not symmetric PSD,
    /// an unknown option name.
    #[error(transparent)]
    Core(#[from] CoreError),
    /// An error at one event of a run, with the event's index in the stream and its
    /// time, so a failure in a long data set names where it happened.
    #[error("event {index} (t = {time}): {source}")]
    AtEvent {
        /// Position of the event in the time-ordered stream (from 0).
        index: usize,
        /// The event's time stamp.
        time: f64,
        /// What went wrong there.
        source: Box<SlamError>,
    },
}

/// Result alias for this crate.
pub type Result<T> = std::result::Result<T, SlamError>;

impl SlamError {
    /// A size mismatch.
    pub(crate) fn dimension(what: String) -> Self {
        SlamError::Core(CoreError::Dimension(what))
    }

    /// A parameter out of range.
    pub(crate) fn invalid(name: &'static str, reason: String) -> Self {
        SlamError::Core(CoreError::InvalidParameter { name, reason })
    }
}

/// Refuses a non-finite matrix or vector.
pub(crate) fn ensure_finite<'a>(
    what: &'static str,
    values: impl IntoIterator<Item = &'a f64>,
) -> Result<()> {
    Ok(rperc_core::ensure_finite(what, values)?)
}

impl SlamError {
    /// Whether the caller passed something wrong or the numerics failed.
    pub fn class(&self) -> rperc_core::ErrorClass {
        match self {
            SlamError::SingularInnovation(_) | SlamError::Diverged(_) => {
                rperc_core::ErrorClass::Numerical
            }
            SlamError::Core(e) => e.class(),
            SlamError::AtEvent { source, .. } => source.class(),
        }
    }
}
