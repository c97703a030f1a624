"""Gait events (heel strike / toe off) and clinical step metrics from tracked leg poses.

Pure Python + numpy; no ROS.  :class:`GaitAnalyzer` is fed one :class:`LegPose` (camera
optical frame) and the current :class:`FloorPlane` per frame, in time order, and returns the
gait events and steps it could finalise in that call.  The metric definitions (GAITRite /
ProtoKinetics conventions) are written out in ``docs/GAIT_METRICS.md``.

Method in short (all geometry in the floor plane of the *walker* frame, see ``types.py``):

1. Heel and toe of each foot are transformed into the walker frame (x towards the user,
   z up, metres); ``z`` is the height above the floor, so camera pitch/roll drop out.
   Each frame gets a quality ``q`` (see :meth:`GaitAnalyzer.frame_quality`).
2. Positions are smoothed by a local quadratic fit over ``±smoothing_half_window_s``
   (a Savitzky-Golay filter that tolerates irregular stamps and missing frames); this
   delays the analysis by that half window.
3. The walker moves with the user, so a planted foot drifts through the walker frame at the
   walker's speed.  For every foot we integrate its heel/toe motion *relative to the other
   foot's planted points* (points within ``plant_height_tol_m`` of that point's floor
   baseline, weighted by lowness).  While the other foot is planted this relative track is
   the foot's displacement in the world, independent of how the walker moves.
4. A state machine (INIT, DOUBLE_SUPPORT, SWING_LEFT, SWING_RIGHT) runs on those tracks:
   toe off = the toe leaves its resting place by more than ``min_swing_distance_m``, moving
   forward (tiny shuffles and a moving walker with still feet produce nothing); heel strike
   = the swinging heel comes to rest (speed < ``rest_speed_mps`` over ``rest_window_s``)
   near the floor.  Both are then timed to sub-frame precision by fitting a hinge
   ``y = b + a*max(0, ±(t - t_c))**p`` (p in {1, 1.5, 2, 3}) to the foot's raw position along its
   swing in the walker frame with a free linear drift (the walker passing a planted foot;
   ``hs_walker_frame``, ``to_walker_frame``) around the detection, for toe offs also relative to the
   other foot's planted heel (off: relative to the other foot, and the toe's height; heel strikes:
   ``hs_height_weight``).
5. Footfalls are located in the world by chaining: at the heel strike of foot B, foot A is
   still planted (double support), so the step vector is the mean over the double-support
   frames of ``heel_B - (toe_A + o_A)``, where ``o_A`` is A's heel-minus-toe offset measured
   while A was flat on the floor.  Both terms are measured in the same frame at the same
   instant, so the walker's own motion cancels exactly; where the tracker reports A's foot hidden
   (late in its stance, behind B's leg), ``toe_A`` continues the drift seen while it was in view
   (:meth:`GaitAnalyzer._planted_point`), and so it does, seen or not, where B's strike is timed so late that A's
   toe is already off the floor.  The component across the line of
   progression (step width) comes from the ankles instead (``ankle + heel-ankle offset`` of each
   foot, see :meth:`GaitAnalyzer._ankle_vector`): far less sensitive to foot yaw errors; the reported width takes
   the trailing foot's from its last flat frames in view (``width_flat_trailing_s``).  Step vectors are chained into a
   footprint map; the line of progression is the mean direction of the last
   ``progression_strides`` strides (fallback: walker -x, or the odometry heading; or the feet's heading where both
   point alike, well off the walker's axis: ``progression_from_feet_deg``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from enum import IntEnum
from typing import Any

import numpy as np
from numpy.typing import NDArray

from walker_gait.core.types import (
    ANKLE,
    HEEL,
    TOE,
    EventKind,
    FloatArray,
    FloorPlane,
    GaitEvent,
    LegPose,
    Side,
    Step,
    TrackStatus,
)

__all__ = [
    "GaitConfig",
    "GaitAnalyzer",
    "GaitSummaryData",
    "GaitInputError",
    "GaitState",
    "fitted_step_time",
    "stride_in_line",
    "summarize_steps",
]

_H, _T = 0, 1  # heel / toe index in the internal (2 feet, 2 points) arrays
_HINGE_POWERS = (1.0, 1.5, 2.0, 3.0)
_TOE_DOWN_S = 0.15  # s: a landing foot's toe is down this soon after its heel strike (foot flat: ~0.06 s in walking)
_MAX_DRIFT_SPEED = 2.0  # m/s: faster than a walker user walks; a planted foot's drift beyond it is a bad fit
_FEET_AGREE_DEG = 20.0  # deg: feet pointing within this of each other give a line of progression (progression_from_feet_deg)
_STRIDE_MAX_OFF_AXIS_DEG = 60.0
"""deg: a stride further than this off the walker's axis (its forward direction; the odometry heading) does not enter the
line of progression.  The user walks behind the walker, towards its front; even walking in at an angle the strides
stay within ~45 deg of it.  A 6 cm sideways "stride" between two junk steps of a user arriving turned the line across
the walker, and the state machine, which looks for a toe moving forward along that line, then saw no toe off for 3 s
of good tracking (synthetic `absent_start:961`)."""
_SEEN_VISIBILITY = 0.5  # a foot segment with a tracker visibility below this is hidden
TOE_OFF_SEEN_BEFORE_S = 0.2
"""s before a toe off through which its foot must have been in view for the toe off to count as seen
(:attr:`GaitConfig.toe_off_seen_gap_s`)."""
_GROUND_VELOCITY_TAU_S = 0.15  # s: time constant of the running ground velocity under the feet in view
_GAP_FIT_PRE_S = 0.15  # s of a strike's fit window before a tracking gap inside it (the swing's last frames seen)
_FLAT_HEEL_SPAN_S = 0.3  # s: the trailing foot's last flat frames averaged for its heel across the line of progression
SWING_QUALITY_BEFORE_S = 0.6  # s before a heel strike from which `swing_min_quality` looks at the frame quality (the swing)


class GaitInputError(ValueError):
    """Invalid input to :class:`GaitAnalyzer` (bad shape, non-increasing stamp, bad config)."""


class StampOrderError(GaitInputError):
    """A frame whose stamp is not after the previous frame's (a duplicate or out-of-order message)."""

    kind = "stamp_not_increasing"


class GaitState(IntEnum):
    """Phase of the event state machine."""

    INIT = 0  # (re)starting: waiting until both feet are seen at rest together
    DOUBLE_SUPPORT = 1  # both feet on the floor (also: standing still)
    SWING_LEFT = 2  # left foot in swing, right foot planted
    SWING_RIGHT = 3  # right foot in swing, left foot planted


@dataclass(kw_only=True)
class GaitConfig:
    """Parameters of :class:`GaitAnalyzer` (they become ROS parameters of the node).

    Units: metres, seconds, m/s; fractions 0..1.
    """

    smoothing_half_window_s: float = 0.1
    """Half width (s) of the local quadratic smoother; also the minimum analysis latency."""
    rest_window_s: float = 0.15
    """Window (s) over which a point's mean speed decides whether it is at rest."""
    rest_speed_mps: float = 0.25
    """A point moving slower than this (m/s, world, mean over ``rest_window_s``) is at rest (a swinging
    heel moves at 1-4 m/s; tracked heels jitter by a few cm per frame, which 0.15 m/s mistook for motion)."""
    min_swing_distance_m: float = 0.06
    """A foot must leave its resting place by at least this (m, horizontal) to count as a
    swing; smaller motions (shuffling in place, tracker jitter) produce no events."""
    min_swing_time_s: float = 0.12
    """Shortest plausible swing (s): heel strikes earlier than this after toe off are ignored."""
    min_stance_time_s: float = 0.2
    """A foot cannot toe off within this time (s) of the detection of its own heel strike (stance lasts
    >= 0.35 s even in fast walking; keeps a just-landed foot whose toe is still coming down, or noise,
    from starting a second swing).  A toe off timed within this time of the foot's own (fitted) heel strike, with
    no strike of the other foot since, withdraws that strike's step while it is pending: the foot stopped mid-swing
    and swings on (a slow first step while the walker starts to roll; on the tracked poses of ``make sweep``, sets
    C / A / B, tracker seeds 0 / 1: 11 of the 12 steps so withdrawn were phantoms, the twelfth a tracking failure)."""
    max_swing_time_s: float = 3.0
    """A swing not landing within this time (s) resets the state machine."""
    plant_height_tol_m: float = 0.03
    """Height band (m) above a point's floor baseline over which its 'planted' weight
    falls from 1 to 0 (after ``plant_height_margin_m``)."""
    plant_height_margin_m: float = 0.01
    """Height (m) above the baseline still counted as fully on the floor (absorbs jitter)."""
    hs_height_weight: float = 0.0
    """Weight of the heel's height in the sub-frame heel-strike fit, next to its horizontal arrest (relative
    to the other, planted foot).  0: the arrest alone, the height only when that reference is missing.  A
    tracked heel's last centimetres of descent are not observed (the segmentation drops the foreground
    ``fg_min_height`` above the floor) and the tracker brings it down late: on tracker poses of 2 x 32
    synthetic sessions x 2 tracker seeds, weight 1 times heel strikes 1-2 frames late (median error
    2.1-2.3 frames, 0: 1.7-2.0).  On exact kinematics the height is the sharper signal (1: 0.6-0.9 frame
    median error with 1 cm noise, 0: 1.4-1.6)."""
    hs_walker_frame: bool = True
    """True: the heel strike fit's horizontal arrest is the heel's own position along the swing in the walker frame,
    with a free linear drift (the walker's motion past the landed foot).  False: the heel relative to the other
    foot's toe.  That toe is the trailing one, in its heel rise, and the tracker lets it creep forward then, which the
    fit takes for the landing heel still moving (strikes timed at the detection, 0.15-0.3 s late).  Tracked poses of
    2 x 32 synthetic sessions x 2 tracker seeds (``make sweep``, sets C / A): median timing error 1.50 / 1.65, 1.47 /
    1.39 -> 1.22 / 1.16, 1.23 / 1.17 frames, steps matched 306 / 300, 312 / 312 -> 310 / 308, 319 / 321, precision
    up or equal in all four runs.  Exact leg points of the synthetic generator (walker speed within +-10 % over a
    step): alike (0.1-1.1 frames either way).  A walker that surges within each step bends the linear drift:
    on :func:`walker_gait.bench.gait.simulate_gait`'s (+-30 %) 0.76-0.98 -> 0.88-1.22 frames."""
    to_walker_frame: bool = True
    """True: the toe off fit uses the toe's own position along the swing in the walker frame (free linear drift: the
    floor carries the planted toe back) next to the toe relative to the other foot's heel, and leaves out the toe's
    height.  False: the height and the relative position.  A tracked toe is raised early in its heel rise, and
    creeps forward relative to the other heel: on the tracked poses of ``make sweep`` (sets C / A, both tracker
    seeds pooled) toe offs came 0.95 / 1.24 frames early (median; median |error| 1.31 / 1.60 frames), with this
    0.15 / 0.12 early (0.67 / 0.66), and the double support time error went from -2.41 / -2.73 to -1.85 / -1.48
    frames (median).  On exact leg points with 1 cm i.i.d. noise the height is the sharper signal: 0.5-1.0 ->
    0.9-1.7 frames on :func:`walker_gait.bench.gait.simulate_gait`."""
    hs_height_tol_m: float = 0.04
    """A heel strike needs the heel within this height (m) of its floor baseline."""
    hs_resume_distance_m: float = 0.04
    """A detected heel strike is withdrawn, and the swing goes on, when heel and toe both advance more than this (m,
    along the swing, relative to the other foot) within ``event_fit_post_s`` of the detection and are still advancing
    at its end, while nothing else happened: a foot that hovers low mid-swing (a slow first step from standing) is
    not a footfall (``inf`` = off)."""
    baseline_window_s: float = 10.0
    """History (s) used to estimate each point's floor-contact height (baseline)."""
    baseline_percentile: float = 25.0
    """Percentile of the recent heights taken as that baseline."""
    hidden_ground_gate_mps: float = 0.6
    """The ground's motion under a planted reference foot that the tracker reports hidden (visibility < 0.5) is taken
    from the feet last seen planted (a running mean of their velocity, time constant 0.15 s) when the hidden foot's
    own tracked motion differs from it by more than this (m/s; ``inf`` = off).  A hidden planted foot is carried by
    the tracker's motion model and drifts (``occlusion:533``: its heel moved back 13 cm in 0.37 s where the real one
    moved 6 cm), and the landing foot, measured against it, then seemed to advance and its strike went undetected.
    The strike's sub-frame fit keeps the window it had before: it ends where the landing heel comes to rest against
    the tracked feet as seen (at most ``event_fit_post_s`` after the detection).  Re-analysis of the tracked poses of
    ``make sweep`` (sets C / B / E / D x tracker seeds 0 / 1, and twelve runs of tracker variants, forty-sixth
    session): steps matched 2564 -> 2578 and 3471 -> 3485, step length MAE summed 11.07 -> 10.65 and 15.97 -> 15.51 cm,
    width 10.62 -> 10.49 and 16.69 -> 16.28, cadence error 9.99 -> 8.76 and 14.97 -> 12.89 %, heel-strike timing
    7.24 -> 7.19 and 10.90 -> 10.77 frames (median |error|, summed)."""
    event_fit_pre_s: float = 0.25
    """Data (s) before the detection used by the sub-frame hinge fit of an event."""
    event_fit_post_s: float = 0.12
    """Data (s) after a heel-strike detection used by its fit (adds to the latency)."""
    max_gap_s: float = 1.0
    """Tracking gaps (s) longer than this reset the state machine; steps inside are lost."""
    min_confidence: float = 0.5
    """Pose confidence below which a frame counts as degraded."""
    degraded_quality: float = 0.5
    """Quality factor applied to DEGRADED / low-confidence / invalid-floor frames."""
    double_support_max_s: float = 0.6
    """Longest time (s) after a heel strike used to average the step vector."""
    planted_fit_sigma_s: float = 0.3
    """Width (s, Gaussian sigma) of the visibility-weighted local-linear fit that gives the trailing foot's
    toe for the step vector where the tracker reports that foot hidden (0 = always the raw positions)."""
    planted_fit_window_s: float = 1.5
    """History (s, bounded by that foot's own heel strike) the planted-foot fit may use."""
    planted_drift_ramp: bool = True
    """The planted-foot fit's drift (the walker's motion past the planted foot) changes linearly from the trailing
    foot's own fitted drift to the landing foot's, fitted over its flat frames after its heel strike (both feet
    are planted then, and drift alike), instead of staying at the trailing foot's: a walker that speeds up
    (gait initiation) moves a hidden trailing foot further than its earlier drift says.  On the tracked poses
    of ``make sweep`` (tracker seeds 0 / 1; false -> true): step length MAE 3.01 / 2.98 -> 2.86 / 2.84 cm (set
    C), 2.69 / 3.32 -> 2.54 / 3.11 (A), 2.55 / 3.86 -> 2.48 / 3.73 (B)."""
    landing_toe_fit_s: float = 0.3
    """Time (s) after the double support over which the landing foot's toe, in the frames in which that foot is
    flat, gives its footprint for the step vector (toe to toe; the camera sees the toes, the heels are hidden
    behind them).  Steps are emitted this much later.  0: the landing foot's tracked heel instead."""
    landing_toe_only: bool = True
    """When the landing foot has fewer than three flat frames (heel and toe in the planted band) for its footprint
    (``landing_toe_fit_s``), take the frames with its toe planted instead: a tracker that pitches a planted foot
    toe-down holds its heel centimetres up through the stance (trousers over the heel), and the step then fell back
    to the tracked landing heel."""
    landing_visibility: float = 0.5
    """Mean visibility (``LegPose.visibility`` of the foot segment, 0.1 s before to 0.2 s after the heel strike)
    of the landing foot below which a step's confidence is scaled down in proportion (``v / landing_visibility``):
    a foot the tracker did not see land was placed by its motion model, and such steps were off by 13-52 cm
    on average on the sweeps (0 = off)."""
    toe_off_seen_gap_s: float = 0.15
    """A toe off counts as seen when its foot was in view (``LegPose.visibility`` of its foot segment at least 0.5)
    from ``TOE_OFF_SEEN_BEFORE_S`` (0.2 s) before it to the first frame after it, out of view for no longer than
    this at a time.  A toe off the tracker did not see (the trailing foot hidden behind the leading leg or under a
    trouser hem from its heel rise into its swing) is timed on the tracker's motion model, or where the foot comes
    back into view: on the sweeps' tracked poses (set C, sixty-sixth session) 41 of ``occlusion``'s 46 toe offs and
    40 of ``baggy_trousers``' 48 were unseen, 106 and 48 ms off on average; the seen ones 6-26 ms per scenario.  An
    unseen toe off keeps its time, which the state machine needs, at ``unseen_event_confidence`` times its
    confidence, and the durations it bounds (the swing, stance, single and double support times of the steps it
    belongs to) are reported unknown (NaN) rather than as the model's guess (0 = every toe off counts as seen)."""
    unseen_event_confidence: float = 0.25
    """Factor on the confidence of a toe-off event the tracker did not see (``toe_off_seen_gap_s``)."""
    swing_min_quality: float = 0.75
    """Lowest frame quality (the tracker's confidence, halved on degraded frames; frames with a pose only) from
    ``SWING_QUALITY_BEFORE_S`` (0.6 s) before a heel strike to 0.2 s after it, below which the step's confidence
    is halved: the tracker doubted its own pose while it carried the landing foot through its swing.  On the
    sweeps' tracked poses (five sets x two tracker seeds, thirty-sixth session) the confident steps' step length
    MAE went from 1.33-2.05 to 1.18-1.83 cm, for 2-4 % of the steps left out of the summary means (0 = off)."""
    heel_rise_travel: bool = True
    """Take back, from the trailing foot's ankle at the strike (the footprint chain's width, and the reported one
    where ``width_flat_trailing_s`` finds no flat frame), its travel along the foot since the foot was
    flat.  A trailing foot in its heel rise pivots about its toe, so its ankle travels forward along the foot and,
    with toe-out, sideways: on exact synthetic poses the width came out 0.9 cm wide (normal walking: 1.0).  The
    travel is the change of the ankle's offset from the planted toe, along the foot's flat heel-to-toe
    direction (session mean, so a tracked foot's wobbling yaw averages out).  On the tracked poses of ``make
    sweep`` (tracker seeds 0 / 1; off -> on): step width MAE 2.28 / 2.41 -> 2.25 / 2.31 cm (set C), 2.30 / 2.50 ->
    2.17 / 2.41 (A), 2.42 / 2.31 -> 2.29 / 2.30 (B); exact poses of set C's sessions 1.32 -> 0.94 cm."""
    width_flat_trailing_s: float = 0.8
    """Across the line of progression, the reported step width takes the trailing foot's heel from its own last flat
    frames (heel and toe on the floor, the foot in view) within this many seconds before the strike: the mean of
    ``ankle + heel-ankle offset`` over those of the last 0.3 s, the ankle as the tracker saw it standing rather than
    at the strike, when the foot is in its heel rise (the tracker rolls it) or hidden behind the landing leg (0 =
    off, or no such frames: the ankle at the strike, see ``heel_rise_travel``).  The footprint chain and the line
    of progression keep the ankle at the strike (with the flat heel there, a wrong lateral place turned the line
    and lengthened later steps).  A strike with no double-support frame takes the landing foot's ankle at its nearest
    frame against the same trailing heel.  On the sweeps (tracker seeds 0 / 1): step width MAE 2.29 / 1.91 -> 1.99 /
    1.66 cm (set C), 1.86 / 1.96 -> 1.50 / 1.69 (A), 2.07 / 2.08 -> 1.86 / 1.78 (B); the landing foot's own flat frames
    after the strike did worse (DEVELOPERS.md, thirty-third session).  Assumes a walker that does not turn in that
    time (a walkway's straight pass)."""
    heading_offsets: bool = True
    """Toe to toe (``landing_toe_fit_s`` > 0), the step vector takes both footprints' heel-toe offsets as equal along
    the line of progression.  A foot turned against the other (a user who stood turned at the walker walks off
    straight) breaks that by ``L (cos a - cos b)``, ``L`` the horizontal heel-toe length and ``a``, ``b`` the two
    feet's angles to the line (each foot's heel-to-toe direction over its last flat frames in view): ~9 cm for a
    trailing foot turned 48 deg.  True: the reported step length (and the stride length, from each footprint's
    own heading) adds that term; the footprint chain, and so the line of progression, stays toe to toe.  On the
    tracked poses of ``make sweep`` (sets C, D, C with tracker seeds 2 / 3, B; seeds 0 / 1; re-analysed,
    forty-second session): step length MAE summed over the eight runs 14.09 -> 13.79 cm (seven better or equal),
    absent_start 4.57 -> 4.18 cm, the other scenarios within 0.03; step width unchanged."""
    heading_offset_min_m: float = 0.005
    """The ``heading_offsets`` term is applied by its excess over this (m; a soft threshold): the headings of tracked
    feet walking straight wobble by 5-10 deg, which makes the term up to ~0.5 cm either way for nothing.  Re-analysed
    (forty-second session; summed step length MAE, 0 -> 0.005 m): the eight baseline runs 13.66 -> 13.65 cm, a fresh
    set never used to choose anything (``--base-seed 300``, tracker seeds 0 / 1) 3.87 -> 3.83, the twenty probes of
    unusual users and mounts 24.29 -> 24.14 (0.01 m: 13.73, 3.83, 24.19)."""
    progression_from_feet_deg: float = 15.0
    """Before the analyzer has a stride (strides are kept through a tracking gap) the line of progression is the
    walker's axis, unless both feet (each over its last flat frames in view, as ``heading_offsets``) point within
    20 deg of each other and their mean heading is more than this (deg) off that axis: then that heading.  A user who walked up to the walker at an
    angle closes the step with the feet side by side across the approach, which along the walker's axis read as a
    10-12 cm step (180 = off).  Re-analysed eight baseline runs (forty-second session): step length MAE summed
    13.79 -> 13.65 cm, width 12.55 -> 12.41, every run better or equal; sixteen runs of earlier tracker variants
    31.24 -> 31.01 cm.  Both feet must agree: with 30 deg instead of 20, 13.79 -> 13.91."""
    progression_strides: int = 4
    """Number of recent strides averaged for the line of progression."""
    max_step_time_s: float = 2.5
    """Steps longer than this (s; gait initiation after a stop) are excluded from temporal
    summary statistics, cadence and speed."""
    summary_window_s: float = 10.0
    """Default rolling-window length (s) of :meth:`GaitAnalyzer.summary`'s WINDOW scope."""
    summary_min_confidence: float = 0.5
    """Steps below this confidence are counted but excluded from summary means."""
    summary_min_time_confidence: float = 0.25
    """Steps at or above this confidence count in the summary's temporal statistics (cadence, step time, stance /
    swing / double-support %, swing symmetry) even when below ``summary_min_confidence``: a step's time is its heel
    strike's, whatever the doubt on its footprint, and the mean step time over an unbroken run of heel strikes
    telescopes (each strike's timing error enters one step with + and the next with -), which a missing step
    breaks.  Below it (``implausible_quality`` x confidence: implausible geometry or time) a step is taken for a
    tracking error, not a step.  Tracker poses of ``make sweep`` (sets C / A, tracker seeds pooled; 0.5 -> 0.25): absolute
    error of the session cadence, mean over sessions 5.1 -> 4.8 % and 6.2 -> 5.2 %, median 2.3 -> 1.9 % and
    2.6 -> 1.5 %."""
    summary_max_step_time_ratio: float = 1.8
    """The summary's temporal statistics and gait speed also skip steps whose time exceeds this multiple of the median
    step time of the steps in scope (at least 4 of them): a step time that long spans a footfall the analyzer did not
    detect, or a hesitation, not one step of walking.  Tracker poses of ``make sweep`` (sets C / A, tracker seeds 0 /
    1; off -> 1.8): session cadence |error| 4.66 / 5.03 and 4.00 / 6.03 % -> 2.61 / 5.06 and 2.90 / 5.18 %, gait speed 10.3 / 8.4
    and 8.1 / 9.6 % -> 8.4 / 7.9 and 7.2 / 7.4 % (1.6: 2.69 / 4.94, 3.15 / 7.13 %; inf = off)."""
    max_step_length_m: float = 1.2
    """A step longer than this (m) is physically implausible behind a walker: reported, but its
    confidence is multiplied by ``implausible_quality`` (a tracking error, not a step)."""
    max_backward_step_m: float = 0.15
    """Likewise for a step length below ``-max_backward_step_m`` (m, a large backward step)."""
    max_step_width_m: float = 0.6
    """Likewise for a step width above this (m)."""
    min_step_time_s: float = 0.3
    """A step whose time (from the other foot's heel strike) is shorter than this (s; a cadence above 200 steps/min,
    running, not walking: adults walk at 0.4-1.5 s per step, walker users at the slow end) is implausible: reported,
    but its confidence is multiplied by ``implausible_quality``.  Such steps are heel strikes the analyzer took from
    tracking errors (a track settling on a user who has just reached the walker): on the tracked poses of ``make
    sweep`` (sets C / A, tracker seeds 0 / 1) the session cadence |error| went 3.15 / 5.21 and 3.67 / 3.39 % ->
    2.46 / 2.96 and 2.53 / 2.47 % (absent-start sessions 12.7 / 15.1 -> 5.9 / 7.6 %; 0 = off)."""
    implausible_quality: float = 0.2
    """Confidence factor of a step with implausible geometry or time: keeps it out of the summary means (below
    ``summary_min_time_confidence`` even at confidence 1)."""
    odometry_base_yaw_rad: float = math.pi
    """Yaw (rad) of the walker frame's +x axis in the odometry base frame (base x forward,
    walker x towards the user: pi)."""
    history_s: float = 30.0
    """Frame history kept (s); must exceed all latencies and ``baseline_window_s``."""

    def __post_init__(self) -> None:
        positive = {
            "smoothing_half_window_s": self.smoothing_half_window_s,
            "rest_window_s": self.rest_window_s,
            "rest_speed_mps": self.rest_speed_mps,
            "min_swing_distance_m": self.min_swing_distance_m,
            "plant_height_tol_m": self.plant_height_tol_m,
            "hs_height_tol_m": self.hs_height_tol_m,
            "baseline_window_s": self.baseline_window_s,
            "event_fit_pre_s": self.event_fit_pre_s,
            "event_fit_post_s": self.event_fit_post_s,
            "max_gap_s": self.max_gap_s,
            "double_support_max_s": self.double_support_max_s,
            "max_step_length_m": self.max_step_length_m,
            "max_step_width_m": self.max_step_width_m,
            "max_step_time_s": self.max_step_time_s,
            "summary_window_s": self.summary_window_s,
            "history_s": self.history_s,
            "planted_fit_window_s": self.planted_fit_window_s,
        }
        if not self.hidden_ground_gate_mps >= 0:
            raise GaitInputError(f"GaitConfig.hidden_ground_gate_mps must be >= 0 (inf = off), got "
                                 f"{self.hidden_ground_gate_mps}")
        for name, value in positive.items():
            if not (math.isfinite(value) and value > 0):
                raise GaitInputError(f"GaitConfig.{name} must be positive and finite, got {value}")
        for name, value in (("planted_fit_sigma_s", self.planted_fit_sigma_s), ("hs_height_weight", self.hs_height_weight),
                            ("landing_toe_fit_s", self.landing_toe_fit_s),
                            ("width_flat_trailing_s", self.width_flat_trailing_s)):
            if not (math.isfinite(value) and value >= 0):
                raise GaitInputError(f"GaitConfig.{name} must be >= 0 and finite, got {value}")
        if not self.summary_max_step_time_ratio > 1:
            raise GaitInputError(f"GaitConfig.summary_max_step_time_ratio must be > 1 (inf = off), got "
                                 f"{self.summary_max_step_time_ratio}")
        if not self.hs_resume_distance_m > 0:
            raise GaitInputError(f"GaitConfig.hs_resume_distance_m must be > 0 (inf = off), got {self.hs_resume_distance_m}")
        if self.progression_strides < 1:
            raise GaitInputError(f"GaitConfig.progression_strides must be >= 1, got {self.progression_strides}")
        if not 0 < self.baseline_percentile < 100:
            raise GaitInputError(f"GaitConfig.baseline_percentile must be in (0, 100), got {self.baseline_percentile}")
        if self.history_s < self.baseline_window_s + 2 * self.double_support_max_s:
            raise GaitInputError("GaitConfig.history_s must exceed baseline_window_s + 2*double_support_max_s")
        if not (math.isfinite(self.heading_offset_min_m) and self.heading_offset_min_m >= 0):
            raise GaitInputError(f"GaitConfig.heading_offset_min_m must be >= 0 and finite, got {self.heading_offset_min_m}")
        if not 0 < self.progression_from_feet_deg <= 180:
            raise GaitInputError(f"GaitConfig.progression_from_feet_deg must be in (0, 180], got {self.progression_from_feet_deg}")
        if not 0 <= self.landing_visibility <= 1:
            raise GaitInputError(f"GaitConfig.landing_visibility must be in [0, 1], got {self.landing_visibility}")
        if not (math.isfinite(self.toe_off_seen_gap_s) and self.toe_off_seen_gap_s >= 0
                and 0 <= self.unseen_event_confidence <= 1):
            raise GaitInputError("GaitConfig.toe_off_seen_gap_s must be finite and >= 0 and unseen_event_confidence "
                                 f"in [0, 1], got {self.toe_off_seen_gap_s}, {self.unseen_event_confidence}")
        if not 0 <= self.swing_min_quality <= 1:
            raise GaitInputError(f"GaitConfig.swing_min_quality must be in [0, 1], got {self.swing_min_quality}")
        if not 0 <= self.summary_min_time_confidence <= self.summary_min_confidence <= 1:
            raise GaitInputError("GaitConfig needs 0 <= summary_min_time_confidence <= summary_min_confidence <= 1, got "
                                 f"{self.summary_min_time_confidence}, {self.summary_min_confidence}")
        if not (self.max_backward_step_m >= 0 and 0 <= self.implausible_quality <= 1):
            raise GaitInputError("GaitConfig.max_backward_step_m must be >= 0 and implausible_quality in [0, 1]")
        if not (math.isfinite(self.min_step_time_s) and self.min_step_time_s >= 0):
            raise GaitInputError(f"GaitConfig.min_step_time_s must be >= 0 and finite, got {self.min_step_time_s}")
        if self.implausible_quality >= self.summary_min_time_confidence > 0:
            raise GaitInputError("GaitConfig.implausible_quality must be below summary_min_time_confidence (an "
                                 f"implausible step stays out of the summary), got {self.implausible_quality}, "
                                 f"{self.summary_min_time_confidence}")


@dataclass(kw_only=True)
class GaitSummaryData:
    """Mirror of ``walker_gait_msgs/GaitSummary`` (pairs are ``[LEFT, RIGHT]``; NaN = unknown)."""

    WINDOW = 0
    SESSION = 1

    stamp: float  # s, heel-strike time of the latest step in scope (NaN if none)
    scope: int  # WINDOW or SESSION
    window_duration: float  # s, 0 for SESSION
    duration: float  # s, first to last heel strike in scope
    step_count: int
    cadence: float  # steps/min
    gait_speed: float  # m/s
    step_length_mean: float  # m
    step_width_mean: float  # m
    step_time_mean: float  # s
    step_length_mean_side: tuple[float, float]
    step_length_sd_side: tuple[float, float]
    step_length_cv_side: tuple[float, float]  # %
    step_width_mean_side: tuple[float, float]
    step_width_sd_side: tuple[float, float]
    step_width_cv_side: tuple[float, float]  # %
    step_time_mean_side: tuple[float, float]
    step_time_sd_side: tuple[float, float]
    step_time_cv_side: tuple[float, float]  # %
    stance_percent_side: tuple[float, float]  # % of gait cycle
    swing_percent_side: tuple[float, float]  # % of gait cycle
    double_support_percent: float  # % of gait cycle
    step_length_symmetry: float  # LEFT/RIGHT
    swing_time_symmetry: float  # LEFT/RIGHT
    mean_confidence: float  # 0..1

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (NaN/inf become ``None``, pairs become lists)."""

        def clean(v: Any) -> Any:
            if isinstance(v, (tuple, list)):
                return [clean(x) for x in v]
            if isinstance(v, float) and not math.isfinite(v):
                return None
            return v

        out = {k: clean(v) for k, v in asdict(self).items()}
        out["scope_name"] = "window" if self.scope == self.WINDOW else "session"
        return out


# --------------------------------------------------------------------------------------
# helpers


def _nanfloat(x: float | None) -> float:
    return float("nan") if x is None else float(x)


def _hinge_time(
    t: FloatArray,
    channels: list[FloatArray],
    *,
    rising: bool,
    tc_lo: float,
    tc_hi: float,
    step_s: float = 0.002,
    drift: tuple[int, ...] = (),
) -> float:
    """Breakpoint time of a hinge model fitted jointly to several signals.

    Channels whose index is in ``drift`` have a free linear trend in time as well (``b + c t + a * hinge``): a
    walker-frame position that drifts at the walker's speed once the foot rests.

    Each channel ``y`` is modelled as ``b + a * max(0, t - t_c)**p`` (``rising``: flat then
    moving, e.g. toe off) or ``b + a * max(0, t_c - t)**p`` (moving then flat, heel strike),
    with ``b, a`` free per channel and ``p`` in {1, 1.5, 2, 3} picked per channel.  ``t_c`` is
    shared and searched on a ``step_s`` grid in ``[tc_lo, tc_hi]``; the sum of squared
    residuals (metres², all channels share units and noise) is minimised.  NaN samples are
    ignored.  Returns NaN when no channel has four samples.
    """
    if not tc_hi > tc_lo:
        tc_hi = tc_lo + step_s
    grid = np.arange(tc_lo, tc_hi + 0.5 * step_s, step_s)
    total = np.zeros(grid.size)
    used = False
    for ci, y in enumerate(channels):
        ok = np.isfinite(y) & np.isfinite(t)
        if ok.sum() < 4:
            continue
        used = True
        tt, yy = t[ok], y[ok]
        if ci in drift:
            total += _drift_hinge_sse(tt, yy, grid, rising=rising)
            continue
        n = float(yy.size)
        sy = yy.sum()
        syy = (yy * yy).sum()
        lag = (tt[None, :] - grid[:, None]) if rising else (grid[:, None] - tt[None, :])
        base = np.maximum(lag, 0.0)
        best = np.full(grid.size, np.inf)
        for p in _HINGE_POWERS:
            x = base**p
            sx = x.sum(axis=1)
            sxx = (x * x).sum(axis=1)
            sxy = x @ yy
            det = n * sxx - sx * sx
            good = det > 1e-12 * max(1.0, n)
            with np.errstate(divide="ignore", invalid="ignore"):
                a = np.where(good, (n * sxy - sx * sy) / det, 0.0)
            b = (sy - a * sx) / n
            # SSE = sum((y - b - a x)^2) expanded
            sse = syy + n * b * b + a * a * sxx - 2 * b * sy - 2 * a * sxy + 2 * a * b * sx
            sse = np.where(good, sse, syy - sy * sy / n)
            best = np.minimum(best, sse)
        total += best
    if not used:
        return float("nan")
    return float(grid[int(np.argmin(total))])


def _drift_hinge_sse(t: FloatArray, y: FloatArray, grid: FloatArray, *, rising: bool) -> FloatArray:
    """Per breakpoint in ``grid``: the least residual sum of squares of ``y ~ b + c t + a max(0, lag)**p`` over
    ``p`` in ``_HINGE_POWERS`` (see :func:`_hinge_time`)."""
    tc = (t - t.mean()) / max(float(np.ptp(t)), 1e-9)
    lag = (t[None, :] - grid[:, None]) if rising else (grid[:, None] - t[None, :])
    base = np.maximum(lag, 0.0)
    poly = np.stack([np.ones_like(tc), tc], axis=1)  # (n, 2): intercept and drift
    best = np.full(grid.size, np.inf)
    for p in _HINGE_POWERS:
        x = base**p  # (G, n)
        design = np.concatenate([np.broadcast_to(poly, (grid.size, *poly.shape)), x[:, :, None]], axis=2)
        gram = np.einsum("gni,gnj->gij", design, design)
        rhs = np.einsum("gni,n->gi", design, y)
        gram += 1e-12 * np.eye(gram.shape[1])
        theta = np.linalg.solve(gram, rhs[:, :, None])[:, :, 0]
        res = y[None, :] - np.einsum("gni,gi->gn", design, theta)
        best = np.minimum(best, (res * res).sum(axis=1))
    return best


def _local_quadratic(t: FloatArray, y: NDArray[np.float64], t0: float) -> NDArray[np.float64] | None:
    """Value at ``t0`` of a least-squares quadratic (linear if few samples) in time.

    ``y`` is ``(N, D)``; returns ``(D,)`` or None without samples.
    """
    n = t.size
    if n == 0:
        return None
    if n == 1:
        return y[0].copy()
    dt = t - t0
    deg = 2 if n >= 5 else 1
    a = np.vander(dt, deg + 1, increasing=True)
    coef, *_ = np.linalg.lstsq(a, y, rcond=None)
    return coef[0]


@dataclass
class _PendingHS:
    side: int
    k_det: int  # buffer index of the detection frame (absolute)
    t_det: float
    t_to: float  # toe-off time of this swing (NaN if unknown)
    direction: FloatArray  # (2,) unit horizontal swing direction (walker frame)
    swing: dict[str, Any] = field(default_factory=dict)  # the swing's state at the detection, to resume it


@dataclass
class _PendingStep:
    side: int  # foot whose heel strike ends the step
    t_hs: float
    hs_conf: float
    o_opp: FloatArray | None  # (2,) opposite foot heel - toe offset (walker frame)
    o_fallback: bool
    t_end: float | None = None  # closing time: opposite toe off (or None)


@dataclass(frozen=True)
class _DriftFit:
    """A planted toe's linear fit over time (walker frame, xy): ``mean`` at time ``centre``, drifting at ``slope``
    (m/s); ``n_eff``: the effective number of frames behind it, ``(Σw)² / Σw²``."""

    mean: FloatArray
    slope: FloatArray
    centre: float
    n_eff: float

    def at(self, t: FloatArray | float) -> FloatArray:
        """The fitted position at time(s) ``t``: ``(2,)`` for a scalar, ``(len(t), 2)`` for an array."""
        dt = np.asarray(t, dtype=np.float64) - self.centre
        return self.mean + (dt[..., None] if dt.ndim else dt) * self.slope


@dataclass
class _FootHistory:
    hs: list[float] = field(default_factory=list)
    to: list[float] = field(default_factory=list)
    to_unseen: set[float] = field(default_factory=set)  # the toe offs in ``to`` the tracker did not see

    def seen_to(self, t: float | None) -> bool:
        """Whether toe off ``t`` (one of ``to``) was seen; False for None (no toe off)."""
        return t is not None and t not in self.to_unseen


# --------------------------------------------------------------------------------------
# analyzer


class GaitAnalyzer:
    """Online heel-strike / toe-off detection and step metrics.

    Call :meth:`update` once per frame in strictly increasing stamp order, optionally
    :meth:`update_odometry` whenever odometry arrives, :meth:`finish` at the end of a
    recording.  Results are returned as they are finalised (events typically
    ``smoothing_half_window_s + event_fit_post_s + rest_window_s`` late, steps
    ``landing_toe_fit_s`` after the following double support ends, at most ``double_support_max_s +
    landing_toe_fit_s`` after their heel strike), stamped with
    their interpolated true times.
    """

    _BUFFERS = ("_t", "_q", "_valid", "_raw", "_ankle", "_vis", "_rot", "_off", "_smooth", "_track", "_track_seen",
                "_ground", "_weight")
    """Per-frame arrays (first axis = buffer index), grown and trimmed together."""

    def __init__(self, config: GaitConfig | None = None) -> None:
        self.config = config or GaitConfig()
        cap = 1024
        self._n = 0
        self._t = np.zeros(cap)
        self._q = np.zeros(cap)
        self._valid = np.zeros(cap, dtype=bool)
        self._raw = np.full((cap, 2, 2, 3), np.nan)  # walker frame [foot, heel/toe, xyz]
        self._ankle = np.full((cap, 2, 3), np.nan)  # walker frame [foot, xyz]
        self._vis = np.ones((cap, 2))  # foot segment visibility reported by the tracker (1 when unknown)
        self._rot = np.zeros((cap, 3, 3))
        self._off = np.zeros((cap, 3))
        self._smooth = np.full((cap, 2, 2, 3), np.nan)
        self._track = np.full((cap, 2, 2, 2), np.nan)  # world-ish relative tracks (xy)
        # the same with the ground always seen through the planted foot's tracked points, hidden or not (where the
        # strike's fit window ends)
        self._track_seen = np.full((cap, 2, 2, 2), np.nan)
        self._ground_vel: FloatArray | None = None  # running mean ground velocity under feet in view (xy, m/s)
        self._ground = np.full((cap, 2), np.nan)  # cumulative ground motion in walker frame
        self._weight = np.zeros((cap, 2, 2))
        self._next_proc = 0  # next buffer index to run the state machine on
        self._last_k: int | None = None  # last processed valid frame
        self._baseline = np.full((2, 2), np.nan)
        self._baseline_age = 10**9
        self._state = GaitState.INIT
        self._anchor = np.full((2, 2), np.nan)  # toe rest position per foot (track xy)
        self._swing_heel_anchor = np.full(2, np.nan)
        self._swing_start_t = float("nan")
        self._swing_to_t = float("nan")
        self._rest_time = np.zeros(2)
        self._landed_t = np.full(2, -math.inf)  # detection time of each foot's last heel strike
        self._o_sum = np.zeros((2, 2))
        self._o_n = np.zeros(2)
        self._o_best = [None, None]  # type: list[tuple[float, FloatArray] | None]
        self._oa_sum = np.zeros((2, 2))  # heel - ankle offset (xy) of each flat foot, summed
        self._oa_n = np.zeros(2)
        self._pending_hs: list[_PendingHS] = []
        self._pending_steps: list[_PendingStep] = []
        self._feet = [_FootHistory(), _FootHistory()]
        self._footprint: list[FloatArray | None] = [None, None]
        self._fp_heading: list[FloatArray | None] = [None, None]  # each footprint's heel-to-toe direction (chain frame)
        self._strides: list[FloatArray] = []
        self._steps: list[Step] = []
        self._events: list[GaitEvent] = []
        self._step_walking: list[bool] = []
        self._odo: list[tuple[float, float, float, float]] = []
        self._lost: list[tuple[float, float]] = []
        self._out_events: list[GaitEvent] = []
        self._out_steps: list[Step] = []
        self._finished = False

    # ------------------------------------------------------------------ public API

    @property
    def state(self) -> GaitState:
        """Current phase of the state machine (lags the input by the smoothing window)."""
        return self._state

    @property
    def steps(self) -> list[Step]:
        """All steps emitted so far."""
        return list(self._steps)

    @property
    def events(self) -> list[GaitEvent]:
        """All events emitted so far."""
        return list(self._events)

    @property
    def lost_intervals(self) -> list[tuple[float, float]]:
        """Tracking gaps longer than ``max_gap_s`` (start, end stamps, s) that reset detection."""
        return list(self._lost)

    def frame_quality(self, pose: LegPose, floor: FloorPlane) -> float:
        """Quality ``q`` (0..1) of one frame, the basis of all confidences.

        ``q = 0`` when the status is NO_USER/SEARCHING, a heel/toe point is not finite or the
        floor normal is not finite (the frame is then a gap and is not used); otherwise
        ``q = clip(confidence, 0, 1)``, multiplied by ``degraded_quality`` when the status is
        DEGRADED, the confidence is below ``min_confidence`` or the floor is marked invalid.
        """
        pts = np.asarray(pose.points, dtype=np.float64)
        if pose.status not in (TrackStatus.TRACKING, TrackStatus.DEGRADED):
            return 0.0
        if not np.all(np.isfinite(pts[:, [HEEL, TOE], :])):
            return 0.0
        if not np.all(np.isfinite(np.asarray(floor.normal, dtype=np.float64))) or not math.isfinite(floor.offset):
            return 0.0
        conf = float(pose.confidence) if math.isfinite(pose.confidence) else 0.0
        q = min(max(conf, 0.0), 1.0)
        if pose.status == TrackStatus.DEGRADED or conf < self.config.min_confidence or not floor.valid:
            q *= self.config.degraded_quality
        return q

    def update_odometry(self, stamp: float, x: float, y: float, yaw: float) -> None:
        """Optional walker odometry: base pose (m, m, rad) in a fixed world frame at ``stamp`` (s).

        When given, step vectors are rotated into the odometry world frame (so turning walks
        keep a consistent footprint map) and the line of progression falls back to the
        odometry heading.  Samples must come in time order.
        """
        if self._odo and stamp <= self._odo[-1][0]:
            return
        if not all(math.isfinite(v) for v in (stamp, x, y, yaw)):
            raise GaitInputError("odometry values must be finite")
        self._odo.append((float(stamp), float(x), float(y), float(yaw)))

    def update(self, pose: LegPose, floor: FloorPlane) -> tuple[list[GaitEvent], list[Step]]:
        """Feed one frame; returns ``(events, steps)`` finalised during this call (time order)."""
        if self._finished:
            raise GaitInputError("update() called after finish()")
        pts = np.asarray(pose.points, dtype=np.float64)
        if pts.shape != (2, 5, 3):
            raise GaitInputError(f"LegPose.points must have shape (2, 5, 3), got {pts.shape}")
        stamp = float(pose.stamp)
        if not math.isfinite(stamp):
            raise GaitInputError("LegPose.stamp must be finite")
        if self._n and stamp <= self._t[self._n - 1]:
            raise StampOrderError(f"stamps must increase: {stamp} after {self._t[self._n - 1]}")
        q = self.frame_quality(pose, floor)
        vis = np.ones(2)
        if pose.visibility is not None:
            v = np.asarray(pose.visibility, dtype=np.float64)
            if v.shape == (2, 3):
                vis = np.where(np.isfinite(v[:, 2]), np.clip(v[:, 2], 0.0, 1.0), 1.0)
        self._append(stamp, q, pts, floor, vis)
        self._advance(horizon=stamp - self.config.smoothing_half_window_s)
        return self._drain()

    def finish(self) -> tuple[list[GaitEvent], list[Step]]:
        """Flush: analyse the remaining frames and close pending events/steps."""
        if not self._finished:
            self._finished = True
            self._advance(horizon=math.inf)
            self._flush_pending(final=True)
        return self._drain()

    def summary(self, *, window_s: float | None = None, steps: Sequence[Step] | None = None,
                checked: bool = False) -> GaitSummaryData:
        """Summary of the whole session (``window_s=None``) or of the last ``window_s`` seconds; of ``steps`` (in
        time order) instead of the analyzer's own where given.  ``checked``: the steps were checked against two
        tracking passes (:func:`walker_gait.core.smoothing.check_against_passes`), whose doubt leaves a step's length
        out of the spatial means but not out of the gait speed (the walking steps of the cadence count there)."""
        steps = list(self._steps if steps is None else steps)
        scope = GaitSummaryData.SESSION
        if window_s is not None:
            if not (math.isfinite(window_s) and window_s > 0):
                raise GaitInputError(f"window_s must be positive, got {window_s}")
            scope = GaitSummaryData.WINDOW
            if steps:
                t_last = steps[-1].stamp
                steps = [s for s in steps if s.stamp >= t_last - window_s]
        return summarize_steps(
            steps,
            scope=scope,
            window_duration=0.0 if window_s is None else float(window_s),
            max_step_time_s=self.config.max_step_time_s,
            min_confidence=self.config.summary_min_confidence,
            min_time_confidence=self.config.summary_min_time_confidence,
            max_step_time_ratio=self.config.summary_max_step_time_ratio,
            min_speed_confidence=self.config.summary_min_time_confidence if checked else None,
        )

    # ------------------------------------------------------------------ buffer

    def _grow(self) -> None:
        cap = self._t.size * 2
        for name in self._BUFFERS:
            old = getattr(self, name)
            new = np.zeros((cap,) + old.shape[1:], dtype=old.dtype)
            if old.dtype.kind == "f" and name not in ("_t", "_q", "_vis", "_rot", "_off", "_weight"):
                new[...] = np.nan
            new[: self._n] = old[: self._n]
            setattr(self, name, new)

    def _trim(self) -> None:
        """Drop frames older than ``history_s`` (keeps indices consistent)."""
        t_now = self._t[self._n - 1]
        cut = int(np.searchsorted(self._t[: self._n], t_now - self.config.history_s))
        cut = min(cut, self._next_proc - 1, (self._last_k or 0))
        for p in self._pending_hs:
            cut = min(cut, p.k_det - 200)
        if cut < 256:
            return
        for name in self._BUFFERS:
            arr = getattr(self, name)
            arr[: self._n - cut] = arr[cut : self._n]
        self._n -= cut
        self._next_proc -= cut
        if self._last_k is not None:
            self._last_k -= cut
        for p in self._pending_hs:
            p.k_det -= cut

    def _append(self, stamp: float, q: float, pts: FloatArray, floor: FloorPlane, vis: FloatArray) -> None:
        if self._n >= self._t.size:
            self._trim()
            if self._n >= self._t.size:
                self._grow()
        k = self._n
        self._n += 1
        self._t[k] = stamp
        self._q[k] = q
        self._valid[k] = q > 0
        self._vis[k] = vis
        self._smooth[k] = np.nan
        self._track[k] = np.nan
        self._track_seen[k] = np.nan
        self._ground[k] = np.nan
        self._weight[k] = 0.0
        if q > 0:
            rot, off = floor.walker_transform()
            self._rot[k] = rot
            self._off[k] = off
            cam = pts[:, [HEEL, TOE], :]
            self._raw[k] = cam @ rot.T + off
            self._ankle[k] = pts[:, ANKLE, :] @ rot.T + off
        else:
            self._raw[k] = np.nan
            self._ankle[k] = np.nan

    # ------------------------------------------------------------------ main loop

    def _advance(self, *, horizon: float) -> None:
        h = self.config.smoothing_half_window_s
        while self._next_proc < self._n and self._t[self._next_proc] <= horizon:
            k = self._next_proc
            self._next_proc += 1
            if self._valid[k]:
                self._smooth_frame(k, h)
                self._process(k)
        self._flush_pending(final=False, horizon=horizon)

    def _smooth_frame(self, k: int, h: float) -> None:
        t0 = self._t[k]
        lo = int(np.searchsorted(self._t[: self._n], t0 - h - 1e-9))
        hi = int(np.searchsorted(self._t[: self._n], t0 + h + 1e-9, side="right"))
        sel = np.nonzero(self._valid[lo:hi])[0] + lo
        val = _local_quadratic(self._t[sel], self._raw[sel].reshape(sel.size, -1), t0)
        self._smooth[k] = self._raw[k] if val is None else val.reshape(2, 2, 3)

    def _update_baseline(self, k: int) -> None:
        self._baseline_age += 1
        if self._baseline_age < 10 and np.all(np.isfinite(self._baseline)):
            return
        self._baseline_age = 0
        lo = int(np.searchsorted(self._t[: self._n], self._t[k] - self.config.baseline_window_s))
        z = self._raw[lo : k + 1, :, :, 2][self._valid[lo : k + 1]]
        if z.shape[0]:
            self._baseline = np.percentile(z, self.config.baseline_percentile, axis=0)

    def _weights(self, k: int) -> FloatArray:
        c = self.config
        lift = self._smooth[k, :, :, 2] - self._baseline - c.plant_height_margin_m
        return np.clip(1.0 - np.maximum(lift, 0.0) / c.plant_height_tol_m, 0.0, 1.0)

    def _reset(self, *, t_from: float, t_to: float) -> None:
        self._lost.append((t_from, t_to))
        self._state = GaitState.INIT
        self._anchor[:] = np.nan
        self._pending_hs.clear()
        for ps in self._pending_steps:  # close with what was seen before the gap
            if ps.t_end is None:
                ps.t_end = t_from
        self._feet = [_FootHistory(), _FootHistory()]
        self._footprint = [None, None]
        self._fp_heading = [None, None]
        self._o_sum[:] = 0
        self._o_n[:] = 0
        self._o_best = [None, None]
        self._oa_sum[:] = 0
        self._oa_n[:] = 0
        self._ground_vel = None

    def _process(self, k: int) -> None:
        c = self.config
        kp = self._last_k
        if kp is not None and self._t[k] - self._t[kp] > c.max_gap_s:
            self._flush_pending(final=False, horizon=math.inf, before=self._t[kp] + 1e-9)
            self._reset(t_from=float(self._t[kp]), t_to=float(self._t[k]))
            kp = None
        self._last_k = k
        self._update_baseline(k)
        w = self._weights(k)
        self._weight[k] = w
        if kp is None:
            self._track[k] = self._smooth[k, :, :, :2]
            self._track_seen[k] = self._track[k]
            self._ground[k] = 0.0
            self._o_accumulate(k, w)
            return
        delta = self._smooth[k, :, :, :2] - self._smooth[kp, :, :, :2]  # (2, 2, 2)
        wm = 0.5 * (w + self._weight[kp])
        # g[f]: displacement of the ground seen through foot f's planted points.  A foot with no planted
        # point (swinging) sees the ground through the other foot instead, so that the planted foot's
        # track stays put instead of following the swing; with neither planted, the toe (as before).
        g = np.full((2, 2), np.nan)
        ws = wm.sum(axis=1)
        for f in range(2):
            if ws[f] > 1e-3:
                g[f] = (wm[f, :, None] * delta[f]).sum(axis=0) / ws[f]
        for f in range(2):
            if not ws[f] > 1e-3:
                g[f] = g[1 - f] if ws[1 - f] > 1e-3 else delta[f, _T]
        self._track_seen[k] = self._track_seen[kp] + delta - g[::-1][:, None, :]
        self._ground_through_hidden(k, kp, g, planted=ws > 1e-3)
        self._track[k] = self._track[kp] + delta - g[::-1][:, None, :]
        if self._state == GaitState.SWING_LEFT:
            gg = g[Side.RIGHT]
        elif self._state == GaitState.SWING_RIGHT:
            gg = g[Side.LEFT]
        else:
            gg = g.mean(axis=0)
        self._ground[k] = self._ground[kp] + gg
        self._o_accumulate(k, w)
        self._step_state(k)

    def _ground_through_hidden(self, k: int, kp: int, g: FloatArray, *, planted: NDArray[np.bool_]) -> None:
        """Update the running ground velocity from the planted feet seen in frames kp and k, and put it (in place, in
        ``g``) for a planted foot that is hidden in either frame and whose tracked displacement differs from it by more
        than ``hidden_ground_gate_mps`` (see :class:`GaitConfig`)."""
        dt = float(self._t[k] - self._t[kp])
        if not dt > 0:
            return
        seen = (self._vis[k] >= _SEEN_VISIBILITY) & (self._vis[kp] >= _SEEN_VISIBILITY)
        gain = 1.0 - math.exp(-dt / _GROUND_VELOCITY_TAU_S)
        for f in range(2):
            if planted[f] and seen[f]:
                v = g[f] / dt
                self._ground_vel = v if self._ground_vel is None else self._ground_vel + gain * (v - self._ground_vel)
        if self._ground_vel is None or not math.isfinite(self.config.hidden_ground_gate_mps):
            return
        for f in range(2):
            if planted[f] and not seen[f] and float(np.hypot(*(g[f] / dt - self._ground_vel))) > \
                    self.config.hidden_ground_gate_mps:
                g[f] = self._ground_vel * dt

    # ------------------------------------------------------------------ state machine

    def _window_start(self, k: int, x: FloatArray) -> int | None:
        """First valid frame with finite ``x`` (per-frame series) in the rest window ending at k, or None
        when the window has < 2 such frames or they span < half of it."""
        c = self.config
        j = int(np.searchsorted(self._t[:k], self._t[k] - c.rest_window_s - 1e-9))
        idx = np.nonzero(self._valid[j : k + 1] & np.isfinite(x[j : k + 1]))[0] + j
        if idx.size < 2 or self._t[k] - self._t[idx[0]] < 0.5 * c.rest_window_s:
            return None
        return int(idx[0])

    def _rest_speed(self, k: int, foot: int, point: int) -> float:
        """Mean horizontal speed (m/s) of a relative track over the rest window ending at k."""
        i = self._window_start(k, self._track[:, foot, point, 0])
        if i is None:
            return math.inf
        d = self._track[k, foot, point] - self._track[i, foot, point]
        return float(np.hypot(*d) / (self._t[k] - self._t[i]))

    def _advance_speed(self, k: int, foot: int, direction: FloatArray, *, track: FloatArray | None = None) -> float:
        """Mean speed (m/s) of the heel track (``self._track`` unless given) along ``direction`` over the rest window
        (may be < 0)."""
        track = self._track if track is None else track
        i = self._window_start(k, track[:, foot, _H, 0])
        if i is None:
            return math.inf
        d = track[k, foot, _H] - track[i, foot, _H]
        lateral = abs(d[0] * direction[1] - d[1] * direction[0])
        along = float(d @ direction)
        return max(along, lateral) / float(self._t[k] - self._t[i])

    def _walker_speed(self, k: int, foot: int, point: int, direction: FloatArray) -> float:
        """Speed (m/s) of a smoothed point along ``direction`` in the walker frame over the rest window
        (a planted point moves backwards at the walker's speed, a swinging one forwards)."""
        i = self._window_start(k, self._smooth[:, foot, point, 0])
        if i is None:
            return math.nan
        d = self._smooth[k, foot, point, :2] - self._smooth[i, foot, point, :2]
        return float(d @ direction) / float(self._t[k] - self._t[i])

    def _progression_dir(self, fallback: FloatArray | None = None) -> FloatArray:
        """Unit line of progression in the walker frame (xy); without a stride ``fallback`` if given, else the walker's
        axis."""
        if self._strides:
            v = np.sum(self._strides[-self.config.progression_strides :], axis=0)
            n = np.hypot(*v)
            if n > 1e-6:
                v = v / n
                if self._odo:  # strides are in the odometry world frame: back to walker frame
                    yaw = self._walker_yaw(self._t[self._n - 1])
                    v = _rot2(-yaw) @ v
                return v
        return np.array([-1.0, 0.0]) if fallback is None else fallback

    def _step_state(self, k: int) -> None:
        c = self.config
        t = float(self._t[k])
        at_rest = np.array(
            [[self._rest_speed(k, f, p) < c.rest_speed_mps for p in range(2)] for f in range(2)]
        )
        if self._state == GaitState.INIT:
            if at_rest[0].any() and at_rest[1].any():
                self._state = GaitState.DOUBLE_SUPPORT
                self._anchor = self._track[k, :, _T].copy()
                self._rest_time[:] = t  # both feet at rest now (not at some time before the track began)
            return
        if self._state == GaitState.DOUBLE_SUPPORT:
            u = self._progression_dir()
            best, best_score, best_dist = -1, -math.inf, 0.0
            for f in range(2):
                if at_rest[f, _T] or not np.all(np.isfinite(self._anchor[f])):
                    self._anchor[f] = self._track[k, f, _T]
                    self._rest_time[f] = t
                    continue
                if t - self._landed_t[f] < c.min_stance_time_s:
                    continue
                d = self._track[k, f, _T] - self._anchor[f]
                # forward motion relative to the other foot, plus toe lift (the stance foot's
                # toe stays on the floor until its own toe off)
                toe_lift = max(float(self._smooth[k, f, _T, 2] - self._baseline[f, _T]), 0.0)
                score = float(d @ u) + toe_lift
                if score > best_score:
                    best, best_score, best_dist = f, score, float(d @ u)
            if best >= 0 and best_score > 0 and best_dist >= c.min_swing_distance_m:
                self._start_swing(k, best)
            return
        # swing of foot a, b planted
        a = 0 if self._state == GaitState.SWING_LEFT else 1
        if t - self._swing_start_t > c.max_swing_time_s:
            self._state = GaitState.INIT
            return
        moved = float(np.hypot(*(self._track[k, a, _H] - self._swing_heel_anchor)))
        # on the floor = the heel within `hs_height_tol_m` of its baseline, or the toe planted: a tracker
        # that pitches a planted foot toe-down (from the front the shoe's top hides the heel) holds its
        # heel centimetres up for a whole stance, and a foot landing toe-first is down before its heel
        low = self._heel_low(k, a)
        sw_dir = self._track[k, a, _H] - self._swing_heel_anchor
        sw_dir = sw_dir / max(float(np.hypot(*sw_dir)), 1e-9)
        # landed = the heel no longer advances relative to the other foot; if the other foot
        # already lifts off, the relative track moves *backwards*, which also counts as landed.
        # Walking has no flight phase: once the other foot has left the floor (its toe lifted and moving
        # forward faster than the walker) while this foot is down and its heel is not moving forward,
        # this foot has landed, even if tracker noise on the other foot's toe kept the relative track
        # from coming to rest during the short double support (afterwards that track follows the other
        # foot's swing and never rests).  Checked in the walker frame, independent of the relative
        # tracks.  The other foot's heel is not asked to be lifted: a tracked swinging heel often stays
        # within the planted band (the model foot pitched toe-up), and at gait initiation, with double
        # support as short as four frames, that cost the first steps.
        other_lifted = self._other_lifted(k, a, self._progression_dir())
        swung = moved >= c.min_swing_distance_m and t - self._swing_to_t >= c.min_swing_time_s
        if swung and (
            (self._advance_speed(k, a, sw_dir) < c.rest_speed_mps and (low or at_rest[a, _T]))
            or (other_lifted and low)
        ):
            d = self._track[k, a, _H] - self._swing_heel_anchor
            swing = dict(
                heel_anchor=self._swing_heel_anchor.copy(), start_t=self._swing_start_t, landed_t=self._landed_t[a],
                anchor=self._anchor.copy(), rest_time=self._rest_time.copy(), o_sum=self._o_sum[a].copy(),
                o_n=self._o_n[a], o_best=self._o_best[a],
            )
            self._pending_hs.append(
                _PendingHS(side=a, k_det=k, t_det=t, t_to=self._swing_to_t, direction=d / max(np.hypot(*d), 1e-9),
                           swing=swing)
            )
            self._state = GaitState.DOUBLE_SUPPORT
            self._landed_t[a] = t
            self._anchor = self._track[k, :, _T].copy()
            self._rest_time[:] = t - c.rest_window_s
            self._o_sum[a] = 0.0
            self._o_n[a] = 0
            self._o_best[a] = None

    def _heel_low(self, k: int, a: int) -> bool:
        """Foot ``a`` on the floor at frame k: its heel within ``hs_height_tol_m`` of its baseline, or its toe planted."""
        return bool(self._smooth[k, a, _H, 2] - self._baseline[a, _H] < self.config.hs_height_tol_m) or bool(
            self._weight[k, a, _T] >= 0.5)

    def _other_lifted(self, k: int, a: int, u: FloatArray) -> bool:
        """At frame k the other foot's toe is lifted and moves forward in the walker frame while foot ``a``'s heel
        does not (foot ``a`` has landed: walking has no flight phase)."""
        rest = self.config.rest_speed_mps
        return (bool(self._weight[k, 1 - a, _T] < 0.5) and self._walker_speed(k, 1 - a, _T, u) > rest
                and self._walker_speed(k, a, _H, u) < rest)

    def _start_swing(self, k: int, a: int) -> None:
        """Toe off of foot ``a`` confirmed at frame k: time it, emit it, enter swing."""
        c = self.config
        b = 1 - a
        # the other foot's heel strike must be final first (it bounds this toe off)
        if any(p.side == b for p in self._pending_hs):
            for p in [p for p in self._pending_hs if p.side == b]:
                self._finish_hs(p)
            self._pending_hs = [p for p in self._pending_hs if p.side != b]
        t_conf = float(self._t[k])
        t_rest = float(self._rest_time[a])
        lo_t = min(t_rest, t_conf) - c.event_fit_pre_s
        t_hs_b = self._feet[b].hs[-1] if self._feet[b].hs else -math.inf
        t_hs_a = self._feet[a].hs[-1] if self._feet[a].hs else -math.inf
        # the toe off comes after the other foot's last strike (which opened the double support) and after its own
        # foot's last landing
        tc_lo = max([lo_t] + [t for t in (t_hs_a, t_hs_b) if t < t_conf])
        idx = self._valid_range(lo_t, t_conf)
        d = self._track[k, a, _T] - self._anchor[a]
        u = d / max(float(np.hypot(*d)), 1e-9)
        tt = self._t[idx]
        rel = self._raw[idx, a, _T, :2] - self._raw[idx, b, _H, :2]
        # the other foot's heel is the horizontal reference only once it is planted
        horiz = np.where((tt < t_hs_b) | (self._weight[idx, b, _H] < 0.5), np.nan, rel @ u)
        chans = [self._raw[idx, a, _T, 2], horiz]
        drift: tuple[int, ...] = ()
        if c.to_walker_frame:
            # the toe's own walker-frame position along the swing instead of its height: planted, it moves back with
            # the floor (a free linear drift), then forward; a tracked toe is raised early in the heel rise
            chans = [horiz, self._raw[idx, a, _T, :2] @ u]
            drift = (1,)
        t_to = _hinge_time(tt, chans, rising=True, tc_lo=tc_lo, tc_hi=t_conf, drift=drift)
        if not math.isfinite(t_to):
            t_to = t_rest
        # the end of a hover (the strike withdrawn) is no toe off: the swing goes on, its next heel strike searched
        # after this time
        if not self._withdraw_hover(a, t_to):
            seen = self._seen_at(a, t_to, k)
            conf = self._event_conf(t_to) * (1.0 if seen else c.unseen_event_confidence)
            pos = self._cam_at(t_to, a, _T)
            ev = GaitEvent(stamp=t_to, side=Side(a), kind=EventKind.TOE_OFF, position=pos, confidence=conf)
            self._emit_event(ev)
            self._feet[a].to.append(t_to)
            if not seen:
                self._feet[a].to_unseen.add(t_to)
            for ps in self._pending_steps:  # opposite toe off closes the double support of a's step
                if ps.t_end is None and ps.side == b:
                    ps.t_end = t_to
        self._state = GaitState.SWING_LEFT if a == 0 else GaitState.SWING_RIGHT
        self._swing_heel_anchor = self._anchor_heel(k, a, t_rest)
        self._swing_start_t = t_conf
        self._swing_to_t = t_to

    def _seen_at(self, a: int, t_e: float, k: int) -> bool:
        """Whether foot ``a`` was in view around time ``t_e`` (frames up to ``k``), as
        :attr:`GaitConfig.toe_off_seen_gap_s` says."""
        gap = self.config.toe_off_seen_gap_s
        if gap <= 0:
            return True
        start = t_e - TOE_OFF_SEEN_BEFORE_S
        idx = self._valid_range(start, t_e + TOE_OFF_SEEN_BEFORE_S)
        tt = self._t[idx[(idx <= k) & (self._vis[idx, a] >= _SEEN_VISIBILITY)]]
        after = tt[tt >= t_e]
        if not after.size:
            return False
        marks = np.concatenate([[start], tt[tt <= after[0]]])
        return bool(np.max(np.diff(marks)) <= gap)

    def _anchor_heel(self, k: int, a: int, t_rest: float) -> FloatArray:
        j = int(np.searchsorted(self._t[: k + 1], t_rest))
        j = min(j, k)
        while j > 0 and not np.isfinite(self._track[j, a, _H, 0]):
            j -= 1
        return self._track[j, a, _H].copy()

    # ------------------------------------------------------------------ foot-flat offset

    def _o_accumulate(self, k: int, w: FloatArray) -> None:
        """Accumulate each stance foot's heel-minus-toe offset while it is flat."""
        for f in range(2):
            if self._state in (GaitState.SWING_LEFT, GaitState.SWING_RIGHT) and self._state - 2 == f:
                continue
            off = self._raw[k, f, _H, :2] - self._raw[k, f, _T, :2]
            score = float(min(w[f, _H], w[f, _T]))
            if score >= 0.7:
                self._o_sum[f] += off
                self._o_n[f] += 1
                oa = self._raw[k, f, _H, :2] - self._ankle[k, f, :2]
                if np.all(np.isfinite(oa)):
                    self._oa_sum[f] += oa
                    self._oa_n[f] += 1
            best = self._o_best[f]
            if best is None or score > best[0]:
                self._o_best[f] = (score, off.copy())

    def _o_get(self, f: int) -> tuple[FloatArray | None, bool]:
        if self._o_n[f] > 0:
            return self._o_sum[f] / self._o_n[f], False
        best = self._o_best[f]
        return (None, True) if best is None else (best[1], True)

    # ------------------------------------------------------------------ pending work

    def _frames(self, t_lo: float, t_hi: float) -> tuple[int, int]:
        """Buffer index range ``[lo, hi)`` of the frames stamped in ``[t_lo, t_hi]``."""
        lo = int(np.searchsorted(self._t[: self._n], t_lo - 1e-9))
        hi = int(np.searchsorted(self._t[: self._n], t_hi + 1e-9, side="right"))
        return lo, hi

    def _valid_range(self, t_lo: float, t_hi: float) -> NDArray[np.intp]:
        lo, hi = self._frames(t_lo, t_hi)
        return np.nonzero(self._valid[lo:hi])[0] + lo

    def _frame_period(self) -> float:
        n = min(self._n, 60)
        if n < 2:
            return 1.0 / 30.0
        return float(np.median(np.diff(self._t[self._n - n : self._n])))

    def _slot_quality(self, t_lo: float, t_hi: float) -> float:
        """Mean frame quality over [t_lo, t_hi], counting missing frames as 0."""
        dt = self._frame_period()
        lo, hi = self._frames(t_lo, t_hi)
        expected = max(1.0, round((t_hi - t_lo) / dt))
        got = float(self._q[lo:hi].sum())
        return float(min(1.0, got / expected))

    def _event_conf(self, t_e: float) -> float:
        return self._slot_quality(t_e - 0.15, t_e + 0.15)

    def _cam_at(self, t_e: float, f: int, p: int) -> FloatArray:
        """Camera-frame position of a point at time t_e (linear interpolation of smoothed data)."""
        idx = self._valid_range(t_e - 0.5, t_e + 0.5)
        idx = idx[np.isfinite(self._smooth[idx, f, p, 0])]
        if idx.size == 0:
            return np.full(3, np.nan)
        tt = self._t[idx]
        j = int(np.clip(np.searchsorted(tt, t_e), 1, max(1, idx.size - 1)))
        if idx.size == 1:
            k = idx[0]
            pw = self._smooth[k, f, p]
        else:
            k0, k1 = idx[j - 1], idx[j]
            a = float(np.clip((t_e - self._t[k0]) / max(self._t[k1] - self._t[k0], 1e-9), 0.0, 1.0))
            pw = (1 - a) * self._smooth[k0, f, p] + a * self._smooth[k1, f, p]
            k = k0 if a < 0.5 else k1
        rot, off = self._rot[k], self._off[k]
        return rot.T @ (pw - off)

    def _flush_pending(self, *, final: bool, horizon: float = math.inf, before: float | None = None) -> None:
        c = self.config
        t_avail = self._t[self._next_proc - 1] if self._next_proc > 0 else -math.inf
        if final:
            t_avail = math.inf
        keep: list[_PendingHS] = []
        for p in self._pending_hs:
            if t_avail >= p.t_det + c.event_fit_post_s or before is not None or final:
                if before is None and not final and self._resumed(p):
                    continue
                self._finish_hs(p)
            else:
                keep.append(p)
        self._pending_hs = keep
        keep_s: list[_PendingStep] = []
        for ps in self._pending_steps:
            limit = ps.t_hs + c.double_support_max_s
            # the landing foot's footprint needs its flat frames after the double support (`_landing_fit`)
            closed = ps.t_end is not None and t_avail >= ps.t_end + c.landing_toe_fit_s
            if closed or t_avail >= limit + c.landing_toe_fit_s or final or before is not None:
                if ps.t_end is None:
                    ps.t_end = min(limit, t_avail if math.isfinite(t_avail) else limit)
                self._finish_step(ps)
            else:
                keep_s.append(ps)
        self._pending_steps = keep_s

    def _withdraw_hover(self, a: int, t_to: float) -> bool:
        """True (and foot ``a``'s last heel strike taken back, its step not reported) when the toe off at ``t_to``
        follows that strike by less than ``min_stance_time_s`` with no heel strike of the other foot since: the
        foot did not land, it stopped mid-swing and swings on (a slow first step while the walker starts to roll:
        in the walker frame the swinging foot stands still for a few frames).  Only a strike whose step is still
        pending is taken back; its heel-strike event has gone out already."""
        c = self.config
        hs_a, hs_b = self._feet[a].hs, self._feet[1 - a].hs
        if not hs_a or not 0.0 <= t_to - hs_a[-1] < c.min_stance_time_s or (hs_b and hs_b[-1] > hs_a[-1]):
            return False
        hover = [ps for ps in self._pending_steps if ps.side == a and ps.t_hs == hs_a[-1]]
        if not hover:
            return False
        self._pending_steps = [ps for ps in self._pending_steps if ps is not hover[0]]
        hs_a.pop()
        return True

    def _resumed(self, p: _PendingHS) -> bool:
        """True (and the swing resumed) when the foot of a heel strike that is still the last thing that happened
        (heel and toe) advanced more than ``hs_resume_distance_m`` along its swing within ``event_fit_post_s`` of the
        detection and still advances at the window's end: the foot hovered mid-swing (a slow or hesitant first
        step) and swings on, so the strike is withdrawn before it is emitted."""
        c = self.config
        a = p.side
        if not (math.isfinite(c.hs_resume_distance_m) and p.swing) or self._state != GaitState.DOUBLE_SUPPORT:
            return False
        if self._landed_t[a] != p.t_det or any(q is not p for q in self._pending_hs if q.t_det > p.t_det):
            return False
        hi = int(np.searchsorted(self._t[: self._next_proc], p.t_det + c.event_fit_post_s + 1e-9))
        seg = self._track[p.k_det : hi, a]  # (n, heel / toe, xy)
        ok = np.all(np.isfinite(seg[:, :, 0]), axis=1)
        if not ok[0] or ok.sum() < 2:
            return False
        along = np.min((seg[ok] - seg[0]) @ p.direction, axis=1)  # the heel's or the toe's, whichever advanced less
        tt = self._t[p.k_det : hi][ok]
        # the whole foot still advancing at the end of the window: a tracked heel that catches up with a landed
        # foot jumps a few centimetres and stops, a tracked foot pitching down moves its heel or its toe alone;
        # a foot that swings on keeps moving
        if float(np.max(along)) <= c.hs_resume_distance_m or not (
            along[-1] - along[-2] > c.rest_speed_mps * (tt[-1] - tt[-2])
        ):
            return False
        sw = p.swing
        self._state = GaitState.SWING_LEFT if a == 0 else GaitState.SWING_RIGHT
        self._swing_heel_anchor = sw["heel_anchor"]
        self._swing_start_t = sw["start_t"]
        self._landed_t[a] = sw["landed_t"]
        self._anchor = sw["anchor"]
        self._rest_time = sw["rest_time"]
        self._o_sum[a] = sw["o_sum"]
        self._o_n[a] = sw["o_n"]
        self._o_best[a] = sw["o_best"]
        return True

    def _fit_end(self, p: _PendingHS) -> float:
        """End of a heel strike's fit window: the first frame from the detection on at which the landing heel rests
        against the tracked feet as seen (``_track_seen``: the detection as it was made before
        ``hidden_ground_gate_mps``), at most ``event_fit_post_s`` after the detection.  The detection itself may come
        earlier, with the ground taken through a hidden foot from the feet last seen: the landing heel then rests a
        frame or two after its strike, and a window ending there leaves the hinge fit too few landed frames (strikes
        timed half a frame early in the median)."""
        c = self.config
        a = p.side
        u = self._progression_dir()
        hi = int(np.searchsorted(self._t[: self._next_proc], p.t_det + c.event_fit_post_s + 1e-9))
        for k in range(p.k_det, hi):
            if self._advance_speed(k, a, p.direction, track=self._track_seen) < c.rest_speed_mps or (
                    self._other_lifted(k, a, u) and self._heel_low(k, a)):
                return float(self._t[k])
        return float(self._t[hi - 1]) if hi > p.k_det else p.t_det

    def _gap_start(self, t_lo: float, t_hi: float) -> float | None:
        """Stamp of the first frame of the last run of gap frames (no usable pose) that reaches into [t_lo, t_hi],
        or None."""
        lo, hi = self._frames(t_lo, t_hi)
        bad = np.nonzero(~self._valid[lo:hi])[0]
        if bad.size == 0:
            return None
        j = lo + int(bad[-1])
        while j > 0 and not self._valid[j - 1]:
            j -= 1
        return float(self._t[j])

    def _finish_hs(self, p: _PendingHS) -> None:
        c = self.config
        a, b = p.side, 1 - p.side
        t_end = self._fit_end(p)
        lo_t = t_end - c.event_fit_pre_s
        if math.isfinite(p.t_to):
            lo_t = max(lo_t, p.t_to + 0.5 * (t_end - p.t_to))
        gap_lo = self._gap_start(lo_t, t_end)
        if gap_lo is not None:
            # frames without a usable pose inside the window (a leg before the lens blanks the view): the strike may
            # lie in the gap; the window reaches back to the last frames seen before it (not before the toe off), or
            # the breakpoint could only fall after the gap (strikes timed up to 0.3 s late, steps unmatched)
            lo_t = min(lo_t, gap_lo - _GAP_FIT_PRE_S)
            if math.isfinite(p.t_to):
                lo_t = max(lo_t, p.t_to)
        hi_t = p.t_det + c.event_fit_post_s
        idx = self._valid_range(lo_t, hi_t)
        tt = self._t[idx]
        rel = self._raw[idx, a, _H, :2] - self._raw[idx, b, _T, :2]
        horiz = rel @ p.direction
        # the other foot's toe is the horizontal reference only while it is planted: drop
        # samples after the detection, after its toe off, or with the toe lifted
        t_to_b = max((x for x in self._feet[b].to if x > lo_t), default=math.inf)
        bad = (tt > t_end) | (tt >= t_to_b) | (self._weight[idx, b, _T] < 0.5)
        horiz = np.where(bad, np.nan, horiz)
        # the heel's height channel counts `hs_height_weight` times (residuals scale with it); without
        # the horizontal reference (other foot not planted) the height alone times the strike
        height = self._raw[idx, a, _H, 2]
        drift: tuple[int, ...] = ()
        if np.isfinite(horiz).sum() < 4:
            chans = [height]
        else:
            chans = [horiz] if c.hs_height_weight <= 0 else [height * c.hs_height_weight, horiz]
        if c.hs_walker_frame:
            own = self._raw[idx, a, _H, :2] @ p.direction
            own = np.where(tt > t_end, np.nan, own)
            if np.isfinite(own).sum() >= 4:
                chans = [own] if c.hs_height_weight <= 0 else [height * c.hs_height_weight, own]
                drift = (len(chans) - 1,)
        tc_lo = max(lo_t, p.t_to if math.isfinite(p.t_to) else lo_t)
        t_hs = _hinge_time(tt, chans, rising=False, tc_lo=tc_lo, tc_hi=t_end, drift=drift)
        if not math.isfinite(t_hs):
            t_hs = t_end - c.rest_window_s
        conf = self._event_conf(t_hs)
        pos = self._cam_at(t_hs, a, _H)
        self._emit_event(GaitEvent(stamp=t_hs, side=Side(a), kind=EventKind.HEEL_STRIKE, position=pos, confidence=conf))
        o_opp, fb = self._o_get(b)
        self._pending_steps.append(_PendingStep(side=a, t_hs=t_hs, hs_conf=conf, o_opp=o_opp, o_fallback=fb))
        # a toe off of b already confirmed after t_hs (possible with long latencies) closes it
        if self._feet[b].to and self._feet[b].to[-1] > t_hs:
            self._pending_steps[-1].t_end = self._feet[b].to[-1]
        self._feet[a].hs.append(t_hs)

    def _planted_point(self, idx: NDArray[np.intp], f: int, t_from: float, *, fit_only: bool = False,
                       late_drift: tuple[FloatArray, float] | None = None, ankle: bool = False) -> FloatArray:
        """``(len(idx), 2)`` xy (walker frame) of the toe (``ankle``: the ankle) of planted foot ``f`` at frames ``idx``.

        While a foot is planted, its points drift through the walker frame only with the walker's smooth motion.  Late in
        its stance the trailing foot is often hidden behind the leading leg; the tracker, which then
        carries it by its motion model, reports it hidden (``LegPose.visibility``) and places it
        centimetres off, mostly ahead (on synthetic sessions with baggy trousers or crossing legs, +8 to
        +16 cm at the other foot's heel strike).  The fit is local-linear over the foot's planted frames
        since ``t_from`` (toe on the floor), weighted by a Gaussian in time (``planted_fit_sigma_s``),
        the frame quality and the square of the foot's visibility, so where the foot is hidden it
        continues the drift seen before.  The result is ``v² x raw + (1 - v²) x fit`` with ``v`` the
        foot's visibility at that frame: a foot in view keeps its raw position, poses without visibility
        count as in view.  With ``fit_only`` the fit alone (frames at which the foot is known to be off the
        floor already: its raw position is no footprint).  Raw positions when the fit is off or has too little data.
        ``late_drift`` ``(v, t)``: the drift velocity (xy, m/s) of the walker frame past planted feet at time ``t``,
        later than the fit's data (from the landing foot); the fitted drift then changes linearly in time from
        the fit's own slope, at the centre of its data, to ``v`` at ``t``, and the fit follows that ramp.
        """
        series = self._ankle[:, f, :2] if ankle else self._raw[:, f, _T, :2]
        raw = series[idx]
        sigma = self.config.planted_fit_sigma_s
        if sigma <= 0 or idx.size == 0:
            return raw
        src = self._valid_range(t_from, float(self._t[idx[-1]]))
        src = src[(self._weight[src, f, _T] >= 0.5) & np.all(np.isfinite(series[src]), axis=1)]
        if src.size < 3:
            return raw
        ts = self._t[src]
        xy = series[src]
        base = np.maximum(self._vis[src, f], 0.05) ** 2 * np.maximum(self._q[src], 1e-3)
        out = raw.copy()
        for i, k in enumerate(idx):
            dt = ts - self._t[k]
            w = base * np.exp(-0.5 * (dt / sigma) ** 2)
            sw = float(w.sum())
            if sw <= 1e-12:
                continue
            mt = float(w @ dt) / sw
            var = float(w @ (dt - mt) ** 2) / sw
            mean = (w @ xy) / sw
            if var < 1e-6:  # all weight on one instant: no slope
                out[i] = mean
                continue
            slope = (w * (dt - mt)) @ (xy - mean) / (sw * var)
            out[i] = mean - mt * slope  # value at dt = 0
            lead = -mt  # time from the data's centre to the frame
            if late_drift is not None and lead > 0.0:
                # the drift ramps linearly from `slope` at the data's centre to v at t_v and stays at v after it:
                # integrated from the centre to the frame, the linear value gains (v - slope) times
                # lead^2 / (2 span) while lead <= span, lead - span / 2 after
                v, t_v = late_drift
                span = t_v - (float(self._t[k]) + mt)
                if span > 1e-3:
                    gain = lead * lead / (2.0 * span) if lead <= span else lead - 0.5 * span
                    out[i] += (v - slope) * gain
        if fit_only:
            return out
        alpha = self._vis[idx, f][:, None] ** 2  # a fully seen foot keeps its raw position
        return alpha * raw + (1.0 - alpha) * out

    def _landing_fit(self, a: int, t_lo: float, t_hi: float) -> _DriftFit | None:
        """Footprint of landing foot ``a``'s toe: a linear fit over time (xy, walker frame) of the toe in the frames
        of ``[t_lo, t_hi]`` in which the foot is flat (heel and toe in the planted band), weighted by frame quality
        and the square of the foot's visibility.

        A planted toe only drifts through the walker frame with the walker's smooth motion, and the landing foot
        comes flat only after its heel strike, so the fit (:meth:`_DriftFit.at`) reaches back into the double
        support from the frames that follow it; its slope is that drift, 0 when the weight is all at one instant.
        None with fewer than three flat frames.  With ``landing_toe_only`` and fewer than three flat frames, the
        frames with the toe planted give the fit if the toe is down within ``_TOE_DOWN_S`` of ``t_lo``, in at least
        three frames and still in the window's last frame (a foot that has landed stays down), and the fit drifts no
        faster than a walker moves.
        """
        series = self._raw[:, a, _T, :2]
        window = self._valid_range(t_lo, t_hi)
        toe_down = window[(self._weight[window, a, _T] >= 0.5) & np.all(np.isfinite(series[window]), axis=1)]
        src = toe_down[self._weight[toe_down, a, _H] >= 0.5]
        toe_only = (src.size < 3 and self.config.landing_toe_only and toe_down.size >= 3
                    and toe_down[-1] == window[-1] and float(self._t[toe_down[0]]) <= t_lo + _TOE_DOWN_S)
        if toe_only:
            src = toe_down
        if src.size < 3:
            return None
        fit = self._drift_fit(src, a)
        if toe_only and float(np.hypot(*fit.slope)) > _MAX_DRIFT_SPEED:
            return None
        return fit

    def _drift_fit(self, src: NDArray[np.intp], a: int) -> _DriftFit:
        """Weighted linear fit over time of foot ``a``'s toe (xy) in frames ``src`` (see :meth:`_landing_fit`)."""
        series = self._raw[:, a, _T, :2]
        ts = self._t[src]
        xy = series[src]
        w = np.maximum(self._vis[src, a], 0.05) ** 2 * np.maximum(self._q[src], 1e-3)
        sw = float(w.sum())
        mt = float(w @ ts) / sw
        var = float(w @ (ts - mt) ** 2) / sw
        mean = (w @ xy) / sw
        n_eff = sw * sw / float(w @ w)
        slope = np.zeros(2) if var < 1e-6 else (w * (ts - mt)) @ (xy - mean) / (sw * var)  # 1e-6: one instant
        return _DriftFit(mean=mean, slope=slope, centre=mt, n_eff=n_eff)

    def _ankle_vector(self, idx: NDArray[np.intp], a: int, b: int, ankle_b: FloatArray) -> FloatArray | None:
        """Heel-to-heel vector (xy) of feet ``a`` and ``b`` from their ankles over frames ``idx``.

        Each heel = ankle + that foot's heel-minus-ankle offset measured while the foot was flat.  A foot's
        yaw (toe-out) error moves its heel by ``lever x yaw error``; the heel-ankle lever (~5 cm) is a
        fifth of the heel-toe one, so this is the better estimate of the lateral (step width) component,
        and the ankle is the best-tracked point of the leg.  ``ankle_b``: ``(len(idx), 2)`` foot ``b``'s ankle at
        ``idx`` (the trailing foot's: from :meth:`_planted_point`'s fit where it is hidden, its heel rise taken
        out).  None when an offset is still unknown.
        """
        if self._oa_n[a] == 0 or self._oa_n[b] == 0:
            return None
        v = self._ankle[idx, a, :2] - ankle_b
        v = v[np.all(np.isfinite(v), axis=1)]
        if v.shape[0] == 0:
            return None
        return v.mean(axis=0) + self._heel_ankle_offset(a) - self._heel_ankle_offset(b)

    def _heel_ankle_offset(self, f: int) -> FloatArray:
        """Foot ``f``'s mean heel-minus-ankle offset (xy, walker frame) over its flat frames; needs ``_oa_n[f] > 0``."""
        return self._oa_sum[f] / self._oa_n[f]

    def _last_flat(self, f: int, t_lo: float, t_hi: float,
                   usable: Callable[[NDArray[np.intp]], NDArray[np.bool_]] | None = None) -> NDArray[np.intp] | None:
        """Foot ``f``'s last flat frames (heel and toe on the floor) in ``[t_lo, t_hi]`` in which the tracker saw it
        (visibility >= 0.5: a hidden foot is where its motion model put it), those within 0.3 s of the last of
        them; ``usable(r)`` (a function of the frame indices) narrows the candidates first.  None with fewer than
        three."""
        r = self._valid_range(t_lo, t_hi)
        r = r[(self._weight[r, f, _T] >= 0.5) & (self._weight[r, f, _H] >= 0.5) & (self._vis[r, f] >= 0.5)]
        if usable is not None:
            r = r[usable(r)]
        if r.size < 3:
            return None
        return r[self._t[r] >= self._t[r[-1]] - _FLAT_HEEL_SPAN_S]

    def _flat_heel(self, f: int, t_lo: float, t_hi: float) -> FloatArray | None:
        """Foot ``f``'s heel (xy, walker frame) as ``ankle + heel-ankle offset`` averaged over its last flat frames in
        view in ``[t_lo, t_hi]`` (:meth:`_last_flat`); None without them or without an offset yet."""
        if self._oa_n[f] == 0:
            return None
        r = self._last_flat(f, t_lo, t_hi, lambda r: np.all(np.isfinite(self._ankle[r, f, :2]), axis=1))
        if r is None:
            return None
        return self._ankle[r, f, :2].mean(axis=0) + self._heel_ankle_offset(f)

    def _flat_heading(self, f: int, t_lo: float, t_hi: float) -> tuple[FloatArray, float] | None:
        """Foot ``f``'s heel-to-toe direction (unit, walker frame) and horizontal length (m) over its last flat frames in
        view in ``[t_lo, t_hi]`` (:meth:`_last_flat`); None without them."""
        def usable(r: NDArray[np.intp]) -> NDArray[np.bool_]:
            v = self._raw[r, f, _T, :2] - self._raw[r, f, _H, :2]
            return np.all(np.isfinite(v), axis=1) & (np.hypot(v[:, 0], v[:, 1]) > 1e-3)

        r = self._last_flat(f, t_lo, t_hi, usable)
        if r is None:
            return None
        v = self._raw[r, f, _T, :2] - self._raw[r, f, _H, :2]
        n = np.hypot(v[:, 0], v[:, 1])
        m = (v / n[:, None]).mean(axis=0)
        nm = float(np.hypot(*m))
        return (m / nm, float(n.mean())) if nm > 1e-6 else None

    def _walker_yaw(self, t: float) -> float:
        if not self._odo:
            return 0.0
        arr = np.asarray(self._odo)
        yaw = np.unwrap(arr[:, 3])
        return float(np.interp(t, arr[:, 0], yaw)) + self.config.odometry_base_yaw_rad

    def _finish_step(self, ps: _PendingStep) -> None:
        c = self.config
        a, b = ps.side, 1 - ps.side
        t_end = float(ps.t_end) if ps.t_end is not None else ps.t_hs + c.double_support_max_s
        dt = self._frame_period()
        idx = self._valid_range(ps.t_hs, max(ps.t_hs, t_end - 0.5 * dt))
        # the other toe is the reference only while it is on the floor (a late toe-off detection must not
        # let its forward swing shorten the step)
        planted = idx[self._weight[idx, b, _T] >= 0.5]
        # none planted (heel strike timed late, after the other foot's toe off): that toe is already swinging, its
        # footprint comes from the frames in which it was planted
        fit_only = planted.size == 0
        idx = planted if planted.size else idx[:1]
        fallback = ps.o_fallback
        o = ps.o_opp
        if o is None:
            o = np.array([-0.0, 0.0])
            fallback = True
        toe_to_toe = False  # the step vector's component along the progression runs toe to toe
        # the two feet's headings (last flat frames in view): b's in its stance, a's after its strike
        hs_b = [t for t in self._feet[b].hs if t < ps.t_hs]
        feet = (self._flat_heading(a, ps.t_hs, t_end + c.landing_toe_fit_s),
                self._flat_heading(b, hs_b[-1] if hs_b else -math.inf, ps.t_hs))
        lop_fallback = None  # the line of progression before the first stride: the feet's heading, if they agree
        if not self._strides and feet[0] is not None and feet[1] is not None and (
                float(feet[0][0] @ feet[1][0]) > math.cos(math.radians(_FEET_AGREE_DEG))):
            m = feet[0][0] + feet[1][0]
            m = m / float(np.hypot(*m))
            if float(m @ np.array([-1.0, 0.0])) < math.cos(math.radians(c.progression_from_feet_deg)):
                lop_fallback = m
        o_used = False  # whether the trailing foot's flat heel-toe offset entered the step vector (heel formulas)
        lateral = None  # the step vector's component across the line of progression, from the ankles
        width_ankle_a = None  # the landing ankle for the reported width, against the trailing heel's last flat frames
        # b is the trailing foot, often hidden behind the leading leg by now: its toe comes from the frames
        # in which it was seen (see _planted_point)
        t_from = max(hs_b[-1] if hs_b else -math.inf, ps.t_hs - c.planted_fit_window_s)
        land = None  # the landing foot's toe once it is flat
        if c.planted_drift_ramp or c.landing_toe_fit_s > 0:
            land = self._landing_fit(a, ps.t_hs, t_end + c.landing_toe_fit_s)
        land_toe = land if c.landing_toe_fit_s > 0 else None
        late_drift = None
        # the landing foot's drift once it is flat: the walker's motion past planted feet then; a slope needs
        # the weight of three frames (one seen frame among hidden ones is a point, not a line) and a walker's speed
        if c.planted_drift_ramp and land is not None and land.n_eff >= 3.0 and (
                0.0 < float(np.hypot(*land.slope)) <= _MAX_DRIFT_SPEED):
            late_drift = (land.slope, land.centre)
        if idx.size:
            toe_b = self._planted_point(idx, b, t_from, fit_only=fit_only, late_drift=late_drift)
            toe_a = None if land_toe is None else land_toe.at(self._t[idx])
            if toe_a is not None:
                # toe to toe: a footprint's heel-toe offset is the same for both feet along the progression;
                # frames in which both toes are planted and a's foot is flat need no fit (the walker's
                # motion cancels), the others take a's toe from the fit
                flat = (self._weight[idx, a, _T] >= 0.5) & (self._weight[idx, a, _H] >= 0.5)
                flat &= np.all(np.isfinite(self._raw[idx, a, _T, :2]), axis=1)
                if flat.any():
                    d = (self._raw[idx[flat], a, _T, :2] - toe_b[flat]).mean(axis=0)
                else:
                    d = (toe_a - toe_b).mean(axis=0)
                toe_to_toe = True
            else:
                d = (self._raw[idx, a, _H, :2] - toe_b - o).mean(axis=0)
                o_used = True
            # the trailing ankle, hidden like its toe, continues its seen drift like it
            ankle_b = self._planted_point(idx, b, t_from, fit_only=fit_only, late_drift=late_drift, ankle=True)
            if c.heel_rise_travel and self._o_n[b] > 0 and self._oa_n[b] > 0:
                # the heel rising about the planted toe carries the ankle forward along the foot: take that back
                o_b = self._o_sum[b] / self._o_n[b]  # flat heel - toe
                toe_to_ankle = o_b - self._heel_ankle_offset(b)  # flat ankle - toe
                nrm = float(np.hypot(*o_b))
                if nrm > 1e-6:
                    axis = -o_b / nrm  # flat heel -> toe
                    travel = ((ankle_b - toe_b) - toe_to_ankle) @ axis
                    ankle_b = ankle_b - travel[:, None] * axis[None, :]
            lateral = self._ankle_vector(idx, a, b, ankle_b)
            if lateral is not None:
                ankle_a = self._ankle[idx, a, :2]
                ankle_a = ankle_a[np.all(np.isfinite(ankle_a), axis=1)]
                if ankle_a.shape[0]:
                    width_ankle_a = ankle_a.mean(axis=0)
        else:  # no frame inside the double support (very short one): nearest frame
            near = self._valid_range(ps.t_hs - 0.1, ps.t_hs + 0.1)
            if not near.size:
                # a strike timed inside a tracking gap: the first frame after the gap (the landed foot stands)
                near = self._valid_range(ps.t_hs, ps.t_hs + c.double_support_max_s)[:1]
            if near.size:
                kn = near[int(np.argmin(np.abs(self._t[near] - ps.t_hs)))]
                toe_b = self._planted_point(np.array([kn]), b, t_from, fit_only=bool(self._weight[kn, b, _T] < 0.5),
                                            late_drift=late_drift)[0]
                d = self._raw[kn, a, _H, :2] - toe_b - o
                o_used = True
                if land_toe is not None:
                    # along the line of progression toe to toe, as with a double support (the tracked heel of a
                    # strike timed this late is what went wrong); across it, heel to heel as before
                    d_toe = land_toe.at(float(self._t[kn])) - toe_b
                    u_p = self._progression_dir(lop_fallback)
                    d = d + float((d_toe - d) @ u_p) * u_p
                    toe_to_toe = True
                if np.all(np.isfinite(self._ankle[kn, a, :2])):  # the reported width as with a double support
                    width_ankle_a = self._ankle[kn, a, :2]
            else:  # tracking gap around the heel strike
                d = np.full(2, np.nan)
        width_vec = None  # heel to heel for the reported width: the trailing heel from its last flat frames
        if width_ankle_a is not None and c.width_flat_trailing_s > 0 and self._oa_n[a] > 0:
            heel_b = self._flat_heel(b, ps.t_hs - c.width_flat_trailing_s, ps.t_hs)
            if heel_b is not None:
                width_vec = width_ankle_a + self._heel_ankle_offset(a) - heel_b
        if lateral is not None and np.all(np.isfinite(d)):
            # across the line of progression, heel positions are taken from the ankles (see _ankle_vector)
            n = self._progression_dir(lop_fallback)
            n = np.array([-n[1], n[0]])
            d = d + float((lateral - d) @ n) * n
        heads = None
        if c.heading_offsets and toe_to_toe and feet[0] is not None and feet[1] is not None:
            heads = (feet[0][0], feet[1][0], 0.5 * (feet[0][1] + feet[1][1]))
        if self._odo:
            rot = _rot2(self._walker_yaw(ps.t_hs))
            d = rot @ d
            if heads is not None:
                heads = (rot @ heads[0], rot @ heads[1], heads[2])
        # footprint chain
        fp_b = self._footprint[b]
        if fp_b is None:
            fp_b = np.zeros(2)
            self._footprint[b] = fp_b
        fp_a_new = fp_b + d
        stride_vec = None
        stride_heading = 0.0  # heel-toe offsets' difference along the line between a's two footprints (heading_offsets)
        if self._footprint[a] is not None and np.all(np.isfinite(fp_a_new)):
            stride_vec = fp_a_new - self._footprint[a]
            # the line of progression comes from strides that go forward, towards the walker's front (stride_in_line):
            # one pointing back turned the line around and the state machine picked the wrong swinging foot from
            # then on; one across it left the state machine waiting for a toe moving forward along it
            forward = np.array([-1.0, 0.0])
            if self._odo:
                forward = _rot2(self._walker_yaw(ps.t_hs)) @ forward
            if stride_in_line(stride_vec, forward, min_length=c.min_swing_distance_m):
                self._strides.append(stride_vec)
                self._strides = self._strides[-max(c.progression_strides, 1) :]
        self._footprint[a] = fp_a_new
        u = self._progression_dir(lop_fallback)
        if self._odo:
            u = _rot2(self._walker_yaw(ps.t_hs)) @ u
        step_length = float(d @ u)
        if heads is not None and np.all(np.isfinite(d)):
            # heel to heel = toe to toe + the difference of the feet's heel-toe offsets along the line
            h_a, h_b, foot = heads
            step_length += _shrink(foot * float((h_b - h_a) @ u), c.heading_offset_min_m)
            if stride_vec is not None and self._fp_heading[a] is not None:
                stride_heading = _shrink(foot * float((self._fp_heading[a] - h_a) @ u), c.heading_offset_min_m)
            self._fp_heading[b] = h_b
        self._fp_heading[a] = heads[0] if heads is not None else None
        step_width = float(abs(d[0] * u[1] - d[1] * u[0]))
        if width_vec is not None and np.all(np.isfinite(d)):
            if self._odo:
                width_vec = _rot2(self._walker_yaw(ps.t_hs)) @ width_vec
            step_width = float(abs(width_vec[0] * u[1] - width_vec[1] * u[0]))
        stride_length = float(stride_vec @ u) + stride_heading if stride_vec is not None else float("nan")
        # temporal parameters from the event history
        t1 = ps.t_hs
        hs_a = [t for t in self._feet[a].hs if t < t1 - 1e-9]
        hs_b = [t for t in self._feet[b].hs if t < t1 - 1e-9]
        to_a = self._feet[a].to
        to_b = self._feet[b].to
        t_b = hs_b[-1] if hs_b else None  # previous opposite heel strike
        t_a0 = hs_a[-1] if hs_a else None  # previous same-side heel strike
        # a same-side heel strike after the last opposite one: the opposite footfall in between was not detected
        # (or this foot stepped twice), and t1 - t_b would span several steps, so this step's time is unknown
        step_time = t1 - t_b if t_b is not None and (t_a0 is None or t_a0 < t_b) else float("nan")
        stride_time = t1 - t_a0 if t_a0 is not None else float("nan")
        to_a_last = max((t for t in to_a if t < t1), default=None)
        # a toe off the tracker did not see bounds no duration (GaitConfig.toe_off_seen_gap_s)
        seen_a = self._feet[a].seen_to(to_a_last)
        swing_time = (t1 - to_a_last if seen_a and to_a_last is not None and (t_a0 is None or to_a_last > t_a0)
                      else float("nan"))
        stance = single = double = float("nan")
        if seen_a and t_a0 is not None and to_a_last is not None and t_a0 < to_a_last:
            stance = to_a_last - t_a0
            # opposite swing inside [t_a0, t1]
            to_b_in = [t for t in to_b if t_a0 < t < t1]
            if (t_b is not None and to_b_in and t_a0 < to_b_in[-1] < t_b < to_a_last
                    and self._feet[b].seen_to(to_b_in[-1])):
                single = t_b - to_b_in[-1]
                double = (to_b_in[-1] - t_a0) + (to_a_last - t_b)
        slots = self._slot_quality(t_b if t_b is not None else t1 - 1.0, t_end)
        conf = min(ps.hs_conf, slots)
        if fallback and o_used:  # an offset from frames that were not flat (toe to toe needs none)
            conf *= 0.5
        if c.landing_visibility > 0:
            seen = self._valid_range(t1 - 0.1, t1 + 0.2)
            if seen.size:
                conf *= min(1.0, float(self._vis[seen, a].mean()) / c.landing_visibility)
        if c.swing_min_quality > 0:
            swing = self._valid_range(t1 - SWING_QUALITY_BEFORE_S, t1 + 0.2)
            if swing.size and float(self._q[swing].min()) < c.swing_min_quality:
                conf *= 0.5
        if not np.all(np.isfinite(d)):
            conf = 0.0
        cfg = self.config
        if (step_length > cfg.max_step_length_m or step_length < -cfg.max_backward_step_m
                or step_width > cfg.max_step_width_m or step_time < cfg.min_step_time_s):
            conf *= cfg.implausible_quality
        step = Step(
            stamp=t1,
            side=Side(a),
            index=len(self._steps),
            step_length=step_length,
            step_width=step_width,
            step_time=float(step_time),
            stride_length=stride_length,
            stride_time=float(stride_time),
            stance_time=float(stance),
            swing_time=float(swing_time),
            single_support_time=float(single),
            double_support_time=float(double),
            confidence=float(conf),
        )
        self._steps.append(step)
        self._out_steps.append(step)

    def _emit_event(self, ev: GaitEvent) -> None:
        self._events.append(ev)
        self._out_events.append(ev)

    def _drain(self) -> tuple[list[GaitEvent], list[Step]]:
        ev = sorted(self._out_events, key=lambda e: e.stamp)
        st = sorted(self._out_steps, key=lambda s: s.stamp)
        self._out_events, self._out_steps = [], []
        return ev, st


def _shrink(x: float, by: float) -> float:
    """``x`` moved towards 0 by ``by`` (0 within it): a soft threshold."""
    return math.copysign(max(0.0, abs(x) - by), x)


def _rot2(yaw: float) -> FloatArray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s], [s, c]])


# --------------------------------------------------------------------------------------
# summary


def _mean_sd_cv(values: list[float]) -> tuple[float, float, float]:
    v = np.asarray([x for x in values if math.isfinite(x)], dtype=np.float64)
    if v.size == 0:
        return math.nan, math.nan, math.nan
    mean = float(v.mean())
    sd = float(v.std(ddof=1)) if v.size >= 2 else math.nan
    cv = 100.0 * sd / abs(mean) if math.isfinite(sd) and abs(mean) > 1e-9 else math.nan
    return mean, sd, cv


def stride_in_line(stride: FloatArray, forward: FloatArray, *, min_length: float) -> bool:
    """Whether a stride (walker frame, xy) may enter the line of progression: longer than ``min_length`` and within
    ``_STRIDE_MAX_OFF_AXIS_DEG`` of the walker's ``forward`` direction (unit).  Its user walks behind the walker,
    towards its front; a stride pointing back or across is a tracking error (a left/right swap, a junk step)."""
    n = float(np.hypot(*stride))
    return n > min_length and float(stride @ forward) > n * math.cos(math.radians(_STRIDE_MAX_OFF_AXIS_DEG))


def fitted_step_time(steps: list[Step]) -> float:
    """Mean step time (s) of ``steps``, with the end strikes of each run of heel strikes taken from a line fit.

    The steps are split into unbroken runs of heel strikes: a step continues a run when its previous heel strike
    (``stamp - step_time``) is the run's last one.  The mean step time of a run of ``n`` steps (``n + 1``
    strikes) is its first-to-last time over ``n``: it rests on the timing of its two end strikes alone, and the
    first strike after a stop or a tracking gap is the worst timed.  So for ``n >= 3`` a least-squares line fits
    the strike times against their running number, with an offset for every other strike when ``n >= 4`` (an
    asymmetric gait alternates a short and a long step), and the run's first and last strike are taken from it:
    for strikes on such a line (even or alternating steps) that is the mean step time exactly, and a timing error
    at an end enters 0.4-0.8 times as much (less in longer runs).  Runs of one or two steps keep their mean.  The runs' step times
    are averaged, weighted by ``n``.  NaN without a step with a finite, positive step time.
    """
    pool = sorted((s for s in steps if math.isfinite(s.step_time) and s.step_time > 0), key=lambda s: s.stamp)
    runs: list[list[float]] = []
    for s in pool:
        start = s.stamp - s.step_time
        if runs and abs(start - runs[-1][-1]) < 1e-6:
            runs[-1].append(s.stamp)
        else:
            runs.append([start, s.stamp])
    total = weight = 0.0
    for run in runs:
        t = np.asarray(run, dtype=np.float64)
        n = t.size - 1
        first, last = float(t[0]), float(t[-1])
        if n >= 3:
            k = np.arange(t.size, dtype=np.float64)
            cols = [np.ones_like(k), k] + ([k % 2] if n >= 4 else [])
            design = np.stack(cols, axis=1)
            coef, *_ = np.linalg.lstsq(design, t - t[0], rcond=None)
            first, last = (float(x) for x in design[[0, -1]] @ coef)  # the run's end strikes as fitted
        total += last - first  # = the run's mean step time x n
        weight += n
    return total / weight if weight > 0 else math.nan


def _ratio(a: float, b: float) -> float:
    return a / b if math.isfinite(a) and math.isfinite(b) and abs(b) > 1e-9 else math.nan


def summarize_steps(
    steps: list[Step],
    *,
    scope: int = GaitSummaryData.SESSION,
    window_duration: float = 0.0,
    max_step_time_s: float = 2.5,
    min_confidence: float = 0.0,
    min_time_confidence: float | None = None,
    max_step_time_ratio: float = math.inf,
    fit_step_rate: bool = True,
    min_speed_confidence: float | None = None,
) -> GaitSummaryData:
    """Aggregate steps into a :class:`GaitSummaryData` (definitions in docs/GAIT_METRICS.md).

    All steps count in ``step_count``/``duration``/``mean_confidence``; spatial means use steps with
    ``confidence >= min_confidence``, temporal statistics (cadence, step time, stance / swing / double-support %,
    swing symmetry) those with ``confidence >= min_time_confidence`` (default: ``min_confidence``); temporal
    statistics and speed additionally skip steps whose ``step_time`` is unknown or above ``max_step_time_s`` (gait
    initiation after a stop) or, with at least 4 such steps, above ``max_step_time_ratio`` times their median (a
    missed footfall or a hesitation inside the step).  Cadence = 60 / step time, the step time fitted to the heel
    strike times of the walking steps (:func:`fitted_step_time`; with ``fit_step_rate`` false, the mean step time:
    the walkway's definition, for ground truth); gait speed = sum of step lengths / sum of step times over the
    walking steps with ``confidence >= min_speed_confidence`` (default: ``min_confidence``; the offline two-pass
    pipeline gives ``min_time_confidence``: along an unbroken run of steps the lengths telescope to the distance
    between its end footprints, which a step doubted only for the passes' disagreement would shorten if left out);
    percentages are per-step ratios to the stride time.
    """
    nan = math.nan
    n = len(steps)
    t_cut = min_confidence if min_time_confidence is None else min_time_confidence

    def walking_steps(cut: float) -> list[Step]:
        pool = [s for s in steps if s.confidence >= cut and math.isfinite(s.step_time) and 0 < s.step_time <= max_step_time_s]
        if len(pool) >= 4 and math.isfinite(max_step_time_ratio):
            med = float(np.median([s.step_time for s in pool]))
            pool = [s for s in pool if s.step_time <= max_step_time_ratio * med]
        return pool

    good = [s for s in steps if s.confidence >= min_confidence]
    walking = walking_steps(t_cut)  # temporal statistics
    duration = (steps[-1].stamp - steps[0].stamp) if n >= 2 else (0.0 if n else nan)
    st_all = _mean_sd_cv([s.step_time for s in walking])[0]
    st_rate = fitted_step_time(walking) if fit_step_rate else st_all
    cadence = 60.0 / st_rate if math.isfinite(st_rate) and st_rate > 0 else nan
    speed_pool = walking_steps(min_confidence if min_speed_confidence is None else min_speed_confidence)
    lens = [s.step_length for s in speed_pool if math.isfinite(s.step_length)]
    times = [s.step_time for s in speed_pool if math.isfinite(s.step_length)]
    speed = float(sum(lens) / sum(times)) if times and sum(times) > 0 else nan

    def side(sd: int, attr: str, pool: list[Step]) -> tuple[float, float, float]:
        return _mean_sd_cv([getattr(s, attr) for s in pool if int(s.side) == sd])

    def pct(sd: int | None, attr: str) -> float:
        vals = [
            100.0 * getattr(s, attr) / s.stride_time
            for s in walking
            if (sd is None or int(s.side) == sd)
            and math.isfinite(getattr(s, attr))
            and math.isfinite(s.stride_time)
            and 0 < s.stride_time <= 2 * max_step_time_s
        ]
        return float(np.mean(vals)) if vals else nan

    sl = [side(i, "step_length", good) for i in range(2)]
    sw = [side(i, "step_width", good) for i in range(2)]
    stt = [side(i, "step_time", walking) for i in range(2)]
    swing_mean = [side(i, "swing_time", walking)[0] for i in range(2)]
    return GaitSummaryData(
        stamp=steps[-1].stamp if n else nan,
        scope=scope,
        window_duration=float(window_duration),
        duration=float(duration),
        step_count=n,
        cadence=float(cadence),
        gait_speed=speed,
        step_length_mean=_mean_sd_cv([s.step_length for s in good])[0],
        step_width_mean=_mean_sd_cv([s.step_width for s in good])[0],
        step_time_mean=float(st_all),
        step_length_mean_side=(sl[0][0], sl[1][0]),
        step_length_sd_side=(sl[0][1], sl[1][1]),
        step_length_cv_side=(sl[0][2], sl[1][2]),
        step_width_mean_side=(sw[0][0], sw[1][0]),
        step_width_sd_side=(sw[0][1], sw[1][1]),
        step_width_cv_side=(sw[0][2], sw[1][2]),
        step_time_mean_side=(stt[0][0], stt[1][0]),
        step_time_sd_side=(stt[0][1], stt[1][1]),
        step_time_cv_side=(stt[0][2], stt[1][2]),
        stance_percent_side=(pct(0, "stance_time"), pct(1, "stance_time")),
        swing_percent_side=(pct(0, "swing_time"), pct(1, "swing_time")),
        double_support_percent=pct(None, "double_support_time"),
        step_length_symmetry=_ratio(sl[0][0], sl[1][0]),
        swing_time_symmetry=_ratio(swing_mean[0], swing_mean[1]),
        mean_confidence=float(np.mean([s.confidence for s in steps])) if n else nan,
    )
