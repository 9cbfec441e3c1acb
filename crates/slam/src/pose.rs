//! Planar poses `(x, y, theta)`, shared by planar SLAM and tracking.

use std::f64::consts::PI;

use nalgebra::{Matrix2, Point2, Vector2};

/// An angle wrapped into (-pi, pi].
pub fn wrap_angle(a: f64) -> f64 {
    let w = a.rem_euclid(2.0 * PI);
    if w > PI { w - 2.0 * PI } else { w }
}

/// A planar pose: position and heading.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Pose2 {
    /// Position x.
    pub x: f64,
    /// Position y.
    pub y: f64,
    /// Heading, radians, wrapped into (-pi, pi].
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

    /// Rotation matrix of the heading.
    pub fn rotation(&self) -> Matrix2<f64> {
        let (s, c) = self.theta.sin_cos();
        Matrix2::new(c, -s, s, c)
    }

    /// `self (+) other`: `other` expressed in this pose's frame, moved to the world.
    pub fn compose(&self, other: &Pose2) -> Pose2 {
        let t = self.rotation() * Vector2::new(other.x, other.y);
        Pose2::new(self.x + t.x, self.y + t.y, self.theta + other.theta)
    }

    /// The inverse transform: `p.compose(&p.inverse())` is the identity.
    pub fn inverse(&self) -> Pose2 {
        let t = self.rotation().transpose() * Vector2::new(-self.x, -self.y);
        Pose2::new(t.x, t.y, -self.theta)
    }

    /// A point in this pose's frame, moved to the world frame.
    pub fn transform_point(&self, p: &Point2<f64>) -> Point2<f64> {
        Point2::from(self.rotation() * p.coords + Vector2::new(self.x, self.y))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compose_with_inverse_is_identity() {
        let p = Pose2::new(1.0, -2.0, 2.5);
        let id = p.compose(&p.inverse());
        assert!(id.x.abs() < 1e-12 && id.y.abs() < 1e-12 && id.theta.abs() < 1e-12);
        assert_eq!(wrap_angle(3.0 * PI), PI);
        assert!((wrap_angle(-PI) - PI).abs() < 1e-15);
    }
}
