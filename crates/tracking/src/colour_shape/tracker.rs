//! The colour+shape tracker of seed 000 section 3.3: CONDENSATION over the target's
//! colour distribution, each sample weighted by the shape of the segmentation it yields.

use image::GrayImage;
use imageproc::distance_transform::Norm;
use imageproc::morphology::dilate_mut;

use super::cloud::measured_state;
use super::params::ColorShapeParams;
use super::sample::{BlobSearch, FrameContext, SampleScratch, SampleTerms, on};
use super::segment::{FrameSides, Grid, LineMasks, Roi, bin_window, resize};
use super::snake::{
    Contour, SnakeParams, SnakeScratch, ellipse_contour, fill_polygon, fit_snake, polygon_area,
    polygon_spreads, pull_radially, relax, resample_closed,
};
use super::state::{ColourDistribution, N_PARAMS, STATE_DIM, State};
use crate::condensation::{Guess, ParticleFilter};
use crate::error::{Result, TrackingError};
use crate::frame::{BoundingBox, RgbFrame};

/// One frame's output of a [`ColorShapeTracker`].
#[derive(Debug, Clone, PartialEq)]
pub struct ColorShapeResult {
    /// The refined contour `r_t`, frame pixel coordinates (pixel centres at integers).
    pub contour: Contour,
    /// The contour's bounding box, clipped to the frame (`[0, width] x [0, height]`):
    /// the part of the target in view.
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

/// Colour+shape tracker (seed 000 section 3.3, after Isard & Blake's CONDENSATION and
/// Kass et al.'s snakes): the filter tracks the target's colour distribution; each sample
/// segments a window around the predicted contour with its histogram (an integer lookup
/// table on a grid of about `sample_cells` cells across the target), cleans it with an
/// opening and a closing, and keeps the blob reconstructed from the prediction within the
/// snake's reach (split at narrow necks when it has grown too big). An affine snake
/// started from `r_{t-1}` is fitted to the blob's boundary, and the sample is weighted by
/// how well the snake sits on that boundary, how its area matches the prediction and
/// how few holes the blob has. The best sample's blob then masks the image edges to which
/// the final contour is fitted, and the contour may relax a few pixels off the affine fit.
///
/// While lost (a low score, a contour whose area is far from the usual one, or one that
/// overlaps the best blob too little) the contour stays, the window widens each frame
/// and each sample takes the blob most like the target in area and principal spreads
/// anywhere in it, fitting the snake from the last well-scored shape.
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
    /// Image velocity of the contour's centroid, pixels per frame.
    velocity: [f64; 2],
    areas: [f64; 2],
    /// The target's usual area: an average of the accepted contours' areas over about
    /// the last `1 / USUAL_AREA_RATE` frames.
    usual_area: f64,
    /// The target's usual principal spreads, averaged like the area: what
    /// re-acquisition looks for besides the area.
    usual_spreads: [f64; 2],
    /// The last contour accepted with a score of at least `GOOD_SHAPE_SCORE`: the shape
    /// re-acquisition starts its snakes from.
    good_shape: Contour,
    lost_frames: usize,
    /// The colour distribution inside the last accepted contour: a fraction of the
    /// next frame's samples is drawn around it.
    measured: State,
    bins: Vec<u16>,
    morphology: LineMasks,
    prior: GrayImage,
    region: GrayImage,
    dilated: GrayImage,
    scratch: Vec<SampleScratch>,
    refine: SnakeScratch,
    last: ColorShapeResult,
}

impl ColorShapeTracker {
    /// Starts tracking the region inside `contour` (a closed polygon in frame pixel
    /// coordinates, at least 3 points): the colours of its pixels that are more
    /// frequent inside than in the ring around it are the reference distribution, and
    /// the contour, resampled to `contour_points`, is `r_0`.
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
        check_contour(contour, frame.width(), frame.height())?;
        let r0 = resample_closed(contour, params.contour_points);
        let cloud = super::cloud::target_colours(&frame, &r0, &params)?;
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
        let usual_spreads = polygon_spreads(&r0);
        let good_shape = r0.clone();
        let measured = reference.to_state();
        let last = ColorShapeResult {
            bbox: BoundingBox::enclosing(&r0).clipped_to(frame.width(), frame.height()),
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
            velocity: [0.0; 2],
            areas: [area, area],
            usual_area: area,
            usual_spreads,
            good_shape,
            lost_frames: 0,
            measured,
            bins: Vec::new(),
            morphology: LineMasks::new(params.morphology_radius),
            prior: GrayImage::new(1, 1),
            region: GrayImage::new(1, 1),
            dilated: GrayImage::new(1, 1),
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
        // Before the ellipse allocates `contour_points` points.
        params.validate()?;
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
    /// refine the best sample's contour on the image edges. While the target is lost
    /// the window widens each frame and each sample looks for the blob whose area
    /// matches the target's anywhere in it.
    ///
    /// # Errors
    /// [`TrackingError::FrameSizeChanged`] when the frame's size differs from the first.
    pub fn update(&mut self, frame: RgbFrame<'_>) -> Result<ColorShapeResult> {
        self.check_size(&frame)?;
        let (predicted, roi, grid) = self.prepare(&frame);
        let p = &self.params;
        let ctx = FrameContext {
            params: p,
            reference: &self.reference,
            cloud: &self.cloud,
            bins: &self.bins,
            roi,
            grid,
            sides: FrameSides::of(roi, self.width, self.height),
            prior: &self.prior,
            region: &self.region,
            predicted: &predicted,
            predicted_centroid: contour_centroid(&predicted),
            predicted_area: self.predicted_area(),
            spreads: self.usual_spreads,
            snake: snake_params(p),
            morphology: &self.morphology,
            search: if self.lost_frames > 0 {
                BlobSearch::Reacquire
            } else {
                BlobSearch::Track
            },
        };
        let guesses = self.guesses();
        let before = self.filter.copy_if_interruptible();
        let report = self.filter.step_mixtures(&ctx, &mut self.scratch, &guesses);
        if report.interrupted {
            // Ctrl-C: the samples go back to where they were; the contour, areas and
            // velocity only change in `conclude`, and the rest is this frame's scratch.
            if let Some(before) = before {
                self.filter = before;
            }
            return Err(rperc_core::CoreError::Interrupted.into());
        }
        let terms = if report.lost {
            None
        } else {
            ctx.evaluate(&self.filter.max_weight().0, &mut self.scratch[0])
        };
        let score = terms.map_or(0.0, |t| t.log_weight(p.mu, p.sigma).exp());
        let refined = match terms {
            Some(t) if score >= p.lost_below => Some(refine(
                &frame,
                &ctx,
                t,
                &mut self.scratch[0],
                &mut self.dilated,
                &mut self.refine,
            )),
            _ => None,
        };
        let min_overlap = p.min_blob_overlap;
        let refined = refined.filter(|r| {
            let blob = &self.scratch[0].blob;
            blob_overlap(r, ctx.grid, blob, &mut self.dilated) >= min_overlap
        });
        Ok(self.conclude(&frame, refined, score, report.ess))
    }

    /// The contour predicted by the image velocity, the window around it and its
    /// sampling grid; bins the window and fills the prediction's masks.
    fn prepare(&mut self, frame: &RgbFrame<'_>) -> (Contour, Roi, Grid) {
        let v = self.velocity;
        // While lost, the snake starts from the last well-scored shape placed where the
        // target was: the contour kept at the loss is often the spoilt one that lost it.
        let shift = if self.lost_frames > 0 {
            let (a, b) = (
                contour_centroid(&self.contour),
                contour_centroid(&self.good_shape),
            );
            [a[0] - b[0] + v[0], a[1] - b[1] + v[1]]
        } else {
            v
        };
        let base = if self.lost_frames > 0 {
            &self.good_shape
        } else {
            &self.contour
        };
        let predicted: Contour = base
            .iter()
            .map(|q| [q[0] + shift[0], q[1] + shift[1]])
            .collect();
        let roi = self.window(&predicted);
        let grid = Grid::over(roi, self.stride());
        let p = &self.params;
        bin_window(frame, grid, p.color_space, p.bins, &mut self.bins);
        prior_masks(
            &predicted,
            grid,
            p.search,
            &mut self.prior,
            &mut self.region,
        );
        (predicted, roi, grid)
    }

    /// The area the snake is compared with: the seed's `A_{t-1} + mu (A_{t-1} -
    /// A_{t-2})` while tracking, the usual area while re-acquiring.
    fn predicted_area(&self) -> f64 {
        let [a1, a2] = self.areas;
        if self.lost_frames > 0 {
            self.usual_area
        } else {
            (a1 + self.params.area_momentum * (a1 - a2)).max(1.0)
        }
    }

    /// The mixture's guesses: half of the mixed samples around the colours measured
    /// last, half around the first frame's (the anchor keeps a contour that slowly loses
    /// part of the target from narrowing the colours with it); while lost, all around
    /// the first frame's.
    fn guesses(&self) -> [Guess<STATE_DIM>; 2] {
        let p = &self.params;
        let n_mixed = (p.mix_fraction * p.n_samples as f64).round() as usize;
        let sigma = p.dynamics.noise_std();
        let anchored = if self.lost_frames > 0 {
            n_mixed
        } else {
            n_mixed / 2
        };
        [
            (self.reference.to_state(), sigma, anchored),
            (self.measured, sigma, n_mixed - anchored),
        ]
    }

    /// Accepts `refined` as `r_t` unless its area is far from the target's usual one
    /// (a contour that each frame shrinks a little onto part of the target would
    /// otherwise collapse), updates the measured colours, and answers.
    fn conclude(
        &mut self,
        frame: &RgbFrame<'_>,
        refined: Option<Contour>,
        score: f64,
        ess: f64,
    ) -> ColorShapeResult {
        let p = &self.params;
        let refined = refined
            .filter(|r| area_ratio(polygon_area(r), self.usual_area) >= p.reacquire_area_ratio);
        let lost = refined.is_none();
        match refined {
            Some(r) => {
                if let Some(m) = measured_state(frame, &r, &self.reference, p) {
                    self.measured = m;
                }
                if score >= GOOD_SHAPE_SCORE {
                    self.good_shape.clone_from(&r);
                }
                self.accept(r);
            }
            None => self.lost_frames += 1,
        }
        self.last = ColorShapeResult {
            // The contour may run past the frame where the snake's affine shape carries
            // points beyond the edges it saw; the box reports only what is in view.
            bbox: BoundingBox::enclosing(&self.contour).clipped_to(self.width, self.height),
            contour: self.contour.clone(),
            distribution: distribution_of(&self.filter.mean()),
            score,
            lost,
            ess,
        };
        self.last.clone()
    }

    fn check_size(&self, frame: &RgbFrame<'_>) -> Result<()> {
        let size = (frame.width(), frame.height());
        TrackingError::check_frame_size((self.width, self.height), size)
    }

    /// Takes `refined` as `r_t`: the image velocity follows its centroid (restarted after
    /// a re-acquisition), the area history its area.
    fn accept(&mut self, refined: Contour) {
        let (c0, c1) = (contour_centroid(&self.contour), contour_centroid(&refined));
        let area = polygon_area(&refined);
        if self.lost_frames > 0 {
            self.velocity = [0.0; 2];
            self.areas = [area, area];
        } else {
            let g = self.params.velocity_gain;
            for k in 0..2 {
                self.velocity[k] = (1.0 - g) * self.velocity[k] + g * (c1[k] - c0[k]);
            }
            self.areas = [area, self.areas[0]];
        }
        self.usual_area += USUAL_AREA_RATE * (area - self.usual_area);
        let spreads = polygon_spreads(&refined);
        for (u, s) in self.usual_spreads.iter_mut().zip(spreads) {
            *u += USUAL_AREA_RATE * (s - *u);
        }
        self.contour = refined;
        self.lost_frames = 0;
    }

    /// The window searched this frame: the predicted contour's box grown by
    /// `roi_margin` of its size plus the edge search, and while lost by a further
    /// `(2^k - 1) / 2` of its size after `k` lost frames, clipped to the frame.
    fn window(&self, predicted: &[[f64; 2]]) -> Roi {
        let b = BoundingBox::enclosing(predicted);
        let lost = self.lost_frames.min(12) as i32;
        let grow = self.params.roi_margin + 0.5 * (2f64.powi(lost) - 1.0);
        let mx = grow * b.w + self.params.search as f64;
        let my = grow * b.h + self.params.search as f64;
        Roi::clipped(
            b.x - mx,
            b.y - my,
            b.x + b.w + mx + 1.0,
            b.y + b.h + my + 1.0,
            self.width,
            self.height,
        )
    }

    /// Pixels between the cells of the samples' grid: the target's diameter (of a
    /// disc of its usual area) over `sample_cells`, at least 1.
    fn stride(&self) -> usize {
        let diameter = 2.0 * (self.usual_area / std::f64::consts::PI).sqrt();
        ((diameter / self.params.sample_cells).floor() as usize).clamp(1, 16)
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

/// The predicted contour filled (`prior`) and dilated by the snake's reach (`region`),
/// both as grid masks; buffers are reused.
fn prior_masks(
    predicted: &[[f64; 2]],
    grid: Grid,
    reach: usize,
    prior: &mut GrayImage,
    region: &mut GrayImage,
) {
    resize(prior, grid);
    let on_grid: Contour = predicted.iter().map(|&p| grid.to_grid(p)).collect();
    fill_polygon(&on_grid, 0.0, 0.0, prior);
    region.clone_from(prior);
    let cells = reach.div_ceil(grid.stride).min(255) as u8;
    dilate_mut(region, Norm::LInf, cells);
}

/// Contour refinement: the snake, started from the best sample's fit, is fitted to the
/// image edges `grad I` (Canny) masked by the dilated boundary of the best sample's blob,
/// `grad I . dil(grad S)`: the object's true edges, without the clutter. Falls back to the
/// sample's own fit when fewer than `refine_min_support` of the snake's points end on
/// those edges. The affine result is then relaxed onto the same edges (see [`relax`]).
fn refine(
    frame: &RgbFrame<'_>,
    ctx: &FrameContext<'_>,
    terms: SampleTerms,
    best: &mut SampleScratch,
    dilated: &mut GrayImage,
    snake: &mut SnakeScratch,
) -> Contour {
    let (p, roi, grid) = (ctx.params, ctx.roi, ctx.grid);
    let sample_edges = |x, y| grid.at(&best.edges, x, y);
    if !p.refine {
        return relax(
            best.snake.contour(),
            p.deform,
            p.deform_passes,
            sample_edges,
            snake,
        );
    }
    dilated.clone_from(&best.edges);
    dilate_mut(dilated, Norm::LInf, p.edge_dilation);
    let gray = GrayImage::from_fn(roi.width as u32, roi.height as u32, |u, v| {
        let px = &frame.row(roi.y0 + v as usize)[3 * (roi.x0 + u as usize)..][..3];
        image::Luma([rperc_core::image::luma(px[0], px[1], px[2])
            .round()
            .clamp(0.0, 255.0) as u8])
    });
    let image_edges = crate::frame::canny_edges(&gray, p.canny[0], p.canny[1]);
    let masked = |x: i64, y: i64| grid.at(dilated, x, y) && on(&image_edges, roi, x, y);
    let fit = fit_snake(ctx.predicted, terms.fit.affine, &ctx.snake, masked, snake);
    let contour = if fit.on_edge >= p.refine_min_support {
        let affine = snake.contour().to_vec();
        relax(&affine, p.deform, p.deform_passes, masked, snake)
    } else {
        let sample = best.snake.contour().to_vec();
        relax(&sample, p.deform, p.deform_passes, sample_edges, snake)
    };
    if p.pull_inside {
        pull_off_distractors(&contour, grid, best, p.deform_passes)
    } else {
        contour
    }
}

/// The refined contour with its points on a touching distractor pulled back.
fn pull_off_distractors(
    contour: &[[f64; 2]],
    grid: Grid,
    best: &SampleScratch,
    passes: usize,
) -> Contour {
    // The image-edge relaxation lets a few points follow a touching distractor's edges
    // a little further each frame, and the affine snake carries such a spike on to the
    // next frame; the segmentation has already told the distractor apart. So a point
    // more than a cell outside the blob but on the distractor (within a cell of the
    // segmentation) moves towards the blob's centroid to within a cell of it: a thread
    // of points has normals that miss the blob, a ray to the centre does not. With a
    // same-coloured object in the window every point that far out is pulled (a thread
    // towards it crosses the background); with none, points off the segmentation stay
    // (a rectangle notched by a highlight shrank when they were pulled too).
    let s = grid.stride as i64;
    let near = |m: &GrayImage, x: i64, y: i64| {
        (-1..=1).any(|dy| (-1..=1).any(|dx| grid.at(m, x + dx * s, y + dy * s)))
    };
    let inside = |x, y| near(&best.blob, x, y);
    let distractor = best
        .seg
        .iter()
        .zip(best.blob.iter())
        .any(|(&g, &b)| g != 0 && b == 0);
    let stay = |x, y| inside(x, y) || (!distractor && !near(&best.seg, x, y));
    let centre = grid.to_frame(blob_centroid(&best.blob));
    pull_radially(contour, centre, passes, stay, inside)
}

/// Mean cell of a grid mask, grid coordinates.
fn blob_centroid(blob: &GrayImage) -> [f64; 2] {
    let (mut n, mut sx, mut sy) = (0.0, 0.0, 0.0);
    for (x, y, v) in blob.enumerate_pixels() {
        if v[0] != 0 {
            (n, sx, sy) = (n + 1.0, sx + f64::from(x), sy + f64::from(y));
        }
    }
    if n > 0.0 {
        [sx / n, sy / n]
    } else {
        [0.0, 0.0]
    }
}

/// Intersection over union of the contour `r_t`, filled on the grid, and the best
/// sample's blob: the two disagree when the snake kept a stretched or drifted shape from
/// earlier frames while the segmentation found the target elsewhere, so a low overlap
/// means lost, whatever the snake's own score. `mask` is reused.
fn blob_overlap(contour: &[[f64; 2]], grid: Grid, blob: &GrayImage, mask: &mut GrayImage) -> f64 {
    resize(mask, grid);
    let on_grid: Contour = contour.iter().map(|&p| grid.to_grid(p)).collect();
    fill_polygon(&on_grid, 0.0, 0.0, mask);
    let (mut both, mut either) = (0usize, 0usize);
    for (&a, &b) in mask.as_raw().iter().zip(blob.as_raw()) {
        both += usize::from(a != 0 && b != 0);
        either += usize::from(a != 0 || b != 0);
    }
    if either == 0 {
        0.0
    } else {
        both as f64 / either as f64
    }
}

/// The affine snake's settings from the tracker's.
fn snake_params(p: &ColorShapeParams) -> SnakeParams {
    SnakeParams {
        search: p.search,
        min_search: p.min_search,
        iterations: p.snake_iterations,
        on_edge_tolerance: p.edge_tolerance,
        stiffness: p.stiffness,
    }
}

/// A contour accepted with at least this score is remembered as the target's shape.
const GOOD_SHAPE_SCORE: f64 = 0.5;

/// Rate of the exponential average that gives the target's usual area.
const USUAL_AREA_RATE: f64 = 0.05;

/// Smaller area over larger, in [0, 1].
fn area_ratio(a: f64, b: f64) -> f64 {
    a.min(b) / a.max(b).max(1e-9)
}

fn distribution_of(s: &State) -> [f64; N_PARAMS] {
    std::array::from_fn(|i| s[i])
}

/// A starting contour holds at least 3 finite points and lies inside the frame, by the
/// rule every box obeys ([`BoundingBox::check_inside`]): the one finite-range check of
/// a coordinate input. A contour outside the frame panicked on an empty window, and
/// one of 1e300 came back as a box of 1e300 (issue 38).
fn check_contour(contour: &[[f64; 2]], width: usize, height: usize) -> Result<()> {
    if contour.len() < 3 || contour.iter().flatten().any(|v| !v.is_finite()) {
        return Err(TrackingError::InvalidParameter {
            name: "contour",
            reason: format!("need >= 3 finite points, got {}", contour.len()),
        });
    }
    let b = BoundingBox::enclosing(contour);
    // A thin contour still encloses pixels: only its position is checked here.
    let outer = BoundingBox {
        w: b.w.max(1.0),
        h: b.h.max(1.0),
        ..b
    };
    outer
        .check_inside(width, height)
        .map_err(|_| TrackingError::InvalidParameter {
            name: "contour",
            reason: format!(
                "its box ({:?}, {:?}, {:?}, {:?}) is not inside the {width}x{height} frame",
                b.x, b.y, b.w, b.h
            ),
        })
}

/// Mean of a contour's points.
pub(crate) fn contour_centroid(c: &[[f64; 2]]) -> [f64; 2] {
    let n = c.len().max(1) as f64;
    let (sx, sy) = c.iter().fold((0.0, 0.0), |(a, b), p| (a + p[0], b + p[1]));
    [sx / n, sy / n]
}
