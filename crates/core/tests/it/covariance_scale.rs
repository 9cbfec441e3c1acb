//! The covariance checks depend on the matrix, not on its units: `s * C` passes or
//! fails exactly as `C` does for any scale `s` that keeps every entry a normal
//! float. Found by the fuzz suite: a product of two variances of 1e-200 underflowed to
//! 0, so a valid covariance was refused, and one of 1e200 overflowed to inf, so any
//! covariance passed Cauchy-Schwarz.
use nalgebra::DMatrix;
use proptest::prelude::*;
use rperc_core::{Definiteness, check_covariance};

/// `J D J^T` (PSD by construction, rank <= 2) plus `eps` on the diagonal, symmetrised.
fn psd(j: &[f64], d: (f64, f64), eps: f64) -> DMatrix<f64> {
    let j = DMatrix::from_row_slice(3, 2, j);
    let d = DMatrix::from_row_slice(2, 2, &[d.0, 0.0, 0.0, d.1]);
    let p = &j * d * j.transpose() + DMatrix::identity(3, 3) * eps;
    (&p + p.transpose()) * 0.5
}

/// A power of ten built from normal factors (`powi` of a large negative exponent is
/// 0 in debug builds).
fn ten_to(e: i32) -> f64 {
    (0..e.unsigned_abs()).fold(1.0, |acc, _| if e < 0 { acc / 10.0 } else { acc * 10.0 })
}

proptest! {
    #[test]
    fn valid_covariances_pass_at_any_scale(
        j in prop::collection::vec(-3.0f64..3.0, 6),
        d in (0.01f64..2.0, 0.01f64..2.0),
        eps in 0.0f64..0.5,
        e in -280i32..280,
    ) {
        let c = psd(&j, d, eps);
        prop_assume!(check_covariance("C", &c, Definiteness::SemiPositive).is_ok());
        let scaled = &c * ten_to(e);
        prop_assert!(check_covariance("C", &scaled, Definiteness::SemiPositive).is_ok());
    }

    #[test]
    fn cauchy_schwarz_violations_fail_at_any_scale(
        v in (0.1f64..2.0, 0.1f64..2.0),
        excess in 1.01f64..10.0,
        e in -280i32..280,
    ) {
        // |c01| > sqrt(c00 c11): no covariance has this entry.
        let c01 = excess * (v.0 * v.1).sqrt();
        let c = DMatrix::from_row_slice(3, 3, &[v.0, c01, 0.0, c01, v.1, 0.0, 0.0, 0.0, 1.0]);
        let scaled = &c * ten_to(e);
        prop_assert!(check_covariance("C", &scaled, Definiteness::SemiPositive).is_err());
    }
}

#[test]
fn extreme_scales_near_the_float_limits() {
    let c = DMatrix::from_row_slice(2, 2, &[2.0, 1.0, 1.0, 1.0]);
    for s in [1e-300, 1e-200, 1e200, 5e307] {
        assert!(
            check_covariance("C", &(&c * s), Definiteness::Positive).is_ok(),
            "{s:e}"
        );
    }
}
