//! The colour + template tracker against generated sequences whose truth is known by
//! construction (never against its own earlier output), and its refusals of bad input.

use proptest::prelude::*;
use rand::Rng;
use tracking::{BoundingBox, ColorTemplateParams, ColorTemplateTracker, RgbFrame, TrackingError};

const W: usize = 160;
const H: usize = 120;

/// A seeded textured target (`size` px square, at `(x, y)`) on a seeded textured
/// background; `hidden` paints the background over it (an occlusion).
struct Scene {
    background: Vec<u8>,
    texture: Vec<[u8; 3]>,
    tex_side: usize,
}

impl Scene {
    fn new(seed: u64) -> Self {
        let mut rng = rperc_core::rng::seeded(seed);
        let background = (0..W * H * 3).map(|_| rng.random_range(40..110)).collect();
        let tex_side = 4;
        let texture = (0..tex_side * tex_side)
            .map(|_| {
                [
                    rng.random_range(150..255),
                    rng.random_range(0..120),
                    rng.random_range(0..80),
                ]
            })
            .collect();
        Self {
            background,
            texture,
            tex_side,
        }
    }

    /// The frame with the target's texture scaled to `size` at `(x, y)`.
    fn frame(&self, x: f64, y: f64, size: f64, hidden: bool) -> Vec<u8> {
        let mut out = self.background.clone();
        if hidden {
            return out;
        }
        for py in 0..H {
            for px in 0..W {
                let (u, v) = ((px as f64 + 0.5 - x) / size, (py as f64 + 0.5 - y) / size);
                if (0.0..1.0).contains(&u) && (0.0..1.0).contains(&v) {
                    let t = self.texture[(v * self.tex_side as f64) as usize * self.tex_side
                        + (u * self.tex_side as f64) as usize];
                    out[(py * W + px) * 3..(py * W + px) * 3 + 3].copy_from_slice(&t);
                }
            }
        }
        out
    }
}

fn view(data: &[u8]) -> RgbFrame<'_> {
    RgbFrame::new(data, W, H).unwrap()
}

fn iou(a: BoundingBox, b: BoundingBox) -> f64 {
    let ix = ((a.x + a.w).min(b.x + b.w) - a.x.max(b.x)).max(0.0);
    let iy = ((a.y + a.h).min(b.y + b.h) - a.y.max(b.y)).max(0.0);
    let inter = ix * iy;
    inter / (a.w * a.h + b.w * b.h - inter)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(12))]

    /// A target moving at a constant seeded velocity stays overlapped by the box.
    #[test]
    fn follows_a_moving_target(seed in 0u64..1000, vx in -2.5f64..2.5, vy in -2.0f64..2.0) {
        let scene = Scene::new(seed);
        let (x0, y0, size) = (60.0, 40.0, 30.0);
        let first = scene.frame(x0, y0, size, false);
        let start = BoundingBox::new(x0, y0, size, size);
        let mut tracker = ColorTemplateTracker::new(view(&first), start, ColorTemplateParams::default()).unwrap();
        for k in 1..20 {
            let (x, y) = (x0 + vx * k as f64, y0 + vy * k as f64);
            let data = scene.frame(x, y, size, false);
            let r = tracker.update(view(&data)).unwrap();
            let truth = BoundingBox::new(x, y, size, size);
            prop_assert!(iou(r.bbox, truth) > 0.6, "frame {k}: {:?} vs {:?}", r.bbox, truth);
            prop_assert!(!r.lost);
        }
    }

    /// A target that grows by 1.5 % a frame (35 % over 20 frames): the box's scale
    /// follows the generator's within a tenth.
    #[test]
    fn follows_a_growing_target(seed in 0u64..1000) {
        let scene = Scene::new(seed);
        let (cx, cy, size0) = (80.0, 60.0, 30.0);
        let first = scene.frame(cx - size0 / 2.0, cy - size0 / 2.0, size0, false);
        let start = BoundingBox::new(cx - size0 / 2.0, cy - size0 / 2.0, size0, size0);
        let params = ColorTemplateParams::default();
        let mut tracker = ColorTemplateTracker::new(view(&first), start, params).unwrap();
        let mut size = size0;
        for _ in 1..20 {
            size *= 1.015;
            let data = scene.frame(cx - size / 2.0, cy - size / 2.0, size, false);
            tracker.update(view(&data)).unwrap();
        }
        let truth = size / size0;
        prop_assert!((tracker.scale() / truth - 1.0).abs() < 0.1, "{} vs {truth}", tracker.scale());
    }
}

/// Hidden for 10 frames, the target is reported lost, the box does not wander, and it
/// is found again (not lost, overlapping the truth) once it reappears.
#[test]
fn occlusion_is_lost_then_recovered() {
    let scene = Scene::new(7);
    let (x, y, size) = (60.0, 40.0, 30.0);
    let first = scene.frame(x, y, size, false);
    let truth = BoundingBox::new(x, y, size, size);
    let mut tracker =
        ColorTemplateTracker::new(view(&first), truth, ColorTemplateParams::default()).unwrap();
    for _ in 0..10 {
        assert!(!tracker.update(view(&first)).unwrap().lost);
    }
    let hidden = scene.frame(x, y, size, true);
    let flags: Vec<bool> = (0..10)
        .map(|_| tracker.update(view(&hidden)).unwrap().lost)
        .collect();
    assert!(flags.iter().filter(|&&l| l).count() >= 8, "{flags:?}");
    let back = scene.frame(x + 4.0, y, size, false);
    let r = tracker.update(view(&back)).unwrap();
    assert!(
        !r.lost && iou(r.bbox, BoundingBox::new(x + 4.0, y, size, size)) > 0.6,
        "{r:?}"
    );
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let scene = Scene::new(1);
    let data = scene.frame(60.0, 40.0, 30.0, false);
    let p = ColorTemplateParams::default;
    let bad_boxes = [
        BoundingBox::new(f64::NAN, 40.0, 30.0, 30.0),
        BoundingBox::new(60.0, 40.0, 0.0, 30.0),
        BoundingBox::new(150.0, 40.0, 30.0, 30.0),
        BoundingBox::new(-20.0, -20.0, 30.0, 30.0),
    ];
    for b in bad_boxes {
        assert!(
            ColorTemplateTracker::new(view(&data), b, p()).is_err(),
            "{b:?}"
        );
    }
    let start = BoundingBox::new(60.0, 40.0, 30.0, 30.0);
    let bad = ColorTemplateParams {
        lost_ratio: f64::NAN,
        ..p()
    };
    let err = ColorTemplateTracker::new(view(&data), start, bad)
        .err()
        .unwrap();
    assert_eq!(err.parameter(), Some("lost_ratio"));
    let mut tracker = ColorTemplateTracker::new(view(&data), start, p()).unwrap();
    let small = vec![0u8; 50 * 40 * 3];
    let err = tracker
        .update(RgbFrame::new(&small, 50, 40).unwrap())
        .unwrap_err();
    assert!(matches!(err, TrackingError::FrameSizeChanged { .. }));
    // A single-colour frame is not a crash either.
    let flat = vec![0u8; W * H * 3];
    tracker.update(view(&flat)).unwrap();
    // A one-pixel box at the frame's corner still makes a tracker.
    let tiny = BoundingBox::new(0.0, 0.0, 1.0, 1.0);
    let mut t = ColorTemplateTracker::new(view(&data), tiny, p()).unwrap();
    t.update(view(&data)).unwrap();
}

/// The frame with seeded sensor noise (+-20 grey levels a channel): a camera never
/// gives the same frame twice, and on identical frames the running level of the peak
/// would be the unreachable peak of a perfect match.
fn noisy(mut data: Vec<u8>, rng: &mut impl Rng) -> Vec<u8> {
    for v in &mut data {
        *v = (i32::from(*v) + rng.random_range(-20..=20)).clamp(0, 255) as u8;
    }
    data
}

/// Runs a tracker from `(x0, y0)` over 10 frames of a still target, then the target
/// jumps by `(dx, dy)` (about a search window: out of the filter's reach) and stays
/// there; the lost flags and IoUs with the truth of the `after` frames after the jump.
fn jump(
    seed: u64,
    (dx, dy): (f64, f64),
    params: ColorTemplateParams,
    after: usize,
) -> Vec<(bool, f64)> {
    let scene = Scene::new(seed);
    let mut rng = rperc_core::rng::seeded(seed + 1);
    let (x0, y0, size) = (68.0, 48.0, 24.0);
    let first = scene.frame(x0, y0, size, false);
    let start = BoundingBox::new(x0, y0, size, size);
    let mut tracker = ColorTemplateTracker::new(view(&first), start, params).unwrap();
    for _ in 0..10 {
        let data = noisy(first.clone(), &mut rng);
        tracker.update(view(&data)).unwrap();
    }
    let moved = scene.frame(x0 + dx, y0 + dy, size, false);
    let truth = BoundingBox::new(x0 + dx, y0 + dy, size, size);
    (0..after)
        .map(|_| {
            let data = noisy(moved.clone(), &mut rng);
            let r = tracker.update(view(&data)).unwrap();
            (r.lost, iou(r.bbox, truth))
        })
        .collect()
}

/// A target that jumps by a window's width is reported lost, then re-detected
/// (IoU > 0.5, not lost) by the wider search within the four frames after the jump,
/// a distant window being taken when, re-centred on its peak, it passes the lost rule
/// (`redetect_ratio` at `lost_ratio`: the rule alone). Without the search
/// (`redetect_radius` 0) it is not found in the first two: the jump is out of the
/// filter's own reach (following the peak, the box may creep over later). The default
/// `redetect_ratio` of 1 also asks for the peak's running level, which this jump
/// reaches only on some seeds (the guide says so).
///
/// Re-detection within four frames is a rate, not a rule: while lost the box follows
/// the last window's peak (`lost_motion` 1), and now and then that peak leads the 3 x 3
/// grid away from the target. A census of seeds 0..1000 in the four directions found
/// 40 of 4000 jumps not re-detected in time (1 %), so a random draw of 16 cases failed
/// about one run in seven (CI, 2026-11-29). The claim is checked over a fixed sample
/// instead: every jump is reported lost, none is found without the search, and at
/// least 45 of 48 are re-detected in time (each run only as long as its check reads).
#[test]
fn a_jump_is_lost_then_redetected_in_most_cases() {
    let params = ColorTemplateParams {
        redetect_ratio: 0.6,
        ..Default::default()
    };
    let blind = ColorTemplateParams {
        redetect_radius: 0,
        ..params.clone()
    };
    let mut in_time = 0;
    for seed in 0..12u64 {
        for step in [(-40.0, 0.0), (40.0, 0.0), (0.0, -38.0), (0.0, 38.0)] {
            let steps = jump(seed, step, params.clone(), 4);
            assert!(
                steps[0].0,
                "seed {seed}: the jump is not reported lost: {steps:?}"
            );
            let found = steps
                .iter()
                .position(|&(lost, overlap)| !lost && overlap > 0.5);
            in_time += usize::from(found.is_some_and(|k| k <= 3));
            let without = jump(seed, step, blind.clone(), 2);
            let seen = without.iter().any(|&(_, overlap)| overlap >= 0.5);
            assert!(!seen, "seed {seed}: found without the search: {without:?}");
        }
    }
    assert!(
        in_time >= 45,
        "re-detected in time in {in_time} of 48 jumps"
    );
}
