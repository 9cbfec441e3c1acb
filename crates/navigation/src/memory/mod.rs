//! Visual memory (second seed, section 2): the mosaic of ceiling models with their
//! poses, localisation from any tracked model (eq. 2), new models placed by eq. 3,
//! automatic model generation, key images, and visual servoing from key image to key
//! image.

mod acquire;
mod geometry;
mod keyimages;
mod localiser;
mod mosaic;
mod run;
mod salient;
mod servo;

pub use acquire::{Found, search_pose};
pub use geometry::{
    ImageScale, PointPair, fit_pose, fuse, new_model_in_mosaic, robot_in_mosaic, spread,
};
pub use keyimages::{
    KeyImage, KeyImageParams, LearntFrame, TrackedModel, check_chain, select_key_images, separation,
};
pub use localiser::{LocaliserParams, ModelSighting, PoseFilter, observe};
pub use mosaic::{
    FrameReport, MosaicBuilder, MosaicCovariance, MosaicModel, MosaicParams, rotation_lever,
};
pub use run::{
    LearnParams, Learning, Replay, ReplayOutcome, ReplayParams, Scene, VisualMemory, World, learn,
    replay,
};
pub use salient::{ProposalParams, propose_regions};
pub use servo::{ServoParams, command, key_error};
