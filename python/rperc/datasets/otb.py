"""OTB (Object Tracking Benchmark, Wu, Lim & Yang) sequences: ``img/0001.jpg ...`` and
``groundtruth_rect.txt`` with one ``x y w h`` box per frame (1-based top-left corner,
separated by tabs, commas or spaces)."""

from __future__ import annotations

import re
import warnings
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rperc import _rperc
from rperc.datasets._text import read_text
from rperc.datasets.errors import DatasetFormatError

_IMAGE_SUFFIXES = {".jpg", ".jpeg", ".png"}


@dataclass(frozen=True, repr=False)
class OtbSequence:
    """A sequence: frame paths in order and ground-truth boxes ``(x, y, w, h)`` with a
    0-based top-left corner (converted from OTB's 1-based files)."""

    name: str
    frame_paths: list[Path]
    boxes: np.ndarray  # (N, 4) float64

    def __len__(self) -> int:
        return len(self.frame_paths)

    def frame(self, k: int) -> np.ndarray:
        """Frame ``k`` as an H x W x 3 uint8 RGB array. 16-bit images are scaled to 8
        bits (the high byte), not clipped to white as Pillow's ``convert`` would."""
        from PIL import Image

        with Image.open(self.frame_paths[k]) as img:
            if img.mode in ("I;16", "I;16B", "I;16L", "I"):
                deep = np.asarray(img, dtype=np.int64)
                if deep.min() < 0 or deep.max() > 65535:
                    raise DatasetFormatError(
                        self.frame_paths[k], 0, f"{img.mode} pixel values outside 0..65535"
                    )
                grey = (deep >> 8).astype(np.uint8)
                return np.repeat(grey[:, :, None], 3, axis=2)
            return np.asarray(img.convert("RGB"))

    def frames(self) -> Iterator[np.ndarray]:
        for k in range(len(self)):
            yield self.frame(k)

    def __repr__(self) -> str:
        return f"OtbSequence({self.name!r}, {len(self)} frames)"


def read_boxes(path: str | Path) -> np.ndarray:
    """Ground-truth boxes of an OTB file, converted from OTB's 1-based corners to
    0-based ones (``x - 1, y - 1``). Parsed by the same Rust reader as ``track_otb``:
    four numbers per line separated by tabs, commas or spaces; a blank line inside the
    file, a non-finite value or a negative size is a :class:`DatasetFormatError` naming
    the file and line (blank lines at the end are allowed)."""
    path = Path(path)
    try:
        return _rperc.otb_groundtruth(read_text(path), str(path))
    except ValueError as exc:
        where = _LOCATION.match(str(exc))
        if where is None:
            raise
        raise DatasetFormatError(where["path"], int(where["line"]), where["reason"]) from None


# "file:line: reason", the format of the Rust parser's errors.
_LOCATION = re.compile(r"^(?P<path>.*):(?P<line>\d+): (?P<reason>.*)$", re.S)


def load_otb(path: str | Path) -> OtbSequence:
    """Read an OTB sequence folder: ``img/`` (frames, sorted by name) and
    ``groundtruth_rect.txt``. Frames are read lazily (:meth:`OtbSequence.frame`).

    OTB's boxes have a 1-based top-left corner (MATLAB's convention: the top-left pixel
    is ``(1, 1)``); they are returned 0-based, ``(x - 1, y - 1, w, h)``, the convention
    of numpy indexing and of rperc's and OpenCV's trackers. Width and height are
    unchanged.

    A folder with more images than boxes (OTB's Football1 has 74 boxes for 75 images)
    uses the first ``len(boxes)`` images and warns (``UserWarning``). Raises
    ``FileNotFoundError`` for a missing folder, and :class:`DatasetFormatError` for a
    malformed ground-truth line or fewer images than boxes.
    """
    root = Path(path)
    gt = root / "groundtruth_rect.txt"
    if not gt.exists():
        raise FileNotFoundError(f"{gt} not found (is {root} an OTB sequence folder?)")
    if not (root / "img").is_dir():
        raise FileNotFoundError(f"{root / 'img'} not found (is {root} an OTB sequence folder?)")
    frames = sorted(p for p in (root / "img").iterdir() if p.suffix.lower() in _IMAGE_SUFFIXES)
    boxes = read_boxes(gt)
    if len(frames) < len(boxes):
        raise DatasetFormatError(
            gt, len(boxes), f"{len(boxes)} boxes for {len(frames)} frames in {root / 'img'}"
        )
    if len(frames) > len(boxes):
        warnings.warn(
            f"{root.name}: {len(frames)} images but {len(boxes)} boxes in {gt.name}; "
            f"using the first {len(boxes)} images",
            UserWarning,
            stacklevel=2,
        )
        frames = frames[: len(boxes)]
    return OtbSequence(root.name, frames, boxes)
