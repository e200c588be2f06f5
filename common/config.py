"""Configuration: typed dataclasses with the defaults in one place, overridden by TOML files.

Each Tier 2 package declares its own section in its ``config.py`` (a plain dataclass tree with
defaults); :class:`AppConfig` gathers them. :func:`load_config` reads an override file and stops
with ONE line (a :class:`ConfigError`) that names the file, the key and what was expected when a
section or key is unknown, a value has the wrong type or the file is missing or unreadable.
"""

from __future__ import annotations

import dataclasses
import enum
import math
import tomllib
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

import tomli_w

from common.errors import ConfigError
from controller.config import ControllerConfig
from mapper.config import MapperConfig
from orchestrator.config import RunConfig
from planner.config import PlannerConfig
from recordings.config import RecordingConfig
from sensors.config import SensorsConfig
from simulator.config import SimConfig
from visualiser.config import VisualiserConfig

PROJECT_ROOT = Path(__file__).resolve().parent.parent
CONFIG_DIR = PROJECT_ROOT / "config"


@dataclass(slots=True)
class CarConfig:
    """The car's geometry and limits (the default car of the issues; SI units)."""

    name: str = "default"
    wheelbase_m: float = 1.53
    track_width_m: float = 1.2
    length_m: float = 2.9
    width_m: float = 1.4
    rear_overhang_m: float = 0.65
    """Distance from the rear axle (the vehicle origin) back to the rear of the car."""
    cg_to_front_axle_m: float = 0.84
    mass_kg: float = 230.0
    yaw_inertia_kgm2: float = 120.0
    wheel_radius_m: float = 0.2286
    max_lateral_accel_mps2: float = 1.5 * 9.81
    max_drive_accel_mps2: float = 8.0
    max_brake_decel_mps2: float = 12.0
    max_steer_rad: float = 0.52
    """Road-wheel steering limit: 30 degrees turn the rear axle on 2.66 m, which takes the
    rules' tightest hairpin (9 m outer diameter) with the front corner 0.2 m inside it."""
    max_steer_rate_radps: float = 1.5
    steer_lag_s: float = 0.05
    top_speed_mps: float = 25.0
    lidar_x_m: float = 1.9
    """LiDAR position ahead of the vehicle origin (m): seed 000 mounts it low at the front."""
    lidar_z_m: float = 0.3
    imu_x_m: float = 0.7
    camera_x_m: float = 0.9
    camera_z_m: float = 1.0


@dataclass(slots=True)
class AppConfig:
    """Everything configurable, one section per manager."""

    car: CarConfig = field(default_factory=CarConfig)
    sensors: SensorsConfig = field(default_factory=SensorsConfig)
    mapper: MapperConfig = field(default_factory=MapperConfig)
    planner: PlannerConfig = field(default_factory=PlannerConfig)
    controller: ControllerConfig = field(default_factory=ControllerConfig)
    sim: SimConfig = field(default_factory=SimConfig)
    visualiser: VisualiserConfig = field(default_factory=VisualiserConfig)
    recording: RecordingConfig = field(default_factory=RecordingConfig)
    run: RunConfig = field(default_factory=RunConfig)


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


def _read_toml(path: Path) -> dict[str, Any]:
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


def load_config(*paths: str | Path | None) -> AppConfig:
    """The defaults, overridden by each given TOML file in turn (``None`` entries are skipped)."""
    config = AppConfig()
    for p in paths:
        if p is None:
            continue
        path = Path(p)
        apply_overrides(config, _read_toml(path), str(path))
    _validate(config)
    return config


def _validate(config: AppConfig) -> None:
    """Cross-field sanity checks that a type alone cannot express."""
    car = config.car
    for name in ("wheelbase_m", "length_m", "width_m", "max_lateral_accel_mps2",
                 "max_drive_accel_mps2", "max_brake_decel_mps2", "max_steer_rad", "top_speed_mps"):
        value = getattr(car, name)
        if not (math.isfinite(value) and value > 0.0):
            raise ConfigError(f"config: 'car.{name}' must be a positive number, got {value!r}")


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
