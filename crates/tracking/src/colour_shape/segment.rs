//! Per-sample segmentation `S(n)` of the region of interest by a bin lookup table, the
//! morphological clean-up (imageproc), the extraction of the target blob, its Euler
//! number and its boundary `grad S(n)`.

use image::{GrayImage, Luma};
use imageproc::distance_transform::Norm;
use imageproc::morphology::{Mask, dilate_mut, grayscale_dilate, grayscale_erode, open_mut};
use imageproc::region_labelling::{Connectivity, connected_components};
use rperc_core::gaussian::covariance_spreads;

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

/// The sampling grid over a window: every `stride`-th pixel of it in each direction.
/// Cell `(u, v)` is frame pixel `(x0 + stride u, y0 + stride v)`. Each sample's
/// segmentation is made on this grid, so its cost follows the target's size in cells,
/// not in pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Grid {
    /// Left column of the window, frame pixels.
    pub x0: usize,
    /// Top row of the window, frame pixels.
    pub y0: usize,
    /// Pixels between cells.
    pub stride: usize,
    /// Cells per row.
    pub width: usize,
    /// Rows of cells.
    pub height: usize,
}

impl Grid {
    /// The grid of `stride` (>= 1) over `roi`, its last cell inside `roi`.
    pub fn over(roi: Roi, stride: usize) -> Self {
        let stride = stride.max(1);
        Self {
            x0: roi.x0,
            y0: roi.y0,
            stride,
            width: roi.width.div_ceil(stride),
            height: roi.height.div_ceil(stride),
        }
    }

    /// Frame coordinates of grid coordinates.
    #[inline]
    pub fn to_frame(self, [u, v]: [f64; 2]) -> [f64; 2] {
        let s = self.stride as f64;
        [self.x0 as f64 + s * u, self.y0 as f64 + s * v]
    }

    /// Grid coordinates of frame coordinates.
    #[inline]
    pub fn to_grid(self, [x, y]: [f64; 2]) -> [f64; 2] {
        let s = self.stride as f64;
        [(x - self.x0 as f64) / s, (y - self.y0 as f64) / s]
    }

    /// Whether `mask` (a grid image) is set at the cell nearest frame pixel `(x, y)`.
    #[inline]
    pub fn at(&self, mask: &GrayImage, x: i64, y: i64) -> bool {
        let s = self.stride as i64;
        let (dx, dy) = (x - self.x0 as i64 + s / 2, y - self.y0 as i64 + s / 2);
        if dx < 0 || dy < 0 {
            return false;
        }
        let (u, v) = ((dx / s) as usize, (dy / s) as usize);
        u < self.width && v < self.height && mask.as_raw()[v * self.width + u] != 0
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

/// The colour bin of every cell of a grid, computed once per frame so every sample's
/// segmentation is one table lookup per cell.
pub fn bin_window(
    frame: &RgbFrame<'_>,
    grid: Grid,
    space: ColorSpace,
    bins: [usize; 3],
    out: &mut Vec<u16>,
) {
    out.clear();
    for v in 0..grid.height {
        let row = frame.row(grid.y0 + v * grid.stride);
        out.extend((0..grid.width).map(|u| {
            let p = &row[3 * (grid.x0 + u * grid.stride)..][..3];
            space.bin([p[0], p[1], p[2]], bins) as u16
        }));
    }
}

/// `S(u, v) = 255` where `lut[bin(u, v)] != 0`, else 0: the seed's segmentation by
/// `H(n) > 0`. `seg` is reused (resized only when the grid changes size).
pub fn segment(bins: &[u16], lut: &[u8], grid: Grid, seg: &mut GrayImage) {
    resize(seg, grid);
    for (s, &b) in seg.iter_mut().zip(bins) {
        *s = lut[b as usize].wrapping_neg();
    }
}

/// The seed's segmentation of a whole frame by the histogram of a colour cloud
/// (section 3.3, "measure and weight"): `H(r, g, b)` counts the `colours` (coordinates
/// in `[0, 1)^3` of `space`, as [`colour_coords`](super::state::colour_coords) gives
/// them; others are left out) per bin, and a pixel is 255 in the raw segmentation when
/// its bin's count is > 0. Also returns it cleaned by the opening and closing of
/// half-side `radius` that every sample applies. The path each sample takes, on every
/// pixel, exposed so that it can be checked against an independent implementation.
///
/// # Errors
/// [`TrackingError::InvalidParameter`](crate::TrackingError) for a colour space other
/// than RGB and opponent, bad bins or a non-finite colour.
pub fn colour_segment(
    frame: &RgbFrame<'_>,
    colours: &[[f64; 3]],
    space: ColorSpace,
    bins: [usize; 3],
    radius: u8,
) -> crate::Result<(GrayImage, GrayImage)> {
    super::state::colour_coords(space, [0, 0, 0])?;
    crate::colour::check_bins(bins)?;
    if colours.iter().flatten().any(|c| !c.is_finite()) {
        return Err(crate::TrackingError::InvalidParameter {
            name: "colours",
            reason: "must be finite".into(),
        });
    }
    let nb = bins.map(|b| b as f64);
    let mut lut = vec![0u8; bins.iter().product()];
    for c in colours
        .iter()
        .filter(|c| c.iter().all(|v| (0.0..1.0).contains(v)))
    {
        let i = [0, 1, 2].map(|k| ((c[k] * nb[k]) as usize).min(bins[k] - 1));
        lut[(i[0] * bins[1] + i[1]) * bins[2] + i[2]] = 1;
    }
    let roi = Roi::clipped(
        0.0,
        0.0,
        frame.width() as f64,
        frame.height() as f64,
        frame.width(),
        frame.height(),
    );
    let grid = Grid::over(roi, 1);
    let mut window = Vec::new();
    bin_window(frame, grid, space, bins, &mut window);
    let mut raw = GrayImage::new(1, 1);
    segment(&window, &lut, grid, &mut raw);
    let mut cleaned = raw.clone();
    clean(&mut cleaned, &LineMasks::new(radius));
    Ok((raw, cleaned))
}

/// Makes `img` a grid-sized image, reallocating only when the size changes.
pub fn resize(img: &mut GrayImage, grid: Grid) {
    if img.dimensions() != (grid.width as u32, grid.height as u32) {
        *img = GrayImage::new(grid.width as u32, grid.height as u32);
    }
}

/// Opening then closing with a square of half-side `radius` (the `L_inf` ball):
/// removes specks, then fills pinholes and gaps narrower than `2 radius + 1`.
///
/// imageproc's mask filters, with the square split into a row and a column (an
/// erosion or dilation by a square is one by its row then one by its column): they
/// cost a third of its in-place distance-transform `open_mut`/`close_mut` at radius 1
/// (callgrind), though each returns a new image.
pub fn clean(seg: &mut GrayImage, masks: &LineMasks) {
    if let Some([row, col]) = &masks.0 {
        let erode = |img: &GrayImage| grayscale_erode(&grayscale_erode(img, row), col);
        let dilate = |img: &GrayImage| grayscale_dilate(&grayscale_dilate(img, row), col);
        *seg = erode(&dilate(&dilate(&erode(seg))));
    }
}

/// The row and the column of a square structuring element, `None` for radius 0.
#[derive(Debug, Clone)]
pub struct LineMasks(Option<[Mask; 2]>);

impl LineMasks {
    /// The row and column of half-length `radius`.
    pub fn new(radius: u8) -> Self {
        if radius == 0 {
            return Self(None);
        }
        let n = 2 * u32::from(radius) + 1;
        let row = Mask::from_image(&GrayImage::from_pixel(n, 1, Luma([255])), radius, 0);
        let col = Mask::from_image(&GrayImage::from_pixel(1, n, Luma([255])), 0, radius);
        Self(Some([row, col]))
    }
}

/// Statistics of an extracted blob, window coordinates.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Blob {
    /// Pixel count.
    pub area: usize,
    /// Centroid.
    pub centroid: [f64; 2],
    /// Bounding box `[x0, y0, x1, y1)`.
    pub bbox: [usize; 4],
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
    let mut acc = BlobSums::default();
    // Explicit stack, no recursion: every pushed pixel is marked first, so each is
    // visited once.
    while let Some(i) = stack.pop() {
        let i = i as usize;
        let (x, y) = (i % w, i / w);
        acc.add(x, y);
        let inner = x > 0 && y > 0 && x + 1 < w && y + 1 < h;
        for (dx, dy) in NEIGHBOURS_8 {
            let (u, v) = (x as isize + dx, y as isize + dy);
            if !inner && (u < 0 || v < 0 || u >= w as isize || v >= h as isize) {
                continue;
            }
            let j = v as usize * w + u as usize;
            if out[j] == 0 && s[j] != 0 && r[j] != 0 {
                out[j] = 255;
                stack.push(j as u32);
            }
        }
    }
    acc.blob()
}

/// Splits a blob grown larger than the target at its narrow necks (a distance-transform
/// split): the blob opened by `radius` (imageproc's distance transform) loses every part
/// thinner than `2 radius + 1`, a touching ring or bar among them; the opened parts that
/// overlap `prior` are kept and grown back by `radius` inside the blob. `None`, leaving
/// the blob as it was, when nothing of it survives the opening over the prior.
/// `scratch` holds two reused images.
pub fn split_at_necks(
    blob: &mut GrayImage,
    prior: &GrayImage,
    radius: u8,
    scratch: &mut [GrayImage; 2],
    flood: &mut FloodScratch,
) -> Option<Blob> {
    let [opened, core] = scratch;
    opened.clone_from(blob);
    open_mut(opened, Norm::LInf, radius);
    let all = &*blob;
    if reconstruct(opened, prior, all, core, flood).area == 0 {
        return None;
    }
    dilate_mut(core, Norm::LInf, radius);
    Some(intersect(blob, core))
}

/// Clears the pixels of `mask` that `keep` leaves out, and sums what is left.
pub fn intersect(mask: &mut GrayImage, keep: &GrayImage) -> Blob {
    let w = mask.width() as usize;
    let mut acc = BlobSums::default();
    for (i, (b, &c)) in mask.iter_mut().zip(keep.iter()).enumerate() {
        if *b != 0 && c == 0 {
            *b = 0;
        }
        if *b != 0 {
            acc.add(i % w, i / w);
        }
    }
    acc.blob()
}

/// The target blob when re-acquiring: [`best_component`] of `seg` opened by `radius`
/// (so a same-coloured bar or ring the target touches is no part of the component
/// compared with the target's shape), grown back by `radius` within `seg`.
pub fn reacquire(
    seg: &GrayImage,
    target: &ShapeMemory,
    min_ratio: f64,
    radius: u8,
    blob: &mut GrayImage,
    scratch: &mut [GrayImage; 2],
    stats: &mut Vec<[f64; 6]>,
) -> Blob {
    let opened = &mut scratch[0];
    opened.clone_from(seg);
    open_mut(opened, Norm::LInf, radius);
    if best_component(opened, target, min_ratio, blob, stats).area == 0 {
        return Blob::default();
    }
    dilate_mut(blob, Norm::LInf, radius);
    intersect(blob, seg)
}

/// Running pixel count, coordinate sums and bounds of a blob.
struct BlobSums {
    n: usize,
    sx: usize,
    sy: usize,
    bbox: [usize; 4],
}

impl Default for BlobSums {
    fn default() -> Self {
        Self {
            n: 0,
            sx: 0,
            sy: 0,
            bbox: [usize::MAX, usize::MAX, 0, 0],
        }
    }
}

impl BlobSums {
    fn add(&mut self, x: usize, y: usize) {
        self.n += 1;
        self.sx += x;
        self.sy += y;
        let b = &mut self.bbox;
        *b = [b[0].min(x), b[1].min(y), b[2].max(x + 1), b[3].max(y + 1)];
    }

    fn blob(&self) -> Blob {
        if self.n == 0 {
            return Blob::default();
        }
        let d = self.n as f64;
        Blob {
            area: self.n,
            centroid: [self.sx as f64 / d, self.sy as f64 / d],
            bbox: self.bbox,
        }
    }
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

/// What a lost target looks like, in grid cells: its area and principal spreads (see
/// [`polygon_spreads`](super::snake::polygon_spreads)), and where it was last.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShapeMemory {
    /// Area, cells.
    pub area: f64,
    /// Principal spreads, largest first, cells.
    pub spreads: [f64; 2],
    /// Last centroid, grid coordinates (breaks ties).
    pub near: [f64; 2],
}

impl ShapeMemory {
    /// Likeness of a component with `n` cells, coordinate sums `sx, sy` and
    /// second-moment sums `sxx, syy, sxy` to the target: the product of the area ratio
    /// and the two spreads' ratios (smaller over larger, 1 when alike). Area alone
    /// took a same-coloured bar of the target's area (a tenth as wide, ten times as
    /// long) for the target; its spreads differ by 3-4x.
    fn likeness(&self, [n, sx, sy, sxx, syy, sxy]: [f64; 6]) -> (f64, f64) {
        let ratio = |a: f64, b: f64| a.min(b) / a.max(b).max(1e-9);
        let (mx, my) = (sx / n, sy / n);
        let spreads = covariance_spreads(sxx / n - mx * mx, syy / n - my * my, sxy / n - mx * my);
        let like = ratio(n, self.area)
            * ratio(spreads[0], self.spreads[0])
            * ratio(spreads[1], self.spreads[1]);
        (like, ratio(n, self.area))
    }
}

/// The target blob when re-acquiring a lost target: of the 8-connected components of
/// `seg` (imageproc's labelling) whose area is within `min_ratio` of the target's, the
/// one most like it in area and principal spreads (ties: nearest to its last place).
/// Writes it into `blob` (0/255).
pub fn best_component(
    seg: &GrayImage,
    target: &ShapeMemory,
    min_ratio: f64,
    blob: &mut GrayImage,
    stats: &mut Vec<[f64; 6]>,
) -> Blob {
    let labels = connected_components(seg, Connectivity::Eight, Luma([0u8]));
    let n_labels = labels.iter().copied().max().unwrap_or(0) as usize;
    stats.clear();
    stats.resize(n_labels + 1, [0.0; 6]);
    for (x, y, l) in labels.enumerate_pixels() {
        let (x, y) = (f64::from(x), f64::from(y));
        let s = &mut stats[l[0] as usize];
        for (acc, v) in s.iter_mut().zip([1.0, x, y, x * x, y * y, x * y]) {
            *acc += v;
        }
    }
    let score = |s: &[f64; 6]| {
        let (like, area) = target.likeness(*s);
        let d = (s[1] / s[0] - target.near[0]).hypot(s[2] / s[0] - target.near[1]);
        (like, -d, area)
    };
    let best = (1..=n_labels)
        .filter(|&l| stats[l][0] > 0.0 && score(&stats[l]).2 >= min_ratio)
        .max_by(|&a, &b| {
            let (sa, sb) = (score(&stats[a]), score(&stats[b]));
            (sa.0, sa.1).partial_cmp(&(sb.0, sb.1)).unwrap()
        });
    if blob.dimensions() != seg.dimensions() {
        *blob = GrayImage::new(seg.width(), seg.height());
    }
    let Some(best) = best else {
        blob.as_mut().fill(0);
        return Blob::default();
    };
    let mut acc = BlobSums::default();
    let w = seg.width() as usize;
    for (i, (b, l)) in blob.iter_mut().zip(labels.iter()).enumerate() {
        *b = if *l as usize == best { 255 } else { 0 };
        if *b != 0 {
            acc.add(i % w, i / w);
        }
    }
    acc.blob()
}

/// Euler number (components minus holes) of the non-zero pixels, foreground
/// 8-connected and background 4-connected, by counting 2x2 bit-quads (Gray 1971):
/// `E = (Q1 - Q3 - 2 QD) / 4`, with pixels outside the image taken as background.
#[cfg(test)]
pub fn euler_number(mask: &GrayImage) -> i64 {
    let all = [0, 0, mask.width() as usize, mask.height() as usize];
    euler_number_in(mask, all, &mut Vec::new())
}

/// [`euler_number`] of the pixels inside `bbox` (`[x0, y0, x1, y1)`), all others being
/// background; `padded` is a reused buffer.
pub fn euler_number_in(mask: &GrayImage, bbox: [usize; 4], padded: &mut Vec<u8>) -> i64 {
    let [x0, y0, x1, y1] = bbox;
    let (w, pw, ph) = (mask.width() as usize, x1 - x0 + 2, y1 - y0 + 2);
    // The box with a ring of background, as 0/1, so the quad loop needs no checks.
    padded.clear();
    padded.resize(pw * ph, 0);
    let m = mask.as_raw();
    for y in y0..y1 {
        let row = &m[y * w + x0..y * w + x1];
        let out = &mut padded[(y - y0 + 1) * pw + 1..][..x1 - x0];
        for (o, &v) in out.iter_mut().zip(row) {
            *o = u8::from(v != 0);
        }
    }
    // Quad counts by the 4-bit pattern (top-left, top-right, bottom-left, bottom-right).
    let mut count = [0i64; 16];
    for rows in padded.windows(2 * pw).step_by(pw) {
        let (top, bottom) = rows.split_at(pw);
        let mut left = (usize::from(top[0]) << 1) | usize::from(bottom[0]);
        for (&t, &b) in top[1..].iter().zip(&bottom[1..]) {
            let right = (usize::from(t) << 1) | usize::from(b);
            // left = (tl, bl), right = (tr, br) -> tl tr bl br.
            let quad = ((left >> 1) << 3) | ((right >> 1) << 2) | ((left & 1) << 1) | (right & 1);
            count[quad] += 1;
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
/// target's edge. Only `bbox` (`[x0, y0, x1, y1)`, the blob's bounds) is scanned;
/// `edges` is reused.
pub fn boundary(
    blob: &GrayImage,
    seg: &GrayImage,
    sides: FrameSides,
    bbox: [usize; 4],
    edges: &mut GrayImage,
) {
    let (w, h) = (blob.width() as usize, blob.height() as usize);
    if edges.dimensions() != blob.dimensions() {
        *edges = GrayImage::new(w as u32, h as u32);
    }
    let (b, s, e) = (blob.as_raw(), seg.as_raw(), edges.as_mut());
    e.fill(0);
    let [left, top, right, bottom] = sides.sides;
    let [x0, y0, x1, y1] = bbox;
    for y in y0..y1.min(h) {
        for x in x0..x1.min(w) {
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

    /// Oracle for the clean-up: opening then closing by the 3x3 square written out
    /// pixel by pixel (min / max over the neighbours inside the image), no imageproc.
    fn open_close_brute_force(m: &GrayImage) -> GrayImage {
        let (w, h) = (m.width() as i64, m.height() as i64);
        let reduce = |img: &GrayImage, erode: bool| {
            GrayImage::from_fn(img.width(), img.height(), |x, y| {
                let mut v = if erode { 255u8 } else { 0u8 };
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        let (u, t) = (i64::from(x) + dx, i64::from(y) + dy);
                        if u >= 0 && t >= 0 && u < w && t < h {
                            let p = img.get_pixel(u as u32, t as u32)[0];
                            v = if erode { v.min(p) } else { v.max(p) };
                        }
                    }
                }
                Luma([v])
            })
        };
        let opened = reduce(&reduce(m, true), false);
        reduce(&reduce(&opened, false), true)
    }

    #[test]
    fn clean_is_the_opening_then_closing_by_the_square() {
        let masks = LineMasks::new(1);
        for seed in 0..30 {
            let m = random_mask(seed, 17 + (seed % 5) as u32, 12, 40 + seed % 40);
            let mut got = m.clone();
            clean(&mut got, &masks);
            assert_eq!(got, open_close_brute_force(&m), "seed {seed}");
        }
        let mut same = random_mask(3, 10, 10, 50);
        let before = same.clone();
        clean(&mut same, &LineMasks::new(0));
        assert_eq!(same, before);
    }

    #[test]
    fn segmentation_matches_the_seed_definition_pixel_by_pixel() {
        // Oracle: S(u, v) = 1 when H(n)(r, g, b) > 0 for the pixel's bin, with H(n)
        // counted straight from the warped cloud (seed 000 section 3.3), on a frame of
        // random colours; the production path goes through the bin window and the LUT.
        use crate::colour_shape::state::{ColourDistribution, ColourWarp, colour_coords, fill_lut};
        let (w, h) = (23, 17);
        let mut s = 99u64;
        let mut next = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 56) as u8
        };
        let data: Vec<u8> = (0..w * h * 3).map(|_| next()).collect();
        let frame = RgbFrame::new(&data, w, h).unwrap();
        let bins = [8, 8, 4];
        for space in [ColorSpace::Rgb, ColorSpace::Opponent] {
            let cloud: Vec<[f64; 3]> = data[..3 * 60]
                .chunks_exact(3)
                .map(|p| colour_coords(space, [p[0], p[1], p[2]]).unwrap())
                .collect();
            let reference = ColourDistribution::from_points(&cloud, 0.01).unwrap();
            let mut state = reference.to_state();
            state[0] += 0.03;
            state[6] = 0.2;
            let warp = ColourWarp::new(&reference, &state, 0.01);
            let mut lut = Vec::new();
            fill_lut(&warp, &cloud, bins, &mut lut);
            let grid = Grid::over(Roi::clipped(2.0, 1.0, 21.0, 16.0, w, h), 1);
            let mut window = Vec::new();
            bin_window(&frame, grid, space, bins, &mut window);
            let mut seg = GrayImage::new(1, 1);
            segment(&window, &lut, grid, &mut seg);
            let cell = |c: f64, n: usize| ((c * n as f64).floor() as usize).min(n - 1);
            let bin_of = |c: [f64; 3]| {
                (
                    cell(c[0], bins[0]),
                    cell(c[1], bins[1]),
                    cell(c[2], bins[2]),
                )
            };
            for v in 0..grid.height {
                for u in 0..grid.width {
                    let p = &data[((grid.y0 + v) * w + grid.x0 + u) * 3..][..3];
                    let want = bin_of(colour_coords(space, [p[0], p[1], p[2]]).unwrap());
                    let hit = cloud.iter().any(|x| {
                        let y = warp.apply(x);
                        y.iter().all(|c| (0.0..1.0).contains(c))
                            && bin_of([y[0], y[1], y[2]]) == want
                    });
                    let got = seg.get_pixel(u as u32, v as u32)[0] != 0;
                    assert_eq!(got, hit, "{space:?} at ({u}, {v})");
                }
            }
        }
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
            // Within a box: the brute force on a copy cleared outside it.
            let (w, h) = (m.width() as usize, m.height() as usize);
            let bbox = [1, 2, w - 2, h - 1];
            let cleared = GrayImage::from_fn(m.width(), m.height(), |x, y| {
                let (x, y) = (x as usize, y as usize);
                let inside = (bbox[0]..bbox[2]).contains(&x) && (bbox[1]..bbox[3]).contains(&y);
                Luma([if inside {
                    m.get_pixel(x as u32, y as u32)[0]
                } else {
                    0
                }])
            });
            let got = euler_number_in(&m, bbox, &mut Vec::new());
            assert_eq!(got, euler_brute_force(&cleared), "seed {seed} in {bbox:?}");
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
    fn a_thin_bar_touching_the_blob_is_split_off() {
        // A disc of radius 10 with a 3-pixel bar attached; the prior is the disc.
        let disc = |x: u32, y: u32| (f64::from(x) - 20.0).hypot(f64::from(y) - 20.0) <= 10.0;
        let bar = |x: u32, y: u32| (29..50).contains(&x) && (19..22).contains(&y);
        let mut blob = GrayImage::from_fn(60, 40, |x, y| {
            Luma([if disc(x, y) || bar(x, y) { 255 } else { 0 }])
        });
        let prior = GrayImage::from_fn(60, 40, |x, y| Luma([if disc(x, y) { 255 } else { 0 }]));
        let (mut scratch, mut flood) = (Default::default(), FloodScratch::default());
        let b = split_at_necks(&mut blob, &prior, 2, &mut scratch, &mut flood).unwrap();
        // Oracle: the disc's own pixels, counted directly; the bar is gone but for the
        // stub within the growing-back radius of the disc.
        let disc_area = (0..60)
            .flat_map(|x| (0..40).map(move |y| (x, y)))
            .filter(|&(x, y)| disc(x, y))
            .count();
        assert!(
            b.area >= disc_area && b.area <= disc_area + 3 * 3,
            "{} vs {disc_area}",
            b.area
        );
        assert_eq!(blob.get_pixel(45, 20)[0], 0);
        assert_eq!(blob.get_pixel(20, 20)[0], 255);
        // Nothing survives an opening wider than the blob: left as it was.
        let mut small =
            GrayImage::from_fn(10, 10, |x, y| Luma([if x < 3 && y < 3 { 255 } else { 0 }]));
        let before = small.clone();
        assert!(split_at_necks(&mut small, &before.clone(), 3, &mut scratch, &mut flood).is_none());
        assert_eq!(small, before);
    }

    #[test]
    fn reacquisition_picks_the_component_of_the_remembered_area() {
        let seg = GrayImage::from_fn(40, 10, |x, y| {
            let on = (1..4).contains(&x) || ((10..20).contains(&x) && (2..8).contains(&y));
            Luma([if on { 255 } else { 0 }])
        });
        let (mut blob, mut stats) = (GrayImage::new(1, 1), Vec::new());
        let like = |area| ShapeMemory {
            area,
            spreads: [3.0, 2.0],
            near: [0.0, 0.0],
        };
        let b = best_component(&seg, &like(55.0), 0.5, &mut blob, &mut stats);
        assert_eq!(b.area, 60);
        assert_eq!(b.centroid, [14.5, 4.5]);
        let b = best_component(&seg, &like(1000.0), 0.5, &mut blob, &mut stats);
        assert_eq!(b.area, 0);
    }

    #[test]
    fn reacquisition_prefers_the_target_shape_to_a_bar_of_its_area() {
        // A 3 x 40 bar (120 cells) and an 11 x 11 square (121 cells), the bar nearer;
        // the target remembered as a square of 120 cells. Closed-form spreads of a
        // solid w x h rectangle: w / sqrt(12), h / sqrt(12).
        let bar = |x: u32, y: u32| (2..5).contains(&x) && (5..45).contains(&y);
        let square = |x: u32, y: u32| (30..41).contains(&x) && (20..31).contains(&y);
        let seg = GrayImage::from_fn(50, 50, |x, y| {
            Luma([if bar(x, y) || square(x, y) { 255 } else { 0 }])
        });
        let side = 120f64.sqrt() / 12f64.sqrt();
        let target = ShapeMemory {
            area: 120.0,
            spreads: [side, side],
            near: [3.0, 25.0],
        };
        let (mut blob, mut stats) = (GrayImage::new(1, 1), Vec::new());
        let b = best_component(&seg, &target, 0.5, &mut blob, &mut stats);
        assert_eq!(b.area, 121);
        assert_eq!(blob.get_pixel(35, 25)[0], 255);
        assert_eq!(blob.get_pixel(3, 25)[0], 0);
    }

    #[test]
    fn grid_maps_frame_pixels_to_their_nearest_cell() {
        let g = Grid::over(Roi::clipped(10.0, 20.0, 17.0, 25.0, 100, 100), 2);
        assert_eq!((g.width, g.height), (4, 3));
        assert_eq!(g.to_frame([3.0, 2.0]), [16.0, 24.0]);
        assert_eq!(g.to_grid([16.0, 24.0]), [3.0, 2.0]);
        let mut m = GrayImage::new(4, 3);
        m.put_pixel(1, 1, Luma([255]));
        // Cell (1, 1) is pixel (12, 22); pixels (11..=12, 21..=22) round to it.
        let hits: Vec<(i64, i64)> = (8..20)
            .flat_map(|x| (18..28).map(move |y| (x, y)))
            .filter(|&(x, y)| g.at(&m, x, y))
            .collect();
        assert_eq!(hits, vec![(11, 21), (11, 22), (12, 21), (12, 22)]);
    }

    #[test]
    fn segmentation_is_the_lookup_of_each_bin() {
        let grid = Grid::over(Roi::clipped(1.0, 0.0, 4.0, 2.0, 5, 5), 1);
        let bins = vec![0u16, 3, 2, 3, 1, 0];
        let lut = [0u8, 1, 0, 1];
        let mut seg = GrayImage::new(1, 1);
        segment(&bins, &lut, grid, &mut seg);
        assert_eq!(seg.as_raw(), &vec![0, 255, 0, 255, 255, 0]);
    }
}
