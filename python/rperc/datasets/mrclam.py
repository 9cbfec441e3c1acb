"""UTIAS MR.CLAM (Multi-Robot Cooperative Localization and Mapping, Leung et al. 2011).

Files of one data set folder (``#`` lines are comments; ``.gz`` files read as well):

- ``Robot{N}_Odometry.dat``: ``time v omega`` (unicycle velocity commands);
- ``Robot{N}_Measurement.dat``: ``time barcode range bearing``. The header calls the
  second column "Subject #", but it holds BARCODES: in Dataset 6 robot 1 it takes the
  values 90, 81, 72, 63, 61, 54, ... which are barcodes of ``Barcodes.dat`` and not
  subject numbers (1 to 20). We map them to subjects through ``Barcodes.dat``;
- ``Robot{N}_Groundtruth.dat``: ``time x y theta`` (Vicon);
- ``Landmark_Groundtruth.dat``: ``subject x y sx sy``;
- ``Barcodes.dat``: ``subject barcode``.

Subjects 1 to 5 are the robots: sightings of them are counted (``robot_sightings``) and
kept out of the landmark measurements. Barcodes missing from ``Barcodes.dat`` are
counted (``unknown_barcodes``, their values in ``unknown_barcode_values``) and kept out
too: nothing is dropped silently.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rperc._args import excerpt
from rperc.datasets._table import Table, data_file, non_negative, read_id_table, read_table
from rperc.datasets.errors import DatasetFormatError

ROBOT_SUBJECTS = range(1, 6)


@dataclass(frozen=True, repr=False)
class MrclamRun:
    """One robot's run of MR.CLAM, as float64 arrays (times in seconds since the epoch)."""

    robot: int
    odometry_t: np.ndarray
    odometry_v: np.ndarray
    odometry_omega: np.ndarray
    measurement_t: np.ndarray
    measurement_landmark: np.ndarray  # int64 subject number, 6..20
    measurement_range: np.ndarray
    measurement_bearing: np.ndarray
    truth_t: np.ndarray
    truth_x: np.ndarray
    truth_y: np.ndarray
    truth_theta: np.ndarray
    landmark_id: np.ndarray  # int64 subject number
    landmark_x: np.ndarray
    landmark_y: np.ndarray
    landmark_sx: np.ndarray
    landmark_sy: np.ndarray
    robot_sightings: int
    unknown_barcodes: int
    unknown_barcode_values: tuple[int, ...]
    nan_rows: int
    time_backwards: int

    def __repr__(self) -> str:
        return (
            f"MrclamRun(robot {self.robot}: {len(self.odometry_t)} odometry, "
            f"{len(self.measurement_t)} landmark measurements, {len(self.truth_t)} "
            f"ground-truth poses, {len(self.landmark_id)} landmarks; ignored "
            f"{self.robot_sightings} robot sightings and {self.unknown_barcodes} unknown "
            f"barcodes {list(self.unknown_barcode_values)}; {self.nan_rows} rows with NaN, "
            f"{self.time_backwards} times going backwards)"
        )


def _barcode_to_subject(table: Table) -> dict[int, int]:
    subject = table.values[:, 0].astype(np.int64)
    barcode = table.values[:, 1]
    mapping: dict[int, int] = {}
    for k, code in enumerate(barcode):
        if not (np.isfinite(code) and code == round(code)) or int(code) in mapping:
            raise DatasetFormatError(
                table.path, int(table.line[k]), f"barcode {code!r} is not a unique integer"
            )
        mapping[int(code)] = int(subject[k])
    return mapping


def _measurements(
    table: Table, mapping: dict[int, int]
) -> tuple[np.ndarray, np.ndarray, int, tuple[int, ...]]:
    """Keeps landmark sightings; returns (mask of kept rows, their subjects, robot
    sightings, unknown barcodes)."""
    codes = table.values[:, 1]
    subjects = np.zeros(len(codes), dtype=np.int64)
    unknown: list[int] = []
    for k, code in enumerate(codes):
        if not (np.isfinite(code) and code == round(code)):
            raise DatasetFormatError(table.path, int(table.line[k]), f"barcode {code!r}")
        subjects[k] = mapping.get(int(code), 0)
        if subjects[k] == 0:
            unknown.append(int(code))
    is_robot = np.isin(subjects, list(ROBOT_SUBJECTS))
    keep = (subjects > 0) & ~is_robot
    return keep, subjects[keep], int(is_robot.sum()), tuple(unknown)


def _robot_tables(files: dict[str, Path], allow_time_backwards: bool) -> dict[str, Table]:
    """The robot's odometry, measurements (column 1 a barcode, column 2 a range that
    cannot be negative) and ground truth."""
    timed = {
        kind: read_table(
            files[kind],
            cols,
            allow_time_backwards=allow_time_backwards,
            id_columns=ids,
        )
        for kind, cols, ids in (("Odometry", 3, {}), ("Measurement", 4, {1: "barcode"}),
                                ("Groundtruth", 4, {}))
    }  # fmt: skip
    non_negative(timed["Measurement"], {2: "range"})
    return timed


def load_mrclam(
    directory: str | Path, robot: int = 1, *, allow_time_backwards: bool = False
) -> MrclamRun:
    """Reads robot ``robot``'s files (and the shared landmark files) from ``directory``.

    Raises :class:`DatasetFormatError` with file and line for a malformed line, an
    empty file or (unless ``allow_time_backwards``, which counts them) a time going
    backwards; ``ValueError`` for a robot number outside 1..5.
    """
    # bool is an int: True passed as robot 1 and looked for RobotTrue_Odometry.dat.
    if isinstance(robot, bool) or not isinstance(robot, int) or robot not in ROBOT_SUBJECTS:
        raise ValueError(f"robot must be 1..5, got {excerpt(robot)}")
    folder = Path(directory)
    # Every file is found before any is parsed (a missing file is named first), and the
    # shared tables are read before the robot's, whose barcodes they define.
    files = {kind: data_file(folder, f"Robot{robot}_{kind}.dat")
             for kind in ("Odometry", "Measurement", "Groundtruth")}  # fmt: skip
    marks_file = data_file(folder, "Landmark_Groundtruth.dat")
    codes = read_id_table(data_file(folder, "Barcodes.dat"), 2, id_columns={1: "barcode"})
    marks = read_id_table(marks_file, 5)
    # The landmark positions' standard deviations have no negative values.
    non_negative(marks, {3: "sx (standard deviation)", 4: "sy (standard deviation)"})
    timed = _robot_tables(files, allow_time_backwards)
    mapping = _barcode_to_subject(codes)
    meas = timed["Measurement"]
    keep, subjects, robots, unknown = _measurements(meas, mapping)
    odo, truth = timed["Odometry"], timed["Groundtruth"]
    return MrclamRun(
        robot=robot,
        odometry_t=odo.column(0),
        odometry_v=odo.column(1),
        odometry_omega=odo.column(2),
        measurement_t=meas.column(0)[keep],
        measurement_landmark=subjects,
        measurement_range=meas.column(2)[keep],
        measurement_bearing=meas.column(3)[keep],
        truth_t=truth.column(0),
        truth_x=truth.column(1),
        truth_y=truth.column(2),
        truth_theta=truth.column(3),
        landmark_id=marks.values[:, 0].astype(np.int64),
        landmark_x=marks.column(1),
        landmark_y=marks.column(2),
        landmark_sx=marks.column(3),
        landmark_sy=marks.column(4),
        robot_sightings=robots,
        unknown_barcodes=len(unknown),
        unknown_barcode_values=unknown,
        nan_rows=sum(t.nan_rows for t in (*timed.values(), marks)),
        time_backwards=sum(t.time_backwards for t in timed.values()),
    )
