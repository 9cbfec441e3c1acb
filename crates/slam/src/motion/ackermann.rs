//! The Ackermann utility car of the Victoria Park data set (Guivant & Nebot, "Optimization
//! of the simultaneous localization and map-building algorithm for real-time
//! implementation", IEEE T-RA 2001), with the constants of the public implementations.
//!
//! The state is the pose of the rear axle centre. The speed is measured by an encoder
//! at the rear LEFT wheel, `H` to the left of the centre, so on a turn it reads
//! `v_e = v_c (1 - tan(steer) H / L)` and the centre speed is
//! `v_c = v_e / (1 - tan(steer) H / L)`. The rear axle centre of a bicycle-model car
//! moves on an arc of radius `L / tan(steer)`: a unicycle with `v = v_c` and
//! `omega = v_c tan(steer) / L`, integrated exactly by [`super::unicycle::unicycle`].
//!
//! The laser sits `a` forward and `b` left of the rear axle centre; trees are seen
//! from there. Guivant & Nebot write the state as the laser's position with Euler
//! steps of its velocity `v_c (cos phi, sin phi) + omega x (a, b)`; the test
//! `laser_point_matches_guivant_nebot_euler_step` checks that our laser point moves the
//! same way to first order in `dt`.

use nalgebra::{Matrix2, Matrix2x3, Matrix3, Point2, Vector2};

use super::unicycle::{Prediction, check_step, unicycle};
use crate::error::{Result, SlamError};
use crate::observation::{landmark_from_range_bearing, range_bearing};
use rperc_core::Pose2;

/// The Ackermann vehicle: controls `(encoder speed [m/s], steering angle [rad])`.
#[derive(
    Debug, Clone, Copy, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema,
)]
#[serde(default, deny_unknown_fields)]
pub struct Ackermann {
    /// Distance between the axles `L`, m (> 0; Victoria Park: 2.83).
    pub wheel_base: f64,
    /// Lateral offset `H` of the speed encoder (rear left wheel) from the rear axle
    /// centre, m (>= 0, < `wheel_base`; Victoria Park: 0.76).
    pub encoder_offset: f64,
    /// Laser position `a` ahead of the rear axle, m (Victoria Park: 3.78).
    pub laser_forward: f64,
    /// Laser position `b` left of the rear axle centre, m (Victoria Park: 0.50).
    pub laser_left: f64,
    /// Variance of the encoder speed noise, m^2/s^2 (>= 0; published: 0.2).
    pub speed_variance: f64,
    /// Variance of the steering angle noise, rad^2 (>= 0; published: 0.025).
    pub steering_variance: f64,
}

impl Default for Ackermann {
    fn default() -> Self {
        Self {
            wheel_base: 2.83,
            encoder_offset: 0.76,
            laser_forward: 3.78,
            laser_left: 0.50,
            speed_variance: 0.2,
            steering_variance: 0.025,
        }
    }
}

/// A range-bearing observation from the laser with its Jacobians.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LaserObservation {
    /// `(range, bearing)`, the bearing relative to the vehicle heading.
    pub z: Vector2<f64>,
    /// `dz/d(rear axle pose)`.
    pub h_pose: Matrix2x3<f64>,
    /// `dz/d(landmark)`.
    pub h_landmark: Matrix2<f64>,
}

impl Ackermann {
    /// Refuses bad values with the parameter's name.
    pub fn validate(&self) -> Result<()> {
        rperc_core::ensure_positive("wheel_base", self.wheel_base)?;
        rperc_core::ensure_non_negative("encoder_offset", self.encoder_offset)?;
        if self.encoder_offset >= self.wheel_base {
            // Otherwise 1 - tan(steer) H / L vanishes at a steering under 45 degrees.
            return Err(SlamError::invalid(
                "encoder_offset",
                format!(
                    "must be < wheel_base ({}), got {}",
                    self.wheel_base, self.encoder_offset
                ),
            ));
        }
        rperc_core::ensure_finite("laser_forward", [self.laser_forward].iter())?;
        rperc_core::ensure_finite("laser_left", [self.laser_left].iter())?;
        rperc_core::ensure_non_negative("speed_variance", self.speed_variance)?;
        rperc_core::ensure_non_negative("steering_variance", self.steering_variance)?;
        Ok(())
    }

    /// `(v_c, omega)` from `(v_e, steer)` and the 2x2 Jacobian `d(v_c, omega)/d(v_e, steer)`.
    pub fn centre_velocity(&self, speed: f64, steer: f64) -> Result<(Vector2<f64>, Matrix2<f64>)> {
        let (l, h) = (self.wheel_base, self.encoder_offset);
        let tan = steer.tan();
        let den = 1.0 - tan * h / l;
        if steer.abs() >= std::f64::consts::FRAC_PI_2 || den <= 0.0 {
            return Err(SlamError::invalid(
                "steering",
                format!("{steer} rad puts the encoder wheel on or beyond the turn centre"),
            ));
        }
        let sec2 = 1.0 + tan * tan;
        let vc = speed / den;
        let dvc_dsteer = speed * (h / l) * sec2 / (den * den);
        let omega = vc * tan / l;
        let j = Matrix2::new(
            1.0 / den,
            dvc_dsteer,
            tan / (l * den),
            (dvc_dsteer * tan + vc * sec2) / l,
        );
        Ok((Vector2::new(vc, omega), j))
    }

    /// One step with `control = (encoder speed, steering)`: the rear axle pose moves
    /// on an arc; `Fv` is wrt `(encoder speed, steering)`.
    pub fn predict(&self, pose: &Pose2, control: Vector2<f64>, dt: f64) -> Result<Prediction> {
        check_step(pose, [control.x, control.y], dt)?;
        let (centre, j) = self.centre_velocity(control.x, control.y)?;
        let p = unicycle(pose, centre.x, centre.y, dt);
        Ok(Prediction { fv: p.fv * j, ..p })
    }

    /// The covariance `V` of `(encoder speed, steering)` noise.
    pub fn control_noise(&self) -> Matrix2<f64> {
        Matrix2::new(self.speed_variance, 0.0, 0.0, self.steering_variance)
    }

    /// The laser's pose (heading = vehicle heading) and `d(laser pose)/d(pose)`.
    pub fn laser_pose(&self, pose: &Pose2) -> (Pose2, Matrix3<f64>) {
        let mount = Pose2::new(self.laser_forward, self.laser_left, 0.0);
        let (laser, j_pose, _) = pose.compose_with_jacobians(&mount);
        (laser, j_pose)
    }

    /// `(range, bearing)` of `landmark` from the laser, the bearing relative to the
    /// vehicle heading, with Jacobians wrt the rear axle pose and the landmark. `None`
    /// when the landmark sits on the laser.
    pub fn observe(&self, pose: &Pose2, landmark: &Point2<f64>) -> Option<LaserObservation> {
        let (laser, j_laser) = self.laser_pose(pose);
        let (z, h_laser, h_landmark) = range_bearing(&laser, landmark)?;
        Some(LaserObservation {
            z,
            h_pose: h_laser * j_laser,
            h_landmark,
        })
    }

    /// The landmark at `z = (range, bearing)` from the laser, with `dl/d(pose)` (2x3)
    /// and `dl/dz` (2x2): the inverse of [`Ackermann::observe`], for initialisation.
    pub fn landmark_from_observation(
        &self,
        pose: &Pose2,
        z: &Vector2<f64>,
    ) -> (Point2<f64>, Matrix2x3<f64>, Matrix2<f64>) {
        let (laser, j_laser) = self.laser_pose(pose);
        let (l, g_laser, g_z) = landmark_from_range_bearing(&laser, z);
        (l, g_laser * j_laser, g_z)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::unicycle::tests::numeric_jacobian;
    use nalgebra::Vector3;
    use proptest::prelude::*;
    use rperc_core::wrap_angle;

    fn pose(s: &[f64; 3]) -> Pose2 {
        Pose2 {
            x: s[0],
            y: s[1],
            theta: s[2],
        }
    }

    #[test]
    fn zero_steering_goes_straight_at_the_encoder_speed() {
        let car = Ackermann::default();
        let start = Pose2::new(-2.0, 1.0, 0.9);
        let p = car
            .predict(&start, Vector2::new(4.0, 0.0), 2.5)
            .unwrap()
            .pose();
        // With no steering v_c = v_e: 10 m along the heading.
        assert!((p.x - (-2.0 + 10.0 * 0.9f64.cos())).abs() < 1e-12);
        assert!((p.y - (1.0 + 10.0 * 0.9f64.sin())).abs() < 1e-12);
        assert_eq!(p.theta, start.theta);
    }

    #[test]
    fn constant_steering_circles_with_the_bicycle_radius() {
        // The rear axle centre turns about a centre L / tan(steer) to its left; half a
        // turn later it is one diameter away.
        let car = Ackermann::default();
        let (speed, steer) = (3.0, 0.3f64);
        let vc = speed / (1.0 - steer.tan() * car.encoder_offset / car.wheel_base);
        let radius = car.wheel_base / steer.tan();
        let half_period = std::f64::consts::PI * radius / vc;
        let start = Pose2::identity();
        let mut p = start;
        for _ in 0..500 {
            p = car
                .predict(&p, Vector2::new(speed, steer), half_period / 500.0)
                .unwrap()
                .pose();
        }
        assert!(
            (p.x).abs() < 1e-9 && (p.y - 2.0 * radius).abs() < 1e-9,
            "{p:?}"
        );
        assert!(
            (wrap_angle(p.theta) - std::f64::consts::PI).abs() < 1e-9
                || (wrap_angle(p.theta) + std::f64::consts::PI).abs() < 1e-9
        );
    }

    #[test]
    fn laser_point_matches_guivant_nebot_euler_step() {
        let car = Ackermann::default();
        let (a, b, l) = (car.laser_forward, car.laser_left, car.wheel_base);
        let start = Pose2::new(5.0, -3.0, 2.4);
        let (speed, steer) = (2.0, -0.35f64);
        let vc = speed / (1.0 - steer.tan() * car.encoder_offset / l);
        for dt in [1e-2, 1e-3] {
            let (laser0, _) = car.laser_pose(&start);
            let phi = start.theta;
            let w = vc * steer.tan() / l;
            // Their laser-point kinematics, one Euler step.
            let xl = laser0.x + dt * (vc * phi.cos() - w * (a * phi.sin() + b * phi.cos()));
            let yl = laser0.y + dt * (vc * phi.sin() + w * (a * phi.cos() - b * phi.sin()));
            let moved = car
                .predict(&start, Vector2::new(speed, steer), dt)
                .unwrap()
                .pose();
            let (laser1, _) = car.laser_pose(&moved);
            let gap = (laser1.translation() - Vector2::new(xl, yl)).norm();
            // Euler's local error: |acceleration of the laser point| dt^2 / 2, with the
            // acceleration ~ omega * |velocity| ~ 1.1 m/s^2 here.
            assert!(gap < 1.0 * dt * dt, "dt {dt}: gap {gap}");
        }
    }

    #[test]
    fn bad_steering_and_config_are_refused_by_name() {
        let car = Ackermann::default();
        let err = car
            .predict(&Pose2::identity(), Vector2::new(1.0, 1.5), 0.1)
            .unwrap_err();
        assert!(err.to_string().contains("steering"), "{err}");
        let bad = Ackermann {
            encoder_offset: 3.0,
            ..car
        };
        assert!(
            bad.validate()
                .unwrap_err()
                .to_string()
                .contains("encoder_offset")
        );
        assert!(
            Ackermann {
                wheel_base: 0.0,
                ..car
            }
            .validate()
            .is_err()
        );
        car.validate().unwrap();
    }

    fn landmark_near(p: Pose2) -> impl Strategy<Value = Point2<f64>> {
        let (x, y) = (p.x, p.y);
        (1.0..40.0f64, -3.2..3.2f64)
            .prop_map(move |(r, a)| Point2::new(x + r * a.cos(), y + r * a.sin()))
    }

    fn any_pose() -> impl Strategy<Value = Pose2> {
        (-50.0..50.0f64, -50.0..50.0f64, -3.2..3.2f64).prop_map(|(x, y, t)| Pose2 {
            x,
            y,
            theta: t,
        })
    }

    proptest! {
        #[test]
        fn prediction_jacobians_match_central_differences(
            start in any_pose(), speed in -1.0..7.0f64,
            steer in prop_oneof![-0.6..0.6f64, -1e-6..1e-6f64, Just(0.0)], dt in 0.001..1.0f64,
        ) {
            let car = Ackermann::default();
            let p = car.predict(&start, Vector2::new(speed, steer), dt).unwrap();
            let eps = 1e-6;
            let at = [start.x, start.y, start.theta];
            let fx = numeric_jacobian(
                |s| car.predict(&pose(s), Vector2::new(speed, steer), dt).unwrap().mean, at, eps);
            let fv = numeric_jacobian(
                |u: &[f64; 2]| car.predict(&start, Vector2::new(u[0], u[1]), dt).unwrap().mean,
                [speed, steer], eps);
            prop_assert!((fx - p.fx).abs().max() < 1e-6, "Fx {} vs {}", p.fx, fx);
            prop_assert!((fv - p.fv).abs().max() < 1e-6, "Fv {} vs {}", p.fv, fv);
        }

        #[test]
        fn observation_jacobians_and_inverse(
            (start, lm) in any_pose().prop_flat_map(|p| (Just(p), landmark_near(p))),
        ) {
            let car = Ackermann::default();
            let Some(o) = car.observe(&start, &lm) else { return Ok(()) };
            let eps = 1e-6;
            // Range in row 0, bearing in row 2: numeric_jacobian differences its third
            // row with wrapping.
            let as_pose = |z: Vector2<f64>| Vector3::new(z.x, 0.0, z.y);
            let hp = numeric_jacobian(
                |s| as_pose(car.observe(&pose(s), &lm).unwrap().z), [start.x, start.y, start.theta], eps);
            let hl = numeric_jacobian(
                |q: &[f64; 2]| as_pose(car.observe(&start, &Point2::new(q[0], q[1])).unwrap().z),
                [lm.x, lm.y], eps);
            for c in 0..3 {
                prop_assert!((hp[(0, c)] - o.h_pose[(0, c)]).abs() < 1e-6);
                prop_assert!((hp[(2, c)] - o.h_pose[(1, c)]).abs() < 1e-6);
            }
            for c in 0..2 {
                prop_assert!((hl[(0, c)] - o.h_landmark[(0, c)]).abs() < 1e-6);
                prop_assert!((hl[(2, c)] - o.h_landmark[(1, c)]).abs() < 1e-6);
            }
            // The inverse returns the landmark, and its Jacobians against differences.
            let (back, g_pose, g_z) = car.landmark_from_observation(&start, &o.z);
            prop_assert!((back - lm).norm() < 1e-9);
            let at = [start.x, start.y, start.theta];
            for c in 0..3 {
                let (mut a, mut b) = (at, at);
                a[c] += eps;
                b[c] -= eps;
                let d = (car.landmark_from_observation(&pose(&a), &o.z).0
                    - car.landmark_from_observation(&pose(&b), &o.z).0) / (2.0 * eps);
                prop_assert!((d - g_pose.column(c)).norm() < 1e-6);
            }
            for c in 0..2 {
                let (mut a, mut b) = (o.z, o.z);
                a[c] += eps;
                b[c] -= eps;
                let d = (car.landmark_from_observation(&start, &a).0
                    - car.landmark_from_observation(&start, &b).0) / (2.0 * eps);
                prop_assert!((d - g_z.column(c)).norm() < 1e-6);
            }
        }
    }
}
