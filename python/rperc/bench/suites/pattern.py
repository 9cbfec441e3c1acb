"""``rperc bench pattern``: the pattern tracker of paper [001] and OpenCV's peers on
generated sequences (a patch moving over clutter, paper [001] section 4.1), every
parameter stepping uniformly up to ``steps`` sigma of paper [001]'s evolution model at
once. One row per case, tracker and seed (the seed draws the sequence and the
tracker's particles): RMS errors of the position (px), angle (degrees) and scale (%),
the alignment error of the four corners (median, precision at 5 and 15 px), POT-210's
mean corner distance and its precision at 5 and 15 px, frames lost or failed, and fps.

The patch is cut from ``images/camera.png`` and moved over ``images/grass.png`` of the
data folder; without it a generated patch and block clutter are used (the row's
``images`` column says which). The sequence is generated on the worker from the seed:
only its description travels.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from rperc._args import excerpt
from rperc._extras import require
from rperc.bench.tasks import Row, Task
from rperc.pose import wrap_angle

TRACKERS = (
    "rperc",
    "ecc-euclidean",
    "ecc-affine",
    "ecc-homography",
    "orb-ransac",
    "match-template",
    "csrt",
)
#: The pattern tracker's motion models (``--motion``).
MOTIONS = ("similarity", "homography")
DEFAULT_TRACKERS = ("rperc", "ecc-affine")
SHOWN = ("position_rms_px", "angle_rms_deg", "scale_rms_pct", "precision_5px", "failures", "fps")
PRIMARY = ("position_rms_px", "px")
#: Paper [001]'s evolution model (section 4.1): 5 px, 5 px, 3 degrees, 0.1 scale.
SIGMA = (5.0, 5.0, math.radians(3.0), 0.1)


#: What a case adds to the steps (the cases the harness runs): nothing; a gain drawn per
#: frame in ``1 +- 0.2``; a band of clutter hiding up to 30 % of the patch; or the patch
#: seen in perspective (:func:`rperc.tracking.perspective.perspective_sequence`, OpenCV
#: draws it: centre, angle and scale step up to the bound in sigma, and each corner is
#: pushed off the similarity by up to 2 px per sigma of the bound a frame).
CONDITIONS = {
    "plain": "",
    "gain": " gain 0.2",
    "occlusion": " occlusion 0.3",
    "perspective": " perspective",
}
GAIN = 0.2
OCCLUSION = 0.3


def case_name(steps: float, condition: str = "plain") -> str:
    """A generated case's name: its step bound in sigmas and its condition."""
    if condition not in CONDITIONS:
        raise ValueError(f"condition {excerpt(condition)}: expected one of {', '.join(CONDITIONS)}")
    return f"steps<={steps:g}sigma{CONDITIONS[condition]}"


def case_condition(name: str) -> tuple[float, str]:
    """The step bound and condition of a case named by :func:`case_name`."""
    condition = next(
        (c for c, suffix in CONDITIONS.items() if suffix and name.endswith(suffix)), "plain"
    )
    body = name.removesuffix(CONDITIONS[condition])
    body = body.removeprefix("steps<=").removesuffix("sigma")
    try:
        return float(body), condition
    except ValueError:
        raise ValueError(
            f"{excerpt(name)} is not a generated pattern case (steps<=Nsigma[ gain 0.2|"
            " occlusion 0.3])"
        ) from None


def case_steps(name: str) -> float:
    """The step bound of a case named by :func:`case_name`."""
    return case_condition(name)[0]


def parse_conditions(text: str) -> list[str]:
    """Comma-separated conditions of :data:`CONDITIONS`."""
    names = [c.strip() for c in text.split(",") if c.strip()]
    bad = [c for c in names if c not in CONDITIONS]
    if not names or bad:
        raise ValueError(f"--conditions {excerpt(text)}: expected some of {', '.join(CONDITIONS)}")
    return list(dict.fromkeys(names))


def parse_steps(text: str) -> list[float]:
    """Comma-separated step bounds in sigmas, each in (0, 10]."""
    try:
        steps = [float(s) for s in text.split(",") if s.strip()]
    except ValueError:
        raise ValueError(f"--steps {excerpt(text)}: expected numbers such as 1,2,3") from None
    if not steps or not all(0 < s <= 10 for s in steps):
        raise ValueError(f"--steps {excerpt(text)}: each bound must be in (0, 10] sigma")
    return list(dict.fromkeys(steps))


def settings_taken() -> set[str]:
    """The fields of :class:`rperc.config.PatternConfig`: what a settings grid may set
    (a nested part as a dict of its fields)."""
    import dataclasses

    from rperc.config import PatternConfig

    return {f.name for f in dataclasses.fields(PatternConfig)}


def images(root: str) -> tuple[np.ndarray, np.ndarray, str]:
    """(patch, background, where from): camera.png over grass.png from ``root``'s
    ``images/``, else the generated pair of ``rperc demo pattern``."""
    folder = Path(root) / "images" if root else None
    if (
        folder is not None
        and (folder / "camera.png").is_file()
        and (folder / "grass.png").is_file()
    ):
        from PIL import Image

        with Image.open(folder / "camera.png") as cam, Image.open(folder / "grass.png") as grass:
            camera = np.asarray(cam.convert("L"), dtype=np.float64)
            background = np.asarray(grass.convert("L"), dtype=np.float64)
        return camera[60:160, 200:300], background, "camera.png over grass.png"
    from rperc.tracking.synthetic import demo_images

    patch, background = demo_images(0)
    return patch, background, "generated"


def corner_pose(corners: np.ndarray, width: float) -> np.ndarray:
    """``(x, y, theta, scale)`` per frame of corners ``(n, 4, 2)``: the centre, the
    top edge's angle (counter-clockwise on screen) and its length over ``width``."""
    c = np.asarray(corners, dtype=np.float64)
    centre = c.mean(axis=1)
    top = c[:, 1] - c[:, 0]
    theta = np.arctan2(-top[:, 1], top[:, 0])
    pose: np.ndarray = np.c_[centre, theta, np.hypot(top[:, 0], top[:, 1]) / width]
    return pose


def _tracker(name: str, settings: dict[str, Any], seed: int) -> Any:
    from rperc.tracking import planar

    if name == "rperc":
        return lambda f, r: planar.run_pattern(f, r, seed=seed, **settings)
    if settings:
        raise ValueError(f"the OpenCV peer {name} takes no settings")
    return {
        "ecc-euclidean": lambda f, r: planar.run_ecc(f, r, "euclidean"),
        "ecc-affine": lambda f, r: planar.run_ecc(f, r, "affine"),
        "ecc-homography": lambda f, r: planar.run_ecc(f, r, "homography"),
        "orb-ransac": planar.run_orb,
        "match-template": planar.run_match_template,
        "csrt": planar.run_csrt,
    }[name]


def run(task: Task) -> Row:
    """One tracker on one generated case."""
    from rperc.tracking import planar

    steps, condition = case_condition(task.dataset)
    patch, background, source = images(task.text("images"))
    frames, region, truth = sequence(patch, background, steps, condition, task)
    if task.method not in TRACKERS:
        raise ValueError(
            f"unknown tracker {excerpt(task.method)}; expected one of {', '.join(TRACKERS)}"
        )
    settings = dict(task.kwargs)
    motion = task.text("motion") or "similarity"
    if task.method == "rperc":
        settings["motion"] = motion
    result = _tracker(task.method, settings, task.seed)(frames, region)
    s = planar.score(task.dataset, result, truth)
    # Every generated frame shows the patch (occlusion hides part of it, never all).
    pot = planar.pot_score(result.corners, truth, np.ones(len(truth), bool))
    est = corner_pose(result.corners, region[2])
    ref = corner_pose(truth, region[2])
    err = est - ref
    err[:, 2] = wrap_angle(err[:, 2])
    rms = np.sqrt(np.nanmean(err**2, axis=0))
    return {
        "library": f"rperc {motion}" if task.method == "rperc" else "OpenCV " + _cv2_version(),
        "images": source,
        "frames": len(truth),
        "position_rms_px": float(math.hypot(rms[0], rms[1])),
        # A position-only peer (CSRT) estimates no angle or scale.
        "angle_rms_deg": math.nan if result.position_only else float(math.degrees(rms[2])),
        "scale_rms_pct": math.nan
        if result.position_only
        else float(100 * np.sqrt(np.nanmean((est[:, 3] / ref[:, 3] - 1) ** 2))),
        "median_alignment_px": s.median_alignment,
        "precision_5px": s.precision_5,
        "precision_15px": s.precision_15,
        "mean_corner_error_px": pot.mean_corner_error_px,
        "precision_at_5": pot.precision_at_5,
        "precision_at_15": pot.precision_at_15,
        "failures": s.failures,
        "fps": s.fps,
    }


def sequence(
    patch: np.ndarray, background: np.ndarray, steps: float, condition: str, task: Task
) -> tuple[np.ndarray, tuple[int, int, int, int], np.ndarray]:
    """The case's frames, the region of frame 0 and the true corners of frames 1..n."""
    from rperc.tracking import pattern_sequence, planar

    n_frames = int(task.number("frames") or 40)
    if condition == "perspective":
        from rperc.tracking.perspective import perspective_sequence

        walk = (SIGMA[0] * steps, math.degrees(SIGMA[2]) * steps, SIGMA[3] * steps, 2.0 * steps)
        seq = perspective_sequence(patch, background, n_frames=n_frames, steps=walk, seed=task.seed)
        return seq.frames, seq.region, seq.corners[1:]
    gain = GAIN if condition == "gain" else 0.0
    generated = pattern_sequence(
        patch,
        background,
        n_frames=n_frames,
        width=640,
        height=480,
        max_step_sigmas=steps,
        other_step_sigmas=steps,
        gain=(1.0 - gain, 1.0 + gain),
        max_occlusion=OCCLUSION if condition == "occlusion" else 0.0,
        seed=task.seed,
    )
    return generated.frames, generated.region, planar.truth_corners(generated)


def _cv2_version() -> str:
    cv2 = require("cv2", "the OpenCV peers")
    return str(cv2.__version__)
