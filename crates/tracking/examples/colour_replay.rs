//! Replays a raw RGB sequence through the colour trackers, for profiling
//! (`valgrind --tool=callgrind`) and timing without Python in the way.
//!
//! `cargo run --release -p tracking --example colour_replay -- FRAMES W H N X Y BW BH [pf]`
//! where FRAMES holds N frames of W x H x 3 bytes and (X, Y, BW, BH) is the first box.
//! Prints frames per second and, for the particle tracker (`pf`), the mean ESS.

use std::time::Instant;

use tracking::{
    BoundingBox, ColorHistogramTracker, ColorTrackerParams, ParticleColorTracker,
    ParticleTrackerParams, RgbFrame,
};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    assert!(args.len() >= 9, "usage: FRAMES W H N X Y BW BH [pf]");
    let bytes = std::fs::read(&args[1]).expect("frames");
    let num = |i: usize| -> f64 { args[i].parse().unwrap() };
    let (w, h, n) = (num(2) as usize, num(3) as usize, num(4) as usize);
    let bbox = BoundingBox::new(num(5), num(6), num(7), num(8));
    let frame = |k: usize| RgbFrame::new(&bytes[k * w * h * 3..][..w * h * 3], w, h).unwrap();
    let particles = args.get(9).is_some_and(|a| a == "pf");
    let start = Instant::now();
    let mut ess = 0.0;
    if particles {
        let mut t =
            ParticleColorTracker::new(frame(0), bbox, ParticleTrackerParams::default(), 0).unwrap();
        for k in 1..n {
            t.update(frame(k)).unwrap();
            ess += t.filter().ess();
        }
    } else {
        // COLOUR_PARAMS may hold a JSON object of ColorTrackerParams fields.
        let params: ColorTrackerParams = std::env::var("COLOUR_PARAMS")
            .map(|j| serde_json::from_str(&j).expect("COLOUR_PARAMS"))
            .unwrap_or_default();
        let mut t = ColorHistogramTracker::new(frame(0), bbox, params).unwrap();
        for k in 1..n {
            t.update(frame(k)).unwrap();
        }
    }
    let secs = start.elapsed().as_secs_f64();
    println!(
        "{:.1} fps, mean ESS {:.1}",
        (n - 1) as f64 / secs,
        ess / (n - 1) as f64
    );
}
