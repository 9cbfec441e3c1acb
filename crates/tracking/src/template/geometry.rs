//! The fixed geometry of one tracker: how the first box maps to the normalised search
//! window, the filter's grid of cells, and the scale model's sample size.

use super::params::ColorTemplateParams;

/// Sizes derived once from the first box and the parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Geometry {
    /// Frame pixels per patch pixel at scale 1.
    pub(crate) zoom: f64,
    /// The normalised window (patch) in pixels: whole cells.
    pub(crate) patch: (usize, usize),
    /// The translation filter's grid in cells.
    pub(crate) grid: (usize, usize),
    /// The target's size in patch pixels at scale 1.
    pub(crate) target: (f64, f64),
    /// The scale samples' model size in pixels: whole cells.
    pub(crate) scale_model: (usize, usize),
}

impl Geometry {
    /// The geometry for a first box of `w x h` frame pixels.
    pub(crate) fn new(w: f64, h: f64, p: &ColorTemplateParams) -> Self {
        let cell = p.cell_size;
        let grow = p.padding * (w + h) / 2.0;
        let (win_w, win_h) = (w + grow, h + grow);
        let side = p.template_size as f64;
        let zoom = (win_w * win_h / (side * side)).sqrt();
        // At least 3 cells each way, so a response map has a centre and neighbours.
        let whole = |v: f64| ((v / cell as f64).round().max(3.0) as usize) * cell;
        let patch = (whole(win_w / zoom), whole(win_h / zoom));
        let grid = (patch.0 / cell, patch.1 / cell);
        let model_zoom = (w * h / p.scale_model_area).sqrt();
        let scale_model = (whole(w / model_zoom), whole(h / model_zoom));
        Self {
            zoom,
            patch,
            grid,
            target: (w / zoom, h / zoom),
            scale_model,
        }
    }

    /// The label's standard deviation in cells (Staple: the output sigma factor times
    /// the target's mean side in the normalised window, over the cell size).
    pub(crate) fn label_sigma(&self, p: &ColorTemplateParams) -> f64 {
        (self.target.0 * self.target.1).sqrt() * p.output_sigma_factor / p.cell_size as f64
    }
}

/// The displacement in cells that grid index `i` of `n` stands for: indices past the
/// middle wrap around to negative shifts (the circular correlation's convention).
pub(crate) fn wrapped(i: usize, n: usize) -> f64 {
    if i < n.div_ceil(2) {
        i as f64
    } else {
        i as f64 - n as f64
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    proptest! {
        /// Whatever the box, the patch holds whole cells, its area is close to the
        /// template's, and it keeps the window's aspect ratio within a cell.
        #[test]
        fn patch_area_is_bounded(w in 2.0f64..600.0, h in 2.0f64..600.0) {
            let p = ColorTemplateParams::default();
            let g = Geometry::new(w, h, &p);
            prop_assert_eq!(g.patch.0 % p.cell_size, 0);
            prop_assert_eq!(g.patch.1 % p.cell_size, 0);
            prop_assert!(g.grid.0 >= 3 && g.grid.1 >= 3);
            let grow = (w + h) / 2.0;
            let aspect = (w + grow) / (h + grow);
            let got = g.patch.0 as f64 / g.patch.1 as f64;
            prop_assert!((got / aspect).ln().abs() < 0.35, "{got} vs {aspect}");
        }
    }
}
