//! Image patches resampled from a frame to a fixed grid: the filters work on a
//! normalised window whatever the target's size in the frame, which bounds the cost of a
//! frame (Staple's "fixed area").

use crate::frame::RgbFrame;

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

/// Bilinear interpolation of one channel-interleaved RGB frame at `(x, y)`, pixel
/// centres at integers, coordinates clamped to the frame so a window that overhangs
/// the border repeats the edge (as OpenCV's `BORDER_REPLICATE`).
fn bilinear(frame: &RgbFrame<'_>, x: f64, y: f64) -> [f32; 3] {
    let (w, h) = (frame.width(), frame.height());
    let x = x.clamp(0.0, (w - 1) as f64);
    let y = y.clamp(0.0, (h - 1) as f64);
    let (x0, y0) = (x.floor() as usize, y.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
    let (fx, fy) = ((x - x0 as f64) as f32, (y - y0 as f64) as f32);
    let data = frame.data();
    let px = |xx: usize, yy: usize, c: usize| f32::from(data[(yy * w + xx) * 3 + c]);
    std::array::from_fn(|c| {
        let top = px(x0, y0, c) * (1.0 - fx) + px(x1, y0, c) * fx;
        let bottom = px(x0, y1, c) * (1.0 - fx) + px(x1, y1, c) * fx;
        top * (1.0 - fy) + bottom * fy
    })
}

/// Resamples `window` of `frame` to `width x height` pixels into `out`: output pixel
/// `(i, j)` takes the frame at the centre of its cell in the window.
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
    let (sx, sy) = (window.width / width as f64, window.height / height as f64);
    let (x0, y0) = (
        window.cx - window.width / 2.0,
        window.cy - window.height / 2.0,
    );
    for j in 0..height {
        // Frame pixel centres are at integers, so the window's left edge is at x - 0.5.
        let y = y0 + (j as f64 + 0.5) * sy - 0.5;
        for i in 0..width {
            let x = x0 + (i as f64 + 0.5) * sx - 0.5;
            let [r, g, b] = bilinear(frame, x, y);
            out.rgb
                .push([r.round() as u8, g.round() as u8, b.round() as u8]);
            out.grey.push((0.299 * r + 0.587 * g + 0.114 * b) / 255.0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A window of the frame's own size at its centre reproduces the frame exactly.
    #[test]
    fn identity_window_copies_the_frame() {
        let (w, h) = (7usize, 5usize);
        let data: Vec<u8> = (0..w * h * 3).map(|k| (k * 37 % 251) as u8).collect();
        let frame = RgbFrame::new(&data, w, h).unwrap();
        let window = Window {
            cx: w as f64 / 2.0,
            cy: h as f64 / 2.0,
            width: w as f64,
            height: h as f64,
        };
        let mut patch = Patch::default();
        sample(&frame, window, w, h, &mut patch);
        for (k, px) in patch.rgb.iter().enumerate() {
            assert_eq!(px, &[data[3 * k], data[3 * k + 1], data[3 * k + 2]]);
        }
    }

    /// Half-size sampling of a horizontal ramp lands between pixel pairs: the mean of
    /// each pair (the closed form of bilinear interpolation of a linear function).
    #[test]
    fn halving_a_ramp_averages_pixel_pairs() {
        let (w, h) = (8usize, 2usize);
        let data: Vec<u8> = (0..w * h).flat_map(|k| [(k % w) as u8 * 10; 3]).collect();
        let frame = RgbFrame::new(&data, w, h).unwrap();
        let window = Window {
            cx: 4.0,
            cy: 1.0,
            width: 8.0,
            height: 2.0,
        };
        let mut patch = Patch::default();
        sample(&frame, window, 4, 1, &mut patch);
        let got: Vec<u8> = patch.rgb.iter().map(|p| p[0]).collect();
        assert_eq!(got, vec![5, 25, 45, 65]);
    }
}
