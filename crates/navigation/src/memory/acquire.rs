//! Finding the robot in a stored mosaic when its pose is known only roughly: at the
//! start of a replay (the robot believes it stands at the first key image, and it
//! stands up to 10 cm and 0.1 rad away) or after a blind stretch of dead reckoning.
//!
//! A tracker started at a model's predicted image pose searches a few pixels around
//! it (its random walk); 15 pixels off, it locks onto the nearest contour that fits,
//! and the filter that trusts it carries the error for tens of frames. Here the robot
//! pose itself is searched over the prior's box, each hypothesis scored by the joint
//! likelihood (eq. 6) of every model it predicts in view: all the models must agree
//! on one rigid pose (eq. 2), which one model on a wrong contour or a tile repeat
//! cannot fake. A grid covers the box finely enough that one of its nodes falls
//! inside the likelihood's basin (a point's deviation grows with its displacement up
//! to half a profile, about 6 pixels), and a coordinate search refines the best
//! nodes.

use nalgebra::{Matrix3, SVector};
use rayon::prelude::*;
use rperc_core::Pose2;
use rperc_core::image::GrayImage;

use super::geometry::ImageScale;
use crate::error::Result;
use tracking::pattern::{PatternLikelihood, PatternModel, PatternScratch, ScaleSpace};

/// Grid step, ideal-image pixels of the models' displacement: within the basin of
/// eq. 6's likelihood.
const GRID_STEP: f64 = 2.0;

/// The grid holds at most this many hypotheses (its steps grow beyond).
const MAX_HYPOTHESES: usize = 30_000;

/// The best grid nodes that are refined.
const REFINED: usize = 6;

/// Refinement rounds, the steps halved each round from half a grid step.
const REFINE_ROUNDS: usize = 5;

/// The robot pose the search found, and each candidate model's score there (eq. 6
/// normalised per point, as a tracker's: 1 for a perfect match).
#[derive(Debug, Clone, PartialEq)]
pub struct Found {
    /// The robot in the mosaic.
    pub pose: Pose2,
    /// Each candidate's score at `pose`, in the candidates' order.
    pub scores: Vec<f64>,
}

/// The search's view of one model: its likelihood on the frame and its pose.
struct Scored<'a> {
    likelihood: PatternLikelihood<'a>,
    pose: Pose2,
    points: usize,
}

/// Searches the robot pose over `prior` plus or minus `sigmas` standard deviations
/// of `covariance` (each axis), scoring each hypothesis by the summed log-likelihood
/// of the `candidates` (a model and its pose `M T_i`) at the image poses it predicts
/// (the inverse of eq. 2). `image` is the ideal image the trackers see. `None`
/// without candidates.
pub fn search_pose(
    image: &GrayImage,
    candidates: &[(&PatternModel, Pose2)],
    scale: &ImageScale,
    prior: &Pose2,
    covariance: &Matrix3<f64>,
    sigmas: f64,
) -> Result<Option<Found>> {
    if candidates.is_empty() {
        return Ok(None);
    }
    let half = [0, 1, 2].map(|d| sigmas * covariance[(d, d)].max(0.0).sqrt());
    let reach = candidates
        .iter()
        .map(|(model, pose)| {
            let s = scale.predicted_state(prior, pose);
            let centre = (s[0] - scale.principal[0]).hypot(s[1] - scale.principal[1]);
            centre + model.radius()
        })
        .fold(10.0, f64::max);
    let grid = Grid::new(half, scale.metres_per_pixel, reach);
    let spaces = candidates
        .iter()
        .map(|(model, pose)| space_for(image, model, pose, prior, scale, &grid))
        .collect::<Result<Vec<_>>>()?;
    let models: Vec<Scored<'_>> = candidates
        .iter()
        .zip(&spaces)
        .map(|((model, pose), space)| Scored {
            likelihood: PatternLikelihood::new(model, space),
            pose: *pose,
            points: model.points.len().max(1),
        })
        .collect();
    let score = |h: &Pose2, floor: f64, scratch: &mut PatternScratch| {
        joint_log_likelihood(&models, scale, h, floor, scratch)
    };
    let nodes = grid.best_nodes(prior, &score);
    let mut scratch = PatternScratch::default();
    let best = nodes
        .iter()
        .map(|&(v, h)| grid.refine(h, v, &score, &mut scratch))
        .max_by(|a, b| a.0.total_cmp(&b.0));
    let Some((_, pose)) = best.filter(|b| b.0.is_finite()) else {
        return Ok(None);
    };
    let scores = models
        .iter()
        .map(|m| {
            let state = SVector::from(scale.predicted_state(&pose, &m.pose));
            let ll = m.likelihood.observe(&state, &mut scratch).log_likelihood;
            let s = (ll / m.points as f64).exp();
            if s.is_finite() { s } else { 0.0 }
        })
        .collect();
    Ok(Some(Found { pose, scores }))
}

/// The candidates' summed log-likelihood at hypothesis `h`, or an upper bound of it
/// below `floor` (each model's is at most 0: every point adds a cost).
fn joint_log_likelihood(
    models: &[Scored<'_>],
    scale: &ImageScale,
    h: &Pose2,
    floor: f64,
    scratch: &mut PatternScratch,
) -> f64 {
    let mut total = 0.0;
    for m in models {
        let state = SVector::from(scale.predicted_state(h, &m.pose));
        total += m
            .likelihood
            .observe_above(&state, scratch, floor - total)
            .log_likelihood;
        if total < floor {
            break;
        }
    }
    total
}

/// The frame's scale space at scale 1 over the window a model's image pose can reach
/// from the grid's hypotheses (and the refinement's).
fn space_for(
    image: &GrayImage,
    model: &PatternModel,
    pose: &Pose2,
    prior: &Pose2,
    scale: &ImageScale,
    grid: &Grid,
) -> Result<ScaleSpace> {
    let s = scale.predicted_state(prior, pose);
    let centre = (s[0] - scale.principal[0]).hypot(s[1] - scale.principal[1]);
    let config = &model.config;
    let profile = 0.5 * config.n_samples as f64 * config.delta;
    let shift = grid.half[0].hypot(grid.half[1]) / grid.metres_per_pixel
        + centre * grid.half[2]
        + 2.0 * GRID_STEP;
    let radius = shift + model.radius() + profile + 2.0;
    let clamp = |v: f64, n: usize| v.floor().clamp(0.0, n as f64) as usize;
    let window = [
        clamp(s[0] - radius, image.width),
        clamp(s[1] - radius, image.height),
        clamp(s[0] + radius + 1.0, image.width),
        clamp(s[1] + radius + 1.0, image.height),
    ];
    let mut space = ScaleSpace::new();
    space.build_window(image, model, window, [1.0, 1.0])?;
    Ok(space)
}

/// The hypotheses: a box around the prior, `half` wide on each axis, in steps that
/// move the models by [`GRID_STEP`] pixels.
struct Grid {
    half: [f64; 3],
    step: [f64; 3],
    counts: [usize; 3],
    metres_per_pixel: f64,
}

impl Grid {
    /// `reach`: the farthest model point from the principal point (pixels), which a
    /// turn of the robot moves most.
    fn new(half: [f64; 3], metres_per_pixel: f64, reach: f64) -> Self {
        let mut step = [
            GRID_STEP * metres_per_pixel,
            GRID_STEP * metres_per_pixel,
            GRID_STEP / reach,
        ];
        let count = |h: f64, s: f64| 2 * (h / s).ceil().min(1e6) as usize + 1;
        let total = |st: &[f64; 3]| (0..3).map(|d| count(half[d], st[d])).product::<usize>();
        let n = total(&step);
        if n > MAX_HYPOTHESES {
            let grow = (n as f64 / MAX_HYPOTHESES as f64).cbrt();
            step = step.map(|s| s * grow);
        }
        while total(&step) > MAX_HYPOTHESES {
            step = step.map(|s| s * 1.1);
        }
        let counts = [0, 1, 2].map(|d| count(half[d], step[d]));
        Self {
            half,
            step,
            counts,
            metres_per_pixel,
        }
    }

    fn node(&self, prior: &Pose2, index: [usize; 3]) -> Pose2 {
        let at = |d: usize| (index[d] as f64 - ((self.counts[d] - 1) / 2) as f64) * self.step[d];
        Pose2::new(prior.x + at(0), prior.y + at(1), prior.theta + at(2))
    }

    /// The [`REFINED`] best nodes `(log-likelihood, pose)`, one heading slice per
    /// rayon task, each keeping its own best and cutting the others short.
    fn best_nodes(
        &self,
        prior: &Pose2,
        score: &(impl Fn(&Pose2, f64, &mut PatternScratch) -> f64 + Sync),
    ) -> Vec<(f64, Pose2)> {
        let [nx, ny, nt] = self.counts;
        let slices: Vec<Vec<(f64, Pose2)>> = (0..nt)
            .into_par_iter()
            .map(|t| {
                let mut scratch = PatternScratch::default();
                let mut best = Vec::with_capacity(REFINED + 1);
                for i in 0..nx {
                    for j in 0..ny {
                        let h = self.node(prior, [i, j, t]);
                        let floor = floor_of(&best);
                        let v = score(&h, floor, &mut scratch);
                        if v > floor {
                            keep(&mut best, (v, h));
                        }
                    }
                }
                best
            })
            .collect();
        let mut best = Vec::with_capacity(REFINED + 1);
        for node in slices.into_iter().flatten() {
            if node.0 > floor_of(&best) {
                keep(&mut best, node);
            }
        }
        best
    }

    /// A coordinate search from `h`: each axis moved by plus or minus a step while
    /// that raises the likelihood, the steps halved each round.
    fn refine(
        &self,
        mut h: Pose2,
        mut value: f64,
        score: &impl Fn(&Pose2, f64, &mut PatternScratch) -> f64,
        scratch: &mut PatternScratch,
    ) -> (f64, Pose2) {
        let mut step = self.step.map(|s| 0.5 * s);
        for _ in 0..REFINE_ROUNDS {
            for d in 0..3 {
                for sign in [-1.0, 1.0] {
                    let mut c = [h.x, h.y, h.theta];
                    c[d] += sign * step[d];
                    let candidate = Pose2::new(c[0], c[1], c[2]);
                    let v = score(&candidate, value, scratch);
                    if v > value {
                        (value, h) = (v, candidate);
                    }
                }
            }
            step = step.map(|s| 0.5 * s);
        }
        (value, h)
    }
}

/// The value a node must beat to enter a full list of the best.
fn floor_of(best: &[(f64, Pose2)]) -> f64 {
    if best.len() < REFINED {
        f64::NEG_INFINITY
    } else {
        best.last().map_or(f64::NEG_INFINITY, |b| b.0)
    }
}

/// Inserts `node` into `best` (sorted, best first), keeping [`REFINED`].
fn keep(best: &mut Vec<(f64, Pose2)>, node: (f64, Pose2)) {
    let at = best.partition_point(|b| b.0 >= node.0);
    best.insert(at, node);
    best.truncate(REFINED);
}
