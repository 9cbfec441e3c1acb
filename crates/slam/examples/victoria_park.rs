//! The whole Victoria Park run with the Python preset's settings (JCBB, three
//! sightings, 1 m and 3 degrees), full and compressed EKF, timed and compared:
//! `cargo run -p slam --release --example victoria_park [DATA_DIR]` (default
//! `$RPERC_DATA/victoria_park`). A development tool: the benchmark of record is
//! `benchmarks/planar_slam.py`.

use std::path::PathBuf;
use std::time::Instant;

use slam::planar::{Association, Compression, EventArrays, PlanarConfig, PlanarSlam};
use slam::{Ackermann, MotionModel};

/// The numeric columns of a whitespace-separated file.
fn read(path: &PathBuf, cols: usize) -> Vec<Vec<f64>> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path:?}: {e}"));
    text.lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let v: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
            assert!(v.len() >= cols, "{path:?}: short line {l}");
            v
        })
        .collect()
}

fn main() {
    let dir = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            PathBuf::from(std::env::var("RPERC_DATA").unwrap_or("../shared/data".into()))
                .join("victoria_park")
        });
    let controls: Vec<[f64; 3]> = read(&dir.join("inputs.dat"), 3)
        .iter()
        .map(|r| [r[0], r[1], r[2]])
        .collect();
    let detections: Vec<[f64; 3]> = read(&dir.join("measurements.dat"), 3)
        .iter()
        .map(|r| [r[0], r[1], r[2] - std::f64::consts::FRAC_PI_2])
        .collect();
    let arrays = EventArrays {
        controls: &controls,
        detections: &detections,
        ..Default::default()
    };
    let radius = std::env::var("ACTIVE_RADIUS")
        .map_or(PlanarConfig::default().active_radius, |r| {
            r.parse().unwrap()
        });
    let run = |compression| {
        let config = PlanarConfig {
            motion: MotionModel::Ackermann(Ackermann::default()),
            range_variance: 1.0,
            bearing_variance: 3f64.to_radians().powi(2),
            association: Association::Jcbb,
            candidate_sightings: 3,
            compression,
            active_radius: radius,
            ..PlanarConfig::default()
        };
        let mut engine = PlanarSlam::new(config).unwrap();
        let t0 = Instant::now();
        engine.run_arrays(&arrays).unwrap();
        let result = engine.finish();
        (result, t0.elapsed().as_secs_f64())
    };
    let only = std::env::var("ONLY").unwrap_or_default();
    if only == "auto" || only == "off" {
        let mode = if only == "auto" {
            Compression::Auto
        } else {
            Compression::Off
        };
        let (comp, t) = run(mode);
        println!("compressed {t:.3} s {:?}", comp.statistics);
        return;
    }
    let (full, t_full) = run(Compression::Off);
    let (comp, t_comp) = run(Compression::Auto);
    let gap = full
        .trajectory
        .pose
        .iter()
        .zip(&comp.trajectory.pose)
        .map(|(a, b)| (a[0] - b[0]).hypot(a[1] - b[1]))
        .fold(0.0, f64::max);
    let lm_gap = full
        .landmarks
        .iter()
        .zip(&comp.landmarks)
        .map(|(a, b)| {
            let cov = (0..4)
                .map(|k| (a.covariance[k] - b.covariance[k]).abs())
                .fold(0.0, f64::max);
            ((a.mean[0] - b.mean[0]).hypot(a.mean[1] - b.mean[1])).max(cov)
        })
        .fold(0.0, f64::max);
    println!(
        "full {t_full:.3} s, compressed {t_comp:.3} s ({:.1}x)",
        t_full / t_comp
    );
    println!("path gap {gap:.2e} m, landmark gap {lm_gap:.2e}");
    println!("full: {:?}", full.statistics);
    println!("compressed: {:?}", comp.statistics);
}
