"""Every node's parameters, in one place: names, defaults, descriptions.

Node-level parameters are listed here; the core config dataclasses contribute the rest
(``floor_segmentation`` ← ``SegmenterConfig``, ``leg_tracker`` ← ``TrackerConfig`` of the chosen
preset, ``gait_analyzer`` ← ``GaitConfig``).  ``python -m walker_gait.paramspec`` prints the
README's parameter table; the test suite checks ``config/walker_gait.yaml`` against this spec.
"""

from __future__ import annotations

import sys
from typing import Any

from walker_gait.config import ParameterError, build, describe

#: Camera parameters several nodes declare; ``walker-gait run --param depth_to_cloud.NAME=VALUE`` and the
#: offline pipeline apply a depth_to_cloud value to the other nodes too, so the stages never disagree.
CAMERA_PARAMS: dict[str, tuple[str, ...]] = {
    "depth_format": ("floor_segmentation",),
    "use_rectified": ("floor_segmentation", "leg_tracker"),
    "input_reliability": ("floor_segmentation",),
}

NODE_PARAMS: dict[str, list[tuple[str, Any, str]]] = {
    "depth_to_cloud": [
        ("depth_format", "auto", "`auto`: 16UC1/mono16 millimetres, 32FC1 metres; `kinect_raw`: 16-bit raw Kinect "
                                 "v1 disparity, metric depth by eq. (1) of the seed paper, 2047 = invalid"),
        ("use_rectified", True, "true: intrinsics from P (rectified/registered depth); false: from K and D, and the "
                                "image is undistorted (plumb_bob / rational_polynomial, OpenCV, nearest neighbour)"),
        ("input_reliability", "best_effort", "QoS reliability of the depth/CameraInfo subscriptions: `best_effort` "
                                             "(matches every driver) or `reliable` (lossless from reliable sources "
                                             "such as `walker-gait replay`)"),
    ],
    "floor_segmentation": [
        ("input", "depth", "`depth`: decode `depth/image_raw` + `depth/camera_info` itself (same core as "
                           "depth_to_cloud; cheaper than receiving the 3.7 MB organised cloud); `points`: "
                           "subscribe to depth_to_cloud's `points`"),
        ("seed", 0, "seed of the RANSAC random generator (numpy Generator)"),
        ("use_rectified", True, "as depth_to_cloud.use_rectified (must match it)"),
        ("depth_format", "auto", "with `input: depth`: as depth_to_cloud.depth_format (must match it)"),
        ("input_reliability", "best_effort", "with `input: depth`: as depth_to_cloud.input_reliability"),
    ],
    "leg_tracker": [
        ("preset", "default", "`default` (real time: partitioned + annealed sampling, low-res 2D cue), `accurate` "
                              "(offline: the default with 288 particles instead of 192, 1.5x its time, step lengths ~10 % "
                              "better on average over the synthetic sweeps, not in every scenario; `walker-gait process` "
                              "also tracks each direction twice with it, `--tracker-runs`) or `paper` (the seed's 5000 "
                              "particles, full-res 2D cue); the fields below "
                              "override the preset"),
        ("mounting", "facing_user", "`facing_user`: camera looks back at the user, whose left leg is on the "
                                    "image's right (+x); `facing_forward` flips left/right"),
        ("use_rectified", True, "as depth_to_cloud.use_rectified (must match it)"),
        ("seed", 0, "seed of the particle filter's random generator"),
        ("pelvis_window_s", 1.0, "s; the published hips and knees, which the camera does not see, with the pelvis "
                                 "over the ankles (their midpoint fitted over the last this long, a few cm ahead of "
                                 "it: more walking than standing; facing the feet's heading) and the joint angles "
                                 "solved again so that the tracked knees, ankles, heels and toes stay, the hips the "
                                 "typical adult's 0.18 m apart, the thighs and calves the typical adult's (or of "
                                 "`leg_length_m`), each knee moved along its "
                                 "tracked calf to it; the heel of a foot whose shoe the track has shown cleanly "
                                 "(or that is under a trouser hem, the calves a tube of loose fabric: then the shoe "
                                 "at least the typical adult's 0.26 m, the hem hides its back) "
                                 "behind its toe at the median foot length so far, at the pitch and heading its "
                                 "shoe shows (reported a quarter of the way back to the tracker's), and its ankle "
                                 "halfway to where the leg model puts it in that foot; each foot whose heel and toe "
                                 "are both within 2 cm of the floor on it, and no heel or toe under it "
                                 "(the tracker's heels, ankles and toes in `leg_track`'s `heel_tracked`, "
                                 "`ankle_tracked` and `toe_tracked`, which the gait analyzer reads; "
                                 "`walker_gait.core.pelvis`; 0 = as tracked, the shoes not measured)"),
        ("leg_length_m", 0.0, "m; the user's measured leg length (the hip joint centre's standing height above the "
                              "floor: floor to greater trochanter; only the stature known: about 0.53 of it): with the "
                              "pelvis placed, the published thighs and "
                              "calves have that length, each knee moved along its tracked calf (the camera measures "
                              "neither; `walker_gait.core.pelvis.with_leg_length`; 0 = not measured: the typical "
                              "adult's, thigh 0.42 m and calf 0.42 m (a 1.70 m stature), `pelvis.TYPICAL_THIGH_CALF_M`; "
                              "may be set while the node runs, for the next user: `ros2 param set /leg_tracker "
                              "leg_length_m 0.91`; the other parameters are read at start)"),
        ("bridge_hidden_s", 1.0, "s; `leg_track_bridged` (LegTrack): `leg_track` with each stretch in which a foot was "
                                 "hidden (its visibility under `hide_below`; the tracker holds its pose while the "
                                 "real foot rolls off the floor and swings; both feet in a frame the tracker held, "
                                 "DEGRADED at confidence 0) bridged as `walker-gait process` bridges "
                                 "it, once the foot has been seen again for 6 frames (or fewer and hidden again, if it "
                                 "stood when last seen), if that is within this long "
                                 "of its last frame seen (a foot planted when last seen rolled over its toe as the "
                                 "floor carries it; one last seen swinging and seen again standing landed and "
                                 "carried back with the floor; else cubic curves between both ends: "
                                 "`walker_gait.core.smoothing.LiveBridge`); its frames are held until then, every "
                                 "frame published once, in order (latency 0 while both feet are seen, up to this "
                                 "long + 6 frames for a hidden foot's frames; frames still held when the input pauses "
                                 "for longer than this, wall clock, come out as tracked; the number held is "
                                 "`bridge_held` on /diagnostics); 0 = not published"),
        ("input_depth", 10, "queue depth of the three synchronised inputs: it absorbs bursts in which the tracker "
                            "is slower than the camera; small = track the newest frames (low latency, frames "
                            "skipped in every burst), large = work through the queued frames (none skipped, more "
                            "latency, bounded by depth / rate); measured with the default preset (192 particles, two annealing "
                            "layers then) on a 30 Hz replay of a 10 s 640x480 session on the 2-core machine (compiled "
                            "likelihood kernels): 2 / 5 / 10 → 82 / 99 / 99 % of frames tracked, median latency 37 / 56 "
                            "/ 52 ms (host load varies between runs: `make bench`'s run at 10 gave 55 ms with two "
                            "layers, 61 ms with three; one or two frames in 300 are occasionally lost between "
                            "floor_segmentation and leg_tracker even at 10); on a host too slow for the tracker to "
                            "keep up (50-70 ms a frame beside the other nodes) 2 / 10 → 125-181 / 139-165 of 300 "
                            "frames tracked, median latency 125-175 / 398-413 ms"),
        ("kernel_threads", 0, "threads the likelihood's compiled kernels spread the particles over (the 3D cue's "
                              "terms, the 2D cue's renderer and pixel costs): the same tracks bit for bit; 0 = by the "
                              "cores the node may use, 2 with four or more, else 1. On the 2-core machine those kernels "
                              "alone take a third to a sixth less time with 2, but the live graph keeps both cores "
                              "busy: over eight alternated 30 Hz replays of 300 frames the tracker published 133-229 "
                              "with 1, 132-234 with 2 (`walker_gait.core.likelihood.Workspace`)"),
    ],
    "gait_analyzer": [
        ("summary_window", 10.0, "s, length of the rolling window of gait_summary/rolling"),
        ("use_odometry", False, "subscribe to `odom` (nav_msgs/Odometry of the walker) for the line of progression"),
    ],
    "bag_replay": [
        ("input", "", "recording to play (.mcap, rosbag2 folder, .db3, ROS 1 .bag); empty = idle"),
        ("rate", 1.0, "playback rate multiplier"),
        ("loop", False, "restart at the end"),
        ("publish_clock", True, "publish /clock (rosgraph_msgs/Clock) with the recording's time"),
        ("start_delay", 1.0, "s to wait after start so subscribers can connect"),
    ],
}


def core_config(node: str, preset: str = "default") -> Any | None:
    """Default core config object of ``node`` (None if it has none)."""
    if node == "floor_segmentation":
        from walker_gait.core.segmentation import SegmenterConfig

        return SegmenterConfig()
    if node == "leg_tracker":
        from walker_gait.core.tracker import preset as tracker_preset

        return tracker_preset(preset)
    if node == "gait_analyzer":
        from walker_gait.core.gait import GaitConfig

        return GaitConfig()
    return None


def all_params(node: str) -> list[tuple[str, Any, str]]:
    params = list(NODE_PARAMS[node])
    cfg = core_config(node)
    if cfg is not None:
        params += list(describe(type(cfg)))
        if node == "leg_tracker":  # defaults are the preset's, not the dataclass's
            from walker_gait.config import flatten

            values = flatten(cfg)
            params = [(n, values.get(n, d), doc) for n, d, doc in params]
    return params


def validate_node_params(node: str, values: dict[str, Any]) -> None:
    """Raise :class:`ParameterError` if ``values`` has unknown names or bad values for ``node``."""
    if node not in NODE_PARAMS:
        raise ParameterError(f"unknown node {node!r}; nodes: {', '.join(NODE_PARAMS)}")
    own = {name for name, _, _ in NODE_PARAMS[node]}
    rest = {k: v for k, v in values.items() if k not in own}
    preset = str(values.get("preset", "default"))
    cfg = core_config(node, preset)
    if cfg is None:
        if rest:
            raise ParameterError(f"unknown {node} parameter(s): {sorted(rest)}")
        return
    build(type(cfg), rest, base=cfg)


def _fmt(value: Any) -> str:
    if isinstance(value, str):
        return f"`{value!r}`" if value == "" else f"`{value}`"
    if isinstance(value, bool):
        return f"`{str(value).lower()}`"
    return f"`{value}`"


def markdown_table() -> str:
    lines = ["| node | parameter | default | meaning |", "|---|---|---|---|"]
    for node in NODE_PARAMS:
        for name, default, doc in all_params(node):
            lines.append(f"| {node} | `{name}` | {_fmt(default)} | {doc.replace('|', '/') } |")
    return "\n".join(lines)


if __name__ == "__main__":
    sys.stdout.write(markdown_table() + "\n")
