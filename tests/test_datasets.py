"""Dataset readers: real files parse completely; malformed lines name file and line."""

from __future__ import annotations

import json

import numpy as np
import pytest

from rperc.datasets import (
    DatasetFormatError,
    TimestampRepairWarning,
    load_carmen,
    load_otb,
    read_boxes,
    read_geometries,
    read_polylines,
    write_geometries,
    write_polyline,
)


def test_intel_log_reads_every_record(data):
    path = data / "carmen" / "intel.log"
    # Four scan times step back in the file: repaired, and said so.
    with pytest.warns(TimestampRepairWarning, match="intel.log: 4 of 910 scan times"):
        log = load_carmen(path)
    text = path.read_text().splitlines()
    assert len(log.scans) == sum(line.startswith("FLASER ") for line in text)
    assert len(log.odometry) == sum(line.startswith("ODOM ") for line in text)
    counted = {
        kind: sum(line.startswith(kind + " ") for line in text) for kind in ("NEFF", "PARAM")
    }
    assert log.skipped == counted  # PARAM lines are counted too, never silently dropped
    assert log.comments == sum(line.startswith("#") for line in text) > 0
    assert f"{log.comments} comment lines" in log.summary()
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


def test_m_values_are_never_read_as_z(tmp_path):
    shapely = pytest.importorskip("shapely")
    path = tmp_path / "m.wkt"
    path.write_text("LINESTRING M (0 0 5, 1 1 6, 2 0 7)\nLINESTRING ZM (0 0 1 5, 1 1 2 6)\n")
    m, zm = read_geometries(path)
    assert m.has_m and not m.has_z and zm.has_m and zm.has_z
    np.testing.assert_array_equal(shapely.get_coordinates(m, include_m=True)[:, 2], [5, 6, 7])
    line_m, line_zm = read_polylines(path)
    np.testing.assert_array_equal(line_m, [[0, 0], [1, 1], [2, 0]])  # M dropped
    np.testing.assert_array_equal(line_zm, [[0, 0, 1], [1, 1, 2]])  # z kept, M dropped


def geometry_zoo(shapely):
    walk = np.cumsum(np.random.default_rng(0).normal(size=(50, 2)), axis=0) / 3.0
    texts = [
        "MULTIPOLYGON (((0 0, 4 0, 4 4, 0 4, 0 0), (1 1, 2 1, 2 2, 1 1)), "
        "((10 10, 11 10, 11 11, 10 10)))",
        "POLYGON ((0 0, 1 0, 1 1, 0 0))",
        "LINESTRING EMPTY",
        "POLYGON EMPTY",
        "MULTILINESTRING ((0 0, 1 1), (2 2, 3 3))",
        "LINESTRING M (0 0 1, 1 1 2)",
        "LINESTRING Z (0.1 0.2 0.3, 1e-300 5e300 7)",
        "GEOMETRYCOLLECTION (POINT (1 2), LINESTRING (0 0, 1 1))",
    ]
    geoms = [shapely.from_wkt(t) for t in texts] + [shapely.LineString(walk)]
    geoms[0] = shapely.set_srid(geoms[0], 4326)
    return geoms


def test_wkt_round_trip_keeps_type_dimensions_srid_and_every_bit(tmp_path):
    shapely = pytest.importorskip("shapely")
    geoms = geometry_zoo(shapely)
    path = write_geometries(tmp_path / "zoo.wkt", geoms)
    lines = path.read_text().splitlines()
    assert lines[0].startswith("SRID=4326;MULTIPOLYGON") and lines[1].startswith("POLYGON")
    back = read_geometries(path)
    assert len(back) == len(geoms)
    for before, after in zip(geoms, back, strict=True):
        assert after.geom_type == before.geom_type
        assert (after.has_z, after.has_m) == (before.has_z, before.has_m)
        assert shapely.get_srid(after) == shapely.get_srid(before)
        assert shapely.equals_exact(after, before, tolerance=0.0) or before.is_empty


def test_geojson_round_trip_keeps_types_and_coordinates(tmp_path):
    shapely = pytest.importorskip("shapely")
    geoms = geometry_zoo(shapely)
    path = write_geometries(tmp_path / "zoo.geojson", geoms)
    doc = json.loads(path.read_text())
    assert doc["type"] == "FeatureCollection" and len(doc["features"]) == len(geoms)
    back = read_geometries(path)
    for before, after in zip(geoms, back, strict=True):
        assert after.geom_type == before.geom_type or before.is_empty
        assert not after.has_m  # GeoJSON has no M
        xyz = shapely.get_coordinates(before, include_z=before.has_z)
        np.testing.assert_array_equal(shapely.get_coordinates(after, include_z=before.has_z), xyz)


def test_csv_output_holds_every_line_and_ring(tmp_path):
    shapely = pytest.importorskip("shapely")
    polygon = shapely.from_wkt("POLYGON ((0 0, 4 0, 4 4, 0 0), (1 0.5, 2 0.5, 2 1, 1 0.5))")
    path = write_geometries(tmp_path / "rings.csv", [polygon, shapely.LineString([(5, 5), (6, 7)])])
    rings = read_polylines(path)
    assert [len(r) for r in rings] == [4, 4, 2]
    np.testing.assert_array_equal(rings[1], np.asarray(polygon.interiors[0].coords))
    with pytest.raises(ValueError, match="Point"):
        write_geometries(tmp_path / "p.csv", [shapely.Point(1, 2)])


def test_ewkt_srid_prefixes(tmp_path):
    shapely = pytest.importorskip("shapely")
    path = tmp_path / "srid.wkt"
    path.write_text("SRID=4326;LINESTRING (0 0, 1 1)\nsrid = 3857 ; POINT (1 2)\nPOINT (3 4)\n")
    srids = [shapely.get_srid(g) for g in read_geometries(path)]
    assert srids == [4326, 3857, 0]


def test_geojson_errors_name_file_and_line(tmp_path):
    pytest.importorskip("shapely")
    broken = tmp_path / "broken.geojson"
    broken.write_text(
        '{"type": "FeatureCollection",\n "features": [\n  {"type": "Feature",,}\n]}\n'
    )
    with pytest.raises(DatasetFormatError, match=r"broken\.geojson:3") as info:
        read_geometries(broken)
    assert info.value.line == 3
    feature = '  {"type": "Feature", "properties": {}, "geometry": %s}'
    good = '{"type": "LineString", "coordinates": [[0, 0], [1, 1]]}'
    bad = '{"type": "LineString", "coordinates": [[0, 0]]}'
    text = (
        '{"type": "FeatureCollection", "features": [\n'
        + ",\n".join([feature % good, feature % "null", feature % bad])
        + "\n]}\n"
    )
    path = tmp_path / "bad.geojson"
    path.write_text(text)
    with pytest.raises(DatasetFormatError, match=r"features\[2\]") as info:
        read_geometries(path)
    assert info.value.line == 4 and str(path) in str(info.value)
    path.write_text(text.replace(feature % bad, feature % good))
    first, empty, last = read_geometries(path)  # a null geometry is kept, as empty
    assert empty.is_empty and first.geom_type == last.geom_type == "LineString"


def test_unknown_suffixes_are_refused(tmp_path):
    with pytest.raises(ValueError, match="unknown file type"):
        write_polyline(tmp_path / "a.dat", np.zeros((2, 2)))
    (tmp_path / "a.shp").write_text("")
    with pytest.raises(ValueError, match="unknown file type"):
        read_geometries(tmp_path / "a.shp")


def test_write_polyline_in_every_format(tmp_path):
    pytest.importorskip("shapely")
    pts = np.cumsum(np.random.default_rng(1).normal(size=(30, 3)), axis=0)
    for suffix in (".wkt", ".geojson", ".csv"):
        (back,) = read_polylines(write_polyline(tmp_path / f"line{suffix}", pts))
        np.testing.assert_array_equal(back, pts)


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


FLASER = "FLASER 3 1.0 2.0 3.0 0.5 0.25 0.1 0.5 0.25 0.1 12.5 host 12.6\n"


def test_carmen_bom_gzip_unknown_types_and_bad_bytes(tmp_path):
    import gzip

    plain = "PARAM robot_x 1\n" + FLASER + "flaser 3 1 2 3 0 0 0 0 0 0 1 h 1\nNEFF 1 2\nNEFF 3 4\n"
    log = tmp_path / "a.log"
    log.write_bytes(b"\xef\xbb\xbf" + plain.encode())
    read = load_carmen(log)
    assert len(read.scans) == 1  # the BOM did not hide the first scan
    np.testing.assert_array_equal(read.scans.ranges[0], [1.0, 2.0, 3.0])
    assert read.skipped == {"PARAM": 1, "flaser": 1, "NEFF": 2}
    assert read.first_line == {"PARAM": 1, "flaser": 3, "NEFF": 4}
    assert "2 NEFF skipped (first at line 4)" in read.summary()
    with pytest.raises(DatasetFormatError, match=r"a\.log:3: unknown record type 'flaser'"):
        load_carmen(log, strict=True)
    # gzip is read transparently, whatever the suffix.
    gz = tmp_path / "b.log"
    gz.write_bytes(gzip.compress(plain.encode()))
    assert load_carmen(gz).skipped == read.skipped
    gz.write_bytes(gzip.compress(plain.encode())[:-9])  # truncated
    with pytest.raises(DatasetFormatError, match="gzip"):
        load_carmen(gz)
    # A byte that is not UTF-8: file, line and the byte's offset in the line.
    bad = tmp_path / "c.log"
    bad.write_bytes(FLASER.encode() + b"NEFF \xff 2\n")
    with pytest.raises(DatasetFormatError, match=r"c\.log:2: byte 5 of the line \(0xff\)"):
        load_carmen(bad)


def test_otb_groundtruth_gzip_and_bad_bytes(tmp_path):
    import gzip

    gt = tmp_path / "groundtruth_rect.txt"
    gt.write_bytes(gzip.compress(b"1,2,3,4\n5,6,7,8\n"))
    np.testing.assert_array_equal(read_boxes(gt), [[0, 1, 3, 4], [4, 5, 7, 8]])
    gt.write_bytes(b"1,2,3,4\n5,6,\xe9,8\n")
    with pytest.raises(DatasetFormatError, match=r":2: byte 4 of the line"):
        read_boxes(gt)


def test_a_16_bit_frame_is_scaled_not_clipped(tmp_path):
    from PIL import Image

    seq = tmp_path / "seq"
    (seq / "img").mkdir(parents=True)
    ramp = (np.arange(64, dtype=np.uint16).reshape(8, 8) * 1000).astype(np.uint16)
    image = Image.fromarray(ramp)
    assert image.mode.startswith("I;16")
    image.save(seq / "img" / "0001.png")
    (seq / "groundtruth_rect.txt").write_text("1,1,4,4\n")
    frame = load_otb(seq).frame(0)
    assert frame.shape == (8, 8, 3) and frame.dtype == np.uint8
    np.testing.assert_array_equal(frame[:, :, 0], (ramp >> 8).astype(np.uint8))
    assert len(np.unique(frame)) > 10  # not all 255


def test_load_otb_with_more_images_than_boxes_uses_the_boxes_and_warns(tmp_path):
    """OTB's Football1 has 74 boxes for 75 images."""
    from PIL import Image

    seq = tmp_path / "Football1"
    (seq / "img").mkdir(parents=True)
    for k in range(5):
        Image.fromarray(np.full((8, 8, 3), k, np.uint8)).save(seq / "img" / f"{k + 1:04d}.jpg")
    (seq / "groundtruth_rect.txt").write_text("1,1,4,4\n2,3,4,4\n3,3,4,4\n4,3,4,4\n")
    with pytest.warns(UserWarning, match="5 images but 4 boxes"):
        loaded = load_otb(seq)
    assert len(loaded) == 4 and loaded.boxes.shape == (4, 4)
    assert [p.name for p in loaded.frame_paths] == [f"{k:04d}.jpg" for k in range(1, 5)]
    (seq / "img" / "0005.jpg").unlink()
    (seq / "img" / "0004.jpg").unlink()
    with pytest.raises(DatasetFormatError, match="4 boxes for 3 frames"):
        load_otb(seq)
    # The docstring states the conversion the test of Girl's first box checks.
    assert "1-based" in (load_otb.__doc__ or "") and "0-based" in (load_otb.__doc__ or "")


def test_binary_input_is_refused_at_once_naming_the_file(tmp_path):
    # Issue 38: a 2 GB binary file was read for 26 s before a MemoryError. Only its
    # first bytes are read now: a 200 MB sparse file (no disk used) is refused fast.
    import gzip
    import time

    from rperc.datasets import load_carmen
    from rperc.datasets._table import read_table

    big = tmp_path / "big.bin"
    with big.open("wb") as f:
        f.write(b"FLASER 3\n\x00\x01")
        f.truncate(200 << 20)
    for reader in (load_carmen, lambda p: read_table(p, 4)):
        started = time.monotonic()
        with pytest.raises(DatasetFormatError, match=r"big\.bin:2: not a text file"):
            reader(big)
        assert time.monotonic() - started < 2.0  # reading it all takes far longer
    zipped = tmp_path / "bin.gz"
    zipped.write_bytes(gzip.compress(b"\x00" * 100))
    with pytest.raises(DatasetFormatError, match=r"bin\.gz:1: not a text file"):
        load_carmen(zipped)


@pytest.mark.parametrize("kind", ["token", "columns", "record type"])
def test_errors_quote_at_most_about_80_characters_of_a_huge_line(tmp_path, kind):
    # Issue 38: errors embedded 20-50 MB input lines in their message.
    from rperc.datasets import load_carmen
    from rperc.datasets._table import read_table

    path = tmp_path / "huge.dat"
    huge = "7" * 5_000_000
    if kind == "token":
        path.write_text(f"1 2 3 {huge}x\n")
        call = lambda: read_table(path, 4)  # noqa: E731
    elif kind == "columns":
        path.write_text(" ".join(["1"] * 1_000_000) + "\n")
        call = lambda: read_table(path, 4)  # noqa: E731
    else:
        path.write_text(f"FLASER{huge} 1 2\n")
        call = lambda: load_carmen(path, strict=True)  # noqa: E731
    with pytest.raises(DatasetFormatError, match=r"huge\.dat:1: ") as info:
        call()
    assert len(str(info.value)) < 200 + len(str(path)), str(info.value)[:300]
    assert "more characters" in str(info.value)


@pytest.mark.parametrize("line", ["1 2 3 " + "4" * 5_000_000 + "x", "1,2," * 1_000_000])
def test_otb_ground_truth_errors_quote_a_huge_line_briefly(tmp_path, line):
    # The Rust reader's messages quoted whole lines ({:?}); now at most 80 characters.
    from rperc.datasets.otb import read_boxes

    path = tmp_path / "groundtruth_rect.txt"
    path.write_text("1 2 3 4\n" + line + "\n")
    with pytest.raises(DatasetFormatError, match=r"groundtruth_rect\.txt:2: ") as info:
        read_boxes(path)
    assert len(str(info.value)) < 200 + len(str(path)) and "more characters" in str(info.value)


def _mrclam_folder(folder, barcode: str = "107", sx: str = "0.1", odometry_v: str = "0.1"):
    """A minimal MR.CLAM folder (robot 1, landmarks 6 and 7) with three values set."""
    files = {
        "Robot1_Odometry.dat": f"# t v w\n10 {odometry_v} 0\n11 0.2 0\n",
        "Robot1_Measurement.dat": f"# t code r b\n10.5 106 1.5 0.2\n11.5 {barcode} 2.5 0.1\n",
        "Robot1_Groundtruth.dat": "# t x y th\n10 1 2 0.5\n",
        "Landmark_Groundtruth.dat": f"# id x y sx sy\n6 1 1 {sx} 0.1\n7 2 3 0.2 0.2\n",
        "Barcodes.dat": "".join(f"{s} {100 + s}\n" for s in range(1, 8)),
    }
    for name, text in files.items():
        (folder / name).write_text(text)
    return folder


def test_mrclam_ids_are_exact_up_to_2_to_the_53(tmp_path):
    from rperc.datasets import load_mrclam

    # 2^53 is the last integer float64 holds exactly: read as written.
    run = load_mrclam(_mrclam_folder(tmp_path, barcode="9007199254740992"))
    assert run.unknown_barcode_values == (2**53,)
    # One past it reads as 2^53 (another barcode), 1e20 overflowed int64: refused.
    for code in ("9007199254740993", "1e20", "-3", "106.5"):
        _mrclam_folder(tmp_path, barcode=code)
        with pytest.raises(DatasetFormatError, match=r"barcode .* is not a whole number") as info:
            load_mrclam(tmp_path)
        assert info.value.line == 3 and info.value.path.endswith("Robot1_Measurement.dat")


@pytest.mark.parametrize(
    ("field", "value", "file", "message"),
    [
        ("sx", "-0.1", "Landmark_Groundtruth.dat", "sx .* must be >= 0"),
        ("sx", "inf", "Landmark_Groundtruth.dat", "infinite"),
        ("odometry_v", "-inf", "Robot1_Odometry.dat", "infinite"),
    ],
)
def test_mrclam_refuses_meaningless_values(tmp_path, field, value, file, message):
    from rperc.datasets import load_mrclam

    _mrclam_folder(tmp_path, **{field: value})
    with pytest.raises(DatasetFormatError, match=message) as info:
        load_mrclam(tmp_path)
    assert info.value.line == 2 and info.value.path.endswith(file)


def test_otb_box_corners_beyond_the_coordinate_range_are_refused(tmp_path):
    path = tmp_path / "groundtruth_rect.txt"
    path.write_text("1 2 3 4\n1e300 2 3 4\n")
    with pytest.raises(DatasetFormatError, match="within") as info:
        read_boxes(path)
    assert info.value.line == 2


@pytest.mark.parametrize(
    ("name", "text", "line"),
    [
        ("a.csv", "x,y\n0,0\nnan,1\n", 3),
        ("a.wkt", "LINESTRING (0 0, 1 1)\nLINESTRING (0 0, nan 1)\n", 2),
        ("a.geojson", '{"type": "LineString", "coordinates": [[0, 0], [NaN, 1]]}', 1),
        ("a.wkt", "LINESTRING (0 0, 1 1)\nCIRCULARSTRING (0 0, 1 1, 2 0)\n", 2),
        (
            "a.geojson",
            '{"type": "LineString", "coordinates": ' + "[" * 100_000 + "]" * 100_000 + "}",
            1,
        ),
        ("a.geojson", '{"type": "LineString", "coordinates": ' + "[" * 200 + "]" * 200 + "}", 1),
    ],
    ids=[
        "csv nan",
        "wkt nan",
        "geojson nan",
        "circularstring",
        "json 100000 deep",
        "json 200 deep",
    ],
)
def test_polyline_files_refuse_what_has_no_place(tmp_path, name, text, line):
    # Issue 38: NaN vertices were read as points; CIRCULARSTRING escaped as shapely's
    # NotImplementedError and deep GeoJSON as a RecursionError, neither naming the file.
    if not name.endswith(".csv"):
        pytest.importorskip("shapely")
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(DatasetFormatError) as info:
        read_polylines(path)
    assert info.value.line == line and len(str(info.value)) < 400
