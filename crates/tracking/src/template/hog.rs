//! Histograms of oriented gradients on square cells (Dalal & Triggs 2005), in the
//! block-normalised, truncated form of Felzenszwalb et al. (2010) that Staple and DSST
//! use, contrast-insensitive only, plus one channel of the cell's mean intensity: a
//! cheap descriptor of the target's layout that the colour histogram lacks.

/// Contrast-insensitive orientation bins over [0, pi).
pub(crate) const ORIENTATIONS: usize = 9;
/// Feature channels per cell: the orientations and the mean intensity.
pub(crate) const CHANNELS: usize = ORIENTATIONS + 1;
/// Felzenszwalb's truncation of each block-normalised value: no single strong edge
/// dominates the cell.
const TRUNCATION: f32 = 0.2;

/// A stack of per-cell feature planes, channel-major (`data[c][y * width + x]`).
#[derive(Debug, Clone, Default)]
pub(crate) struct FeatureMap {
    /// Cells across.
    pub(crate) width: usize,
    /// Cells down.
    pub(crate) height: usize,
    /// One plane per channel.
    pub(crate) planes: Vec<Vec<f32>>,
}

impl FeatureMap {
    fn reset(&mut self, width: usize, height: usize, channels: usize) {
        self.width = width;
        self.height = height;
        self.planes.resize_with(channels, Vec::new);
        for p in &mut self.planes {
            p.clear();
            p.resize(width * height, 0.0);
        }
    }
}

/// Gradient magnitude and orientation of pixel `(x, y)` by central differences
/// (one-sided at the border).
fn gradient(grey: &[f32], width: usize, height: usize, x: usize, y: usize) -> (f32, f32) {
    let at = |xx: usize, yy: usize| grey[yy * width + xx];
    let gx = at((x + 1).min(width - 1), y) - at(x.saturating_sub(1), y);
    let gy = at(x, (y + 1).min(height - 1)) - at(x, y.saturating_sub(1));
    let magnitude = (gx * gx + gy * gy).sqrt();
    (magnitude, unsigned_angle(gx, gy))
}

/// The direction of `(gx, gy)` modulo pi, in [0, pi): a polynomial arctangent (error
/// below 1e-5 rad, Abramowitz-Stegun style minimax on [0, 1]) instead of `atan2`, which
/// was half the cost of a HOG map.
#[inline]
pub(crate) fn unsigned_angle(gx: f32, gy: f32) -> f32 {
    use std::f32::consts::{FRAC_PI_2, PI};
    let (ax, ay) = (gx.abs(), gy.abs());
    if ax == 0.0 && ay == 0.0 {
        return 0.0;
    }
    let (num, den) = if ax >= ay { (ay, ax) } else { (ax, ay) };
    let t = num / den;
    let t2 = t * t;
    let p = t
        * (0.999_977_3
            + t2 * (-0.332_623_5
                + t2 * (0.193_543_5
                    + t2 * (-0.116_432_9 + t2 * (0.052_653_3 + t2 * -0.011_721_2)))));
    // Unfold the octant, then fold the full angle onto [0, pi).
    let first_quadrant = if ax >= ay { p } else { FRAC_PI_2 - p };
    let theta = if (gx >= 0.0) == (gy >= 0.0) {
        first_quadrant
    } else {
        PI - first_quadrant
    };
    if theta >= PI { 0.0 } else { theta }
}

/// Splits a magnitude between the two orientation bins whose centres bracket `theta`
/// (linear interpolation, so the histogram changes smoothly as an edge turns).
#[inline]
pub(crate) fn orientation_votes(theta: f32) -> [(usize, f32); 2] {
    let width = std::f32::consts::PI / ORIENTATIONS as f32;
    let t = theta / width - 0.5;
    // The floor without libm's call (the baseline x86-64 target has no rounding
    // instruction, and this runs for every pixel): truncate, one less below zero.
    let truncated = t as i32;
    let lower = truncated - i32::from(truncated as f32 > t);
    let frac = t - lower as f32;
    let b0 = lower.rem_euclid(ORIENTATIONS as i32) as usize;
    let b1 = (b0 + 1) % ORIENTATIONS;
    [(b0, 1.0 - frac), (b1, frac)]
}

/// Per-cell orientation histograms (magnitude-weighted) and mean intensities of a
/// `width x height` grey image in [0, 1]; cells of `cell` pixels (the image is cut to
/// whole cells).
///
/// Each cell is summed on its own, its pixels in raster order, from zero: every sum
/// adds the same terms in the same order as a plain per-pixel loop over the image
/// would. The loop is only arranged so that a cell's sums stay in a small local array
/// (not in ten planes of the map), a pixel costs no division by the cell size and,
/// inside the image, no clamping of its neighbours.
pub(crate) fn cell_histograms(
    grey: &[f32],
    width: usize,
    height: usize,
    cell: usize,
    out: &mut FeatureMap,
) {
    let (cw, ch) = (width / cell, height / cell);
    out.reset(cw, ch, CHANNELS);
    let area = (cell * cell) as f32;
    for cy in 0..ch {
        for cx in 0..cw {
            let mut sums = [0.0f32; CHANNELS];
            for y in cy * cell..(cy + 1) * cell {
                let inner_row = y > 0 && y + 1 < height;
                for x in cx * cell..(cx + 1) * cell {
                    let (magnitude, theta) = if inner_row && x > 0 && x + 1 < width {
                        interior_gradient(grey, width, x, y)
                    } else {
                        gradient(grey, width, height, x, y)
                    };
                    for (bin, weight) in orientation_votes(theta) {
                        sums[bin] += magnitude * weight;
                    }
                    sums[ORIENTATIONS] += grey[y * width + x] / area;
                }
            }
            let k = cy * cw + cx;
            for (plane, sum) in out.planes.iter_mut().zip(sums) {
                plane[k] = sum;
            }
        }
    }
}

/// [`gradient`] at a pixel with all four neighbours inside the image: the same
/// differences, without the border's clamping.
#[inline(always)]
fn interior_gradient(grey: &[f32], width: usize, x: usize, y: usize) -> (f32, f32) {
    let k = y * width + x;
    let gx = grey[k + 1] - grey[k - 1];
    let gy = grey[k + width] - grey[k - width];
    ((gx * gx + gy * gy).sqrt(), unsigned_angle(gx, gy))
}

/// Normalises each cell's orientation histogram by the energy of the four 2 x 2 blocks
/// that contain it, truncates at [`TRUNCATION`] and averages the four (Felzenszwalb
/// et al. 2010, section 6.1): invariance to local contrast. The intensity channel is
/// centred on zero so the filter does not learn a constant offset.
pub(crate) fn normalise(map: &mut FeatureMap) {
    let (w, h) = (map.width, map.height);
    if w == 0 || h == 0 {
        return; // no cell (a patch under one cell): nothing to normalise
    }
    let norms = block_norms(map);
    // Block `(bx, by)` covers cells `bx - 1 ..= bx` by `by - 1 ..= by`.
    let at = |bx: usize, by: usize| norms[by * (w + 1) + bx];
    for y in 0..h {
        for x in 0..w {
            let four = [at(x, y), at(x + 1, y), at(x, y + 1), at(x + 1, y + 1)];
            let k = y * w + x;
            for plane in &mut map.planes[..ORIENTATIONS] {
                let v = plane[k];
                plane[k] = 0.5 * four.iter().map(|n| (v * n).min(TRUNCATION)).sum::<f32>();
            }
            map.planes[ORIENTATIONS][k] -= 0.5;
        }
    }
}

/// `1 / sqrt(energy + 1e-4)` of every 2 x 2 block of cells, the blocks of the map's
/// corners and edges reaching one cell beyond it (clamped: its edge cells again), in a
/// `(w + 1) x (h + 1)` grid: block `(bx, by)` sums the cells `bx - 1 ..= bx`, `by - 1
/// ..= by`. Each block is shared by four cells, so it is computed once, not four times.
fn block_norms(map: &FeatureMap) -> Vec<f32> {
    let (w, h) = (map.width, map.height);
    let energy: Vec<f32> = (0..w * h)
        .map(|k| map.planes[..ORIENTATIONS].iter().map(|p| p[k] * p[k]).sum())
        .collect();
    let e = |x: isize, y: isize| {
        let xx = x.clamp(0, w as isize - 1) as usize;
        let yy = y.clamp(0, h as isize - 1) as usize;
        energy[yy * w + xx]
    };
    let mut norms = Vec::with_capacity((w + 1) * (h + 1));
    for by in 0..=h as isize {
        for bx in 0..=w as isize {
            let block = e(bx - 1, by - 1) + e(bx, by - 1) + e(bx - 1, by) + e(bx, by);
            norms.push(1.0 / (block + 1e-4).sqrt());
        }
    }
    norms
}

/// The normalised HOG + intensity features of a grey image: [`cell_histograms`] then
/// [`normalise`].
pub(crate) fn features(
    grey: &[f32],
    width: usize,
    height: usize,
    cell: usize,
    out: &mut FeatureMap,
) {
    cell_histograms(grey, width, height, cell, out);
    normalise(out);
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    proptest! {
        /// A linear ramp `a x + b y` has the same gradient everywhere: inside the image
        /// every pixel votes |grad| = 2 sqrt(a^2 + b^2) (central difference over two
        /// pixels) split between the bins bracketing atan2(b, a) mod pi, which the
        /// oracle computes from the closed form, independently of the code's binning.
        #[test]
        fn a_ramp_votes_for_its_direction(angle in 0.0f64..std::f64::consts::PI, slope in 0.001f64..0.01) {
            let (a, b) = (slope * angle.cos(), slope * angle.sin());
            let (w, h, cell) = (24usize, 24usize, 4usize);
            let grey: Vec<f32> = (0..w * h)
                .map(|k| (0.3 + a * (k % w) as f64 + b * (k / w) as f64) as f32)
                .collect();
            let mut map = FeatureMap::default();
            cell_histograms(&grey, w, h, cell, &mut map);
            // The oracle: the bin centres are (i + 0.5) pi / 9; the weight of bin i is
            // max(0, 1 - |angular distance to its centre| / bin width), cyclic over pi.
            let bin_width = std::f64::consts::PI / ORIENTATIONS as f64;
            let magnitude = 2.0 * slope * 16.0;
            let k = 2 * map.width + 2; // an interior cell: no one-sided differences
            for i in 0..ORIENTATIONS {
                let centre = (i as f64 + 0.5) * bin_width;
                let mut d = (angle - centre).abs();
                d = d.min(std::f64::consts::PI - d);
                let expected = magnitude * (1.0 - d / bin_width).max(0.0);
                prop_assert!((f64::from(map.planes[i][k]) - expected).abs() < 1e-3 * magnitude + 1e-6,
                    "bin {i}: {} vs {expected}", map.planes[i][k]);
            }
        }

        /// The normalised values are bounded: each of the four terms is at most the
        /// truncation, and the mean intensity of a [0, 1] image lies in [-0.5, 0.5].
        #[test]
        fn normalised_features_are_bounded(seed in 0u64..500) {
            let mut rng = rperc_core::rng::seeded(seed);
            let (w, h) = (20usize, 16usize);
            let grey: Vec<f32> = (0..w * h).map(|_| rand::Rng::random_range(&mut rng, 0.0..1.0)).collect();
            let mut map = FeatureMap::default();
            features(&grey, w, h, 4, &mut map);
            prop_assert_eq!((map.width, map.height), (5, 4));
            for plane in &map.planes[..ORIENTATIONS] {
                prop_assert!(plane.iter().all(|&v| (0.0..=2.0 * TRUNCATION + 1e-6).contains(&v)));
            }
            prop_assert!(map.planes[ORIENTATIONS].iter().all(|&v| (-0.5..=0.5).contains(&v)));
        }
    }

    /// The histograms equal those of the plain loop (every pixel through the
    /// clamped [`gradient`], its cell by division), bit for bit, on images whose
    /// sides are and are not whole cells.
    #[test]
    fn histograms_equal_the_plain_per_pixel_loop() {
        let mut rng = rperc_core::rng::seeded(7);
        for (w, h, cell) in [
            (20usize, 16usize, 4usize),
            (23, 17, 4),
            (9, 9, 3),
            (6, 5, 6),
        ] {
            let grey: Vec<f32> = (0..w * h)
                .map(|_| rand::Rng::random_range(&mut rng, 0.0..1.0))
                .collect();
            let mut map = FeatureMap::default();
            cell_histograms(&grey, w, h, cell, &mut map);
            let (cw, ch) = (w / cell, h / cell);
            let mut planes = vec![vec![0.0f32; cw * ch]; CHANNELS];
            for y in 0..ch * cell {
                for x in 0..cw * cell {
                    let k = (y / cell) * cw + x / cell;
                    let (magnitude, theta) = gradient(&grey, w, h, x, y);
                    for (bin, weight) in orientation_votes(theta) {
                        planes[bin][k] += magnitude * weight;
                    }
                    planes[ORIENTATIONS][k] += grey[y * w + x] / (cell * cell) as f32;
                }
            }
            let bits = |p: &[Vec<f32>]| -> Vec<Vec<u32>> {
                p.iter()
                    .map(|v| v.iter().map(|g| g.to_bits()).collect())
                    .collect()
            };
            assert_eq!(bits(&map.planes), bits(&planes), "{w} x {h}, cell {cell}");
        }
    }

    /// The normalisation equals the per-cell form (each cell's four blocks summed
    /// from the clamped energies on the spot), bit for bit, on maps of one cell, a
    /// row, and several rows.
    #[test]
    fn normalise_equals_the_per_cell_blocks() {
        let mut rng = rperc_core::rng::seeded(11);
        for (w, h) in [(1usize, 1usize), (5, 1), (6, 4), (0, 3)] {
            let mut map = FeatureMap::default();
            map.reset(w, h, CHANNELS);
            for p in &mut map.planes {
                p.iter_mut()
                    .for_each(|v| *v = rand::Rng::random_range(&mut rng, 0.0..2.0));
            }
            let mut expected = map.planes.clone();
            let energy: Vec<f32> = (0..w * h)
                .map(|k| expected[..ORIENTATIONS].iter().map(|p| p[k] * p[k]).sum())
                .collect();
            let e = |x: isize, y: isize| {
                energy
                    [y.clamp(0, h as isize - 1) as usize * w + x.clamp(0, w as isize - 1) as usize]
            };
            for y in 0..h as isize {
                for x in 0..w as isize {
                    let norms = [(-1, -1), (0, -1), (-1, 0), (0, 0)].map(|(dx, dy)| {
                        let block = e(x + dx, y + dy)
                            + e(x + dx + 1, y + dy)
                            + e(x + dx, y + dy + 1)
                            + e(x + dx + 1, y + dy + 1);
                        1.0 / (block + 1e-4).sqrt()
                    });
                    let k = y as usize * w + x as usize;
                    for plane in &mut expected[..ORIENTATIONS] {
                        let v = plane[k];
                        plane[k] = 0.5 * norms.iter().map(|n| (v * n).min(TRUNCATION)).sum::<f32>();
                    }
                    expected[ORIENTATIONS][k] -= 0.5;
                }
            }
            normalise(&mut map);
            let bits = |p: &[Vec<f32>]| -> Vec<Vec<u32>> {
                p.iter()
                    .map(|v| v.iter().map(|g| g.to_bits()).collect())
                    .collect()
            };
            assert_eq!(bits(&map.planes), bits(&expected), "{w} x {h}");
        }
    }

    proptest! {
        /// The polynomial arctangent agrees with `atan2` folded onto [0, pi).
        #[test]
        fn unsigned_angle_matches_atan2(gx in -10.0f32..10.0, gy in -10.0f32..10.0) {
            prop_assume!(gx.abs() + gy.abs() > 1e-6);
            let mut expected = f64::from(gy).atan2(f64::from(gx));
            if expected < 0.0 {
                expected += std::f64::consts::PI;
            }
            let got = f64::from(unsigned_angle(gx, gy));
            let d = (got - expected).abs();
            prop_assert!(d.min(std::f64::consts::PI - d) < 2e-5, "{got} vs {expected}");
        }
    }

    /// The votes equal those computed with libm's floor (the oracle), across [0, pi)
    /// and at every bin's edge and centre, where the floor changes.
    #[test]
    fn votes_equal_the_floor_based_split() {
        let width = std::f32::consts::PI / ORIENTATIONS as f32;
        let mut thetas: Vec<f32> = (0..20_000)
            .map(|k| k as f32 * std::f32::consts::PI / 20_000.0)
            .collect();
        for b in 0..=2 * ORIENTATIONS {
            let edge = b as f32 * width / 2.0;
            thetas.extend([edge, edge.next_up(), edge.next_down().max(0.0)]);
        }
        for theta in thetas {
            let t = theta / width - 0.5;
            let lower = t.floor();
            let b0 = (lower as isize).rem_euclid(ORIENTATIONS as isize) as usize;
            let expected = [
                (b0, 1.0 - (t - lower)),
                ((b0 + 1) % ORIENTATIONS, t - lower),
            ];
            assert_eq!(orientation_votes(theta), expected, "theta {theta}");
        }
    }

    /// A flat image has no gradient anywhere.
    #[test]
    fn a_flat_image_has_empty_histograms() {
        let grey = vec![0.7f32; 16 * 16];
        let mut map = FeatureMap::default();
        features(&grey, 16, 16, 4, &mut map);
        assert!(
            map.planes[..ORIENTATIONS]
                .iter()
                .flatten()
                .all(|&v| v == 0.0)
        );
        assert!(
            map.planes[ORIENTATIONS]
                .iter()
                .all(|&v| (v - 0.2).abs() < 1e-6)
        );
    }
}
