"""Typed configs to plain data and back: a run stores its whole resolved configuration and is rebuilt from it.

``to_data`` turns nested dataclasses into JSON-able dicts (tuples become lists, paths strings, slices
[start, stop], tensors and arrays lists); ``from_data``
rebuilds the dataclass from such a dict, field by field from the type hints, so a stored run never depends on
today's defaults. Unknown keys are an error that names them (a config written by another version of the code),
except the ones a dataclass lists in its ``RETIRED_FIELDS`` (fields it no longer has, still in stored runs).
"""

from __future__ import annotations

import dataclasses
import math
import types
import typing
from pathlib import Path


def to_data(x):
    if dataclasses.is_dataclass(x) and not isinstance(x, type):
        return {f.name: to_data(getattr(x, f.name)) for f in dataclasses.fields(x)}
    if isinstance(x, dict):
        return {str(k): to_data(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [to_data(v) for v in x]
    if isinstance(x, Path):
        return str(x)
    if isinstance(x, slice):
        return [x.start, x.stop]
    if hasattr(x, "tolist"):  # torch tensors, numpy arrays and scalars
        return x.tolist()
    return x


def _scalar(tp, value, where: str):
    ok = {bool: isinstance(value, bool), int: isinstance(value, int) and not isinstance(value, bool),
          float: isinstance(value, (int, float)) and not isinstance(value, bool), str: isinstance(value, str)}[tp]
    if not ok or (tp is float and not math.isfinite(value)):
        raise ValueError(f"{where} must be a {'finite ' if tp is float else ''}{tp.__name__}, got {value!r}")
    return float(value) if tp is float else value


def _build(tp, value, where: str):
    origin = typing.get_origin(tp)
    optional = origin in (typing.Union, types.UnionType) and type(None) in typing.get_args(tp)
    if value is None:
        if optional:
            return None
        raise ValueError(f"{where} must not be null")
    if tp in (bool, int, float, str):
        return _scalar(tp, value, where)
    if origin is typing.Literal:
        if value not in typing.get_args(tp):
            raise ValueError(f"{where} must be one of {typing.get_args(tp)}, got {value!r}")
        return value
    if origin in (typing.Union, types.UnionType):
        options = [a for a in typing.get_args(tp) if a is not type(None)]
        dcs = [a for a in options if dataclasses.is_dataclass(a)]
        if dcs and isinstance(value, dict):
            return from_data(dcs[0], value, where)
        return _build(options[0], value, where) if len(options) == 1 else value
    if dataclasses.is_dataclass(tp):
        return from_data(tp, value, where)
    if origin is tuple:
        args = typing.get_args(tp)
        if not isinstance(value, (list, tuple)):
            raise ValueError(f"{where} must be a list, got {value!r}")
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_build(args[0], v, where) for v in value)
        if args and len(args) != len(value):
            raise ValueError(f"{where} must have {len(args)} entries, got {len(value)}")
        return tuple(_build(a, v, where) for a, v in zip(args, value)) if args else tuple(value)
    if origin is dict:
        if not isinstance(value, dict):
            raise ValueError(f"{where} must be a mapping, got {value!r}")
        key_t, val_t = typing.get_args(tp) or (str, object)
        return {k: _build(val_t, v, f"{where}.{k}") if val_t is not object else v for k, v in value.items()}
    if origin is list:
        return list(value)
    if tp is Path:
        return Path(value)
    return value


def with_overrides(cfg, overrides: dict[str, object]):
    """A copy of dataclass ``cfg`` with dotted-path values replaced, e.g. {"rewards.weights.contact_momentum": -1e-4,
    "obs.noise": False}; ValueError naming a path that does not exist."""
    data = to_data(cfg)
    for path, value in overrides.items():
        node, keys = data, path.split(".")
        for k in keys[:-1]:
            if not isinstance(node, dict) or k not in node:
                raise ValueError(f"{path}: no {k!r} in {type(cfg).__name__}")
            node = node[k]
        if not isinstance(node, dict) or keys[-1] not in node:
            raise ValueError(f"{path}: no {keys[-1]!r} in {type(cfg).__name__}")
        node[keys[-1]] = to_data(value)
    return from_data(type(cfg), data)


def from_data(cls, data: dict, where: str = ""):
    """``cls`` (a dataclass) from ``to_data``'s output; ValueError naming any key ``cls`` does not have."""
    name = where or cls.__name__
    if not isinstance(data, dict):
        raise ValueError(f"{name}: expected a mapping, got {type(data).__name__}")
    fields = {f.name: f for f in dataclasses.fields(cls)}
    retired = getattr(cls, "RETIRED_FIELDS", ())
    data = {k: v for k, v in data.items() if k not in retired}
    unknown = sorted(set(data) - set(fields))
    if unknown:
        raise ValueError(f"{name} has no field(s) {unknown} (a config from another version of the code?)")
    hints = typing.get_type_hints(cls)
    kwargs = {k: _build(hints[k], v, f"{name}.{k}") for k, v in data.items() if fields[k].init}
    return cls(**kwargs)


def flatten(data: dict, prefix: str = "") -> dict:
    """{"a": {"b": 1}} -> {"a.b": 1}: nested config data (``to_data``'s) as dotted paths, empty dicts kept as leaves."""
    out = {}
    for k, v in data.items():
        if isinstance(v, dict) and v:
            out |= flatten(v, f"{prefix}{k}.")
        else:
            out[f"{prefix}{k}"] = v
    return out
