"""``rperc demo all`` tells the truth: every number it prints is recomputed here from
the simulated truth with independent code (brute-force loops, closed forms, scipy),
and each capability writes its figure."""

from __future__ import annotations

import contextlib
import dataclasses
import io
import itertools
import json
import math
import re
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
import shapely

from rperc.cli import demo as demo_module
from rperc.cli import lines as lines_cli
from rperc.cli import main
from rperc.cli.demo import Demo, DemoResult
from rperc.linesimp import extract_lines
from rperc.slam import monobot
from rperc.tracking.synthetic import synthetic_sequence

NUMBER = r"([-+]?\d+(?:\.\d+)?)"


@pytest.fixture(scope="module")
def demo_all(tmp_path_factory):
    """One ``rperc demo all`` run (the command ``make demo`` runs), with its stdout,
    stderr, JSON and figures, shared by the checks below."""
    out = tmp_path_factory.mktemp("demo")
    stdout, stderr = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
        code = main(["demo", "all", "--out", str(out), "--json", str(out / "all.json")])
    assert code == 0, stderr.getvalue()
    lines = stdout.getvalue().splitlines()
    summary = {line.split(":", 1)[0]: line for line in lines}
    measured = json.loads((out / "all.json").read_text())["demos"]
    return {"out": out, "lines": lines, "summary": summary, "measured": measured,
            "stderr": stderr.getvalue()}  # fmt: skip


def grab(pattern: str, text: str) -> list[float]:
    match = re.search(pattern, text)
    assert match, f"{pattern!r} not in {text!r}"
    return [float(g) for g in match.groups()]


def test_one_summary_line_and_one_figure_per_capability(demo_all):
    names = [d.name for d in demo_module.registry()]
    assert [line.split(":", 1)[0] for line in demo_all["lines"]] == names
    for name in ("lines", "walls", "tracking", "monobot_fig3_fisher", "monobot_monte_carlo"):
        assert (demo_all["out"] / f"{name}.png").stat().st_size > 10_000
    assert "wrote" not in "\n".join(demo_all["lines"])  # notes go to stderr
    # The JSON keeps the printed lines for the docs' papers page.
    summaries = json.loads((demo_all["out"] / "all.json").read_text())["summaries"]
    assert list(summaries) == names and list(summaries.values()) == demo_all["lines"]
    for path in re.findall(r"wrote (.+)", demo_all["stderr"]):
        assert Path(path).is_file()


def chord_line_distance_brute_force(points: np.ndarray, kept: list[int]) -> float:
    """Max distance of every dropped point to the line through its chord's ends."""
    worst = 0.0
    for a, b in itertools.pairwise(kept):
        (x0, y0), (x1, y1) = points[a], points[b]
        norm = math.hypot(x1 - x0, y1 - y0)
        for i in range(a + 1, b):
            x, y = points[i]
            worst = max(worst, abs((x - x0) * (y1 - y0) - (y - y0) * (x1 - x0)) / norm)
    return worst


def test_lines_deviation_is_recomputed_from_the_input(demo_all):
    line = demo_all["summary"]["lines"]
    n, kept_count, epsilon = grab(rf"spiral of {NUMBER} points simplified to {NUMBER} at "
                                  rf"epsilon {NUMBER} m", line)  # fmt: skip
    (printed,) = grab(rf"from its chord's line {NUMBER} m", line)
    kept = demo_all["measured"]["lines"]["kept_indices"]
    spiral = lines_cli.noisy_spiral(0)
    assert n == len(spiral) and kept_count == len(kept)
    assert kept[0] == 0 and kept[-1] == len(spiral) - 1
    ours = chord_line_distance_brute_force(spiral, kept)
    assert printed == pytest.approx(ours, abs=5e-5)
    assert ours <= epsilon  # Douglas-Peucker's guarantee (seed Table 2)
    assert "within epsilon" in line


def brute_force_beam_counts(walls: np.ndarray, pose: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Beams per wall, one beam and one wall at a time: the nearest wall a beam meets."""
    counts = np.zeros(len(walls), dtype=int)
    for a in angles:
        d = np.array([math.cos(pose[2] + a), math.sin(pose[2] + a)])
        best, best_w = math.inf, -1
        for w, (p, q) in enumerate(walls):
            m = np.column_stack([d, p - q])  # pose + t d = p + s (q - p)
            if abs(np.linalg.det(m)) < 1e-12:
                continue
            t, s = np.linalg.solve(m, p - pose[:2])
            if t > 0 and 0 <= s <= 1 and t < best:
                best, best_w = t, w
        if best_w >= 0:
            counts[best_w] += 1
    return counts


def true_line(p: np.ndarray, q: np.ndarray, pose: np.ndarray) -> tuple[float, float]:
    """(rho, alpha) of the line through world points p, q in the sensor frame."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    rot = np.array([[c, s], [-s, c]])
    a, b = rot @ (p - pose[:2]), rot @ (q - pose[:2])
    n = np.array([a[1] - b[1], b[0] - a[0]]) / np.linalg.norm(b - a)
    rho = float(n @ a)
    if rho < 0:
        n, rho = -n, -rho
    return rho, math.atan2(n[1], n[0])


def test_walls_visibility_and_errors_are_recomputed_from_the_ray_cast(demo_all):
    line = demo_all["summary"]["walls"]
    found_count, visible_count = grab(rf"{NUMBER} of {NUMBER} visible walls found", line)
    hidden_count, total = grab(rf"{NUMBER} of {NUMBER} walls not visible", line)
    d_rho_mm, d_alpha_deg = grab(rf"max \|d rho\| {NUMBER} mm, max \|d alpha\| {NUMBER} deg", line)

    walls, scan = lines_cli.room_scan(0)
    counts = brute_force_beam_counts(walls, scan.pose, scan.angles)
    visible = np.flatnonzero(counts >= lines_cli.WALLS_MIN_POINTS)
    assert total == len(walls)
    assert visible_count == len(visible) and hidden_count == len(walls) - len(visible)
    assert demo_all["measured"]["walls"]["visible"] == visible.tolist()

    found = extract_lines(
        scan.ranges,
        scan.angles,
        max_range=scan.max_range,
        sigma_range=lines_cli.WALLS_SIGMA,
        min_points=lines_cli.WALLS_MIN_POINTS,
    )
    truth = {w: true_line(*walls[w], scan.pose) for w in visible}
    worst_rho = worst_alpha = 0.0
    matched = set()
    for rho, alpha in zip(found.rho, found.alpha, strict=True):
        w = min(truth, key=lambda w: abs(rho - truth[w][0]) + abs(alpha - truth[w][1]))
        d_alpha = (alpha - truth[w][1] + math.pi) % (2 * math.pi) - math.pi
        assert abs(rho - truth[w][0]) < 0.05 and abs(d_alpha) < math.radians(2)
        matched.add(w)
        worst_rho = max(worst_rho, abs(rho - truth[w][0]))
        worst_alpha = max(worst_alpha, abs(d_alpha))
    assert found_count == len(matched) == len(visible)
    assert d_rho_mm == pytest.approx(1e3 * worst_rho, abs=0.051)
    assert d_alpha_deg == pytest.approx(math.degrees(worst_alpha), abs=0.0051)


def test_monobot_ranks_and_monte_carlo_are_recomputed(demo_all):
    from scipy import stats

    line = demo_all["summary"]["monobot"]
    ranks = grab(rf"relative {NUMBER}/2, anchor {NUMBER}/2, external {NUMBER}/2", line)
    assert ranks == [1, 2, 2]  # the paper: relative measurements leave one direction free
    for model, rank in zip(("relative", "anchor", "external"), ranks, strict=True):
        J = monobot.fisher_information(monobot.simulate(model=model, landmarks=1, seed=0))
        assert rank == np.linalg.matrix_rank(J, tol=1e-9 * np.abs(J).max())
    direction = grab(rf"unobservable along \({NUMBER}, {NUMBER}\)", line)
    assert abs(direction[0]) == pytest.approx(1 / math.sqrt(2), abs=0.006)
    assert direction[0] == direction[1]  # (1, 1) / sqrt(2): a common shift of all

    sds = grab(rf"error sd {NUMBER} / {NUMBER} / {NUMBER} mm", line)
    inside = grab(rf"band {NUMBER} / {NUMBER} / {NUMBER}% of steps", line)
    runs = demo_all["measured"]["monobot"]["runs"]
    lo, hi = (stats.chi2.ppf(p, df=2 * runs) / runs for p in (0.025, 0.975))
    for k, model in enumerate(("relative", "anchor", "external")):
        mc = monobot.monte_carlo(model=model, landmarks=1, runs=runs, seed=0, initial_variance=1e-2)
        assert sds[k] == pytest.approx(1e3 * np.std(mc.final_landmark_error, ddof=1), abs=0.051)
        nees = mc.run_nees.mean(axis=0)
        assert inside[k] == round(100 * np.mean((nees >= lo) & (nees <= hi)))


def iou_brute_force(a: np.ndarray, b: np.ndarray) -> Fraction:
    """Exact IoU in rational arithmetic (identical boxes give exactly 1)."""
    ax0, ay0, aw, ah = (Fraction(float(v)) for v in a)
    bx0, by0, bw, bh = (Fraction(float(v)) for v in b)
    w = max(Fraction(0), min(ax0 + aw, bx0 + bw) - max(ax0, bx0))
    h = max(Fraction(0), min(ay0 + ah, by0 + bh) - max(ay0, by0))
    return w * h / (aw * ah + bw * bh - w * h)


def test_tracking_scores_are_recomputed_against_the_generator(demo_all):
    line = demo_all["summary"]["tracking"]
    (frames,) = grab(rf"{NUMBER}-frame synthetic sequence", line)
    truth = synthetic_sequence(int(frames), seed=0).boxes
    for name, m in demo_all["measured"]["tracking"]["trackers"].items():
        auc, precision, mean_iou = grab(
            rf"{re.escape(name)} AUC {NUMBER}, precision@20px {NUMBER}, mean IoU {NUMBER}", line
        )
        boxes = np.asarray(m["boxes"])
        assert boxes.shape == truth.shape
        np.testing.assert_array_equal(boxes[0], truth[0])  # trackers start on the truth
        ious = [iou_brute_force(p, t) for p, t in zip(boxes, truth, strict=True)]
        thresholds = [Fraction(k, 20) for k in range(21)]  # OTB's success curve
        ours_auc = sum(sum(o > t for o in ious) / len(ious) for t in thresholds) / 21
        centre = np.hypot(
            *((boxes[:, :2] + boxes[:, 2:] / 2) - (truth[:, :2] + truth[:, 2:] / 2)).T
        )
        assert auc == pytest.approx(ours_auc, abs=5e-4)
        assert mean_iou == pytest.approx(float(sum(ious) / len(ious)), abs=5e-4)
        assert precision == pytest.approx(np.mean(centre <= 20), abs=5e-4)
        assert precision >= 0.9, f"{name} lost the synthetic target: {line}"


def test_a_new_capability_is_one_registry_entry(tmp_path, capsys, monkeypatch):
    from rperc.plot import save
    from rperc.plot.lines import polyline_figure

    def fake(out: Path, seed: int, size: int = 3) -> DemoResult:
        pts = np.arange(2.0 * size).reshape(-1, 2)
        path = save(polyline_figure([pts], [pts], 0.1, title="fake", unit="m"), out / "fake.png")
        return DemoResult(f"fake: {size} points, seed {seed}", [path], {"size": size})

    from rperc.cli.demo import Option
    from rperc.cli.outputs import count_at_least

    entry = Demo(
        "fake", "a test demo", fake, (Option("--size", "size", count_at_least(2), 4, "n"),)
    )
    monkeypatch.setattr(demo_module, "registry", lambda: (entry,))
    # One process: worker processes would look the demo up in the unpatched registry.
    assert main(["demo", "all", "--out", str(tmp_path), "--seed", "7", "--jobs", "1"]) == 0
    assert capsys.readouterr().out == "fake: 4 points, seed 7\n"
    assert main(["demo", "fake", "--out", str(tmp_path), "--size", "5"]) == 0
    assert capsys.readouterr().out == "fake: 5 points, seed 0\n"
    assert (tmp_path / "fake.png").is_file()


def test_slam_demo_numbers_are_recomputed_from_the_truth(demo_all):
    """The slam line: each variant's ATE of run 0 recomputed as the RMS distance from
    the true position to the estimate at the same event (brute force, no
    interpolation); the band from scipy's chi-square quantiles; the mean NEES from the
    per-run series averaged here."""
    scipy_stats = pytest.importorskip("scipy.stats")
    from rperc.cli.slamrun import DEMO_FIX_EVERY, DEMO_WORLD
    from rperc.slam import PlanarSlam
    from rperc.slam.planar import VARIANTS, monte_carlo, sim_slam_config, simulate

    line = demo_all["summary"]["slam"]
    measured = demo_all["measured"]["slam"]
    runs = measured["runs"]
    ates = grab(r"ATE " + r" / ".join([NUMBER] * 3) + " m", line)
    lo, hi = grab(r"band \[" + NUMBER + ", " + NUMBER + r"\]", line)
    assert lo == pytest.approx(scipy_stats.chi2.ppf(0.025, 3 * runs) / runs, abs=0.006)
    assert hi == pytest.approx(scipy_stats.chi2.ppf(0.975, 3 * runs) / runs, abs=0.006)
    for (name, over), ate in zip(VARIANTS.items(), ates, strict=True):
        world = {**DEMO_WORLD, "fix_every": DEMO_FIX_EVERY} if name == "external" else DEMO_WORLD
        sim = simulate(world, seed=0, run=0)
        result = PlanarSlam(sim_slam_config(world, **over)).run(sim.recording)
        est = {float(t): p[:2] for t, p in zip(result.t, result.pose, strict=True)}
        true = {float(row[0]): row[1:3] for row in sim.truth}
        sq = [float(np.sum((est[t] - xy) ** 2)) for t, xy in true.items()]
        assert ate == pytest.approx(math.sqrt(sum(sq) / len(sq)), abs=6e-4)
        mc = monte_carlo(world, slam=sim_slam_config(world, **over), runs=runs, seed=0)
        mean = float(np.mean([np.mean(mc.run_nees[:, k]) for k in range(mc.run_nees.shape[1])]))
        assert measured[name]["mean_nees"] == pytest.approx(mean, rel=1e-12)
        text = grab(name + " " + NUMBER + " \\(" + NUMBER + "% in band\\)", line)
        assert text[0] == pytest.approx(mean, abs=0.006)
    assert (demo_all["out"] / "slam_variants.png").stat().st_size > 10_000


def test_slam_demo_smoothed_numbers_are_recomputed_from_the_truth(demo_all):
    """The smoothed run's ATE in the slam line: run 0 smoothed here, its pose at each
    true time found by exact time (every truth row's time is a smoothed pose's: the
    sightings' and the controls' times coincide in the simulation) and the RMS
    distance taken by brute force; below the filter's, as smoothing must."""
    from rperc.cli.slamrun import DEMO_WORLD
    from rperc.slam import PlanarSlam
    from rperc.slam.planar import sim_slam_config, simulate
    from rperc.slam.smoothing import smooth

    line = demo_all["summary"]["slam"]
    (printed,) = grab(r"smoothed ATE " + NUMBER + " m", line)
    sim = simulate(DEMO_WORLD, seed=0, run=0)
    rec = sim.recording
    result = PlanarSlam(sim_slam_config(DEMO_WORLD)).run(rec)
    times = np.unique(np.r_[result.t[0], rec.detections[:, 0]])
    sm = smooth(result, rec.controls, times, detections=rec.detections)
    est = {float(t): p[:2] for t, p in zip(sm.times, sm.pose, strict=True)}
    true = {float(row[0]): row[1:3] for row in sim.truth}
    sq = [float(np.sum((est[t] - xy) ** 2)) for t, xy in true.items() if t in est]
    assert len(sq) > 0.9 * len(true)
    assert printed == pytest.approx(math.sqrt(sum(sq) / len(sq)), abs=6e-4)
    assert printed < demo_all["measured"]["slam"]["smoothed"]["filter_ate_m"]
    assert (demo_all["out"] / "slam_smoothed.png").stat().st_size > 10_000


def test_color_shape_contour_iou_is_recomputed_against_the_generator(demo_all):
    from rperc.tracking.shape_sequences import shape_sequence

    line = demo_all["summary"]["color-shape"]
    (frames, seed, printed) = grab(
        rf"\({NUMBER} frames, seed {NUMBER}\) against its truth masks: color-shape contour "
        rf"IoU {NUMBER}",
        line,
    )
    seq = shape_sequence("rectangle", frames=int(frames), seed=int(seed))
    contours = demo_all["measured"]["color-shape"]["contours"]
    assert len(contours) == len(seq)
    # Oracle: shapely's area of each contour against the truth rectangle (pixel j spans
    # [j, j + 1), so a pixel-centre contour is shifted by half a pixel).
    ious = []
    for c, m in zip(contours[1:], seq.masks[1:], strict=True):
        ys, xs = np.nonzero(m)
        truth = shapely.box(xs.min(), ys.min(), xs.max() + 1, ys.max() + 1)
        poly = shapely.Polygon(np.asarray(c) + 0.5).buffer(0)
        ious.append(poly.intersection(truth).area / poly.union(truth).area)
    # Rasterised IoU (printed) and exact areas differ by the boundary pixels only.
    assert printed == pytest.approx(np.mean(ious), abs=0.03)
    # Each experiment's loss and re-acquisition counts from its per-frame lost flags: a
    # re-acquisition is a lost frame followed by a tracked one.
    for name, run in demo_all["measured"]["color-shape"]["experiments"].items():
        lost, found, fps = grab(
            rf"{name} experiment .*?lost in {NUMBER} frames, re-acquired {NUMBER} times, "
            rf"{NUMBER} fps",
            line,
        )
        flags = run["lost"]
        assert len(flags) == int(frames) - 1
        assert lost == sum(flags)
        assert found == sum(1 for k in range(1, len(flags)) if flags[k - 1] and not flags[k])
        assert fps == pytest.approx(run["fps"], abs=0.5)


def test_pattern_fig8_errors_are_recomputed_against_the_generator(demo_all):
    from rperc.cli.pattern import demo_images
    from rperc.tracking import pattern_sequence

    line = demo_all["summary"]["pattern"]
    frames, seed = grab(rf"\({NUMBER} frames, seed {NUMBER}, steps to 4 sigma\)", line)
    pos, ang, scl, lost = grab(
        rf"RMS {NUMBER} px, {NUMBER} deg, {NUMBER} % scale, lost {NUMBER}", line
    )
    patch, background = demo_images(int(seed))
    truth = pattern_sequence(
        patch, background, n_frames=int(frames), seed=int(seed), max_step_sigmas=4.0
    ).truth
    est = np.asarray(demo_all["measured"]["pattern"]["estimates"])
    assert est.shape == (len(truth) - 1, 4)
    sigma = (5.0, 5.0, math.radians(3.0), 0.1)
    sq: list[tuple[float, float, float]] = []
    for k in range(1, len(truth)):  # frame k sweeps component (k - 1) % 4
        d = (k - 1) % 4
        if abs(truth[k][d] - truth[k - 1][d]) / sigma[d] > 3.0:
            continue
        e, t = est[k - 1], truth[k]
        sq.append(
            (
                (e[0] - t[0]) ** 2 + (e[1] - t[1]) ** 2,
                math.degrees(e[2] - t[2]) ** 2,
                (100 * (e[3] / t[3] - 1)) ** 2,
            )
        )
    rms = [math.sqrt(sum(v[i] for v in sq) / len(sq)) for i in range(3)]
    assert pos == pytest.approx(rms[0], abs=0.006)
    assert ang == pytest.approx(rms[1], abs=0.006)
    assert scl == pytest.approx(rms[2], abs=0.06)
    assert lost == demo_all["measured"]["pattern"]["lost"]
    table = (demo_all["out"] / "pattern_harness.txt").read_text()
    for name in ("rperc pattern", "ECC affine", "ECC euclidean", "matchTemplate", "CSRT"):
        assert name in table
    # Every harness row is scored on at least one frame.
    assert all(row["frames"] >= 1 for row in demo_all["measured"]["pattern"]["harness"])


def test_wall_slam_demo_numbers_are_recomputed_from_the_truth(demo_all):
    """The wall-slam line: each run's ATE and loop error recomputed against the
    simulator's true path (scansim.loop_path, not the log's rounded poses) by brute
    force: the RMS position error over the scans, and for every scan the nearest
    earlier scan within 1 m after more than 10 m of path, searched here in a loop."""
    from rperc.cli.wallslam import DEMO_RUNS
    from rperc.datasets.carmen import load_carmen
    from rperc.scansim import loop_path, write_loop_log
    from rperc.slam.wallslam import run_walls

    line = demo_all["summary"]["wall-slam"]
    ates = grab(r"ATE " + r" / ".join([NUMBER] * 4) + " m", line)
    loops = grab(r"loop error " + r" / ".join([NUMBER] * 4) + " m", line)
    truth = loop_path()
    travelled = [0.0]
    for a, b in itertools.pairwise(truth):
        travelled.append(travelled[-1] + math.dist(a[:2], b[:2]))
    pairs = []
    for j in range(len(truth)):
        near = [(math.dist(truth[i, :2], truth[j, :2]), i) for i in range(j)
                if travelled[j] - travelled[i] > 10.0]  # fmt: skip
        if near and min(near)[0] < 1.0:
            pairs.append((min(near)[1], j))
    log = load_carmen(write_loop_log(demo_all["out"] / "wall_slam_check.log", seed=0))
    runs = [*DEMO_RUNS.items(), ("plain, smoothed", {"smooth": True})]
    for (name, kwargs), ate, loop in zip(runs, ates, loops, strict=True):
        res = run_walls(log, seed=0, **kwargs)
        est = res.smoothed().pose if name == "plain, smoothed" else res.pose
        sq = [math.dist(p[:2], q[:2]) ** 2 for p, q in zip(est, truth, strict=True)]
        assert ate == pytest.approx(math.sqrt(sum(sq) / len(sq)), abs=6e-4), name
        gaps = [math.dist(est[j, :2] - est[i, :2], truth[j, :2] - truth[i, :2]) for i, j in pairs]
        assert loop == pytest.approx(sum(gaps) / len(gaps), abs=6e-4), name
    # Fig. 7's claim on this loop: the wall map closes the loop far better than odometry.
    assert max(loops[1:]) < loops[0] / 10
    assert (demo_all["out"] / "wall_slam_fig7.png").stat().st_size > 10_000


def test_visual_memory_demo_scores_its_own_replays(demo_all):
    """The success rate is the share of replays that reached B, recounted from the
    outcomes; the figure and the replay strip exist."""
    m = demo_all["measured"]["visual-memory"]
    outcomes = m["outcomes"]
    assert m["starts"] == len(outcomes) == 10
    assert m["success_rate"] == pytest.approx(outcomes.count("reached") / len(outcomes))
    for key in ("localization_error_cm", "localization_error_deg", "final_error_cm", "hz"):
        assert np.isfinite(m[key])
    assert (demo_all["out"] / "visual_memory.png").stat().st_size > 10_000
    assert (demo_all["out"] / "replay_strip.png").is_file()


@pytest.mark.parametrize(
    ("old", "new"), [("wall_slam", "wall-slam"), ("color_shape", "color-shape")]
)
def test_deprecated_demo_names_still_parse_to_the_kebab_case_demo(old, new):
    """Demo names are kebab-case like every other command; the old spellings stay for
    one release and reach the same demo."""
    from rperc.cli import build_parser

    parser = build_parser()
    assert parser.parse_args(["demo", old]).demo_entry.name == new
    assert parser.parse_args(["demo", new]).demo_entry.name == new
    assert all("_" not in d.name for d in demo_module.registry())


def test_demos_in_worker_processes_print_and_measure_what_one_process_does(tmp_path, monkeypatch):
    """``demo all --jobs 2`` runs the demos in two processes, longest first, and must
    print the same lines in the registry's order, with the same measured figures, as
    ``--jobs 1`` (timings aside). Three short demos stand in for the registry (the
    workers find each by name in the full one)."""
    chosen = [d for d in demo_module.registry() if d.name in ("lines", "walls", "tracking")]
    # tracking, last here, is started first (the longest) and ends last; lines and walls
    # end in the other order than they are printed.
    weights = (0.1, 0.2, 5.0)
    chosen = [dataclasses.replace(d, seconds=s) for d, s in zip(chosen, weights, strict=True)]
    monkeypatch.setattr(demo_module, "registry", lambda: tuple(chosen))
    runs = {}
    for jobs in (1, 2):
        out = tmp_path / f"jobs{jobs}"
        stdout, stderr = io.StringIO(), io.StringIO()
        argv = ["demo", "all", "--out", str(out), "--json", str(out / "all.json")]
        with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
            assert main([*argv, "--jobs", str(jobs)]) == 0, stderr.getvalue()
        measured = _untimed(json.loads((out / "all.json").read_text())["demos"])
        figures = sorted(p.name for p in out.glob("*.png"))
        runs[jobs] = (stdout.getvalue().splitlines(), measured, figures)
        assert [line.split(":")[0] for line in runs[jobs][0]] == ["lines", "walls", "tracking"]
        assert len(re.findall(r"wrote (.+\.png)", stderr.getvalue())) == len(figures)
    assert runs[1][1:] == runs[2][1:]
    # The summary lines agree but for the measured speeds some of them print.
    speeds = re.compile(r"\d+(?:\.\d+)? (?:fps|Hz|s)\b")
    assert [speeds.sub("#", x) for x in runs[1][0]] == [speeds.sub("#", x) for x in runs[2][0]]


def _untimed(value):
    """``value`` without its timings (keys ``seconds*``, ``fps``, ``hz``), recursively."""
    if isinstance(value, dict):
        timing = ("fps", "hz")
        return {
            k: _untimed(v) for k, v in value.items() if not (k.startswith("seconds") or k in timing)
        }
    if isinstance(value, list):
        return [_untimed(v) for v in value]
    return value


def test_a_worker_that_dies_is_a_one_line_error_not_a_hang(tmp_path):
    """A script without the ``__main__`` guard re-runs itself in each spawned worker,
    which then fails to start; ``demo all`` must say so in one line and exit 2, at once."""
    import subprocess
    import sys

    script = tmp_path / "unguarded.py"
    script.write_text(
        "import sys\nfrom rperc.cli import main\n"
        f"sys.exit(main(['demo', 'all', '--out', {str(tmp_path / 'out')!r}, '--jobs', '2']))\n"
    )
    done = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, timeout=120, cwd=tmp_path
    )
    assert done.returncode == 2, done.stderr
    (line,) = [x for x in done.stderr.splitlines() if x.startswith("rperc: error:")]
    assert "demo worker process ended abruptly" in line and "--jobs 1" in line
    assert done.stdout == ""  # no demo finished


def test_laser_slam_scores_are_recomputed_from_the_truth(demo_all):
    """The laser-slam line's two ATEs are the simulated truth's (ATE written out
    here), its wall count is the walls run's, and the mapped walls' ends lie within
    5 cm of the line of the simulator's nearest wall."""
    from rperc.datasets.carmen import load_carmen
    from rperc.scansim import loop_walls, write_loop_log
    from rperc.slam.laser import run_laser

    line = demo_all["summary"]["laser-slam"]
    ates = grab(r"ATE " + NUMBER + " / " + NUMBER + " m", line)
    (walls,) = grab(NUMBER + r" walls", line)
    log = load_carmen(write_loop_log(demo_all["out"] / "laser_check.log", seed=0))
    truth = np.asarray(log.scans.pose)
    for variant, printed in zip(("loops", "walls"), ates, strict=True):
        r = run_laser(log, seed=0, variant=variant)
        d = r.pose[:, :2] - truth[:, :2]
        assert printed == pytest.approx(math.sqrt(np.mean(np.sum(d**2, axis=1))), abs=6e-4)
    assert walls == len(r.walls) > 0
    sides = loop_walls().reshape(-1, 4)
    for x0, y0, x1, y1 in r.walls:
        mid = np.array([(x0 + x1) / 2, (y0 + y1) / 2])
        best = min(sides, key=lambda w: shapely.LineString(w.reshape(2, 2)).distance(
            shapely.Point(mid)))  # fmt: skip
        (ax, ay), (bx, by) = best.reshape(2, 2)
        for px, py in ((x0, y0), (x1, y1)):
            off = abs((px - ax) * (by - ay) - (py - ay) * (bx - ax)) / math.hypot(bx - ax, by - ay)
            assert off < 0.05
    assert (demo_all["out"] / "laser_slam.png").stat().st_size > 10_000
