"""rperc._progress: a tqdm bar on a terminal; elsewhere at most one log line per
interval plus a final line, through the ``rperc`` logger."""

from __future__ import annotations

import io
import logging
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from rperc._progress import progress
from rperc.slam import monobot


class FakeClock:
    """One second passes at every reading."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        self.now += 1.0
        return self.now


def test_off_a_terminal_progress_is_rate_limited_log_lines(caplog):
    caplog.set_level(logging.INFO, logger="rperc")
    items = list(progress(range(20), desc="work", unit="scan", interval=5.0, clock=FakeClock()))
    assert items == list(range(20))
    messages = [r.getMessage() for r in caplog.records if r.name == "rperc"]
    # 21 clock readings one second apart in the loop: a line every 5 s, then the final one.
    assert len(messages) == 20 // 5 + 1
    assert messages[-1].startswith("work: 20/20 (100%) scan in ")
    assert all(m.startswith("work: ") for m in messages)


def test_progress_without_a_length_counts_what_it_saw(caplog):
    caplog.set_level(logging.INFO, logger="rperc")
    assert sum(progress((k for k in range(7)), desc="gen")) == 21
    assert caplog.records[-1].getMessage().startswith("gen: 7 it in ")


def test_on_a_terminal_progress_is_a_tqdm_bar(monkeypatch, caplog):
    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    screen = Terminal()
    monkeypatch.setattr("sys.stderr", screen)
    caplog.set_level(logging.INFO, logger="rperc")
    assert list(progress(range(3), desc="bar")) == [0, 1, 2]
    assert "bar:" in screen.getvalue() and "/3 [" in screen.getvalue()  # a tqdm bar
    assert not [r for r in caplog.records if r.name == "rperc"]


@pytest.mark.parametrize("use_executor", [False, True])
def test_monte_carlo_progress_reports_and_changes_nothing(caplog, use_executor):
    caplog.set_level(logging.INFO, logger="rperc")
    kwargs = {"model": "anchor", "landmarks": 2, "runs": 6, "seed": 3}
    with ThreadPoolExecutor(2) as pool:
        executor = pool if use_executor else None
        quiet = monobot.monte_carlo(**kwargs, executor=executor)
        assert not caplog.records
        loud = monobot.monte_carlo(**kwargs, executor=executor, progress=True)
    np.testing.assert_array_equal(quiet.run_nees, loud.run_nees)
    final = caplog.records[-1].getMessage()
    assert final.startswith("monobot anchor") and "(100%)" in final
