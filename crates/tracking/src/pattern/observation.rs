//! The observation model of section 3.3 (eqs. 5-6): the likelihood of a state
//! `X = (x, y, theta, s)` from the inter-correlation of each model point's stored and
//! observed grey-level vectors, with occlusion and scale space handling.

use super::correlation::{autocorrelation_curvature, centred_products, energy};
use super::model::{DeviationModel, PatternModel, sample_along, segment};
use rayon::prelude::*;
use std::sync::Arc;

use crate::condensation::Likelihood;
use crate::error::Result;
use nalgebra::SVector;
use rperc_core::image::GrayImage;

mod newton;
pub use newton::NormalEquations;

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
    /// The top-left pixel of the union of the levels' windows in the frame.
    origin: [f64; 2],
    crop: GrayImage,
    kernels: Vec<(f64, Arc<[f32]>)>,
    /// Levels not used by the last build, kept for their buffers.
    spare: Vec<Level>,
}

/// One level of a [`ScaleSpace`] with its own work buffers (one per band of rows),
/// so that levels, and bands of one level, blur in parallel.
#[derive(Debug, Clone, Default)]
struct Level {
    image: GrayImage,
    /// The level's window inside the crop, `[x0, y0, x1, y1)`.
    inner: [usize; 4],
    /// Its top-left pixel in the frame.
    origin: [f64; 2],
    kernel: Arc<[f32]>,
    scratch: Vec<GrayImage>,
    /// Blurred for this frame (see [`ScaleSpace::build_window_for`]).
    ready: bool,
}

/// Rows `window` of a level's blur, computed as one task into `out`, their part of
/// the level's image.
struct Band<'a> {
    kernel: &'a [f32],
    window: [usize; 4],
    scratch: &'a mut GrayImage,
    out: &'a mut [f32],
}

impl Level {
    fn blur(&mut self, crop: &GrayImage) {
        // Only the window: the crop's margin is there to be read, not kept.
        let inner = self.inner;
        if self.scratch.is_empty() {
            self.scratch.push(GrayImage::default());
        }
        crop.convolve_separable_window(&self.kernel, inner, &mut self.scratch[0], &mut self.image);
        self.ready = true;
    }

    /// The level's window cut into `n` bands of rows, each with its own scratch and
    /// its rows of the level's image (sized here): blurred separately, they hold the
    /// whole window's numbers (`GrayImage::convolve_separable_window_into`).
    fn bands(&mut self, crop: &GrayImage, n: usize) -> Vec<Band<'_>> {
        let [x0, y0, x1, y1] = crop.clamp_window(self.inner);
        let (width, height) = (x1 - x0, y1 - y0);
        self.image.width = width;
        self.image.height = height;
        self.image.data.resize(width * height, 0.0);
        self.ready = true;
        let rows = height.div_ceil(n.max(1)).max(1);
        if width * height == 0 {
            return Vec::new();
        }
        self.scratch
            .resize_with(height.div_ceil(rows), GrayImage::default);
        let kernel = &self.kernel[..];
        self.image
            .data
            .chunks_mut(width * rows)
            .zip(self.scratch.iter_mut())
            .enumerate()
            .map(|(i, (out, scratch))| {
                let top = y0 + i * rows;
                Band {
                    kernel,
                    window: [x0, top, x1, (top + rows).min(y1)],
                    scratch,
                    out,
                }
            })
            .collect()
    }
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
        self.build_window_for(size, copy, model, window, span, None)
    }

    /// [`Self::build_window`] on a frame of `size = [width, height]` that `crop` reads
    /// on demand (`crop(window, out)` fills `out` with the frame's grey levels inside
    /// `window = [x0, y0, x1, y1)`: a tracker converts only that part of an 8-bit
    /// frame, not all of it), blurring, of the levels of `span`, only those nearest to
    /// one of the scales `needed` (the particles' and the reference state's; all of
    /// them for `None`); [`Self::ensure`] blurs others later from the same crop (the
    /// refinement's, once its start is known). Every state whose
    /// nearest level of `span` is blurred reads the same values as from the whole
    /// stack: [`Self::level`] takes the nearest blurred level.
    pub fn build_window_for(
        &mut self,
        size: [usize; 2],
        crop: impl FnOnce([usize; 4], &mut GrayImage),
        model: &PatternModel,
        window: [usize; 4],
        span: [f64; 2],
        needed: Option<&[f64]>,
    ) -> Result<()> {
        self.build_windows_for(size, crop, model, |_| window, span, needed)
    }

    /// [`Self::build_window_for`] with a window per level: `window(cell)` is the window
    /// `[x0, y0, x1, y1)` a level must cover for the states whose scale lies in `cell
    /// = [s_lo, s_hi]`, the scales of `span` nearest to that level (a pattern seen at
    /// a smaller scale covers fewer pixels). Each level then reads, inside its window,
    /// the same values as the whole frame's blur; [`Self::level_at`] gives its origin.
    pub fn build_windows_for(
        &mut self,
        size: [usize; 2],
        crop: impl FnOnce([usize; 4], &mut GrayImage),
        model: &PatternModel,
        mut window: impl FnMut([f64; 2]) -> [usize; 4],
        span: [f64; 2],
        needed: Option<&[f64]>,
    ) -> Result<()> {
        let wanted = self.choose_levels(model, span, needed);
        let union = self.level_windows(size, &mut window, span);
        self.crop_for_levels(size, union, crop);
        self.blur_levels(&wanted);
        Ok(())
    }

    /// Takes the levels of `model`'s stack nearest to the ends of `span` and those
    /// between, each with its kernel, none blurred yet; returns which of them to blur
    /// now: all of them, or (with `needed`) those nearest to one of its scales.
    fn choose_levels(
        &mut self,
        model: &PatternModel,
        span: [f64; 2],
        needed: Option<&[f64]>,
    ) -> Vec<bool> {
        let config = &model.config;
        let all = &config.scale_levels;
        // Clamped first: infinite spans (the whole stack) would tie every level.
        let (first, last) = (all[0], all[all.len() - 1]);
        let lo = nearest(all, span[0].clamp(first, last));
        let hi = nearest(all, span[1].clamp(first, last));
        self.scales.clear();
        self.scales.extend_from_slice(&all[lo..=hi.max(lo)]);
        // Levels beyond this frame's wait in `spare` with their buffers: a frame
        // needing one more level would otherwise allocate (and fault in) new ones.
        let n = self.scales.len();
        if self.levels.len() > n {
            self.spare.extend(self.levels.drain(n..));
        }
        while self.levels.len() < n {
            self.levels.push(self.spare.pop().unwrap_or_default());
        }
        for (level, &s) in self.levels.iter_mut().zip(&self.scales) {
            level.kernel = kernel(&mut self.kernels, config.blur_sigma * s);
            level.ready = false;
        }
        let mut wanted = vec![needed.is_none(); self.scales.len()];
        for &s in needed.unwrap_or(&[]) {
            wanted[nearest(&self.scales, s)] = true;
        }
        wanted
    }

    /// Sets each level's window in the frame, clipped to `size`: the window its cell
    /// of `span` (the scales nearest to it, both ends of a tie) needs. Returns their
    /// union.
    fn level_windows(
        &mut self,
        [width, height]: [usize; 2],
        window: &mut impl FnMut([f64; 2]) -> [usize; 4],
        span: [f64; 2],
    ) -> [usize; 4] {
        let clip = |w: [usize; 4]| {
            let [x0, y0] = [w[0].min(width), w[1].min(height)];
            [x0, y0, w[2].clamp(x0, width), w[3].clamp(y0, height)]
        };
        let n = self.scales.len();
        let mut union = [usize::MAX, usize::MAX, 0, 0];
        for k in 0..n {
            let lo = if k == 0 {
                span[0]
            } else {
                0.5 * (self.scales[k - 1] + self.scales[k])
            };
            let hi = if k + 1 == n {
                span[1]
            } else {
                0.5 * (self.scales[k] + self.scales[k + 1])
            };
            let w = clip(window([lo.max(span[0]), hi.min(span[1])]));
            self.levels[k].inner = w;
            union = [
                union[0].min(w[0]),
                union[1].min(w[1]),
                union[2].max(w[2]),
                union[3].max(w[3]),
            ];
        }
        clip(union)
    }

    /// Crops the frame once for every level: the `union` of their windows grown by
    /// the widest kernel's radius, so that each level blurs its window from the crop,
    /// which lies at least its own radius inside the crop wherever the crop does not
    /// stop at the frame's edge. Each level's window becomes its place in the crop.
    fn crop_for_levels(
        &mut self,
        [width, height]: [usize; 2],
        [x0, y0, x1, y1]: [usize; 4],
        crop: impl FnOnce([usize; 4], &mut GrayImage),
    ) {
        self.origin = [x0 as f64, y0 as f64];
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
        for level in &mut self.levels {
            let [a, b, c, d] = level.inner;
            // An empty window (a level no state can use) sits at the union's corner.
            let [a, b] = if a < c && b < d { [a, b] } else { [x0, y0] };
            let [c, d] = [c.max(a), d.max(b)];
            level.origin = [a as f64, b as f64];
            level.inner = [a - grown[0], b - grown[1], c - grown[0], d - grown[1]];
        }
    }

    /// Blurs the levels nearest to the scales of `span = [s_lo, s_hi]` and those
    /// between, among the levels of the last build, that are not blurred yet.
    pub fn ensure(&mut self, span: [f64; 2]) {
        if self.scales.is_empty() || span.iter().any(|v| v.is_nan()) || span[0] > span[1] {
            return;
        }
        let (lo, hi) = (
            nearest(&self.scales, span[0]),
            nearest(&self.scales, span[1]),
        );
        let wanted: Vec<bool> = (0..self.levels.len())
            .map(|k| (lo..=hi).contains(&k) && !self.levels[k].ready)
            .collect();
        self.blur_levels(&wanted);
    }

    /// Blurs, among the levels of the last build, those nearest to one of `scales`
    /// that are not blurred yet (as the build blurs those of its `needed`).
    pub fn ensure_nearest(&mut self, scales: &[f64]) {
        if self.scales.is_empty() {
            return;
        }
        let mut wanted = vec![false; self.levels.len()];
        for &s in scales.iter().filter(|s| !s.is_nan()) {
            wanted[nearest(&self.scales, s)] = true;
        }
        for (w, level) in wanted.iter_mut().zip(&self.levels) {
            *w &= !level.ready;
        }
        self.blur_levels(&wanted);
    }

    /// Blurs the levels `k` with `wanted[k]`, in parallel when there is enough work
    /// and it runs on a worker of the rayon pool:
    /// each level in as many bands of rows as there are threads, so that one large
    /// level (the usual case) uses every core too. The numbers do not depend on the
    /// banding.
    fn blur_levels(&mut self, wanted: &[bool]) {
        let crop = &self.crop;
        let chosen = || self.levels.iter().zip(wanted).filter(|(_, w)| **w);
        let taps: usize = chosen().map(|(l, _)| l.kernel.len()).sum();
        // Only from a worker of the pool (a tracker's parallel update runs there):
        // from any other thread each fork would be a hand-over to the pool.
        let threads = rayon::current_num_threads();
        let parallel = rayon::current_thread_index().is_some()
            && threads > 1
            && crop.data.len() * taps >= PARALLEL_BLUR_WORK;
        let levels = self.levels.iter_mut().zip(wanted).filter(|(_, w)| **w);
        if parallel {
            let mut bands: Vec<Band<'_>> =
                levels.flat_map(|(l, _)| l.bands(crop, threads)).collect();
            bands.par_iter_mut().for_each(|b| {
                crop.convolve_separable_window_into(b.kernel, b.window, b.scratch, b.out);
            });
        } else {
            levels.for_each(|(l, _)| l.blur(crop));
        }
    }

    /// Pixel coordinates in the frame of the top-left pixel of the union of the
    /// levels' windows (every level's with [`Self::build_window`]).
    pub fn origin(&self) -> [f64; 2] {
        self.origin
    }

    /// The blurred level nearest to scale `s` (the first one for `s <= 1`).
    pub fn level(&self, s: f64) -> &GrayImage {
        self.level_at(s).0
    }

    /// [`Self::level`] and the frame coordinates of its top-left pixel.
    pub fn level_at(&self, s: f64) -> (&GrayImage, [f64; 2]) {
        let k = self
            .levels
            .iter()
            .zip(&self.scales)
            .enumerate()
            .filter(|(_, (l, _))| l.ready)
            .min_by(|a, b| (a.1.1 - s).abs().total_cmp(&(b.1.1 - s).abs()))
            .map_or(0, |(k, _)| k);
        let level = &self.levels[k];
        (&level.image, level.origin)
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

/// Per-chunk buffers of [`PatternLikelihood`]: one observed vector and the point
/// deviations, so that no particle allocates, and the best log-likelihood met so far
/// in the chunk by a likelihood with an early exit (and which one it was).
#[derive(Debug, Clone, Default)]
pub struct PatternScratch {
    observed: Vec<f32>,
    deviations: Vec<f64>,
    best: f64,
    generation: u64,
}

/// The observation model of one frame: a model and the frame's scale space.
#[derive(Debug, Clone)]
pub struct PatternLikelihood<'a> {
    model: &'a PatternModel,
    space: &'a ScaleSpace,
    /// The model points in the order they are visited: interleaved along the
    /// contours, so that any first few of them spread over the whole pattern (shared:
    /// computed once per model, see [`PointTable`]).
    table: PointTable,
    /// How many of them are weighed ([`Self::with_points`]).
    count: usize,
    early_exit: Option<EarlyExit>,
}

/// See [`PatternLikelihood::with_early_exit`].
#[derive(Debug, Clone, Copy)]
struct EarlyExit {
    margin: f64,
    generation: u64,
    reference: f64,
}

/// How [`PatternLikelihood::fill_deviations`] values a state it stops early on.
#[derive(Debug, Clone, Copy)]
enum Stop {
    /// The cost of the points seen: an upper bound of the log-likelihood.
    Bound,
    /// The cost of the points seen scaled to all points, from
    /// [`EXTRAPOLATE_AFTER`] points on: an estimate.
    Extrapolate,
}

impl Stop {
    fn min_points(self) -> usize {
        match self {
            Stop::Bound => 0,
            Stop::Extrapolate => EXTRAPOLATE_AFTER,
        }
    }
}

/// Points seen before [`PatternLikelihood::with_early_exit`] extrapolates a state's
/// log-likelihood.
pub const EXTRAPOLATE_AFTER: usize = 8;

/// Model points sampled and correlated together (and between two checks of the early
/// exit's bound).
const BATCH: usize = 8;

/// Tells apart the likelihoods with an early exit, so that a scratch carried over
/// from another frame does not bring its best log-likelihood along.
static GENERATION: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);

/// The order model points are visited in: `0, k, 2k, ... (mod n)` with the stride `k`
/// near `n / golden ratio` and prime to `n`, a permutation that spreads consecutive
/// visits over the contours.
fn interleaved(n: usize) -> impl Iterator<Item = usize> {
    let gcd = |mut a: usize, mut b: usize| {
        while b != 0 {
            (a, b) = (b, a % b);
        }
        a
    };
    let mut stride = ((n as f64 * 0.618_034).round() as usize).max(1);
    while n > 1 && gcd(stride, n) != 1 {
        stride += 1;
    }
    (0..n).map(move |k| (k * stride) % n)
}

/// What a particle needs of a model point besides its vector, computed once per frame
/// (not per particle): its pixel offset, the unit vector of its gradient direction, its
/// vector's energy and sum, and the inverse of its `C~`'s parameter (`1 / |W|` for the
/// line, `1 / a` for the parabola), so that `lambda` costs no division.
#[derive(Debug, Clone, Copy)]
struct PointGeometry {
    index: usize,
    offset: [f64; 2],
    direction: [f64; 2],
    energy: f64,
    sum: f32,
    inverse_width: f64,
}

impl PointGeometry {
    /// The point's position and gradient direction for a state whose centre is
    /// `centre` (level pixels), rotation `[sin theta, cos theta]` and scale `scale`:
    /// `centre + s R (dx, dy)` and `R (cos phi, sin phi)`, `R = [[c, s], [-s, c]]` (see
    /// [`place`]).
    #[inline]
    fn placed(&self, centre: [f64; 2], [sin, cos]: [f64; 2], scale: f64) -> ([f64; 2], [f64; 2]) {
        let [dx, dy] = self.offset;
        let p = [
            centre[0] + scale * (cos * dx + sin * dy),
            centre[1] + scale * (-sin * dx + cos * dy),
        ];
        let [u, v] = self.direction;
        (p, [cos * u + sin * v, -sin * u + cos * v])
    }

    /// `lambda^2` of eq. 6 for inter-correlation `c`: `((1 - c) / |W|)^2` for the
    /// line, `(1 - c) / a` for the parabola (`correlation::deviation`,
    /// `correlation::deviation_parabolic`, squared).
    #[inline]
    fn squared_deviation(&self, c: f64, model: DeviationModel) -> f64 {
        // Not `max`: a NaN correlation (a corrupt frame) must stay NaN.
        let gap = (1.0 - c) * self.inverse_width;
        let gap = if gap < 0.0 { 0.0 } else { gap };
        match model {
            DeviationModel::Line => gap * gap,
            DeviationModel::Parabola => gap,
        }
    }
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

/// What a [`PatternLikelihood`] needs of each model point besides its vector, in the
/// order the points are visited: computed once per model (a tracker keeps it from
/// frame to frame) and shared without copying.
#[derive(Debug, Clone)]
pub(crate) struct PointTable {
    points: Arc<[PointGeometry]>,
    /// The largest distance of a point from the centre (pixels at scale 1).
    radius: f64,
}

impl PointTable {
    /// The table of `model`.
    pub(crate) fn new(model: &PatternModel) -> Self {
        let config = &model.config;
        let points = interleaved(model.points.len())
            .map(|j| {
                let point = &model.points[j];
                let (s, c) = point.phi.sin_cos();
                // As `correlation::deviation(_parabolic)`: a zero parameter gives a huge
                // deviation.
                let width = match config.deviation {
                    DeviationModel::Line => point.slope.abs(),
                    DeviationModel::Parabola => {
                        autocorrelation_curvature(&point.vector, config.fit_lags)
                    }
                };
                PointGeometry {
                    index: j,
                    offset: model.offset(j),
                    direction: [c, s],
                    energy: energy(&point.vector),
                    sum: point.vector.iter().sum(),
                    inverse_width: 1.0 / width.max(f64::MIN_POSITIVE),
                }
            })
            .collect::<Arc<[PointGeometry]>>();
        let radius = points
            .iter()
            .map(|g| g.offset[0].hypot(g.offset[1]))
            .fold(0.0, f64::max);
        Self { points, radius }
    }

    /// The table of the same points seen through the projective rest `rest` of the
    /// homography mode ([`super::homography::split`]): each offset moved by it and
    /// each direction by its Jacobian there, unnormalised, so that a profile's step
    /// stretches as the plane does. The similarity of a state then places them as
    /// usual, which places the model by the homography `S rest` (profiles straight
    /// and evenly spaced, to first order). `half_profile` is half a profile's length
    /// at scale 1 (pixels), which the bound of the interior check grows by a
    /// stretch. `None` when `rest` sends a point to infinity.
    pub(crate) fn warped(&self, rest: &nalgebra::Matrix3<f64>, half_profile: f64) -> Option<Self> {
        use super::homography::{apply, jacobian};
        let mut radius = 0.0f64;
        let points = self
            .points
            .iter()
            .map(|g| {
                let offset = apply(rest, g.offset)?;
                let [[a, b], [c, d]] = jacobian(rest, g.offset)?;
                let [u, v] = g.direction;
                let direction = [a * u + b * v, c * u + d * v];
                let stretch = direction[0].hypot(direction[1]);
                let reach = offset[0].hypot(offset[1]) + half_profile * (stretch - 1.0).max(0.0);
                radius = radius.max(reach);
                Some(PointGeometry {
                    offset,
                    direction,
                    ..*g
                })
            })
            .collect::<Option<Arc<[PointGeometry]>>>()?;
        Some(Self { points, radius })
    }

    /// The model point offsets in visiting order (pixels from the centre, as placed
    /// at scale 1).
    pub(crate) fn offsets(&self) -> impl Iterator<Item = [f64; 2]> + '_ {
        self.points.iter().map(|g| g.offset)
    }
}

impl<'a> PatternLikelihood<'a> {
    /// The observation model of `model` in the frame whose scale space is `space`.
    pub fn new(model: &'a PatternModel, space: &'a ScaleSpace) -> Self {
        Self::with_table(model, space, &PointTable::new(model))
    }

    /// [`Self::new`] with the point table of `model` computed before ([`PointTable::new`]
    /// of the same model, which the crate's callers keep with it): nothing is
    /// computed or allocated.
    pub(crate) fn with_table(
        model: &'a PatternModel,
        space: &'a ScaleSpace,
        table: &PointTable,
    ) -> Self {
        Self {
            model,
            space,
            table: table.clone(),
            count: table.points.len(),
            early_exit: None,
        }
    }

    /// The points weighed, in their visiting order.
    fn points(&self) -> &[PointGeometry] {
        &self.table.points[..self.count]
    }

    /// The indices of the model points in the order they are visited (interleaved
    /// along the contours).
    pub fn visiting_order(&self) -> impl Iterator<Item = usize> + '_ {
        self.points().iter().map(|g| g.index)
    }

    /// The same observation model on the first `count` model points of its visiting
    /// order only (interleaved along the contours, so that they spread over the whole
    /// pattern): a cheaper, coarser likelihood.
    pub fn with_points(&self, count: usize) -> Self {
        let mut out = self.clone();
        out.count = count.max(1).min(self.count);
        out
    }

    /// The same observation model, whose [`Likelihood::log_likelihood`] stops early on
    /// states that do not matter: within one chunk of particles (weighed in order on
    /// one scratch), once [`EXTRAPOLATE_AFTER`] points or more (interleaved over the
    /// contours) put a state's log-likelihood, extrapolated to all points, more than
    /// `margin` below the best one met before it in the chunk, it gets that
    /// extrapolation instead of its value. Its weight is then about `exp(-margin)`
    /// times the best particle's or less (a margin of 30 is a relative weight of
    /// 1e-13): eq. 6 is so sharp that one particle carries nearly all the weight, and
    /// most particles are that far below it. The answer still depends only on the
    /// chunk's particles, never on the number of threads. [`Self::observe`] and
    /// [`Self::observe_above`] stay exact.
    pub fn with_early_exit(mut self, margin: f64) -> Self {
        use std::sync::atomic::Ordering;
        let generation = GENERATION.fetch_add(1, Ordering::Relaxed);
        self.early_exit = Some(EarlyExit {
            margin,
            generation,
            reference: f64::NEG_INFINITY,
        });
        self
    }

    /// With an early exit, every chunk starts as if it had already met a state of
    /// log-likelihood `reference` (a tracker's last estimate on the new frame, weighed
    /// before the particles), so that its first particles can be cut short too. Does
    /// nothing without [`Self::with_early_exit`].
    pub fn with_reference(mut self, reference: f64) -> Self {
        if let Some(exit) = &mut self.early_exit {
            exit.reference = reference;
        }
        self
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
        self.observe_until(state, scratch, f64::NEG_INFINITY, Stop::Bound)
    }

    /// [`Self::observe`], or, once the points seen bound the log-likelihood below
    /// `floor`, that upper bound and the occluded fraction of the points seen: the
    /// exact answer whenever it is `>= floor`. Each point adds at least `min(lambda,
    /// T)^2 / (2 sigma^2)` to the cost of eq. 6 (a left-out point adds `T^2` and is
    /// above `T`), so the points seen bound the log-likelihood from above.
    pub fn observe_above(
        &self,
        state: &SVector<f64, 4>,
        scratch: &mut PatternScratch,
        floor: f64,
    ) -> Observation {
        self.observe_until(state, scratch, floor, Stop::Bound)
    }

    /// [`Self::observe`], stopped by the rule `stop` below `floor`.
    fn observe_until(
        &self,
        state: &SVector<f64, 4>,
        scratch: &mut PatternScratch,
        floor: f64,
        stop: Stop,
    ) -> Observation {
        let n = self.points().len();
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
        let config = &self.model.config;
        // Deviations are kept squared (the parabola gives `lambda^2` without a root).
        let threshold = config.occlusion_threshold * config.occlusion_threshold;
        if let Some(bound) = self.fill_deviations(state, scratch, floor, stop) {
            let d = &scratch.deviations;
            let occluded = d.iter().filter(|&&l| l > threshold).count();
            return Observation {
                log_likelihood: bound,
                occluded_fraction: occluded as f64 / d.len() as f64,
            };
        }
        let (mut occluded, mut below) = (0usize, 0.0);
        for &l in &scratch.deviations {
            if l > threshold {
                occluded += 1;
            } else {
                below += l;
            }
        }
        let allowed = (config.max_occluded_fraction * n as f64).floor() as usize;
        let tolerated = allowed.min(occluded);
        // The `tolerated` largest deviations are left out. When every occluded point is
        // (the usual case) they are exactly those above the threshold; otherwise the
        // occluded ones beyond the tolerated count with their own terms, the smallest
        // first.
        let mut squares = below;
        if occluded > tolerated {
            let d = &mut scratch.deviations;
            // (With none tolerated, every point counts: nothing to select, and
            // selecting the n-th of n would panic.)
            if tolerated > 0 {
                d.select_nth_unstable_by(n - tolerated, |a, b| a.total_cmp(b));
            }
            squares += d[..n - tolerated]
                .iter()
                .filter(|&&l| l > threshold)
                .sum::<f64>();
        }
        let inv = 1.0 / (2.0 * config.sigma * config.sigma);
        let left_out = tolerated as f64 * threshold;
        Observation {
            log_likelihood: -(squares + left_out) * inv,
            occluded_fraction: occluded as f64 / n as f64,
        }
    }

    /// Whether every profile of a state at `centre` (level pixels) and `scale`, with
    /// `n` samples `step` apart, lies within the bounds of
    /// [`GrayImage::sample_line_interior`] in `image`: points lie within `scale *
    /// radius` of the centre and profiles reach half their length from them (plus a
    /// millipixel for the rounding of the positions), checked once per state instead
    /// of once per point.
    fn inside(&self, image: &GrayImage, centre: [f64; 2], scale: f64, step: f64, n: usize) -> bool {
        use rperc_core::image::INTERIOR_MARGIN;
        let reach = scale * self.table.radius + 0.5 * (n as f64 - 1.0) * step.abs() + 1e-3;
        let (w, h) = (image.width as f64, image.height as f64);
        let huge = 1usize << 36;
        centre[0] - reach >= INTERIOR_MARGIN
            && centre[1] - reach >= INTERIOR_MARGIN
            && centre[0] + reach <= w - 1.0 - INTERIOR_MARGIN
            && centre[1] + reach <= h - 1.0 - INTERIOR_MARGIN
            && (1..=1024).contains(&n)
            && (2..=huge).contains(&image.width)
            && (2..=huge).contains(&image.height)
    }

    /// The squared deviation `lambda^2` of every model point for `state` into
    /// `scratch.deviations`
    /// (infinite when the observed vector leaves the frame), in the order of
    /// `self.points`; or, as soon as the points seen put the log-likelihood below
    /// `floor` by the rule `stop` (checked every [`BATCH`] points), its value by that
    /// rule.
    ///
    /// The similarity of [`place`] with `sin theta` and `cos theta` taken once per
    /// state: a point's position is `centre + s R (dx, dy)` and its direction `R (cos
    /// phi, sin phi)`, i.e. `phi - theta`, with `R = [[c, s], [-s, c]]`.
    fn fill_deviations(
        &self,
        state: &SVector<f64, 4>,
        scratch: &mut PatternScratch,
        floor: f64,
        stop: Stop,
    ) -> Option<f64> {
        let config = &self.model.config;
        let bounded = floor > f64::NEG_INFINITY;
        let inv = 1.0 / (2.0 * config.sigma * config.sigma);
        let mut cost = 0.0;
        let placed = self.placement(state);
        let ns = config.n_samples;
        scratch.observed.resize(BATCH * ns, 0.0);
        scratch.deviations.clear();
        let n = self.points().len();
        // A batch of points is sampled, then correlated, then turned into deviations:
        // the square roots and divisions of a batch overlap instead of each waiting for
        // its own point's samples.
        for (b, batch) in self.points().chunks(BATCH).enumerate() {
            let inside = placed.sample_batch(batch, &mut scratch.observed, ns);
            self.batch_deviations(batch, &inside, scratch, &mut cost);
            let seen = (b + 1) * BATCH;
            if bounded && seen < n {
                let bound = -cost * inv;
                let cut = match stop {
                    Stop::Bound => bound,
                    Stop::Extrapolate => bound * n as f64 / seen as f64,
                };
                if seen >= stop.min_points() && cut < floor {
                    return Some(cut);
                }
            }
        }
        None
    }

    /// Where `state` puts the model in its scale-space level: the level, the centre in
    /// its pixels, the rotation and scale, the profiles' step and whether every
    /// profile lies in the interior (see [`Self::inside`]).
    fn placement(&self, state: &SVector<f64, 4>) -> Placement<'_> {
        let config = &self.model.config;
        let (image, origin) = self.space.level_at(state[3]);
        let scale = state[3];
        let centre = [state[0] - origin[0], state[1] - origin[1]];
        let step = config.delta * scale;
        let interior = self.inside(image, centre, scale, step, config.n_samples);
        let (sin, cos) = state[2].sin_cos();
        Placement {
            image,
            centre,
            sin_cos: [sin, cos],
            scale,
            step,
            interior,
        }
    }

    /// Correlates a sampled batch with the model's vectors and pushes each point's
    /// squared deviation into `scratch.deviations` (infinite where it left the frame
    /// or met a NaN); adds each deviation, capped at the occlusion threshold, to
    /// `cost` in point order (one running sum, as the early exit's bound expects).
    fn batch_deviations(
        &self,
        batch: &[PointGeometry],
        inside: &[bool; BATCH],
        scratch: &mut PatternScratch,
        cost: &mut f64,
    ) {
        let config = &self.model.config;
        let threshold = config.occlusion_threshold * config.occlusion_threshold;
        let ns = config.n_samples;
        let mut products = [(0.0f32, 0.0f32); BATCH];
        let buffers = scratch.observed.chunks_exact(ns);
        for ((geometry, product), observed) in batch.iter().zip(&mut products).zip(buffers) {
            let stored = &self.model.points[geometry.index].vector;
            *product = centred_products(stored, geometry.sum, observed);
        }
        for ((geometry, &(dot, energy)), &ok) in batch.iter().zip(&products).zip(inside) {
            let norm = f64::from(energy) * geometry.energy;
            // The inter-correlation of section 3.3, 0 for a flat vector.
            let c = if norm > 1e-18 {
                f64::from(dot) / norm.sqrt()
            } else {
                0.0
            };
            let squared = geometry.squared_deviation(c, config.deviation);
            // Outside the frame, or a NaN grey level (a corrupt frame): the point is
            // occluded, the sum is not NaN.
            let squared = if ok && !squared.is_nan() {
                squared
            } else {
                f64::INFINITY
            };
            scratch.deviations.push(squared);
            *cost += squared.min(threshold);
        }
    }
}

/// A state's model placed in its scale-space level (see
/// [`PatternLikelihood::placement`]).
struct Placement<'a> {
    image: &'a GrayImage,
    centre: [f64; 2],
    sin_cos: [f64; 2],
    scale: f64,
    step: f64,
    interior: bool,
}

impl Placement<'_> {
    /// Samples each point's profile of `batch` into its `ns`-long slice of
    /// `observed`; whether each stayed in the frame.
    fn sample_batch(
        &self,
        batch: &[PointGeometry],
        observed: &mut [f32],
        ns: usize,
    ) -> [bool; BATCH] {
        let mut inside = [false; BATCH];
        let buffers = observed.chunks_exact_mut(ns);
        for ((geometry, ok), out) in batch.iter().zip(&mut inside).zip(buffers) {
            let (p, direction) = geometry.placed(self.centre, self.sin_cos, self.scale);
            *ok = if self.interior {
                // As `sample_along`, without its checks.
                let (start, delta) = segment(p, direction, self.step, out.len());
                self.image.sample_line_interior(start, delta, out)
            } else {
                sample_along(self.image, p, direction, self.step, out)
            };
        }
        inside
    }
}

impl Likelihood<4> for PatternLikelihood<'_> {
    type Scratch = PatternScratch;

    fn new_scratch(&self) -> PatternScratch {
        PatternScratch {
            observed: Vec::with_capacity(self.model.config.n_samples),
            deviations: Vec::with_capacity(self.model.points.len()),
            best: f64::NEG_INFINITY,
            generation: 0,
        }
    }

    fn log_likelihood(&self, state: &SVector<f64, 4>, scratch: &mut PatternScratch) -> f64 {
        let Some(exit) = self.early_exit else {
            return self.observe(state, scratch).log_likelihood;
        };
        if scratch.generation != exit.generation {
            scratch.generation = exit.generation;
            scratch.best = exit.reference;
        }
        let floor = scratch.best - exit.margin;
        let ll = self
            .observe_until(state, scratch, floor, Stop::Extrapolate)
            .log_likelihood;
        scratch.best = scratch.best.max(ll);
        ll
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
