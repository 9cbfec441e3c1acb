//! The pattern model and observation model of Ait Aider et al., sections 3.2-3.3,
//! against synthetic patterns whose edges and pose are known by construction.

use nalgebra::SVector;
use proptest::prelude::*;
use rand::Rng;
use rperc_core::image::GrayImage;
use rperc_core::rng::{normal, seeded};
use tracking::pattern::{DeviationModel, PatternScratch, place};

use tracking::{PatternConfig, PatternLikelihood, PatternModel, Region, ScaleSpace};

/// A filled rectangle of inclusive pixel columns `x0..=x1`, rows `y0..=y1`.
struct Rect(usize, usize, usize, usize, f32);
/// A disc of centre `(cx, cy)` and radius `r`.
struct Disc(f64, f64, f64, f32);

const RECTS: [Rect; 2] = [Rect(25, 35, 52, 62, 180.0), Rect(25, 82, 80, 96, 220.0)];
const DISC: Disc = Disc(85.0, 48.0, 17.0, 40.0);
const SIZE: usize = 130;
const WINDOW: Region = Region::Box {
    x: 15,
    y: 25,
    w: 98,
    h: 80,
};

fn clean_pattern() -> GrayImage {
    let mut img = GrayImage::zeros(SIZE, SIZE);
    for y in 0..SIZE {
        for x in 0..SIZE {
            let mut g = 100.0;
            for r in &RECTS {
                if (r.0..=r.2).contains(&x) && (r.1..=r.3).contains(&y) {
                    g = r.4;
                }
            }
            if (x as f64 - DISC.0).hypot(y as f64 - DISC.1) <= DISC.2 {
                g = DISC.3;
            }
            img.data[y * SIZE + x] = g;
        }
    }
    img
}

fn add_noise(img: &mut GrayImage, sigma: f64, seed: u64) {
    let mut rng = seeded(seed);
    for g in &mut img.data {
        *g += (sigma * normal(&mut rng)) as f32;
    }
}

/// Distance from `p` to the nearest true edge, the edge normal there (radians) and
/// whether `p` is within 3 px of a rectangle corner (where the normal is undefined).
fn nearest_edge(p: [f64; 2]) -> (f64, f64, bool) {
    let mut best = (f64::INFINITY, 0.0, false);
    for r in &RECTS {
        let (a, b, c, d) = (
            r.0 as f64 - 0.5,
            r.2 as f64 + 0.5,
            r.1 as f64 - 0.5,
            r.3 as f64 + 0.5,
        );
        let dists = [
            (p[0] - a).abs(),
            (p[0] - b).abs(),
            (p[1] - c).abs(),
            (p[1] - d).abs(),
        ];
        let dx = (a - p[0]).max(p[0] - b).max(0.0);
        let dy = (c - p[1]).max(p[1] - d).max(0.0);
        let inside = dx == 0.0 && dy == 0.0;
        let (dist, normal) = if inside {
            let k = (0..4)
                .min_by(|&i, &j| dists[i].total_cmp(&dists[j]))
                .unwrap();
            (
                dists[k],
                if k < 2 {
                    0.0
                } else {
                    std::f64::consts::FRAC_PI_2
                },
            )
        } else {
            (
                dx.hypot(dy),
                if dx > dy {
                    0.0
                } else {
                    std::f64::consts::FRAC_PI_2
                },
            )
        };
        let corner = [(a, c), (a, d), (b, c), (b, d)]
            .iter()
            .any(|q| (p[0] - q.0).hypot(p[1] - q.1) < 3.0);
        if dist < best.0 {
            best = (dist, normal, corner);
        }
    }
    let radial = (p[0] - DISC.0).hypot(p[1] - DISC.1);
    if (radial - DISC.2).abs() < best.0 {
        best = (
            (radial - DISC.2).abs(),
            (p[1] - DISC.1).atan2(p[0] - DISC.0),
            false,
        );
    }
    best
}

/// Angle between two undirected lines, degrees.
fn line_angle_deg(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(std::f64::consts::PI);
    d.min(std::f64::consts::PI - d).to_degrees()
}

fn model() -> PatternModel {
    let mut reference = clean_pattern();
    add_noise(&mut reference, 3.0, 1);
    PatternModel::from_region(&reference, WINDOW, &PatternConfig::default()).unwrap()
}

#[test]
fn model_points_lie_on_the_drawn_edges_with_normal_gradients() {
    let m = model();
    assert!(m.points.len() >= 40, "only {} points", m.points.len());
    let (mut worst_d, mut worst_a) = (0.0f64, 0.0f64);
    for (j, p) in m.points.iter().enumerate() {
        let o = m.offset(j);
        let (d, normal, corner) = nearest_edge([m.centre[0] + o[0], m.centre[1] + o[1]]);
        worst_d = worst_d.max(d);
        if !corner {
            worst_a = worst_a.max(line_angle_deg(p.phi, normal));
        }
        assert!(p.slope < 0.0);
    }
    println!(
        "{} points, worst edge distance {worst_d:.3} px, worst angle {worst_a:.2} deg",
        m.points.len()
    );
    assert!(worst_d < 1.5, "edge distance {worst_d}");
    assert!(worst_a < 15.0, "normal angle {worst_a}");
}

/// The pattern warped by the similarity of `state` (bilinear, the inverse map of
/// `x' = t + s R(theta) (x - c)` with `R = [[c, s], [-s, c]]`) over a flat background.
fn render(state: [f64; 4], centre: [f64; 2], size: usize) -> GrayImage {
    let reference = clean_pattern();
    let mut out = GrayImage::zeros(size, size);
    let (sn, cs) = state[2].sin_cos();
    for y in 0..size {
        for x in 0..size {
            let q = [
                (x as f64 - state[0]) / state[3],
                (y as f64 - state[1]) / state[3],
            ];
            // R^T q.
            let src = [
                centre[0] + cs * q[0] - sn * q[1],
                centre[1] + sn * q[0] + cs * q[1],
            ];
            out.data[y * size + x] = reference.sample_bilinear(src[0], src[1]).unwrap_or(100.0);
        }
    }
    out
}

const TRUTH: [f64; 4] = [85.0, 82.0, 0.14, 1.1];
const FRAME: usize = 170;

/// The grid state of largest log-likelihood around the truth: +-2 px by 0.5, +-4 deg
/// by 1 deg, +-0.06 by 0.02.
fn grid_argmax(model: &PatternModel, frame: &GrayImage) -> ([f64; 4], f64) {
    let mut space = ScaleSpace::new();
    space.build(frame, model).unwrap();
    let lik = PatternLikelihood::new(model, &space);
    let mut scratch = PatternScratch::default();
    let mut best = ([0.0; 4], f64::NEG_INFINITY);
    for i in -4..=4 {
        for k in -4..=4 {
            for a in -4..=4 {
                for s in -3..=3 {
                    let st = [
                        TRUTH[0] + 0.5 * f64::from(i),
                        TRUTH[1] + 0.5 * f64::from(k),
                        TRUTH[2] + f64::from(a).to_radians(),
                        TRUTH[3] + 0.02 * f64::from(s),
                    ];
                    let ll = lik.observe(&SVector::from(st), &mut scratch).log_likelihood;
                    if ll > best.1 {
                        best = (st, ll);
                    }
                }
            }
        }
    }
    best
}

fn assert_near_truth(best: [f64; 4]) {
    println!("argmax {best:?}, truth {TRUTH:?}");
    assert!((best[0] - TRUTH[0]).abs() <= 1.0 && (best[1] - TRUTH[1]).abs() <= 1.0);
    assert!((best[2] - TRUTH[2]).to_degrees().abs() <= 1.0 + 1e-9);
    assert!((best[3] - TRUTH[3]).abs() <= 0.02 + 1e-9);
}

#[test]
fn likelihood_is_maximal_at_the_true_pose() {
    let m = model();
    let mut frame = render(TRUTH, m.centre, FRAME);
    add_noise(&mut frame, 3.0, 2);
    let (best, _) = grid_argmax(&m, &frame);
    assert_near_truth(best);
}

#[test]
fn occluded_pattern_keeps_its_maximum_and_reports_the_occluded_fraction() {
    let m = model();
    let mut frame = render(TRUTH, m.centre, FRAME);
    add_noise(&mut frame, 3.0, 3);
    let truth = SVector::from(TRUTH);
    // The disc (about 30 % of the contour length) and a margin wider than half a
    // grey-level vector are overwritten by uniform noise; the rectangles stay clean.
    let (sn, cs) = TRUTH[2].sin_cos();
    let mut rng = seeded(4);
    for y in 0..FRAME {
        for x in 0..FRAME {
            let q = [
                (x as f64 - TRUTH[0]) / TRUTH[3],
                (y as f64 - TRUTH[1]) / TRUTH[3],
            ];
            let src = [
                m.centre[0] + cs * q[0] - sn * q[1],
                m.centre[1] + sn * q[0] + cs * q[1],
            ];
            if (src[0] - DISC.0).hypot(src[1] - DISC.1) < DISC.2 + 7.0 {
                frame.data[y * FRAME + x] = rng.random_range(0.0..255.0);
            }
        }
    }
    // Oracle: the occluded points are those on the disc's edge.
    let on_disc = |j: usize| {
        let o = m.offset(j);
        (m.centre[0] + o[0] - DISC.0).hypot(m.centre[1] + o[1] - DISC.1) < DISC.2 + 2.0
    };
    let n = m.points.len();
    let expected = (0..n).filter(|&j| on_disc(j)).count() as f64 / n as f64;
    let mut space = ScaleSpace::new();
    space.build(&frame, &m).unwrap();
    let obs = PatternLikelihood::new(&m, &space).observe(&truth, &mut PatternScratch::default());
    println!(
        "occluded fraction {:.3}, expected {expected:.3}",
        obs.occluded_fraction
    );
    assert!((0.25..=0.4).contains(&expected));
    assert!((obs.occluded_fraction - expected).abs() < 0.06);
    let (best, _) = grid_argmax(&m, &frame);
    assert_near_truth(best);
}

#[test]
fn rotation_follows_opencv_get_rotation_matrix_2d() {
    // getRotationMatrix2D(center, angle, scale): alpha = s cos, beta = s sin,
    // M = [[alpha, beta, (1 - alpha) cx - beta cy], [-beta, alpha, beta cx + (1 - alpha) cy]].
    let (c, theta, s) = ([40.0, 30.0], 0.7, 1.3);
    let (alpha, beta) = (s * f64::cos(theta), s * f64::sin(theta));
    let offset = [5.0, -3.0];
    let p = [c[0] + offset[0], c[1] + offset[1]];
    let mx = alpha * p[0] + beta * p[1] + (1.0 - alpha) * c[0] - beta * c[1];
    let my = -beta * p[0] + alpha * p[1] + beta * c[0] + (1.0 - alpha) * c[1];
    let (q, _) = place(&SVector::from([c[0], c[1], theta, s]), offset, 0.0);
    assert!((q[0] - mx).abs() < 1e-12 && (q[1] - my).abs() < 1e-12);
    // A quarter turn counter-clockwise on screen (y down) takes "right" to "up".
    let (q, phi) = place(
        &SVector::from([0.0, 0.0, std::f64::consts::FRAC_PI_2, 1.0]),
        [1.0, 0.0],
        0.0,
    );
    assert!(q[0].abs() < 1e-12 && (q[1] + 1.0).abs() < 1e-12);
    assert!((phi + std::f64::consts::FRAC_PI_2).abs() < 1e-12);
}

fn region_error(image: &GrayImage, region: Region) -> Option<&'static str> {
    PatternModel::from_region(image, region, &PatternConfig::default())
        .unwrap_err()
        .parameter()
}

#[test]
fn bad_regions_are_refused_by_name() {
    let mut flat = GrayImage::zeros(60, 60);
    flat.data.iter_mut().for_each(|g| *g = 120.0);
    add_noise(&mut flat, 1.0, 5);
    assert_eq!(
        region_error(
            &flat,
            Region::Box {
                x: 5,
                y: 5,
                w: 40,
                h: 40
            }
        ),
        Some("region")
    );
    let pattern = clean_pattern();
    assert_eq!(
        region_error(
            &pattern,
            Region::Box {
                x: 100,
                y: 10,
                w: 40,
                h: 40
            }
        ),
        Some("region")
    );
    assert_eq!(
        region_error(
            &pattern,
            Region::Box {
                x: 10,
                y: 10,
                w: 0,
                h: 40
            }
        ),
        Some("region")
    );
    assert_eq!(
        region_error(
            &pattern,
            Region::Box {
                x: 10,
                y: 10,
                w: 3,
                h: 3
            }
        ),
        Some("region")
    );
    assert_eq!(
        region_error(&pattern, Region::Mask(vec![false; SIZE * SIZE])),
        Some("region")
    );
    assert_eq!(
        region_error(&pattern, Region::Mask(vec![true; 10])),
        Some("region")
    );
    let mut mask = vec![false; SIZE * SIZE];
    for y in 25..105 {
        for x in 15..113 {
            mask[y * SIZE + x] = true;
        }
    }
    assert!(
        PatternModel::from_region(&pattern, Region::Mask(mask), &PatternConfig::default()).is_ok()
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(12))]
    #[test]
    fn likelihood_ignores_gain_and_offset(gain in 0.3f32..3.0, offset in -60.0f32..60.0, dx in -2.0f64..2.0) {
        let m = model();
        let mut frame = render(TRUTH, m.centre, FRAME);
        add_noise(&mut frame, 3.0, 6);
        let mut changed = frame.clone();
        changed.data.iter_mut().for_each(|g| *g = gain * *g + offset);
        let state = SVector::from([TRUTH[0] + dx, TRUTH[1], TRUTH[2], TRUTH[3]]);
        let ll = |img: &GrayImage| {
            let mut space = ScaleSpace::new();
            space.build(img, &m).unwrap();
            PatternLikelihood::new(&m, &space).observe(&state, &mut PatternScratch::default())
        };
        let (a, b) = (ll(&frame), ll(&changed));
        prop_assert!((a.log_likelihood - b.log_likelihood).abs() < 1e-3 * (1.0 + a.log_likelihood.abs()));
        prop_assert_eq!(a.occluded_fraction, b.occluded_fraction);
    }
}

#[test]
fn scale_space_picks_the_nearest_level_blurred_by_blur_sigma_times_s() {
    let m = model();
    let frame = render(TRUTH, m.centre, FRAME);
    let mut space = ScaleSpace::new();
    space.build(&frame, &m).unwrap();
    assert_eq!(space.len(), m.config.scale_levels.len());
    let (mut scratch, mut direct) = (GrayImage::default(), GrayImage::default());
    // 1.3 is nearest to the 1.25 level; 0.7 uses the first level (scale 1).
    for (s, level) in [(1.3, 1.25), (0.7, 1.0), (2.9, 3.0)] {
        frame
            .gaussian_blur(m.config.blur_sigma * level, &mut scratch, &mut direct)
            .unwrap();
        assert_eq!(space.level(s), &direct, "scale {s}");
    }
}

#[test]
fn particle_filter_weighs_particles_with_the_pattern_likelihood() {
    use nalgebra::{SMatrix, Vector4};
    use tracking::{FilterParams, Likelihood, LinearGaussian, ParticleFilter};
    let m = model();
    let mut frame = render(TRUTH, m.centre, FRAME);
    add_noise(&mut frame, 3.0, 7);
    let mut space = ScaleSpace::new();
    space.build(&frame, &m).unwrap();
    let lik = PatternLikelihood::new(&m, &space);
    // Section 4.1's evolution noise: 5 px, 5 px, 3 deg, 0.1.
    let sigma = Vector4::new(5.0, 5.0, 3f64.to_radians(), 0.1);
    let prior = Vector4::new(
        TRUTH[0] + 4.0,
        TRUTH[1] - 3.0,
        TRUTH[2] + 0.05,
        TRUTH[3] + 0.08,
    );
    let cov = SMatrix::from_diagonal(&sigma.component_mul(&sigma));
    let params = FilterParams::default();
    let mut pf = ParticleFilter::new(
        400,
        prior,
        cov,
        LinearGaussian::random_walk(sigma),
        params,
        9,
    )
    .unwrap();
    let report = pf.step(&lik);
    assert!(!report.lost);
    // Log-weights are the pattern log-likelihoods up to one constant.
    let mut scratch = lik.new_scratch();
    let offsets: Vec<f64> = pf
        .particles()
        .iter()
        .zip(pf.log_weights())
        .map(|(p, lw)| lw - lik.observe(p, &mut scratch).log_likelihood)
        .filter(|d| d.is_finite())
        .collect();
    let spread = offsets
        .iter()
        .fold(0.0f64, |a, d| a.max((d - offsets[0]).abs()));
    assert!(spread < 1e-9, "log-weight offsets spread {spread}");
    let err = (pf.mean() - SVector::from(TRUTH)).fixed_rows::<2>(0).norm();
    println!("one step: position error {err:.2} px (prior 5 px)");
    assert!(err < 5.0);
}

#[test]
fn scale_is_recovered_at_a_large_scale_through_the_scale_space() {
    let m = model();
    let truth = [84.0, 86.0, -0.3, 1.45];
    let mut frame = render(truth, m.centre, 190);
    add_noise(&mut frame, 3.0, 8);
    let mut space = ScaleSpace::new();
    space.build(&frame, &m).unwrap();
    let lik = PatternLikelihood::new(&m, &space);
    let mut scratch = PatternScratch::default();
    // Scale from 1.25 to 1.65 by 0.02, position +-1 px by 0.5.
    let mut best = ([0.0; 4], f64::NEG_INFINITY);
    for k in -10..=10 {
        for i in -2..=2 {
            for j in -2..=2 {
                let st = [
                    truth[0] + 0.5 * f64::from(i),
                    truth[1] + 0.5 * f64::from(j),
                    truth[2],
                    truth[3] + 0.02 * f64::from(k),
                ];
                let ll = lik.observe(&SVector::from(st), &mut scratch).log_likelihood;
                if ll > best.1 {
                    best = (st, ll);
                }
            }
        }
    }
    println!("scale argmax {:?}, truth {truth:?}", best.0);
    assert!((best.0[3] - truth[3]).abs() <= 0.02 + 1e-9);
    assert!((best.0[0] - truth[0]).abs() <= 1.0 && (best.0[1] - truth[1]).abs() <= 1.0);
}

#[test]
fn max_points_caps_the_model_and_a_mask_restricts_it() {
    let mut reference = clean_pattern();
    add_noise(&mut reference, 3.0, 1);
    let config = PatternConfig {
        max_points: 20,
        ..PatternConfig::default()
    };
    let capped = PatternModel::from_region(&reference, WINDOW, &config).unwrap();
    assert_eq!(capped.points.len(), 20);
    // A mask over the disc only: every model point is on the disc's edge.
    let mask: Vec<bool> = (0..SIZE * SIZE)
        .map(|i| ((i % SIZE) as f64 - DISC.0).hypot((i / SIZE) as f64 - DISC.1) < DISC.2 + 5.0)
        .collect();
    let m = PatternModel::from_region(&reference, Region::Mask(mask), &PatternConfig::default())
        .unwrap();
    assert!(m.points.len() >= 10);
    for j in 0..m.points.len() {
        let o = m.offset(j);
        let r = (m.centre[0] + o[0] - DISC.0).hypot(m.centre[1] + o[1] - DISC.1);
        assert!((r - DISC.2).abs() < 1.5, "point at radius {r}");
    }
}

#[test]
fn non_finite_grey_levels_are_refused_or_occluded() {
    let mut reference = clean_pattern();
    reference.data[10] = f32::NAN;
    let err = PatternModel::from_region(&reference, WINDOW, &PatternConfig::default());
    assert_eq!(err.unwrap_err().parameter(), Some("image"));
    // A frame with NaN over the disc: those points are occluded, the likelihood finite.
    let m = model();
    let mut frame = render(TRUTH, m.centre, FRAME);
    let (sn, cs) = TRUTH[2].sin_cos();
    for y in 0..FRAME {
        for x in 0..FRAME {
            let q = [
                (x as f64 - TRUTH[0]) / TRUTH[3],
                (y as f64 - TRUTH[1]) / TRUTH[3],
            ];
            let src = [
                m.centre[0] + cs * q[0] - sn * q[1],
                m.centre[1] + sn * q[0] + cs * q[1],
            ];
            if (src[0] - DISC.0).hypot(src[1] - DISC.1) < DISC.2 + 7.0 {
                frame.data[y * FRAME + x] = f32::NAN;
            }
        }
    }
    let mut space = ScaleSpace::new();
    space.build(&frame, &m).unwrap();
    let lik = PatternLikelihood::new(&m, &space);
    let obs = lik.observe(&SVector::from(TRUTH), &mut PatternScratch::default());
    assert!(obs.log_likelihood.is_finite() && obs.occluded_fraction > 0.2);
    // The Gauss-Newton system leaves those points out too: finite, on fewer points.
    let ne = lik.normal_equations(&SVector::from(TRUTH)).unwrap();
    assert!(ne.points < m.points.len());
    assert!(
        ne.gradient
            .iter()
            .chain(ne.hessian.iter())
            .all(|v| v.is_finite())
    );
}

#[test]
fn a_windowed_scale_space_equals_the_whole_frame_blur_inside_its_window() {
    let m = model();
    let mut frame = render(TRUTH, m.centre, FRAME);
    add_noise(&mut frame, 3.0, 12);
    let mut full = ScaleSpace::new();
    full.build(&frame, &m).unwrap();
    // A window touching the frame's left edge (reflected border) and one inside.
    for (window, span) in [
        ([0, 20, 90, 150], [1.1, 1.6]),
        ([6, 5, 166, 167], [0.5, 2.2]),
    ] {
        let mut part = ScaleSpace::new();
        part.build_window(&frame, &m, window, span).unwrap();
        assert_eq!(part.origin(), [window[0] as f64, window[1] as f64]);
        for s in [span[0], 0.5 * (span[0] + span[1]), span[1]] {
            let (a, b) = (full.level(s), part.level(s));
            assert_eq!(
                (b.width, b.height),
                (window[2] - window[0], window[3] - window[1])
            );
            for y in window[1]..window[3] {
                for x in window[0]..window[2] {
                    assert_eq!(
                        a.at(x, y),
                        b.at(x - window[0], y - window[1]),
                        "({x}, {y}) s {s}"
                    );
                }
            }
        }
        // The likelihood of a state whose points and profiles lie inside the interior
        // window is unchanged.
        let state = SVector::from([TRUTH[0], TRUTH[1], TRUTH[2], 1.2]);
        let mut scratch = PatternScratch::default();
        let whole = PatternLikelihood::new(&m, &full).observe(&state, &mut scratch);
        let windowed = PatternLikelihood::new(&m, &part).observe(&state, &mut scratch);
        if window[0] > 0 {
            assert_eq!(whole, windowed);
        }
    }
}

/// Reads the window `[x0, y0, x1, y1)` of `frame` into `out`, as a tracker's frame
/// conversion does for a scale space.
fn crop_reader(frame: &GrayImage) -> impl FnOnce([usize; 4], &mut GrayImage) + '_ {
    |g: [usize; 4], out: &mut GrayImage| {
        out.width = g[2] - g[0];
        out.height = g[3] - g[1];
        out.data = (g[1]..g[3])
            .flat_map(|y| (g[0]..g[2]).map(move |x| (x, y)))
            .map(|(x, y)| frame.at(x, y))
            .collect();
    }
}

/// A window per level (`build_windows_for`): each level equals the whole frame's blur
/// inside its own window, at its own origin, whichever cell of scales asked for it,
/// and a state whose level's window holds its points has the whole frame's likelihood.
#[test]
fn per_level_windows_equal_the_whole_frame_blur_inside_each() {
    let m = model();
    let mut frame = render(TRUTH, m.centre, FRAME);
    add_noise(&mut frame, 3.0, 23);
    let mut full = ScaleSpace::new();
    full.build(&frame, &m).unwrap();
    // Larger scales get larger windows (as a tracker's footprints do).
    let window_of = |cell: [f64; 2]| {
        let r = (50.0 * cell[1]) as usize + 18;
        [
            90 - r.min(90),
            85 - r.min(85),
            (90 + r).min(FRAME),
            (85 + r).min(FRAME),
        ]
    };
    let mut cells = vec![];
    let mut part = ScaleSpace::new();
    let copy = crop_reader(&frame);
    let record = |cell: [f64; 2]| {
        let w = window_of(cell);
        cells.push((cell, w));
        w
    };
    part.build_windows_for([FRAME, FRAME], copy, &m, record, [0.9, 1.6], None)
        .unwrap();
    // Levels 1.0, 1.25, 1.5: the cells split the span at the midpoints.
    let bounds: Vec<[f64; 2]> = cells.iter().map(|c| c.0).collect();
    assert_eq!(bounds, vec![[0.9, 1.125], [1.125, 1.375], [1.375, 1.6]]);
    for (s, (_, w)) in [1.0, 1.25, 1.5].into_iter().zip(&cells) {
        let (a, (b, origin)) = (full.level(s), part.level_at(s));
        assert_eq!(origin, [w[0] as f64, w[1] as f64]);
        assert_eq!((b.width, b.height), (w[2] - w[0], w[3] - w[1]));
        for y in w[1]..w[3] {
            for x in w[0]..w[2] {
                assert_eq!(a.at(x, y), b.at(x - w[0], y - w[1]), "({x}, {y}) s {s}");
            }
        }
    }
    assert_eq!(part.origin(), [cells[2].1[0] as f64, cells[2].1[1] as f64]);
    let mut scratch = PatternScratch::default();
    for s in [1.0, 1.2] {
        let state = SVector::from([TRUTH[0], TRUTH[1], TRUTH[2], s]);
        let whole = PatternLikelihood::new(&m, &full).observe(&state, &mut scratch);
        let windowed = PatternLikelihood::new(&m, &part).observe(&state, &mut scratch);
        assert_eq!(whole, windowed, "s {s}");
    }
}

/// Levels blurred on demand (`build_window_for`, then `ensure`) against the whole
/// stack: a needed or ensured level equals the whole stack's, and a scale whose level
/// is not blurred yet reads the nearest blurred one.
#[test]
fn levels_blurred_on_demand_equal_the_whole_stack() {
    let m = model();
    let mut frame = render(TRUTH, m.centre, FRAME);
    add_noise(&mut frame, 3.0, 17);
    let mut full = ScaleSpace::new();
    full.build(&frame, &m).unwrap();
    let window = [6, 5, 166, 167];
    let same = |a: &GrayImage, b: &GrayImage| {
        (window[1]..window[3]).all(|y| {
            (window[0]..window[2]).all(|x| a.at(x, y) == b.at(x - window[0], y - window[1]))
        })
    };
    let mut part = ScaleSpace::new();
    let copy = crop_reader(&frame);
    // Levels of 1.0-2.0; only 1.0 (nearest to 0.9 and 1.1) is needed.
    part.build_window_for(
        [FRAME, FRAME],
        copy,
        &m,
        window,
        [1.0, 2.0],
        Some(&[0.9, 1.1]),
    )
    .unwrap();
    assert!(same(full.level(1.0), part.level(1.0)));
    // 1.5 is not blurred: the nearest blurred level (1.0) answers.
    assert!(same(full.level(1.0), part.level(1.5)));
    assert!(!same(full.level(1.5), part.level(1.5)));
    part.ensure([1.4, 1.6]);
    assert!(same(full.level(1.5), part.level(1.5)));
    // By nearest level: 1.9 and 2.2 want 2.0 only, so 1.75 still reads 1.5.
    assert!(!same(full.level(2.0), part.level(2.0)));
    part.ensure_nearest(&[1.9, 2.2, f64::NAN]);
    assert!(same(full.level(2.0), part.level(2.0)));
    assert!(same(full.level(1.5), part.level(1.7)));
    let state = SVector::from([TRUTH[0], TRUTH[1], TRUTH[2], 1.5]);
    let mut scratch = PatternScratch::default();
    let whole = PatternLikelihood::new(&m, &full).observe(&state, &mut scratch);
    let ensured = PatternLikelihood::new(&m, &part).observe(&state, &mut scratch);
    assert_eq!(whole, ensured);
}

/// Eq. 6 computed the slow way for one state: each point placed by `place`, its vector
/// sampled point by point with `sample_vector` on the level, `lambda` from the
/// two-pass inter-correlation and `deviation`, then the worst `tolerated` left out
/// after a full sort.
fn brute_force_eq6(m: &PatternModel, space: &ScaleSpace, state: [f64; 4]) -> (f64, f64) {
    use tracking::pattern::correlation::{
        autocorrelation_curvature, deviation, deviation_parabolic, inter_correlation,
    };
    use tracking::pattern::sample_vector;
    let c = &m.config;
    let image = space.level(state[3]);
    let o = space.origin();
    let st = SVector::from(state);
    let mut lambdas: Vec<f64> = (0..m.points.len())
        .map(|j| {
            let (p, phi) = place(&st, m.offset(j), m.points[j].phi);
            let mut v = vec![0.0f32; c.n_samples];
            let q = [p[0] - o[0], p[1] - o[1]];
            if !sample_vector(image, q, phi, c.delta * state[3], &mut v) {
                return f64::INFINITY;
            }
            let point = &m.points[j];
            let ncc = inter_correlation(&point.vector, &v);
            match c.deviation {
                DeviationModel::Line => deviation(ncc, point.slope),
                DeviationModel::Parabola => {
                    deviation_parabolic(ncc, autocorrelation_curvature(&point.vector, c.fit_lags))
                }
            }
        })
        .collect();
    let n = lambdas.len();
    let occluded = lambdas
        .iter()
        .filter(|&&l| l > c.occlusion_threshold)
        .count();
    let tolerated = ((c.max_occluded_fraction * n as f64).floor() as usize).min(occluded);
    lambdas.sort_by(f64::total_cmp);
    let inv = 1.0 / (2.0 * c.sigma * c.sigma);
    let kept: f64 = lambdas[..n - tolerated].iter().map(|l| l * l).sum();
    let left = tolerated as f64 * c.occlusion_threshold.powi(2);
    (-(kept + left) * inv, occluded as f64 / n as f64)
}

/// The observation model against eq. 6 computed point by point (states near and far,
/// some with points leaving the frame or occluded beyond the tolerated fraction).
#[test]
fn observe_equals_eq6_computed_point_by_point() {
    for deviation in [DeviationModel::Parabola, DeviationModel::Line] {
        let mut m = model();
        m.config.deviation = deviation;
        observe_equals_eq6_with(&m);
    }
}

fn observe_equals_eq6_with(m: &PatternModel) {
    let mut frame = render(TRUTH, m.centre, FRAME);
    add_noise(&mut frame, 3.0, 11);
    let mut space = ScaleSpace::new();
    space.build(&frame, m).unwrap();
    let lik = PatternLikelihood::new(m, &space);
    let mut scratch = PatternScratch::default();
    let mut rng = seeded(12);
    let mut far = 0;
    for k in 0..200 {
        let spread = if k % 2 == 0 { 1.0 } else { 8.0 };
        let state = [
            TRUTH[0] + spread * normal(&mut rng),
            TRUTH[1] + spread * normal(&mut rng),
            TRUTH[2] + 0.02 * spread * normal(&mut rng),
            TRUTH[3] * (1.0 + 0.02 * spread * normal(&mut rng)),
        ];
        let (ll, occ) = brute_force_eq6(m, &space, state);
        let obs = lik.observe(&SVector::from(state), &mut scratch);
        far += usize::from(occ > m.config.max_occluded_fraction);
        if ll.is_finite() {
            assert!(
                (obs.log_likelihood - ll).abs() < 1e-3 * (1.0 + ll.abs()),
                "{state:?}: {} vs {ll}",
                obs.log_likelihood
            );
        } else {
            assert_eq!(obs.log_likelihood, ll, "{state:?}");
        }
        assert_eq!(obs.occluded_fraction, occ, "{state:?}");
    }
    assert!(
        far > 10,
        "the states should include some beyond the tolerated occlusion"
    );
}

/// The coarse likelihood on the first `k` points of the visiting order against eq. 6
/// of a model holding only those points (computed point by point), and the whole
/// order's against the full likelihood.
#[test]
fn a_likelihood_on_some_points_is_eq6_of_those_points() {
    let m = model();
    let mut frame = render(TRUTH, m.centre, FRAME);
    add_noise(&mut frame, 3.0, 21);
    let mut space = ScaleSpace::new();
    space.build(&frame, &m).unwrap();
    let lik = PatternLikelihood::new(&m, &space);
    let n = m.points.len();
    let mut scratch = PatternScratch::default();
    let mut rng = seeded(22);
    for k in [1, n / 3, n.div_ceil(2), n] {
        let part = lik.with_points(k);
        let order: Vec<usize> = part.visiting_order().collect();
        assert_eq!(order.len(), k);
        let mut sub = m.clone();
        sub.points = order.iter().map(|&j| m.points[j].clone()).collect();
        for _ in 0..20 {
            let state = [
                TRUTH[0] + 2.0 * normal(&mut rng),
                TRUTH[1] + 2.0 * normal(&mut rng),
                TRUTH[2] + 0.03 * normal(&mut rng),
                TRUTH[3] * (1.0 + 0.03 * normal(&mut rng)),
            ];
            let (ll, occ) = brute_force_eq6(&sub, &space, state);
            let got = part.observe(&SVector::from(state), &mut scratch);
            assert!(
                (got.log_likelihood - ll).abs() < 1e-3 * (1.0 + ll.abs()),
                "k {k}: {} vs {ll}",
                got.log_likelihood
            );
            assert_eq!(got.occluded_fraction, occ);
            if k == n {
                let all = lik.observe(&SVector::from(state), &mut scratch);
                assert_eq!(got, all);
            }
        }
    }
}

/// `observe_above`'s contract against `observe`: the exact answer at or above the
/// floor, an upper bound of it below the floor otherwise.
#[test]
fn observe_above_is_exact_above_its_floor_and_a_bound_below() {
    let m = model();
    let mut frame = render(TRUTH, m.centre, FRAME);
    add_noise(&mut frame, 3.0, 15);
    let mut space = ScaleSpace::new();
    space.build(&frame, &m).unwrap();
    let lik = PatternLikelihood::new(&m, &space);
    let (mut s1, mut s2) = (PatternScratch::default(), PatternScratch::default());
    let mut rng = seeded(16);
    let mut bounded = 0;
    for _ in 0..300 {
        let state = SVector::from([
            TRUTH[0] + 4.0 * normal(&mut rng),
            TRUTH[1] + 4.0 * normal(&mut rng),
            TRUTH[2] + 0.05 * normal(&mut rng),
            TRUTH[3] * (1.0 + 0.05 * normal(&mut rng)),
        ]);
        let floor = -10.0 - 60.0 * rng.random::<f64>();
        let exact = lik.observe(&state, &mut s1);
        let got = lik.observe_above(&state, &mut s2, floor);
        if exact.log_likelihood >= floor {
            assert_eq!(got, exact, "{state:?} floor {floor}");
        } else if got != exact {
            bounded += 1;
            assert!(
                got.log_likelihood >= exact.log_likelihood && got.log_likelihood < floor,
                "{got:?} {exact:?} floor {floor}"
            );
        }
    }
    assert!(bounded > 50, "only {bounded} states were bounded");
}

/// The early exit on one chunk's scratch, against the exact likelihood: a state cut
/// short gets a value more than the margin below the best met before it in the
/// chunk, and no state within a third of the margin of that best is cut.
#[test]
fn the_early_exit_cuts_only_states_far_below_the_best() {
    use tracking::Likelihood;
    let m = model();
    let mut frame = render(TRUTH, m.centre, FRAME);
    add_noise(&mut frame, 3.0, 13);
    let mut space = ScaleSpace::new();
    space.build(&frame, &m).unwrap();
    let exact = PatternLikelihood::new(&m, &space);
    let margin = 30.0;
    let quick = PatternLikelihood::new(&m, &space).with_early_exit(margin);
    let (mut s_exact, mut s_quick) = (PatternScratch::default(), PatternScratch::default());
    let mut rng = seeded(14);
    let (mut best, mut cut) = (f64::NEG_INFINITY, 0);
    for _ in 0..300 {
        let state = SVector::from([
            TRUTH[0] + 4.0 * normal(&mut rng),
            TRUTH[1] + 4.0 * normal(&mut rng),
            TRUTH[2] + 0.05 * normal(&mut rng),
            TRUTH[3] * (1.0 + 0.05 * normal(&mut rng)),
        ]);
        let want = exact.observe(&state, &mut s_exact).log_likelihood;
        let got = quick.log_likelihood(&state, &mut s_quick);
        if got != want {
            cut += 1;
            assert!(got < best - margin, "{got} {want} {best}");
            assert!(want < best - margin / 3.0, "{got} {want} {best}");
        }
        best = best.max(want);
    }
    assert!(cut > 50, "only {cut} states were cut short");
    // A new likelihood (the next frame) does not inherit the scratch's best.
    let again = PatternLikelihood::new(&m, &space).with_early_exit(margin);
    let far = SVector::from([TRUTH[0] + 30.0, TRUTH[1], TRUTH[2], TRUTH[3]]);
    let far_exact = exact.observe(&far, &mut s_exact).log_likelihood;
    assert_eq!(again.log_likelihood(&far, &mut s_quick), far_exact);
    // With a reference (the truth's log-likelihood), a fresh chunk cuts that state
    // short from its first particle on, below the reference by more than the margin.
    let at_truth = exact
        .observe(&SVector::from(TRUTH), &mut s_exact)
        .log_likelihood;
    assert!(far_exact < at_truth - margin);
    let referenced = PatternLikelihood::new(&m, &space)
        .with_early_exit(margin)
        .with_reference(at_truth);
    let got = referenced.log_likelihood(&far, &mut PatternScratch::default());
    assert!(
        got != far_exact && got < at_truth - margin,
        "{got} {far_exact}"
    );
}

/// The scale space of a noise-free render of the pattern at the truth.
fn clean_space(m: &PatternModel) -> ScaleSpace {
    let mut space = ScaleSpace::new();
    space.build(&render(TRUTH, m.centre, FRAME), m).unwrap();
    space
}

/// The Gauss-Newton gradient is the log-likelihood's: central differences of eq. 6
/// at states around the truth where no point is occluded.
#[test]
fn normal_equations_match_central_differences_of_eq_6() {
    let m = model();
    let space = clean_space(&m);
    let lik = PatternLikelihood::new(&m, &space);
    let mut scratch = PatternScratch::default();
    let mut ll = |x: [f64; 4]| lik.observe(&SVector::from(x), &mut scratch).log_likelihood;
    let h = [1e-2, 1e-2, 1e-4, 1e-4];
    for off in [
        [0.6, -0.4, 0.02, 0.015],
        [-0.3, 0.5, -0.01, -0.02],
        [0.2, 0.2, 0.0, 0.0],
    ] {
        let x: [f64; 4] = std::array::from_fn(|k| TRUTH[k] + off[k]);
        let ne = lik.normal_equations(&SVector::from(x)).unwrap();
        assert_eq!(ne.points, m.points.len(), "a point occluded at {x:?}");
        for k in 0..4 {
            let (mut a, mut b) = (x, x);
            a[k] += h[k];
            b[k] -= h[k];
            let fd = (ll(a) - ll(b)) / (2.0 * h[k]);
            let g = ne.gradient[k];
            println!("{k}: analytic {g:.4}, central {fd:.4}");
            assert!(
                (g - fd).abs() <= 0.02 * g.abs().max(fd.abs()) + 0.05,
                "{k}: {g} vs {fd}"
            );
        }
    }
}

/// At the truth of a clean frame the residuals are small, so the Gauss-Newton
/// Hessian approaches the true one: against central second differences of eq. 6.
#[test]
fn the_gauss_newton_hessian_is_the_curvature_of_eq_6_at_the_truth() {
    let m = model();
    let space = clean_space(&m);
    let lik = PatternLikelihood::new(&m, &space);
    let mut scratch = PatternScratch::default();
    let mut ll = |x: [f64; 4]| lik.observe(&SVector::from(x), &mut scratch).log_likelihood;
    let ne = lik.normal_equations(&SVector::from(TRUTH)).unwrap();
    let h = [0.05, 0.05, 5e-4, 5e-4];
    for k in 0..4 {
        for j in 0..4 {
            let at = |dk: f64, dj: f64| {
                let mut x = TRUTH;
                x[k] += dk * h[k];
                x[j] += dj * h[j];
                x
            };
            let fd = -(ll(at(1.0, 1.0)) - ll(at(1.0, -1.0)) - ll(at(-1.0, 1.0))
                + ll(at(-1.0, -1.0)))
                / (4.0 * h[k] * h[j]);
            let gn = ne.hessian[(k, j)];
            let scale = (ne.hessian[(k, k)] * ne.hessian[(j, j)]).sqrt();
            println!("({k},{j}): gauss-newton {gn:.1}, second differences {fd:.1}");
            assert!((gn - fd).abs() <= 0.1 * scale, "({k},{j}): {gn} vs {fd}");
        }
    }
}

/// A scale space built on a worker of a pool of 3 threads (each level blurred in
/// bands of rows, in parallel) holds the serial build's numbers bit for bit (the test
/// thread is not a worker: there it blurs serially).
#[test]
fn a_scale_space_blurred_in_parallel_bands_equals_the_serial_one() {
    let m = model();
    let mut frame = render(TRUTH, m.centre, FRAME);
    add_noise(&mut frame, 3.0, 21);
    let mut serial = ScaleSpace::new();
    serial.build(&frame, &m).unwrap();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(3)
        .build()
        .unwrap();
    let parallel = pool.install(|| {
        let mut space = ScaleSpace::new();
        space.build(&frame, &m).unwrap();
        space
    });
    assert_eq!(serial.len(), m.config.scale_levels.len());
    for &s in &m.config.scale_levels {
        let bits = |img: &GrayImage| img.data.iter().map(|g| g.to_bits()).collect::<Vec<_>>();
        let (a, b) = (serial.level(s), parallel.level(s));
        assert_eq!((a.width, a.height), (b.width, b.height), "scale {s}");
        assert!(bits(a) == bits(b), "scale {s}");
    }
}
