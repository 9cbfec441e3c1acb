"""Offline calibration of MR.CLAM's sensor biases and noise levels from one robot's
ground truth, for the ``mrclam`` preset of :mod:`rperc.slam.planar`.

The ground truth is read here, once, offline; the filter then runs with the constants
this returns and never sees ground truth (only the start pose, the dataset's surveyed
start). Fit on one part of the data (robot 1, or its first half) and report the
scores on data the fit has not seen.

What is fitted (the model of :class:`SensorBias` in the Rust crate):

- camera bearing ``b_measured = bearing_offset + bearing_scale * b``;
- camera range ``r_measured = range_offset + range_scale * r cos(b)``: MR.CLAM's
  camera sizes a barcode by its image height, which gives the depth along the optical
  axis, not the range (off-axis landmarks read short: 0.2 m at 0.5 rad on robot 1);
- odometry scales: the true distance and turn over ``window`` seconds against the
  odometry's, integrated from the true start of each window. The window is the
  odometry error's correlation time (:func:`correlation_window`): MR.CLAM's speed
  error is slip that persists for seconds, so a white per-step noise fitted over
  1 s windows under-states the error over the 5-10 s between corrections;
- the noise left after the correction: detection variances are the mean squares of
  the residuals within 5 robust sigmas (heavier tails than a Gaussian, so not the
  MAD), control variances are the residual variances of the windows divided by the
  mean of ``sum(dt^2)`` over a window, as the engine's prediction holds the control
  noise over each step.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from rperc._config_base import as_config
from rperc.config import PlanarConfig, Unicycle
from rperc.pose import wrap_angle

if TYPE_CHECKING:
    from rperc.datasets.mrclam import MrclamRun

__all__ = [
    "MrclamCalibration",
    "calibrate_mrclam",
    "calibrate_mrclam_preset",
    "correlation_window",
    "gate_inflation",
    "inflated",
    "mrclam_window",
    "true_range_bearing",
]

FloatArray = npt.NDArray[np.float64]
# Odometry windows tried by correlation_window, seconds (doubling: the growth of the
# variance per doubling is what the rule tests).
CANDIDATE_WINDOWS = (1.0, 2.0, 4.0, 8.0, 16.0, 32.0)


@dataclass(frozen=True)
class MrclamCalibration:
    """Biases and noise variances fitted by :func:`calibrate_mrclam`, with the sizes
    of the samples they come from."""

    range_offset: float
    range_scale: float
    bearing_offset: float
    bearing_scale: float
    speed_scale: float
    turn_rate_scale: float
    range_variance: float
    bearing_variance: float
    speed_variance: float
    turn_rate_variance: float
    detections: int
    outliers: int
    windows: int
    window: float  # seconds: the odometry windows the scales and variances come from

    def config(self) -> dict[str, object]:
        """The fields of a :class:`rperc.slam.PlanarSlam` config."""
        return {
            "motion": {
                "unicycle": {
                    "speed_variance": self.speed_variance,
                    "turn_rate_variance": self.turn_rate_variance,
                }
            },
            "range_variance": self.range_variance,
            "bearing_variance": self.bearing_variance,
            "bias": {
                "range_offset": self.range_offset,
                "range_scale": self.range_scale,
                "range_is_depth": True,
                "bearing_offset": self.bearing_offset,
                "bearing_scale": self.bearing_scale,
                "control_scale": [self.speed_scale, self.turn_rate_scale],
            },
        }


def _heading(run: MrclamRun) -> FloatArray:
    return np.asarray(np.unwrap(run.truth_theta), dtype=np.float64)


def true_range_bearing(run: MrclamRun) -> tuple[FloatArray, FloatArray]:
    """The true range and bearing of every landmark sighting, from the ground-truth
    pose interpolated at the sighting's time and the surveyed landmark."""
    t = run.measurement_t
    x = np.interp(t, run.truth_t, run.truth_x)
    y = np.interp(t, run.truth_t, run.truth_y)
    theta = np.interp(t, run.truth_t, _heading(run))
    where = {int(i): k for k, i in enumerate(run.landmark_id)}
    missing = sorted({int(i) for i in run.measurement_landmark} - set(where))
    if missing:
        raise ValueError(f"sightings of landmarks {missing} have no ground truth")
    k = np.array([where[int(i)] for i in run.measurement_landmark], dtype=np.int64)
    dx = run.landmark_x[k] - x
    dy = run.landmark_y[k] - y
    bearing = wrap_angle(np.arctan2(dy, dx) - theta)
    return np.hypot(dx, dy), bearing


def _robust_line(
    regressor: FloatArray, measured: FloatArray
) -> tuple[float, float, FloatArray, npt.NDArray[np.bool_]]:
    """``measured = offset + scale * regressor`` by least squares, refitted without the
    residuals beyond 5 robust sigmas until the inlier set settles."""
    inlier = np.ones(len(measured), dtype=bool)
    for _ in range(10):
        a = np.c_[np.ones(int(inlier.sum())), regressor[inlier]]
        offset, scale = np.linalg.lstsq(a, measured[inlier], rcond=None)[0]
        residual = measured - offset - scale * regressor
        mad = 1.4826 * np.median(np.abs(residual[inlier] - np.median(residual[inlier])))
        now = np.abs(residual) <= 5.0 * mad
        if np.array_equal(now, inlier):
            break
        inlier = now
    return float(offset), float(scale), residual, inlier


def _windows(run: MrclamRun, window: float) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Per window of ``window`` s: (true, odometry) distance along the track, (true,
    odometry) turn, and the sum of the squared odometry steps.

    The true distance is the truth's displacement projected on its own heading, step
    by step, so that it is the arc the wheels rolled: a chord between the window's
    ends would mix the turn-rate noise into the speed error, and more so the longer
    and the more curved the window."""
    t = run.odometry_t
    dt = np.diff(t)
    heading = _heading(run)
    xy = np.interp(t, run.truth_t, run.truth_x) + 1j * np.interp(t, run.truth_t, run.truth_y)
    th = np.interp(t, run.truth_t, heading)
    along = np.real(np.diff(xy) * np.exp(-0.5j * (th[1:] + th[:-1])))
    arc = np.r_[0.0, np.cumsum(along)]
    rolled = np.r_[0.0, np.cumsum(run.odometry_v[:-1] * dt)]
    phi = np.r_[0.0, np.cumsum(run.odometry_omega[:-1] * dt)]
    sq = np.r_[0.0, np.cumsum(dt * dt)]
    i0 = np.searchsorted(t, np.arange(t[0], t[-1] - window, window))
    i1 = np.searchsorted(t, t[i0] + window)
    i0, i1 = i0[i1 < len(t)], i1[i1 < len(t)]
    distance = np.c_[arc[i1] - arc[i0], rolled[i1] - rolled[i0]]
    turn = np.c_[th[i1] - th[i0], phi[i1] - phi[i0]]
    return distance, turn, sq[i1] - sq[i0]


def _scale_and_variance(pairs: FloatArray, sum_dt2: FloatArray) -> tuple[float, float]:
    true, odo = pairs[:, 0], pairs[:, 1]
    scale = float(np.sum(true * odo) / np.sum(odo * odo))
    residual = true - scale * odo
    return scale, float(np.mean(residual**2) / np.mean(sum_dt2))


def _control_variances(run: MrclamRun, window: float) -> tuple[float, float, int]:
    """Per-step speed and turn-rate variances fitted over ``window`` s, and the
    number of windows."""
    distance, turn, sum_dt2 = _windows(run, window)
    if len(sum_dt2) < 10:
        raise ValueError(f"calibration needs at least 10 odometry windows of {window} s")
    return (
        _scale_and_variance(distance, sum_dt2)[1],
        _scale_and_variance(turn, sum_dt2)[1],
        len(sum_dt2),
    )


def correlation_window(
    run: MrclamRun, *, candidates: tuple[float, ...] = CANDIDATE_WINDOWS
) -> float:
    """The odometry error's correlation time: the shortest candidate window whose
    doubling raises neither fitted per-step variance (speed, turn rate) by more than
    two standard errors of that variance, ``2 sqrt(2 / n)`` for ``n`` windows
    (a one-sided test at about 2.5 %: a flat doubling is seldom taken for growth).

    A white per-step noise sums to a variance linear in the window, so the per-step
    variance fitted from white errors is the same over any window; errors that persist
    (slip, a miscalibrated wheel) make it grow until the window outlasts them. Beyond
    that time the white model is honest; below it, it is over-confident over the
    horizons a filter integrates between corrections. With no candidate pair left
    (too few windows), the longest window that still has ten is returned."""
    usable = []
    for w in sorted(candidates):
        if not w > 0:
            raise ValueError(f"candidate windows must be > 0, got {w}")
        try:
            usable.append((w, _control_variances(run, w)))
        except ValueError:
            break
    if not usable:
        raise ValueError("calibration needs at least 10 odometry windows")
    for (w, (v1, t1, _)), (_, (v2, t2, n2)) in itertools.pairwise(usable):
        limit = 1.0 + 2.0 * np.sqrt(2.0 / n2)
        if v2 <= limit * v1 and t2 <= limit * t1:
            return float(w)
    return float(usable[-1][0])


def calibrate_mrclam(run: MrclamRun, *, window: float | None = None) -> MrclamCalibration:
    """Fits the camera and odometry biases and noise of a
    :class:`rperc.datasets.MrclamRun` against its ground truth (see the module docs).
    ``window`` (s) defaults to :func:`correlation_window` of the run. Use
    :func:`mrclam_window` to fit on part of a run."""
    if len(run.measurement_t) < 10 or len(run.odometry_t) < 10:
        raise ValueError("calibration needs at least 10 sightings and 10 odometry rows")
    if window is None:
        window = correlation_window(run)
    if not window > 0:
        raise ValueError(f"window must be > 0, got {window}")
    # One window per odometry step at most: a window of 1e-9 s asked numpy for 10^12
    # window starts (issue 38's unbounded-spacing cause).
    mean_step = (run.odometry_t[-1] - run.odometry_t[0]) / (len(run.odometry_t) - 1)
    if window < mean_step:
        raise ValueError(f"window must be at least the mean odometry step {mean_step:.3g} s, "
                         f"got {window:.3g}")  # fmt: skip
    r, b = true_range_bearing(run)
    b_off, b_scale, b_res, b_in = _robust_line(b, run.measurement_bearing)
    depth = r * np.cos(b)
    r_off, r_scale, r_res, r_in = _robust_line(depth, run.measurement_range)
    inlier = b_in & r_in
    distance, turn, sum_dt2 = _windows(run, window)
    if len(sum_dt2) < 10:
        raise ValueError("calibration needs at least 10 odometry windows")
    v_scale, v_var = _scale_and_variance(distance, sum_dt2)
    w_scale, w_var = _scale_and_variance(turn, sum_dt2)
    # The filter sees corrected detections: residuals are divided by the scales.
    return MrclamCalibration(
        range_offset=r_off,
        range_scale=r_scale,
        bearing_offset=b_off,
        bearing_scale=b_scale,
        speed_scale=v_scale,
        turn_rate_scale=w_scale,
        range_variance=float(np.mean((r_res[inlier] / r_scale) ** 2)),
        bearing_variance=float(np.mean((b_res[inlier] / b_scale) ** 2)),
        speed_variance=v_var,
        turn_rate_variance=w_var,
        detections=int(inlier.sum()),
        outliers=int((~inlier).sum()),
        windows=len(sum_dt2),
        window=float(window),
    )


def mrclam_window(run: MrclamRun, start: float, stop: float) -> MrclamRun:
    """The part of a :class:`rperc.datasets.MrclamRun` with times in ``[start, stop)``
    seconds after its first odometry row (all its time series cut alike)."""
    t0 = float(run.odometry_t[0])
    if not 0 <= start < stop:
        raise ValueError(f"need 0 <= start < stop, got {start}, {stop}")

    def cut(t: FloatArray) -> npt.NDArray[np.bool_]:
        return np.asarray((t >= t0 + start) & (t < t0 + stop))

    o, m, g = cut(run.odometry_t), cut(run.measurement_t), cut(run.truth_t)
    if not (o.any() and m.any() and g.any()):
        raise ValueError(f"[{start}, {stop}) s holds no odometry, sightings or truth")
    return replace(
        run,
        odometry_t=run.odometry_t[o],
        odometry_v=run.odometry_v[o],
        odometry_omega=run.odometry_omega[o],
        measurement_t=run.measurement_t[m],
        measurement_landmark=run.measurement_landmark[m],
        measurement_range=run.measurement_range[m],
        measurement_bearing=run.measurement_bearing[m],
        truth_t=run.truth_t[g],
        truth_x=run.truth_x[g],
        truth_y=run.truth_y[g],
        truth_theta=run.truth_theta[g],
    )


def gate_inflation(
    run: MrclamRun,
    config: dict[str, object],
    *,
    factors: tuple[float, ...] = (1.0, 2.0, 4.0),
) -> tuple[float, float, int]:
    """The smallest inflation ``(detection, control)`` of the noise variances of
    ``config`` under which the run's known-association sightings are refused by the
    chi-square gate no more often than the gate's own rate, ``1 - gate_confidence``.

    The variances fitted by :func:`calibrate_mrclam` are those of single residuals;
    the filter also needs the errors that repeat (time stamps, slowly varying odometry
    slip, the surveyed positions), which inflate every innovation. The innovation test
    needs no ground truth (only the start pose), so this is the consistency a run can
    check by itself; it is fitted on the calibration data like the rest. Ties in the
    product of the two factors go to the smaller detection factor. Returns the two
    factors and the refused count."""
    from rperc.slam.planar import PlanarSlam, mrclam_recording, mrclam_start

    rate = 1.0 - as_config(PlanarConfig, config).gate_confidence
    recording = mrclam_recording(run)
    allowed = rate * len(run.measurement_t)
    pairs = sorted(
        ((fr, fq) for fr in factors for fq in factors), key=lambda p: (p[0] * p[1], p[0])
    )
    refused = -1
    for fr, fq in pairs:
        cfg = inflated(config, fr, fq)
        result = PlanarSlam({**cfg, **mrclam_start(run)}).run(recording)
        refused = int(result.statistics["rejected"])
        if refused <= allowed:
            return fr, fq, refused
    raise ValueError(f"no inflation in {factors} brings the refusals ({refused}) to {allowed:.1f}")


def inflated(config: dict[str, object], detection: float, control: float) -> dict[str, object]:
    """``config`` (a dict of :class:`rperc.config.PlanarConfig`'s fields with a unicycle
    motion) with its detection variances times ``detection`` and its control variances
    times ``control``."""
    typed = as_config(PlanarConfig, config)
    motion = typed.motion
    if not isinstance(motion, Unicycle):
        raise ValueError(f"inflated: the motion model must be a unicycle, got {motion!r}")
    unicycle = {
        "speed_variance": motion.speed_variance * control,
        "turn_rate_variance": motion.turn_rate_variance * control,
    }
    return {
        **config,
        "motion": {"unicycle": unicycle},
        "range_variance": typed.range_variance * detection,
        "bearing_variance": typed.bearing_variance * detection,
    }


def calibrate_mrclam_preset(
    run: MrclamRun,
    *,
    seconds: float,
    factors: tuple[float, ...],
) -> tuple[dict[str, object], MrclamCalibration, tuple[float, float]]:
    """The one procedure behind every robot's preset, on that robot's first
    ``seconds`` only (the rest stays held out): :func:`calibrate_mrclam`, then the
    linearisation and the inflation chosen by the innovation test (:func:`gate_inflation`
    over ``factors``), which needs no ground truth.

    First-estimates Jacobians (``first_estimates``) are tried first: linearised at its
    changing estimates the EKF gains heading information from nowhere (robot 3's
    full run: NEES mean 42 with the error 0.2 rad for minutes at 0.03 rad claimed).
    They rely on the first estimates, though: a robot that maps landmarks after an
    odometry slip in a stretch without sightings (robot 2: 46 s, 0.5 rad) keeps
    Jacobians that no longer describe the map, and its innovations fail the gate at
    every inflation. Then the filter is linearised at the current estimates.

    Returns the preset (a :class:`rperc.slam.PlanarSlam` config without a start
    pose), the calibration and the ``(detection, control)`` inflation."""
    half = mrclam_window(run, 0.0, seconds)
    calibration = calibrate_mrclam(half)
    for first_estimates in (True, False):
        fitted = {**calibration.config(), "first_estimates": first_estimates}
        try:
            detection, control, _ = gate_inflation(half, fitted, factors=factors)
        except ValueError:
            if not first_estimates:
                raise
            continue
        return inflated(fitted, detection, control), calibration, (detection, control)
    raise AssertionError("unreachable: the last choice raises or returns")
