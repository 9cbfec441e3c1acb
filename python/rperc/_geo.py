"""Geometries in and out through shapely, an optional dependency (``pip install shapely``
or ``pip install 'rperc[geo]'``), imported only when a geometry is actually used.

A geometry is split into its linear *parts* (each LineString, LinearRing and polygon
ring, in order, with every coordinate column: x, y and z and/or m when present), the
parts are simplified, and the geometry is rebuilt from the kept coordinates with the
same type, dimensions (Z, M, ZM) and SRID. Rebuilding writes ISO WKB, which carries M
(shapely's array constructors do not).
"""

from __future__ import annotations

import importlib
import struct
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from types import ModuleType
from typing import Any, Protocol

import numpy as np

from rperc._extras import require

# shapely ships no type information: inside this module, and where a reader takes a
# geometry apart, a geometry is a ``Shape`` (unchecked); public signatures name the
# protocols below, which say what rperc relies on.
Shape = Any


class Geometry(Protocol):
    """A shapely geometry (any of its types): what rperc returns and reads."""

    @property
    def geom_type(self) -> str: ...

    @property
    def is_empty(self) -> bool: ...


class GeoInterface(Protocol):
    """An object that describes itself as GeoJSON (``__geo_interface__``)."""

    @property
    def __geo_interface__(self) -> Mapping[str, object]: ...


#: What a function that takes a geometry accepts: a shapely geometry, any object
#: with ``__geo_interface__``, or a GeoJSON-like mapping.
GeometryLike = Geometry | GeoInterface | Mapping[str, object]


_WKB_CODES = {
    "Point": 1,
    "LineString": 2,
    "Polygon": 3,
    "MultiPoint": 4,
    "MultiLineString": 5,
    "MultiPolygon": 6,
    "GeometryCollection": 7,
}


def shapely_module() -> ModuleType:
    """The shapely module, or an ImportError that says how to install it."""
    return require("shapely", "shapely geometries, WKT and GeoJSON")


def is_geometry(obj: object) -> bool:
    """Whether ``obj`` is a geometry rather than an array of points: a shapely
    geometry, any object with ``__geo_interface__``, or a GeoJSON-like mapping."""
    # Look on the type first: shapely computes ``__geo_interface__`` (a tuple of every
    # coordinate) each time the property is read.
    if hasattr(type(obj), "__geo_interface__") or hasattr(obj, "__geo_interface__"):
        return True
    return isinstance(obj, Mapping) and "type" in obj


def to_shapely(obj: object) -> Geometry:
    """``obj`` as a shapely geometry (shapely geometries are returned as they are)."""
    shapely = shapely_module()
    if isinstance(obj, shapely.Geometry):
        same: Geometry = obj
        return same
    geometry = importlib.import_module("shapely.geometry")
    try:
        made: Geometry = geometry.shape(obj)
        return made
    except (KeyError, TypeError, ValueError, AttributeError, shapely.errors.GEOSException) as exc:
        raise ValueError(f"not a valid geometry: {exc}") from exc


@dataclass(frozen=True)
class Part:
    """One linear component: coordinates ``(N, 2 + has_z + has_m)`` and whether it is a
    polygon ring or LinearRing (whose start vertex may move) rather than a line."""

    coords: np.ndarray
    ring: bool


@dataclass(frozen=True)
class Layout:
    """How a geometry is made of parts. ``parts`` indexes the flat part list (one for
    a line or ring, shell then holes for a polygon); ``children`` are the members of a
    multi-geometry or collection; ``keep`` is a geometry passed through unchanged
    (points, empty members)."""

    geom_type: str
    parts: tuple[int, ...] = ()
    children: tuple[Layout, ...] = ()
    keep: Shape = None


@dataclass(frozen=True)
class Dims:
    has_z: bool
    has_m: bool

    @property
    def flag(self) -> int:
        """The ISO WKB type offset: 1000 for Z, 2000 for M, 3000 for ZM."""
        return 1000 * self.has_z + 2000 * self.has_m


def dims_of(geom: Shape) -> Dims:
    shapely = shapely_module()
    return Dims(bool(shapely.has_z(geom)), bool(shapely.has_m(geom)))


def decompose(geom: Shape) -> tuple[Layout, list[Part]]:
    """The layout of ``geom`` and its linear parts, in order."""
    shapely = shapely_module()
    dims = dims_of(geom)
    parts: list[Part] = []

    def coords(line: Shape) -> np.ndarray:
        return np.asarray(
            shapely.get_coordinates(line, include_z=dims.has_z, include_m=dims.has_m),
            dtype=np.float64,
        )

    def add(line: Shape, ring: bool) -> int:
        parts.append(Part(coords(line), ring))
        return len(parts) - 1

    def walk(g: Shape) -> Layout:
        kind = g.geom_type
        if g.is_empty or kind in ("Point", "MultiPoint"):
            return Layout(kind, keep=g)
        if kind in ("LineString", "LinearRing"):
            return Layout(kind, parts=(add(g, kind == "LinearRing"),))
        if kind == "Polygon":
            rings = (g.exterior, *g.interiors)
            return Layout(kind, parts=tuple(add(r, True) for r in rings))
        return Layout(kind, children=tuple(walk(member) for member in g.geoms))

    return walk(geom), parts


def rebuild(
    layout: Layout, coords: Sequence[np.ndarray | None], dims: Dims, srid: int = 0
) -> Shape:
    """The geometry of ``layout`` with part ``k`` replaced by ``coords[k]``; ``None``
    drops a collapsed ring (a polygon whose shell is dropped becomes empty)."""
    shapely = shapely_module()
    if layout.geom_type == "LinearRing":
        geom = _linear_ring(coords[layout.parts[0]], dims)
    else:
        geom = shapely.from_wkb(_wkb(layout, coords, dims))
    return shapely.set_srid(geom, srid) if srid else geom


def _linear_ring(ring: np.ndarray | None, dims: Dims) -> Shape:
    """WKB has no LinearRing type; WKT has, with M."""
    shapely = shapely_module()
    tag = {(False, False): "", (True, False): " Z", (False, True): " M", (True, True): " ZM"}
    head = f"LINEARRING{tag[dims.has_z, dims.has_m]}"
    if ring is None:
        return shapely.from_wkt(f"{head} EMPTY")
    body = ", ".join(" ".join(_number(v) for v in row) for row in ring)
    return shapely.from_wkt(f"{head} ({body})")


def _wkb(layout: Layout, coords: Sequence[np.ndarray | None], dims: Dims) -> bytes:
    shapely = shapely_module()
    if layout.keep is not None:
        return bytes(shapely.to_wkb(layout.keep, flavor="iso", output_dimension=4))
    kind = "LineString" if layout.geom_type == "LinearRing" else layout.geom_type
    head = struct.pack("<BI", 1, _WKB_CODES[kind] + dims.flag)
    if kind == "LineString":
        return head + _wkb_points(coords[layout.parts[0]])
    if kind == "Polygon":
        rings = [coords[k] for k in layout.parts]
        kept = [] if rings[0] is None else [r for r in rings if r is not None]
        return head + struct.pack("<I", len(kept)) + b"".join(_wkb_points(r) for r in kept)
    # A polygon whose shell collapsed leaves its multi-geometry, as in GEOS.
    members = [
        _wkb(child, coords, dims) for child in layout.children if not _collapsed(child, coords)
    ]
    return head + struct.pack("<I", len(members)) + b"".join(members)


def _collapsed(layout: Layout, coords: Sequence[np.ndarray | None]) -> bool:
    return layout.geom_type in ("Polygon", "LinearRing") and coords[layout.parts[0]] is None


def _wkb_points(points: np.ndarray | None) -> bytes:
    pts = np.zeros((0, 2)) if points is None else points
    return struct.pack("<I", len(pts)) + np.ascontiguousarray(pts, dtype="<f8").tobytes()


def linear_parts(geom: Shape) -> list[Part]:
    """Every line and ring of ``geom``, in order."""
    return decompose(geom)[1]


def map_parts(
    geom: Shape, simplify_parts: Callable[[list[Part]], list[np.ndarray | None]]
) -> Geometry:
    """``geom`` with its parts replaced by ``simplify_parts(parts)`` (same order)."""
    shapely = shapely_module()
    if geom.is_empty:
        unchanged: Geometry = geom
        return unchanged
    layout, parts = decompose(geom)
    new = simplify_parts(parts) if parts else []
    rebuilt: Geometry = rebuild(layout, new, dims_of(geom), int(shapely.get_srid(geom)))
    return rebuilt


_DIM_TAGS = {(False, False): "", (True, False): " Z", (False, True): " M", (True, True): " ZM"}
_KEYWORDS = {
    "Point": "POINT",
    "LineString": "LINESTRING",
    "LinearRing": "LINEARRING",
    "Polygon": "POLYGON",
    "MultiPoint": "MULTIPOINT",
    "MultiLineString": "MULTILINESTRING",
    "MultiPolygon": "MULTIPOLYGON",
    "GeometryCollection": "GEOMETRYCOLLECTION",
}


def exact_wkt(geom: Shape) -> str:
    """WKT whose numbers read back bit for bit (Python's shortest round-trip repr),
    with the Z/M tag; GEOS's writer rounds some values at 16 or 17 digits."""
    dims = dims_of(geom)
    return f"{_KEYWORDS[geom.geom_type]}{_DIM_TAGS[dims.has_z, dims.has_m]} {_wkt_body(geom, dims)}"


def _wkt_body(geom: Shape, dims: Dims) -> str:
    """The parenthesised part of a geometry's WKT (``EMPTY`` when empty)."""
    shapely = shapely_module()
    kind = geom.geom_type
    if geom.is_empty:
        return "EMPTY"
    if kind in ("Point", "LineString", "LinearRing"):
        xyzm = shapely.get_coordinates(geom, include_z=dims.has_z, include_m=dims.has_m)
        return "(" + ", ".join(" ".join(_number(v) for v in row) for row in xyzm) + ")"
    if kind == "Polygon":
        rings = (geom.exterior, *geom.interiors)
        return "(" + ", ".join(_wkt_body(r, dims) for r in rings) + ")"
    if kind == "GeometryCollection":
        return "(" + ", ".join(exact_wkt(m) for m in geom.geoms) + ")"
    return "(" + ", ".join(_wkt_body(m, dims) for m in geom.geoms) + ")"


def _number(v: float) -> str:
    """The shortest text that reads back as ``v``, without a trailing ``.0``."""
    text = repr(float(v))
    return text[:-2] if text.endswith(".0") else text
