//! The ceiling world of the visual memory (second seed, section 2): conversion only.

use navigation::ceiling::{
    Ceiling, CeilingCamera, CeilingParams, OdometryNoise, RenderParams, RenderTruth,
};
use numpy::IntoPyArray;
use numpy::PyArrayDyn;
use pyo3::prelude::*;
use rperc_core::Pose2;

use crate::arrays::shaped;
use crate::errors::{Error, detached, detached_parallel};

/// Rows `(x, y, theta)` of an `(n, 3)` float array as poses.
pub(crate) fn poses(obj: &Bound<'_, PyAny>, name: &str) -> Result<Vec<Pose2>, Error> {
    let (shape, data) = crate::arrays::tensor(obj, name, 2)?;
    if shape[1] != 3 {
        return Err(Error::Value(format!(
            "{name} must have shape (n, 3) rows (x, y, theta), got {shape:?}"
        )));
    }
    if let Some(bad) = data.iter().position(|v| !v.is_finite()) {
        return Err(Error::Value(format!(
            "{name} row {} holds a non-finite value",
            bad / 3
        )));
    }
    Ok(data
        .chunks_exact(3)
        .map(|r| Pose2::new(r[0], r[1], r[2]))
        .collect())
}

/// Rows of an `(n, 2)` float array.
pub(crate) fn pairs(obj: &Bound<'_, PyAny>, name: &str) -> Result<Vec<[f64; 2]>, Error> {
    let (shape, data) = crate::arrays::tensor(obj, name, 2)?;
    if shape[1] != 2 {
        return Err(Error::Value(format!(
            "{name} must have shape (n, 2), got {shape:?}"
        )));
    }
    Ok(data.chunks_exact(2).map(|r| [r[0], r[1]]).collect())
}

pub(crate) fn pose_rows(poses: &[Pose2]) -> Vec<f64> {
    poses.iter().flat_map(|p| [p.x, p.y, p.theta]).collect()
}

/// A ceiling, its camera and the rendering effects: the world a visual memory runs in.
#[pyclass(name = "CeilingWorld", module = "rperc._rperc", frozen)]
pub struct PyCeilingWorld {
    pub(crate) ceiling: Ceiling,
    pub(crate) camera: CeilingCamera,
    pub(crate) render: RenderParams,
}

/// Three float arrays.
type Arrays3<'py> = (
    Bound<'py, PyArrayDyn<f64>>,
    Bound<'py, PyArrayDyn<f64>>,
    Bound<'py, PyArrayDyn<f64>>,
);

/// `(kinds, centres (n, 2), theta (n,))`.
type Patterns<'py> = (
    Vec<String>,
    Bound<'py, PyArrayDyn<f64>>,
    Bound<'py, PyArrayDyn<f64>>,
);

/// `(frames (n, H, W) uint8, lighting (n, 2), occluders (n, 3) with NaN rows where a
/// frame has none)`.
type Rendered<'py> = (
    Bound<'py, PyArrayDyn<u8>>,
    Bound<'py, PyArrayDyn<f64>>,
    Bound<'py, PyArrayDyn<f64>>,
);

#[pymethods]
impl PyCeilingWorld {
    /// Each config is a dict of the Rust struct's fields (`rperc.config`'s
    /// `CeilingConfig`, `CeilingCameraConfig`, `CeilingRenderConfig`).
    #[new]
    #[pyo3(signature = (ceiling = None, camera = None, render = None))]
    fn new(
        py: Python<'_>,
        ceiling: Option<&Bound<'_, PyAny>>,
        camera: Option<&Bound<'_, PyAny>>,
        render: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let params: CeilingParams = crate::config::from_python(ceiling, "ceiling")?;
        let camera: CeilingCamera = crate::config::from_python(camera, "camera")?;
        let render: RenderParams = crate::config::from_python(render, "render")?;
        camera.validate().map_err(Error::from)?;
        render.validate().map_err(Error::from)?;
        let ceiling = detached(py, || Ok(Ceiling::generate(&params)?))?;
        Ok(Self {
            ceiling,
            camera,
            render,
        })
    }

    /// Renders frame `first_frame + k` at `poses[k]` (GIL released, frames in parallel).
    #[pyo3(signature = (poses, first_frame = 0))]
    fn render<'py>(
        &self,
        py: Python<'py>,
        poses: &Bound<'py, PyAny>,
        first_frame: u64,
    ) -> PyResult<Rendered<'py>> {
        let poses = self::poses(poses, "poses")?;
        let (frames, truths) = detached_parallel(py, || {
            Ok(navigation::ceiling::render_sequence(
                &self.ceiling,
                &self.camera,
                &poses,
                &self.render,
                first_frame,
            )?)
        })?;
        let n = poses.len();
        let shape = [n, self.camera.height, self.camera.width];
        let frames = numpy::ndarray::ArrayD::from_shape_vec(numpy::ndarray::IxDyn(&shape), frames)
            .map_err(|e| Error::Value(format!("internal shape error: {e}")))?;
        let lighting = truths
            .iter()
            .flat_map(|t: &RenderTruth| t.lighting)
            .collect();
        let occluders = truths
            .iter()
            .flat_map(|t| t.occluder.unwrap_or([f64::NAN; 3]))
            .collect();
        Ok((
            frames.into_pyarray(py),
            shaped(py, lighting, &[n, 2])?,
            shaped(py, occluders, &[n, 3])?,
        ))
    }

    /// Where the real camera sees ceiling points `xy` (n, 2) from `pose` (3,), pixels;
    /// NaN rows behind the camera.
    fn project<'py>(
        &self,
        py: Python<'py>,
        pose: &Bound<'py, PyAny>,
        xy: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        let pose = one_pose(pose, "pose")?;
        let points = pairs(xy, "xy")?;
        let uv: Vec<f64> = points
            .iter()
            .flat_map(|&p| self.camera.project(&pose, p).unwrap_or([f64::NAN; 2]))
            .collect();
        Ok(shaped(py, uv, &[points.len(), 2])?)
    }

    /// The camera's 3x3 matrices: `(K, C_H_R of eq. 1, its inverse the correction,
    /// pixel_to_world at pose)`.
    fn matrices<'py>(
        &self,
        py: Python<'py>,
        pose: &Bound<'py, PyAny>,
    ) -> PyResult<Vec<Bound<'py, PyArrayDyn<f64>>>> {
        let pose = one_pose(pose, "pose")?;
        let c = &self.camera;
        let list = [
            c.intrinsics(),
            c.robot_to_camera_homography(),
            c.correction_homography().map_err(Error::from)?,
            c.pixel_to_world(&pose).map_err(Error::from)?,
        ];
        list.iter()
            .map(|m| Ok(shaped(py, m.transpose().as_slice().to_vec(), &[3, 3])?))
            .collect()
    }

    /// The ceiling texture (rows along world y), float32 grey levels.
    fn texture<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        let t = &self.ceiling.texture;
        numpy::ndarray::ArrayD::from_shape_vec(
            numpy::ndarray::IxDyn(&[t.height, t.width]),
            t.data.clone(),
        )
        .map(|a| a.into_pyarray(py))
        .map_err(|e| Error::Value(format!("internal shape error: {e}")).into())
    }

    /// Metres per texel of `texture()`.
    #[getter]
    fn resolution(&self) -> f64 {
        self.ceiling.resolution
    }

    /// The true patterns: `(kinds, centres (n, 2), theta (n,))`.
    fn patterns<'py>(&self, py: Python<'py>) -> PyResult<Patterns<'py>> {
        let p = &self.ceiling.patterns;
        let kinds = p.iter().map(|q| q.kind.name().to_owned()).collect();
        let centres = p.iter().flat_map(|q| q.centre).collect();
        let theta = p.iter().map(|q| q.theta).collect();
        Ok((
            kinds,
            shaped(py, centres, &[p.len(), 2])?,
            shaped(py, theta, &[p.len()])?,
        ))
    }
}

/// One pose `(x, y, theta)`, refused by `name` unless it is 3 finite values.
pub(crate) fn one_pose(obj: &Bound<'_, PyAny>, name: &str) -> Result<Pose2, Error> {
    let v = crate::arrays::float_vector(obj, name)?;
    if v.len() != 3 || !v.iter().all(|x| x.is_finite()) {
        // The values only when there are three: never a whole array in a message.
        let got = if v.len() == 3 {
            format!("{v:?}")
        } else {
            format!("{} values", v.len())
        };
        return Err(Error::Value(format!(
            "{name} must be 3 finite values (x, y, theta), got {got}"
        )));
    }
    // The core's rule; the message names this argument (`start`, `pose`).
    if let Err(rperc_core::CoreError::InvalidParameter { reason, .. }) =
        rperc_core::ensure_coordinates("pose", &v[..2])
    {
        return Err(Error::Value(format!("{name}: {reason}")));
    }
    Ok(Pose2::new(v[0], v[1], v[2]))
}

/// The robot driven by `commands` (n, 2) `(v, omega)` from `start` (3,): `(truth (n+1,
/// 3), odometry (n+1, 3), measured (n, 2))`.
#[pyfunction]
#[pyo3(signature = (start, commands, dt, noise = None))]
pub fn ceiling_drive<'py>(
    py: Python<'py>,
    start: &Bound<'py, PyAny>,
    commands: &Bound<'py, PyAny>,
    dt: f64,
    noise: Option<&Bound<'py, PyAny>>,
) -> PyResult<Arrays3<'py>> {
    let noise: OdometryNoise = crate::config::from_python(noise, "noise")?;
    let start = one_pose(start, "start")?;
    let commands = pairs(commands, "commands")?;
    let run = detached(py, || {
        Ok(navigation::ceiling::drive(start, &commands, dt, &noise)?)
    })?;
    let n = commands.len();
    Ok((
        shaped(py, pose_rows(&run.truth), &[n + 1, 3])?,
        shaped(py, pose_rows(&run.odometry), &[n + 1, 3])?,
        shaped(py, run.measured.into_iter().flatten().collect(), &[n, 2])?,
    ))
}
