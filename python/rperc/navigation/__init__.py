"""Visual memory on a ceiling (paper [001], Ait Aider et al., section 2), typed.

A robot with an upward-looking camera builds a mosaic of the 2-D patterns on the
ceiling, localises itself against it (eq. 2), stores a path as key images and replays
it by visual servoing. No public ceiling-camera data set has ground truth, so this
package starts with a seeded ceiling world that has it (:class:`CeilingWorld`).
"""

from __future__ import annotations

from rperc.navigation.memory import (
    Evaluation,
    Frames,
    Learning,
    ReplayResult,
    VisualMemory,
    evaluate,
    learn,
    replay,
    starts_around,
)
from rperc.navigation.world import CeilingWorld, Drive, defaults, drive

__all__ = [
    "CeilingWorld",
    "Drive",
    "Evaluation",
    "Frames",
    "Learning",
    "ReplayResult",
    "VisualMemory",
    "defaults",
    "drive",
    "evaluate",
    "learn",
    "replay",
    "starts_around",
]
