//! The upward-looking camera of the second seed's section 2.1: intrinsics `K`, the
//! camera-robot transform `C T_R`, and the homography of eq. 1 that corrects an image
//! for it.
//!
//! Frames (right-handed, metres):
//! - the robot frame `F_R`: x forward, y left, z up, its origin on the floor;
//! - the camera frame `F_C`: the pinhole frame, z along the optical axis, x towards
//!   growing image columns `u`, y towards growing rows `v`;
//! - the ideal camera has `C T_R = I` and square pixels: its optical axis is the
//!   robot's z (straight up), so a ceiling point `(X, Y)` of the robot frame at height
//!   `d` is seen at `u = cx + fx X / d`, `v = cy + fx Y / d` (its focal length is `fx`
//!   on both axes, so that its image is a similarity of the ceiling).
//!
//! Looking up, the image is the plan view of the ceiling mirrored (a rotation of the
//! robot by `+phi` turns the image content by `-phi` in the `(u, v)` axes).

use nalgebra::{Matrix3, Rotation3, Vector3};
use rperc_core::Pose2;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::error::{NavigationError, Result};

/// Where the camera sits on the robot: the camera frame in the robot frame,
/// `X_R = R_m X_C + offset`, with `R_m = Rz(yaw) Ry(pitch) Rx(roll)` (radians).
/// The ideal mount is all zeros.
#[derive(Debug, Clone, Copy, PartialEq, Default, Deserialize, Serialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct CameraMount {
    /// Rotation about the camera's x axis, radians.
    pub roll: f64,
    /// Rotation about y, radians.
    pub pitch: f64,
    /// Rotation about z (the optical axis), radians.
    pub yaw: f64,
    /// The camera centre in the robot frame, metres.
    pub offset: [f64; 3],
}

impl CameraMount {
    /// `R_m`, the camera axes in the robot frame.
    pub fn rotation(&self) -> Matrix3<f64> {
        *Rotation3::from_euler_angles(self.roll, self.pitch, self.yaw).matrix()
    }

    /// `C T_R` as `(R, t)`: `X_C = R X_R + t`.
    pub fn camera_from_robot(&self) -> (Matrix3<f64>, Vector3<f64>) {
        let r = self.rotation().transpose();
        let t = -(r * Vector3::from(self.offset));
        (r, t)
    }
}

/// A pinhole camera looking up at a ceiling plane.
///
/// # Examples
/// ```
/// use rperc_core::Pose2;
/// use navigation::ceiling::CeilingCamera;
///
/// let camera = CeilingCamera::default();
/// // The ceiling point straight above the ideal camera is the principal point.
/// let robot = Pose2::new(2.0, 1.0, 0.3);
/// let uv = camera.project_ideal(&robot, [2.0, 1.0]);
/// assert!((uv[0] - camera.cx).abs() < 1e-9 && (uv[1] - camera.cy).abs() < 1e-9);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct CeilingCamera {
    /// Image width, pixels.
    pub width: usize,
    /// Image height, pixels.
    pub height: usize,
    /// Focal length along u, pixels.
    pub fx: f64,
    /// Focal length along v, pixels.
    pub fy: f64,
    /// Principal point, pixels (0-based, pixel centres at integers).
    pub cx: f64,
    /// Principal point, pixels.
    pub cy: f64,
    /// `d`: the height of the ceiling above the robot frame's origin, metres.
    pub ceiling_height: f64,
    /// The camera-robot transform.
    pub mount: CameraMount,
}

impl Default for CeilingCamera {
    /// A 320x240 camera with a 90-degree horizontal field of view under a ceiling
    /// 2.5 m up: one pixel spans 1.6 cm of ceiling.
    fn default() -> Self {
        Self {
            width: 320,
            height: 240,
            fx: 160.0,
            fy: 160.0,
            cx: 159.5,
            cy: 119.5,
            ceiling_height: 2.5,
            mount: CameraMount::default(),
        }
    }
}

fn invalid(name: &'static str, reason: impl Into<String>) -> NavigationError {
    NavigationError::InvalidParameter {
        name,
        reason: reason.into(),
    }
}

/// The widest and tallest camera image, pixels: far beyond any real camera, and its
/// square still counts in a usize on every platform rperc builds for.
const MAX_IMAGE_SIDE: usize = 1 << 15;

impl CeilingCamera {
    /// Refuses a calibration that cannot be inverted or a ceiling the camera cannot see.
    pub fn validate(&self) -> Result<()> {
        use rperc_core::{ensure_finite, ensure_positive};
        if self.width < 16 || self.height < 16 {
            return Err(invalid("width", "images must be at least 16x16"));
        }
        // Bounded before any image is allocated: a 2^33 x 2^33 camera's pixel count
        // wrapped in usize, passed the frames' allocation check and aborted (issue 38).
        rperc_core::ensure_count("width", self.width, 16, MAX_IMAGE_SIDE, 1)?;
        rperc_core::ensure_count("height", self.height, 16, MAX_IMAGE_SIDE, 1)?;
        let pixels = self.width as u128 * self.height as u128;
        rperc_core::check_allocation("width", pixels, 4)?;
        ensure_positive("fx", self.fx)?;
        ensure_positive("fy", self.fy)?;
        ensure_finite("cx", [self.cx, self.cy].iter())?;
        ensure_positive("ceiling_height", self.ceiling_height)?;
        let m = &self.mount;
        ensure_finite("mount", [m.roll, m.pitch, m.yaw].iter().chain(&m.offset))?;
        // The ceiling must stay in front of the camera and off its centre: a tilt
        // towards the horizon or a camera at the ceiling makes eq. 1 singular.
        let axis = m.rotation() * Vector3::z();
        if axis.z < 0.5 {
            return Err(invalid(
                "mount",
                "the optical axis must point up (tilt < 60 deg)",
            ));
        }
        if m.offset[2] >= 0.9 * self.ceiling_height {
            return Err(invalid("mount", "the camera must sit below the ceiling"));
        }
        Ok(())
    }

    /// The intrinsic matrix `K`.
    pub fn intrinsics(&self) -> Matrix3<f64> {
        Matrix3::new(self.fx, 0.0, self.cx, 0.0, self.fy, self.cy, 0.0, 0.0, 1.0)
    }

    /// The ideal camera's intrinsics: `K` with `fy` set to `fx` (square pixels).
    pub fn ideal_intrinsics(&self) -> Matrix3<f64> {
        Matrix3::new(self.fx, 0.0, self.cx, 0.0, self.fx, self.cy, 0.0, 0.0, 1.0)
    }

    /// Eq. 1, `C H_R = K (R - t n^T / d) K'^-1`: ideal-image pixels (the image the
    /// camera would take with `C T_R = I`, intrinsics `K'` of
    /// [`Self::ideal_intrinsics`]) to real-image pixels, for points of the ceiling.
    /// `(R, t)` is `C T_R`, `n = (0, 0, -1)` the ceiling's normal towards the robot
    /// and `d` the ceiling's distance from the robot frame. (The seed writes `K` on
    /// both sides; with square pixels `K' = K`.)
    pub fn robot_to_camera_homography(&self) -> Matrix3<f64> {
        let (r, t) = self.mount.camera_from_robot();
        let n = Vector3::new(0.0, 0.0, -1.0);
        let k = self.intrinsics();
        k * (r - t * n.transpose() / self.ceiling_height) * self.ideal_inverse()
    }

    /// The correction of eq. 1: real-image pixels to ideal-image pixels (the inverse
    /// of [`Self::robot_to_camera_homography`]). `validate` guarantees it exists.
    pub fn correction_homography(&self) -> Result<Matrix3<f64>> {
        self.robot_to_camera_homography()
            .try_inverse()
            .ok_or_else(|| invalid("mount", "the camera-robot homography is singular"))
    }

    fn ideal_inverse(&self) -> Matrix3<f64> {
        let f = self.fx;
        Matrix3::new(
            1.0 / f,
            0.0,
            -self.cx / f,
            0.0,
            1.0 / f,
            -self.cy / f,
            0.0,
            0.0,
            1.0,
        )
    }

    /// Ideal-image pixels to world `(x, y)` on the ceiling, for a robot at `pose`.
    pub fn ideal_pixel_to_world(&self, pose: &Pose2) -> Matrix3<f64> {
        let d = self.ceiling_height;
        // Ideal pixel -> robot-frame ceiling point (X, Y) = d K^-1 (u, v, 1).
        let to_robot = Matrix3::new(d, 0.0, 0.0, 0.0, d, 0.0, 0.0, 0.0, 1.0);
        world_from_robot(pose) * to_robot * self.ideal_inverse()
    }

    /// Real-image pixels to world `(x, y)` on the ceiling (the renderer's warp).
    pub fn pixel_to_world(&self, pose: &Pose2) -> Result<Matrix3<f64>> {
        Ok(self.ideal_pixel_to_world(pose) * self.correction_homography()?)
    }

    /// Where the ideal camera sees the ceiling point `xy` (world metres).
    pub fn project_ideal(&self, pose: &Pose2, xy: [f64; 2]) -> [f64; 2] {
        let p = pose.inverse_transform_point(&nalgebra::Point2::new(xy[0], xy[1]));
        [
            self.cx + self.fx * p.x / self.ceiling_height,
            self.cy + self.fx * p.y / self.ceiling_height,
        ]
    }

    /// Where the real camera sees the ceiling point `xy`, by the full 3-D pinhole
    /// projection (no homography: the independent route the tests compare eq. 1 with).
    /// `None` behind the camera.
    pub fn project(&self, pose: &Pose2, xy: [f64; 2]) -> Option<[f64; 2]> {
        let p = pose.inverse_transform_point(&nalgebra::Point2::new(xy[0], xy[1]));
        let (r, t) = self.mount.camera_from_robot();
        let c = r * Vector3::new(p.x, p.y, self.ceiling_height) + t;
        (c.z > 1e-9).then(|| [self.cx + self.fx * c.x / c.z, self.cy + self.fy * c.y / c.z])
    }

    /// Metres of ceiling per ideal-image pixel: `Z / f`, the scale of eq. 2.
    pub fn metres_per_pixel(&self) -> f64 {
        self.ceiling_height / self.fx
    }
}

/// The homogeneous 3x3 matrix of a planar pose: robot-frame `(x, y, 1)` to world.
pub fn world_from_robot(pose: &Pose2) -> Matrix3<f64> {
    let (s, c) = pose.theta.sin_cos();
    Matrix3::new(c, -s, pose.x, s, c, pose.y, 0.0, 0.0, 1.0)
}

/// Refills `out` with the ideal image of `frame` (eq. 1's correction applied to the
/// image data, section 2.1): each ideal pixel samples the real frame bilinearly where
/// `C H_R` sends it; pixels that fall outside the real frame get `fill`.
pub fn correct_image(
    camera: &CeilingCamera,
    frame: &rperc_core::image::GrayImage,
    fill: f32,
    out: &mut rperc_core::image::GrayImage,
) -> Result<()> {
    camera.validate()?;
    let expected = (camera.width, camera.height);
    tracking::TrackingError::check_frame_size(expected, (frame.width, frame.height))?;
    let h = camera.robot_to_camera_homography();
    out.width = camera.width;
    out.height = camera.height;
    out.data.clear();
    out.data.reserve(camera.width * camera.height);
    for v in 0..camera.height {
        for u in 0..camera.width {
            let level = apply_homography(&h, [u as f64, v as f64])
                .and_then(|p| frame.sample_bilinear(p[0], p[1]))
                .unwrap_or(fill);
            out.data.push(level);
        }
    }
    Ok(())
}

/// Applies a homography to a point; `None` when it maps to infinity.
pub fn apply_homography(h: &Matrix3<f64>, p: [f64; 2]) -> Option<[f64; 2]> {
    let q = h * Vector3::new(p[0], p[1], 1.0);
    (q.z.abs() > 1e-12).then(|| [q.x / q.z, q.y / q.z])
}
