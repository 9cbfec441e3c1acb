//! Wall landmarks in the pose graph: the sparse solution and marginals against a
//! dense Gauss-Newton with numeric Jacobians, one wrong wall pairing held off by
//! the robust kernel, and the walls a simulated run maps lying on the true walls.

use laser::graph::{Edge, PoseGraph, linearise};
use laser::sim::{Segment, cluttered_room};
use laser::wall_factor::{WallFactor, linearise_wall};
use laser::{LaserConfig, run};

use crate::pipeline::{config, geometry, laps, log};
use nalgebra::{DMatrix, DVector, Matrix2, Matrix3, Point2, Vector2, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use rperc_core::{Pose2, wrap_angle};
use slam::wall::observe_wall;

/// A robot driving 30 m along a corridor (walls y = 2 and y = -2) with odometry
/// that drifts in heading, sighting both walls every 5 m: poses, edges, factors and
/// the walls' initial estimates (a little off), with the true poses.
struct Corridor {
    truth: Vec<Pose2>,
    dead: Vec<Pose2>,
    edges: Vec<Edge>,
    factors: Vec<WallFactor>,
    walls: Vec<Vector2<f64>>,
}

fn corridor(seed: u64) -> Corridor {
    let truth: Vec<Pose2> = (0..31).map(|k| Pose2::new(k as f64, 0.0, 0.0)).collect();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut n = |s: f64| Normal::new(0.0, s).unwrap().sample(&mut rng);
    let (sxy, sth): (f64, f64) = (0.02, 0.005);
    let info = Matrix3::from_diagonal(&Vector3::new(sxy.powi(-2), sxy.powi(-2), sth.powi(-2)));
    let (mut dead, mut edges) = (vec![truth[0]], Vec::new());
    for k in 1..truth.len() {
        let z = truth[k - 1].between(&truth[k]);
        let z = Pose2::new(z.x + n(sxy), z.y + n(sxy), z.theta + n(sth) + 0.004);
        dead.push(dead[k - 1].compose(&z));
        edges.push(Edge {
            from: k - 1,
            to: k,
            measurement: z,
            information: info,
            robust: None,
        });
    }
    let true_walls = [
        Vector2::new(2.0, std::f64::consts::FRAC_PI_2),
        Vector2::new(2.0, -std::f64::consts::FRAC_PI_2),
    ];
    let r = Matrix2::new(1e-4, 0.0, 0.0, 1e-4);
    let mut factors = Vec::new();
    for k in (0..truth.len()).step_by(5) {
        for (w, wall) in true_walls.iter().enumerate() {
            let seen = observe_wall(&truth[k], wall).unwrap().wall;
            let z = Vector2::new(seen.x + n(0.01), wrap_angle(seen.y + n(0.01)));
            let mid = Point2::new(z.x * z.y.cos() + 0.5, z.x * z.y.sin());
            factors.push(WallFactor {
                pose: k,
                wall: w,
                z,
                mid,
                information: r.try_inverse().unwrap(),
                robust: None,
            });
        }
    }
    let walls = true_walls
        .iter()
        .map(|w| w + Vector2::new(0.05, 0.01))
        .collect();
    Corridor {
        truth,
        dead,
        edges,
        factors,
        walls,
    }
}

fn graph(c: &Corridor, factors: &[WallFactor]) -> PoseGraph {
    let mut g = PoseGraph::new(c.dead[0], Matrix3::identity() * 1e8);
    for p in &c.dead[1..] {
        g.add_pose(*p);
    }
    for e in &c.edges {
        g.add_edge(*e).unwrap();
    }
    for w in &c.walls {
        g.add_wall(*w).unwrap();
    }
    for f in factors {
        g.add_wall_factor(*f).unwrap();
    }
    g
}

/// Every residual of the graph stacked and whitened, at the state vector `x`
/// (poses then walls, 3 and 2 entries each).
fn residuals(c: &Corridor, g: &PoseGraph, x: &DVector<f64>) -> DVector<f64> {
    let n = c.dead.len();
    let pose = |k: usize| Pose2::new(x[3 * k], x[3 * k + 1], x[3 * k + 2]);
    let wall = |j: usize| Vector2::new(x[3 * n + 2 * j], x[3 * n + 2 * j + 1]);
    let mut out = Vec::new();
    let chol = |m: &Matrix3<f64>| m.cholesky().unwrap().l().transpose();
    let a = pose(0).to_vector() - c.dead[0].to_vector();
    out.extend(
        (chol(&(Matrix3::identity() * 1e8)) * Vector3::new(a.x, a.y, wrap_angle(a.z))).iter(),
    );
    for e in &g.edges {
        let (err, _, _) = linearise(&pose(e.from), &pose(e.to), &e.measurement);
        out.extend((chol(&e.information) * err).iter());
    }
    for f in &g.wall_factors {
        let (err, _, _) = linearise_wall(&pose(f.pose), &wall(f.wall), &f.z, &f.mid).unwrap();
        let l = f.information.cholesky().unwrap().l().transpose();
        out.extend((l * err).iter());
    }
    DVector::from_vec(out)
}

/// Dense Gauss-Newton with central-difference Jacobians over the same residuals:
/// the state, and the inverse of `J^T J` at the optimum.
fn dense_optimum(c: &Corridor, g: &PoseGraph) -> (DVector<f64>, DMatrix<f64>) {
    let n = c.dead.len();
    let mut x = DVector::zeros(3 * n + 2 * c.walls.len());
    for (k, p) in c.dead.iter().enumerate() {
        x.fixed_rows_mut::<3>(3 * k).copy_from(&p.to_vector());
    }
    for (j, w) in c.walls.iter().enumerate() {
        x.fixed_rows_mut::<2>(3 * n + 2 * j).copy_from(w);
    }
    let jacobian = |x: &DVector<f64>| {
        let r0 = residuals(c, g, x);
        let mut jac = DMatrix::zeros(r0.len(), x.len());
        for i in 0..x.len() {
            let h = 1e-6;
            let (mut a, mut b) = (x.clone(), x.clone());
            a[i] += h;
            b[i] -= h;
            jac.set_column(
                i,
                &((residuals(c, g, &a) - residuals(c, g, &b)) / (2.0 * h)),
            );
        }
        (r0, jac)
    };
    for _ in 0..10 {
        let (r, jac) = jacobian(&x);
        let h = jac.transpose() * &jac;
        let step = h.cholesky().unwrap().solve(&(jac.transpose() * r));
        x -= step;
    }
    let (_, jac) = jacobian(&x);
    (x.clone(), (jac.transpose() * jac).try_inverse().unwrap())
}

#[test]
fn walls_in_the_sparse_graph_match_a_dense_solution() {
    let c = corridor(7);
    let mut g = graph(&c, &c.factors);
    g.optimize(20, 1e-12).unwrap();
    let (x, cov) = dense_optimum(&c, &g);
    let n = c.dead.len();
    for (k, p) in g.poses.iter().enumerate() {
        let d = p.to_vector() - x.fixed_rows::<3>(3 * k);
        assert!(
            d.norm() < 1e-6,
            "pose {k}: {p:?} vs {:?}",
            x.fixed_rows::<3>(3 * k)
        );
    }
    for (j, w) in g.walls.iter().enumerate() {
        assert!(
            (w - x.fixed_rows::<2>(3 * n + 2 * j)).norm() < 1e-6,
            "wall {j}"
        );
    }
    let m = g.marginals().unwrap();
    assert_eq!(m.len(), n);
    for (k, mk) in m.iter().enumerate() {
        let dense = cov.view((3 * k, 3 * k), (3, 3));
        assert!(
            (mk - dense).norm() < 1e-6 * (1.0 + dense.norm()),
            "marginal {k}"
        );
    }
}

#[test]
fn walls_remove_the_drift_across_the_corridor() {
    let c = corridor(11);
    let lateral = |poses: &[Pose2]| poses.iter().map(|p| p.y.abs()).fold(0.0, f64::max);
    let mut plain = graph(&c, &[]);
    plain.optimize(20, 1e-9).unwrap();
    let mut with = graph(&c, &c.factors);
    with.optimize(20, 1e-9).unwrap();
    let (before, after) = (lateral(&plain.poses), lateral(&with.poses));
    assert!(
        before > 0.5,
        "the heading bias must drift the chain: {before}"
    );
    assert!(after < 0.1 * before, "{before} -> {after}");
    // Along the corridor the walls say nothing: the last pose's x variance is the
    // chain's, 30 steps of 0.02 m each (closed form, the heading held near 0).
    let (mp, mw) = (plain.marginals().unwrap(), with.marginals().unwrap());
    let last = c.truth.len() - 1;
    let along = last as f64 * 0.02f64.powi(2);
    assert!(
        (mw[last][(0, 0)] / along - 1.0).abs() < 0.01,
        "{} vs {along}",
        mw[last][(0, 0)]
    );
    // Across it they do, though each sighting's angle (sd 0.01 rad here) over 30 m
    // leaves the far end's lateral sd near 0.15 m: well under the chain's 0.5 m.
    assert!(mw[last][(1, 1)] < 0.2 * mp[last][(1, 1)]);
}

#[test]
fn one_wrong_wall_pairing_does_not_wreck_the_map() {
    let c = corridor(13);
    let robust: Vec<WallFactor> = c
        .factors
        .iter()
        .map(|f| WallFactor {
            robust: Some(5.0),
            ..*f
        })
        .collect();
    let mut clean = graph(&c, &robust);
    clean.optimize(30, 1e-9).unwrap();
    // Pose 15 "sees" the left wall 1 m nearer than it is (a cupboard taken for it).
    let mut wrong = robust[6];
    assert_eq!(wrong.pose, 15);
    wrong.z.x -= 1.0;
    wrong.mid.y -= 1.0;
    let bent = |r: Option<f64>| {
        let mut g = graph(&c, &robust);
        g.add_wall_factor(WallFactor { robust: r, ..wrong })
            .unwrap();
        g.optimize(30, 1e-9).unwrap();
        g.poses
            .iter()
            .zip(&clean.poses)
            .map(|(a, b)| (a.translation() - b.translation()).norm())
            .fold(0.0, f64::max)
    };
    let (plain, kept) = (bent(None), bent(Some(5.0)));
    // Pose 15 is held by the chain and by its sighting of the right wall, so a plain
    // wrong factor bends the map by centimetres; the kernel leaves it untouched.
    assert!(
        plain > 0.05,
        "a plain wrong factor must bend the map: {plain}"
    );
    assert!(kept < 1e-3, "the robust kernel keeps the map: {kept}");
}

/// Pruning removes the wrong pairing (and only it) from a plain graph, and the map
/// is then the clean one.
#[test]
fn pruning_removes_the_wrong_wall_pairing() {
    let c = corridor(17);
    let mut clean = graph(&c, &c.factors);
    clean.optimize(30, 1e-9).unwrap();
    let mut wrong = c.factors[6];
    wrong.z.x -= 1.0;
    wrong.mid.y -= 1.0;
    let mut g = graph(&c, &c.factors);
    g.add_wall_factor(wrong).unwrap();
    g.optimize(30, 1e-9).unwrap();
    let gate = rperc_core::chi2_gate(2, 0.999).unwrap();
    assert!(g.prune_wall_factor(gate).unwrap());
    assert!(!g.wall_factors.contains(&wrong));
    assert_eq!(g.wall_factors.len(), c.factors.len());
    g.optimize(30, 1e-9).unwrap();
    assert!(!g.prune_wall_factor(gate).unwrap());
    for (a, b) in g.poses.iter().zip(&clean.poses) {
        assert!((a.to_vector() - b.to_vector()).norm() < 1e-6);
    }
}

/// Distance from `p` to segment `s`.
fn to_segment(p: &Point2<f64>, s: &Segment) -> f64 {
    let (a, b, p) = (s.a, s.b, p.coords);
    let t = ((p - a).dot(&(b - a)) / (b - a).norm_squared()).clamp(0.0, 1.0);
    (p - (a + (b - a) * t)).norm()
}

/// Two laps inside the cluttered room: the walls the run maps lie on the true walls.
#[test]
fn a_simulated_run_maps_walls_on_the_true_walls() {
    // The double loop of the pipeline's own test, in the same room.
    let room = cluttered_room(12.0, 8.0);
    let (ranges, counts, controls, times) = laps();
    let g = geometry(counts.len());
    let log = log(&ranges, &counts, &g);
    let cfg = LaserConfig {
        walls: laser::WallConfig {
            enabled: true,
            ..Default::default()
        },
        ..config()
    };
    let out = run(&log, &controls, &times, &cfg).unwrap();
    assert!(out.walls.len() >= 4, "{} walls", out.walls.len());
    assert!(out.wall_factors >= 2 * out.walls.len());
    for s in &out.walls {
        for end in [Point2::new(s[0], s[1]), Point2::new(s[2], s[3])] {
            let d = room
                .iter()
                .map(|w| to_segment(&end, w))
                .fold(f64::INFINITY, f64::min);
            assert!(d < 0.05, "wall end {end} is {d} m from every true wall");
        }
    }
    let off = LaserConfig {
        walls: laser::WallConfig::default(),
        ..cfg
    };
    let plain = run(&log, &controls, &times, &off).unwrap();
    assert!(plain.walls.is_empty() && plain.wall_factors == 0);
}
