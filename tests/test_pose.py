"""SE(2) point transforms from rperc-core against the closed form written here."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from rperc.pose import point_path, to_frame, to_world, wrap_angle

coords = st.floats(-1e3, 1e3)


@given(coords, coords, st.floats(-10, 10), st.lists(st.tuples(coords, coords), max_size=20))
def test_to_world_is_rotation_then_translation(x, y, theta, points):
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    c, s = np.cos(theta), np.sin(theta)
    expected = pts @ np.array([[c, -s], [s, c]]).T + (x, y)
    np.testing.assert_allclose(to_world((x, y, theta), pts), expected, atol=1e-9)
    # to_frame undoes it.
    np.testing.assert_allclose(to_frame((x, y, theta), expected), pts, atol=1e-8)


def test_bad_pose_is_a_clear_error():
    import pytest

    with pytest.raises(ValueError, match=r"\(x, y, theta\)"):
        to_world([1.0, 2.0], [[0.0, 0.0]])
    # A pose with no position or heading moves no point: refused, not NaN rows.
    for bad in ([np.nan, 0.0, 0.0], [0.0, 0.0, np.inf]):
        with pytest.raises(ValueError, match=r"finite numbers \(x, y, theta\)"):
            to_world(bad, [[1.0, 0.0]])
        with pytest.raises(ValueError, match=r"finite numbers \(x, y, theta\)"):
            to_frame(bad, [[1.0, 0.0]])


@given(
    st.lists(st.tuples(coords, coords, st.floats(-10, 10)), max_size=20),
    st.tuples(st.floats(-10, 10), st.floats(-10, 10)),
)
def test_point_path_is_each_pose_moving_the_offset(poses, offset):
    """Oracle: the closed form of one pose at a time (written here, numpy)."""
    p = np.asarray(poses, dtype=float).reshape(-1, 3)
    c, s = np.cos(p[:, 2]), np.sin(p[:, 2])
    fx, fy = offset
    expected = np.c_[p[:, 0] + c * fx - s * fy, p[:, 1] + s * fx + c * fy]
    np.testing.assert_allclose(point_path(p, offset), expected, atol=1e-9)


def test_point_path_refuses_bad_poses_and_offsets():
    import pytest

    with pytest.raises(ValueError, match=r"\(N, 3\)"):
        point_path(np.zeros((2, 2)), (1.0, 0.0))
    with pytest.raises(TypeError, match="real numbers"):
        point_path(np.array([["a", "b", "c"]]), (1.0, 0.0))
    with pytest.raises(ValueError, match="row 1"):
        point_path([[0.0, 0.0, 0.0], [np.nan, 0.0, 0.0]], (1.0, 0.0))
    for bad in ((1.0,), (1.0, np.inf), (1.0, 2.0, 3.0)):
        with pytest.raises(ValueError, match="offset"):
            point_path([[0.0, 0.0, 0.0]], bad)
    assert point_path(np.zeros((0, 3)), (1.0, 0.0)).shape == (0, 2)


@given(st.lists(st.floats(-1e6, 1e6), min_size=1, max_size=50))
def test_wrap_angle_is_the_same_direction_in_range(angles):
    """Oracle: the unit vector of the angle is unchanged (numpy's cos and sin), and the
    result lies in (-pi, pi]."""
    a = np.asarray(angles)
    w = wrap_angle(a)
    assert np.all((w > -np.pi) & (w <= np.pi))
    np.testing.assert_allclose(np.cos(w), np.cos(a), atol=1e-9)
    np.testing.assert_allclose(np.sin(w), np.sin(a), atol=1e-9)


def test_wrap_angle_keeps_shape_and_convention():
    a = np.array([[np.pi, -np.pi], [0.25, 7.0]])
    w = wrap_angle(a)
    assert w.shape == (2, 2)
    assert w[0, 0] == np.pi and w[0, 1] == np.pi  # pi stays pi, -pi becomes pi
    assert w[1, 0] == 0.25  # in range: returned exactly
    assert np.isnan(wrap_angle([np.nan, np.inf])).all()
    assert wrap_angle(3 * np.pi).shape == ()
