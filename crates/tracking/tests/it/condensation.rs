//! The particle filter against independent oracles: a Kalman filter written out here, and
//! the known count distributions of each resampler.

use nalgebra::{Matrix2, SMatrix, SVector, Vector2};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use tracking::{
    FilterParams, LinearGaussian, ParticleFilter, ResamplePolicy, Resampler, StepReport,
    effective_sample_size,
};

// ---------------------------------------------------------------- Kalman oracle

/// x_t = A x_{t-1} + B w,  z_t = H x_t + v,  v ~ N(0, r^2), H = [1, 0].
struct Model {
    a: Matrix2<f64>,
    b: Matrix2<f64>,
    r: f64,
}

/// Textbook Kalman predict + update for a scalar measurement of the first component.
fn kalman_step(
    m: &Model,
    mean: Vector2<f64>,
    cov: Matrix2<f64>,
    z: f64,
) -> (Vector2<f64>, Matrix2<f64>, Matrix2<f64>) {
    let mp = m.a * mean;
    let pp = m.a * cov * m.a.transpose() + m.b * m.b.transpose();
    let s = pp[(0, 0)] + m.r * m.r;
    let k = Vector2::new(pp[(0, 0)], pp[(1, 0)]) / s;
    let innovation = z - mp[0];
    let mean = mp + k * innovation;
    let mut ikh = Matrix2::<f64>::identity();
    ikh[(0, 0)] -= k[0];
    ikh[(1, 0)] -= k[1];
    let cov = ikh * pp;
    // Error-propagation matrix of the filter: an error in the prior mean reaches the
    // posterior mean multiplied by (I - K H) A.
    (mean, cov, ikh * m.a)
}

#[test]
fn linear_gaussian_filter_converges_to_kalman() {
    let model = Model {
        a: Matrix2::new(0.95, 0.1, 0.0, 0.9),
        b: Matrix2::new(0.3, 0.0, 0.0, 0.2),
        r: 0.5,
    };
    let m0 = Vector2::new(1.0, -0.5);
    let p0 = Matrix2::new(1.0, 0.2, 0.2, 0.5);
    let n = 40_000;

    // Simulated truth and measurements from their own seeded stream.
    let mut sim = ChaCha8Rng::seed_from_u64(2024);
    let mut x = m0;
    let mut zs = Vec::new();
    for _ in 0..15 {
        let w = Vector2::new(
            StandardNormal.sample(&mut sim),
            StandardNormal.sample(&mut sim),
        );
        x = model.a * x + model.b * w;
        let v: f64 = StandardNormal.sample(&mut sim);
        zs.push(x[0] + model.r * v);
    }

    let dynamics = LinearGaussian {
        a: model.a,
        b: model.b,
    };
    let params = FilterParams {
        resampler: Resampler::Systematic,
        ..FilterParams::default()
    };
    let mut pf = ParticleFilter::new(n, m0, p0, dynamics, params, 11).unwrap();
    let (mut km, mut kp) = (m0, p0);
    // Monte-Carlo error of the filter's mean: each step adds sampling error of covariance
    // about P/ESS (weighting) + P/n (resampling) and carries the previous error through
    // F = (I - K H) A. `err_cov` accumulates exactly that recursion.
    let mut err_cov = p0 / n as f64;
    let mut cov_err_var = Matrix2::<f64>::zeros();
    for &z in &zs {
        let r = model.r;
        let report = pf.step(&|s: &SVector<f64, 2>| -0.5 * ((s[0] - z) / r).powi(2));
        assert!(!report.lost && report.resampled);
        let (m, p, f) = kalman_step(&model, km, kp, z);
        km = m;
        kp = p;
        let fresh = kp * (1.0 / report.ess + 1.0 / n as f64);
        err_cov = f * err_cov * f.transpose() + fresh;
        // Sample covariance of `ess` draws: Var(S_ij) = (P_ii P_jj + P_ij^2) / ess; the
        // previous step's error reaches it through F twice.
        let rho = f.norm();
        cov_err_var = cov_err_var * rho.powi(4)
            + Matrix2::from_fn(|i, j| {
                (kp[(i, i)] * kp[(j, j)] + kp[(i, j)].powi(2)) * (1.0 / report.ess + 1.0 / n as f64)
            });

        let mean = pf.mean();
        let cov = pf.covariance();
        for i in 0..2 {
            let tol = 5.0 * err_cov[(i, i)].sqrt();
            assert!(
                (mean[i] - km[i]).abs() < tol,
                "mean[{i}] {} vs Kalman {} (tol {tol})",
                mean[i],
                km[i]
            );
            for j in 0..2 {
                let tol = 5.0 * cov_err_var[(i, j)].sqrt();
                assert!(
                    (cov[(i, j)] - kp[(i, j)]).abs() < tol,
                    "cov[{i},{j}] {} vs Kalman {} (tol {tol})",
                    cov[(i, j)],
                    kp[(i, j)]
                );
            }
        }
    }
}

#[test]
fn a_shift_is_a_control_input_of_the_random_walk() {
    // s_t = s_{t-1} + u_t + B w: a filter shifted by each u_t before its step is the
    // unshifted filter (same seed) of the state minus the summed controls, whose
    // likelihood is moved by them; every particle differs by that sum.
    let dynamics = LinearGaussian::random_walk(Vector2::new(0.3, 0.2));
    let make = || {
        let params = FilterParams::default();
        ParticleFilter::new(
            300,
            Vector2::zeros(),
            Matrix2::identity(),
            dynamics.clone(),
            params,
            9,
        )
        .unwrap()
    };
    let (mut shifted, mut plain) = (make(), make());
    let mut total = Vector2::zeros();
    for t in 0..6 {
        let u = Vector2::new(1.5 - 0.4 * t as f64, 0.25 * t as f64);
        total += u;
        let z = total + Vector2::new(0.1, -0.2);
        shifted.shift(&u).unwrap();
        shifted.step(&|s: &SVector<f64, 2>| -0.5 * (s - z).norm_squared());
        plain.step(&|s: &SVector<f64, 2>| -0.5 * (s + total - z).norm_squared());
        for (a, b) in shifted.particles().iter().zip(plain.particles()) {
            assert!(
                (a - b - total).norm() < 1e-9,
                "step {t}: {a} vs {b} + {total}"
            );
        }
        assert!((shifted.mean() - plain.mean() - total).norm() < 1e-9);
    }
    // A non-finite control is refused and moves nothing.
    let before = shifted.particles().to_vec();
    assert!(shifted.shift(&Vector2::new(f64::NAN, 0.0)).is_err());
    assert!(shifted.shift(&Vector2::new(0.0, f64::INFINITY)).is_err());
    assert_eq!(shifted.particles(), &before[..]);
}

/// `clamp` puts each component into its interval, `min(max(v, lo), hi)` of the set
/// before, and leaves the weights alone; particles already inside do not move.
#[test]
fn clamping_keeps_each_component_in_its_interval() {
    let dynamics = LinearGaussian::random_walk(Vector2::new(1.0, 1.0));
    let mut pf = ParticleFilter::new(
        200,
        Vector2::zeros(),
        Matrix2::identity() * 4.0,
        dynamics,
        FilterParams::default(),
        5,
    )
    .unwrap();
    pf.step(&|s: &SVector<f64, 2>| -0.5 * (s - Vector2::new(0.5, -0.5)).norm_squared());
    let (before, weights) = (pf.particles().to_vec(), pf.weights().to_vec());
    let (lo, hi) = (Vector2::new(-1.0, -0.5), Vector2::new(0.75, 2.0));
    pf.clamp(&lo, &hi);
    let mut moved = 0;
    for (a, b) in pf.particles().iter().zip(&before) {
        for d in 0..2 {
            let expected = if b[d] < lo[d] {
                lo[d]
            } else if b[d] > hi[d] {
                hi[d]
            } else {
                b[d]
            };
            assert_eq!(a[d], expected);
        }
        moved += usize::from(a != b);
    }
    assert!(moved > 0 && moved < before.len(), "{moved} moved");
    assert_eq!(pf.weights(), &weights[..]);
}

// ---------------------------------------------------------------- determinism

fn run_filter(threads: usize, parallel: bool) -> (Vec<SVector<f64, 3>>, Vec<f64>, Vec<StepReport>) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let dynamics = LinearGaussian::random_walk(SVector::<f64, 3>::new(0.5, 0.5, 0.05));
        let params = FilterParams {
            chunk_size: 16,
            parallel,
            ..FilterParams::default()
        };
        let mut pf = ParticleFilter::new(
            1000,
            SVector::zeros(),
            SMatrix::identity(),
            dynamics,
            params,
            99,
        )
        .unwrap();
        let mut reports = Vec::new();
        for t in 0..10 {
            let target = SVector::<f64, 3>::new(t as f64 * 0.3, -(t as f64) * 0.2, 1.0);
            reports.push(pf.step(&|s: &SVector<f64, 3>| -(s - target).norm_squared()));
        }
        (pf.particles().to_vec(), pf.log_weights().to_vec(), reports)
    })
}

#[test]
fn bit_identical_whatever_the_thread_count() {
    let one = run_filter(1, true);
    let two = run_filter(2, true);
    let serial = run_filter(2, false);
    let bits = |v: &(Vec<SVector<f64, 3>>, Vec<f64>, Vec<StepReport>)| {
        let mut b: Vec<u64> =
            v.0.iter()
                .flat_map(|p| p.iter().map(|x| x.to_bits()))
                .collect();
        b.extend(v.1.iter().map(|x| x.to_bits()));
        b
    };
    assert_eq!(bits(&one), bits(&two));
    assert_eq!(bits(&one), bits(&serial));
    assert_eq!(one.2, two.2);
}

#[test]
fn resample_below_threshold_keeps_weights_otherwise() {
    let dynamics = LinearGaussian::random_walk(SVector::<f64, 1>::new(0.01));
    let params = FilterParams {
        policy: ResamplePolicy::BelowEss(0.5),
        ..FilterParams::default()
    };
    let mut pf = ParticleFilter::new(
        500,
        SVector::zeros(),
        SMatrix::identity(),
        dynamics,
        params,
        5,
    )
    .unwrap();
    // A flat likelihood keeps ESS at n: no resampling.
    let r = pf.step(&|_: &SVector<f64, 1>| 0.0);
    assert!(!r.resampled);
    // A sharp one collapses ESS; the next step must resample.
    let r = pf.step(&|s: &SVector<f64, 1>| -50.0 * s[0] * s[0]);
    assert!(r.ess < 250.0);
    let r = pf.step(&|_: &SVector<f64, 1>| 0.0);
    assert!(r.resampled);
}

// ---------------------------------------------------------------- resamplers

const WEIGHTS: [f64; 7] = [0.31, 0.005, 0.2, 0.0, 0.137, 0.05, 0.298];

fn counts(idx: &[usize], m: usize) -> Vec<usize> {
    let mut c = vec![0; m];
    for &i in idx {
        c[i] += 1;
    }
    c
}

/// Mean counts over many repetitions must match n w_i within 4.5 standard errors, where
/// `var_bound(i)` bounds the variance of one repetition's count for that scheme.
fn check_unbiased(
    resampler: Resampler,
    n: usize,
    var_bound: impl Fn(f64) -> f64,
    per_run: impl Fn(&[usize]),
) {
    let reps = 4000;
    let mut rng = ChaCha8Rng::seed_from_u64(77);
    let mut idx = Vec::new();
    let mut sum = vec![0.0; WEIGHTS.len()];
    for _ in 0..reps {
        resampler.resample(&WEIGHTS, n, &mut rng, &mut idx).unwrap();
        assert_eq!(idx.len(), n);
        assert!(
            idx.windows(2).all(|w| w[0] <= w[1]),
            "indices must be sorted"
        );
        let c = counts(&idx, WEIGHTS.len());
        assert_eq!(c[3], 0, "{resampler:?} picked a zero-weight particle");
        per_run(&c);
        for (s, &k) in sum.iter_mut().zip(&c) {
            *s += k as f64;
        }
    }
    for (i, &w) in WEIGHTS.iter().enumerate() {
        let expected = n as f64 * w;
        let mean = sum[i] / reps as f64;
        let se = (var_bound(w) / reps as f64).sqrt().max(1e-12);
        assert!(
            (mean - expected).abs() <= 4.5 * se,
            "{resampler:?} particle {i}: mean count {mean}, expected {expected}"
        );
    }
}

#[test]
fn systematic_counts_are_floor_or_ceil() {
    let n = 40;
    check_unbiased(
        Resampler::Systematic,
        n,
        |_| 0.25,
        |c| {
            for (&k, &w) in c.iter().zip(&WEIGHTS) {
                let e = n as f64 * w;
                assert!(
                    k as f64 >= e.floor() && k as f64 <= e.ceil(),
                    "count {k} for n w = {e}"
                );
            }
        },
    );
}

#[test]
fn stratified_counts_are_within_one_of_floor_ceil() {
    let n = 40;
    // At most two strata are partly covered by a particle's interval: variance <= 2/4.
    check_unbiased(
        Resampler::Stratified,
        n,
        |_| 0.5,
        |c| {
            for (&k, &w) in c.iter().zip(&WEIGHTS) {
                let e = n as f64 * w;
                assert!(
                    k as f64 >= e.floor() - 1.0 && k as f64 <= e.ceil() + 1.0,
                    "count {k} for n w = {e}"
                );
            }
        },
    );
}

#[test]
fn residual_counts_have_the_deterministic_floor() {
    let n = 40;
    // Only the residual draws are random: variance <= R r (1 - r) <= R / 4, R < 7 draws.
    check_unbiased(
        Resampler::Residual,
        n,
        |_| 7.0 / 4.0,
        |c| {
            for (&k, &w) in c.iter().zip(&WEIGHTS) {
                let e = n as f64 * w;
                assert!(k as f64 >= e.floor(), "count {k} below floor of n w = {e}");
            }
        },
    );
}

#[test]
fn multinomial_counts_are_unbiased_and_pass_chi_square() {
    let n = 40;
    check_unbiased(
        Resampler::Multinomial,
        n,
        |w| n as f64 * w * (1.0 - w),
        |_| {},
    );
    // One large draw: Pearson chi-square over the 6 positive-weight particles (5 degrees
    // of freedom); 20.52 is the 99.9% quantile.
    let big = 200_000;
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut idx = Vec::new();
    Resampler::Multinomial
        .resample(&WEIGHTS, big, &mut rng, &mut idx)
        .unwrap();
    let c = counts(&idx, WEIGHTS.len());
    let chi2: f64 = WEIGHTS
        .iter()
        .zip(&c)
        .filter(|(w, _)| **w > 0.0)
        .map(|(&w, &k)| {
            let e = big as f64 * w;
            (k as f64 - e).powi(2) / e
        })
        .sum();
    assert!(chi2 < 20.52, "chi-square {chi2}");
}

#[test]
fn resamplers_reject_bad_weights_and_handle_edge_cases() {
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let mut idx = vec![9];
    for r in [
        Resampler::Multinomial,
        Resampler::Systematic,
        Resampler::Stratified,
        Resampler::Residual,
    ] {
        assert!(r.resample(&[], 3, &mut rng, &mut idx).is_err());
        assert!(r.resample(&[0.0, 0.0], 3, &mut rng, &mut idx).is_err());
        assert!(r.resample(&[1.0, -0.1], 3, &mut rng, &mut idx).is_err());
        assert!(r.resample(&[1.0, f64::NAN], 3, &mut rng, &mut idx).is_err());
        r.resample(&[0.0, 3.0, 0.0], 5, &mut rng, &mut idx).unwrap();
        assert_eq!(idx, vec![1; 5], "{r:?}");
        r.resample(&[2.0, 2.0], 0, &mut rng, &mut idx).unwrap();
        assert!(idx.is_empty());
        // Unnormalised weights are fine.
        r.resample(&[10.0, 30.0], 4, &mut rng, &mut idx).unwrap();
        assert_eq!(idx.len(), 4);
    }
}

#[test]
fn effective_sample_size_formula() {
    let ess = |w: &[f64]| effective_sample_size(w).unwrap();
    assert!((ess(&[0.1; 10]) - 10.0).abs() < 1e-12);
    assert_eq!(ess(&[1.0, 0.0, 0.0]), 1.0);
    // 1 / (0.6^2 + 0.2^2 + 0.2^2) = 1 / 0.44
    assert!((ess(&[0.6, 0.2, 0.2]) - 1.0 / 0.44).abs() < 1e-12);
    // Unnormalised weights: the same as their normalised version (3 + 1 + 1 = 5).
    assert!((ess(&[3.0, 1.0, 1.0]) - 1.0 / 0.44).abs() < 1e-12);
    assert!((ess(&[1.0; 4]) - 4.0).abs() < 1e-12);
    // Bounded by 1 and n on random weights.
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let w: Vec<f64> = (0..100).map(|_| rng.random::<f64>()).collect();
    let e = ess(&w);
    assert!(e > 1.0 && e <= 100.0);
    // The weights resample refuses are refused here too.
    for bad in [&[][..], &[0.5, f64::NAN], &[0.5, -0.1], &[0.0, 0.0]] {
        assert!(effective_sample_size(bad).is_err(), "{bad:?}");
    }
}

/// `substitute_lightest` against the weights written out: the lightest particle
/// becomes the new state with the heaviest one's likelihood times `exp(gain)`, the
/// others keep their ratios, the mean is the weighted mean of the new set.
#[test]
fn substitute_lightest_weighs_the_new_state_against_the_heaviest() {
    use nalgebra::Vector1;
    let mut pf = ParticleFilter::new(
        50,
        Vector1::new(0.0),
        SMatrix::identity() * 4.0,
        LinearGaussian::random_walk(Vector1::new(0.5)),
        FilterParams::default(),
        3,
    )
    .unwrap();
    pf.step(&|s: &SVector<f64, 1>| -0.5 * ((s[0] - 1.0) / 0.7).powi(2));
    let before: Vec<f64> = pf.log_weights().to_vec();
    let particles = pf.particles().to_vec();
    let light = (0..50)
        .min_by(|&a, &b| before[a].total_cmp(&before[b]))
        .unwrap();
    let heavy = (0..50)
        .max_by(|&a, &b| before[a].total_cmp(&before[b]))
        .unwrap();
    let gain = 0.8;
    pf.substitute_lightest(Vector1::new(1.05), gain);
    // Unnormalised weights: the old ones with the lightest replaced.
    let mut w: Vec<f64> = before.iter().map(|lw| lw.exp()).collect();
    w[light] = before[heavy].exp() * gain.exp();
    let total: f64 = w.iter().sum();
    for (i, (&got, want)) in pf.weights().iter().zip(&w).enumerate() {
        assert!((got - want / total).abs() < 1e-12, "particle {i}");
    }
    assert_eq!(pf.particles()[light][0], 1.05);
    let mean: f64 = (0..50)
        .map(|i| w[i] / total * if i == light { 1.05 } else { particles[i][0] })
        .sum();
    assert!((pf.mean()[0] - mean).abs() < 1e-12);
    // A non-finite gain or state changes nothing.
    let kept = pf.weights().to_vec();
    pf.substitute_lightest(Vector1::new(2.0), f64::NAN);
    pf.substitute_lightest(Vector1::new(f64::INFINITY), 1.0);
    assert_eq!(pf.weights(), &kept[..]);
}

/// Issue 38: weights near the largest float overflowed the plain sum to infinity, and
/// every particle went to the last index. Scaled by any positive factor, the weights
/// must resample exactly as the small ones do (same seed, same draws).
#[test]
fn resampling_is_invariant_to_the_weights_scale_up_to_the_largest_float() {
    let small = [1.0, 2.0, 3.0, 4.0];
    for r in [
        Resampler::Multinomial,
        Resampler::Systematic,
        Resampler::Stratified,
        Resampler::Residual,
    ] {
        let draw = |w: &[f64]| {
            let mut idx = Vec::new();
            r.resample(w, 400, &mut ChaCha8Rng::seed_from_u64(3), &mut idx)
                .unwrap();
            idx
        };
        let reference = draw(&small);
        // Particle k is expected 40 (k + 1) times of 400.
        for k in 0..4 {
            let copies = reference.iter().filter(|&&i| i == k).count();
            assert!(copies >= 40 * (k + 1) - 30, "{r:?}: {copies} copies of {k}");
        }
        // The largest weight is f64::MAX itself: the plain sum overflows.
        for scale in [1e300, f64::MAX / 4.0] {
            let big: Vec<f64> = small.iter().map(|w| w * scale).collect();
            assert_eq!(draw(&big), reference, "{r:?} at scale {scale:e}");
        }
    }
    let ess = effective_sample_size(&[f64::MAX; 10]).unwrap();
    assert!((ess - 10.0).abs() < 1e-9, "{ess}");
}
