//! Systematic errors of the sensors, removed from every input before the filter sees
//! it. The model is the one calibrated for MR.CLAM's cameras (see
//! `rperc.slam.calibration` in Python, which fits it offline from one robot's ground
//! truth; nothing here reads ground truth at run time):
//!
//! - bearing: `b_measured = bearing_offset + bearing_scale * b`;
//! - range: `r_measured = range_offset + range_scale * q`, where `q` is the range `r`,
//!   or, when `range_is_depth`, the depth along the optical axis `r cos(b)` (a camera
//!   that sizes a target by its apparent height measures depth, not range);
//! - controls: `u_measured = u / control_scale` per control (odometry that reads long
//!   or short by a constant factor).
//!
//! The identity (the default) changes nothing. The variances of the config describe
//! the noise left after the correction.

use nalgebra::{Matrix2, Matrix3, Matrix3x2, Vector2, Vector3};
use rperc_core::Pose2;

use crate::error::ensure_finite;
use crate::error::{Result, SlamError};
use crate::motion::MotionModel;

/// The sensors' biases, removed from every input. Bearing:
/// `b_measured = bearing_offset + bearing_scale * b`. Range:
/// `r_measured = range_offset + range_scale * q`, `q` the range, or the depth
/// `r cos(b)` when `range_is_depth`. Controls: `u_measured = u / control_scale`. The
/// identity (the default) changes nothing.
#[derive(
    Debug, Clone, Copy, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema,
)]
#[serde(default, deny_unknown_fields)]
pub struct SensorBias {
    /// Range offset, m.
    pub range_offset: f64,
    /// Range scale (> 0).
    pub range_scale: f64,
    /// The sensor reports the depth `r cos(b)` instead of the range `r`.
    pub range_is_depth: bool,
    /// Bearing offset, rad.
    pub bearing_offset: f64,
    /// Bearing scale (> 0).
    pub bearing_scale: f64,
    /// Factors applied to the two controls (> 0): the true control is the measured
    /// one times this.
    pub control_scale: [f64; 2],
}

impl Default for SensorBias {
    fn default() -> Self {
        Self {
            range_offset: 0.0,
            range_scale: 1.0,
            range_is_depth: false,
            bearing_offset: 0.0,
            bearing_scale: 1.0,
            control_scale: [1.0, 1.0],
        }
    }
}

impl SensorBias {
    /// Refuses non-finite values and non-positive scales, naming the field.
    pub fn validate(&self) -> Result<()> {
        ensure_finite("bias.range_offset", [self.range_offset].iter())?;
        ensure_finite("bias.bearing_offset", [self.bearing_offset].iter())?;
        let scales = [
            ("bias.range_scale", self.range_scale),
            ("bias.bearing_scale", self.bearing_scale),
            ("bias.control_scale", self.control_scale[0]),
            ("bias.control_scale", self.control_scale[1]),
        ];
        for (name, s) in scales {
            if !(s.is_finite() && s > 0.0) {
                return Err(SlamError::invalid(name, format!("must be > 0, got {s}")));
            }
        }
        Ok(())
    }

    /// The true `(range, bearing)` of a measured pair: the inverse of the model. A
    /// depth seen at a bearing of 90 degrees or more has no range, which is an error.
    pub fn correct_detection(&self, range: f64, bearing: f64) -> Result<(f64, f64)> {
        let b = (bearing - self.bearing_offset) / self.bearing_scale;
        let q = (range - self.range_offset) / self.range_scale;
        if !self.range_is_depth {
            return Ok((q, b));
        }
        let c = b.cos();
        if c <= 0.0 {
            return Err(SlamError::invalid(
                "bearing",
                format!("a depth sensor cannot see at bearing {b} rad (|b| >= pi/2)"),
            ));
        }
        Ok((q / c, b))
    }

    /// The true controls of measured ones.
    pub fn correct_control(&self, control: [f64; 2]) -> [f64; 2] {
        [
            control[0] * self.control_scale[0],
            control[1] * self.control_scale[1],
        ]
    }

    /// The measured `(range, bearing)` of a true pair: the forward model (for
    /// simulation and tests).
    pub fn distort_detection(&self, range: f64, bearing: f64) -> (f64, f64) {
        let q = if self.range_is_depth {
            range * bearing.cos()
        } else {
            range
        };
        (
            self.range_offset + self.range_scale * q,
            self.bearing_offset + self.bearing_scale * bearing,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn mrclam_like() -> SensorBias {
        SensorBias {
            range_offset: 0.045,
            range_scale: 1.015,
            range_is_depth: true,
            bearing_offset: 2e-4,
            bearing_scale: 0.976,
            control_scale: [0.95, 0.93],
        }
    }

    #[test]
    fn identity_changes_nothing() {
        let b = SensorBias::default();
        assert_eq!(b.correct_detection(2.5, -0.3).unwrap(), (2.5, -0.3));
        assert_eq!(b.correct_control([0.2, -0.1]), [0.2, -0.1]);
    }

    #[test]
    fn depth_camera_closed_form() {
        // A target 2 m away at 60 degrees: the camera's depth is 2 cos(60 deg) = 1 m.
        let b = SensorBias {
            range_is_depth: true,
            ..SensorBias::default()
        };
        let b60 = std::f64::consts::FRAC_PI_3;
        let (r, bearing) = b.correct_detection(1.0, b60).unwrap();
        assert!((r - 2.0).abs() < 1e-12 && (bearing - b60).abs() < 1e-15);
        let err = b.correct_detection(1.0, 2.0).unwrap_err().to_string();
        assert!(err.contains("bearing"), "{err}");
    }

    #[test]
    fn validate_names_the_field() {
        let bad = SensorBias {
            range_scale: 0.0,
            ..SensorBias::default()
        };
        assert!(
            bad.validate()
                .unwrap_err()
                .to_string()
                .contains("range_scale")
        );
        let bad = SensorBias {
            bearing_offset: f64::NAN,
            ..SensorBias::default()
        };
        assert!(
            bad.validate()
                .unwrap_err()
                .to_string()
                .contains("bearing_offset")
        );
        assert!(mrclam_like().validate().is_ok());
    }

    proptest! {
        /// The correction inverts the forward model.
        #[test]
        fn correction_inverts_the_model(r in 0.1..10.0f64, b in -1.4..1.4f64) {
            let bias = mrclam_like();
            let (rm, bm) = bias.distort_detection(r, b);
            let (r2, b2) = bias.correct_detection(rm, bm).unwrap();
            prop_assert!((r2 - r).abs() < 1e-9 && (b2 - b).abs() < 1e-12);
        }
    }
}

/// A pose predicted with control-bias states, with its Jacobians.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BiasedPrediction {
    /// The new pose `(x, y, theta)`.
    pub mean: Vector3<f64>,
    /// With respect to the pose (3x3).
    pub fx: Matrix3<f64>,
    /// With respect to the biases `(s, b)`: `Fv diag(-u0, -1)` (3x2).
    pub fb: Matrix3x2<f64>,
    /// With respect to the true controls' noise (3x2).
    pub fv: Matrix3x2<f64>,
}

/// The prediction of a robot block `(x, y, theta, s, b)` with unknown control biases
/// (`PlanarConfig::control_bias_sd`): the pose moves under the true controls
/// `(u0 (1 - s), u1 - b)`, the biases stay.
pub fn predict_biased(
    motion: &MotionModel,
    pose: &Pose2,
    control: Vector2<f64>,
    bias: Vector2<f64>,
    dt: f64,
) -> Result<BiasedPrediction> {
    let true_control = Vector2::new(control.x * (1.0 - bias.x), control.y - bias.y);
    let p = motion.predict(pose, true_control, dt)?;
    Ok(BiasedPrediction {
        mean: p.mean,
        fx: p.fx,
        fb: p.fv * Matrix2::new(-control.x, 0.0, 0.0, -1.0),
        fv: p.fv,
    })
}

#[cfg(test)]
mod control_bias_tests {
    use super::*;
    use crate::ackermann::Ackermann;
    use crate::motion::Unicycle;
    use proptest::prelude::*;

    proptest! {
        /// `Fx`, `Fb` and `Fv` against central differences of the biased prediction,
        /// for both vehicles.
        #[test]
        fn biased_prediction_jacobians_match_central_differences(
            x in -5.0..5.0f64, y in -5.0..5.0f64, th in -3.0..3.0f64,
            v in -2.0..2.0f64, w in -0.5..0.5f64, s in -0.1..0.1f64, b in -0.05..0.05f64,
            ackermann in any::<bool>(),
        ) {
            let motion = if ackermann {
                MotionModel::Ackermann(Ackermann::default())
            } else {
                MotionModel::Unicycle(Unicycle::default())
            };
            let dt = 0.3;
            let at = [x, y, th, s, b, 0.0, 0.0];
            // The state (pose, bias) and an additive noise on the true control.
            let f = |q: &[f64; 7]| {
                let pose = Pose2::new(q[0], q[1], q[2]);
                let noisy = Vector2::new(v * (1.0 - q[3]) + q[5], w - q[4] + q[6]);
                motion.predict(&pose, noisy, dt).unwrap().mean
            };
            let num = crate::motion::unicycle::tests::numeric_jacobian(f, at, 1e-6);
            let BiasedPrediction { fx, fb, fv, .. } =
                predict_biased(&motion, &Pose2::new(x, y, th), Vector2::new(v, w), Vector2::new(s, b), dt)
                    .unwrap();
            prop_assert!((num.fixed_columns::<3>(0) - fx).abs().max() < 1e-5, "{} {}", num, fx);
            prop_assert!((num.fixed_columns::<2>(3) - fb).abs().max() < 1e-5, "{} {}", num, fb);
            prop_assert!((num.fixed_columns::<2>(5) - fv).abs().max() < 1e-5, "{} {}", num, fv);
        }
    }
}
