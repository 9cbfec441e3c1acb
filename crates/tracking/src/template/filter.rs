//! The translation correlation filter: a multi-channel discriminative correlation
//! filter in the Fourier domain (Danelljan et al. 2014, eqs. 3-5; Staple's template
//! model). Numerator `A^l = conj(G) X^l` and denominator `B = sum_l conj(X^l) X^l` are
//! running averages with the learning rate; the response map to a sample `Z` is
//! `F^-1(sum_l conj(A^l) Z^l / (B + lambda))`.

use rustfft::num_complex::Complex32;

use super::dcf::{DcfModel, hann_1d};
use super::fft::Fft2;
use super::hog::FeatureMap;

/// A Gaussian of standard deviation `sigma` cells with its peak at cell (0, 0),
/// wrapped circularly: the desired response (the label) of the filter.
pub(crate) fn gaussian_label(width: usize, height: usize, sigma: f64) -> Vec<f32> {
    let wrap = |i: usize, n: usize| {
        let i = i as f64;
        let n = n as f64;
        if i < n / 2.0 { i } else { i - n }
    };
    let mut out = Vec::with_capacity(width * height);
    for y in 0..height {
        for x in 0..width {
            let (dx, dy) = (wrap(x, width), wrap(y, height));
            out.push((-(dx * dx + dy * dy) / (2.0 * sigma * sigma)).exp() as f32);
        }
    }
    out
}

/// The separable Hann (cosine) window: tapers the patch's edges so the circular
/// correlation does not see the wrap-around seam.
pub(crate) fn hann(width: usize, height: usize) -> Vec<f32> {
    let (wx, wy) = (hann_1d(width), hann_1d(height));
    wy.iter()
        .flat_map(|&a| wx.iter().map(move |&b| a * b))
        .collect()
}

/// The translation filter's state for one grid size.
pub(crate) struct CorrelationFilter {
    fft: Fft2,
    window: Vec<f32>,
    model: DcfModel,
    sample_hat: Vec<Vec<Complex32>>,
    spectrum: Vec<Complex32>,
}

impl CorrelationFilter {
    /// An untrained filter for `width x height` cells with the label's `sigma` (cells)
    /// and the regulariser `lambda`.
    pub(crate) fn new(width: usize, height: usize, sigma: f64, lambda: f64) -> Self {
        let mut fft = Fft2::new(width, height);
        let mut label_hat = Vec::new();
        fft.forward_real(&gaussian_label(width, height, sigma), &mut label_hat);
        Self {
            fft,
            window: hann(width, height),
            model: DcfModel::new(label_hat, lambda),
            sample_hat: Vec::new(),
            spectrum: Vec::new(),
        }
    }

    /// The windowed DFT of every channel of `map` into `self.sample_hat`.
    fn transform(&mut self, map: &FeatureMap) {
        self.sample_hat.resize_with(map.planes.len(), Vec::new);
        for (plane, out) in map.planes.iter().zip(&mut self.sample_hat) {
            out.clear();
            out.extend(
                plane
                    .iter()
                    .zip(&self.window)
                    .map(|(v, w)| Complex32::new(v * w, 0.0)),
            );
            self.fft.forward(out);
        }
    }

    /// Learns from `map` with learning rate `rate` (1 replaces the model: the first frame).
    pub(crate) fn train(&mut self, map: &FeatureMap, rate: f32) {
        self.transform(map);
        self.model.train(&self.sample_hat, rate);
    }

    /// The response map to `map`, row-major, cell (0, 0) the zero shift, wrapped.
    pub(crate) fn respond(&mut self, map: &FeatureMap, out: &mut Vec<f32>) {
        self.transform(map);
        self.model.respond(&self.sample_hat, &mut self.spectrum);
        self.fft.inverse(&mut self.spectrum);
        out.clear();
        out.extend(self.spectrum.iter().map(|c| c.re));
    }

    /// The spatial filter of each channel, `h^l = F^-1(A^l / (B + lambda))`: the
    /// response is the circular cross-correlation `r(d) = sum_l sum_p h^l(p) z^l(p + d)`
    /// of these with the windowed sample (what the tests check by brute force).
    #[cfg(test)]
    pub(crate) fn spatial(&mut self) -> Vec<Vec<f32>> {
        let mut out = Vec::new();
        for mut h in self.model.filters() {
            self.fft.inverse(&mut h);
            out.push(h.iter().map(|c| c.re).collect());
        }
        out
    }

    /// The cosine window (for the tests' brute-force correlation).
    #[cfg(test)]
    pub(crate) fn window(&self) -> &[f32] {
        &self.window
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    fn random_map(width: usize, height: usize, channels: usize, seed: u64) -> FeatureMap {
        let mut rng = rperc_core::rng::seeded(seed);
        FeatureMap {
            width,
            height,
            planes: (0..channels)
                .map(|_| {
                    (0..width * height)
                        .map(|_| rand::Rng::random_range(&mut rng, -1.0..1.0))
                        .collect()
                })
                .collect(),
        }
    }

    proptest! {
        /// The FFT response equals the brute-force circular cross-correlation of the
        /// spatial filters with the windowed sample.
        #[test]
        fn response_is_the_spatial_correlation(
            width in 3usize..10, height in 3usize..10, seed in 0u64..500,
        ) {
            let mut filter = CorrelationFilter::new(width, height, 1.0, 1e-2);
            filter.train(&random_map(width, height, 3, seed), 1.0);
            filter.train(&random_map(width, height, 3, seed + 1), 0.3);
            let z = random_map(width, height, 3, seed + 2);
            let mut fast = Vec::new();
            filter.respond(&z, &mut fast);
            let h = filter.spatial();
            let win = filter.window().to_vec();
            for dy in 0..height {
                for dx in 0..width {
                    let mut r = 0.0f64;
                    for (hl, zl) in h.iter().zip(&z.planes) {
                        for py in 0..height {
                            for px in 0..width {
                                let q = ((py + dy) % height) * width + (px + dx) % width;
                                r += f64::from(hl[py * width + px]) * f64::from(zl[q] * win[q]);
                            }
                        }
                    }
                    prop_assert!((f64::from(fast[dy * width + dx]) - r).abs() < 1e-3, "{dx},{dy}");
                }
            }
        }

        /// Closed form: trained on one sample with a tiny lambda, the response to that
        /// sample is the label `G |X|^2 / (|X|^2 + lambda)` ~ the Gaussian itself, and
        /// to a circular shift of it, the label shifted by as much.
        #[test]
        fn trained_sample_answers_with_its_label(seed in 0u64..300, sx in 0usize..8, sy in 0usize..6) {
            let (w, h) = (8usize, 6usize);
            let mut filter = CorrelationFilter::new(w, h, 1.2, 1e-7);
            let base = random_map(w, h, 1, seed);
            let win = hann(w, h);
            filter.train(&base, 1.0);
            let mut response = Vec::new();
            filter.respond(&base, &mut response);
            let label = gaussian_label(w, h, 1.2);
            for (r, g) in response.iter().zip(&label) {
                prop_assert!((r - g).abs() < 2e-2, "{r} vs {g}");
            }
            // A shifted sample: shift the windowed signal, so undo the window after.
            let shifted = FeatureMap {
                width: w,
                height: h,
                planes: vec![(0..w * h)
                    .map(|k| {
                        let (x, y) = (k % w, k / w);
                        let src = ((y + h - sy) % h) * w + (x + w - sx) % w;
                        base.planes[0][src] * win[src] / win[k]
                    })
                    .collect()],
            };
            filter.respond(&shifted, &mut response);
            let peak = response
                .iter()
                .enumerate()
                .max_by(|a, b| a.1.total_cmp(b.1))
                .map(|(k, _)| k)
                .unwrap();
            prop_assert_eq!(peak, sy * w + sx);
        }
    }
}
