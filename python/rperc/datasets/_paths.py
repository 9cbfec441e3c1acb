"""Where the shared data sets live: ``$RPERC_DATA``, else ``../shared/data`` beside the
repository root."""

from __future__ import annotations

import os
from pathlib import Path


def data_dir() -> Path | None:
    """The data folder, or ``None`` when it cannot be found."""
    env = os.environ.get("RPERC_DATA")
    if env:
        return Path(env)
    # python/rperc/datasets/_paths.py -> the repository root is three levels up
    # (editable installs); fall back to the working directory's parent.
    repo_root = Path(__file__).resolve().parents[3]
    for candidate in (repo_root.parent / "shared" / "data", Path.cwd().parent / "shared" / "data"):
        if candidate.is_dir():
            return candidate
    return None


def data_path(*parts: str) -> Path:
    """A path inside the data folder; ``FileNotFoundError`` with a hint when absent."""
    root = data_dir()
    if root is None:
        raise FileNotFoundError(
            "rperc's data folder was not found: set RPERC_DATA to the folder holding "
            "carmen/, otb/, polylines/ ..."
        )
    path = root.joinpath(*parts)
    if not path.exists():
        raise FileNotFoundError(f"{path} does not exist (RPERC_DATA={root})")
    return path
