"""The EKF-SLAM core of paper [000] (section 2.2, eqs. 1-9), typed.

A state ``[x_robot, l_1, ..., l_n]`` of a robot block and landmark blocks with a full
covariance ``P``: an O(n) prediction (eq. 5) and an O(n^2) Joseph-form update (eqs.
6-9) that exploits the sparse observation Jacobian.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from rperc import _rperc
from rperc._args import float_array, whole_number


def _vector(values: npt.ArrayLike, name: str) -> np.ndarray:
    arr: np.ndarray = float_array(values, name)
    if arr.ndim != 1:
        raise ValueError(f"{name} must be 1-D, got shape {arr.shape}")
    return arr


def _matrix(values: npt.ArrayLike, name: str) -> np.ndarray:
    arr: np.ndarray = float_array(values, name)
    if arr.ndim == 0:
        arr = arr.reshape(1, 1)
    if arr.ndim != 2:
        raise ValueError(f"{name} must be 2-D, got shape {arr.shape}")
    return arr


@dataclass(frozen=True, repr=False)
class EkfUpdate:
    """What one measurement update did: the ``innovation`` ``z - h(x)`` it used, the
    innovation covariance ``innovation_cov`` ``S = H P H^T + R`` (eq. 8), the Kalman
    ``gain`` ``K = P H^T S^-1`` (eq. 7, ``d x m``) and the normalised innovation
    squared ``nis`` ``nu^T S^-1 nu`` (chi-square with ``m`` degrees of freedom for a
    consistent filter)."""

    innovation: np.ndarray
    innovation_cov: np.ndarray
    gain: np.ndarray
    nis: float

    def __repr__(self) -> str:
        return f"EkfUpdate(m={len(self.innovation)}, nis={self.nis:.3f})"


def _typed(up: _rperc.KalmanUpdate) -> EkfUpdate:
    return EkfUpdate(up.innovation, up.innovation_cov, up.gain, up.nis)


def _restore(state: np.ndarray, covariance: np.ndarray, robot_dim: int, landmark_dim: int) -> Ekf:
    return Ekf(state, covariance, robot_dim, landmark_dim)


class Ekf:
    """Extended Kalman filter over a robot block of ``robot_dim`` entries followed by
    landmark blocks of ``landmark_dim`` entries each (paper [000], eqs. 3-9).

    ``state`` and ``covariance`` accept any array-like (lists included). The
    covariance must be symmetric positive semi-definite; noise covariances ``V`` and
    ``R`` likewise. A failed step raises and leaves the filter unchanged: a bad
    argument is a ``ValueError``, a singular innovation covariance
    ``rperc.NumericalError``. Filters pickle and deep-copy.

    Examples
    --------
    >>> from rperc.slam import Ekf
    >>> ekf = Ekf([0.0, 0.0, 0.0], [[0.01, 0, 0], [0, 0.01, 0], [0, 0, 0.001]], 3, 2)
    >>> j = ekf.add_landmark_range_bearing([5.0, 0.3], [[0.01, 0], [0, 0.001]])
    >>> up = ekf.update_range_bearing(j, [5.02, 0.31], [[0.01, 0], [0, 0.001]])
    >>> ekf.num_landmarks, up.gain.shape
    (1, (5, 2))
    """

    def __init__(
        self,
        state: npt.ArrayLike,
        covariance: npt.ArrayLike,
        robot_dim: int,
        landmark_dim: int,
    ) -> None:
        for name, value in (("robot_dim", robot_dim), ("landmark_dim", landmark_dim)):
            whole_number(value, name, 1)
        self._native = _rperc.Ekf(
            _vector(state, "state"),
            _matrix(covariance, "covariance"),
            int(robot_dim),
            int(landmark_dim),
        )

    @property
    def state(self) -> np.ndarray:
        """The state estimate (a copy)."""
        return self._native.state

    @state.setter
    def state(self, value: npt.ArrayLike) -> None:
        self._native.state = _vector(value, "state")

    @property
    def covariance(self) -> np.ndarray:
        """The full covariance ``P`` (a copy, O(n^2))."""
        return self._native.covariance

    @property
    def robot_dim(self) -> int:
        return self._native.robot_dim

    @property
    def landmark_dim(self) -> int:
        return self._native.landmark_dim

    @property
    def num_landmarks(self) -> int:
        return self._native.num_landmarks

    def predict(
        self,
        robot_mean: npt.ArrayLike,
        Fx: npt.ArrayLike,
        Fv: npt.ArrayLike,
        V: npt.ArrayLike,
    ) -> None:
        """Prediction (eqs. 3, 5): the robot block moves to ``robot_mean`` and
        ``P <- Fx P Fx^T + Fv V Fv^T`` with ``Fx`` acting on the robot block only. O(n)."""
        self._native.predict(
            _vector(robot_mean, "robot_mean"),
            _matrix(Fx, "Fx"),
            _matrix(Fv, "Fv"),
            _matrix(V, "V"),
        )

    def update(
        self,
        innovation: npt.ArrayLike,
        blocks: Sequence[tuple[int, int, npt.ArrayLike]],
        R: npt.ArrayLike,
    ) -> EkfUpdate:
        """Update (eqs. 6-9) with ``innovation`` and a sparse ``H`` given as
        ``[(row, col, block), ...]`` (each block's entries placed at ``H[row:, col:]``)."""
        nu = _vector(innovation, "innovation")
        h = [(int(r), int(c), _matrix(b, f"blocks[{k}]")) for k, (r, c, b) in enumerate(blocks)]
        return _typed(self._native.update(nu, h, _matrix(R, "R")))

    def update_range_bearing(self, j: int, z: npt.ArrayLike, R: npt.ArrayLike) -> EkfUpdate:
        """Update with a range-bearing observation ``z = (range, bearing)`` of point
        landmark ``j`` (planar robot ``(x, y, theta)``); the bearing innovation is
        wrapped into (-pi, pi]."""
        return _typed(self._native.update_range_bearing(int(j), _vector(z, "z"), _matrix(R, "R")))

    def add_landmark(
        self,
        mean: npt.ArrayLike,
        G_robot: npt.ArrayLike,
        G_z: npt.ArrayLike,
        R: npt.ArrayLike,
    ) -> int:
        """Append a landmark initialised through the inverse observation model
        ``l = g(x_robot, z)`` with its full cross-covariance; returns its index."""
        return self._native.add_landmark(
            _vector(mean, "mean"),
            _matrix(G_robot, "G_robot"),
            _matrix(G_z, "G_z"),
            _matrix(R, "R"),
        )

    def add_landmark_range_bearing(self, z: npt.ArrayLike, R: npt.ArrayLike) -> int:
        """Append a point landmark first seen at ``z = (range, bearing)``; returns its index."""
        return self._native.add_landmark_range_bearing(_vector(z, "z"), _matrix(R, "R"))

    def __reduce__(self) -> tuple[Any, tuple[Any, ...]]:
        return (_restore, (self.state, self.covariance, self.robot_dim, self.landmark_dim))

    def __repr__(self) -> str:
        return (
            f"Ekf(robot_dim={self.robot_dim}, landmark_dim={self.landmark_dim}, "
            f"landmarks={self.num_landmarks}, state_dim={len(self.state)})"
        )
