//! The reference colour cloud `C_0`: the colours of the target's pixels, less those
//! that are at least as frequent in the ring of background around it.

use image::GrayImage;

use super::params::ColorShapeParams;
use super::segment::Roi;
use super::snake::fill_polygon;
use super::state::{ColourDistribution, State, colour_coords};
use crate::error::{Result, TrackingError};
use crate::frame::{BoundingBox, RgbFrame};

/// The colour distribution `C_t` the refined contour `r_t` encloses: the measured
/// counterpart of the filter's state, relative to `reference`. `None` when the
/// contour encloses no pixel.
pub fn measured_state(
    frame: &RgbFrame<'_>,
    contour: &[[f64; 2]],
    reference: &ColourDistribution,
    p: &ColorShapeParams,
) -> Option<State> {
    let b = BoundingBox::enclosing(contour);
    let (w, h) = (frame.width(), frame.height());
    let roi = Roi::clipped(b.x, b.y, b.x + b.w + 1.0, b.y + b.h + 1.0, w, h);
    if roi.width == 0 || roi.height == 0 {
        return None; // off the frame: no pixel to measure
    }
    let mut mask = GrayImage::new(roi.width.max(1) as u32, roi.height.max(1) as u32);
    fill_polygon(contour, roi.x0 as f64, roi.y0 as f64, &mut mask);
    let stride = (mask.iter().filter(|m| **m != 0).count()).div_ceil(4 * p.cloud_points);
    let colours: Vec<[f64; 3]> = mask
        .enumerate_pixels()
        .filter(|(_, _, m)| m[0] != 0)
        .step_by(stride.max(1))
        .filter_map(|(u, v, _)| {
            let px = &frame.row(roi.y0 + v as usize)[3 * (roi.x0 + u as usize)..][..3];
            colour_coords(p.color_space, [px[0], px[1], px[2]]).ok()
        })
        .collect();
    let d = ColourDistribution::from_points(&colours, p.min_spread()).ok()?;
    Some(d.state_relative_to(reference))
}

/// Colour coordinates of the target's pixels inside `contour`, thinned by a fixed stride
/// to at most `cloud_points`.
///
/// A contour drawn by a user, or the ellipse inscribed in a box, takes in some
/// background; the seed's segmentation `H(n) > 0` would then segment that background
/// too. So a pixel is kept only when its colour bin is more frequent (as a fraction)
/// inside the contour than in the ring around it: the contour's box grown by
/// `background_ring` of its size on every side, less the contour. If that leaves under
/// a fifth of the pixels (a target the colour of its surroundings), all are kept.
///
/// # Errors
/// [`TrackingError::InvalidParameter`] when the contour encloses no pixel of the frame.
pub fn target_colours(
    frame: &RgbFrame<'_>,
    contour: &[[f64; 2]],
    p: &ColorShapeParams,
) -> Result<Vec<[f64; 3]>> {
    let b = BoundingBox::enclosing(contour);
    let (gx, gy) = (p.background_ring * b.w, p.background_ring * b.h);
    let (w, h) = (frame.width(), frame.height());
    let roi = Roi::clipped(
        b.x - gx,
        b.y - gy,
        b.x + b.w + gx + 1.0,
        b.y + b.h + gy + 1.0,
        w,
        h,
    );
    if roi.width == 0 || roi.height == 0 {
        return Err(no_pixel());
    }
    let mut mask = GrayImage::new(roi.width as u32, roi.height as u32);
    fill_polygon(contour, roi.x0 as f64, roi.y0 as f64, &mut mask);
    let n_bins: usize = p.bins.iter().product();
    let (mut inside, mut ring) = (vec![0u32; n_bins], vec![0u32; n_bins]);
    let mut pixels = Vec::new();
    for (u, v, m) in mask.enumerate_pixels() {
        let (x, y) = (roi.x0 + u as usize, roi.y0 + v as usize);
        let px = &frame.row(y)[3 * x..][..3];
        let bin = p.color_space.bin([px[0], px[1], px[2]], p.bins);
        if m[0] != 0 {
            inside[bin] += 1;
            pixels.push((bin, [px[0], px[1], px[2]]));
        } else {
            ring[bin] += 1;
        }
    }
    if pixels.is_empty() {
        return Err(no_pixel());
    }
    let (n_in, n_ring) = (pixels.len() as u64, u64::from(ring.iter().sum::<u32>()));
    // inside / n_in > ring / n_ring, in integers.
    let typical = |bin: usize| u64::from(inside[bin]) * n_ring > u64::from(ring[bin]) * n_in;
    let kept = pixels.iter().filter(|(bin, _)| typical(*bin)).count();
    let keep_all = n_ring == 0 || 5 * kept < pixels.len();
    let chosen: Vec<[u8; 3]> = pixels
        .iter()
        .filter(|(bin, _)| keep_all || typical(*bin))
        .map(|(_, c)| *c)
        .collect();
    let stride = chosen.len().div_ceil(p.cloud_points);
    chosen
        .into_iter()
        .step_by(stride)
        .map(|c| colour_coords(p.color_space, c))
        .collect()
}

fn no_pixel() -> TrackingError {
    TrackingError::InvalidParameter {
        name: "contour",
        reason: "encloses no pixel of the frame".into(),
    }
}
