#![doc = include_str!("../README.md")]
#![deny(missing_docs)]

mod condensation;
mod error;

pub use condensation::{
    FilterParams, Likelihood, LinearGaussian, ParticleFilter, ResamplePolicy, Resampler,
    StepReport, effective_sample_size,
};
pub use error::{Result, TrackingError};
