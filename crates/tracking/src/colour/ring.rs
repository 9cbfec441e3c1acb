//! The background around the target: the colour histogram of a ring around the box, and
//! the foreground contrast of a candidate (how much more target-like its inside is than
//! the ring around it). An oversized box takes in background, so its inside looks less
//! like the target; an undersized one leaves target colours in the ring. Either way the
//! contrast falls, which is the scale signal the histogram intersection lacks.

use super::ellipse::Ellipse;
use super::space::BinImage;

/// The ring's outer ellipse has semi-axes this many times the box's.
pub(crate) const RING_FACTOR: f64 = 1.5;

/// Histogram of the ring and the per-bin foreground probability derived from it.
#[derive(Debug, Clone, Default)]
pub(crate) struct Background {
    /// Normalised histogram of the ring (sums to one, or all zero with no ring pixel).
    hist: Vec<f64>,
    /// `m / (m + b)` per bin: the chance that a pixel of that bin is the target's, for a
    /// model `m` and this background `b` given equal priors.
    foreground: Vec<f32>,
    scratch: Vec<f64>,
}

/// Calls `f(bin)` for every pixel of the ellipse `e` centred on pixel `(cx, cy)` that
/// lies in the frame; returns the number of such pixels.
fn for_each_bin(image: &BinImage, e: &Ellipse, cx: i32, cy: i32, mut f: impl FnMut(u16)) -> usize {
    let mut n = 0;
    for dy in -e.ry..=e.ry {
        let y = cy + dy;
        if y < 0 || y as usize >= image.height {
            continue;
        }
        let h = e.half(dy).unwrap_or(-1);
        let x0 = (cx - h).max(0);
        let x1 = (cx + h).min(image.width as i32 - 1);
        if x0 > x1 {
            continue;
        }
        let row = y as usize * image.width;
        for &bin in &image.bins[row + x0 as usize..=row + x1 as usize] {
            f(bin);
        }
        n += (x1 - x0 + 1) as usize;
    }
    n
}

impl Background {
    /// The ring between `inner` and `outer` (same centre) as a normalised histogram into
    /// the scratch buffer; `false` when no ring pixel lies in the frame.
    fn ring_histogram(
        &mut self,
        image: &BinImage,
        inner: &Ellipse,
        outer: &Ellipse,
        cx: i32,
        cy: i32,
    ) -> bool {
        let h = &mut self.scratch;
        h.fill(0.0);
        for_each_bin(image, outer, cx, cy, |b| h[b as usize] += 1.0);
        for_each_bin(image, inner, cx, cy, |b| h[b as usize] -= 1.0);
        let total: f64 = h.iter().sum();
        if total < 1.0 {
            return false;
        }
        h.iter_mut().for_each(|v| *v /= total);
        true
    }

    /// Samples the ring around the initial box.
    pub(crate) fn sample(
        n_bins: usize,
        image: &BinImage,
        inner: &Ellipse,
        outer: &Ellipse,
        cx: i32,
        cy: i32,
    ) -> Self {
        let mut bg = Self {
            hist: vec![0.0; n_bins],
            foreground: vec![0.5; n_bins],
            scratch: vec![0.0; n_bins],
        };
        if bg.ring_histogram(image, inner, outer, cx, cy) {
            bg.hist.copy_from_slice(&bg.scratch);
        }
        bg
    }

    /// Eq. (29) for the background: `B = (1 - a) B + a R` with the ring `R` of a
    /// confident match, so a changing background is followed.
    pub(crate) fn adapt(
        &mut self,
        rate: f64,
        image: &BinImage,
        inner: &Ellipse,
        outer: &Ellipse,
        cx: i32,
        cy: i32,
    ) {
        if self.ring_histogram(image, inner, outer, cx, cy) {
            for (b, r) in self.hist.iter_mut().zip(&self.scratch) {
                *b = (1.0 - rate) * *b + rate * r;
            }
        }
    }

    /// Recomputes the per-bin foreground probability for the model `reference`.
    pub(crate) fn refresh(&mut self, reference: &[f32]) {
        for ((p, &m), &b) in self.foreground.iter_mut().zip(reference).zip(&self.hist) {
            let (m, b) = (f64::from(m), b);
            *p = if m + b > 0.0 {
                (m / (m + b)) as f32
            } else {
                0.5
            };
        }
    }

    /// Mean foreground probability inside `inner` minus that in the ring out to `outer`,
    /// in [-1, 1]; 0 when either has no pixel in the frame.
    pub(crate) fn contrast(
        &self,
        image: &BinImage,
        inner: &Ellipse,
        outer: &Ellipse,
        cx: i32,
        cy: i32,
    ) -> f64 {
        let fg = &self.foreground;
        let mut s_in = 0.0f64;
        let n_in = for_each_bin(image, inner, cx, cy, |b| s_in += f64::from(fg[b as usize]));
        let mut s_out = 0.0f64;
        let n_out = for_each_bin(image, outer, cx, cy, |b| s_out += f64::from(fg[b as usize]));
        let n_ring = n_out.saturating_sub(n_in);
        if n_in == 0 || n_ring == 0 {
            return 0.0;
        }
        s_in / n_in as f64 - (s_out - s_in) / n_ring as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colour::space::ColorSpace;
    use crate::frame::RgbFrame;

    /// A red disc of radius `r` at (40, 30) on a blue background, binned in RGB.
    fn disc_image(r: f64) -> BinImage {
        let (w, h) = (80, 60);
        let mut px = vec![0u8; w * h * 3];
        for y in 0..h {
            for x in 0..w {
                let inside = (x as f64 + 0.5 - 40.5).hypot(y as f64 + 0.5 - 30.5) < r;
                let c = if inside { [220, 20, 20] } else { [20, 20, 220] };
                px[(y * w + x) * 3..][..3].copy_from_slice(&c);
            }
        }
        let mut image = BinImage::default();
        let frame = RgbFrame::new(&px, w, h).unwrap();
        image.compute(&frame, ColorSpace::Rgb, [4, 4, 4], false);
        image
    }

    fn ellipses(a: f64) -> (Ellipse, Ellipse) {
        let (mut inner, mut outer) = (Ellipse::default(), Ellipse::default());
        inner.rebuild(a, a, 0.5);
        outer.rebuild(a * RING_FACTOR, a * RING_FACTOR, 0.5);
        (inner, outer)
    }

    #[test]
    fn contrast_peaks_at_the_true_size() {
        // Model: pure red; background: the ring around the true disc, pure blue.
        let image = disc_image(10.0);
        let (inner, outer) = ellipses(10.0);
        let mut bg = Background::sample(64, &image, &inner, &outer, 40, 30);
        let red = ColorSpace::Rgb.bin([220, 20, 20], [4, 4, 4]);
        let mut model = vec![0.0f32; 64];
        model[red] = 1.0;
        bg.refresh(&model);
        let at = |a: f64| {
            let (i, o) = ellipses(a);
            bg.contrast(&image, &i, &o, 40, 30)
        };
        let (small, right, big) = (at(6.0), at(10.0), at(16.0));
        assert!(right > 0.9, "{right}");
        assert!(
            right > small + 0.2 && right > big + 0.2,
            "{small} {right} {big}"
        );
    }

    #[test]
    fn ring_histogram_counts_only_the_ring() {
        // The ring around a disc of radius 10 read with an inner ellipse of the same
        // size holds no red pixel (brute-force: the disc lies inside the inner ellipse).
        let image = disc_image(10.0);
        let (inner, outer) = ellipses(10.5);
        let bg = Background::sample(64, &image, &inner, &outer, 40, 30);
        let red = ColorSpace::Rgb.bin([220, 20, 20], [4, 4, 4]);
        let blue = ColorSpace::Rgb.bin([20, 20, 220], [4, 4, 4]);
        assert_eq!(bg.hist[red], 0.0);
        assert!((bg.hist[blue] - 1.0).abs() < 1e-12);
    }
}
