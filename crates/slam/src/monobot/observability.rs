//! Observability matrices, ranks, information spectra and the closed form of eq. (17).

use nalgebra::{DMatrix, DVector};

use super::model::MeasurementModel;
use crate::error::{Result, SlamError, ensure_finite};

/// The observability matrix `O = [H; H A; ...; H A^(d-1)]` of the monobot with `A =
/// I` (static landmarks, the robot's own motion is the known input).
pub fn observability_matrix(model: MeasurementModel, landmarks: usize) -> DMatrix<f64> {
    let d = landmarks + 1;
    let h = model.jacobian(landmarks).to_dense(d);
    let p = h.nrows();
    let mut o = DMatrix::zeros(p * d, d);
    for k in 0..d {
        // A = I, so every block row is H itself.
        o.view_mut((k * p, 0), (p, d)).copy_from(&h);
    }
    o
}

/// Numerical rank: singular values above `tol` times the largest.
pub fn rank(m: &DMatrix<f64>, tol: f64) -> usize {
    let sv = m.clone().singular_values();
    let max = sv.max();
    sv.iter().filter(|&&s| s > tol * max).count()
}

/// Rank of the observability matrix for `model` with `landmarks` landmarks: `d - 1`
/// for the relative model, `d` for anchor and external.
pub fn observability_rank(model: MeasurementModel, landmarks: usize) -> Result<usize> {
    if landmarks == 0 {
        return Err(SlamError::invalid("landmarks", "must be >= 1".into()));
    }
    // With static landmarks (A = I) every block row of O is H, so rank O = rank H: the
    // rank needs H (p x d), not the (p d) x d matrix O.
    let d = landmarks as u128 + 1;
    let p = model.observation_dim(landmarks) as u128;
    rperc_core::check_allocation("landmarks", p * d, 8)?;
    Ok(rank(
        &model.jacobian(landmarks).to_dense(landmarks + 1),
        1e-10,
    ))
}

/// Eigen-decomposition of a symmetric information matrix.
#[derive(Debug, Clone, PartialEq)]
pub struct InformationSpectrum {
    /// Eigenvalues, ascending.
    pub eigenvalues: DVector<f64>,
    /// Matching unit eigenvectors as columns.
    pub eigenvectors: DMatrix<f64>,
    /// Number of eigenvalues above `tol * max`.
    pub rank: usize,
}

/// Eigenvalues, rank and eigenvectors of a symmetric `J`.
pub fn information_spectrum(j: &DMatrix<f64>, tol: f64) -> Result<InformationSpectrum> {
    if !j.is_square() || j.nrows() == 0 {
        return Err(SlamError::dimension(format!(
            "J must be square, got {:?}",
            j.shape()
        )));
    }
    ensure_finite("J", j.iter())?;
    if !(tol.is_finite() && tol >= 0.0) {
        return Err(SlamError::invalid(
            "tol",
            format!("must be finite and >= 0, got {tol}"),
        ));
    }
    let sym = (j + j.transpose()) * 0.5;
    let eig = sym.symmetric_eigen();
    let mut order: Vec<usize> = (0..eig.eigenvalues.len()).collect();
    order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
    let values = DVector::from_iterator(order.len(), order.iter().map(|&k| eig.eigenvalues[k]));
    let mut vectors = DMatrix::zeros(j.nrows(), order.len());
    for (c, &k) in order.iter().enumerate() {
        vectors.set_column(c, &eig.eigenvectors.column(k));
    }
    let max = values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let rank = values.iter().filter(|&&v| v > tol * max).count();
    Ok(InformationSpectrum {
        eigenvalues: values,
        eigenvectors: vectors,
        rank,
    })
}

/// A basis of the unobservable directions: eigenvectors of `J` whose eigenvalues are
/// at most `tol` times the largest, as columns (`d x k`).
pub fn unobservable_directions(j: &DMatrix<f64>, tol: f64) -> Result<DMatrix<f64>> {
    let spec = information_spectrum(j, tol)?;
    let k = j.nrows() - spec.rank;
    Ok(spec.eigenvectors.columns(0, k).clone_owned())
}

/// The closed form of eq. (17) for one landmark and the relative model:
/// `J = [[1, -1], [-1, 1]] * sum 1 / s_i` from the scalar innovation variances `s_i`.
pub fn one_landmark_fisher(innovation_variances: &[f64]) -> DMatrix<f64> {
    let total: f64 = innovation_variances.iter().map(|s| 1.0 / s).sum();
    DMatrix::from_row_slice(2, 2, &[1.0, -1.0, -1.0, 1.0]) * total
}
