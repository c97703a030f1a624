"""Gait kinematics of a person walking behind a wheeled walker (world frame, exact ground truth).

World frame: X = direction of progression (the user walks towards +X), Y = the user's left,
Z = up, origin on the floor; metres, seconds, radians.

Model (planted feet by construction)
------------------------------------
1. **Footfall plan.** Heel-strike (HS) and toe-off (TO) times and planted heel positions are
   drawn per step from the session's gait parameters (cadence, step length/width, double
   support, step-to-step variability, left/right asymmetry, stand-still periods).  For a
   footfall of side ``s`` at ``T_i``, the opposite foot toes off at ``T_i + DS_i`` (DS = double
   support), so swing = step time − DS and stance = next step time + DS.
2. **Stance foot = rocker model** (Perry & Burnfield, *Gait Analysis*, 2nd ed. 2010: heel,
   ankle and forefoot rockers).  The sole pitch ``p`` (toes up positive) goes from the
   heel-strike pitch to 0 at foot-flat, stays 0, and falls to the toe-off pitch after heel-off.
   While ``p >= 0`` the foot rotates about the **heel point, which is fixed in the world**;
   while ``p < 0`` it rotates about the **toe point, fixed in the world** (heel and toe are
   both on the floor at ``p = 0``, so the hand-over is continuous).  No sliding, exactly.
3. **Pelvis.** Horizontal position: monotone PCHIP through mid-stance knots above the stance
   ankle (lateral sway towards the stance foot), pelvic rotation/obliquity splines.  Height:
   the highest pelvis position for which every planted foot is reachable with the knee flexed
   at least ``knee_min_flex`` (inverted-pendulum vaulting emerges from this), smoothed by an
   erosion followed by a Gaussian of smaller support so that the smoothed height never exceeds
   the reach bound.
4. **Swing leg** from normative sagittal joint-angle curves: the swing ankle trajectory and
   foot pitch are the forward kinematics of the normative hip/knee/ankle angles from the
   current hip centre, plus a minimum-jerk blend of the offsets needed to start exactly at the
   toe-off pose and end exactly at the planned heel-strike pose, plus toe-clearance lifting.
5. **Knee** from two-link inverse kinematics (hip centre → ankle centre), in the plane of the
   foot's heading.

Normative curves
----------------
Sagittal angles over the gait cycle ``phi`` in [0, 1) from heel strike, degrees::

    theta(phi) = a0 + sum_{n=1..6} a_n cos(2 pi n phi) + b_n sin(2 pi n phi)

The coefficients (:data:`NORMATIVE_FOURIER`) are a 6-harmonic least-squares fit (max error
< 0.9 deg) to key values read off the adult normal-cadence ensemble averages in
D. A. Winter, *Biomechanics and Motor Control of Human Movement*, 4th ed., Wiley 2009
(Appendix A gait data; also Winter, *The Biomechanics and Motor Control of Human Gait*, 1991),
cross-checked with Perry & Burnfield (2010) ch. 4-6.  Key values used (% cycle: deg)::

    hip   (flexion +):     0:25 10:22 20:13 30:5 40:-3 50:-9 55:-10 60:-6 65:2 70:11
                           75:19 80:24 85:27 90:28 95:27
    knee  (flexion +):     0:4 5:11 10:17 15:19 20:17 30:10 40:6 45:7 50:12 55:22 60:36
                           65:50 70:60 73:62 80:54 85:40 90:22 95:8
    ankle (dorsiflexion +):0:0 5:-5 10:-3 20:4 30:8 40:10 45:10 50:5 55:-5 60:-15 63:-18
                           65:-17 70:-9 75:-3 80:0 90:1

These are approximations of the published curves (digitised key points, not the original data
table); they drive the swing phase, the stance phase being constrained by the planted foot.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy.interpolate import CubicSpline, PchipInterpolator
from scipy.ndimage import gaussian_filter1d, minimum_filter1d

from walker_gait.core.types import Side

FloatArray = NDArray[np.float64]

NORMATIVE_FOURIER: dict[str, tuple[float, tuple[float, ...], tuple[float, ...]]] = {
    # name: (a0, (a1..a6), (b1..b6)), degrees
    "hip": (
        11.008,
        (17.678, -2.893, -0.167, -0.107, -0.394, -0.049),
        (-3.616, -2.313, 1.456, -0.231, 0.038, -0.121),
    ),
    "knee": (
        23.860,
        (-1.862, -14.503, -1.537, -1.022, -0.395, -0.159),
        (-20.644, 6.264, 3.627, 0.664, 0.380, 0.196),
    ),
    "ankle": (
        -0.012,
        (-0.315, 0.051, -2.378, 2.074, -0.309, 0.241),
        (6.543, -7.292, 1.300, -1.013, -0.862, -0.056),
    ),
}
NORMATIVE_TOE_OFF_PHASE = 0.62
"""Toe-off as a fraction of the normative gait cycle (Winter 2009: ~60-62 %)."""
SWING_STALL_RATIO = 0.25
"""A swing whose ankle advances slower than this share of its mean speed somewhere mid-swing (or slides back) is
an artefact of the normative curves on a short stride, and advances along the min-jerk blend of its ends instead
(:meth:`GaitKinematics._forward_only`)."""

_BIG = 1.0e6  # "never" in seconds


def normative_angle(name: str, phi: FloatArray) -> FloatArray:
    """Normative sagittal angle ``name`` ('hip' | 'knee' | 'ankle') in radians at cycle phase ``phi``."""
    a0, a, b = NORMATIVE_FOURIER[name]
    phi = np.asarray(phi, dtype=np.float64)
    out = np.full(phi.shape, a0)
    for n, (an, bn) in enumerate(zip(a, b, strict=True), start=1):
        out = out + an * np.cos(2 * np.pi * n * phi) + bn * np.sin(2 * np.pi * n * phi)
    return np.deg2rad(out)


def min_jerk(s: FloatArray) -> FloatArray:
    """Minimum-jerk blend 10s^3 - 15s^4 + 6s^5 of ``s`` clipped to [0, 1]."""
    s = np.clip(s, 0.0, 1.0)
    return s**3 * (10.0 + s * (-15.0 + 6.0 * s))


# --------------------------------------------------------------------------- parameters
@dataclass(frozen=True, kw_only=True)
class BodyDims:
    """Skeleton dimensions (metres); foot values are for the shod foot (sole level)."""

    thigh_length: float = 0.42  # hip joint centre -> knee joint centre
    shank_length: float = 0.41  # knee joint centre -> ankle joint centre
    pelvis_width: float = 0.18  # distance between the hip joint centres
    foot_length: float = 0.27  # heel point -> toe point, sole level (shoe)
    ankle_height: float = 0.095  # ankle centre above the sole
    ankle_forward: float = 0.065  # ankle centre ahead of the heel point


@dataclass(frozen=True, kw_only=True)
class GaitParams:
    """Resolved per-session gait parameters (SI units)."""

    cadence: float = 100.0  # steps / min (mean)
    step_length: float = 0.55  # m, mean (GAITRite definition)
    step_width: float = 0.10  # m, mean heel-to-heel lateral distance
    double_support: float = 0.24  # each double-support period as a fraction of the step time
    step_time_cv: float = 0.025  # coefficient of variation of step time
    step_length_sd: float = 0.015  # m
    step_width_sd: float = 0.015  # m
    asym_length: float = 0.0  # left step length * (1 + a), right * (1 - a)
    asym_time: float = 0.0  # left step time * (1 + a), right * (1 - a)
    toe_out: float = np.deg2rad(6.0)  # foot progression angle (rad, outwards)
    knee_min_flex: float = np.deg2rad(5.0)  # minimum stance knee flexion (rad)
    heel_strike_pitch: float = np.deg2rad(18.0)  # sole pitch at HS (rad, toes up)
    toe_off_pitch: float = np.deg2rad(-40.0)  # sole pitch at TO (rad, toes down)
    foot_flat_frac: float = 0.14  # foot flat after HS, fraction of nominal stance time
    heel_off_frac: float = 0.45  # heel off, fraction of nominal stance time
    toe_clearance: float = 0.015  # m, minimum sole clearance in mid swing
    min_stance_width: float = 0.10  # m, heel-to-heel lateral distance standing (at least; feet cannot overlap)
    swing_clearance: float = 0.10  # m, lateral ankle-to-ankle distance as the swing foot passes the stance foot
    first_step_factor: float = 0.75  # first step of a bout relative to step_length
    pelvis_sway: float = 0.35  # lateral pelvis excursion as a fraction of the stance foot offset
    pelvis_rotation: float = np.deg2rad(4.0)  # transverse rotation amplitude (rad)
    pelvis_obliquity: float = np.deg2rad(3.0)  # frontal drop of the swing side (rad)
    trunk_lean: float = 0.10  # m, pelvis ahead of the stance ankle at mid stance

    @property
    def stance_width(self) -> float:
        """Heel-to-heel lateral distance while standing (m): the step width, but feet cannot overlap."""
        return max(self.step_width, self.min_stance_width)

    @property
    def step_time(self) -> float:
        """Mean step time (s)."""
        return 60.0 / self.cadence

    @property
    def speed(self) -> float:
        """Mean walking speed (m/s)."""
        return self.step_length / self.step_time


@dataclass(frozen=True, kw_only=True)
class Phase:
    """One phase of the walking programme.

    ``kind``: ``"stand"`` (both feet planted for ``duration`` s), ``"walk"`` (walk for
    ``duration`` s then stop with a closing step; ``duration=inf`` walks to the end),
    ``"approach"`` (walk ``distance`` m along ``heading``, then stop).
    """

    kind: str
    duration: float = float("inf")
    distance: float = 0.0
    heading: float = 0.0  # approach: walking direction (rad, CCW from +X)


@dataclass(kw_only=True)
class FootPlan:
    """Footfalls of one foot (index 0 is the initial standing position)."""

    hs: list[float] = field(default_factory=list)  # heel-strike time (s); -BIG for the initial stance
    to: list[float] = field(default_factory=list)  # toe-off time (s); +BIG when it never lifts
    heel: list[tuple[float, float]] = field(default_factory=list)  # planted heel (X, Y), floor level
    yaw: list[float] = field(default_factory=list)  # foot heading (rad, CCW from +X)
    bout: list[int] = field(default_factory=list)  # walking bout index (-1: initial stance)

    def arrays(self) -> dict[str, FloatArray]:
        return {
            "hs": np.asarray(self.hs, float),
            "to": np.asarray(self.to, float),
            "heel": np.asarray(self.heel, float).reshape(-1, 2),
            "yaw": np.asarray(self.yaw, float),
            "bout": np.asarray(self.bout, int),
        }


def _side_sign(side: int) -> float:
    """+1 for the left foot (towards +Y), -1 for the right."""
    return 1.0 if side == Side.LEFT else -1.0


def plan_footfalls(
    programme: list[Phase],
    params: GaitParams,
    dims: BodyDims,
    *,
    start_x: float,
    start_y: float = 0.0,
    t_end: float,
    rng: np.random.Generator,
) -> tuple[FootPlan, FootPlan]:
    """Draw the footfall sequence (times, planted heel positions) for ``programme``.

    The user starts standing with the pelvis at ``(start_x, start_y)`` facing +X, feet
    ``stance_width`` apart (also after a closing step).
    An infinite ``walk`` phase stops planning at ``t_end + 2`` s; after the last phase the user
    stands still.
    Returns ``(left, right)`` plans.
    """
    feet = (FootPlan(), FootPlan())
    ank = dims.ankle_forward
    for side in (Side.LEFT, Side.RIGHT):
        sgn = _side_sign(side)
        yaw = sgn * params.toe_out
        feet[side].hs.append(-_BIG)
        feet[side].to.append(_BIG)
        feet[side].heel.append(
            (start_x - ank * np.cos(yaw), start_y + sgn * params.stance_width / 2 - ank * np.sin(yaw))
        )
        feet[side].yaw.append(yaw)
        feet[side].bout.append(-1)

    t = 0.0
    bout = 0
    first_side = int(rng.integers(2))
    horizon = t_end + 2.0
    phases = list(programme)
    for ph in phases:
        if t >= horizon:
            break
        if ph.kind == "stand":
            t += ph.duration
            continue
        if ph.kind not in ("walk", "approach"):
            msg = f"unknown programme phase kind {ph.kind!r}"
            raise ValueError(msg)
        t = _plan_bout(feet, ph, params, t0=t, first_side=first_side, bout=bout, horizon=horizon, rng=rng)
        bout += 1
        first_side = 1 - first_side
    return feet


def _path_coord(foot: FootPlan, heading: float, origin: tuple[float, float]) -> float:
    """Coordinate of the foot's last heel along a path through ``origin`` with ``heading``."""
    hx, hy = foot.heel[-1]
    return (hx - origin[0]) * np.cos(heading) + (hy - origin[1]) * np.sin(heading)


def _plan_bout(
    feet: tuple[FootPlan, FootPlan],
    ph: Phase,
    params: GaitParams,
    *,
    t0: float,
    first_side: int,
    bout: int,
    horizon: float,
    rng: np.random.Generator,
) -> float:
    """Append one walking bout to ``feet``; returns the time the user is standing still again."""
    st_mean = params.step_time
    s = first_side
    other = 1 - s
    t_to = t0 + 0.25  # anticipatory postural adjustment before the first toe-off
    feet[s].to[-1] = t_to
    heading = 0.0
    if ph.kind == "approach":
        n_steps = max(1, int(np.ceil(ph.distance / params.step_length)))
        sl_plan = ph.distance / n_steps
        heading = ph.heading
    else:
        n_steps = 10**9
        sl_plan = params.step_length
    t_stop = t0 + ph.duration if ph.kind == "walk" else np.inf
    prev_hs = None
    i = 0
    centre_y = 0.5 * (feet[0].heel[-1][1] + feet[1].heel[-1][1])
    origin = (0.0, centre_y) if heading == 0.0 else (
        0.5 * (feet[0].heel[-1][0] + feet[1].heel[-1][0]),
        centre_y,
    )
    while True:
        asym = _side_sign(s)
        st = st_mean * (1.0 + asym * params.asym_time) * (1.0 + params.step_time_cv * rng.standard_normal())
        st = max(st, 0.35 * st_mean)
        ds = params.double_support * st
        hs = (t_to + st - ds) if prev_hs is None else prev_hs + st
        factor = params.first_step_factor if i == 0 else 1.0
        if ph.kind == "approach":
            sl = sl_plan
        else:
            sl = sl_plan * factor * (1.0 + asym * params.asym_length) + params.step_length_sd * rng.standard_normal()
        yaw = heading + asym * params.toe_out + np.deg2rad(1.5) * rng.standard_normal()
        along = _path_coord(feet[other], heading, origin) + sl
        lat = asym * params.step_width / 2 + params.step_width_sd / np.sqrt(2) * rng.standard_normal()
        x = origin[0] + along * np.cos(heading) - lat * np.sin(heading)
        y = origin[1] + along * np.sin(heading) + lat * np.cos(heading)
        feet[s].hs.append(hs)
        feet[s].to.append(_BIG)
        feet[s].heel.append((x, y))
        feet[s].yaw.append(yaw)
        feet[s].bout.append(bout)
        i += 1
        done = i >= n_steps or hs >= t_stop
        if hs >= horizon:
            return hs
        # the other foot lifts off after the double support period
        feet[other].to[-1] = hs + ds
        if done:
            # closing step: the trailing foot comes alongside the leading one
            st_c = st_mean * (1.0 + 0.5 * params.step_time_cv * rng.standard_normal())
            hs_c = hs + st_c
            asym_o = _side_sign(other)
            yaw_c = heading + asym_o * params.toe_out + np.deg2rad(1.0) * rng.standard_normal()
            along_c = _path_coord(feet[s], heading, origin) + 0.01 * rng.standard_normal()
            lat_c = asym_o * params.stance_width / 2
            feet[other].hs.append(hs_c)
            feet[other].to.append(_BIG)
            feet[other].heel.append(
                (
                    origin[0] + along_c * np.cos(heading) - lat_c * np.sin(heading),
                    origin[1] + along_c * np.sin(heading) + lat_c * np.cos(heading),
                )
            )
            feet[other].yaw.append(yaw_c)
            feet[other].bout.append(bout)
            return hs_c + 0.6
        prev_hs = hs
        s, other = other, s


# --------------------------------------------------------------------------- evaluated state
@dataclass(kw_only=True)
class BodyState:
    """Kinematic state at ``times`` (world frame). Shapes: T = len(times), leg axis [LEFT, RIGHT]."""

    times: FloatArray  # (T,)
    pelvis: FloatArray  # (T, 3) pelvis centre (midpoint of the hip joint centres)
    pelvis_rot: FloatArray  # (T, 3, 3) columns: forward, left, up
    hip: FloatArray  # (T, 2, 3) hip joint centres
    knee: FloatArray  # (T, 2, 3) knee joint centres
    ankle: FloatArray  # (T, 2, 3) ankle joint centres
    heel: FloatArray  # (T, 2, 3) heel point (posterior sole edge)
    toe: FloatArray  # (T, 2, 3) toe point (anterior sole tip)
    foot_rot: FloatArray  # (T, 2, 3, 3) columns: forward, left, up of the shoe
    stance: NDArray[np.bool_]  # (T, 2) foot in contact with the floor
    angles: FloatArray  # (T, 12) JOINT_NAMES order (rad)
    ik_clamped: NDArray[np.bool_]  # (T, 2) leg was out of reach and the ankle pulled in

    def leg_points(self) -> FloatArray:
        """``(T, 2, 5, 3)`` [time, side, (hip, knee, ankle, heel, toe), xyz] world points."""
        return np.stack([self.hip, self.knee, self.ankle, self.heel, self.toe], axis=2)


def _foot_axes(yaw: FloatArray, pitch: FloatArray) -> FloatArray:
    """(..., 3, 3) rotation with columns forward, left, up for a foot with ``yaw`` and ``pitch``."""
    cy, sy, cp, sp = np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch)
    fwd = np.stack([cp * cy, cp * sy, sp], axis=-1)
    left = np.stack([-sy, cy, np.zeros_like(cy)], axis=-1)
    up = np.stack([-sp * cy, -sp * sy, cp], axis=-1)
    return np.stack([fwd, left, up], axis=-1)


class GaitKinematics:
    """Continuous-time gait of one session: ``evaluate(times) -> BodyState`` (world frame)."""

    def __init__(
        self,
        feet: tuple[FootPlan, FootPlan],
        params: GaitParams,
        dims: BodyDims,
        *,
        t_start: float,
        t_end: float,
        grid_hz: float = 240.0,
    ) -> None:
        self.params = params
        self.dims = dims
        self.plans = feet
        self.f = [ft.arrays() for ft in feet]
        self._nominal_stance = params.step_time * (1.0 + params.double_support)
        self._stall_cache: dict[tuple[int, int], bool] = {}  # (side, swing) -> whether it stalls (_stalls)
        self._build_pelvis(t_start - 1.0, t_end + 1.0, grid_hz)

    # ------------------------------------------------------------------ feet
    def _footfall_index(self, side: int, t: FloatArray) -> NDArray[np.intp]:
        return np.searchsorted(self.f[side]["hs"], t, side="right") - 1

    def _stance_pitch(self, side: int, k: NDArray[np.intp], t: FloatArray) -> FloatArray:
        """Rocker-model sole pitch of footfall ``k`` at time ``t`` (stance only)."""
        p = self.params
        hs = self.f[side]["hs"][k]
        to = self.f[side]["to"][k]
        d_ff = p.foot_flat_frac * self._nominal_stance
        d_ho = (1.0 - p.heel_off_frac) * self._nominal_stance
        # do not let the rockers overlap on short stances
        t_ff = hs + np.minimum(d_ff, 0.3 * (to - hs))
        t_ho = np.maximum(to - d_ho, t_ff + 0.2 * (to - t_ff))
        u1 = np.clip((t - hs) / np.maximum(t_ff - hs, 1e-9), 0.0, 1.0)
        pitch = np.where(t < t_ff, p.heel_strike_pitch * (1.0 - u1) ** 2, 0.0)
        u3 = np.clip((t - t_ho) / np.maximum(to - t_ho, 1e-9), 0.0, 1.0)
        pitch = np.where(t > t_ho, p.toe_off_pitch * u3**1.3, pitch)
        return np.where(hs < -_BIG / 2, 0.0, pitch)  # initial standing foot is flat

    def _stance_foot(
        self, side: int, k: NDArray[np.intp], t: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """Heel, toe, ankle (each (N,3)) and axes (N,3,3) of a planted foot (rocker about heel/toe)."""
        d = self.dims
        yaw = self.f[side]["yaw"][k]
        heel0 = np.concatenate([self.f[side]["heel"][k], np.zeros((len(k), 1))], axis=1)
        pitch = self._stance_pitch(side, k, t)
        axes = _foot_axes(yaw, pitch)
        fwd = axes[..., 0]
        up = axes[..., 2]
        flat_fwd = np.stack([np.cos(yaw), np.sin(yaw), np.zeros_like(yaw)], axis=-1)
        toe0 = heel0 + d.foot_length * flat_fwd
        on_toe = (pitch < 0)[:, None]
        heel = np.where(on_toe, toe0 - d.foot_length * fwd, heel0)
        toe = np.where(on_toe, toe0, heel0 + d.foot_length * fwd)
        ankle = heel + d.ankle_forward * fwd + d.ankle_height * up
        return heel, toe, ankle, axes

    def _foot_from_ankle(self, ankle: FloatArray, axes: FloatArray) -> tuple[FloatArray, FloatArray]:
        d = self.dims
        heel = ankle - d.ankle_forward * axes[..., 0] - d.ankle_height * axes[..., 2]
        toe = heel + d.foot_length * axes[..., 0]
        return heel, toe

    # ------------------------------------------------------------------ pelvis
    def _planted_ankle_grid(self, side: int, t: FloatArray) -> tuple[FloatArray, NDArray[np.bool_]]:
        k = self._footfall_index(side, t)
        k = np.clip(k, 0, None)
        planted = t < self.f[side]["to"][k]
        _, _, ankle, _ = self._stance_foot(side, k, t)
        return ankle, planted

    def _ankle_flat(self, side: int, k: int) -> FloatArray:
        """(X, Y) of the ankle centre of footfall ``k`` with the foot flat."""
        d = self.dims
        yaw = self.f[side]["yaw"][k]
        hx, hy = self.f[side]["heel"][k]
        return np.array([hx + d.ankle_forward * np.cos(yaw), hy + d.ankle_forward * np.sin(yaw)])

    def _pelvis_knots(self) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
        """Knot times and pelvis X, Y, rotation, obliquity (NaN = no knot for that quantity)."""
        p = self.params
        knots: list[tuple[float, float, float, float, float]] = []
        nan = float("nan")
        for side in (0, 1):
            o = 1 - side
            sgn = _side_sign(side)
            hs_arr, to_arr = self.f[side]["hs"], self.f[side]["to"]
            for k in range(len(hs_arr)):
                a = self._ankle_flat(side, k)
                ko = int(np.searchsorted(self.f[o]["hs"], max(hs_arr[k], -_BIG / 2), side="right") - 1)
                ao = self._ankle_flat(o, ko)
                centre = 0.5 * (a + ao)
                to_o = self.f[o]["to"][ko]
                hs_o_next = self.f[o]["hs"][ko + 1] if ko + 1 < len(self.f[o]["hs"]) else _BIG
                heading = self.f[side]["yaw"][k] - sgn * p.toe_out
                if hs_arr[k] <= to_o < to_arr[k] and hs_o_next < _BIG / 2:
                    # mid stance of this foot = middle of the opposite foot's swing
                    tm = 0.5 * (to_o + hs_o_next)
                    y = centre[1] + p.pelvis_sway * (a[1] - centre[1])
                    # swing side drops: positive obliquity raises the left side
                    x = a[0] + p.trunk_lean * np.cos(heading)
                    y += p.trunk_lean * np.sin(heading)
                    knots.append((tm, x, y, heading, sgn * p.pelvis_obliquity))
                if hs_arr[k] > -_BIG / 2:
                    # at heel strike this side's hip is forward (pelvic rotation)
                    knots.append((hs_arr[k], nan, nan, heading - sgn * p.pelvis_rotation, 0.0))
        # stand-still: both feet planted for longer than 0.9 s
        fl, fr = self.f[0], self.f[1]
        for kl in range(len(fl["hs"])):
            for kr in range(len(fr["hs"])):
                lo = max(fl["hs"][kl], fr["hs"][kr])
                hi = min(fl["to"][kl], fr["to"][kr])
                if hi - lo <= 0.9:
                    continue
                c = 0.5 * (self._ankle_flat(0, kl) + self._ankle_flat(1, kr))
                heading = 0.5 * (fl["yaw"][kl] + fr["yaw"][kr])
                t_a = lo + 0.45 if lo > -_BIG / 2 else hi - 1.0e3
                t_b = hi - 0.3 if hi < _BIG / 2 else lo + 1.0e3
                for tk in (t_a, t_b):
                    knots.append((tk, c[0], c[1], heading, 0.0))
        knots.sort()
        arr = np.array(knots, dtype=float)
        return arr[:, 0], arr[:, 1], arr[:, 2], arr[:, 3], arr[:, 4]

    def _build_pelvis(self, t0: float, t1: float, hz: float) -> None:
        p = self.params
        d = self.dims
        tk, xk, yk, rotk, oblk = self._pelvis_knots()

        def spline(t: FloatArray, v: FloatArray, *, monotone: bool) -> PchipInterpolator | CubicSpline:
            ok = np.isfinite(v)
            tt, vv = t[ok], v[ok]
            tt, idx = np.unique(tt, return_index=True)
            vv = vv[idx]
            if len(tt) == 1:
                tt = np.array([tt[0] - 1.0, tt[0] + 1.0])
                vv = np.array([vv[0], vv[0]])
            if monotone:
                vv = np.maximum.accumulate(vv)  # never walk backwards
                return PchipInterpolator(tt, vv, extrapolate=False)
            return PchipInterpolator(tt, vv, extrapolate=False)

        self._sx = spline(tk, xk, monotone=True)
        self._sy = spline(tk, yk, monotone=False)
        self._srot = spline(tk, rotk, monotone=False)
        self._sobl = spline(tk, oblk, monotone=False)
        self._knot_range = (float(np.nanmin(tk)), float(np.nanmax(tk)))

        n = int(np.ceil((t1 - t0) * hz)) + 1
        grid = t0 + np.arange(n) / hz
        px, py, rot, obl = self._pelvis_xy(grid)
        prot = self._pelvis_rotation(rot, obl)
        # reach bound on the pelvis height
        l1, l2 = d.thigh_length, d.shank_length
        lmax = np.sqrt(l1**2 + l2**2 + 2 * l1 * l2 * np.cos(p.knee_min_flex))
        bound = np.full(n, np.inf)
        for side in (0, 1):
            off = prot @ np.array([0.0, _side_sign(side) * d.pelvis_width / 2, 0.0])
            ankle, planted = self._planted_ankle_grid(side, grid)
            hx = px + off[:, 0] - ankle[:, 0]
            hy = py + off[:, 1] - ankle[:, 1]
            horiz2 = hx**2 + hy**2
            zb = ankle[:, 2] - off[:, 2] + np.sqrt(np.maximum(lmax**2 - horiz2, 0.0))
            bound = np.where(planted, np.minimum(bound, zb), bound)
        stand_z = lmax + d.ankle_height
        bound = np.minimum(bound, stand_z) - 0.002
        sigma = 0.025 * hz
        radius = int(3.0 * sigma + 0.5)
        eroded = minimum_filter1d(bound, size=2 * radius + 1, mode="nearest")
        z = gaussian_filter1d(eroded, sigma, mode="nearest", truncate=3.0)
        self._grid = grid
        self._pz = z
        self.max_reach_violation = float(np.max(z - bound, initial=0.0))

    def _pelvis_xy(self, t: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        lo, hi = self._knot_range
        tc = np.clip(t, lo, hi)
        return self._sx(tc), self._sy(tc), self._srot(tc), self._sobl(tc)

    @staticmethod
    def _pelvis_rotation(rot: FloatArray, obl: FloatArray) -> FloatArray:
        """(T,3,3) pelvis axes (columns forward, left, up): yaw ``rot`` then roll ``obl`` about forward."""
        cz, sz = np.cos(rot), np.sin(rot)
        cx, sx = np.cos(obl), np.sin(obl)
        rz = np.zeros((len(rot), 3, 3))
        rz[:, 0, 0], rz[:, 0, 1], rz[:, 1, 0], rz[:, 1, 1], rz[:, 2, 2] = cz, -sz, sz, cz, 1.0
        rx = np.zeros((len(rot), 3, 3))
        rx[:, 0, 0], rx[:, 1, 1], rx[:, 1, 2], rx[:, 2, 1], rx[:, 2, 2] = 1.0, cx, -sx, sx, cx
        return rz @ rx

    def pelvis_velocity(self, t: FloatArray) -> FloatArray:
        """Forward (X) velocity of the pelvis (m/s) at ``t``."""
        lo, hi = self._knot_range
        tc = np.clip(t, lo, hi)
        v = self._sx.derivative()(tc)
        return np.where((t < lo) | (t > hi), 0.0, v)

    def pelvis_x(self, t: FloatArray) -> FloatArray:
        """Forward (X) position of the pelvis (m) at ``t``."""
        return self._pelvis_xy(np.asarray(t, float))[0]

    # ------------------------------------------------------------------ full state
    def evaluate(self, times: FloatArray) -> BodyState:
        """Kinematic state at ``times`` (s); vectorised."""
        t = np.atleast_1d(np.asarray(times, dtype=np.float64))
        n = len(t)
        p, d = self.params, self.dims
        px, py, rot, obl = self._pelvis_xy(t)
        pz = np.interp(t, self._grid, self._pz)
        pelvis = np.stack([px, py, pz], axis=-1)
        prot = self._pelvis_rotation(rot, obl)
        hip = np.empty((n, 2, 3))
        knee = np.empty((n, 2, 3))
        ankle = np.empty((n, 2, 3))
        heel = np.empty((n, 2, 3))
        toe = np.empty((n, 2, 3))
        axes = np.empty((n, 2, 3, 3))
        stance = np.empty((n, 2), bool)
        clamped = np.zeros((n, 2), bool)
        for side in (0, 1):
            sgn = _side_sign(side)
            hip[:, side] = pelvis + prot @ np.array([0.0, sgn * d.pelvis_width / 2, 0.0])
            k = np.clip(self._footfall_index(side, t), 0, None)
            to = self.f[side]["to"][k]
            st = t < to
            stance[:, side] = st
            h_s, t_s, a_s, ax_s = self._stance_foot(side, k, t)
            heel[:, side], toe[:, side], ankle[:, side], axes[:, side] = h_s, t_s, a_s, ax_s
            sw = np.nonzero(~st)[0]
            if len(sw):
                hs_, to_, an_, ax_ = self._swing_foot(side, k[sw], t[sw], hip[sw, side])
                push = self._swing_clearance(side, t[sw], an_)
                hs_, to_, an_ = hs_ + push, to_ + push, an_ + push
                heel[sw, side], toe[sw, side], ankle[sw, side], axes[sw, side] = hs_, to_, an_, ax_
            kn, cl = self._knee_ik(hip[:, side], ankle[:, side], axes[:, side, :, 0])
            knee[:, side] = kn
            clamped[:, side] = cl & ~st
            if np.any(cl & ~st):  # pull swing ankles back into reach (foot follows)
                idx = np.nonzero(cl & ~st)[0]
                v = ankle[idx, side] - hip[idx, side]
                lmax = d.thigh_length + d.shank_length - 1e-6
                ankle[idx, side] = hip[idx, side] + v * (lmax / np.linalg.norm(v, axis=-1))[:, None]
                heel[idx, side], toe[idx, side] = self._foot_from_ankle(ankle[idx, side], axes[idx, side])
                knee[idx, side], _ = self._knee_ik(hip[idx, side], ankle[idx, side], axes[idx, side, :, 0])
        angles = _joint_angles(prot, hip, knee, ankle, axes)
        return BodyState(
            times=t,
            pelvis=pelvis,
            pelvis_rot=prot,
            hip=hip,
            knee=knee,
            ankle=ankle,
            heel=heel,
            toe=toe,
            foot_rot=axes,
            stance=stance,
            angles=angles,
            ik_clamped=clamped,
        )

    def _swing_clearance(self, side: int, t: FloatArray, ankle: FloatArray) -> FloatArray:
        """Lateral displacement ``(n, 3)`` that keeps the swing foot clear of the stance foot.

        A narrow-base walker (step width near zero) swings the foot around the stance leg instead
        of through it: while the two ankles are less than a foot length apart along the stance
        foot, the swing ankle keeps at least ``swing_clearance`` laterally (faded in and out
        between one and 1.5 foot lengths; nothing changes for wider gaits).
        """
        other = 1 - side
        ko = np.clip(self._footfall_index(other, t), 0, None)
        _, _, a_o, ax_o = self._stance_foot(other, ko, t)
        fwd = ax_o[:, :, 0].copy()
        fwd[:, 2] = 0.0
        fwd /= np.maximum(np.linalg.norm(fwd, axis=-1, keepdims=True), 1e-9)
        lat = np.stack([-fwd[:, 1], fwd[:, 0], np.zeros(len(t))], axis=-1)  # towards the user's left
        delta = ankle - a_o
        along = np.einsum("ij,ij->i", delta, fwd) / self.dims.foot_length
        sgn = _side_sign(side)
        u = np.clip((1.5 - np.abs(along)) / 0.5, 0.0, 1.0)  # 0 beyond 1.5 foot lengths, 1 within one
        need = self.params.swing_clearance * u * u * (3.0 - 2.0 * u)
        push = np.maximum(need - sgn * np.einsum("ij,ij->i", delta, lat), 0.0)
        return (sgn * push)[:, None] * lat

    def _natural_swing(self, side: int, phi: FloatArray, hip: FloatArray, yaw: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Ankle position and sole pitch from the normative angles at phase ``phi`` hanging from ``hip``."""
        d = self.dims
        th = normative_angle("hip", phi)
        tk = normative_angle("knee", phi)
        ta = normative_angle("ankle", phi)
        fwd = np.stack([np.cos(yaw), np.sin(yaw), np.zeros_like(yaw)], axis=-1)
        down = np.array([0.0, 0.0, -1.0])
        thigh = np.cos(th)[:, None] * down + np.sin(th)[:, None] * fwd
        shank_a = th - tk
        shank = np.cos(shank_a)[:, None] * down + np.sin(shank_a)[:, None] * fwd
        ankle = hip + d.thigh_length * thigh + d.shank_length * shank
        return ankle, shank_a + ta

    def _swing_foot(
        self, side: int, k: NDArray[np.intp], t: FloatArray, hip: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """Swing foot from footfall ``k`` (lifted at its TO) to footfall ``k+1`` (HS)."""
        p = self.params
        ankle, pitch, yaw, s, w, a0, a1 = self._swing_path(side, k, t, hip)
        ankle = self._forward_only(side, k, w, ankle, a0, a1)
        axes = _foot_axes(yaw, pitch)
        heel, toe = self._foot_from_ankle(ankle, axes)
        # toe / heel clearance
        clear = p.toe_clearance * np.sin(np.pi * s) ** 0.5
        low = np.minimum(heel[:, 2], toe[:, 2])
        lift = np.maximum(clear - low, 0.0)
        ankle[:, 2] += lift
        heel[:, 2] += lift
        toe[:, 2] += lift
        return heel, toe, ankle, axes

    def _swing_path(
        self, side: int, k: NDArray[np.intp], t: FloatArray, hip: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
        """The swing ankle (from the normative curves hanging from ``hip``, blended into the exact ends), sole pitch
        and yaw at ``t`` of swings ``k``, with the swing fractions ``s``, their min-jerk blend ``w`` and the ankle at
        toe off ``a0`` and heel strike ``a1``."""
        p, d = self.params, self.dims
        f = self.f[side]
        kn = np.minimum(k + 1, len(f["hs"]) - 1)
        t_to = f["to"][k]
        t_hs = f["hs"][kn]
        s = np.clip((t - t_to) / np.maximum(t_hs - t_to, 1e-9), 0.0, 1.0)
        yaw0, yaw1 = f["yaw"][k], f["yaw"][kn]
        w = min_jerk(s)
        yaw = yaw0 + (yaw1 - yaw0) * w
        phi0 = NORMATIVE_TOE_OFF_PHASE
        phi = phi0 + s * (1.0 - phi0)
        # hip at the swing's start and end
        hip_to = self._hip_at(side, t_to)
        hip_hs = self._hip_at(side, t_hs)
        ank_nat, pitch_nat = self._natural_swing(side, phi, hip, yaw)
        a0n, p0n = self._natural_swing(side, np.full_like(s, phi0), hip_to, yaw0)
        a1n, p1n = self._natural_swing(side, np.ones_like(s), hip_hs, yaw1)
        # exact poses at toe-off (end of stance of k) and heel strike (start of stance of kn)
        _, _, a0, ax0 = self._stance_foot(side, k, t_to)
        pitch0 = np.arctan2(ax0[:, 2, 0], np.hypot(ax0[:, 0, 0], ax0[:, 1, 0]))
        yaw_hs = yaw1
        heel1 = np.concatenate([f["heel"][kn], np.zeros((len(kn), 1))], axis=1)
        ax1 = _foot_axes(yaw_hs, np.full_like(s, p.heel_strike_pitch))
        a1 = heel1 + d.ankle_forward * ax1[..., 0] + d.ankle_height * ax1[..., 2]
        ankle = ank_nat + (1.0 - w)[:, None] * (a0 - a0n) + w[:, None] * (a1 - a1n)
        pitch = pitch_nat + (1.0 - w) * (pitch0 - p0n) + w * (p.heel_strike_pitch - p1n)
        return ankle, pitch, yaw, s, w, a0, a1

    def _forward_only(self, side: int, k: NDArray[np.intp], w: FloatArray, ankle: FloatArray,
                      a0: FloatArray, a1: FloatArray) -> FloatArray:
        """The swing ankles ``ankle`` ``(n, 3)`` (min-jerk swing fractions ``w``; ``a0`` / ``a1`` the ankle at toe
        off / heel strike) with the progress along the swing (horizontal, from ``a0`` to ``a1``) of every swing
        that would stall or slide back mid-swing (:meth:`_stalls`) replaced by the min-jerk blend of its ends.  The
        normative curves hang a normal stride's excursion from the hip; the end corrections of a short stride (under
        ~0.4 m: a first step from standing, a frail user's shuffle) then cancel it unevenly, and the foot stopped or
        slid back by up to 2-3 cm mid-swing and went on, which no foot does.  Other swings are left exactly as they
        were."""
        swings, which = np.unique(k, return_inverse=True)
        fix = np.array([self._stalls(side, int(kk)) for kk in swings], dtype=bool)[which]
        if not fix.any():
            return ankle
        d = (a1 - a0)[fix, :2]
        dist = np.linalg.norm(d, axis=-1)
        u = d / np.maximum(dist, 1e-9)[:, None]
        along = np.einsum("ij,ij->i", (ankle - a0)[fix, :2], u)
        out = ankle.copy()
        out[fix, :2] += ((dist * w[fix]) - along)[:, None] * u
        return out

    def _stalls(self, side: int, k: int) -> bool:
        """Whether swing ``k`` of foot ``side`` (from footfall ``k``'s toe off to footfall ``k + 1``'s heel strike)
        stalls or slides back mid-swing: its ankle's speed along the swing somewhere between 15 and 85 % of it under
        :data:`SWING_STALL_RATIO` of its mean (64 samples; a normal stride's is 0.6-0.7 of it there, the min-jerk
        blend's 0.49), cached."""
        cache = self._stall_cache
        key = (side, k)
        if key not in cache:
            f = self.f[side]
            kn = min(k + 1, len(f["hs"]) - 1)
            t_to, t_hs = float(f["to"][k]), float(f["hs"][kn])
            stalls = False
            if t_hs > t_to:
                s = np.linspace(0.0, 1.0, 64)
                t = t_to + s * (t_hs - t_to)
                ankle, _, _, _, _, a0, a1 = self._swing_path(side, np.full(len(s), k, dtype=np.intp), t,
                                                             self._hip_at(side, t))
                d = (a1 - a0)[0, :2]
                dist = float(np.linalg.norm(d))
                if dist > 1e-3:
                    along = (ankle[:, :2] - a0[0, :2]) @ (d / dist)
                    speed = np.diff(along) / np.diff(s)
                    mid = (s[1:] > 0.15) & (s[:-1] < 0.85)
                    stalls = bool(np.min(speed[mid]) < SWING_STALL_RATIO * dist)
            cache[key] = stalls
        return cache[key]

    def _hip_at(self, side: int, t: FloatArray) -> FloatArray:
        t = np.atleast_1d(np.asarray(t, float))
        px, py, rot, obl = self._pelvis_xy(t)
        pz = np.interp(t, self._grid, self._pz)
        prot = self._pelvis_rotation(rot, obl)
        return np.stack([px, py, pz], -1) + prot @ np.array([0.0, _side_sign(side) * self.dims.pelvis_width / 2, 0.0])

    def _knee_ik(
        self, hip: FloatArray, ankle: FloatArray, foot_fwd: FloatArray
    ) -> tuple[FloatArray, NDArray[np.bool_]]:
        """Knee centre by two-link IK; knee bends forward towards the foot heading."""
        l1, l2 = self.dims.thigh_length, self.dims.shank_length
        v = ankle - hip
        dist = np.linalg.norm(v, axis=-1)
        clamped = dist > l1 + l2 - 1e-6
        dc = np.clip(dist, 1e-6, l1 + l2 - 1e-9)
        u = v / np.maximum(dist, 1e-9)[:, None]
        fh = foot_fwd.copy()
        fh[:, 2] = 0.0
        fh /= np.maximum(np.linalg.norm(fh, axis=-1), 1e-9)[:, None]
        nf = fh - np.sum(fh * u, axis=-1)[:, None] * u
        nf /= np.maximum(np.linalg.norm(nf, axis=-1), 1e-9)[:, None]
        cos_a = np.clip((l1**2 + dc**2 - l2**2) / (2 * l1 * dc), -1.0, 1.0)
        sin_a = np.sqrt(1.0 - cos_a**2)
        knee = hip + l1 * (cos_a[:, None] * u + sin_a[:, None] * nf)
        return knee, clamped


def _joint_angles(
    prot: FloatArray, hip: FloatArray, knee: FloatArray, ankle: FloatArray, foot_axes: FloatArray
) -> FloatArray:
    """Joint angles (T, 12) in ``JOINT_NAMES`` order from the skeleton (sign conventions of types.py)."""
    n = len(prot)
    out = np.zeros((n, 12))
    fwd_p, left_p, up_p = prot[..., 0], prot[..., 1], prot[..., 2]
    for side in (0, 1):
        sgn = _side_sign(side)
        thigh = knee[:, side] - hip[:, side]
        shank = ankle[:, side] - knee[:, side]
        tn = thigh / np.linalg.norm(thigh, axis=-1)[:, None]
        sn = shank / np.linalg.norm(shank, axis=-1)[:, None]
        flex = np.arctan2(np.sum(tn * fwd_p, -1), -np.sum(tn * up_p, -1))
        abd = np.arcsin(np.clip(sgn * np.sum(tn * left_p, -1), -1, 1))
        ffwd = foot_axes[:, side, :, 0]
        yaw_f = np.arctan2(ffwd[:, 1], ffwd[:, 0])
        yaw_p = np.arctan2(fwd_p[:, 1], fwd_p[:, 0])
        rot_int = -sgn * np.angle(np.exp(1j * (yaw_f - yaw_p)))  # toe-out = external = negative
        knee_flex = np.arccos(np.clip(np.sum(tn * sn, -1), -1, 1))
        # ankle: foot pitch relative to the shank, 0 when the sole is perpendicular to the shank
        sole_angle = np.arccos(np.clip(np.sum(sn * ffwd, -1), -1, 1))  # angle shank-dir vs foot fwd
        dorsi = sole_angle - np.pi / 2
        base = 0 if side == 0 else 6
        out[:, base + 0] = flex
        out[:, base + 1] = abd
        out[:, base + 2] = rot_int
        out[:, base + 3] = knee_flex
        out[:, base + 4] = dorsi
        out[:, base + 5] = 0.0
    return out
