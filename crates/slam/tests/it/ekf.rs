//! The EKF core against independent oracles: a textbook linear Kalman filter, the
//! dense O(n^3) Joseph form, and the augmented-covariance definition of landmark
//! initialisation; plus property tests of symmetry and definiteness.

use nalgebra::{DMatrix, DVector, Matrix2, Vector2};
use proptest::prelude::*;
use rand::{Rng, SeedableRng, rngs::StdRng};
use rperc_core::{CoreError, asymmetry, min_relative_eigenvalue};
use slam::{Ekf, SlamError, SparseJacobian};

fn random_spd(rng: &mut StdRng, d: usize) -> DMatrix<f64> {
    let a = DMatrix::from_fn(d, d, |_, _| rng.random_range(-1.0..1.0));
    &a * a.transpose() + DMatrix::identity(d, d) * 0.1
}

/// The dense Joseph form, eq. (9), written out with the full H: the O(n^3) oracle.
fn dense_joseph(
    x: &DVector<f64>,
    p: &DMatrix<f64>,
    nu: &DVector<f64>,
    h: &DMatrix<f64>,
    r: &DMatrix<f64>,
) -> (DVector<f64>, DMatrix<f64>) {
    let s = h * p * h.transpose() + r;
    let k = p * h.transpose() * s.try_inverse().unwrap();
    let ikh = DMatrix::identity(x.len(), x.len()) - &k * h;
    (
        x + &k * nu,
        &ikh * p * ikh.transpose() + &k * r * k.transpose(),
    )
}

fn rel_err(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
    (a - b).amax() / b.amax().max(1e-300)
}

/// A random sparse H: a robot block and one landmark block, sometimes two blocks
/// in different rows.
fn random_problem(
    seed: u64,
    landmarks: usize,
    obs: usize,
) -> (Ekf, DVector<f64>, SparseJacobian, DMatrix<f64>) {
    let mut rng = StdRng::seed_from_u64(seed);
    let (rd, md) = (3, 2);
    let d = rd + md * landmarks;
    let x = DVector::from_fn(d, |_, _| rng.random_range(-5.0..5.0));
    let p = random_spd(&mut rng, d);
    let j = rng.random_range(0..landmarks);
    let h = SparseJacobian::new(obs)
        .with_block(
            0,
            0,
            DMatrix::from_fn(obs, rd, |_, _| rng.random_range(-1.0..1.0)),
        )
        .with_block(
            0,
            rd + md * j,
            DMatrix::from_fn(obs, md, |_, _| rng.random_range(-1.0..1.0)),
        );
    let nu = DVector::from_fn(obs, |_, _| rng.random_range(-1.0..1.0));
    let r = random_spd(&mut rng, obs) * 0.1;
    (Ekf::new(x, p, rd, md).unwrap(), nu, h, r)
}

/// States large enough for the update's column blocks (several, the last one
/// partial) and for its parallel path: the blocked products equal the dense Joseph
/// form written out with the full H.
#[test]
fn blocked_joseph_equals_dense_joseph_on_large_states() {
    for (seed, landmarks, obs) in [(1, 30, 2), (2, 47, 4), (3, 230, 6)] {
        let (mut ekf, nu, h, r) = random_problem(seed, landmarks, obs);
        let (x0, p0) = (ekf.state().clone(), ekf.covariance().clone());
        let (x1, p1) = dense_joseph(&x0, &p0, &nu, &h.to_dense(x0.len()), &r);
        ekf.update(&nu, &h, &r).unwrap();
        assert!((ekf.state() - &x1).amax() < 1e-9 * (1.0 + x1.amax()));
        assert!(
            rel_err(&ekf.covariance(), &p1) < 1e-9,
            "{landmarks} landmarks"
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn sparse_joseph_equals_dense_joseph(seed in any::<u64>(), landmarks in 1usize..12, obs in 1usize..4) {
        let (mut ekf, nu, h, r) = random_problem(seed, landmarks, obs);
        let (x0, p0) = (ekf.state().clone(), ekf.covariance().clone());
        let hd = h.to_dense(x0.len());
        let (x1, p1) = dense_joseph(&x0, &p0, &nu, &hd, &r);
        ekf.update(&nu, &h, &r).unwrap();
        prop_assert!((ekf.state() - &x1).amax() < 1e-9 * (1.0 + x1.amax()));
        prop_assert!(rel_err(&ekf.covariance(), &p1) < 1e-9);
    }

    /// Issue 15: a covariance at any scale from 1e-250 to 1e250, a noise-free or
    /// relatively tiny R, any H: the update either succeeds with a finite covariance
    /// whose variances are >= 0 and that matches the dense Joseph form, or is refused
    /// (a numerical error) with the filter unchanged. Never a silent negative variance.
    #[test]
    fn updates_at_extreme_scales_stay_valid_or_are_refused(
        seed in any::<u64>(),
        exponent in -250i32..250,
        r_kind in 0usize..3,
        unit_h in any::<bool>(),
    ) {
        let mut rng = StdRng::seed_from_u64(seed);
        let scale = (0..exponent.unsigned_abs())
            .fold(1.0f64, |acc, _| if exponent < 0 { acc / 10.0 } else { acc * 10.0 });
        let p = random_spd(&mut rng, 3) * scale;
        let mut ekf = Ekf::new(DVector::zeros(3), p.clone(), 3, 2).unwrap();
        let before = ekf.clone();
        let row = if unit_h {
            let mut row = DMatrix::zeros(1, 3);
            row[(0, rng.random_range(0..3))] = 1.0;
            row
        } else {
            DMatrix::from_fn(1, 3, |_, _| rng.random_range(-1.0..1.0))
        };
        let r = DMatrix::from_element(1, 1, [0.0, scale * 1e-20, scale][r_kind]);
        let h = SparseJacobian::new(1).with_block(0, 0, row.clone());
        let nu = DVector::from_element(1, 1.0);
        match ekf.update(&nu, &h, &r) {
            Ok(_) => {
                let c = ekf.covariance();
                prop_assert!(c.iter().all(|v| v.is_finite()));
                prop_assert!((0..3).all(|i| c[(i, i)] >= 0.0), "negative variance: {c}");
                let (_, p1) = dense_joseph(&DVector::zeros(3), &p, &nu, &row, &r);
                // Entries that cancel to ~0 (a direction observed exactly) are compared
                // at the scale of the prior.
                prop_assert!((&c - &p1).amax() < 1e-8 * p.amax(), "{c} vs {p1}");
            }
            Err(_) => prop_assert_eq!(&ekf, &before),
        }
    }

    /// 100 cases x 1000 steps = 10^5 updates of a planar SLAM filter, each between
    /// random predictions: P stays symmetric and positive semi-definite.
    #[test]
    fn covariance_stays_symmetric_psd(seed in any::<u64>()) {
        let mut rng = StdRng::seed_from_u64(seed);
        let mut ekf = Ekf::new(DVector::zeros(3), DMatrix::identity(3, 3) * 0.01, 3, 2).unwrap();
        let r = Matrix2::new(0.05, 0.0, 0.0, 0.002);
        for _ in 0..4 {
            let z = Vector2::new(rng.random_range(1.0..10.0), rng.random_range(-3.0..3.0));
            ekf.add_landmark_range_bearing(&z, &r).unwrap();
        }
        for step in 0..1000 {
            let th = ekf.state()[2];
            let (v, w) = (rng.random_range(0.0..0.5), rng.random_range(-0.3..0.3));
            let mut mean = ekf.state().rows(0, 3).clone_owned();
            mean[0] += v * th.cos();
            mean[1] += v * th.sin();
            mean[2] += w;
            let fx = DMatrix::from_row_slice(3, 3, &[1.0, 0.0, -v * th.sin(), 0.0, 1.0, v * th.cos(), 0.0, 0.0, 1.0]);
            let fv = DMatrix::from_row_slice(3, 2, &[th.cos(), 0.0, th.sin(), 0.0, 0.0, 1.0]);
            let q = DMatrix::from_diagonal(&DVector::from_vec(vec![0.01, 0.001]));
            ekf.predict(&mean, &fx, &fv, &q).unwrap();
            let j = rng.random_range(0..ekf.num_landmarks());
            let z = Vector2::new(rng.random_range(1.0..10.0), rng.random_range(-3.0..3.0));
            match ekf.update_range_bearing(j, &z, &r) {
                Ok(_) | Err(SlamError::SingularInnovation(_)) => {}
                Err(e) => return Err(TestCaseError::fail(e.to_string())),
            }
            if step % 50 == 49 {
                let p = &ekf.covariance();
                prop_assert!(asymmetry(p) < 1e-9, "asymmetry {}", asymmetry(p));
                prop_assert!(min_relative_eigenvalue(p) > -1e-9, "eigenvalue {}", min_relative_eigenvalue(p));
            }
        }
    }
}

/// A 1-D robot among three landmarks with linear relative observations: the EKF
/// must equal the textbook Kalman filter, written here with the standard
/// `P = (I - K H) P` update and plain dense algebra.
#[test]
fn equals_textbook_kalman_filter_on_a_linear_model() {
    let mut rng = StdRng::seed_from_u64(11);
    let n = 3;
    let d = n + 1;
    let mut x = DVector::from_vec(vec![0.0, 1.0, 2.5, 4.0]);
    let mut p = DMatrix::from_diagonal(&DVector::from_vec(vec![0.5, 2.0, 2.0, 2.0]));
    p[(0, 1)] = 0.3;
    p[(1, 0)] = 0.3;
    let mut ekf = Ekf::new(x.clone(), p.clone(), 1, 1).unwrap();
    let mut h = DMatrix::zeros(n, d);
    for i in 0..n {
        h[(i, 0)] = -1.0;
        h[(i, i + 1)] = 1.0;
    }
    let sparse = SparseJacobian::new(n)
        .with_block(0, 0, DMatrix::from_element(n, 1, -1.0))
        .with_block(0, 1, DMatrix::identity(n, n));
    let r = DMatrix::from_diagonal(&DVector::from_vec(vec![0.1, 0.2, 0.3]));
    let a = DMatrix::<f64>::identity(d, d);
    let mut b = DMatrix::zeros(d, 1);
    b[(0, 0)] = 1.0;
    let q = 0.05;
    for _ in 0..60 {
        let u = rng.random_range(-0.5..0.5);
        // Textbook predict: x = A x + B u, P = A P A^T + B Q B^T.
        x = &a * &x + &b * u;
        p = &a * &p * a.transpose() + &b * q * b.transpose();
        let mut mean = ekf.state().rows(0, 1).clone_owned();
        mean[0] += u;
        ekf.predict(
            &mean,
            &DMatrix::identity(1, 1),
            &DMatrix::identity(1, 1),
            &DMatrix::from_element(1, 1, q),
        )
        .unwrap();
        let z = DVector::from_fn(n, |_, _| rng.random_range(-1.0..5.0));
        // Textbook update: K = P H^T (H P H^T + R)^-1, x += K (z - H x), P = (I - K H) P.
        let s = &h * &p * h.transpose() + &r;
        let k = &p * h.transpose() * s.try_inverse().unwrap();
        let nu = &z - &h * &x;
        x += &k * &nu;
        p = (DMatrix::identity(d, d) - &k * &h) * &p;
        ekf.update(&nu, &sparse, &r).unwrap();
        assert!((ekf.state() - &x).amax() < 1e-9);
        assert!(rel_err(&ekf.covariance(), &p) < 1e-9);
    }
}

/// Landmark initialisation: the augmented covariance is `G blockdiag(P, R) G^T` with
/// `G = [[I, 0], [G_robot 0, G_z]]` (the definition, built densely here).
#[test]
fn landmark_initialisation_has_the_full_cross_covariance() {
    let mut rng = StdRng::seed_from_u64(5);
    let (mut ekf, _, _, _) = random_problem(3, 2, 2);
    let (x0, p0) = (ekf.state().clone(), ekf.covariance().clone());
    let d = x0.len();
    let z = Vector2::new(4.0, 0.4);
    let r = random_spd(&mut rng, 2) * 0.01;
    let r2 = Matrix2::from_iterator(r.iter().copied());
    ekf.add_landmark_range_bearing(&z, &r2).unwrap();
    let robot = rperc_core::Pose2 {
        x: x0[0],
        y: x0[1],
        theta: x0[2],
    };
    let (l, gr, gz) = slam::landmark_from_range_bearing(&robot, &z);
    let mut g = DMatrix::zeros(d + 2, d + 2);
    g.view_mut((0, 0), (d, d))
        .copy_from(&DMatrix::identity(d, d));
    g.view_mut((d, 0), (2, 3)).copy_from(&gr);
    g.view_mut((d, d), (2, 2)).copy_from(&gz);
    let mut ext = DMatrix::zeros(d + 2, d + 2);
    ext.view_mut((0, 0), (d, d)).copy_from(&p0);
    ext.view_mut((d, d), (2, 2)).copy_from(&r);
    let expected = &g * ext * g.transpose();
    assert!(rel_err(&ekf.covariance(), &expected) < 1e-12);
    assert!((ekf.state()[d] - l.x).abs() < 1e-12 && (ekf.state()[d + 1] - l.y).abs() < 1e-12);
}

/// For a linear model, independent observations give the same posterior applied
/// together (batch) or one after another (sequential).
#[test]
fn batch_equals_sequential_on_independent_observations() {
    let (ekf, _, _, _) = random_problem(9, 3, 2);
    let obs: Vec<_> = (0..3)
        .map(|j| {
            let (_, nu, h, r) = random_problem(100 + j, 3, 2);
            (nu, h, r)
        })
        .collect();
    let mut batch = ekf.clone();
    batch.update_batch(&obs).unwrap();
    let mut seq = ekf.clone();
    let x0 = ekf.state().clone();
    // Linear: innovations are fixed relative to the starting state.
    seq.update_sequential(3, |x, i| {
        let (nu, h, r) = &obs[i];
        let shift = h.to_dense(x.len()) * (x - &x0);
        Ok((nu - shift, h.clone(), r.clone()))
    })
    .unwrap();
    assert!((batch.state() - seq.state()).amax() < 1e-9);
    assert!(rel_err(&batch.covariance(), &seq.covariance()) < 1e-9);
}

#[test]
fn singular_or_non_finite_input_leaves_the_state_unchanged() {
    // A landmark with zero variance observed with zero noise: S = 0.
    let x = DVector::from_vec(vec![0.0, 1.0]);
    let p = DMatrix::from_row_slice(2, 2, &[0.0, 0.0, 0.0, 0.0]);
    let mut ekf = Ekf::new(x, p, 1, 1).unwrap();
    let before = ekf.clone();
    let h = SparseJacobian::new(1).with_block(0, 1, DMatrix::from_element(1, 1, 1.0));
    let err = ekf
        .update(&DVector::from_element(1, 0.5), &h, &DMatrix::zeros(1, 1))
        .unwrap_err();
    assert!(matches!(err, SlamError::SingularInnovation(_)), "{err}");
    assert_eq!(ekf, before);
    let err = ekf
        .update(
            &DVector::from_element(1, f64::NAN),
            &h,
            &DMatrix::identity(1, 1),
        )
        .unwrap_err();
    assert!(matches!(err, SlamError::Core(CoreError::NonFinite(_))));
    assert_eq!(ekf, before);
    let err = ekf
        .update(&DVector::from_element(2, 0.0), &h, &DMatrix::identity(1, 1))
        .unwrap_err();
    assert!(matches!(err, SlamError::Core(CoreError::Dimension(_))));
    let err = ekf
        .update(
            &DVector::from_element(1, 0.0),
            &SparseJacobian::new(1).with_block(0, 5, DMatrix::identity(1, 1)),
            &DMatrix::identity(1, 1),
        )
        .unwrap_err();
    assert!(matches!(err, SlamError::Core(CoreError::Dimension(_))));
    assert_eq!(ekf, before);
    assert!(Ekf::new(DVector::zeros(4), DMatrix::zeros(4, 4), 3, 2).is_err());
}

/// Negative or asymmetric noise covariances would make `P` indefinite silently; each
/// entry point refuses them by name and leaves the filter as it was.
#[test]
fn negative_noise_is_refused_and_leaves_the_state_unchanged() {
    let x = DVector::from_vec(vec![0.0, 2.0]);
    let p = DMatrix::from_diagonal(&DVector::from_vec(vec![1.0, 4.0]));
    let mut ekf = Ekf::new(x, p, 1, 1).unwrap();
    let before = ekf.clone();
    let one = DMatrix::from_element(1, 1, 1.0);
    let negative = DMatrix::from_element(1, 1, -0.5);
    let h = SparseJacobian::new(1)
        .with_block(0, 0, -&one)
        .with_block(0, 1, one.clone());
    let refused = |e: SlamError, what: &str| matches!(e, SlamError::Core(CoreError::NotPositiveDefinite { name, .. }) if name == what);
    // S = 1 + 4 - 0.5 would still be positive: only the noise check catches this.
    let e = ekf
        .update(&DVector::from_element(1, 0.5), &h, &negative)
        .unwrap_err();
    assert!(refused(e, "R"));
    let e = ekf
        .predict(&DVector::from_element(1, 0.0), &one, &one, &negative)
        .unwrap_err();
    assert!(refused(e, "V"));
    let e = ekf
        .add_landmark(&DVector::from_element(1, 1.0), &one, &one, &negative)
        .unwrap_err();
    assert!(refused(e, "R"));
    // Indefinite though every diagonal entry is positive; and asymmetric.
    let indefinite = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 1.0]);
    let asymmetric = DMatrix::from_row_slice(2, 2, &[1.0, 0.5, 0.0, 1.0]);
    let h2 = SparseJacobian::new(2).with_block(0, 0, DMatrix::from_element(2, 1, 1.0));
    for r in [indefinite, asymmetric] {
        let e = ekf.update(&DVector::zeros(2), &h2, &r).unwrap_err();
        assert!(refused(e, "R"));
    }
    assert_eq!(ekf, before);
    // Zero noise is legitimate.
    ekf.predict(
        &DVector::from_element(1, 0.0),
        &one,
        &one,
        &DMatrix::zeros(1, 1),
    )
    .unwrap();
}

/// Large states update on all cores; the result must not depend on the pool size.
#[test]
fn parallel_update_is_bit_identical_across_thread_counts() {
    let (ekf, nu, h, r) = random_problem(21, 300, 2);
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let mut e = ekf.clone();
        pool.install(|| e.update(&nu, &h, &r).unwrap());
        e
    };
    assert_eq!(run(1), run(2));
}

/// An outlier behind the gate changes nothing and is reported with its NIS, which
/// equals `nu^T S^-1 nu` computed densely here; an inlier is applied.
#[test]
fn gated_update_rejects_an_outlier_without_touching_the_state() {
    let (ekf, _, _, _) = random_problem(4, 3, 2);
    let mut ekf = ekf.with_wrapped_angle(2).unwrap();
    let before = ekf.clone();
    let r = Matrix2::new(0.01, 0.0, 0.0, 0.001);
    let off = ekf.landmark_offset(1).unwrap();
    let robot = rperc_core::Pose2::new(ekf.state()[0], ekf.state()[1], ekf.state()[2]);
    let lm = nalgebra::Point2::new(ekf.state()[off], ekf.state()[off + 1]);
    let (z_true, hr, hl) = slam::range_bearing(&robot, &lm).unwrap();
    let z_far = z_true + Vector2::new(100.0, 0.0);
    let gate = rperc_core::chi2_gate(2, 0.99).unwrap();
    let out = ekf.update_range_bearing_gated(1, &z_far, &r, gate).unwrap();
    let mut h = DMatrix::zeros(2, ekf.state().len());
    h.view_mut((0, 0), (2, 3)).copy_from(&hr);
    h.view_mut((0, off), (2, 2)).copy_from(&hl);
    let s =
        &h * before.covariance() * h.transpose() + DMatrix::from_column_slice(2, 2, r.as_slice());
    let nu = DVector::from_vec(vec![100.0, 0.0]);
    let nis = nu.dot(&(s.try_inverse().unwrap() * &nu));
    match out {
        slam::Gated::Rejected { nis: got, gate: g } => {
            assert!((got - nis).abs() < 1e-9 * nis && g == gate);
        }
        other => panic!("expected a rejection, got {other:?}"),
    }
    assert_eq!(ekf, before);
    let ok = ekf
        .update_range_bearing_gated(1, &z_true, &r, gate)
        .unwrap();
    assert!(matches!(ok, slam::Gated::Applied(_)));
    assert!(
        ekf.update_range_bearing_gated(1, &z_true, &r, f64::NAN)
            .is_err()
    );
}

/// After an update that turns the heading past pi, it is back in (-pi, pi].
#[test]
fn heading_is_wrapped_after_every_update() {
    let x = DVector::from_vec(vec![0.0, 0.0, 3.1, 5.0, 0.0]);
    let p = DMatrix::from_diagonal(&DVector::from_vec(vec![0.01, 0.01, 1.0, 0.01, 0.01]));
    let mut ekf = Ekf::new(x, p, 3, 2).unwrap();
    // The landmark due east is predicted at bearing -3.1; seen at -3.2 (wrapped to
    // +3.083), the heading must grow from 3.1 to about 3.2, past pi.
    let z = Vector2::new(5.0, rperc_core::wrap_angle(-3.2));
    let r = Matrix2::new(0.01, 0.0, 0.0, 1e-4);
    ekf.update_range_bearing(0, &z, &r).unwrap();
    let th = ekf.state()[2];
    assert!(
        th > -std::f64::consts::PI && th <= std::f64::consts::PI,
        "{th}"
    );
    assert!(
        (th - rperc_core::wrap_angle(3.2)).abs() < 1e-3,
        "crossed pi and wrapped: {th}"
    );
}

/// The block readers return exactly the blocks of the full covariance.
#[test]
fn block_readers_equal_the_blocks_of_the_full_covariance() {
    let (ekf, _, _, _) = random_problem(8, 5, 2);
    let p = ekf.covariance();
    assert_eq!(ekf.robot_covariance(), p.view((0, 0), (3, 3)).into_owned());
    for j in 0..5 {
        let off = 3 + 2 * j;
        assert_eq!(
            ekf.landmark_covariance(j).unwrap(),
            p.view((off, off), (2, 2)).into_owned()
        );
        assert_eq!(
            ekf.robot_landmark_covariance(j).unwrap(),
            p.view((0, off), (3, 2)).into_owned()
        );
    }
    assert!(ekf.landmark_covariance(5).is_err());
    assert!(ekf.covariance_block(10, 0, 5, 1).is_err());
}

/// Many landmarks added one by one (the buffer grows several times) give the same
/// filter as the dense augmentation `G blockdiag(P, R) G^T` applied each time; then
/// removing a landmark equals deleting its rows and columns (marginalisation), and
/// the id map follows.
#[test]
fn growing_and_removing_landmarks_matches_dense_algebra() {
    let mut ekf = Ekf::new(
        DVector::from_vec(vec![0.5, -0.2, 0.3]),
        DMatrix::identity(3, 3) * 0.01,
        3,
        2,
    )
    .unwrap();
    let mut p = ekf.covariance();
    let r = Matrix2::new(0.02, 0.001, 0.001, 0.003);
    for k in 0..40 {
        let z = Vector2::new(2.0 + 0.1 * k as f64, -1.5 + 0.07 * k as f64);
        let robot = rperc_core::Pose2::new(ekf.state()[0], ekf.state()[1], ekf.state()[2]);
        let (_, gr, gz) = slam::landmark_from_range_bearing(&robot, &z);
        let d = p.nrows();
        let mut g = DMatrix::zeros(d + 2, d + 2);
        g.view_mut((0, 0), (d, d))
            .copy_from(&DMatrix::identity(d, d));
        g.view_mut((d, 0), (2, 3)).copy_from(&gr);
        g.view_mut((d, d), (2, 2)).copy_from(&gz);
        let mut ext = DMatrix::zeros(d + 2, d + 2);
        ext.view_mut((0, 0), (d, d)).copy_from(&p);
        ext.view_mut((d, d), (2, 2))
            .copy_from(&DMatrix::from_column_slice(2, 2, r.as_slice()));
        p = &g * ext * g.transpose();
        assert_eq!(ekf.add_landmark_range_bearing(&z, &r).unwrap(), k);
    }
    assert!(rel_err(&ekf.covariance(), &p) < 1e-12);
    let (x, full) = (ekf.state().clone(), ekf.covariance());
    let id = ekf.remove_landmark(7).unwrap();
    assert_eq!(id, 7);
    let keep: Vec<usize> = (0..p.nrows()).filter(|&i| i != 17 && i != 18).collect();
    let expected = full.select_rows(&keep).select_columns(&keep);
    assert_eq!(ekf.covariance(), expected);
    assert_eq!(*ekf.state(), x.select_rows(&keep));
    assert_eq!(ekf.landmark_index(7), None);
    assert_eq!(ekf.landmark_index(8), Some(7));
    assert_eq!(ekf.landmark_id(7).unwrap(), 8);
    // A new landmark takes a fresh id; a taken id is refused.
    let z = Vector2::new(3.0, 0.1);
    let j = ekf.add_landmark_range_bearing(&z, &r).unwrap();
    assert_eq!(ekf.landmark_id(j).unwrap(), 40);
    let zero = DMatrix::zeros(2, 3);
    let e = ekf.add_landmark_with_id(
        3,
        &DVector::zeros(2),
        &zero,
        &DMatrix::identity(2, 2),
        &DMatrix::identity(2, 2),
    );
    assert!(e.is_err());
}

/// A range-bearing batch of independent landmarks equals sequential updates when
/// the robot is known exactly (then the observations are independent given the
/// state and the model is linear in each landmark at a fixed robot... up to the
/// relinearisation, which a zero robot variance removes).
#[test]
fn range_bearing_batch_equals_sequential_for_a_known_robot() {
    let mut p = DMatrix::zeros(7, 7);
    p.view_mut((3, 3), (4, 4))
        .copy_from(&(DMatrix::identity(4, 4) * 0.04));
    let x = DVector::from_vec(vec![0.0, 0.0, 0.2, 4.0, 1.0, -2.0, 3.0]);
    let ekf = Ekf::new(x, p, 3, 2).unwrap();
    let r = Matrix2::new(0.01, 0.0, 0.0, 1e-3);
    let obs = [
        (0usize, Vector2::new(4.2, 0.05)),
        (1, Vector2::new(3.5, 1.9)),
    ];
    let mut batch = ekf.clone();
    batch.update_range_bearing_batch(&obs, &r).unwrap();
    let mut seq = ekf.clone();
    for (j, z) in obs {
        seq.update_range_bearing(j, &z, &r).unwrap();
    }
    assert!((batch.state() - seq.state()).amax() < 1e-9);
    assert!(rel_err(&batch.covariance(), &seq.covariance()) < 1e-9);
}

/// The allocation-free planar prediction equals the generic one (same algebra,
/// fixed-size matrices), and both equal `F P F^T + G V G^T` written densely.
#[test]
fn planar_prediction_equals_the_generic_and_dense_predictions() {
    let (ekf, _, _, _) = random_problem(17, 6, 2);
    let x = ekf.state().clone();
    let pose = rperc_core::Pose2::new(x[0], x[1], x[2]);
    let pred = slam::unicycle(&pose, 0.7, -0.3, 0.2);
    let v = Matrix2::new(0.02, 0.001, 0.001, 0.005);
    let mut generic = ekf.clone();
    let (mean, fx, fv) = pred.to_dynamic();
    let vd = DMatrix::from_column_slice(2, 2, v.as_slice());
    generic.predict(&mean, &fx, &fv, &vd).unwrap();
    let mut planar = ekf.clone();
    planar
        .predict_planar(&pred.mean, &pred.fx, &pred.fv, &v)
        .unwrap();
    assert!((planar.state() - generic.state()).amax() < 1e-15);
    assert!(rel_err(&planar.covariance(), &generic.covariance()) < 1e-14);
    let d = x.len();
    let mut f = DMatrix::identity(d, d);
    f.view_mut((0, 0), (3, 3)).copy_from(&fx);
    let mut g = DMatrix::zeros(d, 2);
    g.view_mut((0, 0), (3, 2)).copy_from(&fv);
    let dense = &f * ekf.covariance() * f.transpose() + &g * vd * g.transpose();
    assert!(rel_err(&planar.covariance(), &dense) < 1e-12);
    let m3 = nalgebra::Matrix3::from_column_slice(planar.robot_covariance().as_slice());
    assert_eq!(planar.robot_covariance_planar(), m3);
}

/// Fuzz reproducer (issue 15): a landmark seen at range 1e20 with R = diag(0, 1e300)
/// has a covariance G_z R G_z^T that overflows to inf; it used to enter P silently.
#[test]
fn an_overflowing_new_landmark_is_refused_and_changes_nothing() {
    let mut ekf = Ekf::new(
        DVector::from_element(3, 1.0),
        DMatrix::identity(3, 3) * 0.01,
        3,
        2,
    )
    .unwrap();
    let before = ekf.clone();
    let e = ekf
        .add_landmark_range_bearing(
            &Vector2::new(1e20, 0.3),
            &Matrix2::new(0.0, 0.0, 0.0, 1e300),
        )
        .unwrap_err();
    assert!(
        matches!(e, SlamError::Diverged(ref m) if m.starts_with("add_landmark")),
        "{e}"
    );
    assert_eq!(ekf, before);
}

/// Issue 15: with every landmark observed at once an update is O(n^3), seconds at a
/// few thousand; Ctrl-C must stop it, and an interrupted update must leave the
/// filter exactly as it was (the covariance is written through a copy). The signal
/// arrives at the 1st, 2nd, 4th, ... poll until the update completes, so every stage
/// (factorisation, gain, covariance write) is hit.
#[test]
fn an_interrupted_large_update_leaves_the_filter_unchanged() {
    let mut rng = StdRng::seed_from_u64(15);
    let n = 600; // 1-D landmarks, all observed relative to a 1-D robot
    let p = random_spd(&mut rng, n + 1);
    let x = DVector::from_fn(n + 1, |_, _| rng.random_range(-1.0..1.0));
    let before = Ekf::new(x.clone(), p.clone(), 1, 1).unwrap();
    let h = SparseJacobian::new(n)
        .with_block(0, 0, DMatrix::from_element(n, 1, -1.0))
        .with_block(0, 1, DMatrix::identity(n, n));
    let nu = DVector::from_fn(n, |_, _| rng.random_range(-0.1..0.1));
    let r = DMatrix::identity(n, n) * 0.01;
    let mut fire_at = 1;
    let ekf = loop {
        let mut ekf = before.clone();
        let mut polls = 0;
        let poll = move || {
            polls += 1;
            polls >= fire_at
        };
        match rperc_core::interrupt::run_polled(poll, || ekf.update(&nu, &h, &r)) {
            Err(SlamError::Core(CoreError::Interrupted)) => {
                assert_eq!(
                    ekf, before,
                    "interrupted at poll {fire_at}: the filter changed"
                );
                fire_at *= 4;
            }
            out => {
                out.unwrap();
                break ekf;
            }
        }
    };
    assert!(fire_at > 1, "the update was never interrupted");
    // The oracle: the same observations one by one (R is diagonal, so sequential
    // equals batch), each a small in-place update; the dense O(n^3) oracle takes
    // tens of seconds in a debug build.
    let mut sequential = before.clone();
    let x0 = before.state().clone();
    sequential
        .update_sequential(n, |x, i| {
            // Linear: z_i = l_i - x_r, so the innovation shifts with the state.
            let shift = (x[i + 1] - x0[i + 1]) - (x[0] - x0[0]);
            let hi = SparseJacobian::new(1)
                .with_block(0, 0, DMatrix::from_element(1, 1, -1.0))
                .with_block(0, i + 1, DMatrix::from_element(1, 1, 1.0));
            Ok((
                DVector::from_element(1, nu[i] - shift),
                hi,
                DMatrix::identity(1, 1) * 0.01,
            ))
        })
        .unwrap();
    assert!(rel_err(&ekf.covariance(), &sequential.covariance()) < 1e-9);
    assert!((ekf.state() - sequential.state()).amax() < 1e-9);
}

/// The Schmidt-Kalman consider state against the dense definition: the optimal gain
/// with the consider rows set to zero, and the Joseph form (valid for any gain) for
/// `P`. The consider landmark's mean and block stay exactly as they were.
#[test]
fn consider_state_is_the_dense_schmidt_update() {
    let mut rng = StdRng::seed_from_u64(42);
    let d = 3 + 2 * 3;
    let x = DVector::from_fn(d, |_, _| rng.random_range(-2.0..2.0));
    let p = random_spd(&mut rng, d);
    let mut ekf = Ekf::new(x.clone(), p.clone(), 3, 2).unwrap();
    ekf.set_consider(1).unwrap();
    assert!(ekf.is_consider(1) && !ekf.is_consider(0));
    // An observation of landmarks 0 and 1 relative to the robot.
    let hr = DMatrix::from_fn(4, 3, |_, _| rng.random_range(-1.0..1.0));
    let mut h = SparseJacobian::new(4)
        .with_block(0, 0, hr.clone())
        .with_block(0, 3, DMatrix::identity(2, 2));
    h = h.with_block(2, 5, DMatrix::identity(2, 2));
    let r = DMatrix::from_diagonal(&DVector::from_element(4, 0.05));
    let nu = DVector::from_fn(4, |_, _| rng.random_range(-0.3..0.3));
    ekf.update(&nu, &h, &r).unwrap();

    let hd = h.to_dense(d);
    let s = &hd * &p * hd.transpose() + &r;
    let mut k = &p * hd.transpose() * s.try_inverse().unwrap();
    k.rows_mut(5, 2).fill(0.0);
    let ikh = DMatrix::identity(d, d) - &k * &hd;
    let p_new = &ikh * &p * ikh.transpose() + &k * &r * k.transpose();
    let x_new = &x + &k * &nu;
    assert!((ekf.state() - &x_new).amax() < 1e-12);
    assert!((ekf.covariance() - &p_new).amax() < 1e-12);
    assert_eq!(ekf.state().rows(5, 2), x.rows(5, 2));
    assert!((ekf.covariance().view((5, 5), (2, 2)) - p.view((5, 5), (2, 2))).amax() < 1e-15);
    // Removing a consider landmark forgets it; the next one is not a consider state.
    ekf.remove_landmark(1).unwrap();
    assert!(!ekf.is_consider(1));
}
