"""The generic TOML loader for dataclass configurations.

A configuration is a tree of dataclasses with the defaults in one place (each package declares
its section in its own ``config.py``; Main gathers them). :func:`apply_overrides` and
:func:`load_overrides` check a TOML table against that tree and stop with ONE line (a
:class:`ConfigError`) naming the file, the key and what was expected when a section or key is
unknown, a value has the wrong type or the file is missing or unreadable.
"""

from __future__ import annotations

import dataclasses
import enum
import math
import tomllib
import types
import typing
from pathlib import Path
from typing import Any, TypeVar

import tomli_w

from common.errors import ConfigError

T = TypeVar("T")


def _type_name(tp: Any) -> str:
    origin = typing.get_origin(tp)
    if origin is typing.Literal:
        return " or ".join(repr(a) for a in typing.get_args(tp))
    if origin in (types.UnionType, typing.Union):
        return " or ".join(_type_name(a) for a in typing.get_args(tp))
    if origin in (list, tuple):
        args = [a for a in typing.get_args(tp) if a is not Ellipsis]
        return f"a list of {_type_name(args[0]) if args else 'values'}"
    if isinstance(tp, type) and issubclass(tp, enum.Enum):
        return " or ".join(repr(m.name.lower()) for m in tp)
    if tp is type(None):
        return "nothing"
    return getattr(tp, "__name__", str(tp))


def _convert(value: Any, tp: Any, where: str) -> Any:
    """Check ``value`` against the annotation ``tp`` and convert it; raise ``_Mismatch``."""
    origin = typing.get_origin(tp)
    if origin is typing.Literal:
        if value in typing.get_args(tp):
            return value
        raise _Mismatch(where, tp, value)
    if origin in (types.UnionType, typing.Union):
        for arg in typing.get_args(tp):
            try:
                return _convert(value, arg, where)
            except _Mismatch:
                continue
        raise _Mismatch(where, tp, value)
    if origin in (list, tuple):
        if not isinstance(value, list):
            raise _Mismatch(where, tp, value)
        args = [a for a in typing.get_args(tp) if a is not Ellipsis]
        item_tp = args[0] if args else Any
        items = [_convert(v, item_tp, f"{where}[{i}]") for i, v in enumerate(value)]
        return tuple(items) if origin is tuple else items
    if tp is Any:
        return value
    if tp is type(None):
        if value is None:
            return None
        raise _Mismatch(where, tp, value)
    if tp is bool:
        if isinstance(value, bool):
            return value
        raise _Mismatch(where, tp, value)
    if tp is float:
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return float(value)
        if isinstance(value, str) and value.lower() in ("inf", "-inf", "nan"):
            return float(value)
        raise _Mismatch(where, tp, value)
    if tp is int:
        if isinstance(value, int) and not isinstance(value, bool):
            return value
        raise _Mismatch(where, tp, value)
    if tp is str:
        if isinstance(value, str):
            return value
        raise _Mismatch(where, tp, value)
    if isinstance(tp, type) and issubclass(tp, enum.Enum):
        if isinstance(value, str) and value.upper() in tp.__members__:
            return tp[value.upper()]
        raise _Mismatch(where, tp, value)
    raise _Mismatch(where, tp, value)


class _Mismatch(Exception):
    def __init__(self, where: str, tp: Any, value: Any) -> None:
        super().__init__(f"key '{where}' expects {_type_name(tp)}, got {value!r}")


def _apply(obj: Any, overrides: dict[str, Any], prefix: str, source: str) -> None:
    """Apply a TOML table onto a dataclass instance in place, checking every key."""
    hints = typing.get_type_hints(type(obj))
    names = {f.name for f in dataclasses.fields(obj)}
    for key, value in overrides.items():
        where = f"{prefix}{key}"
        if key not in names:
            kind = "section" if isinstance(value, dict) else "key"
            known = ", ".join(sorted(names))
            shown = f"[{where}]" if kind == "section" else f"'{where}'"
            raise ConfigError(f"{source}: unknown {kind} {shown} (expected one of: {known})")
        current = getattr(obj, key)
        if dataclasses.is_dataclass(current):
            if not isinstance(value, dict):
                raise ConfigError(f"{source}: '{where}' is a section [{where}], got {value!r}")
            _apply(current, value, f"{where}.", source)
            continue
        if isinstance(value, dict):
            raise ConfigError(
                f"{source}: '{where}' expects {_type_name(hints[key])}, got a section"
            )
        try:
            setattr(obj, key, _convert(value, hints[key], where))
        except _Mismatch as exc:
            raise ConfigError(f"{source}: {exc}") from None


def read_toml(path: Path) -> dict[str, Any]:
    """A TOML file as nested dicts; :class:`ConfigError` when it is missing or unreadable."""
    try:
        with path.open("rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise ConfigError(f"{path}: config file not found") from None
    except IsADirectoryError:
        raise ConfigError(f"{path}: is a directory, expected a TOML config file") from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: not valid TOML ({exc})") from None
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read ({exc.strerror})") from None


def apply_overrides(config: T, overrides: dict[str, Any], source: str = "<overrides>") -> T:
    """Apply a nested dict (as a TOML file would give) onto ``config`` in place; return it."""
    _apply(config, overrides, "", source)
    return config


def load_overrides(config: T, *paths: str | Path | None) -> T:
    """Apply each TOML file in turn onto ``config`` in place (``None`` entries are skipped)."""
    for p in paths:
        if p is None:
            continue
        path = Path(p)
        apply_overrides(config, read_toml(path), str(path))
    return config


def _to_plain(value: Any) -> Any:
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: _to_plain(getattr(value, f.name)) for f in dataclasses.fields(value)
                if getattr(value, f.name) is not None}
    if isinstance(value, enum.Enum):
        return value.name.lower()
    if isinstance(value, (list, tuple)):
        return [_to_plain(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    return value


def config_to_dict(config: Any) -> dict[str, Any]:
    """A dataclass tree as plain dicts and lists (TOML-ready; ``None`` fields left out)."""
    plain = _to_plain(config)
    assert isinstance(plain, dict)
    return plain


def config_to_toml(config: Any) -> str:
    """The merged configuration as TOML text (what ``main.py config --print`` shows)."""
    return tomli_w.dumps(config_to_dict(config))
