"""The ``rperc`` command under fuzzing: files from the loader fixtures (valid or
broken), numbers at and beyond their limits and output paths that cannot be written.
The property: exit status 0 (and the output exists) or 2 with a one-line message,
never a traceback. ``rperc.cli.main`` runs inside the fuzz child, itself a subprocess
under the memory and time limits, so one interpreter serves the whole batch."""

from __future__ import annotations

import contextlib
import io
import shutil
import tempfile
from pathlib import Path
from typing import Any

from hypothesis import given
from hypothesis import strategies as st

from rperc.cli import main

from fuzz.files import Mutation, apply
from fuzz.harness import case, examples
from fuzz.loaders import FIXTURES

NUMBERS = st.sampled_from(
    [
        "0",
        "-1",
        "1",
        "0.5",
        "nan",
        "inf",
        "-inf",
        "1e400",
        "abc",
        "4611686018427387904",
        "",
        "1_0",
        " 2",
    ]
)
OUTPUTS = st.sampled_from(["ok", "folder", "missing_dir", "under_file", None])


def _run(argv: list[str]) -> tuple[int, str]:
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse
            code = exc.code if isinstance(exc.code, int) else 2
    return code, err.getvalue()


def _output(folder: Path, kind: str | None, suffix: str) -> str | None:
    paths = {
        "ok": folder / f"out{suffix}",
        "folder": folder,
        "missing_dir": folder / "no" / "such" / f"out{suffix}",
        "under_file": folder / "input" / f"out{suffix}",
    }
    return None if kind is None else str(paths[kind])


def _input(folder: Path, data: Any, loader: str, name: str) -> Path:
    fx = data.draw(FIXTURES[loader])
    raw: dict[str, bytes] = {}
    if data.draw(st.booleans()):
        m = data.draw(st.sampled_from(fx.breaking)), data.draw(st.sampled_from(fx.data_lines[name]))
        raw, _ = apply(fx, Mutation(m[0], name, m[1]))
    fx.write(folder, raw)
    target = folder / "input"
    (folder / name).rename(target)
    return target


def _check(argv: list[str], outputs: list[str | None]) -> None:
    case("rperc", argv=argv)
    code, err = _run(argv)
    assert code in (0, 2), (code, err[-2000:])
    assert "Traceback" not in err, err[-3000:]
    if code == 2:
        last = err.strip().splitlines()[-1] if err.strip() else ""
        assert last.startswith("rperc") and "error" in last, err[-2000:]
    else:
        for out in outputs:
            assert out is None or Path(out).is_file(), (out, err)


@examples(40)
@given(
    st.sampled_from(["wkt", "csv"]),
    NUMBERS,
    st.sampled_from(["auto", "dp", "vw", "hull"]),
    OUTPUTS,
    st.sampled_from([None, None, "ok", "folder", "under_file"]),
    st.data(),
)
def prop_cli_lines_simplify(loader, epsilon, method, output, plot, data):
    folder = Path(tempfile.mkdtemp(prefix="rperc-cli-"))
    try:
        src = _input(folder, data, loader, "lines.wkt" if loader == "wkt" else "lines.csv")
        argv = [
            "lines",
            "simplify",
            str(src.rename(src.with_suffix("." + loader))),
            "--epsilon",
            epsilon,
            "--method",
            method,
        ]
        out, png = _output(folder, output, ".wkt"), _output(folder, plot, ".png")
        argv += ["-o", out] if out else []
        argv += ["--plot", png] if png else []
        _check(argv, [out, png])
    finally:
        shutil.rmtree(folder)


@examples(30)
@given(NUMBERS, NUMBERS, NUMBERS, OUTPUTS, st.data())
def prop_cli_lines_extract(every, min_points, sigma, json_out, data):
    folder = Path(tempfile.mkdtemp(prefix="rperc-cli-"))
    try:
        log = _input(folder, data, "carmen", "log.txt")
        argv = [
            "lines",
            "extract",
            str(log),
            "--every",
            every,
            "--min-points",
            min_points,
            "--sigma-range",
            sigma,
        ]
        out = _output(folder, json_out, ".json")
        argv += ["--json", out] if out else []
        _check(argv, [out])
    finally:
        shutil.rmtree(folder)


@examples(20)
@given(NUMBERS, NUMBERS, st.sampled_from(["color", "color-pf"]), st.data())
def prop_cli_track_bad_sequences(seed, frames, tracker, data):
    """No images here: the sequence is always refused, but with a one-line message."""
    folder = Path(tempfile.mkdtemp(prefix="rperc-cli-"))
    try:
        seq = folder / "seq"
        seq.mkdir()
        if data.draw(st.booleans()):
            gt = _input(seq, data, "otb", "groundtruth_rect.txt")
            gt.rename(seq / "groundtruth_rect.txt")
        if data.draw(st.booleans()):
            (seq / "img").mkdir()
            (seq / "img" / "0001.jpg").write_bytes(b"\xff\xd8 not a jpeg")
        argv = ["track", str(seq), "--tracker", tracker, "--seed", seed, "--frames", frames]
        _check(argv, [])
    finally:
        shutil.rmtree(folder)


@examples(20)
@given(NUMBERS, NUMBERS, st.booleans(), OUTPUTS, st.sampled_from([None, "ok", "folder"]), st.data())
def prop_cli_slam_walls(seed, freeze, anchor, json_out, plot, data):
    folder = Path(tempfile.mkdtemp(prefix="rperc-cli-"))
    try:
        log = _input(folder, data, "carmen", "log.txt")
        argv = ["slam", "walls", str(log), "--seed", seed, "--freeze", freeze]
        argv += ["--anchor"] if anchor else []
        argv += ["--straightness", data.draw(NUMBERS)] if data.draw(st.booleans()) else []
        out, png = _output(folder, json_out, ".json"), _output(folder, plot, ".png")
        tum = _output(folder, data.draw(OUTPUTS), ".tum")
        argv += ["--json", out] if out else []
        argv += ["--plot", png] if png else []
        argv += ["--tum", tum] if tum else []
        _check(argv, [out, png, tum])
    finally:
        shutil.rmtree(folder)
