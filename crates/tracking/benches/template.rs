//! The colour + template tracker (issue 34) stage by stage: resampling the search
//! window, HOG, the translation filter (detect + learn), the scale filter, the colour
//! likelihood and response, the lost rule's PSR and APCE, and one whole update on a
//! 320 x 240 frame.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use tracking::template::stages;
use tracking::{BoundingBox, ColorTemplateParams, ColorTemplateTracker, RgbFrame};

const W: usize = 320;
const H: usize = 240;

/// A textured frame with a bright square whose position depends on `t`.
fn frame(t: usize) -> Vec<u8> {
    (0..W * H)
        .flat_map(|k| {
            let (x, y) = (k % W, k / W);
            let inside = (100 + t..140 + t).contains(&x) && (90..140).contains(&y);
            let v = ((x * 31 + y * 17) % 97) as u8;
            if inside {
                [200, v, 60]
            } else {
                [v, 120, v / 2]
            }
        })
        .collect()
}

fn stages_bench(c: &mut Criterion) {
    let data = frame(0);
    let view = RgbFrame::new(&data, W, H).unwrap();
    let mut group = c.benchmark_group("color_template_stage");
    group.bench_function("resample_96x96", |b| {
        b.iter(|| black_box(stages::resample(view, 96, 96)))
    });
    let grey: Vec<f32> = (0..96 * 96)
        .map(|k| ((k * 37) % 101) as f32 / 101.0)
        .collect();
    group.bench_function("hog_96x96", |b| {
        b.iter(|| black_box(stages::hog_features(&grey, 96, 96)))
    });
    let mut translation = stages::Translation::new(24, 24);
    group.bench_function("translation_filter_24x24", |b| {
        b.iter(|| black_box(translation.respond_and_train()))
    });
    let mut scale = stages::Scale::new(17, 320);
    group.bench_function("scale_filter_17x320", |b| {
        b.iter(|| black_box(scale.respond()))
    });
    let response: Vec<f32> = (0..24 * 24)
        .map(|k| ((k * 29) % 53) as f32 / 53.0)
        .collect();
    group.bench_function("psr_apce_24x24", |b| {
        b.iter(|| black_box(stages::sharpness(&response, 24, 24)))
    });
    let rgb: Vec<[u8; 3]> = data
        .chunks_exact(3)
        .take(96 * 96)
        .map(|p| [p[0], p[1], p[2]])
        .collect();
    group.bench_function("colour_96x96", |b| {
        b.iter(|| black_box(stages::colour(&rgb, 96, 96)))
    });
    group.finish();
}

fn update_bench(c: &mut Criterion) {
    let frames: Vec<Vec<u8>> = (0..8).map(frame).collect();
    let first = RgbFrame::new(&frames[0], W, H).unwrap();
    let start = BoundingBox::new(100.0, 90.0, 40.0, 50.0);
    let mut tracker =
        ColorTemplateTracker::new(first, start, ColorTemplateParams::default()).unwrap();
    let mut k = 0;
    c.bench_function("color_template_update_320x240", |b| {
        b.iter(|| {
            k = (k + 1) % frames.len();
            let view = RgbFrame::new(&frames[k], W, H).unwrap();
            black_box(tracker.update(view).unwrap())
        })
    });
}

criterion_group!(benches, stages_bench, update_bench);
criterion_main!(benches);
