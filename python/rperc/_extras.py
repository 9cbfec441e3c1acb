"""Optional dependencies, imported in one place: a missing one is reported by the
extra that installs it (``pip install 'rperc[video]'``), which the ``rperc`` command
prints in one line with exit status 2, instead of a traceback."""

from __future__ import annotations

import importlib
from types import ModuleType

#: The extra that installs each optional top-level module.
EXTRAS: dict[str, str] = {
    "cv2": "opencv",
    "shapely": "geo",
    "rerun": "viz",
    "imageio": "video",
    "distributed": "cluster",
    "dask": "cluster",
}


class MissingExtraError(ImportError):
    """An optional dependency is not installed; the message names its extra."""


def require(module: str, needed_for: str) -> ModuleType:
    """``module`` imported, or :class:`MissingExtraError` saying that ``needed_for``
    needs its extra. An import error inside an installed module is not hidden."""
    top = module.split(".")[0]
    try:
        importlib.import_module(top)
    except ModuleNotFoundError as exc:
        # Only the optional package itself missing is a missing extra: anything it
        # fails to import in turn is a real bug, and keeps its traceback.
        if exc.name != top or top not in EXTRAS:
            raise
        extra = EXTRAS[top]
        raise MissingExtraError(
            f"{needed_for}: needs the {extra} extra (pip install 'rperc[{extra}]')"
        ) from None
    return importlib.import_module(module)
