"""Offline two-way tracking: a recording tracked forwards and backwards in time, the two tracks merged frame by frame.

A particle filter run forwards knows only the past.  Where it went wrong (legs exchanged as one passes the
other, a user who walked up from the side found turned, a hidden leg left behind) it stays wrong until the data
pull it back; a second filter run over the same frames *backwards* meets the same stretch from its other end,
with a track that was right there, and usually goes wrong elsewhere, if at all.  Offline, both are available,
so for every frame we keep the estimate the data support better, switching between the two tracks only where
the gain outweighs the jump that the switch puts into the trajectory:

* each pass's estimate (its 23-element state) is scored on each frame by the tracker's own likelihood
  (:meth:`LegTracker.score <walker_gait.core.tracker.LegTracker.score>`: both cues, every segment, the pose
  priors), with one scorer for all passes so that the scores compare;
* a Viterbi path over the passes (:func:`best_path`) maximises the summed scores minus ``switch_cost`` times the
  mean distance between the leg points of the two tracks at every switch: two tracks that agree switch for
  free, an exchange of legs (tracks 30-60 cm apart) is left only for a clearly better explanation of the data;
* where the two tracks' feet agree (within a few cm) they are two estimates of one pose and are averaged
  (:func:`blend_poses`).

Before the merge the backward pass loses the poses it alone gave before it had seen both feet
(:func:`wait_for_both_feet`): run backwards, a track ends at the user's arrival, where the forward tracker has not
started yet for want of a second leg in view.

After the merge, the poses reported bridge each stretch in which a foot was hidden behind the other leg
(:func:`bridge_hidden_legs`): the tracker holds a hidden leg's pose, the real foot rolls off the floor and swings
through; offline, cubic curves in time join where it was last seen to where it is seen again.  Their points and
joint angles are then low-passed at 6 Hz (:func:`lowpass_poses`), as gait laboratories filter marker trajectories
(:func:`reported_poses` does both).  The gait analyzer reads the merged poses as tracked.

The live graph cannot wait for the future and tracks forwards only; ``walker-gait process`` does both passes
unless told ``--passes forward``.  Measured on synthetic sessions with ground truth (DEVELOPERS.md, forty-third
session): heel error and the frames more than 10 cm off fell on every sweep set; see BENCHMARKS.md.

Pure numpy; no ROS.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Protocol, TypeVar

import numpy as np
from numpy.typing import NDArray

from walker_gait.core.pelvis import _runs, moved_pose, place_poses, with_points
from walker_gait.core.types import (
    ANKLE,
    HEEL,
    HIP,
    KNEE,
    TOE,
    CameraIntrinsics,
    EventKind,
    FloorPlane,
    GaitEvent,
    LegPose,
    Step,
    TrackStatus,
)

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]

SWITCH_COST_PER_M = 100.0
"""Log-likelihood units that a switch between two passes costs per metre of mean distance between their leg points
(10 points: hip, knee, ankle, heel, toe of both legs).  A switch between tracks 5 cm apart costs 5, one across
exchanged legs (40 cm) 40.  On synthetic sessions (16 sessions, forty-third session) 20, 100 and 500 gave heel errors
within 0.13 cm of each other, all far better than either pass alone."""

_CHUNK = 2048
"""Frames at a time in :func:`switch_costs` and :func:`identity_flips` (their pairwise arrays stay a few MB)."""

IDENTITY_COST_PER_M = 100.0
"""Log-likelihood units that the merged track pays per metre by which its feet (ankle, heel, toe of both legs, mean
distance) move further from one frame to the next than they would with the later frame's legs exchanged, beyond
:data:`IDENTITY_MARGIN_M` (:func:`identity_flips`): a track whose model legs change places between two frames (a
pass that exchanged its legs as one passed the other, or took them back) pays for the jump (feet 30 cm apart
exchanged, about 20); legs that move as legs do pay nothing.  The passes' scores do not tell exchanged legs apart
(the model's shape is shared by both legs, so the depth data fit both labellings alike); their continuity does.
On the synthetic sweep sets (seventy-fourth session) 100 and 200 gave the same merges, 50 left one exchange."""

IDENTITY_MARGIN_M = 0.05
"""How much further (m) the feet must move than they would with the legs exchanged before the merged track pays
:data:`IDENTITY_COST_PER_M` for the rest: a pass whose feet are both a little off (or both on one real foot) moves
about as far either way, which is no sign of an exchange.  Without it a 2.5 cm difference had the merge exchange a
pass's first 2.6 s back to front (`normal:902` with a lagging walker); 0.03 to 0.08 gave the same merges."""

EXCHANGE_COST = 1.0
"""Log-likelihood units a merged frame pays for taking a pass's legs exchanged: the tracker's own labelling (its
state keeps each hip on its side and the detection assigns legs by the image's sides) stands unless continuity
says otherwise.  A stretch the merge takes exchanged must save more than this per frame: an exchange of feet 30 cm
apart (about 20 units of :data:`IDENTITY_COST_PER_M`) is taken back over up to about 20 frames (0.7 s at 30 Hz);
a pass that ran longer with its legs exchanged keeps them so.  0.5 and 1 gave the same merges on the sweep sets, 2
left one exchange; without it (ties only) two passes that each had one foot wrong were merged with one of them
exchanged for 25 frames (`absent_start:962`, tracker seed 1)."""

AGREE_M = (0.04, 0.10)
"""Mean distance (m) between two passes' feet (ankle, heel, toe of both legs) below which :func:`blend_poses` averages
them with equal weights, and above which it keeps the chosen pass alone (linear between).  On synthetic sessions
(16 sessions, forty-third session) blending took the step length MAE from 1.11 to 0.92 cm and the heel error from
4.85 to 4.50 cm against the Viterbi choice alone; hard thresholds at 5-8 cm did about as well, 12 cm worse."""

CONFIRM_S = 0.25
"""A merged track's step is confirmed by a pass whose own steps (the gait analyzer on that pass's poses alone) hold
one of the same side whose heel strike lies within this many seconds of it ..."""
CONFIRM_M = 0.08
"""... and whose step length is within this many metres of it (:func:`confirm_steps`)."""
CONFIRM_SHARE = 0.75
"""A merged track's step is confirmed when at least this share of the passes (rounded up) confirm it: both of two
passes; three of four (each direction tracked twice, ``PipelineOptions.tracker_runs``; eighty-second session, set C:
277 steps all four passes confirmed were 0.71 cm off on average, the 30 that three did 0.99 cm, the 16 fewer
1.9-8.9 cm)."""
UNCONFIRMED_FACTOR = 0.4
"""Factor on the confidence of a step that a pass does not confirm: a step at confidence 1 falls to 0.4, below the
summaries' spatial cut (``GaitConfig.summary_min_confidence`` 0.5) but above their temporal one (0.25), so its time
still counts towards the cadence while its length and width stay out of the means."""

START_VISIBILITY = 0.5
"""Visible share of a model foot (the tracker's ``show_above``) from which :func:`wait_for_both_feet` counts it as
seen ..."""
START_FRAMES = 1
"""... on average over this many consecutive frames (one: that frame's share alone).  Three, with ``at_once``, is what
a segmenter that joins a leg across the region of interest's side (``RoiConfig.join_edge_parts``) needs: it shows the
far foot of a user walking in sooner, and one frame's share at 0.55 of a model foot beside the one foot in view, or
each model foot seen on that foot at another time, let a backward pass report a leg 15-40 cm off for 5-8 frames
(eighty-fourth session, DEVELOPERS.md); with the segmenter's default those settings cost frames the backward pass
alone tracks well (set A: frames over 10 cm at the walker 0.37 -> 0.55 %)."""

BRIDGE_MAX_S = 1.0
"""Longest gap (s) over which :func:`bridge_hidden_legs` bridges a hidden leg."""
BRIDGE_FIT_FRAMES = 5
"""Frames either side of a gap over which :func:`bridge_hidden_legs` takes the points' velocities (each end's
velocity is the mean over that many frames: one frame's difference carries the tracker's jitter)."""
BRIDGE_POINTS = (1, 2, 3, 4)
"""Points a bridge replaces: knee, ankle, heel and toe (the hip is the pelvis's, tracked through any hiding)."""
BRIDGE_PLANTED_Z = 0.045
"""m: in a floor-aligned frame, a hidden foot whose toe stood at most this high over the floor in the last frame seen
before the stretch, ...  The toe is measured on the shoe's front above the segmentation's floor cut, and under a
trouser hem it reads higher: in `baggy_trousers` trailing feet that stood, moving with the floor, read 3.1-4.2 cm up.
At 3 cm (to the seventy-seventh session) they were left to the curves, heels held low and toes forward; at 4.5 cm 14 of
the 134 planted stretches of the baggy, occlusion and slow sessions of sweep sets C and A are such feet (seventy-eighth
session: set C's heels there 3.18 -> 3.13 cm, toes 2.36 -> 2.33, set A's 3.24 -> 3.23 and 2.51 -> 2.48; 4.5 and 6 cm give
the same figures on set C)."""
BRIDGE_PLANTED_SPEED = 0.5
"""m/s: ... and moved with the floor to within this (over the :data:`BRIDGE_FIT_FRAMES` before), stood on it: its toe
is carried with the floor until it can leave it (:func:`bridge_hidden_legs`).  Over the 166 stretches of sweep sets C
and A (sixty-fifth session) with the toe that low, the 143 whose real toe stood on the floor had their tracked toe
moving 0.12 m/s against it (median; 90th percentile 0.35, at most 0.71), 20 of the other 23 (a landing foot, its
tracked toe lagging the real one by up to 20 cm; a swinging one) 0.6-3.9 m/s.  A foot wrongly taken for planted costs
more than one left to the curves: at 1.0 m/s 0.64 -> 0.67 % of set C's frames at the walker were off by over 10 cm
(at 0.5: 0.61)."""
BRIDGE_FLAT_Z = 0.02
"""m: a seen foot whose heel and toe are both this low stands flat; its toe's velocity is the floor's."""
BRIDGE_FLOOR_S = 0.5
"""s: the floor's velocity through the walker frame at a stretch is the median over the flat feet seen within this of
it (at least :data:`BRIDGE_FLOOR_SAMPLES` of them)."""
BRIDGE_FLOOR_SAMPLES = 5
BRIDGE_LANDING_SPEED_PCT = 95.0
"""Percentile of the seen toes' frame-to-frame speeds that bounds a hidden foot's swing into its landing
(:func:`_landing_bridge`): the landing is put at the earliest frame from which a swing no faster than this reaches
the floor where the foot is seen standing later.  The fastest seen toe (what bounds a toe-off, :data:`_FloorMotion`)
is often one jump of the tracker (6 m/s where the 95th percentile was 2.3) and lands the foot too early.  Heels on
the `lag`, `close` and `fast` probes and the bench's `walker_lag` session (seventy-sixth session, before
:data:`BRIDGE_LANDING_MIN_FLOOR`): the maximum 2.570 / 2.206 / 1.829 / 2.363 cm, the 98th percentile 2.534 / 2.184 /
1.822 / 2.393, the 95th 2.530 / 2.179 / 1.819 / 2.405 (frames over 10 cm at the walker on `lag` 2.22 / 1.98 /
1.98 %)."""
BRIDGE_LANDING_MIN_FLOOR = 0.3
"""m/s: the floor (the walker) moves at least this fast through the walker frame for :func:`_landing_bridge` to
carry a landed foot with it; a walker standing or starting to roll is left to the curves (a foot landing near a
still walker is not carried anywhere, and at a start the floor's velocity, a median over a second, lags the
walker's)."""

LOWPASS_HZ = 6.0
"""Cut-off (Hz) of the zero-phase low-pass over the reported points and angles (:func:`lowpass_poses`): the usual
6 Hz of gait laboratories' marker trajectories (Winter).  On sweep runs (fifty-second session) 4-12 Hz all lowered
the heel and ankle errors; below 5 Hz the toe's take-offs and landings got blunted."""
LOWPASS_ORDER = 2
"""Order of that Butterworth filter (run both ways: fourth-order roll-off, no phase lag)."""
LOWPASS_MIN_FRAMES = 10
"""A stretch of tracked frames shorter than this is not filtered (the filter's padding needs more)."""

PASSES = ("forward", "both")
"""``forward``: one pass, as the live graph; ``both``: forwards and backwards, merged (offline default)."""


class TrackerFrame(Protocol):
    """What a tracking pass needs of a frame (``walker_gait.pipeline.PreparedFrame`` is one)."""

    stamp: float
    intrinsics: CameraIntrinsics
    points: NDArray[np.floating]
    depth_fg: NDArray[np.floating]
    floor: FloorPlane
    no_depth: NDArray[np.bool_] | None


class Tracker(Protocol):
    """The part of :class:`walker_gait.core.tracker.LegTracker` a pass uses."""

    def update(self, *, stamp: float, points: NDArray[np.floating], depth_fg: NDArray[np.floating],
               floor: FloorPlane, no_depth: NDArray[np.bool_] | None = None) -> LegPose: ...

    @property
    def state(self) -> FloatArray | None: ...


class Scorer(Protocol):
    """The part of :class:`walker_gait.core.tracker.LegTracker` that scores states on a frame."""

    def score(self, states: FloatArray, *, points: NDArray[np.floating], depth_fg: NDArray[np.floating],
              floor: FloorPlane, no_depth: NDArray[np.bool_] | None = None,
              rng: np.random.Generator | None = None) -> FloatArray: ...


@dataclass
class PassTrack:
    """One tracking pass over a recording, in recording order whatever the pass's direction."""

    poses: list[LegPose]
    scores: FloatArray  # (T,) log likelihood of the pass's estimate on each frame (-inf: no pose; NaN: not scored)
    tracker_ms: FloatArray  # (T,) the tracker's time per frame
    scoring_ms: FloatArray  # (T,) the scoring's


@dataclass
class MergedTrack:
    """The passes merged frame by frame."""

    poses: list[LegPose]  # the chosen pass's pose per frame, in recording order
    choice: IntArray  # (T,) index of the pass chosen per frame
    scores: FloatArray  # (T, K) each pass's log likelihood per frame (-inf: no pose)
    exchanged: NDArray[np.bool_] | None = None  # (T,) the chosen pass's legs taken exchanged (swap_sides); None: none

    def share(self, k: int) -> float:
        """Fraction of the frames taken from pass ``k``."""
        return float(np.mean(self.choice == k)) if self.choice.size else math.nan


def track_pass(make_tracker: Callable[[TrackerFrame], Tracker], frames: Sequence[TrackerFrame], *,
               backward: bool = False, score: Callable[[int, TrackerFrame, FloatArray | None], float] | None = None,
               progress: Callable[[Iterable[int]], Iterable[int]] | None = None) -> PassTrack:
    """Track ``frames`` (stamps increasing), forwards or backwards in time.

    ``make_tracker(frame)`` gives the tracker for the first frame and a fresh one wherever the calibration
    (``frame.intrinsics``) changes, as the forward pipeline restarts its tracker.  Backwards, the tracker sees the
    stamps negated (they must increase for it) and the poses get their frame's stamp back; the tracker's motion
    model (constant velocity per frame) does not mind the direction.  ``score(i, frame, state)``, if given, scores
    the tracker's state after frame ``i`` (see :func:`score_passes`).  ``progress`` wraps the loop over frame
    indices (e.g. a tqdm bar).
    """
    n = len(frames)
    poses: list[LegPose | None] = [None] * n
    scores = np.full(n, np.nan)
    tracker_ms = np.zeros(n)
    scoring_ms = np.zeros(n)
    tracker: Tracker | None = None
    intrinsics: CameraIntrinsics | None = None
    order: Iterable[int] = range(n - 1, -1, -1) if backward else range(n)
    for i in progress(order) if progress is not None else order:
        f = frames[i]
        if tracker is None or f.intrinsics != intrinsics:
            tracker, intrinsics = make_tracker(f), f.intrinsics
        stamp = float(f.stamp)
        t0 = time.perf_counter()
        pose = tracker.update(stamp=-stamp if backward else stamp, points=f.points, depth_fg=f.depth_fg,
                              floor=f.floor, no_depth=f.no_depth)
        t1 = time.perf_counter()
        poses[i] = dataclasses.replace(pose, stamp=stamp) if backward else pose
        if score is not None:
            scores[i] = score(i, f, tracker.state)
        tracker_ms[i] = (t1 - t0) * 1e3
        scoring_ms[i] = (time.perf_counter() - t1) * 1e3
    return PassTrack(poses=[p for p in poses if p is not None], scores=scores, tracker_ms=tracker_ms,
                     scoring_ms=scoring_ms)


def score_passes(scorer: Scorer, frame: TrackerFrame, states: Sequence[FloatArray | None], *,
                 rng: np.random.Generator) -> FloatArray:
    """``(K,)`` log likelihood of each pass's state on ``frame`` (``-inf`` where a pass has no pose)."""
    out = np.full(len(states), -np.inf)
    have = [k for k, s in enumerate(states) if s is not None]
    if have:
        x = np.stack([states[k] for k in have])  # type: ignore[misc]
        out[have] = scorer.score(x, points=frame.points, depth_fg=frame.depth_fg, floor=frame.floor,
                                 no_depth=frame.no_depth, rng=rng)
    return out


def switch_costs(points: FloatArray, *, switch_cost: float = SWITCH_COST_PER_M) -> FloatArray:
    """``(T, K, K)``: ``switch_cost`` times the mean distance between passes ``i`` and ``j``'s points ``(T, K, ..., 3)``
    on each frame (``[t, i, j]``; 0 where they are not both there), what :func:`best_path` charges a switch."""
    p = np.asarray(points, dtype=np.float64)
    p = p.reshape(*p.shape[:2], -1, 3)
    out = np.zeros((p.shape[0], p.shape[1], p.shape[1]))
    for a in range(0, p.shape[0], _CHUNK):  # frames at a time: an hour's recording needs no gigabyte
        q = p[a:a + _CHUNK]
        d = np.linalg.norm(q[:, :, None] - q[:, None, :], axis=-1)  # (t, K, K, N)
        ok = np.isfinite(d)
        out[a:a + _CHUNK] = np.where(ok, d, 0.0).sum(axis=-1) / np.maximum(ok.sum(axis=-1), 1) * switch_cost
    return out


def best_path(scores: FloatArray, points: FloatArray, *, switch_cost: float = SWITCH_COST_PER_M,
              transition: FloatArray | None = None) -> IntArray:
    """The pass per frame that maximises the summed ``scores`` less the switches' costs (Viterbi).

    Args:
        scores: ``(T, K)`` log likelihood of pass ``k``'s estimate on frame ``t``; ``-inf`` (or NaN) where the pass
            has none, which is never chosen while another pass has one.
        points: ``(T, K, ..., 3)`` the passes' leg points (any frame); NaN where a pass has none.
        switch_cost: cost per metre of the mean distance between the two passes' points on the frame where the
            path switches (0 where they are not both there).
        transition: ``(T, K, K)`` a further cost of going from pass ``i`` on frame ``t - 1`` to pass ``j`` on frame
            ``t`` (``[t, i, j]``; row 0 unused), staying included; ``None``: none.

    Ties go to the lower pass index (the forward pass first), so equal passes give pass 0 throughout.
    """
    s = np.asarray(scores, dtype=np.float64)
    if s.ndim != 2:
        raise ValueError(f"scores must be (T, K), got {s.shape}")
    t_n, k_n = s.shape
    if t_n == 0:
        return np.zeros(0, dtype=np.intp)
    p = np.asarray(points, dtype=np.float64)
    if p.shape[:2] != (t_n, k_n) or p.shape[-1] != 3:
        raise ValueError(f"points must be (T, K, ..., 3) with (T, K) = {s.shape}, got {p.shape}")
    # a pass without a pose: far below any real score, but finite so that the path stays defined
    floor_score = np.nanmin(np.where(np.isfinite(s), s, np.nan)) if np.isfinite(s).any() else 0.0
    s = np.where(np.isfinite(s), s, floor_score - 1e6)
    jump = switch_costs(p, switch_cost=switch_cost)
    if transition is not None:
        extra = np.asarray(transition, dtype=np.float64)
        if extra.shape != (t_n, k_n, k_n):
            raise ValueError(f"transition must be (T, K, K) = {(t_n, k_n, k_n)}, got {extra.shape}")
        jump = jump + np.where(np.isfinite(extra), extra, 0.0)
    acc = s[0].copy()
    back = np.zeros((t_n, k_n), dtype=np.intp)
    for t in range(1, t_n):
        total = acc[:, None] - jump[t]  # from -> to
        back[t] = np.argmax(total, axis=0)  # first maximum: the lower index on ties
        acc = total[back[t], np.arange(k_n)] + s[t]
    path = np.zeros(t_n, dtype=np.intp)
    path[-1] = int(np.argmax(acc))
    for t in range(t_n - 1, 0, -1):
        path[t - 1] = back[t, path[t]]
    return path


def wait_for_both_feet(track: PassTrack, *, other: PassTrack | None = None,
                       min_visibility: float = START_VISIBILITY, frames: int = START_FRAMES,
                       at_once: bool = False) -> PassTrack:
    """``track`` without the poses it gave, at the start (recording order) of each of its tracks, before both model
    feet had been seen: a foot is seen from the first frame where its visibility, and its average with that of the
    track's next ``frames - 1`` frames (those the track has), reach ``min_visibility``; with ``at_once`` both feet
    must be seen so on the same frame (each seen at another time is not enough: a model foot moved onto the one foot
    in view is seen there too, the other model foot off over nothing).  The frames before that get no pose
    (``NO_USER``, score ``-inf``), except where ``other`` (the other pass) has a pose, which leaves the merge both
    to choose from.

    The pipeline applies it to the backward pass.  Run forwards, the tracker starts a track only once its foreground
    shows two legs (``TrackerConfig.single_leg_wait_s``); run backwards, it meets a user's arrival at the *end* of
    its track and carries a leg it no longer sees (behind the other one, or still outside the region of interest)
    until its lost tests end the track.  On synthetic sweeps (forty-eighth session) the frames that only the
    backward pass covered were 29.7 cm off on average, 78 % of them by more than 10 cm, most of them a user walking
    in from the side with both model legs on the one foot in view.  Poses without a visibility estimate count as
    seen.
    """
    n = len(track.poses)
    if other is not None and len(other.poses) != n:
        raise ValueError(f"the passes cover {n} and {len(other.poses)} frames")
    if frames < 1:
        raise ValueError(f"frames must be >= 1, got {frames}")
    has = np.array([_has_points(p) for p in track.poses], dtype=bool)
    feet = np.array([np.ones(2) if p.visibility is None else np.asarray(p.visibility, dtype=np.float64)[:, 2]
                     for p in track.poses]).reshape(n, 2)
    keep = np.ones(n, dtype=bool)
    for start, stop in _runs(has):  # each track: frames start .. stop - 1
        vis = feet[start:stop]
        csum = np.concatenate([np.zeros((1, 2)), np.cumsum(vis, axis=0)])
        ends = np.minimum(np.arange(len(vis)) + frames, len(vis))
        ahead = (csum[ends] - csum[:-1]) / (ends - np.arange(len(vis)))[:, None]  # mean over the window ahead
        seen = (ahead >= min_visibility) & (vis >= min_visibility)
        if at_once:
            both = seen.all(axis=1)
            first = int(np.argmax(both)) if both.any() else len(vis)
        else:
            first = max((int(np.argmax(seen[:, leg])) if seen[:, leg].any() else len(vis)) for leg in (0, 1))
        keep[start:start + first] = False
    if other is not None:
        keep |= np.array([_has_points(p) for p in other.poses], dtype=bool) & has
    if keep.all():
        return track
    poses = [p if keep[t] else LegPose.no_user(p.stamp) for t, p in enumerate(track.poses)]
    return dataclasses.replace(track, poses=poses, scores=np.where(keep, track.scores, -np.inf))


def swap_sides(pose: LegPose) -> LegPose:
    """``pose`` with its legs' identities exchanged below the hips: each hip keeps its place and takes the other
    leg's knee, ankle, heel and toe, with that leg's joint angles, radii, visibility and shoe measures (the thigh's
    segment runs from the hip kept to the knee taken).  The tracker's state keeps each hip on its own side, so a
    tracker that took one leg for the other crossed its legs below the hips; this uncrosses them.  Applied twice
    it gives ``pose`` back.  A pose without all its points is returned as it is."""
    if not _has_points(pose):
        return pose
    pts = _swapped_points(pose.points)

    def flipped(a: FloatArray | None) -> FloatArray | None:
        return None if a is None else np.array(np.asarray(a)[::-1], copy=True)

    segs = pose.segments
    if segs is not None and np.shape(segs) == (2, 3, 2, 3):
        segs = np.array(np.asarray(segs, dtype=np.float64)[::-1], copy=True)
        segs[:, 0, 0] = pts[:, HIP]
    angles = np.asarray(pose.angles, dtype=np.float64)
    half = angles.shape[-1] // 2
    angles = np.concatenate([angles[half:], angles[:half]]) if angles.shape[-1] == 2 * half else angles.copy()
    return dataclasses.replace(pose, points=pts, angles=angles, segments=segs, radii=flipped(pose.radii),
                               visibility=flipped(pose.visibility), shoe_rise=flipped(pose.shoe_rise),
                               shoe_turn=flipped(pose.shoe_turn), heel_tracked=flipped(pose.heel_tracked),
                               ankle_tracked=flipped(pose.ankle_tracked), toe_tracked=flipped(pose.toe_tracked))


def _swapped_points(points: FloatArray) -> FloatArray:
    """``(..., 2, 5, 3)`` leg points with the legs exchanged below the hips, as :func:`swap_sides` does."""
    out = np.array(points, dtype=np.float64, copy=True)
    out[..., KNEE:, :] = np.asarray(points)[..., ::-1, KNEE:, :]
    return out


def identity_flips(points: FloatArray, twin: Sequence[int], *, margin_m: float = 0.0) -> FloatArray:
    """``(T, C, C)``: for candidates ``(T, C, 2, 5, 3)`` whose candidate ``twin[j]`` is candidate ``j`` with its
    legs exchanged, how much further (m; mean over the ankle, heel and toe of both legs) the feet move from
    candidate ``i`` on frame ``t - 1`` to candidate ``j`` on frame ``t`` than to ``twin[j]``, less ``margin_m``
    (``[t, i, j]``; 0 where that is not positive, on frame 0, and where points are missing).  Legs that change
    places between two frames move further than they would exchanged back; legs that move as legs do, less."""
    p = np.asarray(points, dtype=np.float64)[:, :, :, ANKLE:TOE + 1]
    t_n, c_n = p.shape[:2]
    out = np.zeros((t_n, c_n, c_n))
    if t_n < 2:
        return out
    twin_idx = np.asarray(twin, dtype=np.intp)
    for a in range(1, t_n, _CHUNK):
        b = min(a + _CHUNK, t_n)
        prev, cur = p[a - 1:b - 1, :, None], p[a:b, None, :]  # (t, C, 1, ...), (t, 1, C, ...)
        own = np.linalg.norm(cur - prev, axis=-1).mean(axis=(-2, -1))  # (t, from, to)
        excess = own - own[:, :, twin_idx] - margin_m
        out[a:b] = np.where(np.isfinite(excess) & (excess > 0), excess, 0.0)
    return out


def merge_passes(passes: Sequence[PassTrack], *, switch_cost: float = SWITCH_COST_PER_M,
                 agree_m: tuple[float, float] = AGREE_M, identity_cost: float = IDENTITY_COST_PER_M,
                 identity_margin_m: float = IDENTITY_MARGIN_M, exchange_cost: float = EXCHANGE_COST) -> MergedTrack:
    """Each frame's pose from the pass :func:`best_path` chooses by the passes' ``scores``, blended with the other
    passes whose feet agree with it (:func:`blend_poses`).

    With ``identity_cost`` > 0 the path chooses among each pass's estimate as it is and with its legs exchanged
    below the hips (:func:`swap_sides`; both score alike, the exchanged one ``exchange_cost`` lower), and pays
    ``identity_cost`` per metre by which the chosen feet jump further between two frames than they would with the
    legs exchanged, less ``identity_margin_m`` (:func:`identity_flips`): where a pass exchanged its legs for a
    while, the merged track takes them back, so that its left leg stays the leg it was.  A change of labelling
    pays ``switch_cost`` as a switch between passes does (the legs' distance from the legs exchanged): with it
    free the merges were worse (set A's `occlusion:131` kept its exchange, 16 frames), so a pass is taken
    exchanged mostly where that brings it onto the other pass, rarely against its own jump alone.  Before, the
    merge followed a pass with exchanged legs wherever it explained the data better (10-14 frames in 3 of the 64
    sessions of the synthetic sweep sets C and A; seventy-fourth session, DEVELOPERS.md).  Each other pass is
    blended in the labelling whose feet lie nearer the chosen ones.  ``identity_cost`` 0: the passes as tracked.
    """
    if not passes:
        raise ValueError("merge_passes needs at least one pass")
    n = len(passes[0].poses)
    k_n = len(passes)
    if any(len(p.poses) != n or p.scores.shape != (n,) for p in passes):
        raise ValueError("the passes must cover the same frames, each with a score per frame")
    scores = np.stack([p.scores for p in passes], axis=1) if n else np.zeros((0, k_n))
    pts = np.stack([np.stack([pose.points for pose in p.poses]) if n else np.zeros((0, 2, 5, 3))
                    for p in passes], axis=1)
    lo_hi = (agree_m[0], agree_m[1])
    if identity_cost <= 0 or n == 0:
        choice = best_path(scores, pts, switch_cost=switch_cost)
        poses = [blend_poses([p.poses[t] for p in passes], int(k), agree_m=lo_hi) for t, k in enumerate(choice)]
        return MergedTrack(poses=poses, choice=choice, scores=scores)
    cand = np.concatenate([pts, _swapped_points(pts)], axis=1)  # (T, 2K, 2, 5, 3): as tracked, then exchanged
    twin = [*range(k_n, 2 * k_n), *range(k_n)]
    cand_scores = np.concatenate([scores, scores - exchange_cost], axis=1)
    path = best_path(cand_scores, cand, switch_cost=switch_cost,
                     transition=identity_cost * identity_flips(cand, twin, margin_m=identity_margin_m))
    choice = path % k_n
    exchanged = path >= k_n
    feet = cand[:, :, :, ANKLE:TOE + 1]
    poses: list[LegPose] = []
    for t, c in enumerate(path):
        chosen = int(choice[t])
        group: list[LegPose] = []
        for k, p in enumerate(passes):
            if k == chosen:
                group.append(swap_sides(p.poses[t]) if exchanged[t] else p.poses[t])
                continue
            d_as, d_ex = (float(np.linalg.norm(feet[t, j] - feet[t, int(c)], axis=-1).mean()) for j in (k, k + k_n))
            group.append(swap_sides(p.poses[t]) if d_ex < d_as else p.poses[t])
        poses.append(blend_poses(group, chosen, agree_m=lo_hi))
    return MergedTrack(poses=poses, choice=choice, scores=scores, exchanged=exchanged)


def blend_poses(poses: Sequence[LegPose], chosen: int, *, agree_m: tuple[float, float] = AGREE_M) -> LegPose:
    """``poses[chosen]`` averaged with the other poses of the same frame whose feet agree with it.

    Two passes that both found the legs are two estimates of one pose: where their feet (ankle, heel and toe of
    both legs) lie within ``agree_m[0]`` (mean distance, m) of each other they are averaged with equal weights;
    the other pass's weight falls to 0 at ``agree_m[1]``, so a pose that is another mode (a leg left behind, legs
    exchanged) is not mixed in, and the merged trajectory has no jump where the distance crosses a threshold.
    Points, joint angles, segments, radii, visibility and the shoes' turns are averaged (a turn is measured from its
    pass's foot: averaged with the feet, the turned feet are the average of the passes' turned ones); status,
    confidence and the rest are the chosen pose's.
    """
    lo, hi = agree_m
    base = poses[chosen]
    feet = base.points[:, 2:5]
    if not np.all(np.isfinite(feet)):
        return base
    weights = np.zeros(len(poses))
    weights[chosen] = 1.0
    for k, other in enumerate(poses):
        if k == chosen or not np.all(np.isfinite(other.points)) or other.angles.shape != base.angles.shape:
            continue
        d = float(np.linalg.norm(other.points[:, 2:5] - feet, axis=-1).mean())
        weights[k] = float(np.clip((hi - d) / (hi - lo), 0.0, 1.0)) if hi > lo else float(d <= lo)
    weights[weights < 1e-9] = 0.0
    if weights.sum() <= 1.0:
        return base
    w = weights / weights.sum()
    used = [k for k in range(len(poses)) if w[k] > 0]

    def mix(attr: str) -> NDArray[np.float64] | None:
        arrays = [getattr(poses[k], attr) for k in used]
        if (any(a is None for a in arrays) or len({np.shape(a) for a in arrays}) != 1
                or not all(np.all(np.isfinite(a)) for a in arrays)):
            return getattr(base, attr)
        return sum(w[k] * np.asarray(a, dtype=np.float64) for k, a in zip(used, arrays))  # type: ignore[return-value]

    return dataclasses.replace(base, points=mix("points"), angles=mix("angles"), segments=mix("segments"),
                               radii=mix("radii"), visibility=mix("visibility"), shoe_turn=mix("shoe_turn"))


def _has_points(pose: LegPose) -> bool:
    """The pose has all ten leg points, finite."""
    return pose.points is not None and np.shape(pose.points) == (2, 5, 3) and bool(np.all(np.isfinite(pose.points)))


def _feet_hidden(pose: LegPose, hide_below: float) -> NDArray[np.bool_]:
    """``(2,)``: which of the pose's feet are seen less than ``hide_below`` (their visibility); none without one.  Both
    in a held pose (the tracker coasting through a dropout or a blanked view: ``DEGRADED`` at confidence 0, its last
    pose repeated), which observed nothing: the legs went on meanwhile (a user ahead of a lagging walker, the view
    blanked for half a second at a time), and a held foot's standstill is no measure of the floor's motion."""
    if pose.status == TrackStatus.DEGRADED and pose.confidence == 0.0:
        return np.ones(2, dtype=bool)
    if pose.visibility is None:
        return np.zeros(2, dtype=bool)
    return np.asarray(pose.visibility, dtype=np.float64)[:, 2] < hide_below


def _with_leg_points(pose: LegPose, leg: int, new: FloatArray) -> LegPose:
    """``pose`` with leg ``leg``'s ``BRIDGE_POINTS`` at ``new`` (:func:`~walker_gait.core.pelvis.with_points`); its
    shoe's measured rise and turn are gone with the tracked foot they were measured along."""
    pts = np.array(pose.points, dtype=np.float64, copy=True)
    pts[leg, np.array(BRIDGE_POINTS)] = new
    out = with_points(pose, pts)
    for name in ("shoe_rise", "shoe_turn"):
        measured = getattr(out, name)
        if measured is not None:
            measured = np.array(measured, dtype=np.float64, copy=True)
            measured[leg] = np.nan
            out = dataclasses.replace(out, **{name: measured})
    return out


def bridge_hidden_legs(poses: Sequence[LegPose], *, hide_below: float, max_gap_s: float = BRIDGE_MAX_S,
                       fit_frames: int = BRIDGE_FIT_FRAMES, floor_frame: bool = False) -> list[LegPose]:
    """``poses`` (a merged track, in recording order) with each stretch in which a foot was hidden bridged.

    A foot seen less than ``hide_below`` (the tracker's ``hide_below``) is out of the tracker's likelihood, which
    holds its pose; the real foot meanwhile rolls off the floor, which carries it back through the walker frame,
    and swings through unseen: in the merged track a hidden foot's heel was 10.6 cm off on average, 5.2 cm ahead of
    the real one (ten sweep runs, DEVELOPERS.md, fifty-second session).  A held pose (the tracker coasting) has
    both feet hidden (:func:`_feet_hidden`).  Offline both ends of the stretch are known: where the leg was last
    seen and how it moved then, where it is seen again and how it moves there.
    Inside the stretch its knee, ankle, heel and toe (``BRIDGE_POINTS``) follow cubic Hermite curves in time from
    the last frame before to the first frame after it, each end's velocity the mean over ``fit_frames`` frames
    outside the stretch: the spline gap fill of marker-based motion capture, with both ends' velocities.  A
    stretch is bridged only when it lasts at most ``max_gap_s`` and the frames ``fit_frames`` either side of it
    have the foot seen and finite points (one track, no restart in between); or, with ``floor_frame``, when the foot
    stood on the floor when last seen (below) and is seen again for fewer frames before it is out of sight again (a
    trailing foot under a hem shows at its toe-off for a frame or three), the far end's tangent then over the frames
    seen (none for one).  The leg's segments move with its
    points (the thigh's and the calf's ends to the knee and ankle, the foot's by the heel's and the toe's
    displacement); joint angles, radii, visibility, status and confidence stay the tracker's.  ``poses`` is not
    modified.

    With ``floor_frame`` (the poses in a floor-aligned frame: z up, the floor at z = 0) a foot that stood on the
    floor when last seen (:data:`BRIDGE_PLANTED_Z`, :data:`BRIDGE_PLANTED_SPEED`) is bridged as a walking foot moves
    (:func:`_planted_bridge`): the trailing foot hidden behind the leading leg from its heel-off on keeps its toe on
    the floor where the frames before put it (:func:`_anchored_shoe`) and rolls over it, where two flat ends' curves
    held it flat and let its toe slide forward.

    A foot last seen swinging and seen again standing on the floor (a user close to the camera landing it below
    the image, the floor carrying it back into view) lands on the track the floor carried it along
    (:func:`_landing_bridge`), where the curves between a swinging end and a standing one cut the corner.
    """
    if fit_frames < 1:
        raise ValueError(f"fit_frames must be >= 1, got {fit_frames}")
    n = len(poses)
    out = list(poses)
    if max_gap_s <= 0 or n < 2 * fit_frames + 3:
        return out
    ok = np.array([_has_points(p) for p in poses])
    hidden = np.array([_feet_hidden(p, hide_below) for p in poses]).reshape(n, 2) & ok[:, None]
    stamps = np.array([float(p.stamp) for p in poses])
    idx = np.array(BRIDGE_POINTS)
    k = fit_frames
    floor = _FloorMotion.of(poses, ~hidden & ok[:, None], stamps) if floor_frame else None
    for leg in (0, 1):
        seen = ok & ~hidden[:, leg]
        t = 1
        while t < n:
            if not (hidden[t, leg] and seen[t - 1]):
                t += 1
                continue
            a = t
            while t < n and hidden[t, leg]:
                t += 1
            lo, hi = a - 1, t  # the last frame seen before the stretch, the first one after it
            if lo - k < 0 or hi >= n or not (seen[lo - k:lo + 1].all() and seen[hi]):
                continue
            ka = 0  # frames seen after ``hi`` for its tangent: ``k``, fewer where the foot is out of sight again
            while ka < k and hi + ka + 1 < n and seen[hi + ka + 1]:
                ka += 1
            brief = ka < k  # seen again only briefly: bridged only as planted, once out of sight again
            if brief and (floor is None or hi + ka + 1 >= n):
                continue
            span = stamps[hi] - stamps[lo]
            dt0, dt1 = stamps[lo] - stamps[lo - k], stamps[hi + ka] - stamps[hi]
            if not (0.0 < span <= max_gap_s and dt0 > 0.0 and (dt1 > 0.0 or ka == 0)):
                continue
            p0, p1 = poses[lo].points[leg, idx], poses[hi].points[leg, idx]
            m0 = span * (p0 - poses[lo - k].points[leg, idx]) / dt0  # end tangents, scaled to the stretch
            m1 = span * (poses[hi + ka].points[leg, idx] - p1) / dt1 if ka else np.zeros_like(p1)
            curve = np.stack([_hermite((stamps[i] - stamps[lo]) / span, p0, m0, p1, m1) for i in range(a, hi)])
            if floor is not None:
                near = floor.velocity(float(stamps[lo]), float(stamps[hi]))
                before = _anchored_shoe(poses[lo].points[leg], np.stack([poses[j].points[leg, TOE]
                                                                         for j in range(lo - k, lo + 1)]),
                                        stamps[lo - k:lo + 1], near)
                planted = _planted_bridge(curve, before, poses[hi].points[leg], stamps[lo:hi + 1],
                                          v0=m0[-1] / span, v1=m1[-1] / span, floor=floor, near=near)
                if brief and planted is curve:
                    continue
                curve = planted if planted is not curve else _landing_bridge(
                    curve, poses[lo].points[leg], poses[hi].points[leg], stamps[lo:hi + 1], v0=m0 / span,
                    v1=m1 / span, floor=floor, near=near)
            for i in range(a, hi):
                out[i] = _with_leg_points(out[i], leg, curve[i - a])
    return out


def _hermite(u: float, p0: FloatArray, m0: FloatArray, p1: FloatArray, m1: FloatArray) -> FloatArray:
    """The cubic Hermite curve from ``p0`` (tangent ``m0``) at ``u`` = 0 to ``p1`` (tangent ``m1``) at 1."""
    h00, h10 = 2 * u**3 - 3 * u**2 + 1, u**3 - 2 * u**2 + u
    h01, h11 = -2 * u**3 + 3 * u**2, u**3 - u**2
    return h00 * p0 + h10 * m0 + h01 * p1 + h11 * m1


def _hermite_speed(p0: FloatArray, m0: FloatArray, p1: FloatArray, m1: FloatArray, duration: float) -> float:
    """Fastest horizontal speed (m/s) along :func:`_hermite` run over ``duration`` s (tangents scaled to it)."""
    u = np.linspace(0.0, 1.0, 21)[:, None]
    vel = ((6 * u**2 - 6 * u) * p0 + (3 * u**2 - 4 * u + 1) * m0 + (6 * u - 6 * u**2) * p1
           + (3 * u**2 - 2 * u) * m1) / duration
    return float(np.max(np.hypot(vel[:, 0], vel[:, 1])))


@dataclass(frozen=True)
class _FloorMotion:
    """How the floor and the feet move through a floor-aligned frame over a merged track, from the feet seen."""

    times: FloatArray  # (F,) s: when the flat feet's velocities were taken
    velocities: FloatArray  # (F, 2) m/s: their toes' velocities, the floor's there
    toe_speed: float  # m/s: the fastest a seen toe moved from one frame to the next (inf: none seen)
    landing_speed: float  # m/s: the BRIDGE_LANDING_SPEED_PCT-th percentile of those speeds (inf: none seen)

    @staticmethod
    def of(poses: Sequence[LegPose], seen: NDArray[np.bool_], stamps: FloatArray) -> _FloorMotion:
        """``seen`` ``(n, 2)``: which feet are seen with finite points."""
        times, vel, speeds = [], [], []
        for i in range(1, len(poses)):
            for leg in (0, 1):
                if not (seen[i, leg] and seen[i - 1, leg] and stamps[i] > stamps[i - 1]):
                    continue
                step = poses[i].points[leg, TOE, :2] - poses[i - 1].points[leg, TOE, :2]
                speeds.append(float(np.hypot(*step)) / (stamps[i] - stamps[i - 1]))
                if i + 1 < len(poses) and seen[i + 1, leg] and stamps[i + 1] > stamps[i - 1] \
                        and max(poses[i].points[leg, HEEL, 2], poses[i].points[leg, TOE, 2]) < BRIDGE_FLAT_Z:
                    times.append(float(stamps[i]))
                    vel.append((poses[i + 1].points[leg, TOE, :2] - poses[i - 1].points[leg, TOE, :2])
                               / (stamps[i + 1] - stamps[i - 1]))
        return _FloorMotion(times=np.array(times, dtype=np.float64), velocities=np.array(vel).reshape(-1, 2),
                            toe_speed=max(speeds) if speeds else math.inf,
                            landing_speed=(float(np.percentile(speeds, BRIDGE_LANDING_SPEED_PCT)) if speeds
                                           else math.inf))

    def rolling_velocity(self) -> FloatArray | None:
        """``(2,)`` m/s: the floor's velocity over the recording while the walker rolls (the median over the flat
        feet seen moving at least :data:`BRIDGE_LANDING_MIN_FLOOR`; None: too few of them)."""
        moving = np.hypot(self.velocities[:, 0], self.velocities[:, 1]) >= BRIDGE_LANDING_MIN_FLOOR
        if int(moving.sum()) < BRIDGE_FLOOR_SAMPLES:
            return None
        return np.asarray(np.median(self.velocities[moving], axis=0), dtype=np.float64)

    def velocity(self, start: float, end: float) -> FloatArray | None:
        """``(2,)`` m/s: the floor's velocity around the times ``start``-``end`` (None: too few flat feet seen
        there)."""
        near = (self.times >= start - BRIDGE_FLOOR_S) & (self.times <= end + BRIDGE_FLOOR_S)
        if int(near.sum()) < BRIDGE_FLOOR_SAMPLES:
            return None
        return np.asarray(np.median(self.velocities[near], axis=0), dtype=np.float64)


def _stands(toe: FloatArray, toe_velocity: FloatArray, floor_velocity: FloatArray) -> bool:
    """A foot whose ``toe`` (floor-aligned frame) is at most :data:`BRIDGE_PLANTED_Z` up and moves (``toe_velocity``,
    m/s) with the floor (``floor_velocity``, ``(2,)``) to within :data:`BRIDGE_PLANTED_SPEED` stands on it."""
    return bool(toe[2] <= BRIDGE_PLANTED_Z
                and float(np.hypot(*(toe_velocity[:2] - floor_velocity))) <= BRIDGE_PLANTED_SPEED)


def _anchored_shoe(before: FloatArray, toes: FloatArray, stamps: FloatArray, near: FloatArray | None) -> FloatArray:
    """``before`` ``(5, 3)`` (the last frame seen before a stretch, floor-aligned frame) with its shoe put where the
    frames before it put the toe on the floor: the toe at the median of the ``toes`` ``(k + 1, 3)`` of the frames at
    ``stamps`` (the last one ``before``'s) that stood at most :data:`BRIDGE_PLANTED_Z` up, each carried to the last
    frame by the floor's velocity ``near`` (``(2,)`` m/s), and the heel moved with it (the foot keeps its length and
    pitch; the ankle, which the calf places, stays).  As given where ``before``'s own toe stood higher (no planted foot:
    the rule for which stretch :func:`_planted_bridge` takes is its own), where ``near`` is None or where fewer than
    two of the toes stood.

    A foot going out of view behind the leading leg or under a trouser hem is measured worst in its last frame seen:
    what is left of the shoe's front lags, and the heel placed behind it with it (the toes of the hidden heel-up feet
    of sweep set B stood 3-4.5 cm off, and the stretch's heel error followed them); the frames before, where the foot
    stood in full view, agree on where the floor holds it (eightieth session: sets C / A / B / D, heels 3.190 / 3.512 /
    3.039 / 3.225 -> 3.134 / 3.469 / 2.952 / 3.168 cm, toes 2.272 / 2.711 / 2.262 / 2.270 -> 2.161 / 2.589 / 2.139 /
    2.170, ankles 0.006-0.012 worse; live, ``leg_track_bridged``, heels 0.025-0.053 and toes 0.10-0.13 better)."""
    if near is None or not before[TOE, 2] <= BRIDGE_PLANTED_Z:
        return before
    toes = np.asarray(toes, dtype=np.float64)
    standing = toes[:, 2] <= BRIDGE_PLANTED_Z
    if int(standing.sum()) < 2:
        return before
    carry = (float(stamps[-1]) - np.asarray(stamps, dtype=np.float64)[standing])[:, None]
    carried = toes[standing] + carry * np.array([near[0], near[1], 0.0])
    out = np.array(before, dtype=np.float64, copy=True)
    toe = np.median(carried, axis=0)
    out[HEEL] += toe - out[TOE]
    out[TOE] = toe
    return out


def _planted_bridge(curve: FloatArray, before: FloatArray, after: FloatArray, stamps: FloatArray, *,
                    v0: FloatArray, v1: FloatArray, floor: _FloorMotion, near: FloatArray | None) -> FloatArray:
    """``curve`` ``(m, 4, 3)`` (a stretch's Hermite knee, ankle, heel and toe; floor-aligned frame) with a foot that
    stood on the floor when last seen (``before``: that frame's ``(5, 3)`` points, ``v0`` its toe's velocity over
    the frames before) bridged as a walking foot moves; ``after`` the points seen after the stretch, ``v1`` that
    toe's velocity; ``stamps`` the ``m + 2`` frames' times from ``lo``'s to ``hi``'s; ``near`` the floor's velocity
    around the stretch (``floor.velocity`` over ``stamps``' ends; None: too few flat feet seen there).

    The trailing foot under a trouser hem or behind the leading leg is hidden from its heel-off to its early swing
    (``baggy_trousers``, ``occlusion``): its toe stays on the floor, which carries it back through the walker frame,
    while the heel rises.  Here the toe moves with the floor (its velocity around the stretch, :class:`_FloorMotion`)
    until the latest time from which a swing at the fastest speed any toe was seen to move this recording can bring
    it to where it is seen again (then a Hermite curve from the floor's velocity to its own); while the toe is on the
    floor the foot, rigid, turns about it (along its heading, in the vertical plane) so that its ankle stays the
    calf's length from the bridged knee (the knee hardly moves through the walker frame in late stance); in the swing
    the ankle's and the heel's offsets from the toe go linearly from there to those seen after.  A foot whose toe was
    not on the floor, or moved faster than :data:`BRIDGE_PLANTED_SPEED` against it, or a floor with too few flat feet
    seen near the stretch, or a foot without a length, keeps ``curve``."""
    toe0 = before[TOE]
    if near is None or not _stands(toe0, v0, near):
        return curve
    heading = before[TOE] - before[HEEL]
    heading[2] = 0.0
    length = float(np.linalg.norm(heading))
    calf = float(np.linalg.norm(before[KNEE] - before[ANKLE]))
    if length < 0.05 or calf < 0.05:
        return curve
    heading /= length
    up = np.array([0.0, 0.0, 1.0])
    across = np.cross(up, heading)
    basis = np.stack([heading, up])  # the foot's vertical plane: along its heading, up

    floor_v = np.array([near[0], near[1], 0.0])
    t_lo, t_hi = float(stamps[0]), float(stamps[-1])
    off_at = t_lo  # latest toe-off from which a swing no faster than any seen reaches the toe seen after
    for j in range(len(stamps) - 2, -1, -1):
        d = t_hi - float(stamps[j])
        off = toe0 + floor_v * (float(stamps[j]) - t_lo)
        if _hermite_speed(off, d * floor_v, after[TOE], d * v1, d) <= floor.toe_speed + 1e-6:  # + rounding
            off_at = float(stamps[j])
            break
    off_toe = toe0 + floor_v * (off_at - t_lo)
    swing = t_hi - off_at

    ankle0, heel0 = basis @ (before[ANKLE] - toe0), basis @ (before[HEEL] - toe0)  # in the plane, from the toe
    ankle_across, heel_across = (before[ANKLE] - toe0) @ across, (before[HEEL] - toe0) @ across
    radius = float(np.hypot(*ankle0))
    turn = 0.0  # the foot's turn about the toe from its pose in ``before`` (+: heel up)
    rel_off = np.stack([before[ANKLE] - toe0, before[HEEL] - toe0])
    rel_after = np.stack([after[ANKLE] - after[TOE], after[HEEL] - after[TOE]])
    out = curve.copy()
    for m in range(curve.shape[0]):
        t = float(stamps[m + 1])
        if t <= off_at:
            toe = toe0 + floor_v * (t - t_lo)
            turn = _turn_to_reach(ankle0, basis @ (curve[m, 0] - toe), calf, radius, turn, heel0, toe[2])
            ankle = toe + _turned(ankle0, turn) @ basis + ankle_across * across
            heel = toe + _turned(heel0, turn) @ basis + heel_across * across
            rel_off = np.stack([ankle - toe, heel - toe])
        else:
            u = (t - off_at) / swing
            toe = _hermite(u, off_toe, swing * floor_v, after[TOE], swing * v1)
            ankle, heel = toe + (1.0 - u) * rel_off + u * rel_after
        out[m, 1:] = np.stack([ankle, heel, toe])
    return out


def _landing_bridge(curve: FloatArray, before: FloatArray, after: FloatArray, stamps: FloatArray, *,
                    v0: FloatArray, v1: FloatArray, floor: _FloorMotion, near: FloatArray | None) -> FloatArray:
    """``curve`` ``(m, 4, 3)`` (a stretch's Hermite knee, ankle, heel and toe; floor-aligned frame) with a foot
    that was swinging when last seen (``before``: that frame's ``(5, 3)`` points) and stands on the floor when seen
    again (``after``) bridged as a landing: it swings on, lands, and the floor carries it to where it is seen.
    ``v0`` / ``v1``: ``(4, 3)`` velocities of the knee, ankle, heel and toe over the frames before / after the
    stretch; ``stamps`` the ``m + 2`` frames' times from ``lo``'s to ``hi``'s; ``near`` as :func:`_planted_bridge`'s.

    A user walking close to the camera, or ahead of a walker that lags, lands the swinging foot below the image's
    bottom edge: hidden from its swing until the floor has carried it back into view, where the tracker holds it
    where it left the view and the curves between a swinging end and a standing one cut the corner (the bench's
    `walker_lag` session: heels 20-40 cm off for half a second).  Here the foot seen standing after the stretch
    (its toe at most :data:`BRIDGE_PLANTED_Z` up and moving with the floor to within :data:`BRIDGE_PLANTED_SPEED`;
    a heel already rising there is turned down about the toe, the foot flat) is carried back in time at the
    floor's velocity (:class:`_FloorMotion`; where no flat foot was seen near the stretch, the foot's own velocity
    after it, if that is within :data:`BRIDGE_PLANTED_SPEED` of the floor's while the walker rolls,
    :meth:`_FloorMotion.rolling_velocity`) to the earliest frame at which a Hermite swing of the heel from
    where it was last seen, at its velocity then, can land on that track no faster than
    :data:`BRIDGE_LANDING_SPEED_PCT` of the seen toes' speeds; from the landing on the foot stands flat on the
    floor's track, before it the heel follows that swing with the ankle and toe turning linearly from their offsets
    last seen to the flat foot's.  A foot that stood when last seen (:func:`_planted_bridge`'s), one not seen
    standing after, a floor slower than :data:`BRIDGE_LANDING_MIN_FLOOR`, or no landing inside the stretch keeps
    ``curve``; the knee always does."""
    toe_v0, toe_v1 = v0[-1], v1[-1]
    v = near
    if v is None:  # no flat foot seen near: the foot's own velocity after, if the floor moves so while it moves
        rolling = floor.rolling_velocity()
        if rolling is None or float(np.hypot(*(toe_v1[:2] - rolling))) > BRIDGE_PLANTED_SPEED:
            return curve
        v = np.asarray(toe_v1[:2], dtype=np.float64)
    if not _stands(after[TOE], toe_v1, v):
        return curve
    if _stands(before[TOE], toe_v0, v):
        return curve  # standing when last seen too
    if float(np.hypot(*v)) < BRIDGE_LANDING_MIN_FLOOR:
        return curve
    floor_v = np.array([v[0], v[1], 0.0])
    t_lo, t_hi = float(stamps[0]), float(stamps[-1])
    flat = np.stack([after[ANKLE], after[HEEL], after[TOE]])  # the foot seen after: ankle, heel, toe
    back = flat[1] - flat[2]
    length = float(np.hypot(back[0], back[1]))
    if length > 0.05 and back[2] > 0.0:  # its heel already rising: turned down about the toe, the foot flat
        up = np.array([0.0, 0.0, 1.0])
        heading = -np.array([back[0], back[1], 0.0]) / length
        basis, across = np.stack([heading, up]), np.cross(up, heading)
        heel = basis @ back
        turn = -math.atan2(heel[1], -heel[0])
        flat = flat[2] + np.stack([_turned(basis @ r, turn) @ basis + (r @ across) * across for r in flat - flat[2]])
    heel0, heel_v0 = before[HEEL], v0[2]
    land_at = t_hi
    for j in range(1, len(stamps) - 1):  # the earliest landing a swing no faster than the bound reaches
        d = float(stamps[j]) - t_lo
        landing = flat[1] + floor_v * (float(stamps[j]) - t_hi)
        if _hermite_speed(heel0, d * heel_v0, landing, d * floor_v, d) <= floor.landing_speed + 1e-6:
            land_at = float(stamps[j])
            break
    if land_at >= t_hi:
        return curve
    swing = land_at - t_lo
    landing = flat[1] + floor_v * (land_at - t_hi)
    rel0 = np.stack([before[ANKLE], before[HEEL], before[TOE]]) - heel0  # from the heel
    rel1 = flat - flat[1]
    out = curve.copy()
    for m in range(curve.shape[0]):
        t = float(stamps[m + 1])
        if t >= land_at:
            out[m, 1:] = flat + floor_v * (t - t_hi)
        else:
            u = (t - t_lo) / swing
            out[m, 1:] = _hermite(u, heel0, swing * heel_v0, landing, swing * floor_v) + (1.0 - u) * rel0 + u * rel1
    return out


def _turned(vec: FloatArray, turn: float) -> FloatArray:
    """``vec`` ``(2,)`` (along the heading, up) turned about the toe by ``turn`` rad (+: a point behind it goes up)."""
    c, s = math.cos(turn), math.sin(turn)
    return np.array([vec[0] * c + vec[1] * s, -vec[0] * s + vec[1] * c])


def _turn_to_reach(ankle: FloatArray, knee: FloatArray, calf: float, radius: float, previous: float,
                   heel: FloatArray, toe_z: float) -> float:
    """The turn (rad, :func:`_turned`) about the toe that puts ``ankle`` (in the foot's plane, from the toe) the
    ``calf``'s length from ``knee``: of the two, the one nearest ``previous``; the nearest reach where the knee is
    out of it; never with the heel below the floor."""
    dist = float(np.hypot(*knee))
    if dist < 1e-6:
        return previous
    toward = knee / dist
    along = (dist * dist + radius * radius - calf * calf) / (2.0 * dist)
    along = min(max(along, -radius), radius)
    side = math.sqrt(max(radius * radius - along * along, 0.0))
    normal = np.array([-toward[1], toward[0]])
    base = math.atan2(ankle[1], ankle[0])
    turns = []
    for sign in (1.0, -1.0):
        target = along * toward + sign * side * normal
        turns.append(math.remainder(base - math.atan2(target[1], target[0]), math.tau))
    turn = min(turns, key=lambda x: abs(x - previous))
    if toe_z + _turned(heel, turn)[1] < 0.0:  # the heel through the floor: the foot flat on it instead
        rho = float(np.hypot(*heel))
        flat = math.atan2(heel[1], heel[0]) - (math.pi - math.asin(min(max(-toe_z / rho, -1.0), 1.0)))
        turn = math.remainder(flat, math.tau)
    return turn


LIVE_BRIDGE_HISTORY_S = BRIDGE_MAX_S + BRIDGE_FLOOR_S
"""s: :class:`LiveBridge` keeps the frames it has released for this long before the first one it still holds: the
floor's velocity at a stretch is read over :data:`BRIDGE_FLOOR_S` either side of it."""


@dataclass
class _Held:
    """One frame in a :class:`LiveBridge`."""

    pose: LegPose  # as pushed (camera frame)
    walker: LegPose  # in its floor's walker frame (no points without a valid floor)
    transform: tuple[FloatArray, FloatArray] | None  # camera -> walker frame; None without a valid floor
    item: object
    hidden: NDArray[np.bool_]  # (2,) the foot hidden (a pose with points and a floor only)
    seen: NDArray[np.bool_]  # (2,) the foot seen, with points and a floor
    decided: NDArray[np.bool_]  # (2,) the hidden foot's stretch bridged (its points in ``final``)
    final: LegPose | None = None  # walker frame, with its bridged legs' points


class LiveBridge:
    """:func:`bridge_hidden_legs` frame by frame, for the live graph: each stretch in which a foot is hidden is
    bridged as soon as it can be, and every frame is released in order, unchanged or bridged.

    A frame in which neither foot is hidden (:func:`_feet_hidden`, ``hide_below`` as the tracker's) comes out at once
    when nothing before it is held.  From the first frame in which a foot is hidden the frames are held until that
    stretch is decided: it is bridged once the foot has been seen again for ``fit_frames`` + 1 frames (about 0.17 s at
    30 Hz), or for fewer and then out of sight again, within ``max_gap_s`` of its last frame seen before it, with :func:`bridge_hidden_legs` (``floor_frame``: in
    each frame's walker frame, a planted foot rolled over its toe) over the frames kept, those since
    :data:`LIVE_BRIDGE_HISTORY_S` before; it is left as tracked where the offline bridge leaves it (a stretch longer
    than ``max_gap_s``, ends not seen for ``fit_frames`` frames either side, a frame without points or floor in
    them, a foot seen again only briefly that did not stand when last seen).  So a stretch's poses come out at most ``max_gap_s`` + ``fit_frames`` frames after their time, as
    bridged as offline, the floor's velocity and the fastest toe taken over the frames kept rather than the whole
    recording.  ``push`` returns what it releases; ``flush`` the frames still held, as tracked (the recording
    ended: no frame will decide them).  Pure bookkeeping around :func:`bridge_hidden_legs`; no ROS."""

    def __init__(self, *, hide_below: float, max_gap_s: float = BRIDGE_MAX_S, fit_frames: int = BRIDGE_FIT_FRAMES,
                 history_s: float = LIVE_BRIDGE_HISTORY_S) -> None:
        if not (math.isfinite(max_gap_s) and max_gap_s > 0):
            raise ValueError(f"max_gap_s must be a finite number > 0, got {max_gap_s}")
        if fit_frames < 1:
            raise ValueError(f"fit_frames must be >= 1, got {fit_frames}")
        if not (math.isfinite(history_s) and history_s >= max_gap_s):
            raise ValueError(f"history_s must be finite and >= max_gap_s ({max_gap_s}), got {history_s}")
        self.hide_below = float(hide_below)
        self.max_gap_s = float(max_gap_s)
        self.fit_frames = int(fit_frames)
        self.history_s = float(history_s)
        self._frames: list[_Held] = []
        self._next = 0  # index in _frames of the first frame not released

    @property
    def held(self) -> int:
        """Frames pushed and not released yet."""
        return len(self._frames) - self._next

    def reset(self) -> None:
        """Forget every frame, held ones included (a new track: new intrinsics, a restarted stream)."""
        self._frames.clear()
        self._next = 0

    def push(self, pose: LegPose, floor: FloorPlane, item: object = None) -> list[tuple[LegPose, object]]:
        """Take the next frame's ``pose`` (camera frame) and ``floor``; return the frames released by it, in order,
        each as ``(pose, item)``: its pose as pushed, or bridged (camera frame), and the ``item`` pushed with it (a
        message header, an index).  A stamp not after the last frame's starts over: the frames still held come out
        as tracked first."""
        out: list[tuple[LegPose, object]] = []
        if self._frames and not float(pose.stamp) > float(self._frames[-1].pose.stamp):
            out = self.flush()
        transform = None
        walker = LegPose.no_user(pose.stamp)
        if floor.usable:
            transform = floor.walker_transform()
            walker = moved_pose(pose, *transform)
        ok = transform is not None and _has_points(walker)
        hidden = _feet_hidden(pose, self.hide_below) & ok
        self._frames.append(_Held(pose=pose, walker=walker, transform=transform, item=item, hidden=hidden,
                                  seen=~hidden & ok, decided=np.zeros(2, dtype=bool)))
        out.extend(self._release())
        self._trim()
        return out

    def flush(self) -> list[tuple[LegPose, object]]:
        """Release every frame still held, as tracked where its stretch was not bridged yet, and start over."""
        out = [self._emit(f) for f in self._frames[self._next:]]
        self.reset()
        return out

    def _emit(self, f: _Held) -> tuple[LegPose, object]:
        if f.final is None or f.transform is None:
            return f.pose, f.item
        rot, t = f.transform
        return moved_pose(f.final, rot.T, -rot.T @ t), f.item  # its heel_tracked the pushed pose's, never moved

    def _release(self) -> list[tuple[LegPose, object]]:
        out: list[tuple[LegPose, object]] = []
        bridged: list[LegPose] | None = None  # bridge_hidden_legs over the frames kept, at most once a push
        while self._next < len(self._frames):
            f = self._frames[self._next]
            for leg in (0, 1):
                if not f.hidden[leg] or f.decided[leg]:
                    continue
                stretch = self._resolve(self._next, leg)
                if stretch is None:
                    return out
                if stretch is False:
                    continue
                a, hi = stretch
                if bridged is None:
                    bridged = bridge_hidden_legs([h.walker for h in self._frames], hide_below=self.hide_below,
                                                 max_gap_s=self.max_gap_s, fit_frames=self.fit_frames,
                                                 floor_frame=True)
                idx = np.array(BRIDGE_POINTS)
                for m in range(a, hi):
                    h = self._frames[m]
                    if not np.array_equal(bridged[m].points[leg, idx], h.walker.points[leg, idx]):  # else as tracked
                        h.final = _with_leg_points(h.final if h.final is not None else h.walker, leg,
                                                   bridged[m].points[leg, idx])
                    h.decided[leg] = True
            out.append(self._emit(f))
            self._next += 1
        return out

    def _resolve(self, i: int, leg: int) -> tuple[int, int] | bool | None:
        """The stretch in which ``leg`` is hidden at frame ``i``: ``(first hidden frame, first frame after)`` when it
        is bridged, False when it is left as tracked, None while undecided (as :func:`bridge_hidden_legs` decides)."""
        fr, k = self._frames, self.fit_frames
        a = i
        while a > 0 and fr[a - 1].hidden[leg]:
            a -= 1
        lo = a - 1
        if lo - k < 0 or not all(fr[j].seen[leg] for j in range(lo - k, lo + 1)):
            return False
        t_lo = float(fr[lo].pose.stamp)
        hi = i + 1
        while hi < len(fr) and fr[hi].hidden[leg]:
            hi += 1
        if hi == len(fr):  # hidden to the newest frame
            return False if float(fr[-1].pose.stamp) - t_lo > self.max_gap_s else None
        if not (float(fr[hi].pose.stamp) - t_lo <= self.max_gap_s and fr[hi].seen[leg]):
            return False
        run = 1  # frames seen from ``hi`` on
        while run <= k and hi + run < len(fr) and fr[hi + run].seen[leg]:
            run += 1
        # seen for ``k`` + 1 frames, or fewer and out of sight again (bridged if the foot stood: the offline rule)
        return None if hi + run == len(fr) and run <= k else (a, hi)

    def _trim(self) -> None:
        """Drop released frames older than ``history_s`` before the first frame held (or the newest one).  The first
        frame held is its stretch's first (the frames of a stretch come out together, or each left as tracked for a
        reason that holds for the whole stretch), so the ``fit_frames`` seen before it are
        ``fit_frames`` / rate before it: kept, as ``history_s`` >= ``max_gap_s``."""
        ref = float(self._frames[min(self._next, len(self._frames) - 1)].pose.stamp)
        drop = 0
        while drop < self._next and float(self._frames[drop].pose.stamp) < ref - self.history_s:
            drop += 1
        if drop:
            del self._frames[:drop]
            self._next -= drop


def live_bridged(poses: Sequence[LegPose], floors: Sequence[FloorPlane], *, hide_below: float,
                 max_gap_s: float = BRIDGE_MAX_S) -> tuple[list[LegPose], IntArray]:
    """A recording's one-pass poses as the live ``leg_tracker`` publishes them on ``leg_track_bridged``: a
    :class:`LiveBridge` fed them frame by frame (``floors``: one per pose), then flushed.  Also returns, per frame, the
    index of the frame whose arrival released it (``len(poses)``: held to the end, released by the flush)."""
    if len(floors) != len(poses):
        raise ValueError(f"{len(floors)} floors for {len(poses)} poses")
    bridge = LiveBridge(hide_below=hide_below, max_gap_s=max_gap_s)
    out: list[LegPose] = list(poses)
    released = np.full(len(poses), len(poses), dtype=np.intp)
    for i, (pose, floor) in enumerate(zip(poses, floors)):
        for shown, j in bridge.push(pose, floor, i):
            out[int(j)], released[int(j)] = shown, i  # type: ignore[call-overload]
    for shown, j in bridge.flush():
        out[int(j)] = shown  # type: ignore[call-overload]
    return out, released


def butter2(cutoff_hz: float, fs: float) -> tuple[FloatArray, FloatArray]:
    """Second-order Butterworth low-pass ``(b, a)`` at ``cutoff_hz`` for samples at ``fs`` (bilinear transform,
    pre-warped: what ``scipy.signal.butter(2, cutoff_hz / (fs / 2))`` gives, without importing ``scipy.signal``,
    which takes half a second)."""
    if not 0.0 < cutoff_hz < 0.5 * fs:
        raise ValueError(f"the cut-off must lie between 0 and half the sampling rate ({0.5 * fs:g} Hz), "
                         f"got {cutoff_hz}")
    k = math.tan(math.pi * cutoff_hz / fs)
    norm = 1.0 / (1.0 + math.sqrt(2.0) * k + k * k)
    b0 = k * k * norm
    return (np.array([b0, 2.0 * b0, b0]),
            np.array([1.0, 2.0 * (k * k - 1.0) * norm, (1.0 - math.sqrt(2.0) * k + k * k) * norm]))


def _lfilter2(b: FloatArray, a: FloatArray, x: FloatArray) -> FloatArray:
    """Second-order IIR filter along axis 0 (direct form II transposed), started in its steady state for ``x[0]``
    (as ``scipy.signal.lfilter`` with ``lfilter_zi``; unit gain at 0 Hz, as a low-pass has)."""
    y = np.empty_like(x)
    z0 = (1.0 - b[0]) * x[0]
    z1 = (b[2] - a[2]) * x[0]
    for i in range(x.shape[0]):
        y[i] = b[0] * x[i] + z0
        z0 = b[1] * x[i] - a[1] * y[i] + z1
        z1 = b[2] * x[i] - a[2] * y[i]
    return y


def filtfilt2(b: FloatArray, a: FloatArray, x: FloatArray) -> FloatArray:
    """``x`` filtered forwards and backwards along axis 0 by the second-order ``(b, a)`` (zero phase), its ends
    extended by odd reflection over 9 samples: ``scipy.signal.filtfilt(b, a, x, axis=0)``'s defaults.  ``x`` needs
    more than 9 samples."""
    pad = 9
    x = np.asarray(x, dtype=np.float64)
    if x.shape[0] <= pad:
        raise ValueError(f"filtfilt2 needs more than {pad} samples, got {x.shape[0]}")
    ext = np.concatenate([2.0 * x[:1] - x[pad:0:-1], x, 2.0 * x[-1:] - x[-2:-pad - 2:-1]])
    y = _lfilter2(b, a, ext)
    y = _lfilter2(b, a, y[::-1])[::-1]
    return y[pad:-pad]


def lowpass_poses(poses: Sequence[LegPose], *, cutoff_hz: float = LOWPASS_HZ,
                  order: int = LOWPASS_ORDER) -> list[LegPose]:
    """``poses`` (a track, in recording order) with their points and joint angles low-passed over time.

    A Butterworth filter of ``order`` with its cut-off at ``cutoff_hz``, run forwards and backwards (zero phase: no
    lag, the order doubled), as gait laboratories filter marker trajectories (6 Hz: Winter, *Biomechanics and Motor
    Control of Human Movement*).  It runs over each stretch of consecutive tracked frames (finite points, status
    TRACKING or DEGRADED, no interval over twice the stretch's median) at that stretch's median frame rate; a stretch
    too short for the filter (``LOWPASS_MIN_FRAMES``) or sampled at less than 2.5 times the cut-off stays as it is.
    Segments move with the points (:func:`~walker_gait.core.pelvis.with_points`); radii, visibility, status and
    confidence stay.  ``poses`` is not modified.  Second order only (:func:`butter2`, :func:`filtfilt2`).
    """
    if order != 2:
        raise ValueError(f"order must be 2 (a second-order Butterworth, run both ways), got {order}")
    n = len(poses)
    out = list(poses)
    if cutoff_hz <= 0 or n < LOWPASS_MIN_FRAMES:
        return out
    tracked = np.array([p.status in (TrackStatus.TRACKING, TrackStatus.DEGRADED) and _has_points(p) for p in poses])
    stamps = np.array([float(p.stamp) for p in poses])
    t = 0
    while t < n:
        if not tracked[t]:
            t += 1
            continue
        a = t
        while t < n and tracked[t]:
            t += 1
        runs = [(a, t)]
        dt = np.diff(stamps[a:t])
        if dt.size and np.all(dt > 0):
            cut = np.nonzero(dt > 2.0 * np.median(dt))[0]  # a dropped stretch of frames splits the run
            bounds = [a, *(a + int(c) + 1 for c in cut), t]
            runs = list(zip(bounds[:-1], bounds[1:]))
        elif dt.size:
            continue  # stamps not increasing: left as they are
        for lo, hi in runs:
            if hi - lo < LOWPASS_MIN_FRAMES:
                continue
            fs = 1.0 / float(np.median(np.diff(stamps[lo:hi])))
            if fs < 2.5 * cutoff_hz:
                continue
            b, a_ = butter2(cutoff_hz, fs)
            pts = filtfilt2(b, a_, np.stack([poses[i].points for i in range(lo, hi)]))
            ang = np.stack([np.asarray(poses[i].angles, dtype=np.float64) for i in range(lo, hi)])
            if ang.ndim == 2 and np.all(np.isfinite(ang)):
                ang = filtfilt2(b, a_, ang)
            else:
                ang = None
            for j, i in enumerate(range(lo, hi)):
                out[i] = with_points(poses[i], pts[j], angles=None if ang is None else ang[j])
    return out


def reported_poses(poses: Sequence[LegPose], *, hide_below: float, max_gap_s: float = BRIDGE_MAX_S,
                   lowpass_hz: float = LOWPASS_HZ, floors: Sequence[FloorPlane] | None = None,
                   pelvis_window_s: float = 0.0, mounting: str = "facing_user",
                   leg_length_m: float | None = None) -> list[LegPose]:
    """The poses an offline run reports for its merged track ``poses``: hidden feet bridged over stretches up to
    ``max_gap_s`` long (:func:`bridge_hidden_legs`; 0: not bridged), then points and angles low-passed at
    ``lowpass_hz`` (:func:`lowpass_poses`; 0: not filtered), then, with ``floors``, the out-of-view pelvis placed
    over the ankles averaged over ``pelvis_window_s`` and the hips, knees and joint angles re-solved with the knees
    and feet held, each track with one length of each segment, its median, the knees and heels moved to it
    (:func:`walker_gait.core.pelvis.place_poses`, ``mounting`` as the tracker's, the thighs and calves of a measured
    ``leg_length_m`` if given; 0: as tracked).
    With ``floors`` (one per pose) all work in each frame's walker frame (:meth:`FloorPlane.walker_transform`), which
    stays with the walker while its camera rocks on the wheels: in the camera frame that rocking is motion of the
    legs a low-pass would take out; frames without a valid floor are reported as tracked.  The gait analyzer reads
    the merged poses themselves."""
    out = list(poses)
    place = pelvis_window_s > 0 and floors is not None
    if max_gap_s <= 0 and lowpass_hz <= 0 and not place:
        return out
    frames: list[tuple[FloatArray, FloatArray] | None] = [None] * len(out)
    if floors is not None:
        if len(floors) != len(out):
            raise ValueError(f"{len(floors)} floors for {len(out)} poses")
        for i, (pose, floor) in enumerate(zip(out, floors)):
            if floor.usable:
                frames[i] = floor.walker_transform()
                out[i] = moved_pose(pose, *frames[i])
            else:  # no walker frame to work in: left out of both, reported as tracked
                out[i] = LegPose.no_user(pose.stamp)
    before = list(out)
    if max_gap_s > 0:
        out = bridge_hidden_legs(out, hide_below=hide_below, max_gap_s=max_gap_s, floor_frame=floors is not None)
    if lowpass_hz > 0:
        out = lowpass_poses(out, cutoff_hz=lowpass_hz)
    if floors is None:
        return out
    if place:
        out = place_poses(out, mounting=mounting, window_s=pelvis_window_s, leg_length_m=leg_length_m)
    shown = []
    for pose, first, done, wt in zip(poses, before, out, frames):
        if wt is None or done is first:
            shown.append(pose)  # untouched (both return an untouched pose as given): the tracker's own, bit for bit
        else:
            rot, t = wt
            shown.append(moved_pose(done, rot.T, -(rot.T @ t)))
    return shown


def confirm_steps(steps: Sequence[Step], per_pass: Sequence[Sequence[Step]], *, within_s: float = CONFIRM_S,
                  within_m: float = CONFIRM_M, factor: float = UNCONFIRMED_FACTOR,
                  share: float = CONFIRM_SHARE) -> list[Step]:
    """``steps`` (the gait analyzer's on the merged poses) with the confidence of each step that fewer than ``share``
    of the passes (rounded up: both of two, three of four) confirm multiplied by ``factor``.

    ``per_pass[k]``: the steps the gait analyzer finds on pass ``k``'s poses alone.  A pass confirms a step when it
    has a step of the same side whose heel strike lies within ``within_s`` of it and whose length differs by at most
    ``within_m``.  Two trackings that went wrong differently rarely agree on a wrong step: where one of them does not
    see the step, or sees it elsewhere, the merged step is a guess between them (synthetic sweeps, forty-fourth
    session: such steps were 5 cm off on average, the confirmed ones 0.9 cm; every step off by more than 10 cm and
    every step that was not there were among them)."""
    if not 0.0 <= factor <= 1.0:
        raise ValueError(f"factor must be in [0, 1], got {factor}")
    if not 0.0 < share <= 1.0:
        raise ValueError(f"share must be in (0, 1], got {share}")
    needed = math.ceil(share * len(per_pass) - 1e-9)
    out = []
    for s in steps:
        confirmed = sum(
            any(int(o.side) == int(s.side) and abs(o.stamp - s.stamp) <= within_s
                and (abs(o.step_length - s.step_length) <= within_m
                     or not (math.isfinite(o.step_length) or math.isfinite(s.step_length)))
                for o in steps_k)
            for steps_k in per_pass) >= needed
        out.append(s if confirmed else dataclasses.replace(s, confidence=s.confidence * factor))
    return out


def refine_event_times(events: Sequence[GaitEvent], steps: Sequence[Step], per_pass: Sequence[Sequence[GaitEvent]], *,
                       within_s: float = CONFIRM_S,
                       kinds: tuple[EventKind, ...] = (EventKind.HEEL_STRIKE, EventKind.TOE_OFF)
                       ) -> tuple[list[GaitEvent], list[Step]]:
    """Events of ``kinds`` timed as the median of the merged track's event and each pass's own (``per_pass[k]``: the
    gait analyzer's events on pass ``k``'s poses alone), where every pass has one of the same foot and kind within
    ``within_s``; the steps' heel strikes and their temporal figures (step, stride, swing, stance, single- and
    double-support time) follow the events they were measured from.

    Each analysis times an event from a noisy foot trajectory, now and then a few frames off (a pass that lags the
    landing foot); the median of the three estimates (the merged track's, partly an average of the other two) keeps
    the scatter and drops the outlier.  Synthetic sweeps (sets C, B, E, D, tracker seeds 0 / 1, forty-fourth session),
    against the merged track's own events: median |heel-strike error| 0.93-1.06 -> 0.86-0.95 frames, |toe-off
    error| 0.37-0.45 -> 0.31-0.41 frames, every run better in both; the double-support bias (median error, two
    heel-strike-to-toe-off intervals) -0.65 to -1.55 -> -0.46 to -1.52 frames, six runs of eight better, one equal.  The mean
    instead of the median timed heel strikes a little better (0.80-0.94) but let outliers in and lengthened the
    double-support bias.  An event without a mate in some pass keeps its time, and so does every time measured from
    it."""
    moved: dict[tuple[int, int], tuple[FloatArray, FloatArray]] = {}
    out_events: list[GaitEvent] = []
    for e in events:
        mates = (_mates(e.stamp, per_pass, within_s=within_s, same=lambda o, e=e: o.side == e.side and o.kind == e.kind)
                 if e.kind in kinds else None)
        if mates:
            e = dataclasses.replace(e, stamp=float(np.median([e.stamp, *(o.stamp for o in mates)])))
        out_events.append(e)
    for kind in EventKind:
        for side in (0, 1):
            pairs = [(a.stamp, b.stamp) for a, b in zip(events, out_events) if int(a.side) == side and a.kind == kind]
            moved[(side, int(kind))] = (np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs]))

    def at(side: int, kind: EventKind, t: float) -> float:
        """The refined time of the event of ``side`` and ``kind`` at ``t`` (``t`` itself when there is none)."""
        old, new = moved[(side, int(kind))]
        if not math.isfinite(t) or old.size == 0:
            return t
        i = int(np.argmin(np.abs(old - t)))
        return float(new[i]) if abs(old[i] - t) <= 1e-6 and new[i] != old[i] else t

    hs, to = EventKind.HEEL_STRIKE, EventKind.TOE_OFF
    out_steps = []
    for st in steps:
        a = int(st.side)
        b = 1 - a
        t1 = st.stamp
        t1n = at(a, hs, t1)
        t_b = t1 - st.step_time  # the previous opposite heel strike (NaN: unknown)
        t_a0 = t1 - st.stride_time  # the previous heel strike of this foot
        to_a = t1 - st.swing_time  # this foot's toe off
        if math.isfinite(st.stance_time) and math.isfinite(t_a0):
            to_a = t_a0 + st.stance_time
        to_b = t_b - st.single_support_time  # the other foot's toe off inside the step
        refs = ((a, hs, t1), (b, hs, t_b), (a, hs, t_a0), (a, to, to_a), (a, to, t1 - st.swing_time), (b, to, to_b))
        if all(at(side, kind, t) == t or not math.isfinite(t) for side, kind, t in refs):
            out_steps.append(st)  # none of its events moved
            continue
        stance = at(a, to, to_a) - at(a, hs, t_a0)
        single = at(b, hs, t_b) - at(b, to, to_b)
        double = (at(b, to, to_b) - at(a, hs, t_a0)) + (at(a, to, to_a) - at(b, hs, t_b))
        out_steps.append(dataclasses.replace(
            st, stamp=t1n, step_time=t1n - at(b, hs, t_b), stride_time=t1n - at(a, hs, t_a0),
            swing_time=t1n - at(a, to, t1 - st.swing_time),
            stance_time=stance if math.isfinite(st.stance_time) else st.stance_time,
            single_support_time=single if math.isfinite(st.single_support_time) else st.single_support_time,
            double_support_time=double if math.isfinite(st.double_support_time) else st.double_support_time))
    return out_events, out_steps


def refine_step_lengths(steps: Sequence[Step], per_pass: Sequence[Sequence[Step]], *,
                        within_s: float = CONFIRM_S) -> list[Step]:
    """``steps`` (the gait analyzer's on the merged poses) with each step's length as the median of its own and each
    pass's (``per_pass[k]``: the analyzer's steps on pass ``k``'s poses alone), where every pass has a step of the
    same side whose heel strike lies within ``within_s`` of it.

    The merged track switches between the passes frame by frame, and a step whose landing or trailing foot each pass
    held somewhere else (a foot hidden, or out of the image below its edge) can come out of the merged poses further
    off than from either pass: the brisk walk's third step of a probe read -0.7 cm on the merged poses, 51.5 and 57.2
    from the passes alone (true 60.5).  The median of the three keeps the merged step where the passes bracket it and
    drops the outlier, as :func:`refine_event_times` does for the events' times (eight sweep runs and 24 probes
    re-analysed, seventy-fifth session: step length MAE better or equal in every sweep run, 0.70 -> 0.58 cm on the
    probes' `base`).  Widths and stride lengths are left as measured on the merged track (their medians were mixed).
    A step without a mate in every pass keeps its length; :func:`confirm_steps` has doubted it already."""
    out = []
    for st in steps:
        mates = _mates(st.stamp, per_pass, within_s=within_s, same=lambda o, st=st: int(o.side) == int(st.side))
        if mates:
            vals = [float(st.step_length), *(float(m.step_length) for m in mates)]
            if all(math.isfinite(v) for v in vals):
                st = dataclasses.replace(st, step_length=float(np.median(vals)))
        out.append(st)
    return out


_Timed = TypeVar("_Timed", GaitEvent, Step)


def _mates(stamp: float, per_pass: Sequence[Sequence[_Timed]], *, within_s: float,
           same: Callable[[_Timed], bool]) -> list[_Timed] | None:
    """Each pass's item (``same`` as the one at ``stamp``: its foot, its kind) nearest to ``stamp`` within
    ``within_s``; None where some pass has none."""
    mates = []
    for items in per_pass:
        near = [o for o in items if same(o) and abs(o.stamp - stamp) <= within_s]
        if not near:
            return None
        mates.append(min(near, key=lambda o: abs(o.stamp - stamp)))
    return mates


def check_against_passes(events: Sequence[GaitEvent], steps: Sequence[Step],
                         per_pass: Sequence[tuple[Sequence[GaitEvent], Sequence[Step]]], *,
                         confirm: dict[str, float] | None = None) -> tuple[list[GaitEvent], list[Step]]:
    """The merged track's events and steps checked against each pass's own (``per_pass[k]``: the gait analyzer's
    events and steps on pass ``k``'s poses alone): steps not confirmed doubted (:func:`confirm_steps`, with the
    keyword arguments ``confirm``, on the merged track's own lengths), their lengths refined
    (:func:`refine_step_lengths`), events and the steps' times refined (:func:`refine_event_times`)."""
    per_steps = [s for _, s in per_pass]
    confirmed = confirm_steps(steps, per_steps, **(confirm or {}))
    return refine_event_times(events, refine_step_lengths(confirmed, per_steps), [e for e, _ in per_pass])
