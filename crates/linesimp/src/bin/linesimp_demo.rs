//! Demo: wall extraction from a simulated scan of a square room, and path-hull
//! Douglas-Peucker on a 10^6-point zig-zag (the plain algorithm's quadratic case).
//!
//! `cargo run --release -p linesimp --bin linesimp_demo`

use std::f64::consts::PI;
use std::time::Instant;

use linesimp::{LineExtractor, Method, Metric, ScanParams, Simplifier};
use nalgebra::Point2;

/// Range from the origin along `phi` to the walls x = +-4, y = +-3 (a 8 m x 6 m room).
fn room_range(phi: f64) -> f64 {
    let (s, c) = phi.sin_cos();
    let tx = if c.abs() > 1e-12 {
        4.0 / c.abs()
    } else {
        f64::INFINITY
    };
    let ty = if s.abs() > 1e-12 {
        3.0 / s.abs()
    } else {
        f64::INFINITY
    };
    tx.min(ty)
}

fn main() {
    let angles: Vec<f64> = (0..361)
        .map(|k| -PI / 2.0 + PI * k as f64 / 360.0)
        .collect();
    // Deterministic pseudo-noise of about 1 cm, so the demo needs no RNG crate.
    let ranges: Vec<f64> = angles
        .iter()
        .enumerate()
        .map(|(k, &a)| room_range(a) + 0.01 * (((k * 7919) % 101) as f64 / 50.0 - 1.0))
        .collect();
    let mut extractor = LineExtractor::new(ScanParams::default());
    let walls = extractor.extract(&ranges, &angles).expect("valid scan");
    println!("simulated 361-beam scan of an 8 m x 6 m room (sensor at the centre, facing +x):");
    println!(
        "  true walls in view: x = 4 (rho 4, alpha 0), y = 3 (rho 3, alpha 90), y = -3 (rho 3, alpha -90)"
    );
    for w in &walls {
        println!(
            "  wall rho = {:.3} m +- {:.3}, alpha = {:7.2} deg +- {:.2}, length {:.2} m, {} points",
            w.rho,
            w.cov[(0, 0)].sqrt(),
            w.alpha.to_degrees(),
            w.cov[(1, 1)].sqrt().to_degrees(),
            w.length(),
            w.indices.len()
        );
    }

    let n = 1_000_000;
    let zigzag: Vec<Point2<f64>> = (0..n)
        .map(|i| Point2::new(i as f64, if i % 2 == 0 { i as f64 } else { -(i as f64) }))
        .collect();
    let t = Instant::now();
    let kept = Simplifier::new(Method::Hull, Metric::Line)
        .indices(&zigzag, 1e-9)
        .expect("finite input");
    println!(
        "path-hull Douglas-Peucker on a {n}-point zig-zag: kept {} points in {:.0} ms",
        kept.len(),
        t.elapsed().as_secs_f64() * 1e3
    );
}
