//! Automatic model generation (section 2.3): where the view has room, propose image
//! regions that hold a distinctive pattern. A ceiling is mostly one material (tiles,
//! plaster) with a faint texture; lights, vents and signs stand out from its median
//! grey by far more than that texture does. The proposals are the bounding boxes of
//! the blobs of strong contrast that lie wholly inside the valid image (a blob that
//! touches the border is a pattern cut by it, or the walls beyond the ceiling, and is
//! dropped before anything merges with it), merged when their boxes come within a few
//! pixels, and clear of the regions already tracked.

use image::{GrayImage as Mask, Luma};
use imageproc::region_labelling::{Connectivity, connected_components};
use rperc_core::image::GrayImage;

use crate::error::{NavigationError, Result};

/// How regions are proposed.
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct ProposalParams {
    /// Least difference from the image's median grey that marks a pattern pixel.
    pub contrast: f64,
    /// Blobs whose boxes come within this many pixels merge into one region: a light's
    /// frame and its bars, an arrow and its plate.
    pub merge_gap: usize,
    /// Least blob area, pixels (smaller blobs carry too few contours to track).
    pub min_area: usize,
    /// Largest region, as a fraction of the image area.
    pub max_area_fraction: f64,
    /// Pixels added around a blob's bounding box, so that its contours are inside.
    pub margin: usize,
    /// A region must keep this far from the image border (pixels), so that a pattern
    /// cut by the border is not learnt.
    pub border: usize,
}

impl Default for ProposalParams {
    fn default() -> Self {
        Self {
            contrast: 45.0,
            merge_gap: 2,
            min_area: 30,
            max_area_fraction: 0.25,
            margin: 4,
            border: 6,
        }
    }
}

impl ProposalParams {
    /// Refuses bad values with the parameter's name.
    pub fn validate(&self) -> Result<()> {
        use rperc_core::{ensure_in_range, ensure_positive};
        ensure_positive("contrast", self.contrast)?;
        ensure_in_range("max_area_fraction", self.max_area_fraction, 0.0, 1.0)?;
        if self.min_area == 0 {
            return Err(NavigationError::InvalidParameter {
                name: "min_area",
                reason: "must be >= 1".into(),
            });
        }
        Ok(())
    }
}

/// Proposed regions `(x, y, w, h)` of `image` (an ideal image; pixels below 0 are
/// invalid, as [`crate::ceiling::correct_image`] fills them), largest first, none
/// overlapping a box of `taken` (the regions already tracked, `(x, y, w, h)` floats).
pub fn propose_regions(
    image: &GrayImage,
    taken: &[[f64; 4]],
    params: &ProposalParams,
) -> Result<Vec<[usize; 4]>> {
    params.validate()?;
    let (w, h) = (image.width, image.height);
    if w == 0 || h == 0 {
        return Ok(Vec::new());
    }
    let median = median_valid(image);
    let mut mask = Mask::new(w as u32, h as u32);
    for (k, &g) in image.data.iter().enumerate() {
        if g >= 0.0 && (f64::from(g) - median).abs() > params.contrast {
            mask.put_pixel((k % w) as u32, (k / w) as u32, Luma([255]));
        }
    }
    let labels = connected_components(&mask, Connectivity::Eight, Luma([0]));
    let inner = blob_boxes(&labels)
        .into_iter()
        .filter(|b| !b.touches(params.border, w, h))
        .collect();
    let merged = merge_near(inner, params.merge_gap);
    let max_area = params.max_area_fraction * (w * h) as f64;
    let mut out: Vec<([usize; 4], usize)> = merged
        .into_iter()
        .filter(|b| b.area >= params.min_area)
        .filter_map(|b| region(&b, params.margin, params.border, w, h).map(|r| (r, b.area)))
        .filter(|(r, _)| ((r[2] * r[3]) as f64) <= max_area)
        .filter(|(r, _)| valid_inside(image, r))
        .filter(|(r, _)| taken.iter().all(|t| !overlaps(r, t)))
        .collect();
    out.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    Ok(out.into_iter().map(|(r, _)| r).collect())
}

/// The median of the valid (non-negative) levels, or 0 if none.
fn median_valid(image: &GrayImage) -> f64 {
    let mut levels: Vec<f32> = image.data.iter().copied().filter(|g| *g >= 0.0).collect();
    if levels.is_empty() {
        return 0.0;
    }
    let mid = levels.len() / 2;
    let (_, m, _) = levels.select_nth_unstable_by(mid, f32::total_cmp);
    f64::from(*m)
}

/// A blob: the bounding box of its strong pixels and their count.
#[derive(Debug, Clone, Copy)]
struct Blob {
    x0: usize,
    y0: usize,
    x1: usize,
    y1: usize,
    area: usize,
}

impl Blob {
    fn touches(&self, border: usize, w: usize, h: usize) -> bool {
        self.x0 < border || self.y0 < border || self.x1 + border >= w || self.y1 + border >= h
    }

    /// Whether the boxes come within `gap` pixels of each other.
    fn near(&self, o: &Blob, gap: usize) -> bool {
        self.x0 <= o.x1 + gap + 1
            && o.x0 <= self.x1 + gap + 1
            && self.y0 <= o.y1 + gap + 1
            && o.y0 <= self.y1 + gap + 1
    }

    fn absorb(&mut self, o: &Blob) {
        self.x0 = self.x0.min(o.x0);
        self.y0 = self.y0.min(o.y0);
        self.x1 = self.x1.max(o.x1);
        self.y1 = self.y1.max(o.y1);
        self.area += o.area;
    }
}

/// One box per label (label 0 is the background).
fn blob_boxes(labels: &image::ImageBuffer<Luma<u32>, Vec<u32>>) -> Vec<Blob> {
    let mut blobs: Vec<Option<Blob>> = Vec::new();
    for (x, y, label) in labels.enumerate_pixels() {
        let l = label[0] as usize;
        if l == 0 {
            continue;
        }
        if blobs.len() <= l {
            blobs.resize_with(l + 1, || None);
        }
        let (x, y) = (x as usize, y as usize);
        let pixel = Blob {
            x0: x,
            y0: y,
            x1: x,
            y1: y,
            area: 1,
        };
        match &mut blobs[l] {
            Some(b) => b.absorb(&pixel),
            slot => *slot = Some(pixel),
        }
    }
    blobs.into_iter().flatten().collect()
}

/// Merges blobs whose boxes come within `gap`, until no two do (a handful of blobs per
/// image: the quadratic pass is nothing).
fn merge_near(mut blobs: Vec<Blob>, gap: usize) -> Vec<Blob> {
    let mut changed = true;
    while changed {
        changed = false;
        let mut k = 0;
        while k < blobs.len() {
            if let Some(j) = (k + 1..blobs.len()).find(|&j| blobs[k].near(&blobs[j], gap)) {
                let other = blobs.swap_remove(j);
                blobs[k].absorb(&other);
                changed = true;
            } else {
                k += 1;
            }
        }
    }
    blobs
}

/// The blob's box grown by `margin`, if it stays `border` pixels inside the image.
fn region(b: &Blob, margin: usize, border: usize, w: usize, h: usize) -> Option<[usize; 4]> {
    let x0 = b.x0.checked_sub(margin)?;
    let y0 = b.y0.checked_sub(margin)?;
    let (x1, y1) = (b.x1 + margin, b.y1 + margin);
    (x0 >= border && y0 >= border && x1 + border < w && y1 + border < h).then_some([
        x0,
        y0,
        x1 - x0 + 1,
        y1 - y0 + 1,
    ])
}

fn valid_inside(image: &GrayImage, r: &[usize; 4]) -> bool {
    (r[1]..r[1] + r[3]).all(|y| {
        let row = &image.data[y * image.width + r[0]..y * image.width + r[0] + r[2]];
        row.iter().all(|g| *g >= 0.0)
    })
}

fn overlaps(r: &[usize; 4], t: &[f64; 4]) -> bool {
    let (ax0, ay0) = (r[0] as f64, r[1] as f64);
    let (ax1, ay1) = (ax0 + r[2] as f64, ay0 + r[3] as f64);
    ax0 < t[0] + t[2] && t[0] < ax1 && ay0 < t[1] + t[3] && t[1] < ay1
}
