//! The visual memory's hot paths: rendering one 320 x 240 ceiling frame, and the
//! robot's work on one frame (eq. 1 correction, the trackers of up to four models,
//! eq. 2) while localising against a learnt mosaic.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use rperc_core::Pose2;
use rperc_core::image::GrayView;
use tracking::ceiling::{Ceiling, CeilingCamera, CeilingParams, RenderParams, render};
use tracking::memory::{LearnParams, MosaicBuilder, MosaicParams, World, learn};

fn bench_memory(c: &mut Criterion) {
    let ceiling = Ceiling::generate(&CeilingParams::default()).unwrap();
    let camera = CeilingCamera::default();
    let params = RenderParams::default();
    let world = World {
        ceiling: &ceiling,
        camera: &camera,
        render: &params,
    };
    let mut group = c.benchmark_group("memory");
    let pose = Pose2::new(3.0, 3.0, 0.3);
    let mut frame = Vec::new();
    group.bench_function("render_320x240", |b| {
        b.iter(|| render(&ceiling, &camera, black_box(&pose), &params, 0, &mut frame).unwrap())
    });
    // A learnt straight path, then localisation along it, frame by frame.
    let start = Pose2::new(3.0, 3.0, 0.0);
    let commands = vec![[0.3, 0.0]; 40];
    let learnt = learn(world, start, &commands, 0.1, &LearnParams::default(), 0).unwrap();
    let frames: Vec<Vec<u8>> = (0..40)
        .map(|k| {
            let mut f = Vec::new();
            let p = start.advance(0.3, 0.0, 0.1 * k as f64);
            render(&ceiling, &camera, &p, &params, 1000 + k, &mut f).unwrap();
            f
        })
        .collect();
    group.bench_function("localise_10_frames_320x240", |b| {
        b.iter_batched(
            || {
                MosaicBuilder::localiser(
                    camera,
                    MosaicParams::default(),
                    learnt.memory.models.clone(),
                    learnt.memory.key_images[0].pose,
                    0,
                )
                .unwrap()
            },
            |mut localiser| {
                for f in &frames[..10] {
                    let view = GrayView::new(f, camera.width, camera.height).unwrap();
                    black_box(localiser.process(view, None).unwrap());
                }
            },
            criterion::BatchSize::LargeInput,
        )
    });
    group.finish();
}

criterion_group!(benches, bench_memory);
criterion_main!(benches);
