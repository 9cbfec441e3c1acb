//! How sharp a correlation response's peak is: the peak-to-sidelobe ratio (PSR, Bolme
//! et al. 2010, MOSSE section 3.4) and the average peak-to-correlation energy (APCE,
//! Wang et al. 2017, LMCF eq. 9). A target in view gives one sharp peak; an occluded or
//! lost one a flat or many-peaked map, whatever the peak's height.

/// The PSR of a `width x height` response map: `(g_max - mu) / sigma` over the
/// sidelobe, every cell outside the `(2 exclude + 1)`-square around the peak (wrapped,
/// as the circular correlation is). A flat map gives 0; a peak over a constant sidelobe
/// (sigma 0) gives infinity; an empty sidelobe (the exclusion covers the map) gives 0.
pub(crate) fn peak_to_sidelobe(
    response: &[f32],
    width: usize,
    height: usize,
    exclude: usize,
) -> f64 {
    let Some((k, peak)) = arg_max(response) else {
        return 0.0;
    };
    let (px, py) = (k % width, k / width);
    // Circular distance along one axis, so a peak at an edge excludes the far side too.
    let near = |a: usize, b: usize, n: usize| {
        let d = a.abs_diff(b);
        d.min(n - d) <= exclude
    };
    let (mut n, mut sum, mut sum_sq) = (0usize, 0.0f64, 0.0f64);
    for (i, &v) in response.iter().enumerate() {
        if near(i % width, px, width) && near(i / width, py, height) {
            continue;
        }
        let v = f64::from(v);
        n += 1;
        sum += v;
        sum_sq += v * v;
    }
    if n == 0 {
        return 0.0;
    }
    let mean = sum / n as f64;
    // Two-pass accuracy is not needed: the maps are a few hundred cells of order 1.
    let variance = (sum_sq / n as f64 - mean * mean).max(0.0);
    let lift = peak - mean;
    if lift <= 0.0 {
        0.0
    } else if variance == 0.0 {
        f64::INFINITY
    } else {
        lift / variance.sqrt()
    }
}

/// The APCE of a response map: `|F_max - F_min|^2 / mean((F - F_min)^2)`. One cell
/// standing out of an otherwise constant map of `n` cells gives `n` (its upper
/// bound); a flat map gives 0.
pub(crate) fn average_peak_correlation_energy(response: &[f32]) -> f64 {
    let Some((_, peak)) = arg_max(response) else {
        return 0.0;
    };
    let floor = response
        .iter()
        .map(|&v| f64::from(v))
        .fold(f64::INFINITY, f64::min);
    let energy: f64 = response
        .iter()
        .map(|&v| (f64::from(v) - floor).powi(2))
        .sum::<f64>()
        / response.len() as f64;
    if energy <= 0.0 {
        0.0
    } else {
        (peak - floor).powi(2) / energy
    }
}

fn arg_max(response: &[f32]) -> Option<(usize, f64)> {
    response
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(b.1))
        .map(|(k, &v)| (k, f64::from(v)))
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    /// A delta on a constant map: APCE is the number of cells (closed form) and PSR
    /// infinite (sigma 0); a flat map scores 0 on both.
    #[test]
    fn delta_and_flat_maps() {
        let (w, h) = (12usize, 9usize);
        let mut map = vec![0.25f32; w * h];
        map[4 * w + 7] = 3.0;
        assert!((average_peak_correlation_energy(&map) - (w * h) as f64).abs() < 1e-9);
        assert_eq!(peak_to_sidelobe(&map, w, h, 2), f64::INFINITY);
        let flat = vec![0.7f32; w * h];
        assert_eq!(average_peak_correlation_energy(&flat), 0.0);
        assert_eq!(peak_to_sidelobe(&flat, w, h, 2), 0.0);
    }

    /// A peak `p` at the origin cell over a checkerboard sidelobe of `a` and `b` (as
    /// many of each: an 8 x 8 map, a 3 x 3 exclusion that wraps round the corner):
    /// mean `(a + b) / 2`, sigma `|a - b| / 2` over the 55 sidelobe cells' closed form.
    #[test]
    fn checkerboard_sidelobe_has_the_closed_form() {
        let (w, h) = (8usize, 8usize);
        let (a, b, p) = (0.5f32, -0.5f32, 4.0f32);
        let mut map: Vec<f32> = (0..w * h)
            .map(|k| if (k % w + k / w) % 2 == 0 { a } else { b })
            .collect();
        map[0] = p;
        // The exclusion around (0, 0) wraps: columns {7, 0, 1} x rows {7, 0, 1}, whose
        // checkerboard has 5 `a` cells and 4 `b` cells; the sidelobe keeps the rest.
        let (na, nb) = (32.0 - 5.0, 32.0 - 4.0);
        let n = na + nb;
        let mean = (na * f64::from(a) + nb * f64::from(b)) / n;
        let var = (na * f64::from(a).powi(2) + nb * f64::from(b).powi(2)) / n - mean * mean;
        let expected = (f64::from(p) - mean) / var.sqrt();
        assert!((peak_to_sidelobe(&map, w, h, 1) - expected).abs() < 1e-9);
        // APCE: F_min = b; (p - b)^2 / mean((F - b)^2), 31 `a` cells and the peak.
        let energy = (31.0 * f64::from(a - b).powi(2) + f64::from(p - b).powi(2)) / 64.0;
        let apce = f64::from(p - b).powi(2) / energy;
        assert!((average_peak_correlation_energy(&map) - apce).abs() < 1e-9);
    }

    proptest! {
        /// Both measures ignore the response's gain and offset (`s F + c`, `s > 0`): a
        /// filter's confidence must not depend on the frame's contrast.
        #[test]
        fn invariant_to_gain_and_offset(
            seed in 0u64..500, s in 0.1f32..10.0, c in -2.0f32..2.0,
        ) {
            let mut rng = rperc_core::rng::seeded(seed);
            let map: Vec<f32> = (0..100).map(|_| rand::Rng::random_range(&mut rng, -1.0..1.0)).collect();
            let scaled: Vec<f32> = map.iter().map(|v| s * v + c).collect();
            let (p0, p1) = (peak_to_sidelobe(&map, 10, 10, 2), peak_to_sidelobe(&scaled, 10, 10, 2));
            prop_assert!((p0 - p1).abs() < 1e-3 * p0.max(1.0), "{p0} vs {p1}");
            let (a0, a1) = (average_peak_correlation_energy(&map), average_peak_correlation_energy(&scaled));
            prop_assert!((a0 - a1).abs() < 1e-3 * a0.max(1.0), "{a0} vs {a1}");
        }
    }
}
