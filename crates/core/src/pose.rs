//! SE(2) poses `(x, y, theta)` and the Jacobians of their operations.
//!
//! Conventions: `a.compose(&b)` is `a (+) b` (b expressed in a's frame, moved to the
//! world), `a.between(&b)` is `a^-1 (+) b` (b seen from a). Every Jacobian is the
//! derivative of the result's `(x, y, theta)` (or `(x, y)` for points) with respect to
//! the inputs' components, checked against central differences in the tests.

use nalgebra::{Matrix2, Matrix2x3, Matrix3, Point2, Vector2, Vector3};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::angle::wrap_angle;

/// Below this turn angle `|omega dt|` the arc functions use their Taylor series: the
/// closed forms lose digits to cancellation there (`phi cos phi - sin phi ~ -phi^3/3`),
/// and the series truncated after these terms is exact to ~1e-19 for `|phi| < 1e-2`.
const SERIES_BELOW: f64 = 1e-2;

/// `sin(phi)/phi` and `(1 - cos phi)/phi` with their derivatives `(f, df, g, dg)`:
/// the chord of an arc of unit length turning by `phi`, in the frame of its start.
/// Continuous through `phi = 0`, where the arc becomes a straight line.
///
/// # Examples
/// ```
/// use rperc_core::pose::arc_functions;
///
/// // A half turn: the chord of a unit arc is its diameter, 2 / pi, straight left.
/// let (f, _, g, _) = arc_functions(std::f64::consts::PI);
/// assert!(f.abs() < 1e-15 && (g - 2.0 / std::f64::consts::PI).abs() < 1e-15);
/// ```
pub fn arc_functions(phi: f64) -> (f64, f64, f64, f64) {
    if phi.abs() < SERIES_BELOW {
        let p2 = phi * phi;
        let f = 1.0 - p2 / 6.0 * (1.0 - p2 / 20.0 * (1.0 - p2 / 42.0));
        let df = -phi / 3.0 * (1.0 - p2 / 10.0 * (1.0 - p2 / 28.0));
        let g = phi / 2.0 * (1.0 - p2 / 12.0 * (1.0 - p2 / 30.0 * (1.0 - p2 / 56.0)));
        let dg = 0.5 * (1.0 - p2 / 4.0 * (1.0 - p2 / 18.0 * (1.0 - p2 / 40.0)));
        return (f, df, g, dg);
    }
    let (s, c) = phi.sin_cos();
    // 1 - cos(phi) = 2 sin^2(phi / 2), without cancellation.
    let one_minus_cos = 2.0 * (phi / 2.0).sin().powi(2);
    let f = s / phi;
    let g = one_minus_cos / phi;
    let df = (phi * c - s) / (phi * phi);
    let dg = (phi * s - one_minus_cos) / (phi * phi);
    (f, df, g, dg)
}

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
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize, JsonSchema)]
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

    /// The pose after driving at speed `v` and turn rate `omega` for `dt` (exactly,
    /// on an arc; the unicycle of MR.CLAM's robots and of the ceiling world).
    pub fn advance(&self, v: f64, omega: f64, dt: f64) -> Pose2 {
        let phi = omega * dt;
        let (f, _, g, _) = arc_functions(phi);
        self.compose(&Pose2::new(v * dt * f, v * dt * g, phi))
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
        let j_self = block(&Matrix2::identity(), dr, 1.0);
        let j_other = block(&self.rotation(), Vector2::zeros(), 1.0);
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
        let j_self = block(&-rt, dth, -1.0);
        let j_other = block(&rt, Vector2::zeros(), 1.0);
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

/// The 3x3 Jacobian `[[m, c], [0 0, s]]` of a planar pose map: the 2x2 block `m` on the
/// translation, the column `c` the translation takes from the heading, and the
/// heading's own factor `s`.
fn block(m: &Matrix2<f64>, c: Vector2<f64>, s: f64) -> Matrix3<f64> {
    Matrix3::new(
        m[(0, 0)],
        m[(0, 1)],
        c.x,
        m[(1, 0)],
        m[(1, 1)],
        c.y,
        0.0,
        0.0,
        s,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arc_functions_are_continuous_across_the_series_switch() {
        for phi in [SERIES_BELOW, -SERIES_BELOW] {
            let below = arc_functions(phi * (1.0 - 1e-12));
            let above = arc_functions(phi * (1.0 + 1e-12));
            for (a, b) in [
                (below.0, above.0),
                (below.1, above.1),
                (below.2, above.2),
                (below.3, above.3),
            ] {
                assert!(
                    (a - b).abs() <= 1e-11 * (1.0 + a.abs().max(b.abs())),
                    "{a} vs {b} at {phi}"
                );
            }
        }
    }

    #[test]
    fn advance_is_the_exact_arc() {
        // A quarter circle of radius 2 from the origin facing +x ends at (2, 2) facing +y.
        let p = Pose2::identity().advance(2.0, 1.0, std::f64::consts::FRAC_PI_2);
        assert!((p.x - 2.0).abs() < 1e-12 && (p.y - 2.0).abs() < 1e-12);
        assert!((p.theta - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        // Straight on: no turn.
        let q = Pose2::new(1.0, 1.0, 0.5).advance(1.0, 0.0, 2.0);
        assert!((q.x - 1.0 - 2.0 * 0.5f64.cos()).abs() < 1e-12);
    }
}
