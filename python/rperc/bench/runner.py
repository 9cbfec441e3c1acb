"""Running tasks: in this process (``serial``), on a Dask ``LocalCluster`` of worker
processes (``local``), or on a running Dask scheduler (``tcp://HOST:PORT``).

The worker side is :func:`run_task`: it imports the task's suite, runs it and turns
any exception into an error row, so one failing run never stops the others. The
client side keeps the rows in task order, shows progress (a bar on a terminal, log
lines elsewhere), and on Ctrl-C cancels every future before it re-raises. Every
process that times runs first fixes its allocator's thresholds
(:func:`rperc.bench.allocator.steady_allocator`), so that no method's speed depends
on what ran before it.
"""

from __future__ import annotations

import contextlib
import importlib
import logging
import math
import time
from collections.abc import Callable, Iterator, Sequence
from typing import Any

from rperc._extras import MissingExtraError, require
from rperc._progress import progress, quiet
from rperc.bench.allocator import steady_allocator
from rperc.bench.tasks import Row as Row  # re-exported: its home before tasks
from rperc.bench.tasks import Task

logger = logging.getLogger("rperc")

#: The suites' modules, by the name tasks carry (imported on the worker).
SUITES = {
    "track": "rperc.bench.suites.track",
    "laser": "rperc.bench.suites.laser",
    "mrclam": "rperc.bench.suites.mrclam",
    "pattern": "rperc.bench.suites.pattern",
}

#: Columns that measure time: the only ones allowed to differ between two runs of
#: the same task.
TIME_COLUMNS = frozenset({"seconds", "fps", "scans_per_second", "events_per_second"})

#: An error row quotes at most this much of the message (a parser may quote a line).
MAX_ERROR_CHARS = 200


def _suite(name: str) -> Any:
    try:
        return importlib.import_module(SUITES[name])
    except KeyError:
        raise ValueError(
            f"unknown bench suite {name!r}; expected one of {', '.join(SUITES)}"
        ) from None


def _short(exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or "(no message)"
    if len(text) > MAX_ERROR_CHARS:
        text = text[: MAX_ERROR_CHARS - 3] + "..."
    return f"{type(exc).__name__}: {text}"


def base_row(task: Task) -> Row:
    """The columns every row starts with: which run it is, and its settings."""
    return {
        "index": task.index,
        "dataset": task.dataset,
        "method": task.method,
        "seed": task.seed,
        **task.kwargs,
    }


def run_task(task: Task) -> Row:
    """Run one task (on a worker or here): its row, or an error row with the
    exception's type and message (``error``), every metric left out. Ctrl-C and
    other ``BaseException`` pass through."""
    row = base_row(task)
    start = time.perf_counter()
    try:
        with quiet():
            measured: Row = _suite(task.suite).run(task)
    except MissingExtraError:
        # Not this run's failure but the install's: every run of the method would
        # fail alike, so the command names the extra (exit 2) instead of a table of
        # error rows.
        raise
    except Exception as exc:
        logger.debug("bench task %d failed", task.index, exc_info=True)
        return row | {"seconds": time.perf_counter() - start, "error": _short(exc)}
    return row | measured | {"seconds": time.perf_counter() - start, "error": ""}


def _serial(tasks: Sequence[Task], desc: str) -> list[Row]:
    steady_allocator()
    return [run_task(t) for t in progress(tasks, desc=desc, unit="run")]


@contextlib.contextmanager
def _client(scheduler: str, workers: int | None) -> Iterator[Any]:
    """A Dask client: on a new LocalCluster of ``workers`` single-threaded processes,
    or connected to the scheduler at ``scheduler`` (``tcp://HOST:PORT``)."""
    distributed = require("distributed", f"--scheduler {scheduler}")
    client_type, cluster_type = distributed.Client, distributed.LocalCluster
    if scheduler == "local":
        # Processes, one thread each: the native code releases the GIL, but each
        # worker then times its runs on a core of its own.
        with (
            cluster_type(
                n_workers=workers or 2,
                threads_per_worker=1,
                processes=True,
                # A port of its own: None still asks for 8787, and two clusters
                # started at once (two runs, or pytest-xdist workers) then clash.
                dashboard_address=":0",
                silence_logs=logging.WARNING,
            ) as cluster,
            client_type(cluster) as client,
        ):
            yield client
        return
    with client_type(scheduler, timeout="30s") as client:
        yield client


def _distributed(
    tasks: Sequence[Task], scheduler: str, workers: int | None, desc: str
) -> list[Row]:
    as_completed = require("distributed", f"--scheduler {scheduler}").as_completed
    with _client(scheduler, workers) as client:
        # Every worker times its runs with the same allocator behaviour (see
        # rperc.bench.allocator), whatever it ran before.
        client.run(steady_allocator)
        # Keys name the task so that two benchmarks on one cluster never share results.
        stamp = f"{time.time_ns():x}"
        futures = client.map(
            run_task, tasks, key=[f"rperc-bench-{stamp}-{t.index}" for t in tasks], pure=False
        )
        place = {f.key: t.index for f, t in zip(futures, tasks, strict=True)}
        rows: list[Row | None] = [None] * len(tasks)
        try:
            done = as_completed(futures)
            for future in progress(done, desc=desc, total=len(tasks), unit="run"):
                rows[place[future.key]] = _result(future, tasks[place[future.key]])
        except BaseException:
            client.cancel(futures)
            raise
    return [r for r in rows if r is not None]


def _result(future: Any, task: Task) -> Row:
    """A future's row; a worker that died (the task never returned) is an error row."""
    if future.status == "finished":
        row: Row = dict(future.result())
        return row
    try:
        future.result()
    except Exception as exc:
        return base_row(task) | {"seconds": math.nan, "error": _short(exc)}
    raise RuntimeError(f"bench task {task.index} ended as {future.status}")


def run_tasks(
    tasks: Sequence[Task],
    *,
    scheduler: str = "serial",
    workers: int | None = None,
    desc: str = "bench",
) -> list[Row]:
    """Every task's row, in task order. ``scheduler`` is ``serial`` (this process),
    ``local`` (a LocalCluster of ``workers`` processes, 2 by default) or a
    scheduler's address ``tcp://HOST:PORT``."""
    check_scheduler(scheduler, workers)
    if scheduler == "serial":
        return _serial(tasks, desc)
    return _distributed(tasks, scheduler, workers, desc)


def check_scheduler(scheduler: str, workers: int | None) -> None:
    """Refuse an unknown scheduler, or workers where they mean nothing."""
    if scheduler not in ("serial", "local") and not scheduler.startswith(("tcp://", "tls://")):
        raise ValueError(f"--scheduler {scheduler!r}: expected serial, local or tcp://HOST:PORT")
    if workers is not None and scheduler != "local":
        raise ValueError("--workers sets the size of a local cluster (--scheduler local)")
    if workers is not None and not 1 <= workers <= 256:
        raise ValueError(f"--workers must be between 1 and 256, got {workers}")


def same_rows(
    a: Sequence[Row], b: Sequence[Row], ignore: Callable[[str], bool] | None = None
) -> bool:
    """Whether two row lists are equal in every column but the time columns (NaN
    equals NaN)."""
    skip = ignore or (lambda k: k in TIME_COLUMNS)
    if len(a) != len(b):
        return False
    for ra, rb in zip(a, b, strict=True):
        ka = {k for k in ra if not skip(k)}
        if ka != {k for k in rb if not skip(k)}:
            return False
        for k in ka:
            va, vb = ra[k], rb[k]
            both_nan = isinstance(va, float) and isinstance(vb, float) and va != va and vb != vb
            if va != vb and not both_nan:
                return False
    return True
