"""``rperc demo visual-memory``: paper [001]'s section 4.2 (Fig. 9) in a ceiling world
with ground truth: learn a path A -> B (mosaic and key images), replay it by visual
servoing from perturbed starts, and score the mosaic, the localisation and the replays
against the truth."""

from __future__ import annotations

import math
import os
from concurrent.futures import Executor, ThreadPoolExecutor
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from rperc.cli.outputs import DemoResult
from rperc.config import CameraMount, CeilingCameraConfig, CeilingConfig, CeilingRenderConfig

if TYPE_CHECKING:
    from rperc.navigation import CeilingWorld, Evaluation, Learning, ReplayResult

# The demo's world: a 12 x 8 m ceiling, a camera tilted by a few degrees and offset
# from the robot's centre (eq. 1 corrects it), grey-level noise sigma 2, lighting
# changes and an occasional occluder.
CAMERA = CeilingCameraConfig(
    mount=CameraMount(roll=0.03, pitch=-0.02, yaw=0.01, offset=(0.08, -0.03, 0.3))
)
RENDER = CeilingRenderConfig(noise=2.0, occluder_probability=0.02)
START = (2.5, 2.5, 0.2)


def s_path(steps: int = 160, speed: float = 0.3, turn: float = 0.15) -> np.ndarray:
    """An S-shaped path: ``steps`` commands of 0.1 s, turning left then right."""
    omega = np.where(np.arange(steps) < steps // 2, turn, -turn)
    return np.column_stack([np.full(steps, speed), omega]).astype(np.float64)


def run_visual_memory(
    seed: int, starts: int, executor: Executor | None = None
) -> tuple[CeilingWorld, Learning, Evaluation, list[ReplayResult]]:
    """The world, the learning run, the evaluation and the replays of the demo."""
    from rperc.navigation import CeilingWorld, evaluate, learn

    world = CeilingWorld(CeilingConfig(seed=seed), CAMERA, RENDER.replace(seed=seed))
    learning = learn(world, START, s_path(), dt=0.1, seed=seed)
    evaluation, runs = evaluate(
        world, learning, starts=starts, seed=seed, executor=executor, show_progress=True
    )
    return world, learning, evaluation, runs


def demo_visual_memory(out: Path, seed: int, starts: int = 10) -> DemoResult:
    """Learn the S-path, replay it from ``starts`` perturbed starts (10 cm, 10 cm,
    0.1 rad), Fig. 9-style figure and an animated strip of one replay."""
    from rperc.plot import save
    from rperc.plot.navigation import replay_strip, visual_memory_figure

    # The replays are independent and release the GIL (each is seeded on its own, so
    # the answers do not depend on the order they finish in): one thread per core.
    # On Ctrl-C the replays not yet started are cancelled; a `with` block would run
    # every queued one before the interrupt reached the user.
    pool = ThreadPoolExecutor(max_workers=os.cpu_count() or 1)
    try:
        world, learning, ev, runs = run_visual_memory(seed, starts, pool)
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
    figures = [save(visual_memory_figure(world, learning, ev, runs), out / "visual_memory.png")]
    figures += replay_strip(world, learning, runs[0], out)
    m = ev.to_dict()
    summary = (
        f"visual-memory: {learning.memory.n_models} models, "
        f"{len(learning.memory.key_images)} key images; mosaic {m['mosaic_error_cm']:.2f} cm "
        f"{m['mosaic_error_deg']:.2f} deg; localisation {m['localization_error_cm']:.2f} cm "
        f"{m['localization_error_deg']:.2f} deg RMS, NEES {m['nees']:.1f} (3 when honest); "
        f"B reached {100 * m['success_rate']:.0f} % "
        f"of {starts} starts, median final error {m['final_error_cm']:.1f} cm; "
        f"{m['hz']:.0f} Hz (rendering excluded)"
    )
    measured = {**m, "models": learning.memory.n_models,
                "key_images": len(learning.memory.key_images),
                "outcomes": [r.outcome for r in runs]}  # fmt: skip
    details = [f"{k}: {v:.4g}" for k, v in m.items() if isinstance(v, float) and math.isfinite(v)]
    return DemoResult(summary, figures, measured, details=details)
