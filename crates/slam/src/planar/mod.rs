//! Planar EKF-SLAM as in section 2.2 of the seed paper: a robot `(x, y, theta)`
//! among point landmarks seen by range and bearing, with the EKF of eqs. (1)-(9),
//! known, nearest-neighbour or JCBB association, a candidate list for new landmarks,
//! and the seed's variants: the anchor (eqs. 24-25), the external xy sensor
//! (eqs. 26-27) and landmark freezing (the text under Fig. 7).
//!
//! The engine consumes a time-ordered stream of [`Event`]s, one at a time
//! ([`PlanarSlam::process`]) or in bulk from columnar arrays ([`EventArrays`], what a
//! Python caller passes as numpy arrays in one call). Controls are held constant
//! until the next control (zero-order hold): every event first predicts the robot
//! to its own time with the control in force, so `dt` is the gap between events.
//!
//! Walls (infinite lines in Hessian form, section 2.1, seen as [`WallDetection`]s in
//! [`Event::Walls`]) are a second landmark kind in the same state and filter: their
//! world `(rho, alpha)` is estimated with the observation model of [`crate::wall`],
//! paired by a Mahalanobis gate plus segment overlap, and frozen and anchored by the
//! same config as the points (see [`PlanarSlam`]).

mod active_area;
mod arrow;
mod associate;
mod associator;
mod bias;
mod candidates;
mod compress;
mod config;
mod engine;
mod fixed;
mod gates;
mod observe;
mod point_map;
pub mod room;
pub mod sim;
pub mod smooth;
mod wall_map;
mod walls;

pub use bias::SensorBias;
pub use config::{Association, Compression, FreezeMode, PlanarConfig, WallInnovation};
pub use engine::PlanarSlam;
pub use wall_map::WALL_PARTS_KEPT;

/// One range-bearing detection of a scan, in the sensor frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Detection {
    /// Range, m (> 0).
    pub range: f64,
    /// Bearing relative to the robot's heading, rad.
    pub bearing: f64,
    /// The landmark's id when the sensor knows it (barcodes); required by
    /// [`Association::Known`], ignored otherwise.
    pub id: Option<u64>,
}

/// One timed input of the engine.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// From `t` on, the vehicle's two controls are `control` (MR.CLAM: `v`, `omega`;
    /// Victoria Park: encoder speed, steering).
    Control {
        /// Time stamp, s.
        t: f64,
        /// The two controls.
        control: [f64; 2],
    },
    /// All detections of one scan, applied in one batch update.
    Scan {
        /// Time stamp, s.
        t: f64,
        /// The detections.
        detections: Vec<Detection>,
    },
    /// The walls extracted from one laser scan, applied in one batch update.
    Walls {
        /// Time stamp, s.
        t: f64,
        /// The walls, in the sensor frame.
        walls: Vec<WallDetection>,
    },
    /// An external measurement of the robot's xy (eqs. 26-27), world frame.
    Fix {
        /// Time stamp, s.
        t: f64,
        /// Measured `(x, y)`.
        xy: [f64; 2],
        /// Its covariance `(xx, xy, yy)`.
        covariance: [f64; 3],
    },
}

impl Event {
    /// The event's time stamp.
    pub fn time(&self) -> f64 {
        match self {
            Event::Control { t, .. }
            | Event::Scan { t, .. }
            | Event::Walls { t, .. }
            | Event::Fix { t, .. } => *t,
        }
    }
}

/// A whole run as columnar arrays, each sorted by time (numpy's `(n, k)` row-major
/// arrays map onto these slices without copying). Detections with equal time stamps
/// form one scan, and so do walls. At equal times, controls come first, then scans,
/// then walls, then fixes.
#[derive(Debug, Clone, Copy, Default)]
pub struct EventArrays<'a> {
    /// Rows `(t, control_0, control_1)`.
    pub controls: &'a [[f64; 3]],
    /// Rows `(t, range, bearing)`.
    pub detections: &'a [[f64; 3]],
    /// One id per detection (negative: unknown), or `None` when no id is known.
    pub detection_ids: Option<&'a [i64]>,
    /// Rows `(t, x, y, var_x, cov_xy, var_y)`.
    pub fixes: &'a [[f64; 6]],
    /// Wall rows `(t, rho, alpha, var_rho, cov, var_alpha, x0, y0, x1, y1)` in the
    /// sensor frame (see [`WallDetection`]).
    pub walls: &'a [[f64; 10]],
}

/// One wall of a scan in the sensor frame: the line `x cos(alpha) + y sin(alpha) =
/// rho` with its covariance, and the seen segment's end points (outside the state:
/// they grow the wall's drawn extent and decide segment overlap).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WallDetection {
    /// Distance from the sensor to the line, m (>= 0).
    pub rho: f64,
    /// Direction of the line's normal, rad.
    pub alpha: f64,
    /// Covariance of `(rho, alpha)`, row-major 2x2 (symmetric positive definite).
    pub covariance: [f64; 4],
    /// First end point of the seen segment, m.
    pub start: [f64; 2],
    /// Last end point of the seen segment, m.
    pub end: [f64; 2],
}

/// What kind of event a trajectory row follows (`as u8`: 0, 1, 2, 3).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum EventKind {
    /// A control.
    Control = 0,
    /// A scan.
    Scan = 1,
    /// An external fix.
    Fix = 2,
    /// A scan's walls.
    Walls = 3,
}

/// The robot after every event, in the world frame: one row per event.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Trajectory {
    /// Event times, s.
    pub t: Vec<f64>,
    /// Event kinds.
    pub kind: Vec<EventKind>,
    /// Robot poses `(x, y, theta)`.
    pub pose: Vec<[f64; 3]>,
    /// Robot covariances `P_rr`, row-major 3x3.
    pub covariance: Vec<[f64; 9]>,
    /// Wall-clock seconds spent on each event.
    pub seconds: Vec<f64>,
}

/// A landmark of the final map, in the world frame.
#[derive(Debug, Clone, PartialEq)]
pub struct LandmarkEstimate {
    /// The landmark's id (the barcode's, or assigned in order of admission).
    pub id: u64,
    /// Position `(x, y)`.
    pub mean: [f64; 2],
    /// Covariance, row-major 2x2 (the anchor's is zero: it defines the frame).
    pub covariance: [f64; 4],
    /// How many updates used it.
    pub revisions: u32,
    /// Whether it left the state (freezing).
    pub frozen: bool,
    /// Whether it is the anchor (eqs. 24-25).
    pub anchor: bool,
}

/// A wall of the final map, in the world frame.
#[derive(Debug, Clone, PartialEq)]
pub struct WallEstimate {
    /// The wall's id (assigned in order of admission, shared with the points' ids).
    pub id: u64,
    /// `(rho, alpha)`, `rho >= 0`, `alpha` in (-pi, pi].
    pub line: [f64; 2],
    /// Covariance of `(rho, alpha)`, row-major 2x2 (the anchor's is zero).
    pub covariance: [f64; 4],
    /// The seen extent: the union of the segments paired with it, on its line, m.
    pub start: [f64; 2],
    /// See `start`.
    pub end: [f64; 2],
    /// The wall's reference point, m: the filter estimates the line about it (the
    /// middle of the segment that first showed the wall), which keeps its updates
    /// linear where the world origin is far away.
    pub origin: [f64; 2],
    /// How many updates used it.
    pub revisions: u32,
    /// Whether it left the state (freezing).
    pub frozen: bool,
    /// Whether it is the anchor.
    pub anchor: bool,
}

/// Association and update counts of a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Statistics {
    /// Detections paired with a landmark and applied.
    pub accepted: u64,
    /// Detections refused: outside the gate (known ids), or compatible with a
    /// landmark but left out by the association.
    pub rejected: u64,
    /// Landmarks admitted into the map.
    pub new: u64,
    /// Sightings held in the candidate list without entering the map.
    pub candidate: u64,
    /// Landmarks frozen.
    pub frozen: u64,
    /// External fixes applied, refused by their gate, and ignored (variant off).
    pub fixes_applied: u64,
    /// See `fixes_applied`.
    pub fixes_rejected: u64,
    /// See `fixes_applied`.
    pub fixes_ignored: u64,
    /// Scans whose JCBB search hit its node budget.
    pub jcbb_truncated: u64,
    /// Active areas made by the compressed filter (each after a global update of the
    /// previous one; see [`Compression`]).
    pub compressions: u64,
    /// Passive landmarks brought into the active area of a compressed filter.
    pub activations: u64,
    /// Wall detections paired with a wall and applied.
    pub walls_accepted: u64,
    /// Wall detections compatible with a wall but left out by the association.
    pub walls_rejected: u64,
    /// Walls admitted into the map.
    pub walls_new: u64,
    /// Wall detections left unused because their angle is too uncertain
    /// (`wall_max_angle_sd`).
    pub walls_vague: u64,
}

/// Everything a run produced.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanarResult {
    /// The robot after every event.
    pub trajectory: Trajectory,
    /// The point map, sorted by id.
    pub landmarks: Vec<LandmarkEstimate>,
    /// The wall map, sorted by id.
    pub walls: Vec<WallEstimate>,
    /// Association statistics.
    pub statistics: Statistics,
    /// The point anchor's world position (the origin of the engine's internal
    /// frame); `None` without an anchor or when the anchor is a wall.
    pub anchor: Option<[f64; 2]>,
    /// The time the anchor was made: the robot covariance is relative to the anchor
    /// from then on, in the world frame before.
    pub anchor_time: Option<f64>,
    /// The data association of the walls: for every wall detection, in the order
    /// given, the id of the wall it was paired with or admitted as; `None` when it
    /// was left out (too vague an angle, or ambiguous).
    pub wall_pairing: Vec<Option<u64>>,
    /// The data association of the point detections: for every one, in the order
    /// given, the id of the landmark it updated or admitted; `None` when it was
    /// rejected by the gate or left as a candidate.
    pub point_pairing: Vec<Option<u64>>,
}
