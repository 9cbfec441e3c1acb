//! The whole run on simulated scans: a loop in a cluttered room closes, and hostile
//! input (huge readings, NaN geometry, arrays that disagree, no scan) gives an error
//! or a result, never a panic or an allocation abort.

use laser::sim::{cluttered_room, ray_cast};
use laser::{LaserConfig, ScanLog, run};
use rperc_core::Pose2;

const BEAMS: usize = 181;

/// Two laps of a circle inside the room: scans every 0.3 m, unicycle controls that
/// drive it exactly (the odometry noise is the config's; the controls are exact).
pub(crate) fn laps() -> (Vec<f64>, Vec<usize>, Vec<[f64; 3]>, Vec<f64>) {
    let walls = cluttered_room(12.0, 8.0);
    let angles: Vec<f64> = (0..BEAMS)
        .map(|i| (-90.0 + i as f64).to_radians())
        .collect();
    let (r, v, steps) = (1.8, 0.3, 76);
    let w = v / r;
    let mut ranges = Vec::new();
    let mut controls = Vec::new();
    let mut times = Vec::new();
    for k in 0..steps {
        let a = w * k as f64;
        let pose = Pose2::new(6.0 + r * a.sin(), 4.0 - r * a.cos(), a);
        ranges.extend(ray_cast(&walls, &pose, &angles, 30.0));
        controls.push([k as f64, v, w]);
        times.push(k as f64);
    }
    (ranges, vec![BEAMS; steps], controls, times)
}

pub(crate) fn log<'a>(
    ranges: &'a [f64],
    counts: &'a [usize],
    geometry: &'a (Vec<f64>, Vec<f64>, Vec<f64>),
) -> ScanLog<'a> {
    ScanLog {
        ranges,
        width: BEAMS,
        counts,
        angle_min: &geometry.0,
        angle_increment: &geometry.1,
        max_range: &geometry.2,
    }
}

pub(crate) fn geometry(n: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    (
        vec![-90f64.to_radians(); n],
        vec![1f64.to_radians(); n],
        vec![30.0; n],
    )
}

pub(crate) fn config() -> LaserConfig {
    LaserConfig {
        initial_pose: [6.0, 2.2, 0.0],
        ..Default::default()
    }
}

#[test]
fn a_simulated_double_loop_runs_and_stays_near_the_truth() {
    let (ranges, counts, controls, times) = laps();
    let g = geometry(counts.len());
    let out = run(&log(&ranges, &counts, &g), &controls, &times, &config()).unwrap();
    assert_eq!(out.pose.len(), counts.len());
    assert!(out.matched.iter().all(|&m| m));
    let (r, w) = (1.8, 0.3 / 1.8);
    for (k, p) in out.pose.iter().enumerate() {
        let a = w * k as f64;
        let (tx, ty) = (6.0 + r * a.sin(), 4.0 - r * a.cos());
        assert!((p.x - tx).hypot(p.y - ty) < 0.05, "scan {k}: {p:?}");
    }
}

#[test]
fn huge_readings_do_not_abort() {
    let (mut ranges, counts, controls, times) = laps();
    for r in ranges.iter_mut().skip(5 * BEAMS).take(BEAMS) {
        *r = 1e9;
    }
    let mut g = geometry(counts.len());
    g.2 = vec![1e12; counts.len()];
    let out = run(&log(&ranges, &counts, &g), &controls, &times, &config()).unwrap();
    assert!(out.pose.iter().all(|p| p.x.is_finite() && p.y.is_finite()));
}

#[test]
fn bad_input_is_an_error() {
    let (ranges, counts, controls, times) = laps();
    let mut g = geometry(counts.len());
    g.0[3] = f64::NAN;
    assert!(run(&log(&ranges, &counts, &g), &controls, &times, &config()).is_err());
    let g = geometry(counts.len());
    assert!(
        run(
            &log(&ranges[..ranges.len() - 1], &counts, &g),
            &controls,
            &times,
            &config()
        )
        .is_err()
    );
    assert!(
        run(
            &log(&ranges, &counts, &g),
            &controls,
            &times[..3],
            &config()
        )
        .is_err()
    );
    let none = geometry(0);
    assert!(run(&log(&[], &[], &none), &controls, &[], &config()).is_err());
    let mut too_many = counts.clone();
    too_many[0] = BEAMS + 1;
    assert!(run(&log(&ranges, &too_many, &g), &controls, &times, &config()).is_err());
}
