//! The learned model of a discriminative correlation filter (Danelljan et al. 2014,
//! eqs. 3-5), shared by the 2-D translation filter ([`super::filter`]) and the 1-D
//! scale filter ([`super::scale`]): the two differ only in how a sample is windowed
//! and transformed, not in how the model learns or answers.

use rustfft::num_complex::Complex32;

/// The Hann (cosine) window of `n` samples: tapers a sample's ends so the circular
/// correlation does not see the wrap-around seam.
pub(crate) fn hann_1d(n: usize) -> Vec<f32> {
    (0..n)
        .map(|i| {
            let t = 2.0 * std::f64::consts::PI * (i as f64 + 0.5) / n as f64;
            (0.5 - 0.5 * t.cos()) as f32
        })
        .collect()
}

/// Numerator `A^l = conj(G) X^l` per channel and the shared denominator
/// `B = sum_l conj(X^l) X^l`, running averages with the learning rate, over the
/// transformed label `G`.
pub(crate) struct DcfModel {
    label_hat: Vec<Complex32>,
    numerator: Vec<Vec<Complex32>>,
    denominator: Vec<f32>,
    lambda: f32,
    trained: bool,
}

impl DcfModel {
    /// An untrained model for the transformed label `label_hat` and the regulariser
    /// `lambda`.
    pub(crate) fn new(label_hat: Vec<Complex32>, lambda: f64) -> Self {
        let n = label_hat.len();
        Self {
            label_hat,
            numerator: Vec::new(),
            denominator: vec![0.0; n],
            lambda: lambda as f32,
            trained: false,
        }
    }

    /// Learns from the transformed channels `sample_hat` with learning rate `rate`
    /// (the first sample replaces the model whatever the rate).
    pub(crate) fn train(&mut self, sample_hat: &[Vec<Complex32>], rate: f32) {
        let rate = if self.trained { rate } else { 1.0 };
        let n = self.label_hat.len();
        self.numerator
            .resize_with(sample_hat.len(), || vec![Complex32::default(); n]);
        for (num, x) in self.numerator.iter_mut().zip(sample_hat) {
            for ((a, xv), g) in num.iter_mut().zip(x).zip(&self.label_hat) {
                *a = *a * (1.0 - rate) + g.conj() * xv * rate;
            }
        }
        for (k, b) in self.denominator.iter_mut().enumerate() {
            let energy: f32 = sample_hat.iter().map(|x| x[k].norm_sqr()).sum();
            *b = *b * (1.0 - rate) + energy * rate;
        }
        self.trained = true;
    }

    /// The response's spectrum `sum_l conj(A^l) Z^l / (B + lambda)` to the transformed
    /// channels `sample_hat`, into `spectrum` (the caller inverts it).
    pub(crate) fn respond(&self, sample_hat: &[Vec<Complex32>], spectrum: &mut Vec<Complex32>) {
        spectrum.clear();
        spectrum.resize(self.label_hat.len(), Complex32::default());
        for (num, z) in self.numerator.iter().zip(sample_hat) {
            for ((s, a), zv) in spectrum.iter_mut().zip(num).zip(z) {
                *s += a.conj() * zv;
            }
        }
        for (s, b) in spectrum.iter_mut().zip(&self.denominator) {
            *s /= b + self.lambda;
        }
    }

    /// `A^l / (B + lambda)` per channel: the filter's spectra (for the tests'
    /// brute-force correlation).
    #[cfg(test)]
    pub(crate) fn filters(&self) -> Vec<Vec<Complex32>> {
        self.numerator
            .iter()
            .map(|num| {
                num.iter()
                    .zip(&self.denominator)
                    .map(|(a, b)| a / (b + self.lambda))
                    .collect()
            })
            .collect()
    }
}
