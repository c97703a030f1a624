"""Articulated lower-limb model of the seed paper (§4.1): 23-D state, tapered cylinders.

Frames
------
All kinematics are computed in a *body* frame that is the floor-aligned walker frame
(see :mod:`walker_gait.core.types`) rotated about the vertical so that, for the
user, +x is anatomical *forward*, +y anatomical *left* and +z up; the floor is the
plane z = 0.  With ``mounting="facing_user"`` (camera looks back at the user, who
walks towards walker -x) the body frame is the walker frame rotated by 180° about z,
with ``"facing_forward"`` it is the walker frame itself (see :class:`BodyFrame`).
Keeping the anatomical axes fixed makes left/right identity part of the state (the
left hip is always at +y of the right hip), so the tracker cannot swap legs.

State layout (23 elements, :class:`StateLayout`)
------------------------------------------------
====  =====================  ===========================================================
idx   name                   meaning (units)
====  =====================  ===========================================================
0     hip_dist               distance left hip - right hip (m)      } spherical coords of
1     hip_azimuth            pelvis yaw about +z (rad)              } the left hip relative
2     hip_elevation          pelvic obliquity (rad)                 } to the right hip
3-5   root_x/y/z             right hip joint centre, body frame (m)
6-8   len_thigh/calf/foot    segment lengths (m); foot = heel-to-toe length
9-10  rad_thigh/calf         proximal radii of thigh and calf (m)
11-16 left angles            JOINT_NAMES order: hip flexion, abduction, rotation,
                             knee flexion, ankle flexion, ankle inversion (rad)
17-22 right angles           same for the right leg
====  =====================  ===========================================================

The paper lists "lengths and widths of the cylinders" without the split; we use
3 lengths + 2 radii so the state has the paper's 23 elements: distal radii and the
foot's geometry follow fixed anthropometric ratios (module constants below).

Geometry
--------
* thigh: tapered cylinder from the hip joint centre to the knee joint centre,
  radii ``rad_thigh`` → ``THIGH_TAPER * rad_thigh``;
* calf: knee → ankle joint centre, radii ``rad_calf`` → ``CALF_TAPER * rad_calf``;
* foot: half-cylinder with a flat base (the sole); its axis lies *in the sole*
  on the heel-toe line, radii ``FOOT_HEEL_RADIUS * len_foot`` →
  ``FOOT_TOE_RADIUS * len_foot``, its ends inset by those radii (``FOOT_CAP_INSET``) so
  that the rounded ends of the rendered capsule stop at the heel and toe points; the ankle joint centre is ``ANKLE_HEIGHT *
  len_foot`` above the sole and ``HEEL_BACK * len_foot`` in front of the heel.
* output points (``LEG_POINTS``): hip/knee/ankle joint centres; heel = the
  posterior-most point of the foot at sole level (heel end of the sole axis);
  toe = anterior tip at sole level (toe end of the sole axis).

Joint angle conventions (``JOINT_NAMES``): with all angles 0 the leg is straight
and vertical and the foot points forward, flat.  Hip: flexion swings the thigh
forward, abduction away from the midline, internal rotation turns the knee towards
the midline; knee flexion bends the calf backwards; ankle flexion (dorsiflexion)
lifts the toes; inversion turns the sole towards the midline.  The leg chain is
``R_thigh = Rz(yaw) Ry(-flex) Rx(s*abd) Rz(-s*rot)``, ``R_calf = R_thigh Ry(knee)``,
``R_foot = R_calf Ry(-dorsi) Rx(-s*inv)`` with ``s = +1`` left, ``-1`` right.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from walker_gait.core.types import ANKLE, HEEL, HIP, KNEE, TOE, FloorPlane

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

STATE_DIM = 23

THIGH_TAPER = 0.72
"""Distal/proximal radius ratio of the thigh."""
CALF_TAPER = 0.62
"""Distal/proximal radius ratio of the calf."""
FOOT_HEEL_RADIUS = 0.28
"""Foot half-cylinder radius at the heel, as a fraction of foot length (~7.5 cm for a 27 cm
shoe: an effective radius of the ~10 cm tall, ~7 cm wide heel counter, so that the model's
surface reaches the observed top of the shoe and the ankle without pitching the foot)."""
FOOT_TOE_RADIUS = 0.15
"""Foot half-cylinder radius at the toe end, as a fraction of foot length (~4 cm for a 27 cm shoe:
half the forefoot width of a shoe, ~9-10 cm, and about the height of its toe box; a thinner toe
end leaves the front of the shoe, which is what the camera sees, unexplained and pulls the
model's foot forward and its heel up)."""
ANKLE_HEIGHT = 0.35
"""Ankle joint centre height above the sole, fraction of foot length (adult anthropometry:
ankle centre ~9.5 cm above the sole of a 27 cm shoe)."""
FOOT_CAP_INSET = 1.0
"""Inset of the foot axis ends, in units of the end radius (1 = the capsule's rounded ends reach
exactly the heel and toe points instead of overshooting them by a radius)."""
HEEL_BACK = 0.24
"""Horizontal heel-to-ankle distance, fraction of foot length (ankle centre ~6.5 cm in front of
the posterior-most sole point of a 27 cm shoe; heel-to-ankle distance ~11.5 cm)."""

COLLISION_SLACK = 0.75
"""Two capsules collide when their axes are closer than this times the sum of their mean radii
(soft tissue deforms: thighs of real people touch, so the check is deliberately lenient)."""


class StateLayout:
    """Indices into the 23-element state vector (see the module docstring)."""

    HIP_DIST = 0
    HIP_AZ = 1
    HIP_EL = 2
    ROOT = slice(3, 6)
    ROOT_X, ROOT_Y, ROOT_Z = 3, 4, 5
    LEN_THIGH, LEN_CALF, LEN_FOOT = 6, 7, 8
    RAD_THIGH, RAD_CALF = 9, 10
    SHAPE = slice(6, 11)
    ANGLES = slice(11, 23)
    LEFT = slice(11, 17)
    RIGHT = slice(17, 23)
    # offsets inside a leg block
    HIP_FLEX, HIP_ABD, HIP_ROT, KNEE_FLEX, ANKLE_FLEX, ANKLE_INV = range(6)

    NAMES: tuple[str, ...] = (
        "hip_dist", "hip_azimuth", "hip_elevation", "root_x", "root_y", "root_z",
        "len_thigh", "len_calf", "len_foot", "rad_thigh", "rad_calf",
        "left_hip_flexion", "left_hip_abduction", "left_hip_rotation", "left_knee_flexion",
        "left_ankle_flexion", "left_ankle_inversion",
        "right_hip_flexion", "right_hip_abduction", "right_hip_rotation", "right_knee_flexion",
        "right_ankle_flexion", "right_ankle_inversion",
    )  # fmt: skip

    @staticmethod
    def leg(side: int) -> slice:
        """State slice of the 6 joint angles of ``side`` (0 = LEFT, 1 = RIGHT)."""
        return StateLayout.LEFT if side == 0 else StateLayout.RIGHT

    @staticmethod
    def angle_mask() -> BoolArray:
        """Boolean ``(23,)`` mask of the joint-angle entries (constant-velocity dims, eq. 3)."""
        m = np.zeros(STATE_DIM, dtype=bool)
        m[StateLayout.ANGLES] = True
        return m


L = StateLayout

# Box limits (lower, upper) per state element; root x/y are loose (the ROI bounds them).
_LIMITS = np.array(
    [
        (0.12, 0.30),  # hip_dist
        (-0.7, 0.7),  # hip_azimuth (pelvis yaw)
        (-0.2, 0.2),  # hip_elevation (obliquity)
        (-4.0, 4.0),  # root x
        (-3.0, 3.0),  # root y
        (0.35, 1.40),  # root z
        (0.28, 0.58),  # len_thigh
        (0.28, 0.58),  # len_calf
        (0.18, 0.33),  # len_foot
        # radii: up to baggy trousers (hem radius 10-13 cm), which the camera sees instead of the leg
        (0.045, 0.14),  # rad_thigh
        (0.030, 0.13),  # rad_calf
    ]
    + [
        (-0.6, 1.3),  # hip flexion (extension 35 deg .. flexion 75 deg)
        (-0.35, 0.6),  # hip abduction
        (-0.7, 0.7),  # hip rotation
        (0.0, 1.7),  # knee flexion
        (-0.75, 0.55),  # ankle dorsiflexion
        (-0.5, 0.5),  # ankle inversion
    ]
    * 2
)
STATE_LOWER: FloatArray = _LIMITS[:, 0].copy()
STATE_UPPER: FloatArray = _LIMITS[:, 1].copy()

MEAN_SHAPE: FloatArray = np.array([0.43, 0.42, 0.26, 0.080, 0.055])
"""Typical adult (len_thigh, len_calf, len_foot, rad_thigh, rad_calf), metres."""


@dataclass(frozen=True)
class BodyFrame:
    """Rigid transforms between the body frame (anatomical axes, floor z=0) and the camera frame.

    ``p_camera = p_body @ body_to_cam_rot.T + body_to_cam_trans``.
    """

    body_to_cam_rot: FloatArray
    body_to_cam_trans: FloatArray

    @staticmethod
    def from_floor(floor: FloorPlane, *, mounting: str = "facing_user") -> BodyFrame:
        """Body frame for ``floor`` (camera frame) and the camera ``mounting``."""
        rot, t = floor.walker_transform()  # p_w = rot @ p_c + t
        if mounting == "facing_user":
            flip = np.diag([-1.0, -1.0, 1.0])
        elif mounting == "facing_forward":
            flip = np.eye(3)
        else:
            msg = f"mounting must be 'facing_user' or 'facing_forward', got {mounting!r}"
            raise ValueError(msg)
        # p_b = flip @ p_w = flip @ rot @ p_c + flip @ t  ->  p_c = rot.T @ flip.T @ (p_b - flip @ t)
        r_bc = flip @ rot
        t_bc = flip @ t
        return BodyFrame(body_to_cam_rot=r_bc.T, body_to_cam_trans=-(r_bc.T @ t_bc))

    def to_camera(self, pts: FloatArray) -> FloatArray:
        """``(..., 3)`` body-frame points to the camera optical frame."""
        return pts @ self.body_to_cam_rot.T + self.body_to_cam_trans

    def to_body(self, pts: FloatArray) -> FloatArray:
        """``(..., 3)`` camera-frame points to the body frame."""
        return (np.asarray(pts, dtype=np.float64) - self.body_to_cam_trans) @ self.body_to_cam_rot


def _rot(a: FloatArray, i: int, j: int) -> FloatArray:
    """``(..., 3, 3)`` rotations by ``a`` in the (i, j) plane (filled in place: no np.stack)."""
    a = np.asarray(a, dtype=np.float64)
    c, s = np.cos(a), np.sin(a)
    out = np.zeros(a.shape + (3, 3))
    k = 3 - i - j
    out[..., k, k] = 1.0
    out[..., i, i] = c
    out[..., j, j] = c
    out[..., i, j] = -s
    out[..., j, i] = s
    return out


def _rx(a: FloatArray) -> FloatArray:
    return _rot(a, 1, 2)


def _ry(a: FloatArray) -> FloatArray:
    return _rot(a, 2, 0)


def _rz(a: FloatArray) -> FloatArray:
    return _rot(a, 0, 1)


@dataclass(frozen=True)
class Kinematics:
    """Output of :func:`forward_kinematics` (body frame, metres).

    ``segments`` (P, 2, 3, 2, 3): [particle, side, SEGMENTS, proximal/distal, xyz]; the foot's
    proximal/distal ends lie on the heel-toe sole axis, inset from the heel/toe points by their radii
    (``FOOT_CAP_INSET``).
    ``radii`` (P, 2, 3, 2): radii at the segment ends.
    ``points`` (P, 2, 5, 3): LEG_POINTS.
    ``foot_lateral`` (P, 2, 3): unit lateral axis of each foot (sole plane, +y of the foot frame).
    """

    segments: FloatArray
    radii: FloatArray
    points: FloatArray
    foot_lateral: FloatArray


def hip_positions(states: FloatArray) -> FloatArray:
    """``(P, 2, 3)`` hip joint centres [LEFT, RIGHT] in the body frame."""
    x = np.atleast_2d(states)
    r, az, el = x[:, L.HIP_DIST], x[:, L.HIP_AZ], x[:, L.HIP_EL]
    right = x[:, L.ROOT]
    off = np.stack([-np.sin(az) * np.cos(el) * r, np.cos(az) * np.cos(el) * r, np.sin(el) * r], -1)
    return np.stack([right + off, right], axis=1)


def forward_kinematics(states: FloatArray) -> Kinematics:
    """Vectorised forward kinematics of ``(P, 23)`` (or ``(23,)``) states, body frame."""
    x = np.atleast_2d(np.asarray(states, dtype=np.float64))
    p = x.shape[0]
    hips = hip_positions(x)
    l_th, l_ca, l_ft = x[:, L.LEN_THIGH], x[:, L.LEN_CALF], x[:, L.LEN_FOOT]
    r_th, r_ca = x[:, L.RAD_THIGH], x[:, L.RAD_CALF]
    yaw = _rz(x[:, L.HIP_AZ])
    segments = np.empty((p, 2, 3, 2, 3))
    radii = np.empty((p, 2, 3, 2))
    points = np.empty((p, 2, 5, 3))
    lateral = np.empty((p, 2, 3))
    down = np.array([0.0, 0.0, -1.0])
    for side in (0, 1):
        s = 1.0 if side == 0 else -1.0
        a = x[:, L.leg(side)]
        r_thigh = yaw @ _ry(-a[:, 0]) @ _rx(s * a[:, 1]) @ _rz(-s * a[:, 2])
        r_calf = r_thigh @ _ry(a[:, 3])
        r_foot = r_calf @ _ry(-a[:, 4]) @ _rx(-s * a[:, 5])
        hip = hips[:, side]
        knee = hip + (r_thigh @ down) * l_th[:, None]
        ankle = knee + (r_calf @ down) * l_ca[:, None]
        heel_local = np.stack([-HEEL_BACK * l_ft, np.zeros(p), -ANKLE_HEIGHT * l_ft], -1)
        toe_local = heel_local + np.stack([l_ft, np.zeros(p), np.zeros(p)], -1)
        heel = ankle + np.einsum("pij,pj->pi", r_foot, heel_local)
        toe = ankle + np.einsum("pij,pj->pi", r_foot, toe_local)
        segments[:, side, 0, 0], segments[:, side, 0, 1] = hip, knee
        segments[:, side, 1, 0], segments[:, side, 1, 1] = knee, ankle
        fwd = r_foot[:, :, 0]
        r_heel, r_toe = FOOT_HEEL_RADIUS * l_ft, FOOT_TOE_RADIUS * l_ft
        segments[:, side, 2, 0] = heel + fwd * (FOOT_CAP_INSET * r_heel)[:, None]
        segments[:, side, 2, 1] = toe - fwd * (FOOT_CAP_INSET * r_toe)[:, None]
        radii[:, side, 0, 0], radii[:, side, 0, 1] = r_th, THIGH_TAPER * r_th
        radii[:, side, 1, 0], radii[:, side, 1, 1] = r_ca, CALF_TAPER * r_ca
        radii[:, side, 2, 0], radii[:, side, 2, 1] = r_heel, r_toe
        points[:, side, HIP], points[:, side, KNEE], points[:, side, ANKLE] = hip, knee, ankle
        points[:, side, HEEL], points[:, side, TOE] = heel, toe
        lateral[:, side] = r_foot[:, :, 1]
    return Kinematics(segments=segments, radii=radii, points=points, foot_lateral=lateral)


def joint_angles(state: FloatArray) -> FloatArray:
    """The 12 joint angles (rad) of ``state`` in ``JOINT_NAMES`` order (``(..., 12)``)."""
    return np.asarray(state, dtype=np.float64)[..., L.ANGLES].copy()


def sole_heights(kin: Kinematics) -> FloatArray:
    """``(P, 2)`` lowest height (m, body z) of each foot's sole (its 4 corner points).

    For the half-cylinder the sole is the flat base spanning ``±radius`` laterally
    around the heel-toe axis, so the corners are heel/toe ± radius * lateral.
    """
    seg = kin.segments[:, :, 2]  # (P,2,2,3) heel, toe
    rad = kin.radii[:, :, 2]  # (P,2,2)
    lat_z = kin.foot_lateral[:, :, 2]  # (P,2)
    z = seg[..., 2]  # (P,2,2)
    corners = z[..., None] + rad[..., None] * lat_z[:, :, None, None] * np.array([-1.0, 1.0])
    return corners.reshape(z.shape[0], 2, 4).min(axis=-1)


def segment_distances(
    p1: FloatArray, q1: FloatArray, p2: FloatArray, q2: FloatArray
) -> FloatArray:
    """Minimum distance between 3D segments ``p1-q1`` and ``p2-q2`` (broadcast ``(..., 3)``).

    Vectorised clamped closest-point algorithm (Ericson, *Real-Time Collision Detection* §5.1.9).
    """
    d1 = q1 - p1
    d2 = q2 - p2
    r = p1 - p2
    a = np.einsum("...i,...i->...", d1, d1)
    e = np.einsum("...i,...i->...", d2, d2)
    f = np.einsum("...i,...i->...", d2, r)
    c = np.einsum("...i,...i->...", d1, r)
    b = np.einsum("...i,...i->...", d1, d2)
    eps = 1e-12
    denom = a * e - b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(denom > eps, np.clip((b * f - c * e) / np.maximum(denom, eps), 0.0, 1.0), 0.0)
        t = (b * s + f) / np.maximum(e, eps)
        s = np.where(t < 0.0, np.clip(-c / np.maximum(a, eps), 0.0, 1.0), s)
        s = np.where(t > 1.0, np.clip((b - c) / np.maximum(a, eps), 0.0, 1.0), s)
        t = np.clip(t, 0.0, 1.0)
    c1 = p1 + d1 * s[..., None]
    c2 = p2 + d2 * t[..., None]
    return np.linalg.norm(c1 - c2, axis=-1)


def collisions(kin: Kinematics, *, slack: float = COLLISION_SLACK) -> BoolArray:
    """``(P,)`` True where any left segment intersects any right segment (capsule test)."""
    seg = kin.segments
    mean_r = kin.radii.mean(axis=-1)  # (P,2,3)
    # all 9 (left i, right j) pairs
    pl = seg[:, 0, :, None, 0]
    ql = seg[:, 0, :, None, 1]
    pr = seg[:, 1, None, :, 0]
    qr = seg[:, 1, None, :, 1]
    dist = segment_distances(pl, ql, pr, qr)  # (P,3,3)
    thresh = slack * (mean_r[:, 0, :, None] + mean_r[:, 1, None, :])
    return np.any(dist < thresh, axis=(1, 2))


def clip_to_limits(states: FloatArray) -> FloatArray:
    """Box limits (in place on a copy); returns the clipped ``(P, 23)`` array."""
    return np.clip(states, STATE_LOWER, STATE_UPPER)


def apply_floor_contact(states: FloatArray) -> FloatArray:
    """Shift the root height so that the lowest sole touches the floor (z = 0).

    This enforces "at least one foot on the floor, none below it" exactly; the root height
    is therefore not a free search dimension.  Returns a new ``(P, 23)`` array.
    """
    x = np.array(np.atleast_2d(states), dtype=np.float64)
    kin = forward_kinematics(x)
    low = sole_heights(kin).min(axis=1)
    x[:, L.ROOT_Z] -= low
    return x


def constraint_violations(states: FloatArray, *, floor_tol: float = 0.005) -> BoolArray:
    """``(P,)`` True where a state breaks a model constraint.

    Constraints: box limits on lengths, widths, angles and the hip geometry; at least one
    foot on the floor and no sole below it (``|min sole height| <= floor_tol`` m); no
    intersection between left and right segments (capsule test, :func:`collisions`).
    """
    x = np.atleast_2d(np.asarray(states, dtype=np.float64))
    tol = 1e-9
    bad = np.any((x < STATE_LOWER - tol) | (x > STATE_UPPER + tol), axis=1)
    bad |= ~np.all(np.isfinite(x), axis=1)
    kin = forward_kinematics(np.nan_to_num(x))
    low = sole_heights(kin).min(axis=1)
    bad |= np.abs(low) > floor_tol
    bad |= collisions(kin)
    return bad


def neutral_state(
    *, right_hip_xy: tuple[float, float] = (0.0, -0.09), hip_dist: float = 0.18
) -> FloatArray:
    """A standing pose (all joint angles 0, mean shape) on the floor, body frame."""
    x = np.zeros(STATE_DIM)
    x[L.HIP_DIST] = hip_dist
    x[L.ROOT_X], x[L.ROOT_Y] = right_hip_xy
    x[L.SHAPE] = MEAN_SHAPE
    x[L.ROOT_Z] = 1.0
    return apply_floor_contact(x[None])[0]


def _shift_kinematics(kin: Kinematics, dz: FloatArray) -> Kinematics:
    """Kinematics translated vertically by ``dz`` ``(P,)`` (body z)."""
    seg = kin.segments.copy()
    seg[..., 2] += dz[:, None, None, None]
    pts = kin.points.copy()
    pts[..., 2] += dz[:, None, None]
    return Kinematics(segments=seg, radii=kin.radii, points=pts, foot_lateral=kin.foot_lateral)


def enforce_constraints(
    states: FloatArray, *, fallback: FloatArray | None = None
) -> tuple[FloatArray, Kinematics, BoolArray]:
    """Make ``(P, 23)`` states satisfy every constraint of :func:`constraint_violations`.

    Box limits are enforced by clipping, floor contact by shifting the root height (the
    lowest sole touches z = 0); particles whose segments intersect (or whose projected
    root height leaves its limits) are replaced by the matching row of ``fallback`` (a
    valid state, e.g. the particle before diffusion), or flagged if no fallback is given.
    Returns ``(states, kinematics, replaced)`` with kinematics of the returned states.
    """
    x = clip_to_limits(np.atleast_2d(np.asarray(states, dtype=np.float64)))
    kin = forward_kinematics(x)
    dz = -sole_heights(kin).min(axis=1)
    x[:, L.ROOT_Z] += dz
    kin = _shift_kinematics(kin, dz)
    bad = collisions(kin)
    bad |= (x[:, L.ROOT_Z] < STATE_LOWER[L.ROOT_Z]) | (x[:, L.ROOT_Z] > STATE_UPPER[L.ROOT_Z])
    if fallback is not None and np.any(bad):
        fb = np.atleast_2d(fallback)
        x[bad] = fb[bad]
        kb = forward_kinematics(fb[bad])
        seg = kin.segments.copy()
        seg[bad] = kb.segments
        rad = kin.radii.copy()
        rad[bad] = kb.radii
        pts = kin.points.copy()
        pts[bad] = kb.points
        lat = kin.foot_lateral.copy()
        lat[bad] = kb.foot_lateral
        kin = Kinematics(segments=seg, radii=rad, points=pts, foot_lateral=lat)
    return x, kin, bad
