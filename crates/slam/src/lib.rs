#![doc = include_str!("../README.md")]
#![deny(missing_docs)]

pub mod ackermann;
mod ekf;
mod error;
pub mod monobot;
pub mod motion;
mod observation;
pub mod planar;
pub mod wall;

pub use ackermann::{Ackermann, LaserObservation};
pub use ekf::{Compressed, Ekf, Gated, JacobianBlock, Passive, SparseJacobian, Update};
pub use error::{Result, SlamError};
pub use motion::{MotionModel, Prediction, Unicycle, unicycle};
pub use observation::{landmark_from_range_bearing, range_bearing};
pub use planar::{PlanarConfig, PlanarSlam};
