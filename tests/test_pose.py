"""SE(2) point transforms from rperc-core against the closed form written here."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from rperc.pose import to_frame, to_world

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
