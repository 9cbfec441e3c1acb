"""The optional rerun stream of a planar SLAM run (``pip install rperc[viz]``),
checked headless by saving an .rrd file; the ellipse outlines against their defining
equation (every point at Mahalanobis radius sqrt(chi2_2(0.95)))."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from rperc.cli import main
from rperc.datasets import data_dir
from rperc.slam import PlanarSlam
from rperc.slam.planar import sim_slam_config, simulate
from rperc.slam.rerun_log import RADIUS_95, ellipse_outlines


def test_ellipse_outlines_lie_on_the_95_percent_contour():
    rng = np.random.default_rng(0)
    a = rng.normal(size=(5, 2, 2))
    cov = a @ a.transpose(0, 2, 1) + 0.01 * np.eye(2)
    mean = rng.normal(size=(5, 2))
    out = ellipse_outlines(mean, cov, points=32)
    assert out.shape == (5, 33, 2)
    for m, c, ring in zip(mean, cov, out, strict=True):
        d = ring - m
        d2 = np.einsum("pi,ij,pj->p", d, np.linalg.inv(c), d)
        np.testing.assert_allclose(d2, RADIUS_95**2, rtol=1e-10)
        np.testing.assert_allclose(ring[0], ring[-1], atol=1e-12)  # closed
    assert RADIUS_95**2 == pytest.approx(5.991464547107979, rel=1e-12)  # chi2.ppf(0.95, 2)


def test_a_run_is_saved_as_an_rrd_file(tmp_path):
    pytest.importorskip("rerun")
    from rperc.slam.rerun_log import log_run

    world = {"steps": 200}
    sim = simulate(world, seed=1)
    result = PlanarSlam(sim_slam_config(world)).run(sim.recording)
    path = log_run(result, tmp_path / "run.rrd", truth=sim.truth[:, 1:3], landmarks=sim.landmarks)
    data = path.read_bytes()
    assert data[:4] == b"RRF2" and len(data) > 10_000  # rerun's file magic


DATA = data_dir()


@pytest.mark.skipif(
    DATA is None or not (Path(DATA) / "mrclam6").is_dir(), reason="RPERC_DATA/mrclam6 is absent"
)
def test_cli_rerun_option_writes_the_file(tmp_path):
    pytest.importorskip("rerun")
    out = tmp_path / "mrclam.rrd"
    argv = ["slam", "mrclam", str(Path(DATA) / "mrclam6"), "--span", "0", "60"]
    assert main([*argv, "--rerun", str(out)]) == 0
    assert out.read_bytes()[:4] == b"RRF2"
    assert math.isfinite(out.stat().st_size)


@pytest.mark.parametrize("frames", [0, -3, 2.5, float("nan")])
def test_a_frame_count_below_one_is_refused_by_name(tmp_path, frames):
    # 0 divided by zero; a fraction or NaN logged no robot at all.
    from rperc.slam.rerun_log import log_run

    world = {"steps": 20}
    result = PlanarSlam(sim_slam_config(world)).run(simulate(world, seed=1).recording)
    with pytest.raises(ValueError, match=r"^frames must be a positive integer"):
        log_run(result, tmp_path / "run.rrd", frames=frames)
    assert list(tmp_path.iterdir()) == []
