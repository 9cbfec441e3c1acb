"""The typed configs (issue 36): generated from the Rust structs, checked once, there.

Oracles: the Rust crates' own serialisation of each config's ``Default`` (a path that
does not go through the schema or the generator), and the native constructors'
refusals."""

from __future__ import annotations

import dataclasses
import json
import pickle
from pathlib import Path
from typing import Any

import pytest

import rperc.config as config_module
from rperc import _rperc
from rperc._codegen import CLASS_NAMES, generate
from rperc.config import PlanarConfig, SimConfig, Unicycle
from rperc.slam import PlanarSlam


def test_the_module_is_what_the_generator_writes_from_the_rust_schemas() -> None:
    # Fails when a Rust config changes (a field, a default, a doc comment) and
    # `python -m rperc._codegen` was not run.
    written = Path(config_module.__file__).read_text()
    assert written == generate()


def test_every_native_config_has_a_class() -> None:
    assert sorted(CLASS_NAMES) == sorted(_rperc.config_names())


@pytest.mark.parametrize("native", sorted(CLASS_NAMES))
def test_defaults_equal_the_rust_defaults(native: str) -> None:
    cls = getattr(config_module, CLASS_NAMES[native])
    # JSON text on both sides: the native dict has tuples where to_dict() has lists.
    ours, rust = cls().to_dict(), _rperc.config_defaults(native)
    assert json.dumps(ours) == json.dumps(rust)


@pytest.mark.parametrize("native", sorted(CLASS_NAMES))
def test_round_trips_through_dicts_json_and_pickle(native: str) -> None:
    cls = getattr(config_module, CLASS_NAMES[native])
    made = cls()
    assert cls.from_dict(made.to_dict()) == made
    assert cls.from_dict(json.loads(json.dumps(made.to_dict()))) == made
    assert pickle.loads(pickle.dumps(made)) == made
    assert hash(made) == hash(cls())


def test_replace_gives_a_changed_checked_copy() -> None:
    base = PlanarConfig()
    changed = base.replace(association="jcbb", fix_lever_arm=(3.78, 0.5))
    assert changed.association == "jcbb" and base.association != "jcbb"
    assert changed.to_dict()["fix_lever_arm"] == [3.78, 0.5]
    with pytest.raises(dataclasses.FrozenInstanceError):
        base.anchor = True  # type: ignore[misc]
    with pytest.raises(ValueError, match="association"):
        base.replace(association="psychic")


@pytest.mark.parametrize(
    ("fields", "error", "names"),
    [
        ({"range_variance": -1.0}, ValueError, "range_variance"),
        ({"gate_confidence": 1.5}, ValueError, "gate_confidence"),
        ({"range_varianse": 1.0}, TypeError, "range_varianse"),
        ({"candidate_sightings": "three"}, TypeError, "candidate_sightings"),
    ],
)
def test_bad_fields_are_refused_when_made_naming_the_field(fields, error, names) -> None:
    with pytest.raises(error, match=names):
        PlanarConfig.from_dict(fields)


def test_a_tagged_union_reads_and_writes_serde_spelling() -> None:
    # serde's externally tagged enum: {"ackermann": {...}} picks the variant.
    defaults: dict[str, Any] = _rperc.config_defaults("planar")  # type: ignore[assignment]
    cfg = PlanarConfig.from_dict({"motion": {"unicycle": {"speed_variance": 0.5}}})
    assert isinstance(cfg.motion, Unicycle) and cfg.motion.speed_variance == 0.5
    assert cfg.to_dict()["motion"] == {
        "unicycle": {**defaults["motion"]["unicycle"], "speed_variance": 0.5}
    }
    with pytest.raises(ValueError, match="unicycle"):
        PlanarConfig.from_dict({"motion": {"bicycle": {}}})
    # The same struct as a field of its own is untagged (the laser pipeline's vehicle).
    from rperc.config import LaserConfig

    laser = LaserConfig.from_dict({"motion": {"speed_variance": 0.5}})
    assert isinstance(laser.motion, Unicycle) and laser.to_dict()["motion"]["speed_variance"] == 0.5


def test_planar_slam_takes_a_config_and_typed_overrides() -> None:
    slam = PlanarSlam(PlanarConfig(association="nn"), anchor=True)
    assert slam.config.association == "nn" and slam.config.anchor
    assert PlanarSlam({"association": "nn"}).config == PlanarConfig(association="nn")
    assert "association='nn'" in repr(slam)
    with pytest.raises(ValueError, match="range_variance"):
        PlanarSlam(range_variance=-1.0)


def test_repr_and_help_show_the_defaults() -> None:
    text = repr(SimConfig())
    default = _rperc.config_defaults("planar_sim")
    assert f"radius={default['radius']!r}" in text
    assert "Radius of the circle the robot drives" in (SimConfig.__doc__ or "")


def test_functions_take_a_config_or_a_dict_of_its_fields_alike() -> None:
    import numpy as np

    from rperc.slam.planar import monte_carlo, sim_slam_config, simulate

    typed = simulate(SimConfig(steps=40, landmarks=8), seed=3)
    plain = simulate({"steps": 40, "landmarks": 8}, seed=3)
    np.testing.assert_array_equal(typed.truth, plain.truth)
    matched = sim_slam_config(SimConfig(range_variance=0.04), anchor=True)
    assert matched["range_variance"] == 0.04 and matched["anchor"] is True
    mc = monte_carlo(SimConfig(steps=30), slam=PlanarConfig.from_dict(matched), runs=2)
    assert mc.runs == 2 and mc.sim["steps"] == 30 and mc.slam["anchor"] is True
    with pytest.raises(ValueError, match="radius"):
        simulate(SimConfig(radius=-1.0))


def test_the_remembered_native_dict_equals_a_fresh_check_and_still_refuses() -> None:
    from rperc._config_base import as_config, native_config
    from rperc.config import ScanParams

    for config, over in [(None, {}), (None, {"min_points": 3}), ({"min_length": 0.5}, {})]:
        fresh = as_config(ScanParams, config, over).to_dict()
        assert native_config(ScanParams, config, over) == fresh
        assert native_config(ScanParams, config, over) == fresh  # from the cache
    for _ in range(2):  # errors are not remembered as answers
        with pytest.raises(ValueError, match="split_epsilon"):
            native_config(ScanParams, None, {"split_epsilon": -1.0})
    got = native_config(PlanarConfig, {"fix_lever_arm": [1.0, 2.0]}, {})  # unhashable
    assert got["fix_lever_arm"] == [1.0, 2.0]


def test_the_smoother_takes_its_config_class_and_refuses_a_bad_one_naming_it() -> None:
    from rperc.config import SmootherConfig
    from rperc.slam.smoothing import smooth_walls

    # The check comes before any smoothing: a result without walls is not even read.
    with pytest.raises(ValueError, match="max_iterations"):
        smooth_walls(None, [], [], [0.0], max_iterations=0)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="tolerance"):
        smooth_walls(None, [], [], [0.0], SmootherConfig(tolerance=-1.0))  # type: ignore[arg-type]


def test_a_config_of_the_wrong_kind_is_a_type_error_naming_what_is_wanted() -> None:
    from rperc.slam.planar import simulate

    with pytest.raises(TypeError, match="SimConfig, a mapping of its fields or None"):
        simulate("radius=3")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="PlanarConfig, a mapping"):
        PlanarSlam(["anchor"])  # type: ignore[arg-type]
