"""Type stubs of the native extension. Use the documented wrappers in :mod:`rperc`."""

import numpy as np
import numpy.typing as npt

__all__ = [
    "NumericalError",
    "RpercError",
    "__version__",
    "extract_lines",
    "simplify_indices",
    "simplify_many_indices",
]

__version__: str

class RpercError(Exception): ...
class NumericalError(RpercError): ...

def simplify_indices(
    points: npt.NDArray[np.floating],
    epsilon: float,
    method: str = "hull",
    metric: str = "line",
    tie: str = "first",
) -> npt.NDArray[np.intp]: ...
def simplify_many_indices(
    polylines: list[npt.NDArray[np.floating]],
    epsilon: float,
    method: str = "hull",
    metric: str = "line",
    tie: str = "first",
    threads: int | None = None,
) -> list[npt.NDArray[np.intp]]: ...
def extract_lines(
    ranges: npt.NDArray[np.floating],
    angles: npt.NDArray[np.floating],
    *,
    min_range: float,
    max_range: float,
    sigma_range: float,
    sigma_bearing: float,
    breakpoint_lambda: float,
    split_epsilon: float,
    merge_chi2: float,
    min_points: int,
    min_length: float,
) -> tuple[
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.intp],
    npt.NDArray[np.intp],
]: ...
