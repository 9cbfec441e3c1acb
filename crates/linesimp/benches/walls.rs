//! Criterion bench of wall extraction on a simulated 180-beam scan of a room with a
//! cabinet (the size of the Intel and ACES logs' scans).

use std::f64::consts::PI;
use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use linesimp::{LineExtractor, ScanParams};

/// Range along `phi` from (0, 0) to the walls x = 5, x = -5, y = 3, y = -3 and a
/// cabinet face at x = 2 for 0.5 < y < 1.5.
fn range(phi: f64) -> f64 {
    let (s, c) = phi.sin_cos();
    let mut best = f64::INFINITY;
    for (wall, along) in [(5.0, c), (-5.0, c)] {
        if along * wall > 0.0 {
            best = best.min(wall / along);
        }
    }
    for (wall, along) in [(3.0, s), (-3.0, s)] {
        if along * wall > 0.0 {
            best = best.min(wall / along);
        }
    }
    if c > 0.0 {
        let t = 2.0 / c;
        let y = t * s;
        if (0.5..1.5).contains(&y) {
            best = best.min(t);
        }
    }
    best
}

fn bench_walls(c: &mut Criterion) {
    let angles: Vec<f64> = (0..180)
        .map(|k| -PI / 2.0 + PI * k as f64 / 180.0)
        .collect();
    let ranges: Vec<f64> = angles
        .iter()
        .enumerate()
        .map(|(k, &a)| range(a) + 0.01 * (((k * 7919) % 101) as f64 / 50.0 - 1.0))
        .collect();
    let mut extractor = LineExtractor::new(ScanParams::default());
    c.bench_function("extract_lines/180 beams", |b| {
        b.iter(|| {
            extractor
                .extract(black_box(&ranges), black_box(&angles))
                .unwrap()
        })
    });
}

criterion_group!(benches, bench_walls);
criterion_main!(benches);
