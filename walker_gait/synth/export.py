"""Write a :class:`~walker_gait.synth.session.Session` as a ROS recording + ground-truth JSON.

Topics
------
``/camera/depth/image_raw``   ``sensor_msgs/Image``, one per frame, ``frame_id =
                              camera_depth_optical_frame``, encoding per ``encoding``:
                              ``"16UC1"`` uint16 millimetres (0 = invalid), ``"32FC1"`` float32
                              metres (NaN = invalid), ``"kinect_raw"`` raw 11-bit Kinect disparity
                              in a ``16UC1`` image (2047 = invalid; metres via eq. (1) of the seed
                              paper).  ``16UC1`` cannot say which of the two it is, so for
                              ``kinect_raw`` the recording says so in rosbag2 ``custom_data``
                              (``walker_gait.depth_format: kinect_raw``) and in the GT JSON
                              (``depth_format``); readers should use ``depth_format="auto"`` or be
                              told explicitly.
``/camera/depth/camera_info`` ``sensor_msgs/CameraInfo``, plumb_bob, zero distortion, same stamp.
``/camera/rgb/image_raw``     small ``rgb8`` image (160x120 at ~5 Hz, a shaded rendering) - an
                              unrelated Image topic so depth-topic auto-detection is exercised.

Receive times and header stamps are the session time (``stamp_offset`` added, default 0).
The ground truth goes to ``<name>.gt.json`` next to the recording (``<name>`` = output path
without its ``.mcap`` / ``.db3`` / ``.bag`` suffix), written atomically.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from walker_gait.core.types import LEG_POINTS, EventKind, Side
from walker_gait.io.bagwriter import BagFormat, BagWriter
from walker_gait.synth.session import Session
from walker_gait.synth.sensor import KINECT_INVALID

DEPTH_TOPIC = "/camera/depth/image_raw"
INFO_TOPIC = "/camera/depth/camera_info"
RGB_TOPIC = "/camera/rgb/image_raw"
DEPTH_FRAME = "camera_depth_optical_frame"
ENCODINGS: tuple[str, ...] = ("16UC1", "32FC1", "kinect_raw")
GT_VERSION = 1


def gt_path_for(path: str | os.PathLike[str]) -> Path:
    """``<name>.gt.json`` next to the recording ``path``."""
    p = Path(path)
    stem = p.name
    for suf in (".mcap", ".db3", ".bag"):
        if stem.endswith(suf):
            stem = stem[: -len(suf)]
            break
    return p.with_name(f"{stem}.gt.json")


def _stamp(ts: Any, t: float, ros1: bool, seq: int) -> Any:
    sec = int(math.floor(t))
    nsec = int(round((t - sec) * 1e9))
    if nsec >= 1_000_000_000:
        sec, nsec = sec + 1, nsec - 1_000_000_000
    time_cls = ts.types["builtin_interfaces/msg/Time"]
    stamp = time_cls(sec=sec, nanosec=nsec)
    header_cls = ts.types["std_msgs/msg/Header"]
    if ros1:
        return header_cls(seq=seq, stamp=stamp, frame_id=DEPTH_FRAME)
    return header_cls(stamp=stamp, frame_id=DEPTH_FRAME)


def depth_payload(session: Session, i: int, encoding: str) -> tuple[str, int, np.ndarray]:
    """(ROS encoding, bytes per row, flat uint8 data) of frame ``i`` in ``encoding``."""
    intr = session.intrinsics
    if encoding == "16UC1":
        arr = session.depth_mm(i).astype("<u2")
        return "16UC1", intr.width * 2, arr.view(np.uint8).reshape(-1)
    if encoding == "32FC1":
        arr = session.depth_m(i).astype("<f4")
        return "32FC1", intr.width * 4, arr.view(np.uint8).reshape(-1)
    if encoding == "kinect_raw":
        if session.depth_format != "kinect_raw":
            # non-Kinect sensor: convert its metric output to equivalent Kinect disparity
            z = session.depth_m(i).astype(np.float64)
            with np.errstate(divide="ignore", invalid="ignore"):
                d = np.rint((1.0 / z - 3.33) / -0.00307)
            raw = np.where(np.isfinite(d) & (d >= 0) & (d < KINECT_INVALID), d, KINECT_INVALID).astype("<u2")
        else:
            raw = session.frame(i).data.astype("<u2")
        return "16UC1", intr.width * 2, raw.view(np.uint8).reshape(-1)
    msg = f"unknown depth encoding {encoding!r}; expected one of {', '.join(ENCODINGS)}"
    raise ValueError(msg)


_MAT_RGB = np.array(
    [[0, 0, 0], [150, 150, 140], [220, 180, 150], [60, 70, 110], [40, 40, 40], [170, 170, 180], [120, 140, 90]],
    dtype=np.float32,
)


def rgb_preview(session: Session, i: int, *, width: int = 160) -> np.ndarray:
    """Small shaded RGB rendering (uint8 HxWx3) of frame ``i`` from material ids and depth."""
    fr = session.frame(i)
    mat = np.clip(fr.material.astype(np.int64), 0, len(_MAT_RGB) - 1)
    col = _MAT_RGB[mat]
    z = np.where(np.isfinite(fr.ideal_depth), fr.ideal_depth, 5.0)
    shade = np.clip(1.2 - 0.25 * z, 0.3, 1.0)[..., None]
    img = (col * shade).astype(np.uint8)
    h = int(round(img.shape[0] * width / img.shape[1]))
    return cv2.resize(img, (width, h), interpolation=cv2.INTER_AREA)


def write_session(
    session: Session,
    path: str | os.PathLike[str],
    *,
    fmt: BagFormat = "mcap",
    encoding: str = "16UC1",
    rgb: bool | None = None,
    rgb_rate: float = 5.0,
    stamp_offset: float = 0.0,
    overwrite: bool = False,
    compress: bool | None = None,
    write_gt: bool = True,
    progress: Callable[[int, int], None] | None = None,
) -> Path:
    """Render all frames of ``session`` and write the recording (+ ``.gt.json``); returns the bag path.

    ``compress`` defaults to True for MCAP (zstd chunks, ~5x smaller) and False otherwise.
    """
    if encoding not in ENCODINGS:
        msg = f"unknown depth encoding {encoding!r}; expected one of {', '.join(ENCODINGS)}"
        raise ValueError(msg)
    rgb = session.spec.rgb_topic if rgb is None else rgb
    ros1 = fmt == "ros1"
    custom = {"walker_gait.depth_format": "kinect_raw" if encoding == "kinect_raw" else encoding, "walker_gait.synthetic": "true"}
    if compress is None:
        compress = fmt == "mcap"
    with BagWriter(path, fmt=fmt, overwrite=overwrite, custom_data=custom, compress=compress) as bag:
        ts = bag.typestore
        img_cls = ts.types["sensor_msgs/msg/Image"]
        info_cls = ts.types["sensor_msgs/msg/CameraInfo"]
        roi_cls = ts.types["sensor_msgs/msg/RegionOfInterest"]
        h_depth = bag.add_topic(DEPTH_TOPIC, "sensor_msgs/msg/Image")
        h_info = bag.add_topic(INFO_TOPIC, "sensor_msgs/msg/CameraInfo")
        h_rgb = bag.add_topic(RGB_TOPIC, "sensor_msgs/msg/Image") if rgb else None
        ci = session.camera_info()
        intr = session.intrinsics
        next_rgb = 0.0
        n = len(session)
        visible = np.zeros((n, 2), dtype=np.int64)
        for i in range(n):
            t = float(session.stamps[i]) + stamp_offset
            t_ns = int(round(t * 1e9))
            enc, step, data = depth_payload(session, i, encoding)
            fr = session.frame(i)
            valid = np.isfinite(session.depth_m(i))
            visible[i] = [np.count_nonzero(valid & (fr.side == 0)), np.count_nonzero(valid & (fr.side == 1))]
            hdr = _stamp(ts, t, ros1, i)
            img = img_cls(header=hdr, height=intr.height, width=intr.width, encoding=enc, is_bigendian=0, step=step, data=data)
            bag.write(h_depth, t_ns, img)
            roi = roi_cls(x_offset=0, y_offset=0, height=0, width=0, do_rectify=False)
            kwargs: dict[str, Any] = {
                "header": _stamp(ts, t, ros1, i),
                "height": intr.height,
                "width": intr.width,
                "distortion_model": ci["distortion_model"],
                "binning_x": 0,
                "binning_y": 0,
                "roi": roi,
            }
            arrays = {k: np.asarray(ci[k], dtype=np.float64) for k in ("d", "k", "r", "p")}
            if ros1:
                kwargs.update({"D": arrays["d"], "K": arrays["k"], "R": arrays["r"], "P": arrays["p"]})
            else:
                kwargs.update(arrays)
            bag.write(h_info, t_ns, info_cls(**kwargs))
            if h_rgb is not None and t + 1e-9 >= next_rgb:
                next_rgb = t + 1.0 / rgb_rate
                rgb_img = rgb_preview(session, i)
                hdr_rgb = _stamp(ts, t, ros1, i)
                hdr_rgb.frame_id = "camera_rgb_optical_frame"
                bag.write(
                    h_rgb,
                    t_ns,
                    img_cls(
                        header=hdr_rgb,
                        height=rgb_img.shape[0],
                        width=rgb_img.shape[1],
                        encoding="rgb8",
                        is_bigendian=0,
                        step=rgb_img.shape[1] * 3,
                        data=np.ascontiguousarray(rgb_img).reshape(-1),
                    ),
                )
            if progress is not None:
                progress(i + 1, n)
    if write_gt:
        write_ground_truth(
            session,
            gt_path_for(path),
            encoding=encoding,
            stamp_offset=stamp_offset,
            bag_path=Path(path),
            fmt=fmt,
            visible_pixels=visible,
        )
    return Path(path)


def _f(x: float) -> float | None:
    return None if not np.isfinite(x) else float(x)


def _arr(a: np.ndarray, nd: int = 5) -> Any:
    """Nested lists rounded to ``nd`` decimals, non-finite values as ``None`` (strict JSON)."""
    a = np.asarray(a, dtype=np.float64)
    o = np.round(a, nd).astype(object)
    o[~np.isfinite(a)] = None
    return o.tolist()


def ground_truth_dict(
    session: Session,
    *,
    encoding: str = "16UC1",
    stamp_offset: float = 0.0,
    visible_pixels: np.ndarray | None = None,
) -> dict[str, Any]:
    """JSON-serialisable ground truth (see :func:`write_ground_truth`).

    ``visible_pixels`` (T, 2): per frame and leg, pixels with valid depth whose surface belongs
    to that leg (trousers/skin/shoe) - 0 when the user is out of view or fully hidden.
    """
    p = session.params
    k = session.intrinsics
    fl = session.floor
    r = session.camera_pose_at(np.array([0.0]))[0][0]
    events = []
    for e in session.events:
        pc = session.world_to_camera(e.position_world[None, :], np.array([e.stamp]))[0]
        events.append(
            {
                "stamp": e.stamp + stamp_offset,
                "side": Side(e.side).label,
                "kind": EventKind(e.kind).label,
                "position_world": _arr(e.position_world),
                "position_camera": _arr(pc),
                "bout": e.bout,
            }
        )
    steps = [
        {
            "stamp": s.stamp + stamp_offset,
            "side": Side(s.side).label,
            "index": s.index,
            "step_length": s.step_length,
            "step_width": s.step_width,
            "step_time": _f(s.step_time),
            "stride_length": _f(s.stride_length),
            "stride_time": _f(s.stride_time),
            "stance_time": _f(s.stance_time),
            "swing_time": _f(s.swing_time),
            "single_support_time": _f(s.single_support_time),
            "double_support_time": _f(s.double_support_time),
            "heel_world": _arr(s.heel_world),
            "prev_opposite_heel_world": _arr(s.prev_opposite_heel_world),
            "bout": s.bout,
        }
        for s in session.steps
    ]
    return {
        "version": GT_VERSION,
        "generator": "walker_gait.synth",
        "scenario": session.spec.scenario,
        "spec": _jsonable(session.spec.to_dict()),
        "resolved": {
            "camera": p.camera_name,
            "sensor": _jsonable(dict(vars(p.sensor))),
            "mount": {"height": p.mount.height, "pitch": p.mount.pitch, "roll": p.mount.roll, "yaw": p.mount.yaw, "lateral": p.mount.lateral},
            "gait": _jsonable(dict(vars(p.gait))),
            "dims": _jsonable(dict(vars(p.dims))),
            "shape": _jsonable(dict(vars(p.shape))),
            "user_distance": p.user_distance,
            "walker_lag": p.walker_lag,
            "programme": [_jsonable(dict(vars(ph))) for ph in p.programme],
        },
        "depth_encoding": encoding,
        "depth_format": "kinect_raw" if encoding == "kinect_raw" else ("mm" if encoding == "16UC1" else "m"),
        "frame_id": DEPTH_FRAME,
        "intrinsics": {"width": k.width, "height": k.height, "fx": k.fx, "fy": k.fy, "cx": k.cx, "cy": k.cy},
        "camera_info": session.camera_info(),
        "floor": {"normal": _arr(fl.normal, 9), "offset": fl.offset, "frame": "camera"},
        "world_from_camera_rotation": _arr(r, 9),
        "conventions": {
            "world": "X progression, Y user's left, Z up, floor z=0, metres",
            "camera": "optical frame: x right, y down, z forward; metres",
            "leg_points": "[frame][side LEFT=0, RIGHT=1][hip, knee, ankle, heel, toe][xyz] camera frame",
            "heel": "posterior-most point of the shoe at sole level",
            "toe": "anterior tip of the shoe at sole level",
            "steps": "GAITRite definitions from planted heel positions in world coordinates (synth/groundtruth.py)",
        },
        "leg_point_names": list(LEG_POINTS),
        "frames": {
            "stamp": _arr(session.stamps + stamp_offset, 9),
            "leg_points": _arr(session.leg_points),
            "leg_points_world": _arr(session.body.leg_points()),
            "stance": session.body.stance.astype(int).tolist(),
            "joint_angles": _arr(session.body.angles),
            "walker_pose": _arr(session.walker_pose),
            "camera_position_world": _arr(session.world_from_camera[:, :3, 3]),
            # a walker rocking on its wheels (spec.vibration_deg): its pitch and roll, and the floor in the camera
            # frame, per frame ("floor" above is the still walker's); None for a rigid walker
            "walker_tilt_rad": None if session.walker_tilt is None else _arr(session.walker_tilt, 9),
            "floor_per_frame": None if session.walker_tilt is None else [
                {"normal": _arr(f.normal, 9), "offset": f.offset} for f in (session.floor_at(i) for i in range(len(session)))],
            "visible_pixels": None if visible_pixels is None else np.asarray(visible_pixels).astype(int).tolist(),
        },
        "events": events,
        "steps": steps,
    }


def _jsonable(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, (np.floating, float)):
        return float(obj) if np.isfinite(obj) else None
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist())
    return obj


def write_ground_truth(
    session: Session,
    path: str | os.PathLike[str],
    *,
    encoding: str = "16UC1",
    stamp_offset: float = 0.0,
    bag_path: Path | None = None,
    fmt: str | None = None,
    visible_pixels: np.ndarray | None = None,
) -> Path:
    """Write the ground-truth JSON atomically (tmp file + ``os.replace``)."""
    out = Path(path)
    d = ground_truth_dict(session, encoding=encoding, stamp_offset=stamp_offset, visible_pixels=visible_pixels)
    if bag_path is not None:
        d["recording"] = {"path": bag_path.name, "format": fmt}
    tmp = out.with_name(f".{out.name}.tmp")
    with open(tmp, "w", encoding="utf-8") as fh:
        json.dump(d, fh, allow_nan=False, separators=(",", ":"))
    os.replace(tmp, out)
    return out

