//! The pose graph: analytic Jacobians against finite differences, a loop closure
//! that removes the drift of a square loop, and one wrong closure that the robust
//! kernel keeps from bending the map.

use laser::graph::{Edge, PoseGraph, linearise};
use nalgebra::{Matrix3, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use rperc_core::{Pose2, wrap_angle};

fn perturb(p: &Pose2, k: usize, h: f64) -> Pose2 {
    let mut v = p.to_vector();
    v[k] += h;
    Pose2::from_vector(&v)
}

#[test]
fn jacobians_match_finite_differences() {
    let a = Pose2::new(1.0, -2.0, 0.7);
    let b = Pose2::new(2.5, -1.0, 1.9);
    let z = Pose2::new(1.6, 0.4, 1.1);
    let (_, ja, jb) = linearise(&a, &b, &z);
    let h = 1e-6;
    for k in 0..3 {
        let (ep, _, _) = linearise(&perturb(&a, k, h), &b, &z);
        let (em, _, _) = linearise(&perturb(&a, k, -h), &b, &z);
        let mut d = (ep - em) / (2.0 * h);
        d.z = wrap_angle(d.z * 2.0 * h) / (2.0 * h);
        assert!(
            (d - ja.column(k)).norm() < 1e-7,
            "d/da[{k}]: {d:?} vs {:?}",
            ja.column(k)
        );
        let (ep, _, _) = linearise(&a, &perturb(&b, k, h), &z);
        let (em, _, _) = linearise(&a, &perturb(&b, k, -h), &z);
        let d = (ep - em) / (2.0 * h);
        assert!((d - jb.column(k)).norm() < 1e-7, "d/db[{k}]");
    }
}

/// A square loop of 40 poses, odometry with noise and a heading bias, and the true
/// closure from the last pose back to the first: the optimum's error is a fraction
/// of the dead reckoning's.
fn square(seed: u64) -> (Vec<Pose2>, Vec<Pose2>, Vec<Edge>) {
    let mut truth = vec![Pose2::identity()];
    for k in 1..40 {
        let turn = if k % 10 == 0 {
            std::f64::consts::FRAC_PI_2
        } else {
            0.0
        };
        truth.push(truth[k - 1].compose(&Pose2::new(1.0, 0.0, turn)));
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (sxy, sth) = (0.02, 0.01);
    let info = Matrix3::from_diagonal(&Vector3::new(
        1.0 / (sxy * sxy),
        1.0 / (sxy * sxy),
        1.0 / (sth * sth),
    ));
    let n = |s: f64, rng: &mut ChaCha8Rng| Normal::new(0.0, s).unwrap().sample(rng);
    let mut edges = Vec::new();
    let mut dead = vec![truth[0]];
    for k in 1..truth.len() {
        let z = truth[k - 1].between(&truth[k]);
        let z = Pose2::new(
            z.x + n(sxy, &mut rng),
            z.y + n(sxy, &mut rng),
            z.theta + n(sth, &mut rng) + 0.01,
        );
        dead.push(dead[k - 1].compose(&z));
        edges.push(Edge {
            from: k - 1,
            to: k,
            measurement: z,
            information: info,
            robust: None,
        });
    }
    (truth, dead, edges)
}

fn ate(a: &[Pose2], b: &[Pose2]) -> f64 {
    (a.iter()
        .zip(b)
        .map(|(p, q)| (p.translation() - q.translation()).norm_squared())
        .sum::<f64>()
        / a.len() as f64)
        .sqrt()
}

fn graph(dead: &[Pose2], edges: &[Edge]) -> PoseGraph {
    let mut g = PoseGraph::new(dead[0], Matrix3::identity() * 1e10);
    for p in &dead[1..] {
        g.add_pose(*p);
    }
    for e in edges {
        g.add_edge(*e).unwrap();
    }
    g
}

#[test]
fn a_closure_removes_the_drift() {
    let (truth, dead, edges) = square(3);
    let mut g = graph(&dead, &edges);
    let last = truth.len() - 1;
    let closure = Edge {
        from: 0,
        to: last,
        measurement: truth[0].between(&truth[last]),
        information: Matrix3::from_diagonal(&Vector3::new(1e4, 1e4, 1e4)),
        robust: None,
    };
    g.add_edge(closure).unwrap();
    let before = ate(&dead, &truth);
    g.optimize(20, 1e-9).unwrap();
    let after = ate(&g.poses, &truth);
    assert!(after < 0.25 * before, "ATE {before} -> {after}");
    // The marginals grow away from the anchored start and shrink again near the
    // closure: the middle of the loop is the least certain.
    let m = g.marginals().unwrap();
    assert!(m[20][(0, 0)] + m[20][(1, 1)] > m[38][(0, 0)] + m[38][(1, 1)]);
}

/// Dynamic covariance scaling fades out a closure that disagrees with the graph,
/// and the consistency pruning removes it: either way the map is the clean one.
#[test]
fn one_wrong_closure_does_not_wreck_the_map() {
    let (truth, dead, edges) = square(5);
    let last = truth.len() - 1;
    let right = Edge {
        from: 0,
        to: last,
        measurement: truth[0].between(&truth[last]),
        information: Matrix3::from_diagonal(&Vector3::new(1e4, 1e4, 1e4)),
        robust: None,
    };
    let mut clean = graph(&dead, &edges);
    clean.add_edge(right).unwrap();
    clean.optimize(30, 1e-9).unwrap();
    let clean_ate = ate(&clean.poses, &truth);
    // A closure claiming pose 25 sits on pose 5: 20 m of loop folded onto itself.
    let wrong = Edge {
        from: 5,
        to: 25,
        measurement: Pose2::new(0.1, 0.0, 0.0),
        ..right
    };
    let mut plain = graph(&dead, &edges);
    plain.add_edge(right).unwrap();
    plain.add_edge(wrong).unwrap();
    plain.optimize(30, 1e-9).unwrap();
    assert!(
        ate(&plain.poses, &truth) > clean_ate + 1.0,
        "the wrong closure must bend a plain graph"
    );

    let mut pruned = graph(&dead, &edges);
    pruned.add_edge(right).unwrap();
    pruned.add_edge(wrong).unwrap();
    let removed = pruned
        .optimize_consistent(30, 1e-9, 100.0, |e| e.from + 1 != e.to)
        .unwrap();
    assert_eq!(removed, vec![wrong]);
    assert!((ate(&pruned.poses, &truth) - clean_ate).abs() < 1e-6);

    let mut robust = graph(&dead, &edges);
    robust.add_edge(right).unwrap();
    robust
        .add_edge(Edge {
            robust: Some(1.0),
            ..wrong
        })
        .unwrap();
    robust.optimize(30, 1e-9).unwrap();
    assert!(ate(&robust.poses, &truth) < clean_ate + 0.05);
    assert!(robust.weight(robust.edges.len() - 1) < 1e-3);
}
