"""What every ``rperc`` command shares about its inputs and outputs: option types
that reject bad counts and seeds, output paths checked before any work is done, the
``--json`` file of measured figures, and "wrote ..." notes on stderr (stdout carries
the results only, so it can be piped)."""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from rperc._args import excerpt
from rperc._atomic import write_text_atomically

if TYPE_CHECKING:
    from rperc.datasets import CarmenLog


def count_at_least(minimum: int, maximum: int | None = None) -> Callable[[str], int]:
    """An argparse type: an integer ``>= minimum`` (and ``<= maximum`` if given)."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, got {excerpt(text)}") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be an integer >= {minimum}, got {value}")
        if maximum is not None and value > maximum:
            raise argparse.ArgumentTypeError(f"must be an integer <= {maximum}, got {value}")
        return value

    parse.__name__ = f"integer >= {minimum}"
    return parse


# Seeds feed 64-bit generators on the native side.
seed_type = count_at_least(0, 2**64 - 1)


def _number(text: str) -> float:
    """The float option types' reading of their text, before each checks its range."""
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {excerpt(text)}") from None


def positive_float(text: str) -> float:
    """An argparse type: a finite float > 0."""
    value = _number(text)
    if not math.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text}")
    return value


def non_negative_float(text: str) -> float:
    """An argparse type: a finite float >= 0."""
    value = _number(text)
    if not math.isfinite(value) or value < 0:
        raise argparse.ArgumentTypeError(f"must be a finite number >= 0, got {text}")
    return value


def add_json_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--json", type=Path, metavar="PATH", help="also write the measured figures as JSON"
    )


def check_output_file(path: Path | None, option: str, *, figure: bool = False) -> None:
    """Refuse, before any work, an output that could not be written: a folder, a file
    in a folder that does not exist (it is not created silently) or is read-only, or a
    figure whose suffix names no image format."""
    if path is None:
        return
    if path.is_dir():
        suffix = {"--rerun": ".rrd", "--tum": ".tum", "--csv": ".csv"}.get(option, ".json")
        example = path / ("figure.png" if figure else "out" + suffix)
        raise ValueError(f"{option} {path} is a folder; give a file name such as {example}")
    folder = path.parent
    if not folder.is_dir():
        raise ValueError(f"{option} {path}: folder {folder} does not exist")
    if not os.access(folder, os.W_OK):
        raise ValueError(f"{option} {path}: folder {folder} is not writable")
    if figure:
        from rperc.plot import figure_format

        try:
            figure_format(path)
        except ValueError as exc:
            raise ValueError(f"{option} {exc}") from None


def prepare_output_folder(path: Path, option: str) -> Path:
    """A folder for several outputs (``demo --out``): created with its parents, as
    ``make demo`` needs on a fresh checkout, but never over an existing file."""
    if path.exists() and not path.is_dir():
        raise ValueError(f"{option} {path} is a file, not a folder")
    path.mkdir(parents=True, exist_ok=True)
    return path


def wrote(path: Path) -> None:
    print(f"wrote {path}", file=sys.stderr)


def read_carmen_log(path: Path) -> CarmenLog:
    """:func:`rperc.datasets.load_carmen` for a command: a repair of the log's scan times
    (:class:`~rperc.datasets.TimestampRepairWarning`) and a max-range PARAM set aside
    (:class:`~rperc.datasets.carmen.MaxRangeWarning`) are told as ``note:`` lines on
    stderr, in the command's words, instead of Python warnings."""
    from rperc.datasets.carmen import _load_untold

    log = _load_untold(path)  # its warnings are told below, from the log's own counts
    for kind, c in log.max_range_contradicted.items():
        print(
            f"note: {path.name}: {kind}'s max-range PARAM {c.param:g} m set aside: "
            f"{c.readings} readings lie beyond it ({c.distinct} distinct values up to "
            f"{c.farthest:g} m), so the scanner's range is inferred from the readings",
            file=sys.stderr,
        )
    if log.times_repaired:
        print(
            f"note: {path.name}: {log.times_repaired} of {len(log.scans)} scan times did not "
            "increase strictly; repaired (rperc.datasets.timestamps) so that trajectories "
            "written from them have one row per scan in log order",
            file=sys.stderr,
        )
    return log


def _plain(value: object) -> object:
    """JSON-ready copies of numpy scalars and arrays, paths and tuples."""
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return _plain(value.tolist())
    if isinstance(value, np.generic):
        return _plain(value.item())
    if isinstance(value, float) and not math.isfinite(value):
        return None  # JSON has no NaN or infinity
    if isinstance(value, Path):
        return str(value)
    return value


def print_measured(measured: Mapping[str, object]) -> None:
    """The measured figures as one ``key=value`` line on stdout, floats to 4 significant
    digits: the SLAM commands' result line, the same for each so that one script reads
    them all."""
    print(
        " ".join(
            f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in measured.items()
        )
    )


def write_json(path: Path | None, measured: Mapping[str, object]) -> None:
    """Write ``measured`` to ``path`` (checked earlier with :func:`check_output_file`)."""
    if path is None:
        return
    write_text_atomically(path, json.dumps(_plain(measured), indent=2) + "\n")
    wrote(path)


@dataclass(frozen=True)
class DemoResult:
    """What a demo found: ``summary`` is one line starting with the demo's name;
    ``details`` are printed after it when the demo runs on its own."""

    summary: str
    figures: list[Path]
    measured: dict[str, object]
    details: list[str] = field(default_factory=list)
