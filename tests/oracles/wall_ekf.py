"""A numpy EKF-SLAM with wall landmarks, the peer of rperc's planar engine with walls
(``crates/slam/src/planar/walls.rs``) in ``benchmarks/wall_slam.py``: the same filter
written out in numpy, for the plain variant (no anchor, no freezing), term for term:

- the unicycle of ``oracles.planar_ekf`` (the sensor at the robot's origin);
- each wall's line ``(rho, alpha)`` about its reference point ``o`` (the middle of
  the segment that first showed it), observed as
  ``rho_r = rho - (x - o_x) cos a - (y - o_y) sin a``, ``alpha_r = alpha - theta``,
  written with ``rho_r >= 0`` (``crates/slam/src/wall.rs``), the innovation compared
  with the line's other form when the angles are more than pi/2 apart;
- with ``segment`` (the engine's default ``wall_innovation="segment"``): the
  innovation's first row is the signed distance, along the predicted normal, of the
  seen segment's middle (on the detected line) from the predicted line, its Jacobian
  and noise those of the offset at that point;
- a detection whose angle sd exceeds ``max_angle_sd`` is not used;
- pairing: segment overlap on the wall's line (gap <= ``overlap_gap``) and the
  Mahalanobis gate; each detection takes its nearest wall; a detection with no wall
  inside the gate becomes new only outside the admission gate of every overlapping
  wall;
- one stacked Joseph-form update per scan (the structured O(n^2) form), extents grown
  with the updated pose, new walls with ``G_r P G_r^T + G_z R G_z^T`` and their
  cross-covariance ``G_r P_r,:``;
- with ``first_estimates`` (Huang, Mourikis & Roumeliotis 2008): each wall's
  observation linearised at its first angle, the robot's position in the motion
  Jacobian and in a new wall's Jacobian at its prediction (before the scan's update);
- with ``shared_sd`` (the engine's ``wall_shared_sd``): a detection's noise gets the
  straightness covariance of ``shared_sd`` times ``sqrt(n)``, ``n`` its wall's earlier
  paired detections whose stretch of the line overlaps its own by more than half of
  the shorter, among its latest ``PARTS_KEPT`` (stretches placed with the pose
  before the scan's update).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .planar_ekf import chi2_quantile_2dof, unicycle, wrap


def observe_wall(pose: np.ndarray, line: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    s, c = math.sin(line[1]), math.cos(line[1])
    rho = line[0] - pose[0] * c - pose[1] * s
    h_r = np.array([[-c, -s, 0.0], [0.0, 0.0, -1.0]])
    h_l = np.array([[1.0, pose[0] * s - pose[1] * c], [0.0, 1.0]])
    alpha = line[1] - pose[2]
    if rho < 0:
        rho, alpha = -rho, alpha + math.pi
        h_r[0], h_l[0] = -h_r[0], -h_l[0]
    return np.array([rho, wrap(alpha)]), h_r, h_l


def wall_to_world(pose: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    alpha = z[1] + pose[2]
    s, c = math.sin(alpha), math.cos(alpha)
    rho = z[0] + pose[0] * c + pose[1] * s
    lever = -pose[0] * s + pose[1] * c
    g_r = np.array([[c, s, lever], [0.0, 0.0, 1.0]])
    g_z = np.array([[1.0, lever], [0.0, 1.0]])
    if rho < 0:
        rho, alpha = -rho, alpha + math.pi
        g_r[0], g_z[0] = -g_r[0], -g_z[0]
    return np.array([rho, wrap(alpha)]), g_r, g_z


def at_segment(
    z: np.ndarray, r: np.ndarray, pred: np.ndarray, h: np.ndarray, seg: list[np.ndarray]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The innovation, Jacobian and noise of detection ``z`` (noise ``r``, seen end
    points ``seg``) against ``pred`` (same form, Jacobian rows ``h``) at the middle
    of the seen segment."""
    n_seen = np.array([math.cos(z[1]), math.sin(z[1])])
    mid = 0.5 * (np.asarray(seg[0]) + np.asarray(seg[1]))
    m = mid - n_seen * (n_seen @ mid - z[0])  # on the detected line
    n_pred = np.array([math.cos(pred[1]), math.sin(pred[1])])
    t_pred = np.array([-n_pred[1], n_pred[0]]) @ m
    t_seen = np.array([-n_seen[1], n_seen[0]]) @ m
    nu = np.array([n_pred @ m - pred[0], wrap(z[1] - pred[1])])
    h = np.vstack([h[0] - t_pred * h[1], h[1]])
    j = np.array([[1.0, -t_seen], [0.0, 1.0]])
    return nu, h, j @ r @ j.T


PARTS_KEPT = 256  # the engine's WALL_PARTS_KEPT


def straightness(z: np.ndarray, seg: list[np.ndarray], sigma: float) -> np.ndarray:
    """The straightness covariance of detection ``z`` seen over ``seg`` (each end off
    the wall by ``sigma``; ``wallslam.straightness_covariance``, written out)."""
    n = np.array([math.cos(z[1]), math.sin(z[1])])
    mid = 0.5 * (np.asarray(seg[0]) + np.asarray(seg[1]))
    m = np.array([-n[1], n[0]]) @ mid
    l2 = max(float(np.sum((np.asarray(seg[1]) - np.asarray(seg[0])) ** 2)), 1e-6)
    q = np.array([[0.5 + 2 * m * m / l2, 2 * m / l2], [2 * m / l2, 2 / l2]])
    return sigma**2 * q


def shifted(pose: np.ndarray, origin: np.ndarray) -> np.ndarray:
    """The pose seen from a wall's reference point."""
    return np.array([pose[0] - origin[0], pose[1] - origin[1], pose[2]])


def in_frame(line: np.ndarray, origin: np.ndarray) -> np.ndarray:
    """A line about ``origin`` as a line about the frame's origin."""
    s, c = math.sin(line[1]), math.cos(line[1])
    return np.array([line[0] + c * origin[0] + s * origin[1], line[1]])


def to_world(pose: np.ndarray, p: np.ndarray) -> np.ndarray:
    s, c = math.sin(pose[2]), math.cos(pose[2])
    return np.array([pose[0] + c * p[0] - s * p[1], pose[1] + s * p[0] + c * p[1]])


def along(line: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, float]:
    s, c = math.sin(line[1]), math.cos(line[1])
    n = np.array([c, s])
    return p - n * (n @ p - line[0]), -s * p[0] + c * p[1]


def covering(line: np.ndarray, points: list[np.ndarray]) -> list[np.ndarray]:
    feet = [along(line, p) for p in points]
    return [min(feet, key=lambda f: f[1])[0], max(feet, key=lambda f: f[1])[0]]


def gap(line: np.ndarray, a: list[np.ndarray], b: list[np.ndarray]) -> float:
    a0, a1, b0, b1 = (along(line, p)[1] for p in (*a, *b))
    return max(min(a0, a1), min(b0, b1)) - min(max(a0, a1), max(b0, b1))


@dataclass
class WallEkfSlam:
    """Plain wall-landmark EKF-SLAM over ``[x, y, theta, rho1, alpha1, ...]``."""

    pose: np.ndarray
    control_noise: np.ndarray
    gate: float = 0.99
    admission: float = 0.999999
    overlap_gap: float = 0.5
    max_angle_sd: float = math.radians(2.0)
    first_estimates: bool = False
    segment: bool = False
    shared_sd: float = 0.0
    x: np.ndarray = field(init=False)
    P: np.ndarray = field(init=False)
    extents: list[list[np.ndarray]] = field(init=False, default_factory=list)
    origins: list[np.ndarray] = field(init=False, default_factory=list)
    first_alpha: list[float] = field(init=False, default_factory=list)
    parts: list[list[tuple[float, float]]] = field(init=False, default_factory=list)
    shift: np.ndarray = field(init=False, default_factory=lambda: np.zeros(2))

    def __post_init__(self) -> None:
        self.x = np.array(self.pose, dtype=float)
        self.P = np.zeros((3, 3))
        self.gate_d2 = chi2_quantile_2dof(self.gate)
        self.new_d2 = chi2_quantile_2dof(self.admission)

    def predict(self, v: float, w: float, dt: float) -> None:
        mean, fx, fv = unicycle(self.x[:3], v, w, dt)
        if self.first_estimates:  # the displacement from the pose's prediction
            fx[0, 2] -= self.shift[1]
            fx[1, 2] += self.shift[0]
        self.shift = np.zeros(2)
        self.x[:3] = mean
        self.P[:3, :] = fx @ self.P[:3, :]
        self.P[:, :3] = self.P[:, :3] @ fx.T
        self.P[:3, :3] += fv @ self.control_noise @ fv.T

    def _pairing(
        self, j: int, z: np.ndarray, r: np.ndarray, seg: list[np.ndarray]
    ) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
        o = 3 + 2 * j
        if self.shared_sd > 0:
            lo, hi = self._stretch(j, seg)
            n = sum(min(hi, b) - max(lo, a) > 0.5 * min(hi - lo, b - a) for a, b in self.parts[j])
            r = r + math.sqrt(n) * straightness(z, seg, self.shared_sd)
        pose = shifted(self.x[:3], self.origins[j])
        pred, h_r, h_l = observe_wall(pose, self.x[o : o + 2])
        if self.first_estimates:
            flipped = h_l[0, 0] < 0
            _, h_r, h_l = observe_wall(pose, np.array([self.x[o], self.first_alpha[j]]))
            if (h_l[0, 0] < 0) != flipped:
                h_r[0], h_l[0] = -h_r[0], -h_l[0]
        d = wrap(z[1] - pred[1])
        if abs(d) <= math.pi / 2:
            nu = np.array([z[0] - pred[0], d])
        else:
            nu = np.array([z[0] + pred[0], wrap(z[1] - pred[1] - math.pi)])
            h_r[0], h_l[0] = -h_r[0], -h_l[0]
            pred = np.array([-pred[0], pred[1] + math.pi])
        h = np.hstack([h_r, h_l])
        if self.segment:
            nu, h, r = at_segment(z, r, pred, h, seg)
        idx = [0, 1, 2, o, o + 1]
        s = h @ self.P[np.ix_(idx, idx)] @ h.T + r
        return float(nu @ np.linalg.solve(s, nu)), nu, h, r

    def _stretch(self, j: int, seg: list[np.ndarray]) -> tuple[float, float]:
        """The stretch of wall ``j``'s line that the seen segment covers."""
        line = in_frame(self.x[3 + 2 * j : 5 + 2 * j], self.origins[j])
        a, b = (along(line, to_world(self.x[:3], p))[1] for p in seg)
        return min(a, b), max(a, b)

    def scan(self, walls: np.ndarray) -> None:
        """One scan's rows ``(t, rho, alpha, var_rho, cov, var_alpha, x0, y0, x1, y1)``."""
        zs = [np.array([w[1], wrap(w[2])]) for w in walls]
        rs = [np.array([[w[3], w[4]], [w[4], w[5]]]) for w in walls]
        local = [[w[6:8], w[8:10]] for w in walls]
        best, near = [], []
        for z, r, seg in zip(zs, rs, local, strict=True):
            if r[1, 1] > self.max_angle_sd**2:
                best.append(None)
                near.append(True)  # never admitted
                continue
            ends = [to_world(self.x[:3], p) for p in seg]
            opts = []
            for j, ext in enumerate(self.extents):
                o = 3 + 2 * j
                if gap(in_frame(self.x[o : o + 2], self.origins[j]), ext, ends) <= self.overlap_gap:
                    nis, nu, h, r_used = self._pairing(j, z, r, seg)
                    if nis <= self.new_d2:
                        opts.append((nis, j, nu, h, r_used))
            near.append(bool(opts))
            opts = sorted((p for p in opts if p[0] <= self.gate_d2), key=lambda p: p[0])
            best.append(opts[0] if opts else None)
        paired = [(i, b) for i, b in enumerate(best) if b is not None]
        if paired:
            stretches = [self._stretch(b[1], local[i]) for i, b in paired]
            self._update([(b[1], b[2], b[3], b[4]) for _, b in paired])
            for (_, b), part in zip(paired, stretches, strict=True):
                self.parts[b[1]] = [*self.parts[b[1]], part][-PARTS_KEPT:]
            for i, b in paired:
                j = b[1]
                o = 3 + 2 * j
                ends = [to_world(self.x[:3], p) for p in local[i]]
                line = in_frame(self.x[o : o + 2], self.origins[j])
                self.extents[j] = covering(line, [*self.extents[j], *ends])
        for i in range(len(zs)):
            if best[i] is None and not near[i]:
                self._admit(zs[i], rs[i], local[i])

    def _update(self, pairs: list[tuple[int, np.ndarray, np.ndarray, np.ndarray]]) -> None:
        n, m = len(self.x), len(pairs)
        nu, h, r = np.zeros(2 * m), np.zeros((2 * m, n)), np.zeros((2 * m, 2 * m))
        for k, (j, nu_k, h_k, r_k) in enumerate(pairs):
            o = 3 + 2 * j
            nu[2 * k : 2 * k + 2] = nu_k
            h[2 * k : 2 * k + 2, :3], h[2 * k : 2 * k + 2, o : o + 2] = h_k[:, :3], h_k[:, 3:]
            r[2 * k : 2 * k + 2, 2 * k : 2 * k + 2] = r_k
        cols = np.flatnonzero(np.any(h != 0.0, axis=0))
        pht = self.P[:, cols] @ h[:, cols].T
        s = h[:, cols] @ pht[cols] + r
        k = np.linalg.solve(s, pht.T).T
        self.P += -k @ pht.T - pht @ k.T + k @ s @ k.T
        self.P = 0.5 * (self.P + self.P.T)
        step = k @ nu
        self.x += step
        self.x[2] = wrap(self.x[2])
        self.shift = self.shift + step[:2]

    def _admit(self, z: np.ndarray, r: np.ndarray, seg: list[np.ndarray]) -> None:
        ends = [to_world(self.x[:3], q) for q in seg]
        origin = 0.5 * (ends[0] + ends[1])
        line, g_r, g_z = wall_to_world(shifted(self.x[:3], origin), z)
        if self.first_estimates:
            prior = self.x[:3] - np.r_[self.shift, 0.0]
            _, g_r2, g_z2 = wall_to_world(shifted(prior, origin), z)
            if (g_z2[0, 0] < 0) != (g_z[0, 0] < 0):
                g_r2[0], g_z2[0] = -g_r2[0], -g_z2[0]
            g_r, g_z = g_r2, g_z2
        cross = g_r @ self.P[:3, :]
        pll = g_r @ self.P[:3, :3] @ g_r.T + g_z @ r @ g_z.T
        n = len(self.x)
        p = np.zeros((n + 2, n + 2))
        p[:n, :n], p[n:, :n], p[:n, n:], p[n:, n:] = self.P, cross, cross.T, 0.5 * (pll + pll.T)
        self.P = p
        self.x = np.r_[self.x, line]
        self.first_alpha.append(float(line[1]))
        self.parts.append([])
        self.origins.append(origin)
        self.extents.append(covering(in_frame(line, origin), ends))

    def world_lines(self) -> np.ndarray:
        """The walls about the world origin, ``rho >= 0``, ``(W, 2)``."""
        out = []
        for j, o in enumerate(self.origins):
            rho, alpha = in_frame(self.x[3 + 2 * j : 5 + 2 * j], o)
            out.append([-rho, wrap(alpha + math.pi)] if rho < 0 else [rho, wrap(alpha)])
        return np.array(out).reshape(-1, 2)


def run(controls: np.ndarray, walls: np.ndarray, slam: WallEkfSlam) -> np.ndarray:
    """Events merged as the engine does (controls first at equal times, walls of equal
    time one scan); the robot pose after each wall scan."""
    scans = np.split(walls, np.flatnonzero(np.diff(walls[:, 0])) + 1) if len(walls) else []
    i, t, u, out = 0, controls[0, 0], (0.0, 0.0), []
    for scan in scans:
        ts = scan[0, 0]
        while i < len(controls) and controls[i, 0] <= ts:
            if controls[i, 0] > t:
                slam.predict(*u, controls[i, 0] - t)
                t = controls[i, 0]
            u = (controls[i, 1], controls[i, 2])
            i += 1
        if ts > t:
            slam.predict(*u, ts - t)
            t = ts
        slam.scan(scan)
        out.append(slam.x[:3].copy())
    return np.array(out)
