//! The association step of a scan, as the engine calls it: which rule pairs the
//! detections (known ids, nearest neighbour or JCBB), against which chi-square gates,
//! and what was left over. The engine hands it the [`Scene`] (the prior) and, with
//! known ids, the landmark each detection names; it answers with the pairings, the
//! detections no landmark explains and the count of ambiguous ones.

use nalgebra::Vector2;

use super::Association;
use super::associate::{self, Pairing, Scene, Target};
use super::gates::Gates;
use crate::error::Result;

/// What the association of one scan found.
#[derive(Debug, Default)]
pub(super) struct Found {
    pub pairings: Vec<Pairing>,
    /// Detections compatible with no landmark: sightings for the candidate list.
    pub unmatched: Vec<usize>,
    /// Detections compatible with some landmark but left unpaired (ambiguous).
    pub rejected: u64,
    /// Whether JCBB stopped at its node budget.
    pub truncated: bool,
}

/// The association rule of a run and its gates.
#[derive(Debug, Clone)]
pub(super) struct Associator {
    rule: Association,
    jcbb_max_nodes: usize,
    gates: Gates,
}

impl Associator {
    /// The rule `rule` at chi-square `confidence`, JCBB stopping after
    /// `jcbb_max_nodes` nodes.
    pub fn new(rule: Association, confidence: f64, jcbb_max_nodes: usize) -> Result<Self> {
        Ok(Self {
            rule,
            jcbb_max_nodes,
            gates: Gates::new(confidence)?,
        })
    }

    /// Whether detections are paired by their ids.
    pub fn by_id(&self) -> bool {
        self.rule == Association::Known
    }

    /// The gates: one detection's, and those of stacked detections.
    pub fn gates(&self) -> &Gates {
        &self.gates
    }

    /// Readies the joint gates for a scan of `n` detections.
    pub fn begin_scan(&mut self, n: usize) -> Result<()> {
        self.gates.grow(n)
    }

    /// Nearest neighbour or JCBB over the individually compatible pairings. A
    /// detection compatible with some landmark but left unpaired is rejected (it is
    /// ambiguous, not new); one compatible with none is a candidate.
    pub fn search(&self, scene: &Scene<'_>, zs: &[Vector2<f64>]) -> Found {
        let options = associate::compatible(scene, zs, self.gates.individual());
        let (pairings, truncated) = self.choose(scene, &options, associate::nearest_neighbour);
        let paired: Vec<usize> = pairings.iter().map(|p| p.det).collect();
        let mut found = Found {
            pairings,
            truncated,
            ..Found::default()
        };
        for (i, opts) in options.iter().enumerate() {
            if opts.is_empty() {
                found.unmatched.push(i);
            } else if !paired.contains(&i) {
                found.rejected += 1;
            }
        }
        found
    }

    /// Known ids: detection `i` is paired with `targets[i]` behind the individual
    /// gate; a detection whose landmark is not in the map (`None`) is a candidate.
    pub fn known(
        &self,
        scene: &Scene<'_>,
        zs: &[Vector2<f64>],
        targets: &[Option<Target>],
    ) -> Found {
        let mut found = Found::default();
        for (i, (z, target)) in zs.iter().zip(targets).enumerate() {
            match target.map(|t| scene.pairing(i, z, t)) {
                None => found.unmatched.push(i),
                Some(Some(p)) if p.nis <= self.gates.individual() => found.pairings.push(p),
                Some(_) => found.rejected += 1,
            }
        }
        found
    }

    /// The pairings among `options` (each detection's compatible pairings): JCBB's
    /// joint choice when that is the rule, otherwise `otherwise`'s. Also whether JCBB
    /// stopped at its node budget.
    pub fn choose(
        &self,
        scene: &Scene<'_>,
        options: &[Vec<Pairing>],
        otherwise: impl FnOnce(&[Vec<Pairing>]) -> Vec<Pairing>,
    ) -> (Vec<Pairing>, bool) {
        if self.rule != Association::Jcbb {
            return (otherwise(options), false);
        }
        let out = associate::jcbb(scene, options, self.gates.joint(), self.jcbb_max_nodes);
        (out.pairings, out.truncated)
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{DMatrix, DVector, Matrix2};
    use rperc_core::{Pose2, chi2_gate};

    use super::*;
    use crate::ekf::Ekf;

    /// A well-known robot at the origin facing +x, and landmarks A at (5, 0) and B at
    /// (0, 5) known to 1 mm.
    fn ekf() -> Ekf {
        let x = DVector::from_vec(vec![0.0, 0.0, 0.0, 5.0, 0.0, 0.0, 5.0]);
        let p = DMatrix::identity(7, 7) * 1e-6;
        Ekf::new(x, p, 3, 2).unwrap().with_wrapped_angle(2).unwrap()
    }

    /// Range and bearing of the point `(x, y)` from the origin facing +x.
    fn rb(x: f64, y: f64) -> Vector2<f64> {
        Vector2::new(x.hypot(y), y.atan2(x))
    }

    fn associator(rule: Association) -> Associator {
        Associator::new(rule, 0.99, 1000).unwrap()
    }

    #[test]
    fn search_pairs_the_nearest_rejects_the_ambiguous_and_leaves_the_unexplained() {
        let ekf = ekf();
        let scene = Scene::new(
            &ekf,
            Pose2::identity(),
            Matrix2::new(1e-2, 0.0, 0.0, 1e-4),
            &[],
        );
        // Two sightings of A (one exact, one 5 cm off), and one 3 m from everything.
        let zs = [rb(5.0, 0.05), rb(5.0, 0.0), rb(-3.0, 0.0)];
        for rule in [Association::NearestNeighbour, Association::Jcbb] {
            let found = associator(rule).search(&scene, &zs);
            let paired: Vec<(usize, Target)> =
                found.pairings.iter().map(|p| (p.det, p.target)).collect();
            // One landmark takes one detection: the exact one, whose NIS is 0.
            assert_eq!(paired, vec![(1, Target::State(0))], "{rule:?}");
            assert_eq!(found.rejected, 1, "{rule:?}");
            assert_eq!(found.unmatched, vec![2], "{rule:?}");
            assert!(!found.truncated);
        }
    }

    #[test]
    fn known_ids_are_paired_behind_the_individual_gate() {
        let ekf = ekf();
        let w = Matrix2::new(1e-2, 0.0, 0.0, 1e-4);
        let scene = Scene::new(&ekf, Pose2::identity(), w, &[]);
        let a = associator(Association::Known);
        assert!(a.by_id());
        // A seen exactly, B seen 1 m off in range (NIS about 1 / 0.01 = 100, over the
        // 2-dof gate of 9.21), and a landmark not in the map.
        let zs = [rb(5.0, 0.0), rb(0.0, 6.0), rb(1.0, 1.0)];
        let targets = [Some(Target::State(0)), Some(Target::State(1)), None];
        let found = a.known(&scene, &zs, &targets);
        assert_eq!(found.pairings.len(), 1);
        assert_eq!(found.pairings[0].det, 0);
        assert!(found.pairings[0].nis < 1e-9);
        assert_eq!(found.rejected, 1);
        assert_eq!(found.unmatched, vec![2]);
        assert!(a.gates().individual() < 100.0);
        assert!((a.gates().individual() - chi2_gate(2, 0.99).unwrap()).abs() < 1e-12);
    }

    #[test]
    fn choose_calls_the_fallback_unless_the_rule_is_jcbb() {
        let ekf = ekf();
        let scene = Scene::new(&ekf, Pose2::identity(), Matrix2::identity() * 1e-4, &[]);
        let options = associate::compatible(&scene, &[rb(5.0, 0.0)], 9.21);
        let none = |_: &[Vec<Pairing>]| Vec::new();
        let (nn, _) = associator(Association::NearestNeighbour).choose(&scene, &options, none);
        assert!(nn.is_empty());
        let (jcbb, truncated) = associator(Association::Jcbb).choose(&scene, &options, none);
        assert_eq!(jcbb.len(), 1);
        assert!(!truncated);
    }
}
