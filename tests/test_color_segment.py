"""The colour+shape tracker's segmentation (seed 000 section 3.3) against a plain numpy
re-implementation: the histogram of a colour cloud, the bin of every pixel, ``H > 0``,
and the opening then closing that clean it."""

from __future__ import annotations

from typing import Literal

import numpy as np
import pytest

from rperc.tracking import color_segment


def _pixel_bins(frame: np.ndarray, space: str, bins: tuple[int, int, int]) -> np.ndarray:
    """Each pixel's bin index per axis, in integers: ``floor(v * n / range)`` of the
    seed's coordinates (RGB over 256; (B-G+255, G-R+255) over 511, R+G+B over 766)."""
    r, g, b = (frame[..., k].astype(np.int64) for k in range(3))
    if space == "rgb":
        axes, ranges = (r, g, b), (256, 256, 256)
    else:
        axes, ranges = (b - g + 255, g - r + 255, r + g + b), (511, 511, 766)
    return np.stack([(v * n) // m for v, n, m in zip(axes, bins, ranges, strict=True)], -1)


def _histogram(colours: np.ndarray, bins: tuple[int, int, int]) -> np.ndarray:
    """Counts of the colours in [0, 1)^3 per bin; others left out."""
    keep = np.all((colours >= 0.0) & (colours < 1.0), axis=1)
    n = np.array(bins)
    idx = np.minimum(np.floor(colours[keep] * n).astype(np.int64), n - 1)
    hist = np.zeros(bins, dtype=np.int64)
    np.add.at(hist, (idx[:, 0], idx[:, 1], idx[:, 2]), 1)
    return hist


def _morph(mask: np.ndarray, radius: int, erode: bool) -> np.ndarray:
    """Min (erode) or max (dilate) over the (2r+1)^2 square, pixels outside the image
    left out (padding with the operation's neutral value)."""
    if radius == 0:
        return mask
    h, w = mask.shape
    padded = np.pad(mask, radius, constant_values=erode)
    shifts = [
        padded[dy : dy + h, dx : dx + w]
        for dy in range(2 * radius + 1)
        for dx in range(2 * radius + 1)
    ]
    out: np.ndarray = np.logical_and.reduce(shifts) if erode else np.logical_or.reduce(shifts)
    return out


def _oracle(
    frame: np.ndarray, colours: np.ndarray, space: str, bins: tuple[int, int, int], radius: int
) -> tuple[np.ndarray, np.ndarray]:
    hist = _histogram(colours, bins)
    pb = _pixel_bins(frame, space, bins)
    raw = hist[pb[..., 0], pb[..., 1], pb[..., 2]] > 0
    opened = _morph(_morph(raw, radius, erode=True), radius, erode=False)
    closed = _morph(_morph(opened, radius, erode=False), radius, erode=True)
    return raw, closed


def _coords(pixels: np.ndarray, space: str) -> np.ndarray:
    p = pixels.astype(np.float64)
    if space == "rgb":
        return p / 256.0
    r, g, b = p[:, 0], p[:, 1], p[:, 2]
    return np.stack([(b - g + 255) / 511, (g - r + 255) / 511, (r + g + b) / 766], axis=1)


@pytest.mark.parametrize("space", ["rgb", "opponent"])
@pytest.mark.parametrize("seed", range(6))
def test_segmentation_matches_numpy(space: Literal["rgb", "opponent"], seed: int) -> None:
    rng = np.random.default_rng(seed)
    h, w = int(rng.integers(8, 40)), int(rng.integers(8, 50))
    # Blocky random frames, so the cleaned segmentation has structure to keep.
    small = rng.integers(0, 256, (h // 2 + 1, w // 2 + 1, 3), dtype=np.uint8)
    frame = np.ascontiguousarray(small.repeat(2, 0).repeat(2, 1)[:h, :w])
    b0, b1, b2 = (int(v) for v in rng.integers(2, 20, 3))
    bins = (b0, b1, b2)
    # The cloud: colours of some of the frame's own pixels, random ones, and a few
    # outside [0, 1) that the histogram must leave out.
    own = _coords(frame.reshape(-1, 3)[rng.integers(0, h * w, 40)], space)
    cloud = np.vstack([own, rng.uniform(0, 1, (30, 3)), rng.uniform(-1, 2, (10, 3))])
    radius = int(seed % 3)
    raw, cleaned = color_segment(
        frame,
        cloud,
        color_space=space,
        bins=bins,
        morphology_radius=radius,
    )
    want_raw, want_clean = _oracle(frame, cloud, space, bins, radius)
    assert raw.shape == (h, w) and raw.dtype == bool
    assert np.array_equal(raw, want_raw)
    assert np.array_equal(cleaned, want_clean)


def test_every_pixel_of_a_cloud_colour_is_segmented() -> None:
    # Closed form: a pixel whose own colour is in the cloud falls in a bin that holds it.
    rng = np.random.default_rng(9)
    frame = rng.integers(0, 256, (20, 30, 3), dtype=np.uint8)
    chosen = frame[5:9, 10:14].reshape(-1, 3)
    raw, _ = color_segment(frame, _coords(chosen, "opponent"), bins=(16, 16, 16))
    assert raw[5:9, 10:14].all()


def test_bad_arguments_are_refused() -> None:
    frame = np.zeros((4, 4, 3), dtype=np.uint8)
    with pytest.raises(ValueError, match="colours"):
        color_segment(frame, np.zeros((3, 2)))
    with pytest.raises(ValueError, match="color_space"):
        color_segment(frame, np.zeros((3, 3)), color_space="hsv")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="colours"):
        color_segment(frame, np.full((3, 3), np.nan))
