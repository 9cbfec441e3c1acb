"""Print rperc's dependencies and those of the named extras, one per line, read from
pyproject.toml (the one list). `make install` installs them while cargo builds the
extension, instead of after it as `pip install -e ".[extras]"` does."""

from __future__ import annotations

import sys
from pathlib import Path

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10: pip carries the same parser.
    from pip._vendor import tomli as tomllib


def requirements(extras: list[str]) -> list[str]:
    project = tomllib.loads((Path(__file__).parents[1] / "pyproject.toml").read_text())["project"]
    optional = project["optional-dependencies"]
    unknown = [e for e in extras if e not in optional]
    if unknown:
        raise SystemExit(f"no such extra in pyproject.toml: {', '.join(unknown)}")
    found = list(project["dependencies"])
    for extra in extras:
        found += [r for r in optional[extra] if not r.startswith("rperc[")]
    return list(dict.fromkeys(found))


if __name__ == "__main__":
    print("\n".join(requirements(sys.argv[1:])))
