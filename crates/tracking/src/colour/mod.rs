//! The colour module of seed 000 section 3.2 (after Birchfield 1998): colour spaces,
//! elliptical regions, histogram intersection eq. (28) with incremental updates, model
//! adaptation eq. (29), and the two trackers built on them.

mod ellipse;
mod gradient;
mod model;
mod particle_tracker;
mod pyramid;
mod region;
mod ring;
mod space;
mod tracker;

pub use model::{AppearanceParams, ModelKind};
pub use particle_tracker::{ParticleColorTracker, ParticleTrackerParams};
pub(crate) use space::check_bins;
pub use space::{ColorSpace, MAX_BINS_PER_AXIS};
pub use tracker::{ColorHistogramTracker, ColorTrackerParams, TrackResult};
