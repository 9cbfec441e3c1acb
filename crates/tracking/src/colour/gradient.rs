//! Intensity gradients (Sobel) and Birchfield's (1998) perimeter term: the mean magnitude
//! of the gradient component normal to the ellipse, over its perimeter.

use super::ellipse::Ellipse;
use crate::frame::RgbFrame;

/// Sobel derivatives of the grey level `(R + 2G + B) / 4`; zero on the frame border.
#[derive(Debug, Clone, Default)]
pub(crate) struct GradientImage {
    gx: Vec<i16>,
    gy: Vec<i16>,
    grey: Vec<u8>,
    width: usize,
    height: usize,
}

impl GradientImage {
    /// Recomputes the gradients of `frame`, reusing the buffers.
    pub(crate) fn compute(&mut self, frame: &RgbFrame<'_>) {
        let (w, h) = (frame.width(), frame.height());
        self.width = w;
        self.height = h;
        self.grey.clear();
        self.grey.extend(
            frame
                .data()
                .chunks_exact(3)
                .map(|p| ((u16::from(p[0]) + 2 * u16::from(p[1]) + u16::from(p[2])) / 4) as u8),
        );
        self.gx.clear();
        self.gx.resize(w * h, 0);
        self.gy.clear();
        self.gy.resize(w * h, 0);
        if w < 3 || h < 3 {
            return;
        }
        for y in 1..h - 1 {
            for x in 1..w - 1 {
                self.sobel_at(x, y);
            }
        }
    }

    /// Sizes the buffers for a `w x h` frame, keeping their contents when the size holds.
    pub(crate) fn resize(&mut self, w: usize, h: usize) {
        if (self.width, self.height) != (w, h) {
            self.width = w;
            self.height = h;
            self.grey = vec![0; w * h];
            self.gx = vec![0; w * h];
            self.gy = vec![0; w * h];
        }
    }

    /// The grey level `(R + 2G + B) / 4` of pixel `(x, y)` from its RGB `p`.
    #[inline]
    pub(crate) fn set_grey(&mut self, x: usize, y: usize, p: &[u8]) {
        self.grey[y * self.width + x] =
            ((u16::from(p[0]) + 2 * u16::from(p[1]) + u16::from(p[2])) / 4) as u8;
    }

    /// The Sobel derivatives at an interior pixel from the grey levels around it.
    #[inline(always)]
    pub(crate) fn sobel_at(&mut self, x: usize, y: usize) {
        let w = self.width;
        let g = |x: usize, y: usize| i16::from(self.grey[y * w + x]);
        let gx = g(x + 1, y - 1) + 2 * g(x + 1, y) + g(x + 1, y + 1)
            - g(x - 1, y - 1)
            - 2 * g(x - 1, y)
            - g(x - 1, y + 1);
        let gy = g(x - 1, y + 1) + 2 * g(x, y + 1) + g(x + 1, y + 1)
            - g(x - 1, y - 1)
            - 2 * g(x, y - 1)
            - g(x + 1, y - 1);
        self.gx[y * w + x] = gx;
        self.gy[y * w + x] = gy;
    }

    /// The derivatives `(gx, gy)` at a pixel.
    #[cfg(test)]
    pub(crate) fn at(&self, x: usize, y: usize) -> (i16, i16) {
        let i = y * self.width + x;
        (self.gx[i], self.gy[i])
    }

    /// Birchfield's gradient score: mean over perimeter points of `|n . g|` (`n` the
    /// ellipse's unit normal), in grey levels per pixel. Points outside the frame count
    /// as zero gradient.
    pub(crate) fn perimeter_score(&self, e: &Ellipse, cx: i32, cy: i32) -> f64 {
        let mut sum = 0.0f32;
        for p in &e.perimeter {
            let (x, y) = (cx + p.dx, cy + p.dy);
            if x >= 0 && y >= 0 && (x as usize) < self.width && (y as usize) < self.height {
                let i = y as usize * self.width + x as usize;
                sum += (p.nx * f32::from(self.gx[i]) + p.ny * f32::from(self.gy[i])).abs();
            }
        }
        // Sobel responds 8 x the grey-level slope.
        f64::from(sum) / (8.0 * e.perimeter.len().max(1) as f64)
    }

    /// The same score for an ellipse of semi-axes `(a, b)` at a continuous centre,
    /// sampled in the unit-circle `directions` `(cos t, sin t)`.
    pub(crate) fn perimeter_at(
        &self,
        cx: f64,
        cy: f64,
        a: f64,
        b: f64,
        directions: &[(f64, f64)],
    ) -> f64 {
        let mut sum = 0.0;
        for &(c, s) in directions {
            let x = (cx + a * c).floor();
            let y = (cy + b * s).floor();
            if x >= 0.0 && y >= 0.0 && (x as usize) < self.width && (y as usize) < self.height {
                let i = y as usize * self.width + x as usize;
                let (nx, ny) = (c / a.max(0.5), s / b.max(0.5));
                let norm = (nx * nx + ny * ny).sqrt();
                sum += ((nx * f64::from(self.gx[i]) + ny * f64::from(self.gy[i])) / norm).abs();
            }
        }
        sum / (8.0 * directions.len().max(1) as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn disc_edge_scores_higher_on_its_boundary() {
        // A bright disc of radius 10 at (20, 20) on black.
        let (w, h) = (40usize, 40usize);
        let mut data = vec![0u8; w * h * 3];
        for y in 0..h {
            for x in 0..w {
                let d = ((x as f64 - 20.0).powi(2) + (y as f64 - 20.0).powi(2)).sqrt();
                if d <= 10.0 {
                    data[(y * w + x) * 3..(y * w + x) * 3 + 3].copy_from_slice(&[200, 200, 200]);
                }
            }
        }
        let frame = RgbFrame::new(&data, w, h).unwrap();
        let mut g = GradientImage::default();
        g.compute(&frame);
        let mut e = Ellipse::default();
        e.rebuild(10.0, 10.0, 0.5);
        let on = g.perimeter_score(&e, 20, 20);
        let off = g.perimeter_score(&e, 26, 20);
        assert!(on > 2.0 * off, "on {on} off {off}");
        // A 200-level step seen by the 3x3 Sobel spreads over about two pixels: the mean
        // normal slope on the boundary is of order 200 / 2.
        assert!(on > 40.0 && on < 200.0, "{on}");
    }
}
