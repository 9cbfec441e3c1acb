//! Criterion benches of planar EKF-SLAM: one prediction and one scan update against
//! the number of landmarks (O(n) and O(n^2): the slopes of log time against log n
//! should be about 1 and 2), whole simulated runs per association method, and the
//! full MR.CLAM robot-1 run when the data set is present (`RPERC_DATA`, default
//! `../shared/data`), the compressed EKF against the full one (a simulated world
//! and Victoria Park, whole runs), a whole simulated room run with wall landmarks, and
//! the batch smoothing of that run.

use std::hint::black_box;
use std::path::PathBuf;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use nalgebra::{DMatrix, DVector, Matrix2, Vector2};
use rand::{Rng, SeedableRng, rngs::StdRng};
use slam::planar::sim::{SimConfig, simulate};
use slam::planar::{Association, Compression, EventArrays, PlanarConfig, PlanarSlam};
use slam::{Ekf, unicycle};

/// A filter with `n` landmarks spread around the robot and a dense SPD covariance.
fn filter(n: usize) -> Ekf {
    let mut rng = StdRng::seed_from_u64(1);
    let d = 3 + 2 * n;
    let mut x = DVector::from_fn(d, |_, _| rng.random_range(-20.0..20.0));
    x[2] = 0.3;
    let a = DMatrix::from_fn(d, 8, |_, _| rng.random_range(-1.0..1.0));
    let p = &a * a.transpose() * 0.05 + DMatrix::identity(d, d) * 0.5;
    Ekf::new(x, p, 3, 2).unwrap().with_wrapped_angle(2).unwrap()
}

const SIZES: [usize; 5] = [10, 50, 100, 500, 1000];

fn bench_predict(c: &mut Criterion) {
    let mut group = c.benchmark_group("planar/predict");
    let v = Matrix2::new(0.01, 0.0, 0.0, 0.001);
    for n in SIZES {
        let mut ekf = filter(n);
        group.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            b.iter(|| {
                let x = ekf.state();
                let pose = rperc_core::Pose2::new(x[0], x[1], x[2]);
                let p = unicycle(&pose, 0.5, 0.1, 0.015);
                ekf.predict_planar(black_box(&p.mean), &p.fx, &p.fv, &v)
                    .unwrap();
            })
        });
    }
    group.finish();
}

fn bench_update(c: &mut Criterion) {
    let mut group = c.benchmark_group("planar/update_batch3");
    group.sample_size(20);
    let r = Matrix2::new(0.01, 0.0, 0.0, 0.001);
    for n in SIZES {
        let mut ekf = filter(n);
        let obs: Vec<_> = (0..3)
            .map(|k| (k * n / 3, Vector2::new(10.0, 0.3)))
            .collect();
        group.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            b.iter(|| ekf.update_range_bearing_batch(black_box(&obs), &r).unwrap())
        });
    }
    group.finish();
}

fn bench_simulated_runs(c: &mut Criterion) {
    let mut group = c.benchmark_group("planar/sim_600_steps");
    group.sample_size(10);
    let sim = SimConfig::default();
    let data = simulate(&sim, 1, 0).unwrap();
    for association in [
        Association::Known,
        Association::NearestNeighbour,
        Association::Jcbb,
    ] {
        let config = PlanarConfig {
            association,
            ..sim.slam_config()
        };
        group.bench_function(association.name(), |b| {
            b.iter(|| {
                let mut engine = PlanarSlam::new(config.clone()).unwrap();
                engine.run(black_box(&data.events)).unwrap();
                engine.statistics().accepted
            })
        });
    }
    group.finish();
}

fn data_dir() -> Option<PathBuf> {
    let dir = std::env::var_os("RPERC_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"));
    dir.join("mrclam6").is_dir().then(|| dir.join("mrclam6"))
}

fn rows(path: &PathBuf) -> Vec<Vec<f64>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| !l.trim_start().starts_with('#') && !l.trim().is_empty())
        .map(|l| l.split_whitespace().map(|v| v.parse().unwrap()).collect())
        .collect()
}

/// Controls, detections, their landmark ids, the start pose.
type MrClam = (Vec<[f64; 3]>, Vec<[f64; 3]>, Vec<i64>, [f64; 3]);

/// MR.CLAM robot 1 as arrays: controls, detections of landmarks (subjects 6-20,
/// by barcode), start pose from the first ground-truth row.
fn mrclam() -> Option<MrClam> {
    let dir = data_dir()?;
    let barcode_to_subject: std::collections::HashMap<i64, i64> = rows(&dir.join("Barcodes.dat"))
        .iter()
        .map(|r| (r[1] as i64, r[0] as i64))
        .collect();
    let controls = rows(&dir.join("Robot1_Odometry.dat"))
        .iter()
        .map(|r| [r[0], r[1], r[2]])
        .collect();
    let (mut dets, mut ids) = (Vec::new(), Vec::new());
    for r in rows(&dir.join("Robot1_Measurement.dat")) {
        if let Some(&s) = barcode_to_subject
            .get(&(r[1] as i64))
            .filter(|s| (6..=20).contains(*s))
        {
            dets.push([r[0], r[2], r[3]]);
            ids.push(s);
        }
    }
    let g = &rows(&dir.join("Robot1_Groundtruth.dat"))[0];
    Some((controls, dets, ids, [g[1], g[2], g[3]]))
}

fn bench_mrclam(c: &mut Criterion) {
    let Some((controls, dets, ids, start)) = mrclam() else {
        eprintln!("MR.CLAM data not found (RPERC_DATA): skipping planar/mrclam_robot1");
        return;
    };
    let config = PlanarConfig {
        initial_pose: start,
        motion: slam::MotionModel::Unicycle(slam::Unicycle {
            speed_variance: 0.1,
            turn_rate_variance: 0.5,
        }),
        range_variance: 0.01,
        bearing_variance: 0.003,
        ..PlanarConfig::default()
    };
    let arrays = EventArrays {
        controls: &controls,
        detections: &dets,
        detection_ids: Some(&ids),
        fixes: &[],
        walls: &[],
    };
    let mut group = c.benchmark_group("planar/mrclam_robot1");
    group.sample_size(10);
    group.bench_function("known", |b| {
        b.iter(|| {
            let mut engine = PlanarSlam::new(config.clone()).unwrap();
            engine.run_arrays(black_box(&arrays)).unwrap();
            engine.statistics().accepted
        })
    });
    group.finish();
}

/// The compressed EKF against the full one, whole runs: a simulated world where the
/// robot sees a small part of the map at a time (60 landmarks on rings around a 25 m
/// circle, 6 m range, 1600 steps), and Victoria Park with its preset (JCBB, three
/// sightings) when the data set is present. Both give the same results.
fn bench_compression(c: &mut Criterion) {
    let sim = SimConfig {
        radius: 25.0,
        landmarks: 60,
        steps: 1600,
        ..SimConfig::default()
    };
    let data = simulate(&sim, 2, 0).unwrap();
    let mut group = c.benchmark_group("planar/wide_world_1600_steps");
    group.sample_size(10);
    for compression in [Compression::Off, Compression::Auto] {
        let config = PlanarConfig {
            association: Association::Jcbb,
            compression,
            compression_min_landmarks: 1,
            ..sim.slam_config()
        };
        group.bench_function(compression.name(), |b| {
            b.iter(|| {
                let mut engine = PlanarSlam::new(config.clone()).unwrap();
                engine.run(black_box(&data.events)).unwrap();
                engine.statistics().accepted
            })
        });
    }
    group.finish();
    let park = data_dir().map(|d| d.with_file_name("victoria_park"));
    let Some(park) = park.filter(|p| p.is_dir()) else {
        eprintln!("Victoria Park not found (RPERC_DATA): skipping planar/victoria_park");
        return;
    };
    let controls: Vec<[f64; 3]> = rows(&park.join("inputs.dat"))
        .iter()
        .map(|r| [r[0], r[1], r[2]])
        .collect();
    // The file's bearing is in the laser frame, pi/2 straight ahead.
    let detections: Vec<[f64; 3]> = rows(&park.join("measurements.dat"))
        .iter()
        .map(|r| [r[0], r[1], r[2] - std::f64::consts::FRAC_PI_2])
        .collect();
    let arrays = EventArrays {
        controls: &controls,
        detections: &detections,
        ..EventArrays::default()
    };
    let mut group = c.benchmark_group("planar/victoria_park");
    group.sample_size(10);
    for compression in [Compression::Off, Compression::Auto] {
        let config = PlanarConfig {
            motion: slam::MotionModel::Ackermann(slam::Ackermann::default()),
            range_variance: 1.0,
            bearing_variance: 3f64.to_radians().powi(2),
            association: Association::Jcbb,
            candidate_sightings: 3,
            compression,
            ..PlanarConfig::default()
        };
        group.bench_function(compression.name(), |b| {
            b.iter(|| {
                let mut engine = PlanarSlam::new(config.clone()).unwrap();
                engine.run_arrays(black_box(&arrays)).unwrap();
                engine.statistics().accepted
            })
        });
    }
    group.finish();
}

/// Wall landmarks: a whole simulated room run (300 wall scans of about 5 walls, 6
/// walls in the map), per association method; 300 / time is the scans per second.
fn bench_wall_room(c: &mut Criterion) {
    use slam::planar::room::{RoomConfig, simulate_room};
    let room = RoomConfig::default();
    let data = simulate_room(&room, 3, 0);
    let mut group = c.benchmark_group("planar/wall_room_300_scans");
    for association in [Association::NearestNeighbour, Association::Jcbb] {
        let config = PlanarConfig {
            association,
            ..room.slam_config()
        };
        group.bench_function(format!("{association}"), |b| {
            b.iter(|| {
                let mut engine = PlanarSlam::new(config.clone()).unwrap();
                engine.run(black_box(&data.events)).unwrap();
                engine.statistics().walls_accepted
            })
        });
    }
    group.finish();
}

/// The batch smoother over a whole simulated room run (300 scans, 6 walls, the
/// filter's association and estimates as the start).
fn bench_wall_smoother(c: &mut Criterion) {
    use slam::planar::room::{RoomConfig, simulate_room};
    use slam::planar::smooth::{FilterRun, SmootherConfig, smooth};
    use slam::planar::{Event, EventKind};
    let room = RoomConfig::default();
    let data = simulate_room(&room, 3, 0);
    let config = room.slam_config();
    let mut engine = PlanarSlam::new(config.clone()).unwrap();
    engine.run(&data.events).unwrap();
    let result = engine.finish();
    let (mut controls, mut rows, mut times) = (vec![], vec![], vec![0.0]);
    for event in &data.events {
        match event {
            Event::Control { t, control } => controls.push([*t, control[0], control[1]]),
            Event::Walls { t, walls } => {
                times.push(*t);
                rows.extend(walls.iter().map(|w| {
                    let c = w.covariance;
                    [
                        *t, w.rho, w.alpha, c[0], c[1], c[3], w.start[0], w.start[1], w.end[0],
                        w.end[1],
                    ]
                }));
            }
            _ => {}
        }
    }
    let tr = &result.trajectory;
    let mut poses = vec![config.initial_pose];
    poses.extend(
        (0..tr.t.len())
            .filter(|&i| tr.kind[i] == EventKind::Walls)
            .map(|i| tr.pose[i]),
    );
    let map: Vec<(u64, [f64; 2])> = result.walls.iter().map(|w| (w.id, w.line)).collect();
    let run = FilterRun {
        config: &config,
        controls: &controls,
        times: &times,
        poses: &poses,
        walls: &rows,
        pairing: &result.wall_pairing,
        map: &map,
        points: &[],
        point_pairing: &[],
        landmarks: &[],
    };
    c.bench_function("planar/wall_smoother_300_scans", |b| {
        b.iter(|| {
            smooth(black_box(&run), &SmootherConfig::default())
                .unwrap()
                .iterations
        })
    });
}

/// The batch smoother over a whole simulated point-landmark run (600 steps, 24
/// landmarks, a pose at every scan; the filter's association and estimates as the
/// start).
fn bench_point_smoother(c: &mut Criterion) {
    use slam::planar::sim::{SimConfig, simulate};
    use slam::planar::smooth::{FilterRun, SmootherConfig, smooth};
    use slam::planar::{Event, EventKind};
    let sim = SimConfig::default();
    let data = simulate(&sim, 3, 0).unwrap();
    let config = sim.slam_config();
    let mut engine = PlanarSlam::new(config.clone()).unwrap();
    engine.run(&data.events).unwrap();
    let result = engine.finish();
    let (mut controls, mut points, mut times) = (vec![], vec![], vec![0.0]);
    for event in &data.events {
        match event {
            Event::Control { t, control } => controls.push([*t, control[0], control[1]]),
            Event::Scan { t, detections } => {
                if *t > 0.0 {
                    times.push(*t);
                }
                points.extend(detections.iter().map(|d| [*t, d.range, d.bearing]));
            }
            _ => {}
        }
    }
    let tr = &result.trajectory;
    let mut poses = vec![config.initial_pose];
    poses.extend(
        (0..tr.t.len())
            .filter(|&i| tr.kind[i] == EventKind::Scan && tr.t[i] > 0.0)
            .map(|i| tr.pose[i]),
    );
    let landmarks: Vec<(u64, [f64; 2])> = result.landmarks.iter().map(|l| (l.id, l.mean)).collect();
    let run = FilterRun {
        config: &config,
        controls: &controls,
        times: &times,
        poses: &poses,
        walls: &[],
        pairing: &[],
        map: &[],
        points: &points,
        point_pairing: &result.point_pairing,
        landmarks: &landmarks,
    };
    let options = SmootherConfig {
        point_correlation_time: 0.5,
        ..SmootherConfig::default()
    };
    c.bench_function("planar/point_smoother_600_steps", |b| {
        b.iter(|| smooth(black_box(&run), &options).unwrap().iterations)
    });
}

criterion_group!(
    benches,
    bench_predict,
    bench_update,
    bench_simulated_runs,
    bench_mrclam,
    bench_compression,
    bench_wall_room,
    bench_wall_smoother,
    bench_point_smoother
);
criterion_main!(benches);
