//! The state of seed 000 section 3.3: a parameterisation `x = [m, lambda, theta, phi]` of
//! the target's colour distribution, its constant-velocity dynamics `s = A s' + B w`, and
//! the warp of the reference colour cloud by a state into a bin lookup table.

use nalgebra::{Matrix3, SMatrix, SVector, SymmetricEigen, Vector3};
use rperc_core::ensure_positive;

use crate::colour::ColorSpace;
use crate::condensation::LinearGaussian;
use crate::error::{Result, TrackingError};

/// Number of colour-distribution parameters: centroid (3), principal magnitudes (3) and
/// the two angles of the principal axes.
pub const N_PARAMS: usize = 8;
/// Filter state: the parameters and their velocities (constant-velocity model).
pub const STATE_DIM: usize = 2 * N_PARAMS;

/// The filter's state vector `[x, dx/dt]`.
pub type State = SVector<f64, STATE_DIM>;

/// Process noise of the constant-velocity model, in colour units where each axis of the
/// colour space spans [0, 1). `B` is diagonal, so `B B^T = diag(std^2)`: the velocity of
/// each parameter performs a random walk with these standard deviations per frame, and the
/// parameter itself gets the `*_std` jitter on top.
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(default, deny_unknown_fields)]
#[schemars(rename = "ColorDynamics")] // the public (Python) names are US spelling
pub struct ColourDynamics {
    /// Std of the centroid per frame (each axis). Default 0.02 (a third of a 16-bin cell).
    pub centroid_std: f64,
    /// Std of the centroid velocity per frame. Default 0.01.
    pub centroid_velocity_std: f64,
    /// Std of each principal magnitude per frame. Default 0.005.
    pub spread_std: f64,
    /// Std of the principal magnitudes' velocity per frame. Default 0.002.
    pub spread_velocity_std: f64,
    /// Std of the two axis angles per frame, radians. Default 0.05.
    pub angle_std: f64,
    /// Std of the angles' velocity per frame, radians. Default 0.02.
    pub angle_velocity_std: f64,
}

impl Default for ColourDynamics {
    fn default() -> Self {
        Self {
            centroid_std: 0.02,
            centroid_velocity_std: 0.01,
            spread_std: 0.005,
            spread_velocity_std: 0.002,
            angle_std: 0.05,
            angle_velocity_std: 0.02,
        }
    }
}

impl ColourDynamics {
    /// Checks every standard deviation is finite and > 0.
    ///
    /// # Errors
    /// [`TrackingError::InvalidParameter`] naming the field.
    pub fn validate(&self) -> Result<()> {
        for (name, v) in [
            ("centroid_std", self.centroid_std),
            ("centroid_velocity_std", self.centroid_velocity_std),
            ("spread_std", self.spread_std),
            ("spread_velocity_std", self.spread_velocity_std),
            ("angle_std", self.angle_std),
            ("angle_velocity_std", self.angle_velocity_std),
        ] {
            ensure_positive(name, v)?;
        }
        Ok(())
    }

    /// The diagonal of `B` (standard deviations), parameters then velocities.
    pub fn noise_std(&self) -> State {
        let mut s = State::zeros();
        for i in 0..3 {
            s[i] = self.centroid_std;
            s[3 + i] = self.spread_std;
            s[N_PARAMS + i] = self.centroid_velocity_std;
            s[N_PARAMS + 3 + i] = self.spread_velocity_std;
        }
        for i in 6..8 {
            s[i] = self.angle_std;
            s[N_PARAMS + i] = self.angle_velocity_std;
        }
        s
    }

    /// `s_t = A s'_t + B w_t` with `A = [[I, I], [0, I]]` (first-order, constant
    /// velocity, one frame per step) and `B = diag(noise_std)`, so `B B^T` is
    /// `diag(noise_std^2)`.
    pub fn linear_gaussian(&self) -> LinearGaussian<STATE_DIM> {
        let mut a = SMatrix::<f64, STATE_DIM, STATE_DIM>::identity();
        for i in 0..N_PARAMS {
            a[(i, N_PARAMS + i)] = 1.0;
        }
        LinearGaussian {
            a,
            b: SMatrix::from_diagonal(&self.noise_std()),
        }
    }
}

/// The colour coordinates of one RGB pixel in `[0, 1)^3`, consistent with
/// [`ColorSpace::bin`]: `floor(c * bins)` is that function's bin on each axis.
///
/// # Errors
/// [`TrackingError::InvalidParameter`] for spaces other than RGB and opponent, whose
/// axes are not affine in (R, G, B) and so do not carry the seed's rigid warp.
pub fn colour_coords(space: ColorSpace, [r, g, b]: [u8; 3]) -> Result<[f64; 3]> {
    let (r, g, b) = (f64::from(r), f64::from(g), f64::from(b));
    match space {
        ColorSpace::Rgb => Ok([r / 256.0, g / 256.0, b / 256.0]),
        ColorSpace::Opponent => Ok([
            (b + 255.0 - g) / 511.0,
            (g + 255.0 - r) / 511.0,
            (r + g + b) / 766.0,
        ]),
        other => Err(TrackingError::InvalidParameter {
            name: "color_space",
            reason: format!("the colour+shape tracker supports rgb and opponent, got {other:?}"),
        }),
    }
}

/// A colour cloud `C` summarised by its centroid and principal axes (PCA).
#[derive(Debug, Clone, PartialEq)]
pub struct ColourDistribution {
    /// Centroid `m` of the cloud.
    pub centroid: Vector3<f64>,
    /// Standard deviations along the principal axes, largest first (floored).
    pub spread: Vector3<f64>,
    /// Principal axes as columns, matching `spread`, right-handed.
    pub axes: Matrix3<f64>,
}

impl ColourDistribution {
    /// PCA of `points`; each spread is floored at `min_spread` so a uniform target still
    /// has a cloud to warp.
    ///
    /// # Errors
    /// [`TrackingError::InvalidParameter`] for an empty cloud.
    pub fn from_points(points: &[[f64; 3]], min_spread: f64) -> Result<Self> {
        if points.is_empty() {
            return Err(TrackingError::InvalidParameter {
                name: "target",
                reason: "the target region holds no pixels".into(),
            });
        }
        let n = points.len() as f64;
        let centroid = points
            .iter()
            .fold(Vector3::zeros(), |acc, p| acc + Vector3::from(*p))
            / n;
        let cov = points.iter().fold(Matrix3::zeros(), |acc, p| {
            let d = Vector3::from(*p) - centroid;
            acc + d * d.transpose()
        }) / n;
        let eig = SymmetricEigen::new(cov);
        let mut order = [0usize, 1, 2];
        order.sort_by(|&i, &j| eig.eigenvalues[j].total_cmp(&eig.eigenvalues[i]));
        let mut axes = Matrix3::zeros();
        let mut spread = Vector3::zeros();
        for (k, &i) in order.iter().enumerate() {
            axes.set_column(k, &eig.eigenvectors.column(i));
            spread[k] = eig.eigenvalues[i].max(0.0).sqrt().max(min_spread);
        }
        if axes.determinant() < 0.0 {
            axes.set_column(2, &(-axes.column(2)));
        }
        Ok(Self {
            centroid,
            spread,
            axes,
        })
    }

    /// The state of this distribution relative to itself: angles zero, no velocity.
    pub fn to_state(&self) -> State {
        let mut s = State::zeros();
        s.fixed_rows_mut::<3>(0).copy_from(&self.centroid);
        s.fixed_rows_mut::<3>(3).copy_from(&self.spread);
        s
    }

    /// This distribution as a state relative to `reference` (no velocity): its centroid
    /// and spreads, and the angles `theta, phi` that turn the reference's first principal
    /// axis onto this one's (see [`principal_rotation`]). The axis' sign is arbitrary,
    /// so the one nearer the reference's is taken.
    pub fn state_relative_to(&self, reference: &ColourDistribution) -> State {
        let mut s = self.to_state();
        let mut v = reference.axes.transpose() * self.axes.column(0);
        if v[0] < 0.0 {
            v = -v;
        }
        // Rot(theta, phi) e1 = (cos theta cos phi, sin theta cos phi, sin phi).
        s[6] = v[1].atan2(v[0]);
        s[7] = v[2].clamp(-1.0, 1.0).asin();
        s
    }
}

/// Rotation of the principal frame by the state's angles: `theta` turns the first axis
/// towards the second, then `phi` tilts it towards the third. These are the seed's two
/// angles aligning the two most significant principal components with the reference's.
pub fn principal_rotation(theta: f64, phi: f64) -> Matrix3<f64> {
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    let rz = Matrix3::new(ct, -st, 0.0, st, ct, 0.0, 0.0, 0.0, 1.0);
    let ry = Matrix3::new(cp, 0.0, -sp, 0.0, 1.0, 0.0, sp, 0.0, cp);
    rz * ry
}

/// The rigid-plus-scale warp taking the reference cloud to the distribution of `state`:
/// `y = m + R_ref Rot(theta, phi) diag(lambda / lambda_ref) R_ref^T (x - m_ref)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ColourWarp {
    linear: Matrix3<f64>,
    offset: Vector3<f64>,
}

impl ColourWarp {
    /// The warp of `reference` to the distribution of `state`; spreads are floored at
    /// `min_spread` so a sample cannot collapse the cloud to a point.
    pub fn new(reference: &ColourDistribution, state: &State, min_spread: f64) -> Self {
        let m = Vector3::new(state[0], state[1], state[2]);
        let scale = Vector3::from_fn(|i, _| state[3 + i].max(min_spread) / reference.spread[i]);
        let rot = principal_rotation(state[6], state[7]);
        let linear =
            reference.axes * rot * Matrix3::from_diagonal(&scale) * reference.axes.transpose();
        Self {
            linear,
            offset: m - linear * reference.centroid,
        }
    }

    /// Applies the warp to one colour.
    #[inline]
    pub fn apply(&self, x: &[f64; 3]) -> Vector3<f64> {
        self.linear * Vector3::from(*x) + self.offset
    }
}

/// The seed's histogram `H(n)` reduced to what segmentation needs: `lut[bin] = 1` when
/// some warped reference colour falls in `bin`. Colours warped outside `[0, 1)^3` are
/// dropped. `lut` is reused: it is cleared and resized to the bin count.
pub fn fill_lut(warp: &ColourWarp, cloud: &[[f64; 3]], bins: [usize; 3], lut: &mut Vec<u8>) {
    lut.clear();
    lut.resize(bins.iter().product(), 0);
    let nb = bins.map(|b| b as f64);
    for x in cloud {
        let y = warp.apply(x);
        if y.iter().any(|&c| !(0.0..1.0).contains(&c)) {
            continue;
        }
        let i = [0, 1, 2].map(|k| ((y[k] * nb[k]) as usize).min(bins[k] - 1));
        lut[(i[0] * bins[1] + i[1]) * bins[2] + i[2]] = 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lcg_cloud(n: usize) -> Vec<[f64; 3]> {
        // A skewed cloud with distinct spreads, deterministic without an RNG crate.
        let mut s = 12345u64;
        let mut next = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        (0..n)
            .map(|_| {
                let (a, b, c) = (next(), next(), next());
                [
                    0.5 + 0.2 * a + 0.05 * b,
                    0.4 + 0.2 * a - 0.05 * b,
                    0.3 + 0.02 * c,
                ]
            })
            .collect()
    }

    #[test]
    fn pca_matches_covariance_eigen_decomposition() {
        let cloud = lcg_cloud(500);
        let d = ColourDistribution::from_points(&cloud, 1e-9).unwrap();
        // Oracle: A diag(spread^2) A^T is the sample covariance, computed directly.
        let n = cloud.len() as f64;
        let mut cov = Matrix3::zeros();
        for p in &cloud {
            let x = Vector3::from(*p) - d.centroid;
            cov += x * x.transpose() / n;
        }
        let s2 = d.spread.component_mul(&d.spread);
        let back = d.axes * Matrix3::from_diagonal(&s2) * d.axes.transpose();
        assert!((back - cov).abs().max() < 1e-12);
        assert!(d.spread[0] >= d.spread[1] && d.spread[1] >= d.spread[2]);
        assert!((d.axes.determinant() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn warp_of_own_state_is_identity_and_moves_the_centroid() {
        let cloud = lcg_cloud(200);
        let d = ColourDistribution::from_points(&cloud, 1e-9).unwrap();
        let w = ColourWarp::new(&d, &d.to_state(), 1e-9);
        for p in &cloud {
            assert!((w.apply(p) - Vector3::from(*p)).norm() < 1e-12);
        }
        let mut s = d.to_state();
        s[0] += 0.1;
        let w = ColourWarp::new(&d, &s, 1e-9);
        let moved: Vec<[f64; 3]> = cloud.iter().map(|p| w.apply(p).into()).collect();
        let m = ColourDistribution::from_points(&moved, 1e-9).unwrap();
        assert!((m.centroid - d.centroid - Vector3::new(0.1, 0.0, 0.0)).norm() < 1e-12);
        assert!((m.spread - d.spread).norm() < 1e-12);
    }

    #[test]
    fn warp_scales_principal_spreads() {
        let cloud = lcg_cloud(300);
        let d = ColourDistribution::from_points(&cloud, 1e-9).unwrap();
        let mut s = d.to_state();
        s[3] *= 2.0;
        s[6] = 0.3;
        let w = ColourWarp::new(&d, &s, 1e-9);
        let moved: Vec<[f64; 3]> = cloud.iter().map(|p| w.apply(p).into()).collect();
        let m = ColourDistribution::from_points(&moved, 1e-9).unwrap();
        assert!((m.spread[0] - 2.0 * d.spread[0]).abs() < 1e-9);
        // The first axis turned by theta within the plane of the first two.
        let cos = m.axes.column(0).dot(&d.axes.column(0)).abs();
        assert!((cos - 0.3f64.cos()).abs() < 1e-9, "{cos}");
    }

    #[test]
    fn measured_state_recovers_the_warp_that_made_the_cloud() {
        // Oracle: the state that warped the reference cloud; PCA of the warped cloud
        // must give it back.
        let cloud = lcg_cloud(400);
        let d = ColourDistribution::from_points(&cloud, 1e-9).unwrap();
        let mut s = d.to_state();
        s[0] += 0.05;
        s[3] *= 1.3;
        s[6] = 0.25;
        s[7] = -0.15;
        let w = ColourWarp::new(&d, &s, 1e-9);
        let moved: Vec<[f64; 3]> = cloud.iter().map(|p| w.apply(p).into()).collect();
        let got = ColourDistribution::from_points(&moved, 1e-9)
            .unwrap()
            .state_relative_to(&d);
        for i in [0, 1, 2, 3, 6, 7] {
            assert!((got[i] - s[i]).abs() < 1e-6, "{i}: {} vs {}", got[i], s[i]);
        }
    }

    #[test]
    fn dynamics_is_constant_velocity() {
        let lg = ColourDynamics::default().linear_gaussian();
        let mut s = State::zeros();
        s[0] = 0.5;
        s[N_PARAMS] = 0.01;
        let s2 = lg.a * (lg.a * s);
        assert!((s2[0] - 0.52).abs() < 1e-15);
        assert_eq!(lg.b[(0, 0)], 0.02);
        let bad = ColourDynamics {
            angle_std: -1.0,
            ..Default::default()
        };
        assert!(bad.validate().is_err());
    }

    #[test]
    fn coords_agree_with_colour_space_bins() {
        let bins = [16, 8, 5];
        for space in [ColorSpace::Rgb, ColorSpace::Opponent] {
            for r in (0..=255).step_by(7) {
                for g in (0..=255).step_by(11) {
                    for b in [0u8, 1, 100, 254, 255] {
                        let c = colour_coords(space, [r, g, b]).unwrap();
                        let i =
                            [0, 1, 2].map(|k| ((c[k] * bins[k] as f64) as usize).min(bins[k] - 1));
                        let want = space.bin([r, g, b], bins);
                        assert_eq!((i[0] * bins[1] + i[1]) * bins[2] + i[2], want);
                    }
                }
            }
        }
        assert!(colour_coords(ColorSpace::Hsv, [0, 0, 0]).is_err());
    }
}
