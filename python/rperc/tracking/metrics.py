"""The OTB evaluation metrics (Wu, Lim & Yang 2013): overlap (IoU), the success curve
and its area, and precision at a centre-error threshold. Boxes are ``(x, y, w, h)``."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from rperc import _rperc
from rperc._args import real_number

SUCCESS_THRESHOLDS = np.linspace(0.0, 1.0, 21)


def _boxes(b: npt.ArrayLike, name: str) -> np.ndarray:
    arr = np.asarray(b, dtype=np.float64)
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != 4:
        raise ValueError(f"{name} must have shape (N, 4) as x, y, w, h; got {arr.shape}")
    return arr


def _overlaps(o: npt.ArrayLike) -> np.ndarray:
    arr = np.asarray(o, dtype=np.float64)
    if arr.ndim != 1:
        raise ValueError(f"overlaps must be 1-D, got shape {arr.shape}")
    if len(arr) == 0:
        raise ValueError("overlaps is empty: a success rate of no frames is undefined")
    return arr


def iou(a: npt.ArrayLike, b: npt.ArrayLike) -> np.ndarray:
    """Intersection over union of matching rows of two (N, 4) box arrays (a single box
    is a row). Boxes with non-positive or non-finite size (a lost target) have IoU 0.
    The arrays must hold as many boxes: nothing is broadcast."""
    return _rperc.otb_iou(_boxes(a, "a"), _boxes(b, "b"))


def success_curve(overlaps: npt.ArrayLike) -> np.ndarray:
    """Fraction of frames whose overlap exceeds each of the 21 thresholds 0, ..., 1."""
    return _rperc.otb_success_curve(_overlaps(overlaps))


def auc(overlaps: npt.ArrayLike) -> float:
    """Area under the success curve: its mean over the 21 thresholds 0, 0.05, ..., 1."""
    return float(success_curve(overlaps).mean())


def center_error(a: npt.ArrayLike, b: npt.ArrayLike) -> np.ndarray:
    """Distance in pixels between the centres of matching boxes (inf when either is
    not finite)."""
    return _rperc.otb_center_error(_boxes(a, "a"), _boxes(b, "b"))


def precision(pred: npt.ArrayLike, truth: npt.ArrayLike, threshold: float = 20.0) -> float:
    """Fraction of frames whose centre error is at most ``threshold`` pixels."""
    limit = real_number(threshold, "threshold")
    if math.isnan(limit):
        raise ValueError("threshold must be a number of pixels, got nan")
    if len(_boxes(pred, "pred")) == 0:
        raise ValueError("pred is empty: a precision over no frames is undefined")
    return float(_rperc.otb_precision(center_error(pred, truth), limit))


def polygon_mask(polygon: npt.ArrayLike, shape: tuple[int, int]) -> np.ndarray:
    """The pixels of an ``(H, W)`` image whose centres (at integer ``(x, y)``) lie inside
    a closed ``(N, 2)`` polygon of ``(x, y)`` points (non-finite vertices refused)."""
    from matplotlib.path import Path

    poly = np.asarray(polygon, dtype=np.float64)
    if poly.ndim != 2 or poly.shape[1] != 2 or len(poly) < 3:
        raise ValueError(f"polygon must have shape (N >= 3, 2), got {poly.shape}")
    if not np.isfinite(poly).all():
        raise ValueError("polygon has a non-finite vertex")
    h, w = shape
    mask = np.zeros((h, w), dtype=bool)
    # Only the centres inside the polygon's bounding box can be inside it: a contour
    # covers a small part of a frame, and the point-in-polygon test is the cost.
    x0, y0 = max(math.ceil(poly[:, 0].min()), 0), max(math.ceil(poly[:, 1].min()), 0)
    x1, y1 = min(math.floor(poly[:, 0].max()), w - 1), min(math.floor(poly[:, 1].max()), h - 1)
    if x0 > x1 or y0 > y1:
        return mask
    yy, xx = np.mgrid[y0 : y1 + 1, x0 : x1 + 1]
    inside = Path(poly).contains_points(np.stack([xx.ravel(), yy.ravel()], axis=1))
    mask[y0 : y1 + 1, x0 : x1 + 1] = inside.reshape(xx.shape)
    return mask


def mask_iou(a: npt.ArrayLike, b: npt.ArrayLike) -> float:
    """Intersection over union of two boolean masks of one shape (1 when both are empty)."""
    ma, mb = np.asarray(a, dtype=bool), np.asarray(b, dtype=bool)
    if ma.shape != mb.shape:
        raise ValueError(f"masks differ in shape: {ma.shape} and {mb.shape}")
    union = int(np.count_nonzero(ma | mb))
    return 1.0 if union == 0 else int(np.count_nonzero(ma & mb)) / union
