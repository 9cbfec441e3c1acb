//! Wall (infinite line) landmarks in Hessian form, seed 000 section 2.1: the world
//! wall `x cos(alpha) + y sin(alpha) = rho` with `rho >= 0` and `alpha` in (-pi, pi],
//! its observation `(rho, alpha)` in the robot frame with analytic Jacobians, and the
//! inverse (a world wall from a robot-frame one) for initialising a new landmark.
//!
//! Seen from the robot `(x, y, theta)`, the world wall is
//! `alpha_r = alpha - theta`, `rho_r = rho - x cos(alpha) - y sin(alpha)`; a negative
//! `rho_r` (the robot on the other side of the line from the world origin) is written
//! `(-rho_r, alpha_r + pi)`, which flips the sign of the `rho` row of the Jacobians.
//! The planar engine uses these for its wall landmarks ([`crate::planar`]).

use std::f64::consts::PI;

use nalgebra::{Matrix2, Matrix2x3, Point2, Vector2};
use rperc_core::{Pose2, wrap_angle};

/// A predicted or inverted wall with its Jacobians.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WallJacobians {
    /// `(rho, alpha)`, `rho >= 0`, `alpha` in (-pi, pi].
    pub wall: Vector2<f64>,
    /// Derivative with respect to the robot pose `(x, y, theta)` (2 x 3).
    pub d_pose: Matrix2x3<f64>,
    /// Derivative with respect to the input wall `(rho, alpha)` (2 x 2).
    pub d_wall: Matrix2<f64>,
}

/// The wall `world = (rho, alpha)` as the robot at `robot` observes it, with the
/// Jacobians with respect to the robot pose and to the world wall. `None` when an
/// input is not finite.
///
/// # Examples
/// ```
/// use nalgebra::Vector2;
/// use rperc_core::Pose2;
/// use slam::wall::observe_wall;
///
/// // The wall x = 5 seen from (2, 1) facing +y: 3 m away, normal at -90 degrees.
/// let robot = Pose2 { x: 2.0, y: 1.0, theta: std::f64::consts::FRAC_PI_2 };
/// let z = observe_wall(&robot, &Vector2::new(5.0, 0.0)).unwrap();
/// assert!((z.wall.x - 3.0).abs() < 1e-12);
/// assert!((z.wall.y + std::f64::consts::FRAC_PI_2).abs() < 1e-12);
/// ```
pub fn observe_wall(robot: &Pose2, world: &Vector2<f64>) -> Option<WallJacobians> {
    if ![robot.x, robot.y, robot.theta, world.x, world.y]
        .iter()
        .all(|v| v.is_finite())
    {
        return None;
    }
    let (s, c) = world.y.sin_cos();
    let rho = world.x - robot.x * c - robot.y * s;
    let lever = robot.x * s - robot.y * c; // d rho_r / d alpha
    let mut d_pose = Matrix2x3::new(-c, -s, 0.0, 0.0, 0.0, -1.0);
    let mut d_wall = Matrix2::new(1.0, lever, 0.0, 1.0);
    Some(flipped(
        rho,
        world.y - robot.theta,
        &mut d_pose,
        &mut d_wall,
    ))
}

/// The world wall of a wall `z = (rho, alpha)` observed in the robot frame from
/// `robot`, with the Jacobians with respect to the robot pose and to `z` (the inverse
/// of [`observe_wall`], for a new landmark's mean and covariance). `None` when an
/// input is not finite.
pub fn wall_to_world(robot: &Pose2, z: &Vector2<f64>) -> Option<WallJacobians> {
    if ![robot.x, robot.y, robot.theta, z.x, z.y]
        .iter()
        .all(|v| v.is_finite())
    {
        return None;
    }
    let alpha = z.y + robot.theta;
    let (s, c) = alpha.sin_cos();
    let rho = z.x + robot.x * c + robot.y * s;
    let lever = -robot.x * s + robot.y * c; // d rho_w / d alpha_w
    let mut d_pose = Matrix2x3::new(c, s, lever, 0.0, 0.0, 1.0);
    let mut d_wall = Matrix2::new(1.0, lever, 0.0, 1.0);
    Some(flipped(rho, alpha, &mut d_pose, &mut d_wall))
}

/// `(rho, alpha)` written with `rho >= 0` and `alpha` wrapped, the rho rows of the
/// Jacobians negated when the line had to be flipped.
fn flipped(
    rho: f64,
    alpha: f64,
    d_pose: &mut Matrix2x3<f64>,
    d_wall: &mut Matrix2<f64>,
) -> WallJacobians {
    let (rho, alpha) = if rho < 0.0 {
        d_pose.row_mut(0).neg_mut();
        d_wall.row_mut(0).neg_mut();
        (-rho, alpha + PI)
    } else {
        (rho, alpha)
    };
    WallJacobians {
        wall: Vector2::new(rho, wrap_angle(alpha)),
        d_pose: *d_pose,
        d_wall: *d_wall,
    }
}

/// The innovation `z - predicted` of an observed wall, and the sign to apply to the
/// rho rows of the prediction's Jacobians. Near `rho = 0` noise can put the observed
/// and the predicted line in opposite forms (`alpha` about pi apart); the observation
/// is then compared with the predicted line's other form `(-rho, alpha + pi)`, whose
/// Jacobian has its rho row negated (the returned sign is -1).
pub fn wall_innovation(z: &Vector2<f64>, predicted: &Vector2<f64>) -> (Vector2<f64>, f64) {
    let d_alpha = wrap_angle(z.y - predicted.y);
    if d_alpha.abs() <= PI / 2.0 {
        (Vector2::new(z.x - predicted.x, d_alpha), 1.0)
    } else {
        (
            Vector2::new(z.x + predicted.x, wrap_angle(z.y - predicted.y - PI)),
            -1.0,
        )
    }
}

/// A wall innovation re-expressed at a point of the seen segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SegmentInnovation {
    /// `(offset, angle)`: how far the seen point `m` lies from the predicted line
    /// along the predicted normal, m, and `z`'s angle minus the predicted one, rad.
    pub nu: Vector2<f64>,
    /// Takes the prediction's Jacobian (rows rho, alpha) to the offset's: `J H`.
    pub j_predicted: Matrix2<f64>,
    /// Takes the detection's noise `R` to the noise of `nu`: `J R J^T`.
    pub j_seen: Matrix2<f64>,
}

/// The innovation of wall detection `z = (rho, alpha)` against the `predicted` line
/// (both in the sensor frame and in the same form, see [`wall_innovation`]),
/// measured at `mid`, a point of the detected line (the middle of the seen segment).
///
/// `(rho, alpha)` is measured at the sensor's foot on the line, often metres from
/// the segment that was seen. A fit pins the line near its points and leaves its
/// angle loose, so in `(rho, alpha)` the noise is curved: with an angle error `b`,
/// the foot's `rho` is short by `rho b^2 / 2`, every sighting the same way, which a
/// linearised update takes for signal (a 0.4 m door jamb, angle sd 6 degrees, at
/// 1.5 m: 0.8 cm a sighting). At the seen point the offset's noise is the fit's own
/// and Gaussian; the angle row is unchanged. To first order both forms carry the
/// same information: `nu = J_seen (z - predicted)`.
///
/// # Examples
/// ```
/// use nalgebra::{Point2, Vector2};
/// use slam::wall::segment_innovation;
///
/// // The wall x = 2 predicted, and seen at x = 2.01 around the point (2.01, 3).
/// let s = segment_innovation(
///     &Vector2::new(2.01, 0.0),
///     &Vector2::new(2.0, 0.0),
///     &Point2::new(2.01, 3.0),
/// );
/// assert!((s.nu.x - 0.01).abs() < 1e-12 && s.nu.y.abs() < 1e-12);
/// // An angle error moves the offset at y = 3 by -3 per radian.
/// assert!((s.j_seen[(0, 1)] + 3.0).abs() < 1e-12);
/// ```
pub fn segment_innovation(
    z: &Vector2<f64>,
    predicted: &Vector2<f64>,
    mid: &Point2<f64>,
) -> SegmentInnovation {
    let (sp, cp) = predicted.y.sin_cos();
    let (sz, cz) = z.y.sin_cos();
    let offset = cp * mid.x + sp * mid.y - predicted.x;
    // d offset / d alpha at either angle: minus the point's coordinate along the line.
    let along_predicted = -sp * mid.x + cp * mid.y;
    let along_seen = -sz * mid.x + cz * mid.y;
    SegmentInnovation {
        nu: Vector2::new(offset, wrap_angle(z.y - predicted.y)),
        j_predicted: Matrix2::new(1.0, -along_predicted, 0.0, 1.0),
        j_seen: Matrix2::new(1.0, -along_seen, 0.0, 1.0),
    }
}

/// The covariance a wall detection `z = (rho, alpha)` (sensor frame) gets when each
/// end of its seen segment `ends` lies off the ideal straight wall by an independent
/// perpendicular error of `sigma` metres (a wall that is not straight at the cm level):
/// the line through the two ends has offset error `(e1 + e2) / 2` at the midpoint and
/// angle error `(e2 - e1) / L`, so at the sensor's foot (the midpoint at `m` along the
/// line) `var(rho) = sigma^2 (1/2 + 2 m^2 / L^2)`, `cov = 2 sigma^2 m / L^2` and
/// `var(alpha) = 2 sigma^2 / L^2`. Unlike a fit's covariance it does not shrink with
/// the number of readings. (Python reaches it over arrays as
/// `rperc.slam.wallslam.straightness_covariance`.)
///
/// # Examples
/// ```
/// use nalgebra::{Point2, Vector2};
/// use slam::wall::straightness_covariance;
///
/// // The wall x = 2 seen from y = -1 to y = 1: the midpoint is at the foot.
/// let ends = [Point2::new(2.0, -1.0), Point2::new(2.0, 1.0)];
/// let c = straightness_covariance(&Vector2::new(2.0, 0.0), &ends, 0.01);
/// assert!((c[(0, 0)] - 0.5e-4).abs() < 1e-15 && (c[(1, 1)] - 0.5e-4).abs() < 1e-15);
/// ```
pub fn straightness_covariance(
    z: &Vector2<f64>,
    ends: &[Point2<f64>; 2],
    sigma: f64,
) -> Matrix2<f64> {
    let (s, c) = z.y.sin_cos();
    let mid = (ends[0].coords + ends[1].coords) * 0.5;
    let m = Vector2::new(-s, c).dot(&mid);
    let l2 = (ends[1] - ends[0]).norm_squared().max(1e-6);
    let q = Matrix2::new(0.5 + 2.0 * m * m / l2, 2.0 * m / l2, 2.0 * m / l2, 2.0 / l2);
    q * (sigma * sigma)
}

/// The foot on the line `z = (rho, alpha)` of the middle of the segment `ends`.
pub fn segment_middle(z: &Vector2<f64>, ends: &[Point2<f64>; 2]) -> Point2<f64> {
    let n = Vector2::new(z.y.cos(), z.y.sin());
    let mid = (ends[0].coords + ends[1].coords) * 0.5;
    Point2::from(mid - n * (n.dot(&mid) - z.x))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Central differences of `f` at `(pose, wall)` with respect to both, alpha
    /// differences wrapped.
    fn numeric(
        f: fn(&Pose2, &Vector2<f64>) -> Option<WallJacobians>,
        pose: &Pose2,
        wall: &Vector2<f64>,
    ) -> (Matrix2x3<f64>, Matrix2<f64>) {
        let h = 1e-6;
        let diff = |a: Vector2<f64>, b: Vector2<f64>| {
            Vector2::new((a.x - b.x) / (2.0 * h), wrap_angle(a.y - b.y) / (2.0 * h))
        };
        let mut d_pose = Matrix2x3::zeros();
        for i in 0..3 {
            let shift = |d: f64| {
                let mut p = *pose;
                match i {
                    0 => p.x += d,
                    1 => p.y += d,
                    _ => p.theta += d,
                }
                f(&p, wall).unwrap().wall
            };
            d_pose.set_column(i, &diff(shift(h), shift(-h)));
        }
        let mut d_wall = Matrix2::zeros();
        for i in 0..2 {
            let mut e = Vector2::zeros();
            e[i] = h;
            d_wall.set_column(
                i,
                &diff(
                    f(pose, &(wall + e)).unwrap().wall,
                    f(pose, &(wall - e)).unwrap().wall,
                ),
            );
        }
        (d_pose, d_wall)
    }

    fn pose_and_wall() -> impl Strategy<Value = (Pose2, Vector2<f64>)> {
        (
            -20.0..20.0f64,
            -20.0..20.0f64,
            -PI..PI,
            0.0..15.0f64,
            -PI..PI,
        )
            .prop_map(|(x, y, theta, rho, alpha)| (Pose2 { x, y, theta }, Vector2::new(rho, alpha)))
    }

    proptest! {
        #[test]
        fn observation_jacobians_match_central_differences((pose, wall) in pose_and_wall()) {
            let z = observe_wall(&pose, &wall).unwrap();
            // At rho_r = 0 the flip makes the observation non-differentiable.
            prop_assume!(z.wall.x > 1e-3);
            let (d_pose, d_wall) = numeric(observe_wall, &pose, &wall);
            prop_assert!((z.d_pose - d_pose).abs().max() < 1e-6, "{} vs {}", z.d_pose, d_pose);
            prop_assert!((z.d_wall - d_wall).abs().max() < 1e-6, "{} vs {}", z.d_wall, d_wall);
            prop_assert!(z.wall.x >= 0.0 && z.wall.y > -PI && z.wall.y <= PI);
        }

        #[test]
        fn inverse_jacobians_match_central_differences((pose, z) in pose_and_wall()) {
            let w = wall_to_world(&pose, &z).unwrap();
            prop_assume!(w.wall.x > 1e-3);
            let (d_pose, d_wall) = numeric(wall_to_world, &pose, &z);
            prop_assert!((w.d_pose - d_pose).abs().max() < 1e-6, "{} vs {}", w.d_pose, d_pose);
            prop_assert!((w.d_wall - d_wall).abs().max() < 1e-6, "{} vs {}", w.d_wall, d_wall);
        }

        #[test]
        fn the_inverse_undoes_the_observation((pose, wall) in pose_and_wall()) {
            prop_assume!(wall.x > 1e-6);
            let z = observe_wall(&pose, &wall).unwrap();
            prop_assume!(z.wall.x > 1e-6);
            let back = wall_to_world(&pose, &z.wall).unwrap();
            prop_assert!((back.wall.x - wall.x).abs() < 1e-9);
            prop_assert!(wrap_angle(back.wall.y - wall.y).abs() < 1e-9);
            // And the Jacobians are inverse to each other with respect to the wall.
            let product = back.d_wall * z.d_wall;
            prop_assert!((product - Matrix2::identity()).abs().max() < 1e-9, "{}", product);
        }

        #[test]
        fn the_observation_is_the_line_through_transformed_points((pose, wall) in pose_and_wall()) {
            // Independent oracle: two points of the world line, taken to the robot
            // frame, give the observed line through them.
            let (s, c) = wall.y.sin_cos();
            let foot = Vector2::new(wall.x * c, wall.x * s);
            let along = Vector2::new(-s, c);
            let to_robot = |p: Vector2<f64>| {
                let d = p - Vector2::new(pose.x, pose.y);
                let (st, ct) = pose.theta.sin_cos();
                Vector2::new(ct * d.x + st * d.y, -st * d.x + ct * d.y)
            };
            let (a, b) = (to_robot(foot - along * 3.0), to_robot(foot + along * 5.0));
            let t = (b - a).normalize();
            let mut n = Vector2::new(-t.y, t.x);
            if n.dot(&a) < 0.0 {
                n = -n;
            }
            let z = observe_wall(&pose, &wall).unwrap();
            prop_assume!(z.wall.x > 1e-6);
            prop_assert!((z.wall.x - n.dot(&a)).abs() < 1e-9);
            prop_assert!(wrap_angle(z.wall.y - n.y.atan2(n.x)).abs() < 1e-9);
        }
    }

    #[test]
    fn innovation_compares_the_right_forms_near_rho_zero() {
        // Predicted (0.01, 0.3); observed just across zero, written (0.02, 0.3 + pi).
        let (nu, sign) = wall_innovation(
            &Vector2::new(0.02, wrap_angle(0.3 + PI)),
            &Vector2::new(0.01, 0.3),
        );
        assert_eq!(sign, -1.0);
        assert!((nu.x - 0.03).abs() < 1e-12 && nu.y.abs() < 1e-12);
        let (nu, sign) = wall_innovation(&Vector2::new(2.0, 3.1), &Vector2::new(1.9, -3.1));
        assert_eq!(sign, 1.0);
        assert!((nu.x - 0.1).abs() < 1e-12 && (nu.y - (6.2 - 2.0 * PI)).abs() < 1e-12);
        assert!(
            observe_wall(
                &Pose2 {
                    x: f64::NAN,
                    y: 0.0,
                    theta: 0.0
                },
                &Vector2::new(1.0, 0.0)
            )
            .is_none()
        );
    }

    /// The segment innovation of `z` seen from `pose` against `wall`, with its
    /// Jacobian (`nu = z - h`, so `H = -d nu / d x`) from the analytic pieces.
    fn segment_form(
        pose: &Pose2,
        wall: &Vector2<f64>,
        z: &Vector2<f64>,
        mid: &Point2<f64>,
    ) -> (Vector2<f64>, Matrix2x3<f64>, Matrix2<f64>) {
        let pred = observe_wall(pose, wall).unwrap();
        let (_, sign) = wall_innovation(z, &pred.wall);
        let (mut d_pose, mut d_wall) = (pred.d_pose, pred.d_wall);
        let mut form = pred.wall;
        if sign < 0.0 {
            d_pose.row_mut(0).neg_mut();
            d_wall.row_mut(0).neg_mut();
            form = Vector2::new(-form.x, wrap_angle(form.y + PI));
        }
        let s = segment_innovation(z, &form, mid);
        (s.nu, s.j_predicted * d_pose, s.j_predicted * d_wall)
    }

    proptest! {
        #[test]
        fn segment_jacobians_match_central_differences(
            (pose, wall) in pose_and_wall(),
            along in -6.0..6.0f64,
            noise in (-0.05..0.05f64, -0.1..0.1f64),
        ) {
            let pred = observe_wall(&pose, &wall).unwrap();
            prop_assume!(pred.wall.x > 1e-2);
            let z = Vector2::new(pred.wall.x + noise.0, wrap_angle(pred.wall.y + noise.1));
            let (s, c) = z.y.sin_cos();
            let mid = Point2::new(z.x * c - along * s, z.x * s + along * c);
            let (_, d_pose, d_wall) = segment_form(&pose, &wall, &z, &mid);
            let h = 1e-6;
            let nu = |p: &Pose2, w: &Vector2<f64>| segment_form(p, w, &z, &mid).0;
            let diff = |a: Vector2<f64>, b: Vector2<f64>| {
                Vector2::new(a.x - b.x, wrap_angle(a.y - b.y)) / (2.0 * h)
            };
            for i in 0..3 {
                let (mut up, mut down) = (pose, pose);
                match i {
                    0 => { up.x += h; down.x -= h; }
                    1 => { up.y += h; down.y -= h; }
                    _ => { up.theta += h; down.theta -= h; }
                }
                let numeric = -diff(nu(&up, &wall), nu(&down, &wall));
                prop_assert!((d_pose.column(i) - numeric).abs().max() < 1e-6);
            }
            for i in 0..2 {
                let mut e = Vector2::zeros();
                e[i] = h;
                let numeric = -diff(nu(&pose, &(wall + e)), nu(&pose, &(wall - e)));
                prop_assert!((d_wall.column(i) - numeric).abs().max() < 1e-6);
            }
        }

        #[test]
        fn segment_innovation_is_the_line_form_to_first_order(
            rho in 0.5..8.0f64,
            alpha in -PI..PI,
            along in -6.0..6.0f64,
            d in (-1e-4..1e-4f64, -1e-4..1e-4f64),
        ) {
            let predicted = Vector2::new(rho, alpha);
            let z = Vector2::new(rho + d.0, wrap_angle(alpha + d.1));
            let (s, c) = z.y.sin_cos();
            let mid = Point2::new(z.x * c - along * s, z.x * s + along * c);
            let seg = segment_innovation(&z, &predicted, &mid);
            let (line, _) = wall_innovation(&z, &predicted);
            // Second-order terms: |mid| d_alpha^2 / 2 at most.
            prop_assert!((seg.nu - seg.j_seen * line).abs().max() < 1e-6);
        }
    }

    /// A wall seen as the line through its two end points, each moved across it by
    /// Gaussian noise (the straightness model): at the true line, the segment form's
    /// innovation has mean zero and covariance `J R J^T`, while the line form's,
    /// taken to the same point, is off by `rho sd_alpha^2 / 2` on average.
    #[test]
    fn segment_innovation_removes_the_line_forms_bias() {
        let (rho, length, along, sigma) = (1.5, 0.4, 3.0, 0.02);
        let truth = Vector2::new(rho, 0.0);
        let ends = [
            Point2::new(rho, along - length / 2.0),
            Point2::new(rho, along + length / 2.0),
        ];
        // The two-point fit's noise: offset sd sigma/sqrt(2) at the middle, angle sd
        // sqrt(2) sigma / length, independent.
        let var_angle = 2.0 * sigma * sigma / (length * length);
        let r_mid = Matrix2::new(sigma * sigma / 2.0, 0.0, 0.0, var_angle);
        let mut rng = rperc_core::rng::seeded(7);
        let n = 200_000;
        let (mut seg_sum, mut line_sum) = (Vector2::zeros(), Vector2::zeros());
        let mut seg_sq = Matrix2::zeros();
        for _ in 0..n {
            let e0 = sigma * rperc_core::rng::normal(&mut rng);
            let e1 = sigma * rperc_core::rng::normal(&mut rng);
            let (a, b) = (
                ends[0] + Vector2::new(e0, 0.0),
                ends[1] + Vector2::new(e1, 0.0),
            );
            let t = (b - a).normalize();
            let mut normal = Vector2::new(t.y, -t.x);
            if normal.dot(&a.coords) < 0.0 {
                normal = -normal;
            }
            let z = Vector2::new(normal.dot(&a.coords), normal.y.atan2(normal.x));
            let mid = segment_middle(&z, &[a, b]);
            let seg = segment_innovation(&z, &truth, &mid);
            seg_sum += seg.nu;
            seg_sq += seg.nu * seg.nu.transpose();
            line_sum += seg.j_seen * wall_innovation(&z, &truth).0;
        }
        let nf = n as f64;
        let (seg_mean, line_mean) = (seg_sum / nf, line_sum / nf);
        let cov = seg_sq / nf - seg_mean * seg_mean.transpose();
        // The standard error of a mean offset at the middle: sd / sqrt(n).
        let se = (r_mid[(0, 0)] / nf).sqrt();
        assert!(
            seg_mean.x.abs() < 4.0 * se,
            "segment offset mean {} (se {se})",
            seg_mean.x
        );
        // The line form, read at the same point, is off by the curvature of its rho.
        let bias = rho * var_angle / 2.0;
        assert!(bias > 50.0 * se);
        assert!(
            (line_mean.x.abs() - bias).abs() < 0.1 * bias,
            "line form {} vs {bias}",
            line_mean.x
        );
        assert!(
            (cov[(0, 0)] / r_mid[(0, 0)] - 1.0).abs() < 0.03,
            "{cov} vs {r_mid}"
        );
        assert!(
            (cov[(1, 1)] / r_mid[(1, 1)] - 1.0).abs() < 0.03,
            "{cov} vs {r_mid}"
        );
    }

    /// `(rho, alpha)` of the line through `a` and `b`, with its normal on the side of
    /// `alpha_near`.
    fn line_through(a: Point2<f64>, b: Point2<f64>, alpha_near: f64) -> Vector2<f64> {
        let t = (b - a).normalize();
        let mut n = Vector2::new(-t.y, t.x);
        if n.dot(&Vector2::new(alpha_near.cos(), alpha_near.sin())) < 0.0 {
            n = -n;
        }
        Vector2::new(n.dot(&a.coords), n.y.atan2(n.x))
    }

    proptest! {
        /// The straightness covariance is the first-order covariance of the line
        /// through the two end points, each moved across the wall by `sigma`
        /// (central differences in the two perpendicular errors).
        #[test]
        fn straightness_covariance_is_the_two_end_point_model(
            rho in 0.5..6.0f64,
            alpha in -PI..PI,
            along0 in -5.0..5.0f64,
            length in 0.3..8.0f64,
            sigma in 0.001..0.05f64,
        ) {
            let n = Vector2::new(alpha.cos(), alpha.sin());
            let t = Vector2::new(-n.y, n.x);
            let ends = [
                Point2::from(n * rho + t * along0),
                Point2::from(n * rho + t * (along0 + length)),
            ];
            let z = Vector2::new(rho, alpha);
            let h = 1e-6;
            let mut jac = Matrix2::zeros();
            for k in 0..2 {
                let moved = |e: f64| {
                    let mut p = ends;
                    p[k] += n * e;
                    line_through(p[0], p[1], alpha)
                };
                let (up, down) = (moved(h), moved(-h));
                jac[(0, k)] = (up.x - down.x) / (2.0 * h);
                jac[(1, k)] = wrap_angle(up.y - down.y) / (2.0 * h);
            }
            let expected = jac * jac.transpose() * sigma * sigma;
            let got = straightness_covariance(&z, &ends, sigma);
            let scale = expected.abs().max();
            prop_assert!((got - expected).abs().max() < 1e-6 * scale, "{got} vs {expected}");
        }
    }
}
