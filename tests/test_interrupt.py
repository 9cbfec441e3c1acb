"""Ctrl-C stops long native work (issue 15): each case runs in a child process that
starts a call which would take tens of seconds to minutes, receives SIGINT while the
call runs with the GIL released, and must die of KeyboardInterrupt promptly instead of
finishing the work first.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")

# Each case builds its input, prints "ready" and starts a call that runs for far
# longer than the test waits (the uninterruptible versions took 39 s to 20 min).
ZIGZAG = (
    "import numpy as np\nk = np.arange(300_000.0)\npts = np.c_[k, np.where(k % 2 == 0, k, -k)]\n"
)
CASES = {
    "dp on a zig-zag": ZIGZAG
    + "from rperc.linesimp import simplify\nprint('ready', flush=True)\n"
    + "simplify(pts, 1e-9, method='dp')\n",
    "simplify_many on zig-zags": ZIGZAG
    + "from rperc.linesimp import simplify_many\nprint('ready', flush=True)\n"
    + "simplify_many([pts, pts], 1e-9, method='dp', threads=2)\n",
    "monobot with hundreds of landmarks": "from rperc.slam import monobot\n"
    + "print('ready', flush=True)\nmonobot.simulate(landmarks=400, steps=1000)\n",
    "monobot Monte Carlo": "from rperc.slam import monobot\n"
    + "print('ready', flush=True)\nmonobot.monte_carlo(runs=8, landmarks=400, steps=1000)\n",
    # One step observes all 3000 landmarks at once: a dense O(n^3) update of tens of
    # seconds (the factorisation, gain, covariance write and NEES are all checkpointed).
    "one monobot step with thousands of landmarks": "from rperc.slam import monobot\n"
    + "print('ready', flush=True)\nmonobot.simulate(landmarks=3000, steps=1)\n",
    # Issue 38: the runs went to rayon's pool, whose threads never saw the signal
    # (a SIGINT at 2 s left it running 40 s later).
    "planar Monte Carlo": "from rperc.slam.planar import monte_carlo\n"
    + "print('ready', flush=True)\nmonte_carlo({'steps': 3000}, runs=2000)\n",
    # Ten million landmarks scanned at each of 2000 steps: minutes of simulation.
    "a planar world of millions of landmarks": "from rperc.slam.planar import simulate\n"
    + "print('ready', flush=True)\n"
    + "simulate({'landmarks': 10**7, 'steps': 2000, 'max_range': 1.0})\n",
    # A 1 GB ceiling texture (80 x 80 m at 5 mm): seconds of tile levels to generate.
    "a huge ceiling world": "from rperc.navigation import CeilingWorld\n"
    + "print('ready', flush=True)\nCeilingWorld(ceiling={'size': [80.0, 80.0]})\n",
}

# Far above the 20 ms poll interval (the child also needs time to unwind and exit on a
# loaded 2-core machine), far below the seconds to minutes the calls take.
DEADLINE_S = 5.0


# A shell without job control starts background jobs with SIGINT ignored, and the
# child would inherit that (Python then installs no KeyboardInterrupt handler): the
# child restores Python's own handler first, as an interactive session has it.
DEFAULT_SIGINT = "import signal\nsignal.signal(signal.SIGINT, signal.default_int_handler)\n"


def _interrupt(code: str) -> tuple[float, str]:
    child = subprocess.Popen(
        [sys.executable, "-c", DEFAULT_SIGINT + code],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert child.stdout is not None
        assert child.stdout.readline().strip() == "ready"
        time.sleep(1.0)  # inside the native call by now
        assert child.poll() is None, "the call ended before it could be interrupted"
        sent = time.monotonic()
        os.kill(child.pid, signal.SIGINT)
        _, stderr = child.communicate(timeout=60)
        return time.monotonic() - sent, stderr
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()


@pytest.mark.parametrize("name", sorted(CASES))
def test_ctrl_c_stops_long_native_work(name):
    elapsed, stderr = _interrupt(CASES[name])
    assert "KeyboardInterrupt" in stderr, stderr[-2000:]
    # A signal that lands while the call returns its arrays once made numpy's lazy
    # C-API import raise inside Rust: a panic that merely mentions KeyboardInterrupt.
    assert "panicked" not in stderr and "PanicException" not in stderr, stderr[-2000:]
    assert elapsed < DEADLINE_S, f"{name}: took {elapsed:.2f} s to stop"


def test_interruptible_calls_still_return_their_results():
    from rperc.linesimp import simplify, simplify_many

    pts = [[0.0, 0.0], [1.0, 1.0], [2.0, 0.0]]
    assert simplify(pts, 0.5, return_indices=True).tolist() == [0, 1, 2]
    assert [r.tolist() for r in simplify_many([pts, pts], 2.0, return_indices=True)] == [
        [0, 2],
        [0, 2],
    ]


def test_ctrl_c_during_the_start_up_imports_prints_one_line(tmp_path):
    # Issue 38: a SIGINT while the command imported numpy, the extension, PIL and
    # matplotlib printed a traceback. A stand-in matplotlib that takes 30 s to import
    # holds the start-up where the signal must land.
    fake = tmp_path / "matplotlib"
    fake.mkdir()
    (fake / "__init__.py").write_text(
        "import sys, time\nprint('ready', flush=True)\ntime.sleep(30)\n"
    )
    code = DEFAULT_SIGINT + (
        f"import sys\nsys.path.insert(0, {str(tmp_path)!r})\n"
        "sys.argv = ['rperc', 'demo', 'lines']\n"
        "import runpy\nrunpy.run_module('rperc', run_name='__main__')\n"
    )
    child = subprocess.Popen(
        [sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        assert child.stdout is not None
        assert child.stdout.readline().strip() == "ready"
        os.kill(child.pid, signal.SIGINT)
        _, stderr = child.communicate(timeout=20)
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
    assert stderr.strip() == "rperc: interrupted", stderr[-2000:]
    assert child.returncode == 130
