//! Hot paths of the crate: one particle-filter step (weighting + resampling), and one
//! update of each colour tracker on a 320 x 240 frame, and the pattern likelihood of one
//! state (and its Gauss-Newton system) with its per-frame scale space, and one
//! pattern-tracker update (200 particles, 640 x 480, the speed goal of issue 12).

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{SMatrix, SVector};
use tracking::{
    BoundingBox, ColorHistogramTracker, ColorShapeParams, ColorShapeTracker, ColorTrackerParams,
    FilterParams, LinearGaussian, ParticleColorTracker, ParticleFilter, ParticleTrackerParams,
    Resampler, RgbFrame,
};

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

const W: usize = 320;
const H: usize = 240;

/// A pseudo-random textured 320 x 240 frame with a 30 x 60 two-colour target at `cx`.
fn frame(cx: f64) -> Vec<u8> {
    let mut px = vec![0u8; W * H * 3];
    let mut state = 12345u32;
    for v in px.iter_mut() {
        state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        *v = 50 + (state >> 25) as u8;
    }
    for y in 0..H {
        for x in 0..W {
            let (dx, dy) = ((x as f64 - cx) / 15.0, (y as f64 - 120.0) / 30.0);
            if dx * dx + dy * dy <= 1.0 {
                let c = if dy < -0.2 {
                    [30, 30, 120]
                } else {
                    [200, 60, 40]
                };
                px[(y * W + x) * 3..][..3].copy_from_slice(&c);
            }
        }
    }
    px
}

fn tracker_update(c: &mut Criterion) {
    let frames = [frame(150.0), frame(154.0)];
    let first = RgbFrame::new(&frames[0], W, H).unwrap();
    let bbox = BoundingBox::new(135.0, 90.0, 30.0, 60.0);
    let mut group = c.benchmark_group("tracker_update_320x240");
    let mut t = ColorHistogramTracker::new(first, bbox, ColorTrackerParams::default()).unwrap();
    let mut k = 0;
    group.bench_function("colour_local_search", |b| {
        b.iter(|| {
            k += 1;
            black_box(
                t.update(RgbFrame::new(&frames[k % 2], W, H).unwrap())
                    .unwrap(),
            )
        })
    });
    let mut t =
        ParticleColorTracker::new(first, bbox, ParticleTrackerParams::default(), 0).unwrap();
    group.bench_function("colour_particles_200", |b| {
        b.iter(|| {
            k += 1;
            black_box(
                t.update(RgbFrame::new(&frames[k % 2], W, H).unwrap())
                    .unwrap(),
            )
        })
    });
    group.finish();
}

/// A 160x160 frame with two rectangles and a disc, the pattern tracker's test scene.
fn pattern_scene() -> rperc_core::image::GrayImage {
    let n = 160;
    let mut img = rperc_core::image::GrayImage::zeros(n, n);
    for (i, g) in img.data.iter_mut().enumerate() {
        let (x, y) = ((i % n) as f64, (i / n) as f64);
        *g = if (x - 100.0).hypot(y - 60.0) < 18.0 {
            40.0
        } else if (30.0..60.0).contains(&x) && (40.0..70.0).contains(&y) {
            180.0
        } else if (30.0..100.0).contains(&x) && (90.0..105.0).contains(&y) {
            220.0
        } else {
            100.0 + ((i * 7919) % 11) as f32
        };
    }
    img
}

fn pattern_likelihood(c: &mut Criterion) {
    use tracking::pattern::PatternScratch;
    use tracking::{PatternConfig, PatternLikelihood, PatternModel, Region, ScaleSpace};
    let scene = pattern_scene();
    let region = Region::Box {
        x: 20,
        y: 30,
        w: 110,
        h: 85,
    };
    let model = PatternModel::from_region(&scene, region, &PatternConfig::default()).unwrap();
    let mut space = ScaleSpace::new();
    let mut group = c.benchmark_group("pattern");
    group.bench_function("scale_space_build_160", |b| {
        b.iter(|| space.build(black_box(&scene), &model).unwrap())
    });
    space.build(&scene, &model).unwrap();
    let lik = PatternLikelihood::new(&model, &space);
    let mut scratch = PatternScratch::default();
    let state = nalgebra::SVector::from([model.centre[0] + 1.0, model.centre[1], 0.05, 1.1]);
    group.bench_function("observe_one_state", |b| {
        b.iter(|| black_box(lik.observe(black_box(&state), &mut scratch)))
    });
    // One Gauss-Newton system of the refinement (about three likelihoods' worth).
    group.bench_function("normal_equations_one_state", |b| {
        b.iter(|| black_box(lik.normal_equations(black_box(&state))))
    });
    group.finish();
}

/// A 640 x 480 grey frame: the pattern scene pasted at `(x0, 160)` over a hashed
/// texture.
fn pattern_frame(x0: usize) -> Vec<u8> {
    let (w, h) = (640, 480);
    let scene = pattern_scene();
    (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            if (x0..x0 + scene.width).contains(&x) && (160..160 + scene.height).contains(&y) {
                scene.at(x - x0, y - 160) as u8
            } else {
                (90 + (i * 2_654_435_761) % 41) as u8
            }
        })
        .collect()
}

/// One pattern-tracker update, 200 particles on 640 x 480 (issue 12: >= 500 fps).
fn pattern_update(c: &mut Criterion) {
    use tracking::{PatternFrame, PatternTracker, PatternTrackerParams, Region};
    let frames = [pattern_frame(240), pattern_frame(241)];
    let view = |k: usize| {
        PatternFrame::Gray(rperc_core::image::GrayView::new(&frames[k % 2], 640, 480).unwrap())
    };
    let region = Region::Box {
        x: 260,
        y: 190,
        w: 110,
        h: 85,
    };
    let mut tracker =
        PatternTracker::new(view(0), region, PatternTrackerParams::default(), 0).unwrap();
    let mut k = 0;
    let mut group = c.benchmark_group("pattern");
    group.bench_function("update_640x480_200", |b| {
        b.iter(|| {
            k += 1;
            black_box(tracker.update(view(k)).unwrap())
        })
    });
    group.finish();
}

/// A 320 x 240 frame with a 50 x 36 blue rectangle at `x0` on a horizontal ramp.
fn rectangle_frame(x0: usize) -> Vec<u8> {
    let (w, h) = (320, 240);
    let mut px = vec![0u8; w * h * 3];
    for y in 0..h {
        for x in 0..w {
            let g = (60 + x * 120 / w) as u8;
            let c = if (x0..x0 + 50).contains(&x) && (100..136).contains(&y) {
                [60, 90, 190]
            } else {
                [g, g, g]
            };
            px[(y * w + x) * 3..][..3].copy_from_slice(&c);
        }
    }
    px
}

/// One colour+shape update, 100 samples, the speed goal of issue 14 (>= 100 fps).
fn color_shape_update(c: &mut Criterion) {
    let frames: Vec<Vec<u8>> = (0..8).map(|k| rectangle_frame(100 + 2 * k)).collect();
    let view = |k: usize| RgbFrame::new(&frames[k % 8], 320, 240).unwrap();
    let outline = [
        [100.0, 100.0],
        [149.0, 100.0],
        [149.0, 135.0],
        [100.0, 135.0],
    ];
    let mut group = c.benchmark_group("color_shape_update");
    for parallel in [false, true] {
        let mut params = ColorShapeParams::default();
        params.filter.parallel = parallel;
        let mut t = ColorShapeTracker::new(view(0), &outline, params).unwrap();
        let mut k = 0;
        let label = if parallel {
            "100_parallel"
        } else {
            "100_serial"
        };
        group.bench_function(label, |b| {
            b.iter(|| {
                k += 1;
                black_box(t.update(view(k)).unwrap())
            })
        });
    }
    group.finish();
}

criterion_group!(
    benches,
    color_shape_update,
    particle_filter_step,
    tracker_update,
    pattern_likelihood,
    pattern_update
);
criterion_main!(benches);
