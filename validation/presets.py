"""Controller presets (assets/presets.toml) and dotted overrides of settings dataclasses.

`resolve("switching", {"mode3.horizon": "10"})` gives the preset's class and its settings with the
file's and the caller's overrides applied; `build(resolved)` the controller. A name of the form
`package.module:Class` is a user's own controller (controller.protocol), resolved the same way.
"""

from __future__ import annotations

import dataclasses
import importlib
import os
import sys
import tomllib
import typing
from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path
from types import NoneType, UnionType
from typing import Any

from uvms.params import ASSETS

PRESETS = ASSETS / "presets.toml"
SCHEMA = "uvms-presets/1"


@dataclass(frozen=True)
class Preset:
    name: str
    description: str
    target: str  # "module:Class"
    overrides: dict[str, Any] = field(default_factory=dict)  # dotted key -> value


@dataclass(frozen=True)
class Resolved:
    """A controller ready to build: its name, class, settings (None: the class takes none) and the
    overrides that made them (the preset's, then the caller's)."""

    name: str
    cls: type
    settings: Any
    overrides: dict[str, Any]

    def settings_dict(self) -> dict | None:
        """The resolved settings as plain data (for manifests and summaries)."""
        return None if self.settings is None else _plain(dataclasses.asdict(self.settings))


def load(path: Path = PRESETS) -> dict[str, Preset]:
    """The presets of a file, validated (one-line errors naming the file and the field)."""
    try:
        data = tomllib.loads(path.read_text())
    except (OSError, tomllib.TOMLDecodeError) as e:
        raise ValueError(f"{path}: {e}; allowed: a TOML file with schema {SCHEMA!r}") from None
    if data.get("schema") != SCHEMA:
        raise ValueError(f"{path}: schema {data.get('schema')!r}; allowed: {SCHEMA!r}")
    out = {}
    for name, entry in data.get("presets", {}).items():
        unknown = set(entry) - {"description", "class", "set"}
        if unknown or "class" not in entry:
            raise ValueError(f"{path}: preset {name!r} has keys {sorted(entry)}; allowed: description, class, set")
        out[name] = Preset(name, entry.get("description", ""), entry["class"], dict(entry.get("set", {})))
    return out


def names() -> list[str]:
    return list(load())


def import_class(target: str) -> type:
    """`package.module:Class` imported."""
    module, sep, attr = target.partition(":")
    if not sep or not module or not attr:
        raise ValueError(f"controller {target!r}; allowed: a preset name ({', '.join(names())}) or "
                         "package.module:Class")
    if os.getcwd() not in sys.path:  # as `python -m` would: modules of the folder the command runs in
        sys.path.append(os.getcwd())
    try:
        cls = getattr(importlib.import_module(module), attr)
    except (ImportError, AttributeError) as e:
        raise ValueError(f"controller {target!r} cannot be imported ({e}); allowed: a preset name "
                         f"({', '.join(names())}) or an importable package.module:Class") from None
    if not (callable(getattr(cls, "reset", None)) and callable(getattr(cls, "step", None))):
        raise ValueError(f"controller {target!r} has no reset(task) and step(h, t); allowed: a class speaking "
                         "controller.protocol")
    return cls


def resolve(name: str, overrides: dict[str, Any] | None = None) -> Resolved:
    """The preset `name` (or a `package.module:Class`) with its overrides and then `overrides`."""
    presets = load()
    if name in presets:
        preset = presets[name]
    elif ":" in name:
        preset = Preset(name, "", name)
    else:
        raise ValueError(f"unknown controller {name!r}; allowed: {', '.join(presets)} or package.module:Class")
    cls = import_class(preset.target)
    merged = {**preset.overrides, **(overrides or {})}
    kind = getattr(cls, "settings_type", None)
    if kind is None:
        if merged:
            raise ValueError(f"controller {name!r} takes no settings; allowed: no --ctl overrides")
        return Resolved(name, cls, None, merged)
    return Resolved(name, cls, apply(kind(), merged), merged)


def of_object(controller: Any) -> Resolved:
    """A controller object given as it is: its class's name, and its `settings` when a dataclass."""
    settings = getattr(controller, "settings", None)
    cls = type(controller)
    return Resolved(f"{cls.__module__}:{cls.__qualname__}", cls,
                    settings if dataclasses.is_dataclass(settings) else None, {})


def build(resolved: Resolved) -> Any:
    return resolved.cls() if resolved.settings is None else resolved.cls(resolved.settings)


def apply(settings: Any, overrides: dict[str, Any]) -> Any:
    """A copy of a frozen dataclass with dotted overrides (`mode3.horizon`: 10 or "10"). Values are
    converted to the field's type: numbers, booleans, "none" for an optional field, tuples from
    lists or comma-separated text, Enums by value or name."""
    for key, value in overrides.items():
        settings = _set(settings, key.split("."), value, key)
    return settings


def _fields(obj: Any) -> dict[str, tuple[dataclasses.Field, Any]]:
    hints = typing.get_type_hints(type(obj))
    return {f.name: (f, hints[f.name]) for f in dataclasses.fields(obj)}


def _allowed(obj: Any, prefix: str) -> str:
    keys = []
    for name, (_, _) in _fields(obj).items():
        value = getattr(obj, name)
        keys += ([f"{prefix}{name}.*"] if dataclasses.is_dataclass(value) else [f"{prefix}{name}"])
    return ", ".join(keys)


def _set(obj: Any, path: list[str], value: Any, key: str) -> Any:
    prefix = key[: len(key) - len(".".join(path))]
    known = _fields(obj)
    if path[0] not in known:
        raise ValueError(f"unknown setting {key!r}; allowed: {_allowed(obj, prefix)}")
    _, hint = known[path[0]]
    current = getattr(obj, path[0])
    if dataclasses.is_dataclass(current):
        if len(path) == 1:
            raise ValueError(f"setting {key!r} is a group; allowed: {_allowed(current, prefix + path[0] + '.')}")
        return dataclasses.replace(obj, **{path[0]: _set(current, path[1:], value, key)})
    if len(path) > 1:
        raise ValueError(f"unknown setting {key!r}; allowed: {_allowed(obj, prefix)}")
    try:
        converted = _convert(value, hint)
        return dataclasses.replace(obj, **{path[0]: converted})
    except (TypeError, ValueError) as e:
        raise ValueError(f"setting {key}={value!r} is malformed ({e}); allowed: a value like {current!r}") from None


def _convert(value: Any, hint: Any) -> Any:
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin in (UnionType, typing.Union):
        if NoneType in args and (value is None or (isinstance(value, str) and value.strip().lower() == "none")):
            return None
        for arg in (a for a in args if a is not NoneType):
            return _convert(value, arg)
    if origin is tuple:
        items = [v for v in value.split(",") if v.strip()] if isinstance(value, str) else list(value)
        kind = args[0] if args else float
        return tuple(_convert(v, kind) for v in items)
    if isinstance(hint, type) and issubclass(hint, Enum):
        if isinstance(value, hint):
            return value
        text = str(value)
        for member in hint:
            if text in (member.value, member.name):
                return member
        raise ValueError(f"allowed: {', '.join(m.name for m in hint)}")
    if hint is bool:
        if isinstance(value, bool):
            return value
        text = str(value).strip().lower()
        if text not in ("true", "false"):
            raise ValueError("allowed: true or false")
        return text == "true"
    if hint is int:
        if isinstance(value, bool) or (isinstance(value, float) and not value.is_integer()):
            raise ValueError("allowed: an integer")
        return int(value)
    if hint is float:
        if isinstance(value, bool):
            raise ValueError("allowed: a number")
        return float(value)
    if hint is str:
        return str(value)
    if origin is dict or hint is dict:
        if not isinstance(value, dict):
            raise ValueError("allowed: a table of options")
        return dict(value)
    raise ValueError(f"fields of type {hint} cannot be set")


def _plain(value: Any) -> Any:
    """Enums to their values, tuples to lists, recursively (JSON-ready)."""
    if isinstance(value, Enum):
        return value.value
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value
