"""What every generated config class (:mod:`rperc.config`) shares: ``replace()``,
``to_dict()``/``from_dict()`` in the native layer's spelling, and one check at
construction, made by the Rust crate that owns the config (its serde reader and
``validate()``), so no rule is written twice."""

from __future__ import annotations

import dataclasses
import functools
import sys
import warnings
from collections.abc import Hashable, Mapping
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
    #: For a variant of a tagged union (a vehicle model): its tag, so that a field
    #: declared as the union is written ``{tag: {...}}``, as serde spells it.
    _tag: ClassVar[str] = ""
    #: True for the base class of a tagged union.
    _union: ClassVar[bool] = False

    def __post_init__(self) -> None:
        if self._native:
            _rperc.config_check(self._native, self.to_dict())

    def replace(self: C, **changes: Any) -> C:
        """A copy with ``changes`` (field names as keywords), checked again."""
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """The fields as plain Python values, nested parts as dicts (JSON-ready)."""
        return {
            f.name: _plain(getattr(self, f.name), _union_of(type(self), f))
            for f in dataclasses.fields(self)
        }

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
            k: _build(cls, known[k], v) if isinstance(v, Mapping) else _tuples(v)
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
    elif config is None or isinstance(config, Mapping):
        base = dict(config or {})
    else:
        raise TypeError(
            f"config must be a {cls.__name__}, a mapping of its fields or None, "
            f"got {type(config).__name__}"
        )
    return cls.from_dict({**base, **(overrides or {})})


def dotted_fields(config: Config) -> dict[str, object]:
    """Every leaf field of ``config`` by its dotted name (``icp.sigma``), as
    :meth:`Config.to_dict` spells it: the names a settings grid sets."""
    return _flatten(config.to_dict())


def with_dotted(config: C, settings: Mapping[str, object]) -> C:
    """``config`` with each setting of ``settings`` (dotted name: value) replaced, the
    other fields of its part kept, checked once, as :meth:`Config.from_dict` checks
    (an unknown name is a TypeError naming it)."""
    values = config.to_dict()
    for name, value in settings.items():
        *path, leaf = name.split(".")
        node = values
        for part in path:
            inner = node.setdefault(part, {})
            if not isinstance(inner, dict):
                raise ValueError(
                    f"{type(config).__name__}: {excerpt(part)} of {name} is not a part"
                )
            node = inner
        node[leaf] = value
    return type(config).from_dict(values)


def merged(config: C, nested: Mapping[str, object]) -> C:
    """``config`` with a nested mapping of changes on top (JSON as ``to_dict`` writes
    it, or a subset): a part's fields not named keep their values."""
    return with_dotted(config, _flatten(nested))


def _flatten(values: Mapping[str, object], prefix: str = "") -> dict[str, object]:
    out: dict[str, object] = {}
    for k, v in values.items():
        out |= _flatten(v, f"{prefix}{k}.") if isinstance(v, Mapping) else {prefix + str(k): v}
    return out


def as_config_moved(
    cls: type[C],
    config: C | Mapping[str, Any] | None,
    overrides: Mapping[str, object],
    moved: Mapping[str, tuple[str, str]],
    owner: str,
    *,
    stacklevel: int = 3,
) -> C:
    """:func:`as_config` for a constructor that took flat keywords for fields of its
    config's nested parts before it took the config: each keyword of ``moved`` sets
    field ``name`` of part ``part`` (``moved[keyword] = (part, name)``) of the config,
    the part's other fields kept, with a DeprecationWarning saying where it lives now.
    Called from the constructor: the warning points at the constructor's caller
    (``stacklevel`` 3; one more for each helper between the constructor and here)."""
    nested = {k: v for k, v in overrides.items() if k in moved}
    made = as_config(cls, config, {k: v for k, v in overrides.items() if k not in moved})
    if not nested:
        return made
    spelled = ", ".join(f"{k}= -> {'.'.join(moved[k])}" for k in nested)
    warnings.warn(
        f"{owner}: keywords of nested fields are deprecated ({spelled}); pass the part "
        f"(such as part=config.part.replace(...)) or config={cls.__name__}(...)",
        DeprecationWarning,
        stacklevel=stacklevel,
    )
    parts: dict[str, Config] = {}
    for key, value in nested.items():
        part, name = moved[key]
        current = parts.get(part, getattr(made, part))
        parts[part] = dataclasses.replace(current, **{name: _tuples(value)})
    return dataclasses.replace(made, **parts)


def native_config(
    cls: type[C], config: C | Mapping[str, Any] | None, overrides: Mapping[str, Any]
) -> dict[str, Any]:
    """``as_config(cls, config, overrides).to_dict()``, the dict the native layer reads,
    remembered for hashable inputs: on a hot path (one call per laser scan) a setting
    is checked once, not at every call (the check costs as much as a small scan)."""
    given = config if config is None or isinstance(config, Config) else tuple(config.items())
    changes = tuple(overrides.items())
    try:
        hash((given, changes))
    except TypeError:  # a list or dict among the values
        return as_config(cls, config, overrides).to_dict()
    return dict(_remembered(cast("Hashable", cls), given, changes))


@functools.lru_cache(maxsize=64)
def _remembered(cls: Hashable, given: object, overrides: tuple[Any, ...]) -> dict[str, Any]:
    config = dict(given) if isinstance(given, tuple) else given
    made: Config = as_config(cast("type[Config]", cls), cast("Any", config), dict(overrides))
    return made.to_dict()


def _union_of(owner: type[Config], f: dataclasses.Field[Any]) -> type[Config] | None:
    """The tagged union a field is declared as (serde's externally tagged enum, such as
    ``MotionModel``), or None. A variant's class (``Unicycle``) may also be a field's
    type on its own, untagged: the declaration decides, not the value."""
    declared = vars(sys.modules[owner.__module__]).get(str(f.type))
    # `_union` is read off the class itself: its variants inherit it.
    if isinstance(declared, type) and issubclass(declared, Config) and vars(declared).get("_union"):
        return declared
    return None


def _plain(value: object, union: type[Config] | None = None) -> object:
    if isinstance(value, Config):
        body = value.to_dict()
        return {value._tag: body} if union is not None else body
    if isinstance(value, tuple):
        return [_plain(v) for v in value]
    return value


def _tuples(value: object) -> object:
    """Lists become tuples: the config classes are frozen and hashable."""
    if isinstance(value, list):
        return tuple(_tuples(v) for v in value)
    return value


def _build(owner: type[Config], f: dataclasses.Field[Any], values: Mapping[str, object]) -> object:
    """A nested part from its dict: the field's default says which class it is; a
    tagged union's dict ``{tag: {...}}`` picks the variant by its tag."""
    union = _union_of(owner, f)
    if union is not None:
        variants = {c._tag: c for c in union.__subclasses__()}
        if len(values) == 1:
            [(tag, body)] = values.items()
            if tag in variants and isinstance(body, Mapping):
                return variants[str(tag)].from_dict(body)
        raise ValueError(
            f"{owner.__name__}: {f.name}: expected one of "
            + ", ".join(f"{{{t!r}: {{...}}}}" for t in variants)
        )
    default = f.default_factory() if callable(f.default_factory) else None
    if isinstance(default, Config):
        return type(default).from_dict(values)
    return dict(values)
