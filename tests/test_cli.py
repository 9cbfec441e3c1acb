"""The ``rperc`` command line, run in-process through its entry point."""

from __future__ import annotations

import numpy as np
import pytest

from rperc.cli import main
from rperc.datasets import read_polylines
from rperc.linesimp import simplify


def test_lines_simplify_wkt_round_trip(tmp_path, capsys):
    pts = np.cumsum(np.random.default_rng(0).normal(size=(300, 2)), axis=0)
    src = tmp_path / "in.wkt"
    src.write_text("LINESTRING(" + ",".join(f"{x:.17g} {y:.17g}" for x, y in pts) + ")\n")
    out = tmp_path / "out.wkt"
    png = tmp_path / "plot.png"
    assert (
        main(
            ["lines", "simplify", str(src), "--epsilon", "1.5", "-o", str(out), "--plot", str(png)]
        )
        == 0
    )
    (kept,) = read_polylines(out)
    np.testing.assert_array_equal(kept, simplify(pts, 1.5))
    assert png.stat().st_size > 1000
    assert "300 ->" in capsys.readouterr().err


def test_lines_simplify_csv_with_segment_metric(tmp_path, capsys):
    pts = np.cumsum(np.random.default_rng(1).normal(size=(100, 3)), axis=0)
    src = tmp_path / "in.csv"
    np.savetxt(src, pts, delimiter=",", header="x,y,z", comments="")
    code = main(
        ["lines", "simplify", str(src), "--epsilon", "1", "--method", "dp", "--metric", "segment"]
    )
    assert code == 0
    wkt = capsys.readouterr().out.strip()
    assert wkt.startswith("LINESTRING Z(")
    expected = simplify(pts, 1.0, method="dp", metric="segment")
    assert wkt.count(",") == len(expected) - 1


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
