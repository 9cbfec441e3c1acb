"""The ``rperc`` command-line program.

    rperc demo all              every demo below: one figure and one summary line each
    rperc demo lines            Douglas-Peucker on a noisy spiral: deviation vs epsilon
    rperc demo walls            walls from a simulated scan against the ray-cast truth
    rperc demo monobot          EKF-SLAM observability: the paper's Figs. 3-6, Monte Carlo
    rperc demo tracking         colour trackers on a synthetic sequence with known boxes
    rperc lines extract LOG     walls from a CARMEN log, in the world frame
    rperc lines simplify FILE   Douglas-Peucker on a WKT or CSV polyline
    rperc track SEQ_DIR         colour tracker on an OTB sequence (AUC, precision, fps)
    rperc track --all PARENT    one table row per OTB sequence folder in PARENT
    rperc track VIDEO --box x,y,w,h   your own video: boxes (--csv/--json), --video OUT.gif
    rperc track-pattern SOURCE --region x,y,w,h
                                planar pattern tracker on a video or image folder
    rperc demo pattern          pattern tracker: Fig. 8 and the harness vs OpenCV
    rperc bench SUITE           a capability over a corpus x seeds x settings grid,
                                serial or on Dask (track, laser, mrclam, pattern)

Run ``rperc COMMAND --help`` for the options of each. Results go to stdout, notes
("wrote ...", progress) to stderr; ``--json PATH`` writes the measured figures. A
mistake in the command line or the input exits with status 2 and one
``rperc: error: ...`` line.
"""

from __future__ import annotations

# Only the standard library at import: a Ctrl-C during the start-up imports (numpy,
# the extension, PIL, matplotlib: most of a second) must reach main's handler and
# print "rperc: interrupted", not a traceback (issue 38).
import argparse
import contextlib
import logging
import sys
from collections.abc import Iterator, Sequence
from typing import NoReturn


def user_errors() -> tuple[type[BaseException], ...]:
    """What a user can cause: bad options or input files (ValueError, TypeError, our
    own errors), sizes beyond the memory limit (MemoryError, raised before anything
    is allocated), unreadable or unwritable paths and corrupt images (OSError, which
    includes PIL's UnidentifiedImageError and truncated files). PIL reports some broken
    PNGs as SyntaxError and oversized ones as DecompressionBombError. A missing
    optional dependency names its extra (MissingExtraError). Anything else is a bug
    and keeps its traceback."""
    from PIL import Image

    from rperc import RpercError
    from rperc._extras import MissingExtraError

    return (
        RpercError,
        MissingExtraError,
        ValueError,
        TypeError,
        MemoryError,
        OSError,
        SyntaxError,
        Image.DecompressionBombError,
    )


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors in rperc's format (argparse prints the usage
    first); the exit status stays 2."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"rperc: error: {message} (see: {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    from rperc import __version__
    from rperc.cli import bench, demo, lines, pattern, slamrun, track

    parser = _Parser(prog="rperc", description="Robot perception in Rust, driven from Python.")
    parser.add_argument("--version", action="version", version=f"rperc {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    demo.add_demos(sub)
    lines.add_commands(sub)
    track.add_commands(sub)
    pattern.add_commands(sub)
    slamrun.add_commands(sub)
    bench.add_commands(sub)
    return parser


class _StderrHandler(logging.Handler):
    """Writes to whatever ``sys.stderr`` is at the time (tests swap it)."""

    def emit(self, record: logging.LogRecord) -> None:
        try:
            sys.stderr.write(self.format(record) + "\n")
        except Exception:  # pragma: no cover - logging must never raise
            self.handleError(record)


@contextlib.contextmanager
def _progress_on_stderr() -> Iterator[None]:
    """Send the ``rperc`` logger's INFO lines (progress) to stderr while a command
    runs, then restore the logger as it was."""
    logger = logging.getLogger("rperc")
    handler = _StderrHandler()
    handler.setFormatter(logging.Formatter("rperc: %(message)s"))
    level = logger.level
    logger.addHandler(handler)
    logger.setLevel(logging.INFO)
    try:
        yield
    finally:
        logger.removeHandler(handler)
        logger.setLevel(level)


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the console script; returns the exit status."""
    try:
        return _run(argv)
    except KeyboardInterrupt:  # from the start-up imports on
        print("rperc: interrupted", file=sys.stderr)
        return 130


def _run(argv: Sequence[str] | None) -> int:
    import matplotlib

    # The command only writes files: select Agg before anything imports pyplot, so no
    # display is needed. (The library itself never chooses a backend.)
    matplotlib.use("Agg")
    expected = user_errors()
    parser = build_parser()
    args = parser.parse_args(argv)
    # What was asked, for outputs that record their command (rperc bench --json):
    # main(argv) is called from Python too, where sys.argv is the caller's.
    args.argv = list(sys.argv[1:] if argv is None else argv)
    with _progress_on_stderr():
        try:
            return int(args.run(args) or 0)
        except expected as exc:
            print(f"rperc: error: {_one_line(exc)}", file=sys.stderr)
            return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
