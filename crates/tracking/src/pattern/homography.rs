//! Plane-to-image homographies for the tracker's homography mode: the motion model
//! enum, the map of four corners, the split of a homography into the similarity the
//! particles carry and the projective rest, and the Jacobian the Gauss-Newton
//! refinement needs.
//!
//! A homography `H` here maps a model offset `o` (pixels from the model's centre at
//! scale 1) to a frame point: `x = (H [o; 1])_xy / (H [o; 1])_z`.

use nalgebra::{Matrix3, SMatrix, SVector};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::error::{Result, TrackingError};

/// The motion model of a [`super::PatternTracker`]: the seed's similarity `(x, y,
/// theta, s)` (section 3.3), or a plane seen in perspective (an 8-dof homography).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
// slam's vehicle `MotionModel` has the name in the schemas the Python configs are
// generated from; serde's spelling of the values is unchanged.
#[schemars(rename = "PatternMotion")]
pub enum MotionModel {
    /// `(x, y, theta, s)` of eq. 5.
    #[default]
    Similarity,
    /// The 8-dof homography of the pattern's plane.
    Homography,
}

impl std::str::FromStr for MotionModel {
    type Err = TrackingError;

    fn from_str(s: &str) -> Result<Self> {
        match s {
            "similarity" => Ok(Self::Similarity),
            "homography" => Ok(Self::Homography),
            other => Err(TrackingError::InvalidParameter {
                name: "motion",
                reason: format!(
                    "unknown motion model {other:?}: expected \"similarity\" or \"homography\""
                ),
            }),
        }
    }
}

/// `H` applied to `p`; `None` on or behind the line at infinity (`w <= 0`: the
/// plane's point lies behind the camera).
pub fn apply(h: &Matrix3<f64>, p: [f64; 2]) -> Option<[f64; 2]> {
    let w = h[(2, 0)] * p[0] + h[(2, 1)] * p[1] + h[(2, 2)];
    if w.is_nan() || w <= 1e-12 {
        return None;
    }
    Some([
        (h[(0, 0)] * p[0] + h[(0, 1)] * p[1] + h[(0, 2)]) / w,
        (h[(1, 0)] * p[0] + h[(1, 1)] * p[1] + h[(1, 2)]) / w,
    ])
}

/// The 2 x 2 Jacobian `d x / d o` of `H` at `p` (rows x, y), `None` as [`apply`].
pub fn jacobian(h: &Matrix3<f64>, p: [f64; 2]) -> Option<[[f64; 2]; 2]> {
    let w = h[(2, 0)] * p[0] + h[(2, 1)] * p[1] + h[(2, 2)];
    let x = apply(h, p)?;
    let row = |r: usize| {
        [
            (h[(r, 0)] - x[r] * h[(2, 0)]) / w,
            (h[(r, 1)] - x[r] * h[(2, 1)]) / w,
        ]
    };
    Some([row(0), row(1)])
}

/// The homography mapping `from[k]` to `to[k]` (four points each, no three on a
/// line), normalised to `H_22 = 1`: the 8 x 8 linear system of the direct linear
/// transform. `None` for a degenerate set.
pub fn from_points(from: &[[f64; 2]; 4], to: &[[f64; 2]; 4]) -> Option<Matrix3<f64>> {
    let mut a = SMatrix::<f64, 8, 8>::zeros();
    let mut b = SVector::<f64, 8>::zeros();
    for k in 0..4 {
        let ([u, v], [x, y]) = (from[k], to[k]);
        let r = 2 * k;
        a.fixed_view_mut::<1, 8>(r, 0)
            .copy_from_slice(&[u, v, 1.0, 0.0, 0.0, 0.0, -x * u, -x * v]);
        a.fixed_view_mut::<1, 8>(r + 1, 0).copy_from_slice(&[
            0.0,
            0.0,
            0.0,
            u,
            v,
            1.0,
            -y * u,
            -y * v,
        ]);
        b[r] = x;
        b[r + 1] = y;
    }
    let h = a.lu().solve(&b)?;
    h.iter()
        .all(|v| v.is_finite())
        .then(|| Matrix3::new(h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7], 1.0))
}

/// The similarity of state `(x, y, theta, s)` as a matrix, the map of
/// [`super::place`]: `centre + s R (dx, dy)`, `R = [[c, s], [-s, c]]`.
pub fn similarity(state: &SVector<f64, 4>) -> Matrix3<f64> {
    let (sin, cos) = state[2].sin_cos();
    let s = state[3];
    Matrix3::new(
        s * cos,
        s * sin,
        state[0],
        -s * sin,
        s * cos,
        state[1],
        0.0,
        0.0,
        1.0,
    )
}

/// `H = S P`: the similarity state `S = (x, y, theta, s)` that moves the model's
/// centre where `H` does, with `H`'s local scale `sqrt(det J)` and the rotation
/// nearest to its Jacobian there, and the projective rest `P = S^-1 H`, which keeps
/// the centre (`P(0) = 0`) and whose Jacobian there has no rotation and determinant
/// one. The particles search over `S`; `P` stays as the last frame left it. `None`
/// when `H` folds the plane at the centre (`det J <= 0`) or sends it to infinity.
pub fn split(h: &Matrix3<f64>) -> Option<(SVector<f64, 4>, Matrix3<f64>)> {
    let centre = apply(h, [0.0, 0.0])?;
    let [[a, b], [c, d]] = jacobian(h, [0.0, 0.0])?;
    let det = a * d - b * c;
    if det.is_nan() || det <= 0.0 {
        return None;
    }
    // J ~ s [[cos, sin], [-sin, cos]]: the rotation nearest to J (polar part).
    let theta = (b - c).atan2(a + d);
    let state = SVector::from([centre[0], centre[1], theta, det.sqrt()]);
    let inverse = similarity(&state).try_inverse()?;
    let mut rest = inverse * h;
    rest /= rest[(2, 2)];
    Some((state, rest))
}

/// Checks that four corners (top-left, top-right, bottom-right, bottom-left on
/// screen, y down) are finite and bound a convex quadrilateral, clockwise on screen,
/// with no side shorter than `min_side` pixels: a crossed, folded, reordered or
/// collapsed quad has no homography from a rectangle that keeps the plane's side.
///
/// # Errors
/// [`TrackingError::InvalidParameter`] named `region`, saying what is wrong.
pub fn check_quad(corners: &[[f64; 2]; 4], min_side: f64) -> Result<()> {
    let bad = |reason: String| TrackingError::InvalidParameter {
        name: "region",
        reason,
    };
    if !corners.iter().flatten().all(|v| v.is_finite()) {
        return Err(bad(format!("corners must be finite, got {corners:?}")));
    }
    for k in 0..4 {
        let (p, q, r) = (corners[k], corners[(k + 1) % 4], corners[(k + 2) % 4]);
        let side = (q[0] - p[0]).hypot(q[1] - p[1]);
        if side < min_side {
            return Err(bad(format!(
                "side {k}-{} of the corners is {side:.2} px, under {min_side} px: \
                 a degenerate quad {corners:?}",
                (k + 1) % 4
            )));
        }
        // Clockwise on screen (y down) is a positive cross product at every corner.
        let cross = (q[0] - p[0]) * (r[1] - q[1]) - (q[1] - p[1]) * (r[0] - q[0]);
        if cross.is_nan() || cross <= 0.0 {
            return Err(bad(format!(
                "the corners must bound a convex quad in the order top-left, top-right, \
                 bottom-right, bottom-left; corner {} turns the wrong way in {corners:?}",
                (k + 1) % 4
            )));
        }
    }
    Ok(())
}

/// `d x / d p` at `p = 0` of `x(p) = H N^-1 W(N o; p)`, the frame point of model
/// offset `o` after the compositional update `H <- H N^-1 W(p) N` (`N` scales offsets
/// by `1 / norm` so that the 8 parameters are of one size):
/// `W(p) = [[1 + p0, p1, p2], [p3, 1 + p4, p5], [p6, p7, 1]]`, whose derivative at
/// `u = N o` is `[[u, v, 1, 0, 0, 0, -u^2, -u v], [0, 0, 0, u, v, 1, -u v, -v^2]]`
/// (Baker and Matthews' homography warp). `None` as [`apply`].
pub fn update_jacobian(h: &Matrix3<f64>, o: [f64; 2], norm: f64) -> Option<[[f64; 8]; 2]> {
    let j = jacobian(h, o)?;
    let (u, v) = (o[0] / norm, o[1] / norm);
    let dw = [
        [u, v, 1.0, 0.0, 0.0, 0.0, -u * u, -u * v],
        [0.0, 0.0, 0.0, u, v, 1.0, -u * v, -v * v],
    ];
    // d o / d u = norm.
    let mut out = [[0.0; 8]; 2];
    for (r, row) in out.iter_mut().enumerate() {
        for (k, value) in row.iter_mut().enumerate() {
            *value = norm * (j[r][0] * dw[0][k] + j[r][1] * dw[1][k]);
        }
    }
    Some(out)
}

/// `H N^-1 W(p) N`, the compositional update of [`update_jacobian`], normalised to
/// `H_22 = 1`.
pub fn compose_update(h: &Matrix3<f64>, p: &SVector<f64, 8>, norm: f64) -> Matrix3<f64> {
    let w = Matrix3::new(
        1.0 + p[0],
        p[1],
        p[2],
        p[3],
        1.0 + p[4],
        p[5],
        p[6],
        p[7],
        1.0,
    );
    let n = Matrix3::new(1.0 / norm, 0.0, 0.0, 0.0, 1.0 / norm, 0.0, 0.0, 0.0, 1.0);
    let n_inv = Matrix3::new(norm, 0.0, 0.0, 0.0, norm, 0.0, 0.0, 0.0, 1.0);
    let out = h * n_inv * w * n;
    out / out[(2, 2)]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn example() -> Matrix3<f64> {
        Matrix3::new(1.1, 0.2, 320.0, -0.15, 0.9, 240.0, 4e-4, -6e-4, 1.0)
    }

    /// The update's Jacobian against central finite differences of the composed map.
    #[test]
    fn the_update_jacobian_matches_finite_differences() {
        let h = example();
        let norm = 60.0;
        for o in [[0.0, 0.0], [40.0, -25.0], [-55.0, 30.0], [10.0, 50.0]] {
            let analytic = update_jacobian(&h, o, norm).unwrap();
            for k in 0..8 {
                let eps = 1e-6;
                let mut p = SVector::<f64, 8>::zeros();
                p[k] = eps;
                let plus = apply(&compose_update(&h, &p, norm), o).unwrap();
                p[k] = -eps;
                let minus = apply(&compose_update(&h, &p, norm), o).unwrap();
                for r in 0..2 {
                    let numeric = (plus[r] - minus[r]) / (2.0 * eps);
                    let scale = 1.0 + numeric.abs();
                    assert!(
                        (numeric - analytic[r][k]).abs() < 1e-5 * scale,
                        "o {o:?} k {k} r {r}: {numeric} vs {}",
                        analytic[r][k]
                    );
                }
            }
        }
    }

    /// The point Jacobian against finite differences.
    #[test]
    fn the_point_jacobian_matches_finite_differences() {
        let h = example();
        for o in [[0.0, 0.0], [35.0, -20.0], [-50.0, 45.0]] {
            let j = jacobian(&h, o).unwrap();
            for d in 0..2 {
                let eps = 1e-5;
                let (mut a, mut b) = (o, o);
                a[d] += eps;
                b[d] -= eps;
                let (pa, pb) = (apply(&h, a).unwrap(), apply(&h, b).unwrap());
                for r in 0..2 {
                    let numeric = (pa[r] - pb[r]) / (2.0 * eps);
                    assert!((numeric - j[r][d]).abs() < 1e-6, "{numeric} {}", j[r][d]);
                }
            }
        }
    }

    /// Four correspondences of a known homography give it back (closed form).
    #[test]
    fn four_points_give_the_homography_back() {
        let h = example();
        let from = [[-50.0, -40.0], [50.0, -40.0], [50.0, 40.0], [-50.0, 40.0]];
        let to = from.map(|p| apply(&h, p).unwrap());
        let got = from_points(&from, &to).unwrap();
        assert!((got - h).abs().max() < 1e-9, "{got}");
        let collinear = [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0], [3.0, 3.0]];
        assert!(from_points(&collinear, &to).is_none());
    }

    /// The split recomposes, keeps the centre, and its rest has a rotation-free
    /// Jacobian of determinant 1 at the centre; a similarity splits into itself.
    #[test]
    fn the_split_recomposes_into_the_homography() {
        let h = example();
        let (state, rest) = split(&h).unwrap();
        let back = similarity(&state) * rest;
        assert!((back / back[(2, 2)] - h).abs().max() < 1e-9);
        let centre = apply(&rest, [0.0, 0.0]).unwrap();
        assert!(centre[0].abs() < 1e-12 && centre[1].abs() < 1e-12);
        let [[a, b], [c, d]] = jacobian(&rest, [0.0, 0.0]).unwrap();
        assert!((a * d - b * c - 1.0).abs() < 1e-9);
        assert!((b - c).abs() < 1e-9, "{b} {c}");
        let s = SVector::from([12.0, -4.0, 0.4, 1.3]);
        let (state, rest) = split(&similarity(&s)).unwrap();
        assert!((state - s).abs().max() < 1e-12);
        assert!((rest - Matrix3::identity()).abs().max() < 1e-12);
        // A fold at the centre has no split.
        let fold = Matrix3::new(-1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0);
        assert!(split(&fold).is_none());
    }

    /// Quads: a box is accepted; reordered, crossed, collapsed or NaN corners are not.
    #[test]
    fn bad_quads_are_refused_with_a_reason() {
        let good = [[10.0, 10.0], [60.0, 12.0], [58.0, 50.0], [12.0, 48.0]];
        check_quad(&good, 4.0).unwrap();
        let cases: [([[f64; 2]; 4], &str); 4] = [
            ([good[0], good[3], good[2], good[1]], "wrong way"),
            ([good[0], good[2], good[1], good[3]], "wrong way"),
            ([good[0], good[0], good[2], good[3]], "degenerate"),
            ([[f64::NAN, 0.0], good[1], good[2], good[3]], "finite"),
        ];
        for (quad, want) in cases {
            let err = check_quad(&quad, 4.0).unwrap_err().to_string();
            assert!(err.contains(want), "{err}");
        }
        // A dart (one reflex corner).
        let dart = [[0.0, 0.0], [50.0, 0.0], [25.0, 10.0], [25.0, 50.0]];
        assert!(check_quad(&dart, 4.0).is_err());
        assert_eq!(
            "homography".parse::<MotionModel>().unwrap(),
            MotionModel::Homography
        );
        assert!("affine".parse::<MotionModel>().is_err());
    }
}
