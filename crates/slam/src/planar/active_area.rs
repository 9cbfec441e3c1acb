//! The compressed EKF's active area (Guivant & Nebot 2001, see [`crate::Compressed`]):
//! while the robot works among a few landmarks, the working filter holds the robot
//! and those, and the auxiliary state stands for the passive rest. This part keeps
//! that state, brings passive landmarks in, and decides when to (re)make the area.
//! How the engine uses it is in `compress.rs`.
//!
//! When: an update of the working filter costs about `m d^2` (Joseph form, `m`
//! rows, `d` states) and, compressed, `m (d^2 + d a + a^2)` with the auxiliary
//! matrices (`a` the basis size); a global update costs about `n_B^2 a / 2`. The
//! filter is compressed once it holds `compression_min_landmarks` landmarks of which
//! those near the sensor (`active_radius`) are at most half, and a compressed one is
//! remade around the robot once the work it would have saved since it was made pays
//! for the global update (the rent-or-buy rule: never more than twice the work of the
//! best choice made in hindsight).

use std::borrow::Cow;

use nalgebra::{DMatrix, DVector, Matrix3, Vector2};
use rperc_core::Pose2;

use super::associate::Scene;
use super::{Compression, FreezeMode, PlanarConfig};
use crate::ekf::{Compressed, Ekf, SparseJacobian, Update};
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

/// The compressed filter's side of the engine: while compressed, the auxiliary state
/// of the passive landmarks and the work an area made afresh would have saved since
/// this one was made; and the settings that say when to (re)make the area.
#[derive(Debug, Clone)]
pub(super) struct ActiveArea {
    /// The run's settings allow compression: `Compression::Auto` and no consider
    /// freezing (its zero gain rows are not what the auxiliary matrices assume).
    allowed: bool,
    min_landmarks: usize,
    radius: f64,
    compressed: Option<Compressed>,
    regret: f64,
}

impl ActiveArea {
    /// Uncompressed, with `config`'s compression settings.
    pub fn new(config: &PlanarConfig) -> Self {
        let consider = config.freeze_after.is_some() && config.freeze_mode == FreezeMode::Consider;
        Self {
            allowed: config.compression == Compression::Auto && !consider,
            min_landmarks: config.compression_min_landmarks as usize,
            radius: config.active_radius,
            compressed: None,
            regret: 0.0,
        }
    }

    /// Whether the working filter is the active area's (compressed).
    pub fn is_compressed(&self) -> bool {
        self.compressed.is_some()
    }

    /// Whether the run's settings allow compression at all.
    pub fn allowed(&self) -> bool {
        self.allowed
    }

    /// Landmarks in the full filter whose working filter is `ekf`.
    pub fn landmarks_in_state(&self, ekf: &Ekf) -> usize {
        match &self.compressed {
            Some(c) => c.num_landmarks(ekf),
            None => ekf.num_landmarks(),
        }
    }

    /// Whether landmark `id` is in the full filter.
    pub fn contains(&self, ekf: &Ekf, id: u64) -> bool {
        match &self.compressed {
            Some(c) => c.contains(ekf, id),
            None => ekf.landmark_index(id).is_some(),
        }
    }

    /// The full filter: the working one, or a global update of a copy of it.
    pub fn full<'a>(&self, ekf: &'a Ekf) -> Cow<'a, Ekf> {
        match &self.compressed {
            Some(c) => Cow::Owned(c.clone().decompress(ekf.clone())),
            None => Cow::Borrowed(ekf),
        }
    }

    /// The global update: the working filter `ekf` becomes the full one again.
    pub fn decompress(&mut self, ekf: &mut Ekf) {
        if let Some(c) = self.compressed.take() {
            let local = std::mem::replace(ekf, Ekf::empty_planar());
            *ekf = c.decompress(local);
        }
    }

    /// (Re)makes the area around the `sensor` when the rent-or-buy rule of the
    /// module docs says so, for an update of about `rows` rows; whether it did.
    pub fn remake_if_worth(&mut self, ekf: &mut Ekf, sensor: &Pose2, rows: usize) -> Result<bool> {
        let small = ekf.num_landmarks() < self.min_landmarks;
        if self.compressed.is_none() && small {
            return Ok(false);
        }
        let near = self.near_landmarks(ekf, sensor);
        if !self.worth_compressing(ekf, near.len(), rows) {
            return Ok(false);
        }
        self.decompress(ekf);
        let full = std::mem::replace(ekf, Ekf::empty_planar());
        let (local, aux) = full.compress(&near)?;
        *ekf = local;
        self.compressed = Some(aux);
        self.regret = 0.0;
        Ok(true)
    }

    fn worth_compressing(&mut self, ekf: &Ekf, near: usize, rows: usize) -> bool {
        let n = ekf.num_landmarks();
        let Some(c) = &self.compressed else {
            return n >= self.min_landmarks && 2 * near <= n;
        };
        let (d, a) = (ekf.state().len() as f64, c.basis_len() as f64);
        let fresh = (3 + 2 * near) as f64;
        let n_b = 2.0 * c.passive().len() as f64;
        self.regret += (update_work(rows, d, a) - update_work(rows, fresh, fresh)).max(0.0);
        self.regret > global_work(n_b, d, a)
    }

    /// The landmarks (active or passive; a passive one at its last global mean)
    /// within the area's radius of the `sensor`.
    fn near_landmarks(&self, ekf: &Ekf, sensor: &Pose2) -> Vec<u64> {
        let r2 = self.radius.powi(2);
        let near = |x: f64, y: f64| (x - sensor.x).powi(2) + (y - sensor.y).powi(2) <= r2;
        let x = ekf.state();
        let ids = ekf.landmark_ids().iter().enumerate();
        let mut out: Vec<u64> = ids
            .filter(|(j, _)| near(x[3 + 2 * j], x[4 + 2 * j]))
            .map(|(_, &id)| id)
            .collect();
        if let Some(c) = &self.compressed {
            let passive = c.passive().iter();
            out.extend(passive.filter(|p| near(p.mean[0], p.mean[1])).map(|p| p.id));
        }
        out
    }

    /// Passive landmarks named by the scan's ids.
    pub fn passive_by_id(&self, ids: &[Option<u64>]) -> Vec<usize> {
        let Some(c) = &self.compressed else {
            return Vec::new();
        };
        let passive = c.passive().iter().enumerate();
        passive
            .filter(|(_, p)| ids.contains(&Some(p.id)))
            .map(|(k, _)| k)
            .collect()
    }

    /// Passive landmarks that may be within reach of a detection: from the sensor
    /// (`mount` on the scene's robot), within the farthest detection's range plus
    /// the drift bound of the landmark's mean since the last refresh plus the
    /// association screen's range bound at `gate`.
    pub fn passive_near(
        &self,
        scene: &Scene<'_>,
        mount: &Pose2,
        zs: &[Vector2<f64>],
        gate: f64,
    ) -> Vec<usize> {
        let Some(c) = self.compressed.as_ref().filter(|_| !zs.is_empty()) else {
            return Vec::new();
        };
        let sensor = scene.robot.compose(mount);
        let farthest = zs.iter().map(|z| z.x).fold(f64::NEG_INFINITY, f64::max);
        let scale = c.drift_scale();
        let passive = c.passive().iter().enumerate();
        passive
            .filter(|(_, p)| {
                let distance2 = (p.mean[0] - sensor.x).powi(2) + (p.mean[1] - sensor.y).powi(2);
                let reach = farthest + p.reach * scale + scene.range_reach(p.trace, gate);
                // Compared squared (reach >= 0); a NaN keeps the landmark for the exact test.
                distance2 <= reach * reach || distance2.is_nan() || reach.is_nan()
            })
            .map(|(k, _)| k)
            .collect()
    }

    /// Refreshes every passive mean when `near` passive landmarks passed the
    /// distance test: a refresh costs about as much as the exact test of a quarter
    /// of them. Whether it did (the distance test is then worth running again).
    pub fn refresh_if_many(&mut self, near: usize) -> bool {
        match &mut self.compressed {
            Some(c) if 4 * near > c.passive().len() => {
                c.refresh();
                true
            }
            _ => false,
        }
    }

    /// Of the passive landmarks `near`, those that may be individually compatible
    /// with a detection at `gate`: the association's screen at the exact mean first
    /// (O(a0)), then the gate with a bound of the robot cross-covariance and the
    /// last global own covariance (O(1), an upper bound: it never drops a compatible
    /// landmark), then the gate itself (O(3 a0)).
    pub fn passive_compatible(
        &self,
        scene: &Scene<'_>,
        near: Vec<usize>,
        zs: &[Vector2<f64>],
        gate: f64,
    ) -> Vec<usize> {
        let Some(c) = &self.compressed else {
            return Vec::new();
        };
        let passive = c.passive();
        let compatible = |&k: &usize| {
            let l = c.passive_mean(k);
            scene.may_observe(&l, passive[k].trace, zs, gate)
                && scene.may_pair(&l, None, &c.passive_own(k), zs, gate)
                && {
                    let (p_rl, p_ll) = c.passive_covariance(k);
                    scene.may_pair(&l, Some(&p_rl), &p_ll, zs, gate)
                }
        };
        near.into_iter().filter(compatible).collect()
    }

    /// Brings passive landmarks (indices into the passive list) into the working
    /// filter `ekf`; how many.
    pub fn activate(&mut self, ekf: &mut Ekf, mut wanted: Vec<usize>) -> Result<u64> {
        let Some(c) = &mut self.compressed else {
            return Ok(0);
        };
        // Descending, so that each removal leaves the smaller indices in place.
        wanted.sort_unstable_by(|a, b| b.cmp(a));
        for &k in &wanted {
            c.activate(ekf, k)?;
        }
        Ok(wanted.len() as u64)
    }

    /// The compressed state follows an update of the working filter.
    pub fn follow_update(
        &mut self,
        observations: &[(DVector<f64>, SparseJacobian, DMatrix<f64>)],
        update: &Update,
    ) -> Result<()> {
        match &mut self.compressed {
            Some(c) => c.update(observations, update),
            None => Ok(()),
        }
    }

    /// A landmark admitted to the working filter from the robot (Jacobian `g_robot`).
    pub fn follow_admission(&mut self, g_robot: &DMatrix<f64>) -> Result<()> {
        match &mut self.compressed {
            Some(c) => c.admitted(g_robot),
            None => Ok(()),
        }
    }

    /// The robot Jacobian of a prediction of the working filter.
    pub fn follow_prediction(&mut self, fx: &Matrix3<f64>) {
        if let Some(c) = &mut self.compressed {
            c.predict_planar(fx);
        }
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{DMatrix, DVector};
    use rand::{Rng, SeedableRng, rngs::StdRng};

    use super::*;

    /// A correlated filter: the robot at the origin, landmarks 0 and 1 within 5 m and
    /// landmarks 2..10 at 20 m and beyond, with a random positive definite covariance.
    fn filter() -> Ekf {
        let mut x = vec![0.0, 0.0, 0.1, 3.0, 1.0, -2.0, 2.5];
        x.extend((0..8).flat_map(|k| [20.0 + 3.0 * k as f64, -5.0 + k as f64]));
        let n = x.len();
        let mut rng = StdRng::seed_from_u64(4);
        let a = DMatrix::from_fn(n, n, |_, _| rng.random_range(-0.1..0.1));
        let p = &a * a.transpose() + DMatrix::identity(n, n) * 1e-3;
        Ekf::new(DVector::from_vec(x), p, 3, 2)
            .unwrap()
            .with_wrapped_angle(2)
            .unwrap()
    }

    fn area(min_landmarks: u32) -> ActiveArea {
        ActiveArea::new(&PlanarConfig {
            compression_min_landmarks: min_landmarks,
            ..PlanarConfig::default()
        })
    }

    fn max_diff(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
        (a - b).abs().max()
    }

    #[test]
    fn the_area_holds_the_near_landmarks_and_the_full_filter_is_the_original() {
        let original = filter();
        let mut ekf = original.clone();
        let mut area = area(4);
        assert!(area.allowed());
        assert!(
            area.remake_if_worth(&mut ekf, &Pose2::identity(), 4)
                .unwrap()
        );
        assert!(area.is_compressed());
        // Only the two landmarks within the default 5 m radius are active.
        assert_eq!(ekf.landmark_ids(), &[0, 1]);
        assert_eq!(area.landmarks_in_state(&ekf), 10);
        assert!(area.contains(&ekf, 9) && !area.contains(&ekf, 10));
        // No update since the compression: the global update gives back the original.
        let full = area.full(&ekf);
        assert!((full.state() - original.state()).abs().max() < 1e-12);
        assert!(max_diff(&full.covariance(), &original.covariance()) < 1e-12);
        // A passive landmark named by id is brought in.
        let wanted = area.passive_by_id(&[Some(5), None]);
        assert_eq!(wanted.len(), 1);
        assert_eq!(area.activate(&mut ekf, wanted).unwrap(), 1);
        assert!(ekf.landmark_index(5).is_some());
        assert_eq!(area.landmarks_in_state(&ekf), 10);
        area.decompress(&mut ekf);
        assert!(!area.is_compressed());
        assert_eq!(ekf.num_landmarks(), 10);
        let (i, j) = (
            ekf.landmark_index(5).unwrap(),
            original.landmark_index(5).unwrap(),
        );
        assert!((ekf.state()[3 + 2 * i] - original.state()[3 + 2 * j]).abs() < 1e-12);
    }

    #[test]
    fn a_small_map_or_a_crowded_area_is_not_compressed() {
        let mut ekf = filter();
        // Fewer landmarks than the minimum.
        assert!(
            !area(11)
                .remake_if_worth(&mut ekf, &Pose2::identity(), 4)
                .unwrap()
        );
        // All ten within the radius of a sensor among the far ones: more than half.
        let far = Pose2::new(30.0, -2.0, 0.0);
        let mut crowded = ActiveArea::new(&PlanarConfig {
            compression_min_landmarks: 4,
            active_radius: 30.0,
            ..PlanarConfig::default()
        });
        assert!(!crowded.remake_if_worth(&mut ekf, &far, 4).unwrap());
        assert_eq!(ekf.num_landmarks(), 10);
        // Consider freezing or compression off: never allowed; marginalising
        // freezing is.
        let off = PlanarConfig {
            compression: Compression::Off,
            ..PlanarConfig::default()
        };
        assert!(!ActiveArea::new(&off).allowed());
        let freezing = |freeze_mode| PlanarConfig {
            freeze_after: Some(5),
            freeze_mode,
            ..PlanarConfig::default()
        };
        assert!(!ActiveArea::new(&freezing(FreezeMode::Consider)).allowed());
        assert!(ActiveArea::new(&freezing(FreezeMode::Marginalise)).allowed());
    }
}
