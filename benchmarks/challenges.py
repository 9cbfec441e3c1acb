"""Seeded synthetic tracking sequences, each with one of the difficulties that break
colour trackers on real video, and their exact boxes:

- ``"fast"``: the target jumps 12 to 24 px per frame, bouncing off the frame's edges;
- ``"scale"``: it grows to twice its size and shrinks to 0.6 of it while it moves;
- ``"occlusion"``: a block of background texture passes over it, hiding it entirely for
  a few frames, twice;
- ``"distractors"``: three discs in the target's two colours wander around it.

The background is one of the textured images in ``$RPERC_DATA/images`` (brick,
camera, coins, grass; chosen by the seed, tinted and cropped at random), or seeded
blocky noise without the data folder. The target is a two-coloured ellipse (upper and
lower colour drawn per seed, saturated, away from the tinted greys of the background).
Boxes follow :mod:`rperc.datasets`: ``(x, y, w, h)``, 0-based top-left corner, the
box of the ellipse drawn in the frame (OTB keeps boxes during occlusions, so do these).

These sequences, with OTB Couple, are what the colour trackers' defaults are set on;
OTB Girl is held out. An experiment harness, so it lives with the benchmarks, not in
the installed package (issue 36): ``benchmarks/tracking.py`` and the tests (through
``tests/conftest.py``) import it as ``challenges``.

Examples
--------
>>> from challenges import challenge_sequence
>>> seq = challenge_sequence("fast", frames=4, seed=1)
>>> seq.frames.shape, seq.boxes.shape
((4, 240, 320, 3), (4, 4))
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import numpy as np

from rperc._args import excerpt, whole_number
from rperc.datasets import data_dir
from rperc.tracking.synthetic import SyntheticSequence

__all__ = ["CHALLENGES", "Challenge", "challenge_sequence"]

Challenge = Literal["fast", "scale", "occlusion", "distractors"]
CHALLENGES: tuple[Challenge, ...] = ("fast", "scale", "occlusion", "distractors")
HEIGHT, WIDTH = 240, 320
TARGET = (36.0, 50.0)  # (w, h) at scale 1, px
TEXTURES = ("brick", "camera", "coins", "grass")
NOISE = 4.0  # grey levels


def _texture(rng: np.random.Generator, seed: int) -> np.ndarray:
    """A tinted, randomly cropped data image (H x W x 3 float), or blocky noise."""
    path = (data_dir() or Path("absent")) / "images" / f"{TEXTURES[seed % 4]}.png"
    if path.is_file():
        from PIL import Image

        with Image.open(path) as img:
            grey = np.asarray(img.convert("L"), np.float64)
        reps = (-(-2 * HEIGHT // grey.shape[0]), -(-2 * WIDTH // grey.shape[1]))
        grey = np.tile(grey, reps)
        y0 = int(rng.integers(0, grey.shape[0] - HEIGHT + 1))
        x0 = int(rng.integers(0, grey.shape[1] - WIDTH + 1))
        grey = grey[y0 : y0 + HEIGHT, x0 : x0 + WIDTH]
    else:
        blocks = rng.normal(128.0, 40.0, (HEIGHT // 8, WIDTH // 8))
        grey = np.kron(blocks, np.ones((8, 8))).astype(np.float64)
    tint = rng.uniform(0.6, 0.9, size=3)
    return np.asarray(np.clip(grey[..., None] * tint + 20.0, 0.0, 255.0))


def _colours(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Two saturated colours of distinct hue for the target's upper and lower parts."""
    import colorsys

    hue = rng.uniform(0, 1)
    upper = colorsys.hsv_to_rgb(hue, rng.uniform(0.7, 1.0), rng.uniform(0.35, 0.6))
    lower = colorsys.hsv_to_rgb((hue + rng.uniform(0.25, 0.5)) % 1, rng.uniform(0.6, 0.9), 0.9)
    return 255 * np.array(upper), 255 * np.array(lower)


def _draw_ellipse(
    frame: np.ndarray, cx: float, cy: float, w: float, h: float, colours: tuple[np.ndarray, ...]
) -> None:
    """Fill the pixels whose centres lie inside the ellipse inscribed in the box, the
    top 40 % of its rows in the first colour."""
    y0, y1 = max(int(cy - h / 2) - 1, 0), min(int(cy + h / 2) + 2, HEIGHT)
    x0, x1 = max(int(cx - w / 2) - 1, 0), min(int(cx + w / 2) + 2, WIDTH)
    if y0 >= y1 or x0 >= x1:
        return
    py, px = np.mgrid[y0:y1, x0:x1] + 0.5
    inside = ((px - cx) / (w / 2)) ** 2 + ((py - cy) / (h / 2)) ** 2 <= 1.0
    upper = py < cy - h / 2 + 0.4 * h
    patch = frame[y0:y1, x0:x1]
    patch[inside & upper] = colours[0]
    patch[inside & ~upper] = colours[1]


def _bounce(
    rng: np.random.Generator, n: int, speed: tuple[float, float], w: np.ndarray, h: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Centres moving in straight lines at a random speed in ``speed`` (px per frame),
    reflected at the frame's edges (keeping the box inside), turning every 20 frames."""
    cx, cy = np.empty(n), np.empty(n)
    x, y = WIDTH / 2, HEIGHT / 2
    for k in range(n):
        if k % 20 == 0:
            angle, v = rng.uniform(0, 2 * np.pi), rng.uniform(*speed)
            vx, vy = v * np.cos(angle), v * np.sin(angle)
        lo_x, hi_x = w[k] / 2 + 2, WIDTH - w[k] / 2 - 2
        lo_y, hi_y = h[k] / 2 + 2, HEIGHT - h[k] / 2 - 2
        x, y = x + vx, y + vy
        if not lo_x <= x <= hi_x:
            vx, x = -vx, float(np.clip(x, lo_x, hi_x))
        if not lo_y <= y <= hi_y:
            vy, y = -vy, float(np.clip(y, lo_y, hi_y))
        cx[k], cy[k] = x, y
    return cx, cy


def _motion(kind: Challenge, rng: np.random.Generator, n: int) -> tuple[np.ndarray, ...]:
    """Centres and sizes of the target over ``n`` frames."""
    k = np.arange(n, dtype=np.float64)
    if kind == "scale":
        # 1 -> 2 -> 0.6 -> 1 over the sequence, smoothly (a sine in log scale).
        scale = np.clip(2.0 ** np.sin(2 * np.pi * k / n), 0.6, 2.0)
    else:
        scale = np.ones(n)
    w, h = TARGET[0] * scale, TARGET[1] * scale
    speed = {"fast": (12.0, 24.0), "scale": (0.5, 2.0)}.get(kind, (2.0, 5.0))
    cx, cy = _bounce(rng, n, speed, w, h)
    return cx, cy, w, h


def _occluder(k: int, n: int, cx: np.ndarray, cy: np.ndarray) -> tuple[int, int, int, int] | None:
    """A 90 x 90 block centred on the target for 8 frames at a third and at two thirds
    of the sequence (sliding in and out over 4 frames either side)."""
    for start in (n // 3, 2 * n // 3):
        if start - 4 <= k < start + 12:
            x, y = cx[min(start + 4, n - 1)], cy[min(start + 4, n - 1)]
            shift = (k - (start + 4)) * 12 if not start <= k < start + 8 else 0
            return int(x - 45 + shift), int(y - 45), 90, 90
    return None


def _distractor_paths(rng: np.random.Generator, n: int) -> list[tuple[np.ndarray, np.ndarray]]:
    return [_bounce(rng, n, (2.0, 5.0), np.full(n, 30.0), np.full(n, 30.0)) for _ in range(3)]


def challenge_sequence(kind: Challenge, frames: int = 150, seed: int = 0) -> SyntheticSequence:
    """The ``kind`` sequence of ``frames`` 320 x 240 frames; the same seed gives the same
    frames and boxes."""
    if kind not in CHALLENGES:
        raise ValueError(f"kind must be one of {', '.join(CHALLENGES)}, got {excerpt(kind)}")
    n = whole_number(frames, "frames", 2)
    seed = whole_number(seed, "seed", 0)
    rng = np.random.default_rng([seed, CHALLENGES.index(kind)])
    background = _texture(rng, seed)
    colours = _colours(rng)
    cx, cy, w, h = _motion(kind, rng, n)
    others = _distractor_paths(rng, n) if kind == "distractors" else []
    out = np.empty((n, HEIGHT, WIDTH, 3), dtype=np.uint8)
    for k in range(n):
        frame = background.copy()
        for dx, dy in others:
            _draw_ellipse(frame, dx[k], dy[k], 30.0, 30.0, colours)
        _draw_ellipse(frame, cx[k], cy[k], w[k], h[k], colours)
        block = _occluder(k, n, cx, cy) if kind == "occlusion" else None
        if block is not None:
            x, y, bw, bh = block
            xs, ys = slice(max(x, 0), max(x + bw, 0)), slice(max(y, 0), max(y + bh, 0))
            frame[ys, xs] = background[ys, xs][::-1, ::-1]
        noisy = frame + rng.normal(0.0, NOISE, frame.shape)
        out[k] = np.clip(np.rint(noisy), 0, 255).astype(np.uint8)
    boxes = np.stack([cx - w / 2, cy - h / 2, w, h], axis=1)
    return SyntheticSequence(f"{kind}-{seed}", out, boxes, background, np.ones(n), seed)
