"""Accuracy sweep over many synthetic sessions and tracker seeds: the tool for judging a tracker change.

The tracker is chaotic: any change reshuffles single sessions by several steps and centimetres, and the
same configuration run with another tracker seed moves the step-length error by ±1-3 cm.  One session
per scenario (``make bench``) cannot tell a change from that noise; this sweep runs ``--per-scenario``
sessions of every scenario (sessions are generated once and their renders cached) with several
tracker seeds, and reports per tracker seed, so a change is judged by whether it moves every column
the same way.

``python -m walker_gait.bench.sweep --out out/sweep/base`` then, after a change,
``python -m walker_gait.bench.sweep --out out/sweep/new --override '{"elliptic_foot": false}'`` and
``python -m walker_gait.bench.sweep --compare out/sweep/base out/sweep/new`` (``--roi-override`` changes the
segmenter's region of interest the same way: ``'{"join_edge_parts": true}'``).

Every sweep also keeps its runs, tracked poses and the pipeline's floors included, in ``runs.pkl``; a change
to the gait analyzer alone is then judged on those same poses in seconds, without tracking again:
``python -m walker_gait.bench.sweep --reanalyse out/sweep/base --out out/sweep/gait_new``
(``--gait-override`` sets GaitConfig fields).  The pipeline feeds its analyzer exactly these poses and floors,
so with the analyzer unchanged the figures are the sweep's own.

Figures (``summary.json``; lengths in cm): joint errors over frames with both legs in view, the share
of those frames with a mean error > 10 cm, errors on the *well-tracked* frames (mean error ≤ 10 cm:
little moved by the chaos), the model foot's length bias, step detection (recall also over the steps
in view: the user in the image and at the walker for a second before the strike and the recording going on for
0.1 s after it, :func:`~walker_gait.bench.endtoend.steps_in_view`, :func:`~walker_gait.bench.endtoend.at_walker`;
and, as before the thirty-second session, over the steps with the user anywhere in the image), step length/width
error (over every matched
step, and over the confident ones the gait summaries pool; the steps off by more than 10 and 40 cm counted apart
and the MAE of the rest, since a run's MAE is mostly its tail of leg exchanges, which tracker seeds reshuffle), and
per scenario
the progression error of the trailing foot's toe at each true heel strike (the reference point of the
step vector).  ``--oracle`` also re-runs the gait analyzer on the tracked poses with the true toes,
heels or ankles substituted: what the step metrics would be if that point were tracked exactly.
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import hashlib
import json
import math
import os
import pickle
import sys
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from walker_gait.core.smoothing import PassTrack
from walker_gait.core.types import ANKLE, HEEL, JOINT_NAMES, LEG_POINTS, TOE, FloorPlane, LegPose, Step, TrackStatus

if TYPE_CHECKING:
    from walker_gait.core.gait import GaitConfig

SCENARIOS = ("normal", "slow_elderly", "baggy_trousers", "occlusion", "asymmetric", "stop_and_go", "absent_start",
             "different_camera")
ORACLE_POINTS = {"toes": (TOE,), "heels": (HEEL,), "ankles": (ANKLE,), "feet": (ANKLE, HEEL, TOE)}


@dataclass
class SessionRun:
    """One session tracked with one tracker seed (camera frame, metres)."""

    key: str  # "scenario:session seed"
    tracker_seed: int
    stamps: np.ndarray  # (T,)
    est: np.ndarray  # (T, 2, 5, 3) tracked LEG_POINTS, NaN without an estimate
    truth: np.ndarray  # (T, 2, 5, 3)
    trackable: np.ndarray  # (T,) both legs in view
    present: np.ndarray  # (T,) the user in view (at least one leg)
    floor_normal: np.ndarray  # (3,) true floor normal (up)
    floor_offset: float
    gt: list[Step]
    det: list[Step]
    pairs: list[tuple[int, int]]  # (gt index, det index)
    tracker_ms: float  # mean per frame after the first
    poses: list[LegPose] = field(default_factory=list, repr=False)  # the pipeline's tracked poses, per frame
    floors: list[FloorPlane] = field(default_factory=list, repr=False)  # the floor the pipeline estimated, per frame
    passes: tuple[PassTrack, ...] = field(default=(), repr=False)  # two passes: forward and backward per tracker run, before merging
    truth_angles: np.ndarray = field(default_factory=lambda: np.zeros((0, len(JOINT_NAMES))), repr=False)  # (T, 12) rad; empty in runs stored before it was kept

    @property
    def scenario(self) -> str:
        return self.key.split(":")[0]

    @property
    def true_floor(self) -> FloorPlane:
        """The session's true floor plane (camera frame)."""
        return FloorPlane(normal=self.floor_normal, offset=self.floor_offset, rms=0.0, inlier_ratio=1.0, valid=True)


def session_list(scenarios: tuple[str, ...], per_scenario: int, base_seed: int) -> list[tuple[str, int]]:
    """``(scenario, session seed)``: seeds ``base_seed + 10 k + j`` for session ``j`` of scenario ``k`` of
    ``SCENARIOS`` (its place there, not in ``scenarios``: a sweep over some scenarios tracks the same sessions as
    the full sweep does)."""
    if per_scenario < 1 or per_scenario > 10:
        raise ValueError(f"per_scenario must be in 1..10, got {per_scenario}")
    for sc in scenarios:
        if sc not in SCENARIOS:
            raise ValueError(f"unknown scenario {sc!r}; expected one of {SCENARIOS}")
    return [(sc, base_seed + 10 * SCENARIOS.index(sc) + j) for sc in scenarios for j in range(per_scenario)]


def spec_overrides(text: str) -> dict[str, Any]:
    """``SessionSpec`` field overrides from JSON (lists become the spec's tuples: ranges, camera names),
    checked against every scenario's preset; raises ``ValueError`` on bad JSON, fields or values."""
    from walker_gait.synth import SessionSpec

    try:
        raw = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(str(exc)) from exc
    if not isinstance(raw, dict):
        raise ValueError("expected a JSON object of SessionSpec fields")
    tuple_fields = {f.name for f in dataclasses.fields(SessionSpec) if isinstance(f.default, tuple)}
    ov: dict[str, Any] = {}
    for k, v in raw.items():
        if isinstance(v, list):  # ranges, camera names
            v = tuple(v)
        elif isinstance(v, str) and k in tuple_fields:  # a bare name for a tuple of names (camera, clothing)
            v = (v,)
        ov[k] = v
    for key in ("scenario", "duration"):
        if key in ov:
            raise ValueError(f"{key!r} is set by the sweep (--scenarios, --duration), not by --spec-override")
    for sc in SCENARIOS:
        try:
            SessionSpec.preset(sc, **ov)
        except TypeError as exc:
            raise ValueError(str(exc)) from exc
    return ov


def _spec_tag(spec: dict[str, Any] | None) -> str:
    """Cache-name suffix of a set of spec overrides ('' for none)."""
    if not spec:
        return ""
    text = json.dumps(spec, sort_keys=True)  # tuples dump as lists
    return "_" + hashlib.sha1(text.encode()).hexdigest()[:10]


def _session(scenario: str, seed: int, duration: float, spec: dict[str, Any] | None = None) -> Any:
    from walker_gait.synth import SessionSpec, generate_session

    dur = max(duration, 14.0) if scenario == "absent_start" else duration  # as make bench: time to walk in
    return generate_session(SessionSpec.preset(scenario, duration=dur, **(spec or {})), rng=np.random.default_rng(seed))


@functools.cache
def generator_tag() -> str:
    """Cache-name suffix naming the synthetic generator's code (its package's sources and the bench's renderer): a
    render cached by an earlier generator is not read back with a newer one's ground truth."""
    from walker_gait.bench import endtoend
    from walker_gait.synth import __file__ as synth_init

    files = sorted(Path(synth_init).parent.glob("*.py")) + [Path(endtoend.__file__)]
    digest = hashlib.sha1()
    for f in files:
        digest.update(f.name.encode())
        digest.update(f.read_bytes())
    return "_g" + digest.hexdigest()[:8]


def _rendered(session: Any, cache: Path | None, name: str) -> Any:
    from walker_gait.bench.endtoend import Rendered, render

    path = None if cache is None else cache / f"{name}{generator_tag()}.npz"
    if path is not None and path.exists():
        with np.load(path) as z:
            return Rendered(frames=list(z["frames"]), visible_pixels=z["visible"], seconds=0.0)
    rendered = render(session)
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(path.name + f".{os.getpid()}.tmp.npz")
        np.savez_compressed(tmp, frames=np.stack(rendered.frames), visible=rendered.visible_pixels)
        os.replace(tmp, path)
    return rendered


def run_session(scenario: str, seed: int, *, duration: float, tracker_seeds: tuple[int, ...],
                overrides: dict[str, Any] | None = None, cache: Path | None = None,
                spec: dict[str, Any] | None = None, passes: str = "both",
                tracker_runs: int | None = None, roi: dict[str, Any] | None = None) -> list[SessionRun]:
    """Generate (or load the cached render of) one session and track it once per tracker seed; ``spec``:
    ``SessionSpec`` overrides of the scenario's preset (other subjects, cameras, mounts); ``passes`` and
    ``tracker_runs`` (None: the default) as ``PipelineOptions``'; ``roi``: the segmenter's ``RoiConfig`` fields
    changed."""
    from walker_gait.bench.endtoend import _gt_as_steps, present_frames, run_pipeline, trackable_frames
    from walker_gait.bench.gait import match_steps

    session = _session(scenario, seed, duration, spec)
    rendered = _rendered(session, cache, f"{scenario}_{seed}_{duration:g}s{_spec_tag(spec)}")
    trackable = trackable_frames(session, rendered)
    present = present_frames(session, rendered)
    n = len(rendered.frames)
    stamps = np.asarray(session.stamps[:n], dtype=float)
    gt = [s for s in _gt_as_steps(session) if s.stamp <= stamps[-1]]
    floor = session.params.mount.floor_plane()
    out = []
    for ts in tracker_seeds:
        run = run_pipeline(session, rendered, seed=ts, overrides=overrides, passes=passes, tracker_runs=tracker_runs,
                           roi=roi)
        pairs, _, _ = match_steps(gt, run.steps)
        out.append(SessionRun(
            key=f"{scenario}:{seed}", tracker_seed=ts, stamps=stamps,
            est=np.stack([p.points for p in run.poses]), truth=np.asarray(session.leg_points[:n], dtype=float),
            trackable=trackable, present=present, floor_normal=np.asarray(floor.normal, dtype=float),
            floor_offset=float(floor.offset),
            gt=gt, det=run.steps, pairs=pairs,
            tracker_ms=float(np.mean(run.tracker_ms[1:])) if n > 1 else float("nan"),
            poses=run.poses, floors=run.floors, passes=tuple(run.passes),
            truth_angles=np.asarray(session.body.angles[:n], dtype=float)))
    return out


def reanalyse(runs: list[SessionRun], gait: GaitConfig | None = None, *,
              merge: dict[str, Any] | None = None, confirm: dict[str, Any] | None = None,
              bridge_hidden_s: float | None = None, report_lowpass_hz: float | None = None,
              report_pelvis_window_s: float | None = None) -> list[SessionRun]:
    """The runs with their steps found again by a fresh gait analyzer (``GaitConfig`` ``gait``, default: the
    pipeline's) on the tracked poses and floors the pipeline gave its analyzer: a two-pass run's passes merged
    (:func:`walker_gait.core.smoothing.merge_passes`; its stored poses are the ones reported, hidden feet bridged and
    low-passed), a one-pass run's own poses.  ``merge`` (keyword arguments of ``merge_passes``): the two-pass runs'
    passes merged that way, and their reported poses (joint errors) made again from that merge as the pipeline does
    (:func:`walker_gait.core.smoothing.reported_poses`, ``bridge_hidden_s``, ``report_lowpass_hz`` and
    ``report_pelvis_window_s`` as ``PipelineOptions``, default its defaults).  Two-pass runs get their steps checked
    against each pass's own as the pipeline does (:func:`walker_gait.core.smoothing.check_against_passes`;
    ``confirm``: keyword arguments of its ``confirm_steps``)."""
    from walker_gait.bench.gait import match_steps, run_analyzer
    from walker_gait.core.smoothing import check_against_passes, merge_passes, reported_poses
    from walker_gait.core.tracker import preset
    from walker_gait.pipeline import PipelineOptions

    bridge = PipelineOptions.bridge_hidden_s if bridge_hidden_s is None else bridge_hidden_s
    lowpass = PipelineOptions.report_lowpass_hz if report_lowpass_hz is None else report_lowpass_hz
    pelvis = PipelineOptions.report_pelvis_window_s if report_pelvis_window_s is None else report_pelvis_window_s
    hide_below = preset("default").hide_below
    out = []
    for r in runs:
        if len(r.poses) != len(r.stamps) or len(r.floors) != len(r.stamps):
            raise ValueError(f"run {r.key} (tracker seed {r.tracker_seed}) has no tracked poses to re-analyse")
        if merge is not None and len(r.passes) < 2:
            raise ValueError(f"run {r.key} (tracker seed {r.tracker_seed}) kept no tracking passes to merge again "
                             "(a one-pass sweep, or one written before the passes were kept)")
        analysed = r.poses
        if len(r.passes) >= 2:
            analysed = merge_passes(r.passes, **(merge or {})).poses
            if merge is not None:
                shown = reported_poses(analysed, hide_below=hide_below, max_gap_s=bridge, lowpass_hz=lowpass,
                                       floors=r.floors, pelvis_window_s=pelvis)
                r = replace(r, poses=shown, est=np.stack([p.points for p in shown]))
        ga = run_analyzer(analysed, r.floors, config=gait)
        det = ga.steps
        if len(r.passes) >= 2:
            alone = [run_analyzer(p.poses, r.floors, config=gait) for p in r.passes]
            det = check_against_passes(ga.events, det, [(a.events, a.steps) for a in alone], confirm=confirm)[1]
        pairs, _, _ = match_steps(r.gt, det)
        out.append(replace(r, det=det, pairs=pairs))
    return out


def save_runs(runs: list[SessionRun], path: Path) -> None:
    """Write ``runs`` (pickle, atomically) for :func:`load_runs` / ``--reanalyse``."""
    tmp = path.with_name(f".{path.name}.tmp")
    with open(tmp, "wb") as fh:
        pickle.dump(runs, fh, protocol=pickle.HIGHEST_PROTOCOL)
    os.replace(tmp, path)


def load_runs(path: Path) -> list[SessionRun]:
    """Runs written by :func:`save_runs` (a file this tool wrote: pickle runs code, load only your own)."""
    with open(path, "rb") as fh:
        runs = pickle.load(fh)  # noqa: S301 - our own output
    if not isinstance(runs, list) or not all(isinstance(r, SessionRun) for r in runs):
        raise ValueError(f"{path} does not hold sweep runs")
    for r in runs:  # runs pickled before a field existed lack it: give them its default, so `replace` and the rest work
        for f in dataclasses.fields(SessionRun):
            if not hasattr(r, f.name) and f.default_factory is not dataclasses.MISSING:
                setattr(r, f.name, f.default_factory())
    return runs


def _progression(run: SessionRun) -> np.ndarray:
    """Unit direction of walking in the camera frame: towards the camera, along the floor."""
    up = run.floor_normal
    z = np.array([0.0, 0.0, 1.0])
    d = -(z - (z @ up) * up)
    return d / np.linalg.norm(d)


TAIL_CM = 10.0
"""A matched step whose length is off by more than this (cm) is in the tail of the step length error (summary rows
``steps off > 10 cm`` and ``step length MAE, steps <= 10 cm off``)."""
GROSS_CM = 40.0
"""...and off by more than this (cm), almost always a left/right exchange of the legs (``steps off > 40 cm``)."""


def _step_errors(runs: list[SessionRun]) -> dict[str, float]:
    """Step length and width errors (cm) over every matched step, and over the confident ones alone: those the
    gait summaries pool (confidence at least ``GaitConfig.summary_min_confidence``)."""
    from walker_gait.core.gait import GaitConfig

    cut = GaitConfig().summary_min_confidence
    pairs = [(r.gt[t], r.det[j]) for r in runs for t, j in r.pairs]
    length = np.array([d.step_length - g.step_length for g, d in pairs]) * 100
    width = np.array([d.step_width - g.step_width for g, d in pairs]) * 100
    sure = np.array([d.confidence >= cut for _, d in pairs], dtype=bool)
    has_w = np.isfinite(width)
    out: dict[str, float] = {}
    for name, e in (("length", length), ("width", width[has_w])):
        out[f"step_{name}_mae_cm"] = float(np.mean(np.abs(e))) if e.size else math.nan
        out[f"step_{name}_bias_cm"] = float(np.mean(e)) if e.size else math.nan
        out[f"step_{name}_median_abs_cm"] = float(np.median(np.abs(e))) if e.size else math.nan
    for name, e in (("length", length[sure]), ("width", width[sure & has_w])):
        out[f"step_{name}_mae_confident_cm"] = float(np.mean(np.abs(e))) if e.size else math.nan
    # the step length MAE of a run is mostly its tail (a leg exchange puts a step tens of cm off) and that tail is what
    # tracker seeds reshuffle; the body (steps at most TAIL_CM off) moves less: report them apart
    a = np.abs(length)
    out["steps_off_over_10cm"] = int(np.sum(a > TAIL_CM))
    out["steps_off_over_40cm"] = int(np.sum(a > GROSS_CM))
    body = a[a <= TAIL_CM]
    out["step_length_mae_body_cm"] = float(np.mean(body)) if body.size else math.nan
    out["confident_share"] = float(sure.mean()) if sure.size else math.nan
    # event timing of the matched steps, in frames of each run: a step's stamp is its heel strike, its swing ends
    # there (toe off = stamp less swing time), and its double support sums two heel-strike-to-toe-off intervals
    hs, to, ds = [], [], []
    for r in runs:
        if r.stamps.size < 2:
            continue
        dt = float(np.median(np.diff(r.stamps)))
        for t, j in r.pairs:
            g, d = r.gt[t], r.det[j]
            hs.append((d.stamp - g.stamp) / dt)
            if math.isfinite(g.swing_time) and math.isfinite(d.swing_time):
                to.append(((d.stamp - d.swing_time) - (g.stamp - g.swing_time)) / dt)
            if math.isfinite(g.double_support_time) and math.isfinite(d.double_support_time):
                ds.append((d.double_support_time - g.double_support_time) / dt)
    out["hs_timing_median_abs_frames"] = float(np.median(np.abs(hs))) if hs else math.nan
    out["to_timing_median_abs_frames"] = float(np.median(np.abs(to))) if to else math.nan
    out["double_support_median_err_frames"] = float(np.median(ds)) if ds else math.nan
    return out


def true_steps_at_walker(run: SessionRun) -> list[Step]:
    """The true steps of ``run`` whose heel strikes the walker measures: the user in view with both ankles in its
    region of interest (:func:`~walker_gait.bench.endtoend.at_walker`, :func:`~walker_gait.bench.endtoend.steps_in_view`,
    as the recall in view).  A user walking up from the side, a metre off the walker's line, takes steps that the
    walker does not measure by design; compared with a summary that pooled them, the gait speed of the
    ``absent_start`` sessions came out 10 % fast on average (their approach steps and the closing step at the walker
    are shorter than the walking ones), though the steps at the walker were measured to 1-2 cm."""
    return [s for s, v in zip(run.gt, _in_view_at_walker(run), strict=True) if v]


def _in_view_at_walker(run: SessionRun) -> np.ndarray:
    """``(len(run.gt),)`` which true steps the recall in view counts (see :func:`true_steps_at_walker`)."""
    from walker_gait.bench.endtoend import IN_VIEW_TAIL_S, at_walker, steps_in_view

    if not run.gt:
        return np.zeros(0, dtype=bool)
    hs = np.array([s.stamp for s in run.gt])
    return steps_in_view(hs, run.stamps, run.present & at_walker(run.truth, run.true_floor), tail_s=IN_VIEW_TAIL_S)


def _summary_errors(runs: list[SessionRun]) -> dict[str, float]:
    """Mean over the runs of the absolute cadence and gait speed errors (%) of the session summary a clinician
    reads (``summarize_steps`` of the detected steps with the analyzer's confidence cuts, as ``GaitAnalyzer.summary``
    gives them: ``checked`` for two-pass runs) against the same summary of the true steps taken at the walker
    (:func:`true_steps_at_walker`), whose cadence is the walkway's definition (60 / their mean step time)."""
    from walker_gait.bench.gait import session_summaries

    errs: dict[str, list[float]] = {"cadence": [], "speed": []}
    for r in runs:
        # two passes: the steps were checked against them, as the pipeline's summary
        true, det = session_summaries(true_steps_at_walker(r), r.det, checked=len(r.passes) >= 2)
        for name, t, d in (("cadence", true.cadence, det.cadence), ("speed", true.gait_speed, det.gait_speed)):
            if math.isfinite(t) and t > 0:
                # a session without a detected walking step misses its figure entirely: 100 %
                errs[name].append(100.0 * abs(d - t) / t if math.isfinite(d) else 100.0)
    return {f"{name}_abs_err_pct": float(np.mean(e)) if e else math.nan for name, e in errs.items()}


def _trailing_toe(runs: list[SessionRun]) -> dict[str, float]:
    """Progression error (cm, + = ahead) of the other foot's toe at each matched true heel strike."""
    errs = []
    for r in runs:
        prog = _progression(r)
        for t, _ in r.pairs:
            g = r.gt[t]
            i = int(np.argmin(np.abs(r.stamps - g.stamp)))
            other = 1 - int(g.side)
            errs.append(float((r.est[i, other, TOE] - r.truth[i, other, TOE]) @ prog) * 100)
    e = np.array(errs)
    e = e[np.isfinite(e)]
    return {"trailing_toe_median_cm": float(np.median(e)) if e.size else math.nan,
            "trailing_toe_mean_cm": float(np.mean(e)) if e.size else math.nan}


def _angle_errors(runs: list[SessionRun]) -> dict[str, dict[str, float]]:
    """``JointState`` angles against the truth over the trackable frames (as the joint errors), both legs pooled:
    mean |error| and bias, degrees (:func:`~walker_gait.bench.endtoend.angle_errors`); runs stored without the true
    angles are left out (all NaN when none has them)."""
    from walker_gait.bench.endtoend import JOINT_KINDS, angle_errors

    est, truth = [], []
    for r in runs:
        true_angles = getattr(r, "truth_angles", None)  # a run built by hand without it, or one unpickled elsewhere
        if true_angles is None or len(true_angles) != len(r.stamps) or len(r.poses) != len(r.stamps):
            continue
        est.append(np.stack([np.asarray(p.angles, dtype=float) for p in r.poses])[r.trackable])
        truth.append(true_angles[r.trackable])
    if not est:
        nan = dict.fromkeys(JOINT_KINDS, math.nan)
        return {"angle_err_deg": nan, "angle_bias_deg": dict(nan)}
    mae, bias = angle_errors(np.concatenate(est), np.concatenate(truth))
    return {"angle_err_deg": mae, "angle_bias_deg": bias}


SWAP_MARGIN_M = 0.05
"""A frame's legs count as swapped when the tracked feet (ankle, heel, toe) fit the other side's true feet better, by
this much on average, than their own."""


def _swaps(runs: list[SessionRun]) -> dict[str, float]:
    """Left/right swaps: the share of trackable frames (%) whose tracked feet lie on the other side's true feet, and
    the number of runs with any such frame (a model leg that merely covers both real legs is not a swap)."""
    frames = swapped = runs_with = 0
    for r in runs:
        est, truth = r.est[:, :, ANKLE : TOE + 1], r.truth[:, :, ANKLE : TOE + 1]
        ok = r.trackable & np.all(np.isfinite(est.reshape(len(est), -1)), axis=1)
        own = np.linalg.norm(est - truth, axis=-1).mean(axis=(1, 2))
        other = np.linalg.norm(est - truth[:, ::-1], axis=-1).mean(axis=(1, 2))
        s = ok & (other + SWAP_MARGIN_M < own)
        frames += int(ok.sum())
        swapped += int(s.sum())
        runs_with += int(s.any())
    return {"swapped_frames_pct": 100.0 * swapped / frames if frames else math.nan, "runs_with_swaps": runs_with}


def summarise(runs: list[SessionRun]) -> dict[str, Any]:
    """Figures of a set of runs (one tracker seed, or several pooled)."""
    import warnings

    from walker_gait.bench.endtoend import at_walker, steps_in_view

    err_all, good_all, flen, bad_at_walker = [], [], [], []
    gt = det = matched = in_view = matched_in_view = in_image = matched_in_image = 0
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Mean of empty slice", category=RuntimeWarning)
        for r in runs:
            e = np.linalg.norm(r.est - r.truth, axis=-1)[r.trackable]  # (F, 2, 5)
            per_frame = np.nanmean(e, axis=(1, 2))
            good = per_frame <= 0.10
            # the frames of a user at the walker (both true ankles in its region of interest): a user still walking
            # up from the side is in the image but outside what the walker measures, by design
            bad_at_walker.append(~good[at_walker(r.truth, r.true_floor)[r.trackable]])
            err_all.append(e)
            good_all.append(e[good])
            est_len = np.linalg.norm(r.est[:, :, TOE] - r.est[:, :, HEEL], axis=-1)[r.trackable][good]
            true_len = np.linalg.norm(r.truth[:, :, TOE] - r.truth[:, :, HEEL], axis=-1)[r.trackable][good]
            flen.append((est_len - true_len).ravel())
            gt += len(r.gt)
            det += len(r.det)
            matched += len(r.pairs)
            if r.gt:
                hs = np.array([s.stamp for s in r.gt])
                iv = _in_view_at_walker(r)
                # the older, looser count: the user anywhere in the image, up to the last frame
                ii = steps_in_view(hs, r.stamps, r.present)
            else:
                iv = ii = np.zeros(0, bool)
            in_view += int(iv.sum())
            matched_in_view += sum(1 for t, _ in r.pairs if iv[t])
            in_image += int(ii.sum())
            matched_in_image += sum(1 for t, _ in r.pairs if ii[t])
        e = np.concatenate(err_all) if err_all else np.zeros((0, 2, 5))
        g = np.concatenate(good_all) if good_all else np.zeros((0, 2, 5))
        per_frame = np.nanmean(e, axis=(1, 2)) if len(e) else np.zeros(0)
        bw = np.concatenate(bad_at_walker) if bad_at_walker else np.zeros(0, dtype=bool)
        out: dict[str, Any] = {
            "sessions": len(runs),
            "joint_err_cm": {p: float(np.nanmean(e[:, :, k]) * 100) for k, p in enumerate(LEG_POINTS)},
            "frames_over_10cm_pct": float(np.mean(~(per_frame <= 0.10)) * 100) if len(e) else math.nan,
            "frames_over_10cm_at_walker_pct": float(np.mean(bw) * 100) if bw.size else math.nan,
            "good_frame_err_cm": {p: float(np.nanmean(g[:, :, k]) * 100) for k, p in enumerate(LEG_POINTS) if k >= ANKLE},
        }
    fl = np.concatenate(flen) if flen else np.zeros(0)
    out["foot_length_bias_cm"] = float(np.nanmedian(fl) * 100) if np.isfinite(fl).any() else math.nan
    out.update(gt_steps=gt, detected_steps=det, matched_steps=matched, gt_steps_in_view=in_view,
               matched_in_view=matched_in_view, precision=matched / det if det else math.nan,
               recall=matched / gt if gt else math.nan,
               recall_in_view=matched_in_view / in_view if in_view else math.nan,
               gt_steps_in_image=in_image, recall_in_image=matched_in_image / in_image if in_image else math.nan)
    out.update(_angle_errors(runs))
    out.update(_swaps(runs))
    out.update(_step_errors(runs))
    out.update(_summary_errors(runs))
    out.update(_trailing_toe(runs))
    out["tracker_ms"] = float(np.nanmean([r.tracker_ms for r in runs])) if runs else math.nan
    return out


def oracle(runs: list[SessionRun], points: tuple[int, ...], gait: GaitConfig | None = None) -> dict[str, float]:
    """Step figures of the gait analyzer (``GaitConfig`` ``gait``, default: the pipeline's) fed the tracked poses
    with the true ``points`` substituted.

    The analyzer gets the true floor and every frame with an estimate at full confidence, so ``points=()``
    differs a little from the pipeline's own steps (estimated floor, tracker confidences).  The tracker's foot
    visibility goes with the poses (the analyzer does not trust a hidden trailing toe) unless the toes are
    substituted (an exact toe counts as in view).  A two-pass run's analyzer read its passes merged (its stored poses
    are the reported ones, bridged and low-passed): the substitution goes into that merged track, which is then
    analysed as a one-pass run's (no check against the passes, which know nothing of the true points)."""
    from walker_gait.core.smoothing import merge_passes

    exact_toe = TOE in points
    subs = []
    for r in runs:
        track = merge_passes(r.passes).poses if len(r.passes) >= 2 else r.poses
        est = np.stack([tp.points for tp in track]) if track else r.est
        poses = []
        for i in range(len(r.stamps)):
            p = np.array(est[i], dtype=np.float64, copy=True)
            p[:, list(points)] = r.truth[i][:, list(points)]
            ok = bool(np.all(np.isfinite(p)))
            vis = None if exact_toe or not track else track[i].visibility
            poses.append(LegPose(stamp=float(r.stamps[i]), points=p if ok else np.full((2, 5, 3), np.nan),
                                 status=TrackStatus.TRACKING if ok else TrackStatus.NO_USER, confidence=1.0 if ok else 0.0,
                                 visibility=vis))
        subs.append(replace(r, poses=poses, floors=[r.true_floor] * len(poses), passes=()))
    subs = reanalyse(subs, gait)
    out = {"matched_steps": float(sum(len(s.pairs) for s in subs))}
    out.update(_step_errors(subs))
    return out


def report(runs: list[SessionRun], *, with_oracle: bool = False, gait: GaitConfig | None = None) -> dict[str, Any]:
    """``summary.json`` content: per tracker seed, and per scenario (tracker seeds pooled); the oracle rows use the
    analyzer configuration ``gait`` (that of a re-analysis)."""
    seeds = sorted({r.tracker_seed for r in runs})
    out: dict[str, Any] = {"per_tracker_seed": {str(s): summarise([r for r in runs if r.tracker_seed == s]) for s in seeds}}
    out["per_scenario"] = {}
    for sc in dict.fromkeys(r.scenario for r in runs):
        sub = [r for r in runs if r.scenario == sc]
        s = summarise(sub)
        out["per_scenario"][sc] = {k: s[k] for k in ("joint_err_cm", "angle_err_deg", "angle_bias_deg", "frames_over_10cm_pct", "matched_steps", "gt_steps",
                                                     "step_length_mae_cm", "step_length_bias_cm", "step_width_mae_cm",
                                                     "confident_share", "step_length_mae_confident_cm",
                                                     "cadence_abs_err_pct", "speed_abs_err_pct",
                                                     "trailing_toe_median_cm")}
    if with_oracle:
        out["oracle"] = {str(s): {name: oracle([r for r in runs if r.tracker_seed == s], pts, gait)
                                  for name, pts in (("none", ()), *ORACLE_POINTS.items())} for s in seeds}
    return out


_ROWS = (("heel err cm", ("joint_err_cm", "heel")), ("toe err cm", ("joint_err_cm", "toe")),
         ("ankle err cm", ("joint_err_cm", "ankle")), ("knee err cm", ("joint_err_cm", "knee")),
         ("hip err cm", ("joint_err_cm", "hip")),
         ("hip flexion err deg", ("angle_err_deg", "hip_flexion")), ("hip flexion bias deg", ("angle_bias_deg", "hip_flexion")),
         ("knee flexion err deg", ("angle_err_deg", "knee_flexion")),
         ("knee flexion bias deg", ("angle_bias_deg", "knee_flexion")),
         ("ankle flexion err deg", ("angle_err_deg", "ankle_flexion")),
         ("frames > 10 cm %", ("frames_over_10cm_pct",)),
         ("frames > 10 cm at the walker %", ("frames_over_10cm_at_walker_pct",)),
         ("swapped frames %", ("swapped_frames_pct",)), ("runs with swaps", ("runs_with_swaps",)),
         ("good-frame heel cm", ("good_frame_err_cm", "heel")), ("good-frame toe cm", ("good_frame_err_cm", "toe")),
         ("foot length bias cm", ("foot_length_bias_cm",)), ("matched steps", ("matched_steps",)),
         ("recall in view", ("recall_in_view",)), ("recall, user in image", ("recall_in_image",)),
         ("precision", ("precision",)),
         ("step length MAE cm", ("step_length_mae_cm",)), ("step length median abs err cm", ("step_length_median_abs_cm",)),
         ("step length bias cm", ("step_length_bias_cm",)),
         ("steps off > 10 cm", ("steps_off_over_10cm",)), ("steps off > 40 cm", ("steps_off_over_40cm",)),
         ("step length MAE, steps <= 10 cm off", ("step_length_mae_body_cm",)),
         ("step width MAE cm", ("step_width_mae_cm",)), ("step width bias cm", ("step_width_bias_cm",)),
         ("confident steps share", ("confident_share",)),
         ("confident: length MAE cm", ("step_length_mae_confident_cm",)),
         ("confident: width MAE cm", ("step_width_mae_confident_cm",)),
         ("HS timing median abs err frames", ("hs_timing_median_abs_frames",)),
         ("TO timing median abs err frames", ("to_timing_median_abs_frames",)),
         ("double support median err frames", ("double_support_median_err_frames",)),
         ("cadence abs err %", ("cadence_abs_err_pct",)), ("gait speed abs err %", ("speed_abs_err_pct",)),
         ("trailing toe median cm", ("trailing_toe_median_cm",)), ("tracker ms/frame", ("tracker_ms",)))


def format_table(summaries: dict[str, dict[str, Any]]) -> str:
    """Markdown table: one column per (name, tracker seed), one row per figure."""
    cols = [(name, seed, s) for name, rep in summaries.items() for seed, s in rep["per_tracker_seed"].items()]
    lines = ["| figure | " + " | ".join(f"{n} (seed {sd})" for n, sd, _ in cols) + " |",
             "|---|" + "---|" * len(cols)]
    for label, path in _ROWS:
        vals = []
        for _, _, s in cols:
            v: Any = s
            for p in path:
                v = v.get(p) if isinstance(v, dict) else None  # sweeps written before a figure existed lack it
            vals.append(f"{v:.2f}" if isinstance(v, float) else "n/a" if v is None else str(v))
        lines.append(f"| {label} | " + " | ".join(vals) + " |")
    return "\n".join(lines)


def format_oracle(rep: dict[str, Any]) -> str:
    """Markdown table of the ``oracle`` figures: step length / width MAE (bias) per substituted point."""
    lines = ["| tracker seed | substituted | matched | step length MAE (bias) cm | step width MAE (bias) cm |",
             "|---|---|---|---|---|"]
    for seed, by_name in rep.get("oracle", {}).items():
        for name, o in by_name.items():
            lines.append(f"| {seed} | {name} | {o['matched_steps']:.0f} | {o['step_length_mae_cm']:.2f} "
                         f"({o['step_length_bias_cm']:+.2f}) | {o['step_width_mae_cm']:.2f} ({o['step_width_bias_cm']:+.2f}) |")
    return "\n".join(lines)


def _work(args: tuple[str, int, float, tuple[int, ...], dict[str, Any], Path | None, dict[str, Any], str,
                      int | None, dict[str, Any]]) -> list[SessionRun]:
    scenario, seed, duration, seeds, overrides, cache, spec, passes, tracker_runs, roi = args
    return run_session(scenario, seed, duration=duration, tracker_seeds=seeds, overrides=overrides, cache=cache,
                       spec=spec, passes=passes, tracker_runs=tracker_runs, roi=roi)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m walker_gait.bench.sweep", description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, help="output directory (summary.json, table.md)")
    ap.add_argument("--compare", type=Path, nargs="+", metavar="DIR", help="print the summaries of earlier sweeps side by side")
    ap.add_argument("--override", default="{}", help="TrackerConfig field overrides of the default preset, JSON")
    ap.add_argument("--roi-override", default="{}",
                    help="the segmenter's RoiConfig field overrides, JSON (e.g. '{\"join_edge_parts\": true}')")
    ap.add_argument("--spec-override", default="{}",
                    help="SessionSpec field overrides for every session, JSON (e.g. other subjects, mounts, cameras: "
                         "'{\"body_scale\": [1.12, 1.2], \"cam_height\": [0.65, 0.75]}'); rendered separately in the cache")
    ap.add_argument("--scenarios", nargs="+", default=list(SCENARIOS), choices=SCENARIOS)
    ap.add_argument("--per-scenario", type=int, default=4, help="sessions per scenario (default 4)")
    ap.add_argument("--base-seed", type=int, default=100, help="session seeds: base + 10 k + j for scenario k (its place in the full list) (default 100; 500 = a second set)")
    ap.add_argument("--tracker-seeds", type=int, nargs="+", default=[0, 1])
    ap.add_argument("--duration", type=float, default=8.0, help="s per session (absent_start: at least 14)")
    ap.add_argument("--cache", type=Path, default=Path("out/sweep/cache"), help="rendered sessions (reused)")
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--passes", choices=("both", "forward"), default="both",
                    help="tracking passes, as `walker-gait process --passes` (default both; forward: the live graph's one)")
    ap.add_argument("--tracker-runs", type=int, default=None, metavar="N",
                    help="with --passes both: each direction tracked N times, as `walker-gait process --tracker-runs` "
                         "(default: the preset's, 1; 2: four passes merged, twice the time)")
    ap.add_argument("--oracle", action="store_true", help="also step figures with true toes/heels/ankles substituted")
    ap.add_argument("--reanalyse", type=Path, metavar="DIR",
                    help="no tracking: re-run the gait analyzer on the tracked poses of the sweep in DIR (its runs.pkl)")
    ap.add_argument("--gait-override", default="{}", help="with --reanalyse: GaitConfig field overrides, JSON")
    ap.add_argument("--merge-override", default=None,
                    help="with --reanalyse of a two-pass sweep: merge the kept forward and backward passes again with "
                         "these merge_passes keyword arguments, JSON (e.g. '{\"switch_cost\": 300}')")
    ap.add_argument("--confirm-override", default=None,
                    help="with --reanalyse of a two-pass sweep: confirm_steps keyword arguments, JSON (e.g. "
                         "'{\"within_m\": 0.05}')")
    a = ap.parse_args(argv)
    if a.compare:
        reps = {}
        for d in a.compare:
            path = d / "summary.json"
            try:
                reps[d.name] = json.loads(path.read_text())
            except (OSError, json.JSONDecodeError) as exc:
                print(f"sweep: cannot read {path}: {exc}", file=sys.stderr)
                return 2
        print(format_table(reps))
        return 0
    if a.out is None:
        ap.error("--out is required (or --compare)")
    if a.reanalyse is not None:
        return _reanalyse_main(a)
    try:
        overrides = json.loads(a.override)
        from walker_gait.core.tracker import preset

        preset("default", **overrides)
    except (json.JSONDecodeError, TypeError, ValueError) as exc:
        print(f"sweep: bad --override {a.override!r}: {exc}", file=sys.stderr)
        return 2
    try:
        from walker_gait.core.segmentation import RoiConfig

        roi = json.loads(a.roi_override)
        if not isinstance(roi, dict):
            raise TypeError("not a JSON object")
        RoiConfig(**roi).validate()
    except (json.JSONDecodeError, TypeError, ValueError) as exc:
        print(f"sweep: bad --roi-override {a.roi_override!r}: {exc}", file=sys.stderr)
        return 2
    try:
        spec = spec_overrides(a.spec_override)
    except ValueError as exc:
        print(f"sweep: bad --spec-override {a.spec_override!r}: {exc}", file=sys.stderr)
        return 2
    sessions = session_list(tuple(a.scenarios), a.per_scenario, a.base_seed)
    try:  # refused here, not in the workers
        from walker_gait.pipeline import PipelineOptions

        PipelineOptions(passes=a.passes, tracker_runs=a.tracker_runs)
    except ValueError as exc:
        print(f"sweep: {exc}", file=sys.stderr)
        return 2
    jobs = [(sc, sd, a.duration, tuple(a.tracker_seeds), overrides, a.cache, spec, a.passes, a.tracker_runs, roi)
            for sc, sd in sessions]
    t0 = time.perf_counter()
    runs: list[SessionRun] = []
    from tqdm import tqdm

    with ProcessPoolExecutor(max_workers=max(1, a.jobs)) as pool:
        for res in tqdm(pool.map(_work, jobs), total=len(jobs), desc="sessions", unit="session", file=sys.stderr):
            runs.extend(res)
    config = {"override": overrides, "roi_override": roi, "spec_override": spec, "scenarios": a.scenarios, "per_scenario": a.per_scenario,
              "base_seed": a.base_seed, "tracker_seeds": a.tracker_seeds, "duration": a.duration, "passes": a.passes,
              "tracker_runs": a.tracker_runs,
              "seconds": round(time.perf_counter() - t0, 1)}
    _write(a.out, runs, config, with_oracle=a.oracle)
    print(f"[sweep] {len(sessions)} sessions x {len(a.tracker_seeds)} tracker seeds in {time.perf_counter() - t0:.0f} s -> "
          f"{a.out}", file=sys.stderr)
    return 0


def _write(out: Path, runs: list[SessionRun], config: dict[str, Any], *, with_oracle: bool,
           gait: GaitConfig | None = None) -> None:
    """``summary.json``, ``table.md`` and ``runs.pkl`` into ``out``; the table also to stdout."""
    rep = report(runs, with_oracle=with_oracle, gait=gait)
    rep["config"] = config
    out.mkdir(parents=True, exist_ok=True)
    table = format_table({out.name: rep})
    if with_oracle:
        table += "\n\nGait analyzer on the tracked poses with true points substituted:\n\n" + format_oracle(rep)
    for name, text in (("summary.json", json.dumps(rep, indent=1)), ("table.md", table + "\n")):
        tmp = out / f".{name}.tmp"
        tmp.write_text(text)
        os.replace(tmp, out / name)
    save_runs(runs, out / "runs.pkl")
    print(table)


def _kwargs_override(text: str | None, func: Callable[..., Any]) -> dict[str, Any] | None:
    """A JSON object of keyword-only arguments of ``func`` (None: no override); ValueError naming the option."""
    import inspect

    if text is None:
        return None
    option = f"--{func.__name__.split('_')[0]}-override"
    try:
        kwargs = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"bad {option} {text!r}: {exc}") from exc
    if not isinstance(kwargs, dict):
        raise ValueError(f"bad {option} {text!r}: not a JSON object")
    known = {n for n, p in inspect.signature(func).parameters.items() if p.kind is p.KEYWORD_ONLY}
    unknown = sorted(set(kwargs) - known)
    if unknown:
        raise ValueError(f"bad {option} {text!r}: unknown {func.__name__} argument(s) {', '.join(unknown)} "
                         f"(known: {', '.join(sorted(known))})")
    return kwargs


def _reanalyse_main(a: argparse.Namespace) -> int:
    from walker_gait.core.gait import GaitConfig
    from walker_gait.core.smoothing import confirm_steps, merge_passes

    t0 = time.perf_counter()
    src = a.reanalyse / "runs.pkl"
    try:
        override = json.loads(a.gait_override)
        gait = GaitConfig(**override)
    except (json.JSONDecodeError, TypeError, ValueError) as exc:
        print(f"sweep: bad --gait-override {a.gait_override!r}: {exc}", file=sys.stderr)
        return 2
    try:
        merge = _kwargs_override(a.merge_override, merge_passes)
        confirm = _kwargs_override(a.confirm_override, confirm_steps)
    except ValueError as exc:
        print(f"sweep: {exc}", file=sys.stderr)
        return 2
    try:
        runs = reanalyse(load_runs(src), gait, merge=merge, confirm=confirm)
    except (OSError, ValueError, pickle.UnpicklingError, EOFError, AttributeError) as exc:
        print(f"sweep: cannot re-analyse {src}: {exc}", file=sys.stderr)
        return 2
    config = {"reanalysed": str(a.reanalyse), "gait_override": override, "merge_override": merge,
              "confirm_override": confirm,
              "seconds": round(time.perf_counter() - t0, 1)}
    _write(a.out, runs, config, with_oracle=a.oracle, gait=gait)
    print(f"[sweep] re-analysed {len(runs)} runs of {src} -> {a.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    # run the importable module's main, so runs.pkl holds walker_gait.bench.sweep.SessionRun, not __main__'s
    from walker_gait.bench import sweep as _sweep

    sys.exit(_sweep.main())
