"""Tests of walker_gait.io.bags (recording reader) and walker_gait.io.camera_yaml.

Fixture recordings are written into tmp dirs with rosbags' writers (and the ``mcap`` library's
writer for a chunked "foreign" MCAP) in every supported format.
"""

from __future__ import annotations

import shutil
import struct
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_typestore

from walker_gait.io.bags import (
    CAMERA_INFO_TYPE,
    COMPRESSED_IMAGE_TYPE,
    IMAGE_TYPE,
    CompressedDepthError,
    DepthFrame,
    Recording,
    RecordingError,
    RecordingWarning,
    TopicSummary,
    decode_compressed_depth,
    decode_rvl,
    find_recordings,
    open_recording,
    pair_camera_info_topic,
    select_depth_topic,
)
from walker_gait.io.camera_yaml import CameraInfoData, dump_camera_info_yaml, load_camera_info_yaml

TS2 = get_typestore(Stores.ROS2_JAZZY)
TS1 = get_typestore(Stores.ROS1_NOETIC)


W, H = 8, 6
N_FRAMES = 5
T0 = 1_700_000_000_000_000_000
DT = 33_000_000
DEPTH = "/cam/depth/image_raw"
RGB = "/cam/color/image_raw"
INFO = "/cam/depth/camera_info"
RGB_INFO = "/cam/color/camera_info"
COMP = "/cam/depth/image_raw/compressedDepth"


# ------------------------------------------------------------------------------------------------
# Fixture helpers: message specs, encoders, writers
# ------------------------------------------------------------------------------------------------


@dataclass
class Msg:
    """A message to write: ``fields`` are ROS 2 style (lower-case) field values."""

    topic: str
    msgtype: str
    log_ns: int
    fields: dict[str, Any]


def header(stamp_ns: int, frame_id: str = "cam_depth_optical") -> dict[str, Any]:
    return {"stamp_ns": stamp_ns, "frame_id": frame_id}


def depth_array(i: int) -> np.ndarray:
    return (np.arange(W * H, dtype=np.uint16).reshape(H, W) + 1000 + 10 * i).astype(np.uint16)


def image_fields(stamp_ns: int, arr: np.ndarray, encoding: str, frame_id: str = "cam_depth_optical") -> dict[str, Any]:
    h, w = arr.shape[:2]
    data = np.ascontiguousarray(arr).view(np.uint8).reshape(-1)
    return {
        "header": header(stamp_ns, frame_id),
        "height": h,
        "width": w,
        "encoding": encoding,
        "is_bigendian": 0,
        "step": data.size // h,
        "data": data,
    }


def info_fields(stamp_ns: int, fx: float, frame_id: str = "cam_depth_optical", w: int = W, h: int = H) -> dict[str, Any]:
    cx, cy = (w - 1) / 2, (h - 1) / 2
    return {
        "header": header(stamp_ns, frame_id),
        "height": h,
        "width": w,
        "distortion_model": "plumb_bob",
        "d": np.array([0.1, -0.2, 0.001, 0.002, 0.0]),
        "k": np.array([fx, 0, cx, 0, fx, cy, 0, 0, 1], dtype=np.float64),
        "r": np.eye(3).reshape(-1),
        "p": np.array([fx, 0, cx, 0, 0, fx, cy, 0, 0, 0, 1, 0], dtype=np.float64),
    }


def encode_rvl(img: np.ndarray) -> bytes:
    """RVL encoder written from the algorithm's description (Wilson 2017; image_transport's codec layout:
    uint32 cols, rows, then 32-bit little-endian words of nibbles, most significant first), plain Python."""
    nibbles: list[int] = []

    def vle(value: int) -> None:
        while True:
            nib, value = value & 7, value >> 3
            nibbles.append(nib | (8 if value else 0))
            if not value:
                return

    flat = [int(v) for v in img.reshape(-1)]
    i, previous = 0, 0
    while i < len(flat):
        j = i
        while j < len(flat) and flat[j] == 0:
            j += 1
        vle(j - i)
        k = j
        while k < len(flat) and flat[k] != 0:
            k += 1
        vle(k - j)
        for v in flat[j:k]:
            delta = v - previous
            vle((delta << 1) ^ (delta >> 31))  # zigzag: -1 -> 1, 1 -> 2, -2 -> 3
            previous = v
        i = k
    nibbles += [0] * (-len(nibbles) % 8)
    words = [int("".join(f"{x:x}" for x in nibbles[w : w + 8]), 16) for w in range(0, len(nibbles), 8)]
    return struct.pack("<II", img.shape[1], img.shape[0]) + struct.pack(f"<{len(words)}I", *words)


def encode_compressed_depth(
    depth: np.ndarray, *, encoding: str, depth_max: float = 10.0, depth_quantization: float = 100.0,
    codec: str = "png",
) -> tuple[str, bytes]:
    """image_transport compressedDepth encoder: 12-byte ConfigHeader + 16-bit PNG (or RVL, ``codec="rvl"``)."""
    if encoding == "16UC1":
        img = depth.astype(np.uint16).copy()
        img[img > int(depth_max * 1000)] = 0
        quant = (0.0, 0.0)
    else:
        quant_a = np.float32(depth_quantization * (depth_quantization + 1.0))
        quant_b = np.float32(1.0 - quant_a / np.float32(depth_max))
        with np.errstate(invalid="ignore", divide="ignore"):
            inv = quant_a / depth.astype(np.float32) + quant_b
        ok = depth < depth_max  # NaN compares False -> 0 (invalid)
        img = np.where(ok, inv, 0).astype(np.uint16)  # float -> ushort truncates like the C++ cast
        quant = (float(quant_a), float(quant_b))
    if codec == "rvl":
        return f"{encoding}; compressedDepth rvl", struct.pack("<iff", 0, *quant) + encode_rvl(img)
    ok, png = cv2.imencode(".png", img)
    assert ok
    return f"{encoding}; compressedDepth png", struct.pack("<iff", 0, *quant) + png.tobytes()


def build(ts: Any, msgtype: str, fields: dict[str, Any], *, ros1: bool) -> Any:
    """Message object of ``msgtype`` in typestore ``ts`` (ROS 1 or ROS 2 flavour)."""
    Time = ts.types["builtin_interfaces/msg/Time"]
    Header = ts.types["std_msgs/msg/Header"]
    hdr = fields["header"]
    sec, nsec = divmod(hdr["stamp_ns"], 1_000_000_000)
    stamp = Time(sec=sec, nanosec=nsec)
    h = Header(seq=0, stamp=stamp, frame_id=hdr["frame_id"]) if ros1 else Header(stamp=stamp, frame_id=hdr["frame_id"])
    values: dict[str, Any] = {"header": h, **{k: v for k, v in fields.items() if k != "header"}}
    if msgtype == CAMERA_INFO_TYPE:
        roi = ts.types["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0, do_rectify=False)
        values.update(binning_x=0, binning_y=0, roi=roi)
    names = [name for name, _ in ts.fielddefs[msgtype][1]]
    return ts.types[msgtype](**{name: values[name.lower()] for name in names})


def write_rosbag2(folder: Path, msgs: list[Msg], *, storage: str = "mcap",
                  compression: str | None = None) -> dict[tuple[str, int], bytes]:
    """Write a rosbag2 folder (``compression`` "file" or "message": zstd, as ``ros2 bag record
    --compression-mode``); returns the CDR bytes written, keyed by (topic, log time)."""
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    written: dict[tuple[str, int], bytes] = {}
    writer = Writer2(folder, version=9, storage_plugin=plugin)
    if compression:
        writer.set_compression(CompressionMode[compression.upper()], CompressionFormat.ZSTD)
    with writer:
        conns: dict[str, Any] = {}
        for m in msgs:
            if m.topic not in conns:
                conns[m.topic] = writer.add_connection(m.topic, m.msgtype, typestore=TS2)
        for m in sorted(msgs, key=lambda m: m.log_ns):
            if not m.fields:
                continue
            raw = bytes(TS2.serialize_cdr(build(TS2, m.msgtype, m.fields, ros1=False), m.msgtype))
            writer.write(conns[m.topic], m.log_ns, raw)
            written[(m.topic, m.log_ns)] = raw
    return written


def write_ros1(path: Path, msgs: list[Msg], *, compression: str | None = None) -> None:
    writer = Writer1(path)
    if compression:  # "bz2" or "lz4" chunks, as `rosbag record --bz2/--lz4`
        writer.set_compression(Writer1.CompressionFormat[compression.upper()])
    with writer:
        conns: dict[str, Any] = {}
        for m in msgs:
            if m.topic not in conns:
                conns[m.topic] = writer.add_connection(m.topic, m.msgtype, typestore=TS1)
        for m in sorted(msgs, key=lambda m: m.log_ns):
            raw = bytes(TS1.serialize_ros1(build(TS1, m.msgtype, m.fields, ros1=True), m.msgtype))
            writer.write(conns[m.topic], m.log_ns, raw)


def write_mcap_ros1(path: Path, msgs: list[Msg]) -> None:
    """A ROS 1 profile MCAP, as ``mcap convert`` makes of a ROS 1 bag (ros1msg schemas named ``pkg/Type``,
    ``ros1`` message encoding, ROS 1 serialisation with the Header's ``seq``)."""
    from mcap.writer import Writer as McapWriter

    with path.open("wb") as f:
        writer = McapWriter(f, chunk_size=4096)
        writer.start(profile="ros1", library="test")
        channels: dict[str, int] = {}
        for m in msgs:
            if m.topic not in channels:
                text, md5 = TS1.generate_msgdef(m.msgtype, ros_version=1)
                sid = writer.register_schema(name=m.msgtype.replace("/msg/", "/"), encoding="ros1msg",
                                             data=text.encode())
                channels[m.topic] = writer.register_channel(topic=m.topic, message_encoding="ros1", schema_id=sid,
                                                            metadata={"md5sum": md5})
        for m in sorted(msgs, key=lambda m: m.log_ns):
            raw = bytes(TS1.serialize_ros1(build(TS1, m.msgtype, m.fields, ros1=True), m.msgtype))
            writer.add_message(channels[m.topic], log_time=m.log_ns, data=raw, publish_time=m.log_ns)
        writer.finish()


def write_mcap_chunked(path: Path, msgs: list[Msg], *, chunk_size: int = 2048, indexed: bool = True) -> None:
    """A ROS 2 MCAP written by the ``mcap`` library (small chunks, zstd, ros2msg schemas)."""
    from mcap.writer import IndexType
    from mcap.writer import Writer as McapWriter

    with path.open("wb") as f:
        if indexed:
            writer = McapWriter(f, chunk_size=chunk_size)
        else:
            writer = McapWriter(
                f, chunk_size=chunk_size, index_types=IndexType.NONE, repeat_channels=False,
                repeat_schemas=False, use_statistics=False, use_summary_offsets=False,
            )
        writer.start(profile="ros2", library="test")
        channels: dict[str, int] = {}
        for m in msgs:
            if m.topic not in channels:
                text, _ = TS2.generate_msgdef(m.msgtype, ros_version=2)
                sid = writer.register_schema(name=m.msgtype, encoding="ros2msg", data=text.encode())
                channels[m.topic] = writer.register_channel(topic=m.topic, message_encoding="cdr", schema_id=sid)
        for m in sorted(msgs, key=lambda m: m.log_ns):
            raw = bytes(TS2.serialize_cdr(build(TS2, m.msgtype, m.fields, ros1=False), m.msgtype))
            writer.add_message(channels[m.topic], log_time=m.log_ns, data=raw, publish_time=m.log_ns)
        writer.finish()


def session(
    *, n: int = N_FRAMES, t0: int = T0, with_info: bool = True, with_rgb: bool = True, info_topic: str = INFO
) -> list[Msg]:
    """Standard session: depth 16UC1 + rgb8 Images, depth and colour CameraInfo.

    Log times: depth i at t0 + i*DT (header stamp 2 ms earlier); depth CameraInfo fx=500 at
    t0 + 5 ms (after depth frame 0) and fx=600 after depth frame 2; colour CameraInfo fx=700.
    """
    msgs: list[Msg] = []
    for i in range(n):
        t = t0 + i * DT
        msgs.append(Msg(DEPTH, IMAGE_TYPE, t, image_fields(t - 2_000_000, depth_array(i), "16UC1")))
        if with_rgb:
            rgb = np.full((H, W, 3), i, np.uint8)
            msgs.append(Msg(RGB, IMAGE_TYPE, t + 1_000_000, image_fields(t, rgb, "rgb8", "cam_color_optical")))
    if with_info:
        msgs.append(Msg(info_topic, CAMERA_INFO_TYPE, t0 + 5_000_000, info_fields(t0, 500.0)))
        msgs.append(Msg(info_topic, CAMERA_INFO_TYPE, t0 + 2 * DT + 10_000_000, info_fields(t0 + 2 * DT, 600.0)))
        if with_rgb:
            msgs.append(Msg(RGB_INFO, CAMERA_INFO_TYPE, t0 + 3_000_000, info_fields(t0, 700.0, "cam_color_optical")))
    return msgs


def make_recording(tmp: Path, fmt: str, msgs: list[Msg], name: str = "rec") -> Path:
    """Write ``msgs`` as ``fmt``: rosbag2_mcap, bare_mcap, rosbag2_sqlite3, bare_db3, ros1, ros1_mcap."""
    if fmt == "ros1":
        path = tmp / f"{name}.bag"
        write_ros1(path, msgs)
        return path
    if fmt == "ros1_mcap":
        path = tmp / f"{name}.mcap"
        write_mcap_ros1(path, msgs)
        return path
    storage = "sqlite3" if fmt in ("rosbag2_sqlite3", "bare_db3") else "mcap"
    folder = tmp / name
    write_rosbag2(folder, msgs, storage=storage)
    if fmt.startswith("bare_"):
        (src,) = [p for p in folder.iterdir() if p.suffix in (".mcap", ".db3")]
        dst = tmp / f"{name}{src.suffix}"
        shutil.move(src, dst)
        shutil.rmtree(folder)
        return dst
    return folder


def quiet_open(path: Path, **kwargs: Any) -> Recording:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RecordingWarning)
        return open_recording(path, **kwargs)


def frames_of(rec: Recording) -> list[DepthFrame]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RecordingWarning)
        return list(rec.iter_frames())


def frame_depth(frame: DepthFrame) -> np.ndarray:
    buf = np.frombuffer(frame.data, dtype=np.uint8)
    rows = buf[: frame.step * frame.height].reshape(frame.height, frame.step)[:, : frame.width * 2]
    return np.ascontiguousarray(rows).view("<u2").reshape(frame.height, frame.width)


FORMATS = ["rosbag2_mcap", "bare_mcap", "rosbag2_sqlite3", "bare_db3", "ros1", "ros1_mcap"]
STORAGE = {
    "rosbag2_mcap": "rosbag2/mcap",
    "bare_mcap": "mcap",
    "rosbag2_sqlite3": "rosbag2/sqlite3",
    "bare_db3": "sqlite3",
    "ros1": "ros1",
    "ros1_mcap": "mcap/ros1",
}


# ------------------------------------------------------------------------------------------------
# Formats, detection, pairing
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("fmt", FORMATS)
def test_every_format_detects_topics_and_yields_frames(tmp_path: Path, fmt: str) -> None:
    path = make_recording(tmp_path, fmt, session())
    rec = quiet_open(path)
    assert rec.storage == STORAGE[fmt]
    assert rec.depth_topic == DEPTH
    assert rec.info_topic == INFO  # paired by namespace, not the colour one
    assert rec.topics[DEPTH] == TopicSummary(name=DEPTH, msgtype=IMAGE_TYPE, count=N_FRAMES, encoding="16UC1")
    assert rec.topics[RGB].encoding == "rgb8"
    assert rec.topics[INFO].count == 2 and rec.topics[INFO].msgtype == CAMERA_INFO_TYPE
    assert rec.frame_count == N_FRAMES
    assert rec.message_count == 2 * N_FRAMES + 3
    assert rec.start_ns == T0
    assert rec.recovered_messages is None
    assert rec.is_ros1 == (fmt in ("ros1", "ros1_mcap"))

    frames = frames_of(rec)
    assert len(frames) == N_FRAMES
    for i, fr in enumerate(frames):
        assert fr.encoding == "16UC1" and (fr.width, fr.height, fr.step) == (W, H, 2 * W)
        assert fr.is_bigendian is False
        assert fr.stamp_ns == T0 + i * DT - 2_000_000
        assert fr.stamp == pytest.approx(fr.stamp_ns / 1e9)
        assert fr.log_time_ns == T0 + i * DT
        assert fr.frame_id == "cam_depth_optical"
        assert fr.topic == DEPTH
        np.testing.assert_array_equal(frame_depth(fr), depth_array(i))
    # pairing: frame 0 precedes every CameraInfo -> the first one; then the latest at or before
    fxs = [fr.camera_info.fx for fr in frames if fr.camera_info is not None]
    assert fxs == [500.0, 500.0, 500.0, 600.0, 600.0]
    ci = frames[0].camera_info
    assert ci is not None
    assert (ci.width, ci.height, ci.distortion_model, ci.frame_id) == (W, H, "plumb_bob", "cam_depth_optical")
    assert ci.d == pytest.approx((0.1, -0.2, 0.001, 0.002, 0.0))
    assert len(ci.k) == 9 and len(ci.r) == 9 and len(ci.p) == 12
    assert ci.r == (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    assert (ci.cx, ci.cy) == ((W - 1) / 2, (H - 1) / 2)
    assert frames[1].camera_info is frames[2].camera_info  # unchanged calibration: same object


@pytest.mark.parametrize(("fmt", "compression"), [("ros1", "bz2"), ("ros1", "lz4"), ("sqlite3", "file"),
                                                  ("sqlite3", "message"), ("mcap", "file"), ("mcap", "message")])
def test_compressed_recordings_are_read(tmp_path: Path, fmt: str, compression: str) -> None:
    """Chunk-compressed ROS 1 bags and zstd-compressed rosbag2 (whole files or per message) give the same frames."""
    if fmt == "ros1":
        path = tmp_path / "rec.bag"
        write_ros1(path, session(), compression=compression)
    else:
        path = tmp_path / "rec"
        write_rosbag2(path, session(), storage=fmt, compression=compression)
    frames = frames_of(quiet_open(path))
    assert len(frames) == N_FRAMES
    for i, fr in enumerate(frames):
        np.testing.assert_array_equal(frame_depth(fr), depth_array(i))
        assert fr.camera_info is not None


def test_frames_do_not_copy_image_bytes(tmp_path: Path) -> None:
    rec = quiet_open(make_recording(tmp_path, "bare_mcap", session()))
    fr = frames_of(rec)[0]
    assert isinstance(fr.data, np.ndarray) and fr.data.dtype == np.uint8
    assert fr.data.base is not None  # a view into the message buffer, not a copy


def test_describe_lists_topics_and_choices(tmp_path: Path) -> None:
    rec = quiet_open(make_recording(tmp_path, "bare_mcap", session()))
    text = rec.describe()
    assert f"{DEPTH}  {IMAGE_TYPE} [16UC1]  x5 <- depth" in text
    assert f"{INFO}  {CAMERA_INFO_TYPE}  x2 <- camera_info" in text


def test_single_camera_info_in_other_namespace_is_used(tmp_path: Path) -> None:
    msgs = [m for m in session() if m.topic != INFO]  # only the colour CameraInfo left
    rec = quiet_open(make_recording(tmp_path, "rosbag2_mcap", msgs))
    assert rec.info_topic == RGB_INFO
    assert {fr.camera_info.fx for fr in frames_of(rec) if fr.camera_info} == {700.0}


def test_selection_functions() -> None:
    def t(name: str, msgtype: str, enc: str | None = None, count: int = 3) -> TopicSummary:
        return TopicSummary(name=name, msgtype=msgtype, count=count, encoding=enc)

    topics = {
        x.name: x
        for x in [
            t("/a/ir/image", IMAGE_TYPE, "mono16"),
            t("/a/depth/image_raw", IMAGE_TYPE, "16UC1"),
            t("/a/depth/image_raw/compressedDepth", COMPRESSED_IMAGE_TYPE, "16UC1; compressedDepth png"),
            t("/a/rgb/image", IMAGE_TYPE, "rgb8"),
            t("/a/rgb/camera_info", CAMERA_INFO_TYPE),
            t("/a/depth/camera_info", CAMERA_INFO_TYPE),
            t("/b/depth/camera_info", CAMERA_INFO_TYPE),
        ]
    }
    assert select_depth_topic(topics) == ("/a/depth/image_raw", [])
    assert pair_camera_info_topic("/a/depth/image_raw", topics) == ("/a/depth/camera_info", [])
    assert pair_camera_info_topic("/a/depth/image_raw/compressedDepth", topics)[0] == "/a/depth/camera_info"
    assert pair_camera_info_topic("/a/ir/image", topics)[0] == "/a/depth/camera_info"  # tie -> 'depth' in name
    # only compressed depth -> it counts; a plain png CompressedImage does not
    only = {
        "/c/depth/compressedDepth": t("/c/depth/compressedDepth", COMPRESSED_IMAGE_TYPE, "32FC1; compressedDepth"),
        "/c/rgb/compressed": t("/c/rgb/compressed", COMPRESSED_IMAGE_TYPE, "rgb8; jpeg compressed bgr8"),
    }
    assert select_depth_topic(only)[0] == "/c/depth/compressedDepth"
    assert select_depth_topic({"/x": t("/x", IMAGE_TYPE, "rgb8")}) == (None, [])
    # empty topics do not count; ambiguity is reported
    two = {
        "/p/depth/image": t("/p/depth/image", IMAGE_TYPE, "16UC1"),
        "/q/depth/image": t("/q/depth/image", IMAGE_TYPE, "32FC1"),
        "/r/depth/image": t("/r/depth/image", IMAGE_TYPE, "16UC1", count=0),
    }
    name, notes = select_depth_topic(two)
    assert name == "/p/depth/image" and notes and "/q/depth/image" in notes[0]


# ------------------------------------------------------------------------------------------------
# Overrides
# ------------------------------------------------------------------------------------------------


def test_overrides_valid(tmp_path: Path) -> None:
    path = make_recording(tmp_path, "rosbag2_mcap", session())
    rec = quiet_open(path, depth_topic=DEPTH, info_topic=RGB_INFO)
    assert rec.info_topic == RGB_INFO
    assert {fr.camera_info.fx for fr in frames_of(rec) if fr.camera_info} == {700.0}


@pytest.mark.parametrize(
    ("kwargs", "needle"),
    [
        ({"depth_topic": "/nope"}, "depth topic /nope not in the recording"),
        ({"depth_topic": INFO}, "has type sensor_msgs/msg/CameraInfo"),
        ({"depth_topic": RGB}, "rgb8, which is not a depth encoding"),
        ({"info_topic": "/nope"}, "CameraInfo topic /nope not in the recording"),
        ({"info_topic": DEPTH}, f"CameraInfo topic {DEPTH} has type sensor_msgs/msg/Image"),
    ],
)
def test_overrides_invalid(tmp_path: Path, kwargs: dict[str, str], needle: str) -> None:
    path = make_recording(tmp_path, "rosbag2_mcap", session())
    with pytest.raises(RecordingError) as err:
        open_recording(path, **kwargs)
    text = str(err.value)
    assert str(path) in text and needle in text
    if "not in the recording" in needle or "has type" in needle:
        assert "available:" in text and DEPTH in text and RGB in text and INFO in text


def test_info_topic_and_file_together_rejected(tmp_path: Path) -> None:
    path = make_recording(tmp_path, "rosbag2_mcap", session())
    with pytest.raises(RecordingError, match="either info_topic"):
        open_recording(path, info_topic=INFO, camera_info_file=tmp_path / "x.yaml")


# ------------------------------------------------------------------------------------------------
# compressedDepth
# ------------------------------------------------------------------------------------------------


def test_compressed_depth_16uc1_round_trip_in_recording(tmp_path: Path) -> None:
    msgs = []
    for i in range(3):
        fmt, data = encode_compressed_depth(depth_array(i), encoding="16UC1")
        fields = {"header": header(T0 + i * DT), "format": fmt, "data": np.frombuffer(data, np.uint8)}
        msgs.append(Msg(COMP, COMPRESSED_IMAGE_TYPE, T0 + i * DT, fields))
    msgs.append(Msg(INFO, CAMERA_INFO_TYPE, T0 - 1, info_fields(T0, 500.0)))
    msgs.append(Msg(RGB, IMAGE_TYPE, T0 + 1, image_fields(T0, np.zeros((H, W, 3), np.uint8), "rgb8")))
    rec = quiet_open(make_recording(tmp_path, "bare_mcap", msgs))
    assert rec.depth_topic == COMP and rec.info_topic == INFO
    assert rec.topics[COMP].encoding == "16UC1; compressedDepth png"
    frames = frames_of(rec)
    assert len(frames) == 3
    for i, fr in enumerate(frames):
        assert isinstance(fr.data, np.ndarray) and fr.data.dtype == np.uint16
        assert (fr.encoding, fr.width, fr.height, fr.step) == ("16UC1", W, H, 2 * W)
        np.testing.assert_array_equal(fr.data, depth_array(i))
        np.testing.assert_array_equal(frame_depth(fr), depth_array(i))  # step/bytes consistent
        assert fr.camera_info is not None and fr.camera_info.fx == 500.0


def test_compressed_depth_32fc1_round_trip() -> None:
    depth = np.linspace(0.4, 6.0, W * H, dtype=np.float32).reshape(H, W)
    depth[0, 0] = np.nan
    depth[1, 1] = 12.0  # beyond depth_max -> invalid
    fmt, data = encode_compressed_depth(depth, encoding="32FC1", depth_max=10.0, depth_quantization=100.0)
    assert fmt == "32FC1; compressedDepth png"
    enc, out = decode_compressed_depth(data, fmt=fmt)
    assert enc == "32FC1" and out.dtype == np.float32 and out.shape == (H, W)
    assert np.isnan(out[0, 0]) and np.isnan(out[1, 1])
    ok = np.isfinite(depth) & (depth < 10.0)
    quant_a = 100.0 * 101.0
    tol = depth[ok].astype(np.float64) ** 2 / quant_a * 1.05 + 1e-5  # one inverse-depth step
    assert np.all(np.abs(out[ok] - depth[ok]) <= tol)
    # the old format string without "png" decodes the same
    enc2, out2 = decode_compressed_depth(data, fmt="32FC1; compressedDepth")
    np.testing.assert_array_equal(np.isnan(out2), np.isnan(out))


def test_compressed_depth_32fc1_in_recording(tmp_path: Path) -> None:
    depth = np.full((H, W), 1.5, np.float32)
    fmt, data = encode_compressed_depth(depth, encoding="32FC1")
    msgs = [
        Msg(COMP, COMPRESSED_IMAGE_TYPE, T0, {"header": header(T0), "format": fmt, "data": np.frombuffer(data, np.uint8)}),
    ]
    rec = quiet_open(make_recording(tmp_path, "rosbag2_sqlite3", msgs))
    (fr,) = frames_of(rec)
    assert fr.encoding == "32FC1" and fr.step == 4 * W and fr.camera_info is None
    np.testing.assert_allclose(fr.data, 1.5, atol=1.5**2 / 10100 * 1.05)


@settings(max_examples=25, deadline=None)
@given(arrays(np.uint16, st.tuples(st.integers(1, 12), st.integers(1, 12)), elements=st.integers(0, 9999)))
def test_compressed_depth_16uc1_property(depth: np.ndarray) -> None:
    fmt, data = encode_compressed_depth(depth, encoding="16UC1")
    enc, out = decode_compressed_depth(data, fmt=fmt)
    assert enc == "16UC1"
    np.testing.assert_array_equal(out, depth)


@pytest.mark.parametrize(
    ("data", "fmt", "needle"),
    [
        (b"\x00" * 12 + b"notapng", "16UC1; compressedDepth png", "cannot be decoded|not a single-channel"),
        (b"\x00" * 5, "16UC1; compressedDepth png", "too short"),
        (b"\x00" * 12 + struct.pack("<II", 0, 4), "16UC1; compressedDepth rvl", "implausible size"),
        (b"\x00" * 12 + struct.pack("<II", 100_000, 480) + b"\x00" * 16, "16UC1; compressedDepth rvl", "implausible size"),
        (b"\x00" * 12 + struct.pack("<II", 1000, 1000) + b"\x00" * 16, "16UC1; compressedDepth rvl", "ends after 0 of"),
        (b"\x00" * 12 + b"\x03\x00", "16UC1; compressedDepth rvl", "too short"),
        (b"\x00" * 40, "rgb8; compressedDepth png", "16- or 32-bit"),
    ],
)
def test_compressed_depth_errors(data: bytes, fmt: str, needle: str) -> None:
    with pytest.raises(CompressedDepthError, match=needle):
        decode_compressed_depth(data, fmt=fmt)


def test_rvl_hand_encoded_example() -> None:
    """[0, 5, 3]: VLE(1 zero), VLE(2 non-zeros), zigzag deltas 10 (nibbles 0xA, 0x1) and 3: nibbles 1 2 A 1 3, padded
    into one word 0x12A13000, stored little-endian.  Pins the layout independently of the test encoder."""
    payload = struct.pack("<II", 3, 1) + bytes([0x00, 0x30, 0xA1, 0x12])
    np.testing.assert_array_equal(decode_rvl(np.frombuffer(payload, np.uint8)), [[0, 5, 3]])
    assert encode_rvl(np.array([[0, 5, 3]], np.uint16)) == payload


@settings(max_examples=40, deadline=None)
@given(arrays(np.uint16, st.tuples(st.integers(1, 9), st.integers(1, 13)),
              elements=st.one_of(st.just(0), st.integers(1, 65535), st.integers(990, 1010))))
def test_rvl_round_trip_property(depth: np.ndarray) -> None:
    """Zero runs, big jumps (deltas wrapping around 16 bits) and small steps survive the round trip."""
    fmt, data = encode_compressed_depth(depth, encoding="16UC1", depth_max=70.0, codec="rvl")
    enc, out = decode_compressed_depth(data, fmt=fmt)
    assert enc == "16UC1" and out.dtype == np.uint16
    np.testing.assert_array_equal(out, depth)


def test_rvl_32fc1_and_in_recording(tmp_path: Path) -> None:
    depth = np.linspace(0.4, 6.0, W * H, dtype=np.float32).reshape(H, W)
    depth[0, :5] = np.nan
    png_fmt, png = encode_compressed_depth(depth, encoding="32FC1")
    fmt, data = encode_compressed_depth(depth, encoding="32FC1", codec="rvl")
    assert fmt == "32FC1; compressedDepth rvl"
    enc, out = decode_compressed_depth(data, fmt=fmt)
    np.testing.assert_array_equal(out, decode_compressed_depth(png, fmt=png_fmt)[1])  # same quantisation as png
    assert enc == "32FC1" and np.isnan(out[0, :5]).all() and np.isfinite(out[1:]).all()
    msgs = []
    for i in range(2):
        fmt16, data16 = encode_compressed_depth(depth_array(i), encoding="16UC1", codec="rvl")
        msgs.append(Msg(COMP, COMPRESSED_IMAGE_TYPE, T0 + i * DT,
                        {"header": header(T0 + i * DT), "format": fmt16, "data": np.frombuffer(data16, np.uint8)}))
    rec = quiet_open(make_recording(tmp_path, "bare_mcap", msgs))
    frames = frames_of(rec)
    assert len(frames) == 2
    for i, fr in enumerate(frames):
        assert (fr.encoding, fr.width, fr.height) == ("16UC1", W, H)
        np.testing.assert_array_equal(fr.data, depth_array(i))


def test_rvl_blank_frame_is_tiny_and_decodes() -> None:
    """A frame without depth (lens covered) is one zero run: 12 bytes for 640x480.  A size-to-bytes ratio test
    rejected it (found by the property test in CI)."""
    blank = np.zeros((480, 640), np.uint16)
    payload = encode_rvl(blank)
    assert len(payload) == 12
    out = decode_rvl(np.frombuffer(payload, np.uint8))
    assert out.shape == (480, 640) and not out.any()


def test_rvl_truncated_stream_is_an_error() -> None:
    img = (np.arange(40, dtype=np.uint16).reshape(5, 8) * 37 + 500) * (np.arange(40).reshape(5, 8) % 3 > 0)
    payload = encode_rvl(img.astype(np.uint16))
    with pytest.raises(CompressedDepthError, match="ends|overruns"):
        decode_rvl(np.frombuffer(payload[:-8], np.uint8))


def test_compressed_depth_8bit_png_rejected() -> None:
    ok, png = cv2.imencode(".png", np.zeros((4, 4), np.uint8))
    with pytest.raises(CompressedDepthError, match="single-channel 16-bit"):
        decode_compressed_depth(b"\x00" * 12 + png.tobytes(), fmt="16UC1; compressedDepth png")


def test_corrupt_depth_messages_are_skipped_with_warning(tmp_path: Path) -> None:
    fmt, good = encode_compressed_depth(depth_array(0), encoding="16UC1")
    bad = b"\x00" * 12 + b"garbage"
    msgs = [
        Msg(COMP, COMPRESSED_IMAGE_TYPE, T0 + i * DT, {"header": header(T0 + i * DT), "format": fmt, "data": np.frombuffer(d, np.uint8)})
        for i, d in enumerate([good, bad, good])
    ]
    path = make_recording(tmp_path, "bare_mcap", msgs)
    rec = quiet_open(path)
    with pytest.warns(RecordingWarning, match="skipping an undecodable depth message"):
        frames = list(rec.iter_frames())
    assert len(frames) == 2 and rec.skipped_frames == 1
    # all frames bad -> RecordingError naming the file
    msgs_bad = [Msg(COMP, COMPRESSED_IMAGE_TYPE, T0, {"header": header(T0), "format": fmt, "data": np.frombuffer(bad, np.uint8)})]
    rec2 = quiet_open(make_recording(tmp_path, "bare_mcap", msgs_bad, name="allbad"))
    with pytest.raises(RecordingError, match="could be decoded") as err, warnings.catch_warnings():
        warnings.simplefilter("ignore", RecordingWarning)
        list(rec2.iter_frames())
    assert "allbad.mcap" in str(err.value)


# ------------------------------------------------------------------------------------------------
# Camera YAML
# ------------------------------------------------------------------------------------------------

CAMERA_YAML = """\
image_width: 8
image_height: 6
camera_name: xtion
camera_matrix:
  rows: 3
  cols: 3
  data: [525.0, 0.0, 3.5, 0.0, 526.0, 2.5, 0.0, 0.0, 1.0]
distortion_model: plumb_bob
distortion_coefficients:
  rows: 1
  cols: 5
  data: [0.01, -0.02, 0.0, 0.0, 0.0]
rectification_matrix:
  rows: 3
  cols: 3
  data: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
projection_matrix:
  rows: 3
  cols: 4
  data: [525.0, 0.0, 3.5, 0.0, 0.0, 526.0, 2.5, 0.0, 0.0, 0.0, 1.0, 0.0]
"""


def test_camera_yaml_fallback_when_recording_has_no_camera_info(tmp_path: Path) -> None:
    path = make_recording(tmp_path, "ros1", session(with_info=False))
    with pytest.warns(RecordingWarning, match="no CameraInfo"):
        rec = open_recording(path)
    assert rec.info_topic is None
    assert all(fr.camera_info is None for fr in frames_of(rec))

    yml = tmp_path / "xtion.yaml"
    yml.write_text(CAMERA_YAML)
    rec = open_recording(path, camera_info_file=yml)
    assert rec.camera_info_file == yml and rec.info_topic is None
    frames = frames_of(rec)
    assert len(frames) == N_FRAMES
    ci = frames[0].camera_info
    assert ci is not None and (ci.fx, ci.fy, ci.cx, ci.cy) == (525.0, 526.0, 3.5, 2.5)
    assert ci.frame_id == "cam_depth_optical"  # filled in from the images
    assert ci.d == (0.01, -0.02, 0.0, 0.0, 0.0) and len(ci.p) == 12
    assert all(fr.camera_info is ci for fr in frames)


def test_camera_yaml_overrides_recording_info_with_warning(tmp_path: Path) -> None:
    path = make_recording(tmp_path, "bare_mcap", session())
    yml = tmp_path / "xtion.yaml"
    yml.write_text(CAMERA_YAML)
    with pytest.warns(RecordingWarning, match="instead of the recording's"):
        rec = open_recording(path, camera_info_file=yml)
    assert {fr.camera_info.fx for fr in frames_of(rec) if fr.camera_info} == {525.0}


def test_camera_yaml_round_trip_and_defaults(tmp_path: Path) -> None:
    info = CameraInfoData(
        width=640, height=480, k=(1.0, 0, 2, 0, 3, 4, 0, 0, 1), d=(0.1,) * 5,
        r=(1.0, 0, 0, 0, 1, 0, 0, 0, 1), p=(1.0, 0, 2, 0, 0, 3, 4, 0, 0, 0, 1, 0), distortion_model="plumb_bob",
    )
    dump_camera_info_yaml(info, tmp_path / "c.yaml", camera_name="cam")
    assert load_camera_info_yaml(tmp_path / "c.yaml") == info
    minimal = tmp_path / "m.yaml"
    minimal.write_text("image_width: 4\nimage_height: 2\ncamera_matrix: {rows: 3, cols: 3, data: [2, 0, 1, 0, 2, 0.5, 0, 0, 1]}\n")
    m = load_camera_info_yaml(minimal)
    assert m.r == (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0) and m.d == () and m.distortion_model == "plumb_bob"
    assert m.p == (2.0, 0.0, 1.0, 0.0, 0.0, 2.0, 0.5, 0.0, 0.0, 0.0, 1.0, 0.0)


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        (None, "not found"),
        ("image_width: [oops", "not a valid YAML"),
        ("- 1\n- 2\n", "expected a camera_calibration_parsers YAML mapping"),
        ("image_width: 4\nimage_height: 2\n", "missing required key"),
        ("image_width: 4\nimage_height: 2\ncamera_matrix: {rows: 3, cols: 3, data: [1, 2]}\n", "declares 3x3"),
        ("image_width: 4\nimage_height: 2\ncamera_matrix: {rows: 3, cols: 3, data: [0,0,0,0,0,0,0,0,1]}\n", "focal"),
    ],
)
def test_camera_yaml_errors_become_recording_errors(tmp_path: Path, text: str | None, needle: str) -> None:
    path = make_recording(tmp_path, "bare_mcap", session(with_info=False))
    yml = tmp_path / "cam.yaml"
    if text is not None:
        yml.write_text(text)
    with pytest.raises(RecordingError, match=needle) as err:
        open_recording(path, camera_info_file=yml)
    assert str(yml) in str(err.value)


# ------------------------------------------------------------------------------------------------
# iter_raw
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("fmt", ["rosbag2_mcap", "bare_db3"])
def test_iter_raw_ros2_passes_cdr_through(tmp_path: Path, fmt: str) -> None:
    msgs = session()
    storage = "sqlite3" if fmt == "bare_db3" else "mcap"
    written = write_rosbag2(tmp_path / "ref", msgs, storage=storage)  # same bytes as the fixture
    rec = quiet_open(make_recording(tmp_path, fmt, msgs))
    raw = list(rec.iter_raw())
    assert len(raw) == len(msgs)
    assert [r.stamp_ns for r in raw] == sorted(m.log_ns for m in msgs)
    for r in raw:
        assert r.data == written[(r.topic, r.stamp_ns)]
        assert isinstance(r.data, bytes)
    depth_only = list(rec.iter_raw(topics=[DEPTH]))
    assert [r.topic for r in depth_only] == [DEPTH] * N_FRAMES
    with pytest.raises(RecordingError, match="unknown topic"):
        list(rec.iter_raw(topics=["/nope"]))


@pytest.mark.parametrize("fmt", ["ros1", "ros1_mcap"])
def test_iter_raw_ros1_converts_to_cdr(tmp_path: Path, fmt: str) -> None:
    msgs = session()
    rec = quiet_open(make_recording(tmp_path, fmt, msgs))
    raw = list(rec.iter_raw())
    assert len(raw) == len(msgs)
    by_key = {(m.topic, m.log_ns): m for m in msgs}
    for r in raw:
        src = by_key[(r.topic, r.stamp_ns)]
        assert r.msgtype == src.msgtype
        assert r.data[:4] == b"\x00\x01\x00\x00"
        msg = TS2.deserialize_cdr(r.data, r.msgtype)  # a ROS 2 (Jazzy) message
        expected = build(TS2, src.msgtype, src.fields, ros1=False)
        assert msg.header.stamp == expected.header.stamp
        assert msg.header.frame_id == expected.header.frame_id
        if r.msgtype == IMAGE_TYPE:
            assert (msg.encoding, msg.width, msg.height, msg.step) == (
                expected.encoding, expected.width, expected.height, expected.step,
            )
            np.testing.assert_array_equal(msg.data, expected.data)
        else:
            np.testing.assert_array_equal(msg.k, expected.k)
            np.testing.assert_array_equal(msg.d, expected.d)
            np.testing.assert_array_equal(msg.p, expected.p)
        # and byte-identical to what a ROS 2 recorder would have written
        assert r.data == bytes(TS2.serialize_cdr(expected, r.msgtype))


# ------------------------------------------------------------------------------------------------
# Truncated / damaged MCAP
# ------------------------------------------------------------------------------------------------


def test_truncated_bare_mcap_recovers_readable_part(tmp_path: Path) -> None:
    path = tmp_path / "cut.mcap"
    write_mcap_chunked(path, session(n=40))
    full = quiet_open(path)
    assert full.recovered_messages is None and full.frame_count == 40
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.warns(RecordingWarning, match=r"truncated.*recovered \d+ message") as rec_warn:
        rec = open_recording(path)
    assert str(path) in str(rec_warn[0].message)
    assert rec.recovered_messages is not None and 0 < rec.recovered_messages < 2 * 40 + 3
    assert rec.depth_topic == DEPTH and rec.info_topic == INFO
    frames = frames_of(rec)
    assert 0 < len(frames) == rec.frame_count < 40
    for i, fr in enumerate(frames):
        np.testing.assert_array_equal(frame_depth(fr), depth_array(i))
    assert len(list(rec.iter_raw())) == rec.recovered_messages


def test_truncated_rosbag2_folder_recovers(tmp_path: Path) -> None:
    # 160x120 16UC1 frames -> several 1 MiB chunks in the rosbag2 MCAP
    msgs = []
    for i in range(60):
        arr = np.full((120, 160), 1000 + i, np.uint16)
        msgs.append(Msg(DEPTH, IMAGE_TYPE, T0 + i * DT, image_fields(T0 + i * DT, arr, "16UC1")))
    msgs.append(Msg(INFO, CAMERA_INFO_TYPE, T0 - 1, info_fields(T0, 500.0, w=160, h=120)))
    folder = tmp_path / "bag"
    write_rosbag2(folder, msgs)
    (mcap,) = folder.glob("*.mcap")
    data = mcap.read_bytes()
    mcap.write_bytes(data[: len(data) // 2])
    with pytest.warns(RecordingWarning, match="recovered"):
        rec = open_recording(folder)
    assert rec.storage == "rosbag2/mcap"
    frames = frames_of(rec)
    assert 0 < len(frames) < 60
    assert [int(frame_depth(f)[0, 0]) for f in frames] == [1000 + i for i in range(len(frames))]
    assert all(f.camera_info is not None for f in frames)


def test_mcap_cut_before_first_chunk_is_an_error(tmp_path: Path) -> None:
    path = tmp_path / "tiny.mcap"
    write_mcap_chunked(path, session(n=2), chunk_size=1 << 20)
    data = path.read_bytes()
    path.write_bytes(data[:200])
    with pytest.raises(RecordingError, match="nothing readable") as err:
        open_recording(path)
    assert str(path) in str(err.value)


@pytest.mark.parametrize("indexed", [True, False])
def test_foreign_mcap_with_small_chunks_reads_normally(tmp_path: Path, indexed: bool) -> None:
    path = tmp_path / "foreign.mcap"
    write_mcap_chunked(path, session(), indexed=indexed)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RecordingWarning)  # complete file: no warning
        rec = open_recording(path)
        assert rec.storage == "mcap" and rec.recovered_messages is None
        assert rec.topics[DEPTH].count == N_FRAMES
        fxs = [fr.camera_info.fx for fr in rec.iter_frames() if fr.camera_info]
        assert fxs == [500.0, 500.0, 500.0, 600.0, 600.0]
        assert len(list(rec.iter_frames())) == N_FRAMES  # re-iterable


# ------------------------------------------------------------------------------------------------
# Folders of several recordings
# ------------------------------------------------------------------------------------------------


def test_folder_of_several_recordings(tmp_path: Path) -> None:
    root = tmp_path / "sessions"
    root.mkdir()
    # names deliberately not in time order
    a = make_recording(root, "ros1", session(t0=T0 + 30 * 10**9), name="a_third")
    b = make_recording(root, "rosbag2_sqlite3", session(t0=T0), name="b_first")
    c = make_recording(root, "bare_mcap", session(t0=T0 + 10 * 10**9), name="c_second")
    (root / "notes.txt").write_text("not a recording")
    assert find_recordings(root) == [b, c, a]
    assert find_recordings(b) == [b]
    assert find_recordings(c) == [c]
    assert find_recordings(b / "metadata.yaml") == [b]
    with pytest.raises(RecordingError, match="contains 3 recordings") as err:
        open_recording(root)
    assert str(root) in str(err.value)
    for p in find_recordings(root):
        assert len(frames_of(quiet_open(p))) == N_FRAMES
    # a folder holding exactly one recording opens it; metadata.yaml opens its folder
    solo = tmp_path / "solo"
    solo.mkdir()
    s = make_recording(solo, "bare_db3", session())
    assert quiet_open(solo).path == s
    assert quiet_open(b / "metadata.yaml").path == b


def test_find_recordings_errors(tmp_path: Path) -> None:
    with pytest.raises(RecordingError, match="no such file"):
        find_recordings(tmp_path / "missing")
    (tmp_path / "empty").mkdir()
    with pytest.raises(RecordingError, match="no recordings found") as err:
        find_recordings(tmp_path / "empty")
    assert str(tmp_path / "empty") in str(err.value)


# ------------------------------------------------------------------------------------------------
# Bad inputs
# ------------------------------------------------------------------------------------------------


def _bad_inputs(tmp: Path) -> dict[str, tuple[Path, str]]:
    rng = np.random.default_rng(0)
    out: dict[str, tuple[Path, str]] = {}
    out["missing"] = (tmp / "nope.mcap", "no such file")
    txt = tmp / "notes.txt"
    txt.write_text("hello, I am not a bag\n")
    out["txt"] = (txt, "unknown recording format")
    rnd = tmp / "random.mcap"
    rnd.write_bytes(rng.integers(0, 256, 4096, dtype=np.uint8).tobytes())
    out["random_mcap"] = (rnd, "unknown recording format")
    rbag = tmp / "random.bag"
    rbag.write_bytes(rng.integers(0, 256, 4096, dtype=np.uint8).tobytes())
    out["random_bag"] = (rbag, "unknown recording format")
    empty = tmp / "empty.bag"
    empty.write_bytes(b"")
    out["empty_file"] = (empty, "file is empty")
    db3 = tmp / "corrupt.db3"
    db3.write_bytes(b"SQLite format 3\x00" + rng.integers(0, 256, 4096, dtype=np.uint8).tobytes())
    out["corrupt_db3"] = (db3, "cannot read sqlite3 recording")
    mc = tmp / "garbage.mcap"
    mc.write_bytes(b"\x89MCAP0\r\n" + rng.integers(0, 256, 4096, dtype=np.uint8).tobytes())
    out["garbage_mcap"] = (mc, "corrupt or truncated MCAP")
    ros1 = make_recording(tmp, "ros1", session(), name="cut")
    data = ros1.read_bytes()
    ros1.write_bytes(data[: len(data) // 2])
    out["truncated_ros1"] = (ros1, "cannot read ros1 recording")
    old = tmp / "old.bag"
    old.write_bytes(b"#ROSBAG V1.2\n" + b"\x00" * 100)
    out["ros1_v12"] = (old, "version 1.2 is not supported")
    meta = tmp / "badmeta"
    meta.mkdir()
    (meta / "metadata.yaml").write_text("rosbag2_bagfile_information: {version: 9}\n")
    out["bad_metadata"] = (meta, "cannot read rosbag2")
    out["no_depth"] = (
        make_recording(tmp, "bare_mcap", [m for m in session() if m.topic != DEPTH], name="nodepth"),
        "no depth image topic found",
    )
    empty_rec = make_recording(tmp, "rosbag2_mcap", [Msg(DEPTH, IMAGE_TYPE, T0, {}), Msg(INFO, CAMERA_INFO_TYPE, T0, {})], name="norecs")
    out["empty_recording"] = (empty_rec, "recording is empty")
    return out


BAD_CASES = [
    "missing", "txt", "random_mcap", "random_bag", "empty_file", "corrupt_db3", "garbage_mcap",
    "truncated_ros1", "ros1_v12", "bad_metadata", "no_depth", "empty_recording",
]


@pytest.mark.parametrize("case", BAD_CASES)
def test_bad_inputs_raise_recording_error_naming_the_file(tmp_path: Path, case: str) -> None:
    path, needle = _bad_inputs(tmp_path)[case]
    with pytest.raises(RecordingError) as err, warnings.catch_warnings():
        warnings.simplefilter("ignore", RecordingWarning)
        open_recording(path)
    text = str(err.value)
    assert str(path) in text, text
    assert needle in text, text
    if case == "no_depth":
        assert RGB in text and "rgb8" in text  # lists what is there


# ------------------------------------------------------------------------------------------------
# Real ROS 1 bag (HSR Xtion): 32FC1 depth + rgb8 image + one CameraInfo
# ------------------------------------------------------------------------------------------------


def test_real_ros1_bag(real_bag: Path) -> None:
    # real_bag (test/conftest.py): <repo>/../shared/data/real/xtion_person_32fc1.bag, pytest.fail if missing
    rec = quiet_open(real_bag)
    assert rec.storage == "ros1"
    assert rec.depth_topic == "/hero/head_rgbd_sensor/depth_registered/image"
    assert rec.info_topic == "/hero/head_rgbd_sensor/rgb/camera_info"
    assert rec.topics["/hero/head_rgbd_sensor/rgb/image_raw"].encoding == "rgb8"
    (fr,) = frames_of(rec)
    assert (fr.encoding, fr.width, fr.height, fr.step) == ("32FC1", 640, 480, 2560)
    assert fr.frame_id == "head_rgbd_sensor_rgb_frame"
    ci = fr.camera_info
    assert ci is not None and ci.distortion_model == "plumb_bob" and (ci.width, ci.height) == (640, 480)
    assert ci.fx > 400 and 250 < ci.cx < 390
    depth = np.frombuffer(fr.data, dtype="<f4").reshape(480, 640)
    valid = depth[np.isfinite(depth)]
    assert valid.size > 0.2 * depth.size  # ~32 % valid in this frame
    assert 0.3 < float(np.median(valid)) < 5.0  # metres
    raw = list(rec.iter_raw())
    assert {r.topic for r in raw} == set(rec.topics)
    for r in raw:  # ROS 1 -> CDR, readable as Jazzy messages
        msg = TS2.deserialize_cdr(r.data, r.msgtype)
        assert msg.header.frame_id == "head_rgbd_sensor_rgb_frame"


def test_db3_without_embedded_definitions_uses_jazzy_types(tmp_path: Path) -> None:
    import sqlite3

    path = make_recording(tmp_path, "bare_db3", session())
    con = sqlite3.connect(path)
    con.execute("DELETE FROM message_definitions")  # like bags from recorders that store no definitions
    con.commit()
    con.close()
    rec = quiet_open(path)
    assert rec.depth_topic == DEPTH and rec.info_topic == INFO
    frames = frames_of(rec)
    assert len(frames) == N_FRAMES and frames[-1].camera_info is not None and frames[-1].camera_info.fx == 600.0
