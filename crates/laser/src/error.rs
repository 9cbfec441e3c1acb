//! The one error type of the crate; the Python bridge maps each variant to an exception.

use rperc_core::CoreError;

/// Everything that can go wrong in `laser`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum LaserError {
    /// A bad argument: a wrong size, a NaN, a value out of range, too large a request,
    /// an interrupt (from the shared core's checks).
    #[error(transparent)]
    Core(#[from] CoreError),
    /// A linear system that should be positive definite is not (a pose graph without
    /// a prior, a degenerate block).
    #[error("numerical failure: {0}")]
    Numerical(String),
    /// An error at one scan of a run, with its index.
    #[error("scan {index}: {source}")]
    AtScan {
        /// Position of the scan in the log (from 0).
        index: usize,
        /// What went wrong there.
        source: Box<LaserError>,
    },
}

/// Result alias for this crate.
pub type Result<T> = std::result::Result<T, LaserError>;

impl LaserError {
    /// A parameter out of range.
    pub(crate) fn invalid(name: &'static str, reason: String) -> Self {
        LaserError::Core(CoreError::InvalidParameter { name, reason })
    }

    /// A size mismatch.
    pub(crate) fn dimension(what: String) -> Self {
        LaserError::Core(CoreError::Dimension(what))
    }
}

impl From<slam::SlamError> for LaserError {
    fn from(e: slam::SlamError) -> Self {
        match e {
            slam::SlamError::Core(c) => LaserError::Core(c),
            other => LaserError::Numerical(other.to_string()),
        }
    }
}

impl LaserError {
    /// Whether the caller passed something wrong or the numerics failed.
    pub fn class(&self) -> rperc_core::ErrorClass {
        match self {
            LaserError::Numerical(_) => rperc_core::ErrorClass::Numerical,
            LaserError::Core(e) => e.class(),
            LaserError::AtScan { source, .. } => source.class(),
        }
    }
}
