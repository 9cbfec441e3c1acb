"""SE(2) point transforms, computed by rperc-core's ``Pose2`` (one implementation for the
whole project). A pose is ``(x, y, theta)``: position in metres, heading in radians."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from rperc import _rperc


def _points(points: npt.ArrayLike) -> np.ndarray:
    """(N, 2) float64 points; one point ``(2,)`` is a row. Any other shape is an error:
    reshaping an (N, 3) array to pairs would silently mix coordinates."""
    arr = np.asarray(points)
    if arr.dtype.kind not in "fiub":
        raise TypeError(f"points must be real numbers, got dtype {arr.dtype}")
    if arr.shape == (2,):
        arr = arr.reshape(1, 2)
    if arr.size == 0:
        return np.zeros((0, 2))
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise ValueError(f"points must have shape (N, 2) or (2,), got {arr.shape}")
    return arr.astype(np.float64)


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


def point_path(poses: npt.ArrayLike, offset: npt.ArrayLike) -> np.ndarray:
    """The world path ``(N, 2)`` of one point of the robot, ``offset`` = (forward, left)
    metres in its frame, over its poses ``(N, 3)``: ``R(theta_k) offset + (x_k, y_k)``
    (a GPS antenna or a laser on a lever arm). NaN or infinite poses are an error.

    >>> import numpy as np
    >>> point_path([[0.0, 0.0, 0.0], [1.0, 2.0, np.pi / 2]], (1.0, 0.5)).round(12)
    array([[1. , 0.5],
           [0.5, 3. ]])
    """
    arr = np.asarray(poses)
    if arr.dtype.kind not in "fiub":
        raise TypeError(f"poses must be real numbers, got dtype {arr.dtype}")
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"poses must have shape (N, 3), got {arr.shape}")
    pts = np.ascontiguousarray(arr, dtype=np.float64)
    return _rperc.pose_path_point(pts, np.asarray(offset, dtype=np.float64))


def wrap_angle(angle: npt.ArrayLike) -> np.ndarray:
    """Angles (any shape) wrapped into (-pi, pi] by rperc-core's ``wrap_angle``, the
    one wrap of the project (pi stays pi; an angle already in range is returned
    exactly). A NaN or infinite angle has no direction and gives NaN.

    >>> import numpy as np
    >>> wrap_angle([3 * np.pi / 2, -np.pi, np.pi]).round(4)
    array([-1.5708,  3.1416,  3.1416])
    """
    arr = np.asarray(angle)
    if arr.dtype.kind not in "fiub":
        raise TypeError(f"angle must hold real numbers, got dtype {arr.dtype}")
    flat = np.ascontiguousarray(arr, dtype=np.float64).reshape(-1)
    return _rperc.wrap_angles(flat).reshape(arr.shape)
