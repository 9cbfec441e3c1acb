#![doc = include_str!("../README.md")]
#![deny(missing_docs)]

mod colour;
mod colour_shape;
mod condensation;
mod error;
mod frame;
pub mod metrics;
pub mod otb;
pub mod pattern;
pub mod template;

pub use colour::{
    AppearanceParams, ColorHistogramTracker, ColorSpace, ColorTrackerParams, MAX_BINS_PER_AXIS,
    ModelKind, ParticleColorTracker, ParticleTrackerParams, TrackResult,
};
pub use colour_shape::{
    ColorShapeParams, ColorShapeResult, ColorShapeTracker, ColourDistribution, ColourDynamics,
    colour_segment,
};
pub use condensation::{
    FilterParams, Guess, Likelihood, LinearGaussian, ParticleFilter, ResamplePolicy, Resampler,
    StepReport, effective_sample_size,
};
pub use error::{Result, TrackingError};
pub use frame::{BoundingBox, RgbFrame, frame_from_image};
pub use pattern::{
    Observation, PatternConfig, PatternFrame, PatternLikelihood, PatternModel, PatternPose,
    PatternSequence, PatternTracker, PatternTrackerParams, Region, ScaleSpace, SequenceParams,
    generate_sequence,
};
pub use template::{ColorTemplateParams, ColorTemplateTracker, Confidence, TemplateResult};
