//! What [`super::ColorTemplateTracker::update`] answers: the box, the score, the lost
//! flag and the signals the flag is decided from.

use crate::colour::TrackResult;
use crate::frame::BoundingBox;

/// How sure one frame's answer is: the signals the lost rule reads.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Confidence {
    /// The merged (template and colour) response's peak.
    pub peak: f64,
    /// Peak-to-sidelobe ratio of the template's correlation response (MOSSE): the
    /// peak's height over the rest of the map in standard deviations.
    pub psr: f64,
    /// Average peak-to-correlation energy of the template's response (LMCF): the squared
    /// peak over the map's mean squared energy, both above the map's minimum.
    pub apce: f64,
    /// Mean foreground probability of the colour model over the target-sized box at the
    /// peak, in [0, 1].
    pub color_score: f64,
    /// The first frame's colour model's mean foreground probability over the box minus
    /// its mean over the rest of the search window, in [-1, 1]: near or under 0 when
    /// the box has drifted onto the background.
    pub contrast: f64,
}

/// One answer of the colour + template tracker.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TemplateResult {
    /// The target's box `(x, y, w, h)`.
    pub bbox: BoundingBox,
    /// The merged response's peak, clamped to [0, 1].
    pub score: f64,
    /// The target is not where the box is (see `ColorTemplateParams::lost_ratio` and the
    /// other `lost_*` fields).
    pub lost: bool,
    /// The signals `lost` was decided from.
    pub confidence: Confidence,
}

impl From<TemplateResult> for TrackResult {
    fn from(r: TemplateResult) -> Self {
        Self {
            bbox: r.bbox,
            score: r.score,
            lost: r.lost,
        }
    }
}
