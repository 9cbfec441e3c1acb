//! The histogram of an ellipse, kept incrementally while the ellipse moves by one pixel:
//! only the pixels that leave and enter each row are touched (seed 000 section 3.2,
//! after Birchfield). The histogram intersection with the model, eq. (28), is updated
//! with every pixel, so scoring a candidate costs nothing extra.

use super::ellipse::Ellipse;
use super::space::BinImage;

/// Counts of an ellipse's pixels per bin plus the running intersection
/// `sum_i min(C(i), M'(i))` with a model `M'` already scaled to the ellipse's pixel count.
pub(crate) struct RegionHistogram<'a> {
    image: &'a BinImage,
    model: &'a [f32],
    counts: &'a mut [u32],
    pub(crate) intersection: f64,
}

impl<'a> RegionHistogram<'a> {
    /// An empty region; `counts` must be all zero and as long as `model`.
    pub(crate) fn new(image: &'a BinImage, model: &'a [f32], counts: &'a mut [u32]) -> Self {
        debug_assert_eq!(model.len(), counts.len());
        Self {
            image,
            model,
            counts,
            intersection: 0.0,
        }
    }

    #[inline]
    fn add_bin(&mut self, bin: usize) {
        // min(c + 1, m) - min(c, m) = clamp(m - c, 0, 1)
        let c = self.counts[bin] as f32;
        self.intersection += f64::from((self.model[bin] - c).clamp(0.0, 1.0));
        self.counts[bin] += 1;
    }

    #[inline]
    fn remove_bin(&mut self, bin: usize) {
        self.counts[bin] -= 1;
        let c = self.counts[bin] as f32;
        self.intersection -= f64::from((self.model[bin] - c).clamp(0.0, 1.0));
    }

    /// Pixels `x0..=x1` of row `y`, clipped to the frame (outside pixels count as no
    /// colour: they can never match the model).
    #[inline]
    fn span(&mut self, y: i32, x0: i32, x1: i32, add: bool) {
        if y < 0 || y as usize >= self.image.height {
            return;
        }
        let x0 = x0.max(0);
        let x1 = x1.min(self.image.width as i32 - 1);
        if x0 > x1 {
            return;
        }
        let row = y as usize * self.image.width;
        let image = self.image;
        for &bin in &image.bins[row + x0 as usize..=row + x1 as usize] {
            if add {
                self.add_bin(bin as usize)
            } else {
                self.remove_bin(bin as usize)
            }
        }
    }

    #[inline]
    fn pixel(&mut self, x: i32, y: i32, add: bool) {
        if let Some(bin) = self.image.at(x, y) {
            if add {
                self.add_bin(bin)
            } else {
                self.remove_bin(bin)
            }
        }
    }

    /// Adds (or removes) every pixel of `e` centred at `(cx, cy)`.
    pub(crate) fn fill(&mut self, e: &Ellipse, cx: i32, cy: i32, add: bool) {
        for dy in -e.ry..=e.ry {
            let h = e.half(dy).unwrap_or(0);
            self.span(cy + dy, cx - h, cx + h, add);
        }
    }

    /// Moves the ellipse from `(cx, cy)` to `(cx + dir, cy)`, `dir` = +1 or -1: one pixel
    /// leaves and one enters on each row.
    pub(crate) fn shift_x(&mut self, e: &Ellipse, cx: i32, cy: i32, dir: i32) {
        for dy in -e.ry..=e.ry {
            let h = e.half(dy).unwrap_or(0);
            let y = cy + dy;
            if dir > 0 {
                self.pixel(cx - h, y, false);
                self.pixel(cx + h + 1, y, true);
            } else {
                self.pixel(cx + h, y, false);
                self.pixel(cx - h - 1, y, true);
            }
        }
    }

    /// Moves the ellipse from `(cx, cy)` to `(cx, cy + 1)`: on each row the old span
    /// becomes the new one by adding or removing its two ends.
    pub(crate) fn shift_down(&mut self, e: &Ellipse, cx: i32, cy: i32) {
        for y in cy - e.ry..=cy + 1 + e.ry {
            match (e.half(y - cy), e.half(y - cy - 1)) {
                (None, Some(new)) => self.span(y, cx - new, cx + new, true),
                (Some(old), None) => self.span(y, cx - old, cx + old, false),
                (Some(old), Some(new)) if new > old => {
                    self.span(y, cx - new, cx - old - 1, true);
                    self.span(y, cx + old + 1, cx + new, true);
                }
                (Some(old), Some(new)) if new < old => {
                    self.span(y, cx - old, cx - new - 1, false);
                    self.span(y, cx + new + 1, cx + old, false);
                }
                _ => {}
            }
        }
    }
}

/// Counts the pixels of `e` at `(cx, cy)` into `upper` (rows above `e.upper_end`) and
/// `lower`, clipped to the frame; returns the number counted.
pub(crate) fn count_parts(
    image: &BinImage,
    e: &Ellipse,
    cx: i32,
    cy: i32,
    upper: &mut [f64],
    lower: &mut [f64],
) -> usize {
    let mut n = 0;
    for dy in -e.ry..=e.ry {
        let h = e.half(dy).unwrap_or(0);
        let y = cy + dy;
        if y < 0 || y as usize >= image.height {
            continue;
        }
        let x0 = (cx - h).max(0);
        let x1 = (cx + h).min(image.width as i32 - 1);
        if x0 > x1 {
            continue;
        }
        let row = y as usize * image.width;
        let target = if dy < e.upper_end {
            &mut *upper
        } else {
            &mut *lower
        };
        for &bin in &image.bins[row + x0 as usize..=row + x1 as usize] {
            target[bin as usize] += 1.0;
            n += 1;
        }
    }
    n
}

#[cfg(test)]
mod tests {
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::*;

    fn random_image(w: usize, h: usize, n_bins: usize, seed: u64) -> BinImage {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        BinImage {
            bins: (0..w * h)
                .map(|_| rng.random_range(0..n_bins as u16))
                .collect(),
            width: w,
            height: h,
        }
    }

    /// Brute force: count every pixel of the ellipse and take the intersection directly.
    fn brute(image: &BinImage, model: &[f32], e: &Ellipse, cx: i32, cy: i32) -> (Vec<u32>, f64) {
        let mut c = vec![0u32; model.len()];
        for dy in -e.ry..=e.ry {
            let h = e.half(dy).unwrap();
            for x in cx - h..=cx + h {
                if let Some(b) = image.at(x, cy + dy) {
                    c[b] += 1;
                }
            }
        }
        let inter = c
            .iter()
            .zip(model)
            .map(|(&c, &m)| f64::from((c as f32).min(m)))
            .sum();
        (c, inter)
    }

    #[test]
    fn incremental_walk_matches_brute_force_everywhere() {
        let n_bins = 12;
        let image = random_image(40, 30, n_bins, 5);
        let mut rng = ChaCha8Rng::seed_from_u64(6);
        let model: Vec<f32> = (0..n_bins).map(|_| rng.random_range(0.0..40.0)).collect();
        let mut e = Ellipse::default();
        e.rebuild(6.5, 9.0, 0.5);
        let mut counts = vec![0u32; n_bins];
        let mut region = RegionHistogram::new(&image, &model, &mut counts);
        // Start partly outside the frame and zig-zag across it and beyond its edges.
        let (mut cx, mut cy) = (-3, -4);
        region.fill(&e, cx, cy, true);
        for step in 0..400 {
            let dir = if (step / 50) % 2 == 0 { 1 } else { -1 };
            if step % 50 == 49 {
                region.shift_down(&e, cx, cy);
                cy += 1;
            } else {
                region.shift_x(&e, cx, cy, dir);
                cx += dir;
            }
            let (want_counts, want) = brute(&image, &model, &e, cx, cy);
            assert_eq!(region.counts, &want_counts[..], "counts at step {step}");
            assert!(
                (region.intersection - want).abs() < 1e-3,
                "intersection at step {step}"
            );
        }
        region.fill(&e, cx, cy, false);
        assert!(region.counts.iter().all(|&c| c == 0));
    }
}
