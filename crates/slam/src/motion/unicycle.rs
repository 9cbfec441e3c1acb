//! The unicycle (MR.CLAM's robots): a constant `(v, omega)` integrated exactly over
//! `dt`, so the robot moves on an arc, with the analytic Jacobians of the
//! prediction; the Ackermann vehicle reuses the same arc.

use nalgebra::{DMatrix, DVector, Matrix2, Matrix3, Matrix3x2, Vector2, Vector3};

use crate::error::{Result, SlamError};
use rperc_core::{Pose2, wrap_angle};

// The chord of an arc, shared with the ceiling world's robot (one place: the core).
pub(crate) use rperc_core::pose::arc_functions;

/// A predicted robot pose with its Jacobians.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prediction {
    /// The new robot mean `(x, y, theta)`, heading wrapped.
    pub mean: Vector3<f64>,
    /// `d(mean)/d(pose)`.
    pub fx: Matrix3<f64>,
    /// `d(mean)/d(control)`, the control being the model's two noisy inputs.
    pub fv: Matrix3x2<f64>,
}

impl Prediction {
    /// The new pose.
    pub fn pose(&self) -> Pose2 {
        Pose2::from_vector(&self.mean)
    }

    /// `(robot mean, Fx, Fv)` as the dynamic matrices [`crate::Ekf::predict`] takes.
    pub fn to_dynamic(&self) -> (DVector<f64>, DMatrix<f64>, DMatrix<f64>) {
        (
            DVector::from_column_slice(self.mean.as_slice()),
            DMatrix::from_column_slice(3, 3, self.fx.as_slice()),
            DMatrix::from_column_slice(3, 2, self.fv.as_slice()),
        )
    }
}

/// Unicycle motion: speed `v` along the heading and turn rate `omega`, both constant
/// over `dt`, integrated exactly (an arc of radius `v / omega`; a straight segment in
/// the limit `omega -> 0`, continuously). Jacobians wrt the pose and wrt `(v, omega)`.
///
/// # Examples
/// ```
/// use rperc_core::Pose2;
/// use slam::motion::unicycle;
///
/// // A quarter turn of radius 1 m: from the origin facing +x to (1, 1) facing +y.
/// let omega = 1.0;
/// let p = unicycle(&Pose2::identity(), 1.0, omega, std::f64::consts::FRAC_PI_2);
/// assert!((p.pose().x - 1.0).abs() < 1e-12 && (p.pose().y - 1.0).abs() < 1e-12);
/// ```
pub fn unicycle(pose: &Pose2, v: f64, omega: f64, dt: f64) -> Prediction {
    let phi = omega * dt;
    let (f, df, g, dg) = arc_functions(phi);
    let (s, c) = pose.theta.sin_cos();
    let d = v * dt; // arc length
    // Chord in the robot frame: d (f, g); rotated into the world by theta.
    let dx = d * (c * f - s * g);
    let dy = d * (s * f + c * g);
    let mean = Vector3::new(pose.x + dx, pose.y + dy, wrap_angle(pose.theta + phi));
    let fx = Matrix3::new(1.0, 0.0, -dy, 0.0, 1.0, dx, 0.0, 0.0, 1.0);
    // d/dv: the chord scales with d = v dt; d/domega through phi = omega dt.
    let fv = Matrix3x2::new(
        dt * (c * f - s * g),
        d * dt * (c * df - s * dg),
        dt * (s * f + c * g),
        d * dt * (s * df + c * dg),
        0.0,
        dt,
    );
    Prediction { mean, fx, fv }
}

/// Refuses a non-finite pose or control, or a negative or non-finite time step.
pub(crate) fn check_step(pose: &Pose2, control: [f64; 2], dt: f64) -> Result<()> {
    rperc_core::ensure_finite("pose", [pose.x, pose.y, pose.theta].iter())?;
    rperc_core::ensure_finite("control", control.iter())?;
    if !(dt.is_finite() && dt >= 0.0) {
        return Err(SlamError::invalid(
            "dt",
            format!("must be finite and >= 0, got {dt}"),
        ));
    }
    Ok(())
}

/// The unicycle of MR.CLAM: controls `(v [m/s], omega [rad/s])`, white noise on each.
#[derive(
    Debug, Clone, Copy, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema,
)]
#[serde(default, deny_unknown_fields)]
pub struct Unicycle {
    /// Variance of the speed command noise, m^2/s^2 (>= 0).
    pub speed_variance: f64,
    /// Variance of the turn-rate command noise, rad^2/s^2 (>= 0).
    pub turn_rate_variance: f64,
}

impl Default for Unicycle {
    fn default() -> Self {
        // Placeholders of the right order for MR.CLAM's commands (0.1 m/s, 0.1 rad/s
        // standard deviations); the EKF study tunes them.
        Self {
            speed_variance: 0.01,
            turn_rate_variance: 0.01,
        }
    }
}

impl Unicycle {
    /// Refuses bad values with the parameter's name.
    pub fn validate(&self) -> Result<()> {
        rperc_core::ensure_non_negative("speed_variance", self.speed_variance)?;
        rperc_core::ensure_non_negative("turn_rate_variance", self.turn_rate_variance)?;
        Ok(())
    }

    /// One step with `control = (v, omega)`.
    pub fn predict(&self, pose: &Pose2, control: Vector2<f64>, dt: f64) -> Result<Prediction> {
        check_step(pose, [control.x, control.y], dt)?;
        Ok(unicycle(pose, control.x, control.y, dt))
    }

    /// The covariance `V` of the `(v, omega)` noise, held over a step (`Fv` already
    /// carries `dt`).
    pub fn control_noise(&self) -> Matrix2<f64> {
        Matrix2::new(self.speed_variance, 0.0, 0.0, self.turn_rate_variance)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Central differences of a pose-valued function, the heading differenced with
    /// wrapping so that a result crossing +-pi does not produce a 2 pi jump.
    pub(crate) fn numeric_jacobian<const N: usize>(
        f: impl Fn(&[f64; N]) -> Vector3<f64>,
        at: [f64; N],
        eps: f64,
    ) -> nalgebra::SMatrix<f64, 3, N> {
        let mut j = nalgebra::SMatrix::<f64, 3, N>::zeros();
        for k in 0..N {
            let (mut a, mut b) = (at, at);
            a[k] += eps;
            b[k] -= eps;
            let (fa, fb) = (f(&a), f(&b));
            let d = Vector3::new(fa.x - fb.x, fa.y - fb.y, wrap_angle(fa.z - fb.z));
            j.set_column(k, &(d / (2.0 * eps)));
        }
        j
    }

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol * (1.0 + a.abs().max(b.abs()))
    }

    #[test]
    fn full_circle_returns_to_the_start() {
        let start = Pose2::new(0.3, -1.2, 2.0);
        for (v, omega) in [(0.5, 0.7), (1.3, -0.2), (0.1, 3.0)] {
            let period = 2.0 * std::f64::consts::PI / f64::abs(omega);
            // In many small steps and in one step: both are exact arcs.
            let mut pose = start;
            let steps = 1000;
            for _ in 0..steps {
                pose = unicycle(&pose, v, omega, period / steps as f64).pose();
            }
            let once = unicycle(&start, v, omega, period).pose();
            for p in [pose, once] {
                assert!((p.translation() - start.translation()).norm() < 1e-9);
                assert!(wrap_angle(p.theta - start.theta).abs() < 1e-9);
            }
            // Half way round, the robot is one diameter 2 v / |omega| away, facing back.
            let half = unicycle(&start, v, omega, period / 2.0).pose();
            let diameter = 2.0 * v / f64::abs(omega);
            assert!(close(
                (half.translation() - start.translation()).norm(),
                diameter,
                1e-12
            ));
            assert!(close(
                wrap_angle(half.theta - start.theta).abs(),
                std::f64::consts::PI,
                1e-12
            ));
        }
    }

    #[test]
    fn zero_turn_rate_goes_straight() {
        let start = Pose2::new(1.0, 2.0, 0.4);
        let p = unicycle(&start, 2.0, 0.0, 3.0).pose();
        assert!(close(p.x, 1.0 + 6.0 * 0.4f64.cos(), 1e-14));
        assert!(close(p.y, 2.0 + 6.0 * 0.4f64.sin(), 1e-14));
        assert_eq!(p.theta, start.theta);
    }

    #[test]
    fn bad_steps_are_refused_with_the_parameter_name() {
        let m = Unicycle::default();
        let err = m.predict(&Pose2::identity(), Vector2::new(1.0, 0.0), -1.0);
        assert!(err.unwrap_err().to_string().contains("dt"));
        let err = m.predict(&Pose2::identity(), Vector2::new(f64::NAN, 0.0), 1.0);
        assert!(err.unwrap_err().to_string().contains("control"));
        let bad = Unicycle {
            speed_variance: -1.0,
            ..Unicycle::default()
        };
        assert!(
            bad.validate()
                .unwrap_err()
                .to_string()
                .contains("speed_variance")
        );
    }

    fn turn_rate() -> impl Strategy<Value = f64> {
        // Ordinary turn rates, tiny ones around the series switch, and exactly zero.
        prop_oneof![-3.0..3.0f64, -1e-2..1e-2f64, -1e-7..1e-7f64, Just(0.0)]
    }

    proptest! {
        #[test]
        fn unicycle_jacobians_match_central_differences(
            x in -10.0..10.0f64, y in -10.0..10.0f64, theta in -3.2..3.2f64,
            v in -2.0..2.0f64, omega in turn_rate(), dt in 0.001..2.0f64,
        ) {
            let p = unicycle(&Pose2 { x, y, theta }, v, omega, dt);
            let eps = 1e-6;
            let fx = numeric_jacobian(
                |s: &[f64; 3]| unicycle(&Pose2 { x: s[0], y: s[1], theta: s[2] }, v, omega, dt).mean,
                [x, y, theta], eps);
            let fv = numeric_jacobian(
                |u: &[f64; 2]| unicycle(&Pose2 { x, y, theta }, u[0], u[1], dt).mean,
                [v, omega], eps);
            // Central differences err by ~eps^2 |f'''| + 1e-16 |f| / eps.
            prop_assert!((fx - p.fx).abs().max() < 1e-7, "Fx {} vs {}", p.fx, fx);
            prop_assert!((fv - p.fv).abs().max() < 1e-7, "Fv {} vs {}", p.fv, fv);
        }

        #[test]
        fn tiny_turn_rates_approach_the_straight_line(
            theta in -3.2..3.2f64, v in -2.0..2.0f64, omega in -1e-9..1e-9f64, dt in 0.0..2.0f64,
        ) {
            let start = Pose2 { x: 0.0, y: 0.0, theta };
            let p = unicycle(&start, v, omega, dt).pose();
            // The arc deviates from the chord-free straight line by ~ v dt^2 |omega| / 2.
            let tol = 1e-12 + (v * dt * dt * omega).abs();
            prop_assert!((p.x - v * dt * theta.cos()).abs() <= tol);
            prop_assert!((p.y - v * dt * theta.sin()).abs() <= tol);
        }
    }
}
