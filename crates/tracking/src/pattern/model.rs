//! The pattern model `M = {(U(j), V(j), W(j))}` of eq. 4, built from a region of an
//! image (section 3.2).

use super::contour::{approximate, sample_polyline, simplifier, trace_contours};
use super::correlation::{autocorrelation_slope, remove_mean};
use crate::error::{Result, TrackingError};
use nalgebra::Point2;
use rperc_core::image::{GrayImage, grey_level};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Smallest accepted window side, pixels.
pub const MIN_REGION_SIDE: usize = 8;

/// The window of interest the pattern is learnt from.
#[derive(Debug, Clone, PartialEq)]
pub enum Region {
    /// A box `(x, y, w, h)` in 0-based pixels: columns `x..x+w`, rows `y..y+h`.
    Box {
        /// Left column.
        x: usize,
        /// Top row.
        y: usize,
        /// Width.
        w: usize,
        /// Height.
        h: usize,
    },
    /// A boolean mask the size of the image (row-major); the window is its bounding box
    /// and only edges under the mask become model points.
    Mask(Vec<bool>),
}

/// Parameters of model building and of the observation model.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
// `PatternConfig` is the Python name of the whole tracker's config.
#[schemars(rename = "PatternModelConfig")]
pub struct PatternConfig {
    /// Canny hysteresis thresholds on imageproc's Sobel magnitude scale.
    pub canny_low: f32,
    /// See `canny_low`.
    pub canny_high: f32,
    /// Douglas-Peucker tolerance of the contour approximation, pixels.
    pub approximation_epsilon: f64,
    /// Contours shorter than this many edge pixels are dropped.
    pub min_contour_pixels: usize,
    /// Arc length between model points along the approximated contours, pixels.
    pub point_spacing: f64,
    /// `N_s`, grey-level samples per vector.
    pub n_samples: usize,
    /// `delta`, the step between samples, pixels.
    pub delta: f64,
    /// Gaussian blur (sigma, pixels) of the image the gradient and the vectors are
    /// sampled from; the scale space blurs a frame by `blur_sigma * s`.
    pub blur_sigma: f64,
    /// Lags `1..=fit_lags` the auto-correlation slope is fitted on.
    pub fit_lags: usize,
    /// Points whose profile has a standard deviation below this (grey levels) are
    /// textureless and rejected.
    pub min_contrast: f64,
    /// Points whose auto-correlation slope `|W|` is below this are rejected (flat
    /// auto-correlation: the profile cannot locate the contour).
    pub min_slope: f64,
    /// At most this many model points are kept (evenly spread along the contours).
    pub max_points: usize,
    /// The approximation `C~` of the auto-correlation whose inverse turns an
    /// inter-correlation into the deviation `lambda` (section 3.3). Default
    /// [`DeviationModel::Parabola`].
    pub deviation: DeviationModel,
    /// `sigma` of the Gaussian `Omega_sigma(lambda)`, samples.
    pub sigma: f64,
    /// A point whose deviation `lambda` exceeds this (samples) is occluded.
    pub occlusion_threshold: f64,
    /// The largest fraction of points left out as occluded.
    pub max_occluded_fraction: f64,
    /// Scales of the scale-space levels (each >= 1, increasing).
    pub scale_levels: Vec<f64>,
}

/// The function `C~` approximating a model point's auto-correlation near its peak
/// (section 3.2, `W(j)`), inverted to read the deviation `lambda = C~^-1(C)` from an
/// inter-correlation `C` (section 3.3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum DeviationModel {
    /// The seed's straight line `1 + W lambda`, `W` the slope:
    /// [`super::correlation::deviation`].
    Line,
    /// The parabola `1 - a lambda^2`: [`super::correlation::deviation_parabolic`].
    /// Profiles of blurred images correlate as `1 - C ~ d^2` a sub-sample `d` off, so
    /// this keeps `lambda` proportional to the offset where the line makes it grow as
    /// `d^2` (see [`super::correlation::autocorrelation_curvature`]).
    #[default]
    Parabola,
}

impl std::str::FromStr for DeviationModel {
    type Err = TrackingError;

    fn from_str(s: &str) -> Result<Self> {
        match s {
            "line" => Ok(Self::Line),
            "parabola" => Ok(Self::Parabola),
            other => Err(invalid(
                "deviation",
                format!("unknown model {other:?}: expected \"line\" or \"parabola\""),
            )),
        }
    }
}

impl Default for PatternConfig {
    fn default() -> Self {
        Self {
            canny_low: 30.0,
            canny_high: 60.0,
            approximation_epsilon: 0.7,
            min_contour_pixels: 6,
            point_spacing: 4.0,
            n_samples: 12,
            delta: 1.0,
            blur_sigma: 1.0,
            fit_lags: 2,
            min_contrast: 3.0,
            min_slope: 0.02,
            max_points: 200,
            deviation: DeviationModel::Parabola,
            sigma: 1.0,
            occlusion_threshold: 1.5,
            max_occluded_fraction: 0.4,
            scale_levels: vec![1.0, 1.25, 1.5, 1.75, 2.0, 2.5, 3.0],
        }
    }
}

/// The most model points kept: each is weighed for every particle on every frame.
const MAX_MODEL_POINTS: usize = 1 << 16;
/// The most scale levels: each blurs its own copy of the frame's window.
const MAX_SCALE_LEVELS: usize = 64;
/// The largest scale level: its blur kernel (`blur_sigma` times the scale) spans
/// thousands of taps there already; a scale of 1e300 asked for an endless kernel.
const MAX_SCALE: f64 = 100.0;
/// The closest spacing of model points along a contour, pixels.
const MIN_POINT_SPACING: f64 = 0.1;

fn invalid(name: &'static str, reason: impl Into<String>) -> TrackingError {
    TrackingError::InvalidParameter {
        name,
        reason: reason.into(),
    }
}

impl PatternConfig {
    /// Checks every parameter; errors name the offending one.
    pub fn validate(&self) -> Result<()> {
        use rperc_core::{ensure_in_range, ensure_positive};
        // Points closer than a tenth of a pixel sample the same grey levels, and each
        // costs a profile: 1e-9 px asked for 10^9 points per pixel of contour (issue 38).
        ensure_in_range("point_spacing", self.point_spacing, MIN_POINT_SPACING, 1e6)?;
        ensure_positive("delta", self.delta)?;
        ensure_positive("sigma", self.sigma)?;
        ensure_positive("occlusion_threshold", self.occlusion_threshold)?;
        ensure_positive("approximation_epsilon", self.approximation_epsilon)?;
        ensure_in_range("blur_sigma", self.blur_sigma, 0.0, 50.0)?;
        ensure_in_range(
            "max_occluded_fraction",
            self.max_occluded_fraction,
            0.0,
            1.0,
        )?;
        ensure_in_range("min_contrast", self.min_contrast, 0.0, f64::MAX)?;
        ensure_in_range("min_slope", self.min_slope, 0.0, f64::MAX)?;
        let (lo, hi) = (f64::from(self.canny_low), f64::from(self.canny_high));
        ensure_in_range("canny_high", hi, 0.0, f64::MAX)?;
        // imageproc's Canny asserts low <= high: refuse it here instead of panicking.
        ensure_in_range("canny_low", lo, 0.0, hi)?;
        if !(3..=1024).contains(&self.n_samples) {
            return Err(invalid("n_samples", "must be in 3..=1024"));
        }
        if self.fit_lags == 0 || self.fit_lags >= self.n_samples {
            return Err(invalid("fit_lags", "must be in 1..n_samples"));
        }
        // Model sizes are bounded before anything is learnt: each model point keeps a
        // vector of n_samples, and each scale level a blurred copy of the frame.
        rperc_core::ensure_count("max_points", self.max_points, 1, MAX_MODEL_POINTS, 1)?;
        let levels = &self.scale_levels;
        rperc_core::ensure_count("scale_levels", levels.len(), 1, MAX_SCALE_LEVELS, 1)?;
        if levels.is_empty()
            || levels[0] != 1.0
            || levels
                .windows(2)
                .any(|w| w[1].partial_cmp(&w[0]) != Some(std::cmp::Ordering::Greater))
        {
            return Err(invalid("scale_levels", "must start at 1.0 and increase"));
        }
        if levels.last().is_some_and(|&s| s > MAX_SCALE) {
            return Err(invalid(
                "scale_levels",
                format!("the largest scale must be at most {MAX_SCALE}"),
            ));
        }
        Ok(())
    }
}

/// One model point: `U(j) = (x, y, phi)`, `V(j)` and `W(j)` of eq. 4.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
pub struct ModelPoint {
    /// `x(j) = (u - x_c) / Delta_x`, normalised in the window.
    pub x: f64,
    /// `y(j) = (v - y_c) / Delta_y`.
    pub y: f64,
    /// `phi(j)`, the gradient orientation (radians, image axes: x right, y down).
    pub phi: f64,
    /// The grey-level vector, mean removed (see [`super::correlation`]).
    pub vector: Vec<f32>,
    /// The slope of the linear approximation of the auto-correlation (`< 0`).
    pub slope: f64,
}

/// A learnt pattern: its window and model points (serialisable, so that a mosaic
/// stores its models as learnt).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
pub struct PatternModel {
    /// Window centre `(x_c, y_c)`, pixels.
    pub centre: [f64; 2],
    /// Window size `(Delta_x, Delta_y)`, pixels.
    pub size: [f64; 2],
    /// The model points.
    pub points: Vec<ModelPoint>,
    /// The configuration the model was built with (also used for observation).
    pub config: PatternConfig,
}

/// The window `(x0, y0, w, h)` of a region, validated against the image.
fn window(image: &GrayImage, region: &Region) -> Result<(usize, usize, usize, usize)> {
    let (iw, ih) = (image.width, image.height);
    let (x, y, w, h) = match region {
        Region::Box { x, y, w, h } => (*x, *y, *w, *h),
        Region::Mask(mask) => {
            if mask.len() != iw * ih {
                return Err(invalid(
                    "region",
                    format!("mask has {} cells, image {iw}x{ih}", mask.len()),
                ));
            }
            let on = || {
                mask.iter()
                    .enumerate()
                    .filter(|(_, m)| **m)
                    .map(|(i, _)| (i % iw, i / iw))
            };
            let (Some(x0), Some(y0)) = (on().map(|p| p.0).min(), on().map(|p| p.1).min()) else {
                return Err(invalid("region", "mask selects no pixel"));
            };
            let x1 = on().map(|p| p.0).max().unwrap_or(x0);
            let y1 = on().map(|p| p.1).max().unwrap_or(y0);
            (x0, y0, x1 - x0 + 1, y1 - y0 + 1)
        }
    };
    if w < MIN_REGION_SIDE || h < MIN_REGION_SIDE {
        return Err(invalid(
            "region",
            format!("{w}x{h} is smaller than {MIN_REGION_SIDE}x{MIN_REGION_SIDE}"),
        ));
    }
    if x.checked_add(w).is_none_or(|e| e > iw) || y.checked_add(h).is_none_or(|e| e > ih) {
        return Err(invalid(
            "region",
            format!("box ({x}, {y}, {w}, {h}) is not inside the {iw}x{ih} image"),
        ));
    }
    Ok((x, y, w, h))
}

/// Canny edges (imageproc) of the image, restricted to the region.
fn region_edges(
    image: &GrayImage,
    region: &Region,
    win: (usize, usize, usize, usize),
    config: &PatternConfig,
) -> Vec<bool> {
    let bytes: Vec<u8> = image
        .data
        .iter()
        .map(|&g| grey_level(f64::from(g)))
        .collect();
    let Some(buffer) = image::GrayImage::from_raw(image.width as u32, image.height as u32, bytes)
    else {
        return vec![false; image.data.len()];
    };
    let edges = crate::frame::canny_edges(&buffer, config.canny_low, config.canny_high);
    let (x0, y0, w, h) = win;
    let iw = image.width;
    (0..image.data.len())
        .map(|i| {
            let (x, y) = (i % iw, i / iw);
            let inside = x >= x0 && x < x0 + w && y >= y0 && y < y0 + h;
            let masked = match region {
                Region::Mask(m) => m[i],
                Region::Box { .. } => true,
            };
            inside && masked && edges.as_raw()[i] > 0
        })
        .collect()
}

/// Gradient orientation at `(x, y)` by central differences of bilinear samples.
fn gradient_orientation(blurred: &GrayImage, p: Point2<f64>) -> Option<f64> {
    let gx = f64::from(blurred.sample_bilinear(p.x + 1.0, p.y)?)
        - f64::from(blurred.sample_bilinear(p.x - 1.0, p.y)?);
    let gy = f64::from(blurred.sample_bilinear(p.x, p.y + 1.0)?)
        - f64::from(blurred.sample_bilinear(p.x, p.y - 1.0)?);
    (gx.hypot(gy) > 1e-6).then(|| gy.atan2(gx))
}

/// Fills `out` with the grey-level vector at `p` along direction `phi`: `N_s` bilinear
/// samples `step` apart, centred on `p`. `false` if a sample leaves the image.
pub fn sample_vector(image: &GrayImage, p: [f64; 2], phi: f64, step: f64, out: &mut [f32]) -> bool {
    let (s, c) = phi.sin_cos();
    sample_along(image, p, [c, s], step, out)
}

/// [`sample_vector`] with the direction given by its unit vector `(cos phi, sin phi)`
/// (the observation model rotates it without an angle).
#[inline]
pub(crate) fn sample_along(
    image: &GrayImage,
    p: [f64; 2],
    direction: [f64; 2],
    step: f64,
    out: &mut [f32],
) -> bool {
    let (start, delta) = segment(p, direction, step, out.len());
    image.sample_line(start, delta, out)
}

/// The first sample and the step between samples of `n` samples `step` apart along
/// `direction`, centred on `p`.
#[inline]
pub(crate) fn segment(
    p: [f64; 2],
    direction: [f64; 2],
    step: f64,
    n: usize,
) -> ([f64; 2], [f64; 2]) {
    let half = 0.5 * (n as f64 - 1.0);
    let (dx, dy) = (step * direction[0], step * direction[1]);
    ([p[0] - half * dx, p[1] - half * dy], [dx, dy])
}

impl PatternModel {
    /// Learns the pattern inside `region` of `image` (section 3.2): Canny edges, chained
    /// into contours, approximated by Douglas-Peucker, sampled every `point_spacing`;
    /// at each sample the gradient orientation and the grey-level vector along it, and
    /// the slope of its auto-correlation; textureless points are rejected.
    pub fn from_region(
        image: &GrayImage,
        region: Region,
        config: &PatternConfig,
    ) -> Result<PatternModel> {
        config.validate()?;
        if image.data.len() != image.width * image.height || image.data.is_empty() {
            return Err(invalid("image", "empty or inconsistent size"));
        }
        if !image.data.iter().all(|g| g.is_finite()) {
            return Err(invalid("image", "contains NaN or infinite grey levels"));
        }
        let win = window(image, &region)?;
        let (mut scratch, mut blurred) = (GrayImage::default(), GrayImage::default());
        image.gaussian_blur(config.blur_sigma, &mut scratch, &mut blurred)?;
        let edges = region_edges(image, &region, win, config);
        let candidates = contour_samples(&edges, image.width, image.height, config)?;
        let centre = [
            win.0 as f64 + 0.5 * (win.2 as f64 - 1.0),
            win.1 as f64 + 0.5 * (win.3 as f64 - 1.0),
        ];
        let size = [win.2 as f64, win.3 as f64];
        let mut points: Vec<ModelPoint> = candidates
            .iter()
            .filter_map(|&p| model_point(&blurred, p, centre, size, config))
            .collect();
        if points.is_empty() {
            return Err(invalid(
                "region",
                "no textured contour point: the region has no usable edges",
            ));
        }
        spread(&mut points, config.max_points);
        Ok(PatternModel {
            centre,
            size,
            points,
            config: config.clone(),
        })
    }

    /// The largest distance of a model point from the window centre, pixels.
    pub fn radius(&self) -> f64 {
        (0..self.points.len())
            .map(|j| {
                let o = self.offset(j);
                o[0].hypot(o[1])
            })
            .fold(0.0, f64::max)
    }

    /// Pixel offset of model point `j` from the window centre.
    pub fn offset(&self, j: usize) -> [f64; 2] {
        let p = &self.points[j];
        [p.x * self.size[0], p.y * self.size[1]]
    }
}

/// Candidate model point positions: every contour's approximation, sampled.
fn contour_samples(
    edges: &[bool],
    width: usize,
    height: usize,
    config: &PatternConfig,
) -> Result<Vec<Point2<f64>>> {
    let mut dp = simplifier();
    let mut out = Vec::new();
    for c in trace_contours(edges, width, height) {
        if c.len() >= config.min_contour_pixels {
            let approximated = approximate(&mut dp, &c, config.approximation_epsilon);
            out.extend(sample_polyline(&approximated, config.point_spacing)?);
        }
    }
    Ok(out)
}

/// A model point at `p`, or `None` if its profile is textureless or leaves the image.
fn model_point(
    blurred: &GrayImage,
    p: Point2<f64>,
    centre: [f64; 2],
    size: [f64; 2],
    config: &PatternConfig,
) -> Option<ModelPoint> {
    let phi = gradient_orientation(blurred, p)?;
    let mut vector = vec![0.0; config.n_samples];
    if !sample_vector(blurred, [p.x, p.y], phi, config.delta, &mut vector) {
        return None;
    }
    let contrast = remove_mean(&mut vector);
    let slope = autocorrelation_slope(&vector, config.fit_lags);
    (contrast >= config.min_contrast && slope.abs() >= config.min_slope).then(|| ModelPoint {
        x: (p.x - centre[0]) / size[0],
        y: (p.y - centre[1]) / size[1],
        phi,
        vector,
        slope,
    })
}

/// Keeps at most `max` points, evenly spaced in contour order.
fn spread(points: &mut Vec<ModelPoint>, max: usize) {
    let n = points.len();
    if n <= max {
        return;
    }
    let kept: Vec<ModelPoint> = (0..max).map(|k| points[k * n / max].clone()).collect();
    *points = kept;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_parameters_are_named() {
        let cases: [(&str, PatternConfig); 6] = [
            (
                "canny_low",
                PatternConfig {
                    canny_low: 70.0,
                    ..PatternConfig::default()
                },
            ),
            (
                "canny_high",
                PatternConfig {
                    canny_high: f32::NAN,
                    ..PatternConfig::default()
                },
            ),
            (
                "n_samples",
                PatternConfig {
                    n_samples: 2,
                    ..PatternConfig::default()
                },
            ),
            (
                "fit_lags",
                PatternConfig {
                    fit_lags: 0,
                    ..PatternConfig::default()
                },
            ),
            (
                "scale_levels",
                PatternConfig {
                    scale_levels: vec![1.0, 0.9],
                    ..PatternConfig::default()
                },
            ),
            (
                "max_occluded_fraction",
                PatternConfig {
                    max_occluded_fraction: 1.5,
                    ..PatternConfig::default()
                },
            ),
        ];
        for (name, config) in cases {
            assert_eq!(
                config.validate().unwrap_err().parameter(),
                Some(name),
                "{name}"
            );
        }
        assert!(PatternConfig::default().validate().is_ok());
    }

    #[test]
    fn deviation_models_parse_by_name() {
        assert_eq!(
            "line".parse::<DeviationModel>().unwrap(),
            DeviationModel::Line
        );
        assert_eq!(
            "parabola".parse::<DeviationModel>().unwrap(),
            DeviationModel::Parabola
        );
        let err = "cubic".parse::<DeviationModel>().unwrap_err();
        assert_eq!(err.parameter(), Some("deviation"));
    }
}
