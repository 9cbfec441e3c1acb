//! Property tests of wall extraction: on any scan (including NaN, zero, infinite and
//! out-of-range readings) the result is well formed.

use std::f64::consts::PI;

use linesimp::{LineExtractor, ScanParams};
use proptest::prelude::*;

fn reading() -> impl Strategy<Value = f64> {
    prop_oneof![
        8 => 0.1..20.0f64,
        1 => Just(0.0),
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => Just(30.0),
    ]
}

/// Piecewise-smooth scans: runs of readings along random lines, plus noise, so that
/// walls are actually found, mixed with invalid readings.
fn scan() -> impl Strategy<Value = (Vec<f64>, Vec<f64>)> {
    (
        prop::collection::vec((0.5..8.0f64, -PI..PI, 5usize..60), 1..6),
        prop::collection::vec(reading(), 0..40),
        any::<u64>(),
    )
        .prop_map(|(walls, junk, seed)| {
            let mut ranges = Vec::new();
            for (rho, alpha, count) in walls {
                for _ in 0..count {
                    let phi = -PI / 2.0 + PI * ranges.len() as f64 / 360.0;
                    let r = rho / (phi - alpha).cos();
                    ranges.push(if r > 0.0 { r } else { f64::NAN });
                }
            }
            // Sprinkle invalid readings at pseudo-random places.
            let mut state = seed | 1;
            for v in junk {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                if !ranges.is_empty() {
                    let k = (state >> 33) as usize % ranges.len();
                    ranges[k] = v;
                }
            }
            let angles = (0..ranges.len())
                .map(|k| -PI / 2.0 + PI * k as f64 / 360.0)
                .collect();
            (ranges, angles)
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn walls_are_well_formed((ranges, angles) in scan()) {
        let params = ScanParams { max_range: 30.0, ..ScanParams::default() };
        let mut extractor = LineExtractor::new(params);
        let walls = extractor.extract(&ranges, &angles).unwrap();
        let mut last_index = None;
        for w in &walls {
            prop_assert!(w.rho >= 0.0 && w.rho.is_finite());
            prop_assert!(w.alpha > -PI && w.alpha <= PI);
            let c = w.cov;
            prop_assert!((c[(0, 1)] - c[(1, 0)]).abs() <= 1e-12 * c.amax().max(1e-300));
            prop_assert!(c[(0, 0)] >= 0.0 && c[(1, 1)] >= 0.0);
            prop_assert!(c[(0, 0)] * c[(1, 1)] - c[(0, 1)] * c[(1, 0)] >= -1e-12 * c.amax().powi(2));
            prop_assert!(w.indices.len() >= params.min_points);
            prop_assert!(w.length() >= params.min_length);
            // Indices increase, stay in range, name valid readings, and walls do not share them.
            for &k in &w.indices {
                prop_assert!(k < ranges.len());
                prop_assert!(ranges[k].is_finite() && ranges[k] > 0.0 && ranges[k] < params.max_range);
                prop_assert!(last_index.is_none_or(|l| k > l));
                last_index = Some(k);
            }
            // End points lie on the line.
            let n = nalgebra::Vector2::new(w.alpha.cos(), w.alpha.sin());
            for p in [w.start, w.end] {
                prop_assert!((n.dot(&p.coords) - w.rho).abs() <= 1e-9 * (1.0 + w.rho));
            }
        }
    }
}
