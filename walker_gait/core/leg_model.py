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
* calf: knee → ankle joint centre, radii ``rad_calf`` → ``calf_taper(rad_calf) * rad_calf`` (``CALF_TAPER``
  for a calf; loose fabric wider than ``LOOSE_CALF_RADIUS[0]`` hangs straighter, a tube at ``LOOSE_CALF_RADIUS[1]``);
* foot: half-cylinder with a flat base (the sole); its axis lies *in the sole*
  on the heel-toe line, radii ``FOOT_HEEL_RADIUS * len_foot`` →
  ``FOOT_TOE_RADIUS * len_foot``, its ends inset by those radii (``FOOT_CAP_INSET``) so
  that the rounded ends of the rendered capsule stop at the heel and toe points; the ankle joint centre is ``ANKLE_HEIGHT *
  len_foot`` above the sole and ``HEEL_BACK * len_foot`` in front of the heel.  The sole
  (floor contact) is ``2 * FOOT_HALF_WIDTH * len_foot`` wide; the tracker's ``elliptic_foot``
  option narrows the foot's cross-section to the same width (a half-ellipse as tall as the radius).
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

from walker_gait.core import kernels
from walker_gait.core.types import ANKLE, HEEL, HIP, KNEE, TOE, FloorPlane

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

STATE_DIM = 23

THIGH_TAPER = 0.72
"""Distal/proximal radius ratio of the thigh."""
CALF_TAPER = 0.62
"""Distal/proximal radius ratio of the calf (a leg, bare or in fitted trousers)."""
LOOSE_CALF_RADIUS = (0.09, 0.12)
"""Calf radii (m) over which the calf's taper relaxes from ``CALF_TAPER`` to 1: a lower leg wider than
any calf in fitted trousers is loose fabric, which hangs straight from the knee (baggy trousers: a
10-13 cm tube down to the hem), not a calf narrowing to the ankle (see :func:`calf_taper`)."""
FOOT_HEEL_RADIUS = 0.32
"""Foot half-cylinder radius at the heel end, as a fraction of foot length (~8.6 cm for a 27 cm
shoe).  It is the height of a shoe's top where the camera sees it, over the instep (~8.5-10 cm
from the heel counter to the laces), not the shoe's width: the radius tapers linearly to the toe,
and a thinner heel end (0.28, ~7.5 cm) left the model's top 2-2.5 cm under the instep, so the
filter pitched flat feet heel-up onto their toes to reach it (synthetic sweeps, flat-foot frames:
heel 3.3 cm above the floor, pitch -4.5 deg).  The collision test keeps the narrower
``COLLISION_FOOT_RADIUS`` (feet meet side by side, by their width)."""
FOOT_TOE_RADIUS = 0.15
"""Foot half-cylinder radius at the toe end, as a fraction of foot length (~4 cm for a 27 cm shoe:
half the forefoot width of a shoe, ~9-10 cm, and about the height of its toe box; a thinner toe
end leaves the front of the shoe, which is what the camera sees, unexplained and pulls the
model's foot forward and its heel up)."""
FOOT_HALF_WIDTH = 0.155
"""Half-width of the foot, fraction of foot length (~4.2 cm for a 27 cm shoe: shoes are ~7 cm wide at
the heel and ~9-10 cm at the ball, while the heel counter stands ~10 cm tall).  The sole spans
this much either side of the heel-toe line (floor contact, :func:`sole_heights`); with the
tracker's ``elliptic_foot`` the likelihood also gives the foot an elliptical cross-section this wide
and as tall as the radius (``FOOT_HEEL_RADIUS`` / ``FOOT_TOE_RADIUS``)."""
ANKLE_HEIGHT = 0.35
"""Ankle joint centre height above the sole, fraction of foot length (adult anthropometry:
ankle centre ~9.5 cm above the sole of a 27 cm shoe)."""
FOOT_CAP_INSET = 1.0
"""Inset of the foot axis ends, in units of the end radius (1 = the capsule's rounded ends reach
exactly the heel and toe points instead of overshooting them by a radius)."""
HEEL_BACK = 0.24
"""Horizontal heel-to-ankle distance, fraction of foot length (ankle centre ~6.5 cm in front of
the posterior-most sole point of a 27 cm shoe; heel-to-ankle distance ~11.5 cm)."""

COLLISION_CALF_RADIUS = LOOSE_CALF_RADIUS[0]
"""Largest calf radius (m) the collision test uses (``LOOSE_CALF_RADIUS[0]``): a wider lower leg is fabric
(baggy trousers), which gives way when the legs pass each other; the legs inside it are no wider."""

COLLISION_FOOT_RADIUS = 0.28
"""Foot radius at the heel end that the collision test uses, fraction of foot length (less than
``FOOT_HEEL_RADIUS``, which is the shoe's height: two feet passing each other meet by their sides)."""

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


# Internal layout: kinematics are computed component-major with the particle axis last, e.g.
# ``(3, 2, P)`` = [xyz, side, particle], and where possible with operands of one shape and
# contiguous, so that numpy takes its fast path for every small-array operation (these functions
# run many times per frame on ~100 particles, so call overhead rather than arithmetic dominates).
# The public ``(P, ...)`` arrays of :class:`Kinematics` are transposed copies made once per call.
#
# Rotations are kept as their *frame axes*: ``axes[k]`` is column k of the rotation matrix R (the
# local x/y/z axis in the body frame), so a chain of elementary rotations is applied by turning two
# axes at a time (:func:`_turn_axes`) instead of building and multiplying 3x3 matrices.  An
# elementary rotation by ``a`` in the (i, j) plane has E[i, i] = E[j, j] = cos a,
# E[j, i] = sin a = -E[i, j]: rotations about x, y and z are the planes (1, 2), (2, 0) and (0, 1).

_LEG_ROTATION_PLANES: tuple[tuple[int, int], ...] = ((2, 0), (1, 2), (0, 1), (2, 0), (2, 0), (1, 2))
"""Plane of each joint rotation of a leg, in chain (``JOINT_NAMES``) order: hip flexion (y),
abduction (x), rotation (z), knee flexion (y), ankle flexion (y), ankle inversion (x)."""
_LEG_ANGLE_SIGNS: FloatArray = np.array(
    [[-1.0, 1.0, -1.0, 1.0, -1.0, -1.0], [-1.0, -1.0, 1.0, 1.0, -1.0, 1.0]]
).T.reshape(6, 2, 1)
"""``(joint, side, 1)`` factors turning the state's joint angles into rotation angles:
``Ry(-flex) Rx(s*abd) Rz(-s*rot) Ry(knee) Ry(-dorsi) Rx(-s*inv)``, ``s = +1`` left, ``-1`` right."""
_RADIUS_INDEX = np.tile([L.RAD_THIGH, L.RAD_THIGH, L.RAD_CALF, L.RAD_CALF, L.LEN_FOOT, L.LEN_FOOT], 2)
_RADIUS_SCALE: FloatArray = np.tile([1.0, THIGH_TAPER, 1.0, CALF_TAPER, FOOT_HEEL_RADIUS, FOOT_TOE_RADIUS], 2)
"""``Kinematics.radii`` of a state ``x`` is ``(x[_RADIUS_INDEX] * _RADIUS_SCALE).reshape(2, 3, 2)``, the
distal calf radius then taken from :func:`calf_taper` (``CALF_TAPER`` here is its value for a calf)."""
_FOOT_START, _FOOT_END = 5, 6
"""Rows of the foot axis ends in :attr:`_Chain.ends` (after the 5 ``LEG_POINTS``)."""
_SEGMENT_ENDS = np.array([[HIP, KNEE, _FOOT_START], [KNEE, ANKLE, _FOOT_END]])
"""``(2, 3)`` rows of :attr:`_Chain.ends` holding the [proximal, distal] end of each of the SEGMENTS."""

# The 9 (left segment i, right segment j) pairs of the collision test, as fancy indices that gather
# ``(4, 3, 9, P)`` [p1, q1, p2, q2] x xyz x pair x particle from the kinematics.
_PAIR_SEG = np.array([np.repeat(np.arange(3), 3)] * 2 + [np.tile(np.arange(3), 3)] * 2)[:, None, :]
"""``(4, 1, 9)`` segment index of p1, q1 (left segment i) and p2, q2 (right segment j)."""
_PAIR_END = np.array([0, 1, 0, 1]).reshape(4, 1, 1)
_PAIR_SIDE = np.array([0, 0, 1, 1]).reshape(4, 1, 1)
_PAIR_XYZ = np.arange(3).reshape(1, 3, 1)
_PAIR_ROW = _SEGMENT_ENDS[_PAIR_END, _PAIR_SEG]
"""``(4, 1, 9)`` rows of :attr:`_Chain.ends` of p1, q1, p2, q2."""
_PAIR_RADIUS = (_PAIR_END[:, 0], _PAIR_SEG[:, 0], _PAIR_SIDE[:, 0])
"""Fancy index of ``radii.T`` ``(2, 3, 2, P)`` [end, segment, side, particle] giving the ``(4, 9, P)``
radii at p1, q1, p2, q2."""


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


@dataclass(frozen=True)
class _Chain:
    """Forward kinematics in the internal particle-last layout (see :func:`_chain`).

    ``ends`` (7, 3, 2, P): [LEG_POINTS + foot axis start/end, xyz, side, particle];
    ``lateral`` (3, 2, P): unit lateral foot axes; ``radii`` (P, 2, 3, 2) as in :class:`Kinematics`.
    """

    ends: FloatArray
    lateral: FloatArray
    radii: FloatArray

    def kinematics(self) -> Kinematics:
        """The public ``(P, ...)`` layout (new C-contiguous arrays)."""
        seg = np.take(self.ends, _SEGMENT_ENDS.T, axis=0)  # (3, 2, 3, 2, P) [segment, end, xyz, side, P]
        return Kinematics(
            segments=np.ascontiguousarray(seg.transpose(4, 3, 0, 1, 2)),
            radii=self.radii,
            points=np.ascontiguousarray(self.ends[: TOE + 1].transpose(3, 2, 0, 1)),
            foot_lateral=np.ascontiguousarray(self.lateral.transpose(2, 1, 0)),
        )

    def replace(self, rows: BoolArray, other: _Chain) -> None:
        """In place: the particles ``rows`` ``(P,)`` become those of ``other`` (``rows.sum()`` of them)."""
        self.ends[..., rows] = other.ends
        self.lateral[..., rows] = other.lateral
        self.radii[rows] = other.radii

    def segment_pairs(self) -> FloatArray:
        """``(4, 3, 9, P)`` [p1, q1, p2, q2] ends of the (left, right) segment pairs (:func:`_collisions`)."""
        return self.ends[_PAIR_ROW, _PAIR_XYZ, _PAIR_SIDE]

    def sole_heights(self) -> FloatArray:
        """``(2, P)`` lowest sole height of each foot (see :func:`sole_heights`)."""
        z = self.ends[:, 2]
        return _sole_heights(z[_FOOT_START], z[_FOOT_END], foot_half_width(self.radii[:, :, 2, 0].T), self.lateral[2])


def _turn_axes(axes: list[FloatArray], i: int, j: int, c: FloatArray, s: FloatArray) -> None:
    """``R <- R @ E`` for a rotation ``R`` stored as its frame axes (``axes[k]`` = column k).

    ``E`` is the elementary rotation in the (i, j) plane with cosine ``c`` and sine ``s`` (same
    shape as the axes); axes i and j are replaced by new arrays, the third one is unchanged.
    """
    ai, aj = axes[i], axes[j]
    new_i = ai * c
    new_i += aj * s
    new_j = aj * c
    new_j -= ai * s
    axes[i], axes[j] = new_i, new_j


def _fill_hips(
    xt: FloatArray, c_az: FloatArray, s_az: FloatArray, c_el: FloatArray, s_el: FloatArray, out: FloatArray
) -> None:
    """Hip joint centres into ``out`` ``(3, 2, P)`` [xyz, LEFT/RIGHT, particle].

    ``xt`` ``(23, P)`` are the states (transposed), ``c_az``..``s_el`` ``(P,)`` the cosines/sines of
    the pelvis azimuth and elevation; the left hip is at a spherical offset from the right one.
    """
    left, right = out[:, 0], out[:, 1]
    right[...] = xt[L.ROOT]
    np.multiply(s_az, c_el, out=left[0])
    np.negative(left[0], out=left[0])
    np.multiply(c_az, c_el, out=left[1])
    left[2] = s_el
    left *= xt[L.HIP_DIST]
    left += right


def _rotation_cos_sin(x: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Cosines and sines ``(14, P)`` of the rotation angles of ``(P, 23)`` states: [pelvis azimuth, elevation, the 12
    signed joint angles joint-major (``_LEG_ANGLE_SIGNS``)] x particle."""
    p = x.shape[0]
    xt = x.T
    ang = np.empty((14, p))
    ang[:2] = xt[L.HIP_AZ : L.HIP_EL + 1]
    leg_angles = xt[L.ANGLES].reshape(2, 6, p).transpose(1, 0, 2)  # [joint, side, particle]
    np.multiply(leg_angles, _LEG_ANGLE_SIGNS, out=ang[2:].reshape(6, 2, p))
    return np.cos(ang), np.sin(ang)


def _chain(x: FloatArray) -> _Chain:
    """Forward kinematics of ``(P, 23)`` float64 states in the internal layout.

    Both legs are computed together: all cosines/sines in one call each, then the leg chain of the
    module docstring applied to frame axes ``(3, 2, P)`` [xyz, side, particle].
    """
    p = x.shape[0]
    xt = x.T
    cos, sin = _rotation_cos_sin(x)
    # joint cosines/sines and segment lengths, broadcast once to the axes' shape (3, 2, P)
    c_leg, s_leg, lengths = np.empty((6, 3, 2, p)), np.empty((6, 3, 2, p)), np.empty((3, 3, 2, p))
    c_leg[...] = cos[2:].reshape(6, 1, 2, p)
    s_leg[...] = sin[2:].reshape(6, 1, 2, p)
    lengths[...] = xt[L.LEN_THIGH : L.LEN_FOOT + 1, None, None]
    l_thigh, l_calf, l_foot = lengths

    ends = np.empty((7, 3, 2, p))
    hip, knee, ankle, heel, toe, foot_start, foot_end = ends
    _fill_hips(xt, cos[0], sin[0], cos[1], sin[1], hip)
    # frame axes of each leg, starting from the pelvis yaw Rz(azimuth)
    yaw = np.zeros((3, 3, 2, p))
    yaw[0, 0] = yaw[1, 1] = cos[0]
    yaw[0, 1] = sin[0]
    np.negative(sin[0], out=yaw[1, 0])
    yaw[2, 2] = 1.0
    axes = list(yaw)

    def turn(joint: int) -> None:
        _turn_axes(axes, *_LEG_ROTATION_PLANES[joint], c_leg[joint], s_leg[joint])

    for joint in (0, 1, 2):  # thigh
        turn(joint)
    np.multiply(axes[2], l_thigh, out=knee)
    np.subtract(hip, knee, out=knee)
    turn(3)  # calf
    np.multiply(axes[2], l_calf, out=ankle)
    np.subtract(knee, ankle, out=ankle)
    for joint in (4, 5):  # foot
        turn(joint)
    fwd, lateral, up = axes
    back = -HEEL_BACK * l_foot  # heel / toe in the foot frame: (back, 0, -h) / (back + l_foot, 0, -h)
    down = up * (-ANKLE_HEIGHT * l_foot)
    np.multiply(fwd, back, out=heel)
    heel += down
    heel += ankle
    back += l_foot
    np.multiply(fwd, back, out=toe)
    toe += down
    toe += ankle
    # foot axis: heel/toe points inset by the end radii
    np.multiply(fwd, FOOT_CAP_INSET * (FOOT_HEEL_RADIUS * l_foot), out=foot_start)
    foot_start += heel
    np.multiply(fwd, FOOT_CAP_INSET * (FOOT_TOE_RADIUS * l_foot), out=foot_end)
    np.subtract(toe, foot_end, out=foot_end)
    radii = (x[:, _RADIUS_INDEX] * _RADIUS_SCALE).reshape(p, 2, 3, 2)
    radii[:, :, 1, 1] = x[:, L.RAD_CALF, None] * calf_taper(x[:, L.RAD_CALF])[:, None]
    return _Chain(ends=ends, lateral=lateral, radii=radii)


def calf_taper(rad_calf: FloatArray) -> FloatArray:
    """Distal/proximal radius ratio of the calf for proximal radii ``rad_calf``: ``CALF_TAPER`` up to
    ``LOOSE_CALF_RADIUS[0]``, rising linearly to 1 (a straight tube of loose fabric) at ``LOOSE_CALF_RADIUS[1]``."""
    lo, hi = LOOSE_CALF_RADIUS
    t = np.clip((np.asarray(rad_calf, dtype=np.float64) - lo) / (hi - lo), 0.0, 1.0)
    return CALF_TAPER + (1.0 - CALF_TAPER) * t


def hip_positions(states: FloatArray) -> FloatArray:
    """``(P, 2, 3)`` hip joint centres [LEFT, RIGHT] in the body frame (as :func:`_fill_hips`)."""
    x = np.atleast_2d(states)
    r, az, el = x[:, L.HIP_DIST], x[:, L.HIP_AZ], x[:, L.HIP_EL]
    right = x[:, L.ROOT]
    off = np.stack([-np.sin(az) * np.cos(el) * r, np.cos(az) * np.cos(el) * r, np.sin(el) * r], -1)
    return np.stack([right + off, right], axis=1)


_CHAIN_CONSTANTS: FloatArray = np.array([
    -HEEL_BACK, -ANKLE_HEIGHT, FOOT_HEEL_RADIUS, FOOT_TOE_RADIUS, FOOT_CAP_INSET, THIGH_TAPER, LOOSE_CALF_RADIUS[0],
    LOOSE_CALF_RADIUS[1] - LOOSE_CALF_RADIUS[0], CALF_TAPER, 1.0 - CALF_TAPER, FOOT_HALF_WIDTH / FOOT_HEEL_RADIUS,
    COLLISION_CALF_RADIUS, COLLISION_FOOT_RADIUS / FOOT_HEEL_RADIUS, COLLISION_SLACK, _LIMITS[L.ROOT_Z, 0],
    _LIMITS[L.ROOT_Z, 1],
])
"""The model's constants as the compiled chain (:func:`walker_gait.core._jit.leg_chain`) takes them, each the value
the numpy code computes with (``-HEEL_BACK``, the calf's taper span, ...)."""


def _compiled_kinematics(jit: object, x: FloatArray, *, constrain: bool) -> tuple[Kinematics, BoolArray]:
    """:func:`_chain` (and with ``constrain`` the floor contact and the collision test of :func:`enforce_constraints`,
    ``x`` shifted in place) by the compiled kernel: ``(kinematics, bad)``.  ``x`` ``(P, 23)`` C-contiguous float64."""
    p = x.shape[0]
    cos, sin = _rotation_cos_sin(x)
    kin = Kinematics(segments=np.empty((p, 2, 3, 2, 3)), radii=np.empty((p, 2, 3, 2)), points=np.empty((p, 2, 5, 3)),
                     foot_lateral=np.empty((p, 2, 3)))
    bad = np.zeros(p, dtype=bool)
    jit.leg_chain(x, cos, sin, _CHAIN_CONSTANTS, constrain, kin.segments, kin.radii,  # type: ignore[attr-defined]
                  kin.points, kin.foot_lateral, bad)
    return kin, bad


def forward_kinematics(states: FloatArray) -> Kinematics:
    """Vectorised forward kinematics of ``(P, 23)`` (or ``(23,)``) states, body frame."""
    x = np.ascontiguousarray(np.atleast_2d(np.asarray(states, dtype=np.float64)))
    jit = kernels.compiled()
    if jit is not None:
        return _compiled_kinematics(jit, x, constrain=False)[0]
    return _chain(x).kinematics()


def joint_angles(state: FloatArray) -> FloatArray:
    """The 12 joint angles (rad) of ``state`` in ``JOINT_NAMES`` order (``(..., 12)``)."""
    return np.asarray(state, dtype=np.float64)[..., L.ANGLES].copy()


def foot_half_width(heel_radius: FloatArray) -> FloatArray:
    """``FOOT_HALF_WIDTH * len_foot`` from the foot's heel radius (``FOOT_HEEL_RADIUS * len_foot``)."""
    return heel_radius * (FOOT_HALF_WIDTH / FOOT_HEEL_RADIUS)


def _sole_heights(z_heel: FloatArray, z_toe: FloatArray, half_width: FloatArray, lateral_z: FloatArray) -> FloatArray:
    """Lowest sole corner height from the foot axis end heights, the sole's half-width and the lateral
    axis z (broadcast)."""
    drop = half_width * lateral_z
    np.abs(drop, out=drop)
    low = np.minimum(z_heel, z_toe)
    low -= drop
    return low


def sole_heights(kin: Kinematics) -> FloatArray:
    """``(P, 2)`` lowest height (m, body z) of each foot's sole (its 4 corner points).

    The sole is the flat base of the foot, spanning ``±FOOT_HALF_WIDTH * len_foot`` laterally
    around the heel-toe axis (a shoe's width, whatever the section used for the likelihood), so
    its corners are heel/toe ± half-width * lateral; the lowest corner is at
    ``min(z_heel, z_toe) - |half-width * lateral_z|``.
    """
    z = kin.segments[:, :, 2, :, 2]
    return _sole_heights(z[..., 0], z[..., 1], foot_half_width(kin.radii[:, :, 2, 0]), kin.foot_lateral[:, :, 2])


def flatten_feet(
    points: FloatArray, soles: FloatArray, *, flat_below: float, blend_to: float, floor_tol: float
) -> FloatArray:
    """``points`` ``(P, 2, 5, 3)`` (``LEG_POINTS``, body frame) with each foot that stands on the floor nearly flat
    reported flat: for the reporting of a pose, not its tracking.

    A foot whose lowest sole corner (``soles`` ``(P, 2)``, :func:`sole_heights`) lies within ``floor_tol`` of the
    floor and whose heel-to-toe pitch ``p`` is under ``blend_to`` (rad, either way) has its ankle, heel and toe turned
    about its lower end (where the sole touches the floor: the toe end of a heel-up foot, the heel end of a toe-up
    one) in the foot's vertical plane to the pitch
    ``0`` while ``|p| <= flat_below``, and ``sign(p) (|p| - flat_below) blend_to / (blend_to - flat_below)`` up to
    ``blend_to``, where it is the foot's own again (continuous and monotonic: a heel rise or a landing foot's toe
    keeps its course).  Hips and knees are left as they are.

    A shoe standing on the floor has its sole on it.  A particle filter places each particle's lowest sole corner on
    the floor, so a spread of pitch among its particles lifts the mean heel and toe (each particle's other end up),
    and a model foot pitched a few degrees to fit a shoe's upper lifts the heel with it.
    """
    if not 0.0 <= flat_below < blend_to:
        raise ValueError(f"need 0 <= flat_below < blend_to, got {flat_below}, {blend_to}")
    out = np.array(points, dtype=np.float64)
    heel, toe = out[..., HEEL, :], out[..., TOE, :]
    d = toe[..., :2] - heel[..., :2]
    run = np.sqrt(np.einsum("...i,...i->...", d, d))
    pitch = np.arctan2(heel[..., 2] - toe[..., 2], run)  # > 0: heel up
    mag = np.abs(pitch)
    target = np.where(mag <= flat_below, 0.0, np.sign(pitch) * (mag - flat_below) * blend_to / (blend_to - flat_below))
    turn = np.where((mag < blend_to) & (np.asarray(soles) < floor_tol) & (run > 1e-6), pitch - target, 0.0)
    if not np.any(turn):
        return out
    u = np.zeros_like(heel)
    u[..., :2] = d / np.maximum(run, 1e-9)[..., None]
    # the sole touches the floor where the foot capsule's rounded end meets the sole axis (its segment end, inset
    # from the heel / toe point by the end's radius: :func:`sole_heights`); a pitched foot's end point itself dips
    # below that, so the turn is about the segment end and a flattened foot's heel and toe come to its height
    axis = toe - heel
    pivot = np.where((pitch > 0.0)[..., None], toe - axis * (FOOT_TOE_RADIUS * FOOT_CAP_INSET),
                     heel + axis * (FOOT_HEEL_RADIUS * FOOT_CAP_INSET))
    c, s = np.cos(turn)[..., None], np.sin(turn)[..., None]
    for j in (ANKLE, HEEL, TOE):
        rel = out[..., j, :] - pivot
        a = np.einsum("...i,...i->...", rel, u)[..., None]
        z = rel[..., 2:3]
        lateral = rel - a * u
        lateral[..., 2] = 0.0
        a2, z2 = a * c - z * s, a * s + z * c
        out[..., j, :] = pivot + lateral + a2 * u
        out[..., j, 2] = pivot[..., 2] + z2[..., 0]
    return out


def _dot3(u: FloatArray, v: FloatArray) -> FloatArray:
    """Dot products over the first axis (length 3, xyz) of broadcast ``u`` and ``v``, summed in order."""
    w = u * v
    out = w[0] + w[1]
    out += w[2]
    return out


def _closest_params(
    a: FloatArray, b: FloatArray, c: FloatArray, e: FloatArray, f: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Clamped closest-point parameters ``(s, t)`` of segment pairs ``p1 + s d1``, ``p2 + t d2``.

    Inputs (broadcast) are the dot products ``a = d1.d1``, ``b = d1.d2``, ``c = d1.r``,
    ``e = d2.d2``, ``f = d2.r`` with ``r = p1 - p2`` (Ericson, *Real-Time Collision Detection*
    §5.1.9); ``s`` and ``t`` have the broadcast shape.
    """
    eps = 1e-12
    denom = a * e - b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        # closest point of line 2 to segment 1 (s = 0 for parallel segments) ...
        s = np.minimum(np.maximum((b * f - c * e) / np.maximum(denom, eps), 0.0), 1.0)
        s = np.where(denom > eps, s, 0.0)
        # ... its parameter on segment 2; where that is clamped to an end (t = 0 or 1), s becomes
        # the clamped closest point of segment 1 to that end: (t b - c) / a
        t_free = (b * s + f) / np.maximum(e, eps)
        t = np.minimum(np.maximum(t_free, 0.0), 1.0)
        s_end = np.minimum(np.maximum((b * t - c) / np.maximum(a, eps), 0.0), 1.0)
        np.copyto(s, s_end, where=t != t_free)
    return s, t


def _closest_distances(
    p1: FloatArray, d1: FloatArray, s: FloatArray, p2: FloatArray, d2: FloatArray, t: FloatArray
) -> FloatArray:
    """``|(p1 + s d1) - (p2 + t d2)|`` for xyz-first ``(3, ...)`` points/directions and ``(...)`` s, t."""
    diff = p1 + d1 * s
    diff -= p2 + d2 * t
    diff *= diff
    dist = diff[0] + diff[1]
    dist += diff[2]
    return np.sqrt(dist)


def segment_distances(
    p1: FloatArray, q1: FloatArray, p2: FloatArray, q2: FloatArray
) -> FloatArray:
    """Minimum distance between 3D segments ``p1-q1`` and ``p2-q2`` (broadcast ``(..., 3)``).

    Vectorised clamped closest-point algorithm (Ericson, *Real-Time Collision Detection* §5.1.9).
    """
    arrays = [np.asarray(v) for v in (p1, q1, p2, q2)]
    ndim = max(v.ndim for v in arrays)
    # xyz first (internal layout): reverse the axes of all inputs padded to the same ndim
    p1, q1, p2, q2 = (v.reshape((1,) * (ndim - v.ndim) + v.shape).T for v in arrays)
    d1 = q1 - p1
    d2 = q2 - p2
    r = p1 - p2
    s, t = _closest_params(_dot3(d1, d1), _dot3(d1, d2), _dot3(d1, r), _dot3(d2, d2), _dot3(d2, r))
    return _closest_distances(p1, d1, s, p2, d2, t).T


def _collisions(pairs: FloatArray, radii: FloatArray, slack: float) -> BoolArray:
    """:func:`collisions` from the segment pairs ``(4, 3, 9, P)`` [p1, q1, p2, q2] x xyz x pair x particle.

    The same computation as :func:`segment_distances` on all 9 (left i, right j) pairs.
    """
    p1, q1, p2, q2 = pairs
    d1 = q1 - p1
    d2 = q2 - p2
    r = p1 - p2
    s, t = _closest_params(_dot3(d1, d1), _dot3(d1, d2), _dot3(d1, r), _dot3(d2, d2), _dot3(d2, r))
    dist = _closest_distances(p1, d1, s, p2, d2, t)  # (9, P)
    radii = radii.copy()
    np.minimum(radii[:, :, 1], COLLISION_CALF_RADIUS, out=radii[:, :, 1])  # bodies collide, not fabric
    radii[:, :, 2, 0] *= COLLISION_FOOT_RADIUS / FOOT_HEEL_RADIUS  # feet meet by their width, not their height
    r1, r1_end, r2, r2_end = radii.T[_PAIR_RADIUS]  # (9, P) radii at p1, q1, p2, q2
    thresh = r1 + r1_end
    thresh /= 2.0
    r2 += r2_end
    r2 /= 2.0
    thresh += r2
    thresh *= slack  # slack * (mean radius of segment 1 + mean radius of segment 2)
    return np.logical_or.reduce(dist < thresh, axis=0)


def collisions(kin: Kinematics, *, slack: float = COLLISION_SLACK) -> BoolArray:
    """``(P,)`` True where any left segment intersects any right segment (capsule test; calf radii capped at
    ``COLLISION_CALF_RADIUS``: loose fabric gives way; foot heel ends at ``COLLISION_FOOT_RADIUS``)."""
    pairs = kin.segments.transpose(1, 2, 3, 4, 0)[_PAIR_SIDE, _PAIR_SEG, _PAIR_END, _PAIR_XYZ]
    return _collisions(pairs, kin.radii, slack)


def clip_to_limits(states: FloatArray) -> FloatArray:
    """Box limits (in place on a copy); returns the clipped ``(P, 23)`` array."""
    x = np.maximum(states, STATE_LOWER)
    return np.minimum(x, STATE_UPPER, out=x)


def _lowest_sole(chain: _Chain) -> FloatArray:
    """``(P,)`` height of the lowest sole corner of both feet."""
    h = chain.sole_heights()
    return np.minimum(h[0], h[1])


def apply_floor_contact(states: FloatArray) -> FloatArray:
    """Shift the root height so that the lowest sole touches the floor (z = 0).

    This enforces "at least one foot on the floor, none below it" exactly; the root height
    is therefore not a free search dimension.  Returns a new ``(P, 23)`` array.
    """
    x = np.array(np.atleast_2d(states), dtype=np.float64)
    x[:, L.ROOT_Z] -= _lowest_sole(_chain(x))
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
    chain = _chain(np.nan_to_num(x))
    bad |= np.abs(_lowest_sole(chain)) > floor_tol
    bad |= _collisions(chain.segment_pairs(), chain.radii, COLLISION_SLACK)
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
    jit = kernels.compiled()
    if jit is not None:  # the same arithmetic, compiled (tested bit for bit)
        x = np.ascontiguousarray(x)  # (a Fortran-ordered input keeps its order through the clip)
        kin, bad = _compiled_kinematics(jit, x, constrain=True)
        if fallback is not None and bad.any():
            x[bad] = np.atleast_2d(fallback)[bad]
            sub, _ = _compiled_kinematics(jit, np.ascontiguousarray(x[bad]), constrain=False)
            for name in ("segments", "radii", "points", "foot_lateral"):
                getattr(kin, name)[bad] = getattr(sub, name)
        return x, kin, bad
    chain = _chain(x)
    dz = -_lowest_sole(chain)
    x[:, L.ROOT_Z] += dz
    chain.ends[:, 2] += dz  # the whole leg moves with the root
    z = x[:, L.ROOT_Z]
    bad = _collisions(chain.segment_pairs(), chain.radii, COLLISION_SLACK)
    bad |= (z < STATE_LOWER[L.ROOT_Z]) | (z > STATE_UPPER[L.ROOT_Z])
    if fallback is not None and bad.any():
        x[bad] = np.atleast_2d(fallback)[bad]
        chain.replace(bad, _chain(x[bad]))
    return x, chain.kinematics(), bad
