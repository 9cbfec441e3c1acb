"""Generated perspective sequences for the pattern tracker's homography mode.

A patch is drawn by OpenCV's ``warpPerspective`` over a background through a
homography that walks from frame to frame: its corners follow a similarity (centre,
angle and scale steps, uniform in their ranges) of the patch's rectangle, each corner
pushed off it by its own random walk (the perspective). The true homographies and
corners are those the frames were drawn with, so that a tracker's corner error is
measured against what OpenCV drew, not against anything rperc computed. A band of
clutter, warped with the patch, can hide a known share of it; the frames get a gain,
an offset and Gaussian noise. Needs OpenCV (``pip install rperc[opencv]``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt


def _cv2() -> Any:
    try:
        import cv2
    except ImportError as e:  # pragma: no cover - optional dependency
        raise ImportError("perspective sequences need OpenCV: pip install rperc[opencv]") from e
    return cv2


@dataclass(frozen=True)
class PerspectiveSequence:
    """A generated perspective sequence and its truth.

    ``frames``: ``(n, H, W)`` uint8; ``homographies``: ``(n, 3, 3)`` from patch pixels
    to frame pixels (``H[2, 2] = 1``), the ones ``warpPerspective`` drew with;
    ``corners``: ``(n, 4, 2)`` the patch's outer corners (top-left, top-right,
    bottom-right, bottom-left) in each frame; ``occluded``: ``(n,)`` the share of the
    patch's area the clutter band hides; ``band``: ``(n,)`` the band's width as a
    share of the patch's width, from its left edge; ``region``: the box ``(x, y, w,
    h)`` the patch fills in frame 0.
    """

    frames: npt.NDArray[np.uint8]
    homographies: npt.NDArray[np.float64]
    corners: npt.NDArray[np.float64]
    occluded: npt.NDArray[np.float64]
    band: npt.NDArray[np.float64]
    region: tuple[int, int, int, int]


def patch_corners(w: int, h: int) -> npt.NDArray[np.float64]:
    """The outer corners of a ``w x h`` patch in its pixels (centres at integers)."""
    return np.array([[-0.5, -0.5], [w - 0.5, -0.5], [w - 0.5, h - 0.5], [-0.5, h - 0.5]])


def _walk(
    rng: np.random.Generator,
    n: int,
    shape: tuple[int, int],
    size: tuple[int, int],
    steps: tuple[float, float, float, float],
) -> npt.NDArray[np.float64]:
    """The frame corners ``(n, 4, 2)`` of a patch of ``shape = (w, h)`` in frames of
    ``size``: a similarity walk (steps ``(px, deg, scale, corner px)``) of its
    rectangle, the corners pushed off by their own walk, kept inside the frame, convex
    and within 40 % of the rectangle's size of it."""
    w, h = shape
    width, height = size
    rect = patch_corners(w, h) - np.array([(w - 1) / 2, (h - 1) / 2])
    x0, y0 = width // 2 - w // 2, height // 2 - h // 2
    centre = np.array([x0 + (w - 1) / 2, y0 + (h - 1) / 2])
    theta, scale, push = 0.0, 1.0, np.zeros((4, 2))
    out = [rect + centre]
    step_px, step_deg, step_scale, step_corner = steps
    limit = 0.2 * min(w, h)
    while len(out) < n:
        c = centre + rng.uniform(-step_px, step_px, 2)
        t = theta + math.radians(rng.uniform(-step_deg, step_deg))
        s = float(np.clip(scale * (1 + rng.uniform(-step_scale, step_scale)), 0.7, 1.4))
        p = np.clip(push + rng.uniform(-step_corner, step_corner, (4, 2)), -limit, limit)
        rot = np.array([[math.cos(t), math.sin(t)], [-math.sin(t), math.cos(t)]])
        q = (s * (rect + p)) @ rot.T + c
        edge = np.roll(q, -1, axis=0) - q
        after = np.roll(edge, -1, axis=0)
        cross = edge[:, 0] * after[:, 1] - edge[:, 1] * after[:, 0]
        inside = np.all(q > 8) and np.all(q[:, 0] < width - 8) and np.all(q[:, 1] < height - 8)
        if not (inside and np.all(cross > 0)):
            continue  # redrawn: the step would leave the frame or fold the quad
        centre, theta, scale, push = c, t, s, p
        out.append(q)
    return np.array(out)


def perspective_sequence(
    patch: npt.ArrayLike,
    background: npt.ArrayLike,
    *,
    n_frames: int = 40,
    size: tuple[int, int] = (640, 480),
    steps: tuple[float, float, float, float] = (5.0, 3.0, 0.05, 2.0),
    max_occlusion: float = 0.0,
    gain: tuple[float, float] = (1.0, 1.0),
    offset: tuple[float, float] = (0.0, 0.0),
    noise: float = 2.0,
    seed: int = 0,
) -> PerspectiveSequence:
    """A perspective sequence of ``patch`` (2-D grey levels) over ``background``
    (2-D; a random crop of it, mirrored out to ``size`` if smaller, stays still).

    ``steps`` are the walk's per-frame ranges: centre (px), angle (degrees), scale
    (relative) and each corner's push off the rectangle (px at scale 1). From frame 1
    on, a band of clutter (another crop of the background) hides the left
    ``U(0, max_occlusion)`` of the patch; gain and offset are uniform in their ranges
    per frame, then Gaussian ``noise`` (grey levels)."""
    cv2 = _cv2()
    rng = np.random.default_rng(seed)
    p = np.asarray(patch, dtype=np.float32)
    bg = np.asarray(background, dtype=np.float32)
    h, w = p.shape
    width, height = size
    if bg.ndim != 2 or p.ndim != 2:
        raise ValueError(f"patch and background must be 2-D, got {p.shape} and {bg.shape}")
    # A background smaller than the frame is mirrored out to its size.
    pad_y, pad_x = max(0, height + 1 - bg.shape[0]), max(0, width + 1 - bg.shape[1])
    bg = np.pad(bg, ((0, pad_y), (0, pad_x)), mode="symmetric")
    oy = int(rng.integers(0, bg.shape[0] - height + 1))
    ox = int(rng.integers(0, bg.shape[1] - width + 1))
    still = bg[oy : oy + height, ox : ox + width]
    cy = int(rng.integers(0, max(1, bg.shape[0] - h)))
    cx = int(rng.integers(0, max(1, bg.shape[1] - w)))
    clutter = bg[cy : cy + h, cx : cx + w]
    corners = _walk(rng, n_frames, (w, h), size, steps)
    source = patch_corners(w, h).astype(np.float32)
    frames, homs, hidden = [], [], []
    for k, q in enumerate(corners):
        hom = cv2.getPerspectiveTransform(source, q.astype(np.float32))
        share = 0.0 if k == 0 else float(rng.uniform(0.0, max_occlusion))
        drawn = p.copy()
        band = round(share * w)
        drawn[:, :band] = clutter[:, :band]
        frame = still.copy()
        cv2.warpPerspective(
            drawn, hom, size, dst=frame, flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_TRANSPARENT
        )
        g = rng.uniform(*gain) if k else 1.0
        o = rng.uniform(*offset) if k else 0.0
        noisy = g * frame + o + rng.normal(0.0, noise, frame.shape)
        frames.append(np.clip(np.rint(noisy), 0, 255).astype(np.uint8))
        homs.append(hom / hom[2, 2])
        hidden.append(band / w)
    x0, y0 = width // 2 - w // 2, height // 2 - h // 2
    hidden_arr = np.array(hidden)
    return PerspectiveSequence(
        np.stack(frames), np.array(homs), corners, hidden_arr, hidden_arr, (x0, y0, w, h)
    )
