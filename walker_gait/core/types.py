"""Shared data types and frame conventions of the algorithm core.

Every stage (depth decoding, segmentation, tracker, gait analysis, synthetic
generator, offline pipeline and ROS nodes) exchanges these types, so they are
kept small, typed and free of ROS imports.

Frames
------
camera optical frame (``camera``)
    REP-103 optical convention: +x right in the image, +y down, +z along the
    optical axis.  Metres.  The camera sits on the walker and looks back at the
    user, so the user's anatomical *left* leg appears on the image's *right*
    (+x) for the default ``mounting="facing_user"``.
walker frame (``walker``)
    Floor-aligned frame attached to the walker, derived from the floor plane:
    origin = camera centre projected onto the floor, +z up (floor normal),
    +x = optical axis projected onto the floor (pointing from the camera
    towards the user), +y = z × x (the camera's left).  The user walks
    towards -x (they follow the walker).  With ``FloorPlane.anchor`` / ``heading`` (what the floor
    tracker reports) the origin and +x are the still walker's, so that a walker rocking on its wheels
    does not shake the frame.  See :meth:`FloorPlane.walker_transform`.

Indexing
--------
Leg points are stored as arrays shaped ``(2, 5, 3)`` indexed
``[side, point, xyz]`` with ``side`` in :class:`Side` order (LEFT=0, RIGHT=1)
and ``point`` in :data:`LEG_POINTS` order.  Sides are *anatomical* sides of
the user.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from enum import IntEnum

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

LEG_POINTS: tuple[str, ...] = ("hip", "knee", "ankle", "heel", "toe")
"""Order of the tracked/ground-truth points of one leg."""

HIP, KNEE, ANKLE, HEEL, TOE = range(5)

SEGMENTS: tuple[str, ...] = ("thigh", "calf", "foot")
"""Order of the model segments of one leg."""

JOINT_NAMES: tuple[str, ...] = (
    "left_hip_flexion",
    "left_hip_abduction",
    "left_hip_rotation",
    "left_knee_flexion",
    "left_ankle_flexion",
    "left_ankle_inversion",
    "right_hip_flexion",
    "right_hip_abduction",
    "right_hip_rotation",
    "right_knee_flexion",
    "right_ankle_flexion",
    "right_ankle_inversion",
)
"""``sensor_msgs/JointState`` names (radians), in publication order.

Sign conventions (anatomical): hip flexion positive when the thigh swings
forward (towards the walker); hip abduction positive when the thigh moves away
from the body midline; hip rotation positive for internal rotation; knee
flexion positive (0 = straight leg); ankle flexion positive for dorsiflexion
(toes up); ankle inversion positive when the sole turns towards the midline.
"""


class Side(IntEnum):
    """Anatomical side of the user; values match ``walker_gait_msgs`` constants."""

    LEFT = 0
    RIGHT = 1

    @property
    def label(self) -> str:
        return self.name.lower()


class EventKind(IntEnum):
    """Gait event kind; values match ``walker_gait_msgs/GaitEvent`` constants."""

    HEEL_STRIKE = 0
    TOE_OFF = 1

    @property
    def label(self) -> str:
        return self.name.lower()


class TrackStatus(IntEnum):
    """Tracker status; values match ``walker_gait_msgs/LegTrack`` constants."""

    NO_USER = 0  # nothing leg-like in the region of interest
    SEARCHING = 1  # (re-)initialising from the foreground
    TRACKING = 2  # converged, following the legs
    DEGRADED = 3  # tracking, but with low confidence (occlusion, missing depth)


@dataclass(frozen=True, kw_only=True)
class CameraIntrinsics:
    """Pinhole intrinsics of a (rectified or undistorted) depth image."""

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float

    def __post_init__(self) -> None:
        if self.width <= 0 or self.height <= 0:
            msg = f"image size must be positive, got {self.width}x{self.height}"
            raise ValueError(msg)
        if not (np.isfinite(self.fx) and np.isfinite(self.fy)) or self.fx <= 0 or self.fy <= 0:
            msg = f"focal lengths must be positive and finite, got fx={self.fx}, fy={self.fy}"
            raise ValueError(msg)

    def project(self, points: FloatArray) -> FloatArray:
        """Project ``(..., 3)`` camera-frame points to ``(..., 2)`` pixel coordinates (u, v).

        Points with z <= 0 give non-finite pixel coordinates.
        """
        pts = np.asarray(points, dtype=np.float64)
        z = pts[..., 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            u = self.fx * pts[..., 0] / z + self.cx
            v = self.fy * pts[..., 1] / z + self.cy
        bad = ~(z > 0)
        u = np.where(bad, np.nan, u)
        v = np.where(bad, np.nan, v)
        return np.stack([u, v], axis=-1)

    def backproject(self, u: FloatArray, v: FloatArray, depth: FloatArray) -> FloatArray:
        """Back-project pixel coordinates with metric depth to ``(..., 3)`` camera points (eq. 2)."""
        z = np.asarray(depth, dtype=np.float64)
        x = (np.asarray(u, dtype=np.float64) - self.cx) * z / self.fx
        y = (np.asarray(v, dtype=np.float64) - self.cy) * z / self.fy
        return np.stack([x, y, z], axis=-1)

    def scaled(self, factor: float) -> CameraIntrinsics:
        """Intrinsics of the image resized by ``factor`` (e.g. 0.25 for a 160x120 cue image)."""
        return CameraIntrinsics(
            width=max(1, round(self.width * factor)),
            height=max(1, round(self.height * factor)),
            fx=self.fx * factor,
            fy=self.fy * factor,
            cx=(self.cx + 0.5) * factor - 0.5,
            cy=(self.cy + 0.5) * factor - 0.5,
        )


@dataclass(frozen=True, kw_only=True)
class FloorPlane:
    """Floor plane in the camera optical frame: ``normal · p + offset = 0``.

    ``normal`` is a unit vector pointing *up* (away from the floor, towards the
    camera side), so :meth:`height` is positive above the floor and
    ``offset`` equals the camera's height above the floor.

    ``anchor`` and ``heading`` (optional) fix the walker frame to the walker's body rather than to the camera:
    a walker rocks on its wheels as it rolls, the camera with it, and the camera's own foot point and optical
    axis then move over the floor (about 9 mm per degree for a camera 0.5 m up), while a point of the walker at
    floor level and its forward direction stay put to first order.  ``anchor`` is such a point (camera frame, m;
    :class:`~walker_gait.core.segmentation.FloorTracker` takes the foot point of the still walker's floor) and
    ``heading`` such a direction (the still walker's optical axis on its floor); without them the walker frame
    hangs from the camera, as for a rigid walker they coincide.
    """

    normal: FloatArray
    offset: float
    rms: float = 0.0  # RMS point-to-plane residual of the inliers (m)
    inlier_ratio: float = 0.0  # inliers / candidate floor points (0..1)
    valid: bool = True
    anchor: FloatArray | None = None  # (3,) camera frame: walker point at floor level; the walker origin is its foot point on this plane
    heading: FloatArray | None = None  # (3,) camera frame: walker direction whose projection on this plane is the walker +x

    @property
    def usable(self) -> bool:
        """Whether this plane can place anything: ``valid`` with a finite normal and offset (a walker frame)."""
        return bool(self.valid and np.all(np.isfinite(self.normal)) and math.isfinite(self.offset))

    def height(self, points: FloatArray) -> FloatArray:
        """Signed height (m) of ``(..., 3)`` camera-frame points above the floor."""
        return np.asarray(points, dtype=np.float64) @ self.normal + self.offset

    def walker_transform(self) -> tuple[FloatArray, FloatArray]:
        """Rotation ``R`` (3x3) and translation ``t`` with ``p_walker = R @ p_camera + t``."""
        n = np.asarray(self.normal, dtype=np.float64)
        n = n / np.linalg.norm(n)
        forward = np.array([0.0, 0.0, 1.0]) if self.heading is None else np.asarray(self.heading, dtype=np.float64)
        x_axis = forward - (forward @ n) * n
        norm = np.linalg.norm(x_axis)
        if norm < 1e-6:  # camera looking straight down: fall back to image "down" direction
            down = np.array([0.0, 1.0, 0.0])
            x_axis = down - (down @ n) * n
            norm = np.linalg.norm(x_axis)
        x_axis = x_axis / norm
        y_axis = np.cross(n, x_axis)
        rot = np.stack([x_axis, y_axis, n])
        if self.anchor is None:
            # camera centre (origin) is at height `offset`; its floor projection is the walker origin
            return rot, np.array([0.0, 0.0, self.offset])
        a = np.asarray(self.anchor, dtype=np.float64)
        origin = a - (a @ n + self.offset) * n  # the anchor's foot point on this plane
        return rot, -(rot @ origin)

    def to_walker(self, points: FloatArray) -> FloatArray:
        """Transform ``(..., 3)`` camera-frame points into the walker frame."""
        rot, t = self.walker_transform()
        return np.asarray(points, dtype=np.float64) @ rot.T + t

    @staticmethod
    def from_camera_pose(*, height: float, pitch: float) -> FloorPlane:
        """Floor seen by a camera ``height`` m above it, pitched down by ``pitch`` rad (no roll)."""
        # In the optical frame "up" is -y; pitching the camera down by `pitch` rotates it about +x.
        normal = np.array([0.0, -np.cos(pitch), -np.sin(pitch)])
        return FloorPlane(normal=normal, offset=float(height), rms=0.0, inlier_ratio=1.0)


@dataclass(kw_only=True)
class LegPose:
    """Pose of both legs in one frame (tracker output or ground truth)."""

    stamp: float  # seconds, image header clock
    points: FloatArray  # (2, 5, 3) [side, LEG_POINTS, xyz] camera optical frame, metres
    angles: FloatArray = field(default_factory=lambda: np.full(len(JOINT_NAMES), np.nan))  # JOINT_NAMES order, rad
    segments: FloatArray | None = None  # (2, 3, 2, 3) [side, SEGMENTS, proximal/distal, xyz]
    radii: FloatArray | None = None  # (2, 3, 2) [side, SEGMENTS, proximal/distal] metres
    visibility: FloatArray | None = None  # (2, 3) [side, SEGMENTS] fraction visible 0..1
    status: TrackStatus = TrackStatus.TRACKING
    confidence: float = 1.0  # 0..1
    ess: float = float("nan")  # effective sample size of the particle set
    shoe_rise: FloatArray | None = None  # (2,) [side] rad, rise of the visible shoe upper behind the toe (feet.measure_shoe_rise), NaN unmeasured
    shoe_turn: FloatArray | None = None  # (2,) [side] rad, the shoe's centre line's turn from the reported foot's heading, anticlockwise from above (feet.measure_shoe_turn), NaN unmeasured
    heel_tracked: FloatArray | None = None  # (2, 3) [side, xyz] the tracker's own heels where the reported ones (points) were placed elsewhere (pelvis.LivePelvis), what the gait analysis reads; None: the points' own
    ankle_tracked: FloatArray | None = None  # (2, 3) [side, xyz] the tracker's own ankles where the reported ones were placed elsewhere (pelvis.LivePelvis), what the gait analysis reads; None: the points' own
    toe_tracked: FloatArray | None = None  # (2, 3) [side, xyz] the tracker's own toes where the reported ones were put elsewhere (on the floor: pelvis.LivePelvis), what the gait analysis reads; None: the points' own

    def as_tracked(self) -> LegPose:
        """This pose with the tracker's own heels, ankles and toes (``heel_tracked``, ``ankle_tracked``,
        ``toe_tracked``) in its points: the pose the gait analysis reads (the live placement moves the reported ones,
        the analysis reads them as tracked)."""
        if self.heel_tracked is None and self.ankle_tracked is None and self.toe_tracked is None:
            return self
        pts = np.array(self.points, dtype=np.float64, copy=True)
        if self.heel_tracked is not None:
            pts[:, HEEL] = self.heel_tracked
        if self.ankle_tracked is not None:
            pts[:, ANKLE] = self.ankle_tracked
        if self.toe_tracked is not None:
            pts[:, TOE] = self.toe_tracked
        return replace(self, points=pts, heel_tracked=None, ankle_tracked=None, toe_tracked=None)

    @classmethod
    def no_user(cls, stamp: float) -> LegPose:
        """The pose of a frame without legs to report: no points, ``NO_USER``, confidence 0."""
        return cls(stamp=stamp, points=np.full((2, 5, 3), np.nan), status=TrackStatus.NO_USER, confidence=0.0)


@dataclass(frozen=True, kw_only=True)
class GaitEvent:
    """A heel strike or toe off."""

    stamp: float  # seconds (sub-frame interpolated), image header clock
    side: Side
    kind: EventKind
    position: FloatArray  # (3,) heel (HS) or toe (TO) position, camera optical frame, metres
    confidence: float = 1.0


@dataclass(frozen=True, kw_only=True)
class Step:
    """One step, ending at the heel strike of ``side`` (GAITRite definitions, see README)."""

    stamp: float  # heel-strike time (s)
    side: Side
    index: int  # 0-based step number in the session
    step_length: float  # m
    step_width: float  # m
    step_time: float  # s
    stride_length: float  # m, NaN when the previous same-side footfall is unknown
    stride_time: float  # s, NaN likewise
    stance_time: float  # s, of the previous gait cycle of this foot, NaN when unknown
    swing_time: float  # s
    single_support_time: float  # s
    double_support_time: float  # s
    confidence: float = 1.0
