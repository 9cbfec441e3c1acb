"""SE(2) point transforms, computed by rperc-core's ``Pose2`` (one implementation for the
whole project). A pose is ``(x, y, theta)``: position in metres, heading in radians."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from rperc import _rperc


def _points(points: npt.ArrayLike) -> np.ndarray:
    arr = np.asarray(points, dtype=np.float64)
    return arr.reshape(-1, 2) if arr.size else np.zeros((0, 2))


def to_world(pose: npt.ArrayLike, points: npt.ArrayLike) -> np.ndarray:
    """Points ``(N, 2)`` given in the frame of ``pose``, moved to the world frame:
    ``R(theta) p + (x, y)``.

    >>> import numpy as np
    >>> to_world([1.0, 2.0, np.pi / 2], [[1.0, 0.0]]).round(12)
    array([[1., 3.]])
    """
    return _rperc.pose_transform_points(np.asarray(pose, dtype=np.float64), _points(points))


def to_frame(pose: npt.ArrayLike, points: npt.ArrayLike) -> np.ndarray:
    """World points ``(N, 2)`` expressed in the frame of ``pose``: ``R^T (p - (x, y))``."""
    pose_arr = np.asarray(pose, dtype=np.float64)
    return _rperc.pose_transform_points(pose_arr, _points(points), inverse=True)
