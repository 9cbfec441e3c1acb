"""A numpy/scipy batch smoother of a wall-SLAM run, the peer of rperc's
``slam::planar::smooth`` (``rperc.slam.smoothing``): the same problem written out in
numpy and solved with scipy's sparse tools, for ``benchmarks/wall_smoother.py`` and
the tests.

- unknowns: one pose per time, each paired wall's line ``(rho, alpha)`` about its
  reference point (the middle of its first sighting placed with the starting pose),
  the control biases ``(s, b)`` (true controls ``(u0 (1 - s), u1 - b)``);
- odometry: the controls between two times (times ``control_scale``) integrated as
  arcs, against the relative pose ``R(theta_k)^T (p_{k+1} - p_k), theta_{k+1} -
  theta_k``, whitened by the control noise carried along at zero bias plus a floor
  of ``LINK_SD_FLOOR``;
- walls: the seen segment's middle on the detected line, placed by its pose, against
  its wall: offset and angle, whitened by the detection's covariance at the middle
  (the off-diagonal negated when the detection has the line's other normal); with
  ``shared_sd`` the straightness floor times ``sqrt(n)`` for the ``n`` earlier
  sightings of the same stretch;
- points (optional): each paired range-bearing detection, its sensors' biases taken
  off (``q = (r - offset) / scale``, the range ``q / cos b`` for a depth camera,
  ``b = (b_m - offset) / scale``), against the range and bearing of its landmark (an
  unknown in the world frame) from its pose, whitened by ``diag(range_sd,
  bearing_sd)``;
- priors: the start (sd floored at ``START_SD_FLOOR``) and the biases;
- solver: Levenberg-Marquardt (damping ``lambda diag(H)``) with scipy's sparse finite
  differences for the Jacobian and SuperLU for each step; covariances from the dense
  inverse of ``J^T J`` at the optimum.
"""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np
from scipy.optimize._numdiff import approx_derivative, group_columns
from scipy.sparse import csc_matrix, diags, lil_matrix
from scipy.sparse.linalg import spsolve

LINK_SD_FLOOR = 1e-3  # the engine's slam::planar::smooth::LINK_SD_FLOOR
START_SD_FLOOR = 1e-4  # the engine's START_SD_FLOOR
PARTS_KEPT = 256  # the engine's WALL_PARTS_KEPT


def wrap(a: Any) -> Any:
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def arcs(pose: np.ndarray, v: np.ndarray, w: np.ndarray, dt: np.ndarray) -> np.ndarray:
    """Each row of ``pose`` moved along an arc (vectorised)."""
    phi = w * dt
    small = np.abs(phi) < 1e-9
    safe = np.where(small, 1.0, phi)
    f = np.where(small, 1 - phi**2 / 6, np.sin(phi) / safe)
    g = np.where(small, phi / 2, (1 - np.cos(phi)) / safe)
    d = v * dt
    c, s = np.cos(pose[:, 2]), np.sin(pose[:, 2])
    x = pose[:, 0] + d * (c * f - s * g)
    y = pose[:, 1] + d * (s * f + c * g)
    return np.c_[x, y, pose[:, 2] + phi]


def segments(controls: np.ndarray, times: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The controls ``(v, w, dt)`` between consecutive times, padded with ``dt = 0``
    (a row applies from its time until the next row's; zero before the first)."""
    out: list[list[tuple[float, float, float]]] = []
    i, u = 0, (0.0, 0.0)
    for t, end in itertools.pairwise(times):
        while i < len(controls) and controls[i, 0] <= t:
            u = (controls[i, 1], controls[i, 2])
            i += 1
        segs = []
        while i < len(controls) and controls[i, 0] < end:
            if controls[i, 0] > t:
                segs.append((*u, controls[i, 0] - t))
            t, u = controls[i, 0], (controls[i, 1], controls[i, 2])
            i += 1
        segs.append((*u, end - t))
        out.append(segs)
    width = max((len(s) for s in out), default=1)
    arr = np.zeros((len(out), width, 3))
    for k, segs in enumerate(out):
        arr[k, : len(segs)] = segs
    return arr[..., 0], arr[..., 1], arr[..., 2]


def relative(v: np.ndarray, w: np.ndarray, dt: np.ndarray, bias: np.ndarray) -> np.ndarray:
    """The relative pose of each link at ``bias``."""
    pose = np.zeros((len(v), 3))
    for q in range(v.shape[1]):
        pose = arcs(pose, v[:, q] * (1 - bias[0]), w[:, q] - bias[1], dt[:, q])
    return pose


def link_whitening(v: np.ndarray, w: np.ndarray, dt: np.ndarray, var: np.ndarray) -> np.ndarray:
    """``L^-1`` of each link's covariance (central differences of the arcs in the
    controls' noise, carried along; zero bias)."""
    q = np.zeros((len(v), 3, 3))
    h = 1e-6
    for seg in range(v.shape[1]):
        for c in range(2):
            plus = [np.array(a, copy=True) for a in (v, w)]
            minus = [np.array(a, copy=True) for a in (v, w)]
            plus[c][:, seg] += h
            minus[c][:, seg] -= h
            d = (relative(*plus, dt, np.zeros(2)) - relative(*minus, dt, np.zeros(2))) / (2 * h)
            # The noise is on the control held over the segment: absent where dt = 0.
            d = d * (dt[:, seg] > 0)[:, None]
            q += var[c] * d[:, :, None] * d[:, None, :]
    q += np.eye(3) * LINK_SD_FLOOR**2
    return np.linalg.inv(np.linalg.cholesky(q))


def straightness(z: np.ndarray, ends: np.ndarray, sigma: float) -> np.ndarray:
    """The straightness covariance of one detection (``wallslam``'s, written out)."""
    n = np.array([math.cos(z[1]), math.sin(z[1])])
    mid = 0.5 * (ends[0] + ends[1])
    m = np.array([-n[1], n[0]]) @ mid
    l2 = max(float(np.sum((ends[1] - ends[0]) ** 2)), 1e-6)
    return sigma**2 * np.array([[0.5 + 2 * m * m / l2, 2 * m / l2], [2 * m / l2, 2 / l2]])


def to_world(pose: np.ndarray, p: np.ndarray) -> np.ndarray:
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return pose[:2] + np.array([c * p[0] - s * p[1], s * p[0] + c * p[1]])


def sightings(
    walls: np.ndarray, pairing: np.ndarray, times: np.ndarray, poses: np.ndarray,
    lines: dict[int, np.ndarray], shared_sd: float,
) -> dict[str, Any]:  # fmt: skip
    """The paired detections' pose, wall, middle, angle and covariance; the walls'
    reference points and starting lines about them."""
    out: dict[str, list[Any]] = {k: [] for k in ("node", "wall", "mid", "alpha", "cov")}
    index: dict[int, int] = {}
    origins, start, parts = [], [], []
    for row, wid in zip(walls, pairing, strict=True):
        if wid < 0:
            continue
        node = int(np.searchsorted(times, row[0]))
        n = np.array([math.cos(row[2]), math.sin(row[2])])
        ends = np.array([row[6:8], row[8:10]])
        mid = 0.5 * (ends[0] + ends[1])
        m = mid - n * (n @ mid - row[1])
        jac = np.array([[1.0, -np.array([-n[1], n[0]]) @ m], [0.0, 1.0]])
        world = to_world(poses[node], m)
        if int(wid) not in index:
            index[int(wid)] = len(origins)
            line = lines[int(wid)]
            origins.append(world)
            normal = np.array([math.cos(line[1]), math.sin(line[1])])
            start.append([line[0] - normal @ world, line[1]])
            parts.append(None)
        j = index[int(wid)]
        cov = jac @ np.array([[row[3], row[4]], [row[4], row[5]]]) @ jac.T
        if shared_sd > 0 and j in out["wall"]:
            t = np.array([-math.sin(start[j][1]), math.cos(start[j][1])])
            a, b = sorted(t @ to_world(poses[node], e) for e in ends)
            kept = parts[j] or []
            n_rep = sum(min(b, hi) - max(a, lo) > 0.5 * min(b - a, hi - lo) for lo, hi in kept)
            cov = cov + math.sqrt(n_rep) * jac @ straightness(row[1:3], ends, shared_sd) @ jac.T
            parts[j] = [*kept, (a, b)][-PARTS_KEPT:]
        for k, v in zip(out, (node, j, m, row[2], cov), strict=True):
            out[k].append(v)
    res = {k: np.array(v) for k, v in out.items()}
    res["origins"], res["start"] = np.array(origins).reshape(-1, 2), np.array(start).reshape(-1, 2)
    res["ids"] = np.array(sorted(index, key=index.__getitem__), dtype=np.int64)
    return res


def unbiased(rows: np.ndarray, bias: dict[str, Any] | None) -> np.ndarray:
    """Point detections ``(t, range, bearing)`` with the sensor's biases removed."""
    out = np.array(rows, dtype=float).reshape(-1, 3)
    if bias is None:
        return out
    b = (out[:, 2] - bias["bearing_offset"]) / bias["bearing_scale"]
    q = (out[:, 1] - bias["range_offset"]) / bias["range_scale"]
    out[:, 1] = q / np.cos(b) if bias["range_is_depth"] else q
    out[:, 2] = b
    return out


class Points:
    """The paired point detections of a run: node, landmark index, ``(range,
    bearing)``; the landmarks' ids and starting positions."""

    def __init__(
        self, rows: np.ndarray, pairing: np.ndarray, times: np.ndarray,
        landmarks: dict[int, np.ndarray], bias: dict[str, Any] | None,
    ) -> None:  # fmt: skip
        rows = unbiased(rows, bias)
        keep = np.asarray(pairing) >= 0
        rows, ids = rows[keep], np.asarray(pairing)[keep]
        self.ids = np.array(list(dict.fromkeys(int(i) for i in ids)), dtype=np.int64)
        index = {int(i): j for j, i in enumerate(self.ids)}
        self.node = np.searchsorted(times, rows[:, 0])
        self.mark = np.array([index[int(i)] for i in ids], dtype=int)
        self.z = rows[:, 1:]
        self.start = np.array([landmarks[int(i)] for i in self.ids], float).reshape(-1, 2)

    def residuals(self, x: np.ndarray, marks: np.ndarray, whiten: np.ndarray) -> np.ndarray:
        xs, m = x[self.node], marks[self.mark]
        d = m - xs[:, :2]
        h = np.c_[np.hypot(d[:, 0], d[:, 1]), wrap(np.arctan2(d[:, 1], d[:, 0]) - xs[:, 2])]
        e = h - self.z
        e[:, 1] = wrap(e[:, 1])
        return (e * whiten).ravel()


class Problem:
    """The whitened residuals of a run (see the module docs)."""

    def __init__(
        self, controls: np.ndarray, times: np.ndarray, poses: np.ndarray, walls: np.ndarray,
        pairing: np.ndarray, map_id: np.ndarray, map_line: np.ndarray, *, speed_var: float,
        turn_var: float, bias_sd: tuple[float, float] | None, start: np.ndarray,
        start_var: np.ndarray, shared_sd: float = 0.0, points: Points | None = None,
        point_var: tuple[float, float] = (1.0, 1.0),
        control_scale: tuple[float, float] = (1.0, 1.0),
    ) -> None:  # fmt: skip
        self.times, self.S = np.asarray(times, float), len(times)
        # The true controls are the measured ones times the calibrated scale.
        scaled = np.array(controls, float) * np.r_[1.0, control_scale]
        self.v, self.w, self.dt = segments(scaled, self.times)
        self.link_w = link_whitening(self.v, self.w, self.dt, np.array([speed_var, turn_var]))
        lines = {int(i): np.asarray(line) for i, line in zip(map_id, map_line, strict=True)}
        self.sg = sightings(np.asarray(walls, float), np.asarray(pairing), self.times,
                            np.asarray(poses, float), lines, shared_sd)  # fmt: skip
        self.W = len(self.sg["origins"])
        self.pt = points
        self.P = 0 if points is None else len(points.ids)
        self.point_w = 1 / np.sqrt(np.asarray(point_var, float))
        self.nb = 0 if bias_sd is None else 2
        self.bias_w = None if bias_sd is None else 1 / np.asarray(bias_sd, float)
        self.start = np.asarray(start, float)
        self.start_w = 1 / np.sqrt(np.maximum(np.asarray(start_var, float), START_SD_FLOOR**2))
        poses = np.asarray(poses, float)
        marks = np.zeros((0, 2)) if points is None else points.start
        self.x0 = np.r_[poses.ravel(), self.sg["start"].ravel(), marks.ravel(), np.zeros(self.nb)]

    def unpack(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        s, w = 3 * self.S, 2 * self.W
        bias = z[s + w + 2 * self.P :] if self.nb else np.zeros(2)
        return z[:s].reshape(-1, 3), z[s : s + w].reshape(-1, 2), bias

    def marks(self, z: np.ndarray) -> np.ndarray:
        """The point landmarks of the unknowns ``z``."""
        at = 3 * self.S + 2 * self.W
        return z[at : at + 2 * self.P].reshape(-1, 2)

    def residuals(self, z: np.ndarray) -> np.ndarray:
        x, lines, bias = self.unpack(z)
        e0 = x[0] - self.start
        e0[2] = wrap(e0[2])
        g = relative(self.v, self.w, self.dt, bias)
        d = x[1:, :2] - x[:-1, :2]
        c, s = np.cos(x[:-1, 2]), np.sin(x[:-1, 2])
        turn = wrap(x[1:, 2] - x[:-1, 2])
        local = np.c_[c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1], turn]
        e = local - g
        e[:, 2] = wrap(e[:, 2])
        r_link = np.einsum("nij,nj->ni", self.link_w, e).ravel()
        r_wall = self.wall_residuals(x, lines)
        r_bias = bias * self.bias_w if self.nb else np.zeros(0)
        r_point = (
            np.zeros(0) if self.pt is None else self.pt.residuals(x, self.marks(z), self.point_w)
        )
        return np.r_[self.start_w * e0, r_link, r_wall, r_point, r_bias]

    def wall_residuals(self, x: np.ndarray, lines: np.ndarray) -> np.ndarray:
        """The whitened wall terms of poses ``x`` and ``lines``."""
        sg = self.sg
        if len(sg["node"]) == 0:
            return np.zeros(0)
        xs = x[sg["node"]]
        c, s = np.cos(xs[:, 2]), np.sin(xs[:, 2])
        m = sg["mid"]
        rel = xs[:, :2] + np.c_[c * m[:, 0] - s * m[:, 1], s * m[:, 0] + c * m[:, 1]]
        rel = rel - sg["origins"][sg["wall"]]
        ln = lines[sg["wall"]]
        offset = np.cos(ln[:, 1]) * rel[:, 0] + np.sin(ln[:, 1]) * rel[:, 1] - ln[:, 0]
        angle = wrap(sg["alpha"] + xs[:, 2] - ln[:, 1])
        flip = np.abs(angle) > np.pi / 2
        angle = np.where(flip, wrap(angle - np.pi), angle)
        cov = sg["cov"].copy()
        cov[flip, 0, 1] *= -1
        cov[flip, 1, 0] *= -1
        wh = np.linalg.inv(np.linalg.cholesky(cov))
        r_wall = np.einsum("nij,nj->ni", wh, np.c_[offset, angle]).ravel()
        return r_wall

    def sparsity(self) -> lil_matrix:
        n_pt = 0 if self.pt is None else len(self.pt.node)
        n_res = 3 + 3 * (self.S - 1) + 2 * len(self.sg["node"]) + 2 * n_pt + self.nb
        a = lil_matrix((n_res, len(self.x0)), dtype=int)
        a[:3, :3] = 1
        bias_cols = slice(3 * self.S + 2 * self.W + 2 * self.P, len(self.x0))
        for k in range(self.S - 1):
            a[3 + 3 * k : 6 + 3 * k, 3 * k : 3 * k + 6] = 1
            a[3 + 3 * k : 6 + 3 * k, bias_cols] = 1
        o = 3 + 3 * (self.S - 1)
        for i, (k, j) in enumerate(zip(self.sg["node"], self.sg["wall"], strict=True)):
            a[o + 2 * i : o + 2 * i + 2, 3 * k : 3 * k + 3] = 1
            a[o + 2 * i : o + 2 * i + 2, 3 * self.S + 2 * j : 3 * self.S + 2 * j + 2] = 1
        o += 2 * len(self.sg["node"])
        at = 3 * self.S + 2 * self.W
        for i in range(n_pt):
            k, j = self.pt.node[i], self.pt.mark[i]  # type: ignore[union-attr]
            a[o + 2 * i : o + 2 * i + 2, 3 * k : 3 * k + 3] = 1
            a[o + 2 * i : o + 2 * i + 2, at + 2 * j : at + 2 * j + 2] = 1
        if self.nb:
            a[-2:, bias_cols] = 1
        return a


def smooth(problem: Problem, max_iterations: int = 100, tolerance: float = 1e-9) -> dict[str, Any]:
    """Levenberg-Marquardt from the starting point; the optimum, its covariances."""
    sparsity = problem.sparsity()
    groups = group_columns(sparsity)
    z, lam = problem.x0.copy(), 1e-4
    r = problem.residuals(z)
    cost = float(r @ r)

    def jacobian(z: np.ndarray, r: np.ndarray) -> csc_matrix:
        return csc_matrix(approx_derivative(
            problem.residuals, z, method="3-point", sparsity=(sparsity, groups), f0=r
        ))  # fmt: skip

    iterations = 0
    while iterations < max_iterations:
        iterations += 1
        jac = jacobian(z, r)
        h = (jac.T @ jac).tocsc()
        grad = jac.T @ r
        improved = False
        while lam <= 1e12:
            step = spsolve(h + diags(lam * h.diagonal()), -grad)
            trial = z + step
            rt = problem.residuals(trial)
            ct = float(rt @ rt)
            if np.isfinite(ct) and ct < cost:
                gain = (cost - ct) / cost
                z, r, cost, lam = trial, rt, ct, max(lam * 0.1, 1e-12)
                improved = gain >= tolerance
                break
            lam *= 10
        if not improved:
            break
    jac = jacobian(z, r)
    cov = np.linalg.inv((jac.T @ jac).toarray())
    x, lines, bias = problem.unpack(z)
    s = problem.S
    pose_cov = np.stack([cov[3 * k : 3 * k + 3, 3 * k : 3 * k + 3] for k in range(s)])
    at = 3 * s + 2 * problem.W
    blocks = [
        cov[at + 2 * j : at + 2 * j + 2, at + 2 * j : at + 2 * j + 2] for j in range(problem.P)
    ]
    mark_cov = np.stack(blocks) if blocks else np.zeros((0, 2, 2))
    return {"pose": x, "covariance": pose_cov, "bias": bias, "cost": cost,
            "iterations": iterations, "lines": lines, "ids": problem.sg["ids"],
            "marks": problem.marks(z), "mark_cov": mark_cov}  # fmt: skip


def wallslam_run(prepared: Any, seed: int) -> tuple[Any, np.ndarray, Any]:
    """One ``rperc.slam.wallslam`` run over a prepared log: its result, the controls
    the engine was given, and the engine's own result (with ``wall_pairing``)."""
    from rperc.slam import PlanarSlam
    from rperc.slam import wallslam as ws

    res = ws.run_prepared(prepared, seed=seed)
    config = {k: v for k, v in res.config.items() if k != "straightness"}
    t = prepared.t
    controls = np.r_[ws.noisy_controls(prepared.exact, seed), [[t[-1], 0.0, 0.0]]]
    out = PlanarSlam(config).run_arrays(controls, np.zeros((0, 3)), walls=prepared.rows)
    return res, controls, out


def wallslam_problem(prepared: Any, controls: np.ndarray, out: Any) -> Problem:
    """The peer's problem for a :func:`wallslam_run`, from the filter's poses."""
    from rperc.slam import wallslam as ws

    start, _ = ws.at_scans(out, prepared.t)
    return Problem(
        controls, prepared.t, start, prepared.rows, out.wall_pairing, out.walls.id,
        out.walls.line, speed_var=ws.SPEED_SIGMA**2, turn_var=ws.TURN_SIGMA**2,
        bias_sd=(ws.SPEED_BIAS, ws.TURN_BIAS), start=prepared.reference[0],
        start_var=np.zeros(3), shared_sd=prepared.straightness,
    )  # fmt: skip
