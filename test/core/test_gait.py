"""Tests of walker_gait.core.gait (events, steps, summary) on kinematic walker sessions.

The sessions come from :func:`walker_gait.bench.gait.simulate_gait`: feet planted in the
world with a rocker roll-over, a walker following the user (so planted feet drift through
the walker/camera frame), converted to the camera frame of a camera 0.5 m above the floor
pitched down 0.5 rad.  Ground truth is exact by construction.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import fields, replace
from pathlib import Path

import numpy as np
import pytest

from walker_gait.bench.gait import (
    SCENARIOS,
    GaitSimResult,
    GaitSimSpec,
    evaluate_gait,
    match_events,
    match_steps,
    run_analyzer,
    simulate_gait,
)
from walker_gait.core.gait import (
    GaitAnalyzer,
    GaitConfig,
    GaitInputError,
    GaitSummaryData,
    _hinge_time,
    _rot2,
    fitted_step_time,
    stride_in_line,
    summarize_steps,
)
from walker_gait.core.types import HEEL, TOE, EventKind, FloatArray, FloorPlane, LegPose, Side, Step, TrackStatus

REPO = Path(__file__).resolve().parents[2]


def _run(spec: GaitSimSpec, seed: int = 0):  # type: ignore[no-untyped-def]
    sim = simulate_gait(spec, rng=np.random.default_rng(seed))
    ga = run_analyzer(sim.poses, sim.floor)
    return sim, ga, evaluate_gait(sim.steps, sim.events, ga, fps=spec.fps)


# ---------------------------------------------------------------------------- basics


def test_hinge_fit_recovers_subframe_breakpoint() -> None:
    t = np.arange(0.0, 0.5, 1 / 30)
    tc = 0.2377
    y_hs = 0.3 * np.maximum(tc - t, 0.0) + 0.02  # moving then flat (heel strike)
    y_to = 0.5 * np.maximum(t - tc, 0.0) ** 2  # flat then accelerating (toe off)
    assert abs(_hinge_time(t, [y_hs], rising=False, tc_lo=0.0, tc_hi=0.5) - tc) < 0.003
    assert abs(_hinge_time(t, [y_to], rising=True, tc_lo=0.0, tc_hi=0.5) - tc) < 0.003


def test_hinge_fit_with_drift_recovers_the_breakpoint_of_a_foot_landing_before_a_moving_walker() -> None:
    """Walker frame: the swinging heel moves forward fast, lands, then drifts back at the walker's speed.  The hinge
    with a free linear drift (``drift``) finds the landing; the plain one, which expects the heel to stop, puts it
    late (the drift looks like the end of the swing)."""
    t = np.arange(0.0, 0.5, 1 / 30)
    tc = 0.2377
    y = 1.2 * np.maximum(tc - t, 0.0) ** 1.5 - 0.5 * t  # swing (decelerating) then drift at -0.5 m/s
    found = _hinge_time(t, [y], rising=False, tc_lo=0.0, tc_hi=0.5, drift=(0,))
    assert abs(found - tc) < 0.003
    plain = _hinge_time(t, [y], rising=False, tc_lo=0.0, tc_hi=0.5)
    assert plain - tc > 0.05
    # only the channels listed drift: a flat height channel with it changes nothing
    h = 0.2 * np.maximum(tc - t, 0.0)
    assert abs(_hinge_time(t, [h, y], rising=False, tc_lo=0.0, tc_hi=0.5, drift=(1,)) - tc) < 0.003


def test_input_validation() -> None:
    ga = GaitAnalyzer(GaitConfig())
    floor = FloorPlane.from_camera_pose(height=0.5, pitch=0.5)
    with pytest.raises(GaitInputError):
        ga.update(LegPose(stamp=0.0, points=np.zeros((2, 4, 3))), floor)
    ga.update(LegPose(stamp=1.0, points=np.ones((2, 5, 3))), floor)
    with pytest.raises(GaitInputError):
        ga.update(LegPose(stamp=1.0, points=np.ones((2, 5, 3))), floor)
    with pytest.raises(GaitInputError):
        GaitConfig(rest_speed_mps=-1.0)
    for bad in ({"planted_fit_sigma_s": -0.1}, {"planted_fit_window_s": 0.0}, {"hs_height_weight": math.nan},
                {"landing_toe_fit_s": -0.3}, {"landing_visibility": 1.5}, {"landing_visibility": math.nan},
                {"hs_resume_distance_m": 0.0}, {"hs_resume_distance_m": math.nan},
                {"progression_from_feet_deg": 0.0}, {"progression_from_feet_deg": 181.0},
                {"heading_offset_min_m": -0.01}, {"heading_offset_min_m": math.nan},
                {"progression_from_feet_deg": math.nan}, {"hidden_ground_gate_mps": -0.1},
                {"hidden_ground_gate_mps": math.nan}):
        with pytest.raises(GaitInputError, match=next(iter(bad))):
            GaitConfig(**bad)
    GaitConfig(planted_fit_sigma_s=0.0, hs_height_weight=0.0, landing_toe_fit_s=0.0, landing_visibility=0.0)  # 0 = off
    GaitConfig(hidden_ground_gate_mps=math.inf)  # off


def test_frame_quality_rule() -> None:
    ga = GaitAnalyzer()
    floor = FloorPlane.from_camera_pose(height=0.5, pitch=0.5)
    pts = np.ones((2, 5, 3))
    assert ga.frame_quality(LegPose(stamp=0.0, points=pts, confidence=0.9), floor) == pytest.approx(0.9)
    assert ga.frame_quality(LegPose(stamp=0.0, points=pts, status=TrackStatus.SEARCHING), floor) == 0.0
    assert ga.frame_quality(
        LegPose(stamp=0.0, points=pts, status=TrackStatus.DEGRADED, confidence=0.8), floor
    ) == pytest.approx(0.4)
    bad = pts.copy()
    bad[1, 4, 0] = np.nan  # right toe lost
    assert ga.frame_quality(LegPose(stamp=0.0, points=bad), floor) == 0.0


# ---------------------------------------------------------------------------- accuracy


def test_first_step_hovering_mid_swing_is_one_step() -> None:
    """The synthetic ``slow_elderly`` subject's first step from standing hovers 2 cm above the floor for a few
    frames mid-swing (heel nearly still relative to the other foot), then swings on.  The strike detected in the
    hover is withdrawn when the heel moves on: one step, not two, on the exact leg points.  The toe off that ends
    the hover is timed after the hovering strike (no toe off before its own foot's landing), so it falls within
    ``min_stance_time_s`` of it, which withdraws the strike; without that withdrawal (``min_stance_time_s`` 0.01) the
    hover is a second step."""
    from walker_gait.bench.gait import _synth_session

    poses, floor, gt, events, fps = _synth_session("slow_elderly", rng=np.random.default_rng(0), noise_m=0.0)
    r = evaluate_gait(gt, events, run_analyzer(poses, floor), fps=fps)
    assert r["precision"] == 1.0 and r["recall"] == 1.0, (r["precision"], r["recall"])
    for cfg in (GaitConfig(min_stance_time_s=0.01), GaitConfig(min_stance_time_s=0.01, hs_resume_distance_m=math.inf)):
        off = evaluate_gait(gt, events, run_analyzer(poses, floor, config=cfg), fps=fps)
        assert off["det_steps"] == r["det_steps"] + 1 and off["precision"] < 1.0


@pytest.mark.parametrize("name", ["normal", "slow", "asymmetric"])
def test_clean_walks_exact(name: str) -> None:
    """Exact leg points.  The default times heel strikes and toe offs on the foot's own walker-frame track with a
    linear drift for the walker passing a planted foot; this simulated walker surges (+-30 % within each step), which
    bends that drift: heel strikes within 1.3 frames (measured 1.22 on ``slow``).  Timed against the other foot
    (``hs_walker_frame`` / ``to_walker_frame`` off), which the surges do not reach: within a frame."""
    sim, ga, r = _run(SCENARIOS[name])
    assert r["precision"] == 1.0 and r["recall"] == 1.0
    assert r["step_length_mae"] < 0.003
    assert r["step_width_mae"] < 0.003
    assert r["hs_timing_median_abs_frames"] <= 1.3
    relative = evaluate_gait(sim.steps, sim.events,
                             run_analyzer(sim.poses, sim.floor,
                                          config=GaitConfig(hs_walker_frame=False, to_walker_frame=False)),
                             fps=SCENARIOS[name].fps)
    assert relative["precision"] == 1.0 and relative["recall"] == 1.0
    assert relative["hs_timing_median_abs_frames"] <= 1.0
    assert relative["to_timing_median_abs_frames"] <= 1.0
    assert r["to_timing_median_abs_frames"] <= 1.0
    assert abs(r["cadence_error_pct"]) < 1.0
    assert all(s.confidence > 0.95 for s in ga.steps)
    # events alternate HS/TO per foot and are in time order
    for side in Side:
        kinds = [e.kind for e in ga.events if e.side == side]
        assert all(kinds[i] != kinds[i + 1] for i in range(len(kinds) - 1))


@pytest.mark.parametrize("swing_fraction", [0.42, 0.45])
def test_short_double_support_with_noisy_feet(swing_fraction: float) -> None:
    """Double support of 0.06-0.1 s (shorter than the rest window) and 2 cm point noise: the landing
    heel's relative track may not come to rest before the other foot lifts off; the analyzer must
    still find every step once, without the just-landed foot (toe still coming down) swinging again.
    (Before: recall/precision 0.92, and 0.3/0.5 for an intermediate version of the landing rule.)"""
    spec = replace(SCENARIOS["normal"], swing_fraction=(swing_fraction, swing_fraction), noise_m=0.02)
    for seed in range(3):
        sim, ga, r = _run(spec, seed)
        assert r["precision"] == 1.0 and r["recall"] == 1.0, (seed, r["precision"], r["recall"])
        assert r["step_length_mae"] < 0.03


TRACKED = REPO / "test" / "core" / "data" / "tracked_sessions.npz"
"""Tracker output (``default`` preset) of 8 s synthetic sessions from ``make sweep``: ``a141``, ``a142``
(``asymmetric``, set A, 96 particles, tracker seed 0), ``b541`` (``asymmetric``, set B, 192 particles, seed 0),
``a132`` (``occlusion``, set A, 192 particles, seed 1), ``a160`` (``absent_start``, set A, 14 s, the default preset
of the twenty-eighth session, seed 0), ``a131`` (``occlusion``, set A, the twenty-ninth session's default, seed 0),
``c910`` (``slow_elderly``, set C, the thirty-first session's default, seed 0), ``a120`` (``baggy_trousers``, set A,
the same, seed 0) and ``c931`` (``occlusion``, set C, the same, seed 1):
per frame the LegPose points, visibility, status and
confidence and the pipeline's floor, plus the true heel strikes.  Poses as the live and offline pipelines give
them to the analyzer."""


def _tracked(name: str) -> tuple[list[LegPose], list[FloorPlane], list[Step]]:
    with np.load(TRACKED) as z:
        d = {k.removeprefix(name + "_"): z[k] for k in z.files if k.startswith(name + "_")}
    poses = [LegPose(stamp=float(t), points=p, visibility=v, status=TrackStatus(int(s)), confidence=float(c))
             for t, p, v, s, c in zip(d["stamp"], d["points"], d["visibility"], d["status"], d["confidence"], strict=True)]
    floors = [FloorPlane(normal=n, offset=float(o), rms=float(r), inlier_ratio=float(i), valid=bool(v))
              for n, o, r, i, v in zip(d["floor_normal"], d["floor_offset"], d["floor_rms"], d["floor_inlier"],
                                       d["floor_valid"], strict=True)]
    nan = math.nan
    gt = [Step(stamp=float(t), side=Side(int(s)), index=i, step_length=float(length), step_width=nan, step_time=nan,
               stride_length=nan, stride_time=nan, stance_time=nan, swing_time=nan, single_support_time=nan,
               double_support_time=nan)
          for i, (t, s, length) in enumerate(zip(d["gt_stamp"], d["gt_side"], d["gt_length"], strict=True))]
    return poses, floors, gt


def _tracked_steps(name: str) -> tuple[list[tuple[int, int]], list[int], list[int], FloatArray]:
    """The analyzer on tracked session ``name``: matching against the true steps, and the step length error (m)
    of each matched pair."""
    poses, floors, gt = _tracked(name)
    det = run_analyzer(poses, floors).steps
    pairs, missed, extra = match_steps(gt, det)
    err = np.array([det[j].step_length - gt[i].step_length for i, j in pairs])
    return pairs, missed, extra, err


def test_tracked_foot_held_toe_down_still_lands() -> None:
    """Session 141: the tracker pitches planted feet toe-down (from the front, the shoe's top hides the heel),
    holding the heel 4-6 cm up through whole stances.  A foot whose toe is planted and whose heel has stopped
    advancing has landed.  (Asking for the heel within ``hs_height_tol_m`` of the floor: 6 of 12 steps
    missed, one phantom step.)"""
    poses, floors, gt = _tracked("a141")
    pairs, missed, extra = match_steps(gt, run_analyzer(poses, floors).steps)
    assert len(missed) <= 1 and not extra, ([gt[i].stamp for i in missed], len(extra))


def test_tracked_gait_initiation_with_dragged_swinging_heel() -> None:
    """Session 142, the first two steps: double support of ~4 frames, and the tracked heel of the foot that
    then swings stays within the planted band (the model foot pitched toe-up).  That foot's toe lifts and moves
    forward faster than the walker while the other foot is down: the other foot has landed.  (Asking for the
    swinging heel to be lifted too: both steps missed.)"""
    poses, floors, gt = _tracked("a142")
    pairs, missed, extra = match_steps(gt, run_analyzer(poses, floors).steps)
    assert not missed and not extra, ([gt[i].stamp for i in missed], [gt[i].stamp for i, _ in pairs][:3])


def test_tracked_late_heel_strike_takes_the_trailing_footprint_not_its_swinging_toe() -> None:
    """Sessions b541 and a132: the tracked leading heel comes to rest late (after the other foot's toe off), so no
    frame after the heel strike has the trailing toe on the floor.  Its footprint then comes from the frames in
    which it was planted (the planted-foot fit), not from the toe already swinging forward at that frame.
    (Before, with the raw toe: b541 step length MAE 7.5 cm, two steps short by 19 and 24 cm; a132 four steps short
    by more than 20 cm.  Now 4.6 cm; two.)"""
    _, missed, extra, err = _tracked_steps("b541")
    assert not missed and not extra
    assert np.mean(np.abs(err)) < 0.06  # measured 0.046
    assert np.min(err) > -0.15  # measured -0.107
    pairs, _, _, err = _tracked_steps("a132")
    assert len(pairs) >= 10
    assert np.sum(err < -0.2) <= 2  # measured 2 (-21, -39 cm: the tracker's own foot errors)


def test_tracked_strike_after_the_other_toe_off_measures_toe_to_toe() -> None:
    """Session a131 (``occlusion``): long steps, and heel strikes the tracked heel times after the other foot's toe
    off, so the step has no double-support frame.  Its length is then measured toe to toe like the others (the
    landing foot's flat toe, the trailing foot's planted one), not from the tracked landing heel at the strike,
    which is still moving: one step was 14.6 cm short that way, the session's MAE 3.6 cm (measured now: 1.8,
    largest error 7.1)."""
    pairs, _, _, err = _tracked_steps("a131")
    assert len(pairs) >= 9
    assert np.mean(np.abs(err)) < 0.025
    assert np.min(err) > -0.10


def test_tracked_backward_strides_do_not_turn_the_line_of_progression() -> None:
    """Session a160 (``absent_start``, set A, tracker seed 0): after the user walks in, the tracker's first steps are
    junk (the same foot three times, lengths of +65 to -39 cm), and two of their strides point backwards.  Summed
    into the line of progression they turned it round (walker +x, away from the walker's front), the state
    machine then took the wrong foot as the swinging one, and each wrong step kept the line reversed: every
    later step had the wrong side (2 of 15 true steps matched).  Strides pointing back are left out of it."""
    pairs, missed, extra, err = _tracked_steps("a160")
    assert len(pairs) >= 7, (len(pairs), len(missed), len(extra))  # measured 8 (before: 2)
    late = [i for i, _ in pairs if _tracked("a160")[2][i].stamp > 10.0]
    assert len(late) >= 5  # the walk after the stop at 8-10 s: measured 6 (before: 0)


def test_tracked_junk_steps_of_an_arriving_user_do_not_stop_the_analysis() -> None:
    """Session c961 (``absent_start``, set C, tracker seed 0, the tracker told the user's height; forty-fifth
    session): the user arrives turned against the walker and the first tracked frames give junk steps of one foot.
    A toe off between them was timed before that foot's own last strike (6.90 s after a strike at 7.10 s), which
    escaped the withdrawal of a strike followed by a toe off within ``min_stance_time_s``; the two junk steps left a
    6 cm sideways stride, the line of progression turned across the walker, and the state machine, looking for a
    toe moving forward along it, saw no toe off for 3 s of good tracking: 2 of the 8 steps at the walker matched.
    A toe off is now timed after its foot's last strike, and a stride more than 60 deg off the walker's axis stays
    out of the line (each alone brings the steps back; the first also the order of the events)."""
    poses, floors, gt = _tracked("c961")
    ga = run_analyzer(poses, floors)
    pairs, missed, extra = match_steps(gt, ga.steps)
    assert len(pairs) >= 8 and not extra, (len(pairs), len(extra))  # measured 9, no false step (before: 2 and 3)
    last_hs = [-math.inf, -math.inf]
    for e in ga.events:
        if e.kind == EventKind.HEEL_STRIKE:
            last_hs[int(e.side)] = e.stamp
        else:
            assert e.stamp >= last_hs[int(e.side)], (e, last_hs)


@pytest.mark.parametrize(("deg", "length", "counts"), [(0.0, 0.5, True), (40.0, 0.5, True), (-55.0, 0.3, True),
                                                       (65.0, 0.5, False), (90.0, 0.06, False), (180.0, 0.5, False),
                                                       (0.0, 0.05, False)])
def test_a_stride_enters_the_line_of_progression_only_along_the_walker(deg: float, length: float, counts: bool) -> None:
    """A stride more than 60 deg off the walker's forward axis (or shorter than ``min_swing_distance_m``) is a
    tracking error, not the user's direction: users walk behind a walker, within ~45 deg of its axis even when they
    walk in from the side."""
    forward = np.array([-1.0, 0.0])
    stride = length * (_rot2(math.radians(deg)) @ forward)
    assert stride_in_line(stride, forward, min_length=GaitConfig().min_swing_distance_m) is counts
    turned = _rot2(math.radians(30.0))  # odometry: the walker's forward turned in the world
    assert stride_in_line(turned @ stride, turned @ forward, min_length=0.06) is counts


def test_landing_footprint_comes_from_its_toe() -> None:
    """From the front the landing heel is hidden behind its own toe; the tracker holds it a few cm behind and up
    for the first frames of the stance.  Here it is 3 cm behind for 0.15 s after each heel strike, the toes are
    exact.  The landing footprint comes from that foot's toe once it is flat (toe to toe): no error.  From its
    heel over the double support (``landing_toe_fit_s`` 0): every step 1.6-2.3 cm short."""
    spec = SCENARIOS["normal"]
    sim = simulate_gait(spec, rng=np.random.default_rng(0))
    rot, off = sim.floor.walker_transform()
    strikes = [(int(e.side), e.stamp) for e in sim.events if e.kind == EventKind.HEEL_STRIKE]
    poses = []
    for p in sim.poses:
        w = p.points @ rot.T + off
        for f, t_e in strikes:
            if t_e <= p.stamp < t_e + 0.15:
                w[f, HEEL, 0] += 0.03  # walker +x points at the user: behind
        poses.append(replace(p, points=(w - off) @ rot))
    toe = evaluate_gait(sim.steps, sim.events, run_analyzer(poses, sim.floor), fps=spec.fps)
    heel = evaluate_gait(sim.steps, sim.events, run_analyzer(poses, sim.floor, config=GaitConfig(landing_toe_fit_s=0.0)),
                         fps=spec.fps)
    assert toe["precision"] == 1.0 and toe["recall"] == 1.0
    assert toe["step_length_mae"] < 0.002  # measured 0.0002
    assert heel["step_length_mae"] > 0.012  # measured 0.018


def test_summary_times_include_doubted_steps_so_heel_strike_errors_cancel() -> None:
    """A step's time is its heel strike's, whatever the doubt on its footprint: the temporal statistics pool the
    steps down to ``summary_min_time_confidence`` (0.25), the spatial ones from ``summary_min_confidence`` (0.5).
    Heel strikes every 0.6 s, the fifth timed 0.1 s late (its step 0.7 s, the next 0.5 s) and doubted
    (confidence 0.4, 20 cm too long): the late strike all but cancels in the cadence (99.6 steps/min; exactly 100
    with the mean step time); left out with its step, the next step's 0.5 s would raise it above 101.5 (102.1 with
    the mean step time).  A step below 0.25 (implausible geometry) is left out of both."""
    nan = math.nan
    times = [0.6 * k for k in range(10)]
    times[5] += 0.1
    steps = [Step(stamp=t, side=Side(k % 2), index=k, step_length=0.5 + (0.2 if k == 5 else 0.0), step_width=0.1,
                  step_time=t - times[k - 1] if k else nan, stride_length=nan, stride_time=nan, stance_time=nan,
                  swing_time=nan, single_support_time=nan, double_support_time=nan,
                  confidence=0.4 if k == 5 else 1.0) for k, t in enumerate(times)]
    cfg = GaitConfig()
    assert (cfg.summary_min_time_confidence, cfg.summary_min_confidence) == (0.25, 0.5)
    s = summarize_steps(steps, min_confidence=0.5, min_time_confidence=0.25)
    assert s.cadence == pytest.approx(100.0, abs=0.5) and s.step_time_mean == pytest.approx(0.6)
    assert summarize_steps(steps, min_confidence=0.5, min_time_confidence=0.25, fit_step_rate=False).cadence == (
        pytest.approx(100.0))
    assert s.step_length_mean == pytest.approx(0.5)  # the doubted step's length is not pooled
    assert s.gait_speed == pytest.approx(sum(0.5 for k in range(1, 10) if k != 5) / sum(
        times[k] - times[k - 1] for k in range(1, 10) if k != 5))
    # steps checked against two tracking passes: the speed pools the cadence's steps, the doubted one's length too;
    # a footprint placed 20 cm ahead lengthens its step and shortens the next (lengths telescope): the speed is exact
    assert summarize_steps(steps, min_confidence=0.5, min_time_confidence=0.25,
                           min_speed_confidence=0.25).gait_speed == pytest.approx((0.5 * 8 + 0.7) / (times[9] - times[0]))
    ahead = [replace(st, step_length=st.step_length - (0.2 if k == 6 else 0.0)) for k, st in enumerate(steps)]
    assert summarize_steps(ahead, min_confidence=0.5, min_time_confidence=0.25,
                           min_speed_confidence=0.25).gait_speed == pytest.approx(0.5 * 9 / (times[9] - times[0]))
    old = summarize_steps(steps, min_confidence=0.5)  # time cut = spatial cut: the run of strikes is broken
    assert old.cadence > 101.5
    assert summarize_steps(steps, min_confidence=0.5, fit_step_rate=False).cadence == pytest.approx(
        60.0 / ((0.6 * 7 + 0.5) / 8))  # 102.1 from the mean step time
    steps[5] = replace(steps[5], confidence=0.2)
    assert summarize_steps(steps, min_confidence=0.5, min_time_confidence=0.25).cadence == pytest.approx(old.cadence)
    # the analyzer's summary uses both cuts
    ga = GaitAnalyzer(GaitConfig())
    ga._steps = [replace(st, confidence=0.4 if k == 5 else 1.0) for k, st in enumerate(steps)]
    assert ga.summary().cadence == pytest.approx(s.cadence)
    assert ga.summary().gait_speed == pytest.approx(s.gait_speed)
    assert ga.summary(checked=True).gait_speed == pytest.approx(
        summarize_steps(ga._steps, min_confidence=0.5, min_time_confidence=0.25, min_speed_confidence=0.25).gait_speed)
    assert ga.summary(checked=True).gait_speed != pytest.approx(s.gait_speed)
    for bad in ({"summary_min_time_confidence": 0.6}, {"summary_min_time_confidence": -0.1},
                {"summary_min_confidence": 1.5, "summary_min_time_confidence": 0.5}):
        with pytest.raises(GaitInputError):
            GaitConfig(**bad)


def test_summary_skips_step_times_that_span_a_missed_footfall() -> None:
    """Heel strikes every 0.6 s with steps 5 and 6 missed: the step detected after them spans three step times
    (1.8 s, under ``max_step_time_s``) and would take the cadence from 100 to 84.2 steps/min.  It is more than
    ``summary_max_step_time_ratio`` (1.8) times the median step time, so the summary skips it; so do the gait
    speed and the analyzer's summary.  Asymmetric gait (0.5 / 0.7 s) keeps every step."""
    nan = math.nan

    def steps_at(times: list[float]) -> list[Step]:
        return [Step(stamp=t, side=Side(k % 2), index=k, step_length=0.5, step_width=0.1,
                     step_time=t - times[k - 1] if k else nan, stride_length=nan, stride_time=nan, stance_time=nan,
                     swing_time=nan, single_support_time=nan, double_support_time=nan) for k, t in enumerate(times)]

    times = [0.6 * k for k in range(12) if k not in (5, 6)]
    steps = steps_at(times)
    assert summarize_steps(steps, fit_step_rate=False).cadence == pytest.approx(60.0 * 9 / (0.6 * 11))  # 81.8: off
    assert summarize_steps(steps).cadence < 95.0  # the fitted rate counts the long step as one step too
    s = summarize_steps(steps, max_step_time_ratio=1.8)
    assert s.cadence == pytest.approx(100.0) and s.gait_speed == pytest.approx(0.5 / 0.6)
    ga = GaitAnalyzer(GaitConfig())
    ga._steps = steps
    assert ga.summary().cadence == pytest.approx(100.0)
    asym = steps_at([k * 0.6 + (0.1 if k % 2 else 0.0) for k in range(12)])
    assert summarize_steps(asym, max_step_time_ratio=1.8).cadence == pytest.approx(summarize_steps(asym).cadence)
    for bad in (1.0, math.nan):
        with pytest.raises(GaitInputError, match="summary_max_step_time_ratio"):
            GaitConfig(summary_max_step_time_ratio=bad)


def _steps_at(times: list[float]) -> list[Step]:
    nan = math.nan
    return [Step(stamp=t, side=Side(k % 2), index=k, step_length=0.5, step_width=0.1,
                 step_time=t - times[k - 1] if k else nan, stride_length=nan, stride_time=nan, stance_time=nan,
                 swing_time=nan, single_support_time=nan, double_support_time=nan) for k, t in enumerate(times)]


@pytest.mark.parametrize("n", [1, 2, 3, 4, 8, 9])
def test_fitted_step_time_of_even_strikes_is_the_step_time(n: int) -> None:
    times = [1.0 + 0.55 * k for k in range(n + 1)]
    steps = _steps_at(times)
    assert fitted_step_time(steps) == pytest.approx(0.55)
    assert summarize_steps(steps).cadence == pytest.approx(summarize_steps(steps, fit_step_rate=False).cadence)


@pytest.mark.parametrize("n", [4, 5, 8, 9])
def test_fitted_step_time_of_an_asymmetric_gait(n: int) -> None:
    """Steps alternating 0.7 and 0.5 s: with an offset for every other strike the fit reproduces the mean step
    time exactly (0.62 s for 5 steps), and with the first strike 0.05 s late it errs less than the mean."""
    times = [0.6 * k + (0.1 if k % 2 else 0.0) for k in range(n + 1)]
    steps = _steps_at(times)
    exact = summarize_steps(steps, fit_step_rate=False).step_time_mean
    assert exact == pytest.approx((0.6 * n + (0.1 if n % 2 else 0.0)) / n)  # 0.62 s for 5 steps
    assert fitted_step_time(steps) == pytest.approx(exact)
    times[0] += 0.05
    steps = _steps_at(times)
    fit_err = abs(fitted_step_time(steps) - exact)
    assert fit_err < abs(summarize_steps(steps, fit_step_rate=False).step_time_mean - exact)


@pytest.mark.parametrize("n", [4, 6, 8, 9, 12])
def test_fitted_step_time_reduces_the_error_of_a_late_first_strike(n: int) -> None:
    """The first heel strike of a run (after a stop, a gap) timed 0.1 s late: the mean step time rests on it and
    its run's last strike alone (error 0.1 / n); the fit weighs every strike (errors 0.80, 0.64, 0.53, 0.60 and
    0.40 times the mean's for 4, 6, 8, 9 and 12 steps)."""
    times = [0.6 * k for k in range(n + 1)]
    times[0] += 0.1
    steps = _steps_at(times)
    mean_err = abs(summarize_steps(steps, fit_step_rate=False).step_time_mean - 0.6)
    assert mean_err == pytest.approx(0.1 / n)
    assert abs(fitted_step_time(steps) - 0.6) <= (0.85 if n < 8 else 0.65) * mean_err


def test_fitted_step_time_pools_unbroken_runs_by_their_steps() -> None:
    """Two runs of heel strikes (a step whose previous strike is not the last one kept starts a new run): 4 steps
    of 0.5 s and 6 of 0.8 s give (4 x 0.5 + 6 x 0.8) / 10 = 0.68 s; steps without a step time are ignored."""
    first = _steps_at([0.5 * k for k in range(5)])
    second = _steps_at([10.0 + 0.8 * k for k in range(7)])
    assert fitted_step_time(first + second) == pytest.approx(0.68)
    assert fitted_step_time(second[::-1] + first[::-1]) == pytest.approx(0.68)  # order does not matter
    assert math.isnan(fitted_step_time([]))
    assert math.isnan(fitted_step_time(first[:1]))  # a first step has no step time


def test_a_step_after_a_same_side_step_has_no_step_time() -> None:
    """Session a160 (``absent_start``): the tracker's first steps after the user walks in include the same foot
    twice in a row.  Such a step's time from the last opposite heel strike would span the missed footfall, so it
    is NaN; every step after an opposite one has its time.  (By default the first of the two is withdrawn as a
    foot stopping mid-swing, see the next test; a stance as short as that is allowed here to keep the repeat, and
    the ground is seen through the hidden feet as tracked, ``hidden_ground_gate_mps`` off, which also avoids it.)"""
    poses, floors, _ = _tracked("a160")
    steps = run_analyzer(poses, floors, config=GaitConfig(min_stance_time_s=0.01, hidden_ground_gate_mps=math.inf)).steps
    repeat = [b for a, b in zip(steps, steps[1:]) if a.side == b.side]
    assert repeat and all(math.isnan(s.step_time) for s in repeat)
    assert all(math.isfinite(b.step_time) for a, b in zip(steps, steps[1:]) if a.side != b.side)


def test_a_foot_that_stops_mid_swing_and_swings_on_makes_one_step() -> None:
    """Session c910 (``slow_elderly``): the first step from standing, while the walker starts to roll.  In the walker
    frame the swinging foot stands still for a few frames 0.3 s before it lands (in the world it hovers 1-2 cm
    up); a heel strike is detected there and the toe leaves again 0.09 s later.  A stance that short, with no
    strike of the other foot since, is no footfall: that step is withdrawn, its foot's swing goes on, and the
    real strike makes the only step."""
    poses, floors, gt = _tracked("c910")
    pairs, _, extra = match_steps(gt, run_analyzer(poses, floors).steps)
    short = GaitConfig(min_stance_time_s=0.01)
    pairs_short, _, extra_short = match_steps(gt, run_analyzer(poses, floors, config=short).steps)
    assert len(extra) == len(extra_short) - 1, (len(extra), len(extra_short))
    assert len(pairs) == len(pairs_short)
    steps = run_analyzer(poses, floors).steps
    assert all(a.side != b.side or b.stamp - a.stamp > 0.4 for a, b in zip(steps, steps[1:]))
    # the real step's swing runs from the swing's toe off, not from the hover's
    assert 0.3 < steps[0].swing_time < 0.6, steps[0].swing_time


def test_a_strike_with_no_double_support_frame_takes_the_walkers_late_drift_for_the_trailing_toe() -> None:
    """Session a120 (``baggy_trousers``, set A, tracker seed 0), the first step from standing, while the walker starts
    to roll: the trailing foot is hidden behind the leading leg's trousers and its toe off is timed at the heel
    strike, so the step has no double-support frame and takes the frame nearest the strike.  The trailing toe
    there continues the drift seen while it was in view (standing still) and must ramp to the walker's drift
    past the landing foot (its flat frames), as it does for steps with double-support frames: the walker moved
    on meanwhile.  (Without the ramp: -12.9 cm.)"""
    pairs, missed, extra, err = _tracked_steps("a120")
    assert len(pairs) >= 10 and not extra
    assert abs(err[0]) < 0.04, err[0]  # measured +0.8 cm
    assert np.mean(np.abs(err)) < 0.025  # measured 1.2 cm (2.2 before)


def _strike_timing(poses: list[LegPose], gt: list[Step], analyzer: GaitAnalyzer) -> FloatArray:
    """Signed error (frames) of the heel-strike event nearest to each true strike within 0.25 s."""
    dt = float(np.median(np.diff([p.stamp for p in poses])))
    hs = [e for e in analyzer.events if e.kind == EventKind.HEEL_STRIKE]
    err = []
    for g in gt:
        near = [e.stamp for e in hs if e.side == g.side and abs(e.stamp - g.stamp) <= 0.25]
        if near:
            err.append((min(near, key=lambda t: abs(t - g.stamp)) - g.stamp) / dt)
    return np.array(err)


def test_tracked_hidden_stance_foot_does_not_carry_the_ground_away() -> None:
    """Session b533 (``occlusion``, set B, tracker seed 0): early on, the tracker carries the hidden right foot by its
    motion model and its planted heel moves back 13 cm in 0.37 s where the real one moved 6 cm.  The landing left
    heel, measured against it, seemed to advance, and the first two strikes were never detected.  The ground's
    motion under the hidden foot from the feet last seen planted (``hidden_ground_gate_mps``) finds all twelve
    steps.  The strikes, now detected a frame or two after they happen, are timed on the fit window that ends where
    the heel comes to rest against the feet as tracked (``_fit_end``): ending it at the detection times them early."""
    poses, floors, gt = _tracked("b533")
    on = run_analyzer(poses, floors)
    pairs, missed, extra = match_steps(gt, on.steps)
    assert len(pairs) == len(gt) == 12 and not extra, ([gt[i].stamp for i in missed], len(extra))
    pairs_off, missed_off, _ = match_steps(gt, run_analyzer(poses, floors,
                                                            config=GaitConfig(hidden_ground_gate_mps=math.inf)).steps)
    assert [round(gt[i].stamp, 2) for i in missed_off] == [1.49, 2.03]
    err = _strike_timing(poses, gt, on)
    assert err.size == 12 and np.median(np.abs(err)) < 0.8, err  # measured 0.56 frames (median -0.24)

    class AtDetection(GaitAnalyzer):
        def _fit_end(self, p):  # type: ignore[no-untyped-def]
            return p.t_det

    early = AtDetection(GaitConfig())
    for pose, floor in zip(poses, floors, strict=True):
        early.update(pose, floor)
    early.finish()
    err_early = _strike_timing(poses, gt, early)
    assert np.median(err_early) < -1.0 and np.median(np.abs(err_early)) > 1.2, err_early  # measured -1.40, 1.43


def test_tracked_strike_inside_a_blanked_view_is_timed_there_and_doubted() -> None:
    """Session d030 (``occlusion``, set D, tracker seed 0): a shin before the lens blanks the view from 2.23 to 2.50 s
    (the tracker holds the legs at confidence 0, gap frames for the analyzer), and the right foot lands at 2.34 s,
    inside the gap.  The strike's fit window reaches back to the frames seen before the gap, so the breakpoint can
    fall inside it; the step is reported with a low confidence (its footprint was not seen landing).  (A window
    that starts inside the gap times the strike after it, at 2.64 s: the step is not matched and a false one is
    reported.)"""
    poses, floors, gt = _tracked("d030")
    run = run_analyzer(poses, floors)
    pairs, missed, extra = match_steps(gt, run.steps)
    assert len(pairs) == len(gt) == 12 and not extra, ([gt[i].stamp for i in missed], len(extra))
    i_gap = next(i for i, g in enumerate(gt) if abs(g.stamp - 2.34) < 0.01)
    step = run.steps[dict(pairs)[i_gap]]
    assert abs(step.stamp - gt[i_gap].stamp) < 0.2 and step.confidence < 0.5, step  # measured 2.49 s, 0.43

    class NoGap(GaitAnalyzer):
        def _gap_start(self, t_lo, t_hi):  # type: ignore[no-untyped-def]
            return None

    late = NoGap(GaitConfig())
    for pose, floor in zip(poses, floors, strict=True):
        late.update(pose, floor)
    late.finish()
    pairs_late, missed_late, extra_late = match_steps(gt, late.steps)
    assert i_gap in missed_late and len(extra_late) == 1


def test_the_ground_through_hidden_feet_changes_nothing_while_the_feet_are_seen() -> None:
    """With every foot in view (the kinematic simulation reports no visibility: all seen) the gate never acts and the
    fit windows end at the detections: events and steps are the same with it off."""
    sim = simulate_gait(SCENARIOS["asymmetric"], rng=np.random.default_rng(3))
    on = run_analyzer(sim.poses, sim.floor)
    off = run_analyzer(sim.poses, sim.floor, config=GaitConfig(hidden_ground_gate_mps=math.inf))
    assert len(on.steps) >= 8
    assert [(e.stamp, e.side, e.kind) for e in on.events] == [(e.stamp, e.side, e.kind) for e in off.events]
    assert [s.step_length for s in on.steps] == [s.step_length for s in off.steps]


def test_a_landing_foot_held_heel_up_takes_its_footprint_from_its_planted_toe() -> None:
    """Session c931 (``occlusion``, set C, tracker seed 1): the tracker holds several landing feet toe-down, their
    heels above the planted band for the whole window after the strike, so no frame counts as flat and the step
    fell back to the tracked landing heel (-5.9 and -6.8 cm).  The toe, down within a few frames of the strike
    and staying down, gives the footprint instead (``landing_toe_only``).  (With ``hidden_ground_gate_mps`` off, as
    when this was found: with it one strike, detected 0.25 s late with or without, falls just outside the matching.)"""
    poses, floors, gt = _tracked("c931")

    def errors(config: GaitConfig) -> FloatArray:
        det = run_analyzer(poses, floors, config=config).steps
        pairs, _, extra = match_steps(gt, det)
        assert len(pairs) >= 10 and not extra
        return np.array([det[j].step_length - gt[i].step_length for i, j in pairs])

    err = errors(GaitConfig(hidden_ground_gate_mps=math.inf))
    off = errors(GaitConfig(landing_toe_only=False, hidden_ground_gate_mps=math.inf))
    assert np.mean(np.abs(err)) < 0.035 < np.mean(np.abs(off)), (np.mean(np.abs(err)), np.mean(np.abs(off)))  # 2.95, 4.26
    assert np.sum(np.abs(err) > 0.05) < np.sum(np.abs(off) > 0.05)  # 2 steps off by more than 5 cm, 4 before


def test_a_trailing_foot_never_seen_flat_costs_confidence_only_where_its_offset_is_used(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The trailing foot's flat heel-toe offset enters a step only through the heel formulas (no landing-toe fit,
    no double-support frame); toe to toe it is not used.  A foot the analyzer never saw flat enough for it (at 15 Hz
    most stances: few frames, and a tracked heel that is seldom in the planted band) made every step's confidence
    half, so the summaries left out most steps.  Here the offsets all come from the fallback: the steps measured
    toe to toe keep their confidence, the ones without a landing-toe fit are halved."""
    sim = simulate_gait(SCENARIOS["normal"], rng=np.random.default_rng(0))
    base = run_analyzer(sim.poses, sim.floor).steps
    real_get = GaitAnalyzer._o_get

    def never_flat(self: GaitAnalyzer, f: int) -> tuple[FloatArray | None, bool]:
        o, _ = real_get(self, f)
        return o, True

    monkeypatch.setattr(GaitAnalyzer, "_o_get", never_flat)
    steps = run_analyzer(sim.poses, sim.floor).steps
    assert [s.stamp for s in steps] == [s.stamp for s in base]
    assert len(steps) >= 8
    toe_to_toe = [s.confidence == pytest.approx(b.confidence) for s, b in zip(steps, base, strict=True)]
    assert sum(toe_to_toe) >= len(steps) - 1  # measured: all
    monkeypatch.setattr(GaitAnalyzer, "_landing_fit", lambda self, a, lo, hi: None)
    heel = run_analyzer(sim.poses, sim.floor).steps
    assert all(h.confidence <= 0.5 * b.confidence + 1e-9 for h, b in zip(heel, base, strict=True))


def test_a_step_whose_landing_foot_was_not_seen_is_doubted() -> None:
    """The tracker places a foot it does not see by its motion model; a step whose landing foot was hidden from
    just before its heel strike to 0.2 s after it (the frames that time the strike and place the footprint) gets
    a confidence in proportion to that foot's visibility and drops out of the summary means, however plausible
    its geometry.  A foot half hidden (visibility 0.5, the threshold) costs nothing, nor do the other steps."""
    spec = SCENARIOS["normal"]
    sim = simulate_gait(spec, rng=np.random.default_rng(0))
    strikes = [(int(e.side), e.stamp) for e in sim.events if e.kind == EventKind.HEEL_STRIKE]
    f_hid, t_hid = strikes[len(strikes) // 2]
    f_half, t_half = strikes[len(strikes) // 2 + 2]

    def seen(v_hid: float) -> list[LegPose]:
        out = []
        for p in sim.poses:
            vis = np.ones((2, 3))
            if t_hid - 0.15 <= p.stamp <= t_hid + 0.25:
                vis[f_hid, 1:] = v_hid
            if t_half - 0.15 <= p.stamp <= t_half + 0.25:
                vis[f_half, 2] = 0.5
            out.append(replace(p, visibility=vis))
        return out

    def by_strike(steps: list[Step]) -> dict[float, Step]:
        pairs, _, _ = match_steps(sim.steps, steps)
        return {sim.steps[i].stamp: steps[j] for i, j in pairs}

    plain = by_strike(run_analyzer(sim.poses, sim.floor).steps)
    for v_hid, cfg in ((0.1, GaitConfig()), (0.1, GaitConfig(landing_visibility=0.0)), (1.0, GaitConfig())):
        ga = run_analyzer(seen(v_hid), sim.floor, config=cfg)
        got = by_strike(ga.steps)
        assert got.keys() == plain.keys() and len(got) == len(sim.steps)
        for t, st in got.items():
            hidden = abs(t - t_hid) < 0.05 and v_hid < 0.5 and cfg.landing_visibility > 0
            assert st.step_length == plain[t].step_length  # the footprint is the same; only the trust in it differs
            if hidden:
                assert st.confidence == pytest.approx(plain[t].confidence * v_hid / 0.5, rel=0.05)
            else:
                assert st.confidence == plain[t].confidence
        n_good = sum(1 for st in got.values() if st.confidence >= cfg.summary_min_confidence)
        assert ga.summary().step_count == len(got)  # counted ...
        assert n_good == len(got) - (1 if v_hid < 0.5 and cfg.landing_visibility > 0 else 0)  # ... not pooled


def test_a_toe_off_the_tracker_did_not_see_bounds_no_duration() -> None:
    """A foot hidden from its heel rise into its swing (behind the leading leg, under a trouser hem), or only in the
    0.2 s before its toe off: the toe off is timed on the tracker's motion model or where the foot comes back, so the
    event keeps its time at a quarter of its confidence and the swing, stance, single and double support times it
    bounds are unknown; the steps themselves, their step times and every other duration stay as they are with the
    rule off."""
    spec = SCENARIOS["normal"]
    sim = simulate_gait(spec, rng=np.random.default_rng(0))
    offs = [(int(e.side), e.stamp) for e in sim.events if e.kind == EventKind.TOE_OFF]
    f_hid, t_hid = offs[len(offs) // 2]

    def hidden(lo_s: float, hi_s: float) -> list[LegPose]:
        out = []
        for p in sim.poses:
            vis = np.ones((2, 3))
            if t_hid + lo_s <= p.stamp <= t_hid + hi_s:
                vis[f_hid, 1:] = 0.1
            out.append(replace(p, visibility=vis))
        return out

    def by_strike(steps: list[Step]) -> dict[float, Step]:
        pairs, _, _ = match_steps(sim.steps, steps)
        return {sim.steps[i].stamp: steps[j] for i, j in pairs}

    durations = ("swing_time", "stance_time", "single_support_time", "double_support_time")
    # out of view 0.3 s around it; from 0.25 s before it until just before it (back in view where the tracker's model
    # foot leaves the floor: the toe off timed late there); 0.1 s around it (three frames: still seen)
    for (lo_s, hi_s), unseen in (((-0.15, 0.15), True), ((-0.25, -0.02), True), ((-0.05, 0.05), False)):
        poses = hidden(lo_s, hi_s)
        off = run_analyzer(poses, sim.floor, config=GaitConfig(toe_off_seen_gap_s=0.0))  # every toe off seen
        ga = run_analyzer(poses, sim.floor)
        got, base = by_strike(ga.steps), by_strike(off.steps)
        assert got.keys() == base.keys() and len(got) == len(sim.steps)
        tos = [e for e in ga.events if e.kind == EventKind.TOE_OFF]
        tos0 = [e for e in off.events if e.kind == EventKind.TOE_OFF]
        assert [e.stamp for e in tos] == [e.stamp for e in tos0]
        for e, e0 in zip(tos, tos0, strict=True):
            hid = unseen and int(e.side) == f_hid and abs(e.stamp - t_hid) < 0.05
            assert e.confidence == pytest.approx(e0.confidence * (0.25 if hid else 1.0))
        n_unknown = 0
        for t, st in got.items():
            b = base[t]
            assert (st.step_length, st.step_width, st.confidence) == (b.step_length, b.step_width, b.confidence)
            assert st.step_time == pytest.approx(b.step_time, nan_ok=True)
            for name in durations:
                if math.isnan(getattr(st, name)) and not math.isnan(getattr(b, name)):
                    n_unknown += 1
                    assert unseen and t > t_hid  # only steps after the hidden toe off lose a duration ...
                else:
                    assert getattr(st, name) == pytest.approx(getattr(b, name), nan_ok=True)
        # ... its own swing and stance (the next step of that foot) and the double / single support of the
        # steps whose gait cycle holds it
        assert (n_unknown >= 3) if unseen else n_unknown == 0
    summary = run_analyzer(hidden(-0.15, 0.15), sim.floor).summary()
    assert math.isfinite(summary.double_support_percent)  # the other steps' still make the figure
    for bad in ({"toe_off_seen_gap_s": -0.1}, {"toe_off_seen_gap_s": math.inf}, {"unseen_event_confidence": 1.5}):
        with pytest.raises(GaitInputError, match=next(iter(bad))):
            GaitConfig(**bad)


def test_a_step_the_tracker_doubted_during_its_swing_is_doubted() -> None:
    """A dip of the tracker's confidence (0.6, below ``swing_min_quality``) in the 0.6 s before a heel strike or the
    0.2 s after it halves that step's confidence; steps whose window misses the dip keep theirs, and with the rule
    off every step keeps the confidence the dipped frames alone give it."""
    from walker_gait.core.gait import SWING_QUALITY_BEFORE_S

    spec = SCENARIOS["normal"]
    sim = simulate_gait(spec, rng=np.random.default_rng(0))
    strikes = [e.stamp for e in sim.events if e.kind == EventKind.HEEL_STRIKE]
    t_dip = strikes[len(strikes) // 2] - 0.3  # in the swing of the middle step
    dipped = [replace(p, confidence=0.6) if abs(p.stamp - t_dip) < 0.05 else p for p in sim.poses]

    def by_strike(steps: list[Step]) -> dict[float, Step]:
        pairs, _, _ = match_steps(sim.steps, steps)
        return {sim.steps[i].stamp: steps[j] for i, j in pairs}

    off = by_strike(run_analyzer(dipped, sim.floor, config=GaitConfig(swing_min_quality=0.0)).steps)
    on = by_strike(run_analyzer(dipped, sim.floor, config=GaitConfig()).steps)
    assert GaitConfig().swing_min_quality > 0.6
    assert on.keys() == off.keys() and len(on) == len(sim.steps)
    n_doubted = 0
    for t, st in on.items():
        assert st.step_length == off[t].step_length  # the footprint is the same; only the trust in it differs
        if t - SWING_QUALITY_BEFORE_S <= t_dip + 0.05 and t_dip - 0.05 <= t + 0.2:
            n_doubted += 1
            assert st.confidence == pytest.approx(0.5 * off[t].confidence)
            assert st.confidence < GaitConfig().summary_min_confidence  # out of the summary means
        else:
            assert st.confidence == off[t].confidence
    assert 1 <= n_doubted <= 2
    with pytest.raises(GaitInputError, match="swing_min_quality"):
        GaitConfig(swing_min_quality=1.5)


def test_temporal_parameters_match_ground_truth() -> None:
    sim, ga, r = _run(SCENARIOS["asymmetric"])
    for attr in ("step_time", "swing_time", "stance_time", "double_support_time"):
        assert r[f"{attr}_mae"] < 0.05, attr  # 1.5 frames (DS sums two intervals = 4 event errors)
    pairs, _, _ = match_steps(sim.steps, ga.steps)
    for i, j in pairs:
        g, d = sim.steps[i], ga.steps[j]
        assert math.isnan(g.stride_time) == math.isnan(d.stride_time)


def test_asymmetric_summary_symmetry_ratios() -> None:
    sim, ga, _ = _run(SCENARIOS["asymmetric"])
    s_det = ga.summary()
    s_gt = summarize_steps(sim.steps)
    assert s_det.step_count == len(sim.steps)
    assert s_det.step_length_symmetry == pytest.approx(s_gt.step_length_symmetry, rel=0.02)
    assert s_det.swing_time_symmetry == pytest.approx(s_gt.swing_time_symmetry, rel=0.1)
    assert s_det.step_length_symmetry > 1.2  # left steps are longer in this scenario


def test_step_width_survives_foot_yaw_errors() -> None:
    """Tracked feet turn about the heel by a wobbling yaw error (±12°, the tracker's typical toe-out
    error): the heel and ankle stay put, the toe swings ±4.5 cm sideways.  Step width is taken across
    the line of progression from the ankles (lever ~5 cm), not from the trailing foot's toe + its flat
    heel-toe offset (lever = foot length).  (Toe-based width, before: MAE 2.9 cm here.)"""
    spec = SCENARIOS["normal"]
    sim = simulate_gait(spec, rng=np.random.default_rng(0))
    rot, off = sim.floor.walker_transform()
    poses = []
    for p in sim.poses:
        pts = p.points.copy()
        w = pts @ rot.T + off
        for f in range(2):
            yaw = math.radians(12.0) * math.sin(2 * math.pi * (p.stamp / 1.7 + 0.37 * f))
            w[f, TOE, :2] = w[f, HEEL, :2] + _rot2(yaw) @ (w[f, TOE, :2] - w[f, HEEL, :2])
        poses.append(replace(p, points=(w - off) @ rot))
    ga = run_analyzer(poses, sim.floor)
    r = evaluate_gait(sim.steps, sim.events, ga, fps=spec.fps)
    assert r["precision"] == 1.0 and r["recall"] == 1.0
    assert r["step_width_mae"] < 0.006


def test_step_width_of_toed_out_feet_is_that_of_their_footprints() -> None:
    """Exact leg points of synthetic sessions (``synth``, 'normal', toe-out 8-10°): the trailing foot in its heel
    rise pivots about its toe, its ankle travels forward along the foot and, toed out, sideways.  The width takes
    that foot's heel from its last flat frames (``width_flat_trailing_s``: MAE 0.43 cm, bias -0.03); from its
    ankle at the strike with the travel taken back (``heel_rise_travel``), 0.43 cm, bias -0.03; left in, 0.93 cm
    too wide on average."""
    from walker_gait.bench.endtoend import _gt_as_steps
    from walker_gait.synth import SessionSpec, generate_session

    configs = {"flat": GaitConfig(), "travel": GaitConfig(width_flat_trailing_s=0.0),
               "neither": GaitConfig(width_flat_trailing_s=0.0, heel_rise_travel=False)}
    errors: dict[str, list[float]] = {k: [] for k in configs}
    for seed in range(3):
        s = generate_session(SessionSpec.preset("normal", duration=8.0, toe_out_deg=(8.0, 10.0)),
                             rng=np.random.default_rng(seed))
        poses = [LegPose(stamp=float(t), points=np.asarray(p, dtype=float)) for t, p in zip(s.stamps, s.leg_points, strict=True)]
        gt = _gt_as_steps(s)
        for name, cfg in configs.items():
            ga = run_analyzer(poses, s.params.mount.floor_plane(), config=cfg)
            pairs, _, _ = match_steps(gt, ga.steps)
            assert len(pairs) == len(gt) == len(ga.steps)
            errors[name] += [ga.steps[j].step_width - gt[i].step_width for i, j in pairs]
    for name in ("flat", "travel"):
        e = np.array(errors[name])
        assert np.abs(e).mean() < 0.005 and abs(e.mean()) < 0.002, name
    off = np.array(errors["neither"])
    assert np.abs(off).mean() > 0.008 and off.mean() > 0.006


def test_step_width_takes_the_trailing_heel_from_its_last_flat_frames() -> None:
    """The tracker rolls a trailing foot outward as its heel rises (its ankle 3 cm to the side, in view): the
    step width takes that foot's heel from where it stood flat (measured: MAE 0.19 cm); from its ankle at the
    strike, the roll goes into every width (2.37 cm)."""
    spec = replace(SCENARIOS["normal"], walker_lag_s=0.6)
    sim = simulate_gait(spec, rng=np.random.default_rng(0))
    rot, off = sim.floor.walker_transform()
    poses = []
    for p in sim.poses:
        w = p.points @ rot.T + off
        for f in range(2):
            if w[f, HEEL, 2] > spec.toe_point_height + 0.01 and w[f, TOE, 2] < spec.toe_point_height + 0.003:
                out = np.sign(w[f, HEEL, 1] - w[1 - f, HEEL, 1])
                w[f, :3, 1] += 0.03 * out  # hip, knee, ankle: the leg above the rolled foot
        poses.append(replace(p, points=(w - off) @ rot))
    flat = evaluate_gait(sim.steps, sim.events, run_analyzer(poses, sim.floor), fps=spec.fps)
    assert flat["precision"] == 1.0 and flat["recall"] == 1.0
    at_strike = evaluate_gait(sim.steps, sim.events, run_analyzer(poses, sim.floor, config=GaitConfig(width_flat_trailing_s=0.0)),
                              fps=spec.fps)
    assert flat["step_width_mae"] < 0.003 < 0.015 < at_strike["step_width_mae"], (flat["step_width_mae"], at_strike["step_width_mae"])


def _turn_foot(sim: GaitSimResult, side: Side, *, t_on: float, t_off: float, deg: float = 45.0) -> list[LegPose]:
    """``sim``'s poses with foot ``side``'s heel turned by ``deg`` about its toe from ``t_on`` to ``t_off`` (ramped in
    over 0.3 s before ``t_on`` and out over 0.2 s after ``t_off``); the ankle, which gives the step width and the
    line of progression, stays, so only the foot's heading changes."""
    rot, off = sim.floor.walker_transform()
    f = int(side)
    poses = []
    for p in sim.poses:
        w = p.points @ rot.T + off
        ramp = float(np.clip((p.stamp - t_on + 0.3) / 0.3, 0.0, 1.0)) * float(np.clip(1.0 - (p.stamp - t_off) / 0.2, 0.0, 1.0))
        w[f, HEEL, :2] = w[f, TOE, :2] + _rot2(math.radians(deg) * ramp) @ (w[f, HEEL, :2] - w[f, TOE, :2])
        poses.append(replace(p, points=(w - off) @ rot))
    return poses


@pytest.mark.parametrize("start", ["standing_start", "after_a_stop"])
def test_a_trailing_foot_turned_against_the_landing_one_is_measured_heel_to_heel(start: str) -> None:
    """A user stands with the left foot turned 45° (about its toe: its heel L (1 - cos 45°) = 6.4 cm further
    forward than a straight foot's) and walks off straight.  Toe to toe, the first step came out 6.4 cm long
    (measured: +6.4 / +6.2 cm); ``heading_offsets`` adds the difference of the two feet's heel-toe offsets along
    the line (measured: -0.02 / +0.08 cm; +0.5 cm with the default soft threshold ``heading_offset_min_m``), and
    after a stop the turned footprint's next stride gets it too (+6.5 -> +0.5 cm).  Feet that point alike get
    nothing added (the other steps equal to the millimetre)."""
    bouts = ((("stand", 1.0), ("walk", 12), ("stand", 1.0)) if start == "standing_start"
             else (("stand", 1.0), ("walk", 4), ("stand", 2.0), ("walk", 6), ("stand", 1.0)))
    spec = replace(SCENARIOS["normal"], bouts=bouts)
    sim = simulate_gait(spec, rng=np.random.default_rng(0))
    hs = sorted(e.stamp for e in sim.events if e.kind == EventKind.HEEL_STRIKE and e.side == Side.LEFT)
    to = sorted(e.stamp for e in sim.events if e.kind == EventKind.TOE_OFF and e.side == Side.LEFT)
    t_on = 0.3 if start == "standing_start" else hs[1] + 1.1  # the stand after the first bout's last left step
    t_off = min(t for t in to if t > t_on)
    poses = _turn_foot(sim, Side.LEFT, t_on=t_on, t_off=t_off)
    shorter = spec.foot_length * (1.0 - math.cos(math.radians(45.0)))
    first = min(i for i, s in enumerate(sim.steps) if s.stamp > t_on)  # the right foot lands, the left one trails
    assert sim.steps[first].side == Side.RIGHT
    stride = first + 1  # the left foot's next landing: its stride from the turned footprint
    steps = {}
    configs = {"off": GaitConfig(heading_offsets=False), "exact": GaitConfig(heading_offset_min_m=0.0),
               "default": GaitConfig()}
    for name, cfg in configs.items():
        ga = run_analyzer(poses, sim.floor, config=cfg)
        pairs, _, _ = match_steps(sim.steps, ga.steps)
        assert len(pairs) == len(sim.steps) == len(ga.steps)
        steps[name] = {i: ga.steps[j] for i, j in pairs}
    err = {name: steps[name][first].step_length - (sim.steps[first].step_length - shorter) for name in steps}
    # the default's soft threshold leaves its 0.5 cm of the term out
    assert err["off"] > 0.05 and abs(err["exact"]) < 0.003 and 0.002 < err["default"] < 0.008, err
    for name in ("exact", "default"):
        for i, s in steps[name].items():
            if i != first:
                assert s.step_length == pytest.approx(steps["off"][i].step_length, abs=0.001), (name, i)
    if start == "after_a_stop":  # the stride of the turned footprint's foot: its heel was `shorter` further forward
        d_off = steps["off"][stride].stride_length - (sim.steps[stride].stride_length - shorter)
        d_on = steps["exact"][stride].stride_length - (sim.steps[stride].stride_length - shorter)
        assert d_off > 0.05 and abs(d_on) < 0.01, (d_off, d_on)


@pytest.mark.parametrize("deg", [25.0, -40.0])
def test_a_user_walking_at_an_angle_to_the_walker_has_that_line_of_progression_from_the_first_step(deg: float) -> None:
    """A user walks at ``deg`` to the walker's axis (the whole session turned about the vertical in the walker's
    frame: a user walking up to the walker from the side).  Before the first stride the line of progression was
    the walker's axis, and the first step, a half step with the feet 16 cm apart, came out 5-15 cm off in length
    and 8-13 cm in width; both feet pointing the same way, more than ``progression_from_feet_deg`` off the axis,
    give the line instead: every step exact.  Walking along the axis nothing changes."""
    spec = replace(SCENARIOS["normal"], bouts=(("stand", 1.0), ("walk", 6), ("stand", 1.0)))
    sim = simulate_gait(spec, rng=np.random.default_rng(0))
    rot, off = sim.floor.walker_transform()
    turn = _rot2(math.radians(deg))
    poses = []
    for p in sim.poses:
        w = p.points @ rot.T + off
        w[..., :2] = w[..., :2] @ turn.T
        poses.append(replace(p, points=(w - off) @ rot))
    for fdeg in (15.0, 180.0):
        ga = run_analyzer(poses, sim.floor, config=GaitConfig(progression_from_feet_deg=fdeg))
        pairs, _, _ = match_steps(sim.steps, ga.steps)
        assert len(pairs) == len(sim.steps) == len(ga.steps)
        err = np.array([[ga.steps[j].step_length - sim.steps[i].step_length, ga.steps[j].step_width - sim.steps[i].step_width]
                        for i, j in pairs])
        if fdeg == 15.0:
            assert np.abs(err).max() < 0.002, err
        else:  # the first step along the walker's axis
            assert np.abs(err[0]).min() > 0.04 and np.abs(err[1:]).max() < 0.002, err
    straight = run_analyzer(sim.poses, sim.floor)
    assert [s.step_length for s in straight.steps] == pytest.approx([s.step_length for s in sim.steps], abs=0.002)


def _hide_trailing_foot(spec: GaitSimSpec, *, error_m: float, lateral_m: float = 0.0
                        ) -> tuple[GaitSimResult, list[LegPose], list[LegPose]]:
    """Session whose trailing foot, once the other foot is 5 cm ahead of its toe, is reported hidden and
    drifts ``error_m`` ahead and ``lateral_m`` sideways (+y; ramping in and out over 0.1 s; hidden until the
    error is gone): what the tracker does with a foot behind the leading leg.  Returns (sim, poses with
    visibility, same without)."""
    sim = simulate_gait(spec, rng=np.random.default_rng(0))
    rot, off = sim.floor.walker_transform()
    dt = 1.0 / spec.fps
    walker = [p.points @ rot.T + off for p in sim.poses]
    env = np.zeros(2)
    with_vis, without = [], []
    for p, w in zip(sim.poses, walker, strict=True):
        hid = np.array([w[f, TOE, 2] < spec.toe_point_height + 0.003 and w[1 - f, HEEL, 0] < w[f, TOE, 0] - 0.05
                        for f in range(2)])
        env = np.clip(env + np.where(hid, 1.0, -1.0) * dt / 0.1, 0.0, 1.0)
        w = w.copy()
        w[:, :, 0] -= error_m * env[:, None]  # walker x points at the user: -x = ahead
        w[:, :, 1] += lateral_m * env[:, None]
        vis = np.where((hid | (env > 0))[:, None], 0.0, 1.0) * np.ones((2, 3))
        moved = replace(p, points=(w - off) @ rot)
        with_vis.append(replace(moved, visibility=vis))
        without.append(moved)
    return sim, with_vis, without


def test_hidden_trailing_foot_continues_its_seen_drift() -> None:
    """The trailing foot, hidden behind the leading leg late in its stance, is reported 8 cm ahead of where
    it is.  With the tracker's visibility the step vector takes that foot's toe from the drift seen while it
    was in view (planted foot = walker motion, constant here), not from the hidden frames.  Control: the
    same poses without visibility (or with the fit off) carry the 8 cm into the step length."""
    spec = replace(SCENARIOS["normal"], walker_lag_s=0.6)  # following window = step time: steady walker
    sim, with_vis, without = _hide_trailing_foot(spec, error_m=0.08)
    r = evaluate_gait(sim.steps, sim.events, run_analyzer(with_vis, sim.floor), fps=spec.fps)
    assert r["precision"] == 1.0 and r["recall"] == 1.0
    assert r["step_length_mae"] < 0.016
    for poses, cfg in ((without, GaitConfig()), (with_vis, GaitConfig(planted_fit_sigma_s=0.0))):
        ctrl = evaluate_gait(sim.steps, sim.events, run_analyzer(poses, sim.floor, config=cfg), fps=spec.fps)
        assert ctrl["step_length_mae"] > 0.05


def test_hidden_trailing_foot_follows_a_walker_that_speeds_up() -> None:
    """Gait initiation: the walker speeds up over the first steps of each bout, so a trailing foot hidden late in
    its stance (and reported 8 cm ahead) drifts faster than while it was seen.  The planted fit's drift ramps from
    that foot's own to the landing foot's (flat after its strike, both feet planted then): the first steps of
    the two bouts are off by at most 3.1 cm instead of 7.6 (measured), step length MAE 1.9 -> 1.0 cm."""
    spec = replace(SCENARIOS["normal"], walker_lag_s=0.6,
                   bouts=(("stand", 1.0), ("walk", 6), ("stand", 1.5), ("walk", 6), ("stand", 1.0)))
    sim, with_vis, _ = _hide_trailing_foot(spec, error_m=0.08)
    errors = {}
    for ramp in (True, False):
        ga = run_analyzer(with_vis, sim.floor, config=GaitConfig(planted_drift_ramp=ramp))
        pairs, _, _ = match_steps(sim.steps, ga.steps)
        assert len(pairs) == len(sim.steps) == len(ga.steps)
        errors[ramp] = np.abs([ga.steps[j].step_length - sim.steps[i].step_length for i, j in pairs])
    assert errors[True].max() < 0.035 < 0.07 < errors[False].max()
    assert errors[True].mean() < 0.012 < 0.018 < errors[False].mean()


def test_hidden_trailing_foot_keeps_its_seen_lateral_place() -> None:
    """The hidden trailing foot reported 10 cm to the side (+y, the tracker's legs crossing or parting behind
    the leading leg): the step width takes that foot's ankle from its seen drift too, as its toe for the length
    (measured: 0.01 cm off).  Control: the same poses without visibility carry the error ramping in over the
    double support into the step widths (1.2 cm)."""
    spec = replace(SCENARIOS["normal"], walker_lag_s=0.6)
    sim, with_vis, without = _hide_trailing_foot(spec, error_m=0.0, lateral_m=0.10)
    r = evaluate_gait(sim.steps, sim.events, run_analyzer(with_vis, sim.floor), fps=spec.fps)
    assert r["precision"] == 1.0 and r["recall"] == 1.0
    ctrl = evaluate_gait(sim.steps, sim.events, run_analyzer(without, sim.floor), fps=spec.fps)
    assert r["step_width_mae"] < 0.002 < 0.008 < ctrl["step_width_mae"], (r["step_width_mae"], ctrl["step_width_mae"])


def test_planted_drift_ramp_starts_at_the_fits_centre_and_stays_at_the_late_drift() -> None:
    """The planted-foot fit with a late drift ``v`` at ``t_v``: a toe drifting at 0.5 m/s, fitted around the last
    frame (Gaussian weights, its data's centre 0.2 s or so before it), and ``v`` = 1 m/s.  The drift ramps from
    the fit's slope at the data's centre to ``v`` at ``t_v`` and stays at ``v`` after it, so the frame moves ahead
    by at most ``(v - slope) x lead`` (``t_v`` at the centre) and by less the later ``t_v`` (nothing in the limit);
    a ``t_v`` before the centre, or a frame before the centre (the first one: its data lie after it), moves nothing."""
    cfg = GaitConfig()
    ga = GaitAnalyzer(cfg)
    n = 30
    t = np.arange(n) / 30.0
    ga._t[:n], ga._q[:n], ga._valid[:n], ga._vis[:n] = t, 1.0, True, 1.0
    ga._raw[:n, 0, 1, 0], ga._raw[:n, 0, 1, 1] = 0.2 + 0.5 * t, 0.1  # foot 0's toe, walker frame
    ga._weight[:n, 0, 1] = 1.0
    ga._n = n
    idx = np.array([0, n - 1])
    v = np.array([1.0, 0.0])
    base = ga._planted_point(idx, 0, -math.inf, fit_only=True)
    assert base[:, 0] == pytest.approx(0.2 + 0.5 * t[[0, n - 1]])  # a straight drift is fitted exactly
    w = np.exp(-0.5 * ((t - t[-1]) / cfg.planted_fit_sigma_s) ** 2)
    centre = float(w @ t / w.sum())
    lead = t[-1] - centre
    gains = []
    for t_v in (centre - 0.1, centre + 2e-3, centre + 0.05, t[-1], t[-1] + 1.0, t[-1] + 1e4):
        out = ga._planted_point(idx, 0, -math.inf, fit_only=True, late_drift=(v, t_v))
        assert out[0] == pytest.approx(base[0])  # the first frame lies before its data's centre
        assert out[1, 1] == pytest.approx(0.1)
        gains.append(out[1, 0] - base[1, 0])
    assert gains[0] == pytest.approx(0.0, abs=1e-12)
    assert gains[1] == pytest.approx(0.5 * lead, rel=0.01)  # v from the centre on
    assert gains[1] > gains[2] > gains[3] > gains[4] > gains[5] > 0.0
    assert gains[5] < 1e-4


def test_visible_feet_keep_their_raw_positions() -> None:
    """Visibility 1 everywhere changes nothing: the step metrics are those of poses without visibility."""
    spec = SCENARIOS["normal"]
    sim = simulate_gait(spec, rng=np.random.default_rng(3))
    seen = [replace(p, visibility=np.ones((2, 3))) for p in sim.poses]
    a = run_analyzer(sim.poses, sim.floor).steps
    b = run_analyzer(seen, sim.floor).steps
    assert len(a) == len(b) > 0
    assert [s.step_length for s in a] == [s.step_length for s in b]


@pytest.mark.parametrize("name", ["normal", "slow", "stop_and_go", "variable"])
def test_noise_1cm_robustness(name: str) -> None:
    """1 cm noise on every point: detection, step length/width and heel-strike timing hold.  The default times
    heel strikes by the heel's horizontal arrest alone (measured 0.8-1.9 frames here); the heel's height next to its
    position relative to the other foot, sharper on exact kinematics but late on tracked heels (see
    test_lagging_heel_height_...), gets them within a frame."""
    spec = replace(SCENARIOS[name], noise_m=0.01)
    tp = gt = det = 0
    sl, sw, hs, hs_height = [], [], [], []
    for seed in range(2):
        sim, ga, r = _run(spec, seed)
        tp += r["matched"]
        gt += r["gt_steps"]
        det += r["det_steps"]
        sl.append(r["step_length_mae"])
        sw.append(r["step_width_mae"])
        hs.append(r["hs_timing_median_abs_frames"])
        ga_h = run_analyzer(sim.poses, sim.floor, config=GaitConfig(hs_height_weight=1.0, hs_walker_frame=False))
        hs_height.append(evaluate_gait(sim.steps, sim.events, ga_h, fps=spec.fps)["hs_timing_median_abs_frames"])
    assert tp / det >= 0.98 and tp / gt >= 0.98
    assert np.mean(sl) <= 0.015
    assert np.mean(sw) <= 0.015
    assert np.median(hs) <= 1.75
    assert np.median(hs_height) <= 1.0


# ---------------------------------------------------------------------------- no phantom steps


@pytest.mark.parametrize("noise", [0.0, 0.01, 0.02])
def test_stand_still_3s_has_no_steps(noise: float) -> None:
    spec = GaitSimSpec(bouts=(("stand", 3.0),), noise_m=noise)
    sim, ga, _ = _run(spec, seed=3)
    assert ga.steps == [] and ga.events == []
    assert ga.summary().step_count == 0


def test_shuffling_in_place_has_no_steps() -> None:
    spec = GaitSimSpec(
        bouts=(("stand", 4.0),),
        shuffle=((0.5, 1.3, 0, 0.03), (1.6, 2.2, 1, 0.025), (2.5, 3.5, 0, 0.02)),
        noise_m=0.005,
    )
    sim, ga, _ = _run(spec, seed=4)
    assert ga.steps == []


def test_walker_moving_with_feet_still_has_no_steps() -> None:
    """The walker rolls 40 cm back and forth while the user stands: feet drift in the camera
    frame together, which must not look like steps."""
    sim = simulate_gait(GaitSimSpec(bouts=(("stand", 4.0),)), rng=np.random.default_rng(5))
    rot, off = sim.floor.walker_transform()
    poses = []
    for p in sim.poses:
        shift = np.array([0.2 * math.sin(2 * math.pi * p.stamp / 2.0) + 0.2, 0.0, 0.0])  # walker frame
        poses.append(replace(p, points=p.points + rot.T @ shift))
    ga = run_analyzer(poses, sim.floor)
    assert ga.steps == [] and ga.events == []


def test_stop_and_go_resumes_cleanly() -> None:
    spec = SCENARIOS["stop_and_go"]  # 6 steps, 3 s stop, 7 steps
    sim, ga, r = _run(spec)
    assert r["precision"] == 1.0 and r["recall"] == 1.0
    assert r["step_length_mae"] < 0.003
    t_stop0 = sim.steps[5].stamp
    t_stop1 = sim.steps[6].stamp
    assert not [e for e in ga.events if t_stop0 + 0.3 < e.stamp < t_stop1 - 1.0]
    # the first step after the stop includes the pause: excluded from cadence
    s = ga.summary()
    assert abs(s.cadence - summarize_steps(sim.steps, fit_step_rate=False).cadence) / s.cadence < 0.02
    assert 60.0 / s.cadence == pytest.approx(0.6, rel=0.03)


# ---------------------------------------------------------------------------- degraded input


def test_lost_tracking_mid_step_gives_low_confidence_step() -> None:
    base = SCENARIOS["normal"]
    sim0 = simulate_gait(base, rng=np.random.default_rng(0))
    hs = [s.stamp for s in sim0.steps]
    k = 5  # lose tracking for 0.3 s inside the swing that ends at step k
    gap = (hs[k] - 0.35, hs[k] - 0.05)
    sim, ga, r = _run(replace(base, lost=(gap,)))
    assert r["precision"] == 1.0 and r["recall"] == 1.0  # not invented, not dropped
    pairs, _, _ = match_steps(sim.steps, ga.steps)
    conf = {i: ga.steps[j].confidence for i, j in pairs}
    assert conf[k] < 0.6
    assert all(c > 0.9 for i, c in conf.items() if abs(i - k) > 1)
    assert ga.lost_intervals == []  # short gap: bridged, no reset


def test_long_tracking_loss_resets_without_inventing_steps() -> None:
    base = replace(SCENARIOS["normal"], bouts=(("stand", 1.0), ("walk", 16), ("stand", 1.0)))
    sim0 = simulate_gait(base, rng=np.random.default_rng(0))
    hs = [s.stamp for s in sim0.steps]
    gap = (hs[5] + 0.1, hs[8] + 0.1)  # ~1.8 s: three footfalls never seen
    sim, ga, r = _run(replace(base, lost=(gap,)))
    assert len(ga.lost_intervals) == 1
    pairs, _, unmatched_det = match_steps(sim.steps, ga.steps)
    assert unmatched_det == []  # nothing invented
    lost = [i for i, s in enumerate(sim.steps) if gap[0] <= s.stamp <= gap[1]]
    assert len(pairs) >= len(sim.steps) - len(lost) - 2  # everything else recovered


def test_user_first_seen_mid_walk_keeps_every_later_step() -> None:
    """A session that starts without the user (NO_USER frames: a user walking in) and first sees them mid-walk,
    at a heel strike: the state machine leaves INIT with both feet on the floor and the next toe off times its
    swing from then.  (It used to take the swing's start from time 0, before the track began, found no heel
    there and never closed that swing: every later step of the session was lost, in 6 of 63 such entries with
    1 cm noise, and in the sweep's absent-start sessions once the tracker stopped taking a wheel for legs.)"""
    for name in ("normal", "asymmetric"):
        base = replace(SCENARIOS[name], bouts=(("stand", 0.5), ("walk", 14), ("stand", 1.0)), noise_m=0.01)
        hs = [s.stamp for s in simulate_gait(base, rng=np.random.default_rng(0)).steps]
        for cut in (hs[2], hs[4]):
            for seed in range(3):
                sim, ga, _ = _run(replace(base, lost=((-1.0, cut),)), seed)
                pairs, _, extra = match_steps(sim.steps, ga.steps)
                later = {i for i, s in enumerate(sim.steps) if s.stamp > cut + 1.0}
                assert later <= {i for i, _ in pairs}, (name, cut, seed)
                assert extra == []


def test_degraded_frames_lower_confidence() -> None:
    base = SCENARIOS["normal"]
    sim0 = simulate_gait(base, rng=np.random.default_rng(0))
    t = sim0.steps[6].stamp
    sim, ga, r = _run(replace(base, degraded=((t - 0.5, t + 0.2),)))
    assert r["precision"] == 1.0 and r["recall"] == 1.0
    pairs, _, _ = match_steps(sim.steps, ga.steps)
    conf = {i: ga.steps[j].confidence for i, j in pairs}
    assert conf[6] < 0.6 and conf[2] > 0.9


# ---------------------------------------------------------------------------- timing, latency


def test_subframe_heel_strike_timing() -> None:
    # step time 0.61 s at 30 fps: heel strikes fall at every sub-frame phase
    spec = GaitSimSpec(step_time=(0.61, 0.61), bouts=(("stand", 1.0), ("walk", 14), ("stand", 1.0)))
    sim = simulate_gait(spec, rng=np.random.default_rng(0))
    g = [e for e in sim.events if e.kind == EventKind.HEEL_STRIKE]
    # default: the heel's horizontal arrest; 1: with the heel's height, sharper on exact kinematics
    for weight, limit in ((0.0, 1.0), (1.0, 0.7)):  # measured 0.76 / 0.54 frame on this model
        ga = run_analyzer(sim.poses, sim.floor, config=GaitConfig(hs_height_weight=weight))
        ep, _, _ = match_events(sim.events, ga.events, kind=EventKind.HEEL_STRIKE)
        d = [e for e in ga.events if e.kind == EventKind.HEEL_STRIKE]
        err = np.array([d[j].stamp - g[i].stamp for i, j in ep])
        assert len(ep) == len(g)
        assert np.median(np.abs(err)) < limit / spec.fps
        frac = np.array([(e.stamp * spec.fps) % 1.0 for e in d])
        assert np.ptp(frac) > 0.5  # stamps are not snapped to frames


def test_lagging_heel_height_does_not_delay_heel_strikes() -> None:
    """A tracked heel comes down late (its last centimetres are below the segmentation's floor cut): here its
    height lags by 3 frames, its horizontal position does not.  The default times the strike by the horizontal
    arrest and stays within a frame; weighting the height in (1.0) makes it late."""
    spec = SCENARIOS["normal"]
    sim = simulate_gait(spec, rng=np.random.default_rng(0))
    rot, off = sim.floor.walker_transform()
    walker = np.array([p.points @ rot.T + off for p in sim.poses])
    walker[3:, :, HEEL, 2] = walker[:-3, :, HEEL, 2].copy()
    poses = [replace(p, points=(w - off) @ rot) for p, w in zip(sim.poses, walker, strict=True)]
    default = evaluate_gait(sim.steps, sim.events, run_analyzer(poses, sim.floor), fps=spec.fps)
    height = evaluate_gait(sim.steps, sim.events, run_analyzer(poses, sim.floor, config=GaitConfig(hs_height_weight=1.0)),
                           fps=spec.fps)
    assert default["precision"] == 1.0 and default["recall"] == 1.0
    assert default["hs_timing_median_abs_frames"] < 1.0  # measured 0.76
    assert height["hs_timing_median_abs_frames"] > 1.3  # measured 1.52


def test_toe_raised_early_does_not_advance_toe_offs() -> None:
    """A tracked toe is raised early in the heel rise (the sweep's tracked toe offs came 1-1.2 frames early with
    the toe's height in the fit): here its height leads by 3 frames, its horizontal position does not.  The default
    times toe offs on the toe's walker-frame position and stays within half a frame; the toe's height (off) makes
    them early."""
    for name in ("normal", "slow", "asymmetric"):
        spec = SCENARIOS[name]
        sim = simulate_gait(spec, rng=np.random.default_rng(0))
        rot, off = sim.floor.walker_transform()
        walker = np.array([p.points @ rot.T + off for p in sim.poses])
        walker[:-3, :, TOE, 2] = walker[3:, :, TOE, 2].copy()
        poses = [replace(p, points=(w - off) @ rot) for p, w in zip(sim.poses, walker, strict=True)]
        default = evaluate_gait(sim.steps, sim.events, run_analyzer(poses, sim.floor), fps=spec.fps)
        height = evaluate_gait(sim.steps, sim.events,
                               run_analyzer(poses, sim.floor, config=GaitConfig(to_walker_frame=False)), fps=spec.fps)
        assert default["precision"] == 1.0 and default["recall"] == 1.0, name
        assert default["to_timing_median_abs_frames"] < 0.5, name  # measured 0.18-0.34
        assert height["to_timing_median_abs_frames"] > 1.3, name  # measured 1.5-1.72
        assert height["to_timing_bias_ms"] < -30, name  # early: -48 to -59 ms


def test_online_latency_is_bounded() -> None:
    sim = simulate_gait(SCENARIOS["normal"], rng=np.random.default_rng(0))
    ga = GaitAnalyzer()
    lat_ev, lat_st = [], []
    for p in sim.poses:
        ev, st = ga.update(p, sim.floor)
        lat_ev += [p.stamp - e.stamp for e in ev]
        lat_st += [p.stamp - s.stamp for s in st]
    ev, st = ga.finish()
    assert max(lat_ev) < 0.6
    assert max(lat_st) < 0.8 + GaitConfig().landing_toe_fit_s  # the landing foot's flat frames (measured 1.03 s)
    assert len(ga.steps) == len(sim.steps)


def test_odometry_rotates_footprints_consistently() -> None:
    """With odometry of a walker that does not turn the results equal the odometry-free ones."""
    sim = simulate_gait(SCENARIOS["normal"], rng=np.random.default_rng(0))
    ga = GaitAnalyzer()
    for p in sim.poses:
        ga.update_odometry(p.stamp, 0.0, 0.0, 0.3)  # constant heading, arbitrary world yaw
        ga.update(p, sim.floor)
    ga.finish()
    ref = run_analyzer(sim.poses, sim.floor)
    assert len(ga.steps) == len(ref.steps)
    for a, b in zip(ga.steps, ref.steps):
        assert a.step_length == pytest.approx(b.step_length, abs=1e-6)
        assert a.step_width == pytest.approx(b.step_width, abs=1e-6)


# ---------------------------------------------------------------------------- summary


def _msg_fields(name: str) -> list[str]:
    text = (REPO / "msg_defs" / "msg" / name).read_text()
    out = []
    for line in text.splitlines():
        line = line.split("#", 1)[0].strip()
        m = re.match(r"^([A-Za-z0-9_/\[\]]+)\s+([a-z_0-9]+)$", line)
        if m and m.group(2) != "header":
            out.append(m.group(2))
    return out


def test_summary_mirrors_message_and_is_json() -> None:
    sim, ga, _ = _run(SCENARIOS["variable"])
    names = {f.name for f in fields(GaitSummaryData)}
    missing = [f for f in _msg_fields("GaitSummary.msg") if f not in names]
    assert missing == []
    s = ga.summary()
    assert s.scope == GaitSummaryData.SESSION and s.window_duration == 0.0
    w = ga.summary(window_s=5.0)
    assert w.scope == GaitSummaryData.WINDOW and w.window_duration == 5.0
    assert 0 < w.step_count < s.step_count
    # given steps (the offline check's) are summarised instead of the analyzer's own, with its configuration
    doubted = [replace(st, confidence=0.4) if i % 3 == 0 else st for i, st in enumerate(ga.steps)]
    given = ga.summary(steps=doubted)
    assert given.step_count == s.step_count and given.mean_confidence < s.mean_confidence
    assert given.to_dict() == summarize_steps(
        doubted, scope=GaitSummaryData.SESSION, max_step_time_s=ga.config.max_step_time_s,
        min_confidence=ga.config.summary_min_confidence, min_time_confidence=ga.config.summary_min_time_confidence,
        max_step_time_ratio=ga.config.summary_max_step_time_ratio).to_dict()
    assert ga.summary(steps=doubted, window_s=5.0).step_count == w.step_count
    d = json.loads(json.dumps(s.to_dict(), allow_nan=False))
    assert d["step_count"] == s.step_count and len(d["stance_percent_side"]) == 2
    gt = summarize_steps(sim.steps, fit_step_rate=False)
    assert s.cadence == pytest.approx(gt.cadence, rel=0.02)
    assert s.gait_speed == pytest.approx(gt.gait_speed, rel=0.02)
    assert s.step_width_mean == pytest.approx(0.16, abs=0.01)
    for side in range(2):
        assert s.stance_percent_side[side] + s.swing_percent_side[side] == pytest.approx(100.0, abs=0.5)
        assert s.stance_percent_side[side] == pytest.approx(gt.stance_percent_side[side], abs=3.0)
    # this simulated walker surges +-30 % within each step, which the walker-frame event fits follow less well,
    # and its heel comes to rest before it touches (strikes timed 1 frame early): double support +3.3 points
    # (+0.3 timed against the other foot, below); on the synthetic generator's tracked poses the default's double
    # support time is the closer one (median error -1.4 against -2.9 frames, see GaitConfig.to_walker_frame)
    assert s.double_support_percent == pytest.approx(gt.double_support_percent, abs=4.0)
    rel = run_analyzer(sim.poses, sim.floor, config=GaitConfig(hs_walker_frame=False, to_walker_frame=False)).summary()
    assert rel.double_support_percent == pytest.approx(gt.double_support_percent, abs=3.0)
    empty = GaitAnalyzer().summary()
    assert empty.step_count == 0 and math.isnan(empty.cadence)
    assert json.dumps(empty.to_dict(), allow_nan=False)


def test_step_fields_follow_message() -> None:
    names = {f.name for f in fields(Step)}
    mapping = {"foot": "side", "step_index": "index"}
    assert all(mapping.get(f, f) in names for f in _msg_fields("Step.msg"))


def test_matcher_pairs_by_time_and_foot() -> None:
    mk = lambda t, s: Step(stamp=t, side=Side(s), index=0, step_length=0, step_width=0, step_time=0,  # noqa: E731
                           stride_length=0, stride_time=0, stance_time=0, swing_time=0,
                           single_support_time=0, double_support_time=0)
    gt = [mk(1.0, 0), mk(1.5, 1), mk(2.0, 0)]
    det = [mk(1.52, 1), mk(1.03, 0), mk(2.6, 0), mk(1.1, 0)]
    pairs, ug, ud = match_steps(gt, det, max_dt=0.25)
    assert sorted(pairs) == [(0, 1), (1, 0)]
    assert ug == [2] and sorted(ud) == [2, 3]


def test_implausible_step_geometry_is_flagged_not_dropped() -> None:
    """A step outside the plausible geometry (here: a limit below the true ~0.5 m steps) is still
    reported, with low confidence, and kept out of the summary means."""
    sim = simulate_gait(SCENARIOS["normal"], rng=np.random.default_rng(0))
    strict = GaitConfig(max_step_length_m=0.3)
    ga = run_analyzer(sim.poses, sim.floor, config=strict)
    normal = run_analyzer(sim.poses, sim.floor)
    assert len(ga.steps) == len(normal.steps) > 0
    long_steps = [s for s in ga.steps if s.step_length > 0.3]
    assert long_steps and all(s.confidence <= 0.25 for s in long_steps)
    assert all(s.confidence > 0.95 for s in normal.steps)
    mean = ga.summary().step_length_mean  # whole session
    assert math.isnan(mean) or mean <= 0.3
    with pytest.raises(GaitInputError):
        GaitConfig(implausible_quality=2.0)
    with pytest.raises(GaitInputError):  # an implausible step at confidence 1 would still count in the cadence
        GaitConfig(implausible_quality=0.25, summary_min_time_confidence=0.25)
    with pytest.raises(GaitInputError):
        GaitConfig(min_step_time_s=-0.1)


def test_steps_faster_than_walking_are_implausible() -> None:
    """A step time under ``min_step_time_s`` (0.3 s, a cadence above 200 steps/min) is not walking: such steps are
    reported with their confidence scaled by ``implausible_quality`` and stay out of the summary; brisk walking
    (0.4 s, 150 steps/min) is untouched."""
    brisk = GaitSimSpec(step_time=(0.4, 0.4), step_length=(0.3, 0.3), bouts=(("stand", 1.0), ("walk", 12), ("stand", 1.0)))
    sim, ga, r = _run(brisk)
    assert r["precision"] == 1.0 and r["recall"] == 1.0
    assert all(s.confidence > 0.95 for s in ga.steps)
    assert ga.summary().cadence == pytest.approx(150.0, rel=0.02)
    running = replace(brisk, step_time=(0.26, 0.26))
    sim = simulate_gait(running, rng=np.random.default_rng(0))
    ga = run_analyzer(sim.poses, sim.floor)
    off = run_analyzer(sim.poses, sim.floor, config=GaitConfig(min_step_time_s=0.0))
    assert len(ga.steps) == len(off.steps) == len(sim.steps)  # reported all the same
    fast = [i for i, s in enumerate(off.steps) if s.step_time < 0.3]
    assert len(fast) >= len(sim.steps) // 2
    assert all(ga.steps[i].confidence <= 0.2 * off.steps[i].confidence + 1e-9 for i in fast)
    assert all(ga.steps[i].confidence == off.steps[i].confidence for i in range(len(ga.steps)) if i not in fast)
    assert off.summary().cadence > 200 and not ga.summary().cadence > 200
