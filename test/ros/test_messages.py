"""walker_gait_msgs: rclpy and rosbags (registered from msg_defs/*.msg) agree on the wire format."""

from __future__ import annotations

import dataclasses
import importlib
import math
from types import SimpleNamespace

import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message

from walker_gait import messages as M
from walker_gait.core.types import ANKLE, HEEL, HIP, KNEE, TOE
from walker_gait.core.types import EventKind, FloorPlane, GaitEvent, LegPose, Side, Step, TrackStatus


def rclpy_cls(typename: str):
    pkg, _, name = typename.split("/")
    return getattr(importlib.import_module(f"{pkg}.msg"), name)


def sample_messages():
    rng = np.random.default_rng(3)
    header = M.make_header(1234.5678, "camera_depth_optical_frame")
    pose = LegPose(stamp=1234.5678, points=rng.normal(size=(2, 5, 3)), angles=rng.normal(size=12),
                   segments=rng.normal(size=(2, 3, 2, 3)), radii=rng.uniform(0.02, 0.08, size=(2, 3, 2)),
                   visibility=rng.uniform(size=(2, 3)), status=TrackStatus.DEGRADED, confidence=0.7, ess=123.0)
    step = Step(stamp=12.25, side=Side.RIGHT, index=7, step_length=0.52, step_width=0.11, step_time=0.61,
                stride_length=1.03, stride_time=1.2, stance_time=0.74, swing_time=0.46, single_support_time=0.45,
                double_support_time=0.28, confidence=0.9)
    event = GaitEvent(stamp=12.25, side=Side.LEFT, kind=EventKind.TOE_OFF, position=np.array([0.1, 0.4, 0.8]),
                      confidence=0.5)
    summary = {"scope": 1, "step_count": 12, "cadence": 98.5, "gait_speed": 0.81,
               "step_length_mean_side": [0.5, 0.55], "step_length_symmetry": 0.91}
    return {
        M.STEP: M.make_step(step, "cam"),
        M.GAIT_EVENT: M.make_gait_event(event, "cam"),
        M.GAIT_SUMMARY: M.make_gait_summary(summary, header),
        M.LEG_TRACK: M.make_leg_track(pose, header, particle_count=300),
        M.FLOOR_PLANE: M.make_floor_plane(dataclasses.replace(FloorPlane.from_camera_pose(height=0.5, pitch=0.6),
                                                              anchor=np.array([0.0, 0.28, 0.41]),
                                                              heading=np.array([0.0, 0.56, 0.83])), header),
        M.JOINT_STATE: M.make_joint_state(pose, header),
        M.MARKER_ARRAY: M.make_markers(pose, header),
    }


OUR_TYPES = [M.STEP, M.GAIT_EVENT, M.GAIT_SUMMARY, M.LEG_TRACK, M.FLOOR_PLANE]


@pytest.mark.parametrize("typename", OUR_TYPES)
def test_round_trip_rosbags_rclpy_rosbags_same_bytes(typename: str) -> None:
    msg = sample_messages()[typename]
    data = M.serialize(msg)
    via_rclpy = deserialize_message(data, rclpy_cls(typename))
    again = M.serialize(M.deserialize(serialize_message(via_rclpy), typename))
    assert again == data


@pytest.mark.parametrize("typename", [M.JOINT_STATE, M.MARKER_ARRAY])
def test_standard_types_we_publish_decode_in_rclpy(typename: str) -> None:
    # FastCDR pads empty float64 sequences where rosbags does not, so rclpy's own bytes for these types
    # are not byte-identical; what subscribers need is that our bytes decode to the same values.
    msg = sample_messages()[typename]
    ros = deserialize_message(M.serialize(msg), rclpy_cls(typename))
    if typename == M.JOINT_STATE:
        assert list(ros.name) == list(msg.name)
        np.testing.assert_allclose(np.asarray(ros.position), msg.position)
    else:
        assert len(ros.markers) == len(msg.markers)
        assert [m.id for m in ros.markers] == [m.id for m in msg.markers]
        assert ros.markers[0].scale.z == pytest.approx(msg.markers[0].scale.z)


def test_rclpy_message_fields_match_rosbags_fields() -> None:
    msg = sample_messages()[M.STEP]
    ros = deserialize_message(M.serialize(msg), rclpy_cls(M.STEP))
    for name in ("foot", "step_index", "step_length", "step_width", "step_time", "stride_length", "stride_time",
                 "stance_time", "swing_time", "single_support_time", "double_support_time", "confidence"):
        assert math.isclose(getattr(ros, name), getattr(msg, name), rel_tol=1e-6), name
    assert ros.header.stamp.sec == 12 and ros.header.stamp.nanosec == 250_000_000
    assert ros.foot == ros.RIGHT == int(Side.RIGHT)


def test_rclpy_bytes_decode_in_rosbags() -> None:
    cls = rclpy_cls(M.LEG_TRACK)
    ros = cls()
    ros.status = cls.TRACKING
    ros.heel[0].x = 0.25
    ros.calf_visibility[1] = 0.5
    back = M.deserialize(serialize_message(ros), M.LEG_TRACK)
    assert back.status == int(TrackStatus.TRACKING)
    assert back.heel[0].x == 0.25
    assert back.calf_visibility[1] == 0.5


def test_constants_match_core_enums() -> None:
    assert rclpy_cls(M.STEP).LEFT == Side.LEFT and rclpy_cls(M.STEP).RIGHT == Side.RIGHT
    ev = rclpy_cls(M.GAIT_EVENT)
    assert (ev.HEEL_STRIKE, ev.TOE_OFF) == (EventKind.HEEL_STRIKE, EventKind.TOE_OFF)
    lt = rclpy_cls(M.LEG_TRACK)
    assert [lt.NO_USER, lt.SEARCHING, lt.TRACKING, lt.DEGRADED] == [s.value for s in TrackStatus]


def test_leg_track_round_trips_a_pose() -> None:
    rng = np.random.default_rng(0)
    pose = LegPose(stamp=3.5, points=rng.normal(size=(2, 5, 3)), segments=rng.normal(size=(2, 3, 2, 3)),
                   radii=rng.uniform(0.02, 0.08, size=(2, 3, 2)), visibility=rng.uniform(size=(2, 3)))
    # the reported points are the particles' mean, the segments the mean state's cylinders: they differ (an ankle by
    # up to 2 cm on a walk), and a subscriber must get the points the offline analysis reads
    back = M.leg_pose_from_track(M.deserialize(M.serialize(M.make_leg_track(pose, M.make_header(3.5, "c"))),
                                               M.LEG_TRACK))
    np.testing.assert_allclose(back.points, pose.points, atol=1e-12)
    np.testing.assert_allclose(back.segments, pose.segments, atol=1e-12)
    np.testing.assert_allclose(back.visibility, pose.visibility, rtol=1e-6)
    np.testing.assert_allclose(back.radii, pose.radii, rtol=1e-6)
    assert back.stamp == pytest.approx(3.5)
    assert back.heel_tracked is None and back.ankle_tracked is None and back.toe_tracked is None  # as tracked
    assert back.as_tracked() is back


def test_leg_track_carries_the_trackers_heels_beside_the_placed_ones() -> None:
    """Live, the placement moves the reported heels (LivePelvis); the message keeps the tracker's in ``heel_tracked``
    and the pose rebuilt from it gives them back to the gait analysis (``as_tracked``), the other points as reported."""
    rng = np.random.default_rng(1)
    points = rng.normal(size=(2, 5, 3))
    tracked = points[:, 3] + np.array([0.03, 0.0, -0.01])
    pose = LegPose(stamp=2.0, points=points, heel_tracked=tracked)
    msg = M.deserialize(M.serialize(M.make_leg_track(pose, M.make_header(2.0, "c"))), M.LEG_TRACK)
    back = M.leg_pose_from_track(msg)
    np.testing.assert_allclose(back.points, points, atol=1e-12)
    np.testing.assert_allclose(back.heel_tracked, tracked, atol=1e-12)
    analysed = back.as_tracked()
    np.testing.assert_allclose(analysed.points[:, 3], tracked, atol=1e-12)
    np.testing.assert_array_equal(np.delete(analysed.points, 3, axis=1), np.delete(back.points, 3, axis=1))
    assert analysed.heel_tracked is None


def test_leg_track_carries_the_trackers_ankles_and_toes_beside_the_placed_ones() -> None:
    """The placement moves the reported ankles towards the placed foot's and puts flat feet on the floor
    (LivePelvis); the message keeps the tracker's in ``ankle_tracked`` and ``toe_tracked``, and the pose rebuilt from
    it gives them and the tracker's heels back to the gait analysis (``as_tracked``); a message without the fields
    (recorded before they existed) reads as nothing moved."""
    rng = np.random.default_rng(2)
    points = rng.normal(size=(2, 5, 3))
    heels = points[:, HEEL] + np.array([0.03, 0.0, -0.01])
    ankles = points[:, ANKLE] + np.array([0.0, 0.01, 0.02])
    toes = points[:, TOE] + np.array([0.0, 0.0, 0.007])
    pose = LegPose(stamp=2.0, points=points, heel_tracked=heels, ankle_tracked=ankles, toe_tracked=toes)
    msg = M.deserialize(M.serialize(M.make_leg_track(pose, M.make_header(2.0, "c"))), M.LEG_TRACK)
    back = M.leg_pose_from_track(msg)
    np.testing.assert_allclose(back.points, points, atol=1e-12)
    np.testing.assert_allclose(back.ankle_tracked, ankles, atol=1e-12)
    np.testing.assert_allclose(back.toe_tracked, toes, atol=1e-12)
    analysed = back.as_tracked()
    np.testing.assert_allclose(analysed.points[:, ANKLE], ankles, atol=1e-12)
    np.testing.assert_allclose(analysed.points[:, HEEL], heels, atol=1e-12)
    np.testing.assert_allclose(analysed.points[:, TOE], toes, atol=1e-12)
    np.testing.assert_array_equal(analysed.points[:, [HIP, KNEE]], back.points[:, [HIP, KNEE]])
    assert analysed.ankle_tracked is None and analysed.heel_tracked is None and analysed.toe_tracked is None
    only_toes = M.leg_pose_from_track(M.deserialize(M.serialize(M.make_leg_track(
        LegPose(stamp=2.0, points=points, toe_tracked=toes), M.make_header(2.0, "c"))), M.LEG_TRACK))
    assert only_toes.heel_tracked is None and only_toes.ankle_tracked is None
    np.testing.assert_allclose(only_toes.as_tracked().points[:, TOE], toes, atol=1e-12)
    old = SimpleNamespace(**{f.name: getattr(msg, f.name) for f in dataclasses.fields(msg)
                             if f.name not in ("ankle_tracked", "toe_tracked")})
    assert not hasattr(old, "ankle_tracked") and not hasattr(old, "toe_tracked")
    rebuilt = M.leg_pose_from_track(old)
    assert rebuilt.ankle_tracked is None and rebuilt.toe_tracked is None


def test_pointcloud2_round_trip_organised_and_dense() -> None:
    rng = np.random.default_rng(1)
    organised = rng.normal(size=(4, 6, 3)).astype(np.float32)
    organised[0, 0] = np.nan
    msg = M.deserialize(M.serialize(M.make_pointcloud2(organised, M.make_header(1.0, "c"))), M.POINT_CLOUD2)
    assert (msg.height, msg.width, msg.is_dense) == (4, 6, False)
    np.testing.assert_array_equal(M.read_pointcloud2(msg), organised)
    dense = rng.normal(size=(10, 3)).astype(np.float32)
    msg = M.make_pointcloud2(dense, M.make_header(1.0, "c"))
    assert (msg.height, msg.width, msg.is_dense) == (1, 10, True)
    np.testing.assert_array_equal(M.read_pointcloud2(msg), dense)


def test_header_stamps_give_the_seconds_the_recording_readers_give() -> None:
    """A frame's stamp is the same float in the live nodes (``builtin_interfaces/Time``) and in the offline
    pipeline (recording readers: integer nanoseconds / 1e9); ``sec + nanosec * 1e-9`` differs in the last bit for
    most 30 Hz stamps, enough to move a frame across an analysis window's edge."""
    rng = np.random.default_rng(3)
    stamps_ns = [round(k * 1e9 / 30) for k in range(300)] + [int(x) for x in rng.integers(0, 2**60, 200)]
    off_by_a_bit = 0
    for ns in stamps_ns:
        t = M.make_time(ns, ns=True)
        assert M.stamp_to_s(t) == ns / 1e9
        off_by_a_bit += (float(t.sec) + float(t.nanosec) * 1e-9) != ns / 1e9
    assert off_by_a_bit > 0  # the naive sum really differs for some of these stamps


def test_floor_plane_anchor_and_heading_survive_the_message_and_zeros_mean_none() -> None:
    header = M.make_header(3.5, "cam")
    plane = dataclasses.replace(FloorPlane.from_camera_pose(height=0.5, pitch=0.6), anchor=np.array([0.01, 0.28, 0.41]),
                                heading=np.array([0.0, 0.56, 0.83]))
    back = M.floor_from_msg(M.deserialize(M.serialize(M.make_floor_plane(plane, header)), M.FLOOR_PLANE))
    np.testing.assert_allclose(back.anchor, plane.anchor)
    np.testing.assert_allclose(back.heading, plane.heading)
    np.testing.assert_allclose(back.to_walker(np.array([0.1, 0.2, 1.0])), plane.to_walker(np.array([0.1, 0.2, 1.0])))
    bare = M.floor_from_msg(M.deserialize(M.serialize(M.make_floor_plane(FloorPlane.from_camera_pose(height=0.5, pitch=0.6),
                                                                          header)), M.FLOOR_PLANE))
    assert bare.anchor is None and bare.heading is None


def test_foreground_mask_carries_the_pixels_without_depth() -> None:
    header = M.make_header(1.0, "cam")
    mask = np.zeros((6, 8), dtype=bool)
    mask[2:4, 3:5] = True
    no_depth = np.zeros_like(mask)
    no_depth[0, :] = True
    no_depth[5, 6] = True
    msg = M.deserialize(M.serialize(M.make_foreground_mask(mask, no_depth, header)), M.IMAGE)
    assert msg.encoding == "mono8"
    np.testing.assert_array_equal(M.image_to_mask(msg), mask)
    np.testing.assert_array_equal(M.image_to_no_depth(msg), no_depth)
    data = np.asarray(msg.data).reshape(6, 8)
    assert data[2, 3] == M.MASK_FOREGROUND and data[0, 0] == M.MASK_NO_DEPTH and data[1, 0] == 0
    # a plain 0 / 255 mask (an older recording) has no unknown pixels
    plain = M.make_image(mask.astype(np.uint8) * 255, header, encoding="mono8")
    np.testing.assert_array_equal(M.image_to_mask(plain), mask)
    assert not M.image_to_no_depth(plain).any()
    assert not M.image_to_no_depth(M.make_foreground_mask(mask, None, header)).any()
