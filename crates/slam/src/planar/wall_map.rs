//! The wall map's data: each wall's seen extent on its line, and the walls the
//! filter no longer estimates. Pure geometry, without the filter: the engine holds
//! these, the wall updates (`walls.rs`) read and write them.

use nalgebra::{Matrix2, Point2, Vector2};

/// A wall the filter no longer estimates (frozen, or a wall anchor with a zero
/// covariance): observed as known, its covariance added to the noise.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct FixedWall {
    pub line: Vector2<f64>,
    pub cov: Matrix2<f64>,
}

/// A wall's seen extent, two points on its line, and its reference point, the
/// origin its state `(rho, alpha)` is measured from; all in the internal frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Extent {
    pub start: Point2<f64>,
    pub end: Point2<f64>,
    pub origin: Point2<f64>,
}

/// The foot of `p` on `line` and its coordinate along the line.
pub(super) fn along(line: &Vector2<f64>, p: &Point2<f64>) -> (Point2<f64>, f64) {
    let (s, c) = line.y.sin_cos();
    let n = Vector2::new(c, s);
    (p - n * (n.dot(&p.coords) - line.x), -s * p.x + c * p.y)
}

/// The shortest extent on `line` (frame form) covering the feet of `points`, with
/// reference point `origin`.
pub(super) fn covering(line: &Vector2<f64>, points: &[Point2<f64>], origin: Point2<f64>) -> Extent {
    let feet: Vec<(Point2<f64>, f64)> = points.iter().map(|p| along(line, p)).collect();
    let lo = feet.iter().min_by(|a, b| a.1.total_cmp(&b.1));
    let hi = feet.iter().max_by(|a, b| a.1.total_cmp(&b.1));
    let (lo, hi) = (
        lo.map_or(Point2::origin(), |f| f.0),
        hi.map_or(Point2::origin(), |f| f.0),
    );
    Extent {
        start: lo,
        end: hi,
        origin,
    }
}

/// The gap between an extent and a segment, both projected on `line` (negative when
/// they overlap).
pub(super) fn gap(line: &Vector2<f64>, a: &Extent, b: &[Point2<f64>; 2]) -> f64 {
    let t = |p: &Point2<f64>| along(line, p).1;
    let (a0, a1, b0, b1) = (t(&a.start), t(&a.end), t(&b[0]), t(&b[1]));
    a0.min(a1).max(b0.min(b1)) - a0.max(a1).min(b0.max(b1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn extents_cover_and_gaps_measure_along_the_line() {
        // The line y = 2 (rho 2, alpha pi/2): along-coordinate is -x.
        let line = Vector2::new(2.0, PI / 2.0);
        let e = covering(
            &line,
            &[
                Point2::new(1.0, 2.1),
                Point2::new(-1.0, 1.9),
                Point2::new(0.0, 2.0),
            ],
            Point2::origin(),
        );
        assert!((e.start - Point2::new(1.0, 2.0)).norm() < 1e-12);
        assert!((e.end - Point2::new(-1.0, 2.0)).norm() < 1e-12);
        let seg = [Point2::new(3.0, 2.0), Point2::new(4.0, 2.0)];
        assert!((gap(&line, &e, &seg) - 2.0).abs() < 1e-12);
        let seg = [Point2::new(0.5, 2.0), Point2::new(4.0, 2.0)];
        assert!((gap(&line, &e, &seg) + 0.5).abs() < 1e-12);
    }
}
