//! The visual memory (second seed, section 2): learning and replay runs in a ceiling
//! world, the memory exchanged as JSON. Conversion only.

use pyo3::prelude::*;
use rperc_core::Pose2;
use tracking::memory::{FrameReport, LearnParams, ReplayParams, VisualMemory, World};

use crate::arrays::shaped;
use crate::ceiling_py::{PyCeilingWorld, one_pose, pairs, pose_rows};
use crate::errors::{Error, detached};

type Array<'py> = Bound<'py, numpy::PyArrayDyn<f64>>;

/// Per-frame arrays of a run: `(truth (n, 3), pose (n, 3) NaN where unknown, lost (n,)
/// as 0/1, tracked models (n,), seconds (n,))`.
type Frames<'py> = (
    Array<'py>,
    Array<'py>,
    Array<'py>,
    Array<'py>,
    Array<'py>,
    Array<'py>,
);

fn world(w: &PyCeilingWorld) -> World<'_> {
    World {
        ceiling: &w.ceiling,
        camera: &w.camera,
        render: &w.render,
    }
}

fn frames<'py>(
    py: Python<'py>,
    truth: &[Pose2],
    reports: &[FrameReport],
    seconds: Vec<f64>,
) -> PyResult<Frames<'py>> {
    let n = truth.len();
    let pose: Vec<f64> = reports
        .iter()
        .flat_map(|r| r.pose.map_or([f64::NAN; 3], |p| [p.x, p.y, p.theta]))
        .collect();
    let lost = reports
        .iter()
        .map(|r| f64::from(u8::from(r.lost)))
        .collect();
    let tracked = reports.iter().map(|r| r.tracked.len() as f64).collect();
    let covariance: Vec<f64> = reports
        .iter()
        .flat_map(|r| r.covariance.map_or([[f64::NAN; 3]; 3], |c| c))
        .flatten()
        .collect();
    Ok((
        shaped(py, pose_rows(truth), &[n, 3])?,
        shaped(py, pose, &[n, 3])?,
        shaped(py, lost, &[n])?,
        shaped(py, tracked, &[n])?,
        shaped(py, seconds, &[n])?,
        shaped(py, covariance, &[n, 3, 3])?,
    ))
}

/// Learns the path driven by `commands` (n, 2) from `start` (3,): `(memory JSON,
/// frames)` (GIL released).
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
) -> PyResult<(String, Frames<'py>)> {
    let params: LearnParams = crate::config::from_python(config, "learn")?;
    let start = one_pose(start, "start")?;
    let commands = pairs(commands, "commands")?;
    let w = &*world;
    let learnt = detached(py, || {
        Ok(tracking::memory::learn(
            self::world(w),
            start,
            &commands,
            dt,
            &params,
            seed,
        )?)
    })?;
    let json = serde_json::to_string(&learnt.memory).map_err(|e| Error::Value(e.to_string()))?;
    Ok((
        json,
        frames(py, &learnt.truth, &learnt.reports, learnt.seconds)?,
    ))
}

/// Replays the memory (JSON) from the true pose `start`: `(outcome, key index (n,),
/// frames)` (GIL released).
#[pyfunction]
#[pyo3(signature = (world, memory, start, config = None, seed = 0))]
pub fn visual_memory_replay<'py>(
    py: Python<'py>,
    world: PyRef<'py, PyCeilingWorld>,
    memory: &str,
    start: &Bound<'py, PyAny>,
    config: Option<&Bound<'py, PyAny>>,
    seed: u64,
) -> PyResult<(String, Array<'py>, Frames<'py>)> {
    let params: ReplayParams = crate::config::from_python(config, "replay")?;
    let memory: VisualMemory = serde_json::from_str(memory)
        .map_err(|e| Error::Value(format!("memory: not a visual memory: {e}")))?;
    let start = one_pose(start, "start")?;
    let w = &*world;
    let run = detached(py, || {
        Ok(tracking::memory::replay(
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
    let n = run.truth.len();
    let keys = run.key_index.iter().map(|&k| k as f64).collect();
    Ok((
        outcome,
        shaped(py, keys, &[n])?,
        frames(py, &run.truth, &run.reports, run.seconds)?,
    ))
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

/// Default configs as dicts: `(learn, replay)`.
#[pyfunction]
pub fn visual_memory_defaults(py: Python<'_>) -> PyResult<(Bound<'_, PyAny>, Bound<'_, PyAny>)> {
    Ok((
        crate::config::defaults::<LearnParams>(py)?,
        crate::config::defaults::<ReplayParams>(py)?,
    ))
}
