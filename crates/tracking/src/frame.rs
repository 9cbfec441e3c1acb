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
pub type RgbFrame<'a> = rperc_core::image::RgbView<'a>;

/// Views an [`image::RgbImage`] as a frame.
///
/// # Errors
/// An empty image.
pub fn frame_from_image(image: &image::RgbImage) -> Result<RgbFrame<'_>> {
    Ok(RgbFrame::new(
        image.as_raw(),
        image.width() as usize,
        image.height() as usize,
    )?)
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
