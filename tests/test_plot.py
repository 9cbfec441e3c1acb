"""rperc.plot: leaves the matplotlib backend alone, writes exactly the file asked for,
keeps outliers from setting axis limits, labels every axis with its unit, says which
artist is the estimate and which the truth, and splits walls into visible and hidden
exactly as a brute-force count of the beams does."""

from __future__ import annotations

import math
import os
import re
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from rperc.linesimp import extract_lines
from rperc.plot import figure_format, outside, robust_limits, save
from rperc.plot.lines import MAX_MARKERS, polyline_figure, walls_figure, world_walls_figure
from rperc.plot.monobot import fisher_figure, monte_carlo_figure, run_figure
from rperc.plot.tracking import strip_figure
from rperc.scansim import check_walls, ray_cast, room_walls
from rperc.slam import monobot

ANGLES = np.linspace(-math.pi / 2, math.pi / 2, 181)


def test_importing_rperc_plot_leaves_the_backend_alone():
    """In a fresh interpreter whose backend is svg, importing every plot module and
    building a figure neither switches the backend nor imports pyplot."""
    script = (
        "import sys, matplotlib\n"
        "before = matplotlib.get_backend()\n"
        "import numpy as np, rperc.plot, rperc.plot.lines, rperc.plot.monobot, "
        "rperc.plot.tracking\n"
        "pts = np.c_[np.arange(5.0), np.zeros(5)]\n"
        "rperc.plot.lines.polyline_figure([pts], [pts[[0, 4]]], 0.1, title='t', unit='m')\n"
        "print(before, matplotlib.get_backend(), 'matplotlib.pyplot' in sys.modules)\n"
    )
    env = {**os.environ, "MPLBACKEND": "svg"}
    run = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, env=env, check=True
    )
    assert run.stdout.split() == ["svg", "svg", "False"]


def test_save_writes_exactly_the_path_or_refuses(tmp_path):
    fig = polyline_figure([np.eye(2)], [np.eye(2)], 0.1, title="t", unit="m")
    assert save(fig, tmp_path / "a.png") == tmp_path / "a.png"
    assert (tmp_path / "a.png").read_bytes()[:4] == b"\x89PNG"
    save(fig, tmp_path / "a.svg")
    assert b"<svg" in (tmp_path / "a.svg").read_bytes()[:400]
    with pytest.raises(ValueError, match="must end in one of"):
        save(fig, tmp_path / "noext")  # matplotlib would write noext.png instead
    with pytest.raises(FileNotFoundError, match=r"folder .*missing does not exist"):
        save(fig, tmp_path / "missing" / "a.png")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.png", "a.svg"]
    assert figure_format("X.PDF") == "pdf"


@given(
    st.integers(0, 2**32 - 1),
    st.lists(st.floats(30, 80), min_size=1, max_size=8),
)
def test_robust_limits_ignore_planted_outliers(seed, distances):
    """A thousand points in a 10 x 6 room and up to 8 strays 30-80 m out (under 1 %):
    the limits hug the room, and ``outside`` counts exactly the strays."""
    rng = np.random.default_rng(seed)
    room = rng.uniform((0, 0), (10, 6), size=(1000, 2))
    bearings = rng.uniform(0, 2 * np.pi, size=len(distances))
    strays = np.c_[np.cos(bearings), np.sin(bearings)] * np.asarray(distances)[:, None] + (5, 3)
    pts = np.concatenate([room, strays])
    trajectory = np.array([[1.0, 1.0], [9.0, 5.0]])
    (x0, x1), (y0, y1) = robust_limits(pts, include=trajectory)
    assert -1.0 < x0 <= 1.0 and 9.0 <= x1 < 11.0
    assert -1.0 < y0 <= 1.0 and 5.0 <= y1 < 7.0
    brute = sum(not (x0 <= x <= x1 and y0 <= y <= y1) for x, y in pts)
    assert outside(pts, ((x0, x1), (y0, y1))) == brute >= len(distances)


def test_robust_limits_always_keep_the_included_points():
    pts = np.random.default_rng(0).normal(size=(500, 2))
    far = np.array([[40.0, -25.0]])
    (x0, x1), (y0, y1) = robust_limits(pts, include=far)
    assert x0 < -1 and x1 > 40 and y0 < -25 and y1 > 1
    with pytest.raises(ValueError, match="finite"):
        robust_limits(np.full((3, 2), np.nan))


def test_world_walls_figure_is_not_scaled_by_stray_returns():
    walls = room_walls()
    scan = ray_cast(walls, np.array([4.0, 2.5, 0.3]), ANGLES)
    pts = np.c_[scan.ranges * np.cos(ANGLES + 0.3), scan.ranges * np.sin(ANGLES + 0.3)] + (4, 2.5)
    strays = np.array([[60.0, 2.0], [-30.0, 50.0]])
    fig = world_walls_figure(
        np.concatenate([pts, strays]), walls, np.array([[4.0, 2.5]]), title="t"
    )
    ax = fig.axes[0]
    assert ax.get_xlim()[1] < 12 and ax.get_ylim()[1] < 8
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "2 stray readings outside the shown area" in labels


def test_a_long_simplification_is_drawn_without_markers():
    """The 4,688-vertex coastline case: markers only when there are few points."""
    t = np.linspace(0, 20, 5000)
    line = np.c_[t, np.sin(t)]
    for kept, marker in ((line[::1], "None"), (line[:: len(line) // 20], "o")):
        ax = polyline_figure([line], [kept], 0.01, title="t", unit="deg").axes[0]
        simplified = [ln for ln in ax.get_lines() if ln.get_label().startswith("simplified")]
        assert len(simplified) == 1 and simplified[0].get_marker() == marker
        assert (len(kept) > MAX_MARKERS) == (marker == "None")


def brute_force_visible(walls, pose, angles, min_points):
    counts = np.zeros(len(walls), dtype=int)
    for a in angles:
        d = np.array([math.cos(pose[2] + a), math.sin(pose[2] + a)])
        hits = []
        for w, (p, q) in enumerate(walls):
            m = np.column_stack([d, p - q])
            if abs(np.linalg.det(m)) > 1e-12:
                t, s = np.linalg.solve(m, p - pose[:2])
                if t > 0 and 0 <= s <= 1:
                    hits.append((t, w))
        if hits:
            counts[min(hits)[1]] += 1
    return set(np.flatnonzero(counts >= min_points).tolist())


def in_free_space(x: float, y: float) -> bool:
    cabinet = 5.9 <= x <= 8.1 and 3.9 <= y <= 5.1
    pillar = 2.4 <= x <= 3.1 and 1.4 <= y <= 2.1
    return not (cabinet or pillar)


@settings(max_examples=40)  # each example draws a figure: keep the suite quick
@given(
    st.floats(0.3, 9.7),
    st.floats(0.3, 5.7),
    st.floats(-math.pi, math.pi),
    st.integers(0, 2**32 - 1),
)
def test_walls_figure_splits_visible_and_hidden_like_a_beam_count(x, y, theta, seed):
    assume(in_free_space(x, y))
    walls, pose = room_walls(), np.array([x, y, theta])
    scan = ray_cast(walls, pose, ANGLES, sigma_range=0.01, rng=np.random.default_rng(seed))
    found = extract_lines(scan.ranges, scan.angles, max_range=scan.max_range, min_points=6)
    check = check_walls(walls, scan, found.indices, found.rho, found.alpha, min_points=6)
    fig = walls_figure(walls, scan, found, check, title="t")
    kinds: dict[str, set[int]] = {"hidden": set(), "visible": set(), "missed": set()}
    for line in fig.axes[0].get_lines():
        gid = line.get_gid()
        if gid and (m := re.fullmatch(r"wall(\d+):(\w+)", gid)):
            kinds[m.group(2)].add(int(m.group(1)))
    visible = brute_force_visible(walls, pose, ANGLES, 6)
    assert kinds["visible"] | kinds["missed"] == visible
    assert kinds["hidden"] == set(range(len(walls))) - visible
    assert not kinds["visible"] & kinds["missed"]
    labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    if kinds["hidden"]:
        assert "true wall, not visible from here" in labels


def axes_with_data(fig: Figure) -> list[Axes]:
    """Axes that plot quantities: not image panels, not the table beside the map."""
    return [ax for ax in fig.axes if ax.axison and not ax.get_images()]


def figures_of_every_kind() -> dict[str, tuple[Figure, tuple[str, str]]]:
    """One figure of each plotting function, with words its legend must hold for the
    truth and for the estimate."""
    walls = room_walls()
    scan = ray_cast(walls, np.array([4.0, 2.5, 0.3]), ANGLES, sigma_range=0.01,
                    rng=np.random.default_rng(0))  # fmt: skip
    found = extract_lines(scan.ranges, scan.angles, max_range=scan.max_range)
    check = check_walls(walls, scan, found.indices, found.rho, found.alpha, min_points=6)
    run = monobot.simulate(model="anchor", landmarks=2, seed=0)
    mc = monobot.monte_carlo(model="relative", landmarks=1, runs=10, seed=0)
    frames = [np.zeros((20, 30, 3), dtype=np.uint8)] * 2
    truth = np.array([[2.0, 2, 10, 10], [3, 3, 10, 10], [4, 4, 10, 10]])
    line = np.c_[np.arange(10.0), np.arange(10.0) % 2]
    return {
        "polyline": (polyline_figure([line], [line[::3]], 1.0, title="t", unit="m"),
                     ("input", "simplified")),
        "walls": (walls_figure(walls, scan, found, check, title="t"), ("true wall", "estimated")),
        "world": (world_walls_figure(line, walls[:2], line, title="t"),
                  ("logged", "estimated walls")),
        "fisher": (fisher_figure([run]), ("computed", "landmarks")),
        "run": (run_figure(run), ("truth", "estimate")),
        "monte_carlo": (monte_carlo_figure([mc]), ("truth", "fit")),
        "strip": (strip_figure(frames, [0, 2], truth, {"color": truth + 1}, title="t"),
                  ("truth", "tracker color")),
    }  # fmt: skip


def test_every_axis_has_a_label_with_its_unit_and_every_figure_a_legend():
    for name, (fig, (truth_word, estimate_word)) in figures_of_every_kind().items():
        for ax in axes_with_data(fig):
            for label in (ax.get_xlabel(), ax.get_ylabel()):
                assert re.search(r"\[.+\]", label), f"{name}: axis label {label!r} has no unit"
        legends = [
            t.get_text()
            for legend in [*(ax.get_legend() for ax in fig.axes), *fig.legends]
            if legend
            for t in [legend.get_title(), *legend.get_texts()]
        ]
        assert any(truth_word in t for t in legends), (name, legends)
        assert any(estimate_word in t for t in legends), (name, legends)


def test_strip_title_carries_each_trackers_score():
    truth = np.array([[0.0, 0, 10, 10], [0, 0, 10, 10], [0, 0, 10, 10], [0, 0, 10, 10]])
    pred = truth + np.array([[0, 0, 0, 0], [5, 0, 0, 0], [0, 0, 0, 0], [20, 0, 0, 0]])
    frames = [np.zeros((40, 40, 3), dtype=np.uint8)] * 2
    fig = strip_figure(frames, [0, 3], truth, {"color-pf": pred}, title="seq")
    ious = [1.0, 50 / 150, 1.0, 0.0]  # by hand: a 5-px shift of a 10-px box
    auc = np.mean([np.mean(np.asarray(ious) > k / 20) for k in range(21)])
    title = fig.get_suptitle()
    assert "color-pf" in title and f"AUC {auc:.3f}" in title
    assert f"mean IoU {np.mean(ious):.2f}" in title


def test_the_tracking_strip_draws_every_box_visibly_and_lists_only_drawn_lines():
    frames = [np.zeros((20, 20, 3), np.uint8)] * 2
    truth = np.array([[2.0, 2, 10, 10], [3, 3, 10, 10], [4, 4, 10, 10]])
    tracks = {"color": truth.copy(), "color-pf": truth.copy()}  # all boxes on the truth
    fig = strip_figure(frames, [0, 2], truth, tracks, title="t")
    panel = fig.axes[0]
    styles = {(p.get_linewidth(), p.get_linestyle()) for p in panel.patches}
    # Boxes that coincide stay apart by width or dash, the truth widest underneath.
    assert len(styles) == len(panel.patches) == 3
    assert max(panel.patches, key=lambda p: p.get_linewidth()).get_zorder() == min(
        p.get_zorder() for p in panel.patches
    )
    iou = fig.axes[-1]
    drawn = {line.get_label() for line in iou.lines}
    listed = {t.get_text() for t in iou.get_legend().get_texts()}
    assert listed <= drawn


def test_a_slam_map_shows_its_sparse_edge_landmarks_and_cuts_only_far_strays():
    # Victoria Park's trees thin out at the map's edges: those few landmarks sit past
    # the bulk's percentiles, and the map cut them. A diverged estimate far out may be
    # cut, and the title says so.
    from types import SimpleNamespace

    from rperc.plot.slam import map_figure

    rng = np.random.default_rng(0)
    path = np.c_[rng.uniform(0, 100, (1000, 2)), np.zeros(1000)]
    dense = rng.uniform(0, 100, (300, 2))
    edges = np.array([[-30.0, 50], [130, 50], [50, -30], [50, 130]]).repeat(4, axis=0)
    edges += rng.normal(0, 1, edges.shape)
    stray = np.array([[5000.0, 5000.0]])
    marks = np.concatenate([dense, edges, stray])
    run = SimpleNamespace(
        pose=path, landmark_mean=marks, landmark_covariance=np.tile(np.eye(2), (len(marks), 1, 1))
    )
    ax = map_figure([("plain", run)], title="t").axes[0]
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    shown = marks[:-1]
    assert (shown[:, 0] > x0).all() and (shown[:, 0] < x1).all()
    assert (shown[:, 1] > y0).all() and (shown[:, 1] < y1).all()
    assert x1 < 1000 and "1 stray" in ax.get_title()


def test_wall_maps_draw_the_true_walls_under_the_estimated_ones():
    from types import SimpleNamespace

    from rperc.plot.wallslam import wall_maps_figure
    from rperc.scansim import loop_walls

    truth = loop_walls()
    path = np.c_[np.linspace(2, 14, 50), np.full(50, 2.0), np.zeros(50)]
    res = SimpleNamespace(
        reference=path, pose=path, wall_ends=truth + 0.01,
        metrics={"ate_rmse": 0.0, "loop_error": 0.0},
    )  # fmt: skip
    (ax,) = wall_maps_figure([("plain", res)], true_walls=truth).axes
    true_layer = next(c for c in ax.collections if np.allclose(c.get_segments(), truth))
    estimate = next(c for c in ax.collections if c is not true_layer)
    assert true_layer.get_zorder() < estimate.get_zorder()
    assert "walls (truth)" in [t.get_text() for t in ax.get_legend().get_texts()]
