//! The two phases of section 2.4 in the ceiling world, closed-loop: a learning run
//! drives A -> B, builds the mosaic and picks the key images; a replay starts near A
//! and servoes from key image to key image to B. The world renders each frame at the
//! true pose; the robot sees only its images (and its odometry while lost). Timings
//! cover the robot's own work (eq. 1, the trackers, eq. 2-3, the control), not the
//! rendering.

use std::time::Instant;

use rperc_core::Pose2;
use rperc_core::image::GrayView;
use rperc_core::rng::{normal, stream};

use super::keyimages::{KeyImage, KeyImageParams, LearntFrame, select_key_images};

use super::geometry::ImageScale;
use super::keyimages::TrackedModel;
use super::mosaic::{FrameReport, MosaicBuilder, MosaicCovariance, MosaicModel, MosaicParams};
use super::servo::{ServoParams, command, key_error};
use crate::ceiling::{Ceiling, CeilingCamera, CeilingParams, OdometryNoise, RenderParams, render};
use crate::error::{NavigationError, Result};

/// The world a run happens in.
#[derive(Debug, Clone, Copy)]
pub struct World<'a> {
    /// The ceiling.
    pub ceiling: &'a Ceiling,
    /// The robot's camera.
    pub camera: &'a CeilingCamera,
    /// How frames are rendered.
    pub render: &'a RenderParams,
}

impl World<'_> {
    fn frame(&self, pose: &Pose2, index: u64, out: &mut Vec<u8>) -> Result<()> {
        render(self.ceiling, self.camera, pose, self.render, index, out).map(|_| ())
    }

    fn view<'b>(&self, bytes: &'b [u8]) -> Result<GrayView<'b>> {
        Ok(GrayView::new(bytes, self.camera.width, self.camera.height)?)
    }
}

/// A ceiling world that owns its parts (a [`World`] borrows them), for programs that
/// make their own: the generated ceiling, the camera and the renderer.
#[derive(Debug, Clone)]
pub struct Scene {
    /// The ceiling.
    pub ceiling: Ceiling,
    /// The robot's camera.
    pub camera: CeilingCamera,
    /// How frames are rendered.
    pub render: RenderParams,
}

impl Scene {
    /// Generates the ceiling of `ceiling` for `camera` and `render`.
    pub fn new(
        ceiling: &CeilingParams,
        camera: CeilingCamera,
        render: RenderParams,
    ) -> Result<Self> {
        camera.validate()?;
        render.validate()?;
        Ok(Self {
            ceiling: Ceiling::generate(ceiling)?,
            camera,
            render,
        })
    }

    /// The world the runs take.
    pub fn world(&self) -> World<'_> {
        World {
            ceiling: &self.ceiling,
            camera: &self.camera,
            render: &self.render,
        }
    }
}

/// A visual memory: the mosaic and the key images of one learnt path, stored
/// together (serialisable: JSON through serde).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct VisualMemory {
    /// The mosaic's models with their poses.
    pub models: Vec<MosaicModel>,
    /// The key images from A to B.
    pub key_images: Vec<KeyImage>,
    /// `(width, height)` of the images it was learnt from.
    pub image_size: [usize; 2],
    /// The joint covariance of the models placed after model 0 (their errors are
    /// correlated: they come from one learning run); absent in older memories, whose
    /// models then count as independent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mosaic_covariance: Option<MosaicCovariance>,
}

impl VisualMemory {
    /// Refuses a memory whose key images name models its mosaic does not hold (a
    /// memory paired with another mosaic), an empty mosaic or chain, or models learnt
    /// on images of another size than `camera`'s.
    pub fn validate(&self, camera: &CeilingCamera) -> Result<()> {
        let invalid = |name, reason: String| NavigationError::InvalidParameter { name, reason };
        if self.models.is_empty() {
            return Err(invalid("mosaic", "the mosaic is empty".into()));
        }
        if self.key_images.is_empty() {
            return Err(invalid(
                "key_images",
                "the memory holds no key image".into(),
            ));
        }
        for (k, key) in self.key_images.iter().enumerate() {
            if let Some(m) = key.models.iter().find(|m| m.id >= self.models.len()) {
                return Err(invalid(
                    "key_images",
                    format!(
                        "key image {k} names model {} but the mosaic holds {}: the memory \
                         belongs to another mosaic",
                        m.id,
                        self.models.len()
                    ),
                ));
            }
        }
        for m in &self.models {
            check_model(m)?;
        }
        for (k, key) in self.key_images.iter().enumerate() {
            let pose = [key.pose.x, key.pose.y, key.pose.theta];
            let states = key.models.iter().flat_map(|m| m.state);
            if !pose.iter().copied().chain(states).all(f64::is_finite)
                || key.models.iter().any(|m| m.state[3] <= 0.0)
            {
                return Err(invalid(
                    "key_images",
                    format!("key image {k} holds a non-finite pose or state, or a scale <= 0"),
                ));
            }
        }
        if let Some(c) = &self.mosaic_covariance {
            c.matrix(self.models.len())?;
        }
        if self.image_size != [camera.width, camera.height] {
            return Err(invalid(
                "camera",
                format!(
                    "the memory was learnt on {}x{} images, the camera takes {}x{}",
                    self.image_size[0], self.image_size[1], camera.width, camera.height
                ),
            ));
        }
        Ok(())
    }
}

/// Refuses a stored model that no learning run makes (a hand-edited or damaged
/// file): a pose or covariance that is not finite, a window that is not a positive
/// size, points outside their window or whose vectors are not of the configured
/// length, or a configuration its own checks refuse.
fn check_model(m: &MosaicModel) -> Result<()> {
    let invalid = |reason: String| NavigationError::InvalidParameter {
        name: "models",
        reason: format!("model {}: {reason}", m.id),
    };
    let model = &m.model;
    model
        .config
        .validate()
        .map_err(|e| invalid(format!("its configuration: {e}")))?;
    let pose = [m.pose.x, m.pose.y, m.pose.theta];
    if !pose
        .iter()
        .chain(m.covariance.iter().flatten())
        .all(|v| v.is_finite())
    {
        return Err(invalid("a pose or covariance that is not finite".into()));
    }
    let window_ok = model.centre.iter().all(|v| v.is_finite())
        && model
            .size
            .iter()
            .all(|v| v.is_finite() && *v > 0.0 && *v < 1e6);
    if !window_ok {
        return Err(invalid(format!(
            "window centre {:?} size {:?}",
            model.centre, model.size
        )));
    }
    let n = model.config.n_samples;
    let point_ok = |p: &tracking::pattern::ModelPoint| {
        p.x.abs() <= 1.0
            && p.y.abs() <= 1.0
            && p.phi.is_finite()
            && p.slope.is_finite()
            && p.vector.len() == n
            && p.vector.iter().all(|v| v.is_finite())
    };
    if let Some(j) = model.points.iter().position(|p| !point_ok(p)) {
        return Err(invalid(format!(
            "point {j} lies outside its window, or its vector is not {n} finite values"
        )));
    }
    Ok(())
}

/// What a learning run produced.
#[derive(Debug, Clone)]
pub struct Learning {
    /// The memory.
    pub memory: VisualMemory,
    /// Each frame's report.
    pub reports: Vec<FrameReport>,
    /// The true pose of each frame.
    pub truth: Vec<Pose2>,
    /// The robot's processing time of each frame, seconds.
    pub seconds: Vec<f64>,
}

impl Learning {
    /// Model `id`'s true frame in the world, the frame its mosaic pose is scored
    /// against: the true robot at the model's creation times its window's image
    /// pose there (`C T_i` of the window centre, no turn: the model's frame is
    /// defined by that window). `None` for no such model.
    pub fn model_in_world(&self, id: usize, camera: &CeilingCamera) -> Option<Pose2> {
        let m = self.memory.models.get(id)?;
        let scale = ImageScale {
            metres_per_pixel: camera.metres_per_pixel(),
            principal: [camera.cx, camera.cy],
        };
        let c_t_i = scale.camera_to_model([m.model.centre[0], m.model.centre[1], 0.0, 1.0]);
        Some(self.truth.get(m.created)?.compose(&c_t_i))
    }

    /// The mosaic frame in the world (model 0's true frame): what maps a pose in the
    /// mosaic to the world, to score it against the truth.
    pub fn mosaic_in_world(&self, camera: &CeilingCamera) -> Option<Pose2> {
        self.model_in_world(0, camera)
    }
}

/// How a learning run goes.
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct LearnParams {
    /// Mosaic building.
    pub mosaic: MosaicParams,
    /// Key image selection.
    pub keys: KeyImageParams,
    /// How the odometry errs (the robot drives the commands exactly; its odometry
    /// reads them with these errors).
    pub odometry: OdometryNoise,
    /// The stored mosaic's covariance (each model's and the joint one) is the
    /// mapping filter's times this: the filter counts a tracker's successive states
    /// as independent, but a tracker's error lasts while it tracks (its frame-to-frame
    /// correlation is 0.65, still 0.38 ten frames apart), and the mosaic it builds is
    /// that much less certain than it claims.
    pub covariance_scale: f64,
}

impl Default for LearnParams {
    fn default() -> Self {
        Self {
            mosaic: MosaicParams::default(),
            keys: KeyImageParams::default(),
            odometry: OdometryNoise::default(),
            covariance_scale: 1.0,
        }
    }
}

impl LearnParams {
    /// Refuses bad values with the parameter's name.
    pub fn validate(&self) -> Result<()> {
        self.mosaic.validate()?;
        self.keys.validate()?;
        self.odometry.validate()?;
        rperc_core::ensure_in_range("covariance_scale", self.covariance_scale, 1.0, 1e6)?;
        Ok(())
    }
}

/// Drives `commands` (`(v, omega)` held `dt` s each) from `start`, building the mosaic
/// from the images (and the odometry, for the heading while only a small model is in
/// view), then picks the key images.
pub fn learn(
    world: World<'_>,
    start: Pose2,
    commands: &[[f64; 2]],
    dt: f64,
    params: &LearnParams,
    seed: u64,
) -> Result<Learning> {
    params.validate()?;
    let drive = crate::ceiling::drive(start, commands, dt, &params.odometry)?;
    let mut builder = MosaicBuilder::new(*world.camera, params.mosaic.clone(), seed)?;
    let (mut reports, mut seconds) = (Vec::new(), Vec::new());
    let mut bytes = Vec::new();
    for (k, pose) in drive.truth.iter().enumerate() {
        rperc_core::interrupt::checkpoint()?;
        world.frame(pose, k as u64, &mut bytes)?;
        let odometry = k
            .checked_sub(1)
            .map(|j| Pose2::identity().advance(drive.measured[j][0], drive.measured[j][1], dt));
        let clock = Instant::now();
        let report = builder.process(world.view(&bytes)?, odometry)?;
        seconds.push(clock.elapsed().as_secs_f64());
        reports.push(report);
    }
    let truth = drive.truth;
    let frames: Vec<LearntFrame> = reports
        .iter()
        .enumerate()
        .map(|(frame, r)| LearntFrame {
            frame,
            models: r.tracked.clone(),
            pose: if r.lost { None } else { r.pose },
        })
        .collect();
    let key_images = select_key_images(&frames, &params.keys, builder.scale().metres_per_pixel)?;
    let k = params.covariance_scale;
    let mut models = builder.models().to_vec();
    for m in &mut models {
        m.covariance = m.covariance.map(|row| row.map(|v| k * v));
    }
    let mut mosaic_covariance = builder.map_covariance();
    if let Some(c) = mosaic_covariance.as_mut() {
        c.matrix.iter_mut().for_each(|v| *v *= k);
    }
    Ok(Learning {
        memory: VisualMemory {
            models,
            key_images,
            image_size: [world.camera.width, world.camera.height],
            mosaic_covariance,
        },
        reports,
        truth,
        seconds,
    })
}

/// How a replay runs.
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct ReplayParams {
    /// The localiser (tracker parameters; mapping is off).
    pub mosaic: MosaicParams,
    /// The servoing law.
    pub servo: ServoParams,
    /// Control period, seconds (one frame per period).
    pub dt: f64,
    /// The replay gives up after this many frames.
    pub max_frames: usize,
    /// The robot gives up after this many frames in a row without a model shared with
    /// its current key image.
    pub max_blind_frames: usize,
    /// Metres per ideal-image pixel the controller assumes to turn its pixel commands
    /// into wheel speeds (a gain: any rough value of `Z / f` will do).
    pub metres_per_pixel: f64,
    /// How the wheels err: the true motion is the command with these scale errors and
    /// noise; the odometry reads the command.
    pub actuation: OdometryNoise,
}

impl Default for ReplayParams {
    fn default() -> Self {
        Self {
            mosaic: MosaicParams::default(),
            servo: ServoParams::default(),
            dt: 0.1,
            max_frames: 1500,
            max_blind_frames: 20,
            metres_per_pixel: 0.015,
            actuation: OdometryNoise::default(),
        }
    }
}

impl ReplayParams {
    /// Refuses bad values with the parameter's name.
    pub fn validate(&self) -> Result<()> {
        self.mosaic.validate()?;
        self.servo.validate()?;
        self.actuation.validate()?;
        rperc_core::ensure_positive("dt", self.dt)?;
        rperc_core::ensure_positive("metres_per_pixel", self.metres_per_pixel)?;
        if self.max_frames == 0 {
            return Err(NavigationError::InvalidParameter {
                name: "max_frames",
                reason: "must be >= 1".into(),
            });
        }
        // Every frame keeps its report (pose, covariance, tracked models): refused
        // up front rather than growing towards an abort (issue 38).
        rperc_core::check_allocation("max_frames", self.max_frames as u128, 1024)?;
        Ok(())
    }
}

/// How a replay ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ReplayOutcome {
    /// The last key image was reached.
    Reached,
    /// No model shared with the current key image for too long: every model lost.
    Lost,
    /// `max_frames` ran out.
    TimedOut,
}

/// A replay: the true and estimated paths, the key image followed at each frame.
#[derive(Debug, Clone)]
pub struct Replay {
    /// How it ended.
    pub outcome: ReplayOutcome,
    /// True pose at each frame.
    pub truth: Vec<Pose2>,
    /// Each frame's report (its pose is eq. 2's estimate in the mosaic).
    pub reports: Vec<FrameReport>,
    /// The key image being servoed to at each frame.
    pub key_index: Vec<usize>,
    /// Processing time of each frame (localisation and control), seconds.
    pub seconds: Vec<f64>,
}

/// Replays `memory` from the true pose `start`, the robot believing it starts at the
/// first key image.
pub fn replay(
    world: World<'_>,
    memory: &VisualMemory,
    start: Pose2,
    params: &ReplayParams,
    seed: u64,
) -> Result<Replay> {
    params.validate()?;
    memory.validate(world.camera)?;
    let keys = &memory.key_images;
    let mut localiser = replay_localiser(world, memory, params, seed)?;
    let principal = [world.camera.cx, world.camera.cy];
    let mut rng = stream(params.actuation.seed, 7);
    let mut out = Replay {
        outcome: ReplayOutcome::TimedOut,
        truth: Vec::new(),
        reports: Vec::new(),
        key_index: Vec::new(),
        seconds: Vec::new(),
    };
    let (mut pose, mut k, mut blind, mut last_command) =
        (start, 1.min(keys.len() - 1), 0, (0.0, 0.0));
    let mut bytes = Vec::new();
    for frame in 0..params.max_frames {
        rperc_core::interrupt::checkpoint()?;
        world.frame(&pose, frame as u64, &mut bytes)?;
        let clock = Instant::now();
        let odometry = Pose2::identity().advance(last_command.0, last_command.1, params.dt);
        let wanted: Vec<usize> = keys[k].models.iter().map(|m| m.id).collect();
        localiser.set_priority(&wanted);
        let report = localiser.process(world.view(&bytes)?, Some(odometry))?;
        let units_per_pixel = localiser.scale().metres_per_pixel;
        let step = next_command(
            &report,
            keys,
            &mut k,
            principal,
            units_per_pixel,
            &params.servo,
        );
        out.seconds.push(clock.elapsed().as_secs_f64());
        out.truth.push(pose);
        out.reports.push(report);
        out.key_index.push(k);
        let (v_px, omega) = match step.command(&mut blind, params.max_blind_frames) {
            Ok(command) => command,
            Err(outcome) => {
                out.outcome = outcome;
                break;
            }
        };
        let v = v_px * params.metres_per_pixel;
        last_command = (v, omega);
        pose = actuate(&pose, v, omega, params, &mut rng);
    }
    Ok(out)
}

/// The localiser of a replay: the stored mosaic (rigid, with its covariance), the
/// robot believed at the first key image.
fn replay_localiser(
    world: World<'_>,
    memory: &VisualMemory,
    params: &ReplayParams,
    seed: u64,
) -> Result<MosaicBuilder> {
    let first = memory
        .key_images
        .first()
        .ok_or_else(|| NavigationError::InvalidParameter {
            name: "key_images",
            reason: "the memory holds no key image".into(),
        })?;
    let mut localiser = MosaicBuilder::localiser(
        *world.camera,
        params.mosaic.clone(),
        memory.models.clone(),
        first.pose,
        seed,
    )?;
    if let Some(c) = &memory.mosaic_covariance {
        localiser.set_map_covariance(&c.ids, &c.matrix(memory.models.len())?);
    }
    Ok(localiser)
}

enum Step {
    Reached,
    /// No model of the key image in view: the command from the localisation alone.
    Blind(f64, f64),
    Drive(f64, f64),
}

impl Step {
    /// The command `(v px/s, omega)` to drive, or how the replay ends: reached, or
    /// lost after more than `max_blind` frames in a row without a shared model.
    fn command(
        self,
        blind: &mut usize,
        max_blind: usize,
    ) -> std::result::Result<(f64, f64), ReplayOutcome> {
        match self {
            Step::Reached => Err(ReplayOutcome::Reached),
            Step::Blind(v, w) => {
                *blind += 1;
                if *blind > max_blind {
                    Err(ReplayOutcome::Lost)
                } else {
                    Ok((v, w))
                }
            }
            Step::Drive(v, w) => {
                *blind = 0;
                Ok((v, w))
            }
        }
    }
}

/// The servoing command of this frame, passing intermediate key images whose error
/// fell under the switching threshold. With no model of the key image in view, the
/// robot drives towards the key image's pose in the mosaic from its localisation
/// (other models, or dead reckoning for a few frames) so that the key image's
/// models come into view, and counts the frame as blind.
fn next_command(
    report: &FrameReport,
    keys: &[KeyImage],
    k: &mut usize,
    principal: [f64; 2],
    units_per_pixel: f64,
    servo: &ServoParams,
) -> Step {
    // The one lost rule (issue 38): a lost frame (no model's image pose accepted by
    // the localisation, `FrameReport::lost`) sees no key image. Its trackers may still
    // follow something, but nothing vouches that it is the model: measured from them,
    // replays started 100 m off, kidnapped, or in another world reported 'reached'
    // with every frame lost.
    let seen: &[TrackedModel] = if report.lost { &[] } else { &report.tracked };
    loop {
        let key = &keys[*k];
        let turn = report
            .pose
            .filter(|_| !report.lost)
            .map(|p| key.pose.theta - p.theta);
        let Some(error) = key_error(seen, key, principal, turn) else {
            return match report.pose {
                Some(p) => {
                    let e = p.between(&key.pose);
                    let pixels = Pose2::new(e.x / units_per_pixel, e.y / units_per_pixel, e.theta);
                    let (v, w) = command(&pixels, servo);
                    Step::Blind(v, w)
                }
                None => Step::Blind(0.0, 0.0),
            };
        };
        let distance = error.x.hypot(error.y);
        let last = *k + 1 == keys.len();
        if last && distance < servo.final_error {
            return Step::Reached;
        }
        if !last && distance < servo.switch_error {
            *k += 1;
            continue;
        }
        let (v, w) = command(&error, servo);
        return Step::Drive(v, w);
    }
}

/// The true motion under a command: scale errors and white noise on each wheel rate.
fn actuate<R: rand::Rng>(pose: &Pose2, v: f64, omega: f64, p: &ReplayParams, rng: &mut R) -> Pose2 {
    let a = &p.actuation;
    // A robot standing still does not drift.
    if v == 0.0 && omega == 0.0 {
        return *pose;
    }
    let tv = v * (1.0 + a.speed_scale_error) + a.speed_sigma * normal(rng);
    let tw = omega * (1.0 + a.turn_scale_error) + a.turn_sigma * normal(rng);
    pose.advance(tv, tw, p.dt)
}
