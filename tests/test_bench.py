"""``rperc bench`` (issue 32): the same rows on one core, a LocalCluster and a real
``tcp://`` cluster; failing runs as error rows; the summary against numpy; each
suite's row against the single command's output for the same input and seed."""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from rperc import bench
from rperc.bench import Task, run_tasks, same_rows
from rperc.bench.tasks import expand_grid, parse_seeds
from rperc.cli import main

distributed = pytest.importorskip("distributed", reason="the cluster extra (rperc[cluster])")


# ---------------------------------------------------------------------------- inputs


@pytest.fixture(scope="module")
def loop_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A short simulated CARMEN log (a corridor loop, 1.2 laps)."""
    from rperc.scansim import write_loop_log

    return write_loop_log(tmp_path_factory.mktemp("laser") / "loop.log", seed=3, laps=1.2)


@pytest.fixture(scope="module")
def otb_corpus(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two OTB-format folders written from the seeded synthetic sequence (PNG frames,
    1-based boxes as OTB writes them)."""
    from PIL import Image

    from rperc.tracking.synthetic import synthetic_sequence

    root = tmp_path_factory.mktemp("otb")
    for name, seed in (("SynA", 1), ("SynB", 2)):
        seq = synthetic_sequence(frames=25, seed=seed)
        (root / name / "img").mkdir(parents=True)
        for k, frame in enumerate(seq.frames):
            Image.fromarray(frame).save(root / name / "img" / f"{k + 1:04d}.png")
        lines = [f"{x + 1:.2f}\t{y + 1:.2f}\t{w:.2f}\t{h:.2f}" for x, y, w, h in seq.boxes]
        (root / name / "groundtruth_rect.txt").write_text("\n".join(lines) + "\n")
    return root


def _tasks(loop_log: Path, otb_corpus: Path) -> list[Task]:
    """A laser grid (2 variants x 2 seeds), trackers (rperc's particle filter and
    OpenCV's CSRT) and one run that fails, as one task list."""
    from rperc.bench.tasks import make_tasks

    tasks = make_tasks("laser", [str(loop_log)], ["plain", "anchor"], [0, 1], [{}])
    folders = [str(otb_corpus / "SynA")]
    more = make_tasks("track", folders, ["color-pf", "csrt"], [5], [{}])
    broken = make_tasks("laser", [str(loop_log.parent / "missing.log")], ["plain"], [0], [{}])
    every = [*tasks, *more, *broken]
    return [
        Task(t.suite, k, t.dataset, t.method, t.seed, t.settings, t.options)
        for k, t in enumerate(every)
    ]


@pytest.fixture(scope="module")
def serial_rows(loop_log: Path, otb_corpus: Path) -> list[dict]:
    return run_tasks(_tasks(loop_log, otb_corpus))


@pytest.fixture(scope="module")
def tcp_cluster(tmp_path_factory: pytest.TempPathFactory):
    """A Dask scheduler and two single-threaded workers started here, on localhost."""
    folder = tmp_path_factory.mktemp("cluster")
    file = folder / "scheduler.json"
    env = {**os.environ, "DASK_DISTRIBUTED__WORKER__DAEMON": "False"}
    common = ["--no-dashboard"]
    procs = [
        subprocess.Popen(
            [
                sys.executable,
                "-m",
                "distributed.cli.dask_scheduler",
                "--host",
                "127.0.0.1",
                "--port",
                "0",
                "--scheduler-file",
                str(file),
                *common,
            ],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            env=env,
        )
    ]
    try:
        deadline = time.monotonic() + 60
        while not file.exists() and time.monotonic() < deadline:
            time.sleep(0.2)
        assert file.exists(), "the dask scheduler did not start"
        for _ in range(2):
            procs.append(
                subprocess.Popen(
                    [
                        sys.executable,
                        "-m",
                        "distributed.cli.dask_worker",
                        "--scheduler-file",
                        str(file),
                        "--nthreads",
                        "1",
                        "--nworkers",
                        "1",
                        # No nanny: one process a worker, which teardown can kill.
                        "--no-nanny",
                        *common,
                    ],
                    stdout=subprocess.DEVNULL,
                    stderr=subprocess.DEVNULL,
                    env=env,
                )
            )
        address = json.loads(file.read_text())["address"]
        with distributed.Client(address, timeout="30s") as client:
            client.wait_for_workers(2, timeout=60)
        yield address
    finally:
        # Killed, not terminated: a worker's graceful close waits on a scheduler that is
        # closing too (seconds, now and then 20), and without a nanny (see above) a
        # worker is one process, so nothing is orphaned.
        for p in procs:
            p.kill()
        for p in procs:
            p.wait(timeout=20)


# ------------------------------------------------------------ schedulers agree


def test_serial_rows_are_complete_and_a_failing_run_is_an_error_row(
    serial_rows: list[dict],
) -> None:
    assert [r["index"] for r in serial_rows] == list(range(len(serial_rows)))
    *good, broken = serial_rows
    assert all(r["error"] == "" for r in good)
    assert broken["error"].startswith(("FileNotFoundError", "OSError", "DatasetFormatError"))
    assert "missing.log" in broken["error"]
    assert "ate_rmse_m" not in broken
    # The others went on: every laser row has its scores.
    assert all(math.isfinite(r["ate_rmse_m"]) for r in good if r["method"] in ("plain", "anchor"))


def test_local_cluster_gives_the_serial_rows(
    serial_rows: list[dict], loop_log: Path, otb_corpus: Path
) -> None:
    rows = run_tasks(_tasks(loop_log, otb_corpus), scheduler="local", workers=2)
    assert same_rows(rows, serial_rows)
    # The time columns are the only ones allowed to differ, and they are there.
    assert all("seconds" in r for r in rows)


def test_tcp_cluster_gives_the_serial_rows(
    serial_rows: list[dict], loop_log: Path, otb_corpus: Path, tcp_cluster: str
) -> None:
    rows = run_tasks(_tasks(loop_log, otb_corpus), scheduler=tcp_cluster)
    assert same_rows(rows, serial_rows)


def test_rows_differ_when_a_seed_differs(serial_rows: list[dict]) -> None:
    """The identity checks above can fail: two seeds of one run give other rows."""
    a, b = serial_rows[0], serial_rows[2]
    assert (a["method"], a["seed"], b["method"], b["seed"]) == ("plain", 0, "plain", 1)
    assert not same_rows([a], [b | {"index": a["index"]}])


# ---------------------------------------------------------------------- summary


def test_summary_against_numpy() -> None:
    rng = np.random.default_rng(4)
    rows = []
    for k in range(48):
        rows.append(
            {
                "index": k,
                "dataset": f"d{k % 2}",
                "method": ["a", "b", "c"][k % 3],
                "seed": k,
                "alpha": [0.1, 0.2][k // 24],
                "score": float(rng.normal()),
                "fps": float(rng.uniform(1, 9)),
                "error": "",
            }
        )
    rows[5]["score"] = math.nan  # a run without a value is left out of its mean
    summary = bench.summarize(rows, ["alpha"])
    assert len(summary) == 2 * 3 * 2
    for g in summary:
        members = [
            r
            for r in rows
            if (r["dataset"], r["method"], r["alpha"]) == (g["dataset"], g["method"], g["alpha"])
        ]
        values = np.array([r["score"] for r in members])
        values = values[np.isfinite(values)]
        assert g["runs"] == len(members)
        assert g["score"]["n"] == len(values)
        assert g["score"]["mean"] == pytest.approx(np.mean(values), rel=1e-12)
        assert g["score"]["sd"] == pytest.approx(np.std(values, ddof=1), rel=1e-12)
        fps = [r["fps"] for r in members]
        assert g["fps"]["mean"] == pytest.approx(np.mean(fps), rel=1e-12)


def test_summary_of_one_run_has_no_sd() -> None:
    rows = [{"index": 0, "dataset": "d", "method": "m", "seed": 0, "x": 2.0, "error": ""}]
    (g,) = bench.summarize(rows)
    assert g["x"] == {"mean": 2.0, "sd": None, "n": 1}


# ------------------------------------------------- rows equal the single commands


def test_track_row_equals_rperc_track(otb_corpus: Path, tmp_path: Path) -> None:
    out = tmp_path / "track.json"
    folder = otb_corpus / "SynB"
    assert (
        main(["track", str(folder), "--tracker", "color-pf", "--seed", "7", "--json", str(out)])
        == 0
    )
    single = json.loads(out.read_text())
    result = bench.track(otb_corpus, sequences=["SynB"], trackers=["color-pf"], seeds=[7])
    (row,) = result.rows
    assert row["dataset"] == single["sequence"] == "SynB"
    for key in ("frames", "auc", "precision_20px", "mean_iou", "lost_frames"):
        assert row[key] == single[key], key


def test_laser_row_equals_rperc_slam_walls(loop_log: Path, tmp_path: Path) -> None:
    out = tmp_path / "walls.json"
    assert (
        main(
            [
                "slam",
                "walls",
                str(loop_log),
                "--anchor",
                "--freeze",
                "50",
                "--seed",
                "2",
                "--json",
                str(out),
            ]
        )
        == 0
    )
    single = json.loads(out.read_text())
    (row,) = bench.laser(loop_log, variants=["anchor+freeze"], seeds=[2]).rows
    for key in (
        "ate_rmse_m",
        "loop_error_m",
        "final_error_m",
        "nees_mean",
        "nees_in_band",
        "scans",
        "walls",
    ):
        assert row[key] == single[key], key


def test_laser_row_on_a_log_whose_scan_times_do_not_increase(
    loop_log: Path, tmp_path: Path
) -> None:
    """Every scan stamped 0 (as orebro.log.gz does): the times are repaired on reading
    and the run does not use them, so the row holds the same scores as the log with
    its times, not an error row (pytest turns the repair's warning into an error)."""
    zeros = tmp_path / "zeros.log"
    lines = [line.split() for line in loop_log.read_text().splitlines()]
    zeros.write_text("".join(" ".join([*tok[:-3], "0", tok[-2], "0"]) + "\n" for tok in lines))
    (row,) = bench.laser(zeros, variants=["plain"], seeds=[0]).rows
    (timed,) = bench.laser(loop_log, variants=["plain"], seeds=[0]).rows
    assert row["error"] == ""
    for key in ("ate_rmse_m", "loop_error_m", "nees_mean", "scans", "walls"):
        assert row[key] == timed[key], key


def test_smoothed_laser_row_equals_the_smoothed_scores(loop_log: Path, tmp_path: Path) -> None:
    out = tmp_path / "walls.json"
    assert (
        main(["slam", "walls", str(loop_log), "--smooth", "--seed", "1", "--json", str(out)]) == 0
    )
    single = json.loads(out.read_text())
    (row,) = bench.laser(loop_log, variants=["smoothed"], seeds=[1]).rows
    for key in ("ate_rmse_m", "loop_error_m", "nees_mean", "nees_in_band"):
        assert row[key] == single[f"smoothed_{key}"], key


def test_mrclam_row_equals_rperc_slam_mrclam(tmp_path: Path) -> None:
    from rperc.datasets import data_dir

    root = data_dir()
    if root is None or not (root / "mrclam6").is_dir():
        pytest.skip("the data folder's mrclam6/ is absent")
    out = tmp_path / "mrclam.json"
    assert (
        main(
            [
                "slam",
                "mrclam",
                str(root / "mrclam6"),
                "--robot",
                "2",
                "--variant",
                "external",
                "--span",
                "0",
                "40",
                "--seed",
                "3",
                "--json",
                str(out),
            ]
        )
        == 0
    )
    single = json.loads(out.read_text())
    (row,) = bench.mrclam(robots=[2], variants=["external"], seeds=[3], span=(0, 40)).rows
    for key in ("ate_m", "ate_aligned_m", "landmark_rmse_aligned_m", "nees_mean", "nees_in_band"):
        assert row[key] == single[key], key


def test_pattern_rows_score_the_tracker_against_the_generated_truth() -> None:
    """The rperc pattern tracker at small steps lands within a pixel; the error row of
    an unknown setting names it."""
    result = bench.pattern(steps=[1.0], trackers=["rperc"], seeds=[0], frames=12, images="")
    (row,) = result.rows
    assert row["error"] == "" and row["images"] == "generated"
    assert row["position_rms_px"] < 1.0 and row["precision_5px"] == 1.0
    # POT-210's numbers: within the 5 px of precision on every frame, as the RMS says.
    assert row["precision_at_5"] == row["precision_at_15"] == 1.0
    assert 0 < row["mean_corner_error_px"] < 5.0
    with pytest.raises(ValueError, match="unknown setting"):
        bench.pattern(steps=[1.0], grid={"no_such_knob": [1]}, seeds=[0], frames=4)


# ------------------------------------------------------------------ the command


def test_cli_writes_rows_summary_and_figure(
    loop_log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    grid = tmp_path / "grid.json"
    grid.write_text(json.dumps({"association": ["nn", "jcbb"]}))
    rows, summary, fig = tmp_path / "rows.csv", tmp_path / "summary.json", tmp_path / "fig.png"
    argv = [
        "bench",
        "laser",
        "--logs",
        str(loop_log),
        "--variants",
        "plain",
        "--seeds",
        "0-2",
        "--config",
        str(grid),
        "--out",
        str(rows),
        "--json",
        str(summary),
        "--plot",
        str(fig),
    ]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert "loop.log" in printed and "± " in printed
    import csv

    with rows.open() as f:
        table = list(csv.DictReader(f))
    assert len(table) == 2 * 3
    assert {r["association"] for r in table} == {"nn", "jcbb"}
    assert {r["seed"] for r in table} == {"0", "1", "2"}
    groups = json.loads(summary.read_text())["groups"]
    for g in groups:
        ates = [float(r["ate_rmse_m"]) for r in table if r["association"] == g["association"]]
        assert g["ate_rmse_m"]["mean"] == pytest.approx(np.mean(ates), rel=1e-12)
        assert g["ate_rmse_m"]["sd"] == pytest.approx(np.std(ates, ddof=1), rel=1e-12)
    assert fig.stat().st_size > 10_000


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--scheduler", "udp://x"], "expected serial, local or tcp"),
        (["--workers", "2"], "--workers sets the size of a local cluster"),
        (["--seeds", "5-2"], "must be 0 <= N <= M"),
        (["--variants", "plain,teleport"], "--variants"),
        (["--out", "rows.xlsx"], "use a .csv, .json or .parquet"),
    ],
)
def test_cli_refuses_bad_options(
    loop_log: Path,
    tmp_path: Path,
    argv: list[str],
    message: str,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.chdir(tmp_path)
    try:
        code = main(["bench", "laser", "--logs", str(loop_log), *argv])
    except SystemExit as exc:  # argparse's own refusals
        code = exc.code
    assert code == 2
    assert message in capsys.readouterr().err


def test_cli_refuses_an_unknown_setting_before_any_run(
    loop_log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    grid = tmp_path / "grid.json"
    grid.write_text('{"straightnes": [0.01]}')
    assert main(["bench", "laser", "--logs", str(loop_log), "--config", str(grid)]) == 2
    err = capsys.readouterr().err
    assert "unknown setting(s) straightnes" in err and "straightness" in err


# ------------------------------------------------------------------- Ctrl-C


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
def test_ctrl_c_cancels_a_cluster_run_and_exits_130(loop_log: Path) -> None:
    code = (
        "import signal, sys\nsignal.signal(signal.SIGINT, signal.default_int_handler)\n"
        "from rperc.cli import main\n"
        f"sys.exit(main(['bench', 'laser', '--logs', {str(loop_log)!r}, '--seeds', '0-400',"
        " '--variants', 'plain,anchor,smoothed', '--scheduler', 'local', '--workers', '2']))\n"
    )
    child = subprocess.Popen([sys.executable, "-c", code], stderr=subprocess.PIPE, text=True)
    assert child.stderr is not None
    # The first progress line says runs are under way on the cluster.
    deadline = time.monotonic() + 120
    seen = ""
    while "bench laser" not in seen and time.monotonic() < deadline:
        seen += child.stderr.readline()
    assert "bench laser" in seen, seen
    child.send_signal(signal.SIGINT)
    start = time.monotonic()
    try:
        rc = child.wait(timeout=60)
        err = seen + child.stderr.read()
    finally:
        child.kill()
        child.stderr.close()
    assert rc == 130, err
    assert "rperc: interrupted" in err
    assert time.monotonic() - start < 30


# ------------------------------------------------------------ grids and seeds


def test_seed_ranges() -> None:
    assert parse_seeds("0-2,7,1") == [0, 1, 2, 7]
    for bad in ("", "a", "3-1", "-1", "0,,2"):
        with pytest.raises(ValueError):
            parse_seeds(bad)


def test_grid_is_every_combination() -> None:
    combos = expand_grid({"a": [1, 2, 3], "b": ["x", "y"], "c": 0.5})
    assert len(combos) == 6
    assert {(c["a"], c["b"], c["c"]) for c in combos} == {
        (a, b, 0.5) for a in (1, 2, 3) for b in ("x", "y")
    }
    assert expand_grid([{"a": 1}, {"a": 2, "b": "z"}]) == [{"a": 1}, {"a": 2, "b": "z"}]
    assert expand_grid(None) == [{}]
    for bad in ({"a": []}, {"a": [[1]]}, {"a": [math.nan]}, "text", [1, 2]):
        with pytest.raises(ValueError):
            expand_grid(bad)  # type: ignore[arg-type]


def test_methods_take_turns_seed_by_seed() -> None:
    """Within a dataset the methods alternate at every seed (a slow spell of the
    machine meets them alike); a tunable method runs each setting in its turn."""
    from rperc.bench.tasks import make_tasks

    tasks = make_tasks(
        "pattern", ["a", "b"], ["ours", "peer"], [3, 4], [{"k": 1}, {"k": 2}], tunable=["ours"]
    )
    order = [(t.dataset, t.seed, t.method, t.kwargs.get("k")) for t in tasks]
    assert order == [
        (d, s, m, k)
        for d in ("a", "b")
        for s in (3, 4)
        for m, ks in (("ours", (1, 2)), ("peer", (None,)))
        for k in ks
    ]
    assert [t.index for t in tasks] == list(range(len(tasks)))


# ------------------------------------------------------------ steady allocator

#: In a fresh interpreter: how many blocks glibc has mapped (mallinfo2's ``hblks``)
#: before and while a 4 MiB array is alive, with the allocator steadied or not.
_MAPPED_BLOCKS = """
import ctypes, sys
import numpy as np
from rperc.bench.allocator import steady_allocator

class MallInfo2(ctypes.Structure):
    _fields_ = [(n, ctypes.c_size_t) for n in
                ("arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks",
                 "fsmblks", "uordblks", "fordblks", "keepcost")]

libc = ctypes.CDLL("libc.so.6")
libc.mallinfo2.restype = MallInfo2
steadied = steady_allocator() if sys.argv[1] == "steady" else False
before = libc.mallinfo2().hblks
block = np.ones(4 << 20, dtype=np.uint8)
print(steadied, before, libc.mallinfo2().hblks)
"""


def _mapped_blocks(mode: str) -> tuple[bool, int, int]:
    out = subprocess.run(
        [sys.executable, "-c", _MAPPED_BLOCKS, mode], capture_output=True, text=True, check=True
    )
    steadied, before, during = out.stdout.split()
    return steadied == "True", int(before), int(during)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's mallopt (Linux)")
def test_the_steady_allocator_serves_frame_sized_arrays_from_the_heap() -> None:
    """glibc's own accounting is the oracle: a fresh interpreter maps a 4 MiB array
    with mmap (one more mapped block), and after ``steady_allocator`` takes it from
    the heap (none more)."""
    try:
        plain = _mapped_blocks("plain")
    except (subprocess.CalledProcessError, AttributeError) as exc:  # no mallinfo2 (musl)
        pytest.skip(f"no glibc mallinfo2: {exc}")
    assert plain[0] is False and plain[2] == plain[1] + 1
    steadied, before, during = _mapped_blocks("steady")
    assert steadied and during == before


def test_the_steady_allocator_is_a_no_op_without_glibc(monkeypatch: pytest.MonkeyPatch) -> None:
    import ctypes

    from rperc.bench import allocator

    def no_libc(*_args: object, **_kw: object) -> None:
        raise OSError("no C library here")

    monkeypatch.setattr(ctypes, "CDLL", no_libc)
    assert allocator.steady_allocator() is False
    monkeypatch.setattr(allocator.sys, "platform", "darwin")
    assert allocator.steady_allocator() is False


def test_a_serial_run_steadies_the_allocator_first(monkeypatch: pytest.MonkeyPatch) -> None:
    from rperc.bench import runner

    calls: list[str] = []
    monkeypatch.setattr(runner, "steady_allocator", lambda: calls.append("steady") or True)
    assert run_tasks([], scheduler="serial") == []
    assert calls == ["steady"]
