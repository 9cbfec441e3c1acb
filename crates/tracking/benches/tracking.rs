//! Hot paths of the crate: one particle-filter step (weighting + resampling).

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{SMatrix, SVector};
use tracking::{FilterParams, LinearGaussian, ParticleFilter, Resampler};

fn particle_filter_step(c: &mut Criterion) {
    let mut group = c.benchmark_group("particle_filter_step");
    for (name, resampler) in [
        ("systematic", Resampler::Systematic),
        ("multinomial", Resampler::Multinomial),
    ] {
        for parallel in [false, true] {
            let dynamics = LinearGaussian::random_walk(SVector::<f64, 3>::new(1.0, 1.0, 0.02));
            let params = FilterParams {
                resampler,
                parallel,
                ..FilterParams::default()
            };
            let mut pf = ParticleFilter::new(
                1000,
                SVector::zeros(),
                SMatrix::identity(),
                dynamics,
                params,
                1,
            )
            .unwrap();
            let target = SVector::<f64, 3>::new(0.5, -0.5, 1.0);
            let likelihood = |s: &SVector<f64, 3>| -0.5 * (s - target).norm_squared();
            let label = format!(
                "{name}_1000_{}",
                if parallel { "parallel" } else { "serial" }
            );
            group.bench_function(label, |b| b.iter(|| black_box(pf.step(&likelihood))));
        }
    }
    group.finish();
}

criterion_group!(benches, particle_filter_step);
criterion_main!(benches);
