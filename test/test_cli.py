"""`walker-gait` command line: outputs of `process`, and clear errors for bad input (exit 2, file named,
no traceback)."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import pytest

from walker_gait.io.outputs import EVENTS_COLUMNS, JOINTS_COLUMNS, STEPS_COLUMNS


def walker_gait(*args: str, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "walker_gait.cli", *args], capture_output=True, text=True,
                          timeout=timeout)


def test_process_real_bag_writes_every_output(real_bag: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    res = walker_gait("process", str(real_bag), "--out", str(out), "--quiet")
    assert res.returncode == 0, res.stderr
    for name in ("steps.csv", "events.csv", "joints.csv", "summary.json", "tracked.mcap", "report.html"):
        assert (out / name).is_file(), name
    with open(out / "steps.csv", newline="") as fh:
        assert tuple(next(csv.reader(fh))) == STEPS_COLUMNS
    with open(out / "events.csv", newline="") as fh:
        assert tuple(next(csv.reader(fh))) == EVENTS_COLUMNS
    with open(out / "joints.csv", newline="") as fh:
        rows = list(csv.reader(fh))
    assert tuple(rows[0]) == JOINTS_COLUMNS
    assert len(rows) == 2  # the bag has one depth frame
    summary = json.loads((out / "summary.json").read_text())
    assert "cadence_steps_per_min" in summary
    assert summary["metadata"]["frames_processed"] == 1
    assert summary["metadata"]["depth_topic"] == "/hero/head_rgbd_sensor/depth_registered/image"
    assert not list(out.glob(".*tmp*")), "temporary files left behind"


def test_passes_choose_one_or_two_tracking_passes(real_bag: Path, tmp_path: Path) -> None:
    """``--passes forward`` tracks as the live graph does; the default tracks forwards and backwards and says so;
    anything else is refused by the parser.  A measured leg length reaches the metadata; one in centimetres is
    refused, naming it."""
    one = walker_gait("process", str(real_bag), "--out", str(tmp_path / "one"), "--passes", "forward",
                      "--leg-length-m", "0.9")
    two = walker_gait("process", str(real_bag), "--out", str(tmp_path / "two"))
    assert one.returncode == 0 and two.returncode == 0, one.stderr + two.stderr
    meta_one = json.loads((tmp_path / "one" / "summary.json").read_text())["metadata"]
    meta_two = json.loads((tmp_path / "two" / "summary.json").read_text())["metadata"]
    assert meta_one["passes"] == "forward" and meta_two["passes"] == "both"
    assert meta_one["leg_length_m"] == 0.9 and meta_two["leg_length_m"] is None
    assert "tracked forwards (one pass)" in one.stdout and "tracked forwards and backwards" in two.stdout
    assert meta_one["tracker_runs"] is None and meta_two["tracker_runs"] == 1
    # each direction tracked once or more; a number of runs for the one pass, or out of range, is refused
    twice = walker_gait("process", str(real_bag), "--out", str(tmp_path / "twice"), "--tracker-runs", "2")
    assert twice.returncode == 0, twice.stderr
    assert json.loads((tmp_path / "twice" / "summary.json").read_text())["metadata"]["tracker_runs"] == 2
    assert "2 times each way" in twice.stdout
    for args in (("--passes", "forward", "--tracker-runs", "2"), ("--tracker-runs", "0"), ("--tracker-runs", "9"),
                 ("--tracker-threads", "2"), ("--passes", "forward", "--tracker-threads", "0")):
        bad = walker_gait("process", str(real_bag), "--out", str(tmp_path / "bad"), *args)
        assert bad.returncode == 2 and args[-2].lstrip("-") in bad.stderr.replace("_", "-"), bad.stderr
        assert "Traceback" not in bad.stderr
    # the kernels' threads for the one pass: the same poses as one thread
    threads = walker_gait("process", str(real_bag), "--out", str(tmp_path / "threads"), "--passes", "forward",
                          "--leg-length-m", "0.9", "--tracker-threads", "2")
    assert threads.returncode == 0, threads.stderr
    assert (tmp_path / "threads" / "joints.csv").read_text() == (tmp_path / "one" / "joints.csv").read_text()
    bad = walker_gait("process", str(real_bag), "--out", str(tmp_path / "bad"), "--passes", "backward")
    assert bad.returncode == 2 and "--passes" in bad.stderr
    # the reported poses' bridge and low-pass take a number >= 0; anything else is refused, naming it
    for flag, name, value in (("--bridge-hidden-s", "bridge_hidden_s", "-1"),
                              ("--report-lowpass-hz", "report_lowpass_hz", "-1"), ("--leg-length-m", "leg_length_m", "90")):
        bad = walker_gait("process", str(real_bag), "--out", str(tmp_path / "bad"), flag, value)
        assert bad.returncode == 2 and name in bad.stderr and "Traceback" not in bad.stderr, bad.stderr
    off = walker_gait("process", str(real_bag), "--out", str(tmp_path / "off"), "--bridge-hidden-s", "0",
                      "--report-lowpass-hz", "0")
    assert off.returncode == 0, off.stderr


def test_tracked_mcap_reads_back_with_rosbags(real_bag: Path, tmp_path: Path) -> None:
    from rosbags.highlevel import AnyReader

    out = tmp_path / "out"
    assert walker_gait("process", str(real_bag), "--out", str(out), "--quiet").returncode == 0
    with AnyReader([out / "tracked.mcap"]) as reader:
        topics = {c.topic: c.msgtype for c in reader.connections}
        assert topics["/leg_track"] == "walker_gait_msgs/msg/LegTrack"
        assert topics["/joint_states"] == "sensor_msgs/msg/JointState"
        conns = [c for c in reader.connections if c.topic == "/leg_track"]
        msgs = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages(connections=conns)]
    assert len(msgs) == 1
    assert msgs[0].header.frame_id


@pytest.mark.parametrize("case", ["missing", "text", "random_bytes", "empty_file", "directory_without_bags"])
def test_process_bad_input_exits_2_and_names_the_file(case: str, tmp_path: Path) -> None:
    if case == "missing":
        path = tmp_path / "nope.mcap"
    elif case == "text":
        path = tmp_path / "notes.txt"
        path.write_text("not a recording\n")
    elif case == "random_bytes":
        path = tmp_path / "broken.mcap"
        path.write_bytes(bytes(range(256)) * 50)
    elif case == "empty_file":
        path = tmp_path / "empty.bag"
        path.write_bytes(b"")
    else:
        path = tmp_path / "folder"
        path.mkdir()
        (path / "readme.md").write_text("nothing here")
    res = walker_gait("process", str(path), "--out", str(tmp_path / "out"), "--quiet")
    assert res.returncode == 2, (res.stdout, res.stderr)
    assert str(path.name) in res.stderr
    assert "Traceback" not in res.stderr
    assert not (tmp_path / "out" / "steps.csv").exists()


def test_process_recording_without_depth_topic(tmp_path: Path) -> None:
    import numpy as np

    from walker_gait import messages as M
    from walker_gait.io.bagwriter import BagWriter

    path = tmp_path / "rgb_only.mcap"
    with BagWriter(path, fmt="mcap") as bag:
        bag.add_topic("/camera/rgb/image_raw", M.IMAGE)
        img = M.make_image(np.zeros((4, 4, 3), np.uint8), M.make_header(1.0, "cam"), encoding="rgb8")
        bag.write("/camera/rgb/image_raw", 1_000_000_000, img)
    res = walker_gait("process", str(path), "--out", str(tmp_path / "out"), "--quiet")
    assert res.returncode == 2
    assert "rgb_only.mcap" in res.stderr and "depth" in res.stderr.lower()
    assert "Traceback" not in res.stderr


def test_unknown_param_is_a_user_error(real_bag: Path, tmp_path: Path) -> None:
    res = walker_gait("process", str(real_bag), "--out", str(tmp_path / "o"), "--param", "leg_tracker.bogus=1")
    assert res.returncode == 2
    assert "bogus" in res.stderr and "Traceback" not in res.stderr


def test_every_subcommand_has_help() -> None:
    for sub in ("run", "replay", "process", "batch", "demo"):
        res = walker_gait(sub, "--help")
        assert res.returncode == 0 and "usage" in res.stdout.lower(), sub


@pytest.mark.parametrize("module", ["walker_gait.cli", "walker_gait.bench.sweep"])
def test_entry_points_limit_blas_threads_unless_the_user_chose(module: str) -> None:
    """numpy's BLAS runs single-threaded in our processes (node children inherit it), the CLI's and the bench's run
    directly (``python -m walker_gait.bench.sweep``: two jobs' threads spun against each other); a user value wins."""
    import os

    code = (f"import {module}, os, numpy; "
            "print(os.environ['OMP_NUM_THREADS'], os.environ['OPENBLAS_NUM_THREADS'])")
    env = {k: v for k, v in os.environ.items() if k not in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS")}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
    assert out.stdout.split() == ["1", "1"]
    env["OMP_NUM_THREADS"] = "2"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
    assert out.stdout.split() == ["2", "1"]


def test_upside_down_camera_is_found_by_auto_flip_and_without_it_warns(tmp_path: Path) -> None:
    """A camera mounted upside down: the floor is not found around the default up direction; ``floor.auto_flip``
    (default) finds it around the half-turned one within a few frames, says so, records it in the metadata, and the
    steps are found.  With auto_flip off, `process` still writes every output and warns, naming the file and the
    parameter; with up_hint set by hand the floor is there from the first frame."""
    import numpy as np

    from walker_gait.synth import SessionSpec, generate_session, write_session

    spec = SessionSpec.preset("normal", duration=4.0, scale=0.5, cam_roll_deg=(180.0, 180.0))
    path = tmp_path / "upside_down.mcap"
    write_session(generate_session(spec, rng=np.random.default_rng(3)), path, fmt="mcap", encoding="16UC1")

    def steps(out: str) -> int:
        with open(tmp_path / out / "steps.csv", newline="") as fh:
            return len(list(csv.reader(fh))) - 1

    auto = walker_gait("process", str(path), "--out", str(tmp_path / "auto"), "--quiet")
    assert auto.returncode == 0, auto.stderr
    assert "no floor plane found" not in auto.stderr
    assert "upside down" in auto.stderr and str(path) in auto.stderr
    meta = json.loads((tmp_path / "auto" / "summary.json").read_text())["metadata"]
    assert meta["floor_up_hint"] == [0.0, 1.0, 0.0] and meta["frames_without_floor"] <= 10
    assert steps("auto") >= 3
    plain = walker_gait("process", str(path), "--out", str(tmp_path / "plain"), "--quiet",
                        "--param", "floor_segmentation.floor.auto_flip=false")
    assert plain.returncode == 0, plain.stderr
    assert "no floor plane found" in plain.stderr and str(path) in plain.stderr and "up_hint" in plain.stderr
    meta = json.loads((tmp_path / "plain" / "summary.json").read_text())["metadata"]
    assert meta["frames_without_floor"] > meta["frames_processed"] // 2 and meta["floor_up_hint"] == [0.0, -1.0, 0.0]
    fixed = walker_gait("process", str(path), "--out", str(tmp_path / "fixed"), "--quiet",
                        "--param", "floor_segmentation.floor.up_hint=[0.0,1.0,0.0]")
    assert fixed.returncode == 0, fixed.stderr
    assert "no floor plane found" not in fixed.stderr and "upside down" not in fixed.stderr
    meta = json.loads((tmp_path / "fixed" / "summary.json").read_text())["metadata"]
    assert meta["frames_without_floor"] == 0 and meta["floor_up_hint"] == [0.0, 1.0, 0.0]
    assert steps("fixed") >= 3


def test_recording_without_calibration_fails_clearly_and_camera_info_yaml_fixes_it(tmp_path: Path) -> None:
    """No CameraInfo in the recording: exit 2 before any output is written, naming the file and the option
    (the empty outputs were written first before); with ``--camera-info`` the results equal those of the
    original recording."""
    import warnings

    import numpy as np
    from rosbags.rosbag2 import Reader, StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    from walker_gait.io.bags import RecordingWarning, open_recording
    from walker_gait.io.camera_yaml import dump_camera_info_yaml
    from walker_gait.synth import SessionSpec, generate_session, write_session

    spec = SessionSpec.preset("normal", duration=2.0, scale=0.5)
    full = tmp_path / "full.mcap"
    write_session(generate_session(spec, rng=np.random.default_rng(3)), full, fmt="mcap", encoding="16UC1")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RecordingWarning)
        info = next(iter(open_recording(full).iter_frames())).camera_info
    assert info is not None
    dump_camera_info_yaml(info, tmp_path / "depth.yaml")
    stripped = tmp_path / "no_info"
    store = get_typestore(Stores.ROS2_JAZZY)
    with Reader(full) as reader, Writer(stripped, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        conns = {c.id: writer.add_connection(c.topic, c.msgtype, typestore=store)
                 for c in reader.connections if not c.msgtype.endswith("CameraInfo")}
        for c, t, raw in reader.messages():
            if c.id in conns:
                writer.write(conns[c.id], t, raw)

    res = walker_gait("process", str(stripped), "--out", str(tmp_path / "fail"), "--quiet")
    assert res.returncode == 2, res.stderr
    assert "no_info" in res.stderr and "--camera-info" in res.stderr and "Traceback" not in res.stderr
    assert "RecordingWarning" not in res.stderr  # warnings read like the CLI's own
    assert not list((tmp_path / "fail").glob("*.csv"))
    ok = walker_gait("process", str(stripped), "--out", str(tmp_path / "ok"), "--quiet",
                     "--camera-info", str(tmp_path / "depth.yaml"))
    assert ok.returncode == 0, ok.stderr
    ref = walker_gait("process", str(full), "--out", str(tmp_path / "ref"), "--quiet")
    assert ref.returncode == 0, ref.stderr
    assert (tmp_path / "ok" / "joints.csv").read_bytes() == (tmp_path / "ref" / "joints.csv").read_bytes()


def test_the_live_demo_says_when_the_machine_was_too_slow_for_it() -> None:
    from walker_gait.demo import too_slow_note

    log = ["[ERROR] [1.0] [leg_tracker]: frame stamped 0.767 s dropped: ... (frame skipped; ...)",
           "[WARN] [2.0] [leg_tracker]: cannot keep up with its input: 104 ms of work on each frame it took, ..."]
    note = too_slow_note(log)
    assert note is not None and "too slow" in note and log[1] in note and "make demo" in note
    assert too_slow_note(log[:1]) is None and too_slow_note([]) is None
