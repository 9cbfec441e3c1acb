"""Timing helpers shared by the benchmark scripts: best-of-repeats wall time, a
subprocess runner for peers that may crash (stack overflow) or hang, and a table."""

from __future__ import annotations

import subprocess
import sys
import time
from collections.abc import Callable


def best_time(fn: Callable[[], object], *, repeat: int = 7, min_time: float = 0.2) -> float:
    """Best per-call seconds over ``repeat`` batches, each at least ``min_time`` long."""
    fn()  # warm up
    t0 = time.perf_counter()
    fn()
    one = max(time.perf_counter() - t0, 1e-9)
    number = max(1, int(min_time / one))
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(number):
            fn()
        best = min(best, (time.perf_counter() - t0) / number)
    return best


def against_peer(ours: float, theirs: float, pose: object, peer_pose: object) -> dict[str, float]:
    """The seconds of rperc and of a peer on the same problem, their ratio, and how far
    apart their optima's positions are (``(N, 3)`` poses, m)."""
    import numpy as np

    gap = np.max(np.abs(np.asarray(pose)[:, :2] - np.asarray(peer_pose)[:, :2]))
    return {"rperc_s": ours, "peer_s": theirs, "ratio": theirs / ours,
            "max_position_gap_m": float(gap)}  # fmt: skip


def time_in_subprocess(setup: str, stmt: str, *, timeout: float = 60.0) -> tuple[float | None, str]:
    """Seconds for one run of ``stmt`` in a fresh interpreter, or ``(None, why)`` when
    it crashed (a peer's recursion overflowing the stack) or took longer than
    ``timeout``."""
    code = (
        f"{setup}\nimport time\nt0 = time.perf_counter()\n{stmt}\nprint(time.perf_counter() - t0)\n"
    )
    try:
        out = subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, timeout=timeout
        )
    except subprocess.TimeoutExpired:
        return None, f"> {timeout:.0f} s (killed)"
    if out.returncode != 0:
        sig = -out.returncode if out.returncode < 0 else None
        why = f"crashed (signal {sig})" if sig else f"failed (exit {out.returncode})"
        return None, why
    return float(out.stdout.strip().splitlines()[-1]), ""


def fmt_seconds(t: float | None, note: str = "") -> str:
    if t is None:
        return note
    if t < 1e-3:
        return f"{t * 1e6:8.1f} us"
    if t < 1:
        return f"{t * 1e3:8.2f} ms"
    return f"{t:8.2f} s "


def print_table(title: str, header: list[str], rows: list[list[str]]) -> None:
    widths = [max([len(h), *(len(r[k]) for r in rows)]) for k, h in enumerate(header)]
    print(f"\n## {title}")
    print(" | ".join(h.ljust(w) for h, w in zip(header, widths, strict=True)))
    print("-+-".join("-" * w for w in widths))
    for r in rows:
        print(" | ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)))
