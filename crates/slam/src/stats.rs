//! Chi-square quantiles for consistency bands (NEES, NIS).

use crate::error::{Result, SlamError};

/// `ln Gamma(x)` for `x > 0` (Lanczos approximation, g = 7, relative error ~1e-15).
fn ln_gamma(x: f64) -> f64 {
    const G: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection keeps the approximation in its accurate range.
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let t = x + 7.5;
    let sum = G[1..]
        .iter()
        .enumerate()
        .fold(G[0], |acc, (i, g)| acc + g / (x + i as f64 + 1.0));
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + sum.ln()
}

/// The regularised lower incomplete gamma function `P(a, x)`: a power series below
/// `a + 1`, a continued fraction (modified Lentz) above.
fn gamma_p(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    let log_prefix = a * x.ln() - x - ln_gamma(a);
    if x < a + 1.0 {
        let (mut term, mut sum, mut n) = (1.0 / a, 1.0 / a, a);
        for _ in 0..10_000 {
            n += 1.0;
            term *= x / n;
            sum += term;
            if term.abs() < sum.abs() * 1e-16 {
                break;
            }
        }
        (sum.ln() + log_prefix).exp().min(1.0)
    } else {
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let delta = d * c;
            h *= delta;
            if (delta - 1.0).abs() < 1e-16 {
                break;
            }
        }
        (1.0 - (h.ln() + log_prefix).exp()).max(0.0)
    }
}

/// Cumulative distribution of the chi-square distribution with `dof` degrees of freedom.
pub fn chi2_cdf(x: f64, dof: f64) -> f64 {
    gamma_p(dof / 2.0, x / 2.0)
}

/// The `p` quantile of the chi-square distribution with `dof` degrees of freedom.
///
/// # Examples
/// ```
/// // Published table value: chi2(10) has its 97.5 % point at 20.483.
/// assert!((slam::chi2_quantile(0.975, 10.0).unwrap() - 20.483).abs() < 1e-3);
/// ```
pub fn chi2_quantile(p: f64, dof: f64) -> Result<f64> {
    if !(p > 0.0 && p < 1.0) {
        return Err(SlamError::InvalidParameter {
            name: "p",
            reason: format!("must be in (0, 1), got {p}"),
        });
    }
    if !(dof > 0.0 && dof.is_finite()) {
        return Err(SlamError::InvalidParameter {
            name: "dof",
            reason: format!("must be finite and > 0, got {dof}"),
        });
    }
    // Bracket, then bisect: the CDF is monotone, so this always converges.
    let (mut lo, mut hi) = (0.0, dof.max(1.0));
    while chi2_cdf(hi, dof) < p {
        lo = hi;
        hi *= 2.0;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if chi2_cdf(mid, dof) < p {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-13 * hi {
            break;
        }
    }
    Ok(0.5 * (lo + hi))
}

/// Two-sided band for the NEES of a `dof`-dimensional state averaged over `runs`
/// Monte Carlo runs: the sum over runs is chi-square with `dof * runs` degrees of
/// freedom, so the band is its `(1 -+ confidence) / 2` quantiles divided by `runs`.
///
/// # Examples
/// ```
/// let (lo, hi) = slam::nees_bounds(1, 50, 0.95).unwrap();
/// assert!(lo < 1.0 && 1.0 < hi);
/// ```
pub fn nees_bounds(dof: usize, runs: usize, confidence: f64) -> Result<(f64, f64)> {
    if dof == 0 || runs == 0 {
        return Err(SlamError::InvalidParameter {
            name: "dof/runs",
            reason: format!("both must be >= 1, got dof={dof}, runs={runs}"),
        });
    }
    if !(confidence > 0.0 && confidence < 1.0) {
        return Err(SlamError::InvalidParameter {
            name: "confidence",
            reason: format!("must be in (0, 1), got {confidence}"),
        });
    }
    let k = (dof * runs) as f64;
    let tail = (1.0 - confidence) / 2.0;
    Ok((
        chi2_quantile(tail, k)? / runs as f64,
        chi2_quantile(1.0 - tail, k)? / runs as f64,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Values from published chi-square tables.
    #[test]
    fn quantiles_match_tables() {
        for (p, dof, expected, tol) in [
            (0.975, 10.0, 20.483, 1e-3),
            (0.025, 10.0, 3.247, 1e-3),
            (0.95, 1.0, 3.841, 1e-3),
            (0.99, 2.0, 9.210, 1e-3),
            (0.5, 2.0, 1.386, 1e-3),
            (0.975, 100.0, 129.561, 1e-3),
            (0.025, 100.0, 74.222, 1e-3),
        ] {
            let q = chi2_quantile(p, dof).unwrap();
            assert!(
                (q - expected).abs() < tol,
                "chi2({dof}) at {p}: {q} vs {expected}"
            );
        }
        // chi2(2) has the closed form CDF 1 - exp(-x/2).
        for x in [0.1, 1.0, 5.0, 20.0] {
            assert!((chi2_cdf(x, 2.0) - (1.0 - (-x / 2.0_f64).exp())).abs() < 1e-13);
        }
    }

    #[test]
    fn bad_arguments_are_refused() {
        assert!(chi2_quantile(1.0, 2.0).is_err());
        assert!(chi2_quantile(0.5, 0.0).is_err());
        assert!(nees_bounds(0, 10, 0.95).is_err());
        assert!(nees_bounds(1, 10, 1.5).is_err());
    }
}
