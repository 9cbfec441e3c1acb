//! How the engine uses its compressed EKF's active area
//! ([`super::active_area::ActiveArea`]): only for runs where the compression is exact,
//! (re)made before each scan's association, with every passive landmark the scan
//! could be paired with brought in first, so that every result equals the full EKF's
//! up to round-off.

use nalgebra::{DMatrix, DVector, Vector2};

use super::engine::PlanarSlam;
use crate::ekf::{SparseJacobian, Update};
use crate::error::Result;

/// The engine's use of its active area.
impl PlanarSlam {
    /// Whether the compressed filter is exact for this run: the settings allow it,
    /// there are no walls (their association reads every wall), and the robot block
    /// is the pose alone (control-bias states are a wall runs' option; the auxiliary
    /// matrices are written for three robot rows).
    fn may_compress(&self) -> bool {
        self.area.allowed() && self.wall_map.is_empty() && self.ekf.robot_dim() == 3
    }

    /// Landmarks in the filter's state, compressed or not (frozen ones and the
    /// anchor have left it).
    pub fn landmarks_in_state(&self) -> usize {
        self.area.landmarks_in_state(&self.ekf)
    }

    /// Before a scan's association: (re)makes the active area when that saves work,
    /// and activates every passive landmark the scan could be paired with (by id, or
    /// by individual compatibility with its exact mean and robot cross-covariance).
    pub(super) fn localise(&mut self, zs: &[Vector2<f64>], ids: &[Option<u64>]) -> Result<()> {
        if !self.may_compress() {
            self.area.decompress(&mut self.ekf);
            return Ok(());
        }
        let sensor = self.robot().compose(&self.mount);
        if self
            .area
            .remake_if_worth(&mut self.ekf, &sensor, 2 * zs.len())?
        {
            self.stats.compressions += 1;
        }
        if !self.area.is_compressed() {
            return Ok(());
        }
        let wanted = if self.association.by_id() {
            self.area.passive_by_id(ids)
        } else {
            self.passive_in_view(zs)
        };
        self.stats.activations += self.area.activate(&mut self.ekf, wanted)?;
        Ok(())
    }

    /// Passive landmarks that may be individually compatible with a detection.
    fn passive_in_view(&mut self, zs: &[Vector2<f64>]) -> Vec<usize> {
        let gate = self.association.gates().individual();
        let mut near = self.area.passive_near(&self.scene(), &self.mount, zs, gate);
        if self.area.refresh_if_many(near.len()) {
            near = self.area.passive_near(&self.scene(), &self.mount, zs, gate);
        }
        self.area.passive_compatible(&self.scene(), near, zs, gate)
    }

    /// Updates the working filter with `observations` (stacked into one update) and
    /// the compressed state with it.
    pub(super) fn update_stacked(
        &mut self,
        observations: &[(DVector<f64>, SparseJacobian, DMatrix<f64>)],
    ) -> Result<Update> {
        let update = self.ekf.update_batch(observations)?;
        self.area.follow_update(observations, &update)?;
        Ok(update)
    }
}
