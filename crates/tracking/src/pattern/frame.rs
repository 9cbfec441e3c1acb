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
}
