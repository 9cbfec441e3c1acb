//! The ceiling world against independent routes: eq. 1's homography against the full
//! 3-D pinhole projection, the renderer against the ceiling seen through that
//! projection, the drive against closed-form arcs, the layout against brute force.

use navigation::NavigationError;
use navigation::ceiling::{
    CameraMount, Ceiling, CeilingCamera, CeilingParams, OdometryNoise, PatternKind, RenderParams,
    apply_homography, drive, render,
};
use proptest::prelude::*;
use rperc_core::Pose2;

fn tilted(roll: f64, pitch: f64, yaw: f64, offset: [f64; 3]) -> CeilingCamera {
    CeilingCamera {
        mount: CameraMount {
            roll,
            pitch,
            yaw,
            offset,
        },
        ..CeilingCamera::default()
    }
}

fn small_ceiling(seed: u64) -> Ceiling {
    Ceiling::generate(&CeilingParams {
        size: [6.0, 4.0],
        resolution: 0.008,
        n_patterns: 8,
        seed,
        ..Default::default()
    })
    .unwrap()
}

fn clean() -> RenderParams {
    RenderParams {
        noise: 0.0,
        blur: 0.0,
        gain: [1.0, 1.0],
        offset: [0.0, 0.0],
        ..Default::default()
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// Eq. 1 maps the ideal image of a ceiling point to where the tilted, offset
    /// camera sees it by the 3-D projection, and the correction undoes it.
    #[test]
    fn eq1_matches_the_3d_projection(
        roll in -0.1f64..0.1, pitch in -0.1f64..0.1, yaw in -3.0f64..3.0,
        ox in -0.2f64..0.2, oy in -0.2f64..0.2, oz in 0.0f64..0.6,
        x in -10.0f64..10.0, y in -10.0f64..10.0, theta in -3.1f64..3.1,
        dx in -1.5f64..1.5, dy in -1.5f64..1.5,
    ) {
        let camera = tilted(roll, pitch, yaw, [ox, oy, oz]);
        camera.validate().unwrap();
        let pose = Pose2::new(x, y, theta);
        let point = [x + dx, y + dy];
        let ideal = camera.project_ideal(&pose, point);
        let real = camera.project(&pose, point).unwrap();
        let mapped = apply_homography(&camera.robot_to_camera_homography(), ideal).unwrap();
        prop_assert!((mapped[0] - real[0]).abs() < 1e-8 && (mapped[1] - real[1]).abs() < 1e-8,
            "eq. 1 gives {mapped:?}, the projection {real:?}");
        let back = apply_homography(&camera.correction_homography().unwrap(), real).unwrap();
        prop_assert!((back[0] - ideal[0]).abs() < 1e-8 && (back[1] - ideal[1]).abs() < 1e-8);
        let world = apply_homography(&camera.pixel_to_world(&pose).unwrap(), real).unwrap();
        prop_assert!((world[0] - point[0]).abs() < 1e-9 && (world[1] - point[1]).abs() < 1e-9);
    }
}

#[test]
fn the_ideal_image_is_a_mirrored_plan_view_at_scale_f_over_z() {
    let camera = CeilingCamera::default();
    let pose = Pose2::new(3.0, 2.0, 0.4);
    let a = camera.project_ideal(&pose, [3.5, 2.2]);
    let b = camera.project_ideal(&pose, [4.0, 2.7]);
    let image_distance = (a[0] - b[0]).hypot(a[1] - b[1]);
    let world_distance = 0.5f64.hypot(0.5);
    assert!((image_distance * camera.metres_per_pixel() - world_distance).abs() < 1e-12);
    // The robot turning by +phi turns the image of a fixed segment by -phi.
    let turned = Pose2::new(3.0, 2.0, 0.4 + 0.3);
    let (a2, b2) = (
        camera.project_ideal(&turned, [3.5, 2.2]),
        camera.project_ideal(&turned, [4.0, 2.7]),
    );
    let angle = |p: [f64; 2], q: [f64; 2]| (q[1] - p[1]).atan2(q[0] - p[0]);
    let turn = rperc_core::angle_diff(angle(a2, b2), angle(a, b));
    assert!((turn + 0.3).abs() < 1e-12, "image turned by {turn}");
}

#[test]
fn a_calibration_that_cannot_be_inverted_is_refused_by_name() {
    let name = |camera: CeilingCamera| match camera.validate() {
        Err(NavigationError::InvalidParameter { name, .. }) => name,
        Err(NavigationError::Core(rperc_core::CoreError::InvalidParameter { name, .. })) => name,
        other => panic!("expected a named refusal, got {other:?}"),
    };
    let ok = CeilingCamera::default();
    assert_eq!(name(CeilingCamera { fx: 0.0, ..ok }), "fx");
    assert_eq!(name(CeilingCamera { fy: f64::NAN, ..ok }), "fy");
    assert_eq!(
        name(CeilingCamera {
            ceiling_height: -1.0,
            ..ok
        }),
        "ceiling_height"
    );
    assert_eq!(name(tilted(1.2, 0.0, 0.0, [0.0; 3])), "mount"); // 69 deg: sees the walls
    assert_eq!(name(tilted(0.0, 0.0, 0.0, [0.0, 0.0, 2.4])), "mount"); // at the ceiling
    assert_eq!(name(CeilingCamera { width: 4, ..ok }), "width");
    // Issue 38: 2^33 x 2^33 pixels wrapped the frame size in usize and aborted.
    let huge = 1usize << 33;
    assert_eq!(
        name(CeilingCamera {
            width: huge,
            height: huge,
            ..ok
        }),
        "width"
    );
    assert_eq!(name(CeilingCamera { height: huge, ..ok }), "height");
}

#[test]
fn patterns_are_placed_apart_inside_the_ceiling_and_reproducibly() {
    let params = CeilingParams {
        size: [6.0, 4.0],
        resolution: 0.01,
        n_patterns: 10,
        min_spacing: 0.9,
        seed: 3,
        ..Default::default()
    };
    let a = Ceiling::generate(&params).unwrap();
    assert_eq!(a, Ceiling::generate(&params).unwrap());
    let b = Ceiling::generate(&CeilingParams {
        seed: 4,
        ..params.clone()
    })
    .unwrap();
    assert_ne!(a.patterns, b.patterns);
    for (i, p) in a.patterns.iter().enumerate() {
        assert_eq!(p.kind, PatternKind::ALL[i % 4]);
        let r = 0.5 * p.kind.size()[0].hypot(p.kind.size()[1]);
        assert!(p.centre[0] >= r && p.centre[0] <= 6.0 - r, "{p:?}");
        assert!(p.centre[1] >= r && p.centre[1] <= 4.0 - r, "{p:?}");
        for q in &a.patterns[..i] {
            let d = (p.centre[0] - q.centre[0]).hypot(p.centre[1] - q.centre[1]);
            assert!(d >= 0.9, "{p:?} and {q:?} are {d} m apart");
        }
    }
    let crowded = CeilingParams {
        n_patterns: 500,
        ..params
    };
    match Ceiling::generate(&crowded) {
        Err(NavigationError::InvalidParameter { name, .. }) => assert_eq!(name, "n_patterns"),
        other => panic!("expected n_patterns refused, got {other:?}"),
    }
}

#[test]
fn the_tile_texture_repeats_with_the_tile() {
    let ceiling = small_ceiling(1);
    for k in 0..50 {
        let xy = [0.013 * k as f64 + 0.07, 0.029 * k as f64 + 0.11];
        let next = [xy[0] + 0.6, xy[1] + 1.2];
        assert!((ceiling.tile_level(xy) - ceiling.tile_level(next)).abs() < 1e-3);
    }
}

/// A point of a light's diffuser, away from its frame and bars (level 232 there).
fn diffuser_point(ceiling: &Ceiling) -> [f64; 2] {
    let light = ceiling
        .patterns
        .iter()
        .find(|p| p.kind == PatternKind::Light)
        .unwrap();
    let (s, c) = light.theta.sin_cos();
    let (a, b) = (0.3, 0.0);
    [
        light.centre[0] + c * a - s * b,
        light.centre[1] + s * a + c * b,
    ]
}

#[test]
fn the_camera_sees_the_ceiling_where_the_3d_projection_puts_it() {
    // Texels of 8, 5 and 3 mm under pixels of 1.6 cm: pyramid levels 0, 1 and 2.
    for resolution in [0.008, 0.005, 0.003] {
        let ceiling = Ceiling::generate(&CeilingParams {
            size: [6.0, 4.0],
            resolution,
            n_patterns: 8,
            seed: 2,
            ..Default::default()
        })
        .unwrap();
        sees_the_ceiling_where_the_projection_puts_it(&ceiling);
    }
}

fn sees_the_ceiling_where_the_projection_puts_it(ceiling: &Ceiling) {
    let camera = tilted(0.03, -0.02, 0.5, [0.05, -0.03, 0.3]);
    let target = diffuser_point(ceiling);
    let mut image = Vec::new();
    for (k, (dx, dy, theta)) in [(0.0, 0.0, 0.0), (0.4, -0.3, 1.0), (-0.5, 0.2, -2.0)]
        .into_iter()
        .enumerate()
    {
        let pose = Pose2::new(target[0] + dx, target[1] + dy, theta);
        render(ceiling, &camera, &pose, &clean(), k as u64, &mut image).unwrap();
        let [u, v] = camera.project(&pose, target).unwrap();
        let (u, v) = (u.round() as usize, v.round() as usize);
        assert_eq!(image[v * camera.width + u], 232, "pose {pose:?}");
    }
    // Looking past the ceiling's edge: the walls' level.
    let outside = Pose2::new(-3.0, -3.0, 0.0);
    render(ceiling, &camera, &outside, &clean(), 0, &mut image).unwrap();
    assert!(image.iter().all(|&g| g == 60));
}

#[test]
fn rendering_is_seeded_per_frame_and_its_noise_has_the_stated_sigma() {
    let ceiling = small_ceiling(5);
    let camera = CeilingCamera::default();
    let pose = Pose2::new(3.0, 2.0, 0.3);
    let params = RenderParams {
        noise: 4.0,
        ..clean()
    };
    let (mut a, mut b, mut c, mut flat) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    render(&ceiling, &camera, &pose, &params, 7, &mut a).unwrap();
    render(&ceiling, &camera, &pose, &params, 3, &mut c).unwrap();
    render(&ceiling, &camera, &pose, &params, 7, &mut b).unwrap();
    assert_eq!(a, b);
    assert_ne!(a, c);
    render(&ceiling, &camera, &pose, &clean(), 7, &mut flat).unwrap();
    // Residual variance against the noiseless image: sigma^2 + 1/12 (rounding), to
    // within 5 standard errors of a variance from ~77,000 pixels.
    let n = a.len() as f64;
    let var = a
        .iter()
        .zip(&flat)
        .map(|(&x, &y)| (f64::from(x) - f64::from(y)).powi(2))
        .sum::<f64>()
        / n;
    let expected = 16.0 + 1.0 / 12.0;
    assert!(
        (var - expected).abs() < 5.0 * expected * (2.0 / n).sqrt(),
        "variance {var}"
    );
}

#[test]
fn an_occluder_hides_a_disc_and_is_reported() {
    let ceiling = small_ceiling(6);
    let camera = CeilingCamera::default();
    let params = RenderParams {
        occluder_probability: 1.0,
        ..clean()
    };
    let mut image = Vec::new();
    let truth = render(
        &ceiling,
        &camera,
        &Pose2::new(3.0, 2.0, 0.0),
        &params,
        0,
        &mut image,
    )
    .unwrap();
    let [u, v, r] = truth.occluder.unwrap();
    assert!((r - 0.15 * 240.0).abs() < 1e-12);
    let mut inside = 0;
    for (k, &g) in image.iter().enumerate() {
        let (x, y) = ((k % camera.width) as f64, (k / camera.width) as f64);
        if (x - u).hypot(y - v) <= r {
            assert_eq!(g, 25);
            inside += 1;
        }
    }
    assert!(inside > 0);
}

#[test]
fn the_drive_follows_closed_form_arcs_and_the_odometry_drifts_as_stated() {
    // A full circle of radius 1 m in 40 steps returns to the start.
    let n = 40;
    let dt = 0.25;
    let omega = std::f64::consts::TAU / (n as f64 * dt);
    let commands = vec![[omega, omega]; n];
    let exact = OdometryNoise {
        speed_scale_error: 0.0,
        turn_scale_error: 0.0,
        speed_sigma: 0.0,
        turn_sigma: 0.0,
        seed: 0,
    };
    let run = drive(Pose2::new(1.0, 2.0, 0.5), &commands, dt, &exact).unwrap();
    let end = run.truth[n];
    assert!((end.x - 1.0).abs() < 1e-9 && (end.y - 2.0).abs() < 1e-9);
    assert_eq!(run.truth, run.odometry);
    // Half-way round: the diametrically opposite point, 2 m from the start.
    let half = run.truth[n / 2];
    assert!(((half.x - 1.0).hypot(half.y - 2.0) - 2.0).abs() < 1e-9);
    // A straight line with a 3 % speed error: the odometry reads 3 % long.
    let line = drive(
        Pose2::identity(),
        &[[1.0, 0.0]; 10],
        0.1,
        &OdometryNoise {
            speed_scale_error: 0.03,
            ..exact
        },
    )
    .unwrap();
    assert!((line.odometry[10].x - 1.03).abs() < 1e-12 && (line.truth[10].x - 1.0).abs() < 1e-12);
    assert!(drive(Pose2::identity(), &[], 0.1, &exact).is_err());
    assert!(drive(Pose2::identity(), &[[f64::NAN, 0.0]], 0.1, &exact).is_err());
    assert!(drive(Pose2::identity(), &[[1.0, 0.0]], 0.0, &exact).is_err());
}

#[test]
fn a_sequence_renders_each_frame_as_it_renders_alone() {
    let ceiling = small_ceiling(7);
    let camera = CeilingCamera::default();
    let params = RenderParams {
        occluder_probability: 0.5,
        ..Default::default()
    };
    let poses: Vec<Pose2> = (0..6)
        .map(|k| Pose2::new(2.0 + 0.2 * k as f64, 2.0, 0.1 * k as f64))
        .collect();
    let (frames, truths) =
        navigation::ceiling::render_sequence(&ceiling, &camera, &poses, &params, 10).unwrap();
    let size = camera.width * camera.height;
    let mut one = Vec::new();
    for (k, pose) in poses.iter().enumerate() {
        let truth = render(&ceiling, &camera, pose, &params, 10 + k as u64, &mut one).unwrap();
        assert_eq!(&frames[k * size..(k + 1) * size], &one[..]);
        assert_eq!(truths[k], truth);
    }
}

#[test]
fn pattern_kinds_read_their_names() {
    for kind in PatternKind::ALL {
        assert_eq!(kind.name().parse::<PatternKind>().unwrap(), kind);
    }
    assert!("lamp".parse::<PatternKind>().is_err());
}

#[test]
fn pyramid_levels_are_box_averages_centred_where_the_docs_say() {
    let ceiling = small_ceiling(8);
    let (base, res) = ceiling.level(0);
    for level in 1..4 {
        let (img, texel) = ceiling.level(level);
        let n = 1usize << level;
        assert!((texel - res * n as f64).abs() < 1e-15);
        for (i, j) in [(3, 5), (17, 9), (img.width - 1, img.height - 1)] {
            let mut sum = 0.0f64;
            for dj in 0..n {
                for di in 0..n {
                    sum += f64::from(base.at(i * n + di, j * n + dj));
                }
            }
            let mean = sum / (n * n) as f64;
            assert!(
                (f64::from(img.at(i, j)) - mean).abs() < 1e-3,
                "level {level} at ({i}, {j})"
            );
        }
    }
}

#[test]
fn the_corrected_image_is_the_ideal_cameras_image() {
    // Anisotropic pixels as well as a tilt and an offset: the ideal camera has
    // square pixels, so its image is a similarity of the ceiling.
    let ceiling = small_ceiling(9);
    let real = CeilingCamera {
        fy: 150.0,
        ..tilted(0.04, -0.03, 0.02, [0.08, -0.05, 0.3])
    };
    let ideal = CeilingCamera::default();
    let pose = Pose2::new(3.0, 2.0, 0.3);
    let (mut seen, mut want) = (Vec::new(), Vec::new());
    render(&ceiling, &real, &pose, &clean(), 0, &mut seen).unwrap();
    render(&ceiling, &ideal, &pose, &clean(), 0, &mut want).unwrap();
    let frame = rperc_core::image::GrayImage {
        data: seen.iter().map(|&g| f32::from(g)).collect(),
        width: real.width,
        height: real.height,
    };
    let mut corrected = rperc_core::image::GrayImage::default();
    navigation::ceiling::correct_image(&real, &frame, -1.0, &mut corrected).unwrap();
    let mut diffs: Vec<f64> = corrected
        .data
        .iter()
        .zip(&want)
        .filter(|(c, _)| **c >= 0.0)
        .map(|(c, w)| (f64::from(*c) - f64::from(*w)).abs())
        .collect();
    assert!(
        diffs.len() > want.len() * 6 / 10,
        "only {} pixels seen",
        diffs.len()
    );
    diffs.sort_by(f64::total_cmp);
    let median = diffs[diffs.len() / 2];
    let mean = diffs.iter().sum::<f64>() / diffs.len() as f64;
    // Resampling twice blurs edges a little; the geometry must be right everywhere.
    assert!(median < 2.0 && mean < 5.0, "median {median}, mean {mean}");
    let wrong = rperc_core::image::GrayImage::zeros(10, 10);
    assert!(navigation::ceiling::correct_image(&real, &wrong, 0.0, &mut corrected).is_err());
}
