//! The one error type of the crate; the Python bridge maps each variant to an exception.

/// Everything that can go wrong in `linesimp`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum LineSimpError {
    /// The tolerance was negative, NaN or infinite.
    #[error("epsilon must be finite and >= 0, got {0}")]
    InvalidEpsilon(f64),
    /// A coordinate was NaN or infinite; `index` is the row of the offending point.
    #[error("point {index} has a non-finite coordinate ({x}, {y})")]
    NonFinitePoint {
        /// Row of the point in the input.
        index: usize,
        /// Its x coordinate.
        x: f64,
        /// Its y coordinate.
        y: f64,
    },
    /// Path hulls answer farthest-from-line queries only.
    #[error(
        "method 'hull' supports only metric 'line' (path hulls find the farthest point from a line); use method 'dp' for metric 'segment'"
    )]
    UnsupportedMetric,
    /// A parameter was out of its valid range.
    #[error("invalid parameter '{name}': {reason}")]
    InvalidParameter {
        /// The parameter's name as documented.
        name: &'static str,
        /// Why the value was refused.
        reason: String,
    },
    /// From the shared core (an unknown option name...).
    #[error(transparent)]
    Core(#[from] rperc_core::CoreError),
    /// Two arrays that must have the same length did not.
    #[error("length mismatch: {what}")]
    LengthMismatch {
        /// Which arrays and their lengths.
        what: String,
    },
}

/// Result alias for this crate.
pub type Result<T> = std::result::Result<T, LineSimpError>;

impl LineSimpError {
    /// Every line-simplification error is a bad argument.
    pub fn class(&self) -> rperc_core::ErrorClass {
        match self {
            LineSimpError::Core(e) => e.class(),
            _ => rperc_core::ErrorClass::InvalidInput,
        }
    }
}
