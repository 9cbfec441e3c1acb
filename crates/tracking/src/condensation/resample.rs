//! Resampling (seed 000 section 3.3, "Sampling from p(x_{t-1} | Z_{t-1})") and the
//! effective sample size. Every scheme draws `n` indices with replacement so that the
//! expected number of copies of particle `i` is `n * w_i`; they differ in variance.

use rand::Rng;

use crate::error::{Result, TrackingError};

rperc_core::named_enum! {
    /// How a weighted particle set is turned into an equally weighted one.
    #[derive(Default)]
    pub enum Resampler: "resampler" {
        /// Independent draws from the weights, as in the seed: counts are multinomial.
        Multinomial = "multinomial",
        /// One uniform offset, `n` evenly spaced pointers: each count is `floor(n w)` or
        /// `ceil(n w)`. Lowest variance in practice; the default.
        #[default]
        Systematic = "systematic",
        /// One independent uniform per stratum `[k/n, (k+1)/n)`.
        Stratified = "stratified",
        /// `floor(n w_i)` copies deterministically, the remainder drawn multinomially
        /// from the residual weights `n w_i - floor(n w_i)`.
        Residual = "residual",
    }
}

/// Effective sample size `(sum w_i)^2 / sum(w_i^2)` (Kong, Liu & Wong) of
/// non-negative weights, which need not be normalised: `n` for equal weights, 1 when
/// one particle carries all the weight.
///
/// # Errors
/// [`TrackingError::InvalidWeights`] for the weights [`Resampler::resample`] refuses:
/// empty, negative, non-finite or all zero.
///
/// # Examples
/// ```
/// use tracking::effective_sample_size;
///
/// assert_eq!(effective_sample_size(&[0.25; 4]).unwrap(), 4.0);
/// assert_eq!(effective_sample_size(&[1.0; 4]).unwrap(), 4.0);
/// assert_eq!(effective_sample_size(&[0.5, 0.25, 0.25]).unwrap(), 1.0 / 0.375);
/// assert!(effective_sample_size(&[0.5, f64::NAN]).is_err());
/// ```
pub fn effective_sample_size(weights: &[f64]) -> Result<f64> {
    let total = checked_total(weights)?;
    Ok(ess_normalized(weights.iter().map(|&w| total.share(w))))
}

/// `1 / sum(w_i^2)` of weights that already sum to one.
pub(crate) fn ess_normalized(weights: impl Iterator<Item = f64>) -> f64 {
    let sum_sq: f64 = weights.map(|w| w * w).sum();
    if sum_sq > 0.0 { 1.0 / sum_sq } else { 0.0 }
}

impl Resampler {
    /// Draws `n` ancestor indices into `out` (cleared first; sorted ascending) from
    /// non-negative `weights`, which need not be normalised.
    ///
    /// # Errors
    /// [`TrackingError::InvalidWeights`] if `weights` is empty, has a negative or
    /// non-finite entry, or sums to zero.
    ///
    /// # Examples
    /// ```
    /// use rand::SeedableRng;
    /// use tracking::Resampler;
    ///
    /// let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    /// let mut idx = Vec::new();
    /// Resampler::Systematic.resample(&[0.5, 0.0, 0.5], 4, &mut rng, &mut idx).unwrap();
    /// assert_eq!(idx, vec![0, 0, 2, 2]);
    /// ```
    pub fn resample<R: Rng + ?Sized>(
        &self,
        weights: &[f64],
        n: usize,
        rng: &mut R,
        out: &mut Vec<usize>,
    ) -> Result<()> {
        let total = checked_total(weights)?;
        rperc_core::check_allocation("n", n as u128, std::mem::size_of::<usize>() as u128)?;
        out.clear();
        out.reserve(n);
        if n == 0 {
            return Ok(());
        }
        match self {
            Resampler::Multinomial => multinomial(weights, total, n, rng, out),
            Resampler::Systematic => {
                let u0: f64 = rng.random();
                walk_pointers(weights, total, n, |k| (k as f64 + u0) / n as f64, out);
            }
            Resampler::Stratified => {
                walk_pointers(
                    weights,
                    total,
                    n,
                    |k| (k as f64 + rng.random::<f64>()) / n as f64,
                    out,
                );
            }
            Resampler::Residual => residual(weights, total, n, rng, out),
        }
        Ok(())
    }
}

/// The sum of the weights, kept as `max * sum(w_i / max)`: finite weights near the
/// largest float (1e308 each) overflow a plain sum to infinity, and every `w_i / inf`
/// is then 0, which gave all the particles to the last index.
#[derive(Debug, Clone, Copy)]
struct Total {
    /// The largest weight (> 0).
    max: f64,
    /// `sum(w_i / max)`, in `[1, n]`: finite for any number of finite weights.
    scaled: f64,
}

impl Total {
    /// `w / sum(w_i)`, without forming the sum.
    fn share(&self, w: f64) -> f64 {
        (w / self.max) / self.scaled
    }
}

fn checked_total(weights: &[f64]) -> Result<Total> {
    if weights.is_empty() {
        return Err(TrackingError::InvalidWeights {
            reason: "no weights".into(),
        });
    }
    let mut max = 0.0_f64;
    for (i, &w) in weights.iter().enumerate() {
        if !(w.is_finite() && w >= 0.0) {
            return Err(TrackingError::InvalidWeights {
                reason: format!("weight {i} is {w}; weights must be finite and >= 0"),
            });
        }
        max = max.max(w);
    }
    if max > 0.0 {
        let scaled = weights.iter().map(|w| w / max).sum();
        Ok(Total { max, scaled })
    } else {
        Err(TrackingError::InvalidWeights {
            reason: "all weights are zero".into(),
        })
    }
}

/// Sends ascending pointers `u_k` in [0, 1) (given by `pointer(k)`, k = 0..n, which must
/// be non-decreasing) through the cumulative distribution of `weights`.
fn walk_pointers(
    weights: &[f64],
    total: Total,
    n: usize,
    mut pointer: impl FnMut(usize) -> f64,
    out: &mut Vec<usize>,
) {
    let last = weights.len() - 1;
    let mut i = 0;
    let mut cumulative = total.share(weights[0]);
    for k in 0..n {
        let u = pointer(k);
        while u >= cumulative && i < last {
            i += 1;
            cumulative += total.share(weights[i]);
        }
        out.push(i);
    }
}

/// `n` independent draws in O(n + m): ordered uniforms generated from the largest down
/// (u_(k) = u_(k+1) * U^(1/k)), matched against the cumulative sum from the top.
fn multinomial<R: Rng + ?Sized>(
    weights: &[f64],
    total: Total,
    n: usize,
    rng: &mut R,
    out: &mut Vec<usize>,
) {
    let mut i = weights.len() - 1;
    // Lower end of the cumulative interval of particle i.
    let mut lower = 1.0 - total.share(weights[i]);
    let mut u = 1.0;
    for k in (1..=n).rev() {
        u *= rng.random::<f64>().powf(1.0 / k as f64);
        while u < lower && i > 0 {
            i -= 1;
            lower -= total.share(weights[i]);
        }
        // A zero-weight particle is never picked, even when rounding leaves `lower` a hair off.
        while weights[i] == 0.0 && i > 0 {
            i -= 1;
            lower -= total.share(weights[i]);
        }
        out.push(i);
    }
    if weights[out[0]] == 0.0 {
        // Rounding pushed the smallest pointers below index 0's interval: first positive.
        let first = weights.iter().position(|&w| w > 0.0).unwrap_or(0);
        for idx in out.iter_mut() {
            if weights[*idx] == 0.0 {
                *idx = first;
            }
        }
    }
    out.reverse();
}

fn residual<R: Rng + ?Sized>(
    weights: &[f64],
    total: Total,
    n: usize,
    rng: &mut R,
    out: &mut Vec<usize>,
) {
    let expected_copies = |w: f64| n as f64 * total.share(w);
    let mut residual_total = 0.0;
    for (i, &w) in weights.iter().enumerate() {
        let expected = expected_copies(w);
        let copies = expected.floor();
        residual_total += expected - copies;
        out.extend(std::iter::repeat_n(i, copies as usize));
    }
    let remaining = n.saturating_sub(out.len());
    out.truncate(n);
    if remaining == 0 || residual_total <= 0.0 {
        // Rounding left no residual mass: top up with the heaviest particle.
        if out.len() < n {
            let heaviest = argmax(weights);
            out.resize(n, heaviest);
        }
        out.sort_unstable();
        return;
    }
    let start = out.len();
    // The residual weights are recomputed on the fly: no buffer needed.
    let residuals = |i: usize| {
        let e = expected_copies(weights[i]);
        e - e.floor()
    };
    let mut i = weights.len() - 1;
    let mut lower = residual_total - residuals(i);
    let mut u = residual_total;
    for k in (1..=remaining).rev() {
        u *= rng.random::<f64>().powf(1.0 / k as f64);
        while (u < lower || residuals(i) == 0.0) && i > 0 {
            i -= 1;
            lower -= residuals(i);
        }
        out.push(i);
    }
    debug_assert_eq!(out.len() - start, remaining);
    out.sort_unstable();
}

fn argmax(weights: &[f64]) -> usize {
    let mut best = 0;
    for (i, &w) in weights.iter().enumerate() {
        if w > weights[best] {
            best = i;
        }
    }
    best
}
