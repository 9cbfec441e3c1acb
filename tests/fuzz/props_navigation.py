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
             "max_refused_frames", "odometry_sigma", "guess_sigma", "search_sigmas",
             "settle_frames", "odometry_scale_sigma")  # fmt: skip
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


_LEARNT: list[Any] = []


def _learning() -> Any:
    """A small world with a 320 x 240 camera and a short learning run in it, once."""
    from rperc.navigation import learn

    if not _LEARNT:
        ceiling = {"size": [4.0, 3.0], "n_patterns": 6, "min_spacing": 0.8,
                   "resolution": 0.01, "seed": 1}  # fmt: skip
        world = CeilingWorld(ceiling)
        _LEARNT.append((world, learn(world, [2.0, 1.5, 0.3], [[0.1, 0.05]] * 6, 0.1)))
    return _LEARNT[0]


EVALUATE_NAMES = ("starts", "perturbation", "seed", "start", "key_images", "config", "max_frames")


@examples(30)
@given(
    st.one_of(EDGE_NUMBERS, st.integers(-3, 3)),
    st.one_of(HOSTILE, st.lists(EDGE_NUMBERS, min_size=0, max_size=4)),
    st.one_of(EDGE_NUMBERS, st.integers(0, 2**64 + 1)),
    st.one_of(EDGE_NUMBERS, st.just(2)),
)
def prop_evaluate(starts: Any, perturbation: Any, seed: Any, max_frames: Any) -> None:
    """The 50-start evaluation with hostile counts, perturbations, seeds and replay
    lengths: an Evaluation whose rates lie in [0, 1], or a clear error naming what
    was wrong; never a panic."""
    from rperc.navigation import evaluate

    world, learning = _learning()
    case("evaluate", starts=starts, perturbation=perturbation, seed=seed, max_frames=max_frames)
    ok, got = outcome(evaluate, world, learning, starts=starts, perturbation=perturbation,
                      config={"max_frames": max_frames}, seed=seed)  # fmt: skip
    if not ok:
        assert any(n in str(got) for n in EVALUATE_NAMES), got
        return
    ev, runs = got
    assert len(runs) == ev.starts and 0.0 <= ev.success_rate <= 1.0


HOSTILE_JSON = st.one_of(
    st.sampled_from([None, "x", -1, 2**70, 1e308, float("nan"), [], {}, [1.0, 2.0], True]),
    st.just("DELETE"),
)


def _paths(value: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Every key path of a JSON value (lists: their first item only)."""
    out = [prefix] if prefix else []
    if isinstance(value, dict):
        for k, v in value.items():
            out += _paths(v, (*prefix, k))
    elif isinstance(value, list) and value:
        out += _paths(value[0], (*prefix, 0))
    return out


@examples(60)
@given(st.data(), HOSTILE_JSON)
def prop_memory_json(data: Any, value: Any) -> None:
    """A learnt memory's JSON with one field replaced by a hostile value (or deleted):
    VisualMemory reads it or raises a ValueError; one it reads replays or raises a
    ValueError. Never a KeyError, a TypeError from deep inside, or a panic."""
    import json

    from rperc.navigation import VisualMemory, replay

    world, learning = _learning()
    base = json.loads(learning.memory.to_json())
    path = data.draw(st.sampled_from(_paths(base)))
    case("VisualMemory", path=path, value=value)
    edited = json.loads(json.dumps(base))
    holder = edited
    for key in path[:-1]:
        holder = holder[key]
    if value == "DELETE" and isinstance(holder, dict):
        del holder[path[-1]]
    elif value != "DELETE":
        holder[path[-1]] = value
    ok, memory = outcome(VisualMemory, json.dumps(edited))
    if not ok:
        assert isinstance(memory, ValueError), repr(memory)
        return
    assert memory.n_models == len(edited["models"])
    ok, run = outcome(replay, world, memory, [2.0, 1.5, 0.3], {"max_frames": 3})
    if not ok:
        assert isinstance(run, ValueError), repr(run)


REPLAY_FIELDS = ("max_frames", "max_blind_frames", "dt", "metres_per_pixel")


@examples(20)
@given(
    st.tuples(st.sampled_from([0.0, 0.05, 0.7, 3.0, 100.0, 1e300, -1e300, np.nan]),
              st.sampled_from([0.0, -0.05, 0.7]), st.sampled_from([0.0, 0.1, 3.0])),
    st.sampled_from(REPLAY_FIELDS),
    st.one_of(EDGE_NUMBERS, st.integers(0, 40)),
    st.booleans(),
)  # fmt: skip
def prop_replay_reaches_only_when_localised(offset: Any, field: str, value: Any, other: bool):
    """Replays from starts near, far and kidnapped, in the learnt world or another,
    with a hostile replay setting: 'reached' only when the last frame is localised
    (issue 38: replays whose every frame was lost reported 'reached'), or a clear
    error naming the start or the setting."""
    from rperc.navigation import replay

    world, learning = _learning()
    if other:
        world = _other_world()
    start = learning.frames.truth[0] + np.asarray(offset)
    config = {"max_frames": 40, field: value}
    case("replay", start=start, config=config, other_world=other)
    ok, run = outcome(replay, world, learning.memory, start, config)
    if not ok:
        assert any(n in str(run) for n in ("start", *REPLAY_FIELDS)), run
        return
    assert run.outcome in ("reached", "lost", "timed_out")
    if run.reached:
        assert not run.frames.lost[-1], "reached on a lost frame"
    if run.frames.lost.all():
        assert not run.reached, "reached with every frame lost"


def _other_world() -> CeilingWorld:
    """A world of the same size with other patterns than the learnt one."""
    if len(_LEARNT) < 2:
        ceiling = {"size": [4.0, 3.0], "n_patterns": 6, "min_spacing": 0.8,
                   "resolution": 0.01, "seed": 7}  # fmt: skip
        _LEARNT.append(CeilingWorld(ceiling))
    return _LEARNT[1]
