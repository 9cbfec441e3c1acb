"""The colour-histogram trackers, typed: keyword parameters with the defaults of the
Rust configs, and :class:`TrackResult` answers.

Both follow OpenCV's convention: construct on the first frame and a box, then call
``update(frame)`` for every next frame. Frames are ``H x W x 3`` uint8 RGB arrays;
boxes are ``(x, y, w, h)`` in pixels with a 0-based top-left corner, given as a tuple,
a list or an array. The GIL is released while a frame is processed.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from rperc import _rperc
from rperc._args import whole_number

ColorSpace = Literal["hsv", "opponent", "rg", "rgb"]
ModelKind = Literal["bimodal", "single"]
ResamplerName = Literal["systematic", "multinomial", "stratified", "residual"]
Box = tuple[float, float, float, float]

# The Rust configs are the one source of the defaults shown in the signatures below.
_COLOR, _PARTICLE = _rperc.tracker_defaults()
_APPEARANCE = _COLOR["appearance"]
_FILTER = _PARTICLE["filter"]


@dataclass(frozen=True)
class TrackResult:
    """One tracker answer: the target's ``box`` ``(x, y, w, h)`` in pixels, its
    ``score`` (histogram intersection with the model, seed 000 eq. 28, in [0, 1]) and
    whether the target is ``lost`` (score below ``lost_threshold``). Unpacks as
    ``box, score, lost = result``."""

    box: Box
    score: float
    lost: bool

    def __iter__(self) -> Iterator[Any]:
        return iter((self.box, self.score, self.lost))

    def __repr__(self) -> str:
        x, y, w, h = self.box
        state = "lost" if self.lost else "tracking"
        box = f"({x:.1f}, {y:.1f}, {w:.1f}, {h:.1f})"
        return f"TrackResult(box={box}, score={self.score:.3f}, {state})"


def _box(box: Sequence[float] | npt.ArrayLike) -> Box:
    arr = np.asarray(box, dtype=np.float64).reshape(-1)
    if arr.shape != (4,):
        raise ValueError(f"box must be 4 numbers (x, y, w, h), got shape {np.shape(box)}")
    x, y, w, h = (float(v) for v in arr)
    return (x, y, w, h)


def _frame(frame: npt.ArrayLike) -> np.ndarray:
    arr = np.asarray(frame)
    if arr.dtype != np.uint8:
        raise TypeError(f"frame must have dtype uint8, got {arr.dtype}")
    return arr


def _plain(value: Any) -> Any:
    """numpy scalars and arrays as Python numbers and lists, as the config reader wants."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, (np.ndarray, list, tuple)):
        return [_plain(v) for v in value]
    return value


def _appearance(**values: Any) -> dict[str, Any]:
    return {k: _plain(v) for k, v in values.items()}


def _answer(native: tuple[Sequence[float], float, bool]) -> TrackResult:
    b, score, lost = native
    return TrackResult((b[0], b[1], b[2], b[3]), float(score), bool(lost))


class ColorHistogramTracker:
    """Birchfield's colour-histogram tracker (seed 000 section 3.2).

    An ellipse inscribed in the box models the target by a 3-D colour histogram
    (bimodal: upper and lower part, e.g. hair and skin). Each frame, every integer
    position within ``search_radius`` pixels of the predicted centre, at three scales,
    is scored by histogram intersection (eq. 28) — computed incrementally from the
    neighbouring ellipse — plus ``gradient_weight`` times the intensity gradient along
    the perimeter. The model adapts by eq. (29) with rate ``adaptation_rate`` when the
    match exceeds ``adaptation_threshold``.

    Parameters: ``color_space`` (``"hsv"``, ``"opponent"`` = the seed's (B-G, G-R,
    R+G+B), ``"rg"``, ``"rgb"``), ``bins`` per axis, ``model``, ``upper_fraction`` of the
    ellipse's rows in the upper part, ``lost_threshold`` (score below which the target
    is reported lost), ``search_radius`` (px), ``scale_step`` (relative), ``min_scale``
    and ``max_scale`` (relative to the first box), ``momentum`` (constant-velocity
    prediction, 0..1), ``parallel`` (search the scales on several threads; same result).

    Examples
    --------
    >>> import numpy as np
    >>> from rperc.tracking import ColorHistogramTracker
    >>> frame = np.full((60, 80, 3), 90, np.uint8); frame[22:38, 22:38] = (220, 30, 30)
    >>> tracker = ColorHistogramTracker(frame, [22, 22, 16, 16])
    >>> moved = np.roll(frame, 3, axis=1)
    >>> r = tracker.update(moved)
    >>> round(r.box[0]), r.lost
    (25, False)
    """

    def __init__(
        self,
        frame: npt.ArrayLike,
        box: Sequence[float] | npt.ArrayLike,
        *,
        color_space: ColorSpace = _APPEARANCE["color_space"],
        bins: Sequence[int] = tuple(_APPEARANCE["bins"]),
        model: ModelKind = _APPEARANCE["model"],
        upper_fraction: float = _APPEARANCE["upper_fraction"],
        adaptation_rate: float = _APPEARANCE["adaptation_rate"],
        adaptation_threshold: float = _APPEARANCE["adaptation_threshold"],
        gradient_weight: float = _APPEARANCE["gradient_weight"],
        lost_threshold: float = _APPEARANCE["lost_threshold"],
        search_radius: int = _COLOR["search_radius"],
        scale_step: float = _COLOR["scale_step"],
        min_scale: float = _COLOR["min_scale"],
        max_scale: float = _COLOR["max_scale"],
        momentum: float = _COLOR["momentum"],
        parallel: bool = _COLOR["parallel"],
    ) -> None:
        appearance = _appearance(
            color_space=color_space,
            bins=bins,
            model=model,
            upper_fraction=upper_fraction,
            adaptation_rate=adaptation_rate,
            adaptation_threshold=adaptation_threshold,
            gradient_weight=gradient_weight,
            lost_threshold=lost_threshold,
        )
        config = {
            "appearance": appearance,
            **_appearance(
                search_radius=search_radius,
                scale_step=scale_step,
                min_scale=min_scale,
                max_scale=max_scale,
                momentum=momentum,
                parallel=parallel,
            ),
        }
        self._native = _rperc.ColorHistogramTracker(_frame(frame), _box(box), config)
        self._last = TrackResult(_box(box), 1.0, False)

    def update(self, frame: npt.ArrayLike) -> TrackResult:
        """Find the target in the next frame."""
        self._last = _answer(self._native.update(_frame(frame)))
        return self._last

    @property
    def scale(self) -> float:
        """The current scale relative to the first box."""
        return self._native.scale

    def __repr__(self) -> str:
        return f"ColorHistogramTracker(last={self._last!r}, scale={self.scale:.3f})"


class ParticleColorTracker:
    """CONDENSATION over ``(x, y, scale)`` with the histogram-intersection likelihood
    (seed 000 section 3.3, seed 001 section 3.1): many hypotheses instead of one local
    search, for clutter and fast motion. Same appearance parameters as
    :class:`ColorHistogramTracker`, plus ``n_particles``, ``position_noise`` (random-walk
    standard deviation as a fraction of the box's mean semi-axis), ``scale_noise``,
    ``sigma`` of the likelihood ``exp(-(1 - score)^2 / 2 sigma^2)``, ``resampler``,
    ``resample_below`` (resample only when the ESS falls below this fraction; ``None``:
    every step, as the seed does), ``chunk_size`` and ``parallel``. A seed gives the
    same track on any number of threads.
    """

    def __init__(
        self,
        frame: npt.ArrayLike,
        box: Sequence[float] | npt.ArrayLike,
        *,
        seed: int = 0,
        n_particles: int = _PARTICLE["n_particles"],
        position_noise: float = _PARTICLE["position_noise"],
        scale_noise: float = _PARTICLE["scale_noise"],
        sigma: float = _PARTICLE["sigma"],
        min_scale: float = _PARTICLE["min_scale"],
        max_scale: float = _PARTICLE["max_scale"],
        resampler: ResamplerName = _FILTER["resampler"],
        resample_below: float | None = _FILTER["resample_below"],
        chunk_size: int = _FILTER["chunk_size"],
        parallel: bool = _FILTER["parallel"],
        color_space: ColorSpace = _APPEARANCE["color_space"],
        bins: Sequence[int] = tuple(_APPEARANCE["bins"]),
        model: ModelKind = _APPEARANCE["model"],
        upper_fraction: float = _APPEARANCE["upper_fraction"],
        adaptation_rate: float = _APPEARANCE["adaptation_rate"],
        adaptation_threshold: float = _APPEARANCE["adaptation_threshold"],
        gradient_weight: float = _APPEARANCE["gradient_weight"],
        lost_threshold: float = _APPEARANCE["lost_threshold"],
    ) -> None:
        appearance = _appearance(
            color_space=color_space,
            bins=bins,
            model=model,
            upper_fraction=upper_fraction,
            adaptation_rate=adaptation_rate,
            adaptation_threshold=adaptation_threshold,
            gradient_weight=gradient_weight,
            lost_threshold=lost_threshold,
        )
        config = {
            "appearance": appearance,
            "filter": _appearance(
                resampler=resampler,
                resample_below=resample_below,
                chunk_size=chunk_size,
                parallel=parallel,
            ),
            **_appearance(
                n_particles=n_particles,
                position_noise=position_noise,
                scale_noise=scale_noise,
                sigma=sigma,
                min_scale=min_scale,
                max_scale=max_scale,
            ),
        }
        seed = whole_number(seed, "seed", 0, limit=2**64)
        self._native = _rperc.ParticleColorTracker(_frame(frame), _box(box), seed, config)
        self._last = TrackResult(_box(box), 1.0, False)

    def update(self, frame: npt.ArrayLike) -> TrackResult:
        """One CONDENSATION step on the next frame."""
        self._last = _answer(self._native.update(_frame(frame)))
        return self._last

    @property
    def ess(self) -> float:
        """Effective sample size of the particle set."""
        return self._native.ess

    def __repr__(self) -> str:
        return f"ParticleColorTracker(last={self._last!r}, ess={self.ess:.1f})"


def resample(
    weights: npt.ArrayLike, n: int, method: ResamplerName = "systematic", seed: int = 0
) -> npt.NDArray[np.intp]:
    """Indices of ``n`` particles drawn from non-negative ``weights`` (need not sum to
    one), sorted ascending, by ``method``; seeded. The GIL is released."""
    count = whole_number(n, "n", 0)
    seed = whole_number(seed, "seed", 0, limit=2**64)
    return _rperc.resample(_weights(weights), count, method, seed)


def effective_sample_size(weights: npt.ArrayLike) -> float:
    """``(sum w)^2 / sum(w^2)`` of non-negative weights (normalised first): ``n`` for
    equal weights, 1 when one particle holds all the weight. Refuses the weights
    :func:`resample` refuses (empty, negative, NaN, all zero)."""
    return _rperc.effective_sample_size(_weights(weights))


def _weights(weights: npt.ArrayLike) -> np.ndarray:
    """Real numbers as float64; strings or complex numbers are a TypeError (numpy would
    parse ``"1"`` and drop an imaginary part without a word)."""
    arr = np.asarray(weights)
    if arr.dtype.kind not in "fiub":
        raise TypeError(f"weights must be real numbers, got dtype {arr.dtype}")
    return arr.astype(np.float64)


_SHAPE = _rperc.color_shape_defaults()


@dataclass(frozen=True)
class ColorShapeResult:
    """One :class:`ColorShapeTracker` answer: the target's ``contour`` (an (N, 2) array
    of ``(x, y)`` pixel coordinates, pixel centres at integers), its bounding ``box``
    ``(x, y, w, h)``, the estimated colour ``distribution`` ``(mR, mG, mB, l1, l2, l3,
    theta, phi)`` (centroid and principal spreads in colour units where each axis spans
    [0, 1), angles in radians), the best sample's weight ``score`` in [0, 1], whether the
    target is ``lost``, and the particle set's effective sample size ``ess``."""

    contour: np.ndarray
    box: Box
    distribution: tuple[float, ...]
    score: float
    lost: bool
    ess: float

    def __repr__(self) -> str:
        x, y, w, h = self.box
        state = "lost" if self.lost else "tracking"
        box = f"({x:.1f}, {y:.1f}, {w:.1f}, {h:.1f})"
        return f"ColorShapeResult(box={box}, score={self.score:.3f}, {state})"


class ColorShapeTracker:
    """Colour+shape tracker (seed 000 section 3.3): CONDENSATION over the target's colour
    distribution ``[m, lambda, theta, phi]`` (constant velocity). Each sample segments a
    window around the target with its histogram; the blob it yields (after an opening
    and a closing) gets an affine snake fitted from the previous contour, and the sample
    is weighted by ``exp(-rho^2 / 2 sigma^2)`` with ``rho = mu1 (1 - Phi_affine) + mu2 (1 -
    Phi_area) + mu3 (1 - Phi_quality)``: snake on the blob's boundary, area against the
    prediction, holes (Euler number). The best sample's contour is refined on the image
    edges masked by its blob's dilated boundary.

    Start from a ``contour`` (an (N, 2) polygon) or a ``box`` (its inscribed ellipse).
    ``color_space`` is ``"rgb"`` or ``"opponent"`` (B-G, G-R, R+G+B); ``config`` may hold
    any other field of the Rust ``ColorShapeParams`` (``rperc._rperc.color_shape_defaults()``
    lists them).
    """

    def __init__(
        self,
        frame: npt.ArrayLike,
        box: Sequence[float] | npt.ArrayLike | None = None,
        *,
        contour: npt.ArrayLike | None = None,
        color_space: Literal["rgb", "opponent"] = _SHAPE["color_space"],
        n_samples: int = _SHAPE["n_samples"],
        sigma: float = _SHAPE["sigma"],
        seed: int = 0,
        config: dict[str, Any] | None = None,
    ) -> None:
        if box is None and contour is None:
            raise ValueError("give a box (x, y, w, h) or a contour (N x 2)")
        cfg: dict[str, Any] = {k: _plain(v) for k, v in (config or {}).items()}
        cfg.update(
            color_space=color_space,
            n_samples=whole_number(n_samples, "n_samples", 1, limit=1_000_000),
            sigma=float(sigma),
            seed=whole_number(seed, "seed", 0, limit=2**64),
        )
        poly = None if contour is None else np.asarray(contour, dtype=np.float64)
        if poly is not None and (poly.ndim != 2 or poly.shape[1] != 2):
            raise ValueError(f"contour must have shape (N, 2), got {poly.shape}")
        bbox = None if box is None else _box(box)
        self._native = _rperc.ColorShapeTracker(_frame(frame), bbox, poly, cfg)
        self._last: ColorShapeResult | None = None

    def update(self, frame: npt.ArrayLike) -> ColorShapeResult:
        """One CONDENSATION step and contour refinement on the next frame."""
        contour, b, dist, score, lost, ess = self._native.update(_frame(frame))
        self._last = ColorShapeResult(
            contour, _box(b), tuple(float(v) for v in dist), float(score), bool(lost), ess
        )
        return self._last

    def __repr__(self) -> str:
        return f"ColorShapeTracker(last={self._last!r})"
