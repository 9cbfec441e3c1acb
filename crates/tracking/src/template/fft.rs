//! Two-dimensional FFTs of small row-major grids through `rustfft`: rows, then columns.
//! The correlation filters live in the Fourier domain because there a correlation over
//! every circular shift is one element-wise product (Bolme et al. 2010).

use std::sync::Arc;

use rustfft::num_complex::Complex32;
use rustfft::{Fft, FftPlanner};

/// Forward and inverse plans for a `width x height` grid, with their scratch buffers.
pub(crate) struct Fft2 {
    width: usize,
    height: usize,
    row_forward: Arc<dyn Fft<f32>>,
    row_inverse: Arc<dyn Fft<f32>>,
    col_forward: Arc<dyn Fft<f32>>,
    col_inverse: Arc<dyn Fft<f32>>,
    column: Vec<Complex32>,
    scratch: Vec<Complex32>,
}

impl Fft2 {
    /// Plans for a `width x height` grid (both >= 1).
    pub(crate) fn new(width: usize, height: usize) -> Self {
        let mut planner = FftPlanner::new();
        let row_forward = planner.plan_fft_forward(width);
        let row_inverse = planner.plan_fft_inverse(width);
        let col_forward = planner.plan_fft_forward(height);
        let col_inverse = planner.plan_fft_inverse(height);
        let scratch_len = [&row_forward, &row_inverse, &col_forward, &col_inverse]
            .iter()
            .map(|p| p.get_inplace_scratch_len())
            .max()
            .unwrap_or(0);
        Self {
            width,
            height,
            row_forward,
            row_inverse,
            col_forward,
            col_inverse,
            column: vec![Complex32::default(); height],
            scratch: vec![Complex32::default(); scratch_len],
        }
    }

    /// Number of elements of a grid.
    pub(crate) fn len(&self) -> usize {
        self.width * self.height
    }

    /// In-place forward DFT `X(u, v) = sum x(x, y) exp(-2 pi i (u x / W + v y / H))`.
    pub(crate) fn forward(&mut self, data: &mut [Complex32]) {
        self.transform(data, true);
    }

    /// In-place inverse DFT, scaled by `1 / (W H)` so that it undoes [`Self::forward`].
    pub(crate) fn inverse(&mut self, data: &mut [Complex32]) {
        self.transform(data, false);
        let scale = 1.0 / self.len() as f32;
        data.iter_mut().for_each(|v| *v *= scale);
    }

    fn transform(&mut self, data: &mut [Complex32], forward: bool) {
        debug_assert_eq!(data.len(), self.len());
        let (rows, cols) = if forward {
            (&self.row_forward, &self.col_forward)
        } else {
            (&self.row_inverse, &self.col_inverse)
        };
        rows.process_with_scratch(data, &mut self.scratch);
        for x in 0..self.width {
            for (y, c) in self.column.iter_mut().enumerate() {
                *c = data[y * self.width + x];
            }
            cols.process_with_scratch(&mut self.column, &mut self.scratch);
            for (y, c) in self.column.iter().enumerate() {
                data[y * self.width + x] = *c;
            }
        }
    }

    /// The forward DFT of a real grid, into `out` (resized).
    pub(crate) fn forward_real(&mut self, real: &[f32], out: &mut Vec<Complex32>) {
        out.clear();
        out.extend(real.iter().map(|&v| Complex32::new(v, 0.0)));
        self.forward(out);
    }
}

/// Plans for one-dimensional transforms of a fixed length (the scale filter's axis).
pub(crate) struct Fft1 {
    forward: Arc<dyn Fft<f32>>,
    inverse: Arc<dyn Fft<f32>>,
    scratch: Vec<Complex32>,
}

impl Fft1 {
    /// Plans for length `n >= 1`.
    pub(crate) fn new(n: usize) -> Self {
        let mut planner = FftPlanner::new();
        let forward = planner.plan_fft_forward(n);
        let inverse = planner.plan_fft_inverse(n);
        let len = forward
            .get_inplace_scratch_len()
            .max(inverse.get_inplace_scratch_len());
        Self {
            forward,
            inverse,
            scratch: vec![Complex32::default(); len],
        }
    }

    /// In-place forward DFT.
    pub(crate) fn forward(&mut self, data: &mut [Complex32]) {
        self.forward.process_with_scratch(data, &mut self.scratch);
    }

    /// In-place inverse DFT scaled by `1 / n`.
    pub(crate) fn inverse(&mut self, data: &mut [Complex32]) {
        self.inverse.process_with_scratch(data, &mut self.scratch);
        let scale = 1.0 / data.len() as f32;
        data.iter_mut().for_each(|v| *v *= scale);
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    /// The DFT by its definition, O(n^2): the oracle.
    fn naive_dft(data: &[Complex32], width: usize, height: usize) -> Vec<Complex32> {
        let mut out = vec![Complex32::default(); data.len()];
        for v in 0..height {
            for u in 0..width {
                let mut acc = rustfft::num_complex::Complex64::default();
                for y in 0..height {
                    for x in 0..width {
                        let phase = -2.0
                            * std::f64::consts::PI
                            * ((u * x) as f64 / width as f64 + (v * y) as f64 / height as f64);
                        let z = data[y * width + x];
                        let z =
                            rustfft::num_complex::Complex64::new(f64::from(z.re), f64::from(z.im));
                        acc += z * rustfft::num_complex::Complex64::from_polar(1.0, phase);
                    }
                }
                out[v * width + u] = Complex32::new(acc.re as f32, acc.im as f32);
            }
        }
        out
    }

    proptest! {
        #[test]
        fn forward_matches_the_definition(
            width in 1usize..9, height in 1usize..9, seed in 0u64..1000,
        ) {
            let mut rng = rperc_core::rng::seeded(seed);
            let data: Vec<Complex32> = (0..width * height)
                .map(|_| Complex32::new(rand::Rng::random_range(&mut rng, -1.0..1.0), rand::Rng::random_range(&mut rng, -1.0..1.0)))
                .collect();
            let expected = naive_dft(&data, width, height);
            let mut got = data.clone();
            let mut fft = Fft2::new(width, height);
            fft.forward(&mut got);
            for (g, e) in got.iter().zip(&expected) {
                prop_assert!((g - e).norm() < 1e-4 * (width * height) as f32);
            }
            fft.inverse(&mut got);
            for (g, d) in got.iter().zip(&data) {
                prop_assert!((g - d).norm() < 1e-5 * (width * height) as f32);
            }
        }
    }
}
