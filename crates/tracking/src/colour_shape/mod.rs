//! The colour+shape tracker of seed 000 section 3.3: CONDENSATION over the target's
//! colour distribution `[m, lambda, theta, phi]`, each sample weighted by the affine snake
//! fitted to the segmentation its histogram produces, and the best sample's contour
//! refined on the image edges.

mod cloud;
mod params;
pub(crate) mod sample;
pub(crate) mod segment;
pub(crate) mod snake;
mod state;
mod tracker;

pub use params::ColorShapeParams;
pub use segment::colour_segment;
pub use state::{ColourDistribution, ColourDynamics};
pub use tracker::{ColorShapeResult, ColorShapeTracker};
