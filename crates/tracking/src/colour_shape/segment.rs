//! Per-sample segmentation `S(n)` of the region of interest by a bin lookup table, the
//! morphological clean-up and blob extraction (imageproc), the blob's Euler number and
//! its boundary `grad S(n)`.

use image::{GrayImage, Luma};
use imageproc::morphology::{Mask, grayscale_close, grayscale_open};
use imageproc::region_labelling::{Connectivity, connected_components};

use crate::colour::ColorSpace;
use crate::frame::RgbFrame;

/// A window of the frame, in pixels: `[x0, x0 + width) x [y0, y0 + height)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Roi {
    /// Left column.
    pub x0: usize,
    /// Top row.
    pub y0: usize,
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
}

impl Roi {
    /// The window `[x0, x1) x [y0, y1)` (floats floored/ceiled) clipped to the frame.
    pub fn clipped(x0: f64, y0: f64, x1: f64, y1: f64, width: usize, height: usize) -> Self {
        let cx = |v: f64, hi: usize| (v.max(0.0) as usize).min(hi);
        let (a, b) = (cx(x0.floor(), width), cx(x1.ceil(), width));
        let (c, d) = (cx(y0.floor(), height), cx(y1.ceil(), height));
        Self {
            x0: a,
            y0: c,
            width: b.saturating_sub(a),
            height: d.saturating_sub(c),
        }
    }
}

/// The colour bin of every pixel of a window, computed once per frame so every
/// sample's segmentation is one table lookup per pixel.
pub fn bin_window(
    frame: &RgbFrame<'_>,
    roi: Roi,
    space: ColorSpace,
    bins: [usize; 3],
    out: &mut Vec<u16>,
) {
    out.clear();
    for y in roi.y0..roi.y0 + roi.height {
        let row = &frame.row(y)[3 * roi.x0..3 * (roi.x0 + roi.width)];
        out.extend(
            row.chunks_exact(3)
                .map(|p| space.bin([p[0], p[1], p[2]], bins) as u16),
        );
    }
}

/// `S(u, v) = 255` where `lut[bin(u, v)] != 0`, else 0: the seed's segmentation by
/// `H(n) > 0`. `seg` is reused (resized only when the window changes size).
pub fn segment(bins: &[u16], lut: &[u8], roi: Roi, seg: &mut GrayImage) {
    if seg.dimensions() != (roi.width as u32, roi.height as u32) {
        *seg = GrayImage::new(roi.width as u32, roi.height as u32);
    }
    for (s, &b) in seg.iter_mut().zip(bins) {
        *s = if lut[b as usize] != 0 { 255 } else { 0 };
    }
}

/// Opening then closing with a square of half-side `radius` (the `L_inf` ball): removes isolated pixels, then fills
/// pinholes and gaps narrower than `2 radius + 1`.
pub fn clean(seg: &mut GrayImage, radius: u8) {
    if radius > 0 {
        // imageproc's mask filters beat its distance-transform `open_mut`/`close_mut`
        // by a third of the whole update at radius 1, at the cost of two images per call.
        let mask = Mask::square(radius);
        *seg = grayscale_open(seg, &mask);
        *seg = grayscale_close(seg, &mask);
    }
}

/// Keeps only the 8-connected component of `seg` that overlaps `prior` (a 0/255 mask of
/// the predicted target, same size) the most; returns its pixel count, 0 when no
/// component overlaps the prior. `seg` becomes the blob mask (0/255).
pub fn keep_target_blob(seg: &mut GrayImage, prior: &GrayImage, overlap: &mut Vec<u32>) -> usize {
    let labels = connected_components(&*seg, Connectivity::Eight, Luma([0u8]));
    let n_labels = labels.iter().copied().max().unwrap_or(0) as usize;
    overlap.clear();
    overlap.resize(n_labels + 1, 0);
    for (&l, &p) in labels.iter().zip(prior.iter()) {
        if p != 0 {
            overlap[l as usize] += 1;
        }
    }
    overlap[0] = 0;
    let best = (1..=n_labels).max_by_key(|&l| (overlap[l], std::cmp::Reverse(l)));
    let Some(best) = best.filter(|&l| overlap[l] > 0) else {
        seg.iter_mut().for_each(|s| *s = 0);
        return 0;
    };
    let mut count = 0;
    for (s, &l) in seg.iter_mut().zip(labels.iter()) {
        *s = if l as usize == best { 255 } else { 0 };
        count += usize::from(*s != 0);
    }
    count
}

/// Euler number (components minus holes) of the non-zero pixels, foreground
/// 8-connected and background 4-connected, by counting 2x2 bit-quads (Gray 1971):
/// `E = (Q1 - Q3 - 2 QD) / 4`, with pixels outside the image taken as background.
pub fn euler_number(mask: &GrayImage) -> i64 {
    let (w, h) = (mask.width() as i64, mask.height() as i64);
    let at = |x: i64, y: i64| -> u8 {
        if x < 0 || y < 0 || x >= w || y >= h {
            0
        } else {
            u8::from(mask.as_raw()[(y * w + x) as usize] != 0)
        }
    };
    let (mut q1, mut q3, mut qd) = (0i64, 0i64, 0i64);
    for y in -1..h {
        for x in -1..w {
            let (a, b, c, d) = (at(x, y), at(x + 1, y), at(x, y + 1), at(x + 1, y + 1));
            match a + b + c + d {
                1 => q1 += 1,
                3 => q3 += 1,
                2 if a == d => qd += 1,
                _ => {}
            }
        }
    }
    (q1 - q3 - 2 * qd) / 4
}

/// The boundary `grad S` of a 0/255 mask: foreground pixels with a 4-neighbour in the
/// background (or on the window's border). `edges` is reused.
pub fn boundary(mask: &GrayImage, edges: &mut GrayImage) {
    let (w, h) = (mask.width() as usize, mask.height() as usize);
    if edges.dimensions() != mask.dimensions() {
        *edges = GrayImage::new(w as u32, h as u32);
    }
    let m = mask.as_raw();
    let on = |x: usize, y: usize| m[y * w + x] != 0;
    for y in 0..h {
        for x in 0..w {
            let e = on(x, y)
                && (x == 0
                    || y == 0
                    || x + 1 == w
                    || y + 1 == h
                    || !on(x - 1, y)
                    || !on(x + 1, y)
                    || !on(x, y - 1)
                    || !on(x, y + 1));
            edges.as_mut()[y * w + x] = if e { 255 } else { 0 };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Oracle for the Euler number: components (8-connected foreground) minus holes
    /// (4-connected background components not touching the border), by flood fill on a
    /// padded copy with imageproc's labelling.
    fn euler_brute_force(mask: &GrayImage) -> i64 {
        let fg = connected_components(mask, Connectivity::Eight, Luma([0u8]));
        let n_fg = fg.iter().copied().max().unwrap_or(0) as i64;
        let (w, h) = mask.dimensions();
        let mut inv = GrayImage::new(w + 2, h + 2);
        for (x, y, p) in inv.enumerate_pixels_mut() {
            let inside = x >= 1 && y >= 1 && x <= w && y <= h;
            let fgp = inside && mask.get_pixel(x - 1, y - 1)[0] != 0;
            *p = Luma([if fgp { 0 } else { 255 }]);
        }
        let bg = connected_components(&inv, Connectivity::Four, Luma([0u8]));
        let n_bg = bg.iter().copied().max().unwrap_or(0) as i64;
        // One background component is the outside (it contains the padding).
        n_fg - (n_bg - 1)
    }

    fn random_mask(seed: u64, w: u32, h: u32, density: u64) -> GrayImage {
        let mut s = seed;
        GrayImage::from_fn(w, h, |_, _| {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            Luma([if (s >> 33) % 100 < density { 255 } else { 0 }])
        })
    }

    #[test]
    fn euler_number_matches_brute_force() {
        for seed in 0..60 {
            let m = random_mask(
                seed,
                13 + (seed % 7) as u32,
                9 + (seed % 5) as u32,
                30 + seed % 50,
            );
            assert_eq!(euler_number(&m), euler_brute_force(&m), "seed {seed}");
        }
    }

    #[test]
    fn euler_number_of_a_ring_is_zero() {
        let ring = GrayImage::from_fn(20, 20, |x, y| {
            let r = (x as f64 - 9.5).hypot(y as f64 - 9.5);
            Luma([if (4.0..8.0).contains(&r) { 255 } else { 0 }])
        });
        assert_eq!(euler_number(&ring), 0);
    }

    #[test]
    fn target_blob_is_the_one_overlapping_the_prior() {
        let mut seg = GrayImage::from_fn(30, 10, |x, _| {
            Luma([if (2..8).contains(&x) || (15..28).contains(&x) {
                255
            } else {
                0
            }])
        });
        let prior = GrayImage::from_fn(30, 10, |x, _| Luma([if x < 10 { 255 } else { 0 }]));
        let mut buf = Vec::new();
        assert_eq!(keep_target_blob(&mut seg, &prior, &mut buf), 60);
        assert_eq!(seg.get_pixel(20, 5)[0], 0);
        let none = GrayImage::new(30, 10);
        assert_eq!(keep_target_blob(&mut seg, &none, &mut buf), 0);
    }

    #[test]
    fn segmentation_is_the_lookup_of_each_bin() {
        let roi = Roi::clipped(1.0, 0.0, 4.0, 2.0, 5, 5);
        let bins = vec![0u16, 3, 2, 3, 1, 0];
        let lut = [0u8, 1, 0, 1];
        let mut seg = GrayImage::new(1, 1);
        segment(&bins, &lut, roi, &mut seg);
        assert_eq!(seg.as_raw(), &vec![0, 255, 0, 255, 255, 0]);
    }
}
