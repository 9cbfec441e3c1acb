"""The numpy oracles of ``tests/oracles`` (one copy, shared with the tests), made
importable from the benchmark scripts, which run from this folder."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from oracles import linesimp, planar_ekf, wall_ekf, wall_smoother

__all__ = ["linesimp", "planar_ekf", "wall_ekf", "wall_smoother"]
