//! The one error type of the crate; every other rperc crate wraps it.

/// Everything that can go wrong in `rperc-core`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CoreError {
    /// A matrix that must be symmetric positive (semi-)definite is not.
    #[error("covariance '{name}' is not {requirement}: {reason}")]
    NotPositiveDefinite {
        /// Which matrix.
        name: &'static str,
        /// "symmetric positive definite" or "symmetric positive semi-definite".
        requirement: &'static str,
        /// What was found (asymmetry, smallest eigenvalue...).
        reason: String,
    },
    /// Sizes that must agree do not.
    #[error("dimension mismatch: {0}")]
    Dimension(String),
    /// A NaN or infinite value where a finite one is required.
    #[error("non-finite value in {0}")]
    NonFinite(&'static str),
    /// A parameter out of its valid range.
    #[error("invalid parameter '{name}': {reason}")]
    InvalidParameter {
        /// The parameter's name as documented.
        name: &'static str,
        /// Why the value was refused.
        reason: String,
    },
    /// A string option that names no known choice.
    #[error("unknown {kind} '{got}'; expected one of {}", quoted(expected))]
    UnknownName {
        /// What was being parsed (`method`, `metric`, ...).
        kind: &'static str,
        /// The string given.
        got: String,
        /// The valid names.
        expected: &'static [&'static str],
    },
}

fn quoted(names: &[&str]) -> String {
    names
        .iter()
        .map(|n| format!("'{n}'"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, CoreError>;

/// `Err(NonFinite(what))` unless every value is finite.
pub fn ensure_finite<'a>(
    what: &'static str,
    values: impl IntoIterator<Item = &'a f64>,
) -> Result<()> {
    if values.into_iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(CoreError::NonFinite(what))
    }
}

/// `Err(InvalidParameter)` unless `value` is finite and `> 0`.
pub fn ensure_positive(name: &'static str, value: f64) -> Result<()> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(CoreError::InvalidParameter {
            name,
            reason: format!("must be finite and > 0, got {value}"),
        })
    }
}

/// `Err(InvalidParameter)` unless `value` is finite and `>= 0`.
pub fn ensure_non_negative(name: &'static str, value: f64) -> Result<()> {
    if value.is_finite() && value >= 0.0 {
        Ok(())
    } else {
        Err(CoreError::InvalidParameter {
            name,
            reason: format!("must be finite and >= 0, got {value}"),
        })
    }
}

/// `Err(InvalidParameter)` unless `value` is finite and in `[lo, hi]`.
pub fn ensure_in_range(name: &'static str, value: f64, lo: f64, hi: f64) -> Result<()> {
    if value.is_finite() && (lo..=hi).contains(&value) {
        Ok(())
    } else {
        Err(CoreError::InvalidParameter {
            name,
            reason: format!("must be finite and in [{lo}, {hi}], got {value}"),
        })
    }
}

/// How a caller should read an error: the one classification every rperc crate gives
/// its errors, so that bindings map classes, not variants, to exceptions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ErrorClass {
    /// A bad argument: wrong value, size or name (Python `ValueError`).
    InvalidInput,
    /// A numerical failure inside an algorithm given valid input: a singular
    /// innovation covariance, a filter that diverged (Python `rperc.NumericalError`).
    Numerical,
    /// A file that could not be read or decoded (Python `OSError`).
    Io,
}

impl CoreError {
    /// Every core error is a bad argument.
    pub fn class(&self) -> ErrorClass {
        ErrorClass::InvalidInput
    }
}
