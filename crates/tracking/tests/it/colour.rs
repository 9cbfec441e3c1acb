//! The colour trackers against synthetic sequences whose true track is known by
//! construction, plus the error contract.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use tracking::{
    AppearanceParams, BoundingBox, ColorHistogramTracker, ColorSpace, ColorTrackerParams,
    ParticleColorTracker, ParticleTrackerParams, RgbFrame, TrackingError,
};

const W: usize = 160;
const H: usize = 120;

/// A textured background (fixed seed) with an elliptical two-colour "head" (dark top,
/// skin-coloured bottom) of semi-axes (ra, rb) centred at (cx, cy).
fn scene(cx: f64, cy: f64, ra: f64, rb: f64) -> Vec<u8> {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut px: Vec<u8> = (0..W * H * 3).map(|_| rng.random_range(60..190)).collect();
    for y in 0..H {
        for x in 0..W {
            let (dx, dy) = ((x as f64 + 0.5 - cx) / ra, (y as f64 + 0.5 - cy) / rb);
            if dx * dx + dy * dy <= 1.0 {
                let c = if dy < -0.3 {
                    [40, 25, 15]
                } else {
                    [225, 170, 140]
                };
                px[(y * W + x) * 3..][..3].copy_from_slice(&c);
            }
        }
    }
    px
}

fn truth(t: usize) -> (f64, f64, f64) {
    // Moves right and down at up to 3 px/frame along a curve; grows by 20%.
    let t = t as f64;
    (50.0 + 2.5 * t, 50.0 + 8.0 * (t / 6.0).sin(), 1.0 + 0.01 * t)
}

#[test]
fn local_search_follows_a_known_track() {
    let (ra, rb) = (12.0, 16.0);
    let (cx, cy, _) = truth(0);
    let f0 = scene(cx, cy, ra, rb);
    let bbox = BoundingBox::new(cx - ra, cy - rb, 2.0 * ra, 2.0 * rb);
    // Both the half-resolution-first search and the full one (12 px semi-axes: the
    // pyramid is used by default).
    for (parallel, pyramid) in [(true, true), (false, true), (true, false)] {
        for space in [
            ColorSpace::Rgb,
            ColorSpace::Opponent,
            ColorSpace::NormalizedRg,
            ColorSpace::Hsv,
        ] {
            let params = ColorTrackerParams {
                appearance: AppearanceParams {
                    color_space: space,
                    ..AppearanceParams::default()
                },
                parallel,
                pyramid,
                ..ColorTrackerParams::default()
            };
            let mut t = ColorHistogramTracker::new(RgbFrame::new(&f0, W, H).unwrap(), bbox, params)
                .unwrap();
            for k in 1..=20 {
                let (cx, cy, s) = truth(k);
                let f = scene(cx, cy, ra * s, rb * s);
                let r = t.update(RgbFrame::new(&f, W, H).unwrap()).unwrap();
                let (ex, ey) = r.bbox.centre();
                // The search is on whole pixels: within 2 px of the truth.
                assert!(
                    (ex - cx).abs() <= 2.0 && (ey - cy).abs() <= 2.0,
                    "{space:?} frame {k}: ({ex}, {ey}) vs ({cx}, {cy})"
                );
                assert!(!r.lost, "{space:?} frame {k}");
            }
            // Grew by 20%; the tracked scale must have followed most of it.
            assert!(
                t.scale() > 1.1 && t.scale() < 1.3,
                "{space:?} scale {}",
                t.scale()
            );
        }
    }
}

#[test]
fn lost_is_reported_when_the_target_vanishes() {
    let f0 = scene(60.0, 60.0, 12.0, 16.0);
    let bbox = BoundingBox::new(48.0, 44.0, 24.0, 32.0);
    let mut t = ColorHistogramTracker::new(
        RgbFrame::new(&f0, W, H).unwrap(),
        bbox,
        ColorTrackerParams::default(),
    )
    .unwrap();
    let empty = scene(-100.0, -100.0, 12.0, 16.0);
    let r = t.update(RgbFrame::new(&empty, W, H).unwrap()).unwrap();
    assert!(r.lost && r.score < 0.3, "{r:?}");
}

fn run_particles(threads: usize) -> Vec<[u64; 4]> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let (ra, rb) = (12.0, 16.0);
        let (cx, cy, _) = truth(0);
        let f0 = scene(cx, cy, ra, rb);
        let bbox = BoundingBox::new(cx - ra, cy - rb, 2.0 * ra, 2.0 * rb);
        let mut params = ParticleTrackerParams::default();
        params.filter.chunk_size = 32;
        let mut t =
            ParticleColorTracker::new(RgbFrame::new(&f0, W, H).unwrap(), bbox, params, 5).unwrap();
        (1..=10)
            .map(|k| {
                let (cx, cy, s) = truth(k);
                let f = scene(cx, cy, ra * s, rb * s);
                let r = t.update(RgbFrame::new(&f, W, H).unwrap()).unwrap();
                assert!(
                    (r.bbox.centre().0 - cx).abs() < 4.0 && (r.bbox.centre().1 - cy).abs() < 4.0,
                    "frame {k}: {r:?}"
                );
                r.bbox.to_array().map(f64::to_bits)
            })
            .collect()
    })
}

#[test]
fn particle_tracker_follows_and_is_bit_identical_across_thread_counts() {
    assert_eq!(run_particles(1), run_particles(2));
}

#[test]
fn bad_inputs_are_clear_errors() {
    let f0 = scene(60.0, 60.0, 12.0, 16.0);
    let frame = RgbFrame::new(&f0, W, H).unwrap();
    let p = ColorTrackerParams::default;
    let size_error = RgbFrame::new(&f0, W, H + 1).unwrap_err().to_string();
    assert!(
        size_error.contains(&format!("{W}x{}x3", H + 1)),
        "{size_error}"
    );
    let empty = RgbFrame::new(&[], 0, 5).unwrap_err().to_string();
    assert!(empty.contains("empty"), "{empty}");
    let bad_box = |b: BoundingBox| ColorHistogramTracker::new(frame, b, p()).unwrap_err();
    assert!(matches!(
        bad_box(BoundingBox::new(10.0, 10.0, 0.0, 5.0)),
        TrackingError::InvalidBox { .. }
    ));
    assert!(matches!(
        bad_box(BoundingBox::new(f64::NAN, 10.0, 5.0, 5.0)),
        TrackingError::InvalidBox { .. }
    ));
    assert!(matches!(
        bad_box(BoundingBox::new(150.0, 10.0, 20.0, 5.0)),
        TrackingError::BoxOutsideFrame { .. }
    ));
    assert!(matches!(
        bad_box(BoundingBox::new(-5.0, 10.0, 20.0, 5.0)),
        TrackingError::BoxOutsideFrame { .. }
    ));
    let bbox = BoundingBox::new(48.0, 44.0, 24.0, 32.0);
    let bad_param =
        |params: ColorTrackerParams| ColorHistogramTracker::new(frame, bbox, params).unwrap_err();
    let mut q = p();
    q.appearance.bins = [0, 8, 8];
    assert_eq!(bad_param(q).parameter(), Some("bins"));
    let mut q = p();
    q.appearance.adaptation_rate = f64::NAN;
    assert_eq!(bad_param(q).parameter(), Some("adaptation_rate"));
    let mut q = p();
    q.appearance.gradient_weight = -1.0;
    assert_eq!(bad_param(q).parameter(), Some("gradient_weight"));
    let e = bad_param(ColorTrackerParams {
        min_scale: 0.0,
        ..p()
    });
    assert_eq!(e.parameter(), Some("min_scale"));
    let pp = ParticleTrackerParams {
        sigma: -0.1,
        ..ParticleTrackerParams::default()
    };
    let e = ParticleColorTracker::new(frame, bbox, pp, 0).unwrap_err();
    assert_eq!(e.parameter(), Some("sigma"));
    let pp = ParticleTrackerParams {
        n_particles: 0,
        ..ParticleTrackerParams::default()
    };
    assert!(ParticleColorTracker::new(frame, bbox, pp, 0).is_err());

    let mut t = ColorHistogramTracker::new(frame, bbox, p()).unwrap();
    let small = vec![0u8; 10 * 10 * 3];
    assert!(matches!(
        t.update(RgbFrame::new(&small, 10, 10).unwrap()),
        Err(TrackingError::FrameSizeChanged {
            expected_width: 160,
            ..
        })
    ));
}

/// A particle tracker on the synthetic head with `n` particles, after one frame.
fn tracker_after_one_frame(n: usize, parallel: bool) -> ParticleColorTracker {
    let (ra, rb) = (12.0, 16.0);
    let (cx, cy, _) = truth(0);
    let f0 = scene(cx, cy, ra, rb);
    let bbox = BoundingBox::new(cx - ra, cy - rb, 2.0 * ra, 2.0 * rb);
    let mut params = ParticleTrackerParams {
        n_particles: n,
        ..ParticleTrackerParams::default()
    };
    params.filter.parallel = parallel;
    let mut t =
        ParticleColorTracker::new(RgbFrame::new(&f0, W, H).unwrap(), bbox, params, 9).unwrap();
    let (cx, cy, s) = truth(1);
    t.update(RgbFrame::new(&scene(cx, cy, ra * s, rb * s), W, H).unwrap())
        .unwrap();
    t
}

fn bits(t: &ParticleColorTracker) -> Vec<u64> {
    let f = t.filter();
    f.particles()
        .iter()
        .flat_map(|p| p.iter().copied())
        .chain(f.weights().iter().copied())
        .chain(f.mean().iter().copied())
        .map(f64::to_bits)
        .collect()
}

#[test]
fn an_interrupted_update_leaves_the_particles_as_they_were() {
    use rperc_core::interrupt::{Interrupt, run_polled, run_with};
    use std::sync::Arc;
    // Enough particles that a step outlasts the first poll (20 ms) many times over.
    let n = 40_000;
    let (cx, cy, s) = truth(2);
    let f2 = scene(cx, cy, 12.0 * s, 16.0 * s);
    let frame = || RgbFrame::new(&f2, W, H).unwrap();
    for parallel in [false, true] {
        let mut t = tracker_after_one_frame(n, parallel);
        let before = bits(&t);
        let stopped = match parallel {
            // The pool's threads see a token another thread stops (the bridge's poll).
            true => {
                let token = Arc::new(Interrupt::new());
                let stopper = Arc::clone(&token);
                let h = std::thread::spawn(move || {
                    std::thread::sleep(std::time::Duration::from_millis(30));
                    stopper.stop();
                });
                let r = run_with(Some(token), || t.update(frame()));
                h.join().unwrap();
                r
            }
            // The calling thread's poll reports a signal at its first chance.
            false => run_polled(|| true, || t.update(frame())),
        };
        let err = stopped.unwrap_err();
        assert_eq!(err.class(), rperc_core::ErrorClass::Interrupted, "{err}");
        assert_eq!(bits(&t), before, "parallel {parallel}: the set changed");
        // The oracle: a twin that was never interrupted steps to the same answer.
        let mut twin = tracker_after_one_frame(n, parallel);
        let (a, b) = (t.update(frame()).unwrap(), twin.update(frame()).unwrap());
        assert_eq!(a, b, "parallel {parallel}");
        assert_eq!(bits(&t), bits(&twin), "parallel {parallel}");
    }
}
