"""Out-of-view hips placed over the feet: the reported pelvis where the seen legs and the base of support put it.

The camera at the walker sees the user's feet and lower calves; the hips and knees are above the image in almost
every frame (``BENCHMARKS.md``: hip 0 %, knee 0 % of the frames in view).  The particle filter weighs a pose by what
the camera sees, so every pose whose lower legs match the data scores alike wherever its pelvis stands, and the
tracked pelvis stays where the first frames put it: on the synthetic sessions 5-7 cm nearer the camera than the
centre of the feet (the true one stands about over it on average while walking), with the knees 4-11 deg straighter
and the thighs 5-8 deg more upright than the real ones (fifty-fifth session).  Moving the tracker's own pelvis that way
(``TrackerConfig.root_compensation``) fixed the hips but cost the seen feet a little.

This module leaves the tracking alone and corrects only what is reported: the pelvis is moved over the floor to
where the tracked ankles put it (:func:`pelvis_target`: the midpoint of the ankles averaged over about one stride,
``window_s``, plus a forward lean that grows from a standing user's to a walking one's with how far the feet swing
back and forth in that window) and turned to the feet's heading over that window (the tracked pelvis's turn is as
unobserved as its place: 5-10 deg RMS off on the synthetic sessions, where the true one keeps within 2-3 deg of the
feet's heading), the root height and the legs' joint angles but the ankle inversions are solved again
(damped Gauss-Newton) so that each leg's knee, ankle, heel and toe stay where they were tracked, and the hips and the
knees are reported from that solution, the toes as tracked but for their height (the heels and ankles below).  The thighs follow the
pelvis; the steps and the events are unchanged.  The angles are solved for the reported points themselves (which the
tracker reports as a weighted mean over its particles, with the toe measured from the data and flat feet levelled),
so they describe the pose the points show.

A user's thighs, calves and shoes keep their lengths, but the tracker's lengths are part of its state and wander
with it from frame to frame (sd 2.4 cm for the shoe within a session, where its error from one session to the next
is 1.2-1.6 cm): the placement reports each track with one length of each, the median over the track so far
(:func:`segment_lengths`) for the shoe (under a trouser hem, which hides the shoe's back, at least the typical
adult's: :func:`shoe_length`), the typical adult's for the thigh and the calf, which the camera does not see
(:data:`TYPICAL_THIGH_CALF_M`), each knee moved along its tracked calf to the calf's length and each heel along its
tracked foot (from the seen toe) to the shoe's length (live only a heel whose shoe the track has shown cleanly:
:meth:`LivePelvis.place`), reported a quarter of the way back to the tracked heel (:data:`TRACKED_HEEL_WEIGHT`: the
two err partly apart).  Each foot whose heel is placed so has its ankle reported halfway
(:data:`FOOT_ANKLE_WEIGHT`) between the tracker's and where the leg model puts the ankle in the placed foot
(:func:`foot_ankle`), its knee moved along the calf with it.  Last, the feet are put on the floor
(:func:`feet_on_floor`): a foot whose heel and toe both read within :data:`SHOE_FLAT_HEIGHT_M` of it stands flat and
has both on it, a toe or heel under the floor is raised onto it, the ankle moving with its foot.  The gait analysis
reads the heels, ankles and toes as tracked: live the placed pose keeps them as ``LegPose.heel_tracked``,
``ankle_tracked`` and ``toe_tracked`` (``LegTrack``'s), so that the live steps stay those of ``walker-gait process
--passes forward``.

The heel is hidden behind the shoe, so where it stands is the toe's place, the shoe's length and the foot's pitch;
the tracker holds a foot in its heel rise or swing several degrees off its pitch (its foot is fitted to the whole
leg's data), while the shoe's upper, the foot's best-seen surface, turns with a rigid shoe.  Offline each heel is put
behind the toe at the pitch its shoe's upper shows (:func:`shoe_pitch`: the upper's rise,
:func:`walker_gait.core.feet.measure_shoe_rise`, less its rise on the track's flat frames), where the upper is seen
cleanly enough to calibrate; and along the heading the shoe's centre line shows (:func:`shoe_heading`: the line
through the upper's points, :func:`walker_gait.core.feet.measure_shoe_turn`) where the foot stands flat, carried into
its heel rise and back to its heel strike (the tracker's foot's yaw, the end of the leg's chain, is 3-5 deg off);
live both over the track so far, the heading carried into the heel rise only (:class:`LivePelvis`).

The hips are reported the typical adult's :data:`TYPICAL_HIP_WIDTH_M` apart (the tracker's distance between them,
unseen, starts from the feet's and wanders).  The hips' height is the leg lengths', which nothing in view measures
either: given the user's measured leg length
(``leg_length_m``, the hip joint centre's standing height above the floor, as gait labs record it), the thighs and
calves are reported with it (:func:`with_leg_length`), otherwise as the typical adult's.

Frames: the poses are given in a floor-aligned frame (the walker frame of
:meth:`~walker_gait.core.types.FloorPlane.walker_transform`, z up) and ``mounting`` says how the body frame of
:mod:`~walker_gait.core.leg_model` (anatomical forward / left / up) lies in it.
"""

from __future__ import annotations

import dataclasses
import math
from collections import deque
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from walker_gait.core import leg_model as lm
from walker_gait.core.leg_model import StateLayout as L
from walker_gait.core.types import ANKLE, HEEL, HIP, KNEE, TOE, FloorPlane, LegPose, TrackStatus

FloatArray = NDArray[np.float64]

__all__ = [
    "CALF_OF_STATURE",
    "HEMMED_SHOE_M",
    "HEM_LOOSENESS",
    "HIP_HEIGHT_SHARE",
    "LEG_LENGTH_RANGE_M",
    "LivePelvis",
    "PLACE_WINDOW_S",
    "SHOE_CARRY_FRAMES",
    "SHOE_FLAT_FRAMES",
    "SHOE_FLAT_HEIGHT_M",
    "SHOE_RISE_FOLLOW",
    "SHOE_RISE_FOLLOW_FRAMES",
    "SHOE_RISE_MAD",
    "SHOE_TURN_JUMP",
    "SHOE_TURN_MAX",
    "STAND_LEAN_M",
    "THIGH_OF_STATURE",
    "THIGH_SHARE",
    "TRACKED_HEEL_WEIGHT",
    "TYPICAL_HIP_WIDTH_M",
    "TYPICAL_STATURE_M",
    "WALK_LEAN_M",
    "WALK_SWING_M",
    "calf_radii",
    "check_leg_length",
    "feet_on_floor",
    "foot_ankle",
    "held_points",
    "hemmed",
    "lean",
    "moved_pose",
    "pelvis_target",
    "place_pelvis",
    "place_poses",
    "pose_state",
    "segment_lengths",
    "shoe_heading",
    "shoe_length",
    "shoe_pitch",
    "support_sample",
    "with_leg_length",
    "with_lengths",
    "with_points",
]

PLACE_WINDOW_S = 1.0
"""Width (s) of the centred window over which the ankles are averaged: about one stride (two steps at
100-120 steps/min), so the swinging feet average out, and short enough to follow a user who drifts nearer the walker
or further from it (the walker lags its user when the walking starts and stops)."""

STAND_LEAN_M = 0.03
"""How far (m) a standing user's pelvis (mid-hip) stands ahead of the midpoint of the ankles: upright, the hips stand
over the ankles and the body's weight a little ahead of them (the line of gravity passes a few cm in front of the
ankle joints).  Synthetic sessions, frames whose feet hardly move (``out/exp57/truth2.py``): the true pelvis stands
+2.7 cm ahead of the ankles' 1 s mean (RMS 5.1 cm with the starts and stops) and 3.9 cm *behind* the centre of the
heels and toes, where the fifty-sixth session's placement put it."""
WALK_LEAN_M = 0.07
"""How far (m) a walking user's pelvis stands ahead of the midpoint of the ankles averaged over a stride: it passes
over each stance foot and leads it at mid stance, more so for a user who leans on a walker.  Synthetic sessions,
walking frames: +6.9 cm (RMS 7.5 before the offset, 2.7 after)."""
WALK_SWING_M = 0.20
"""Standard deviation (m) over the window of the ankles' fore-aft separation at and above which the user counts as
walking (:func:`lean`): walking, the separation swings by about plus or minus a step length (sd 0.2-0.47 m in the
synthetic sessions, median per scenario), standing it stays within noise."""

LIVE_LENGTHS_FRAMES = 1800
"""The live placement's segment lengths are the medians over at most this many of the track's last frames (a minute at
30 Hz): a user's lengths do not change, the bound keeps the cost of a frame bounded."""
LIVE_HEM_FRAMES = 10
"""The live placement judges a trouser hem (:func:`hemmed`) on the calves of at most this many of the track's last
frames.  A track's calves widen to a tube of loose fabric over its first frames (15-30 from the model's mean radius,
before a search took the shins' width, ``TrackerConfig.detect_calf_radius``); judged over the whole track so far, as
:func:`place_poses` judges it offline, the hem was recognised only once the loose frames outnumbered the tight ones,
some 35 frames in, and the heels of the frames in between stayed the tracker's short ones (eighty-first session, 27
forward passes of the bench's scenarios, other seeds and probes, tracked before that change: heels 3.476 -> 3.420 cm
on ``leg_track``, 3.198 -> 3.143 on ``leg_track_bridged``, 0.07-0.32 cm better in each of the eight sessions under
trouser hems, the same in every other; knees 0.005 and hips 0.008 cm worse)."""

SHOE_FLAT_HEIGHT_M = 0.02
"""A reported foot whose heel and toe are both lower than this (m above the floor) stands flat: its frames calibrate
the shoe's rise (:func:`shoe_pitch`)."""
SHOE_FLAT_FRAMES = 10
"""Flat frames of a foot a track needs before its shoe's rise is taken as calibrated."""
SHOE_RISE_MAD = math.radians(0.5)
"""Largest median absolute deviation (rad) of a shoe's rise over its flat frames for the rise to measure the foot's
pitch: a rigid upper seen clearly gives the same rise frame after frame (0.04-0.25 deg in every track of the sweep
sets C and B's ``normal``, ``asymmetric`` and ``occlusion`` sessions); a trouser hem over the shoe, or clutter taken
for it, does not (``baggy_trousers`` 0.68-2.6 deg, half the tracks of a user walking in from the side over 0.6), and
there the tracker's own pitch is kept (DEVELOPERS.md, fifty-ninth session)."""

SHOE_RISE_FOLLOW = 0.8
"""Smallest correlation, over a foot's frames off the flat, of the pitch its shoe's rise measures with the tracker's
pitch of it for a rise that scatters more than :data:`SHOE_RISE_MAD` over the flat frames to measure the pitch all the
same (:func:`shoe_pitch`).  Through a step a foot's pitch swings over tens of degrees, and a rigid upper seen less
cleanly (a lower-resolution camera's fewer points) follows that swing as the tracker's foot does, a few degrees off
it (0.85-0.97 on the sweep sets C and A: ``different_camera``, a ``stop_and_go`` and a ``normal`` track with a
flat-frame scatter of 0.5-1.2 deg, the rise's pitch 1.8-3.5 deg off in heel rise and swing where the tracker's was
4-7); a trouser hem's slope does not (-0.6 to 0.46: ``baggy_trousers``, ``slow_elderly``, the rise's pitch 10-37 deg
off).  DEVELOPERS.md, eighty-fifth and eighty-sixth sessions."""
SHOE_RISE_FOLLOW_FRAMES = 20
"""Frames off the flat a foot needs, with both its shoe's rise and the tracker's foot, before the correlation of
:data:`SHOE_RISE_FOLLOW` is judged (fewer: the flat-frame scatter alone decides, as before)."""

SHOE_CARRY_FRAMES = 5
"""A foot's heading measured flat is carried into the frames of its heel rise (the foot pivots about its toes) and
back into those after its heel strike (it pivots about its heel) as the mean of this many flat frames next to them
(:func:`shoe_heading`)."""
SHOE_CARRY_TOE_M = 0.04
"""A heading is carried into a heel rise while the reported toe stays lower than this (m above the floor): the toe
stays planted until the toe off, but the tracker holds a pivoting foot's tip up to a few centimetres off the floor
(a quarter of the heel-rise tips over 1 cm up: DEVELOPERS.md, thirty-third session), and at
:data:`SHOE_FLAT_HEIGHT_M` the carry broke off in 13 % of the heel-rise frames of the sweep set C's clean sessions,
whose heading was then the tracker's (10 deg RMS off against 1 deg carried).  DEVELOPERS.md, sixty-second session."""
HEEL_ON_FLOOR_M = 0.04
"""A reported foot whose toe is higher than its heel and whose heel is lower than this (m above the floor) stands on
its heel: flat, or landed on it and pivoting about it to foot flat.  Its heel is put on the floor, turned about the
toe at the foot's length (:func:`with_lengths`).  The toe's height is the tracker's, which stands a flat foot's toe a
few millimetres up, and the shoe's rise reads a landing foot's toe-up pitch short (3.4 deg on the sweep set C's
clean sessions, more the steeper the landing): the heel of a flat foot was reported 0.6 cm up and a landing one's
1.6 cm.  A foot about to land, its heel a few centimetres up with its toe higher, is put down a frame or two early.
DEVELOPERS.md, sixty-second session."""
FEET_ON_FLOOR = True
"""Whether the reported feet are put on the floor (:func:`feet_on_floor`): a foot whose heel and toe both read lower
than :data:`SHOE_FLAT_HEIGHT_M` stands flat, its sole on the floor, and no sole point is under the floor.  The heel
and the toe are points of the sole (GAITRite's footprint), but the tracker stands a flat foot's toe a few millimetres
up (it is measured from what stands above the segmentation's floor cut) and the placed heel follows it, and a toe
pitched down can dip under the floor: on the synthetic sweeps (eighty-seventh session's stored runs re-reported)
flat feet read 0.5-0.65 cm up on average, and 14 % of the toes were under the floor (4 % by more than 1 cm).  Put
on it, heels 2.33 -> 2.29 / 2.19 -> 2.14 / 2.46 -> 2.43 cm and toes 1.93 -> 1.85 / 2.03 -> 1.96 / 1.89 -> 1.83 on
good frames (sets C / A / B3), better in every scenario of the three sets; knees 0.04-0.08 cm and the ankle flexion
0.1-0.25 deg better.  DEVELOPERS.md, ninety-first session.  ``False``: the heights as placed."""
TRACKED_HEEL_WEIGHT = 0.25
"""Weight of the tracker's heel against the placed one (behind the toe at the shoe's length, pitch and heading) in
the reported heel of each foot whose heel is placed (0: the placed heel alone).  The placed heel is the better
estimate, but the two err partly apart (the tracker's foot is fitted to the data about the heel as well): on the
synthetic sweeps (eighty-seventh session's stored runs re-reported, good frames) the tracker's heels were 3.26 /
3.10 cm off (sets C / A), the placed ones 2.49 / 2.38, and a weight of 0.2 / 0.25 / 0.3 gave 2.34 / 2.33 / 2.34
(C), 2.20 / 2.19 / 2.18 (A) and 2.46 / 2.46 / 2.46 cm (B3: set B's ``slow_elderly``, ``baggy_trousers``,
``stop_and_go``), 0.5 gave 2.45 (C): better in every phase of the step and every scenario of C and A.  Inverse-variance
weights for independent errors would give the tracker's 0.37; the errors are correlated, and the measured minimum
lies at 0.2-0.3 on all three sets.  DEVELOPERS.md, ninetieth session."""
FOOT_ANKLE_WEIGHT = 0.5
"""Weight of the ankle where the leg model puts it in the placed foot (:func:`foot_ankle` of the reported heel and
toe) against the tracker's own in the reported ankle of each foot whose heel is placed (0: the tracker's).  The
two are estimates of one joint with errors of a size and largely apart: the tracker's ankle is fitted to the whole
leg's data (the calf's points pull it), the foot's is the better measured toe, shoe length and pitch with the
model's offsets.  On the synthetic sweeps (eighty-seventh session's stored runs re-reported, good frames) the
tracker's ankles were 2.42 / 2.29 / 2.38 cm off (sets C / A / B3), the foot's 2.11 / 2.03 / 2.05, their mean 1.89 /
1.77 / 1.91 (a weight of 0.75: 1.91 / 1.80 / 1.90); better in every scenario of the three sets.  The synthetic
ankle sits exactly at the model's offsets, a real one's place in a shoe varies with the foot and the shoe: with the
true ankle moved 1 cm within the foot either way, the mean stayed better than the tracker's alone (2.00-2.36 against
2.39-2.84 cm on set C).  Equal weights, not fitted: DEVELOPERS.md, ninetieth session."""
SHOE_TURN_JUMP = math.radians(2.0)
"""Largest median change (rad) of a shoe's measured heading from one flat frame to the next for its centre line to
be taken as the foot's heading (:func:`shoe_heading`): a planted foot does not turn, and a shoe seen clearly gives
the same line frame after frame (median 0.15-0.75 deg on the sweep set C's clean sessions); a trouser hem over the
shoe sways (4.3-5.4 deg under baggy trousers).  DEVELOPERS.md, sixtieth session."""
SHOE_TURN_MAX = math.radians(12.0)
"""Largest median turn (rad) of a shoe's centre line from the reported foot over the flat frames for the line to be
taken as the foot's heading (:func:`shoe_heading`): the tracker holds a flat foot's heading 3-5 deg RMS off; a line
that stays further from it is something else's (a trouser hem lying over the shoe: 15-47 deg on the sweep set B's
baggy trousers, some of which sway little enough to pass :data:`SHOE_TURN_JUMP`).  DEVELOPERS.md, sixtieth session."""

_HELD = [KNEE, ANKLE, HEEL, TOE]
"""The points of each leg a placed pelvis leaves where they were tracked."""
_FOOT = (ANKLE, HEEL, TOE)
"""The points the placement may move (:meth:`LivePelvis.place`) ..."""
_TRACKED = {ANKLE: "ankle_tracked", HEEL: "heel_tracked", TOE: "toe_tracked"}
"""... and the :class:`~walker_gait.core.types.LegPose` fields that keep the tracker's own."""
_SOLVED = np.array([L.ROOT_Z, *(L.ANGLES.start + 6 * side + j for side in (0, 1) for j in range(L.ANKLE_INV))])
"""The unknowns re-solved: the root height and each leg's hip (3), knee and ankle flexion angles.  The ankle
inversion stays as tracked: the foot's roll about its own axis is the one thing its ankle, heel and toe points pin
weakly, and solved it took up the difference between the reported feet (levelled when flat, the toe measured from
the data) and the model's, 1.2 deg further off the truth on the synthetic sessions."""
_GN_ITERATIONS = 8
_GN_DAMPING = 1e-4  # m^2 per unit^2 of the unknowns (rad, m): a small pull towards the pose as tracked
_GN_EPS = 1e-5
_GN_TOL = 1e-4  # rad / m: the largest change of an unknown in an iteration that ends the solve

_FLIP = {"facing_user": np.diag([-1.0, -1.0, 1.0]), "facing_forward": np.eye(3)}


def _flip(mounting: str) -> FloatArray:
    try:
        return _FLIP[mounting]
    except KeyError:
        msg = f"mounting must be 'facing_user' or 'facing_forward', got {mounting!r}"
        raise ValueError(msg) from None


def pose_state(points: FloatArray, angles: FloatArray) -> FloatArray:
    """A 23-D state for a reported pose: ``points`` ``(2, 5, 3)`` in the body frame, ``angles`` its 12 joint angles.

    The hips give the root and the pelvis's spherical offset, the points' distances the segment lengths (both legs
    averaged, as the state shares them), the radii are the model's mean; clipped to the model's limits."""
    p = np.asarray(points, dtype=np.float64)
    x = np.zeros(lm.STATE_DIM)
    x[L.SHAPE] = lm.MEAN_SHAPE
    right, left = p[1, HIP], p[0, HIP]
    d = left - right
    r = float(np.linalg.norm(d))
    x[L.HIP_DIST] = r
    x[L.HIP_AZ] = math.atan2(-d[0], d[1])
    x[L.HIP_EL] = math.asin(float(np.clip(d[2] / r, -1.0, 1.0))) if r > 0 else 0.0
    x[L.ROOT] = right
    x[L.LEN_THIGH] = float(np.mean(np.linalg.norm(p[:, HIP] - p[:, KNEE], axis=-1)))
    x[L.LEN_CALF] = float(np.mean(np.linalg.norm(p[:, KNEE] - p[:, ANKLE], axis=-1)))
    x[L.LEN_FOOT] = float(np.mean(np.linalg.norm(p[:, TOE] - p[:, HEEL], axis=-1)))
    x[L.ANGLES] = np.asarray(angles, dtype=np.float64)
    return lm.clip_to_limits(x[None])[0]


def held_points(points: FloatArray) -> FloatArray:
    """``(2, 4, 3)``: each leg's knee, ankle, heel and toe (the points a placed pelvis leaves where they were)."""
    return np.array(np.asarray(points, dtype=np.float64)[:, _HELD])


def _held_of(states: FloatArray) -> FloatArray:
    """``(P, 24)`` held points of the states' forward kinematics."""
    return lm.forward_kinematics(states).points[:, :, _HELD].reshape(len(states), -1)


def place_pelvis(state: FloatArray, held: FloatArray, pelvis_xy: FloatArray, *,
                 yaw: FloatArray | None = None) -> FloatArray:
    """``state`` with its pelvis centre (mid-hip) moved over the floor to ``pelvis_xy`` (body frame), turned about it
    to the azimuth ``yaw`` (rad, body frame; ``None``: as it is), and its root
    height and joint angles but the ankle inversions (``_SOLVED``) solved (damped Gauss-Newton on finite
    differences) so that the held points of its legs (:func:`held_points`) come as near ``held`` ``(2, 4, 3)`` as the
    model's lengths allow.  Vectorised:
    ``(F, 23)`` states with ``(F, 2, 4, 3)`` held points and ``(F, 2)`` places are solved together, each row until
    its own steps are below the tolerance."""
    single = np.ndim(state) == 1
    x = np.array(np.atleast_2d(state), dtype=np.float64)
    f = len(x)
    target = np.asarray(held, dtype=np.float64).reshape(f, -1)
    if yaw is not None:
        mid = lm.hip_positions(x).mean(axis=1)
        x[:, L.HIP_AZ] = np.broadcast_to(yaw, (f,))
        x = lm.clip_to_limits(x)
        x[:, L.ROOT] += mid - lm.hip_positions(x).mean(axis=1)
    x[:, [L.ROOT_X, L.ROOT_Y]] += np.atleast_2d(pelvis_xy) - lm.hip_positions(x).mean(axis=1)[:, :2]
    cols = _SOLVED
    n = len(cols)
    damping = _GN_DAMPING * np.eye(n)
    active = np.arange(f)
    for _ in range(_GN_ITERATIONS):
        xa = x[active]
        batch = np.repeat(xa[:, None], 1 + n, axis=1)  # (F, 1 + n, 23): the state, then one unknown nudged each
        batch[:, np.arange(1, 1 + n), cols] += _GN_EPS
        h = _held_of(batch.reshape(-1, lm.STATE_DIM)).reshape(len(xa), 1 + n, -1)
        res = h[:, 0] - target[active]  # (F, 24)
        jac_t = (h[:, 1:] - h[:, :1]) / _GN_EPS  # (F, n, 24): the Jacobian, transposed
        step = -np.linalg.solve(jac_t @ jac_t.transpose(0, 2, 1) + damping, (jac_t @ res[..., None]))[..., 0]
        xa[:, cols] += step
        x[active] = lm.clip_to_limits(xa)
        active = active[np.max(np.abs(step), axis=1) >= _GN_TOL]
        if not len(active):
            break
    return x[0] if single else x


def support_sample(points: FloatArray) -> FloatArray:
    """``(5,)`` of one pose's ``points`` ``(2, 5, 3)`` (body frame): the x and y of the midpoint of the two ankles,
    their fore-aft (x) separation, left minus right, and the x and y of the sum of the two feet's unit heel-to-toe
    directions over the floor (the feet's heading: their toe-outs cancel); NaN without them."""
    p = np.asarray(points, dtype=np.float64)
    a = p[:, ANKLE]
    feet = p[:, TOE, :2] - p[:, HEEL, :2]
    with np.errstate(invalid="ignore", divide="ignore"):
        heading = (feet / np.linalg.norm(feet, axis=-1, keepdims=True)).sum(axis=0)
    return np.array([0.5 * (a[0, 0] + a[1, 0]), 0.5 * (a[0, 1] + a[1, 1]), a[0, 0] - a[1, 0], *heading])


def lean(separations: FloatArray) -> float:
    """Forward offset (m) of the pelvis over the ankles' midpoint for a window of the ankles' fore-aft
    ``separations``: :data:`STAND_LEAN_M` for feet that stay put, :data:`WALK_LEAN_M` for feet that swing by
    :data:`WALK_SWING_M` (standard deviation) or more, linear in between."""
    swing = min(1.0, float(np.std(np.asarray(separations, dtype=np.float64))) / WALK_SWING_M)
    return STAND_LEAN_M + swing * (WALK_LEAN_M - STAND_LEAN_M)


def pelvis_target(samples: FloatArray) -> FloatArray:
    """``(3,)``: where (body frame x, y) and turned how (azimuth, rad) the pelvis is placed for a window of
    :func:`support_sample` rows ``(K, 5)``: facing the feet's mean heading, :func:`lean` ahead of the ankles' mean
    midpoint along it."""
    s = np.asarray(samples, dtype=np.float64)
    hx, hy = s[:, 3:5].sum(axis=0)
    yaw = math.atan2(hy, hx)
    return np.array([*(s[:, :2].mean(axis=0) + lean(s[:, 2]) * np.array([math.cos(yaw), math.sin(yaw)])), yaw])


THIGH_OF_STATURE = 0.245
"""The thigh's length (greater trochanter to knee) as a share of stature (Winter, *Biomechanics and Motor Control of
Human Movement*, segment lengths)."""
CALF_OF_STATURE = 0.246
"""The shank's length (knee to ankle) as a share of stature (Winter, as :data:`THIGH_OF_STATURE`)."""
THIGH_SHARE = THIGH_OF_STATURE / (THIGH_OF_STATURE + CALF_OF_STATURE)
"""The thigh's share of thigh + shank for a measured leg length (Winter's segment lengths as fractions of stature:
thigh 0.245, leg 0.246)."""
TYPICAL_STATURE_M = 1.70
"""The stature (m) of the typical adult whose thighs and calves are reported where the user's leg length is not
measured (:data:`TYPICAL_THIGH_CALF_M`): adult women average about 1.62 m and men 1.76 m in the United States and
western Europe, older adults a few centimetres less; 1.70 m lies between (a user far from it gives the measured leg
length, ``leg_length_m``)."""
LEG_LENGTH_RANGE_M = (0.5, 1.3)
"""Leg lengths (m) :func:`with_leg_length` accepts: adults' hips stand 0.65-1.05 m above the floor; a value outside
is a mistake (centimetres, a stature) rather than a user."""


TYPICAL_THIGH_CALF_M: tuple[float, float] | None = (THIGH_OF_STATURE * TYPICAL_STATURE_M,
                                                    CALF_OF_STATURE * TYPICAL_STATURE_M)
"""The thigh and calf lengths (m) reported where the user's leg length is not measured: the typical adult's,
Winter's shares of a :data:`TYPICAL_STATURE_M` stature (0.4165 and 0.4182 m, hips 0.835 m over the ankles).  Until
the eighty-ninth session these were the leg model's mean shape (:data:`~walker_gait.core.leg_model.MEAN_SHAPE`, 0.43
and 0.42 m, hips 0.85 m over the ankles: a 1.73 m adult's legs), which put the reported hips 2.6 cm too high on
average over the sweep sets C and A (the synthetic users' legs average 83.4 cm); with a 1.70 m adult's legs, the
same stored runs re-reported: hips C 5.96 -> 5.56, A 5.82 -> 5.65, B (three scenarios) 5.89 -> 5.36 cm, knees 0.04-0.06
cm better, live (C / A) hips 6.48 -> 6.31 / 6.63 -> 6.28 (DEVELOPERS.md, eighty-ninth session).  The tracker's own mean
shape is unchanged.  The camera sees neither the hips nor,
mounted as usual, the knees, so the tracker's thigh and calf lengths are carried by its dynamics alone: over the 64
sessions of sweep sets C and A (sixty-fifth session) each track's medians were uncorrelated with the user's
(correlation -0.13 / -0.04 for the thigh, 0.15 / -0.05 for the calf), their sum 6.0 / 6.6 cm off (RMS) where the
typical adult's is 4.4 / 4.4 cm off (the synthetic users' 83.1 / 83.7 cm on average, the typical 85); the reported
hips 6.65 -> 5.90 / 6.94 -> 5.82 cm, the knees 4.11 -> 4.04 / 4.93 -> 3.82, live 7.1 -> 6.6 and 5.3 -> 4.6 (both
sets).  Even a camera that sees the knees (``different_camera``) had the calves 1.6-7.2 cm short.  ``None``: the
tracked ones (the track's medians)."""


TYPICAL_HIP_WIDTH_M: float | None = 0.18
"""The distance (m) between the hip joint centres of the reported pelvis: the typical adult's (the hip joint centre
lies 0.33 of the pelvis's width plus 7 mm from its midline, Harrington et al., J. Biomech. 40 (2007); an adult's
pelvis, from one anterior superior iliac spine to the other, is about 0.25 m wide; the leg model's neutral stance).
The camera sees no hip, and the tracker's hip distance starts from the separation of the two leg blobs, the feet's,
which walk narrower than the hips, and is carried by its dynamics: over the sweep sets C and A it was 15.5 cm on
average (sd 2.0-2.3 cm within and between sessions) where the synthetic users' is 18.0 (sd 0.9), each reported hip
1.2 cm too near the midline.  Reported at this distance: hips C 5.56 -> 5.30, A 5.65 -> 5.38, B (three scenarios)
5.36 -> 5.04 cm, better in every scenario; knees 0.10-0.12 cm better; live (C / A) hips 6.31 -> 6.07 / 6.28 -> 6.04;
the joint angles' errors within 0.07 deg (hip abduction 0.11-0.16 better, hip rotation and ankle flexion 0.03-0.06
worse) (DEVELOPERS.md, eighty-ninth session).  ``None``: the tracked one."""


HIP_HEIGHT_SHARE = 0.530
"""The hip joint centre's (greater trochanter's) standing height as a share of stature (Winter's segment lengths):
what the refusal of a stature given as a leg length suggests instead."""


def check_leg_length(leg_length_m: float | None) -> float | None:
    """``leg_length_m`` as a float, ``None`` when not measured (``None`` or 0, the parameters' "not measured"), or
    a ``ValueError`` naming the accepted range (a string, NaN or a value outside :data:`LEG_LENGTH_RANGE_M`)."""
    if leg_length_m is None:
        return None
    lo, hi = LEG_LENGTH_RANGE_M
    number = isinstance(leg_length_m, (int, float, np.floating)) and not isinstance(leg_length_m, bool)
    if number and leg_length_m == 0:
        return None
    if not (number and lo <= leg_length_m <= hi):
        msg = (f"leg_length_m must be the standing height of the hip joint above the floor in metres, within "
               f"{lo}-{hi}, got {leg_length_m!r} (0 = not measured)")
        if number and hi < leg_length_m <= 2.5:
            msg += (f"; a stature? the hip joint stands at about {HIP_HEIGHT_SHARE} of it: "
                    f"{HIP_HEIGHT_SHARE * leg_length_m:.2f} m")
        elif number and 100 * lo <= leg_length_m <= 100 * hi:
            msg += f"; centimetres? {leg_length_m / 100:.2f} m"
        raise ValueError(msg)
    return float(leg_length_m)


HEMMED_SHOE_M: float | None = float(lm.MEAN_SHAPE[L.LEN_FOOT - L.LEN_THIGH])
"""The shortest shoe (m) reported for a track whose lower legs are loose fabric down to a hem (:func:`hemmed`): the
hem hides the back of the shoe, which the tracker then leaves out of its foot, so under it the tracked shoe is short
(on the synthetic sessions' baggy trousers every one of them, by 0.8-5.3 cm), never long; the model's typical adult
shoe (:data:`~walker_gait.core.leg_model.MEAN_SHAPE`) stands in for a length nothing in view measures, and a longer
tracked one is kept.  ``None``: the tracked length under a hem too."""
HEM_LOOSENESS = 0.5
"""A track is :func:`hemmed` when the median looseness of its calves (0 for a calf, 1 for a straight tube of fabric:
the model's :func:`~walker_gait.core.leg_model.calf_taper` between ``LOOSE_CALF_RADIUS``) is at least this."""


def hemmed(calf_radii: FloatArray) -> bool:
    """Whether the calves' proximal radii ``calf_radii`` (m, any shape: a track's frames and legs) are loose fabric
    down to a hem (:data:`HEM_LOOSENESS`); False where none is finite."""
    r = np.asarray(calf_radii, dtype=np.float64).ravel()
    r = r[np.isfinite(r)]
    if not r.size:
        return False
    lo, hi = lm.LOOSE_CALF_RADIUS
    return bool((float(np.median(r)) - lo) / (hi - lo) >= HEM_LOOSENESS)


def shoe_length(tracked: float, *, hem: bool) -> float:
    """The shoe's length (m) reported for a track whose tracked shoe is ``tracked`` long (its median): under a ``hem``
    at least :data:`HEMMED_SHOE_M`, else as tracked."""
    if hem and HEMMED_SHOE_M is not None and math.isfinite(tracked):
        return max(float(tracked), HEMMED_SHOE_M)
    return float(tracked)


def calf_radii(pose: LegPose) -> FloatArray:
    """``(2,)``: the pose's calves' proximal radii (m, what :func:`hemmed` reads), NaN where it carries none."""
    return np.full(2, np.nan) if pose.radii is None else np.asarray(pose.radii, dtype=np.float64)[:, 1, 0]


def segment_lengths(points: FloatArray) -> FloatArray:
    """``(3,)``: the median thigh (hip to knee), calf (knee to ankle) and foot (heel to toe) length over the frames of
    ``points`` ``(F, 2, 5, 3)`` whose points are all finite, both legs pooled (the model's legs share their lengths);
    NaN where there is no such frame."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 2, 5, 3)
    p = p[np.all(np.isfinite(p), axis=(1, 2, 3))]
    if not len(p):
        return np.full(3, np.nan)
    return np.array([np.median(np.linalg.norm(p[:, :, a] - p[:, :, b], axis=-1))
                     for a, b in ((HIP, KNEE), (KNEE, ANKLE), (TOE, HEEL))])


_UP = np.array([0.0, 0.0, 1.0])
_BACK = np.array([-1.0, 0.0, 0.0])  # body frame: the heel behind the toe


def with_lengths(states: FloatArray, held: FloatArray, *, thigh: float | FloatArray, calf: float | FloatArray,
                 foot: float | FloatArray | None = None,
                 foot_pitch: FloatArray | None = None,
                 foot_heading: FloatArray | None = None,
                 heel_sides: NDArray[np.bool_] | None = None) -> tuple[FloatArray, FloatArray]:
    """``states`` ``(F, 23)`` with these thigh and calf lengths (m) and ``held`` ``(F, 2, 4, 3)``
    (:func:`held_points`) with each knee moved along its tracked calf (the lower calf is in view, the knee is not) to
    the calf length; with a ``foot`` length also the states' feet of that length and each heel moved along its
    tracked foot from the toe (seen from the front the toe is in view, the heel behind the shoe is not), or, where
    ``foot_pitch`` ``(F, 2)`` (rad, the heel-to-toe line's elevation: negative heel-up) is finite, behind the toe along
    the tracked foot's heading at that pitch; where ``foot_heading`` ``(F, 2)`` (rad, the heel-to-toe line's azimuth
    in the floor's plane) is finite, behind the toe along that heading (at the pitch given, else the tracked
    foot's), then drawn :data:`TRACKED_HEEL_WEIGHT` of the way back to the held heel, and the ankle of each foot whose
    heel moved :data:`FOOT_ANKLE_WEIGHT` of the way to where the leg model puts it in the foot of the heel so placed
    (:func:`foot_ankle`, before that draw), the knee along the calf from it; with ``heel_sides`` ``(F, 2)`` only
    those heels and ankles move (the others stay as held)."""
    x = np.array(states, dtype=np.float64, copy=True)
    h = np.array(held, dtype=np.float64, copy=True)
    x[:, L.LEN_THIGH] = thigh
    x[:, L.LEN_CALF] = calf
    if foot is not None:
        x[:, L.LEN_FOOT] = foot
    x = lm.clip_to_limits(x)
    if foot is not None:
        toward = h[:, :, 2]
        if foot_heading is not None:
            heading = np.asarray(foot_heading, dtype=np.float64).reshape(len(x), 2)
            back = toward - h[:, :, 3]
            run = np.linalg.norm(back[..., :2], axis=-1)
            a = np.nan_to_num(heading)
            turned = h[:, :, 3] + np.stack([-np.cos(a) * run, -np.sin(a) * run, back[..., 2]], axis=-1)
            toward = np.where(np.isfinite(heading)[..., None], turned, toward)
        if foot_pitch is not None:
            pitch = np.asarray(foot_pitch, dtype=np.float64).reshape(len(x), 2)
            back = toward[..., :2] - h[:, :, 3, :2]
            run = np.linalg.norm(back, axis=-1, keepdims=True)
            flat = np.where(run > 1e-9, back / np.maximum(run, 1e-9), _BACK[:2])
            p = np.nan_to_num(pitch)[..., None]
            aimed = h[:, :, 3] + np.concatenate([np.cos(p) * flat, -np.sin(p)], axis=-1)  # one metre behind the toe
            toward = np.where(np.isfinite(pitch)[..., None], aimed, toward)
        moved = _on_heel(h[:, :, 3], _along(h[:, :, 3], toward, x[:, L.LEN_FOOT], _BACK))
        sides = np.ones((len(x), 2), dtype=bool) if heel_sides is None else np.asarray(
            heel_sides, dtype=bool).reshape(len(x), 2)
        # the ankle where the model has it in the placed foot (before the heel is drawn back towards the tracked one)
        if FOOT_ANKLE_WEIGHT > 0:
            ankle = (1.0 - FOOT_ANKLE_WEIGHT) * h[:, :, 1] + FOOT_ANKLE_WEIGHT * foot_ankle(moved, h[:, :, 3])
            h[:, :, 1] = np.where(sides[..., None] & np.isfinite(ankle), ankle, h[:, :, 1])
        heel = (1.0 - TRACKED_HEEL_WEIGHT) * moved + TRACKED_HEEL_WEIGHT * h[:, :, 2]
        h[:, :, 2] = np.where(sides[..., None], heel, h[:, :, 2])
    h[:, :, 0] = _along(h[:, :, 1], h[:, :, 0], x[:, L.LEN_CALF], _UP)
    return x, h


def foot_ankle(heel: FloatArray, toe: FloatArray) -> FloatArray:
    """``(..., 3)``: the ankle joint centre where the leg model puts it in a foot from ``heel`` to ``toe`` (body
    frame, z up): :data:`~walker_gait.core.leg_model.HEEL_BACK` of the foot's length ahead of the heel along the
    foot and :data:`~walker_gait.core.leg_model.ANKLE_HEIGHT` of it above the sole, in the vertical plane through
    the foot (the foot's roll, which heel and toe do not show, taken as none); NaN where heel and toe coincide or
    the foot stands upright."""
    d = np.asarray(toe, dtype=np.float64) - np.asarray(heel, dtype=np.float64)
    length = np.linalg.norm(d, axis=-1, keepdims=True)
    run = np.linalg.norm(d[..., :2], axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        along = d / length
        flat = d[..., :2] / run  # the foot's heading in the floor's plane
        # up in the foot's vertical plane, square to the foot: (-sin p * heading, cos p) for the foot's pitch p
        up = np.concatenate([-along[..., 2:3] * flat, run / length], axis=-1)
    ok = (length > 1e-9) & (run > 1e-9)
    out = heel + lm.HEEL_BACK * length * along + lm.ANKLE_HEIGHT * length * up
    return np.where(ok, out, np.nan)


def feet_on_floor(held: FloatArray) -> FloatArray:
    """``held`` ``(..., 4, 3)`` (:func:`held_points`: knee, ankle, heel, toe of each leg; body frame, z the height above
    the floor) with each foot whose heel and toe are both lower than :data:`SHOE_FLAT_HEIGHT_M` put on the floor (its
    heel and toe at height 0) and every other heel and toe under the floor raised onto it; each ankle moves up or
    down with its foot, by the heel's and the toe's changes in height interpolated at the ankle's place along the foot
    (:data:`~walker_gait.core.leg_model.HEEL_BACK` of the way from the heel).  Only heights change; NaN stays NaN."""
    h = np.array(held, dtype=np.float64, copy=True)
    heel, toe = h[..., 2, 2], h[..., 3, 2]
    flat = (heel < SHOE_FLAT_HEIGHT_M) & (toe < SHOE_FLAT_HEIGHT_M)
    new_heel = np.where(flat, 0.0, np.maximum(heel, 0.0))
    new_toe = np.where(flat, 0.0, np.maximum(toe, 0.0))
    rise = (1.0 - lm.HEEL_BACK) * (new_heel - heel) + lm.HEEL_BACK * (new_toe - toe)
    h[..., 1, 2] += np.where(np.isfinite(rise), rise, 0.0)
    h[..., 2, 2], h[..., 3, 2] = new_heel, new_toe
    return h


def _on_heel(toe: FloatArray, heel: FloatArray) -> FloatArray:
    """``heel`` ``(..., 3)`` (body frame) with each foot that stands on its heel (:data:`HEEL_ON_FLOOR_M`: its toe
    higher than its heel, its heel lower than that) turned about its ``toe`` until the heel is on the floor, the
    heel-to-toe distance and the heading kept."""
    back = heel - toe
    length = np.linalg.norm(back, axis=-1)
    flat = np.linalg.norm(back[..., :2], axis=-1)
    on = ((heel[..., 2] < HEEL_ON_FLOOR_M) & (toe[..., 2] > heel[..., 2]) & (toe[..., 2] < length)
          & (flat > 1e-9))
    run = np.sqrt(np.maximum(length**2 - toe[..., 2] ** 2, 0.0)) / np.maximum(flat, 1e-9)
    down = np.concatenate([toe[..., :2] + back[..., :2] * run[..., None], np.zeros_like(run)[..., None]], axis=-1)
    return np.where(on[..., None], down, heel)


def shoe_pitch(points: FloatArray, rise: FloatArray) -> FloatArray:
    """``(F, 2)`` each foot's pitch (rad, the heel-to-toe line's elevation: negative heel-up) over one track's frames
    ``points`` ``(F, 2, 5, 3)`` (body frame) from the rise of its shoe's visible upper ``rise`` ``(F, 2)``
    (:func:`walker_gait.core.feet.measure_shoe_rise`, NaN unmeasured): the shoe's own rise is the median over the
    frames whose reported foot stands flat (heel and toe below :data:`SHOE_FLAT_HEIGHT_M`), and a frame's pitch is
    that less its rise (a rigid shoe turned heel-up turns its upper with it).  NaN where unmeasured, and for a foot
    with fewer than :data:`SHOE_FLAT_FRAMES` flat frames measured, or whose rise over them scatters more than
    :data:`SHOE_RISE_MAD` unless the pitch it measures follows the tracker's foot through the frames off the flat
    (:data:`SHOE_RISE_FOLLOW`; no clean upper in view: a trouser hem over the shoe).

    On the synthetic sessions the pitch measured so is 1-4 deg off in heel rise and swing where the tracker's is 3-12
    deg (``out/exp59/pitchdiag.py``, DEVELOPERS.md, fifty-ninth session)."""
    pts = np.asarray(points, dtype=np.float64)
    r = np.asarray(rise, dtype=np.float64).reshape(len(pts), 2)
    out = np.full((len(pts), 2), np.nan)
    for side in (0, 1):
        down = (pts[:, side, HEEL, 2] < SHOE_FLAT_HEIGHT_M) & (pts[:, side, TOE, 2] < SHOE_FLAT_HEIGHT_M)
        flat = down & np.isfinite(r[:, side])
        off = ~down & np.isfinite(r[:, side])
        own = _own_rise(r[flat, side], r[off, side], _foot_pitch(pts[off, side]))
        if math.isfinite(own):
            out[:, side] = own - r[:, side]
    return out


def _foot_pitch(feet: FloatArray) -> FloatArray:
    """``(...)`` the pitch (rad, the heel-to-toe line's elevation: negative heel-up) of the feet of ``feet``
    ``(..., 5, 3)`` (``LEG_POINTS``, body frame)."""
    f = np.asarray(feet, dtype=np.float64)
    d = f[..., TOE, :] - f[..., HEEL, :]
    return np.arctan2(d[..., 2], np.hypot(d[..., 0], d[..., 1]))


def _own_rise(rises: FloatArray, off_rises: ArrayLike | None = None, off_pitch: ArrayLike | None = None) -> float:
    """A shoe's own rise: the median of its ``rises`` on flat frames; NaN for fewer than :data:`SHOE_FLAT_FRAMES`
    of them, or ones that scatter more than :data:`SHOE_RISE_MAD` unless over the frames off the flat the pitch the
    rise measures there (``off_rises``) follows the tracker's (``off_pitch``, rad) as :func:`_rise_follows` asks
    (:func:`shoe_pitch`)."""
    r = np.asarray(rises, dtype=np.float64)
    if len(r) < SHOE_FLAT_FRAMES:
        return math.nan
    own = float(np.median(r))
    if float(np.median(np.abs(r - own))) <= SHOE_RISE_MAD:
        return own
    if off_rises is not None and off_pitch is not None and _rise_follows(off_rises, off_pitch):
        return own
    return math.nan


def _rise_follows(rises: ArrayLike, pitch: ArrayLike) -> bool:
    """Whether the pitch a shoe's ``rises`` measure (its own rise less each: the sign turned) follows the tracker's
    foot ``pitch`` over the same frames off the flat: at least :data:`SHOE_RISE_FOLLOW_FRAMES` of them, correlated at
    least :data:`SHOE_RISE_FOLLOW`."""
    a = -np.asarray(rises, dtype=np.float64)
    b = np.asarray(pitch, dtype=np.float64)
    if len(a) < SHOE_RISE_FOLLOW_FRAMES or len(a) != len(b):
        return False
    a, b = a - a.mean(), b - b.mean()
    den = math.sqrt(float(a @ a) * float(b @ b))
    return den > 0.0 and float(a @ b) / den >= SHOE_RISE_FOLLOW


def _steady_turns(jumps: FloatArray, turns: FloatArray) -> bool:
    """Whether a foot's measured heading is steady enough over a track's flat frames (:func:`shoe_heading`): its
    ``jumps`` from one flat frame to the next (rad, absolute) at most :data:`SHOE_TURN_JUMP` and its ``turns`` from
    the reported foot at most :data:`SHOE_TURN_MAX` (medians)."""
    return (len(jumps) > 0 and float(np.median(jumps)) <= SHOE_TURN_JUMP
            and float(np.median(np.abs(np.asarray(turns, dtype=np.float64)))) <= SHOE_TURN_MAX)


def _steady(stance: FloatArray | list[float]) -> bool:
    """A stretch of flat frames whose heading holds (:func:`shoe_heading`'s per-stance gate): at least two frames,
    changing by at most :data:`SHOE_TURN_JUMP` from one to the next (the median)."""
    return len(stance) >= 2 and float(np.median(np.abs(_wrap(np.diff(stance))))) <= SHOE_TURN_JUMP


def _wrap(a: FloatArray) -> FloatArray:
    return np.angle(np.exp(1j * np.asarray(a, dtype=np.float64)))


def _runs(mask: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """The ``[start, stop)`` of each stretch of consecutive true values of ``mask``."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist()))


def _mean_angle(a: FloatArray) -> float:
    return float(np.angle(np.mean(np.exp(1j * np.asarray(a, dtype=np.float64)))))


def shoe_heading(points: FloatArray, turn: FloatArray) -> FloatArray:
    """``(F, 2)`` each foot's heading (rad, the heel-to-toe line's azimuth in the floor's plane) over one track's
    frames ``points`` ``(F, 2, 5, 3)`` (body frame) where its shoe's centre line measures it: the reported foot's
    heading turned by ``turn`` ``(F, 2)`` (:func:`walker_gait.core.feet.measure_shoe_turn`, NaN unmeasured) in the
    frames whose reported foot stands flat (heel and toe below :data:`SHOE_FLAT_HEIGHT_M`); carried from there
    (the mean of the :data:`SHOE_CARRY_FRAMES` flat frames next to them) into the following frames whose toe stays
    below :data:`SHOE_CARRY_TOE_M` (the heel rise: the foot pivots about its toes) and the frames before whose heel
    is down (after the heel strike: it pivots about its heel).  NaN elsewhere, and:

    * for a foot with fewer than :data:`SHOE_FLAT_FRAMES` flat frames measured;
    * for a foot whose measured heading changes by more than :data:`SHOE_TURN_JUMP` from one flat frame to the next
      (the median over the track: a planted foot does not turn; a trouser hem over the shoe sways) or whose line turns
      from the reported foot by more than :data:`SHOE_TURN_MAX` (the median over its flat frames: something else's
      line);
    * on a stretch of flat frames shorter than two or whose heading changes by more than :data:`SHOE_TURN_JUMP` from
      frame to frame (the median over the stretch: one stance whose line sways, as for a foot turned far from the
      tracked one, which the measured stretch cuts askew).

    On the synthetic sessions the flat feet's heading measured so is about 1 deg RMS off where the tracker's is 3-5
    (DEVELOPERS.md, sixtieth session).  A foot in the air tilts its shoe and the line moves with the ankle and the
    trouser above it: there it is no better than the tracker's."""
    pts = np.asarray(points, dtype=np.float64)
    tn = np.asarray(turn, dtype=np.float64).reshape(len(pts), 2)
    out = np.full((len(pts), 2), np.nan)
    for side in (0, 1):
        heel_down = pts[:, side, HEEL, 2] < SHOE_FLAT_HEIGHT_M
        toe_down = pts[:, side, TOE, 2] < SHOE_FLAT_HEIGHT_M
        toe_planted = pts[:, side, TOE, 2] < SHOE_CARRY_TOE_M
        flat = heel_down & toe_down & np.isfinite(tn[:, side])
        if int(flat.sum()) < SHOE_FLAT_FRAMES:
            continue
        d = pts[:, side, TOE, :2] - pts[:, side, HEEL, :2]
        heading = np.arctan2(d[:, 1], d[:, 0]) + tn[:, side]
        pairs = flat[1:] & flat[:-1]
        if not _steady_turns(np.abs(_wrap(np.diff(heading)[pairs])), tn[flat, side]):
            continue
        col = np.where(flat, _wrap(heading), np.nan)
        for start, stop in _runs(flat):
            if not _steady(heading[start:stop]):
                col[start:stop] = np.nan  # one planted foot's line that sways (or a single frame, which cannot tell)
                continue
            last = _mean_angle(heading[max(start, stop - SHOE_CARRY_FRAMES):stop])
            j = stop
            while j < len(pts) and toe_planted[j] and not flat[j]:
                col[j] = last
                j += 1
            first = _mean_angle(heading[start:min(stop, start + SHOE_CARRY_FRAMES)])
            j = start - 1
            while j >= 0 and heel_down[j] and not flat[j] and not np.isfinite(col[j]):
                col[j] = first
                j -= 1
        out[:, side] = col
    return out


def _along(start: FloatArray, end: FloatArray, length: FloatArray, fallback: FloatArray) -> FloatArray:
    """``(F, 2, 3)``: the point ``length`` ``(F,)`` from ``start`` towards ``end`` (towards ``fallback`` where they
    coincide)."""
    d = end - start
    norm = np.linalg.norm(d, axis=-1, keepdims=True)
    u = np.where(norm > 1e-9, d / np.maximum(norm, 1e-9), fallback)
    return start + length[:, None, None] * u


def with_leg_length(states: FloatArray, held: FloatArray, leg_length_m: float) -> tuple[FloatArray, FloatArray]:
    """``states`` ``(F, 23)`` with the thigh and calf lengths of a measured leg length (the hip joint centre's height
    above the floor standing: the thigh and the calf share it less the model's ankle height as :data:`THIGH_SHARE`
    says) and ``held`` ``(F, 2, 4, 3)`` (:func:`held_points`) with each knee moved along its tracked calf to the new
    calf length (:func:`with_lengths`).  The camera sees neither the thigh nor the knee, so the tracker's leg lengths
    are the model's guess (uncorrelated with the user's, :data:`TYPICAL_THIGH_CALF_M`); a clinic measures the leg
    length anyway (GAITRite and gait labs normalise by it)."""
    legs = leg_length_m - lm.ANKLE_HEIGHT * np.asarray(states, dtype=np.float64)[:, L.LEN_FOOT]
    return with_lengths(states, held, thigh=THIGH_SHARE * legs, calf=(1.0 - THIGH_SHARE) * legs)


def _shoe_measure(value: FloatArray | None) -> FloatArray:
    """A pose's ``shoe_rise`` or ``shoe_turn`` as ``(2,)`` (NaN: not measured)."""
    return np.full(2, np.nan) if value is None else np.asarray(value, dtype=np.float64).reshape(2)


def _placeable(pose: LegPose) -> bool:
    return (pose.status in (TrackStatus.TRACKING, TrackStatus.DEGRADED) and np.all(np.isfinite(pose.points))
            and np.all(np.isfinite(pose.angles)))


def place_poses(poses: Sequence[LegPose], *, mounting: str = "facing_user",
                window_s: float = PLACE_WINDOW_S, leg_length_m: float | None = None) -> list[LegPose]:
    """The poses (floor-aligned frame, see the module docstring) with each tracked frame's pelvis placed where the
    ankles in a centred window of ``window_s`` put it (:func:`pelvis_target`) and its hips, knees and joint angles
    re-solved with the knees, ankles, heels and toes held (:func:`place_pelvis`), the feet of the track's median
    length (:func:`segment_lengths`; under a trouser hem at least the typical shoe's, :func:`shoe_length`; a track
    ends at a frame that is ``NO_USER`` or ``SEARCHING``), the thighs and calves the typical adult's
    (:data:`TYPICAL_THIGH_CALF_M`), each knee moved along its tracked calf and each heel along its tracked foot to
    them (:func:`with_lengths`); with a measured ``leg_length_m`` the thighs
    and calves of that length (:func:`with_leg_length`).  Frames that are neither ``TRACKING`` nor ``DEGRADED`` or
    lack points or angles are returned as given; a pose the tracker held (the same points and angles as the frame
    before) is held as placed."""
    if not window_s > 0:
        raise ValueError(f"window_s must be > 0, got {window_s}")
    flip = _flip(mounting)
    leg_length_m = check_leg_length(leg_length_m)
    out = list(poses)
    idx = [i for i, p in enumerate(out) if _placeable(p)]
    if not idx:
        return out
    stamps = np.array([out[i].stamp for i in idx], dtype=np.float64)
    body = np.stack([np.asarray(out[i].points, dtype=np.float64) @ flip.T for i in idx])
    samples = np.stack([support_sample(p) for p in body])
    ok = np.all(np.isfinite(samples), axis=1)
    half = 0.5 * window_s
    rows, targets = [], []
    for k in range(len(idx)):
        near = ok & (np.abs(stamps - stamps[k]) <= half + 1e-9)
        if near.any():
            rows.append(k)
            targets.append(pelvis_target(samples[near]))
    if not rows:
        return out
    # one length of each segment per track: a frame without one (the user gone, a search) ends it
    track = np.cumsum([p.status in (TrackStatus.NO_USER, TrackStatus.SEARCHING) for p in out])[idx]
    lengths = np.full((len(idx), 3), np.nan)
    pitch = np.full((len(idx), 2), np.nan)
    heading = np.full((len(idx), 2), np.nan)

    rise = np.stack([_shoe_measure(out[i].shoe_rise) for i in idx])
    turn = np.stack([_shoe_measure(out[i].shoe_turn) for i in idx])
    calves = np.stack([calf_radii(out[i]) for i in idx])
    for t in np.unique(track):
        seg = segment_lengths(body[track == t])
        seg[2] = shoe_length(seg[2], hem=hemmed(calves[track == t]))
        lengths[track == t] = seg
        pitch[track == t] = shoe_pitch(body[track == t], rise[track == t])
        heading[track == t] = shoe_heading(body[track == t], turn[track == t])
    new, placed = _solve(body[rows], np.stack([out[idx[k]].angles for k in rows]), np.stack(targets), leg_length_m,
                         lengths[rows], pitch[rows], heading[rows])
    for j, k in enumerate(rows):
        i = idx[k]
        before = poses[i - 1] if i > 0 else None
        if before is not None and out[i - 1] is not before and np.array_equal(before.points, poses[i].points) \
                and np.array_equal(before.angles, poses[i].angles):
            # the tracker held its last pose (a blanked view): so is the placed one
            out[i] = with_points(poses[i], np.array(out[i - 1].points, dtype=np.float64),
                                 angles=out[i - 1].angles)
            continue
        out[i] = with_points(out[i], placed[j] @ flip, angles=lm.joint_angles(new[j]))
    return out


@dataclasses.dataclass
class _LiveShoe:
    """One foot's shoe measures over a live track so far (:meth:`LivePelvis.place`)."""

    rises: deque[float]  # the shoe's rise on its flat frames
    off_rises: deque[float]  # its rise on the frames off the flat ...
    off_pitch: deque[float]  # ... and the tracker's foot's pitch on them
    turns: deque[float]  # its turn on its flat frames
    jumps: deque[float]  # the heading's change from one flat frame to the next
    stance: list[float] = dataclasses.field(default_factory=list)  # the headings of the flat frames up to this one
    carry: float = math.nan  # the heading carried into the heel rise after the last stance


def _live_shoe() -> _LiveShoe:
    return _LiveShoe(*(deque(maxlen=LIVE_LENGTHS_FRAMES) for _ in range(5)))


class LivePelvis:
    """:func:`place_poses` frame by frame, for the live graph: the ankles' midpoint over the last ``window_s`` (a
    straight line fitted to it against time, read at the newest frame, so a user who walks in or drifts towards the
    walker is not left behind by half a window) with the lean of the feet's swing and their heading in that window
    (:func:`pelvis_target`), the same re-solve with the feet of the median length over the track's frames so far (at
    most :data:`LIVE_LENGTHS_FRAMES`; under a hem, judged on the last :data:`LIVE_HEM_FRAMES` frames' calves, at
    least the typical shoe's, :func:`shoe_length`) and the thighs
    and calves as :func:`place_poses` has them, and the heels placed as :func:`place_poses` places them, causally
    (:meth:`place`).  A frame without a track, a floor or time that runs backwards starts the history afresh; a pose
    the tracker held (the same points and angles as the last one placed: a blanked view) is held as placed.
    ``leg_length_m`` as :func:`place_poses`'s."""

    def __init__(self, *, mounting: str = "facing_user", window_s: float = PLACE_WINDOW_S,
                 leg_length_m: float | None = None) -> None:
        if not window_s > 0:
            raise ValueError(f"window_s must be > 0, got {window_s}")
        self._flip = _flip(mounting)
        self.leg_length_m = check_leg_length(leg_length_m)
        self.window_s = float(window_s)
        self._history: deque[tuple[float, FloatArray]] = deque()
        self._lengths = np.zeros((LIVE_LENGTHS_FRAMES, 2, 3))  # a ring of the frames' (thigh, calf, foot) per leg
        self._n_lengths = 0  # frames in it, this track
        # the calves' proximal radii of the track's last frames (NaN: none given), what a hem is judged on
        self._calves: deque[FloatArray] = deque(maxlen=LIVE_HEM_FRAMES)
        self._shoes = (_live_shoe(), _live_shoe())
        self._last: tuple[LegPose, LegPose] | None = None  # the last pose placed, as given and as placed

    def reset(self) -> None:
        self._history.clear()
        self._n_lengths = 0
        self._calves.clear()
        self._shoes = (_live_shoe(), _live_shoe())
        self._last = None

    def _shoe_frame(self, body: FloatArray, rise: FloatArray, turn: FloatArray
                    ) -> tuple[FloatArray, FloatArray, NDArray[np.bool_]]:
        """This frame's ``(2,)`` foot pitch and heading (NaN: not measured) and which feet show their shoe cleanly,
        from the track's frames so far: :func:`shoe_pitch` and :func:`shoe_heading` made causal (the heading is
        carried into a heel rise, not back to a heel strike)."""
        pitch, heading = np.full(2, np.nan), np.full(2, np.nan)
        clean = np.zeros(2, dtype=bool)
        for side, shoe in enumerate(self._shoes):
            heel_down = body[side, HEEL, 2] < SHOE_FLAT_HEIGHT_M
            toe_down = body[side, TOE, 2] < SHOE_FLAT_HEIGHT_M
            if heel_down and toe_down and math.isfinite(rise[side]):
                shoe.rises.append(float(rise[side]))
            elif math.isfinite(rise[side]):
                shoe.off_rises.append(float(rise[side]))
                shoe.off_pitch.append(float(_foot_pitch(body[side])))
            own = _own_rise(np.asarray(shoe.rises), shoe.off_rises, shoe.off_pitch)  # converted only when judged
            if math.isfinite(own):
                clean[side] = True
                pitch[side] = own - rise[side]
            flat = heel_down and toe_down and math.isfinite(turn[side])
            if flat:
                d = body[side, TOE, :2] - body[side, HEEL, :2]
                h = math.atan2(float(d[1]), float(d[0])) + float(turn[side])
                shoe.turns.append(float(turn[side]))
                if shoe.stance:
                    shoe.jumps.append(abs(float(_wrap(h - shoe.stance[-1]))))
                shoe.stance.append(h)
            elif shoe.stance:  # a stance ended: its last frames' heading goes on while the foot pivots on its toes
                steady = _steady(shoe.stance)
                shoe.carry = _mean_angle(shoe.stance[-SHOE_CARRY_FRAMES:]) if steady else math.nan
                shoe.stance = []
            if not flat and not body[side, TOE, 2] < SHOE_CARRY_TOE_M:  # the toe off: the heel rise is over
                shoe.carry = math.nan
            if len(shoe.turns) >= SHOE_FLAT_FRAMES and _steady_turns(np.asarray(shoe.jumps), np.asarray(shoe.turns)):
                clean[side] = True
                if flat and _steady(shoe.stance):
                    heading[side] = float(_wrap(shoe.stance[-1]))
                elif not flat:
                    heading[side] = shoe.carry
        return pitch, heading, clean

    def place(self, pose: LegPose, floor: FloorPlane) -> LegPose:
        """``pose`` (camera frame) with its pelvis placed (the walker frame of ``floor``); as given where it cannot
        be (no track, no valid floor).

        A foot whose shoe the track has shown cleanly so far (its rise calibrated as :func:`shoe_pitch` does, or its
        heading steady as :func:`shoe_heading` asks, over at least :data:`SHOE_FLAT_FRAMES` flat frames) has its heel
        placed behind its toe at the track's median foot length so far, at the pitch its shoe shows and, on flat
        frames and the heel rise after them, along the heading its shoe shows; the pose's shoe measures
        (``shoe_rise``, ``shoe_turn``) are what shows it.  A track whose calves are a tube of loose fabric down to a
        hem (:func:`hemmed`: a hem hides the shoe's back, so it is never shown cleanly) has both heels placed, along
        the tracked feet, at :func:`shoe_length`'s length: at least the typical shoe's, not the tracker's short one
        (at the tracked median the heels under baggy trousers were 0.5 cm worse placed, DEVELOPERS.md, sixty-first
        session; at this length 0.3-0.7 cm better, seventy-first).  Other heels stay the tracker's.
        A placed heel is drawn :data:`TRACKED_HEEL_WEIGHT` of the way back to the tracker's, and a foot whose heel is
        placed has its ankle placed too (:data:`FOOT_ANKLE_WEIGHT`); then every foot is put on the floor as
        :func:`feet_on_floor` says (:data:`FEET_ON_FLOOR`).  The ankles, heels and toes nothing moved stay the
        tracker's bit for bit, and a pose whose ankles, heels or toes moved keeps the tracker's as ``ankle_tracked``,
        ``heel_tracked`` or ``toe_tracked`` (what the gait analysis reads, :meth:`LegPose.as_tracked`)."""
        if not _placeable(pose) or not floor.usable:
            if pose.status in (TrackStatus.NO_USER, TrackStatus.SEARCHING):
                self.reset()
            return pose
        if self._history and pose.stamp <= self._history[-1][0]:
            self.reset()
        if self._last is not None and np.array_equal(self._last[0].points, pose.points) \
                and np.array_equal(self._last[0].angles, pose.angles):
            # the tracker held its last pose (a blanked view): so is the placed one
            held = self._last[1]
            return dataclasses.replace(with_points(pose, np.array(held.points, dtype=np.float64), angles=held.angles),
                                       heel_tracked=held.heel_tracked, ankle_tracked=held.ankle_tracked,
                                       toe_tracked=held.toe_tracked)
        rot, t = floor.walker_transform()
        walker = moved_pose(pose, rot, t)
        sample = support_sample(np.asarray(walker.points, dtype=np.float64) @ self._flip.T)
        if not np.all(np.isfinite(sample)):
            return pose
        self._history.append((pose.stamp, sample))
        while self._history[0][0] < pose.stamp - self.window_s:
            self._history.popleft()
        stamps = np.array([h[0] for h in self._history]) - pose.stamp
        samples = np.stack([h[1] for h in self._history])
        target = pelvis_target(samples)
        if stamps[0] < -0.5 * self.window_s:  # enough of a window for a slope
            coef = np.polyfit(stamps, samples[:, :2], 1)  # (2, 2): slope, value at the newest frame
            target[:2] += coef[1] - samples[:, :2].mean(axis=0)
        body = np.asarray(walker.points, dtype=np.float64) @ self._flip.T
        self._lengths[self._n_lengths % LIVE_LENGTHS_FRAMES] = np.linalg.norm(
            body[:, [HIP, KNEE, TOE]] - body[:, [KNEE, ANKLE, HEEL]], axis=-1)
        self._calves.append(calf_radii(pose))
        self._n_lengths += 1
        n = min(self._n_lengths, LIVE_LENGTHS_FRAMES)
        lengths = np.median(self._lengths[:n].reshape(-1, 3), axis=0)
        hem = hemmed(np.stack(self._calves))
        lengths[2] = shoe_length(lengths[2], hem=hem)
        pitch, heading, clean = self._shoe_frame(body, _shoe_measure(pose.shoe_rise), _shoe_measure(pose.shoe_turn))
        if hem:  # a shoe under a hem is never shown cleanly, and its length is not the tracker's short one: placed
            clean[:] = True
        if not clean.any():
            lengths[2] = np.nan  # every heel as tracked
        new, placed = _solve(body[None], np.asarray(pose.angles)[None], target[None], self.leg_length_m,
                             lengths[None], pitch[None], heading[None], heel_sides=clean[None])
        # the new hips and knees back in the camera frame, with the placed heels and ankles and every ankle, heel and
        # toe the placement moved (a foot put on the floor); the others stay the tracker's bit for bit
        pts = np.array(pose.points, dtype=np.float64, copy=True)
        pts[:, [HIP, KNEE]] = (placed[0][:, [HIP, KNEE]] @ self._flip - t) @ rot
        moved = np.any(placed[0][:, _FOOT] != body[:, _FOOT], axis=-1)  # (2, 3): side, ankle / heel / toe
        moved[clean, 0] |= FOOT_ANKLE_WEIGHT > 0
        moved[clean, 1] = True
        fields = {}
        for j, point in enumerate(_FOOT):
            pts[moved[:, j], point] = (placed[0][moved[:, j], point] @ self._flip - t) @ rot
            if moved[:, j].any() and getattr(pose, _TRACKED[point]) is None:  # what the gait analysis reads
                fields[_TRACKED[point]] = np.array(pose.points[:, point], dtype=np.float64)
        out = dataclasses.replace(with_points(pose, pts, angles=lm.joint_angles(new[0])), **fields)
        self._last = (pose, out)
        return out


def moved_pose(pose: LegPose, rot: FloatArray, t: FloatArray) -> LegPose:
    """``pose`` with its points and segments mapped by ``p -> rot @ p + t``."""
    segs = None if pose.segments is None else np.asarray(pose.segments, dtype=np.float64) @ rot.T + t
    return dataclasses.replace(pose, points=np.asarray(pose.points, dtype=np.float64) @ rot.T + t, segments=segs)


def _solve(points: FloatArray, angles: FloatArray, target: FloatArray, leg_length_m: float | None,
           lengths: FloatArray, foot_pitch: FloatArray | None = None,
           foot_heading: FloatArray | None = None,
           heel_sides: NDArray[np.bool_] | None = None) -> tuple[FloatArray, FloatArray]:
    """Poses ``points`` ``(F, 2, 5, 3)`` (body frame) with joint ``angles`` ``(F, 12)`` placed at ``target`` ``(F, 3)``
    (:func:`pelvis_target`'s x, y, azimuth), the hips :data:`TYPICAL_HIP_WIDTH_M` apart, with the thigh, calf and
    foot ``lengths`` ``(F, 3)`` of their tracks
    (:func:`segment_lengths`; NaN: as tracked, a NaN foot in any row: every heel as tracked), the thighs and calves
    of ``leg_length_m`` instead if given, and each heel (of ``heel_sides`` ``(F, 2)``, if given) at ``foot_pitch`` and
    ``foot_heading`` ``(F, 2)`` where finite (:func:`with_lengths`):
    the solved states ``(F, 23)`` and the points with the solution's hips and knees, the heels moved to the foot's
    length and the ankles with them (:func:`with_lengths`), the rest as given."""
    states = np.stack([pose_state(p, a) for p, a in zip(points, angles)])
    if TYPICAL_HIP_WIDTH_M is not None:
        states[:, L.HIP_DIST] = TYPICAL_HIP_WIDTH_M
    held = np.asarray(points, dtype=np.float64)[:, :, _HELD]
    lengths = np.asarray(lengths, dtype=np.float64).reshape(len(states), 3)
    tracked = states[:, [L.LEN_THIGH, L.LEN_CALF]]
    legs = np.where(np.isfinite(lengths[:, :2]), lengths[:, :2], tracked)
    if leg_length_m is None and TYPICAL_THIGH_CALF_M is not None:
        legs = np.broadcast_to(np.asarray(TYPICAL_THIGH_CALF_M, dtype=np.float64), legs.shape)
    foot = lengths[:, 2] if np.all(np.isfinite(lengths[:, 2])) else None
    states, held = with_lengths(states, held, thigh=legs[:, 0], calf=legs[:, 1], foot=foot,
                                foot_pitch=None if foot is None else foot_pitch,
                                foot_heading=None if foot is None else foot_heading, heel_sides=heel_sides)
    if leg_length_m is not None:
        states, held = with_leg_length(states, held, leg_length_m)
    if FEET_ON_FLOOR:
        held = feet_on_floor(held)
    new = place_pelvis(states, held, target[:, :2], yaw=target[:, 2])
    placed = np.array(points, dtype=np.float64, copy=True)
    placed[:, :, [HIP, KNEE]] = lm.forward_kinematics(new).points[:, :, [HIP, KNEE]]
    placed[:, :, [ANKLE, HEEL, TOE]] = held[:, :, [1, 2, 3]]
    return new, placed


def with_points(pose: LegPose, pts: FloatArray, *, angles: FloatArray | None = None) -> LegPose:
    """``pose`` with its points ``pts`` ``(2, 5, 3)`` (and joint ``angles``, if given), its segments moved with them:
    the thigh's and the calf's ends to the hip, knee and ankle, the foot's ends by the heel's and the toe's
    displacement."""
    old = np.asarray(pose.points, dtype=np.float64)
    segs = pose.segments
    if segs is not None and np.shape(segs) == (2, 3, 2, 3):
        segs = np.array(segs, dtype=np.float64, copy=True)
        segs[:, 0, 0], segs[:, 0, 1] = pts[:, HIP], pts[:, KNEE]  # thigh: hip -> knee
        segs[:, 1, 0], segs[:, 1, 1] = pts[:, KNEE], pts[:, ANKLE]  # calf: knee -> ankle
        segs[:, 2, 0] += pts[:, HEEL] - old[:, HEEL]  # foot: heel end, toe end
        segs[:, 2, 1] += pts[:, TOE] - old[:, TOE]
    return dataclasses.replace(pose, points=pts, segments=segs, angles=pose.angles if angles is None else angles)
