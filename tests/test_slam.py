"""rperc.slam against filterpy and scipy, plus the monobot study's Python API."""

from __future__ import annotations

from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest

import rperc
from rperc.slam import Ekf, monobot


def random_spd(rng: np.random.Generator, d: int) -> np.ndarray:
    a = rng.normal(size=(d, d))
    return a @ a.T + 0.1 * np.eye(d)


def test_ekf_equals_filterpy_on_a_linear_model():
    """A 1-D robot among 3 landmarks, relative observations: rperc's EKF against
    filterpy's KalmanFilter (predict/update, standard form)."""
    filterpy = pytest.importorskip("filterpy.kalman")
    rng = np.random.default_rng(4)
    n, d = 3, 4
    x0 = np.array([0.0, 1.0, 2.0, 3.0])
    P0 = np.diag([0.3, 1.0, 1.5, 2.0])
    H = np.hstack([-np.ones((n, 1)), np.eye(n)])
    R = np.diag([0.1, 0.2, 0.3])
    Q = 0.05
    kf = filterpy.KalmanFilter(dim_x=d, dim_z=n, dim_u=1)
    kf.x, kf.P, kf.F, kf.H, kf.R = x0.copy(), P0.copy(), np.eye(d), H, R
    kf.B = np.array([[1.0], [0], [0], [0]])
    kf.Q = kf.B @ kf.B.T * Q
    ekf = Ekf(x0, P0, robot_dim=1, landmark_dim=1)
    one = np.ones((1, 1))
    for _ in range(40):
        u = rng.uniform(-0.5, 0.5)
        kf.predict(u=np.array([u]))
        ekf.predict(ekf.state[:1] + u, one, one, one * Q)
        z = rng.normal(size=n) + 1.0
        innovation = z - H @ ekf.state
        kf.update(z)
        ekf.update(innovation, [(0, 0, -np.ones((n, 1))), (0, 1, np.eye(n))], R)
        np.testing.assert_allclose(ekf.state, kf.x, atol=1e-9)
        np.testing.assert_allclose(ekf.covariance, kf.P, atol=1e-9)


def test_range_bearing_update_matches_numpy_joseph():
    rng = np.random.default_rng(8)
    d = 3 + 2 * 5
    x, P = rng.normal(size=d) * 3, random_spd(rng, d)
    R = np.diag([0.05, 0.01])
    ekf = Ekf(x, P, robot_dim=3, landmark_dim=2)
    j = 2
    lx, ly = x[3 + 2 * j], x[4 + 2 * j]
    dx, dy = lx - x[0], ly - x[1]
    q = dx * dx + dy * dy
    r = np.sqrt(q)
    H = np.zeros((2, d))
    H[:, :3] = [[-dx / r, -dy / r, 0], [dy / q, -dx / q, -1]]
    H[:, 3 + 2 * j : 5 + 2 * j] = [[dx / r, dy / r], [-dy / q, dx / q]]
    z = np.array([r + 0.1, np.arctan2(dy, dx) - x[2] + 0.02])
    nu = z - np.array([r, np.arctan2(dy, dx) - x[2]])
    S = H @ P @ H.T + R
    K = P @ H.T @ np.linalg.inv(S)
    IKH = np.eye(d) - K @ H
    up = ekf.update_range_bearing(j, z, R)
    nis = up.nis
    with pytest.raises(ValueError, match="read-only"):  # the native result is frozen
        up.gain[0, 0] = 0.0
    expected = x + K @ nu
    expected[2] = np.angle(np.exp(1j * expected[2]))  # the heading is wrapped (issue 10)
    np.testing.assert_allclose(ekf.state, expected, atol=1e-9)
    np.testing.assert_allclose(ekf.covariance, IKH @ P @ IKH.T + K @ R @ K.T, atol=1e-9)
    assert nis == pytest.approx(nu @ np.linalg.solve(S, nu))


def test_ekf_errors_map_to_python_exceptions():
    ekf = Ekf(np.zeros(2), np.zeros((2, 2)), robot_dim=1, landmark_dim=1)
    with pytest.raises(rperc.NumericalError, match="singular"):
        ekf.update(np.array([0.5]), [(0, 1, np.ones((1, 1)))], np.zeros((1, 1)))
    with pytest.raises(ValueError, match="non-finite"):
        ekf.update(np.array([np.nan]), [(0, 1, np.ones((1, 1)))], np.ones((1, 1)))
    with pytest.raises(ValueError, match="dimension"):
        ekf.update(np.array([0.5, 1.0]), [(0, 1, np.ones((1, 1)))], np.ones((1, 1)))
    with pytest.raises(TypeError, match="dtype"):
        Ekf(np.array(["a", "b"]), np.zeros((2, 2)), robot_dim=1, landmark_dim=1)
    with pytest.raises(TypeError, match="covariance must be a rectangular array"):
        Ekf([0.0, 1.0], [[1.0, 0.0], [0.0]], robot_dim=1, landmark_dim=1)
    # Integers and lists are numbers: accepted, as simplify accepts them.
    ints = Ekf([0, 2], [[1, 0], [0, 4]], robot_dim=1, landmark_dim=1)
    assert ints.state.dtype == np.float64 and ints.state.tolist() == [0.0, 2.0]
    with pytest.raises(ValueError, match="robot block"):
        Ekf(np.zeros(4), np.eye(4), robot_dim=3, landmark_dim=2)
    one = np.ones((1, 1))
    with pytest.raises(ValueError, match="non-finite"):
        ekf.predict(np.array([np.nan]), one, one, one)  # a NaN control
    with pytest.raises(ValueError, match="dimension"):
        ekf.predict(np.zeros(2), one, one, one)
    np.testing.assert_array_equal(ekf.state, [0.0, 0.0])  # unchanged by the failures


def test_nees_bounds_match_scipy():
    stats = pytest.importorskip("scipy.stats")
    for dof, runs in [(1, 1), (2, 100), (11, 100), (3, 50)]:
        lo, hi = monobot.nees_bounds(dof, runs)
        assert lo == pytest.approx(stats.chi2.ppf(0.025, dof * runs) / runs, rel=1e-9)
        assert hi == pytest.approx(stats.chi2.ppf(0.975, dof * runs) / runs, rel=1e-9)


@pytest.mark.parametrize("landmarks", [1, 2, 5, 10])
def test_fisher_rank_and_null_space(landmarks):
    rel = monobot.simulate(model="relative", landmarks=landmarks, seed=2)
    J = monobot.fisher_information(rel)
    assert J.shape == (landmarks + 1, landmarks + 1)
    null = monobot.unobservable_directions(J)
    assert null.shape == (landmarks + 1, 1)
    ones = np.ones(landmarks + 1) / np.sqrt(landmarks + 1)
    assert abs(null[:, 0] @ ones) == pytest.approx(1.0)
    assert monobot.observability_rank(model="relative", landmarks=landmarks) == landmarks
    for model in ("anchor", "external"):
        run = monobot.simulate(model=model, landmarks=landmarks, seed=2)
        assert monobot.unobservable_directions(monobot.fisher_information(run)).shape[1] == 0
        assert np.linalg.matrix_rank(run.fisher) == landmarks + 1
        assert monobot.observability_rank(model=model, landmarks=landmarks) == landmarks + 1


def test_result_arrays_and_repr():
    run = monobot.simulate(model="anchor", landmarks=3, steps=50, seed=1)
    assert run.truth.shape == run.estimate.shape == run.bounds.shape == (51, 4)
    assert run.gain.shape == (50, 4, 4) and run.innovation.shape == (50, 4)
    assert run.nees.shape == (51,) and run.fisher_00.shape == (50,)
    assert "anchor" in repr(run) and "rank J = 4/4" in repr(run)


def test_executor_path_equals_the_rayon_path():
    kwargs = {"model": "anchor", "landmarks": 2, "runs": 12, "steps": 30, "seed": 9}
    native = monobot.monte_carlo(**kwargs)
    with ProcessPoolExecutor(max_workers=2) as pool:
        pooled = monobot.monte_carlo(**kwargs, executor=pool)
    np.testing.assert_array_equal(native.run_nees, pooled.run_nees)
    np.testing.assert_array_equal(native.final_landmark_error, pooled.final_landmark_error)
    assert native.sensitivity == pooled.sensitivity


@pytest.mark.filterwarnings("ignore")
def test_dask_executor_path():
    distributed = pytest.importorskip("distributed")
    kwargs = {"model": "external", "landmarks": 1, "runs": 6, "steps": 20, "seed": 3}
    native = monobot.monte_carlo(**kwargs)
    with distributed.Client(
        processes=False, n_workers=1, threads_per_worker=2, dashboard_address=None
    ) as client:
        dasked = monobot.monte_carlo(**kwargs, executor=client.get_executor())
    np.testing.assert_array_equal(native.run_nees, dasked.run_nees)


@pytest.mark.parametrize(
    ("kwargs", "exc", "message"),
    [
        ({"landmarks": 0}, ValueError, "landmarks"),
        ({"plant_noise": ("proportional", -0.1)}, ValueError, "plant_noise"),
        ({"measurement_noise": ("gaussian", 1.0)}, ValueError, "measurement_noise"),
        ({"model": "magic"}, ValueError, "model"),
        ({"bogus": 1}, TypeError, "bogus"),
    ],
)
def test_bad_monobot_input(kwargs, exc, message):
    with pytest.raises(exc, match=message):
        monobot.simulate(**kwargs)


def test_a_bad_monobot_config_is_refused_when_made_and_the_old_constructor_warns():
    # The config class is generated from the Rust struct, which checks it (issue 36).
    with pytest.raises(ValueError, match="start"):
        monobot.MonobotConfig(start=float("nan"))
    with pytest.warns(DeprecationWarning, match="monobot.unit_noise"):
        old = monobot.MonobotConfig.unit_noise(3)  # type: ignore[attr-defined]
    assert old == monobot.unit_noise(3) and old.plant_noise == ("constant", 1.0)


def test_a_monobot_monte_carlo_beyond_memory_is_refused_naming_runs():
    # Issue 38's cause in another surface: runs=10**9 ran on for minutes.
    from rperc.slam import monobot

    with pytest.raises(MemoryError, match=r"^'runs' = 1000000000 would need "):
        monobot.monte_carlo(runs=10**9, steps=10)


def test_monobot_native_results_are_typed_frozen_and_read_only():
    """The seam's monobot results: named read-only arrays whose shapes follow the
    config, and a summary whose runs and band are numbers, not dict entries."""
    from rperc import _rperc

    run = _rperc.monobot_simulate("relative", 3, 0, {"landmarks": 2, "steps": 5})
    assert isinstance(run, _rperc.MonobotRun)
    assert run.truth.shape == run.estimate.shape == (6, 3)
    assert run.gain.shape[:2] == (5, 3) and run.nees.shape == (6,)
    with pytest.raises(ValueError, match="read-only"):
        run.truth[0, 0] = 1.0
    errors = _rperc.monobot_monte_carlo("relative", 4, 3, {"landmarks": 2, "steps": 5})
    assert errors.landmark_error.shape == (4, 6, 2)
    s = _rperc.monobot_summarize(
        errors.nees, errors.robot_error, errors.landmark_error, errors.first_observation_error
    )
    assert isinstance(s, _rperc.MonobotSummary) and s.runs == 4
    lo, hi = s.nees_band
    assert lo < hi and s.final_landmark_error.shape == (4, 2)
    with pytest.raises(AttributeError):
        s.runs = 5  # type: ignore[misc]
