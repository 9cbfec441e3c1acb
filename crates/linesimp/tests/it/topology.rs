//! Topology-preserving simplification on random collections of simple, disjoint
//! integer-coordinate polygons, holes and lines:
//! - against a naive reference written here from GEOS's rules (every check scans
//!   every live segment, recursion instead of a stack, exact integer predicates);
//! - for the properties the rules promise: no new intersection, nesting kept, every
//!   dropped vertex within epsilon of its chord, rings keep 4 coordinates, and no fewer
//!   vertices than plain Douglas-Peucker keeps.

use linesimp::{
    Component, LineSimpError, Method, Metric, Tie, chord_distance, simplify_indices,
    simplify_preserving_topology,
};
use nalgebra::Point2;
use proptest::prelude::*;

type P = Point2<f64>;

// ---- exact predicates on integer coordinates (independent of the crate) ----

fn orient(a: &P, b: &P, c: &P) -> i128 {
    let q = |v: f64| v as i128;
    let det = (q(b.x) - q(a.x)) * (q(c.y) - q(a.y)) - (q(b.y) - q(a.y)) * (q(c.x) - q(a.x));
    det.signum()
}

fn on_segment(p: &P, a: &P, b: &P) -> bool {
    orient(a, b, p) == 0
        && p.x >= a.x.min(b.x)
        && p.x <= a.x.max(b.x)
        && p.y >= a.y.min(b.y)
        && p.y <= a.y.max(b.y)
}

/// Whether two segments share any point.
fn meet(a0: &P, a1: &P, b0: &P, b1: &P) -> bool {
    let (d1, d2) = (orient(a0, a1, b0), orient(a0, a1, b1));
    let (d3, d4) = (orient(b0, b1, a0), orient(b0, b1, a1));
    if d1 * d2 < 0 && d3 * d4 < 0 {
        return true;
    }
    on_segment(b0, a0, a1)
        || on_segment(b1, a0, a1)
        || on_segment(a0, b0, b1)
        || on_segment(a1, b0, b1)
}

/// GEOS's "invalid intersection": equal segments, or a common point that is not an
/// end point of both.
fn conflict(a0: &P, a1: &P, b0: &P, b1: &P) -> bool {
    if (a0 == b0 && a1 == b1) || (a0 == b1 && a1 == b0) {
        return true;
    }
    if !meet(a0, a1, b0, b1) {
        return false;
    }
    let end_of_both = |x: &P| (x == a0 || x == a1) && (x == b0 || x == b1);
    // Candidate common points: the end points lying on the other segment, or a proper
    // crossing (which is interior to both).
    let ends = [(b0, a0, a1), (b1, a0, a1), (a0, b0, b1), (a1, b0, b1)];
    let touching: Vec<&P> = ends
        .iter()
        .filter(|(x, s, t)| on_segment(x, s, t))
        .map(|(x, _, _)| *x)
        .collect();
    touching.is_empty() || touching.iter().any(|x| !end_of_both(x))
}

/// Ray from p to +x, half-open in y, segments through p not counted.
fn crosses(p: &P, a: &P, b: &P) -> bool {
    if (a.y > p.y) == (b.y > p.y) {
        return false;
    }
    let (lo, hi) = if a.y < b.y { (a, b) } else { (b, a) };
    orient(lo, hi, p) > 0
}

fn inside(p: &P, ring: &[P]) -> bool {
    ring.windows(2).filter(|w| crosses(p, &w[0], &w[1])).count() % 2 == 1
}

// ---- the naive reference ----

struct Live {
    a: P,
    b: P,
    input: Option<(usize, usize)>,
    alive: bool,
}

struct Reference<'a> {
    comps: &'a [(Vec<P>, bool)],
    eps: f64,
    live: Vec<Live>,
    /// Second input vertex until the component is simplified, then its first kept one.
    probes: Vec<Option<P>>,
}

impl Reference<'_> {
    fn input_id(&self, c: usize, k: usize) -> usize {
        self.live
            .iter()
            .position(|s| s.input == Some((c, k)))
            .unwrap()
    }

    fn crosses_live(&self, a: &P, b: &P, skip: impl Fn(&Live) -> bool) -> bool {
        self.live
            .iter()
            .any(|s| s.alive && !skip(s) && conflict(&s.a, &s.b, a, b))
    }

    fn jumps(&self, c: usize, chain: &[P], a: &P, b: &P) -> bool {
        let (x0, x1) = chain
            .iter()
            .fold((f64::MAX, f64::MIN), |r, p| (r.0.min(p.x), r.1.max(p.x)));
        let (y0, y1) = chain
            .iter()
            .fold((f64::MAX, f64::MIN), |r, p| (r.0.min(p.y), r.1.max(p.y)));
        self.probes.iter().enumerate().any(|(o, probe)| {
            let Some(q) = *probe else { return false };
            if o == c {
                return false;
            }
            if q.x < x0 || q.x > x1 || q.y < y0 || q.y > y1 {
                return false;
            }
            let along = chain
                .windows(2)
                .filter(|w| crosses(&q, &w[0], &w[1]))
                .count();
            along % 2 != usize::from(crosses(&q, a, b))
        })
    }

    fn section(
        &mut self,
        c: usize,
        i: usize,
        j: usize,
        depth: usize,
        out: &mut Vec<(usize, usize, usize)>,
    ) {
        let depth = depth + 1;
        let pts = &self.comps[c].0;
        if i + 1 == j {
            out.push((i, j, self.input_id(c, i)));
            return;
        }
        let closed = pts.len() > 1 && pts[0] == pts[pts.len() - 1];
        let min = if closed { 4 } else { 2 };
        let size = if out.is_empty() { 0 } else { out.len() + 1 };
        let (mut f, mut d) = (i + 1, -1.0);
        for k in i + 1..j {
            let dk = chord_distance(&pts[k], &pts[i], &pts[j], Metric::Segment);
            if dk > d {
                (f, d) = (k, dk);
            }
        }
        let (a, b) = (pts[i], pts[j]);
        let ok = (size >= min || depth + 1 >= min)
            && d <= self.eps
            && !self.crosses_live(
                &a,
                &b,
                |s| matches!(s.input, Some((cc, k)) if cc == c && k >= i && k < j),
            )
            && !self.jumps(c, &pts[i..=j], &a, &b);
        if ok {
            for s in &mut self.live {
                if matches!(s.input, Some((cc, k)) if cc == c && k >= i && k < j) {
                    s.alive = false;
                }
            }
            self.live.push(Live {
                a,
                b,
                input: None,
                alive: true,
            });
            out.push((i, j, self.live.len() - 1));
        } else {
            self.section(c, i, f, depth, out);
            self.section(c, f, j, depth, out);
        }
    }

    fn ring_start(&mut self, c: usize, out: &mut Vec<(usize, usize, usize)>) {
        let pts = &self.comps[c].0;
        let (first, last) = (out[0], out[out.len() - 1]);
        let (a, b, s) = (pts[last.0], pts[first.1], pts[first.0]);
        if chord_distance(&s, &a, &b, Metric::Segment) > self.eps {
            return;
        }
        let ok = orient(&a, &b, &s) == 0
            || (!self.crosses_live(&a, &b, |_| false) && !self.jumps(c, &[a, s, b], &a, &b));
        if ok {
            // GEOS retires the replaced chords but not a replaced single input segment.
            for piece in [first, last] {
                if piece.1 > piece.0 + 1 {
                    self.live[piece.2].alive = false;
                }
            }
            self.live.push(Live {
                a,
                b,
                input: None,
                alive: true,
            });
            out[0] = (last.0, first.1, self.live.len() - 1);
            out.pop();
        }
    }

    fn run(comps: &[(Vec<P>, bool)], eps: f64) -> Vec<Vec<usize>> {
        let mut live = Vec::new();
        for (c, (pts, _)) in comps.iter().enumerate() {
            for (k, w) in pts.windows(2).enumerate() {
                live.push(Live {
                    a: w[0],
                    b: w[1],
                    input: Some((c, k)),
                    alive: true,
                });
            }
        }
        let probes = comps.iter().map(|(p, _)| p.get(1).copied()).collect();
        let mut r = Reference {
            comps,
            eps,
            live,
            probes,
        };
        let mut result: Vec<Vec<usize>> = Vec::new();
        for (c, (pts, ring)) in comps.iter().enumerate() {
            if pts.len() < 3 {
                result.push((0..pts.len()).collect());
                if !pts.is_empty() {
                    r.probes[c] = Some(pts[0]);
                }
                continue;
            }
            let mut out = Vec::new();
            r.section(c, 0, pts.len() - 1, 0, &mut out);
            if *ring && out.len() + 1 > 4 {
                r.ring_start(c, &mut out);
            }
            let mut kept: Vec<usize> = out.iter().map(|p| p.0).collect();
            kept.push(out.last().unwrap().1);
            r.probes[c] = Some(pts[kept[0]]);
            result.push(kept);
        }
        result
    }
}

// ---- generators ----

/// A star-shaped ring around `centre` with radii in `[r (1 - rough), r (1 + rough)]`,
/// rounded to integers; closed.
fn star(centre: (f64, f64), r: f64, rough: f64, shape: &[(f64, f64)]) -> Vec<P> {
    let n = shape.len();
    let mut pts: Vec<P> = shape
        .iter()
        .enumerate()
        .map(|(k, &(jitter_t, jitter_r))| {
            let t = (k as f64 + 0.8 * jitter_t) / n as f64 * std::f64::consts::TAU;
            let radius = r * (1.0 + rough * (2.0 * jitter_r - 1.0));
            P::new(
                (centre.0 + radius * t.cos()).round(),
                (centre.1 + radius * t.sin()).round(),
            )
        })
        .collect();
    pts.dedup();
    pts.push(pts[0]);
    pts
}

/// One island: a rough polygon with up to three holes well inside it, and maybe an
/// open line inside too; each in its own 4000-wide cell so islands never touch.
fn island(cell: usize) -> impl Strategy<Value = Vec<(Vec<P>, bool)>> {
    let shape = || prop::collection::vec((0.0..1.0f64, 0.0..1.0f64), 4..60);
    (
        100.0..1500.0f64,
        0.0..0.3f64,
        shape(),
        prop::collection::vec(shape(), 0..3),
        prop::option::of(prop::collection::vec(-1.0..1.0f64, 2..30)),
    )
        .prop_map(move |(r, rough, outer, holes, line)| {
            let centre = (cell as f64 * 4000.0, 0.0);
            let mut comps = vec![(star(centre, r, rough, &outer), true)];
            let inner = r * (1.0 - rough);
            for (k, h) in holes.iter().enumerate() {
                let t = k as f64 / 3.0 * std::f64::consts::TAU;
                let c = (
                    centre.0 + 0.5 * inner * t.cos(),
                    centre.1 + 0.5 * inner * t.sin(),
                );
                comps.push((star(c, 0.2 * inner, 0.3, h), true));
            }
            if let Some(steps) = line {
                // Below the holes (which reach down to 0.69 of the inner radius), inside
                // the ring (x^2 + 0.83^2 < 1 for |x| <= 0.5).
                let x0 = centre.0 - 0.5 * inner;
                let dx = inner / steps.len() as f64;
                let mut pts: Vec<P> = steps
                    .iter()
                    .enumerate()
                    .map(|(k, dy)| {
                        let y = centre.1 - (0.8 + 0.03 * dy) * inner;
                        P::new((x0 + k as f64 * dx).round(), y.round())
                    })
                    .collect();
                pts.dedup_by(|a, b| a.x == b.x);
                comps.push((pts, false));
            }
            comps
        })
}

fn collection() -> impl Strategy<Value = Vec<(Vec<P>, bool)>> {
    (island(0), island(1), prop::bool::ANY).prop_map(|(a, b, both)| {
        let mut comps = a;
        if both {
            comps.extend(b);
        }
        comps
    })
}

fn segments(comps: &[Vec<P>]) -> Vec<(usize, usize, P, P)> {
    comps
        .iter()
        .enumerate()
        .flat_map(|(c, pts)| {
            pts.windows(2)
                .enumerate()
                .map(move |(k, w)| (c, k, w[0], w[1]))
        })
        .collect()
}

/// Whether the collection is free of intersections, except each component's
/// consecutive segments sharing their common vertex (and a ring's first and last).
fn is_clean(comps: &[Vec<P>]) -> bool {
    let segs = segments(comps);
    for (x, s) in segs.iter().enumerate() {
        for t in &segs[x + 1..] {
            let n = comps[s.0].len() - 1;
            let adjacent = s.0 == t.0
                && (t.1 == s.1 + 1 || (s.1 == 0 && t.1 == n - 1 && comps[s.0][0] == comps[s.0][n]));
            if s.2 == s.3 || t.2 == t.3 {
                return false;
            }
            let bad = if adjacent {
                conflict(&s.2, &s.3, &t.2, &t.3)
            } else {
                meet(&s.2, &s.3, &t.2, &t.3)
            };
            if bad {
                return false;
            }
        }
    }
    true
}

fn run(comps: &[(Vec<P>, bool)], eps: f64) -> Vec<Vec<usize>> {
    let parts: Vec<Component<'_>> = comps
        .iter()
        .map(|(p, ring)| Component {
            points: p,
            ring: *ring,
        })
        .collect();
    simplify_preserving_topology(&parts, eps, Metric::Segment, Tie::First).unwrap()
}

/// The input vertices each output chord replaced, walking a ring across its start.
fn dropped(n: usize, from: usize, to: usize, closed: bool) -> Vec<usize> {
    if from < to {
        (from + 1..to).collect()
    } else {
        assert!(closed, "only a ring may wrap");
        (from + 1..n - 1).chain(0..to).collect()
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(160))]

    #[test]
    fn matches_the_naive_reference_and_keeps_topology(comps in collection(), eps in 1.0..400.0f64) {
        let inputs: Vec<Vec<P>> = comps.iter().map(|c| c.0.clone()).collect();
        prop_assume!(is_clean(&inputs));
        let kept = run(&comps, eps);
        prop_assert_eq!(&kept, &Reference::run(&comps, eps));

        let outputs: Vec<Vec<P>> = comps.iter().zip(&kept).map(|(c, k)| k.iter().map(|&i| c.0[i]).collect()).collect();
        prop_assert!(is_clean(&outputs), "the simplification introduced an intersection");
        for (c, ((pts, ring), k)) in comps.iter().zip(&kept).enumerate() {
            let closed = pts[0] == pts[pts.len() - 1];
            let minimum = if closed { 4 } else { 2 };
            prop_assert!(k.len() >= minimum.min(pts.len()), "{} coordinates left", k.len());
            if closed {
                prop_assert_eq!(pts[k[0]], pts[k[k.len() - 1]]);
            } else {
                prop_assert_eq!((k[0], k[k.len() - 1]), (0, pts.len() - 1));
            }
            for w in k.windows(2) {
                // The chord across a ring's old start replaced two chords, each within
                // epsilon of the vertices it dropped, and only the old start vertex is
                // tested against it (GEOS's rule). Both old chords lie within epsilon
                // of it (their ends do, and distance to a segment is convex), so their
                // dropped vertices are within 2 epsilon.
                let bound = if w[0] > w[1] { 2.0 * eps } else { eps };
                for d in dropped(pts.len(), w[0], w[1], closed) {
                    let dist = chord_distance(&pts[d], &pts[w[0]], &pts[w[1]], Metric::Segment);
                    prop_assert!(dist <= bound, "component {} vertex {} is {} from its chord", c, d, dist);
                }
            }
            if !ring {
                let dp = simplify_indices(pts, eps, Method::Dp, Metric::Segment).unwrap();
                prop_assert!(dp.iter().all(|i| k.contains(i)), "fewer vertices than plain DP");
            }
        }
        // Nesting: every component's first kept vertex is inside the same rings as before.
        for (c, out) in outputs.iter().enumerate() {
            for (r, ring_out) in outputs.iter().enumerate() {
                if r != c && comps[r].1 {
                    prop_assert_eq!(inside(&out[0], &inputs[r]), inside(&out[0], ring_out));
                }
            }
        }
    }
}

/// Cases checked on shapely 2.2 / GEOS 3.14 (`MultiLineString([...])`, tolerance 2.5):
/// the jump check probes the second input vertex of a component not yet simplified and
/// the first kept vertex of one already simplified.
#[test]
fn jump_probes_follow_geos() {
    let bump = [P::new(0.0, 0.0), P::new(5.0, 2.0), P::new(10.0, 0.0)];
    let run = |lines: &[&[P]]| {
        let comps: Vec<Component<'_>> = lines.iter().map(|l| Component::line(l)).collect();
        simplify_preserving_topology(&comps, 2.5, Metric::Segment, Tie::First).unwrap()
    };
    // Hangs from the bump's top into the pocket under it.
    let hanging = [P::new(5.0, 2.0), P::new(5.1, 1.0), P::new(5.0, 0.5)];
    let rising = [P::new(5.0, 0.5), P::new(5.1, 1.0), P::new(5.0, 2.0)];
    // Simplified first: the probe is the first kept vertex, the shared top for
    // `hanging` (no jump: GEOS flattens the bump), inside the pocket for `rising`.
    assert_eq!(run(&[&hanging, &bump]), vec![vec![0, 2], vec![0, 2]]);
    assert_eq!(run(&[&rising, &bump]), vec![vec![0, 2], vec![0, 1, 2]]);
    // Not simplified yet: the probe is the second vertex, inside the pocket.
    assert_eq!(run(&[&bump, &hanging]), vec![vec![0, 1, 2], vec![0, 2]]);
    // A line dipping under the chord and coming back: simplified first, it no longer
    // reaches the pocket, though its dropped second vertex does.
    let dipping = [P::new(5.0, -1.0), P::new(5.5, 0.5), P::new(6.0, -1.0)];
    assert_eq!(run(&[&dipping, &bump]), vec![vec![0, 2], vec![0, 2]]);
}

#[test]
fn ring_start_moves_when_it_can_go() {
    // A square whose start vertex sits in the middle of the bottom edge.
    let ring = [
        P::new(1.0, 0.01),
        P::new(2.0, 0.0),
        P::new(2.0, 2.0),
        P::new(0.0, 2.0),
        P::new(0.0, 0.0),
        P::new(1.0, 0.01),
    ];
    let as_ring =
        simplify_preserving_topology(&[Component::ring(&ring)], 0.1, Metric::Segment, Tie::First)
            .unwrap();
    assert_eq!(as_ring, vec![vec![4, 1, 2, 3, 4]]);
    let as_line =
        simplify_preserving_topology(&[Component::line(&ring)], 0.1, Metric::Segment, Tie::First)
            .unwrap();
    assert_eq!(as_line, vec![vec![0, 1, 2, 3, 4, 5]]);
}

/// Cases checked on shapely 2.2 / GEOS 3.14.1 (`GeometryCollection([Polygon(ring),
/// LineString(line)])`, tolerance 1): a ring's start vertex (5, -0.5) goes, and then a
/// line below the ring flattens only if the ring's pieces on either side of the old
/// start were chords. Single input segments there stay live in GEOS (its result holds
/// copies of them, which its index cannot find to remove), so the line's chord at
/// y = -0.4 crosses them and the line keeps its low vertex. The same rule made
/// `random_polygons(57541)` at tolerance 4 differ from GEOS in the Python tests.
#[test]
fn ring_start_drop_leaves_single_end_segments_live_as_geos_does() {
    let line = [P::new(12.0, -0.4), P::new(5.0, -1.2), P::new(-2.0, -0.4)];
    let run = |ring: &[P]| {
        let comps = [Component::ring(ring), Component::line(&line)];
        simplify_preserving_topology(&comps, 1.0, Metric::Segment, Tie::First).unwrap()
    };
    // The pieces (5,-0.5)-(10,0) and (0,0)-(5,-0.5) are single input segments.
    let square = [
        P::new(5.0, -0.5),
        P::new(10.0, 0.0),
        P::new(10.0, 10.0),
        P::new(0.0, 10.0),
        P::new(0.0, 0.0),
        P::new(5.0, -0.5),
    ];
    assert_eq!(run(&square), vec![vec![4, 1, 2, 3, 4], vec![0, 1, 2]]);
    // With a vertex in each, they are chords, retired with the old start.
    let flattened = [
        P::new(5.0, -0.5),
        P::new(7.5, -0.3),
        P::new(10.0, 0.0),
        P::new(10.0, 10.0),
        P::new(0.0, 10.0),
        P::new(0.0, 0.0),
        P::new(2.5, -0.3),
        P::new(5.0, -0.5),
    ];
    assert_eq!(run(&flattened), vec![vec![5, 2, 3, 4, 5], vec![0, 2]]);
    // The line first: nothing of the ring is retired yet, so the line keeps its vertex.
    let comps = [Component::line(&line), Component::ring(&square)];
    let kept = simplify_preserving_topology(&comps, 1.0, Metric::Segment, Tie::First).unwrap();
    assert_eq!(kept, vec![vec![0, 1, 2], vec![4, 1, 2, 3, 4]]);
}

#[test]
fn closed_components_keep_four_coordinates() {
    let thin = [
        P::new(0.0, 0.0),
        P::new(1.0, 0.01),
        P::new(2.0, 0.0),
        P::new(1.0, 0.02),
        P::new(0.0, 0.0),
    ];
    for comp in [Component::ring(&thin), Component::line(&thin)] {
        let kept =
            simplify_preserving_topology(&[comp], 10.0, Metric::Segment, Tie::First).unwrap();
        assert!(kept[0].len() >= 4, "{kept:?}");
    }
}

#[test]
fn short_and_empty_components_come_back_whole() {
    let one = [P::new(1.0, 2.0)];
    let two = [P::new(1.0, 2.0), P::new(3.0, 4.0)];
    let comps = [
        Component::line(&[]),
        Component::line(&one),
        Component::line(&two),
    ];
    let kept = simplify_preserving_topology(&comps, 1.0, Metric::Segment, Tie::First).unwrap();
    assert_eq!(kept, vec![vec![], vec![0], vec![0, 1]]);
    assert_eq!(
        simplify_preserving_topology(&[], 1.0, Metric::Line, Tie::First).unwrap(),
        Vec::<Vec<usize>>::new()
    );
}

#[test]
fn bad_input_is_an_error_naming_the_component() {
    let good = [P::new(0.0, 0.0), P::new(1.0, 1.0), P::new(2.0, 0.0)];
    let bad = [P::new(0.0, 0.0), P::new(f64::NAN, 1.0), P::new(2.0, 0.0)];
    let err = simplify_preserving_topology(
        &[Component::line(&good), Component::line(&bad)],
        1.0,
        Metric::Segment,
        Tie::First,
    )
    .unwrap_err();
    assert!(
        err.to_string().contains("component 1") && err.to_string().contains("point 1"),
        "{err}"
    );
    let err =
        simplify_preserving_topology(&[Component::ring(&good)], 1.0, Metric::Segment, Tie::First)
            .unwrap_err();
    assert!(
        matches!(
            err,
            LineSimpError::InvalidParameter {
                name: "components",
                ..
            }
        ),
        "{err}"
    );
    let err =
        simplify_preserving_topology(&[Component::line(&good)], -1.0, Metric::Segment, Tie::First)
            .unwrap_err();
    assert_eq!(err, LineSimpError::InvalidEpsilon(-1.0));
}

/// 3 000 nested sections: a recursive implementation would need far more than the
/// 96 KiB stack this runs on.
#[test]
fn deep_zigzag_uses_no_recursion() {
    let zz: Vec<P> = (0..3_000)
        .map(|k| {
            P::new(
                f64::from(k),
                if k % 2 == 0 {
                    f64::from(k)
                } else {
                    -f64::from(k)
                },
            )
        })
        .collect();
    let kept = std::thread::Builder::new()
        .stack_size(96 * 1024)
        .spawn(move || {
            simplify_preserving_topology(&[Component::line(&zz)], 1e-9, Metric::Segment, Tie::First)
                .unwrap()
        })
        .unwrap()
        .join()
        .unwrap();
    assert_eq!(kept[0].len(), 3_000);
}
