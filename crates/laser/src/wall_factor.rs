//! A wall landmark in the pose graph: the world line `(rho, alpha)` of seed 000
//! section 2.1 (`slam::wall`), seen from a key scan's pose.
//!
//! The error is the segment innovation (`slam::wall::segment_innovation`): how far
//! the middle of the seen segment lies from the predicted line along its normal, and
//! the seen angle minus the predicted one. Measured at the seen segment instead of at
//! the sensor's foot on the line, the offset's noise is the fit's own and nearly
//! Gaussian; `(rho, alpha)` at a foot metres away is curved in the angle error.

use nalgebra::{Matrix2, Matrix2x3, Point2, Vector2};
use rperc_core::{Pose2, wrap_angle};
use slam::wall::{observe_wall, segment_innovation, wall_innovation};

/// One sighting of a wall from one pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WallFactor {
    /// The pose that saw it.
    pub pose: usize,
    /// The wall it saw.
    pub wall: usize,
    /// The seen line `(rho, alpha)`, laser frame.
    pub z: Vector2<f64>,
    /// The middle of the seen segment, laser frame.
    pub mid: Point2<f64>,
    /// Information (inverse covariance) of the segment innovation.
    pub information: Matrix2<f64>,
    /// The robust kernel's `phi` (dynamic covariance scaling), `None` for a plain
    /// Gaussian factor.
    pub robust: Option<f64>,
}

/// The error of sighting `z` (segment middle `mid`) of the world wall `wall` from
/// `pose`, with its Jacobians in the pose and the wall; `None` when an input is not
/// finite.
///
/// # Examples
/// ```
/// use nalgebra::{Point2, Vector2};
/// use rperc_core::Pose2;
/// use laser::wall_factor::linearise_wall;
///
/// // The wall x = 5 seen from the origin at x = 5.02: the segment is 2 cm off.
/// let (e, _, _) = linearise_wall(
///     &Pose2::identity(),
///     &Vector2::new(5.0, 0.0),
///     &Vector2::new(5.02, 0.0),
///     &Point2::new(5.02, 1.0),
/// )
/// .unwrap();
/// assert!((e.x - 0.02).abs() < 1e-12 && e.y.abs() < 1e-12);
/// ```
pub fn linearise_wall(
    pose: &Pose2,
    wall: &Vector2<f64>,
    z: &Vector2<f64>,
    mid: &Point2<f64>,
) -> Option<(Vector2<f64>, Matrix2x3<f64>, Matrix2<f64>)> {
    let seen = observe_wall(pose, wall)?;
    // Near rho = 0 the seen and predicted lines can be in opposite forms: compare
    // with the predicted line's other form, whose rho row changes sign.
    let (_, sign) = wall_innovation(z, &seen.wall);
    let (mut predicted, mut d_pose, mut d_wall) = (seen.wall, seen.d_pose, seen.d_wall);
    if sign < 0.0 {
        predicted = Vector2::new(-predicted.x, wrap_angle(predicted.y + std::f64::consts::PI));
        d_pose.row_mut(0).neg_mut();
        d_wall.row_mut(0).neg_mut();
    }
    let s = segment_innovation(z, &predicted, mid);
    // nu = (offset(mid) - rho, z_alpha - alpha): d nu / d predicted = -J_predicted.
    let d = -s.j_predicted;
    Some((s.nu, d * d_pose, d * d_wall))
}

/// The covariance of a sighting's segment innovation, from the seen line's
/// covariance `r` (`J_seen R J_seen^T`, see `slam::wall::segment_innovation`).
pub fn innovation_covariance(
    z: &Vector2<f64>,
    mid: &Point2<f64>,
    r: &Matrix2<f64>,
) -> Matrix2<f64> {
    let j = segment_innovation(z, z, mid).j_seen;
    let c = j * r * j.transpose();
    (c + c.transpose()) * 0.5
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn error(
        pose: &Pose2,
        wall: &Vector2<f64>,
        z: &Vector2<f64>,
        mid: &Point2<f64>,
    ) -> Vector2<f64> {
        linearise_wall(pose, wall, z, mid).unwrap().0
    }

    proptest! {
        /// Central differences confirm both Jacobians, wherever the wall is seen from
        /// (either side of it, near or far from the origin), with the sighting written
        /// in either form of its line: `(-rho, alpha + pi)` takes the branch that
        /// compares with the predicted line's other form.
        #[test]
        fn jacobians_match_finite_differences(
            x in -20.0..20.0f64, y in -20.0..20.0f64, th in -3.1..3.1f64,
            rho in 0.5..30.0f64, alpha in -3.1..3.1f64,
            dz in -0.05..0.05f64, da in -0.05..0.05f64, t in -3.0..3.0f64,
            flip in any::<bool>(),
        ) {
            let pose = Pose2::new(x, y, th);
            let wall = Vector2::new(rho, alpha);
            let seen = observe_wall(&pose, &wall).unwrap().wall;
            prop_assume!(seen.x > 0.2);
            let z = Vector2::new(seen.x + dz, wrap_angle(seen.y + da));
            let z = if flip {
                Vector2::new(-z.x, wrap_angle(z.y + std::f64::consts::PI))
            } else {
                z
            };
            let mid = Point2::new(z.x * z.y.cos() - t * z.y.sin(), z.x * z.y.sin() + t * z.y.cos());
            let (_, jp, jw) = linearise_wall(&pose, &wall, &z, &mid).unwrap();
            let h = 1e-6;
            for k in 0..3 {
                let mut v = [x, y, th];
                v[k] += h;
                let plus = error(&Pose2::new(v[0], v[1], v[2]), &wall, &z, &mid);
                v[k] -= 2.0 * h;
                let minus = error(&Pose2::new(v[0], v[1], v[2]), &wall, &z, &mid);
                let fd = (plus - minus) / (2.0 * h);
                for r in 0..2 {
                    prop_assert!((fd[r] - jp[(r, k)]).abs() < 1e-5 * (1.0 + jp[(r, k)].abs()),
                        "pose column {k} row {r}: {} vs {}", fd[r], jp[(r, k)]);
                }
            }
            for k in 0..2 {
                let mut w = wall;
                w[k] += h;
                let plus = error(&pose, &w, &z, &mid);
                w[k] -= 2.0 * h;
                let minus = error(&pose, &w, &z, &mid);
                let fd = (plus - minus) / (2.0 * h);
                for r in 0..2 {
                    prop_assert!((fd[r] - jw[(r, k)]).abs() < 1e-5 * (1.0 + jw[(r, k)].abs()),
                        "wall column {k} row {r}: {} vs {}", fd[r], jw[(r, k)]);
                }
            }
        }
    }

    /// A sighting that agrees with the wall has zero error, whichever form it is in.
    #[test]
    fn a_consistent_sighting_has_no_error() {
        let pose = Pose2::new(1.0, -2.0, 0.7);
        let wall = Vector2::new(4.0, 2.0);
        let seen = observe_wall(&pose, &wall).unwrap().wall;
        let mid = Point2::new(seen.x * seen.y.cos(), seen.x * seen.y.sin());
        let e = error(&pose, &wall, &seen, &mid);
        assert!(e.norm() < 1e-12, "{e}");
        let flipped = Vector2::new(-seen.x, wrap_angle(seen.y + std::f64::consts::PI));
        let e = error(&pose, &wall, &flipped, &mid);
        assert!(e.norm() < 1e-12, "{e}");
    }

    /// At the foot of the perpendicular the innovation's covariance is the line's;
    /// `t` metres along the line from it, the offset there moves by `d rho - t d
    /// alpha` (the point `rho n + t n_perp` of the seen line, measured along the
    /// predicted normal), which the closed form below spells out entry by entry.
    #[test]
    fn innovation_covariance_carries_the_angle_along_the_line() {
        let z = Vector2::new(3.0, 0.4);
        let (s, c) = 0.4f64.sin_cos();
        let r = Matrix2::new(1e-4, 2e-5, 2e-5, 3e-4);
        for t in [0.0, 2.5, -7.0] {
            let mid = Point2::new(3.0 * c - t * s, 3.0 * s + t * c);
            let expected = Matrix2::new(
                r[(0, 0)] - 2.0 * t * r[(0, 1)] + t * t * r[(1, 1)],
                r[(0, 1)] - t * r[(1, 1)],
                r[(0, 1)] - t * r[(1, 1)],
                r[(1, 1)],
            );
            let got = innovation_covariance(&z, &mid, &r);
            assert!(
                (got - expected).norm() < 1e-15,
                "t = {t}: {got} vs {expected}"
            );
        }
    }
}
