"""Readers for the public data sets rperc is tested and benchmarked on.

Every reader reports a malformed line with its file name and line number
(:class:`DatasetFormatError`, a ``ValueError``) and never drops a record silently.
"""

from rperc.datasets._paths import data_dir, data_path
from rperc.datasets.carmen import (
    CarmenLog,
    LaserScans,
    MaxRangeWarning,
    Odometry,
    SkippedLine,
    load_carmen,
)
from rperc.datasets.errors import DatasetFormatError
from rperc.datasets.mrclam import MrclamRun, load_mrclam
from rperc.datasets.otb import OtbSequence, load_otb, read_boxes
from rperc.datasets.polylines import (
    read_geometries,
    read_polylines,
    write_geometries,
    write_polyline,
)
from rperc.datasets.pot import PlanarTruth, load_planar_truth
from rperc.datasets.timestamps import (
    TimeOrderError,
    TimestampRepairWarning,
    check_increasing,
    repair_increasing,
)
from rperc.datasets.tum import read_tum, write_tum
from rperc.datasets.victoria_park import VictoriaPark, load_victoria_park

__all__ = [
    "CarmenLog",
    "DatasetFormatError",
    "LaserScans",
    "MaxRangeWarning",
    "MrclamRun",
    "Odometry",
    "OtbSequence",
    "PlanarTruth",
    "SkippedLine",
    "TimeOrderError",
    "TimestampRepairWarning",
    "VictoriaPark",
    "check_increasing",
    "data_dir",
    "data_path",
    "load_carmen",
    "load_mrclam",
    "load_otb",
    "load_planar_truth",
    "load_victoria_park",
    "read_boxes",
    "read_geometries",
    "read_polylines",
    "read_tum",
    "repair_increasing",
    "write_geometries",
    "write_polyline",
    "write_tum",
]
