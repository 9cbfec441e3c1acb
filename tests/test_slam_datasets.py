"""MR.CLAM and Victoria Park readers: the real files against an independent reading
written here, malformed files written by the tests, and dead reckoning over the first
60 s of each run against its ground truth (Vicon) or GPS."""

from __future__ import annotations

import gzip
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from rperc.datasets import DatasetFormatError, load_mrclam, load_victoria_park
from rperc.datasets._table import read_table

MRCLAM_FILES = ("Odometry", "Measurement", "Groundtruth")


def data_lines(path: Path) -> list[list[str]]:
    """The independent reading: every non-comment, non-blank line split on whitespace."""
    out = []
    for text in path.read_text().splitlines():
        fields = text.split()
        if fields and not fields[0].startswith("#"):
            out.append(fields)
    return out


# ---------------------------------------------------------------- MR.CLAM, real data


@pytest.fixture(scope="module")
def mrclam_dir(data: Path) -> Path:
    folder = data / "mrclam6"
    if not folder.is_dir():
        pytest.skip(f"{folder} not found")
    return folder


def test_mrclam_counts_and_first_last_records(mrclam_dir: Path) -> None:
    run = load_mrclam(mrclam_dir, robot=1)
    odo = data_lines(mrclam_dir / "Robot1_Odometry.dat")
    truth = data_lines(mrclam_dir / "Robot1_Groundtruth.dat")
    assert len(run.odometry_t) == len(odo) and len(run.truth_t) == len(truth)
    for k in (0, -1):
        assert run.odometry_t[k] == float(odo[k][0])
        assert run.odometry_v[k] == float(odo[k][1])
        assert run.odometry_omega[k] == float(odo[k][2])
        assert (run.truth_x[k], run.truth_theta[k]) == (float(truth[k][1]), float(truth[k][3]))
    marks = data_lines(mrclam_dir / "Landmark_Groundtruth.dat")
    assert run.landmark_id.tolist() == [int(m[0]) for m in marks] == list(range(6, 21))
    assert run.landmark_sy[-1] == float(marks[-1][4])
    assert run.nan_rows == 0 and run.time_backwards == 0
    assert "robot 1" in repr(run) and "robot sightings" in repr(run)


def test_mrclam_measurement_column_holds_barcodes(mrclam_dir: Path) -> None:
    """The header says "Subject #" but the values are barcodes: 90, 81, 72, 63 ... are
    barcodes in Barcodes.dat and cannot be subjects (1..20)."""
    barcode_to_subject = {int(b): int(s) for s, b in data_lines(mrclam_dir / "Barcodes.dat")}
    meas = data_lines(mrclam_dir / "Robot1_Measurement.dat")
    column = [int(m[1]) for m in meas]
    assert max(column) > 20
    subjects = [barcode_to_subject.get(c) for c in column]
    robots = sum(1 for s in subjects if s is not None and s <= 5)
    unknown = sorted({c for c, s in zip(column, subjects, strict=True) if s is None})
    run = load_mrclam(mrclam_dir)
    assert run.robot_sightings == robots
    assert list(run.unknown_barcode_values) == [c for c in column if c not in barcode_to_subject]
    assert unknown == [43]  # one sighting of a barcode no subject wears
    kept = [(m, s) for m, s in zip(meas, subjects, strict=True) if s is not None and s > 5]
    assert len(run.measurement_t) + robots + run.unknown_barcodes == len(meas)
    assert run.measurement_landmark.tolist() == [s for _, s in kept]
    assert run.measurement_range[0] == float(kept[0][0][2])
    assert run.measurement_bearing[-1] == float(kept[-1][0][3])


def unicycle_steps(
    pose: np.ndarray, v: np.ndarray, omega: np.ndarray, dt: np.ndarray
) -> np.ndarray:
    """Exact arcs, written here as the oracle (the straight line for omega = 0)."""
    x, y, th = (float(p) for p in pose)
    for vk, wk, dk in zip(v, omega, dt, strict=True):
        if abs(wk * dk) < 1e-9:
            x, y = x + vk * dk * math.cos(th), y + vk * dk * math.sin(th)
        else:
            r = vk / wk
            x += r * (math.sin(th + wk * dk) - math.sin(th))
            y += r * (math.cos(th) - math.cos(th + wk * dk))
            th += wk * dk
    return np.array([x, y, th])


def test_mrclam_dead_reckoning_first_60_s(mrclam_dir: Path) -> None:
    """Odometry (velocity commands) integrated from the Vicon pose at the first
    command. Measured: 0.21 m and 0.008 rad off after 60 s and 3.7 m of path (5.6 %).
    The bound is 10 % of the path, about twice what we see, as velocity commands
    (not wheel encoders) are a few per cent off the true motion; it still fails a
    robot that did not move (truth moves 1.6 m net) or a swapped v/omega."""
    run = load_mrclam(mrclam_dir)
    t0 = run.odometry_t[0]
    n = int(np.searchsorted(run.odometry_t, t0 + 60.0))
    dt = np.diff(run.odometry_t[: n + 1])
    i0 = int(np.searchsorted(run.truth_t, t0))
    i1 = int(np.searchsorted(run.truth_t, run.odometry_t[n]))
    start = np.array([run.truth_x[i0], run.truth_y[i0], run.truth_theta[i0]])
    end = unicycle_steps(start, run.odometry_v[:n], run.odometry_omega[:n], dt)
    truth_end = np.array([run.truth_x[i1], run.truth_y[i1]])
    path = float(np.sum(np.abs(run.odometry_v[:n]) * dt))
    drift = float(np.hypot(*(end[:2] - truth_end)))
    heading = abs(math.remainder(end[2] - run.truth_theta[i1], 2 * math.pi))
    assert abs(run.truth_t[i1] - run.odometry_t[n]) < 0.05
    assert drift < 0.1 * path, (drift, path)
    assert heading < 0.1, heading
    assert float(np.hypot(*(truth_end - start[:2]))) > 5 * drift


# ----------------------------------------------------------- Victoria Park, real data


@pytest.fixture(scope="module")
def park_dir(data: Path) -> Path:
    folder = data / "victoria_park"
    if not folder.is_dir():
        pytest.skip(f"{folder} not found")
    return folder


def test_victoria_park_counts_and_first_last_records(park_dir: Path) -> None:
    park = load_victoria_park(park_dir)
    meas = data_lines(park_dir / "measurements.dat")
    inputs = data_lines(park_dir / "inputs.dat")
    gps = data_lines(park_dir / "gps.dat")
    assert (len(park.measurement_t), len(park.input_t), len(park.gps_t)) == (
        len(meas),
        len(inputs),
        len(gps),
    )
    for k in (0, -1):
        assert park.measurement_range[k] == float(meas[k][1])
        assert park.measurement_bearing_laser[k] == float(meas[k][2])
        assert park.measurement_bearing[k] == pytest.approx(float(meas[k][2]) - math.pi / 2)
        assert park.measurement_diameter[k] == float(meas[k][3])
        assert (park.input_speed[k], park.input_steering[k]) == (
            float(inputs[k][1]),
            float(inputs[k][2]),
        )
        assert (park.gps_t[k], park.gps_y[k]) == (float(gps[k][0]), float(gps[k][2]))
    # Laser bearings lie in (0, pi): vehicle-relative ones in (-pi/2, pi/2).
    assert np.all(np.abs(park.measurement_bearing) < math.pi / 2)
    assert park.scans() == len({m[0] for m in meas})
    assert park.nan_rows == 0 and park.time_backwards == 0


def guivant_nebot_laser_track(park: object, horizon: float) -> np.ndarray:
    """Dead reckoning in Guivant & Nebot's published form (the laser point's Euler
    steps), written here as the oracle: rows (t, x, y) from (0, 0) heading 0."""
    big_l, h, a, b = 2.83, 0.76, 3.78, 0.50
    t, speed, steer = park.input_t, park.input_speed, park.input_steering  # type: ignore[attr-defined]
    x = y = phi = 0.0
    rows = [(t[0], x, y)]
    for k in range(len(t) - 1):
        if t[k] > horizon:
            break
        dt = t[k + 1] - t[k]
        vc = speed[k] / (1 - math.tan(steer[k]) * h / big_l)
        w = vc * math.tan(steer[k]) / big_l
        s, c = math.sin(phi), math.cos(phi)
        x, y = x + dt * (vc * c - w * (a * s + b * c)), y + dt * (vc * s + w * (a * c - b * s))
        phi += dt * w
        rows.append((t[k + 1], x, y))
    return np.array(rows)


def test_victoria_park_dead_reckoning_first_60_s(park_dir: Path) -> None:
    """The laser point dead-reckoned from the inputs, moved to the first GPS fix and
    turned by the least-squares rotation that fits the first 20 s of GPS (the data set
    gives no initial heading). The bound is 2 m (GPS in the park: 0.04 to 0.07 m
    standard deviation at rest, metres under trees) plus 5 % of the path (encoder scale
    and steering bias: over the first 23 m, where the car then stops, the encoders
    give 22.2 m and GPS 23.2 m). GPS also jumps: at t = 25.0 s one fix lands 3.6 m off
    a track that was 0.7 m off 0.2 s before and 2.1 m off 0.4 s later, while the car
    moved 0.5 m. Such isolated fixes (more than 1 m off both neighbours' gaps) are
    counted, at most 2 allowed, and left out of the bound. Measured: 1 isolated fix;
    the others are at most 4.3 m off after 121 m of path (3.6 %), 0.48 m inside the
    bound; with the speed scaled by 0.9 or 1.1 the bound is exceeded by 6.9 or 4.3 m."""
    park = load_victoria_park(park_dir)
    track = guivant_nebot_laser_track(park, 60.0)
    fixes = park.gps_t <= 60.0
    t, gx, gy = park.gps_t[fixes], park.gps_x[fixes], park.gps_y[fixes]
    px, py = np.interp(t, track[:, 0], track[:, 1]), np.interp(t, track[:, 0], track[:, 2])
    fit = t <= 20.0
    bx, by = gx[fit] - gx[0], gy[fit] - gy[0]
    angle = math.atan2(
        float(np.sum(px[fit] * by - py[fit] * bx)), float(np.sum(px[fit] * bx + py[fit] * by))
    )
    c, s = math.cos(angle), math.sin(angle)
    gap = np.hypot(gx[0] + c * px - s * py - gx, gy[0] + s * px + c * py - gy)
    step = np.hypot(np.diff(track[:, 1]), np.diff(track[:, 2]))
    path = np.interp(t, track[:, 0], np.concatenate([[0.0], np.cumsum(step)]))
    inner = gap[1:-1]
    isolated = (np.abs(inner - gap[:-2]) > 1.0) & (np.abs(inner - gap[2:]) > 1.0)
    kept = np.concatenate([[True], ~isolated, [True]])
    assert len(t) == 195 and path[-1] > 100.0
    assert int(isolated.sum()) <= 2
    assert np.all(gap[kept] < 2.0 + 0.05 * path[kept]), float(np.max(gap - 0.05 * path))


# ------------------------------------------------------------------ malformed files


def write_park(folder: Path, measurements: str, inputs: str, gps: str) -> Path:
    folder.mkdir(exist_ok=True)
    (folder / "measurements.dat").write_text(measurements)
    (folder / "inputs.dat").write_text(inputs)
    (folder / "gps.dat").write_text(gps)
    return folder


GOOD_MEAS = "0.5 10.0 1.5707963 0.3\n0.5 12.0 0.5 0.2\n1.0 8.0 2.0 0.4\n"
GOOD_INPUTS = "0.0 1.0 0.0\n0.025 1.1 0.01\n"
GOOD_GPS = "0.0 -2.0 -1.9\n0.2 -2.1 -1.8\n"


def test_small_park_reads(tmp_path: Path) -> None:
    park = load_victoria_park(write_park(tmp_path / "p", GOOD_MEAS, GOOD_INPUTS, GOOD_GPS))
    assert park.measurement_range.tolist() == [10.0, 12.0, 8.0]
    assert park.measurement_bearing[0] == pytest.approx(0.0, abs=1e-7)
    assert park.scans() == 2 and park.gps_x.tolist() == [-2.0, -2.1]


@pytest.mark.parametrize(
    ("text", "line", "words"),
    [
        ("0.5 10.0 1.5 0.3\n0.6 11.0 1.2\n", 2, "expected 4 columns"),  # truncated
        ("# c\n0.5 10.0 1.5 0.3\n0.6 11.0 abc 0.3\n", 3, "column 3 is not a number"),
        ("0.5 10.0 1.5 0.3\n\n0.4 11.0 1.2 0.3\n", 3, "time goes backwards"),
        ("", 0, "no records"),
        ("# only a comment\n", 1, "no records"),
        ("nan 10.0 1.5 0.3\n", 1, "time is nan"),
    ],
)
def test_malformed_lines_name_file_and_line(
    tmp_path: Path, text: str, line: int, words: str
) -> None:
    folder = write_park(tmp_path / "p", text, GOOD_INPUTS, GOOD_GPS)
    with pytest.raises(DatasetFormatError) as err:
        load_victoria_park(folder)
    assert err.value.line == line and words in err.value.reason
    assert err.value.path.endswith("measurements.dat")
    assert isinstance(err.value, ValueError)


def test_backwards_time_can_be_counted_instead(tmp_path: Path) -> None:
    folder = write_park(tmp_path / "p", GOOD_MEAS, "0.1 1 0\n0.0 1 0\n0.2 1 0\n", GOOD_GPS)
    park = load_victoria_park(folder, allow_time_backwards=True)
    assert park.time_backwards == 1 and len(park.input_t) == 3
    assert "1 times going backwards" in repr(park)


def test_nan_values_are_kept_and_counted(tmp_path: Path) -> None:
    folder = write_park(tmp_path / "p", GOOD_MEAS, "0.0 nan 0\n0.1 1 NaN\n", GOOD_GPS)
    park = load_victoria_park(folder)
    assert park.nan_rows == 2 and np.isnan(park.input_speed[0])


def test_gzip_files_read_transparently(tmp_path: Path) -> None:
    folder = write_park(tmp_path / "p", GOOD_MEAS, GOOD_INPUTS, GOOD_GPS)
    raw = (folder / "inputs.dat").read_bytes()
    (folder / "inputs.dat").unlink()
    with gzip.open(folder / "inputs.dat.gz", "wb") as f:
        f.write(raw)
    assert load_victoria_park(folder).input_speed.tolist() == [1.0, 1.1]


def write_mrclam(folder: Path, measurement: str) -> Path:
    folder.mkdir(exist_ok=True)
    (folder / "Robot2_Odometry.dat").write_text("# h\n10.0 0.1 0.0\n10.5 0.1 0.1\n")
    (folder / "Robot2_Measurement.dat").write_text(measurement)
    (folder / "Robot2_Groundtruth.dat").write_text("9.0 0 0 0\n11.0 0.1 0 0.05\n")
    (folder / "Landmark_Groundtruth.dat").write_text("6 1.0 2.0 0.01 0.02\n7 3 4 0 0\n")
    (folder / "Barcodes.dat").write_text("# s b\n1 5\n2 14\n6 63\n7 81\n")
    return folder


def test_small_mrclam_maps_barcodes_and_counts(tmp_path: Path) -> None:
    meas = "10.1 63 1.0 0.1\n10.1 14 2.0 0.2\n10.2 99 3.0 0.3\n10.3 81 4.0 -0.4\n"
    run = load_mrclam(write_mrclam(tmp_path / "m", meas), robot=2)
    assert run.measurement_landmark.tolist() == [6, 7]
    assert run.measurement_range.tolist() == [1.0, 4.0]
    assert (run.robot_sightings, run.unknown_barcodes) == (1, 1)
    assert run.unknown_barcode_values == (99,)


def test_mrclam_errors(tmp_path: Path) -> None:
    folder = write_mrclam(tmp_path / "m", "10.1 63 1.0 0.1\n10.2 6.5 1.0 0.1\n")
    with pytest.raises(DatasetFormatError) as err:
        load_mrclam(folder, robot=2)
    assert err.value.line == 2 and "barcode" in err.value.reason
    (folder / "Barcodes.dat").write_text("1 5\n1 14\n")
    with pytest.raises(DatasetFormatError, match=r"Barcodes.dat:2: id 1 repeats line 1"):
        load_mrclam(folder, robot=2)
    with pytest.raises(ValueError, match="robot"):
        load_mrclam(folder, robot=6)
    with pytest.raises(FileNotFoundError):
        load_mrclam(folder, robot=3)


# ------------------------------------------------------------- property: line numbers

finite = st.floats(-1e6, 1e6, allow_nan=False)


@given(
    rows=st.lists(st.tuples(finite, finite), min_size=1, max_size=30),
    filler=st.lists(st.sampled_from(["", "# comment", "   "]), max_size=30),
    seed=st.integers(0, 2**32 - 1),
    corrupt=st.booleans(),
)
def test_line_numbers_are_exact(
    tmp_path_factory: pytest.TempPathFactory,
    rows: list[tuple[float, float]],
    filler: list[str],
    seed: int,
    corrupt: bool,
) -> None:
    """Records interleaved with comments and blank lines at random: every value and
    line number comes back, and a corrupted record is named by its line."""
    rng = np.random.default_rng(seed)
    times = [float(t) for t in np.cumsum(rng.uniform(0.0, 1.0, len(rows)))]
    lines = [f"{t!r} {a!r} {b!r}" for t, (a, b) in zip(times, rows, strict=True)]
    for text in filler:
        lines.insert(int(rng.integers(0, len(lines) + 1)), text)
    record_lines = [k + 1 for k, text in enumerate(lines) if text.strip() and text[0] != "#"]
    bad = int(rng.integers(0, len(record_lines)))
    if corrupt:
        k = record_lines[bad] - 1
        lines[k] = lines[k].rsplit(" ", 1)[0] + " 1.2.3"
    path = tmp_path_factory.mktemp("t") / "x.dat"
    path.write_text("\n".join(lines) + "\n")
    if corrupt:
        with pytest.raises(DatasetFormatError) as err:
            read_table(path, 3)
        assert err.value.line == record_lines[bad] and "column 3" in err.value.reason
        return
    table = read_table(path, 3)
    assert table.line.tolist() == record_lines
    assert table.values[:, 0].tolist() == times
    assert table.values[:, 1:].tolist() == [list(r) for r in rows]
