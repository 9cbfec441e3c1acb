//! Per-sample segmentation `S(n)` of the region of interest by a bin lookup table, the
//! morphological clean-up (imageproc), the extraction of the target blob, its Euler
//! number and its boundary `grad S(n)`.

use image::{GrayImage, Luma};
use imageproc::distance_transform::Norm;
use imageproc::morphology::{close_mut, open_mut};
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

/// Which sides of a window are the frame's own border: there the target's boundary is
/// real; on the other sides the window merely cuts the segmentation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FrameSides {
    /// Left, top, right, bottom.
    pub sides: [bool; 4],
}

impl FrameSides {
    /// The sides of `roi` lying on the border of a `width x height` frame.
    pub fn of(roi: Roi, width: usize, height: usize) -> Self {
        Self {
            sides: [
                roi.x0 == 0,
                roi.y0 == 0,
                roi.x0 + roi.width == width,
                roi.y0 + roi.height == height,
            ],
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
    resize(seg, roi);
    for (s, &b) in seg.iter_mut().zip(bins) {
        *s = lut[b as usize].wrapping_neg();
    }
}

/// Makes `img` a `roi`-sized image, reallocating only when the size changes.
pub fn resize(img: &mut GrayImage, roi: Roi) {
    if img.dimensions() != (roi.width as u32, roi.height as u32) {
        *img = GrayImage::new(roi.width as u32, roi.height as u32);
    }
}

/// Opening then closing with a square of half-side `radius` (the `L_inf` ball), in
/// place: removes specks, then fills pinholes and gaps narrower than `2 radius + 1`.
pub fn clean(seg: &mut GrayImage, radius: u8) {
    if radius > 0 {
        open_mut(seg, Norm::LInf, radius);
        close_mut(seg, Norm::LInf, radius);
    }
}

/// Statistics of an extracted blob, window coordinates.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Blob {
    /// Pixel count.
    pub area: usize,
    /// Centroid.
    pub centroid: [f64; 2],
}

/// Reusable buffers of [`reconstruct`].
#[derive(Debug, Clone, Default)]
pub struct FloodScratch {
    stack: Vec<u32>,
}

/// The target blob in tracking: the pixels of `seg` inside `region` that are
/// 8-connected, within `seg` and `region`, to a pixel of `seg` inside `seeds` (a
/// morphological reconstruction). `region` is the predicted contour dilated by the snake's
/// reach, so a same-coloured object touching the target is cut where the target can no
/// longer be: the blob is split by the shape prior. Writes the blob (0/255) into `blob`.
pub fn reconstruct(
    seg: &GrayImage,
    seeds: &GrayImage,
    region: &GrayImage,
    blob: &mut GrayImage,
    scratch: &mut FloodScratch,
) -> Blob {
    let (w, h) = (seg.width() as usize, seg.height() as usize);
    if blob.dimensions() != seg.dimensions() {
        *blob = GrayImage::new(w as u32, h as u32);
    }
    let (s, r, out) = (seg.as_raw(), region.as_raw(), blob.as_mut());
    out.fill(0);
    let stack = &mut scratch.stack;
    stack.clear();
    for (i, (&q, &p)) in s.iter().zip(seeds.as_raw()).enumerate() {
        if q != 0 && p != 0 && r[i] != 0 {
            out[i] = 255;
            stack.push(i as u32);
        }
    }
    let (mut n, mut sx, mut sy) = (0usize, 0usize, 0usize);
    // Explicit stack, no recursion: every pushed pixel is marked first, so each is
    // visited once.
    while let Some(i) = stack.pop() {
        let i = i as usize;
        let (x, y) = (i % w, i / w);
        n += 1;
        sx += x;
        sy += y;
        for (dx, dy) in NEIGHBOURS_8 {
            let (u, v) = (x as isize + dx, y as isize + dy);
            if u < 0 || v < 0 || u >= w as isize || v >= h as isize {
                continue;
            }
            let j = v as usize * w + u as usize;
            if out[j] == 0 && s[j] != 0 && r[j] != 0 {
                out[j] = 255;
                stack.push(j as u32);
            }
        }
    }
    blob_of(n, sx, sy)
}

const NEIGHBOURS_8: [(isize, isize); 8] = [
    (-1, -1),
    (0, -1),
    (1, -1),
    (-1, 0),
    (1, 0),
    (-1, 1),
    (0, 1),
    (1, 1),
];

fn blob_of(n: usize, sx: usize, sy: usize) -> Blob {
    let d = n.max(1) as f64;
    Blob {
        area: n,
        centroid: [sx as f64 / d, sy as f64 / d],
    }
}

/// The target blob when re-acquiring a lost target: of the 8-connected components of
/// `seg` (imageproc's labelling), the one whose area is closest in ratio to `area`
/// (ties: nearest to `near`), if that ratio is at least `min_ratio`. Writes it into
/// `blob` (0/255).
pub fn best_component(
    seg: &GrayImage,
    area: f64,
    near: [f64; 2],
    min_ratio: f64,
    blob: &mut GrayImage,
    stats: &mut Vec<[f64; 3]>,
) -> Blob {
    let labels = connected_components(seg, Connectivity::Eight, Luma([0u8]));
    let n_labels = labels.iter().copied().max().unwrap_or(0) as usize;
    stats.clear();
    stats.resize(n_labels + 1, [0.0; 3]);
    for (x, y, l) in labels.enumerate_pixels() {
        let s = &mut stats[l[0] as usize];
        s[0] += 1.0;
        s[1] += f64::from(x);
        s[2] += f64::from(y);
    }
    let score = |s: &[f64; 3]| {
        let ratio = s[0].min(area) / s[0].max(area).max(1e-9);
        let d = (s[1] / s[0] - near[0]).hypot(s[2] / s[0] - near[1]);
        (ratio, -d)
    };
    let best = (1..=n_labels)
        .filter(|&l| stats[l][0] > 0.0 && score(&stats[l]).0 >= min_ratio)
        .max_by(|&a, &b| score(&stats[a]).partial_cmp(&score(&stats[b])).unwrap());
    if blob.dimensions() != seg.dimensions() {
        *blob = GrayImage::new(seg.width(), seg.height());
    }
    let Some(best) = best else {
        blob.as_mut().fill(0);
        return Blob::default();
    };
    for (b, l) in blob.iter_mut().zip(labels.iter()) {
        *b = if *l as usize == best { 255 } else { 0 };
    }
    let s = stats[best];
    Blob {
        area: s[0] as usize,
        centroid: [s[1] / s[0], s[2] / s[0]],
    }
}

/// Euler number (components minus holes) of the non-zero pixels, foreground
/// 8-connected and background 4-connected, by counting 2x2 bit-quads (Gray 1971):
/// `E = (Q1 - Q3 - 2 QD) / 4`, with pixels outside the image taken as background.
pub fn euler_number(mask: &GrayImage) -> i64 {
    let (w, h) = (mask.width() as usize, mask.height() as usize);
    let m = mask.as_raw();
    // Quad counts by the 4-bit pattern of (top-left, top-right, bottom-left,
    // bottom-right); rows -1 and h and columns -1 and w are background.
    let mut count = [0i64; 16];
    let bit = |x: usize, y: usize| -> usize {
        // x and y are shifted by one: 0 is the padding column/row.
        if x == 0 || y == 0 || x > w || y > h {
            0
        } else {
            usize::from(m[(y - 1) * w + (x - 1)] != 0)
        }
    };
    for y in 0..=h {
        let mut left = (bit(0, y), bit(0, y + 1));
        for x in 0..=w {
            let right = (bit(x + 1, y), bit(x + 1, y + 1));
            count[(left.0 << 3) | (right.0 << 2) | (left.1 << 1) | right.1] += 1;
            left = right;
        }
    }
    let ones: i64 = [1, 2, 4, 8].iter().map(|&p| count[p]).sum();
    let threes: i64 = [7, 11, 13, 14].iter().map(|&p| count[p]).sum();
    // Diagonal pairs: top-left with bottom-right (0b1001) or top-right with
    // bottom-left (0b0110).
    let diagonals = count[0b1001] + count[0b0110];
    (ones - threes - 2 * diagonals) / 4
}

/// The boundary `grad S` of a blob: its pixels with a 4-neighbour that the
/// segmentation `seg` leaves out, or on a side of the window that is the frame's border.
/// A neighbour that is in `seg` but not in the blob (a same-coloured object cut off by
/// the shape prior) or beyond an inner side of the window is no evidence of the
/// target's edge. `edges` is reused.
pub fn boundary(blob: &GrayImage, seg: &GrayImage, sides: FrameSides, edges: &mut GrayImage) {
    let (w, h) = (blob.width() as usize, blob.height() as usize);
    if edges.dimensions() != blob.dimensions() {
        *edges = GrayImage::new(w as u32, h as u32);
    }
    let (b, s, e) = (blob.as_raw(), seg.as_raw(), edges.as_mut());
    let [left, top, right, bottom] = sides.sides;
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let out = |ok: bool, j: usize| ok && s[j] == 0;
            let edge = b[i] != 0
                && ((x == 0 && left)
                    || (y == 0 && top)
                    || (x + 1 == w && right)
                    || (y + 1 == h && bottom)
                    || out(x > 0, i.wrapping_sub(1))
                    || out(x + 1 < w, i + 1)
                    || out(y > 0, i.wrapping_sub(w))
                    || out(y + 1 < h, i + w));
            e[i] = if edge { 255 } else { 0 };
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
    fn reconstruction_keeps_what_the_prior_reaches_and_cuts_at_the_region() {
        // Two bars, the left one joined by a bridge to a third blob on the right.
        let seg = GrayImage::from_fn(30, 10, |x, y| {
            let on =
                (2..8).contains(&x) || (15..28).contains(&x) || (y == 5 && (8..15).contains(&x));
            Luma([if on { 255 } else { 0 }])
        });
        let seeds = GrayImage::from_fn(30, 10, |x, _| Luma([if x < 6 { 255 } else { 0 }]));
        let all = GrayImage::from_pixel(30, 10, Luma([255]));
        let (mut blob, mut flood) = (GrayImage::new(1, 1), FloodScratch::default());
        // Unbounded, the bridge joins the right blob in: 60 + 7 + 130 pixels.
        let b = reconstruct(&seg, &seeds, &all, &mut blob, &mut flood);
        assert_eq!(b.area, 60 + 7 + 130);
        // Within a region ending at x = 10 only the left bar and 2 bridge pixels stay.
        let region = GrayImage::from_fn(30, 10, |x, _| Luma([if x < 10 { 255 } else { 0 }]));
        let b = reconstruct(&seg, &seeds, &region, &mut blob, &mut flood);
        assert_eq!(b.area, 62);
        assert_eq!(blob.get_pixel(20, 5)[0], 0);
        let none = GrayImage::new(30, 10);
        assert_eq!(
            reconstruct(&seg, &none, &all, &mut blob, &mut flood).area,
            0
        );
    }

    #[test]
    fn reacquisition_picks_the_component_of_the_remembered_area() {
        let seg = GrayImage::from_fn(40, 10, |x, y| {
            let on = (1..4).contains(&x) || ((10..20).contains(&x) && (2..8).contains(&y));
            Luma([if on { 255 } else { 0 }])
        });
        let (mut blob, mut stats) = (GrayImage::new(1, 1), Vec::new());
        let b = best_component(&seg, 55.0, [0.0, 0.0], 0.5, &mut blob, &mut stats);
        assert_eq!(b.area, 60);
        assert_eq!(b.centroid, [14.5, 4.5]);
        let b = best_component(&seg, 1000.0, [0.0, 0.0], 0.5, &mut blob, &mut stats);
        assert_eq!(b.area, 0);
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
