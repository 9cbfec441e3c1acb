//! DSST's scale filter (Danelljan et al. 2014, section 2.3): a one-dimensional
//! correlation filter over `n_scales` samples of the target at scales
//! `step^k, k = -(S-1)/2 .. (S-1)/2`, each resampled to a fixed model size and
//! described by HOG, so the scale is found by one small correlation instead of
//! running the translation filter at several sizes.

use rustfft::num_complex::Complex32;

use super::dcf::{DcfModel, hann_1d};
use super::fft::Fft1;

/// The 1-D Gaussian label over scale indices, peaked at the middle index (no change).
pub(crate) fn scale_label(n: usize, sigma: f64) -> Vec<f32> {
    let mid = (n / 2) as f64;
    (0..n)
        .map(|k| (-((k as f64 - mid).powi(2)) / (2.0 * sigma * sigma)).exp() as f32)
        .collect()
}

/// The scale filter: per feature dimension a numerator over the scale axis, one shared
/// denominator.
pub(crate) struct ScaleFilter {
    n: usize,
    fft: Fft1,
    window: Vec<f32>,
    model: DcfModel,
    sample_hat: Vec<Vec<Complex32>>,
}

impl ScaleFilter {
    /// An untrained filter over `n` scales with label width `sigma` (scale steps).
    pub(crate) fn new(n: usize, sigma: f64, lambda: f64) -> Self {
        let mut fft = Fft1::new(n);
        let mut label_hat: Vec<Complex32> = scale_label(n, sigma)
            .iter()
            .map(|&v| Complex32::new(v, 0.0))
            .collect();
        fft.forward(&mut label_hat);
        Self {
            n,
            fft,
            window: hann_1d(n),
            model: DcfModel::new(label_hat, lambda),
            sample_hat: Vec::new(),
        }
    }

    /// `samples[k]` is the feature vector at scale index `k` (all the same length):
    /// windowed over the scale axis and transformed per dimension.
    fn transform(&mut self, samples: &[Vec<f32>]) {
        let dims = samples.first().map_or(0, Vec::len);
        self.sample_hat.resize_with(dims, Vec::new);
        for (d, out) in self.sample_hat.iter_mut().enumerate() {
            out.clear();
            out.extend(
                samples
                    .iter()
                    .zip(&self.window)
                    .map(|(s, w)| Complex32::new(s[d] * w, 0.0)),
            );
            self.fft.forward(out);
        }
    }

    /// Learns from one set of scale samples with learning rate `rate`.
    pub(crate) fn train(&mut self, samples: &[Vec<f32>], rate: f32) {
        debug_assert_eq!(samples.len(), self.n);
        self.transform(samples);
        self.model.train(&self.sample_hat, rate);
    }

    /// The response over scale indices; its peak's index minus the middle is the
    /// scale change in steps.
    pub(crate) fn respond(&mut self, samples: &[Vec<f32>]) -> Vec<f32> {
        self.transform(samples);
        let mut spectrum = Vec::with_capacity(self.n);
        self.model.respond(&self.sample_hat, &mut spectrum);
        self.fft.inverse(&mut spectrum);
        spectrum.iter().map(|c| c.re).collect()
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    proptest! {
        /// Closed form: trained on samples `x`, the response to `x` is
        /// `F^-1(G sum|X|^2 / (sum|X|^2 + lambda))`, the label itself as lambda -> 0;
        /// and samples rolled by `m` scale steps answer with a peak `m` steps from the
        /// middle (the window is undone so the windowed signal is exactly rolled).
        #[test]
        fn peak_follows_a_scale_shift(seed in 0u64..300, shift in 0usize..17) {
            let (n, dims) = (17usize, 6usize);
            let mut rng = rperc_core::rng::seeded(seed);
            let x: Vec<Vec<f32>> = (0..n)
                .map(|_| (0..dims).map(|_| rand::Rng::random_range(&mut rng, -1.0..1.0)).collect())
                .collect();
            let mut filter = ScaleFilter::new(n, 1.5, 1e-7);
            filter.train(&x, 1.0);
            let response = filter.respond(&x);
            for (r, g) in response.iter().zip(scale_label(n, 1.5)) {
                prop_assert!((r - g).abs() < 2e-2);
            }
            let w = filter.window.clone();
            let rolled: Vec<Vec<f32>> = (0..n)
                .map(|k| {
                    let src = (k + n - shift) % n;
                    x[src].iter().map(|v| v * w[src] / w[k]).collect()
                })
                .collect();
            let response = filter.respond(&rolled);
            let peak = response.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)).unwrap().0;
            prop_assert_eq!(peak, (n / 2 + shift) % n);
        }
    }
}
