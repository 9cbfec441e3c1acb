//! The geometry of section 2.2-2.3: a model's image pose as the planar transform
//! `C T_i` (eq. 2's), the robot's pose in the mosaic from any tracked model (eq. 2),
//! a new model's pose from the robot's (eq. 3), and the inverse used to re-acquire a
//! model that comes back into view.
//!
//! All of it lives in the ideal image (corrected by eq. 1, square pixels), whose `(u,
//! v)` axes are the robot's `(x, y)` axes scaled by `f / Z`: the image is a similarity
//! of the ceiling, so a model's image pose is a planar rigid transform once its
//! position is multiplied by `Z / f`. That factor is [`ImageScale::metres_per_pixel`];
//! with it set to 1 the mosaic and the robot are in pixels, "up to the scale factor
//! Z/f" of the seed, which is all visual servoing needs.

use nalgebra::Point2;
use rperc_core::{Pose2, wrap_angle};

/// The ideal camera's principal point and the scale `Z / f` of eq. 2.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImageScale {
    /// Metres of ceiling per ideal-image pixel (`Z / f`), or 1 for a mosaic in pixels.
    pub metres_per_pixel: f64,
    /// The principal point `(cx, cy)`, pixels.
    pub principal: [f64; 2],
}

impl ImageScale {
    /// `C T_i`: the model frame seen from the robot (the projection of the camera frame
    /// on the ceiling), from a tracker state `(x, y, theta, s)`. The tracker's `theta`
    /// is counter-clockwise on screen, which is clockwise in the `(u, v)` axes (`v`
    /// points down), so the model turned by `-theta` there; the model frame of a
    /// freshly created model is the image axes, centred on its region.
    ///
    /// # Examples
    /// ```
    /// use navigation::memory::ImageScale;
    ///
    /// let scale = ImageScale { metres_per_pixel: 0.01, principal: [160.0, 120.0] };
    /// let t = scale.camera_to_model([260.0, 120.0, 0.5, 1.0]);
    /// // 100 px along u is 1 m ahead of the robot; the image turn is -theta.
    /// assert!((t.x - 1.0).abs() < 1e-12 && t.y.abs() < 1e-12 && (t.theta + 0.5).abs() < 1e-12);
    /// ```
    pub fn camera_to_model(&self, state: [f64; 4]) -> Pose2 {
        let m = self.metres_per_pixel;
        Pose2::new(
            m * (state[0] - self.principal[0]),
            m * (state[1] - self.principal[1]),
            -state[2],
        )
    }

    /// The tracker state at which a model seen at `state` is seen again after the
    /// robot moved by `motion` (robot frame, mosaic units): `C T_i' = motion^-1 C T_i`
    /// in image coordinates, the scale unchanged.
    pub fn moved_state(&self, state: [f64; 4], motion: &Pose2) -> [f64; 4] {
        let c_t_i = motion.inverse().compose(&self.camera_to_model(state));
        [
            self.principal[0] + c_t_i.x / self.metres_per_pixel,
            self.principal[1] + c_t_i.y / self.metres_per_pixel,
            state[2] + motion.theta,
            state[3],
        ]
    }

    /// The tracker state `(x, y, theta, 1)` at which a model at `model_in_mosaic` is
    /// seen from a robot at `robot_in_mosaic`: the inverse of eq. 2, used to restart
    /// the tracker of a model that comes back into view.
    pub fn predicted_state(&self, robot_in_mosaic: &Pose2, model_in_mosaic: &Pose2) -> [f64; 4] {
        let c_t_i = robot_in_mosaic.between(model_in_mosaic);
        [
            self.principal[0] + c_t_i.x / self.metres_per_pixel,
            self.principal[1] + c_t_i.y / self.metres_per_pixel,
            -c_t_i.theta,
            1.0,
        ]
    }
}

/// Eq. 2: `M T_C = M T_i (C T_i)^-1`, the robot in the mosaic from one model.
pub fn robot_in_mosaic(model_in_mosaic: &Pose2, camera_to_model: &Pose2) -> Pose2 {
    model_in_mosaic.compose(&camera_to_model.inverse())
}

/// Eq. 3 (and its generalisation to any model `m_j` in view): `M T_i = M T_C C T_i`,
/// a new model's pose in the mosaic from the robot's pose there, which itself comes
/// from the models already in the mosaic (eq. 2); `M T_C = M T_j (C T_j)^-1` makes
/// this `M T_j (j T_i)`, the composition the seed writes.
pub fn new_model_in_mosaic(robot_in_mosaic: &Pose2, camera_to_new: &Pose2) -> Pose2 {
    robot_in_mosaic.compose(camera_to_new)
}

/// The weighted mean of several estimates of one pose (positions averaged, headings
/// by their mean unit vector); `None` for no estimate or no positive weight.
pub fn fuse(estimates: &[(Pose2, f64)]) -> Option<Pose2> {
    let total: f64 = estimates
        .iter()
        .filter(|(_, w)| *w > 0.0 && w.is_finite())
        .map(|(_, w)| w)
        .sum();
    if total <= 0.0 || !total.is_finite() {
        return None;
    }
    let (mut x, mut y, mut c, mut s) = (0.0, 0.0, 0.0, 0.0);
    for (p, w) in estimates.iter().filter(|(_, w)| *w > 0.0 && w.is_finite()) {
        let k = w / total;
        x += k * p.x;
        y += k * p.y;
        c += k * p.theta.cos();
        s += k * p.theta.sin();
    }
    Some(Pose2::new(x, y, wrap_angle(s.atan2(c))))
}

/// `(mosaic point, robot-frame point, weight)`.
pub type PointPair = ([f64; 2], [f64; 2], f64);

/// The pose `T` that best maps robot-frame points onto their mosaic positions,
/// `mosaic ~ T (robot)`, by weighted least squares (the 2-D Kabsch / Umeyama fit
/// without scale); `None` with fewer than two points of positive weight or all
/// points at one place.
///
/// With several models in view this is eq. 2 fused through the models' positions:
/// the robot's heading then comes from the baseline between models (a hundred
/// pixels) rather than from each tracker's rotation (a model's own contours, tens of
/// pixels), so it is several times more precise.
pub fn fit_pose(pairs: &[([f64; 2], [f64; 2], f64)]) -> Option<Pose2> {
    let used: Vec<&([f64; 2], [f64; 2], f64)> = pairs
        .iter()
        .filter(|p| p.2 > 0.0 && p.2.is_finite())
        .collect();
    if used.len() < 2 {
        return None;
    }
    let total: f64 = used.iter().map(|p| p.2).sum();
    let mean = |pick: fn(&PointPair) -> [f64; 2]| {
        used.iter().fold([0.0, 0.0], |acc, p| {
            let q = pick(p);
            [acc[0] + p.2 * q[0] / total, acc[1] + p.2 * q[1] / total]
        })
    };
    let cm = mean(|p| p.0);
    let cr = mean(|p| p.1);
    let (mut dot, mut cross) = (0.0, 0.0);
    for (m, r, w) in &used {
        let (a, b) = ([r[0] - cr[0], r[1] - cr[1]], [m[0] - cm[0], m[1] - cm[1]]);
        dot += w * (a[0] * b[0] + a[1] * b[1]);
        cross += w * (a[0] * b[1] - a[1] * b[0]);
    }
    if dot == 0.0 && cross == 0.0 {
        return None;
    }
    let theta = cross.atan2(dot);
    // The translation takes the turned robot-frame centroid onto the mosaic's.
    let turned = Pose2::new(0.0, 0.0, theta).transform_point(&Point2::from(cr));
    Some(Pose2::new(cm[0] - turned.x, cm[1] - turned.y, theta))
}

/// The largest distance between two of `points` (0 for fewer than two): how far
/// apart the models are that a fit would take the heading from.
///
/// # Examples
/// ```
/// use navigation::memory::spread;
///
/// assert_eq!(spread(&[[0.0, 0.0], [3.0, 4.0], [1.0, 1.0]]), 5.0);
/// assert_eq!(spread(&[[2.0, 2.0]]), 0.0);
/// ```
pub fn spread(points: &[[f64; 2]]) -> f64 {
    points
        .iter()
        .enumerate()
        .flat_map(|(i, a)| {
            points[i + 1..]
                .iter()
                .map(move |b| (a[0] - b[0]).hypot(a[1] - b[1]))
        })
        .fold(0.0, f64::max)
}
