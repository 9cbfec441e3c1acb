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
