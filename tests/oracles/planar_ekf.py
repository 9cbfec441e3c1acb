"""A straightforward numpy EKF-SLAM, the one a Python user would write today
(PythonRobotics style): one dense state vector ``[x, y, theta, l1x, l1y, ...]`` that
grows with the map, one dense covariance, the models written out in numpy.

It is the peer of rperc's planar SLAM in ``benchmarks/planar_slam.py`` and an oracle in
the tests, so its models are the ones of the Rust ``slam`` crate, term for term:

- the unicycle of ``crates/slam/src/motion/unicycle.rs`` (exact arc integration with the same
  series below ``|omega dt| < 1e-2``) and the Ackermann vehicle of
  ``crates/slam/src/motion/ackermann.rs`` (encoder speed at the rear left wheel, steering, a
  laser ahead and to the left of the rear axle);
- range-bearing to point landmarks (``crates/slam/src/observation.rs``), bearings
  wrapped into (-pi, pi];
- the EKF of the seed paper (eqs. 3-9), Joseph form;
- association by known identity, or without identities by the rules of rperc's
  engine, written again in Python rather than translated: individual compatibility
  by a Mahalanobis chi-square gate, then nearest neighbour or JCBB (Neira & Tardos
  2001; here a recursive branch and bound taking the joint NIS from a fresh Cholesky
  factor of each hypothesis, where the Rust keeps an explicit stack and grows one
  factor), and a candidate list that admits a landmark after k consistent sightings.

``structured=False`` (the default) is the textbook dense form: the prediction builds
the full ``F`` and computes ``F P F^T`` (O(n^3)); the update computes ``P H^T`` with
the full ``H`` and the Joseph form with full ``I - K H`` (O(n^3)). ``structured=True``
is what a careful numpy user writes instead: the prediction touches the robot rows and
columns only (O(n)), and the update uses the sparsity of ``H`` (O(n^2)). Both give the
same numbers; the benchmark should quote rperc against the structured one.

    from oracles.planar_ekf import PlanarEkfSlam, unicycle
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

SERIES_BELOW = 1e-2  # as unicycle.rs: closed forms lose digits to cancellation below


def wrap(a: float) -> float:
    """Into (-pi, pi], as rperc-core's wrap_angle."""
    w = a % (2.0 * math.pi)
    return w - 2.0 * math.pi if w > math.pi else w


def chi2_quantile_2dof(p: float) -> float:
    """The chi-square quantile for 2 degrees of freedom, in closed form: its CDF is
    ``1 - exp(-x / 2)`` (no scipy needed at run time)."""
    return -2.0 * math.log1p(-p)


def chi2_quantile_even(p: float, dof: int) -> float:
    """The chi-square quantile for an even number of degrees of freedom ``2k``, by
    bisection on its closed-form CDF ``1 - exp(-x/2) sum_{i<k} (x/2)^i / i!``."""
    if dof % 2 or dof < 2 or not 0.0 < p < 1.0:
        raise ValueError(f"need an even dof >= 2 and p in (0, 1), got {dof}, {p}")

    def cdf(x: float) -> float:
        term, total = 1.0, 1.0
        for i in range(1, dof // 2):
            term *= x / 2.0 / i
            total += term
        return 1.0 - math.exp(-x / 2.0) * total

    lo, hi = 0.0, float(dof)
    while cdf(hi) < p:
        lo, hi = hi, 2.0 * hi
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if mid in (lo, hi):
            break
        lo, hi = (mid, hi) if cdf(mid) < p else (lo, mid)
    return hi


# ------------------------------------------------------------------ motion


def arc_functions(phi: float) -> tuple[float, float, float, float]:
    """``sin(phi)/phi``, its derivative, ``(1 - cos phi)/phi`` and its derivative."""
    if abs(phi) < SERIES_BELOW:
        p2 = phi * phi
        f = 1.0 - p2 / 6.0 * (1.0 - p2 / 20.0 * (1.0 - p2 / 42.0))
        df = -phi / 3.0 * (1.0 - p2 / 10.0 * (1.0 - p2 / 28.0))
        g = phi / 2.0 * (1.0 - p2 / 12.0 * (1.0 - p2 / 30.0 * (1.0 - p2 / 56.0)))
        dg = 0.5 * (1.0 - p2 / 4.0 * (1.0 - p2 / 18.0 * (1.0 - p2 / 40.0)))
        return f, df, g, dg
    s, c = math.sin(phi), math.cos(phi)
    one_minus_cos = 2.0 * math.sin(phi / 2.0) ** 2
    return s / phi, (phi * c - s) / phi**2, one_minus_cos / phi, (phi * s - one_minus_cos) / phi**2


def unicycle(
    pose: np.ndarray, v: float, omega: float, dt: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Constant ``(v, omega)`` over ``dt``, integrated exactly (an arc): the new pose,
    ``Fx = d(pose')/d(pose)`` (3x3) and ``Fv = d(pose')/d(v, omega)`` (3x2)."""
    phi = omega * dt
    f, df, g, dg = arc_functions(phi)
    s, c = math.sin(pose[2]), math.cos(pose[2])
    d = v * dt
    dx, dy = d * (c * f - s * g), d * (s * f + c * g)
    mean = np.array([pose[0] + dx, pose[1] + dy, wrap(pose[2] + phi)])
    fx = np.array([[1.0, 0.0, -dy], [0.0, 1.0, dx], [0.0, 0.0, 1.0]])
    fv = np.array(
        [
            [dt * (c * f - s * g), d * dt * (c * df - s * dg)],
            [dt * (s * f + c * g), d * dt * (s * df + c * dg)],
            [0.0, dt],
        ]
    )
    return mean, fx, fv


@dataclass(frozen=True)
class Ackermann:
    """Victoria Park's car (defaults: the public implementations' constants)."""

    wheel_base: float = 2.83
    encoder_offset: float = 0.76
    laser_forward: float = 3.78
    laser_left: float = 0.50

    def centre_velocity(self, speed: float, steer: float) -> tuple[float, float, np.ndarray]:
        """``(v_c, omega)`` of the rear axle centre from the encoder speed and the
        steering, and ``d(v_c, omega)/d(speed, steer)``."""
        length, h = self.wheel_base, self.encoder_offset
        tan = math.tan(steer)
        den = 1.0 - tan * h / length
        if abs(steer) >= math.pi / 2 or den <= 0.0:
            raise ValueError(f"steering {steer} rad puts the encoder wheel past the turn centre")
        sec2 = 1.0 + tan * tan
        vc = speed / den
        dvc_dsteer = speed * (h / length) * sec2 / den**2
        j = np.array(
            [
                [1.0 / den, dvc_dsteer],
                [tan / (length * den), (dvc_dsteer * tan + vc * sec2) / length],
            ]
        )
        return vc, vc * tan / length, j

    def predict(
        self, pose: np.ndarray, speed: float, steer: float, dt: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        vc, omega, j = self.centre_velocity(speed, steer)
        mean, fx, fv = unicycle(pose, vc, omega, dt)
        return mean, fx, fv @ j

    def laser_pose(self, pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The laser's pose (same heading) and ``d(laser pose)/d(pose)``."""
        s, c = math.sin(pose[2]), math.cos(pose[2])
        a, b = self.laser_forward, self.laser_left
        laser = np.array([pose[0] + c * a - s * b, pose[1] + s * a + c * b, pose[2]])
        j = np.array([[1.0, 0.0, -s * a - c * b], [0.0, 1.0, c * a - s * b], [0.0, 0.0, 1.0]])
        return laser, j


# ------------------------------------------------------------------ observation


def range_bearing(
    pose: np.ndarray, landmark: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``z = (range, bearing)`` of ``landmark`` from ``pose``, ``dz/d(pose)`` (2x3) and
    ``dz/d(landmark)`` (2x2)."""
    dx, dy = landmark[0] - pose[0], landmark[1] - pose[1]
    q = dx * dx + dy * dy
    if q == 0.0:
        raise ValueError("the landmark sits on the sensor")
    r = math.sqrt(q)
    z = np.array([r, wrap(math.atan2(dy, dx) - pose[2])])
    h_pose = np.array([[-dx / r, -dy / r, 0.0], [dy / q, -dx / q, -1.0]])
    h_landmark = np.array([[dx / r, dy / r], [-dy / q, dx / q]])
    return z, h_pose, h_landmark


def landmark_from_range_bearing(
    pose: np.ndarray, z: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The inverse: the landmark at ``z`` from ``pose``, ``dl/d(pose)`` and ``dl/dz``."""
    a = pose[2] + z[1]
    s, c = math.sin(a), math.cos(a)
    landmark = np.array([pose[0] + z[0] * c, pose[1] + z[0] * s])
    g_pose = np.array([[1.0, 0.0, -z[0] * s], [0.0, 1.0, z[0] * c]])
    g_z = np.array([[c, -z[0] * s], [s, z[0] * c]])
    return landmark, g_pose, g_z


# ------------------------------------------------------------------ the filter


@dataclass
class AssociationStats:
    """What happened to every sighting."""

    accepted: int = 0  # updated a mapped landmark
    rejected: int = 0  # failed the gate (known ids), or compatible but left unpaired
    new: int = 0  # started a landmark
    candidate: int = 0  # joined or started a candidate that is not yet a landmark
    truncated: int = 0  # scans whose JCBB search ran out of nodes

    def total(self) -> int:
        return self.accepted + self.rejected + self.new + self.candidate


@dataclass(frozen=True)
class Pairing:
    """Sighting ``det`` of a scan paired with landmark ``j``, linearised at the prior:
    its NIS, innovation (bearing wrapped) and the two blocks of its Jacobian."""

    det: int
    j: int
    nis: float
    nu: np.ndarray
    h_robot: np.ndarray  # 2x3
    h_landmark: np.ndarray  # 2x2


@dataclass
class Candidate:
    """A point seen ``count`` times that is not yet a landmark."""

    mean: np.ndarray
    cov: np.ndarray
    count: int
    last_seen: float

    def fuse(self, point: np.ndarray, cov: np.ndarray, t: float) -> None:
        """Information-form fusion of a new sighting (the two taken as independent:
        good enough for an admission test)."""
        a, b = np.linalg.inv(self.cov), np.linalg.inv(cov)
        self.cov = np.linalg.inv(a + b)
        self.mean = self.cov @ (a @ self.mean + b @ point)
        self.count += 1
        self.last_seen = t


class _OutOfNodes(Exception):
    """JCBB spent its node budget."""


def nearest_neighbour(options: list[list[Pairing]]) -> list[Pairing]:
    """Greedy over all compatible pairings by increasing NIS: a pairing is taken when
    neither its sighting nor its landmark is taken yet."""
    chosen: list[Pairing] = []
    dets: set[int] = set()
    marks: set[int] = set()
    for p in sorted((p for o in options for p in o), key=lambda p: p.nis):
        if p.det not in dets and p.j not in marks:
            dets.add(p.det)
            marks.add(p.j)
            chosen.append(p)
    return chosen


@dataclass
class PlanarEkfSlam:
    """EKF-SLAM over ``[x, y, theta, l1x, l1y, ...]`` with dense numpy matrices.

    ``control_noise`` ``V`` (2x2) is the covariance of the two controls (``(v, omega)``
    for the unicycle, ``(encoder speed, steering)`` with ``vehicle``); ``measurement_noise``
    ``R`` (2x2) that of ``(range, bearing)``. With ``vehicle`` the range-bearing is
    measured from its laser, otherwise from the robot's centre. ``gate`` is the
    probability of the chi-square gates on the NIS (individual, and joint in JCBB).
    Without identities (:meth:`observe_unknown`), ``association`` is ``"nn"`` or
    ``"jcbb"``, a new landmark needs ``candidate_sightings`` consistent sightings, a
    candidate unseen for ``candidate_window`` seconds is dropped, and JCBB makes at
    most ``jcbb_max_nodes`` joint tests per scan (the meanings and defaults of
    rperc's ``PlanarConfig`` fields of those names).
    """

    pose: np.ndarray
    pose_covariance: np.ndarray
    control_noise: np.ndarray
    measurement_noise: np.ndarray
    vehicle: Ackermann | None = None
    structured: bool = False
    gate: float = 0.99
    gate_known: bool = True
    association: str = "nn"
    candidate_sightings: int = 1
    candidate_window: float = 10.0
    jcbb_max_nodes: int = 20_000
    x: np.ndarray = field(init=False)
    P: np.ndarray = field(init=False)
    ids: list[int] = field(init=False, default_factory=list)
    stats: AssociationStats = field(init=False, default_factory=AssociationStats)
    candidates: list[Candidate] = field(init=False, default_factory=list)
    _joint_gates: list[float] = field(init=False, default_factory=lambda: [0.0])

    def __post_init__(self) -> None:
        self.x = np.array(self.pose, dtype=np.float64).copy()
        self.P = np.array(self.pose_covariance, dtype=np.float64).copy()
        self.V = np.asarray(self.control_noise, dtype=np.float64)
        self.R = np.asarray(self.measurement_noise, dtype=np.float64)
        self.gate_d2 = chi2_quantile_2dof(self.gate)

    @property
    def num_landmarks(self) -> int:
        return (len(self.x) - 3) // 2

    def landmarks(self) -> np.ndarray:
        """``(n, 2)`` landmark means, in the order they were added."""
        return self.x[3:].reshape(-1, 2)

    def landmark_covariance(self, j: int) -> np.ndarray:
        o = 3 + 2 * j
        return self.P[o : o + 2, o : o + 2].copy()

    # -------------------------------------------------------------- prediction

    def predict(self, u1: float, u2: float, dt: float) -> None:
        """Seed eqs. (3) and (5): the robot moves, ``P <- F P F^T + G V G^T``."""
        if self.vehicle is None:
            mean, fx, fv = unicycle(self.x[:3], u1, u2, dt)
        else:
            mean, fx, fv = self.vehicle.predict(self.x[:3], u1, u2, dt)
        self.x[:3] = mean
        if self.structured:
            # Only the robot rows and columns change: O(n).
            self.P[:3, :] = fx @ self.P[:3, :]
            self.P[:, :3] = self.P[:, :3] @ fx.T
            self.P[:3, :3] += fv @ self.V @ fv.T
            return
        n = len(self.x)
        f = np.eye(n)
        f[:3, :3] = fx
        g = np.zeros((n, 2))
        g[:3] = fv
        self.P = f @ self.P @ f.T + g @ self.V @ g.T

    # -------------------------------------------------------------- observation

    def _sensor(self) -> tuple[np.ndarray, np.ndarray]:
        """The sensor's pose and its Jacobian wrt the robot pose."""
        if self.vehicle is None:
            return self.x[:3], np.eye(3)
        return self.vehicle.laser_pose(self.x[:3])

    def predict_observation(self, j: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``h(x)`` for landmark ``j``, ``dh/d(robot)`` and ``dh/d(landmark)``."""
        sensor, j_sensor = self._sensor()
        o = 3 + 2 * j
        z, h_sensor, h_landmark = range_bearing(sensor, self.x[o : o + 2])
        return z, h_sensor @ j_sensor, h_landmark

    def nis(self, j: int, z: np.ndarray) -> float:
        """Normalised innovation squared of ``z`` against landmark ``j`` (prior)."""
        zhat, h_r, h_l = self.predict_observation(j)
        o = 3 + 2 * j
        nu = np.array([z[0] - zhat[0], wrap(z[1] - zhat[1])])
        cols = [0, 1, 2, o, o + 1]
        h = np.hstack([h_r, h_l])
        s = h @ self.P[np.ix_(cols, cols)] @ h.T + self.R
        return float(nu @ np.linalg.solve(s, nu))

    def nis_all(self, z: np.ndarray) -> np.ndarray:
        """:meth:`nis` of ``z`` against every landmark at once, ``(n,)``: the same
        algebra on stacked 2x3 and 2x2 Jacobians, so that nearest neighbour costs one
        numpy pass per sighting instead of a Python loop over the map."""
        n = self.num_landmarks
        sensor, j_sensor = self._sensor()
        d = self.landmarks() - sensor[:2]
        q = np.einsum("ij,ij->i", d, d)
        r = np.sqrt(q)
        dx, dy, zero = d[:, 0], d[:, 1], np.zeros(n)
        h_s = np.stack([[-dx / r, -dy / r, zero], [dy / q, -dx / q, zero - 1.0]]).transpose(2, 0, 1)
        h_r = h_s @ j_sensor
        h_l = np.stack([[dx / r, dy / r], [-dy / q, dx / q]]).transpose(2, 0, 1)
        off = 3 + 2 * np.arange(n)
        p_rl = self.P[:3, 3:].reshape(3, n, 2).transpose(1, 0, 2)  # (n, 3, 2)
        p_ll = self.P[off[:, None, None] + [[0], [1]], off[:, None, None] + [[0, 1]]]
        cross = h_r @ p_rl @ h_l.transpose(0, 2, 1)
        s = h_r @ self.P[:3, :3] @ h_r.transpose(0, 2, 1) + cross + cross.transpose(0, 2, 1)
        s += h_l @ p_ll @ h_l.transpose(0, 2, 1) + self.R
        bearing = np.arctan2(dy, dx) - sensor[2]
        nu = np.stack([z[0] - r, np.mod(z[1] - bearing + math.pi, 2 * math.pi) - math.pi], 1)
        return np.einsum("ij,ij->i", nu, np.linalg.solve(s, nu[:, :, None])[:, :, 0])

    def _stack(self, pairs: list[tuple[int, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
        """The stacked innovation (bearings wrapped) and dense ``H`` of a scan."""
        n, m = len(self.x), len(pairs)
        nu, h = np.zeros(2 * m), np.zeros((2 * m, n))
        for k, (j, z) in enumerate(pairs):
            zhat, h_r, h_l = self.predict_observation(j)
            nu[2 * k : 2 * k + 2] = [z[0] - zhat[0], wrap(z[1] - zhat[1])]
            o = 3 + 2 * j
            h[2 * k : 2 * k + 2, :3], h[2 * k : 2 * k + 2, o : o + 2] = h_r, h_l
        return nu, h

    def update(self, pairs: list[tuple[int, np.ndarray]]) -> None:
        """One batch update (seed eqs. 6-9, Joseph form) with sightings ``(j, z)``."""
        if not pairs:
            return
        nu, h = self._stack(pairs)
        r = np.kron(np.eye(len(pairs)), self.R)
        if self.structured:
            # H touches 5 columns per sighting: P H^T in O(n m), the expanded Joseph
            # form P - K (P H^T)^T - (P H^T) K^T + K S K^T in O(n^2 m).
            cols = np.flatnonzero(np.any(h != 0.0, axis=0))
            pht = self.P[:, cols] @ h[:, cols].T
            s = h[:, cols] @ pht[cols] + r
            k = np.linalg.solve(s, pht.T).T
            self.P += -k @ pht.T - pht @ k.T + k @ s @ k.T
            # Unlike the product form, this sum does not shrink an asymmetric part of
            # P left by rounding: it would grow over thousands of updates (measured on
            # MR.CLAM: 6e-3 after 477 updates, then a negative eigenvalue).
            self.P = 0.5 * (self.P + self.P.T)
        else:
            s = h @ self.P @ h.T + r
            k = self.P @ h.T @ np.linalg.inv(s)
            ikh = np.eye(len(self.x)) - k @ h
            self.P = ikh @ self.P @ ikh.T + k @ r @ k.T
        self.x += k @ nu
        self.x[2] = wrap(self.x[2])

    def add_landmark(self, ident: int, z: np.ndarray) -> int:
        """Appends the landmark first seen at ``z`` with its full covariance:
        ``P_ll = G_x P_xx G_x^T + G_z R G_z^T``, ``P_l* = G_x P_x*``."""
        sensor, j_sensor = self._sensor()
        landmark, g_sensor, g_z = landmark_from_range_bearing(sensor, z)
        g_x = g_sensor @ j_sensor
        n = len(self.x)
        cross = g_x @ self.P[:3, :]  # 2 x n
        p = np.zeros((n + 2, n + 2))
        p[:n, :n] = self.P
        p[n:, :n], p[:n, n:] = cross, cross.T
        p[n:, n:] = g_x @ self.P[:3, :3] @ g_x.T + g_z @ self.R @ g_z.T
        self.x, self.P = np.concatenate([self.x, landmark]), p
        self.ids.append(int(ident))
        self.stats.new += 1
        return self.num_landmarks - 1

    # -------------------------------------------------------------- association

    def observe_known(self, ids: list[int], zs: np.ndarray) -> None:
        """A scan with known identities: mapped landmarks (each through the NIS gate
        when ``gate_known``) in one batch update, then new ones initialised."""
        index = {ident: k for k, ident in enumerate(self.ids)}
        pairs, new, again = [], {}, []
        for ident, z in zip(ids, np.asarray(zs, dtype=np.float64), strict=True):
            j = index.get(int(ident))
            if j is None:
                # A new id seen twice in one scan: the first sighting starts it, the
                # others update it once it exists.
                if int(ident) in new:
                    again.append((int(ident), z))
                else:
                    new[int(ident)] = z
            elif self.gate_known and self.nis(j, z) > self.gate_d2:
                self.stats.rejected += 1
            else:
                pairs.append((j, z))
        self.stats.accepted += len(pairs)
        self.update(pairs)
        for ident, z in new.items():
            self.add_landmark(ident, z)
        if again:
            self.observe_known([i for i, _ in again], np.array([z for _, z in again]))

    def observe_unknown(self, zs: np.ndarray, t: float) -> None:
        """A scan without identities at time ``t``, associated as rperc's engine
        does (``crates/slam/src/planar``), written again from its description:

        1. individual compatibility: each sighting's landmarks within the NIS gate;
        2. ``association="jcbb"``: the jointly compatible hypothesis with the most
           pairings (:meth:`jcbb`); ``"nn"``: greedy over all pairings by NIS;
        3. the pairings in one batch update; a sighting compatible with some
           landmark but left unpaired is rejected (ambiguous, not new);
        4. a sighting compatible with no landmark joins the candidate list
           (:meth:`sighting`), after the list drops candidates unseen for
           ``candidate_window`` seconds.
        """
        zs = np.asarray(zs, dtype=np.float64)
        options = self.compatible(zs)
        if self.association == "jcbb":
            pairs, truncated = self.jcbb(options)
            self.stats.truncated += int(truncated)
        elif self.association == "nn":
            pairs = nearest_neighbour(options)
        else:
            raise ValueError(f"association must be 'nn' or 'jcbb', got {self.association!r}")
        paired = {p.det for p in pairs}
        self.stats.accepted += len(pairs)
        self.stats.rejected += sum(1 for i, o in enumerate(options) if o and i not in paired)
        self.update([(p.j, zs[p.det]) for p in sorted(pairs, key=lambda p: p.det)])
        self.candidates = [c for c in self.candidates if t - c.last_seen <= self.candidate_window]
        for i, o in enumerate(options):
            if not o:
                self.sighting(zs[i], t)

    def compatible(self, zs: np.ndarray) -> list[list[Pairing]]:
        """For each sighting, the landmarks whose NIS is within the gate, as
        :class:`Pairing` s in increasing NIS (ties in map order)."""
        out = []
        for i, z in enumerate(zs):
            d2 = self.nis_all(z) if self.num_landmarks else np.zeros(0)
            near = np.flatnonzero(d2 <= self.gate_d2)
            near = near[np.argsort(d2[near], kind="stable")]
            out.append([self.pairing(i, int(j), z, float(d2[j])) for j in near])
        return out

    def pairing(self, det: int, j: int, z: np.ndarray, nis: float) -> Pairing:
        zhat, h_r, h_l = self.predict_observation(j)
        nu = np.array([z[0] - zhat[0], wrap(z[1] - zhat[1])])
        return Pairing(det, j, nis, nu, h_r, h_l)

    def joint_gate(self, k: int) -> float:
        """The chi-square gate of ``k`` stacked sightings (2k degrees of freedom)."""
        while len(self._joint_gates) <= k:
            self._joint_gates.append(chi2_quantile_even(self.gate, 2 * len(self._joint_gates)))
        return self._joint_gates[k]

    def joint_nis(self, hyp: list[Pairing]) -> float | None:
        """``nu^T S^-1 nu`` of the stacked pairings, ``S = H P H^T + R`` over the robot
        and the landmarks involved; ``None`` when ``S`` is not positive definite."""
        k = len(hyp)
        cols = [0, 1, 2] + [3 + 2 * p.j + e for p in hyp for e in (0, 1)]
        h = np.zeros((2 * k, 3 + 2 * k))
        for i, p in enumerate(hyp):
            h[2 * i : 2 * i + 2, :3] = p.h_robot
            h[2 * i : 2 * i + 2, 3 + 2 * i : 5 + 2 * i] = p.h_landmark
        s = h @ self.P[np.ix_(cols, cols)] @ h.T + np.kron(np.eye(k), self.R)
        try:
            lower = np.linalg.cholesky(s)
        except np.linalg.LinAlgError:
            return None
        y = np.linalg.solve(lower, np.concatenate([p.nu for p in hyp]))
        return float(y @ y)

    def jcbb(self, options: list[list[Pairing]]) -> tuple[list[Pairing], bool]:
        """Joint compatibility branch and bound (Neira & Tardos 2001), recursive: of
        all hypotheses (each sighting paired with one of its compatible landmarks or
        with none, each landmark at most once) whose joint NIS passes the gate of its
        dimension, the one with the most pairings, ties to the smaller joint NIS.
        Sightings are visited in order, their options in increasing NIS, the null
        option last; a branch is cut when pairing every remaining sighting could not
        beat the best. After ``jcbb_max_nodes`` joint tests the best so far is
        returned, and the flag says so."""
        levels = [o for o in options if o]
        best: list[Pairing] = []
        best_nis, nodes = math.inf, 0

        def hopeless(pairs: int, level: int, nis: float) -> bool:
            reach = pairs + len(levels) - level
            return reach < len(best) or (reach == len(best) and bool(best) and nis >= best_nis)

        def search(level: int, hyp: list[Pairing], nis: float) -> None:
            nonlocal best, best_nis, nodes
            if level == len(levels):
                if len(hyp) > len(best) or (len(hyp) == len(best) and nis < best_nis):
                    best, best_nis = list(hyp), nis
                return
            for p in [*levels[level], None]:
                if hopeless(len(hyp), level, nis):
                    return
                if p is None:
                    search(level + 1, hyp, nis)
                    continue
                if any(q.j == p.j for q in hyp):
                    continue
                nodes += 1
                if nodes > self.jcbb_max_nodes:
                    raise _OutOfNodes
                joint = self.joint_nis([*hyp, p])
                if joint is not None and joint <= self.joint_gate(len(hyp) + 1):
                    search(level + 1, [*hyp, p], joint)

        try:
            search(0, [], 0.0)
        except _OutOfNodes:
            return best, True
        return best, False

    def sighting(self, z: np.ndarray, t: float) -> None:
        """A sighting no landmark explains: it joins the nearest candidate within the
        Mahalanobis gate (fused in information form) or starts one; the candidate
        seen ``candidate_sightings`` times enters the map, initialised from this
        sighting."""
        sensor, j_sensor = self._sensor()
        point, g_sensor, g_z = landmark_from_range_bearing(sensor, z)
        g_x = g_sensor @ j_sensor
        cov = g_x @ self.P[:3, :3] @ g_x.T + g_z @ self.R @ g_z.T
        k = self.nearest_candidate(point, cov)
        if k is None:
            self.candidates.append(Candidate(point, cov, 1, t))
            k = len(self.candidates) - 1
        else:
            self.candidates[k].fuse(point, cov, t)
        if self.candidates[k].count < self.candidate_sightings:
            self.stats.candidate += 1
            return
        del self.candidates[k]
        self.add_landmark(len(self.ids), z)

    def nearest_candidate(self, point: np.ndarray, cov: np.ndarray) -> int | None:
        """The candidate of least Mahalanobis distance to ``point``, if within the gate."""
        best, best_d2 = None, math.inf
        for k, c in enumerate(self.candidates):
            e = point - c.mean
            d2 = float(e @ np.linalg.solve(c.cov + cov, e))
            if d2 <= self.gate_d2 and d2 < best_d2:
                best, best_d2 = k, d2
        return best

    def pose_nees(self, truth: np.ndarray) -> float:
        """``e^T P_xx^-1 e`` of the robot pose against ``truth`` (heading wrapped)."""
        e = self.x[:3] - np.asarray(truth, dtype=np.float64)
        e[2] = wrap(e[2])
        return float(e @ np.linalg.solve(self.P[:3, :3], e))


# ------------------------------------------------------------------ MR.CLAM driver


@dataclass
class RunResult:
    """A whole run: the pose and robot covariance after every odometry record."""

    t: np.ndarray  # (N,) odometry times
    poses: np.ndarray  # (N, 3)
    covariances: np.ndarray  # (N, 3, 3)
    landmark_ids: np.ndarray  # (n,) subject numbers, in the order they were mapped
    landmarks: np.ndarray  # (n, 2)
    stats: AssociationStats
    seconds: float  # wall time of the filter loop


def _scans(t: np.ndarray) -> list[tuple[int, int]]:
    """``[start, end)`` row ranges of the measurements sharing one time stamp."""
    cuts = np.flatnonzero(np.diff(t) != 0) + 1
    bounds = np.r_[0, cuts, len(t)]
    return list(zip(bounds[:-1].tolist(), bounds[1:].tolist(), strict=True))


def initial_pose(run: Any) -> np.ndarray:
    """The ground truth at the first odometry time (heading along the shorter arc)."""
    t0 = run.odometry_t[0]
    k = int(np.clip(np.searchsorted(run.truth_t, t0) - 1, 0, len(run.truth_t) - 2))
    s = (t0 - run.truth_t[k]) / (run.truth_t[k + 1] - run.truth_t[k])
    th = run.truth_theta[k] + s * wrap(run.truth_theta[k + 1] - run.truth_theta[k])
    x = run.truth_x[k] + s * (run.truth_x[k + 1] - run.truth_x[k])
    y = run.truth_y[k] + s * (run.truth_y[k + 1] - run.truth_y[k])
    return np.array([x, y, wrap(th)])


def drive(
    slam: PlanarEkfSlam,
    t_controls: np.ndarray,
    controls: np.ndarray,
    t_sightings: np.ndarray,
    observe: Callable[[int, int], None],
) -> RunResult:
    """Drives ``slam`` through controls ``(N, 2)`` at times ``t_controls`` and the
    scans of ``t_sightings`` (rows sharing one time), calling ``observe(a, b)`` for
    the rows ``[a, b)`` of each scan.

    Controls are held constant until the next record; a scan between two records is
    applied after predicting up to its own time, so every prediction covers exactly
    the time that passed. The pose is recorded at every control time.
    """
    scans, s = _scans(t_sightings), 0
    poses, covs = np.empty((len(t_controls), 3)), np.empty((len(t_controls), 3, 3))
    start, now = time.perf_counter(), t_controls[0]
    poses[0], covs[0] = slam.x[:3], slam.P[:3, :3]
    for k in range(1, len(t_controls) + 1):
        end = t_controls[k] if k < len(t_controls) else math.inf
        while s < len(scans) and t_sightings[scans[s][0]] < end:
            a, b = scans[s]
            if t_sightings[a] > now:
                slam.predict(controls[k - 1, 0], controls[k - 1, 1], t_sightings[a] - now)
                now = t_sightings[a]
            observe(a, b)
            s += 1
        if k < len(t_controls):
            slam.predict(controls[k - 1, 0], controls[k - 1, 1], t_controls[k] - now)
            now = t_controls[k]
            poses[k], covs[k] = slam.x[:3], slam.P[:3, :3]
    seconds = time.perf_counter() - start
    ids, marks = np.array(slam.ids, dtype=np.int64), slam.landmarks().copy()
    return RunResult(t_controls, poses, covs, ids, marks, slam.stats, seconds)


def run_mrclam(run: Any, slam: PlanarEkfSlam) -> RunResult:
    """A :class:`rperc.datasets.MrclamRun` with known association (barcodes)."""
    z = np.c_[run.measurement_range, run.measurement_bearing]
    controls = np.c_[run.odometry_v, run.odometry_omega]

    def observe(a: int, b: int) -> None:
        slam.observe_known(run.measurement_landmark[a:b].tolist(), z[a:b])

    return drive(slam, run.odometry_t, controls, run.measurement_t, observe)


def ackermann_filter(config: dict[str, Any]) -> PlanarEkfSlam:
    """The structured filter with the settings of a complete rperc ``PlanarSlam``
    config for the Ackermann vehicle (rperc's ``defaults()`` with the run's fields on
    top): start, noise, gate and association. The vehicle's fields it leaves out take
    the defaults of ``crates/slam/src/motion/ackermann.rs`` (those of :class:`Ackermann`,
    and the published 0.2 m^2/s^2 and 0.025 rad^2 control noise)."""
    variants = [k for k in ("anchor", "external_fix", "freeze_after") if config.get(k)]
    identity = {
        "range_offset": 0.0,
        "range_scale": 1.0,
        "range_is_depth": False,
        "bearing_offset": 0.0,
        "bearing_scale": 1.0,
        "control_scale": [1.0, 1.0],
    }
    bias = {k: list(v) if isinstance(v, tuple) else v for k, v in config.get("bias", {}).items()}
    if {**identity, **bias} != identity:
        variants.append("bias")
    if variants:
        raise ValueError(f"the reference does not implement {variants}")
    car = config["motion"]["ackermann"]
    geometry = ("wheel_base", "encoder_offset", "laser_forward", "laser_left")
    return PlanarEkfSlam(
        pose=np.array(config["initial_pose"], dtype=np.float64),
        pose_covariance=np.diag(config["initial_pose_variance"]).astype(np.float64),
        control_noise=np.diag(
            [car.get("speed_variance", 0.2), car.get("steering_variance", 0.025)]
        ),
        measurement_noise=np.diag([config["range_variance"], config["bearing_variance"]]),
        vehicle=Ackermann(**{k: car[k] for k in geometry if k in car}),
        structured=True,
        gate=config["gate_confidence"],
        association=config["association"],
        candidate_sightings=config["candidate_sightings"],
        candidate_window=config["candidate_window"],
        jcbb_max_nodes=config["jcbb_max_nodes"],
    )


def first_scans(park: Any, scans: int) -> Any:
    """The prefix of a :class:`rperc.datasets.VictoriaPark` run up to the end of its
    ``scans``-th laser scan: controls, detections and GPS up to that time."""
    times = np.unique(park.measurement_t)
    if not 1 <= scans <= len(times):
        raise ValueError(f"scans must be in [1, {len(times)}], got {scans}")
    end = times[scans - 1]
    cut = {group: getattr(park, f"{group}_t") <= end for group in ("measurement", "input", "gps")}
    fields = {
        name: value[cut[name.split("_")[0]]]
        for name, value in vars(park).items()
        if isinstance(value, np.ndarray) and name.split("_")[0] in cut
    }
    return dataclasses.replace(park, **fields)


def run_victoria_park(park: Any, slam: PlanarEkfSlam) -> RunResult:
    """A :class:`rperc.datasets.VictoriaPark` run without identities, associated by
    ``slam.association`` (``slam`` should carry the :class:`Ackermann` vehicle). GPS
    is not used."""
    z = np.c_[park.measurement_range, park.measurement_bearing]
    controls = np.c_[park.input_speed, park.input_steering]
    t = park.measurement_t

    def observe(a: int, b: int) -> None:
        slam.observe_unknown(z[a:b], float(t[a]))

    return drive(slam, park.input_t, controls, park.measurement_t, observe)
