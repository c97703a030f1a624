"""Drive the live node graph with a recording and watch it from outside, like a dashboard would.

``run_live(path)`` starts the node graph with ``walker-gait run`` (one OS process per node, real DDS), waits until
every link is subscribed, replays PATH into it with ``walker-gait replay``, subscribes
came out: the steps, the latency from a depth image's arrival to the arrival of the JointState with the
same stamp (and of ``leg_track_bridged``'s LegTrack, which holds a hidden foot's frames until it is seen again), frames
in vs out, and the frames the nodes reported as skipped.

When the recording has one CameraInfo per depth image (same stamp, published next to it), the probe
times a frame's arrival by its CameraInfo instead of subscribing to the 614 KB images: receiving them
would cost the probe ~8 % of a core, taken from the graph it measures on a 2-core machine.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from walker_gait import messages as M


@dataclass
class LiveResult:
    images: int = 0
    joint_states: int = 0
    bridged_stamps_ns: list[int] = field(default_factory=list)  # leg_track_bridged's frames, in arrival order
    bridged_latencies_ms: list[float] = field(default_factory=list)  # image arrival -> leg_track_bridged arrival
    steps: list[Any] = field(default_factory=list)
    latencies_ms: list[float] = field(default_factory=list)
    floor_latencies_ms: list[float] = field(default_factory=list)  # image arrival -> floor_plane arrival (segmented)
    skipped: dict[str, int] = field(default_factory=dict)
    stood_in: dict[str, int] = field(default_factory=dict)  # frames processed with a stand-in part, per node and part
    absent: dict[str, int] = field(default_factory=dict)  # frames a node got without a part its sender left out
    missed: dict[str, int] = field(default_factory=dict)  # per node: frames between those it worked on that it did not
    run_exit_code: int | None = None
    wall_s: float = 0.0
    first_stamp_ns: int | None = None
    missing_stamps_ns: list[int] = field(default_factory=list)  # images that produced no JointState
    skip_log: list[str] = field(default_factory=list)  # the graph's log lines about skipped frames and stand-ins

    @property
    def median_latency_ms(self) -> float:
        return float(np.median(self.latencies_ms)) if self.latencies_ms else float("nan")

    @property
    def floor_median_latency_ms(self) -> float:
        """Median image -> floor_plane latency (ms): the depth decoding and segmentation's share."""
        return float(np.median(self.floor_latencies_ms)) if self.floor_latencies_ms else float("nan")

    @property
    def p95_latency_ms(self) -> float:
        return float(np.percentile(self.latencies_ms, 95)) if self.latencies_ms else float("nan")

    def latency_trend_ms_per_s(self) -> float:
        """Slope of latency over the run: > 0 means a growing backlog."""
        if len(self.latencies_ms) < 10:
            return float("nan")
        y = np.asarray(self.latencies_ms)
        x = np.linspace(0, self.wall_s, len(y))
        return float(np.polyfit(x, y, 1)[0])


def run_live(path: Path, *, rate: float = 1.0, timeout_s: float = 120.0, settle_s: float = 3.0,
             params: tuple[str, ...] = ()) -> LiveResult:
    """Replay ``path`` through ``walker-gait run`` and collect what the graph publishes.

    ``params``: extra ``NODE.PARAM=VALUE`` overrides for the graph."""
    import rclpy
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    from walker_gait.io.bags import open_recording
    from walker_gait.ros.base import DIAGNOSTICS, EVENTS, rclpy_type

    recording = open_recording(path)
    expected = recording.frame_count
    info_topic = recording.info_topic
    # frame arrivals from the (small) per-frame CameraInfo when there is one per image
    by_info = info_topic is not None and recording.topics[info_topic].count >= expected
    result = LiveResult()
    arrivals: dict[int, float] = {}
    arrivals_bridged: dict[int, float] = {}
    arrivals_floor: dict[int, float] = {}
    rclpy.init()
    node = rclpy.create_node("walker_gait_live_probe")
    best_effort = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=50, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.VOLATILE)  # reliable: the probe must not lose frames itself

    def on_image(data: bytes, typename: str = M.IMAGE) -> None:
        msg = M.deserialize(data, typename)
        stamp = M.stamp_to_ns(msg.header.stamp)
        arrivals[stamp] = arrivals_bridged[stamp] = arrivals_floor[stamp] = time.monotonic()
        if result.first_stamp_ns is None:
            result.first_stamp_ns = stamp
        result.images += 1

    def on_joints(data: bytes) -> None:
        now = time.monotonic()
        msg = M.deserialize(data, M.JOINT_STATE)
        t_in = arrivals.pop(M.stamp_to_ns(msg.header.stamp), None)
        result.joint_states += 1
        if t_in is not None:
            result.latencies_ms.append((now - t_in) * 1e3)

    def on_bridged(data: bytes) -> None:
        now = time.monotonic()
        stamp = M.stamp_to_ns(M.deserialize(data, M.LEG_TRACK).header.stamp)
        result.bridged_stamps_ns.append(stamp)
        t_in = arrivals_bridged.pop(stamp, None)
        if t_in is not None:
            result.bridged_latencies_ms.append((now - t_in) * 1e3)

    def on_floor(data: bytes) -> None:
        now = time.monotonic()
        t_in = arrivals_floor.pop(M.stamp_to_ns(M.deserialize(data, M.FLOOR_PLANE).header.stamp), None)
        if t_in is not None:
            result.floor_latencies_ms.append((now - t_in) * 1e3)

    def on_diag(data: bytes) -> None:
        msg = M.deserialize(data, M.DIAGNOSTIC_ARRAY)
        for status in msg.status:
            for kv in status.values:
                if kv.key.startswith("skipped."):
                    result.skipped[f"{status.name}:{kv.key[8:]}"] = int(kv.value)
                elif kv.key.startswith("stood_in."):
                    result.stood_in[f"{status.name}:{kv.key[9:]}"] = int(kv.value)
                elif kv.key.startswith("absent."):
                    result.absent[f"{status.name}:{kv.key[7:]}"] = int(kv.value)
                elif kv.key == "frames_missed":
                    result.missed[status.name] = int(kv.value)

    if by_info:
        node.create_subscription(rclpy_type(M.CAMERA_INFO), "/depth/camera_info",
                                 lambda d: on_image(d, M.CAMERA_INFO), best_effort, raw=True)
    else:
        node.create_subscription(rclpy_type(M.IMAGE), "/depth/image_raw", on_image, best_effort, raw=True)
    node.create_subscription(rclpy_type(M.JOINT_STATE), "/joint_states", on_joints, best_effort, raw=True)
    node.create_subscription(rclpy_type(M.LEG_TRACK), "/leg_track_bridged", on_bridged, best_effort, raw=True)
    node.create_subscription(rclpy_type(M.STEP), "/steps",
                             lambda d: result.steps.append(M.step_from_msg(M.deserialize(d, M.STEP))), EVENTS,
                             raw=True)
    node.create_subscription(rclpy_type(M.DIAGNOSTIC_ARRAY), "/diagnostics", on_diag, DIAGNOSTICS, raw=True)
    # the segmentation's share of the latency: its floor plane (some 100 bytes) carries the image's stamp
    node.create_subscription(rclpy_type(M.FLOOR_PLANE), "/floor_plane", on_floor, best_effort, raw=True)
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    graph = [sys.executable, "-m", "walker_gait.cli", "run", "--nodes",
             "depth_to_cloud,floor_segmentation,leg_tracker,gait_analyzer",
             "--param", "floor_segmentation.input_reliability=reliable"]
    for p in params:
        graph += ["--param", p]
    # the graph's log goes to a file: a pipe nobody reads would block the nodes once it fills
    log_file = tempfile.TemporaryFile(mode="w+", encoding="utf-8")
    run = subprocess.Popen(graph, env=env, stdout=subprocess.DEVNULL, stderr=log_file, text=True,
                           start_new_session=True)
    replay: subprocess.Popen[str] | None = None
    t0 = time.monotonic()
    try:
        # wait until every link of the graph is subscribed, so no frame is lost at the start
        # (floor_segmentation reads the depth image itself; depth_to_cloud subscribes to it only while its
        # `points` has a subscriber: none here)
        # graph: images -> floor_segmentation; CameraInfo -> depth_to_cloud, floor_segmentation, leg_tracker
        links = {"/depth/image_raw": 1 if by_info else 2, "/depth/camera_info": 4 if by_info else 3,
                 "/foreground/points": 1, "/foreground/mask": 1,
                 "/floor_plane": 3, "/leg_track": 1}  # floor_plane: leg_tracker, gait_analyzer, this probe
        while time.monotonic() - t0 < 60:
            rclpy.spin_once(node, timeout_sec=0.1)
            if all(node.count_subscribers(t) >= n for t, n in links.items()):
                break
        replay = subprocess.Popen([sys.executable, "-m", "walker_gait.cli", "replay", str(path), "--rate", str(rate),
                                   "--start-delay", "0.5", "--wait-subscribers", str(links["/depth/image_raw"]),
                                   "--wait-info-subscribers", str(links["/depth/camera_info"])],
                                  env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, text=True,
                                  start_new_session=True)
        t0 = time.monotonic()
        deadline = t0 + timeout_s
        last_progress = time.monotonic()
        seen = 0
        while time.monotonic() < deadline:
            rclpy.spin_once(node, timeout_sec=0.05)
            if result.joint_states != seen:
                seen, last_progress = result.joint_states, time.monotonic()
            if result.joint_states >= expected and time.monotonic() - last_progress > settle_s:
                break
            if result.images >= expected and time.monotonic() - last_progress > settle_s + 5:
                break  # some frames never came out
        result.wall_s = time.monotonic() - t0
        # Ctrl-C the graph and keep listening: gait_analyzer flushes its last steps while it shuts down
        run.send_signal(signal.SIGINT)
        end = time.monotonic() + 30
        while run.poll() is None and time.monotonic() < end:
            rclpy.spin_once(node, timeout_sec=0.05)
        end = time.monotonic() + 0.5
        while time.monotonic() < end:
            rclpy.spin_once(node, timeout_sec=0.05)
    finally:
        if replay is not None and replay.poll() is None:
            replay.send_signal(signal.SIGINT)
            try:
                replay.wait(timeout=10)
            except subprocess.TimeoutExpired:
                os.killpg(replay.pid, signal.SIGKILL)
        if run.poll() is None:
            run.send_signal(signal.SIGINT)
            try:
                run.wait(timeout=30)
            except subprocess.TimeoutExpired:
                os.killpg(run.pid, signal.SIGKILL)
        result.run_exit_code = run.wait()
        log_file.seek(0)
        result.skip_log = [line.strip() for line in log_file
                           if "frame skipped" in line or "stood in" in line or "cannot keep up" in line]
        log_file.close()
        result.missing_stamps_ns = sorted(arrivals)
        node.destroy_node()
        rclpy.shutdown()
    return result
