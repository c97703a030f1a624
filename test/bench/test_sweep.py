"""The accuracy sweep (walker_gait.bench.sweep): its figures on hand-built runs, and one real session."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from walker_gait.bench import sweep
from walker_gait.core.types import ANKLE, HEEL, TOE, Side, Step


def _step(stamp: float, side: int, length: float, width: float) -> Step:
    nan = math.nan
    return Step(stamp=stamp, side=Side(side), index=0, step_length=length, step_width=width, step_time=0.5,
                stride_length=nan, stride_time=nan, stance_time=nan, swing_time=nan, single_support_time=nan,
                double_support_time=nan)


def _run(seed: int = 0) -> sweep.SessionRun:
    """60 frames, floor z = 0 seen from a camera looking along +z (progression = -z); known tracking errors."""
    rng = np.random.default_rng(seed)
    t = 60
    truth = rng.normal(0.0, 0.2, (t, 2, 5, 3)) + np.array([0.0, 0.0, 1.5])
    truth[:, :, TOE] = truth[:, :, HEEL] + np.array([0.0, 0.0, -0.26])  # feet 26 cm long, pointing at the camera
    truth[:, :, ANKLE, 0] = np.array([0.1, -0.1])  # the ankles inside the walker's region of interest
    truth[:, :, ANKLE, 2] = 1.0
    est = truth.copy()
    est[:, :, HEEL] += np.array([0.0, 0.0, -0.02])  # every heel 2 cm forward: foot 2 cm short
    gt = [_step(0.5, 0, 0.50, 0.10), _step(1.0, 1, 0.55, 0.12)]
    det = [_step(0.51, 0, 0.51, 0.13), _step(1.02, 1, 0.56, 0.15)]
    est[15, 1, TOE] += np.array([0.0, 0.0, -0.05])  # at the first heel strike (left), the right toe is 5 cm ahead
    est[30, 0, TOE] += np.array([0.0, 0.0, -0.03])  # at the second (right), the left toe 3 cm ahead
    return sweep.SessionRun(key="normal:1", tracker_seed=seed, stamps=np.arange(t) / 30.0, est=est, truth=truth,
                            trackable=np.ones(t, dtype=bool), present=np.ones(t, dtype=bool), floor_normal=np.array([0.0, -1.0, 0.0]), floor_offset=0.5,
                            gt=gt, det=det, pairs=[(0, 0), (1, 1)], tracker_ms=10.0)


def test_session_list() -> None:
    assert sweep.session_list(("normal", "occlusion"), 2, 100) == [("normal", 100), ("normal", 101),
                                                                    ("occlusion", 130), ("occlusion", 131)]
    # a subset sweep tracks the sessions the full sweep tracks
    full = sweep.session_list(sweep.SCENARIOS, 3, 900)
    assert sweep.session_list(("absent_start",), 3, 900) == [s for s in full if s[0] == "absent_start"]
    with pytest.raises(ValueError):
        sweep.session_list(("normal",), 11, 100)
    with pytest.raises(ValueError, match="unknown scenario"):
        sweep.session_list(("jogging",), 1, 100)


def test_spec_overrides_parse_check_and_tag_the_cache(capsys: pytest.CaptureFixture[str]) -> None:
    ov = sweep.spec_overrides('{"body_scale": [1.12, 1.2], "camera": ["kinect_v2_512x424"], "fps": 15}')
    assert ov == {"body_scale": (1.12, 1.2), "camera": ("kinect_v2_512x424",), "fps": 15}
    # a bare name where the spec holds a tuple of names is a tuple of one (not its characters)
    assert sweep.spec_overrides('{"camera": "realsense_424x240"}') == {"camera": ("realsense_424x240",)}
    assert sweep.spec_overrides('{"clothing": "baggy"}') == {"clothing": ("baggy",)}
    assert sweep._spec_tag({}) == "" and sweep._spec_tag(None) == ""
    tag = sweep._spec_tag(ov)
    assert tag.startswith("_") and tag == sweep._spec_tag(dict(reversed(ov.items())))  # order-free
    assert tag != sweep._spec_tag({**ov, "fps": 30})
    for bad in ('{"no_such_field": 1}', '{"body_scale": [1.2, 1.1]}', '{"camera": ["nope"]}', '[1]', '{"duration": 3}',
                "{"):
        with pytest.raises(ValueError):
            sweep.spec_overrides(bad)
    assert sweep.main(["--out", "unused", "--spec-override", '{"cam_height": [0.7, 0.6]}']) == 2
    assert "cam_height" in capsys.readouterr().err


def test_summarise_hand_built_errors() -> None:
    s = sweep.summarise([_run()])
    assert s["joint_err_cm"]["heel"] == pytest.approx(2.0)
    assert s["joint_err_cm"]["hip"] == pytest.approx(0.0)
    assert s["joint_err_cm"]["toe"] == pytest.approx((5 + 3) / (60 * 2))  # two toes off, in 120 foot-frames
    assert s["frames_over_10cm_pct"] == 0.0 and s["good_frame_err_cm"]["heel"] == pytest.approx(2.0)
    assert s["foot_length_bias_cm"] == pytest.approx(-2.0)
    assert (s["gt_steps"], s["detected_steps"], s["matched_steps"]) == (2, 2, 2)
    assert s["precision"] == 1.0 and s["recall"] == 1.0
    assert (s["gt_steps_in_view"], s["matched_in_view"]) == (1, 1)  # the first step comes 0.5 s into the session
    assert (s["gt_steps_in_image"], s["recall_in_image"]) == (1, 1.0)
    assert s["step_length_bias_cm"] == pytest.approx(1.0) and s["step_length_mae_cm"] == pytest.approx(1.0)
    assert s["step_width_bias_cm"] == pytest.approx(3.0)
    assert s["trailing_toe_median_cm"] == pytest.approx(4.0) and s["trailing_toe_mean_cm"] == pytest.approx(4.0)
    # every detected step is confident (Step's default confidence 1.0): the confident figures are the same
    assert s["confident_share"] == 1.0 and s["step_length_mae_confident_cm"] == pytest.approx(1.0)
    assert s["step_width_mae_confident_cm"] == pytest.approx(3.0)
    assert s["hs_timing_median_abs_frames"] == pytest.approx((0.3 + 0.6) / 2)  # strikes 10 and 20 ms late at 30 Hz
    assert math.isnan(s["to_timing_median_abs_frames"]) and math.isnan(s["double_support_median_err_frames"])
    # toe offs (heel strike less swing time) and double supports, where both steps have them
    t = _run()
    t.gt[0] = replace(t.gt[0], swing_time=0.40, double_support_time=0.10)
    t.det[0] = replace(t.det[0], swing_time=0.44, double_support_time=0.05)  # toe off 30 ms early, DS 1.5 frames short
    t.gt[1] = replace(t.gt[1], swing_time=0.40)
    t.det[1] = replace(t.det[1], swing_time=0.40)  # toe off 20 ms late (the strike's error)
    e = sweep.summarise([t])
    assert e["to_timing_median_abs_frames"] == pytest.approx((0.9 + 0.6) / 2)
    assert e["double_support_median_err_frames"] == pytest.approx(-1.5)
    table = sweep.format_table({"x": {"per_tracker_seed": {0: e}}})
    assert "| TO timing median abs err frames | 0.75 |" in table and "| step length median abs err cm | 1.00 |" in table
    # a step the analyzer doubts is left out of the confident figures only
    r = _run()
    r.det[1] = replace(r.det[1], step_length=0.35, confidence=0.2)  # 20 cm short
    d = sweep.summarise([r])
    assert d["step_length_mae_cm"] == pytest.approx((1 + 20) / 2) and d["confident_share"] == 0.5
    assert d["step_length_mae_confident_cm"] == pytest.approx(1.0) and d["step_width_mae_confident_cm"] == pytest.approx(3.0)
    table = sweep.format_table({"x": {"per_tracker_seed": {0: d}}})
    assert "| confident: length MAE cm | 1.00 |" in table and "| confident steps share | 0.50 |" in table
    # the tail of the step length error apart from its body: 20 cm off is over 10 and under 40; 50 cm over both
    assert (s["steps_off_over_10cm"], s["steps_off_over_40cm"], s["step_length_mae_body_cm"]) == (0, 0, pytest.approx(1.0))
    assert (d["steps_off_over_10cm"], d["steps_off_over_40cm"], d["step_length_mae_body_cm"]) == (1, 0, pytest.approx(1.0))
    assert "| steps off > 10 cm | 1 |" in table and "| step length MAE, steps <= 10 cm off | 1.00 |" in table
    g = _run()
    g.det[0] = replace(g.det[0], step_length=0.0)  # 50 cm short: a leg exchange
    e2 = sweep.summarise([g])
    assert (e2["steps_off_over_10cm"], e2["steps_off_over_40cm"], e2["step_length_mae_body_cm"]) == (1, 1, pytest.approx(1.0))
    assert e2["step_length_mae_cm"] == pytest.approx((50 + 1) / 2)
    # a summary written before a figure existed shows it as n/a
    old = {k: v for k, v in d.items() if k != "confident_share"}
    assert "| confident steps share | n/a |" in sweep.format_table({"x": {"per_tracker_seed": {0: old}}})
    assert s["swapped_frames_pct"] == 0.0 and s["runs_with_swaps"] == 0
    # left and right exchanged in 6 frames: swaps; both model feet on the right foot in 3 more: not swaps
    w = _run()
    w.est[20:26] = w.truth[20:26, ::-1]
    w.est[40:43, 0] = w.truth[40:43, 1]
    w.est[40:43, 1] = w.truth[40:43, 1]
    sw = sweep.summarise([w, _run(1)])
    assert sw["swapped_frames_pct"] == pytest.approx(100 * 6 / 120) and sw["runs_with_swaps"] == 1
    assert "| swapped frames % | 5.00 |" in sweep.format_table({"x": {"per_tracker_seed": {0: sw}}})
    # a frame lost (no estimate) counts as > 10 cm
    r = _run()
    r.est[10] = np.nan
    assert sweep.summarise([r])["frames_over_10cm_pct"] == pytest.approx(100 / 60)
    # a user still making for the walker (a metre to its side) is in the image, not at the walker: that step is
    # out of the recall in view and counted only in the older figure
    a = _run()
    a.truth[:20, 0, ANKLE, 0] = -1.0
    s2 = sweep.summarise([a])
    assert (s2["gt_steps_in_view"], s2["gt_steps_in_image"], s2["matched_in_view"]) == (0, 1, 0)
    assert math.isnan(s2["recall_in_view"]) and s2["recall_in_image"] == 1.0
    # ... and its frames, tracked or not, are left out of the frames > 10 cm at the walker, not of the older figure
    a.est[:20] = np.nan  # not tracked on its way in
    a.est[40:46] += 0.5  # 6 of the 40 frames at the walker 50 cm off
    s3 = sweep.summarise([a])
    assert s3["frames_over_10cm_pct"] == pytest.approx(100 * 26 / 60)
    assert s3["frames_over_10cm_at_walker_pct"] == pytest.approx(100 * 6 / 40)
    assert "| frames > 10 cm at the walker % | 15.00 |" in sweep.format_table({"x": {"per_tracker_seed": {0: s3}}})
    assert s["frames_over_10cm_at_walker_pct"] == 0.0


def test_summarise_scores_the_joint_angles_of_runs_that_kept_the_true_ones() -> None:
    from walker_gait.core.types import LegPose

    r = _run()
    t = len(r.stamps)
    r.truth_angles = np.zeros((t, 12))
    r.truth_angles[:, 3] = r.truth_angles[:, 9] = 0.3  # both knees flexed 0.3 rad
    est = r.truth_angles.copy()
    est[:, 3] -= np.radians(6.0)  # the left knee reported 6 deg straighter
    r.poses = [LegPose(stamp=float(r.stamps[i]), points=r.est[i], angles=est[i]) for i in range(t)]
    r.trackable[:30] = False  # only the trackable frames count
    est[30:, 9] += np.radians(2.0)
    s = sweep.summarise([r])
    assert s["angle_err_deg"]["knee_flexion"] == pytest.approx((6 + 2) / 2)
    assert s["angle_bias_deg"]["knee_flexion"] == pytest.approx((-6 + 2) / 2)
    assert s["angle_err_deg"]["hip_flexion"] == 0.0
    table = sweep.format_table({"x": {"per_tracker_seed": {0: s}}})
    assert "| knee flexion err deg | 4.00 |" in table and "| knee flexion bias deg | -2.00 |" in table
    # a run stored before the true angles were kept is left out, not scored against nothing
    old = sweep.summarise([_run()])
    assert math.isnan(old["angle_err_deg"]["knee_flexion"])
    pickled_before = _run()
    del pickled_before.truth_angles  # unpickled from a file written before the field existed
    assert math.isnan(sweep.summarise([pickled_before])["angle_err_deg"]["knee_flexion"])
    assert sweep.summarise([_run(), r])["angle_err_deg"]["knee_flexion"] == pytest.approx(4.0)


def test_summary_errors_compare_the_session_cadence_and_speed_with_the_truth() -> None:
    """Cadence and gait speed of the session summary (the analyzer's confidence cuts) against the true steps'; a
    session without a walking step detected misses its figures (100 %)."""
    def steps(times: list[float], *, length: float, conf: list[float] | None = None) -> list[Step]:
        out = []
        for k, t in enumerate(times):
            st = t - times[k - 1] if k else math.nan
            out.append(replace(_step(t, k % 2, length, 0.1), step_time=st, confidence=1.0 if conf is None else conf[k]))
        return out

    r = _run()
    r.gt = steps([0.6 * k for k in range(8)], length=0.5)  # 100 steps/min, 0.5 m per 0.6 s
    r.det = steps([0.5 * k for k in range(8)], length=0.5)  # 120 steps/min, 1 m/s
    e = sweep.summarise([r])
    assert e["cadence_abs_err_pct"] == pytest.approx(20.0) and e["speed_abs_err_pct"] == pytest.approx(20.0)
    # a doubted step (0.25 <= confidence < 0.5) keeps its time in the cadence, not its length in the speed
    r.det = steps([0.6 * k for k in range(8)], length=0.5, conf=[1.0] * 4 + [0.3] + [1.0] * 3)
    r.det[4] = replace(r.det[4], step_length=1.0)
    e = sweep.summarise([r])
    assert e["cadence_abs_err_pct"] == pytest.approx(0.0, abs=1e-9) and e["speed_abs_err_pct"] == pytest.approx(0.0, abs=1e-9)
    # the true steps a user takes on the way to the walker (ankles a metre to its side) are not the walker's to
    # measure: the true summary leaves them out, as the recall in view does
    r.gt = steps([0.6 * k for k in range(8)], length=0.5)
    r.gt[:3] = [replace(g, step_length=0.2) for g in r.gt[:3]]  # short steps while walking up from the side ...
    r.det = steps([0.6 * k for k in range(3, 8)], length=0.5)  # ... which the walker does not see
    n = 150  # 5 s
    r.stamps, r.trackable, r.present = np.arange(n) / 30.0, np.ones(n, dtype=bool), np.ones(n, dtype=bool)
    r.truth = np.repeat(r.truth[:1], n, axis=0)
    r.est = r.truth.copy()
    r.truth[:14, :, ANKLE, 0] = -1.0  # to 0.43 s the user is beside the walker: a step needs 1 s at it before
    assert [g.stamp for g in sweep.true_steps_at_walker(r)] == pytest.approx([1.8, 2.4, 3.0, 3.6, 4.2])
    e = sweep.summarise([r])
    assert e["cadence_abs_err_pct"] == pytest.approx(0.0, abs=1e-9) and e["speed_abs_err_pct"] == pytest.approx(0.0, abs=1e-9)
    r.truth[:, :, ANKLE, 0] = np.array([0.1, -0.1])  # at the walker all along: the short steps count, and are missed
    assert len(sweep.true_steps_at_walker(r)) == 6  # the first second: no evidence the user could be seen
    assert sweep.summarise([r])["speed_abs_err_pct"] > 10.0
    r.det, r.pairs = [], []
    e = sweep.summarise([r])
    assert e["cadence_abs_err_pct"] == 100.0 and e["speed_abs_err_pct"] == 100.0
    assert "| cadence abs err % | 100.00 |" in sweep.format_table({"x": {"per_tracker_seed": {0: e}}})


def test_report_pools_per_seed_and_scenario() -> None:
    rep = sweep.report([_run(0), _run(1)])
    assert set(rep["per_tracker_seed"]) == {"0", "1"} and set(rep["per_scenario"]) == {"normal"}
    assert rep["per_scenario"]["normal"]["matched_steps"] == 4
    table = sweep.format_table({"x": rep})
    assert "| heel err cm | 2.00 | 2.00 |" in table
    assert "| hip err cm | 0.00 | 0.00 |" in table  # the joints out of the camera's view are shown too


def test_reanalyse_runs_the_gait_analyzer_on_the_kept_poses(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Re-analysis = a fresh analyzer on the run's own poses and floors: exact kinematic poses give the true steps,
    a GaitConfig override changes them; the runs survive save/load; bad input is refused with a message."""
    from walker_gait.bench.gait import SCENARIOS, simulate_gait
    from walker_gait.core.gait import GaitConfig

    sim = simulate_gait(SCENARIOS["normal"], rng=np.random.default_rng(0))
    n = len(sim.poses)
    pts = np.stack([p.points for p in sim.poses])
    run = sweep.SessionRun(key="normal:1", tracker_seed=0, stamps=np.array([p.stamp for p in sim.poses]), est=pts,
                           truth=pts, trackable=np.ones(n, bool), present=np.ones(n, bool),
                           floor_normal=np.asarray(sim.floor.normal), floor_offset=sim.floor.offset, gt=sim.steps,
                           det=[], pairs=[], tracker_ms=0.0, poses=sim.poses, floors=[sim.floor] * n)
    again = sweep.reanalyse([run])[0]
    assert len(again.pairs) == len(sim.steps) == len(again.det) and run.det == []
    assert sweep.reanalyse([run], GaitConfig(min_swing_distance_m=5.0))[0].det == []  # no 5 m swings: no steps
    # the oracle rows of a re-analysis use its analyzer configuration too
    assert sweep.oracle([run], ())["matched_steps"] == len(sim.steps)
    assert sweep.oracle([run], (), GaitConfig(min_swing_distance_m=5.0))["matched_steps"] == 0
    oracle_rep = sweep.report([run], with_oracle=True, gait=GaitConfig(min_swing_distance_m=5.0))["oracle"]["0"]
    assert all(v["matched_steps"] == 0 for v in oracle_rep.values())
    with pytest.raises(ValueError, match="no tracked poses"):
        sweep.reanalyse([replace(run, poses=[])])
    sweep.save_runs([run], tmp_path / "runs.pkl")
    assert sweep.load_runs(tmp_path / "runs.pkl")[0].key == "normal:1"
    # a file written before a field existed: its runs load with that field's default and re-analyse as before
    old = replace(run)
    del old.truth_angles
    sweep.save_runs([old], tmp_path / "old.pkl")
    loaded = sweep.load_runs(tmp_path / "old.pkl")[0]
    assert loaded.truth_angles.shape == (0, 12)
    assert len(sweep.reanalyse([loaded])[0].pairs) == len(sim.steps)
    # CLI
    assert sweep.main(["--reanalyse", str(tmp_path), "--out", str(tmp_path / "re")]) == 0
    summary = json.loads((tmp_path / "re" / "summary.json").read_text())
    assert summary["per_tracker_seed"]["0"]["matched_steps"] == len(sim.steps)
    assert summary["config"]["reanalysed"] == str(tmp_path)
    capsys.readouterr()
    assert sweep.main(["--reanalyse", str(tmp_path), "--out", str(tmp_path / "x"), "--gait-override", '{"nope": 1}']) == 2
    assert "nope" in capsys.readouterr().err
    assert sweep.main(["--reanalyse", str(tmp_path / "missing"), "--out", str(tmp_path / "x")]) == 2
    assert "runs.pkl" in capsys.readouterr().err
    # a two-pass run merged again from its kept passes: a backward pass 2 cm off blends in, one 30 cm off does not
    from walker_gait.core.smoothing import PassTrack

    def shifted(dx: float, score: float) -> PassTrack:
        poses = [replace(p, points=p.points + [dx, 0.0, 0.0]) for p in sim.poses]
        return PassTrack(poses=poses, scores=np.full(n, score), tracker_ms=np.zeros(n), scoring_ms=np.zeros(n))

    two = replace(run, passes=(shifted(0.0, 0.0), shifted(0.02, 0.0)))
    # a two-pass run's analyzer reads its passes merged, as the pipeline's did, not its stored poses (the reported
    # ones, hidden feet bridged)
    moved = replace(two, poses=[replace(p, points=p.points * [1.0, 1.0, 1.3]) for p in two.poses])  # steps 30 % long
    assert [(s.stamp, s.step_length) for s in sweep.reanalyse([moved])[0].det] == \
        [(s.stamp, s.step_length) for s in sweep.reanalyse([two])[0].det]
    near = sweep.reanalyse([two], merge={}, report_lowpass_hz=0.0)[0]
    np.testing.assert_allclose(near.est, pts + [0.01, 0.0, 0.0])
    far = sweep.reanalyse([replace(two, passes=(shifted(0.0, 0.0), shifted(0.3, -1.0)))], merge={},
                          report_lowpass_hz=0.0)[0]
    np.testing.assert_allclose(far.est, pts)
    # by default the re-merged run's reported poses are low-passed as the pipeline's are
    from walker_gait.core.smoothing import reported_poses

    lowpassed = np.stack([p.points for p in reported_poses(shifted(0.01, 0.0).poses, hide_below=0.25)])
    np.testing.assert_allclose(sweep.reanalyse([two], merge={})[0].est, lowpassed)
    assert not np.allclose(lowpassed, pts + [0.01, 0.0, 0.0])
    assert len(far.pairs) == len(sim.steps)
    # the oracle of a two-pass run substitutes into the track its analyzer read (the passes merged): with both passes
    # 3 cm off sideways every footprint moves alike, so the feet substituted (the others off) change the widths;
    # nothing substituted, the merged track's own steps
    off = replace(run, passes=(shifted(0.03, 0.0), shifted(0.03, 0.0)))
    lopsided = [replace(p, points=p.points + np.where(np.arange(2)[:, None, None] == 0, 0.03, 0.0) * [1, 0, 0])
                for p in sim.poses]
    skewed = replace(run, passes=(PassTrack(poses=lopsided, scores=np.zeros(n), tracker_ms=np.zeros(n),
                                            scoring_ms=np.zeros(n)),) * 2)
    assert sweep.oracle([off], ())["step_width_mae_cm"] == pytest.approx(
        sweep.oracle([run], ())["step_width_mae_cm"], abs=1e-9)
    wide = sweep.oracle([skewed], ())
    exact = sweep.oracle([skewed], (0, 1, 2, 3, 4))
    assert wide["step_width_mae_cm"] > 2.0 and exact["step_width_mae_cm"] < 0.5
    with pytest.raises(ValueError, match="no tracking passes"):
        sweep.reanalyse([run], merge={})
    (tmp_path / "two").mkdir()
    sweep.save_runs([two], tmp_path / "two" / "runs.pkl")
    assert sweep.main(["--reanalyse", str(tmp_path / "two"), "--out", str(tmp_path / "m"), "--merge-override",
                       '{"agree_m": [0.0, 0.001]}']) == 0
    summary = json.loads((tmp_path / "m" / "summary.json").read_text())
    assert summary["config"]["merge_override"] == {"agree_m": [0.0, 0.001]}
    np.testing.assert_allclose(sweep.load_runs(tmp_path / "m" / "runs.pkl")[0].est,  # nothing blended
                               np.stack([p.points for p in reported_poses(sim.poses, hide_below=0.25)]))
    capsys.readouterr()
    assert sweep.main(["--reanalyse", str(tmp_path / "two"), "--out", str(tmp_path / "x"), "--merge-override",
                       '{"bogus": 1}']) == 2
    assert "bogus" in capsys.readouterr().err
    assert sweep.main(["--reanalyse", str(tmp_path / "two"), "--out", str(tmp_path / "x"), "--confirm-override",
                       "[0.05]"]) == 2
    assert "--confirm-override" in capsys.readouterr().err
    assert sweep.main(["--reanalyse", str(tmp_path / "two"), "--out", str(tmp_path / "c"), "--confirm-override",
                       '{"factor": 1.0}']) == 0
    assert json.loads((tmp_path / "c" / "summary.json").read_text())["config"]["confirm_override"] == {"factor": 1.0}
    # `python -m` (as make sweep runs it) writes runs another program can load
    import subprocess
    import sys

    res = subprocess.run([sys.executable, "-m", "walker_gait.bench.sweep", "--reanalyse", str(tmp_path), "--out",
                          str(tmp_path / "cli")], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    cli = sweep.load_runs(tmp_path / "cli" / "runs.pkl")[0]
    assert [(s.stamp, s.step_length) for s in cli.det] == [(s.stamp, s.step_length) for s in again.det]


@pytest.mark.slow
def test_real_session_and_cli(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # a render cached by another version of the generator is not read back (its frames would not be this truth's)
    (tmp_path / "cache").mkdir()
    (tmp_path / "cache" / "normal_7_3s.npz").write_bytes(b"not a render")
    runs = sweep.run_session("normal", 7, duration=3.0, tracker_seeds=(0,), cache=tmp_path / "cache")
    tag = sweep.generator_tag()
    assert tag.startswith("_g") and len(runs) == 1 and (tmp_path / "cache" / f"normal_7_3s{tag}.npz").exists()
    r = runs[0]
    assert r.est.shape == r.truth.shape and r.trackable.all() and len(r.gt) >= 2
    s = sweep.summarise(runs)
    assert s["joint_err_cm"]["ankle"] < 15.0  # tracked, not lost
    assert r.truth_angles.shape == (len(r.stamps), 12)
    assert 0.0 < s["angle_err_deg"]["knee_flexion"] < 30.0  # scored against the session's own angles
    # the analyzer on the exact poses measures the true steps (its own error is sub-centimetre)
    exact = sweep.oracle(runs, (0, 1, 2, 3, 4))
    assert exact["matched_steps"] >= len(r.gt) - 1 and exact["step_length_mae_cm"] < 1.0
    none = sweep.oracle(runs, ())
    assert none["matched_steps"] == len(r.pairs)  # nothing substituted: the pipeline's own steps (true floor)
    # re-analysis of the kept poses and floors reproduces the pipeline's steps exactly
    assert len(r.poses) == len(r.floors) == len(r.stamps)
    assert [(s.stamp, s.step_length) for s in sweep.reanalyse(runs)[0].det] == [(s.stamp, s.step_length) for s in r.det]
    # CLI: bad override, then --compare of a written summary
    assert sweep.main(["--out", str(tmp_path / "o"), "--override", '{"no_such_field": 1}']) == 2
    assert "no_such_field" in capsys.readouterr().err
    (tmp_path / "a").mkdir()
    (tmp_path / "a" / "summary.json").write_text(json.dumps(sweep.report(runs)))
    assert sweep.main(["--compare", str(tmp_path / "a")]) == 0
    assert "| heel err cm |" in capsys.readouterr().out
    assert sweep.main(["--compare", str(tmp_path / "missing")]) == 2


def test_roi_override_reaches_the_segmenter_and_bad_ones_are_refused(monkeypatch: pytest.MonkeyPatch,
                                                                      capsys: pytest.CaptureFixture[str]) -> None:
    """``--roi-override`` (``run_session``'s and ``run_pipeline``'s ``roi``): the pipeline's segmenter gets the region
    of interest with those fields changed, the rest its defaults; a field it lacks or a value it refuses exits 2."""
    import walker_gait.pipeline as pipeline
    from walker_gait.bench.endtoend import run_pipeline
    from walker_gait.core.segmentation import RoiConfig

    seen = []

    class Stop(Exception):
        pass

    def capture(options: pipeline.PipelineOptions) -> None:
        seen.append(options)
        raise Stop

    monkeypatch.setattr(pipeline, "FrameProcessor", capture)
    for roi in ({"join_edge_parts": True, "join_max_jump": 0.08}, None):
        with pytest.raises(Stop):
            run_pipeline(None, None, roi=roi)  # type: ignore[arg-type]
    changed, default = (o.segmenter.roi for o in seen)
    assert changed == RoiConfig(join_edge_parts=True, join_max_jump=0.08) and default == RoiConfig()
    assert changed != default
    for bad, word in (('{"no_such_field": 1}', "no_such_field"), ('{"join_max_jump": -1}', "join_max_jump"),
                      ('[1]', "JSON object"), ("{", "roi-override")):
        assert sweep.main(["--out", "unused", "--roi-override", bad]) == 2
        assert word in capsys.readouterr().err
