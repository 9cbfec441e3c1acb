//! [`ColorTemplateTracker`]: Staple's merge of a correlation-filter template and a
//! colour back-projection, DSST's scale filter, a lost signal on the merged peak and a
//! wider re-detection search while lost.

use super::filter::CorrelationFilter;
use super::geometry::Geometry;
use super::hog::FeatureMap;
use super::likelihood::ColourLikelihood;
use super::lost::{Levels, Located, LostRule, WARM_UP_FRAMES};
use super::params::ColorTemplateParams;
use super::patch::{Patch, Window};
use super::result::{Confidence, TemplateResult};
use super::scale::ScaleFilter;
use crate::error::{Result, TrackingError};
use crate::frame::{BoundingBox, RgbFrame};

/// Working buffers reused every frame (no allocation in the steady state).
#[derive(Default)]
pub(super) struct Scratch {
    pub(super) patch: Patch,
    pub(super) map: FeatureMap,
    pub(super) template: Vec<f32>,
    pub(super) colour: Vec<f32>,
    pub(super) probability: Vec<f32>,
    pub(super) scale_samples: Vec<Vec<f32>>,
    /// A scale sample's grey levels.
    pub(super) scale_grey: Vec<f32>,
}

/// A Staple-style tracker: a correlation filter on HOG + intensity cells fused with a
/// foreground/background colour likelihood, DSST scale estimation, a lost flag and
/// re-detection. Deterministic: the same frames give the same boxes.
///
/// # Examples
/// ```
/// use tracking::{BoundingBox, ColorTemplateParams, ColorTemplateTracker, RgbFrame};
///
/// let (w, h) = (80usize, 60usize);
/// let scene = |x0: usize| -> Vec<u8> {
///     (0..w * h)
///         .flat_map(|k| {
///             let (x, y) = (k % w, k / w);
///             let inside = (x0..x0 + 16).contains(&x) && (22..38).contains(&y);
///             if inside { [220, 40 + ((x - x0) as u8 % 8) * 20, 30] } else { [60, 90, 60] }
///         })
///         .collect()
/// };
/// let first = scene(22);
/// let frame = RgbFrame::new(&first, w, h).unwrap();
/// let start = BoundingBox::new(22.0, 22.0, 16.0, 16.0);
/// let mut tracker = ColorTemplateTracker::new(frame, start, ColorTemplateParams::default()).unwrap();
/// let next = scene(25);
/// let r = tracker.update(RgbFrame::new(&next, w, h).unwrap()).unwrap();
/// assert!((r.bbox.x - 25.0).abs() < 1.0 && !r.lost);
/// ```
pub struct ColorTemplateTracker {
    pub(super) params: ColorTemplateParams,
    pub(super) geometry: Geometry,
    pub(super) frame_size: (usize, usize),
    pub(super) base: (f64, f64),
    pub(super) centre: (f64, f64),
    pub(super) scale: f64,
    pub(super) filter: CorrelationFilter,
    pub(super) scale_filter: ScaleFilter,
    pub(super) colour: ColourLikelihood,
    /// The colour histograms learned on the first frame alone: the drift signal's
    /// reference, which a slow slide onto the background cannot teach.
    pub(super) colour_seed: ColourLikelihood,
    pub(super) levels: Levels,
    pub(super) rule: LostRule,
    pub(super) tracked_frames: usize,
    pub(super) lost_frames: usize,
    pub(super) scratch: Scratch,
}

impl ColorTemplateTracker {
    /// Starts tracking `bbox` in `frame`.
    ///
    /// # Errors
    /// Invalid parameters, or a box that is not finite, smaller than a pixel, or not
    /// inside the frame.
    pub fn new(
        frame: RgbFrame<'_>,
        bbox: BoundingBox,
        params: ColorTemplateParams,
    ) -> Result<Self> {
        params.validate()?;
        bbox.check_inside(frame.width(), frame.height())?;
        let geometry = Geometry::new(bbox.w, bbox.h, &params);
        let (gw, gh) = geometry.grid;
        let mut tracker = Self {
            filter: CorrelationFilter::new(gw, gh, geometry.label_sigma(&params), params.lambda),
            scale_filter: ScaleFilter::new(params.n_scales, params.scale_sigma, params.lambda),
            colour: ColourLikelihood::new(params.color_space, params.bins),
            colour_seed: ColourLikelihood::new(params.color_space, params.bins),
            geometry,
            frame_size: (frame.width(), frame.height()),
            base: (bbox.w, bbox.h),
            centre: bbox.centre(),
            scale: 1.0,
            levels: Levels::default(),
            rule: LostRule::new(&params),
            tracked_frames: 0,
            lost_frames: 0,
            scratch: Scratch::default(),
            params,
        };
        tracker.learn(&frame, None, false);
        tracker.colour_seed = tracker.colour.clone();
        Ok(tracker)
    }

    /// The current box.
    pub fn bbox(&self) -> BoundingBox {
        let (w, h) = (self.base.0 * self.scale, self.base.1 * self.scale);
        BoundingBox::new(self.centre.0 - w / 2.0, self.centre.1 - h / 2.0, w, h)
    }

    /// The current scale relative to the first box.
    pub fn scale(&self) -> f64 {
        self.scale
    }

    /// Frames in a row the target has been lost (0 while it is tracked).
    pub fn lost_frames(&self) -> usize {
        self.lost_frames
    }

    /// The parameters.
    pub fn params(&self) -> &ColorTemplateParams {
        &self.params
    }

    /// Tracks the target into the next frame.
    ///
    /// # Errors
    /// [`TrackingError::FrameSizeChanged`] when the frame's size differs from the first.
    pub fn update(&mut self, frame: RgbFrame<'_>) -> Result<TemplateResult> {
        self.check_size(&frame)?;
        let levels = self.levels;
        let best = self.search(&frame, &levels);
        // The first frames only set the levels: a loss needs them to compare with.
        let was_lost = self.lost_frames > 0;
        let lost =
            self.tracked_frames >= WARM_UP_FRAMES && !self.rule.passes(&best, &levels, was_lost);
        if lost {
            self.lost_frames += 1;
            // The levels sink while the target stays lost, so that a target that came
            // back changed (turned, lit differently) is taken up again and learned
            // from, instead of being held to the levels of its old appearance forever.
            self.levels.decay(self.params.lost_level_decay);
            let (m, (cx, cy)) = (self.params.lost_motion, self.centre);
            let (x, y) = if m >= 1.0 {
                (best.cx, best.cy)
            } else {
                (cx + m * (best.cx - cx), cy + m * (best.cy - cy))
            };
            self.centre = self.clamp_centre(x, y);
        } else {
            self.lost_frames = 0;
            self.centre = self.clamp_centre(best.cx, best.cy);
            let scales_sampled = self.estimate_scale(&frame);
            self.tracked_frames += 1;
            self.levels.follow(&best, self.tracked_frames);
            let confidence = self.confidence(best.peak, levels.peak);
            self.learn(&frame, Some(confidence as f32), scales_sampled);
        }
        Ok(TemplateResult {
            bbox: self.bbox(),
            score: best.peak.clamp(0.0, 1.0),
            lost,
            confidence: Confidence {
                peak: best.peak,
                psr: best.psr,
                apce: best.apce,
                color_score: best.color,
                contrast: best.contrast,
            },
        })
    }

    /// How much to learn from a frame, in [0, 1]: 1 at or above the running level,
    /// falling linearly to 0 at the loss threshold, so that a target sliding behind an
    /// occluder stops teaching the models before it is declared lost, instead of at one
    /// threshold whose exact value decides the whole sequence.
    fn confidence(&self, peak: f64, level: f64) -> f64 {
        if self.tracked_frames <= WARM_UP_FRAMES || level <= 0.0 {
            return 1.0;
        }
        let ratio = self.rule.peak_ratio();
        if ratio >= 1.0 {
            return 1.0;
        }
        ((peak / level - ratio) / (1.0 - ratio)).clamp(0.0, 1.0)
    }

    fn check_size(&self, frame: &RgbFrame<'_>) -> Result<()> {
        TrackingError::check_frame_size(self.frame_size, (frame.width(), frame.height()))
    }

    /// The centre kept inside the frame, so a drifting box cannot leave it.
    fn clamp_centre(&self, cx: f64, cy: f64) -> (f64, f64) {
        let (w, h) = self.frame_size;
        (cx.clamp(0.0, w as f64), cy.clamp(0.0, h as f64))
    }

    /// The search window at `(cx, cy)` and the current scale, in frame pixels.
    pub(super) fn window_at(&self, cx: f64, cy: f64) -> Window {
        let z = self.geometry.zoom * self.scale;
        let (pw, ph) = self.geometry.patch;
        Window {
            cx,
            cy,
            width: pw as f64 * z,
            height: ph as f64 * z,
        }
    }

    /// The target in the window at the last position; while lost, when that window
    /// fails the lost rule, the best (by peak) of a grid of windows around it that
    /// passes the rule and whose peak reaches `redetect_ratio` of its level
    /// (re-detection in a wider window), else the last window's answer.
    fn search(&mut self, frame: &RgbFrame<'_>, levels: &Levels) -> Located {
        let (cx, cy) = self.centre;
        let here = self.locate(frame, cx, cy);
        if self.lost_frames == 0 || self.rule.passes(&here, levels, true) {
            return here;
        }
        let reach = self.params.redetect_radius as isize;
        let window = self.window_at(cx, cy);
        let step = self.params.redetect_step;
        let mut best = here;
        for j in -reach..=reach {
            for i in -reach..=reach {
                if i == 0 && j == 0 {
                    continue;
                }
                let x = cx + i as f64 * step * window.width;
                let y = cy + j as f64 * step * window.height;
                let found = self.redetect_at(frame, x, y, levels);
                let taken = found.peak >= self.params.redetect_ratio * levels.peak
                    && self.rule.passes(&found, levels, true);
                if taken && found.peak > best.peak {
                    best = found;
                }
            }
        }
        best
    }

    /// A re-detection window at `(cx, cy)`; when its peak could pass the rule, the
    /// window re-centred on that peak, whose answer is judged instead: a target found
    /// off-centre is under the cosine window's taper and half out of the colour box,
    /// and its peak there understates the match.
    fn redetect_at(&mut self, frame: &RgbFrame<'_>, cx: f64, cy: f64, levels: &Levels) -> Located {
        let found = self.locate(frame, cx, cy);
        if found.peak < self.rule.peak_ratio() * levels.peak {
            return found;
        }
        let centred = self.locate(frame, found.cx, found.cy);
        if centred.peak > found.peak {
            centred
        } else {
            found
        }
    }
}
