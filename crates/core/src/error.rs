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
    /// A size a caller asked for would need more memory than rperc allows itself.
    #[error("{}", too_large(name, *count, *bytes, *limit))]
    TooLarge {
        /// The parameter that sets the size.
        name: &'static str,
        /// The size asked for.
        count: u128,
        /// The bytes it would need.
        bytes: u128,
        /// [`max_allocation_bytes`].
        limit: u128,
    },
    /// The caller asked the work to stop (Ctrl-C in Python): see [`crate::interrupt`].
    #[error("interrupted")]
    Interrupted,
    /// A string option that names no known choice.
    #[error(
        "unknown {kind} '{}'; expected one of {}",
        clip(got, QUOTE_LIMIT),
        quoted(expected)
    )]
    UnknownName {
        /// What was being parsed (`method`, `metric`, ...).
        kind: &'static str,
        /// The string given.
        got: String,
        /// The valid names.
        expected: &'static [&'static str],
    },
}

/// The message of [`CoreError::TooLarge`], also for a size named at run time (the
/// Python layer's own allocations).
pub fn too_large(name: &str, count: u128, bytes: u128, limit: u128) -> String {
    format!("'{name}' = {count} would need {bytes} bytes, over the limit of {limit} bytes")
}

/// The most characters of a caller's input an error message quotes.
pub const QUOTE_LIMIT: usize = 80;

/// `text` quoted (Rust's `{:?}`), cut after [`QUOTE_LIMIT`] characters with a count of
/// the rest: an error names enough of its input to find it, never a 50 MB line
/// (issue 38; `rperc._args.excerpt` is the Python side's).
///
/// # Examples
/// ```
/// assert_eq!(rperc_core::excerpt("1 2 x"), "\"1 2 x\"");
/// let long = "7".repeat(1000);
/// assert_eq!(rperc_core::excerpt(&long), format!("{:?}... (920 more characters)", &long[..80]));
/// ```
pub fn excerpt(text: &str) -> String {
    let (head, rest) = split_at_char(text, QUOTE_LIMIT);
    match rest {
        0 => format!("{head:?}"),
        _ => format!("{head:?}... ({rest} more characters)"),
    }
}

/// `text` unquoted, cut after `limit` characters with a count of the rest: for a
/// message that carries input inside it (serde's, a library's).
///
/// # Examples
/// ```
/// assert_eq!(rperc_core::clip("unknown field `x`", 80), "unknown field `x`");
/// assert_eq!(rperc_core::clip(&"z".repeat(10), 4), "zzzz... (6 more characters)");
/// ```
pub fn clip(text: &str, limit: usize) -> String {
    match split_at_char(text, limit) {
        (head, 0) => head.to_owned(),
        (head, rest) => format!("{head}... ({rest} more characters)"),
    }
}

/// The first `limit` characters of `text` and how many follow.
fn split_at_char(text: &str, limit: usize) -> (&str, usize) {
    match text.char_indices().nth(limit) {
        None => (text, 0),
        Some((cut, _)) => (&text[..cut], text[cut..].chars().count()),
    }
}

fn quoted(names: &[&str]) -> String {
    names
        .iter()
        .map(|n| format!("'{n}'"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The most memory one request may ask rperc to allocate by default (4 GiB): a size
/// above the limit is refused with [`CoreError::TooLarge`] before anything is
/// allocated, so a typo such as `n_particles=10**13` is an error, not an aborted
/// process.
pub const MAX_ALLOCATION_BYTES: u128 = 4 << 30;

/// The environment variable that replaces [`MAX_ALLOCATION_BYTES`] for the process
/// (read once, at the first check): a machine, container or test harness with less
/// memory than the default sets it below what it can really allocate, so that every
/// accepted request also succeeds. A value that is not a positive integer is ignored.
pub const MAX_ALLOCATION_ENV: &str = "RPERC_MAX_ALLOCATION_BYTES";

/// The limit in force: [`MAX_ALLOCATION_ENV`] if set to a positive integer, else
/// [`MAX_ALLOCATION_BYTES`].
pub fn max_allocation_bytes() -> u128 {
    static LIMIT: std::sync::OnceLock<u128> = std::sync::OnceLock::new();
    *LIMIT.get_or_init(|| {
        std::env::var(MAX_ALLOCATION_ENV)
            .ok()
            .and_then(|v| v.trim().parse::<u128>().ok())
            .filter(|&v| v > 0)
            .unwrap_or(MAX_ALLOCATION_BYTES)
    })
}

/// `Err(TooLarge)` when `count` items of `bytes_each` bytes exceed
/// [`max_allocation_bytes`].
///
/// # Examples
/// ```
/// assert!(rperc_core::check_allocation("n", 1_000, 8).is_ok());
/// let err = rperc_core::check_allocation("n", 1 << 40, 8).unwrap_err();
/// assert!(err.to_string().starts_with("'n' = 1099511627776 would need 8796093022208 bytes"));
/// ```
pub fn check_allocation(name: &'static str, count: u128, bytes_each: u128) -> Result<()> {
    check_bytes(name, count, count.saturating_mul(bytes_each))
}

/// `Err(TooLarge)` when the `bytes` that `count` (the value the caller set for `name`)
/// implies exceed [`max_allocation_bytes`]: for sizes that grow faster than linearly,
/// such as a covariance of `(3 + 2 n)^2` entries for `n` landmarks, so that the
/// message still names what the caller asked for, not a derived dimension.
///
/// # Examples
/// ```
/// let err = rperc_core::check_bytes("landmarks", 30_000, 60_003u128.pow(2) * 8).unwrap_err();
/// assert!(err.to_string().starts_with("'landmarks' = 30000 would need 28802880072 bytes"));
/// ```
pub fn check_bytes(name: &'static str, count: u128, bytes: u128) -> Result<()> {
    let limit = max_allocation_bytes();
    if bytes <= limit {
        Ok(())
    } else {
        Err(CoreError::TooLarge {
            name,
            count,
            bytes,
            limit,
        })
    }
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

/// The largest coordinate magnitude (metres, or pixels) a position may have: there a
/// float still resolves a tenth of a micrometre, and no robot's world or image is
/// larger. A start at 1e300 m stood still to every motion added to it (issue 38).
pub const MAX_COORDINATE: f64 = 1e9;

/// `Err(InvalidParameter)` unless every value is finite and within
/// [`MAX_COORDINATE`]: the one finite-range check of a coordinate input.
///
/// # Examples
/// ```
/// assert!(rperc_core::ensure_coordinates("start", &[3.0, -2.5e6]).is_ok());
/// assert!(rperc_core::ensure_coordinates("start", &[1e300, 0.0]).is_err());
/// ```
pub fn ensure_coordinates<'a>(
    name: &'static str,
    values: impl IntoIterator<Item = &'a f64>,
) -> Result<()> {
    match values
        .into_iter()
        .find(|v| !(v.is_finite() && v.abs() <= MAX_COORDINATE))
    {
        None => Ok(()),
        Some(v) => Err(CoreError::InvalidParameter {
            name,
            reason: format!(
                "coordinates must be finite and within +-{MAX_COORDINATE:e}, got {v:e}"
            ),
        }),
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

/// A config's fields checked by name: each of `positive` with [`ensure_positive`],
/// then each of `non_negative` with [`ensure_non_negative`]; the first refused
/// field's error.
///
/// # Examples
/// ```
/// assert!(rperc_core::ensure_fields(&[("dt", 0.1)], &[("noise", 0.0)]).is_ok());
/// let err = rperc_core::ensure_fields(&[("dt", 0.1)], &[("noise", -1.0)]).unwrap_err();
/// assert!(err.to_string().contains("'noise'"));
/// ```
pub fn ensure_fields(
    positive: &[(&'static str, f64)],
    non_negative: &[(&'static str, f64)],
) -> Result<()> {
    for &(name, v) in positive {
        ensure_positive(name, v)?;
    }
    for &(name, v) in non_negative {
        ensure_non_negative(name, v)?;
    }
    Ok(())
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

/// The most particles (samples) any of rperc's particle filters runs: each is weighed
/// against the image every frame, so a million already takes seconds per frame, and a
/// typo such as `n_particles=10**13` is refused at once by [`ensure_count`].
pub const MAX_PARTICLES: usize = 1_000_000;

/// The one check of a size or count a caller sets (particles, contour points, model
/// points, scale levels): `Err(InvalidParameter)` naming `name` unless `min <= value
/// <= max`, then `Err(TooLarge)` when `value` items of `bytes_each` bytes exceed
/// [`max_allocation_bytes`]. Called before anything is allocated, so no size aborts
/// the process or runs for minutes before failing.
///
/// # Examples
/// ```
/// use rperc_core::{MAX_PARTICLES, ensure_count};
/// assert!(ensure_count("n_particles", 200, 1, MAX_PARTICLES, 64).is_ok());
/// let err = ensure_count("n_particles", 10_000_000_000_000, 1, MAX_PARTICLES, 64);
/// assert!(err.unwrap_err().to_string().contains("'n_particles'"));
/// ```
pub fn ensure_count(
    name: &'static str,
    value: usize,
    min: usize,
    max: usize,
    bytes_each: u128,
) -> Result<()> {
    if !(min..=max).contains(&value) {
        return Err(CoreError::InvalidParameter {
            name,
            reason: format!("must be in {min}..={max}, got {value}"),
        });
    }
    check_allocation(name, value as u128, bytes_each)
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
    /// A request for more memory than rperc allows itself (Python `MemoryError`).
    Memory,
    /// The work was stopped on request (Python: the pending `KeyboardInterrupt`).
    Interrupted,
}

impl CoreError {
    /// How a caller should read this error.
    pub fn class(&self) -> ErrorClass {
        match self {
            CoreError::TooLarge { .. } => ErrorClass::Memory,
            CoreError::Interrupted => ErrorClass::Interrupted,
            _ => ErrorClass::InvalidInput,
        }
    }
}
