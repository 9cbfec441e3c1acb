//! The engine's compressed EKF (Guivant & Nebot 2001, see [`crate::Compressed`]):
//! when to compress, which landmarks are active, and bringing a passive landmark
//! into the active area before any step could touch it, so that every result equals
//! the full EKF's up to round-off.
//!
//! When: an update of the working filter costs about `m d^2` (Joseph form, `m`
//! rows, `d` states) and, compressed, `m (d^2 + d a + a^2)` with the auxiliary
//! matrices (`a` the basis size); a global update costs about `n_B^2 a / 2`. The
//! filter is compressed once it holds `compression_min_landmarks` landmarks of which
//! those near the sensor (`active_radius`) are at most half, and a compressed one is remade around the robot once
//! the work it would have saved since it was made pays for the global update (the
//! rent-or-buy rule: never more than twice the work of the best choice made in
//! hindsight).

use std::borrow::Cow;

use nalgebra::{DMatrix, DVector, Vector2};

use super::engine::PlanarSlam;
use super::local::Local;
use super::{Compression, FreezeMode};
use crate::ekf::{Ekf, SparseJacobian, Update};
use crate::error::Result;

/// Multiply-adds of an update of `rows` rows of a compressed filter of `d` states
/// with a basis of `a`: the Joseph form (`rows d^2`), the gain (`2 d rows^2`), and
/// `phi` and `psi` (`rows a (d + a)`).
fn update_work(rows: usize, d: f64, a: f64) -> f64 {
    let m = rows as f64;
    m * d * d + 2.0 * d * m * m + m * a * (d + a)
}

/// Multiply-adds of a global update with `n_b` passive states: `P_BB` (`n_b^2 a / 2`),
/// `P_BA0 psi` (`n_b a^2`) and `P_AB` (`d a n_b`).
fn global_work(n_b: f64, d: f64, a: f64) -> f64 {
    n_b * n_b * a / 2.0 + n_b * a * a + d * a * n_b
}

impl PlanarSlam {
    /// Whether the compressed filter is exact for this run: not with consider
    /// freezing (zero gain rows) or walls (their association reads every wall), and
    /// only for a robot block of the pose alone (control-bias states are a wall
    /// runs' option; the auxiliary matrices are written for three robot rows).
    fn may_compress(&self) -> bool {
        let consider =
            self.config.freeze_after.is_some() && self.config.freeze_mode == FreezeMode::Consider;
        self.config.compression == Compression::Auto
            && !consider
            && self.wall_map.is_empty()
            && self.ekf.robot_dim() == 3
    }

    /// Landmarks in the filter's state, compressed or not (frozen ones and the
    /// anchor have left it).
    pub fn landmarks_in_state(&self) -> usize {
        match &self.cekf {
            Some(c) => c.aux.num_landmarks(&self.ekf),
            None => self.ekf.num_landmarks(),
        }
    }

    /// Whether landmark `id` is in the full filter.
    pub(super) fn in_state(&self, id: u64) -> bool {
        match &self.cekf {
            Some(c) => c.aux.contains(&self.ekf, id),
            None => self.ekf.landmark_index(id).is_some(),
        }
    }

    /// The full filter: the working one, or a global update of a copy of it.
    pub(super) fn full_ekf(&self) -> Cow<'_, Ekf> {
        match &self.cekf {
            Some(c) => Cow::Owned(c.aux.clone().decompress(self.ekf.clone())),
            None => Cow::Borrowed(&self.ekf),
        }
    }

    /// The global update: the working filter becomes the full one again.
    pub(super) fn decompress(&mut self) {
        if let Some(c) = self.cekf.take() {
            let local = std::mem::replace(&mut self.ekf, Ekf::empty_planar());
            self.ekf = c.aux.decompress(local);
        }
    }

    /// Before a scan's association: (re)makes the active area when that saves work,
    /// and activates every passive landmark the scan could be paired with (by id, or
    /// by individual compatibility with its exact mean and robot cross-covariance).
    pub(super) fn localise(&mut self, zs: &[Vector2<f64>], ids: &[Option<u64>]) -> Result<()> {
        if !self.may_compress() {
            self.decompress();
            return Ok(());
        }
        let small = self.ekf.num_landmarks() < self.config.compression_min_landmarks as usize;
        if self.cekf.is_none() && small {
            return Ok(());
        }
        let near = self.near_landmarks();
        if self.worth_compressing(near.len(), 2 * zs.len()) {
            self.decompress();
            let full = std::mem::replace(&mut self.ekf, Ekf::empty_planar());
            let (local, aux) = full.compress(&near)?;
            self.ekf = local;
            self.cekf = Some(Local { aux, regret: 0.0 });
            self.stats.compressions += 1;
        }
        if self.cekf.is_none() {
            return Ok(());
        }
        let wanted = if self.association.by_id() {
            self.passive_by_id(ids)
        } else {
            self.passive_in_view(zs)
        };
        self.activate(wanted)
    }

    /// The rent-or-buy rule of the module docs, for an area of `near` landmarks and
    /// an update of about `rows` rows.
    fn worth_compressing(&mut self, near: usize, rows: usize) -> bool {
        let n = self.ekf.num_landmarks();
        let Some(c) = &mut self.cekf else {
            let enough = n >= self.config.compression_min_landmarks as usize;
            return enough && 2 * near <= n;
        };
        let (d, a) = (self.ekf.state().len() as f64, c.aux.basis_len() as f64);
        let fresh = (3 + 2 * near) as f64;
        let n_b = 2.0 * c.aux.passive().len() as f64;
        c.regret += (update_work(rows, d, a) - update_work(rows, fresh, fresh)).max(0.0);
        c.regret > global_work(n_b, d, a)
    }

    /// The landmarks (active or passive; a passive one at its last global mean)
    /// within `active_radius` of the sensor.
    fn near_landmarks(&self) -> Vec<u64> {
        let sensor = self.robot().compose(&self.mount);
        let r2 = self.config.active_radius.powi(2);
        let near = |x: f64, y: f64| (x - sensor.x).powi(2) + (y - sensor.y).powi(2) <= r2;
        let x = self.ekf.state();
        let mut out: Vec<u64> = self
            .ekf
            .landmark_ids()
            .iter()
            .enumerate()
            .filter(|(j, _)| near(x[3 + 2 * j], x[4 + 2 * j]))
            .map(|(_, &id)| id)
            .collect();
        if let Some(c) = &self.cekf {
            let passive = c.aux.passive().iter();
            out.extend(passive.filter(|p| near(p.mean[0], p.mean[1])).map(|p| p.id));
        }
        out
    }

    /// Passive landmarks named by the scan's ids.
    fn passive_by_id(&self, ids: &[Option<u64>]) -> Vec<usize> {
        let Some(c) = &self.cekf else {
            return Vec::new();
        };
        let passive = c.aux.passive().iter().enumerate();
        passive
            .filter(|(_, p)| ids.contains(&Some(p.id)))
            .map(|(k, _)| k)
            .collect()
    }

    /// Passive landmarks that may be individually compatible with a detection: first
    /// by distance ([`PlanarSlam::passive_near`]), then by the gate with the exact
    /// mean and robot cross-covariance and the last global own covariance (an upper
    /// bound: the test never drops a compatible landmark).
    fn passive_in_view(&mut self, zs: &[Vector2<f64>]) -> Vec<usize> {
        let mut near = self.passive_near(zs);
        let Some(c) = &mut self.cekf else {
            return Vec::new();
        };
        // A refresh of every passive mean costs about as much as the exact test of a
        // quarter of them: refresh when more than that pass the distance test.
        if 4 * near.len() > c.aux.passive().len() {
            c.aux.refresh();
            near = self.passive_near(zs);
        }
        let Some(c) = &self.cekf else {
            return Vec::new();
        };
        let scene = self.scene();
        let passive = c.aux.passive();
        near.into_iter()
            .filter(|&k| {
                // The association's screen at the exact mean first (O(a0)), then the
                // gate with a bound of the robot cross-covariance (O(1)), then the gate
                // itself (O(3 a0)).
                let l = c.aux.passive_mean(k);
                scene.may_observe(
                    &l,
                    passive[k].trace,
                    zs,
                    self.association.gates().individual(),
                ) && scene.may_pair(
                    &l,
                    None,
                    &c.aux.passive_own(k),
                    zs,
                    self.association.gates().individual(),
                ) && {
                    let (p_rl, p_ll) = c.aux.passive_covariance(k);
                    scene.may_pair(
                        &l,
                        Some(&p_rl),
                        &p_ll,
                        zs,
                        self.association.gates().individual(),
                    )
                }
            })
            .collect()
    }

    /// Passive landmarks that may be within reach of a detection: from the sensor,
    /// within the farthest detection's range plus the drift bound of the landmark's
    /// mean since the last refresh plus the association screen's range bound.
    fn passive_near(&self, zs: &[Vector2<f64>]) -> Vec<usize> {
        let Some(c) = self.cekf.as_ref().filter(|_| !zs.is_empty()) else {
            return Vec::new();
        };
        let scene = self.scene();
        let sensor = scene.robot.compose(&self.mount);
        let farthest = zs.iter().map(|z| z.x).fold(f64::NEG_INFINITY, f64::max);
        let scale = c.aux.drift_scale();
        let passive = c.aux.passive().iter().enumerate();
        passive
            .filter(|(_, p)| {
                let distance2 = (p.mean[0] - sensor.x).powi(2) + (p.mean[1] - sensor.y).powi(2);
                let reach = farthest
                    + p.reach * scale
                    + scene.range_reach(p.trace, self.association.gates().individual());
                // Compared squared (reach >= 0); a NaN keeps the landmark for the exact test.
                distance2 <= reach * reach || distance2.is_nan() || reach.is_nan()
            })
            .map(|(k, _)| k)
            .collect()
    }

    /// Brings passive landmarks (indices into the passive list) into the active area.
    fn activate(&mut self, mut wanted: Vec<usize>) -> Result<()> {
        let Some(c) = &mut self.cekf else {
            return Ok(());
        };
        // Descending, so that each removal leaves the smaller indices in place.
        wanted.sort_unstable_by(|a, b| b.cmp(a));
        for k in wanted {
            c.aux.activate(&mut self.ekf, k)?;
            self.stats.activations += 1;
        }
        Ok(())
    }

    /// Updates the working filter with `observations` (stacked into one update) and
    /// the compressed state with it.
    pub(super) fn update_stacked(
        &mut self,
        observations: &[(DVector<f64>, SparseJacobian, DMatrix<f64>)],
    ) -> Result<Update> {
        let update = self.ekf.update_batch(observations)?;
        self.follow_update(observations, &update)?;
        Ok(update)
    }

    /// The compressed state follows an update of the working filter.
    pub(super) fn follow_update(
        &mut self,
        observations: &[(DVector<f64>, SparseJacobian, DMatrix<f64>)],
        update: &Update,
    ) -> Result<()> {
        match &mut self.cekf {
            Some(c) => c.aux.update(observations, update),
            None => Ok(()),
        }
    }

    /// A landmark admitted to the working filter from the robot (Jacobian `g_robot`).
    pub(super) fn follow_admission(&mut self, g_robot: &DMatrix<f64>) -> Result<()> {
        match &mut self.cekf {
            Some(c) => c.aux.admitted(g_robot),
            None => Ok(()),
        }
    }

    /// The robot Jacobian of a prediction of the working filter.
    pub(super) fn follow_prediction(&mut self, fx: &nalgebra::Matrix3<f64>) {
        if let Some(c) = &mut self.cekf {
            c.aux.predict_planar(fx);
        }
    }
}
