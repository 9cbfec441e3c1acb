//! Criterion bench of one EKF-SLAM update: a planar robot observing one point
//! landmark by range and bearing, at growing map sizes. The update is O(n^2): one
//! pass over the covariance.

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use nalgebra::{DMatrix, DVector, Matrix2, Vector2};
use rand::{Rng, SeedableRng, rngs::StdRng};
use slam::Ekf;

fn filter(landmarks: usize) -> Ekf {
    let mut rng = StdRng::seed_from_u64(1);
    let d = 3 + 2 * landmarks;
    let x = DVector::from_fn(d, |_, _| rng.random_range(-20.0..20.0));
    // A dense SPD covariance: low-rank correlations plus a diagonal.
    let a = DMatrix::from_fn(d, 8, |_, _| rng.random_range(-1.0..1.0));
    let p = &a * a.transpose() * 0.05 + DMatrix::identity(d, d) * 0.5;
    Ekf::new(x, p, 3, 2).unwrap()
}

fn bench_update(c: &mut Criterion) {
    let mut group = c.benchmark_group("ekf_update/range_bearing");
    group.sample_size(20);
    let r = Matrix2::new(0.01, 0.0, 0.0, 0.001);
    for n in [10, 100, 500, 1000, 2000] {
        let mut ekf = filter(n);
        let j = n / 2;
        let z = Vector2::new(10.0, 0.3);
        group.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            b.iter(|| {
                // Repeated updates keep the covariance valid: each is a proper update.
                ekf.update_range_bearing(black_box(j), &z, &r).unwrap();
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench_update);
criterion_main!(benches);
