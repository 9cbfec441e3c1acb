"""Writes :mod:`rperc.config` from the JSON Schemas the Rust crates export
(``_rperc.config_schema``): one frozen dataclass per config struct, with its fields'
types, defaults and doc comments, and a ``TypedDict`` of its fields for typed keyword
overrides. A config is defined once, in Rust; ``tests/test_config.py`` checks that the
module is what this writes. Run ``python -m rperc._codegen`` after changing a config.
"""

from __future__ import annotations

import json
import keyword
import textwrap
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rperc import _rperc
from rperc._atomic import write_text_atomically

#: The Python class of each native config, by the name ``config_schema`` takes.
CLASS_NAMES = {
    "color_histogram": "ColorHistogramConfig",
    "color_shape": "ColorShapeConfig",
    "color_template": "ColorTemplateConfig",
    "particle_color": "ParticleColorConfig",
    "pattern": "PatternConfig",
    "pattern_sequence": "PatternSequenceConfig",
    "laser": "LaserConfig",
    "laser_scan": "ScanConfig",
    "monobot": "MonobotConfig",
    "planar": "PlanarConfig",
    "planar_sim": "SimConfig",
    "scan_params": "ScanParams",
    "smoother": "SmootherConfig",
    # After "pattern": the visual memory's mosaic nests the pattern tracker's config,
    # whose class is the one "pattern" makes (checked natively when made).
    "ceiling": "CeilingConfig",
    "ceiling_camera": "CeilingCameraConfig",
    "ceiling_render": "CeilingRenderConfig",
    "odometry_noise": "OdometryNoise",
    "memory_learn": "LearnConfig",
    "memory_replay": "ReplayConfig",
}

HEADER = '''"""The typed configs of rperc, generated from the Rust structs that define them
(``python -m rperc._codegen``; do not edit by hand).

Each is a frozen dataclass: ``replace(**changes)`` gives a changed copy,
``to_dict()``/``from_dict()`` convert to and from plain dicts (JSON), and the owning
Rust crate checks every value when one is made. Each ``...Overrides`` is the
``TypedDict`` of the config's fields, for typed keyword arguments."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar, Literal, TypedDict

from rperc._config_base import Config
'''


@dataclass
class Module:
    """The classes written so far, in dependency order, each once."""

    schemas: dict[str, Any] = field(default_factory=dict)
    blocks: list[str] = field(default_factory=list)
    done: set[str] = field(default_factory=set)
    names: list[str] = field(default_factory=list)

    def resolve(self, schema: dict[str, Any]) -> tuple[str, dict[str, Any]]:
        ref = schema.get("$ref", "")
        name = ref.rsplit("/", 1)[-1]
        return name, self.schemas[name] if ref else schema


def generate() -> str:
    """The source of :mod:`rperc.config`."""
    module = Module()
    schemas = {cls: json.loads(_rperc.config_schema(n)) for n, cls in CLASS_NAMES.items()}
    for schema in schemas.values():
        for name, part in schema.get("$defs", {}).items():
            if module.schemas.setdefault(name, part) != part:
                raise ValueError(f"two Rust types are both called {name}: rename one")
    # Unions first: a variant's class must subclass its union even where another
    # config uses the same struct on its own.
    for name, part in module.schemas.items():
        if _is_union(part):
            _union(module, name, part)
    for (native, cls), schema in zip(CLASS_NAMES.items(), schemas.values(), strict=True):
        module.schemas[cls] = schema
        _struct(module, cls, schema, native=native)
    exports = "".join(f'    "{n}",\n' for n in sorted(module.names))
    body = "\n\n\n".join(module.blocks)
    return f"{HEADER}\n__all__ = [\n{exports}]\n\n\n{body}\n"


def _struct(
    module: Module,
    name: str,
    schema: dict[str, Any],
    native: str = "",
    base: str = "Config",
    tag: str = "",
) -> None:
    if name in module.done:
        return
    module.done.add(name)
    props = schema.get("properties", {})
    fields = [(k, _annotation(module, v), _default(module, v)) for k, v in props.items()]
    lines = ["@dataclass(frozen=True, kw_only=True)", f"class {name}({base}):"]
    lines += _docstring(schema, props)
    if native:
        lines.append(f'    _native: ClassVar[str] = "{native}"')
    if tag:
        lines.append(f'    _tag: ClassVar[str] = "{tag}"')
    for key, annotation, default in fields:
        lines.append(_field(_identifier(key), annotation, default))
    module.blocks.append("\n".join(lines))
    overrides = [
        f"class {name}Overrides(TypedDict, total=False):",
        f'    """The fields of :class:`{name}`, for keyword arguments."""',
        "",
    ]
    overrides += [f"    {_identifier(k)}: {a}" for k, a, _ in fields]
    module.blocks.append("\n".join(overrides))
    module.names += [name, f"{name}Overrides"]


def _docstring(schema: dict[str, Any], props: dict[str, Any]) -> list[str]:
    """The class docstring: the struct's doc comment, then each field's (Google style,
    as the API reference renders it)."""
    text = [_wrap(schema.get("description", "").strip() or "A part of a config.")]
    if props:
        fields = ["Attributes:"]
        for key, prop in props.items():
            doc = " ".join((prop.get("description") or "(no description)").split())
            fields.append(
                textwrap.fill(
                    f"{key}: {doc}", 88, initial_indent="    ", subsequent_indent="        "
                )
            )
        text.append("\n".join(fields))
    body = "\n\n".join(text).replace("\\", "\\\\").replace('"""', "'''")
    return [textwrap.indent(f'"""{body}\n"""', "    ", lambda line: bool(line.strip())), ""]


def _wrap(text: str, width: int = 88) -> str:
    paragraphs = [" ".join(p.split()) for p in text.split("\n\n")]
    return "\n\n".join(textwrap.fill(p, width) for p in paragraphs)


def _identifier(key: str) -> str:
    if not key.isidentifier() or keyword.iskeyword(key):
        raise ValueError(f"config field {key!r} is not a Python identifier")
    return key


def _annotation(module: Module, schema: dict[str, Any]) -> str:
    if "anyOf" in schema:  # Option<T> of a named type
        parts = [_annotation(module, s) for s in schema["anyOf"]]
        return " | ".join(parts)
    if "$ref" in schema:
        return _named(module, *module.resolve(schema))
    kinds = schema.get("type")
    if isinstance(kinds, list):
        return " | ".join(_annotation(module, {**schema, "type": k}) for k in kinds)
    if kinds == "null":
        return "None"
    if "enum" in schema:
        return "Literal[" + ", ".join(json.dumps(v) for v in schema["enum"]) + "]"
    if "oneOf" in schema:  # a plain enum whose variants have doc comments
        return "Literal[" + ", ".join(json.dumps(v["const"]) for v in schema["oneOf"]) + "]"
    if kinds == "array":
        return _array(module, schema)
    simple = {"number": "float", "integer": "int", "boolean": "bool", "string": "str"}
    if kinds in simple:
        return simple[kinds]
    raise ValueError(f"no Python type for schema {schema}")


def _array(module: Module, schema: dict[str, Any]) -> str:
    if "prefixItems" in schema:
        return "tuple[" + ", ".join(_annotation(module, s) for s in schema["prefixItems"]) + "]"
    item = _annotation(module, schema["items"])
    n = schema.get("minItems")
    if n is not None and n == schema.get("maxItems"):
        return "tuple[" + ", ".join([item] * n) + "]"
    return f"tuple[{item}, ...]"


def _named(module: Module, name: str, schema: dict[str, Any]) -> str:
    """A named type: a string enum becomes its Literal, a struct its class, a tagged
    union (serde's externally tagged enum) a base class with one class per variant."""
    if not _is_union(schema) and schema.get("type") != "object":  # a Literal, tuple, number
        return _annotation(module, {k: v for k, v in schema.items() if k != "description"})
    if _is_union(schema):
        _union(module, name, schema)
        return name
    _struct(module, name, schema)
    return name


def _is_union(schema: dict[str, Any]) -> bool:
    """serde's externally tagged enum (variants with fields); an enum of plain variants
    with doc comments is a ``oneOf`` of string constants, a Literal."""
    variants = schema.get("oneOf", [])
    return bool(variants) and not all("const" in v for v in variants)


def _union(module: Module, name: str, schema: dict[str, Any]) -> None:
    if name in module.done:
        return
    module.done.add(name)
    doc = _wrap(schema.get("description", "").strip() or "One of its subclasses.")
    module.blocks.append(
        f"@dataclass(frozen=True, kw_only=True)\nclass {name}(Config):\n"
        + textwrap.indent(f'"""{doc}"""', "    ")
        + "\n\n    _union: ClassVar[bool] = True"
    )
    module.names.append(name)
    for variant in schema["oneOf"]:
        [(tag, body)] = variant["properties"].items()
        vname, vschema = module.resolve(body)
        described = {
            **vschema,
            "description": variant.get("description", "") or vschema.get("description", ""),
        }
        _struct(module, vname, described, base=name, tag=tag)


#: ruff's line length: the module is written as ruff formats it.
WIDTH = 100


@dataclass
class Call:
    """A constructor call ``name(key=value, ...)`` of a default."""

    name: str
    args: list[tuple[str, str | Call]]

    def flat(self) -> str:
        inner = ", ".join(f"{k}={v.flat() if isinstance(v, Call) else v}" for k, v in self.args)
        return f"{self.name}({inner})"

    def text(self, column: int, indent: int, tail: int) -> str:
        """The call from ``column`` of a line indented ``indent`` and followed by
        ``tail`` characters: on that line when it fits, else one argument a line with
        a trailing comma, as ruff writes it."""
        flat = self.flat()
        if column + len(flat) + tail <= WIDTH or not self.args:
            return flat
        pad = " " * (indent + 4)
        rows = []
        for key, value in self.args:
            head = f"{pad}{key}="
            body = value.text(len(head), indent + 4, 1) if isinstance(value, Call) else value
            rows.append(f"{head}{body},")
        return f"{self.name}(\n" + "\n".join(rows) + f"\n{' ' * indent})"


def _field(key: str, annotation: str, default: str | Call) -> str:
    """One field's line (or lines): ``key: annotation = default``."""
    lead = f"    {key}: {annotation} = "
    if not isinstance(default, Call):
        return lead + default
    if not default.args:  # the part's own defaults
        return f"{lead}field(default_factory={default.name})"
    line = f"{lead}field(default_factory=lambda: {default.flat()})"
    if len(line) <= WIDTH:
        return line
    head = "        default_factory=lambda: "
    return f"{lead}field(\n{head}{default.text(len(head), 8, 0)}\n    )"


def _default(module: Module, schema: dict[str, Any]) -> str | Call:
    value = schema.get("default")
    if schema.get("type") == "number" and isinstance(value, str):
        value = float(value)  # "inf": JSON has no infinity
    ref_name, ref = module.resolve(schema) if "$ref" in schema else ("", {})
    if isinstance(value, dict):
        return _value(module, ref_name, ref, value)
    return _literal(value)


def _value(module: Module, name: str, schema: dict[str, Any], value: dict[str, Any]) -> Call:
    """The constructor call that builds ``value`` (a dict) as the class ``name``."""
    if _is_union(schema):
        [(tag, body)] = value.items()
        for variant in schema["oneOf"]:
            if tag in variant["properties"]:
                return _value(module, *module.resolve(variant["properties"][tag]), body)
    args: list[tuple[str, str | Call]] = []
    for key, v in value.items():
        prop = schema["properties"][key]
        if v == prop.get("default"):  # only what differs from the part's default
            continue
        if isinstance(v, dict):
            args.append((key, _value(module, *module.resolve(prop), v)))
        else:
            args.append((key, _literal(v)))
    return Call(name, args)


def _literal(value: object) -> str:
    if isinstance(value, float) and value in (float("inf"), float("-inf")):
        return f'float("{value}")'
    if isinstance(value, list):
        inner = ", ".join(_literal(v) for v in value)
        return f"({inner},)" if len(value) == 1 else f"({inner})"
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, float) and value != value:
        raise ValueError("a NaN default cannot be written")
    return repr(value)


def main() -> None:
    target = write_text_atomically(Path(__file__).with_name("config.py"), generate())
    print(f"wrote {target}")


if __name__ == "__main__":
    main()
