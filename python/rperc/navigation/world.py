"""A seeded ceiling world with ground truth: the test bed of the visual memory.

The ceiling (``size`` metres, origin at a corner, x and y along its sides) carries
distinctive patterns (lights, vents, signs, smoke detectors) at known poses over
suspended-ceiling tiles whose texture repeats. The robot is a unicycle whose odometry
drifts. Its camera looks up with known intrinsics ``K`` and a slightly tilted, offset
mount: eq. 1's homography ``C_H_R = K (R - t n^T / d) K^-1`` corrects its images to the
ideal camera, whose image is the ceiling seen straight up from the robot, ``f / Z``
pixels per metre, mirrored (a robot turning by ``+phi`` turns its image by ``-phi``).

>>> import numpy as np
>>> from rperc.navigation import CeilingWorld
>>> from rperc.config import CeilingConfig
>>> world = CeilingWorld(ceiling=CeilingConfig(size=(6.0, 4.0), n_patterns=8))
>>> frames = world.render(np.array([[3.0, 2.0, 0.0]]))
>>> frames.shape, frames.dtype
((1, 240, 320), dtype('uint8'))
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from rperc import _rperc
from rperc._args import float_array, real_number, whole_number
from rperc._config_base import as_config
from rperc.config import (
    CeilingCameraConfig,
    CeilingConfig,
    CeilingRenderConfig,
    LearnConfig,
    OdometryNoise,
    ReplayConfig,
)

__all__ = ["CeilingWorld", "Drive", "defaults", "drive"]


def defaults() -> dict[str, dict[str, object]]:
    """Deprecated: the default configs as dicts. The typed configs of
    :mod:`rperc.config` hold them: ``CeilingConfig()``, ``CeilingCameraConfig()``,
    ``CeilingRenderConfig()``, ``OdometryNoise()``, ``LearnConfig()``,
    ``ReplayConfig()``."""
    warnings.warn(
        "rperc.navigation.defaults() is deprecated; use the classes of rperc.config "
        "(CeilingConfig(), CeilingCameraConfig(), CeilingRenderConfig(), OdometryNoise(), "
        "LearnConfig(), ReplayConfig())",
        DeprecationWarning,
        stacklevel=2,
    )
    kinds = {"ceiling": CeilingConfig, "camera": CeilingCameraConfig,
             "render": CeilingRenderConfig, "odometry": OdometryNoise,
             "learn": LearnConfig, "replay": ReplayConfig}  # fmt: skip
    return {name: cls().to_dict() for name, cls in kinds.items()}


def _poses(poses: npt.ArrayLike, name: str) -> np.ndarray:
    arr = float_array(poses, name)
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"{name} must be (x, y, theta) rows of shape (n, 3), got {arr.shape}")
    return np.ascontiguousarray(arr)


@dataclass(frozen=True, repr=False)
class Rendering:
    """What :meth:`CeilingWorld.render_truth` drew: ``frames`` ``(n, H, W)`` uint8, the
    lighting ``(gain, offset)`` of each and the occluder ``(u, v, radius)`` (NaN rows
    for frames without one)."""

    frames: np.ndarray
    lighting: np.ndarray
    occluders: np.ndarray

    def __repr__(self) -> str:
        n = len(self.frames)
        hidden = int(np.count_nonzero(~np.isnan(self.occluders[:, 0])))
        return f"Rendering(frames={n}, shape={self.frames.shape[1:]}, occluded={hidden})"


class CeilingWorld:
    """A generated ceiling, its camera and the rendering effects.

    ``ceiling``, ``camera`` and ``render`` are a :class:`rperc.config.CeilingConfig`,
    :class:`~rperc.config.CeilingCameraConfig` and
    :class:`~rperc.config.CeilingRenderConfig`, or dicts of their fields (missing
    fields keep their defaults; unknown ones are a ``TypeError``); the world keeps them
    as :attr:`ceiling_config`, :attr:`camera` and :attr:`render_config`. The layout and
    the texture are drawn from the ceiling's ``seed``, each frame's effects from the
    render's ``seed`` and its frame number, so a frame renders identically alone or in
    a batch.
    """

    def __init__(
        self,
        ceiling: CeilingConfig | Mapping[str, object] | None = None,
        camera: CeilingCameraConfig | Mapping[str, object] | None = None,
        render: CeilingRenderConfig | Mapping[str, object] | None = None,
    ) -> None:
        self.ceiling_config: CeilingConfig = as_config(CeilingConfig, ceiling)
        self.camera: CeilingCameraConfig = as_config(CeilingCameraConfig, camera)
        self.render_config: CeilingRenderConfig = as_config(CeilingRenderConfig, render)
        self._native = _rperc.CeilingWorld(
            self.ceiling_config.to_dict(), self.camera.to_dict(), self.render_config.to_dict()
        )
        kinds, centres, theta = self._native.patterns()
        self.pattern_kinds: tuple[str, ...] = tuple(kinds)
        self.pattern_centres: np.ndarray = centres
        self.pattern_theta: np.ndarray = theta

    def __reduce__(
        self,
    ) -> tuple[type[CeilingWorld], tuple[CeilingConfig, CeilingCameraConfig, CeilingRenderConfig]]:
        # Pickled as its configs (the ceiling regenerates from its seed), so that
        # worlds travel to process pools and Dask workers.
        return (CeilingWorld, (self.ceiling_config, self.camera, self.render_config))

    def __repr__(self) -> str:
        c = self.camera
        return (
            f"CeilingWorld(patterns={len(self.pattern_kinds)}, "
            f"image={c.width}x{c.height}, ceiling_height={c.ceiling_height} m)"
        )

    @property
    def image_shape(self) -> tuple[int, int]:
        """``(height, width)`` of the camera's images."""
        return self.camera.height, self.camera.width

    def render(self, poses: npt.ArrayLike, first_frame: int = 0) -> np.ndarray:
        """The camera's images at ``poses`` (``(n, 3)`` or one ``(3,)``), frame numbers
        from ``first_frame``: ``(n, H, W)`` uint8 (GIL released, frames in parallel)."""
        return self.render_truth(poses, first_frame).frames

    def render_truth(self, poses: npt.ArrayLike, first_frame: int = 0) -> Rendering:
        """:meth:`render` with the lighting and occluders each frame drew."""
        first = whole_number(first_frame, "first_frame", 0, 2**64)
        frames, lighting, occluders = self._native.render(_poses(poses, "poses"), first)
        return Rendering(frames, lighting, occluders)

    def project(self, pose: npt.ArrayLike, xy: npt.ArrayLike) -> np.ndarray:
        """Pixels ``(n, 2)`` where the real (tilted) camera at ``pose`` sees the ceiling
        points ``xy`` ``(n, 2)`` metres; NaN rows behind it."""
        p = float_array(pose, "pose").reshape(-1)
        pts = float_array(xy, "xy")
        if pts.ndim == 1:
            pts = pts[None, :]
        result: np.ndarray = self._native.project(p, np.ascontiguousarray(pts))
        return result

    def matrices(self, pose: npt.ArrayLike = (0.0, 0.0, 0.0)) -> dict[str, np.ndarray]:
        """The camera's 3x3 matrices: ``K``; ``C_H_R`` (eq. 1: ideal to real pixels);
        ``correction`` (real to ideal pixels); ``pixel_to_world`` at ``pose``."""
        p = float_array(pose, "pose").reshape(-1)
        k, h, correction, to_world = self._native.matrices(p)
        return {"K": k, "C_H_R": h, "correction": correction, "pixel_to_world": to_world}

    def texture(self) -> np.ndarray:
        """The ceiling's grey levels (float32, a copy), row ``j`` at world
        ``y = j * resolution``, column ``i`` at ``x = i * resolution``."""
        result: np.ndarray = self._native.texture()
        return result

    @property
    def resolution(self) -> float:
        """Metres per texel of :meth:`texture`."""
        return float(self._native.resolution)


@dataclass(frozen=True, repr=False)
class Drive:
    """A drive: ``truth`` and dead-reckoned ``odometry`` poses ``(n + 1, 3)`` at times
    ``t``, and the ``measured`` commands ``(n, 2)`` the odometry integrated."""

    t: np.ndarray
    truth: np.ndarray
    odometry: np.ndarray
    measured: np.ndarray

    def __repr__(self) -> str:
        drift = float(np.hypot(*(self.odometry[-1, :2] - self.truth[-1, :2])))
        steps, seconds = len(self.measured), float(self.t[-1])
        return f"Drive(steps={steps}, seconds={seconds:.1f}, final_drift={drift:.3f} m)"


def drive(
    start: npt.ArrayLike,
    commands: npt.ArrayLike,
    dt: float,
    noise: OdometryNoise | Mapping[str, object] | None = None,
) -> Drive:
    """Drives the unicycle from ``start`` ``(x, y, theta)`` by ``commands`` ``(n, 2)``
    ``(v, omega)`` each held ``dt`` seconds, with the odometry errors of ``noise`` (a
    :class:`rperc.config.OdometryNoise` or a dict of its fields: scale errors and white
    noise, seeded)."""
    cmd = np.ascontiguousarray(float_array(commands, "commands"))
    s = float_array(start, "start").reshape(-1)
    step = real_number(dt, "dt")
    native = as_config(OdometryNoise, noise).to_dict()
    truth, odometry, measured = _rperc.ceiling_drive(s, cmd, step, native)
    t = np.arange(len(truth), dtype=np.float64) * step
    return Drive(t, truth, odometry, measured)
