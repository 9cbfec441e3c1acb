//! Elliptical regions as per-row spans around an integer centre, and their perimeter.

/// One point of the perimeter: offset from the centre and the outward unit normal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct PerimeterPoint {
    pub(crate) dx: i32,
    pub(crate) dy: i32,
    pub(crate) nx: f32,
    pub(crate) ny: f32,
}

/// An axis-aligned ellipse of semi-axes `a` (horizontal) and `b` (vertical) rasterised
/// around an integer centre `(cx, cy)`: row `cy + dy` (|dy| <= `ry`) holds pixels
/// `cx - half(dy) ..= cx + half(dy)`.
#[derive(Debug, Clone, Default)]
pub(crate) struct Ellipse {
    pub(crate) a: f64,
    pub(crate) b: f64,
    pub(crate) ry: i32,
    half: Vec<i32>,
    pub(crate) n_pixels: usize,
    /// Rows `dy < upper_end` form the upper part of a bimodal model.
    pub(crate) upper_end: i32,
    pub(crate) perimeter: Vec<PerimeterPoint>,
}

/// Half-width of row `dy` of an ellipse with semi-axes `a`, `b`.
#[inline]
pub(crate) fn half_width(a: f64, b: f64, dy: i32) -> i32 {
    let t = dy as f64 / b;
    (a * (1.0 - t * t).max(0.0).sqrt()).floor() as i32
}

/// Vertical pixel radius of an ellipse of vertical semi-axis `b`: rows `-ry..=ry`.
#[inline]
pub(crate) fn vertical_radius(b: f64) -> i32 {
    // A box of height h covers h rows; 2 ry + 1 of them are the closest odd count.
    ((b - 0.5).round() as i32).max(0)
}

impl Ellipse {
    /// Rebuilds the rows and perimeter in place (no allocation once grown).
    pub(crate) fn rebuild(&mut self, a: f64, b: f64, upper_fraction: f64) {
        self.a = a;
        self.b = b;
        self.ry = vertical_radius(b);
        self.half.clear();
        self.n_pixels = 0;
        // Semi-axes grown by half a pixel so a w x h box's inscribed ellipse spans w columns.
        let (ae, be) = (a - 0.5, b.max(0.5));
        for dy in -self.ry..=self.ry {
            let h = half_width(ae.max(0.0), be, dy);
            self.half.push(h);
            self.n_pixels += (2 * h + 1) as usize;
        }
        self.upper_end = -self.ry + ((2 * self.ry + 1) as f64 * upper_fraction).round() as i32;
        // Birchfield samples the perimeter densely enough to see every boundary pixel.
        let n = ((std::f64::consts::PI * (a + b)).ceil() as usize).clamp(8, 256);
        self.perimeter.clear();
        for k in 0..n {
            let t = 2.0 * std::f64::consts::PI * k as f64 / n as f64;
            let (s, c) = t.sin_cos();
            let (nx, ny) = (c / a.max(0.5), s / b.max(0.5));
            let norm = (nx * nx + ny * ny).sqrt();
            self.perimeter.push(PerimeterPoint {
                dx: (a * c).round() as i32,
                dy: (b * s).round() as i32,
                nx: (nx / norm) as f32,
                ny: (ny / norm) as f32,
            });
        }
    }

    /// Half-width of row `dy`, or `None` outside the ellipse.
    #[inline]
    pub(crate) fn half(&self, dy: i32) -> Option<i32> {
        if dy.abs() <= self.ry {
            Some(self.half[(dy + self.ry) as usize])
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pixel_count_approaches_the_area() {
        let mut e = Ellipse::default();
        for (a, b) in [(20.0, 30.0), (15.5, 22.5), (40.0, 12.0)] {
            e.rebuild(a, b, 0.5);
            let area = std::f64::consts::PI * a * b;
            // The pixelised ellipse differs from pi a b by at most about one perimeter.
            let perimeter = std::f64::consts::PI * (a + b) * 2.0;
            assert!(
                (e.n_pixels as f64 - area).abs() < perimeter,
                "{a} {b}: {} vs {area}",
                e.n_pixels
            );
        }
    }

    #[test]
    fn box_of_odd_size_is_covered_exactly() {
        // 5 x 3 box: rows -1..=1, middle row 5 wide.
        let mut e = Ellipse::default();
        e.rebuild(2.5, 1.5, 0.5);
        assert_eq!(e.ry, 1);
        assert_eq!(e.half(0), Some(2));
        assert_eq!(e.half(2), None);
    }
}
