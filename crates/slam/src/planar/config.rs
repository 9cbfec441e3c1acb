//! The planar engine's configuration: one struct, every field with a default, so a
//! config file or a Python dict names only what it changes.

use rperc_core::{chi2_gate, ensure_non_negative, ensure_positive};

use super::SensorBias;
use crate::error::{Result, SlamError};
use crate::motion::MotionModel;

rperc_core::named_enum! {
    /// How detections are paired with landmarks.
    #[derive(Default)]
    pub enum Association: "association" {
        /// The detection carries the landmark's id (MR.CLAM's barcodes).
        #[default]
        Known = "known",
        /// Each detection takes its most compatible landmark (Mahalanobis chi-square
        /// gate), each landmark at most once.
        NearestNeighbour = "nn",
        /// Joint compatibility branch and bound (Neira & Tardos 2001).
        Jcbb = "jcbb",
    }
}

rperc_core::named_enum! {
    /// Where a wall detection is compared with the map's wall
    /// ([`crate::wall::segment_innovation`]).
    #[derive(Default)]
    pub enum WallInnovation: "wall_innovation" {
        /// `(rho, alpha)` at the sensor's foot on the line, as in seed 000.
        Line = "line",
        /// The offset at the middle of the seen segment, and the angle: the same
        /// information to first order, without the foot's curvature in the angle.
        /// Chosen on the simulated corridor loop (`benchmarks/wall_corridor.py`),
        /// where `line` left the robot far out of its NEES band (figures:
        /// `docs/decisions.md`).
        #[default]
        Segment = "segment",
    }
}

rperc_core::named_enum! {
    /// What freezing does to a landmark (text under Fig. 7).
    #[derive(Default)]
    pub enum FreezeMode: "freeze_mode" {
        /// The seed's: the landmark leaves the state (marginalised) and is then used
        /// as known with its covariance added to the detection noise. Its correlation
        /// with the robot is lost, so every later sighting counts that covariance
        /// again as if it were new: the robot becomes over-confident.
        #[default]
        Marginalise = "marginalise",
        /// The landmark stays in the state as a consider state (Schmidt-Kalman): its
        /// mean and covariance are fixed, its cross-covariances kept exact, so its
        /// sightings correct the rest without over-confidence. No state reduction.
        Consider = "consider",
    }
}

rperc_core::named_enum! {
    /// Whether the engine runs the compressed EKF of Guivant & Nebot (2001): while the
    /// robot sees only the landmarks of a local area, only the robot and those are
    /// updated, and one global update restores the full filter exactly (see
    /// [`crate::Compressed`]).
    #[derive(Default)]
    pub enum Compression: "compression" {
        /// Compressed whenever it is exact and saves work: a map of point landmarks
        /// of which at most half are near the sensor (`active_radius`), without
        /// consider freezing (its zero gains break the compression) or walls. Any
        /// step that touches a passive landmark (an association candidate, a known
        /// id) first brings it into the active area, exactly, and freezing (a
        /// removal) first makes the global update: the results equal the full EKF's
        /// up to round-off.
        #[default]
        Auto = "auto",
        /// The full EKF at every step.
        Off = "off",
    }
}

/// Settings of [`super::PlanarSlam`]. The seed's variants (anchor, external sensor,
/// freezing) are fields and combine freely.
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct PlanarConfig {
    /// The vehicle, with its control noise (eqs. 1, 5). The sensor sits at the robot's
    /// origin for the unicycle and at the laser mount for the Ackermann vehicle.
    pub motion: MotionModel,
    /// Range noise variance of a detection, m^2 (> 0).
    pub range_variance: f64,
    /// Bearing noise variance of a detection, rad^2 (> 0).
    pub bearing_variance: f64,
    /// Pairing method.
    pub association: Association,
    /// Confidence of the chi-square gates (individual, joint, fix), in (0, 1).
    pub gate_confidence: f64,
    /// Consistent sightings a new landmark needs before it enters the map (>= 1).
    pub candidate_sightings: u32,
    /// A candidate not seen again within this many seconds is dropped (> 0).
    pub candidate_window: f64,
    /// Joint-compatibility tests JCBB may make per scan before it settles for the
    /// best hypothesis found so far (>= 1).
    pub jcbb_max_nodes: usize,
    /// A seen wall segment and a map wall's extent, both on the wall's line, may be
    /// this far apart and still be paired, m (>= 0): collinear walls separated by
    /// more (two sides of a doorway) stay two walls.
    pub wall_overlap_gap: f64,
    /// A wall detection outside the gate of every overlapping wall is new only when
    /// it is also outside this wider chi-square gate of each (in (0, 1), at least
    /// `gate_confidence`); in between it is refused. Set on the simulated room
    /// (`room::RoomConfig`), where at 0.9999 about one run in ten still duplicated a
    /// wall after an unlucky sighting (NIS 20).
    pub wall_admission_confidence: f64,
    /// A wall detection whose angle's standard deviation exceeds this is not used,
    /// rad (> 0): a line landmark's observation is curved in its angle, so a short
    /// wall seen with a loose angle (a door jamb 0.4 m long: about 6 degrees) biases
    /// every linearised update the same way and the filter turns overconfident. Set
    /// on a simulated 40 m corridor loop with door jambs, never on a laser log
    /// (`benchmarks/wall_corridor.py`; figures: `docs/decisions.md`).
    pub wall_max_angle_sd: f64,
    /// The straightness error a detection shares with earlier detections of the same
    /// part of its wall, m (>= 0; 0: none): a wall's own bends stay where they are,
    /// so sightings of one stretch of it repeat their error instead of averaging it
    /// away. A detection paired with a wall gets
    /// [`crate::wall::straightness_covariance`] of this `sigma` times `sqrt(n)` added
    /// to its noise, `n` the wall's earlier paired detections covering more than half
    /// of the same stretch (the shorter one's), among its latest
    /// [`super::WALL_PARTS_KEPT`]. Its own covariance should already
    /// hold the floor once (`rperc.slam.wallslam` adds it to every sighting). `sqrt(n)`
    /// lies between independent sightings (no growth) and one error shared by all
    /// (`n`). Checked in a simulated corridor whose walls have bends of their own
    /// (`benchmarks/wall_corridor.py --bend 0.02`) and chosen on ACES with the floor
    /// `wallslam.STRAIGHTNESS`, Intel held out (`benchmarks/wall_fig7.py`); the
    /// detection that admits a wall is not counted (figures: `docs/decisions.md`).
    pub wall_shared_sd: f64,
    /// Where a wall detection is compared with the map's wall (`segment`, the
    /// default, or seed 000's `line`).
    pub wall_innovation: WallInnovation,
    /// Eqs. (24)-(25): the first landmark becomes the global reference (a point, or a
    /// wall: then the robot's distance to it and heading are taken relative to it).
    pub anchor: bool,
    /// Eqs. (26)-(27): apply the xy fixes of an external sensor (otherwise they are
    /// counted and ignored).
    pub external_fix: bool,
    /// Where the external sensor's point sits on the robot, m (forward, left of the
    /// pose's origin): a fix measures `t + R(theta) lever_arm` (Victoria Park's GPS
    /// is compared at the laser, 3.78 m ahead and 0.5 m left of the rear axle).
    pub fix_lever_arm: [f64; 2],
    /// Landmarks revised more than this many times leave the state (text under
    /// Fig. 7, where it is 50); `None` never freezes.
    pub freeze_after: Option<u32>,
    /// How a landmark is frozen.
    pub freeze_mode: FreezeMode,
    /// Start pose `(x, y, theta)`.
    pub initial_pose: [f64; 3],
    /// Variances of the start pose (>= 0; zero: a known start).
    pub initial_pose_variance: [f64; 3],
    /// Whether to run the compressed EKF (a speed choice: the results are the same).
    pub compression: Compression,
    /// The compressed filter's active area when it is made: the landmarks within this
    /// distance of the sensor, m (> 0); any other landmark a scan may be paired with
    /// joins it when seen. The area is made afresh (one global update) when the work
    /// it costs over a fresh one has paid for a global update. A speed setting only:
    /// timed on Victoria Park from 1 to 50 m (0.68 to 0.97 s), the results identical.
    pub active_radius: f64,
    /// The compressed filter is used once the state holds at least this many
    /// landmarks (>= 1): below, a full update costs less than the compressed one's
    /// bookkeeping (Victoria Park's first 300 scans, 74 landmarks: 20 ms full, 26 ms
    /// compressed; MR.CLAM's 15: 36 ms against 60 ms). A speed setting only.
    pub compression_min_landmarks: u32,
    /// Systematic sensor and odometry errors, removed from every detection and
    /// control before use (identity by default; MR.CLAM's are calibrated offline).
    /// `range_variance` and `bearing_variance` are the noise left after it.
    pub bias: SensorBias,
    /// Unknown constant odometry biases estimated in the state, with these prior
    /// standard deviations: a relative error `s` of the first control and an offset
    /// `b` of the second, so that the true controls are `(u0 (1 - s), u1 - b)`
    /// (speed read long by `s`, turn rate off by `b` rad/s). `None`: no bias states
    /// (the robot block is `(x, y, theta)`); otherwise it is `(x, y, theta, s, b)`.
    pub control_bias_sd: Option<[f64; 2]>,
    /// First-estimates Jacobians (Huang, Mourikis & Roumeliotis 2008): a wall's
    /// observation is linearised at the wall's first estimate (the one it entered the
    /// map with), not its current one, and the robot's prediction at the pose it was
    /// first estimated at (its prediction, before the last update moved it). Then the
    /// linearised system keeps the translation and rotation of the whole map
    /// unobservable, as the nonlinear one is; linearised at changing estimates it
    /// gains information about them from nowhere, which makes the filter
    /// overconfident (tested: with it, the robot's absolute heading and position
    /// variances never fall below the start's). A point landmark's observation is
    /// linearised at the point's first estimate too (its position when admitted; the
    /// predicted detection stays at its current one). It made MR.CLAM robot 3
    /// consistent; but a first estimate made while the robot was far off (robot 2
    /// after a long stretch without a sighting) keeps Jacobians that no longer
    /// describe the map, and that run diverges (figures: `docs/decisions.md`).
    pub first_estimates: bool,
}

impl Default for PlanarConfig {
    fn default() -> Self {
        Self {
            motion: MotionModel::default(),
            range_variance: 0.01,
            bearing_variance: 1e-3,
            association: Association::Known,
            gate_confidence: 0.99,
            candidate_sightings: 1,
            candidate_window: 10.0,
            jcbb_max_nodes: 20_000,
            wall_overlap_gap: 0.5,
            wall_admission_confidence: 0.999_999,
            wall_max_angle_sd: 2f64.to_radians(),
            wall_shared_sd: 0.0,
            wall_innovation: WallInnovation::Segment,
            anchor: false,
            external_fix: false,
            fix_lever_arm: [0.0; 2],
            freeze_after: None,
            freeze_mode: FreezeMode::Marginalise,
            initial_pose: [0.0; 3],
            initial_pose_variance: [0.0; 3],
            compression: Compression::Auto,
            active_radius: 5.0,
            compression_min_landmarks: 100,
            bias: SensorBias::default(),
            control_bias_sd: None,
            first_estimates: false,
        }
    }
}

impl PlanarConfig {
    /// Refuses bad values with the parameter's name.
    pub fn validate(&self) -> Result<()> {
        self.motion.validate()?;
        ensure_positive("range_variance", self.range_variance)?;
        ensure_positive("bearing_variance", self.bearing_variance)?;
        chi2_gate(2, self.gate_confidence).map_err(|_| {
            SlamError::invalid(
                "gate_confidence",
                format!("must be in (0, 1), got {}", self.gate_confidence),
            )
        })?;
        if self.candidate_sightings == 0 {
            return Err(SlamError::invalid(
                "candidate_sightings",
                "must be >= 1".into(),
            ));
        }
        ensure_positive("candidate_window", self.candidate_window)?;
        ensure_positive("active_radius", self.active_radius)?;
        if self.compression_min_landmarks == 0 {
            return Err(SlamError::invalid(
                "compression_min_landmarks",
                "must be >= 1".into(),
            ));
        }
        ensure_non_negative("wall_overlap_gap", self.wall_overlap_gap)?;
        ensure_positive("wall_max_angle_sd", self.wall_max_angle_sd)?;
        ensure_non_negative("wall_shared_sd", self.wall_shared_sd)?;
        let admission = self.wall_admission_confidence;
        if !(self.gate_confidence..1.0).contains(&admission) {
            return Err(SlamError::invalid(
                "wall_admission_confidence",
                format!(
                    "must be in [gate_confidence {}, 1), got {admission}",
                    self.gate_confidence
                ),
            ));
        }
        if self.jcbb_max_nodes == 0 {
            return Err(SlamError::invalid("jcbb_max_nodes", "must be >= 1".into()));
        }
        if self.freeze_after == Some(0) {
            return Err(SlamError::invalid(
                "freeze_after",
                "must be >= 1 (or None)".into(),
            ));
        }
        for sd in self.control_bias_sd.iter().flatten() {
            ensure_positive("control_bias_sd", *sd)?;
        }
        rperc_core::ensure_coordinates("initial_pose", &self.initial_pose[..2])?;
        rperc_core::ensure_finite("initial_pose", self.initial_pose.iter())?;
        rperc_core::ensure_coordinates("fix_lever_arm", self.fix_lever_arm.iter())?;
        for v in self.initial_pose_variance {
            ensure_non_negative("initial_pose_variance", v)?;
        }
        self.bias.validate()
    }
}
