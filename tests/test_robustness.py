"""Issue 15's reproducers that are fixed: each used to abort, hang or give a silently
wrong number. Each runs in a subprocess with a time limit, so a regression to an
abort or a hang fails the test instead of killing the run."""

from __future__ import annotations

import re
import subprocess
import sys
import textwrap

import pytest

from rperc import NumericalError


def run(code: str, timeout: float = 60.0) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)],
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )


@pytest.mark.parametrize(
    ("code", "error", "message"),
    [
        (
            "import numpy as np; from rperc.tracking import resample; "
            "resample(np.ones(2) / 2, 2**40)",
            "MemoryError",
            "'n' = 1099511627776 would need",
        ),
        (
            "import numpy as np; from rperc.tracking import resample; "
            "resample(np.ones(2) / 2, 2**62)",
            "MemoryError",
            "'n' =",
        ),
        (
            "from rperc.slam import monobot; "
            "monobot.observability_rank(model='anchor', landmarks=100000)",
            "MemoryError",
            "'landmarks'",
        ),
        (
            "from rperc.slam import monobot; monobot.simulate(landmarks=200000, steps=1)",
            "MemoryError",
            "'landmarks and steps'",
        ),
        (
            "import numpy as np; from rperc.tracking import ParticleColorTracker; "
            "f = np.zeros((40, 40, 3), np.uint8); "
            "ParticleColorTracker(f, (5, 5, 10, 10), n_particles=10**13)",
            # Issue 38: a count beyond MAX_PARTICLES is a bad value, named, not a
            # request the allocator refuses.
            "ValueError",
            "'n_particles': must be in 1..=1000000",
        ),
        (
            "import numpy as np; from rperc.slam import Ekf; "
            "e = Ekf(np.zeros(3), np.eye(3), 3, 2); "
            "e.predict(np.zeros(3), np.eye(3) * 1e200, np.eye(3), np.eye(3))",
            "NumericalError",
            "predict",
        ),
        (
            "import numpy as np; from rperc.linesimp import extract_lines; "
            "a = np.radians(np.arange(-45.0, 46.0)); a[[10, 11]] = a[[11, 10]]; "
            "extract_lines(2 / np.cos(a), a)",
            "ValueError",
            "strictly monotonic",
        ),
    ],
)
def test_a_bad_size_or_value_is_an_exception_not_an_abort(code, error, message):
    out = run(code)
    assert out.returncode == 1, (out.returncode, out.stderr[-2000:])
    last = out.stderr.strip().splitlines()[-1]
    assert error in last and message in last, last


def test_a_diverged_prediction_leaves_the_filter_unchanged():
    import numpy as np

    import rperc
    from rperc.slam import Ekf

    ekf = Ekf(np.zeros(5), np.eye(5), 3, 2)
    before = (ekf.state, ekf.covariance)
    with pytest.raises(rperc.NumericalError, match="predict"):
        ekf.predict(np.ones(3), np.eye(3) * 1e200, np.eye(3), np.eye(3))
    np.testing.assert_array_equal(ekf.state, before[0])
    np.testing.assert_array_equal(ekf.covariance, before[1])


def test_nees_band_of_huge_dof_is_fast_and_ordered():
    """dof * runs beyond 2**64 neither overflows nor hangs (it used to, for minutes)."""
    out = run(
        "from rperc.slam import nees_bounds; lo, hi = nees_bounds(2**62 + 1, 4, 0.95); "
        "print(lo < 2**62 + 1 < hi)",
        timeout=20,
    )
    assert out.stdout.strip() == "True", out.stderr[-2000:]


def test_nees_band_matches_scipy_to_1e9_at_large_dof():
    from scipy.stats import chi2

    from rperc.slam import nees_bounds

    for dof, runs in [(10**6, 10**6), (1, 10**9), (6, 100)]:
        lo, hi = nees_bounds(dof, runs, 0.95)
        k = dof * runs
        assert lo == pytest.approx(chi2.ppf(0.025, k) / runs, rel=1e-9)
        assert hi == pytest.approx(chi2.ppf(0.975, k) / runs, rel=1e-9)


def test_threads_are_capped_and_still_correct():
    import numpy as np

    from rperc.linesimp import simplify, simplify_many

    pts = np.cumsum(np.random.default_rng(3).normal(size=(200, 2)), axis=0)
    out = run(
        "import numpy as np, time; from rperc.linesimp import simplify_many; "
        "t = time.perf_counter(); simplify_many([np.zeros((3, 2))], 1.0, threads=10000); "
        "print(time.perf_counter() - t)",
        timeout=30,
    )
    assert out.returncode == 0 and float(out.stdout) < 10.0, out.stderr[-2000:]
    many = simplify_many([pts, pts], 0.5, threads=10000, return_indices=True)
    np.testing.assert_array_equal(many[0], simplify(pts, 0.5, return_indices=True))


def test_one_filter_from_two_threads_says_why():
    """A second thread entering a filter that is mid-update gets an error that says
    what to do (not PyO3's bare 'Already borrowed'), and the filter stays usable."""
    import threading
    import time

    import numpy as np

    from rperc.slam import Ekf

    n = 600  # landmarks: one update takes milliseconds, long enough to collide
    ekf = Ekf(np.zeros(3 + 2 * n), np.eye(3 + 2 * n), 3, 2)
    blocks = [(0, 0, np.ones((1, 3))), (0, 3, np.ones((1, 2 * n)))]
    stop = time.monotonic() + 10.0
    errors: list[str] = []

    def hammer() -> None:
        while time.monotonic() < stop and not errors:
            ekf.update(np.zeros(1), blocks, np.eye(1))

    worker = threading.Thread(target=hammer)
    worker.start()
    while time.monotonic() < stop and not errors:
        try:
            ekf.predict(np.zeros(3), np.eye(3), np.eye(3), np.eye(3) * 1e-6)
        except RuntimeError as exc:
            errors.append(str(exc))
    worker.join()
    assert errors, "no collision in 10 s"
    assert "in use by another thread; create one per thread" in errors[0]
    ekf.predict(np.zeros(3), np.eye(3), np.eye(3), np.eye(3) * 1e-6)  # still usable


def test_negative_counts_name_the_parameter():
    import numpy as np

    from rperc.linesimp import simplify_many
    from rperc.tracking import resample

    with pytest.raises(ValueError, match="threads"):
        simplify_many([np.zeros((3, 2))], 1.0, threads=-1)
    with pytest.raises(ValueError, match="n must be"):
        resample(np.ones(3), -1)


# Reproducers the fuzz suite (tests/fuzz) found; each used to give a message naming
# nothing, a caught Rust panic, or a silently wrong answer.
FUZZ_REPRODUCERS = [
    # Wrong types for the Rust config's fields: serde's TypeError, naming the field.
    (
        "extract_lines(np.ones(5), np.arange(5.0), min_points=float('nan'))",
        TypeError,
        "min_points: Invalid type",
    ),
    ("extract_lines(np.ones(5), np.arange(5.0), min_range=None)", TypeError, "min_range"),
    ("extract_lines(np.ones(5), np.arange(5.0), sigma_range=1e300)", ValueError, "sigma_range"),
    # A float where the Rust config holds a count: serde's type error, naming it.
    ("monobot.simulate(landmarks=float('nan'))", TypeError, "landmarks: Invalid type"),
    ("monobot.observability_rank(landmarks=-1)", ValueError, "landmarks must be"),
    ("monobot.observability_rank(landmarks=2**64)", ValueError, "landmarks must be"),
    ("monobot.simulate(landmarks=2, steps=2**31)", MemoryError, "'landmarks and steps'"),
    ("monobot.unobservable_directions(np.eye(2) * 1j)", TypeError, "real matrix"),
    ("resample(np.ones(3), float('nan'))", ValueError, "n must be"),
    ("resample(np.ones(3), 3, seed=float('nan'))", ValueError, "seed must be"),
    ("effective_sample_size(np.array(['1', '2']))", TypeError, "weights"),
    ("ParticleColorTracker(FRAME, (8, 8, 12, 12), filter={'resample_below': 0})", ValueError,
     "resample_below"),
    ("ColorHistogramTracker(FRAME, (8, 8, 12, 12), appearance={'adaptation_rate': 2**64})",
     ValueError,
     "adaptation_rate"),
    ("metrics.precision(np.zeros((1, 4)), np.zeros((1, 4)), float('nan'))", ValueError,
     "threshold"),
    ("to_world([0.0, 0.0, 0.0], np.zeros((2, 3)))", ValueError, "shape (N, 2)"),
    ("wrap_angle(np.array([1j]))", TypeError, "real numbers"),
    # Variances whose products under- or overflow inside the filter: named, not
    # "covariance 'covariance' is not positive definite".
    ("monobot.simulate(landmarks=2, steps=3, initial_variance=1e300)", ValueError,
     "initial_variance"),
    ("monobot.simulate(landmarks=2, steps=3, measurement_noise=('constant', 1e-320))",
     ValueError, "measurement_noise"),
    ("monobot.simulate(landmarks=2, steps=3, plant_noise=('proportional', 1e60))",
     ValueError, "plant_noise"),
    ("ParticleColorTracker(FRAME, (8, 8, 12, 12), position_noise=1e300)", ValueError,
     "position_noise"),
    ("ParticleColorTracker(FRAME, (8, 8, 12, 12), scale_noise=1e-320)", ValueError,
     "scale_noise"),
    # In range, but 1e18 beside a landmark's 1e-2 leaves P numerically singular.
    ("monobot.simulate(landmarks=2, steps=3, initial_variance=2**62)", NumericalError,
     "initial_variance"),
]  # fmt: skip


@pytest.mark.parametrize(("code", "error", "message"), FUZZ_REPRODUCERS)
def test_fuzz_reproducers_raise_a_clear_error(code, error, message):
    import numpy as np

    from rperc.linesimp import extract_lines
    from rperc.pose import to_world
    from rperc.slam import monobot
    from rperc.slam.evaluation import wrap_angle
    from rperc.tracking import (
        ColorHistogramTracker,
        ParticleColorTracker,
        effective_sample_size,
        metrics,
        resample,
    )

    names = {
        "np": np,
        "extract_lines": extract_lines,
        "to_world": to_world,
        "monobot": monobot,
        "wrap_angle": wrap_angle,
        "ColorHistogramTracker": ColorHistogramTracker,
        "ParticleColorTracker": ParticleColorTracker,
        "effective_sample_size": effective_sample_size,
        "metrics": metrics,
        "resample": resample,
        "FRAME": np.zeros((32, 32, 3), np.uint8),
    }
    with pytest.raises(error, match=re.escape(message)) as info:
        eval(code, names)
    assert "internal error" not in str(info.value)


def test_numpy_scalars_in_a_config_are_numbers_not_a_panic():
    """np.float32 in a config used to hit serde-pyobject's unreachable!() (caught, but
    reported as an internal error); it is a number like any other."""
    import numpy as np

    from rperc.slam import monobot

    a = monobot.simulate(landmarks=2, steps=4, initial_variance=np.float32(0.5))
    b = monobot.simulate(landmarks=2, steps=4, initial_variance=0.5)
    np.testing.assert_array_equal(a.estimate, b.estimate)


def test_an_overflowing_new_landmark_is_a_numerical_error_and_changes_nothing():
    import numpy as np

    import rperc
    from rperc.slam import Ekf

    ekf = Ekf(np.ones(3), np.eye(3) * 0.01, 3, 2)
    with pytest.raises(rperc.NumericalError, match="add_landmark"):
        ekf.add_landmark_range_bearing([1e20, 0.3], np.diag([0.0, 1e300]))
    assert ekf.num_landmarks == 0 and np.isfinite(ekf.covariance).all()


def test_polyline_files_are_read_through_gzip_and_name_bad_bytes(tmp_path):
    """Fuzz reproducers: read_polylines read CSV and WKT with path.read_text, so a
    gzipped file or a stray byte was a bare UnicodeDecodeError."""
    import gzip

    import numpy as np

    from rperc.datasets import DatasetFormatError, read_polylines

    path = tmp_path / "lines.csv"
    path.write_bytes(gzip.compress(b"x,y\n0,0\n1,2\n"))
    np.testing.assert_array_equal(read_polylines(path)[0], [[0.0, 0.0], [1.0, 2.0]])
    path.write_bytes(b"x,y\n0,0\n1,\xff2\n")
    with pytest.raises(DatasetFormatError, match=re.escape("lines.csv:3:")):
        read_polylines(path)


def test_odd_line_separators_neither_split_records_nor_shift_line_numbers(tmp_path):
    """str.splitlines() also breaks at form feeds, NEL and U+2028: a comment holding one
    became a record (or a skipped CARMEN type) and every later line number shifted."""
    from rperc.datasets import DatasetFormatError, load_carmen, read_tum

    log = tmp_path / "log.txt"
    log.write_text("# note\u2028ODOMETRY is fine\nODOM 1 2 3 0 0 0 5 host 5\nODOM 1 2\n")
    with pytest.raises(DatasetFormatError, match=re.escape("log.txt:3:")):
        load_carmen(log)
    traj = tmp_path / "traj.txt"
    traj.write_text("# t x y z qx qy qz qw\x0c\n1 0 0 0 0 0 0 1\n")
    t, poses = read_tum(traj)
    assert list(t) == [1.0] and poses.shape == (1, 3)
