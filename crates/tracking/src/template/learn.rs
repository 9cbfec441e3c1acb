//! Model updates and the scale step: what the tracker learns from a frame once it has
//! placed the target, and how the scale filter re-sizes the box.

use super::hog;
use super::likelihood::Rect;
use super::patch::{self, Window};
use super::tracker::ColorTemplateTracker;
use crate::frame::RgbFrame;

impl ColorTemplateTracker {
    /// Learns the template, the colour histograms and the scale filter at the current
    /// box, each at its own learning rate times `confidence` in [0, 1]; `None` is the
    /// first frame, which replaces every model. `scales_sampled`: the scale samples
    /// already hold this frame's at the current centre and scale (the scale step
    /// sampled them and kept the scale), so they are not sampled again.
    pub(super) fn learn(
        &mut self,
        frame: &RgbFrame<'_>,
        confidence: Option<f32>,
        scales_sampled: bool,
    ) {
        let first = confidence.is_none();
        let weight = confidence.unwrap_or(1.0);
        if !first && weight <= 0.0 {
            return; // nothing to learn: skip the samples
        }
        let rate = |r: f64| if first { 1.0 } else { r as f32 * weight };
        let (cx, cy) = self.centre;
        let window = self.window_at(cx, cy);
        let (pw, ph) = self.geometry.patch;
        let s = &mut self.scratch;
        patch::sample(frame, window, pw, ph, &mut s.patch);
        hog::features(&s.patch.grey, pw, ph, self.params.cell_size, &mut s.map);
        self.filter.train(&s.map, rate(self.params.learning_rate));
        let (tw, th) = self.geometry.target;
        let shrink = self.params.inner_padding * (tw + th) / 2.0;
        let target = Rect::centred(pw, ph, tw, th);
        let object = Rect::centred(pw, ph, (tw - shrink).max(1.0), (th - shrink).max(1.0));
        let colour_rate = rate(self.params.color_learning_rate);
        self.colour
            .learn(&s.patch.rgb, pw, target, object, colour_rate);
        if !scales_sampled {
            self.sample_scales(frame);
        }
        let scale_rate = rate(self.params.scale_learning_rate);
        self.scale_filter
            .train(&self.scratch.scale_samples, scale_rate);
    }

    /// The HOG vector of the target at each of the `n_scales` scales around the
    /// current one, resampled to the scale model's size (DSST section 2.3).
    fn sample_scales(&mut self, frame: &RgbFrame<'_>) {
        let n = self.params.n_scales;
        let (mw, mh) = self.geometry.scale_model;
        let cell = self.params.cell_size;
        let (cx, cy) = self.centre;
        let mut grey = std::mem::take(&mut self.scratch.scale_grey);
        self.scratch.scale_samples.resize_with(n, Vec::new);
        for k in 0..n {
            let factor = self.scale * self.params.scale_step.powf(k as f64 - (n / 2) as f64);
            let window = Window {
                cx,
                cy,
                width: self.base.0 * factor,
                height: self.base.1 * factor,
            };
            patch::sample_grey(frame, window, mw, mh, &mut grey);
            hog::features(&grey, mw, mh, cell, &mut self.scratch.map);
            let out = &mut self.scratch.scale_samples[k];
            out.clear();
            for plane in &self.scratch.map.planes {
                out.extend_from_slice(plane);
            }
        }
        self.scratch.scale_grey = grey;
    }

    /// Re-sizes the box by the scale filter's peak, within `min_scale..=max_scale`;
    /// whether the scale stayed as it was (the scale samples are then those of the
    /// new box, and [`Self::learn`] can train on them).
    pub(super) fn estimate_scale(&mut self, frame: &RgbFrame<'_>) -> bool {
        self.sample_scales(frame);
        let response = self.scale_filter.respond(&self.scratch.scale_samples);
        let Some((k, _)) = response
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
        else {
            return true;
        };
        let steps = k as f64 - (self.params.n_scales / 2) as f64;
        let scale = self.scale * self.params.scale_step.powf(steps);
        let before = self.scale;
        self.scale = scale.clamp(self.params.min_scale, self.params.max_scale);
        self.scale.to_bits() == before.to_bits()
    }
}
