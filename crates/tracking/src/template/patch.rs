//! Image patches resampled from a frame to a fixed grid: the filters work on a
//! normalised window whatever the target's size in the frame, which bounds the cost of a
//! frame (Staple's "fixed area").

use crate::frame::RgbFrame;
use rperc_core::image::grey_level;

/// A resampled RGB patch with its grey levels, `width x height` pixels.
#[derive(Debug, Clone, Default)]
pub(crate) struct Patch {
    /// Pixels across.
    pub(crate) width: usize,
    /// Pixels down.
    pub(crate) height: usize,
    /// Colour per pixel, rounded to bytes (what the colour histograms count).
    pub(crate) rgb: Vec<[u8; 3]>,
    /// Luma per pixel in [0, 1] (what the gradients see).
    pub(crate) grey: Vec<f32>,
}

/// A window of the frame: its centre in frame pixels and its size in frame pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Window {
    /// Centre, frame pixels (x).
    pub(crate) cx: f64,
    /// Centre, frame pixels (y).
    pub(crate) cy: f64,
    /// Width in frame pixels.
    pub(crate) width: f64,
    /// Height in frame pixels.
    pub(crate) height: f64,
}

/// The two neighbouring pixel indices and the weight of the second for a coordinate
/// along an axis of `n` pixels, clamped so a window that overhangs the border repeats
/// the edge (OpenCV's `BORDER_REPLICATE`). Computed once per column and per row.
fn taps(coordinate: f64, n: usize) -> Tap {
    let c = coordinate.clamp(0.0, (n - 1) as f64);
    // c >= 0 (NaN clamps to NaN, which casts to 0): truncation is the floor.
    let i0 = c as usize;
    (i0, (i0 + 1).min(n - 1), (c - i0 as f64) as f32)
}

/// The two neighbouring pixels along an axis and the weight of the second.
type Tap = (usize, usize, f32);

/// The frame's column and row taps of `window` resampled to `width x height`: output
/// pixel `(i, j)` takes the frame at the centre of its cell in the window (frame pixel
/// centres at integers).
fn window_taps(
    frame: &RgbFrame<'_>,
    window: Window,
    width: usize,
    height: usize,
) -> (Vec<Tap>, Vec<Tap>) {
    let (fw, fh) = (frame.width(), frame.height());
    let (sx, sy) = (window.width / width as f64, window.height / height as f64);
    let (x0, y0) = (
        window.cx - window.width / 2.0,
        window.cy - window.height / 2.0,
    );
    let columns = (0..width)
        .map(|i| taps(x0 + (i as f64 + 0.5) * sx - 0.5, fw))
        .collect();
    let rows = (0..height)
        .map(|j| taps(y0 + (j as f64 + 0.5) * sy - 0.5, fh))
        .collect();
    (columns, rows)
}

/// Visits the bilinear `[r, g, b]` (0..255, unrounded) of every output pixel of
/// `window` resampled to `width x height`, row by row.
#[inline(always)]
fn for_each_colour(
    frame: &RgbFrame<'_>,
    window: Window,
    width: usize,
    height: usize,
    mut visit: impl FnMut([f32; 3]),
) {
    let (columns, rows) = window_taps(frame, window, width, height);
    let (fw, data) = (frame.width(), frame.data());
    for &(r0, r1, fy) in &rows {
        let (top, bottom) = (
            &data[r0 * fw * 3..(r0 + 1) * fw * 3],
            &data[r1 * fw * 3..(r1 + 1) * fw * 3],
        );
        for &(c0, c1, fx) in &columns {
            let mix = |row: &[u8], c: usize| {
                f32::from(row[c0 * 3 + c]) * (1.0 - fx) + f32::from(row[c1 * 3 + c]) * fx
            };
            visit(std::array::from_fn(|c| {
                mix(top, c) * (1.0 - fy) + mix(bottom, c) * fy
            }));
        }
    }
}

/// Luma in [0, 1] of a bilinear colour.
#[inline(always)]
fn luma([r, g, b]: [f32; 3]) -> f32 {
    (0.299 * r + 0.587 * g + 0.114 * b) / 255.0
}

/// Resamples `window` of `frame` to `width x height` pixels into `out` by bilinear
/// interpolation: colours rounded to bytes, and luma.
pub(crate) fn sample(
    frame: &RgbFrame<'_>,
    window: Window,
    width: usize,
    height: usize,
    out: &mut Patch,
) {
    out.width = width;
    out.height = height;
    out.rgb.clear();
    out.grey.clear();
    for_each_colour(frame, window, width, height, |rgb| {
        out.rgb.push(rgb.map(|v| grey_level(v.into())));
        out.grey.push(luma(rgb));
    });
}

/// [`sample`]'s luma alone into `grey` (the scale filter's samples need no colour):
/// the same values, without rounding colours nobody reads.
pub(crate) fn sample_grey(
    frame: &RgbFrame<'_>,
    window: Window,
    width: usize,
    height: usize,
    grey: &mut Vec<f32>,
) {
    grey.clear();
    for_each_colour(frame, window, width, height, |rgb| grey.push(luma(rgb)));
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `w x h` RGB frame's bytes, hashed by `step` (every byte differs from its
    /// neighbours).
    fn hashed(w: usize, h: usize, step: usize) -> Vec<u8> {
        (0..w * h * 3).map(|k| (k * step % 251) as u8).collect()
    }

    fn window([cx, cy, width, height]: [f64; 4]) -> Window {
        Window {
            cx,
            cy,
            width,
            height,
        }
    }

    /// A window of the frame's own size at its centre reproduces the frame exactly.
    #[test]
    fn identity_window_copies_the_frame() {
        let (w, h) = (7usize, 5usize);
        let data = hashed(w, h, 37);
        let frame = RgbFrame::new(&data, w, h).unwrap();
        let (wf, hf) = (w as f64, h as f64);
        let window = window([wf / 2.0, hf / 2.0, wf, hf]);
        let mut patch = Patch::default();
        sample(&frame, window, w, h, &mut patch);
        for (k, px) in patch.rgb.iter().enumerate() {
            assert_eq!(px, &[data[3 * k], data[3 * k + 1], data[3 * k + 2]]);
        }
    }

    /// The grey-only sampler gives [`sample`]'s luma bit for bit, on a window that
    /// overhangs the frame and scales unevenly.
    #[test]
    fn grey_only_sampling_equals_the_full_one() {
        let (w, h) = (13usize, 9usize);
        let data = hashed(w, h, 53);
        let frame = RgbFrame::new(&data, w, h).unwrap();
        let window = window([2.3, 7.9, 11.7, 6.1]);
        let (mut full, mut grey) = (Patch::default(), Vec::new());
        sample(&frame, window, 10, 7, &mut full);
        sample_grey(&frame, window, 10, 7, &mut grey);
        let bits = |v: &[f32]| v.iter().map(|g| g.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&full.grey), bits(&grey));
    }

    /// Half-size sampling of a horizontal ramp lands between pixel pairs: the mean of
    /// each pair (the closed form of bilinear interpolation of a linear function).
    #[test]
    fn halving_a_ramp_averages_pixel_pairs() {
        let (w, h) = (8usize, 2usize);
        let data: Vec<u8> = (0..w * h).flat_map(|k| [(k % w) as u8 * 10; 3]).collect();
        let frame = RgbFrame::new(&data, w, h).unwrap();
        let window = window([4.0, 1.0, 8.0, 2.0]);
        let mut patch = Patch::default();
        sample(&frame, window, 4, 1, &mut patch);
        let got: Vec<u8> = patch.rgb.iter().map(|p| p[0]).collect();
        assert_eq!(got, vec![5, 25, 45, 65]);
    }
}
