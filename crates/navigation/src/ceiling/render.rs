//! Images of the ceiling as the robot's camera takes them: the ceiling warped through
//! the pixel-to-ceiling homography, then optics and sensor effects (blur, lighting
//! gain and offset, an occasional occluder, Gaussian noise), each drawn from the
//! frame's own seeded stream so that any frame renders alone, identically.

use rand::Rng;
use rperc_core::Pose2;
use rperc_core::image::{GrayImage, grey_level};
use rperc_core::rng::{normal, stream};

use super::camera::{CeilingCamera, apply_homography};
use super::world::Ceiling;
use crate::error::Result;

/// The effects of one rendering.
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct RenderParams {
    /// Standard deviation of the additive noise, grey levels.
    pub noise: f64,
    /// Optical blur, pixels (standard deviation of a Gaussian).
    pub blur: f64,
    /// Lighting gain `a` of `g -> a g + b`, uniform in this range per frame.
    pub gain: [f64; 2],
    /// Lighting offset `b`, grey levels, uniform in this range per frame.
    pub offset: [f64; 2],
    /// Chance that a frame holds an occluder (a dark disc, as a cable or a person's
    /// head passing between camera and ceiling).
    pub occluder_probability: f64,
    /// The occluder's radius, as a fraction of the image height.
    pub occluder_radius: f64,
    /// Grey level seen beyond the ceiling's edge (the walls).
    pub outside_level: f64,
    /// Seed of every per-frame draw (frame `k` uses stream `k`).
    pub seed: u64,
}

impl Default for RenderParams {
    fn default() -> Self {
        Self {
            noise: 2.0,
            blur: 0.6,
            gain: [0.9, 1.1],
            offset: [-10.0, 10.0],
            occluder_probability: 0.0,
            occluder_radius: 0.15,
            outside_level: 60.0,
            seed: 0,
        }
    }
}

impl RenderParams {
    /// Refuses bad values with the parameter's name.
    pub fn validate(&self) -> Result<()> {
        use rperc_core::{ensure_in_range, ensure_non_negative, ensure_positive};
        ensure_non_negative("noise", self.noise)?;
        ensure_in_range("blur", self.blur, 0.0, 50.0)?;
        ensure_positive("gain", self.gain[0])?;
        ensure_in_range("gain", self.gain[1], self.gain[0], 100.0)?;
        ensure_in_range("offset", self.offset[0], -255.0, 255.0)?;
        ensure_in_range("offset", self.offset[1], self.offset[0], 255.0)?;
        ensure_in_range("occluder_probability", self.occluder_probability, 0.0, 1.0)?;
        ensure_in_range("occluder_radius", self.occluder_radius, 0.0, 1.0)?;
        ensure_in_range("outside_level", self.outside_level, 0.0, 255.0)?;
        Ok(())
    }
}

/// What a rendering drew at random: the truth of its effects.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct RenderTruth {
    /// The lighting `(gain, offset)`.
    pub lighting: [f64; 2],
    /// The occluder `(u, v, radius)` in pixels, if the frame has one.
    pub occluder: Option<[f64; 3]>,
}

/// Renders the camera's image at `pose` into `out` (8-bit grey, row-major, `width x
/// height` of the camera), drawing frame `frame`'s effects.
///
/// # Examples
/// ```
/// use rperc_core::Pose2;
/// use navigation::ceiling::{Ceiling, CeilingCamera, CeilingParams, RenderParams, render};
///
/// let ceiling = Ceiling::generate(&CeilingParams { size: [4.0, 3.0], resolution: 0.01,
///                                                  n_patterns: 2, min_spacing: 0.5,
///                                                  ..Default::default() }).unwrap();
/// let camera = CeilingCamera::default();
/// let mut image = Vec::new();
/// let truth = render(&ceiling, &camera, &Pose2::new(2.0, 1.5, 0.0), &RenderParams::default(),
///                    0, &mut image).unwrap();
/// assert_eq!(image.len(), camera.width * camera.height);
/// assert!(truth.occluder.is_none());
/// ```
pub fn render(
    ceiling: &Ceiling,
    camera: &CeilingCamera,
    pose: &Pose2,
    params: &RenderParams,
    frame: u64,
    out: &mut Vec<u8>,
) -> Result<RenderTruth> {
    camera.validate()?;
    params.validate()?;
    rperc_core::ensure_finite("pose", [pose.x, pose.y, pose.theta].iter())?;
    let mut rng = stream(params.seed, frame);
    let mut image = warp(ceiling, camera, pose, params.outside_level)?;
    if params.blur > 0.0 {
        let (mut scratch, mut blurred) = (GrayImage::default(), GrayImage::default());
        image.gaussian_blur(params.blur, &mut scratch, &mut blurred)?;
        image = blurred;
    }
    let gain = uniform(&mut rng, params.gain);
    let offset = uniform(&mut rng, params.offset);
    let occluder = (rng.random::<f64>() < params.occluder_probability).then(|| {
        let r = params.occluder_radius * camera.height as f64;
        [
            rng.random::<f64>() * camera.width as f64,
            rng.random::<f64>() * camera.height as f64,
            r,
        ]
    });
    out.clear();
    out.reserve(image.data.len());
    for (k, &g) in image.data.iter().enumerate() {
        let (u, v) = ((k % camera.width) as f64, (k / camera.width) as f64);
        let hidden = occluder.is_some_and(|[cu, cv, r]| (u - cu).hypot(v - cv) <= r);
        let level = if hidden {
            25.0
        } else {
            gain * f64::from(g) + offset
        };
        let noisy = level + params.noise * normal(&mut rng);
        out.push(grey_level(noisy));
    }
    Ok(RenderTruth {
        lighting: [gain, offset],
        occluder,
    })
}

fn uniform<R: Rng>(rng: &mut R, range: [f64; 2]) -> f64 {
    range[0] + (range[1] - range[0]) * rng.random::<f64>()
}

/// The noiseless image: each pixel's ceiling point by the homography, sampled
/// bilinearly from the pyramid level whose texel is the largest not above the pixel's
/// footprint; where a pixel still covers more than 1.5 of those texels it averages
/// 2x2 samples spread over its footprint, so the tile texture does not alias into
/// moire.
fn warp(
    ceiling: &Ceiling,
    camera: &CeilingCamera,
    pose: &Pose2,
    outside: f64,
) -> Result<GrayImage> {
    let footprint = camera.metres_per_pixel() / ceiling.resolution;
    let level = footprint.log2().floor().max(0.0) as usize;
    let (texture, texel) = ceiling.level(level);
    let scale = texel / ceiling.resolution;
    // World metres to this level's texel coordinates (see `Ceiling::level`).
    let half = 0.5 * (scale - 1.0) / scale;
    let h = camera.pixel_to_world(pose)?;
    let k = if footprint / scale > 1.5 { 2 } else { 1 };
    let step = 1.0 / k as f64;
    let mut image = GrayImage::zeros(camera.width, camera.height);
    for (n, px) in image.data.iter_mut().enumerate() {
        let (u, v) = ((n % camera.width) as f64, (n / camera.width) as f64);
        let mut sum = 0.0;
        for s in 0..k * k {
            let du = ((s % k) as f64 + 0.5) * step - 0.5;
            let dv = ((s / k) as f64 + 0.5) * step - 0.5;
            sum += apply_homography(&h, [u + du, v + dv])
                .and_then(|xy| texture.sample_bilinear(xy[0] / texel - half, xy[1] / texel - half))
                .unwrap_or(outside as f32);
        }
        *px = sum / (k * k) as f32;
    }
    Ok(image)
}

/// Renders frame `first_frame + k` at `poses[k]` for every `k`, in parallel (one frame
/// per task: a frame is milliseconds of work, far above rayon's overhead), into one
/// buffer of `poses.len()` images. Each frame draws from its own stream, so the result
/// is bit-identical to rendering the frames one by one, on any thread count.
pub fn render_sequence(
    ceiling: &Ceiling,
    camera: &CeilingCamera,
    poses: &[Pose2],
    params: &RenderParams,
    first_frame: u64,
) -> Result<(Vec<u8>, Vec<RenderTruth>)> {
    use rayon::prelude::*;
    camera.validate()?;
    let size = camera.width * camera.height;
    rperc_core::check_allocation("poses", poses.len() as u128, size as u128)?;
    let token = rperc_core::interrupt::current();
    let mut frames = vec![0u8; poses.len() * size];
    let truths = frames
        .par_chunks_mut(size.max(1))
        .zip(poses.par_iter())
        .enumerate()
        .map(|(k, (chunk, pose))| {
            rperc_core::interrupt::run_with(token.clone(), || {
                rperc_core::interrupt::checkpoint()?;
                let mut image = Vec::with_capacity(size);
                let truth = render(
                    ceiling,
                    camera,
                    pose,
                    params,
                    first_frame + k as u64,
                    &mut image,
                )?;
                chunk.copy_from_slice(&image);
                Ok(truth)
            })
        })
        .collect::<Result<Vec<_>>>()?;
    Ok((frames, truths))
}
