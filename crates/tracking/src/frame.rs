//! Borrowed RGB frames and (x, y, w, h) boxes: the tracker's inputs.

use crate::error::{Result, TrackingError};

/// A borrowed RGB frame: `height` rows of `width` pixels, 3 bytes each, row-major and
/// contiguous (the layout of an `H x W x 3` uint8 numpy array or an [`image::RgbImage`]).
///
/// # Examples
/// ```
/// use tracking::RgbFrame;
///
/// let pixels = vec![0u8; 4 * 3 * 3];
/// let frame = RgbFrame::new(&pixels, 4, 3).unwrap();
/// assert_eq!((frame.width(), frame.height()), (4, 3));
/// assert!(RgbFrame::new(&pixels, 5, 3).is_err());
/// ```
#[derive(Debug, Clone, Copy)]
pub struct RgbFrame<'a> {
    data: &'a [u8],
    width: usize,
    height: usize,
}

impl<'a> RgbFrame<'a> {
    /// Wraps `data` without copying.
    ///
    /// # Errors
    /// [`TrackingError::EmptyFrame`] for a zero dimension, [`TrackingError::FrameSize`]
    /// unless `data.len() == width * height * 3`.
    pub fn new(data: &'a [u8], width: usize, height: usize) -> Result<Self> {
        if width == 0 || height == 0 {
            return Err(TrackingError::EmptyFrame { width, height });
        }
        let expected = width
            .checked_mul(height)
            .and_then(|p| p.checked_mul(3))
            .unwrap_or(usize::MAX);
        if data.len() != expected {
            return Err(TrackingError::FrameSize {
                width,
                height,
                expected,
                got: data.len(),
            });
        }
        Ok(Self {
            data,
            width,
            height,
        })
    }

    /// Views an [`image::RgbImage`].
    ///
    /// # Errors
    /// [`TrackingError::EmptyFrame`] for an empty image.
    pub fn from_image(image: &'a image::RgbImage) -> Result<Self> {
        Self::new(
            image.as_raw(),
            image.width() as usize,
            image.height() as usize,
        )
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
    pub(crate) fn row(&self, y: usize) -> &'a [u8] {
        &self.data[y * self.width * 3..(y + 1) * self.width * 3]
    }
}

/// An axis-aligned box in pixels: top-left corner `(x, y)` (0-based), width and height.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoundingBox {
    /// Left edge.
    pub x: f64,
    /// Top edge.
    pub y: f64,
    /// Width.
    pub w: f64,
    /// Height.
    pub h: f64,
}

impl BoundingBox {
    /// A box from its corner and size.
    pub const fn new(x: f64, y: f64, w: f64, h: f64) -> Self {
        Self { x, y, w, h }
    }

    /// Its centre `(x + w/2, y + h/2)`.
    pub fn centre(&self) -> (f64, f64) {
        (self.x + self.w / 2.0, self.y + self.h / 2.0)
    }

    /// The box as `[x, y, w, h]`.
    pub fn to_array(&self) -> [f64; 4] {
        [self.x, self.y, self.w, self.h]
    }

    /// Checks that the box is finite, at least one pixel in each direction, and inside a
    /// `width x height` frame (a box may touch the frame's edges; up to half a pixel of
    /// overhang is tolerated for rounding).
    ///
    /// # Errors
    /// [`TrackingError::InvalidBox`] or [`TrackingError::BoxOutsideFrame`].
    pub fn check_inside(&self, width: usize, height: usize) -> Result<()> {
        let BoundingBox { x, y, w, h } = *self;
        if ![x, y, w, h].iter().all(|v| v.is_finite()) || w < 1.0 || h < 1.0 {
            return Err(TrackingError::InvalidBox { x, y, w, h });
        }
        let inside =
            x >= -0.5 && y >= -0.5 && x + w <= width as f64 + 0.5 && y + h <= height as f64 + 0.5;
        if inside {
            Ok(())
        } else {
            Err(TrackingError::BoxOutsideFrame {
                x,
                y,
                w,
                h,
                width,
                height,
            })
        }
    }
}

impl From<[f64; 4]> for BoundingBox {
    fn from([x, y, w, h]: [f64; 4]) -> Self {
        Self { x, y, w, h }
    }
}
