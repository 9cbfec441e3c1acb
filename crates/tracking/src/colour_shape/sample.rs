//! One sample's measurement (seed 000 section 3.3, "measure and weight"): its histogram
//! `H(n)`, the segmentation `S(n)` it gives, the target blob, the affine snake fitted to
//! the blob's boundary `grad S(n)`, and the three terms of the weight.

use image::GrayImage;

use super::params::ColorShapeParams;
use super::segment::{
    Blob, FloodScratch, FrameSides, Grid, LineMasks, Roi, ShapeMemory, boundary, clean,
    euler_number_in, reacquire, reconstruct, segment, split_at_necks,
};
use super::snake::{Affine, SnakeFit, SnakeParams, SnakeScratch, fit_snake, polygon_area};
use super::state::{ColourDistribution, ColourWarp, STATE_DIM, State, fill_lut};
use crate::condensation::Likelihood;

/// The three measures of seed 000 section 3.3, each in [0, 1] (1 is best).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampleTerms {
    /// Fraction of the fitted affine snake lying on `grad S(n)`.
    pub affine: f64,
    /// `1 - |A~ - A| / max(A~, A)`.
    pub area: f64,
    /// `clamp(1 - k (1 - E), 0, 1)`, `E` the blob's Euler number.
    pub quality: f64,
    /// The snake fit.
    pub fit: SnakeFit,
}

impl SampleTerms {
    /// `rho = mu1 (1 - Phi_affine) + mu2 (1 - Phi_area) + mu3 (1 - Phi_quality)`.
    pub fn rho(&self, mu: [f64; 3]) -> f64 {
        mu[0] * (1.0 - self.affine) + mu[1] * (1.0 - self.area) + mu[2] * (1.0 - self.quality)
    }

    /// The weight `exp(-rho^2 / 2 sigma^2)` in the log domain.
    pub fn log_weight(&self, mu: [f64; 3], sigma: f64) -> f64 {
        -self.rho(mu).powi(2) / (2.0 * sigma * sigma)
    }
}

/// Buffers of one sample's evaluation, reused across samples and frames: nothing is
/// allocated per sample while tracking (re-acquisition labels components with
/// imageproc, which allocates its label image).
#[derive(Debug, Clone, Default)]
pub struct SampleScratch {
    lut: Vec<u8>,
    pub(crate) seg: GrayImage,
    pub(crate) blob: GrayImage,
    pub(crate) edges: GrayImage,
    flood: FloodScratch,
    stats: Vec<[f64; 6]>,
    padded: Vec<u8>,
    split: [GrayImage; 2],
    pub(crate) snake: SnakeScratch,
}

/// How the blob of a sample is chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BlobSearch {
    /// Tracking: the segmentation reconstructed from the predicted contour, within it
    /// dilated by the snake's reach.
    Track,
    /// Re-acquiring a lost target: the component whose area best matches the last
    /// one, anywhere in the (widened) window.
    Reacquire,
}

/// What every sample of one frame shares.
pub struct FrameContext<'a> {
    pub params: &'a ColorShapeParams,
    pub reference: &'a ColourDistribution,
    pub cloud: &'a [[f64; 3]],
    /// Colour bin of every grid cell.
    pub bins: &'a [u16],
    /// The window, frame pixels.
    pub roi: Roi,
    /// The sampling grid over `roi`: every mask below is a grid image.
    pub grid: Grid,
    pub sides: FrameSides,
    /// The predicted contour, filled (window mask).
    pub prior: &'a GrayImage,
    /// `prior` dilated by the snake's reach (window mask).
    pub region: &'a GrayImage,
    /// The predicted contour `r_{t-1}` (moved by the image velocity), frame pixels.
    pub predicted: &'a [[f64; 2]],
    pub predicted_centroid: [f64; 2],
    pub predicted_area: f64,
    /// The target's usual principal spreads, frame pixels (re-acquisition's shape).
    pub spreads: [f64; 2],
    pub snake: SnakeParams,
    pub search: BlobSearch,
    /// The structuring element of the clean-up.
    pub morphology: &'a LineMasks,
}

impl FrameContext<'_> {
    /// `H(n)`, `S(n)`, the blob, `grad S(n)`, the affine snake and the three terms;
    /// `None` when the segmentation holds no blob where the target can be.
    pub fn evaluate(&self, state: &State, s: &mut SampleScratch) -> Option<SampleTerms> {
        let p = self.params;
        let warp = ColourWarp::new(self.reference, state, p.min_spread());
        fill_lut(&warp, self.cloud, p.bins, &mut s.lut);
        segment(self.bins, &s.lut, self.grid, &mut s.seg);
        clean(&mut s.seg, self.morphology);
        let blob = self.blob(s);
        if blob.area == 0 {
            return None;
        }
        let holes = (1 - euler_number_in(&s.blob, blob.bbox, &mut s.padded)).max(0) as f64;
        let quality = (1.0 - p.hole_penalty * holes).clamp(0.0, 1.0);
        boundary(&s.blob, &s.seg, self.sides, blob.bbox, &mut s.edges);
        let [cx, cy] = self.grid.to_frame(blob.centroid);
        let [px, py] = self.predicted_centroid;
        let init = Affine::translation(cx - px, cy - py);
        let (grid, edges) = (self.grid, &s.edges);
        let fit = fit_snake(
            self.predicted,
            init,
            &self.snake,
            |x, y| grid.at(edges, x, y),
            &mut s.snake,
        );
        let a = polygon_area(s.snake.contour());
        let area = 1.0 - (self.predicted_area - a).abs() / self.predicted_area.max(a).max(1e-9);
        Some(SampleTerms {
            affine: fit.on_edge,
            area,
            quality,
            fit,
        })
    }

    fn blob(&self, s: &mut SampleScratch) -> Blob {
        let stride = self.grid.stride as f64;
        let cells = self.predicted_area / stride.powi(2);
        // The split's opening: a fraction of the target's disc-equivalent radius, cells.
        let radius = (self.params.split_radius * (cells / std::f64::consts::PI).sqrt())
            .round()
            .clamp(1.0, 255.0) as u8;
        match self.search {
            BlobSearch::Track => {
                let blob = reconstruct(&s.seg, self.prior, self.region, &mut s.blob, &mut s.flood);
                if blob.area as f64 > self.params.split_ratio * cells {
                    split_at_necks(&mut s.blob, self.prior, radius, &mut s.split, &mut s.flood)
                        .unwrap_or(blob)
                } else {
                    blob
                }
            }
            BlobSearch::Reacquire => {
                let target = ShapeMemory {
                    area: cells,
                    spreads: self.spreads.map(|s| s / stride),
                    near: self.grid.to_grid(self.predicted_centroid),
                };
                let min_ratio = self.params.reacquire_area_ratio;
                reacquire(
                    &s.seg,
                    &target,
                    min_ratio,
                    radius,
                    &mut s.blob,
                    &mut s.split,
                    &mut s.stats,
                )
            }
        }
    }
}

impl Likelihood<STATE_DIM> for FrameContext<'_> {
    type Scratch = SampleScratch;

    fn new_scratch(&self) -> SampleScratch {
        SampleScratch::default()
    }

    fn log_likelihood(&self, state: &State, scratch: &mut SampleScratch) -> f64 {
        match self.evaluate(state, scratch) {
            Some(t) => t.log_weight(self.params.mu, self.params.sigma),
            None => f64::NEG_INFINITY,
        }
    }
}

/// Whether the window mask is set at frame pixel `(x, y)`.
#[inline]
pub fn on(mask: &GrayImage, roi: Roi, x: i64, y: i64) -> bool {
    let (u, v) = (x - roi.x0 as i64, y - roi.y0 as i64);
    u >= 0
        && v >= 0
        && (u as usize) < roi.width
        && (v as usize) < roi.height
        && mask.as_raw()[v as usize * roi.width + u as usize] != 0
}
