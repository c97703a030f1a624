"""ROS message construction and parsing without rclpy.

One set of builders serves both the live nodes and the offline pipeline: messages are
``rosbags`` dataclasses from a typestore in which ``walker_gait_msgs`` is registered from the
``.msg`` text of ``msg_defs/``.  Live nodes publish their CDR bytes (rclpy publishers accept
serialized bytes) and subscribe with ``raw=True``; the offline pipeline writes the very same
bytes into ``tracked.mcap``.  The wire format is therefore identical by construction, which
the test suite checks against ``rclpy.serialization``.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Sequence
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from walker_gait.core.types import (
    ANKLE,
    HEEL,
    JOINT_NAMES,
    LEG_POINTS,
    SEGMENTS,
    TOE,
    CameraIntrinsics,
    FloorPlane,
    GaitEvent,
    LegPose,
    Side,
    Step,
    TrackStatus,
)

MSG_PACKAGE = "walker_gait_msgs"
MSG_NAMES = ("GaitEvent", "Step", "GaitSummary", "LegTrack", "FloorPlane")

# Topic types (ROS 2 names)
IMAGE = "sensor_msgs/msg/Image"
COMPRESSED_IMAGE = "sensor_msgs/msg/CompressedImage"
CAMERA_INFO = "sensor_msgs/msg/CameraInfo"
POINT_CLOUD2 = "sensor_msgs/msg/PointCloud2"
JOINT_STATE = "sensor_msgs/msg/JointState"
MARKER_ARRAY = "visualization_msgs/msg/MarkerArray"
DIAGNOSTIC_ARRAY = "diagnostic_msgs/msg/DiagnosticArray"
ODOMETRY = "nav_msgs/msg/Odometry"
CLOCK = "rosgraph_msgs/msg/Clock"
GAIT_EVENT = f"{MSG_PACKAGE}/msg/GaitEvent"
STEP = f"{MSG_PACKAGE}/msg/Step"
GAIT_SUMMARY = f"{MSG_PACKAGE}/msg/GaitSummary"
LEG_TRACK = f"{MSG_PACKAGE}/msg/LegTrack"
FLOOR_PLANE = f"{MSG_PACKAGE}/msg/FloorPlane"


def msg_dir_candidates() -> list[Path]:
    """Where the ``walker_gait_msgs`` ``.msg`` files may be, most specific first."""
    cands = [Path(__file__).resolve().parent.parent / "msg_defs" / "msg"]  # source tree / editable
    for prefix in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep):
        if prefix:
            cands.append(Path(prefix) / "share" / MSG_PACKAGE / "msg")
    cands.append(Path(sys.prefix) / "share" / MSG_PACKAGE / "msg")  # venv install
    return cands


def find_msg_dir() -> Path:
    for cand in msg_dir_candidates():
        if all((cand / f"{name}.msg").is_file() for name in MSG_NAMES):
            return cand
    tried = ", ".join(str(c) for c in msg_dir_candidates())
    msg = f"cannot find the {MSG_PACKAGE} .msg files (tried {tried})"
    raise FileNotFoundError(msg)


@lru_cache(maxsize=1)
def typestore() -> Any:
    """ROS 2 Jazzy typestore with ``walker_gait_msgs`` registered from its ``.msg`` text."""
    store = get_typestore(Stores.ROS2_JAZZY)
    msg_dir = find_msg_dir()
    types: dict[str, Any] = {}
    for name in MSG_NAMES:
        text = (msg_dir / f"{name}.msg").read_text(encoding="utf-8")
        types.update(get_types_from_msg(text, f"{MSG_PACKAGE}/msg/{name}"))
    store.register(types)
    return store


def msg_class(typename: str) -> Any:
    return typestore().types[typename]


def serialize(msg: Any) -> bytes:
    """CDR bytes of a typestore message (what rclpy would put on the wire)."""
    return bytes(typestore().serialize_cdr(msg, msg.__msgtype__))


def deserialize(data: bytes | memoryview, typename: str) -> Any:
    return typestore().deserialize_cdr(data, typename)


# ---------------------------------------------------------------------------------------- headers


def stamp_to_ns(stamp: Any) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def stamp_to_s(stamp: Any) -> float:
    """Seconds of a ``builtin_interfaces/Time``, as the recording readers compute them (integer nanoseconds / 1e9):
    the live nodes and the offline pipeline must see the very same float for a frame, or a window edge that falls
    on a frame's stamp (the gait analyzer's fits) can take that frame in one and leave it out in the other."""
    return (int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)) / 1e9


def make_time(t: float | int, *, ns: bool = False) -> Any:
    """``builtin_interfaces/Time`` from seconds (float) or, with ``ns=True``, integer nanoseconds."""
    total_ns = int(t) if ns else round(float(t) * 1e9)
    total_ns = max(total_ns, 0)
    return msg_class("builtin_interfaces/msg/Time")(sec=total_ns // 1_000_000_000, nanosec=total_ns % 1_000_000_000)


def make_header(stamp: float | Any, frame_id: str) -> Any:
    """``std_msgs/Header`` from seconds or an existing ``Time``."""
    time = stamp if hasattr(stamp, "nanosec") else make_time(stamp)
    return msg_class("std_msgs/msg/Header")(stamp=time, frame_id=frame_id)


def _point(p: Sequence[float] | NDArray[Any]) -> Any:
    x, y, z = (float(v) if np.isfinite(v) else float("nan") for v in p)
    return msg_class("geometry_msgs/msg/Point")(x=x, y=y, z=z)


def _xyz(p: Any) -> list[float]:
    return [p.x, p.y, p.z]


# ----------------------------------------------------------------------------------- camera input


def intrinsics_fields(info: Any) -> dict[str, Any]:
    """The CameraInfo fields the core needs, as plain Python values."""
    return {
        "width": int(info.width),
        "height": int(info.height),
        "k": [float(v) for v in info.k],
        "d": [float(v) for v in info.d],
        "p": [float(v) for v in info.p],
        "distortion_model": str(info.distortion_model),
    }


def make_camera_info(intr: CameraIntrinsics, header: Any, *, d: Sequence[float] = (0.0,) * 5) -> Any:
    """A plumb_bob ``CameraInfo`` for an undistorted pinhole camera (tests, synthetic sessions)."""
    k = np.array([intr.fx, 0, intr.cx, 0, intr.fy, intr.cy, 0, 0, 1], dtype=np.float64)
    p = np.array([intr.fx, 0, intr.cx, 0, 0, intr.fy, intr.cy, 0, 0, 0, 1, 0], dtype=np.float64)
    roi = msg_class("sensor_msgs/msg/RegionOfInterest")(x_offset=0, y_offset=0, height=0, width=0, do_rectify=False)
    return msg_class(CAMERA_INFO)(
        header=header,
        height=intr.height,
        width=intr.width,
        distortion_model="plumb_bob",
        d=np.asarray(d, dtype=np.float64),
        k=k,
        r=np.eye(3).reshape(-1),
        p=p,
        binning_x=0,
        binning_y=0,
        roi=roi,
    )


def make_image(array: NDArray[Any], header: Any, *, encoding: str) -> Any:
    """``sensor_msgs/Image`` from a 2-D array (mono8/16UC1/32FC1) or HxWx3 uint8 (rgb8)."""
    arr = np.ascontiguousarray(array)
    height, width = arr.shape[:2]
    step = arr.strides[0]
    return msg_class(IMAGE)(
        header=header,
        height=height,
        width=width,
        encoding=encoding,
        is_bigendian=int(sys.byteorder == "big" and arr.dtype.itemsize > 1),
        step=step,
        data=np.frombuffer(arr.tobytes(), dtype=np.uint8),
    )


MASK_FOREGROUND = 255
"""``foreground/mask`` value of a foreground (leg) pixel."""
MASK_NO_DEPTH = 64
"""``foreground/mask`` value of a pixel without a depth measurement (nearer than the sensor's near limit, IR
shadow, dropouts): unknown to the tracker, neither foreground nor background (0)."""


def make_foreground_mask(mask: NDArray[np.bool_], no_depth: NDArray[np.bool_] | None, header: Any) -> Any:
    """``foreground/mask`` image: ``MASK_FOREGROUND`` on ``mask``, ``MASK_NO_DEPTH`` on ``no_depth``, 0 elsewhere."""
    img = np.zeros(mask.shape, dtype=np.uint8)
    if no_depth is not None:
        img[no_depth] = MASK_NO_DEPTH
    img[mask] = MASK_FOREGROUND
    return make_image(img, header, encoding="mono8")


def _mono8_rows(msg: Any) -> NDArray[np.uint8]:
    if msg.encoding != "mono8":
        raise ValueError(f"mask image must be mono8, got {msg.encoding!r}")
    data = np.asarray(msg.data, dtype=np.uint8)
    return data[: msg.height * msg.step].reshape(msg.height, msg.step)[:, : msg.width]


def image_to_mask(msg: Any) -> NDArray[np.bool_]:
    """mono8 ``foreground/mask`` ``Image`` → HxW bool foreground (values of 128 and more)."""
    return _mono8_rows(msg) >= 128


def image_to_no_depth(msg: Any) -> NDArray[np.bool_]:
    """mono8 ``foreground/mask`` ``Image`` → HxW bool, pixels marked ``MASK_NO_DEPTH``."""
    return _mono8_rows(msg) == MASK_NO_DEPTH


# ----------------------------------------------------------------------------------- point clouds


def _pc2_fields() -> list[Any]:
    field_cls = msg_class("sensor_msgs/msg/PointField")
    return [field_cls(name=n, offset=4 * i, datatype=7, count=1) for i, n in enumerate("xyz")]  # FLOAT32


def make_pointcloud2(points: NDArray[Any], header: Any) -> Any:
    """``PointCloud2`` with float32 x, y, z from an Nx3 (dense, unorganised) or HxWx3 (organised) array."""
    pts = np.ascontiguousarray(points, dtype=np.float32)
    if pts.ndim == 2:
        height, width = 1, pts.shape[0]
        dense = bool(np.isfinite(pts).all())
    elif pts.ndim == 3:
        height, width = pts.shape[:2]
        dense = bool(np.isfinite(pts).all())
    else:
        raise ValueError(f"points must be Nx3 or HxWx3, got shape {pts.shape}")
    return msg_class(POINT_CLOUD2)(
        header=header,
        height=height,
        width=width,
        fields=_pc2_fields(),
        is_bigendian=sys.byteorder == "big",
        point_step=12,
        row_step=12 * width,
        data=np.frombuffer(pts.tobytes(), dtype=np.uint8),
        is_dense=dense,
    )


def read_pointcloud2(msg: Any) -> NDArray[np.float32]:
    """x, y, z float32 of a ``PointCloud2`` as HxWx3 (organised) or Nx3 (height 1)."""
    offsets = {f.name: (f.offset, f.datatype) for f in msg.fields}
    for axis in "xyz":
        if axis not in offsets or offsets[axis][1] != 7:
            raise ValueError(f"PointCloud2 needs float32 field {axis!r}")
    order = ">" if msg.is_bigendian else "<"
    dtype = np.dtype(
        {
            "names": list("xyz"),
            "formats": [order + "f4"] * 3,
            "offsets": [offsets[a][0] for a in "xyz"],
            "itemsize": msg.point_step,
        }
    )
    raw = np.asarray(msg.data, dtype=np.uint8)
    rows = raw[: msg.height * msg.row_step].reshape(msg.height, msg.row_step)[:, : msg.width * msg.point_step]
    structured = np.ascontiguousarray(rows).view(dtype).reshape(msg.height, msg.width)
    out = np.stack([structured["x"], structured["y"], structured["z"]], axis=-1).astype(np.float32, copy=False)
    return out[0] if msg.height == 1 else out


# ------------------------------------------------------------------------------------ floor plane


def make_floor_plane(plane: FloorPlane, header: Any) -> Any:
    n = np.asarray(plane.normal, dtype=np.float64)
    return msg_class(FLOOR_PLANE)(
        header=header,
        a=float(n[0]),
        b=float(n[1]),
        c=float(n[2]),
        d=float(plane.offset),
        rms_error=float(plane.rms),
        inlier_ratio=float(plane.inlier_ratio),
        valid=bool(plane.valid),
        anchor=np.zeros(3) if plane.anchor is None else np.asarray(plane.anchor, dtype=np.float64).reshape(3),
        heading=np.zeros(3) if plane.heading is None else np.asarray(plane.heading, dtype=np.float64).reshape(3),
    )


def floor_from_msg(msg: Any) -> FloorPlane:
    def vec(v: Any) -> NDArray[np.float64] | None:
        a = np.asarray(v, dtype=np.float64).reshape(-1)
        return None if a.size != 3 or not np.any(a) else a  # all zeros: not known

    return FloorPlane(
        normal=np.array([msg.a, msg.b, msg.c], dtype=np.float64),
        offset=float(msg.d),
        rms=float(msg.rms_error),
        inlier_ratio=float(msg.inlier_ratio),
        valid=bool(msg.valid),
        anchor=vec(getattr(msg, "anchor", ())),
        heading=vec(getattr(msg, "heading", ())),
    )


# ------------------------------------------------------------------------------------- leg poses


def make_joint_state(pose: LegPose, header: Any) -> Any:
    angles = np.asarray(pose.angles, dtype=np.float64)
    return msg_class(JOINT_STATE)(
        header=header,
        name=list(JOINT_NAMES),
        position=angles.copy(),
        velocity=np.zeros(0, dtype=np.float64),
        effort=np.zeros(0, dtype=np.float64),
    )


def _side_points(arr: NDArray[Any]) -> list[Any]:
    return [_point(arr[s]) for s in (Side.LEFT, Side.RIGHT)]


def make_leg_track(pose: LegPose, header: Any, *, particle_count: int = 0) -> Any:
    nan3 = np.full((2, 3, 2, 3), np.nan)
    segs = pose.segments if pose.segments is not None else nan3
    radii = pose.radii if pose.radii is not None else np.full((2, 3, 2), np.nan)
    vis = pose.visibility if pose.visibility is not None else np.full((2, 3), np.nan)
    if pose.segments is None:  # fall back to joint points for the skeleton
        segs = nan3.copy()
        segs[:, 0, 0], segs[:, 0, 1] = pose.points[:, 0], pose.points[:, 1]
        segs[:, 1, 0], segs[:, 1, 1] = pose.points[:, 1], pose.points[:, 2]
        segs[:, 2, 0], segs[:, 2, 1] = pose.points[:, 3], pose.points[:, 4]
    f32 = np.float32
    kwargs: dict[str, Any] = {
        "header": header,
        "status": int(pose.status),
        "confidence": float(pose.confidence),
        "effective_sample_size": float(pose.ess) if np.isfinite(pose.ess) else float("nan"),
        "particle_count": int(particle_count),
    }
    for j, name in enumerate(LEG_POINTS):  # the message's point fields are named as LEG_POINTS
        kwargs[name] = _side_points(pose.points[:, j])
    kwargs["heel_tracked"] = _side_points(pose.points[:, HEEL] if pose.heel_tracked is None else pose.heel_tracked)
    kwargs["ankle_tracked"] = _side_points(pose.points[:, ANKLE] if pose.ankle_tracked is None
                                           else pose.ankle_tracked)
    kwargs["toe_tracked"] = _side_points(pose.points[:, TOE] if pose.toe_tracked is None else pose.toe_tracked)
    for si, seg in enumerate(SEGMENTS):
        kwargs[f"{seg}_proximal"] = _side_points(segs[:, si, 0])
        kwargs[f"{seg}_distal"] = _side_points(segs[:, si, 1])
        kwargs[f"{seg}_radius_proximal"] = radii[:, si, 0].astype(f32)
        kwargs[f"{seg}_radius_distal"] = radii[:, si, 1].astype(f32)
        kwargs[f"{seg}_visibility"] = vis[:, si].astype(f32)
    return msg_class(LEG_TRACK)(**kwargs)


def leg_pose_from_track(msg: Any) -> LegPose:
    """Rebuild a :class:`LegPose` (points, segments, radii, visibility, status, the tracker's own heels, ankles and
    toes) from a ``LegTrack``: the points are the message's reported ones (its ``LEG_POINTS`` fields), not its
    segments' ends; ``heel_tracked``, ``ankle_tracked`` and ``toe_tracked`` where the message's differ from its
    reported heels, ankles and toes (:meth:`LegPose.as_tracked` is what the gait analysis reads)."""
    segs = np.empty((2, 3, 2, 3))
    radii = np.empty((2, 3, 2))
    vis = np.empty((2, 3))
    for si, seg in enumerate(SEGMENTS):
        for s in range(2):
            segs[s, si, 0] = _xyz(getattr(msg, f"{seg}_proximal")[s])
            segs[s, si, 1] = _xyz(getattr(msg, f"{seg}_distal")[s])
        radii[:, si, 0] = getattr(msg, f"{seg}_radius_proximal")
        radii[:, si, 1] = getattr(msg, f"{seg}_radius_distal")
        vis[:, si] = getattr(msg, f"{seg}_visibility")
    points = np.empty((2, 5, 3))
    for s in range(2):
        for j, name in enumerate(LEG_POINTS):
            points[s, j] = _xyz(getattr(msg, name)[s])
    # the tracker's own heels, ankles and toes (a message recorded before the fields existed has none: its points
    # are the tracker's)
    heel_tracked = _tracked_points(msg, "heel_tracked", points[:, HEEL])
    ankle_tracked = _tracked_points(msg, "ankle_tracked", points[:, ANKLE])
    toe_tracked = _tracked_points(msg, "toe_tracked", points[:, TOE])
    return LegPose(
        stamp=stamp_to_s(msg.header.stamp),
        points=points,
        segments=segs,
        radii=radii,
        visibility=vis,
        status=TrackStatus(int(msg.status)),
        confidence=float(msg.confidence),
        ess=float(msg.effective_sample_size),
        heel_tracked=heel_tracked,
        ankle_tracked=ankle_tracked,
        toe_tracked=toe_tracked,
    )


def _tracked_points(msg: Any, field: str, reported: NDArray[np.float64]) -> NDArray[np.float64] | None:
    """A ``LegTrack``'s ``field`` (the tracker's own points of one kind) as ``(2, 3)``; None where the message has no
    such field or it equals the ``reported`` points (nothing moved them)."""
    tracked = getattr(msg, field, None)
    if tracked is None or len(tracked) != 2:
        return None
    out = np.stack([_xyz(tracked[s]) for s in range(2)])
    return None if np.array_equal(out, reported, equal_nan=True) else out


_SIDE_RGBA = {Side.LEFT: (0.12, 0.47, 0.71, 0.8), Side.RIGHT: (0.84, 0.15, 0.16, 0.8)}


def _quat_z_to(v: NDArray[Any]) -> tuple[float, float, float, float]:
    """Quaternion (x, y, z, w) rotating +z onto direction ``v``."""
    n = np.linalg.norm(v)
    if not np.isfinite(n) or n < 1e-9:
        return (0.0, 0.0, 0.0, 1.0)
    d = v / n
    z = np.array([0.0, 0.0, 1.0])
    axis = np.cross(z, d)
    s = np.linalg.norm(axis)
    c = float(z @ d)
    if s < 1e-9:
        return (0.0, 0.0, 0.0, 1.0) if c > 0 else (1.0, 0.0, 0.0, 0.0)
    axis /= s
    half = np.arctan2(s, c) / 2
    return (*(axis * np.sin(half)).tolist(), float(np.cos(half)))


def make_markers(pose: LegPose, header: Any, *, ns: str = "legs") -> Any:
    """``MarkerArray``: a cylinder per segment (mean radius) and spheres at heel and toe."""
    marker_cls = msg_class("visualization_msgs/msg/Marker")
    pose_cls = msg_class("geometry_msgs/msg/Pose")
    quat_cls = msg_class("geometry_msgs/msg/Quaternion")
    vec_cls = msg_class("geometry_msgs/msg/Vector3")
    color_cls = msg_class("std_msgs/msg/ColorRGBA")
    duration = msg_class("builtin_interfaces/msg/Duration")(sec=0, nanosec=200_000_000)
    markers = []
    visible = pose.status in (TrackStatus.TRACKING, TrackStatus.DEGRADED)

    def add(mid: int, mtype: int, centre: NDArray[Any], quat: tuple[float, ...], scale: tuple[float, ...],
            rgba: tuple[float, ...]) -> None:
        ok = visible and bool(np.all(np.isfinite(centre))) and all(np.isfinite(scale))
        markers.append(
            marker_cls(
                header=header, ns=ns, id=mid, type=mtype, action=0 if ok else 2,  # ADD / DELETE
                pose=pose_cls(position=_point(centre if ok else np.zeros(3)), orientation=quat_cls(
                    x=quat[0], y=quat[1], z=quat[2], w=quat[3])),
                scale=vec_cls(x=scale[0] if ok else 1.0, y=scale[1] if ok else 1.0, z=scale[2] if ok else 1.0),
                color=color_cls(r=rgba[0], g=rgba[1], b=rgba[2], a=rgba[3]),
                lifetime=duration, frame_locked=False, points=[], colors=[], texture_resource="",
                texture=msg_class("sensor_msgs/msg/CompressedImage")(
                    header=header, format="", data=np.zeros(0, dtype=np.uint8)),
                uv_coordinates=[], text="", mesh_resource="",
                mesh_file=msg_class("visualization_msgs/msg/MeshFile")(filename="", data=np.zeros(0, dtype=np.uint8)),
                mesh_use_embedded_materials=False,
            )
        )

    segs = pose.segments
    radii = pose.radii
    for side in (Side.LEFT, Side.RIGHT):
        rgba = _SIDE_RGBA[side]
        for si in range(3):
            mid = side * 10 + si
            if segs is None:
                add(mid, 3, np.full(3, np.nan), (0, 0, 0, 1), (1, 1, 1), rgba)
                continue
            a, b = segs[side, si, 0], segs[side, si, 1]
            r = float(np.nanmean(radii[side, si])) if radii is not None else 0.05
            add(mid, 3, (a + b) / 2, _quat_z_to(b - a), (2 * r, 2 * r, float(np.linalg.norm(b - a))), rgba)
        for pi, point in ((3, 5), (4, 6)):
            add(side * 10 + point, 2, pose.points[side, pi], (0, 0, 0, 1), (0.03, 0.03, 0.03), (1, 1, 0, 1))
    return msg_class(MARKER_ARRAY)(markers=markers)


# ------------------------------------------------------------------------------ gait events/steps


def make_gait_event(event: GaitEvent, frame_id: str) -> Any:
    return msg_class(GAIT_EVENT)(
        header=make_header(event.stamp, frame_id),
        foot=int(event.side),
        kind=int(event.kind),
        position=_point(event.position),
        confidence=float(event.confidence),
    )


def make_step(step: Step, frame_id: str) -> Any:
    return msg_class(STEP)(
        header=make_header(step.stamp, frame_id),
        foot=int(step.side),
        step_index=int(step.index),
        step_length=float(step.step_length),
        step_width=float(step.step_width),
        step_time=float(step.step_time),
        stride_length=float(step.stride_length),
        stride_time=float(step.stride_time),
        stance_time=float(step.stance_time),
        swing_time=float(step.swing_time),
        single_support_time=float(step.single_support_time),
        double_support_time=float(step.double_support_time),
        confidence=float(step.confidence),
    )


def step_from_msg(msg: Any) -> Step:
    return Step(
        stamp=stamp_to_s(msg.header.stamp),
        side=Side(int(msg.foot)),
        index=int(msg.step_index),
        step_length=float(msg.step_length),
        step_width=float(msg.step_width),
        step_time=float(msg.step_time),
        stride_length=float(msg.stride_length),
        stride_time=float(msg.stride_time),
        stance_time=float(msg.stance_time),
        swing_time=float(msg.swing_time),
        single_support_time=float(msg.single_support_time),
        double_support_time=float(msg.double_support_time),
        confidence=float(msg.confidence),
    )


SUMMARY_SCALARS = (
    "window_duration", "duration", "cadence", "gait_speed", "step_length_mean", "step_width_mean",
    "step_time_mean", "double_support_percent", "step_length_symmetry", "swing_time_symmetry",
    "mean_confidence",
)
SUMMARY_PAIRS = (
    "step_length_mean_side", "step_length_sd_side", "step_length_cv_side", "step_width_mean_side",
    "step_width_sd_side", "step_width_cv_side", "step_time_mean_side", "step_time_sd_side",
    "step_time_cv_side", "stance_percent_side", "swing_percent_side",
)


def make_gait_summary(summary: dict[str, Any], header: Any) -> Any:
    """``GaitSummary`` from a dict with the message's field names (missing values → NaN)."""
    kwargs: dict[str, Any] = {"header": header, "scope": int(summary.get("scope", 1)),
                              "step_count": int(summary.get("step_count", 0))}
    for name in SUMMARY_SCALARS:
        value = summary.get(name)
        kwargs[name] = float("nan") if value is None else float(value)
    for name in SUMMARY_PAIRS:
        value = summary.get(name)
        kwargs[name] = np.full(2, np.nan, dtype=np.float32) if value is None else np.asarray(value, dtype=np.float32)
    return msg_class(GAIT_SUMMARY)(**kwargs)


# ------------------------------------------------------------------------------------ diagnostics


def make_diagnostics(header: Any, *, name: str, hardware_id: str, level: int, message: str,
                     values: dict[str, Any]) -> Any:
    kv = msg_class("diagnostic_msgs/msg/KeyValue")
    status = msg_class("diagnostic_msgs/msg/DiagnosticStatus")(
        level=level, name=name, message=message, hardware_id=hardware_id,
        values=[kv(key=str(k), value=str(v)) for k, v in values.items()],
    )
    return msg_class(DIAGNOSTIC_ARRAY)(header=header, status=[status])
