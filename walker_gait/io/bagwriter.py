"""Atomic writer for ROS recordings (rosbag2 MCAP / rosbag2 sqlite3 / ROS 1 ``.bag``).

Thin layer over the ``rosbags`` library (0.11 API) used by the synthetic session
generator and by the offline pipeline (``tracked.mcap``).

Output layout
-------------
``fmt="mcap"``
    * ``path`` ending in ``.mcap``: a single self-contained MCAP file (ros2
      profile, CDR, message definitions and rosbag2 metadata embedded).  It is
      exactly the storage file rosbag2 would write; ``rosbags`` (``AnyReader``),
      ``ros2 bag`` (Jazzy) and Foxglove open it directly.
    * any other ``path``: a rosbag2 directory ``path/`` with ``metadata.yaml``
      and ``path/<name>.mcap``.
``fmt="sqlite3"``
    * ``path`` ending in ``.db3``: a single rosbag2 sqlite3 file.
    * any other ``path``: a rosbag2 directory with ``metadata.yaml`` and ``<name>.db3``.
``fmt="ros1"``
    ``path`` is the ``.bag`` file (ROS 1 bag v2.0); the suffix must be ``.bag``
    so that readers detect the format.

Atomicity: everything is written under a hidden temporary directory next to the
final path and moved into place with :func:`os.replace` only when the context
exits without an exception; on error the temporary data is removed and nothing
exists under the final name.  An existing final path is never overwritten
unless ``overwrite=True``.

Example::

    with BagWriter("out/session.mcap", fmt="mcap") as bag:
        h = bag.add_topic("/camera/depth/image_raw", "sensor_msgs/msg/Image")
        bag.write(h, stamp_ns, msg)          # msg: a typestore message object
"""

from __future__ import annotations

import os
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any, Literal

from rosbags.interfaces import Connection, Qos
from rosbags.rosbag1 import Writer as Ros1Writer
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin
from rosbags.rosbag2 import Writer as Ros2Writer
from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.store import Typestore

BagFormat = Literal["mcap", "sqlite3", "ros1"]
BAG_FORMATS: tuple[str, ...] = ("mcap", "sqlite3", "ros1")


class BagWriteError(RuntimeError):
    """Raised for invalid use of :class:`BagWriter` or when a recording cannot be written."""


@dataclass(frozen=True)
class TopicHandle:
    """Handle returned by :meth:`BagWriter.add_topic`; pass it to :meth:`BagWriter.write`."""

    topic: str
    msgtype: str
    connection: Connection


def default_typestore(fmt: BagFormat) -> Typestore:
    """Typestore matching ``fmt``: ROS 2 Jazzy for rosbag2 formats, ROS 1 Noetic for ``ros1``."""
    return get_typestore(Stores.ROS1_NOETIC if fmt == "ros1" else Stores.ROS2_JAZZY)


class BagWriter:
    """Context manager writing one recording atomically.

    Args:
        path: final output path (see module docstring for the layout per format).
        fmt: ``"mcap"`` (rosbag2 + MCAP storage), ``"sqlite3"`` (rosbag2 + sqlite3) or ``"ros1"``.
        typestore: typestore used to serialise messages and generate definitions;
            defaults to :func:`default_typestore`.  Callers register custom types
            (e.g. ``walker_gait_msgs/msg/LegTrack``) into it before adding topics.
        overwrite: replace an existing output (otherwise :class:`BagWriteError`).
        custom_data: rosbag2 ``custom_data`` key/value strings (ignored for ROS 1).
        compress: zstd chunk compression for MCAP (``CompressionMode.STORAGE``), zstd per
            message for sqlite3, lz4 chunks for ROS 1.  All are read transparently by
            ``rosbags`` / ``ros2 bag``.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        fmt: BagFormat = "mcap",
        typestore: Typestore | None = None,
        overwrite: bool = False,
        custom_data: dict[str, str] | None = None,
        compress: bool = False,
    ) -> None:
        if fmt not in BAG_FORMATS:
            msg = f"unknown bag format {fmt!r}; expected one of {', '.join(BAG_FORMATS)}"
            raise BagWriteError(msg)
        self.path = Path(path)
        self.fmt: BagFormat = fmt
        if fmt == "ros1" and self.path.suffix != ".bag":
            msg = f"ROS 1 bags must end in '.bag' (readers detect the format by suffix), got {self.path}"
            raise BagWriteError(msg)
        self.typestore: Typestore = typestore if typestore is not None else default_typestore(fmt)
        self.overwrite = overwrite
        self.custom_data = dict(custom_data or {})
        self.compress = compress
        if compress and fmt == "sqlite3" and self._single_file:
            msg = (
                f"compressed sqlite3 needs the rosbag2 directory layout (metadata.yaml records the "
                f"compression); use a path without the .db3 suffix instead of {self.path}"
            )
            raise BagWriteError(msg)
        self._tmpdir: Path | None = None
        self._writer: Ros1Writer | Ros2Writer | None = None
        self._inner: Path | None = None
        self._handles: dict[str, TopicHandle] = {}
        self._count = 0

    # ------------------------------------------------------------------ properties
    @property
    def is_ros1(self) -> bool:
        """True when messages are serialised as ROS 1 (``fmt="ros1"``)."""
        return self.fmt == "ros1"

    @property
    def message_count(self) -> int:
        """Number of messages written so far."""
        return self._count

    # ------------------------------------------------------------------ lifecycle
    def open(self) -> BagWriter:
        """Create the temporary output and open the underlying ``rosbags`` writer."""
        if self._writer is not None:
            msg = f"bag writer for {self.path} is already open"
            raise BagWriteError(msg)
        if self.path.exists() and not self.overwrite:
            msg = f"output {self.path} exists already (pass overwrite=True to replace it)"
            raise BagWriteError(msg)
        parent = self.path.parent
        parent.mkdir(parents=True, exist_ok=True)
        self._tmpdir = Path(tempfile.mkdtemp(prefix=f".{self.path.name}.", suffix=".tmp", dir=parent))
        try:
            if self.fmt == "ros1":
                self._inner = self._tmpdir / self.path.name
                writer: Ros1Writer | Ros2Writer = Ros1Writer(self._inner)
                if self.compress:
                    writer.set_compression(Ros1Writer.CompressionFormat.LZ4)
            else:
                # rosbag2 directory named like the final output (minus a file suffix), so the
                # storage file inside is called <name>.mcap / <name>.db3.
                stem = self.path.stem if self._single_file else self.path.name
                self._inner = self._tmpdir / stem
                plugin = StoragePlugin.MCAP if self.fmt == "mcap" else StoragePlugin.SQLITE3
                writer = Ros2Writer(self._inner, version=Ros2Writer.VERSION_LATEST, storage_plugin=plugin)
                if self.compress:
                    mode = CompressionMode.STORAGE if self.fmt == "mcap" else CompressionMode.MESSAGE
                    writer.set_compression(mode, CompressionFormat.ZSTD)
                for key, value in self.custom_data.items():
                    writer.set_custom_data(key, value)
            writer.open()
        except Exception as err:
            self._cleanup()
            msg = f"cannot open {self.fmt} bag for {self.path}: {err}"
            raise BagWriteError(msg) from err
        self._writer = writer
        return self

    @property
    def _single_file(self) -> bool:
        return (self.fmt == "mcap" and self.path.suffix == ".mcap") or (
            self.fmt == "sqlite3" and self.path.suffix == ".db3"
        )

    def close(self) -> Path:
        """Finish the recording and move it to its final path; returns that path."""
        if self._writer is None or self._tmpdir is None or self._inner is None:
            msg = f"bag writer for {self.path} is not open"
            raise BagWriteError(msg)
        writer, self._writer = self._writer, None
        try:
            writer.close()
            if self.fmt == "ros1":
                src = self._inner
            elif self._single_file:
                ext = ".mcap" if self.fmt == "mcap" else ".db3"
                src = self._inner / f"{self._inner.name}{ext}"
                if not src.is_file():
                    msg = f"rosbags did not produce the expected storage file {src}"
                    raise BagWriteError(msg)
            else:
                src = self._inner
            if self.path.exists():
                if not self.overwrite:
                    msg = f"output {self.path} appeared while writing; not overwriting"
                    raise BagWriteError(msg)
                if self.path.is_dir() and not self.path.is_symlink():
                    shutil.rmtree(self.path)
                else:
                    self.path.unlink()
            os.replace(src, self.path)
        finally:
            self._cleanup()
        return self.path

    def abort(self) -> None:
        """Discard everything written; nothing is left under the final path."""
        writer, self._writer = self._writer, None
        if writer is not None:
            try:
                writer.abort()
            except Exception:  # noqa: BLE001 - cleaning up after an error anyway
                pass
        self._cleanup()

    def _cleanup(self) -> None:
        if self._tmpdir is not None:
            shutil.rmtree(self._tmpdir, ignore_errors=True)
            self._tmpdir = None
            self._inner = None

    def __enter__(self) -> BagWriter:
        return self.open()

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()

    # ------------------------------------------------------------------ topics / messages
    def add_topic(self, topic: str, msgtype: str, *, qos: list[Qos] | None = None) -> TopicHandle:
        """Register ``topic`` with ROS 2 style type name ``msgtype`` (``pkg/msg/Name``).

        ``qos`` is the list of offered QoS profiles stored in rosbag2 metadata (ignored for ROS 1).
        """
        if self._writer is None:
            msg = "add_topic() called on a bag writer that is not open (use it as a context manager)"
            raise BagWriteError(msg)
        if topic in self._handles:
            msg = f"topic {topic!r} was already added"
            raise BagWriteError(msg)
        if msgtype not in self.typestore.types:
            msg = f"message type {msgtype!r} is not in the typestore; register it before add_topic()"
            raise BagWriteError(msg)
        if isinstance(self._writer, Ros1Writer):
            conn = self._writer.add_connection(topic, msgtype, typestore=self.typestore)
        else:
            conn = self._writer.add_connection(
                topic, msgtype, typestore=self.typestore, offered_qos_profiles=list(qos or [])
            )
        handle = TopicHandle(topic=topic, msgtype=msgtype, connection=conn)
        self._handles[topic] = handle
        return handle

    def serialize(self, msg: Any, msgtype: str) -> bytes | memoryview:
        """Serialise a typestore message object (CDR for rosbag2, ROS 1 wire format for ``ros1``)."""
        if self.is_ros1:
            return self.typestore.serialize_ros1(msg, msgtype)
        return self.typestore.serialize_cdr(msg, msgtype)

    def write(self, topic: str | TopicHandle, stamp_ns: int, msg: Any) -> None:
        """Write one message with receive time ``stamp_ns`` (integer nanoseconds).

        ``msg`` is a message object from :attr:`typestore` or already serialised ``bytes``.
        """
        if self._writer is None:
            msg_ = "write() called on a bag writer that is not open"
            raise BagWriteError(msg_)
        handle = topic if isinstance(topic, TopicHandle) else self._handles.get(topic)
        if handle is None:
            msg_ = f"topic {topic!r} was not added; call add_topic() first"
            raise BagWriteError(msg_)
        stamp = int(stamp_ns)
        if stamp < 0:
            msg_ = f"negative timestamp {stamp} ns on {handle.topic}"
            raise BagWriteError(msg_)
        data = msg if isinstance(msg, (bytes, bytearray, memoryview)) else self.serialize(msg, handle.msgtype)
        self._writer.write(handle.connection, stamp, data)  # type: ignore[arg-type]
        self._count += 1
