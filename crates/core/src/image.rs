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

/// A borrowed 8-bit grey image, row-major and contiguous.
#[derive(Debug, Clone, Copy)]
pub struct GrayView<'a> {
    data: &'a [u8],
    width: usize,
    height: usize,
}

impl<'a> GrayView<'a> {
    /// Wraps `data` (`width * height` bytes) without copying.
    pub fn new(data: &'a [u8], width: usize, height: usize) -> Result<Self> {
        check_size(data.len(), width, height, 1)?;
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

    /// The raw bytes, row by row.
    pub fn data(&self) -> &'a [u8] {
        self.data
    }
}

/// A borrowed 8-bit RGB image, row-major and contiguous (`R G B R G B ...`).
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
#[derive(Debug, Clone, Copy)]
pub struct RgbView<'a> {
    data: &'a [u8],
    width: usize,
    height: usize,
}

impl<'a> RgbView<'a> {
    /// Wraps `data` (`width * height * 3` bytes) without copying.
    pub fn new(data: &'a [u8], width: usize, height: usize) -> Result<Self> {
        check_size(data.len(), width, height, 3)?;
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

    /// The raw bytes, `R G B R G B ...` row by row.
    pub fn data(&self) -> &'a [u8] {
        self.data
    }

    /// Row `y` as `width * 3` bytes.
    pub fn row(&self, y: usize) -> &'a [u8] {
        &self.data[y * self.width * 3..(y + 1) * self.width * 3]
    }
}

/// Grey level of an RGB pixel, ITU-R BT.601 luma (OpenCV's `COLOR_RGB2GRAY` weights).
#[inline]
pub fn luma(r: u8, g: u8, b: u8) -> f32 {
    0.299 * f32::from(r) + 0.587 * f32::from(g) + 0.114 * f32::from(b)
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
        let (x0, y0) = (x.floor() as usize, y.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(self.width - 1), (y0 + 1).min(self.height - 1));
        let (fx, fy) = ((x - x0 as f64) as f32, (y - y0 as f64) as f32);
        let top = self.at(x0, y0) * (1.0 - fx) + self.at(x1, y0) * fx;
        let bottom = self.at(x0, y1) * (1.0 - fx) + self.at(x1, y1) * fx;
        Some(top * (1.0 - fy) + bottom * fy)
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
        let kernel = gaussian_kernel(sigma);
        scratch.resize(self.width, self.height);
        out.resize(self.width, self.height);
        let r = kernel.len() / 2;
        for y in 0..self.height {
            let row = &self.data[y * self.width..(y + 1) * self.width];
            let dst = &mut scratch.data[y * self.width..(y + 1) * self.width];
            for (x, d) in dst.iter_mut().enumerate() {
                *d = kernel
                    .iter()
                    .enumerate()
                    .map(|(k, &w)| {
                        w * row[reflect101(x as isize + k as isize - r as isize, self.width)]
                    })
                    .sum();
            }
        }
        for y in 0..self.height {
            for x in 0..self.width {
                out.data[y * self.width + x] = kernel
                    .iter()
                    .enumerate()
                    .map(|(k, &w)| {
                        let yy = reflect101(y as isize + k as isize - r as isize, self.height);
                        w * scratch.data[yy * self.width + x]
                    })
                    .sum();
            }
        }
        Ok(())
    }
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

    #[test]
    fn reflect101_matches_opencv_rule() {
        let got: Vec<usize> = (-3..7).map(|i| reflect101(i, 4)).collect();
        // OpenCV BORDER_REFLECT_101 of "abcd": dcb|abcd|cba
        assert_eq!(got, vec![3, 2, 1, 0, 1, 2, 3, 2, 1, 0]);
    }

    /// The separable blur against a direct 2-D convolution with the product kernel.
    #[test]
    fn blur_matches_direct_convolution() {
        let (w, h) = (13, 9);
        let img = GrayImage {
            data: (0..w * h).map(|i| ((i * 37) % 101) as f32).collect(),
            width: w,
            height: h,
        };
        let sigma = 1.3;
        let (mut scratch, mut out) = (GrayImage::default(), GrayImage::default());
        img.gaussian_blur(sigma, &mut scratch, &mut out).unwrap();
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
                assert!((f64::from(out.at(x, y)) - s).abs() < 1e-3, "({x}, {y})");
            }
        }
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

    #[test]
    fn views_check_their_size() {
        assert!(GrayView::new(&[0; 6], 3, 2).is_ok());
        assert!(GrayView::new(&[0; 6], 3, 3).is_err());
        assert!(RgbView::new(&[], 0, 3).is_err());
    }
}
