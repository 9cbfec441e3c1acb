//! Chi-square quantiles and consistency bands (NEES, NIS, gates), from `statrs`.

use statrs::distribution::{ChiSquared, ContinuousCDF, Normal};

use crate::error::{CoreError, Result};

fn distribution(dof: f64) -> Result<ChiSquared> {
    if !(dof > 0.0 && dof.is_finite()) {
        return Err(CoreError::InvalidParameter {
            name: "dof",
            reason: format!("must be finite and > 0, got {dof}"),
        });
    }
    ChiSquared::new(dof).map_err(|e| CoreError::InvalidParameter {
        name: "dof",
        reason: e.to_string(),
    })
}

fn probability(name: &'static str, p: f64) -> Result<f64> {
    if p > 0.0 && p < 1.0 {
        Ok(p)
    } else {
        Err(CoreError::InvalidParameter {
            name,
            reason: format!("must be in (0, 1), got {p}"),
        })
    }
}

/// Cumulative distribution of the chi-square distribution with `dof` degrees of freedom.
pub fn chi2_cdf(x: f64, dof: f64) -> Result<f64> {
    Ok(distribution(dof)?.cdf(x))
}

/// Above this many degrees of freedom the quantile comes from the Wilson-Hilferty
/// cube-root transform, whose relative error falls as 1/dof (below 1e-12 here), where
/// the incomplete-gamma inversion would need time growing with sqrt(dof).
const WILSON_HILFERTY_DOF: f64 = 1e10;

/// The `p` quantile of the chi-square distribution with `dof` degrees of freedom.
///
/// # Examples
/// ```
/// // Published table value: chi2(10) has its 97.5 % point at 20.483.
/// assert!((rperc_core::chi2_quantile(0.975, 10.0).unwrap() - 20.483).abs() < 1e-3);
/// ```
pub fn chi2_quantile(p: f64, dof: f64) -> Result<f64> {
    let p = probability("p", p)?;
    let chi = distribution(dof)?;
    if dof > WILSON_HILFERTY_DOF {
        return Ok(wilson_hilferty(p, dof));
    }
    Ok(chi.inverse_cdf(p))
}

/// `dof (1 - 2/(9 dof) + z sqrt(2/(9 dof)))^3` with `z` the standard normal quantile.
fn wilson_hilferty(p: f64, dof: f64) -> f64 {
    let z = Normal::standard().inverse_cdf(p);
    let v = 2.0 / (9.0 * dof);
    dof * (1.0 - v + z * v.sqrt()).powi(3)
}

/// The validation gate of an innovation with `dof` entries: its NIS is accepted when
/// below this value, which a correct innovation exceeds with probability `1 - confidence`.
///
/// # Examples
/// ```
/// // The classic 99 % gate of a 2-D innovation (9.21).
/// assert!((rperc_core::chi2_gate(2, 0.99).unwrap() - 9.2103).abs() < 1e-4);
/// ```
pub fn chi2_gate(dof: usize, confidence: f64) -> Result<f64> {
    let confidence = probability("confidence", confidence)?;
    chi2_quantile(confidence, dof as f64)
}

/// Two-sided band for the NEES of a `dof`-dimensional state averaged over `runs`
/// Monte Carlo runs: the sum over runs is chi-square with `dof * runs` degrees of
/// freedom, so the band is its `(1 -+ confidence) / 2` quantiles divided by `runs`
/// (Bar-Shalom, Li & Kirubarajan 2001, section 5.4).
///
/// # Examples
/// ```
/// let (lo, hi) = rperc_core::nees_band(1, 50, 0.95).unwrap();
/// assert!(lo < 1.0 && 1.0 < hi);
/// ```
pub fn nees_band(dof: usize, runs: usize, confidence: f64) -> Result<(f64, f64)> {
    if dof == 0 || runs == 0 {
        return Err(CoreError::InvalidParameter {
            name: "dof/runs",
            reason: format!("both must be >= 1, got dof={dof}, runs={runs}"),
        });
    }
    let confidence = probability("confidence", confidence)?;
    // dof * runs may not fit a usize; in f64 it is exact up to 2^53.
    let k = dof as f64 * runs as f64;
    let tail = (1.0 - confidence) / 2.0;
    Ok((
        chi2_quantile(tail, k)? / runs as f64,
        chi2_quantile(1.0 - tail, k)? / runs as f64,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Values from published chi-square tables, and the closed form of dof 2.
    #[test]
    fn quantiles_match_tables_and_closed_form() {
        for (p, dof, expected) in [
            (0.975, 10.0, 20.483),
            (0.025, 10.0, 3.247),
            (0.95, 1.0, 3.841),
            (0.99, 2.0, 9.210),
            (0.975, 100.0, 129.561),
            (0.025, 100.0, 74.222),
        ] {
            let q = chi2_quantile(p, dof).unwrap();
            assert!((q - expected).abs() < 1e-3, "chi2({dof}) at {p}: {q}");
        }
        // dof 2: CDF 1 - exp(-x/2), so the quantile is -2 ln(1 - p).
        for p in [1e-6, 0.1, 0.5, 0.9, 0.999_999] {
            let q = chi2_quantile(p, 2.0).unwrap();
            let want = -2.0 * (-p).ln_1p();
            assert!((q - want).abs() <= 1e-9 * want, "{p}: {q} vs {want}");
            assert!((chi2_cdf(want, 2.0).unwrap() - p).abs() < 1e-12);
        }
    }

    /// Where both paths apply, the cube-root transform agrees with the incomplete-gamma
    /// inversion to its O(1/dof) error; and the band stays ordered for huge products.
    #[test]
    fn large_dof_quantiles_agree_across_methods() {
        for dof in [1e8, 1e9] {
            let exact = distribution(dof).unwrap();
            for p in [0.025, 0.5, 0.975] {
                let (a, b) = (exact.inverse_cdf(p), wilson_hilferty(p, dof));
                assert!((a / b - 1.0).abs() < 1e-9, "dof {dof} p {p}: {a} vs {b}");
            }
        }
        let (lo, hi) = nees_band(usize::MAX / 2, 4, 0.95).unwrap();
        let dof = (usize::MAX / 2) as f64;
        assert!(lo < dof && dof < hi);
    }

    #[test]
    fn bad_arguments_are_refused() {
        assert!(chi2_quantile(1.0, 2.0).is_err());
        assert!(chi2_quantile(0.5, 0.0).is_err());
        assert!(chi2_quantile(0.5, f64::NAN).is_err());
        assert!(nees_band(0, 10, 0.95).is_err());
        assert!(nees_band(1, 10, 1.5).is_err());
        assert!(chi2_gate(2, 0.0).is_err());
    }
}
