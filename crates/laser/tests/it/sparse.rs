//! The block LDL^T factorisation against dense nalgebra (the oracle): solutions and
//! marginal covariances of random SPD systems on random graphs.

use std::collections::HashMap;

use laser::sparse::{Factor, Pattern};
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use proptest::prelude::*;

/// A random SPD block system on a chain with `loops` extra edges, dense and sparse.
type System = (
    Pattern,
    Vec<Matrix3<f64>>,
    HashMap<(usize, usize), Matrix3<f64>>,
    DMatrix<f64>,
);

fn system(n: usize, loops: &[(usize, usize)], seed: u64) -> System {
    let mut state = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    let mut next = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5
    };
    let mut edges: Vec<(usize, usize)> = (1..n).map(|i| (i - 1, i)).collect();
    edges.extend(
        loops
            .iter()
            .copied()
            .filter(|(a, b)| a != b && *a < n && *b < n),
    );
    // H = sum over edges of J^T J with random 3x6 J: SPD with the graph's pattern.
    let mut dense = DMatrix::<f64>::identity(3 * n, 3 * n) * 0.1;
    let mut diag = vec![Matrix3::identity() * 0.1; n];
    let mut off = HashMap::new();
    for &(a, b) in &edges {
        let ja = Matrix3::from_fn(|_, _| next());
        let jb = Matrix3::from_fn(|_, _| next()) + Matrix3::identity();
        diag[a] += ja.transpose() * ja;
        diag[b] += jb.transpose() * jb;
        let ab = ja.transpose() * jb;
        *off.entry((a, b)).or_insert_with(Matrix3::zeros) += ab;
        for (r, c, m) in [
            (a, a, ja.transpose() * ja),
            (b, b, jb.transpose() * jb),
            (a, b, ab),
            (b, a, ab.transpose()),
        ] {
            let mut v = dense.view_mut((3 * r, 3 * c), (3, 3));
            v += m;
        }
    }
    (Pattern::new(n, &edges).unwrap(), diag, off, dense)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    #[test]
    fn solve_and_marginals_equal_dense(n in 2usize..40, loops in prop::collection::vec((0usize..40, 0usize..40), 0..12), seed in 0u64..1000) {
        let (pattern, diag, off, dense) = system(n, &loops, seed);
        let factor = Factor::new(&pattern, &diag, &off).unwrap();
        let rhs: Vec<Vector3<f64>> = (0..n).map(|i| Vector3::new(i as f64, 1.0 - i as f64, 0.5)).collect();
        let x = factor.solve(&rhs);
        let b = DVector::from_iterator(3 * n, rhs.iter().flat_map(|v| v.iter().copied()));
        let inv = dense.clone().cholesky().unwrap().inverse();
        let expect = &inv * b;
        for i in 0..n {
            for r in 0..3 {
                prop_assert!((x[i][r] - expect[3 * i + r]).abs() <= 1e-8 * (1.0 + expect[3 * i + r].abs()));
            }
        }
        let marg = factor.marginals();
        for (i, m) in marg.iter().enumerate() {
            let block = inv.view((3 * i, 3 * i), (3, 3));
            prop_assert!((m - block).norm() <= 1e-8 * (1.0 + block.norm()));
        }
    }
}

#[test]
fn a_chain_has_no_fill() {
    let edges: Vec<(usize, usize)> = (1..100).map(|i| (i - 1, i)).collect();
    let p = Pattern::new(100, &edges).unwrap();
    assert!(p.columns.iter().all(|c| c.len() <= 1));
}

#[test]
fn an_indefinite_system_is_an_error() {
    let (pattern, mut diag, off, _) = system(5, &[], 1);
    diag[2] = -Matrix3::identity();
    assert!(Factor::new(&pattern, &diag, &off).is_err());
}
