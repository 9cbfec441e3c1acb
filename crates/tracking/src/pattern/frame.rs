//! The frames the pattern tracker reads: borrowed grey or RGB views, read as grey.

use rperc_core::image::{GrayImage, GrayView, RgbView, luma};

/// A borrowed 8-bit frame, grey (`H x W`) or RGB (`H x W x 3`, converted to luma).
#[derive(Debug, Clone, Copy)]
pub enum PatternFrame<'a> {
    /// One byte per pixel.
    Gray(GrayView<'a>),
    /// Three bytes per pixel, RGB.
    Rgb(RgbView<'a>),
}

impl PatternFrame<'_> {
    /// `(width, height)`.
    pub fn size(&self) -> (usize, usize) {
        match self {
            PatternFrame::Gray(v) => (v.width(), v.height()),
            PatternFrame::Rgb(v) => (v.width(), v.height()),
        }
    }

    /// Refills `out` with the frame's grey levels, reusing its buffer.
    pub(super) fn to_gray(self, out: &mut GrayImage) {
        match self {
            PatternFrame::Gray(v) => out.set_from_gray(&v),
            PatternFrame::Rgb(v) => out.set_from_rgb(&v),
        }
    }

    /// Refills `out` with the grey levels of `window = [x0, y0, x1, y1)` only (the
    /// same values as [`Self::to_gray`] there).
    pub(super) fn window_to_gray(self, window: [usize; 4], out: &mut GrayImage) {
        let [x0, y0, x1, y1] = window;
        out.width = x1 - x0;
        out.height = y1 - y0;
        out.data.clear();
        for y in y0..y1 {
            match self {
                PatternFrame::Gray(v) => {
                    let row = &v.data()[y * v.width()..][x0..x1];
                    out.data.extend(row.iter().map(|&g| f32::from(g)));
                }
                PatternFrame::Rgb(v) => {
                    let row = &v.row(y)[3 * x0..3 * x1];
                    out.data
                        .extend(row.chunks_exact(3).map(|p| luma(p[0], p[1], p[2])));
                }
            }
        }
    }

    /// Refills `out` with the means of the `factor x factor` blocks of the grey levels
    /// of `window = [x0, y0, x1, y1)` (whose sides are multiples of `factor`): the
    /// window read by [`Self::window_to_gray`], then block-averaged. A grey frame's
    /// blocks are summed as integers, which is exact, so the values are those of the
    /// two passes (whose `f32` sums of whole numbers are exact too); an RGB frame
    /// takes the two passes through `fine`.
    pub(super) fn window_to_blocks(
        self,
        window: [usize; 4],
        factor: usize,
        fine: &mut GrayImage,
        out: &mut GrayImage,
    ) {
        let PatternFrame::Gray(v) = self else {
            self.window_to_gray(window, fine);
            downsample(fine, factor, out);
            return;
        };
        let factor = factor.max(1);
        let [x0, y0, x1, y1] = window;
        let (w, h) = ((x1 - x0) / factor, (y1 - y0) / factor);
        out.width = w;
        out.height = h;
        out.data.clear();
        let mut sums = vec![0u32; w];
        let norm = 1.0 / (factor * factor) as f32;
        for cy in 0..h {
            sums.fill(0);
            for y in y0 + cy * factor..y0 + (cy + 1) * factor {
                let row = &v.data()[y * v.width()..][x0..x0 + w * factor];
                for (sum, block) in sums.iter_mut().zip(row.chunks_exact(factor)) {
                    *sum += block.iter().map(|&g| u32::from(g)).sum::<u32>();
                }
            }
            out.data.extend(sums.iter().map(|&s| s as f32 * norm));
        }
    }
}

/// `out` (resized) = `image` averaged over blocks of `factor x factor` pixels; a
/// partial block at the right or bottom edge is dropped.
pub(super) fn downsample(image: &GrayImage, factor: usize, out: &mut GrayImage) {
    let factor = factor.max(1);
    let (w, h) = (image.width / factor, image.height / factor);
    out.width = w;
    out.height = h;
    out.data.clear();
    out.data.resize(w * h, 0.0);
    let norm = 1.0 / (factor * factor) as f32;
    for y in 0..h * factor {
        let row = &image.data[y * image.width..][..w * factor];
        let sums = &mut out.data[(y / factor) * w..][..w];
        for (sum, block) in sums.iter_mut().zip(row.chunks_exact(factor)) {
            *sum += block.iter().sum::<f32>();
        }
    }
    for v in &mut out.data {
        *v *= norm;
    }
}
