"""The ``rperc`` command line, run in-process through its entry point (and once as a
real process): results on stdout, notes on stderr, ``--json`` files recomputed from the
inputs, and every user mistake a one-line error with exit status 2, checked before
any work is done."""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from rperc.cli import main
from rperc.datasets import read_geometries, read_polylines
from rperc.linesimp import simplify
from rperc.scansim import ray_cast, room_walls
from rperc.tracking.synthetic import synthetic_sequence

shapely = pytest.importorskip("shapely")
simplification = pytest.importorskip("simplification.cutil")


def walk(n: int, dims: int = 2, seed: int = 0) -> np.ndarray:
    return np.cumsum(np.random.default_rng(seed).normal(size=(n, dims)), axis=0)


def test_lines_simplify_wkt_round_trip(tmp_path, capsys):
    """Plain DP with the segment metric is GEOS's DouglasPeuckerSimplifier: the output
    file must hold exactly what shapely's simplify gives."""
    pts = walk(300)
    src = tmp_path / "in.wkt"
    src.write_text(shapely.to_wkt(shapely.LineString(pts), rounding_precision=-1) + "\n")
    out, png, summary = tmp_path / "out.wkt", tmp_path / "plot.png", tmp_path / "run.json"
    argv = ["lines", "simplify", str(src), "--epsilon", "1.5", "--metric", "segment"]
    assert main([*argv, "-o", str(out), "--plot", str(png), "--json", str(summary)]) == 0
    expected = shapely.simplify(shapely.LineString(pts), 1.5, preserve_topology=False)
    (got,) = read_geometries(out)
    assert shapely.equals_exact(got, expected, tolerance=0.0)
    assert png.stat().st_size > 1000
    captured = capsys.readouterr()
    assert captured.out == ""  # everything else goes to stderr
    n_out = shapely.get_num_coordinates(expected)
    assert f"300 -> {n_out} points" in captured.err
    for path in (out, png, summary):
        assert f"wrote {path}" in captured.err
    record = json.loads(summary.read_text())
    assert record["points_in"] == 300 and record["points_out"] == n_out
    assert record["epsilon"] == 1.5 and record["metric"] == "segment"
    assert record["method"] == "auto" and record["method_run"] == "dp"
    assert record["geometries"] == [
        {"index": 0, "type": "LineString", "points_in": 300, "points_out": n_out}
    ]


def test_lines_simplify_csv_with_z_to_stdout(tmp_path, capsys):
    pts = walk(100, dims=3, seed=1)
    src = tmp_path / "in.csv"
    np.savetxt(src, pts, delimiter=",", header="x,y,z", comments="", fmt="%.17g")
    argv = [
        "lines",
        "simplify",
        str(src),
        "--epsilon",
        "1",
        "--method",
        "dp",
        "--metric",
        "segment",
    ]
    assert main(argv) == 0
    got = shapely.from_wkt(capsys.readouterr().out)
    expected = shapely.simplify(shapely.LineString(pts), 1.0, preserve_topology=False)
    assert got.has_z and shapely.equals_exact(got, expected, tolerance=0.0)
    np.testing.assert_array_equal(
        shapely.get_coordinates(got, include_z=True)[:, 2], expected.coords.__array__()[:, 2]
    )


def test_lines_simplify_geojson_keeps_types_and_topology(tmp_path, capsys):
    """Polygons with holes and lines, simplified without creating intersections, written
    as GeoJSON; checked against shapely's preserve_topology=True."""
    t = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    rng = np.random.default_rng(0)
    shell = np.c_[np.cos(t), np.sin(t)] * (10 + rng.normal(scale=0.1, size=(400, 1)))
    hole = np.c_[np.cos(t[::8]), np.sin(t[::8])] * 9.5
    polygon = shapely.Polygon(shell, [hole])
    lines = shapely.MultiLineString([walk(80, seed=3) * 0.2 + 30, walk(60, seed=4) * 0.2 - 30])
    src = tmp_path / "in.wkt"
    src.write_text(
        "".join(shapely.to_wkt(g, rounding_precision=-1) + "\n" for g in (polygon, lines))
    )
    out = tmp_path / "out.geojson"
    argv = ["lines", "simplify", str(src), "--epsilon", "0.8", "--metric", "segment"]
    assert main([*argv, "--preserve-topology", "-o", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert doc["type"] == "FeatureCollection" and len(doc["features"]) == 2
    for feature, geom in zip(doc["features"], (polygon, lines), strict=True):
        got = shapely.geometry.shape(feature["geometry"])
        expected = shapely.simplify(geom, 0.8, preserve_topology=True)
        assert got.geom_type == geom.geom_type
        assert shapely.equals_exact(got, expected, tolerance=0.0)
        assert got.is_valid
    # What --preserve-topology avoids: without it the shell cuts through the hole (and
    # shapely's own plain DP only comes out valid because GEOS repairs it).
    assert not simplify(polygon, 0.8, metric="segment").is_valid
    assert "wrote" in capsys.readouterr().err


def test_lines_simplify_polygon_stays_a_polygon_and_vw_matches_simplification(tmp_path, capsys):
    pts = walk(200, seed=5)
    src = tmp_path / "in.csv"
    np.savetxt(src, pts, delimiter=",", fmt="%.17g")
    out = tmp_path / "out.csv"
    assert (
        main(["lines", "simplify", str(src), "--epsilon", "2", "--method", "vw", "-o", str(out)])
        == 0
    )
    (got,) = read_polylines(out)
    idx = simplification.simplify_coords_vw_idx(pts, 2.0)
    np.testing.assert_array_equal(got, pts[np.asarray(idx, dtype=np.intp)])
    square = tmp_path / "square.wkt"
    square.write_text("POLYGON ((0 0, 1 0.01, 2 0, 2 2, 0 2, 0 0))\n")
    assert main(["lines", "simplify", str(square), "--epsilon", "0.1", "--metric", "segment"]) == 0
    got = shapely.from_wkt(capsys.readouterr().out)
    expected = shapely.simplify(shapely.from_wkt(square.read_text()), 0.1, preserve_topology=False)
    assert got.geom_type == "Polygon" and shapely.equals_exact(got, expected, tolerance=0.0)


def test_lines_simplify_refuses_unknown_suffixes(tmp_path, capsys):
    src = tmp_path / "in.csv"
    np.savetxt(src, walk(20), delimiter=",")
    out = tmp_path / "out.shp"
    assert main(["lines", "simplify", str(src), "--epsilon", "1", "-o", str(out)]) == 2
    assert "out.shp" in capsys.readouterr().err and not out.exists()
    weird = tmp_path / "in.dat"
    weird.write_text("0,0\n1,1\n")
    assert main(["lines", "simplify", str(weird), "--epsilon", "1"]) == 2
    assert "unknown file type" in capsys.readouterr().err


def test_bad_input_is_an_error_message_not_a_traceback(tmp_path, capsys):
    src = tmp_path / "bad.csv"
    src.write_text("x,y\n0,0\n1,nope\n")
    assert main(["lines", "simplify", str(src), "--epsilon", "1"]) == 2
    assert "bad.csv:3" in capsys.readouterr().err
    good = tmp_path / "good.csv"
    good.write_text("0,0\n1,1\n2,0\n")
    assert main(["lines", "simplify", str(good), "--epsilon", "-1"]) == 2
    assert "epsilon" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["lines", "simplify", str(good)])  # --epsilon is required


def one_error_line(capsys) -> str:
    """The single ``rperc: error: ...`` line of a failed command (and no traceback)."""
    err = capsys.readouterr().err
    assert "Traceback" not in err
    errors = [line for line in err.splitlines() if line.startswith("rperc: error: ")]
    assert len(errors) == 1, err
    return errors[0]


POSES = [(4.0, 2.5, 0.3), (5.0, 1.0, 1.2), (8.5, 3.0, 2.5), (2.0, 4.5, -1.0), (9.0, 1.0, 3.0)]


@pytest.fixture
def carmen_log(tmp_path) -> Path:
    """A FLASER log of the simulated room: noise-free 180-beam ray casts from 5 poses."""
    walls = room_walls()
    angles = -math.pi / 2 + math.pi / 180 * np.arange(180)
    rows = []
    for k, (x, y, th) in enumerate(POSES):
        scan = ray_cast(walls, np.array([x, y, th]), angles, max_range=81.83)
        ranges = " ".join(f"{r:.5f}" for r in scan.ranges)
        rows.append(f"FLASER 180 {ranges} {x} {y} {th} {x} {y} {th} {k}.0 sim {k}.0")
    path = tmp_path / "room.log"
    path.write_text("\n".join(rows) + "\n")
    return path


@pytest.fixture
def otb_folder(tmp_path) -> Path:
    """The synthetic sequence stored as an OTB folder (PNG frames, 1-based boxes)."""
    seq = synthetic_sequence(12, seed=3)
    root = tmp_path / "Synthetic"
    (root / "img").mkdir(parents=True)
    for k, frame in enumerate(seq.frames):
        Image.fromarray(frame).save(root / "img" / f"{k + 1:04d}.png")
    rows = [" ".join(f"{v:.6f}" for v in (x + 1, y + 1, w, h)) for x, y, w, h in seq.boxes]
    (root / "groundtruth_rect.txt").write_text("\n".join(rows) + "\n")
    return root


def test_demo_lines_writes_exactly_its_figure(tmp_path, capsys):
    assert main(["demo", "lines", "--out", str(tmp_path)]) == 0
    captured = capsys.readouterr()
    assert captured.out.startswith("lines: ") and len(captured.out.splitlines()) == 1
    assert captured.err.splitlines() == [f"wrote {tmp_path / 'lines.png'}"]
    assert (tmp_path / "lines.png").stat().st_size > 10_000


def test_demo_monobot_writes_the_papers_figures(tmp_path, capsys):
    assert main(["demo", "monobot", "--out", str(tmp_path), "--runs", "20"]) == 0
    for name in ("fig3_fisher", "fig4_relative", "fig5_anchor", "fig6_external", "monte_carlo"):
        assert (tmp_path / f"monobot_{name}.png").stat().st_size > 10_000
    out = capsys.readouterr().out
    assert out.startswith("monobot: ")
    assert "unobservable directions: [[" in out


def test_demo_creates_its_output_folder_but_not_over_a_file(tmp_path, capsys):
    out = tmp_path / "a" / "b"
    assert main(["demo", "walls", "--out", str(out)]) == 0
    assert (out / "walls.png").is_file()
    capsys.readouterr()
    afile = tmp_path / "file"
    afile.write_text("x")
    assert main(["demo", "walls", "--out", str(afile)]) == 2
    assert "is a file" in one_error_line(capsys)


def test_lines_extract_prints_results_and_writes_what_it_says(carmen_log, tmp_path, capsys):
    png, js = tmp_path / "walls.png", tmp_path / "walls.json"
    argv = ["lines", "extract", str(carmen_log), "--plot", str(png), "--json", str(js)]
    assert main(argv) == 0
    captured = capsys.readouterr()
    (line,) = captured.out.splitlines()
    walls, scans = (int(v) for v in re.search(r"(\d+) walls from (\d+) scans", line).groups())
    assert "wrote" not in captured.out
    assert f"wrote {png}" in captured.err.splitlines()
    assert f"wrote {js}" in captured.err.splitlines()
    assert png.stat().st_size > 10_000 and sorted(p.name for p in tmp_path.iterdir()) == [
        "room.log",
        "walls.json",
        "walls.png",
    ]
    measured = json.loads(js.read_text())
    assert measured["scans"] == scans == len(POSES)
    assert measured["walls"] == walls >= len(POSES)  # every pose sees at least one wall
    assert measured["readings"] == 180 * len(POSES)  # a closed room: every beam returns


def brute_force_auc(pred: np.ndarray, truth: np.ndarray) -> float:
    """OTB's area under the success curve, with exact rational IoUs."""
    ious = []
    for p, t in zip(pred, truth, strict=True):
        ax, ay, aw, ah = (Fraction(float(v)) for v in p)
        bx, by, bw, bh = (Fraction(float(v)) for v in t)
        w = max(Fraction(0), min(ax + aw, bx + bw) - max(ax, bx))
        h = max(Fraction(0), min(ay + ah, by + bh) - max(ay, by))
        ious.append(w * h / (aw * ah + bw * bh - w * h))
    success = [sum(o > Fraction(k, 20) for o in ious) / len(ious) for k in range(21)]
    return float(sum(success) / 21)


@pytest.mark.parametrize("tracker", ["color-template", "color", "color-pf", "color-shape"])
def test_track_scores_an_otb_folder_against_its_ground_truth(otb_folder, tmp_path, capsys, tracker):
    strip, js = tmp_path / "strip.png", tmp_path / "track.json"
    argv = ["track", str(otb_folder), "--tracker", tracker, "--strip", str(strip), "--frames", "3"]
    assert main([*argv, "--json", str(js)]) == 0
    captured = capsys.readouterr()
    (auc,) = (float(v) for v in re.search(r"AUC (\d\.\d+)", captured.out).groups())
    measured = json.loads(js.read_text())
    truth = synthetic_sequence(12, seed=3).boxes
    assert auc == pytest.approx(brute_force_auc(np.asarray(measured["boxes"]), truth), abs=5e-4)
    assert measured["tracker"] == tracker and measured["frames"] == 12
    assert f"wrote {strip}" in captured.err.splitlines() and strip.stat().st_size > 10_000


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["track", "SEQ", "--frames", "0"], "argument --frames: must be an integer >= 2, got 0"),
        (["track", "SEQ", "--frames", "1"], "argument --frames: must be an integer >= 2, got 1"),
        (["track", "SEQ", "--frames", "two"], "argument --frames: expected an integer"),
        (["track", "SEQ", "--seed", "-1"], "argument --seed: must be an integer >= 0"),
        (["track", "SEQ", "--seed", str(2**64)], "argument --seed: must be an integer <= "),
        (["track", "V.mp4", "--box", "1,2,3"], "argument --box: expected 4 finite numbers"),
        (["track", "V.mp4", "--box", "1,2,0,4"], "argument --box: w and h must be > 0"),
        (["track", "V.mp4", "--box", "a,2,3,4"], "argument --box: expected x,y,w,h"),
        (["demo", "tracking", "--frames", "1001"], "argument --frames: must be an integer <= 1000"),
        (["demo", "tracking", "--frames", "1"], "argument --frames"),
        (["demo", "monobot", "--runs", "1"], "argument --runs"),
        (["demo", "all", "--seed", "-3"], "argument --seed"),
        (["lines", "extract", "LOG", "--every", "0"], "argument --every"),
        (["lines", "extract", "LOG", "--sigma-range", "nan"], "argument --sigma-range"),
        (["demo", "nothing"], "invalid choice"),
    ],
)
def test_bad_options_are_one_line_errors_with_status_2(argv, needle, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == 2
    assert needle in one_error_line(capsys)


def test_output_paths_are_checked_before_any_work(tmp_path, capsys):
    missing = tmp_path / "no" / "such"
    log = tmp_path / "absent.log"  # the work would fail on it; the path check comes first
    assert main(["lines", "extract", str(log), "--plot", str(missing / "p.png")]) == 2
    assert f"folder {missing} does not exist" in one_error_line(capsys)
    assert not missing.exists() and not missing.parent.exists()
    assert main(["lines", "extract", str(log), "--plot", str(tmp_path)]) == 2
    assert f"--plot {tmp_path} is a folder" in one_error_line(capsys)
    assert main(["lines", "extract", str(log), "--plot", str(tmp_path / "walls")]) == 2
    assert "must end in one of" in one_error_line(capsys)
    assert main(["lines", "extract", str(log), "--json", str(missing / "x.json")]) == 2
    assert "does not exist" in one_error_line(capsys)
    assert main(["track", str(tmp_path), "--strip", str(missing / "s.png")]) == 2
    assert f"folder {missing} does not exist" in one_error_line(capsys)
    assert main(["demo", "lines", "--out", str(tmp_path), "--json", str(tmp_path)]) == 2
    assert "is a folder" in one_error_line(capsys)


def test_bad_input_files_are_one_line_errors(tmp_path, otb_folder, capsys):
    assert main(["lines", "extract", str(tmp_path / "absent.log")]) == 2
    assert "absent.log" in one_error_line(capsys)
    bad_log = tmp_path / "bad.log"
    bad_log.write_text("FLASER 3 1.0 oops 1.0 0 0 0 0 0 0 0 h 0\n")
    assert main(["lines", "extract", str(bad_log)]) == 2
    assert "bad.log:1" in one_error_line(capsys)
    assert main(["track", str(tmp_path)]) == 2  # not an OTB folder
    assert "groundtruth_rect.txt" in one_error_line(capsys)
    assert main(["track", str(otb_folder), "--strip", str(tmp_path / "s.png"), "--frames", "13"])
    assert "--frames must be between 2 and 12" in one_error_line(capsys)


@pytest.mark.parametrize("damage", ["text", "truncated", "empty"])
def test_a_corrupt_frame_is_a_one_line_error(otb_folder, capsys, damage):
    frame = otb_folder / "img" / "0005.png"
    data = frame.read_bytes()
    frame.write_bytes({"text": b"not an image\n", "truncated": data[:200], "empty": b""}[damage])
    assert main(["track", str(otb_folder)]) == 2
    one_error_line(capsys)


def test_python_dash_m_rperc_runs_the_command(tmp_path):
    run = subprocess.run(
        [sys.executable, "-m", "rperc", "--version"], capture_output=True, text=True, check=False
    )
    assert run.returncode == 0 and run.stdout.startswith("rperc ")
    run = subprocess.run(
        [sys.executable, "-m", "rperc", "lines", "extract", str(tmp_path / "absent.log")],
        capture_output=True,
        text=True,
        check=False,
    )
    assert run.returncode == 2 and run.stdout == ""
    assert run.stderr.count("\n") == 1 and run.stderr.startswith("rperc: error: ")


def test_lines_extract_on_a_real_log(tmp_path, data, capsys):
    png = tmp_path / "intel.png"
    log = data / "carmen" / "intel.log"
    assert main(["lines", "extract", str(log), "--every", "10", "--plot", str(png)]) == 0
    assert png.stat().st_size > 10_000
    assert "walls" in capsys.readouterr().out


def test_track_command_scores_a_sequence(tmp_path, data, capsys):
    strip = tmp_path / "strip.png"
    seq = data / "otb" / "Girl"
    assert (
        main(["track", str(seq), "--tracker", "color", "--strip", str(strip), "--frames", "4"]) == 0
    )
    out = capsys.readouterr().out
    assert "AUC" in out and "fps" in out
    assert strip.stat().st_size > 10_000


@pytest.fixture(scope="module")
def pattern_folder(tmp_path_factory):
    """A generated pattern sequence written as PNG files, with its truth."""
    from PIL import Image

    from rperc.cli.pattern import demo_images
    from rperc.tracking import pattern_sequence

    patch, background = demo_images(0)
    seq = pattern_sequence(
        patch, background, n_frames=8, width=320, height=240, seed=1, max_step_sigmas=0.5
    )
    folder = tmp_path_factory.mktemp("pattern")
    for k, frame in enumerate(seq.frames):
        Image.fromarray(frame).save(folder / f"{k:04d}.png")
    return folder, seq


def test_track_pattern_follows_a_generated_sequence(pattern_folder, tmp_path, capsys):
    folder, seq = pattern_folder
    region = ",".join(str(v) for v in seq.region)
    out, strip = tmp_path / "poses.json", tmp_path / "strip.png"
    argv = ["track-pattern", str(folder), "--region", region, "--json", str(out)]
    assert main([*argv, "--strip", str(strip), "--frames", "3"]) == 0
    assert "8 frames" in capsys.readouterr().out
    doc = json.loads(out.read_text())
    assert doc["frames"] == 8 and len(doc["poses"]) == 8
    est = np.array([[p["x"], p["y"]] for p in doc["poses"]])
    # Steps within half a sigma on the generator's clean frames: within 2 px of its truth.
    err = np.hypot(*(est - seq.truth[:, :2]).T)
    assert err.max() < 2.0, err
    corners = np.asarray(doc["poses"][0]["corners"])
    x, y, w, h = seq.region
    np.testing.assert_allclose(
        corners,
        [
            [x - 0.5, y - 0.5],
            [x + w - 0.5, y - 0.5],
            [x + w - 0.5, y + h - 0.5],
            [x - 0.5, y + h - 0.5],
        ],
    )
    assert strip.stat().st_size > 10_000


def test_track_pattern_scores_against_a_pot_truth(pattern_folder, tmp_path, capsys):
    from rperc.tracking.planar import similarity_corners

    folder, seq = pattern_folder
    truth = similarity_corners(seq.truth, seq.region)
    gt = tmp_path / "gt"
    gt.mkdir()
    np.savetxt(gt / "gt_corners.txt", truth.reshape(len(truth), 8), fmt="%.4f")
    flags = [0] * len(truth)
    flags[3] = 1  # an occluded frame: not scored
    (gt / "gt_flag.txt").write_text("".join(f"{f}\n" for f in flags))
    out = tmp_path / "poses.json"
    region = ",".join(str(v) for v in seq.region)
    argv = ["track-pattern", str(folder), "--region", region, "--truth", str(gt)]
    assert main([*argv, "--json", str(out)]) == 0
    assert "against the truth (6 visible frames)" in capsys.readouterr().out
    doc = json.loads(out.read_text())
    est = np.array([p["corners"] for p in doc["poses"]])
    # Brute force over the frames after the first that are flagged visible.
    errs = [
        sum(math.dist(est[k][i], truth[k][i]) for i in range(4)) / 4
        for k in range(1, len(truth))
        if flags[k] == 0
    ]
    assert doc["scored_frames"] == len(errs) == 6
    assert doc["mean_corner_error_px"] == pytest.approx(sum(errs) / 6, abs=1e-3)
    assert doc["precision_at_5"] == sum(e <= 5 for e in errs) / 6
    assert doc["precision_at_15"] == sum(e <= 15 for e in errs) / 6
    assert doc["fps"] > 0
    (gt / "gt_flag.txt").write_text("0\n")
    assert main(argv) == 2
    assert "1 flags for 8 frames" in one_error_line(capsys)


@pytest.mark.parametrize(
    ("extra", "needle"),
    [
        (["--region", "1,2,3"], "--region must be x,y,w,h"),
        (["--region", "300,200,80,80"], "region"),
        (["--region", "0,0,4,4"], "smaller than"),
    ],
)
def test_track_pattern_refuses_bad_regions_in_one_line(pattern_folder, extra, needle, capsys):
    folder, _ = pattern_folder
    try:
        code = main(["track-pattern", str(folder), *extra])
    except SystemExit as e:
        code = e.code
    assert code == 2
    assert needle in one_error_line(capsys)


def test_track_pattern_refuses_a_missing_source_and_a_bad_animation(
    pattern_folder, tmp_path, capsys
):
    folder, seq = pattern_folder
    region = ",".join(str(v) for v in seq.region)
    assert main(["track-pattern", str(tmp_path / "nope.mp4"), "--region", region]) == 2
    assert "does not exist" in one_error_line(capsys)
    bad = tmp_path / "a.avi"
    assert main(["track-pattern", str(folder), "--region", region, "--animation", str(bad)]) == 2
    assert ".gif or .mp4" in one_error_line(capsys)


def _otb_copy(root: Path, name: str, seed: int, frames: int = 10) -> Path:
    """A synthetic sequence written as an OTB folder (PNG frames, 1-based boxes)."""
    seq = synthetic_sequence(frames, seed=seed)
    folder = root / name
    (folder / "img").mkdir(parents=True)
    for k, frame in enumerate(seq.frames):
        Image.fromarray(frame).save(folder / "img" / f"{k + 1:04d}.png")
    rows = [",".join(f"{v:.6f}" for v in (x + 1, y + 1, w, h)) for x, y, w, h in seq.boxes]
    (folder / "groundtruth_rect.txt").write_text("\n".join(rows) + "\n")
    return folder


def test_track_all_tables_every_otb_folder_and_its_json_holds_every_box(tmp_path, capsys):
    parent = tmp_path / "otb"
    _otb_copy(parent, "Alpha", seed=4)
    _otb_copy(parent, "Beta", seed=5, frames=8)
    (parent / "notes").mkdir()  # not a sequence: skipped
    js = tmp_path / "all.json"
    assert main(["track", "--all", str(parent), "--json", str(js)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in out[2:5]] == ["Alpha", "Beta", "mean"]
    measured = json.loads(js.read_text())
    rows = measured["sequences"]
    aucs = []
    for row, seed, n in zip(rows, (4, 5), (10, 8), strict=True):
        truth = synthetic_sequence(n, seed=seed).boxes
        boxes = np.asarray(row["boxes"])
        assert boxes.shape == (n, 4) and len(row["scores"]) == n and len(row["lost"]) == n
        aucs.append(brute_force_auc(boxes, truth))
        assert row["auc"] == pytest.approx(aucs[-1], abs=5e-4)
    assert measured["mean_auc"] == pytest.approx(np.mean(aucs), abs=5e-4)
    assert float(out[4].split()[1]) == pytest.approx(np.mean(aucs), abs=6e-4)


def test_track_a_video_with_a_box_writes_csv_json_and_an_annotated_gif(tmp_path, capsys):
    iio = pytest.importorskip("imageio.v3")
    seq = synthetic_sequence(10, seed=6)
    video, csv, js, gif = (tmp_path / n for n in ("in.gif", "b.csv", "b.json", "out.gif"))
    iio.imwrite(video, seq.frames, duration=40, loop=0)
    box = ",".join(f"{v:.2f}" for v in seq.boxes[0])
    argv = ["track", str(video), "--box", box, "--csv", str(csv), "--json", str(js)]
    assert main([*argv, "--video", str(gif)]) == 0
    err = capsys.readouterr().err
    assert all(f"wrote {p}" in err for p in (csv, js, gif))
    lines = csv.read_text().splitlines()
    assert lines[0] == "frame,x,y,w,h,score,lost" and len(lines) == 11
    boxes = np.array([[float(v) for v in line.split(",")[1:5]] for line in lines[1:]])
    np.testing.assert_allclose(boxes, json.loads(js.read_text())["boxes"], atol=0.006)
    # GIF frames are palette-quantised: the tracker still follows the generator's truth.
    assert (
        np.mean(
            [
                np.hypot(*(b[:2] + b[2:] / 2 - t[:2] - t[2:] / 2))
                for b, t in zip(boxes, seq.boxes, strict=True)
            ]
        )
        < 5.0
    )
    with iio.imopen(gif, "r") as f:
        drawn = f.read(index=None)
    assert drawn.shape[:3] == (10, *seq.frames.shape[1:3])
    x, y = round(boxes[5, 0]), round(boxes[5, 1])
    # The box's top-left corner is drawn in red (tracking) in frame 5.
    assert drawn[5, y, x + 3, 0] > 200 and drawn[5, y, x + 3, 1] < 100


def test_color_shape_video_draws_the_contour(tmp_path, capsys):
    """``--tracker color-shape --video`` draws the contour as well as the box: the
    returned contour's pixels are red in the written frames."""
    iio = pytest.importorskip("imageio.v3")
    from rperc.tracking.shape_sequences import shape_sequence

    seq = shape_sequence("rectangle", frames=4, seed=1)
    video, js, gif = tmp_path / "in.gif", tmp_path / "c.json", tmp_path / "out.gif"
    iio.imwrite(video, seq.frames, duration=40, loop=0)
    ys, xs = np.nonzero(seq.masks[0])
    box = f"{xs.min()},{ys.min()},{np.ptp(xs) + 1},{np.ptp(ys) + 1}"
    argv = ["track", str(video), "--box", box, "--tracker", "color-shape", "--json", str(js)]
    assert main([*argv, "--video", str(gif)]) == 0
    capsys.readouterr()
    with iio.imopen(gif, "r") as f:
        drawn = f.read(index=None)
    from rperc.cli.track import draw_contour

    square = np.array([[10.0, 10.0], [30.0, 10.0], [30.0, 20.0], [10.0, 20.0]])
    marked = draw_contour(np.zeros((40, 40, 3), np.uint8), square, (255, 0, 0))
    assert marked[10, 20, 0] == 255 and marked[15, 10, 0] == 255 and marked[15, 20, 0] == 0
    # Oracle: the JSON's contour of frame 2; its points (rounded) are red in the GIF
    # (palette-quantised), most of them away from the box's outline.
    contour = np.asarray(json.loads(js.read_text())["contours"][2])
    assert drawn.shape[0] == 4 and contour.shape[1] == 2
    px = np.rint(contour).astype(int)
    red = (drawn[2, px[:, 1], px[:, 0], 0] > 180) & (drawn[2, px[:, 1], px[:, 0], 1] < 120)
    assert red.mean() > 0.8, red.mean()


# imageio's ffmpeg reader (imageio 2.38) leaves its pipe file objects to the garbage
# collector when the video is closed; that is imageio's, not ours.
@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
def test_track_an_mp4_round_trip(tmp_path, capsys):
    iio = pytest.importorskip("imageio.v3")
    pytest.importorskip("imageio_ffmpeg")
    seq = synthetic_sequence(8, seed=7)
    video, out = tmp_path / "in.mp4", tmp_path / "out.mp4"
    iio.imwrite(video, seq.frames, fps=10, codec="libx264", macro_block_size=1)
    box = ",".join(f"{v:.2f}" for v in seq.boxes[0])
    assert main(["track", str(video), "--box", box, "--video", str(out)]) == 0
    assert "8 frames" in capsys.readouterr().out
    with iio.imopen(out, "r") as f:
        assert f.read(index=None).shape[0] == 8


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["track", "{video}"], "give the initial box with --box"),
        (["track", "{video}", "--box", "1,2,3,4", "--video", "{tmp}/o.avi"], ".gif or .mp4"),
        (["track"], "give one sequence folder or video, or --all"),
        (["track", "--all", "{tmp}"], "no OTB sequence folder"),
    ],
)
def test_track_video_and_all_mistakes_are_one_line_errors(tmp_path, capsys, argv, needle):
    video = tmp_path / "v.gif"
    video.write_bytes(b"GIF89a")
    args = [a.format(video=video, tmp=tmp_path) for a in argv]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert needle in err and len(err.strip().splitlines()) == 1, err


def test_the_simplification_plot_is_a_map_with_labelled_axes(tmp_path, monkeypatch):
    # A coastline drawn with unequal axes is another coastline; unlabelled axes hide
    # what the numbers are.
    import rperc.plot

    figures = []
    real_save = rperc.plot.save
    monkeypatch.setattr(
        rperc.plot, "save", lambda fig, path: figures.append(fig) or real_save(fig, path)
    )
    src = tmp_path / "wide.wkt"
    pts = np.c_[np.linspace(0, 40, 200), np.sin(np.linspace(0, 9, 200))]
    src.write_text(shapely.to_wkt(shapely.LineString(pts)) + "\n")
    argv = ["lines", "simplify", str(src), "--epsilon", "0.2", "--plot", str(tmp_path / "p.png")]
    assert main([*argv, "-o", str(tmp_path / "o.wkt")]) == 0
    (ax,) = figures[0].axes
    assert ax.get_aspect() == 1.0
    assert ax.get_xlabel() and ax.get_ylabel()
