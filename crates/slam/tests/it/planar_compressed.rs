//! The compressed EKF (Guivant & Nebot 2001) in the planar engine against the full
//! EKF as the oracle: on simulated worlds, with every association method and the
//! seed's variants, the path, the robot covariance after every event, the map and
//! the association statistics equal the full filter's to round-off, whatever the
//! active area's size.

use proptest::prelude::*;
use slam::planar::sim::{SimConfig, simulate};
use slam::planar::{
    Association, Compression, Event, PlanarConfig, PlanarResult, PlanarSlam, Statistics,
};

fn run(config: PlanarConfig, events: &[Event]) -> PlanarResult {
    let mut engine = PlanarSlam::new(config).unwrap();
    engine.run(events).unwrap();
    engine.finish()
}

/// The counts that describe what the filter did (not how it was computed).
fn decisions(s: &Statistics) -> [u64; 8] {
    [
        s.accepted,
        s.rejected,
        s.new,
        s.candidate,
        s.frozen,
        s.fixes_applied,
        s.fixes_rejected,
        s.jcbb_truncated,
    ]
}

/// The largest difference between two runs: every pose and robot covariance of the
/// trajectory, every landmark mean and covariance.
fn largest_gap(a: &PlanarResult, b: &PlanarResult) -> f64 {
    let (ta, tb) = (&a.trajectory, &b.trajectory);
    assert_eq!(ta.kind, tb.kind);
    let poses = ta.pose.iter().zip(&tb.pose).flat_map(|(p, q)| {
        let heading = rperc_core::angle_diff(p[2], q[2]).abs();
        [(p[0] - q[0]).abs(), (p[1] - q[1]).abs(), heading]
    });
    let covs = ta.covariance.iter().zip(&tb.covariance).flat_map(|(p, q)| {
        p.iter()
            .zip(q)
            .map(|(x, y)| (x - y).abs())
            .collect::<Vec<_>>()
    });
    assert_eq!(a.landmarks.len(), b.landmarks.len());
    let marks = a.landmarks.iter().zip(&b.landmarks).flat_map(|(l, k)| {
        assert_eq!((l.id, l.frozen, l.anchor), (k.id, k.frozen, k.anchor));
        let mean = l.mean.iter().zip(&k.mean).map(|(x, y)| (x - y).abs());
        let cov = l
            .covariance
            .iter()
            .zip(&k.covariance)
            .map(|(x, y)| (x - y).abs());
        mean.chain(cov).collect::<Vec<_>>()
    });
    poses.chain(covs).chain(marks).fold(0.0, f64::max)
}

/// A world where the robot sees a small part of the map at a time: 60 landmarks on
/// rings around a 25 m circle, 6 m range, two laps.
fn wide_world(steps: usize) -> SimConfig {
    SimConfig {
        radius: 25.0,
        landmarks: 60,
        steps,
        ..SimConfig::default()
    }
}

fn compare(config: PlanarConfig, sim: &SimConfig, seed: u64) -> (PlanarResult, f64) {
    let data = simulate(sim, seed, 0).unwrap();
    let off = PlanarConfig {
        compression: Compression::Off,
        ..config.clone()
    };
    let full = run(off, &data.events);
    let compressed = run(config, &data.events);
    assert_eq!(
        decisions(&compressed.statistics),
        decisions(&full.statistics)
    );
    assert_eq!(full.statistics.compressions, 0);
    let gap = largest_gap(&full, &compressed);
    (compressed, gap)
}

/// The compression really happens in these worlds (areas are made, passive
/// landmarks activated; from the first landmark on, for the test), and changes
/// nothing but round-off.
#[test]
fn a_compressed_run_equals_the_full_ekf() {
    for association in [
        Association::Known,
        Association::NearestNeighbour,
        Association::Jcbb,
    ] {
        let sim = wide_world(1600);
        let config = PlanarConfig {
            association,
            active_radius: 4.0,
            compression_min_landmarks: 1,
            ..sim.slam_config()
        };
        let (compressed, gap) = compare(config, &sim, 2);
        let s = &compressed.statistics;
        println!(
            "{association}: {} areas, {} activations, gap {gap:.1e}",
            s.compressions, s.activations
        );
        assert!(s.compressions >= 3 && s.activations > 0, "{s:?}");
        assert!(gap < 1e-9, "{association}: gap {gap}");
    }
}

/// The compressed filter follows the external fix (an update of the robot only)
/// and the first-estimates motion Jacobian, and freezing (a removal: the global update first) and the anchor (made before
/// any compression) leave it exact.
#[test]
fn the_seed_variants_compress_exactly() {
    let sim = SimConfig {
        fix_every: Some(10),
        ..wide_world(1000)
    };
    let base = PlanarConfig {
        association: Association::Jcbb,
        active_radius: 5.0,
        compression_min_landmarks: 1,
        ..sim.slam_config()
    };
    let variants = [
        (
            "anchor",
            PlanarConfig {
                anchor: true,
                ..base.clone()
            },
        ),
        (
            "external",
            PlanarConfig {
                external_fix: true,
                ..base.clone()
            },
        ),
        (
            "freeze",
            PlanarConfig {
                freeze_after: Some(15),
                ..base.clone()
            },
        ),
        (
            "first estimates",
            PlanarConfig {
                first_estimates: true,
                ..base.clone()
            },
        ),
    ];
    for (name, config) in variants {
        let (compressed, gap) = compare(config, &sim, 5);
        let s = &compressed.statistics;
        println!("{name}: {} areas, gap {gap:.1e}", s.compressions);
        assert!(s.compressions >= 1, "{name}: {s:?}");
        assert!(gap < 1e-9, "{name}: gap {gap}");
    }
}

/// Consider freezing (zero gains) cannot be compressed exactly: the engine then
/// runs the full filter.
#[test]
fn consider_freezing_runs_the_full_filter() {
    let sim = wide_world(400);
    let config = PlanarConfig {
        freeze_after: Some(10),
        freeze_mode: slam::planar::FreezeMode::Consider,
        active_radius: 4.0,
        ..sim.slam_config()
    };
    let (compressed, gap) = compare(config, &sim, 1);
    assert_eq!(compressed.statistics.compressions, 0);
    assert_eq!(gap, 0.0);
}

#[test]
fn bad_compression_settings_are_refused_by_name() {
    for radius in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let config = PlanarConfig {
            active_radius: radius,
            ..PlanarConfig::default()
        };
        let err = PlanarSlam::new(config).unwrap_err().to_string();
        assert!(err.contains("active_radius"), "{radius}: {err}");
    }
    let config = PlanarConfig {
        compression_min_landmarks: 0,
        ..PlanarConfig::default()
    };
    let err = PlanarSlam::new(config).unwrap_err().to_string();
    assert!(err.contains("compression_min_landmarks"), "{err}");
    let err = "on".parse::<Compression>().unwrap_err().to_string();
    assert!(err.contains("auto") && err.contains("off"), "{err}");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(12))]
    /// Over seeds, area sizes and association methods: the same decisions, and the
    /// same path, covariances and map to round-off.
    #[test]
    fn compression_is_exact_for_any_area(
        seed in 0u64..1000,
        radius in 1.0f64..30.0,
        method in 0usize..3,
    ) {
        let association =
            [Association::Known, Association::NearestNeighbour, Association::Jcbb][method];
        let sim = wide_world(500);
        let config = PlanarConfig {
            association,
            active_radius: radius,
            compression_min_landmarks: 1,
            ..sim.slam_config()
        };
        let (_, gap) = compare(config, &sim, seed);
        prop_assert!(gap < 1e-9, "gap {}", gap);
    }
}

/// Control-bias states lengthen the robot block, which the auxiliary matrices do
/// not cover: the engine then runs the full filter.
#[test]
fn control_bias_states_run_the_full_filter() {
    let sim = wide_world(400);
    let config = PlanarConfig {
        control_bias_sd: Some([0.01, 0.01]),
        active_radius: 4.0,
        compression_min_landmarks: 1,
        ..sim.slam_config()
    };
    let (compressed, gap) = compare(config, &sim, 1);
    assert_eq!(compressed.statistics.compressions, 0);
    assert_eq!(gap, 0.0);
}
