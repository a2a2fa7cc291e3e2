"""Build frozen config dataclasses from TOML tables, generically and strictly.

Every package declares its own config dataclasses (fields of simple types, validated in
``__post_init__``). This module turns a TOML table into one of them: unknown keys are rejected,
types are checked, relative paths are resolved against the config file's folder, and every error
names the file, the key and what was expected.
"""

from __future__ import annotations

import dataclasses
import math
import types
import typing
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal, TypeVar, get_args, get_origin, get_type_hints

from sensors.untrusted import one_line, shorten

T = TypeVar("T")


class ConfigError(ValueError):
    """A config that cannot be used. The message is one line: ``file: key: what was expected``."""


def _describe(value: object) -> str:
    if isinstance(value, str):
        return shorten(value)
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, list):
        return "a list"
    return f"{shorten(value)} ({type(value).__name__})"


def _type_name(tp: Any) -> str:
    origin = get_origin(tp)
    if tp is float:
        return "a number"
    if tp is int:
        return "a whole number"
    if tp is bool:
        return "true or false"
    if tp is str:
        return "a string"
    if tp is Path:
        return "a path (string)"
    if origin is Literal:
        return "one of " + ", ".join(repr(a) for a in get_args(tp))
    if origin is tuple:
        args = get_args(tp)
        inner = _type_name(args[0]) if args else "values"
        return f"a list of {inner.removeprefix('a ').removeprefix('an ')}s" if args else "a list"
    if origin in (typing.Union, types.UnionType):
        return " or ".join(_type_name(a) for a in get_args(tp) if a is not type(None))
    if dataclasses.is_dataclass(tp):
        return "a table"
    return str(tp)


class _Bad(Exception):
    pass


def _convert(value: Any, tp: Any, base_dir: Path) -> Any:
    origin = get_origin(tp)
    if tp is Any:
        return value
    if origin in (typing.Union, types.UnionType):
        args = get_args(tp)
        for arg in args:
            if arg is type(None):
                continue
            try:
                return _convert(value, arg, base_dir)
            except _Bad:
                continue
        raise _Bad
    if origin is Literal:
        if value in get_args(tp) and type(value) is type(get_args(tp)[0]):
            return value
        raise _Bad
    if tp is bool:
        if isinstance(value, bool):
            return value
        raise _Bad
    if tp is int:
        if isinstance(value, int) and not isinstance(value, bool):
            return value
        raise _Bad
    if tp is float:  # finite only: a nan or inf in a config hangs or breaks whatever reads it
        if isinstance(value, int | float) and not isinstance(value, bool):
            try:
                number = float(value)
            except OverflowError:  # an integer beyond 1e308
                raise _Bad from None
            if math.isfinite(number):
                return number
        raise _Bad
    if tp is str:
        if isinstance(value, str):
            return value
        raise _Bad
    if tp is Path:
        if isinstance(value, str) and value and "\0" not in value:
            try:
                p = Path(value).expanduser()
            except RuntimeError:  # "~someone" with no such user
                raise _Bad from None
            return p if p.is_absolute() else (base_dir / p)
        raise _Bad
    if origin is tuple:
        if not isinstance(value, list | tuple):
            raise _Bad
        args = get_args(tp)
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_convert(v, args[0], base_dir) for v in value)
        if len(args) != len(value):
            raise _Bad
        return tuple(_convert(v, a, base_dir) for v, a in zip(value, args, strict=True))
    if dataclasses.is_dataclass(tp):
        raise _Bad  # nested tables are handled by build()
    raise _Bad


def build(cls: type[T], table: Mapping[str, Any], *, source: str, key: str, base_dir: Path) -> T:
    """Make ``cls`` from ``table``; errors read ``source: key.field: ...``."""
    if not isinstance(table, Mapping):
        raise ConfigError(f"{source}: {key}: expected a table, got {_describe(table)}")
    if not dataclasses.is_dataclass(cls):
        raise TypeError(f"{cls!r} is not a dataclass")
    hints = get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    prefix = f"{key}." if key else ""
    unknown = [k for k in table if k not in fields]
    if unknown:
        raise ConfigError(
            f"{source}: {prefix}{unknown[0]}: unknown key; expected one of: {', '.join(sorted(fields))}"
        )
    kwargs: dict[str, Any] = {}
    for name, f in fields.items():
        if name not in table:
            if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
                raise ConfigError(f"{source}: {prefix}{name}: missing; expected {_type_name(hints[name])}")
            continue
        tp = hints[name]
        value = table[name]
        nested = _nested_dataclass(tp)
        if nested is not None and isinstance(value, Mapping):
            kwargs[name] = build(nested, value, source=source, key=f"{prefix}{name}", base_dir=base_dir)
            continue
        try:
            kwargs[name] = _convert(value, tp, base_dir)
        except _Bad:
            expected = _type_name(tp)
            if isinstance(value, float) and not math.isfinite(value):
                expected = expected.replace("a number", "a finite number")
            raise ConfigError(
                f"{source}: {prefix}{name}: expected {expected}, got {_describe(value)}"
            ) from None
    try:
        return cls(**kwargs)
    except ValueError as e:  # the dataclass's own checks (an UntrustedInput from finite/whole among them)
        raise ConfigError(one_line(f"{source}: {prefix}{e}", 1000)) from None


def _nested_dataclass(tp: Any) -> type | None:
    if dataclasses.is_dataclass(tp) and isinstance(tp, type):
        return tp
    if get_origin(tp) in (typing.Union, types.UnionType):
        for arg in get_args(tp):
            if dataclasses.is_dataclass(arg) and isinstance(arg, type):
                return arg
    return None
