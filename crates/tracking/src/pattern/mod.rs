//! The 2-D pattern tracker's model and observation model (Ait Aider, Chateau &
//! Lapresté, sections 3.2-3.3): contour points with grey-level vectors along their
//! gradient, the inter-correlation likelihood with occlusion and scale space.

pub mod contour;
pub mod correlation;
mod model;
mod observation;

pub use model::{MIN_REGION_SIDE, ModelPoint, PatternConfig, PatternModel, Region, sample_vector};
pub use observation::{Observation, PatternLikelihood, PatternScratch, ScaleSpace, place};
