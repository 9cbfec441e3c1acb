//! The planar range-bearing observation of a point landmark, its Jacobians and its
//! inverse (for landmark initialisation), with the matching EKF helpers.

use nalgebra::{DMatrix, DVector, Matrix2, Matrix2x3, Point2, Vector2};

use crate::ekf::{Ekf, Gated, SparseJacobian, Update};
use crate::error::{Result, SlamError};
use rperc_core::{Pose2, wrap_angle};

/// `z = (range, bearing)` of `landmark` seen from `robot`, with `dz/d(robot)` (2x3)
/// and `dz/d(landmark)` (2x2). `None` when the landmark sits on the robot.
pub fn range_bearing(
    robot: &Pose2,
    landmark: &Point2<f64>,
) -> Option<(Vector2<f64>, Matrix2x3<f64>, Matrix2<f64>)> {
    let (dx, dy) = (landmark.x - robot.x, landmark.y - robot.y);
    let q = dx * dx + dy * dy;
    if q == 0.0 || !q.is_finite() {
        return None;
    }
    let r = q.sqrt();
    let z = Vector2::new(r, wrap_angle(dy.atan2(dx) - robot.theta));
    let h_robot = Matrix2x3::new(-dx / r, -dy / r, 0.0, dy / q, -dx / q, -1.0);
    let h_landmark = Matrix2::new(dx / r, dy / r, -dy / q, dx / q);
    Some((z, h_robot, h_landmark))
}

/// The landmark at `z = (range, bearing)` from `robot`, with `dl/d(robot)` (2x3) and
/// `dl/dz` (2x2).
pub fn landmark_from_range_bearing(
    robot: &Pose2,
    z: &Vector2<f64>,
) -> (Point2<f64>, Matrix2x3<f64>, Matrix2<f64>) {
    let a = robot.theta + z.y;
    let (s, c) = a.sin_cos();
    let l = Point2::new(robot.x + z.x * c, robot.y + z.x * s);
    let g_robot = Matrix2x3::new(1.0, 0.0, -z.x * s, 0.0, 1.0, z.x * c);
    let g_z = Matrix2::new(c, -z.x * s, s, z.x * c);
    (l, g_robot, g_z)
}

impl Ekf {
    fn planar_robot(&self) -> Result<Pose2> {
        if self.robot_dim() != 3 || self.landmark_dim() != 2 {
            return Err(SlamError::dimension(format!(
                "range-bearing needs a planar robot (3) and point landmarks (2), not {} and {}",
                self.robot_dim(),
                self.landmark_dim()
            )));
        }
        let x = self.state();
        Ok(Pose2 {
            x: x[0],
            y: x[1],
            theta: x[2],
        })
    }

    /// `(innovation, H, R)` of a range-bearing observation `z` of landmark `j`, the
    /// bearing innovation wrapped to (-pi, pi].
    fn range_bearing_observation(
        &self,
        j: usize,
        z: &Vector2<f64>,
        r: &Matrix2<f64>,
    ) -> Result<(DVector<f64>, SparseJacobian, DMatrix<f64>)> {
        let robot = self.planar_robot()?;
        let off = self.landmark_offset(j)?;
        rperc_core::ensure_finite("z", z.iter())?;
        let landmark = Point2::new(self.state()[off], self.state()[off + 1]);
        let (predicted, h_robot, h_landmark) =
            range_bearing(&robot, &landmark).ok_or_else(|| {
                SlamError::SingularInnovation(format!("landmark {j} sits on the robot"))
            })?;
        let nu = DVector::from_vec(vec![z.x - predicted.x, wrap_angle(z.y - predicted.y)]);
        let h = SparseJacobian::new(2)
            .with_block(0, 0, DMatrix::from_column_slice(2, 3, h_robot.as_slice()))
            .with_block(
                0,
                off,
                DMatrix::from_column_slice(2, 2, h_landmark.as_slice()),
            );
        Ok((nu, h, DMatrix::from_column_slice(2, 2, r.as_slice())))
    }

    /// Update with a range-bearing observation `z` of landmark `j` (noise `R`). The
    /// heading (state entry 2) is wrapped after the update. No gate: see
    /// [`Ekf::update_range_bearing_gated`].
    pub fn update_range_bearing(
        &mut self,
        j: usize,
        z: &Vector2<f64>,
        r: &Matrix2<f64>,
    ) -> Result<Update> {
        let (nu, h, r) = self.range_bearing_observation(j, z, r)?;
        self.ensure_wrapped_angle(2);
        self.update(&nu, &h, &r)
    }

    /// [`Ekf::update_range_bearing`] behind a chi-square gate on its NIS: an outlier
    /// is reported as [`Gated::Rejected`] and changes nothing.
    pub fn update_range_bearing_gated(
        &mut self,
        j: usize,
        z: &Vector2<f64>,
        r: &Matrix2<f64>,
        gate: f64,
    ) -> Result<Gated> {
        let (nu, h, r) = self.range_bearing_observation(j, z, r)?;
        self.ensure_wrapped_angle(2);
        self.update_gated(&nu, &h, &r, gate)
    }

    /// All range-bearing observations `(landmark index, z)` of one scan in one stacked
    /// update (one `S`, one Joseph pass over `P`), each with noise `R`.
    pub fn update_range_bearing_batch(
        &mut self,
        observations: &[(usize, Vector2<f64>)],
        r: &Matrix2<f64>,
    ) -> Result<Update> {
        let stacked = observations
            .iter()
            .map(|(j, z)| self.range_bearing_observation(*j, z, r))
            .collect::<Result<Vec<_>>>()?;
        self.ensure_wrapped_angle(2);
        self.update_batch(&stacked)
    }

    /// Add a point landmark first seen at range-bearing `z` (noise `R`); returns its index.
    pub fn add_landmark_range_bearing(
        &mut self,
        z: &Vector2<f64>,
        r: &Matrix2<f64>,
    ) -> Result<usize> {
        let robot = self.planar_robot()?;
        let (l, g_robot, g_z) = landmark_from_range_bearing(&robot, z);
        self.add_landmark(
            &DVector::from_vec(vec![l.x, l.y]),
            &DMatrix::from_column_slice(2, 3, g_robot.as_slice()),
            &DMatrix::from_column_slice(2, 2, g_z.as_slice()),
            &DMatrix::from_column_slice(2, 2, r.as_slice()),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Jacobians against central differences.
    #[test]
    fn jacobians_match_finite_differences() {
        let robot = Pose2::new(1.0, -0.5, 0.7);
        let lm = Point2::new(3.0, 2.0);
        let (z, hr, hl) = range_bearing(&robot, &lm).unwrap();
        let eps = 1e-6;
        for k in 0..3 {
            let mut a = [robot.x, robot.y, robot.theta];
            let mut b = a;
            a[k] += eps;
            b[k] -= eps;
            let za = range_bearing(
                &Pose2 {
                    x: a[0],
                    y: a[1],
                    theta: a[2],
                },
                &lm,
            )
            .unwrap()
            .0;
            let zb = range_bearing(
                &Pose2 {
                    x: b[0],
                    y: b[1],
                    theta: b[2],
                },
                &lm,
            )
            .unwrap()
            .0;
            let d = (za - zb) / (2.0 * eps);
            assert!((d - hr.column(k)).norm() < 1e-6);
        }
        for k in 0..2 {
            let mut a = lm;
            let mut b = lm;
            a[k] += eps;
            b[k] -= eps;
            let d = (range_bearing(&robot, &a).unwrap().0 - range_bearing(&robot, &b).unwrap().0)
                / (2.0 * eps);
            assert!((d - hl.column(k)).norm() < 1e-6);
        }
        let (back, _, gz) = landmark_from_range_bearing(&robot, &z);
        assert!((back - lm).norm() < 1e-12);
        // G_z is the inverse of H_landmark at the same point.
        assert!((gz * hl - Matrix2::identity()).norm() < 1e-9);
    }
}
