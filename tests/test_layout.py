"""The package's layout: no two modules of ``python/rperc`` import each other,
directly or around a loop (issue 36). Read statically from the source, so a lazy
import inside a function counts too: a loop through one still ties the modules."""

from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1] / "python"


def _modules() -> dict[str, Path]:
    mods = {}
    for path in ROOT.rglob("*.py"):
        name = ".".join(path.relative_to(ROOT).with_suffix("").parts)
        mods[name.removesuffix(".__init__")] = path
    return mods


def _imported(node: ast.AST, package: str, mods: dict[str, Path]) -> list[str]:
    """The modules of ``mods`` one import statement reaches. ``from pkg import sub``
    reaches the submodule ``sub`` (Python runs ``pkg/__init__`` first, but a package
    that re-exports its parts is not a loop of its files)."""
    if isinstance(node, ast.Import):
        return [a.name for a in node.names if a.name in mods]
    if not isinstance(node, ast.ImportFrom):
        return []
    base = node.module or ""
    if node.level:
        parts = package.split(".")[: len(package.split(".")) - node.level + 1]
        base = ".".join(parts + ([node.module] if node.module else []))
    subs = [f"{base}.{a.name}" for a in node.names if f"{base}.{a.name}" in mods]
    return subs or ([base] if base in mods else [])


def import_graph() -> dict[str, set[str]]:
    mods = _modules()
    graph: dict[str, set[str]] = {}
    for name, path in mods.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        tree = ast.parse(path.read_text(encoding="utf-8"))
        reached = {m for node in ast.walk(tree) for m in _imported(node, package, mods)}
        graph[name] = reached - {name}
    return graph


def loops(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected groups of more than one module (Tarjan, with an explicit
    stack of iterators instead of recursion)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: list[list[str]] = []
    for root in graph:
        if root in index:
            continue
        index[root] = low[root] = len(index)
        stack.append(root)
        work = [(root, iter(sorted(graph[root])))]
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is None:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    group = stack[stack.index(node) :]
                    del stack[stack.index(node) :]
                    if len(group) > 1:
                        found.append(sorted(group))
            elif child not in index:
                index[child] = low[child] = len(index)
                stack.append(child)
                work.append((child, iter(sorted(graph[child]))))
            elif child in stack:
                low[node] = min(low[node], index[child])
    return found


def test_the_loop_finder_finds_loops():
    """The oracle of the check itself: a hand-made graph with two loops."""
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"e"}, "e": {"d", "a"}, "f": set()}
    assert sorted(loops(graph)) == [["a", "b", "c"], ["d", "e"]]


def test_no_module_imports_itself_around_a_loop():
    graph = import_graph()
    assert "rperc.cli.demo" in graph and "rperc.slam.planar" in graph
    assert loops(graph) == []


def test_the_library_never_imports_the_command_line():
    """The CLI is a layer on the library: nothing outside ``rperc.cli`` (but the
    ``python -m rperc`` entry point) reaches into it for logic."""
    graph = import_graph()
    inside = {m for m in graph if m == "rperc.cli" or m.startswith("rperc.cli.")}
    leaks = {m: sorted(graph[m] & inside) for m in graph if m not in inside}
    assert {m: v for m, v in leaks.items() if v and m != "rperc.__main__"} == {}


CRATES = Path(__file__).resolve().parents[1] / "crates"
# Loops left to break: none. A new loop fails the test. (The last one, slam's planar
# compress/engine/walls, went when the engine stopped importing the wall map's and the
# compressed filter's types from the files that extend it.)
KNOWN_RUST_LOOPS: list[list[object]] = []
RUST_PATH = re.compile(r"\b(crate|super|self)((?:::\w+)+)")


def _rust_modules(src: Path) -> dict[str, Path]:
    mods = {}
    for path in src.rglob("*.rs"):
        parts = path.relative_to(src).with_suffix("").parts
        if parts[0] == "bin":
            continue
        if parts[-1] in ("mod", "lib", "main"):
            parts = parts[:-1]
        mods["::".join(parts)] = path
    return mods


def _rust_targets(code: str, here: list[str], mods: dict[str, str | Path]) -> set[str]:
    """The modules that ``crate::``, ``self::`` and ``super::`` paths in ``code``
    name (the longest prefix that is a module), leaving out the module's own
    ancestors: a child naming its parent's items is how Rust modules nest."""
    found = set()
    for m in RUST_PATH.finditer(code):
        head, rest = m.group(1), m.group(2).strip(":").split("::")
        base = [] if head == "crate" else list(here) if head == "self" else list(here[:-1])
        while head == "super" and rest and rest[0] == "super":
            base, rest = base[:-1], rest[1:]
        path = base + rest
        for k in range(len(path), 0, -1):
            name = "::".join(path[:k])
            if name in mods:
                own = "::".join(here)
                if name != own and not own.startswith(name + "::"):
                    found.add(name)
                break
    return found


def rust_loops() -> list[list[object]]:
    found: list[list[object]] = []
    for crate in sorted(p for p in CRATES.iterdir() if (p / "src").is_dir()):
        mods = _rust_modules(crate / "src")
        graph = {}
        for name, path in mods.items():
            lines = path.read_text(encoding="utf-8").splitlines()
            code = "\n".join(ln for ln in lines if not ln.lstrip().startswith("//"))
            here = name.split("::") if name else []
            graph[name] = _rust_targets(code, here, mods)  # type: ignore[arg-type]
        found += [[crate.name, group] for group in loops(graph)]
    return found


def test_rust_module_loops_only_shrink():
    assert sorted(rust_loops()) == sorted(KNOWN_RUST_LOOPS)
