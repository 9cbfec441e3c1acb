//! CONDENSATION over (x, y, scale) with the histogram-intersection likelihood: many
//! hypotheses instead of one local search, for clutter and fast motion.

use nalgebra::{Matrix3, SVector, Vector3};

use super::ellipse::{Ellipse, half_width, vertical_radius};
use super::gradient::GradientImage;
use super::model::{AppearanceParams, ColourModel};
use super::space::BinImage;
use super::tracker::{TrackResult, check_search_radii, pixel_centre};
use crate::condensation::{FilterParams, Likelihood, LinearGaussian, ParticleFilter};
use rperc_core::{MAX_PARTICLES, ensure_positive as positive};

use crate::error::{Result, TrackingError};
use crate::frame::{BoundingBox, RgbFrame};

/// Parameters of a [`ParticleColorTracker`].
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct ParticleTrackerParams {
    /// Colour model, adaptation and gradient term.
    pub appearance: AppearanceParams,
    /// Number of particles, >= 1. Default 200.
    pub n_particles: usize,
    /// Standard deviation of the per-frame random walk of the centre, as a fraction of
    /// the initial box's mean half-size. Default 0.25.
    pub position_noise: f64,
    /// Standard deviation of the per-frame random walk of the scale. Default 0.02.
    pub scale_noise: f64,
    /// `sigma` of the weight `exp(-rho^2 / (2 sigma^2))` (seed 000 section 3.3) with
    /// `rho = 1 - intersection` (+ the gradient term). Default 0.1.
    pub sigma: f64,
    /// Smallest scale relative to the initial box, > 0. Default 0.5.
    pub min_scale: f64,
    /// Largest scale relative to the initial box. Default 2.0.
    pub max_scale: f64,
    /// Share of the particles redrawn each frame around the best centre of a coarse
    /// local search (a mixture proposal), in [0, 0.99]. Default 0.1 (set on the fast
    /// challenge sequences and Couple); 0 is plain CONDENSATION.
    pub mix_fraction: f64,
    /// Half-size in pixels of that search's window when the target is still. Default 10.
    pub search_radius: usize,
    /// The window grows by this times the estimated speed (px per frame). Default 1.5.
    pub velocity_gain: f64,
    /// Largest half-size of the window, >= `search_radius`, <= 512. Default 60.
    pub max_search_radius: usize,
    /// Particle-filter settings (resampler, policy, chunking, parallelism).
    pub filter: FilterParams,
}

impl Default for ParticleTrackerParams {
    fn default() -> Self {
        Self {
            appearance: AppearanceParams::default(),
            n_particles: 200,
            position_noise: 0.25,
            scale_noise: 0.02,
            sigma: 0.1,
            min_scale: 0.5,
            max_scale: 2.0,
            mix_fraction: 0.1,
            search_radius: 10,
            velocity_gain: 1.5,
            max_search_radius: 60,
            filter: FilterParams::default(),
        }
    }
}

/// A mixture proposal's guess: centre, spread and how many particles it redraws.
type MixtureGuess = (Vector3<f64>, Vector3<f64>, usize);

/// Unit-circle directions where the perimeter gradient is sampled by the particle
/// likelihood.
const PERIMETER_POINTS: usize = 32;

/// The histogram likelihood of one (x, y, scale) state; the scratch is a counts buffer.
struct HistogramLikelihood<'a> {
    image: &'a BinImage,
    gradient: Option<&'a GradientImage>,
    model: &'a [f32],
    base_a: f64,
    base_b: f64,
    min_scale: f64,
    max_scale: f64,
    inv_two_sigma_sq: f64,
    gradient_weight: f64,
    gradient_ref: f64,
    directions: &'a [(f64, f64)],
}

/// Histogram intersection eq. (28) of the ellipse `(cx, cy, a, b)` with `model`
/// (normalised): `sum_i min(n m_i, c_i) / n`, `c_i` the ellipse's count in bin `i` and
/// `n` its pixel count (pixels outside the frame count in `n`, not in `c`). One pass
/// over the pixels counts; the sum then runs over the bins, clearing `counts` (or, when
/// the ellipse has fewer pixels than there are bins, over its pixels again).
fn intersection(
    image: &BinImage,
    model: &[f32],
    counts: &mut [u32],
    cx: f64,
    cy: f64,
    a: f64,
    b: f64,
) -> f64 {
    let (icx, icy) = (pixel_centre(cx), pixel_centre(cy));
    let ry = vertical_radius(b);
    let (ae, be) = ((a - 0.5).max(0.0), b.max(0.5));
    let (width, height) = (image.width as i32, image.height as i32);
    // The part of row `dy` inside the frame, if any.
    let span = |dy: i32, h: i32| {
        let y = icy + dy;
        let (x0, x1) = ((icx - h).max(0), (icx + h).min(width - 1));
        (y >= 0 && y < height && x0 <= x1).then(|| {
            let row = y as usize * image.width;
            &image.bins[row + x0 as usize..=row + x1 as usize]
        })
    };
    let mut n = 0i64;
    for dy in -ry..=ry {
        let h = half_width(ae, be, dy);
        n += 2 * i64::from(h) + 1;
        for &bin in span(dy, h).unwrap_or_default() {
            counts[bin as usize] += 1;
        }
    }
    let n = n as f32;
    let mut inter = 0.0f64;
    let mut take = |c: &mut u32, m: f32| {
        if *c > 0 {
            inter += f64::from((m * n).min(*c as f32));
            *c = 0;
        }
    };
    if (model.len() as f32) <= n {
        for (c, &m) in counts.iter_mut().zip(model) {
            take(c, m);
        }
    } else {
        for dy in -ry..=ry {
            for &bin in span(dy, half_width(ae, be, dy)).unwrap_or_default() {
                take(&mut counts[bin as usize], model[bin as usize]);
            }
        }
    }
    inter / f64::from(n)
}

/// The centre of best intersection on a grid of step about a quarter of the smaller
/// semi-axis within `radius` of `predicted`: the guess the mixture proposal samples
/// around. Coarse, so it costs a few dozen intersections rather than a full search.
fn local_search(
    image: &BinImage,
    model: &[f32],
    counts: &mut [u32],
    predicted: (f64, f64),
    (a, b): (f64, f64),
    radius: usize,
) -> Result<(f64, f64)> {
    let step = (a.min(b) / 4.0).round().max(1.0) as usize;
    let r = (radius / step) as i64;
    let mut best = (f64::NEG_INFINITY, predicted);
    for j in -r..=r {
        // Up to a thousand rows of a thousand ellipses each (radius 512, step 1).
        rperc_core::interrupt::checkpoint()?;
        for i in -r..=r {
            let c = (
                predicted.0 + (i * step as i64) as f64,
                predicted.1 + (j * step as i64) as f64,
            );
            let phi = intersection(image, model, counts, c.0, c.1, a, b);
            // Ties (a flat image) go to the candidate nearest the prediction.
            let nearer = (i * i + j * j) < {
                let (dx, dy) = (best.1.0 - predicted.0, best.1.1 - predicted.1);
                ((dx * dx + dy * dy) / (step * step) as f64).round() as i64
            };
            if phi > best.0 || (phi == best.0 && nearer) {
                best = (phi, c);
            }
        }
    }
    Ok(best.1)
}

impl HistogramLikelihood<'_> {
    fn rho(&self, s: &SVector<f64, 3>, counts: &mut [u32]) -> f64 {
        let scale = s[2];
        if !(self.min_scale..=self.max_scale).contains(&scale) {
            return f64::INFINITY;
        }
        let (a, b) = (self.base_a * scale, self.base_b * scale);
        let phi = intersection(self.image, self.model, counts, s[0], s[1], a, b);
        let mut rho = 1.0 - phi;
        if let Some(g) = self.gradient {
            let psi = g.perimeter_at(s[0], s[1], a, b, self.directions);
            rho += self.gradient_weight * (1.0 - (psi / self.gradient_ref).min(1.0));
        }
        rho
    }
}

impl Likelihood<3> for HistogramLikelihood<'_> {
    type Scratch = Vec<u32>;
    fn new_scratch(&self) -> Vec<u32> {
        vec![0; self.model.len()]
    }
    fn log_likelihood(&self, s: &SVector<f64, 3>, counts: &mut Vec<u32>) -> f64 {
        let rho = self.rho(s, counts);
        // Seed 000 section 3.3: pi = exp(-rho^2 / (2 sigma^2)).
        if rho.is_finite() {
            -rho * rho * self.inv_two_sigma_sq
        } else {
            f64::NEG_INFINITY
        }
    }
}

/// CONDENSATION colour tracker over the state (centre x, centre y, scale), weighted by
/// the histogram likelihood `exp(-(1 - phi)^2 / (2 sigma^2))`, `phi` the intersection
/// eq. (28). The estimate is the weighted mean; the model adapts by eq. (29) there.
///
/// # Examples
/// ```
/// use tracking::{BoundingBox, ParticleColorTracker, ParticleTrackerParams, RgbFrame};
///
/// let (w, h) = (64, 48);
/// let frame = |cx: f64| -> Vec<u8> {
///     let mut px = vec![100u8; w * h * 3];
///     for y in 0..h {
///         for x in 0..w {
///             if (x as f64 + 0.5 - cx).hypot(y as f64 + 0.5 - 24.0) < 7.0 {
///                 px[(y * w + x) * 3..][..3].copy_from_slice(&[30, 200, 40]);
///             }
///         }
///     }
///     px
/// };
/// let f0 = frame(20.0);
/// let mut t = ParticleColorTracker::new(
///     RgbFrame::new(&f0, w, h).unwrap(), BoundingBox::new(13.0, 17.0, 14.0, 14.0),
///     ParticleTrackerParams::default(), 7,
/// ).unwrap();
/// let mut r = t.last();
/// for k in 1..=5 {
///     let f = frame(20.0 + 2.0 * k as f64);
///     r = t.update(RgbFrame::new(&f, w, h).unwrap()).unwrap();
/// }
/// assert!((r.bbox.centre().0 - 30.0).abs() < 2.0, "{:?}", r.bbox);
/// ```
#[derive(Debug, Clone)]
pub struct ParticleColorTracker {
    params: ParticleTrackerParams,
    width: usize,
    height: usize,
    base_a: f64,
    base_b: f64,
    filter: ParticleFilter<3>,
    model: ColourModel,
    image: BinImage,
    gradient: GradientImage,
    gradient_ref: f64,
    scratch: Vec<Vec<u32>>,
    ellipse: Ellipse,
    directions: Vec<(f64, f64)>,
    /// Counts buffer of the local search.
    counts: Vec<u32>,
    velocity: (f64, f64),
    speed: f64,
    last: TrackResult,
}

impl ParticleTrackerParams {
    /// Refuses bad values with the parameter's name; returns the number of bins.
    pub fn validate(&self) -> Result<usize> {
        let n_bins = self.appearance.validate()?;
        // Refused before the frame is binned, not by the filter after it.
        rperc_core::ensure_count("n_particles", self.n_particles, 1, MAX_PARTICLES, 1)?;
        rperc_core::ensure_in_range("mix_fraction", self.mix_fraction, 0.0, 0.99)?;
        rperc_core::ensure_in_range("velocity_gain", self.velocity_gain, 0.0, 100.0)?;
        check_search_radii(self.search_radius, self.max_search_radius)?;
        positive("position_noise", self.position_noise)?;
        positive("scale_noise", self.scale_noise)?;
        positive("sigma", self.sigma)?;
        positive("min_scale", self.min_scale)?;
        positive("max_scale", self.max_scale)?;
        if self.min_scale > 1.0 || self.max_scale < 1.0 {
            return Err(TrackingError::InvalidParameter {
                name: "max_scale",
                reason: format!(
                    "need min_scale <= 1 <= max_scale, got {} and {}",
                    self.min_scale, self.max_scale
                ),
            });
        }
        Ok(n_bins)
    }
}

/// Unit directions `(cos t, sin t)` at which the ellipse's perimeter is sampled.
fn perimeter_directions() -> Vec<(f64, f64)> {
    (0..PERIMETER_POINTS)
        .map(|k| {
            let t = 2.0 * std::f64::consts::PI * k as f64 / PERIMETER_POINTS as f64;
            (t.cos(), t.sin())
        })
        .collect()
}

/// The particle filter over `(x, y, scale)`: a random walk whose position noise scales
/// with the target's mean semi-axis, started around `centre` at scale 1.
fn random_walk_filter(
    params: &ParticleTrackerParams,
    centre: (f64, f64),
    semi_axis: f64,
    seed: u64,
) -> Result<ParticleFilter<3>> {
    let sp = params.position_noise * semi_axis;
    // A standard deviation whose square under- or overflows has no usable covariance;
    // say which parameter, not "covariance".
    for (name, sd) in [("position_noise", sp), ("scale_noise", params.scale_noise)] {
        if !(sd * sd).is_normal() {
            return Err(TrackingError::InvalidParameter {
                name,
                reason: format!(
                    "a standard deviation of {sd:e} (times the box's semi-axis for \
                     position_noise) squares to {:e}; use a value between 1e-150 and 1e150",
                    sd * sd
                ),
            });
        }
    }
    let noise = Vector3::new(sp, sp, params.scale_noise);
    let cov = Matrix3::from_diagonal(&noise.component_mul(&noise));
    ParticleFilter::new(
        params.n_particles,
        Vector3::new(centre.0, centre.1, 1.0),
        cov,
        LinearGaussian::random_walk(noise),
        params.filter.clone(),
        seed,
    )
}

impl ParticleColorTracker {
    /// Samples the model from `bbox` and spreads the particles around it. `seed` fixes
    /// every random draw: the same seed gives the same track, whatever the thread count.
    ///
    /// # Errors
    /// Invalid parameters, an empty frame, or a box that is degenerate or outside the frame.
    pub fn new(
        frame: RgbFrame<'_>,
        bbox: BoundingBox,
        params: ParticleTrackerParams,
        seed: u64,
    ) -> Result<Self> {
        let n_bins = params.validate()?;
        let app = &params.appearance;
        bbox.check_inside(frame.width(), frame.height())?;
        let mut image = BinImage::default();
        image.compute(&frame, app.color_space, app.bins, params.filter.parallel);
        let (a, b) = (bbox.w / 2.0, bbox.h / 2.0);
        let mut ellipse = Ellipse::default();
        ellipse.rebuild(a, b, app.upper_fraction());
        let (cx, cy) = bbox.centre();
        let model = ColourModel::sample(
            app.model,
            n_bins,
            &image,
            &ellipse,
            pixel_centre(cx),
            pixel_centre(cy),
        );
        let directions = perimeter_directions();
        let mut gradient = GradientImage::default();
        let mut gradient_ref = 1.0;
        if app.gradient_weight > 0.0 {
            gradient.compute(&frame);
            // The initial box's own edge strength is what a perfect candidate scores.
            gradient_ref = gradient.perimeter_at(cx, cy, a, b, &directions).max(1.0);
        }
        let filter = random_walk_filter(&params, (cx, cy), (a + b) / 2.0, seed)?;
        Ok(Self {
            width: frame.width(),
            height: frame.height(),
            base_a: a,
            base_b: b,
            filter,
            model,
            image,
            gradient,
            gradient_ref,
            scratch: Vec::new(),
            ellipse,
            directions,
            counts: vec![0; n_bins],
            velocity: (0.0, 0.0),
            speed: 0.0,
            last: TrackResult::initial(bbox),
            params,
        })
    }

    /// One CONDENSATION step on the next frame.
    ///
    /// # Errors
    /// [`TrackingError::FrameSizeChanged`] if `frame` differs in size from the first.
    pub fn update(&mut self, frame: RgbFrame<'_>) -> Result<TrackResult> {
        let size = (frame.width(), frame.height());
        TrackingError::check_frame_size((self.width, self.height), size)?;
        let use_gradient = self.prepare_frame(&frame);
        if self.image.bins.iter().all(|&b| b == self.image.bins[0]) {
            // One colour everywhere (a black frame): nothing to weigh the particles by;
            // the set and the box stay as they were.
            self.last = TrackResult {
                score: 0.0,
                lost: true,
                ..self.last
            };
            return Ok(self.last);
        }
        let previous = self.last.bbox.centre();
        let guess = self.mixture_guess(previous)?;
        let app = &self.params.appearance;
        let likelihood = HistogramLikelihood {
            image: &self.image,
            gradient: use_gradient.then_some(&self.gradient),
            model: &self.model.reference,
            base_a: self.base_a,
            base_b: self.base_b,
            min_scale: self.params.min_scale,
            max_scale: self.params.max_scale,
            inv_two_sigma_sq: 1.0 / (2.0 * self.params.sigma * self.params.sigma),
            gradient_weight: app.gradient_weight,
            gradient_ref: self.gradient_ref,
            directions: &self.directions,
        };
        let before = self.filter.copy_if_interruptible();
        let report = match guess {
            Some((centre, sigma, n)) => {
                self.filter
                    .step_mixed(&likelihood, &mut self.scratch, centre, sigma, n)
            }
            None => self
                .filter
                .step_with_scratch(&likelihood, &mut self.scratch),
        };
        if report.interrupted {
            // Ctrl-C: the tracker stays as it was before this frame (the colour model,
            // velocity and last box are only changed by `conclude`).
            if let Some(before) = before {
                self.filter = before;
            }
            return Err(rperc_core::CoreError::Interrupted.into());
        }
        self.last = self.conclude(report.lost, previous);
        Ok(self.last)
    }

    /// The mixture proposal's guess `(centre, sigma, count)`: the best centre of a coarse
    /// local search around the predicted one, or `None` when `mix_fraction` redraws no
    /// particle.
    fn mixture_guess(&mut self, previous: (f64, f64)) -> Result<Option<MixtureGuess>> {
        let n_mixed = (self.params.mix_fraction * self.params.n_particles as f64).round() as usize;
        if n_mixed == 0 {
            return Ok(None);
        }
        let scale = self.filter.mean()[2].clamp(self.params.min_scale, self.params.max_scale);
        let radius = self.window_radius();
        let (gx, gy) = local_search(
            &self.image,
            &self.model.reference,
            &mut self.counts,
            (previous.0 + self.velocity.0, previous.1 + self.velocity.1),
            (self.base_a * scale, self.base_b * scale),
            radius,
        )?;
        let sp = 0.5 * self.params.position_noise * (self.base_a + self.base_b) / 2.0;
        let centre = Vector3::new(gx, gy, scale);
        let sigma = Vector3::new(sp, sp, self.params.scale_noise);
        Ok(Some((centre, sigma, n_mixed)))
    }

    /// The frame's result from the filter's mean: the box, its eq. (28) score and
    /// whether it is lost (the filter's own flag or a score under `lost_threshold`);
    /// the colour model adapts on a confident frame, and the velocity and speed that
    /// steer the next search follow the centre's move from `previous`.
    fn conclude(&mut self, filter_lost: bool, previous: (f64, f64)) -> TrackResult {
        let app = &self.params.appearance;
        let mean = self.filter.mean();
        let scale = mean[2].clamp(self.params.min_scale, self.params.max_scale);
        let (a, b) = (self.base_a * scale, self.base_b * scale);
        let counts = &mut self.scratch[0];
        let score = intersection(
            &self.image,
            &self.model.reference,
            counts,
            mean[0],
            mean[1],
            a,
            b,
        );
        let lost = filter_lost || score < app.lost_threshold;
        if !lost && score > app.adaptation_threshold && app.adaptation_rate > 0.0 {
            self.ellipse.rebuild(a, b, app.upper_fraction());
            self.model.adapt(
                app.adaptation_rate,
                &self.image,
                &self.ellipse,
                pixel_centre(mean[0]),
                pixel_centre(mean[1]),
            );
        }
        self.velocity = if lost {
            (0.0, 0.0)
        } else {
            (mean[0] - previous.0, mean[1] - previous.1)
        };
        self.speed += 0.5 * (self.velocity.0.hypot(self.velocity.1) - self.speed);
        TrackResult {
            bbox: BoundingBox::new(mean[0] - a, mean[1] - b, 2.0 * a, 2.0 * b),
            score,
            lost,
        }
    }

    /// Half-size of the local search's window: grown with the estimated speed.
    fn window_radius(&self) -> usize {
        let p = &self.params;
        let grown = p.search_radius + (p.velocity_gain * self.speed).round() as usize;
        grown.clamp(p.search_radius, p.max_search_radius)
    }

    /// Bins (and, with the gradient term, differentiates) the new frame; whether the
    /// gradient term is on.
    fn prepare_frame(&mut self, frame: &RgbFrame<'_>) -> bool {
        let app = &self.params.appearance;
        let parallel = self.params.filter.parallel;
        self.image
            .compute(frame, app.color_space, app.bins, parallel);
        let use_gradient = app.gradient_weight > 0.0;
        if use_gradient {
            self.gradient.compute(frame);
        }
        use_gradient
    }

    /// The last answer (the initial box, score 1, before the first update).
    pub fn last(&self) -> TrackResult {
        self.last
    }

    /// The underlying particle filter (particles, weights, ESS).
    pub fn filter(&self) -> &ParticleFilter<3> {
        &self.filter
    }

    /// The parameters.
    pub fn params(&self) -> &ParticleTrackerParams {
        &self.params
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Eq. (28) by brute force: every pixel of the frame tested against the ellipse's
    /// rows, the histogram counted, and `sum_i min(m_i, c_i / n)` with `n` the
    /// ellipse's pixel count, those outside the frame included.
    fn brute_force(image: &BinImage, model: &[f32], cx: f64, cy: f64, a: f64, b: f64) -> f64 {
        let (icx, icy) = (pixel_centre(cx), pixel_centre(cy));
        let ry = vertical_radius(b);
        let (ae, be) = ((a - 0.5).max(0.0), b.max(0.5));
        let n: i64 = (-ry..=ry)
            .map(|dy| 2 * i64::from(half_width(ae, be, dy)) + 1)
            .sum();
        let mut hist = vec![0u32; model.len()];
        for y in 0..image.height as i32 {
            for x in 0..image.width as i32 {
                let dy = y - icy;
                if dy.abs() <= ry && (x - icx).abs() <= half_width(ae, be, dy) {
                    hist[image.bins[y as usize * image.width + x as usize] as usize] += 1;
                }
            }
        }
        let n = n as f64;
        hist.iter()
            .zip(model)
            .map(|(&c, &m)| f64::from(m).min(f64::from(c) / n))
            .sum()
    }

    #[test]
    fn intersection_matches_brute_force_inside_and_across_the_border() {
        let (width, height, n_bins) = (48usize, 36usize, 64usize);
        let bins: Vec<u16> = (0..width * height)
            .map(|k| ((k * 7919 + k / width * 31) % n_bins) as u16)
            .collect();
        let image = BinImage {
            bins,
            width,
            height,
        };
        let raw: Vec<f32> = (0..n_bins).map(|i| ((i * 13) % 17) as f32 + 0.5).collect();
        let total: f32 = raw.iter().sum();
        let model: Vec<f32> = raw.iter().map(|v| v / total).collect();
        let mut counts = vec![0u32; n_bins];
        // Small ellipses (fewer pixels than bins) and large ones, inside the frame
        // and reaching past each border.
        for &(cx, cy, a, b) in &[
            (24.0, 18.0, 3.0, 2.0),
            (24.0, 18.0, 12.0, 9.0),
            (2.0, 18.0, 10.0, 6.0),
            (46.5, 1.0, 8.0, 8.0),
            (20.3, 34.7, 5.5, 4.2),
            (24.0, 18.0, 0.4, 0.3),
        ] {
            let fast = intersection(&image, &model, &mut counts, cx, cy, a, b);
            let slow = brute_force(&image, &model, cx, cy, a, b);
            assert!(
                (fast - slow).abs() < 1e-5,
                "({cx}, {cy}, {a}, {b}): {fast} vs {slow}"
            );
            assert!(counts.iter().all(|&c| c == 0), "counts left dirty");
        }
    }
}
