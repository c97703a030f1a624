"""Replay a recording into the ROS graph: recorded CDR bytes republished in log-time order, with /clock."""

from __future__ import annotations

import threading
import time
from typing import Any

from walker_gait import messages as M
from walker_gait.ros.base import STREAM, rclpy_type

#: The topics walker_gait's nodes read, onto which the recording's depth/CameraInfo topics are mapped.
DEPTH_TOPIC = "/depth/image_raw"
INFO_TOPIC = "/depth/camera_info"


class Replayer:
    """Publishes a recording from a background thread of a node.

    The recording's auto-detected depth and CameraInfo topics are published on
    :data:`DEPTH_TOPIC` / :data:`INFO_TOPIC` (``remap_inputs=True``), the other topics under
    their recorded names.  Messages whose type is not importable here are skipped with one warning.
    """

    def __init__(self, node: Any, path: str, *, rate: float = 1.0, loop: bool = False, publish_clock: bool = True,
                 start_delay: float = 1.0, remap_inputs: bool = True, depth_topic: str | None = None,
                 info_topic: str | None = None, wait_subscribers: int = 0, wait_info_subscribers: int | None = None,
                 wait_timeout: float = 30.0) -> None:
        from walker_gait.io.bags import open_recording

        self.node = node
        self.path = path
        self.rate = rate
        self.loop = loop
        self.publish_clock = publish_clock
        self.start_delay = start_delay
        self.recording = open_recording(path, depth_topic=depth_topic, info_topic=info_topic)
        self.topic_map: dict[str, str] = {}
        if remap_inputs:
            if self.recording.depth_topic:
                self.topic_map[self.recording.depth_topic] = DEPTH_TOPIC
            if self.recording.info_topic:
                self.topic_map[self.recording.info_topic] = INFO_TOPIC
        self.publishers: dict[str, Any] = {}
        self.skipped_types: set[str] = set()
        self.clock_pub = node.create_publisher(rclpy_type(M.CLOCK), "/clock", 10) if publish_clock else None
        self.published = 0
        self.wait_subscribers = wait_subscribers
        self.wait_info_subscribers = wait_subscribers if wait_info_subscribers is None else wait_info_subscribers
        self.wait_timeout = wait_timeout
        self.finished = threading.Event()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="bag_replay", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=2.0)

    def _publisher(self, topic: str, msgtype: str) -> Any:
        pub = self.publishers.get(topic)
        if pub is None and msgtype not in self.skipped_types:
            try:
                pub = self.node.create_publisher(rclpy_type(msgtype), self.topic_map.get(topic, topic), STREAM)
            except (ImportError, AttributeError, ValueError):
                self.skipped_types.add(msgtype)
                self.node.get_logger().warning(f"{self.path}: type {msgtype} not available here; not replaying {topic}")
                return None
            self.publishers[topic] = pub
        return pub

    def _wait_for_subscribers(self) -> None:
        """Create the input publishers and wait until ``wait_subscribers`` match the depth topic's and
        ``wait_info_subscribers`` the CameraInfo topic's (volatile QoS loses whatever is published before
        a subscriber is matched)."""
        wanted = {self.recording.depth_topic: self.wait_subscribers, self.recording.info_topic: self.wait_info_subscribers}
        types = {t.name: t.msgtype for t in self.recording.topics.values()}
        pubs = [(p, n) for t, n in wanted.items() if t and (p := self._publisher(t, types[t])) is not None]
        deadline = time.monotonic() + self.wait_timeout
        while not self._stop.is_set() and time.monotonic() < deadline:
            if all(p.get_subscription_count() >= n for p, n in pubs):
                return
            time.sleep(0.05)
        self.node.get_logger().warning(f"only {[p.get_subscription_count() for p, _ in pubs]} subscribers after "
                                       f"{self.wait_timeout:.0f} s; replaying anyway")

    def _run(self) -> None:
        try:
            if self.wait_subscribers > 0:
                self._wait_for_subscribers()
            if self._stop.wait(self.start_delay):
                return
            while not self._stop.is_set():
                self._play_once()
                if not self.loop:
                    break
                from walker_gait.io.bags import open_recording

                self.recording = open_recording(self.path, depth_topic=self.recording.depth_topic,
                                                info_topic=self.recording.info_topic)
            self.node.get_logger().info(f"replay of {self.path} finished: {self.published} messages")
        except Exception as exc:  # noqa: BLE001 - reported, node keeps running
            self.node.report_problem("replay_error", f"{self.path}: {exc}")
        finally:
            self.finished.set()

    def _play_once(self) -> None:
        t0_wall: float | None = None
        t0_log = 0
        clock_cls = rclpy_type(M.CLOCK) if self.clock_pub is not None else None
        for msg in self.recording.iter_raw():
            if self._stop.is_set():
                return
            if t0_wall is None:
                t0_wall, t0_log = time.monotonic(), msg.stamp_ns
            due = t0_wall + (msg.stamp_ns - t0_log) * 1e-9 / self.rate
            delay = due - time.monotonic()
            if delay > 0 and self._stop.wait(delay):
                return
            if self.clock_pub is not None and clock_cls is not None:
                clock = clock_cls()
                clock.clock.sec, clock.clock.nanosec = divmod(msg.stamp_ns, 1_000_000_000)
                self.clock_pub.publish(clock)
            pub = self._publisher(msg.topic, msg.msgtype)
            if pub is not None:
                pub.publish(msg.data)
                self.published += 1
