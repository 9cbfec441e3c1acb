//! The compressed filter's state while the robot works in a local area (see
//! `compress.rs` for when and how the engine uses it).

use crate::ekf::Compressed;

/// A compressed filter's auxiliary state and the work an area made afresh would
/// have saved since this one was made.
#[derive(Debug, Clone)]
pub(super) struct Local {
    pub(super) aux: Compressed,
    pub(super) regret: f64,
}
