//! Birchfield's local search: every integer position in a window around the predicted
//! centre, at three scales, scored by histogram intersection (plus the optional
//! perimeter gradient); the best candidate wins.

use rayon::prelude::*;

use super::ellipse::Ellipse;
use super::gradient::GradientImage;
use super::model::{AppearanceParams, ColourModel};
use super::region::RegionHistogram;
use super::space::BinImage;
use rperc_core::{ensure_in_range as in_range, ensure_positive as positive};

use crate::error::{Result, TrackingError};
use crate::frame::{BoundingBox, RgbFrame};

/// Parameters of a [`ColorHistogramTracker`]. Defaults are the values tuned on OTB Girl
/// and Couple (the same for both).
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(default, deny_unknown_fields)]
pub struct ColorTrackerParams {
    /// Colour model, adaptation and gradient term.
    pub appearance: AppearanceParams,
    /// Half-size of the square search window of centre positions, in pixels. Default 10.
    pub search_radius: usize,
    /// Relative scale step: each frame tries `s / (1 + step)`, `s`, `s * (1 + step)`.
    /// Default 0.04; 0 keeps the initial size.
    pub scale_step: f64,
    /// Smallest scale relative to the initial box, > 0. Default 0.5.
    pub min_scale: f64,
    /// Largest scale relative to the initial box, >= `min_scale`. Default 2.0.
    pub max_scale: f64,
    /// Constant-velocity prediction: the search is centred on `centre + momentum *
    /// (last displacement)`, momentum in [0, 1]. Default 0.5.
    pub momentum: f64,
    /// Search the three scales in parallel with rayon (default `true`); results are the
    /// same either way.
    pub parallel: bool,
}

impl Default for ColorTrackerParams {
    fn default() -> Self {
        Self {
            appearance: AppearanceParams::default(),
            search_radius: 10,
            scale_step: 0.04,
            min_scale: 0.5,
            max_scale: 2.0,
            momentum: 0.5,
            parallel: true,
        }
    }
}

impl ColorTrackerParams {
    /// Refuses bad values with the parameter's name; returns the number of bins.
    pub fn validate(&self) -> Result<usize> {
        let n_bins = self.appearance.validate()?;
        if self.search_radius > 512 {
            return Err(TrackingError::InvalidParameter {
                name: "search_radius",
                reason: format!("must be <= 512, got {}", self.search_radius),
            });
        }
        in_range("scale_step", self.scale_step, 0.0, 1.0)?;
        positive("min_scale", self.min_scale)?;
        positive("max_scale", self.max_scale)?;
        if self.max_scale < self.min_scale || self.min_scale > 1.0 || self.max_scale < 1.0 {
            return Err(TrackingError::InvalidParameter {
                name: "max_scale",
                reason: format!(
                    "need min_scale <= 1 <= max_scale, got {} and {}",
                    self.min_scale, self.max_scale
                ),
            });
        }
        in_range("momentum", self.momentum, 0.0, 1.0)?;
        Ok(n_bins)
    }
}

/// One tracker answer, OpenCV style.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackResult {
    /// The target's box `(x, y, w, h)`.
    pub bbox: BoundingBox,
    /// Histogram intersection eq. (28) of the chosen candidate with the model, in [0, 1].
    pub score: f64,
    /// The score fell below `lost_threshold` (or the particle set collapsed).
    pub lost: bool,
}

/// The search at one scale: its ellipse, the model scaled to its pixel count, a counts
/// buffer, and the scores of every window position.
#[derive(Debug, Clone, Default)]
struct ScaleSearch {
    scale: f64,
    ellipse: Ellipse,
    scaled_model: Vec<f32>,
    counts: Vec<u32>,
    colour: Vec<f32>,
    gradient: Vec<f32>,
}

/// Window geometry shared by the scale searches of one frame.
#[derive(Debug, Clone, Copy)]
struct Window {
    x0: i32,
    y0: i32,
    side: usize,
}

impl ScaleSearch {
    fn run(
        &mut self,
        image: &BinImage,
        grad: Option<&GradientImage>,
        model: &ColourModel,
        w: Window,
    ) {
        model.scaled(self.ellipse.n_pixels, &mut self.scaled_model);
        self.counts.clear();
        self.counts.resize(self.scaled_model.len(), 0);
        self.colour.clear();
        self.colour.resize(w.side * w.side, 0.0);
        self.gradient.clear();
        self.gradient.resize(w.side * w.side, 0.0);
        let n = self.ellipse.n_pixels as f64;
        let e = &self.ellipse;
        let mut region = RegionHistogram::new(image, &self.scaled_model, &mut self.counts);
        let (mut x, mut y) = (w.x0, w.y0);
        region.fill(e, x, y, true);
        // Boustrophedon raster: every move is one pixel, so every candidate's histogram
        // comes from its neighbour's by per-row span differences.
        for j in 0..w.side {
            if j > 0 {
                region.shift_down(e, x, y);
                y += 1;
            }
            let dir = if j % 2 == 0 { 1 } else { -1 };
            for k in 0..w.side {
                if k > 0 {
                    region.shift_x(e, x, y, dir);
                    x += dir;
                }
                let i = j * w.side + (x - w.x0) as usize;
                // Eq. (28): the candidate's pixel count n is fixed by the ellipse.
                self.colour[i] = (region.intersection / n) as f32;
                if let Some(g) = grad {
                    self.gradient[i] = g.perimeter_score(e, x, y) as f32;
                }
            }
        }
    }
}

/// Birchfield-style colour-histogram tracker (seed 000 section 3.2): an ellipse around
/// the target, searched locally over position and scale each frame to maximise the
/// histogram intersection eq. (28) with the model (plus, optionally, the intensity
/// gradient along the perimeter), with the model adapted by eq. (29) when the match is
/// good.
///
/// # Examples
/// A red disc moving right on a grey background:
/// ```
/// use tracking::{BoundingBox, ColorHistogramTracker, ColorTrackerParams, RgbFrame};
///
/// fn frame(cx: usize) -> Vec<u8> {
///     let (w, h) = (80, 60);
///     let mut px = vec![90u8; w * h * 3];
///     for y in 0..h {
///         for x in 0..w {
///             if (x as f64 - cx as f64).hypot(y as f64 - 30.0) < 8.0 {
///                 px[(y * w + x) * 3..][..3].copy_from_slice(&[220, 30, 30]);
///             }
///         }
///     }
///     px
/// }
/// let first = frame(30);
/// let mut t = ColorHistogramTracker::new(
///     RgbFrame::new(&first, 80, 60).unwrap(),
///     BoundingBox::new(22.0, 22.0, 16.0, 16.0),
///     ColorTrackerParams::default(),
/// ).unwrap();
/// let next = frame(34);
/// let r = t.update(RgbFrame::new(&next, 80, 60).unwrap()).unwrap();
/// let (cx, cy) = r.bbox.centre();
/// assert!((cx - 34.0).abs() <= 1.5 && (cy - 30.0).abs() <= 1.5, "{cx} {cy}");
/// assert!(!r.lost && r.score > 0.9);
/// ```
#[derive(Debug, Clone)]
pub struct ColorHistogramTracker {
    params: ColorTrackerParams,
    width: usize,
    height: usize,
    base_a: f64,
    base_b: f64,
    scale: f64,
    centre: (f64, f64),
    velocity: (f64, f64),
    model: ColourModel,
    image: BinImage,
    gradient: GradientImage,
    searches: Vec<ScaleSearch>,
    last: TrackResult,
}

/// Integer centre of the rasterised ellipse for a continuous centre: pixel `i` covers
/// `[i, i + 1)`, so the ellipse centred on pixel `i` has its centre at `i + 0.5`.
pub(crate) fn pixel_centre(c: f64) -> i32 {
    (c - 0.5).round() as i32
}

impl ColorHistogramTracker {
    /// Samples the colour model from the ellipse inscribed in `bbox` in `frame`.
    ///
    /// # Errors
    /// Invalid parameters, an empty frame, or a box that is degenerate or outside the
    /// frame.
    pub fn new(frame: RgbFrame<'_>, bbox: BoundingBox, params: ColorTrackerParams) -> Result<Self> {
        let n_bins = params.validate()?;
        bbox.check_inside(frame.width(), frame.height())?;
        let mut image = BinImage::default();
        let app = &params.appearance;
        image.compute(&frame, app.color_space, app.bins, params.parallel);
        let (a, b) = (bbox.w / 2.0, bbox.h / 2.0);
        let mut ellipse = Ellipse::default();
        ellipse.rebuild(a, b, app.upper_fraction());
        let centre = bbox.centre();
        let model = ColourModel::sample(
            app.model,
            n_bins,
            &image,
            &ellipse,
            pixel_centre(centre.0),
            pixel_centre(centre.1),
        );
        Ok(Self {
            width: frame.width(),
            height: frame.height(),
            base_a: a,
            base_b: b,
            scale: 1.0,
            centre,
            velocity: (0.0, 0.0),
            model,
            image,
            gradient: GradientImage::default(),
            searches: vec![ScaleSearch::default(); 3],
            last: TrackResult {
                bbox,
                score: 1.0,
                lost: false,
            },
            params,
        })
    }

    /// Finds the target in the next frame.
    ///
    /// # Errors
    /// [`TrackingError::FrameSizeChanged`] if `frame` differs in size from the first.
    pub fn update(&mut self, frame: RgbFrame<'_>) -> Result<TrackResult> {
        if frame.width() != self.width || frame.height() != self.height {
            return Err(TrackingError::FrameSizeChanged {
                expected_width: self.width,
                expected_height: self.height,
                width: frame.width(),
                height: frame.height(),
            });
        }
        let app = &self.params.appearance;
        self.image
            .compute(&frame, app.color_space, app.bins, self.params.parallel);
        let use_gradient = app.gradient_weight > 0.0;
        if use_gradient {
            self.gradient.compute(&frame);
        }
        let window = self.search_window();
        self.search_scales(window, use_gradient);

        let app = &self.params.appearance;
        let (best_scale, best_index) = self.best_candidate(use_gradient);
        let search = &self.searches[best_scale];
        let side = window.side;
        let (bx, by) = (
            window.x0 + (best_index % side) as i32,
            window.y0 + (best_index / side) as i32,
        );
        let score = f64::from(search.colour[best_index]);
        let new_centre = (bx as f64 + 0.5, by as f64 + 0.5);
        self.velocity = (new_centre.0 - self.centre.0, new_centre.1 - self.centre.1);
        self.centre = new_centre;
        self.scale = search.scale;
        let lost = score < app.lost_threshold;
        // Eq. (29) only for a confident match, so false candidates cannot corrupt the model.
        if !lost && score > app.adaptation_threshold && app.adaptation_rate > 0.0 {
            let rate = app.adaptation_rate;
            self.model.adapt(rate, &self.image, &search.ellipse, bx, by);
        }
        let (a, b) = (self.base_a * self.scale, self.base_b * self.scale);
        self.last = TrackResult {
            bbox: BoundingBox::new(new_centre.0 - a, new_centre.1 - b, 2.0 * a, 2.0 * b),
            score,
            lost,
        };
        Ok(self.last)
    }

    /// The window of centres searched this frame: around the constant-velocity
    /// prediction, twice as wide when the target was lost.
    fn search_window(&self) -> Window {
        let m = self.params.momentum;
        let predicted = (
            self.centre.0 + m * self.velocity.0,
            self.centre.1 + m * self.velocity.1,
        );
        let radius = (self.params.search_radius * if self.last.lost { 2 } else { 1 }) as i32;
        Window {
            x0: pixel_centre(predicted.0) - radius,
            y0: pixel_centre(predicted.1) - radius,
            side: 2 * radius as usize + 1,
        }
    }

    /// Scores every centre of `window` at the current scale and one step either side.
    fn search_scales(&mut self, window: Window, use_gradient: bool) {
        let step = 1.0 + self.params.scale_step;
        let scales = [self.scale, self.scale / step, self.scale * step];
        let upper_fraction = self.params.appearance.upper_fraction();
        for (search, &s) in self.searches.iter_mut().zip(&scales) {
            search.scale = s.clamp(self.params.min_scale, self.params.max_scale);
            search.ellipse.rebuild(
                self.base_a * search.scale,
                self.base_b * search.scale,
                upper_fraction,
            );
        }
        let (image, model) = (&self.image, &self.model);
        let grad = use_gradient.then_some(&self.gradient);
        if self.params.parallel {
            self.searches
                .par_iter_mut()
                .for_each(|s| s.run(image, grad, model, window));
        } else {
            self.searches
                .iter_mut()
                .for_each(|s| s.run(image, grad, model, window));
        }
    }

    /// (scale index, window index) of the best candidate. With the gradient term, both
    /// scores are normalised to [0, 1] over all candidates and added (Birchfield 1998).
    fn best_candidate(&self, use_gradient: bool) -> (usize, usize) {
        let range = |f: &dyn Fn(&ScaleSearch) -> &[f32]| {
            let mut lo = f32::INFINITY;
            let mut hi = f32::NEG_INFINITY;
            for s in &self.searches {
                for &v in f(s) {
                    lo = lo.min(v);
                    hi = hi.max(v);
                }
            }
            (lo, if hi > lo { 1.0 / (hi - lo) } else { 0.0 })
        };
        let (c_lo, c_inv) = if use_gradient {
            range(&|s| &s.colour)
        } else {
            (0.0, 1.0)
        };
        let (g_lo, g_inv) = if use_gradient {
            range(&|s| &s.gradient)
        } else {
            (0.0, 0.0)
        };
        let wg = self.params.appearance.gradient_weight as f32;
        let mut best = (0, 0);
        let mut best_total = f32::NEG_INFINITY;
        // Scale 0 is the current one, so ties keep the size.
        for (si, s) in self.searches.iter().enumerate() {
            for (i, (&c, &g)) in s.colour.iter().zip(&s.gradient).enumerate() {
                let total = (c - c_lo) * c_inv + wg * (g - g_lo) * g_inv;
                if total > best_total {
                    best_total = total;
                    best = (si, i);
                }
            }
        }
        best
    }

    /// The last answer (the initial box, score 1, before the first update).
    pub fn last(&self) -> TrackResult {
        self.last
    }

    /// The parameters.
    pub fn params(&self) -> &ColorTrackerParams {
        &self.params
    }

    /// Current scale relative to the initial box.
    pub fn scale(&self) -> f64 {
        self.scale
    }
}
