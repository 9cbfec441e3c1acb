"""Both sides of a fuzz run.

Parent side: :func:`run_child` starts ``python -m fuzz.harness MODULE`` with
``tests/`` on the path, waits at most ``timeout`` seconds and returns what happened.

Child side: :func:`main` caps the address space (``RLIMIT_AS``), arms a per-example
watchdog, then calls every ``prop_*`` function of the module; each is a hypothesis
``@given`` test, so one child runs a whole batch of examples and hypothesis shrinks a
failing property in-process. Before each example :func:`case` writes a description of
it to the file named by ``RPERC_FUZZ_LOG``: when the child dies on a signal or hangs,
that file holds the reproducer.
"""

from __future__ import annotations

import faulthandler
import importlib
import os
import resource
import subprocess
import sys
import traceback
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from hypothesis import HealthCheck, settings

TESTS = Path(__file__).resolve().parent.parent
MEMORY_LIMIT = 2 << 30  # bytes of address space per child
# rperc's own request limit in the child (RPERC_MAX_ALLOCATION_BYTES), well under the
# address space: a request may allocate its buffer a few times over (particles, their
# spare set, weights) beside the interpreter, and every request rperc accepts must then
# succeed. Under the default 4 GiB, a 3 GiB request would pass the check and abort.
ALLOCATION_LIMIT = MEMORY_LIMIT // 8
# Seconds one example may take before it counts as a hang (the canary test shortens it).
EXAMPLE_TIMEOUT = float(os.environ.get("RPERC_FUZZ_EXAMPLE_TIMEOUT", "20"))
LONG = os.environ.get("RPERC_FUZZ") == "long"


def examples(ci: int) -> settings:
    """Settings for one property: ``ci`` examples, derandomized so CI is reproducible;
    ``RPERC_FUZZ=long`` runs 20 times as many with fresh randomness."""
    return settings(
        max_examples=ci * 20 if LONG else ci,
        derandomize=not LONG,
        deadline=None,
        database=None,
        suppress_health_check=list(HealthCheck),
        print_blob=True,
    )


def config_fields(d: dict[str, Any], prefix: str = "") -> list[str]:
    """Dotted paths of every leaf of a nested config dict (``"motion.speed_variance"``)."""
    out: list[str] = []
    for k, v in d.items():
        out += config_fields(v, f"{prefix}{k}.") if isinstance(v, dict) else [f"{prefix}{k}"]
    return out


def nested_config(path: str, value: Any) -> dict[str, Any]:
    """The nested dict that sets one dotted path to ``value``."""
    head, _, rest = path.partition(".")
    return {head: nested_config(rest, value) if rest else value}


def describe(value: Any) -> str:
    """A reproducible description of an argument: arrays with dtype, shape, strides and
    every value (they are small), anything else by repr."""
    if isinstance(value, np.ndarray):
        with np.printoptions(threshold=400, floatmode="unique"):
            body = repr(value)
        return f"<{value.dtype.str} shape={value.shape} strides={value.strides}> {body}"
    return repr(value)


def case(label: str, **args: Any) -> None:
    """Records the example about to run (for a crash or hang report) and restarts the
    watchdog."""
    faulthandler.dump_traceback_later(EXAMPLE_TIMEOUT, exit=True)
    log = os.environ.get("RPERC_FUZZ_LOG")
    if log is None:
        return
    text = label + "(" + ", ".join(f"{k}={describe(v)}" for k, v in args.items()) + ")"
    with open(log, "w", encoding="utf-8") as f:
        f.write(text)


# Exceptions a caller may expect from bad input; anything else is a bug.
def _clear_errors() -> tuple[type[BaseException], ...]:
    import rperc

    return (ValueError, TypeError, MemoryError, OverflowError, rperc.RpercError)


def outcome(fn: Callable[..., Any], *args: Any, **kwargs: Any) -> tuple[bool, Any]:
    """``(True, result)`` or ``(False, exception)`` for an expected error with a
    message. An unexpected exception type, an empty message or a BaseException that is
    not an Exception (pyo3's PanicException) propagates and fails the property."""
    try:
        with warnings.catch_warnings():
            # numpy dropping an imaginary part is silent corruption, not a warning.
            warnings.simplefilter("error", np.exceptions.ComplexWarning)
            return True, fn(*args, **kwargs)
    except _clear_errors() as exc:
        if isinstance(exc, UnicodeError):
            raise AssertionError(f"bare {type(exc).__name__}: {exc}") from exc
        assert str(exc).strip(), f"{type(exc).__name__} without a message"
        # A Rust panic caught at the boundary is still a bug.
        assert "internal error in rperc" not in str(exc), str(exc)
        return False, exc


def _limit_memory() -> None:
    # Before rperc's first size check, which reads the variable once.
    os.environ["RPERC_MAX_ALLOCATION_BYTES"] = str(ALLOCATION_LIMIT)
    _, hard = resource.getrlimit(resource.RLIMIT_AS)
    cap = MEMORY_LIMIT if hard == resource.RLIM_INFINITY else min(MEMORY_LIMIT, hard)
    resource.setrlimit(resource.RLIMIT_AS, (cap, hard))


def main(module_name: str, only: str | None = None) -> int:
    """Runs every ``prop_*`` of ``fuzz.MODULE`` (or just ``only``); exit status 1 and a
    traceback on the first failing property."""
    _limit_memory()
    module = importlib.import_module(f"fuzz.{module_name}")
    names = sorted(n for n in vars(module) if n.startswith("prop_"))
    failed = 0
    for name in names if only is None else [only]:
        try:
            getattr(module, name)()
        except Exception:
            failed += 1
            print(f"FAILED {module_name}.{name}", file=sys.stderr)
            traceback.print_exc()
    faulthandler.cancel_dump_traceback_later()
    return 1 if failed else 0


@dataclass(frozen=True)
class ChildResult:
    returncode: int | None  # None: killed after the timeout
    stderr: str
    last_case: str


def run_child(
    module_name: str,
    log: Path,
    timeout: float,
    only: str | None = None,
    extra_env: dict[str, str] | None = None,
) -> ChildResult:
    """Runs :func:`main` for one module in a fresh interpreter."""
    env = dict(os.environ, RPERC_FUZZ_LOG=str(log), PYTHONPATH=str(TESTS), **(extra_env or {}))
    # One BLAS/rayon thread: thread stacks count against RLIMIT_AS, and the machine
    # is shared.
    env.update(OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", RAYON_NUM_THREADS="2")
    argv = [sys.executable, "-m", "fuzz.harness", module_name] + ([only] if only else [])
    try:
        out = subprocess.run(
            argv, capture_output=True, text=True, timeout=timeout, env=env, check=False
        )
        code: int | None = out.returncode
        stderr = out.stderr
    except subprocess.TimeoutExpired as exc:
        code = None
        stderr = exc.stderr.decode(errors="replace") if isinstance(exc.stderr, bytes) else ""
    last = log.read_text(encoding="utf-8") if log.exists() else "(no example started)"
    return ChildResult(code, stderr, last)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], sys.argv[2] if len(sys.argv) > 2 else None))
