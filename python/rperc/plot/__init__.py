"""Matplotlib figures of rperc's results.

Every function here builds a :class:`matplotlib.figure.Figure` object and never touches
pyplot's global state, so importing :mod:`rperc.plot` leaves the backend alone: the
figures display in a notebook (return them from a cell) and save headless alike. The
``rperc`` command selects the Agg backend itself.
"""

from __future__ import annotations

import sys
from pathlib import Path
from types import ModuleType

import numpy as np
import numpy.typing as npt
from matplotlib.axes import Axes
from matplotlib.backend_bases import FigureCanvasBase
from matplotlib.figure import Figure

from rperc._atomic import write_atomically

Limits = tuple[tuple[float, float], tuple[float, float]]

__all__ = ["Limits", "figure_format", "outside", "robust_limits", "save", "set_limits"]


def figure_format(path: str | Path) -> str:
    """The image format named by ``path``'s suffix (``"png"``, ``"pdf"``, ``"svg"``...).

    Matplotlib would append ``.png`` to a path without a suffix and so write a file
    other than the one asked for; that is refused here instead.
    """
    suffix = Path(path).suffix.lower().lstrip(".")
    supported = FigureCanvasBase.get_supported_filetypes()
    if suffix not in supported:
        names = ", ".join(f".{s}" for s in sorted(supported))
        raise ValueError(f"{path}: a figure file must end in one of {names}")
    return suffix


def save(fig: Figure, path: str | Path, *, dpi: int = 110) -> Path:
    """Write ``fig`` to exactly ``path`` (format from the suffix) and return the path.

    Raises ``FileNotFoundError`` naming the folder when it does not exist (folders are
    not created behind the caller's back) and ``ValueError`` for an unknown suffix.
    """
    path = Path(path)
    fmt = figure_format(path)
    folder = path.parent
    if not folder.is_dir():
        raise FileNotFoundError(f"folder {folder} does not exist (writing {path})")
    write_atomically(path, lambda tmp: fig.savefig(tmp, format=fmt, dpi=dpi, bbox_inches="tight"))
    if "matplotlib.pyplot" in sys.modules:  # a figure made by pyplot stays registered
        import matplotlib.pyplot as plt

        plt.close(fig)
    return path


def robust_limits(
    points: npt.ArrayLike,
    *,
    include: npt.ArrayLike | None = None,
    percentiles: tuple[float, float] = (1.0, 99.0),
    margin: float = 0.05,
) -> Limits:
    """Axis limits that show the bulk of ``points`` ((N, 2)) and all of ``include``.

    The per-axis ``percentiles`` of the points decide the box, so a few stray laser
    returns tens of metres out (or any planted outlier) do not shrink the data to a
    corner; every point of ``include`` (a trajectory, the true walls) is kept inside.
    The box then grows by ``margin`` times its larger side on each edge.
    """
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    pts = pts[np.isfinite(pts).all(axis=1)]
    boxes = []
    if len(pts):
        boxes.append(np.percentile(pts, percentiles, axis=0))  # rows: low, high
    if include is not None:
        inc = np.asarray(include, dtype=np.float64).reshape(-1, 2)
        inc = inc[np.isfinite(inc).all(axis=1)]
        if len(inc):
            boxes.append(np.stack([inc.min(axis=0), inc.max(axis=0)]))
    if not boxes:
        raise ValueError("robust_limits needs at least one finite point")
    low = np.min([b[0] for b in boxes], axis=0)
    high = np.max([b[1] for b in boxes], axis=0)
    pad = margin * max(float(np.max(high - low)), 1e-9)
    return (
        (float(low[0] - pad), float(high[0] + pad)),
        (float(low[1] - pad), float(high[1] + pad)),
    )


def set_limits(ax: Axes, limits: Limits, *, equal: bool = True) -> None:
    """Fix ``ax``'s limits (and an equal aspect for maps) so nothing rescales them."""
    ax.set_xlim(*limits[0])
    ax.set_ylim(*limits[1])
    if equal:
        ax.set_aspect("equal", adjustable="box")


def outside(points: npt.ArrayLike, limits: Limits) -> int:
    """How many finite ``points`` fall outside ``limits`` (to say so in a legend)."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    pts = pts[np.isfinite(pts).all(axis=1)]
    (x0, x1), (y0, y1) = limits
    inside = (pts[:, 0] >= x0) & (pts[:, 0] <= x1) & (pts[:, 1] >= y0) & (pts[:, 1] <= y1)
    return int(np.count_nonzero(~inside))


def __getattr__(name: str) -> ModuleType:
    # ``from rperc.plot import plt`` was the old way to make figures; it still works
    # for callers not yet moved to Figure objects, but pyplot is only imported (and a
    # backend chosen by matplotlib's own rules) when someone asks for it.
    if name == "plt":
        import matplotlib.pyplot as plt

        return plt
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
