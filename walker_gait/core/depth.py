"""Depth image decoding, camera-model handling and back-projection.

Everything here is pure numpy/OpenCV (no rclpy).  Units are SI: depth images
are returned as ``float32`` arrays in **metres** with ``NaN`` marking invalid
pixels; 3-D points are in the **camera optical frame** (x right, y down,
z forward, metres; see :mod:`walker_gait.core.types`).

Spec: seed paper 000 §4.2, eq. (1) (Kinect raw 11-bit disparity to
millimetres, ``z_mm = 1000 / (-0.00307 d + 3.33)``, 2047 = no reading) and
eq. (2) (pinhole back-projection).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import ArrayLike, NDArray

from walker_gait.core import kernels
from walker_gait.core.types import CameraIntrinsics

F32 = NDArray[np.float32]

__all__ = [
    "DEPTH_FORMATS",
    "KINECT_INVALID",
    "KINECT_MAX_RANGE_M",
    "KINECT_MIN_RANGE_M",
    "MAX_DEPTH_M",
    "SUPPORTED_ENCODINGS",
    "CameraInfoError",
    "DepthDecodeError",
    "DepthProjector",
    "Undistorter",
    "check_info_matches",
    "decode_depth",
    "intrinsics_from_camera_info",
    "kinect_raw_to_metres",
    "metres_to_kinect_raw",
]


class DepthDecodeError(ValueError):
    """A depth image message cannot be decoded (bad encoding, size, step or buffer)."""


class CameraInfoError(ValueError):
    """A ``CameraInfo`` is unusable (bad focal length, all-zero matrices, size mismatch, ...)."""


# --------------------------------------------------------------------------- Kinect eq. (1)

KINECT_A = -0.00307
"""Slope of eq. (1), ``1/z[m] = KINECT_A * d + KINECT_B`` (per raw disparity unit)."""
KINECT_B = 3.33
"""Intercept of eq. (1) (1/m)."""
KINECT_INVALID = 2047
"""Raw value of a pixel without a reading (seed §4.2)."""
KINECT_MIN_RANGE_M = 0.25
"""Raw values decoding nearer than this are treated as invalid (eq. (1) gives >= 0.300 m at d = 0)."""
KINECT_MAX_RANGE_M = 10.0
"""Raw values decoding farther than this (d >= ~1053, where eq. (1) diverges) are invalid."""
MAX_DEPTH_M = 1000.0
"""32FC1 depths beyond this are treated as invalid (no depth sensor reports them; avoids overflow)."""


def _kinect_lut() -> F32:
    d = np.arange(65536, dtype=np.float64)
    denom = KINECT_A * d + KINECT_B
    with np.errstate(divide="ignore"):
        z = np.where(denom > 0, 1.0 / denom, np.nan)
    z[(z < KINECT_MIN_RANGE_M) | (z > KINECT_MAX_RANGE_M)] = np.nan
    z[KINECT_INVALID:] = np.nan  # 2047 = no reading; > 2047 is not an 11-bit value
    return z.astype(np.float32)


_KINECT_LUT: F32 = _kinect_lut()


def kinect_raw_to_metres(raw: ArrayLike) -> F32:
    """Convert raw 11-bit Kinect disparity to metres with eq. (1) (``z_m = 1/(-0.00307 d + 3.33)``).

    ``2047`` (no reading), values above 2047, and values for which eq. (1) is
    non-positive or outside ``[KINECT_MIN_RANGE_M, KINECT_MAX_RANGE_M]`` give NaN.
    Non-integer input is rounded; negative input is invalid.
    """
    arr = np.asarray(raw)
    if arr.dtype == np.uint16:
        return _KINECT_LUT[arr]
    a = np.asarray(arr, dtype=np.float64)
    ok = np.isfinite(a) & (a >= 0) & (a < KINECT_INVALID)
    idx = np.where(ok, np.rint(np.where(ok, a, 0)), KINECT_INVALID).astype(np.intp)
    return _KINECT_LUT[idx]


def metres_to_kinect_raw(depth_m: ArrayLike) -> NDArray[np.uint16]:
    """Inverse of eq. (1): metres to raw 11-bit Kinect disparity (rounded to the nearest unit).

    Non-finite, non-positive or out-of-range (``KINECT_MIN_RANGE_M``..``KINECT_MAX_RANGE_M``)
    depths map to ``KINECT_INVALID`` (2047).  The round trip
    ``kinect_raw_to_metres(metres_to_kinect_raw(z))`` reproduces ``z`` up to the
    quantisation step ``|dz| <= 0.5 * 0.00307 * z**2`` (m), plus the at most one-unit
    error where rounding crosses a range limit.
    """
    z = np.asarray(depth_m, dtype=np.float64)
    ok = np.isfinite(z) & (z >= KINECT_MIN_RANGE_M) & (z <= KINECT_MAX_RANGE_M)
    with np.errstate(divide="ignore", invalid="ignore"):
        d = (KINECT_B - 1.0 / np.where(ok, z, 1.0)) / -KINECT_A
    d = np.rint(d)
    ok &= (d >= 0) & (d < KINECT_INVALID)
    out = np.where(ok, d, KINECT_INVALID).astype(np.uint16)
    # rounding may push a value just outside the valid range: mark it invalid like the decoder
    out[np.isnan(_KINECT_LUT[out])] = KINECT_INVALID
    return out


# --------------------------------------------------------------------------- decoding

SUPPORTED_ENCODINGS: tuple[str, ...] = ("16UC1", "mono16", "32FC1")
"""``sensor_msgs/Image`` encodings accepted by :func:`decode_depth`."""

DEPTH_FORMATS: tuple[str, ...] = ("auto", "kinect_raw")
"""``auto``: 16-bit = millimetres, 32FC1 = metres (REP 118).  ``kinect_raw``: 16-bit raw Kinect disparity."""

_BYTES_PER_PIXEL = {"16UC1": 2, "mono16": 2, "32FC1": 4}


def _as_byte_buffer(data: bytes | bytearray | memoryview | NDArray[np.generic]) -> NDArray[np.uint8]:
    if isinstance(data, np.ndarray):
        arr = data if data.flags.c_contiguous else np.ascontiguousarray(data)
        return arr.reshape(-1).view(np.uint8)
    if isinstance(data, (bytes, bytearray, memoryview)):
        mv = memoryview(data)
        if not mv.c_contiguous:
            mv = memoryview(mv.tobytes())
        return np.frombuffer(mv.cast("B") if mv.format != "B" or mv.ndim != 1 else mv, dtype=np.uint8)
    msg = f"depth data must be bytes, memoryview or numpy array, got {type(data).__name__}"
    raise DepthDecodeError(msg)


def decode_depth(
    data: bytes | bytearray | memoryview | NDArray[np.generic],
    *,
    encoding: str,
    width: int,
    height: int,
    step: int,
    is_bigendian: bool,
    depth_format: str = "auto",
) -> F32:
    """Decode a ``sensor_msgs/Image`` depth payload to a ``(height, width)`` float32 image in metres.

    Parameters mirror the message fields.  ``step`` is the row length in bytes
    and may exceed ``width * bytes_per_pixel`` (row padding, ignored).  The
    buffer must hold at least ``step * (height - 1) + width * bytes_per_pixel``
    bytes; trailing bytes are ignored.

    * ``16UC1`` / ``mono16``: millimetres, ``0`` = invalid (``depth_format="auto"``),
      or raw Kinect disparity (``depth_format="kinect_raw"``, eq. (1), 2047 = invalid).
    * ``32FC1``: metres; NaN, +-Inf, values ``<= 0`` and absurd values ``> MAX_DEPTH_M`` are invalid.

    Returns a new C-contiguous float32 array (never a view of ``data``), NaN = invalid.

    Raises:
        DepthDecodeError: unsupported encoding or depth format, non-positive size,
            step too small, or buffer too short.
    """
    if depth_format not in DEPTH_FORMATS:
        msg = f"unsupported depth_format {depth_format!r} (expected one of {DEPTH_FORMATS})"
        raise DepthDecodeError(msg)
    enc = encoding.strip()
    canonical = {e.lower(): e for e in SUPPORTED_ENCODINGS}.get(enc.lower())
    if canonical is None:
        msg = f"unsupported depth encoding {encoding!r} (expected one of {SUPPORTED_ENCODINGS})"
        raise DepthDecodeError(msg)
    bpp = _BYTES_PER_PIXEL[canonical]
    if depth_format == "kinect_raw" and bpp != 2:
        msg = f"depth_format 'kinect_raw' needs a 16-bit encoding, got {canonical!r}"
        raise DepthDecodeError(msg)
    try:
        width, height, step = int(width), int(height), int(step)
    except (TypeError, ValueError, OverflowError) as exc:
        msg = f"{canonical}: width/height/step must be integers ({exc})"
        raise DepthDecodeError(msg) from exc
    if width <= 0 or height <= 0:
        msg = f"{canonical}: image size must be positive, got {width}x{height}"
        raise DepthDecodeError(msg)
    if step < width * bpp:
        msg = f"{canonical}: step {step} is smaller than width*{bpp} = {width * bpp} bytes"
        raise DepthDecodeError(msg)
    buf = _as_byte_buffer(data)
    needed = step * (height - 1) + width * bpp
    if buf.size < needed:
        msg = (
            f"{canonical}: buffer too short: {buf.size} bytes for {width}x{height} "
            f"with step {step} (need at least {needed})"
        )
        raise DepthDecodeError(msg)

    order = ">" if is_bigendian else "<"
    kind = "f4" if bpp == 4 else "u2"
    # Strided view of the rows (no copy); unaligned access is handled by numpy.
    raw = np.ndarray(shape=(height, width), dtype=np.dtype(order + kind), buffer=buf, offset=0, strides=(step, bpp))

    if bpp == 4:
        out = raw.astype(np.float32)  # native-endian copy
        bad = ~((out > 0) & (out <= MAX_DEPTH_M))  # NaN, <= 0, +-Inf and absurd values
        out[bad] = np.nan
        return out
    raw16 = raw if raw.dtype.isnative else raw.astype(np.uint16)
    if depth_format == "kinect_raw":
        return _KINECT_LUT[raw16]
    out = np.multiply(raw16, np.float32(0.001), dtype=np.float32)
    out[raw16 == 0] = np.nan
    return out


# --------------------------------------------------------------------------- camera info


@dataclass(frozen=True)
class Undistorter:
    """Maps a raw (distorted) depth image onto the undistorted pinhole image of ``intrinsics``.

    Built from OpenCV ``initUndistortRectifyMap``; :meth:`apply` uses
    nearest-neighbour ``remap`` so depth is never blended across object edges.
    Pixels mapping outside the raw image become NaN.  Depth values (z) are
    unchanged by undistortion, only their pixel positions move.
    """

    map1: NDArray[np.int16]
    map2: NDArray[np.uint16]
    width: int
    height: int

    def apply(self, depth_m: F32) -> F32:
        """Undistort a ``(height, width)`` float32 depth image (metres, NaN invalid)."""
        if depth_m.shape != (self.height, self.width):
            msg = f"depth image shape {depth_m.shape} does not match the undistortion maps ({self.width}x{self.height})"
            raise CameraInfoError(msg)
        src = np.ascontiguousarray(depth_m, dtype=np.float32)
        return cv2.remap(
            src,
            self.map1,
            self.map2,
            interpolation=cv2.INTER_NEAREST,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=float("nan"),
        )


_DISTORTION_LENGTHS = {"plumb_bob": (4, 5), "rational_polynomial": (8,)}


def _finite_array(values: Sequence[float] | ArrayLike, *, name: str, size: int | None) -> NDArray[np.float64]:
    try:
        arr = np.asarray(values, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError) as exc:
        msg = f"CameraInfo {name} is not numeric ({exc})"
        raise CameraInfoError(msg) from exc
    if size is not None and arr.size != size:
        msg = f"CameraInfo {name} must have {size} entries, got {arr.size}"
        raise CameraInfoError(msg)
    if not np.all(np.isfinite(arr)):
        msg = f"CameraInfo {name} contains non-finite values"
        raise CameraInfoError(msg)
    return arr


def intrinsics_from_camera_info(
    *,
    width: int,
    height: int,
    k: Sequence[float] | ArrayLike,
    d: Sequence[float] | ArrayLike,
    p: Sequence[float] | ArrayLike,
    distortion_model: str,
    rectified: bool,
) -> tuple[CameraIntrinsics, Undistorter | None]:
    """Pinhole intrinsics (and, for raw images, an undistortion) from ``sensor_msgs/CameraInfo`` fields.

    * ``rectified=True`` (e.g. ``image_rect``/``depth_registered`` images): the
      projection matrix P is used (``fx=P[0], fy=P[5], cx=P[2], cy=P[6]``), no
      undistortion (returns ``None``).  Falls back to K when P is all zero.
    * ``rectified=False`` (raw images): K is used; if D is non-zero
      (``plumb_bob``: 4-5 coefficients, ``rational_polynomial``: 8) an
      :class:`Undistorter` mapping the raw image onto the undistorted pinhole
      image with the same K is returned, else ``None``.

    Binning and ROI fields of CameraInfo are not supported (callers must pass
    full-resolution images).

    Raises:
        CameraInfoError: non-positive size, wrong matrix sizes, non-finite entries,
            all-zero K (raw) / K and P (rectified), non-positive or non-finite focal
            lengths, or an unsupported distortion model with non-zero coefficients.
    """
    try:
        width, height = int(width), int(height)
    except (TypeError, ValueError, OverflowError) as exc:
        msg = f"CameraInfo width/height must be integers ({exc})"
        raise CameraInfoError(msg) from exc
    if width <= 0 or height <= 0:
        msg = f"CameraInfo image size must be positive, got {width}x{height}"
        raise CameraInfoError(msg)
    k_arr = _finite_array(k, name="K", size=9)
    p_arr = _finite_array(p, name="P", size=12)
    d_arr = _finite_array(d, name="D", size=None)

    if rectified:
        if np.any(p_arr != 0):
            fx, fy, cx, cy = p_arr[0], p_arr[5], p_arr[2], p_arr[6]
            src = "P"
        elif np.any(k_arr != 0):
            fx, fy, cx, cy = k_arr[0], k_arr[4], k_arr[2], k_arr[5]
            src = "K (P is all zero)"
        else:
            msg = "CameraInfo K and P are all zero (uncalibrated camera)"
            raise CameraInfoError(msg)
    else:
        if not np.any(k_arr != 0):
            msg = "CameraInfo K is all zero (uncalibrated camera)"
            raise CameraInfoError(msg)
        fx, fy, cx, cy = k_arr[0], k_arr[4], k_arr[2], k_arr[5]
        src = "K"
    if not (fx > 0 and fy > 0):
        msg = f"CameraInfo {src} focal lengths must be positive, got fx={fx}, fy={fy}"
        raise CameraInfoError(msg)
    intr = CameraIntrinsics(width=width, height=height, fx=float(fx), fy=float(fy), cx=float(cx), cy=float(cy))

    if rectified or not np.any(d_arr != 0):
        return intr, None
    model = distortion_model.strip()
    lengths = _DISTORTION_LENGTHS.get(model)
    if lengths is None:
        msg = (
            f"unsupported distortion model {distortion_model!r} with non-zero D "
            "(expected plumb_bob or rational_polynomial)"
        )
        raise CameraInfoError(msg)
    if d_arr.size not in lengths:
        msg = f"distortion model {model!r} needs {' or '.join(map(str, lengths))} coefficients, got {d_arr.size}"
        raise CameraInfoError(msg)
    cam = np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
    map1, map2 = cv2.initUndistortRectifyMap(cam, d_arr, None, cam, (width, height), cv2.CV_16SC2)
    return intr, Undistorter(map1=map1, map2=map2, width=width, height=height)


def check_info_matches(intrinsics: CameraIntrinsics, *, width: int, height: int) -> None:
    """Raise :class:`CameraInfoError` if a ``width`` x ``height`` image does not match ``intrinsics``."""
    if (int(width), int(height)) != (intrinsics.width, intrinsics.height):
        msg = (
            f"image size {width}x{height} does not match CameraInfo size "
            f"{intrinsics.width}x{intrinsics.height}"
        )
        raise CameraInfoError(msg)


# --------------------------------------------------------------------------- back-projection


class DepthProjector:
    """Back-projects depth images to camera-frame points (eq. (2)) with cached per-pixel rays.

    The rays ``(x/z, y/z)`` of every pixel are float32 ``(H, W)`` arrays built
    once per intrinsics/image size; :attr:`rebuild_count` counts rebuilds.
    ``stride`` > 1 subsamples rows and columns (pixel ``(v, u) = (i*stride, j*stride)``).
    """

    def __init__(self, intrinsics: CameraIntrinsics | None = None, *, stride: int = 1) -> None:
        if int(stride) < 1:
            msg = f"stride must be >= 1, got {stride}"
            raise ValueError(msg)
        self._stride = int(stride)
        self._intrinsics: CameraIntrinsics | None = None
        self._rx: F32 | None = None
        self._ry: F32 | None = None
        self._rebuilds = 0
        if intrinsics is not None:
            self.set_intrinsics(intrinsics)

    @property
    def stride(self) -> int:
        """Pixel subsampling step (1 = every pixel)."""
        return self._stride

    @property
    def intrinsics(self) -> CameraIntrinsics | None:
        """Intrinsics of the full-resolution depth image the rays were built for."""
        return self._intrinsics

    @property
    def rebuild_count(self) -> int:
        """Number of times the ray cache was (re)built."""
        return self._rebuilds

    @property
    def rays(self) -> tuple[F32, F32]:
        """Cached ``(x/z, y/z)`` ray images, float32, shape of the (subsampled) output."""
        if self._rx is None or self._ry is None:
            msg = "DepthProjector has no intrinsics yet"
            raise ValueError(msg)
        return self._rx, self._ry

    def set_intrinsics(self, intrinsics: CameraIntrinsics) -> bool:
        """Use ``intrinsics``; rebuilds the rays only if they changed.  Returns True on rebuild."""
        if intrinsics == self._intrinsics and self._rx is not None:
            return False
        s = self._stride
        u = np.arange(0, intrinsics.width, s, dtype=np.float64)
        v = np.arange(0, intrinsics.height, s, dtype=np.float64)
        rx = ((u - intrinsics.cx) / intrinsics.fx).astype(np.float32)
        ry = ((v - intrinsics.cy) / intrinsics.fy).astype(np.float32)
        self._rx = np.ascontiguousarray(np.broadcast_to(rx[None, :], (v.size, u.size)))
        self._ry = np.ascontiguousarray(np.broadcast_to(ry[:, None], (v.size, u.size)))
        self._intrinsics = intrinsics
        self._rebuilds += 1
        return True

    def points(self, depth_m: F32, *, out: F32 | None = None) -> F32:
        """Camera-frame points ``(H', W', 3)`` float32 (metres) of a depth image; NaN where depth is invalid.

        ``depth_m`` must be ``(H, W)`` matching the intrinsics (full resolution;
        it is subsampled here when ``stride`` > 1).  ``out`` may be a reusable
        float32 buffer of the output shape.
        """
        intr = self._intrinsics
        if intr is None or self._rx is None or self._ry is None:
            msg = "DepthProjector has no intrinsics; call set_intrinsics() first"
            raise ValueError(msg)
        if depth_m.ndim != 2 or depth_m.shape != (intr.height, intr.width):
            msg = f"depth image shape {depth_m.shape} does not match intrinsics {intr.width}x{intr.height}"
            raise ValueError(msg)
        z = depth_m if self._stride == 1 else depth_m[:: self._stride, :: self._stride]
        if z.dtype != np.float32:
            z = z.astype(np.float32)
        shape = (*self._rx.shape, 3)
        if out is None or out.shape != shape or out.dtype != np.float32:
            out = np.empty(shape, dtype=np.float32)
        jit = kernels.compiled()
        if jit is not None and out.flags.c_contiguous:  # one pass, bit for bit as the numpy code below (tested)
            jit.back_project(np.ascontiguousarray(z), self._rx, self._ry, out)
            return out
        with np.errstate(over="ignore", invalid="ignore"):
            np.multiply(z, self._rx, out=out[..., 0])
            np.multiply(z, self._ry, out=out[..., 1])
        out[..., 2] = z
        return out
