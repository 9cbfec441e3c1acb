//! The typed configuration of the colour+shape tracker.

use rperc_core::{
    MAX_PARTICLES, ensure_count, ensure_in_range, ensure_non_negative, ensure_positive,
};

use super::state::{ColourDynamics, colour_coords};
use crate::colour::ColorSpace;
use crate::condensation::FilterParams;
use crate::error::{Result, TrackingError};

/// Parameters of a [`ColorShapeTracker`](super::ColorShapeTracker) (seed 000 section 3.3).
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct ColorShapeParams {
    /// Colour space of the distribution: `rgb` or `opponent` (B-G, G-R, R+G+B), the
    /// seed's choice against specular highlights. Default opponent.
    pub color_space: ColorSpace,
    /// Histogram bins per axis of `H(n)`, 1..=64 each. Default 16 x 16 x 16.
    pub bins: [usize; 3],
    /// Number of samples `N`. Default 100.
    pub n_samples: usize,
    /// Process noise `B` of `s = A s' + B w`.
    pub dynamics: ColourDynamics,
    /// `sigma` of the weight `exp(-rho^2 / (2 sigma^2))`. Default 0.3.
    pub sigma: f64,
    /// `mu_1, mu_2, mu_3` weighting `1 - Phi_affine`, `1 - Phi_area`, `1 - Phi_quality`
    /// in `rho`, each >= 0, not all zero. Default (1, 1, 0.5).
    pub mu: [f64; 3],
    /// `mu` of the area prediction `A_{t-1} + mu (A_{t-1} - A_{t-2})`, in [0, 1].
    /// Default 0.5.
    pub area_momentum: f64,
    /// Drop of `Phi_quality` per hole: `Phi_quality = clamp(1 - k (1 - E), 0, 1)` with
    /// `E` the blob's Euler number. Default 0.25.
    pub hole_penalty: f64,
    /// Points on the snake, >= 8. Default 48.
    pub contour_points: usize,
    /// Edge search along each normal in the snake's first iteration, pixels, 1..=64:
    /// also how far outside the predicted contour the target's blob may reach.
    /// Default 12.
    pub search: usize,
    /// The snake's narrowest search, pixels (each iteration halves the search down to
    /// this), >= 1. Default 2.
    pub min_search: usize,
    /// A snake point lies on an edge (for `Phi_affine`) within this many pixels.
    /// Default 1.5.
    pub edge_tolerance: f64,
    /// After the affine fit, each point of `r_t` may move this far along its normal
    /// to the nearest edge (then the moves are smoothed): how much a non-rigid target's
    /// outline may change shape per frame, pixels. 0 keeps `r_t` affine. Default 4 (set
    /// on seeds 10-14 of the clutter and 10-12 of the other experiments: 2 left a bulge
    /// into a distractor touching the first frames in the outline for good).
    pub deform: usize,
    /// Smoothing passes of those moves, (1, 2, 1) / 4 each. Default 2.
    pub deform_passes: usize,
    /// Ring of background, as a fraction of the target's box on each side, whose
    /// colours are left out of the reference cloud when at least as frequent there as
    /// inside the target; 0 keeps every colour. Default 0.5.
    pub background_ring: f64,
    /// Image velocity smoothing: the contour's predicted motion is this fraction of
    /// the last displacement plus the rest of the previous prediction, in [0, 1].
    /// Default 0.5.
    pub velocity_gain: f64,
    /// Fraction of the samples drawn each frame around the colour distribution measured
    /// inside the last accepted contour (a mixture proposal, as in Isard & Blake's
    /// ICONDENSATION), in [0, 0.99]: where the shape barely constrains the colour, it
    /// keeps the set from drifting off the target's real colours. Default 0.1.
    pub mix_fraction: f64,
    /// A blob larger than this times the predicted area is split at its narrow necks
    /// (see `split_radius`), >= 1. Default 1.25.
    pub split_ratio: f64,
    /// The split opens the blob by this fraction of the target's disc-equivalent
    /// radius, cutting off parts thinner than twice that (a touching ring or bar of the
    /// target's colour), then grows the part over the prediction back; re-acquisition
    /// opens the whole segmentation by the same radius before comparing shapes.
    /// Default 0.3 (0.2 kept a bar a fifth of the target's width; chosen on seeds 10-19
    /// of the clutter experiment).
    pub split_radius: f64,
    /// While lost, a blob is a candidate target when its area is within this ratio of
    /// the last area (smaller over larger), in (0, 1]. Default 0.3.
    pub reacquire_area_ratio: f64,
    /// The snake's resistance to changing shape from one frame to the next: the affine
    /// fit's linear part is drawn towards the prediction's with this weight, relative
    /// to a whole contour's worth of edge points (a ridge penalty; the translation is
    /// free). Keeps a touching same-coloured object from stretching the contour in one
    /// frame. >= 0. Default 0.5.
    pub stiffness: f64,
    /// Snake fit iterations, >= 1. Default 6.
    pub snake_iterations: usize,
    /// Radius of the opening and closing that clean `S(n)`, pixels. Default 1.
    pub morphology_radius: u8,
    /// Refine the best sample's contour on the image edges (seed 000 "contour
    /// updating"). Default true.
    pub refine: bool,
    /// The refined contour replaces the best sample's only when at least this fraction
    /// of its points lie on the masked image edges: where the target's grey level
    /// matches the background, `grad I` has no edge and the sample's contour is kept.
    /// Default 0.5.
    pub refine_min_support: f64,
    /// After the refinement, contour points outside the best sample's blob move back
    /// to its nearest cell along their normal. Default true.
    pub pull_inside: bool,
    /// Dilation radius of `grad S` masking the image edges in the refinement. Default 2.
    pub edge_dilation: u8,
    /// Canny thresholds (low, high) for the image edges `grad I`. Default (20, 50).
    pub canny: [f32; 2],
    /// The target's size on each sample's grid: a target whose disc-equivalent
    /// diameter is `d` pixels is segmented on every `floor(d / sample_cells)`-th pixel
    /// (at least every pixel). Bounds a sample's cost whatever the target's size; the
    /// refined contour is fitted on every pixel. >= 4. Default 24.
    pub sample_cells: f64,
    /// Window margin around the predicted contour, as a fraction of its size (plus the
    /// edge search). Default 0.1.
    pub roi_margin: f64,
    /// Most reference colours kept in the cloud that samples warp. Default 512.
    pub cloud_points: usize,
    /// The target is lost when the best sample's weight is below this. Default 0.05.
    pub lost_below: f64,
    /// The target is also lost when the refined contour and the best sample's blob
    /// overlap (intersection over union, on the sampling grid) less than this: the
    /// snake kept a shape the segmentation no longer supports. 0 never. Default 0.5.
    pub min_blob_overlap: f64,
    /// Seed of the sampler.
    pub seed: u64,
    /// Particle-filter settings. The default chunk of 16 samples gives several chunks
    /// to the thread pool for the default 100 samples, each costing a segmentation.
    pub filter: FilterParams,
}

impl Default for ColorShapeParams {
    fn default() -> Self {
        Self {
            color_space: ColorSpace::Opponent,
            bins: [16, 16, 16],
            n_samples: 100,
            dynamics: ColourDynamics::default(),
            sigma: 0.3,
            mu: [1.0, 1.0, 0.5],
            area_momentum: 0.5,
            hole_penalty: 0.25,
            contour_points: 48,
            search: 12,
            min_search: 2,
            edge_tolerance: 1.5,
            deform: 4,
            deform_passes: 2,
            background_ring: 0.5,
            velocity_gain: 0.5,
            reacquire_area_ratio: 0.3,
            mix_fraction: 0.1,
            split_ratio: 1.25,
            split_radius: 0.3,
            stiffness: 0.5,
            snake_iterations: 6,
            morphology_radius: 1,
            refine: true,
            refine_min_support: 0.5,
            pull_inside: true,
            edge_dilation: 2,
            canny: [20.0, 50.0],
            sample_cells: 24.0,
            roi_margin: 0.1,
            cloud_points: 512,
            lost_below: 0.05,
            min_blob_overlap: 0.5,
            seed: 0,
            filter: FilterParams {
                chunk_size: 16,
                ..FilterParams::default()
            },
        }
    }
}

impl ColorShapeParams {
    /// Checks every field.
    ///
    /// # Errors
    /// [`TrackingError::InvalidParameter`] naming the first bad field.
    pub fn validate(&self) -> Result<()> {
        colour_coords(self.color_space, [0, 0, 0])?;
        crate::colour::check_bins(self.bins)?;
        self.dynamics.validate()?;
        // Every size and count a caller sets has an upper bound, checked before
        // anything is allocated: contour_points = 10^9 aborted the process, and 10^9
        // snake iterations or smoothing passes never returned (issue 38).
        count_in("n_samples", self.n_samples, 1, MAX_PARTICLES)?;
        count_in("contour_points", self.contour_points, 8, MAX_CONTOUR_POINTS)?;
        count_in("search", self.search, 1, MAX_SEARCH)?;
        count_in("min_search", self.min_search, 1, MAX_SEARCH)?;
        count_in("deform", self.deform, 0, MAX_SEARCH)?;
        count_in("deform_passes", self.deform_passes, 0, MAX_PASSES)?;
        count_in("snake_iterations", self.snake_iterations, 1, MAX_PASSES)?;
        count_in("cloud_points", self.cloud_points, 1, MAX_CLOUD_POINTS)?;
        ensure_non_negative("edge_tolerance", self.edge_tolerance)?;
        ensure_non_negative("stiffness", self.stiffness)?;
        ensure_non_negative("background_ring", self.background_ring)?;
        ensure_in_range("mix_fraction", self.mix_fraction, 0.0, 0.99)?;
        ensure_in_range("split_ratio", self.split_ratio, 1.0, 1e9)?;
        ensure_in_range("split_radius", self.split_radius, 0.0, 1.0)?;
        ensure_in_range("velocity_gain", self.velocity_gain, 0.0, 1.0)?;
        ensure_in_range("reacquire_area_ratio", self.reacquire_area_ratio, 1e-6, 1.0)?;
        ensure_positive("sigma", self.sigma)?;
        for m in self.mu {
            ensure_non_negative("mu", m)?;
        }
        if self.mu.iter().sum::<f64>() <= 0.0 {
            return Err(TrackingError::InvalidParameter {
                name: "mu",
                reason: "at least one weight must be > 0".into(),
            });
        }
        ensure_in_range("area_momentum", self.area_momentum, 0.0, 1.0)?;
        ensure_non_negative("hole_penalty", self.hole_penalty)?;
        ensure_non_negative("roi_margin", self.roi_margin)?;
        ensure_in_range("sample_cells", self.sample_cells, 4.0, 1e6)?;
        ensure_in_range("lost_below", self.lost_below, 0.0, 1.0)?;
        ensure_in_range("min_blob_overlap", self.min_blob_overlap, 0.0, 1.0)?;
        ensure_in_range("refine_min_support", self.refine_min_support, 0.0, 1.0)?;
        let [lo, hi] = self.canny.map(f64::from);
        ensure_non_negative("canny", lo)?;
        if !(hi.is_finite() && hi >= lo) {
            return Err(TrackingError::InvalidParameter {
                name: "canny",
                reason: format!("need 0 <= low <= high, got ({lo}, {hi})"),
            });
        }
        Ok(())
    }

    /// Floor on the principal spreads: half of the finest bin, so a uniform target's cloud
    /// still covers its bin.
    pub(crate) fn min_spread(&self) -> f64 {
        0.5 / *self.bins.iter().max().unwrap_or(&1) as f64
    }
}

/// Most snake points: one per pixel of the outline of a target filling a 4K frame.
const MAX_CONTOUR_POINTS: usize = 1 << 14;
/// Widest edge search and deformation, pixels (the window margin follows them).
const MAX_SEARCH: usize = 64;
/// Most snake iterations and smoothing passes: the fit converges in a handful.
const MAX_PASSES: usize = 1_000;
/// Most reference colours in the cloud every sample warps.
const MAX_CLOUD_POINTS: usize = 1 << 20;

/// Through rperc-core's one size check (a snake point, a cloud colour: a few dozen
/// bytes each), so every count is refused the same way.
fn count_in(name: &'static str, value: usize, min: usize, max: usize) -> Result<()> {
    Ok(ensure_count(name, value, min, max, 64)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_validate_and_bad_fields_are_named() {
        ColorShapeParams::default().validate().unwrap();
        let cases: [(&str, ColorShapeParams); 4] = [
            (
                "n_samples",
                ColorShapeParams {
                    n_samples: 0,
                    ..Default::default()
                },
            ),
            (
                "mu",
                ColorShapeParams {
                    mu: [0.0; 3],
                    ..Default::default()
                },
            ),
            (
                "color_space",
                ColorShapeParams {
                    color_space: ColorSpace::Hsv,
                    ..Default::default()
                },
            ),
            (
                "canny",
                ColorShapeParams {
                    canny: [5.0, 1.0],
                    ..Default::default()
                },
            ),
        ];
        for (name, p) in cases {
            let e = p.validate().unwrap_err();
            assert_eq!(e.parameter(), Some(name), "{e}");
        }
    }
}
