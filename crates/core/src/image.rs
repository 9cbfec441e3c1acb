//! Grey and colour images for the trackers: borrowed 8-bit views (the layout of an
//! `H x W` or `H x W x 3` uint8 numpy array), an owned `f32` grey image, bilinear
//! sampling and separable Gaussian blur.
//!
//! Pixel centres sit at integer coordinates, as in OpenCV: `(x, y)` samples column
//! `x`, row `y`, and `(0.5, 0)` lies halfway between the first two pixels of row 0.

use crate::error::{CoreError, Result};

fn check_size(len: usize, width: usize, height: usize, channels: usize) -> Result<()> {
    if width == 0 || height == 0 {
        return Err(CoreError::Dimension(format!(
            "image is empty ({width}x{height})"
        )));
    }
    let expected = width
        .checked_mul(height)
        .and_then(|p| p.checked_mul(channels))
        .ok_or_else(|| CoreError::Dimension(format!("image {width}x{height} is too large")))?;
    if len != expected {
        return Err(CoreError::Dimension(format!(
            "buffer has {len} bytes but a {width}x{height}x{channels} image needs {expected}"
        )));
    }
    Ok(())
}

/// A borrowed 8-bit image of `C` channels, row-major and contiguous: the layout of
/// an `H x W` (`C = 1`) or `H x W x C` uint8 numpy array.
#[derive(Debug, Clone, Copy)]
pub struct ImageView<'a, const C: usize> {
    data: &'a [u8],
    width: usize,
    height: usize,
}

/// A borrowed 8-bit grey image.
pub type GrayView<'a> = ImageView<'a, 1>;

/// A borrowed 8-bit RGB image (`R G B R G B ...`).
///
/// # Examples
/// ```
/// use rperc_core::image::RgbView;
///
/// let pixels = vec![0u8; 4 * 3 * 3];
/// let frame = RgbView::new(&pixels, 4, 3).unwrap();
/// assert_eq!((frame.width(), frame.height()), (4, 3));
/// assert!(RgbView::new(&pixels, 5, 3).is_err());
/// ```
pub type RgbView<'a> = ImageView<'a, 3>;

impl<'a, const C: usize> ImageView<'a, C> {
    /// Wraps `data` (`width * height * C` bytes) without copying.
    pub fn new(data: &'a [u8], width: usize, height: usize) -> Result<Self> {
        check_size(data.len(), width, height, C)?;
        Ok(Self {
            data,
            width,
            height,
        })
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// The raw bytes, row by row (channels interleaved).
    pub fn data(&self) -> &'a [u8] {
        self.data
    }

    /// Row `y` as `width * C` bytes.
    pub fn row(&self, y: usize) -> &'a [u8] {
        &self.data[y * self.width * C..(y + 1) * self.width * C]
    }
}

/// Grey level of an RGB pixel, ITU-R BT.601 luma (OpenCV's `COLOR_RGB2GRAY` weights).
///
/// Summed in `f64` and rounded once, so that a grey pixel `(g, g, g)` gives exactly `g`
/// (in `f32` the three products rounded apart can miss it by an ulp, and a colour frame
/// of grey pixels would not track exactly as the grey frame).
///
/// # Examples
/// ```
/// use rperc_core::image::luma;
///
/// assert!((0..=255u8).all(|g| luma(g, g, g) == f32::from(g)));
/// ```
#[inline]
pub fn luma(r: u8, g: u8, b: u8) -> f32 {
    (0.299 * f64::from(r) + 0.587 * f64::from(g) + 0.114 * f64::from(b)) as f32
}

/// The 8-bit grey level nearest `v`: `v.round().clamp(0.0, 255.0) as u8` (ties away
/// from zero, NaN to 0), without libm's `round` call, which the baseline x86-64 target
/// makes for every pixel of a rendered or converted image.
///
/// # Examples
/// ```
/// use rperc_core::image::grey_level;
///
/// assert_eq!([grey_level(-3.0), grey_level(2.5), grey_level(2.49), grey_level(300.0)], [0, 3, 2, 255]);
/// ```
#[inline]
pub fn grey_level(v: f64) -> u8 {
    let v = v.clamp(0.0, 255.0);
    // In [0, 255] truncation is the floor, exactly, and so is the fraction.
    let floor = v as u8;
    floor + u8::from(v - f64::from(floor) >= 0.5)
}

/// An owned grey image of `f32` levels (0..255 for converted 8-bit images).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GrayImage {
    /// Levels, row-major.
    pub data: Vec<f32>,
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
}

impl GrayImage {
    /// A `width x height` image of zeros.
    pub fn zeros(width: usize, height: usize) -> Self {
        Self {
            data: vec![0.0; width * height],
            width,
            height,
        }
    }

    /// Refills `self` from an 8-bit grey view, reusing the buffer.
    pub fn set_from_gray(&mut self, view: &GrayView<'_>) {
        self.resize(view.width, view.height);
        for (o, &v) in self.data.iter_mut().zip(view.data) {
            *o = f32::from(v);
        }
    }

    /// Refills `self` with the luma of an RGB view, reusing the buffer.
    pub fn set_from_rgb(&mut self, view: &RgbView<'_>) {
        self.resize(view.width, view.height);
        for (o, px) in self.data.iter_mut().zip(view.data.chunks_exact(3)) {
            *o = luma(px[0], px[1], px[2]);
        }
    }

    fn resize(&mut self, width: usize, height: usize) {
        self.width = width;
        self.height = height;
        self.data.resize(width * height, 0.0);
    }

    /// The level at integer pixel `(x, y)`.
    #[inline]
    pub fn at(&self, x: usize, y: usize) -> f32 {
        self.data[y * self.width + x]
    }

    /// Bilinear interpolation at `(x, y)`; `None` outside `[0, w-1] x [0, h-1]`.
    ///
    /// # Examples
    /// ```
    /// use rperc_core::image::GrayImage;
    ///
    /// let img = GrayImage { data: vec![0.0, 10.0, 20.0, 30.0], width: 2, height: 2 };
    /// assert_eq!(img.sample_bilinear(0.5, 0.5), Some(15.0));
    /// assert_eq!(img.sample_bilinear(1.0, 0.0), Some(10.0));
    /// assert_eq!(img.sample_bilinear(1.5, 0.0), None);
    /// ```
    #[inline]
    pub fn sample_bilinear(&self, x: f64, y: f64) -> Option<f32> {
        let (w, h) = (self.width as f64, self.height as f64);
        if !(x >= 0.0 && y >= 0.0 && x <= w - 1.0 && y <= h - 1.0) {
            return None;
        }
        // The coordinates are >= 0 here: truncation is the floor, without a libm call.
        let (x0, y0) = (x as usize, y as usize);
        let (x1, y1) = ((x0 + 1).min(self.width - 1), (y0 + 1).min(self.height - 1));
        let (fx, fy) = ((x - x0 as f64) as f32, (y - y0 as f64) as f32);
        let top = self.at(x0, y0) * (1.0 - fx) + self.at(x1, y0) * fx;
        let bottom = self.at(x0, y1) * (1.0 - fx) + self.at(x1, y1) * fx;
        Some(top * (1.0 - fy) + bottom * fy)
    }

    /// [`Self::sample_bilinear`] with the bilinear interpolant's gradient: `[value,
    /// d/dx, d/dy]` at `(x, y)`, `None` outside `[0, w-1] x [0, h-1]`. The gradient is
    /// the one of the cell `(x, y)` falls in (one-sided on the last row and column),
    /// so that a Gauss-Newton step sees the derivative of exactly what it samples.
    ///
    /// # Examples
    /// ```
    /// use rperc_core::image::GrayImage;
    ///
    /// let img = GrayImage { data: vec![0.0, 10.0, 20.0, 30.0], width: 2, height: 2 };
    /// assert_eq!(img.sample_bilinear_gradient(0.5, 0.5), Some([15.0, 10.0, 20.0]));
    /// ```
    #[inline]
    pub fn sample_bilinear_gradient(&self, x: f64, y: f64) -> Option<[f32; 3]> {
        let (w, h) = (self.width as f64, self.height as f64);
        if !(x >= 0.0 && y >= 0.0 && x <= w - 1.0 && y <= h - 1.0) {
            return None;
        }
        // The cell to the left of / above the last column / row, so that its
        // difference is the gradient there (images one pixel wide have none). The
        // coordinates are >= 0 here: truncation is the floor, without a libm call.
        let x0 = (x as usize).min(self.width.saturating_sub(2));
        let y0 = (y as usize).min(self.height.saturating_sub(2));
        let (x1, y1) = ((x0 + 1).min(self.width - 1), (y0 + 1).min(self.height - 1));
        let (fx, fy) = ((x - x0 as f64) as f32, (y - y0 as f64) as f32);
        let (a, b) = (self.at(x0, y0), self.at(x1, y0));
        let (c, d) = (self.at(x0, y1), self.at(x1, y1));
        let top = a + fx * (b - a);
        let bottom = c + fx * (d - c);
        let gx = (b - a) + fy * ((d - c) - (b - a));
        Some([top + fy * (bottom - top), gx, bottom - top])
    }

    /// [`Self::sample_bilinear_gradient`] at `start + l * step`, `l = 0..out.len()`:
    /// `false`, with `out` partly written, when a sample falls outside `[0, w-1] x [0,
    /// h-1]` (or is NaN). The bounds are checked at the two ends; a segment at least
    /// [`INTERIOR_MARGIN`] inside steps through the pixels in fixed point, as
    /// [`Self::sample_line`] does (positions exact to 6e-8 px).
    pub fn sample_line_gradient(
        &self,
        start: [f64; 2],
        step: [f64; 2],
        out: &mut [[f32; 3]],
    ) -> bool {
        if !self.walks_inside(start, step, out.len()) {
            return self.sample_line_gradient_checked(start, step, out);
        }
        let interpolate = |g: &mut [f32; 3], [a, b, c, d]: [f32; 4], tx: f32, ty: f32| {
            let top = a + tx * (b - a);
            let bottom = c + tx * (d - c);
            let gx = (b - a) + ty * ((d - c) - (b - a));
            *g = [top + ty * (bottom - top), gx, bottom - top];
        };
        self.walk_cells(start, step, out, interpolate)
            || self.sample_line_gradient_checked(start, step, out)
    }

    /// [`Self::sample_line_gradient`] point by point (near the image's edges).
    fn sample_line_gradient_checked(
        &self,
        start: [f64; 2],
        step: [f64; 2],
        out: &mut [[f32; 3]],
    ) -> bool {
        sample_points(start, step, out, |x, y| self.sample_bilinear_gradient(x, y))
    }

    /// Gaussian blur of standard deviation `sigma` pixels into `out` (separable, a
    /// kernel of radius `ceil(3 sigma)`, borders reflected without repeating the edge
    /// pixel as OpenCV's `BORDER_REFLECT_101`). `scratch` holds the horizontal pass;
    /// both buffers are reused, so a scale space allocates once.
    pub fn gaussian_blur(
        &self,
        sigma: f64,
        scratch: &mut GrayImage,
        out: &mut GrayImage,
    ) -> Result<()> {
        crate::error::ensure_non_negative("sigma", sigma)?;
        self.convolve_separable(&gaussian_kernel(sigma), scratch, out);
        Ok(())
    }

    /// Convolves rows then columns with the odd-length `kernel` into `out`, borders
    /// reflected as `BORDER_REFLECT_101` (the blur of [`Self::gaussian_blur`] with a
    /// kernel computed once by the caller, e.g. once per scale-space level): the whole
    /// image's [`Self::convolve_separable_window`].
    pub fn convolve_separable(&self, kernel: &[f32], scratch: &mut GrayImage, out: &mut GrayImage) {
        let window = [0, 0, self.width, self.height];
        self.convolve_separable_window(kernel, window, scratch, out);
    }

    /// [`Self::convolve_separable`]'s output inside `window = [x0, y0, x1, y1)` only
    /// (clamped to the image), into `out` (the window's size), with the same numbers
    /// (borders reflected at the image's edges, each output the sum over taps in
    /// kernel order, from 0). The horizontal pass runs on the window's columns of every row
    /// the vertical pass reads, the vertical one on the window's rows; sums are kept
    /// in registers over blocks of [`LANES`] pixels rather than written back per tap,
    /// and nothing is zero-filled (buffers are reused).
    pub fn convolve_separable_window(
        &self,
        kernel: &[f32],
        window: [usize; 4],
        scratch: &mut GrayImage,
        out: &mut GrayImage,
    ) {
        let [x0, y0, x1, y1] = self.clamp_window(window);
        resize_for(out, x1 - x0, y1 - y0);
        self.convolve_separable_window_into(kernel, window, scratch, &mut out.data);
    }

    /// `window = [x0, y0, x1, y1)` clamped to the image (ends no smaller than starts).
    pub fn clamp_window(&self, window: [usize; 4]) -> [usize; 4] {
        let (w, h) = (self.width, self.height);
        let [x0, y0] = [window[0].min(w), window[1].min(h)];
        [x0, y0, window[2].clamp(x0, w), window[3].clamp(y0, h)]
    }

    /// [`Self::convolve_separable_window`] into the rows of `out`, which holds the
    /// clamped window's levels row by row (nothing is written unless `out.len()` is
    /// its size): bands of rows of one window can then be blurred on separate threads
    /// into disjoint parts of one image, each with the whole window's numbers.
    pub fn convolve_separable_window_into(
        &self,
        kernel: &[f32],
        window: [usize; 4],
        scratch: &mut GrayImage,
        out: &mut [f32],
    ) {
        let (w, h) = (self.width, self.height);
        let [x0, y0, x1, y1] = self.clamp_window(window);
        let (ww, wh) = (x1 - x0, y1 - y0);
        let r = kernel.len() / 2;
        // The rows the vertical pass reads: the window's, grown by the radius
        // (reflected ones are among them).
        let (r0, r1) = (y0.saturating_sub(r), (y1 + r).min(h));
        resize_for(scratch, ww, r1 - r0);
        if ww == 0 || wh == 0 || kernel.is_empty() || out.len() != ww * wh {
            return;
        }
        for y in r0..r1 {
            let row = &self.data[y * w..(y + 1) * w];
            let dst = &mut scratch.data[(y - r0) * ww..(y - r0 + 1) * ww];
            convolve_row_window(row, kernel, x0, dst);
        }
        // Where each tap's row starts in `scratch`, for the current output row.
        let mut starts = vec![0usize; kernel.len()];
        for y in y0..y1 {
            for (k, start) in starts.iter_mut().enumerate() {
                *start = (reflect101(y as isize + k as isize - r as isize, h) - r0) * ww;
            }
            let dst = &mut out[(y - y0) * ww..(y - y0 + 1) * ww];
            if ww < LANES {
                for (x, d) in dst.iter_mut().enumerate() {
                    *d = kernel
                        .iter()
                        .zip(&starts)
                        .fold(0.0, |acc, (&wk, &start)| acc + wk * scratch.data[start + x]);
                }
                continue;
            }
            for x in block_starts(ww) {
                let mut acc = [0.0f32; LANES];
                for (&wk, &start) in kernel.iter().zip(&starts) {
                    add_scaled(&mut acc, wk, &scratch.data[start + x..start + x + LANES]);
                }
                dst[x..x + LANES].copy_from_slice(&acc);
            }
        }
    }

    /// Bilinear samples at `start + l * step`, `l = 0..out.len()`, into `out` (the
    /// grey-level profile along a segment); `false`, with `out` partly written, when
    /// a sample falls outside `[0, w-1] x [0, h-1]` (or is NaN).
    ///
    /// Equal to [`Self::sample_bilinear`] at each point up to the rounding of the
    /// positions to 2^-24 px, but the bounds are checked once, at the two ends: the
    /// points of a segment lie between them.
    ///
    /// # Examples
    /// ```
    /// use rperc_core::image::GrayImage;
    ///
    /// let img = GrayImage { data: vec![0.0, 10.0, 20.0, 30.0], width: 2, height: 2 };
    /// let mut out = [0.0; 3];
    /// assert!(img.sample_line([0.0, 0.0], [0.5, 0.5], &mut out));
    /// assert_eq!(out, [0.0, 15.0, 30.0]);
    /// assert!(!img.sample_line([0.0, 0.0], [1.0, 0.0], &mut out));
    /// ```
    #[inline]
    pub fn sample_line(&self, start: [f64; 2], step: [f64; 2], out: &mut [f32]) -> bool {
        let Some(last) = out.len().checked_sub(1) else {
            return true;
        };
        let end = [
            start[0] + last as f64 * step[0],
            start[1] + last as f64 * step[1],
        ];
        let (w, h) = (self.width as f64, self.height as f64);
        let inside = |p: [f64; 2]| p[0] >= 0.0 && p[1] >= 0.0 && p[0] <= w - 1.0 && p[1] <= h - 1.0;
        if !(inside(start) && inside(end)) {
            return false;
        }
        // Fixed point with FRACTION_BITS fractional bits (positions exact to 6e-8 px):
        // integer steps and a shift instead of a saturating float-to-int cast per
        // sample, which cost more than the interpolation. Segments within
        // INTERIOR_MARGIN px of the last row or column (where the right or lower neighbour does not exist)
        // or of the first (where the fixed-point rounding, a unit per sample, could
        // cross them), segments of more than 1024 samples, and images too small or too
        // large for it, go point by point.
        if !self.walks_inside(start, step, out.len()) {
            return self.sample_line_checked(start, step, out);
        }
        self.sample_line_interior(start, step, out)
    }

    /// [`Self::sample_line`] for a segment the caller knows to lie inside: its two
    /// ends at least [`INTERIOR_MARGIN`] px inside the first and last rows and
    /// columns, at most 1024 samples, an image 2 to 2^36 pixels wide and high. Then
    /// it gives the same values as [`Self::sample_line`] without its checks, which
    /// cost as much as a few samples when a caller has bounded many segments at once
    /// (all of a pattern's profiles, by the pattern's radius). Outside these bounds
    /// the values are unspecified but it never panics (debug builds assert them).
    ///
    /// # Examples
    /// ```
    /// use rperc_core::image::GrayImage;
    ///
    /// let img = GrayImage { data: (0..16).map(|v| v as f32).collect(), width: 4, height: 4 };
    /// let (mut a, mut b) = ([0.0; 3], [0.0; 3]);
    /// assert!(img.sample_line([0.5, 0.25], [1.0, 0.5], &mut a));
    /// assert!(img.sample_line_interior([0.5, 0.25], [1.0, 0.5], &mut b));
    /// assert_eq!(a, b);
    /// ```
    #[inline]
    pub fn sample_line_interior(&self, start: [f64; 2], step: [f64; 2], out: &mut [f32]) -> bool {
        debug_assert!(self.walks_inside(start, step, out.len()));
        let interpolate = |g: &mut f32, [a, b, c, d]: [f32; 4], tx: f32, ty: f32| {
            let upper = a + tx * (b - a);
            let lower = c + tx * (d - c);
            *g = upper + ty * (lower - upper);
        };
        // Out of the image only when the caller broke the bounds.
        self.walk_cells(start, step, out, interpolate) || self.sample_line_checked(start, step, out)
    }

    /// Whether `n` samples from `start` by `step` suit the fixed-point walk of
    /// [`Self::walk_cells`]: both ends at least [`INTERIOR_MARGIN`] px inside the first
    /// and last rows and columns, at most 1024 samples, an image 2 to 2^36 pixels
    /// wide and high.
    fn walks_inside(&self, start: [f64; 2], step: [f64; 2], n: usize) -> bool {
        let last = n.saturating_sub(1) as f64;
        let end = [start[0] + last * step[0], start[1] + last * step[1]];
        let (w, h) = (self.width as f64, self.height as f64);
        let inner = |p: [f64; 2]| {
            p[0] >= INTERIOR_MARGIN
                && p[1] >= INTERIOR_MARGIN
                && p[0] <= w - 1.0 - INTERIOR_MARGIN
                && p[1] <= h - 1.0 - INTERIOR_MARGIN
        };
        let sizes = 2..=1usize << 36;
        inner(start)
            && inner(end)
            && n <= 1024
            && sizes.contains(&self.width)
            && sizes.contains(&self.height)
    }

    /// Visits the samples `out[l]` at `start + l * step` with their cell's four
    /// neighbours `[top-left, top-right, bottom-left, bottom-right]` and the fractions
    /// `(tx, ty)` of the position in it, stepping in fixed point with
    /// [`FRACTION_BITS`] fractional bits (positions truncated, no libm call: at most
    /// one unit, 6e-8 px, off); `false` as soon as a cell leaves the image (the ends
    /// are meant to lie [`INTERIOR_MARGIN`] inside, which keeps every cell in it).
    #[inline(always)]
    fn walk_cells<T>(
        &self,
        start: [f64; 2],
        step: [f64; 2],
        out: &mut [T],
        mut visit: impl FnMut(&mut T, [f32; 4], f32, f32),
    ) -> bool {
        let one = f64::from(1u32 << FRACTION_BITS);
        let (unit, mask) = (1.0 / one as f32, (1u64 << FRACTION_BITS) - 1);
        let fixed = |v: f64| (v * one) as i64;
        let (mut fx, mut fy) = (fixed(start[0]), fixed(start[1]));
        let (dx, dy) = (fixed(step[0]), fixed(step[1]));
        let w = self.width;
        for g in out.iter_mut() {
            // Non-negative and below (size - 1) * 2^24 when the ends are MARGIN = 1677
            // units inside: the rounding drifts by at most 1024 units.
            let (ux, uy) = (fx as u64, fy as u64);
            let (x0, y0) = (
                (ux >> FRACTION_BITS) as usize,
                (uy >> FRACTION_BITS) as usize,
            );
            let tx = (ux & mask) as f32 * unit;
            let ty = (uy & mask) as f32 * unit;
            let i = y0 * w + x0;
            // One slice over the four neighbours: one bounds check, not one per pixel.
            let Some(quad) = self.data.get(i..i + w + 2) else {
                return false;
            };
            visit(g, [quad[0], quad[1], quad[w], quad[w + 1]], tx, ty);
            fx += dx;
            fy += dy;
        }
        true
    }

    /// [`Self::sample_line`] point by point through [`Self::sample_bilinear`] (near the
    /// image's edges, and images a single pixel wide or high, or wider than 2^36).
    fn sample_line_checked(&self, start: [f64; 2], step: [f64; 2], out: &mut [f32]) -> bool {
        sample_points(start, step, out, |x, y| self.sample_bilinear(x, y))
    }
}

/// `out[l] = sample(start + l step)` point by point, the checked path of the line
/// samplers; false at the first point `sample` refuses (outside the image).
fn sample_points<T>(
    start: [f64; 2],
    step: [f64; 2],
    out: &mut [T],
    sample: impl Fn(f64, f64) -> Option<T>,
) -> bool {
    for (l, g) in out.iter_mut().enumerate() {
        let x = start[0] + l as f64 * step[0];
        let y = start[1] + l as f64 * step[1];
        match sample(x, y) {
            Some(v) => *g = v,
            None => return false,
        }
    }
    true
}

/// Fractional bits of the fixed-point positions of the line samplers (2^-24 px).
const FRACTION_BITS: u32 = 24;

/// How far inside the first and last rows and columns [`GrayImage::sample_line`]'s
/// fixed-point path needs a segment's ends (see [`GrayImage::sample_line_interior`]).
pub const INTERIOR_MARGIN: f64 = 1e-4;

/// Pixels whose sums [`GrayImage::convolve_separable_window`] keeps in registers
/// together (four SSE registers).
const LANES: usize = 16;

/// `acc += wk * line` lane by lane (`line` holds [`LANES`] levels): a fixed-size
/// block the compiler keeps in vector registers.
#[inline(always)]
fn add_scaled(acc: &mut [f32; LANES], wk: f32, line: &[f32]) {
    let Ok(line) = <&[f32; LANES]>::try_from(line) else {
        return;
    };
    for i in 0..LANES {
        acc[i] += wk * line[i];
    }
}

/// Sets `img` to `width x height`, its levels left as they are (every one is about to
/// be written): only a growing buffer is filled.
fn resize_for(img: &mut GrayImage, width: usize, height: usize) {
    img.width = width;
    img.height = height;
    img.data.resize(width * height, 0.0);
}

/// Columns `x0..x0 + dst.len()` of `row` convolved with `kernel`, reflected at the
/// row's ends (the reflection paid only within the kernel's radius of them).
fn convolve_row_window(row: &[f32], kernel: &[f32], x0: usize, dst: &mut [f32]) {
    let (w, r) = (row.len(), kernel.len() / 2);
    let reflected = |x: usize| {
        kernel.iter().enumerate().fold(0.0f32, |acc, (k, &wk)| {
            acc + wk * row[reflect101(x as isize + k as isize - r as isize, w)]
        })
    };
    let x1 = x0 + dst.len();
    // Columns whose taps all fall inside the row: [lo, hi).
    let (lo, hi) = if w > 2 * r {
        (r.clamp(x0, x1), (w - r).clamp(x0, x1))
    } else {
        (x1, x1)
    };
    let hi = hi.max(lo);
    for x in (x0..lo).chain(hi..x1) {
        dst[x - x0] = reflected(x);
    }
    let interior = &mut dst[lo - x0..hi - x0];
    if interior.len() < LANES {
        for (i, d) in interior.iter_mut().enumerate() {
            *d = reflected(lo + i);
        }
        return;
    }
    for i in block_starts(interior.len()) {
        // Output x reads row[x - r + k]: a block starting at x reads from x - r.
        let x = lo + i - r;
        let segment = &row[x..x + kernel.len() - 1 + LANES];
        let mut acc = [0.0f32; LANES];
        for (&wk, line) in kernel.iter().zip(segment.windows(LANES)) {
            add_scaled(&mut acc, wk, line);
        }
        interior[i..i + LANES].copy_from_slice(&acc);
    }
}

/// Starts of blocks of [`LANES`] outputs covering `0..n` (`n >= LANES`): every
/// `LANES`, the last one moved back to end at `n`, overlapping its neighbour (each
/// output is computed the same way wherever its block starts).
fn block_starts(n: usize) -> impl Iterator<Item = usize> {
    (0..n / LANES)
        .map(|b| b * LANES)
        .chain((!n.is_multiple_of(LANES)).then(|| n - LANES))
}

/// Normalised Gaussian weights on `-r..=r`, `r = ceil(3 sigma)`; `[1]` for sigma 0.
pub fn gaussian_kernel(sigma: f64) -> Vec<f32> {
    if sigma <= 0.0 {
        return vec![1.0];
    }
    let r = (3.0 * sigma).ceil() as isize;
    let w: Vec<f64> = (-r..=r)
        .map(|k| (-(k * k) as f64 / (2.0 * sigma * sigma)).exp())
        .collect();
    let total: f64 = w.iter().sum();
    w.iter().map(|v| (v / total) as f32).collect()
}

/// Index `i` reflected into `0..n` without repeating the edge (`-1 -> 1`, `n -> n-2`).
#[inline]
fn reflect101(i: isize, n: usize) -> usize {
    if n == 1 {
        return 0;
    }
    let n = n as isize;
    let period = 2 * (n - 1);
    let m = i.rem_euclid(period);
    (if m < n { m } else { period - m }) as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `w x h` image of hashed grey levels (no two neighbours alike), the samplers'
    /// test image.
    fn hashed(w: usize, h: usize) -> GrayImage {
        GrayImage {
            data: (0..w * h).map(|i| ((i * 53) % 97) as f32 * 1.3).collect(),
            width: w,
            height: h,
        }
    }

    #[test]
    fn grey_level_is_libms_round_then_clamp() {
        let oracle = |v: f64| v.round().clamp(0.0, 255.0) as u8;
        let mut specials = vec![f64::NAN, f64::INFINITY, f64::NEG_INFINITY, -0.0, 0.5, 254.5];
        specials.extend([0.49999999999999994, 255.49999999999997, 1e300, -1e-300]);
        for v in specials {
            assert_eq!(grey_level(v), oracle(v), "v = {v:e}");
        }
        // Every tie and its two neighbouring doubles, and a dense sweep.
        for k in -4..=520 {
            let tie = f64::from(k) * 0.5;
            for v in [tie.next_down(), tie, tie.next_up()] {
                assert_eq!(grey_level(v), oracle(v), "v = {v:e}");
            }
        }
        for k in -10_000..=270_000 {
            let v = f64::from(k) * 1e-3 + 1e-7;
            assert_eq!(grey_level(v), oracle(v), "v = {v:e}");
        }
    }

    #[test]
    fn reflect101_matches_opencv_rule() {
        let got: Vec<usize> = (-3..7).map(|i| reflect101(i, 4)).collect();
        // OpenCV BORDER_REFLECT_101 of "abcd": dcb|abcd|cba
        assert_eq!(got, vec![3, 2, 1, 0, 1, 2, 3, 2, 1, 0]);
    }

    /// The separable blur against a direct 2-D convolution with the product kernel.
    #[test]
    fn blur_matches_direct_convolution() {
        // Interior and border paths, and images narrower than the kernel.
        for (w, h, sigma) in [
            (13, 9, 1.3),
            (3, 40, 2.0),
            (64, 2, 0.8),
            (31, 27, 3.0),
            (1, 1, 1.0),
        ] {
            let img = GrayImage {
                data: (0..w * h).map(|i| ((i * 37) % 101) as f32).collect(),
                width: w,
                height: h,
            };
            let (mut scratch, mut out) = (GrayImage::default(), GrayImage::default());
            img.gaussian_blur(sigma, &mut scratch, &mut out).unwrap();
            assert_eq!((out.width, out.height), (w, h));
            let r = (3.0 * sigma).ceil() as isize;
            let g = |k: isize| (-(k * k) as f64 / (2.0 * sigma * sigma)).exp();
            let norm: f64 = (-r..=r).map(g).sum();
            for y in 0..h {
                for x in 0..w {
                    let mut s = 0.0;
                    for dy in -r..=r {
                        for dx in -r..=r {
                            let xx = reflect101(x as isize + dx, w);
                            let yy = reflect101(y as isize + dy, h);
                            s += g(dx) * g(dy) / (norm * norm) * f64::from(img.at(xx, yy));
                        }
                    }
                    let got = f64::from(out.at(x, y));
                    assert!((got - s).abs() < 1e-3, "{w}x{h} ({x}, {y})");
                }
            }
        }
        let (w, h) = (13, 9);
        let (mut scratch, mut out) = (GrayImage::default(), GrayImage::default());
        // A constant image stays constant.
        let flat = GrayImage {
            data: vec![7.0; w * h],
            width: w,
            height: h,
        };
        flat.gaussian_blur(2.0, &mut scratch, &mut out).unwrap();
        assert!(out.data.iter().all(|&v| (v - 7.0).abs() < 1e-4));
    }

    /// Bilinear sampling reproduces a linear ramp exactly.
    #[test]
    fn bilinear_is_exact_on_planes() {
        let (w, h) = (6, 5);
        let img = GrayImage {
            data: (0..h)
                .flat_map(|y| (0..w).map(move |x| 3.0 * x as f32 - 2.0 * y as f32 + 1.0))
                .collect(),
            width: w,
            height: h,
        };
        for &(x, y) in &[(0.0, 0.0), (2.25, 3.5), (5.0, 4.0), (4.9, 0.1)] {
            let want = 3.0 * x - 2.0 * y + 1.0;
            assert!((f64::from(img.sample_bilinear(x, y).unwrap()) - want).abs() < 1e-5);
        }
        assert_eq!(img.sample_bilinear(-0.01, 1.0), None);
        assert_eq!(img.sample_bilinear(1.0, f64::NAN), None);
    }

    proptest::proptest! {
        /// The segment sampler equals the point sampler at every sample, and refuses a
        /// segment exactly when some point sampler refuses one of its samples.
        #[test]
        fn sample_line_equals_point_samples(
            x in -3.0f64..12.0, y in -3.0f64..10.0, dx in -2.0f64..2.0, dy in -2.0f64..2.0,
            n in 1usize..16, w in 1usize..10, h in 1usize..8,
        ) {
            let img = hashed(w, h);
            let mut out = vec![0.0; n];
            let ok = img.sample_line([x, y], [dx, dy], &mut out);
            let each: Option<Vec<f32>> = (0..n)
                .map(|l| img.sample_bilinear(x + l as f64 * dx, y + l as f64 * dy))
                .collect();
            proptest::prop_assert_eq!(ok, each.is_some());
            if let Some(each) = each {
                for (a, b) in out.iter().zip(&each) {
                    proptest::prop_assert!((a - b).abs() <= 1e-4 * b.abs().max(1.0), "{} {}", a, b);
                }
            }
        }
    }

    proptest::proptest! {
        /// Inside its bounds, the unchecked sampler gives the checked one's values bit
        /// for bit.
        #[test]
        fn sample_line_interior_equals_sample_line_inside(
            x in 0.0f64..1.0, y in 0.0f64..1.0, dx in -1.5f64..1.5, dy in -1.5f64..1.5,
            n in 1usize..16, w in 2usize..30, h in 2usize..30,
        ) {
            let img = hashed(w, h);
            let last = (n - 1) as f64;
            let start = [
                INTERIOR_MARGIN + x * (w as f64 - 1.0 - 2.0 * INTERIOR_MARGIN),
                INTERIOR_MARGIN + y * (h as f64 - 1.0 - 2.0 * INTERIOR_MARGIN),
            ];
            let end = [start[0] + last * dx, start[1] + last * dy];
            let inside = |v: f64, size: usize| {
                (INTERIOR_MARGIN..=size as f64 - 1.0 - INTERIOR_MARGIN).contains(&v)
            };
            proptest::prop_assume!(inside(end[0], w) && inside(end[1], h));
            let (mut a, mut b) = (vec![0.0; n], vec![0.0; n]);
            proptest::prop_assert!(img.sample_line(start, [dx, dy], &mut a));
            proptest::prop_assert!(img.sample_line_interior(start, [dx, dy], &mut b));
            let bits = |v: &[f32]| v.iter().map(|g| g.to_bits()).collect::<Vec<_>>();
            proptest::prop_assert_eq!(bits(&a), bits(&b));
        }
    }

    proptest::proptest! {
        /// The sampled gradient is the interpolant's: inside a cell the bilinear
        /// surface is linear along each axis, so its x-derivative is exactly the
        /// secant across the cell at the same y (and likewise in y). The secant spans
        /// a whole pixel, so the f32 samples' rounding (about 1e-5 on values up to
        /// 125) stays far below the tolerance; a 2e-3 px central difference divided
        /// that rounding by 2e-3 and failed on 0.01 now and then (CI, 2026-11-29).
        #[test]
        fn the_bilinear_gradient_matches_the_cell_secants(
            cx in 0usize..19, cy in 0usize..19, fx in 0.01f64..0.99, fy in 0.01f64..0.99,
            w in 2usize..20, h in 2usize..20,
        ) {
            let img = hashed(w, h);
            // A point strictly inside a cell, so that its gradient is the cell's.
            let (x0, y0) = ((cx % (w - 1)) as f64, (cy % (h - 1)) as f64);
            let (px, py) = (x0 + fx, y0 + fy);
            let [value, gx, gy] = img.sample_bilinear_gradient(px, py).unwrap();
            let at = |u: f64, v: f64| f64::from(img.sample_bilinear(u, v).unwrap());
            let dx = at(x0 + 1.0, py) - at(x0, py);
            let dy = at(px, y0 + 1.0) - at(px, y0);
            proptest::prop_assert!((f64::from(value) - at(px, py)).abs() < 1e-3);
            proptest::prop_assert!((f64::from(gx) - dx).abs() < 1e-3, "{} vs {}", gx, dx);
            proptest::prop_assert!((f64::from(gy) - dy).abs() < 1e-3, "{} vs {}", gy, dy);
        }
    }

    proptest::proptest! {
        /// The line sampler with gradients gives the point sampler's values (to the
        /// fixed point's rounding of the positions), inside and near the edges, and
        /// refuses a segment that leaves the image.
        #[test]
        fn the_gradient_line_sampler_matches_the_point_sampler(
            x in -0.5f64..1.5, y in -0.5f64..1.5, dx in -1.5f64..1.5, dy in -1.5f64..1.5,
            n in 1usize..16, w in 2usize..30, h in 2usize..30,
        ) {
            let img = hashed(w, h);
            let start = [x * (w as f64 - 1.0), y * (h as f64 - 1.0)];
            let mut out = vec![[0.0f32; 3]; n];
            let ok = img.sample_line_gradient(start, [dx, dy], &mut out);
            let points: Vec<Option<[f32; 3]>> = (0..n)
                .map(|l| img.sample_bilinear_gradient(start[0] + l as f64 * dx, start[1] + l as f64 * dy))
                .collect();
            proptest::prop_assert_eq!(ok, points.iter().all(Option::is_some));
            if ok {
                for (l, (got, want)) in out.iter().zip(&points).enumerate() {
                    let want = want.unwrap();
                    let (px, py) = (start[0] + l as f64 * dx, start[1] + l as f64 * dy);
                    let off_grid = |v: f64| (v - v.round()).abs() > 1e-6;
                    // Values are off by at most a position rounding (6e-8 px) times the
                    // steepest slope; gradients too, unless the rounding crosses a cell
                    // edge (a sample within 1e-6 px of a grid line) where they jump.
                    let compared = if off_grid(px) && off_grid(py) { 3 } else { 1 };
                    for k in 0..compared {
                        proptest::prop_assert!((got[k] - want[k]).abs() < 1e-3, "{:?} vs {:?}", got, want);
                    }
                }
            }
        }
    }

    proptest::proptest! {
        /// A window of the blur holds the whole image's blur there, bit for bit, into
        /// buffers left over from other sizes.
        #[test]
        fn a_window_blurs_as_the_whole_image_does_there(
            w in 1usize..40, h in 1usize..30, taps in 0usize..8,
            x0 in 0usize..45, y0 in 0usize..35, ww in 0usize..45, wh in 0usize..35,
            stale in 0usize..3000,
        ) {
            let img = GrayImage {
                data: (0..w * h).map(|i| ((i * 53) % 97) as f32 * 1.7).collect(),
                width: w,
                height: h,
            };
            let kernel: Vec<f32> = (0..2 * taps + 1).map(|k| 0.1 + (k % 3) as f32 * 0.2).collect();
            let (mut scratch, mut whole) = (GrayImage::default(), GrayImage::default());
            img.convolve_separable(&kernel, &mut scratch, &mut whole);
            let mut part = GrayImage { data: vec![f32::NAN; stale], width: 1, height: stale };
            let mut scratch = GrayImage { data: vec![-1.0; stale / 2], width: 1, height: stale / 2 };
            img.convolve_separable_window(&kernel, [x0, y0, x0 + ww, y0 + wh], &mut scratch, &mut part);
            let (cx0, cy0) = (x0.min(w), y0.min(h));
            let (cx1, cy1) = ((x0 + ww).min(w), (y0 + wh).min(h));
            proptest::prop_assert_eq!((part.width, part.height), (cx1 - cx0, cy1 - cy0));
            proptest::prop_assert_eq!(part.data.len(), part.width * part.height);
            for y in cy0..cy1 {
                for x in cx0..cx1 {
                    let (a, b) = (part.at(x - cx0, y - cy0), whole.at(x, y));
                    proptest::prop_assert_eq!(a.to_bits(), b.to_bits(), "({}, {})", x, y);
                }
            }
        }
    }

    proptest::proptest! {
        /// Two bands of rows of a window, blurred into the two parts of one buffer,
        /// give the window's blur bit for bit; a buffer of the wrong size is left as
        /// it was.
        #[test]
        fn bands_of_a_window_blur_as_the_window_does(
            w in 1usize..40, h in 1usize..30, taps in 0usize..6,
            x0 in 0usize..20, y0 in 0usize..20, ww in 0usize..40, wh in 0usize..30,
            split in 0.0f64..1.0,
        ) {
            let img = GrayImage {
                data: (0..w * h).map(|i| ((i * 37) % 89) as f32 * 1.3).collect(),
                width: w,
                height: h,
            };
            let kernel: Vec<f32> = (0..2 * taps + 1).map(|k| 0.2 + (k % 2) as f32 * 0.3).collect();
            let window = [x0, y0, x0 + ww, y0 + wh];
            let (mut scratch, mut part) = (GrayImage::default(), GrayImage::default());
            img.convolve_separable_window(&kernel, window, &mut scratch, &mut part);
            let [cx0, cy0, cx1, cy1] = img.clamp_window(window);
            let rows = cy1 - cy0;
            let mid = cy0 + (split * rows as f64) as usize;
            let mut out = vec![f32::NAN; (cx1 - cx0) * rows];
            let (top, bottom) = out.split_at_mut((cx1 - cx0) * (mid - cy0));
            img.convolve_separable_window_into(&kernel, [cx0, cy0, cx1, mid], &mut scratch, top);
            img.convolve_separable_window_into(&kernel, [cx0, mid, cx1, cy1], &mut scratch, bottom);
            let bits = |v: &[f32]| v.iter().map(|g| g.to_bits()).collect::<Vec<_>>();
            proptest::prop_assert_eq!(bits(&out), bits(&part.data));
            let mut wrong = vec![7.0f32; out.len() + 1];
            img.convolve_separable_window_into(&kernel, window, &mut scratch, &mut wrong);
            proptest::prop_assert!(wrong.iter().all(|&g| g == 7.0));
        }
    }

    #[test]
    fn views_check_their_size() {
        assert!(GrayView::new(&[0; 6], 3, 2).is_ok());
        assert!(GrayView::new(&[0; 6], 3, 3).is_err());
        assert!(RgbView::new(&[], 0, 3).is_err());
    }
}
