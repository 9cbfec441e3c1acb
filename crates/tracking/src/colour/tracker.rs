//! Birchfield's local search: every integer position in a window around the predicted
//! centre, at three scales, scored by histogram intersection (plus the optional
//! perimeter gradient); the best candidate of each scale then competes on the
//! foreground contrast against the background ring and a prior on the scale.

use rayon::prelude::*;

use super::ellipse::Ellipse;
use super::gradient::GradientImage;
use super::model::{AppearanceParams, ColourModel};
use super::pyramid::downsample;
use super::region::RegionHistogram;
use super::ring::{Background, RING_FACTOR};
use super::space::BinImage;
use rperc_core::{ensure_in_range as in_range, ensure_positive as positive};

use crate::error::{Result, TrackingError};
use crate::frame::{BoundingBox, RgbFrame};

/// Parameters of a [`ColorHistogramTracker`]. The appearance defaults were tuned on OTB
/// Girl and Couple; the search, lost and scale defaults added since were set on the
/// seeded synthetic sequences and Couple only, with Girl held out.
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct ColorTrackerParams {
    /// Colour model, adaptation and gradient term.
    pub appearance: AppearanceParams,
    /// Half-size of the square search window of centre positions when the target is
    /// still, in pixels. Default 10.
    pub search_radius: usize,
    /// The window grows by this times the estimated speed (px per frame, an average of
    /// the last displacements), so fast motion stays inside it. Default 1.5; 0 keeps it
    /// at `search_radius`.
    pub velocity_gain: f64,
    /// Largest half-size of the window, whether grown by speed or while the target is
    /// lost (it doubles every lost frame), >= `search_radius`, <= 512.
    /// Default 60.
    pub max_search_radius: usize,
    /// The target is lost when the intersection falls below this fraction of its
    /// running average over confident frames (as well as below
    /// `appearance.lost_threshold`), in [0, 1]. Default 0 (off): on the challenge
    /// sequences and Couple it froze the box on fast motion (0.6 gave 8 lost frames on
    /// fast-1, 7 of them caused by the freeze) and caught no loss the contrast test
    /// missed.
    pub lost_ratio: f64,
    /// The target is lost when its foreground contrast (mean foreground probability
    /// inside the box minus that in the ring around it) falls below this, in [-1, 1].
    /// Default 0.05.
    pub lost_contrast: f64,
    /// Weight of the foreground contrast against the background ring when the three
    /// scales compete, >= 0. Default 0.5; 0 leaves the scale to the intersection.
    pub ring_weight: f64,
    /// Weight of the prior `(ln(s / s_confident))^2` that keeps the scale near its value
    /// at the last confident frame, >= 0. Default 20: a 4 % step then costs 0.03 of a
    /// score range of 1 + `gradient_weight`, enough to stop the perimeter gradient from
    /// pulling the box out to a stronger edge around the target (a synthetic
    /// white ring 1.4-1.7x the target's radius: scale 1.27 with 2, 1.0 with 20) while a
    /// target that doubles in 60 frames is still followed.
    pub scale_prior: f64,
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
    /// Search at half resolution first (a 2 x 2-averaged frame: a quarter of the
    /// positions, each a quarter of the pixels), then refine the best position over the
    /// 4 x 4 full-resolution centres it stands for, at its scale. Used while both
    /// semi-axes are at least 8 pixels. Default `true`.
    pub pyramid: bool,
    /// Search the three scales in parallel with rayon (default `true`); results are the
    /// same either way.
    pub parallel: bool,
}

impl Default for ColorTrackerParams {
    fn default() -> Self {
        Self {
            appearance: AppearanceParams::default(),
            search_radius: 10,
            velocity_gain: 1.5,
            max_search_radius: 60,
            lost_ratio: 0.0,
            lost_contrast: 0.05,
            ring_weight: 0.5,
            scale_prior: 20.0,
            scale_step: 0.04,
            min_scale: 0.5,
            max_scale: 2.0,
            momentum: 0.5,
            pyramid: true,
            parallel: true,
        }
    }
}

/// The search window's half-sizes of both colour trackers: the first `search` and the
/// widest `max` a lost target grows it to, `search <= max <= 512` (512 px each way
/// already spans a 1024-pixel frame).
pub(crate) fn check_search_radii(search: usize, max: usize) -> Result<()> {
    if search > 512 {
        return Err(TrackingError::InvalidParameter {
            name: "search_radius",
            reason: format!("must be <= 512, got {search}"),
        });
    }
    if max < search || max > 512 {
        return Err(TrackingError::InvalidParameter {
            name: "max_search_radius",
            reason: format!("must be between search_radius ({search}) and 512, got {max}"),
        });
    }
    Ok(())
}

impl ColorTrackerParams {
    /// Refuses bad values with the parameter's name; returns the number of bins.
    pub fn validate(&self) -> Result<usize> {
        let n_bins = self.appearance.validate()?;
        check_search_radii(self.search_radius, self.max_search_radius)?;
        in_range("velocity_gain", self.velocity_gain, 0.0, 100.0)?;
        in_range("lost_ratio", self.lost_ratio, 0.0, 1.0)?;
        in_range("lost_contrast", self.lost_contrast, -1.0, 1.0)?;
        in_range("ring_weight", self.ring_weight, 0.0, 100.0)?;
        in_range("scale_prior", self.scale_prior, 0.0, 1e6)?;
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
    /// The target was not found: the score fell below `lost_threshold` or its running
    /// level, the box stood out too little from the background ring, the frame had a
    /// single colour, or the particle set collapsed. The box is then where the target
    /// was last seen.
    pub lost: bool,
}

impl TrackResult {
    /// The answer before the first update: the box given, a perfect score.
    pub fn initial(bbox: BoundingBox) -> Self {
        Self {
            bbox,
            score: 1.0,
            lost: false,
        }
    }
}

/// The search at one scale: its ellipse, the model scaled to its pixel count, a counts
/// buffer, and the scores of every window position.
#[derive(Debug, Clone, Default)]
struct ScaleSearch {
    scale: f64,
    ellipse: Ellipse,
    /// The outer edge of the background ring around `ellipse`.
    ring: Ellipse,
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

impl Window {
    /// The pixels that searches over this window and their rings read,
    /// `[x0, y0, x1, y1)` (unclipped).
    fn reach(&self, searches: &[ScaleSearch]) -> [i32; 4] {
        let (mut ra, mut rb) = (0, 0);
        for s in searches {
            ra = ra.max(s.ring.a.ceil() as i32 + 2);
            rb = rb.max(s.ring.b.ceil() as i32 + 2);
        }
        let end = self.side as i32;
        [
            self.x0 - ra,
            self.y0 - rb,
            self.x0 + end + ra,
            self.y0 + end + rb,
        ]
    }

    /// The centre (pixel) of window index `i`.
    fn position(&self, i: usize) -> (i32, i32) {
        (
            self.x0 + (i % self.side) as i32,
            self.y0 + (i / self.side) as i32,
        )
    }
}

/// Sets each search's scale (clamped to the allowed range) and rebuilds its ellipse, of
/// semi-axes `base` times the scale, and its ring, at `resolution` (1 full, 0.5 the
/// half-resolution level).
fn prepare_scales(
    searches: &mut [ScaleSearch],
    scales: [f64; 3],
    base: (f64, f64),
    resolution: f64,
    p: &ColorTrackerParams,
) {
    let upper_fraction = p.appearance.upper_fraction();
    for (search, &s) in searches.iter_mut().zip(&scales) {
        search.scale = s.clamp(p.min_scale, p.max_scale);
        let (a, b) = (
            base.0 * search.scale * resolution,
            base.1 * search.scale * resolution,
        );
        search.ellipse.rebuild(a, b, upper_fraction);
        search
            .ring
            .rebuild(a * RING_FACTOR, b * RING_FACTOR, upper_fraction);
    }
}

/// Runs every search over `window`, in parallel when asked (same results either way).
fn run_all(
    searches: &mut [ScaleSearch],
    image: &BinImage,
    grad: Option<&GradientImage>,
    model: &ColourModel,
    window: Window,
    parallel: bool,
) {
    if parallel {
        searches
            .par_iter_mut()
            .for_each(|s| s.run(image, grad, model, window));
    } else {
        searches
            .iter_mut()
            .for_each(|s| s.run(image, grad, model, window));
    }
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
    /// The scale at the last confident frame, where the scale prior pulls.
    confident_scale: f64,
    /// Running average of the intersection over confident frames.
    confident_score: f64,
    centre: (f64, f64),
    velocity: (f64, f64),
    /// Running average of the speed (px per frame) that widens the search window.
    speed: f64,
    lost_frames: usize,
    model: ColourModel,
    background: Background,
    image: BinImage,
    gradient: GradientImage,
    searches: Vec<ScaleSearch>,
    coarse: Coarse,
    last: TrackResult,
}

/// The half-resolution level of the search (see [`ColorTrackerParams::pyramid`]).
#[derive(Debug, Clone, Default)]
struct Coarse {
    frame: Vec<u8>,
    image: BinImage,
    gradient: GradientImage,
    searches: Vec<ScaleSearch>,
}

/// Integer centre of the rasterised ellipse for a continuous centre: pixel `i` covers
/// `[i, i + 1)`, so the ellipse centred on pixel `i` has its centre at `i + 0.5`.
pub(crate) fn pixel_centre(c: f64) -> i32 {
    (c - 0.5).round() as i32
}

/// The best candidate of one frame: scale index, window index, its intersection and its
/// foreground contrast.
#[derive(Debug, Clone, Copy)]
struct Candidate {
    scale: usize,
    index: usize,
    score: f64,
    contrast: f64,
}

/// The best `(total, window index)` of one scale's search by `total(colour, gradient)`,
/// ties going to the position nearest the window's centre.
fn top_position(s: &ScaleSearch, window: Window, total: impl Fn(f32, f32) -> f32) -> (f32, usize) {
    let mid = (window.side / 2) as i64;
    let mut top = (f32::NEG_INFINITY, i64::MAX, 0usize);
    for (i, (&c, &g)) in s.colour.iter().zip(&s.gradient).enumerate() {
        let t = total(c, g);
        let (dx, dy) = (
            (i % window.side) as i64 - mid,
            (i / window.side) as i64 - mid,
        );
        let d2 = dx * dx + dy * dy;
        if t > top.0 || (t == top.0 && d2 < top.1) {
            top = (t, d2, i);
        }
    }
    (top.0, top.2)
}

/// Weight of the newest value in the running average of the confident score.
const RUNNING_RATE: f64 = 0.1;
/// Weight of the newest displacement in the running speed: fast, so a sudden move
/// widens the next window at once.
const SPEED_RATE: f64 = 0.5;

impl ColorHistogramTracker {
    /// Samples the colour model from the ellipse inscribed in `bbox` in `frame`, and the
    /// background from the ring around it.
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
        let (mut ellipse, mut ring) = (Ellipse::default(), Ellipse::default());
        ellipse.rebuild(a, b, app.upper_fraction());
        ring.rebuild(a * RING_FACTOR, b * RING_FACTOR, app.upper_fraction());
        let centre = bbox.centre();
        let (icx, icy) = (pixel_centre(centre.0), pixel_centre(centre.1));
        let model = ColourModel::sample(app.model, n_bins, &image, &ellipse, icx, icy);
        let mut background = Background::sample(n_bins, &image, &ellipse, &ring, icx, icy);
        background.refresh(&model.reference);
        Ok(Self {
            width: frame.width(),
            height: frame.height(),
            base_a: a,
            base_b: b,
            scale: 1.0,
            confident_scale: 1.0,
            confident_score: 1.0,
            centre,
            velocity: (0.0, 0.0),
            speed: 0.0,
            lost_frames: 0,
            model,
            background,
            image,
            gradient: GradientImage::default(),
            searches: vec![ScaleSearch::default(); 3],
            coarse: Coarse {
                searches: vec![ScaleSearch::default(); 3],
                ..Coarse::default()
            },
            last: TrackResult::initial(bbox),
            params,
        })
    }

    /// Finds the target in the next frame. When it is not found (see
    /// [`TrackResult::lost`]) the box stays where the target was last seen and the next
    /// search is wider, until the target is found again.
    ///
    /// # Errors
    /// [`TrackingError::FrameSizeChanged`] if `frame` differs in size from the first.
    pub fn update(&mut self, frame: RgbFrame<'_>) -> Result<TrackResult> {
        let size = (frame.width(), frame.height());
        TrackingError::check_frame_size((self.width, self.height), size)?;
        let use_gradient = self.params.appearance.gradient_weight > 0.0;
        let window = self.search_window();
        let found = if self.use_pyramid(&frame) {
            self.coarse_to_fine(&frame, window, use_gradient)
        } else {
            self.full_search(&frame, window, use_gradient)
        };
        // None: one colour everywhere (a black frame), nothing to find or move.
        let Some((best, window)) = found else {
            return Ok(self.mark_lost(0.0));
        };
        let level = self.params.lost_ratio * self.confident_score;
        let app = &self.params.appearance;
        if best.score < app.lost_threshold.max(level) || best.contrast < self.params.lost_contrast {
            return Ok(self.mark_lost(best.score));
        }
        Ok(self.accept(best, window))
    }

    /// Whether this frame is searched coarse to fine: asked for, and both semi-axes at
    /// least 8 pixels at the smallest scale tried.
    fn use_pyramid(&self, frame: &RgbFrame<'_>) -> bool {
        let smallest = self.base_a.min(self.base_b) * self.scale / (1.0 + self.params.scale_step);
        self.params.pyramid && smallest >= 8.0 && frame.width() >= 4 && frame.height() >= 4
    }

    /// Every centre of `window` at three scales, on the full-resolution frame.
    fn full_search(
        &mut self,
        frame: &RgbFrame<'_>,
        window: Window,
        use_gradient: bool,
    ) -> Option<(Candidate, Window)> {
        let app = &self.params.appearance;
        self.image
            .compute(frame, app.color_space, app.bins, self.params.parallel);
        if self.image.bins.iter().all(|&b| b == self.image.bins[0]) {
            return None;
        }
        if use_gradient {
            self.gradient.compute(frame);
        }
        let (base, scales) = ((self.base_a, self.base_b), self.scales());
        prepare_scales(&mut self.searches, scales, base, 1.0, &self.params);
        let grad = use_gradient.then_some(&self.gradient);
        run_all(
            &mut self.searches,
            &self.image,
            grad,
            &self.model,
            window,
            self.params.parallel,
        );
        let best = self.best_candidate(&self.searches, &self.image, use_gradient, window);
        Some((best, window))
    }

    /// The window searched at half resolution, then the 4 x 4 full-resolution centres
    /// under the best coarse centre searched at its scale.
    fn coarse_to_fine(
        &mut self,
        frame: &RgbFrame<'_>,
        window: Window,
        use_gradient: bool,
    ) -> Option<(Candidate, Window)> {
        let (base, scales) = ((self.base_a, self.base_b), self.scales());
        let (p, c) = (&self.params, &mut self.coarse);
        let (hw, hh) = downsample(frame, &mut c.frame);
        let half = RgbFrame::new(&c.frame, hw, hh).ok()?;
        // Half-resolution pixel u stands for full-resolution pixels 2u and 2u + 1.
        let (u0, v0) = (window.x0.div_euclid(2), window.y0.div_euclid(2));
        let last = window.side as i32 - 1;
        let side = ((window.x0 + last).div_euclid(2) - u0)
            .max((window.y0 + last).div_euclid(2) - v0) as usize
            + 1;
        let coarse_window = Window {
            x0: u0,
            y0: v0,
            side,
        };
        prepare_scales(&mut c.searches, scales, base, 0.5, p);
        // Bins and gradients only where the searches and their rings read.
        let rect = coarse_window.reach(&c.searches);
        let app = &p.appearance;
        c.image.compute_rect(&half, app.color_space, app.bins, rect);
        if c.image.uniform_in(rect) {
            return None;
        }
        if use_gradient {
            c.gradient.compute_rect(&half, rect);
        }
        let grad = use_gradient.then_some(&c.gradient);
        run_all(
            &mut c.searches,
            &c.image,
            grad,
            &self.model,
            coarse_window,
            p.parallel,
        );
        let top = self.best_candidate(
            &self.coarse.searches,
            &self.coarse.image,
            use_gradient,
            coarse_window,
        );
        let (u, v) = coarse_window.position(top.index);
        let fine = Window {
            x0: 2 * u - 1,
            y0: 2 * v - 1,
            side: 4,
        };
        Some((self.refine(frame, top.scale, fine, use_gradient), fine))
    }

    /// The best centre of `fine` at scale `si`, at full resolution: bins and gradients
    /// are computed only where that search and the accepted target's model and ring
    /// updates read them.
    fn refine(
        &mut self,
        frame: &RgbFrame<'_>,
        si: usize,
        fine: Window,
        use_gradient: bool,
    ) -> Candidate {
        let scale = self.coarse.searches[si].scale;
        let base = (self.base_a, self.base_b);
        prepare_scales(
            &mut self.searches[si..=si],
            [scale; 3],
            base,
            1.0,
            &self.params,
        );
        let s = &self.searches[si];
        let (ra, rb) = (s.ring.a.ceil() as i32 + 2, s.ring.b.ceil() as i32 + 2);
        let end = fine.side as i32;
        let rect = [
            fine.x0 - ra,
            fine.y0 - rb,
            fine.x0 + end + ra,
            fine.y0 + end + rb,
        ];
        let app = &self.params.appearance;
        self.image
            .compute_rect(frame, app.color_space, app.bins, rect);
        if use_gradient {
            self.gradient.compute_rect(frame, rect);
        }
        let grad = use_gradient.then_some(&self.gradient);
        self.searches[si].run(&self.image, grad, &self.model, fine);
        let mut cand =
            self.best_candidate(&self.searches[si..=si], &self.image, use_gradient, fine);
        cand.scale = si;
        cand
    }

    /// The scales tried this frame: the current one and one step either side.
    fn scales(&self) -> [f64; 3] {
        let step = 1.0 + self.params.scale_step;
        [self.scale, self.scale / step, self.scale * step]
    }

    /// Moves to the best candidate, updates the motion, scale and score averages and,
    /// for a confident match, the colour model and the background.
    fn accept(&mut self, best: Candidate, window: Window) -> TrackResult {
        let search = &self.searches[best.scale];
        let (bx, by) = (
            window.x0 + (best.index % window.side) as i32,
            window.y0 + (best.index / window.side) as i32,
        );
        let new_centre = (bx as f64 + 0.5, by as f64 + 0.5);
        // After a loss the displacement is a jump back onto the target, not motion.
        self.velocity = if self.lost_frames == 0 {
            (new_centre.0 - self.centre.0, new_centre.1 - self.centre.1)
        } else {
            (0.0, 0.0)
        };
        let speed = self.velocity.0.hypot(self.velocity.1);
        self.speed += SPEED_RATE * (speed - self.speed);
        self.lost_frames = 0;
        self.centre = new_centre;
        self.scale = search.scale;
        let app = &self.params.appearance;
        // Eq. (29) only for a confident match, so false candidates cannot corrupt the model.
        if best.score > app.adaptation_threshold {
            self.confident_scale = self.scale;
            self.confident_score += RUNNING_RATE * (best.score - self.confident_score);
            if app.adaptation_rate > 0.0 {
                let rate = app.adaptation_rate;
                self.model.adapt(rate, &self.image, &search.ellipse, bx, by);
                let (e, r) = (&search.ellipse, &search.ring);
                self.background.adapt(rate, &self.image, e, r, bx, by);
                self.background.refresh(&self.model.reference);
            }
        }
        let (a, b) = (self.base_a * self.scale, self.base_b * self.scale);
        self.last = TrackResult {
            bbox: BoundingBox::new(new_centre.0 - a, new_centre.1 - b, 2.0 * a, 2.0 * b),
            score: best.score,
            lost: false,
        };
        self.last
    }

    /// The target was not found: the box stays, the motion stops, the model is kept.
    fn mark_lost(&mut self, score: f64) -> TrackResult {
        self.lost_frames += 1;
        self.velocity = (0.0, 0.0);
        self.last = TrackResult {
            score,
            lost: true,
            ..self.last
        };
        self.last
    }

    /// The half-size of the next frame's search window: `search_radius` grown with the
    /// estimated speed, or doubled for every frame the target has been lost, up to
    /// `max_search_radius`.
    pub fn search_radius(&self) -> usize {
        let p = &self.params;
        let grown = if self.lost_frames > 0 {
            // Doubling: a target that kept moving while lost is caught up with.
            p.search_radius
                .saturating_mul(1usize << self.lost_frames.min(16))
        } else {
            // Rounded, so sub-pixel jitter of a still target does not widen it.
            p.search_radius + (p.velocity_gain * self.speed).round() as usize
        };
        grown.clamp(p.search_radius, p.max_search_radius)
    }

    /// The window of centres searched this frame, around the constant-velocity
    /// prediction.
    fn search_window(&self) -> Window {
        let m = self.params.momentum;
        let predicted = (
            self.centre.0 + m * self.velocity.0,
            self.centre.1 + m * self.velocity.1,
        );
        let radius = self.search_radius() as i32;
        Window {
            x0: pixel_centre(predicted.0) - radius,
            y0: pixel_centre(predicted.1) - radius,
            side: 2 * radius as usize + 1,
        }
    }

    /// The best position of each scale by colour (plus gradient: both normalised to
    /// [0, 1] over all candidates and added, Birchfield 1998), ties going to the
    /// position nearest the window's centre; then the three compete with the foreground
    /// contrast and the scale prior added.
    fn best_candidate(
        &self,
        searches: &[ScaleSearch],
        image: &BinImage,
        use_gradient: bool,
        window: Window,
    ) -> Candidate {
        let range = |f: &dyn Fn(&ScaleSearch) -> &[f32]| {
            let mut lo = f32::INFINITY;
            let mut hi = f32::NEG_INFINITY;
            for s in searches {
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
        let mut best: Option<(f64, Candidate)> = None;
        // Scale 0 is the current one, so ties keep the size.
        for (si, s) in searches.iter().enumerate() {
            let top = top_position(s, window, |c, g| {
                (c - c_lo) * c_inv + wg * (g - g_lo) * g_inv
            });
            let index = top.1;
            let (cx, cy) = window.position(index);
            let contrast = self.background.contrast(image, &s.ellipse, &s.ring, cx, cy);
            let drift = (s.scale / self.confident_scale).ln();
            let total = f64::from(top.0) + self.params.ring_weight * contrast
                - self.params.scale_prior * drift * drift;
            let cand = Candidate {
                scale: si,
                index,
                score: f64::from(s.colour[index]),
                contrast,
            };
            if best.is_none_or(|(t, _)| total > t) {
                best = Some((total, cand));
            }
        }
        best.map(|(_, c)| c).unwrap_or(Candidate {
            scale: 0,
            index: 0,
            score: 0.0,
            contrast: 0.0,
        })
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

    /// Frames in a row the target has been lost (0 while it is tracked).
    pub fn lost_frames(&self) -> usize {
        self.lost_frames
    }
}
