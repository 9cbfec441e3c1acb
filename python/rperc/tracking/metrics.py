"""The OTB evaluation metrics (Wu, Lim & Yang 2013): overlap (IoU), the success curve
and its area, and precision at a centre-error threshold. Boxes are ``(x, y, w, h)``."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

SUCCESS_THRESHOLDS = np.linspace(0.0, 1.0, 21)


def _boxes(b: npt.ArrayLike, name: str) -> np.ndarray:
    arr = np.asarray(b, dtype=np.float64)
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != 4:
        raise ValueError(f"{name} must have shape (N, 4) as x, y, w, h; got {arr.shape}")
    return arr


def iou(a: npt.ArrayLike, b: npt.ArrayLike) -> np.ndarray:
    """Intersection over union of matching rows of two (N, 4) box arrays. Boxes with
    non-positive or non-finite size (a lost target) have IoU 0."""
    a, b = _boxes(a, "a"), _boxes(b, "b")
    if a.shape != b.shape:
        raise ValueError(f"a and b must have the same shape, got {a.shape} and {b.shape}")
    x0 = np.maximum(a[:, 0], b[:, 0])
    y0 = np.maximum(a[:, 1], b[:, 1])
    x1 = np.minimum(a[:, 0] + a[:, 2], b[:, 0] + b[:, 2])
    y1 = np.minimum(a[:, 1] + a[:, 3], b[:, 1] + b[:, 3])
    inter = np.clip(x1 - x0, 0, None) * np.clip(y1 - y0, 0, None)
    union = a[:, 2] * a[:, 3] + b[:, 2] * b[:, 3] - inter
    valid = (
        (a[:, 2:] > 0).all(1)
        & (b[:, 2:] > 0).all(1)
        & np.isfinite(a).all(1)
        & np.isfinite(b).all(1)
    )
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(valid & (union > 0), inter / union, 0.0)
    # Rounding in the union can put identical boxes a hair above 1, and the success
    # curve's last threshold (overlap > 1) would then count them.
    return np.minimum(out, 1.0)


def success_curve(
    overlaps: npt.ArrayLike, thresholds: npt.ArrayLike = SUCCESS_THRESHOLDS
) -> np.ndarray:
    """Fraction of frames whose overlap exceeds each threshold."""
    o = np.asarray(overlaps, dtype=np.float64)
    t = np.asarray(thresholds, dtype=np.float64)
    return np.asarray((o[None, :] > t[:, None]).mean(axis=1), dtype=np.float64)


def auc(overlaps: npt.ArrayLike) -> float:
    """Area under the success curve: its mean over the 21 thresholds 0, 0.05, ..., 1."""
    return float(success_curve(overlaps).mean())


def center_error(a: npt.ArrayLike, b: npt.ArrayLike) -> np.ndarray:
    """Distance in pixels between the centres of matching boxes."""
    a, b = _boxes(a, "a"), _boxes(b, "b")
    ca = a[:, :2] + a[:, 2:] / 2
    cb = b[:, :2] + b[:, 2:] / 2
    return np.asarray(np.hypot(*(ca - cb).T), dtype=np.float64)


def precision(pred: npt.ArrayLike, truth: npt.ArrayLike, threshold: float = 20.0) -> float:
    """Fraction of frames whose centre error is at most ``threshold`` pixels."""
    err = center_error(pred, truth)
    return float(np.mean(np.where(np.isfinite(err), err, np.inf) <= threshold))
