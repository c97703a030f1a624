"""Exact gait events and GAITRite-style step parameters from the footfall plan (world frame).

Definitions (shared with ``core/gait.py``; all from *planted heel positions in world
coordinates* at heel strike, i.e. where the footprint is on a GAITRite mat):

* **footfall**: a heel strike (HS) of one foot, with its planted heel point ``h`` (floor level).
* **line of progression** for the footfall of foot ``s`` at ``h_k``: the unit horizontal vector
  from the previous footfall of the same foot ``h_{k-1}`` to ``h_k`` (its stride line); when
  there is no previous same-side footfall in the bout, the session walking direction (+X).
* **step length**: ``(h_k - h_o) . d`` where ``h_o`` is the heel of the previous opposite
  footfall and ``d`` the line of progression; **step width**: ``|(h_k - h_o) x d|`` (horizontal,
  perpendicular distance, always >= 0); **step time**: ``t_k - t_o``.
* **stride length / time**: ``|h_k - h_{k-1}|`` / ``t_k - t_{k-1}`` (same foot).
* For the gait cycle of foot ``s`` that *ends* at this HS (previous HS of ``s`` -> this HS):
  stance = TO_s - HS_prev_s, swing = HS_s - TO_s, single support = swing time of the opposite
  foot inside that stance, double support = stance - single support.  NaN when unknown.
* Steps exist only inside a walking bout (between stand-stills); the first footfall of a bout
  (gait initiation) has no previous opposite footfall *in the bout* and is not a step; the
  closing footfall that brings the feet together is a step (short step length).  A
  stand-still produces zero steps.
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


def gait_steps(plans: list[dict[str, FloatArray]], *, t_min: float, t_max: float) -> list[GtStep]:
    """GAITRite steps for all heel strikes within ``[t_min, t_max]`` (see module docstring)."""
    falls = []  # (time, side, k)
    for side in (Side.LEFT, Side.RIGHT):
        f = plans[side]
        for k in range(len(f["hs"])):
            if f["hs"][k] > -1e5:
                falls.append((float(f["hs"][k]), side, k))
    falls.sort()
    steps: list[GtStep] = []
    nan = float("nan")
    for t, side, k in falls:
        if not (t_min <= t <= t_max):
            continue
        f = plans[side]
        o = Side(1 - side)
        fo = plans[o]
        bout = int(f["bout"][k])
        # previous opposite footfall (in the same bout)
        ko = int(np.searchsorted(fo["hs"], t, side="left") - 1)
        if ko < 0 or fo["hs"][ko] < -1e5 or int(fo["bout"][ko]) != bout:
            continue
        h = np.array([*f["heel"][k], 0.0])
        ho = np.array([*fo["heel"][ko], 0.0])
        same_prev = k - 1 >= 0 and f["hs"][k - 1] > -1e5 and int(f["bout"][k - 1]) == bout
        if same_prev:
            hp = np.array([*f["heel"][k - 1], 0.0])
            d = h - hp
            stride_len = float(np.linalg.norm(d[:2]))
            stride_time = float(t - f["hs"][k - 1])
            stance = float(f["to"][k - 1] - f["hs"][k - 1])
            swing = float(t - f["to"][k - 1])
            # opposite swing inside that stance: TO_o -> HS_o = fo[ko]
            to_o = float(fo["to"][ko - 1]) if ko - 1 >= 0 else nan
            single = float(fo["hs"][ko] - to_o) if np.isfinite(to_o) and to_o >= f["hs"][k - 1] else nan
            double = stance - single if np.isfinite(single) else nan
            dirv = d[:2] / max(np.linalg.norm(d[:2]), 1e-9)
        else:
            stride_len = stride_time = stance = swing = single = double = nan
            dirv = np.array([1.0, 0.0])
        rel = (h - ho)[:2]
        step_len = float(rel @ dirv)
        step_w = float(abs(rel[0] * dirv[1] - rel[1] * dirv[0]))
        steps.append(
            GtStep(
                stamp=t,
                side=side,
                index=len(steps),
                step_length=step_len,
                step_width=step_w,
                step_time=float(t - fo["hs"][ko]),
                stride_length=stride_len,
                stride_time=stride_time,
                stance_time=stance,
                swing_time=swing,
                single_support_time=single,
                double_support_time=double,
                heel_world=h,
                prev_opposite_heel_world=ho,
                bout=bout,
            )
        )
    return steps
