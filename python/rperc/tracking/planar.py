"""A planar-tracking harness with the field's metrics (POT-210, UCSB), run on the
generated sequences of :func:`rperc.tracking.pattern_sequence`.

Metrics, per frame after the first:

- the alignment error: the RMS distance of the four corners of the tracked region
  from their true positions, ``sqrt(mean_i |c_i - c*_i|^2)`` (pixels);
- the corner error: their mean distance, ``mean_i |c_i - c*_i|`` (pixels), issue 35's
  reading of POT-210's alignment error; :func:`pot_score` gives its mean and the
  precision at 5 and 15 px over the frames a sequence flags visible;
- precision at ``t`` pixels: the fraction of frames whose alignment error is at most
  ``t`` (reported at 5 and 15 px); the success curve is the precision at every
  threshold of :data:`ALIGNMENT_THRESHOLDS`, its area the mean over them;
- the centre error, for trackers that report a position only (CSRT);
- frames per second, each tracker timed in the same run on the same frames.

Trackers (OpenCV ones only when ``cv2`` is installed): the seed's pattern tracker;
``findTransformECC`` with Euclidean and affine motion, pyramid-initialised (three
levels, coarse to fine), its exceptions caught and counted as failures (the frame keeps
the coarser estimate); ``matchTemplate`` searching rotations and scales around the last
estimate; and CSRT, position only.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from rperc._extras import require
from rperc.tracking.pattern import PatternSequence, PatternTracker, pattern_sequence

if TYPE_CHECKING:
    from typing_extensions import Unpack

    from rperc.config import PatternConfigOverrides

#: Alignment-error thresholds of the success curve, pixels.
ALIGNMENT_THRESHOLDS = np.arange(0.0, 20.5, 0.5)

SIGMA = (5.0, 5.0, math.radians(3.0), 0.1)

Region = tuple[int, int, int, int]

#: Angles searched by :func:`run_match_template` around the last estimate (radians).
TEMPLATE_ANGLES = tuple(math.radians(d) for d in (-6, -3, 0, 3, 6))


def _cv2() -> Any:
    """OpenCV (the ``opencv`` extra): the clutter generator and the peers use it."""
    return require("cv2", "the planar-pattern generator and its OpenCV peers")


def region_offsets(region: Region) -> npt.NDArray[np.float64]:
    """The region's outer corners (top-left, top-right, bottom-right, bottom-left, on
    the pixel edges) relative to its centre ``(x + (w - 1) / 2, y + (h - 1) / 2)``."""
    _, _, w, h = region
    hw, hh = 0.5 * w, 0.5 * h
    return np.array([[-hw, -hh], [hw, -hh], [hw, hh], [-hw, hh]], dtype=np.float64)


def similarity_corners(states: npt.ArrayLike, region: Region) -> npt.NDArray[np.float64]:
    """Corners ``(n, 4, 2)`` of ``region`` moved by states ``(n, 4)`` ``(x, y, theta,
    s)`` in the tracker's convention: ``centre + s R(theta) offset`` with ``R = [[c,
    s], [-s, c]]`` (theta counter-clockwise on screen, as ``getRotationMatrix2D``)."""
    st = np.asarray(states, dtype=np.float64).reshape(-1, 4)
    off = region_offsets(region)
    c, s = np.cos(st[:, 2])[:, None], np.sin(st[:, 2])[:, None]
    scale = st[:, 3][:, None]
    x = st[:, 0][:, None] + scale * (c * off[:, 0] + s * off[:, 1])
    y = st[:, 1][:, None] + scale * (-s * off[:, 0] + c * off[:, 1])
    return np.stack([x, y], axis=-1)


def _corners(a: npt.ArrayLike, name: str) -> np.ndarray:
    arr = np.asarray(a, dtype=np.float64)
    if arr.ndim != 3 or arr.shape[1:] != (4, 2):
        raise ValueError(f"{name} must have shape (n, 4, 2), got {arr.shape}")
    return arr


def alignment_error(estimated: npt.ArrayLike, truth: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """Per frame, the RMS distance of the four corners from the truth (pixels); ``inf``
    where an estimate is not finite (a failure)."""
    est, tru = _corners(estimated, "estimated"), _corners(truth, "truth")
    if est.shape != tru.shape:
        raise ValueError(f"estimated {est.shape} and truth {tru.shape} differ in shape")
    err = np.sqrt(np.mean(np.sum((est - tru) ** 2, axis=2), axis=1))
    return np.where(np.isfinite(err), err, np.inf)


def center_error(estimated: npt.ArrayLike, truth: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """Per frame, the distance between the corners' centroids (pixels), ``inf`` where
    not finite."""
    est, tru = _corners(estimated, "estimated"), _corners(truth, "truth")
    err = np.hypot(*(est.mean(axis=1) - tru.mean(axis=1)).T)
    return np.where(np.isfinite(err), err, np.inf)


def centre_error(estimated: npt.ArrayLike, truth: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """Deprecated spelling of :func:`center_error` (API names spell as OpenCV)."""
    warnings.warn("centre_error is deprecated; use center_error", DeprecationWarning, stacklevel=2)
    return center_error(estimated, truth)


def corner_error(estimated: npt.ArrayLike, truth: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """Per frame, the mean distance of the four corners from the truth (pixels);
    ``inf`` where an estimate is not finite (a failure)."""
    est, tru = _corners(estimated, "estimated"), _corners(truth, "truth")
    if est.shape != tru.shape:
        raise ValueError(f"estimated {est.shape} and truth {tru.shape} differ in shape")
    err = np.mean(np.hypot(*np.moveaxis(est - tru, 2, 0)), axis=1)
    return np.where(np.isfinite(err), err, np.inf)


@dataclass(frozen=True)
class PotScore:
    """POT-210's numbers for one run: ``frames`` scored (the visible ones), the mean
    corner error over them (px, ``inf`` if any failed) and the fraction of them within
    5 and 15 px."""

    frames: int
    mean_corner_error_px: float
    precision_at_5: float
    precision_at_15: float


def pot_score(estimated: npt.ArrayLike, truth: npt.ArrayLike, visible: npt.ArrayLike) -> PotScore:
    """Scores corners ``(n, 4, 2)`` against the truth on the frames ``visible`` (a
    boolean mask ``(n,)``, ``gt_flag == 0``) selects; occluded and out-of-view frames
    count for nothing, as in POT-210."""
    err = corner_error(estimated, truth)
    keep = np.asarray(visible)
    if keep.dtype != np.bool_ or keep.shape != err.shape:
        raise ValueError(f"visible must be a boolean mask of shape {err.shape}, got {keep.shape}")
    if not keep.any():
        raise ValueError("no visible frame to score")
    e = err[keep]
    return PotScore(int(keep.sum()), float(np.mean(e)), precision_at(e, 5.0), precision_at(e, 15.0))


def precision_at(errors: npt.ArrayLike, threshold: float) -> float:
    """Fraction of frames whose error is at most ``threshold`` pixels."""
    e = np.asarray(errors, dtype=np.float64)
    if e.ndim != 1 or len(e) == 0:
        raise ValueError(f"errors must be a non-empty 1-D array, got shape {e.shape}")
    if not math.isfinite(threshold) or threshold < 0:
        raise ValueError(f"threshold must be finite and >= 0, got {threshold}")
    return float(np.mean(e <= threshold))


def success_curve(
    errors: npt.ArrayLike, thresholds: npt.ArrayLike = ALIGNMENT_THRESHOLDS
) -> npt.NDArray[np.float64]:
    """The precision at each threshold (the success rate against the threshold)."""
    return np.array([precision_at(errors, float(t)) for t in np.asarray(thresholds)])


@dataclass(frozen=True)
class PlanarRun:
    """One tracker on one sequence: estimated corners ``(n - 1, 4, 2)`` of frames
    ``1..n`` (NaN where it gave none), failures (exceptions, lost frames), seconds per
    frame, and whether it estimates the position only."""

    tracker: str
    corners: npt.NDArray[np.float64]
    failures: int
    seconds: float
    position_only: bool = False

    @property
    def fps(self) -> float:
        """Frames per second."""
        return 1.0 / self.seconds if self.seconds > 0 else math.inf


@dataclass(frozen=True)
class PlanarScore:
    """The metrics of one run: the median alignment error (px), precision at 5 and 15
    px, the success curve's area over :data:`ALIGNMENT_THRESHOLDS`, the centre
    precision at 5 px, failures and fps. Alignment metrics are NaN for position-only
    trackers."""

    case: str
    tracker: str
    frames: int
    median_alignment: float
    precision_5: float
    precision_15: float
    success_auc: float
    centre_precision_5: float
    failures: int
    fps: float


def score(
    case: str,
    run: PlanarRun,
    truth: npt.ArrayLike,
    select: npt.ArrayLike | None = None,
) -> PlanarScore:
    """Scores ``run`` against true corners ``(n - 1, 4, 2)``, on the frames where
    ``select`` (a boolean mask over them) holds, all frames by default."""
    tru = _corners(truth, "truth")
    keep = np.ones(len(tru), bool) if select is None else np.asarray(select, bool)
    if keep.shape != (len(tru),) or not keep.any():
        raise ValueError("select must be a boolean mask over the frames selecting some")
    align = alignment_error(run.corners, tru)[keep]
    centre = center_error(run.corners, tru)[keep]
    nan = math.nan
    return PlanarScore(
        case,
        run.tracker,
        int(keep.sum()),
        nan if run.position_only else float(np.median(align)),
        nan if run.position_only else precision_at(align, 5.0),
        nan if run.position_only else precision_at(align, 15.0),
        nan if run.position_only else float(success_curve(align).mean()),
        precision_at(centre, 5.0),
        run.failures,
        run.fps,
    )


def _timed(
    name: str, frames: np.ndarray, step: Callable[[np.ndarray], tuple[np.ndarray, bool]]
) -> PlanarRun:
    corners, failures = [], 0
    t0 = time.perf_counter()
    for frame in frames[1:]:
        c, failed = step(frame)
        corners.append(c)
        failures += failed
    seconds = (time.perf_counter() - t0) / max(len(frames) - 1, 1)
    return PlanarRun(name, np.array(corners, dtype=np.float64).reshape(-1, 4, 2), failures, seconds)


def run_pattern(
    frames: np.ndarray, region: Region, seed: int = 1, **params: Unpack[PatternConfigOverrides]
) -> PlanarRun:
    """The seed's pattern tracker (:class:`PatternTracker`); lost frames are failures."""
    tracker = PatternTracker(frames[0], region, seed=seed, **params)

    def step(frame: np.ndarray) -> tuple[np.ndarray, bool]:
        pose = tracker.update(frame)
        return pose.corners_array(), pose.lost

    return _timed("rperc pattern", frames, step)


def ecc_corners(warp: npt.ArrayLike, region: Region) -> npt.NDArray[np.float64]:
    """Corners of the template (the region, on its pixel edges) mapped by an ECC warp
    from template to frame coordinates: 2 x 3 (affine) or 3 x 3 (a homography, with
    the perspective division)."""
    _, _, w, h = region
    edges = np.array(
        [[-0.5, -0.5, 1], [w - 0.5, -0.5, 1], [w - 0.5, h - 0.5, 1], [-0.5, h - 0.5, 1]]
    )
    m = np.asarray(warp, dtype=np.float64)
    mapped = edges @ m.T
    if m.shape == (3, 3):
        return mapped[:, :2] / mapped[:, 2:]
    return mapped


def _ecc_level(warp: np.ndarray, factor: float) -> np.ndarray:
    """The warp between template and frame both scaled by ``factor``: ``S W S^-1``
    with ``S = diag(factor, factor, 1)`` (the translation scales by ``factor``, a
    homography's perspective row by its inverse)."""
    out = warp.copy()
    out[:2, 2] *= factor
    if out.shape == (3, 3):
        out[2, :2] /= factor
    return out


#: ``gaussFiltSize`` of the harness's ``findTransformECC``: no pre-blur, the peer at
#: its best. OpenCV's default, 5, blurs the template, a crop, with its edges
#: reflected, and the frame with the true neighbours there: on the very frame the
#: template was cut from, affine ECC started at the exact warp moves away from it, and
#: on ``rperc bench pattern``'s 3-sigma steps it is less accurate and fails more often
#: than with 1 (the figures are in the commit that chose 1, and in the benchmark's
#: output).
ECC_GAUSS_FILTER = 1


def run_ecc(
    frames: np.ndarray,
    region: Region,
    motion: str = "affine",
    levels: int = 3,
    gauss_filter: int = ECC_GAUSS_FILTER,
) -> PlanarRun:
    """``cv2.findTransformECC`` (``motion`` "euclidean", "affine" or "homography") on
    the region's template, warm-started from the last warp and initialised coarse to
    fine over a ``levels``-level pyramid, with ``gaussFiltSize`` ``gauss_filter`` (see
    :data:`ECC_GAUSS_FILTER`). An exception at the finest level, or a non-finite warp,
    counts as a failure; the frame keeps the coarser (or last) warp.

    Raises ValueError for a ``gauss_filter`` that is not a positive odd int (OpenCV
    would throw at every frame, which the harness would count as failures)."""
    if isinstance(gauss_filter, bool) or not isinstance(gauss_filter, int):
        raise TypeError(f"gauss_filter must be an int, got {type(gauss_filter).__name__}")
    if gauss_filter < 1 or gauss_filter % 2 == 0:
        raise ValueError(f"gauss_filter must be a positive odd int, got {gauss_filter}")
    cv2 = _cv2()

    kinds = {
        "euclidean": cv2.MOTION_EUCLIDEAN,
        "affine": cv2.MOTION_AFFINE,
        "homography": cv2.MOTION_HOMOGRAPHY,
    }
    kind = kinds[motion]
    x, y, w, h = region
    templates = [frames[0][y : y + h, x : x + w].astype(np.float32)]
    for _ in range(levels - 1):
        templates.append(cv2.pyrDown(templates[-1]))
    criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 50, 1e-4)
    rows = 3 if motion == "homography" else 2
    state = {"warp": np.eye(3, dtype=np.float32)[:rows]}
    state["warp"][:2, 2] = (x, y)

    def step(frame: np.ndarray) -> tuple[np.ndarray, bool]:
        pyramid = [frame.astype(np.float32)]
        for _ in range(levels - 1):
            pyramid.append(cv2.pyrDown(pyramid[-1]))
        warp = _ecc_level(state["warp"], 0.5 ** (levels - 1))
        failed = False
        for level in reversed(range(levels)):
            try:
                _, warp = cv2.findTransformECC(
                    templates[level], pyramid[level], warp, kind, criteria, None, gauss_filter
                )
            except cv2.error:
                failed = level == 0
            if level > 0:
                warp = _ecc_level(warp, 2.0)
        if not np.all(np.isfinite(warp)):
            failed, warp = True, state["warp"]
        state["warp"] = warp
        return ecc_corners(warp, region), failed

    return _timed(f"ECC {motion}", frames, step)


def run_orb(
    frames: np.ndarray, region: tuple[int, int, int, int], n_features: int = 1000
) -> PlanarRun:
    """ORB + RANSAC homography against the first frame, as a user writes it with
    OpenCV: ORB keypoints of the region in frame 0 matched to each frame's (brute
    force, Hamming, Lowe's ratio 0.75), ``findHomography`` with RANSAC (3 px). A frame
    with fewer than 4 matches or no homography is a failure and keeps the last
    corners."""
    cv2 = _cv2()
    x, y, w, h = region
    orb = cv2.ORB_create(nfeatures=n_features)
    mask = np.zeros(frames[0].shape[:2], np.uint8)
    mask[y : y + h, x : x + w] = 255
    kp0, des0 = orb.detectAndCompute(frames[0], mask)
    matcher = cv2.BFMatcher(cv2.NORM_HAMMING)
    edges = np.array(
        [
            [
                [x - 0.5, y - 0.5],
                [x + w - 0.5, y - 0.5],
                [x + w - 0.5, y + h - 0.5],
                [x - 0.5, y + h - 0.5],
            ]
        ]
    )
    last = edges[0].copy()
    corners, failures = [], 0
    t0 = time.perf_counter()
    for frame in frames[1:]:
        kp, des = orb.detectAndCompute(frame, None)
        pairs = matcher.knnMatch(des0, des, k=2) if des is not None and des0 is not None else []
        good = [p[0] for p in pairs if len(p) == 2 and p[0].distance < 0.75 * p[1].distance]
        hom = None
        if len(good) >= 4:
            src = np.array([kp0[m.queryIdx].pt for m in good], dtype=np.float32)
            dst = np.array([kp[m.trainIdx].pt for m in good], dtype=np.float32)
            hom, _ = cv2.findHomography(src, dst, cv2.RANSAC, 3.0)
        if hom is None:
            failures += 1
        else:
            last = cv2.perspectiveTransform(edges, hom)[0]
        corners.append(last.copy())
    seconds = (time.perf_counter() - t0) / (len(frames) - 1)
    return PlanarRun("ORB + RANSAC", np.array(corners), failures, seconds)


def run_match_template(
    frames: np.ndarray,
    region: Region,
    angles: Sequence[float] = TEMPLATE_ANGLES,
    scales: Sequence[float] = (0.9, 1.0, 1.1),
    search: int = 20,
) -> PlanarRun:
    """``cv2.matchTemplate`` (normalised correlation coefficient, masked) of the region
    rotated by the last angle plus each of ``angles`` and scaled by the last scale
    times each of ``scales``, within ``search`` pixels of the last centre; the best
    score gives the new similarity."""
    cv2 = _cv2()

    x, y, w, h = region
    template = frames[0][y : y + h, x : x + w].astype(np.float32)
    ones = np.ones_like(template)
    state = np.array([x + (w - 1) / 2, y + (h - 1) / 2, 0.0, 1.0])
    height, width = frames[0].shape[:2]

    def candidate(theta: float, s: float) -> tuple[np.ndarray, np.ndarray]:
        c, n = abs(math.cos(theta)), abs(math.sin(theta))
        cw, ch = math.ceil(s * (w * c + h * n)) | 1, math.ceil(s * (w * n + h * c)) | 1
        m = cv2.getRotationMatrix2D(((w - 1) / 2, (h - 1) / 2), math.degrees(theta), s)
        m[:, 2] += ((cw - 1) / 2 - (w - 1) / 2, (ch - 1) / 2 - (h - 1) / 2)
        warped = cv2.warpAffine(template, m, (cw, ch), flags=cv2.INTER_LINEAR)
        mask = cv2.warpAffine(ones, m, (cw, ch), flags=cv2.INTER_NEAREST)
        return warped, mask

    def step(frame: np.ndarray) -> tuple[np.ndarray, bool]:
        image = frame.astype(np.float32)
        best = (-math.inf, state.copy())
        for da in angles:
            for ds in scales:
                theta, s = state[2] + da, state[3] * ds
                templ, mask = candidate(theta, s)
                ch, cw = templ.shape
                x0 = round(state[0] - (cw - 1) / 2) - search
                y0 = round(state[1] - (ch - 1) / 2) - search
                x0, y0 = max(x0, 0), max(y0, 0)
                x1, y1 = min(x0 + cw + 2 * search, width), min(y0 + ch + 2 * search, height)
                if x1 - x0 < cw or y1 - y0 < ch:
                    continue
                res = cv2.matchTemplate(image[y0:y1, x0:x1], templ, cv2.TM_CCOEFF_NORMED, mask=mask)
                res = np.nan_to_num(res, nan=-1.0, posinf=-1.0, neginf=-1.0)
                _, value, _, loc = cv2.minMaxLoc(res)
                if value > best[0]:
                    centre = (x0 + loc[0] + (cw - 1) / 2, y0 + loc[1] + (ch - 1) / 2)
                    best = (value, np.array([centre[0], centre[1], theta, s]))
        failed = not math.isfinite(best[0])
        state[:] = best[1]
        return similarity_corners(state, region)[0], failed

    return _timed("matchTemplate rot+scale", frames, step)


def run_csrt(frames: np.ndarray, region: Region) -> PlanarRun:
    """OpenCV's CSRT (position and box size, no rotation); a frame it reports lost
    is a failure and keeps the last box."""
    cv2 = _cv2()

    def bgr(frame: np.ndarray) -> np.ndarray:
        return cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR) if frame.ndim == 2 else frame

    tracker = cv2.TrackerCSRT.create()
    tracker.init(bgr(frames[0]), tuple(int(v) for v in region))
    box = [float(v) for v in region]

    def step(frame: np.ndarray) -> tuple[np.ndarray, bool]:
        ok, found = tracker.update(bgr(frame))
        if ok:
            box[:] = [float(v) for v in found]
        bx, by, bw, bh = box
        corners = [
            [bx - 0.5, by - 0.5],
            [bx + bw - 0.5, by - 0.5],
            [bx + bw - 0.5, by + bh - 0.5],
            [bx - 0.5, by + bh - 0.5],
        ]
        return np.array(corners), not ok

    run = _timed("CSRT (position)", frames, step)
    return PlanarRun(run.tracker, run.corners, run.failures, run.seconds, position_only=True)


def truth_corners(seq: PatternSequence) -> npt.NDArray[np.float64]:
    """True corners ``(n - 1, 4, 2)`` of frames ``1..n`` of a generated sequence."""
    return similarity_corners(seq.truth[1:], seq.region)


def clutter_background(
    patch: npt.ArrayLike, background: npt.ArrayLike, copies: int = 10, seed: int = 0
) -> npt.NDArray[np.float64]:
    """``background`` with ``copies`` of ``patch`` pasted at random places, rotated by
    up to 180 degrees and scaled by 0.7-1.3: clutter that looks like the pattern."""
    cv2 = _cv2()

    rng = np.random.default_rng(seed)
    p = np.asarray(patch, dtype=np.float32)
    out = np.asarray(background, dtype=np.float32).copy()
    ph, pw = p.shape
    for _ in range(copies):
        m = cv2.getRotationMatrix2D(
            ((pw - 1) / 2, (ph - 1) / 2), rng.uniform(-180, 180), rng.uniform(0.7, 1.3)
        )
        warped = cv2.warpAffine(p, m, (pw, ph), flags=cv2.INTER_LINEAR)
        mask = cv2.warpAffine(np.ones_like(p), m, (pw, ph), flags=cv2.INTER_NEAREST) > 0
        y0 = int(rng.integers(0, max(out.shape[0] - ph, 1)))
        x0 = int(rng.integers(0, max(out.shape[1] - pw, 1)))
        view = out[y0 : y0 + ph, x0 : x0 + pw]
        view[mask[: view.shape[0], : view.shape[1]]] = warped[: view.shape[0], : view.shape[1]][
            mask[: view.shape[0], : view.shape[1]]
        ]
    return out.astype(np.float64)


@dataclass(frozen=True)
class HarnessCase:
    """A named generated sequence and the frames (a mask over frames ``1..n``) it is
    scored on."""

    name: str
    sequence: PatternSequence
    select: npt.NDArray[np.bool_]


def harness_cases(
    patch: npt.ArrayLike,
    background: npt.ArrayLike,
    n_frames: int = 40,
    size: tuple[int, int] = (640, 480),
    seed: int = 3,
) -> list[HarnessCase]:
    """The harness's cases: steps within 1 sigma; steps up to 3 sigma (``3 n_frames``
    frames, scored on those whose swept step is 2.5-3 sigma); 30-40 % occlusion
    (occluders up to 40 %, scored on the frames hidden 30-40 %); and a background
    cluttered with copies of the pattern."""

    def seq(**kw: Any) -> PatternSequence:
        kw.setdefault("background", background)
        bg = kw.pop("background")
        return pattern_sequence(
            patch, bg, n_frames=n_frames, width=size[0], height=size[1], seed=seed, **kw
        )

    every = np.ones(n_frames - 1, bool)
    # Three times the frames: a sixth of uniform steps fall within 2.5-3 sigma.
    near3 = pattern_sequence(
        patch,
        background,
        n_frames=3 * n_frames,
        width=size[0],
        height=size[1],
        seed=seed,
        max_step_sigmas=3.0,
    )
    k = np.arange(3 * n_frames - 1)
    steps = np.abs(np.diff(near3.truth, axis=0) / np.array(SIGMA))
    swept = steps[k, k % 4]
    occluded = seq(max_occlusion=0.4, max_step_sigmas=1.0)
    hidden = occluded.occlusion[1:]
    clutter = clutter_background(patch, background, seed=seed)
    return [
        HarnessCase("steps <= 1 sigma", seq(max_step_sigmas=1.0), every),
        HarnessCase("steps 2.5-3 sigma", near3, swept >= 2.5),
        HarnessCase("occlusion 30-40 %", occluded, (hidden >= 0.3) & (hidden <= 0.4)),
        HarnessCase("pattern-like clutter", seq(max_step_sigmas=1.0, background=clutter), every),
    ]


def available_trackers() -> dict[str, Callable[[np.ndarray, Region], PlanarRun]]:
    """The trackers the harness runs: the pattern tracker, and the OpenCV peers when
    ``cv2`` is installed."""
    trackers: dict[str, Callable[[np.ndarray, Region], PlanarRun]] = {"rperc pattern": run_pattern}
    try:
        _cv2()
    except ImportError:
        return trackers
    trackers["ECC euclidean"] = lambda f, r: run_ecc(f, r, "euclidean")
    trackers["ECC affine"] = lambda f, r: run_ecc(f, r, "affine")
    trackers["matchTemplate rot+scale"] = run_match_template
    trackers["CSRT (position)"] = run_csrt
    return trackers


def run_harness(
    cases: Sequence[HarnessCase],
    trackers: dict[str, Callable[[np.ndarray, Region], PlanarRun]] | None = None,
) -> list[PlanarScore]:
    """Every tracker on every case's frames, scored on the case's frames."""
    chosen = available_trackers() if trackers is None else trackers
    scores = []
    for case in cases:
        truth = truth_corners(case.sequence)
        for run_tracker in chosen.values():
            run = run_tracker(case.sequence.frames, case.sequence.region)
            scores.append(score(case.name, run, truth, case.select))
    return scores


def format_table(scores: Sequence[PlanarScore]) -> str:
    """The scores as a text table (``-`` for a position-only tracker's alignment)."""

    def cell(v: float, fmt: str) -> str:
        return "-" if math.isnan(v) else format(v, fmt)

    header = [
        "case",
        "tracker",
        "frames",
        "median align px",
        "P@5",
        "P@15",
        "success AUC",
        "centre P@5",
        "failures",
        "fps",
    ]
    rows = [
        [
            s.case,
            s.tracker,
            str(s.frames),
            cell(s.median_alignment, ".2f"),
            cell(s.precision_5, ".2f"),
            cell(s.precision_15, ".2f"),
            cell(s.success_auc, ".2f"),
            f"{s.centre_precision_5:.2f}",
            str(s.failures),
            f"{s.fps:.0f}",
        ]
        for s in scores
    ]
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]
    lines = [
        " | ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)) for r in [header, *rows]
    ]
    lines.insert(1, "-+-".join("-" * w for w in widths))
    return "\n".join(lines)
