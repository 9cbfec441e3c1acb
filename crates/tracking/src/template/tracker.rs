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

/// The running level of the peak follows tracked frames with this weight, slowly
/// enough that one bad frame does not move it.
const LEVEL_RATE: f64 = 0.1;

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
///             if inside { [220, 40 + (x as u8 % 8) * 20, 30] } else { [60, 90, 60] }
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
            lost_frames: 0,
            scratch: Scratch::default(),
            params,
        };
        tracker.learn(&frame, 1.0);
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
        let best = self.search(&frame);
        let level = *self.peak_level.get_or_insert(best.peak);
        let lost = best.peak < self.params.lost_ratio * level;
        if lost {
            self.lost_frames += 1;
        } else {
            self.lost_frames = 0;
            self.centre = self.clamp_centre(best.cx, best.cy);
            self.estimate_scale(&frame);
            self.peak_level = Some((1.0 - LEVEL_RATE) * level + LEVEL_RATE * best.peak);
            self.learn(&frame, self.params.learning_rate as f32);
        }
        Ok(TrackResult {
            bbox: self.bbox(),
            score: best.peak.clamp(0.0, 1.0),
            lost,
        })
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

    /// The best of the search windows: the last position's while tracked; a grid of
    /// windows around it while lost (re-detection in a wider window).
    fn search(&mut self, frame: &RgbFrame<'_>) -> Located {
        let (cx, cy) = self.centre;
        let reach = if self.lost_frames > 0 {
            self.params.redetect_radius as isize
        } else {
            0
        };
        let window = self.window_at(cx, cy);
        let step = self.params.redetect_step;
        let mut best: Option<Located> = None;
        for j in -reach..=reach {
            for i in -reach..=reach {
                let x = cx + i as f64 * step * window.width;
                let y = cy + j as f64 * step * window.height;
                let found = self.locate(frame, x, y);
                if best.is_none_or(|b| found.peak > b.peak) {
                    best = Some(found);
                }
            }
        }
        best.unwrap_or(Located { peak: 0.0, cx, cy })
    }
}
