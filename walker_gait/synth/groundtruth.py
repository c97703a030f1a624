"""Exact gait events and GAITRite-style step parameters from the footfall plan (world frame).

Definitions follow ``docs/GAIT_METRICS.md`` (``core/gait.py``), evaluated on the *planted heel
positions in world coordinates* (where the footprints are on a GAITRite mat):

* **footfall**: a heel strike (HS) of one foot with its planted heel point; the feet's standing
  positions at the session start are footfalls with unknown time.
* **line of progression** ``u`` for the step ending at footfall ``k``: direction of the sum of
  the last 4 stride vectors of this walking bout (same-foot footfall-to-footfall displacements of
  either foot, up to and including this one; a bout's first stride runs from where the foot stood).
  A line across a stand-still would carry the direction of the walk before it into the next: a user
  who walks in from the side, stops at the walker and walks off with it had a first step 32 cm wide
  (the thirty-first session's ground truth).
* **step length** ``d . u`` and **step width** ``|d x u|`` with ``d`` = this heel minus the heel
  of the previous footfall of the opposite foot (horizontal); **step time**: previous opposite
  HS -> this HS (NaN when that HS is unknown, i.e. the standing start; includes pauses after a
  stop, as measured).
* **stride length** ``(this - previous same-foot footfall) . u``; **stride time** previous
  same-foot HS -> this HS.
* **stance** previous same-foot HS -> its TO; **swing** that TO -> this HS; **single support**
  the opposite foot's swing (TO -> HS) inside that cycle; **double support** stance - single
  support (initial + terminal).  NaN when an event is unknown.
* Every heel strike in the session is a step (including gait initiation after a stop and the
  closing step that brings the feet together); a stand-still produces zero steps.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from walker_gait.core.types import EventKind, Side

FloatArray = NDArray[np.float64]


@dataclass(frozen=True, kw_only=True)
class GtEvent:
    """Heel strike / toe off with its exact time and contact point (world frame, metres)."""

    stamp: float
    side: Side
    kind: EventKind
    position_world: FloatArray  # heel point (HS) or toe point (TO), (3,)
    bout: int


@dataclass(frozen=True, kw_only=True)
class GtStep:
    """One step ending at the heel strike of ``side`` (see module docstring)."""

    stamp: float
    side: Side
    index: int
    step_length: float
    step_width: float
    step_time: float
    stride_length: float
    stride_time: float
    stance_time: float
    swing_time: float
    single_support_time: float
    double_support_time: float
    heel_world: FloatArray  # (3,)
    prev_opposite_heel_world: FloatArray  # (3,)
    bout: int


def gait_events(plans: list[dict[str, FloatArray]], *, foot_length: float, t_min: float, t_max: float) -> list[GtEvent]:
    """HS and TO events within ``[t_min, t_max]`` sorted by time.

    ``plans`` are :meth:`FootPlan.arrays` per side.  The TO contact point is the toe, which is
    fixed from heel-off to toe-off: planted heel + ``foot_length`` along the foot heading.
    """
    out: list[GtEvent] = []
    for side in (Side.LEFT, Side.RIGHT):
        f = plans[side]
        for k in range(len(f["hs"])):
            hs, to = f["hs"][k], f["to"][k]
            heel = np.array([f["heel"][k][0], f["heel"][k][1], 0.0])
            if t_min <= hs <= t_max:
                out.append(GtEvent(stamp=float(hs), side=side, kind=EventKind.HEEL_STRIKE, position_world=heel, bout=int(f["bout"][k])))
            if t_min <= to <= t_max:
                yaw = f["yaw"][k]
                toe = heel + foot_length * np.array([np.cos(yaw), np.sin(yaw), 0.0])
                # the bout of a toe-off is the bout of the swing it starts (next footfall)
                bout = int(f["bout"][k + 1]) if k + 1 < len(f["bout"]) else int(f["bout"][k])
                out.append(GtEvent(stamp=float(to), side=side, kind=EventKind.TOE_OFF, position_world=toe, bout=bout))
    out.sort(key=lambda e: (e.stamp, e.side, e.kind))
    return out


def gait_steps(
    plans: list[dict[str, FloatArray]], *, t_min: float, t_max: float, n_progression: int = 4
) -> list[GtStep]:
    """GAITRite steps for all heel strikes within ``[t_min, t_max]`` (see module docstring)."""
    nan = float("nan")
    falls = []  # (time, side, k) of real heel strikes
    for side in (Side.LEFT, Side.RIGHT):
        for k in range(len(plans[side]["hs"])):
            if plans[side]["hs"][k] > -1e5:
                falls.append((float(plans[side]["hs"][k]), side, k))
    falls.sort()

    def known(t: float) -> bool:
        return t > -1e5

    strides: list[tuple[int, np.ndarray]] = []  # (bout, stride vector) in HS order
    steps: list[GtStep] = []
    for t, side, k in falls:
        f = plans[side]
        fo = plans[Side(1 - side)]
        h = np.array([*f["heel"][k], 0.0])
        stride = h[:2] - f["heel"][k - 1]  # k >= 1 always (index 0 = standing start)
        bout = int(f["bout"][k])
        strides.append((bout, stride))
        if not (t_min <= t <= t_max):
            continue
        acc = np.sum([v for b, v in strides if b == bout][-n_progression:], axis=0)
        nrm = float(np.linalg.norm(acc))
        u = acc / nrm if nrm > 1e-6 else np.array([1.0, 0.0])
        ko = int(np.searchsorted(fo["hs"], t, side="left") - 1)
        ho = np.array([*fo["heel"][ko], 0.0])
        t_o = float(fo["hs"][ko])
        rel = (h - ho)[:2]
        t_prev = float(f["hs"][k - 1])
        to_prev = float(f["to"][k - 1])
        stance = to_prev - t_prev if known(t_prev) else nan
        swing = t - to_prev
        # opposite swing inside the previous cycle of this foot: fo TO (of footfall ko-1) -> fo HS (ko)
        single = nan
        if known(t_prev) and ko >= 1 and known(t_o):
            to_o = float(fo["to"][ko - 1])
            if t_prev <= to_o <= to_prev:
                single = t_o - to_o
        steps.append(
            GtStep(
                stamp=t,
                side=side,
                index=len(steps),
                step_length=float(rel @ u),
                step_width=float(abs(rel[0] * u[1] - rel[1] * u[0])),
                step_time=t - t_o if known(t_o) else nan,
                stride_length=float(stride @ u),
                stride_time=t - t_prev if known(t_prev) else nan,
                stance_time=stance,
                swing_time=swing,
                single_support_time=single,
                double_support_time=stance - single if np.isfinite(single) else nan,
                heel_world=h,
                prev_opposite_heel_world=ho,
                bout=int(f["bout"][k]),
            )
        )
    return steps
