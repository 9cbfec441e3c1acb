"""rperc: robot perception in Rust, driven from Python.

Subpackages:

- :mod:`rperc.linesimp` -- Douglas-Peucker line simplification (plain and
  Hershberger-Snoeyink path hulls) and wall extraction from 2-D laser scans;
- :mod:`rperc.slam` -- EKF-SLAM and the monobot observability study;
- :mod:`rperc.tracking` -- CONDENSATION and colour-histogram tracking, OTB metrics;
- :mod:`rperc.datasets` -- readers for the public data sets (CARMEN logs, WKT, OTB);
- the ``rperc`` command-line program (:mod:`rperc.cli`).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from rperc._rperc import NumericalError, RpercError, __version__

__all__ = ["NumericalError", "RpercError", "__version__"]

#: The subpackages ``rperc.<name>`` reaches after a plain ``import rperc``.
SUBPACKAGES = ("bench", "datasets", "linesimp", "navigation", "plot", "pose", "slam", "tracking")


def __getattr__(name: str) -> Any:
    # Loaded on first use, not at import: the ``rperc`` command imports this package
    # before it can catch Ctrl-C, and the extension pulls in numpy (issue 38).
    if name in __all__:
        from rperc import _rperc

        return getattr(_rperc, name)
    if name in SUBPACKAGES:
        return importlib.import_module(f"rperc.{name}")
    raise AttributeError(f"module 'rperc' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__, *SUBPACKAGES})
