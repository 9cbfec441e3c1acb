//! The one error type of the crate; the Python bridge maps each variant to an exception.

use tracking::TrackingError;

/// Everything that can go wrong in `navigation`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum NavigationError {
    /// A parameter was out of its valid range.
    #[error("invalid parameter '{name}': {reason}")]
    InvalidParameter {
        /// The parameter's name as documented.
        name: &'static str,
        /// Why the value was refused.
        reason: String,
    },
    /// From the pattern tracker a model is followed with, and a frame whose size is not
    /// the camera's ([`TrackingError::FrameSizeChanged`]).
    #[error(transparent)]
    Tracking(#[from] TrackingError),
    /// From the shared core: a bad image size, a parameter out of range, an unknown
    /// option name.
    #[error(transparent)]
    Core(#[from] rperc_core::CoreError),
}

/// Shorthand for results of this crate.
pub type Result<T> = std::result::Result<T, NavigationError>;

impl NavigationError {
    /// The name of the parameter this error refuses, whichever layer refused it.
    pub fn parameter(&self) -> Option<&'static str> {
        match self {
            NavigationError::InvalidParameter { name, .. } => Some(name),
            NavigationError::Tracking(e) => e.parameter(),
            NavigationError::Core(rperc_core::CoreError::InvalidParameter { name, .. }) => {
                Some(name)
            }
            _ => None,
        }
    }

    /// Whether the caller passed something wrong or a file could not be read.
    pub fn class(&self) -> rperc_core::ErrorClass {
        match self {
            NavigationError::Tracking(e) => e.class(),
            NavigationError::Core(e) => e.class(),
            _ => rperc_core::ErrorClass::InvalidInput,
        }
    }
}
