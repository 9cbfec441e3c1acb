"""What every generated config class (:mod:`rperc.config`) shares: ``replace()``,
``to_dict()``/``from_dict()`` in the native layer's spelling, and one check at
construction, made by the Rust crate that owns the config (its serde reader and
``validate()``), so no rule is written twice."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any, ClassVar, TypeVar, cast

from rperc import _rperc
from rperc._args import excerpt

C = TypeVar("C", bound="Config")


@dataclasses.dataclass(frozen=True, kw_only=True)
class Config:
    """Base of the frozen config classes generated from the Rust structs."""

    #: The name the native layer knows this config by; empty for nested parts, which
    #: are checked as part of the config that holds them.
    _native: ClassVar[str] = ""
    #: For a variant of a tagged union (a vehicle model): its tag, so that
    #: ``to_dict()`` writes ``{tag: {...}}`` as serde spells it.
    _tag: ClassVar[str] = ""

    def __post_init__(self) -> None:
        if self._native:
            _rperc.config_check(self._native, self.to_dict())

    def replace(self: C, **changes: Any) -> C:
        """A copy with ``changes`` (field names as keywords), checked again."""
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """The fields as plain Python values, nested parts as dicts (JSON-ready)."""
        return {f.name: _plain(getattr(self, f.name)) for f in dataclasses.fields(self)}

    @classmethod
    def from_dict(cls: type[C], values: Mapping[str, object]) -> C:
        """The config with the fields in ``values`` (a dict as :meth:`to_dict` writes
        it, or a subset); nested parts may be dicts. Unknown names are a TypeError."""
        known = {f.name: f for f in dataclasses.fields(cls)}
        unknown = sorted(set(values) - set(known), key=str)
        if unknown:
            if cls._native:  # the owning crate's message, as for any other bad field
                _rperc.config_check(cls._native, dict(values))
            raise TypeError(f"{cls.__name__}: unknown field {excerpt(unknown[0])}")
        built = {
            k: _build(known[k].default_factory, v) if isinstance(v, Mapping) else _tuples(v)
            for k, v in values.items()
        }
        return cls(**built)


def as_config(
    cls: type[C], config: C | Mapping[str, Any] | None, overrides: Mapping[str, Any] | None = None
) -> C:
    """``config`` (an instance of ``cls``, a dict of its fields, or ``None`` for the
    defaults) with ``overrides`` on top, as ``cls``: every function that takes a config
    takes both spellings, checked once, here."""
    if isinstance(config, Config):
        base = config.to_dict()
    else:
        base = dict(config or {})
    return cls.from_dict({**base, **(overrides or {})})


def _plain(value: object) -> object:
    if isinstance(value, Config):
        body = value.to_dict()
        return {value._tag: body} if value._tag else body
    if isinstance(value, tuple):
        return [_plain(v) for v in value]
    return value


def _tuples(value: object) -> object:
    """Lists become tuples: the config classes are frozen and hashable."""
    if isinstance(value, list):
        return tuple(_tuples(v) for v in value)
    return value


def _build(factory: object, values: Mapping[str, object]) -> object:
    """A nested part from its dict: the field's default says which class it is; a
    tagged union's dict ``{tag: {...}}`` picks the variant by its tag."""
    default = factory() if callable(factory) else None
    if not isinstance(default, Config):
        return dict(values)
    if default._tag:
        [(tag, body)] = values.items() if len(values) == 1 else [(None, None)]
        for variant in _variants(type(default)):
            if variant._tag == tag and isinstance(body, Mapping):
                return variant.from_dict(body)
        raise ValueError(f"expected one of {{{', '.join(_tags(type(default)))}: {{...}}}}")
    return type(default).from_dict(values)


def _variants(cls: type[Config]) -> list[type[Config]]:
    """The variants of the tagged union that ``cls`` (a variant) belongs to."""
    union = cast("type[Config]", cls.__mro__[1])
    return [c for c in union.__subclasses__() if c._tag]


def _tags(cls: type[Config]) -> list[str]:
    return [c._tag for c in _variants(cls)]
