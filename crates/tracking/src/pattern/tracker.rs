//! The 2-D pattern tracker of section 3 (Ait Aider, Chateau & Lapresté): CONDENSATION
//! (section 3.1) over the state `X = (x, y, theta, s)` of eq. 5, with the random walk
//! `X_k = X_{k-1} + v` and the inter-correlation likelihood of eq. 6.

use nalgebra::{Matrix3, SMatrix, SVector};
use rperc_core::MAX_PARTICLES;
use rperc_core::image::GrayImage;

use super::frame::PatternFrame;
use super::homography::{self, MotionModel};
use super::layer::CoarseLayer;
use super::model::{PatternConfig, PatternModel, Region};
use super::observation::{
    Observation, PatternLikelihood, PatternScratch, PointTable, ScaleSpace, place,
};
use super::search::{NEWTON_TOLERANCE, Newton, frame_window};
use crate::condensation::{FilterParams, LinearGaussian, ParticleFilter, StepReport};
use crate::error::{Result, TrackingError};

mod plane;
mod warp;

use plane::PlaneState;
use warp::Profiles;

/// Particles whose log-likelihood, extrapolated from part of their points, falls this
/// far below a better one's are not weighed to the end (a relative weight of about
/// 1e-13), see [`PatternLikelihood::with_early_exit`].
pub(super) const NEGLIGIBLE_LOG_WEIGHT: f64 = 30.0;

/// The coarse rounds of the refinement weigh at least this many model points (all of
/// a smaller model): fewer locate a pattern less well than its own noise.
const COARSE_MIN_POINTS: usize = 64;

/// More Gauss-Newton steps than this are refused: the search converges in a few, and
/// a huge count (a typo) would only spend time where it has not.
const MAX_NEWTON_STEPS: usize = 100;
/// Most rounds of the coordinate refinement (see `refine_steps`).
const MAX_REFINE_STEPS: usize = 64;

/// The coarse layer's level is at most this many times coarser than the frame: a
/// coarser one leaves a pattern a few pixels wide.
const MAX_COARSE_FACTOR: usize = 32;

/// How fast the typical score of `second_look` forgets a good frame (per frame).
const TYPICAL_SCORE_DECAY: f64 = 0.95;

/// Parameters of a [`PatternTracker`].
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(default, deny_unknown_fields)]
// Its Python name, also where the visual memory's mosaic nests it.
#[schemars(rename = "PatternConfig")]
pub struct PatternTrackerParams {
    /// `N_p`, the number of particles (section 4.1 uses 200), without the coarse
    /// layer (with it, `coarse_kept`).
    pub n_particles: usize,
    /// `sigma_v = (sigma_x, sigma_y, sigma_theta, sigma_s)` of the random walk of
    /// section 3.3, in pixels, pixels, radians and scale units. Default section 4.1's
    /// `(5, 5, 3 deg, 0.1)`.
    pub sigma: [f64; 4],
    /// The estimate is reported lost when more than this fraction of the model points
    /// is occluded at it (an all-black frame occludes every point). Default 0.6, above
    /// the 40 % of occlusion the likelihood tolerates.
    pub lost_occluded_fraction: f64,
    /// Rounds of the local refinement of the estimate (see
    /// [`PatternTracker::update`]); 0 (with no `newton_steps`) reports the seed's plain
    /// weighted mean. Default 2 (steps of `sigma` and `sigma / 2`), then Gauss-Newton.
    pub refine_steps: usize,
    /// The refinement's first step, in random-walk sigmas (halved each round). Default
    /// 1: the search then reaches two sigmas from the weighted mean.
    pub refine_first_step: f64,
    /// The refined state replaces the lightest particle, weighted by its likelihood,
    /// so that the next frame starts from it. Default `true`.
    pub refined_particle: bool,
    /// A frame whose estimate scores below this fraction of the track's typical
    /// score gets a second CONDENSATION iteration (see [`PatternTracker::update`]); 0
    /// never. Default 0.9.
    pub second_look: f64,
    /// The last rounds of the refinement that weigh every model point; the earlier
    /// (coarse) ones weigh every other point, at half the cost. Default 0: both
    /// rounds are coarse, the Gauss-Newton steps place the peak on every point.
    pub refine_fine_rounds: usize,
    /// Gauss-Newton iterations on eq. 6 after the coordinate rounds (parabola
    /// deviation only; see [`PatternTracker::update`]): each costs about three
    /// likelihoods where a round of the coordinate search costs twelve. 0 leaves the
    /// whole refinement to the coordinate search (6 rounds, the last 2 fine, were the
    /// default before). Default 3, at most 100.
    pub newton_steps: usize,
    /// With `filter.parallel`, a frame is processed on the rayon pool only when the
    /// tracker's work, particles times model points, reaches this: handing a frame to
    /// the pool and back costs more than two cores save on small ones (figures:
    /// `docs/decisions.md`). 0: whenever `filter.parallel`.
    /// Default 100 000. The numbers do not depend on it.
    pub parallel_min_work: usize,
    /// States screened a frame by the coarse layer (see [`PatternTracker::update`]),
    /// drawn from the prior predictive; its best `coarse_kept` become the particles
    /// weighed on the frame. 0: no coarse layer, the particles are the prior
    /// predictive's as in the seed. Default 500. A pattern under 16 coarse pixels
    /// across (80 frame pixels at the default factor) goes without the layer: its
    /// coarse profiles would not fit inside it.
    pub coarse_particles: usize,
    /// How many times coarser the layer's level is than the frame (each of its pixels
    /// the mean of a `coarse_factor x coarse_factor` block). Default 5.
    pub coarse_factor: usize,
    /// Most model points the coarse layer weighs (spread over the fine model's).
    /// Default 64.
    pub coarse_points: usize,
    /// With the coarse layer, the filter holds this many particles (at most
    /// `n_particles`): the layer's best states, not the random walk's draws, so fewer
    /// do (200 without the layer: 8 of 10 sequences of 3-sigma steps strayed; 50
    /// after it: none, seeds 0-9). Default 50.
    pub coarse_kept: usize,
    /// The coarse layer's states are drawn with the random walk's spread times this.
    /// Default 2: steps of 3 sigma in all four parameters at once lie where the walk
    /// itself hardly draws.
    pub coarse_spread: f64,
    /// The best this many states of the coarse layer are moved to their peak on the
    /// coarse level by Gauss-Newton before the fine layer weighs them. Default 4.
    pub coarse_refined: usize,
    /// The motion model: the seed's similarity `(x, y, theta, s)` (default), or
    /// `homography`, the plane in perspective: the particles still search over the
    /// similarity, with the model seen through the last frame's projective rest, and
    /// the estimate is then refined by Gauss-Newton on the 8-dof homography (see
    /// [`PatternTracker::update`]).
    pub motion: MotionModel,
    /// The estimate is also lost when the gains of its
    /// unoccluded profiles (each profile's slope on its stored one, eq. 6's
    /// correlation times their contrast ratio) spread more than this: the median
    /// absolute deviation of their logarithms. The pattern under one gain gives
    /// them all alike; clutter where the pattern is hidden matches a third to a
    /// half of the profiles by chance (no more than `lost_occluded_fraction`
    /// occluded), each with its own gain. Default 0.3, tuned on generated
    /// perspective sequences, seeds 0-9 (camera.png over grass.png, and the
    /// generated pair): every tracked frame, with gain 0.8-1.2 and up to 30 %
    /// occlusion, spread at most 0.22; every frame with the pattern hidden but one
    /// (0.24, of 40 per image pair) at least 0.36. In similarity mode the gains are
    /// read only on frames that score under `second_look` of the track's typical
    /// score (the frames that get a second look).
    pub lost_gain_spread: f64,
    /// Model building and observation model (sections 3.2-3.3).
    pub pattern: PatternConfig,
    /// Particle-filter settings (resampler, policy, chunking, parallelism). Default
    /// chunks of 50 particles.
    pub filter: FilterParams,
}

impl Default for PatternTrackerParams {
    fn default() -> Self {
        Self {
            n_particles: 200,
            sigma: [5.0, 5.0, 3f64.to_radians(), 0.1],
            lost_occluded_fraction: 0.6,
            refine_steps: 2,
            refine_first_step: 1.0,
            refined_particle: true,
            second_look: 0.9,
            refine_fine_rounds: 0,
            newton_steps: 3,
            parallel_min_work: 100_000,
            // Tuned on 3-sigma steps of seeds 0-9 (plain, gain 0.2, occlusion 0.3):
            // 500 states at twice the random walk's spread, the best 4 moved to their
            // coarse peak; 1000 at the walk's own spread, unrefined, strayed on 5 of
            // 10 sequences.
            coarse_particles: 500,
            coarse_factor: 5,
            coarse_points: 64,
            coarse_kept: 50,
            coarse_spread: 2.0,
            coarse_refined: 4,
            motion: MotionModel::Similarity,
            lost_gain_spread: 0.3,
            pattern: PatternConfig::default(),
            // Each chunk weighs its particles until one is good, then cuts the rest
            // short (the early exit of `PatternLikelihood::with_early_exit`): fewer,
            // longer chunks weigh fewer particles in full. 200 particles in 4 chunks
            // still balance two cores (figures: `docs/decisions.md`).
            filter: FilterParams {
                chunk_size: 50,
                ..FilterParams::default()
            },
        }
    }
}

/// `Err` naming `name` unless the number of steps `value` is at most `max`.
fn at_most(name: &'static str, value: usize, max: usize) -> Result<()> {
    if value <= max {
        return Ok(());
    }
    Err(TrackingError::InvalidParameter {
        name,
        reason: format!("must be at most {max}, got {value}"),
    })
}

impl PatternTrackerParams {
    /// Refuses bad values with the parameter's name.
    pub fn validate(&self) -> Result<()> {
        rperc_core::ensure_count("n_particles", self.n_particles, 1, MAX_PARTICLES, 1)?;
        if !self.sigma.iter().all(|s| s.is_finite() && *s > 0.0) {
            return Err(TrackingError::InvalidParameter {
                name: "sigma",
                reason: format!("must be 4 finite values > 0, got {:?}", self.sigma),
            });
        }
        rperc_core::ensure_in_range("second_look", self.second_look, 0.0, 1.0)?;
        at_most("newton_steps", self.newton_steps, MAX_NEWTON_STEPS)?;
        // The step halves each round: after 64 it is 2^-64 sigmas, so more rounds
        // only spend time (10^9 of them never returned, issue 38).
        at_most("refine_steps", self.refine_steps, MAX_REFINE_STEPS)?;
        if !(self.refine_first_step.is_finite() && self.refine_first_step > 0.0) {
            return Err(TrackingError::InvalidParameter {
                name: "refine_first_step",
                reason: format!("must be finite and > 0, got {}", self.refine_first_step),
            });
        }
        self.validate_coarse()?;
        if self.lost_gain_spread.is_nan() || self.lost_gain_spread < 0.0 {
            return Err(TrackingError::InvalidParameter {
                name: "lost_gain_spread",
                reason: format!("must be >= 0, got {}", self.lost_gain_spread),
            });
        }
        rperc_core::ensure_in_range(
            "lost_occluded_fraction",
            self.lost_occluded_fraction,
            0.0,
            1.0,
        )?;
        self.pattern.validate()
    }

    /// The coarse layer's settings (see `coarse_particles`).
    fn validate_coarse(&self) -> Result<()> {
        rperc_core::check_allocation("coarse_particles", self.coarse_particles as u128, 64)?;
        if !(2..=MAX_COARSE_FACTOR).contains(&self.coarse_factor) {
            return Err(TrackingError::InvalidParameter {
                name: "coarse_factor",
                reason: format!(
                    "must be in 2..={MAX_COARSE_FACTOR}, got {}",
                    self.coarse_factor
                ),
            });
        }
        for (name, value) in [
            ("coarse_points", self.coarse_points),
            ("coarse_kept", self.coarse_kept),
        ] {
            if value == 0 {
                return Err(TrackingError::InvalidParameter {
                    name,
                    reason: "must be >= 1".into(),
                });
            }
        }
        rperc_core::ensure_in_range("coarse_spread", self.coarse_spread, 0.0, 100.0)?;
        Ok(())
    }
}

/// One frame's answer of a [`PatternTracker`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PatternPose {
    /// The estimated state `(x, y, theta, s)` of eq. 5: the pattern centre (pixels,
    /// pixel centres at integer coordinates), the rotation (radians, counter-clockwise
    /// on screen, as OpenCV's `getRotationMatrix2D`) and the scale relative to the
    /// initial region.
    pub state: [f64; 4],
    /// The geometric mean over model points of `Omega_sigma(lambda_j) / Omega_sigma(0)`
    /// at the estimate (eq. 6 per point, occluded points at the threshold): 1 for a
    /// perfect match, towards 0 for none.
    pub score: f64,
    /// Fraction of model points occluded at the estimate (section 3.3).
    pub occluded_fraction: f64,
    /// The target is lost: the pose is the last one held, not a new estimate.
    pub lost: bool,
    /// The initial region's corners (top-left, top-right, bottom-right, bottom-left,
    /// on the outer pixel edges) moved by the similarity of `state`.
    pub corners: [[f64; 2]; 4],
    /// The homography (row-major, `H_22 = 1`) from the first frame to this one: the
    /// similarity's in similarity mode, the plane's in homography mode.
    pub homography: [[f64; 3]; 3],
}

/// CONDENSATION tracker of a planar pattern over `(x, y, theta, s)` (section 3).
///
/// Each [`update`](Self::update) builds the frame's scale space once, then runs one
/// filter step: resample, propagate with `X_k = X_{k-1} + v` (section 3.3), weigh every
/// particle with eq. 6. The estimate is the weighted mean, with a circular mean for
/// `theta`. A seed gives bit-identical tracks whatever the number of threads, and no
/// particle allocates (per-chunk scratch buffers are kept from frame to frame).
#[derive(Debug, Clone)]
pub struct PatternTracker {
    params: PatternTrackerParams,
    /// Frames are processed on the rayon pool (`filter.parallel` and enough work,
    /// see `parallel_min_work`).
    parallel: bool,
    model: PatternModel,
    /// The model's per-point constants of the likelihood, computed once.
    table: PointTable,
    /// The model points' pixel offsets from the centre at scale 1 (for [`footprint`]).
    offsets: Vec<[f64; 2]>,
    width: usize,
    height: usize,
    filter: ParticleFilter<4>,
    space: ScaleSpace,
    scratch: Vec<PatternScratch>,
    /// The scales of the states weighed on a frame (kept to reuse its buffer).
    needed: Vec<f64>,
    /// The bounds of the states (particles and last estimate) the frame's scale
    /// space was last built for: its windows cover them and the refinement's reach
    /// around them (see `reach`).
    covered: Option<([f64; 4], [f64; 4])>,
    last: PatternPose,
    /// The track's recent best score, decaying by [`TYPICAL_SCORE_DECAY`] a frame (see
    /// `second_look`).
    typical_score: f64,
    /// The coarse layer (`coarse_particles > 0` and a model learnt from a frame).
    coarse: Option<CoarseLayer>,
    /// The states it screens and those it keeps (buffers reused).
    hypotheses: Vec<SVector<f64, 4>>,
    kept: Vec<SVector<f64, 4>>,
    /// The map of model offsets into the first frame, inverted (for
    /// [`PatternPose::homography`]).
    first_inverse: Matrix3<f64>,
    /// The model's profiles as the homography's refinement and the lost test read
    /// them (both modes).
    profiles: Profiles,
    /// The homography mode's state (`motion = homography`).
    plane: Option<PlaneState>,
}

impl PatternTracker {
    /// Learns the pattern inside `region` of `frame` (section 3.2) and spreads the
    /// particles around its pose `(centre, 0, 1)` with the random walk's covariance.
    ///
    /// # Errors
    /// Invalid parameters (named), a region outside the frame, too small or without
    /// usable contours.
    pub fn new(
        frame: PatternFrame<'_>,
        region: Region,
        params: PatternTrackerParams,
        seed: u64,
    ) -> Result<Self> {
        params.validate()?;
        let mut image = GrayImage::default();
        frame.to_gray(&mut image);
        let model = PatternModel::from_region(&image, region, &params.pattern)?;
        let state = [model.centre[0], model.centre[1], 0.0, 1.0];
        let (factor, points) = (params.coarse_factor, params.coarse_points);
        let coarse = (params.coarse_particles > 0)
            .then(|| CoarseLayer::new(&image, &model, factor, points))
            .flatten();
        let mut tracker = Self::with_layer(
            model,
            [image.width, image.height],
            state,
            params,
            seed,
            coarse,
        )?;
        if tracker.params.motion == MotionModel::Homography {
            let start = homography::similarity(&SVector::from(state));
            tracker.start_plane(start)?;
        }
        Ok(tracker)
    }

    /// A tracker of an already learnt `model` in frames of `width x height`, its
    /// particles spread around `state` with the random walk's covariance: how a model
    /// of a mosaic is tracked again when it comes back into view (second seed,
    /// section 2.3), without learning it anew. It has no coarse layer (that is
    /// learnt from the frame the model was).
    ///
    /// # Errors
    /// Invalid parameters (named), a non-finite state or a scale `<= 0`.
    pub fn from_model(
        model: PatternModel,
        width: usize,
        height: usize,
        state: [f64; 4],
        params: PatternTrackerParams,
        seed: u64,
    ) -> Result<Self> {
        Self::with_layer(model, [width, height], state, params, seed, None)
    }

    /// [`Self::from_model`] with the coarse layer `coarse`, if any: the filter then
    /// holds `coarse_kept` particles (at most `n_particles`), else `n_particles`.
    fn with_layer(
        model: PatternModel,
        [width, height]: [usize; 2],
        state: [f64; 4],
        params: PatternTrackerParams,
        seed: u64,
        coarse: Option<CoarseLayer>,
    ) -> Result<Self> {
        params.validate()?;
        let count = match coarse {
            Some(_) => params.coarse_kept.min(params.n_particles),
            None => params.n_particles,
        };
        check_start(&model, [width, height], &state)?;
        let state = SVector::from(state);
        // The pool only when a frame's work pays for the hand-over.
        let parallel = params.filter.parallel
            && count.saturating_mul(model.points.len()) >= params.parallel_min_work;
        let filter = start_filter(count, &state, &params, parallel, seed)?;
        let last = PatternPose {
            state: state.into(),
            score: 1.0,
            occluded_fraction: 0.0,
            lost: false,
            corners: corners(&model, &state),
            homography: Matrix3::identity().into(),
        };
        Ok(Self {
            width,
            height,
            parallel,
            params,
            profiles: Profiles::new(&model),
            table: PointTable::new(&model),
            offsets: (0..model.points.len()).map(|j| model.offset(j)).collect(),
            model,
            filter,
            space: ScaleSpace::new(),
            scratch: Vec::new(),
            needed: Vec::new(),
            covered: None,
            last,
            // The initial pose's score (1), so that the first frame can be looked at
            // again too.
            typical_score: last.score,
            coarse,
            hypotheses: Vec::new(),
            kept: Vec::new(),
            first_inverse: homography::similarity(&state)
                .try_inverse()
                .unwrap_or_else(Matrix3::identity),
            plane: None,
        })
    }

    /// One CONDENSATION step on the next frame (section 3.1).
    ///
    /// With the coarse layer (`coarse_particles > 0`, not in the seed) the particles
    /// weighed on the frame are the best `coarse_kept` of `coarse_particles` states
    /// drawn from the prior predictive at `coarse_spread` times the random walk's
    /// spread and weighed on a level `coarse_factor` times coarser, the best
    /// `coarse_refined` of them moved to their peak there by Gauss-Newton (see
    /// [`CoarseLayer`]): eq. 6 on the frame is too sharp for a few hundred draws in
    /// four dimensions to land near a step of 3 sigma in all of them.
    ///
    /// The weighted mean is then refined on the same frame's likelihood (eq. 6): a
    /// coordinate search of `refine_steps` rounds, steps starting at
    /// `refine_first_step * sigma` and halved each round, each coordinate moved to the
    /// vertex of the parabola through three log-likelihoods. Moves are kept only when
    /// they raise the likelihood. The refined state then replaces the lightest
    /// particle, weighted by its likelihood, so that the next frame starts from it
    /// (`refined_particle`). This is not in the seed: eq. 6 is so sharp that one
    /// particle carries nearly all the weight, and 200 particles spread over `sigma` in
    /// four dimensions leave the nearest one a pixel or more (and, after a step of 2-3
    /// sigma, a few degrees) from the peak; the search reaches `2 sigma` from the mean
    /// (with the default first step), as a second, deterministic layer (annealing in
    /// CONDENSATION practice), and costs about `12 * refine_steps` likelihoods, those
    /// of the coarse rounds (all but the last `refine_fine_rounds`) on every other
    /// model point only: they need the direction to the peak, the fine ones its
    /// place. `newton_steps` Gauss-Newton steps of eq. 6 on every point then place
    /// the peak ([`PatternLikelihood::normal_equations`]; a step is kept only when it
    /// raises the likelihood, halved once otherwise, held within the search's reach,
    /// and the search stops once a step moves less than 0.01 sigma): near the peak
    /// eq. 6 is a least-squares cost, and one pass over the points gives the whole
    /// 4 x 4 system where a coordinate round spends a dozen likelihoods.
    ///
    /// A frame whose estimate scores below `second_look` times the track's typical
    /// score (its recent best, forgotten by 5 % a frame) gets a second iteration on
    /// the same frame ([`Self::look_again`]), and the better of the two estimates.
    ///
    /// When the estimate is lost (the filter's total loss, more than
    /// `lost_occluded_fraction` of the points occluded, as on an all-black frame, or
    /// the profiles' gains spread over `lost_gain_spread`, as where the pattern is
    /// hidden) the last pose is kept and the particles are re-drawn around it; with
    /// the coarse layer, the next frame is searched whole at the last angle and scale.
    ///
    /// # Errors
    /// [`TrackingError::FrameSizeChanged`] if `frame` differs in size from the first.
    pub fn update(&mut self, frame: PatternFrame<'_>) -> Result<PatternPose> {
        let before = self.filter.copy_if_interruptible();
        let out = if self.parallel {
            // The whole step on a rayon worker: its blur and weighing fork and join a
            // few times per frame, cheap from a worker but a thread hand-over each
            // from any other thread (the numbers are the same). The worker takes this
            // call's interrupt token along, so its checkpoints still see Ctrl-C.
            let token = rperc_core::interrupt::current();
            rayon::scope(|_| rperc_core::interrupt::run_with(token, || self.step(frame)))
        } else {
            self.step(frame)
        };
        if let (Err(e), Some(before)) = (&out, before)
            && e.class() == rperc_core::ErrorClass::Interrupted
        {
            // Ctrl-C: the particles go back to where they were before this frame (the
            // last pose and typical score only change once a step has finished).
            self.filter = before;
        }
        out
    }

    /// [`Self::update`] on the calling thread.
    fn step(&mut self, frame: PatternFrame<'_>) -> Result<PatternPose> {
        TrackingError::check_frame_size((self.width, self.height), frame.size())?;
        let resampled = self.predict(frame)?;
        self.build_space(frame)?;
        let report = self.weigh(resampled)?;
        let (mut estimate, mut observation) = self.refine(report.lost);
        let mut lost_filter = report.lost;
        if !report.lost && self.doubtful(&observation) {
            (estimate, observation, lost_filter) = self.look_again(frame, estimate, observation)?;
        }
        let report = StepReport {
            lost: lost_filter,
            ..report
        };
        let fit = match self.plane.is_some() && !report.lost {
            true => self.fit_plane(estimate),
            false => None,
        };
        let similarity_estimate = estimate;
        if let Some(fit) = &fit {
            (estimate, observation) = (fit.state, fit.observation);
        }
        // In similarity mode the gains are read only where the frame looks doubtful,
        // as a hidden pattern does: reading them on every frame cost too much speed.
        let spread = match &fit {
            Some(f) => f.gain_spread,
            None if self.plane.is_none() && !report.lost && self.doubtful(&observation) => {
                self.gain_spread(&estimate)
            }
            None => 0.0,
        };
        let lost = report.lost
            || observation.occluded_fraction > self.params.lost_occluded_fraction
            || !observation.log_likelihood.is_finite()
            || spread > self.params.lost_gain_spread;
        self.commit_plane(fit, &similarity_estimate, lost);
        if lost {
            let kept = SVector::from(self.last.state);
            self.filter.scatter_around(kept);
            self.last.lost = true;
            self.last.occluded_fraction = observation.occluded_fraction;
            self.last.score = self.score(&observation);
        } else {
            self.last = PatternPose {
                state: estimate.into(),
                score: self.score(&observation),
                occluded_fraction: observation.occluded_fraction,
                lost: false,
                corners: self.corners_at(&estimate),
                homography: self.pose_homography(&estimate),
            };
            self.typical_score = self
                .last
                .score
                .max(TYPICAL_SCORE_DECAY * self.typical_score);
        }
        Ok(self.last)
    }

    /// Whether `observation` scores under `second_look` of the track's typical score:
    /// the frame gets a second look, and in similarity mode its gains are read.
    fn doubtful(&self, observation: &Observation) -> bool {
        self.score(observation) < self.params.second_look * self.typical_score
    }

    /// The spread of the profiles' gains at the similarity `estimate` (see
    /// `lost_gain_spread`); 0, no evidence, where its scale has no level.
    fn gain_spread(&mut self, estimate: &SVector<f64, 4>) -> f64 {
        self.space.ensure([estimate[3], estimate[3]]);
        let h = homography::similarity(estimate);
        let t = self.model.config.occlusion_threshold;
        self.profiles.gain_spread(&h, &self.space, t).unwrap_or(0.0)
    }

    /// The prediction of the particles, [`ParticleFilter::predict`] without a coarse
    /// layer. With one, `coarse_particles` states are drawn from the prior predictive
    /// (the random walk widened by `coarse_spread`) and the `coarse_kept` of them most
    /// likely on the coarse level of `frame` become the particles (see
    /// [`CoarseLayer`]). Returns whether the set was resampled.
    fn predict(&mut self, frame: PatternFrame<'_>) -> Result<bool> {
        let Some(layer) = self.coarse.as_mut() else {
            return Ok(self.filter.predict());
        };
        let kept = self.filter.particles().len();
        let count = self.params.coarse_particles.max(kept);
        if self.last.lost {
            // Lost: the whole frame is searched again.
            plane::grid(
                [self.width, self.height],
                self.params.coarse_factor,
                &self.last.state,
                &mut self.hypotheses,
            );
        } else {
            self.filter
                .sample_predictive(count, self.params.coarse_spread, &mut self.hypotheses);
        }
        let last = SVector::from(self.last.state);
        let keep = [kept, self.params.coarse_refined];
        let sigma = SVector::from(self.params.sigma);
        layer.screen(frame, &self.hypotheses, &last, keep, &sigma, &mut self.kept)?;
        if self.filter.set_particles(&self.kept).is_err() {
            // Nothing drawn (weights lost): the plain prediction.
            return Ok(self.filter.predict());
        }
        Ok(true)
    }

    /// A second CONDENSATION iteration on the same frame: the particles the first
    /// left (the refined state among them, usually the heaviest) resampled and moved
    /// by the random walk again, half of them redrawn around the last frame's
    /// estimate with twice the random walk's spread, all of them kept inside the
    /// bounds of the first look's states, weighed and refined. Its estimate is kept
    /// if its likelihood is higher, otherwise the first one is, and joins the
    /// particles. `(estimate, observation, lost)`.
    ///
    /// Run when the first estimate's score falls below `second_look` times the
    /// track's typical score: a step of 2-3 sigma leaves few particles near the
    /// target, and the refinement from their mean can settle in a compromise (a wrong
    /// scale explaining part of a translation, score ~0.6 where the track had ~0.93).
    /// A cloud around the compromise is usually nearer the target; one around the
    /// last estimate, wider, covers a compromise on the wrong side. Not in the seed
    /// (an annealing layer, as [`Self::update`]'s refinement is).
    fn look_again(
        &mut self,
        frame: PatternFrame<'_>,
        first: SVector<f64, 4>,
        at_first: Observation,
    ) -> Result<(SVector<f64, 4>, Observation, bool)> {
        let resampled = self.filter.predict();
        // Half the cloud from where the last frame left the target, twice as wide:
        // the compromise can lie on the wrong side of it.
        let sigma = SVector::from(self.params.sigma) * 2.0;
        let half = self.filter.particles().len() / 2;
        self.filter
            .redraw(half, SVector::from(self.last.state), sigma);
        self.space_for_second_look(frame)?;
        let report = self.weigh(resampled)?;
        let (second, at_second) = self.refine(report.lost);
        if !report.lost && at_second.log_likelihood > at_first.log_likelihood {
            return Ok((second, at_second, false));
        }
        if !report.lost {
            self.join_particles(first, &at_first);
        }
        Ok((first, at_first, false))
    }

    /// The frame's scale space, built once per frame, never per particle (section
    /// 3.3), and only where this frame's predicted particles and the refinement look
    /// (each level where the states nearest to its scale do), at the levels the
    /// particles and the last estimate fall on (the refinement's are added once its
    /// start is known).
    fn build_space(&mut self, frame: PatternFrame<'_>) -> Result<()> {
        self.covered = Some(self.state_bounds());
        let extent = self.reach();
        let span = [extent.0[3], extent.1[3]];
        let crop = |grown: [usize; 4], out: &mut GrayImage| frame.window_to_gray(grown, out);
        self.needed.clear();
        self.needed
            .extend(self.filter.particles().iter().map(|p| p[3]));
        self.needed.push(self.last.state[3]);
        let size = [self.width, self.height];
        let needed = Some(&self.needed[..]);
        let config = &self.model.config;
        let profile = 0.5 * config.n_samples as f64 * config.delta;
        let offsets = &self.offsets;
        let window = |cell: [f64; 2]| frame_window(offsets, profile, size, extent, cell);
        self.space
            .build_windows_for(size, crop, &self.model, window, span, needed)
    }

    /// The second look's scale space: the first look's, with the levels the new
    /// particles' scales need blurred. The particles are clamped into the bounds of
    /// the states it was built for, so that its windows cover them and the
    /// refinement's reach around their mean; a level's values inside its window do
    /// not depend on the window, so every state reads what a rebuild would give. The
    /// second look then searches where the first one's particles spread (the coarse
    /// layer's, tens of pixels wide) without blurring the frame again, which cost
    /// about as much as the rest of the second look (most frames of a partly
    /// occluded pattern take one).
    fn space_for_second_look(&mut self, frame: PatternFrame<'_>) -> Result<()> {
        let Some((lo, hi)) = self.covered else {
            return self.build_space(frame);
        };
        self.filter.clamp(&SVector::from(lo), &SVector::from(hi));
        self.needed.clear();
        self.needed
            .extend(self.filter.particles().iter().map(|p| p[3]));
        self.needed.push(self.last.state[3]);
        self.space.ensure_nearest(&self.needed);
        Ok(())
    }

    /// Weighs the predicted particles (eq. 6), those far below the best cut short;
    /// every chunk compares its particles from the start with the last estimate's
    /// likelihood on this frame.
    fn weigh(&mut self, resampled: bool) -> Result<StepReport> {
        let likelihood = PatternLikelihood::with_table(&self.model, &self.space, &self.table);
        if self.scratch.is_empty() {
            self.scratch.push(PatternScratch::default());
        }
        let last = SVector::from(self.last.state);
        let reference = likelihood
            .observe(&last, &mut self.scratch[0])
            .log_likelihood;
        let likelihood = likelihood
            .with_early_exit(NEGLIGIBLE_LOG_WEIGHT)
            .with_reference(reference);
        let report = self
            .filter
            .correct_with_scratch(&likelihood, &mut self.scratch, resampled);
        match report.interrupted {
            true => Err(rperc_core::CoreError::Interrupted.into()),
            false => Ok(report),
        }
    }

    /// The weighted mean refined by the search of [`Self::update`], and its
    /// observation; the refined state then replaces the lightest particle unless the
    /// filter lost the target (`lost`).
    fn refine(&mut self, lost: bool) -> (SVector<f64, 4>, Observation) {
        let mut estimate = self.estimate();
        let start = estimate;
        // The refinement's levels: it stays within its reach of the estimate.
        let reach = 2.0 * self.params.refine_first_step * self.params.sigma[3];
        self.space
            .ensure([estimate[3] - reach, estimate[3] + reach]);
        let likelihood = PatternLikelihood::with_table(&self.model, &self.space, &self.table);
        // The coarse rounds on every other point (interleaved over the contours) but
        // at least COARSE_MIN_POINTS, the last `refine_fine_rounds` on all of them.
        let n = self.model.points.len();
        let coarse = likelihood.with_points(n.div_ceil(2).max(COARSE_MIN_POINTS));
        let steps = self.params.refine_steps;
        let first_fine = steps.saturating_sub(self.params.refine_fine_rounds);
        let mut step = SVector::from(self.params.sigma) * self.params.refine_first_step;
        let mut observation = None;
        for (stage, rounds) in [(&coarse, 0..first_fine), (&likelihood, first_fine..steps)] {
            let fine = rounds.start == first_fine;
            if rounds.is_empty() {
                continue;
            }
            let scratch = &mut self.scratch[0];
            let mut at = stage.observe(&estimate, scratch);
            let mut search = Refinement {
                likelihood: stage,
                scratch,
                floor: f64::NEG_INFINITY,
            };
            for _ in rounds {
                search.round(&mut estimate, &mut at, &step);
                step /= 2.0;
            }
            observation = fine.then_some(at);
        }
        // The answer is always on all the points.
        let mut observation =
            observation.unwrap_or_else(|| likelihood.observe(&estimate, &mut self.scratch[0]));
        if self.params.newton_steps > 0 {
            let reach = SVector::from(self.params.sigma) * (2.0 * self.params.refine_first_step);
            let mut search = Newton {
                likelihood: &likelihood,
                scratch: &mut self.scratch[0],
                bounds: (start - reach, start + reach),
                tolerance: SVector::from(self.params.sigma) * NEWTON_TOLERANCE,
            };
            for _ in 0..self.params.newton_steps {
                if !search.step(&mut estimate, &mut observation) {
                    break;
                }
            }
        }
        let refined = self.params.refine_steps > 0 || self.params.newton_steps > 0;
        if self.params.refined_particle && refined && !lost {
            self.join_particles(estimate, &observation);
        }
        (estimate, observation)
    }

    /// The refined `state` joins the particles in place of the lightest, with its
    /// likelihood relative to the best particle's (weighed in full unless all of them
    /// fell far below the reference, when the refined state outweighs them all
    /// anyway).
    fn join_particles(&mut self, state: SVector<f64, 4>, observation: &Observation) {
        let likelihood = PatternLikelihood::with_table(&self.model, &self.space, &self.table);
        let (best, _) = self.filter.max_weight();
        let at_best = likelihood.observe(&best, &mut self.scratch[0]);
        let gain = observation.log_likelihood - at_best.log_likelihood;
        self.filter.substitute_lightest(state, gain);
    }

    /// The extent `(lo, hi)` of the states this frame's likelihood is asked about: the
    /// predicted particles and the last estimate (weighed as the early exit's
    /// reference), grown by the refinement's reach (it starts at the weighted mean,
    /// inside the extent, and its moves and probes add up to at most
    /// `refine_first_step * sigma * (1 + 1/2 + ...)`).
    fn reach(&self) -> ([f64; 4], [f64; 4]) {
        let reach = 2.0 * self.params.refine_first_step;
        let sigma = &self.params.sigma;
        let (mut lo, mut hi) = self.state_bounds();
        for d in 0..4 {
            lo[d] -= reach * sigma[d];
            hi[d] += reach * sigma[d];
        }
        (lo, hi)
    }

    /// The bounds `(lo, hi)` of the particles and the last estimate, per component.
    fn state_bounds(&self) -> ([f64; 4], [f64; 4]) {
        let (mut lo, mut hi) = ([f64::INFINITY; 4], [f64::NEG_INFINITY; 4]);
        let last = SVector::from(self.last.state);
        for p in self.filter.particles().iter().chain([&last]) {
            for d in 0..4 {
                lo[d] = lo[d].min(p[d]);
                hi[d] = hi[d].max(p[d]);
            }
        }
        (lo, hi)
    }

    /// The weighted mean of the particles, `theta` by the circular mean taken relative
    /// to the last estimate so that the angle stays continuous across `+-pi`.
    fn estimate(&self) -> SVector<f64, 4> {
        let reference = self.last.state[2];
        let (mut mean, mut sin, mut cos) = (SVector::<f64, 4>::zeros(), 0.0, 0.0);
        for (p, &w) in self.filter.particles().iter().zip(self.filter.weights()) {
            mean += p * w;
            let (s, c) = (p[2] - reference).sin_cos();
            sin += w * s;
            cos += w * c;
        }
        mean[2] = reference + sin.atan2(cos);
        mean
    }

    /// `exp(log p / N_m)`: eq. 6 normalised per point, in (0, 1].
    fn score(&self, observation: &Observation) -> f64 {
        let n = self.model.points.len().max(1) as f64;
        let s = (observation.log_likelihood / n).exp();
        if s.is_finite() { s } else { 0.0 }
    }

    /// Moves the whole state, the particles and the last answer, by `delta` `(dx, dy,
    /// dtheta, ds)`: the image motion of the pattern that a known control (say, the
    /// robot's odometry) predicts before the next frame. The random walk of `sigma`
    /// then covers only the control's error, not the whole motion: a pattern turning
    /// with the robot no longer lags behind it.
    ///
    /// # Errors
    /// [`TrackingError::InvalidParameter`] for a non-finite `delta`; nothing moves.
    pub fn shift(&mut self, delta: [f64; 4]) -> Result<()> {
        let delta = SVector::from(delta);
        self.filter.shift(&delta)?;
        let state = SVector::from(self.last.state) + delta;
        self.last.state = state.into();
        if let Some(plane) = &mut self.plane {
            plane.homography = homography::similarity(&state) * plane.rest;
        }
        self.last.corners = self.corners_at(&state);
        self.last.homography = self.pose_homography(&state);
        Ok(())
    }

    /// Whether [`Self::update`] runs its frames on the rayon pool (`filter.parallel`
    /// and at least `parallel_min_work`); otherwise it runs on the calling thread.
    pub fn runs_on_pool(&self) -> bool {
        self.parallel
    }

    /// The last answer (the initial pose, score 1, before the first update).
    pub fn last(&self) -> PatternPose {
        self.last
    }

    /// The learnt pattern model.
    pub fn model(&self) -> &PatternModel {
        &self.model
    }

    /// The underlying particle filter (particles, weights, ESS).
    pub fn filter(&self) -> &ParticleFilter<4> {
        &self.filter
    }

    /// The parameters.
    pub fn params(&self) -> &PatternTrackerParams {
        &self.params
    }
}

/// The model window's outer corners moved by the similarity of `state` (the same map
/// as the model points, [`place`]).
/// The corners of `model`'s window (top-left, top-right, bottom-right, bottom-left,
/// outer pixel edges) placed at tracker state `(x, y, theta, s)`.
pub fn corners_of(model: &PatternModel, state: [f64; 4]) -> [[f64; 2]; 4] {
    corners(model, &SVector::from(state))
}

fn corners(model: &PatternModel, state: &SVector<f64, 4>) -> [[f64; 2]; 4] {
    let (hw, hh) = (0.5 * model.size[0], 0.5 * model.size[1]);
    [[-hw, -hh], [hw, -hh], [hw, hh], [-hw, hh]].map(|offset| place(state, offset, 0.0).0)
}

/// The local search of [`PatternTracker::update`] on one frame's likelihood.
///
/// Its probes run one after the other even when the filter runs in parallel: a
/// probe costs a few microseconds, about what handing one to another thread does.
/// The two probes of a coordinate joined on two threads ran 2-3 % slower a frame
/// than in turn (640 x 480 benchmark sequence, 200 particles, 8 alternated runs;
/// the same numbers either way).
struct Refinement<'a, 'b> {
    likelihood: &'a PatternLikelihood<'a>,
    scratch: &'b mut PatternScratch,
    /// Probes below this are only bounded (see [`PatternLikelihood::observe_above`]).
    floor: f64,
}

impl Refinement<'_, '_> {
    /// The log-likelihoods of `a` and `b`.
    fn pair(&mut self, a: &SVector<f64, 4>, b: &SVector<f64, 4>) -> (f64, f64) {
        // A probe far below the centre only needs to be known as such: its bound
        // (exact above the floor) still bends the parabola down on its side.
        let floor = self.floor;
        let mut observe = |x: &SVector<f64, 4>| {
            self.likelihood
                .observe_above(x, self.scratch, floor)
                .log_likelihood
        };
        (observe(a), observe(b))
    }

    /// One round of the coordinate search: for each state component, the
    /// log-likelihoods at `x - h`, `x`, `x + h` give a parabola whose vertex (clamped
    /// to `[-h, h]`; the better neighbour when the parabola is not concave) is tried;
    /// the move is kept when it raises the log-likelihood of eq. 6.
    fn round(
        &mut self,
        state: &mut SVector<f64, 4>,
        best: &mut Observation,
        step: &SVector<f64, 4>,
    ) {
        for d in 0..4 {
            let h = step[d];
            let (mut below, mut above) = (*state, *state);
            below[d] -= h;
            above[d] += h;
            let centre = best.log_likelihood;
            self.floor = centre - NEGLIGIBLE_LOG_WEIGHT;
            let (minus, plus) = self.pair(&below, &above);
            let curvature = plus + minus - 2.0 * centre;
            let shift = if curvature < 0.0 && curvature.is_finite() {
                (0.5 * h * (minus - plus) / curvature).clamp(-h, h)
            } else if plus > minus {
                h
            } else if minus > plus {
                -h
            } else {
                continue;
            };
            let mut probe = *state;
            probe[d] += shift;
            // Exact whenever it beats the centre, which is all that is asked of it.
            let tried = self.likelihood.observe_above(&probe, self.scratch, centre);
            if tried.log_likelihood > centre {
                *state = probe;
                *best = tried;
            }
        }
    }
}

/// Refuses a start state that is not finite or has a scale `<= 0`, and a model whose
/// scale levels would each blur up to a whole `size` frame beyond the allocation
/// bound (a model read back from a mosaic carries its own config).
fn check_start(model: &PatternModel, [width, height]: [usize; 2], state: &[f64; 4]) -> Result<()> {
    if !state.iter().all(|v| v.is_finite()) || state[3] <= 0.0 {
        return Err(TrackingError::InvalidParameter {
            name: "state",
            reason: format!("must be finite with a scale > 0, got {state:?}"),
        });
    }
    model.config.validate()?;
    let frame_bytes = (width as u128)
        .saturating_mul(height as u128)
        .saturating_mul(4);
    let levels = model.config.scale_levels.len() as u128;
    rperc_core::check_allocation("scale_levels", levels, frame_bytes)?;
    Ok(())
}

/// The tracker's particle filter: `count` particles about `state`, spread and moved
/// by the random walk of `params.sigma`, on the pool when `parallel`.
fn start_filter(
    count: usize,
    state: &SVector<f64, 4>,
    params: &PatternTrackerParams,
    parallel: bool,
    seed: u64,
) -> Result<ParticleFilter<4>> {
    let sigma = SVector::from(params.sigma);
    let covariance = SMatrix::from_diagonal(&sigma.component_mul(&sigma));
    ParticleFilter::new(
        count,
        *state,
        covariance,
        LinearGaussian::random_walk(sigma),
        FilterParams {
            parallel,
            ..params.filter.clone()
        },
        seed,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pattern::search::footprint;
    use rperc_core::image::{GrayView, RgbView};

    /// The footprint against brute force: every point, grown by the profile in any
    /// direction, at dense angles and scales of the spans lies inside it, and its
    /// bound is tight to the slack of the angle span.
    #[test]
    fn the_footprint_holds_every_placed_point_and_profile() {
        let cloud: Vec<[f64; 2]> = (0..40)
            .map(|k| {
                let t = f64::from(k) * 0.7;
                [
                    45.0 * t.cos() * (1.0 + 0.1 * t.sin()),
                    30.0 * (1.3 * t).sin(),
                ]
            })
            .collect();
        // A lone point on the x axis is farthest right at angle 0, inside the span.
        let lone = vec![[50.0, 0.0]];
        for (offsets, theta, scale, profile) in [
            (&cloud, [-0.3, 0.2], [0.8, 1.4], 6.0),
            (&lone, [-0.3, 0.4], [0.8, 1.4], 0.0),
            (&cloud, [2.9, 3.4], [1.0, 1.0], 0.0),
            (&cloud, [-1.0, 2.5], [0.5, 2.0], 6.0),
            (&cloud, [0.0, 4.0], [0.9, 1.1], 6.0),
        ] {
            let [fx, fy] = footprint(offsets, theta, scale, profile);
            let mut seen = [[f64::INFINITY, f64::NEG_INFINITY]; 2];
            for i in 0..=200 {
                let t = theta[0] + (theta[1] - theta[0]) * f64::from(i) / 200.0;
                for j in 0..=10 {
                    let s = scale[0] + (scale[1] - scale[0]) * f64::from(j) / 10.0;
                    let state = SVector::from([0.0, 0.0, t, s]);
                    for (o, a) in offsets.iter().zip(0..) {
                        let (p, _) = place(&state, *o, 0.0);
                        let (sin, cos) = (f64::from(a) * 0.37).sin_cos();
                        for end in [-1.0, 1.0] {
                            let q = [
                                p[0] + end * s * profile * cos,
                                p[1] + end * s * profile * sin,
                            ];
                            for d in 0..2 {
                                seen[d][0] = seen[d][0].min(q[d]);
                                seen[d][1] = seen[d][1].max(q[d]);
                            }
                        }
                    }
                }
            }
            for (d, f) in [fx, fy].into_iter().enumerate() {
                assert!(
                    f[0] <= seen[d][0] && f[1] >= seen[d][1],
                    "{theta:?}: {f:?} {:?}",
                    seen[d]
                );
            }
            // Tight for a narrow angle span: within the profile and slack of the
            // points' own extent.
            if theta[1] - theta[0] < 1.0 {
                assert!(
                    fx[1] - seen[0][1] < 2.0 * profile * scale[1] + 5.0,
                    "{theta:?}: {fx:?} {:?}",
                    seen[0]
                );
            }
        }
    }

    /// The window conversion against the whole-frame conversion, cropped.
    #[test]
    fn a_window_converts_as_the_whole_frame_does_there() {
        let (w, h) = (13, 7);
        let grey: Vec<u8> = (0..w * h).map(|i| (i * 37 % 251) as u8).collect();
        let rgb: Vec<u8> = (0..w * h * 3).map(|i| (i * 53 % 241) as u8).collect();
        let frames = [
            PatternFrame::Gray(GrayView::new(&grey, w, h).unwrap()),
            PatternFrame::Rgb(RgbView::new(&rgb, w, h).unwrap()),
        ];
        for frame in frames {
            let mut whole = GrayImage::default();
            frame.to_gray(&mut whole);
            for window in [[0, 0, w, h], [2, 1, 9, 6], [12, 6, 13, 7], [4, 3, 4, 5]] {
                let mut part = GrayImage::default();
                frame.window_to_gray(window, &mut part);
                let [x0, y0, x1, y1] = window;
                assert_eq!((part.width, part.height), (x1 - x0, y1 - y0));
                let want: Vec<f32> = (y0..y1)
                    .flat_map(|y| (x0..x1).map(move |x| (x, y)))
                    .map(|(x, y)| whole.at(x, y))
                    .collect();
                assert_eq!(part.data, want, "{window:?}");
            }
        }
    }
}
