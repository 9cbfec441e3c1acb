//! [`ColorTemplateTracker`]: Staple's merge of a correlation-filter template and a
//! colour back-projection, DSST's scale filter, a lost signal on the merged peak and a
//! wider re-detection search while lost.

use super::filter::CorrelationFilter;
use super::geometry::Geometry;
use super::hog::FeatureMap;
use super::likelihood::ColourLikelihood;
use super::params::ColorTemplateParams;
use super::patch::{Patch, Window};
use super::scale::ScaleFilter;
use crate::colour::TrackResult;
use crate::error::{Result, TrackingError};
use crate::frame::{BoundingBox, RgbFrame};

/// The running level of the peak is the plain mean of the tracked frames' peaks for
/// the first `1 / LEVEL_RATE` of them, then an average with this weight: slow enough
/// that a peak sinking over a few tens of frames (a target sliding behind an
/// occluder) still falls below it, instead of dragging it down.
const LEVEL_RATE: f64 = 0.02;
/// A re-detection window away from the last position is taken only when its peak
/// reaches the full running level (not `lost_ratio` of it): far away, another object
/// of the same kind is likelier than the target (Bolt2's runners, Jogging's joggers).
/// Factor on the running level per lost frame (halves it in about 23 frames).
const LOST_LEVEL_DECAY: f64 = 0.97;
/// Tracked frames whose peaks set the level before a loss can be declared.
const WARM_UP_FRAMES: usize = 5;

/// Where one search window put the target.
#[derive(Debug, Clone, Copy)]
pub(super) struct Located {
    /// The merged response's peak.
    pub(super) peak: f64,
    /// The target's centre it implies, frame pixels.
    pub(super) cx: f64,
    /// The target's centre it implies, frame pixels.
    pub(super) cy: f64,
}

/// Working buffers reused every frame (no allocation in the steady state).
#[derive(Default)]
pub(super) struct Scratch {
    pub(super) patch: Patch,
    pub(super) map: FeatureMap,
    pub(super) template: Vec<f32>,
    pub(super) colour: Vec<f32>,
    pub(super) probability: Vec<f32>,
    pub(super) scale_samples: Vec<Vec<f32>>,
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
    pub(super) peak_level: Option<f64>,
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
            geometry,
            frame_size: (frame.width(), frame.height()),
            base: (bbox.w, bbox.h),
            centre: bbox.centre(),
            scale: 1.0,
            peak_level: None,
            tracked_frames: 0,
            lost_frames: 0,
            scratch: Scratch::default(),
            params,
        };
        tracker.learn(&frame, None);
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
    pub fn update(&mut self, frame: RgbFrame<'_>) -> Result<TrackResult> {
        self.check_size(&frame)?;
        let level = self.peak_level.unwrap_or(0.0);
        let threshold = self.params.lost_ratio * level;
        let best = self.search(&frame, threshold, level);
        // The first frames only set the level: a loss needs one to compare with.
        let lost = self.tracked_frames >= WARM_UP_FRAMES && best.peak < threshold;
        if lost {
            self.lost_frames += 1;
            // The level sinks while the target stays lost, so that a target that came
            // back changed (turned, lit differently) is taken up again and learned
            // from, instead of being held to the level of its old appearance forever.
            self.peak_level = Some(level * LOST_LEVEL_DECAY);
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
            self.estimate_scale(&frame);
            self.tracked_frames += 1;
            let rate = (1.0 / self.tracked_frames as f64).max(LEVEL_RATE);
            self.peak_level = Some((1.0 - rate) * level + rate * best.peak);
            let confidence = self.confidence(best.peak, level);
            self.learn(&frame, Some(confidence as f32));
        }
        Ok(TrackResult {
            bbox: self.bbox(),
            score: best.peak.clamp(0.0, 1.0),
            lost,
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
        let ratio = self.params.lost_ratio;
        if ratio >= 1.0 {
            return 1.0;
        }
        ((peak / level - ratio) / (1.0 - ratio)).clamp(0.0, 1.0)
    }

    fn check_size(&self, frame: &RgbFrame<'_>) -> Result<()> {
        let (w, h) = self.frame_size;
        if (frame.width(), frame.height()) == (w, h) {
            return Ok(());
        }
        Err(TrackingError::FrameSizeChanged {
            expected_width: w,
            expected_height: h,
            width: frame.width(),
            height: frame.height(),
        })
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

    /// The target in the window at the last position; while lost, when that window's
    /// peak stays under `threshold`, the best of a grid of windows around it
    /// (re-detection in a wider window); a distant window must reach the level.
    fn search(&mut self, frame: &RgbFrame<'_>, threshold: f64, level: f64) -> Located {
        let (cx, cy) = self.centre;
        let here = self.locate(frame, cx, cy);
        if self.lost_frames == 0 || here.peak >= threshold {
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
                let found = self.locate(frame, x, y);
                if found.peak >= level && found.peak > best.peak {
                    best = found;
                }
            }
        }
        best
    }
}
