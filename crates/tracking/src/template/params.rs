//! The typed configuration of [`super::ColorTemplateTracker`].

use rperc_core::{ensure_in_range as in_range, ensure_positive as positive};

use crate::colour::{ColorSpace, check_bins};
use crate::error::{Result, TrackingError};

/// Parameters of a [`super::ColorTemplateTracker`]. Defaults chosen by
/// leave-one-sequence-out over the ten dev OTB sequences (see the crate README).
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct ColorTemplateParams {
    /// Side in pixels of the square whose area the search window is resampled to
    /// (Staple's fixed area): bounds the cost of a frame whatever the target's size.
    /// Default 96, in 32..=256.
    pub template_size: usize,
    /// HOG cell side in patch pixels, in 2..=8. Default 4.
    pub cell_size: usize,
    /// The search window is the target grown by `padding` times its mean side on each
    /// axis, in 0.2..=4. Default 1.
    pub padding: f64,
    /// Learning rate of the translation filter (running average of its numerator and
    /// denominator), in (0, 1]. Default 0.02.
    pub learning_rate: f64,
    /// Regulariser `lambda` of the correlation filters, > 0. Default 1e-3. Spelled
    /// `lambda_` in configs (`lambda` is a Python keyword).
    #[serde(rename = "lambda_")]
    pub lambda: f64,
    /// Width of the Gaussian label as a fraction of the target's mean side (in cells),
    /// > 0. Default 1/16.
    pub output_sigma_factor: f64,
    /// Colour space of the foreground and background histograms. Default RGB.
    pub color_space: ColorSpace,
    /// Histogram bins per axis. Default 32 x 32 x 32.
    pub bins: [usize; 3],
    /// Learning rate of the colour histograms, in (0, 1]. Default 0.04.
    pub color_learning_rate: f64,
    /// The foreground histogram is learned inside the target shrunk by this times its
    /// mean side (its edges mix target and background), in [0, 0.45]. Default 0.2.
    pub inner_padding: f64,
    /// Weight of the colour response in the merged response map, in [0, 1]; 0 is the
    /// template alone, 1 the colour alone. Default 0.2.
    pub merge_factor: f64,
    /// Scales sampled by the scale filter (odd, 3..=65). Default 17.
    pub n_scales: usize,
    /// Ratio between neighbouring scale samples, in (1, 1.5]. Default 1.03.
    pub scale_step: f64,
    /// Learning rate of the scale filter, in (0, 1]. Default 0.025.
    pub scale_learning_rate: f64,
    /// Width of the scale filter's Gaussian label, in scale steps, > 0. Default 1.
    pub scale_sigma: f64,
    /// Pixel area each scale sample is resampled to before HOG, in 64..=4096.
    /// Default 512.
    pub scale_model_area: f64,
    /// Smallest scale relative to the first box, in (0, 1]. Default 0.1.
    pub min_scale: f64,
    /// Largest scale relative to the first box, >= 1. Default 10.
    pub max_scale: f64,
    /// The target is lost when the merged response's peak falls below this fraction of
    /// its running level over tracked frames, in [0, 1]; 0 never reports a loss.
    /// Learning fades linearly from the level down to this threshold. Default 0.6.
    pub lost_ratio: f64,
    /// The target is also lost when the template response's peak-to-sidelobe ratio
    /// falls below this fraction of its running level, in [0, 1]; 0 turns the test off.
    /// Default 0.
    pub lost_psr_ratio: f64,
    /// The target is also lost when the colour score at the peak (the mean foreground
    /// probability over the box) falls below this fraction of its running level, in
    /// [0, 1]; 0 turns the test off. Default 0.75 (with `lost_level_decay`, chosen on
    /// the ten OTB dev sequences by `benchmarks/template_lost.py`: the best F1 of the
    /// flag against IoU-0 frames among the settings within 0.005 of the best mean AUC).
    pub lost_color_ratio: f64,
    /// The target is also lost when the seed's colour contrast (the first frame's
    /// colour model's mean foreground probability over the box minus over the rest of
    /// the search window, in [-1, 1]) falls below this multiple of its mean over the
    /// first tracked frames, in [-1, 1]: catches a slow drift onto the background,
    /// which the other signals follow. `None` turns the test off. Default `None`: on
    /// its own, leave-one-sequence-out over the ten OTB dev sequences chose no setting
    /// of it that improved the flag's precision and recall at once (see the guide).
    pub lost_contrast_ratio: Option<f64>,
    /// Hysteresis of the contrast test: once lost, the target is found again only when
    /// the seed's colour contrast is back over this multiple of its warm-up mean (or
    /// `lost_contrast_ratio`, when higher), in [-1, 1]. Default 0.5.
    pub found_contrast_ratio: f64,
    /// While lost, a window whose seed colour contrast reaches this multiple of its
    /// warm-up mean is the target again even when its peak or colour score is under
    /// its threshold (those levels are of the appearance just before the loss), in
    /// [0, 1]; `None` turns this off. Default 0.7: with the levels sinking slowly, a
    /// target back after a short occlusion is then taken up at once (the OTB dev
    /// sequences hardly tell 0.7, 0.8, 0.9 and off apart; figures:
    /// `docs/decisions.md`).
    pub refind_contrast_ratio: Option<f64>,
    /// Factor on the running levels per lost frame, in (0, 1]: below 1 a target that
    /// came back changed (turned, lit differently) is taken up again; 1 holds it to its
    /// old levels. Default 0.995 (halves them in about 140 frames; chosen with
    /// `lost_color_ratio`): a long loss stays flagged instead of the sunk levels taking
    /// up the background after a few tens of frames.
    pub lost_level_decay: f64,
    /// Re-detection: while lost, the search also covers windows centred
    /// `redetect_step` window sizes apart around the last position, in (0, 2].
    /// Default 0.75.
    pub redetect_step: f64,
    /// Re-detection: the grid of windows reaches this many steps each way (1: 3 x 3),
    /// in 0..=4; 0 searches only the last window. Default 1.
    pub redetect_radius: usize,
    /// Re-detection: a window away from the last position is taken when it passes the
    /// lost rule and its merged peak reaches this fraction of the running level, in
    /// [0, 1] (1: the full level; at most `lost_ratio`: the lost rule alone). Far away,
    /// another object of the same kind is likelier than the target. Default 1.
    pub redetect_ratio: f64,
    /// While lost, the box moves this fraction of the way to the last window's peak
    /// (without learning from it), in [0, 1]: 0 keeps it where the target was last
    /// seen (right behind an occluder), 1 follows the peak (right when the loss was
    /// a false alarm). Default 1.
    pub lost_motion: f64,
}

impl Default for ColorTemplateParams {
    fn default() -> Self {
        Self {
            template_size: 96,
            cell_size: 4,
            padding: 1.0,
            learning_rate: 0.02,
            lambda: 1e-3,
            output_sigma_factor: 1.0 / 16.0,
            color_space: ColorSpace::Rgb,
            bins: [32, 32, 32],
            color_learning_rate: 0.04,
            inner_padding: 0.2,
            merge_factor: 0.2,
            n_scales: 17,
            scale_step: 1.03,
            scale_learning_rate: 0.025,
            scale_sigma: 1.0,
            scale_model_area: 512.0,
            min_scale: 0.1,
            max_scale: 10.0,
            lost_ratio: 0.6,
            lost_psr_ratio: 0.0,
            lost_color_ratio: 0.75,
            lost_contrast_ratio: None,
            found_contrast_ratio: 0.5,
            refind_contrast_ratio: Some(0.7),
            lost_level_decay: 0.995,
            redetect_step: 0.75,
            redetect_radius: 1,
            redetect_ratio: 1.0,
            lost_motion: 1.0,
        }
    }
}

fn count_in(name: &'static str, value: usize, lo: usize, hi: usize) -> Result<()> {
    if (lo..=hi).contains(&value) {
        Ok(())
    } else {
        Err(TrackingError::InvalidParameter {
            name,
            reason: format!("must be in {lo}..={hi}, got {value}"),
        })
    }
}

impl ColorTemplateParams {
    /// Refuses bad values with the parameter's name.
    ///
    /// # Errors
    /// [`TrackingError::InvalidParameter`] naming the first bad field.
    pub fn validate(&self) -> Result<()> {
        count_in("template_size", self.template_size, 32, 256)?;
        count_in("cell_size", self.cell_size, 2, 8)?;
        in_range("padding", self.padding, 0.2, 4.0)?;
        rate("learning_rate", self.learning_rate)?;
        positive("lambda_", self.lambda)?;
        positive("output_sigma_factor", self.output_sigma_factor)?;
        check_bins(self.bins)?;
        rate("color_learning_rate", self.color_learning_rate)?;
        in_range("inner_padding", self.inner_padding, 0.0, 0.45)?;
        in_range("merge_factor", self.merge_factor, 0.0, 1.0)?;
        count_in("n_scales", self.n_scales, 3, 65)?;
        if self.n_scales.is_multiple_of(2) {
            return Err(TrackingError::InvalidParameter {
                name: "n_scales",
                reason: format!("must be odd, got {}", self.n_scales),
            });
        }
        in_range("scale_step", self.scale_step, 1.0 + 1e-6, 1.5)?;
        rate("scale_learning_rate", self.scale_learning_rate)?;
        positive("scale_sigma", self.scale_sigma)?;
        in_range("scale_model_area", self.scale_model_area, 64.0, 4096.0)?;
        in_range("min_scale", self.min_scale, 1e-3, 1.0)?;
        in_range("max_scale", self.max_scale, 1.0, 1e3)?;
        in_range("lost_ratio", self.lost_ratio, 0.0, 1.0)?;
        in_range("lost_psr_ratio", self.lost_psr_ratio, 0.0, 1.0)?;
        in_range("lost_color_ratio", self.lost_color_ratio, 0.0, 1.0)?;
        if let Some(ratio) = self.lost_contrast_ratio {
            in_range("lost_contrast_ratio", ratio, -1.0, 1.0)?;
        }
        in_range("found_contrast_ratio", self.found_contrast_ratio, -1.0, 1.0)?;
        if let Some(ratio) = self.refind_contrast_ratio {
            in_range("refind_contrast_ratio", ratio, 0.0, 1.0)?;
        }
        rate("lost_level_decay", self.lost_level_decay)?;
        in_range("redetect_step", self.redetect_step, 1e-3, 2.0)?;
        in_range("lost_motion", self.lost_motion, 0.0, 1.0)?;
        in_range("redetect_ratio", self.redetect_ratio, 0.0, 1.0)?;
        count_in("redetect_radius", self.redetect_radius, 0, 4)
    }
}

fn rate(name: &'static str, value: f64) -> Result<()> {
    if value.is_finite() && value > 0.0 && value <= 1.0 {
        Ok(())
    } else {
        Err(TrackingError::InvalidParameter {
            name,
            reason: format!("must be in (0, 1], got {value}"),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_bad_values_are_named() {
        ColorTemplateParams::default().validate().unwrap();
        let cases: Vec<(ColorTemplateParams, &str)> = vec![
            (
                ColorTemplateParams {
                    learning_rate: f64::NAN,
                    ..Default::default()
                },
                "learning_rate",
            ),
            (
                ColorTemplateParams {
                    n_scales: 16,
                    ..Default::default()
                },
                "n_scales",
            ),
            (
                ColorTemplateParams {
                    merge_factor: 1.5,
                    ..Default::default()
                },
                "merge_factor",
            ),
            (
                ColorTemplateParams {
                    bins: [0, 4, 4],
                    ..Default::default()
                },
                "bins",
            ),
            (
                ColorTemplateParams {
                    template_size: 8,
                    ..Default::default()
                },
                "template_size",
            ),
            (
                ColorTemplateParams {
                    lost_motion: -0.1,
                    ..Default::default()
                },
                "lost_motion",
            ),
            (
                ColorTemplateParams {
                    lost_color_ratio: 1.5,
                    ..Default::default()
                },
                "lost_color_ratio",
            ),
            (
                ColorTemplateParams {
                    lost_contrast_ratio: Some(f64::NAN),
                    ..Default::default()
                },
                "lost_contrast_ratio",
            ),
            (
                ColorTemplateParams {
                    refind_contrast_ratio: Some(1.5),
                    ..Default::default()
                },
                "refind_contrast_ratio",
            ),
        ];
        for (params, name) in cases {
            assert_eq!(params.validate().unwrap_err().parameter(), Some(name));
        }
    }
}
