"""The CARMEN reader: every record type, PARAM use, and every way a line can be bad
(an error naming file and line, or with ``on_error="skip"`` a listed, counted skip).
Oracles are written out by hand or parsed independently with numpy."""

from __future__ import annotations

import gzip
import math

import numpy as np
import pytest
from hypothesis import example, given
from hypothesis import strategies as st

from rperc import _rperc
from rperc.datasets import DatasetFormatError, TimestampRepairWarning, load_carmen

ODOM = "ODOM {x} {y} {th} 0 0 0 {t} host {t}\n"


def flaser(ranges: list[str], pose: str = "0.5 0.25 0.1", t: float = 12.5) -> str:
    return f"FLASER {len(ranges)} {' '.join(ranges)} {pose} {pose} {t} host {t}\n"


def load_repaired(path, repaired: int):
    """``load_carmen(path)``, expecting exactly ``repaired`` scan times to be repaired:
    one TimestampRepairWarning naming the file and the count when there are some, no
    warning at all otherwise (pytest turns any warning into an error)."""
    if not repaired:
        log = load_carmen(path)
    else:
        with pytest.warns(TimestampRepairWarning) as caught:
            log = load_carmen(path)
        assert len(caught) == 1
        message = str(caught[0].message)
        assert message.startswith(f"{path}: {repaired} of {len(log.scans)} scan times")
    assert log.times_repaired == repaired
    return log


@pytest.mark.parametrize(("name", "repaired"), [("intel.log", 4), ("aces.log", 0)])
def test_real_logs_round_trip(data, tmp_path, name, repaired):
    """Every FLASER and ODOM line of the real logs, parsed independently by numpy,
    equals what the reader returns (the scan times as written in ``timestamp_raw``;
    intel.log's four steps back repaired in ``timestamp``); written back as gzip, the
    log reads the same."""
    path = data / "carmen" / name
    text = path.read_text().splitlines()
    log = load_repaired(path, repaired)
    flines = [line.split() for line in text if line.startswith("FLASER ")]
    oracle = np.array([[float(v) for v in tok[2:-2]] for tok in flines])
    np.testing.assert_array_equal(log.scans.ranges, oracle[:, :180])
    np.testing.assert_array_equal(log.scans.pose, oracle[:, 180:183])
    np.testing.assert_array_equal(log.scans.timestamp_raw, oracle[:, 186])
    same = log.scans.timestamp == oracle[:, 186]
    assert np.count_nonzero(~same) == repaired and np.all(np.diff(log.scans.timestamp) > 0)
    odom = np.array([[float(v) for v in line.split()[1:8]] for line in text if line[:5] == "ODOM "])
    np.testing.assert_array_equal(log.odometry.pose, odom[:, :3])
    assert log.errors == () and log.scans_without_pose == 0
    assert int(log.scans.invalid.sum()) == 0 and set(log.scans.kind) == {"FLASER"}
    params = [line.split() for line in text if line.startswith("PARAM ")]
    assert log.params == {tok[1]: tok[2] for tok in params}
    summary = log.summary()
    for count in (f"{len(flines)} scans ({len(flines)} FLASER)", f"{len(odom)} odometry"):
        assert count in summary
    assert f"{len(params)} PARAM read" in summary and "0 malformed lines skipped" in summary
    # Round trip through gzip, whatever the suffix.
    gz = tmp_path / "copy.log"
    gz.write_bytes(gzip.compress(path.read_bytes()))
    again = load_repaired(gz, repaired)
    np.testing.assert_array_equal(again.scans.ranges, log.scans.ranges)
    np.testing.assert_array_equal(again.scans.pose, log.scans.pose)
    assert again.skipped == log.skipped and again.params == log.params


def test_truncated_last_line_raises_or_is_skipped(tmp_path):
    good = flaser(["1.0", "2.0", "3.0"])
    path = tmp_path / "t.log"
    path.write_text(good + ODOM.format(x=0, y=0, th=0, t=1) + good[:25])  # no newline
    with pytest.raises(DatasetFormatError, match=r"t\.log:3: FLASER with 3 beams") as info:
        load_carmen(path)
    assert info.value.line == 3
    log = load_carmen(path, on_error="skip")
    assert len(log.scans) == 1 and len(log.odometry) == 1
    assert [e.line for e in log.errors] == [3] and "needs 14 fields" in log.errors[0].reason
    assert "1 malformed lines skipped (first at line 3" in log.summary()


def test_bad_ranges_become_counted_invalid_readings(tmp_path):
    path = tmp_path / "r.log"
    path.write_text(flaser(["1.0", "nan", "-0.5", "inf", "2.0"]) + flaser(["1", "2", "3"], t=13))
    scans = load_carmen(path).scans
    row = scans.ranges[0]
    assert row[0] == 1.0 and row[4] == 2.0 and np.isnan(row[1:4]).all()
    assert scans.invalid.tolist() == [3, 0]
    assert "3 invalid readings (NaN, inf or negative) in 1 scans" in load_carmen(path).summary()


@pytest.mark.parametrize("pose", ["nan 0 0", "0 inf 0", "0 0 -nan"])
def test_nan_poses_are_errors_with_line(tmp_path, pose):
    path = tmp_path / "p.log"
    path.write_text(flaser(["1", "2"]) + flaser(["1", "2"], pose=pose))
    with pytest.raises(DatasetFormatError, match=r"p\.log:2: pose not finite"):
        load_carmen(path)
    log = load_carmen(path, on_error="skip")
    assert len(log.scans) == 1 and log.errors[0].line == 2
    path.write_text("ODOM nan 0 0 0 0 0 1 host 1\n")
    with pytest.raises(DatasetFormatError, match=r"p\.log:1: pose not finite"):
        load_carmen(path)


def test_bad_odom_lines_are_reported_in_file_order(tmp_path):
    """ODOM lines are read as numbers once the file is read (a batch); their errors
    still come in file order: the first bad line of any kind raises, and a skip lists
    every bad line by line number, the good ODOM rows kept in order."""
    path = tmp_path / "o.log"
    path.write_text(
        ODOM.format(x=0, y=0, th=0, t=1)
        + ODOM.format(x="1.5e", y=0, th=0, t=2)  # line 2: not a number
        + flaser(["1", "2"])
        + flaser(["1", "2"], pose="0 nan 0")  # line 4: a pose that is not finite
        + ODOM.format(x=0, y="inf", th=0, t=5)  # line 5: a pose that is not finite
        + ODOM.format(x=3, y=4, th=0.5, t=6)
    )
    with pytest.raises(DatasetFormatError, match=r"o\.log:2: ODOM values: not a number: '1\.5e'"):
        load_carmen(path)
    log = load_carmen(path, on_error="skip")
    assert [e.line for e in log.errors] == [2, 4, 5]
    assert "pose not finite" in log.errors[2].reason
    assert log.odometry.pose.tolist() == [[0.0, 0.0, 0.0], [3.0, 4.0, 0.5]]
    assert log.odometry.timestamp.tolist() == [1.0, 6.0]
    # With only the late ODOM line bad, the error names it, after the scans read.
    path.write_text(flaser(["1", "2"]) + ODOM.format(x=0, y="inf", th=0, t=5))
    with pytest.raises(DatasetFormatError, match=r"o\.log:2: pose not finite"):
        load_carmen(path)


def test_non_utf8_line_is_reported_or_skipped(tmp_path):
    path = tmp_path / "u.log"
    path.write_bytes(
        b"\xef\xbb\xbf"
        + flaser(["1", "2"]).encode()
        + b"NEFF \xe9 2\n"
        + flaser(["3"], t=13).encode()
    )
    with pytest.raises(DatasetFormatError, match=r"u\.log:2: byte 5 of the line \(0xe9\)"):
        load_carmen(path)
    log = load_carmen(path, on_error="skip")
    assert len(log.scans) == 2 and log.scans.line.tolist() == [1, 3]  # BOM did not hide line 1
    assert log.errors[0].line == 2 and "0xe9" in log.errors[0].reason


def test_param_lines_set_max_range_fov_and_resolution(tmp_path):
    path = tmp_path / "param.log"
    path.write_text(
        flaser(["1"] * 180, t=1)
        + "PARAM robot_front_laser_max 50.0 nohost 0\n"
        + "PARAM laser_front_laser_fov 100 nohost 0\n"
        + flaser(["1"] * 101, t=2)
        + "PARAM laser_front_laser_resolution 0.5 nohost 0\n"
        + flaser(["1"] * 201, t=3)
        + "RLASER 3 1 2 3 0 0 0 0 0 0 4 h 4\n"
    )
    log = load_carmen(path)
    s = log.scans
    # Before any PARAM: 180 beams over 180 degrees from -90, 81.83 m.
    assert s.angle_min[0] == pytest.approx(-math.pi / 2)
    assert s.angle_increment[0] == pytest.approx(math.radians(1.0))
    assert s.max_range[0] == 81.83
    # fov 100 degrees, 101 beams (odd: both ends), 50 m.
    assert s.angles(1)[[0, -1]] == pytest.approx(np.radians([-50.0, 50.0]))
    assert s.max_range[1] == 50.0
    # The resolution, when given, is the step.
    assert s.angles(2)[[0, -1]] == pytest.approx(np.radians([-50.0, 50.0]))
    # The rear laser has its own parameters: none given, so the FLASER defaults.
    assert s.kind.tolist() == ["FLASER"] * 3 + ["RLASER"] and s.max_range[3] == 81.83
    assert log.skipped == {"PARAM": 3} and log.params["laser_front_laser_fov"] == "100"
    assert "3 PARAM read (first at line 2)" in log.summary()


def test_no_return_marker_is_inferred_without_a_max_range_param(tmp_path):
    """Without a max-range PARAM, a value that many readings share exactly at the top
    of the range is the scanner's no-return marker: it becomes the scans' max range
    (so those readings are invalid for the wall extractor); a log with far readings
    spread over distinct values keeps the SICK default; a PARAM wins over both."""
    from rperc.datasets.carmen import FLASER_MAX_RANGE, infer_no_return

    rng = np.random.default_rng(3)
    spread = [f"{v:.2f}" for v in rng.uniform(0.5, 29.0, 4000)]
    lines = "".join(flaser(spread[k : k + 40] + ["30.00"] * 5, t=k) for k in range(0, 4000, 40))
    path = tmp_path / "marker.log"
    path.write_text(lines)
    log = load_carmen(path)
    assert np.all(log.scans.max_range == 30.0)
    assert log.no_return == {"FLASER": (30.0, 500)}
    assert "FLASER no-return marker 30 m inferred (500 readings" in log.summary()
    # The marker's readings are beyond range for the extractor: no phantom wall at 30 m.
    from rperc.linesimp import extract_lines

    walls = extract_lines(log.scans.ranges[0], log.scans.angles(0), max_range=30.0)
    assert not np.isin(walls.flat_indices, np.arange(40, 45)).any()
    # Far readings all distinct: no marker, the default.
    path.write_text("".join(flaser(spread[k : k + 45], t=k) for k in range(0, 3960, 45)))
    log = load_carmen(path)
    assert log.no_return == {} and np.all(log.scans.max_range == FLASER_MAX_RANGE)
    # A few repeats of the largest value (a wall seen twice) are not a marker.
    assert infer_no_return(np.r_[np.linspace(1.0, 9.0, 1000), [9.5] * 3]) is None
    # Nor is one value repeated everywhere.
    assert infer_no_return(np.ones(500)) is None
    # A max-range PARAM wins.
    path.write_text("PARAM robot_front_laser_max 40.0 nohost 0\n" + lines)
    log = load_carmen(path)
    assert log.no_return == {} and np.all(log.scans.max_range == 40.0)


def test_aces_no_return_marker(data):
    """The ACES log has no max-range PARAM and writes "no return" as 50.0 m: counted
    independently, every reading of exactly 50.0 is the marker."""
    path = data / "carmen" / "aces.log"
    readings = [
        float(v)
        for line in path.read_text().splitlines()
        if line.startswith("FLASER ")
        for v in line.split()[2:182]
    ]
    log = load_carmen(path)
    assert log.no_return == {"FLASER": (50.0, readings.count(50.0))}
    assert np.all(log.scans.max_range == 50.0)


def test_rawlaser1_gets_the_interpolated_odometry_pose(tmp_path):
    path = tmp_path / "raw.log"
    raw = "RAWLASER1 0 -1.5 3.0 1.5 20.0 0.01 0 3 1.0 -2.0 3.0 1 7 {t} host {t}\n"
    path.write_text(
        ODOM.format(x=0, y=0, th=3.0, t=10)
        + raw.format(t=10.25)
        + ODOM.format(x=2, y=4, th=-3.0, t=11)
        + raw.format(t=12)  # after the last odometry: no pose
    )
    log = load_carmen(path)
    s = log.scans
    np.testing.assert_array_equal(s.ranges[0], [1.0, np.nan, 3.0])
    assert s.invalid.tolist() == [1, 1] and s.max_range[0] == 20.0
    np.testing.assert_allclose(s.angles(0), [-1.5, 0.0, 1.5])
    # A quarter of the way, heading along the short arc through pi: 3 + (2 pi - 6) / 4.
    heading = 3.0 + (2 * math.pi - 6.0) / 4
    np.testing.assert_allclose(s.pose[0], [0.5, 1.0, heading])
    assert np.isnan(s.pose[1]).all() and log.scans_without_pose == 1
    assert "1 RAWLASER1 scans without a pose" in log.summary()
    path.write_text("RAWLASER1 0 -1.5 3.0 1.5 20.0 0.01 0 3 1.0 2.0 3.0 2 7 10 host 10\n")
    with pytest.raises(DatasetFormatError, match=r"raw\.log:1: RAWLASER1 with 3 beams"):
        load_carmen(path)


def test_on_error_is_checked(tmp_path):
    path = tmp_path / "a.log"
    path.write_text(flaser(["1"]))
    with pytest.raises(ValueError, match="on_error"):
        load_carmen(path, on_error="ignore")  # type: ignore[arg-type]


# ------------------------------------------------- scan times that do not increase


@pytest.mark.parametrize(
    ("name", "repaired"),
    [("orebro.log.gz", 236), ("intel.log", 4), ("infinite-corridor.log.gz", 1939)],
)
def test_real_logs_get_strictly_increasing_scan_times(data, name, repaired):
    """orebro stamps every scan 0, the infinite corridor steps back three times and
    then repeats one value 1,937 times, intel steps back four times: read, every log
    keeps one time per scan, in log order, strictly increasing, with one warning that
    names the file and the count; the times that were consistent are kept, and the
    file's own times stay in ``timestamp_raw``."""
    path = data / "carmen" / name
    log = load_repaired(path, repaired)
    with gzip.open(path, "rt") if path.suffix == ".gz" else path.open() as f:
        written = [float(line.split()[-3]) for line in f if line.startswith("FLASER ")]
    t, raw = log.scans.timestamp, log.scans.timestamp_raw
    assert len(t) == len(written) == len(log.scans) and np.all(np.diff(t) > 0)
    np.testing.assert_array_equal(raw, written)
    assert np.count_nonzero(t != raw) == repaired
    assert f"{repaired} scan times repaired to increase strictly (first at line" in log.summary()


def test_repeated_and_backward_times_are_spread_between_their_neighbours(tmp_path):
    """A synthetic log: a run of repeats and a step back are spread evenly between the
    neighbouring kept times, the last repeats continue at the median step; the lines of
    the scans and the warning say where."""
    path = tmp_path / "times.log"
    times = [5.0, 5.0, 5.0, 8.0, 7.5, 10.0, 10.0]
    path.write_text(ODOM.format(x=0, y=0, th=0, t=4) + "".join(flaser(["1"], t=t) for t in times))
    with pytest.warns(TimestampRepairWarning, match=r"times\.log: 4 of 7 scan times .*line 3\)"):
        log = load_carmen(path)
    np.testing.assert_array_equal(log.scans.timestamp, [5, 6, 7, 8, 9, 10, 11])
    np.testing.assert_array_equal(log.scans.timestamp_raw, times)
    assert log.times_repaired == 4 and log.scans.line.tolist() == list(range(2, 9))
    assert "4 scan times repaired to increase strictly (first at line 3)" in log.summary()
    np.testing.assert_array_equal(log.odometry.timestamp, [4.0])  # odometry as written


def test_increasing_times_are_kept_without_a_warning(tmp_path):
    path = tmp_path / "fine.log"
    path.write_text("".join(flaser(["1"], t=t) for t in (1.0, 1.5, 3.0)))
    log = load_carmen(path)  # any warning would fail the test
    assert log.times_repaired == 0 and "repaired" not in log.summary()
    assert log.scans.timestamp_raw is log.scans.timestamp


def test_times_that_cannot_be_repaired_name_the_line(tmp_path):
    """Times at the top of the float range leave no room to increase: an error naming
    the scan's line, not a silent infinity."""
    path = tmp_path / "huge.log"
    path.write_text("# log\n" + flaser(["1"], t=1.7976931348623157e308) * 2)
    with pytest.raises(DatasetFormatError, match=r"huge\.log:3: t\[1\] cannot be given"):
        load_carmen(path)


ROBOTLASER = (
    "ROBOTLASER1 0 -1.5 {fov} {res} {max_range} 0.01 0 3 1.0 2.0 3.0 0 "
    "0 0 0 0 0 0 0 0 0 0 0 10 host 10\n"
)


@pytest.mark.parametrize(
    ("name", "value"),
    [
        ("laser_front_laser_resolution", "0"),
        ("laser_front_laser_resolution", "nan"),
        ("laser_rear_laser_resolution", "-1"),
        ("robot_front_laser_max", "-5"),
        ("robot_rear_laser_max", "inf"),
        ("laser_front_laser_fov", "0"),
        ("laser_front_laser_fov", "400"),
        ("laser_front_laser_fov", "wide"),
    ],
)
def test_bad_laser_params_are_refused_at_their_line(tmp_path, name, value):
    # Issue 38: a resolution of 0 or NaN and a negative maximum range were accepted and
    # used for every scan after them; a value that did not parse was silently replaced.
    path = tmp_path / "param.log"
    path.write_text(
        flaser(["1"] * 3, t=1) + f"PARAM {name} {value} nohost 0\n" + flaser(["1"] * 3, t=2)
    )
    with pytest.raises(DatasetFormatError, match=rf"param\.log:2: .*{name}"):
        load_carmen(path)
    # Skipped, the PARAM is left out: the later scan keeps the defaults.
    log = load_carmen(path, on_error="skip")
    assert [e.line for e in log.errors] == [2] and name not in log.params
    assert log.scans.max_range[1] == log.scans.max_range[0]
    assert log.scans.angle_increment[1] == log.scans.angle_increment[0]


@pytest.mark.parametrize(
    ("fov", "res", "max_range", "field"),
    [
        ("0", "0", "20", "fov"),
        ("3.0", "0", "20", "resolution"),
        ("3.0", "-0.1", "20", "resolution"),
        ("3.0", "1.5", "-20", "max range"),
        ("3.0", "1.5", "0", "max range"),
        ("7.0", "1.5", "20", "fov"),
    ],
)
def test_a_robotlaser1_without_a_real_geometry_is_refused(tmp_path, fov, res, max_range, field):
    # Issue 38: a ROBOTLASER1 with resolution and field of view 0 was read as scans.
    path = tmp_path / "robot.log"
    path.write_text(ROBOTLASER.format(fov=fov, res=res, max_range=max_range))
    with pytest.raises(DatasetFormatError, match=rf"robot\.log:1: ROBOTLASER1 {field} is"):
        load_carmen(path)
    path.write_text(ROBOTLASER.format(fov="3.0", res="1.5", max_range="20"))
    assert load_carmen(path).scans.angle_increment.tolist() == [1.5]


def test_a_robotlaser1_with_a_field_too_few_is_refused_with_its_counts(tmp_path):
    # ROBOTLASER1 and RAWLASER1 share the check (the RAWLASER1 test has its own).
    path = tmp_path / "robot.log"
    line = ROBOTLASER.format(fov="3.0", res="1.5", max_range="20").rsplit(" ", 1)[0]
    path.write_text(line + "\n")
    with pytest.raises(
        DatasetFormatError,
        match=r"robot\.log:1: ROBOTLASER1 with 3 beams and 0 remissions needs 27 fields, got 26",
    ):
        load_carmen(path)


@pytest.mark.parametrize(
    ("lines", "kind"),
    [
        ("PARAM laser_front_laser_resolution 181 nohost 0\n" + "FLASER 3 1 2 3 0 0 0 0 0 0 1 h 1\n",
         "FLASER"),
        ("ROBOTLASER1 0 -1.5 6.2 3.2 80 0.01 0 3 1.0 2.0 3.0 0 "
         "0 0 0 0 0 0 0 0 0 0 0 10 host 10\n", "ROBOTLASER1"),
    ],
)  # fmt: skip
def test_beams_that_sweep_past_a_turn_are_refused_by_line(tmp_path, lines, kind):
    """A resolution (from a PARAM or the line) that puts three beams 181 or 183
    degrees apart sweeps them past 360: two would share a direction (fuzz found it)."""
    path = tmp_path / "turn.log"
    path.write_text(lines)
    with pytest.raises(DatasetFormatError, match=rf"turn.log:{lines.count(chr(10))}: {kind}.*turn"):
        load_carmen(path)


_DECIMAL = st.from_regex(r"\A[+-]?(\d{1,20}(\.\d{0,20})?|\.\d{1,20})([eE][+-]?\d{1,4})?\Z")
_TOKEN = st.one_of(
    _DECIMAL,
    st.sampled_from(["inf", "-Infinity", "nan", "+NaN", "1_0", "\u0661", "0x1", "1e", ".", ""]),
    st.text(max_size=6),
)


@given(st.lists(_TOKEN, max_size=8))
def test_the_fast_number_reader_reads_what_float_reads(tokens):
    """The readings go through Rust's number parser first (a scan line holds hundreds).
    Whatever it reads, Python's float() reads to the same value; what it refuses goes to
    float(), so the reader accepts exactly what float() accepts."""
    fast = _rperc.parse_floats(tokens)
    if fast is None:
        return
    expected = [float(t) for t in tokens]  # raises if Rust read something float() refuses
    np.testing.assert_array_equal(fast, np.array(expected, dtype=np.float64))


def test_readings_float_alone_reads_take_the_slow_path(tmp_path):
    """A reading only float() reads (a digit separator) is read as float() reads it, and
    a bad one is still named."""
    path = tmp_path / "sep.log"
    path.write_text(flaser(["1_0", "2.5", "3"]))
    np.testing.assert_array_equal(load_carmen(path).scans.ranges[0], [10.0, 2.5, 3.0])
    path.write_text(flaser(["1", "2.5x", "3"]))
    with pytest.raises(DatasetFormatError, match=r"sep.log:1: ranges: not a number: '2.5x'"):
        load_carmen(path)


_FIELD = st.one_of(_TOKEN, st.sampled_from(["FLASER", "host", "0.5", "-3e2"]))
_GAP = st.sampled_from([" ", "  ", "\t", " \t ", "\u2003", "\u00a0", "\x0b", "\x1c"])


@given(st.lists(st.tuples(_FIELD, _GAP), max_size=10), st.integers(0, 4), st.integers(0, 6))
@example([("1", " "), ("2", "\x1c"), ("3", " ")], 0, 1)  # Python splits at \x1c, Rust did not
@example([("1", "\x0b"), ("2", " ")], 1, 1)
def test_the_line_reader_reads_what_split_and_float_read(parts, first, count):
    """Scan and ODOM lines are read by Rust without Python's split. Whatever it reads,
    ``str.split`` and ``float()`` (the oracle) read alike: the same field count and the
    same numbers; anything else it refuses, and the reader then splits the line."""
    line = "".join(token + gap for token, gap in parts)
    fast = _rperc.parse_line_floats(line, first, count)
    batch = _rperc.parse_lines_floats([line, line], first, count)
    if fast is None:
        assert batch is None
        return
    fields = line.split()
    assert fast[0] == len(fields)
    expected = [float(t) for t in fields[first : first + count]]  # raises if Rust read more
    np.testing.assert_array_equal(fast[1], np.array(expected, dtype=np.float64))
    assert batch is not None
    np.testing.assert_array_equal(batch[0], [len(fields)] * 2)
    np.testing.assert_array_equal(batch[1], np.array([expected] * 2).reshape(2, count))


def test_lines_read_by_rust_and_by_split_give_the_same_log(tmp_path):
    """The same log twice: once with plain spaces (its FLASER and ODOM lines read in
    Rust), once with a non-ASCII space in every line (each split in Python, the
    reader's checked path): every array of the two logs is equal, invalid readings
    and skipped lines included."""
    lines = ["PARAM robot_front_laser_max 50.0\n"]
    for k in range(30):
        lines.append(ODOM.format(x=0.1 * k, y=0.0, th=0.01 * k, t=10.0 + k))
        ranges = [f"{1.0 + 0.01 * (k + b)}" for b in range(7)] + ["nan", "-1"]
        lines.append(flaser(ranges, pose=f"{0.1 * k} 0.2 0.03", t=10.5 + k))
    lines.append("ODOM 1 2 3\n")  # truncated: skipped with its line
    plain = tmp_path / "plain.log"
    plain.write_text("".join(lines))
    spaced = tmp_path / "spaced.log"
    spaced.write_text("".join(line.replace(" ", "\u2003", 1) for line in lines))
    a = load_carmen(plain, on_error="skip")
    b = load_carmen(spaced, on_error="skip")
    assert a.errors == b.errors and [e.line for e in a.errors] == [62]
    names = ("ranges", "num_beams", "invalid", "max_range", "pose", "odom", "timestamp", "line")
    for name in names:
        np.testing.assert_array_equal(getattr(a.scans, name), getattr(b.scans, name), err_msg=name)
    np.testing.assert_array_equal(a.odometry.pose, b.odometry.pose)
    assert a.scans.invalid.tolist() == [2] * 30


def test_a_beam_count_too_large_to_read_is_named_in_file_order(tmp_path):
    """A beam count no line could hold (past 64 bits, or past Python's digit limit for
    int()) is the checked path's: a DatasetFormatError naming the line, skipped on
    request, and a bad ODOM line before it is still reported first."""
    huge = "18446744073709551615"
    path = tmp_path / "huge.log"
    path.write_text(f"FLASER {huge} 1 2 3 1 2 0 0 0 0 1 h 2\n")
    with pytest.raises(DatasetFormatError, match=rf"huge.log:1: FLASER with {huge} beams"):
        load_carmen(path)
    assert [e.line for e in load_carmen(path, on_error="skip").errors] == [1]
    path.write_text("RLASER " + "9" * 5000 + " 1 2 3\n")
    with pytest.raises(DatasetFormatError, match=r"huge.log:1: RLASER without a beam count"):
        load_carmen(path)
    path.write_text(f"ODOM 1 2 3\nFLASER {huge} 1 2 3 1 2 0 0 0 0 1 h 2\n")
    with pytest.raises(DatasetFormatError, match=r"huge.log:1: ODOM needs 10 fields, got 4"):
        load_carmen(path)
    assert [e.line for e in load_carmen(path, on_error="skip").errors] == [1, 2]


def _continuum_lines(param: str, far: list[str], t0: int = 0) -> list[str]:
    """A max-range PARAM, then 100 FLASER lines: near readings and ``far`` ones spread
    over the scans."""
    rng = np.random.default_rng(5 + t0)
    near = [f"{v:.2f}" for v in rng.uniform(0.5, 9.5, 4000)]
    lines = [f"PARAM robot_front_laser_max {param} nohost 0\n"]
    for k in range(100):
        lines.append(flaser(near[40 * k : 40 * k + 40] + far[5 * k : 5 * k + 5], t=t0 + k))
    return lines


def _continuum_log(path, param: str, far: list[str]) -> None:
    path.write_text("".join(_continuum_lines(param, far)))


def test_a_max_range_param_the_readings_contradict_is_set_aside(tmp_path):
    """Edmonton's case: a PARAM of 10 m under walls seen 11-40 m away (a continuum of
    distinct values) is CARMEN's robot setting, not the scanner's reach: it is set
    aside with a MaxRangeWarning and counted, the range inferred as without a PARAM
    (here the SICK default); max_range="param" keeps it."""
    from rperc.datasets import MaxRangeWarning
    from rperc.datasets.carmen import FLASER_MAX_RANGE

    far = [f"{v:.2f}" for v in np.random.default_rng(6).uniform(11.5, 40.0, 500)]
    path = tmp_path / "far.log"
    _continuum_log(path, "10", far)
    with pytest.warns(MaxRangeWarning, match=r"far\.log: FLASER's max-range PARAM 10 m"):
        log = load_carmen(path)
    assert np.all(log.scans.max_range == FLASER_MAX_RANGE)
    c = log.max_range_contradicted["FLASER"]
    values = np.array(far, dtype=float)
    assert (c.param, c.readings, c.distinct) == (10.0, 500, len(np.unique(values)))
    assert c.farthest == values.max()
    assert "FLASER max-range PARAM 10 m set aside (500 readings beyond it" in log.summary()
    kept = load_carmen(path, max_range="param")
    assert np.all(kept.scans.max_range == 10.0) and kept.max_range_contradicted == {}
    with pytest.raises(ValueError, match="max_range must be 'auto' or 'param'"):
        load_carmen(path, max_range="sensor")  # type: ignore[arg-type]


def test_each_param_value_is_judged_on_its_own_scans(tmp_path):
    """A PARAM that changes mid-log: the contradicted 10 m is set aside for its scans
    only, the honest 50 m stays for its own; infinite readings (invalid) are no
    evidence either way."""
    from rperc.datasets import MaxRangeWarning

    far = [f"{v:.2f}" for v in np.random.default_rng(8).uniform(12.0, 30.0, 500)]
    honest = ["inf"] * 300 + [f"{v:.2f}" for v in np.random.default_rng(9).uniform(10, 40, 200)]
    path = tmp_path / "two.log"
    path.write_text("".join(_continuum_lines("10", far) + _continuum_lines("50", honest, 100)))
    with pytest.warns(MaxRangeWarning) as caught:
        log = load_carmen(path)
    assert len(caught) == 1 and "PARAM 10 m" in str(caught[0].message)
    assert log.max_range_contradicted["FLASER"].param == 10.0
    assert np.all(log.scans.max_range[100:] == 50.0)
    assert np.all(log.scans.max_range[:100] != 10.0)


def test_inf_readings_do_not_contradict_a_param(tmp_path):
    path = tmp_path / "inf.log"
    _continuum_log(path, "10", ["inf"] * 500)
    log = load_carmen(path)
    assert np.all(log.scans.max_range == 10.0) and log.max_range_contradicted == {}


def test_robotlaser1_keeps_its_own_max_range(tmp_path):
    """A ROBOTLASER1 line states its max range itself: no PARAM is involved, so none is
    set aside whatever its readings."""
    far = " ".join(f"{v:.2f}" for v in np.linspace(21.0, 40.0, 30))
    line = f"ROBOTLASER1 0 -1.5 3.0 0.1 20 0.01 0 30 {far} 0 0 0 0 0 0 0 0 0 0 0 0 10 host 10\n"
    path = tmp_path / "robot.log"
    path.write_text(line)
    log = load_carmen(path)
    assert log.scans.max_range[0] == 20.0 and log.max_range_contradicted == {}


def test_a_saturation_just_beyond_the_param_does_not_contradict_it(tmp_path):
    """The Freiburg logs' case: "no return" written as 81.91 m (with a few strays just
    below it) above a PARAM of 80.99 m lies within NO_RETURN_BAND of it: the PARAM
    stands, with no warning (pytest fails on any)."""
    far = ["81.91"] * 450 + [f"{81.4 + 0.01 * k:.2f}" for k in range(50)]
    path = tmp_path / "saturated.log"
    _continuum_log(path, "80.99", far)
    log = load_carmen(path)
    assert np.all(log.scans.max_range == 80.99) and log.max_range_contradicted == {}


def test_the_command_line_tells_a_param_set_aside(tmp_path, capsys):
    from rperc.cli.outputs import read_carmen_log

    far = [f"{v:.2f}" for v in np.random.default_rng(7).uniform(12.0, 30.0, 500)]
    path = tmp_path / "far.log"
    _continuum_log(path, "10", far)
    log = read_carmen_log(path)
    assert log.max_range_contradicted["FLASER"].readings == 500
    assert "note: far.log: FLASER's max-range PARAM 10 m set aside" in capsys.readouterr().err


def test_edmonton_max_range_param_is_set_aside(data):
    """Edmonton's PARAM says 10 m; counted independently from its FLASER lines, the
    readings more than 10 % beyond it are the ones that set it aside. Most are walls
    between 11 and 40 m (a continuum of distinct values); its no-return cluster near
    51.1 m has no single top value, so no marker is inferred and the SICK default
    holds, as on the acapulco, fhw and infinite-corridor logs (those readings are kept
    as points on all four)."""
    import gzip

    from rperc.datasets import MaxRangeWarning
    from rperc.datasets.carmen import FLASER_MAX_RANGE

    path = data / "carmen" / "edmonton.log.gz"
    with gzip.open(path, "rt") as f:
        rows = [line.split() for line in f if line.startswith("FLASER ")]
    readings = np.array([float(v) for r in rows for v in r[2 : 2 + int(r[1])]])
    beyond = readings[readings > 11.0]
    with pytest.warns(MaxRangeWarning, match="edmonton"):
        log = load_carmen(path)
    c = log.max_range_contradicted["FLASER"]
    assert (c.param, c.readings, c.distinct) == (10.0, len(beyond), len(np.unique(beyond)))
    walls = beyond[beyond < 40.0]
    assert len(walls) > 0.75 * len(beyond) and len(np.unique(walls)) > 500
    assert log.no_return == {} and np.all(log.scans.max_range == FLASER_MAX_RANGE)
