"""Gait-analysis benchmark: events and step metrics of :class:`GaitAnalyzer` vs ground truth.

Two data sources:

* ``source="kinematic"`` — :func:`simulate_gait`, a small rocker-foot kinematic model of the
  feet only (heel/toe points; feet planted in the world, walker following the user, poses
  converted to the camera frame through a :class:`FloorPlane`).  Ground-truth events and
  steps are exact by construction.  Also used by the unit tests.
* ``source="synth"`` — the full synthetic session generator of :mod:`walker_gait.synth`
  (another engineer's module) when its ground-truth API is importable; see
  :func:`synth_available`.

:func:`match_steps` / :func:`match_events` (ground truth ↔ detections, by time and foot) are
meant to be reused by other benchmarks (e.g. the tracker benchmark).

Run: ``python -m walker_gait.bench.gait --scenarios normal slow asymmetric --noise 0.01``.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from walker_gait.core.gait import GaitAnalyzer, GaitConfig, GaitSummaryData, summarize_steps
from walker_gait.core.types import (
    ANKLE,
    HEEL,
    HIP,
    KNEE,
    TOE,
    EventKind,
    FloorPlane,
    GaitEvent,
    LegPose,
    Side,
    Step,
    TrackStatus,
)

FloatArray = NDArray[np.float64]

__all__ = [
    "GaitSimSpec",
    "GaitSimResult",
    "simulate_gait",
    "match_steps",
    "match_events",
    "evaluate_gait",
    "run_gait_bench",
    "SCENARIOS",
    "synth_available",
]


# --------------------------------------------------------------------------------------
# simple kinematic generator (feet only)


@dataclass(kw_only=True)
class GaitSimSpec:
    """Walking pattern for :func:`simulate_gait` (SI units; pairs are ``[LEFT, RIGHT]``).

    ``bouts`` is a sequence of ``("stand", seconds)`` and ``("walk", n_steps)`` items; each
    walking bout starts and ends with the feet side by side (half-length first/last steps).
    """

    fps: float = 30.0
    bouts: tuple[tuple[str, float], ...] = (("stand", 1.0), ("walk", 12), ("stand", 1.0))
    step_length: tuple[float, float] = (0.40, 0.40)  # m, of the step ending with that foot
    step_width: float = 0.16  # m, heel-to-heel lateral distance
    step_time: tuple[float, float] = (0.60, 0.60)  # s, of the step ending with that foot
    swing_fraction: tuple[float, float] = (0.38, 0.38)  # swing / stride time per foot
    foot_length: float = 0.22  # m, heel point to toe point
    heel_off_fraction: float = 0.55  # heel-off time as a fraction of the stance (before TO)
    toe_off_pitch: float = math.radians(35.0)  # heel-up pitch at toe off
    heel_strike_pitch: float = math.radians(18.0)  # toe-up pitch at heel strike
    foot_flat_time: float = 0.10  # s, heel strike -> foot flat
    toe_clearance: float = 0.03  # m, extra toe lift in swing
    heel_point_height: float = 0.02  # m, tracked heel point above the floor when planted
    toe_point_height: float = 0.015  # m
    walker_distance: float = 0.55  # m, walker origin -> mid-feet along x
    walker_lag_s: float = 0.5  # s, smoothing of the walker's following motion
    camera_height: float = 0.5  # m
    camera_pitch: float = 0.5  # rad
    noise_m: float = 0.0  # σ of iid Gaussian noise on every camera-frame point
    lost: tuple[tuple[float, float], ...] = ()  # (t0, t1): pose SEARCHING, points NaN
    degraded: tuple[tuple[float, float], ...] = ()  # (t0, t1): DEGRADED, confidence 0.3
    shuffle: tuple[tuple[float, float, int, float], ...] = ()  # (t0, t1, side, amplitude m)
    lateral_jitter_m: float = 0.0  # σ of per-footfall lateral placement variation
    length_jitter_m: float = 0.0  # σ of per-step length variation


@dataclass
class GaitSimResult:
    """Output of :func:`simulate_gait`."""

    poses: list[LegPose]
    floor: FloorPlane
    events: list[GaitEvent]  # ground truth, time order
    steps: list[Step]  # ground truth, one per heel strike
    footfalls: list[tuple[int, float, FloatArray]]  # (side, t_hs, world heel xy)
    spec: GaitSimSpec = field(repr=False, default_factory=GaitSimSpec)


def _smoothstep(s: FloatArray) -> FloatArray:
    s = np.clip(s, 0.0, 1.0)
    return s * s * (3 - 2 * s)


def _plan(spec: GaitSimSpec, rng: np.random.Generator) -> tuple[list[dict[str, Any]], float]:
    """Footfall plan: per foot a list of planted intervals with heel xy, HS and TO times."""
    lat = [-spec.step_width / 2, spec.step_width / 2]  # walker/world y: LEFT at -y (camera's right)
    stance: list[list[dict[str, Any]]] = [[], []]
    # initial standing footprints (no HS time)
    for f in range(2):
        stance[f].append({"hs": -math.inf, "to": math.inf, "xy": np.array([0.0, lat[f]])})
    t = 0.0
    lead = 1  # first stepping foot: RIGHT (then alternate)
    for kind, val in spec.bouts:
        if kind == "stand":
            t += float(val)
            continue
        n = int(val)
        # step i ends with HS of foot s_i; the first step is preceded by the TO of s_0
        sides = [(lead + i) % 2 for i in range(n)]
        hs_times = []
        tt = t
        for i, s in enumerate(sides):
            st = spec.step_time[s]
            tt += st if i > 0 else spec.step_time[s] * (1 - 0.0)
            hs_times.append(tt)
        for i, s in enumerate(sides):
            o = 1 - s
            stride = spec.step_time[0] + spec.step_time[1]
            sw = spec.swing_fraction[s] * stride
            t_hs = hs_times[i]
            t_to = t_hs - sw
            if i == 0:
                t_to = max(t_to, t + 0.05)
            # length: half steps at the start and end of a bout
            length = spec.step_length[s] * (0.5 if (i == 0 or i == n - 1) else 1.0)
            length += rng.normal(0.0, spec.length_jitter_m) if spec.length_jitter_m > 0 else 0.0
            prev_o = stance[o][-1]["xy"]
            y = lat[s] + (rng.normal(0.0, spec.lateral_jitter_m) if spec.lateral_jitter_m > 0 else 0.0)
            xy = np.array([prev_o[0] - length, y])  # walking towards -x
            stance[s][-1]["to"] = t_to
            stance[s].append({"hs": t_hs, "to": math.inf, "xy": xy})
        t = hs_times[-1]
        # the next bout starts with the other foot than the one that ended this bout
        lead = (sides[-1] + 1) % 2
    return [stance[0], stance[1]], t  # type: ignore[return-value]


def _foot_points(spec: GaitSimSpec, plan: list[dict[str, Any]], t: float) -> FloatArray:
    """World heel/toe (2, 3) of one foot at time t (floor contact heights 0)."""
    L = spec.foot_length
    fwd = np.array([-1.0, 0.0, 0.0])
    up = np.array([0.0, 0.0, 1.0])
    for i, st in enumerate(plan):
        hs, to = st["hs"], st["to"]
        heel0 = np.array([st["xy"][0], st["xy"][1], 0.0])
        if hs <= t <= to:  # stance
            ff = hs + spec.foot_flat_time
            if math.isfinite(to):
                dur = (to - hs) if math.isfinite(hs) else 1.0
                ho = to - (1 - spec.heel_off_fraction) * dur
            else:
                ho = math.inf
            if t < ff:  # rotating about the heel, toe up
                p = spec.heel_strike_pitch * (1 - _smoothstep(np.array((t - hs) / spec.foot_flat_time)))
                heel = heel0
                toe = heel + L * math.cos(p) * fwd + L * math.sin(p) * up
            elif t < ho:
                heel = heel0
                toe = heel0 + L * fwd
            else:  # rotating about the toe, heel up
                p = spec.toe_off_pitch * float(_smoothstep(np.array((t - ho) / max(to - ho, 1e-6))))
                toe = heel0 + L * fwd
                heel = toe - L * math.cos(p) * fwd + L * math.sin(p) * up
            return np.stack([heel, toe])
        nxt = plan[i + 1] if i + 1 < len(plan) else None
        if nxt is not None and to < t < nxt["hs"]:  # swing
            tau = (t - to) / (nxt["hs"] - to)
            toe0 = heel0 + L * fwd
            heel1 = np.array([nxt["xy"][0], nxt["xy"][1], 0.0])
            ph = spec.heel_strike_pitch
            toe1 = heel1 + L * math.cos(ph) * fwd + L * math.sin(ph) * up
            s = tau - math.sin(2 * math.pi * tau) / (2 * math.pi)  # zero speed at both ends
            toe = toe0 + (toe1 - toe0) * s
            toe[2] = toe1[2] * float(_smoothstep(np.array(tau))) + spec.toe_clearance * math.sin(math.pi * tau)
            lat_s = float(_smoothstep(np.array(tau)))
            toe[1] = toe0[1] + (toe1[1] - toe0[1]) * lat_s
            p = spec.toe_off_pitch + (-ph - spec.toe_off_pitch) * float(_smoothstep(np.array(tau)))
            heel = toe - L * math.cos(p) * fwd + L * math.sin(p) * up
            return np.stack([heel, toe])
    raise RuntimeError(f"time {t} not covered by the plan")


def _gt_steps(plan: list[list[dict[str, Any]]]) -> tuple[list[Step], list[GaitEvent], list[tuple[int, float, FloatArray]]]:
    """Ground-truth steps (GAITRite definitions, line of progression = -x) and events."""
    hs_list = []
    for f in range(2):
        for st in plan[f]:
            if math.isfinite(st["hs"]):
                hs_list.append((st["hs"], f, st))
    hs_list.sort(key=lambda x: x[0])
    events: list[GaitEvent] = []
    for f in range(2):
        for st in plan[f]:
            if math.isfinite(st["hs"]):
                events.append(GaitEvent(stamp=st["hs"], side=Side(f), kind=EventKind.HEEL_STRIKE,
                                        position=np.array([st["xy"][0], st["xy"][1], 0.0])))
            if math.isfinite(st["to"]):
                events.append(GaitEvent(stamp=st["to"], side=Side(f), kind=EventKind.TOE_OFF,
                                        position=np.array([st["xy"][0], st["xy"][1], 0.0])))
    events.sort(key=lambda e: e.stamp)
    u = np.array([-1.0, 0.0])
    steps: list[Step] = []
    footfalls = []
    for t1, a, st in hs_list:
        b = 1 - a
        # opposite stance active at t1
        opp = [s for s in plan[b] if s["hs"] < t1 <= s["to"] or (s["hs"] < t1 and s["to"] == math.inf)][-1]
        same_prev = [s for s in plan[a] if s["hs"] < t1][-1]
        d = st["xy"] - opp["xy"]
        stride = st["xy"] - same_prev["xy"]
        t_b = opp["hs"]
        t_a0 = same_prev["hs"]
        to_a = same_prev["to"]
        stance = to_a - t_a0
        swing = t1 - to_a
        # opposite swing in the cycle: TO of the opposite stance before `opp`
        prev_opp = [s for s in plan[b] if s["hs"] < opp["hs"]]
        to_b = prev_opp[-1]["to"] if prev_opp else math.nan
        single = t_b - to_b if prev_opp and t_a0 < to_b else math.nan
        double = (to_b - t_a0) + (to_a - t_b) if math.isfinite(single) else math.nan
        nanif = lambda x: x if math.isfinite(x) else math.nan  # noqa: E731
        steps.append(Step(
            stamp=t1, side=Side(a), index=len(steps),
            step_length=float(d @ u), step_width=float(abs(d[0] * u[1] - d[1] * u[0])),
            step_time=nanif(t1 - t_b), stride_length=float(stride @ u) if math.isfinite(t_a0) else math.nan,
            stride_time=nanif(t1 - t_a0), stance_time=nanif(stance), swing_time=nanif(swing),
            single_support_time=nanif(single), double_support_time=nanif(double),
        ))
        footfalls.append((a, t1, st["xy"].copy()))
    return steps, events, footfalls


def simulate_gait(spec: GaitSimSpec, *, rng: np.random.Generator) -> GaitSimResult:
    """Render a feet-only walking session behind a walker (camera-frame :class:`LegPose` list).

    The feet follow :func:`_plan` (planted in the world, rocker foot roll-over), the walker
    (camera) follows the mid-point of the feet with a ``walker_lag_s`` moving average at
    ``walker_distance`` ahead (towards -x), never rotating.  Ground-truth steps use the
    GAITRite definitions with the line of progression = world -x.
    """
    plan, t_end = _plan(spec, rng)
    steps, events, footfalls = _gt_steps(plan)
    floor = FloorPlane.from_camera_pose(height=spec.camera_height, pitch=spec.camera_pitch)
    rot, off = floor.walker_transform()
    dt = 1.0 / spec.fps
    times = np.arange(0.0, t_end + 1.0 + 1e-9, dt)
    feet = np.zeros((times.size, 2, 2, 3))
    for i, t in enumerate(times):
        for f in range(2):
            feet[i, f] = _foot_points(spec, plan[f], float(t))
    mid = feet[:, :, 0, 0].mean(axis=1)  # mid-heel x
    # walker follows with a causal moving average (lag), walker_distance ahead
    n = max(1, int(round(spec.walker_lag_s * spec.fps)))
    pad = np.concatenate([np.full(n - 1, mid[0]), mid])
    walker_x = np.convolve(pad, np.ones(n) / n, mode="valid") - spec.walker_distance
    heights = np.array([spec.heel_point_height, spec.toe_point_height])
    poses: list[LegPose] = []
    for i, t in enumerate(times):
        pw = feet[i].copy()
        pw[:, :, 0] -= walker_x[i]
        pw[:, :, 2] += heights[None, :]
        legs = np.zeros((2, 5, 3))
        for f in range(2):
            heel, toe = pw[f, 0], pw[f, 1]
            ankle = heel + np.array([-0.05, 0.0, 0.07])
            legs[f, HEEL], legs[f, TOE], legs[f, ANKLE] = heel, toe, ankle
            legs[f, KNEE] = ankle + np.array([0.0, 0.0, 0.45])
            legs[f, HIP] = legs[f, KNEE] + np.array([0.0, 0.0, 0.45])
        cam = (legs - off) @ rot  # inverse of p_w = R p_c + t
        if spec.noise_m > 0:
            cam = cam + rng.normal(0.0, spec.noise_m, cam.shape)
        status, conf = TrackStatus.TRACKING, 1.0
        if any(a <= t < b for a, b in spec.lost):
            status, conf = TrackStatus.SEARCHING, 0.0
            cam = np.full_like(cam, np.nan)
        elif any(a <= t < b for a, b in spec.degraded):
            status, conf = TrackStatus.DEGRADED, 0.3
        for t0, t1, side, amp in spec.shuffle:
            if t0 <= t < t1:  # small in-place foot slide (world), walker frame = world shift
                shift = amp * math.sin(2 * math.pi * (t - t0) / (t1 - t0))
                sh_w = np.array([shift, 0.5 * shift, 0.0])
                cam[side] = cam[side] + rot.T @ sh_w
        poses.append(LegPose(stamp=float(t), points=cam, status=status, confidence=conf))
    # GT event positions into the camera frame at their times
    ev_cam = []
    for e in events:
        i = int(np.clip(np.searchsorted(times, e.stamp), 0, times.size - 1))
        h = heights[0] if e.kind == EventKind.HEEL_STRIKE else heights[1]
        p_w = np.array([e.position[0] - walker_x[i], e.position[1], h])
        if e.kind == EventKind.TOE_OFF:
            p_w[0] -= spec.foot_length
        ev_cam.append(replace(e, position=(p_w - off) @ rot))
    return GaitSimResult(poses=poses, floor=floor, events=ev_cam, steps=steps, footfalls=footfalls, spec=spec)


# --------------------------------------------------------------------------------------
# matching (reusable)


def _match(gt_t: FloatArray, gt_side: NDArray[np.int_], det_t: FloatArray, det_side: NDArray[np.int_],
           max_dt: float) -> list[tuple[int, int]]:
    cand = []
    for i in range(gt_t.size):
        for j in range(det_t.size):
            if gt_side[i] == det_side[j]:
                d = abs(gt_t[i] - det_t[j])
                if d <= max_dt:
                    cand.append((d, i, j))
    cand.sort()
    used_g, used_d, pairs = set(), set(), []
    for _, i, j in cand:
        if i not in used_g and j not in used_d:
            used_g.add(i)
            used_d.add(j)
            pairs.append((i, j))
    pairs.sort()
    return pairs


def match_steps(gt: list[Step], det: list[Step], *, max_dt: float = 0.25) -> tuple[list[tuple[int, int]], list[int], list[int]]:
    """One-to-one matching of ground-truth and detected steps of the same foot by HS time.

    Greedy on increasing ``|Δt|`` (≤ ``max_dt`` s), which is optimal for well-separated
    events.  Returns ``(pairs (gt_index, det_index), unmatched_gt, unmatched_det)``.
    """
    pairs = _match(np.array([s.stamp for s in gt]), np.array([int(s.side) for s in gt]),
                   np.array([s.stamp for s in det]), np.array([int(s.side) for s in det]), max_dt)
    mg = {i for i, _ in pairs}
    md = {j for _, j in pairs}
    return pairs, [i for i in range(len(gt)) if i not in mg], [j for j in range(len(det)) if j not in md]


def match_events(gt: list[GaitEvent], det: list[GaitEvent], *, kind: EventKind, max_dt: float = 0.25
                 ) -> tuple[list[tuple[int, int]], list[int], list[int]]:
    """Like :func:`match_steps` for events of one ``kind``; indices refer to the filtered lists."""
    g = [e for e in gt if e.kind == kind]
    d = [e for e in det if e.kind == kind]
    pairs = _match(np.array([e.stamp for e in g]), np.array([int(e.side) for e in g]),
                   np.array([e.stamp for e in d]), np.array([int(e.side) for e in d]), max_dt)
    mg = {i for i, _ in pairs}
    md = {j for _, j in pairs}
    return pairs, [i for i in range(len(g)) if i not in mg], [j for j in range(len(d)) if j not in md]


def run_analyzer(poses: list[LegPose], floor: FloorPlane | list[FloorPlane], *, config: GaitConfig | None = None
                 ) -> GaitAnalyzer:
    """Feed a pose sequence through a fresh :class:`GaitAnalyzer` (and ``finish()`` it)."""
    ga = GaitAnalyzer(config or GaitConfig())
    for i, p in enumerate(poses):
        ga.update(p, floor[i] if isinstance(floor, list) else floor)
    ga.finish()
    return ga


def session_summaries(gt: list[Step], det: list[Step], *, checked: bool, config: GaitConfig | None = None
                      ) -> tuple[GaitSummaryData, GaitSummaryData]:
    """The session summary a clinician reads of the detected steps ``det`` (``summarize_steps`` with the analyzer's
    confidence cuts, as ``GaitAnalyzer.summary`` gives them; ``checked``: steps checked against two tracking passes,
    as the offline pipeline's) and the same summary of the true steps ``gt``, whose cadence is the walkway's
    definition (60 / their mean step time): ``(true, detected)``."""
    cfg = config or GaitConfig()
    true = summarize_steps(gt, max_step_time_s=cfg.max_step_time_s, max_step_time_ratio=cfg.summary_max_step_time_ratio,
                           fit_step_rate=False)
    found = summarize_steps(det, max_step_time_s=cfg.max_step_time_s, min_confidence=cfg.summary_min_confidence,
                            max_step_time_ratio=cfg.summary_max_step_time_ratio,
                            min_time_confidence=cfg.summary_min_time_confidence,
                            min_speed_confidence=cfg.summary_min_time_confidence if checked else None)
    return true, found


def evaluate_gait(gt_steps: list[Step], gt_events: list[GaitEvent], ga: GaitAnalyzer, *, fps: float,
                  max_dt: float = 0.25, max_step_time_s: float = 2.5) -> dict[str, Any]:
    """Accuracy figures of one analysed session vs its ground truth (units: m, s, %, frames)."""
    det = ga.steps
    pairs, ug, ud = match_steps(gt_steps, det, max_dt=max_dt)
    n_tp = len(pairs)
    # detections that are real heel strikes without a GT step (ground truths that, like
    # GAITRite, give the first footfall of a bout no step) are reported, not counted as false
    g_hs = [e for e in gt_events if e.kind == EventKind.HEEL_STRIKE]
    gt_hs_t = np.array([e.stamp for e in g_hs])
    gt_hs_s = np.array([int(e.side) for e in g_hs])
    initiation = [j for j in ud if gt_hs_t.size and np.any(
        (gt_hs_s == int(det[j].side)) & (np.abs(gt_hs_t - det[j].stamp) <= max_dt)
        & ~np.isin(gt_hs_t, [s.stamp for s in gt_steps]))]
    n_det = len(det) - len(initiation)
    prec = n_tp / n_det if n_det else math.nan
    rec = n_tp / len(gt_steps) if gt_steps else math.nan

    def err(attr: str) -> FloatArray:
        e = np.array([getattr(det[j], attr) - getattr(gt_steps[i], attr) for i, j in pairs])
        return e[np.isfinite(e)] if e.size else e

    out: dict[str, Any] = {
        "gt_steps": len(gt_steps),
        "det_steps": len(det),
        "matched": n_tp,
        "det_initiation_steps": len(initiation),
        "precision": prec,
        "recall": rec,
    }
    for attr in ("step_length", "step_width", "step_time", "stride_length", "swing_time", "stance_time",
                 "double_support_time"):
        e = err(attr)
        out[f"{attr}_mae"] = float(np.mean(np.abs(e))) if e.size else math.nan
        out[f"{attr}_bias"] = float(np.mean(e)) if e.size else math.nan
    for kind, name in ((EventKind.HEEL_STRIKE, "hs"), (EventKind.TOE_OFF, "to")):
        ep, eug, eud = match_events(gt_events, ga.events, kind=kind, max_dt=max_dt)
        g = [e for e in gt_events if e.kind == kind]
        d = [e for e in ga.events if e.kind == kind]
        te = np.array([d[j].stamp - g[i].stamp for i, j in ep])
        out[f"{name}_precision"] = len(ep) / len(d) if d else math.nan
        out[f"{name}_recall"] = len(ep) / len(g) if g else math.nan
        out[f"{name}_timing_median_abs_ms"] = float(np.median(np.abs(te)) * 1e3) if te.size else math.nan
        out[f"{name}_timing_median_abs_frames"] = float(np.median(np.abs(te)) * fps) if te.size else math.nan
        out[f"{name}_timing_bias_ms"] = float(np.mean(te) * 1e3) if te.size else math.nan
    # the summary a clinician reads: the analyzer's own cuts (confidence, step-time ratio) on its steps, against
    # the true steps' (cadence by the walkway's definition: 60 / mean step time)
    ratio = ga.config.summary_max_step_time_ratio
    sg = summarize_steps(gt_steps, max_step_time_s=max_step_time_s, max_step_time_ratio=ratio, fit_step_rate=False)
    sd = summarize_steps(det, max_step_time_s=max_step_time_s, min_confidence=ga.config.summary_min_confidence,
                         min_time_confidence=ga.config.summary_min_time_confidence, max_step_time_ratio=ratio)
    out["cadence_gt"] = sg.cadence
    out["cadence_det"] = sd.cadence
    out["cadence_error_pct"] = 100.0 * (sd.cadence - sg.cadence) / sg.cadence if sg.cadence else math.nan
    out["speed_error_pct"] = 100.0 * (sd.gait_speed - sg.gait_speed) / sg.gait_speed if sg.gait_speed else math.nan
    out["mean_confidence"] = sd.mean_confidence
    return out


# --------------------------------------------------------------------------------------
# scenarios


SCENARIOS: dict[str, GaitSimSpec] = {
    "normal": GaitSimSpec(),
    "slow": GaitSimSpec(step_length=(0.30, 0.30), step_time=(0.9, 0.9), swing_fraction=(0.33, 0.33),
                        bouts=(("stand", 1.0), ("walk", 10), ("stand", 1.0))),
    "asymmetric": GaitSimSpec(step_length=(0.45, 0.32), step_time=(0.55, 0.72), swing_fraction=(0.40, 0.33)),
    "stop_and_go": GaitSimSpec(bouts=(("stand", 1.0), ("walk", 6), ("stand", 3.0), ("walk", 7), ("stand", 1.0))),
    "variable": GaitSimSpec(lateral_jitter_m=0.02, length_jitter_m=0.03,
                            bouts=(("stand", 1.0), ("walk", 20), ("stand", 1.0))),
    "stand_still": GaitSimSpec(bouts=(("stand", 3.0),)),
}
"""Named kinematic scenarios of :func:`run_gait_bench`."""


def synth_available() -> bool:
    """Whether :mod:`walker_gait.synth.session` (``generate_session`` + ground truth) imports."""
    try:
        from walker_gait.synth.session import SessionSpec, generate_session  # noqa: F401
    except Exception:  # noqa: BLE001 - any import problem means "not usable yet"
        return False
    return True


def run_gait_bench(*, scenarios: list[str] | tuple[str, ...] = ("normal", "slow", "asymmetric", "stop_and_go",
                                                                  "variable"),
                   seed: int = 0, noise_m: float = 0.0, source: str = "kinematic",
                   config: GaitConfig | None = None) -> list[dict[str, Any]]:
    """Run the analyzer on each scenario and compare with ground truth; one dict per scenario.

    ``noise_m``: σ (m) of iid Gaussian noise added to every camera-frame point.
    ``source``: ``"kinematic"`` (:data:`SCENARIOS`) or ``"synth"`` (raises if unavailable).
    """
    results = []
    for k, name in enumerate(scenarios):
        rng = np.random.default_rng([seed, k])
        t0 = time.perf_counter()
        if source == "kinematic":
            spec = replace(SCENARIOS[name], noise_m=noise_m)
            sim = simulate_gait(spec, rng=rng)
            poses, floor, gt_steps, gt_events, fps = sim.poses, sim.floor, sim.steps, sim.events, spec.fps
        elif source == "synth":
            poses, floor, gt_steps, gt_events, fps = _synth_session(name, rng=rng, noise_m=noise_m)
        else:
            raise ValueError(f"unknown source {source!r}")
        t_gen = time.perf_counter() - t0
        t0 = time.perf_counter()
        ga = run_analyzer(poses, floor, config=config)
        t_run = time.perf_counter() - t0
        res = {"scenario": name, "source": source, "seed": seed, "noise_m": noise_m, "frames": len(poses),
               "gen_s": t_gen, "analyze_s": t_run}
        res.update(evaluate_gait(gt_steps, gt_events, ga, fps=fps))
        results.append(res)
    return results


def _synth_session(name: str, *, rng: np.random.Generator, noise_m: float):  # type: ignore[no-untyped-def]
    """Adapter to :mod:`walker_gait.synth.session`: ground-truth leg points (camera frame) of a
    scenario preset as poses, its GT steps/events as :class:`Step`/:class:`GaitEvent`.

    Uses the generator's exact leg points (no rendering, no tracker), optionally with iid noise.
    """
    if not synth_available():
        raise RuntimeError("walker_gait.synth.session.generate_session is not importable")
    from walker_gait.synth.session import SessionSpec, generate_session

    session = generate_session(SessionSpec.preset(name), rng=rng)
    pts = np.asarray(session.leg_points, dtype=np.float64)
    if noise_m > 0:
        pts = pts + rng.normal(0.0, noise_m, pts.shape)
    poses = [LegPose(stamp=float(t), points=pts[i]) for i, t in enumerate(session.stamps)]
    steps = [Step(stamp=g.stamp, side=Side(int(g.side)), index=g.index, step_length=g.step_length,
                  step_width=g.step_width, step_time=g.step_time, stride_length=g.stride_length,
                  stride_time=g.stride_time, stance_time=g.stance_time, swing_time=g.swing_time,
                  single_support_time=g.single_support_time, double_support_time=g.double_support_time)
             for g in session.steps]
    events = [GaitEvent(stamp=e.stamp, side=Side(int(e.side)), kind=EventKind(int(e.kind)),
                        position=np.asarray(e.position_world, dtype=np.float64)) for e in session.events]
    return poses, session.floor, steps, events, float(session.spec.fps)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenarios", nargs="+", default=["normal", "slow", "asymmetric", "stop_and_go", "variable"])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--noise", type=float, nargs="+", default=[0.0, 0.01])
    ap.add_argument("--source", default="kinematic")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    rows = []
    for nz in args.noise:
        rows += run_gait_bench(scenarios=args.scenarios, seed=args.seed, noise_m=nz, source=args.source)
    if args.json:
        print(json.dumps(rows, indent=1, default=float))
        return
    cols = ["scenario", "noise_m", "gt_steps", "det_steps", "precision", "recall", "step_length_mae",
            "step_width_mae", "hs_timing_median_abs_frames", "to_timing_median_abs_frames", "cadence_error_pct",
            "mean_confidence"]
    print(" ".join(f"{c[:14]:>14}" for c in cols))
    for r in rows:
        print(" ".join(f"{r[c]:>14.4f}" if isinstance(r[c], float) else f"{str(r[c]):>14}" for c in cols))


if __name__ == "__main__":
    main()
