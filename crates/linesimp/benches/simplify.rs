//! Criterion benches of the hot paths: path hull vs plain DP on random walks and
//! zig-zags (the DP worst case), and `simplify_many` against a serial loop.

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use linesimp::{Method, Metric, Simplifier, simplify_many};
use nalgebra::Point2;
use rand::{Rng, SeedableRng, rngs::StdRng};

fn random_walk(n: usize, seed: u64) -> Vec<Point2<f64>> {
    let mut rng = StdRng::seed_from_u64(seed);
    let mut p = Point2::new(0.0, 0.0);
    (0..n)
        .map(|_| {
            p += nalgebra::Vector2::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
            p
        })
        .collect()
}

/// Amplitude grows along the chain, so each chord's farthest vertex is next to its
/// end: plain DP peels one vertex per level and takes quadratic time.
fn zigzag(n: usize) -> Vec<Point2<f64>> {
    (0..n)
        .map(|i| Point2::new(i as f64, if i % 2 == 0 { i as f64 } else { -(i as f64) }))
        .collect()
}

fn bench_simplify(c: &mut Criterion) {
    let mut g = c.benchmark_group("simplify");
    for &n in &[10_000usize, 100_000] {
        let walk = random_walk(n, 7);
        for method in [Method::Hull, Method::Dp] {
            let mut s = Simplifier::new(method, Metric::Line);
            g.bench_with_input(
                BenchmarkId::new(format!("walk/{method:?}"), n),
                &walk,
                |b, pts| b.iter(|| s.indices(black_box(pts), 1.0).unwrap()),
            );
        }
    }
    for &n in &[16_000usize, 64_000] {
        let zz = zigzag(n);
        let mut s = Simplifier::new(Method::Hull, Metric::Line);
        g.bench_with_input(BenchmarkId::new("zigzag/Hull", n), &zz, |b, pts| {
            b.iter(|| s.indices(black_box(pts), 1e-9).unwrap())
        });
    }
    let zz = zigzag(4_000);
    let mut s = Simplifier::new(Method::Dp, Metric::Line);
    g.bench_with_input(BenchmarkId::new("zigzag/Dp", 4_000), &zz, |b, pts| {
        b.iter(|| s.indices(black_box(pts), 1e-9).unwrap())
    });
    g.finish();
}

fn bench_many(c: &mut Criterion) {
    let lines: Vec<Vec<Point2<f64>>> = (0..2_000).map(|k| random_walk(500, k)).collect();
    let mut g = c.benchmark_group("simplify_many");
    g.bench_function("parallel/2000x500", |b| {
        b.iter(|| simplify_many(black_box(&lines), 1.0, Method::Hull, Metric::Line))
    });
    g.bench_function("serial/2000x500", |b| {
        let mut s = Simplifier::new(Method::Hull, Metric::Line);
        b.iter(|| {
            lines
                .iter()
                .map(|l| s.indices(l, 1.0).unwrap().len())
                .sum::<usize>()
        })
    });
    g.finish();
}

criterion_group!(benches, bench_simplify, bench_many);
criterion_main!(benches);
