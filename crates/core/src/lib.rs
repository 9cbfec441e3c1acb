#![doc = include_str!("../README.md")]
#![deny(missing_docs)]

pub mod angle;
pub mod chi2;
mod error;
pub mod gaussian;
pub mod image;
pub mod interrupt;
mod named;
pub mod pose;
pub mod rng;

pub use angle::{angle_diff, wrap_angle};
pub use chi2::{chi2_cdf, chi2_gate, chi2_quantile, nees_band};
pub use error::{
    CoreError, ErrorClass, MAX_ALLOCATION_BYTES, MAX_ALLOCATION_ENV, MAX_COORDINATE, MAX_PARTICLES,
    QUOTE_LIMIT, Result, check_allocation, check_bytes, clip, ensure_coordinates, ensure_count,
    ensure_fields, ensure_finite, ensure_in_range, ensure_non_negative, ensure_positive, excerpt,
    max_allocation_bytes, too_large,
};
pub use gaussian::{
    Definiteness, Gaussian, asymmetry, check_covariance, cholesky_inverse, cholesky_lower,
    cholesky_solve_mut, lower_inverse, mahalanobis2, min_relative_eigenvalue, repair_covariance,
};
pub use pose::Pose2;
/// Re-exported for [`named_enum!`].
#[doc(hidden)]
pub use schemars;
pub use serde;
