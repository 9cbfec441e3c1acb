//! From a range scan to the points ICP matches: the valid beams as points in the
//! laser frame, thinned to a minimum spacing, each with the normal of the line its
//! neighbours along the scan lie on (when they lie on one).

use nalgebra::{Matrix2, SymmetricEigen, Vector2};

use crate::error::{LaserError, Result};

/// How a scan becomes points.
#[derive(
    Debug, Clone, Copy, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema,
)]
#[serde(default, deny_unknown_fields)]
pub struct ScanConfig {
    /// Readings shorter than this are the robot itself or noise, m (>= 0).
    pub min_range: f64,
    /// Readings within this of the scan's maximum range are no-returns, m (>= 0).
    pub max_range_margin: f64,
    /// Kept points are this far apart along the scan, m (> 0), the beams' sweep at
    /// their ranges: a near wall gives many readings per centimetre and would
    /// outweigh everything else.
    pub point_spacing: f64,
    /// A point's normal is fitted to the readings within this distance of it that
    /// are contiguous along the scan, m (> 0); at least three times the wider of the
    /// beams' sweep at the point's range and the gap to its nearer neighbour (a wall
    /// seen at a slant spreads its readings wider than the sweep). Chosen by
    /// leave-one-log-out over the corpus logs on seeds 10-14, among 0.2 and 0.35.
    pub normal_radius: f64,
    /// A normal needs at least this many readings (>= 3).
    pub normal_min_points: usize,
    /// The fit's smaller spread over its larger one must stay under this for the
    /// readings to count as a line (in (0, 1)): corners and clutter get no normal.
    pub max_flatness: f64,
    /// Two successive readings further apart than this are not contiguous, m (> 0);
    /// at least as much as the normal's radius grows to (see `normal_radius`).
    pub max_gap: f64,
}

impl Default for ScanConfig {
    fn default() -> Self {
        Self {
            min_range: 0.05,
            max_range_margin: 0.01,
            point_spacing: 0.05,
            normal_radius: 0.35,
            normal_min_points: 4,
            max_flatness: 0.05,
            max_gap: 0.3,
        }
    }
}

impl ScanConfig {
    /// Refuses bad values with the parameter's name.
    pub fn validate(&self) -> Result<()> {
        rperc_core::ensure_fields(
            &[
                ("point_spacing", self.point_spacing),
                ("normal_radius", self.normal_radius),
                ("max_gap", self.max_gap),
            ],
            &[
                ("min_range", self.min_range),
                ("max_range_margin", self.max_range_margin),
            ],
        )?;
        // A neighbourhood's size: its points are gathered in a reused buffer.
        rperc_core::ensure_count("normal_min_points", self.normal_min_points, 3, 10_000, 0)?;
        if !(self.max_flatness > 0.0 && self.max_flatness < 1.0) {
            let f = self.max_flatness;
            return Err(LaserError::invalid(
                "max_flatness",
                format!("must be in (0, 1), got {f}"),
            ));
        }
        Ok(())
    }
}

/// The beams of one scan: `ranges[i]` at angle `angle_min + i * angle_increment`
/// (laser frame, radians); readings that are not finite, below `min_range` or at the
/// maximum range are no-returns.
#[derive(Debug, Clone, Copy)]
pub struct Beams<'a> {
    /// The readings, m.
    pub ranges: &'a [f64],
    /// Angle of the first beam, rad.
    pub angle_min: f64,
    /// Angle between beams, rad.
    pub angle_increment: f64,
    /// The scanner's maximum range, m.
    pub max_range: f64,
}

/// A scan's points in the laser frame: every kept point (what is matched) and, for
/// those on a line, its unit normal facing the sensor (what a map is made of).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ScanPoints {
    /// The kept points, in scan order.
    pub points: Vec<Vector2<f64>>,
    /// The unit normal of each kept point, `None` off lines (corners, clutter).
    pub normals: Vec<Option<Vector2<f64>>>,
}

impl ScanPoints {
    /// How many points have a normal.
    pub fn with_normals(&self) -> usize {
        self.normals.iter().filter(|n| n.is_some()).count()
    }

    /// The points that have a normal (lie on a line), in scan order.
    pub fn on_lines(&self) -> Vec<Vector2<f64>> {
        self.points
            .iter()
            .zip(&self.normals)
            .filter(|(_, n)| n.is_some())
            .map(|(p, _)| *p)
            .collect()
    }
}

/// The beams' unit directions, kept from scan to scan: every scan of a log usually
/// shares one geometry, and a direction's sine and cosine were a twentieth of the
/// pipeline's time. Recomputed, the same way, whenever the geometry changes.
#[derive(Debug, Clone, Default)]
pub struct BeamDirections {
    key: (u64, u64),
    directions: Vec<Vector2<f64>>,
}

impl BeamDirections {
    /// The directions of `count` beams from `angle_min` by `angle_increment`.
    fn of(&mut self, angle_min: f64, angle_increment: f64, count: usize) -> &[Vector2<f64>] {
        let key = (angle_min.to_bits(), angle_increment.to_bits());
        if key != self.key || self.directions.len() < count {
            self.key = key;
            self.directions = (0..count)
                .map(|i| {
                    let a = angle_min + i as f64 * angle_increment;
                    Vector2::new(a.cos(), a.sin())
                })
                .collect();
        }
        &self.directions[..count]
    }
}

/// The valid readings as points, in scan order.
fn raw_points(
    beams: &Beams<'_>,
    cfg: &ScanConfig,
    cache: &mut BeamDirections,
) -> Result<Vec<Vector2<f64>>> {
    let Beams {
        ranges,
        angle_min,
        angle_increment,
        max_range,
    } = *beams;
    if !(angle_min.is_finite() && angle_increment.is_finite() && angle_increment != 0.0) {
        return Err(LaserError::invalid(
            "angle_increment",
            format!(
                "the beam angles must be finite and distinct, got start {angle_min}, step {angle_increment}"
            ),
        ));
    }
    if max_range.is_nan() || max_range <= 0.0 {
        return Err(LaserError::invalid(
            "max_range",
            format!("must be > 0, got {max_range}"),
        ));
    }
    let far = max_range - cfg.max_range_margin;
    let valid = |r: f64| r.is_finite() && r >= cfg.min_range && r < far;
    let directions = cache.of(angle_min, angle_increment, ranges.len());
    Ok(ranges
        .iter()
        .zip(directions)
        .filter(|&(&r, _)| valid(r))
        .map(|(&r, d)| Vector2::new(r * d.x, r * d.y))
        .collect())
}

/// The points of a scan (see [`ScanPoints`]).
///
/// # Examples
/// ```
/// use laser::scan::{Beams, ScanConfig, scan_points};
///
/// // A wall 2 m ahead, seen by 181 beams over 180 degrees.
/// let angles: Vec<f64> = (0..181).map(|i| (i as f64 - 90.0).to_radians()).collect();
/// let ranges: Vec<f64> = angles.iter().map(|a| if a.cos() > 0.3 { 2.0 / a.cos() } else { f64::NAN }).collect();
/// let beams = Beams { ranges: &ranges, angle_min: -90f64.to_radians(), angle_increment: 1f64.to_radians(), max_range: 80.0 };
/// let scan = scan_points(&beams, &ScanConfig::default()).unwrap();
/// // Every point with a normal sees the wall face-on: normal (-1, 0).
/// for n in scan.normals.iter().flatten() {
///     assert!((n.x + 1.0).abs() < 1e-9 && n.y.abs() < 1e-6);
/// }
/// assert!(scan.with_normals() > 10);
/// ```
pub fn scan_points(beams: &Beams<'_>, cfg: &ScanConfig) -> Result<ScanPoints> {
    scan_points_with(beams, cfg, &mut BeamDirections::default())
}

/// [`scan_points`] with the beams' directions kept in `cache` across calls.
pub fn scan_points_with(
    beams: &Beams<'_>,
    cfg: &ScanConfig,
    cache: &mut BeamDirections,
) -> Result<ScanPoints> {
    let raw = raw_points(beams, cfg, cache)?;
    let step = beams.angle_increment.abs();
    let mut out = ScanPoints::default();
    // A reading is kept once the beams since the last kept one sweep `point_spacing`
    // at their ranges. The gap to the last kept point would be the exact spacing, but
    // a reading whose noise carries it away from that point would be kept more
    // often: along a wall seen at a slant, the kept points then lie off the wall by
    // a bias that changes with the slant, and scan-to-map ICP turned the same way at
    // every match (see the corridor test in tests/it/icp.rs).
    // A reading after a jump in depth starts afresh, so that a narrow object before
    // a wall keeps its first reading.
    let mut swept = f64::INFINITY;
    for (i, p) in raw.iter().enumerate() {
        let sweep = p.norm() * step;
        let jump = i > 0 && (p - raw[i - 1]).norm() > cfg.max_gap.max(3.0 * sweep);
        if swept < cfg.point_spacing && !jump {
            swept += sweep;
            continue;
        }
        swept = sweep;
        out.points.push(*p);
        out.normals.push(fit_normal(&raw, i, step, cfg));
    }
    Ok(out)
}

/// The normal of the line through the readings around `raw[i]`: those within a
/// radius of it and contiguous along the scan, fitted by the smallest eigenvector of
/// their scatter. Far from the sensor the beams spread, and along a wall seen at a
/// slant the readings spread wider still, so the radius and the gap allowed between
/// neighbours grow to three times the wider of the beams' sweep at the reading's
/// range and its gap to its nearer neighbour: without that, the far stretches of a
/// corridor's walls, which fix the heading, had no normal, and the odometry's heading
/// error leaked into every match.
fn fit_normal(raw: &[Vector2<f64>], i: usize, step: f64, cfg: &ScanConfig) -> Option<Vector2<f64>> {
    let centre = raw[i];
    let spread = 3.0 * (centre.norm() * step).max(reading_gap(raw, i));
    let (radius, gap) = (cfg.normal_radius.max(spread), cfg.max_gap.max(spread));
    let near = |j: usize| (raw[j] - centre).norm() <= radius;
    let mut lo = i;
    while lo > 0 && near(lo - 1) && (raw[lo] - raw[lo - 1]).norm() <= gap {
        lo -= 1;
    }
    let mut hi = i;
    while hi + 1 < raw.len() && near(hi + 1) && (raw[hi + 1] - raw[hi]).norm() <= gap {
        hi += 1;
    }
    let group = &raw[lo..=hi];
    if group.len() < cfg.normal_min_points {
        return None;
    }
    let mean = group.iter().sum::<Vector2<f64>>() / group.len() as f64;
    let scatter = group.iter().fold(Matrix2::zeros(), |acc, p| {
        let d = p - mean;
        acc + d * d.transpose()
    });
    let eig = SymmetricEigen::new(scatter);
    let (small, large) = if eig.eigenvalues[0] <= eig.eigenvalues[1] {
        (0, 1)
    } else {
        (1, 0)
    };
    if eig.eigenvalues[large] <= 0.0
        || eig.eigenvalues[small] > cfg.max_flatness * eig.eigenvalues[large]
    {
        return None;
    }
    let mut n: Vector2<f64> = eig.eigenvectors.column(small).into_owned();
    // Facing the sensor, so that the two sides of a thin wall stay apart.
    if n.dot(&centre) > 0.0 {
        n = -n;
    }
    Some(n.normalize())
}

/// The gap from `raw[i]` to its nearer neighbour along the scan (infinite for a lone
/// reading). Along a wall seen at a slant the readings are spread wider than the
/// beams' sweep, by one over the sine of the slant, and both gaps are wide; at a jump
/// in depth only one is.
fn reading_gap(raw: &[Vector2<f64>], i: usize) -> f64 {
    let before = i.checked_sub(1).map(|j| (raw[i] - raw[j]).norm());
    let after = raw.get(i + 1).map(|q| (q - raw[i]).norm());
    before
        .into_iter()
        .chain(after)
        .fold(f64::INFINITY, f64::min)
}

/// Checks that a scan has as many readings as it says.
pub(crate) fn check_beams(ranges: &[f64], count: usize, index: usize) -> Result<()> {
    if ranges.len() < count {
        return Err(LaserError::dimension(format!(
            "scan {index} says {count} beams but has {} readings",
            ranges.len()
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use std::f64::consts::FRAC_PI_2;

    use super::*;

    /// Readings of `segments` from the origin facing +x: 180 beams, one degree apart.
    fn seen(segments: &[crate::sim::Segment]) -> ScanPoints {
        seen_every(segments, 1.0)
    }

    /// Readings of `segments` from the origin facing +x over 180 degrees, `degrees`
    /// apart.
    fn seen_every(segments: &[crate::sim::Segment], degrees: f64) -> ScanPoints {
        let step = degrees.to_radians();
        let n = (180.0 / degrees).round() as usize;
        let angles: Vec<f64> = (0..n).map(|i| -FRAC_PI_2 + step * i as f64).collect();
        let ranges = crate::sim::ray_cast(segments, &rperc_core::Pose2::identity(), &angles, 30.0);
        let beams = Beams {
            ranges: &ranges,
            angle_min: -FRAC_PI_2,
            angle_increment: step,
            max_range: 30.0,
        };
        scan_points(&beams, &ScanConfig::default()).unwrap()
    }

    /// A corridor wall seen at a slant keeps its normal far down the corridor, where
    /// the readings are spread wider than the beams' sweep: every normal is the
    /// wall's own, and the points that have one reach past 8 m along it (with the
    /// sweep alone the radius was too small there).
    #[test]
    fn a_wall_seen_at_a_slant_has_normals_far_along_it() {
        let wall = crate::sim::Segment::new(-1.0, 1.2, 30.0, 1.2);
        let scan = seen(&[wall]);
        let mut farthest: f64 = 0.0;
        for (p, n) in scan.points.iter().zip(&scan.normals) {
            let Some(n) = n else { continue };
            assert!((p.y - 1.2).abs() < 1e-9);
            // Facing the sensor: (0, -1), to round-off.
            assert!(n.x.abs() < 1e-6 && (n.y + 1.0).abs() < 1e-9, "{p:?}: {n:?}");
            farthest = farthest.max(p.x);
        }
        assert!(farthest > 8.0, "the farthest normal is at {farthest} m");
    }

    /// The wider radius does not bridge a jump in depth: a post 1 m in front of a
    /// wall gets no normal from the wall's readings, and every normal given is the
    /// true one of the surface its point lies on.
    #[test]
    fn a_jump_in_depth_is_not_bridged() {
        let wall = crate::sim::Segment::new(4.0, -10.0, 4.0, 10.0);
        let post = crate::sim::Segment::new(3.0, -0.06, 3.0, 0.06);
        let scan = seen(&[wall, post]);
        let mut on_post = 0;
        for (p, n) in scan.points.iter().zip(&scan.normals) {
            if (p.x - 3.0).abs() < 1e-9 {
                on_post += 1;
            }
            let Some(n) = n else { continue };
            // Both face the sensor along -x.
            assert!((n.x + 1.0).abs() < 1e-9 && n.y.abs() < 1e-6, "{p:?}: {n:?}");
        }
        assert!(on_post >= 1, "the post was not seen");
    }

    /// A narrow post before a wall keeps a point wherever it stands: the thinning
    /// starts afresh after a jump in depth, so the sweep over the wall's readings
    /// cannot skip the post's few.
    #[test]
    fn a_narrow_object_before_a_wall_keeps_a_point() {
        let wall = crate::sim::Segment::new(2.5, -10.0, 2.5, 10.0);
        for degrees in [0.25, 0.5, 1.0] {
            for k in 0..25 {
                let y = -0.5 + 0.04 * k as f64;
                let post = crate::sim::Segment::new(2.0, y - 0.02, 2.0, y + 0.02);
                let scan = seen_every(&[wall, post], degrees);
                let on_post = scan.points.iter().filter(|p| (p.x - 2.0).abs() < 1e-9);
                assert!(
                    on_post.count() >= 1,
                    "post at y = {y}, {degrees} degree beams"
                );
            }
        }
    }

    /// Kept directions give exactly the points computed afresh (the oracle), through
    /// changes of start, step and beam count, and back.
    #[test]
    fn kept_directions_equal_fresh_ones() {
        let cfg = ScanConfig::default();
        let mut cache = BeamDirections::default();
        let geometries = [
            (-1.5, 0.01, 300),
            (-1.5, 0.01, 200),
            (-1.4, 0.01, 300),
            (-1.5, 0.02, 150),
            (-1.5, 0.01, 300),
        ];
        for (k, (start, step, n)) in geometries.into_iter().enumerate() {
            let ranges: Vec<f64> = (0..n)
                .map(|i| 2.0 + (i as f64 * 0.37 + k as f64).sin())
                .collect();
            let beams = Beams {
                ranges: &ranges,
                angle_min: start,
                angle_increment: step,
                max_range: 30.0,
            };
            let kept = scan_points_with(&beams, &cfg, &mut cache).unwrap();
            assert_eq!(kept, scan_points(&beams, &cfg).unwrap(), "geometry {k}");
        }
    }
}
