"""The colour-histogram trackers, typed: keyword parameters with the defaults of the
Rust configs, and :class:`TrackResult` answers.

Both follow OpenCV's convention: construct on the first frame and a box, then call
``update(frame)`` for every next frame. Frames are ``H x W x 3`` uint8 RGB arrays
(``channels="bgr"`` takes OpenCV's BGR frames as they are; ``H x W`` greyscale frames
are accepted too); boxes are ``(x, y, w, h)`` in pixels with a 0-based top-left corner,
given as a tuple, a list or an array. A first box partly outside the frame is clipped
to it with a warning (OTB ground truth has such boxes); a box of zero size, or one
wholly outside the frame, is a ``ValueError``. :func:`opencv` wraps a tracker in
OpenCV's ``init(frame, box)`` / ``update(frame) -> (ok, box)`` protocol. The GIL is
released while a frame is processed.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Generic, Literal, Protocol, TypeVar, cast

import numpy as np
import numpy.typing as npt

from rperc import _rperc
from rperc._args import excerpt, seed_number, whole_number
from rperc._config_base import C, as_config_moved
from rperc.config import (
    ColorHistogramConfig,
    ColorHistogramConfigOverrides,
    ColorShapeConfig,
    ColorShapeConfigOverrides,
    ColorTemplateConfig,
    ColorTemplateConfigOverrides,
    ParticleColorConfig,
    ParticleColorConfigOverrides,
)

if TYPE_CHECKING:
    from typing_extensions import Unpack

ColorSpace = Literal["hsv", "opponent", "rg", "rgb"]
ModelKind = Literal["bimodal", "single"]
ResamplerName = Literal["systematic", "multinomial", "stratified", "residual"]
Channels = Literal["rgb", "bgr"]
Box = tuple[float, float, float, float]

#: The keywords the histogram trackers took for the fields of their nested parts before
#: they took a config (issue 36), by the part and the field they set: they still work,
#: with a DeprecationWarning, for one release.
_APPEARANCE_KEYWORDS = {
    name: ("appearance", name)
    for name in (
        "color_space",
        "bins",
        "model",
        "upper_fraction",
        "adaptation_rate",
        "adaptation_threshold",
        "gradient_weight",
        "lost_threshold",
    )
}
_FILTER_KEYWORDS = {
    name: ("filter", name) for name in ("resampler", "resample_below", "chunk_size", "parallel")
}


@dataclass(frozen=True)
class TrackResult:
    """One tracker answer: the target's ``box`` ``(x, y, w, h)`` in pixels, its
    ``score`` (histogram intersection with the model, seed 000 eq. 28, in [0, 1]) and
    whether the target is ``lost`` (score below ``lost_threshold``). Unpacks as
    ``box, score, lost = result``."""

    box: Box
    score: float
    lost: bool

    def __iter__(self) -> Iterator[Box | float | bool]:
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


def _frame(frame: npt.ArrayLike, channels: Channels = "rgb") -> np.ndarray:
    """An ``H x W x 3`` uint8 RGB array from an RGB or BGR colour frame or an ``H x W``
    (or ``H x W x 1``) greyscale one."""
    arr = np.asarray(frame)
    if arr.dtype != np.uint8:
        raise TypeError(f"frame must have dtype uint8, got {arr.dtype}")
    if arr.ndim == 2 or (arr.ndim == 3 and arr.shape[2] == 1):
        grey = arr.reshape(arr.shape[0], arr.shape[1], 1)
        return np.ascontiguousarray(np.broadcast_to(grey, (*grey.shape[:2], 3)))
    if arr.ndim != 3 or arr.shape[2] != 3:
        raise ValueError(
            f"frame must have shape (H, W, 3) (colour) or (H, W) (greyscale), got {arr.shape}"
        )
    if channels == "bgr":
        return np.ascontiguousarray(arr[:, :, ::-1])
    return arr


def _channels(channels: str) -> Channels:
    if channels == "rgb":
        return "rgb"
    if channels == "bgr":
        return "bgr"
    raise ValueError(f"channels must be 'rgb' or 'bgr', got {excerpt(channels)}")


def _first_box(box: Sequence[float] | npt.ArrayLike, frame: np.ndarray) -> Box:
    """The initial box, clipped to the frame with a warning when it overhangs it.
    A box of zero size or wholly outside the frame is refused."""
    x, y, w, h = _box(box)
    if not all(math.isfinite(v) for v in (x, y, w, h)):
        raise ValueError(f"box must be finite numbers, got {(x, y, w, h)}")
    if w <= 0 or h <= 0:
        raise ValueError(f"box has zero or negative size (w={w}, h={h}); need w, h >= 1 px")
    height, width = frame.shape[:2]
    if x >= 0 and y >= 0 and x + w <= width and y + h <= height:
        return (x, y, w, h)
    x0, y0 = max(x, 0.0), max(y, 0.0)
    x1, y1 = min(x + w, float(width)), min(y + h, float(height))
    if x1 - x0 < 1 or y1 - y0 < 1:
        raise ValueError(
            f"box {(x, y, w, h)} leaves less than 1 px inside the {width} x {height} frame"
        )
    clipped = (x0, y0, x1 - x0, y1 - y0)
    warnings.warn(
        f"box {(x, y, w, h)} is partly outside the {width} x {height} frame; clipped to {clipped}",
        UserWarning,
        stacklevel=3,
    )
    return clipped


def _plain(value: Any) -> Any:
    """numpy scalars and arrays as Python numbers and lists, as the config reader wants."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, (np.ndarray, list, tuple)):
        return [_plain(v) for v in value]
    return value


def _given(config: Mapping[str, object] | None) -> dict[str, object] | None:
    """A dict of config fields with numpy values as Python ones."""
    return None if config is None else {str(k): _plain(v) for k, v in config.items()}


#: The trackers that never took flat keywords for their nested parts.
_NOTHING_MOVED: Mapping[str, tuple[str, str]] = {}


def _settings(
    cls: type[C],
    config: C | Mapping[str, object] | None,
    overrides: Mapping[str, object],
    owner: str,
    moved: Mapping[str, tuple[str, str]] = _NOTHING_MOVED,
) -> C:
    """A tracker's config, the one way every tracker reads it: ``config`` (a ``cls``, a
    dict of its fields or ``None``) with the keyword ``overrides`` on top, numpy values
    as Python ones, checked by the Rust crate. The old flat keywords of ``moved`` still
    set their nested fields, with a DeprecationWarning at the tracker's caller."""
    if not isinstance(config, cls):
        # mypy does not narrow a type variable by isinstance: the cast says what is left.
        config = _given(cast("Mapping[str, object] | None", config))
    fields = {k: _plain(v) for k, v in overrides.items()}
    # 4: as_config_moved, this, the tracker's constructor, then its caller.
    return as_config_moved(cls, config, fields, moved, owner, stacklevel=4)


@dataclass(frozen=True, repr=False)
class ColorTemplateResult(TrackResult):
    """A :class:`ColorTemplateTracker` answer: the :class:`TrackResult` (``score`` is the
    merged response's peak clamped to [0, 1]) and the signals ``lost`` is decided from:
    the merged response's ``peak``, the template's correlation response's peak-to-
    sidelobe ratio ``psr`` (MOSSE) and average peak-to-correlation energy ``apce``
    (LMCF), ``color_score``, the colour model's mean foreground probability over the
    box, in [0, 1], and ``contrast``, the first frame's colour model's mean foreground
    probability over the box minus its mean over the rest of the search window, in
    [-1, 1] (near or under 0 once the box has drifted onto the background). Unpacks as
    ``box, score, lost = result``."""

    peak: float
    psr: float
    apce: float
    color_score: float
    contrast: float

    def __repr__(self) -> str:
        base = super().__repr__()[len("TrackResult(") : -1]
        return (
            f"ColorTemplateResult({base}, psr={self.psr:.1f}, apce={self.apce:.1f}, "
            f"color_score={self.color_score:.3f}, contrast={self.contrast:.3f})"
        )


_Native = _rperc.TrackAnswer | _rperc.ColorTemplateAnswer


def _answer(native: _Native) -> TrackResult:
    if isinstance(native, _rperc.ColorTemplateAnswer):
        return _template_answer(native)
    return TrackResult(native.box, native.score, native.lost)


def _template_answer(native: _rperc.ColorTemplateAnswer) -> ColorTemplateResult:
    x, y, w, h = native.box
    return ColorTemplateResult(
        (x, y, w, h),
        native.score,
        native.lost,
        native.peak,
        native.psr,
        native.apce,
        native.color_score,
        native.contrast,
    )


class _NativeBox(Protocol):
    def update(self, frame: npt.NDArray[np.uint8]) -> _Native: ...


_Tracker = TypeVar("_Tracker", bound=_NativeBox)


class _BoxTracker(Generic[_Tracker]):
    """What the box trackers share: the frame rule, the first box and the update."""

    _native: _Tracker
    _channels: Channels
    _last: TrackResult

    def _start(
        self,
        frame: npt.ArrayLike,
        box: Sequence[float] | npt.ArrayLike,
        channels: str,
        make: Callable[[np.ndarray, Box], _Tracker],
    ) -> None:
        self._channels = _channels(channels)
        first = _frame(frame, self._channels)
        start = _first_box(box, first)
        self._native = make(first, start)
        self._last = TrackResult(start, 1.0, False)

    def update(self, frame: npt.ArrayLike) -> TrackResult:
        """Track the target into the next frame."""
        self._last = _answer(self._native.update(_frame(frame, self._channels)))
        return self._last


class ColorHistogramTracker(_BoxTracker[_rperc.ColorHistogramTracker]):
    """Birchfield's colour-histogram tracker (seed 000 section 3.2).

    An ellipse inscribed in the box models the target by a 3-D colour histogram
    (bimodal: upper and lower part, e.g. hair and skin). Each frame, every integer
    position within ``search_radius`` pixels of the predicted centre, at three scales,
    is scored by histogram intersection (eq. 28) — computed incrementally from the
    neighbouring ellipse — plus ``gradient_weight`` times the intensity gradient along
    the perimeter. The model adapts by eq. (29) with rate ``adaptation_rate`` when the
    match exceeds ``adaptation_threshold``.

    ``config`` is a :class:`rperc.config.ColorHistogramConfig` (or a dict of its fields;
    its help lists every field with its default); keyword arguments override its
    fields, checked by the Rust crate when the tracker is made. Its ``appearance`` part
    (:class:`rperc.config.AppearanceParams`): ``color_space`` (``"hsv"``,
    ``"opponent"`` = the seed's (B-G, G-R, R+G+B), ``"rg"``, ``"rgb"``), ``bins`` per
    axis, ``model``, ``upper_fraction`` of the ellipse's rows in the upper part,
    ``lost_threshold`` (score below which the target is reported lost). Its own fields:
    ``search_radius`` (px, when still), ``velocity_gain`` (the window
    grows by this times the estimated speed), ``max_search_radius`` (px; also the widest
    search while lost), ``lost_ratio`` (lost below this fraction of the running
    confident score), ``lost_contrast`` (lost when the box's foreground probability
    exceeds the ring's around it by less than this), ``ring_weight`` (weight of that
    contrast when the scales compete), ``scale_prior`` (weight of ``ln(s /
    s_confident)^2``), ``scale_step`` (relative), ``min_scale`` and ``max_scale``
    (relative to the first box), ``momentum`` (constant-velocity prediction, 0..1),
    ``pyramid`` (search a 2 x 2-averaged frame first, then refine the best position at
    full resolution; used while both semi-axes are at least 8 px), ``parallel``
    (search the scales on several threads; same result). ``channels``: ``"rgb"``, or
    ``"bgr"`` for OpenCV frames.

    When the target is lost (:attr:`TrackResult.lost`) the box stays where it was last
    seen and the search window doubles every frame (up to ``max_search_radius``) until
    the target is found again; a single-colour frame (all black) is lost.

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
        config: ColorHistogramConfig | Mapping[str, object] | None = None,
        channels: Channels = "rgb",
        **overrides: Unpack[ColorHistogramConfigOverrides],
    ) -> None:
        #: The tracker's settings, checked by the Rust crate when they were made.
        self.config = _settings(
            ColorHistogramConfig, config, overrides, "ColorHistogramTracker", _APPEARANCE_KEYWORDS
        )
        native = self.config.to_dict()
        self._start(
            frame,
            box,
            channels,
            lambda first, start: _rperc.ColorHistogramTracker(first, start, native),
        )

    @property
    def scale(self) -> float:
        """The current scale relative to the first box."""
        return self._native.scale

    @property
    def search_radius(self) -> int:
        """Half-size in pixels of the next frame's search window: ``search_radius``
        grown with the estimated speed, or widened while the target is lost."""
        return self._native.search_radius

    @property
    def lost_frames(self) -> int:
        """Frames in a row the target has been lost (0 while it is tracked)."""
        return self._native.lost_frames

    def __repr__(self) -> str:
        return f"ColorHistogramTracker(last={self._last!r}, scale={self.scale:.3f})"


class ParticleColorTracker(_BoxTracker[_rperc.ParticleColorTracker]):
    """CONDENSATION over ``(x, y, scale)`` with the histogram-intersection likelihood
    (seed 000 section 3.3, seed 001 section 3.1): many hypotheses instead of one local
    search, for clutter and fast motion. ``config`` is a
    :class:`rperc.config.ParticleColorConfig` (or a dict of its fields), its fields
    also keyword overrides: the same ``appearance`` part as
    :class:`ColorHistogramTracker`, ``n_particles``, ``position_noise`` (random-walk
    standard deviation as a fraction of the box's mean semi-axis), ``scale_noise``,
    ``sigma`` of the likelihood ``exp(-(1 - score)^2 / 2 sigma^2)``, ``mix_fraction``
    (share of the particles redrawn each frame around the best centre of a coarse
    local search within ``search_radius`` px, grown by ``velocity_gain`` times the
    estimated speed up to ``max_search_radius``: a mixture proposal that keeps
    particles on a target that jumped; 0 is plain CONDENSATION), and the ``filter``
    part: ``resampler``, ``resample_below`` (resample only when the ESS falls below this
    fraction; ``None``: every step, as the seed does), ``chunk_size``, ``parallel``. A
    seed gives the same track on any number of threads.
    """

    def __init__(
        self,
        frame: npt.ArrayLike,
        box: Sequence[float] | npt.ArrayLike,
        *,
        seed: int = 0,
        config: ParticleColorConfig | Mapping[str, object] | None = None,
        channels: Channels = "rgb",
        **overrides: Unpack[ParticleColorConfigOverrides],
    ) -> None:
        moved = {**_APPEARANCE_KEYWORDS, **_FILTER_KEYWORDS}
        #: The tracker's settings, checked by the Rust crate when they were made.
        self.config = _settings(
            ParticleColorConfig, config, overrides, "ParticleColorTracker", moved
        )
        native = self.config.to_dict()
        seed = seed_number(seed)
        self._start(
            frame,
            box,
            channels,
            lambda first, start: _rperc.ParticleColorTracker(first, start, seed, native),
        )

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
    seed = seed_number(seed)
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


TemplateColorSpace = Literal["hsv", "opponent", "rg", "rgb"]


class ColorTemplateTracker(_BoxTracker[_rperc.ColorTemplateTracker]):
    """The colour + template tracker (issue 34), after Staple (Bertinetto et al. 2016):
    a correlation filter on HOG + intensity cells (``learning_rate``, ``lambda_``,
    ``output_sigma_factor``, ``cell_size``) merged with the per-pixel foreground
    probability of the seed's colour histograms (``color_space``, ``bins``,
    ``color_learning_rate``, ``inner_padding``) with weight ``merge_factor``, in a
    search window ``padding`` times the target's mean side larger than it, resampled
    to about ``template_size`` squared pixels. DSST's scale filter (``n_scales``,
    ``scale_step``, ``scale_learning_rate``, ``scale_sigma``, ``scale_model_area``)
    re-sizes the box within ``min_scale..max_scale`` of the first. The target is
    ``lost`` when the merged response's peak falls under ``lost_ratio`` times its
    running level over the tracked frames (learning fades out on the way down from the
    level to there), when the template response's peak-to-sidelobe ratio falls under
    ``lost_psr_ratio`` times its level, or when the colour score falls under
    ``lost_color_ratio`` times its level (each ratio 0 turns its test off), or, when
    ``lost_contrast_ratio`` is set, when the seed's colour contrast (the first frame's
    colour model inside the box against the rest of the window) falls under it times
    its mean over the first tracked frames, a lost target being found again only once
    it is back over ``found_contrast_ratio`` times that mean (the answer, a
    :class:`ColorTemplateResult`, carries these signals). While lost, a window whose
    seed contrast reaches ``refind_contrast_ratio`` times that mean is the target again
    whatever its peak. The models then stop
    learning, the levels sink by the factor ``lost_level_decay`` a frame, the box
    moves ``lost_motion`` of the way to the peak (0 keeps it where the target was last
    seen, 1 follows the peak), and each frame searches a grid of windows
    ``redetect_step`` window sizes apart, ``redetect_radius`` steps each way (a region
    about 2.5 windows wide); a distant window, re-centred on its peak, is taken when it
    passes the same rule and its peak reaches ``redetect_ratio`` times the level.

    ``config`` is a :class:`rperc.config.ColorTemplateConfig` (or a dict of its fields;
    its help lists every field with its default); keyword arguments override its
    fields, checked by the Rust crate when the tracker is made. ``seed`` is accepted
    for the trackers' common signature; nothing is random. Defaults were chosen by
    leave-one-sequence-out over the ten dev OTB sequences.

    Examples
    --------
    >>> import numpy as np
    >>> from rperc.tracking import ColorTemplateTracker
    >>> rng = np.random.default_rng(0)
    >>> frame = np.full((60, 80, 3), 90, np.uint8)
    >>> frame[22:38, 22:38] = rng.integers(150, 255, (16, 16, 3), dtype=np.uint8)
    >>> tracker = ColorTemplateTracker(frame, [22, 22, 16, 16])
    >>> r = tracker.update(np.roll(frame, 3, axis=1))
    >>> round(r.box[0]), r.lost
    (25, False)
    """

    def __init__(
        self,
        frame: npt.ArrayLike,
        box: Sequence[float] | npt.ArrayLike,
        *,
        seed: int = 0,
        config: ColorTemplateConfig | Mapping[str, object] | None = None,
        channels: Channels = "rgb",
        **overrides: Unpack[ColorTemplateConfigOverrides],
    ) -> None:
        #: The tracker's settings, checked by the Rust crate when they were made.
        self.config = _settings(ColorTemplateConfig, config, overrides, "ColorTemplateTracker")
        native = self.config.to_dict()
        seed = seed_number(seed)
        self._start(
            frame,
            box,
            channels,
            lambda first, start: _rperc.ColorTemplateTracker(first, start, seed, native),
        )

    def update(self, frame: npt.ArrayLike) -> ColorTemplateResult:
        """Track the target into the next frame."""
        result = _template_answer(self._native.update(_frame(frame, self._channels)))
        self._last = result
        return result

    @property
    def scale(self) -> float:
        """The current scale relative to the first box."""
        return self._native.scale

    @property
    def lost_frames(self) -> int:
        """Frames in a row the target has been lost (0 while it is tracked)."""
        return self._native.lost_frames

    def __repr__(self) -> str:
        return f"ColorTemplateTracker(last={self._last!r}, scale={self.scale:.3f})"


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
    window around the predicted contour with its histogram (``H(n) > 0``, on a grid of
    about ``sample_cells`` cells across the target); the blob reconstructed from the
    prediction within the snake's reach (after an opening and a closing, and split at
    narrow necks when it grew too big) gets an affine snake fitted from the previous
    contour, and the sample is weighted by ``exp(-rho^2 / 2 sigma^2)`` with ``rho = mu1 (1 -
    Phi_affine) + mu2 (1 - Phi_area) + mu3 (1 - Phi_quality)``: snake on the blob's
    boundary, area against the prediction, holes (Euler number). The best sample's
    contour is refined on the image edges masked by its blob's dilated boundary and may
    relax ``deform`` pixels off the affine fit. A tenth of the samples are drawn around the
    colours measured inside the last contour and the first frame's. When lost, the window
    widens every frame and samples look for the blob most like the target in area and
    principal spreads.

    Start from a ``contour`` (an (N, 2) polygon) or a ``box`` (its inscribed ellipse).
    ``config`` is a :class:`rperc.config.ColorShapeConfig` (or a dict of its fields);
    keyword arguments override its fields (``color_space`` ``"rgb"`` or ``"opponent"``
    (B-G, G-R, R+G+B), ``n_samples``, ``sigma``, ``seed``, ...), checked by the Rust
    crate when the tracker is made.
    """

    def __init__(
        self,
        frame: npt.ArrayLike,
        box: Sequence[float] | npt.ArrayLike | None = None,
        *,
        contour: npt.ArrayLike | None = None,
        config: ColorShapeConfig | Mapping[str, object] | None = None,
        channels: Channels = "rgb",
        **overrides: Unpack[ColorShapeConfigOverrides],
    ) -> None:
        if box is None and contour is None:
            raise ValueError("give a box (x, y, w, h) or a contour (N x 2)")
        #: The tracker's settings, checked by the Rust crate when they were made.
        self.config = _settings(ColorShapeConfig, config, overrides, "ColorShapeTracker")
        cfg = self.config.to_dict()
        poly = None if contour is None else np.asarray(contour, dtype=np.float64)
        if poly is not None and (poly.ndim != 2 or poly.shape[1] != 2):
            raise ValueError(f"contour must have shape (N, 2), got {poly.shape}")
        self._channels = _channels(channels)
        first = _frame(frame, self._channels)
        bbox = None if box is None else _first_box(box, first)
        self._native = _rperc.ColorShapeTracker(first, bbox, poly, cfg)
        self._last: ColorShapeResult | None = None

    def update(self, frame: npt.ArrayLike) -> ColorShapeResult:
        """One CONDENSATION step and contour refinement on the next frame."""
        a = self._native.update(_frame(frame, self._channels))
        self._last = ColorShapeResult(a.contour, a.box, a.distribution, a.score, a.lost, a.ess)
        return self._last

    def __repr__(self) -> str:
        return f"ColorShapeTracker(last={self._last!r})"


def color_segment(
    frame: npt.ArrayLike,
    colours: npt.ArrayLike,
    *,
    color_space: Literal["rgb", "opponent"] = "opponent",
    bins: Sequence[int] = (16, 16, 16),
    morphology_radius: int = 1,
) -> tuple[np.ndarray, np.ndarray]:
    """The colour+shape tracker's segmentation of a whole ``frame`` (H x W x 3 uint8 RGB)
    by the histogram of ``colours`` (seed 000 section 3.3): an (N, 3) cloud in the colour
    space's coordinates in ``[0, 1)`` (RGB: ``v / 256``; opponent: ``((B - G + 255) / 511,
    (G - R + 255) / 511, (R + G + B) / 766)``), binned ``bins`` per axis (colours outside
    ``[0, 1)`` left out); a pixel is in when its bin holds a colour. Returns the raw
    segmentation and the one cleaned by an opening then a closing with the square of
    half-side ``morphology_radius``, both (H, W) bool."""
    cloud = np.asarray(colours, dtype=np.float64)
    if cloud.ndim != 2 or cloud.shape[1] != 3:
        raise ValueError(f"colours must have shape (N, 3), got {cloud.shape}")
    b = [whole_number(v, "bins", 1, limit=64) for v in bins]
    if len(b) != 3:
        raise ValueError(f"bins must hold 3 counts, got {len(b)}")
    radius = whole_number(morphology_radius, "morphology_radius", 0, limit=255)
    raw, cleaned = _rperc.color_segment(
        _frame(frame), np.ascontiguousarray(cloud), color_space, (b[0], b[1], b[2]), radius
    )
    return raw != 0, cleaned != 0


TrackerName = Literal["color-template", "color", "color-pf", "color-shape"]


class Updates(Protocol):
    """A tracker once made: ``update(frame)`` answers a box, a score and ``lost``."""

    def update(self, frame: npt.ArrayLike) -> TrackResult | ColorShapeResult: ...


#: A tracker class: called with the first frame, the box and its own keyword options.
TrackerClass = Callable[..., Updates]

_BY_NAME: dict[str, TrackerClass] = {
    "color-template": ColorTemplateTracker,
    "color": ColorHistogramTracker,
    "color-pf": ParticleColorTracker,
    "color-shape": ColorShapeTracker,
}


class OpenCVTracker:
    """One of rperc's trackers behind OpenCV's tracker protocol (``cv2.TrackerCSRT``
    and friends): ``init(frame, box)`` then ``update(frame) -> (ok, box)``, frames in
    BGR order by default, ``box`` an integer ``(x, y, w, h)`` as OpenCV's ``Rect``
    (so it goes straight into ``cv2.rectangle``). ``ok`` is ``False`` when the tracker
    reports the target lost; the box is then where the target was last seen. The
    full answer (float box, score) of the last call is :attr:`last`. Made by
    :func:`opencv`."""

    def __init__(self, kind: TrackerClass, channels: Channels, options: dict[str, object]) -> None:
        self._kind = kind
        self._channels = channels
        self._options = options
        self._tracker: Updates | None = None
        self.last: TrackResult | ColorShapeResult | None = None

    def init(self, frame: npt.ArrayLike, box: Sequence[float] | npt.ArrayLike) -> None:
        """Start (or restart) tracking ``box`` in ``frame``."""
        self._tracker = self._kind(frame, box, channels=self._channels, **self._options)
        self.last = None

    def update(self, frame: npt.ArrayLike) -> tuple[bool, tuple[int, int, int, int]]:
        """Track into ``frame``: ``(ok, (x, y, w, h))`` with integer pixels."""
        if self._tracker is None:
            raise RuntimeError("call init(frame, box) before update(frame)")
        r = self._tracker.update(frame)
        self.last = r
        x, y, w, h = (round(v) for v in r.box)
        return (not r.lost, (x, y, max(w, 1), max(h, 1)))

    def __repr__(self) -> str:
        name = getattr(self._kind, "__name__", repr(self._kind))
        return f"OpenCVTracker({name}, channels={self._channels!r})"


def opencv(
    tracker: TrackerName | type = "color-template", *, channels: Channels = "bgr", **options: object
) -> OpenCVTracker:
    """An OpenCV-style tracker: ``t = opencv("color"); t.init(frame, box);
    ok, box = t.update(frame)``. ``tracker`` is ``"color-template"`` (the default),
    ``"color"``, ``"color-pf"``, ``"color-shape"`` or one of the tracker classes;
    ``options`` are its keyword parameters (checked by its config). Frames are BGR
    (OpenCV's order) unless ``channels="rgb"``.

    Examples
    --------
    >>> import numpy as np
    >>> from rperc.tracking import opencv
    >>> frame = np.full((60, 80, 3), 90, np.uint8); frame[22:38, 22:38] = (30, 30, 220)
    >>> t = opencv("color")
    >>> t.init(frame, (22, 22, 16, 16))
    >>> ok, (x, y, w, h) = t.update(np.roll(frame, 3, axis=1))
    >>> ok, x, y
    (True, 25, 22)
    """
    if isinstance(tracker, str):
        if tracker not in _BY_NAME:
            raise ValueError(
                f"tracker must be one of {', '.join(_BY_NAME)}, got {excerpt(tracker)}"
            )
        kind = _BY_NAME[tracker]
    elif tracker in _BY_NAME.values():
        kind = tracker
    else:
        raise TypeError(f"tracker must be a name or an rperc tracker class, got {excerpt(tracker)}")
    return OpenCVTracker(kind, _channels(channels), options)
