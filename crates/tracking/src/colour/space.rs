//! Colour spaces and the per-pixel bin-index image: each pixel's 3-D histogram bin is
//! computed once per frame, so every histogram afterwards is plain counting.

use rayon::prelude::*;

use crate::error::{Result, TrackingError};
use crate::frame::RgbFrame;

rperc_core::named_enum! {
    /// The colour space whose 3-D histogram models the target (seed 000 section 3.2).
    #[derive(Default)]
    pub enum ColorSpace: "color_space" {
        /// Raw (R, G, B).
        Rgb = "rgb",
        /// The seed's and Birchfield's opponent axes (B-G, G-R, R+G+B): chroma separated
        /// from intensity, robust to specular highlights.
        #[default]
        Opponent = "opponent",
        /// Normalised chromaticity (r, g) = (R, G) / (R+G+B), plus the intensity R+G+B as
        /// the third axis (give it 1 bin to ignore intensity).
        NormalizedRg = "rg",
        /// Hue, saturation, value (hue in degrees, 0..360).
        Hsv = "hsv",
    }
}

/// Largest number of bins per axis.
pub const MAX_BINS_PER_AXIS: usize = 64;

/// Checks a bins-per-axis triple and returns the total number of bins.
pub(crate) fn check_bins(bins: [usize; 3]) -> Result<usize> {
    if bins.iter().any(|&b| b == 0 || b > MAX_BINS_PER_AXIS) {
        return Err(TrackingError::InvalidParameter {
            name: "bins",
            reason: format!("each axis needs 1..={MAX_BINS_PER_AXIS} bins, got {bins:?}"),
        });
    }
    Ok(bins.iter().product())
}

#[inline]
fn quantise(value: u32, range: u32, bins: u32) -> u32 {
    // value in [0, range): floor(value * bins / range), never reaching `bins`.
    (value * bins / range).min(bins - 1)
}

impl ColorSpace {
    /// The histogram bin of one RGB pixel with `bins` per axis (axis 0 slowest).
    ///
    /// # Examples
    /// ```
    /// use tracking::ColorSpace;
    ///
    /// // Opponent axes: B-G = 0 is level 255 of 0..511, bin floor(255 * 4 / 511) = 1;
    /// // the same for G-R; R+G+B = 0 is bin 0.
    /// assert_eq!(ColorSpace::Opponent.bin([0, 0, 0], [4, 4, 4]), (1 * 4 + 1) * 4);
    /// assert_eq!(ColorSpace::Rgb.bin([255, 0, 128], [2, 2, 2]), (1 * 2 + 0) * 2 + 1);
    /// ```
    #[inline(always)]
    pub fn bin(self, [r, g, b]: [u8; 3], bins: [usize; 3]) -> usize {
        let [b0, b1, b2] = bins.map(|v| v as u32);
        let (r, g, b) = (u32::from(r), u32::from(g), u32::from(b));
        let (i0, i1, i2) = match self {
            ColorSpace::Rgb => (
                quantise(r, 256, b0),
                quantise(g, 256, b1),
                quantise(b, 256, b2),
            ),
            ColorSpace::Opponent => (
                quantise(b + 255 - g, 511, b0),
                quantise(g + 255 - r, 511, b1),
                quantise(r + g + b, 766, b2),
            ),
            ColorSpace::NormalizedRg => {
                let sum = r + g + b;
                if sum == 0 {
                    (b0 / 3, b1 / 3, 0)
                } else {
                    (
                        quantise(r, sum + 1, b0),
                        quantise(g, sum + 1, b1),
                        quantise(sum, 766, b2),
                    )
                }
            }
            ColorSpace::Hsv => {
                let max = r.max(g).max(b);
                let min = r.min(g).min(b);
                let chroma = max - min;
                let hue = if chroma == 0 {
                    0.0
                } else if max == r {
                    60.0 * ((g as f32 - b as f32) / chroma as f32).rem_euclid(6.0)
                } else if max == g {
                    60.0 * ((b as f32 - r as f32) / chroma as f32 + 2.0)
                } else {
                    60.0 * ((r as f32 - g as f32) / chroma as f32 + 4.0)
                };
                let h = ((hue / 360.0 * b0 as f32) as u32).min(b0 - 1);
                let s = if max == 0 {
                    0
                } else {
                    quantise(chroma, max + 1, b1)
                };
                (h, s, quantise(max, 256, b2))
            }
        };
        ((i0 * b1 + i1) * b2 + i2) as usize
    }
}

impl ColorSpace {
    /// Bins a row of RGB pixels (`3 * out.len()` bytes) into `out`. The colour space is
    /// matched once per row rather than once per pixel, so each space's loop is
    /// compiled on its own.
    pub(crate) fn bin_row(self, src: &[u8], out: &mut [u16], bins: [usize; 3]) {
        #[inline(always)]
        fn run(space: ColorSpace, src: &[u8], out: &mut [u16], bins: [usize; 3]) {
            for (o, px) in out.iter_mut().zip(src.chunks_exact(3)) {
                *o = space.bin([px[0], px[1], px[2]], bins) as u16;
            }
        }
        match self {
            ColorSpace::Rgb => run(ColorSpace::Rgb, src, out, bins),
            ColorSpace::Opponent => run(ColorSpace::Opponent, src, out, bins),
            ColorSpace::NormalizedRg => run(ColorSpace::NormalizedRg, src, out, bins),
            ColorSpace::Hsv => run(ColorSpace::Hsv, src, out, bins),
        }
    }
}

/// Rows per parallel work item when binning a frame: a few thousand pixels, enough to
/// pay for a rayon task, and a fixed split so the result never depends on the pool.
const BIN_ROWS_PER_TASK: usize = 16;

/// The bin index of every pixel of a frame.
#[derive(Debug, Clone, Default)]
pub(crate) struct BinImage {
    pub(crate) bins: Vec<u16>,
    pub(crate) width: usize,
    pub(crate) height: usize,
}

impl BinImage {
    /// Recomputes the bins of `frame`, reusing the buffer.
    pub(crate) fn compute(
        &mut self,
        frame: &RgbFrame<'_>,
        space: ColorSpace,
        bins: [usize; 3],
        parallel: bool,
    ) {
        self.width = frame.width();
        self.height = frame.height();
        self.bins.resize(self.width * self.height, 0);
        let width = self.width;
        let bin_rows = |(row0, out): (usize, &mut [u16])| {
            for (k, out_row) in out.chunks_mut(width).enumerate() {
                space.bin_row(frame.row(row0 + k), out_row, bins);
            }
        };
        let chunk = BIN_ROWS_PER_TASK * width;
        if parallel && self.height > BIN_ROWS_PER_TASK {
            self.bins
                .par_chunks_mut(chunk)
                .enumerate()
                .for_each(|(i, out)| bin_rows((i * BIN_ROWS_PER_TASK, out)));
        } else {
            self.bins
                .chunks_mut(chunk)
                .enumerate()
                .for_each(|(i, out)| bin_rows((i * BIN_ROWS_PER_TASK, out)));
        }
    }

    #[inline]
    pub(crate) fn at(&self, x: i32, y: i32) -> Option<usize> {
        if x >= 0 && y >= 0 && (x as usize) < self.width && (y as usize) < self.height {
            Some(self.bins[y as usize * self.width + x as usize] as usize)
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A row binned at once equals each pixel binned alone, in every space.
    #[test]
    fn a_row_bins_as_its_pixels_do() {
        let src: Vec<u8> = (0..3 * 97).map(|k| (k * 37 % 256) as u8).collect();
        for space in [
            ColorSpace::Rgb,
            ColorSpace::Opponent,
            ColorSpace::NormalizedRg,
            ColorSpace::Hsv,
        ] {
            let mut out = vec![0u16; 97];
            space.bin_row(&src, &mut out, [8, 6, 4]);
            for (o, px) in out.iter().zip(src.chunks_exact(3)) {
                assert_eq!(usize::from(*o), space.bin([px[0], px[1], px[2]], [8, 6, 4]));
            }
        }
    }

    /// Reference HSV in f64 (the textbook formulas), to check the integer/f32 path.
    fn hsv_ref(r: u8, g: u8, b: u8) -> (f64, f64, f64) {
        let (r, g, b) = (r as f64 / 255.0, g as f64 / 255.0, b as f64 / 255.0);
        let max = r.max(g).max(b);
        let min = r.min(g).min(b);
        let c = max - min;
        let h = if c == 0.0 {
            0.0
        } else if max == r {
            60.0 * (((g - b) / c).rem_euclid(6.0))
        } else if max == g {
            60.0 * ((b - r) / c + 2.0)
        } else {
            60.0 * ((r - g) / c + 4.0)
        };
        let s = if max == 0.0 { 0.0 } else { c / max };
        (h, s, max)
    }

    #[test]
    fn hsv_bins_match_reference_away_from_bin_edges() {
        let bins = [12, 4, 4];
        for r in (0..=255).step_by(17) {
            for g in (0..=255).step_by(15) {
                for b in (0..=255).step_by(51) {
                    let (h, s, v) = hsv_ref(r, g, b);
                    let f = [h / 360.0 * 12.0, s * 4.0, v * 4.0];
                    // Skip values within 2% of a bin edge, where rounding may differ.
                    if f.iter()
                        .any(|x| (x - x.round()).abs() < 0.02 && x.round() > 0.0)
                    {
                        continue;
                    }
                    let want = f.map(|x| (x.floor() as usize).min(11));
                    let want = (want[0] * 4 + want[1].min(3)) * 4 + want[2].min(3);
                    assert_eq!(
                        ColorSpace::Hsv.bin([r, g, b], bins),
                        want,
                        "rgb {r} {g} {b}"
                    );
                }
            }
        }
    }

    #[test]
    fn every_space_stays_in_range() {
        let bins = [7, 5, 3];
        for space in [
            ColorSpace::Rgb,
            ColorSpace::Opponent,
            ColorSpace::NormalizedRg,
            ColorSpace::Hsv,
        ] {
            for r in (0..=255).step_by(5) {
                for g in (0..=255).step_by(5) {
                    for b in [0u8, 1, 128, 254, 255] {
                        assert!(space.bin([r, g, b], bins) < 105, "{space:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn normalized_rg_ignores_brightness() {
        let bins = [8, 8, 1];
        assert_eq!(
            ColorSpace::NormalizedRg.bin([40, 20, 20], bins),
            ColorSpace::NormalizedRg.bin([200, 100, 100], bins)
        );
        // Opponent's chroma axes are differences: they do change with brightness.
        assert_ne!(
            ColorSpace::Opponent.bin([40, 20, 20], bins),
            ColorSpace::Opponent.bin([200, 100, 100], bins)
        );
    }
}
