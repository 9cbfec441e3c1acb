"""The public API spells its names one way (docs/glossary.md): American spelling as
OpenCV and numpy write it, so ``color`` and ``center``, never ``colour`` or ``centre``.
A name the rule was written after keeps a deprecated alias that warns."""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import warnings

import pytest

import rperc

#: British spellings the API must not use in a name.
BRITISH = ("colour", "centre")

#: Deprecated aliases kept for old code; each warns and names the new spelling.
DEPRECATED = {
    "rperc.navigation.memory.VisualMemory.model_centres": "model_centers",
    "rperc.tracking.planar.centre_error": "center_error",
}

#: Names not yet renamed. This list may only shrink.
NOT_YET_RENAMED: set[str] = set()


def _public_names() -> set[str]:
    """Every public module-level name of the library (its ``__all__``, or its names
    without a leading underscore) and every public attribute of its classes."""
    found: set[str] = set()
    for info in pkgutil.walk_packages(rperc.__path__, "rperc."):
        if info.name.startswith("rperc.cli") or info.name.endswith("__main__"):
            continue
        module = importlib.import_module(info.name)
        names = getattr(module, "__all__", [n for n in dir(module) if not n.startswith("_")])
        for name in names:
            found.add(f"{info.name}.{name}")
            obj = getattr(module, name, None)
            if inspect.isclass(obj) and obj.__module__.startswith("rperc"):
                for attr in dir(obj):
                    if not attr.startswith("_"):
                        found.add(f"{obj.__module__}.{obj.__qualname__}.{attr}")
    return found


def test_no_public_name_uses_british_spelling() -> None:
    british = {
        n for n in _public_names() if any(w in n.rsplit(".", 1)[-1].lower() for w in BRITISH)
    }
    assert british - set(DEPRECATED) - NOT_YET_RENAMED == set()
    # The list of names not yet renamed only shrinks: a renamed one leaves it.
    assert NOT_YET_RENAMED <= british


def test_model_centres_warns_and_answers_as_model_centers() -> None:
    """The deprecated alias on a real memory: the same array, with a warning."""
    from rperc.cli.navigation import s_path
    from rperc.navigation import CeilingWorld, learn

    world = CeilingWorld(ceiling={"seed": 4})
    memory = learn(world, (2.5, 2.5, 0.2), s_path(40), dt=0.1, seed=4).memory
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        new = memory.model_centers
    with pytest.warns(DeprecationWarning, match="model_centers"):
        old = memory.model_centres
    assert (old == new).all()
