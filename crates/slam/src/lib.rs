#![doc = include_str!("../README.md")]
#![deny(missing_docs)]

mod ekf;
mod error;
mod gaussian;
pub mod monobot;
mod observation;
mod pose;
mod stats;

pub use ekf::{Ekf, JacobianBlock, SparseJacobian, Update};
pub use error::{Result, SlamError};
pub use gaussian::{Gaussian, asymmetry, mahalanobis2, min_relative_eigenvalue};
pub use observation::{landmark_from_range_bearing, range_bearing};
pub use pose::{Pose2, wrap_angle};
pub use stats::{chi2_cdf, chi2_quantile, nees_bounds};
