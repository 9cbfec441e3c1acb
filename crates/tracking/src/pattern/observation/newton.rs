//! Gauss-Newton normal equations of eq. 6, for the tracker's fine refinement.
//!
//! With the parabola deviation, a point's term of eq. 6 is `lambda^2 = (1 - C) / a`,
//! and for mean-removed unit vectors `1 - C = |a^ - o^|^2 / 2`: eq. 6 is a weighted
//! least-squares cost in the normalised observed vectors `o^(X)`, the cost ECC
//! minimises for a whole window. Its Gauss-Newton step needs the derivative of every
//! observed grey level with respect to the state, `grad I . dp/dX`, read from the
//! same bilinear interpolant the likelihood samples (one pass over the points gives
//! the whole 4 x 4 system, where a coordinate search spends a dozen likelihoods per
//! round).

use nalgebra::{SMatrix, SVector};
use rperc_core::image::GrayImage;

use super::{PatternLikelihood, PointGeometry};
use crate::pattern::model::{DeviationModel, segment};

/// The quadratic model `L(X + d) ~ L(X) + gradient . d - d' hessian d / 2` of the
/// log-likelihood of eq. 6 around a state, over its unoccluded points (the occluded
/// ones are constant at the threshold).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NormalEquations {
    /// The exact gradient of the log-likelihood (per pixel, pixel, radian, scale unit).
    pub gradient: SVector<f64, 4>,
    /// The Gauss-Newton approximation of minus its Hessian (positive semi-definite).
    pub hessian: SMatrix<f64, 4, 4>,
    /// Model points that took part (inside the frame, not occluded).
    pub points: usize,
}

/// Samples of a profile read at once (a stack buffer: profiles are usually 12 long).
const SAMPLES_AT_ONCE: usize = 32;

impl PointSums {
    /// One sample: stored level `a`, observed level `value` and its derivatives `d`.
    /// Whole rows of four, which the compiler keeps in vector registers (the full
    /// outer product costs less than its upper triangle, element by element).
    #[inline]
    fn add(&mut self, a: f32, value: f32, d: [f32; 4]) {
        for (k, &dk) in d.iter().enumerate() {
            self.d[k] += dk;
            self.ad[k] += a * dk;
            self.od[k] += value * dk;
        }
        for (row, &dk) in self.dd.iter_mut().zip(&d) {
            for (entry, &dm) in row.iter_mut().zip(&d) {
                *entry += dk * dm;
            }
        }
        self.o += value;
        self.oo += value * value;
        self.ao += a * value;
    }
}

/// A state's similarity in its scale-space level's pixels.
struct Placement<'a> {
    image: &'a GrayImage,
    centre: [f64; 2],
    /// `(sin theta, cos theta)`.
    rotation: [f64; 2],
    scale: f64,
}

/// Sums over one point's samples of the derivatives `D_k = d o_l / d X_k` of its
/// observed grey levels: `sum D_k`, `sum D_k D_m`, `sum a_l D_k`, `sum o_l D_k`, and of
/// the levels themselves. In `f32`, as the likelihood's own sums: a dozen terms of
/// grey levels and their gradients lose about 1e-6 of each.
#[derive(Default)]
struct PointSums {
    d: [f32; 4],
    dd: [[f32; 4]; 4],
    ad: [f32; 4],
    od: [f32; 4],
    o: f32,
    oo: f32,
    ao: f32,
}

impl PatternLikelihood<'_> {
    /// The Gauss-Newton normal equations of the log-likelihood at `state` (see
    /// [`NormalEquations`]); `None` for the line deviation model (its `lambda^2` is
    /// quartic in the vectors, not a least-squares cost), a degenerate state, or no
    /// point left.
    pub fn normal_equations(&self, state: &SVector<f64, 4>) -> Option<NormalEquations> {
        let config = &self.model.config;
        if config.deviation != DeviationModel::Parabola
            || self.space.is_empty()
            || !state.iter().all(|v| v.is_finite())
            || state[3] <= 0.0
        {
            return None;
        }
        let threshold = config.occlusion_threshold * config.occlusion_threshold;
        let inv = 1.0 / (2.0 * config.sigma * config.sigma);
        let (mut gradient, mut hessian) =
            (SVector::<f64, 4>::zeros(), SMatrix::<f64, 4, 4>::zeros());
        let mut points = 0;
        let (image, origin) = self.space.level_at(state[3]);
        let (sin, cos) = state[2].sin_cos();
        let placement = Placement {
            image,
            centre: [state[0] - origin[0], state[1] - origin[1]],
            rotation: [sin, cos],
            scale: state[3],
        };
        for geometry in self.points() {
            let Some(sums) = self.point_sums(&placement, geometry) else {
                continue;
            };
            let Some((g, h)) = self.point_terms(geometry, &sums, threshold) else {
                continue;
            };
            gradient += g * inv;
            hessian += h * inv;
            points += 1;
        }
        (points > 0).then_some(NormalEquations {
            gradient,
            hessian,
            points,
        })
    }

    /// The sums of [`PointSums`] for one point placed by `placement`; `None` when a sample
    /// leaves the frame.
    fn point_sums(&self, placement: &Placement<'_>, geometry: &PointGeometry) -> Option<PointSums> {
        let config = &self.model.config;
        let Placement {
            image,
            centre,
            rotation: [sin, cos],
            scale,
        } = *placement;
        let (p, direction) = geometry.placed(centre, [sin, cos], scale);
        let (start, delta) = segment(p, direction, config.delta * scale, config.n_samples);
        let stored = &self.model.points[geometry.index].vector;
        let mut sums = PointSums::default();
        let inverse_scale = (1.0 / scale) as f32;
        // The first sample's place relative to the centre, and the step between two:
        // d p / d theta = (q_y, -q_x), d p / d s = q / s (the profile's step grows
        // with s too).
        let q0 = [(start[0] - centre[0]) as f32, (start[1] - centre[1]) as f32];
        let step = [delta[0] as f32, delta[1] as f32];
        let mut first = None;
        let mut samples = [[0.0f32; 3]; SAMPLES_AT_ONCE];
        for (c, chunk) in stored.chunks(SAMPLES_AT_ONCE).enumerate() {
            let l0 = c * SAMPLES_AT_ONCE;
            let from = [
                start[0] + l0 as f64 * delta[0],
                start[1] + l0 as f64 * delta[1],
            ];
            let samples = &mut samples[..chunk.len()];
            if !image.sample_line_gradient(from, delta, samples) {
                return None;
            }
            // Levels taken from the first one's, so that the energy's difference of
            // sums does not cancel in f32 (the correlation ignores an offset).
            let first = *first.get_or_insert(samples[0][0]);
            for (l, (&a, &[value, gx, gy])) in (l0..).zip(chunk.iter().zip(samples.iter())) {
                let value = value - first;
                let q = [q0[0] + l as f32 * step[0], q0[1] + l as f32 * step[1]];
                let d = [
                    gx,
                    gy,
                    gx * q[1] - gy * q[0],
                    (gx * q[0] + gy * q[1]) * inverse_scale,
                ];
                sums.add(a, value, d);
            }
        }
        Some(sums)
    }

    /// One point's gradient and Gauss-Newton Hessian of `-lambda^2 = -(1 - C) / a`,
    /// or `None` when it is occluded (or flat).
    ///
    /// With the observed vector centred, `o_c`, and `C = a^ . o^`: the residual `a^ -
    /// o^` has the Jacobian `J_k = P (D_k - mean D_k) / |o_c|`, `P` the projection off
    /// `o^`, so that `(a^ - o^) . J_k = (a^ . D_k - C o^ . D_k) / |o_c|` (the means
    /// drop out against centred vectors) and `J_k . J_m = (D_k . D_m - n mean_k mean_m
    /// - (o^ . D_k)(o^ . D_m)) / |o_c|^2`.
    fn point_terms(
        &self,
        geometry: &PointGeometry,
        sums: &PointSums,
        threshold: f64,
    ) -> Option<(SVector<f64, 4>, SMatrix<f64, 4, 4>)> {
        let n = self.model.config.n_samples as f64;
        let wide = |v: [f32; 4]| v.map(f64::from);
        let (d, ad, od) = (wide(sums.d), wide(sums.ad), wide(sums.od));
        let mean = f64::from(sums.o) / n;
        let energy_o = f64::from(sums.oo) - n * mean * mean;
        // The stored vector is centred: sum a_l (o_l - mean) = sum a_l o_l - mean sum a.
        let dot = f64::from(sums.ao) - mean * f64::from(geometry.sum);
        if !(energy_o > 1e-12 && geometry.energy > 1e-12) {
            return None;
        }
        let (norm_o, norm_a) = (energy_o.sqrt(), geometry.energy.sqrt());
        let c = dot / (norm_o * norm_a);
        let squared = geometry.squared_deviation(c, DeviationModel::Parabola);
        // Occluded, or NaN (a corrupt frame): left out.
        if squared.is_nan() || squared > threshold {
            return None;
        }
        // o^ . D_k and a^ . D_k, the observed vector centred by its mean.
        let od = |k: usize| (od[k] - mean * d[k]) / norm_o;
        let ad = |k: usize| (ad[k] - f64::from(geometry.sum) / n * d[k]) / norm_a;
        // d lambda^2 = -dC / a and 1 - C = |a^ - o^|^2 / 2: weight 1 / a on each.
        let weight = geometry.inverse_width;
        let mut g = SVector::<f64, 4>::zeros();
        let mut h = SMatrix::<f64, 4, 4>::zeros();
        for k in 0..4 {
            g[k] = weight * (ad(k) - c * od(k)) / norm_o;
            for m in k..4 {
                let centred = f64::from(sums.dd[k][m]) - d[k] * d[m] / n;
                let v = weight * (centred - od(k) * od(m)) / energy_o;
                h[(k, m)] = v;
                h[(m, k)] = v;
            }
        }
        Some((g, h))
    }
}
