//! The visual memory's geometry (eqs. 2-3) against the ceiling world's ground truth:
//! tracker states made from the true poses through the camera's own projection, then
//! the robot and the models recovered in the mosaic frame of model 0.

use navigation::ceiling::CeilingCamera;
use navigation::memory::{ImageScale, fuse, new_model_in_mosaic, robot_in_mosaic};
use proptest::prelude::*;
use rperc_core::Pose2;

/// A model created at robot pose `created`, centred on the ceiling point `origin`:
/// its world frame (the image axes at creation are the robot's axes).
fn model_frame(created: &Pose2, origin: [f64; 2]) -> Pose2 {
    Pose2::new(origin[0], origin[1], created.theta)
}

/// The tracker state of a model with world frame `model` seen from `robot`: the
/// ideal camera's projection of its origin, and its turn since creation.
fn state(camera: &CeilingCamera, robot: &Pose2, model: &Pose2) -> [f64; 4] {
    let uv = camera.project_ideal(robot, [model.x, model.y]);
    [
        uv[0],
        uv[1],
        rperc_core::wrap_angle(robot.theta - model.theta),
        1.0,
    ]
}

fn scale(camera: &CeilingCamera, metric: bool) -> ImageScale {
    ImageScale {
        metres_per_pixel: if metric {
            camera.metres_per_pixel()
        } else {
            1.0
        },
        principal: [camera.cx, camera.cy],
    }
}

fn close(a: &Pose2, b: &Pose2, tol: f64) -> bool {
    (a.x - b.x).abs() < tol
        && (a.y - b.y).abs() < tol
        && rperc_core::angle_diff(a.theta, b.theta).abs() < 1e-9
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    /// Model 0 defines the mosaic; model 1 is placed by eq. 3 from model 0 while both
    /// are in view; model 2 from model 1 after model 0 has left. Eq. 2 from model 2
    /// alone then gives the true robot pose in model 0's frame, in metres when
    /// calibrated and in pixels (metres / (Z / f)) when not.
    #[test]
    fn chained_models_localise_the_robot(
        r0 in prop::array::uniform3(-5.0f64..5.0),
        steps in prop::collection::vec(prop::array::uniform3(-0.6f64..0.6), 3),
        offsets in prop::collection::vec(prop::array::uniform2(-0.8f64..0.8), 3),
        metric in any::<bool>(),
    ) {
        let camera = CeilingCamera::default();
        let s = scale(&camera, metric);
        let unit = if metric { 1.0 } else { camera.metres_per_pixel() };
        let robot0 = Pose2::new(r0[0], r0[1], r0[2]);
        let robot1 = robot0.compose(&Pose2::new(steps[0][0], steps[0][1], steps[0][2]));
        let robot2 = robot1.compose(&Pose2::new(steps[1][0], steps[1][1], steps[1][2]));
        let robot3 = robot2.compose(&Pose2::new(steps[2][0], steps[2][1], steps[2][2]));
        let near = |r: &Pose2, o: [f64; 2]| r.transform_point(&nalgebra::Point2::new(o[0], o[1]));
        let p0 = near(&robot0, offsets[0]);
        let w0 = model_frame(&robot0, [p0.x, p0.y]);
        let p1 = near(&robot1, offsets[1]);
        let w1 = model_frame(&robot1, [p1.x, p1.y]);
        let p2 = near(&robot2, offsets[2]);
        let w2 = model_frame(&robot2, [p2.x, p2.y]);
        // Mosaic: M T_0 = I. Model 1 at time 1 from model 0; model 2 at time 2 from 1.
        let m0 = Pose2::identity();
        let robot_at1 = robot_in_mosaic(&m0, &s.camera_to_model(state(&camera, &robot1, &w0)));
        let m1 = new_model_in_mosaic(&robot_at1, &s.camera_to_model(state(&camera, &robot1, &w1)));
        let robot_at2 = robot_in_mosaic(&m1, &s.camera_to_model(state(&camera, &robot2, &w1)));
        let m2 = new_model_in_mosaic(&robot_at2, &s.camera_to_model(state(&camera, &robot2, &w2)));
        let estimate = robot_in_mosaic(&m2, &s.camera_to_model(state(&camera, &robot3, &w2)));
        let truth = w0.between(&robot3);
        let truth = Pose2::new(truth.x / unit, truth.y / unit, truth.theta);
        prop_assert!(close(&estimate, &truth, 1e-7 / unit), "{estimate:?} vs {truth:?}");
        // The models themselves, against their true frames seen from model 0.
        let t2 = w0.between(&w2);
        prop_assert!(close(&m2, &Pose2::new(t2.x / unit, t2.y / unit, t2.theta), 1e-7 / unit));
        // Re-acquisition: the predicted state is the one the camera shows.
        let predicted = s.predicted_state(&estimate, &m1);
        let seen = state(&camera, &robot3, &w1);
        for k in 0..3 {
            let d = if k == 2 { rperc_core::angle_diff(predicted[k], seen[k]) } else { predicted[k] - seen[k] };
            prop_assert!(d.abs() < 1e-6, "state {k}: {predicted:?} vs {seen:?}");
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// The image motion an odometry step predicts for a tracked model (the control
    /// that carries its tracker) is where the camera shows the model after the step.
    #[test]
    fn a_moved_state_is_where_the_camera_sees_the_model_after_the_step(
        r0 in prop::array::uniform3(-5.0f64..5.0),
        step in prop::array::uniform3(-0.3f64..0.3),
        offset in prop::array::uniform2(-0.8f64..0.8),
        turn in -3.0f64..3.0,
        metric in any::<bool>(),
    ) {
        let camera = CeilingCamera::default();
        let s = scale(&camera, metric);
        let unit = if metric { 1.0 } else { camera.metres_per_pixel() };
        let before = Pose2::new(r0[0], r0[1], r0[2]);
        let motion = Pose2::new(step[0], step[1], step[2]);
        let after = before.compose(&motion);
        let origin = before.transform_point(&nalgebra::Point2::new(offset[0], offset[1]));
        let model = Pose2::new(origin.x, origin.y, before.theta + turn);
        let in_units = Pose2::new(motion.x / unit, motion.y / unit, motion.theta);
        let moved = s.moved_state(state(&camera, &before, &model), &in_units);
        let seen = state(&camera, &after, &model);
        for k in 0..3 {
            let d = if k == 2 { rperc_core::angle_diff(moved[k], seen[k]) } else { moved[k] - seen[k] };
            prop_assert!(d.abs() < 1e-6, "state {k}: {moved:?} vs {seen:?}");
        }
    }
}

#[test]
fn fusion_is_a_weighted_mean_with_a_circular_heading() {
    let a = Pose2::new(1.0, 2.0, 3.1);
    let b = Pose2::new(3.0, 4.0, -3.1);
    let f = fuse(&[(a, 1.0), (b, 3.0)]).unwrap();
    assert!((f.x - 2.5).abs() < 1e-12 && (f.y - 3.5).abs() < 1e-12);
    // Across +-pi: near pi, not near 0.
    assert!(f.theta.abs() > 3.0);
    assert!(fuse(&[]).is_none());
    assert!(fuse(&[(a, 0.0), (b, f64::NAN)]).is_none());
}

/// Proposals against the world's truth: over random poses, every light, vent and sign
/// wholly in view gets a proposal holding its centre, and every proposal holds a
/// pattern's centre.
#[test]
fn proposals_find_the_patterns_in_view_and_only_them() {
    use navigation::ceiling::{Ceiling, CeilingParams, PatternKind, RenderParams, render};
    use navigation::memory::{ProposalParams, propose_regions};
    let ceiling = Ceiling::generate(&CeilingParams {
        seed: 11,
        ..Default::default()
    })
    .unwrap();
    let camera = CeilingCamera::default();
    let params = ProposalParams::default();
    let mut rng_state = 12345u64;
    let mut next = || {
        rng_state = rng_state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (rng_state >> 11) as f64 / (1u64 << 53) as f64
    };
    let (mut expected, mut found, mut proposals, mut hits) = (0, 0, 0, 0);
    let mut frame = Vec::new();
    for k in 0..40 {
        let pose = Pose2::new(
            1.5 + 9.0 * next(),
            1.5 + 5.0 * next(),
            std::f64::consts::TAU * next(),
        );
        render(
            &ceiling,
            &camera,
            &pose,
            &RenderParams::default(),
            k,
            &mut frame,
        )
        .unwrap();
        let image = rperc_core::image::GrayImage {
            data: frame.iter().map(|&g| f32::from(g)).collect(),
            width: camera.width,
            height: camera.height,
        };
        let regions = propose_regions(&image, &[], &params).unwrap();
        let inside = |r: &[usize; 4], uv: [f64; 2]| {
            uv[0] >= r[0] as f64
                && uv[0] < (r[0] + r[2]) as f64
                && uv[1] >= r[1] as f64
                && uv[1] < (r[1] + r[3]) as f64
        };
        let centres: Vec<([f64; 2], f64, PatternKind)> = ceiling
            .patterns
            .iter()
            .map(|p| {
                let radius =
                    0.5 * p.kind.size()[0].hypot(p.kind.size()[1]) / camera.metres_per_pixel();
                (camera.project_ideal(&pose, p.centre), radius, p.kind)
            })
            .collect();
        let clear = (params.border + params.margin + 1) as f64;
        for (uv, radius, kind) in &centres {
            let in_view = uv[0] - radius > clear
                && uv[1] - radius > clear
                && uv[0] + radius < camera.width as f64 - clear
                && uv[1] + radius < camera.height as f64 - clear;
            if in_view && *kind != PatternKind::Detector {
                expected += 1;
                if regions.iter().any(|r| inside(r, *uv)) {
                    found += 1;
                }
            }
        }
        for r in &regions {
            proposals += 1;
            if centres.iter().any(|(uv, _, _)| inside(r, *uv)) {
                hits += 1;
            }
        }
    }
    assert!(expected >= 20, "only {expected} patterns wholly in view");
    assert_eq!(found, expected, "recall {found}/{expected}");
    assert_eq!(hits, proposals, "precision {hits}/{proposals}");
}

mod keys_and_servo {
    use navigation::ceiling::CeilingCamera;
    use navigation::memory::{
        KeyImage, KeyImageParams, LearntFrame, ServoParams, TrackedModel, check_chain, command,
        key_error, select_key_images, separation,
    };
    use rperc_core::Pose2;

    use super::{model_frame, state};

    /// A ceiling of point models on a 0.5 m grid, and what the ideal camera tracks of
    /// them from `robot`: every model whose centre is 30 px inside the image.
    fn seen(camera: &CeilingCamera, robot: &Pose2, models: &[Pose2]) -> Vec<TrackedModel> {
        models
            .iter()
            .enumerate()
            .filter_map(|(id, m)| {
                let s = state(camera, robot, m);
                let ok = s[0] > 30.0 && s[1] > 30.0 && s[0] < 290.0 && s[1] < 210.0;
                ok.then_some(TrackedModel {
                    id,
                    state: s,
                    score: 1.0,
                })
            })
            .collect()
    }

    fn grid() -> Vec<Pose2> {
        let created = Pose2::new(0.0, 0.0, 0.3);
        (0..20)
            .flat_map(|i| (0..12).map(move |j| (i, j)))
            .map(|(i, j)| model_frame(&created, [0.5 * i as f64, 0.5 * j as f64]))
            .collect()
    }

    /// A learning run along an S-curve: 0.3 m/s, turning left then right.
    fn learning_path() -> Vec<Pose2> {
        let mut pose = Pose2::new(1.0, 2.0, 0.0);
        let mut path = vec![pose];
        for k in 0..200 {
            let omega = if k < 100 { 0.25 } else { -0.25 };
            pose = pose.advance(0.3, omega, 0.1);
            path.push(pose);
        }
        path
    }

    fn learnt(camera: &CeilingCamera, models: &[Pose2], path: &[Pose2]) -> Vec<LearntFrame> {
        path.iter()
            .enumerate()
            .map(|(frame, p)| LearntFrame {
                frame,
                models: seen(camera, p, models),
                pose: Some(*p),
            })
            .collect()
    }

    #[test]
    fn key_images_meet_both_conditions_from_a_to_b() {
        let camera = CeilingCamera::default();
        let models = grid();
        let path = learning_path();
        let params = KeyImageParams::default();
        let px = camera.metres_per_pixel();
        let keys = select_key_images(&learnt(&camera, &models, &path), &params, px).unwrap();
        assert_eq!(keys.first().unwrap().frame, 0);
        assert_eq!(keys.last().unwrap().frame, path.len() - 1);
        assert!(keys.len() >= 4, "{} key images over 6 m", keys.len());
        check_chain(&keys, &params).unwrap();
        // Brute force over the chain: a shared model, turns, shifts and the robot's
        // travel within limits.
        for pair in keys.windows(2) {
            let (turn, shift) = separation(&pair[0].models, &pair[1].models).unwrap();
            assert!(turn <= params.max_turn && shift <= params.max_shift);
            let d = pair[0].pose.between(&pair[1].pose);
            assert!(d.x.hypot(d.y) / px <= params.max_travel);
        }
        // A broken chain is refused, naming the pair.
        let mut broken = keys.clone();
        broken[1].models.clear();
        let err = check_chain(&broken, &params).unwrap_err().to_string();
        assert!(
            err.contains("key images 0 and 1") && err.contains("condition i"),
            "{err}"
        );
        // A learning run that jumps (the view changes entirely between two frames).
        let mut jump = learnt(&camera, &models, &path);
        for f in &mut jump[100..] {
            for m in &mut f.models {
                m.id += 1000;
            }
        }
        assert!(select_key_images(&jump, &params, px).is_err());
    }

    /// The servoing law closes the loop on perfect image measurements: from perturbed
    /// starts the robot passes every key image and stops at B within a few pixels.
    #[test]
    fn servoing_replays_the_path_from_perturbed_starts() {
        let camera = CeilingCamera::default();
        let models = grid();
        let path = learning_path();
        let keys = select_key_images(
            &learnt(&camera, &models, &path),
            &KeyImageParams::default(),
            camera.metres_per_pixel(),
        )
        .unwrap();
        let params = ServoParams::default();
        let m_per_px = camera.metres_per_pixel();
        for (dx, dy, dth) in [(0.1, -0.1, 0.15), (-0.15, 0.05, -0.2), (0.0, 0.15, 0.0)] {
            let mut robot = path[0].compose(&Pose2::new(dx, dy, dth));
            let mut k = 1;
            let dt = 0.1;
            let mut steps = 0;
            let final_error = loop {
                steps += 1;
                assert!(steps < 3000, "did not reach B");
                let now = seen(&camera, &robot, &models);
                let error = key_error(&now, &keys[k], [camera.cx, camera.cy], None)
                    .expect("a shared model");
                let last = k + 1 == keys.len();
                let distance = error.x.hypot(error.y);
                if !last && distance < params.switch_error {
                    k += 1;
                    continue;
                }
                if last && distance < params.final_error {
                    break robot.between(&keys[k].pose);
                }
                let (v, omega) = command(&error, &params);
                robot = robot.advance(v * m_per_px, omega, dt);
            };
            let metres = final_error.x.hypot(final_error.y);
            assert!(
                metres < 0.05,
                "final error {metres} m from ({dx}, {dy}, {dth})"
            );
        }
    }

    #[test]
    fn key_error_is_the_key_pose_seen_from_the_robot() {
        let camera = CeilingCamera::default();
        let models = grid();
        let robot = Pose2::new(3.0, 2.5, 0.4);
        let then = Pose2::new(3.3, 2.4, 0.1);
        let key = KeyImage {
            frame: 0,
            models: seen(&camera, &then, &models),
            pose: then,
        };
        let error = key_error(
            &seen(&camera, &robot, &models),
            &key,
            [camera.cx, camera.cy],
            None,
        )
        .unwrap();
        let truth = robot.between(&then);
        let px = camera.metres_per_pixel();
        assert!((error.x * px - truth.x).abs() < 1e-9 && (error.y * px - truth.y).abs() < 1e-9);
        assert!(rperc_core::angle_diff(error.theta, truth.theta).abs() < 1e-9);
    }
}

proptest! {
    /// The rigid fit recovers the transform that made the points, and with noise it
    /// is no worse (in weighted squared residual) than the transform itself.
    #[test]
    fn fit_pose_recovers_the_transform(
        t in prop::array::uniform3(-5.0f64..5.0),
        points in prop::collection::vec(prop::array::uniform2(-3.0f64..3.0), 2..8),
        noise in prop::collection::vec(prop::array::uniform2(-0.01f64..0.01), 8),
    ) {
        use navigation::memory::fit_pose;
        let truth = Pose2::new(t[0], t[1], t[2]);
        let spread = points.iter().any(|p| (p[0] - points[0][0]).hypot(p[1] - points[0][1]) > 0.5);
        prop_assume!(spread);
        let pairs: Vec<([f64; 2], [f64; 2], f64)> = points.iter().map(|p| {
            let q = truth.transform_point(&nalgebra::Point2::new(p[0], p[1]));
            ([q.x, q.y], *p, 1.0)
        }).collect();
        let fit = fit_pose(&pairs).unwrap();
        prop_assert!(close(&fit, &truth, 1e-9), "{fit:?} vs {truth:?}");
        let noisy: Vec<_> = pairs.iter().zip(&noise).map(|(p, n)| ([p.0[0] + n[0], p.0[1] + n[1]], p.1, 1.0)).collect();
        let residual = |pose: &Pose2| noisy.iter().map(|(m, r, _)| {
            let q = pose.transform_point(&nalgebra::Point2::new(r[0], r[1]));
            (q.x - m[0]).powi(2) + (q.y - m[1]).powi(2)
        }).sum::<f64>();
        let fit = fit_pose(&noisy).unwrap();
        prop_assert!(residual(&fit) <= residual(&truth) + 1e-12);
    }
}
