"""The 2-D pattern tracker of seed 001 (Ait Aider et al., section 3), typed.

A planar pattern (a ceiling light, a poster) is learnt from a region of the first
frame: Canny contours, approximated by Douglas-Peucker and sampled, each point with its
grey-level profile along the gradient (section 3.2). CONDENSATION over the state
``(x, y, theta, scale)`` (eq. 5) follows it, weighting every particle by the
inter-correlation of the stored and observed profiles (eq. 6), with occluded points
left out and a scale space per frame (section 3.3).

Conventions: frames are ``H x W`` or ``H x W x 3`` uint8 arrays; pixel centres are at
integer coordinates; ``theta`` is in radians, positive counter-clockwise as seen on
screen, the convention of OpenCV's ``getRotationMatrix2D``; ``scale`` is relative to the
initial region. The GIL is released while a frame is processed.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import numpy as np
import numpy.typing as npt

from rperc import _rperc
from rperc._args import seed_number
from rperc._config_base import as_config, as_config_moved
from rperc.config import (
    PatternConfig,
    PatternConfigOverrides,
    PatternSequenceConfig,
    PatternSequenceConfigOverrides,
)
from rperc.tracking.trackers import _plain

if TYPE_CHECKING:
    from typing_extensions import Unpack

#: The function approximating a point's auto-correlation whose inverse reads its
#: deviation (section 3.3): the seed's straight line, or a parabola (the default).
DeviationName = Literal["line", "parabola"]

#: The tracker's motion model: the seed's similarity ``(x, y, theta, scale)``, or the
#: 8-dof homography of a plane seen in perspective.
MotionName = Literal["similarity", "homography"]

#: The keywords PatternTracker took for fields of its nested parts before it took a
#: PatternConfig (issue 36), by the part and the field they set there. They still
#: work, with a DeprecationWarning, for one release.
_NESTED_KEYWORDS = {
    **{
        name: ("pattern", name)
        for name in (
            "canny_low",
            "canny_high",
            "max_points",
            "point_spacing",
            "n_samples",
            "delta",
            "occlusion_threshold",
            "max_occluded_fraction",
            "deviation",
        )
    },
    "likelihood_sigma": ("pattern", "sigma"),
    **{name: ("filter", name) for name in ("resampler", "chunk_size", "parallel")},
}


@dataclass(frozen=True, eq=False)
class PatternPose:
    """One answer of :class:`PatternTracker`.

    ``x, y``: the pattern centre (pixels); ``theta``: rotation (radians, CCW on screen);
    ``scale``: relative to the initial region; ``score``: the per-point geometric mean
    of the eq. 6 likelihood at the estimate, in (0, 1]; ``occluded_fraction``: the
    fraction of model points occluded there; ``lost``: the pose is the last one held
    (too many points occluded, e.g. an all-black frame); ``corners``: a read-only
    ``(4, 2)`` float64 array of the initial region's outer corners (top-left,
    top-right, bottom-right, bottom-left, on the pixel edges) moved by the pose,
    computed by the native tracker; ``homography``: a read-only ``(3, 3)`` float64
    array mapping first-frame pixels to this frame's (``H[2, 2] = 1``): the
    similarity's in similarity mode, the plane's in homography mode (in homography
    mode ``x, y, theta, scale`` are the similarity part of it at the region's centre:
    where the centre goes, the local rotation and the square root of the local area
    ratio). Two poses are equal when every field is, the arrays element by element.
    """

    x: float
    y: float
    theta: float
    scale: float
    score: float
    occluded_fraction: float
    lost: bool
    corners: npt.NDArray[np.float64]
    homography: npt.NDArray[np.float64]

    # The generated __eq__ would ask an array of comparisons for one truth value.
    __hash__ = None  # type: ignore[assignment]

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, PatternPose):
            return NotImplemented
        scalars = ("x", "y", "theta", "scale", "score", "occluded_fraction", "lost")
        return (
            all(getattr(self, f) == getattr(other, f) for f in scalars)
            and bool(np.array_equal(self.corners, other.corners))
            and bool(np.array_equal(self.homography, other.homography))
        )

    def corners_array(self) -> npt.NDArray[np.float64]:
        """A writable copy of the corners (for ``cv2.polylines`` after a cast)."""
        return np.array(self.corners, dtype=np.float64)


def _pose(native: _rperc.PatternAnswer) -> PatternPose:
    # The native answer's arrays are read-only: a pose handed out (and the track's
    # last) cannot be changed in place.
    return PatternPose(
        x=native.x,
        y=native.y,
        theta=native.theta,
        scale=native.scale,
        score=native.score,
        occluded_fraction=native.occluded_fraction,
        lost=native.lost,
        corners=native.corners,
        homography=native.homography,
    )


def _tree(value: object) -> object:
    """Nested dicts of numpy scalars and arrays as plain Python, for the config reader."""
    if isinstance(value, Mapping):
        return {k: _tree(v) for k, v in value.items()}
    return _plain(value)


def _given(config: Mapping[str, object] | None) -> dict[str, object] | None:
    return None if config is None else {str(k): _tree(v) for k, v in config.items()}


def _frame(frame: npt.ArrayLike) -> np.ndarray:
    arr = np.asarray(frame)
    if arr.dtype != np.uint8:
        raise TypeError(f"frame must have dtype uint8, got {arr.dtype}")
    return arr


def _region(region: Sequence[int] | npt.ArrayLike) -> tuple[int, int, int, int] | np.ndarray:
    arr = np.asarray(region)
    if arr.shape == (4, 2):
        if not np.issubdtype(arr.dtype, np.number):
            raise ValueError(f"region corners must be numbers, got dtype {arr.dtype}")
        return np.ascontiguousarray(arr, dtype=np.float64)
    if arr.dtype == np.bool_:
        if arr.ndim != 2:
            raise ValueError(f"region mask must be 2-D (H, W), got shape {arr.shape}")
        return np.ascontiguousarray(arr)
    flat = arr.reshape(-1)
    if flat.shape != (4,) or not np.issubdtype(flat.dtype, np.number):
        raise ValueError(
            f"region must be a box (x, y, w, h) or a boolean mask, got shape {arr.shape}"
        )
    if not np.all(np.isfinite(flat)) or np.any(flat != np.round(flat)):
        raise ValueError(f"region box must be whole pixels (x, y, w, h), got {flat.tolist()}")
    x, y, w, h = (int(v) for v in flat)
    return (x, y, w, h)


class PatternTracker:
    """CONDENSATION tracker of a planar pattern over ``(x, y, theta, scale)``, or over
    the plane's homography.

    ``region`` is a box ``(x, y, w, h)`` in 0-based pixels, a boolean mask of the
    frame's shape, or (homography mode only) a ``(4, 2)`` array of the four corners
    top-left, top-right, bottom-right, bottom-left on the outer pixel edges, which
    must bound a convex quad inside the frame. ``motion`` is ``"similarity"`` (the
    seed's, default) or ``"homography"``: the particles then search over the
    similarity with the model seen through the last frame's perspective, the
    estimate is refined by Gauss-Newton on the 8-dof homography over the model's
    profiles (eq. 6, Tukey weights on the profiles; ``occluded_fraction`` counts
    those weighed 0), and after a loss the whole frame is searched again on the
    coarse level. In homography mode the estimate is also lost when the gains of its
    unoccluded profiles spread more than ``lost_gain_spread`` (the median absolute
    deviation of their logarithms; clutter matching profiles by chance gives each its
    own gain, the pattern one for all). ``sigma`` is the random walk's ``(sigma_x,
    sigma_y, sigma_theta, sigma_s)`` in pixels, pixels, radians, scale (section 4.1: 5,
    5, 3 degrees, 0.1).
    ``refine_steps`` rounds of a local search refine the weighted mean on the same
    frame (0: the seed's plain mean), with steps starting at ``refine_first_step``
    sigmas and halved each round; with ``refined_particle`` the refined pose replaces
    the lightest particle, so that the next frame starts from it. All but the last
    ``refine_fine_rounds`` rounds weigh every other model point only (coarse);
    ``newton_steps`` Gauss-Newton steps of eq. 6 on every point then place the peak
    (kept only when they raise the likelihood; 0: the coordinate search alone). A frame
    scoring below ``second_look`` times the track's recent best score gets a second
    CONDENSATION iteration (half its particles around the last pose, twice as wide)
    and keeps the better estimate; 0 never.
    ``lost_occluded_fraction``: the estimate is lost above this occluded fraction.
    The ``pattern`` part (:class:`rperc.config.PatternModelConfig`: Canny thresholds,
    points, profile length ``n_samples`` and step ``delta``, likelihood ``sigma``,
    occlusion) is the model's; the ``filter`` part the particle filter's. ``deviation``
    (in ``pattern``) is the approximation ``C~`` of a point's
    auto-correlation whose inverse turns an inter-correlation into the deviation
    ``lambda``: ``"line"`` is the seed's, ``"parabola"`` (default) keeps ``lambda``
    proportional to a sub-sample offset where the line makes it grow as its square.
    A seed gives the same track on any number of threads. With ``filter.parallel`` a
    frame is processed on the thread pool only when particles times model points reaches
    ``parallel_min_work`` (default 100 000): below it, handing a frame to the pool
    and back costs more than two cores save.
    The coarse layer screens ``coarse_particles`` predicted states (the random walk
    widened by ``coarse_spread``) on a level ``coarse_factor`` times coarser, on at
    most ``coarse_points`` model points; the best ``coarse_refined`` are moved to their
    coarse peak by Gauss-Newton and the best ``coarse_kept`` become the particles
    weighed on the frame (``n_particles`` only without the layer): its wider basin
    finds steps of 3 sigma that the particles alone miss. 0 turns it off.

    ``config`` is a :class:`rperc.config.PatternConfig` (or a dict of its fields; its
    help lists every field with its default); keyword arguments override its fields
    (``n_particles=500``, ``motion="homography"``, ``pattern=...``), checked by the
    Rust crate when the tracker is made. ``seed`` seeds the particle filter.

    Examples
    --------
    >>> import numpy as np
    >>> from rperc.tracking import PatternTracker
    >>> frame = np.full((120, 160), 90, np.uint8)
    >>> frame[40:70, 50:90] = 200; frame[50:60, 60:75] = 30
    >>> tracker = PatternTracker(frame, (45, 35, 50, 40), seed=1)
    >>> pose = tracker.update(np.roll(frame, 3, axis=1))
    >>> round(pose.x - tracker.initial.x), pose.lost
    (3, False)
    """

    def __init__(
        self,
        frame: npt.ArrayLike,
        region: Sequence[int] | npt.ArrayLike,
        *,
        seed: int = 0,
        config: PatternConfig | Mapping[str, object] | None = None,
        **overrides: Unpack[PatternConfigOverrides],
    ) -> None:
        #: The tracker's settings, checked by the Rust crate when they were made.
        base = config if isinstance(config, PatternConfig) else _given(config)
        fields = {k: _tree(v) for k, v in overrides.items()}
        self.config: PatternConfig = as_config_moved(
            PatternConfig, base, fields, _NESTED_KEYWORDS, "PatternTracker"
        )
        native = _rperc.PatternTracker(
            _frame(frame), _region(region), seed_number(seed), self.config.to_dict()
        )
        self._native = native
        # The native tracker's own initial pose: its corners come from the one place
        # that maps a pose to corners, not from a second formula here.
        self.initial = _pose(native.last)
        self._last = self.initial

    def update(self, frame: npt.ArrayLike) -> PatternPose:
        """One CONDENSATION step on the next frame (same size as the first)."""
        self._last = _pose(self._native.update(_frame(frame)))
        return self._last

    @property
    def last(self) -> PatternPose:
        """The last answer (the initial pose before any update)."""
        return self._last

    @property
    def n_points(self) -> int:
        """Number of model points learnt from the region."""
        return self._native.n_points

    @property
    def model_offsets(self) -> npt.NDArray[np.float64]:
        """The model points' offsets ``(n, 2)`` from the region's centre, in pixels of
        the region at scale 1 (of the rectified quad for a corners region)."""
        return self._native.model_offsets

    def __repr__(self) -> str:
        p = self._last
        state = "lost" if p.lost else "tracking"
        return (
            f"PatternTracker(x={p.x:.1f}, y={p.y:.1f}, theta={p.theta:.3f}, "
            f"scale={p.scale:.3f}, {state}, {self.n_points} points)"
        )


@dataclass(frozen=True)
class PatternSequence:
    """A generated sequence (seed 001 section 4.1, Fig. 8) and its ground truth.

    ``frames``: ``(n, H, W)`` uint8; ``truth``: ``(n, 4)`` states ``(x, y, theta,
    scale)`` in the tracker's convention; ``occlusion``: the hidden fraction of the
    patch per frame; ``illumination``: ``(n, 2)`` gain and offset; ``region``: the box
    ``(x, y, w, h)`` the patch fills in frame 0 (give it to :class:`PatternTracker`).
    """

    frames: npt.NDArray[np.uint8]
    truth: npt.NDArray[np.float64]
    occlusion: npt.NDArray[np.float64]
    illumination: npt.NDArray[np.float64]
    region: tuple[int, int, int, int]


def pattern_sequence(
    patch: npt.ArrayLike,
    background: npt.ArrayLike,
    *,
    config: PatternSequenceConfig | Mapping[str, object] | None = None,
    size: tuple[int, int] | None = None,
    **overrides: Unpack[PatternSequenceConfigOverrides],
) -> PatternSequence:
    """The Fig. 8 experiment's sequence: ``patch`` (2-D grey levels) moved along a seeded
    trajectory over ``background`` (2-D, moving by ``background_speed`` px/frame).

    Frame ``k >= 1`` steps component ``(k - 1) % 4`` (x, y, theta, s) uniformly in
    ``[-max_step_sigmas sigma, +max_step_sigmas sigma]`` and the others within
    ``other_step_sigmas sigma``; a band of clutter hides up to ``max_occlusion`` of the
    patch; the whole frame gets ``gain * g + offset`` (uniform in the ranges) and
    Gaussian ``noise``. ``config`` is a :class:`rperc.config.PatternSequenceConfig` (or
    a dict of its fields); keyword arguments override its fields (``n_frames``,
    ``width``, ``height``, ``seed``, ...). ``size=(width, height)`` is deprecated. The
    GIL is released.
    """
    fields = {k: _tree(v) for k, v in overrides.items()}
    if size is not None:
        warnings.warn(
            "pattern_sequence(size=(w, h)) is deprecated; use width=w, height=h",
            DeprecationWarning,
            stacklevel=2,
        )
        fields.update(width=_tree(size[0]), height=_tree(size[1]))
    if "seed" in fields:
        fields["seed"] = seed_number(fields["seed"])
    base = config if isinstance(config, PatternSequenceConfig) else _given(config)
    cfg = as_config(PatternSequenceConfig, base, fields)
    p = np.asarray(patch, dtype=np.float64)
    b = np.asarray(background, dtype=np.float64)
    seq = _rperc.pattern_sequence(p, b, cfg.to_dict())
    return PatternSequence(seq.frames, seq.truth, seq.occlusion, seq.illumination, seq.region)
