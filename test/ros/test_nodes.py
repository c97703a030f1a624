"""Nodes survive bad input: nothing escapes a callback, each kind is logged once and counted, and the
next good frame is processed. Messages enter through the same dispatch path as DDS deliveries."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
import rclpy
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from walker_gait import messages as M
from walker_gait.core.types import CameraIntrinsics, FloorPlane, LegPose, TrackStatus

pytestmark = pytest.mark.ros

INTR = CameraIntrinsics(width=64, height=48, fx=60.0, fy=60.0, cx=31.5, cy=23.5)


@pytest.fixture(scope="module")
def rclpy_context() -> Iterator[None]:
    rclpy.init()
    yield
    rclpy.shutdown()


def good_depth(h: int = 48, w: int = 64) -> np.ndarray:
    """Floor seen by a camera 0.5 m up, pitched 0.5 rad down, plus a box 'leg'."""
    floor = FloorPlane.from_camera_pose(height=0.5, pitch=0.5)
    v, u = np.mgrid[0:h, 0:w].astype(np.float64)
    rays = np.stack([(u - INTR.cx) / INTR.fx, (v - INTR.cy) / INTR.fy, np.ones_like(u)], axis=-1)
    denom = rays @ floor.normal
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(denom < -1e-6, -floor.offset / denom, 0.0)
    z[10:40, 25:35] = 0.8
    return (np.clip(z, 0, 4) * 1000).astype(np.uint16)


def good_points() -> np.ndarray:
    """The organised camera-frame cloud ``(48, 64, 3)`` of :func:`good_depth`."""
    from walker_gait.core.depth import DepthProjector, decode_depth

    proj = DepthProjector()
    proj.set_intrinsics(INTR)
    return proj.points(decode_depth(good_depth().tobytes(), encoding="16UC1", width=64, height=48, step=128,
                                    is_bigendian=False))


def image_bytes(depth: np.ndarray, *, encoding: str = "16UC1", stamp: float = 1.0) -> bytes:
    return M.serialize(M.make_image(depth, M.make_header(stamp, "cam"), encoding=encoding))


def info_bytes() -> bytes:
    return M.serialize(M.make_camera_info(INTR, M.make_header(1.0, "cam")))


def make_depth_node() -> Any:
    from walker_gait.ros.nodes import DepthToCloudNode

    node = DepthToCloudNode()
    published: list[Any] = []
    node.pub_points = published.append
    node.points_wanted = lambda: True  # as if RViz subscribed to `points`
    return node, published


def test_depth_to_cloud_is_lazy(rclpy_context: None) -> None:
    """No cloud is built while nothing subscribes to `points`; one is as soon as something does."""
    from walker_gait.ros.base import STREAM_IN, rclpy_type
    from walker_gait.ros.nodes import DepthToCloudNode

    node = DepthToCloudNode()
    published: list[Any] = []
    real_publish = node.pub_points
    node.pub_points = lambda msg: (published.append(msg), real_publish(msg))
    try:
        node.dispatch("depth/camera_info", M.CAMERA_INFO, node.on_info, info_bytes())
        node.input.on_image_bytes(image_bytes(good_depth()))  # what the subscription calls
        node.input.on_image_bytes(b"garbage")  # not even deserialised
        assert published == [] and node.frames_ok == 0 and not node.problems
        sub = node.create_subscription(rclpy_type(M.POINT_CLOUD2), "points", lambda m: None, STREAM_IN, raw=True)
        assert node.points_wanted()
        node.input.on_image_bytes(image_bytes(good_depth(), stamp=2.0))
        assert len(published) == 1 and node.frames_ok == 1
        node.destroy_subscription(sub)
    finally:
        node.destroy_node()


def _spin_until(nodes: list[Any], cond: Any, timeout: float = 10.0) -> bool:
    import time

    from rclpy.executors import SingleThreadedExecutor

    ex = SingleThreadedExecutor()
    for n in nodes:
        ex.add_node(n)
    end = time.monotonic() + timeout
    while not cond() and time.monotonic() < end:
        ex.spin_once(timeout_sec=0.05)
    ex.shutdown()
    return bool(cond())


def test_depth_to_cloud_subscribes_to_images_only_while_points_has_a_subscriber(rclpy_context: None) -> None:
    """Without a `points` subscriber the node does not even subscribe to the depth images (receiving them
    costs CPU); a subscriber appearing/leaving (the publisher's matched event) adds/removes it."""
    from walker_gait.ros.base import STREAM_IN, rclpy_type
    from walker_gait.ros.nodes import DepthToCloudNode

    node = DepthToCloudNode()
    probe = rclpy.create_node("lazy_probe")
    try:
        assert node.input.image_subscription is None
        sub = probe.create_subscription(rclpy_type(M.POINT_CLOUD2), "points", lambda m: None, STREAM_IN, raw=True)
        assert _spin_until([node, probe], lambda: node.input.image_subscription is not None)
        probe.destroy_subscription(sub)
        assert _spin_until([node, probe], lambda: node.input.image_subscription is None)
    finally:
        probe.destroy_node()
        node.destroy_node()


def test_depth_before_camera_info_is_held_then_processed(rclpy_context: None) -> None:
    from walker_gait.ros.nodes import WAITING_IMAGES

    node, published = make_depth_node()
    try:
        # images racing ahead of the first CameraInfo are held (only the newest WAITING_IMAGES)...
        for _ in range(WAITING_IMAGES + 2):
            node.dispatch("depth/image_raw", M.IMAGE, node.on_image, image_bytes(good_depth()))
        assert published == []
        # ...and converted, in order, when it arrives
        node.dispatch("depth/camera_info", M.CAMERA_INFO, node.on_info, info_bytes())
        assert len(published) == WAITING_IMAGES
        published.clear()
        node.dispatch("depth/image_raw", M.IMAGE, node.on_image, image_bytes(good_depth()))
        assert len(published) == 1
        cloud = M.read_pointcloud2(published[0])
        assert cloud.shape == (48, 64, 3)
        assert np.nanmax(cloud[..., 2]) == pytest.approx(good_depth().max() / 1000, rel=1e-6)
    finally:
        node.destroy_node()


class FakeLogger:
    def __init__(self) -> None:
        self.errors: list[str] = []

    def error(self, text: str) -> None:
        self.errors.append(text)

    def warning(self, text: str) -> None:
        pass


def test_bad_camera_info_is_rejected_counted_and_logged_once(rclpy_context: None) -> None:
    node, published = make_depth_node()
    logger = FakeLogger()
    node.get_logger = lambda: logger
    try:
        bad = M.make_camera_info(INTR, M.make_header(1.0, "cam"))
        bad.k[0] = 0.0
        bad.p[0] = 0.0
        for _ in range(3):
            node.dispatch("depth/camera_info", M.CAMERA_INFO, node.on_info, M.serialize(bad))
        assert sum(node.problems.values()) == 3 and len(node.problems) == 1
        assert len(logger.errors) == 1 and "focal" in logger.errors[0].lower()
        for _ in range(2):  # a second kind of problem is logged once too
            node.dispatch("depth/image_raw", M.IMAGE, node.on_image, b"junk")
        assert len(logger.errors) == 2
        node.dispatch("depth/camera_info", M.CAMERA_INFO, node.on_info, info_bytes())
        node.dispatch("depth/image_raw", M.IMAGE, node.on_image, image_bytes(good_depth()))
        assert len(published) == 1
    finally:
        node.destroy_node()


ENCODINGS = st.sampled_from(["16UC1", "mono16", "32FC1", "rgb8", "8UC1", "bgr8", "", "64FC1"])


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(h=st.integers(0, 60), w=st.integers(0, 80), pad=st.integers(-4, 8), encoding=ENCODINGS,
       fill=st.sampled_from(["random", "zero", "nan", "inf", "max"]), bigendian=st.booleans(),
       truncate=st.integers(0, 5), seed=st.integers(0, 2**16))
def test_random_bad_frames_never_escape_and_good_frame_follows(rclpy_context: None, h: int, w: int, pad: int,
                                                               encoding: str, fill: str, bigendian: bool,
                                                               truncate: int, seed: int) -> None:
    node, published = make_depth_node()
    try:
        node.dispatch("depth/camera_info", M.CAMERA_INFO, node.on_info, info_bytes())
        rng = np.random.default_rng(seed)
        bpp = 4 if encoding == "32FC1" else 2
        step = max(w * bpp + pad, 0)
        raw = rng.integers(0, 256, size=step * h, dtype=np.uint8)
        if fill == "zero":
            raw[:] = 0
        elif fill == "max":
            raw[:] = 255
        elif encoding == "32FC1" and fill in ("nan", "inf") and w > 0 and h > 0 and pad >= 0:
            vals = np.full((h, step // 4), np.nan if fill == "nan" else np.inf, dtype=np.float32)
            raw = np.frombuffer(vals.tobytes(), dtype=np.uint8)
        if truncate:
            raw = raw[: max(0, raw.size - truncate * 7)]
        msg = M.msg_class(M.IMAGE)(header=M.make_header(2.0, "cam"), height=h, width=w, encoding=encoding,
                                   is_bigendian=int(bigendian), step=step, data=raw)
        node.dispatch("depth/image_raw", M.IMAGE, node.on_image, M.serialize(msg))  # must not raise
        node.dispatch("depth/image_raw", M.IMAGE, node.on_image, b"\x00\x01\x00\x00garbage")  # undecodable
        assert "undecodable_message" in node.problems
        before = len(published)
        node.dispatch("depth/image_raw", M.IMAGE, node.on_image, image_bytes(good_depth(), stamp=3.0))
        assert len(published) == before + 1
    finally:
        node.destroy_node()


def test_floor_segmentation_node_handles_all_invalid_and_good_clouds(rclpy_context: None) -> None:
    from walker_gait.core.depth import DepthProjector, decode_depth
    from walker_gait.ros.nodes import FloorSegmentationNode

    node = FloorSegmentationNode(parameter_overrides=[rclpy.parameter.Parameter("input", value="points")])
    out: dict[str, list[Any]] = {"fg": [], "mask": [], "floor": []}
    node.pub_fg, node.pub_mask, node.pub_floor = out["fg"].append, out["mask"].append, out["floor"].append
    try:
        proj = DepthProjector()
        proj.set_intrinsics(INTR)
        nan_cloud = np.full((48, 64, 3), np.nan, dtype=np.float32)
        node.dispatch("points", M.POINT_CLOUD2, node.on_cloud,
                      M.serialize(M.make_pointcloud2(nan_cloud, M.make_header(1.0, "cam"))))
        node.dispatch("points", M.POINT_CLOUD2, node.on_cloud,
                      M.serialize(M.make_pointcloud2(np.zeros((5, 3), np.float32), M.make_header(1.0, "cam"))))
        assert node.problems  # unorganised cloud counted
        d = good_depth()
        d[:3] = 0  # no depth measured in the top rows, in every frame
        depth = decode_depth(d.tobytes(), encoding="16UC1", width=64, height=48, step=128, is_bigendian=False)
        for i in range(3):
            node.dispatch("points", M.POINT_CLOUD2, node.on_cloud,
                          M.serialize(M.make_pointcloud2(proj.points(depth), M.make_header(2.0 + i, "cam"))))
        assert len(out["floor"]) == 4 and len(out["mask"]) == 4
        last_floor = M.floor_from_msg(out["floor"][-1])
        assert last_floor.valid
        assert last_floor.offset == pytest.approx(0.5, abs=0.03)
        mask = M.image_to_mask(out["mask"][-1])
        assert mask[12:25, 27:33].mean() > 0.9  # the box (above the floor) is foreground
        assert mask[45:, :].mean() < 0.02  # the floor is not
        # a hole that opens in the box (nearer than the sensor reaches) is marked as such for the tracker: unknown,
        # not background; the top rows, missing in every frame, are not
        d[15:20, 28:32] = 0
        holed = decode_depth(d.tobytes(), encoding="16UC1", width=64, height=48, step=128, is_bigendian=False)
        node.dispatch("points", M.POINT_CLOUD2, node.on_cloud,
                      M.serialize(M.make_pointcloud2(proj.points(holed), M.make_header(5.0, "cam"))))
        no_depth = M.image_to_no_depth(out["mask"][-1])
        expected = np.zeros_like(no_depth)
        expected[15:20, 28:32] = True
        np.testing.assert_array_equal(no_depth, expected)
    finally:
        node.destroy_node()


def test_floor_segmentation_warns_once_per_floorless_stretch(rclpy_context: None) -> None:
    """NO_FLOOR_WARN_FRAMES frames in a row without a floor (blank clouds here; in practice a camera rolled sideways,
    or upside down with floor.auto_flip off): one warning naming floor.up_hint; a floor resets the count."""
    from walker_gait.ros.nodes import NO_FLOOR_WARN_FRAMES, FloorSegmentationNode

    node = FloorSegmentationNode(parameter_overrides=[rclpy.parameter.Parameter("input", value="points")])
    node.pub_fg = node.pub_mask = node.pub_floor = lambda msg: None
    logger = FakeLogger()
    warnings: list[str] = []
    logger.warning = warnings.append  # type: ignore[method-assign]
    node.get_logger = lambda: logger
    try:
        blank = M.serialize(M.make_pointcloud2(np.full((48, 64, 3), np.nan, np.float32), M.make_header(1.0, "cam")))
        good = M.serialize(M.make_pointcloud2(good_points(), M.make_header(2.0, "cam")))
        for _ in range(2 * NO_FLOOR_WARN_FRAMES):
            node.dispatch("points", M.POINT_CLOUD2, node.on_cloud, blank)
        assert len(warnings) == 1 and "floor.up_hint" in warnings[0]
        node.dispatch("points", M.POINT_CLOUD2, node.on_cloud, good)
        assert node._no_floor == 0
    finally:
        node.destroy_node()


def test_floor_segmentation_finds_the_floor_of_a_camera_upside_down_and_says_so_once(rclpy_context: None) -> None:
    """The same view from a camera turned half a turn about its optical axis: with the default floor.up_hint the
    node finds the floor through floor.auto_flip (FLIP_CONFIRM_ATTEMPTS attempts), publishes it with its normal up
    (image rows up: +y) and logs the turned up_hint once; no floorless warning."""
    from walker_gait.core.segmentation import FLIP_CONFIRM_ATTEMPTS, FloorConfig
    from walker_gait.ros.nodes import FloorSegmentationNode

    node = FloorSegmentationNode(parameter_overrides=[rclpy.parameter.Parameter("input", value="points")])
    floors: list[Any] = []
    node.pub_fg = node.pub_mask = lambda msg: None
    node.pub_floor = floors.append
    logger = FakeLogger()
    infos: list[str] = []
    warnings: list[str] = []
    logger.info = infos.append  # type: ignore[attr-defined]
    logger.warning = warnings.append  # type: ignore[method-assign]
    node.get_logger = lambda: logger
    try:
        turned = good_points() * np.array([-1.0, -1.0, 1.0], np.float32)
        n_frames = 1 + FLIP_CONFIRM_ATTEMPTS * FloorConfig().retry_interval
        for k in range(n_frames):
            cloud = M.serialize(M.make_pointcloud2(turned, M.make_header(1.0 + k / 30, "cam")))
            node.dispatch("points", M.POINT_CLOUD2, node.on_cloud, cloud)
        last = M.floor_from_msg(floors[-1])
        assert last.valid and last.normal[1] > 0.5
        assert not M.floor_from_msg(floors[0]).valid  # the first attempt alone does not turn the camera over
        assert len(infos) == 1 and "upside down" in infos[0] and not warnings
    finally:
        node.destroy_node()


def test_floor_segmentation_reads_depth_like_the_chain_through_points(rclpy_context: None) -> None:
    """`input: depth` (default) gives the same outputs as depth_to_cloud → `input: points`, and holds early images."""
    from walker_gait.ros.nodes import FloorSegmentationNode

    def collect(node: Any) -> dict[str, list[Any]]:
        out: dict[str, list[Any]] = {"fg": [], "mask": [], "floor": []}
        node.pub_fg, node.pub_mask, node.pub_floor = out["fg"].append, out["mask"].append, out["floor"].append
        return out

    direct = FloorSegmentationNode()
    chained = FloorSegmentationNode(parameter_overrides=[rclpy.parameter.Parameter("input", value="points")])
    cloud_node, clouds = make_depth_node()
    a, b = collect(direct), collect(chained)
    try:
        depth = good_depth()
        direct.dispatch("depth/image_raw", M.IMAGE, direct.on_image, image_bytes(depth, stamp=1.0))
        assert a["floor"] == []  # held until the calibration arrives
        for n in (direct, chained, cloud_node):
            n.dispatch("depth/camera_info", M.CAMERA_INFO, n.on_info, info_bytes())
        assert len(a["floor"]) == 1
        cloud_node.dispatch("depth/image_raw", M.IMAGE, cloud_node.on_image, image_bytes(depth, stamp=1.0))
        for i in range(1, 4):
            direct.dispatch("depth/image_raw", M.IMAGE, direct.on_image, image_bytes(depth, stamp=1.0 + i))
            cloud_node.dispatch("depth/image_raw", M.IMAGE, cloud_node.on_image, image_bytes(depth, stamp=1.0 + i))
        for cloud in clouds:
            chained.dispatch("points", M.POINT_CLOUD2, chained.on_cloud, M.serialize(cloud))
        assert len(a["floor"]) == len(b["floor"]) == 4 and not direct.problems
        for x, y in zip(a["mask"], b["mask"], strict=True):
            np.testing.assert_array_equal(M.image_to_mask(x), M.image_to_mask(y))
            assert M.stamp_to_ns(x.header.stamp) == M.stamp_to_ns(y.header.stamp)
        for x, y in zip(a["fg"], b["fg"], strict=True):
            np.testing.assert_array_equal(M.read_pointcloud2(x), M.read_pointcloud2(y))
        assert M.floor_from_msg(a["floor"][-1]).offset == pytest.approx(M.floor_from_msg(b["floor"][-1]).offset)
        assert M.image_to_mask(a["mask"][-1])[12:25, 27:33].mean() > 0.9
    finally:
        for n in (direct, chained, cloud_node):
            n.destroy_node()


def test_floor_segmentation_rejects_unknown_input(rclpy_context: None) -> None:
    from walker_gait.config import ParameterError
    from walker_gait.ros.nodes import FloorSegmentationNode

    with pytest.raises(ParameterError, match="input must be 'depth' or 'points'"):
        FloorSegmentationNode(parameter_overrides=[rclpy.parameter.Parameter("input", value="cloud")])


def make_tracker_node() -> tuple[Any, list[Any]]:
    """A quick leg_tracker (32 particles, one search round) and the list its JointStates go to."""
    from walker_gait.ros.nodes import LegTrackerNode

    node = LegTrackerNode(parameter_overrides=[rclpy.parameter.Parameter("n_particles", value=32),
                                               rclpy.parameter.Parameter("init_rounds", value=1)])
    joints: list[Any] = []
    node.pub_joints = joints.append
    node.pub_track = lambda msg: None
    node.pub_markers = lambda msg: None
    return node, joints


STANDING_FLOOR = FloorPlane.from_camera_pose(height=0.70, pitch=0.50)
"""The floor of :func:`standing_frame`'s camera."""


def standing_frame(stamp: float = 0.0) -> Any:
    """A rendered frame (``bench.tracker.Frame``) of a user standing before a Kinect over :data:`STANDING_FLOOR`."""
    from walker_gait.bench.tracker import KINECT, gait_state, render_frame

    return render_frame(gait_state(0.2), intrinsics=KINECT, floor=STANDING_FLOOR, mounting="facing_user",
                        rng=np.random.default_rng(0), stamp=stamp)


def dispatch_parts(node: Any, stamp: float, *, points: np.ndarray, mask: np.ndarray, no_depth: np.ndarray | None = None,
                   parts: tuple[str, ...] = ("points", "mask", "floor")) -> None:
    """floor_segmentation's ``parts`` of one frame (foreground ``points``, its ``mask`` and pixels without depth,
    :data:`STANDING_FLOOR`) through ``node``'s dispatch path."""
    header = M.make_header(stamp, "cam")
    if "points" in parts:
        node.dispatch("foreground/points", M.POINT_CLOUD2, lambda m: node.on_part("points", m),
                      M.serialize(M.make_pointcloud2(points, header)))
    if "mask" in parts:
        node.dispatch("foreground/mask", M.IMAGE, lambda m: node.on_part("mask", m),
                      M.serialize(M.make_foreground_mask(mask, no_depth, header)))
    if "floor" in parts:
        node.dispatch("floor_plane", M.FLOOR_PLANE, lambda m: node.on_part("floor", m),
                      M.serialize(M.make_floor_plane(STANDING_FLOOR, header)))


def send_foreground(node: Any, stamp: float, *, parts: tuple[str, ...] = ("points", "mask", "floor")) -> None:
    """floor_segmentation's ``parts`` of :func:`standing_frame`, through ``node``'s dispatch path."""
    fr = standing_frame(stamp)
    dispatch_parts(node, stamp, points=fr.points, mask=np.isfinite(fr.depth), parts=parts)


def test_leg_tracker_holds_frames_until_camera_info(rclpy_context: None) -> None:
    """Foreground frames completed before the first CameraInfo are tracked once it arrives, not lost."""
    from walker_gait.bench.tracker import KINECT
    from walker_gait.ros.nodes import WAITING_IMAGES

    node, joints = make_tracker_node()
    try:
        for i in range(WAITING_IMAGES + 1):
            send_foreground(node, 1.0 + i / 30)
        assert joints == []
        assert sum(node._problems.values()) == 1  # the one frame beyond the hold is dropped and counted
        node.dispatch("depth/camera_info", M.CAMERA_INFO, node.on_info,
                      M.serialize(M.make_camera_info(KINECT, M.make_header(1.0, "cam"))))
        assert [M.stamp_to_ns(j.header.stamp) for j in joints] == [
            M.stamp_to_ns(M.make_header(1.0 + i / 30, "cam").stamp) for i in range(1, WAITING_IMAGES + 1)]
        send_foreground(node, 2.0)
        assert len(joints) == WAITING_IMAGES + 1
    finally:
        node.destroy_node()


def test_leg_tracker_holds_a_blanked_view(rclpy_context: None) -> None:
    """The node takes the pixels without depth from floor_segmentation's mask: a frame whose legs' pixels have lost
    their depth (a shin in front of the lens) and whose foreground is a walker's wheel alone is held, as offline:
    LegTrack DEGRADED, confidence 0, the last pose."""
    from walker_gait.bench.tracker import KINECT
    from walker_gait.core.leg_model import BodyFrame

    node, joints = make_tracker_node()
    tracks: list[Any] = []
    node.pub_track = tracks.append
    try:
        node.dispatch("depth/camera_info", M.CAMERA_INFO, node.on_info,
                      M.serialize(M.make_camera_info(KINECT, M.make_header(1.0, "cam"))))
        for i in range(6):
            send_foreground(node, 1.0 + i / 30)
        assert tracks[-1].status == TrackStatus.TRACKING
        legs = standing_frame()
        rng = np.random.default_rng(3)
        wheel = BodyFrame.from_floor(STANDING_FLOOR, mounting="facing_user").to_camera(np.column_stack(
            [rng.uniform(-0.75, -0.55, 5000), rng.uniform(-0.33, -0.25, 5000), rng.uniform(0.03, 0.3, 5000)]))
        uv = np.round(KINECT.project(wheel)).astype(int)
        wheel_px = np.zeros((KINECT.height, KINECT.width), bool)
        ok = (uv[:, 0] >= 0) & (uv[:, 0] < KINECT.width) & (uv[:, 1] >= 0) & (uv[:, 1] < KINECT.height)
        wheel_px[uv[ok, 1], uv[ok, 0]] = True
        dispatch_parts(node, 1.2, points=wheel.astype(np.float32), mask=wheel_px,
                       no_depth=np.isfinite(legs.depth) & ~wheel_px)
        assert len(tracks) == 7
        assert tracks[-1].status == TrackStatus.DEGRADED and tracks[-1].confidence == 0.0
        assert list(tracks[-1].thigh_proximal) == list(tracks[-2].thigh_proximal)
        assert list(tracks[-1].foot_distal) == list(tracks[-2].foot_distal)
    finally:
        node.destroy_node()


def test_leg_tracker_input_depth_sets_the_queue_and_is_validated(rclpy_context: None) -> None:
    from walker_gait.config import ParameterError
    from walker_gait.ros.base import stream_in
    from walker_gait.ros.nodes import LegTrackerNode

    assert stream_in(3).depth == 3
    with pytest.raises(ParameterError):
        stream_in(0)
    node = LegTrackerNode(parameter_overrides=[rclpy.parameter.Parameter("input_depth", value=4)])
    try:
        depths = {s.topic_name: s.qos_profile.depth for s in node.subscriptions}
        assert depths["/foreground/points"] == depths["/foreground/mask"] == depths["/floor_plane"] == 4
    finally:
        node.destroy_node()


def test_leg_tracker_loads_the_compiled_kernels_before_it_subscribes(rclpy_context: None, monkeypatch: Any) -> None:
    # loaded at the first CameraInfo instead, the ~1 s numba import stalled the node while frames queued up and
    # overflowed its input queue (frames lost at the start of a live session)
    from walker_gait.core import kernels
    from walker_gait.ros import nodes

    subscriptions_when_loaded: list[int] = []
    holder: dict[str, Any] = {}
    real_init = nodes.WalkerNode.__init__

    def init(self: Any, *args: Any, **kwargs: Any) -> None:
        real_init(self, *args, **kwargs)
        holder["node"] = self

    monkeypatch.setattr(nodes.WalkerNode, "__init__", init)
    monkeypatch.setattr(kernels, "compiled", lambda: subscriptions_when_loaded.append(len(list(holder["node"].subscriptions))))
    node = nodes.LegTrackerNode()
    try:
        assert len(subscriptions_when_loaded) >= 1  # before any CameraInfo or frame arrived
        # nothing of the camera or the segmentation subscribed yet at that point
        assert subscriptions_when_loaded[0] < len(list(node.subscriptions))
        topics = {s.topic_name for s in node.subscriptions}
        assert {"/foreground/points", "/foreground/mask", "/floor_plane", "/depth/camera_info"} <= topics
    finally:
        node.destroy_node()


def test_replay_waits_for_the_wanted_subscribers_on_each_input_topic(rclpy_context: None, tmp_path: Any) -> None:
    """Nothing is published until the depth topic has `wait_subscribers` and the CameraInfo topic
    `wait_info_subscribers` matched subscriptions (volatile QoS loses what is published before)."""
    import time

    from walker_gait.ros.base import SENSOR_IN, WalkerNode, rclpy_type
    from walker_gait.ros.replay import Replayer
    from walker_gait.synth import SessionSpec, generate_session, write_session

    session = generate_session(SessionSpec.preset("normal", duration=0.5, scale=0.25), rng=np.random.default_rng(3))
    path = tmp_path / "s.mcap"
    write_session(session, path, fmt="mcap", encoding="16UC1")
    node = WalkerNode("bag_replay_wait_test")
    listener = rclpy.create_node("replay_wait_listener")
    replayer = Replayer(node, str(path), publish_clock=False, start_delay=0.0, wait_subscribers=1,
                        wait_info_subscribers=2, wait_timeout=30.0)
    try:
        listener.create_subscription(rclpy_type(M.IMAGE), "depth/image_raw", lambda m: None, SENSOR_IN, raw=True)
        listener.create_subscription(rclpy_type(M.CAMERA_INFO), "depth/camera_info", lambda m: None, SENSOR_IN,
                                     raw=True)
        replayer.start()
        time.sleep(1.5)  # one subscriber on each topic: still waiting for the second CameraInfo one
        assert replayer.published == 0 and not replayer.finished.is_set()
        listener.create_subscription(rclpy_type(M.CAMERA_INFO), "depth/camera_info", lambda m: None, SENSOR_IN,
                                     raw=True)
        assert replayer.finished.wait(20.0)
        assert replayer.published > 0
    finally:
        replayer.stop()
        listener.destroy_node()
        node.destroy_node()


def test_gait_analyzer_restarts_when_a_replay_loops_and_skips_repeated_stamps(rclpy_context: None) -> None:
    """A looping replay sends the same stamps again: the session is flushed and analysed afresh (every frame
    of the second pass was refused as 'stamps must increase' before); a repeated stamp skips one frame."""
    from walker_gait.bench.gait import GaitSimSpec, simulate_gait
    from walker_gait.ros.nodes import GaitAnalyzerNode

    sim = simulate_gait(GaitSimSpec(), rng=np.random.default_rng(0))
    node = GaitAnalyzerNode()
    steps: list[Any] = []
    node.pub_step = steps.append
    node.pub_event = lambda msg: None
    node.pub_summary = node.pub_window = lambda msg: None

    def send(pose: Any, t: float) -> None:
        header = M.make_header(t, "cam")
        node.dispatch("floor_plane", M.FLOOR_PLANE, lambda m: node.on_part("floor", m),
                      M.serialize(M.make_floor_plane(sim.floor, header)))
        node.dispatch("leg_track", M.LEG_TRACK, lambda m: node.on_part("track", m),
                      M.serialize(M.make_leg_track(pose, header, particle_count=0)))

    try:
        for pose in sim.poses:
            send(pose, 100.0 + pose.stamp)
        send(sim.poses[-1], 100.0 + sim.poses[-1].stamp)  # the last frame again
        assert node.problems == {"stamp_not_increasing": 1}
        first = len(steps)
        for pose in sim.poses:  # the replay starts over
            send(pose, 100.0 + pose.stamp)
        node.close()
        assert first >= len(sim.steps) - 1  # the first pass, flushed when time jumped back
        assert len(steps) - first >= len(sim.steps) - 1  # and the second, analysed from scratch
        assert node.problems == {"stamp_not_increasing": 1}
    finally:
        node.destroy_node()


def _part(stamp: float) -> Any:
    from types import SimpleNamespace

    return SimpleNamespace(header=M.make_header(stamp, "cam"))


def test_stamp_sync_hands_out_complete_frames_and_lists_the_ones_it_gave_up_once() -> None:
    from walker_gait.ros.nodes import StampSync

    sync = StampSync(("a", "b", "c"), keep=3)
    assert sync.add("a", _part(1.0)) == []
    assert sync.add("b", _part(1.0)) == []
    # frame 1's "c" never comes; frame 2 completes: frame 1 is given up (each topic arrives in order)
    for name in ("a", "c"):
        assert sync.add(name, _part(2.0)) == []
    ready = sync.add("b", _part(2.0))
    assert len(ready) == 1 and sorted(ready[0]) == ["a", "b", "c"]
    assert sync.take_dropped() == [(M.stamp_to_ns(_part(1.0).header.stamp), ("c",))]
    assert sync.take_dropped() == []  # listed once
    # more incomplete frames than `keep`: the oldest ones are pushed out
    for i in range(5):
        assert sync.add("a", _part(3.0 + i)) == []
    dropped = sync.take_dropped()
    assert [m for _, m in dropped] == [("b", "c"), ("b", "c")] and len(sync.pending) == 3
    # the frames still pending complete as usual
    for name in ("b", "c"):
        sync.add(name, _part(7.0))
    assert sync.take_dropped() == [(M.stamp_to_ns(_part(5.0).header.stamp), ("b", "c")),
                                   (M.stamp_to_ns(_part(6.0).header.stamp), ("b", "c"))]
    assert not sync.pending and sync.take_stood_in() == []


def test_stamp_sync_stands_in_the_latest_slow_part_for_one_that_never_arrived() -> None:
    from walker_gait.ros.nodes import StampSync

    with pytest.raises(ValueError, match="stand_in"):
        StampSync(("a", "b"), stand_in=("x",))
    sync = StampSync(("pts", "floor"), stand_in=("floor",))
    first_floor = _part(1.0)
    assert sync.add("pts", _part(1.0)) == [] and len(sync.add("floor", first_floor)) == 1
    pts2, pts3, floor3 = _part(2.0), _part(3.0), _part(3.0)
    assert sync.add("pts", pts2) == []  # frame 2's floor never comes
    assert sync.add("pts", pts3) == []
    ready = sync.add("floor", floor3)
    # frame 2 first, with the latest floor (frame 3's, which came before it was given up), then frame 3
    assert [r["pts"] for r in ready] == [pts2, pts3] and [r["floor"] for r in ready] == [floor3, floor3]
    assert sync.take_stood_in() == [(M.stamp_to_ns(pts2.header.stamp), ("floor",))] and sync.take_dropped() == []
    # a frame missing a part that cannot be stood in for is dropped as before
    sync.add("floor", _part(4.0))
    sync.add("pts", _part(5.0))
    sync.add("floor", _part(5.0))
    assert sync.take_dropped() == [(M.stamp_to_ns(_part(4.0).header.stamp), ("pts",))]


def test_gait_analyzer_counts_a_frame_whose_parts_did_not_all_arrive(rclpy_context: None) -> None:
    """A LegTrack whose FloorPlane never came is analysed with the latest floor plane (counted); a FloorPlane
    whose LegTrack never came is counted on /diagnostics as an absent track (the tracker dropped the frame and says
    so on its own /diagnostics), not as the analyzer's problem, and not lost silently."""
    from walker_gait.core.types import LegPose
    from walker_gait.ros.nodes import GaitAnalyzerNode

    node = GaitAnalyzerNode()
    node.publish_results = lambda events, steps, header: None
    floor = FloorPlane.from_camera_pose(height=0.5, pitch=0.5)
    try:
        def send(stamp: float, *, track: bool = True, with_floor: bool = True) -> None:
            header = M.make_header(stamp, "cam")
            pose = LegPose(stamp=stamp, points=np.zeros((2, 5, 3)), status=TrackStatus.NO_USER, confidence=0.0)
            if track:
                node.dispatch("leg_track", M.LEG_TRACK, lambda m: node.on_part("track", m),
                              M.serialize(M.make_leg_track(pose, header)))
            if with_floor:
                node.dispatch("floor_plane", M.FLOOR_PLANE, lambda m: node.on_part("floor", m),
                              M.serialize(M.make_floor_plane(floor, header)))

        send(1.0)
        send(1.1, with_floor=False)
        send(1.2)
        send(1.3, track=False)
        send(1.4)
        assert node.frames_ok == 4
        assert node.problems == {} and node.absent == {"track": 1}
        assert node.stand_ins == {"floor": 1}
    finally:
        node.destroy_node()


def test_gait_analyzer_waits_for_leg_tracks_that_lag_their_floor_planes(rclpy_context: None) -> None:
    """A busy tracker's leg tracks come 15 frames behind the floor planes (the live bench on a slow host: ~400 ms):
    each is analysed with its own floor plane, nothing reported skipped or stood in."""
    from walker_gait.core.types import LegPose
    from walker_gait.ros.nodes import GaitAnalyzerNode

    node = GaitAnalyzerNode()
    floors: list[float] = []
    node.publish_results = lambda events, steps, header: None
    analyse = node.on_frame
    node.on_frame = lambda msg, floor: (floors.append(floor.offset), analyse(msg, floor))  # type: ignore[method-assign]
    try:
        for i in range(40):
            header = M.make_header(1.0 + i / 30, "cam")
            floor = FloorPlane.from_camera_pose(height=0.5 + i / 1000, pitch=0.5)
            node.dispatch("floor_plane", M.FLOOR_PLANE, lambda m: node.on_part("floor", m),
                          M.serialize(M.make_floor_plane(floor, header)))
            if i >= 15:
                j = i - 15
                pose = LegPose(stamp=1.0 + j / 30, points=np.zeros((2, 5, 3)), status=TrackStatus.NO_USER,
                               confidence=0.0)
                node.dispatch("leg_track", M.LEG_TRACK, lambda m: node.on_part("track", m),
                              M.serialize(M.make_leg_track(pose, M.make_header(1.0 + j / 30, "cam"))))
        assert node.frames_ok == 25 and node.problems == {} and node.stand_ins == {}
        assert floors == pytest.approx([0.5 + j / 1000 for j in range(25)])
    finally:
        node.destroy_node()


def test_leg_tracker_tracks_a_frame_whose_floor_plane_never_arrived(rclpy_context: None) -> None:
    """The floor plane is the part the live graph lost (an input queue overflowing while the tracker was busy): the
    frame is tracked with the latest floor plane, a JointState per image; a frame without its cloud is dropped."""
    from walker_gait.bench.tracker import KINECT

    node, joints = make_tracker_node()
    try:
        node.dispatch("depth/camera_info", M.CAMERA_INFO, node.on_info,
                      M.serialize(M.make_camera_info(KINECT, M.make_header(1.0, "cam"))))
        send_foreground(node, 1.0)
        send_foreground(node, 1.0 + 1 / 30, parts=("points", "mask"))
        send_foreground(node, 1.0 + 2 / 30)
        send_foreground(node, 1.0 + 3 / 30, parts=("mask", "floor"))
        send_foreground(node, 1.0 + 4 / 30)
        stamps = [M.stamp_to_ns(j.header.stamp) for j in joints]
        assert stamps == [M.stamp_to_ns(M.make_header(1.0 + i / 30, "cam").stamp) for i in (0, 1, 2, 4)]
        assert node.stand_ins == {"floor": 1} and node.problems == {"incomplete_frame": 1}
    finally:
        node.destroy_node()


def test_stamp_sync_hands_frames_out_in_stamp_order_when_a_lost_part_delays_one() -> None:
    """The floor planes run ahead of the leg tracks; a frame whose floor was lost is first seen, by its track, after
    later frames' floors: it still comes out before them (it came out after them, out of order, by arrival)."""
    from walker_gait.ros.nodes import StampSync

    sync = StampSync(("track", "floor"), stand_in=("floor",))
    assert sync.add("floor", _part(0.9)) == [] and len(sync.add("track", _part(0.9))) == 1
    for t in (1.1, 1.2):  # floor 1.0 is lost
        assert sync.add("floor", _part(t)) == []
    track1 = _part(1.0)
    assert sync.add("track", track1) == []
    ready = sync.add("track", _part(1.1))
    assert [M.stamp_to_ns(r["track"].header.stamp) for r in ready] == [
        M.stamp_to_ns(_part(1.0).header.stamp), M.stamp_to_ns(_part(1.1).header.stamp)]
    assert ready[0]["track"] is track1 and sync.take_stood_in() == [(M.stamp_to_ns(track1.header.stamp), ("floor",))]
    assert list(sync.pending) == [(M.stamp_to_ns(_part(1.2).header.stamp), "cam")]


def test_stamp_sync_lets_stand_in_parts_wait_for_a_lagging_topic_beyond_keep() -> None:
    """The floor planes run ahead of the leg tracks by the tracker's latency, more than ``keep`` frames when it is
    busy: with ``keep_waiting`` each late track still finds its own floor (none dropped, none stood in); without it
    the floors were pushed out, each frame reported dropped and then analysed with a newer floor."""
    from walker_gait.ros.nodes import StampSync

    with pytest.raises(ValueError, match="keep_waiting"):
        StampSync(("track", "floor"), keep_waiting=-1)

    def run(sync: StampSync, lag: int) -> list[dict[str, Any]]:
        out: list[dict[str, Any]] = []
        for i in range(40):
            out += sync.add("floor", _part(1.0 + i / 30))
            if i >= lag:
                out += sync.add("track", _part(1.0 + (i - lag) / 30))
        return out

    sync = StampSync(("track", "floor"), keep=3, stand_in=("floor",), keep_waiting=20)
    ready = run(sync, lag=12)
    assert len(ready) == 28 and sync.take_dropped() == [] and sync.take_stood_in() == []
    assert all(r["floor"].header.stamp == r["track"].header.stamp for r in ready)
    assert len(sync.pending) == 12  # the floors still waiting for their tracks
    old = StampSync(("track", "floor"), keep=3, stand_in=("floor",))
    ready_old = run(old, lag=12)
    assert len(ready_old) == 28 and len(old.take_dropped()) == 40 - 3 and len(old.take_stood_in()) == 28
    # a floor waits at most keep_waiting frames: a longer lag is the old behaviour again
    sync = StampSync(("track", "floor"), keep=3, stand_in=("floor",), keep_waiting=5)
    ready = run(sync, lag=8)
    assert len(sync.take_dropped()) == 40 - 5 and len(sync.take_stood_in()) == len(ready) == 32 - 3
    # a floor whose track never comes is still reported, once, when a later frame completes (tracks come in order)
    sync = StampSync(("track", "floor"), keep=3, stand_in=("floor",), keep_waiting=20)
    for i in range(8):
        sync.add("floor", _part(1.0 + i / 30))
    for i in (0, 1, 3):  # the tracker skipped frame 2
        sync.add("track", _part(1.0 + i / 30))
    assert sync.take_dropped() == [(M.stamp_to_ns(_part(1.0 + 2 / 30).header.stamp), ("track",))]
    assert sync.take_stood_in() == [] and len(sync.pending) == 4
    sync = StampSync(("pts", "mask", "floor"), keep=2, stand_in=("floor",), keep_waiting=50)
    for i in range(6):
        sync.add("pts", _part(1.0 + i))  # the masks never come
    assert len(sync.pending) == 2 and [m for _, m in sync.take_dropped()] == [("mask", "floor")] * 4


def test_leg_tracker_leg_length_reaches_the_placement_and_is_validated(rclpy_context: None) -> None:
    """``leg_length_m`` (m; 0 = not measured) goes to the reported pelvis's placement, also when set while the node
    runs; centimetres are refused."""
    from walker_gait.config import ParameterError
    from walker_gait.ros.nodes import LegTrackerNode

    node = LegTrackerNode(parameter_overrides=[rclpy.parameter.Parameter("leg_length_m", value=0.88)])
    try:
        assert node.pelvis is not None and node.pelvis.leg_length_m == pytest.approx(0.88)
        # the next user, while the node runs; centimetres refused with the reason, the value kept
        assert node.set_parameters([rclpy.parameter.Parameter("leg_length_m", value=0.93)])[0].successful
        assert node.pelvis.leg_length_m == pytest.approx(0.93)
        refused = node.set_parameters([rclpy.parameter.Parameter("leg_length_m", value=93.0)])[0]
        assert not refused.successful and "metres" in refused.reason
        assert node.pelvis.leg_length_m == pytest.approx(0.93)
        assert node.get_parameter("leg_length_m").value == pytest.approx(0.93)
        assert node.set_parameters([rclpy.parameter.Parameter("leg_length_m", value=0.0)])[0].successful
        assert node.pelvis.leg_length_m is None
    finally:
        node.destroy_node()
    node = LegTrackerNode()
    try:
        assert node.pelvis is not None and node.pelvis.leg_length_m is None
    finally:
        node.destroy_node()
    with pytest.raises(ParameterError, match="leg_tracker.leg_length_m .*metres"):
        LegTrackerNode(parameter_overrides=[rclpy.parameter.Parameter("leg_length_m", value=88.0)])


def test_leg_tracker_publishes_hidden_feet_bridged_on_a_track_of_its_own(rclpy_context: None, monkeypatch: Any) -> None:
    """``leg_track_bridged``: ``leg_track``'s frames, each once and in order, those while a foot is hidden held until
    it is seen again and then published bridged (here a foot moving steadily, held by the tracker while hidden:
    bridged onto its real line); the frames around as published on ``leg_track``; frames still held when the input
    pauses for longer than ``bridge_hidden_s`` published as tracked (and counted on /diagnostics while held).
    ``bridge_hidden_s`` 0: no such topic; a negative value is refused."""
    from walker_gait.bench.tracker import KINECT
    from walker_gait.config import ParameterError
    from walker_gait.core.smoothing import BRIDGE_FIT_FRAMES
    from walker_gait.ros.nodes import LegTrackerNode

    rot, t = STANDING_FLOOR.walker_transform()
    n, hidden = 30, [*range(10, 18), *range(27, 30)]  # the second stretch lasts to the end: held
    truth, poses = [], []
    for i in range(n):  # walker frame: both legs' points 10-60 cm up, moving steadily along x; the left foot hides
        pts = np.zeros((2, 5, 3))
        pts[..., 0] = -0.8 + 0.3 * i / 30
        pts[..., 1] = [[0.1], [-0.1]]
        pts[..., 2] = [0.6, 0.4, 0.2, 0.12, 0.1]
        truth.append(pts)
        vis = np.ones((2, 3))
        if i in hidden:
            vis[0, 2] = 0.0
            pts = poses[-1].points.copy()
            pts[1] = truth[-1][1]
        else:
            pts = pts.copy()
        poses.append(LegPose(stamp=1.0 + i / 30, points=pts, visibility=vis, status=TrackStatus.TRACKING,
                             confidence=0.9))
    camera = [dataclasses.replace(p, points=(p.points - t) @ rot) for p in poses]
    node, _ = make_tracker_node()
    tracks: list[Any] = []
    bridged: list[tuple[int, Any]] = []
    node.pub_track = tracks.append
    node.pub_bridged = lambda msg: bridged.append((len(tracks), msg))
    node.pelvis = None  # the poses as given
    try:
        node.dispatch("depth/camera_info", M.CAMERA_INFO, node.on_info,
                      M.serialize(M.make_camera_info(KINECT, M.make_header(1.0, "cam"))))
        given = iter(camera)
        node.tracker.update = lambda **kw: next(given)
        for i in range(n):
            send_foreground(node, 1.0 + i / 30)
        assert len(tracks) == n and len(bridged) == 27 and node.diagnostic_values()["bridge_held"] == 3
        node.release_stale()  # the input has not paused yet
        assert len(bridged) == 27
        node._last_frame_wall -= 2.0  # ... now it has, for longer than bridge_hidden_s: what is held comes out
        node.release_stale()
        assert len(bridged) == n and node.diagnostic_values()["bridge_held"] == 0
        # the tracker's passing checks (none here: its update is replaced)
        assert {k: node.diagnostic_values()[k] for k in ("passing_checks", "passing_checks_kept")} == {
            "passing_checks": 0, "passing_checks_kept": 0}
        stamps = [M.stamp_to_ns(m.header.stamp) for m in tracks]
        assert [M.stamp_to_ns(m.header.stamp) for _, m in bridged] == stamps
        k = BRIDGE_FIT_FRAMES
        # published with leg_track while both feet are seen; the hidden foot's frames once it was seen k + 1 times
        assert [when for when, _ in bridged][:10] == list(range(1, 11))
        assert [when for when, _ in bridged][10:18 + k + 1] == [18 + k + 1] * (8 + k + 1)
        for i, (_, msg) in enumerate(bridged):
            heel = np.array([[p.x, p.y, p.z] for p in msg.heel])
            sent = np.array([[p.x, p.y, p.z] for p in tracks[i].heel])
            want = STANDING_FLOOR.to_walker(heel)
            if 10 <= i < 18:
                assert np.abs(want[0] - truth[i][0, 3]).max() < 1e-5  # float32 messages
                assert np.abs(STANDING_FLOOR.to_walker(sent)[0] - truth[i][0, 3]).max() > 0.005
            else:
                assert np.array_equal(heel, sent)
    finally:
        node.destroy_node()
    node = LegTrackerNode(parameter_overrides=[rclpy.parameter.Parameter("bridge_hidden_s", value=0.0)])
    try:
        assert node.bridge is None and node.pub_bridged is None
    finally:
        node.destroy_node()
    # without a subscriber no message is built; with one, each released frame is published
    from walker_gait.ros.base import rclpy_type

    node = LegTrackerNode()
    built: list[Any] = []
    make = M.make_leg_track
    monkeypatch.setattr(M, "make_leg_track", lambda *a, **kw: built.append(1) or make(*a, **kw))
    try:
        released = [(camera[0], M.make_header(1.0, "cam"))]
        node._publish_bridged(released)
        assert built == []
        node.create_subscription(rclpy_type(M.LEG_TRACK), "leg_track_bridged", lambda m: None, 10)
        node._publish_bridged(released)
        assert built == [1]
    finally:
        node.destroy_node()
    with pytest.raises(ParameterError, match="leg_tracker.bridge_hidden_s"):
        LegTrackerNode(parameter_overrides=[rclpy.parameter.Parameter("bridge_hidden_s", value=-1.0)])
    # the likelihood kernels' threads (the same tracks), a whole number >= 0; 0 (the default) by the usable cores
    with pytest.raises(ParameterError, match="leg_tracker.kernel_threads"):
        LegTrackerNode(parameter_overrides=[rclpy.parameter.Parameter("kernel_threads", value=-1)])
    from walker_gait.ros.nodes import auto_kernel_threads, usable_cores

    assert [auto_kernel_threads(c) for c in (1, 2, 3, 4, 16)] == [1, 1, 1, 2, 2]
    node = LegTrackerNode()
    try:
        assert node.kernel_threads == auto_kernel_threads(usable_cores())
    finally:
        node.destroy_node()
    node = LegTrackerNode(parameter_overrides=[rclpy.parameter.Parameter("kernel_threads", value=3)])
    try:
        assert node.kernel_threads == 3
    finally:
        node.destroy_node()


def test_leg_markers_are_built_only_while_something_subscribes(rclpy_context: None, monkeypatch: Any) -> None:
    """``leg_markers`` costs the tracker node a few ms a frame: without a subscriber no MarkerArray is built; with
    one, each frame's is built and handed to the publisher."""
    from walker_gait.ros.base import rclpy_type
    from walker_gait.ros.nodes import LegTrackerNode

    node = LegTrackerNode()
    built: list[Any] = []
    make = M.make_markers
    monkeypatch.setattr(M, "make_markers", lambda *a, **kw: built.append(1) or make(*a, **kw))
    try:
        pts = np.zeros((2, 5, 3))
        pts[..., 1] = [[0.1], [-0.1]]
        pts[..., 2] = [0.6, 0.4, 0.2, 0.12, 0.1]
        pose = LegPose(stamp=1.0, points=pts, visibility=np.ones((2, 3)), status=TrackStatus.TRACKING, confidence=0.9)
        node._publish_markers(pose, M.make_header(1.0, "cam"))
        assert built == []
        node.create_subscription(rclpy_type(M.MARKER_ARRAY), "leg_markers", lambda m: None, 10)
        node._publish_markers(pose, M.make_header(1.0, "cam"))
        assert built == [1]
    finally:
        node.destroy_node()


def test_busy_monitor_says_once_per_episode_that_a_node_falls_behind() -> None:
    """Work against the span of the frames' stamps: a node that spends longer on a frame than the camera leaves
    between frames falls behind (said once, until it has kept up again); a replay that loops starts afresh."""
    from walker_gait.ros.base import BusyMonitor

    m = BusyMonitor(window=20, min_frames=5)
    said = [m.add(i / 30, 0.010) for i in range(20)]  # 10 ms of work every 33 ms: keeps up
    assert not any(said) and m.busy == pytest.approx(0.3) and not m.overloaded
    assert m.work_ms == pytest.approx(10.0) and m.interval_ms == pytest.approx(1000 / 30)
    said = [m.add(20 / 30 + i / 30, 0.060) for i in range(1, 21)]  # 60 ms of work every 33 ms
    assert said.count(True) == 1 and m.overloaded and m.busy == pytest.approx(1.8) and m.episodes == 1
    t = 40 / 30
    for i in range(1, 21):  # frames dropped: the ones worked on lie 100 ms apart, 60 ms each: busy 60 %
        assert not m.add(t + i * 0.1, 0.060)
    assert not m.overloaded and m.busy == pytest.approx(0.6)
    assert m.add(t + 2.0 + 1 / 30, 0.2) is False  # one slow frame in a window of quick ones
    assert not m.add(0.0, 0.01) and math.isnan(m.busy)  # the replay looped: afresh
    with pytest.raises(ValueError):
        BusyMonitor(window=3, min_frames=5)


def test_busy_monitor_counts_the_frames_between_those_worked_on() -> None:
    """Frames the node never worked on are counted from the gaps in the stamps of those it did, by the camera's
    period (the median of the recent intervals within 1.5 times the shortest): none at the camera's rate, even with
    jitter; two in each 100 ms gap of a 30 Hz camera; an interval under 0.1 ms is no period; a pause of the input
    (``max_gap_s`` or longer) is not frames missed; a loop starts no count."""
    from walker_gait.ros.base import BusyMonitor

    rng = np.random.default_rng(0)
    m = BusyMonitor()
    stamps = np.arange(60) / 30 + rng.uniform(-0.004, 0.004, 60)  # 30 Hz, +-4 ms of jitter
    for t in stamps:
        m.add(float(t), 0.01)
    assert m.missed == 0 and m.period_s == pytest.approx(1 / 30, abs=0.009)
    t = float(stamps[-1])
    for i in range(1, 11):  # every third frame taken
        m.add(t + i / 10, 0.09)
    assert m.missed == 20
    m.add(t + 1.0 + 5e-5, 0.01)  # stamped a hair after the last: no period of a camera
    assert m.missed == 20 and m.period_s == pytest.approx(1 / 30, abs=0.009)
    m.add(t + 1.0 + 5.0, 0.01)  # the input paused for 5 s
    assert m.missed == 20
    m.add(t + 6.0 + 4 / 30, 0.01)  # three frames lost whole
    assert m.missed == 23
    m.add(0.0, 0.01)  # a replay that loops
    m.add(1 / 30, 0.01)
    assert m.missed == 23
    with pytest.raises(ValueError):
        BusyMonitor(max_gap_s=0.0)


def test_leg_tracker_says_when_it_cannot_keep_up_and_diagnostics_warn(rclpy_context: None) -> None:
    """Frames stamped 1 ms apart (far more than any tracker keeps up with): the node falls behind once, its
    /diagnostics turn WARN with the share of the time it is busy and count the frames that never came between those
    it tracked; frames a second apart: it keeps up again, OK."""
    from walker_gait.bench.tracker import KINECT

    node, joints = make_tracker_node()
    sent: list[Any] = []
    node._diag_pub = type("Pub", (), {"publish": lambda self, data: sent.append(M.deserialize(data, M.DIAGNOSTIC_ARRAY))})()
    try:
        node.dispatch("depth/camera_info", M.CAMERA_INFO, node.on_info,
                      M.serialize(M.make_camera_info(KINECT, M.make_header(1.0, "cam"))))
        fr = standing_frame(1.0)
        for i in [*range(20), 23]:  # the frames stamped 1.020-1.022 s never come
            dispatch_parts(node, 1.0 + i * 0.001, points=fr.points, mask=np.isfinite(fr.depth))
        assert len(joints) == 21 and node.busy_monitor is not None
        assert node.busy_monitor.overloaded and node.busy_monitor.episodes == 1 and node.busy_monitor.busy > 1
        node._publish_diagnostics()
        status = sent[-1].status[0]
        values = {kv.key: kv.value for kv in status.values}
        assert status.level == 1 and "cannot keep up" in status.message
        assert float(values["busy_pct"]) > 100 and float(values["work_ms_mean"]) > 1
        assert int(values["frames_missed"]) == 3
        for i in range(60):
            dispatch_parts(node, 2.0 + i, points=fr.points, mask=np.isfinite(fr.depth))
        assert not node.busy_monitor.overloaded and node.busy_monitor.episodes == 1
        node._publish_diagnostics()
        assert sent[-1].status[0].level == 0 and sent[-1].status[0].message == "ok"
    finally:
        node.destroy_node()
