"""Planar SLAM, wall SLAM, smoothing, TUM writing and the loaders' header values
under fuzzing (issue 38). Each example gives a clear error naming what was wrong, or a
result that passes its own check: a finite path with symmetric covariances, a TUM file
that reads back as written, a log whose laser geometry is positive and finite."""

from __future__ import annotations

import math
import shutil
import tempfile
import warnings
from pathlib import Path
from typing import Any

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from rperc.datasets import load_carmen, read_tum, write_tum
from rperc.slam import PlanarSlam, planar
from rperc.slam import wallslam as ws
from rperc.slam.smoothing import smooth_walls

from fuzz.harness import case, config_fields, examples, nested_config, outcome
from fuzz.strategies import EDGE_NUMBERS

FIELD_VALUES = st.one_of(
    EDGE_NUMBERS,
    st.sampled_from([10**9, 2**62, 0.5, 2.0, "nn", "jcbb", "x", [1.0, 2.0], [0.0, 0.0, 0.0]]),
)


PLANAR_FIELDS = sorted(config_fields(planar.defaults()))
_CACHE: dict[str, Any] = {}


def _recording() -> Any:
    if "sim" not in _CACHE:
        _CACHE["sim"] = planar.simulate({"steps": 40}, seed=1)
    return _CACHE["sim"]


def _prepared() -> ws.PreparedLog:
    """A short simulated loop's walls, prepared once."""
    if "loop" not in _CACHE:
        from rperc.scansim import write_loop_log

        folder = Path(tempfile.mkdtemp(prefix="rperc-fuzz-"))
        try:
            log = load_carmen(write_loop_log(folder / "loop.log", seed=1, laps=0.3))
            _CACHE["loop"] = ws.prepare(log)
        finally:
            shutil.rmtree(folder)
    return _CACHE["loop"]


def _healthy(out: Any) -> None:
    assert np.isfinite(out.pose).all(), "non-finite pose"
    cov = out.covariance
    assert np.allclose(cov, np.swapaxes(cov, -1, -2), rtol=1e-9, atol=1e-12), "asymmetric"


def _named(exc: BaseException, field: str) -> bool:
    text = str(exc)
    parts = field.split(".")
    return any(p in text for p in parts) or "event" in text


@examples(80)
@given(st.sampled_from(PLANAR_FIELDS), FIELD_VALUES)
def prop_planar_slam_config_fields(field, value):
    config = nested_config(field, value)
    rec = _recording().recording
    case("PlanarSlam.run", config=config)
    ok, out = outcome(lambda: PlanarSlam(config).run(rec))
    if not ok:
        assert _named(out, field), f"{field}={value!r}: {out}"
        return
    _healthy(out)


WALL_FIELDS = [f for f in PLANAR_FIELDS if f.startswith("wall") or f in (
    "association", "anchor", "freeze_after", "first_estimates", "gate_confidence",
    "jcbb_max_nodes", "control_bias_sd")]  # fmt: skip


@examples(40)
@given(
    st.sampled_from(WALL_FIELDS), FIELD_VALUES, st.one_of(st.integers(0, 2**64 - 1), EDGE_NUMBERS)
)
def prop_wallslam_config_fields(field, value, seed):
    case("run_prepared", seed=seed, override={field: value})
    ok, out = outcome(ws.run_prepared, _prepared(), seed=seed, **{field: value})
    if not ok:
        assert _named(out, field) or "seed" in str(out), f"{field}={value!r}: {out}"
        return
    assert np.isfinite(out.pose).all() and len(out.pose) == len(_prepared().t)


@examples(40)
@given(
    st.one_of(st.integers(1, 50), st.integers(-2, 0), EDGE_NUMBERS),
    st.one_of(st.floats(0, 1e-3), st.floats(-1, 1), EDGE_NUMBERS),
    # The run's scan times, or times the smoother must refuse.
    st.one_of(
        st.just("scans"), st.sampled_from(["reversed", "repeated", "shifted", "empty", "nan"])
    ),
)
def prop_smoothing(max_iterations, tolerance, times):
    prep = _prepared()
    controls, out = _filter_run(prep)
    t = {"scans": prep.t, "reversed": prep.t[::-1], "repeated": np.repeat(prep.t, 2),
         "shifted": prep.t + 0.5, "empty": prep.t[:0],
         "nan": np.r_[prep.t[:-1], np.nan]}[times]  # fmt: skip
    case("smooth_walls", max_iterations=max_iterations, tolerance=tolerance, times=times)
    ok, sm = outcome(smooth_walls, out, controls, prep.rows, t,
                     max_iterations=max_iterations, tolerance=tolerance)  # fmt: skip
    if not ok:
        names = ("max_iterations", "tolerance", "times", "increas")
        assert any(n in str(sm) for n in names), sm
        return
    assert times == "scans", f"accepted {times} times"
    assert np.isfinite(sm.pose).all() and sm.pose.shape == (len(t), 3)
    assert np.allclose(sm.covariance, np.swapaxes(sm.covariance, -1, -2), atol=1e-12)


def _filter_run(prep: ws.PreparedLog) -> tuple[np.ndarray, Any]:
    """The controls and the filter's run over the prepared loop, as run_prepared
    makes them (its config), once."""
    if "out" not in _CACHE:
        controls = np.r_[ws.noisy_controls(prep.exact, 2), [[prep.t[-1], 0.0, 0.0]]]
        config = dict(ws.run_prepared(prep, seed=2).config)
        config.pop("straightness")
        out = PlanarSlam(config).run_arrays(controls, np.zeros((0, 3)), walls=prep.rows)
        _CACHE["out"] = (controls, out)
    return _CACHE["out"]


@examples(80)
@given(
    st.lists(st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.floats(-1e3, 1e3)),
             min_size=0, max_size=6),
    st.sampled_from([1.0, 1e-300, 1e300, -1e300]),
)  # fmt: skip
def prop_tum_write_reads_back_or_refuses(times, scale):
    t = np.asarray(times, dtype=np.float64)
    poses = np.c_[np.full(len(t), scale), np.linspace(0, 1, len(t)), np.linspace(-3, 3, len(t))]
    folder = Path(tempfile.mkdtemp(prefix="rperc-fuzz-"))
    try:
        path = folder / "run.tum"
        path.write_text("old\n")
        case("write_tum", t=t, poses=poses)
        ok, err = outcome(write_tum, path, t, poses)
        if not ok:
            assert path.read_text() == "old\n", "a refused write changed the file"
            assert any(n in str(err) for n in ("t[", "t ", "poses", "finite", "empty")), err
            return
        assert len(t) and np.all(np.isfinite(t)) and np.all(np.diff(t) > 0), t
        got_t, got = read_tum(path)
        np.testing.assert_array_equal(got_t, t)
        np.testing.assert_allclose(got[:, :2], poses[:, :2], rtol=1e-15)
        assert np.allclose(np.angle(np.exp(1j * (got[:, 2] - poses[:, 2]))), 0, atol=1e-12)
        assert sorted(p.name for p in folder.iterdir()) == ["run.tum"]
    finally:
        shutil.rmtree(folder)


PARAMS = ["robot_front_laser_max", "laser_front_laser_fov", "laser_front_laser_resolution",
          "robot_rear_laser_max", "laser_rear_laser_fov", "laser_rear_laser_resolution",
          "unrelated_param"]  # fmt: skip
PARAM_VALUES = st.one_of(
    st.sampled_from(["0", "-0", "-1", "nan", "inf", "-inf", "1e309", "abc", "0x10", "360",
                     "361", "1e-300", "0.5", "50", "180"]),
    st.floats(-1e3, 1e3).map(repr),
)  # fmt: skip
ROBOTLASER = (
    "ROBOTLASER1 0 -1.5 {fov} {res} {max_range} 0.01 0 3 1.0 2.0 3.0 0 "
    "0 0 0 0 0 0 0 0 0 0 0 10 host 10\n"
)


@examples(100)
@given(st.lists(st.tuples(st.sampled_from(PARAMS), PARAM_VALUES), max_size=3),
       st.tuples(PARAM_VALUES, PARAM_VALUES, PARAM_VALUES), st.booleans())  # fmt: skip
def prop_carmen_header_values(params, robotlaser, skip):
    lines = [f"PARAM {n} {v} nohost 0\n" for n, v in params]
    lines.append("FLASER 3 1 2 3 0 0 0 0 0 0 1 h 1\nRLASER 3 1 2 3 0 0 0 0 0 0 2 h 2\n")
    fov, res, max_range = robotlaser
    lines.append(ROBOTLASER.format(fov=fov, res=res, max_range=max_range))
    folder = Path(tempfile.mkdtemp(prefix="rperc-fuzz-"))
    try:
        path = folder / "log.log"
        path.write_text("".join(lines))
        case("load_carmen", file="".join(lines), skip=skip)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ok, log = outcome(load_carmen, path, on_error="skip" if skip else "raise")
    finally:
        shutil.rmtree(folder)
    if not ok:
        assert "log.log:" in str(log) and len(str(log)) < 400, log
        return
    s = log.scans
    assert np.all(np.isfinite(s.angle_increment)) and np.all(s.angle_increment > 0), s
    assert np.all(np.isfinite(s.max_range)) and np.all(s.max_range > 0), s.max_range
    span = s.angle_increment * (s.num_beams - 1)
    assert np.all(span <= 2 * math.pi + 1e-9), span


HEADER_LINES = st.one_of(
    st.sampled_from(["# t x y z qx qy qz qw", "#", "# \x00 binary", "#" + "x" * 100_000,
                     "t x y z qx qy qz qw", "% comment", "\ufeff# bom", "   # indented"]),
    st.text(max_size=40).map(lambda s: "# " + s.replace("\n", " ").replace("\r", " ")),
)  # fmt: skip


@examples(60)
@given(st.lists(HEADER_LINES, max_size=3))
def prop_tum_header_lines(header):
    """A TUM file with hostile header lines before two good poses: read back as
    written, or refused by a short error naming the file and a line of the header."""
    body = "1 0 0 0 0 0 0 1\n2 1 0 0 0 0 0.5 0.8660254037844386\n"
    folder = Path(tempfile.mkdtemp(prefix="rperc-fuzz-"))
    try:
        path = folder / "run.tum"
        path.write_text("".join(h + "\n" for h in header) + body, encoding="utf-8")
        case("read_tum", header=header)
        ok, got = outcome(read_tum, path)
    finally:
        shutil.rmtree(folder)
    if not ok:
        text = str(got)
        assert "run.tum:" in text and len(text) < 400, text[:500]
        line = int(text.split("run.tum:")[1].split(":")[0])
        assert 1 <= line <= len(header), (line, header)
        return
    t, poses = got
    np.testing.assert_array_equal(t, [1.0, 2.0])
    np.testing.assert_allclose(poses, [[0, 0, 0], [1, 0, math.pi / 3]], atol=1e-12)
