//! The target's colour model: normalised 3-D histograms sampled from the initial box,
//! optionally bimodal (upper part and lower part, e.g. hair and skin), adapted over time
//! with eq. (29) when the match is good enough.

use super::ellipse::Ellipse;
use super::region::count_parts;
use super::space::{BinImage, ColorSpace, check_bins};
use rperc_core::{ensure_in_range, ensure_non_negative};

use crate::error::{Result, TrackingError};

rperc_core::named_enum! {
    /// How the target's colours are modelled.
    #[derive(Default)]
    pub enum ModelKind: "model" {
        /// One histogram of the whole ellipse.
        Single = "single",
        /// Two histograms, of the top `upper_fraction` of the ellipse's rows and of the
        /// rest (hair and skin for a head: seed 000 section 3.2 "bimodal histogram"). A
        /// candidate is compared with their upper envelope `max(M_upper(i), M_lower(i))`,
        /// so it matches when each of its colours is explained by either mode: a head
        /// still matches when it turns and shows only hair.
        #[default]
        Bimodal = "bimodal",
    }
}

/// The appearance part of a tracker's parameters: colour space, bins, model and its
/// adaptation, and the gradient term. Defaults are the values tuned on OTB Girl + Couple.
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct AppearanceParams {
    /// Colour space of the histograms. Default [`ColorSpace::Hsv`] (best on OTB Girl +
    /// Couple; the seed's [`ColorSpace::Opponent`] scores lower there).
    pub color_space: ColorSpace,
    /// Bins per axis, 1..=64 each. Default `[8, 8, 4]` (finer chroma than intensity).
    pub bins: [usize; 3],
    /// Single or bimodal model. Default bimodal.
    pub model: ModelKind,
    /// Fraction of the ellipse's rows in the upper part of a bimodal model, in (0, 1).
    /// Default 0.4.
    pub upper_fraction: f64,
    /// `a` of eq. (29), in [0, 1]: weight of the new candidate when adapting the model.
    /// Default 0.03. 0 disables adaptation.
    pub adaptation_rate: f64,
    /// Eq. (29) is applied only when the intersection eq. (28) exceeds this, in [0, 1].
    /// Default 0.7.
    pub adaptation_threshold: f64,
    /// Weight of Birchfield's perimeter-gradient term relative to the colour term, >= 0.
    /// Default 0.7. 0 skips the gradient computation entirely.
    pub gradient_weight: f64,
    /// Below this intersection the target is reported lost, in [0, 1]. Default 0.3.
    pub lost_threshold: f64,
}

impl Default for AppearanceParams {
    fn default() -> Self {
        Self {
            color_space: ColorSpace::Hsv,
            bins: [8, 8, 4],
            model: ModelKind::default(),
            upper_fraction: 0.4,
            adaptation_rate: 0.03,
            adaptation_threshold: 0.7,
            gradient_weight: 0.7,
            lost_threshold: 0.3,
        }
    }
}

impl AppearanceParams {
    pub(crate) fn validate(&self) -> Result<usize> {
        let n_bins = check_bins(self.bins)?;
        ensure_in_range("adaptation_rate", self.adaptation_rate, 0.0, 1.0)?;
        ensure_in_range("adaptation_threshold", self.adaptation_threshold, 0.0, 1.0)?;
        ensure_in_range("lost_threshold", self.lost_threshold, 0.0, 1.0)?;
        ensure_non_negative("gradient_weight", self.gradient_weight)?;
        let upper_fraction = self.upper_fraction;
        if !(upper_fraction.is_finite() && upper_fraction > 0.0 && upper_fraction < 1.0) {
            return Err(TrackingError::InvalidParameter {
                name: "upper_fraction",
                reason: format!("must be in (0, 1), got {upper_fraction}"),
            });
        }
        Ok(n_bins)
    }

    pub(crate) fn upper_fraction(&self) -> f64 {
        match self.model {
            ModelKind::Single => 0.5,
            ModelKind::Bimodal => self.upper_fraction,
        }
    }
}

/// Normalised histograms of the target (each sums to one) and the envelope that
/// candidates are compared with.
#[derive(Debug, Clone)]
pub(crate) struct ColourModel {
    kind: ModelKind,
    upper: Vec<f64>,
    lower: Vec<f64>,
    /// The model distribution candidates are matched against (sums to >= 1 when bimodal).
    pub(crate) reference: Vec<f32>,
    scratch_upper: Vec<f64>,
    scratch_lower: Vec<f64>,
}

impl ColourModel {
    /// Samples the model from the ellipse `e` at `(cx, cy)`.
    pub(crate) fn sample(
        kind: ModelKind,
        n_bins: usize,
        image: &BinImage,
        e: &Ellipse,
        cx: i32,
        cy: i32,
    ) -> Self {
        let mut m = Self {
            kind,
            upper: vec![0.0; n_bins],
            lower: vec![0.0; n_bins],
            reference: vec![0.0; n_bins],
            scratch_upper: vec![0.0; n_bins],
            scratch_lower: vec![0.0; n_bins],
        };
        m.candidate(image, e, cx, cy);
        m.upper.copy_from_slice(&m.scratch_upper);
        m.lower.copy_from_slice(&m.scratch_lower);
        m.refresh_reference();
        m
    }

    /// Normalised histograms of the candidate's upper and lower parts into the scratch
    /// buffers (for a single model, both hold the whole ellipse).
    fn candidate(&mut self, image: &BinImage, e: &Ellipse, cx: i32, cy: i32) {
        self.scratch_upper.fill(0.0);
        self.scratch_lower.fill(0.0);
        count_parts(
            image,
            e,
            cx,
            cy,
            &mut self.scratch_upper,
            &mut self.scratch_lower,
        );
        if self.kind == ModelKind::Single {
            for (u, l) in self
                .scratch_upper
                .iter_mut()
                .zip(self.scratch_lower.iter_mut())
            {
                *u += *l;
                *l = *u;
            }
        }
        for h in [&mut self.scratch_upper, &mut self.scratch_lower] {
            let total: f64 = h.iter().sum();
            if total > 0.0 {
                h.iter_mut().for_each(|v| *v /= total);
            }
        }
    }

    /// Eq. (29): `M_k = (1 - a) M_{k-1} + a C_k`, per part. A part of the candidate with
    /// no pixel in the frame leaves that part of the model unchanged.
    pub(crate) fn adapt(&mut self, rate: f64, image: &BinImage, e: &Ellipse, cx: i32, cy: i32) {
        self.candidate(image, e, cx, cy);
        for (model, cand) in [
            (&mut self.upper, &self.scratch_upper),
            (&mut self.lower, &self.scratch_lower),
        ] {
            if cand.iter().sum::<f64>() > 0.0 {
                for (m, c) in model.iter_mut().zip(cand) {
                    *m = (1.0 - rate) * *m + rate * c;
                }
            }
        }
        self.refresh_reference();
    }

    fn refresh_reference(&mut self) {
        for ((r, u), l) in self.reference.iter_mut().zip(&self.upper).zip(&self.lower) {
            *r = match self.kind {
                ModelKind::Single => *u as f32,
                ModelKind::Bimodal => u.max(*l) as f32,
            };
        }
    }

    /// The reference scaled to a region of `n_pixels` pixels, into `out`.
    pub(crate) fn scaled(&self, n_pixels: usize, out: &mut Vec<f32>) {
        out.clear();
        out.extend(self.reference.iter().map(|r| r * n_pixels as f32));
    }
}
