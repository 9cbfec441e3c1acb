"""Seeded synthetic sequences with truth masks for the four experiments of seed 000
section 3.4 (Fig. 13), for the colour+shape tracker.

1. ``circles``: discs moving on a plain background while their colours random-walk
   (tracked in RGB).
2. ``rectangle``: a coloured rectangle under changing illumination with a moving
   specular highlight (tracked in the opponent space (B-G, G-R, R+G+B)).
3. ``nonrigid``: a blob whose outline deforms every frame, over a textured background.
4. ``clutter``: a blob over a textured background among distractors of the same colour
   but other shapes, which cross its path.

The seed draws everything that varies: the shades, the target's colour, size and
path (periods and phases), the distractors' sweep and place, and the noise.

Textured backgrounds come from the grey images in ``$RPERC_DATA/images`` when present
(tinted to colour); otherwise a seeded noise texture is used, so the sequences never
need downloaded data. Each sequence gives the frames, the truth mask of the target in
every frame, and the target's outline in frame 0 (to start a tracker from).

Examples
--------
>>> from rperc.tracking.shape_sequences import shape_sequence
>>> seq = shape_sequence("circles", frames=4, seed=1)
>>> seq.frames.shape, seq.masks.shape, seq.masks.dtype
((4, 240, 320, 3), (4, 240, 320), dtype('bool'))
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from rperc._args import excerpt, whole_number
from rperc.datasets._paths import data_dir
from rperc.tracking.metrics import polygon_mask

__all__ = ["EXPERIMENTS", "ShapeSequence", "shape_sequence"]

Experiment = Literal["circles", "rectangle", "nonrigid", "clutter"]
EXPERIMENTS: tuple[Experiment, ...] = ("circles", "rectangle", "nonrigid", "clutter")
HEIGHT, WIDTH = 240, 320
NOISE = 4.0  # sensor noise, grey levels (std)


@dataclass(frozen=True, repr=False)
class ShapeSequence:
    """Frames (N x H x W x 3 uint8 RGB), the target's truth masks (N x H x W bool), its
    outline in frame 0 as an (M, 2) polygon ``(x, y)`` in pixel coordinates (pixel
    centres at integers), and the colour space the seed tracks it in."""

    name: str
    frames: np.ndarray
    masks: np.ndarray
    outline: np.ndarray
    color_space: Literal["rgb", "opponent"]
    seed: int

    def __len__(self) -> int:
        return len(self.frames)

    def __repr__(self) -> str:
        n, h, w, _ = self.frames.shape
        return f"ShapeSequence({self.name!r}, {n} frames of {w} x {h}, seed {self.seed})"


def _grid() -> tuple[np.ndarray, np.ndarray]:
    yy, xx = np.mgrid[0:HEIGHT, 0:WIDTH]
    return xx.astype(np.float64), yy.astype(np.float64)


def _texture(rng: np.random.Generator, name: str) -> np.ndarray:
    """A colour texture (H x W x 3 float): a data image tinted, or seeded noise."""
    root = (data_dir() or Path("absent")) / "images" / f"{name}.png"
    if root.is_file():
        from PIL import Image

        grey = np.asarray(Image.open(root).convert("L").resize((WIDTH, HEIGHT)), np.float64)
    else:
        grey = rng.normal(128.0, 40.0, (HEIGHT // 8, WIDTH // 8)).repeat(8, 0).repeat(8, 1)
    tint = np.array([0.75, 0.85, 0.7])
    out: np.ndarray = np.clip(grey[..., None] * tint + 20.0, 0.0, 255.0)
    return out


def _star(cx: float, cy: float, r0: float, phase: float, n: int = 120) -> np.ndarray:
    """The deforming outline r(t) = r0 (1 + 0.18 sin(3 t + phase) + 0.08 cos(2 t - phase))."""
    t = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    r = r0 * (1 + 0.18 * np.sin(3 * t + phase) + 0.08 * np.cos(2 * t - 1.7 * phase))
    return np.stack([cx + r * np.cos(t), cy + r * np.sin(t)], axis=1)


def _finish(rng: np.random.Generator, image: np.ndarray) -> np.ndarray:
    noisy = image + rng.normal(0.0, NOISE, image.shape)
    return np.clip(np.rint(noisy), 0, 255).astype(np.uint8)


def _circles(
    rng: np.random.Generator, n: int
) -> tuple[list[np.ndarray], list[np.ndarray], np.ndarray]:
    k, radius = 3, 18.0
    pos = np.array([[90.0, 80.0], [220.0, 150.0], [160.0, 60.0]])
    vel = rng.normal(0.0, 2.0, (k, 2))
    # Red, green and blue discs, each shade drawn per seed.
    base = np.array([[200.0, 60.0, 60.0], [60.0, 180.0, 70.0], [70.0, 80.0, 200.0]])
    colour = np.clip(base + rng.normal(0.0, 15.0, base.shape), 30.0, 225.0)
    xx, yy = _grid()
    frames, masks = [], []
    for _ in range(n):
        image = np.full((HEIGHT, WIDTH, 3), 110.0)
        # The target (disc 0) is drawn last, on top: its truth is its whole disc.
        for i in reversed(range(k)):
            disc = np.hypot(xx - pos[i, 0], yy - pos[i, 1]) <= radius
            image[disc] = colour[i]
            if i == 0:
                masks.append(disc)
        frames.append(_finish(rng, image))
        pos += vel
        for i in range(k):
            for d, hi in ((0, WIDTH), (1, HEIGHT)):
                if not radius + 2 < pos[i, d] < hi - radius - 2:
                    vel[i, d] = -vel[i, d]
        # The colours wander at random (the seed's experiment 1).
        colour = np.clip(colour + rng.normal(0.0, 3.0, colour.shape), 30.0, 225.0)
    t = np.linspace(0.0, 2 * np.pi, 64, endpoint=False)
    outline = np.stack([90.0 + radius * np.cos(t), 80.0 + radius * np.sin(t)], axis=1)
    return frames, masks, outline


def _saturated(rng: np.random.Generator, value: float) -> np.ndarray:
    """A saturated colour of random hue (RGB, 0..255), far from the greys around it."""
    import colorsys

    return 255.0 * np.array(colorsys.hsv_to_rgb(rng.uniform(0, 1), rng.uniform(0.6, 0.8), value))


def _rectangle(
    rng: np.random.Generator, n: int
) -> tuple[list[np.ndarray], list[np.ndarray], np.ndarray]:
    xx, yy = _grid()
    frames, masks = [], []
    w, h = rng.uniform(48.0, 68.0), rng.uniform(32.0, 46.0)
    colour = _saturated(rng, 0.75)
    periods = rng.uniform([100.0, 75.0, 60.0, 35.0], [140.0, 105.0, 80.0, 45.0])

    def corner(f: int) -> tuple[float, float]:
        x = 60.0 + 140.0 * (0.5 - 0.5 * np.cos(2 * np.pi * f / periods[0]))
        return x, 70.0 + 60.0 * np.sin(2 * np.pi * f / periods[1])

    for f in range(n):
        x0, y0 = corner(f)
        gain = 1.0 + 0.3 * np.sin(2 * np.pi * f / periods[2])
        image = np.full((HEIGHT, WIDTH, 3), 120.0) + 30 * np.sin(xx / 40.0)[..., None]
        rect = (xx >= x0) & (xx < x0 + w) & (yy >= y0) & (yy < y0 + h)
        image[rect] = colour
        # A specular highlight: a white lobe sliding over the rectangle.
        hx = x0 + w * (0.5 + 0.35 * np.sin(2 * np.pi * f / periods[3]))
        lobe = 110.0 * np.exp(-((xx - hx) ** 2 + (yy - y0 - h / 2) ** 2) / (2 * 6.0**2))
        image[rect] += lobe[rect][:, None]
        frames.append(_finish(rng, image * gain))
        masks.append(rect)
    # The outline of frame 0's pixels: centres x0 .. x0 + w - 1 along the first row...
    ys, xs = np.nonzero(masks[0])
    x0, y0, x1, y1 = xs.min(), ys.min(), xs.max(), ys.max()
    outline = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=np.float64)
    return frames, masks, outline


def _nonrigid(
    rng: np.random.Generator, n: int, clutter: bool
) -> tuple[list[np.ndarray], list[np.ndarray], np.ndarray]:
    background = _texture(rng, "grass" if clutter else "brick")
    xx, yy = _grid()
    colour = _saturated(rng, 0.9)
    radius = rng.uniform(20.0, 27.0)
    periods = rng.uniform([130.0, 95.0], [170.0, 125.0])
    phase = rng.uniform(0.0, 2 * np.pi, 2)

    def track(f: int) -> tuple[float, float]:
        return (
            160.0 + 90.0 * np.sin(2 * np.pi * f / periods[0] + phase[0]),
            120.0 + 55.0 * np.sin(2 * np.pi * f / periods[1] + phase[1]),
        )

    # Same-colour distractors of other shapes: a long bar sweeping across the path and
    # a thin ring on the path, both where the target passes.
    bar_period, bar_phase = rng.uniform(85.0, 110.0), rng.uniform(0.0, 2 * np.pi)
    ring_centre = track(int(rng.integers(n // 4, max(n // 4 + 1, 3 * n // 4))))
    frames, masks = [], []
    for f in range(n):
        poly = _star(*track(f), radius, 0.15 * f)
        mask = polygon_mask(poly, (HEIGHT, WIDTH))
        image = background.copy()
        if clutter:
            bx = 160.0 + 120.0 * np.sin(2 * np.pi * f / bar_period + bar_phase)
            bar = (np.abs(xx - bx) < 5) & (np.abs(yy - 120.0) < 70)
            ring = np.abs(np.hypot(xx - ring_centre[0] - 40.0, yy - ring_centre[1]) - 22.0) < 3.0
            image[(bar | ring) & ~mask] = colour
        image[mask] = colour
        frames.append(_finish(rng, image))
        masks.append(mask)
    return frames, masks, _star(*track(0), radius, 0.0)


def shape_sequence(name: Experiment, frames: int = 120, seed: int = 0) -> ShapeSequence:
    """The seeded sequence of experiment ``name`` (see the module's documentation)."""
    n = whole_number(frames, "frames", 1, limit=100_000)
    seed = whole_number(seed, "seed", 0, limit=2**63)
    rng = np.random.default_rng(seed)
    if name == "circles":
        f, m, outline = _circles(rng, n)
    elif name == "rectangle":
        f, m, outline = _rectangle(rng, n)
    elif name in ("nonrigid", "clutter"):
        f, m, outline = _nonrigid(rng, n, clutter=name == "clutter")
    else:
        raise ValueError(f"experiment must be one of {EXPERIMENTS}, got {excerpt(name)}")
    space: Literal["rgb", "opponent"] = "rgb" if name == "circles" else "opponent"
    return ShapeSequence(name, np.stack(f), np.stack(m), np.asarray(outline, float), space, seed)
