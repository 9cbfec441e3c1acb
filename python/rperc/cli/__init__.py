"""The ``rperc`` command-line program.

    rperc demo lines            simulated scan -> walls, and a simplified polyline (PNG)
    rperc demo monobot          EKF-SLAM observability: the paper's Figs. 3-6, Monte Carlo
    rperc lines extract LOG     walls from a CARMEN log, in the world frame (PNG)
    rperc lines simplify FILE   Douglas-Peucker on a WKT or CSV polyline
    rperc track SEQ_DIR         colour tracker on an OTB sequence (AUC, precision, fps)

Run ``rperc COMMAND --help`` for the options of each.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from rperc import RpercError, __version__
from rperc.cli import lines, slam, track


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="rperc", description="Robot perception in Rust, driven from Python."
    )
    parser.add_argument("--version", action="version", version=f"rperc {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    demo = sub.add_parser("demo", help="run a demo on data rperc generates itself")
    demos = demo.add_subparsers(dest="demo", required=True, metavar="DEMO")
    lines.add_demo(demos)
    slam.add_demo(demos)

    lines.add_commands(sub)
    track.add_commands(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the console script; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.run(args) or 0)
    except (RpercError, ValueError, TypeError, FileNotFoundError) as exc:
        print(f"rperc: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
