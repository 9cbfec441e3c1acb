//! First-estimates Jacobians for POINT landmarks (`PlanarConfig::first_estimates`,
//! Huang, Mourikis & Roumeliotis 2008), against the observability oracle: range and
//! bearing to points are relative measurements, so nothing observes where the whole
//! map (robot and points) sits or how it is turned, and the robot's absolute position
//! and heading variances can never fall below the start's. Linearised at the
//! changing current estimates, the filter "observes" its heading from nowhere (the
//! test shows it does, so the oracle can fail); with first estimates it must not.

use slam::planar::PlanarConfig;
use slam::planar::sim::{SimConfig, simulate};

use crate::planar_first_estimates::{START_VARIANCE, lowest_ratio_over};

/// The smallest ratio, over all events, of the robot's x, y and heading variances to
/// the start's.
fn lowest_variance_ratio(cfg: &PlanarConfig, sim: &SimConfig, run: u64) -> [f64; 3] {
    lowest_ratio_over(cfg, &simulate(sim, 7, run).unwrap().events)
}

#[test]
fn point_first_estimates_leave_the_map_frame_unobservable() {
    let sim = SimConfig {
        initial_pose_variance: START_VARIANCE,
        steps: 300,
        ..SimConfig::default()
    };
    let current = sim.slam_config();
    let fej = PlanarConfig {
        first_estimates: true,
        ..current.clone()
    };
    for run in 0..3 {
        let low = lowest_variance_ratio(&current, &sim, run);
        assert!(low[2] < 0.9, "run {run}: current estimates kept {low:?}");
        let low = lowest_variance_ratio(&fej, &sim, run);
        for (k, l) in low.iter().enumerate() {
            assert!(
                *l > 1.0 - 1e-6,
                "run {run}: variance {k} fell to {l} of the start's"
            );
        }
    }
}
