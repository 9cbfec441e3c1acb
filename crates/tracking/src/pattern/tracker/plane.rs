//! The tracker's homography mode: a plane in perspective.
//!
//! The particles keep searching over the seed's similarity `S = (x, y, theta, s)`,
//! but with the model seen through the projective rest `P` of the last frame's
//! homography `H = S P` ([`homography::split`]): the same eq. 6 and scale space
//! weigh a tilted pattern as well as a frontal one, and a step of the plane
//! between two frames is mostly a similarity. The estimate is then refined by
//! Gauss-Newton on all 8 parameters of `H` ([`super::warp`]), and the refined `H`
//! splits into the next frame's `S` and `P`.

use nalgebra::{Matrix3, SVector};
use rperc_core::image::GrayImage;

use super::warp::WarpSearch;
use super::{PatternTracker, corners};
use crate::error::{Result, TrackingError};
use crate::pattern::frame::PatternFrame;
use crate::pattern::homography::{self, MotionModel, apply};
use crate::pattern::layer::CoarseLayer;
use crate::pattern::model::{MIN_REGION_SIDE, PatternModel, Region};
use crate::pattern::observation::{Observation, PatternLikelihood, PointTable};

/// Gauss-Newton iterations of the homography per frame (each about two passes over
/// the profiles); it stops earlier once a step moves no corner by
/// [`WARP_TOLERANCE`].
const WARP_ITERATIONS: usize = 15;
/// Levenberg-Marquardt damping of its steps (a fraction of the diagonal), as the
/// similarity's Gauss-Newton.
const WARP_DAMPING: f64 = 0.05;
/// Pixels.
const WARP_TOLERANCE: f64 = 0.01;

/// Frame pixels between the grid's states when the whole frame is searched again
/// after a loss, in coarse pixels (the coarse layer's Gauss-Newton brings a state a
/// pixel or two off to the peak).
const GRID_STEP_COARSE: usize = 2;

/// Pixels of the rectified image around a quad's rectangle: a profile at the
/// region's edge reads half its length outside it, through the blur.
const RECTIFIED_MARGIN: usize = 16;

/// The homography mode's state.
#[derive(Debug, Clone)]
pub(super) struct PlaneState {
    /// Model offsets to the current frame.
    pub(super) homography: Matrix3<f64>,
    /// Its projective rest (`H = S P`).
    pub(super) rest: Matrix3<f64>,
    /// The model's point table as learnt, before the rest.
    base_table: PointTable,
}

/// A refined homography, not yet committed (the frame may still be lost).
pub(super) struct PlaneFit {
    pub(super) state: SVector<f64, 4>,
    pub(super) observation: Observation,
    /// The spread of the profiles' gains there (see `lost_gain_spread`).
    pub(super) gain_spread: f64,
    homography: Matrix3<f64>,
    rest: Matrix3<f64>,
    /// The similarity estimate it started from.
    before: SVector<f64, 4>,
}

impl PatternTracker {
    /// A tracker in homography mode of the plane whose four `corners` (top-left,
    /// top-right, bottom-right, bottom-left, on the outer pixel edges as
    /// [`super::PatternPose::corners`]) are seen in `frame`: the quad is rectified
    /// onto a rectangle of its mean side lengths, the pattern learnt there (section
    /// 3.2), and followed from the homography of that rectangle onto the quad.
    ///
    /// # Errors
    /// `params.motion` not `homography`, a crossed, reordered or degenerate quad, a
    /// corner outside the frame, and the errors of [`PatternTracker::new`].
    pub fn with_corners(
        frame: PatternFrame<'_>,
        corners: [[f64; 2]; 4],
        params: super::PatternTrackerParams,
        seed: u64,
    ) -> Result<Self> {
        params.validate()?;
        if params.motion != MotionModel::Homography {
            return Err(TrackingError::InvalidParameter {
                name: "region",
                reason: "four corners need motion = \"homography\": a similarity cannot map \
                         a rectangle onto a quad"
                    .into(),
            });
        }
        homography::check_quad(&corners, MIN_REGION_SIDE as f64)?;
        let mut image = GrayImage::default();
        frame.to_gray(&mut image);
        let (w, h) = (image.width as f64, image.height as f64);
        let inside =
            |p: &[f64; 2]| p[0] >= -0.5 && p[1] >= -0.5 && p[0] <= w - 0.5 && p[1] <= h - 0.5;
        if !corners.iter().all(inside) {
            return Err(TrackingError::InvalidParameter {
                name: "region",
                reason: format!("corners {corners:?} are not inside the {w}x{h} frame"),
            });
        }
        let (rectified, region, to_frame) = rectify(&image, &corners)?;
        let model = PatternModel::from_region(&rectified, region, &params.pattern)?;
        let (factor, points) = (params.coarse_factor, params.coarse_points);
        let coarse = (params.coarse_particles > 0)
            .then(|| CoarseLayer::new(&rectified, &model, factor, points))
            .flatten();
        let [cx, cy] = model.centre;
        let start = to_frame * Matrix3::new(1.0, 0.0, cx, 0.0, 1.0, cy, 0.0, 0.0, 1.0);
        let (state, _) = homography::split(&start).ok_or_else(|| degenerate(&corners))?;
        let size = [image.width, image.height];
        let mut tracker = Self::with_layer(model, size, state.into(), params, seed, coarse)?;
        tracker.start_plane(start)?;
        Ok(tracker)
    }

    /// Enters homography mode at `start` (model offsets to this frame).
    pub(super) fn start_plane(&mut self, start: Matrix3<f64>) -> Result<()> {
        let bad = || TrackingError::InvalidParameter {
            name: "region",
            reason: "the region's homography is degenerate".into(),
        };
        let (state, rest) = homography::split(&start).ok_or_else(bad)?;
        self.plane = Some(PlaneState {
            homography: start,
            rest: Matrix3::identity(),
            base_table: self.table.clone(),
        });
        if !self.set_rest(&rest) {
            return Err(bad());
        }
        if let Some(plane) = &mut self.plane {
            plane.rest = rest;
        }
        self.first_inverse = start.try_inverse().ok_or_else(bad)?;
        self.last.corners = self.corners_at(&state);
        self.last.homography = Matrix3::identity().into();
        Ok(())
    }

    /// The fine and coarse point tables seen through `rest`; `false`, nothing
    /// changed, when `rest` sends a point to infinity.
    fn set_rest(&mut self, rest: &Matrix3<f64>) -> bool {
        let Some(plane) = &self.plane else {
            return false;
        };
        let config = &self.model.config;
        let half = 0.5 * (config.n_samples as f64 - 1.0) * config.delta;
        let Some(table) = plane.base_table.warped(rest, half) else {
            return false;
        };
        if let Some(layer) = &mut self.coarse
            && !layer.set_rest(rest)
        {
            return false;
        }
        self.offsets.clear();
        self.offsets.extend(table.offsets());
        self.table = table;
        true
    }

    /// Gauss-Newton on the homography from the similarity `estimate` and the last
    /// rest; the tables are then seen through the new rest, and the observation is
    /// eq. 6 there with the refinement's occluded fraction (Tukey's zero weights).
    /// `None` when the refinement fails (the estimate then stands as it is).
    pub(super) fn fit_plane(&mut self, estimate: SVector<f64, 4>) -> Option<PlaneFit> {
        let plane = self.plane.as_ref()?;
        let start = homography::similarity(&estimate) * plane.rest;
        self.space.ensure([estimate[3], estimate[3]]);
        let search = WarpSearch {
            threshold: self.model.config.occlusion_threshold,
            iterations: WARP_ITERATIONS,
            damping: WARP_DAMPING,
            tolerance: WARP_TOLERANCE,
        };
        let fit = self.profiles.refine(&start, &self.space, &search)?;
        let quad = self.model_corners().map(|o| apply(&fit.homography, o));
        let quad = [quad[0]?, quad[1]?, quad[2]?, quad[3]?];
        homography::check_quad(&quad, 1.0).ok()?;
        let (state, rest) = homography::split(&fit.homography)?;
        if !self.set_rest(&rest) {
            return None;
        }
        let likelihood = PatternLikelihood::with_table(&self.model, &self.space, &self.table);
        let seen = likelihood.observe(&state, &mut self.scratch[0]);
        Some(PlaneFit {
            state,
            observation: Observation {
                log_likelihood: seen.log_likelihood,
                occluded_fraction: fit.occluded_fraction,
            },
            homography: fit.homography,
            gain_spread: fit.gain_spread,
            rest,
            before: estimate,
        })
    }

    /// Keeps the frame's homography unless it is `lost` (the tables go back to the
    /// last rest); the particles follow the refinement's move of the similarity.
    /// Without a fit, the similarity `estimate` moves the last rest.
    pub(super) fn commit_plane(
        &mut self,
        fit: Option<PlaneFit>,
        estimate: &SVector<f64, 4>,
        lost: bool,
    ) {
        let Some(plane) = &mut self.plane else {
            return;
        };
        match fit {
            Some(fit) if !lost => {
                plane.homography = fit.homography;
                plane.rest = fit.rest;
                // A finite move of finite particles: it cannot fail.
                let _ = self.filter.shift(&(fit.state - fit.before));
            }
            Some(_) => {
                let rest = plane.rest;
                self.set_rest(&rest);
            }
            None if !lost => plane.homography = homography::similarity(estimate) * plane.rest,
            None => {}
        }
    }

    /// The model window's outer corners, as offsets from its centre.
    fn model_corners(&self) -> [[f64; 2]; 4] {
        let (hw, hh) = (0.5 * self.model.size[0], 0.5 * self.model.size[1]);
        [[-hw, -hh], [hw, -hh], [hw, hh], [-hw, hh]]
    }

    /// The corners of the pose `state`: moved by the similarity, or in homography
    /// mode by `S P`.
    pub(super) fn corners_at(&self, state: &SVector<f64, 4>) -> [[f64; 2]; 4] {
        let Some(plane) = &self.plane else {
            return corners(&self.model, state);
        };
        let h = homography::similarity(state) * plane.rest;
        let last = self.last.corners;
        let placed = self.model_corners().map(|o| apply(&h, o));
        std::array::from_fn(|k| placed[k].unwrap_or(last[k]))
    }

    /// The homography from the first frame to the pose `state`, row-major.
    pub(super) fn pose_homography(&self, state: &SVector<f64, 4>) -> [[f64; 3]; 3] {
        let model = homography::similarity(state)
            * self.plane.as_ref().map_or(Matrix3::identity(), |p| p.rest);
        let h = model * self.first_inverse;
        let h = h / h[(2, 2)];
        std::array::from_fn(|r| std::array::from_fn(|c| h[(r, c)]))
    }
}

fn degenerate(corners: &[[f64; 2]; 4]) -> TrackingError {
    TrackingError::InvalidParameter {
        name: "region",
        reason: format!("the corners {corners:?} have no homography from a rectangle"),
    }
}

/// The states of the whole frame's search after a loss: a grid every
/// [`GRID_STEP_COARSE`] coarse pixels at the last pose's angle and scale.
pub(super) fn grid(
    [width, height]: [usize; 2],
    factor: usize,
    last: &[f64; 4],
    out: &mut Vec<SVector<f64, 4>>,
) {
    let step = (GRID_STEP_COARSE * factor).max(1);
    out.clear();
    for y in (step / 2..height).step_by(step) {
        for x in (step / 2..width).step_by(step) {
            out.push(SVector::from([x as f64, y as f64, last[2], last[3]]));
        }
    }
}

/// `image` seen through the homography of a rectangle onto `corners`: the
/// rectangle of the quad's mean side lengths with a margin of
/// [`RECTIFIED_MARGIN`] around it (bilinear; points outside the frame read its
/// nearest edge), the box of the rectangle in it, and the homography from its
/// pixels to the frame's.
fn rectify(
    image: &GrayImage,
    corners: &[[f64; 2]; 4],
) -> Result<(GrayImage, Region, Matrix3<f64>)> {
    let side =
        |a: usize, b: usize| (corners[b][0] - corners[a][0]).hypot(corners[b][1] - corners[a][1]);
    let w = (0.5 * (side(0, 1) + side(3, 2))).round().max(1.0) as usize;
    let h = (0.5 * (side(0, 3) + side(1, 2))).round().max(1.0) as usize;
    let m = RECTIFIED_MARGIN;
    let (x0, y0) = (m as f64 - 0.5, m as f64 - 0.5);
    let (x1, y1) = (x0 + w as f64, y0 + h as f64);
    let from = [[x0, y0], [x1, y0], [x1, y1], [x0, y1]];
    let to_frame = homography::from_points(&from, corners).ok_or_else(|| degenerate(corners))?;
    let (rw, rh) = (w + 2 * m, h + 2 * m);
    let (fw, fh) = (image.width as f64 - 1.0, image.height as f64 - 1.0);
    let mut data = Vec::with_capacity(rw * rh);
    for j in 0..rh {
        for i in 0..rw {
            let p = apply(&to_frame, [i as f64, j as f64]).ok_or_else(|| degenerate(corners))?;
            let (x, y) = (p[0].clamp(0.0, fw), p[1].clamp(0.0, fh));
            data.push(image.sample_bilinear(x, y).unwrap_or(0.0));
        }
    }
    let rectified = GrayImage {
        data,
        width: rw,
        height: rh,
    };
    Ok((rectified, Region::Box { x: m, y: m, w, h }, to_frame))
}
