"""Issue 15's fuzz suite: each module of ``tests/fuzz`` runs in its own child process
under a 2 GiB address-space limit, a per-example watchdog and a time limit for the
whole batch. A crash (signal), a hang or a failing property fails the test and prints
the example that was running. ``RPERC_FUZZ=long`` runs 20 times as many examples."""

from __future__ import annotations

import signal
from pathlib import Path

import pytest

from fuzz.harness import LONG, run_child

MODULES = [
    "props_linesimp",
    "props_slam",
    "props_tracking",
    "props_navigation",
    "props_eval",
    "props_files",
    "props_cli",
    "props_shape_pattern",
    "props_planar_io",
    "props_headers",
]
BATCH_TIMEOUT = 3000.0 if LONG else 300.0


@pytest.mark.parametrize("module", MODULES)
def test_no_input_crashes_hangs_or_corrupts(module: str, tmp_path: Path) -> None:
    got = run_child(module, tmp_path / "last_case.txt", BATCH_TIMEOUT)
    if got.returncode == 0:
        return
    if got.returncode is None:
        what = f"hung: no answer in {BATCH_TIMEOUT:.0f} s"
    elif got.returncode < 0:
        what = f"crashed on {signal.Signals(-got.returncode).name}"
    elif "Timeout (" in got.stderr:
        what = "hung: one example ran past the watchdog"
    else:
        what = "a property failed"
    pytest.fail(f"{module}: {what}\nlast example: {got.last_case}\n{got.stderr[-6000:]}")


@pytest.mark.parametrize(
    ("prop", "expected"),
    [("prop_abort", "SIGABRT"), ("prop_hang", "Timeout"), ("prop_allocate", None)],
)
def test_the_harness_survives_and_reports_an_abort_or_a_hang(prop, expected, tmp_path):
    """The canary examples abort, sleep forever or allocate 8 GiB: the child must die
    alone (or raise MemoryError under its limit), and the report must name the example."""
    got = run_child(
        "canary", tmp_path / "last.txt", 60.0, only=prop,
        extra_env={"RPERC_FUZZ_EXAMPLE_TIMEOUT": "1"},
    )  # fmt: skip
    if expected is None:
        assert got.returncode == 0, got.stderr[-2000:]
    elif expected == "SIGABRT":
        assert got.returncode == -signal.SIGABRT, (got.returncode, got.stderr[-2000:])
    else:
        assert got.returncode == 1 and "Timeout (" in got.stderr, got.stderr[-2000:]
    if expected:
        assert got.last_case.startswith(prop.removeprefix("prop_") + "(k="), got.last_case
