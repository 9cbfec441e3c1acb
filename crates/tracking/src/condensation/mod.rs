//! The CONDENSATION particle filter (Isard & Blake 1998; seed 000 section 3.3, seed 001
//! section 3.1): resample, propagate `s = A s' + B w`, weight by the likelihood.

mod dynamics;
mod filter;
mod mixture;
mod resample;

pub use dynamics::LinearGaussian;
pub use filter::{FilterParams, Likelihood, ParticleFilter, ResamplePolicy, StepReport};
pub use mixture::Guess;
pub use resample::{Resampler, effective_sample_size};
