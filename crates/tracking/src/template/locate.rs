//! One search window: the merged response map (template and colour) and its peak.

use super::contrast::{box_at, contrast};
use super::geometry::wrapped;
use super::hog;
use super::likelihood::{colour_response, integral};
use super::lost::Located;
use super::patch;
use super::sharpness::{average_peak_correlation_energy, peak_to_sidelobe};
use super::tracker::ColorTemplateTracker;
use crate::frame::RgbFrame;

/// The sub-cell offset of a peak from its two neighbours' values (the vertex of the
/// parabola through the three), within half a cell.
fn parabola_offset(left: f32, centre: f32, right: f32) -> f64 {
    let denominator = f64::from(left - 2.0 * centre + right);
    if denominator.abs() < 1e-12 {
        return 0.0;
    }
    (0.5 * f64::from(left - right) / denominator).clamp(-0.5, 0.5)
}

/// Half-side in cells of the square around the peak that PSR leaves out of the
/// sidelobe: MOSSE's 11 x 11 pixels on a 64 x 64 map is about a sixth of the map; on
/// the ~24-cell grid that is 2 cells each way (the label's main lobe is under 1.5 cells).
const SIDELOBE_EXCLUSION: usize = 2;

impl ColorTemplateTracker {
    /// Samples the window centred at `(cx, cy)`, computes the template and colour
    /// responses, merges them (Staple eq. 4: `(1 - alpha) f_tmpl + alpha f_hist`) and
    /// returns the peak, the signals of the lost rule and the target centre it implies,
    /// in frame pixels.
    pub(super) fn locate(&mut self, frame: &RgbFrame<'_>, cx: f64, cy: f64) -> Located {
        let window = self.window_at(cx, cy);
        let (pw, ph) = self.geometry.patch;
        let (gw, gh) = self.geometry.grid;
        let cell = self.params.cell_size;
        let s = &mut self.scratch;
        patch::sample(frame, window, pw, ph, &mut s.patch);
        hog::features(&s.patch.grey, pw, ph, cell, &mut s.map);
        self.filter.respond(&s.map, &mut s.template);
        self.colour.back_project(&s.patch.rgb, &mut s.probability);
        let table = integral(&s.probability, pw, ph);
        let target = self.geometry.target;
        colour_response(&table, pw, ph, target, (gw, gh, cell), &mut s.colour);
        // The template's own sharpness, before the colour (smooth by construction: a
        // box mean) blurs it.
        let psr = peak_to_sidelobe(&s.template, gw, gh, SIDELOBE_EXCLUSION);
        let apce = average_peak_correlation_energy(&s.template);
        let alpha = self.params.merge_factor as f32;
        for (t, c) in s.template.iter_mut().zip(&s.colour) {
            *t = (1.0 - alpha) * *t + alpha * c;
        }
        let merged = &s.template;
        let (k, &peak) = merged
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .unwrap_or((0, &0.0));
        let (i, j) = (k % gw, k / gw);
        self.colour_seed
            .back_project(&s.patch.rgb, &mut s.probability);
        let seed_table = integral(&s.probability, pw, ph);
        let at_peak = box_at((pw, ph), target, (i, j), (gw, gh, cell));
        let contrast = contrast(&seed_table, pw, ph, at_peak);
        let at = |ii: usize, jj: usize| merged[jj * gw + ii];
        let dx =
            wrapped(i, gw) + parabola_offset(at((i + gw - 1) % gw, j), peak, at((i + 1) % gw, j));
        let dy =
            wrapped(j, gh) + parabola_offset(at(i, (j + gh - 1) % gh), peak, at(i, (j + 1) % gh));
        let to_frame = cell as f64 * self.geometry.zoom * self.scale;
        Located {
            peak: f64::from(peak),
            psr,
            apce,
            color: f64::from(s.colour[k]),
            contrast,
            cx: cx + dx * to_frame,
            cy: cy + dy * to_frame,
        }
    }
}
