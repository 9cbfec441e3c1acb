//! The coarse layer of the pattern tracker: many predicted states screened on a
//! coarse pyramid level before the particles are weighed on the frame itself.
//!
//! Why: eq. 6 on the frame is sharp (a profile point `sigma` = 1 sample = 1 px off
//! already costs a factor `e^-0.5`), so a state a few pixels or degrees from the
//! target scores like one far away, and the particles must fall inside that basin
//! by chance. At steps of 3 sigma in all four parameters at once, 200 particles
//! drawn from the random walk left none there on 8 of 10 sequences (1000 particles:
//! none of 10 lost), and the refinement from their mean settled in a wrong pose. On
//! a level `factor` times coarser the same profiles span `factor` times more pixels,
//! so the basin is as many times wider, and a state costs a fraction of a fine one
//! (few points, small images): the layer screens many predicted states there and
//! hands the best ones to the fine layer as its particles (annealed layers of
//! CONDENSATION, two of them).

use nalgebra::SVector;
use rperc_core::image::GrayImage;

use super::correlation::{autocorrelation_curvature, autocorrelation_slope, remove_mean};
use super::frame::{PatternFrame, downsample};
use super::model::{ModelPoint, PatternConfig, PatternModel, sample_vector};
use super::observation::{PatternLikelihood, PatternScratch, PointTable, ScaleSpace};
use super::search::{NEWTON_TOLERANCE, Newton, frame_window};
use crate::error::Result;

/// A coarse model needs this many points to locate anything; with fewer (a region
/// with hardly any texture at the coarse level) the tracker goes without the layer.
const MIN_COARSE_POINTS: usize = 8;

/// The coarse layer stops weighing a state once its log-likelihood, extrapolated
/// from part of its points, falls this far below the best one met before it (see
/// [`PatternLikelihood::with_early_exit`]): it only ranks states, and one that far
/// below (a factor `e^-10`) is not among those kept. 10 rather than the filter's 30
/// is faster at the same accuracy (figures: `docs/decisions.md`).
const COARSE_MARGIN: f64 = 10.0;

/// Most Gauss-Newton steps of [`CoarseLayer::refine`] per state.
const COARSE_NEWTON_STEPS: usize = 6;

/// The pattern's window must span this many coarse pixels each way: its profiles
/// ([`COARSE_SAMPLES`] long) must fit inside it across most of it. A smaller pattern
/// (under 80 frame pixels at the default factor) goes without the layer.
const MIN_COARSE_SIDE: f64 = 16.0;

/// Samples of a coarse profile (a coarse pixel apart, `factor` frame pixels): the
/// profile must lie inside the pattern's window, and the fine model's 12 would span
/// 60 frame pixels at the default factor, more than most patterns.
const COARSE_SAMPLES: usize = 7;

/// The pattern's model on a level `factor` times coarser than the frame (each pixel
/// the mean of a `factor x factor` block) and the buffers of its per-frame scale
/// space.
#[derive(Debug, Clone)]
pub(crate) struct CoarseLayer {
    factor: usize,
    model: PatternModel,
    table: PointTable,
    /// The table as learnt, before any projective rest ([`Self::set_rest`]).
    base_table: PointTable,
    offsets: Vec<[f64; 2]>,
    space: ScaleSpace,
    scratch: PatternScratch,
    /// The frame's grey levels under the coarse window (reused).
    fine: GrayImage,
    /// `(log-likelihood, index)` of the screened states (reused).
    scored: Vec<(f64, usize)>,
    /// The screened states in coarse coordinates, and their scales (reused).
    states: Vec<SVector<f64, 4>>,
    scales: Vec<f64>,
}

impl CoarseLayer {
    /// The coarse model of `fine`, learnt from `image` (the frame it was learnt
    /// from): the fine model's points, taken at most `points` of them evenly, with
    /// their profiles sampled on the coarse level (same direction, same number of
    /// samples, each a coarse pixel apart); textureless ones are dropped as the fine
    /// model drops them. `None` when fewer than [`MIN_COARSE_POINTS`] are left, or
    /// the window is under [`MIN_COARSE_SIDE`] coarse pixels.
    pub(crate) fn new(
        image: &GrayImage,
        fine: &PatternModel,
        factor: usize,
        points: usize,
    ) -> Option<Self> {
        let side = fine.size[0].min(fine.size[1]) / factor as f64;
        if side < MIN_COARSE_SIDE {
            return None;
        }
        let config = &PatternConfig {
            n_samples: COARSE_SAMPLES.min(fine.config.n_samples),
            ..fine.config.clone()
        };
        let mut coarse = GrayImage::default();
        downsample(image, factor, &mut coarse);
        let (mut scratch, mut blurred) = (GrayImage::default(), GrayImage::default());
        coarse
            .gaussian_blur(config.blur_sigma, &mut scratch, &mut blurred)
            .ok()?;
        let f = factor as f64;
        let centre = fine.centre.map(|c| to_coarse(c, f));
        let half = [0.5 * fine.size[0] / f, 0.5 * fine.size[1] / f];
        let mut kept: Vec<ModelPoint> = (0..fine.points.len())
            .filter_map(|j| {
                let o = fine.offset(j);
                let p = [centre[0] + o[0] / f, centre[1] + o[1] / f];
                let point = &fine.points[j];
                // Outside the window lies the background, which moves against the
                // pattern: a profile reaching there would not match it next frame.
                let reach = 0.5 * (config.n_samples as f64 - 1.0) * config.delta;
                let (sin, cos) = point.phi.sin_cos();
                let inside = |d: usize, v: f64| (p[d] + v - centre[d]).abs() <= half[d];
                let within = [1.0, -1.0]
                    .iter()
                    .all(|e| inside(0, e * reach * cos) && inside(1, e * reach * sin));
                within
                    .then(|| coarse_point(&blurred, p, point, config))
                    .flatten()
            })
            .collect();
        if kept.len() < MIN_COARSE_POINTS {
            return None;
        }
        let n = kept.len();
        if n > points {
            kept = (0..points).map(|k| kept[k * n / points].clone()).collect();
        }
        let model = PatternModel {
            centre,
            size: fine.size.map(|s| s / f),
            points: kept,
            config: config.clone(),
        };
        let table = PointTable::new(&model);
        Some(Self {
            factor,
            base_table: table.clone(),
            table,
            offsets: (0..model.points.len()).map(|j| model.offset(j)).collect(),
            model,
            space: ScaleSpace::new(),
            scratch: PatternScratch::default(),
            fine: GrayImage::default(),
            scored: Vec::new(),
            states: Vec::new(),
            scales: Vec::new(),
        })
    }

    /// Sees the model through the projective rest `rest` of the homography mode (a
    /// map of frame-pixel offsets, see [`PointTable::warped`]), conjugated to this
    /// level's pixels (`D^-1 rest D`, `D` the scaling by `factor`). `false`, nothing
    /// changed, when `rest` sends a point to infinity.
    pub(crate) fn set_rest(&mut self, rest: &nalgebra::Matrix3<f64>) -> bool {
        let f = self.factor as f64;
        let mut coarse = *rest;
        coarse[(0, 2)] /= f;
        coarse[(1, 2)] /= f;
        coarse[(2, 0)] *= f;
        coarse[(2, 1)] *= f;
        let config = &self.model.config;
        let half = 0.5 * (config.n_samples as f64 - 1.0) * config.delta;
        let Some(table) = self.base_table.warped(&coarse, half) else {
            return false;
        };
        self.offsets.clear();
        self.offsets.extend(table.offsets());
        self.table = table;
        true
    }

    /// The `keep` states of `hypotheses` (frame coordinates) most likely on the
    /// coarse level of `frame`, best first, into `out` (cleared). `last` is the last
    /// estimate: the states far below it are only bounded (the early exit of
    /// [`PatternLikelihood::with_early_exit`]), which cannot change which states
    /// are best.
    pub(crate) fn screen(
        &mut self,
        frame: PatternFrame<'_>,
        hypotheses: &[SVector<f64, 4>],
        last: &SVector<f64, 4>,
        [keep, refined]: [usize; 2],
        sigma: &SVector<f64, 4>,
        out: &mut Vec<SVector<f64, 4>>,
    ) -> Result<()> {
        out.clear();
        let f = self.factor as f64;
        let last = coarse_state(last, f);
        self.states.clear();
        self.states
            .extend(hypotheses.iter().map(|h| coarse_state(h, f)));
        self.build_space(frame, &last)?;
        let likelihood = PatternLikelihood::with_table(&self.model, &self.space, &self.table);
        let reference = likelihood.observe(&last, &mut self.scratch).log_likelihood;
        let likelihood = likelihood
            .with_early_exit(COARSE_MARGIN)
            .with_reference(reference);
        use crate::condensation::Likelihood;
        self.scored.clear();
        for (i, s) in self.states.iter().enumerate() {
            let ll = likelihood.log_likelihood(s, &mut self.scratch);
            // NaN (a corrupt frame) ranks last rather than poisoning the order.
            self.scored
                .push((if ll.is_nan() { f64::NEG_INFINITY } else { ll }, i));
        }
        let keep = keep.min(self.scored.len());
        if keep < self.scored.len() && keep > 0 {
            self.scored
                .select_nth_unstable_by(keep - 1, |a, b| b.0.total_cmp(&a.0));
        }
        self.scored.truncate(keep);
        self.scored.sort_unstable_by(|a, b| b.0.total_cmp(&a.0));
        out.extend(self.scored.iter().map(|&(_, i)| hypotheses[i]));
        self.refine(out, refined, sigma);
        Ok(())
    }

    /// Gauss-Newton on the coarse level from the first `count` states of `kept`
    /// (frame coordinates), each replaced by where it converged: the level's wide
    /// basin brings a state several pixels off to within a pixel or two of the peak,
    /// where the fine layer's own basin takes over, so that fewer screened states
    /// need to fall near the target. Each search stays within `2 sigma` (the random
    /// walk's) of its start.
    fn refine(&mut self, kept: &mut [SVector<f64, 4>], count: usize, sigma: &SVector<f64, 4>) {
        let f = self.factor as f64;
        let likelihood = PatternLikelihood::with_table(&self.model, &self.space, &self.table);
        let mut reach = sigma * 2.0;
        reach[0] /= f;
        reach[1] /= f;
        let tolerance = reach * (0.5 * NEWTON_TOLERANCE);
        for state in kept.iter_mut().take(count) {
            let mut at = coarse_state(state, f);
            let mut best = likelihood.observe(&at, &mut self.scratch);
            let mut search = Newton {
                likelihood: &likelihood,
                scratch: &mut self.scratch,
                bounds: (at - reach, at + reach),
                tolerance,
            };
            for _ in 0..COARSE_NEWTON_STEPS {
                if !search.step(&mut at, &mut best) {
                    break;
                }
            }
            *state = SVector::from([from_coarse(at[0], f), from_coarse(at[1], f), at[2], at[3]]);
        }
    }

    /// The coarse scale space of `frame` over the window the screened states (and
    /// `last`) read, at the levels their scales fall on; only that window of the
    /// frame is converted and averaged.
    fn build_space(&mut self, frame: PatternFrame<'_>, last: &SVector<f64, 4>) -> Result<()> {
        let (lo, hi) = extent(self.states.iter().chain([last]));
        let factor = self.factor;
        let (width, height) = frame.size();
        let size = [width / factor, height / factor];
        let fine = &mut self.fine;
        let crop = |grown: [usize; 4], out: &mut GrayImage| {
            let window = grown.map(|v| v * factor);
            frame.window_to_blocks(window, factor, fine, out);
        };
        self.scales.clear();
        self.scales.extend(self.states.iter().map(|s| s[3]));
        self.scales.push(last[3]);
        let config = &self.model.config;
        let profile = 0.5 * config.n_samples as f64 * config.delta;
        let offsets = &self.offsets;
        let window = |cell: [f64; 2]| frame_window(offsets, profile, size, (lo, hi), cell);
        let needed = Some(&self.scales[..]);
        self.space
            .build_windows_for(size, crop, &self.model, window, [lo[3], hi[3]], needed)
    }
}

/// A frame state `(x, y, theta, s)` on a level `f` times coarser.
fn coarse_state(state: &SVector<f64, 4>, f: f64) -> SVector<f64, 4> {
    SVector::from([
        to_coarse(state[0], f),
        to_coarse(state[1], f),
        state[2],
        state[3],
    ])
}

/// The extent `(lo, hi)` of `states`, per component.
fn extent<'a>(states: impl Iterator<Item = &'a SVector<f64, 4>>) -> ([f64; 4], [f64; 4]) {
    let (mut lo, mut hi) = ([f64::INFINITY; 4], [f64::NEG_INFINITY; 4]);
    for s in states {
        for d in 0..4 {
            lo[d] = lo[d].min(s[d]);
            hi[d] = hi[d].max(s[d]);
        }
    }
    (lo, hi)
}

/// A frame coordinate on a level `f` times coarser: coarse pixel `k` is the mean of
/// frame pixels `f k .. f k + f - 1`, centred at `f k + (f - 1) / 2`.
fn to_coarse(v: f64, f: f64) -> f64 {
    (v - 0.5 * (f - 1.0)) / f
}

/// The inverse of [`to_coarse`].
fn from_coarse(v: f64, f: f64) -> f64 {
    v * f + 0.5 * (f - 1.0)
}

/// The fine model point `point`, at `p` on the coarse level `blurred`, with its
/// profile sampled there; `None` when it is textureless or leaves the level.
fn coarse_point(
    blurred: &GrayImage,
    p: [f64; 2],
    point: &ModelPoint,
    config: &PatternConfig,
) -> Option<ModelPoint> {
    let mut vector = vec![0.0; config.n_samples];
    if !sample_vector(blurred, p, point.phi, config.delta, &mut vector) {
        return None;
    }
    let contrast = remove_mean(&mut vector);
    let slope = autocorrelation_slope(&vector, config.fit_lags);
    let textured = contrast >= config.min_contrast
        && slope.abs() >= config.min_slope
        && autocorrelation_curvature(&vector, config.fit_lags) > 0.0;
    textured.then_some(ModelPoint {
        x: point.x,
        y: point.y,
        phi: point.phi,
        vector,
        slope,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fused block means of an 8-bit window are those of its grey levels
    /// block-averaged in two passes, bit for bit, at every factor and offset.
    #[test]
    fn fused_block_means_equal_the_two_passes() {
        let (w, h) = (23, 17);
        let data: Vec<u8> = (0..w * h).map(|i| (i * 7919 % 251) as u8).collect();
        let view = rperc_core::image::GrayView::new(&data, w, h).unwrap();
        let frame = PatternFrame::Gray(view);
        for factor in 1..=5 {
            for (x0, y0) in [(0, 0), (3, 2), (1, 4)] {
                let (cw, ch) = ((w - x0) / factor, (h - y0) / factor);
                let window = [x0, y0, x0 + cw * factor, y0 + ch * factor];
                let (mut fine, mut two, mut fused) = (
                    GrayImage::default(),
                    GrayImage::default(),
                    GrayImage::default(),
                );
                frame.window_to_gray(window, &mut fine);
                downsample(&fine, factor, &mut two);
                frame.window_to_blocks(window, factor, &mut fine, &mut fused);
                assert_eq!((fused.width, fused.height), (cw, ch));
                assert_eq!(fused.data, two.data, "factor {factor} at ({x0}, {y0})");
            }
        }
    }

    /// The block means against their definition, a partial block dropped.
    #[test]
    fn downsampling_averages_blocks() {
        let (w, h) = (7, 5);
        let image = GrayImage {
            data: (0..w * h).map(|i| (i * i % 97) as f32).collect(),
            width: w,
            height: h,
        };
        let mut out = GrayImage::default();
        downsample(&image, 3, &mut out);
        assert_eq!((out.width, out.height), (2, 1));
        for x in 0..2 {
            let mut sum = 0.0;
            for dy in 0..3 {
                for dx in 0..3 {
                    sum += image.at(3 * x + dx, dy);
                }
            }
            assert!((out.at(x, 0) - sum / 9.0).abs() < 1e-4);
        }
        // A block's centre maps to its coarse pixel.
        assert_eq!(to_coarse(3.0 * 1.0 + 1.0, 3.0), 1.0);
    }
}
