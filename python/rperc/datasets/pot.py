"""POT-210 planar-tracking ground truth (Liang et al., "Planar Object Tracking in the
Wild", 2018): a sequence folder holds ``gt_corners.txt``, one line per frame ``x1 y1 x2
y2 x3 y3 x4 y4`` (top-left, top-right, bottom-right, bottom-left, as defined in frame
1), and ``gt_flag.txt``, one integer per frame: 0 visible, 1 occluded, 2 out of view."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from rperc.datasets._text import read_text, split_lines
from rperc.datasets.errors import DatasetFormatError

#: ``gt_flag.txt``'s values: visible, occluded, out of view.
VISIBLE, OCCLUDED, OUT_OF_VIEW = 0, 1, 2


@dataclass(frozen=True)
class PlanarTruth:
    """``corners``: ``(n, 4, 2)`` float64 per frame; ``flags``: ``(n,)`` int (0 visible,
    1 occluded, 2 out of view; all 0 when the folder has no ``gt_flag.txt``)."""

    corners: npt.NDArray[np.float64]
    flags: npt.NDArray[np.int64]

    @property
    def visible(self) -> npt.NDArray[np.bool_]:
        """Frames whose flag is 0, the frames POT-210 scores."""
        return np.asarray(self.flags == VISIBLE)


def _records(path: Path) -> list[tuple[int, list[str]]]:
    """(line number, fields) of every non-blank line."""
    return [
        (k, line.split())
        for k, line in enumerate(split_lines(read_text(path)), start=1)
        if line.strip()
    ]


def read_corners(path: str | Path) -> npt.NDArray[np.float64]:
    """``gt_corners.txt`` as ``(n, 4, 2)``; a line without 8 finite numbers is a
    :class:`DatasetFormatError` naming its file and line."""
    path = Path(path)
    rows = []
    for k, fields in _records(path):
        try:
            values = [float(v) for v in fields]
        except ValueError:
            values = []
        if len(values) != 8 or not all(math.isfinite(v) for v in values):
            raise DatasetFormatError(
                path, k, f"expected 8 finite numbers, got {len(fields)} fields"
            )
        rows.append(values)
    if not rows:
        raise DatasetFormatError(path, 0, "no corners")
    return np.array(rows, dtype=np.float64).reshape(-1, 4, 2)


def read_flags(path: str | Path) -> npt.NDArray[np.int64]:
    """``gt_flag.txt`` as ``(n,)``; a line that is not 0, 1 or 2 is a
    :class:`DatasetFormatError` naming its file and line."""
    path = Path(path)
    flags = []
    for k, fields in _records(path):
        if len(fields) != 1 or fields[0] not in ("0", "1", "2"):
            raise DatasetFormatError(
                path, k, f"expected a flag 0, 1 or 2, got {' '.join(fields)!r}"
            )
        flags.append(int(fields[0]))
    return np.array(flags, dtype=np.int64)


def load_planar_truth(folder: str | Path) -> PlanarTruth:
    """The ground truth of a POT-210 sequence folder; ``gt_flag.txt`` must list as many
    frames as ``gt_corners.txt`` when present."""
    folder = Path(folder)
    corners = read_corners(folder / "gt_corners.txt")
    flag_file = folder / "gt_flag.txt"
    if not flag_file.exists():
        return PlanarTruth(corners, np.zeros(len(corners), dtype=np.int64))
    flags = read_flags(flag_file)
    if len(flags) != len(corners):
        raise DatasetFormatError(
            flag_file, 0, f"{len(flags)} flags for {len(corners)} frames of gt_corners.txt"
        )
    return PlanarTruth(corners, flags)
