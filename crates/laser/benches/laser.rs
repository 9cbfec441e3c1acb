//! Criterion benches of the laser pipeline's hot paths: scan preprocessing and one
//! ICP match against a local map, one loop-closure attempt, and one key scan's
//! walls extracted and paired with a wall map, on simulated scans of a cluttered
//! room.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use laser::graph::PoseGraph;
use laser::loops::{LoopConfig, close_loop};
use laser::scan::{Beams, ScanConfig, scan_points};
use laser::sim::{cluttered_room, ray_cast};
use laser::walls::{Extractor, WallConfig, WallMap};
use laser::{IcpConfig, MapIndex, Prior, match_scan};
use nalgebra::Matrix3;
use rperc_core::Pose2;

fn angles(n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| -std::f64::consts::FRAC_PI_2 + std::f64::consts::PI * i as f64 / (n - 1) as f64)
        .collect()
}

fn bench_scan(c: &mut Criterion) {
    let walls = cluttered_room(12.0, 8.0);
    let a = angles(361);
    let pose = Pose2::new(3.0, 2.0, 0.3);
    let ranges = ray_cast(&walls, &pose, &a, 80.0);
    let beams = Beams {
        ranges: &ranges,
        angle_min: a[0],
        angle_increment: a[1] - a[0],
        max_range: 80.0,
    };
    let cfg = ScanConfig::default();
    c.bench_function("scan_points/361 beams", |b| {
        b.iter(|| scan_points(black_box(&beams), &cfg).unwrap())
    });

    let scan = scan_points(&beams, &cfg).unwrap();
    let (mut pts, mut nrm) = (Vec::new(), Vec::new());
    for (p, n) in scan.points.iter().zip(&scan.normals) {
        if let Some(n) = n {
            pts.push(pose.transform_point(&(*p).into()).coords);
            nrm.push(pose.rotation() * n);
        }
    }
    let map = MapIndex::new(pts, nrm, 0.3).unwrap();
    let start = Pose2::new(3.05, 1.97, 0.31);
    let prior = Prior {
        mean: start,
        information: Matrix3::from_diagonal(&nalgebra::Vector3::new(400.0, 400.0, 3000.0)),
    };
    let icp = IcpConfig::default();
    c.bench_function("match_scan/one scan", |b| {
        b.iter(|| match_scan(black_box(&scan), &map, start, &prior, &icp).unwrap())
    });

    // A closure attempt: the correlative search (branch and bound) over a window of
    // about 2 m and 15 degrees, then ICP from its best poses.
    let loops = LoopConfig::default();
    let window = loops.window(&Matrix3::from_diagonal(&nalgebra::Vector3::new(
        0.4, 0.3, 0.0025,
    )));
    let guess = Pose2::new(3.6, 1.5, 0.2);
    c.bench_function("close_loop/2 m window", |b| {
        b.iter(|| close_loop(black_box(&scan), &map, &guess, &window, &icp, &loops).unwrap())
    });

    // A key scan's walls: extracted from the beams, then paired with a map that
    // already holds them (seen from 12 m of path back, so each becomes a factor).
    let cfg = WallConfig {
        enabled: true,
        ..WallConfig::default()
    };
    let mut extractor = Extractor::new(cfg);
    let bounds = (0.0, 80.0);
    c.bench_function("walls/extract and pair one key scan", |b| {
        b.iter_batched(
            || {
                let mut graph = PoseGraph::new(pose, Matrix3::identity() * 1e8);
                let mut map = WallMap::default();
                let seen = Extractor::new(cfg)
                    .sightings(&ranges, a[0], a[1] - a[0], bounds)
                    .unwrap();
                map.observe(0, 0.0, &seen, &mut graph, &cfg).unwrap();
                graph.add_pose(pose);
                (graph, map)
            },
            |(mut graph, mut map)| {
                let seen = extractor
                    .sightings(black_box(&ranges), a[0], a[1] - a[0], bounds)
                    .unwrap();
                map.observe(1, 12.0, &seen, &mut graph, &cfg).unwrap();
                (graph, map)
            },
            criterion::BatchSize::SmallInput,
        )
    });
}

criterion_group!(benches, bench_scan);
criterion_main!(benches);
