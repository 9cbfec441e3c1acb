//! Visual memory (second seed, section 2): the mosaic of ceiling models with their
//! poses, localisation from any tracked model (eq. 2), new models placed by eq. 3,
//! automatic model generation, key images, and the geometry that links image poses to
//! robot poses.

mod geometry;
mod salient;

pub use geometry::{ImageScale, fuse, new_model_in_mosaic, robot_in_mosaic};
pub use salient::{ProposalParams, propose_regions};
