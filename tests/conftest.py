"""Shared fixtures: the real data folder (tests skip with a reason when it is absent)
and hypothesis profiles chosen by HYPOTHESIS_PROFILE (``ci`` runs more examples)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

from rperc.datasets import data_dir

# The experiment harnesses that live with the benchmarks (not in the installed
# package), such as ``challenges``, import by name; appended, so nothing of the
# package or of the tests is shadowed by a benchmark script's name.
sys.path.append(str(Path(__file__).resolve().parents[1] / "benchmarks"))

settings.register_profile(
    "default", max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
settings.register_profile(
    "ci", max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "default"))


@pytest.fixture(scope="session")
def data() -> Path:
    """The shared data folder; skips the test when it is not there."""
    root = data_dir()
    if root is None or not root.is_dir():
        pytest.skip("real data not found: set RPERC_DATA (see ../shared/data/README.md)")
    return root
