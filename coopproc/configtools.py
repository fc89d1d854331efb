"""Turn TOML tables into frozen parameter dataclasses, with errors that help.

Every stage keeps its parameters in a frozen dataclass whose fields carry a default and a
one-line help in ``field(metadata={"help": ...})``. :func:`from_table` builds one from a
TOML table: an unknown key is an error naming the nearest valid key, a value of the wrong
type is an error naming the key, the type found and the type expected.
"""

from __future__ import annotations

import dataclasses
import difflib
import types
import typing
from collections.abc import Mapping
from typing import Any, TypeVar

from coopproc.errors import ConfigError

__all__ = ["check_keys", "describe", "from_table", "help_of", "nearest", "to_table"]

T = TypeVar("T")


def nearest(key: str, valid: typing.Iterable[str]) -> str:
    """`` (did you mean 'x'?)`` for the closest valid key, or ``valid keys: ...``."""
    options = sorted(valid)
    close = difflib.get_close_matches(key, options, n=1, cutoff=0.5)
    if close:
        return f" (did you mean '{close[0]}'?)"
    return f" (valid keys: {', '.join(options)})" if options else ""


def check_keys(table: Mapping[str, Any], valid: typing.Iterable[str], where: str) -> None:
    """Raise ConfigError for the first key of ``table`` not in ``valid``."""
    valid_set = set(valid)
    for key in table:
        if key not in valid_set:
            raise ConfigError(f"{where}: unknown key '{key}'{nearest(key, valid_set)}")


def help_of(cls: type, name: str) -> str:
    """The one-line help of field ``name`` of dataclass ``cls``."""
    for f in dataclasses.fields(cls):
        if f.name == name:
            return str(f.metadata.get("help", ""))
    raise KeyError(name)


def _type_name(tp: Any) -> str:
    return getattr(tp, "__name__", str(tp))


def _convert(value: Any, tp: Any, where: str) -> Any:
    origin = typing.get_origin(tp)
    args = typing.get_args(tp)
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        errors = []
        for arg in args:
            if arg is type(None):
                continue
            try:
                return _convert(value, arg, where)
            except ConfigError as err:
                errors.append(str(err))
        if len(errors) > 1:  # e.g. bool | Literal["auto"]: every accepted form named
            reasons = [e.removeprefix(f"{where}: ") for e in errors]
            raise ConfigError(f"{where}: {'; or '.join(reasons)}")
        raise ConfigError(errors[0] if errors else f"{where}: unexpected value {value!r}")
    if origin is typing.Literal:
        if value not in args:
            choices = " | ".join(repr(a) for a in args)
            raise ConfigError(f"{where}: {value!r} is not one of {choices}")
        return value
    if origin is tuple:
        if not isinstance(value, list | tuple):
            raise ConfigError(f"{where}: expected a list, found {type(value).__name__}")
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_convert(v, args[0], where) for v in value)
        if len(args) != len(value):
            raise ConfigError(f"{where}: expected {len(args)} values, found {len(value)}")
        return tuple(_convert(v, a, where) for v, a in zip(value, args, strict=True))
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ConfigError(f"{where}: expected a number, found {value!r}")
        return float(value)
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"{where}: expected an integer, found {value!r}")
        return value
    if tp is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"{where}: expected true or false, found {value!r}")
        return value
    if tp is str:
        if not isinstance(value, str):
            raise ConfigError(f"{where}: expected a string, found {value!r}")
        return value
    if dataclasses.is_dataclass(tp) and isinstance(tp, type):
        if not isinstance(value, Mapping):
            raise ConfigError(f"{where}: expected a table, found {value!r}")
        return from_table(tp, value, where)
    return value


def from_table(cls: type[T], table: Mapping[str, Any] | None, where: str) -> T:
    """Build dataclass ``cls`` from a TOML table; missing keys keep their defaults.

    ``where`` names the place for messages, e.g. ``"run.toml [ranging]"``.
    """
    if not dataclasses.is_dataclass(cls):
        raise TypeError(f"{cls!r} is not a dataclass")
    table = table or {}
    if not isinstance(table, Mapping):
        raise ConfigError(f"{where}: expected a table, found {table!r}")
    hints = typing.get_type_hints(cls)
    names = [f.name for f in dataclasses.fields(cls) if f.init]
    check_keys(table, names, where)
    kwargs = {key: _convert(value, hints[key], f"{where} {key}") for key, value in table.items()}
    try:
        return cls(**kwargs)
    except ValueError as err:  # __post_init__ range checks
        raise ConfigError(f"{where}: {err}") from err


def to_table(obj: Any) -> dict[str, Any]:
    """A dataclass instance as a plain dict (tuples as lists), for run.json and printing."""

    def plain(value: Any) -> Any:
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            return {f.name: plain(getattr(value, f.name)) for f in dataclasses.fields(value)}
        if isinstance(value, tuple | list):
            return [plain(v) for v in value]
        if isinstance(value, Mapping):
            return {str(k): plain(v) for k, v in value.items()}
        return value

    result = plain(obj)
    assert isinstance(result, dict)
    return result


def describe(cls: type) -> list[tuple[str, Any, str]]:
    """(name, default, help) of every field, for docs and ``coopproc config``."""
    rows = []
    for f in dataclasses.fields(cls):
        default: Any = f.default
        factory: Any = f.default_factory
        if default is dataclasses.MISSING and factory is not dataclasses.MISSING:
            default = factory()
        rows.append((f.name, default, str(f.metadata.get("help", ""))))
    return rows
