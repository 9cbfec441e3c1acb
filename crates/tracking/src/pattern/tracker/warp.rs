//! The homography mode's refinement: Gauss-Newton on the 8 parameters of the
//! plane's homography, maximising eq. 6 over the model's profiles, each sample
//! placed by the homography itself (not by a similarity), with Tukey's robust
//! weights on the profiles.
//!
//! Each profile's term of eq. 6 is `lambda^2 = (1 - C) / a = |a^ - o^|^2 / (2 a)`
//! for the unit, mean-removed stored and observed vectors: a weighted least-squares
//! cost in the normalised observed profiles, the cost ECC minimises over a whole
//! window (Evangelidis and Psarakis), here per profile. The update is
//! compositional (`H <- H N^-1 W(p) N`, [`homography::update_jacobian`]), and each
//! step is kept only when it lowers the robust cost.

use nalgebra::{Matrix3, SMatrix, SVector};
use rperc_core::image::GrayImage;

use crate::pattern::correlation::autocorrelation_curvature;
use crate::pattern::homography::{self, apply};
use crate::pattern::model::PatternModel;
use crate::pattern::observation::ScaleSpace;

/// A profile of the model in model offsets: its samples' places at scale 1, its
/// stored vector as a unit, mean-removed vector, and `1 / a` (the inverse
/// curvature of its auto-correlation, eq. 6's weight of the parabola deviation).
#[derive(Debug, Clone)]
struct Profile {
    samples: Vec<[f64; 2]>,
    unit: Vec<f64>,
    /// The stored vector's centred norm (its contrast), for the profile's gain.
    contrast: f64,
    inverse_width: f64,
}

/// The model's profiles for the refinement, computed once per model.
#[derive(Debug, Clone)]
pub(super) struct Profiles {
    profiles: Vec<Profile>,
    /// The offsets' scale (the model window's half diagonal): the update's
    /// parameters are of one size with offsets divided by it.
    norm: f64,
}

impl Profiles {
    pub(super) fn new(model: &PatternModel) -> Self {
        let config = &model.config;
        let n = config.n_samples;
        let half = 0.5 * (n as f64 - 1.0);
        let profiles = (0..model.points.len())
            .map(|j| {
                let point = &model.points[j];
                let o = model.offset(j);
                let (sin, cos) = point.phi.sin_cos();
                let samples = (0..n)
                    .map(|l| {
                        let t = (l as f64 - half) * config.delta;
                        [o[0] + t * cos, o[1] + t * sin]
                    })
                    .collect();
                let mean = point.vector.iter().map(|&v| f64::from(v)).sum::<f64>() / n as f64;
                let centred: Vec<f64> = point.vector.iter().map(|&v| f64::from(v) - mean).collect();
                let norm = centred.iter().map(|v| v * v).sum::<f64>().sqrt().max(1e-12);
                let curvature = autocorrelation_curvature(&point.vector, config.fit_lags);
                Profile {
                    samples,
                    unit: centred.iter().map(|v| v / norm).collect(),
                    contrast: norm,
                    inverse_width: 1.0 / curvature.max(1e-9),
                }
            })
            .collect();
        let norm = (0.5 * model.size[0]).hypot(0.5 * model.size[1]).max(1.0);
        Self { profiles, norm }
    }
}

/// What the refinement reports at its answer.
#[derive(Debug, Clone, Copy)]
pub(super) struct WarpFit {
    pub(super) homography: Matrix3<f64>,
    /// Profiles whose deviation exceeds the occlusion threshold or that leave the
    /// scale space's window, over all profiles: Tukey's weight 0.
    pub(super) occluded_fraction: f64,
    /// The spread of the unoccluded profiles' gains: the median absolute deviation
    /// of `ln g`, `g = C |o_c| / |a_c|` the slope of the observed profile on the
    /// stored one. The pattern itself, under one gain, gives them all alike;
    /// clutter matching profiles by chance gives each its own. Infinite with fewer
    /// than [`MIN_GAINS`] unoccluded profiles.
    pub(super) gain_spread: f64,
}

/// Fewer unoccluded profiles than this leave the gains' spread unknown (infinite).
const MIN_GAINS: usize = 8;

/// The median absolute deviation of `values` (reordered), infinite below
/// [`MIN_GAINS`] values.
fn spread(values: &mut [f64]) -> f64 {
    if values.len() < MIN_GAINS {
        return f64::INFINITY;
    }
    let median = |v: &mut [f64]| {
        let k = v.len() / 2;
        *v.select_nth_unstable_by(k, f64::total_cmp).1
    };
    let m = median(values);
    values.iter_mut().for_each(|v| *v = (*v - m).abs());
    median(values)
}

/// The refinement's settings.
#[derive(Debug, Clone, Copy)]
pub(super) struct WarpSearch {
    /// Tukey's threshold on `lambda`: eq. 6's occlusion threshold.
    pub(super) threshold: f64,
    pub(super) iterations: usize,
    /// Levenberg-Marquardt damping (a fraction of the diagonal).
    pub(super) damping: f64,
    /// Steps that move every sample less than this (pixels) end the search.
    pub(super) tolerance: f64,
}

/// One profile's observed samples and their derivatives `D_k = grad I . dx/dp_k`.
struct Observed {
    values: Vec<f64>,
    derivatives: Vec<[f64; 8]>,
}

/// The level of `space` for `h` (its local scale at the centre) and its origin.
fn level<'a>(space: &'a ScaleSpace, h: &Matrix3<f64>) -> Option<(&'a GrayImage, [f64; 2])> {
    let (state, _) = homography::split(h)?;
    Some(space.level_at(state[3]))
}

impl Profiles {
    /// Samples profile `p` at `h` on `image` (frame origin `origin`), with the
    /// derivatives when `derivatives`; `None` when a sample leaves the image.
    fn observe(
        &self,
        p: &Profile,
        h: &Matrix3<f64>,
        (image, origin): (&GrayImage, [f64; 2]),
        derivatives: bool,
        out: &mut Observed,
    ) -> Option<()> {
        out.values.clear();
        out.derivatives.clear();
        for &o in &p.samples {
            let x = apply(h, o)?;
            let (u, v) = (x[0] - origin[0], x[1] - origin[1]);
            if !derivatives {
                out.values.push(f64::from(image.sample_bilinear(u, v)?));
                continue;
            }
            let [value, gx, gy] = image.sample_bilinear_gradient(u, v)?;
            let j = homography::update_jacobian(h, o, self.norm)?;
            let (gx, gy) = (f64::from(gx), f64::from(gy));
            out.values.push(f64::from(value));
            out.derivatives
                .push(std::array::from_fn(|k| gx * j[0][k] + gy * j[1][k]));
        }
        Some(())
    }

    /// `(C, |o_c|, o^)` of an observed profile against `p`: the inter-correlation,
    /// the centred vector's norm and the unit centred vector (in `unit`).
    fn correlate(p: &Profile, values: &[f64], unit: &mut Vec<f64>) -> Option<(f64, f64)> {
        let n = values.len() as f64;
        let mean = values.iter().sum::<f64>() / n;
        unit.clear();
        unit.extend(values.iter().map(|v| v - mean));
        let norm = unit.iter().map(|v| v * v).sum::<f64>().sqrt();
        if norm.is_nan() || norm <= 1e-9 {
            return None;
        }
        unit.iter_mut().for_each(|v| *v /= norm);
        let c = unit.iter().zip(&p.unit).map(|(a, b)| a * b).sum::<f64>();
        Some((c, norm))
    }

    /// Tukey's weight and cost of squared deviation `l2` at threshold `t` (squared
    /// `t2`): `(1 - l2/t2)^2` and `t2 / 6 (1 - (1 - l2/t2)^3)`, 0 and `t2 / 6` beyond.
    fn tukey(l2: f64, t2: f64) -> (f64, f64) {
        if l2.is_nan() || l2 >= t2 {
            return (0.0, t2 / 6.0);
        }
        let r = 1.0 - l2 / t2;
        (r * r, t2 / 6.0 * (1.0 - r * r * r))
    }

    /// The robust cost per profile and the occluded fraction at `h`; with
    /// `equations`, also the weighted Gauss-Newton system `(A, b)`.
    fn evaluate(
        &self,
        h: &Matrix3<f64>,
        space: &ScaleSpace,
        t: f64,
        mut equations: Option<&mut (SMatrix<f64, 8, 8>, SVector<f64, 8>)>,
        mut gains: Option<&mut Vec<f64>>,
    ) -> Option<(f64, f64)> {
        let level = level(space, h)?;
        let t2 = t * t;
        let (mut cost, mut occluded) = (0.0, 0usize);
        let mut observed = Observed {
            values: Vec::new(),
            derivatives: Vec::new(),
        };
        let mut unit = Vec::new();
        let with = equations.is_some();
        for p in &self.profiles {
            let seen = self
                .observe(p, h, level, with, &mut observed)
                .and_then(|_| Self::correlate(p, &observed.values, &mut unit));
            let Some((c, norm)) = seen else {
                occluded += 1;
                cost += t2 / 6.0;
                continue;
            };
            let l2 = (1.0 - c).max(0.0) * p.inverse_width;
            let (w, rho) = Self::tukey(l2, t2);
            cost += rho;
            if w == 0.0 {
                occluded += 1;
                continue;
            }
            if let Some(gains) = gains.as_deref_mut() {
                gains.push((c.max(1e-6) * norm / p.contrast).ln());
            }
            if let Some((a, b)) = equations.as_deref_mut() {
                let weight = w * p.inverse_width;
                add_profile(p, &unit, c, norm, &observed.derivatives, weight, a, b);
            }
        }
        let n = self.profiles.len().max(1) as f64;
        Some((cost / n, occluded as f64 / n))
    }

    /// Gauss-Newton from `h` on the frame's scale space `space`; `None` when `h`
    /// has no level there (it folds or leaves the plane).
    pub(super) fn refine(
        &self,
        h: &Matrix3<f64>,
        space: &ScaleSpace,
        search: &WarpSearch,
    ) -> Option<WarpFit> {
        let t = search.threshold;
        let mut h = *h;
        let (mut cost, mut occluded) = self.evaluate(&h, space, t, None, None)?;
        for _ in 0..search.iterations {
            let mut system = (SMatrix::<f64, 8, 8>::zeros(), SVector::<f64, 8>::zeros());
            self.evaluate(&h, space, t, Some(&mut system), None)?;
            let (mut a, b) = system;
            for k in 0..8 {
                a[(k, k)] *= 1.0 + search.damping;
            }
            let Some(delta) = a.cholesky().map(|c| c.solve(&b)) else {
                break;
            };
            let mut moved = None;
            for fraction in [1.0, 0.5, 0.25] {
                let tried = homography::compose_update(&h, &(delta * fraction), self.norm);
                let Some((c, o)) = self.evaluate(&tried, space, t, None, None) else {
                    continue;
                };
                if c < cost {
                    moved = Some((tried, c, o));
                    break;
                }
            }
            let Some((next, c, o)) = moved else { break };
            let shift = self.largest_move(&h, &next);
            (h, cost, occluded) = (next, c, o);
            if shift < search.tolerance {
                break;
            }
        }
        let mut gains = Vec::with_capacity(self.profiles.len());
        self.evaluate(&h, space, t, None, Some(&mut gains))?;
        Some(WarpFit {
            homography: h,
            occluded_fraction: occluded,
            gain_spread: spread(&mut gains),
        })
    }

    /// The spread of the unoccluded profiles' gains at `h` (see
    /// [`WarpFit::gain_spread`]), Tukey's threshold `t`; `None` when `h` has no
    /// level in `space`.
    pub(super) fn gain_spread(&self, h: &Matrix3<f64>, space: &ScaleSpace, t: f64) -> Option<f64> {
        let mut gains = Vec::with_capacity(self.profiles.len());
        self.evaluate(h, space, t, None, Some(&mut gains))?;
        Some(spread(&mut gains))
    }

    /// The largest move of the model window's corners from `a` to `b` (pixels).
    fn largest_move(&self, a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
        let r = self.norm;
        [[-r, -r], [r, -r], [r, r], [-r, r]]
            .iter()
            .filter_map(|&o| Some((apply(a, o)?, apply(b, o)?)))
            .map(|(p, q)| (p[0] - q[0]).hypot(p[1] - q[1]))
            .fold(0.0, f64::max)
    }
}

/// Adds one profile's Gauss-Newton terms, weighted by `weight`, to `(a, b)`: with the
/// centred observed vector `o_c` (norm `norm`, unit `o^`), `J_k = P (D_k - mean
/// D_k) / |o_c|` (`P` the projection off `o^`), so that `J_k . J_m = (D_k . D_m - n
/// mean_k mean_m - (o^ . D_k)(o^ . D_m)) / |o_c|^2` and `J_k . (a^ - o^) = (a^ . D_k
/// - C o^ . D_k) / |o_c|`.
#[allow(clippy::too_many_arguments)]
fn add_profile(
    p: &Profile,
    unit: &[f64],
    c: f64,
    norm: f64,
    derivatives: &[[f64; 8]],
    weight: f64,
    a: &mut SMatrix<f64, 8, 8>,
    b: &mut SVector<f64, 8>,
) {
    let n = derivatives.len() as f64;
    let (mut sum, mut od, mut ad) = ([0.0; 8], [0.0; 8], [0.0; 8]);
    let mut dd = SMatrix::<f64, 8, 8>::zeros();
    for ((d, &o), &s) in derivatives.iter().zip(unit).zip(&p.unit) {
        let column = SVector::<f64, 8>::from(*d);
        dd += column * column.transpose();
        for k in 0..8 {
            sum[k] += d[k];
            od[k] += o * d[k];
            ad[k] += s * d[k];
        }
    }
    let inv = 1.0 / (norm * norm);
    for k in 0..8 {
        for m in 0..8 {
            let jj = dd[(k, m)] - sum[k] * sum[m] / n - od[k] * od[m];
            a[(k, m)] += weight * jj * inv;
        }
        b[k] += weight * (ad[k] - c * od[k]) / norm;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pattern::model::{PatternConfig, Region};

    /// A smooth, textured image: sums of sinusoids and a few blobs.
    fn texture(width: usize, height: usize) -> GrayImage {
        let data = (0..width * height)
            .map(|i| {
                let (x, y) = ((i % width) as f32, (i / width) as f32);
                let blobs = [(60.0, 50.0, 9.0), (95.0, 70.0, 6.0), (75.0, 95.0, 11.0)]
                    .iter()
                    .map(|&(cx, cy, r): &(f32, f32, f32)| {
                        let d2 = (x - cx).powi(2) + (y - cy).powi(2);
                        90.0 * (-d2 / (2.0 * r * r)).exp()
                    })
                    .sum::<f32>();
                100.0
                    + 40.0 * (0.21 * x).sin() * (0.17 * y).cos()
                    + 25.0 * (0.05 * x + 0.11 * y).sin()
                    + blobs
            })
            .collect();
        GrayImage {
            data,
            width,
            height,
        }
    }

    /// The Gauss-Newton right-hand side is minus the gradient of the weighted cost
    /// `sum w_j / a_j (1 - C_j(p))` (weights held at the start), by central finite
    /// differences of the compositional update's 8 parameters.
    #[test]
    fn the_normal_equations_point_down_the_cost() {
        let image = texture(160, 140);
        let region = Region::Box {
            x: 40,
            y: 35,
            w: 80,
            h: 75,
        };
        let model = PatternModel::from_region(&image, region, &PatternConfig::default()).unwrap();
        let mut space = ScaleSpace::new();
        space.build(&image, &model).unwrap();
        let profiles = Profiles::new(&model);
        let [cx, cy] = model.centre;
        // Near the pattern but not on it: a small perspective and shift.
        let h = Matrix3::new(
            1.02,
            0.01,
            cx + 0.7,
            -0.015,
            0.99,
            cy - 0.4,
            2e-4,
            -1e-4,
            1.0,
        );
        let t = 1.5;
        let mut system = (SMatrix::<f64, 8, 8>::zeros(), SVector::<f64, 8>::zeros());
        profiles
            .evaluate(&h, &space, t, Some(&mut system), None)
            .unwrap();
        let at = level(&space, &h).unwrap();
        let mut observed = Observed {
            values: Vec::new(),
            derivatives: Vec::new(),
        };
        let mut unit = Vec::new();
        let weights: Vec<f64> = profiles
            .profiles
            .iter()
            .map(|p| {
                let seen = profiles.observe(p, &h, at, false, &mut observed);
                let c = seen.and_then(|_| Profiles::correlate(p, &observed.values, &mut unit));
                c.map_or(0.0, |(c, _)| {
                    let l2 = (1.0 - c).max(0.0) * p.inverse_width;
                    Profiles::tukey(l2, t * t).0 * p.inverse_width
                })
            })
            .collect();
        let mut cost = |p: &SVector<f64, 8>| -> f64 {
            let moved = homography::compose_update(&h, p, profiles.norm);
            let there = level(&space, &moved).unwrap();
            let mut sum = 0.0;
            for (profile, w) in profiles.profiles.iter().zip(&weights) {
                if *w == 0.0 {
                    continue;
                }
                profiles
                    .observe(profile, &moved, there, false, &mut observed)
                    .unwrap();
                let (c, _) = Profiles::correlate(profile, &observed.values, &mut unit).unwrap();
                sum += w * (1.0 - c);
            }
            sum
        };
        let scale = system.1.abs().max();
        assert!(scale > 0.0);
        for k in 0..8 {
            // A step of about 5e-3 px: the f32 grey levels' rounding (1e-5 of 200)
            // stays far below the change, and few samples cross a pixel's edge.
            let eps = 1e-4;
            let mut p = SVector::<f64, 8>::zeros();
            p[k] = eps;
            let plus = cost(&p);
            p[k] = -eps;
            let minus = cost(&p);
            let numeric = -(plus - minus) / (2.0 * eps);
            assert!(
                (numeric - system.1[k]).abs() < 1e-3 * scale,
                "parameter {k}: finite differences {numeric}, normal equations {}",
                system.1[k]
            );
        }
    }

    /// The median absolute deviation against its definition on sorted values, and
    /// Tukey's weight and cost against their formulas.
    #[test]
    fn the_gain_spread_and_tukeys_terms_follow_their_definitions() {
        let values = [0.3, -1.2, 0.05, 2.5, 0.1, 0.0, -0.2, 0.4, 0.15];
        let mut sorted = values.to_vec();
        sorted.sort_by(f64::total_cmp);
        let median = sorted[sorted.len() / 2];
        let mut deviations: Vec<f64> = values.iter().map(|v| (v - median).abs()).collect();
        deviations.sort_by(f64::total_cmp);
        let want = deviations[deviations.len() / 2];
        assert_eq!(spread(&mut values.to_vec()), want);
        assert_eq!(spread(&mut [1.0; MIN_GAINS - 1]), f64::INFINITY);
        let t2: f64 = 2.25;
        for l2 in [0.0, 0.5, 1.0, 2.0] {
            let (w, rho) = Profiles::tukey(l2, t2);
            let r = 1.0 - l2 / t2;
            assert!((w - r * r).abs() < 1e-15);
            assert!((rho - t2 / 6.0 * (1.0 - r.powi(3))).abs() < 1e-15);
        }
        assert_eq!(Profiles::tukey(3.0, t2), (0.0, t2 / 6.0));
        assert_eq!(Profiles::tukey(f64::NAN, t2), (0.0, t2 / 6.0));
    }
}
