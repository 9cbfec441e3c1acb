//! Planar motion models with analytic Jacobians, for the EKF's O(n) prediction
//! (eqs. (3) and (5) of the seed paper): every model returns the new robot mean with
//! `Fx = df/d(pose)` (3x3) and `Fv = df/d(control)` (3x2), touching only the robot
//! block, so that [`crate::Ekf::predict`] can propagate `P <- Fx P Fx^T + Fv V Fv^T`
//! with `V` the covariance of the control noise.
//!
//! The unicycle (MR.CLAM's robots) is in [`mod@unicycle`]; the Ackermann vehicle
//! (Victoria Park's utility car) is in [`ackermann`] and reuses the same arc.

pub mod ackermann;
pub mod unicycle;

use nalgebra::{Matrix2, Vector2};
use rperc_core::Pose2;

pub use self::ackermann::Ackermann;
pub use self::unicycle::{Prediction, Unicycle, unicycle};
use crate::error::Result;

/// Which vehicle moves the robot, with its parameters; spelled in configs as
/// `{"unicycle": {...}}` or `{"ackermann": {...}}`.
#[derive(
    Debug, Clone, Copy, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum MotionModel {
    /// Speed and turn rate (MR.CLAM).
    Unicycle(Unicycle),
    /// Rear-wheel encoder speed and steering angle (Victoria Park).
    Ackermann(Ackermann),
}

impl Default for MotionModel {
    fn default() -> Self {
        MotionModel::Unicycle(Unicycle::default())
    }
}

impl MotionModel {
    /// Refuses bad values with the parameter's name.
    pub fn validate(&self) -> Result<()> {
        match self {
            MotionModel::Unicycle(m) => m.validate(),
            MotionModel::Ackermann(m) => m.validate(),
        }
    }

    /// One prediction step with the model's two controls.
    pub fn predict(&self, pose: &Pose2, control: Vector2<f64>, dt: f64) -> Result<Prediction> {
        match self {
            MotionModel::Unicycle(m) => m.predict(pose, control, dt),
            MotionModel::Ackermann(m) => m.predict(pose, control, dt),
        }
    }

    /// The covariance `V` of the two controls' noise.
    pub fn control_noise(&self) -> Matrix2<f64> {
        match self {
            MotionModel::Unicycle(m) => m.control_noise(),
            MotionModel::Ackermann(m) => m.control_noise(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn config_round_trips_and_refuses_unknown_fields() {
        let json = r#"{"ackermann": {"wheel_base": 2.5}}"#;
        let m: MotionModel = serde_json::from_str(json).unwrap();
        match m {
            MotionModel::Ackermann(a) => assert_eq!(a.wheel_base, 2.5),
            MotionModel::Unicycle(_) => panic!("wrong variant"),
        }
        m.validate().unwrap();
        let back: MotionModel = serde_json::from_str(&serde_json::to_string(&m).unwrap()).unwrap();
        assert_eq!(back, m);
        assert!(serde_json::from_str::<MotionModel>(r#"{"unicycle": {"speed": 1}}"#).is_err());
        assert!(serde_json::from_str::<MotionModel>(r#"{"bicycle": {}}"#).is_err());
    }
}
