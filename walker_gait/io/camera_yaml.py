"""Camera calibration data and ``camera_calibration_parsers`` YAML files.

:class:`CameraInfoData` is the ROS-free equivalent of ``sensor_msgs/CameraInfo``
that the recording reader (:mod:`walker_gait.io.bags`) attaches to every depth
frame.  :func:`load_camera_info_yaml` reads the YAML written by
``camera_calibration`` / ``camera_info_manager`` (keys ``image_width``,
``image_height``, ``camera_name``, ``camera_matrix``, ``distortion_model``,
``distortion_coefficients``, ``rectification_matrix``, ``projection_matrix``;
matrices as ``{rows, cols, data}``), used when a recording has no CameraInfo
topic.  No ROS imports.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

__all__ = [
    "CameraInfoData",
    "CameraYamlError",
    "dump_camera_info_yaml",
    "load_camera_info_yaml",
]

_IDENTITY_3X3: tuple[float, ...] = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)


class CameraYamlError(ValueError):
    """A camera calibration YAML file is missing, unreadable or malformed."""


@dataclass(frozen=True, kw_only=True)
class CameraInfoData:
    """Calibration of one camera, mirroring ``sensor_msgs/CameraInfo`` (row-major matrices).

    Attributes:
        width: Image width in pixels the calibration refers to.
        height: Image height in pixels.
        k: Intrinsic matrix K (3x3, 9 values).
        d: Distortion coefficients (length depends on ``distortion_model``).
        r: Rectification matrix R (3x3, 9 values).
        p: Projection matrix P (3x4, 12 values).
        distortion_model: e.g. ``"plumb_bob"``, ``"rational_polynomial"``, ``"equidistant"``.
        frame_id: Optical frame of the camera (empty when unknown).
    """

    width: int
    height: int
    k: tuple[float, ...]
    d: tuple[float, ...]
    r: tuple[float, ...]
    p: tuple[float, ...]
    distortion_model: str
    frame_id: str = ""

    def __post_init__(self) -> None:
        for name, size in (("k", 9), ("r", 9), ("p", 12)):
            value = getattr(self, name)
            if len(value) != size:
                msg = f"CameraInfo {name.upper()} must have {size} values, got {len(value)}"
                raise ValueError(msg)
        if self.width < 0 or self.height < 0:
            msg = f"CameraInfo image size must not be negative, got {self.width}x{self.height}"
            raise ValueError(msg)

    @property
    def fx(self) -> float:
        """Focal length in x (pixels), ``K[0]``."""
        return self.k[0]

    @property
    def fy(self) -> float:
        """Focal length in y (pixels), ``K[4]``."""
        return self.k[4]

    @property
    def cx(self) -> float:
        """Principal point x (pixels), ``K[2]``."""
        return self.k[2]

    @property
    def cy(self) -> float:
        """Principal point y (pixels), ``K[5]``."""
        return self.k[5]


def _matrix(doc: Mapping[str, Any], key: str, *, rows: int | None, cols: int | None) -> tuple[float, ...]:
    """Read a ``{rows, cols, data}`` matrix entry and check its shape."""
    entry = doc[key]
    if isinstance(entry, Mapping):
        data = entry.get("data")
        if data is None:
            msg = f"'{key}' has no 'data' list"
            raise CameraYamlError(msg)
        r = entry.get("rows")
        c = entry.get("cols")
        if r is not None and c is not None and int(r) * int(c) != len(data):
            msg = f"'{key}' declares {r}x{c} but has {len(data)} values"
            raise CameraYamlError(msg)
    elif isinstance(entry, Sequence) and not isinstance(entry, str):
        data = entry  # tolerate a bare list
    else:
        msg = f"'{key}' must be a mapping with rows/cols/data"
        raise CameraYamlError(msg)
    try:
        values = tuple(float(x) for x in data)
    except (TypeError, ValueError) as exc:
        msg = f"'{key}' contains a non-numeric value ({exc})"
        raise CameraYamlError(msg) from None
    if rows is not None and cols is not None and len(values) != rows * cols:
        msg = f"'{key}' must have {rows}x{cols}={rows * cols} values, got {len(values)}"
        raise CameraYamlError(msg)
    if not all(math.isfinite(v) for v in values):
        msg = f"'{key}' contains non-finite values"
        raise CameraYamlError(msg)
    return values


def load_camera_info_yaml(path: str | Path, *, frame_id: str = "") -> CameraInfoData:
    """Load a ``camera_calibration_parsers`` YAML file.

    ``image_width``, ``image_height`` and ``camera_matrix`` are required;
    a missing ``rectification_matrix`` defaults to identity, a missing
    ``projection_matrix`` to ``[K | 0]``, missing ``distortion_coefficients``
    to none (with ``distortion_model`` defaulting to ``plumb_bob``).

    Args:
        path: The YAML file.
        frame_id: Frame id to store (the YAML format has none; ``camera_name`` is not a frame).

    Raises:
        CameraYamlError: The file is missing, not YAML, or lacks/malforms a required entry;
            the message names the file.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        msg = f"{p}: camera info file not found"
        raise CameraYamlError(msg) from None
    except (OSError, UnicodeDecodeError) as exc:
        msg = f"{p}: cannot read camera info file ({exc})"
        raise CameraYamlError(msg) from None
    try:
        doc = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        msg = f"{p}: not a valid YAML file ({exc})"
        raise CameraYamlError(msg) from None
    if not isinstance(doc, Mapping):
        msg = f"{p}: expected a camera_calibration_parsers YAML mapping, got {type(doc).__name__}"
        raise CameraYamlError(msg)
    try:
        missing = [k for k in ("image_width", "image_height", "camera_matrix") if k not in doc]
        if missing:
            msg = f"missing required key(s) {', '.join(missing)}"
            raise CameraYamlError(msg)
        width = int(doc["image_width"])
        height = int(doc["image_height"])
        k = _matrix(doc, "camera_matrix", rows=3, cols=3)
        d = _matrix(doc, "distortion_coefficients", rows=None, cols=None) if "distortion_coefficients" in doc else ()
        r = _matrix(doc, "rectification_matrix", rows=3, cols=3) if "rectification_matrix" in doc else _IDENTITY_3X3
        if "projection_matrix" in doc:
            proj = _matrix(doc, "projection_matrix", rows=3, cols=4)
        else:
            proj = (k[0], k[1], k[2], 0.0, k[3], k[4], k[5], 0.0, k[6], k[7], k[8], 0.0)
        model = str(doc.get("distortion_model") or "plumb_bob")
        if width <= 0 or height <= 0:
            msg = f"image size must be positive, got {width}x{height}"
            raise CameraYamlError(msg)
        if k[0] <= 0 or k[4] <= 0:
            msg = f"camera_matrix focal lengths must be positive, got fx={k[0]}, fy={k[4]}"
            raise CameraYamlError(msg)
        return CameraInfoData(
            width=width, height=height, k=k, d=d, r=r, p=proj, distortion_model=model, frame_id=frame_id
        )
    except CameraYamlError as exc:
        msg = f"{p}: invalid camera info YAML: {exc}"
        raise CameraYamlError(msg) from None
    except (TypeError, ValueError) as exc:
        msg = f"{p}: invalid camera info YAML: {exc}"
        raise CameraYamlError(msg) from None


def dump_camera_info_yaml(info: CameraInfoData, path: str | Path, *, camera_name: str = "camera") -> None:
    """Write ``info`` as a ``camera_calibration_parsers`` YAML file (inverse of :func:`load_camera_info_yaml`)."""

    def mat(rows: int, cols: int, data: Sequence[float]) -> dict[str, Any]:
        return {"rows": rows, "cols": cols, "data": [float(x) for x in data]}

    doc = {
        "image_width": int(info.width),
        "image_height": int(info.height),
        "camera_name": camera_name,
        "camera_matrix": mat(3, 3, info.k),
        "distortion_model": info.distortion_model,
        "distortion_coefficients": mat(1, len(info.d), info.d),
        "rectification_matrix": mat(3, 3, info.r),
        "projection_matrix": mat(3, 4, info.p),
    }
    Path(path).write_text(yaml.safe_dump(doc, sort_keys=False), encoding="utf-8")
