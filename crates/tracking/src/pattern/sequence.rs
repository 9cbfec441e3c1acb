//! A seeded sequence generator for the evaluation of section 4.1 (Fig. 8): a patch
//! moved along a known `(x, y, theta, s)` trajectory over a moving cluttered
//! background, with per-frame displacements swept up to a few `sigma`, partial
//! occlusion, gain/offset illumination changes and noise.

use rand::Rng;
use rperc_core::image::{GrayImage, grey_level};
use rperc_core::rng::{normal, seeded};

use crate::error::{Result, TrackingError};

/// How a sequence is generated.
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct SequenceParams {
    /// Frames, the first one at the identity pose included.
    pub n_frames: usize,
    /// Frame width, pixels.
    pub width: usize,
    /// Frame height, pixels.
    pub height: usize,
    /// The tracker's `sigma_v` (pixels, pixels, radians, scale): steps are drawn in its
    /// units. Default section 4.1's `(5, 5, 3 deg, 0.1)`.
    pub sigma: [f64; 4],
    /// Frame `k`'s step sweeps one component, `(k - 1) mod 4` (x, y, theta, s in
    /// turn), uniform in `[-K sigma, K sigma]` with this `K` (Fig. 8 sweeps to about 4),
    /// as Fig. 8 plots each component against its own truth.
    pub max_step_sigmas: f64,
    /// The other components step uniformly in `[-k sigma, k sigma]` with this `k`.
    pub other_step_sigmas: f64,
    /// Largest fraction of the patch hidden by an occluder (uniform per frame, from
    /// 0); the occluder is a band of background clutter over one side of the patch.
    pub max_occlusion: f64,
    /// Gain `a` of the illumination change `g -> a g + b`, uniform in this range.
    pub gain: [f64; 2],
    /// Offset `b`, uniform in this range (grey levels).
    pub offset: [f64; 2],
    /// Standard deviation of the additive Gaussian noise, grey levels.
    pub noise: f64,
    /// Background motion, pixels per frame (a random direction per sequence).
    pub background_speed: f64,
    /// The scale stays in this range (a step that would leave it is reflected).
    pub scale_range: [f64; 2],
    /// Seed of every random draw.
    pub seed: u64,
}

impl Default for SequenceParams {
    fn default() -> Self {
        Self {
            n_frames: 60,
            width: 640,
            height: 480,
            sigma: [5.0, 5.0, 3f64.to_radians(), 0.1],
            max_step_sigmas: 4.0,
            other_step_sigmas: 0.5,
            max_occlusion: 0.0,
            gain: [1.0, 1.0],
            offset: [0.0, 0.0],
            noise: 2.0,
            background_speed: 2.0,
            scale_range: [0.7, 1.5],
            seed: 0,
        }
    }
}

/// A generated sequence and its ground truth.
#[derive(Debug, Clone, PartialEq)]
pub struct PatternSequence {
    /// `n_frames` grey frames, each `height x width`, concatenated row-major.
    pub frames: Vec<u8>,
    /// The true state `(x, y, theta, s)` of each frame (the tracker's convention).
    pub truth: Vec<[f64; 4]>,
    /// The fraction of the patch hidden in each frame.
    pub occlusion: Vec<f64>,
    /// The `(gain, offset)` of each frame.
    pub illumination: Vec<[f64; 2]>,
    /// The region `(x, y, w, h)` the patch fills exactly in frame 0.
    pub region: [usize; 4],
}

fn invalid(name: &'static str, reason: impl Into<String>) -> TrackingError {
    TrackingError::InvalidParameter {
        name,
        reason: reason.into(),
    }
}

impl SequenceParams {
    /// Refuses bad values with the parameter's name.
    pub fn validate(&self) -> Result<()> {
        use rperc_core::{ensure_in_range, ensure_non_negative, ensure_positive};
        if self.n_frames == 0 {
            return Err(invalid("n_frames", "must be >= 1"));
        }
        if self.width < 8 || self.height < 8 {
            return Err(invalid("width", "frames must be at least 8x8"));
        }
        // In u128 and saturating: width * height in usize wrapped (or panicked) for
        // 2^32 x 2^32 frames and passed the check (issue 38).
        let frame_bytes = (self.width as u128).saturating_mul(self.height as u128);
        rperc_core::check_allocation("n_frames", self.n_frames as u128, frame_bytes)?;
        if !self.sigma.iter().all(|s| s.is_finite() && *s >= 0.0) {
            return Err(invalid("sigma", "must be 4 finite values >= 0"));
        }
        ensure_non_negative("max_step_sigmas", self.max_step_sigmas)?;
        ensure_non_negative("other_step_sigmas", self.other_step_sigmas)?;
        ensure_in_range("max_occlusion", self.max_occlusion, 0.0, 1.0)?;
        ensure_non_negative("noise", self.noise)?;
        ensure_non_negative("background_speed", self.background_speed)?;
        ensure_positive("gain", self.gain[0])?;
        ensure_in_range("gain", self.gain[1], self.gain[0], f64::MAX)?;
        ensure_in_range("offset", self.offset[0], -255.0, 255.0)?;
        ensure_in_range("offset", self.offset[1], self.offset[0], 255.0)?;
        ensure_positive("scale_range", self.scale_range[0])?;
        ensure_in_range(
            "scale_range",
            self.scale_range[1],
            self.scale_range[0],
            10.0,
        )?;
        Ok(())
    }
}

/// Checks a patch and background: finite, non-empty, the patch inside the frame.
fn check_images(patch: &GrayImage, background: &GrayImage, params: &SequenceParams) -> Result<()> {
    for (name, img) in [("patch", patch), ("background", background)] {
        if img.data.is_empty() || img.data.len() != img.width * img.height {
            return Err(invalid(name, "empty or inconsistent size"));
        }
        if !img.data.iter().all(|g| g.is_finite()) {
            return Err(invalid(name, "contains NaN or infinite grey levels"));
        }
    }
    if patch.width < 8 || patch.height < 8 {
        return Err(invalid("patch", "must be at least 8x8"));
    }
    if patch.width >= params.width || patch.height >= params.height {
        return Err(invalid("patch", "must be smaller than the frame"));
    }
    Ok(())
}

/// One frame's draws: the state, the hidden side and fraction, the illumination.
struct FrameDraw {
    state: [f64; 4],
    occlusion: f64,
    side: usize,
    gain: f64,
    offset: f64,
    shift: [f64; 2],
}

/// The next state: component `swept` stepped by `u K sigma`, the others by `u k sigma`,
/// `u` uniform in [-1, 1] (see [`SequenceParams`]); a step that would take the centre within `margin` of the frame's edge, or the scale
/// out of its range, is reflected (its sign flipped).
fn next_state<R: Rng>(
    rng: &mut R,
    state: [f64; 4],
    params: &SequenceParams,
    margin: f64,
    swept: usize,
) -> [f64; 4] {
    let limits = [
        [margin, params.width as f64 - 1.0 - margin],
        [margin, params.height as f64 - 1.0 - margin],
        [f64::NEG_INFINITY, f64::INFINITY],
        params.scale_range,
    ];
    let mut next = state;
    for d in 0..4 {
        let k = if d == swept {
            params.max_step_sigmas
        } else {
            params.other_step_sigmas
        };
        let step = rng.random_range(-1.0..=1.0) * k * params.sigma[d];
        let [lo, hi] = limits[d];
        next[d] = if (lo..=hi).contains(&(state[d] + step)) {
            state[d] + step
        } else {
            (state[d] - step).clamp(lo, hi)
        };
    }
    next
}

/// Generates the sequence (section 4.1): frame 0 shows `patch` at the identity pose,
/// centred; each later frame moves it by a random step (see [`SequenceParams`]).
/// Frame pixel `u` shows patch point `c + R(theta)^T (u - t) / s`, the inverse of the
/// tracker's `t + s R(theta) (p - c)`, `c` the patch centre, bilinearly interpolated
/// inside the patch's pixel area (see `footprint`); elsewhere the background, shifted by the background motion (wrapping around).
///
/// # Errors
/// A bad parameter (named), or an empty, non-finite or too large patch or background.
pub fn generate_sequence(
    patch: &GrayImage,
    background: &GrayImage,
    params: &SequenceParams,
) -> Result<PatternSequence> {
    params.validate()?;
    check_images(patch, background, params)?;
    let mut rng = seeded(params.seed);
    let (pw, ph) = (patch.width, patch.height);
    let region = [(params.width - pw) / 2, (params.height - ph) / 2, pw, ph];
    let centre = [0.5 * (pw as f64 - 1.0), 0.5 * (ph as f64 - 1.0)];
    let start = [
        region[0] as f64 + centre[0],
        region[1] as f64 + centre[1],
        0.0,
        1.0,
    ];
    let heading = rng.random_range(0.0..std::f64::consts::TAU);
    // Keep the patch's centre half a patch diagonal (at the largest scale) inside.
    let margin = 0.5 * (pw as f64).hypot(ph as f64) * params.scale_range[1].min(1.5);
    let mut out = PatternSequence {
        frames: Vec::with_capacity(params.n_frames * params.width * params.height),
        truth: Vec::with_capacity(params.n_frames),
        occlusion: Vec::with_capacity(params.n_frames),
        illumination: Vec::with_capacity(params.n_frames),
        region,
    };
    let mut state = start;
    for k in 0..params.n_frames {
        let draw = if k == 0 {
            FrameDraw {
                state,
                occlusion: 0.0,
                side: 0,
                gain: 1.0,
                offset: 0.0,
                shift: [0.0; 2],
            }
        } else {
            let margin = margin.min(start[0]).min(start[1]);
            state = next_state(&mut rng, state, params, margin, (k - 1) % 4);
            let speed = params.background_speed * k as f64;
            FrameDraw {
                state,
                occlusion: rng.random_range(0.0..=params.max_occlusion),
                side: rng.random_range(0..4),
                gain: rng.random_range(params.gain[0]..=params.gain[1]),
                offset: rng.random_range(params.offset[0]..=params.offset[1]),
                shift: [speed * heading.cos(), speed * heading.sin()],
            }
        };
        render_frame(patch, background, params, &draw, &mut rng, &mut out.frames);
        out.truth.push(draw.state);
        out.occlusion.push(draw.occlusion);
        out.illumination.push([draw.gain, draw.offset]);
    }
    Ok(out)
}

/// Whether patch point `p` is under the occluder: the band of width `fraction` of the
/// patch along one of its four sides, so that `fraction` of its area is hidden.
fn occluded(p: [f64; 2], size: [f64; 2], fraction: f64, side: usize) -> bool {
    // Normalised position in the patch's footprint, its pixels' area (see `footprint`).
    let (u, v) = ((p[0] + 0.5) / size[0], (p[1] + 0.5) / size[1]);
    match side {
        0 => u < fraction,
        1 => u > 1.0 - fraction,
        2 => v < fraction,
        _ => v > 1.0 - fraction,
    }
}

/// The patch's grey level at patch point `p`, or `None` outside its footprint.
///
/// The footprint is the area of the patch's pixels, `[-0.5, w - 0.5) x [-0.5, h -
/// 0.5)` (pixel centres at integer coordinates), the window the tracker learns and
/// whose corners it reports: frame 0 shows exactly the patch's `w x h` pixels, and a
/// patch scaled by `s` covers `s w x s h` pixels. Inside, levels are interpolated
/// bilinearly, the outer half pixel repeating the edge pixels (OpenCV's
/// `BORDER_REPLICATE`). Cutting the patch at its outer pixel centres instead (where
/// bilinear interpolation stops) showed it one pixel smaller than frame 0 in every
/// later frame: its border moved half a pixel inwards, a scale 1/w too small.
fn footprint(patch: &GrayImage, p: [f64; 2]) -> Option<f32> {
    let (w, h) = (patch.width as f64, patch.height as f64);
    let inside = |v: f64, n: f64| v >= -0.5 && v < n - 0.5;
    if !(inside(p[0], w) && inside(p[1], h)) {
        return None;
    }
    patch.sample_bilinear(p[0].clamp(0.0, w - 1.0), p[1].clamp(0.0, h - 1.0))
}

/// Appends one frame to `frames`.
fn render_frame<R: Rng>(
    patch: &GrayImage,
    background: &GrayImage,
    params: &SequenceParams,
    draw: &FrameDraw,
    rng: &mut R,
    frames: &mut Vec<u8>,
) {
    let [tx, ty, theta, s] = draw.state;
    let (sn, cs) = theta.sin_cos();
    let c = [
        0.5 * (patch.width as f64 - 1.0),
        0.5 * (patch.height as f64 - 1.0),
    ];
    let size = [patch.width as f64, patch.height as f64];
    let shift = [draw.shift[0].round() as i64, draw.shift[1].round() as i64];
    let clutter = |x: usize, y: usize, extra: i64| -> f64 {
        let bx = (x as i64 + shift[0] + extra).rem_euclid(background.width as i64) as usize;
        let by = (y as i64 + shift[1] + extra).rem_euclid(background.height as i64) as usize;
        f64::from(background.at(bx, by))
    };
    for y in 0..params.height {
        for x in 0..params.width {
            let q = [(x as f64 - tx) / s, (y as f64 - ty) / s];
            let src = [c[0] + cs * q[0] - sn * q[1], c[1] + sn * q[0] + cs * q[1]];
            let g = match footprint(patch, src) {
                // The occluder shows clutter from elsewhere in the background.
                Some(_) if occluded(src, size, draw.occlusion, draw.side) => clutter(x, y, 97),
                Some(g) => f64::from(g),
                None => clutter(x, y, 0),
            };
            let noisy = draw.gain * g + draw.offset + params.noise * normal(rng);
            frames.push(grey_level(noisy));
        }
    }
}
