//! The drift signal: how much more the seed's colour model (the foreground and
//! background histograms of the first frame, never updated) sees the target inside the
//! box than in the rest of the search window. A tracker that slides onto the
//! background keeps learning on the way, so its own models, and every signal read
//! from them, follow it there; the seed's model does not, and on the background the
//! box is no more target-coloured than its surroundings (contrast near or under 0).

use super::geometry::wrapped;
use super::likelihood::Rect;

/// The box of `w x h` patch pixels centred at the patch centre plus the displacement of
/// grid index `(i, j)` of a `grid_w x grid_h` grid of `cell`-pixel cells (the colour
/// response's convention), rounded and clipped to the `width x height` patch.
pub(super) fn box_at(
    (width, height): (usize, usize),
    (w, h): (f64, f64),
    (i, j): (usize, usize),
    (grid_w, grid_h, cell): (usize, usize, usize),
) -> Rect {
    let clip = |v: f64, n: usize| v.round().clamp(0.0, n as f64) as usize;
    let cx = width as f64 / 2.0 + wrapped(i, grid_w) * cell as f64;
    let cy = height as f64 / 2.0 + wrapped(j, grid_h) * cell as f64;
    Rect {
        x0: clip(cx - w / 2.0, width),
        y0: clip(cy - h / 2.0, height),
        x1: clip(cx + w / 2.0, width),
        y1: clip(cy + h / 2.0, height),
    }
}

/// The mean of the values inside `inner` minus their mean over the rest of the
/// `width x height` patch, from its summed-area table (`integral`), in [-1, 1] for
/// probabilities; 0 when either part is empty (nothing to compare).
pub(super) fn contrast(table: &[f64], width: usize, height: usize, inner: Rect) -> f64 {
    let stride = width + 1;
    let sum = |r: Rect| {
        table[r.y1 * stride + r.x1] - table[r.y0 * stride + r.x1] - table[r.y1 * stride + r.x0]
            + table[r.y0 * stride + r.x0]
    };
    let whole = Rect {
        x0: 0,
        y0: 0,
        x1: width,
        y1: height,
    };
    let inside_area =
        (inner.x1.saturating_sub(inner.x0) * inner.y1.saturating_sub(inner.y0)) as f64;
    let rest_area = (width * height) as f64 - inside_area;
    if inside_area <= 0.0 || rest_area <= 0.0 {
        return 0.0;
    }
    let inside = sum(inner);
    inside / inside_area - (sum(whole) - inside) / rest_area
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::super::likelihood::integral;
    use super::*;

    proptest! {
        /// The summed-area contrast equals the two means summed pixel by pixel.
        #[test]
        fn contrast_matches_brute_force_means(
            width in 3usize..30, height in 3usize..30, bw in 1.0f64..20.0, bh in 1.0f64..20.0,
            i in 0usize..8, j in 0usize..8, seed in 0u64..200,
        ) {
            let mut rng = rperc_core::rng::seeded(seed);
            let p: Vec<f32> = (0..width * height).map(|_| rand::Rng::random_range(&mut rng, 0.0..1.0)).collect();
            let grid = (8usize, 8usize, 1usize);
            let r = box_at((width, height), (bw, bh), (i, j), grid);
            let got = contrast(&integral(&p, width, height), width, height, r);
            let (mut s_in, mut n_in, mut s_out, mut n_out) = (0.0f64, 0usize, 0.0f64, 0usize);
            for y in 0..height {
                for x in 0..width {
                    let v = f64::from(p[y * width + x]);
                    if (r.x0..r.x1).contains(&x) && (r.y0..r.y1).contains(&y) {
                        s_in += v;
                        n_in += 1;
                    } else {
                        s_out += v;
                        n_out += 1;
                    }
                }
            }
            let expected = if n_in == 0 || n_out == 0 { 0.0 } else { s_in / n_in as f64 - s_out / n_out as f64 };
            prop_assert!((got - expected).abs() < 1e-5, "{got} vs {expected}");
        }
    }

    /// A box exactly on the only target-coloured pixels has contrast 1, a box on the
    /// background beside them -(its share of them) / (the rest's area), by hand.
    #[test]
    fn target_box_has_full_contrast() {
        let (w, h) = (10usize, 8usize);
        // P = 1 on the 4 x 4 block x in 3..7, y in 2..6, 0 elsewhere.
        let p: Vec<f32> = (0..w * h)
            .map(|k| {
                f32::from(u8::from(
                    (3..7).contains(&(k % w)) && (2..6).contains(&(k / w)),
                ))
            })
            .collect();
        let table = integral(&p, w, h);
        let on = box_at((w, h), (4.0, 4.0), (0, 0), (10, 8, 1));
        assert_eq!((on.x0, on.y0, on.x1, on.y1), (3, 2, 7, 6));
        assert!((contrast(&table, w, h, on) - 1.0).abs() < 1e-12);
        // Shifted 4 right (x in 7..11 clipped to 7..10): no target inside, all 16 outside.
        let off = box_at((w, h), (4.0, 4.0), (4, 0), (10, 8, 1));
        assert_eq!((off.x0, off.x1), (7, 10));
        let expected = 0.0 - 16.0 / (80.0 - 12.0);
        assert!((contrast(&table, w, h, off) - expected).abs() < 1e-12);
    }
}
