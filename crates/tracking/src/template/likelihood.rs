//! The colour half of the tracker: foreground and background colour histograms (the
//! seed's 3-D histograms, section 3.2, binned as the colour trackers bin them), each
//! pixel's back-projected foreground probability `P = H_fg(b) / (H_fg(b) + H_bg(b))`
//! (Staple, eq. 13-ish), and the colour response: the mean of `P` over a target-sized
//! box at every displacement, through an integral image.

use crate::colour::ColorSpace;

/// A rectangle of patch pixels `[x0, x1) x [y0, y1)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Rect {
    /// Left (inclusive).
    pub(crate) x0: usize,
    /// Top (inclusive).
    pub(crate) y0: usize,
    /// Right (exclusive).
    pub(crate) x1: usize,
    /// Bottom (exclusive).
    pub(crate) y1: usize,
}

impl Rect {
    /// The rectangle of size `w x h` (rounded, at least 1 px) centred in a
    /// `width x height` patch, clipped to it.
    pub(crate) fn centred(width: usize, height: usize, w: f64, h: f64) -> Self {
        let side = |n: usize, s: f64| {
            let s = s.round().clamp(1.0, n as f64) as usize;
            let a = (n - s) / 2;
            (a, a + s)
        };
        let (x0, x1) = side(width, w);
        let (y0, y1) = side(height, h);
        Self { x0, y0, x1, y1 }
    }

    fn contains(&self, x: usize, y: usize) -> bool {
        (self.x0..self.x1).contains(&x) && (self.y0..self.y1).contains(&y)
    }
}

/// Foreground and background histograms with their learning state.
#[derive(Clone)]
pub(crate) struct ColourLikelihood {
    space: ColorSpace,
    bins: [usize; 3],
    foreground: Vec<f32>,
    background: Vec<f32>,
    trained: bool,
}

impl ColourLikelihood {
    /// Empty histograms of `bins` per axis in `space`.
    pub(crate) fn new(space: ColorSpace, bins: [usize; 3]) -> Self {
        let n = bins.iter().product();
        Self {
            space,
            bins,
            foreground: vec![0.0; n],
            background: vec![0.0; n],
            trained: false,
        }
    }

    /// Learns the foreground from the pixels inside `object` and the background from
    /// those outside `target` (the object is the target shrunk, so its edges, which mix
    /// both, teach neither), each histogram normalised to sum 1, blended in at `rate`.
    pub(crate) fn learn(
        &mut self,
        rgb: &[[u8; 3]],
        width: usize,
        target: Rect,
        object: Rect,
        rate: f32,
    ) {
        let n = self.foreground.len();
        let (mut fg, mut bg) = (vec![0.0f32; n], vec![0.0f32; n]);
        for (k, px) in rgb.iter().enumerate() {
            let (x, y) = (k % width, k / width);
            let b = self.space.bin(*px, self.bins);
            if object.contains(x, y) {
                fg[b] += 1.0;
            } else if !target.contains(x, y) {
                bg[b] += 1.0;
            }
        }
        let rate = if self.trained { rate } else { 1.0 };
        blend(&mut self.foreground, &fg, rate);
        blend(&mut self.background, &bg, rate);
        self.trained = true;
    }

    /// Each pixel's foreground probability (0 for a colour neither histogram has seen).
    pub(crate) fn back_project(&self, rgb: &[[u8; 3]], out: &mut Vec<f32>) {
        out.clear();
        out.extend(rgb.iter().map(|px| {
            let b = self.space.bin(*px, self.bins);
            let (f, g) = (self.foreground[b], self.background[b]);
            if f + g > 0.0 { f / (f + g) } else { 0.0 }
        }));
    }
}

/// `model = (1 - rate) model + rate sample / sum(sample)` (a sample with no pixels
/// leaves the model as it is).
fn blend(model: &mut [f32], sample: &[f32], rate: f32) {
    let total: f32 = sample.iter().sum();
    if total <= 0.0 {
        return;
    }
    for (m, s) in model.iter_mut().zip(sample) {
        *m = (1.0 - rate) * *m + rate * s / total;
    }
}

/// Summed-area table with a zero first row and column: `(width + 1) x (height + 1)`.
pub(crate) fn integral(values: &[f32], width: usize, height: usize) -> Vec<f64> {
    let stride = width + 1;
    let mut table = vec![0.0f64; stride * (height + 1)];
    for y in 0..height {
        let mut row = 0.0f64;
        for x in 0..width {
            row += f64::from(values[y * width + x]);
            table[(y + 1) * stride + x + 1] = table[y * stride + x + 1] + row;
        }
    }
    table
}

/// The colour response on the translation filter's grid: for the wrapped cell
/// displacement at each grid index, the sum of `P` over a `box_w x box_h` box centred
/// at the patch centre plus that displacement (`cell` pixels per cell), clipped to the
/// patch, divided by the whole box's area (so a box half outside scores at most 1/2).
pub(crate) fn colour_response(
    table: &[f64],
    width: usize,
    height: usize,
    (box_w, box_h): (f64, f64),
    (grid_w, grid_h, cell): (usize, usize, usize),
    out: &mut Vec<f32>,
) {
    let stride = width + 1;
    let area = (box_w * box_h).max(1.0);
    let wrap = |i: usize, n: usize| {
        if i < n.div_ceil(2) {
            i as f64
        } else {
            i as f64 - n as f64
        }
    };
    let clip = |v: f64, n: usize| v.round().clamp(0.0, n as f64) as usize;
    out.clear();
    for j in 0..grid_h {
        let cy = height as f64 / 2.0 + wrap(j, grid_h) * cell as f64;
        let (y0, y1) = (
            clip(cy - box_h / 2.0, height),
            clip(cy + box_h / 2.0, height),
        );
        for i in 0..grid_w {
            let cx = width as f64 / 2.0 + wrap(i, grid_w) * cell as f64;
            let (x0, x1) = (clip(cx - box_w / 2.0, width), clip(cx + box_w / 2.0, width));
            let sum = table[y1 * stride + x1] - table[y0 * stride + x1] - table[y1 * stride + x0]
                + table[y0 * stride + x0];
            out.push((sum / area) as f32);
        }
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    proptest! {
        /// The integral-image response equals summing the box pixel by pixel.
        #[test]
        fn response_matches_brute_force_box_sums(
            width in 4usize..30, height in 4usize..30, bw in 1.0f64..20.0, bh in 1.0f64..20.0,
            seed in 0u64..200,
        ) {
            let mut rng = rperc_core::rng::seeded(seed);
            let p: Vec<f32> = (0..width * height).map(|_| rand::Rng::random_range(&mut rng, 0.0..1.0)).collect();
            let (gw, gh, cell) = (width / 2, height / 2, 2usize);
            let mut fast = Vec::new();
            colour_response(&integral(&p, width, height), width, height, (bw, bh), (gw, gh, cell), &mut fast);
            for j in 0..gh {
                for i in 0..gw {
                    let d = |k: usize, n: usize| if k < n.div_ceil(2) { k as f64 } else { k as f64 - n as f64 };
                    let cx = width as f64 / 2.0 + d(i, gw) * 2.0;
                    let cy = height as f64 / 2.0 + d(j, gh) * 2.0;
                    let mut sum = 0.0f64;
                    for y in 0..height {
                        for x in 0..width {
                            // Pixel (x, y) covers [x, x + 1); it is in the box when its
                            // index lies between the rounded edges.
                            let inside_x = (x as f64) >= (cx - bw / 2.0).round() && (x as f64) < (cx + bw / 2.0).round();
                            let inside_y = (y as f64) >= (cy - bh / 2.0).round() && (y as f64) < (cy + bh / 2.0).round();
                            if inside_x && inside_y {
                                sum += f64::from(p[y * width + x]);
                            }
                        }
                    }
                    let expected = sum / (bw * bh).max(1.0);
                    prop_assert!((f64::from(fast[j * gw + i]) - expected).abs() < 1e-4);
                }
            }
        }
    }

    /// A red target on a green background: after learning, red pixels back-project to
    /// 1 and green ones to 0 (the histograms separate them completely).
    #[test]
    fn separated_colours_back_project_to_certainty() {
        let (w, h) = (12usize, 12usize);
        let rgb: Vec<[u8; 3]> = (0..w * h)
            .map(|k| {
                if (3..9).contains(&(k % w)) && (3..9).contains(&(k / w)) {
                    [220, 20, 20]
                } else {
                    [20, 200, 20]
                }
            })
            .collect();
        let mut model = ColourLikelihood::new(ColorSpace::Rgb, [8, 8, 8]);
        let target = Rect::centred(w, h, 6.0, 6.0);
        let object = Rect::centred(w, h, 4.0, 4.0);
        model.learn(&rgb, w, target, object, 0.1);
        let mut p = Vec::new();
        model.back_project(&rgb, &mut p);
        for (px, v) in rgb.iter().zip(&p) {
            let expected = if px[0] > 100 { 1.0 } else { 0.0 };
            assert_eq!(*v, expected);
        }
    }
}
