"""Reading recorded sessions (ROS 2 MCAP / SQLite3 rosbag2, ROS 1 bags) for offline processing and replay.

Pure Python (``rosbags`` + ``mcap``, no rclpy).  Entry points:

* :func:`find_recordings` — the recordings under a path (a file, a rosbag2 folder,
  or a folder of several recordings), sorted by start time.
* :func:`open_recording` — open one recording, detect its depth and CameraInfo
  topics and return a :class:`Recording` with :meth:`Recording.iter_frames`
  (depth images paired with camera calibration) and :meth:`Recording.iter_raw`
  (every message as CDR bytes, for replay).

Accepted inputs: a bare ``.mcap`` (with or without rosbag2 ``metadata.yaml``
beside it), a rosbag2 folder (MCAP or SQLite3 storage, optionally zstd
compressed), a bare ``.db3``, a ROS 1 ``.bag`` (v2.0, indexed), or a folder of
several of those.  Formats are recognised by their magic bytes, not only by the
file suffix.

A truncated or otherwise damaged MCAP (e.g. the recorder was killed) is read
with the ``mcap`` library's streaming reader up to the first damaged record;
a :class:`RecordingWarning` reports how many messages were recovered.

Every user-input problem (missing path, unknown format, corrupt file, no depth
topic, bad override, empty recording, bad camera YAML) raises
:class:`RecordingError` with a message naming the file and the problem; no raw
library exception escapes for those.

Depth images are delivered undecoded (``encoding``, ``width``, ``height``,
``step``, ``is_bigendian``, ``data``) for ``walker_gait.core.depth.decode_depth``,
except image_transport ``compressedDepth`` messages, which are decoded here to
16UC1 / 32FC1 numpy arrays (:func:`decode_compressed_depth`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import os
import struct
import sys
import warnings
from collections.abc import Callable, Collection, Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO, NamedTuple

import numpy as np
from numpy.typing import NDArray

from walker_gait.io.camera_yaml import CameraInfoData, CameraYamlError, load_camera_info_yaml

__all__ = [
    "CAMERA_INFO_TYPE",
    "COMPRESSED_IMAGE_TYPE",
    "DEPTH_ENCODINGS",
    "IMAGE_TYPE",
    "CameraInfoData",
    "CompressedDepthError",
    "DepthFrame",
    "RawMessage",
    "Recording",
    "RecordingError",
    "RecordingWarning",
    "TopicSummary",
    "decode_compressed_depth",
    "decode_rvl",
    "find_recordings",
    "open_recording",
    "pair_camera_info_topic",
    "select_depth_topic",
]

IMAGE_TYPE = "sensor_msgs/msg/Image"
COMPRESSED_IMAGE_TYPE = "sensor_msgs/msg/CompressedImage"
CAMERA_INFO_TYPE = "sensor_msgs/msg/CameraInfo"

DEPTH_ENCODINGS: frozenset[str] = frozenset({"16UC1", "mono16", "32FC1"})
"""Image encodings that are treated as depth during auto-detection."""

# Encodings that can never be a depth image (colour, 8-bit, multi-channel, Bayer, YUV).
_NON_DEPTH_PREFIXES = ("rgb", "bgr", "mono8", "bayer_", "yuv", "uyvy", "yuyv", "nv21", "nv24", "8U", "8S")

_MCAP_MAGIC = b"\x89MCAP0\r\n"
_SQLITE_MAGIC = b"SQLite format 3\x00"
_ROS1_MAGIC = b"#ROSBAG V"
_RECORDING_SUFFIXES = (".mcap", ".db3", ".bag")
_MSGTYPE_RENAMES = {"tf/msg/tfMessage": "tf2_msgs/msg/TFMessage"}  # as rosbags.convert does
_MAX_FRAME_WARNINGS = 5


class RecordingError(Exception):
    """A recording cannot be opened or read; the message names the file and the problem."""


class RecordingWarning(UserWarning):
    """A recording was read only partially or with an assumption worth knowing about."""


class CompressedDepthError(ValueError):
    """A ``compressedDepth`` message cannot be decoded."""


@dataclass(frozen=True, kw_only=True)
class TopicSummary:
    """One topic of a recording.

    Attributes:
        name: Topic name.
        msgtype: ROS 2 style message type (``sensor_msgs/msg/Image``; ROS 1 names are normalised).
        count: Number of messages (for a recovered truncated MCAP: the readable ones).
        encoding: For Image topics the ``encoding`` of the first message, for CompressedImage the
            ``format`` string; ``None`` otherwise or when the topic has no messages.
    """

    name: str
    msgtype: str
    count: int
    encoding: str | None = None


@dataclass(frozen=True, kw_only=True)
class DepthFrame:
    """One depth image with its calibration, undecoded (see ``core.depth.decode_depth``).

    ``data`` is a zero-copy ``uint8`` view of the message buffer for raw Images; for
    ``compressedDepth`` messages it is the decoded ``(height, width)`` ``uint16`` (16UC1, mm)
    or ``float32`` (32FC1, metres, NaN invalid) array in native byte order, and ``step``,
    ``is_bigendian`` describe that array.
    """

    stamp: float  # seconds, image header clock (log time when the header stamp is zero)
    stamp_ns: int
    encoding: str
    width: int
    height: int
    step: int
    is_bigendian: bool
    data: bytes | NDArray[Any]
    frame_id: str
    camera_info: CameraInfoData | None
    log_time_ns: int = 0  # time the recorder received the message
    topic: str = ""


class RawMessage(NamedTuple):
    """One message for replay: CDR bytes (``\\x00\\x01`` little-endian encapsulation for ROS 1 sources)."""

    topic: str
    msgtype: str
    stamp_ns: int  # log (receive) time in nanoseconds
    data: bytes


# ---------------------------------------------------------------------------------------------
# compressedDepth codec
# ---------------------------------------------------------------------------------------------

_CONFIG_HEADER = struct.Struct("<iff")  # compressionFormat (enum, int32), float depthParam[2]


def decode_compressed_depth(data: bytes | memoryview | NDArray[np.uint8], *, fmt: str) -> tuple[str, NDArray[Any]]:
    """Decode an image_transport ``compressedDepth`` payload.

    The payload is a 12-byte ``ConfigHeader`` (int32 format, float32 depthParam[2]) followed by
    a 16-bit image, PNG or (format ``"...; compressedDepth rvl"``, the codec's other ``format`` option) RVL
    (:func:`decode_rvl`).  For 16-bit encodings the image holds the depth (mm); for 32-bit encodings it
    holds quantised inverse depth: ``depth = depthParam[0] / (value - depthParam[1])`` for ``value != 0``,
    NaN otherwise.

    Args:
        data: The ``CompressedImage.data`` bytes.
        fmt: The ``CompressedImage.format`` string, e.g. ``"16UC1; compressedDepth png"``,
            ``"32FC1; compressedDepth rvl"`` or ``"32FC1; compressedDepth"``.

    Returns:
        ``("16UC1", uint16 HxW)`` or ``("32FC1", float32 HxW metres, NaN invalid)``.

    Raises:
        CompressedDepthError: unsupported format (non-depth encoding) or corrupt data.
    """
    import cv2  # local: only needed for compressed topics

    head, sep, tail = fmt.partition(";")
    encoding = head.strip() if sep else ""
    rvl = "rvl" in tail.strip().lower().split()
    buf = np.frombuffer(data, dtype=np.uint8)
    if buf.size <= _CONFIG_HEADER.size:
        msg = f"compressedDepth payload too short ({buf.size} bytes)"
        raise CompressedDepthError(msg)
    _fmt_enum, quant_a, quant_b = _CONFIG_HEADER.unpack_from(buf, 0)
    if not encoding:  # very old publishers: format without "; compressedDepth"; guess from the header
        encoding = "32FC1" if quant_a != 0.0 else "16UC1"
    bits = _encoding_bit_depth(encoding)
    if bits not in (16, 32):
        msg = f"compressedDepth needs a 16- or 32-bit single-channel encoding, got {encoding!r}"
        raise CompressedDepthError(msg)
    if rvl:
        img = decode_rvl(buf[_CONFIG_HEADER.size :])
        return ("16UC1", img) if bits == 16 else ("32FC1", _from_inverse_depth(img, quant_a, quant_b))
    try:
        img = cv2.imdecode(buf[_CONFIG_HEADER.size :], cv2.IMREAD_UNCHANGED)
    except cv2.error as exc:
        msg = f"compressedDepth PNG cannot be decoded: {exc}"
        raise CompressedDepthError(msg) from None
    if img is None or img.ndim != 2 or img.dtype != np.uint16 or img.size == 0:
        what = "undecodable" if img is None else f"{img.dtype} {img.shape}"
        msg = f"compressedDepth payload is not a single-channel 16-bit PNG ({what})"
        raise CompressedDepthError(msg)
    if bits == 16:
        return "16UC1", img
    return "32FC1", _from_inverse_depth(img, quant_a, quant_b)


def _from_inverse_depth(img: NDArray[np.uint16], quant_a: float, quant_b: float) -> NDArray[np.float32]:
    """Metres (NaN invalid) from the codec's quantised inverse depth (0 = invalid)."""
    inv = img.astype(np.float32)
    with np.errstate(divide="ignore", invalid="ignore"):
        depth = np.float32(quant_a) / (inv - np.float32(quant_b))
    depth[img == 0] = np.nan
    return depth.astype(np.float32, copy=False)


_RVL_SIZE = struct.Struct("<II")  # cols, rows
_RVL_NIBBLE_SHIFTS = np.arange(28, -1, -4, dtype=np.uint32)  # nibbles of a word, most significant first
_RVL_MAX_NIBBLES = 11  # a value of up to 32 bits: 11 nibbles of 3 payload bits
_RVL_MAX_SIDE = 16384  # pixels per row or column; depth sensors are far below (a corrupt header is caught here)


def decode_rvl(payload: NDArray[np.uint8]) -> NDArray[np.uint16]:
    """Decode an RVL image (A. D. Wilson, "Fast lossless depth image compression", ISS 2017) as image_transport's
    ``compressedDepth`` codec writes it after its ConfigHeader: uint32 cols, uint32 rows (little-endian), then
    32-bit little-endian words of 4-bit nibbles, most significant nibble first.  Values are variable-length
    integers (3 payload bits per nibble, least significant first, high bit = more to come) forming runs of
    ``zeros, nonzeros, nonzeros x zigzag delta`` from the previous non-zero pixel (row-major).

    Vectorised: nibbles and values with numpy, one Python iteration per run of non-zero pixels.

    Raises:
        CompressedDepthError: a zero or implausible size, or a stream that ends early or overruns the image.
    """
    buf = np.asarray(payload, dtype=np.uint8).reshape(-1)
    if buf.size < _RVL_SIZE.size:
        msg = f"compressedDepth RVL payload too short ({buf.size} bytes)"
        raise CompressedDepthError(msg)
    cols, rows = _RVL_SIZE.unpack_from(buf, 0)
    n = rows * cols
    # no ratio test: a blank frame (one zero run) is 12 bytes for any size.  The size only has to be sane; the
    # stream walk below must then cover exactly these pixels before anything of that size is allocated.
    if n == 0 or cols > _RVL_MAX_SIDE or rows > _RVL_MAX_SIDE:
        msg = f"compressedDepth RVL payload has an implausible size {cols}x{rows} for {buf.size} bytes"
        raise CompressedDepthError(msg)
    body = buf[_RVL_SIZE.size :]
    words = np.frombuffer(body[: body.size // 4 * 4].tobytes(), dtype="<u4")
    nib = ((words[:, None] >> _RVL_NIBBLE_SHIFTS) & 0xF).astype(np.int64).reshape(-1)
    ends = np.flatnonzero(nib < 8)  # last nibble of each value
    starts = np.concatenate(([0], ends[:-1] + 1)).astype(np.int64)
    lengths = ends - starts + 1
    if lengths.size and int(lengths.max()) > _RVL_MAX_NIBBLES:
        msg = "compressedDepth RVL stream is corrupt (a value longer than 32 bits)"
        raise CompressedDepthError(msg)
    m = int(ends[-1]) + 1 if ends.size else 0
    shift = 3 * (np.arange(m, dtype=np.int64) - np.repeat(starts, lengths))
    vals = np.add.reduceat((nib[:m] & 7) << shift, starts) if m else np.zeros(0, np.int64)
    # runs: zeros, nonzeros, then that many deltas; the loop only walks the run headers
    run_pos: list[int] = []
    run_len: list[int] = []
    delta_from: list[int] = []
    pos = i = 0
    nv = int(vals.size)
    while pos < n:
        if i + 2 > nv:
            msg = f"compressedDepth RVL stream ends after {pos} of {n} pixels"
            raise CompressedDepthError(msg)
        zeros, nonzeros = int(vals[i]), int(vals[i + 1])
        i += 2
        pos += zeros
        if pos + nonzeros > n or i + nonzeros > nv:
            msg = f"compressedDepth RVL stream overruns the {cols}x{rows} image or ends early"
            raise CompressedDepthError(msg)
        if nonzeros:
            run_pos.append(pos)
            run_len.append(nonzeros)
            delta_from.append(i)
        i += nonzeros
        pos += nonzeros
    out = np.zeros(n, dtype=np.uint16)
    if run_len:
        lens = np.asarray(run_len, dtype=np.int64)
        offs = np.arange(int(lens.sum()), dtype=np.int64) - np.repeat(np.cumsum(lens) - lens, lens)
        positive = vals[np.repeat(np.asarray(delta_from, dtype=np.int64), lens) + offs]
        delta = (positive >> 1) ^ -(positive & 1)
        out[np.repeat(np.asarray(run_pos, dtype=np.int64), lens) + offs] = (np.cumsum(delta) & 0xFFFF).astype(np.uint16)
    return out.reshape(rows, cols)


def _encoding_bit_depth(encoding: str) -> int:
    """Bit depth of a single-channel ROS image encoding (0 when not single-channel)."""
    enc = encoding.strip()
    if enc in ("mono16", "16UC1", "16SC1"):
        return 16
    if enc in ("32FC1", "32SC1"):
        return 32
    return 0


def _is_non_depth_encoding(encoding: str) -> bool:
    enc = encoding.strip()
    return enc.startswith(_NON_DEPTH_PREFIXES) or (len(enc) > 2 and enc[-2] == "C" and enc[-1] not in "1")


# ---------------------------------------------------------------------------------------------
# Typestores
# ---------------------------------------------------------------------------------------------


@functools.cache
def _jazzy_fielddefs() -> Mapping[str, Any]:
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_JAZZY).fielddefs


def _parse_definitions(defs: Iterable[tuple[str, str, str]], warn: Callable[[str], None]) -> dict[str, Any]:
    """Parse ``(msgtype, format, text)`` definitions (format ``msg`` or ``idl``) into rosbags typedefs."""
    from rosbags.typesys import get_types_from_idl, get_types_from_msg

    typs: dict[str, Any] = {}
    for msgtype, fmt, text in defs:
        try:
            if fmt == "msg":
                typs.update(get_types_from_msg(text, msgtype))
            elif fmt == "idl":
                sep = "=" * 80 + "\n"
                if text.startswith(f"{sep}IDL: "):
                    for part in text.split(sep)[1:]:
                        _hdr, idl = part.split("\n", 1)
                        typs.update(get_types_from_idl(idl))
                else:
                    typs.update(get_types_from_idl(text))
        except Exception as exc:  # noqa: BLE001 - a bad embedded definition must not abort reading
            warn(f"cannot parse the embedded definition of {msgtype}: {exc}")
    return typs


def _make_typestore(typs: Mapping[str, Any], needed: Collection[str]) -> Any:
    """Typestore with the recording's own definitions, completed from ROS 2 Jazzy's for missing types."""
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.EMPTY)
    merged = dict(typs)
    jazzy = _jazzy_fielddefs()
    missing = [t for t in needed if t not in merged]
    if missing:
        # Pull the missing types and everything they reference from the Jazzy definitions.
        stack = list(missing)
        while stack:
            name = stack.pop()
            if name in merged or name not in jazzy:
                continue
            merged[name] = jazzy[name]
            stack.extend(_referenced_types(jazzy[name]))
    with contextlib.suppress(Exception):
        store.register(merged)
        return store
    # A conflicting embedded definition: fall back to the full Jazzy store plus new names only.
    store = get_typestore(Stores.ROS2_JAZZY)
    with contextlib.suppress(Exception):
        store.register({k: v for k, v in typs.items() if k not in store.fielddefs})
    return store


def _referenced_types(fielddef: Any) -> list[str]:
    """Message type names referenced by a rosbags field definition ``(consts, fields)``."""
    out: list[str] = []

    def walk(desc: Any) -> None:
        kind = int(desc[0])
        if kind == 2:  # Nodetype.NAME
            out.append(desc[1])
        elif kind in (3, 4):  # ARRAY, SEQUENCE
            walk(desc[1][0])

    for _name, desc in fielddef[1]:
        walk(desc)
    return out


# ---------------------------------------------------------------------------------------------
# Sources (one per storage backend); each iteration opens its own reader, nothing is held open
# ---------------------------------------------------------------------------------------------


class _Source:
    """A readable recording: topic table, typestore and a message iterator."""

    path: Path
    storage: str
    is_ros1: bool
    topics: dict[str, tuple[str, int]]  # name -> (msgtype, count)
    start_ns: int | None
    end_ns: int | None
    warnings: list[str]
    recovered_messages: int | None = None  # set when a damaged file was read partially
    typestore: Any
    _typs: dict[str, Any]  # the recording's own message definitions
    _cdr_store: Any = None  # ROS 1 sources: typestore that converts to CDR (built on first use)

    def _warn(self, text: str) -> None:
        self.warnings.append(text)

    @property
    def message_count(self) -> int:
        return sum(c for _t, c in self.topics.values())

    def messages(self, topics: Collection[str] | None) -> Iterator[tuple[str, str, int, bytes]]:
        """Yield ``(topic, msgtype, log_time_ns, raw)`` in log-time order; raw is CDR (ROS 2) or ROS 1."""
        raise NotImplementedError

    def _build_typestore(self, needed: Collection[str]) -> None:
        """``typestore`` from the recording's definitions ``_typs``: as they are for ROS 1 (its Header has
        ``seq``), completed from ROS 2 Jazzy's for ROS 2."""
        if self.is_ros1:
            from rosbags.typesys import Stores, get_typestore

            self.typestore = get_typestore(Stores.EMPTY)
            try:
                self.typestore.register(self._typs)
            except Exception as exc:
                raise self._fail("cannot build message types from the recording's definitions", exc) from None
        else:
            self.typestore = _make_typestore(self._typs, needed)

    def deserialize(self, raw: bytes, msgtype: str) -> Any:
        if self.is_ros1:
            return self.typestore.deserialize_ros1(raw, msgtype)
        return self.typestore.deserialize_cdr(raw, msgtype)

    def to_cdr(self, raw: bytes, msgtype: str) -> bytes:
        """CDR bytes of a message (identity for ROS 2 sources)."""
        if not self.is_ros1:
            return raw
        if self._cdr_store is None:
            # ROS 1 definitions with the ROS 2 std_msgs/Header (no seq), as rosbags.convert does;
            # rosbags' ros1_to_cdr drops the seq field when converting a Header.
            from rosbags.typesys import Stores, get_typestore

            store = get_typestore(Stores.EMPTY)
            store.register({**self._typs, "std_msgs/msg/Header": _jazzy_fielddefs()["std_msgs/msg/Header"]})
            self._cdr_store = store
        return bytes(self._cdr_store.ros1_to_cdr(raw, msgtype))

    def _fail(self, text: str, exc: BaseException | None = None) -> RecordingError:
        detail = f": {exc}" if exc is not None and str(exc) else (f": {type(exc).__name__}" if exc else "")
        return RecordingError(f"{self.path}: {text}{detail}")


class _RosbagsSource(_Source):
    """rosbag2 folder / bare .mcap / bare .db3 (``rosbags.rosbag2.Reader``) or ROS 1 bag (``rosbags.rosbag1``)."""

    def __init__(self, path: Path, *, storage: str, ros1: bool) -> None:
        self.path = path
        self.storage = storage
        self.is_ros1 = ros1
        self.warnings = []
        with self._reader() as reader:
            conns = list(reader.connections)
            counts: dict[str, int] = {}
            types: dict[str, str] = {}
            for conn in conns:
                types.setdefault(conn.topic, conn.msgtype)
                if types[conn.topic] != conn.msgtype:
                    self._warn(f"topic {conn.topic} has several types; using {types[conn.topic]}")
                    continue
                counts[conn.topic] = counts.get(conn.topic, 0) + int(conn.msgcount)
            self.topics = {t: (types[t], counts.get(t, 0)) for t in sorted(types)}
            count = sum(counts.values())
            self.start_ns = int(reader.start_time) if count else None
            self.end_ns = int(reader.end_time) - 1 if count else None
            defs = [
                (c.msgtype, c.msgdef.format.name.lower(), c.msgdef.data)
                for c in conns
                if c.msgdef.format.name != "NONE" and c.msgdef.data
            ]
        self._typs = _parse_definitions(defs, self._warn)
        self._build_typestore({t for t, _c in self.topics.values()})

    @contextlib.contextmanager
    def _reader(self) -> Iterator[Any]:
        """Open a fresh rosbags reader, converting library errors to :class:`RecordingError`."""
        try:
            if self.is_ros1:
                from rosbags.rosbag1 import Reader as Reader1

                reader: Any = Reader1(self.path)
            else:
                from rosbags.rosbag2 import Reader as Reader2

                reader = Reader2(self.path)
            reader.open()
        except RecordingError:
            raise
        except Exception as exc:
            raise self._fail(f"cannot read {self.storage} recording", exc) from None
        try:
            yield reader
        finally:
            with contextlib.suppress(Exception):
                reader.close()

    def messages(self, topics: Collection[str] | None) -> Iterator[tuple[str, str, int, bytes]]:
        with self._reader() as reader:
            conns = [c for c in reader.connections if topics is None or c.topic in topics]
            conns = [c for c in conns if self.topics.get(c.topic, ("", 0))[0] == c.msgtype]
            if not conns:
                return
            n = 0
            it = iter(reader.messages(connections=conns))
            while True:
                try:
                    conn, stamp, raw = next(it)
                except StopIteration:
                    return
                except Exception as exc:
                    raise self._fail(f"read error after {n} messages (file corrupt?)", exc) from None
                n += 1
                yield conn.topic, conn.msgtype, int(stamp), raw


class _StrictIO:
    """File wrapper whose ``read(n)`` raises :class:`_Truncated` instead of returning short data."""

    def __init__(self, f: BinaryIO) -> None:
        self._f = f
        self.pos = 0

    def read(self, n: int = -1) -> bytes:
        data = self._f.read(n)
        if n is not None and n >= 0 and len(data) < n:
            raise _Truncated(self.pos + len(data))
        self.pos += len(data)
        return data


class _Truncated(Exception):
    def __init__(self, offset: int) -> None:
        super().__init__(f"file ends unexpectedly at byte {offset}")
        self.offset = offset


@dataclass
class _ScanState:
    clean: bool = False  # footer reached
    data_end: bool = False  # all data records read (summary may be damaged)
    error: str | None = None
    offset: int = 0


class _StreamMcapSource(_Source):
    """Lenient MCAP reading with the ``mcap`` library's streaming reader (truncated/unindexed files).

    Reads records in file order up to the first damaged one; messages of each chunk are sorted by
    log time (chunks themselves are assumed to be in order, as rosbag2 writes them).
    """

    def __init__(self, paths: list[Path], *, display_path: Path, storage: str, reason: str | None) -> None:
        self.path = display_path
        self._paths = paths
        self.storage = storage
        self.is_ros1 = False
        self._encoding: str | None = None  # "cdr" (ROS 2 profile) or "ros1" (ROS 1 profile, e.g. `mcap convert`)
        self.warnings = []
        self._schemas: dict[tuple[int, int], tuple[str, str, bytes]] = {}
        self._channels: dict[tuple[int, int], tuple[str, str]] = {}  # (file, id) -> (topic, msgtype)
        counts: dict[str, int] = {}
        types: dict[str, str] = {}
        start: int | None = None
        end: int | None = None
        out_of_order = False
        skipped_enc: set[str] = set()
        self._states: list[_ScanState] = []
        for fidx, p in enumerate(paths):
            state = _ScanState()
            last = -1
            for kind, rec in self._records(fidx, p, state):
                if kind == "channel":
                    topic, encoding, schema_id = rec.topic, rec.message_encoding, rec.schema_id
                    if self._encoding is None and encoding in ("cdr", "ros1"):
                        self._encoding = encoding  # the first ROS channel decides: ROS 2 or ROS 1 profile
                        self.is_ros1 = encoding == "ros1"
                    if encoding != self._encoding:
                        skipped_enc.add(f"{topic} ({encoding})")
                        continue
                    schema = self._schemas.get((fidx, schema_id))
                    msgtype = _ros2_msgtype(schema[0]) if schema else ""
                    if not msgtype:
                        skipped_enc.add(f"{topic} (no schema)")
                        continue
                    self._channels[(fidx, rec.id)] = (topic, msgtype)
                    types.setdefault(topic, msgtype)
                elif kind == "messages":
                    for m in rec:
                        ch = self._channels.get((fidx, m.channel_id))
                        if ch is None:
                            continue
                        counts[ch[0]] = counts.get(ch[0], 0) + 1
                        start = m.log_time if start is None else min(start, m.log_time)
                        end = m.log_time if end is None else max(end, m.log_time)
                    if rec:
                        first = min(m.log_time for m in rec)
                        out_of_order |= first < last
                        last = max(last, max(m.log_time for m in rec))
            self._states.append(state)
        self.topics = {t: (types[t], counts.get(t, 0)) for t in sorted(types)}
        self.start_ns, self.end_ns = start, end
        total = sum(counts.values())
        if skipped_enc:
            kind = "ROS 1" if self.is_ros1 else "CDR"
            self._warn(f"ignoring non-{kind} topics: {', '.join(sorted(skipped_enc))}")
        if out_of_order:
            self._warn("MCAP chunks are not in log-time order; messages are delivered in file order")
        damaged = [(p, s) for p, s in zip(paths, self._states, strict=True) if s.error]
        self.recovered_messages = total if damaged else None
        if damaged:
            where = "; ".join(
                f"{p.name}: {s.error}" + (" (after the data section)" if s.data_end else "") for p, s in damaged
            )
            why = f" ({reason})" if reason else ""
            self._warn(
                f"MCAP is truncated or damaged{why}: {where}; recovered {total} "
                f"message(s) from the readable part ("
                + ", ".join(f"{t}: {c}" for t, (_m, c) in self.topics.items())
                + ")"
            )
        elif reason:
            self._warn(f"read with the streaming MCAP reader ({reason})")
        defs = []
        formats = {"ros1msg": "msg"} if self.is_ros1 else {"ros2msg": "msg", "ros2idl": "idl", "omgidl": "idl"}
        for _key, (name, enc, data) in self._schemas.items():
            fmt = formats.get(enc)
            if fmt:
                defs.append((_ros2_msgtype(name), fmt, data.decode("utf-8", errors="replace")))
        self._typs = _parse_definitions(defs, self._warn)
        self._build_typestore(set(types.values()))

    def _records(self, fidx: int, path: Path, state: _ScanState) -> Iterator[tuple[str, Any]]:
        """Yield ``("channel", Channel)`` / ``("messages", [Message])`` up to the first damaged record."""
        from mcap.records import Channel, Chunk, DataEnd, Footer, Message, Schema
        from mcap.stream_reader import StreamReader, breakup_chunk

        try:
            f = path.open("rb")
        except OSError as exc:
            raise self._fail(f"cannot open {path}", exc) from None
        with f:
            sio = _StrictIO(f)
            size = max(1, path.stat().st_size)
            try:
                reader = StreamReader(sio, emit_chunks=True, record_size_limit=size)  # type: ignore[arg-type]
                for rec in reader.records:
                    if isinstance(rec, Schema):
                        self._schemas[(fidx, rec.id)] = (rec.name, rec.encoding, rec.data)
                    elif isinstance(rec, Channel):
                        yield "channel", rec
                    elif isinstance(rec, Message):
                        yield "messages", [rec]
                    elif isinstance(rec, Chunk):
                        inner = breakup_chunk(rec, validate_crc=True)
                        msgs: list[Any] = []
                        for sub in inner:
                            if isinstance(sub, Schema):
                                self._schemas[(fidx, sub.id)] = (sub.name, sub.encoding, sub.data)
                            elif isinstance(sub, Channel):
                                yield "channel", sub
                            elif isinstance(sub, Message):
                                msgs.append(sub)
                        msgs.sort(key=lambda m: m.log_time)
                        yield "messages", msgs
                    elif isinstance(rec, DataEnd):
                        state.data_end = True
                    elif isinstance(rec, Footer):
                        state.clean = True
            except Exception as exc:  # noqa: BLE001 - any damage ends the readable part
                if not state.clean:
                    state.error = str(exc) or type(exc).__name__
                    state.offset = sio.pos

    def messages(self, topics: Collection[str] | None) -> Iterator[tuple[str, str, int, bytes]]:
        for fidx, p in enumerate(self._paths):
            state = _ScanState()
            for kind, rec in self._records(fidx, p, state):
                if kind != "messages":
                    continue
                for m in rec:
                    ch = self._channels.get((fidx, m.channel_id))
                    if ch is None or (topics is not None and ch[0] not in topics):
                        continue
                    yield ch[0], ch[1], int(m.log_time), m.data


def _ros2_msgtype(name: str) -> str:
    """``pkg/msg/Type`` from a ROS 1 schema name ``pkg/Type`` (ROS 2 names pass through)."""
    parts = name.split("/")
    return f"{parts[0]}/msg/{parts[1]}" if len(parts) == 2 else name


# ---------------------------------------------------------------------------------------------
# Opening
# ---------------------------------------------------------------------------------------------


def _magic(path: Path) -> bytes:
    try:
        with path.open("rb") as f:
            return f.read(16)
    except OSError as exc:
        msg = f"{path}: cannot read file ({exc.strerror or exc})"
        raise RecordingError(msg) from None


def _mcap_profile(path: Path) -> str | None:
    """The profile of an MCAP file's Header record (``ros1``, ``ros2``, ``""``); None when unreadable."""
    try:
        with path.open("rb") as f:
            head = f.read(len(_MCAP_MAGIC) + 13)
            if len(head) < len(_MCAP_MAGIC) + 13 or head[len(_MCAP_MAGIC)] != 0x01:  # opcode 0x01 = Header
                return None
            (n,) = struct.unpack_from("<I", head, len(_MCAP_MAGIC) + 9)
            return f.read(min(n, 256)).decode("utf-8", errors="replace")
    except OSError:
        return None


def _rosbag2_storage(folder: Path) -> tuple[str, list[Path]]:
    """Storage id and storage files listed in a rosbag2 ``metadata.yaml`` (best effort)."""
    import yaml

    try:
        doc = yaml.safe_load((folder / "metadata.yaml").read_text(encoding="utf-8"))
        info = doc["rosbag2_bagfile_information"]
        files = [folder / Path(x).name for x in info.get("relative_file_paths", [])]
        return str(info.get("storage_identifier", "")), files
    except Exception:  # noqa: BLE001
        return "", []


def _open_source(path: Path) -> _Source:
    """Open ``path`` (a single recording) with the right backend."""
    if not path.exists():
        msg = f"{path}: no such file or directory"
        raise RecordingError(msg)
    if path.is_file() and path.name == "metadata.yaml":
        path = path.parent
    if path.is_dir():
        if not (path / "metadata.yaml").is_file():
            recs = find_recordings(path)
            if len(recs) == 1:
                return _open_source(recs[0])
            names = ", ".join(str(r) for r in recs)
            msg = (
                f"{path}: folder contains {len(recs)} recordings ({names}); open them one at a time "
                "(find_recordings() lists them in time order)"
            )
            raise RecordingError(msg)
        storage_id, files = _rosbag2_storage(path)
        storage = f"rosbag2/{storage_id or 'unknown'}"
        try:
            return _RosbagsSource(path, storage=storage, ros1=False)
        except RecordingError as err:
            mcaps = [f for f in files if f.suffix == ".mcap" and f.is_file()] or sorted(path.glob("*.mcap"))
            if storage_id not in ("", "mcap") or not mcaps:
                raise
            return _lenient_mcap(mcaps, display=path, storage=storage, reason=str(err).split(": ", 1)[-1])
    if not path.is_file():
        msg = f"{path}: not a regular file or folder"
        raise RecordingError(msg)
    magic = _magic(path)
    if not magic:
        msg = f"{path}: file is empty"
        raise RecordingError(msg)
    if magic.startswith(_MCAP_MAGIC):
        _warn_if_split_part(path)
        if _mcap_profile(path) == "ros1":  # e.g. `mcap convert` of a ROS 1 bag; rosbags reads ROS 2 profiles only
            return _lenient_mcap([path], display=path, storage="mcap/ros1", reason=None)
        if path.suffix != ".mcap":
            return _lenient_mcap([path], display=path, storage="mcap", reason=None)
        try:
            return _RosbagsSource(path, storage="mcap", ros1=False)
        except RecordingError as err:
            return _lenient_mcap([path], display=path, storage="mcap", reason=str(err).split(": ", 1)[-1])
    if magic.startswith(_SQLITE_MAGIC):
        if path.suffix != ".db3":
            msg = f"{path}: looks like a rosbag2 SQLite3 file but the name does not end in .db3; rename it"
            raise RecordingError(msg)
        _warn_if_split_part(path)
        return _RosbagsSource(path, storage="sqlite3", ros1=False)
    if magic.startswith(_ROS1_MAGIC):
        if not magic.startswith(b"#ROSBAG V2.0"):
            version = magic[len(_ROS1_MAGIC) :].split(b"\n")[0].decode("ascii", "replace")
            msg = f"{path}: ROS 1 bag version {version} is not supported (need 2.0)"
            raise RecordingError(msg)
        try:
            return _RosbagsSource(path, storage="ros1", ros1=True)
        except RecordingError as err:
            if "not indexed" in str(err):
                msg = f"{path}: ROS 1 bag is not indexed (recording interrupted?); run `rosbag reindex` on it"
                raise RecordingError(msg) from None
            raise
    msg = (
        f"{path}: unknown recording format (not MCAP, rosbag2 SQLite3 or ROS 1 bag; "
        f"file starts with {magic[:8]!r})"
    )
    raise RecordingError(msg)


def _lenient_mcap(paths: list[Path], *, display: Path, storage: str, reason: str | None) -> _Source:
    try:
        source = _StreamMcapSource(paths, display_path=display, storage=storage, reason=reason)
    except RecordingError:
        raise
    except Exception as exc:
        msg = f"{display}: cannot read MCAP: {exc}"
        raise RecordingError(msg) from None
    if not source.topics:
        why = f" ({reason})" if reason else ""
        state = source._states[0] if source._states else None  # noqa: SLF001
        detail = f"; {state.error}" if state and state.error else ""
        msg = f"{display}: corrupt or truncated MCAP, nothing readable{why}{detail}"
        raise RecordingError(msg)
    return source


def _warn_if_split_part(path: Path) -> None:
    meta = path.parent / "metadata.yaml"
    if meta.is_file():
        _sid, files = _rosbag2_storage(path.parent)
        if len(files) > 1:
            warnings.warn(
                f"{path}: is one of {len(files)} files of the rosbag2 recording {path.parent}; "
                "open the folder to read all of it",
                RecordingWarning,
                stacklevel=4,
            )


def _quick_start_ns(path: Path) -> int | None:
    """Start time of a recording for sorting, or ``None`` when it cannot be determined cheaply."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            if path.is_dir():
                return _RosbagsSource(path, storage="rosbag2", ros1=False).start_ns
            magic = _magic(path)
            if magic.startswith(_ROS1_MAGIC):
                return _RosbagsSource(path, storage="ros1", ros1=True).start_ns
            if magic.startswith(_SQLITE_MAGIC) or (magic.startswith(_MCAP_MAGIC) and path.suffix == ".mcap"):
                return _RosbagsSource(path, storage="rosbag2", ros1=False).start_ns
        except Exception:  # noqa: BLE001 - fall through to the streaming MCAP probe
            pass
        with contextlib.suppress(Exception):
            if _magic(path).startswith(_MCAP_MAGIC):
                from mcap.records import Chunk, Message
                from mcap.stream_reader import StreamReader

                with path.open("rb") as f:
                    for rec in StreamReader(_StrictIO(f), emit_chunks=True).records:  # type: ignore[arg-type]
                        if isinstance(rec, Message):
                            return int(rec.log_time)
                        if isinstance(rec, Chunk):
                            return int(rec.message_start_time)
    return None


def find_recordings(path: str | os.PathLike[str]) -> list[Path]:
    """List the recordings at ``path``, sorted by start time (then name).

    A file or a rosbag2 folder (with ``metadata.yaml``) is one recording.  Any other folder is
    searched recursively for rosbag2 folders and ``*.mcap`` / ``*.db3`` / ``*.bag`` files (files
    inside a rosbag2 folder belong to it and are not listed separately).

    Raises:
        RecordingError: ``path`` does not exist, or the folder contains no recording.
    """
    root = Path(path)
    if not root.exists():
        msg = f"{root}: no such file or directory"
        raise RecordingError(msg)
    if root.is_file():
        return [root.parent if root.name == "metadata.yaml" else root]
    if (root / "metadata.yaml").is_file():
        return [root]
    found: list[Path] = []
    for dirpath, dirnames, filenames in os.walk(root):
        here = Path(dirpath)
        dirnames[:] = sorted(d for d in dirnames if not d.startswith("."))
        if here != root and "metadata.yaml" in filenames:
            found.append(here)
            dirnames[:] = []
            continue
        found.extend(here / f for f in sorted(filenames) if f.endswith(_RECORDING_SUFFIXES))
    if not found:
        msg = f"{root}: no recordings found (looked for rosbag2 folders and *.mcap, *.db3, *.bag files)"
        raise RecordingError(msg)
    starts = {p: _quick_start_ns(p) for p in found}
    return sorted(found, key=lambda p: (starts[p] is None, starts[p] or 0, str(p)))


# ---------------------------------------------------------------------------------------------
# Topic selection
# ---------------------------------------------------------------------------------------------


def _is_depth_candidate(t: TopicSummary) -> bool:
    if t.count <= 0 or t.encoding is None:
        return False
    if t.msgtype == IMAGE_TYPE:
        return t.encoding.strip() in DEPTH_ENCODINGS
    if t.msgtype == COMPRESSED_IMAGE_TYPE:
        return "compresseddepth" in t.encoding.lower()
    return False


def _namespace(topic: str) -> list[str]:
    return [x for x in topic.split("/") if x][:-1]


def select_depth_topic(topics: Mapping[str, TopicSummary]) -> tuple[str | None, list[str]]:
    """Pick the depth image topic among ``topics``.

    Candidates: ``sensor_msgs/msg/Image`` topics whose (first message's) encoding is 16UC1,
    mono16 or 32FC1, and ``sensor_msgs/msg/CompressedImage`` topics whose format contains
    ``compressedDepth``.  Preference: "depth" in the name, then 16UC1/32FC1 over mono16, then raw
    over compressed, then a CameraInfo in the same namespace, then more messages.

    Returns:
        ``(topic or None, warnings)``; a warning is added when the choice was ambiguous.
    """
    cands = [t for t in topics.values() if _is_depth_candidate(t)]
    if not cands:
        return None, []
    info_ns = {tuple(_namespace(t.name)) for t in topics.values() if t.msgtype == CAMERA_INFO_TYPE}

    def key(t: TopicSummary) -> tuple[int, int, int, int, int]:
        ns = _namespace(t.name)
        if t.msgtype == COMPRESSED_IMAGE_TYPE and ns:
            ns = ns[:-1]  # /x/depth/image_raw/compressedDepth -> /x/depth
        return (
            int("depth" in t.name.lower()),
            int((t.encoding or "").strip() != "mono16"),
            int(t.msgtype == IMAGE_TYPE),
            int(tuple(ns) in info_ns),
            t.count,
        )

    cands.sort(key=lambda t: (tuple(-x for x in key(t)), t.name))
    notes: list[str] = []
    if len(cands) > 1 and key(cands[0])[:4] == key(cands[1])[:4]:
        others = ", ".join(t.name for t in cands[1:])
        notes.append(f"several depth topics; using {cands[0].name} (others: {others}); choose with depth_topic")
    return cands[0].name, notes


def pair_camera_info_topic(depth_topic: str, topics: Mapping[str, TopicSummary]) -> tuple[str | None, list[str]]:
    """Pick the CameraInfo topic belonging to ``depth_topic``.

    The CameraInfo sharing the longest namespace prefix with the depth topic wins (so
    ``/x/depth/image_raw`` pairs with ``/x/depth/camera_info`` rather than ``/x/rgb/camera_info``);
    ties prefer names containing "depth".  With a single CameraInfo topic that one is used.

    Returns:
        ``(topic or None, warnings)``.
    """
    infos = [t for t in topics.values() if t.msgtype == CAMERA_INFO_TYPE]
    if not infos:
        return None, []
    if len(infos) == 1:
        return infos[0].name, []
    dns = _namespace(depth_topic)

    def common(t: TopicSummary) -> int:
        n = 0
        for a, b in zip(dns, _namespace(t.name), strict=False):
            if a != b:
                break
            n += 1
        return n

    ranked = sorted(infos, key=lambda t: (-common(t), -int("depth" in t.name.lower()), -int(t.count > 0), t.name))
    best = ranked[0]
    notes: list[str] = []
    if (common(ranked[1]), "depth" in ranked[1].name.lower()) == (common(best), "depth" in best.name.lower()):
        notes.append(
            f"several CameraInfo topics match {depth_topic}; using {best.name} "
            f"(others: {', '.join(t.name for t in ranked[1:])}); choose with info_topic"
        )
    return best.name, notes


# ---------------------------------------------------------------------------------------------
# Recording
# ---------------------------------------------------------------------------------------------


def _stamp_ns(header: Any) -> int:
    return int(header.stamp.sec) * 1_000_000_000 + int(header.stamp.nanosec)


def _camera_info_from_msg(msg: Any) -> CameraInfoData:
    """CameraInfoData from a ROS 2 (``k``) or ROS 1 (``K``) CameraInfo message object."""

    def field(name: str) -> Any:
        return getattr(msg, name) if hasattr(msg, name) else getattr(msg, name.upper())

    return CameraInfoData(
        width=int(msg.width),
        height=int(msg.height),
        k=tuple(float(x) for x in field("k")),
        d=tuple(float(x) for x in field("d")),
        r=tuple(float(x) for x in field("r")),
        p=tuple(float(x) for x in field("p")),
        distortion_model=str(msg.distortion_model),
        frame_id=str(msg.header.frame_id),
    )


class Recording:
    """An opened recording: its topics, the chosen depth / CameraInfo topics, and iterators.

    Create with :func:`open_recording`.  Nothing is held open between iterations; each call of
    :meth:`iter_frames` / :meth:`iter_raw` reads the file afresh, so they may be called repeatedly.

    Attributes:
        path: The recording (file or rosbag2 folder).
        storage: ``"mcap"``, ``"sqlite3"``, ``"ros1"``, ``"rosbag2/mcap"`` or ``"rosbag2/sqlite3"``.
        topics: All topics by name.
        depth_topic: The depth image topic.
        info_topic: The CameraInfo topic, or ``None`` (see ``camera_info_file``).
        camera_info_file: The calibration YAML used when given, else ``None``.
        start_ns / end_ns: First / last log time (ns).
        recovered_messages: For a damaged MCAP read partially, the number of messages recovered;
            ``None`` when the file was read normally.
        warnings: Human-readable notes (also emitted as :class:`RecordingWarning`).
    """

    def __init__(
        self,
        source: _Source,
        *,
        topics: dict[str, TopicSummary],
        depth_topic: str,
        info_topic: str | None,
        camera_info: CameraInfoData | None,
        camera_info_file: Path | None,
        notes: list[str],
    ) -> None:
        """Internal; use :func:`open_recording`."""
        self._source = source
        self.path: Path = source.path
        self.storage: str = source.storage
        self.topics: dict[str, TopicSummary] = topics
        self.depth_topic: str = depth_topic
        self.info_topic: str | None = info_topic
        self.camera_info_file: Path | None = camera_info_file
        self._file_info = camera_info
        self.start_ns: int | None = source.start_ns
        self.end_ns: int | None = source.end_ns
        self.recovered_messages: int | None = source.recovered_messages
        self.warnings: list[str] = notes
        self.skipped_frames = 0  # frames skipped by the last iter_frames() (corrupt messages)

    # -- information --------------------------------------------------------------------------

    @property
    def is_ros1(self) -> bool:
        """Whether the source is a ROS 1 bag (``iter_raw`` converts its messages to CDR)."""
        return self._source.is_ros1

    @property
    def frame_count(self) -> int:
        """Number of depth messages."""
        return self.topics[self.depth_topic].count

    @property
    def message_count(self) -> int:
        """Number of messages over all topics."""
        return sum(t.count for t in self.topics.values())

    @property
    def duration_s(self) -> float:
        """Log-time span of the recording in seconds."""
        if self.start_ns is None or self.end_ns is None:
            return 0.0
        return (self.end_ns - self.start_ns) / 1e9

    def describe(self) -> str:
        """Multi-line human-readable summary (topics, choices, warnings) for CLIs."""
        lines = [f"{self.path} [{self.storage}], {self.message_count} messages, {self.duration_s:.1f} s"]
        for t in self.topics.values():
            mark = " <- depth" if t.name == self.depth_topic else (" <- camera_info" if t.name == self.info_topic else "")
            enc = f" [{t.encoding}]" if t.encoding else ""
            lines.append(f"  {t.name}  {t.msgtype}{enc}  x{t.count}{mark}")
        if self.camera_info_file is not None:
            lines.append(f"  camera info from {self.camera_info_file}")
        lines.extend(f"  warning: {w}" for w in self.warnings)
        return "\n".join(lines)

    # -- iteration ----------------------------------------------------------------------------

    def _first_info(self) -> CameraInfoData | None:
        if self.info_topic is None:
            return None
        with contextlib.closing(self._source.messages({self.info_topic})) as it:
            for _topic, msgtype, _t, raw in it:
                with contextlib.suppress(Exception):
                    return _camera_info_from_msg(self._source.deserialize(raw, msgtype))
        return None

    def iter_frames(self) -> Iterator[DepthFrame]:
        """Yield the depth frames in log-time order, each with its calibration.

        Each image is paired with the latest CameraInfo logged at or before it (log-time order), or
        with the first CameraInfo of the recording for images logged before any; with
        ``camera_info_file`` that calibration is used for every frame.  A frame whose message
        cannot be decoded is skipped with a :class:`RecordingWarning` (counted in
        ``skipped_frames``); a header stamp of zero is replaced by the log time.

        Raises:
            RecordingError: the file cannot be read, or no depth message at all could be decoded.
        """
        src = self._source
        depth = self.depth_topic
        info_topic = None if self._file_info is not None else self.info_topic
        wanted = {depth} | ({info_topic} if info_topic else set())
        current: CameraInfoData | None = self._file_info
        file_info_by_frame: dict[str, CameraInfoData] = {}
        first_info_done = False
        self.skipped_frames = 0
        yielded = 0
        zero_stamp_warned = size_warned = False
        for topic, msgtype, log_ns, raw in src.messages(wanted):
            if topic != depth:
                try:
                    new = _camera_info_from_msg(src.deserialize(raw, msgtype))
                    if new != current:  # keep the same object while the calibration is unchanged
                        current = new
                    first_info_done = True
                except Exception as exc:  # noqa: BLE001
                    self._frame_warning(f"skipping an undecodable CameraInfo on {topic}: {exc}")
                continue
            if current is None and info_topic and not first_info_done:
                current = self._first_info()
                first_info_done = True
            try:
                frame = self._make_frame(raw, msgtype, log_ns, current)
            except Exception as exc:  # noqa: BLE001 - one bad message must not abort the session
                self.skipped_frames += 1
                if self.skipped_frames <= _MAX_FRAME_WARNINGS:
                    self._frame_warning(f"skipping an undecodable depth message at log time {log_ns} ns: {exc}")
                continue
            if frame.camera_info is not None and self._file_info is not None and not frame.camera_info.frame_id:
                info = file_info_by_frame.get(frame.frame_id)
                if info is None:
                    info = dataclasses.replace(frame.camera_info, frame_id=frame.frame_id)
                    file_info_by_frame[frame.frame_id] = info
                frame = dataclasses.replace(frame, camera_info=info)
            if frame.stamp_ns == 0 and log_ns != 0 and not zero_stamp_warned:
                zero_stamp_warned = True
                self._frame_warning(f"depth images on {depth} have zero header stamps; using log times")
            if frame.stamp_ns == 0:
                frame = dataclasses.replace(frame, stamp_ns=log_ns, stamp=log_ns / 1e9)
            ci = frame.camera_info
            if ci is not None and ci.width and ci.height and (ci.width, ci.height) != (frame.width, frame.height):
                if not size_warned:
                    size_warned = True
                    self._frame_warning(
                        f"CameraInfo size {ci.width}x{ci.height} differs from depth image size "
                        f"{frame.width}x{frame.height}"
                    )
            yielded += 1
            yield frame
        if self.skipped_frames > _MAX_FRAME_WARNINGS:
            self._frame_warning(f"skipped {self.skipped_frames} undecodable depth messages in total")
        if yielded == 0 and self.skipped_frames:
            msg = f"{self.path}: none of the {self.skipped_frames} messages on {depth} could be decoded"
            raise RecordingError(msg)

    def _frame_warning(self, text: str) -> None:
        full = f"{self.path}: {text}"
        if text not in self.warnings:
            self.warnings.append(text)
        warnings.warn(full, RecordingWarning, stacklevel=3)

    def _make_frame(self, raw: bytes, msgtype: str, log_ns: int, info: CameraInfoData | None) -> DepthFrame:
        msg = self._source.deserialize(raw, msgtype)
        stamp_ns = _stamp_ns(msg.header)
        frame_id = str(msg.header.frame_id)
        if msgtype == COMPRESSED_IMAGE_TYPE:
            encoding, arr = decode_compressed_depth(msg.data, fmt=str(msg.format))
            h, w = arr.shape
            return DepthFrame(
                stamp=stamp_ns / 1e9,
                stamp_ns=stamp_ns,
                encoding=encoding,
                width=int(w),
                height=int(h),
                step=int(arr.strides[0]),
                is_bigendian=sys.byteorder == "big",
                data=arr,
                frame_id=frame_id,
                camera_info=info,
                log_time_ns=log_ns,
                topic=self.depth_topic,
            )
        width, height, step = int(msg.width), int(msg.height), int(msg.step)
        data = msg.data
        if width <= 0 or height <= 0 or step <= 0 or len(data) < step * height:
            text = f"inconsistent Image ({width}x{height}, step {step}, {len(data)} data bytes)"
            raise ValueError(text)
        return DepthFrame(
            stamp=stamp_ns / 1e9,
            stamp_ns=stamp_ns,
            encoding=str(msg.encoding),
            width=width,
            height=height,
            step=step,
            is_bigendian=bool(msg.is_bigendian),
            data=data,
            frame_id=frame_id,
            camera_info=info,
            log_time_ns=log_ns,
            topic=self.depth_topic,
        )

    def iter_raw(self, *, topics: Collection[str] | None = None) -> Iterator[RawMessage]:
        """Yield every message (or those on ``topics``) in log-time order as CDR bytes, for replay.

        ROS 2 sources pass their CDR bytes through untouched; ROS 1 messages are converted to
        little-endian CDR of the same-named ROS 2 type (``std_msgs/Header`` loses ``seq``).

        Raises:
            RecordingError: unknown topic requested, the file cannot be read, or a ROS 1 message
                cannot be converted.
        """
        if topics is not None:
            unknown = sorted(set(topics) - set(self.topics))
            if unknown:
                msg = f"{self.path}: unknown topic(s) {', '.join(unknown)}; available: {', '.join(self.topics)}"
                raise RecordingError(msg)
        src = self._source
        for topic, msgtype, log_ns, raw in src.messages(None if topics is None else set(topics)):
            try:
                data = src.to_cdr(raw, msgtype)
            except Exception as exc:
                msg = f"{self.path}: cannot convert a {msgtype} message on {topic} to CDR: {exc}"
                raise RecordingError(msg) from None
            yield RawMessage(topic, _MSGTYPE_RENAMES.get(msgtype, msgtype), log_ns, data)


def _sniff_encodings(source: _Source, topics: dict[str, tuple[str, int]]) -> dict[str, str]:
    """Encoding (Image) or format (CompressedImage) of the first message of each image topic."""
    want = {t for t, (m, c) in topics.items() if c > 0 and m in (IMAGE_TYPE, COMPRESSED_IMAGE_TYPE)}
    out: dict[str, str] = {}
    if not want:
        return out
    with contextlib.closing(source.messages(want)) as it:
        for topic, msgtype, _t, raw in it:
            if topic in out:
                continue
            try:
                msg = source.deserialize(raw, msgtype)
                out[topic] = str(msg.encoding if msgtype == IMAGE_TYPE else msg.format)
            except Exception as exc:  # noqa: BLE001
                source.warnings.append(f"cannot decode the first message on {topic}: {exc}")
                out[topic] = ""
            if len(out) == len(want):
                break
    return out


def _topic_table(topics: Mapping[str, TopicSummary]) -> str:
    return ", ".join(
        f"{t.name} ({t.msgtype}{', ' + t.encoding if t.encoding else ''}, {t.count} msgs)" for t in topics.values()
    )


def open_recording(
    path: str | os.PathLike[str],
    *,
    depth_topic: str | None = None,
    info_topic: str | None = None,
    camera_info_file: str | os.PathLike[str] | None = None,
) -> Recording:
    """Open one recording and choose its depth and CameraInfo topics.

    Args:
        path: A ``.mcap``, ``.db3`` or ROS 1 ``.bag`` file, a rosbag2 folder, or a folder that
            holds exactly one recording (use :func:`find_recordings` for several).
        depth_topic: Use this depth topic instead of auto-detection; it must be a
            ``sensor_msgs/msg/Image`` with a depth encoding or a ``compressedDepth``
            ``sensor_msgs/msg/CompressedImage``.
        info_topic: Use this ``sensor_msgs/msg/CameraInfo`` topic instead of auto-pairing.
        camera_info_file: A ``camera_calibration_parsers`` YAML used for every frame (for
            recordings without CameraInfo; when the recording has one too, the file wins and a
            warning says so).  Cannot be combined with ``info_topic``.

    Raises:
        RecordingError: missing path, unknown format, corrupt file, empty recording, no depth
            topic, invalid overrides or camera YAML; the message names the file.
    """
    p = Path(path)
    if info_topic is not None and camera_info_file is not None:
        msg = f"{p}: give either info_topic ({info_topic}) or camera_info_file ({camera_info_file}), not both"
        raise RecordingError(msg)
    file_info: CameraInfoData | None = None
    info_path: Path | None = None
    if camera_info_file is not None:
        info_path = Path(camera_info_file)
        try:
            file_info = load_camera_info_yaml(info_path)
        except CameraYamlError as exc:
            raise RecordingError(str(exc)) from None

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        source = _open_source(p)
    notes = [str(w.message) for w in caught if issubclass(w.category, RecordingWarning)]
    notes += list(source.warnings)
    path_str = str(source.path)

    if source.message_count == 0:
        listed = f" (topics without messages: {', '.join(source.topics)})" if source.topics else ""
        msg = f"{path_str}: recording is empty, it contains no messages{listed}"
        raise RecordingError(msg)

    enc = _sniff_encodings(source, source.topics)
    notes += [w for w in source.warnings if w not in notes]
    topics = {
        name: TopicSummary(name=name, msgtype=mt, count=cnt, encoding=enc.get(name) or None)
        for name, (mt, cnt) in source.topics.items()
    }
    table = _topic_table(topics)

    if depth_topic is not None:
        t = topics.get(depth_topic)
        if t is None:
            msg = f"{path_str}: depth topic {depth_topic} not in the recording; available: {table}"
            raise RecordingError(msg)
        if t.msgtype not in (IMAGE_TYPE, COMPRESSED_IMAGE_TYPE):
            msg = (
                f"{path_str}: depth topic {depth_topic} has type {t.msgtype}, expected {IMAGE_TYPE} "
                f"or a compressedDepth {COMPRESSED_IMAGE_TYPE}; available: {table}"
            )
            raise RecordingError(msg)
        if t.count == 0:
            msg = f"{path_str}: depth topic {depth_topic} has no messages"
            raise RecordingError(msg)
        if t.msgtype == IMAGE_TYPE and t.encoding and _is_non_depth_encoding(t.encoding):
            msg = f"{path_str}: depth topic {depth_topic} has encoding {t.encoding}, which is not a depth encoding"
            raise RecordingError(msg)
        if t.msgtype == COMPRESSED_IMAGE_TYPE and "compresseddepth" not in (t.encoding or "").lower():
            msg = (
                f"{path_str}: depth topic {depth_topic} is a CompressedImage in format {t.encoding!r}, "
                "not image_transport compressedDepth"
            )
            raise RecordingError(msg)
        chosen: str = depth_topic
    else:
        auto, more = select_depth_topic(topics)
        if auto is None:
            msg = (
                f"{path_str}: no depth image topic found (need a sensor_msgs/msg/Image with encoding "
                f"16UC1, mono16 or 32FC1, or a compressedDepth CompressedImage); topics: {table}"
            )
            raise RecordingError(msg)
        chosen = auto
        notes += more

    if info_topic is not None:
        t = topics.get(info_topic)
        if t is None:
            msg = f"{path_str}: CameraInfo topic {info_topic} not in the recording; available: {table}"
            raise RecordingError(msg)
        if t.msgtype != CAMERA_INFO_TYPE:
            msg = (
                f"{path_str}: CameraInfo topic {info_topic} has type {t.msgtype}, expected {CAMERA_INFO_TYPE}; "
                f"available: {table}"
            )
            raise RecordingError(msg)
        info: str | None = info_topic
    else:
        info, more = pair_camera_info_topic(chosen, topics)
        notes += more
    if file_info is not None:
        if info is not None:
            notes.append(f"using calibration from {info_path} instead of the recording's {info}")
        info = None
    elif info is None:
        notes.append("no CameraInfo in the recording; give the calibration as a YAML file "
                     "(walker-gait process --camera-info FILE.yaml, camera_info_file in Python)")
    elif topics[info].count == 0:
        notes.append(f"CameraInfo topic {info} has no messages; give the calibration as a YAML file "
                     "(walker-gait process --camera-info FILE.yaml, camera_info_file in Python)")

    for note in notes:
        warnings.warn(f"{path_str}: {note}", RecordingWarning, stacklevel=2)
    return Recording(
        source,
        topics=topics,
        depth_topic=chosen,
        info_topic=info,
        camera_info=file_info,
        camera_info_file=info_path,
        notes=notes,
    )
