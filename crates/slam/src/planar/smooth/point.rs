//! Point landmarks in the smoother. Each paired range-bearing detection is corrected
//! for the sensors' biases exactly as the filter corrects it, and measures its
//! landmark from its pose with the filter's noise `diag(range_variance,
//! bearing_variance)`. Landmarks are unknowns in the world frame.
//!
//! A point sighting may carry a Huber kernel (`SmootherConfig::point_huber`): the
//! filter gates each sighting on its own innovation, and the smoother must not let
//! the few it would have refused (a barcode read on the wrong target, a reflection)
//! pull every pose around them.

use std::collections::HashMap;

use nalgebra::{Matrix2, Matrix2x3, Point2, Vector2, Vector3};
use rperc_core::{Pose2, wrap_angle};

use super::{FilterRun, node_of};
use crate::error::{Result, SlamError};
use crate::observation::range_bearing;

/// One paired point detection, corrected for the sensors' biases.
pub(super) struct PointSighting {
    pub(super) node: usize,
    pub(super) landmark: usize,
    /// `(range, bearing)` in the sensor frame.
    pub(super) z: Vector2<f64>,
    /// `1 / sqrt(m)` for the `m` sightings of its landmark within the correlation
    /// time of it (itself included): scales its whitened residual.
    pub(super) weight: f64,
}

/// The paired detections, the landmarks' ids and their starting positions.
pub(super) type PointSightings = (Vec<PointSighting>, Vec<u64>, Vec<Vector2<f64>>);

/// The run's paired point detections, each landmark starting at the filter's final
/// estimate (`run.landmarks`), weighted for the sightings of the same landmark
/// within `correlation_time` seconds.
pub(super) fn point_sightings(
    run: &FilterRun<'_>,
    correlation_time: f64,
) -> Result<PointSightings> {
    let map: HashMap<u64, [f64; 2]> = run.landmarks.iter().copied().collect();
    let mut index: HashMap<u64, usize> = HashMap::new();
    let (mut out, mut ids, mut means) = (vec![], vec![], vec![]);
    for (i, (row, id)) in run.points.iter().zip(run.point_pairing).enumerate() {
        let Some(id) = *id else { continue };
        let node = node_of(run.times, "points", i, row[0])?;
        let (range, bearing) = run.config.bias.correct_detection(row[1], row[2])?;
        // As the filter refuses it: a landmark at or behind the sensor has no bearing.
        if range.is_nan() || range <= 0.0 {
            return Err(SlamError::invalid(
                "points",
                format!(
                    "row {i}: the range must be > 0, got {} ({range} unbiased)",
                    row[1]
                ),
            ));
        }
        let landmark = match index.get(&id) {
            Some(&j) => j,
            None => {
                let mean = map.get(&id).ok_or_else(|| {
                    SlamError::invalid(
                        "landmarks",
                        format!("landmark {id} (point row {i}) is not in the map"),
                    )
                })?;
                index.insert(id, ids.len());
                ids.push(id);
                means.push(Vector2::from(*mean));
                ids.len() - 1
            }
        };
        out.push(PointSighting {
            node,
            landmark,
            z: Vector2::new(range, bearing),
            weight: 1.0,
        });
    }
    let times: Vec<f64> = out.iter().map(|s| run.times[s.node]).collect();
    correlated_weights(&mut out, &times, ids.len(), correlation_time);
    Ok((out, ids, means))
}

/// Sets each sighting's weight to `1 / sqrt(m)`, `m` the sightings of its landmark
/// at most `window` seconds from it (itself included): two pointers over each
/// landmark's sightings in time order, O(n log n) for the sort.
fn correlated_weights(sightings: &mut [PointSighting], times: &[f64], marks: usize, window: f64) {
    if window <= 0.0 {
        return;
    }
    let mut by_mark: Vec<Vec<usize>> = vec![Vec::new(); marks];
    for (i, s) in sightings.iter().enumerate() {
        by_mark[s.landmark].push(i);
    }
    for list in &mut by_mark {
        list.sort_by(|&a, &b| times[a].total_cmp(&times[b]));
        let (mut lo, mut hi) = (0, 0);
        for k in 0..list.len() {
            let t = times[list[k]];
            while times[list[lo]] < t - window {
                lo += 1;
            }
            while hi + 1 < list.len() && times[list[hi + 1]] <= t + window {
                hi += 1;
            }
            sightings[list[k]].weight = 1.0 / ((hi - lo + 1) as f64).sqrt();
        }
    }
}

/// A point sighting's residual `h(pose, landmark) - z` (bearing wrapped), whitened by
/// the per-component `whiten = 1 / sd`, with its Jacobians (pose, landmark).
pub(super) fn point_residual(
    s: &PointSighting,
    whiten: &Vector2<f64>,
    pose: &Vector3<f64>,
    landmark: &Vector2<f64>,
) -> Result<(Vector2<f64>, Matrix2x3<f64>, Matrix2<f64>)> {
    let (h, jx, jl) = range_bearing(&Pose2::from_vector(pose), &Point2::from(*landmark))
        .ok_or_else(|| {
            SlamError::Diverged("a landmark on the position of a robot that sees it".into())
        })?;
    let e = Vector2::new(h.x - s.z.x, wrap_angle(h.y - s.z.y));
    let w = Matrix2::from_diagonal(&(whiten * s.weight));
    Ok((w * e, w * jx, w * jl))
}

/// Huber's kernel on a whitened residual of norm `norm`, threshold `k` (`None`: the
/// plain square): the cost `rho` and the square root of the iteratively reweighted
/// least-squares weight `rho' = min(1, k / norm)` that scales the residual and its
/// Jacobians in the normal equations.
pub(super) fn huber(norm: f64, k: Option<f64>) -> (f64, f64) {
    match k {
        Some(k) if norm > k => (2.0 * k * norm - k * k, (k / norm).sqrt()),
        _ => (norm * norm, 1.0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// The point residual's Jacobians against central differences.
        #[test]
        fn point_jacobians_match_central_differences(
            pose in prop::array::uniform3(-3.0..3.0f64), l in prop::array::uniform2(-5.0..5.0f64),
            z in prop::array::uniform2(0.5..4.0f64),
        ) {
            let (x, m) = (Vector3::from(pose), Vector2::from(l));
            prop_assume!((m - x.xy()).norm() > 0.3);
            let s = PointSighting { node: 0, landmark: 0, z: Vector2::from(z), weight: 0.7 };
            let w = Vector2::new(10.0, 30.0);
            let (r0, jx, jl) = point_residual(&s, &w, &x, &m).unwrap();
            // Away from the bearing's wrap, where the residual jumps.
            prop_assume!(r0.y.abs() < 0.9 * std::f64::consts::PI * w.y);
            let h = 1e-6;
            for i in 0..3 {
                let (mut p, mut q) = (x, x);
                p[i] += h;
                q[i] -= h;
                let fd = (point_residual(&s, &w, &p, &m).unwrap().0
                    - point_residual(&s, &w, &q, &m).unwrap().0) / (2.0 * h);
                prop_assert!((fd - jx.column(i)).amax() < 1e-4 * (1.0 + fd.amax()));
            }
            for i in 0..2 {
                let (mut p, mut q) = (m, m);
                p[i] += h;
                q[i] -= h;
                let fd = (point_residual(&s, &w, &x, &p).unwrap().0
                    - point_residual(&s, &w, &x, &q).unwrap().0) / (2.0 * h);
                prop_assert!((fd - jl.column(i)).amax() < 1e-4 * (1.0 + fd.amax()));
            }
        }

        /// Each weight is `1 / sqrt` of the brute-force count of the same landmark's
        /// sightings within the window, itself included.
        #[test]
        fn correlated_weights_count_the_window(
            times in prop::collection::vec(0.0..20.0f64, 1..40),
            marks in prop::collection::vec(0usize..3, 40), window in 0.0..5.0f64,
        ) {
            let mut sightings: Vec<PointSighting> = times
                .iter()
                .zip(&marks)
                .map(|(_, &m)| PointSighting { node: 0, landmark: m, z: Vector2::zeros(), weight: 1.0 })
                .collect();
            correlated_weights(&mut sightings, &times, 3, window);
            for (i, s) in sightings.iter().enumerate() {
                let m = (0..times.len())
                    .filter(|&j| marks[j] == marks[i] && (times[j] - times[i]).abs() <= window)
                    .count();
                let want = if window > 0.0 { 1.0 / (m as f64).sqrt() } else { 1.0 };
                prop_assert!((s.weight - want).abs() < 1e-12, "{} {}", s.weight, want);
            }
        }

        /// Huber's cost is the square inside the threshold, linear outside, continuous
        /// with a continuous slope at it; its weight is the slope over `2 norm`.
        #[test]
        fn huber_is_the_square_then_linear(norm in 0.0..20.0f64, k in 0.5..5.0f64) {
            let (c, w) = huber(norm, Some(k));
            prop_assert!(c <= norm * norm + 1e-12);
            if norm <= k {
                prop_assert!((c - norm * norm).abs() < 1e-12 && w == 1.0);
            } else {
                prop_assert!((c - (2.0 * k * norm - k * k)).abs() < 1e-9);
                // The IRLS weight is rho'(n) / (2 n) = k / n.
                prop_assert!((w * w - k / norm).abs() < 1e-12);
            }
            let h = 1e-7;
            let slope = (huber(k + h, Some(k)).0 - huber(k - h, Some(k)).0) / (2.0 * h);
            prop_assert!((slope - 2.0 * k).abs() < 1e-5);
            prop_assert_eq!(huber(norm, None), (norm * norm, 1.0));
        }
    }
}
