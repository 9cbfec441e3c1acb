"""rperc.slam under fuzzing: the EKF accepts only PSD covariances, keeps its state
finite with a non-negative diagonal through any sequence of steps and leaves it
unchanged when a step fails; monobot's parameters at and beyond their limits are
clear errors naming the parameter, never an abort, and its results are finite."""

from __future__ import annotations

from typing import Any

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from scipy.stats import chi2

from rperc.slam import Ekf, monobot, nees_bounds

from fuzz.harness import case, examples, outcome
from fuzz.strategies import EDGE_NUMBERS, HOSTILE, SCALES


@st.composite
def covariances(draw: st.DrawFn, n: int) -> np.ndarray:
    """Mostly PSD (A A^T at some scale), sometimes indefinite, asymmetric or NaN."""
    a = np.array(draw(st.lists(st.floats(-3, 3), min_size=n * n, max_size=n * n)))
    a = a.reshape(n, n)
    kind = draw(st.sampled_from(["psd", "psd", "psd", "indefinite", "asymmetric", "nan"]))
    cov = a @ a.T * draw(SCALES)
    if kind == "indefinite" and n:
        cov[0, 0] = -abs(cov[0, 0]) - 0.01
    elif kind == "asymmetric" and n > 1:
        cov[0, 1] += 1.0 + abs(cov[0, 1])
    elif kind == "nan" and n:
        cov[-1, -1] = np.nan
    return cov


def _is_psd(cov: np.ndarray) -> bool:
    # Symmetric within 1e-9 of the largest entry, the documented rule of
    # rperc_core::check_covariance (an asymmetry of 1 beside a variance of 1e20 is
    # round-off at that scale; the filter reads the lower triangle).
    if not np.isfinite(cov).all():
        return False
    scale = max(float(np.abs(cov).max()) if cov.size else 0.0, 1e-300)
    if cov.size and np.abs(cov / scale - cov.T / scale).max() > 1e-9:
        return False
    eig = np.linalg.eigvalsh(cov) if cov.size else np.zeros(0)
    return bool(eig.size == 0 or eig.min() >= -1e-6 * max(abs(eig).max(), 1e-300))


def _healthy(ekf: Ekf) -> None:
    p = ekf.covariance
    assert np.isfinite(ekf.state).all() and np.isfinite(p).all(), (ekf.state, p)
    assert (np.diag(p) >= 0).all(), np.diag(p)


@examples(150)
@given(st.integers(0, 4), st.data())
def prop_ekf_accepts_only_psd_covariances(landmarks, data):
    n = 3 + 2 * landmarks
    cov = data.draw(covariances(n))
    state = np.zeros(n)
    case("Ekf", state=state, covariance=cov)
    ok, ekf = outcome(Ekf, state, cov, 3, 2)
    if ok:
        assert _is_psd(cov), f"accepted a covariance that is not PSD: {cov!r}"
        _healthy(ekf)


@examples(80)
@given(
    st.one_of(HOSTILE, st.just(np.zeros(5))),
    st.one_of(HOSTILE, st.just(np.eye(5))),
    st.one_of(st.just(3), EDGE_NUMBERS),
    st.one_of(st.just(2), EDGE_NUMBERS),
)
def prop_ekf_hostile_construction(state, cov, robot_dim, landmark_dim):
    case("Ekf", state=state, covariance=cov, robot_dim=robot_dim, landmark_dim=landmark_dim)
    ok, ekf = outcome(Ekf, state, cov, robot_dim, landmark_dim)
    if ok:
        _healthy(ekf)


def _step(ekf: Ekf, op: str, scale: float, j: int, noise: np.ndarray) -> Any:
    if op == "predict":
        return ekf.predict(ekf.state[:3] + 0.1, np.eye(3) * scale, np.eye(3), noise)
    if op == "update":
        return ekf.update_range_bearing(j, [5.0 * scale, 0.3], noise[:2, :2])
    if op == "add":
        return ekf.add_landmark_range_bearing([5.0 * scale, 0.3], noise[:2, :2])
    ekf.state = np.full(len(ekf.state), scale)
    return None


@examples(150)
@given(
    st.lists(
        st.tuples(
            st.sampled_from(["predict", "update", "add", "set_state"]),
            st.one_of(SCALES, st.sampled_from([np.nan, np.inf, -1.0, 0.0])),
            st.sampled_from([0, 1, 2, -1, 10**6, 2**63]),
            st.one_of(covariances(3), st.just(np.eye(3) * 1e-2)),
        ),
        max_size=12,
    )
)
def prop_ekf_steps_stay_finite_or_change_nothing(steps):
    ekf = Ekf(np.zeros(3), np.eye(3) * 0.01, 3, 2)
    for op, scale, j, noise in steps:
        before = (ekf.state, ekf.covariance)
        case("Ekf step", op=op, scale=scale, j=j, noise=noise, state=before[0], P=before[1])
        ok, _ = outcome(_step, ekf, op, scale, j, noise)
        if ok:
            _healthy(ekf)
        else:
            np.testing.assert_array_equal(ekf.state, before[0])
            np.testing.assert_array_equal(ekf.covariance, before[1])


MONOBOT_PARAMS = [
    "landmarks",
    "steps",
    "seed",
    "initial_variance",
    "plant_noise",
    "measurement_noise",
    "reference_noise",
]
NOISE_EDGES = st.sampled_from(
    [
        ("constant", -1.0),
        ("constant", np.nan),
        ("proportional", np.inf),
        ("bogus", 1.0),
        ["constant", 1.0],
        ("constant",),
        "constant",
        None,
        ("constant", "x"),
        ("constant", 1e300),
    ]
)


@examples(120)
@given(
    st.sampled_from(["relative", "anchor", "external", "bogus", ""]),
    st.sampled_from(MONOBOT_PARAMS),
    st.one_of(EDGE_NUMBERS, NOISE_EDGES),
)
def prop_monobot_simulate_edges(model, name, value):
    kwargs: dict[str, Any] = {"landmarks": 2, "steps": 4, name: value}
    case("monobot.simulate", model=model, **kwargs)
    ok, got = outcome(monobot.simulate, model=model, **kwargs)
    if not ok:
        assert name in str(got) or "model" in str(got), f"{name}={value!r}: {got}"
        return
    for key, arr in vars(got).items():
        if isinstance(arr, np.ndarray):
            assert np.isfinite(arr).all(), (key, name, value)


@examples(100)
@given(
    st.sampled_from(["relative", "anchor", "external", "bogus"]),
    st.one_of(st.integers(0, 40), EDGE_NUMBERS),
)
def prop_observability_rank(model, landmarks):
    """Closed form (the function's documented contract): landmarks for the relative
    model, landmarks + 1 for anchor and external."""
    case("observability_rank", model=model, landmarks=landmarks)
    ok, rank = outcome(monobot.observability_rank, model=model, landmarks=landmarks)
    if ok:
        assert isinstance(landmarks, int) and landmarks >= 0
        assert rank == landmarks + (model != "relative"), rank
    else:
        assert "landmarks" in str(rank) or "model" in str(rank), rank


@examples(150)
@given(
    st.one_of(st.integers(1, 10**6), EDGE_NUMBERS),
    st.one_of(st.integers(1, 10**6), EDGE_NUMBERS),
    st.one_of(st.floats(0.01, 0.999), EDGE_NUMBERS),
)
def prop_nees_bounds_match_scipy(dof, runs, confidence):
    case("nees_bounds", dof=dof, runs=runs, confidence=confidence)
    ok, band = outcome(nees_bounds, dof, runs, confidence)
    if not ok:
        return
    assert isinstance(dof, int) and isinstance(runs, int) and dof >= 1 and runs >= 1
    assert 0 < float(confidence) < 1, confidence
    k = dof * runs
    if k < 2**53:
        tail = (1 - confidence) / 2
        assert band[0] == pytest_approx(chi2.ppf(tail, k) / runs)
        assert band[1] == pytest_approx(chi2.isf(tail, k) / runs)


def pytest_approx(x: float) -> Any:
    import pytest

    return pytest.approx(x, rel=1e-7)


@examples(80)
@given(
    st.one_of(HOSTILE, st.integers(0, 5).flatmap(covariances)),
    st.one_of(st.just(1e-9), EDGE_NUMBERS),
)
def prop_unobservable_directions(J, tol):
    case("unobservable_directions", J=J, tol=tol)
    ok, basis = outcome(monobot.unobservable_directions, J, tol)
    if ok:
        basis = np.asarray(basis)
        assert np.isfinite(basis).all(), basis
