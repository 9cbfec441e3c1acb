//! Edge pixels chained into contours and sampled along their polygonal approximation
//! (the first level of the pattern model, section 3.2).

use linesimp::{Method, Metric, Simplifier};
use nalgebra::Point2;

use crate::error::Result;

/// The 8 neighbours, 4-connected ones first so that a chain prefers straight steps.
const NEIGHBOURS: [(isize, isize); 8] = [
    (1, 0),
    (0, 1),
    (-1, 0),
    (0, -1),
    (1, 1),
    (-1, 1),
    (-1, -1),
    (1, -1),
];

/// Chains the set pixels of `edges` (`width x height`, row-major) into 8-connected
/// contours. Each chain is grown from a seed in both directions by walking to an
/// unvisited neighbour; the unvisited neighbours seen on the way are pushed on an
/// explicit stack and seed later chains, so branches become contours of their own and
/// nothing recurses.
pub fn trace_contours(edges: &[bool], width: usize, height: usize) -> Vec<Vec<Point2<f64>>> {
    let mut visited = vec![false; edges.len()];
    let mut contours = Vec::new();
    let mut seeds = Vec::new();
    for start in 0..edges.len() {
        if !edges[start] || visited[start] {
            continue;
        }
        seeds.push(start);
        while let Some(seed) = seeds.pop() {
            if visited[seed] {
                continue;
            }
            visited[seed] = true;
            let mut forward = walk(seed, edges, &mut visited, width, height, &mut seeds);
            let backward = walk(seed, edges, &mut visited, width, height, &mut seeds);
            let mut chain: Vec<usize> = backward.into_iter().rev().collect();
            chain.push(seed);
            chain.append(&mut forward);
            contours.push(
                chain
                    .iter()
                    .map(|&i| Point2::new((i % width) as f64, (i / width) as f64))
                    .collect(),
            );
        }
    }
    contours
}

/// Walks from `from` to unvisited edge neighbours until none is left; returns the
/// pixels visited (without `from`) and pushes the neighbours not taken on `seeds`.
fn walk(
    from: usize,
    edges: &[bool],
    visited: &mut [bool],
    width: usize,
    height: usize,
    seeds: &mut Vec<usize>,
) -> Vec<usize> {
    let mut path = Vec::new();
    let mut current = from;
    loop {
        let (x, y) = ((current % width) as isize, (current / width) as isize);
        let mut next = None;
        for (dx, dy) in NEIGHBOURS {
            let (nx, ny) = (x + dx, y + dy);
            if nx < 0 || ny < 0 || nx >= width as isize || ny >= height as isize {
                continue;
            }
            let n = ny as usize * width + nx as usize;
            if edges[n] && !visited[n] {
                if next.is_none() {
                    next = Some(n);
                } else {
                    seeds.push(n);
                }
            }
        }
        match next {
            Some(n) => {
                visited[n] = true;
                path.push(n);
                current = n;
            }
            None => return path,
        }
    }
}

/// The Douglas-Peucker approximation of `contour` (our `linesimp`, segment metric)
/// with tolerance `epsilon` pixels.
pub fn approximate(
    simplifier: &mut Simplifier,
    contour: &[Point2<f64>],
    epsilon: f64,
) -> Vec<Point2<f64>> {
    match simplifier.indices(contour, epsilon) {
        Ok(keep) => keep.iter().map(|&i| contour[i]).collect(),
        // The contour is finite pixel coordinates and epsilon was validated, so this
        // only happens for a degenerate chain: keep it as it is.
        Err(_) => contour.to_vec(),
    }
}

/// A simplifier for [`approximate`].
pub fn simplifier() -> Simplifier {
    Simplifier::new(Method::Dp, Metric::Segment)
}

/// Points every `spacing` pixels of arc length along `polyline`, the first at half a
/// spacing from its start.
///
/// # Errors
/// [`TrackingError::InvalidParameter`] (as `point_spacing`) for a spacing that is not
/// positive and finite, and `TooLarge` when the samples would exceed rperc's allocation
/// limit: a spacing of 1e-9 px asked for 10^9 points per pixel of contour (issue 38).
pub fn sample_polyline(polyline: &[Point2<f64>], spacing: f64) -> Result<Vec<Point2<f64>>> {
    rperc_core::ensure_positive("point_spacing", spacing)?;
    let total: f64 = polyline.windows(2).map(|s| (s[1] - s[0]).norm()).sum();
    let count = if total >= 0.5 * spacing {
        ((total - 0.5 * spacing) / spacing).floor() + 1.0
    } else {
        0.0
    };
    // A float count past u128 saturates, and is refused all the same.
    rperc_core::check_allocation("point_spacing", count as u128, 16)?;
    let mut out = Vec::with_capacity(count as usize);
    let mut travelled = 0.0;
    for seg in polyline.windows(2) {
        let d = seg[1] - seg[0];
        let len = d.norm();
        // The k-th sample's arc length from its index, not a running sum: adding a
        // spacing far below the travelled length's resolution would never advance.
        let mut next = (out.len() as f64 + 0.5) * spacing;
        while len > 0.0 && next <= travelled + len && out.len() < count as usize {
            let t = (next - travelled) / len;
            out.push(seg[0] + d * t);
            next = (out.len() as f64 + 0.5) * spacing;
        }
        travelled += len;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_square_outline_is_one_closed_chain() {
        let (w, h) = (12, 10);
        let mut edges = vec![false; w * h];
        for x in 2..9 {
            edges[2 * w + x] = true;
            edges[7 * w + x] = true;
        }
        for y in 2..8 {
            edges[y * w + 2] = true;
            edges[y * w + 8] = true;
        }
        let contours = trace_contours(&edges, w, h);
        assert_eq!(contours.len(), 1);
        assert_eq!(contours[0].len(), edges.iter().filter(|&&e| e).count());
        for pair in contours[0].windows(2) {
            let d = pair[1] - pair[0];
            assert!(
                d.x.abs() <= 1.0 && d.y.abs() <= 1.0,
                "chain must be 8-connected"
            );
        }
    }

    #[test]
    fn polyline_sampling_spacing() {
        let line = [
            Point2::new(0.0, 0.0),
            Point2::new(10.0, 0.0),
            Point2::new(10.0, 10.0),
        ];
        let pts = sample_polyline(&line, 4.0).unwrap();
        let xs: Vec<(f64, f64)> = pts.iter().map(|p| (p.x, p.y)).collect();
        assert_eq!(
            xs,
            vec![
                (2.0, 0.0),
                (6.0, 0.0),
                (10.0, 0.0),
                (10.0, 4.0),
                (10.0, 8.0)
            ]
        );
    }
}
