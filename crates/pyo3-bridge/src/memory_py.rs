//! The visual memory (second seed, section 2): learning and replay runs in a ceiling
//! world, the memory exchanged as JSON. Conversion only.

use navigation::memory::{FrameReport, LearnParams, ReplayParams, VisualMemory, World};
use numpy::{IntoPyArray, PyArray1, PyArrayDyn};
use pyo3::prelude::*;
use rperc_core::Pose2;

use crate::arrays::{frozen_array, read_only};
use crate::ceiling_py::{PyCeilingWorld, one_pose, pairs, pose_rows};
use crate::errors::{Error, detached};

/// Per-frame arrays of a run, frozen, read-only: `truth` (n, 3) and `pose` (n, 3,
/// NaN where unknown), `lost` (n,), the models `tracked` (n,), the robot's processing
/// `seconds` (n,) and the `covariance` (n, 3, 3) of `pose` (NaN where unknown).
#[pyclass(name = "MemoryFrames", module = "rperc._rperc", frozen, get_all)]
pub struct PyMemoryFrames {
    truth: Py<PyArrayDyn<f64>>,
    pose: Py<PyArrayDyn<f64>>,
    lost: Py<PyArray1<bool>>,
    tracked: Py<PyArray1<i64>>,
    seconds: Py<PyArrayDyn<f64>>,
    covariance: Py<PyArrayDyn<f64>>,
}

/// A learning run ([`visual_memory_learn`]), frozen: the `memory` (JSON) and its
/// `frames`.
#[pyclass(name = "MemoryLearning", module = "rperc._rperc", frozen, get_all)]
pub struct PyMemoryLearning {
    memory: String,
    frames: Py<PyMemoryFrames>,
}

/// A replay ([`visual_memory_replay`]), frozen: its `outcome` (`reached`, `lost` or
/// `timed_out`), the key image followed at each frame `key_index` (n,) and the
/// `frames`.
#[pyclass(name = "MemoryReplay", module = "rperc._rperc", frozen, get_all)]
pub struct PyMemoryReplay {
    outcome: String,
    key_index: Py<PyArray1<i64>>,
    frames: Py<PyMemoryFrames>,
}

fn world(w: &PyCeilingWorld) -> World<'_> {
    World {
        ceiling: &w.ceiling,
        camera: &w.camera,
        render: &w.render,
    }
}

fn frames(
    py: Python<'_>,
    truth: &[Pose2],
    reports: &[FrameReport],
    seconds: Vec<f64>,
) -> PyResult<Py<PyMemoryFrames>> {
    let n = truth.len();
    let pose: Vec<f64> = reports
        .iter()
        .flat_map(|r| r.pose.map_or([f64::NAN; 3], |p| [p.x, p.y, p.theta]))
        .collect();
    let lost: Vec<bool> = reports.iter().map(|r| r.lost).collect();
    let tracked: Vec<i64> = reports.iter().map(|r| r.tracked.len() as i64).collect();
    let covariance: Vec<f64> = reports
        .iter()
        .flat_map(|r| r.covariance.map_or([[f64::NAN; 3]; 3], |c| c))
        .flatten()
        .collect();
    let frames = PyMemoryFrames {
        truth: frozen_array(py, pose_rows(truth), &[n, 3])?,
        pose: frozen_array(py, pose, &[n, 3])?,
        lost: read_only(lost.into_pyarray(py))?,
        tracked: read_only(tracked.into_pyarray(py))?,
        seconds: frozen_array(py, seconds, &[n])?,
        covariance: frozen_array(py, covariance, &[n, 3, 3])?,
    };
    Py::new(py, frames)
}

/// Learns the path driven by `commands` (n, 2) from `start` (3,) (GIL released).
#[pyfunction]
#[pyo3(signature = (world, start, commands, dt, config = None, seed = 0))]
pub fn visual_memory_learn<'py>(
    py: Python<'py>,
    world: PyRef<'py, PyCeilingWorld>,
    start: &Bound<'py, PyAny>,
    commands: &Bound<'py, PyAny>,
    dt: f64,
    config: Option<&Bound<'py, PyAny>>,
    seed: u64,
) -> PyResult<PyMemoryLearning> {
    let params: LearnParams = crate::config::from_python(config, "learn")?;
    let start = one_pose(start, "start")?;
    let commands = pairs(commands, "commands")?;
    let w = &*world;
    let learnt = detached(py, || {
        Ok(navigation::memory::learn(
            self::world(w),
            start,
            &commands,
            dt,
            &params,
            seed,
        )?)
    })?;
    let json = serde_json::to_string(&learnt.memory).map_err(|e| Error::Value(e.to_string()))?;
    Ok(PyMemoryLearning {
        memory: json,
        frames: frames(py, &learnt.truth, &learnt.reports, learnt.seconds)?,
    })
}

/// Replays the memory (JSON) from the true pose `start` (GIL released).
#[pyfunction]
#[pyo3(signature = (world, memory, start, config = None, seed = 0))]
pub fn visual_memory_replay<'py>(
    py: Python<'py>,
    world: PyRef<'py, PyCeilingWorld>,
    memory: &str,
    start: &Bound<'py, PyAny>,
    config: Option<&Bound<'py, PyAny>>,
    seed: u64,
) -> PyResult<PyMemoryReplay> {
    let params: ReplayParams = crate::config::from_python(config, "replay")?;
    let memory: VisualMemory = serde_json::from_str(memory)
        .map_err(|e| Error::Value(format!("memory: not a visual memory: {e}")))?;
    let start = one_pose(start, "start")?;
    let w = &*world;
    let run = detached(py, || {
        Ok(navigation::memory::replay(
            self::world(w),
            &memory,
            start,
            &params,
            seed,
        )?)
    })?;
    let outcome = serde_json::to_value(run.outcome)
        .ok()
        .and_then(|v| v.as_str().map(str::to_owned))
        .unwrap_or_default();
    let keys: Vec<i64> = run.key_index.iter().map(|&k| k as i64).collect();
    Ok(PyMemoryReplay {
        outcome,
        key_index: read_only(keys.into_pyarray(py))?,
        frames: frames(py, &run.truth, &run.reports, run.seconds)?,
    })
}

/// Checks that a visual memory (JSON) reads as the native side reads it: that schema
/// is the one check of a memory's structure, so that a hand-edited model without its
/// `pose` is a ValueError naming the field, not a KeyError later.
#[pyfunction]
pub fn visual_memory_check(memory: &str) -> PyResult<()> {
    serde_json::from_str::<VisualMemory>(memory)
        .map_err(|e| Error::Value(format!("memory: not a visual memory: {e}")))?;
    Ok(())
}
