"""``rperc bench mrclam``: MR.CLAM robots through planar EKF-SLAM with paper [000]'s
variants, exactly as ``rperc slam mrclam`` runs them. One row per robot, variant and
seed (the seed draws the external variant's fix noise; the other variants use the
recording as it is): ATE against Vicon (raw and aligned), the landmark error after
alignment, the robot NEES mean and share in band, and events per second.

Variants, combinable with ``+``: ``plain``, ``anchor``, ``external``, ``freeze``, and
``smooth`` (the run smoothed afterwards; its ``ate_aligned_causal_m`` is the filter's). A
settings grid may set any planar EKF config field (``rperc.slam.planar.defaults()``).
"""

from __future__ import annotations

import time

from rperc._args import excerpt
from rperc.bench.tasks import Row, Task, parse_names

VARIANT_PARTS = ("plain", "anchor", "external", "freeze", "smooth")
DEFAULT_VARIANTS = ("plain", "anchor", "external", "smooth")
SHOWN = ("ate_m", "ate_aligned_m", "landmark_rmse_aligned_m", "nees_mean", "nees_in_band")
PRIMARY = ("ate_aligned_m", "m")


def parse_variants(text: str) -> list[str]:
    """Comma-separated variants, each a ``+``-joined combination of
    :data:`VARIANT_PARTS`."""
    out = [
        "+".join(parse_names(v.replace("+", ","), VARIANT_PARTS, "--variants"))
        for v in text.split(",")
        if v.strip()
    ]
    if not out:
        raise ValueError(f"--variants {excerpt(text)}: no variant")
    for v in out:
        parts = set(v.split("+"))
        if "smooth" in parts and parts & {"anchor", "external"}:
            raise ValueError(
                f"--variants {excerpt(text)}: smooth models odometry and sightings only, "
                "not with anchor or external"
            )
    return list(dict.fromkeys(out))


def parse_robots(text: str) -> list[int]:
    """``"1-3"`` or ``"1,3"``: robots between 1 and 5."""
    from rperc.bench.tasks import parse_seeds

    robots = parse_seeds(text)
    if not robots or robots[0] < 1 or robots[-1] > 5:
        raise ValueError(f"--robots {excerpt(text)}: MR.CLAM robots are 1-5")
    return robots


def settings_taken() -> set[str]:
    from rperc.slam.planar import defaults

    return set(defaults())


def run(task: Task) -> Row:
    """One robot (``dataset`` is ``robotN``) with one variant: ``rperc slam
    mrclam``'s scores."""
    from rperc.slam.mrclam import mrclam_run

    robot = int(task.dataset.removeprefix("robot"))
    begin, end = task.number("span_start"), task.number("span_stop")
    span = None if begin is None or end is None else (begin, end)
    start = time.perf_counter()
    result, metrics, _ = mrclam_run(
        task.text("directory"),
        robot=robot,
        variants=tuple(task.method.split("+")),
        seed=task.seed,
        fix_interval=task.number("fix_interval") or 1.0,
        fix_sigma=task.number("fix_sigma") or 0.1,
        span=span,
        config=task.kwargs,
    )
    seconds = time.perf_counter() - start
    # The smooth variant's rows are its poses; its metrics carry the filter's events.
    events = metrics.pop("events", len(result.seconds))
    return {
        "library": "rperc",
        **metrics,
        "landmarks": len(result.landmark_id),
        "events": events,
        "events_per_second": events / seconds,
    }
