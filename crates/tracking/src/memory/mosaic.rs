//! The mosaic of section 2.3 and the localisation of section 2.2, frame by frame:
//! several pattern trackers run at once, managed (started on new models, stopped when
//! their model leaves the view or is lost, restarted when it comes back), the robot
//! localised from every tracked model by eq. 2, and new models generated where the
//! view has room and placed by eq. 3.

use rperc_core::Pose2;
use rperc_core::image::{GrayImage, GrayView};

use super::geometry::{ImageScale, fit_pose, fuse, new_model_in_mosaic, robot_in_mosaic};
use super::keyimages::TrackedModel;
use super::salient::{ProposalParams, propose_regions};
use crate::ceiling::{CeilingCamera, correct_image};
use crate::error::{Result, TrackingError};
use crate::pattern::{
    PatternFrame, PatternModel, PatternTracker, PatternTrackerParams, Region, corners_of,
};

/// How the mosaic is built and the robot localised.
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(default, deny_unknown_fields)]
pub struct MosaicParams {
    /// Each model's tracker.
    pub tracker: PatternTrackerParams,
    /// Where new models are proposed.
    pub proposals: ProposalParams,
    /// At most this many models are tracked at once.
    pub max_tracked: usize,
    /// While mapping, new models are generated when fewer than this are tracked.
    pub min_tracked: usize,
    /// A tracker whose score falls below this is stopped (its model is lost).
    pub min_score: f64,
    /// A model is stopped when its box comes this close to the image border (pixels),
    /// and restarted when its predicted box is 3 pixels further inside.
    pub view_margin: f64,
    /// Poses in metres (`Z / f` from the camera) or, when false, in ideal-image pixels
    /// ("up to the scale factor Z/f").
    pub metric: bool,
    /// Eq. 2 takes the robot's heading from a model's rotation only when the model's
    /// rotation lever ([`rotation_lever`]) is at least this many pixels: a disc, or a
    /// small blob whose contours a rotation slides along themselves, cannot tell the
    /// heading (its position still counts).
    pub min_rotation_lever: f64,
    /// Models at least this far apart in the image (pixels) localise the robot through
    /// their positions ([`fit_pose`]) rather than each one's rotation.
    pub min_baseline: f64,
}

impl Default for MosaicParams {
    fn default() -> Self {
        Self {
            // A robot under a flat ceiling: the image scale stays 1 (a small sigma_s),
            // and it turns at most a degree or two per frame: a tighter rotation walk
            // than the seed's 3 degrees lets the filter average the rotation of a small
            // pattern over several frames.
            tracker: PatternTrackerParams {
                n_particles: 100,
                sigma: [4.0, 4.0, 1.5f64.to_radians(), 0.02],
                // The mosaic's models move little from frame to frame: a short
                // refinement from the weighted mean, which leaves the particles as
                // they are (the search of the tracker's defaults, made for steps of
                // 2-3 sigma, moved a model's pose 2.7 cm on the test ceiling).
                refine_steps: 4,
                refine_first_step: 0.25,
                refined_particle: false,
                ..PatternTrackerParams::default()
            },
            proposals: ProposalParams::default(),
            max_tracked: 4,
            min_tracked: 3,
            min_score: 0.6,
            view_margin: 2.0,
            metric: true,
            min_rotation_lever: 12.0,
            min_baseline: 40.0,
        }
    }
}

impl MosaicParams {
    /// Refuses bad values with the parameter's name.
    pub fn validate(&self) -> Result<()> {
        self.tracker.validate()?;
        self.proposals.validate()?;
        if self.max_tracked == 0 || self.min_tracked > self.max_tracked {
            return Err(TrackingError::InvalidParameter {
                name: "max_tracked",
                reason: format!(
                    "need 1 <= min_tracked <= max_tracked, got {} and {}",
                    self.min_tracked, self.max_tracked
                ),
            });
        }
        rperc_core::ensure_in_range("min_score", self.min_score, 0.0, 1.0)?;
        rperc_core::ensure_non_negative("view_margin", self.view_margin)?;
        rperc_core::ensure_non_negative("min_rotation_lever", self.min_rotation_lever)?;
        rperc_core::ensure_non_negative("min_baseline", self.min_baseline)?;
        Ok(())
    }
}

/// Pixels between the stop and the restart distances from the border, so that a model
/// at the edge of the view is not stopped and restarted on alternate frames.
const REACQUIRE_HYSTERESIS: f64 = 3.0;

/// A model of the mosaic: the learnt pattern and its pose `M T_i`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MosaicModel {
    /// Its index in the mosaic (creation order).
    pub id: usize,
    /// `M T_i`, in metres or pixels (see [`MosaicParams::metric`]).
    pub pose: Pose2,
    /// The learnt pattern (contours and grey-level profiles, section 3.2).
    pub model: PatternModel,
    /// The frame it was generated in.
    pub created: usize,
}

/// What one frame did.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FrameReport {
    /// The robot in the mosaic (eq. 2, fused over the tracked models), or the dead
    /// reckoning of the last one when no model is tracked (then `lost` is true).
    pub pose: Option<Pose2>,
    /// Every model tracked after this frame.
    pub tracked: Vec<TrackedModel>,
    /// Models generated in this frame.
    pub created: Vec<usize>,
    /// Models whose tracker was restarted in this frame.
    pub reacquired: Vec<usize>,
    /// Models whose tracker was stopped in this frame.
    pub stopped: Vec<usize>,
    /// No model is tracked: the pose (if any) is dead reckoning.
    pub lost: bool,
}

struct Track {
    id: usize,
    tracker: PatternTracker,
}

/// Builds a mosaic (mapping on) or localises against one (mapping off).
pub struct MosaicBuilder {
    camera: CeilingCamera,
    scale: ImageScale,
    params: MosaicParams,
    models: Vec<MosaicModel>,
    tracks: Vec<Track>,
    mapping: bool,
    priority: Vec<usize>,
    pose: Option<Pose2>,
    frame: usize,
    seed: u64,
    raw: GrayImage,
    ideal: GrayImage,
    bytes: Vec<u8>,
}

impl MosaicBuilder {
    /// An empty mosaic, mapping, for frames of `camera`.
    pub fn new(camera: CeilingCamera, params: MosaicParams, seed: u64) -> Result<Self> {
        camera.validate()?;
        params.validate()?;
        let metres = if params.metric {
            camera.metres_per_pixel()
        } else {
            1.0
        };
        Ok(Self {
            scale: ImageScale {
                metres_per_pixel: metres,
                principal: [camera.cx, camera.cy],
            },
            camera,
            params,
            models: Vec::new(),
            tracks: Vec::new(),
            mapping: true,
            priority: Vec::new(),
            pose: None,
            frame: 0,
            seed,
            raw: GrayImage::default(),
            ideal: GrayImage::default(),
            bytes: Vec::new(),
        })
    }

    /// Localisation against a stored mosaic (mapping off), starting from a guess of
    /// the robot's pose in it (the trackers of the models it predicts in view start
    /// there).
    pub fn localiser(
        camera: CeilingCamera,
        params: MosaicParams,
        models: Vec<MosaicModel>,
        guess: Pose2,
        seed: u64,
    ) -> Result<Self> {
        if models.is_empty() {
            return Err(TrackingError::InvalidParameter {
                name: "mosaic",
                reason: "an empty mosaic cannot localise anything".into(),
            });
        }
        let mut this = Self::new(camera, params, seed)?;
        this.models = models;
        this.mapping = false;
        this.pose = Some(guess);
        Ok(this)
    }

    /// Models to restart first when they come into view (the models of the key
    /// image being servoed to), before the others by decreasing rotation lever.
    pub fn set_priority(&mut self, ids: &[usize]) {
        self.priority = ids.to_vec();
    }

    /// The order in which models are considered for a restart.
    fn reacquire_order(&self) -> Vec<usize> {
        let mut order: Vec<usize> = (0..self.models.len()).collect();
        let lever: Vec<f64> = self
            .models
            .iter()
            .map(|m| rotation_lever(&m.model))
            .collect();
        order.sort_by(|&a, &b| {
            let (pa, pb) = (self.priority.contains(&a), self.priority.contains(&b));
            pb.cmp(&pa)
                .then(lever[b].total_cmp(&lever[a]))
                .then(a.cmp(&b))
        });
        order
    }

    /// Switches model generation on or off.
    pub fn set_mapping(&mut self, mapping: bool) {
        self.mapping = mapping;
    }

    /// The mosaic so far.
    pub fn models(&self) -> &[MosaicModel] {
        &self.models
    }

    /// The robot in the mosaic after the last frame (eq. 2), if known.
    pub fn pose(&self) -> Option<Pose2> {
        self.pose
    }

    /// The image scale (`Z / f` or 1) and principal point of the poses.
    pub fn scale(&self) -> ImageScale {
        self.scale
    }

    /// One frame of the real camera, with the odometry's motion since the last frame
    /// (robot frame, mosaic units) used only while no model is tracked.
    pub fn process(&mut self, frame: GrayView<'_>, odometry: Option<Pose2>) -> Result<FrameReport> {
        self.correct(frame)?;
        let mut report = FrameReport::default();
        self.update_tracks(&mut report)?;
        self.localise(&mut report, odometry);
        self.reacquire(&mut report)?;
        if self.mapping {
            self.generate(&mut report)?;
            if report.lost && !report.created.is_empty() {
                self.localise(&mut report, None);
            }
        }
        report.tracked = self.tracked();
        self.frame += 1;
        Ok(report)
    }

    /// Eq. 1 on the frame: the ideal image as floats (for proposals, invalid pixels
    /// -1) and as bytes (for the trackers, invalid pixels at the image's level 0).
    fn correct(&mut self, frame: GrayView<'_>) -> Result<()> {
        self.raw.set_from_gray(&frame);
        correct_image(&self.camera, &self.raw, -1.0, &mut self.ideal)?;
        self.bytes.clear();
        self.bytes.extend(
            self.ideal
                .data
                .iter()
                .map(|&g| g.round().clamp(0.0, 255.0) as u8),
        );
        Ok(())
    }

    /// Whether the ideal image shows the ceiling at `c` and `margin` pixels around it
    /// (along both axes). After eq. 1 the real frame covers a quadrilateral of the
    /// ideal image, not all of it (a camera mounted higher than the robot frame sees
    /// less of the ceiling); a model's window is in view when its corners are, the
    /// quadrilateral being convex.
    fn seen(&self, c: [f64; 2], margin: f64) -> bool {
        let (w, h) = (self.ideal.width, self.ideal.height);
        [
            (-margin, -margin),
            (margin, -margin),
            (-margin, margin),
            (margin, margin),
        ]
        .iter()
        .all(|(dx, dy)| {
            let (x, y) = ((c[0] + dx).round(), (c[1] + dy).round());
            x >= 0.0
                && y >= 0.0
                && (x as usize) < w
                && (y as usize) < h
                && self.ideal.data[y as usize * w + x as usize] >= 0.0
        })
    }

    fn view(&self) -> Result<PatternFrame<'_>> {
        let view = GrayView::new(&self.bytes, self.ideal.width, self.ideal.height)?;
        Ok(PatternFrame::Gray(view))
    }

    /// Updates every tracker; stops the lost, the weak and those leaving the view.
    fn update_tracks(&mut self, report: &mut FrameReport) -> Result<()> {
        let view = GrayView::new(&self.bytes, self.ideal.width, self.ideal.height)?;
        let margin = self.params.view_margin;
        let min_score = self.params.min_score;
        let mut kept = Vec::with_capacity(self.tracks.len());
        for mut track in std::mem::take(&mut self.tracks) {
            let pose = track.tracker.update(PatternFrame::Gray(view))?;
            let inside = pose.corners.iter().all(|c| self.seen(*c, margin));
            if pose.lost || pose.score < min_score || !inside {
                report.stopped.push(track.id);
            } else {
                kept.push(track);
            }
        }
        self.tracks = kept;
        Ok(())
    }

    /// Eq. 2 from the tracked models: with two or more spread over the image, the
    /// pose that best maps their image positions onto their mosaic positions
    /// ([`fit_pose`], weighted by score); with one, eq. 2 itself; with none, dead
    /// reckoning from the odometry.
    fn localise(&mut self, report: &mut FrameReport, odometry: Option<Pose2>) {
        let mut pairs = Vec::with_capacity(self.tracks.len());
        let mut single = Vec::with_capacity(self.tracks.len());
        for t in &self.tracks {
            let last = t.tracker.last();
            let c_t_i = self.scale.camera_to_model(last.state);
            let m_t_i = self.models[t.id].pose;
            pairs.push(([m_t_i.x, m_t_i.y], [c_t_i.x, c_t_i.y], last.score));
            single.push((robot_in_mosaic(&m_t_i, &c_t_i), last.score));
        }
        let spread = pairs
            .iter()
            .flat_map(|a| {
                pairs
                    .iter()
                    .map(move |b| (a.1[0] - b.1[0]).hypot(a.1[1] - b.1[1]))
            })
            .fold(0.0, f64::max)
            / self.scale.metres_per_pixel;
        let fitted = if spread >= self.params.min_baseline {
            fit_pose(&pairs)
        } else {
            None
        };
        let predicted = match (self.pose, odometry) {
            (Some(p), Some(d)) => Some(p.compose(&d)),
            (p, _) => p,
        };
        let estimate = fitted.or_else(|| self.single_model_pose(&single, predicted));
        report.lost = estimate.is_none();
        self.pose = estimate.or(predicted);
        report.pose = self.pose;
    }

    /// Eq. 2 from the models tracked in a small part of the image. When none of them
    /// has a rotation lever of `min_rotation_lever` pixels and the odometry predicts the
    /// heading, the heading is the prediction's and the position comes from the
    /// models' positions under it: a few pixels of contour cannot fix the heading to
    /// the degree that the odometry does over one frame.
    fn single_model_pose(
        &self,
        single: &[(Pose2, f64)],
        predicted: Option<Pose2>,
    ) -> Option<Pose2> {
        let fused = fuse(single)?;
        let strong = self
            .tracks
            .iter()
            .any(|t| rotation_lever(t.tracker.model()) >= self.params.min_rotation_lever);
        let Some(heading) = predicted.map(|p| p.theta).filter(|_| !strong) else {
            return Some(fused);
        };
        let (s, c) = heading.sin_cos();
        let positions: Vec<(Pose2, f64)> = self
            .tracks
            .iter()
            .map(|t| {
                let last = t.tracker.last();
                let c_t_i = self.scale.camera_to_model(last.state);
                let m = self.models[t.id].pose;
                let x = m.x - (c * c_t_i.x - s * c_t_i.y);
                let y = m.y - (s * c_t_i.x + c * c_t_i.y);
                (Pose2::new(x, y, heading), last.score)
            })
            .collect();
        fuse(&positions)
    }

    /// Restarts the trackers of the models predicted well inside the view.
    fn reacquire(&mut self, report: &mut FrameReport) -> Result<()> {
        let Some(pose) = self.pose else {
            return Ok(());
        };
        let (w, h, margin) = (self.ideal.width, self.ideal.height, self.params.view_margin);
        for id in self.reacquire_order() {
            if self.tracks.len() >= self.params.max_tracked {
                break;
            }
            if self.tracks.iter().any(|t| t.id == id) || report.stopped.contains(&id) {
                continue;
            }
            let model = &self.models[id].model;
            let state = self.scale.predicted_state(&pose, &self.models[id].pose);
            let corners = corners_of(model, state);
            if !corners
                .iter()
                .all(|c| self.seen(*c, margin + REACQUIRE_HYSTERESIS))
            {
                continue;
            }
            let tracker = PatternTracker::from_model(
                model.clone(),
                w,
                h,
                state,
                self.params.tracker.clone(),
                self.stream(id),
            )?;
            self.tracks.push(Track { id, tracker });
            report.reacquired.push(id);
        }
        Ok(())
    }

    /// New models where the view has room (section 2.3), placed by eq. 3 from the
    /// robot's pose; the first model defines the mosaic frame (`M T_0 = I`).
    fn generate(&mut self, report: &mut FrameReport) -> Result<()> {
        if self.tracks.len() >= self.params.min_tracked {
            return Ok(());
        }
        if !self.models.is_empty() && self.pose.is_none() {
            return Ok(()); // nothing to place new models from
        }
        // Regions already tracked, and those where a model of the mosaic is predicted:
        // a pattern seen again is the same model, not a new one.
        let mut taken: Vec<[f64; 4]> = self
            .tracks
            .iter()
            .map(|t| bounds(&t.tracker.last().corners))
            .collect();
        if let Some(pose) = self.pose {
            taken.extend(self.models.iter().map(|m| {
                let state = self.scale.predicted_state(&pose, &m.pose);
                bounds(&corners_of(&m.model, state))
            }));
        }
        let regions = propose_regions(&self.ideal, &taken, &self.params.proposals)?;
        for [x, y, w, h] in regions {
            if self.tracks.len() >= self.params.max_tracked {
                break;
            }
            let id = self.models.len();
            let tracker = match PatternTracker::new(
                self.view()?,
                Region::Box { x, y, w, h },
                self.params.tracker.clone(),
                self.stream(id),
            ) {
                Ok(t) => t,
                // A region without usable contours is simply not a model.
                Err(TrackingError::InvalidParameter { name: "region", .. }) => continue,
                Err(e) => return Err(e),
            };
            let c_t_i = self.scale.camera_to_model(tracker.last().state);
            let pose = match self.pose {
                Some(robot) => new_model_in_mosaic(&robot, &c_t_i),
                None => {
                    // M T_0 = I: the robot is where model 0 sees it.
                    self.pose = Some(c_t_i.inverse());
                    Pose2::identity()
                }
            };
            self.models.push(MosaicModel {
                id,
                pose,
                model: tracker.model().clone(),
                created: self.frame,
            });
            self.tracks.push(Track { id, tracker });
            report.created.push(id);
        }
        Ok(())
    }

    fn tracked(&self) -> Vec<TrackedModel> {
        self.tracks
            .iter()
            .map(|t| {
                let last = t.tracker.last();
                TrackedModel {
                    id: t.id,
                    state: last.state,
                    score: last.score,
                }
            })
            .collect()
    }

    /// Each model's tracker draws from its own seeded stream, restarts included.
    fn stream(&self, id: usize) -> u64 {
        self.seed
            .wrapping_mul(0x9E37_79B9_7F4A_7C15)
            .wrapping_add((id as u64) << 32 | self.frame as u64)
    }
}

/// How well a model's contours fix its rotation: the RMS, over its points, of the
/// distance (pixels) a unit rotation about the model centre moves each point across
/// its own contour (along its gradient). Zero for a disc; about a third of the side
/// for a square outline; large for a long bar.
pub fn rotation_lever(model: &PatternModel) -> f64 {
    if model.points.is_empty() {
        return 0.0;
    }
    let sum: f64 = model
        .points
        .iter()
        .map(|p| {
            let (rx, ry) = (p.x * model.size[0], p.y * model.size[1]);
            let (s, c) = p.phi.sin_cos();
            (rx * s - ry * c).powi(2)
        })
        .sum();
    (sum / model.points.len() as f64).sqrt()
}

/// The axis-aligned box `(x, y, w, h)` around four corners.
fn bounds(corners: &[[f64; 2]; 4]) -> [f64; 4] {
    let (mut x0, mut y0, mut x1, mut y1) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
    for c in corners {
        x0 = x0.min(c[0]);
        y0 = y0.min(c[1]);
        x1 = x1.max(c[0]);
        y1 = y1.max(c[1]);
    }
    [x0, y0, x1 - x0, y1 - y0]
}
