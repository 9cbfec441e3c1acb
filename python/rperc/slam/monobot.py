"""The monobot study of paper [000] (section 2.2, eqs. 14 to 23, Figs. 3 to 6).

A 1-D robot ``x_{k+1} = x_k + u_k + v_k`` among static landmarks, observed with one
of three measurement models:

- ``"relative"``: ``z_i = l_i - x + w_i``, ``H = [-1, I]``; the Fisher information is
  singular and the map is only known up to a common shift;
- ``"anchor"``: plus a landmark at the origin used as a global reference (eq. 20);
- ``"external"``: plus a fixed sensor that measures the robot (eq. 23).

Examples
--------
>>> from rperc.slam import monobot
>>> run = monobot.simulate(model="relative", landmarks=3, seed=1)
>>> J = monobot.fisher_information(run)
>>> monobot.unobservable_directions(J).shape   # one direction: (1, 1, 1, 1) / 2
(4, 1)
>>> monobot.observability_rank(model="anchor", landmarks=3)
4
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable
from concurrent.futures import Executor
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from rperc import _rperc
from rperc._args import seed_number, whole_number
from rperc._config_base import as_config
from rperc._progress import progress as _progress
from rperc.config import MonobotConfig

Model = Literal["relative", "anchor", "external"]
NoiseSpec = tuple[Literal["constant", "proportional"], float]

__all__ = [
    "MonobotResult",
    "MonteCarloResult",
    "fisher_information",
    "monte_carlo",
    "nees_bounds",
    "observability_rank",
    "simulate",
    "unobservable_directions",
]


def unit_noise(landmarks: int, steps: int = 100) -> MonobotConfig:
    """Fig. 3's setting: ``P0 = V = W = 1``."""
    return MonobotConfig(
        landmarks=landmarks,
        steps=steps,
        initial_variance=1.0,
        plant_noise=("constant", 1.0),
        measurement_noise=("constant", 1.0),
        reference_noise=("constant", 1.0),
    )


def _unit_noise_deprecated(landmarks: int, steps: int = 100) -> MonobotConfig:
    warnings.warn(
        "MonobotConfig.unit_noise is deprecated; use rperc.slam.monobot.unit_noise",
        DeprecationWarning,
        stacklevel=2,
    )
    return unit_noise(landmarks, steps)


# The config class is generated from the Rust struct (rperc.config); the old static
# constructor stays for one release.
setattr(MonobotConfig, "unit_noise", staticmethod(_unit_noise_deprecated))  # noqa: B010


def _config(config: MonobotConfig | None, overrides: dict[str, Any]) -> MonobotConfig:
    """``config`` (default: the paper's run) with the given fields replaced; the Rust
    crate checks it (rperc.config)."""
    given = {k: v for k, v in overrides.items() if v is not None}
    return as_config(MonobotConfig, config, given)


@dataclass(frozen=True, repr=False)
class MonobotResult:
    """One run. Per-step arrays start at step 0 (landmarks just initialised from the
    first observation); the state is ``[x_robot, l_1, ..., l_n]``."""

    model: str
    config: MonobotConfig
    seed: int
    truth: np.ndarray  # (steps + 1, d)
    estimate: np.ndarray  # (steps + 1, d)
    std: np.ndarray  # (steps + 1, d) standard deviations
    initial_measurement: np.ndarray  # (n,)
    measurement: np.ndarray  # (steps, p)
    innovation: np.ndarray  # (steps, p)
    innovation_cov: np.ndarray  # (steps, p, p)
    gain: np.ndarray  # (steps, d, p) Kalman gains
    predicted_cov: np.ndarray  # (steps, d, d)
    nees: np.ndarray  # (steps + 1,)
    fisher: np.ndarray  # (d, d) total Fisher information, eq. (14)
    fisher_00: np.ndarray  # (steps,) J[0, 0] after each update (Fig. 3)
    first_observation_error: np.ndarray  # (n,)

    @property
    def bounds(self) -> np.ndarray:
        """2-sigma bounds of each state entry, ``(steps + 1, d)``."""
        return 2.0 * self.std

    @property
    def error(self) -> np.ndarray:
        return np.asarray(self.estimate - self.truth)

    def __repr__(self) -> str:
        e = self.error[-1]
        return (
            f"MonobotResult(model={self.model!r}, landmarks={self.config.landmarks}, "
            f"steps={self.config.steps}, final robot error {e[0]:+.4f} m, "
            f"final landmark error {np.mean(e[1:]):+.4f} m, "
            f"rank J = {np.linalg.matrix_rank(self.fisher)}/{len(self.fisher)})"
        )


def simulate(
    *,
    model: Model = "relative",
    seed: int = 0,
    config: MonobotConfig | None = None,
    landmarks: int | None = None,
    steps: int | None = None,
    initial_variance: float | None = None,
    plant_noise: NoiseSpec | None = None,
    measurement_noise: NoiseSpec | None = None,
    reference_noise: NoiseSpec | None = None,
) -> MonobotResult:
    """Simulate one monobot run and its EKF-SLAM estimate (paper [000], Figs. 4-6).

    ``config`` is the experiment (default: the paper's run, see
    :class:`MonobotConfig`); the other keywords replace its fields.
    """
    cfg = _config(
        config,
        {
            "landmarks": landmarks,
            "steps": steps,
            "initial_variance": initial_variance,
            "plant_noise": plant_noise,
            "measurement_noise": measurement_noise,
            "reference_noise": reference_noise,
        },
    )
    r = _rperc.monobot_simulate(model, seed_number(seed), 0, cfg.to_dict())
    return MonobotResult(
        model=model, config=cfg, seed=seed, truth=r.truth, estimate=r.estimate, std=r.std,
        initial_measurement=r.initial_measurement, measurement=r.measurement,
        innovation=r.innovation, innovation_cov=r.innovation_cov, gain=r.gain,
        predicted_cov=r.predicted_cov, nees=r.nees, fisher=r.fisher, fisher_00=r.fisher_00,
        first_observation_error=r.first_observation_error,
    )  # fmt: skip


def fisher_information(result: MonobotResult) -> np.ndarray:
    """The total Fisher information ``J`` (eq. 14) accumulated along ``result``'s run,
    ``d x d`` over the robot and the estimated landmarks."""
    return result.fisher


def observability_rank(*, model: Model = "relative", landmarks: int = 1) -> int:
    """Rank of the observability matrix: ``landmarks`` for the relative model,
    ``landmarks + 1`` (full) for anchor and external."""
    return _rperc.monobot_observability_rank(model, whole_number(landmarks, "landmarks", 0))


def unobservable_directions(J: npt.ArrayLike, tol: float = 1e-9) -> np.ndarray:
    """A basis (``d x k`` columns) of the null space of the information matrix ``J``:
    eigenvectors whose eigenvalues are at most ``tol`` times the largest."""
    arr = np.asarray(J)
    if arr.dtype.kind not in "fiu":
        raise TypeError(f"J must be a real matrix, got dtype {arr.dtype}")
    arr = arr.astype(np.float64)
    spectrum = _rperc.information_spectrum(arr, float(tol))
    return spectrum.eigenvectors[:, : arr.shape[0] - spectrum.rank]


def nees_bounds(dof: int, runs: int, confidence: float = 0.95) -> tuple[float, float]:
    """Two-sided ``confidence`` band for the NEES of a ``dof``-dimensional state averaged
    over ``runs`` Monte Carlo runs (chi-square with ``dof * runs`` degrees of freedom,
    divided by ``runs``)."""
    return _rperc.nees_bounds(dof, runs, confidence)


@dataclass(frozen=True, repr=False)
class MonteCarloResult:
    """Statistics over Monte Carlo runs of one experiment."""

    model: str
    config: MonobotConfig
    runs: int
    nees: np.ndarray  # (steps + 1,) run-averaged NEES of the whole state
    nees_band: tuple[float, float]
    nees_in_band: float  # fraction of steps inside the band
    landmark_error_mean: np.ndarray  # (steps + 1,)
    landmark_error_std: np.ndarray
    robot_error_mean: np.ndarray
    robot_error_std: np.ndarray
    final_landmark_error: np.ndarray  # (runs, n)
    first_observation_error: np.ndarray  # (runs, n)
    sensitivity: float  # slope of final on first-observation landmark error
    correlation: float
    run_nees: np.ndarray = field(repr=False)  # (runs, steps + 1)

    def __repr__(self) -> str:
        return (
            f"MonteCarloResult(model={self.model!r}, landmarks={self.config.landmarks}, "
            f"runs={self.runs}, final landmark error {self.landmark_error_mean[-1]:+.4f} "
            f"+- {self.landmark_error_std[-1]:.4f} m, sensitivity {self.sensitivity:.3f} "
            f"(corr {self.correlation:.2f}), NEES in band {100 * self.nees_in_band:.0f}% of steps)"
        )


def _run_errors(model: str, seed: int, run: int, config: dict[str, Any]) -> tuple[np.ndarray, ...]:
    """Run ``run``'s errors; a top-level function so process pools and Dask can pickle
    it. The run draws from stream ``run`` of ``seed``, as the native Monte Carlo does."""
    r = _rperc.monobot_simulate(model, seed, run, config)
    err = r.estimate - r.truth
    return r.nees, err[:, 0], err[:, 1:], r.first_observation_error


def monte_carlo(
    *,
    model: Model = "relative",
    runs: int = 100,
    seed: int = 0,
    config: MonobotConfig | None = None,
    landmarks: int | None = None,
    steps: int | None = None,
    initial_variance: float | None = None,
    executor: Executor | None = None,
    confidence: float = 0.95,
    progress: bool = False,
) -> MonteCarloResult:
    """Monte Carlo over ``runs`` seeded runs.

    Without ``executor`` the runs go in parallel on all cores (rayon, GIL released).
    With any :class:`concurrent.futures.Executor` (a process pool, Dask's
    ``client.get_executor()``, Ray's) each run is submitted to it instead. Run ``i``
    is seeded from ``(seed, i)`` either way, so both paths give identical results,
    whatever the number of workers.
    """
    cfg = _config(
        config, {"landmarks": landmarks, "steps": steps, "initial_variance": initial_variance}
    )
    whole_number(runs, "runs", 1)
    seed = seed_number(seed)
    if executor is None:
        # One native call does every run on all cores, so progress reports it as one
        # batch (its final line gives the time).
        batch: Iterable[int] = [int(runs)]
        if progress:
            batch = _progress(batch, desc=f"monobot {model}, {runs} runs (rayon)", unit="batch")
        for n in batch:
            e = _rperc.monobot_monte_carlo(model, n, seed, cfg.to_dict())
            nees, robot, first = e.nees, e.robot_error, e.first_observation_error
            lm = e.landmark_error
    else:
        _rperc.monobot_simulate(model, seed, 0, {**cfg.to_dict(), "steps": 1})  # validate early
        kwargs = cfg.to_dict()
        futures = [executor.submit(_run_errors, model, seed, i, kwargs) for i in range(runs)]
        done = _progress(futures, desc=f"monobot {model}", unit="run") if progress else futures
        results = [f.result() for f in done]
        nees, robot, lm, first = (np.stack(parts) for parts in zip(*results, strict=True))
    s = _rperc.monobot_summarize(nees, robot, lm, first, confidence)
    return MonteCarloResult(
        model=model, config=cfg, runs=s.runs, run_nees=np.asarray(nees), nees=s.nees,
        nees_band=s.nees_band, nees_in_band=s.nees_in_band,
        landmark_error_mean=s.landmark_error_mean, landmark_error_std=s.landmark_error_std,
        robot_error_mean=s.robot_error_mean, robot_error_std=s.robot_error_std,
        final_landmark_error=s.final_landmark_error,
        first_observation_error=s.first_observation_error, sensitivity=s.sensitivity,
        correlation=s.correlation,
    )  # fmt: skip
