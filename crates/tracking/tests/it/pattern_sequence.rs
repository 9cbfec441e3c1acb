//! The Fig. 8 sequence generator (section 4.1) against closed forms: a linear-ramp
//! patch (exact under bilinear interpolation) located through the tracker's `place`,
//! which is itself checked against OpenCV's `getRotationMatrix2D`.

use nalgebra::SVector;
use rperc_core::image::{GrayImage, GrayView};
use tracking::pattern::place;
use tracking::{
    PatternFrame, PatternTracker, PatternTrackerParams, Region, SequenceParams, generate_sequence,
};

const PW: usize = 40;
const PH: usize = 30;

/// `g = 40 + 2 x + 3 y` in patch pixels: bilinear interpolation reproduces it exactly.
fn ramp(x: f64, y: f64) -> f64 {
    40.0 + 2.0 * x + 3.0 * y
}

fn ramp_patch() -> GrayImage {
    let mut img = GrayImage::zeros(PW, PH);
    for y in 0..PH {
        for x in 0..PW {
            img.data[y * PW + x] = ramp(x as f64, y as f64) as f32;
        }
    }
    img
}

fn flat(width: usize, height: usize, g: f32) -> GrayImage {
    GrayImage {
        data: vec![g; width * height],
        width,
        height,
    }
}

fn small(n_frames: usize) -> SequenceParams {
    SequenceParams {
        n_frames,
        width: 160,
        height: 120,
        noise: 0.0,
        background_speed: 0.0,
        ..SequenceParams::default()
    }
}

/// Frame `k` of a generated sequence as the tracker reads it, and the sequence's
/// region.
fn tracker_input<'a>(
    seq: &'a tracking::PatternSequence,
    params: &SequenceParams,
    k: usize,
) -> (PatternFrame<'a>, Region) {
    let n = params.width * params.height;
    let data = &seq.frames[k * n..(k + 1) * n];
    let view = GrayView::new(data, params.width, params.height).unwrap();
    let [x, y, w, h] = seq.region;
    (PatternFrame::Gray(view), Region::Box { x, y, w, h })
}

fn frame(seq: &tracking::PatternSequence, params: &SequenceParams, k: usize) -> GrayImage {
    let n = params.width * params.height;
    let view = GrayView::new(&seq.frames[k * n..(k + 1) * n], params.width, params.height);
    let mut img = GrayImage::default();
    img.set_from_gray(&view.unwrap());
    img
}

#[test]
fn frame_zero_shows_the_patch_on_its_region() {
    let params = small(1);
    let seq = generate_sequence(&ramp_patch(), &flat(50, 50, 250.0), &params).unwrap();
    let [x0, y0, w, h] = seq.region;
    assert_eq!((w, h), (PW, PH));
    let f = frame(&seq, &params, 0);
    for y in 0..h {
        for x in 0..w {
            assert_eq!(f64::from(f.at(x0 + x, y0 + y)), ramp(x as f64, y as f64));
        }
    }
    assert_eq!(f.at(x0 - 1, y0), 250.0);
    let c = [
        x0 as f64 + 0.5 * (w as f64 - 1.0),
        y0 as f64 + 0.5 * (h as f64 - 1.0),
    ];
    assert_eq!(seq.truth[0], [c[0], c[1], 0.0, 1.0]);
}

#[test]
fn patch_points_land_where_place_puts_them_with_the_illumination() {
    let params = SequenceParams {
        gain: [0.7, 1.3],
        offset: [-20.0, 20.0],
        max_step_sigmas: 3.0,
        ..small(12)
    };
    let seq = generate_sequence(&ramp_patch(), &flat(50, 50, 0.0), &params).unwrap();
    let c = [0.5 * (PW as f64 - 1.0), 0.5 * (PH as f64 - 1.0)];
    for k in 0..params.n_frames {
        let f = frame(&seq, &params, k);
        let state = SVector::from(seq.truth[k]);
        let [gain, offset] = seq.illumination[k];
        // Interior patch points (two pixels from its edge, so bilinear frame samples
        // stay on the patch).
        for py in (3..PH - 3).step_by(4) {
            for px in (3..PW - 3).step_by(5) {
                let (p, _) = place(&state, [px as f64 - c[0], py as f64 - c[1]], 0.0);
                let got = f64::from(f.sample_bilinear(p[0], p[1]).unwrap());
                let want = gain * ramp(px as f64, py as f64) + offset;
                // Rounding to 8 bits, plus clipping of the ramp's brightest end.
                if want < 254.0 {
                    assert!((got - want).abs() <= 0.51, "frame {k}: {got} vs {want}");
                }
            }
        }
    }
}

#[test]
fn steps_sweep_up_to_k_sigma_per_component() {
    let params = SequenceParams {
        width: 400,
        height: 400,
        ..small(300)
    };
    let seq = generate_sequence(&ramp_patch(), &flat(50, 50, 0.0), &params).unwrap();
    let mut largest = [0.0f64; 4];
    for (k, pair) in seq.truth.windows(2).enumerate() {
        for d in 0..4 {
            let r = (pair[1][d] - pair[0][d]).abs() / params.sigma[d];
            // Frame k + 1 sweeps component k mod 4.
            let bound = if d == k % 4 {
                params.max_step_sigmas
            } else {
                params.other_step_sigmas
            };
            assert!(r <= bound + 1e-9, "component {d}: {r} sigma");
            if d == k % 4 {
                largest[d] = largest[d].max(r);
            }
        }
    }
    let k = params.max_step_sigmas;
    println!("largest steps in sigma: {largest:?}");
    assert!(largest.iter().all(|&r| r > 0.9 * k));
    let [lo, hi] = params.scale_range;
    assert!(seq.truth.iter().all(|t| (lo..=hi).contains(&t[3])));
}

#[test]
fn the_occluder_hides_the_reported_fraction_of_the_patch() {
    let params = SequenceParams {
        max_occlusion: 0.4,
        max_step_sigmas: 1.0,
        ..small(10)
    };
    // Patch at 100, background at 250: a footprint pixel showing 250 is occluded.
    let seq = generate_sequence(&flat(PW, PH, 100.0), &flat(50, 50, 250.0), &params).unwrap();
    let c = [0.5 * (PW as f64 - 1.0), 0.5 * (PH as f64 - 1.0)];
    for k in 1..params.n_frames {
        let f = frame(&seq, &params, k);
        let state = SVector::from(seq.truth[k]);
        // Sample the patch densely through `place` and count the hidden samples.
        let (mut hidden, mut total) = (0usize, 0usize);
        for j in 0..4 * PH {
            for i in 0..4 * PW {
                // Over the patch's pixel area [-0.5, w - 0.5) x [-0.5, h - 0.5).
                let q = [(i as f64 + 0.5) / 4.0 - 0.5, (j as f64 + 0.5) / 4.0 - 0.5];
                let (p, _) = place(&state, [q[0] - c[0], q[1] - c[1]], 0.0);
                let g = f.at(p[0].round() as usize, p[1].round() as usize);
                total += 1;
                hidden += usize::from(g > 175.0);
            }
        }
        let measured = hidden as f64 / total as f64;
        println!(
            "frame {k}: reported {:.3}, measured {measured:.3}",
            seq.occlusion[k]
        );
        assert!((measured - seq.occlusion[k]).abs() < 0.05);
    }
}

/// A flat patch covers `s^2 w h` frame pixels at scale `s` (closed form: the area of
/// its `w x h` pixels scaled by `s`), as frame 0 covers its `w x h` region exactly:
/// each frame up to the pixel grid's quantisation (at most a pixel along the
/// perimeter), on average over the frames within 1 %. Cut at its outer pixel centres
/// it covered `s^2 (w - 1)(h - 1)`, 6 % less here: its border sat half a pixel inside,
/// and trackers read a scale about 1/w too small.
#[test]
fn a_scaled_patch_covers_its_pixels_area_scaled() {
    let params = SequenceParams {
        width: 200,
        height: 160,
        max_step_sigmas: 2.0,
        other_step_sigmas: 1.0,
        ..small(24)
    };
    // Patch at 100, background at 250.
    let seq = generate_sequence(&flat(PW, PH, 100.0), &flat(50, 50, 250.0), &params).unwrap();
    let mut ratios = 0.0;
    for k in 0..params.n_frames {
        let f = frame(&seq, &params, k);
        let covered = f.data.iter().filter(|&&g| g < 175.0).count() as f64;
        let s = seq.truth[k][3];
        let area = s * s * (PW * PH) as f64;
        let perimeter = 2.0 * s * (PW + PH) as f64;
        println!("frame {k}: scale {s:.3}, {covered} pixels, area {area:.1}");
        assert!((covered - area).abs() <= perimeter, "frame {k}");
        ratios += covered / area;
    }
    let mean = ratios / params.n_frames as f64;
    assert!((mean - 1.0).abs() < 0.01, "mean covered / area {mean}");
}

#[test]
fn bad_parameters_are_refused_by_name() {
    let (p, b) = (ramp_patch(), flat(50, 50, 0.0));
    let name = |params: SequenceParams| generate_sequence(&p, &b, &params).unwrap_err().parameter();
    assert_eq!(
        name(SequenceParams {
            n_frames: 0,
            ..small(1)
        }),
        Some("n_frames")
    );
    assert_eq!(
        name(SequenceParams {
            max_occlusion: 1.5,
            ..small(1)
        }),
        Some("max_occlusion")
    );
    assert_eq!(
        name(SequenceParams {
            sigma: [f64::NAN, 5.0, 0.05, 0.1],
            ..small(1)
        }),
        Some("sigma")
    );
    assert_eq!(
        name(SequenceParams {
            gain: [1.2, 1.1],
            ..small(1)
        }),
        Some("gain")
    );
    assert_eq!(
        name(SequenceParams {
            width: 30,
            ..small(1)
        }),
        Some("patch")
    );
    let empty = GrayImage::default();
    assert_eq!(
        generate_sequence(&empty, &b, &small(1))
            .unwrap_err()
            .parameter(),
        Some("patch")
    );
    assert_eq!(
        generate_sequence(&p, &empty, &small(1))
            .unwrap_err()
            .parameter(),
        Some("background")
    );
}

#[test]
fn the_same_seed_gives_the_same_sequence() {
    let (p, b) = (ramp_patch(), flat(50, 50, 0.0));
    let params = SequenceParams {
        noise: 3.0,
        max_occlusion: 0.3,
        ..small(3)
    };
    let a = generate_sequence(&p, &b, &params).unwrap();
    assert_eq!(a, generate_sequence(&p, &b, &params).unwrap());
    let other = SequenceParams { seed: 1, ..params };
    assert_ne!(a.truth, generate_sequence(&p, &b, &other).unwrap().truth);
}

/// A textured patch (rectangles, a disc, a bar) and a cluttered background.
fn scene() -> (GrayImage, GrayImage) {
    let mut patch = GrayImage::zeros(64, 52);
    for y in 0..52 {
        for x in 0..64 {
            let (xf, yf) = (x as f64, y as f64);
            let mut g = 60.0;
            if (8..=26).contains(&x) && (6..=22).contains(&y) {
                g = 200.0;
            }
            if (34..=56).contains(&x) && (30..=44).contains(&y) {
                g = 150.0;
            }
            if (xf - 18.0).hypot(yf - 37.0) <= 9.0 {
                g = 230.0;
            }
            if (40..=44).contains(&x) && (4..=24).contains(&y) {
                g = 20.0;
            }
            patch.data[y * 64 + x] = g;
        }
    }
    let mut bg = GrayImage::zeros(256, 256);
    for y in 0..256 {
        for x in 0..256 {
            let (xf, yf) = (x as f64, y as f64);
            let mut g = 120.0 + 30.0 * (0.07 * xf + 0.03 * yf).sin();
            if (x / 23 + y / 31) % 3 == 0 {
                g += 40.0;
            }
            bg.data[y * 256 + x] = g as f32;
        }
    }
    (patch, bg)
}

/// RMS errors (position px, angle deg, relative scale) of the default tracker on a
/// generated sequence: steps up to 3 sigma, up to 30 % occlusion, gain 0.8-1.2, offset
/// +-20, noise 2; panics if a frame is lost.
fn three_sigma_run() -> [f64; 3] {
    let (patch, bg) = scene();
    let params = SequenceParams {
        n_frames: 16,
        width: 260,
        height: 220,
        max_step_sigmas: 3.0,
        max_occlusion: 0.3,
        gain: [0.8, 1.2],
        offset: [-20.0, 20.0],
        noise: 2.0,
        background_speed: 2.0,
        seed: 5,
        ..SequenceParams::default()
    };
    let seq = generate_sequence(&patch, &bg, &params).unwrap();
    let view = |k: usize| tracker_input(&seq, &params, k).0;
    let region = tracker_input(&seq, &params, 0).1;
    let mut tracker =
        PatternTracker::new(view(0), region, PatternTrackerParams::default(), 2).unwrap();
    let mut sq = [0.0; 3];
    for k in 1..params.n_frames {
        let pose = tracker.update(view(k)).unwrap();
        assert!(
            !pose.lost,
            "frame {k} lost at occlusion {:.2}",
            seq.occlusion[k]
        );
        let (e, t) = (pose.state, seq.truth[k]);
        sq[0] += (e[0] - t[0]).powi(2) + (e[1] - t[1]).powi(2);
        sq[1] += (e[2] - t[2]).to_degrees().powi(2);
        sq[2] += (e[3] / t[3] - 1.0).powi(2);
    }
    let rms = sq.map(|s| (s / (params.n_frames - 1) as f64).sqrt());
    println!(
        "RMS: {:.3} px, {:.3} deg, {:.2} %",
        rms[0],
        rms[1],
        100.0 * rms[2]
    );
    rms
}

#[test]
fn the_tracker_keeps_a_generated_sequence_within_three_sigma_at_30_percent_occlusion() {
    // The goals: no loss at 30 % occlusion, position below 1 px RMS.
    let [pos, _, _] = three_sigma_run();
    assert!(pos < 1.0, "position RMS {pos}");
}

/// The issue's angle and scale goals (section 4.1's "accurate inside [-3 sigma, +3
/// sigma]"). This sequence (seed 5) was never used to choose a default.
#[test]
fn the_tracker_meets_the_angle_and_scale_goals_within_three_sigma() {
    let [_, ang, scale] = three_sigma_run();
    assert!(ang < 1.0 && scale < 0.02, "{ang} deg, {scale}");
}

/// Steps of 2.5-3 sigma (the frames of a sequence swept to 3 sigma whose swept step
/// is that large; the others carry the track): each one caught within 2 px of the
/// generator's truth, with the second look (the default); a single iteration a
/// frame missed 1 of these 20 when this was written (printed, not asserted). Seeds
/// 101-103 were not used to choose anything.
#[test]
fn steps_near_three_sigma_are_caught() {
    let (patch, bg) = scene();
    let mut misses = vec![];
    for seed in [101, 102, 103] {
        let params = SequenceParams {
            n_frames: 40,
            width: 260,
            height: 220,
            max_step_sigmas: 3.0,
            seed,
            ..SequenceParams::default()
        };
        let seq = generate_sequence(&patch, &bg, &params).unwrap();
        let view = |k: usize| tracker_input(&seq, &params, k).0;
        let region = tracker_input(&seq, &params, 0).1;
        for second_look in [0.9, 0.0] {
            let tracker_params = PatternTrackerParams {
                second_look,
                ..PatternTrackerParams::default()
            };
            let mut tracker =
                PatternTracker::new(view(0), region.clone(), tracker_params, 1).unwrap();
            let (mut big, mut missed) = (0, 0);
            for k in 1..params.n_frames {
                let pose = tracker.update(view(k)).unwrap();
                let (e, t, before) = (pose.state, seq.truth[k], seq.truth[k - 1]);
                let d = (k - 1) % 4;
                if ((t[d] - before[d]) / params.sigma[d]).abs() >= 2.5 {
                    big += 1;
                    missed += usize::from((e[0] - t[0]).hypot(e[1] - t[1]) > 2.0);
                }
            }
            println!("seed {seed}, second look {second_look}: {missed} of {big} missed");
            if second_look > 0.0 {
                misses.push(missed);
            }
        }
    }
    assert!(misses.iter().all(|&m| m == 0), "{misses:?}");
}

/// The shared data folder (`RPERC_DATA`, else `../shared/data` beside the
/// repository), if present.
fn data_dir() -> Option<std::path::PathBuf> {
    let dir = match std::env::var_os("RPERC_DATA") {
        Some(d) => std::path::PathBuf::from(d),
        None => std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"),
    };
    dir.is_dir().then_some(dir)
}

/// A grey image of the data folder's `images/`, columns `x0..x0 + w` and rows `y0..y0
/// + h` of it (the whole image for `None`).
fn data_image(dir: &std::path::Path, name: &str, crop: Option<[u32; 4]>) -> GrayImage {
    let img = image::open(dir.join("images").join(name))
        .unwrap()
        .to_luma8();
    let [x0, y0, w, h] = crop.unwrap_or([0, 0, img.width(), img.height()]);
    let mut out = GrayImage::zeros(w as usize, h as usize);
    for y in 0..h {
        for x in 0..w {
            out.data[(y * w + x) as usize] = f32::from(img.get_pixel(x0 + x, y0 + y)[0]);
        }
    }
    out
}

/// Issue 35: steps drawn up to 3 sigma in all four parameters at once (not one at a
/// time), with noise and a moving background: a 100 x 100 patch of the photograph
/// `camera.png` over `grass.png`, 640 x 480, as `rperc bench pattern` draws them.
/// The seed's 200 particles strayed by more than 5 px on most such sequences; with
/// the coarse layer the track keeps the goals (RMS within 1.5 px, 1.5
/// degrees and 3 %, never lost) against the generator's truth. Seed 17 was never used
/// to choose a default (they were chosen on seeds 0-9).
#[test]
fn full_three_sigma_steps_in_every_parameter_stay_within_the_goals() {
    let Some(dir) = data_dir() else {
        eprintln!("skipped: shared data not found (set RPERC_DATA)");
        return;
    };
    let patch = data_image(&dir, "camera.png", Some([200, 60, 100, 100]));
    let bg = data_image(&dir, "grass.png", None);
    let params = SequenceParams {
        n_frames: 40,
        width: 640,
        height: 480,
        max_step_sigmas: 3.0,
        other_step_sigmas: 3.0,
        seed: 17,
        ..SequenceParams::default()
    };
    let seq = generate_sequence(&patch, &bg, &params).unwrap();
    let view = |k: usize| tracker_input(&seq, &params, k).0;
    let region = tracker_input(&seq, &params, 0).1;
    let mut tracker =
        PatternTracker::new(view(0), region, PatternTrackerParams::default(), 4).unwrap();
    let mut sq = [0.0; 3];
    for k in 1..params.n_frames {
        let pose = tracker.update(view(k)).unwrap();
        assert!(!pose.lost, "frame {k} lost");
        let (e, t) = (pose.state, seq.truth[k]);
        sq[0] += (e[0] - t[0]).powi(2) + (e[1] - t[1]).powi(2);
        sq[1] += (e[2] - t[2]).to_degrees().powi(2);
        sq[2] += (e[3] / t[3] - 1.0).powi(2);
    }
    let [pos, ang, scale] = sq.map(|s| (s / (params.n_frames - 1) as f64).sqrt());
    println!("RMS: {pos:.3} px, {ang:.3} deg, {:.2} %", 100.0 * scale);
    assert!(
        pos <= 1.5 && ang <= 1.5 && scale <= 0.03,
        "{pos} px, {ang} deg, {scale}"
    );
}
