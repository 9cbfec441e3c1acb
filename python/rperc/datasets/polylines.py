"""Geometries and polylines in WKT, GeoJSON and CSV files.

- ``.wkt``/``.txt``: one WKT geometry per line, any type shapely reads (``LINESTRING``,
  ``POLYGON``, ``MULTIPOLYGON``, ``... EMPTY``, ``Z``, ``M``, ``ZM``), optionally as
  EWKT with an ``SRID=4326;`` prefix (kept as the geometry's SRID and written back).
- ``.geojson``/``.json``: a FeatureCollection, a Feature or a bare geometry. GeoJSON has
  no M: M values are dropped when writing (Z is kept).
- ``.csv``: ``x,y[,z]`` rows (a header line is allowed); blank lines separate polylines.

WKT and GeoJSON go through shapely (``pip install shapely``); CSV polylines need only
numpy. Every malformed record raises :class:`DatasetFormatError` naming file and line.
"""

from __future__ import annotations

import json
import math
import re
import warnings
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from rperc import _geo
from rperc._args import excerpt
from rperc._atomic import write_atomically, write_text_atomically
from rperc.datasets._text import read_text, split_lines
from rperc.datasets.errors import DatasetFormatError

__all__ = [
    "format_of",
    "read_geometries",
    "read_polylines",
    "wkt_line",
    "write_geometries",
    "write_polyline",
]

_WKT = (".wkt", ".txt")
_GEOJSON = (".geojson", ".json")
_SRID = re.compile(r"^\s*SRID\s*=\s*(-?\d+)\s*;", re.I)


def format_of(path: str | Path) -> str:
    """The file format a suffix names: ``"wkt"``, ``"geojson"`` or ``"csv"``; anything
    else is a ValueError naming the path."""
    path = Path(path)
    suffix = path.suffix.lower()
    for kind, suffixes in (("wkt", _WKT), ("geojson", _GEOJSON), ("csv", (".csv",))):
        if suffix in suffixes:
            return kind
    raise ValueError(
        f"{path}: unknown file type {suffix!r}; use .wkt or .txt (WKT), .geojson or .json "
        "(GeoJSON), or .csv"
    )


def read_geometries(path: str | Path) -> list[_geo.Geometry]:
    """All geometries in a file, as shapely geometries, in file order (CSV polylines
    become LineStrings)."""
    return [g for _, g in _read_numbered(Path(path))]


def _read_numbered(path: Path) -> list[tuple[int, _geo.Shape]]:
    """Each geometry with the line it starts on."""
    kind = format_of(path)
    text = read_text(path)
    if kind == "csv":
        shapely = _geo.shapely_module()
        return [(line, shapely.LineString(pts)) for line, pts in _read_csv(path, text)]
    found = _read_wkt(path, text) if kind == "wkt" else _read_geojson(path, text)
    if not found:
        raise DatasetFormatError(path, 1, "no geometry in file")
    return found


def _read_wkt(path: Path, text: str) -> list[tuple[int, _geo.Shape]]:
    shapely = _geo.shapely_module()
    out = []
    for lineno, line in enumerate(split_lines(text), start=1):
        if not line.strip():
            continue
        srid = _SRID.match(line)
        body = line[srid.end() :] if srid else line
        try:
            with warnings.catch_warnings():
                # NaN coordinates warn here; _finite refuses them below, by line.
                warnings.simplefilter("ignore", RuntimeWarning)
                geom = shapely.from_wkt(body)
        except (shapely.errors.ShapelyError, ValueError) as exc:
            raise DatasetFormatError(
                path, lineno, f"bad WKT {excerpt(line.strip())}: {exc}"
            ) from None
        except NotImplementedError:
            # GEOS parses CIRCULARSTRING, COMPOUNDCURVE, CURVEPOLYGON and MULTICURVE,
            # but shapely has no type for them: its NotImplementedError named no file.
            raise DatasetFormatError(
                path, lineno, f"curved geometries are not supported: {excerpt(line.strip())}"
            ) from None
        if srid:
            geom = shapely.set_srid(geom, int(srid.group(1)))
        out.append((lineno, _finite(path, lineno, geom)))
    return out


def _finite(path: Path, lineno: int, geom: _geo.Shape) -> _geo.Shape:
    """``geom``, after checking that its coordinates are finite: a NaN or infinite
    vertex (WKT ``nan``, GeoJSON ``NaN``) gave polylines no length or area means."""
    shapely = _geo.shapely_module()
    coords = shapely.get_coordinates(geom, include_z=bool(shapely.has_z(geom)))
    if not np.isfinite(coords).all():
        raise DatasetFormatError(path, lineno, "coordinates must be finite, got NaN or infinity")
    return geom


# GeoJSON nests at most a few levels (a FeatureCollection of GeometryCollections of
# MultiPolygons); deeper documents are refused before any recursive code sees them.
_MAX_JSON_DEPTH = 64
_TOO_DEEP = object()


def _too_deep(doc: Any) -> bool:
    """Whether ``doc`` nests lists and dicts deeper than :data:`_MAX_JSON_DEPTH`,
    walked with a stack of its own (recursion is what fails on such documents)."""
    stack = [(doc, 1)]
    while stack:
        item, depth = stack.pop()
        children = item.values() if isinstance(item, dict) else item
        if isinstance(item, (dict, list)):
            if depth > _MAX_JSON_DEPTH:
                return True
            stack.extend((c, depth + 1) for c in children)
    return False


def _read_geojson(path: Path, text: str) -> list[tuple[int, _geo.Shape]]:
    shapely = _geo.shapely_module()
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise DatasetFormatError(path, exc.lineno, f"bad JSON: {exc.msg}") from None
    except RecursionError:
        # json's decoder recurses once per level: [[[...]]] 100,000 deep escaped as a
        # bare RecursionError.
        doc = _TOO_DEEP
    if doc is _TOO_DEEP or _too_deep(doc):
        raise DatasetFormatError(path, 1, f"JSON nested deeper than {_MAX_JSON_DEPTH} levels")
    if not isinstance(doc, dict):
        raise DatasetFormatError(path, 1, "GeoJSON must be an object")
    if doc.get("type") == "FeatureCollection":
        features = doc.get("features")
        if not isinstance(features, list):
            raise DatasetFormatError(path, 1, "FeatureCollection without a features list")
        lines = _element_lines(text, "features", len(features))
        items = [(f"features[{k}]", f, lines[k]) for k, f in enumerate(features)]
    else:
        items = [("the document", doc, 1)]
    out = []
    for where, item, lineno in items:
        geometry = (
            item.get("geometry")
            if isinstance(item, dict) and item.get("type") == "Feature"
            else item
        )
        if geometry is None:
            # A Feature without a location: keep the record, as an empty geometry.
            out.append((lineno, shapely.GeometryCollection()))
            continue
        try:
            geom = shapely.from_geojson(json.dumps(geometry))
        except (shapely.errors.ShapelyError, ValueError, TypeError) as exc:
            raise DatasetFormatError(
                path, lineno, f"{where}: bad GeoJSON geometry: {exc}"
            ) from None
        out.append((lineno, _finite(path, lineno, geom)))
    return out


def _element_lines(text: str, key: str, count: int) -> list[int]:
    """The line each element of the array ``"key": [...]`` starts on (1 for all when the
    array cannot be located unambiguously)."""
    head = re.search(rf'"{key}"\s*:\s*\[', text)
    if head is None:
        return [1] * count
    decoder = json.JSONDecoder()
    starts: list[int] = []
    pos = head.end()
    while len(starts) < count:
        while pos < len(text) and text[pos] in " \t\r\n,":
            pos += 1
        if pos >= len(text) or text[pos] == "]":
            break
        starts.append(pos)
        try:
            pos = decoder.raw_decode(text, pos)[1]
        except json.JSONDecodeError:
            break
    if len(starts) != count:
        return [1] * count
    return [text.count("\n", 0, s) + 1 for s in starts]


def read_polylines(path: str | Path) -> list[np.ndarray]:
    """Every line and ring in a file, each an (N, 2) or (N, 3) float64 array.

    Polygon rings become closed polylines, multi-geometries contribute each member;
    z is kept, M values are dropped (never turned into z). Points, empty geometries
    and non-linear members are an error naming the line. CSV files need no shapely.
    """
    path = Path(path)
    if format_of(path) == "csv":
        return [pts for _, pts in _read_csv(path, read_text(path))]
    out: list[np.ndarray] = []
    for lineno, geom in _read_numbered(path):
        kinds = _leaf_types(geom)
        if geom.is_empty or not kinds <= {"LineString", "LinearRing", "Polygon"}:
            what = "an empty geometry" if geom.is_empty else f"a {geom.geom_type}"
            raise DatasetFormatError(path, lineno, f"expected lines or polygons, got {what}")
        has_z = _geo.dims_of(geom).has_z
        out.extend(part.coords[:, : 3 if has_z else 2] for part in _geo.linear_parts(geom))
    return out


def _leaf_types(geom: _geo.Shape) -> set[str]:
    if hasattr(geom, "geoms"):
        return set().union(*(_leaf_types(g) for g in geom.geoms)) if len(geom.geoms) else set()
    return {geom.geom_type}


def _read_csv(path: Path, text: str) -> list[tuple[int, np.ndarray]]:
    out: list[tuple[int, np.ndarray]] = []
    rows: list[list[float]] = []
    width, first = None, 0
    for lineno, line in enumerate(split_lines(text), start=1):
        fields = [f.strip() for f in line.split(",")] if line.strip() else []
        if not fields:
            if rows:
                out.append((first, np.asarray(rows)))
                rows, width = [], None
            continue
        try:
            values = [float(f) for f in fields]
        except ValueError:
            if lineno == 1:  # header
                continue
            raise DatasetFormatError(path, lineno, f"bad CSV row {excerpt(line.strip())}") from None
        if len(values) not in (2, 3) or (width is not None and len(values) != width):
            raise DatasetFormatError(
                path, lineno, f"rows must have 2 or 3 values, got {len(values)}"
            )
        if not all(map(math.isfinite, values)):
            # float() reads "nan" and "inf": a point without a place.
            raise DatasetFormatError(path, lineno, f"coordinates must be finite, got {values}")
        if not rows:
            first = lineno
        width = len(values)
        rows.append(values)
    if rows:
        out.append((first, np.asarray(rows)))
    if not out:
        raise DatasetFormatError(path, 1, "no points in file")
    return out


def write_geometries(path: str | Path, geometries: Iterable[_geo.GeometryLike]) -> Path:
    """Write geometries (shapely geometries or ``__geo_interface__`` objects) in the
    format the suffix names; returns the path.

    WKT keeps the type, Z, M and SRID (as EWKT), and numbers read back exactly. GeoJSON writes a
    FeatureCollection (M dropped). CSV writes every line and ring as a polyline of
    ``x,y[,z]`` rows, blank lines between them (types and M are lost; points refused).
    An unknown suffix is a ValueError.
    """
    path = Path(path)
    kind = format_of(path)
    geoms = [_geo.to_shapely(g) for g in geometries]
    if kind == "wkt":
        text = "".join(wkt_line(g) + "\n" for g in geoms)
    elif kind == "geojson":
        text = _feature_collection(geoms)
    else:
        text = _csv_text(geoms)
    return write_text_atomically(path, text)


def wkt_line(geom: _geo.Geometry) -> str:
    """``geom`` as one line of WKT that reads back exactly (every digit needed), with
    Z and M, and an ``SRID=n;`` prefix (EWKT) when it has an SRID."""
    shapely = _geo.shapely_module()
    wkt = _geo.exact_wkt(geom)
    srid = int(shapely.get_srid(geom))
    return f"SRID={srid};{wkt}" if srid else wkt


def _feature_collection(geoms: Sequence[_geo.Shape]) -> str:
    shapely = _geo.shapely_module()
    features = ",\n".join(
        '{"type": "Feature", "properties": {}, "geometry": ' + str(shapely.to_geojson(g)) + "}"
        for g in geoms
    )
    return '{"type": "FeatureCollection", "features": [\n' + features + "\n]}\n"


def _csv_text(geoms: Sequence[_geo.Shape]) -> str:
    parts: list[np.ndarray] = []
    for geom in geoms:
        if not _leaf_types(geom) <= {"LineString", "LinearRing", "Polygon"}:
            raise ValueError(f"CSV holds polylines only, got a {geom.geom_type}")
        has_z = _geo.dims_of(geom).has_z
        parts.extend(p.coords[:, : 3 if has_z else 2] for p in _geo.linear_parts(geom))
    width = {p.shape[1] for p in parts}
    header = "x,y,z" if width == {3} else "x,y"
    blocks = [
        "\n".join(",".join(f"{v:.17g}" for v in row[: len(header.split(","))]) for row in p)
        for p in parts
    ]
    return header + "\n" + "\n\n".join(blocks) + "\n"


def write_polyline(path: str | Path, points: np.ndarray) -> Path:
    """Write one polyline ((N, 2) or (N, 3) array) as a LineString in WKT (``.wkt``),
    GeoJSON (``.geojson``/``.json``) or CSV (``.csv``; needs no shapely). An unknown
    suffix is a ValueError. Returns the path."""
    path = Path(path)
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] not in (2, 3):
        raise ValueError(f"points must have shape (N, 2) or (N, 3), got {pts.shape}")
    if format_of(path) == "csv":
        header = "x,y,z" if pts.shape[1] == 3 else "x,y"
        return write_atomically(
            path,
            lambda tmp: np.savetxt(
                tmp, pts, delimiter=",", header=header, comments="", fmt="%.17g"
            ),
        )
    return write_geometries(path, [_geo.shapely_module().LineString(pts)])
