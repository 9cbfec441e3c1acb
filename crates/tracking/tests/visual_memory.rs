//! The visual memory end to end in the ceiling world, against its ground truth: a
//! learning run builds the mosaic (model poses within their claimed covariances and
//! 2 cm and 0.5 degrees RMS of their true frames), localises the robot along the way by eq. 2, picks a valid key-image
//! chain, and a replay from a perturbed start servoes to B within 5 cm.

use rperc_core::Pose2;
use tracking::ceiling::{Ceiling, CeilingCamera, CeilingParams, RenderParams};
use tracking::memory::{
    ImageScale, KeyImageParams, LearnParams, ReplayOutcome, ReplayParams, World, check_chain,
    learn, replay,
};

#[test]
fn learn_then_replay_against_the_truth() {
    let ceiling = Ceiling::generate(&CeilingParams {
        seed: 3,
        ..Default::default()
    })
    .unwrap();
    let camera = CeilingCamera::default();
    let render = RenderParams::default();
    let world = World {
        ceiling: &ceiling,
        camera: &camera,
        render: &render,
    };
    let start = Pose2::new(3.0, 3.0, 0.0);
    let commands: Vec<[f64; 2]> = (0..60)
        .map(|k| [0.3, if k < 30 { 0.2 } else { 0.0 }])
        .collect();
    let learnt = learn(world, start, &commands, 0.1, &LearnParams::default(), 0).unwrap();
    let memory = &learnt.memory;
    assert!(memory.models.len() >= 2, "{} models", memory.models.len());
    check_chain(&memory.key_images, &KeyImageParams::default()).unwrap();
    // The mosaic frame in the world: model 0's true frame (the robot's true pose at
    // its creation, times its image pose there).
    let scale = ImageScale {
        metres_per_pixel: camera.metres_per_pixel(),
        principal: [camera.cx, camera.cy],
    };
    let frame_of = |m: &tracking::memory::MosaicModel| {
        let c = scale.camera_to_model([m.model.centre[0], m.model.centre[1], 0.0, 1.0]);
        learnt.truth[m.created].compose(&c)
    };
    let w_t_m = frame_of(&memory.models[0]);
    // Every model within its own claimed covariance (99.9 % ellipsoid), and the
    // mosaic within the 2 cm and 0.5 degrees RMS.
    let gate = rperc_core::chi2_quantile(0.999, 3.0).unwrap();
    let (mut sq_d, mut sq_t) = (0.0, 0.0);
    for m in memory.models.iter().skip(1) {
        let t = w_t_m.between(&frame_of(m));
        let e = nalgebra::Vector3::new(
            m.pose.x - t.x,
            m.pose.y - t.y,
            rperc_core::angle_diff(m.pose.theta, t.theta),
        );
        let cov = nalgebra::Matrix3::from(m.covariance).transpose();
        let nees = (e.transpose() * cov.try_inverse().expect("a placed model's covariance") * e)[0];
        assert!(nees < gate, "model {}: error {e:?}, NEES {nees}", m.id);
        sq_d += e[0] * e[0] + e[1] * e[1];
        sq_t += e[2] * e[2];
    }
    let placed = (memory.models.len() - 1) as f64;
    let (rms_d, rms_t) = ((sq_d / placed).sqrt(), (sq_t / placed).sqrt());
    assert!(
        rms_d < 0.02 && rms_t < 0.5f64.to_radians(),
        "mosaic RMS {rms_d} m, {rms_t} rad"
    );
    let (mut sq, mut n) = (0.0, 0);
    for (r, truth) in learnt.reports.iter().zip(&learnt.truth) {
        if let (Some(p), false) = (r.pose, r.lost) {
            let e = w_t_m.compose(&p).between(truth);
            sq += e.x * e.x + e.y * e.y;
            n += 1;
        }
    }
    assert!(
        n > 50 && (sq / n as f64).sqrt() < 0.02,
        "localisation RMS over {n} frames"
    );
    let b = *learnt.truth.last().unwrap();
    let run = replay(
        world,
        memory,
        start.compose(&Pose2::new(0.08, -0.06, 0.1)),
        &ReplayParams::default(),
        1,
    )
    .unwrap();
    assert_eq!(run.outcome, ReplayOutcome::Reached);
    let end = run.truth.last().unwrap().between(&b);
    assert!(end.x.hypot(end.y) < 0.05, "final error {end:?}");
}

#[test]
fn an_empty_mosaic_or_memory_is_refused() {
    use tracking::memory::{MosaicBuilder, MosaicParams, VisualMemory};
    let camera = CeilingCamera::default();
    let err = MosaicBuilder::localiser(
        camera,
        MosaicParams::default(),
        Vec::new(),
        Pose2::identity(),
        0,
    );
    assert!(err.is_err());
    let ceiling = Ceiling::generate(&CeilingParams {
        size: [3.0, 3.0],
        n_patterns: 2,
        ..Default::default()
    })
    .unwrap();
    let render = RenderParams::default();
    let world = World {
        ceiling: &ceiling,
        camera: &camera,
        render: &render,
    };
    let empty = VisualMemory {
        models: Vec::new(),
        key_images: Vec::new(),
        image_size: [320, 240],
        mosaic_covariance: None,
    };
    assert!(
        replay(
            world,
            &empty,
            Pose2::identity(),
            &ReplayParams::default(),
            0
        )
        .is_err()
    );
}
