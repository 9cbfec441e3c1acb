"""The header and value surfaces of the MR.CLAM, Victoria Park, OTB ground-truth and
polyline (WKT, GeoJSON, CSV) loaders under fuzzing (issue 38). A small valid file set
gets one hostile value (an id past 2^53, an infinity, a negative range, a box corner at
1e300, a NaN vertex), a hostile header line, a curved WKT type or a deeply nested
GeoJSON document. Each example is a DatasetFormatError naming the file and the line,
briefly, or a result that passes its own check: the value comes back exactly as
written, and nothing that cannot be (an infinite range, a lossy id) is accepted."""

from __future__ import annotations

import math
import re
import shutil
import tempfile
from collections.abc import Callable
from decimal import Decimal, InvalidOperation
from pathlib import Path
from typing import Any

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from rperc.datasets import DatasetFormatError, load_mrclam, load_victoria_park, read_boxes
from rperc.datasets.polylines import read_polylines

from fuzz.harness import case, examples, outcome

# Tokens a value column may hold: ids at and past 2^53 (the last integer float64 holds
# exactly), infinities, NaN, negatives, overflow and underflow, and plain numbers.
TOKENS = st.one_of(
    st.sampled_from([
        "9007199254740992", "9007199254740993", "9.007199254740993e15", "18014398509481984",
        "1e20", "-1", "-0", "0", "7", "7.0", "7.5", "inf", "-inf", "Infinity", "nan", "NaN",
        "1e308", "1e309", "-1e309", "1e-320", "1" * 400, "1_000",
    ]),
    st.floats(-1e12, 1e12, allow_nan=False).map(repr),
)  # fmt: skip
# Lines a header may start with: comments a reader skips, and lines it must refuse.
HEADERS = st.sampled_from([
    "# Time [s]    v [m/s]", "#", "# \x00 binary", "#" + "x" * 100_000, "   # indented",
    "Time [s] v w", "% comment", "\ufeff# a BOM", "#\t\ttabs",
])  # fmt: skip
MESSAGE_LIMIT = 400  # characters: a message names its place, it does not quote the file


def _number(token: str) -> float | None:
    """What float() reads from ``token`` (Python's reading), or None."""
    try:
        return float(token)
    except ValueError:
        return None


def _exact_id(token: str) -> int | None:
    """The id ``token`` states when it is a whole number in 0..2^53 that float64 holds
    exactly (the text is the float), else None."""
    value = _number(token)
    if value is None or not math.isfinite(value) or value != round(value):
        return None
    try:
        exact = Decimal(token.replace("_", "")) == Decimal(value)
    except InvalidOperation:
        return None
    return int(value) if exact and 0 <= value <= 2**53 else None


def _load(files: dict[str, str], load: Callable[[Path], Any]) -> tuple[bool, Any]:
    folder = Path(tempfile.mkdtemp(prefix="rperc-fuzz-"))
    try:
        for name, text in files.items():
            (folder / name).write_text(text, encoding="utf-8")
        return outcome(load, folder)
    finally:
        shutil.rmtree(folder)


def _names_the_line(err: BaseException, name: str, line: int, role: str = "v") -> None:
    """``err`` is a short DatasetFormatError naming ``name`` and ``line``; for a time
    that goes backwards there, the next line may be named (its time then precedes),
    and for an id that another record holds, the later of the two."""
    assert isinstance(err, DatasetFormatError), f"{type(err).__name__}: {err}"
    repeated = role == "id" and "repeats line" in str(err)
    lines = {"t": (line, line + 1)}.get(role, (line,))
    fine = err.line in lines or (repeated and f"repeats line {line}" in str(err))
    assert Path(err.path).name == name and fine, (str(err)[:300], name, line)
    assert len(str(err)) < MESSAGE_LIMIT, str(err)[:300]


def _same(got: float, token: str) -> bool:
    want = _number(token)
    return want is not None and (got == want or (math.isnan(got) and math.isnan(want)))


# MR.CLAM: robot 1's three timed files and the two id tables. Column roles per file:
# "t" a time, "id" an id, "range" a value >= 0, "v" any value.
MRCLAM = {
    "Robot1_Odometry.dat": (["t", "v", "v"], [[10.0, 0.1, 0.0], [11.0, 0.2, -0.1]]),
    "Robot1_Measurement.dat": (["t", "id", "range", "v"], [[10.5, 106, 1.5, 0.2],
                                                           [11.5, 107, 2.5, -0.3]]),
    "Robot1_Groundtruth.dat": (["t", "v", "v", "v"], [[10.0, 1.0, 2.0, 0.5],
                                                      [11.0, 1.1, 2.1, 0.6]]),
    "Landmark_Groundtruth.dat": (["id", "v", "v", "range", "range"], [[6, 1.0, 1.0, 0.1, 0.1],
                                                                     [7, 2.0, 3.0, 0.2, 0.2]]),
    "Barcodes.dat": (["id", "id"], [[s, 100 + s] for s in range(1, 8)]),
}  # fmt: skip


def _mrclam_files(table: dict[str, tuple[list[str], list[list[float]]]],
                  header: str) -> dict[str, str]:  # fmt: skip
    """Each file: ``header`` (line 1), then one record per line."""
    return {
        name: header + "\n" + "".join(" ".join(map(str, row)) + "\n" for row in rows)
        for name, (_, rows) in table.items()
    }


def _mrclam_column(run: Any, name: str, col: int) -> np.ndarray | None:
    """The loaded array that column ``col`` of ``name`` becomes (None: not one array)."""
    arrays = {
        "Robot1_Odometry.dat": [run.odometry_t, run.odometry_v, run.odometry_omega],
        "Robot1_Groundtruth.dat": [run.truth_t, run.truth_x, run.truth_y, run.truth_theta],
        "Landmark_Groundtruth.dat": [run.landmark_id, run.landmark_x, run.landmark_y,
                                     run.landmark_sx, run.landmark_sy],
    }.get(name)  # fmt: skip
    return None if arrays is None else arrays[col]


def _mrclam_sane(run: Any) -> None:
    """What every accepted run holds, whatever was written."""
    for key, value in vars(run).items():
        if isinstance(value, np.ndarray) and value.dtype.kind == "f":
            assert not np.isinf(value).any(), f"{key} holds an infinity"
    for key in ("measurement_range", "landmark_sx", "landmark_sy"):
        assert not (getattr(run, key) < 0).any(), f"{key} holds a negative value"
    assert run.landmark_id.dtype == np.int64 and (run.landmark_id >= 0).all()


def _mrclam_expected(name: str, role: str, row: int, token: str) -> bool | None:
    """Whether the loader must accept ``token`` there (None: either answer is fair,
    as for a time whose order it may break or an id that may collide)."""
    value = _number(token)
    if value is None or math.isinf(value):
        return False
    if role == "t":
        return None
    if role == "id":
        ident = _exact_id(token)
        if ident is None:
            return False
        return None
    if role == "range":
        return not value < 0
    return True


@examples(80)
@given(st.sampled_from(sorted(MRCLAM)), st.data(), TOKENS, HEADERS)
def prop_mrclam_values_and_headers(name, data, token, header):
    roles, rows = MRCLAM[name]
    row = data.draw(st.integers(0, len(rows) - 1))
    col = data.draw(st.integers(0, len(roles) - 1))
    hostile_header = data.draw(st.booleans())
    table = {k: (r, [list(x) for x in v]) for k, (r, v) in MRCLAM.items()}
    table[name][1][row][col] = token  # type: ignore[call-overload]
    files = _mrclam_files(table, header if hostile_header else "# Time [s]")
    case("load_mrclam", file=name, row=row, col=col, token=token, header=hostile_header)
    ok, got = _load(files, load_mrclam)
    # A NUL byte marks a file as binary: refused at once, at its line.
    header_is_comment = "\x00" not in header and header.lstrip("\ufeff").split()[0][0] == "#"
    if hostile_header and not header_is_comment:
        assert not ok, f"header {header[:40]!r} accepted"
        assert isinstance(got, DatasetFormatError) and got.line == 1, str(got)[:300]
        assert len(str(got)) < MESSAGE_LIMIT, str(got)[:300]
        return
    expected = _mrclam_expected(name, roles[col], row, token)
    if not ok:
        assert expected is not True, f"{name}[{row}][{col}] = {token!r} refused: {got}"
        _names_the_line(got, name, row + 2, roles[col])
        return
    assert expected is not False, f"{name}[{row}][{col}] = {token!r} accepted"
    _mrclam_sane(got)
    column = _mrclam_column(got, name, col)
    if column is not None:
        if roles[col] == "id":
            assert int(column[row]) == _exact_id(token), (column[row], token)
        else:
            assert _same(float(column[row]), token), (column[row], token)
    if name == "Robot1_Measurement.dat" and roles[col] == "id":
        # A barcode no subject has is counted, with its value exactly as written.
        codes = set(got.unknown_barcode_values)
        assert codes <= {_exact_id(token)}, (codes, token)


VICTORIA = {
    "measurements.dat": (["t", "range", "v", "range"], [[1.0, 5.0, 1.5, 0.3],
                                                        [2.0, 6.0, 1.4, 0.4]]),
    "inputs.dat": (["t", "v", "v"], [[1.0, 2.0, 0.01], [2.0, 2.1, -0.02]]),
    "gps.dat": (["t", "v", "v"], [[1.0, 3.0, 4.0], [2.0, 3.5, 4.5]]),
}  # fmt: skip


@examples(50)
@given(st.sampled_from(sorted(VICTORIA)), st.data(), TOKENS)
def prop_victoria_park_values(name, data, token):
    roles, rows = VICTORIA[name]
    row = data.draw(st.integers(0, len(rows) - 1))
    col = data.draw(st.integers(0, len(roles) - 1))
    table = {k: [list(map(str, x)) for x in v] for k, (_, v) in VICTORIA.items()}
    table[name][row][col] = token
    files = {k: "".join(" ".join(r) + "\n" for r in v) for k, v in table.items()}
    case("load_victoria_park", file=name, row=row, col=col, token=token)
    ok, got = _load(files, load_victoria_park)
    expected = _mrclam_expected(name, roles[col], row, token)
    if not ok:
        assert expected is not True, f"{name}[{row}][{col}] = {token!r} refused: {got}"
        _names_the_line(got, name, row + 1, roles[col])
        return
    assert expected is not False, f"{name}[{row}][{col}] = {token!r} accepted"
    arrays = {
        "measurements.dat": [got.measurement_t, got.measurement_range,
                             got.measurement_bearing_laser, got.measurement_diameter],
        "inputs.dat": [got.input_t, got.input_speed, got.input_steering],
        "gps.dat": [got.gps_t, got.gps_x, got.gps_y],
    }[name]  # fmt: skip
    assert _same(float(arrays[col][row]), token), (arrays[col][row], token)
    for a in (got.measurement_range, got.measurement_diameter):
        assert not (a < 0).any() and not np.isinf(a).any(), a


# OTB boxes: x y w h per line, 1-based corners. Tokens as the Rust reader reads them.
BOX_TOKENS = st.one_of(
    st.sampled_from(["1e9", "999999999", "1000000001", "1e300", "-1e300", "inf", "nan",
                     "-5", "0", "2.5", "1e-320"]),
    st.floats(-2e9, 2e9, allow_nan=False).map(repr),
)  # fmt: skip


@examples(60)
@given(st.integers(0, 2), st.integers(0, 3), BOX_TOKENS, st.sampled_from(["\t", " ", ","]))
def prop_otb_box_values(row, col, token, sep):
    boxes = [["10", "20", "30", "40"], ["11", "21", "31", "41"], ["12", "22", "32", "42"]]
    boxes[row][col] = token
    text = "".join(sep.join(b) + "\n" for b in boxes)
    case("read_boxes", text=text)
    ok, got = _load({"groundtruth_rect.txt": text},
                    lambda folder: read_boxes(folder / "groundtruth_rect.txt"))  # fmt: skip
    values = [float(v) for v in boxes[row]]
    x, y, w, h = values
    fits = all(math.isfinite(v) for v in values) and w >= 0 and h >= 0
    fits = fits and all(abs(c) <= 1e9 for c in (x, y, x + w, y + h))
    if not ok:
        assert not fits, f"box {boxes[row]} refused: {got}"
        _names_the_line(got, "groundtruth_rect.txt", row + 1)
        return
    assert fits, f"box {boxes[row]} accepted"
    np.testing.assert_array_equal(got[row], [x - 1, y - 1, w, h])


def _nested(depth: int) -> str:
    """A GeoJSON LineString whose coordinates nest ``depth`` arrays deep."""
    return '{"type": "LineString", "coordinates": ' + "[" * depth + "]" * depth + "}"


# Whole lines of a WKT file that must be refused (naming the line) or read.
WKT_LINES = st.sampled_from([
    "CIRCULARSTRING (0 0, 1 1, 2 0)", "COMPOUNDCURVE ((0 0, 1 1))", "MULTICURVE ((0 0, 1 1))",
    "CURVEPOLYGON ((0 0, 1 1, 1 0, 0 0))", "TRIANGLE ((0 0, 1 0, 0 1, 0 0))",
    "POINT (1 2)", "LINESTRING EMPTY", "LINESTRING (1 2)", "LINESTRING (0 0, 1 1",
    "POLYGON ((0 0, 1 0, 1 1, 0 0))", "LINESTRING Z (0 0 0, 1 1 1)",
])  # fmt: skip


@examples(80)
@given(st.sampled_from(["wkt", "geojson", "csv", "wkt_line", "nested"]), TOKENS,
       WKT_LINES, st.integers(2, 200_000))  # fmt: skip
def prop_polyline_values(kind, token, wkt_line, depth):
    """A NaN, infinite or overflowing vertex is refused naming its line; a curved or
    otherwise unreadable WKT line is refused naming its line; a deeply nested GeoJSON
    document is refused, never a RecursionError; what is read has finite vertices."""
    coords = [["0", "0"], ["1", token], ["2", "0"]]
    name = {"wkt": "a.wkt", "wkt_line": "a.wkt", "geojson": "a.geojson",
            "nested": "a.geojson", "csv": "a.csv"}[kind]  # fmt: skip
    line = 2
    if kind == "wkt":
        text = (
            "LINESTRING (5 5, 6 6)\nLINESTRING (" + ", ".join(" ".join(c) for c in coords) + ")\n"
        )
    elif kind == "wkt_line":
        text = "LINESTRING (5 5, 6 6)\n" + wkt_line + "\n"
    elif kind == "csv":
        text = "x,y\n" + "".join(",".join(c) + "\n" for c in coords)
        line = 3
    elif kind == "geojson":
        points = ", ".join("[" + ", ".join(c) + "]" for c in coords)
        text = '{"type": "LineString", "coordinates": [' + points + "]}\n"
        line = 1
    else:
        text = _nested(depth)
        line = 1
    case("read_polylines", kind=kind, text=text[:300])
    ok, got = _load({name: text}, lambda folder: read_polylines(folder / name))
    # A plain finite number in a WKT or CSV vertex must be read.
    plain = kind in ("wkt", "csv") and re.fullmatch(r"-?\d+(\.\d+)?(e-?\d+)?", token)
    must_read = bool(plain) and math.isfinite(float(token))
    if not ok:
        assert not must_read, f"{token!r} refused: {got}"
        _names_the_line(got, name, line)
        return
    for part in got:
        assert np.isfinite(part).all(), part
    if kind in ("wkt", "csv"):
        value = _number(token)
        assert value is not None and math.isfinite(value), f"{token!r} accepted"
        assert got[-1][1, 1] == value, (got[-1], token)
