//! The importance correction of a mixture proposal (Isard & Blake's ICONDENSATION):
//! particles drawn partly from the dynamics and partly around guesses (a detector's
//! answers) are reweighted by `pi(x) / q(x)`, the prior predictive over the proposal, so
//! the weighted set still targets the posterior of the stated model.

use nalgebra::SVector;

use super::filter::LinearGaussian;

/// A guess: `count` particles drawn from `N(centre, diag(sigma^2))`.
pub type Guess<const D: usize> = (SVector<f64, D>, SVector<f64, D>, usize);

/// `ln pi(x_i) - ln q(x_i)` for every particle into `out`, where
/// `pi(x) = sum_j w_j N(x; A x_j, B B^T)` is the prior predictive of the `parents` (with
/// normalised log-weights `parent_log_weights`), `g(x)` the guesses' mixture (each
/// weighted by its count) and `q = (1 - alpha) pi + alpha g` with `alpha` the guessed
/// share of the `particles.len()` particles. `None` when `B B^T` or a guess's covariance
/// is singular (no density to correct with).
pub(crate) fn log_importance<const D: usize>(
    particles: &[SVector<f64, D>],
    parents: &[SVector<f64, D>],
    parent_log_weights: &[f64],
    dynamics: &LinearGaussian<D>,
    guesses: &[Guess<D>],
    out: &mut Vec<f64>,
) -> Option<()> {
    let n = particles.len();
    let total = guesses.iter().map(|g| g.2).sum::<usize>().min(n);
    out.clear();
    if total == 0 {
        out.resize(n, 0.0);
        return Some(());
    }
    let alpha = total as f64 / n as f64;
    let chol = (dynamics.b * dynamics.b.transpose()).cholesky()?;
    let l = chol.l();
    let log_det = l.diagonal().iter().map(|v| v.ln()).sum::<f64>();
    let whiten = |v: SVector<f64, D>| l.solve_lower_triangular(&v);
    // pi: every particle against every parent's prediction, in whitened coordinates.
    let means: Vec<SVector<f64, D>> = parents
        .iter()
        .map(|p| whiten(dynamics.a * p).unwrap_or_else(SVector::zeros))
        .collect();
    let half_log_2pi = 0.5 * (2.0 * std::f64::consts::PI).ln() * D as f64;
    let mut terms = Vec::with_capacity(parents.len().max(guesses.len()));
    for x in particles {
        let z = whiten(*x)?;
        terms.clear();
        terms.extend(
            means
                .iter()
                .zip(parent_log_weights)
                .map(|(m, lw)| lw - 0.5 * (z - m).norm_squared() - log_det - half_log_2pi),
        );
        let log_pi = log_sum_exp(&terms);
        terms.clear();
        for (centre, sigma, count) in guesses.iter().filter(|g| g.2 > 0) {
            let log_norm: f64 = sigma.iter().map(|s| s.ln()).sum::<f64>() + half_log_2pi;
            let d2 = (x - centre).component_div(sigma).norm_squared();
            terms.push((*count as f64 / total as f64).ln() - 0.5 * d2 - log_norm);
        }
        if terms.iter().any(|t| t.is_nan()) {
            return None;
        }
        let log_g = log_sum_exp(&terms);
        let log_q = log_sum_exp(&[(1.0 - alpha).ln() + log_pi, alpha.ln() + log_g]);
        out.push(log_pi - log_q);
    }
    Some(())
}

/// `ln sum exp(v)`, `-inf` for an empty or all `-inf` slice.
fn log_sum_exp(v: &[f64]) -> f64 {
    let max = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !max.is_finite() {
        return max;
    }
    max + v.iter().map(|t| (t - max).exp()).sum::<f64>().ln()
}
