"""Synthetic walker sessions: :class:`SessionSpec`, scenario presets, :func:`generate_session`.

A session is a person walking behind a wheeled walker whose depth camera (on the walker's
front cross-bar, ~0.4-0.6 m high, pitched down 20-40 deg, small roll/yaw) looks back at the
user's legs (coronal view).  The walker is pushed by the user: its velocity follows the
user's pelvis velocity with a smooth (critically damped) lag and a spring that keeps the
preferred camera-to-pelvis distance, so planted feet recede from the camera during stance.

Frames
------
world: X progression, Y user's left, Z up, floor z = 0.  camera: optical frame (x right,
y down, z forward).  walker pose: (X, Y, yaw) of the point on the floor under the camera;
the camera faces -X (back towards the user), so the image's +x is world +Y (user's left).

Determinism: everything is drawn from the ``rng`` passed to :func:`generate_session`; frame
noise uses per-frame seeds drawn at generation time, so frames can be rendered lazily, in any
order, and always give identical images.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

from walker_gait.core.types import CameraIntrinsics, FloorPlane, Side
from walker_gait.synth import body as B
from walker_gait.synth.groundtruth import GtEvent, GtStep, gait_events, gait_steps
from walker_gait.synth.kinematics import BodyDims, BodyState, GaitKinematics, GaitParams, Phase, plan_footfalls
from walker_gait.synth.sensor import (
    SensorModel,
    apply_sensor,
    floor_depth,
    pixel_rays,
    rasterize,
    sensor_output_to_m,
    sensor_output_to_mm,
)

FloatArray = NDArray[np.float64]
Range = tuple[float, float]

SCENARIOS: tuple[str, ...] = (
    "normal",
    "slow_elderly",
    "baggy_trousers",
    "occlusion",
    "asymmetric",
    "stop_and_go",
    "absent_start",
    "different_camera",
    "walker_lag",
)

CAMERAS: dict[str, dict[str, object]] = {
    # name: size, focal range (px at full size), sensor kind, extra sensor settings
    "kinect_v1": {"size": (640, 480), "f": (525.0, 580.0), "sensor": "kinect_v1", "near": 0.40, "right_cols": 8},
    "realsense_424x240": {"size": (424, 240), "f": (205.0, 222.0), "sensor": "stereo", "near": 0.20, "right_cols": 0},
    "kinect_v2_512x424": {"size": (512, 424), "f": (360.0, 372.0), "sensor": "tof", "near": 0.50, "right_cols": 0},
}


@dataclass(frozen=True, kw_only=True)
class SessionSpec:
    """What to generate.  ``(lo, hi)`` ranges are sampled uniformly per session.

    Distances in metres, angles in degrees (spec only), times in seconds.
    ``user_distance`` is the horizontal distance from the camera to the user's pelvis
    (midpoint of the hip joint centres) while walking; feet range ~0.3 m either side.
    """

    scenario: str = "normal"
    duration: float = 10.0
    fps: float = 30.0
    scale: float = 1.0  # image resolution factor (0.25: 160x120 for a Kinect)
    camera: tuple[str, ...] = ("kinect_v1",)  # chosen uniformly
    cam_height: Range = (0.42, 0.58)
    cam_pitch_deg: Range = (22.0, 38.0)
    cam_roll_deg: Range = (-3.0, 3.0)
    cam_yaw_deg: Range = (-2.0, 2.0)
    cam_lateral: Range = (-0.02, 0.02)
    principal_jitter_px: float = 6.0  # cx, cy offsets from the centre (full-size px)
    user_distance: Range = (0.78, 0.95)
    walker_lag: Range = (0.25, 0.45)  # s, time constant of the walker following the user
    vibration_deg: Range = (0.0, 0.0)  # RMS tilt (pitch and roll, each) of the rolling walker and its camera, see _walker_tilt
    # gait
    cadence: Range = (95.0, 110.0)  # steps / min
    step_length: Range = (0.45, 0.58)
    step_width: Range = (0.08, 0.13)
    double_support: Range = (0.22, 0.28)  # fraction of step time
    step_time_cv: Range = (0.02, 0.035)
    step_length_sd: Range = (0.010, 0.020)
    step_width_sd: Range = (0.010, 0.020)
    asym_length: Range = (0.0, 0.0)
    asym_time: Range = (0.0, 0.0)
    knee_min_flex_deg: Range = (3.0, 7.0)
    heel_strike_pitch_deg: Range = (14.0, 22.0)
    toe_off_pitch_deg: Range = (-44.0, -36.0)
    toe_clearance: Range = (0.012, 0.02)
    toe_out_deg: Range = (3.0, 10.0)
    body_scale: Range = (0.92, 1.08)  # segment lengths
    girth: Range = (0.9, 1.15)
    # programme
    stand_start: Range = (0.6, 1.2)  # standing still at the start
    absent_start: Range = (0.0, 0.0)  # s the user is out of view before walking in
    walk_bout: Range = (0.0, 0.0)  # stop-and-go: walking bout duration (0 = walk to the end)
    stand_bout: Range = (1.0, 2.5)  # stop-and-go: stand-still duration
    stand_only: bool = False  # never walk (stand-still session)
    # clothing / scene / sensor
    clothing: tuple[str, ...] = ("fitted", "fitted", "none")  # chosen uniformly
    fold_amp: Range = (0.04, 0.08)
    fabric_dropout: Range = (0.02, 0.06)
    clutter: bool = True
    walker_parts: bool = True
    sensor_noise: bool = True  # False: ideal depth (still quantised to the output format)
    rgb_topic: bool = True

    def __post_init__(self) -> None:
        if self.duration <= 0 or self.fps <= 0:
            msg = f"duration and fps must be positive, got {self.duration}, {self.fps}"
            raise ValueError(msg)
        if not (0.05 <= self.scale <= 2.0):
            msg = f"scale must be in [0.05, 2], got {self.scale}"
            raise ValueError(msg)
        for cam in self.camera:
            if cam not in CAMERAS:
                msg = f"unknown camera {cam!r}; expected one of {sorted(CAMERAS)}"
                raise ValueError(msg)
        for c in self.clothing:
            if c not in B.CLOTHING:
                msg = f"unknown clothing {c!r}; expected one of {B.CLOTHING}"
                raise ValueError(msg)
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if isinstance(v, tuple) and len(v) == 2 and all(isinstance(x, float | int) for x in v) and v[0] > v[1]:
                msg = f"range {f.name}={v} has lo > hi"
                raise ValueError(msg)

    @staticmethod
    def preset(name: str, **overrides: object) -> SessionSpec:
        """Named scenario (see :data:`SCENARIOS`) with optional field overrides."""
        if name not in SCENARIOS:
            msg = f"unknown scenario {name!r}; expected one of {', '.join(SCENARIOS)}"
            raise ValueError(msg)
        base: dict[str, object] = dict(_PRESETS[name])
        base.update(overrides)
        return SessionSpec(scenario=name, **base)  # type: ignore[arg-type]

    def to_dict(self) -> dict[str, object]:
        return dataclasses.asdict(self)


_PRESETS: dict[str, dict[str, object]] = {
    "normal": {},
    "slow_elderly": {
        "cadence": (72.0, 90.0),
        "step_length": (0.28, 0.40),
        "step_width": (0.10, 0.16),
        "double_support": (0.32, 0.42),
        "step_time_cv": (0.04, 0.07),
        "step_length_sd": (0.02, 0.03),
        "step_width_sd": (0.015, 0.03),
        "knee_min_flex_deg": (10.0, 16.0),
        "heel_strike_pitch_deg": (6.0, 12.0),
        "toe_off_pitch_deg": (-30.0, -22.0),
        "toe_clearance": (0.006, 0.012),
        "user_distance": (0.72, 0.88),
        "clothing": ("fitted", "baggy"),
    },
    "baggy_trousers": {"clothing": ("baggy",), "fold_amp": (0.06, 0.12), "fabric_dropout": (0.05, 0.10)},
    "occlusion": {
        "step_width": (0.0, 0.04),
        "step_length": (0.58, 0.68),
        "step_width_sd": (0.008, 0.012),
        "toe_out_deg": (0.0, 4.0),
        "cadence": (100.0, 112.0),
    },
    "asymmetric": {"asym_length": (0.15, 0.25), "asym_time": (0.08, 0.15)},
    "stop_and_go": {"walk_bout": (2.5, 4.0), "stand_bout": (1.2, 2.5)},
    "absent_start": {"absent_start": (2.0, 3.0), "clutter": True},
    "different_camera": {"camera": ("realsense_424x240", "kinect_v2_512x424")},
    # the walker follows its user sluggishly (a user who lets it lag, or leans on it less): setting off, the user walks
    # up close to it, thighs nearer than the sensor's range and a foot at or below the image's bottom edge
    "walker_lag": {"walker_lag": (0.6, 0.9)},
}


@dataclass(frozen=True, kw_only=True)
class CameraMount:
    """Resolved camera placement on the walker."""

    height: float  # m above the floor
    pitch: float  # rad, down
    roll: float  # rad, about the optical axis
    yaw: float  # rad, about the vertical (0: optical axis along world -X)
    lateral: float  # m, world Y of the camera relative to the walker centre line

    def rotation(self) -> FloatArray:
        """``R`` (3x3) with ``p_world = R @ p_camera + C`` for a walker heading along +X."""
        cp, sp = np.cos(self.pitch), np.sin(self.pitch)
        x_c = np.array([0.0, 1.0, 0.0])
        y_c = np.array([sp, 0.0, -cp])
        z_c = np.array([-cp, 0.0, -sp])
        cr, sr = np.cos(self.roll), np.sin(self.roll)
        x_r = cr * x_c + sr * y_c
        y_r = -sr * x_c + cr * y_c
        r = np.stack([x_r, y_r, z_c], axis=1)
        cy, sy = np.cos(self.yaw), np.sin(self.yaw)
        rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
        return rz @ r

    def floor_plane(self) -> FloorPlane:
        """Ground-truth floor in the camera frame (constant: the walker is rigid on a flat floor)."""
        n = self.rotation().T @ np.array([0.0, 0.0, 1.0])
        return FloorPlane(normal=n, offset=float(self.height), rms=0.0, inlier_ratio=1.0, valid=True)


@dataclass(frozen=True, kw_only=True)
class ResolvedParams:
    """Everything sampled for one session (stored in the ground truth)."""

    camera_name: str
    intrinsics: CameraIntrinsics
    mount: CameraMount
    sensor: SensorModel
    gait: GaitParams
    dims: BodyDims
    shape: B.BodyShape
    user_distance: float
    walker_lag: float
    programme: tuple[Phase, ...]
    start_x: float
    start_y: float


WHEEL_HALF_TRACK = 0.28
"""m: the walker's wheels this far either side of its centre line (when the scene has no walker parts)."""
REAR_WHEELS = 0.56
"""m: its rear wheels this far towards the user from the camera (likewise)."""
FRONT_WHEELS = 0.12
"""m: its front wheels this far ahead of the camera (out of view; the walker rocks forward onto them)."""


@dataclass
class SceneStatic:
    """Per-session static scene: floor + walker parts in the camera frame, clutter in the world."""

    static_depth: FloatArray  # (H, W) floor/walker depth, inf = nothing
    static_cos: FloatArray
    static_mat: NDArray[np.int8]
    clutter: B.Mesh  # world frame boxes
    walls_y: tuple[float, ...]  # world Y of hallway walls
    parts_depth: FloatArray | None = None  # (H, W) walker parts alone (inf = none): a vibrating walker's floor moves
    parts_cos: FloatArray | None = None
    wheels: tuple[float, float] = (WHEEL_HALF_TRACK, REAR_WHEELS)  # m: half track, rear wheels behind the camera


@dataclass(kw_only=True)
class RenderedFrame:
    """One rendered frame."""

    index: int
    stamp: float
    data: NDArray[np.uint16]  # sensor output (raw Kinect disparity, 2047 invalid; or mm, 0 invalid)
    material: NDArray[np.int8]  # (H, W) ideal material id (body.MAT_*)
    side: NDArray[np.int8]  # (H, W) leg side of the ideal surface (-1 none)
    ideal_depth: NDArray[np.float32]  # (H, W) noiseless depth z (m), inf where nothing


@dataclass
class Session:
    """A generated session: parameters, trajectories, ground truth and lazily rendered frames."""

    spec: SessionSpec
    params: ResolvedParams
    stamps: FloatArray  # (T,) s, session time of each frame (= header stamps)
    kinematics: GaitKinematics
    body: BodyState  # at the frame stamps (world frame)
    walker_pose: FloatArray  # (T, 3) walker (X, Y, yaw) in the world at the frame stamps
    world_from_camera: FloatArray  # (T, 4, 4)
    leg_points: FloatArray  # (T, 2, 5, 3) camera optical frame, metres
    floor: FloorPlane
    events: list[GtEvent]
    steps: list[GtStep]
    scene: SceneStatic
    hem_centres: FloatArray  # (T, 2, 3) baggy-trouser hem centres (world)
    frame_seeds: NDArray[np.uint64]
    _walker_t: FloatArray = field(repr=False)
    _walker_x: FloatArray = field(repr=False)
    walker_tilt: FloatArray | None = None  # (T, 2) pitch, roll (rad) of a vibrating walker at the frames; None: rigid on the floor
    _tilt: FloatArray | None = field(default=None, repr=False)  # (N, 2) tilt on the walker's time grid (_walker_t)

    # ------------------------------------------------------------------ basics
    @property
    def intrinsics(self) -> CameraIntrinsics:
        return self.params.intrinsics

    @property
    def depth_format(self) -> str:
        """Native storage of :attr:`RenderedFrame.data`: ``"kinect_raw"`` or ``"mm"``."""
        return self.params.sensor.output

    def __len__(self) -> int:
        return len(self.stamps)

    def camera_info(self) -> dict[str, object]:
        """``sensor_msgs/CameraInfo`` fields (plumb_bob, rectified pinhole, zero distortion)."""
        k = self.intrinsics
        return {
            "width": k.width,
            "height": k.height,
            "distortion_model": "plumb_bob",
            "d": [0.0, 0.0, 0.0, 0.0, 0.0],
            "k": [k.fx, 0.0, k.cx, 0.0, k.fy, k.cy, 0.0, 0.0, 1.0],
            "r": [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
            "p": [k.fx, 0.0, k.cx, 0.0, 0.0, k.fy, k.cy, 0.0, 0.0, 0.0, 1.0, 0.0],
        }

    def camera_pose_at(self, t: FloatArray) -> tuple[FloatArray, FloatArray]:
        """World-from-camera rotations (N,3,3) and camera centres (N,3) at times ``t`` (the mount's
        rotation throughout unless the walker vibrates)."""
        t = np.atleast_1d(np.asarray(t, float))
        xw = np.interp(t, self._walker_t, self._walker_x)
        m = self.params.mount
        if self._tilt is None:
            c = np.stack([xw, np.full_like(xw, m.lateral), np.full_like(xw, m.height)], axis=-1)
            return np.broadcast_to(m.rotation(), (t.size, 3, 3)).copy(), c
        tilt = np.stack([np.interp(t, self._walker_t, self._tilt[:, k]) for k in (0, 1)], axis=-1)
        return _tilted_camera(m.rotation(), m, xw, tilt, wheels=self.scene.wheels)

    def world_to_camera(self, points: FloatArray, t: FloatArray) -> FloatArray:
        """Transform world points ``(N, ..., 3)`` observed at times ``t`` (N,) into the camera frame."""
        r, c = self.camera_pose_at(t)
        p = np.asarray(points, float)
        shape = p.shape
        p = p.reshape(len(c), -1, 3)
        return np.einsum("nmj,njk->nmk", p - c[:, None, :], r).reshape(shape)

    def floor_at(self, i: int) -> FloorPlane:
        """The true floor in the camera frame at frame ``i`` (:attr:`floor` unless the walker vibrates)."""
        if self.walker_tilt is None:
            return self.floor
        r = self.world_from_camera[i, :3, :3]
        return FloorPlane(normal=r.T @ np.array([0.0, 0.0, 1.0]), offset=float(self.world_from_camera[i, 2, 3]),
                          rms=0.0, inlier_ratio=1.0, valid=True)

    # ------------------------------------------------------------------ rendering
    def frame(self, i: int) -> RenderedFrame:
        """Render frame ``i`` (deterministic; recent frames cached)."""
        if not (0 <= i < len(self)):
            msg = f"frame index {i} out of range 0..{len(self) - 1}"
            raise IndexError(msg)
        return self._render_cached(i)

    def __iter__(self) -> Iterator[RenderedFrame]:
        for i in range(len(self)):
            yield self.frame(i)

    def depth_m(self, i: int) -> NDArray[np.float32]:
        """Frame ``i`` as float32 metres (NaN invalid)."""
        return sensor_output_to_m(self.frame(i).data, self.depth_format)

    def depth_mm(self, i: int) -> NDArray[np.uint16]:
        """Frame ``i`` as uint16 millimetres (0 invalid)."""
        return sensor_output_to_mm(self.frame(i).data, self.depth_format)

    def __post_init__(self) -> None:
        self._render_cached = lru_cache(maxsize=4)(self._render)

    def _render(self, i: int) -> RenderedFrame:
        p = self.params
        intr = p.intrinsics
        st = self.body
        detail = float(np.clip(0.35 + 0.65 * self.spec.scale, 0.45, 1.0))
        meshes: list[B.Mesh] = []
        for side in (0, 1):
            meshes += B.leg_meshes(
                hip=st.hip[i, side],
                knee=st.knee[i, side],
                ankle=st.ankle[i, side],
                heel=st.heel[i, side],
                foot_rot=st.foot_rot[i, side],
                side=side,
                shape=p.shape,
                hem_centre=self.hem_centres[i, side],
                knee_flex=float(st.angles[i, 3 if side == 0 else 9]),
                foot_length=p.dims.foot_length,
                detail=detail,
            )
        n_body = sum(len(m.faces) for m in meshes)
        meshes.append(self.scene.clutter)
        mesh = B.Mesh.concat(meshes)
        r = self.world_from_camera[i, :3, :3]
        c = self.world_from_camera[i, :3, 3]
        v_cam = (mesh.vertices - c) @ r
        depth, face, cos = rasterize(v_cam, mesh.faces, intr)
        mat = np.where(face >= 0, mesh.material[np.maximum(face, 0)], B.MAT_NONE).astype(np.int8)
        side_img = np.where((face >= 0) & (face < n_body), mesh.side[np.maximum(face, 0)], -1).astype(np.int8)
        # hallway walls (analytic planes, world Y = const, 0 <= Z <= 2.2)
        rays, ray_norm = _rays_cached(intr)
        for wy in self.scene.walls_y:
            # world Y and Z of the pixel rays are linear in t: Y = c_y + t (r^T e_y).ray
            nr = rays @ r[1]
            with np.errstate(divide="ignore", invalid="ignore"):
                t = (wy - c[1]) / nr
            hit_z = c[2] + t * (rays @ r[2])
            ok = (t > 0) & (hit_z > 0) & (hit_z < 2.2) & (t < depth)
            if np.any(ok):
                depth[ok] = t[ok]
                cos[ok] = np.abs(nr[ok]) / ray_norm[ok]
                mat[ok] = B.MAT_CLUTTER
                side_img[ok] = -1
        # floor + walker parts (static in the camera frame; a vibrating walker's floor moves in it)
        static_z, static_cos, static_mat = self.scene.static_depth, self.scene.static_cos, self.scene.static_mat
        if self.walker_tilt is not None and self.scene.parts_depth is not None and self.scene.parts_cos is not None:
            fl = self.floor_at(i)
            fz, fcos = floor_depth(intr, fl.normal, fl.offset)
            part = self.scene.parts_depth < fz
            static_z = np.where(part, self.scene.parts_depth, fz)
            static_cos = np.where(part, self.scene.parts_cos, fcos)
            static_mat = np.where(part, B.MAT_WALKER, np.where(np.isfinite(fz), B.MAT_FLOOR, B.MAT_NONE)).astype(np.int8)
        closer = static_z < depth
        depth[closer] = static_z[closer]
        cos[closer] = static_cos[closer]
        mat[closer] = static_mat[closer]
        side_img[closer] = -1
        rng = np.random.default_rng(int(self.frame_seeds[i]))
        model = p.sensor
        if not self.spec.sensor_noise:
            model = dataclasses.replace(
                model,
                disparity_sigma=0.0,
                disparity_sigma_corr=0.0,
                tof_sigma=(0.0, 0.0),
                grazing_cos=(0.0, 1e-9),
                edge_dropout=0.0,
                speckle_dropout=0.0,
                fabric_dropout=0.0,
                baseline=0.0,
            )
        data = apply_sensor(depth, cos, mat == B.MAT_TROUSERS, intr, model, rng=rng)
        return RenderedFrame(
            index=i,
            stamp=float(self.stamps[i]),
            data=data,
            material=mat,
            side=side_img,
            ideal_depth=depth.astype(np.float32),
        )


@lru_cache(maxsize=8)
def _rays_cached(intr: CameraIntrinsics) -> tuple[FloatArray, FloatArray]:
    rays = pixel_rays(intr)
    return rays, np.linalg.norm(rays, axis=-1)


# --------------------------------------------------------------------------- generation
def _u(rng: np.random.Generator, r: Range) -> float:
    lo, hi = float(r[0]), float(r[1])
    return lo if hi <= lo else float(rng.uniform(lo, hi))


def _resolve(spec: SessionSpec, rng: np.random.Generator) -> ResolvedParams:
    cam_name = spec.camera[int(rng.integers(len(spec.camera)))]
    cam = CAMERAS[cam_name]
    w0, h0 = cam["size"]  # type: ignore[misc]
    f = _u(rng, cam["f"])  # type: ignore[arg-type]
    jit = spec.principal_jitter_px
    full = CameraIntrinsics(
        width=int(w0),
        height=int(h0),
        fx=f * (1.0 + 0.01 * rng.standard_normal()),
        fy=f,
        cx=(w0 - 1) / 2 + _u(rng, (-jit, jit)),
        cy=(h0 - 1) / 2 + _u(rng, (-jit, jit)),
    )
    intr = full if spec.scale == 1.0 else full.scaled(spec.scale)
    mount = CameraMount(
        height=_u(rng, spec.cam_height),
        pitch=np.deg2rad(_u(rng, spec.cam_pitch_deg)),
        roll=np.deg2rad(_u(rng, spec.cam_roll_deg)),
        yaw=np.deg2rad(_u(rng, spec.cam_yaw_deg)),
        lateral=_u(rng, spec.cam_lateral),
    )
    right_cols = int(round(int(cam["right_cols"]) * spec.scale))  # type: ignore[call-overload]
    kind = str(cam["sensor"])
    sensor = SensorModel(
        kind=kind,
        near=float(cam["near"]),  # type: ignore[arg-type]
        far=4.5,
        baseline={"kinect_v1": 0.075, "stereo": 0.05, "tof": 0.0}[kind],
        disparity_sigma={"kinect_v1": 0.35, "stereo": 0.06, "tof": 0.0}[kind],
        disparity_sigma_corr={"kinect_v1": 0.25, "stereo": 0.05, "tof": 0.0}[kind],
        corr_scale=max(2, int(round(8 * spec.scale))),
        fabric_dropout=_u(rng, spec.fabric_dropout),
        invalid_right_cols=right_cols,
    )
    bs = _u(rng, spec.body_scale)
    dims = BodyDims(
        thigh_length=0.42 * bs,
        shank_length=0.41 * bs,
        pelvis_width=0.18 * bs,
        foot_length=0.27 * (0.5 + 0.5 * bs),
        ankle_height=0.095 * (0.5 + 0.5 * bs),
        ankle_forward=0.065 * (0.5 + 0.5 * bs),
    )
    gait = GaitParams(
        cadence=_u(rng, spec.cadence),
        step_length=_u(rng, spec.step_length) * (0.6 + 0.4 * bs),
        step_width=_u(rng, spec.step_width),
        double_support=_u(rng, spec.double_support),
        step_time_cv=_u(rng, spec.step_time_cv),
        step_length_sd=_u(rng, spec.step_length_sd),
        step_width_sd=_u(rng, spec.step_width_sd),
        asym_length=_u(rng, spec.asym_length) * (1 if rng.random() < 0.5 else -1),
        asym_time=_u(rng, spec.asym_time),
        toe_out=np.deg2rad(_u(rng, spec.toe_out_deg)),
        knee_min_flex=np.deg2rad(_u(rng, spec.knee_min_flex_deg)),
        heel_strike_pitch=np.deg2rad(_u(rng, spec.heel_strike_pitch_deg)),
        toe_off_pitch=np.deg2rad(_u(rng, spec.toe_off_pitch_deg)),
        toe_clearance=_u(rng, spec.toe_clearance),
    )
    if gait.asym_length != 0.0:
        gait = dataclasses.replace(gait, asym_time=np.sign(gait.asym_length) * gait.asym_time)
    clothing = spec.clothing[int(rng.integers(len(spec.clothing)))]
    shape = B.BodyShape(
        girth=_u(rng, spec.girth),
        calf_bulge=_u(rng, (0.7, 1.4)),
        shoe_scale=_u(rng, (0.92, 1.08)),
        clothing=clothing,
        ease=_u(rng, (0.008, 0.02)),
        baggy_radius=_u(rng, (0.10, 0.13)),
        hem_height=_u(rng, (0.02, 0.06)),
        fold_amp=_u(rng, spec.fold_amp),
        fold_phase=tuple(float(x) for x in rng.uniform(0, 2 * np.pi, 6)),
        hem_lag=_u(rng, (0.04, 0.09)),
    )
    d0 = _u(rng, spec.user_distance)
    programme: list[Phase] = []
    start_x = -d0
    start_y = 0.0
    absent = _u(rng, spec.absent_start)
    if spec.stand_only:
        programme = [Phase(kind="stand", duration=float("inf"))]
    else:
        if absent > 0:
            # start out of view (off to the side and far back), walk in, stop at the walker
            dx = 2.6
            dy = float(rng.choice([-1.0, 1.0])) * 2.3
            start_x, start_y = -d0 - dx, dy
            heading = float(np.arctan2(-dy, dx))
            programme.append(Phase(kind="stand", duration=absent))
            programme.append(Phase(kind="approach", distance=float(np.hypot(dx, dy)), heading=heading))
            programme.append(Phase(kind="stand", duration=_u(rng, (0.6, 1.2))))
        else:
            programme.append(Phase(kind="stand", duration=_u(rng, spec.stand_start)))
        if spec.walk_bout[1] > 0:
            t = sum(ph.duration for ph in programme)
            while t < spec.duration + 2.0:
                wb = _u(rng, spec.walk_bout)
                sb = _u(rng, spec.stand_bout)
                programme += [Phase(kind="walk", duration=wb), Phase(kind="stand", duration=sb)]
                t += wb + sb + 1.5
        else:
            programme.append(Phase(kind="walk"))
    return ResolvedParams(
        camera_name=cam_name,
        intrinsics=intr,
        mount=mount,
        sensor=sensor,
        gait=gait,
        dims=dims,
        shape=shape,
        user_distance=d0,
        walker_lag=_u(rng, spec.walker_lag),
        programme=tuple(programme),
        start_x=start_x,
        start_y=start_y,
    )


def _simulate_walker(
    kin: GaitKinematics, *, d0: float, lag: float, t0: float, t1: float, start_y: float, start_x: float
) -> tuple[FloatArray, FloatArray]:
    """Walker X(t) on a 1 kHz grid: critically damped follower of pelvis X + d0 with velocity
    feed-forward (no lag in steady walking, smooth lag on speed changes), never rolling back.
    The walker only starts following once the user has reached it (absent-start scenario)."""
    dt = 1e-3
    t = np.arange(t0, t1 + dt, dt)
    px = kin.pelvis_x(t)
    vp = kin.pelvis_velocity(t)
    py = kin._pelvis_xy(t)[1]  # noqa: SLF001 - same package
    w = 1.0 / lag
    x = np.empty_like(t)
    xw, vw = 0.0, 0.0
    engaged = abs(start_y) < 0.3 and abs(start_x + d0) < 0.3
    vf = 0.0
    alpha = 1.0 - np.exp(-dt / lag)
    for i in range(len(t)):
        if not engaged and (xw - px[i]) < d0 + 0.15 and abs(py[i]) < 0.3:
            engaged = True
        if engaged:
            vf += alpha * (vp[i] - vf)  # low-passed user velocity (lag)
            acc = w * w * (px[i] + d0 - xw) + 2.0 * w * (vf - vw)
            vw = max(0.0, vw + acc * dt)
            xw += vw * dt
        x[i] = xw
    return t, x


def _walker_scene(
    intr: CameraIntrinsics, mount: CameraMount, *, parts: bool, rng: np.random.Generator
) -> tuple[FloatArray, FloatArray, NDArray[np.int8], FloatArray, FloatArray, tuple[float, float]]:
    """Floor + walker parts (rear wheels, rear posts, low side bars) in the camera frame, the parts alone
    (depth, cosine; inf where none), and the wheels' half track and rear distance (m)."""
    floor = mount.floor_plane()
    z, cos = floor_depth(intr, floor.normal, floor.offset)
    mat = np.where(np.isfinite(z), B.MAT_FLOOR, B.MAT_NONE).astype(np.int8)
    if not parts:
        return z, cos, mat, np.full_like(z, np.inf), np.zeros_like(cos), (WHEEL_HALF_TRACK, REAR_WHEELS)
    half_w = _u(rng, (0.26, 0.31))
    rear = _u(rng, (0.50, 0.62))  # wheels this far towards the user from the camera (m)
    wheel_r = _u(rng, (0.08, 0.10))
    meshes: list[B.Mesh] = []
    for s in (-1.0, 1.0):
        y = s * half_w - mount.lateral
        axle = np.array([-rear, y, wheel_r])
        meshes.append(B.cylinder_mesh(axle - [0, 0.018, 0], axle + [0, 0.018, 0], wheel_r, material=B.MAT_WALKER, n_theta=24))
        meshes.append(B.cylinder_mesh(axle + [0.0, 0, 0.0], axle + [0.02, 0, 0.95], 0.013, material=B.MAT_WALKER, n_len=12))
        meshes.append(B.cylinder_mesh(np.array([0.05, y, 0.24]), np.array([-rear, y, 0.24]), 0.012, material=B.MAT_WALKER, n_len=12))
    mesh = B.Mesh.concat(meshes)
    r = mount.rotation()
    c = np.array([0.0, mount.lateral, mount.height])
    v_cam = (mesh.vertices - c) @ r
    dw, _, cw = rasterize(v_cam, mesh.faces, intr)
    closer = dw < z
    return (np.where(closer, dw, z), np.where(closer, cw, cos), np.where(closer, B.MAT_WALKER, mat).astype(np.int8), dw, cw,
            (half_w, rear))


def _clutter(spec: SessionSpec, p: ResolvedParams, x_range: tuple[float, float], rng: np.random.Generator) -> tuple[B.Mesh, tuple[float, ...]]:
    if not spec.clutter:
        return B.Mesh.concat([]), ()
    wall = _u(rng, (1.1, 1.7)) if p.start_y == 0.0 else 3.2
    walls = (wall, -_u(rng, (1.1, 1.7)) if p.start_y == 0.0 else -3.2)
    boxes = []
    n = int(rng.integers(3, 8))
    for _ in range(n):
        side = rng.choice([-1.0, 1.0])
        y = side * _u(rng, (0.65, abs(walls[0 if side > 0 else 1]) - 0.15))
        x = _u(rng, (x_range[0] - 4.0, x_range[1] - 1.5))
        half = np.array([_u(rng, (0.1, 0.35)), _u(rng, (0.08, 0.25)), _u(rng, (0.15, 0.5))])
        yaw = _u(rng, (-0.5, 0.5))
        rz = np.array([[np.cos(yaw), -np.sin(yaw), 0], [np.sin(yaw), np.cos(yaw), 0], [0, 0, 1.0]])
        boxes.append(B.box_mesh(np.array([x, y, half[2]]), half, rz, material=B.MAT_CLUTTER, tiles=2))
    return B.Mesh.concat(boxes), walls


def _hem_centres(body: BodyState, dims: BodyDims, shape: B.BodyShape, dt: float) -> FloatArray:
    """Baggy hem centres: below the ankle, hanging, lagging the leg (first-order, clipped)."""
    target = body.ankle.copy()
    target[..., 2] -= dims.ankle_height - shape.hem_height
    out = np.empty_like(target)
    a = 1.0 - np.exp(-dt / max(shape.hem_lag, 1e-3))
    y = target[0].copy()
    for i in range(len(target)):
        y = y + a * (target[i] - y)
        dev = y[:, :2] - target[i, :, :2]
        n = np.linalg.norm(dev, axis=-1, keepdims=True)
        dev = dev * np.minimum(1.0, 0.035 / np.maximum(n, 1e-9))
        out[i, :, :2] = target[i, :, :2] + dev
        out[i, :, 2] = target[i, :, 2]
        y = out[i].copy()
    return out


def _walker_tilt(t: FloatArray, x: FloatArray, *, rms: float, step_hz: float, rng: np.random.Generator) -> FloatArray:
    """``(N, 2)`` pitch and roll (rad) of a rolling walker at times ``t`` (walker position ``x``).

    A walker rocks on its wheels as it rolls: at the step frequency, as the user leans on the handles
    at each step, and faster (4-12 Hz) over the floor's joints and bumps.  Each axis is half step-rate
    sway (with a slowly wandering phase) and half a sum of six bump sinusoids, normalised to unit
    RMS, scaled by ``rms`` times the walker's speed over its median speed while moving (capped at 1.5x): the
    tilt's RMS is about ``rms`` while the user walks, and a walker standing still does not rock.
    """
    dt = float(np.median(np.diff(t))) if t.size > 1 else 1.0
    v = np.abs(np.gradient(x, dt)) if t.size > 1 else np.zeros_like(t)
    k = max(1, int(round(0.3 / dt)))  # 0.3 s running mean: the rocking follows the speed smoothly
    v = np.convolve(v, np.ones(k) / k, mode="same")
    moving = v > 0.1
    v_walk = float(np.median(v[moving])) if moving.any() else 1.0
    gain = rms * np.clip(v / v_walk, 0.0, 1.5)
    out = np.empty((t.size, 2))
    for axis in range(2):
        wander = np.cumsum(rng.normal(0.0, 0.3 * np.sqrt(dt), t.size))  # rad of phase, a random walk
        sway = np.sin(2 * np.pi * step_hz * t + rng.uniform(0, 2 * np.pi) + wander)
        f = rng.uniform(4.0, 12.0, 6)
        ph = rng.uniform(0, 2 * np.pi, 6)
        bumps = np.sin(2 * np.pi * f[None, :] * t[:, None] + ph[None, :]).sum(axis=1)
        sig = sway + bumps / np.sqrt(6.0)  # variance 1/2 + 1/2: unit RMS
        out[:, axis] = gain * sig
    return out


def _tilt_rotations(tilt: FloatArray) -> FloatArray:
    """``(N, 3, 3)`` world-frame rotations of a walker pitched by ``tilt[:, 0]`` (about world Y) and rolled by
    ``tilt[:, 1]`` (about world X)."""
    cp, sp = np.cos(tilt[:, 0]), np.sin(tilt[:, 0])
    cr, sr = np.cos(tilt[:, 1]), np.sin(tilt[:, 1])
    n = tilt.shape[0]
    ry = np.zeros((n, 3, 3))
    ry[:, 0, 0], ry[:, 0, 2], ry[:, 1, 1], ry[:, 2, 0], ry[:, 2, 2] = cp, sp, 1.0, -sp, cp
    rx = np.zeros((n, 3, 3))
    rx[:, 0, 0], rx[:, 1, 1], rx[:, 1, 2], rx[:, 2, 1], rx[:, 2, 2] = 1.0, cr, -sr, sr, cr
    return rx @ ry


def _tilted_camera(
    r: FloatArray, mount: CameraMount, xw: FloatArray, tilt: FloatArray, *, wheels: tuple[float, float]
) -> tuple[FloatArray, FloatArray]:
    """World-from-camera rotations ``(N, 3, 3)`` and centres ``(N, 3)`` of the camera on a walker at ``xw`` tilted
    by ``tilt``.  The walker and its camera rock together about the wheels they tip onto: forward onto the front
    wheels (:data:`FRONT_WHEELS` ahead), back onto the rear ones (``wheels[1]`` behind), sideways onto one side's
    (``wheels[0]`` out), all on the floor, so the camera moves as well as turning."""
    j = _tilt_rotations(tilt)
    half_track, rear = wheels
    # pitch > 0 lowers +X (forward): the walker tips onto its front wheels; roll > 0 raises +Y: onto its -Y wheels
    px = np.where(tilt[:, 0] > 0, FRONT_WHEELS, -rear)
    py = np.where(tilt[:, 1] > 0, -half_track, half_track)
    arm = np.stack([-px, mount.lateral - py, np.full_like(px, mount.height)], axis=-1)  # camera from the pivot
    pivot = np.stack([xw + px, py, np.zeros_like(xw)], axis=-1)
    return j @ r, pivot + np.einsum("nij,nj->ni", j, arm)


def generate_session(spec: SessionSpec, *, rng: np.random.Generator) -> Session:
    """Generate a session (trajectories, ground truth; frames render lazily via :meth:`Session.frame`)."""
    p = _resolve(spec, rng)
    n_frames = int(round(spec.duration * spec.fps))
    stamps = np.arange(n_frames) / spec.fps
    t_end = float(stamps[-1]) if n_frames else 0.0
    feet = plan_footfalls(
        list(p.programme), p.gait, p.dims, start_x=p.start_x, start_y=p.start_y, t_end=t_end, rng=rng
    )
    kin = GaitKinematics(feet, p.gait, p.dims, t_start=0.0, t_end=t_end)
    wt, wx = _simulate_walker(kin, d0=p.user_distance, lag=p.walker_lag, t0=-1.0, t1=t_end + 1.0, start_y=p.start_y, start_x=p.start_x)
    body = kin.evaluate(stamps)
    xw = np.interp(stamps, wt, wx)
    r = p.mount.rotation()
    wfc = np.tile(np.eye(4), (n_frames, 1, 1))
    wfc[:, :3, :3] = r
    wfc[:, 0, 3] = xw
    wfc[:, 1, 3] = p.mount.lateral
    wfc[:, 2, 3] = p.mount.height
    walker_pose = np.stack([xw, np.zeros_like(xw), np.zeros_like(xw)], axis=-1)
    pts_w = body.leg_points()
    leg_points = ((pts_w - wfc[:, None, None, :3, 3]) @ r)
    plans = [f.arrays() for f in feet]
    events = gait_events(plans, foot_length=p.dims.foot_length, t_min=0.0, t_max=t_end)
    steps = gait_steps(plans, t_min=0.0, t_max=t_end)
    static_z, static_cos, static_mat, parts_z, parts_cos, wheels = _walker_scene(p.intrinsics, p.mount, parts=spec.walker_parts, rng=rng)
    clutter, walls = _clutter(spec, p, (float(xw.min()), float(xw.max())), rng)
    scene = SceneStatic(static_depth=static_z, static_cos=static_cos, static_mat=static_mat, clutter=clutter, walls_y=walls,
                        parts_depth=parts_z, parts_cos=parts_cos, wheels=wheels)
    seeds = rng.integers(0, 2**63 - 1, size=n_frames, dtype=np.int64).astype(np.uint64)
    hem = _hem_centres(body, p.dims, p.shape, 1.0 / spec.fps)
    tilt_fine = tilt = None
    rms = _u(rng, spec.vibration_deg) if spec.vibration_deg[1] > 0 else 0.0  # no draw when off: rigid sessions unchanged
    if rms > 0:
        tilt_fine = _walker_tilt(wt, wx, rms=np.deg2rad(rms), step_hz=p.gait.cadence / 60.0, rng=rng)
        tilt = np.stack([np.interp(stamps, wt, tilt_fine[:, k]) for k in (0, 1)], axis=-1)
        rots, centres = _tilted_camera(r, p.mount, xw, tilt, wheels=wheels)
        wfc[:, :3, :3] = rots
        wfc[:, :3, 3] = centres
        leg_points = np.einsum("tslj,tjk->tslk", pts_w - centres[:, None, None, :], rots)
    return Session(
        spec=spec,
        params=p,
        stamps=stamps,
        kinematics=kin,
        body=body,
        walker_pose=walker_pose,
        world_from_camera=wfc,
        leg_points=leg_points,
        floor=p.mount.floor_plane(),
        events=events,
        steps=steps,
        scene=scene,
        hem_centres=hem,
        frame_seeds=seeds,
        _walker_t=wt,
        _walker_x=wx,
        walker_tilt=tilt,
        _tilt=tilt_fine,
    )


def side_name(side: int) -> str:
    return Side(side).label
