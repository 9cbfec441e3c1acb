//! The visual memory's hot paths: rendering one 320 x 240 ceiling frame, the robot's
//! work on one frame (eq. 1 correction, the trackers of up to four models, eq. 2)
//! while localising against a learnt mosaic, the pose filter's frame (prediction and
//! four gated sightings against a stored mosaic of 30 models in its state), and the
//! search of the robot pose that starts a replay.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{DMatrix, Matrix3};
use navigation::ceiling::{Ceiling, CeilingCamera, CeilingParams, RenderParams, render};
use navigation::memory::{
    ImageScale, LearnParams, LocaliserParams, ModelSighting, MosaicBuilder, MosaicParams,
    PoseFilter, World, learn, observe, search_pose,
};
use rperc_core::Pose2;
use rperc_core::image::GrayView;

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

/// A replay's filter: the robot and a stored mosaic of 30 models on a 6 x 5 grid of
/// 0.8 m (93 states), with the mosaic's covariance; per frame one odometry prediction
/// and the gated updates of four models in view.
fn bench_filter(c: &mut Criterion) {
    let scale = ImageScale {
        metres_per_pixel: 2.5 / 160.0,
        principal: [159.5, 119.5],
    };
    let params = LocaliserParams::default();
    let models: Vec<(usize, Pose2)> = (0..30)
        .map(|k| {
            let (i, j) = ((k % 6) as f64, (k / 6) as f64);
            (k + 1, Pose2::new(0.8 * i, 0.8 * j, 0.3 * k as f64))
        })
        .collect();
    let map = DMatrix::<f64>::identity(90, 90) * 1e-4;
    let robot = Pose2::new(1.2, 1.0, 0.2);
    let filter = PoseFilter::with_map(robot, Matrix3::identity() * 1e-4, &models, &map);
    let sightings: Vec<ModelSighting> = [1, 2, 7, 8]
        .iter()
        .map(|&k| {
            let (id, model) = models[k];
            let (z, _, _) = observe(&scale, &robot, &model);
            ModelSighting {
                id,
                model_in_mosaic: model,
                model_covariance: Matrix3::zeros(),
                state: [z[0] + 0.2, z[1] - 0.1, z[2], 1.0],
                rotation_sigma: 0.05,
            }
        })
        .collect();
    let gate = rperc_core::chi2_quantile(params.gate_probability, 3.0).unwrap();
    let step = Pose2::new(0.03, 0.0, 0.01);
    c.bench_function("memory/filter_frame_30_models_4_sightings", |b| {
        b.iter_batched(
            || filter.clone(),
            |mut f| {
                f.predict(&step, &params, 1.0);
                for s in &sightings {
                    if f.nis(&scale, s, params.pixel_sigma)
                        .is_some_and(|d| d < gate)
                    {
                        f.update(&scale, s, params.pixel_sigma);
                    }
                }
                f
            },
            criterion::BatchSize::SmallInput,
        )
    });
}

/// The search that starts a replay: three models of a learnt mosaic, the robot 6 cm
/// and 3 degrees from its guess, a guess of 5.8 cm and 0.058 rad (a start drawn
/// within 10 cm and 0.1 rad), searched over three standard deviations.
fn bench_search(c: &mut Criterion) {
    let ceiling = Ceiling::generate(&CeilingParams::default()).unwrap();
    let camera = CeilingCamera::default();
    let params = RenderParams::default();
    let world = World {
        ceiling: &ceiling,
        camera: &camera,
        render: &params,
    };
    let start = Pose2::new(3.0, 3.0, 0.0);
    let learnt = learn(
        world,
        start,
        &[[0.3, 0.0]; 10],
        0.1,
        &LearnParams::default(),
        0,
    )
    .unwrap();
    let truth = learnt.reports[0].pose.unwrap();
    let mut frame = Vec::new();
    render(&ceiling, &camera, &start, &params, 7, &mut frame).unwrap();
    let mut image = rperc_core::image::GrayImage::default();
    image.set_from_gray(&GrayView::new(&frame, camera.width, camera.height).unwrap());
    let mut ideal = rperc_core::image::GrayImage::default();
    navigation::ceiling::correct_image(&camera, &image, 0.0, &mut ideal).unwrap();
    let candidates: Vec<_> = learnt
        .memory
        .models
        .iter()
        .take(3)
        .map(|m| (&m.model, m.pose))
        .collect();
    let scale = ImageScale {
        metres_per_pixel: camera.metres_per_pixel(),
        principal: [camera.cx, camera.cy],
    };
    let guess = truth.compose(&Pose2::new(0.05, -0.03, 0.05));
    let sigma = 0.1 / 3f64.sqrt();
    let cov = Matrix3::from_diagonal_element(sigma * sigma);
    c.bench_function("memory/search_pose_3_models", |b| {
        b.iter(|| search_pose(&ideal, &candidates, &scale, black_box(&guess), &cov, 3.0).unwrap())
    });
}

criterion_group!(benches, bench_memory, bench_filter, bench_search);
criterion_main!(benches);
