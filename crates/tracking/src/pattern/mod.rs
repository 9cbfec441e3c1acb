//! The 2-D pattern tracker (Ait Aider, Chateau & Lapresté, sections 3.1-3.3):
//! contour points with grey-level vectors along their
//! gradient, the inter-correlation likelihood with occlusion and scale space, and the
//! CONDENSATION tracker over (x, y, theta, s).

pub mod contour;
pub mod correlation;
mod frame;
pub mod homography;
mod layer;
mod model;
mod observation;
mod search;
mod sequence;
mod tracker;

pub use frame::PatternFrame;
pub use homography::MotionModel;
pub use model::{
    DeviationModel, MIN_REGION_SIDE, ModelPoint, PatternConfig, PatternModel, Region, sample_vector,
};
pub use observation::{
    EXTRAPOLATE_AFTER, NormalEquations, Observation, PatternLikelihood, PatternScratch, ScaleSpace,
    place,
};
pub use sequence::{PatternSequence, SequenceParams, generate_sequence};
pub use tracker::{PatternPose, PatternTracker, PatternTrackerParams, corners_of};
