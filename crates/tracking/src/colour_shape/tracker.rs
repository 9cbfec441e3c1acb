//! The colour+shape tracker of seed 000 section 3.3: CONDENSATION over the target's
//! colour distribution, each sample weighted by the shape of the segmentation it yields.

use image::GrayImage;
use imageproc::distance_transform::Norm;
use imageproc::morphology::dilate_mut;

use super::params::ColorShapeParams;
use super::segment::{Roi, bin_window, boundary, clean, euler_number, keep_target_blob, segment};
use super::snake::{
    Affine, Contour, SnakeFit, SnakeParams, SnakeScratch, ellipse_contour, fill_polygon, fit_snake,
    polygon_area,
};
use super::state::{
    ColourDistribution, ColourWarp, N_PARAMS, STATE_DIM, State, colour_coords, fill_lut,
};
use crate::condensation::{Likelihood, ParticleFilter};
use crate::error::{Result, TrackingError};
use crate::frame::{BoundingBox, RgbFrame};

/// One frame's output of a [`ColorShapeTracker`].
#[derive(Debug, Clone, PartialEq)]
pub struct ColorShapeResult {
    /// The refined contour `r_t`, frame pixel coordinates (pixel centres at integers).
    pub contour: Contour,
    /// The contour's bounding box.
    pub bbox: BoundingBox,
    /// The estimated colour distribution `[m (3), lambda (3), theta, phi]`.
    pub distribution: [f64; N_PARAMS],
    /// The best sample's weight `exp(-rho^2 / 2 sigma^2)`, in [0, 1].
    pub score: f64,
    /// No sample produced a usable blob, or the score fell below `lost_below`: the
    /// contour was kept from the previous frame.
    pub lost: bool,
    /// Effective sample size after weighting.
    pub ess: f64,
}

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
}

/// Buffers of one sample's evaluation, reused across samples and frames.
#[derive(Debug, Clone, Default)]
pub struct SampleScratch {
    lut: Vec<u8>,
    seg: GrayImage,
    edges: GrayImage,
    overlap: Vec<u32>,
    snake: SnakeScratch,
}

/// What every sample of one frame shares.
struct FrameContext<'a> {
    params: &'a ColorShapeParams,
    reference: &'a ColourDistribution,
    cloud: &'a [[f64; 3]],
    bins: &'a [u16],
    roi: Roi,
    prior: &'a GrayImage,
    previous: &'a [[f64; 2]],
    previous_centroid: [f64; 2],
    predicted_area: f64,
    snake: SnakeParams,
}

impl FrameContext<'_> {
    /// `H(n)`, `S(n)`, the blob, `grad S(n)`, the affine snake and the three terms;
    /// `None` when the segmentation holds no blob over the predicted target.
    fn evaluate(&self, state: &State, s: &mut SampleScratch) -> Option<SampleTerms> {
        let p = self.params;
        let warp = ColourWarp::new(self.reference, state, p.min_spread());
        fill_lut(&warp, self.cloud, p.bins, &mut s.lut);
        segment(self.bins, &s.lut, self.roi, &mut s.seg);
        clean(&mut s.seg, p.morphology_radius);
        if keep_target_blob(&mut s.seg, self.prior, &mut s.overlap) == 0 {
            return None;
        }
        let holes = (1 - euler_number(&s.seg)).max(0) as f64;
        let quality = (1.0 - p.hole_penalty * holes).clamp(0.0, 1.0);
        boundary(&s.seg, &mut s.edges);
        let [bx, by] = mask_centroid(&s.seg);
        let init = Affine::translation(
            bx + self.roi.x0 as f64 - self.previous_centroid[0],
            by + self.roi.y0 as f64 - self.previous_centroid[1],
        );
        let fit = fit_snake(
            self.previous,
            init,
            &self.snake,
            |x, y| on(&s.edges, self.roi, x, y),
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
}

impl Likelihood<STATE_DIM> for FrameContext<'_> {
    type Scratch = SampleScratch;

    fn new_scratch(&self) -> SampleScratch {
        SampleScratch::default()
    }

    fn log_likelihood(&self, state: &State, scratch: &mut SampleScratch) -> f64 {
        match self.evaluate(state, scratch) {
            Some(t) => -t.rho(self.params.mu).powi(2) / (2.0 * self.params.sigma.powi(2)),
            None => f64::NEG_INFINITY,
        }
    }
}

/// Whether the window mask is set at frame pixel `(x, y)`.
#[inline]
fn on(mask: &GrayImage, roi: Roi, x: i64, y: i64) -> bool {
    let (u, v) = (x - roi.x0 as i64, y - roi.y0 as i64);
    u >= 0
        && v >= 0
        && (u as usize) < roi.width
        && (v as usize) < roi.height
        && mask.as_raw()[v as usize * roi.width + u as usize] != 0
}

/// Centroid of the non-zero pixels of a mask (window coordinates).
fn mask_centroid(mask: &GrayImage) -> [f64; 2] {
    let (mut sx, mut sy, mut n) = (0.0f64, 0.0f64, 0.0f64);
    for (x, y, p) in mask.enumerate_pixels() {
        if p[0] != 0 {
            sx += f64::from(x);
            sy += f64::from(y);
            n += 1.0;
        }
    }
    [sx / n.max(1.0), sy / n.max(1.0)]
}

/// Mean of a contour's points.
fn contour_centroid(c: &[[f64; 2]]) -> [f64; 2] {
    let n = c.len().max(1) as f64;
    let (sx, sy) = c.iter().fold((0.0, 0.0), |(a, b), p| (a + p[0], b + p[1]));
    [sx / n, sy / n]
}

/// Bounding box of a contour.
fn contour_box(c: &[[f64; 2]]) -> BoundingBox {
    let (mut x0, mut y0, mut x1, mut y1) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
    for p in c {
        x0 = x0.min(p[0]);
        y0 = y0.min(p[1]);
        x1 = x1.max(p[0]);
        y1 = y1.max(p[1]);
    }
    BoundingBox::new(x0, y0, (x1 - x0).max(0.0), (y1 - y0).max(0.0))
}

/// Colour+shape tracker (seed 000 section 3.3, after Isard & Blake's CONDENSATION and
/// Kass et al.'s snakes): the filter tracks the target's colour distribution; each sample
/// segments the frame with its histogram, an affine snake is fitted to the segmented
/// blob, and the sample is weighted by how well the snake sits on the blob's boundary,
/// how its area matches the prediction and how few holes the blob has. The best sample's
/// blob then masks the image edges to which the final contour is fitted.
///
/// The search is confined to a window around the previous contour (its box grown by
/// `roi_margin` plus the edge search), so the cost per sample is set by the target's
/// size, not the frame's.
///
/// # Examples
/// A red square moving right on a grey background:
/// ```
/// use tracking::{BoundingBox, ColorShapeParams, ColorShapeTracker, RgbFrame};
///
/// fn frame(x0: usize) -> Vec<u8> {
///     let (w, h) = (100, 80);
///     let mut px = vec![90u8; w * h * 3];
///     for y in 30..50 {
///         for x in x0..x0 + 20 {
///             px[(y * w + x) * 3..][..3].copy_from_slice(&[220, 30, 30]);
///         }
///     }
///     px
/// }
/// let square = [[30.0, 30.0], [49.0, 30.0], [49.0, 49.0], [30.0, 49.0]];
/// let first = frame(30);
/// let mut t = ColorShapeTracker::new(
///     RgbFrame::new(&first, 100, 80).unwrap(), &square, ColorShapeParams::default(),
/// ).unwrap();
/// let next = frame(34);
/// let r = t.update(RgbFrame::new(&next, 100, 80).unwrap()).unwrap();
/// assert!(!r.lost);
/// assert!((r.bbox.x - 34.0).abs() <= 1.0 && (r.bbox.w - 19.0).abs() <= 1.5, "{:?}", r.bbox);
/// ```
#[derive(Debug, Clone)]
pub struct ColorShapeTracker {
    params: ColorShapeParams,
    width: usize,
    height: usize,
    reference: ColourDistribution,
    cloud: Vec<[f64; 3]>,
    filter: ParticleFilter<STATE_DIM>,
    contour: Contour,
    areas: [f64; 2],
    bins: Vec<u16>,
    prior: GrayImage,
    scratch: Vec<SampleScratch>,
    refine: SnakeScratch,
    last: ColorShapeResult,
}

impl ColorShapeTracker {
    /// Starts tracking the region inside `contour` (a closed polygon in frame pixel
    /// coordinates, at least 3 points): its pixels' colours are the reference
    /// distribution, and the contour, resampled to `contour_points`, is `r_0`.
    ///
    /// # Errors
    /// Invalid parameters, a contour with fewer than 3 points, non-finite points, or
    /// enclosing no pixel of the frame.
    pub fn new(
        frame: RgbFrame<'_>,
        contour: &[[f64; 2]],
        params: ColorShapeParams,
    ) -> Result<Self> {
        params.validate()?;
        check_contour(contour)?;
        let r0 = resample_closed(contour, params.contour_points);
        let cloud = colours_inside(&frame, &r0, &params)?;
        let reference = ColourDistribution::from_points(&cloud, params.min_spread())?;
        let dynamics = params.dynamics.linear_gaussian();
        // The initial spread: a few frames of process noise around the reference.
        let cov = dynamics.b * dynamics.b.transpose() * 4.0;
        let filter = ParticleFilter::new(
            params.n_samples,
            reference.to_state(),
            cov,
            dynamics,
            params.filter.clone(),
            params.seed,
        )?;
        let area = polygon_area(&r0);
        let last = ColorShapeResult {
            bbox: contour_box(&r0),
            contour: r0.clone(),
            distribution: distribution_of(&reference.to_state()),
            score: 1.0,
            lost: false,
            ess: params.n_samples as f64,
        };
        Ok(Self {
            width: frame.width(),
            height: frame.height(),
            reference,
            cloud,
            filter,
            contour: r0,
            areas: [area, area],
            bins: Vec::new(),
            prior: GrayImage::new(1, 1),
            scratch: Vec::new(),
            refine: SnakeScratch::default(),
            last,
            params,
        })
    }

    /// Starts from the ellipse inscribed in `bbox`, the seed's initial snake.
    ///
    /// # Errors
    /// As [`new`](Self::new), and a box that is not inside the frame.
    pub fn from_box(
        frame: RgbFrame<'_>,
        bbox: BoundingBox,
        params: ColorShapeParams,
    ) -> Result<Self> {
        bbox.check_inside(frame.width(), frame.height())?;
        let (cx, cy) = bbox.centre();
        // Pixel centres are at integers: the box [x, x + w) spans centres x .. x + w - 1.
        let (rx, ry) = ((bbox.w - 1.0).max(0.5) / 2.0, (bbox.h - 1.0).max(0.5) / 2.0);
        let ellipse = ellipse_contour(cx - 0.5, cy - 0.5, rx, ry, params.contour_points.max(8));
        Self::new(frame, &ellipse, params)
    }
}

impl ColorShapeTracker {
    /// One iteration: resample, propagate and weight the colour distributions, then
    /// refine the best sample's contour on the image edges.
    ///
    /// # Errors
    /// [`TrackingError::FrameSizeChanged`] when the frame's size differs from the first.
    pub fn update(&mut self, frame: RgbFrame<'_>) -> Result<ColorShapeResult> {
        if (frame.width(), frame.height()) != (self.width, self.height) {
            return Err(TrackingError::FrameSizeChanged {
                expected_width: self.width,
                expected_height: self.height,
                width: frame.width(),
                height: frame.height(),
            });
        }
        let roi = self.window();
        bin_window(
            &frame,
            roi,
            self.params.color_space,
            self.params.bins,
            &mut self.bins,
        );
        if self.prior.dimensions() != (roi.width as u32, roi.height as u32) {
            self.prior = GrayImage::new(roi.width as u32, roi.height as u32);
        }
        fill_polygon(&self.contour, roi.x0 as f64, roi.y0 as f64, &mut self.prior);
        let [a1, a2] = self.areas;
        let ctx = FrameContext {
            params: &self.params,
            reference: &self.reference,
            cloud: &self.cloud,
            bins: &self.bins,
            roi,
            prior: &self.prior,
            previous: &self.contour,
            previous_centroid: contour_centroid(&self.contour),
            predicted_area: (a1 + self.params.area_momentum * (a1 - a2)).max(1.0),
            snake: SnakeParams {
                search: self.params.search,
                iterations: self.params.snake_iterations,
                on_edge_tolerance: 1.0,
            },
        };
        let report = self.filter.step_with_scratch(&ctx, &mut self.scratch);
        let best = self.filter.max_weight().0;
        let terms = if report.lost {
            None
        } else {
            ctx.evaluate(&best, &mut self.scratch[0])
        };
        let score = terms.map_or(0.0, |t| {
            (-t.rho(self.params.mu).powi(2) / (2.0 * self.params.sigma.powi(2))).exp()
        });
        let lost = terms.is_none() || score < self.params.lost_below;
        if let (Some(t), false) = (terms, lost) {
            let refined = if !self.params.refine {
                self.scratch[0].snake.contour().to_vec()
            } else {
                refine(
                    &frame,
                    roi,
                    &ctx,
                    t.fit.affine,
                    &mut self.scratch[0],
                    &mut self.refine,
                )
            };
            self.areas = [polygon_area(&refined), a1];
            self.contour = refined;
        }
        self.last = ColorShapeResult {
            bbox: contour_box(&self.contour),
            contour: self.contour.clone(),
            distribution: distribution_of(&self.filter.mean()),
            score,
            lost,
            ess: report.ess,
        };
        Ok(self.last.clone())
    }

    /// The window searched this frame: the previous contour's box grown by `roi_margin`
    /// of its size plus the edge search, clipped to the frame.
    fn window(&self) -> Roi {
        let b = contour_box(&self.contour);
        let mx = self.params.roi_margin * b.w + self.params.search as f64;
        let my = self.params.roi_margin * b.h + self.params.search as f64;
        Roi::clipped(
            b.x - mx,
            b.y - my,
            b.x + b.w + mx + 1.0,
            b.y + b.h + my + 1.0,
            self.width,
            self.height,
        )
    }

    /// The last result.
    pub fn last(&self) -> &ColorShapeResult {
        &self.last
    }

    /// The parameters.
    pub fn params(&self) -> &ColorShapeParams {
        &self.params
    }

    /// The particle filter over colour distributions.
    pub fn filter(&self) -> &ParticleFilter<STATE_DIM> {
        &self.filter
    }
}

/// Contour refinement: the snake, started from the best sample's fit, is fitted to the
/// image edges `grad I` (Canny) masked by the dilated boundary of the best sample's blob,
/// `grad I . dil(grad S)`: the object's true edges, without the clutter. Falls back to the
/// sample's own fit when fewer than `refine_min_support` of the snake's points end on
/// those edges.
fn refine(
    frame: &RgbFrame<'_>,
    roi: Roi,
    ctx: &FrameContext<'_>,
    start: Affine,
    best: &mut SampleScratch,
    snake: &mut SnakeScratch,
) -> Contour {
    let p = ctx.params;
    let sample_contour = best.snake.contour().to_vec();
    dilate_mut(&mut best.edges, Norm::LInf, p.edge_dilation);
    let gray = GrayImage::from_fn(roi.width as u32, roi.height as u32, |u, v| {
        let px = &frame.row(roi.y0 + v as usize)[3 * (roi.x0 + u as usize)..][..3];
        image::Luma([rperc_core::image::luma(px[0], px[1], px[2])
            .round()
            .clamp(0.0, 255.0) as u8])
    });
    let image_edges = imageproc::edges::canny(&gray, p.canny[0], p.canny[1]);
    let masked = |x: i64, y: i64| on(&best.edges, roi, x, y) && on(&image_edges, roi, x, y);
    let fit = fit_snake(ctx.previous, start, &ctx.snake, masked, snake);
    if fit.on_edge >= p.refine_min_support {
        snake.contour().to_vec()
    } else {
        sample_contour
    }
}

fn distribution_of(s: &State) -> [f64; N_PARAMS] {
    std::array::from_fn(|i| s[i])
}

fn check_contour(contour: &[[f64; 2]]) -> Result<()> {
    if contour.len() < 3 || contour.iter().flatten().any(|v| !v.is_finite()) {
        return Err(TrackingError::InvalidParameter {
            name: "contour",
            reason: format!("need >= 3 finite points, got {}", contour.len()),
        });
    }
    Ok(())
}

/// `n` points spaced evenly by arc length along a closed polygon.
pub fn resample_closed(poly: &[[f64; 2]], n: usize) -> Contour {
    let m = poly.len();
    let seg = |i: usize| {
        let (a, b) = (poly[i], poly[(i + 1) % m]);
        (b[0] - a[0]).hypot(b[1] - a[1])
    };
    let total: f64 = (0..m).map(seg).sum();
    if total <= 0.0 {
        return vec![poly[0]; n];
    }
    let (mut out, mut i, mut start) = (Vec::with_capacity(n), 0, 0.0);
    for k in 0..n {
        let s = total * k as f64 / n as f64;
        while start + seg(i) < s && i + 1 < m {
            start += seg(i);
            i += 1;
        }
        let (a, b) = (poly[i], poly[(i + 1) % m]);
        let f = if seg(i) > 0.0 {
            (s - start) / seg(i)
        } else {
            0.0
        };
        out.push([a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])]);
    }
    out
}

/// Colour coordinates of the pixels inside `contour`, thinned by a fixed stride to at
/// most `cloud_points`.
fn colours_inside(
    frame: &RgbFrame<'_>,
    contour: &[[f64; 2]],
    p: &ColorShapeParams,
) -> Result<Vec<[f64; 3]>> {
    let b = contour_box(contour);
    let roi = Roi::clipped(
        b.x,
        b.y,
        b.x + b.w + 1.0,
        b.y + b.h + 1.0,
        frame.width(),
        frame.height(),
    );
    let mut mask = GrayImage::new(roi.width.max(1) as u32, roi.height.max(1) as u32);
    fill_polygon(contour, roi.x0 as f64, roi.y0 as f64, &mut mask);
    let mut all = Vec::new();
    for (u, v, m) in mask.enumerate_pixels() {
        let (x, y) = (roi.x0 + u as usize, roi.y0 + v as usize);
        if m[0] != 0 && x < frame.width() && y < frame.height() {
            let px = &frame.row(y)[3 * x..][..3];
            all.push(colour_coords(p.color_space, [px[0], px[1], px[2]])?);
        }
    }
    if all.is_empty() {
        return Err(TrackingError::InvalidParameter {
            name: "contour",
            reason: "encloses no pixel of the frame".into(),
        });
    }
    let stride = all.len().div_ceil(p.cloud_points);
    Ok(all.into_iter().step_by(stride).collect())
}
