"""rperc: robot perception in Rust, driven from Python.

Subpackages:

- :mod:`rperc.linesimp` -- Douglas-Peucker line simplification (plain and
  Hershberger-Snoeyink path hulls) and wall extraction from 2-D laser scans;
- :mod:`rperc.slam` -- EKF-SLAM and the monobot observability study;
- :mod:`rperc.tracking` -- CONDENSATION and colour-histogram tracking, OTB metrics;
- :mod:`rperc.datasets` -- readers for the public data sets (CARMEN logs, WKT, OTB);
- the ``rperc`` command-line program (:mod:`rperc.cli`).
"""

from rperc._rperc import NumericalError, RpercError, __version__

__all__ = ["NumericalError", "RpercError", "__version__"]
