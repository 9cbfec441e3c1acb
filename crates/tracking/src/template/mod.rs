//! The colour + template tracker (issue 34): Staple (Bertinetto et al. 2016) on the
//! seed's colour histograms (000 section 3.2): a correlation filter on HOG cells
//! ([`hog`], [`filter`]) merged with a per-pixel colour likelihood ([`likelihood`]),
//! DSST's scale filter ([`scale`]), a lost signal and re-detection ([`tracker`]).

mod contrast;
mod dcf;
mod fft;
mod filter;
mod geometry;
mod hog;
mod learn;
mod likelihood;
mod locate;
mod lost;
mod params;
mod patch;
mod result;
mod scale;
mod sharpness;
pub mod stages;
mod tracker;

pub use params::ColorTemplateParams;
pub use result::{Confidence, TemplateResult};
pub use tracker::ColorTemplateTracker;
