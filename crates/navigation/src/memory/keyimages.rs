//! Key images (section 2.4): a learnt path A -> B is stored as a chain of key images
//! `I_k = {(m_i, L_i)}`, each the models seen in one frame with their image poses,
//! chosen so that (i) successive key images share at least one model and (ii) no
//! shared model turns by more than a threshold between them. Visual servoing then
//! carries the robot from each key image to the next.

use rperc_core::{Pose2, angle_diff};

use crate::error::{NavigationError, Result};

/// One tracked model in one frame.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TrackedModel {
    /// The model's id.
    pub id: usize,
    /// The tracker's state `(x, y, theta, s)` in the ideal image.
    pub state: [f64; 4],
    /// The tracker's score.
    pub score: f64,
}

/// When a new key image is taken.
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct KeyImageParams {
    /// Condition (ii): the largest turn of a shared model between successive key
    /// images, radians.
    pub max_turn: f64,
    /// The largest image displacement of a shared model between successive key images,
    /// pixels: short elementary trajectories keep the replay close to the learnt path
    /// (the seed's "approximatively fits").
    pub max_shift: f64,
    /// The largest travel of the robot between successive key images, ideal-image
    /// pixels (its pose in the mosaic over the mosaic's units per pixel): a model near
    /// the turn's centre barely shifts in the image while the robot drives on, and one
    /// such model alone is a poor guide over a long stretch.
    pub max_travel: f64,
}

impl Default for KeyImageParams {
    fn default() -> Self {
        Self {
            max_turn: 20f64.to_radians(),
            max_shift: 60.0,
            max_travel: 60.0,
        }
    }
}

impl KeyImageParams {
    /// Refuses bad values with the parameter's name.
    pub fn validate(&self) -> Result<()> {
        rperc_core::ensure_in_range("max_turn", self.max_turn, 1e-6, std::f64::consts::PI)?;
        rperc_core::ensure_positive("max_shift", self.max_shift)?;
        rperc_core::ensure_positive("max_travel", self.max_travel)?;
        Ok(())
    }
}

/// A key image: the models of one learning frame with their image poses (ideal image),
/// and where the robot was then by eq. 2 (for drawing and scoring; the servoing reads
/// only the image poses).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct KeyImage {
    /// The learning frame it was taken from.
    pub frame: usize,
    /// `(model id, tracker state)` of every model seen.
    pub models: Vec<TrackedModel>,
    /// The robot in the mosaic at that frame (eq. 2).
    pub pose: Pose2,
}

/// One frame of a learning run: its index, the tracked models and the robot's pose.
#[derive(Debug, Clone, PartialEq)]
pub struct LearntFrame {
    /// Frame index.
    pub frame: usize,
    /// Models tracked in it.
    pub models: Vec<TrackedModel>,
    /// The robot in the mosaic, if localised.
    pub pose: Option<Pose2>,
}

/// How far apart two model sets are: `None` when they share no model, else the
/// largest turn and the largest image shift of a shared model.
pub fn separation(a: &[TrackedModel], b: &[TrackedModel]) -> Option<(f64, f64)> {
    let mut out: Option<(f64, f64)> = None;
    for m in a {
        if let Some(n) = b.iter().find(|n| n.id == m.id) {
            let turn = angle_diff(n.state[2], m.state[2]).abs();
            let shift = (n.state[0] - m.state[0]).hypot(n.state[1] - m.state[1]);
            let (t, s) = out.unwrap_or((0.0, 0.0));
            out = Some((t.max(turn), s.max(shift)));
        }
    }
    out
}

/// Whether frame `b` may follow key image `a` (models and pose): a shared model, its
/// turn and shift within the limits, and the robot's travel (in pixels, through
/// `units_per_pixel`) too.
fn within(
    a: (&[TrackedModel], &Pose2),
    b: (&[TrackedModel], &Pose2),
    params: &KeyImageParams,
    units_per_pixel: f64,
) -> bool {
    let travel = (b.1.x - a.1.x).hypot(b.1.y - a.1.y) / units_per_pixel;
    travel <= params.max_travel
        && separation(a.0, b.0)
            .is_some_and(|(turn, shift)| turn <= params.max_turn && shift <= params.max_shift)
}

/// Chooses the key images of a learning run: the first localised frame, then, each
/// time the next frame would break a condition against the last key image, the frame
/// before it, and the last frame (B). `units_per_pixel` is the mosaic's unit per
/// ideal-image pixel (`Z / f` for a metric mosaic, 1 for one in pixels). Errors when
/// two successive frames already break them (the run lost every model, or turned or
/// moved too fast to be learnt).
pub fn select_key_images(
    frames: &[LearntFrame],
    params: &KeyImageParams,
    units_per_pixel: f64,
) -> Result<Vec<KeyImage>> {
    params.validate()?;
    rperc_core::ensure_positive("units_per_pixel", units_per_pixel)?;
    let usable: Vec<&LearntFrame> = frames
        .iter()
        .filter(|f| f.pose.is_some() && !f.models.is_empty())
        .collect();
    let Some(first) = usable.first() else {
        return Err(invalid(
            "frames",
            "no frame of the learning run is localised".into(),
        ));
    };
    let key = |f: &LearntFrame| KeyImage {
        frame: f.frame,
        models: f.models.clone(),
        pose: f.pose.unwrap_or_default(),
    };
    let mut keys = vec![key(first)];
    for pair in usable.windows(2) {
        let (prev, next) = (pair[0], pair[1]);
        let pose = |f: &LearntFrame| f.pose.unwrap_or_default();
        let last = keys
            .last()
            .map(|k| (&k.models[..], k.pose))
            .unwrap_or_default();
        let (next_pose, prev_pose) = (pose(next), pose(prev));
        if within(
            (last.0, &last.1),
            (&next.models, &next_pose),
            params,
            units_per_pixel,
        ) {
            continue;
        }
        let step = within(
            (&prev.models, &prev_pose),
            (&next.models, &next_pose),
            params,
            units_per_pixel,
        );
        if !step || keys.last().map(|k| k.frame) == Some(prev.frame) {
            return Err(invalid(
                "frames",
                format!(
                    "frames {} and {} break the key-image conditions (no shared model, or a \
                     turn or shift beyond the limits): the run cannot be learnt",
                    prev.frame, next.frame
                ),
            ));
        }
        keys.push(key(prev));
    }
    if let Some(last) = usable.last()
        && keys.last().map(|k| k.frame) != Some(last.frame)
    {
        keys.push(key(last));
    }
    Ok(keys)
}

/// Checks a chain of key images against conditions (i) and (ii); the error names the
/// first pair that breaks them.
pub fn check_chain(keys: &[KeyImage], params: &KeyImageParams) -> Result<()> {
    params.validate()?;
    if keys.is_empty() {
        return Err(invalid("key_images", "the chain is empty".into()));
    }
    for (k, pair) in keys.windows(2).enumerate() {
        match separation(&pair[0].models, &pair[1].models) {
            None => {
                return Err(invalid(
                    "key_images",
                    format!("key images {k} and {} share no model (condition i)", k + 1),
                ));
            }
            Some((turn, _)) if turn > params.max_turn => {
                return Err(invalid(
                    "key_images",
                    format!(
                        "a model turns {:.1} deg between key images {k} and {} (condition ii)",
                        turn.to_degrees(),
                        k + 1
                    ),
                ));
            }
            Some(_) => {}
        }
    }
    Ok(())
}

fn invalid(name: &'static str, reason: String) -> NavigationError {
    NavigationError::InvalidParameter { name, reason }
}
