//! The half-resolution level of the colour tracker's search: the window of centres is
//! scored on a 2 x 2-averaged frame (a quarter of the pixels, a quarter of the
//! positions), then the best position is refined at full resolution around it.

use super::gradient::GradientImage;
use super::space::{BinImage, ColorSpace};
use crate::frame::RgbFrame;

/// The 2 x 2 box average of `frame` into `out` (reused); returns its width and height
/// (half the frame's, rounded down).
pub(crate) fn downsample(frame: &RgbFrame<'_>, out: &mut Vec<u8>) -> (usize, usize) {
    let (w, h) = (frame.width() / 2, frame.height() / 2);
    out.clear();
    out.reserve(w * h * 3);
    for v in 0..h {
        let (top, bottom) = (frame.row(2 * v), frame.row(2 * v + 1));
        for u in 0..w {
            for c in 0..3 {
                let i = 6 * u + c;
                let sum = u16::from(top[i])
                    + u16::from(top[i + 3])
                    + u16::from(bottom[i])
                    + u16::from(bottom[i + 3]);
                out.push(((sum + 2) / 4) as u8);
            }
        }
    }
    (w, h)
}

/// The pixels of `[x0, x1) x [y0, y1)` clipped to a `width x height` frame.
pub(crate) fn clip_rect(rect: [i32; 4], width: usize, height: usize) -> [usize; 4] {
    let cx = |v: i32, hi: usize| (v.max(0) as usize).min(hi);
    [
        cx(rect[0], width),
        cx(rect[1], height),
        cx(rect[2], width),
        cx(rect[3], height),
    ]
}

impl BinImage {
    /// Recomputes the bins of `frame` inside `rect` (`[x0, y0, x1, y1)`, clipped) only,
    /// reusing the buffer; bins elsewhere keep older values, so callers read only there.
    pub(crate) fn compute_rect(
        &mut self,
        frame: &RgbFrame<'_>,
        space: ColorSpace,
        bins: [usize; 3],
        rect: [i32; 4],
    ) {
        self.width = frame.width();
        self.height = frame.height();
        self.bins.resize(self.width * self.height, 0);
        let [x0, y0, x1, y1] = clip_rect(rect, self.width, self.height);
        for y in y0..y1 {
            let src = &frame.row(y)[3 * x0..3 * x1];
            let out = &mut self.bins[y * self.width + x0..y * self.width + x1];
            space.bin_row(src, out, bins);
        }
    }
}

impl BinImage {
    /// Whether every bin inside `rect` (clipped) is the same: nothing there to find.
    pub(crate) fn uniform_in(&self, rect: [i32; 4]) -> bool {
        let [x0, y0, x1, y1] = clip_rect(rect, self.width, self.height);
        let mut rows = (y0..y1).map(|y| &self.bins[y * self.width + x0..y * self.width + x1]);
        let Some(first) = rows.clone().flat_map(|r| r.iter()).next() else {
            return true;
        };
        rows.all(|r| r.iter().all(|b| b == first))
    }
}

impl GradientImage {
    /// [`compute`](GradientImage::compute) inside `rect` (clipped) only; gradients
    /// elsewhere keep older values.
    pub(crate) fn compute_rect(&mut self, frame: &RgbFrame<'_>, rect: [i32; 4]) {
        let (w, h) = (frame.width(), frame.height());
        self.resize(w, h);
        // Grey levels one pixel beyond the rectangle, for the Sobel stencil.
        let [gx0, gy0, gx1, gy1] =
            clip_rect([rect[0] - 1, rect[1] - 1, rect[2] + 1, rect[3] + 1], w, h);
        for y in gy0..gy1 {
            let src = &frame.row(y)[3 * gx0..3 * gx1];
            for (x, p) in (gx0..gx1).zip(src.chunks_exact(3)) {
                self.set_grey(x, y, p);
            }
        }
        let [x0, y0, x1, y1] = clip_rect(rect, w, h);
        for y in y0.max(1)..y1.min(h.saturating_sub(1)) {
            for x in x0.max(1)..x1.min(w.saturating_sub(1)) {
                self.sobel_at(x, y);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn noise_frame(w: usize, h: usize, seed: u32) -> Vec<u8> {
        let mut s = seed;
        (0..w * h * 3)
            .map(|_| {
                s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                (s >> 24) as u8
            })
            .collect()
    }

    #[test]
    fn downsample_is_the_rounded_mean_of_each_2x2_block() {
        let data = noise_frame(7, 5, 3);
        let frame = RgbFrame::new(&data, 7, 5).unwrap();
        let mut out = Vec::new();
        assert_eq!(downsample(&frame, &mut out), (3, 2));
        for v in 0..2 {
            for u in 0..3 {
                for c in 0..3 {
                    let at = |x: usize, y: usize| f64::from(data[(y * 7 + x) * 3 + c]);
                    let mean = (at(2 * u, 2 * v)
                        + at(2 * u + 1, 2 * v)
                        + at(2 * u, 2 * v + 1)
                        + at(2 * u + 1, 2 * v + 1))
                        / 4.0;
                    let got = f64::from(out[(v * 3 + u) * 3 + c]);
                    assert!((got - mean).abs() <= 0.5, "{got} vs {mean}");
                }
            }
        }
    }

    #[test]
    fn rectangles_match_the_whole_frame_inside() {
        let (w, h) = (40, 30);
        let data = noise_frame(w, h, 11);
        let frame = RgbFrame::new(&data, w, h).unwrap();
        let (space, bins) = (ColorSpace::Opponent, [8, 8, 4]);
        let (mut all, mut part) = (BinImage::default(), BinImage::default());
        all.compute(&frame, space, bins, false);
        let rect = [-3, 5, 17, 40];
        part.compute_rect(&frame, space, bins, rect);
        let (mut g_all, mut g_part) = (GradientImage::default(), GradientImage::default());
        g_all.compute(&frame);
        g_part.compute_rect(&frame, rect);
        for y in 5..30 {
            for x in 0..17 {
                assert_eq!(part.at(x, y), all.at(x, y));
                assert_eq!(
                    g_part.at(x as usize, y as usize),
                    g_all.at(x as usize, y as usize)
                );
            }
        }
    }
}
