#![doc = include_str!("../README.md")]
#![deny(missing_docs)]

mod ekf;
mod error;
pub mod monobot;
mod observation;

pub use ekf::{Ekf, JacobianBlock, SparseJacobian, Update};
pub use error::{Result, SlamError};
pub use observation::{landmark_from_range_bearing, range_bearing};
