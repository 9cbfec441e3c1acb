//! What the tracker's refinement and its coarse layer share: the Gauss-Newton step
//! on eq. 6 and the frame window a set of states reads.

use nalgebra::SVector;

use super::observation::{Observation, PatternLikelihood, PatternScratch};

/// The window `[x0, y0, x1, y1)` of a `size = [width, height]` frame that the
/// states of the extent `(lo, hi)` (`PatternTracker::reach`) whose scales lie in `scale`
/// read: their centres' extent grown by the footprint of the model points at
/// `offsets` and their profiles (`profile` pixels each side) over their angles and
/// those scales ([`footprint`]). Every such state therefore reads the same
/// values as from a scale space of the whole frame.
/// (A free function, so that the scale space can call it while it is built.)
pub(super) fn frame_window(
    offsets: &[[f64; 2]],
    profile: f64,
    [width, height]: [usize; 2],
    (lo, hi): ([f64; 4], [f64; 4]),
    scale: [f64; 2],
) -> [usize; 4] {
    let [fx, fy] = footprint(offsets, [lo[2], hi[2]], scale, profile);
    let clamp = |v: f64, n: usize| v.floor().clamp(0.0, n as f64) as usize;
    [
        clamp(lo[0] + fx[0] - 2.0, width),
        clamp(lo[1] + fy[0] - 2.0, height),
        clamp(hi[0] + fx[1] + 4.0, width),
        clamp(hi[1] + fy[1] + 4.0, height),
    ]
}

/// The extent `[[x_lo, x_hi], [y_lo, y_hi]]` of the model points at `offsets` (pixels
/// from the centre at scale 1), each grown by `profile` pixels along its direction,
/// under the similarity of [`super::observation::place`] at every angle of `theta = [a, b]` and scale of
/// `scale = [s_lo, s_hi]`, relative to the centre.
///
/// A point's x offset at angle `t` is `r cos(t - psi)` for some `psi` (its y offset
/// too, with another `psi`): over `[a, b]` its largest value is at an end, or is `r`
/// where `t = psi`, and then one end lies within `(b - a) / 2` of `psi`, at least `r
/// cos((b - a) / 2)`. So the largest value at the two ends plus `r_max (1 - cos((b -
/// a) / 2))` bounds every angle between (for `b - a < pi`; wider spans take the
/// radius, every angle's bound). A profile adds at most `profile` in any direction.
pub(super) fn footprint(
    offsets: &[[f64; 2]],
    theta: [f64; 2],
    scale: [f64; 2],
    profile: f64,
) -> [[f64; 2]; 2] {
    let radius = offsets.iter().map(|o| o[0].hypot(o[1])).fold(0.0, f64::max);
    let width = theta[1] - theta[0];
    let (mut lo, mut hi) = ([0.0f64; 2], [0.0f64; 2]);
    if width.is_finite() && width < std::f64::consts::PI {
        let slack = radius * (1.0 - (0.5 * width).cos());
        for t in theta {
            // `place`'s rotation: x' = c dx + s dy, y' = -s dx + c dy.
            let (s, c) = t.sin_cos();
            for o in offsets {
                let p = [c * o[0] + s * o[1], -s * o[0] + c * o[1]];
                for d in 0..2 {
                    lo[d] = lo[d].min(p[d]);
                    hi[d] = hi[d].max(p[d]);
                }
            }
        }
        for d in 0..2 {
            lo[d] -= slack + profile;
            hi[d] += slack + profile;
        }
    } else {
        lo = [-(radius + profile); 2];
        hi = [radius + profile; 2];
    }
    // Each bound at whichever end of the scales makes it widest.
    let ends = |v: f64| [v * scale[0], v * scale[1]];
    let widest = |v: f64, pick: fn(f64, f64) -> f64| {
        let [a, b] = ends(v);
        pick(a, b)
    };
    let extent = |d: usize| {
        [
            widest(lo[d], f64::min).min(0.0),
            widest(hi[d], f64::max).max(0.0),
        ]
    };
    [extent(0), extent(1)]
}

/// The Gauss-Newton stage of the refinement: steps of the normal equations of eq. 6
/// ([`PatternLikelihood::normal_equations`]), kept when they raise the likelihood,
/// and held inside the box the frame's scale space covers.
pub(super) struct Newton<'a, 'b> {
    pub(super) likelihood: &'a PatternLikelihood<'a>,
    pub(super) scratch: &'b mut PatternScratch,
    /// The refinement's reach around the weighted mean it started from.
    pub(super) bounds: (SVector<f64, 4>, SVector<f64, 4>),
    /// Steps below this in every component end the search.
    pub(super) tolerance: SVector<f64, 4>,
}

impl Newton<'_, '_> {
    /// One step from `state`; `false` when none raised the likelihood (the search
    /// has converged or the model no longer fits a quadratic).
    pub(super) fn step(&mut self, state: &mut SVector<f64, 4>, best: &mut Observation) -> bool {
        let Some(equations) = self.likelihood.normal_equations(state) else {
            return false;
        };
        // Levenberg-Marquardt's damping of the diagonal: a direction eq. 6 hardly
        // constrains (a short model's scale) moves little.
        let mut hessian = equations.hessian;
        for k in 0..4 {
            hessian[(k, k)] *= 1.0 + NEWTON_DAMPING;
        }
        let Some(delta) = hessian.cholesky().map(|c| c.solve(&equations.gradient)) else {
            return false;
        };
        // A step that does not raise the likelihood is halved once.
        for fraction in [1.0, 0.5] {
            let mut probe = *state + delta * fraction;
            for k in 0..4 {
                probe[k] = probe[k].clamp(self.bounds.0[k], self.bounds.1[k]);
            }
            let tried = self
                .likelihood
                .observe_above(&probe, self.scratch, best.log_likelihood);
            if tried.log_likelihood > best.log_likelihood {
                let moved = (probe - *state).component_div(&self.tolerance);
                *state = probe;
                *best = tried;
                // Converged: a smaller step would not change the answer.
                return moved.iter().any(|m| m.abs() > 1.0);
            }
        }
        false
    }
}

/// [`Newton::step`]s smaller than this many random-walk sigmas in every component
/// end the search (0.01 sigma: 0.05 px and 0.03 degrees by default).
pub(super) const NEWTON_TOLERANCE: f64 = 0.01;

/// Levenberg-Marquardt damping of [`Newton::step`] (a fraction of the diagonal).
const NEWTON_DAMPING: f64 = 0.05;
