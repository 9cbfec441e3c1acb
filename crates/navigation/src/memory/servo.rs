//! Visual servoing from key image to key image (section 2.4): a 2-D image-based law on
//! the image poses of the models shared by the current image and the key image.
//!
//! For a shared model `m_i`, the current and the key image poses give `C T_i` now
//! and at the key image; `C T_i(now) C T_i(key)^-1` is where the robot stood at the
//! key image, seen from where it stands now, in ideal-image pixels: an error made of
//! image measurements only, up to the scale `Z / f` (no mosaic pose, no calibration).
//! Fused over the shared models, it drives a unicycle with the classic polar law:
//! forward speed from the distance along the heading, turn rate from the bearing to
//! the goal, and from the remaining heading error once there.

use rperc_core::{Pose2, wrap_angle};

use super::geometry::{ImageScale, fit_pose, fuse, spread};
use super::keyimages::{KeyImage, TrackedModel};
use crate::error::Result;

/// Gains and limits of the servoing law.
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct ServoParams {
    /// Forward gain, 1/s (pixels of error to pixels per second).
    pub gain_distance: f64,
    /// Turn gain on the bearing to the goal, 1/s.
    pub gain_bearing: f64,
    /// Turn gain on the heading error near the goal, 1/s.
    pub gain_heading: f64,
    /// Largest forward speed, ideal-image pixels per second.
    pub max_speed: f64,
    /// Largest turn rate, rad/s.
    pub max_turn_rate: f64,
    /// An intermediate key image is passed when the error falls under this (pixels).
    pub switch_error: f64,
    /// The last key image (B) is reached when the error falls under this (pixels).
    pub final_error: f64,
    /// Within this distance of the goal (pixels) the heading error is corrected.
    pub align_radius: f64,
}

impl Default for ServoParams {
    fn default() -> Self {
        Self {
            gain_distance: 0.8,
            gain_bearing: 1.5,
            gain_heading: 0.8,
            max_speed: 25.0,
            max_turn_rate: 0.25,
            switch_error: 12.0,
            final_error: 1.5,
            align_radius: 0.0,
        }
    }
}

impl ServoParams {
    /// Refuses bad values with the parameter's name.
    pub fn validate(&self) -> Result<()> {
        use rperc_core::ensure_positive;
        ensure_positive("gain_distance", self.gain_distance)?;
        ensure_positive("gain_bearing", self.gain_bearing)?;
        ensure_positive("gain_heading", self.gain_heading)?;
        ensure_positive("max_speed", self.max_speed)?;
        ensure_positive("max_turn_rate", self.max_turn_rate)?;
        ensure_positive("switch_error", self.switch_error)?;
        ensure_positive("final_error", self.final_error)?;
        rperc_core::ensure_non_negative("align_radius", self.align_radius)?;
        Ok(())
    }
}

/// The key image's robot pose seen from the current one (pixels), from the models
/// shared by the current image and the key image: with two or more spread over the
/// image, the rigid fit of their key-image positions onto their current ones
/// ([`fit_pose`]); with fewer, each shared model's own image pose fused by score.
/// A lone small or round model tells its position well and its rotation badly, and
/// a rotation error moves the goal by the model's distance from the robot times the
/// error; `turn`, when given, is the robot's turn from now to the key image known
/// otherwise (from the localisation in the mosaic), and replaces the lone models'
/// rotations. `None` when no model is shared.
pub fn key_error(
    current: &[TrackedModel],
    key: &KeyImage,
    principal: [f64; 2],
    turn: Option<f64>,
) -> Option<Pose2> {
    let pixels = ImageScale {
        metres_per_pixel: 1.0,
        principal,
    };
    let mut pairs = Vec::new();
    let mut single = Vec::new();
    for m in current {
        let Some(k) = key.models.iter().find(|k| k.id == m.id) else {
            continue;
        };
        let now = pixels.camera_to_model(m.state);
        let then = pixels.camera_to_model(k.state);
        // Robot-frame positions: the model now, and at the key image.
        pairs.push(([now.x, now.y], [then.x, then.y], m.score));
        let now = match turn {
            // C T_i(now) C T_i(key)^-1 has the heading now.theta - then.theta.
            Some(t) => Pose2::new(now.x, now.y, then.theta + t),
            None => now,
        };
        single.push((now.compose(&then.inverse()), m.score));
    }
    let now: Vec<[f64; 2]> = pairs.iter().map(|p| p.0).collect();
    let fitted = if spread(&now) >= MIN_BASELINE {
        fit_pose(&pairs)
    } else {
        None
    };
    fitted.or_else(|| fuse(&single))
}

/// Shared models at least this far apart (pixels) give the error by their positions.
const MIN_BASELINE: f64 = 40.0;

/// The command `(v, omega)` (pixels per second, rad/s) towards a goal seen at `error`
/// (from [`key_error`]).
pub fn command(error: &Pose2, params: &ServoParams) -> (f64, f64) {
    let distance = error.x.hypot(error.y);
    let (v, omega) = if distance > params.align_radius {
        let bearing = error.y.atan2(error.x);
        // Drive backwards to a goal behind (no U-turn for a small overshoot).
        let (bearing, sign) = if bearing.abs() > std::f64::consts::FRAC_PI_2 {
            (wrap_angle(bearing + std::f64::consts::PI), -1.0)
        } else {
            (bearing, 1.0)
        };
        (
            sign * params.gain_distance * distance * bearing.cos(),
            params.gain_bearing * bearing,
        )
    } else {
        (
            params.gain_distance * error.x,
            params.gain_heading * error.theta,
        )
    };
    (
        v.clamp(-params.max_speed, params.max_speed),
        omega.clamp(-params.max_turn_rate, params.max_turn_rate),
    )
}
