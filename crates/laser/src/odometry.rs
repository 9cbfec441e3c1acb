//! Odometry between scans: unicycle controls `(t, v, omega)` integrated from one scan
//! time to the next, as the step `u` (the new pose in the old one's frame) with the
//! covariance its control noise gives (eqs. 3 and 5 of the first seed, the EKF's own
//! prediction with the pose held at the origin).

use nalgebra::{Matrix2, Matrix3, Vector2};
use rperc_core::Pose2;
use slam::motion::Unicycle;

use crate::error::{LaserError, Result};

/// Added to every step's covariance (1 mm, 1 mrad): a step with no control between
/// its scans (two scans at one time, a robot standing still) would otherwise claim to
/// be known exactly, and a pose graph of such steps is numerically singular.
const FLOOR: [f64; 3] = [1e-6, 1e-6, 1e-6];

/// One odometry step and its covariance (in the frame of the step's start).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Step {
    /// The new pose seen from the old one.
    pub motion: Pose2,
    /// Its covariance over `(x, y, theta)`.
    pub covariance: Matrix3<f64>,
}

/// The steps between consecutive scan times `times` (non-decreasing, `S` of them:
/// `S - 1` steps) from `controls` rows `(t, v, omega)` sorted by time, each held
/// until the next one's time; `model` gives the control noise. A scan before the
/// first control, or a control time going back, is an error.
pub fn steps(controls: &[[f64; 3]], times: &[f64], model: &Unicycle) -> Result<Vec<Step>> {
    check(controls, times)?;
    let noise: Matrix2<f64> = model.control_noise();
    let mut out = Vec::with_capacity(times.len().saturating_sub(1));
    let mut c = 0; // the control in force at the current time
    for w in times.windows(2) {
        let (mut t, end) = (w[0], w[1]);
        let mut pose = Pose2::identity();
        let mut cov = Matrix3::from_diagonal(&FLOOR.into());
        while t < end {
            while c + 1 < controls.len() && controls[c + 1][0] <= t {
                c += 1;
            }
            let until = controls.get(c + 1).map_or(end, |next| next[0].min(end));
            let p = model.predict(
                &pose,
                Vector2::new(controls[c][1], controls[c][2]),
                until - t,
            )?;
            cov = p.fx * cov * p.fx.transpose() + p.fv * noise * p.fv.transpose();
            pose = p.pose();
            t = until;
        }
        out.push(Step {
            motion: pose,
            covariance: (cov + cov.transpose()) * 0.5,
        });
    }
    Ok(out)
}

fn check(controls: &[[f64; 3]], times: &[f64]) -> Result<()> {
    if controls.is_empty() {
        return Err(LaserError::dimension("no odometry controls".into()));
    }
    if controls
        .iter()
        .flatten()
        .chain(times)
        .any(|v| !v.is_finite())
    {
        return Err(LaserError::Core(rperc_core::CoreError::NonFinite(
            "controls or scan times",
        )));
    }
    if let Some(k) = controls.windows(2).position(|w| w[1][0] < w[0][0]) {
        return Err(LaserError::invalid(
            "controls",
            format!(
                "time goes back at row {}: {} after {}",
                k + 1,
                controls[k + 1][0],
                controls[k][0]
            ),
        ));
    }
    if let Some(k) = times.windows(2).position(|w| w[1] < w[0]) {
        return Err(LaserError::invalid(
            "times",
            format!(
                "scan time goes back at scan {}: {} after {}",
                k + 1,
                times[k + 1],
                times[k]
            ),
        ));
    }
    if times.first().is_some_and(|&t0| t0 < controls[0][0]) {
        return Err(LaserError::invalid(
            "times",
            format!(
                "the first scan ({}) is before the first control ({})",
                times[0], controls[0][0]
            ),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Straight driving: the step is the distance, its along-track variance the speed
    /// noise times the duration squared (closed form).
    #[test]
    fn straight_step_has_the_closed_form_variance() {
        let model = Unicycle {
            speed_variance: 0.01,
            turn_rate_variance: 0.0001,
        };
        let controls = [[0.0, 2.0, 0.0]];
        let out = steps(&controls, &[0.0, 0.5], &model).unwrap();
        let s = out[0];
        assert!((s.motion.x - 1.0).abs() < 1e-12 && s.motion.y.abs() < 1e-12);
        assert!((s.covariance[(0, 0)] - (0.01 * 0.25 + FLOOR[0])).abs() < 1e-12);
        assert!((s.covariance[(2, 2)] - (0.0001 * 0.25 + FLOOR[2])).abs() < 1e-12);
    }

    /// Controls split anywhere give the same step as one long control (composition).
    #[test]
    fn a_step_spans_its_controls() {
        let model = Unicycle::default();
        let one = steps(&[[0.0, 1.0, 0.4]], &[0.0, 2.0], &model).unwrap()[0];
        let split = steps(
            &[[0.0, 1.0, 0.4], [0.7, 1.0, 0.4], [1.3, 1.0, 0.4]],
            &[0.0, 2.0],
            &model,
        )
        .unwrap()[0];
        assert!((one.motion.to_vector() - split.motion.to_vector()).norm() < 1e-12);
    }

    #[test]
    fn bad_input_is_refused() {
        let m = Unicycle::default();
        assert!(steps(&[], &[0.0, 1.0], &m).is_err());
        assert!(steps(&[[0.0, f64::NAN, 0.0]], &[0.0, 1.0], &m).is_err());
        assert!(steps(&[[1.0, 1.0, 0.0], [0.5, 1.0, 0.0]], &[1.0, 2.0], &m).is_err());
        assert!(steps(&[[0.0, 1.0, 0.0]], &[2.0, 1.0], &m).is_err());
        assert!(steps(&[[1.0, 1.0, 0.0]], &[0.0, 2.0], &m).is_err());
    }
}
