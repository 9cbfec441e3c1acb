#![doc = include_str!("../README.md")]
#![deny(missing_docs)]

mod ekf;
mod error;
pub mod monobot;
pub mod motion;
/// The Ackermann vehicle, also at [`motion::ackermann`].
pub use motion::ackermann;
mod observation;
pub mod planar;
pub mod wall;

pub use ackermann::{Ackermann, LaserObservation};
pub use ekf::{Compressed, Ekf, Gated, JacobianBlock, Passive, SparseJacobian, Update};
pub use error::{Result, SlamError};
pub use motion::{MotionModel, Prediction, Unicycle, unicycle};
pub use observation::{landmark_from_range_bearing, range_bearing};
pub use planar::{PlanarConfig, PlanarSlam};
