"""rperc.slam.planar.monte_carlo: Monte Carlo consistency of planar EKF-SLAM in the
simulated world (Bailey et al. 2006). Oracles: scipy's chi-square quantiles for the
band, a filter whose model is the world's (its run-averaged NEES must sit in that
band), and the serial result for the executor path."""

from __future__ import annotations

from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor

import numpy as np
import pytest

from rperc.slam.planar import consistency, monte_carlo, sim_defaults, sim_slam_config

SHORT = {"steps": 150}
# Heading drifts between sparse sightings (the Rust crate's long-run test world).
DRIFTING = {"steps": 1500, "turn_rate_variance": 0.05, "bearing_variance": 1e-3,
            "landmarks": 12, "max_range": 4.5}  # fmt: skip


def test_the_band_is_scipys_chi_square_band():
    scipy_stats = pytest.importorskip("scipy.stats")
    mc = monte_carlo({"steps": 5}, runs=20, seed=1)
    lo = scipy_stats.chi2.ppf(0.025, 3 * 20) / 20
    hi = scipy_stats.chi2.ppf(0.975, 3 * 20) / 20
    assert mc.band == pytest.approx((lo, hi), rel=1e-9)
    assert mc.run_nees.shape == (20, 5) and mc.runs == 20


def test_seeded_runs_repeat_and_seeds_differ():
    a = monte_carlo(SHORT, runs=4, seed=3)
    b = monte_carlo(SHORT, runs=4, seed=3)
    c = monte_carlo(SHORT, runs=4, seed=4)
    np.testing.assert_array_equal(a.run_nees, b.run_nees)
    assert not np.array_equal(a.run_nees, c.run_nees)
    # Run i is stream i of the seed: a batch of 4 starts with the batch of 2.
    np.testing.assert_array_equal(monte_carlo(SHORT, runs=2, seed=3).run_nees, a.run_nees[:2])


@pytest.mark.parametrize("pool", [ThreadPoolExecutor, ProcessPoolExecutor])
def test_an_executor_gives_the_serial_result(pool):
    serial = monte_carlo(SHORT, slam=sim_slam_config(SHORT, anchor=True), runs=4, seed=7)
    with pool(max_workers=2) as executor:
        pooled = monte_carlo(
            SHORT, slam=sim_slam_config(SHORT, anchor=True), runs=4, seed=7, executor=executor
        )
    np.testing.assert_array_equal(pooled.run_nees, serial.run_nees)
    assert pooled.band == serial.band


def test_a_filter_with_the_worlds_model_is_in_the_band():
    """Short horizon, known association, the filter's noise is the world's: Bailey et
    al. find EKF-SLAM consistent early on. 95 % of steps are expected inside for a
    consistent filter; steps are correlated, so 85 % is asked, and the time average
    of the mean NEES must lie in the band."""
    mc = monte_carlo(SHORT, runs=50, seed=11)
    lo, hi = mc.band
    assert mc.in_band >= 0.85, mc
    assert lo < float(np.mean(mc.mean_nees[5:])) < hi, mc


def test_long_runs_plain_is_over_confident_external_is_not():
    """The known inconsistency on long runs (Bailey et al. 2006), and the external
    xy sensor (eqs. 26-27) that bounds it."""
    out = consistency(DRIFTING, runs=20, seed=5, fix_every=10)
    half = DRIFTING["steps"] // 2
    plain, external = out["plain"], out["external"]
    assert float(np.mean(plain.mean_nees[half:])) > plain.band[1], plain
    lo, hi = external.band
    assert lo < float(np.mean(external.mean_nees[half:])) < hi, external
    assert external.slam["external_fix"] and out["anchor"].slam["anchor"]


def test_bad_config_is_named():
    assert sim_defaults()["steps"] > 0
    with pytest.raises(TypeError, match="colour"):
        monte_carlo({"colour": 1}, runs=2)
    with pytest.raises(ValueError, match="dt"):
        monte_carlo({"dt": -0.1}, runs=2)
    with pytest.raises(ValueError, match="runs"):
        monte_carlo(SHORT, runs=0)
    with pytest.raises(ValueError, match="range_variance"):
        monte_carlo(SHORT, slam=sim_slam_config(SHORT, range_variance=-1.0), runs=2)
    with pytest.raises(ValueError, match="variant"):
        consistency(SHORT, variants=("magic",))


@pytest.mark.parametrize("executor", [None, "threads"])
def test_runs_beyond_the_memory_limit_are_refused_at_once(executor):
    # Issue 38: runs=10**9 neither refused nor answered within 60 s. The (runs, steps)
    # NEES array alone would need 10**9 * 150 * 8 bytes; the message names runs.
    pool = ThreadPoolExecutor(1) if executor else None
    try:
        with pytest.raises(MemoryError, match=r"^'runs' = 1000000000 would need 1200000000000 "):
            monte_carlo(SHORT, runs=10**9, executor=pool)
    finally:
        if pool is not None:
            pool.shutdown()
