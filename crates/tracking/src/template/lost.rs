//! The lost rule: the frame's signals against their running levels over the tracked
//! frames. A target is lost when the merged peak sinks (`lost_ratio`), when the template's
//! response loses its single sharp peak (PSR, `lost_psr_ratio`) or when the colour under
//! the box stops looking like the target's (`lost_color_ratio`); each ratio of 0 turns
//! its test off. A slow drift onto the background escapes those (the models learn on
//! the way, and the levels follow); the seed's colour contrast catches it
//! (`lost_contrast_ratio`, against its level over the warm-up frames), with hysteresis:
//! a target lost is found again only once the contrast is back over
//! `found_contrast_ratio` of the level (a box on the background hovers around 0 and
//! would flicker between lost and found across a single threshold). While lost, a
//! window whose seed contrast is back over `refind_contrast_ratio` of the level is the
//! target again whatever its peak (the peak's level is of the appearance before the
//! loss, and sinks slowly). The same rule
//! accepts a re-detection candidate, so a target is taken up again only where it would
//! not be declared lost.

use super::params::ColorTemplateParams;

/// Where one search window put the target.
#[derive(Debug, Clone, Copy)]
pub(super) struct Located {
    /// The merged response's peak.
    pub(super) peak: f64,
    /// PSR of the template's response.
    pub(super) psr: f64,
    /// APCE of the template's response.
    pub(super) apce: f64,
    /// The colour response at the merged peak.
    pub(super) color: f64,
    /// The seed colour model's contrast of the box at the merged peak
    /// ([`super::contrast::contrast`]).
    pub(super) contrast: f64,
    /// The target's centre it implies, frame pixels.
    pub(super) cx: f64,
    /// The target's centre it implies, frame pixels.
    pub(super) cy: f64,
}

/// The running level of the peak is the plain mean of the tracked frames' signals for
/// the first `1 / LEVEL_RATE` of them, then an average with this weight: slow enough
/// that a signal sinking over a few tens of frames (a target sliding behind an
/// occluder) still falls below it, instead of dragging it down.
const LEVEL_RATE: f64 = 0.02;
/// PSR is infinite for a peak over a constant sidelobe; the level takes it at this
/// value (real responses give 5-60) so one such frame cannot hold it up for ever.
const PSR_CAP: f64 = 1e3;
/// Tracked frames whose signals set the levels before a loss can be declared; the
/// contrast's level is their mean, then stays.
pub(super) const WARM_UP_FRAMES: usize = 5;

/// Running levels of the signals over tracked frames (zero before the first).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(super) struct Levels {
    /// The merged response's peak.
    pub(super) peak: f64,
    /// The template response's PSR.
    pub(super) psr: f64,
    /// The colour score at the peak.
    pub(super) color: f64,
    /// The seed contrast: its mean over the warm-up frames, then fixed, neither
    /// followed nor decayed. A running level follows a slow drift down (on the OTB
    /// dev sequences it ranked the IoU-0 frames worse than the warm-up mean does;
    /// figures: `docs/decisions.md`), and the seed's model does not change, so its
    /// contrast need not sink to take a target up again.
    pub(super) contrast: f64,
}

impl Levels {
    /// Takes in the `n`-th tracked frame's signals (`n >= 1`).
    pub(super) fn follow(&mut self, found: &Located, n: usize) {
        let rate = (1.0 / n as f64).max(LEVEL_RATE);
        let mix = |level: f64, value: f64| (1.0 - rate) * level + rate * value;
        self.peak = mix(self.peak, found.peak);
        self.psr = mix(self.psr, found.psr.min(PSR_CAP));
        self.color = mix(self.color, found.color);
        if n <= WARM_UP_FRAMES {
            let mean = 1.0 / n as f64;
            self.contrast = (1.0 - mean) * self.contrast + mean * found.contrast;
        }
    }

    /// Every followed level (not the seed contrast) times `factor`.
    pub(super) fn decay(&mut self, factor: f64) {
        self.peak *= factor;
        self.psr *= factor;
        self.color *= factor;
    }
}

/// The thresholds of the rule, as fractions of the levels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct LostRule {
    peak: f64,
    psr: f64,
    color: f64,
    contrast: Option<f64>,
    found_contrast: f64,
    refind_contrast: Option<f64>,
}

impl LostRule {
    pub(super) fn new(p: &ColorTemplateParams) -> Self {
        Self {
            peak: p.lost_ratio,
            psr: p.lost_psr_ratio,
            color: p.lost_color_ratio,
            contrast: p.lost_contrast_ratio,
            found_contrast: p.found_contrast_ratio,
            refind_contrast: p.refind_contrast_ratio,
        }
    }

    /// Whether `found` is the target by the rule: no signal under its threshold; while
    /// the target `was_lost`, the contrast's threshold is the higher of the lost and
    /// found ratios. The contrast test needs a seed that stood out from its
    /// surroundings (a positive level): otherwise its colours tell nothing about where
    /// the target is.
    pub(super) fn passes(&self, found: &Located, levels: &Levels, was_lost: bool) -> bool {
        let contrast = match self.contrast {
            Some(lost) if levels.contrast > 0.0 => {
                let ratio = if was_lost {
                    lost.max(self.found_contrast)
                } else {
                    lost
                };
                found.contrast >= ratio * levels.contrast
            }
            _ => true,
        };
        let usual = found.peak >= self.peak * levels.peak
            && found.psr >= self.psr * levels.psr
            && found.color >= self.color * levels.color
            && contrast;
        usual || (was_lost && self.refound(found, levels))
    }

    /// Whether a lost target is back by its seed contrast alone: the peak and colour
    /// levels are those of the appearance before the loss, which the frames up to it
    /// (learned from at a fading rate) may have blurred; the seed's model was not.
    fn refound(&self, found: &Located, levels: &Levels) -> bool {
        self.refind_contrast
            .is_some_and(|r| levels.contrast > 0.0 && found.contrast >= r * levels.contrast)
    }

    /// The merged-peak threshold (where learning has faded to nothing).
    pub(super) fn peak_ratio(&self) -> f64 {
        self.peak
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(peak: f64, psr: f64, color: f64) -> Located {
        Located {
            peak,
            psr,
            apce: 0.0,
            color,
            contrast: 0.0,
            cx: 0.0,
            cy: 0.0,
        }
    }

    /// Each ratio tests its own signal, and a ratio of 0 never fires.
    #[test]
    fn each_signal_against_its_level() {
        let levels = Levels {
            peak: 0.4,
            psr: 20.0,
            color: 0.6,
            contrast: 0.4,
        };
        let rule = LostRule {
            peak: 0.5,
            psr: 0.5,
            color: 0.5,
            contrast: None,
            found_contrast: 0.0,
            refind_contrast: None,
        };
        assert!(rule.passes(&at(0.2, 10.0, 0.3), &levels, false));
        assert!(!rule.passes(&at(0.19, 10.0, 0.3), &levels, false));
        assert!(!rule.passes(&at(0.2, 9.9, 0.3), &levels, false));
        assert!(!rule.passes(&at(0.2, 10.0, 0.29), &levels, false));
        let off = LostRule {
            peak: 0.0,
            psr: 0.0,
            color: 0.0,
            contrast: None,
            found_contrast: 0.0,
            refind_contrast: None,
        };
        assert!(off.passes(&at(0.0, 0.0, 0.0), &levels, true));
    }

    /// The contrast test: a negative ratio puts the threshold under 0 (the box less
    /// target-coloured than its surroundings by that share of the seed's contrast);
    /// once lost, the found ratio's threshold holds (hysteresis); `None` or a seed
    /// without contrast never fires.
    #[test]
    fn contrast_against_the_seed_level_with_hysteresis() {
        let mut levels = Levels {
            contrast: 0.4,
            ..Levels::default()
        };
        let rule = LostRule {
            peak: 0.0,
            psr: 0.0,
            color: 0.0,
            contrast: Some(-0.25),
            found_contrast: 0.5,
            refind_contrast: None,
        };
        let with = |c: f64| Located {
            contrast: c,
            ..at(0.0, 0.0, 0.0)
        };
        assert!(rule.passes(&with(-0.1), &levels, false));
        assert!(!rule.passes(&with(-0.1001), &levels, false));
        assert!(!rule.passes(&with(0.1999), &levels, true));
        assert!(rule.passes(&with(0.2), &levels, true));
        let below = LostRule {
            found_contrast: -0.5,
            ..rule
        };
        assert!(!below.passes(&with(-0.1001), &levels, true));
        levels.contrast = 0.0;
        assert!(rule.passes(&with(-1.0), &levels, true));
        levels.contrast = 0.4;
        let off = LostRule {
            contrast: None,
            ..rule
        };
        assert!(off.passes(&with(-1.0), &levels, true));
    }

    /// While lost, a window whose contrast reaches the refind ratio of the seed level
    /// is the target even with its peak under threshold; while tracked, it is not.
    #[test]
    fn a_lost_target_is_refound_by_its_contrast() {
        let levels = Levels {
            peak: 1.0,
            contrast: 0.4,
            ..Levels::default()
        };
        let rule = LostRule {
            peak: 0.6,
            psr: 0.0,
            color: 0.0,
            contrast: None,
            found_contrast: 0.0,
            refind_contrast: Some(0.7),
        };
        let weak = |c: f64| Located {
            contrast: c,
            ..at(0.5, 0.0, 0.0)
        };
        assert!(!rule.passes(&weak(0.28), &levels, false));
        assert!(rule.passes(&weak(0.28), &levels, true));
        assert!(!rule.passes(&weak(0.2799), &levels, true));
        let off = LostRule {
            refind_contrast: None,
            ..rule
        };
        assert!(!off.passes(&weak(1.0), &levels, true));
    }

    /// The first tracked frame sets the levels; later ones average in at `1 / n`
    /// (a plain mean), an infinite PSR counting as the cap.
    #[test]
    fn levels_are_running_means() {
        let mut levels = Levels::default();
        levels.follow(&at(0.3, 10.0, 0.5), 1);
        assert_eq!(
            levels,
            Levels {
                peak: 0.3,
                psr: 10.0,
                color: 0.5,
                contrast: 0.0,
            }
        );
        levels.follow(&at(0.5, f64::INFINITY, 0.7), 2);
        assert!((levels.peak - 0.4).abs() < 1e-12);
        assert!((levels.psr - (10.0 + PSR_CAP) / 2.0).abs() < 1e-9);
        assert!((levels.color - 0.6).abs() < 1e-12);
    }

    /// The seed contrast is the plain mean of the warm-up frames' contrasts; later
    /// frames and a decay leave it.
    #[test]
    fn seed_contrast_is_the_warm_up_mean() {
        let mut levels = Levels::default();
        let values = [0.5, 0.3, 0.4, 0.6, 0.2];
        for (n, c) in values.iter().enumerate() {
            let found = Located {
                contrast: *c,
                ..at(1.0, 1.0, 1.0)
            };
            levels.follow(&found, n + 1);
        }
        let mean = values.iter().sum::<f64>() / values.len() as f64;
        assert!((levels.contrast - mean).abs() < 1e-12);
        let late = Located {
            contrast: -1.0,
            ..at(1.0, 1.0, 1.0)
        };
        levels.follow(&late, WARM_UP_FRAMES + 1);
        levels.decay(0.5);
        assert!((levels.contrast - mean).abs() < 1e-12);
    }
}
