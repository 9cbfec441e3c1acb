//! SE(2) poses `(x, y, theta)` and the Jacobians of their operations.
//!
//! Conventions: `a.compose(&b)` is `a (+) b` (b expressed in a's frame, moved to the
//! world), `a.between(&b)` is `a^-1 (+) b` (b seen from a). Every Jacobian is the
//! derivative of the result's `(x, y, theta)` (or `(x, y)` for points) with respect to
//! the inputs' components, checked against central differences in the tests.

use nalgebra::{Matrix2, Matrix2x3, Matrix3, Point2, Vector2, Vector3};

use crate::angle::wrap_angle;

/// A planar pose: position and heading (radians, wrapped into (-pi, pi]).
///
/// # Examples
/// ```
/// use nalgebra::Point2;
/// use rperc_core::Pose2;
///
/// let robot = Pose2::new(1.0, 2.0, std::f64::consts::FRAC_PI_2);
/// let ahead = robot.transform_point(&Point2::new(1.0, 0.0)); // 1 m ahead of the robot
/// assert!((ahead - Point2::new(1.0, 3.0)).norm() < 1e-12);
/// let back = robot.inverse_transform_point(&ahead);
/// assert!((back - Point2::new(1.0, 0.0)).norm() < 1e-12);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Pose2 {
    /// Position x.
    pub x: f64,
    /// Position y.
    pub y: f64,
    /// Heading, radians.
    pub theta: f64,
}

impl Pose2 {
    /// A pose with its heading wrapped.
    pub fn new(x: f64, y: f64, theta: f64) -> Self {
        Self {
            x,
            y,
            theta: wrap_angle(theta),
        }
    }

    /// The identity pose.
    pub fn identity() -> Self {
        Self::default()
    }

    /// From `[x, y, theta]` (heading wrapped).
    pub fn from_vector(v: &Vector3<f64>) -> Self {
        Self::new(v.x, v.y, v.z)
    }

    /// As `[x, y, theta]`.
    pub fn to_vector(&self) -> Vector3<f64> {
        Vector3::new(self.x, self.y, self.theta)
    }

    /// The position.
    pub fn translation(&self) -> Vector2<f64> {
        Vector2::new(self.x, self.y)
    }

    /// Rotation matrix `R(theta)`.
    pub fn rotation(&self) -> Matrix2<f64> {
        let (s, c) = self.theta.sin_cos();
        Matrix2::new(c, -s, s, c)
    }

    /// `dR/dtheta`.
    fn rotation_derivative(&self) -> Matrix2<f64> {
        let (s, c) = self.theta.sin_cos();
        Matrix2::new(-s, -c, c, -s)
    }

    /// `self (+) other`: `other` expressed in this pose's frame, moved to the world.
    pub fn compose(&self, other: &Pose2) -> Pose2 {
        let t = self.translation() + self.rotation() * other.translation();
        Pose2::new(t.x, t.y, self.theta + other.theta)
    }

    /// `self (+) other` with `d/d self` and `d/d other`.
    pub fn compose_with_jacobians(&self, other: &Pose2) -> (Pose2, Matrix3<f64>, Matrix3<f64>) {
        let dr = self.rotation_derivative() * other.translation();
        let j_self = Matrix3::new(1.0, 0.0, dr.x, 0.0, 1.0, dr.y, 0.0, 0.0, 1.0);
        let r = self.rotation();
        let j_other = Matrix3::new(
            r[(0, 0)],
            r[(0, 1)],
            0.0,
            r[(1, 0)],
            r[(1, 1)],
            0.0,
            0.0,
            0.0,
            1.0,
        );
        (self.compose(other), j_self, j_other)
    }

    /// The inverse transform: `p.compose(&p.inverse())` is the identity.
    pub fn inverse(&self) -> Pose2 {
        let t = -(self.rotation().transpose() * self.translation());
        Pose2::new(t.x, t.y, -self.theta)
    }

    /// The inverse with `d/d self`.
    pub fn inverse_with_jacobian(&self) -> (Pose2, Matrix3<f64>) {
        let (s, c) = self.theta.sin_cos();
        let (x, y) = (self.x, self.y);
        let j = Matrix3::new(-c, -s, s * x - c * y, s, -c, c * x + s * y, 0.0, 0.0, -1.0);
        (self.inverse(), j)
    }

    /// `self^-1 (+) other`: `other` seen from this pose (an odometry increment).
    pub fn between(&self, other: &Pose2) -> Pose2 {
        let t = self.rotation().transpose() * (other.translation() - self.translation());
        Pose2::new(t.x, t.y, other.theta - self.theta)
    }

    /// `self^-1 (+) other` with `d/d self` and `d/d other`.
    pub fn between_with_jacobians(&self, other: &Pose2) -> (Pose2, Matrix3<f64>, Matrix3<f64>) {
        let rt = self.rotation().transpose();
        let d = other.translation() - self.translation();
        let dth = self.rotation_derivative().transpose() * d;
        let j_self = Matrix3::new(
            -rt[(0, 0)],
            -rt[(0, 1)],
            dth.x,
            -rt[(1, 0)],
            -rt[(1, 1)],
            dth.y,
            0.0,
            0.0,
            -1.0,
        );
        let j_other = Matrix3::new(
            rt[(0, 0)],
            rt[(0, 1)],
            0.0,
            rt[(1, 0)],
            rt[(1, 1)],
            0.0,
            0.0,
            0.0,
            1.0,
        );
        (self.between(other), j_self, j_other)
    }

    /// A point in this pose's frame, moved to the world frame: `R p + t`.
    pub fn transform_point(&self, p: &Point2<f64>) -> Point2<f64> {
        Point2::from(self.rotation() * p.coords + self.translation())
    }

    /// `R p + t` with `d/d pose` (2x3) and `d/d p` (2x2).
    pub fn transform_point_with_jacobians(
        &self,
        p: &Point2<f64>,
    ) -> (Point2<f64>, Matrix2x3<f64>, Matrix2<f64>) {
        let dr = self.rotation_derivative() * p.coords;
        let j_pose = Matrix2x3::new(1.0, 0.0, dr.x, 0.0, 1.0, dr.y);
        (self.transform_point(p), j_pose, self.rotation())
    }

    /// A world point expressed in this pose's frame: `R^T (p - t)`.
    pub fn inverse_transform_point(&self, p: &Point2<f64>) -> Point2<f64> {
        Point2::from(self.rotation().transpose() * (p.coords - self.translation()))
    }

    /// `R^T (p - t)` with `d/d pose` (2x3) and `d/d p` (2x2).
    pub fn inverse_transform_point_with_jacobians(
        &self,
        p: &Point2<f64>,
    ) -> (Point2<f64>, Matrix2x3<f64>, Matrix2<f64>) {
        let rt = self.rotation().transpose();
        let d = p.coords - self.translation();
        let dth = self.rotation_derivative().transpose() * d;
        let j_pose = Matrix2x3::new(
            -rt[(0, 0)],
            -rt[(0, 1)],
            dth.x,
            -rt[(1, 0)],
            -rt[(1, 1)],
            dth.y,
        );
        (self.inverse_transform_point(p), j_pose, rt)
    }
}
