//! The importance correction of a mixture proposal (Isard & Blake's ICONDENSATION):
//! particles drawn partly from the dynamics and partly around guesses (a detector's
//! answers) are reweighted by `pi(x) / q(x)`, the prior predictive over the proposal, so
//! the weighted set still targets the posterior of the stated model.

use nalgebra::SVector;

use super::dynamics::LinearGaussian;

/// A guess: `count` particles drawn from `N(centre, diag(sigma^2))`.
pub type Guess<const D: usize> = (SVector<f64, D>, SVector<f64, D>, usize);

/// `ln pi(x_i) - ln q(x_i)` for every particle into `out`, where
/// `pi(x) = sum_j w_j N(x; A x_j, B B^T)` is the prior predictive of the `parents`
/// (states with normalised log-weights `ln w_j`), `g(x)` the guesses' mixture (each
/// weighted by its count) and `q = (1 - alpha) pi + alpha g` with `alpha` the guessed
/// share of the `particles.len()` particles. `None` when `B B^T` or a guess's covariance
/// is singular (no density to correct with).
pub(crate) fn log_importance<const D: usize>(
    particles: &[SVector<f64, D>],
    parents: &[(SVector<f64, D>, f64)],
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
    let means: Vec<(SVector<f64, D>, f64)> = parents
        .iter()
        .map(|(p, lw)| (whiten(dynamics.a * p).unwrap_or_else(SVector::zeros), *lw))
        .collect();
    let half_log_2pi = 0.5 * (2.0 * std::f64::consts::PI).ln() * D as f64;
    let mut terms = Vec::with_capacity(parents.len().max(guesses.len()));
    for x in particles {
        let z = whiten(*x)?;
        terms.clear();
        terms.extend(
            means
                .iter()
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

/// The weighted set `(states, log_weights)` with runs of equal states (a resampled
/// set's copies of one ancestor sit side by side) merged into one entry each, whose
/// log-weight is the log of the run's summed weight: the same mixture, fewer terms.
pub(crate) fn merge_copies<const D: usize>(
    states: &[SVector<f64, D>],
    log_weights: &[f64],
    out: &mut Vec<(SVector<f64, D>, f64)>,
) {
    out.clear();
    for (s, &lw) in states.iter().zip(log_weights) {
        match out.last_mut() {
            Some((last, total)) if last == s => *total = log_sum_exp(&[*total, lw]),
            _ => out.push((*s, lw)),
        }
    }
}

/// `ln sum exp(v)`, `-inf` for an empty or all `-inf` slice.
fn log_sum_exp(v: &[f64]) -> f64 {
    let max = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !max.is_finite() {
        return max;
    }
    max + v.iter().map(|t| (t - max).exp()).sum::<f64>().ln()
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector2;

    use super::*;

    #[test]
    fn merged_copies_give_the_same_correction_as_every_copy() {
        // Parents as resampling leaves them: copies side by side, weights 1/n each.
        let states = [0.0, 0.0, 0.0, 1.5, 2.0, 2.0].map(|x| Vector2::new(x, -x));
        let n = states.len() as f64;
        let log_weights = [-n.ln(); 6];
        let mut merged = Vec::new();
        merge_copies(&states, &log_weights, &mut merged);
        assert_eq!(merged.len(), 3);
        assert!((merged[0].1 - (3.0 / n).ln()).abs() < 1e-12);
        let every: Vec<_> = states.iter().copied().zip(log_weights).collect();
        let dynamics = LinearGaussian::random_walk(Vector2::new(0.7, 0.4));
        let particles = [Vector2::new(0.3, 0.1), Vector2::new(1.9, -2.2)];
        let guesses = [(Vector2::new(1.0, 1.0), Vector2::new(0.5, 0.5), 1)];
        let (mut a, mut b) = (Vec::new(), Vec::new());
        log_importance(&particles, &merged, &dynamics, &guesses, &mut a).unwrap();
        log_importance(&particles, &every, &dynamics, &guesses, &mut b).unwrap();
        for (x, y) in a.iter().zip(&b) {
            assert!((x - y).abs() < 1e-12, "{x} {y}");
        }
    }
}
