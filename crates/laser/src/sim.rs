//! Simulated scans: beams ray-cast against line segments, for the crate's tests,
//! benchmarks and the NEES checks of its covariances.

use nalgebra::Vector2;
use rperc_core::Pose2;

/// A wall: a segment from `a` to `b`, m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    /// One end.
    pub a: Vector2<f64>,
    /// The other end.
    pub b: Vector2<f64>,
}

impl Segment {
    /// The segment from `(ax, ay)` to `(bx, by)`.
    pub fn new(ax: f64, ay: f64, bx: f64, by: f64) -> Self {
        Segment {
            a: Vector2::new(ax, ay),
            b: Vector2::new(bx, by),
        }
    }
}

/// The distance along the ray from `o` in unit direction `d` to `s`, if it hits.
fn hit(o: &Vector2<f64>, d: &Vector2<f64>, s: &Segment) -> Option<f64> {
    let e = s.b - s.a;
    let denom = d.x * e.y - d.y * e.x;
    if denom.abs() < 1e-15 {
        return None;
    }
    let w = s.a - o;
    let t = (w.x * e.y - w.y * e.x) / denom;
    let u = (w.x * d.y - w.y * d.x) / denom;
    (t > 0.0 && (0.0..=1.0).contains(&u)).then_some(t)
}

/// The ranges a laser at `pose` reads at `angles` (laser frame, rad): the nearest
/// segment hit, or `max_range` (no return) when none is nearer.
pub fn ray_cast(segments: &[Segment], pose: &Pose2, angles: &[f64], max_range: f64) -> Vec<f64> {
    let o = Vector2::new(pose.x, pose.y);
    angles
        .iter()
        .map(|a| {
            let th = pose.theta + a;
            let d = Vector2::new(th.cos(), th.sin());
            segments
                .iter()
                .filter_map(|s| hit(&o, &d, s))
                .fold(max_range, f64::min)
        })
        .collect()
}

/// The walls of a rectangular room `w x h` m with its corner at the origin, and a
/// few boxes inside so that every pose sees structure in every direction.
pub fn cluttered_room(w: f64, h: f64) -> Vec<Segment> {
    let mut walls = vec![
        Segment::new(0.0, 0.0, w, 0.0),
        Segment::new(w, 0.0, w, h),
        Segment::new(w, h, 0.0, h),
        Segment::new(0.0, h, 0.0, 0.0),
    ];
    for &(x, y, s) in &[(0.25, 0.3, 0.6), (0.7, 0.6, 0.8), (0.45, 0.75, 0.4)] {
        let (cx, cy) = (x * w, y * h);
        walls.push(Segment::new(cx, cy, cx + s, cy));
        walls.push(Segment::new(cx + s, cy, cx + s, cy + s));
        walls.push(Segment::new(cx + s, cy + s, cx, cy + s));
        walls.push(Segment::new(cx, cy + s, cx, cy));
    }
    walls
}

/// A straight corridor `length` m long and `width` m wide along x, with no feature
/// along it: a scan fixes the cross-corridor position and the heading, never the
/// position along it.
pub fn corridor(length: f64, width: f64) -> Vec<Segment> {
    vec![
        Segment::new(-length / 2.0, -width / 2.0, length / 2.0, -width / 2.0),
        Segment::new(-length / 2.0, width / 2.0, length / 2.0, width / 2.0),
    ]
}
