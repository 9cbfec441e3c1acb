//! Replays a raw RGB sequence through the colour+shape tracker, for profiling
//! (`valgrind --tool=callgrind`) and timing without Python in the way.
//!
//! `cargo run --release -p tracking --example colour_shape_replay -- FRAMES W H N OUTLINE`
//! where FRAMES holds N frames of W x H x 3 bytes and OUTLINE is a text file of
//! `x y` lines (the target's outline in frame 0). Prints frames per second, the mean
//! score and the lost count; with a seventh argument, writes each frame's contour there
//! as one line of `x y` pairs.

use std::time::Instant;

use tracking::{ColorShapeParams, ColorShapeTracker, RgbFrame};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    assert!(
        args.len() >= 6,
        "usage: FRAMES W H N OUTLINE [opponent|rgb]"
    );
    let bytes = std::fs::read(&args[1]).expect("frames");
    let (w, h, n): (usize, usize, usize) = (
        args[2].parse().unwrap(),
        args[3].parse().unwrap(),
        args[4].parse().unwrap(),
    );
    let outline: Vec<[f64; 2]> = std::fs::read_to_string(&args[5])
        .expect("outline")
        .lines()
        .map(|l| {
            let v: Vec<f64> = l.split_whitespace().map(|s| s.parse().unwrap()).collect();
            [v[0], v[1]]
        })
        .collect();
    // COLOUR_SHAPE_PARAMS may hold a JSON object of ColorShapeParams fields.
    let mut params: ColorShapeParams = std::env::var("COLOUR_SHAPE_PARAMS")
        .map(|j| serde_json::from_str(&j).expect("COLOUR_SHAPE_PARAMS"))
        .unwrap_or_default();
    if let Some(space) = args.get(6) {
        params.color_space = space.parse().unwrap();
    }
    let frame = |k: usize| RgbFrame::new(&bytes[k * w * h * 3..][..w * h * 3], w, h).unwrap();
    let mut t = ColorShapeTracker::new(frame(0), &outline, params).unwrap();
    let (mut lost, mut score) = (0, 0.0);
    let mut contours = String::new();
    let start = Instant::now();
    for k in 1..n {
        let r = t.update(frame(k)).unwrap();
        lost += usize::from(r.lost);
        score += r.score;
        for p in &r.contour {
            contours.push_str(&format!("{} {} ", p[0], p[1]));
        }
        contours.push('\n');
    }
    let secs = start.elapsed().as_secs_f64();
    if let Some(path) = args.get(7) {
        std::fs::write(path, contours).expect("contours");
    }
    println!(
        "{:.1} fps, mean score {:.3}, lost {lost} of {}",
        (n - 1) as f64 / secs,
        score / (n - 1) as f64,
        n - 1
    );
}
