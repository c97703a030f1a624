"""End-to-end accuracy and speed on synthetic sessions with ground truth.

The whole offline pipeline (``FrameProcessor``: decode, back-project, segment, track, gait) runs on the
rendered depth of a generated session, exactly as ``walker-gait process`` would, and its output is scored
against the session's ground truth: 3D joint errors, left/right swaps, step detection, step length/width
errors (the seed paper's Tables 2-3 measure), heel-strike timing, cadence, and per-stage time.
"""

from __future__ import annotations

import dataclasses
import math
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from types import SimpleNamespace
from typing import TYPE_CHECKING, Any

import numpy as np

from walker_gait.core.types import JOINT_NAMES, LEG_POINTS, FloorPlane, Step

if TYPE_CHECKING:
    from walker_gait.core.segmentation import RoiConfig

STAGES = ("depth", "segmentation", "tracker", "tracker_backward", "pass_scoring", "gait")
"""Per-frame stages of the offline pipeline; ``tracker`` is the forward pass (the live tracker's work), the
backward pass and the scoring of both passes' estimates come with ``passes="both"`` only."""


@dataclass
class Score:
    scenario: str
    preset: str
    cue: str
    frames: int
    ms_per_frame: dict[str, float] = field(default_factory=dict)
    joint_err_cm: dict[str, float] = field(default_factory=dict)
    frames_over_10cm_pct: float = float("nan")  # of the frames with both legs in the image
    frames_over_10cm_at_walker_pct: float = float("nan")  # ... with both ankles at the walker (:func:`at_walker`)
    swap_frames: int = 0
    gt_steps: int = 0
    detected_steps: int = 0
    matched_steps: int = 0
    precision: float = float("nan")
    recall: float = float("nan")
    gt_steps_in_view: int = 0  # true steps whose heel strike follows >= IN_VIEW_LEAD_S s with the user in view
    matched_in_view: int = 0
    recall_in_view: float = float("nan")
    step_length_err_cm: tuple[float, float] = (float("nan"), float("nan"))  # mean, SD of |error|
    step_width_err_cm: tuple[float, float] = (float("nan"), float("nan"))
    hs_timing_median_frames: float = float("nan")
    cadence_err_pct: float = float("nan")
    steps_during_standstill: int = 0
    recovery_s: float = float("nan")  # from the user's arrival at the walker (:func:`recovery_time`)
    recovery_in_image_s: float = float("nan")  # from the user's first frame in the image, wherever
    in_image_pct: dict[str, float] = field(default_factory=dict)  # frames where the true point is in the image
    angle_err_deg: dict[str, float] = field(default_factory=dict)  # JointState angles: mean |error| (:func:`angle_errors`)
    angle_bias_deg: dict[str, float] = field(default_factory=dict)  # ... and mean signed error
    tracker_first_ms: float = float("nan")  # the first frame (initial search)
    tracker_ms_after_first: float = float("nan")  # mean over the frames after it
    held_pct: float = float("nan")  # live_bridged: share of the frames held back (a foot hidden, or behind one)
    held_s: tuple[float, float] = (float("nan"), float("nan"))  # ... their delay, median and largest (s)

    @property
    def fps(self) -> float:
        total = sum(self.ms_per_frame.values())
        return 1000.0 / total if total > 0 else float("nan")


IN_VIEW_LEAD_S = 1.0
"""A true step counts as *in view* when the user was in view for this long (s) before its heel strike:
the tracker's re-acquisition allowance (issue: recover within 1 s)."""

IN_VIEW_TAIL_S = 0.1
"""... and when the recording goes on for this long (s) after it: a landing is told from a foot still coming down
only by the frames in which it stays down (the analyzer fits ``GaitConfig.event_fit_post_s``, 0.12 s, after it), so
a strike in the last few frames of a recording cannot be confirmed (a walkway likewise leaves out footfalls
cut by its ends)."""


def at_walker(truth: np.ndarray, floor: FloorPlane, roi: RoiConfig | None = None) -> np.ndarray:
    """``(T,)`` True where both true ankles (``truth`` ``(T, 2, 5, 3)``, camera frame, ``LEG_POINTS``) lie in the
    walker's region of interest (``roi``, default :class:`~walker_gait.core.segmentation.RoiConfig`): forward
    between ``near`` and ``forward``, sideways inside the box widened by ``center_max_shift`` (the box follows the
    legs that far).  A user approaching the walker from the side, a metre off its line, is in the image but not in
    the region the walker measures by design (seed 000 §4.2): the steps taken there are not walker gait."""
    from walker_gait.core.segmentation import RoiConfig

    r = roi if roi is not None else RoiConfig()
    pw = floor.to_walker(np.asarray(truth, dtype=float)[:, :, LEG_POINTS.index("ankle")])  # (T, 2, 3)
    with np.errstate(invalid="ignore"):
        inside = ((pw[..., 0] >= r.near) & (pw[..., 0] <= r.forward)
                  & (pw[..., 1] <= r.left + r.center_max_shift) & (pw[..., 1] >= -(r.right + r.center_max_shift)))
    return np.asarray(inside.all(axis=1), dtype=bool)


def frames_off_pct(err: np.ndarray, frames: np.ndarray, *, limit_m: float = 0.10) -> float:
    """The share (%) of the ``frames`` ``(T,)`` (bool) whose mean error over the points of ``err`` ``(T, 2, 5)`` (m)
    exceeds ``limit_m``; a frame without an estimate (all NaN) counts as off; NaN without frames."""
    frames = np.asarray(frames, dtype=bool)
    if not frames.any():
        return float("nan")
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Mean of empty slice", category=RuntimeWarning)
        per_frame = np.nanmean(np.asarray(err, dtype=float)[frames], axis=(1, 2))
    return float(np.mean(~(per_frame <= limit_m)) * 100)


JOINT_KINDS: tuple[str, ...] = tuple(name.removeprefix("left_") for name in JOINT_NAMES[: len(JOINT_NAMES) // 2])
"""The ``JointState`` angles of one leg (``hip_flexion`` ... ``ankle_inversion``), both sides' names without the side."""


def angle_errors(est: np.ndarray, truth: np.ndarray) -> tuple[dict[str, float], dict[str, float]]:
    """``JointState`` angle errors: per angle of :data:`JOINT_KINDS`, the mean |estimate − truth| and the mean signed
    error (estimate − truth), degrees, both legs pooled (the names' sign conventions are anatomical, the same for
    either leg).

    ``est`` and ``truth`` are ``(F, 12)`` angles in ``JOINT_NAMES`` order, radians, over the frames to score;
    differences are wrapped to (−180, 180] deg, and an angle that is NaN in either is left out of its own figures
    (NaN when none is left)."""
    est = np.asarray(est, dtype=float).reshape(-1, len(JOINT_NAMES))
    truth = np.asarray(truth, dtype=float).reshape(-1, len(JOINT_NAMES))
    if est.shape != truth.shape:
        msg = f"estimated and true angles differ in shape: {est.shape} vs {truth.shape}"
        raise ValueError(msg)
    d = np.degrees(np.angle(np.exp(1j * (est - truth))))
    n = len(JOINT_KINDS)
    pooled = np.concatenate([d[:, :n], d[:, n:]])  # (2F, 6): left frames, then right
    mae, bias = {}, {}
    for k, name in enumerate(JOINT_KINDS):
        v = pooled[:, k][np.isfinite(pooled[:, k])]
        mae[name] = float(np.abs(v).mean()) if v.size else math.nan
        bias[name] = float(v.mean()) if v.size else math.nan
    return mae, bias


RECOVERY_ERR_M = 0.10
"""Mean 3D error (m) of the five points of both legs under which a track counts as recovered ..."""

RECOVERY_HOLD_FRAMES = 5
"""... in this many frames in a row."""


def recovery_time(stamps: np.ndarray, err: np.ndarray, start: np.ndarray) -> float:
    """Seconds from the first frame in which ``start`` holds to the first frame from which the mean error stays
    under :data:`RECOVERY_ERR_M` for :data:`RECOVERY_HOLD_FRAMES` frames (``err`` ``(T, 2, 5)`` metres, NaN where
    the tracker reports no pose: not recovered).  NaN when ``start`` never holds, inf when the track never
    recovers after it."""
    start = np.asarray(start, dtype=bool)
    if not start.any():
        return float("nan")
    first = int(np.argmax(start))
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Mean of empty slice", category=RuntimeWarning)
        ok = np.nanmean(np.asarray(err, dtype=float).reshape(len(start), -1), axis=1) < RECOVERY_ERR_M
    for j in range(first, len(ok) - RECOVERY_HOLD_FRAMES + 1):
        if ok[j:j + RECOVERY_HOLD_FRAMES].all():
            return float(stamps[j] - stamps[first])
    return math.inf


def steps_in_view(step_stamps: np.ndarray, stamps: np.ndarray, present: np.ndarray, *,
                  lead_s: float = IN_VIEW_LEAD_S, tail_s: float = 0.0) -> np.ndarray:
    """``(S,)`` True for steps (heel-strike ``step_stamps``) preceded by ``lead_s`` s with the user in view.

    ``stamps`` ``(T,)`` increasing frame times, ``present`` ``(T,)`` the user in view (a leg hidden
    behind the other one still counts: that is the tracker's job; the benchmarks pass the user in the image *and*
    at the walker, :func:`at_walker`).  A step before the first frame, closer than ``lead_s`` to the session start
    or closer than ``tail_s`` (the benchmarks: :data:`IN_VIEW_TAIL_S`) to its last frame is not in view (no
    evidence it could be seen).
    """
    step_stamps = np.asarray(step_stamps, dtype=float)
    stamps = np.asarray(stamps, dtype=float)
    ok = np.asarray(present, dtype=bool)
    out = np.zeros(step_stamps.shape, dtype=bool)
    for i, t in enumerate(step_stamps):
        if t - lead_s < stamps[0] - 1e-9 or t > stamps[-1] - tail_s + 1e-9:
            continue
        window = (stamps >= t - lead_s - 1e-9) & (stamps <= t + 1e-9)
        out[i] = bool(window.any() and ok[window].all())
    return out


def _gt_as_steps(session: Any) -> list[Step]:
    return [Step(stamp=s.stamp, side=s.side, index=s.index, step_length=s.step_length, step_width=s.step_width,
                 step_time=s.step_time, stride_length=s.stride_length, stride_time=s.stride_time,
                 stance_time=s.stance_time, swing_time=s.swing_time, single_support_time=s.single_support_time,
                 double_support_time=s.double_support_time) for s in session.steps]


@dataclass
class Rendered:
    """A session's rendered 16UC1 frames and, per frame and leg, the count of valid leg pixels."""

    frames: list[np.ndarray]
    visible_pixels: np.ndarray  # (T, 2)
    seconds: float

    def trackable(self, min_pixels: int = 200) -> np.ndarray:
        """(T,) True where both legs show at least ``min_pixels`` valid pixels (at full 640x480 scale)."""
        return (self.visible_pixels >= min_pixels).all(axis=1)

    def present(self, min_pixels: int = 200) -> np.ndarray:
        """(T,) True where at least one leg shows ``min_pixels`` valid pixels: the user is in view (the
        other leg may be hidden behind it)."""
        return (self.visible_pixels >= min_pixels).any(axis=1)


def render(session: Any, max_frames: int | None = None) -> Rendered:
    """Render (once) a session's frames, to score several configurations on the same data."""
    n = len(session) if max_frames is None else min(len(session), max_frames)
    t0 = time.perf_counter()
    frames, visible = [], np.zeros((n, 2), dtype=np.int64)
    for i in range(n):
        fr = session.frame(i)
        mm = session.depth_mm(i)
        valid = mm > 0
        visible[i] = [np.count_nonzero(valid & (fr.side == 0)), np.count_nonzero(valid & (fr.side == 1))]
        frames.append(mm)
    return Rendered(frames=frames, visible_pixels=visible, seconds=time.perf_counter() - t0)


def _min_pixels(session: Any) -> int:
    intr = session.intrinsics
    return max(20, int(200 * (intr.width * intr.height) / (640 * 480)))


def trackable_frames(session: Any, rendered: Rendered) -> np.ndarray:
    """``(T,)`` frames where both legs are in view (200 valid pixels each at 640x480, scaled to the camera)."""
    return rendered.trackable(min_pixels=_min_pixels(session))


def present_frames(session: Any, rendered: Rendered) -> np.ndarray:
    """``(T,)`` frames where the user is in view (at least one leg with 200 valid pixels, scaled)."""
    return rendered.present(min_pixels=_min_pixels(session))


@dataclass
class PipelineRun:
    """Output of :func:`run_pipeline`: per-frame poses, the detected steps and per-stage times."""

    tracker_cue: str
    poses: list[Any]  # LegPose per frame
    steps: list[Step]
    timing_ms: dict[str, float]  # summed over frames, per STAGES entry
    tracker_ms: list[float]  # per frame
    floors: list[Any] = field(default_factory=list)  # FloorPlane per frame, as the pipeline estimated it
    passes: tuple[Any, ...] = ()  # two passes: the PassTracks merged into ``poses`` (forward, backward per tracker run)


def recording_frames(session: Any, frames: Sequence[np.ndarray]) -> list[SimpleNamespace]:
    """A session's rendered depth images (16UC1) as a recording yields its frames, each with the session's
    CameraInfo (what ``FrameProcessor.learn_structure`` reads)."""
    intr, info = session.intrinsics, SimpleNamespace(**session.camera_info())
    return [SimpleNamespace(stamp=float(session.stamps[i]), data=data, encoding="16UC1", width=intr.width,
                            height=intr.height, step=intr.width * 2, is_bigendian=False, camera_info=info)
            for i, data in enumerate(frames)]


def true_leg_length(session: Any) -> float:
    """The synthetic user's leg length as a clinic measures it (m): the hip joint centre's height above the floor
    standing with straight legs, thigh + shank + the ankle centre's height above the sole."""
    d = session.params.dims
    return float(d.thigh_length + d.shank_length + d.ankle_height)


def run_pipeline(session: Any, rendered: Rendered, *, preset: str = "default", cue: str | None = None, seed: int = 0,
                 max_frames: int | None = None, overrides: dict[str, Any] | None = None,
                 passes: str = "both", leg_length_m: float = 0.0, tracker_runs: int | None = None,
                 roi: dict[str, Any] | None = None) -> PipelineRun:
    """The offline pipeline (``FrameProcessor``) on a session's rendered frames, as ``walker-gait process``
    runs it; tracker ``preset`` with ``overrides`` (``TrackerConfig`` fields) and ``cue``; the segmenter's
    ``RoiConfig`` with ``roi`` (its fields); ``passes``, ``leg_length_m`` and ``tracker_runs`` (None: the default)
    as ``PipelineOptions``' (``forward``: the live graph's one pass)."""
    import dataclasses

    from walker_gait.core.segmentation import RoiConfig, SegmenterConfig
    from walker_gait.core.tracker import preset as tracker_preset
    from walker_gait.pipeline import FrameProcessor, PipelineOptions

    tracker = tracker_preset(preset)
    changes = dict(overrides or {})
    if cue is not None:
        changes["cue"] = cue
    if changes:
        tracker = dataclasses.replace(tracker, **changes)
    segmenter = SegmenterConfig(roi=RoiConfig(**roi)) if roi else None
    proc = FrameProcessor(PipelineOptions(preset=preset, tracker=tracker, seed=seed, write_mcap=False,
                                          write_report=False, passes=passes, leg_length_m=leg_length_m,
                                          segmenter=segmenter,
                                          **({} if tracker_runs is None else {"tracker_runs": tracker_runs})))
    proc.set_camera_info(SimpleNamespace(**session.camera_info()))
    n = len(rendered.frames) if max_frames is None else min(len(rendered.frames), max_frames)
    intr = session.intrinsics
    if passes == "both":  # as process_recording: the walker's structure learned from the recording first
        proc.learn_structure(recording_frames(session, rendered.frames[:n]))
    run = PipelineRun(tracker_cue=tracker.cue, poses=[], steps=[], timing_ms={k: 0.0 for k in STAGES}, tracker_ms=[])
    results = []
    for i in range(n):
        res = proc.process(stamp=float(session.stamps[i]), data=rendered.frames[i], encoding="16UC1",
                           width=intr.width, height=intr.height, step=intr.width * 2, is_bigendian=False)
        if res is not None:
            results.append(res)
    finished = proc.finish()
    for res in results + finished.results:
        for k in STAGES:
            run.timing_ms[k] += res.timings_ms.get(k, 0.0)
        run.tracker_ms.append(res.timings_ms["tracker"])  # the forward pass: what the live tracker spends
        run.poses.append(res.pose)
        run.floors.append(res.floor)
        run.steps.extend(res.steps)
    run.steps.extend(finished.steps)
    run.passes = finished.passes
    return run


def live_bridged(run: PipelineRun, *, hide_below: float) -> tuple[list[Any], np.ndarray]:
    """A one-pass run's poses (``passes="forward"``: the live ``leg_track``) as the live ``leg_tracker`` publishes them
    on ``leg_track_bridged`` (:func:`walker_gait.core.smoothing.live_bridged`), and each frame's delay (s: from its own
    stamp to that of the frame that released it; NaN for frames still held at the end)."""
    from walker_gait.core import smoothing

    out, released = smoothing.live_bridged(run.poses, run.floors, hide_below=hide_below)
    stamps = np.array([float(p.stamp) for p in run.poses] + [math.nan])
    return out, stamps[released] - stamps[:-1]


def evaluate(session: Any, *, preset: str = "default", cue: str | None = None, seed: int = 0,
             max_frames: int | None = None, overrides: dict[str, Any] | None = None,
             rendered: Rendered | None = None, passes: str = "both", leg_length_m: float = 0.0,
             run: PipelineRun | None = None, bridged: bool = False) -> Score:
    """Run the pipeline on ``session`` (a ``walker_gait.synth.Session``) and score it (``passes`` and
    ``leg_length_m`` as ``PipelineOptions``'), or score ``run`` (:func:`run_pipeline`'s, on the same session and
    frames).  ``bridged`` (a one-pass run): the poses as the live ``leg_track_bridged`` has them (:func:`live_bridged`;
    the steps as they were, which the live analyzer reads from ``leg_track``)."""
    from walker_gait.bench.gait import match_steps, session_summaries

    rendered = rendered if rendered is not None else render(session, max_frames)
    if run is None:
        run = run_pipeline(session, rendered, preset=preset, cue=cue, seed=seed, max_frames=max_frames,
                           overrides=overrides, passes=passes, leg_length_m=leg_length_m)
    delay = None
    if bridged:
        from walker_gait.core.tracker import preset as tracker_preset

        hide_below = dataclasses.replace(tracker_preset(preset), **(overrides or {})).hide_below
        poses, delay = live_bridged(run, hide_below=hide_below)
        run = dataclasses.replace(run, poses=poses)
    n = len(run.poses)
    intr = session.intrinsics
    timing, tracker_ms, poses, steps = run.timing_ms, run.tracker_ms, run.poses, run.steps
    score = Score(scenario=session.spec.scenario, preset=preset, cue=run.tracker_cue, frames=n,
                  ms_per_frame={k: v / max(n, 1) for k, v in timing.items()})
    if delay is not None:
        late = delay[np.isfinite(delay) & (delay > 0)]
        score.held_pct = float(np.mean(~np.isfinite(delay) | (delay > 0)) * 100) if n else float("nan")
        score.held_s = (float(np.median(late)), float(late.max())) if late.size else (0.0, 0.0)
    if tracker_ms:
        score.tracker_first_ms = tracker_ms[0]
        score.tracker_ms_after_first = float(np.mean(tracker_ms[1:])) if n > 1 else float("nan")
    # --- joints: frames where both legs are in view
    truth = np.asarray(session.leg_points[:n])
    est = np.stack([p.points for p in poses])
    vis = trackable_frames(session, rendered)[:n]
    err = np.linalg.norm(est - truth, axis=-1)  # T, 2, 5
    swapped = np.linalg.norm(est[:, ::-1] - truth, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        u = intr.fx * truth[..., 0] / truth[..., 2] + intr.cx
        v = intr.fy * truth[..., 1] / truth[..., 2] + intr.cy
    inside = (truth[..., 2] > 0) & (u >= 0) & (u < intr.width) & (v >= 0) & (v < intr.height)  # (T, 2, 5)
    score.in_image_pct = {name: float(np.mean(inside[:, :, k]) * 100) for k, name in enumerate(LEG_POINTS)}
    # frames without an estimate (no user found: NaN points) are all-NaN slices: they count as > 10 cm
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Mean of empty slice", category=RuntimeWarning)
        if vis.any():
            score.joint_err_cm = {name: float(np.nanmean(err[vis][:, :, k]) * 100) for k, name in enumerate(LEG_POINTS)}
            est_angles = np.stack([np.asarray(p.angles, dtype=float) for p in poses])
            score.angle_err_deg, score.angle_bias_deg = angle_errors(est_angles[vis],
                                                                     np.asarray(session.body.angles[:n])[vis])
            score.frames_over_10cm_pct = frames_off_pct(err, vis)
            score.frames_over_10cm_at_walker_pct = frames_off_pct(
                err, vis & at_walker(truth, session.params.mount.floor_plane()))
            lower = slice(1, 5)  # knee..toe: the observable points
            score.swap_frames = int(np.sum(np.nanmean(swapped[vis][:, :, lower], axis=(1, 2)) + 0.05
                                           < np.nanmean(err[vis][:, :, lower], axis=(1, 2))))
        # recovery after the user appears (absent start): from the first frame with both legs in the image and at
        # the walker (the region the tracker measures), and from the first with both legs anywhere in the image
        if not vis.all() and vis.any():
            stamps = np.asarray(session.stamps[:n], dtype=float)
            arrived = vis & at_walker(truth, session.params.mount.floor_plane())
            score.recovery_s = recovery_time(stamps, err, arrived)
            score.recovery_in_image_s = recovery_time(stamps, err, vis)
    # --- steps
    t_end = float(session.stamps[n - 1])
    gt = [s for s in _gt_as_steps(session) if s.stamp <= t_end]
    score.gt_steps, score.detected_steps = len(gt), len(steps)
    pairs, _missed, _extra = match_steps(gt, steps)
    score.matched_steps = len(pairs)
    score.precision = len(pairs) / len(steps) if steps else float("nan")
    score.recall = len(pairs) / len(gt) if gt else float("nan")
    present = present_frames(session, rendered)[:n] & at_walker(truth, session.params.mount.floor_plane())
    in_view = (steps_in_view(np.array([g.stamp for g in gt]), np.asarray(session.stamps[:n]), present,
                             tail_s=IN_VIEW_TAIL_S) if gt else np.zeros(0, bool))
    score.gt_steps_in_view = int(in_view.sum())
    score.matched_in_view = int(sum(1 for t, _ in pairs if in_view[t]))
    score.recall_in_view = score.matched_in_view / score.gt_steps_in_view if score.gt_steps_in_view else float("nan")
    le = np.array([abs(steps[d].step_length - gt[t].step_length) for t, d in pairs
                   if np.isfinite(gt[t].step_length)]) * 100
    we = np.array([abs(steps[d].step_width - gt[t].step_width) for t, d in pairs
                   if np.isfinite(gt[t].step_width)]) * 100
    if le.size:
        score.step_length_err_cm = (float(le.mean()), float(le.std()))
    if we.size:
        score.step_width_err_cm = (float(we.mean()), float(we.std()))
    dt = np.array([abs(steps[d].stamp - gt[t].stamp) for t, d in pairs])
    if dt.size:
        score.hs_timing_median_frames = float(np.median(dt) * session.spec.fps)
    # the cadence of the session summary a clinician reads against the true steps' at the walker (a user walking in
    # from the side takes steps the walker does not measure by design, as for the recall in view)
    true_summary, summary = session_summaries([g for g, v in zip(gt, in_view, strict=True) if v], steps,
                                              checked=passes == "both")
    if math.isfinite(true_summary.cadence) and true_summary.cadence > 0 and math.isfinite(summary.cadence):
        score.cadence_err_pct = float((summary.cadence / true_summary.cadence - 1) * 100)
    return score
