"""One small valid fixture per loader (a hypothesis strategy each), with the records
the loader must return: CARMEN, MR.CLAM, Victoria Park, OTB ground truth, TUM, CSV and
WKT polylines."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
from hypothesis import strategies as st

from rperc import datasets

from fuzz.files import Fixture, line_of, number_rows


def _stack(*cols: Any) -> np.ndarray:
    return np.column_stack([np.asarray(c, dtype=np.float64) for c in cols])


@st.composite
def carmen(draw: st.DrawFn) -> Fixture:
    n = draw(st.integers(2, 5))
    scans = draw(number_rows(draw(st.integers(1, 5)), n + 7, time=False))
    odom = draw(number_rows(draw(st.integers(0, 4)), 7, time=False))
    lines = ["# CARMEN log", "PARAM robot_width 0.5 nohost 0.0"]
    data: list[int] = []
    for row in scans:
        data.append(len(lines))
        lines.append(f"FLASER {n} {line_of(row)} nohost 0.5")
    for row in odom:
        data.append(len(lines))
        lines.append(f"ODOM {line_of(row)} nohost 0.5")

    def extract(log: Any) -> dict[str, np.ndarray]:
        s, o = log.scans, log.odometry
        # Drawn times need not increase: the file's are kept in timestamp_raw, and
        # timestamp is repaired to increase strictly, one per scan.
        assert len(s.timestamp) == len(s.timestamp_raw) and np.all(np.diff(s.timestamp) > 0)
        assert log.times_repaired == np.count_nonzero(s.timestamp != s.timestamp_raw)
        return {
            "scans": _stack(s.ranges, s.pose, s.odom, s.timestamp_raw),
            "odom": _stack(o.pose, o.velocity, o.timestamp).reshape(-1, 7),
        }

    expected = scans.copy()
    # Negative ranges are invalid readings: the reader stores them as NaN (and counts them).
    expected[:, :n] = np.where(expected[:, :n] < 0, np.nan, expected[:, :n])
    return Fixture(
        files={"log.txt": lines},
        records={"scans": expected, "odom": odom},
        data_lines={"log.txt": data},
        load=lambda folder: datasets.load_carmen(folder / "log.txt"),
        extract=extract,
    )


def _table(rows: np.ndarray, header: str) -> tuple[list[str], list[int]]:
    return [header] + [line_of(r, "\t") for r in rows], list(range(1, len(rows) + 1))


@st.composite
def mrclam(draw: st.DrawFn) -> Fixture:
    marks = draw(number_rows(draw(st.integers(1, 4)), 5, time=False, ids=True))
    barcodes = np.array([[s, 100 + s] for s in [1, 2, 3, 4, 5, *marks[:, 0]]], float)
    meas = draw(number_rows(draw(st.integers(1, 5)), 4, time=True))
    meas[:, 1] = 100 + marks[draw(st.integers(0, len(marks) - 1)), 0]
    # Ranges and the landmarks' standard deviations are never negative (refused).
    meas[:, 2] = np.abs(meas[:, 2])
    marks[:, 3:] = np.abs(marks[:, 3:])
    tables = {
        "Robot1_Odometry.dat": draw(number_rows(draw(st.integers(1, 5)), 3, time=True)),
        "Robot1_Measurement.dat": meas,
        "Robot1_Groundtruth.dat": draw(number_rows(draw(st.integers(1, 5)), 4, time=True)),
        "Landmark_Groundtruth.dat": marks,
        "Barcodes.dat": barcodes,
    }
    files, data = {}, {}
    for name, rows in tables.items():
        files[name], data[name] = _table(rows, "# Time [s]    columns of " + name)

    def extract(run: Any) -> dict[str, np.ndarray]:
        return {
            "Robot1_Odometry.dat": _stack(run.odometry_t, run.odometry_v, run.odometry_omega),
            "Robot1_Measurement.dat": _stack(
                run.measurement_t,
                run.measurement_landmark + 100,
                run.measurement_range,
                run.measurement_bearing,
            ),
            "Robot1_Groundtruth.dat": _stack(
                run.truth_t, run.truth_x, run.truth_y, run.truth_theta
            ),
            "Landmark_Groundtruth.dat": _stack(
                run.landmark_id, run.landmark_x, run.landmark_y, run.landmark_sx, run.landmark_sy
            ),
        }

    records = {k: v for k, v in tables.items() if k != "Barcodes.dat"}
    timed = ("Robot1_Odometry.dat", "Robot1_Measurement.dat", "Robot1_Groundtruth.dat")
    return Fixture(files, records, data, datasets.load_mrclam, extract, timed=timed)


@st.composite
def victoria_park(draw: st.DrawFn) -> Fixture:
    tables = {
        name: draw(number_rows(draw(st.integers(1, 5)), cols, time=True))
        for name, cols in (("measurements.dat", 4), ("inputs.dat", 3), ("gps.dat", 3))
    }
    # Ranges and trunk diameters are never negative (refused).
    tables["measurements.dat"][:, [1, 3]] = np.abs(tables["measurements.dat"][:, [1, 3]])
    files, data = {}, {}
    for name, rows in tables.items():
        lines = [line_of(r) for r in rows]
        files[name], data[name] = lines, list(range(len(rows)))

    def extract(vp: Any) -> dict[str, np.ndarray]:
        return {
            "measurements.dat": _stack(
                vp.measurement_t,
                vp.measurement_range,
                vp.measurement_bearing_laser,
                vp.measurement_diameter,
            ),
            "inputs.dat": _stack(vp.input_t, vp.input_speed, vp.input_steering),
            "gps.dat": _stack(vp.gps_t, vp.gps_x, vp.gps_y),
        }

    return Fixture(files, tables, data, datasets.load_victoria_park, extract, timed=tuple(tables))


@st.composite
def otb_groundtruth(draw: st.DrawFn) -> Fixture:
    boxes = draw(number_rows(draw(st.integers(1, 6)), 4, time=False))
    boxes[:, 2:] = np.abs(boxes[:, 2:])
    lines = [line_of(b, draw(st.sampled_from(["\t", " ", "  "]))) for b in boxes]
    return Fixture(
        files={"groundtruth_rect.txt": lines},
        records={"boxes": boxes - [1.0, 1.0, 0.0, 0.0]},
        data_lines={"groundtruth_rect.txt": list(range(len(lines)))},
        load=lambda folder: datasets.read_boxes(folder / "groundtruth_rect.txt"),
        extract=lambda boxes: {"boxes": boxes},
        benign=("none", "bom", "gzip", "crlf", "blank_end", "spaces"),
    )


@st.composite
def tum(draw: st.DrawFn) -> Fixture:
    rows = draw(number_rows(draw(st.integers(1, 6)), 4, time=True))
    rows[:, 3] = np.arctan2(np.sin(rows[:, 3]), np.cos(rows[:, 3]))
    lines = ["# t x y z qx qy qz qw"] + [
        f"{line_of(r[:3])} 0 0 0 {math.sin(r[3] / 2)!r} {math.cos(r[3] / 2)!r}" for r in rows
    ]

    def load(folder: Path) -> Any:
        return datasets.read_tum(folder / "traj.txt")

    return Fixture(
        files={"traj.txt": lines},
        records={"traj": rows},
        data_lines={"traj.txt": list(range(1, len(lines)))},
        load=load,
        extract=lambda got: {"traj": _stack(got[0], got[1])},
        timed=("traj.txt",),
    )


@st.composite
def wkt_polylines(draw: st.DrawFn) -> Fixture:
    parts = [draw(number_rows(draw(st.integers(2, 5)), 2, time=False)) for _ in range(2)]
    lines = ["LINESTRING (" + ", ".join(line_of(p) for p in part) + ")" for part in parts]
    return Fixture(
        files={"lines.wkt": lines},
        records={f"line{k}": p for k, p in enumerate(parts)},
        data_lines={"lines.wkt": [0, 1]},
        load=lambda folder: datasets.read_polylines(folder / "lines.wkt"),
        extract=lambda got: {f"line{k}": p for k, p in enumerate(got)},
        benign=("none", "bom", "gzip", "crlf", "blank_end", "spaces"),
        breaking=("truncate", "garbage", "undecodable"),
    )


@st.composite
def csv_polylines(draw: st.DrawFn) -> Fixture:
    parts = [draw(number_rows(draw(st.integers(2, 4)), 2, time=False)) for _ in range(2)]
    lines = ["x,y"] + [line_of(r, ",") for r in parts[0]] + [""]
    lines += [line_of(r, ",") for r in parts[1]]
    data = [k for k, line in enumerate(lines) if k > 0 and line]
    return Fixture(
        files={"lines.csv": lines},
        records={f"line{k}": p for k, p in enumerate(parts)},
        data_lines={"lines.csv": data},
        load=lambda folder: datasets.read_polylines(folder / "lines.csv"),
        extract=lambda got: {f"line{k}": p for k, p in enumerate(got)},
        benign=("none", "bom", "gzip", "crlf", "blank_end"),
        breaking=("extra_column", "undecodable"),
    )


FIXTURES = {
    "carmen": carmen(),
    "mrclam": mrclam(),
    "victoria_park": victoria_park(),
    "otb": otb_groundtruth(),
    "tum": tum(),
    "wkt": wkt_polylines(),
    "csv": csv_polylines(),
}
