"""Output files of the offline ``walker-gait process`` command (issue 5), written atomically.

Files written into the output directory (schemas documented in ``docs/OUTPUTS.md``):

``steps.csv``
    One row per detected step, columns :data:`STEPS_COLUMNS`.
``events.csv``
    One row per heel strike / toe off, columns :data:`EVENTS_COLUMNS`.
``joints.csv``
    One row per processed frame (tracked leg pose), columns :data:`JOINTS_COLUMNS`.
``summary.json``
    The session gait summary with explicit unit-suffixed keys (:data:`SUMMARY_JSON_KEYS`,
    see :func:`summary_to_json`) plus a ``metadata`` object (:data:`METADATA_KEYS`).

CSV conventions (all three files)
---------------------------------
* UTF-8, comma separated, ``\\n`` line endings, exactly one header row.
* SI units: seconds, metres, radians; positions in the camera optical frame.
* A missing / unknown value (NaN) is written as an **empty field**; the readers turn empty
  fields back into NaN (they also accept ``nan``).  ``inf`` is written as ``inf``.
* Floats are written with a fixed number of decimals per kind of column
  (:data:`DECIMALS`): times 6 (1 µs), lengths and positions 5 (10 µm), durations 5 (10 µs),
  angles 6 (≈ 6e-5 °), confidences 4.  Reading a file back therefore reproduces the values
  to within half a unit of the last decimal written.
* Enumerations are written as lower-case labels: ``foot`` = ``left``/``right``,
  ``event`` = ``heel_strike``/``toe_off``, ``status`` = ``no_user``/``searching``/
  ``tracking``/``degraded``.

Every file is written through :func:`atomic_write`: a temporary file in the same directory
is written, flushed and fsync'ed and then renamed over the final name with :func:`os.replace`,
so after a crash or Ctrl-C the final name holds either the complete previous file or the
complete new one, never a truncated one.
"""

from __future__ import annotations

import contextlib
import csv
import json
import math
import os
import tempfile
import time
from collections.abc import Iterable, Iterator, Mapping, Sequence
from enum import Enum
from pathlib import Path
from typing import IO, Any, Literal

import numpy as np

from walker_gait import __version__
from walker_gait.core.types import (
    JOINT_NAMES,
    LEG_POINTS,
    EventKind,
    GaitEvent,
    LegPose,
    Side,
    Step,
    TrackStatus,
)

__all__ = [
    "DECIMALS",
    "EVENTS_COLUMNS",
    "EVENTS_CSV",
    "JOINTS_COLUMNS",
    "JOINTS_CSV",
    "METADATA_KEYS",
    "REPORT_HTML",
    "STEPS_COLUMNS",
    "STEPS_CSV",
    "SUMMARY_JSON",
    "SUMMARY_JSON_KEYS",
    "SUMMARY_SCHEMA",
    "OutputFormatError",
    "atomic_write",
    "build_metadata",
    "json_to_summary",
    "read_events_csv",
    "read_joints_csv",
    "read_steps_csv",
    "read_summary_json",
    "summary_to_json",
    "write_events_csv",
    "write_joints_csv",
    "write_steps_csv",
    "write_summary_json",
]

# --------------------------------------------------------------------------------------------
# File names and schemas
# --------------------------------------------------------------------------------------------

STEPS_CSV = "steps.csv"
EVENTS_CSV = "events.csv"
JOINTS_CSV = "joints.csv"
SUMMARY_JSON = "summary.json"
REPORT_HTML = "report.html"

STEPS_COLUMNS: tuple[str, ...] = (
    "time",  # s, heel-strike time (image header clock)
    "foot",  # left / right: the foot whose heel strike ends the step
    "step_length",  # m
    "step_width",  # m
    "step_time",  # s
    "stride_length",  # m
    "stride_time",  # s
    "stance_time",  # s
    "swing_time",  # s
    "single_support_time",  # s
    "double_support_time",  # s
    "step_index",  # 0-based step number in the session
    "confidence",  # 0..1
)
"""Columns of ``steps.csv``, in order."""

EVENTS_COLUMNS: tuple[str, ...] = ("time", "foot", "event", "x", "y", "z", "confidence")
"""Columns of ``events.csv``, in order (x, y, z: heel (HS) or toe (TO) position, camera frame, m)."""


def _joints_columns() -> tuple[str, ...]:
    cols = ["time"]
    for side in Side:
        for point in LEG_POINTS:
            cols.extend(f"{side.label}_{point}_{axis}" for axis in "xyz")
    cols.extend(JOINT_NAMES)
    cols.extend(("status", "confidence"))
    return tuple(cols)


JOINTS_COLUMNS: tuple[str, ...] = _joints_columns()
"""Columns of ``joints.csv``: ``time``, 30 point coordinates (left then right, LEG_POINTS order,
x/y/z, camera optical frame, m), the 12 joint angles (JOINT_NAMES, rad), ``status``, ``confidence``."""

DECIMALS: dict[str, int] = {
    "time": 6,
    "length": 5,
    "duration": 5,
    "angle": 6,
    "confidence": 4,
}
"""Decimals written per kind of CSV column (see the module docstring)."""

_STEP_KINDS: dict[str, str] = {
    "time": "time",
    "step_length": "length",
    "step_width": "length",
    "step_time": "duration",
    "stride_length": "length",
    "stride_time": "duration",
    "stance_time": "duration",
    "swing_time": "duration",
    "single_support_time": "duration",
    "double_support_time": "duration",
    "confidence": "confidence",
}

SUMMARY_SCHEMA = "walker_gait.summary/1"
"""Value of the ``schema`` key of ``summary.json``; bump on incompatible changes."""

_SIDE_SUFFIXES = ("left", "right")

# GaitSummary field -> (JSON key stem, unit suffix, per-side?).  Per-side fields (float32[2],
# [LEFT, RIGHT]) become two keys ``<stem>_left_<unit>`` and ``<stem>_right_<unit>``.
_SUMMARY_FIELDS: tuple[tuple[str, str, str, bool], ...] = (
    ("stamp", "stamp", "s", False),
    ("window_duration", "window_duration", "s", False),
    ("duration", "duration", "s", False),
    ("cadence", "cadence", "steps_per_min", False),
    ("gait_speed", "gait_speed", "m_per_s", False),
    ("step_length_mean", "step_length_mean", "m", False),
    ("step_width_mean", "step_width_mean", "m", False),
    ("step_time_mean", "step_time_mean", "s", False),
    ("step_length_mean_side", "step_length_mean", "m", True),
    ("step_length_sd_side", "step_length_sd", "m", True),
    ("step_length_cv_side", "step_length_cv", "percent", True),
    ("step_width_mean_side", "step_width_mean", "m", True),
    ("step_width_sd_side", "step_width_sd", "m", True),
    ("step_width_cv_side", "step_width_cv", "percent", True),
    ("step_time_mean_side", "step_time_mean", "s", True),
    ("step_time_sd_side", "step_time_sd", "s", True),
    ("step_time_cv_side", "step_time_cv", "percent", True),
    ("stance_percent_side", "stance", "percent", True),
    ("swing_percent_side", "swing", "percent", True),
    ("double_support_percent", "double_support", "percent", False),
    ("step_length_symmetry", "step_length_symmetry", "ratio", False),
    ("swing_time_symmetry", "swing_time_symmetry", "ratio", False),
    ("mean_confidence", "mean_confidence", "", False),
)
# Fields copied under their own name (no unit): scope is a label, step_count a count.
_SUMMARY_PLAIN: tuple[str, ...] = ("scope", "step_count")


def _summary_key_map() -> dict[str, tuple[str, ...]]:
    out: dict[str, tuple[str, ...]] = {name: (name,) for name in _SUMMARY_PLAIN}
    for field_name, stem, unit, per_side in _SUMMARY_FIELDS:
        suffix = f"_{unit}" if unit else ""
        if per_side:
            out[field_name] = tuple(f"{stem}_{side}{suffix}" for side in _SIDE_SUFFIXES)
        else:
            out[field_name] = (f"{stem}{suffix}",)
    return out


SUMMARY_KEY_MAP: dict[str, tuple[str, ...]] = _summary_key_map()
"""GaitSummary field name -> JSON key(s) (two keys, left then right, for the ``*_side`` arrays)."""

SUMMARY_JSON_KEYS: tuple[str, ...] = tuple(k for keys in SUMMARY_KEY_MAP.values() for k in keys)
"""Summary keys always present at the top level of ``summary.json`` (``null`` when unknown)."""

METADATA_KEYS: tuple[str, ...] = (
    "input_file",  # path of the processed recording, as given
    "preset",  # tracker preset name
    "seed",  # RNG seed (int) or null
    "frames_processed",  # depth frames run through the tracker
    "frames_skipped",  # {reason: count} of frames not processed
    "frames_skipped_total",  # sum of frames_skipped (filled in automatically)
    "walker_gait_version",  # filled in automatically
    "processing_time_s",  # wall-clock seconds of the whole processing
    "created_utc",  # ISO 8601 UTC time the file was written (filled in automatically)
)
"""Keys always present in ``summary.json``'s ``metadata`` object (``null`` when not given)."""


class OutputFormatError(ValueError):
    """An output file does not follow its documented schema (wrong header, bad value)."""


# --------------------------------------------------------------------------------------------
# Atomic writes
# --------------------------------------------------------------------------------------------


def _current_umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


_UMASK = _current_umask()  # read once at import: os.umask() can only be read by setting it


def _fsync_directory(directory: Path) -> None:
    """Best-effort fsync of a directory so that a rename survives a power cut."""
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


@contextlib.contextmanager
def atomic_write(
    path: str | os.PathLike[str],
    *,
    mode: Literal["w", "wb"] = "w",
    encoding: str = "utf-8",
    newline: str | None = None,
) -> Iterator[IO[Any]]:
    """Open ``path`` for writing such that it is replaced atomically when the block succeeds.

    The data go to a temporary file ``.<name>.<random>.tmp`` in the same directory (same file
    system, so the rename is atomic).  On normal exit of the ``with`` block the file is
    flushed, fsync'ed, given the usual permissions (``0o666 & ~umask``, or the permissions
    of the file it replaces) and renamed over ``path`` with :func:`os.replace`; the directory
    is then fsync'ed.  If the block raises anything (including :class:`KeyboardInterrupt`),
    the temporary file is deleted, ``path`` is left untouched (old content, or absent) and
    the exception propagates.  A hard kill (SIGKILL, power cut) can leave a ``.tmp`` file
    behind but never a partial file under ``path``.

    Args:
        path: final file name.  Its directory must exist (it is not created).
        mode: ``"w"`` (text) or ``"wb"`` (binary).
        encoding: text encoding (text mode only).
        newline: passed to :func:`open` in text mode (``""`` for the :mod:`csv` module).

    Yields:
        The open temporary file object.
    """
    if mode not in ("w", "wb"):
        msg = f"atomic_write mode must be 'w' or 'wb', got {mode!r}"
        raise ValueError(msg)
    final = Path(path)
    directory = final.parent if str(final.parent) else Path(".")
    if not directory.is_dir():
        msg = f"output directory does not exist: {directory}"
        raise FileNotFoundError(msg)
    fd, tmp_name = tempfile.mkstemp(prefix=f".{final.name}.", suffix=".tmp", dir=directory)
    tmp = Path(tmp_name)
    try:
        if mode == "wb":
            handle: IO[Any] = os.fdopen(fd, "wb")
        else:
            handle = os.fdopen(fd, "w", encoding=encoding, newline=newline)
    except BaseException:
        os.close(fd)
        tmp.unlink(missing_ok=True)
        raise
    try:
        with handle:
            yield handle
            handle.flush()
            os.fsync(handle.fileno())
        try:
            perms = final.stat().st_mode & 0o7777
        except OSError:
            perms = 0o666 & ~_UMASK
        os.chmod(tmp, perms)
        os.replace(tmp, final)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    _fsync_directory(directory)


# --------------------------------------------------------------------------------------------
# Value formatting / parsing
# --------------------------------------------------------------------------------------------


def _fmt_float(value: float, decimals: int) -> str:
    """Fixed-decimal text of ``value``; NaN -> empty field, ±inf -> ``inf``/``-inf``."""
    v = float(value)
    if math.isnan(v):
        return ""
    if math.isinf(v):
        return "inf" if v > 0 else "-inf"
    text = f"{v:.{decimals}f}"
    if text.startswith("-") and float(text) == 0.0:  # no "-0.00000"
        text = text[1:]
    return text


def _parse_float(text: str, *, column: str, line: int) -> float:
    t = text.strip()
    if t == "" or t.lower() == "nan":
        return math.nan
    try:
        return float(t)
    except ValueError:
        msg = f"line {line}, column {column!r}: not a number: {text!r}"
        raise OutputFormatError(msg) from None


def _parse_int(text: str, *, column: str, line: int) -> int:
    try:
        return int(text.strip())
    except ValueError:
        msg = f"line {line}, column {column!r}: not an integer: {text!r}"
        raise OutputFormatError(msg) from None


def _parse_enum(enum_type: type[Side] | type[EventKind] | type[TrackStatus], text: str, *,
                column: str, line: int) -> Any:
    label = text.strip().lower()
    for member in enum_type:
        if member.name.lower() == label:
            return member
    allowed = "/".join(m.name.lower() for m in enum_type)
    msg = f"line {line}, column {column!r}: expected one of {allowed}, got {text!r}"
    raise OutputFormatError(msg)


def _write_csv(path: str | os.PathLike[str], columns: Sequence[str], rows: Iterable[Sequence[str]]) -> None:
    with atomic_write(path, mode="w", newline="") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(columns)
        writer.writerows(rows)


def _read_csv(path: str | os.PathLike[str], columns: Sequence[str]) -> Iterator[tuple[int, list[str]]]:
    """Yield ``(line number, row)`` of a CSV whose header must equal ``columns``."""
    with open(path, encoding="utf-8", newline="") as fh:
        reader = csv.reader(fh)
        try:
            header = next(reader)
        except StopIteration:
            msg = f"{path}: empty file, expected header {','.join(columns)}"
            raise OutputFormatError(msg) from None
        if tuple(h.strip() for h in header) != tuple(columns):
            msg = f"{path}: unexpected header {header}, expected {list(columns)}"
            raise OutputFormatError(msg)
        for row in reader:
            if not row:
                continue
            if len(row) != len(columns):
                msg = f"{path}, line {reader.line_num}: {len(row)} fields, expected {len(columns)}"
                raise OutputFormatError(msg)
            yield reader.line_num, row


# --------------------------------------------------------------------------------------------
# steps.csv
# --------------------------------------------------------------------------------------------


def _step_row(step: Step) -> list[str]:
    row: list[str] = []
    for col in STEPS_COLUMNS:
        if col == "time":
            row.append(_fmt_float(step.stamp, DECIMALS["time"]))
        elif col == "foot":
            row.append(Side(step.side).label)
        elif col == "step_index":
            row.append(str(int(step.index)))
        else:
            row.append(_fmt_float(getattr(step, col), DECIMALS[_STEP_KINDS[col]]))
    return row


def write_steps_csv(path: str | os.PathLike[str], steps: Iterable[Step]) -> None:
    """Write ``steps.csv`` (columns :data:`STEPS_COLUMNS`), one row per step in the given order."""
    _write_csv(path, STEPS_COLUMNS, (_step_row(s) for s in steps))


def read_steps_csv(path: str | os.PathLike[str]) -> list[Step]:
    """Read a ``steps.csv`` written by :func:`write_steps_csv` back into :class:`Step` objects.

    Raises:
        OutputFormatError: wrong header, wrong number of fields or unparsable value.
    """
    steps: list[Step] = []
    for line, row in _read_csv(path, STEPS_COLUMNS):
        rec = dict(zip(STEPS_COLUMNS, row, strict=True))
        floats = {
            col: _parse_float(rec[col], column=col, line=line)
            for col in STEPS_COLUMNS
            if col not in ("foot", "step_index", "time")
        }
        steps.append(
            Step(
                stamp=_parse_float(rec["time"], column="time", line=line),
                side=_parse_enum(Side, rec["foot"], column="foot", line=line),
                index=_parse_int(rec["step_index"], column="step_index", line=line),
                **floats,
            )
        )
    return steps


# --------------------------------------------------------------------------------------------
# events.csv
# --------------------------------------------------------------------------------------------


def _event_row(event: GaitEvent) -> list[str]:
    pos = np.asarray(event.position, dtype=np.float64).reshape(-1)
    if pos.shape != (3,):
        msg = f"event position must have 3 elements, got shape {np.shape(event.position)}"
        raise ValueError(msg)
    return [
        _fmt_float(event.stamp, DECIMALS["time"]),
        Side(event.side).label,
        EventKind(event.kind).label,
        *(_fmt_float(v, DECIMALS["length"]) for v in pos),
        _fmt_float(event.confidence, DECIMALS["confidence"]),
    ]


def write_events_csv(path: str | os.PathLike[str], events: Iterable[GaitEvent]) -> None:
    """Write ``events.csv`` (columns :data:`EVENTS_COLUMNS`), one row per event in the given order."""
    _write_csv(path, EVENTS_COLUMNS, (_event_row(e) for e in events))


def read_events_csv(path: str | os.PathLike[str]) -> list[GaitEvent]:
    """Read an ``events.csv`` back into :class:`GaitEvent` objects.

    Raises:
        OutputFormatError: wrong header, wrong number of fields or unparsable value.
    """
    events: list[GaitEvent] = []
    for line, row in _read_csv(path, EVENTS_COLUMNS):
        rec = dict(zip(EVENTS_COLUMNS, row, strict=True))
        events.append(
            GaitEvent(
                stamp=_parse_float(rec["time"], column="time", line=line),
                side=_parse_enum(Side, rec["foot"], column="foot", line=line),
                kind=_parse_enum(EventKind, rec["event"], column="event", line=line),
                position=np.array([_parse_float(rec[a], column=a, line=line) for a in "xyz"]),
                confidence=_parse_float(rec["confidence"], column="confidence", line=line),
            )
        )
    return events


# --------------------------------------------------------------------------------------------
# joints.csv
# --------------------------------------------------------------------------------------------

_N_POINT_COLS = 2 * len(LEG_POINTS) * 3


def _joint_row(pose: LegPose) -> list[str]:
    points = np.asarray(pose.points, dtype=np.float64)
    if points.shape != (2, len(LEG_POINTS), 3):
        msg = f"LegPose.points must have shape (2, {len(LEG_POINTS)}, 3), got {points.shape}"
        raise ValueError(msg)
    angles = np.asarray(pose.angles, dtype=np.float64).reshape(-1)
    if angles.shape != (len(JOINT_NAMES),):
        msg = f"LegPose.angles must have {len(JOINT_NAMES)} elements, got shape {np.shape(pose.angles)}"
        raise ValueError(msg)
    return [
        _fmt_float(pose.stamp, DECIMALS["time"]),
        *(_fmt_float(v, DECIMALS["length"]) for v in points.reshape(-1)),
        *(_fmt_float(v, DECIMALS["angle"]) for v in angles),
        TrackStatus(pose.status).name.lower(),
        _fmt_float(pose.confidence, DECIMALS["confidence"]),
    ]


def write_joints_csv(path: str | os.PathLike[str], poses: Iterable[LegPose]) -> None:
    """Write ``joints.csv`` (columns :data:`JOINTS_COLUMNS`), one row per pose in the given order."""
    _write_csv(path, JOINTS_COLUMNS, (_joint_row(p) for p in poses))


def read_joints_csv(path: str | os.PathLike[str]) -> list[LegPose]:
    """Read a ``joints.csv`` back into :class:`LegPose` objects.

    Only the columns of the file are restored (stamp, points, angles, status, confidence);
    segments, radii, visibility and ESS are left at their defaults.

    Raises:
        OutputFormatError: wrong header, wrong number of fields or unparsable value.
    """
    poses: list[LegPose] = []
    n_ang = len(JOINT_NAMES)
    for line, row in _read_csv(path, JOINTS_COLUMNS):
        values = [
            _parse_float(text, column=col, line=line)
            for col, text in zip(JOINTS_COLUMNS[1 : 1 + _N_POINT_COLS + n_ang],
                                 row[1 : 1 + _N_POINT_COLS + n_ang], strict=True)
        ]
        poses.append(
            LegPose(
                stamp=_parse_float(row[0], column="time", line=line),
                points=np.array(values[:_N_POINT_COLS]).reshape(2, len(LEG_POINTS), 3),
                angles=np.array(values[_N_POINT_COLS:]),
                status=_parse_enum(TrackStatus, row[-2], column="status", line=line),
                confidence=_parse_float(row[-1], column="confidence", line=line),
            )
        )
    return poses


# --------------------------------------------------------------------------------------------
# summary.json
# --------------------------------------------------------------------------------------------


def _json_safe(value: Any) -> Any:
    """Convert ``value`` to plain JSON types: NaN/inf -> None, numpy -> Python, Path -> str."""
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, Enum):
        return value.name.lower()
    if isinstance(value, (int, np.integer)) and not isinstance(value, np.bool_):
        return int(value)
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, (float, np.floating)):
        v = float(value)
        return v if math.isfinite(v) else None
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    if isinstance(value, Mapping):
        return {str(k): _json_safe(v) for k, v in value.items()}
    if isinstance(value, np.ndarray):
        return [_json_safe(v) for v in value.tolist()]
    if isinstance(value, (list, tuple, set, frozenset)):
        return [_json_safe(v) for v in value]
    msg = f"cannot store a {type(value).__name__} in summary.json: {value!r}"
    raise TypeError(msg)


def _scope_label(value: Any) -> Any:
    """GaitSummary ``scope`` (0 = WINDOW, 1 = SESSION, or a label) -> ``"window"``/``"session"``."""
    if isinstance(value, str):
        return value.lower()
    if isinstance(value, Enum):
        return value.name.lower()
    if isinstance(value, (int, np.integer)):
        return {0: "window", 1: "session"}.get(int(value), int(value))
    return value


def summary_to_json(summary: Mapping[str, Any]) -> dict[str, Any]:
    """Map a gait summary to ``summary.json``'s unit-suffixed keys.

    ``summary`` uses the ``walker_gait_msgs/GaitSummary`` field names (as produced by
    ``GaitSummaryData.to_dict()``): e.g. ``cadence`` -> ``cadence_steps_per_min``,
    ``gait_speed`` -> ``gait_speed_m_per_s``, ``step_length_mean_side`` ([LEFT, RIGHT]) ->
    ``step_length_mean_left_m`` and ``step_length_mean_right_m``; the full table is
    :data:`SUMMARY_KEY_MAP` and ``docs/OUTPUTS.md``.  Keys that are already output keys
    (:data:`SUMMARY_JSON_KEYS`) are accepted as they are, so the function is idempotent.
    A ``header`` mapping with a ``stamp`` is accepted in place of ``stamp``.  Fields that are
    not part of the schema are kept, JSON-safe, under ``"extra"``.

    Every key of :data:`SUMMARY_JSON_KEYS` is present in the result; unknown values and NaN
    become ``None`` (JSON ``null``).  ``scope`` becomes ``"window"``/``"session"``.  An object
    with a ``to_dict()`` method (``GaitSummaryData``) is accepted in place of the dict.

    Raises:
        TypeError: ``summary`` is neither a mapping nor has ``to_dict()``.
        ValueError: a per-side field does not have exactly two values.
    """
    if not isinstance(summary, Mapping) and callable(getattr(summary, "to_dict", None)):
        summary = summary.to_dict()  # a GaitSummaryData passed directly
    if not isinstance(summary, Mapping):
        msg = f"summary must be a dict (GaitSummaryData.to_dict()), got {type(summary).__name__}"
        raise TypeError(msg)
    out: dict[str, Any] = dict.fromkeys(SUMMARY_JSON_KEYS)
    extra: dict[str, Any] = {}
    json_keys = set(SUMMARY_JSON_KEYS)
    for name, value in summary.items():
        if name in SUMMARY_KEY_MAP:
            keys = SUMMARY_KEY_MAP[name]
            if len(keys) == 2:
                arr = np.asarray(value, dtype=np.float64).reshape(-1)
                if arr.shape != (2,):
                    msg = f"summary field {name!r} must have 2 values [left, right], got {value!r}"
                    raise ValueError(msg)
                out[keys[0]] = _json_safe(arr[0])
                out[keys[1]] = _json_safe(arr[1])
            elif name == "scope":
                out["scope"] = _json_safe(_scope_label(value))
            else:
                out[keys[0]] = _json_safe(value)
        elif name in json_keys:
            out[name] = _json_safe(_scope_label(value) if name == "scope" else value)
        elif name == "header" and isinstance(value, Mapping) and "stamp" in value:
            out["stamp_s"] = _json_safe(value["stamp"])
        elif name == "extra" and isinstance(value, Mapping):
            extra.update(_json_safe(value))
        else:
            extra[str(name)] = _json_safe(value)
    if isinstance(out.get("step_count"), float):  # a count written as float by some producer
        out["step_count"] = int(out["step_count"])
    if extra:
        out["extra"] = extra
    return out


def json_to_summary(data: Mapping[str, Any]) -> dict[str, Any]:
    """Inverse of :func:`summary_to_json`: unit-suffixed keys -> GaitSummary field names.

    ``null`` becomes NaN for numeric fields; per-side fields become ``[left, right]`` lists;
    ``scope`` stays a label.  Keys outside the schema (``metadata``, ``schema``, ``extra``)
    are ignored.
    """
    out: dict[str, Any] = {}
    for name, keys in SUMMARY_KEY_MAP.items():
        if name == "scope":
            out[name] = data.get("scope")
            continue
        vals = [data.get(k) for k in keys]
        if name == "step_count":
            out[name] = vals[0]
            continue
        nums = [math.nan if v is None else float(v) for v in vals]
        out[name] = nums if len(keys) == 2 else nums[0]
    return out


def build_metadata(
    *,
    input_file: str | os.PathLike[str] | None,
    preset: str | None,
    seed: int | None,
    frames_processed: int,
    frames_skipped: Mapping[str, int] | None = None,
    processing_time_s: float | None = None,
    **extra: Any,
) -> dict[str, Any]:
    """Build the ``metadata`` object of ``summary.json`` (keys :data:`METADATA_KEYS`).

    ``walker_gait_version``, ``frames_skipped_total`` and ``created_utc`` are filled in.
    ``extra`` keyword arguments (e.g. ``topic``, ``duration_s``) are kept as given.
    """
    skipped = {str(k): int(v) for k, v in (frames_skipped or {}).items()}
    meta: dict[str, Any] = {
        "input_file": None if input_file is None else os.fspath(input_file),
        "preset": preset,
        "seed": seed,
        "frames_processed": int(frames_processed),
        "frames_skipped": skipped,
        "frames_skipped_total": sum(skipped.values()),
        "walker_gait_version": __version__,
        "processing_time_s": processing_time_s,
        "created_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    }
    meta.update(extra)
    return meta


def _complete_metadata(metadata: Mapping[str, Any]) -> dict[str, Any]:
    meta: dict[str, Any] = dict.fromkeys(METADATA_KEYS)
    meta["frames_skipped"] = {}
    meta.update(metadata)
    skipped = meta.get("frames_skipped") or {}
    if not isinstance(skipped, Mapping):
        msg = f"metadata['frames_skipped'] must map reason -> count, got {skipped!r}"
        raise ValueError(msg)
    meta["frames_skipped"] = dict(skipped)
    if meta.get("frames_skipped_total") is None:
        meta["frames_skipped_total"] = int(sum(int(v) for v in skipped.values()))
    if meta.get("walker_gait_version") is None:
        meta["walker_gait_version"] = __version__
    if meta.get("created_utc") is None:
        meta["created_utc"] = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
    return meta


def write_summary_json(
    path: str | os.PathLike[str],
    summary: Mapping[str, Any],
    *,
    metadata: Mapping[str, Any],
) -> dict[str, Any]:
    """Write ``summary.json``: ``{"schema", <summary keys>..., "metadata": {...}}``.

    ``summary`` is a GaitSummary-style dict (``GaitSummaryData.to_dict()``) or an already
    mapped one; it goes through :func:`summary_to_json`, so every key of
    :data:`SUMMARY_JSON_KEYS` is present at the top level.  ``metadata`` is completed to
    :data:`METADATA_KEYS` (see :func:`build_metadata`).  NaN and infinities are written as
    ``null``; the output is strict JSON (``allow_nan=False``), indented, UTF-8.

    Returns:
        The dict that was written.
    """
    doc: dict[str, Any] = {"schema": SUMMARY_SCHEMA}
    doc.update(summary_to_json(summary))
    doc["metadata"] = _json_safe(_complete_metadata(metadata))
    text = json.dumps(doc, indent=2, allow_nan=False, ensure_ascii=False)
    with atomic_write(path, mode="w") as fh:
        fh.write(text)
        fh.write("\n")
    return doc


def read_summary_json(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Read ``summary.json`` as written (``null`` stays ``None``); see :func:`json_to_summary`.

    Raises:
        OutputFormatError: not a JSON object or not this schema.
    """
    with open(path, encoding="utf-8") as fh:
        try:
            data = json.load(fh)
        except json.JSONDecodeError as exc:
            msg = f"{path}: invalid JSON: {exc}"
            raise OutputFormatError(msg) from None
    if not isinstance(data, dict) or data.get("schema") != SUMMARY_SCHEMA:
        msg = f"{path}: not a {SUMMARY_SCHEMA} file"
        raise OutputFormatError(msg)
    return data
