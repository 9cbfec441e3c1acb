"""The ``rperc`` command line, run in-process through its entry point."""

from __future__ import annotations

import json

import numpy as np
import pytest

from rperc.cli import main
from rperc.datasets import read_geometries, read_polylines
from rperc.linesimp import simplify

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


def test_demo_lines_writes_its_figure(tmp_path, capsys):
    assert main(["demo", "lines", "--out", str(tmp_path)]) == 0
    assert (tmp_path / "lines.png").stat().st_size > 10_000
    assert "walls extracted" in capsys.readouterr().out


def test_demo_monobot_writes_the_papers_figures(tmp_path, capsys):
    assert main(["demo", "monobot", "--out", str(tmp_path), "--runs", "20"]) == 0
    for name in ("fig3_fisher", "fig4_relative", "fig5_anchor", "fig6_external", "monte_carlo"):
        assert (tmp_path / f"monobot_{name}.png").stat().st_size > 10_000
    out = capsys.readouterr().out
    assert "unobservable directions: [[" in out


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
        main(["track", str(seq), "--tracker", "colour", "--strip", str(strip), "--frames", "4"])
        == 0
    )
    out = capsys.readouterr().out
    assert "AUC" in out and "fps" in out
    assert strip.stat().st_size > 10_000
