"""The package's public signatures say what they take and give (issue 36): ``Any`` is
allowed only where a value is genuinely arbitrary (user data, or a protocol that answers
whatever is asked for), at most 10 places, each listed below with its reason. Read
statically from the source with ``ast``, so nothing is imported and a module that fails
to import still counts.

Public means: a module whose path has no part starting with ``_`` (``__init__.py``
counts), and in it a function, a class, a method (``__init__``, ``__call__`` and a
module's ``__getattr__`` included) or a class or module attribute whose name has no
leading ``_``. A type alias (``Row = dict[str, Any]``, here or imported) counts as the
``Any`` it stands for.

Run ``python tests/test_typed_contract.py`` to print every place still counted."""

from __future__ import annotations

import ast
from collections import Counter
from collections.abc import Iterator
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1] / "python"

#: ``Any`` in a public signature that is genuinely arbitrary, with the reason.
#: Keys are ``module.qualname`` (a parameter's or field's owner); at most 10.
ALLOWED: dict[str, str] = {
    "rperc.__getattr__": "the lazy attributes of ``import rperc`` (PEP 562): whichever "
    "subpackage, exception class or version string is asked for; a narrower type would "
    "hide the subpackages' own types from a type checker",
}

#: Places not yet typed, per module: the exact count, which may only shrink (a typed
#: place leaves it). Empty when issue 36 is done.
NOT_YET_TYPED: dict[str, int] = {}


def _module_name(path: Path) -> str:
    name = ".".join(path.relative_to(ROOT).with_suffix("").parts)
    return name.removesuffix(".__init__")


def _is_public_module(path: Path) -> bool:
    parts = path.relative_to(ROOT / "rperc").parts
    return all(p == "__init__.py" or not p.startswith("_") for p in parts)


def _public(name: str) -> bool:
    # A module's __getattr__ (PEP 562) answers for public names too.
    return not name.startswith("_") or name in ("__init__", "__call__", "__getattr__")


def _names_in(node: ast.AST | None) -> Iterator[str]:
    """Every name an annotation mentions (``typing.Any`` as ``Any``); a string
    annotation is parsed, so ``"Any"`` counts as well."""
    if node is None:
        return
    for sub in ast.walk(node):
        if isinstance(sub, ast.Name):
            yield sub.id
        elif isinstance(sub, ast.Attribute):
            yield sub.attr
            if isinstance(sub.value, ast.Name):
                yield f"{sub.value.id}.{sub.attr}"
        elif isinstance(sub, ast.Constant) and isinstance(sub.value, str):
            try:
                yield from _names_in(ast.parse(sub.value, mode="eval"))
            except SyntaxError:
                continue


def _alias_value(stmt: ast.stmt) -> tuple[str, ast.expr] | None:
    """A module-level type alias: ``X = <type>``, ``X: TypeAlias = <type>``."""
    if isinstance(stmt, ast.Assign) and len(stmt.targets) == 1:
        target, value = stmt.targets[0], stmt.value
    elif isinstance(stmt, ast.AnnAssign) and stmt.value is not None:
        if "TypeAlias" not in set(_names_in(stmt.annotation)):
            return None
        target, value = stmt.target, stmt.value
    else:
        return None
    return (target.id, value) if isinstance(target, ast.Name) else None


def _any_aliases(trees: dict[str, ast.Module]) -> dict[str, set[str]]:
    """Per module, the names that stand for a type holding ``Any``: its own aliases,
    those it imports by name from another module of the package, and ``mod.Alias``
    for a module it imports whole."""
    own = {
        mod: {
            a[0]
            for stmt in tree.body
            if (a := _alias_value(stmt)) and "Any" in set(_names_in(a[1]))
        }
        for mod, tree in trees.items()
    }
    seen = {mod: set(names) for mod, names in own.items()}
    for mod, tree in trees.items():
        package = mod if mod in trees and _is_package(mod, trees) else mod.rpartition(".")[0]
        for stmt in ast.walk(tree):
            if not isinstance(stmt, ast.ImportFrom):
                continue
            base = stmt.module or ""
            if stmt.level:
                parts = package.split(".")[: len(package.split(".")) - stmt.level + 1]
                base = ".".join(parts + ([stmt.module] if stmt.module else []))
            for alias in stmt.names:
                local = alias.asname or alias.name
                if alias.name in own.get(base, set()):
                    seen[mod].add(local)
                # ``from pkg import _geo`` then ``_geo.Geometry``
                seen[mod] |= {f"{local}.{n}" for n in own.get(f"{base}.{alias.name}", set())}
        for stmt in ast.walk(tree):
            if isinstance(stmt, ast.Import):
                for alias in stmt.names:
                    local = alias.asname or alias.name
                    seen[mod] |= {f"{local}.{n}" for n in own.get(alias.name, set())}
    return seen


def _is_package(mod: str, trees: dict[str, ast.Module]) -> bool:
    return any(other.startswith(mod + ".") for other in trees)


def _count(node: ast.AST | None, aliases: set[str]) -> int:
    return sum(1 for n in _names_in(node) if n == "Any" or n in aliases)


def _signature_places(fn: ast.FunctionDef | ast.AsyncFunctionDef) -> Iterator[ast.AST | None]:
    args = fn.args
    for a in [*args.posonlyargs, *args.args, *args.kwonlyargs, args.vararg, args.kwarg]:
        if a is not None:
            yield a.annotation
    yield fn.returns


def _places(body: list[ast.stmt], owner: str, aliases: set[str]) -> Iterator[tuple[str, int]]:
    """``(qualname, count)`` for every public signature and attribute in ``body``."""
    for stmt in body:
        if isinstance(stmt, ast.FunctionDef | ast.AsyncFunctionDef) and _public(stmt.name):
            n = sum(_count(p, aliases) for p in _signature_places(stmt))
            yield f"{owner}{stmt.name}", n
        elif isinstance(stmt, ast.ClassDef) and not stmt.name.startswith("_"):
            yield from _places(stmt.body, f"{owner}{stmt.name}.", aliases)
        elif isinstance(stmt, ast.AnnAssign) and isinstance(stmt.target, ast.Name):
            if _public(stmt.target.id) and "TypeAlias" not in set(_names_in(stmt.annotation)):
                yield f"{owner}{stmt.target.id}", _count(stmt.annotation, aliases)


def any_in_public_signatures() -> Counter[str]:
    """How many ``Any`` each public place of the package has (places with none left out)."""
    paths = {_module_name(p): p for p in sorted((ROOT / "rperc").rglob("*.py"))}
    trees = {mod: ast.parse(p.read_text(), filename=str(p)) for mod, p in paths.items()}
    aliases = _any_aliases(trees)
    found: Counter[str] = Counter()
    for mod, tree in trees.items():
        if not _is_public_module(paths[mod]):
            continue
        for qualname, n in _places(tree.body, "", aliases[mod]):
            if n:
                found[f"{mod}.{qualname}"] += n
    return found


def _per_module(found: Counter[str]) -> dict[str, int]:
    """Counts of the places not allowed, per module (the module is the longest prefix
    of the place that names a file of the package)."""
    modules = {_module_name(p) for p in (ROOT / "rperc").rglob("*.py")}
    per: Counter[str] = Counter()
    for place, n in found.items():
        if place in ALLOWED:
            continue
        parts = place.split(".")
        mod = next(
            ".".join(parts[:k]) for k in range(len(parts), 0, -1) if ".".join(parts[:k]) in modules
        )
        per[mod] += n
    return dict(per)


def test_allowed_any_is_at_most_ten_and_each_has_a_reason() -> None:
    found = any_in_public_signatures()
    assert sum(found[p] for p in ALLOWED) <= 10
    assert all(reason.strip() for reason in ALLOWED.values())
    # An allowed place that no longer holds an Any leaves the list.
    assert {p for p in ALLOWED if not found[p]} == set()


def test_no_new_any_and_the_untyped_list_only_shrinks() -> None:
    """Every module's count of untyped places equals its entry in NOT_YET_TYPED:
    a new ``Any`` fails, and so does a typed place not yet struck from the list."""
    assert _per_module(any_in_public_signatures()) == NOT_YET_TYPED


def test_the_scanner_counts_aliases_strings_and_keywords() -> None:
    """The counter itself, on a source with one of each form it must see."""
    source = (
        "from typing import Any\n"
        "Row = dict[str, Any]\n"
        "def f(x: 'Any', *a: int, **kw: Any) -> Row: ...\n"
        "def _g(x: Any) -> None: ...\n"
        "class C:\n"
        "    y: Mapping[str, Any]\n"
        "    def __init__(self, z: list[Any]) -> None: ...\n"
        "    def _h(self, z: Any) -> None: ...\n"
    )
    tree = ast.parse(source)
    aliases = _any_aliases({"m": tree})["m"]
    assert aliases == {"Row"}
    assert dict(_places(tree.body, "", aliases)) == {
        "f": 3,
        "C.y": 1,
        "C.__init__": 1,
    }
    # An alias reached through its module, imported whole or from its package.
    user = ast.parse("from p import m\nimport p.m as q\ndef g(a: m.Row, b: q.Row) -> None: ...\n")
    aliases = _any_aliases({"p.m": tree, "p.u": user})["p.u"]
    assert dict(_places(user.body, "", aliases)) == {"g": 2}


if __name__ == "__main__":
    places = any_in_public_signatures()
    for place, n in sorted(places.items(), key=lambda kv: (-kv[1], kv[0])):
        print(f"{n:4d}  {place}{'  (allowed)' if place in ALLOWED else ''}")
    print(f"total {sum(places.values())} in {len(places)} places")
    for mod, n in sorted(_per_module(places).items(), key=lambda kv: -kv[1]):
        print(f"    {mod!r}: {n},")
