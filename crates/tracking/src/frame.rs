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

/// The smallest Canny threshold [`canny_edges`] uses: an edge strength of 0 is no
/// edge at all.
const MIN_CANNY_THRESHOLD: f32 = f32::MIN_POSITIVE;

/// Canny edges of `gray` with hysteresis thresholds `(low, high)`, `low <= high`, for
/// any thresholds a config may hold. imageproc's hysteresis walks the neighbours of
/// every pixel at least `low` strong without a bounds check, and the frame's border
/// (never a local maximum) has strength 0: a threshold of 0 walked off the image and
/// panicked (issue 38, the colour+shape tracker's `canny = [0, 50]`), so thresholds
/// are raised to the smallest positive strength, which keeps every real edge. Images
/// under 3 x 3 pixels have no interior, hence no edges.
pub(crate) fn canny_edges(gray: &image::GrayImage, low: f32, high: f32) -> image::GrayImage {
    let (w, h) = gray.dimensions();
    let (low, high) = (low.max(MIN_CANNY_THRESHOLD), high.max(MIN_CANNY_THRESHOLD));
    if w < 3 || h < 3 || low > high {
        return image::GrayImage::new(w, h);
    }
    imageproc::edges::canny(gray, low, high)
}

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

    /// The smallest box holding every point `[x, y]` (a contour's box).
    pub fn enclosing(points: &[[f64; 2]]) -> Self {
        let (mut x0, mut y0, mut x1, mut y1) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
        for p in points {
            x0 = x0.min(p[0]);
            y0 = y0.min(p[1]);
            x1 = x1.max(p[0]);
            y1 = y1.max(p[1]);
        }
        Self::new(x0, y0, (x1 - x0).max(0.0), (y1 - y0).max(0.0))
    }

    /// The part of the box inside a `width x height` frame (corners clamped to
    /// `[0, width] x [0, height]`); a box wholly outside becomes an empty box on the
    /// nearest edge.
    pub fn clipped_to(&self, width: usize, height: usize) -> Self {
        let (w, h) = (width as f64, height as f64);
        let x0 = self.x.clamp(0.0, w);
        let y0 = self.y.clamp(0.0, h);
        let x1 = (self.x + self.w).clamp(0.0, w);
        let y1 = (self.y + self.h).clamp(0.0, h);
        Self::new(x0, y0, (x1 - x0).max(0.0), (y1 - y0).max(0.0))
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A 40 x 30 grey image with a bright 12 x 10 rectangle at (14, 10).
    fn square() -> image::GrayImage {
        image::GrayImage::from_fn(40, 30, |x, y| {
            let inside = (14..26).contains(&x) && (10..20).contains(&y);
            image::Luma([if inside { 220 } else { 30 }])
        })
    }

    #[test]
    fn zero_thresholds_find_the_edges_instead_of_panicking() {
        // imageproc's own canny panics here (it followed the zero-strength border).
        for (low, high) in [(0.0, 50.0), (0.0, 0.0), (-5.0, 0.0)] {
            let edges = canny_edges(&square(), low, high);
            let on: Vec<(u32, u32)> = edges
                .enumerate_pixels()
                .filter(|p| p.2[0] > 0)
                .map(|p| (p.0, p.1))
                .collect();
            assert!(!on.is_empty(), "({low}, {high}) found no edge");
            // Every edge pixel is within the blur's reach (2 px) of the rectangle's
            // outline, which no zero-strength pixel is.
            let near_outline = |&(x, y): &(u32, u32)| {
                let (x, y) = (f64::from(x) + 0.5, f64::from(y) + 0.5);
                let dx = (x - 14.0).abs().min((x - 26.0).abs());
                let dy = (y - 10.0).abs().min((y - 20.0).abs());
                let in_x = (12.0..=28.0).contains(&x);
                let in_y = (8.0..=22.0).contains(&y);
                (dx <= 2.5 && in_y) || (dy <= 2.5 && in_x)
            };
            assert!(on.iter().all(near_outline), "({low}, {high}): {on:?}");
        }
    }

    #[test]
    fn tiny_images_have_no_edges() {
        for (w, h) in [(0, 0), (1, 5), (2, 2), (5, 2)] {
            let e = canny_edges(&image::GrayImage::new(w, h), 0.0, 0.0);
            assert_eq!(e.dimensions(), (w, h));
        }
    }

    /// Clipping against brute force: on integer boxes the clipped box covers exactly the
    /// unit cells of the frame that the box covers.
    #[test]
    fn clipped_box_covers_the_frame_cells_the_box_covers() {
        let (width, height) = (7usize, 5usize);
        for x in -9..9 {
            for w in 0..12 {
                for (y, h) in [(-3, 4), (1, 2), (3, 6), (6, 2), (-8, 3)] {
                    let b = BoundingBox::new(x as f64, y as f64, w as f64, h as f64);
                    let c = b.clipped_to(width, height);
                    let inside = |cx: f64, cy: f64, r: &BoundingBox| {
                        cx > r.x && cx < r.x + r.w && cy > r.y && cy < r.y + r.h
                    };
                    for cy in 0..height {
                        for cx in 0..width {
                            let (px, py) = (cx as f64 + 0.5, cy as f64 + 0.5);
                            assert_eq!(inside(px, py, &b), inside(px, py, &c), "{b:?} {c:?}");
                        }
                    }
                    assert!(
                        c.x >= 0.0 && c.y >= 0.0 && c.w >= 0.0 && c.h >= 0.0,
                        "{c:?}"
                    );
                    assert!(
                        c.x + c.w <= width as f64 && c.y + c.h <= height as f64,
                        "{c:?}"
                    );
                }
            }
        }
    }
}
