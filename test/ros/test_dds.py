"""Real rclpy, real DDS, separate OS processes: the dashboard use cases and the node graph lifecycle."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import textwrap
import time

import pytest

pytestmark = pytest.mark.ros

STEP_FIELDS = {"foot": 1, "step_index": 7, "step_length": 0.52, "step_width": 0.11, "step_time": 0.61,
               "stride_length": 1.03, "stride_time": 1.2, "stance_time": 0.74, "swing_time": 0.46,
               "single_support_time": 0.45, "double_support_time": 0.28, "confidence": 0.9}

PUBLISH_STEPS = textwrap.dedent(f"""
    import time, rclpy
    from walker_gait import messages as M
    from walker_gait.core.types import Side, Step
    from walker_gait.ros.base import EVENTS, rclpy_type
    f = {STEP_FIELDS!r}
    rclpy.init()
    node = rclpy.create_node("step_publisher")
    pub = node.create_publisher(rclpy_type(M.STEP), "/steps", EVENTS)
    step = Step(stamp=12.25, side=Side(f["foot"]), index=f["step_index"], step_length=f["step_length"],
                step_width=f["step_width"], step_time=f["step_time"], stride_length=f["stride_length"],
                stride_time=f["stride_time"], stance_time=f["stance_time"], swing_time=f["swing_time"],
                single_support_time=f["single_support_time"], double_support_time=f["double_support_time"],
                confidence=f["confidence"])
    data = M.serialize(M.make_step(step, "camera_depth_optical_frame"))
    end = time.monotonic() + 30
    while time.monotonic() < end:
        pub.publish(data)
        rclpy.spin_once(node, timeout_sec=0.1)
""")

# The subscriber is what a dashboard author writes: plain rclpy, generated message classes.
SUBSCRIBE_STEP = textwrap.dedent("""
    import json, rclpy
    from rclpy.qos import QoSProfile, ReliabilityPolicy, HistoryPolicy, DurabilityPolicy
    from walker_gait_msgs.msg import Step
    rclpy.init()
    node = rclpy.create_node("dashboard")
    got = []
    qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.VOLATILE)
    node.create_subscription(Step, "/steps", got.append, qos)
    while not got:
        rclpy.spin_once(node, timeout_sec=0.1)
    m = got[0]
    print(json.dumps({k: getattr(m, k) for k in m.get_fields_and_field_types() if k != "header"}
                     | {"stamp": [m.header.stamp.sec, m.header.stamp.nanosec], "frame_id": m.header.frame_id}))
""")

PUBLISH_SUMMARY_ONCE = textwrap.dedent("""
    import sys, time, rclpy
    from walker_gait import messages as M
    from walker_gait.ros.base import LATCHED, rclpy_type
    rclpy.init()
    node = rclpy.create_node("summary_publisher")
    pub = node.create_publisher(rclpy_type(M.GAIT_SUMMARY), "/gait_summary", LATCHED)
    pub.publish(M.serialize(M.make_gait_summary({"scope": 1, "step_count": 42, "cadence": 101.5},
                                                M.make_header(99.0, "cam"))))
    print("published", flush=True)
    end = time.monotonic() + 60
    while time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.1)
""")

LATE_SUBSCRIBER = textwrap.dedent("""
    import rclpy
    from rclpy.qos import QoSProfile, ReliabilityPolicy, HistoryPolicy, DurabilityPolicy
    from walker_gait_msgs.msg import GaitSummary
    rclpy.init()
    node = rclpy.create_node("late_dashboard")
    got = []
    qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
    node.create_subscription(GaitSummary, "/gait_summary", got.append, qos)
    while not got:
        rclpy.spin_once(node, timeout_sec=0.1)
    print(got[0].step_count, round(got[0].cadence, 3))
""")

LIST_NODES = textwrap.dedent("""
    import sys, time, rclpy
    wanted = set(sys.argv[1].split(","))
    rclpy.init()
    node = rclpy.create_node("graph_probe")
    end = time.monotonic() + 60
    names = set()
    while time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.2)
        names = set(node.get_node_names())
        if wanted <= names:
            break
    print(",".join(sorted(names)))
""")


def _python(script: str, env: dict[str, str], *args: str) -> list[str]:
    return [sys.executable, "-c", script, *args]


def test_step_published_in_one_process_is_received_field_for_field_in_another(ros_env: dict[str, str]) -> None:
    pub = subprocess.Popen(_python(PUBLISH_STEPS, ros_env), env=ros_env)
    try:
        out = subprocess.run(_python(SUBSCRIBE_STEP, ros_env), env=ros_env, capture_output=True, text=True,
                             timeout=60, check=True).stdout
    finally:
        pub.kill()
        pub.wait()
    got = json.loads(out.strip().splitlines()[-1])
    for key, value in STEP_FIELDS.items():
        assert got[key] == pytest.approx(value, rel=1e-6), key
    assert got["stamp"] == [12, 250_000_000]
    assert got["frame_id"] == "camera_depth_optical_frame"


def test_gait_summary_reaches_a_late_joining_subscriber(ros_env: dict[str, str]) -> None:
    pub = subprocess.Popen(_python(PUBLISH_SUMMARY_ONCE, ros_env), env=ros_env, stdout=subprocess.PIPE, text=True)
    try:
        assert pub.stdout is not None
        assert pub.stdout.readline().strip() == "published"
        time.sleep(1.0)  # the subscriber joins after the only publication
        out = subprocess.run(_python(LATE_SUBSCRIBER, ros_env), env=ros_env, capture_output=True, text=True,
                             timeout=60, check=True).stdout
    finally:
        pub.kill()
        pub.wait()
    assert out.split() == ["42", "101.5"]


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:  # a zombie is not alive
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().split()[2] != "Z"
    except FileNotFoundError:
        return False


def test_walker_gait_run_starts_five_nodes_and_ctrl_c_stops_them(ros_env: dict[str, str]) -> None:
    run = subprocess.Popen([sys.executable, "-m", "walker_gait.cli", "run"], env=ros_env, stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        assert run.stdout is not None
        line = run.stdout.readline()
        pids = [int(p) for p in re.findall(r"pid (\d+)", line)]
        assert len(pids) == 5, line
        wanted = "depth_to_cloud,floor_segmentation,leg_tracker,gait_analyzer,bag_replay"
        seen = subprocess.run(_python(LIST_NODES, ros_env, wanted), env=ros_env, capture_output=True, text=True,
                              timeout=90, check=True).stdout.strip().split(",")
        assert set(wanted.split(",")) <= set(seen), seen
        run.send_signal(signal.SIGINT)  # what Ctrl-C does
        code = run.wait(timeout=30)
        err = run.stderr.read() if run.stderr else ""
        assert code == 0, err
        deadline = time.monotonic() + 5
        while any(_alive(p) for p in pids) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not [p for p in pids if _alive(p)], "orphaned node processes"
        assert "Traceback" not in err, err
    finally:
        if run.poll() is None:
            os.killpg(run.pid, signal.SIGKILL)
