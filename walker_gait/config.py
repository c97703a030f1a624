"""Parameters: core config dataclasses <-> flat ROS parameters <-> ``config/walker_gait.yaml``.

The core's config dataclasses (``SegmenterConfig``, ``TrackerConfig``, ``GaitConfig``, ...) are the
single source of truth for parameter names, types and defaults.  Nested dataclasses flatten to
dotted names (``roi.forward``).  The live nodes declare exactly these parameters; the offline
pipeline builds the same configs from the same YAML file, so both run with identical settings.
"""

from __future__ import annotations

import dataclasses
import sys
import typing
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any, TypeVar

import yaml

T = TypeVar("T")

Scalar = bool | int | float | str


class ParameterError(ValueError):
    """A parameter name or value that does not fit its config."""


def _field_types(cls: type) -> dict[str, Any]:
    return typing.get_type_hints(cls)


def flatten(obj: Any, prefix: str = "") -> dict[str, Any]:
    """Flat ``{dotted_name: value}`` of a (nested) config dataclass instance; tuples become lists."""
    out: dict[str, Any] = {}
    for f in dataclasses.fields(obj):
        if not f.init:
            continue
        value = getattr(obj, f.name)
        name = prefix + f.name
        if dataclasses.is_dataclass(value):
            out.update(flatten(value, name + "."))
        elif isinstance(value, tuple):
            out[name] = list(value)
        else:
            out[name] = value
    return out


def describe(cls: type, prefix: str = "") -> Iterator[tuple[str, Any, str]]:
    """``(dotted_name, default, description)`` for every parameter of a config dataclass."""
    default_obj = cls()
    for f in dataclasses.fields(cls):
        if not f.init:
            continue
        value = getattr(default_obj, f.name)
        if dataclasses.is_dataclass(value):
            yield from describe(type(value), prefix + f.name + ".")
            continue
        doc = str(f.metadata.get("doc", "")) if f.metadata else ""
        if not doc:
            doc = _attribute_doc(cls, f.name)
        yield prefix + f.name, (list(value) if isinstance(value, tuple) else value), doc


def _attribute_doc(cls: type, name: str) -> str:
    """The field's trailing ``# comment`` or attribute docstring in the dataclass source, if any."""
    import inspect

    try:
        lines = inspect.getsource(cls).splitlines()
    except (OSError, TypeError):
        return ""
    quote = '"' * 3
    for i, line in enumerate(lines):
        stripped = line.strip()
        if not stripped.startswith(f"{name}:"):
            continue
        if "#" in stripped:
            return stripped.split("#", 1)[1].strip()
        nxt = lines[i + 1].strip() if i + 1 < len(lines) else ""
        if not nxt.startswith(quote):
            return ""
        parts: list[str] = []
        body, j = nxt[3:], i + 1
        while quote not in body and j + 1 < len(lines):
            parts.append(body)
            j += 1
            body = lines[j].strip()
        parts.append(body.split(quote, 1)[0])
        return " ".join(p.strip() for p in parts if p.strip())
    return ""


def _coerce(value: Any, target: Any, name: str) -> Any:
    origin = typing.get_origin(target)
    args = typing.get_args(target)
    if target is bool:
        if isinstance(value, str):
            if value.lower() in ("true", "1", "yes", "on"):
                return True
            if value.lower() in ("false", "0", "no", "off"):
                return False
            raise ParameterError(f"parameter {name!r}: expected a boolean, got {value!r}")
        return bool(value)
    if target is int:
        if isinstance(value, bool) or (isinstance(value, float) and not value.is_integer()):
            raise ParameterError(f"parameter {name!r}: expected an integer, got {value!r}")
        try:
            return int(value)
        except (TypeError, ValueError) as exc:
            raise ParameterError(f"parameter {name!r}: expected an integer, got {value!r}") from exc
    if target is float:
        try:
            return float(value)
        except (TypeError, ValueError) as exc:
            raise ParameterError(f"parameter {name!r}: expected a number, got {value!r}") from exc
    if target is str:
        return str(value)
    if origin is tuple or origin is list:
        if isinstance(value, str):
            value = yaml.safe_load(value)
        if not isinstance(value, (list, tuple)):
            raise ParameterError(f"parameter {name!r}: expected a list, got {value!r}")
        item_t = args[0] if args else Any
        items = [_coerce(v, item_t, name) if item_t is not Any else v for v in value]
        return tuple(items) if origin is tuple else items
    if origin in (typing.Union, getattr(__import__("types"), "UnionType", None)):
        non_none = [a for a in args if a is not type(None)]
        if value is None or (isinstance(value, str) and value.lower() in ("none", "null", "")):
            if type(None) in args:
                return None
        for cand in non_none:
            try:
                return _coerce(value, cand, name)
            except ParameterError:
                continue
        raise ParameterError(f"parameter {name!r}: cannot interpret {value!r} as {target}")
    if typing.get_origin(target) is typing.Literal:
        if value not in args:
            raise ParameterError(f"parameter {name!r}: must be one of {list(args)}, got {value!r}")
        return value
    return value


def build(cls: type[T], values: Mapping[str, Any], *, base: T | None = None, strict: bool = True) -> T:
    """Instantiate config ``cls`` from flat dotted ``values`` on top of ``base`` (or the defaults)."""
    base_obj = base if base is not None else cls()
    hints = _field_types(cls)
    kwargs: dict[str, Any] = {}
    consumed: set[str] = set()
    for f in dataclasses.fields(cls):
        if not f.init:
            continue
        current = getattr(base_obj, f.name)
        if dataclasses.is_dataclass(current):
            sub = {k[len(f.name) + 1 :]: v for k, v in values.items() if k.startswith(f.name + ".")}
            consumed.update(f.name + "." + k for k in sub)
            kwargs[f.name] = build(type(current), sub, base=current, strict=strict)
        elif f.name in values:
            kwargs[f.name] = _coerce(values[f.name], hints[f.name], f.name)
            consumed.add(f.name)
        else:
            kwargs[f.name] = current
    unknown = set(values) - consumed
    if strict and unknown:
        known = ", ".join(sorted(flatten(base_obj)))
        raise ParameterError(f"unknown parameter(s) {sorted(unknown)} for {cls.__name__}; known: {known}")
    try:
        return cls(**kwargs)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"invalid {cls.__name__}: {exc}") from exc


def default_params_file() -> Path:
    """``config/walker_gait.yaml`` of the source tree, else of the install prefix."""
    here = Path(__file__).resolve().parent.parent / "config" / "walker_gait.yaml"
    if here.is_file():
        return here
    return Path(sys.prefix) / "share" / "walker_gait" / "config" / "walker_gait.yaml"


def load_params_file(path: Path) -> dict[str, dict[str, Any]]:
    """``{node_name: {param: value}}`` from a ROS 2 parameters YAML (``node: ros__parameters: ...``)."""
    try:
        data = yaml.safe_load(Path(path).read_text(encoding="utf-8")) or {}
    except FileNotFoundError as exc:
        raise ParameterError(f"{path}: parameters file not found") from exc
    except yaml.YAMLError as exc:
        raise ParameterError(f"{path}: not valid YAML: {exc}") from exc
    if not isinstance(data, dict):
        raise ParameterError(f"{path}: expected a mapping of node names")
    out: dict[str, dict[str, Any]] = {}
    for node, body in data.items():
        node_name = str(node).strip("/").split("/")[-1]
        if node_name == "**":
            node_name = "*"
        params = (body or {}).get("ros__parameters", {}) if isinstance(body, dict) else {}
        out[node_name] = _flatten_mapping(params)
    return out


def _flatten_mapping(d: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in d.items():
        if isinstance(v, Mapping):
            out.update(_flatten_mapping(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = v
    return out


def parse_overrides(items: list[str]) -> dict[str, Any]:
    """``["leg_tracker.n_particles=300", ...]`` → ``{"leg_tracker.n_particles": 300}`` (YAML-typed values)."""
    out: dict[str, Any] = {}
    for item in items:
        if "=" not in item:
            raise ParameterError(f"--param expects KEY=VALUE, got {item!r}")
        key, raw = item.split("=", 1)
        out[key.strip()] = yaml.safe_load(raw) if raw.strip() else ""
    return out


STAGES = ("floor_segmentation", "leg_tracker", "leg_tracker_backward", "pass_scoring")
"""Stages with a random generator of their own; new ones go at the end (an index is part of the seed)."""


def stage_rng(seed: int, stage: str, *, run: int = 0) -> Any:
    """The random generator of one pipeline stage for a run seed.

    The live nodes (one process per stage) and the offline pipeline derive their generators the same
    way, so both see identical random streams for the same ``seed``.  ``run`` > 0: the stage's further, independent
    streams (offline, each direction tracked more than once: ``PipelineOptions.tracker_runs``); run 0 is the stage's
    own stream, the live one.
    """
    import numpy as np

    if run < 0:
        raise ValueError(f"run must be >= 0, got {run}")
    return np.random.default_rng([int(seed), STAGES.index(stage), *([int(run)] if run else [])])


def frame_rng(seed: int, index: int) -> Any:
    """The generator with which the offline two-way tracking scores the passes' estimates on its ``index``-th frame
    (``pass_scoring``): one per frame, so that passes scored in different processes draw alike."""
    import numpy as np

    return np.random.default_rng([int(seed), STAGES.index("pass_scoring"), int(index)])
