"""rperc.tracking under fuzzing: resample and effective_sample_size against the
definitions written here, the OTB metrics against numpy, and the trackers on hostile
frames, boxes and parameters: a finite answer or a clear error naming the parameter."""

from __future__ import annotations

from typing import Any

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from rperc.tracking import (
    ColorHistogramTracker,
    ParticleColorTracker,
    effective_sample_size,
    metrics,
    resample,
)

from fuzz.harness import ALLOCATION_LIMIT, case, examples, outcome
from fuzz.strategies import EDGE_NUMBERS, HOSTILE, same_values

RESAMPLERS = st.sampled_from(["systematic", "multinomial", "stratified", "residual"])
# Index counts (8 bytes each) a quarter of the child's allocation limit, which must be
# drawn, and one past it, which must be refused.
AROUND_THE_LIMIT = [ALLOCATION_LIMIT // 32, ALLOCATION_LIMIT // 8 + 1]


@st.composite
def weights(draw: st.DrawFn) -> np.ndarray:
    """Non-negative weights, some zero, at some scale; sometimes invalid (negative,
    NaN, inf, all zero, empty)."""
    w = draw(hnp.arrays(np.float64, st.integers(0, 30), elements=st.floats(0, 1)))
    # Up to the largest float, whose sum overflows (issue 38).
    w = w * draw(st.sampled_from([1.0, 1e-300, 1e-30, 1e30, 1e300, np.finfo(float).max]))
    if w.size and draw(st.integers(0, 4)) == 0:
        w[draw(st.integers(0, w.size - 1))] = draw(st.sampled_from([-1.0, np.nan, np.inf]))
    return w


def _valid(w: np.ndarray) -> bool:
    return bool(w.size and np.isfinite(w).all() and (w >= 0).all() and w.sum() > 0)


@examples(150)
@given(
    weights(),
    # Either side of the child's allocation limit: refused with MemoryError, or drawn.
    st.one_of(st.integers(0, 40), EDGE_NUMBERS, st.sampled_from(AROUND_THE_LIMIT)),
    RESAMPLERS,
    st.one_of(st.integers(0, 2**64 - 1), EDGE_NUMBERS),
    st.data(),
)
def prop_resample(w, n, method, seed, data):
    variant, ref = data.draw(same_values(w))
    case("resample", weights=variant, n=n, method=method, seed=seed)
    ok, idx = outcome(resample, variant, n, method, seed)
    if not ok:
        assert any(k in str(idx) for k in ("weight", "n ", "n=", "'n'", "seed", "method")), idx
        return
    assert _valid(ref), f"accepted invalid weights {ref!r}"
    assert len(idx) == n and np.all(np.diff(idx) >= 0), idx
    assert np.all(ref[idx] > 0), "drew a particle of zero weight"
    np.testing.assert_array_equal(idx, resample(ref, n, method, seed))
    # The weights' scale changes nothing: divided by their largest, the same draws.
    np.testing.assert_array_equal(idx, resample(ref / ref.max(), n, method, seed))


@examples(150)
@given(st.one_of(weights(), HOSTILE), st.data())
def prop_effective_sample_size(w, data):
    """(sum w)^2 / sum w^2, computed on w / max(w) so that no scale overflows."""
    ref = None
    if isinstance(w, np.ndarray) and w.dtype == np.float64:
        w, ref = data.draw(same_values(w))
    elif isinstance(w, np.ndarray) and w.dtype.kind in "fiub" and w.ndim == 1:
        ref = w.astype(np.float64)
    case("effective_sample_size", weights=w)
    ok, ess = outcome(effective_sample_size, w)
    if ref is None or not _valid(ref):
        assert not ok, f"accepted invalid weights: {ess}"
        return
    assert ok, ess
    u = ref / ref.max()
    expected = u.sum() ** 2 / (u @ u)
    assert abs(ess - expected) <= 1e-12 * expected, (ess, expected)


@st.composite
def boxes(draw: st.DrawFn, n: int) -> np.ndarray:
    b = draw(hnp.arrays(np.float64, (n, 4), elements=st.floats(-50, 200)))
    if n and draw(st.booleans()):
        b[draw(st.integers(0, n - 1)), draw(st.integers(0, 3))] = draw(
            st.sampled_from([np.nan, np.inf, -np.inf, 0.0, -1.0, 1e300])
        )
    return b


def _iou_reference(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    out = np.zeros(len(a))
    for k, (p, q) in enumerate(zip(a, b, strict=True)):
        if not (np.isfinite(p).all() and np.isfinite(q).all()):
            continue
        if min(p[2], p[3], q[2], q[3]) <= 0:
            continue
        w = min(p[0] + p[2], q[0] + q[2]) - max(p[0], q[0])
        h = min(p[1] + p[3], q[1] + q[3]) - max(p[1], q[1])
        inter = max(w, 0.0) * max(h, 0.0)
        union = p[2] * p[3] + q[2] * q[3] - inter
        out[k] = inter / union if union > 0 else 0.0  # subnormal sizes underflow to 0
    return out


def _centre_reference(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    with np.errstate(all="ignore"):
        d = np.hypot(*((a[:, :2] + a[:, 2:] / 2) - (b[:, :2] + b[:, 2:] / 2)).T)
    return np.where(np.isfinite(d), d, np.inf)


@examples(150)
@given(st.integers(0, 6), st.integers(0, 6), st.data())
def prop_metrics_match_numpy(na, nb, data):
    a, b = data.draw(boxes(na)), data.draw(boxes(nb))
    thr = data.draw(st.one_of(st.floats(0, 50), EDGE_NUMBERS))
    case("metrics", a=a, b=b, threshold=thr)
    results = {
        "iou": outcome(metrics.iou, a, b),
        "center_error": outcome(metrics.center_error, a, b),
        "precision": outcome(metrics.precision, a, b, thr),
    }
    if na != nb:
        assert not any(ok for ok, _ in results.values()), f"broadcast {na} vs {nb}: {results}"
        return
    ok, iou = results["iou"]
    assert ok, iou
    # Intersections are differences of corners: a box of side s at coordinate c keeps
    # about s / (c * 2**-52) digits, whichever formula computes it.
    reference = _iou_reference(a, b)
    with np.errstate(all="ignore"):
        digits = np.abs(np.hstack([a, b])).max(axis=1, initial=1.0) / np.minimum(
            np.minimum(a[:, 2], a[:, 3]), np.minimum(b[:, 2], b[:, 3])
        )
    bound = np.where(reference > 0, 8 * np.finfo(float).eps * np.nan_to_num(digits), 0.0)
    assert np.all(np.abs(iou - reference) <= bound + 1e-15), (iou, reference)
    ok, err = results["center_error"]
    np.testing.assert_allclose(err, _centre_reference(a, b), rtol=1e-12)
    ok, prec = results["precision"]
    if ok and na:  # the precision of no frames is not specified
        assert isinstance(thr, (int, float, np.number)) and not isinstance(thr, bool), thr
        assert not np.isnan(float(thr)), (thr, prec)
        assert prec == np.mean(err <= float(thr)), (prec, err, thr)
    curve_ok, curve = outcome(metrics.success_curve, iou)
    if curve_ok and len(iou):
        thresholds = np.linspace(0, 1, 21)
        np.testing.assert_array_equal(curve, [np.mean(iou > t) for t in thresholds])


FRAMES = st.one_of(
    hnp.arrays(np.uint8, st.tuples(st.integers(16, 48), st.integers(16, 48), st.just(3))),
    hnp.arrays(
        np.uint8,
        st.sampled_from([(0, 0, 3), (1, 1, 3), (20, 20), (20, 20, 4), (20, 20, 1), (3, 20, 20)]),
    ),
    hnp.arrays(st.sampled_from([np.uint16, np.float32, np.float64, np.int8]), (20, 20, 3)),
    HOSTILE,
)
BOXES = st.one_of(
    st.tuples(*[st.integers(-5, 30)] * 4),
    st.lists(st.one_of(st.floats(-10, 40), EDGE_NUMBERS), min_size=0, max_size=5),
)
TRACKER_PARAMS = {
    "color_space": st.sampled_from(["hsv", "opponent", "rg", "rgb", "HSV", "x"]),
    "bins": st.one_of(st.lists(st.integers(-1, 40), max_size=4), EDGE_NUMBERS),
    "model": st.sampled_from(["bimodal", "single", ""]),
    "upper_fraction": EDGE_NUMBERS,
    "adaptation_rate": EDGE_NUMBERS,
    "lost_threshold": EDGE_NUMBERS,
    "search_radius": EDGE_NUMBERS,
    "scale_step": EDGE_NUMBERS,
    "min_scale": EDGE_NUMBERS,
    "max_scale": EDGE_NUMBERS,
    "momentum": EDGE_NUMBERS,
    "velocity_gain": EDGE_NUMBERS,
    "max_search_radius": EDGE_NUMBERS,
    "lost_ratio": EDGE_NUMBERS,
    "lost_contrast": EDGE_NUMBERS,
    "ring_weight": EDGE_NUMBERS,
    "scale_prior": EDGE_NUMBERS,
    "channels": st.sampled_from(["rgb", "bgr", "BGR", "", "gray"]),
}
PARTICLE_PARAMS = {
    "mix_fraction": EDGE_NUMBERS,
    "n_particles": st.one_of(st.sampled_from([0, 1, 2, 10**13, 2**62]), EDGE_NUMBERS),
    "position_noise": EDGE_NUMBERS,
    "scale_noise": EDGE_NUMBERS,
    "sigma": EDGE_NUMBERS,
    "resample_below": EDGE_NUMBERS,
    "chunk_size": EDGE_NUMBERS,
    "seed": EDGE_NUMBERS,
    "resampler": st.sampled_from(["residual", "Systematic", ""]),
}


def _finite_answer(tracker: Any, frame: Any) -> None:
    ok, got = outcome(tracker.update, frame)
    if ok:
        assert np.isfinite(got.box).all() and np.isfinite(got.score), got
        assert 0.0 <= got.score <= 1.0, got


@examples(100)
@given(FRAMES, BOXES, st.booleans(), st.data())
def prop_trackers_hostile_frames_and_boxes(frame, box, particle, data):
    kind = ParticleColorTracker if particle else ColorHistogramTracker
    extra: dict[str, Any] = {"n_particles": 50} if particle else {}
    case(kind.__name__, frame=frame, box=box, **extra)
    ok, tracker = outcome(kind, frame, box, **extra)
    if ok:
        _finite_answer(tracker, data.draw(FRAMES))


@examples(150)
@given(st.booleans(), st.data())
def prop_tracker_bad_parameter_is_named(particle, data):
    params = {**TRACKER_PARAMS, **PARTICLE_PARAMS} if particle else TRACKER_PARAMS
    name = data.draw(st.sampled_from(sorted(params)))
    value = data.draw(params[name])
    kind = ParticleColorTracker if particle else ColorHistogramTracker
    kwargs: dict[str, Any] = {name: value}
    if particle and name != "n_particles":
        kwargs.setdefault("n_particles", 50)
    frame = np.random.default_rng(0).integers(0, 255, (32, 32, 3), dtype=np.uint8)
    case(kind.__name__, frame="rng(0) 32x32", box=(8, 8, 12, 12), **kwargs)
    ok, tracker = outcome(kind, frame, (8, 8, 12, 12), **kwargs)
    if not ok:
        assert name in str(tracker), f"{name}={value!r}: {type(tracker).__name__}: {tracker}"
        return
    _finite_answer(tracker, np.roll(frame, 2, axis=1))
