//! The normalised auto-correlation of a grey-level vector, its linear approximation
//! (the `W(j)` of eq. 4) and the normalised inter-correlation of section 3.3.
//!
//! Grey-level vectors are stored with their mean removed: the paper's normalisation by
//! `||V||` already cancels a gain, removing the mean also cancels an offset, so the
//! inter-correlation is invariant to `g -> a g + b` (`a > 0`), the illumination change
//! the paper claims robustness to. The auto-correlation is computed on the same
//! zero-mean vector so that its slope and the inter-correlation are on one scale.

/// Removes the mean of `v` in place and returns its standard deviation (the contrast
/// of the profile).
pub fn remove_mean(v: &mut [f32]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let n = v.len() as f64;
    let mean = v.iter().map(|&g| f64::from(g)).sum::<f64>() / n;
    let mut ss = 0.0;
    for g in v.iter_mut() {
        let d = f64::from(*g) - mean;
        *g = d as f32;
        ss += d * d;
    }
    (ss / n).sqrt()
}

/// The discrete normalised auto-correlation `C_GG(lambda)` of section 3.2:
/// `(1 / ||V||^2) sum_l G(l) G(l - lambda)` with `G` zero outside `1..=Ns`.
/// Returns 0 for a zero vector.
pub fn autocorrelation(v: &[f32], lambda: usize) -> f64 {
    let energy: f64 = v.iter().map(|&g| f64::from(g) * f64::from(g)).sum();
    if energy <= 0.0 || lambda >= v.len() {
        return 0.0;
    }
    let cross: f64 = v[lambda..]
        .iter()
        .zip(v)
        .map(|(&a, &b)| f64::from(a) * f64::from(b))
        .sum();
    cross / energy
}

/// The slope `W` of the straight line `C~(lambda) = 1 + W lambda` approximating the
/// auto-correlation near `lambda = 0` (Figure 6).
///
/// The line is forced through `C(0) = 1` and fitted by least squares to
/// `C(1), ..., C(fit_lags)`: `W = sum_k k (C(k) - 1) / sum_k k^2`. For a centred step
/// profile of `Ns` samples `C(lambda) = 1 - 3 lambda / Ns` exactly, so `W = -3 / Ns`.
/// `W <= 0` for any vector; a flat (textureless) profile has `W` near 0.
pub fn autocorrelation_slope(v: &[f32], fit_lags: usize) -> f64 {
    let lags = fit_lags.min(v.len().saturating_sub(1));
    let (mut num, mut den) = (0.0, 0.0);
    for k in 1..=lags {
        let kf = k as f64;
        num += kf * (autocorrelation(v, k) - 1.0);
        den += kf * kf;
    }
    if den > 0.0 { num / den } else { 0.0 }
}

/// The curvature `a` of the parabola `C~(lambda) = 1 - a lambda^2` approximating the
/// auto-correlation near `lambda = 0`, fitted as [`autocorrelation_slope`] is: forced
/// through `C(0) = 1`, least squares on `C(1), ..., C(fit_lags)`: `a = sum_k k^2 (1 -
/// C(k)) / sum_k k^4` (`>= 0`; near 0 for a flat profile).
///
/// Why a parabola: the tracker's profiles are sampled from Gaussian-blurred images, so
/// the inter-correlation of a profile observed `d` samples off falls as `1 - C ~ d^2`
/// for sub-sample `d` (a smooth peak), not linearly. The straight line's inverse then
/// reads `lambda ~ d^2`, and eq. 6's `Omega_sigma(lambda)` goes as `exp(-d^4)`: flat at
/// the peak, where the estimate is then set by the few worst-fitting points that pass
/// the occlusion test (partly occluded ones) rather than by all of them. The
/// parabola's inverse keeps `lambda` proportional to `d`.
pub fn autocorrelation_curvature(v: &[f32], fit_lags: usize) -> f64 {
    let lags = fit_lags.min(v.len().saturating_sub(1));
    let (mut num, mut den) = (0.0, 0.0);
    for k in 1..=lags {
        let k2 = (k * k) as f64;
        num += k2 * (1.0 - autocorrelation(v, k));
        den += k2 * k2;
    }
    if den > 0.0 { (num / den).max(0.0) } else { 0.0 }
}

/// The deviation `lambda = C~^-1(c)` for the parabola `C~(lambda) = 1 - a lambda^2`
/// of [`autocorrelation_curvature`], in samples: `sqrt((1 - c) / a)`.
pub fn deviation_parabolic(inter_correlation: f64, curvature: f64) -> f64 {
    ((1.0 - inter_correlation).max(0.0) / curvature.max(f64::MIN_POSITIVE)).sqrt()
}

/// The normalised inter-correlation `V . V_k / (||V|| ||V_k||)` (section 3.3) between
/// a stored zero-mean vector and an observed vector (whose mean is removed here
/// without modifying it). 0 when either vector is flat.
pub fn inter_correlation(stored: &[f32], observed: &[f32]) -> f64 {
    inter_correlation_with_energy(stored, energy(stored), observed)
}

/// `sum g^2` of a vector, in `f64`: the stored vector's part of the inter-correlation's
/// normalisation, computed once per model point rather than once per particle.
pub fn energy(v: &[f32]) -> f64 {
    v.iter().map(|&g| f64::from(g) * f64::from(g)).sum()
}

/// [`inter_correlation`] with the stored vector's [`energy`] given.
///
/// The sums run in `f32` (twelve-odd grey levels below 256 lose nothing that matters:
/// the relative rounding is about 1e-6, a thousandth of a sample of deviation) and the
/// ratio in `f64`.
#[inline]
pub fn inter_correlation_with_energy(stored: &[f32], stored_energy: f64, observed: &[f32]) -> f64 {
    let mean = observed.iter().sum::<f32>() / observed.len() as f32;
    let (mut dot, mut so) = (0.0f32, 0.0f32);
    for (&a, &b) in stored.iter().zip(observed) {
        let b = b - mean;
        dot += a * b;
        so += b * b;
    }
    let norm = (f64::from(so) * stored_energy).sqrt();
    if norm > 1e-9 {
        f64::from(dot) / norm
    } else {
        0.0
    }
}

/// The parts of [`inter_correlation`] that depend on the observed vector, in one pass
/// over it: `(dot, energy)` with `dot = sum a (b - mean b)` and `energy = sum (b -
/// mean b)^2`, so that `C = dot / sqrt(energy * sum a^2)`. `stored_sum` is `sum a`
/// (zero up to rounding for a stored zero-mean vector).
///
/// One pass instead of two (mean, then the centred sums): `sum a (b - m) = sum a b - m
/// sum a` and `sum (b - m)^2 = sum b^2 - m sum b`, with `b` taken relative to its first
/// value so that the difference does not cancel digits of grey levels near 255. Four
/// independent partial sums per quantity let the compiler keep them in one vector
/// register.
#[inline]
pub fn centred_products(stored: &[f32], stored_sum: f32, observed: &[f32]) -> (f32, f32) {
    let Some(&first) = observed.first() else {
        return (0.0, 0.0);
    };
    let (mut s1, mut s2, mut sab) = ([0.0f32; 4], [0.0f32; 4], [0.0f32; 4]);
    let (a4, b4) = (stored.chunks_exact(4), observed.chunks_exact(4));
    let (a_rest, b_rest) = (a4.remainder(), b4.remainder());
    for (a, b) in a4.zip(b4) {
        for k in 0..4 {
            let d = b[k] - first;
            s1[k] += d;
            s2[k] += d * d;
            sab[k] += a[k] * d;
        }
    }
    for (k, (&a, &b)) in a_rest.iter().zip(b_rest).enumerate() {
        let d = b - first;
        s1[k] += d;
        s2[k] += d * d;
        sab[k] += a * d;
    }
    let total = |v: [f32; 4]| (v[0] + v[1]) + (v[2] + v[3]);
    let (s1, s2, sab) = (total(s1), total(s2), total(sab));
    let mean = s1 / observed.len() as f32;
    (sab - mean * stored_sum, (s2 - mean * s1).max(0.0))
}

/// The deviation `lambda = C~^-1(c)` of section 3.3 for the linear approximation
/// `C~(lambda) = 1 + W lambda` (`W < 0`), in samples: `(1 - c) / |W|`.
pub fn deviation(inter_correlation: f64, slope: f64) -> f64 {
    (1.0 - inter_correlation) / slope.abs().max(f64::MIN_POSITIVE)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn autocorrelation_matches_brute_force_definition() {
        let v: Vec<f32> = [3.0, -1.0, 4.0, 1.0, -5.0, 9.0, 2.0, -6.0].to_vec();
        let ns = v.len() as i64;
        // G(l) = g_l for l = 1..Ns, zero elsewhere; sum over l = -Ns..Ns.
        let g = |l: i64| {
            if (1..=ns).contains(&l) {
                f64::from(v[(l - 1) as usize])
            } else {
                0.0
            }
        };
        let energy: f64 = (1..=ns).map(|l| g(l) * g(l)).sum();
        for lambda in 0..ns {
            let brute: f64 = (-ns..=ns).map(|l| g(l) * g(l - lambda)).sum::<f64>() / energy;
            assert!((autocorrelation(&v, lambda as usize) - brute).abs() < 1e-12);
        }
        assert!((autocorrelation(&v, 0) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn slope_of_a_step_profile_is_minus_three_over_ns() {
        for ns in [8usize, 12, 20] {
            let mut v: Vec<f32> = (0..ns)
                .map(|l| if l < ns / 2 { 10.0 } else { 70.0 })
                .collect();
            remove_mean(&mut v);
            for lags in 1..=3 {
                let w = autocorrelation_slope(&v, lags);
                assert!(
                    (w + 3.0 / ns as f64).abs() < 1e-9,
                    "ns {ns} lags {lags}: {w}"
                );
            }
            // The deviation grows with the shift of the observed profile.
            let w1 = autocorrelation_slope(&v, 1);
            let lambdas: Vec<f64> = (0..3)
                .map(|shift| {
                    let obs: Vec<f32> = (0..ns)
                        .map(|l| if l < ns / 2 + shift { 10.0 } else { 70.0 })
                        .collect();
                    deviation(inter_correlation(&v, &obs), w1)
                })
                .collect();
            assert!(lambdas[0].abs() < 1e-6 && lambdas[0] < lambdas[1] && lambdas[1] < lambdas[2]);
        }
    }

    /// The parabola's curvature against its closed form on a step profile, whose
    /// auto-correlation is `1 - 3 k / Ns` (`a = (3 / Ns) sum k^3 / sum k^4`), and its
    /// inverse against the parabola itself.
    #[test]
    fn curvature_of_a_step_profile_and_its_inverse() {
        for ns in [8usize, 12, 20] {
            let mut v: Vec<f32> = (0..ns)
                .map(|l| if l < ns / 2 { 10.0 } else { 70.0 })
                .collect();
            remove_mean(&mut v);
            for lags in 1..=3usize {
                let (k3, k4): (f64, f64) = (1..=lags)
                    .map(|k| ((k as f64).powi(3), (k as f64).powi(4)))
                    .fold((0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
                let want = 3.0 / ns as f64 * k3 / k4;
                let a = autocorrelation_curvature(&v, lags);
                assert!(
                    (a - want).abs() < 1e-9,
                    "ns {ns} lags {lags}: {a} vs {want}"
                );
                for lambda in [0.0, 0.3, 1.0, 1.7] {
                    let c = 1.0 - a * lambda * lambda;
                    assert!((deviation_parabolic(c, a) - lambda).abs() < 1e-9);
                }
            }
        }
        assert_eq!(deviation_parabolic(1.0 + 1e-12, 0.2), 0.0);
    }

    /// A blurred step observed `d` samples off (erf profile, sigma 1 sample: the
    /// tracker's blur): the parabola reads a deviation proportional to `d` for
    /// sub-sample offsets, the line one that grows as `d^2` (the reason for the
    /// parabola).
    #[test]
    fn the_parabola_reads_sub_sample_offsets_linearly() {
        let erf = |x: f64| {
            // Abramowitz & Stegun 7.1.26 (error below 1.5e-7).
            let t = 1.0 / (1.0 + 0.327_591_1 * x.abs());
            let poly = t
                * (0.254_829_592
                    + t * (-0.284_496_736
                        + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
            (1.0 - poly * (-x * x).exp()).copysign(x)
        };
        let profile = |d: f64| -> Vec<f32> {
            (0..12)
                .map(|l| {
                    let x = l as f64 - 5.5 + d;
                    (100.0 + 80.0 * erf(x / std::f64::consts::SQRT_2)) as f32
                })
                .collect()
        };
        let mut stored = profile(0.0);
        remove_mean(&mut stored);
        let (a, w) = (
            autocorrelation_curvature(&stored, 2),
            autocorrelation_slope(&stored, 2),
        );
        let read = |d: f64| {
            let c = inter_correlation(&stored, &profile(d));
            (deviation_parabolic(c, a), deviation(c, w))
        };
        let (p1, l1) = read(0.1);
        for d in [0.2, 0.4] {
            let (p, l) = read(d);
            let ratio = d / 0.1;
            // Proportional within 5 % for the parabola; the line's ratio is the square.
            assert!(
                (p / p1 / ratio - 1.0).abs() < 0.05,
                "parabola at {d}: {p} vs {p1}"
            );
            assert!(
                (l / l1 / (ratio * ratio) - 1.0).abs() < 0.1,
                "line at {d}: {l} vs {l1}"
            );
        }
    }

    /// The one-pass products against the two-pass definition, in f64.
    #[test]
    fn centred_products_match_the_two_pass_sums() {
        for n in [1usize, 3, 4, 7, 12, 13] {
            let mut a: Vec<f32> = (0..n).map(|l| ((l * 37) % 11) as f32 * 9.0).collect();
            remove_mean(&mut a);
            let b: Vec<f32> = (0..n)
                .map(|l| 250.0 - ((l * 53) % 17) as f32 * 3.5)
                .collect();
            let mean = b.iter().map(|&g| f64::from(g)).sum::<f64>() / n as f64;
            let dot: f64 = a
                .iter()
                .zip(&b)
                .map(|(&x, &y)| f64::from(x) * (f64::from(y) - mean))
                .sum();
            let so: f64 = b.iter().map(|&y| (f64::from(y) - mean).powi(2)).sum();
            let sum: f32 = a.iter().sum();
            let (d, e) = centred_products(&a, sum, &b);
            assert!(
                (f64::from(d) - dot).abs() < 1e-3 * (1.0 + dot.abs()),
                "n {n}: {d} vs {dot}"
            );
            assert!(
                (f64::from(e) - so).abs() < 1e-3 * (1.0 + so),
                "n {n}: {e} vs {so}"
            );
        }
        assert_eq!(centred_products(&[], 0.0, &[]), (0.0, 0.0));
    }

    #[test]
    fn inter_correlation_ignores_gain_and_offset() {
        let mut v: Vec<f32> = vec![1.0, 5.0, 2.0, 8.0, 3.0];
        let obs: Vec<f32> = v.iter().map(|g| 2.5 * g + 40.0).collect();
        remove_mean(&mut v);
        assert!((inter_correlation(&v, &obs) - 1.0).abs() < 1e-6);
    }
}
