"""rperc.navigation's ceiling world under fuzzing: configs at and beyond their limits,
hostile pose and command arrays. Each call gives a well-formed answer (frames of the
camera's size, finite poses) or a clear error naming what was wrong."""

from __future__ import annotations

from typing import Any

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from rperc.navigation import CeilingWorld, drive

from fuzz.harness import case, examples, outcome
from fuzz.strategies import EDGE_NUMBERS, HOSTILE, LAYOUTS, relayout

FIELDS = ("size", "resolution", "tile", "texture_contrast", "n_patterns", "min_spacing",
          "fx", "fy", "cx", "ceiling_height", "width", "mount", "noise", "blur", "gain",
          "offset", "occluder_probability", "occluder_radius", "outside_level", "roll",
          "pitch", "colour")  # fmt: skip
# A small world, so that each example is milliseconds; fuzzed fields replace its values.
BASE = {"size": [3.0, 2.0], "resolution": 0.02, "n_patterns": 4, "min_spacing": 0.5}
CAMERA = {"width": 64, "height": 48, "fx": 40.0, "fy": 40.0, "cx": 31.5, "cy": 23.5}


def _named(exc: BaseException) -> bool:
    return any(f in str(exc) for f in FIELDS) or isinstance(exc, MemoryError)


FUZZED = ["size", "resolution", "n_patterns", "min_spacing", "tile", "fx", "ceiling_height",
          "width", "mount", "noise", "blur", "gain", "offset", "occluder_probability",
          "colour"]  # fmt: skip


@examples(60)
@given(
    st.sampled_from(["ceiling", "camera", "render"]),
    st.sampled_from(FUZZED),
    st.one_of(EDGE_NUMBERS, st.lists(EDGE_NUMBERS, min_size=0, max_size=3), st.just("x")),
)
def prop_world_configs(group: str, field: str, value: Any) -> None:
    configs: dict[str, dict[str, Any]] = {"ceiling": dict(BASE), "camera": dict(CAMERA),
                                          "render": {}}  # fmt: skip
    if field == "mount":
        value = {"roll": value} if not isinstance(value, list) else {"offset": value}
    configs[group][field] = value
    case("CeilingWorld", **configs)
    ok, world = outcome(CeilingWorld, configs["ceiling"], configs["camera"], configs["render"])
    if not ok:
        assert _named(world), world
        return
    ok, frames = outcome(world.render, np.array([[1.5, 1.0, 0.3]]))
    if not ok:
        assert _named(frames), frames
        return
    h, w = world.image_shape
    assert frames.shape == (1, h, w) and frames.dtype == np.uint8


@examples(60)
@given(st.one_of(HOSTILE, st.lists(EDGE_NUMBERS, min_size=3, max_size=3)),
       st.sampled_from(LAYOUTS))  # fmt: skip
def prop_render_poses(poses: Any, layout: str) -> None:
    world = _world()
    if isinstance(poses, np.ndarray) and poses.dtype == np.float64 and poses.ndim == 2:
        poses = relayout(poses, layout)
    case("CeilingWorld.render", poses=poses)
    ok, frames = outcome(world.render, poses)
    if ok:
        assert frames.dtype == np.uint8 and frames.shape[1:] == (48, 64)
        rows = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
        assert len(frames) == len(rows) and np.isfinite(rows).all()
    else:
        assert "poses" in str(frames), frames


@examples(60)
@given(st.lists(st.tuples(EDGE_NUMBERS, EDGE_NUMBERS), min_size=0, max_size=5), EDGE_NUMBERS)
def prop_drive(commands: list[tuple[Any, Any]], dt: Any) -> None:
    case("drive", commands=commands, dt=dt)
    ok, run = outcome(drive, [0.0, 0.0, 0.0], commands, dt)
    if not ok:
        assert any(k in str(run) for k in ("commands", "dt", "start")), run
        return
    assert np.isfinite(run.truth).all() and np.isfinite(run.odometry).all()
    assert run.truth.shape == (len(commands) + 1, 3)


_CACHE: list[CeilingWorld] = []


def _world() -> CeilingWorld:
    if not _CACHE:
        _CACHE.append(CeilingWorld(BASE, CAMERA))
    return _CACHE[0]


LOCALISER = ("pixel_sigma", "rotation_pixel_sigma", "min_rotation_lever", "gate_probability",
             "max_refused_frames", "odometry_sigma", "guess_sigma")  # fmt: skip
LEARN_NAMES = ("start", "commands", "dt", "seed", "config", "localiser", "mosaic",
               *LOCALISER)  # fmt: skip


@examples(30)
@given(
    st.one_of(HOSTILE, st.lists(EDGE_NUMBERS, min_size=3, max_size=3)),
    st.lists(st.tuples(EDGE_NUMBERS, EDGE_NUMBERS), min_size=0, max_size=4),
    st.sampled_from(LOCALISER),
    st.one_of(EDGE_NUMBERS, st.lists(EDGE_NUMBERS, min_size=0, max_size=5), st.just("x")),
)
def prop_learn_and_replay(start: Any, commands: Any, field: str, value: Any) -> None:
    """Learning and replaying with hostile starts, commands and localiser settings:
    per-frame arrays of one length with finite truth and symmetric covariances, or a
    clear error naming what was wrong; never a panic."""
    from rperc.navigation import learn, replay

    world = _world()
    config = {"mosaic": {"localiser": {field: value}}}
    case("learn", start=start, commands=commands, field=field, value=value)
    ok, learning = outcome(learn, world, start, commands, 0.1, config)
    if not ok:
        assert any(n in str(learning) for n in LEARN_NAMES), learning
        return
    f = learning.frames
    n = len(f.truth)
    assert f.pose.shape == (n, 3) and f.covariance.shape == (n, 3, 3) and len(f.lost) == n
    assert np.isfinite(f.truth).all()
    known = np.isfinite(f.covariance).all(axis=(1, 2))
    assert np.allclose(f.covariance[known], f.covariance[known].transpose(0, 2, 1))
    if not learning.memory.key_images:
        return
    ok, run = outcome(replay, world, learning.memory, start, {"max_frames": 5})
    if not ok:
        assert any(n in str(run) for n in LEARN_NAMES), run
        return
    assert run.outcome in ("reached", "lost", "timed_out") and len(run.frames.truth) <= 5
