"""The visual memory of paper [001], section 2.3-2.4: learn a path A -> B in a ceiling
world (the mosaic and the key images), replay it by visual servoing, and score both
against the world's truth.

The robot runs natively (GIL released): every frame is rendered at the true pose, the
robot corrects it by eq. 1, tracks several ceiling models with the pattern tracker,
localises itself by eq. 2 (a rigid fit of the tracked models when several are in view),
generates new models where the view has room and places them by eq. 3. Replays servo
from key image to key image on the image poses of the shared models.

>>> import numpy as np
>>> from rperc.navigation import CeilingWorld, learn, replay
>>> world = CeilingWorld(ceiling={"size": [8.0, 6.0], "n_patterns": 12, "seed": 1})
>>> commands = np.tile([0.3, 0.1], (40, 1))          # (v m/s, omega rad/s), 0.1 s each
>>> learning = learn(world, [3.0, 2.5, 0.0], commands, dt=0.1)
>>> run = replay(world, learning.memory, [3.05, 2.45, 0.05], seed=1)
>>> run.outcome
'reached'
"""

from __future__ import annotations

import hashlib
import json
import math
import warnings
from collections.abc import Mapping, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypedDict, cast

import numpy as np
import numpy.typing as npt

from rperc import _rperc
from rperc._args import float_array, real_number, seed_number, whole_number
from rperc._atomic import write_text_atomically
from rperc._config_base import Config, as_config
from rperc.config import LearnConfig, LearnConfigOverrides, ReplayConfig, ReplayConfigOverrides
from rperc.datasets._text import read_text
from rperc.datasets.errors import DatasetFormatError
from rperc.navigation.world import CeilingWorld
from rperc.pose import wrap_angle

if TYPE_CHECKING:
    from typing_extensions import Unpack

__all__ = [
    "FORMAT",
    "Evaluation",
    "Frames",
    "Learning",
    "ReplayResult",
    "VisualMemory",
    "evaluate",
    "learn",
    "replay",
    "starts_around",
]

FORMAT = "rperc-visual-memory/2"


def _sha256(value: Any) -> str:
    text = json.dumps(value, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


class MemoryPose(TypedDict):
    """A robot pose in the mosaic frame, as the memory file writes it."""

    x: float
    y: float
    theta: float


class KeyModel(TypedDict):
    """A model seen in a key image: its ``id``, tracker ``state`` ``(x, y, theta, s)``
    in the ideal image and the tracker's ``score``."""

    id: int
    state: list[float]
    score: float


class KeyImage(TypedDict):
    """A key image of the memory file: its learning ``frame``, the robot ``pose`` and
    the ``models`` in view."""

    frame: int
    pose: MemoryPose
    models: list[KeyModel]


class VisualMemory:
    """A mosaic (models with their poses ``M T_i``) and the key images of one path.

    Saved as one JSON file holding both, with the mosaic's SHA-256 in the key-image
    part: :meth:`load` refuses a file whose key images belong to another mosaic."""

    def __init__(self, native_json: str) -> None:
        try:
            data = json.loads(native_json)
        except json.JSONDecodeError as exc:
            raise ValueError(f"memory: not a visual memory: {exc}") from None
        if not isinstance(data, dict) or not {"models", "key_images", "image_size"} <= set(data):
            raise ValueError("memory: not a visual memory (needs models, key_images, image_size)")
        # Every field, as the native side reads it (a model without its pose, a pose
        # without theta, a state of three numbers: each a ValueError naming it).
        _rperc.visual_memory_check(native_json)
        self._data: dict[str, Any] = data

    def __repr__(self) -> str:
        return f"VisualMemory(models={self.n_models}, key_images={len(self.key_images)})"

    @property
    def n_models(self) -> int:
        return len(self._data["models"])

    @property
    def model_poses(self) -> np.ndarray:
        """``(n, 3)`` poses ``(x, y, theta)`` of the models in the mosaic frame."""
        rows = [[m["pose"]["x"], m["pose"]["y"], m["pose"]["theta"]] for m in self._data["models"]]
        return np.array(rows, dtype=np.float64).reshape(-1, 3)

    @property
    def model_centers(self) -> np.ndarray:
        """``(n, 2)`` centers of the models' windows in the image they were learnt in."""
        rows = [m["model"]["centre"] for m in self._data["models"]]
        return np.array(rows, dtype=np.float64).reshape(-1, 2)

    @property
    def model_centres(self) -> np.ndarray:
        """Deprecated spelling of :attr:`model_centers` (API names spell as OpenCV)."""
        warnings.warn(
            "VisualMemory.model_centres is deprecated; use model_centers",
            DeprecationWarning,
            stacklevel=2,
        )
        return self.model_centers

    @property
    def model_created(self) -> np.ndarray:
        """The learning frame each model was generated in."""
        return np.array([m["created"] for m in self._data["models"]], dtype=np.int64)

    @property
    def key_images(self) -> list[KeyImage]:
        """Each key image: its learning ``frame``, robot ``pose`` (mosaic) and
        ``models`` (``id`` and tracker ``state`` ``(x, y, theta, s)``)."""
        return cast("list[KeyImage]", list(self._data["key_images"]))

    @property
    def key_poses(self) -> np.ndarray:
        """``(k, 3)`` robot poses of the key images in the mosaic frame."""
        rows = [[k["pose"]["x"], k["pose"]["y"], k["pose"]["theta"]] for k in self.key_images]
        return np.array(rows, dtype=np.float64).reshape(-1, 3)

    def to_json(self) -> str:
        """The memory as the native side reads it."""
        return json.dumps(self._data)

    def _mosaic(self) -> dict[str, Any]:
        """The mosaic: the models and their joint covariance (when learnt with one)."""
        return {"models": self._data["models"],
                "covariance": self._data.get("mosaic_covariance")}  # fmt: skip

    def save(self, path: str | Path) -> Path:
        """Writes the mosaic and the key images to one JSON file."""
        mosaic = self._mosaic()
        out = {
            "format": FORMAT,
            "mosaic": {**mosaic, "sha256": _sha256(mosaic)},
            "memory": {
                "mosaic_sha256": _sha256(mosaic),
                "key_images": self._data["key_images"],
                "image_size": self._data["image_size"],
            },
        }
        return write_text_atomically(path, json.dumps(out))

    @classmethod
    def load(cls, path: str | Path) -> VisualMemory:
        """Reads :meth:`save`'s file; a file whose key images were learnt on another
        mosaic, or a mosaic altered since, is a ``ValueError``."""
        p = Path(path)
        try:
            # The readers' text rule: binary input refused from its first bytes.
            data = json.loads(read_text(p))
        except (DatasetFormatError, json.JSONDecodeError) as exc:
            raise ValueError(f"{p}: not a visual-memory file: {exc}") from None
        if not isinstance(data, dict) or data.get("format") != FORMAT:
            raise ValueError(f"{p}: not a visual-memory file (format {FORMAT!r} expected)")
        try:
            mosaic = {"models": data["mosaic"]["models"],
                      "covariance": data["mosaic"].get("covariance")}  # fmt: skip
            memory = data["memory"]
            native = {"models": mosaic["models"], "key_images": memory["key_images"],
                      "image_size": memory["image_size"]}  # fmt: skip
        except (KeyError, TypeError, AttributeError) as exc:
            raise ValueError(f"{p}: not a visual-memory file: no {exc}") from None
        if _sha256(mosaic) != data["mosaic"].get("sha256"):
            raise ValueError(f"{p}: the mosaic was altered after it was saved")
        if memory.get("mosaic_sha256") != _sha256(mosaic):
            raise ValueError(f"{p}: the key images belong to another mosaic")
        if mosaic["covariance"] is not None:
            native["mosaic_covariance"] = mosaic["covariance"]
        return cls(json.dumps(native))

    def with_mosaic_of(self, other: VisualMemory) -> VisualMemory:
        """These key images on ``other``'s mosaic (for experiments; the native side
        refuses key images that name models the mosaic does not hold)."""
        data = {**self._data, "models": other._data["models"]}
        data.pop("mosaic_covariance", None)
        if "mosaic_covariance" in other._data:
            data["mosaic_covariance"] = other._data["mosaic_covariance"]
        return VisualMemory(json.dumps(data))


@dataclass(frozen=True, repr=False)
class Frames:
    """Per-frame arrays of a run: ``truth`` (world) and ``pose`` (mosaic, NaN where
    unknown) ``(n, 3)``, ``lost`` (no model's image pose used: dead reckoning),
    ``tracked`` (models tracked), the robot's processing ``seconds`` (rendering
    excluded) and the ``covariance`` ``(n, 3, 3)`` of ``pose`` relative to the mosaic
    (x, y in mosaic units, theta in radians; NaN where unknown)."""

    truth: np.ndarray
    pose: np.ndarray
    lost: np.ndarray
    tracked: np.ndarray
    seconds: np.ndarray
    covariance: np.ndarray

    def __repr__(self) -> str:
        return f"Frames(n={len(self.truth)}, lost={int(self.lost.sum())}, hz={self.hz:.0f})"

    @property
    def hz(self) -> float:
        """Frames per second of the robot's own processing."""
        total = float(self.seconds.sum())
        return len(self.seconds) / total if total > 0 else math.inf


def _frames(native: _rperc.MemoryFrames) -> Frames:
    f = native
    return Frames(f.truth, f.pose, f.lost, f.tracked, f.seconds, f.covariance)


def _se2(p: npt.ArrayLike) -> np.ndarray:
    c, s = math.cos(float(np.asarray(p)[2])), math.sin(float(np.asarray(p)[2]))
    x, y = float(np.asarray(p)[0]), float(np.asarray(p)[1])
    return np.array([[c, -s, x], [s, c, y], [0.0, 0.0, 1.0]])


def _pose(m: np.ndarray) -> np.ndarray:
    return np.array([m[0, 2], m[1, 2], math.atan2(m[1, 0], m[0, 0])])


@dataclass(frozen=True, repr=False)
class Learning:
    """A learning run: the ``memory``, its ``frames``, and ``mosaic_in_world``, the
    mosaic frame in the world (model 0's true frame: the true robot at its creation
    times its image pose there), by which the mosaic and the localisation are
    scored."""

    memory: VisualMemory
    frames: Frames
    mosaic_in_world: np.ndarray
    metres_per_pixel: float  # Z / f of the ideal image
    principal: tuple[float, float]
    unit: float = 1.0  # metres per mosaic unit: 1, or Z / f for a mosaic in pixels

    def __repr__(self) -> str:
        return f"Learning({self.memory!r}, {self.frames!r})"

    def camera_to_model(self, centre: npt.ArrayLike) -> list[float]:
        """``C T_i`` of a model at image position ``centre`` with no turn (metres)."""
        c = np.asarray(centre, dtype=np.float64)
        m = self.metres_per_pixel
        return [m * (c[0] - self.principal[0]), m * (c[1] - self.principal[1]), 0.0]

    def to_world(self, poses: npt.ArrayLike) -> np.ndarray:
        """Mosaic-frame poses ``(n, 3)`` in the world frame (NaN rows stay NaN)."""
        arr = np.asarray(poses, dtype=np.float64).reshape(-1, 3) * [self.unit, self.unit, 1.0]
        w = _se2(self.mosaic_in_world)
        out = np.full_like(arr, np.nan)
        for k, p in enumerate(arr):
            if np.isfinite(p).all():
                out[k] = _pose(w @ _se2(p))
        return out


def learn(
    world: CeilingWorld,
    start: npt.ArrayLike,
    commands: npt.ArrayLike,
    dt: float = 0.1,
    config: LearnConfig | Mapping[str, object] | None = None,
    seed: int = 0,
    **overrides: Unpack[LearnConfigOverrides],
) -> Learning:
    """Drives ``commands`` (``(n, 2)``: ``v`` m/s, ``omega`` rad/s, each ``dt`` s) from
    ``start`` ``(x, y, theta)``, building the mosaic and choosing the key images.
    ``config`` is a :class:`rperc.config.LearnConfig` or a dict of its fields
    (``mosaic``, ``keys``, ``odometry``, and ``covariance_scale``, >= 1, which
    multiplies the stored mosaic covariance: the mapping filter counts a tracker's
    successive, correlated states as independent); keyword arguments override its
    fields."""
    cfg = as_config(LearnConfig, config, overrides)
    learnt = _rperc.visual_memory_learn(
        world._native,
        float_array(start, "start").reshape(-1),
        np.ascontiguousarray(float_array(commands, "commands")),
        real_number(dt, "dt"),
        cfg.to_dict(),
        seed_number(seed),
    )
    memory = VisualMemory(learnt.memory)
    f = _frames(learnt.frames)
    c = world.camera
    scale = c.ceiling_height / c.fx
    principal = (c.cx, c.cy)
    unit = 1.0 if cfg.mosaic.metric else scale
    learning = Learning(memory, f, np.zeros(3), scale, principal, unit)
    c_t_0 = learning.camera_to_model(memory.model_centers[0])
    w_t_m = _pose(_se2(f.truth[memory.model_created[0]]) @ _se2(c_t_0))
    return Learning(memory, f, w_t_m, scale, principal, unit)


@dataclass(frozen=True, repr=False)
class ReplayResult:
    """A replay: ``outcome`` (``"reached"``, ``"lost"`` or ``"timed_out"``), the key
    image followed at each frame and the frames."""

    outcome: str
    key_index: np.ndarray
    frames: Frames

    def __repr__(self) -> str:
        return f"ReplayResult({self.outcome!r}, {self.frames!r})"

    @property
    def reached(self) -> bool:
        return self.outcome == "reached"


def replay(
    world: CeilingWorld,
    memory: VisualMemory,
    start: npt.ArrayLike,
    config: ReplayConfig | Mapping[str, object] | None = None,
    seed: int = 0,
    **overrides: Unpack[ReplayConfigOverrides],
) -> ReplayResult:
    """Replays ``memory`` from the true pose ``start`` (the robot believes it is at the
    first key image). ``config``: a :class:`rperc.config.ReplayConfig` or a dict of its
    fields; keyword arguments override its fields."""
    run = _rperc.visual_memory_replay(
        world._native,
        memory.to_json(),
        float_array(start, "start").reshape(-1),
        as_config(ReplayConfig, config, overrides).to_dict(),
        seed_number(seed),
    )
    return ReplayResult(run.outcome, run.key_index, _frames(run.frames))


@dataclass(frozen=True)
class Evaluation:
    """Scores of a memory against the world's truth (section 4.2's experiment with
    truth). Distances in cm, angles in degrees; ``hz`` is the robot's own processing
    rate (rendering excluded). ``nees`` is the replays' mean NEES of the localised
    pose against its covariance (3 dof: 3 when honest), ``nees_in_band`` the share of
    time steps whose NEES averaged over the starts lies in its 95 % band (Bailey et
    al.'s measure)."""

    starts: int
    success_rate: float
    final_error_cm: float
    localization_error_cm: float
    localization_error_deg: float
    replay_deviation_cm: float
    mosaic_error_cm: float
    mosaic_error_deg: float
    learning_localization_error_cm: float
    learning_localization_error_deg: float
    nees: float
    nees_in_band: float
    hz: float

    def to_dict(self) -> dict[str, float]:
        return {k: float(v) for k, v in self.__dict__.items()}


def _errors(estimate_world: np.ndarray, truth: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    ok = np.isfinite(estimate_world).all(axis=1)
    d = estimate_world[ok] - truth[ok]
    heading = wrap_angle(d[:, 2])
    return np.hypot(d[:, 0], d[:, 1]), heading


def _rms(values: np.ndarray) -> float:
    return float(np.sqrt(np.mean(values**2))) if len(values) else math.nan


def _replay_job(args: tuple[Any, ...]) -> ReplayResult:
    world, memory_json, start, config, seed = args
    return replay(world, VisualMemory(memory_json), start, config, seed)


def starts_around(
    start: npt.ArrayLike, n: int, perturbation: Sequence[float], seed: int = 0
) -> np.ndarray:
    """``n`` seeded start poses around ``start``: uniform in ``[-p, p]`` for each of
    ``perturbation = (dx m, dy m, dtheta rad)``."""
    rng = np.random.default_rng(seed)
    p: np.ndarray = float_array(perturbation, "perturbation").reshape(-1)
    if p.shape != (3,) or not (np.isfinite(p).all() and (p >= 0).all()):
        raise ValueError(f"perturbation must be 3 finite values >= 0 (m, m, rad), got {p}")
    centre: np.ndarray = np.asarray(start, dtype=np.float64)
    out: np.ndarray = centre + rng.uniform(-1.0, 1.0, size=(n, 3)) * p
    return out


def evaluate(
    world: CeilingWorld,
    learning: Learning,
    *,
    starts: int = 50,
    perturbation: Sequence[float] = (0.1, 0.1, 0.1),
    config: ReplayConfig | Mapping[str, object] | None = None,
    executor: Executor | None = None,
    seed: int = 0,
    show_progress: bool = False,
    **overrides: Unpack[ReplayConfigOverrides],
) -> tuple[Evaluation, list[ReplayResult]]:
    """Replays the learnt memory from ``starts`` seeded perturbed starts (through
    ``executor.map`` when given: a process pool or a Dask client's executor) and scores
    everything against the truth. ``show_progress``: a bar on a terminal, log lines
    elsewhere, one step per finished replay. ``config`` and the keyword overrides are
    :func:`replay`'s; the localiser's ``guess_sigma`` is set from ``perturbation``
    unless they set their own (a dict with the field, or a value not the default)."""
    from rperc._progress import progress

    n = whole_number(starts, "starts", 1, 100_000)
    seed = whole_number(seed, "seed", 0)
    begin = learning.frames.truth[0]
    poses = starts_around(begin, n, perturbation, seed)
    native = _with_start_guess(config, overrides, perturbation)
    jobs = [(world, learning.memory.to_json(), p, native, seed + k)
            for k, p in enumerate(poses)]  # fmt: skip
    done = executor.map(_replay_job, jobs) if executor else map(_replay_job, jobs)
    if show_progress:
        done = progress(done, desc="replays", total=n, unit="replay")
    runs = list(done)
    return _score(learning, runs), runs


def _with_start_guess(
    config: ReplayConfig | Mapping[str, object] | None,
    overrides: Mapping[str, object],
    perturbation: Sequence[float],
) -> dict[str, object]:
    """The replays' config with the localiser's starting guess told how the starts are
    drawn (uniform in ``[-p, p]``: a standard deviation of ``p / sqrt(3)``), unless it
    sets its own: the replay then searches the box its start can be in, no wider, and
    its first covariance is honest. A dict sets its own when it names the field, a
    typed config or override when its value is not the default (a dataclass always
    holds the field)."""
    named = isinstance(config, Mapping) and "guess_sigma" in _part(
        _part(config, "mosaic"), "localiser"
    )
    made = as_config(ReplayConfig, config, overrides)
    localiser = made.mosaic.localiser
    if named or localiser.guess_sigma != ReplayConfig().mosaic.localiser.guess_sigma:
        return made.to_dict()
    p = np.asarray(perturbation, dtype=np.float64).reshape(-1)
    sigma = tuple(max(float(v) / math.sqrt(3.0), 1e-3) for v in p)
    guess = localiser.replace(guess_sigma=sigma)
    return made.replace(mosaic=made.mosaic.replace(localiser=guess)).to_dict()


def _part(config: Mapping[str, object], name: str) -> dict[str, object]:
    """The nested part ``name`` of a config dict, as a dict (empty when absent)."""
    part = config.get(name)
    if isinstance(part, Mapping):
        return {str(k): v for k, v in part.items()}
    if part is None:
        return {}
    if isinstance(part, Config):  # a typed part inside a dict
        return part.to_dict()
    raise TypeError(f"{name} must be a config or a dict of its fields, got {type(part).__name__}")


def _score(learning: Learning, runs: list[ReplayResult]) -> Evaluation:
    b = learning.frames.truth[-1]
    final = np.array([np.hypot(*(r.frames.truth[-1, :2] - b[:2])) for r in runs])
    dist, head = [], []
    path = learning.frames.truth[:, :2]
    deviation = []
    nees = [localization_nees(learning, r.frames) for r in runs]
    for r in runs:
        d, h = _errors(learning.to_world(r.frames.pose[~r.frames.lost]),
                       r.frames.truth[~r.frames.lost])  # fmt: skip
        dist.append(d)
        head.append(h)
        gaps = np.linalg.norm(r.frames.truth[:, None, :2] - path[None, :, :], axis=2)
        deviation.append(gaps.min(axis=1))
    d_all, h_all = np.concatenate(dist), np.concatenate(head)
    learn_d, learn_h = _errors(
        learning.to_world(learning.frames.pose[~learning.frames.lost]),
        learning.frames.truth[~learning.frames.lost],
    )
    mosaic_d, mosaic_h = _mosaic_errors(learning)
    seconds = sum(float(r.frames.seconds.sum()) for r in runs)
    frames = sum(len(r.frames.seconds) for r in runs)
    return Evaluation(
        starts=len(runs),
        success_rate=float(np.mean([r.reached for r in runs])),
        final_error_cm=100 * float(np.median(final)),
        localization_error_cm=100 * _rms(d_all),
        localization_error_deg=float(np.degrees(_rms(h_all))),
        replay_deviation_cm=100 * _rms(np.concatenate(deviation)),
        mosaic_error_cm=100 * _rms(mosaic_d),
        mosaic_error_deg=float(np.degrees(_rms(mosaic_h))),
        learning_localization_error_cm=100 * _rms(learn_d),
        learning_localization_error_deg=float(np.degrees(_rms(learn_h))),
        nees=float(np.nanmean(np.concatenate(nees))) if nees else math.nan,
        nees_in_band=_share_in_band(nees),
        hz=frames / seconds if seconds > 0 else math.inf,
    )


def localization_nees(learning: Learning, frames: Frames) -> np.ndarray:
    """Each frame's NEES of the localised pose against the truth seen from the
    mosaic frame, with the pose's covariance (NaN where the pose was dead reckoning
    or unknown)."""
    from_world = np.linalg.inv(_se2(learning.mosaic_in_world))
    out = np.full(len(frames.truth), math.nan)
    rows = zip(frames.pose, frames.truth, frames.covariance, frames.lost, strict=True)
    for k, (p, truth, cov, lost) in enumerate(rows):
        if lost or not (np.isfinite(p).all() and np.isfinite(cov).all()):
            continue
        t = _pose(from_world @ _se2(truth))
        e = np.array([p[0] - t[0] / learning.unit, p[1] - t[1] / learning.unit, 0.0])
        e[2] = math.remainder(p[2] - t[2], 2 * math.pi)
        try:
            out[k] = float(e @ np.linalg.solve(cov, e))
        except np.linalg.LinAlgError:
            continue
    return out


def _share_in_band(nees: list[np.ndarray]) -> float:
    """Share of the time steps (up to the shortest run) whose NEES averaged over the
    runs lies inside the 95 % band of that average (3 dof)."""
    if not nees:
        return math.nan
    steps = min(len(n) for n in nees)
    table = np.array([n[:steps] for n in nees])
    inside = []
    for column in table.T:
        seen = column[np.isfinite(column)]
        if len(seen):
            lo, hi = _rperc.nees_bounds(3, len(seen), 0.95)
            inside.append(lo <= seen.mean() <= hi)
    return float(np.mean(inside)) if inside else math.nan


def _mosaic_errors(learning: Learning) -> tuple[np.ndarray, np.ndarray]:
    """Each model's mosaic pose against its true frame (the true robot at its creation
    times its image pose there), seen from the mosaic frame's truth."""
    memory, truth = learning.memory, learning.frames.truth
    to_mosaic = np.linalg.inv(_se2(learning.mosaic_in_world))
    true = np.array(
        [
            _pose(to_mosaic @ _se2(truth[k]) @ _se2(learning.camera_to_model(centre)))
            for k, centre in zip(memory.model_created, memory.model_centers, strict=True)
        ]
    ).reshape(-1, 3)
    return _errors(memory.model_poses * [learning.unit, learning.unit, 1.0], true)
