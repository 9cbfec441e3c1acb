//! The planar engine's observation models: range-bearing from a sensor mounted on
//! the robot, the anchor of eqs. (24)-(25) and the change of frame it implies, and
//! the external xy fix of eqs. (26)-(27). Each returns its analytic Jacobians, checked
//! against central differences in the tests below.

use nalgebra::{Matrix2, Matrix2x3, Matrix3, Matrix3x2, Point2, Vector2, Vector3};
use rperc_core::Pose2;

use crate::observation::{landmark_from_range_bearing, range_bearing};

/// `(range, bearing)` of `landmark` from the sensor at `mount` on the robot, with
/// `dz/d(robot)` (2x3) and `dz/d(landmark)` (2x2). `None` when the landmark sits on
/// the sensor. (The engine calls [`observe_from`] with the sensor made once per
/// scan; the Jacobian tests check them through this.)
#[cfg(test)]
pub(crate) fn observe(
    robot: &Pose2,
    mount: &Pose2,
    landmark: &Point2<f64>,
) -> Option<(Vector2<f64>, Matrix2x3<f64>, Matrix2<f64>)> {
    let (sensor, j_robot, _) = robot.compose_with_jacobians(mount);
    observe_from(&sensor, &j_robot, landmark)
}

/// [`observe`] from the sensor pose and its Jacobian wrt the robot
/// (`robot.compose_with_jacobians(mount)`), made once for many landmarks.
pub(crate) fn observe_from(
    sensor: &Pose2,
    j_robot: &Matrix3<f64>,
    landmark: &Point2<f64>,
) -> Option<(Vector2<f64>, Matrix2x3<f64>, Matrix2<f64>)> {
    let (z, h_sensor, h_landmark) = range_bearing(sensor, landmark)?;
    Some((z, h_sensor * j_robot, h_landmark))
}

/// The landmark at `z` from the sensor at `mount`, with `dl/d(robot)` (2x3) and
/// `dl/dz` (2x2): the inverse of [`observe`], for initialisation.
pub(crate) fn landmark_from(
    robot: &Pose2,
    mount: &Pose2,
    z: &Vector2<f64>,
) -> (Point2<f64>, Matrix2x3<f64>, Matrix2<f64>) {
    let (sensor, j_robot, _) = robot.compose_with_jacobians(mount);
    let (l, g_sensor, g_z) = landmark_from_range_bearing(&sensor, z);
    (l, g_sensor * j_robot, g_z)
}

/// The anchor's change of frame: when the first landmark `a = g(robot, z)` becomes
/// the global reference, the map is re-expressed relative to it, `t' = t - a`,
/// `theta' = theta`, so that the anchor sits at the origin with no uncertainty as in
/// eq. (24) ("a global reference fixed at the origin"). Returns the new robot
/// `(t', theta')`, its Jacobians wrt the robot and wrt `z`, and `a`.
pub(crate) fn anchor_frame(
    robot: &Pose2,
    mount: &Pose2,
    z: &Vector2<f64>,
) -> (Vector3<f64>, Matrix3<f64>, Matrix3x2<f64>, Point2<f64>) {
    let (a, g_robot, g_z) = landmark_from(robot, mount, z);
    let moved = Vector3::new(robot.x - a.x, robot.y - a.y, robot.theta);
    let mut j_robot = Matrix3::identity();
    j_robot
        .fixed_view_mut::<2, 3>(0, 0)
        .copy_from(&(Matrix2x3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0) - g_robot));
    let mut j_z = Matrix3x2::zeros();
    j_z.fixed_view_mut::<2, 2>(0, 0).copy_from(&(-g_z));
    (moved, j_robot, j_z, a)
}

/// Eq. (24) with the sensor's mount: the anchor (the origin of the frame) seen in
/// the sensor frame, `h = R^T (0 - t) - m`, and eq. (25), its Jacobian
/// `[-R^T, -(dR/dtheta)^T t]` (the mount offset `m` is constant).
pub(crate) fn anchor_observation(robot: &Pose2, mount: &Pose2) -> (Vector2<f64>, Matrix2x3<f64>) {
    // The origin seen from the robot, R^T (0 - t), is rperc-core's inverse transform,
    // and its pose Jacobian is eq. (25)'s.
    let (origin, jac, _) = robot.inverse_transform_point_with_jacobians(&Point2::origin());
    (origin.coords - mount.translation(), jac)
}

/// A range-bearing detection as a Cartesian point in the sensor frame, with its
/// covariance `G W G^T` (what eq. (24) measures).
pub(crate) fn cartesian(z: &Vector2<f64>, w: &Matrix2<f64>) -> (Vector2<f64>, Matrix2<f64>) {
    let (s, c) = z.y.sin_cos();
    let g = Matrix2::new(c, -z.x * s, s, z.x * c);
    (Vector2::new(z.x * c, z.x * s), g * w * g.transpose())
}

/// Eqs. (26)-(27): an external sensor measures the robot's xy, `h = t + offset`
/// (`offset` maps the engine's internal frame to the world), `H = [I 0]`; with the
/// sensor's point `lever` (robot frame) off the pose's origin, `h = t + R(theta) lever
/// + offset` and `H = [I, dR/dtheta lever]`.
pub(crate) fn fix_observation(
    robot: &Pose2,
    offset: &Vector2<f64>,
    lever: &Vector2<f64>,
) -> (Vector2<f64>, Matrix2x3<f64>) {
    let (s, c) = robot.theta.sin_cos();
    let arm = Vector2::new(c * lever.x - s * lever.y, s * lever.x + c * lever.y);
    (
        robot.translation() + arm + offset,
        Matrix2x3::new(1.0, 0.0, -arm.y, 0.0, 1.0, arm.x),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector};

    /// Central differences of `f` at `x0`.
    fn numeric(f: impl Fn(&DVector<f64>) -> DVector<f64>, x0: &DVector<f64>) -> DMatrix<f64> {
        let eps = 1e-6;
        let cols: Vec<_> = (0..x0.len())
            .map(|k| {
                let (mut a, mut b) = (x0.clone(), x0.clone());
                a[k] += eps;
                b[k] -= eps;
                (f(&a) - f(&b)) / (2.0 * eps)
            })
            .collect();
        DMatrix::from_columns(&cols)
    }

    fn pose(v: &DVector<f64>) -> Pose2 {
        Pose2::new(v[0], v[1], v[2])
    }

    fn dyn2(v: Vector2<f64>) -> DVector<f64> {
        DVector::from_column_slice(v.as_slice())
    }

    const MOUNT: Pose2 = Pose2 {
        x: 3.78,
        y: 0.5,
        theta: 0.0,
    };

    #[test]
    fn mounted_observation_jacobians_match_finite_differences() {
        let x0 = DVector::from_vec(vec![1.0, -2.0, 0.7]);
        let l = Point2::new(9.0, 4.0);
        let (_, hr, hl) = observe(&pose(&x0), &MOUNT, &l).unwrap();
        let num = numeric(|x| dyn2(observe(&pose(x), &MOUNT, &l).unwrap().0), &x0);
        assert!((num - DMatrix::from_column_slice(2, 3, hr.as_slice())).amax() < 1e-7);
        let l0 = DVector::from_vec(vec![l.x, l.y]);
        let num = numeric(
            |p| {
                dyn2(
                    observe(&pose(&x0), &MOUNT, &Point2::new(p[0], p[1]))
                        .unwrap()
                        .0,
                )
            },
            &l0,
        );
        assert!((num - DMatrix::from_column_slice(2, 2, hl.as_slice())).amax() < 1e-7);
    }

    /// The anchor's change of frame, differentiated wrt the robot and the detection.
    #[test]
    fn anchor_frame_jacobians_match_finite_differences() {
        let x0 = DVector::from_vec(vec![0.4, 1.1, -2.5]);
        let z0 = Vector2::new(7.0, 0.3);
        let (_, jr, jz, _) = anchor_frame(&pose(&x0), &MOUNT, &z0);
        let f_robot = |x: &DVector<f64>| {
            DVector::from_column_slice(anchor_frame(&pose(x), &MOUNT, &z0).0.as_slice())
        };
        assert!(
            (numeric(f_robot, &x0) - DMatrix::from_column_slice(3, 3, jr.as_slice())).amax() < 1e-7
        );
        let f_z = |z: &DVector<f64>| {
            let moved = anchor_frame(&pose(&x0), &MOUNT, &Vector2::new(z[0], z[1])).0;
            DVector::from_column_slice(moved.as_slice())
        };
        let num = numeric(f_z, &dyn2(z0));
        assert!((num - DMatrix::from_column_slice(3, 2, jz.as_slice())).amax() < 1e-7);
    }

    /// Eq. (25) against differences of eq. (24), and eq. (24) against the generic
    /// range-bearing model of a landmark at the origin (converted to Cartesian).
    #[test]
    fn anchor_observation_matches_eq_25_and_the_point_model() {
        let x0 = DVector::from_vec(vec![-3.0, 2.0, 1.2]);
        let (h, jac) = anchor_observation(&pose(&x0), &MOUNT);
        let num = numeric(|x| dyn2(anchor_observation(&pose(x), &MOUNT).0), &x0);
        assert!((num - DMatrix::from_column_slice(2, 3, jac.as_slice())).amax() < 1e-7);
        let z = observe(&pose(&x0), &MOUNT, &Point2::origin()).unwrap().0;
        let (p, _) = cartesian(&z, &Matrix2::identity());
        assert!((p - h).norm() < 1e-12);
    }

    #[test]
    fn fix_jacobian_is_eq_27() {
        let x0 = DVector::from_vec(vec![5.0, -1.0, 0.3]);
        let off = Vector2::new(2.0, 3.0);
        let (h, jac) = fix_observation(&pose(&x0), &off, &Vector2::zeros());
        assert_eq!(h, Vector2::new(7.0, 2.0));
        let num = numeric(
            |x| dyn2(fix_observation(&pose(x), &off, &Vector2::zeros()).0),
            &x0,
        );
        assert!((num - DMatrix::from_column_slice(2, 3, jac.as_slice())).amax() < 1e-9);
    }

    /// With a lever arm, the fix is the point `lever` of the robot: at heading pi/2 the
    /// arm (3, 0.5) points along +y and to -x (closed form), and the Jacobian matches
    /// central differences.
    #[test]
    fn fix_with_a_lever_arm_is_that_point_of_the_robot() {
        let lever = Vector2::new(3.0, 0.5);
        let up = Pose2::new(1.0, 2.0, std::f64::consts::FRAC_PI_2);
        let (h, _) = fix_observation(&up, &Vector2::zeros(), &lever);
        assert!((h - Vector2::new(0.5, 5.0)).norm() < 1e-12);
        let x0 = DVector::from_vec(vec![5.0, -1.0, 0.3]);
        let off = Vector2::new(2.0, 3.0);
        let (_, jac) = fix_observation(&pose(&x0), &off, &lever);
        let num = numeric(|x| dyn2(fix_observation(&pose(x), &off, &lever).0), &x0);
        assert!((num - DMatrix::from_column_slice(2, 3, jac.as_slice())).amax() < 1e-8);
    }
}
