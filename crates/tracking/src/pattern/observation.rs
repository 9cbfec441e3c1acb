//! The observation model of section 3.3 (eqs. 5-6): the likelihood of a state
//! `X = (x, y, theta, s)` from the inter-correlation of each model point's stored and
//! observed grey-level vectors, with occlusion and scale space handling.

use super::correlation::{deviation, energy, inter_correlation_with_energy};
use super::model::{PatternModel, sample_along};
use rayon::prelude::*;
use std::sync::Arc;

use crate::condensation::Likelihood;
use crate::error::Result;
use nalgebra::SVector;
use rperc_core::image::GrayImage;

/// A per-frame stack of Gaussian-blurred copies of the frame, one per scale level
/// (section 3.3, "scale changing effects"): level `k` of scale `s_k` is blurred by
/// `blur_sigma * s_k`, so that a pattern seen `s_k` times larger, once rescaled, has
/// the blur its model was learnt with. Buffers are reused from frame to frame.
///
/// A stack may cover only a window of the frame and the levels a range of scales
/// need ([`Self::build_window`]): the particles of one frame only look there, and the
/// blur of a whole 640 x 480 frame at every level costs far more than the particles.
#[derive(Debug, Clone, Default)]
pub struct ScaleSpace {
    scales: Vec<f64>,
    levels: Vec<Level>,
    origin: [f64; 2],
    crop: GrayImage,
    kernels: Vec<(f64, Arc<[f32]>)>,
}

/// One level of a [`ScaleSpace`] with its own work buffers, so that levels blur in
/// parallel.
#[derive(Debug, Clone, Default)]
struct Level {
    image: GrayImage,
    kernel: Arc<[f32]>,
    blurred: GrayImage,
    scratch: GrayImage,
}

/// Below this many pixel-taps (crop pixels times kernel taps over all levels) the
/// levels blur serially: a rayon task would cost more than it saves.
const PARALLEL_BLUR_WORK: usize = 200_000;

/// The Gaussian kernel of `sigma` from `cache`, computed on first use.
fn kernel(cache: &mut Vec<(f64, Arc<[f32]>)>, sigma: f64) -> Arc<[f32]> {
    if let Some((_, k)) = cache.iter().find(|(s, _)| *s == sigma) {
        return k.clone();
    }
    let k: Arc<[f32]> = rperc_core::image::gaussian_kernel(sigma).into();
    cache.push((sigma, k.clone()));
    k
}

/// Index of the entry of `scales` nearest to `s` (the first on ties).
fn nearest(scales: &[f64], s: f64) -> usize {
    scales
        .iter()
        .enumerate()
        .min_by(|a, b| (a.1 - s).abs().total_cmp(&(b.1 - s).abs()))
        .map_or(0, |(k, _)| k)
}

impl ScaleSpace {
    /// An empty stack; [`Self::build`] fills it.
    pub fn new() -> Self {
        Self::default()
    }

    /// Blurs the whole `frame` once per level of `config.scale_levels` (never per
    /// particle).
    pub fn build(&mut self, frame: &GrayImage, model: &PatternModel) -> Result<()> {
        let window = [0, 0, frame.width, frame.height];
        self.build_window(frame, model, window, [f64::NEG_INFINITY, f64::INFINITY])
    }

    /// Blurs only the window `[x0, y0, x1, y1)` of `frame`, at the levels nearest to
    /// the scales of `span = [s_lo, s_hi]` and those between. Inside the window each
    /// level equals the whole frame's blur exactly: the blur runs on the window grown
    /// by the kernel's radius (borders reflected only at the frame's own edges).
    /// Outside it, samples are missing and the points there count as occluded.
    pub fn build_window(
        &mut self,
        frame: &GrayImage,
        model: &PatternModel,
        window: [usize; 4],
        span: [f64; 2],
    ) -> Result<()> {
        let size = [frame.width, frame.height];
        let copy = |grown: [usize; 4], crop: &mut GrayImage| copy_window(frame, grown, crop);
        self.build_window_with(size, copy, model, window, span)
    }

    /// [`Self::build_window`] on a frame of `size = [width, height]` that `crop` reads
    /// on demand: `crop(window, out)` fills `out` with the frame's grey levels inside
    /// `window = [x0, y0, x1, y1)` (a tracker converts only that part of an 8-bit frame,
    /// not all of it).
    pub fn build_window_with(
        &mut self,
        size: [usize; 2],
        crop: impl FnOnce([usize; 4], &mut GrayImage),
        model: &PatternModel,
        window: [usize; 4],
        span: [f64; 2],
    ) -> Result<()> {
        let config = &model.config;
        let all = &config.scale_levels;
        // Clamped first: infinite spans (the whole stack) would tie every level.
        let (first, last) = (all[0], all[all.len() - 1]);
        let lo = nearest(all, span[0].clamp(first, last));
        let hi = nearest(all, span[1].clamp(first, last));
        self.scales.clear();
        self.scales.extend_from_slice(&all[lo..=hi.max(lo)]);
        self.levels.resize_with(self.scales.len(), Level::default);
        for (level, &s) in self.levels.iter_mut().zip(&self.scales) {
            level.kernel = kernel(&mut self.kernels, config.blur_sigma * s);
        }
        let [width, height] = size;
        let [x0, y0] = [window[0].min(width), window[1].min(height)];
        let [x1, y1] = [window[2].clamp(x0, width), window[3].clamp(y0, height)];
        self.origin = [x0 as f64, y0 as f64];
        // One crop, grown by the widest kernel's radius: every level blurs all of it
        // and keeps the window, which lies at least its own radius inside the crop
        // wherever the crop does not stop at the frame's edge.
        let r = self
            .levels
            .iter()
            .map(|l| l.kernel.len() / 2)
            .max()
            .unwrap_or(0);
        let grown = [
            x0.saturating_sub(r),
            y0.saturating_sub(r),
            (x1 + r).min(width),
            (y1 + r).min(height),
        ];
        crop(grown, &mut self.crop);
        let inner = [x0 - grown[0], y0 - grown[1], x1 - grown[0], y1 - grown[1]];
        let crop = &self.crop;
        let blur = |level: &mut Level| {
            crop.convolve_separable(&level.kernel, &mut level.scratch, &mut level.blurred);
            copy_window(&level.blurred, inner, &mut level.image);
        };
        let taps: usize = self.levels.iter().map(|l| l.kernel.len()).sum();
        if self.levels.len() > 1 && crop.data.len() * taps >= PARALLEL_BLUR_WORK {
            self.levels.par_iter_mut().for_each(blur);
        } else {
            self.levels.iter_mut().for_each(blur);
        }
        Ok(())
    }

    /// Pixel coordinates of the levels' top-left pixel in the frame.
    pub fn origin(&self) -> [f64; 2] {
        self.origin
    }

    /// The level nearest to scale `s` (the first one for `s <= 1`).
    pub fn level(&self, s: f64) -> &GrayImage {
        &self.levels[nearest(&self.scales, s)].image
    }

    /// Number of levels.
    pub fn len(&self) -> usize {
        self.levels.len()
    }

    /// Whether [`Self::build`] has not run yet.
    pub fn is_empty(&self) -> bool {
        self.levels.is_empty()
    }
}

/// The likelihood of one state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Observation {
    /// `log p(Z | X)`, eq. 6 in the log domain (up to a constant).
    pub log_likelihood: f64,
    /// The occlusion fraction: model points whose deviation exceeds the occlusion
    /// threshold (or whose vector leaves the frame), over all model points.
    pub occluded_fraction: f64,
}

/// Per-thread buffers of [`PatternLikelihood`]: one observed vector and the point
/// deviations, so that no particle allocates.
#[derive(Debug, Clone, Default)]
pub struct PatternScratch {
    observed: Vec<f32>,
    deviations: Vec<f64>,
}

/// The observation model of one frame: a model and the frame's scale space.
#[derive(Debug, Clone)]
pub struct PatternLikelihood<'a> {
    model: &'a PatternModel,
    space: &'a ScaleSpace,
    points: Vec<PointGeometry>,
}

/// What a particle needs of a model point besides its vector, computed once per frame
/// (not per particle): its pixel offset, the unit vector of its gradient direction, and
/// its vector's energy.
#[derive(Debug, Clone, Copy)]
struct PointGeometry {
    offset: [f64; 2],
    direction: [f64; 2],
    energy: f64,
}

/// Where model point offset `(dx, dy)` and direction `phi` land for state `x`: the
/// similarity `centre + s R(theta) (dx, dy)` with `R = [[c, s], [-s, c]]`, theta
/// counter-clockwise on screen (y down), as OpenCV's `getRotationMatrix2D`.
pub fn place(state: &SVector<f64, 4>, offset: [f64; 2], phi: f64) -> ([f64; 2], f64) {
    let (s, c) = state[2].sin_cos();
    let scale = state[3];
    let x = state[0] + scale * (c * offset[0] + s * offset[1]);
    let y = state[1] + scale * (-s * offset[0] + c * offset[1]);
    ([x, y], phi - state[2])
}

impl<'a> PatternLikelihood<'a> {
    /// The observation model of `model` in the frame whose scale space is `space`.
    pub fn new(model: &'a PatternModel, space: &'a ScaleSpace) -> Self {
        let points = (0..model.points.len())
            .map(|j| {
                let point = &model.points[j];
                let (s, c) = point.phi.sin_cos();
                PointGeometry {
                    offset: model.offset(j),
                    direction: [c, s],
                    energy: energy(&point.vector),
                }
            })
            .collect();
        Self {
            model,
            space,
            points,
        }
    }

    /// The likelihood and occlusion fraction of `state` (eqs. 5-6).
    ///
    /// Each model point gives a deviation `lambda = (1 - C) / |W|` (samples) from its
    /// inter-correlation `C`, and the log-Gaussian term `-lambda^2 / (2 sigma^2)`.
    /// Occlusion: points with `lambda > occlusion_threshold` are left out, at most
    /// `floor(max_occluded_fraction * N_m)` of them, the worst first; beyond that the
    /// remaining ones count with their own term. A left-out point contributes the term
    /// of the threshold itself, `-T^2 / (2 sigma^2)`, rather than nothing: otherwise a
    /// state would gain likelihood by occluding points, and states with different
    /// numbers of occluded points could not be compared.
    pub fn observe(&self, state: &SVector<f64, 4>, scratch: &mut PatternScratch) -> Observation {
        let n = self.model.points.len();
        if self.space.is_empty()
            || n == 0
            || !state.iter().all(|v| v.is_finite())
            || state[3] <= 0.0
        {
            return Observation {
                log_likelihood: f64::NEG_INFINITY,
                occluded_fraction: 1.0,
            };
        }
        self.fill_deviations(state, scratch);
        let config = &self.model.config;
        let threshold = config.occlusion_threshold;
        let occluded = scratch
            .deviations
            .iter()
            .filter(|&&l| l > threshold)
            .count();
        let tolerated = ((config.max_occluded_fraction * n as f64).floor() as usize).min(occluded);
        // The `tolerated` largest deviations are left out: move them to the end.
        let d = &mut scratch.deviations;
        if tolerated > 0 {
            d.select_nth_unstable_by(n - tolerated, |a, b| a.total_cmp(b));
        }
        let inv = 1.0 / (2.0 * config.sigma * config.sigma);
        let kept: f64 = d[..n - tolerated].iter().map(|l| -l * l * inv).sum();
        let left_out = tolerated as f64 * (-threshold * threshold * inv);
        Observation {
            log_likelihood: kept + left_out,
            occluded_fraction: occluded as f64 / n as f64,
        }
    }

    /// The deviation of every model point for `state` into `scratch.deviations`
    /// (infinite when the observed vector leaves the frame).
    ///
    /// The similarity of [`place`] with `sin theta` and `cos theta` taken once per
    /// state: a point's position is `centre + s R (dx, dy)` and its direction `R (cos
    /// phi, sin phi)`, i.e. `phi - theta`, with `R = [[c, s], [-s, c]]`.
    fn fill_deviations(&self, state: &SVector<f64, 4>, scratch: &mut PatternScratch) {
        let config = &self.model.config;
        let image = self.space.level(state[3]);
        let origin = self.space.origin();
        let (sin, cos) = state[2].sin_cos();
        let scale = state[3];
        let centre = [state[0] - origin[0], state[1] - origin[1]];
        let step = config.delta * scale;
        scratch.observed.resize(config.n_samples, 0.0);
        scratch.deviations.clear();
        for (point, geometry) in self.model.points.iter().zip(&self.points) {
            let [dx, dy] = geometry.offset;
            let p = [
                centre[0] + scale * (cos * dx + sin * dy),
                centre[1] + scale * (-sin * dx + cos * dy),
            ];
            let [u, v] = geometry.direction;
            let direction = [cos * u + sin * v, -sin * u + cos * v];
            let lambda = if sample_along(image, p, direction, step, &mut scratch.observed) {
                let c = inter_correlation_with_energy(
                    &point.vector,
                    geometry.energy,
                    &scratch.observed,
                );
                deviation(c, point.slope)
            } else {
                f64::INFINITY
            };
            // A NaN grey level (a corrupt frame) makes the point occluded, not the sum NaN.
            scratch.deviations.push(if lambda.is_nan() {
                f64::INFINITY
            } else {
                lambda
            });
        }
    }
}

impl Likelihood<4> for PatternLikelihood<'_> {
    type Scratch = PatternScratch;

    fn new_scratch(&self) -> PatternScratch {
        PatternScratch {
            observed: Vec::with_capacity(self.model.config.n_samples),
            deviations: Vec::with_capacity(self.model.points.len()),
        }
    }

    fn log_likelihood(&self, state: &SVector<f64, 4>, scratch: &mut PatternScratch) -> f64 {
        self.observe(state, scratch).log_likelihood
    }
}

/// Copies the window `[x0, y0, x1, y1)` of `image` into `out` (resized).
fn copy_window(image: &GrayImage, window: [usize; 4], out: &mut GrayImage) {
    let [x0, y0, x1, y1] = window;
    out.width = x1 - x0;
    out.height = y1 - y0;
    out.data.clear();
    for y in y0..y1 {
        out.data
            .extend_from_slice(&image.data[y * image.width + x0..y * image.width + x1]);
    }
}
