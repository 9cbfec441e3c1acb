//! Topology-preserving Douglas-Peucker for a collection of polylines and polygon rings,
//! following the rules of GEOS's `TopologyPreservingSimplifier` (shapely's
//! `simplify(tolerance, preserve_topology=True)`):
//!
//! - Components are simplified one after the other, in input order, each by the
//!   Douglas-Peucker recursion (left part first, on an explicit stack).
//! - A section `i..j` is replaced by its chord only if (1) no vertex is farther than
//!   `epsilon` from the chord, (2) the line keeps enough vertices (a closed component
//!   keeps at least 4 coordinates, an open one 2), (3) the chord has no *interior
//!   intersection* (a crossing, a touch inside a segment, an overlap; a shared end
//!   point is fine) with any live segment: the not-yet-replaced input segments of every
//!   component except those of the section itself, and every chord accepted so far, and
//!   (4) the chord does not jump over another component: for each other component whose
//!   *probe* lies in the section's bounding box, the section and the chord must see the
//!   probe on the same side (equal parity of ray crossings). The probe is the second
//!   vertex of a component not simplified yet, and the first kept vertex of one already
//!   simplified (GEOS since JTS #1096). Otherwise the section splits at its farthest
//!   vertex, as plain DP would.
//! - When condition (2) fails, GEOS's rule is used: at depth `d` of the recursion a
//!   section may be flattened only if the line already has the minimum number of
//!   vertices or `d + 1` reaches it.
//! - A polygon ring ([`Component::ring`]) then also drops its start vertex when it lies
//!   within `epsilon` of the chord joining its neighbours and that chord passes the same
//!   checks (a start vertex collinear with that chord is always dropped, as in GEOS); the
//!   ring then starts at its last kept vertex before the old start. The chords it
//!   replaced leave the live segments, but a replaced piece that was a single input
//!   segment stays live, as in GEOS (whose index misses it). Closed
//!   polylines that are not rings keep their start vertex.
//!
//! Live segments sit in a uniform grid ([`grid::SegmentGrid`]), so a check looks at
//! the cells along the chord rather than at every segment.

mod grid;
pub(crate) mod predicates;
mod probes;

use nalgebra::Point2;

use self::grid::{Origin, Segment, SegmentGrid};
use self::predicates::{crosses_ray, interior_intersection, orientation, same_segment};
use self::probes::Probes;
use crate::{LineSimpError, Metric, Result, Tie, chord_distance};

type P = Point2<f64>;

/// One linear part of a geometry: an open or closed polyline, or a polygon ring.
#[derive(Debug, Clone, Copy)]
pub struct Component<'a> {
    /// The vertices, in order.
    pub points: &'a [Point2<f64>],
    /// A polygon ring (a GEOS `LinearRing`): must be closed (first vertex equal to the
    /// last) with at least 4 coordinates; its start vertex may be dropped like any
    /// other. `false` for a polyline, whose end points always stay.
    pub ring: bool,
}

impl<'a> Component<'a> {
    /// An open or closed polyline: its end points stay.
    pub fn line(points: &'a [Point2<f64>]) -> Self {
        Self {
            points,
            ring: false,
        }
    }

    /// A polygon ring: closed, and its start vertex may go.
    pub fn ring(points: &'a [Point2<f64>]) -> Self {
        Self { points, ring: true }
    }

    fn is_closed(&self) -> bool {
        self.points.len() > 1 && self.points.first() == self.points.last()
    }
}

/// Simplifies every component with tolerance `epsilon` so that no new intersection
/// appears between or within them (see the module documentation for the exact rules).
/// Returns, per component, the indices of the kept vertices in output order: increasing
/// for polylines; for a ring whose start vertex went, starting and ending at another
/// vertex (e.g. `[7, 3, 5, 7]`).
///
/// `metric` measures the distance to a chord ([`Metric::Segment`] is what GEOS uses)
/// and `tie` picks among equally far vertices (GEOS: [`Tie::First`]).
///
/// # Errors
/// A negative or non-finite `epsilon`, a non-finite coordinate, or a component marked
/// as a ring that is not closed or has fewer than 4 coordinates.
///
/// # Examples
/// ```
/// use linesimp::{Component, Metric, Tie, simplify_preserving_topology};
/// use nalgebra::Point2;
///
/// // A bump and, between it and its chord, a short line: flattening the bump would
/// // jump over the line (move it to the other side), so the bump keeps its top.
/// let bump = [Point2::new(0.0, 0.0), Point2::new(5.0, 1.0), Point2::new(10.0, 0.0)];
/// let island = [Point2::new(4.0, 0.2), Point2::new(6.0, 0.2)];
/// let alone = simplify_preserving_topology(&[Component::line(&bump)], 2.0, Metric::Segment, Tie::First);
/// assert_eq!(alone.unwrap(), vec![vec![0, 2]]);
/// let both = [Component::line(&bump), Component::line(&island)];
/// let kept = simplify_preserving_topology(&both, 2.0, Metric::Segment, Tie::First).unwrap();
/// assert_eq!(kept, vec![vec![0, 1, 2], vec![0, 1]]);
/// ```
pub fn simplify_preserving_topology(
    components: &[Component<'_>],
    epsilon: f64,
    metric: Metric,
    tie: Tie,
) -> Result<Vec<Vec<usize>>> {
    check(components, epsilon)?;
    let mut engine = Engine::new(components, epsilon, metric, tie);
    Ok((0..components.len())
        .map(|c| engine.simplify_component(c))
        .collect())
}

fn check(components: &[Component<'_>], epsilon: f64) -> Result<()> {
    let total: usize = components.iter().map(|c| c.points.len()).sum();
    if total >= u32::MAX as usize {
        return Err(LineSimpError::InvalidParameter {
            name: "components",
            reason: format!("at most {} points in all are supported", u32::MAX - 1),
        });
    }
    for (k, comp) in components.iter().enumerate() {
        crate::validate(comp.points, epsilon).map_err(|e| match e {
            LineSimpError::NonFinitePoint { .. } => LineSimpError::InvalidParameter {
                name: "components",
                reason: format!("component {k}: {e}"),
            },
            other => other,
        })?;
        if comp.ring && !(comp.is_closed() && comp.points.len() >= 4) {
            return Err(LineSimpError::InvalidParameter {
                name: "components",
                reason: format!(
                    "component {k} is a ring, so it must be closed with at least 4 \
                     coordinates; got {} coordinates{}",
                    comp.points.len(),
                    if comp.is_closed() { "" } else { ", not closed" }
                ),
            });
        }
    }
    Ok(())
}

/// A piece of a component's result: the chord from vertex `start` to vertex `end`
/// (consecutive vertices when nothing was dropped between them), stored as `segment`.
#[derive(Debug, Clone, Copy)]
struct Piece {
    start: usize,
    end: usize,
    segment: u32,
}

/// The state shared by all components: the live segments and the probe points.
struct Engine<'a> {
    components: &'a [Component<'a>],
    epsilon: f64,
    metric: Metric,
    tie: Tie,
    grid: SegmentGrid,
    /// Id of input segment 0 of each component (input segments are stored first, in
    /// order, so segment `k` of component `c` has id `first_segment[c] + k`).
    first_segment: Vec<u32>,
    /// The point of each component that chords must not jump over.
    probes: Probes,
}

impl<'a> Engine<'a> {
    fn new(components: &'a [Component<'a>], epsilon: f64, metric: Metric, tie: Tie) -> Self {
        let all = || components.iter().flat_map(|c| c.points.iter());
        let mut lo = P::new(f64::INFINITY, f64::INFINITY);
        let mut hi = P::new(f64::NEG_INFINITY, f64::NEG_INFINITY);
        for p in all() {
            lo = P::new(lo.x.min(p.x), lo.y.min(p.y));
            hi = P::new(hi.x.max(p.x), hi.y.max(p.y));
        }
        if lo.x > hi.x {
            (lo, hi) = (P::origin(), P::origin());
        }
        let segments: usize = components
            .iter()
            .map(|c| c.points.len().saturating_sub(1))
            .sum();
        let length: f64 = components
            .iter()
            .flat_map(|c| c.points.windows(2).map(|w| (w[1] - w[0]).norm()))
            .sum();
        let mut grid = SegmentGrid::new(lo, hi, segments, length);
        let mut first_segment = Vec::with_capacity(components.len());
        let mut stored = 0u32;
        for (c, comp) in components.iter().enumerate() {
            first_segment.push(stored);
            stored += comp.points.len().saturating_sub(1) as u32;
            for (k, w) in comp.points.windows(2).enumerate() {
                let origin = Origin::Input {
                    component: c as u32,
                    index: k as u32,
                };
                grid.insert(Segment {
                    a: w[0],
                    b: w[1],
                    origin,
                });
            }
        }
        let probes = Probes::new(components.iter().map(|c| c.points.get(1).copied()));
        Self {
            components,
            epsilon,
            metric,
            tie,
            grid,
            first_segment,
            probes,
        }
    }

    /// The kept vertices of component `c`; its probe then moves to its first kept
    /// vertex.
    fn simplify_component(&mut self, c: usize) -> Vec<usize> {
        let comp = self.components[c];
        let kept = self.kept_vertices(c);
        if let Some(&first) = kept.first() {
            self.probes.set(c, comp.points[first]);
        }
        kept
    }

    /// The Douglas-Peucker recursion on an explicit stack (left part on top, so pieces
    /// come out in order), then the ring start vertex.
    fn kept_vertices(&mut self, c: usize) -> Vec<usize> {
        let comp = self.components[c];
        let n = comp.points.len();
        if n < 3 {
            return (0..n).collect();
        }
        let min_size = if comp.is_closed() { 4 } else { 2 };
        let mut pieces: Vec<Piece> = Vec::new();
        let mut stack = vec![(0usize, n - 1, 0usize)];
        while let Some((i, j, parent_depth)) = stack.pop() {
            let depth = parent_depth + 1;
            if i + 1 == j {
                // A single input segment stays as it is, and stays live.
                let segment = self.first_segment[c] + i as u32;
                pieces.push(Piece {
                    start: i,
                    end: j,
                    segment,
                });
                continue;
            }
            let (split, distance) = self.farthest(comp.points, i, j);
            let size = if pieces.is_empty() {
                0
            } else {
                pieces.len() + 1
            };
            let big_enough = size >= min_size || depth + 1 >= min_size;
            if big_enough && distance <= self.epsilon && self.section_is_safe(c, i, j) {
                let segment = self.flatten(c, i, j);
                pieces.push(Piece {
                    start: i,
                    end: j,
                    segment,
                });
            } else {
                stack.push((split, j, depth));
                stack.push((i, split, depth));
            }
        }
        if comp.ring && pieces.len() + 1 > min_size {
            self.drop_ring_start(c, &mut pieces);
        }
        let mut kept: Vec<usize> = pieces.iter().map(|p| p.start).collect();
        kept.extend(pieces.last().map(|p| p.end));
        kept
    }

    /// The vertex strictly between `i` and `j` farthest from the chord, and its
    /// distance. Starts from `i + 1`, so the split always makes progress.
    fn farthest(&self, points: &[P], i: usize, j: usize) -> (usize, f64) {
        let (a, b) = (&points[i], &points[j]);
        let d = |k: usize| chord_distance(&points[k], a, b, self.metric);
        let mut best = (i + 1, d(i + 1));
        for k in i + 2..j {
            let dk = d(k);
            let better = match self.tie {
                Tie::First => dk > best.1,
                Tie::Last => dk >= best.1,
            };
            if better {
                best = (k, dk);
            }
        }
        best
    }

    /// Whether the chord of section `i..j` of component `c` can replace it.
    fn section_is_safe(&mut self, c: usize, i: usize, j: usize) -> bool {
        let points = self.components[c].points;
        let (a, b) = (points[i], points[j]);
        let section = |o: &Origin| match *o {
            Origin::Input { component, index } => {
                component as usize == c && (i..j).contains(&(index as usize))
            }
            Origin::Output => false,
        };
        let crossed = self.grid.any_near(&a, &b, |s| {
            !section(&s.origin) && chord_conflicts(s, &a, &b)
        });
        !crossed && !self.jumps_component(c, &points[i..=j], &a, &b)
    }

    /// Whether replacing the chain `chain` (of component `c`) by the chord `a b` moves
    /// another component's probe point to the other side (GEOS's component jump check).
    fn jumps_component(&self, c: usize, chain: &[P], a: &P, b: &P) -> bool {
        let (mut lo, mut hi) = (chain[0], chain[0]);
        for p in chain {
            lo = P::new(lo.x.min(p.x), lo.y.min(p.y));
            hi = P::new(hi.x.max(p.x), hi.y.max(p.y));
        }
        self.probes.inside(&lo, &hi, c).any(|probe| {
            let along = chain
                .windows(2)
                .filter(|w| crosses_ray(&probe, &w[0], &w[1]))
                .count();
            along % 2 != usize::from(crosses_ray(&probe, a, b))
        })
    }

    /// Replaces section `i..j` of component `c` by its chord; returns the chord's id.
    fn flatten(&mut self, c: usize, i: usize, j: usize) -> u32 {
        let first = self.first_segment[c];
        for k in i..j {
            self.grid.remove(first + k as u32);
        }
        let points = self.components[c].points;
        self.grid.insert(Segment {
            a: points[i],
            b: points[j],
            origin: Origin::Output,
        })
    }

    /// GEOS's ring end point step: drop the start vertex when it lies within epsilon
    /// of the chord joining its kept neighbours and that chord is safe.
    fn drop_ring_start(&mut self, c: usize, pieces: &mut Vec<Piece>) {
        let points = self.components[c].points;
        let (Some(&first), Some(&last)) = (pieces.first(), pieces.last()) else {
            return;
        };
        let (a, b, start) = (points[last.start], points[first.end], points[first.start]);
        if chord_distance(&start, &a, &b, self.metric) > self.epsilon {
            return;
        }
        let safe = orientation(&a, &b, &start) == 0 || {
            let crossed = self.grid.any_near(&a, &b, |s| chord_conflicts(s, &a, &b));
            !crossed && !self.jumps_component(c, &[a, start, b], &a, &b)
        };
        if !safe {
            return;
        }
        // GEOS's index update: a piece that is a flattened chord leaves the live set,
        // but a piece that is a single input segment stays live although the vertex
        // it ends at is gone (GEOS's result holds a copy of that segment, so removing
        // the copy from its index removes nothing). Such a leftover can only block
        // later chords, never let one through, and keeping it gives GEOS's vertices.
        for piece in [first, last] {
            if piece.end > piece.start + 1 {
                self.grid.remove(piece.segment);
            }
        }
        let segment = self.grid.insert(Segment {
            a,
            b,
            origin: Origin::Output,
        });
        pieces[0] = Piece {
            start: last.start,
            end: first.end,
            segment,
        };
        pieces.pop();
    }
}

/// GEOS's "invalid intersection" of a live segment with a candidate chord: the same
/// segment, or an interior intersection.
fn chord_conflicts(s: &Segment, a: &P, b: &P) -> bool {
    same_segment(&s.a, &s.b, a, b) || interior_intersection(&s.a, &s.b, a, b)
}
