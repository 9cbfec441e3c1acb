"""A seeded synthetic tracking sequence with exactly known boxes.

A two-coloured elliptical target (a dark upper part over a light lower part, like the
hair and skin of the seed's head tracker) moves along a Lissajous path and slowly
grows and shrinks over a textured background with coloured clutter and two distractors
in the target's lower colour (discs without the dark upper part) near its path. The
illumination drifts slowly and every frame gets sensor noise. The true box of frame
``k`` is the bounding box of the ellipse drawn in it, so trackers can be scored
without any downloaded data.

Examples
--------
>>> from rperc.tracking.synthetic import synthetic_sequence
>>> seq = synthetic_sequence(frames=5, seed=1)
>>> seq.frames.shape, seq.boxes.shape
((5, 240, 320, 3), (5, 4))
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rperc._args import excerpt, whole_number

__all__ = ["SyntheticSequence", "synthetic_sequence"]

UPPER_COLOUR = (95, 45, 25)  # dark brown
LOWER_COLOUR = (235, 160, 120)  # light orange
UPPER_FRACTION = 0.4  # share of the ellipse's height in the upper colour
SCALE_SWING = 0.15  # the target's size varies by +-15 %
LIGHT_SWING = 0.12  # the illumination's gain varies by +-12 %
PERIODS = (160, 120, 150, 150)  # frames: x and y motion, scale, illumination


@dataclass(frozen=True, repr=False)
class SyntheticSequence:
    """Frames (N x H x W x 3 uint8 RGB) and true boxes ``(x, y, w, h)`` in pixels with
    a 0-based top-left corner (pixel ``j`` spans ``[j, j + 1)``), as :mod:`rperc.datasets`
    gives OTB sequences. ``background`` is the scene without the target, lighting and
    noise; frame ``k`` is lit with the gain ``illumination[k]``."""

    name: str
    frames: np.ndarray
    boxes: np.ndarray
    background: np.ndarray
    illumination: np.ndarray
    seed: int

    def __len__(self) -> int:
        return len(self.frames)

    def frame(self, k: int) -> np.ndarray:
        return np.asarray(self.frames[k])

    def __repr__(self) -> str:
        n, h, w, _ = self.frames.shape
        return f"SyntheticSequence({self.name!r}, {n} frames of {w} x {h}, seed {self.seed})"


def _count(value: int, name: str, minimum: int) -> int:
    return whole_number(value, name, minimum)


def _background(rng: np.random.Generator, height: int, width: int) -> np.ndarray:
    """Smooth colour waves plus blocky noise and muted rectangles (clutter): texture in
    greens, blues and greys, away from the target's browns and oranges."""
    yy, xx = np.mgrid[0:height, 0:width].astype(np.float64)
    img = np.empty((height, width, 3))
    base = np.array([90.0, 120.0, 125.0])  # grey-green-blue
    for c in range(3):
        fx, fy = rng.uniform(0.01, 0.06, size=2)
        phase = rng.uniform(0, 2 * np.pi, size=2)
        img[..., c] = base[c] + 25 * np.sin(fx * xx + phase[0]) * np.cos(fy * yy + phase[1])
    blocks = rng.normal(0, 14, size=(height // 8 + 1, width // 8 + 1, 3))
    img += np.kron(blocks, np.ones((8, 8, 1)))[:height, :width]
    for _ in range(12):
        x0, y0 = rng.integers(0, width - 20), rng.integers(0, height - 20)
        w, h = rng.integers(10, 50, size=2)
        img[y0 : y0 + h, x0 : x0 + w] = rng.uniform([30, 80, 80], [110, 170, 200])
    return np.clip(img, 0, 255).astype(np.uint8)


def _path(
    rng: np.random.Generator, n: int, height: int, width: int, size: tuple[int, int]
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Centres and sizes along a Lissajous path that keeps the box inside the frame.
    The periods are fixed in frames, so the speed (at most about 7 px per frame in a
    320 x 240 frame) does not depend on the length of the sequence."""
    k = np.arange(n, dtype=np.float64)
    scale = 1.0 + SCALE_SWING * np.sin(2 * np.pi * k / PERIODS[2] + rng.uniform(0, 2 * np.pi))
    w, h = size[0] * scale, size[1] * scale
    room_x = width / 2 - (1 + SCALE_SWING) * size[0] / 2 - 4
    room_y = height / 2 - (1 + SCALE_SWING) * size[1] / 2 - 4
    phase = rng.uniform(0, 2 * np.pi, size=2)
    cx = width / 2 + room_x * np.sin(2 * np.pi * k / PERIODS[0] + phase[0])
    cy = height / 2 + room_y * np.sin(2 * np.pi * k / PERIODS[1] + phase[1])
    return cx, cy, w, h


def _draw_distractors(
    background: np.ndarray, cx: np.ndarray, cy: np.ndarray, size: tuple[int, int]
) -> None:
    """Two discs in the lower colour, beside the path at a third and two thirds of the
    sequence, so a tracker that only matches one colour can jump to them."""
    height, width, _ = background.shape
    yy, xx = np.mgrid[0:height, 0:width] + 0.5
    radius = 0.35 * min(size)
    for k in (len(cx) // 3, 2 * len(cx) // 3):
        dx = cx[k] + 1.3 * size[0] if cx[k] < width / 2 else cx[k] - 1.3 * size[0]
        background[(xx - dx) ** 2 + (yy - cy[k]) ** 2 <= radius**2] = LOWER_COLOUR


def _draw_target(frame: np.ndarray, cx: float, cy: float, w: float, h: float) -> None:
    """Fill the pixels whose centres lie inside the ellipse inscribed in the box."""
    height, width, _ = frame.shape
    y0, y1 = max(int(cy - h / 2) - 1, 0), min(int(cy + h / 2) + 2, height)
    x0, x1 = max(int(cx - w / 2) - 1, 0), min(int(cx + w / 2) + 2, width)
    py, px = np.mgrid[y0:y1, x0:x1] + 0.5
    inside = ((px - cx) / (w / 2)) ** 2 + ((py - cy) / (h / 2)) ** 2 <= 1.0
    upper = py < cy - h / 2 + UPPER_FRACTION * h
    patch = frame[y0:y1, x0:x1]
    patch[inside & upper] = UPPER_COLOUR
    patch[inside & ~upper] = LOWER_COLOUR


def synthetic_sequence(
    frames: int = 120,
    *,
    height: int = 240,
    width: int = 320,
    target: tuple[int, int] = (40, 56),
    noise: float = 4.0,
    distractors: bool = True,
    seed: int = 0,
) -> SyntheticSequence:
    """Generate the sequence; the same ``seed`` gives the same frames and boxes.

    ``target`` is the ``(width, height)`` of the target's box at scale 1 (pixels);
    ``noise`` the standard deviation of the per-pixel sensor noise (grey levels);
    ``distractors=False`` leaves out the two discs in the target's lower colour.
    """
    n = _count(frames, "frames", 2)
    height, width = _count(height, "height", 32), _count(width, "width", 32)
    tw, th = _count(target[0], "target width", 4), _count(target[1], "target height", 4)
    if (1 + SCALE_SWING) * tw + 8 >= width or (1 + SCALE_SWING) * th + 8 >= height:
        raise ValueError(f"target {target} does not fit a {width} x {height} frame")
    if not np.isfinite(noise) or noise < 0:
        raise ValueError(f"noise must be finite and >= 0, got {excerpt(noise)}")
    seed = _count(seed, "seed", 0)
    rng = np.random.default_rng(seed)
    background = _background(rng, height, width)
    cx, cy, w, h = _path(rng, n, height, width, (tw, th))
    if distractors:
        _draw_distractors(background, cx, cy, (tw, th))
    gain = 1.0 + LIGHT_SWING * np.sin(2 * np.pi * np.arange(n) / PERIODS[3])
    out = np.empty((n, height, width, 3), dtype=np.uint8)
    for k in range(n):
        frame = background.copy()
        _draw_target(frame, cx[k], cy[k], w[k], h[k])
        lit = gain[k] * frame + (rng.normal(0.0, noise, size=frame.shape) if noise > 0 else 0.0)
        out[k] = np.clip(np.rint(lit), 0, 255).astype(np.uint8)
    boxes = np.stack([cx - w / 2, cy - h / 2, w, h], axis=1)
    return SyntheticSequence(f"synthetic-{seed}", out, boxes, background, gain, seed)


def demo_images(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A grey pattern patch (100 x 100: rectangles and a disc) and a blocky clutter
    background (512 x 512) for the pattern tracker's generated sequences (no data)."""
    rng = np.random.default_rng(seed)
    patch = np.full((100, 100), 60.0)
    patch[10:45, 15:60] = 200
    patch[55:90, 40:85] = 140
    yy, xx = np.mgrid[0:100, 0:100]
    patch[(xx - 30) ** 2 + (yy - 70) ** 2 < 225] = 230
    background = rng.uniform(40, 200, (32, 32)).repeat(16, 0).repeat(16, 1)
    return patch, background
