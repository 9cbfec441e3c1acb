//! A seeded ceiling world with ground truth, for the visual memory of the second seed
//! (section 2): a ceiling plane carrying distinctive 2-D patterns over a repeated tile
//! texture, a unicycle robot whose odometry drifts, and its upward-looking camera with
//! known intrinsics and a slightly tilted, offset mount (the `C T_R` of eq. 1).
//!
//! No public ceiling-camera data set has ground truth, so this is where the mosaic,
//! the localisation of eq. 2 and the key-image navigation are measured.

mod camera;
mod drive;
mod render;
mod world;

pub use camera::{CameraMount, CeilingCamera, apply_homography, correct_image, world_from_robot};
pub use drive::{Drive, OdometryNoise, drive};
pub use render::{RenderParams, RenderTruth, render, render_sequence};
pub use world::{Ceiling, CeilingParams, CeilingPattern, PatternKind};
