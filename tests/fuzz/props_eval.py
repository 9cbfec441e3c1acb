"""rperc.pose and rperc.slam.evaluation under fuzzing: rigid transforms against the
rotation matrix written here, the SE(2) alignment against its optimality and
invariance, and hostile arrays as clear errors, never a silently reshaped answer."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from rperc import pose
from rperc.slam import evaluation as ev

from fuzz.harness import case, examples, outcome
from fuzz.strategies import EDGE_NUMBERS, HOSTILE, LAYOUTS, relayout, same_values

COORDS = st.floats(-1e6, 1e6)


@examples(150)
@given(
    hnp.arrays(np.float64, 3, elements=st.floats(-100, 100)),
    st.one_of(
        hnp.arrays(np.float64, st.tuples(st.integers(0, 6), st.just(2)), elements=COORDS), HOSTILE
    ),
    st.data(),
)
def prop_pose_transforms(p, pts, data):
    """to_world(p, q) = R q + t (R written here), to_frame inverts it; any layout
    gives the float64 answer; a shape that is not (N, 2) or (2,) is an error."""
    if isinstance(pts, np.ndarray) and pts.dtype == np.float64 and pts.shape[1:] == (2,):
        pts, ref = data.draw(same_values(pts))
    else:
        ref = None
    case("pose.to_world", pose=p, points=pts)
    ok, world = outcome(pose.to_world, p, pts)
    if ref is None:
        if ok:
            shape = np.asarray(pts).shape
            assert shape == (2,) or np.size(pts) == 0 or shape[1:] == (2,), (
                f"accepted points of shape {shape}: {world!r}"
            )
        return
    assert ok, world
    c, s = math.cos(p[2]), math.sin(p[2])
    expected = ref @ np.array([[c, s], [-s, c]]) + p[:2]
    np.testing.assert_allclose(world, expected, rtol=1e-12, atol=1e-9)
    back = pose.to_frame(p, world)
    # A round trip keeps the digits of the largest coordinate, not of the smallest
    # (a uint64 of 1.8e19 next to 1.0 loses the 1.0).
    np.testing.assert_allclose(back, ref, rtol=1e-9, atol=1e-6 + 1e-12 * np.abs(ref).max(initial=0))


@examples(100)
@given(
    st.one_of(
        hnp.arrays(np.float64, st.integers(0, 8), elements=st.floats(-1e6, 1e6)),
        HOSTILE,
        EDGE_NUMBERS,
    )
)
def prop_wrap_angle(angle):
    case("wrap_angle", angle=angle)
    ok, w = outcome(ev.wrap_angle, angle)
    if not ok:
        return
    a = np.asarray(angle, dtype=np.float64)
    # Beyond 1e9 rad, wrapping by the float 2 pi keeps no digit of the true angle
    # (cos uses exact reduction); only the range is checked there.
    finite = np.isfinite(a) & (np.abs(a) < 1e9)
    w = np.asarray(w)
    assert np.all(np.isfinite(w) == np.isfinite(a)), (angle, w)
    inside = w[np.isfinite(a)]
    assert np.all((inside > -math.pi) & (inside <= math.pi)), w
    wf, af = w[finite], a[finite]
    np.testing.assert_allclose(np.cos(wf), np.cos(af), atol=1e-6)


@st.composite
def trajectories(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray]:
    n = draw(st.integers(2, 12))
    t = np.cumsum(draw(hnp.arrays(np.float64, n, elements=st.floats(0.01, 10))))
    xy = draw(hnp.arrays(np.float64, (n, 3), elements=st.floats(-100, 100)))
    return t, xy


@examples(100)
@given(trajectories(), st.floats(-math.pi, math.pi), st.tuples(COORDS, COORDS), st.data())
def prop_aligned_ate_is_invariant_to_a_rigid_motion(traj, theta, shift, data):
    """Moving the estimate rigidly changes nothing in the aligned ATE; the alignment
    recovers the motion when the estimate is the reference moved."""
    t, ref = traj
    c, s = math.cos(theta), math.sin(theta)
    moved = ref.copy()
    moved[:, :2] = ref[:, :2] @ np.array([[c, s], [-s, c]]) + shift
    moved[:, 2] = ev.wrap_angle(ref[:, 2] + theta)
    est = relayout(moved, data.draw(st.sampled_from(LAYOUTS)))
    case("ate", t=t, estimate=est, reference=ref)
    ok, err = outcome(ev.ate, t, est, t, ref, align=True)
    if not ok:
        assert "undetermined" in str(err), err
        return
    scale = 1 + np.abs(moved[:, :2]).max()
    assert err.rmse <= 1e-6 * scale, err


@examples(120)
@given(
    st.one_of(st.just(np.arange(4.0)), HOSTILE),
    st.one_of(st.just(np.zeros((4, 3))), HOSTILE),
    st.one_of(st.just(np.arange(4.0)), HOSTILE, st.just(np.array([0.0, 2.0, 1.0, 3.0]))),
    st.one_of(st.just(np.ones((4, 3))), HOSTILE),
    st.one_of(st.none(), EDGE_NUMBERS),
)
def prop_evaluation_hostile_input(t_est, est, t_ref, ref, max_gap):
    case("ate", t_estimate=t_est, estimate=est, t_reference=t_ref, reference=ref, max_gap=max_gap)
    ok, got = outcome(ev.ate, t_est, est, t_ref, ref, max_gap=max_gap)
    if ok:
        assert np.isfinite(got.rmse), got
    ok, got = outcome(ev.gps_error, t_est, est, t_ref, ref, max_gap=max_gap)
    if ok:
        assert np.isfinite(got.rms), got
    ok, got = outcome(ev.align_se2, est, ref)
    if ok:
        assert np.isfinite(got.theta) and np.isfinite(got.translation).all(), got


@examples(80)
@given(
    st.one_of(st.just(np.arange(3)), HOSTILE, st.just(np.array([1, 1, 2]))),
    st.one_of(st.just(np.zeros((3, 2))), HOSTILE),
    st.one_of(st.just(np.arange(3)), HOSTILE, st.just(np.array([0.5, 1, 2]))),
    st.one_of(st.just(np.ones((3, 2))), HOSTILE),
)
def prop_landmark_error_hostile_input(est_ids, est, ref_ids, ref):
    case("landmark_error", estimate_ids=est_ids, estimate=est, reference_ids=ref_ids, reference=ref)
    ok, got = outcome(ev.landmark_error, est_ids, est, ref_ids, ref)
    if ok:
        assert np.isfinite(got.rmse), got
