//! Learns an S-shaped path in the default ceiling world and replays it from perturbed
//! starts, printing the mosaic, localisation and replay errors against the truth.
//!
//! cargo run --release -p tracking --example visual_memory

use navigation::ceiling::{CeilingCamera, CeilingParams, RenderParams};
use navigation::memory::{LearnParams, ReplayParams, Scene, learn, replay};
use rperc_core::Pose2;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let scene = Scene::new(
        &CeilingParams::default(),
        CeilingCamera::default(),
        RenderParams::default(),
    )?;
    let world = scene.world();
    let start = Pose2::new(2.0, 2.0, 0.2);
    let commands: Vec<[f64; 2]> = (0..150)
        .map(|k| [0.3, if k < 75 { 0.15 } else { -0.15 }])
        .collect();
    let learnt = learn(world, start, &commands, 0.1, &LearnParams::default(), 1)?;
    let frames = learnt.seconds.len() as f64;
    println!(
        "learnt: {} models, {} key images, {:.1} ms/frame",
        learnt.memory.models.len(),
        learnt.memory.key_images.len(),
        1e3 * learnt.seconds.iter().sum::<f64>() / frames
    );
    let w_t_m = learnt
        .mosaic_in_world(&scene.camera)
        .ok_or("no model in the mosaic")?;
    let mut worst = (0.0f64, 0.0f64);
    for (report, truth) in learnt.reports.iter().zip(&learnt.truth) {
        if let (Some(p), false) = (report.pose, report.lost) {
            let e = w_t_m.compose(&p).between(truth);
            worst = (worst.0.max(e.x.hypot(e.y)), worst.1.max(e.theta.abs()));
        }
    }
    println!(
        "learning localisation, worst frame: {:.3} m, {:.2} deg",
        worst.0,
        worst.1.to_degrees()
    );
    let b = learnt.truth.last().copied().unwrap_or(start);
    for (dx, dy, dth) in [(0.0, 0.0, 0.0), (0.1, -0.1, 0.1), (-0.1, 0.15, -0.15)] {
        let s = start.compose(&Pose2::new(dx, dy, dth));
        let run = replay(world, &learnt.memory, s, &ReplayParams::default(), 3)?;
        let end = run.truth.last().copied().unwrap_or(s).between(&b);
        println!(
            "replay from ({dx}, {dy}, {dth}): {:?} after {} frames, {:.3} m from B, {:.1} ms/frame",
            run.outcome,
            run.truth.len(),
            end.x.hypot(end.y),
            1e3 * run.seconds.iter().sum::<f64>() / run.seconds.len() as f64,
        );
    }
    Ok(())
}
