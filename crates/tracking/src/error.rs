//! The one error type of the crate; the Python bridge maps each variant to an exception.

/// Everything that can go wrong in `tracking`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum TrackingError {
    /// A parameter was out of its valid range (negative noise, zero particles, NaN...).
    #[error("invalid parameter '{name}': {reason}")]
    InvalidParameter {
        /// The parameter's name as documented.
        name: &'static str,
        /// Why the value was refused.
        reason: String,
    },
    /// A covariance matrix that must be symmetric positive definite was not.
    #[error("covariance '{name}' is not symmetric positive definite")]
    NotPositiveDefinite {
        /// Which covariance.
        name: &'static str,
    },
    /// The frame size changed between `new` and `update`.
    #[error("frame size changed from {expected_width}x{expected_height} to {width}x{height}")]
    FrameSizeChanged {
        /// Size the tracker was initialised with.
        expected_width: usize,
        /// Size the tracker was initialised with.
        expected_height: usize,
        /// Size of the frame passed now.
        width: usize,
        /// Size of the frame passed now.
        height: usize,
    },
    /// A box with a non-positive or non-finite width or height, or a non-finite corner.
    #[error("box ({x}, {y}, {w}, {h}) must have finite coordinates and w, h >= 1")]
    InvalidBox {
        /// Left edge.
        x: f64,
        /// Top edge.
        y: f64,
        /// Width.
        w: f64,
        /// Height.
        h: f64,
    },
    /// A box that does not lie inside the frame.
    #[error("box ({x}, {y}, {w}, {h}) is not inside the {width}x{height} frame")]
    BoxOutsideFrame {
        /// Left edge.
        x: f64,
        /// Top edge.
        y: f64,
        /// Width.
        w: f64,
        /// Height.
        h: f64,
        /// Frame width.
        width: usize,
        /// Frame height.
        height: usize,
    },
    /// Two inputs that must have the same length did not.
    #[error("length mismatch: {what}")]
    LengthMismatch {
        /// Which inputs and their lengths.
        what: String,
    },
    /// Resampling weights were empty, negative, non-finite or all zero.
    #[error("invalid weights: {reason}")]
    InvalidWeights {
        /// What is wrong with them.
        reason: String,
    },
    /// A malformed line in a data file (file name and 1-based line number).
    #[error("{path}:{line}: {reason}")]
    Parse {
        /// The file.
        path: String,
        /// 1-based line number.
        line: usize,
        /// What is wrong with the line.
        reason: String,
    },
    /// From the shared core: a bad image size, a parameter out of range, an unknown
    /// option name.
    #[error(transparent)]
    Core(#[from] rperc_core::CoreError),
    /// An I/O or image decoding failure, with the file concerned.
    #[error("{path}: {reason}")]
    Io {
        /// The file.
        path: String,
        /// The underlying error's message.
        reason: String,
    },
}

/// Shorthand for results of this crate.
pub type Result<T> = std::result::Result<T, TrackingError>;

impl TrackingError {
    /// The name of the parameter this error refuses, whichever layer refused it.
    pub fn parameter(&self) -> Option<&'static str> {
        match self {
            TrackingError::InvalidParameter { name, .. } => Some(name),
            TrackingError::Core(rperc_core::CoreError::InvalidParameter { name, .. }) => Some(name),
            _ => None,
        }
    }

    /// [`TrackingError::FrameSizeChanged`] unless a frame of `(width, height)` `size`
    /// has the `expected` size: every tracker and camera refuses a frame of another
    /// size the same way.
    pub fn check_frame_size(expected: (usize, usize), size: (usize, usize)) -> Result<()> {
        if size == expected {
            return Ok(());
        }
        Err(TrackingError::FrameSizeChanged {
            expected_width: expected.0,
            expected_height: expected.1,
            width: size.0,
            height: size.1,
        })
    }
}

impl TrackingError {
    /// Whether the caller passed something wrong or a file could not be read.
    pub fn class(&self) -> rperc_core::ErrorClass {
        match self {
            TrackingError::Io { .. } => rperc_core::ErrorClass::Io,
            TrackingError::Core(e) => e.class(),
            _ => rperc_core::ErrorClass::InvalidInput,
        }
    }
}
