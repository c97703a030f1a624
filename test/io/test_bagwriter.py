"""Atomic rosbag writer (walker_gait/io/bagwriter.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from walker_gait.io.bagwriter import BagWriteError, BagWriter, default_typestore

CASES = [("mcap", "b.mcap"), ("mcap", "bagdir"), ("sqlite3", "b.db3"), ("sqlite3", "bagdir"), ("ros1", "b.bag")]


def _string_msg(bag: BagWriter, text: str) -> object:
    return bag.typestore.types["std_msgs/msg/String"](data=text)


@pytest.mark.parametrize(("fmt", "name"), CASES)
@pytest.mark.parametrize("compress", [False, True])
def test_round_trip(tmp_path: Path, fmt: str, name: str, compress: bool) -> None:
    path = tmp_path / name
    if compress and name == "b.db3":
        with pytest.raises(BagWriteError, match="directory layout"):
            BagWriter(path, fmt="sqlite3", compress=True)
        return
    with BagWriter(path, fmt=fmt, compress=compress) as bag:  # type: ignore[arg-type]
        h = bag.add_topic("/chatter", "std_msgs/msg/String")
        for i in range(5):
            bag.write(h, 1_000 + i, _string_msg(bag, f"hello {i}"))
        bag.write("/chatter", 2_000, _string_msg(bag, "by name"))
        assert bag.message_count == 6
    assert path.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]  # temp dir removed
    with AnyReader([path]) as reader:
        got = [(t, reader.deserialize(raw, c.msgtype).data) for c, t, raw in reader.messages()]  # type: ignore[attr-defined]
    assert got == [(1_000 + i, f"hello {i}") for i in range(5)] + [(2_000, "by name")]
    if name == "bagdir":
        assert (path / "metadata.yaml").is_file()


@pytest.mark.parametrize(("fmt", "name"), CASES)
def test_exception_leaves_nothing(tmp_path: Path, fmt: str, name: str) -> None:
    path = tmp_path / name
    with pytest.raises(RuntimeError, match="boom"):
        with BagWriter(path, fmt=fmt) as bag:  # type: ignore[arg-type]
            h = bag.add_topic("/chatter", "std_msgs/msg/String")
            for i in range(100):
                bag.write(h, i, _string_msg(bag, "x" * 1000))
            raise RuntimeError("boom")
    assert not path.exists()
    assert list(tmp_path.iterdir()) == []


def test_refuses_to_overwrite(tmp_path: Path) -> None:
    path = tmp_path / "b.mcap"
    path.write_bytes(b"precious")
    with pytest.raises(BagWriteError, match="exists"):
        BagWriter(path, fmt="mcap").open()
    assert path.read_bytes() == b"precious"
    with BagWriter(path, fmt="mcap", overwrite=True) as bag:
        bag.add_topic("/a", "std_msgs/msg/String")
    assert path.read_bytes() != b"precious"


def test_errors(tmp_path: Path) -> None:
    with pytest.raises(BagWriteError, match="unknown bag format"):
        BagWriter(tmp_path / "x", fmt="zip")  # type: ignore[arg-type]
    with pytest.raises(BagWriteError, match=r"\.bag"):
        BagWriter(tmp_path / "x.mcap", fmt="ros1")
    bag = BagWriter(tmp_path / "y.mcap")
    with pytest.raises(BagWriteError, match="not open"):
        bag.add_topic("/a", "std_msgs/msg/String")
    with BagWriter(tmp_path / "z.mcap") as bag:
        with pytest.raises(BagWriteError, match="not in the typestore"):
            bag.add_topic("/a", "nope_msgs/msg/Nope")
        with pytest.raises(BagWriteError, match="was not added"):
            bag.write("/missing", 0, b"")
        bag.add_topic("/a", "std_msgs/msg/String")
        with pytest.raises(BagWriteError, match="already added"):
            bag.add_topic("/a", "std_msgs/msg/String")
        with pytest.raises(BagWriteError, match="negative"):
            bag.write("/a", -1, _string_msg(bag, "x"))
    assert (tmp_path / "z.mcap").is_file()


@pytest.mark.parametrize(("fmt", "name"), [("mcap", "c.mcap"), ("ros1", "c.bag")])
def test_custom_message_type(tmp_path: Path, fmt: str, name: str) -> None:
    ts = default_typestore(fmt)  # type: ignore[arg-type]
    ts.register(get_types_from_msg("float64 step_length\nuint8 side\n", "walker_gait_msgs/msg/Demo"))
    path = tmp_path / name
    with BagWriter(path, fmt=fmt, typestore=ts) as bag:  # type: ignore[arg-type]
        h = bag.add_topic("/steps", "walker_gait_msgs/msg/Demo")
        cls = ts.types["walker_gait_msgs/msg/Demo"]
        bag.write(h, 5, cls(step_length=0.5, side=1))
    with AnyReader([path]) as reader:
        (conn, t, raw), = list(reader.messages())
        msg = reader.deserialize(raw, conn.msgtype)
    assert conn.msgtype == "walker_gait_msgs/msg/Demo" and t == 5
    assert msg.step_length == 0.5 and msg.side == 1  # type: ignore[attr-defined]


def test_image_message_bytes(tmp_path: Path) -> None:
    ts = get_typestore(Stores.ROS2_JAZZY)
    path = tmp_path / "img.mcap"
    data = np.arange(12, dtype="<u2")
    with BagWriter(path, typestore=ts) as bag:
        h = bag.add_topic("/img", "sensor_msgs/msg/Image", qos=None)
        Img = ts.types["sensor_msgs/msg/Image"]
        Hdr = ts.types["std_msgs/msg/Header"]
        Time = ts.types["builtin_interfaces/msg/Time"]
        msg = Img(header=Hdr(stamp=Time(sec=1, nanosec=2), frame_id="f"), height=3, width=4, encoding="16UC1", is_bigendian=0, step=8, data=data.view(np.uint8))
        bag.write(h, 10, bag.serialize(msg, "sensor_msgs/msg/Image"))  # pre-serialised bytes
    with AnyReader([path]) as reader:
        (conn, _, raw), = list(reader.messages())
        m = reader.deserialize(raw, conn.msgtype)
    np.testing.assert_array_equal(np.asarray(m.data).view("<u2"), data)  # type: ignore[attr-defined]
