//! The particle set, its propagation, parallel weighting in the log domain, estimates and
//! the recovery when every particle has zero likelihood.

use nalgebra::{SMatrix, SVector};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;
use rperc_core::interrupt;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicBool, Ordering};

use super::dynamics::LinearGaussian;
use super::mixture::{Guess, log_importance, merge_copies};
use super::resample::{Resampler, ess_normalized};
use crate::error::{Result, TrackingError};

/// Particles weighed between two interrupt checks in a chunk: one likelihood can cost
/// a segmentation (the colour+shape tracker), so a check per particle would already
/// be cheap, and 16 keep the check invisible for the cheapest likelihoods too.
const CHECK_PARTICLES: usize = 16;

/// The measurement model: log-likelihood `ln p(z | s)` of a state, up to a constant.
///
/// `-inf` means "impossible"; NaN and `+inf` are treated as `-inf` (zero weight). The
/// filter calls it from several threads at once, each call with its own scratch value,
/// so a likelihood that needs a work buffer (a histogram...) allocates it once per
/// chunk of particles, never per particle.
///
/// Any `Fn(&SVector<f64, D>) -> f64 + Sync` closure is a likelihood with no scratch.
pub trait Likelihood<const D: usize>: Sync {
    /// Per-chunk work space, reused across particles and steps.
    type Scratch: Send;
    /// A fresh work space.
    fn new_scratch(&self) -> Self::Scratch;
    /// `ln p(z | state)`.
    fn log_likelihood(&self, state: &SVector<f64, D>, scratch: &mut Self::Scratch) -> f64;
}

impl<const D: usize, F> Likelihood<D> for F
where
    F: Fn(&SVector<f64, D>) -> f64 + Sync,
{
    type Scratch = ();
    fn new_scratch(&self) {}
    fn log_likelihood(&self, state: &SVector<f64, D>, _: &mut ()) -> f64 {
        self(state)
    }
}

/// When to resample at the start of a step. In configs: `resample_below = None`
/// (always) or an ESS fraction.
#[derive(Debug, Clone, Copy, PartialEq, Default, Deserialize, Serialize, JsonSchema)]
#[serde(from = "Option<f64>", into = "Option<f64>")]
pub enum ResamplePolicy {
    /// Every step, as in the seed's CONDENSATION.
    #[default]
    Always,
    /// Only when the effective sample size falls below `fraction * n`
    /// (`fraction` in (0, 1]); otherwise the weights carry over (importance sampling).
    BelowEss(f64),
}

impl From<Option<f64>> for ResamplePolicy {
    fn from(fraction: Option<f64>) -> Self {
        fraction.map_or(ResamplePolicy::Always, ResamplePolicy::BelowEss)
    }
}

impl From<ResamplePolicy> for Option<f64> {
    fn from(policy: ResamplePolicy) -> Self {
        match policy {
            ResamplePolicy::Always => None,
            ResamplePolicy::BelowEss(f) => Some(f),
        }
    }
}

/// Tuning of a [`ParticleFilter`].
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct FilterParams {
    /// Resampling scheme. Default [`Resampler::Systematic`].
    pub resampler: Resampler,
    /// When to resample. Default [`ResamplePolicy::Always`]. Spelled `resample_below`
    /// (an ESS fraction, or none for "always") in configs.
    #[serde(rename = "resample_below")]
    pub policy: ResamplePolicy,
    /// Particles per parallel work item (default 64). Fixed, so the split of the work never
    /// depends on the thread count; large enough that a chunk's likelihood calls outweigh
    /// rayon's per-task cost.
    pub chunk_size: usize,
    /// Weight particles in parallel with rayon (default `true`). Results are identical
    /// either way; the serial path is faster for cheap likelihoods or few particles.
    pub parallel: bool,
}

impl Default for FilterParams {
    fn default() -> Self {
        Self {
            resampler: Resampler::Systematic,
            policy: ResamplePolicy::Always,
            chunk_size: 64,
            parallel: true,
        }
    }
}

/// What one [`ParticleFilter::step`] did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepReport {
    /// Effective sample size of the new weights (`n` after a recovery).
    pub ess: f64,
    /// Whether the set was resampled at the start of the step.
    pub resampled: bool,
    /// Every particle had zero likelihood: the set was re-initialised around the last
    /// estimate and the target is reported lost.
    pub lost: bool,
    /// The step stopped at an interrupt checkpoint (Ctrl-C in Python, see
    /// [`rperc_core::interrupt`]) before every particle was weighed: the set is left
    /// partly weighed, and the caller restores the copy it took before the step.
    pub interrupted: bool,
}

/// A CONDENSATION particle filter over a `D`-dimensional state.
///
/// One [`step`](Self::step) is the seed's iteration: resample with probability
/// proportional to the weights, propagate each sample with `s = A s' + B w`, weight it by
/// the likelihood. Weights are kept as logarithms and normalised with log-sum-exp, so a
/// sharp likelihood cannot underflow them. Random draws are made serially from one
/// ChaCha8 stream, and each particle's weight is a pure function of its state, so a seed
/// gives bit-identical results whatever the number of rayon threads.
///
/// # Examples
/// Track a constant scalar observed with noise:
/// ```
/// use nalgebra::{SMatrix, SVector, Vector1};
/// use tracking::{FilterParams, LinearGaussian, ParticleFilter};
///
/// let dynamics = LinearGaussian::random_walk(Vector1::new(0.1));
/// let mut pf = ParticleFilter::new(
///     500, Vector1::new(0.0), SMatrix::identity() * 4.0, dynamics, FilterParams::default(), 42,
/// ).unwrap();
/// for z in [1.1, 0.9, 1.05, 0.95, 1.0] {
///     pf.step(&|s: &SVector<f64, 1>| -0.5 * ((s[0] - z) / 0.2_f64).powi(2));
/// }
/// assert!((pf.mean()[0] - 1.0).abs() < 0.15);
/// ```
#[derive(Debug, Clone)]
pub struct ParticleFilter<const D: usize> {
    particles: Vec<SVector<f64, D>>,
    spare: Vec<SVector<f64, D>>,
    log_weights: Vec<f64>,
    weights: Vec<f64>,
    ancestors: Vec<usize>,
    dynamics: LinearGaussian<D>,
    recovery_chol: SMatrix<f64, D, D>,
    params: FilterParams,
    rng: ChaCha8Rng,
    /// ICONDENSATION's work space: distinct parents with their log-weights, and the
    /// importance correction.
    parents: Vec<(SVector<f64, D>, f64)>,
    correction: Vec<f64>,
    mean: SVector<f64, D>,
    ess: f64,
    lost: bool,
}

impl<const D: usize> ParticleFilter<D> {
    /// `n` particles drawn from `N(mean, covariance)` with equal weights. After a total
    /// loss the set is re-drawn from `N(last estimate, covariance)`.
    ///
    /// # Errors
    /// [`TrackingError::InvalidParameter`] for `n` outside `1..=MAX_PARTICLES`, a zero chunk size, a threshold
    /// outside (0, 1], non-finite values; [`TrackingError::NotPositiveDefinite`] when
    /// `covariance` is not symmetric positive definite.
    pub fn new(
        n: usize,
        mean: SVector<f64, D>,
        covariance: SMatrix<f64, D, D>,
        dynamics: LinearGaussian<D>,
        params: FilterParams,
        seed: u64,
    ) -> Result<Self> {
        // Particles, their copy for resampling, weights, log-weights and ancestors.
        let per_particle = 2 * std::mem::size_of::<SVector<f64, D>>() + 3 * 8;
        rperc_core::ensure_count(
            "n_particles",
            n,
            1,
            rperc_core::MAX_PARTICLES,
            per_particle as u128,
        )?;
        if params.chunk_size == 0 {
            return Err(TrackingError::InvalidParameter {
                name: "chunk_size",
                reason: "must be >= 1".into(),
            });
        }
        if let ResamplePolicy::BelowEss(f) = params.policy
            && !(f.is_finite() && f > 0.0 && f <= 1.0)
        {
            // Named as configs and Python spell it (the field is serde-renamed).
            return Err(TrackingError::InvalidParameter {
                name: "resample_below",
                reason: format!("ESS fraction must be in (0, 1], got {f}"),
            });
        }
        if !mean.iter().all(|v| v.is_finite()) {
            return Err(TrackingError::InvalidParameter {
                name: "mean",
                reason: "must be finite".into(),
            });
        }
        dynamics.validate()?;
        let recovery_chol = cholesky(&covariance, "covariance")?;
        let mut pf = Self {
            particles: vec![mean; n],
            spare: Vec::with_capacity(n),
            log_weights: vec![0.0; n],
            weights: vec![0.0; n],
            ancestors: Vec::with_capacity(n),
            dynamics,
            recovery_chol,
            params,
            rng: rperc_core::rng::seeded(seed),
            parents: Vec::new(),
            correction: Vec::new(),
            mean,
            ess: n as f64,
            lost: false,
        };
        pf.scatter_around(mean);
        Ok(pf)
    }

    /// A copy to put back when the coming step reports
    /// [`interrupted`](StepReport::interrupted), taken only when this thread's call can
    /// be interrupted (see [`rperc_core::interrupt`]): plain Rust use pays nothing.
    pub fn copy_if_interruptible(&self) -> Option<Self> {
        interrupt::current().map(|_| self.clone())
    }

    /// Replaces the covariance used to re-draw the set after a total loss.
    ///
    /// # Errors
    /// [`TrackingError::NotPositiveDefinite`] when it is not symmetric positive definite.
    pub fn set_recovery_covariance(&mut self, covariance: SMatrix<f64, D, D>) -> Result<()> {
        self.recovery_chol = cholesky(&covariance, "covariance")?;
        Ok(())
    }

    /// Redraws every particle from `N(centre, recovery covariance)` with equal weights.
    pub fn scatter_around(&mut self, centre: SVector<f64, D>) {
        let l = self.recovery_chol;
        for p in &mut self.particles {
            *p = centre + l * standard_normal(&mut self.rng);
        }
        self.set_uniform_weights();
        self.mean = self.weighted_mean();
    }

    /// One CONDENSATION iteration; see the type's documentation.
    pub fn step<L: Likelihood<D>>(&mut self, likelihood: &L) -> StepReport {
        let mut scratch = Vec::new();
        self.step_with_scratch(likelihood, &mut scratch)
    }

    /// [`step`](Self::step) reusing the caller's per-chunk scratch values, so that repeated
    /// steps allocate nothing once `scratch` has grown to one value per chunk.
    pub fn step_with_scratch<L: Likelihood<D>>(
        &mut self,
        likelihood: &L,
        scratch: &mut Vec<L::Scratch>,
    ) -> StepReport {
        let resampled = self.predict();
        self.correct_with_scratch(likelihood, scratch, resampled)
    }

    /// The first half of [`step`](Self::step): resample when due, then propagate by the
    /// dynamics. Returns whether it resampled. A caller that prepares its likelihood
    /// from where the predicted particles are (a tracker that builds image data only
    /// where they look) calls this, then [`correct_with_scratch`](Self::correct_with_scratch):
    /// the two together are exactly one `step`.
    pub fn predict(&mut self) -> bool {
        let resampled = self.resample_if_needed();
        self.propagate();
        resampled
    }

    /// [`step_with_scratch`](Self::step_with_scratch) with a mixture proposal (Isard &
    /// Blake's ICONDENSATION, without its importance correction): after propagation,
    /// `count` particles evenly spaced through the set are redrawn from
    /// `N(centre, diag(sigma^2))`, a detector's guess, so that a target that jumped
    /// beyond the random walk's reach still has particles on it. Their weights are the
    /// likelihood alone, so the estimate leans towards the guess when the image agrees.
    pub fn step_mixed<L: Likelihood<D>>(
        &mut self,
        likelihood: &L,
        scratch: &mut Vec<L::Scratch>,
        centre: SVector<f64, D>,
        sigma: SVector<f64, D>,
        count: usize,
    ) -> StepReport {
        self.step_mixtures(likelihood, scratch, &[(centre, sigma, count)])
    }

    /// [`step_mixed`](Self::step_mixed) with several guesses: for each
    /// `(centre, sigma, count)`, `count` particles are redrawn from
    /// `N(centre, diag(sigma^2))`; the redrawn particles are spread evenly through the
    /// set, the guesses interleaved, and never more than the whole set in total.
    pub fn step_mixtures<L: Likelihood<D>>(
        &mut self,
        likelihood: &L,
        scratch: &mut Vec<L::Scratch>,
        guesses: &[Guess<D>],
    ) -> StepReport {
        let resampled = self.predict();
        self.draw_guesses(guesses);
        self.correct_with_scratch(likelihood, scratch, resampled)
    }

    /// Isard & Blake's ICONDENSATION step, with its importance correction: after
    /// resampling, particles are propagated by the dynamics and then, for each
    /// `(centre, sigma, count)`, `count` of them redrawn from `N(centre, diag(sigma^2))`
    /// as in [`step_mixtures`](Self::step_mixtures). The proposal is then
    /// `q = (1 - alpha) pi + alpha g`, `pi` the prior predictive of the resampled set,
    /// `g` the guesses' mixture and `alpha` their share; each particle's weight is
    /// `p(z | x) pi(x) / q(x)`, so the set targets the posterior under the dynamics and
    /// the guesses only decide where particles are put. Costs `n^2` Gaussian terms.
    /// Without a usable correction (a singular `B B^T`) this is `step_mixtures`.
    pub fn step_icondensation<L: Likelihood<D>>(
        &mut self,
        likelihood: &L,
        scratch: &mut Vec<L::Scratch>,
        guesses: &[Guess<D>],
    ) -> StepReport {
        let resampled = self.resample_if_needed();
        // A resampled set holds each ancestor's copies side by side: one Gaussian term
        // of pi per distinct parent, its copies' weights summed.
        let mut parents = std::mem::take(&mut self.parents);
        merge_copies(&self.particles, &self.log_weights, &mut parents);
        self.propagate();
        self.draw_guesses(guesses);
        let mut correction = std::mem::take(&mut self.correction);
        if log_importance(
            &self.particles,
            &parents,
            &self.dynamics,
            guesses,
            &mut correction,
        )
        .is_some()
        {
            // The marginal weight pi / q replaces the carried one (pi holds the
            // parents' weights).
            self.log_weights.copy_from_slice(&correction);
        }
        (self.parents, self.correction) = (parents, correction);
        self.correct_with_scratch(likelihood, scratch, resampled)
    }

    /// Between [`predict`](Self::predict) and
    /// [`correct_with_scratch`](Self::correct_with_scratch): `count` particles evenly
    /// spaced through the set (at most all of them) are redrawn from `N(centre,
    /// diag(sigma^2))`, the mixture proposal of [`step_mixed`](Self::step_mixed).
    pub fn redraw(&mut self, count: usize, centre: SVector<f64, D>, sigma: SVector<f64, D>) {
        self.draw_guesses(&[(centre, sigma, count)]);
    }

    /// Draws `count` states from the set's prior predictive into `out` (cleared):
    /// `count` ancestors resampled by weight with the set's resampler, each propagated
    /// by `s = A s' + spread B w`. The set itself is left as it is (only the random
    /// stream moves): a layered filter screens these many states with a cheap
    /// likelihood and keeps some with [`set_particles`](Self::set_particles), where a
    /// set that large would cost its full likelihood on every one. `spread > 1` widens
    /// the proposal beyond the dynamics. Nothing is drawn for a non-finite or negative
    /// `spread`, or weights that cannot be resampled (after a total loss, say).
    pub fn sample_predictive(&mut self, count: usize, spread: f64, out: &mut Vec<SVector<f64, D>>) {
        out.clear();
        if !(spread.is_finite() && spread >= 0.0) {
            return;
        }
        let mut ancestors = std::mem::take(&mut self.ancestors);
        let drawn =
            self.params
                .resampler
                .resample(&self.weights, count, &mut self.rng, &mut ancestors);
        if drawn.is_ok() {
            let LinearGaussian { a, b } = self.dynamics;
            let b = b * spread;
            for &i in &ancestors {
                out.push(a * self.particles[i] + b * standard_normal(&mut self.rng));
            }
        }
        self.ancestors = ancestors;
    }

    /// Replaces the states of the set by `states` (as many as it holds), with equal
    /// weights: the states a first layer kept (see
    /// [`sample_predictive`](Self::sample_predictive)), weighed next by
    /// [`correct_with_scratch`](Self::correct_with_scratch).
    ///
    /// # Errors
    /// [`TrackingError::InvalidParameter`] when the count differs or a state is not
    /// finite; the set is then left as it was.
    pub fn set_particles(&mut self, states: &[SVector<f64, D>]) -> Result<()> {
        if states.len() != self.particles.len() {
            return Err(TrackingError::InvalidParameter {
                name: "states",
                reason: format!(
                    "{} states for a set of {} particles",
                    states.len(),
                    self.particles.len()
                ),
            });
        }
        if !states.iter().all(|s| s.iter().all(|v| v.is_finite())) {
            return Err(TrackingError::InvalidParameter {
                name: "states",
                reason: "must be finite".into(),
            });
        }
        self.particles.copy_from_slice(states);
        self.set_uniform_weights();
        Ok(())
    }

    /// Redraws particles around the guesses, spread evenly through the set and
    /// interleaved, never more than the whole set.
    fn draw_guesses(&mut self, guesses: &[Guess<D>]) {
        let n = self.particles.len();
        let total = guesses.iter().map(|g| g.2).sum::<usize>().min(n);
        let (mut k, mut drawn) = (0, vec![0usize; guesses.len()]);
        while k < total {
            for (g, (centre, sigma, count)) in guesses.iter().enumerate() {
                if drawn[g] < *count && k < total {
                    // Evenly spaced: resampled sets are sorted by ancestor.
                    let i = (k * n) / total;
                    let noise: SVector<f64, D> = standard_normal(&mut self.rng);
                    self.particles[i] = centre + sigma.component_mul(&noise);
                    drawn[g] += 1;
                    k += 1;
                }
            }
        }
    }

    /// The second half of [`step`](Self::step), after [`predict`](Self::predict)
    /// (whose answer is `resampled`): weigh, normalise, and re-draw the set on a total
    /// loss.
    pub fn correct_with_scratch<L: Likelihood<D>>(
        &mut self,
        likelihood: &L,
        scratch: &mut Vec<L::Scratch>,
        resampled: bool,
    ) -> StepReport {
        if !self.weigh(likelihood, scratch) {
            return StepReport {
                ess: self.ess,
                resampled,
                lost: self.lost,
                interrupted: true,
            };
        }
        let lost = !self.normalise();
        if lost {
            let centre = self.mean;
            self.scatter_around(centre);
        } else {
            self.mean = self.weighted_mean();
            self.ess = ess_normalized(self.weights.iter().copied());
        }
        self.lost = lost;
        StepReport {
            ess: self.ess,
            resampled,
            lost,
            interrupted: false,
        }
    }

    fn resample_if_needed(&mut self) -> bool {
        let n = self.particles.len();
        let due = match self.params.policy {
            ResamplePolicy::Always => true,
            ResamplePolicy::BelowEss(f) => self.ess < f * n as f64,
        };
        if !due {
            return false;
        }
        // Weights are normalised, finite and sum to one here, so this cannot fail.
        if self
            .params
            .resampler
            .resample(&self.weights, n, &mut self.rng, &mut self.ancestors)
            .is_err()
        {
            return false;
        }
        self.spare.clear();
        self.spare
            .extend(self.ancestors.iter().map(|&i| self.particles[i]));
        std::mem::swap(&mut self.particles, &mut self.spare);
        self.set_uniform_weights();
        true
    }

    /// `s = A s' + B w`, seed 000 section 3.3; noise drawn serially in particle order.
    fn propagate(&mut self) {
        let LinearGaussian { a, b } = self.dynamics;
        for p in &mut self.particles {
            *p = a * *p + b * standard_normal(&mut self.rng);
        }
    }

    /// Adds each particle's log-likelihood to its log-weight, in fixed chunks; `false`
    /// when an interrupt stopped it first. Every [`CHECK_PARTICLES`] particles each
    /// chunk checks for one: on the calling thread through the checkpoint (which
    /// polls for signals there), on the pool's threads through the call's token,
    /// since a likelihood can cost milliseconds (a segmentation per sample) and a
    /// million particles ran for minutes past a Ctrl-C (issue 38).
    fn weigh<L: Likelihood<D>>(&mut self, likelihood: &L, scratch: &mut Vec<L::Scratch>) -> bool {
        let chunk = self.params.chunk_size;
        let n_chunks = self.particles.len().div_ceil(chunk);
        while scratch.len() < n_chunks {
            scratch.push(likelihood.new_scratch());
        }
        let token = interrupt::current();
        let stopped = AtomicBool::new(false);
        let interrupted = || {
            let hit = stopped.load(Ordering::Relaxed)
                || interrupt::checkpoint().is_err()
                || token.as_ref().is_some_and(|t| t.is_stopped());
            if hit {
                stopped.store(true, Ordering::Relaxed);
            }
            hit
        };
        let weigh_chunk = |(particles, log_weights): (&[SVector<f64, D>], &mut [f64]),
                           scratch: &mut L::Scratch| {
            for (k, (p, lw)) in particles.iter().zip(log_weights.iter_mut()).enumerate() {
                if k % CHECK_PARTICLES == 0 && interrupted() {
                    return;
                }
                let ll = likelihood.log_likelihood(p, scratch);
                // NaN and +inf are not likelihoods: zero weight.
                *lw += if ll.is_nan() || ll == f64::INFINITY {
                    f64::NEG_INFINITY
                } else {
                    ll
                };
            }
        };
        if self.params.parallel && n_chunks > 1 {
            self.particles
                .par_chunks(chunk)
                .zip(self.log_weights.par_chunks_mut(chunk))
                .zip(scratch.par_iter_mut())
                .for_each(|(pair, s)| weigh_chunk(pair, s));
        } else {
            for (pair, s) in self
                .particles
                .chunks(chunk)
                .zip(self.log_weights.chunks_mut(chunk))
                .zip(scratch.iter_mut())
            {
                weigh_chunk(pair, s);
            }
        }
        !stopped.load(Ordering::Relaxed)
    }

    /// Log-sum-exp normalisation; `false` when no weight is positive and finite.
    fn normalise(&mut self) -> bool {
        let max = self
            .log_weights
            .iter()
            .copied()
            .fold(f64::NEG_INFINITY, f64::max);
        if !max.is_finite() {
            return false;
        }
        let sum: f64 = self.log_weights.iter().map(|lw| (lw - max).exp()).sum();
        let log_total = max + sum.ln();
        for (lw, w) in self.log_weights.iter_mut().zip(self.weights.iter_mut()) {
            *lw -= log_total;
            *w = lw.exp();
        }
        true
    }

    fn set_uniform_weights(&mut self) {
        let n = self.particles.len() as f64;
        self.log_weights.fill(-n.ln());
        self.weights.fill(1.0 / n);
        self.ess = n;
    }

    fn weighted_mean(&self) -> SVector<f64, D> {
        self.particles
            .iter()
            .zip(&self.weights)
            .fold(SVector::zeros(), |acc, (p, &w)| acc + p * w)
    }

    /// Moves every particle, and the estimate, by `delta`: a known control input, the
    /// deterministic part of the motion (`s = A s' + u + B w`), as when an odometry
    /// tells how far the target moved in the image since the last frame. Weights,
    /// spread and random stream are unchanged.
    ///
    /// # Errors
    /// [`TrackingError::InvalidParameter`] for a non-finite `delta`; the set is then
    /// left as it was.
    pub fn shift(&mut self, delta: &SVector<f64, D>) -> Result<()> {
        if !delta.iter().all(|v| v.is_finite()) {
            return Err(TrackingError::InvalidParameter {
                name: "delta",
                reason: format!("must be finite, got {:?}", delta.as_slice()),
            });
        }
        for p in &mut self.particles {
            *p += delta;
        }
        self.mean += delta;
        Ok(())
    }

    /// Clamps every particle into the box `[lo, hi]`, component by component: a
    /// search confined to where its likelihood is cheap to evaluate (the pattern
    /// tracker's second look, inside the scale space already built). Weights, mean
    /// and random stream are unchanged.
    pub fn clamp(&mut self, lo: &SVector<f64, D>, hi: &SVector<f64, D>) {
        for p in &mut self.particles {
            for d in 0..D {
                p[d] = p[d].max(lo[d]).min(hi[d]);
            }
        }
    }

    /// Weighted mean of the particles: the state estimate.
    pub fn mean(&self) -> SVector<f64, D> {
        self.mean
    }

    /// Weighted covariance `sum w_i (s_i - mean)(s_i - mean)^T`.
    pub fn covariance(&self) -> SMatrix<f64, D, D> {
        self.particles
            .iter()
            .zip(&self.weights)
            .fold(SMatrix::zeros(), |acc, (p, &w)| {
                let d = p - self.mean;
                acc + d * d.transpose() * w
            })
    }

    /// The particle of largest weight and its (normalised) weight; the first on ties.
    pub fn max_weight(&self) -> (SVector<f64, D>, f64) {
        let mut best = 0;
        for (i, &w) in self.weights.iter().enumerate() {
            if w > self.weights[best] {
                best = i;
            }
        }
        (self.particles[best], self.weights[best])
    }

    /// Replaces the particle of smallest weight by `state`, whose log-likelihood exceeds
    /// that of the particle of largest weight by `gain` (a local search from the
    /// estimate found it on the same frame): its log-weight is the best one's plus
    /// `gain`, the weights are normalised again and the estimate recomputed. The next
    /// step resamples from a set that holds it. Nothing changes for a non-finite gain
    /// or state, or after a total loss.
    pub fn substitute_lightest(&mut self, state: SVector<f64, D>, gain: f64) {
        if self.lost || !gain.is_finite() || !state.iter().all(|v| v.is_finite()) {
            return;
        }
        let (mut light, mut heavy) = (0, 0);
        for (i, &lw) in self.log_weights.iter().enumerate() {
            if lw < self.log_weights[light] {
                light = i;
            }
            if lw > self.log_weights[heavy] {
                heavy = i;
            }
        }
        self.log_weights[light] = self.log_weights[heavy] + gain;
        self.particles[light] = state;
        if self.normalise() {
            self.mean = self.weighted_mean();
            self.ess = ess_normalized(self.weights.iter().copied());
        }
    }

    /// Effective sample size `1 / sum w^2` of the current weights.
    pub fn ess(&self) -> f64 {
        self.ess
    }

    /// Whether the last step lost the target (every likelihood was zero).
    pub fn lost(&self) -> bool {
        self.lost
    }

    /// The particles.
    pub fn particles(&self) -> &[SVector<f64, D>] {
        &self.particles
    }

    /// Their normalised weights (sum to one).
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }

    /// Their normalised log-weights.
    pub fn log_weights(&self) -> &[f64] {
        &self.log_weights
    }

    /// The dynamics.
    pub fn dynamics(&self) -> &LinearGaussian<D> {
        &self.dynamics
    }

    /// Replaces the dynamics (e.g. to change the noise with the target's scale).
    ///
    /// # Errors
    /// [`TrackingError::InvalidParameter`] if `A` or `B` has a non-finite entry.
    pub fn set_dynamics(&mut self, dynamics: LinearGaussian<D>) -> Result<()> {
        dynamics.validate()?;
        self.dynamics = dynamics;
        Ok(())
    }

    /// The parameters.
    pub fn params(&self) -> &FilterParams {
        &self.params
    }
}

fn standard_normal<const D: usize>(rng: &mut ChaCha8Rng) -> SVector<f64, D> {
    SVector::from_fn(|_, _| StandardNormal.sample(rng))
}

fn cholesky<const D: usize>(
    m: &SMatrix<f64, D, D>,
    name: &'static str,
) -> Result<SMatrix<f64, D, D>> {
    let symmetric = (m - m.transpose()).abs().max() <= 1e-12 * m.abs().max().max(1.0);
    if !m.iter().all(|v| v.is_finite()) || !symmetric {
        return Err(TrackingError::NotPositiveDefinite { name });
    }
    m.cholesky()
        .map(|c| c.l())
        .ok_or(TrackingError::NotPositiveDefinite { name })
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector1;

    use super::*;

    #[test]
    fn rejects_bad_construction() {
        let d = LinearGaussian::random_walk(Vector1::new(1.0));
        let p = FilterParams::default();
        let cov = SMatrix::<f64, 1, 1>::identity();
        assert!(ParticleFilter::new(0, Vector1::zeros(), cov, d.clone(), p.clone(), 0).is_err());
        assert_eq!(
            ParticleFilter::new(10, Vector1::zeros(), -cov, d.clone(), p.clone(), 0).unwrap_err(),
            TrackingError::NotPositiveDefinite { name: "covariance" }
        );
        assert!(
            ParticleFilter::new(10, Vector1::new(f64::NAN), cov, d.clone(), p.clone(), 0).is_err()
        );
        let bad = FilterParams {
            policy: ResamplePolicy::BelowEss(1.5),
            ..p.clone()
        };
        assert!(ParticleFilter::new(10, Vector1::zeros(), cov, d.clone(), bad, 0).is_err());
        let nan_dyn = LinearGaussian::random_walk(Vector1::new(f64::NAN));
        assert!(ParticleFilter::new(10, Vector1::zeros(), cov, nan_dyn, p, 0).is_err());
    }

    #[test]
    fn mixtures_draw_each_guess_its_count_in_place_of_the_set() {
        // The set sits near 0 with a tiny spread; guesses at 100 and -100 are told
        // apart by where the particles land. A flat likelihood keeps every particle.
        let d = LinearGaussian::random_walk(Vector1::new(1e-3));
        let cov = SMatrix::<f64, 1, 1>::identity() * 1e-6;
        let flat = |_: &SVector<f64, 1>| 0.0;
        let mut pf = ParticleFilter::new(
            50,
            Vector1::zeros(),
            cov,
            d.clone(),
            FilterParams::default(),
            3,
        )
        .unwrap();
        let sigma = Vector1::new(1.0);
        let guesses = [
            (Vector1::new(100.0), sigma, 7),
            (Vector1::new(-100.0), sigma, 3),
        ];
        pf.step_mixtures(&flat, &mut Vec::new(), &guesses);
        let count = |lo: f64, hi: f64| {
            pf.particles()
                .iter()
                .filter(|p| lo < p[0] && p[0] < hi)
                .count()
        };
        assert_eq!(
            (count(90.0, 110.0), count(-110.0, -90.0), count(-1.0, 1.0)),
            (7, 3, 40)
        );
        // One guess is exactly step_mixed, draw for draw.
        let run = |mixed: bool| {
            let mut pf = ParticleFilter::new(
                20,
                Vector1::zeros(),
                cov,
                d.clone(),
                FilterParams::default(),
                9,
            )
            .unwrap();
            let like = |s: &SVector<f64, 1>| -s[0].powi(2);
            if mixed {
                pf.step_mixed(&like, &mut Vec::new(), Vector1::new(2.0), sigma, 5);
            } else {
                pf.step_mixtures(&like, &mut Vec::new(), &[(Vector1::new(2.0), sigma, 5)]);
            }
            pf.particles().to_vec()
        };
        assert_eq!(run(true), run(false));
    }

    #[test]
    fn icondensation_weights_keep_the_prior_predictive() {
        // A flat likelihood: the weighted set must stay the prior predictive N(m, 1 +
        // 0.25) however many particles the guess at 3 pulls away (importance sampling is
        // unbiased). Without the correction the mean would be near 0.3 * 3.
        let d = LinearGaussian::random_walk(Vector1::new(0.5));
        let cov = SMatrix::<f64, 1, 1>::identity();
        let n = 4_000;
        let mut pf =
            ParticleFilter::new(n, Vector1::zeros(), cov, d, FilterParams::default(), 5).unwrap();
        let flat = |_: &SVector<f64, 1>| 0.0;
        let guess = [(Vector1::new(3.0), Vector1::new(0.5), 1_200)];
        pf.step_icondensation(&flat, &mut Vec::new(), &guess);
        let m = pf.mean()[0];
        let var = pf.covariance()[(0, 0)];
        // Standard errors: about 0.025 on the mean, 0.05 on the variance.
        assert!(m.abs() < 0.1, "{m}");
        assert!((var - 1.25).abs() < 0.2, "{var}");
        let mut plain = pf.clone();
        plain.step_mixtures(&flat, &mut Vec::new(), &guess);
        assert!(plain.mean()[0] > 0.5, "{}", plain.mean()[0]);
    }

    #[test]
    fn total_loss_recovers_around_last_estimate() {
        let d = LinearGaussian::random_walk(Vector1::new(0.1));
        let cov = SMatrix::<f64, 1, 1>::identity() * 0.01;
        let mut pf =
            ParticleFilter::new(200, Vector1::new(5.0), cov, d, FilterParams::default(), 1)
                .unwrap();
        let r = pf.step(&|_: &SVector<f64, 1>| f64::NAN);
        assert!(r.lost && pf.lost());
        assert_eq!(r.ess, 200.0);
        // Recovered set is N(5, 0.01): its mean is within 5 standard errors.
        assert!((pf.mean()[0] - 5.0).abs() < 5.0 * 0.1 / 200f64.sqrt());
        let r = pf.step(&|s: &SVector<f64, 1>| -s[0].powi(2));
        assert!(!r.lost && !pf.lost());
    }

    #[test]
    fn log_domain_survives_tiny_likelihoods() {
        // exp(-1e4) underflows to 0 in linear weights; the log domain keeps the ranking.
        let d = LinearGaussian::random_walk(Vector1::new(0.0001));
        let cov = SMatrix::<f64, 1, 1>::identity();
        let mut pf =
            ParticleFilter::new(100, Vector1::zeros(), cov, d, FilterParams::default(), 3).unwrap();
        let r = pf.step(&|s: &SVector<f64, 1>| -1e4 - (s[0] - 1.0).powi(2));
        assert!(!r.lost);
        let (best, _) = pf.max_weight();
        assert!(
            pf.particles()
                .iter()
                .all(|p| (p[0] - 1.0).abs() >= (best[0] - 1.0).abs())
        );
        assert!((pf.weights().iter().sum::<f64>() - 1.0).abs() < 1e-12);
    }
}
