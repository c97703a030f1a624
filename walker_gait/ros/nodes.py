"""The five walker_gait nodes: thin rclpy wrappers around the algorithm core.

=====================  =====================================================================
node                   what it does
=====================  =====================================================================
depth_to_cloud         depth Image + CameraInfo → organised PointCloud2 (camera optical frame)
floor_segmentation     organised cloud → foreground cloud + mask + FloorPlane
leg_tracker            foreground + floor + CameraInfo → JointState, LegTrack, MarkerArray
gait_analyzer          LegTrack + floor (+ Odometry) → GaitEvent, Step, GaitSummary
bag_replay             recording (MCAP / rosbag2 / ROS 1) → its topics + /clock
=====================  =====================================================================

Topics, types, QoS and parameters are tabulated in the README.
"""

from __future__ import annotations

import math
import os
import time
from collections import deque
from typing import Any

import numpy as np

from walker_gait import messages as M
from walker_gait.config import ParameterError, stage_rng
from walker_gait.ros.base import (
    EVENTS,
    LATCHED,
    SENSOR_IN,
    STREAM,
    STREAM_IN,
    WalkerNode,
    input_qos,
    rclpy_type,
    spin_node,
    stream_in,
)


WAITING_IMAGES = 5
"""Depth images held while no CameraInfo has arrived yet (converted once it comes)."""
NO_FLOOR_WARN_FRAMES = 90
"""floor_segmentation warns once when this many consecutive frames had no floor (3 s at 30 Hz)."""
TIME_JUMP_RESET_S = 1.0
"""gait_analyzer restarts its session when frame stamps jump back by more than this (s): a looping replay."""


class MissingCameraInfo(RuntimeError):
    kind = "no_camera_info"


# ------------------------------------------------------------------------------- depth_to_cloud


class DepthInput:
    """Depth image + CameraInfo subscriptions of a node, decoded and back-projected by the core.

    Declares ``depth_format``, ``use_rectified`` and ``input_reliability`` on ``node`` and calls
    ``on_frame(depth, points, header)`` per image (``depth`` (H, W) float32 metres, NaN = no depth;
    ``points`` (H, W, 3) camera optical frame).  Images that arrive before the first CameraInfo (the
    two topics race at start-up) are held (:data:`WAITING_IMAGES`) and converted as soon as it comes.
    ``wanted()`` returning False drops an image as it arrives, before it is even deserialised (lazy
    publishers); ``subscribed=False`` does not subscribe to the images at all until
    :meth:`set_subscribed` (the CameraInfo subscription is always there).
    """

    def __init__(self, node: WalkerNode, on_frame: Any, *, wanted: Any = None, subscribed: bool = True) -> None:
        from walker_gait.core.depth import DepthProjector

        self.node = node
        self.on_frame = on_frame
        self.wanted = wanted
        self.depth_format = str(node.declare_parameter("depth_format", "auto").value)
        self.use_rectified = bool(node.declare_parameter("use_rectified", True).value)
        self.qos_in = input_qos(str(node.declare_parameter("input_reliability", "best_effort").value))
        self.projector = DepthProjector()
        self.undistorter: Any = None
        self.info_key: tuple[Any, ...] | None = None
        self.info: Any = None
        self._warned_no_info = 0.0
        self._waiting: deque[Any] = deque(maxlen=WAITING_IMAGES)
        self.image_subscription: Any = None
        node.raw_subscription(M.CAMERA_INFO, "depth/camera_info", self.on_info, self.qos_in)
        self.set_subscribed(subscribed)

    def set_subscribed(self, on: bool) -> None:
        """Subscribe to ``depth/image_raw`` (``on``) or drop the subscription (no image is even delivered)."""
        if on and self.image_subscription is None:
            self.image_subscription = self.node.create_subscription(
                rclpy_type(M.IMAGE), "depth/image_raw", self.on_image_bytes, self.qos_in, raw=True)
        elif not on and self.image_subscription is not None:
            self.node.destroy_subscription(self.image_subscription)
            self.image_subscription = None

    def on_image_bytes(self, data: bytes) -> None:
        """Subscription callback: a serialised image, dropped unread while it is not ``wanted``."""
        if self.wanted is None or self.wanted():
            self.node.dispatch("depth/image_raw", M.IMAGE, self.on_image, data)

    def on_info(self, msg: Any) -> None:
        from walker_gait.core.depth import intrinsics_from_camera_info

        fields = M.intrinsics_fields(msg)
        key = (fields["width"], fields["height"], tuple(fields["k"]), tuple(fields["d"]), tuple(fields["p"]),
               fields["distortion_model"])
        if key != self.info_key:
            intr, undist = intrinsics_from_camera_info(**fields, rectified=self.use_rectified)
            self.projector.set_intrinsics(intr)
            self.undistorter = undist
            self.info_key = key
            self.info = intr
        while self._waiting:
            with self.node.guard("depth/image_raw"):  # a bad held image is skipped like any other
                self.on_image(self._waiting.popleft())

    def on_image(self, msg: Any) -> None:
        from walker_gait.core.depth import check_info_matches, decode_depth

        if self.info is None:
            now = time.monotonic()
            if now - self._warned_no_info > 5.0:
                self._warned_no_info = now
                self.node.get_logger().warning(f"depth image received but no CameraInfo yet on depth/camera_info; "
                                               f"holding the latest {WAITING_IMAGES} images until one arrives")
            self._waiting.append(msg)
            return
        check_info_matches(self.info, width=msg.width, height=msg.height)
        depth = decode_depth(msg.data, encoding=msg.encoding, width=msg.width, height=msg.height, step=msg.step,
                             is_bigendian=bool(msg.is_bigendian), depth_format=self.depth_format)
        if self.undistorter is not None:
            depth = self.undistorter.apply(depth)
        self.on_frame(depth, self.projector.points(depth), msg.header)


class DepthToCloudNode(WalkerNode):
    """``depth/image_raw`` + ``depth/camera_info`` → ``points`` (organised, NaN = no depth).

    Lazy: the node subscribes to ``depth/image_raw`` only while ``points`` has a subscriber (the publisher's
    "matched" event), and an image that still arrives without one is dropped unread.  A 640×480 cloud
    is 3.7 MB to build and serialise, and merely receiving the raw images cost ~8 % of a core at 30 Hz;
    floor_segmentation reads the depth image itself by default.
    """

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("depth_to_cloud", **kwargs)
        from rclpy.event_handler import PublisherEventCallbacks

        self.pub_points = self.raw_publisher(M.POINT_CLOUD2, "points", STREAM,
                                             event_callbacks=PublisherEventCallbacks(matched=self.on_points_matched))
        self._points_publisher = self.pub_points.publisher  # type: ignore[attr-defined]
        self.input = DepthInput(self, self.on_frame, wanted=lambda: self.points_wanted(),
                                subscribed=self.points_wanted())
        self.on_info, self.on_image = self.input.on_info, self.input.on_image

    def on_points_matched(self, info: Any) -> None:
        """A subscriber of ``points`` came or went: (un)subscribe the depth images accordingly."""
        self.input.set_subscribed(int(info.current_count) > 0)

    def points_wanted(self) -> bool:
        """True while something subscribes to ``points``."""
        return bool(self._points_publisher.get_subscription_count() > 0)

    def on_frame(self, depth: np.ndarray, points: np.ndarray, header: Any) -> None:
        self.pub_points(M.make_pointcloud2(points, header))
        self.frames_ok += 1


# --------------------------------------------------------------------------- floor_segmentation


class FloorSegmentationNode(WalkerNode):
    """Depth image (or ``points``) → ``foreground/points``, ``foreground/mask``, ``floor_plane``.

    ``input: depth`` (default) decodes ``depth/image_raw`` itself with the same core as depth_to_cloud
    (cheaper than receiving the 3.7 MB organised cloud); ``input: points`` subscribes to depth_to_cloud's
    ``points`` instead.
    """

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("floor_segmentation", **kwargs)
        from walker_gait.core import kernels
        from walker_gait.core.segmentation import Segmenter, SegmenterConfig

        kernels.compiled()  # the compiled pixel passes loaded before subscribing, as leg_tracker does (not on frame 1)
        config = self.declare_config(SegmenterConfig)
        seed = int(self.declare_parameter("seed", 0).value)
        self.segmenter = Segmenter(config, rng=stage_rng(seed, "floor_segmentation"))
        self._no_floor = 0  # consecutive frames without a floor
        self._told_flip = False  # the half-turned up_hint (floor.auto_flip) was logged
        self.pub_fg = self.raw_publisher(M.POINT_CLOUD2, "foreground/points", STREAM)
        self.pub_mask = self.raw_publisher(M.IMAGE, "foreground/mask", STREAM)
        self.pub_floor = self.raw_publisher(M.FLOOR_PLANE, "floor_plane", STREAM)
        source = str(self.declare_parameter("input", "depth").value)
        self.intrinsics: Any = None
        if source == "depth":
            self.depth_input: DepthInput | None = DepthInput(self, self.on_depth)
            self.use_rectified = self.depth_input.use_rectified
            self.on_image = self.depth_input.on_image
            self.on_info = self.depth_input.on_info  # type: ignore[method-assign]
        elif source == "points":
            self.depth_input = None
            self.use_rectified = bool(self.declare_parameter("use_rectified", True).value)
            self.raw_subscription(M.CAMERA_INFO, "depth/camera_info", self.on_info, SENSOR_IN)
            self.raw_subscription(M.POINT_CLOUD2, "points", self.on_cloud, STREAM_IN)
        else:
            self.get_logger().fatal(f"input must be 'depth' or 'points', got {source!r}")
            raise ParameterError(f"floor_segmentation.input must be 'depth' or 'points', got {source!r}")

    def on_info(self, msg: Any) -> None:
        from walker_gait.core.depth import intrinsics_from_camera_info

        intr, _ = intrinsics_from_camera_info(**M.intrinsics_fields(msg), rectified=self.use_rectified)
        self._set_intrinsics(intr)

    def _set_intrinsics(self, intr: Any) -> None:
        if intr != self.intrinsics:
            self.intrinsics = intr
            self.segmenter.set_intrinsics(intr)

    def on_cloud(self, msg: Any) -> None:
        points = M.read_pointcloud2(msg)
        if points.ndim != 3:
            raise ValueError("floor_segmentation needs an organised cloud (height > 1) aligned with the depth image")
        self.segment(points[..., 2], points, msg.header)

    def on_depth(self, depth: np.ndarray, points: np.ndarray, header: Any) -> None:
        assert self.depth_input is not None
        self._set_intrinsics(self.depth_input.info)
        self.segment(depth, points, header)

    def segment(self, depth: np.ndarray, points: np.ndarray, header: Any) -> None:
        seg = self.segmenter.process(depth, points)
        self._no_floor = 0 if seg.floor.valid else self._no_floor + 1
        if self._no_floor == NO_FLOOR_WARN_FRAMES:  # once per floorless stretch
            self.get_logger().warning(
                f"no floor plane found in the last {NO_FLOOR_WARN_FRAMES} frames: the legs cannot be tracked (leg_track "
                "says NO_USER); if the camera is mounted rolled, set floor.up_hint (the floor's up direction in the "
                "camera frame, default [0.0, -1.0, 0.0]; upside down: [0.0, 1.0, 0.0], which floor.auto_flip also "
                "tries until a floor was found)")
        tracker = self.segmenter.floor_tracker
        if tracker.flipped and not self._told_flip:
            self._told_flip = True
            self.get_logger().info(
                f"the floor was found with the camera upside down: floor.up_hint {list(tracker.config.up_hint)} from "
                "now on (floor.auto_flip; set floor.up_hint so to skip the search)")
        self.pub_floor(M.make_floor_plane(seg.floor, header))
        self.pub_mask(M.make_foreground_mask(seg.mask, seg.no_depth, header))
        self.pub_fg(M.make_pointcloud2(seg.points, header))
        self.frames_ok += 1


# ---------------------------------------------------------------------------------- leg_tracker


# frames of which only the floor plane has arrived wait this long for their other parts (5 s at 30 Hz): the floor
# planes come straight from floor_segmentation, the leg tracks behind them by the tracker's latency (400 ms and more
# when it cannot keep up); a floor plane is some 100 bytes
FLOOR_WAIT_FRAMES = 150


class StampSync:
    """Exact-time synchroniser for a few topics published with one header (no message_filters on PyPI).

    A frame is complete once every named part with its stamp (and frame id) has arrived.  A frame still
    incomplete when a later one completes (each topic arrives in order, so it will not complete any more), or
    pushed out by more than ``keep`` incomplete ones, is given up: :meth:`take_dropped` lists those (stamp,
    missing parts) once, for the node to report.  Parts named in ``stand_in`` (ones that change slowly, the floor
    plane) are not worth a frame: a frame missing only those is handed out with the latest message of each
    instead, and :meth:`take_stood_in` lists it.

    ``keep_waiting``: a frame of which only stand-in parts have arrived so far is waiting for a slower topic (the
    floor planes run ahead of the leg tracks by the tracker's latency, often more than ``keep`` frames when the
    tracker is busy); up to this many such frames wait without counting towards ``keep``, so the slower part still
    finds its own.  ``None``: they count towards ``keep`` like any other.
    """

    def __init__(self, names: tuple[str, ...], *, keep: int = 10, stand_in: tuple[str, ...] = (),
                 keep_waiting: int | None = None) -> None:
        if not set(stand_in) <= set(names):
            raise ValueError(f"stand_in {stand_in} must be among the parts {names}")
        if keep < 0 or (keep_waiting is not None and keep_waiting < 0):
            raise ValueError(f"keep {keep} and keep_waiting {keep_waiting} must be >= 0")
        self.names = names
        self.keep = keep
        self.keep_waiting = keep_waiting
        self.stand_in = stand_in
        self.pending: dict[tuple[int, str], dict[str, Any]] = {}
        self._latest: dict[str, Any] = {}
        self._dropped: list[tuple[int, tuple[str, ...]]] = []
        self._stood_in: list[tuple[int, tuple[str, ...]]] = []

    def add(self, name: str, msg: Any) -> list[dict[str, Any]]:
        """The frames ready after ``msg`` arrived as part ``name``, oldest first (often none or one)."""
        key = (M.stamp_to_ns(msg.header.stamp), msg.header.frame_id)
        if name in self.stand_in:
            self._latest[name] = msg
        slot = self.pending.setdefault(key, {})
        slot[name] = msg
        ready: list[dict[str, Any]] = []
        if len(slot) == len(self.names):
            del self.pending[key]
            # frames by stamp, not by arrival: a frame whose first part was lost is first seen after later ones
            for k in sorted((k for k in self.pending if k[0] < key[0]), key=lambda k: k[0]):
                self._give_up(k, self.pending.pop(k), ready)
            ready.append(slot)
            return ready
        for k in self._overflow():
            self._give_up(k, self.pending.pop(k), ready)
        return ready

    def _overflow(self) -> list[tuple[int, str]]:
        """The pending frames pushed out by newer incomplete ones, oldest first: those beyond ``keep`` of the ones
        holding a required part, and those beyond ``keep_waiting`` of the ones holding only stand-in parts (with
        ``keep_waiting`` None, every frame counts towards ``keep``)."""
        def beyond(keys: set[tuple[int, str]], cap: int) -> list[tuple[int, str]]:
            return sorted(keys, key=lambda k: k[0])[:max(len(keys) - cap, 0)]

        waiting = set() if self.keep_waiting is None else \
            {k for k, slot in self.pending.items() if all(n in self.stand_in for n in slot)}
        pushed = beyond(set(self.pending) - waiting, self.keep) + beyond(waiting, self.keep_waiting or 0)
        return sorted(pushed, key=lambda k: k[0])

    def _give_up(self, key: tuple[int, str], slot: dict[str, Any], ready: list[dict[str, Any]]) -> None:
        missing = tuple(n for n in self.names if n not in slot)
        if all(n in self.stand_in and n in self._latest for n in missing):
            ready.append({**slot, **{n: self._latest[n] for n in missing}})
            self._stood_in.append((key[0], missing))
        else:
            self._dropped.append((key[0], missing))

    def take_dropped(self) -> list[tuple[int, tuple[str, ...]]]:
        """``(stamp ns, missing part names)`` of the frames given up since the last call."""
        out, self._dropped = self._dropped, []
        return out

    def take_stood_in(self) -> list[tuple[int, tuple[str, ...]]]:
        """``(stamp ns, part names stood in for)`` of the frames handed out with a stand-in since the last call."""
        out, self._stood_in = self._stood_in, []
        return out


def report_sync(node: WalkerNode, sync: StampSync, *, absent: tuple[str, ...] = ()) -> None:
    """Count each frame ``sync`` gave up as a skipped frame of ``node`` (logged once, on /diagnostics), and each
    one it completed with a stand-in part (logged once, counted on /diagnostics).  A frame that lacks only parts
    named in ``absent`` (ones whose publisher reports the frames it leaves out itself) is counted as absent, not as
    this node's problem."""
    for stamp_ns, missing in sync.take_dropped():
        if absent and set(missing) <= set(absent):
            node.report_absent("_".join(missing), f"the {', '.join(missing)} of the frame stamped "
                                                  f"{stamp_ns * 1e-9:.3f} s never came (the node that sends it dropped "
                                                  "the frame, most often because it could not keep up: see its "
                                                  "/diagnostics)")
            continue
        node.report_problem("incomplete_frame", f"frame stamped {stamp_ns * 1e-9:.3f} s dropped: its "
                                                f"{', '.join(missing)} never arrived (an input queue overflowed?)")
    for stamp_ns, missing in sync.take_stood_in():
        node.report_stand_in("_".join(missing), f"the {', '.join(missing)} of the frame stamped "
                                                 f"{stamp_ns * 1e-9:.3f} s never arrived: the latest one stood in")


def usable_cores() -> int:
    """The cores this process may run on (a container's or ``taskset``'s share, not the machine's)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def auto_kernel_threads(cores: int) -> int:
    """``leg_tracker.kernel_threads`` 0: the likelihood kernels' threads on a computer with ``cores`` cores.

    The live graph keeps two cores busy (floor_segmentation, the replay or the camera driver, gait_analyzer beside
    the tracker): on two cores a second kernel thread has no idle core to run on (the live bench's replay on the
    2-core VM, eight alternated runs each: 133-229 of 300 JointStates out with 1, 132-234 with 2, no difference
    beyond the host's noise); with four or more it finds one."""
    return 2 if cores >= 4 else 1


def _nobody_listens(publish: Any) -> bool:
    """True when the topic of ``publish`` (a :meth:`WalkerNode.raw_publisher`) has no subscriber: its message need
    not be built."""
    publisher = getattr(publish, "publisher", None)
    return publisher is not None and publisher.get_subscription_count() == 0


class LegTrackerNode(WalkerNode):
    """Foreground + floor → ``joint_states``, ``leg_track``, ``leg_markers``."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("leg_tracker", **kwargs)
        from walker_gait.core import kernels
        from walker_gait.core import tracker as T

        # the likelihood's compiled kernels (numba import + cache load, ~1 s; compiled the first time after an
        # install) before subscribing: done at the first CameraInfo instead, the stall overflowed the input queue
        kernels.compiled()

        preset = str(self.declare_parameter("preset", "default").value)
        base = T.preset(preset)
        self.config = self.declare_config(type(base), base=base, prefix="")
        self.use_rectified = bool(self.declare_parameter("use_rectified", True).value)
        self.mounting = str(self.declare_parameter("mounting", "facing_user").value)
        self.seed = int(self.declare_parameter("seed", 0).value)
        window = float(self.declare_parameter("pelvis_window_s", 1.0).value)
        if not (math.isfinite(window) and window >= 0):
            raise ParameterError(f"leg_tracker.pelvis_window_s must be a finite number >= 0 (0 = off), got {window}")
        leg = float(self.declare_parameter("leg_length_m", 0.0).value)
        from walker_gait.core.pelvis import LivePelvis, check_leg_length

        try:
            check_leg_length(leg)
        except ValueError as exc:
            raise ParameterError(f"leg_tracker.{exc}") from None
        self.pelvis = LivePelvis(mounting=self.mounting, window_s=window, leg_length_m=leg) if window > 0 else None
        bridge_s = float(self.declare_parameter("bridge_hidden_s", 1.0).value)
        if not (math.isfinite(bridge_s) and bridge_s >= 0):
            raise ParameterError(f"leg_tracker.bridge_hidden_s must be a finite number >= 0 (0 = off), got {bridge_s}")
        from walker_gait.core.smoothing import LiveBridge

        # leg_track_bridged: leg_track with each hidden foot's stretch bridged once it is seen again (held till then)
        self.bridge = LiveBridge(hide_below=self.config.hide_below, max_gap_s=bridge_s) if bridge_s > 0 else None
        threads = self.declare_parameter("kernel_threads", 0).value
        if isinstance(threads, bool) or not isinstance(threads, int) or threads < 0:
            raise ParameterError(f"leg_tracker.kernel_threads must be an integer >= 0 (0 = by the computer's cores), "
                                 f"got {threads!r}")
        self.kernel_threads = int(threads) or auto_kernel_threads(usable_cores())
        self.tracker: Any = None
        self.intrinsics: Any = None
        self.sync = StampSync(("points", "mask", "floor"), stand_in=("floor",),
                              keep_waiting=FLOOR_WAIT_FRAMES)
        self.pub_joints = self.raw_publisher(M.JOINT_STATE, "joint_states", STREAM)
        self.pub_track = self.raw_publisher(M.LEG_TRACK, "leg_track", STREAM)
        self.pub_markers = self.raw_publisher(M.MARKER_ARRAY, "leg_markers", STREAM)
        self.pub_bridged = self.raw_publisher(M.LEG_TRACK, "leg_track_bridged", STREAM) if self.bridge else None
        # frames held for a hidden foot come out as tracked once the input has paused longer than the longest bridge
        # (the stream stopped: no frame will decide them)
        self._last_frame_wall = time.monotonic()
        if self.bridge is not None:
            self._bridge_timer = self.create_timer(0.25, self.release_stale)
        self.raw_subscription(M.CAMERA_INFO, "depth/camera_info", self.on_info, SENSOR_IN)
        # the queue (default 10 frames = 1/3 s at 30 Hz) absorbs bursts in which the tracker is slower than the
        # camera, so no frame is skipped while it keeps up on average; latency stays bounded by depth / rate
        qos_in = stream_in(int(self.declare_parameter("input_depth", 10).value))
        self.raw_subscription(M.POINT_CLOUD2, "foreground/points", lambda m: self.on_part("points", m), qos_in)
        self.raw_subscription(M.IMAGE, "foreground/mask", lambda m: self.on_part("mask", m), qos_in)
        self.raw_subscription(M.FLOOR_PLANE, "floor_plane", lambda m: self.on_part("floor", m), qos_in)
        self.latencies: list[float] = []
        self._waiting: deque[dict[str, Any]] = deque()  # complete frames held until the first CameraInfo
        self.add_on_set_parameters_callback(self._on_set_parameters)

    def _on_set_parameters(self, params: list[Any]) -> Any:
        """``leg_length_m`` may change while the node runs (the next user at the walker: ``ros2 param set
        /leg_tracker leg_length_m 0.91``); a value the placement would refuse is refused with its reason."""
        from rcl_interfaces.msg import SetParametersResult

        from walker_gait.core.pelvis import check_leg_length

        try:
            new = [check_leg_length(p.value) for p in params if p.name == "leg_length_m"]
        except ValueError as exc:
            return SetParametersResult(successful=False, reason=f"leg_tracker.{exc}")
        for value in new:
            if self.pelvis is not None:
                self.pelvis.leg_length_m = value
            self.get_logger().info(f"leg_length_m set to {value if value else 'not measured'}"
                                   + ("" if self.pelvis is not None else " (the placement is off: pelvis_window_s 0)"))
        return SetParametersResult(successful=True)

    def on_info(self, msg: Any) -> None:
        from walker_gait.core.depth import intrinsics_from_camera_info
        from walker_gait.core.tracker import LegTracker

        intr, _ = intrinsics_from_camera_info(**M.intrinsics_fields(msg), rectified=self.use_rectified)
        if intr == self.intrinsics:
            return
        self.intrinsics = intr
        # the shoes' rise and turn place the reported heels (LivePelvis; about 5 ms a frame on a slow 2-core computer)
        self.tracker = LegTracker(self.config, intr, rng=stage_rng(self.seed, "leg_tracker"), mounting=self.mounting,
                                  measure_shoes=self.pelvis is not None, threads=self.kernel_threads)
        if self.pelvis is not None:
            self.pelvis.reset()
        if self.bridge is not None:  # a new track: what is held comes out as tracked
            self._publish_bridged(self.bridge.flush())
        while self._waiting:  # frames that were complete before the first CameraInfo
            with self.guard("leg_tracker"):
                self.track(self._waiting.popleft())

    def on_part(self, name: str, msg: Any) -> None:
        ready = self.sync.add(name, msg)
        report_sync(self, self.sync)
        for complete in ready:
            with self.guard("leg_tracker"):
                self.on_frame_parts(complete)

    def on_frame_parts(self, complete: dict[str, Any]) -> None:
        """One frame's parts: tracked, or held until the first CameraInfo."""
        if self.tracker is None:
            self._waiting.append(complete)
            if len(self._waiting) > WAITING_IMAGES:
                self._waiting.popleft()  # the oldest held frame is dropped and counted
                raise MissingCameraInfo("no CameraInfo received on depth/camera_info yet")
            return
        self.track(complete)

    def track(self, parts: dict[str, Any]) -> None:
        t0 = time.perf_counter()
        header = parts["points"].header
        mask = M.image_to_mask(parts["mask"])
        no_depth = M.image_to_no_depth(parts["mask"])
        points = M.read_pointcloud2(parts["points"])
        if points.ndim == 3:
            points = points.reshape(-1, 3)
        depth_fg = np.full(mask.shape, np.nan, dtype=np.float32)
        if len(points) == int(mask.sum()):
            depth_fg[mask] = points[:, 2]
        floor = M.floor_from_msg(parts["floor"])
        pose = self.tracker.update(stamp=M.stamp_to_s(header.stamp), points=points, depth_fg=depth_fg, floor=floor,
                                   no_depth=no_depth)
        if self.pelvis is not None:  # the hips and knees the camera does not see, over the feet (same feet)
            pose = self.pelvis.place(pose, floor)
        self.pub_joints(M.make_joint_state(pose, header))
        self.pub_track(M.make_leg_track(pose, header, particle_count=int(getattr(self.config, "n_particles", 0))))
        self._publish_markers(pose, header)
        if self.bridge is not None:
            self._publish_bridged(self.bridge.push(pose, floor, header))
        self._last_frame_wall = time.monotonic()
        self.frames_ok += 1
        self.frame_timed(M.stamp_to_s(header.stamp), time.perf_counter() - t0,
                         advice="fewer particles (n_particles) or a lighter preset keep up; input_depth 1-2 tracks the "
                                "newest frames with less latency")

    def release_stale(self) -> None:
        """``leg_track_bridged``'s held frames published as tracked once no frame has come for ``bridge_hidden_s``
        (wall clock)."""
        if self.bridge is not None and self.bridge.held and \
                time.monotonic() - self._last_frame_wall > self.bridge.max_gap_s:
            with self.guard("leg_tracker"):
                self._publish_bridged(self.bridge.flush())

    def diagnostic_values(self) -> dict[str, Any]:
        out: dict[str, Any] = {} if self.bridge is None else {"bridge_held": self.bridge.held}
        if self.tracker is not None:  # frames tracked again by the passing check (`passing_jump`), and kept
            out["passing_checks"] = self.tracker.passings
            out["passing_checks_kept"] = self.tracker.passings_kept
        return out

    def _publish_markers(self, pose: Any, header: Any) -> None:
        """``leg_markers``, the cylinders for RViz / Foxglove: built only while something subscribes (about 2 ms a
        frame on a 2-core host, a twentieth of the tracker node's time at 30 Hz)."""
        if not _nobody_listens(self.pub_markers):
            self.pub_markers(M.make_markers(pose, header))

    def _publish_bridged(self, released: list[tuple[Any, Any]]) -> None:
        assert self.pub_bridged is not None
        if not released or _nobody_listens(self.pub_bridged):
            return  # nobody listens: the frames pass through the bridge (its state), no message is built
        particles = int(getattr(self.config, "n_particles", 0))
        for pose, header in released:
            self.pub_bridged(M.make_leg_track(pose, header, particle_count=particles))


# -------------------------------------------------------------------------------- gait_analyzer


class GaitAnalyzerNode(WalkerNode):
    """``leg_track`` + ``floor_plane`` (+ ``odom``) → ``gait_events``, ``steps``, ``gait_summary``."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("gait_analyzer", **kwargs)
        from walker_gait.core.gait import GaitAnalyzer, GaitConfig

        self.config = self.declare_config(GaitConfig)
        self.window_s = float(self.declare_parameter("summary_window", 10.0).value)
        use_odom = bool(self.declare_parameter("use_odometry", False).value)
        self.analyzer = GaitAnalyzer(self.config)
        self._last_stamp: float | None = None
        self.sync = StampSync(("track", "floor"), stand_in=("floor",), keep_waiting=FLOOR_WAIT_FRAMES)
        self.frame_id = ""
        self.pub_event = self.raw_publisher(M.GAIT_EVENT, "gait_events", EVENTS)
        self.pub_step = self.raw_publisher(M.STEP, "steps", EVENTS)
        self.pub_summary = self.raw_publisher(M.GAIT_SUMMARY, "gait_summary", LATCHED)
        self.pub_window = self.raw_publisher(M.GAIT_SUMMARY, "gait_summary/rolling", LATCHED)
        self.raw_subscription(M.FLOOR_PLANE, "floor_plane", lambda m: self.on_part("floor", m), STREAM_IN)
        self.raw_subscription(M.LEG_TRACK, "leg_track", lambda m: self.on_part("track", m), STREAM_IN)
        if use_odom:
            self.raw_subscription(M.ODOMETRY, "odom", self.on_odom, STREAM_IN)

    def on_odom(self, msg: Any) -> None:
        q = msg.pose.pose.orientation
        yaw = float(np.arctan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z)))
        self.analyzer.update_odometry(M.stamp_to_s(msg.header.stamp), float(msg.pose.pose.position.x),
                                      float(msg.pose.pose.position.y), yaw)

    def on_part(self, name: str, msg: Any) -> None:
        ready = self.sync.add(name, msg)
        report_sync(self, self.sync, absent=("track",))
        for parts in ready:
            with self.guard("leg_track"):
                self.on_frame(parts["track"], M.floor_from_msg(parts["floor"]))

    def on_frame(self, msg: Any, floor: Any) -> None:
        """One frame: its LegTrack and the FloorPlane with the same stamp.

        Time running backwards by more than ``TIME_JUMP_RESET_S`` (a looping or restarted bag replay, a
        simulator reset) ends the session: its last steps are flushed and the analysis starts afresh.  A
        smaller step back or a repeated stamp skips the frame (``StampOrderError``, counted on /diagnostics).
        """
        from walker_gait.core.gait import GaitAnalyzer

        self.frame_id = msg.header.frame_id
        # the analysis reads the tracker's own heels, ankles and toes (the reported ones are placed: LegTrack.
        # heel_tracked, ankle_tracked, toe_tracked), so its steps are those of an offline one-pass run
        pose = M.leg_pose_from_track(msg).as_tracked()
        if self._last_stamp is not None and pose.stamp < self._last_stamp - TIME_JUMP_RESET_S:
            self.get_logger().warning(
                f"time jumped back from {self._last_stamp:.3f} s to {pose.stamp:.3f} s (replay looped or "
                "restarted?): gait analysis restarted")
            self.close()
            self.analyzer = GaitAnalyzer(self.config)
            self._last_stamp = None
        events, steps = self.analyzer.update(pose, floor)
        self._last_stamp = pose.stamp
        self.publish_results(events, steps, msg.header)
        self.frames_ok += 1

    def publish_results(self, events: list[Any], steps: list[Any], header: Any) -> None:
        for ev in events:
            self.pub_event(M.make_gait_event(ev, header.frame_id))
        for st in steps:
            self.pub_step(M.make_step(st, header.frame_id))
        if steps:
            self.pub_summary(M.make_gait_summary(self.analyzer.summary(window_s=None).to_dict(), header))
            self.pub_window(M.make_gait_summary(self.analyzer.summary(window_s=self.window_s).to_dict(), header))

    def close(self) -> bool:
        """Flush the analyzer at shutdown; True if something was published."""
        events, steps = self.analyzer.finish()
        if events or steps:
            header = M.make_header(steps[-1].stamp if steps else events[-1].stamp, self.frame_id)
            self.publish_results(events, steps, header)
        return bool(events or steps)


# ----------------------------------------------------------------------------------- bag_replay


class BagReplayNode(WalkerNode):
    """Publishes a recording's topics (CDR bytes as recorded; ROS 1 converted) and ``/clock``."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("bag_replay", **kwargs)
        self.input = str(self.declare_parameter("input", "").value)
        self.rate = float(self.declare_parameter("rate", 1.0).value)
        self.loop = bool(self.declare_parameter("loop", False).value)
        self.publish_clock = bool(self.declare_parameter("publish_clock", True).value)
        self.start_delay = float(self.declare_parameter("start_delay", 1.0).value)
        self.done = False
        if not self.input:
            self.get_logger().info("no 'input' parameter: idle (start with -p input:=FILE, or use walker-gait replay)")
            return
        if self.rate <= 0:
            raise ValueError(f"rate must be > 0, got {self.rate}")
        from walker_gait.ros.replay import Replayer

        self.replayer = Replayer(self, self.input, rate=self.rate, loop=self.loop, publish_clock=self.publish_clock,
                                 start_delay=self.start_delay)
        self.replayer.start()

    def close(self) -> bool:
        replayer = getattr(self, "replayer", None)
        if replayer is not None:
            replayer.stop()
        return False


# ------------------------------------------------------------------------------- entry points


def _main(cls: type[WalkerNode]) -> int:
    return spin_node(cls)


def depth_to_cloud_main() -> int:
    return _main(DepthToCloudNode)


def floor_segmentation_main() -> int:
    return _main(FloorSegmentationNode)


def leg_tracker_main() -> int:
    return _main(LegTrackerNode)


def gait_analyzer_main() -> int:
    return _main(GaitAnalyzerNode)


def bag_replay_main() -> int:
    return _main(BagReplayNode)


NODES: dict[str, type[WalkerNode]] = {
    "depth_to_cloud": DepthToCloudNode,
    "floor_segmentation": FloorSegmentationNode,
    "leg_tracker": LegTrackerNode,
    "gait_analyzer": GaitAnalyzerNode,
    "bag_replay": BagReplayNode,
}
