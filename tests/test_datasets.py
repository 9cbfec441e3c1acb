"""Dataset readers: real files parse completely; malformed lines name file and line."""

from __future__ import annotations

import numpy as np
import pytest

from rperc.datasets import DatasetFormatError, load_carmen, load_otb, read_boxes, read_polylines


def test_intel_log_reads_every_record(data):
    path = data / "carmen" / "intel.log"
    log = load_carmen(path)
    text = path.read_text().splitlines()
    assert len(log.scans) == sum(line.startswith("FLASER ") for line in text)
    assert len(log.odometry) == sum(line.startswith("ODOM ") for line in text)
    assert log.skipped == {"NEFF": sum(line.startswith("NEFF ") for line in text)}
    assert log.scans.ranges.shape[1] == 180
    first = next(line for line in text if line.startswith("FLASER "))
    np.testing.assert_allclose(log.scans.ranges[0], [float(v) for v in first.split()[2:182]])
    angles = log.scans.angles(0)
    assert angles[0] == pytest.approx(-np.pi / 2) and np.diff(angles) == pytest.approx(np.pi / 180)


@pytest.mark.parametrize(
    ("line", "message"),
    [
        ("FLASER 3 1.0 2.0 x 0 0 0 0 0 0 12.0 host 12.0", "ranges"),
        ("FLASER 3 1.0 2.0 3.0 0 0 0 0 0 12.0 host 12.0", "fields"),
        ("FLASER -2 0 0 0 0 0 0 1 h 1", "positive"),
        ("FLASER", "beam count"),
        ("ODOM 0 0 0 0 0 0 host 1", "ODOM"),
        ("ROBOTLASER1 0 -1.57 3.14 0.01 80 0.01 0 2 1.0 2.0 0 0 0 0", "ROBOTLASER1"),
    ],
)
def test_malformed_carmen_lines_name_file_and_line(tmp_path, line, message):
    path = tmp_path / "bad.log"
    path.write_text("# header\nODOM 0 0 0 0 0 0 1.0 host 1.0\n" + line + "\n")
    with pytest.raises(DatasetFormatError, match=message) as info:
        load_carmen(path)
    assert info.value.line == 3 and str(path) in str(info.value)
    assert isinstance(info.value, ValueError)


def test_robotlaser1_is_read(tmp_path):
    path = tmp_path / "r.log"
    path.write_text(
        "ROBOTLASER1 0 -1.5 3.0 1.5 20.0 0.01 0 3 1.0 2.0 3.0 0 "
        "1 2 0.5 1.1 2.1 0.6 0 0 0 0 0 7.5 host 7.5\n"
    )
    scans = load_carmen(path).scans
    np.testing.assert_allclose(scans.ranges[0], [1.0, 2.0, 3.0])
    np.testing.assert_allclose(scans.angles(0), [-1.5, 0.0, 1.5])
    np.testing.assert_allclose(scans.pose[0], [1, 2, 0.5])
    assert scans.max_range[0] == 20.0 and scans.timestamp[0] == 7.5


def test_wkt_and_csv(tmp_path):
    wkt = tmp_path / "a.wkt"
    wkt.write_text("LINESTRING(0 0, 1 1, 2 0)\nPOLYGON((0 0, 1 0, 1 1, 0 0))\n")
    a, b = read_polylines(wkt)
    assert a.shape == (3, 2) and b.shape == (4, 2) and (b[0] == b[-1]).all()
    csv = tmp_path / "a.csv"
    csv.write_text("x,y,z\n0,0,1\n1,1,2\n\n5,5,0\n6,6,0\n")
    c, d = read_polylines(csv)
    assert c.shape == (2, 3) and d.shape == (2, 3)
    bad = tmp_path / "b.csv"
    bad.write_text("x,y\n0,0\n1,oops\n")
    with pytest.raises(DatasetFormatError, match=r"b.csv:3"):
        read_polylines(bad)
    bad_wkt = tmp_path / "b.wkt"
    bad_wkt.write_text("LINESTRING(0 0, 1 1)\nPOINT(1 2)\n")
    with pytest.raises(DatasetFormatError, match=r"b.wkt:2"):
        read_polylines(bad_wkt)


def test_otb_sequences(data):
    for name, frames in [("Girl", 500), ("Couple", 140)]:
        seq = load_otb(data / "otb" / name)
        assert len(seq) == frames and seq.boxes.shape == (frames, 4)
        img = seq.frame(0)
        assert img.dtype == np.uint8 and img.ndim == 3 and img.shape[2] == 3
    first = (data / "otb" / "Girl" / "groundtruth_rect.txt").read_text().split()[:4]
    np.testing.assert_allclose(
        load_otb(data / "otb" / "Girl").boxes[0], [float(v) for v in first] - np.array([1, 1, 0, 0])
    )


def test_malformed_otb_box_line(tmp_path):
    gt = tmp_path / "groundtruth_rect.txt"
    gt.write_text("1,2,3,4\n1\t2\t3\n")
    with pytest.raises(DatasetFormatError, match=r"groundtruth_rect\.txt:2"):
        read_boxes(gt)


def test_groundtruth_blank_lines_and_impossible_boxes(tmp_path):
    gt = tmp_path / "groundtruth_rect.txt"
    gt.write_text("1,2,3,4\n5,6,7,8\n\n\n")  # blank lines at the end: fine
    np.testing.assert_array_equal(read_boxes(gt), [[0, 1, 3, 4], [4, 5, 7, 8]])
    gt.write_text("1,2,3,4\n\n5,6,7,8\n")  # a frame without a box: an error
    with pytest.raises(DatasetFormatError, match=r"groundtruth_rect\.txt:2"):
        read_boxes(gt)
    gt.write_text("1,2,3,4\n5,6,-7,8\n")  # a negative width
    with pytest.raises(DatasetFormatError, match=r":2: .*negative"):
        read_boxes(gt)
