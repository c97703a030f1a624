"""Particle-filter leg tracker (seed paper §4) with partitioned annealed sampling.

Pipeline of one :meth:`LegTracker.update` (camera frame in, camera frame out; the model
lives in the floor-aligned *body* frame of :mod:`walker_gait.core.leg_model`):

1. foreground check: fewer than ``min_fg_points`` points, or (``presence_height``, ``default``) a
   foreground that does not show legs → ``NO_USER`` and the particle set is dropped (the next frame
   with legs re-initialises; a track coasts through ``coast_frames`` frames without foreground first, and
   goes on through ``lost_frames`` frames in a row without legs).  A frame whose foreground is left but in which
   ``blank_view_share`` of the last estimate's calf and foot pixels have no depth is coasted through likewise: a
   shin swinging past the lens, nearer than the sensor's range, blanks the view and hides both legs, and what
   foreground is left is not the user (a walker's rear wheel that the auto-centred region of interest took in:
   the model legs jumped 25 cm onto it, and one re-detection after such a blank exchanged the legs); such a frame
   does not count towards ``lost_frames`` without legs either (a leg in front of the lens is a user at the walker).
   Legs belong to a body above them, so they rise above knee height or leave the image through the border that is
   "up" for the camera, directly or (``no_depth_unknown``) through pixels without depth: a close user's thighs are
   nearer than the sensor's range (:meth:`LegTracker.legs_in_view`); a walker's rear wheel in view while its user is
   away does none of these, and without the check the tracker fitted both legs to it and the gait analyzer
   counted steps from their jitter;
2. (re-)initialisation when there is no particle set: the foreground (body frame) is split
   into two leg blobs along the anatomical left axis (2-means on y; left = +y, so identity
   is fixed by geometry), hip positions are fitted from the blobs and particles are sampled
   around a standing pose (with ``detect_calf_radius``, its calves as wide as the blobs' shins
   where those are loose fabric: :func:`_shin_radius`, :data:`SHIN_FABRIC_RADIUS`); the first
   frame is searched with ``init_rounds`` extra rounds (status ``SEARCHING``);
3. prediction: constant velocity on the 12 joint angles (eq. 3, damped by
   ``velocity_damping``), Gaussian noise on all other elements;
4. weighting / sampling: ``paper`` = one SIR step with the full likelihood (eq. 10).
   ``default`` = partitioned annealed sampling (MacCormick & Isard partitioned sampling
   combined with Deutscher's annealing, as in seed 003 §III-C, and the hierarchical
   weighting/resampling of seed 001): stages *root* (hips, pelvis, shape; both legs) →
   *left leg* → *right leg*; in each stage ``n_layers`` layers of
   diffuse-that-partition → weight (``β_layer`` × stage likelihood) → resample.  Leg stages
   use only that leg's terms, with the other leg held at the current estimate
   (``ref`` foreground costs and ref render), which removes the other leg's noise from the
   weights.  With ``fine_2d_only`` (``default``) the coarse layers weigh with the cheap 3D cue
   alone and only each stage's final layer adds the rendered 2D cue (coarse-to-fine: the
   render is ~40 % of the cost);
   Every weighting may add pose priors: from the front, a flat foot and one pitched onto its toes
   explain the same shoe front (the heel is hidden behind it), and without a prior the filter
   drifts into the tiptoe pose.  ``foot_pitch_prior_sigma`` (``default``) is a Gaussian on each
   foot's pitch against the floor (heel-to-toe line), ``foot_roll_prior_sigma`` (``default``) one on
   its sideways tilt (the sole's lateral axis against the floor), ``ankle_prior_sigma`` one on ankle flexion
   around neutral; the pitch prior also holds a planted foot flat when the shank leans forward
   or back over it (mid stance: ankle dorsiflexed), where the ankle prior tilts it.  With
   ``heel_rise_dorsiflexion`` D (``default``) its centre follows the heel rise of late stance: heel-up by the
   shank's forward lean beyond D, the ankle's dorsiflexion in gait, up to ``HEEL_RISE_MAX``, for a foot behind
   the other one whose calf is not HIDDEN (a prior centred on a flat foot held the trailing foot too flat in its
   heel rise, its toe 2-3 cm ahead of the real one);
   ``footprint_sigma`` (measured, off in both presets) is a Gaussian on the toe of a HIDDEN foot that was
   planted when last seen, around that footprint carried along by the floor's motion through the walker frame
   (measured from the planted toes in view), until the foot leaves the floor unseen: ``footprint_release_s`` after the other foot
   lands, at the latest ``footprint_max_s`` after it was last seen (``_Footprints``; held in its last pose, a
   hidden stance foot travelled with the walker, its toe 10 cm ahead after 9-15 hidden frames);
   ``feet_crossing_sigma`` (``default``) is a half-Gaussian against crossed feet: across the pelvis the
   left foot's centre lies left of the right foot's (no synthetic session's feet ever cross; tracked ones
   did in 3.5 % of the frames, up to 30 cm, and in half of those with left and right swapped);
   With ``root_compensation`` (measured, off in both presets) the root stage's random moves of the pelvis over the floor (right hip
   x/y, pelvis azimuth) come with the legs' angle change that keeps each ankle, heel, toe and lower calf where it
   was (damped least squares on the forward kinematics' Jacobian at the particles' mean, the previous frame's
   particles taking the same change so that the legs' velocity stays): the hips and knees are out of view, and a
   pelvis move that dragged the seen feet along was weighed down at once, so the pelvis stayed where the first
   frames put it (6 cm ahead of the centre of the feet, thighs 6° and knees 7° straighter than the real ones);
   moved this way it explores the poses that explain the same data, and ``pelvis_prior_sigma`` decides among them
   (hips 17 % and the hip and knee flexion angles ~35 % nearer the truth over ten sweep runs, but the seen heels and
   the step width, cadence and heel-strike timing a little worse: not the default, see DEVELOPERS.md);
   With ``elliptic_foot`` (``default``) both cues see each foot as a half-ellipse as wide as a shoe
   (``leg_model.FOOT_HALF_WIDTH``) and as tall as the foot radius instead of the paper's
   half-cylinder, which is twice as wide at the heel: the silhouette and the surface's depth
   come from the section's extent across and along the line of sight (:func:`camera_segments`);
   the half-cylinder made the filter shorten the model foot (by ~3.7 cm) to hide its too-wide heel;
5. final weights with the full likelihood; estimate = weighted mean (points and angles); with
   ``toe_from_data`` (``default``) each reported toe is then measured from the foreground around the tracked
   foot (:mod:`walker_gait.core.feet`: the front of its toe box), the particles left as they are; with
   ``flat_feet_report`` (``default``) each particle's foot that stands on the floor nearly flat is turned flat about
   its sole's contact before the mean (:func:`walker_gait.core.leg_model.flatten_feet`): every particle stands on
   the floor at its lowest point, so a spread of pitch among them lifted the mean heel, and a model foot pitched a
   few degrees to fit a shoe's upper lifted it further (flat feet's heels were reported 1.6-1.8 cm up);
6. hidden-part handling: per-segment visibility of the estimate by comparing its rendered
   depth with the observed depth, a VISIBLE/HIDDEN state machine per segment (seed 003
   fig. 7); hidden segments are left out of ``d_MF`` (carried by the dynamics) and, when a
   segment re-appears, its leg is searched with ``reappear_noise_gain`` × noise for
   ``reappear_frames`` frames.  A leg can also stay "hidden" at a wrong position: behind the other
   leg, where nothing can contradict it, while its real counterpart swings past in front (narrow
   gait); so while a leg's calf and foot are HIDDEN and the estimate leaves more than
   ``hidden_search_unexplained`` of the foreground unexplained, ``hidden_search_share`` of the
   particles draw that leg afresh from a wide range of poses before the stages weigh them
   (for ``hidden_search_frames`` frames in a row), and such a leg keeps only
   ``hidden_velocity_damping`` of its joint-angle velocity (``default``: none, it holds its pose): the
   velocity of its last seen frames, carried on through a hidden stance, ran the model foot 20-50 cm past
   the real one, which by then was swinging forward.  Neither rule acts in the frame in which the hidden foot,
   swinging past the standing one in depth (a narrow gait lines them up), comes out in front of it: its data are
   new, the seen leg is drawn with the hidden one held behind, and the seen leg takes them, the hidden one then the
   standing foot (the legs exchanged for 12-30 frames, seventy-first session).  So where a seen foot (not HIDDEN)
   whose toe stood on the floor two and three frames ago comes forward ``passing_jump`` (``default``) from there
   while the other foot is HIDDEN or went unseen in the last frame, the frame is tracked a second time: the
   standing leg started from its pose of two frames ago without velocity, the other leg drawn afresh in half of the
   particles and drawn first; each outcome's mean is weighed with every segment in the likelihood (as a
   re-detection) and a Gaussian (``passing_sigma``) on how far the standing foot came forward, and the likelier
   outcome is kept.  The second tracking draws from a stream of its own (one not kept leaves the track as it was)
   and costs a frame's tracking again where it runs (in none of set C's `normal` sessions);
7. status/confidence from the foreground support of the estimate; a lost track
   (confidence < ``lost_confidence`` for ``lost_frames`` frames) re-initialises, and so does
   a track that leaves foreground unexplained (less than ``min_explained`` of it within
   ``support_tol`` of the model for ``lost_frames`` frames: e.g. both model legs locked on the
   one leg that was in view when the user walked in, the other leg now visible), and so does a track
   one of whose legs has left the data (``lost_leg_frames``: its calf and foot out of the image or over
   background, nothing observed in front of them, for that many frames).  The hidden-part machine of
   step 6 cannot tell such a leg from a hidden one (nobody sees either) and takes it out of the
   likelihood, where nothing brings it back; with the user's legs close together the other model leg
   explains both legs' foreground, so neither the confidence nor ``min_explained`` fires (the sweep's
   absent-start and occlusion sessions: a model leg held above or beside the image, 40-70 cm off, for
   seconds).  Points over pixels without depth count as possibly hidden there, not as over nothing: a leg
   swinging close to the lens lies mostly in the hole it makes, with its knee above the image's top, and
   counting only those few points out of the image re-detected the legs mid-swing (and exchanged them);
8. re-detection (``redetect_every_s``, ``default``): that often a track that goes on is searched afresh from the
   foreground as on initialisation (``redetect_rounds`` rounds), and the fresh estimate replaces the track's when it
   scores ``redetect_margin`` higher with every segment in the likelihood.  None of the rules of step 7 fires on a
   track that is wrong but explains the foreground: a user who walked in from the side and stood at the walker
   turned 40° kept a model crouched 30 cm back with its pelvis square to the camera (the hips are out of view),
   10-35 cm off for seconds, while a search from scratch on the same frame came within 6-7 cm and scored higher.
   The search draws from a random stream of its own (spawned from ``rng``), so a re-detection that is not adopted
   leaves the track bit for bit as it would be without it.  A track that resumes after coasting (a dropout or a
   blanked view, step 1) for at least ``coast_redetect_s`` since its last tracked frame is re-detected on the frame
   it resumes on as well (``default``: 0.4 s, about a swing): the legs moved unseen meanwhile, and a user walking
   ahead of a lagging walker, a shin nearer than the sensor's range for half a second at a time, came back with the
   held model legs on the wrong leg or beside the legs for the next half second (the bench's ``walker_lag``
   session, one pass: frames off by more than 10 cm at the walker 9.8 -> 6.3 %).  Shorter coasts (a leg before the
   lens for a third of a second in ``occlusion``) resume from the held track: re-detected, they came back no better
   on average (DEVELOPERS.md, seventy-seventh session).

Left/right identity: the state keeps the left hip at +y (anatomical left) of the right hip
(``|hip_azimuth| < 0.7``) and the detection assigns blobs by the same axis, so legs cannot
swap; ``mounting`` decides how anatomical axes map to the camera
(``facing_user``: the user's left appears on the image's right, +x camera).
"""

from __future__ import annotations

import dataclasses

import math
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from walker_gait.core import kernels
from walker_gait.core import leg_model as lm
from walker_gait.core.feet import (
    ShoeRiseFit,
    ShoeTurnFit,
    ToeFit,
    across_only,
    measure_shoes,
    measure_toes,
    toes_in_view,
)
from walker_gait.core.presence import PresenceTest, legs_in_view
from walker_gait.core.leg_model import BodyFrame, Kinematics, StateLayout
from walker_gait.core.likelihood import (
    PAPER_LAMBDA_2D,
    PAPER_LAMBDA_3D,
    Cue2DParams,
    Cue3DParams,
    CueImage,
    Workspace,
    elliptic_section_radii,
    foreground_costs,
    log_likelihood_2d,
    log_likelihood_3d,
    project_bbox,
    render_depth,
    skeleton_points,
    union_bbox,
)
from walker_gait.core.resampling import effective_sample_size, normalise_log_weights, resample
from walker_gait.core.types import (
    ANKLE,
    HEEL,
    HIP,
    KNEE,
    TOE,
    CameraIntrinsics,
    FloorPlane,
    LegPose,
    TrackStatus,
)

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]
L = StateLayout

HEEL_RISE_BEHIND = 0.05
"""m: ``heel_rise_dorsiflexion`` applies in full to a foot whose ankle is this far or more behind the other ankle
(along the foot), not at all to one level with it or ahead, linearly in between."""

HEEL_RISE_MAX = 0.6
"""rad: most heel-up pitch ``heel_rise_dorsiflexion`` expects (a foot about to leave the floor, ~35 deg): a shank
leaning further is not standing on its foot (a hidden leg drawn afresh had its heel raised 30-40 cm for free)."""

FOOTPRINT_HEIGHT = 0.04
"""m: a toe this low over the floor stands on it (``footprint_sigma``)."""

FOOTPRINT_MAX_FORWARD = 0.3
"""m/s: a foot in view with its toe on the floor but moving forward (body +x) faster than this is swinging."""

_FOOTPRINT_SAMPLES = 6  # a hidden foot's footprint: the mean of its toe's last this many planted positions in view ...
_FOOTPRINT_MIN_SAMPLES = 3  # ... of which it needs this many (a lagging estimate of a swinging foot can look planted for a frame)
_FOOTPRINT_GATE = 0.2  # m: an unseen foot whose estimate is this far from its footprint has left it (or the footprint was wrong)
_PLANT_END_FRAMES = 2  # a planted run ends once its foot is seen not planted in this many frames in a row
_FLOOR_VEL_GAIN = 0.15  # per-frame gain of the floor velocity estimate (time constant ~6 frames)
_FLOOR_MAX_SPEED = 2.5  # m/s: a planted toe moving faster between two frames is a tracking jump, not the floor

Cue = Literal["3d", "2d", "combined"]

_SINGLE_LEG_SEP = 0.09  # m: leg blobs' centres closer than this are one leg split in two (shins are ~10 cm wide)
_VIS_POINTS = 10  # interior axis points per segment sampled by the visibility test
_UNSUPPORTED_MAX = 0.1  # a leg's calf + foot with at most this share of their counted axis points seen or hidden lie over nothing


_REDETECT_POINTS = 2048
"""Most foreground points a re-detection's comparison of the fresh estimate with the track's weighs."""

_PASSING_STILL = 0.01
"""m: a foot whose toe came forward at most this much over a frame stood still on the floor (``passing_jump``)."""
_PASSING_HISTORY = 3
"""Frames of the estimate the passing check keeps: the seen foot stood on the floor in the oldest two."""
_PASSING_SEARCH_SHARE = 0.5
"""Share of the particles whose hidden leg the passing check's second tracking draws afresh (``passing_jump``)."""

_COMPENSATED_ROOT = (StateLayout.ROOT_X, StateLayout.ROOT_Y, StateLayout.HIP_AZ)
"""State dims whose random moves ``root_compensation`` offsets in the legs' angles: the pelvis's place and turn over the
floor (its height follows the floor contact)."""
_COMPENSATION_CALF = 0.4
"""Point of the calf that ``root_compensation`` holds, as a fraction of the way from the ankle to the knee (the part of
the shank a camera at the walker sees)."""
_COMPENSATION_DAMPING = 1e-3
"""Damping (m²/rad²) of ``root_compensation``'s least-squares solve: a leg whose angles barely move its held points
(a straight leg's knee) is not turned far for them."""


class TrackerInputError(ValueError):
    """Malformed input to :meth:`LegTracker.update` (shapes, dtypes, invalid floor)."""


@dataclass(frozen=True, kw_only=True)
class TrackerConfig:
    """Leg tracker parameters (become ROS parameters). Units SI; noise std-devs are per frame."""

    n_particles: int = 160  # particles
    cue: Cue = "combined"  # "3d" (eq. 7), "2d" (eq. 9) or "combined" (eq. 10)
    # 3D cue
    fg_fraction: float = 0.1  # fraction of foreground points used by the 3D cue (paper 10 %)
    fg_max_points: int = 160  # cap on that number (0 = no cap)
    n_skeleton: int = 10  # interior skeleton points per segment (paper n = 10)
    lambda_3d: float = PAPER_LAMBDA_3D  # eq. 7 rate in 1/m (paper 1/5 mm^-1 = 200 m^-1)
    truncate_3d: float = math.inf  # m, per-point distance cap
    # 2D cue
    lambda_2d: float = PAPER_LAMBDA_2D  # eq. 9 rate in 1/m (paper 1/3 mm^-1 = 333 m^-1)
    cue2d_stride: int = 1  # 2D cue image = depth image / stride (paper: full 640x480), where `cue2d_focal` is 0
    cue2d_focal: float = 0.0  # px; > 0: the stride is chosen per camera instead, the smallest that brings the 2D cue image's focal length (fx / stride) to at most this, so that a cue pixel covers about the same angle with any camera (58: a Kinect v1 at 640x480 gets stride 10, a 424x240 RealSense 4, a Kinect v2 7); 0 = `cue2d_stride` as given (paper)
    truncate_2d: float = math.inf  # m, per-pixel cost cap
    # occlusion / hidden parts
    occlusion_aware: bool = False  # occlusion-aware cues (see likelihood module)
    hidden_parts: bool = False  # VISIBLE/HIDDEN state machine per segment
    no_depth_unknown: bool = False  # pixels without a depth measurement (nearer than the sensor's near limit, IR shadow, dropouts) are unknown to both cues and to the visibility test, not background: a leg there costs nothing (false: background, paper)
    hide_below: float = 0.25  # visible fraction under which a segment becomes HIDDEN
    show_above: float = 0.5  # visible fraction over which a HIDDEN segment is VISIBLE again
    reappear_noise_gain: float = 2.0  # noise gain on a leg whose segment re-appeared
    reappear_frames: int = 5  # frames the gain lasts
    hidden_search_share: float = 0.0  # share of the particles whose hidden leg (calf and foot HIDDEN) is drawn afresh from a wide range of poses while the estimate leaves more than `hidden_search_unexplained` of the foreground unexplained (0 = off, paper)
    hidden_search_unexplained: float = 0.2  # unexplained foreground share that starts that search ...
    hidden_search_frames: int = 3  # ... once it has lasted this many frames in a row
    passing_jump: float = math.inf  # m: a seen foot whose toe stood on the floor two and three frames ago and now comes forward this far from there, while the other foot is HIDDEN or went unseen in the last frame (the hidden foot swinging past it in depth may have come out in front, and the seen leg taken it), has the frame tracked a second time, the standing leg started where it stood and the other drawn afresh and first, and the likelier of the two kept (inf = off, paper)
    passing_sigma: float = 0.03  # m, std-dev of that comparison's Gaussian on how far the standing foot came forward (beyond 1 cm) from where it stood two frames ago
    hidden_leg_first: bool = False  # partitioned sampling draws a leg whose calf and foot are HIDDEN before the other one (false: left, then right, always; paper)
    root_compensation: float = 0.0  # share of the particles whose random move of the pelvis over the floor (right hip x/y, pelvis azimuth) comes with the leg-angle change that keeps each leg's ankle, heel, toe and lower calf where they were (least squares, linearised at the particles' mean), so the out-of-view hips can move without dragging the seen feet (a leg whose calf and foot are HIDDEN moves with the pelvis); the rest move the whole body as before (0 = none, paper)
    hidden_velocity_damping: float = 1.0  # factor on the joint-angle velocity of a leg whose calf and foot are HIDDEN, on top of `velocity_damping` (1 = as any leg, paper; 0 = hold its pose)
    footprint_sigma: float = math.inf  # m, Gaussian prior on the toe (floor plane) of a HIDDEN foot that was planted when last seen, around that footprint carried along by the floor's motion in the walker frame (inf = none, paper)
    footprint_sigma_growth: float = 0.1  # m/s, growth of that prior's std-dev with the time since the foot was last seen
    footprint_max_s: float = 0.5  # s, the prior ends this long after the foot was last seen ...
    footprint_release_s: float = 0.08  # s, ... or this long after the other foot landed (the double support: then the hidden foot leaves the floor)
    # sampling
    partitioned: bool = False  # root -> left leg -> right leg partitions
    n_layers: int = 1  # annealing layers per partition
    root_layers: int = 1  # layers of the root (hips/pelvis/shape) partition, <= n_layers
    anneal_betas: tuple[float, ...] = (1.0,)  # likelihood exponent per layer (last = final)
    layer_noise_decay: float = 0.5  # noise factor between successive layers
    fine_2d_only: bool = False  # combined cue: coarse annealing layers weigh with the 3D cue alone (2D cue in the final layer of each partition)
    resample_scheme: str = "systematic"
    init_rounds: int = 4  # extra search rounds (all partitions, shrinking noise) on (re-)init
    init_noise_gain: float = 3.0  # noise gain of the first search round
    detect_calf_radius: bool = False  # a search from scratch starts with the calves' radius measured across the two leg blobs' shins where that is loose fabric (at least 0.08 m: a tube of baggy trousers from the first frame), not the typical adult's (paper: always the typical)
    redetect_every_s: float = 0.0  # s between re-detections while tracking: a fresh search from the foreground, as on (re-)init, whose estimate replaces the track's where it scores `redetect_margin` higher (0 = never, paper)
    redetect_margin: float = 5.0  # log-likelihood units by which a re-detection must beat the track (5: odds of about 150 to 1)
    redetect_rounds: int = 0  # search rounds of a re-detection (0 = `init_rounds`)
    # dynamics (eq. 3 on angles, random walk elsewhere)
    velocity_damping: float = 1.0  # 1 = paper's constant velocity
    sigma_root: float = 0.015  # m, right hip x/y
    sigma_hip_dist: float = 0.003  # m
    sigma_pelvis: float = 0.02  # rad, hip azimuth / elevation
    sigma_length: float = 0.003  # m, segment lengths
    sigma_radius: float = 0.001  # m, radii
    sigma_hip: float = 0.05  # rad, hip flexion/abduction/rotation
    sigma_knee: float = 0.08  # rad
    sigma_ankle: float = 0.07  # rad
    # model
    toe_from_data: bool = False  # report each toe measured from the foreground around the tracked foot (the front of its toe box, see `feet`) instead of the model foot's end, except where the shoe may be cut by the image's border; the particles are unchanged (false: the model's, paper)
    flat_feet_report: tuple[float, float] = (0.0, 0.0)  # rad (flat_below, blend_to): a reported foot whose particles stand on the floor within `flat_feet_floor_tol` is turned flat about its lower end where pitched less than flat_below either way, blending back to its own pitch at blend_to (see `leg_model.flatten_feet`); the particles are unchanged ((0, 0) = off, paper)
    flat_feet_floor_tol: float = 0.01  # m, lowest sole corner height under which a particle's foot stands on the floor for `flat_feet_report`
    elliptic_foot: bool = False  # likelihood sees each foot as a half-ellipse as tall as its radius and 0.155 x foot length wide, like a shoe (false: the paper's half-cylinder)
    # pose prior
    ankle_prior_sigma: float = math.inf  # rad, Gaussian prior on ankle flexion around neutral (inf = none, paper)
    foot_pitch_prior_sigma: float = math.inf  # rad, Gaussian prior on each foot's pitch against the floor (inf = none, paper)
    heel_rise_dorsiflexion: float = math.inf  # rad, ankle dorsiflexion past which the foot pitch prior expects the heel to rise: its centre is heel-up by the shank's forward lean beyond this (inf = centred on a flat foot)
    foot_roll_prior_sigma: float = math.inf  # rad, Gaussian prior on each foot's sideways tilt (sole roll) against the floor (inf = none, paper)
    feet_crossing_sigma: float = math.inf  # m, half-Gaussian prior against the left foot's centre (ankle, heel, toe) lying right of the right foot's, across the pelvis (inf = none, paper)
    pelvis_prior_sigma: tuple[float, float] = (math.inf, math.inf)  # m, Gaussian prior (forward, lateral) on the pelvis (mid-hip) over the centre of the feet (mean of heels and toes): the base of support (inf = none, paper)
    # track management
    min_fg_points: int = 60  # fewer foreground points = no user
    presence_height: float = 0.0  # m; > 0: the foreground is a user only if it shows legs: `presence_share` of its points higher than this, or a part at least `presence_width` wide in the band along the image border that is "up" or reaching it through pixels without depth (a close user's legs nearer than the sensor's range; with `no_depth_unknown`) (else no user, a track ending after `lost_frames` such frames in a row: a walker's wheel alone in view; 0 = off, paper)
    presence_share: float = 0.02  # fraction of the foreground points (at least 10) above `presence_height` that shows legs
    presence_band: float = 0.04  # width of the image border band (fraction of the image) through which legs leave the view
    presence_width: float = 0.04  # m, widest foreground part in that band that shows a leg (a walker's tube is thinner)
    coast_frames: int = 0  # frames a track is held (DEGRADED, confidence 0) through a foreground dropout before it is dropped (0 = at once)
    coast_redetect_s: float = 0.0  # s; a track that resumes after coasting (`coast_frames`) for at least this long since its last tracked frame is searched afresh on the frame it resumes on and replaced where that scores `redetect_margin` higher, as a re-detection: the legs moved unseen meanwhile (0 = never, paper)
    blank_view_share: float = 1.0  # a frame in which at least this share of the tracked calves' and feet's pixels (last estimate) has no depth is a blanked view (a shin nearer than the sensor's range hides both legs): the track coasts through it like a dropout, up to `coast_frames` (1 = off, paper)
    track_confidence: float = 0.55  # confidence for TRACKING
    degraded_confidence: float = 0.4  # below: DEGRADED
    lost_confidence: float = 0.25  # below this for `lost_frames` frames: re-initialise
    lost_frames: int = 8
    min_explained: float = 0.0  # fraction of foreground the estimate must explain; below it for `lost_frames` frames: re-initialise (0 = off)
    single_leg_wait_s: float = 0.0  # s a new track waits while its foreground shows one leg (a user walking in: the other leg still outside the region of interest) before it starts on it anyway (0 = start at once, paper)
    lost_leg_frames: int = 0  # frames a leg's calf and foot may lie over nothing (out of the image or over background, nothing in front of them) before the track re-initialises (0 = off)
    support_tol: float = 0.04  # m, surface distance counted as support for the confidence
    fg_min_height: float = 0.03  # m, floor cut of the segmentation (model surface below it is unobservable)

    def __post_init__(self) -> None:
        if self.cue not in ("3d", "2d", "combined"):
            raise ValueError(f"cue must be '3d', '2d' or 'combined', got {self.cue!r}")
        if self.n_particles < 2:
            raise ValueError("n_particles must be >= 2")
        if len(self.anneal_betas) != self.n_layers:
            raise ValueError("anneal_betas needs one entry per layer")
        if self.cue2d_stride < 1:
            raise ValueError("cue2d_stride must be >= 1")
        if not (self.cue2d_focal >= 0 and math.isfinite(self.cue2d_focal)):
            raise ValueError(f"cue2d_focal must be >= 0 (0 = use cue2d_stride), got {self.cue2d_focal}")
        if not (0.0 <= self.hidden_search_share <= 1.0 and 0.0 <= self.hidden_search_unexplained < 1.0):
            raise ValueError("hidden_search_share must be in [0, 1] and hidden_search_unexplained in [0, 1), got "
                             f"{self.hidden_search_share}, {self.hidden_search_unexplained}")
        if not 0.0 < self.blank_view_share <= 1.0:
            raise ValueError(f"blank_view_share must be in (0, 1], got {self.blank_view_share}")
        if not 0.0 <= self.root_compensation <= 1.0:
            raise ValueError(f"root_compensation must be a share in [0, 1], got {self.root_compensation}")
        if not (self.redetect_every_s >= 0 and math.isfinite(self.redetect_every_s) and self.redetect_margin >= 0
                and self.redetect_rounds >= 0):
            raise ValueError("redetect_every_s must be finite and >= 0 (0 = never), redetect_margin and redetect_rounds "
                             f">= 0, got {self.redetect_every_s}, {self.redetect_margin}, {self.redetect_rounds}")
        if not (self.coast_redetect_s >= 0 and math.isfinite(self.coast_redetect_s)):
            raise ValueError(f"coast_redetect_s must be finite and >= 0 (0 = never), got {self.coast_redetect_s}")
        if not (self.passing_jump > 0 and self.passing_sigma > 0):
            raise ValueError(f"passing_jump and passing_sigma must be > 0, got {self.passing_jump}, {self.passing_sigma}")
        if self.hidden_search_frames < 1:
            raise ValueError(f"hidden_search_frames must be >= 1, got {self.hidden_search_frames}")
        if not 0.0 <= self.hidden_velocity_damping <= 1.0:
            raise ValueError(f"hidden_velocity_damping must be in [0, 1], got {self.hidden_velocity_damping}")
        if len(self.pelvis_prior_sigma) != 2 or not all(v > 0 for v in self.pelvis_prior_sigma):
            raise ValueError(f"pelvis_prior_sigma must be two positive values (forward, lateral), got {self.pelvis_prior_sigma}")
        if not (self.footprint_sigma > 0 and self.footprint_sigma_growth >= 0 and self.footprint_max_s > 0
                and self.footprint_release_s >= 0):
            raise ValueError("footprint_sigma must be > 0 (inf = no prior), footprint_sigma_growth and footprint_release_s "
                             f">= 0 and footprint_max_s > 0, got {self.footprint_sigma}, {self.footprint_sigma_growth}, "
                             f"{self.footprint_release_s}, {self.footprint_max_s}")
        if not self.heel_rise_dorsiflexion >= 0:
            raise ValueError(f"heel_rise_dorsiflexion must be >= 0 (inf = off), got {self.heel_rise_dorsiflexion}")
        if not (self.foot_roll_prior_sigma > 0 and self.foot_pitch_prior_sigma > 0 and self.feet_crossing_sigma > 0):
            raise ValueError("foot_pitch_prior_sigma, foot_roll_prior_sigma and feet_crossing_sigma must be > 0 "
                             "(inf = no prior)")
        below, blend = self.flat_feet_report
        if not ((below, blend) == (0.0, 0.0) or 0.0 <= below < blend) or not self.flat_feet_floor_tol > 0:
            raise ValueError("flat_feet_report must be (0, 0) (off) or (flat_below, blend_to) with 0 <= flat_below < "
                             f"blend_to, and flat_feet_floor_tol > 0, got {self.flat_feet_report}, {self.flat_feet_floor_tol}")
        self.presence_test()  # validates the presence_* fields

    def presence_test(self) -> PresenceTest:
        """The ``presence_*`` fields as the thresholds of :func:`walker_gait.core.presence.legs_in_view`."""
        return PresenceTest(height=self.presence_height, share=self.presence_share, band=self.presence_band,
                            width=self.presence_width)

    def cue_stride(self, intrinsics: CameraIntrinsics) -> int:
        """The 2D cue's stride for a camera: ``cue2d_stride``, or with ``cue2d_focal`` the smallest stride that
        brings the cue image's focal length to at most ``cue2d_focal`` px.  A fixed stride gave a wide-angle,
        low-resolution camera a cue of a few pixels per leg (a 424x240 RealSense at stride 10: 42x24 pixels of
        2.1° against a Kinect v1's 64x48 of 1.0°), and the step width came out 2.1 cm wide on average."""
        if self.cue2d_focal <= 0:
            return self.cue2d_stride
        return max(1, math.ceil(max(intrinsics.fx, intrinsics.fy) / self.cue2d_focal - 1e-9))

    def noise_vector(self) -> FloatArray:
        """Per-element diffusion std-devs ``(23,)``."""
        s = np.zeros(lm.STATE_DIM)
        s[L.HIP_DIST] = self.sigma_hip_dist
        s[L.HIP_AZ] = s[L.HIP_EL] = self.sigma_pelvis
        s[L.ROOT_X] = s[L.ROOT_Y] = self.sigma_root
        s[L.ROOT_Z] = 0.0  # determined by the floor contact
        s[L.LEN_THIGH : L.LEN_FOOT + 1] = self.sigma_length
        s[L.RAD_THIGH : L.RAD_CALF + 1] = self.sigma_radius
        for leg in (L.LEFT, L.RIGHT):
            block = np.array([self.sigma_hip] * 3 + [self.sigma_knee] + [self.sigma_ankle] * 2)
            s[leg] = block
        return s


PAPER = TrackerConfig(
    n_particles=5000,
    cue="combined",
    fg_fraction=0.1,
    fg_max_points=0,
    n_skeleton=10,
    lambda_3d=PAPER_LAMBDA_3D,
    lambda_2d=PAPER_LAMBDA_2D,
    cue2d_stride=1,
    partitioned=False,
    n_layers=1,
    anneal_betas=(1.0,),
    init_rounds=1,
)
"""Seed paper: 5000 particles, full-resolution 2D cue, 10 % foreground, n = 10, λ1 = 1/5 mm⁻¹,
λ2 = 1/3 mm⁻¹, plain SIR (no partitions/annealing), constant velocity."""

DEFAULT = TrackerConfig(
    n_particles=192,
    cue="combined",
    fg_fraction=0.1,
    fg_max_points=128,
    n_skeleton=6,
    lambda_3d=4.0 * PAPER_LAMBDA_3D,
    lambda_2d=4.0 * PAPER_LAMBDA_2D,
    truncate_3d=0.15,
    cue2d_stride=10,
    cue2d_focal=58.0,
    truncate_2d=0.5,
    occlusion_aware=True,
    hidden_parts=True,
    no_depth_unknown=True,
    partitioned=True,
    n_layers=3,
    root_layers=3,
    anneal_betas=(0.25, 0.5, 1.0),
    velocity_damping=0.7,
    init_rounds=6,
    detect_calf_radius=True,
    redetect_every_s=1.0,
    min_explained=0.75,
    lost_leg_frames=6,
    single_leg_wait_s=1.0,
    hidden_search_share=0.25,
    hidden_velocity_damping=0.0,
    hidden_leg_first=True,
    passing_jump=0.035,
    coast_frames=15,
    coast_redetect_s=0.4,
    blank_view_share=0.7,
    presence_height=0.40,
    fine_2d_only=True,
    sigma_root=0.008,
    foot_pitch_prior_sigma=0.3,
    heel_rise_dorsiflexion=0.175,
    foot_roll_prior_sigma=0.1,
    pelvis_prior_sigma=(0.12, 0.06),
    feet_crossing_sigma=0.03,
    elliptic_foot=True,
    toe_from_data=True,
    flat_feet_report=(0.14, 0.28),
    flat_feet_floor_tol=0.03,
)
"""Real-time preset: partitioned annealed sampling with 192 particles in three annealing layers per partition
(β 0.25, 0.5, 1; two layers until the thirty-ninth session: the third took the summed step length MAE of ten sweep
runs from 19.1 to 15.9 cm and exchanged legs in 6 steps instead of 14, for ~3 ms a frame, DEVELOPERS.md); coarse
layers weighted by the 3D cue, final layers by the combined cue with a 64x48 2D cue."""

ACCURATE = replace(DEFAULT, n_particles=288)
"""Offline preset: the default's sampling with 288 particles instead of 192, for ``walker-gait process`` where no
camera sets the pace.  About 1.5 times the tracker's time (22-24 ms a frame in the sweeps on the 2-core machine
against 15-17; live it would leave no margin under a 30 Hz camera's 33 ms).  On eight sweep runs (sets A and C,
tracker seeds 0-3, sixty-eighth session, DEVELOPERS.md) the step length MAE was smaller in all eight (1.23 -> 1.11 cm
on average), the step width's in seven (1.30 -> 1.21), the heels' in six (2.78 -> 2.66 cm); the cadence error about
the same (1.10 -> 1.08 %, worse in six).  By scenario the gain is the tail under baggy trousers and occlusion; for a user
walking in from the side (``absent_start``) it found more steps, each session as often better as worse."""

PRESETS: dict[str, TrackerConfig] = {"paper": PAPER, "default": DEFAULT, "accurate": ACCURATE}


SHIN_BAND_M = (0.25, 0.7)
"""Heights (m above the floor) of the shin band in which :meth:`LegTracker._leg_blobs` tells the two legs apart (shins
and knees, above what lies on the floor) and :func:`_shin_radius` measures their width."""
SHIN_BAND_SHARE = 0.65
"""Where along the calf, from the ankle, the shin band (:data:`SHIN_BAND_M`, of which a camera at the walker sees
mostly the lower part) measures its width on average: the calf's radius there
is its proximal radius narrowed by this share of its taper (:func:`~walker_gait.core.leg_model.calf_taper`)."""
SHIN_MIN_POINTS = 40
"""Fewest shin-band points of each leg blob for :func:`_shin_radius` to measure its width."""
SHIN_FABRIC_RADIUS = float(lm.MEAN_SHAPE[L.RAD_THIGH - L.LEN_THIGH])
"""A calf radius (m) measured across the shins (:func:`_shin_radius`) from which a search from scratch starts with
it (``detect_calf_radius``): the typical adult's thigh, wider than any calf in fitted trousers, so only loose fabric
(a tube of baggy trousers) is taken.  Below it the search starts from the typical calf as before: measured, fitted
calves gained nothing and lost some (eighty-first session, sweep sets C and A, ``normal`` heels 1.87 / 1.50 ->
1.86 / 1.91 cm), while under baggy trousers a track started from the typical calf took 30-60 frames to widen its
calves to the fabric, its ankles and heels 1.5-3 cm worse meanwhile."""


def _shin_radius(sel: FloatArray, left: NDArray[np.bool_], sep: float) -> float | None:
    """The calves' proximal radius (m) that the two leg blobs' shins show (``sel``: the shin-band points of
    :meth:`LegTracker._leg_blobs`, body frame; ``left``: which of them are the left blob's; ``sep``: the lateral
    distance between the blobs' centres), or None where they do not tell: a blob with fewer than
    :data:`SHIN_MIN_POINTS` points, or legs whose half-width exceeds 3/4 of their centres' distance (one in front of
    the other; two tubes of baggy trousers that touch have half of it).

    Each blob's half-width is its lateral spread between the 5th and 95th percentiles over 0.9 (a cylinder facing the
    camera shows its width as a band of nearly even density), the two legs' median taken as the radius at
    :data:`SHIN_BAND_SHARE` of the calf, and the proximal radius solved from it through the model's taper (a tube of
    loose fabric has none)."""
    halves = []
    for blob in (~left, left):
        y = sel[blob, 1]
        if y.size < SHIN_MIN_POINTS:
            return None
        lo, hi = np.percentile(y, [5.0, 95.0])
        halves.append(0.5 * float(hi - lo) / 0.9)
    band = float(np.median(halves))
    if not band <= 0.75 * sep:
        return None
    radius = band
    for _ in range(8):  # band = radius * (1 - (1 - SHIN_BAND_SHARE) * (1 - taper(radius))): a fixed point
        taper = float(lm.calf_taper(np.array(radius)))
        radius = band / (1.0 - (1.0 - SHIN_BAND_SHARE) * (1.0 - taper))
    lo_r, hi_r = lm.STATE_LOWER[L.RAD_CALF], lm.STATE_UPPER[L.RAD_CALF]
    return float(np.clip(radius, lo_r, hi_r))


def preset(name: str, **overrides: object) -> TrackerConfig:
    """A named preset (``paper`` / ``default`` / ``accurate``) with optional field overrides."""
    if name not in PRESETS:
        raise ValueError(f"unknown tracker preset {name!r}; choose one of {sorted(PRESETS)}")
    return replace(PRESETS[name], **overrides)  # type: ignore[arg-type]


def camera_segments(
    kin: Kinematics, body: BodyFrame, legs: tuple[int, ...] = (0, 1), *, elliptic_foot: bool
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Camera-frame segments ``(P, S, 2, 3)`` of ``legs`` (``S = 3 * len(legs)``), their radii
    towards the camera and their silhouette half-widths ``(P, S, 2)``.

    The two radii differ only for the feet with ``elliptic_foot`` (cross-section
    ``lm.FOOT_HALF_WIDTH * len_foot`` wide and as tall as the foot radius, seen from the camera:
    :func:`~walker_gait.core.likelihood.elliptic_section_radii`); otherwise both are ``kin.radii``.
    """
    jit = kernels.compiled()
    if jit is not None:  # one compiled pass (tested against the numpy code below)
        p, s = kin.segments.shape[0], 3 * len(legs)
        seg_c, toward, sil = np.empty((p, s, 2, 3)), np.empty((p, s, 2)), np.empty((p, s, 2))
        jit.camera_segments(np.ascontiguousarray(kin.segments), np.ascontiguousarray(kin.radii),
                            np.ascontiguousarray(kin.foot_lateral), np.asarray(legs, dtype=np.int64),
                            np.ascontiguousarray(body.body_to_cam_rot), np.ascontiguousarray(body.body_to_cam_trans),
                            bool(elliptic_foot), lm.FOOT_HALF_WIDTH / lm.FOOT_HEEL_RADIUS, seg_c, toward, sil)
        return seg_c, toward, (sil if elliptic_foot else toward)
    seg = kin.segments[:, list(legs)]  # (P, nl, 3, 2, 3)
    p = seg.shape[0]
    seg_c = body.to_camera(seg).reshape(p, 3 * len(legs), 2, 3)
    rad = kin.radii[:, list(legs)].reshape(p, 3 * len(legs), 2)
    if not elliptic_foot:
        return seg_c, rad, rad
    feet = slice(2, None, 3)  # the foot of each leg
    lateral = kin.foot_lateral[:, list(legs)] @ body.body_to_cam_rot.T  # (P, nl, 3)
    widths = np.repeat(lm.foot_half_width(rad[:, feet, :1]), 2, axis=-1)  # (P, nl, 2), constant along the foot
    sil_f, toward_f = elliptic_section_radii(seg_c[:, feet], lateral, rad[:, feet], widths)
    toward, sil = rad.copy(), rad.copy()
    toward[:, feet] = toward_f
    sil[:, feet] = sil_f
    return seg_c, toward, sil


@dataclass
class _Reference:
    """Fixed model part (the other leg) for partitioned weighting."""

    fg_costs: NDArray[np.float32] | None = None
    render: NDArray[np.float32] | None = None
    segments: FloatArray | None = None  # (1, S, 2, 3) camera frame
    radii: FloatArray | None = None  # (1, S, 2) towards the camera
    silhouette: FloatArray | None = None  # (1, S, 2) half-widths of the projected capsules


@dataclass
class _Frame:
    """Per-frame observation, prepared once."""

    body: BodyFrame
    fg: FloatArray  # (N, 3) sub-sampled foreground, camera frame
    fg_all_body: FloatArray  # (M, 3) all foreground points, body frame
    cue: CueImage
    no_depth: BoolArray | None = None  # (H, W) pixels without a depth measurement (when they count as unknown)


@dataclass
class _HiddenState:
    hidden: np.ndarray = field(default_factory=lambda: np.zeros((2, 3), dtype=bool))
    low_count: np.ndarray = field(default_factory=lambda: np.zeros((2, 3), dtype=int))
    boost: np.ndarray = field(default_factory=lambda: np.zeros(2, dtype=int))  # frames left per leg


@dataclass
class _Footprints:
    """Where each foot stood when it was last seen, and the floor's motion through the walker (body) frame.

    A planted foot stays put on the floor, which moves through the walker frame with the walker; when the leading
    leg hides the trailing foot, nothing in the data holds that foot and, its pose held, it travelled along with
    the walker (its toe ran 2 cm ahead of the real one after 1-3 hidden frames, 10 cm after 9-15 on the synthetic
    narrow-gait and baggy-trousers sessions).

    A foot is *planted* in a frame in which it is in view with its toe on the floor (lower than
    ``FOOTPRINT_HEIGHT``) and not moving forward faster than ``FOOTPRINT_MAX_FORWARD`` (a swinging foot skims the
    floor at the start of its swing).  Its *planted run* starts there and ends once it is seen not planted in
    ``_PLANT_END_FRAMES`` frames in a row (one noisy estimate does not end it), or, while it is out of view, once the
    other foot has been planted for the release time (a walking foot leaves the floor one double support after the
    other foot lands; the hidden foot cannot be seen to go), or once its estimate lies ``_FOOTPRINT_GATE`` from the
    footprint (the data have moved it: it swings, or the footprint was wrong).  A footprint needs
    ``_FOOTPRINT_MIN_SAMPLES`` planted frames.  The floor's velocity is the running mean of the
    velocities of toes planted in this frame and the last.  Estimated heels are no help here: seen from the front,
    the tracker often has a flat foot's heel raised by 4-9 cm.  Body-frame xy throughout (+x = the user's forward,
    the floor moves towards -x).  Fed a recording backwards (``direction`` -1, the offline backward pass) the floor
    moves towards +x and a swinging foot back, so "moving forward" is read the other way round: read forwards, stance
    feet were never planted there and swinging feet near the floor were (the floor's velocity came out -0.8 to
    -1.3 m/s where it was +1.1, fifty-second session).
    """

    direction: float = 1.0  # +1: the frames come forwards in time; -1: backwards (the backward tracking pass)
    floor_vel: FloatArray = field(default_factory=lambda: np.zeros(2))  # m/s, floor velocity in the body frame
    prev_stamp: float = math.nan
    prev_toe: FloatArray = field(default_factory=lambda: np.full((2, 2), np.nan))  # toe xy of the last frame
    prev_seen: BoolArray = field(default_factory=lambda: np.zeros(2, dtype=bool))
    prev_planted: BoolArray = field(default_factory=lambda: np.zeros(2, dtype=bool))
    off_run: NDArray[np.int_] = field(default_factory=lambda: np.zeros(2, dtype=int))  # frames in a row seen not planted
    planted_since: FloatArray = field(default_factory=lambda: np.full(2, np.nan))  # stamp each planted run began
    toe_runs: tuple[list[tuple[float, FloatArray]], list[tuple[float, FloatArray]]] = field(
        default_factory=lambda: ([], []))  # per foot, (stamp, toe xy) of the last planted frames of its planted run

    def update(self, stamp: float, pts: FloatArray, seen: BoolArray, *, release_s: float) -> None:
        """Take the estimate ``pts`` ``(2, 5, 3)`` (body frame) of the frame at ``stamp``; ``seen`` ``(2,)``:
        which feet are in view; ``release_s``: how long after the other foot's landing an unseen foot leaves the
        floor."""
        toe = pts[:, TOE, :2]
        low = seen & (pts[:, TOE, 2] < FOOTPRINT_HEIGHT)
        dt = stamp - self.prev_stamp
        both = seen & self.prev_seen & (0.0 < dt <= 0.2)
        vel = (toe - self.prev_toe) / dt if dt > 0 else np.zeros_like(toe)
        # swinging forward (tracked backwards in time, the floor moves forward and a swinging foot back)
        moving = both & (self.direction * vel[:, 0] > FOOTPRINT_MAX_FORWARD)
        planted = low & ~moving
        ok = planted & self.prev_planted & both & (np.hypot(vel[:, 0], vel[:, 1]) < _FLOOR_MAX_SPEED)
        if ok.any():
            self.floor_vel += _FLOOR_VEL_GAIN * (vel[ok].mean(axis=0) - self.floor_vel)
        self.prev_stamp = stamp
        self.prev_toe = toe.copy()
        self.prev_seen = seen.copy()
        self.prev_planted = planted
        self.off_run = np.where(planted, 0, np.where(seen, self.off_run + 1, self.off_run))
        ended = self.off_run >= _PLANT_END_FRAMES
        self.planted_since = np.where(planted & np.isnan(self.planted_since), stamp, self.planted_since)
        self.planted_since = np.where(ended, np.nan, self.planted_since)
        for leg in (0, 1):
            # NaN (the other foot not planted) compares False
            released = not seen[leg] and stamp - self.planted_since[1 - leg] > release_s
            if not seen[leg] and self.toe_runs[leg]:
                pred = self._carried(leg, stamp)
                released |= bool(np.hypot(*(toe[leg] - pred)) > _FOOTPRINT_GATE)
            if planted[leg]:
                self.toe_runs[leg].append((stamp, toe[leg].copy()))
                del self.toe_runs[leg][:-_FOOTPRINT_SAMPLES]
            elif ended[leg] or released:
                self.toe_runs[leg].clear()
                if released:
                    self.planted_since[leg] = np.nan

    def predicted(self, leg: int, stamp: float, *, max_s: float) -> tuple[FloatArray, float] | None:
        """Where the toe of foot ``leg`` stands at ``stamp`` and the time (s) since it was last seen planted, if its
        planted run goes on and that was no longer than ``max_s`` ago."""
        run = self.toe_runs[leg]
        if len(run) < _FOOTPRINT_MIN_SAMPLES:
            return None
        age = stamp - run[-1][0]
        if not 0.0 <= age <= max_s:
            return None
        return self._carried(leg, stamp), age

    def _carried(self, leg: int, stamp: float) -> FloatArray:
        """The mean of the planted toe's positions of foot ``leg``'s run, each carried along by the floor to
        ``stamp``."""
        return np.mean([p + self.floor_vel * (stamp - t) for t, p in self.toe_runs[leg]], axis=0)


def _child_generator(rng: np.random.Generator) -> np.random.Generator:
    """An independent generator derived from ``rng`` without drawing from it (``Generator.spawn``); a generator
    whose bit generator has no seed sequence to spawn from gives one seeded by a draw from ``rng``."""
    try:
        return rng.spawn(1)[0]
    except TypeError:
        return np.random.default_rng(int(rng.integers(2**63)))


class FeetReport:
    """The feet's measures a :class:`LegTracker`'s pose reports: each toe measured from the foreground around the
    tracked foot (``toe_from_data``, :func:`walker_gait.core.feet.measure_toes`; as tracked where the shoe may be cut
    by the image's border) and the shoes' rise and turn (``shoes``, :func:`walker_gait.core.feet.measure_shoes`).

    They are functions of the estimate's leg points (body frame) and the frame's foreground alone, and the tracking
    does not read them, so a pass tracked with ``LegTracker(defer_feet=True)`` can have them taken afterwards, or in
    another process (:meth:`complete`), with the same results bit for bit.
    """

    def __init__(self, config: TrackerConfig, intrinsics: CameraIntrinsics, *, mounting: str = "facing_user",
                 shoes: bool = True) -> None:
        self.config = config
        self.intrinsics = intrinsics
        self.mounting = mounting
        self.shoes = shoes
        self._toe_fit = ToeFit(min_height=config.fg_min_height)
        self._rise_fit = ShoeRiseFit(min_height=config.fg_min_height)
        self._turn_fit = ShoeTurnFit(min_height=config.fg_min_height)

    def measure(self, pts_body: FloatArray, *, body: BodyFrame, fg_all_body: FloatArray,
                no_depth: NDArray[np.bool_] | None) -> tuple[FloatArray, FloatArray | None, FloatArray | None]:
        """``(leg points, shoe rise, shoe turn)``: ``pts_body`` ``(2, 5, 3)`` with the toes measured (``toe_from_data``),
        and the shoes' measures (None without ``shoes``); ``fg_all_body``: the frame's foreground (body frame),
        ``no_depth``: its pixels without depth where they count as unknown (else None)."""
        if self.config.toe_from_data:
            camera = body.to_body(np.zeros(3))
            toes, _ = measure_toes(pts_body, fg_all_body, camera=camera, fit=self._toe_fit)
            # a shoe cut by the image's border ends there, not at its toe box: along the foot the model's toe stays;
            # across it, what is left of the shoe still gives its centre line
            in_view = toes_in_view(body.to_camera(pts_body), body.to_camera(toes),
                                   intrinsics=self.intrinsics, fit=self._toe_fit, no_depth=no_depth)
            pts_body = pts_body.copy()
            pts_body[:, TOE] = across_only(pts_body, toes, ~in_view)
        rise = turn = None
        if self.shoes:
            rise, turn = measure_shoes(pts_body, fg_all_body, rise_fit=self._rise_fit, turn_fit=self._turn_fit)
        return pts_body, rise, turn

    def complete(self, pose: LegPose, pending: FloatArray, *, points: NDArray[np.floating], floor: FloorPlane,
                 no_depth: NDArray[np.bool_] | None = None) -> LegPose:
        """``pose``, returned by a ``defer_feet`` tracker's :meth:`LegTracker.update` whose
        :attr:`~LegTracker.pending_feet` was ``pending``, with the feet's measures taken on that update's ``points``,
        ``floor`` and ``no_depth``: the pose the tracker would have returned without ``defer_feet``.  (A pose the
        tracker held instead, ``pending_feet`` None, repeats the last one it estimated, measures and all.)"""
        pts, rise, turn = self.measured(pending, points=points, floor=floor, no_depth=no_depth)
        return replace(pose, points=pts, shoe_rise=rise, shoe_turn=turn)

    def measured(self, pending: FloatArray, *, points: NDArray[np.floating], floor: FloorPlane,
                 no_depth: NDArray[np.bool_] | None = None) -> tuple[FloatArray, FloatArray | None, FloatArray | None]:
        """What :meth:`complete` puts in the pose: its leg points (camera frame), shoe rise and shoe turn."""
        pts = np.asarray(points, dtype=np.float64)
        finite = np.isfinite(pts)
        if not finite.all():  # as LegTracker.update
            pts = pts[finite.all(axis=1)]
        unknown = None
        if no_depth is not None and self.config.no_depth_unknown:
            unknown = np.asarray(no_depth, dtype=bool)
        body = BodyFrame.from_floor(floor, mounting=self.mounting)
        measured, rise, turn = self.measure(pending, body=body, fg_all_body=body.to_body(pts), no_depth=unknown)
        return body.to_camera(measured), rise, turn


class LegTracker:
    """Particle-filter tracker of both legs (see module docstring).

    ``rng`` drives every random choice, so a seeded Generator makes the tracker deterministic.  ``time_reversed``:
    the frames come backwards in time (stamps negated, :func:`walker_gait.core.smoothing.track_pass`); only the
    footprints' test of a swinging foot reads the direction (``footprint_sigma``).  ``measure_shoes``: each pose
    reports the rise of its shoes' uppers and how far their centre lines turn from the reported feet
    (:func:`walker_gait.core.feet.measure_shoes`: about 2 ms a frame with the compiled kernels, 9 without, on the
    slow 2-core VM of the sixty-fourth session), which the placement (:mod:`walker_gait.core.pelvis`, offline and
    live) turns into the heels' pitch and heading; false (nothing placed afterwards: the placement off): None.
    ``defer_feet``: the feet's measures (the toes measured from the data, ``toe_from_data``, and the shoes'; ~3 ms of
    the ~17 a frame) are left out of the poses, which report the particles' mean feet, and each :meth:`update` that
    estimates a pose leaves their input in :attr:`pending_feet` (None otherwise: no pose, or the last one held) for
    :meth:`FeetReport.complete`, in this process or another: the same poses bit for bit (``walker-gait process``'s
    worker hands its backward pass's to the main process, which is idle by then).  The tracking does not read them.
    ``threads``: how many threads the likelihood's compiled kernels spread the particles over
    (:class:`~walker_gait.core.likelihood.Workspace`): the same tracks bit for bit, in less time where a core is
    otherwise idle (the live ``leg_tracker``; not where every core already tracks, as ``walker-gait process``'s two
    passes do).
    """

    def __init__(
        self,
        config: TrackerConfig,
        intrinsics: CameraIntrinsics,
        *,
        rng: np.random.Generator,
        mounting: str = "facing_user",
        time_reversed: bool = False,
        measure_shoes: bool = True,
        defer_feet: bool = False,
        threads: int = 1,
    ) -> None:
        if mounting not in ("facing_user", "facing_forward"):
            raise ValueError(f"mounting must be 'facing_user' or 'facing_forward', got {mounting!r}")
        self.config = config
        self.intrinsics = intrinsics
        self.rng = rng
        # the re-detections draw from a stream of their own, so one that is not adopted leaves the track exactly as
        # it would be without it (the main stream is not advanced by it)
        self._redetect_rng = _child_generator(rng)
        self._passing_rng = _child_generator(self._redetect_rng)  # the passing check's second tracking, likewise
        self._direction = -1.0 if time_reversed else 1.0  # +x is forward in time: a swinging foot's way
        self.passings = 0  # frames tracked a second time by the passing check (`passing_jump`) ...
        self.passings_kept = 0  # ... and those whose second tracking was kept
        self.mounting = mounting
        self.time_reversed = time_reversed  # fed a recording backwards (stamps negated): the walker backs away
        self.defer_feet = defer_feet
        self.pending_feet: FloatArray | None = None  # with defer_feet: the last update's points for FeetReport.complete
        self._feet = FeetReport(config, intrinsics, mounting=mounting, shoes=measure_shoes)
        self._noise = config.noise_vector()
        self._angle_mask = StateLayout.angle_mask()
        self._p3 = Cue3DParams(
            lam=config.lambda_3d,
            n_skeleton=config.n_skeleton,
            occlusion_aware=config.occlusion_aware,
            truncate=config.truncate_3d,
        )
        self._p2 = Cue2DParams(
            lam=config.lambda_2d,
            stride=config.cue_stride(intrinsics),
            truncate=config.truncate_2d,
            occlusion_aware=config.occlusion_aware,
        )
        self._floor_clip = np.array([False, False, True] * 2)
        self._presence = config.presence_test()
        self._work = Workspace(threads=threads)  # likelihood scratch buffers, reused across frames; its threads
        kernels.compiled()  # load the likelihood's compiled kernels now (compiled once after an install), not on frame 1
        self.reset()

    # ------------------------------------------------------------------ public API
    def reset(self) -> None:
        """Forget the track (next frame with legs re-initialises)."""
        self._x: FloatArray | None = None  # (P, 23) particles, body frame
        self._x_prev: FloatArray | None = None
        self._logw: FloatArray | None = None
        self._mean: FloatArray | None = None
        self._last_ll: FloatArray | None = None
        self._low_conf = 0
        self._unsupported_run = np.zeros(2, dtype=int)  # consecutive frames each leg's lower segments lay over nothing
        self._fresh = True  # no track since the last reset (`single_leg_wait_s` applies)
        self._wait_start = math.nan
        self._unexplained_run = 0  # frames in a row whose estimate left `hidden_search_unexplained` of the foreground unexplained
        self._forget_parts()
        self._stamp = math.nan
        self._redetect_stamp = math.nan  # stamp of the last (re-)detection
        self.status = TrackStatus.NO_USER
        self._coasted = 0
        self._no_legs_run = 0  # consecutive frames whose foreground showed no legs (`legs_in_view`)
        self._last_pose: LegPose | None = None

    @property
    def particles(self) -> FloatArray | None:
        """Current ``(P, 23)`` particle states (body frame), or None when not tracking."""
        return None if self._x is None else self._x.copy()

    @property
    def state(self) -> FloatArray | None:
        """The 23-element state (body frame of the last frame's floor) of the pose the last :meth:`update` returned,
        or None when it returned no pose (``NO_USER``, ``SEARCHING`` before a track)."""
        pose = self._last_pose
        if self._mean is None or pose is None or not bool(np.all(np.isfinite(pose.points))):
            return None
        return self._mean.copy()

    @property
    def measure_shoes(self) -> bool:
        """Whether the poses report the shoes' rise and turn (the constructor's ``measure_shoes``)."""
        return self._feet.shoes

    @property
    def feet(self) -> FeetReport:
        """The feet's measures this tracker's poses report (for :meth:`FeetReport.complete` with ``defer_feet``)."""
        return self._feet

    def score(
        self,
        states: FloatArray,
        *,
        points: NDArray[np.floating],
        depth_fg: NDArray[np.floating],
        floor: FloorPlane,
        no_depth: NDArray[np.bool_] | None = None,
        rng: np.random.Generator | None = None,
    ) -> FloatArray:
        """Log likelihood ``(K,)`` of ``K`` states (rows of ``states``, body frame of ``floor``) on one frame: both
        legs' every segment (no part left out as hidden), with the preset's pose priors; the track is not touched.

        This is what :mod:`walker_gait.core.smoothing` compares the estimates of several tracking passes by.  The
        inputs are those of :meth:`update`; the foreground is sub-sampled with ``rng`` (default: this tracker's
        generator, which a tracker that also tracks should not share).  A frame without a valid floor or
        foreground scores every state ``-inf``.
        """
        x = np.atleast_2d(np.asarray(states, dtype=np.float64))
        if x.shape[1] != lm.STATE_DIM:
            raise TrackerInputError(f"states must be (K, {lm.STATE_DIM}), got {x.shape}")
        pts = np.asarray(points)
        if pts.ndim != 2 or pts.shape[1] != 3:
            raise TrackerInputError(f"points must be (N, 3), got {pts.shape}")
        if not np.isfinite(pts).all():
            pts = pts[np.all(np.isfinite(pts), axis=1)]
        no_floor = not floor.usable
        if no_floor or pts.shape[0] < self.config.min_fg_points:
            return np.full(x.shape[0], -np.inf)
        if not self.config.no_depth_unknown:
            no_depth = None
        frame = self._prepare(pts, np.asarray(depth_fg), floor, no_depth, rng=rng, all_points=False)
        saved = self._hidden
        self._hidden = _HiddenState()  # every part in the likelihood
        try:
            return self._evaluate(frame, x, legs=(0, 1), ref=None)
        finally:
            self._hidden = saved

    def update(
        self,
        *,
        stamp: float,
        points: NDArray[np.floating],
        depth_fg: NDArray[np.floating],
        floor: FloorPlane,
        no_depth: NDArray[np.bool_] | None = None,
    ) -> LegPose:
        """Track one frame.

        ``points``: ``(N, 3)`` foreground points, camera optical frame (m);
        ``depth_fg``: ``(H, W)`` foreground depth (m), NaN elsewhere, same size as the intrinsics;
        ``floor``: floor plane in the camera frame; ``no_depth``: ``(H, W)`` bool, pixels without a depth
        measurement (None: every pixel that is not foreground is background).  Returns the pose in the camera
        frame.  A frame without a valid floor is treated like one without foreground: a track coasts through up
        to ``coast_frames`` of them (DEGRADED, confidence 0), then the pose is NO_USER until the floor is back.
        """
        self.pending_feet = None
        pts = np.asarray(points, dtype=np.float64)
        if pts.ndim != 2 or pts.shape[1] != 3:
            raise TrackerInputError(f"points must be (N, 3), got {pts.shape}")
        depth = np.asarray(depth_fg)
        if depth.shape != (self.intrinsics.height, self.intrinsics.width):
            msg = f"depth_fg shape {depth.shape} does not match the intrinsics {self.intrinsics.height}x{self.intrinsics.width}"
            raise TrackerInputError(msg)
        if no_depth is not None:
            no_depth = np.asarray(no_depth, dtype=bool)
            if no_depth.shape != depth.shape:
                raise TrackerInputError(f"no_depth shape {no_depth.shape} does not match depth_fg {depth.shape}")
        finite = np.isfinite(pts)
        if not finite.all():  # (one pass over the points when all are finite, as the segmentation's are)
            pts = pts[finite.all(axis=1)]
        cfg = self.config
        if not cfg.no_depth_unknown:
            no_depth = None  # pixels without depth are background to both cues (paper)
        # no floor in this frame (not found yet, or hidden by the user or something in front of the lens): there
        # is no walker frame to track in and no region of interest, so the frame counts as one without foreground
        no_floor = not floor.usable

        holding = self._x is not None and self._last_pose is not None and self._coasted < cfg.coast_frames
        if no_floor or pts.shape[0] < cfg.min_fg_points:
            if holding:
                # a brief dropout (a leg in front of the lens, nearer than the sensor's range, blanks the
                # view): hold the track instead of re-detecting from whatever partial view comes next
                return self._coast(stamp)
            self.reset()
            return LegPose.no_user(stamp)
        legs = self.legs_in_view(pts, depth, floor, no_depth)
        frame = None
        if holding:
            frame = self._prepare(pts, depth, floor, no_depth)
            if self._view_blanked(frame):
                # the legs' pixels have gone without depth (a leg in front of the lens): whatever foreground is left
                # is not the user (a wheel the region of interest takes in), so nothing is fitted to it; and a leg
                # in front of the lens is a user at the walker, whatever the rest shows (no "no legs" count)
                self._no_legs_run = 0
                return self._coast(stamp)
        # a track ends once `lost_frames` frames in a row show no legs (the user has left, a wheel stays in
        # view); until then it goes on as usual, so a frame whose legs happen not to pass the check (they
        # reach neither knee height nor the image border for an instant) costs nothing
        self._no_legs_run = 0 if legs else self._no_legs_run + 1
        if self._no_legs_run > (cfg.lost_frames if self.status != TrackStatus.NO_USER else 0):
            self.reset()
            self._no_legs_run = 1
            return LegPose.no_user(stamp)
        if frame is None:
            frame = self._prepare(pts, depth, floor, no_depth)
        resumed = abs(float(stamp) - self._stamp) if self._coasted else 0.0  # s since the last tracked frame
        self._coasted = 0
        self._stamp = float(stamp)
        searching = False
        if self._x is None and self._fresh and cfg.single_leg_wait_s > 0:
            c = self._leg_blobs(frame)[1]
            if c[1] - c[0] < _SINGLE_LEG_SEP:
                if math.isnan(self._wait_start):
                    self._wait_start = float(stamp)
                if float(stamp) - self._wait_start < cfg.single_leg_wait_s:
                    self.status = TrackStatus.SEARCHING
                    return dataclasses.replace(LegPose.no_user(stamp), status=TrackStatus.SEARCHING)
        if self._x is None:
            self._initialise(frame)
            self._fresh = False
            searching = True
        else:
            self._step(frame)

        if self._last_ll is not None:
            self._logw = self._last_ll  # weights of the last annealing layer (the second leg's stage)
        else:
            self._logw = self._evaluate(frame, self._x, legs=(0, 1), ref=None)
        self._last_ll = None
        if searching:
            self._redetect_stamp = float(stamp)
        elif (cfg.redetect_every_s > 0 and not abs(float(stamp) - self._redetect_stamp) < cfg.redetect_every_s) or (
                0.0 < cfg.coast_redetect_s <= resumed):
            self._redetect_stamp = float(stamp)
            self._redetect(frame)
        pose, conf, explained, unsupported = self._estimate(frame, stamp)
        self._unexplained_run = self._unexplained_run + 1 if 1.0 - explained > cfg.hidden_search_unexplained else 0
        # track management
        self._unsupported_run = np.where(unsupported, self._unsupported_run + 1, 0)
        leg_lost = cfg.lost_leg_frames > 0 and bool(np.any(self._unsupported_run >= cfg.lost_leg_frames))
        if conf < cfg.lost_confidence or explained < cfg.min_explained:
            # lost, or locked onto part of the user (e.g. both model legs on the one leg that was in view
            # when the track started, the other leg unexplained): re-detect from the foreground
            self._low_conf += 1
        else:
            self._low_conf = 0
        if searching or self.status == TrackStatus.SEARCHING:
            status = TrackStatus.TRACKING if conf >= cfg.track_confidence else TrackStatus.SEARCHING
        else:
            status = TrackStatus.TRACKING if conf >= cfg.degraded_confidence else TrackStatus.DEGRADED
        if self._low_conf >= cfg.lost_frames or leg_lost:
            # lost (or a leg escaped the data: its calf and foot out of the image or over background, with
            # nothing in front of them that could hide them): re-initialise from the foreground on the next frame
            self._x = None
            self._low_conf = 0
            self._unsupported_run[:] = 0
            status = TrackStatus.SEARCHING
        self.status = status
        pose.status = status
        self._last_pose = pose
        return pose

    # ------------------------------------------------------------------ internals
    def legs_in_view(self, points: FloatArray, depth_fg: NDArray[np.floating], floor: FloorPlane,
                     no_depth: NDArray[np.bool_] | None = None) -> bool:
        """Whether the foreground shows legs rather than low things alone (``presence_height``; always
        true when it is 0).

        A leg belongs to a body above it, so in the image it rises out of the view or above knee height:
        at least ``presence_share`` of the points (and 10) higher than ``presence_height`` above the
        floor, or a foreground part at least ``presence_width`` wide (metres, at its depth) in the
        ``presence_band`` of the image along the border that is "up" for this camera (the floor
        normal projected into the image: the top rows for an upright camera, the bottom rows for one
        mounted upside down), or reaching that border through pixels without depth (``no_depth``, as
        :meth:`update` takes it): the legs of a user close to the walker are nearer than the sensor's
        range above the shins (with the walker lagging behind its user, a track ended for half a second
        at every close approach).  A walker's wheel, in view while its user is away, is none of these:
        0.3 m high at most, its frame tubes 1-2 cm wide where they leave the image, the floor and the
        room above it.
        """
        cfg = self.config
        if cfg.presence_height <= 0:
            return True
        return legs_in_view(floor.height(points), depth_fg, up=floor.normal, intrinsics=self.intrinsics,
                            test=self._presence, no_depth=no_depth)

    def _coast(self, stamp: float) -> LegPose:
        """The last pose held through a frame that cannot be tracked (DEGRADED, confidence 0; ``coast_frames``)."""
        assert self._last_pose is not None
        self._coasted += 1
        return dataclasses.replace(self._last_pose, stamp=stamp, status=TrackStatus.DEGRADED, confidence=0.0)

    def _view_blanked(self, frame: _Frame) -> bool:
        """Whether at least ``blank_view_share`` of the calves' and feet's axis points of the last estimate that
        project into the image fall on pixels without depth in this frame (see ``blank_view_share``)."""
        share = self.config.blank_view_share
        pose = self._last_pose
        if share >= 1.0 or frame.no_depth is None or pose is None or pose.segments is None or pose.radii is None:
            return False
        pts, _ = skeleton_points(pose.segments.reshape(1, 6, 2, 3), pose.radii.reshape(1, 6, 2), n=_VIS_POINTS)
        inside, _, unknown = frame.cue.sample(pts[0])
        inside = inside.reshape(2, 3, -1)[:, 1:]
        n = int(np.count_nonzero(inside))
        return n > 0 and int(np.count_nonzero(unknown.reshape(2, 3, -1)[:, 1:])) >= share * n

    def _prepare(self, pts: NDArray[np.floating], depth: NDArray[np.floating], floor: FloorPlane,
                 no_depth: NDArray[np.bool_] | None = None, *, rng: np.random.Generator | None = None,
                 all_points: bool = True) -> _Frame:
        """The frame's observation for the likelihood: the sub-sampled foreground (float64), the cue image and, with
        ``all_points``, every foreground point in the body frame (the toes' measurement and the leg blobs)."""
        cfg = self.config
        body = BodyFrame.from_floor(floor, mounting=self.mounting)
        n = pts.shape[0]
        k = max(1, int(math.ceil(cfg.fg_fraction * n)))
        if cfg.fg_max_points > 0:
            k = min(k, cfg.fg_max_points)
        k = min(k, n)
        idx = (rng or self.rng).choice(n, size=k, replace=False) if k < n else np.arange(n)
        cue = CueImage.from_depth(
            depth, intrinsics=self.intrinsics, stride=self._p2.stride, floor=floor, min_height=cfg.fg_min_height,
            unknown=no_depth,
        )
        fg = np.asarray(pts[np.sort(idx)], dtype=np.float64)
        all_body = body.to_body(np.asarray(pts, dtype=np.float64)) if all_points else np.empty((0, 3))
        return _Frame(body=body, fg=fg, fg_all_body=all_body, cue=cue, no_depth=no_depth)

    # -- likelihood -------------------------------------------------------------
    def _cam_segments(
        self, frame: _Frame, kin: Kinematics, legs: tuple[int, ...]
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        return camera_segments(kin, frame.body, legs, elliptic_foot=self.config.elliptic_foot)

    def _active(self, legs: tuple[int, ...]) -> np.ndarray | None:
        if not self.config.hidden_parts:
            return None
        return ~self._hidden.hidden[list(legs)].ravel()

    def _evaluate(
        self,
        frame: _Frame,
        states: FloatArray,
        *,
        legs: tuple[int, ...],
        ref: _Reference | None,
        kin: Kinematics | None = None,
        use_2d: bool = True,
    ) -> FloatArray:
        """Log likelihood ``(P,)`` of ``states`` using the segments of ``legs`` (+ ``ref``)."""
        cfg = self.config
        if kin is None:
            kin = lm.forward_kinematics(states)
        seg, rad, sil = self._cam_segments(frame, kin, legs)
        jit = kernels.compiled()
        if jit is not None:
            total = self._priors_compiled(jit, states, kin, legs)
        else:
            total = self._priors(states, kin, legs)
        if cfg.cue in ("3d", "combined"):
            total += log_likelihood_3d(
                seg,
                rad,
                fg=frame.fg,
                params=self._p3,
                ref_fg_costs=None if ref is None else ref.fg_costs,
                active=self._active(legs),
                cue_image=frame.cue,
                work=self._work,
            )
        if cfg.cue == "2d" or (cfg.cue == "combined" and use_2d):
            # Only pixels some particle renders differ between particles; every other pixel adds the
            # same cost to all of them, which normalised (log) weights ignore, so the 2D cue is
            # evaluated over the particles' own bbox (identical weights, less work than eq. 9's
            # whole image; `log_likelihood_2d` keeps the whole-image normaliser).
            bbox = project_bbox(seg, np.maximum(rad, sil), intrinsics=frame.cue.intrinsics)
            ref_render = None
            if ref is not None and ref.segments is not None:
                ref_render = render_depth(
                    ref.segments, ref.silhouette, cue=frame.cue, bbox=bbox, floor_clip=self._floor_clip[:3],
                    depth_radii=ref.radii,
                )[0]
            total += log_likelihood_2d(
                seg,
                sil,
                depth_radii=rad,
                cue=frame.cue,
                params=self._p2,
                bbox=bbox,
                ref_render=ref_render,
                floor_clip=self._floor_clip[: seg.shape[1]],
                work=self._work,
            )
        return total

    def _heel_rise_on(self, leg: int) -> bool:
        """Whether the foot pitch prior of ``leg`` allows a heel rise (``heel_rise_dorsiflexion``): not for a HIDDEN
        calf, whose lean is not measured."""
        return math.isfinite(self.config.heel_rise_dorsiflexion) and not self._hidden.hidden[leg, 1]

    def _footprint_target(self, leg: int) -> tuple[FloatArray, float] | None:
        """The footprint prior's centre (floor xy) and scale (m) for the toe of a HIDDEN foot ``leg`` that stood on the
        floor when last seen (``footprint_sigma``, widening with its age), or None."""
        cfg = self.config
        if not self._hidden.hidden[leg, 2]:
            return None
        pred = self._footprints.predicted(leg, self._stamp, max_s=cfg.footprint_max_s)
        if pred is None:
            return None
        xy, age = pred
        return xy, cfg.footprint_sigma + cfg.footprint_sigma_growth * age

    def _priors(self, states: FloatArray, kin: Kinematics, legs: tuple[int, ...]) -> FloatArray:
        """Log priors ``(P,)`` of ``states`` (kinematics ``kin``) for the segments of ``legs`` (numpy)."""
        cfg = self.config
        total = np.zeros(states.shape[0])
        if math.isfinite(cfg.ankle_prior_sigma):
            # seen from the front, a flat foot and a plantar-flexed one standing on its toes explain the
            # same shoe front (the heel is hidden behind it); the prior prefers the common pose
            for leg in legs:
                a = states[:, L.leg(leg)][:, L.ANKLE_FLEX] / cfg.ankle_prior_sigma
                total -= 0.5 * a * a
        if math.isfinite(cfg.foot_pitch_prior_sigma):
            for leg in legs:
                v = kin.points[:, leg, TOE] - kin.points[:, leg, HEEL]  # heel -> toe, body frame (z up)
                flat = np.hypot(v[:, 0], v[:, 1])
                a = np.arctan2(v[:, 2], flat)  # toe-up pitch
                if self._heel_rise_on(leg):
                    # late stance: the shank leans forward over the planted foot until the ankle reaches its
                    # dorsiflexion in gait (~10 deg, Perry & Burnfield 2010), then the heel rises; held flat, the
                    # heel-up foot slid forward along its hidden sole (the trailing toe ran 2-3 cm ahead).  Only a
                    # foot behind the other one rises onto its toes (late stance, early swing): ahead of it, a
                    # landing foot goes heel first, and the allowance let a forward-leaning model shank stand it
                    # on its toes.  A HIDDEN calf's lean is not measured: the prior stays centred on a flat foot
                    ankle = kin.points[:, leg, ANKLE]
                    s = kin.points[:, leg, KNEE] - ankle
                    fwd = (s[:, 0] * v[:, 0] + s[:, 1] * v[:, 1]) / np.maximum(flat, 1e-9)
                    lean = np.arctan2(fwd, s[:, 2])
                    o = kin.points[:, 1 - leg, ANKLE] - ankle
                    behind = (o[:, 0] * v[:, 0] + o[:, 1] * v[:, 1]) / np.maximum(flat, 1e-9)
                    gate = np.clip(behind / HEEL_RISE_BEHIND, 0.0, 1.0)
                    a = a + gate * np.clip(lean - cfg.heel_rise_dorsiflexion, 0.0, HEEL_RISE_MAX)
                a /= cfg.foot_pitch_prior_sigma
                total -= 0.5 * a * a
        if math.isfinite(cfg.footprint_sigma):
            # a HIDDEN foot that stood on the floor when last seen stays there until it leaves the floor, which
            # nobody sees: one double support (`footprint_release_s`) after the other foot landed, or at the latest
            # `footprint_max_s` after it was last seen; the prior widens with time.  The floor moves through the
            # walker frame at the walker's speed, and the footprint with it (see _Footprints)
            for leg in legs:
                target = self._footprint_target(leg)
                if target is None:
                    continue
                d = (kin.points[:, leg, TOE, :2] - target[0]) / target[1]
                total -= 0.5 * np.einsum("pi,pi->p", d, d)
        if math.isfinite(cfg.foot_roll_prior_sigma):
            # a sole rolled sideways stands on its edge with its heel-toe line off the floor; shoes stay
            # nearly level across (subtalar motion of a few degrees), but from the front the roll is hardly
            # observable, and without a prior it wanders and lifts the tracked heel and toe
            for leg in legs:
                r = np.arcsin(np.clip(kin.foot_lateral[:, leg, 2], -1.0, 1.0)) / cfg.foot_roll_prior_sigma
                total -= 0.5 * r * r
        if math.isfinite(cfg.pelvis_prior_sigma[0]) or math.isfinite(cfg.pelvis_prior_sigma[1]):
            # the hips are out of view (the camera sees the shanks and feet) and only the dynamics carry them;
            # a person walking stands over their feet, so keep the pelvis over the centre of the base of support
            d = kin.points[:, :, HIP, :2].mean(axis=1) - kin.points[:, :, HEEL : TOE + 1, :2].mean(axis=(1, 2))
            d /= np.asarray(cfg.pelvis_prior_sigma, dtype=float)
            total -= 0.5 * np.einsum("pi,pi->p", d, d)
        if math.isfinite(cfg.feet_crossing_sigma):
            # walking feet stay on their own side of the body: across the pelvis (the hip line on the floor) the
            # left foot's centre lies left of the right foot's (by the step width, 5-20 cm); crossed model feet
            # are one model leg covering both real legs, or the legs' identities exchanged
            across = kin.points[:, 0, HIP, :2] - kin.points[:, 1, HIP, :2]
            across /= np.maximum(np.linalg.norm(across, axis=1, keepdims=True), 1e-9)
            feet = kin.points[:, :, ANKLE : TOE + 1, :2].mean(axis=2)
            c = np.maximum(-np.einsum("pi,pi->p", feet[:, 0] - feet[:, 1], across), 0.0) / cfg.feet_crossing_sigma
            total -= 0.5 * c * c
        return total

    def _priors_compiled(self, jit: object, states: FloatArray, kin: Kinematics, legs: tuple[int, ...]) -> FloatArray:
        """:meth:`_priors` by the compiled kernels (:func:`walker_gait.core._jit.prior_terms`: the same arithmetic and
        numpy's arctangents and arcsines, bit for bit, tested)."""
        cfg = self.config
        p, nl = states.shape[0], len(legs)
        leg_idx = np.asarray(legs, dtype=np.int64)
        points = np.ascontiguousarray(kin.points)
        args = np.empty((5, nl, p))
        pitch = lean = roll = np.empty((nl, p))
        pitch_on = math.isfinite(cfg.foot_pitch_prior_sigma)
        rise_on = np.array([pitch_on and self._heel_rise_on(leg) for leg in legs])
        if pitch_on:
            jit.prior_angle_args(points, leg_idx, args)  # type: ignore[attr-defined]
            pitch = np.arctan2(args[0], args[1])
            if rise_on.any():
                lean = np.arctan2(args[2], args[3])
        fp_on, fp_xy, fp_scale = np.zeros(nl, dtype=bool), np.zeros((nl, 2)), np.ones(nl)
        if math.isfinite(cfg.footprint_sigma):
            for li, leg in enumerate(legs):
                target = self._footprint_target(leg)
                if target is not None:
                    fp_on[li], fp_xy[li], fp_scale[li] = True, target[0][:2], target[1]
        if math.isfinite(cfg.foot_roll_prior_sigma):
            roll = np.arcsin(np.clip(kin.foot_lateral[:, list(legs), 2].T, -1.0, 1.0))
        sx, sy = (float(v) for v in cfg.pelvis_prior_sigma)
        total = np.zeros(p)
        jit.prior_terms(  # type: ignore[attr-defined]
            np.ascontiguousarray(states, dtype=np.float64), points, leg_idx, float(cfg.ankle_prior_sigma),
            np.ascontiguousarray(pitch), np.ascontiguousarray(lean), args, rise_on, float(cfg.heel_rise_dorsiflexion),
            HEEL_RISE_BEHIND, HEEL_RISE_MAX, float(cfg.foot_pitch_prior_sigma), fp_on, fp_xy, fp_scale,
            np.ascontiguousarray(roll), float(cfg.foot_roll_prior_sigma), sx, sy,
            math.isfinite(sx) or math.isfinite(sy), float(cfg.feet_crossing_sigma), total)
        return total

    def _reference(self, frame: _Frame, state: FloatArray, leg: int) -> _Reference:
        kin = lm.forward_kinematics(state[None])
        seg, rad, sil = self._cam_segments(frame, kin, (leg,))
        ref = _Reference(segments=seg, radii=rad, silhouette=sil)
        if self.config.cue in ("3d", "combined"):
            ref.fg_costs = foreground_costs(seg, rad, fg=frame.fg, n=self.config.n_skeleton)[0]
        return ref

    # -- sampling -----------------------------------------------------------------
    def _weighted_mean(self, states: FloatArray, logw: FloatArray) -> FloatArray:
        w = normalise_log_weights(logw)
        return w @ states

    def _diffuse(self, x: FloatArray, dims: np.ndarray, gain: float | FloatArray,
                 comp: FloatArray | None = None) -> tuple[FloatArray, Kinematics]:
        """Particles moved by the transition noise of ``dims``, and their kinematics.  With ``comp``
        (:meth:`_root_compensation`) the legs' angles also take the change that offsets the pelvis's move, and so do
        the previous frame's particles (``_x_prev``, whose rows pair with ``x``'s): a change that offsets a pelvis
        move is not motion, so the legs' constant-velocity prediction stays."""
        sigma = np.where(dims, self._noise, 0.0)
        noise = self.rng.standard_normal(x.shape) * sigma
        if np.ndim(gain) == 1:
            noise *= gain
        else:
            noise *= float(gain)  # type: ignore[arg-type]
        delta = None
        if comp is not None and dims[list(_COMPENSATED_ROOT)].any():
            delta = np.zeros_like(noise)
            delta[:, L.ANGLES] = noise[:, list(_COMPENSATED_ROOT)] @ comp.T
            share = self.config.root_compensation
            if share < 1.0:  # an even spread of the rows, without a draw (the resampled rows are in no order that matters)
                i = np.arange(x.shape[0])
                delta[np.floor((i + 1) * share) == np.floor(i * share)] = 0.0
            noise += delta
            if self._x_prev is not None:
                self._x_prev = self._x_prev + delta
        new, kin, _ = lm.enforce_constraints(x + noise, fallback=x)
        return new, kin

    def _root_compensation(self, x: FloatArray) -> FloatArray:
        """``(12, 3)`` leg-angle change per unit move of the root dims ``_COMPENSATED_ROOT`` that keeps, in the least
        squares sense, each leg's ankle, heel, toe and a point on its lower calf where they are: finite differences of
        the forward kinematics at the particles' mean ``x``, a damped least-squares solve per leg (none for a leg
        whose calf and foot are HIDDEN)."""
        ref = self._mean_estimate(x)
        eps = 1e-4
        cols = [*_COMPENSATED_ROOT, *range(L.ANGLES.start, L.ANGLES.stop)]
        states = np.repeat(ref[None], 1 + len(cols), axis=0)
        states[np.arange(1, 1 + len(cols)), cols] += eps
        pts = lm.forward_kinematics(states).points  # (1 + n, 2, 5, 3)
        held = np.concatenate([pts[:, :, ANKLE : TOE + 1],
                               (pts[:, :, ANKLE] + _COMPENSATION_CALF * (pts[:, :, KNEE] - pts[:, :, ANKLE]))[:, :, None]],
                              axis=2).reshape(1 + len(cols), 2, -1)  # (1 + n, 2 legs, 12)
        jac = (held[1:] - held[0]) / eps  # (n, 2, 12)
        nr = len(_COMPENSATED_ROOT)
        out = np.zeros((12, nr))
        for side in (0, 1):
            if self._hidden.hidden[side, 1:].all():
                # a leg whose calf and foot nobody sees has nothing to hold: it moves with the pelvis, and where its
                # particles are being drawn afresh (`hidden_search_share`) the mean is no pose to linearise at
                continue
            j_root = jac[:nr, side].T  # (12 outputs, nr)
            j_leg = jac[nr + 6 * side : nr + 6 * side + 6, side].T  # (12 outputs, 6 angles of this leg)
            lhs = j_leg.T @ j_leg + _COMPENSATION_DAMPING * np.eye(6)
            out[6 * side : 6 * side + 6] = -np.linalg.solve(lhs, j_leg.T @ j_root)
        return out

    def _leg_gain(self) -> FloatArray:
        g = np.ones(lm.STATE_DIM)
        for side in (0, 1):
            if self._hidden.boost[side] > 0:
                g[L.leg(side)] = self.config.reappear_noise_gain
        return g

    def _stages(self, first: int | None = None) -> list[tuple[np.ndarray, tuple[int, ...], int | None]]:
        """(dims mask, legs evaluated, reference leg) per partition; ``first``: the leg drawn first (default: a
        HIDDEN one with ``hidden_leg_first``, else the left)."""
        if not self.config.partitioned:
            return [(np.ones(lm.STATE_DIM, dtype=bool), (0, 1), None)]
        root = np.zeros(lm.STATE_DIM, dtype=bool)
        root[:11] = True
        left = np.zeros(lm.STATE_DIM, dtype=bool)
        left[L.LEFT] = True
        right = np.zeros(lm.STATE_DIM, dtype=bool)
        right[L.RIGHT] = True
        h = self._hidden.hidden
        if first == 1 or (first is None and self.config.hidden_leg_first and h[1, 1:].all() and not h[0, 1:].all()):
            # the hidden right leg first, against the visible left one where it was: drawn second, the left leg
            # was free to take data the hidden leg's real counterpart had left unexplained (a trailing leg that
            # swings past the other one while the model still holds it behind), and the hidden leg's search then
            # found the place the left leg had left: both identities exchanged
            return [(root, (0, 1), None), (right, (1,), 0), (left, (0,), 1)]
        return [(root, (0, 1), None), (left, (0,), 1), (right, (1,), 0)]

    def _run_stages(
        self,
        frame: _Frame,
        x: FloatArray,
        *,
        gain: float | FloatArray,
        layers: int,
        betas: tuple[float, ...],
        final: bool = False,
        first: int | None = None,
    ) -> FloatArray:
        """Partitioned annealed search.

        Returns the particles; with ``final`` the very last layer is *not* resampled and its
        log likelihood is kept in ``self._last_ll`` as the frame's particle weights (saves one
        full evaluation), otherwise the returned particles carry uniform weights.  ``first``: the leg drawn first
        (default: as :meth:`_stages` orders them).
        """
        cfg = self.config
        stages = self._stages(first)
        comp = self._root_compensation(x) if cfg.root_compensation > 0 else None
        for k, (dims, legs, ref_leg) in enumerate(stages):
            ref = None
            if ref_leg is not None:
                ref = self._reference(frame, self._mean_estimate(x), ref_leg)
            n_layers = min(layers, cfg.root_layers) if (cfg.partitioned and k == 0) else layers
            b = betas[-n_layers:]
            for layer in range(n_layers):
                layer_gain = gain * cfg.layer_noise_decay**layer
                x_new, kin = self._diffuse(x, dims, layer_gain, comp)
                # coarse layers may skip the 2D cue of the combined likelihood (`fine_2d_only`)
                use_2d = not (cfg.fine_2d_only and layer < n_layers - 1)
                ll = self._evaluate(frame, x_new, legs=legs, ref=ref, kin=kin, use_2d=use_2d)
                if final and k == len(stages) - 1 and layer == n_layers - 1:
                    self._last_ll = b[layer] * ll
                    return x_new
                idx = resample(b[layer] * ll, rng=self.rng, scheme=cfg.resample_scheme)
                x = x_new[idx]
                self._x_prev = self._x_prev[idx] if self._x_prev is not None else None
        return x

    def _mean_estimate(self, x: FloatArray) -> FloatArray:
        m = x.mean(axis=0)
        return lm.enforce_constraints(m[None])[0][0]

    def _step(self, frame: _Frame) -> None:
        cfg = self.config
        assert self._x is not None and self._logw is not None
        # resample with last frame's final weights
        idx = resample(self._logw, rng=self.rng, scheme=cfg.resample_scheme)
        x = self._x[idx]
        prev = self._x_prev[idx] if self._x_prev is not None else x.copy()
        # constant velocity on joint angles (eq. 3)
        vel = np.where(self._angle_mask, x - prev, 0.0) * cfg.velocity_damping
        if cfg.hidden_velocity_damping != 1.0:
            for side in (0, 1):
                if self._hidden.hidden[side, 1:].all():
                    vel[:, L.leg(side)] *= cfg.hidden_velocity_damping
        self._x_prev = x.copy()
        x_pred, _, _ = lm.enforce_constraints(x + vel, fallback=x)
        if cfg.hidden_search_share > 0 and self._unexplained_run >= cfg.hidden_search_frames:
            for side in (0, 1):
                if self._hidden.hidden[side, 1:].all() and not self._hidden.hidden[1 - side, 1:].all():
                    x_pred = self._search_hidden_leg(x_pred, side)
        gain = self._leg_gain()
        if cfg.partitioned or cfg.n_layers > 1:
            standing = self._passing_legs()
            prev = None if not standing or self._x_prev is None else self._x_prev.copy()
            x = self._run_stages(frame, x_pred, gain=gain, layers=cfg.n_layers, betas=cfg.anneal_betas, final=True)
            if standing:
                x = self._passing_check(frame, x, (x_pred, prev), legs=standing, gain=gain)
        else:
            comp = self._root_compensation(x_pred) if cfg.root_compensation > 0 else None
            x, _ = self._diffuse(x_pred, np.ones(lm.STATE_DIM, dtype=bool), gain, comp)
        self._x = x
        self._hidden.boost = np.maximum(self._hidden.boost - 1, 0)

    def _passing_legs(self) -> list[int]:
        """The legs whose feet this frame's :meth:`_passing_check` watches: not HIDDEN while the other foot is HIDDEN
        or went unseen in the last frame, and their toes stood on the floor two and three frames ago without coming
        forward between them (``passing_jump``)."""
        cfg = self.config
        pose = self._last_pose
        if not math.isfinite(cfg.passing_jump) or len(self._recent) < _PASSING_HISTORY or pose is None \
                or pose.visibility is None:
            return []
        unseen = self._hidden.hidden[:, 2] | (pose.visibility[:, 2] < cfg.hide_below)
        stamps = [t for t, _, _ in self._recent[-_PASSING_HISTORY:]] + [self._stamp]
        if not all(0.0 < abs(b - a) <= 0.1 for a, b in zip(stamps[:-1], stamps[1:])):
            return []
        (_, p0, _), (_, p1, _) = self._recent[-_PASSING_HISTORY:][:2]
        return [leg for leg in (0, 1) if not self._hidden.hidden[leg, 2] and unseen[1 - leg]
                and max(p0[leg, 2], p1[leg, 2]) < FOOTPRINT_HEIGHT
                and self._direction * (p1[leg, 0] - p0[leg, 0]) <= _PASSING_STILL]

    def _passing_jumps(self, states: FloatArray) -> FloatArray:
        """``(K, 2)`` m: how far each leg's toe of ``states`` ``(K, 23)`` came forward from where it stood two frames
        ago."""
        toes = lm.forward_kinematics(states).points[:, :, TOE, 0]
        return self._direction * (toes - self._recent[-2][1][:, 0])

    def _passing_check(self, frame: _Frame, x: FloatArray, before: tuple[FloatArray, FloatArray | None], *,
                       legs: list[int], gain: FloatArray) -> FloatArray:
        """The frame's particles ``x`` (tracked from ``before``: the predicted particles and their previous ones),
        or those of a second tracking of the frame, where the foot of one of the standing ``legs``
        (:meth:`_passing_legs`) came forward ``passing_jump`` from where it stood two frames ago.  A standing foot
        does not come forward, but the hidden foot swinging past it in depth comes out in front of it, and the seen
        leg, drawn while the other is held where it was last seen (behind), takes the foot that came out (the legs
        exchanged live, seventy-first session).  The second tracking starts the standing leg from its pose of two
        frames ago, without velocity, draws the other leg afresh in half of the particles (as
        ``hidden_search_share``) and draws it first.  Each outcome's mean state is weighed with every segment in the
        likelihood (as a re-detection) and a Gaussian (``passing_sigma``) on how far the standing foot came forward;
        the likelier is kept.  The second tracking draws from a stream of its own: kept or not, the first is as it
        would be without the check."""
        cfg = self.config
        assert self._last_ll is not None
        mean_a = self._weighted_mean(x, self._last_ll)
        jump = self._passing_jumps(mean_a[None])[0]
        seen_leg = max(legs, key=lambda leg: jump[leg])
        if jump[seen_leg] < cfg.passing_jump:
            return x
        hidden_leg = 1 - seen_leg
        a_ll, a_prev, main_rng = self._last_ll, self._x_prev, self.rng
        self.rng = self._passing_rng
        leg = L.leg(seen_leg)
        start = before[0].copy()
        start[:, leg] = self._recent[-2][2][leg]  # the seen leg as it stood, without velocity
        prev = start.copy() if before[1] is None else before[1].copy()
        prev[:, leg] = start[:, leg]
        self._x_prev = prev
        try:
            xb = self._search_hidden_leg(start, hidden_leg, share=_PASSING_SEARCH_SHARE)
            xb = self._run_stages(frame, xb, gain=gain, layers=cfg.n_layers, betas=cfg.anneal_betas, final=True,
                                  first=hidden_leg)
            b_ll, b_prev = self._last_ll, self._x_prev
            assert b_ll is not None
            means = np.stack([mean_a, self._weighted_mean(xb, b_ll)])
            means, _, _ = lm.enforce_constraints(means)
            ll = self._compare(frame, means)
        finally:
            self.rng = main_rng
        jumps = np.maximum(self._passing_jumps(means)[:, seen_leg] - _PASSING_STILL, 0.0)
        score = ll - 0.5 * (jumps / cfg.passing_sigma) ** 2
        self.passings += 1
        if score[1] > score[0]:
            self.passings_kept += 1
            self._last_ll, self._x_prev = b_ll, b_prev
            return xb
        self._last_ll, self._x_prev = a_ll, a_prev
        return x

    def _search_hidden_leg(self, x: FloatArray, side: int, *, tries: int = 4,
                           share: float | None = None) -> FloatArray:
        """``x`` with the leg ``side`` of a share of the particles drawn from a wide range of poses.

        A leg whose calf and foot are HIDDEN is out of ``d_MF`` and held only by the dynamics; where the
        estimate leaves foreground unexplained, that leg is more likely there than behind the other one (a back
        leg that stayed behind while its real counterpart swung past, seed 003 §III-D's wide search started by
        the data instead of by the model's own visibility, which stays low at a wrong position).  Hip flexion
        and knee flexion are drawn across their walking range, abduction, rotation and the ankle near the
        particle's own; a draw that would lift the other foot off the floor (the drawn leg reaching below it)
        is tried again up to ``tries`` times, else the particle keeps its leg.  The drawn particles start
        with no velocity; the stages' annealing then weighs them against the rest.
        """
        cfg = self.config
        p = x.shape[0]
        n = int(round((cfg.hidden_search_share if share is None else share) * p))
        if n == 0:
            return x
        rows = self.rng.choice(p, size=n, replace=False)
        leg = L.leg(side)
        cand = np.repeat(x[rows], tries, axis=0)
        m = cand.shape[0]
        blk = cand[:, leg]
        blk[:, L.HIP_FLEX] = self.rng.uniform(-0.5, 0.9, m)
        blk[:, L.HIP_ABD] += 0.05 * self.rng.standard_normal(m)
        blk[:, L.HIP_ROT] += 0.1 * self.rng.standard_normal(m)
        blk[:, L.KNEE_FLEX] = self.rng.uniform(0.0, 1.3, m)
        blk[:, L.ANKLE_FLEX] = 0.25 * self.rng.standard_normal(m)
        blk[:, L.ANKLE_INV] = 0.05 * self.rng.standard_normal(m)
        cand[:, leg] = blk
        new, _, bad = lm.enforce_constraints(cand)
        ok = ~bad & (np.abs(new[:, L.ROOT_Z] - cand[:, L.ROOT_Z]) < 0.02)
        ok = ok.reshape(n, tries)
        first = np.argmax(ok, axis=1)
        found = ok[np.arange(n), first]
        out = x.copy()
        pick = new.reshape(n, tries, -1)[np.arange(n), first]
        out[rows[found]] = pick[found]
        if self._x_prev is not None:
            self._x_prev[rows[found]] = pick[found]
        return out

    # -- initialisation -----------------------------------------------------------
    def _leg_blobs(self, frame: _Frame) -> tuple[FloatArray, FloatArray]:
        """The foreground points (body frame) that tell the two legs apart, and the two centres (right, left) of a
        2-means clustering of their lateral positions."""
        pb = frame.fg_all_body
        # shins and knees (SHIN_BAND_M above the floor) separate the two legs best and leave out what
        # lies low on the floor: feet together, a walker's wheels, a bag; feet-only views fall back.  A camera
        # at the walker sees mostly feet: the shin band held 3-4 % of the foreground of a user standing at the
        # start of the synthetic sessions (asymmetric:940), and a 10 % threshold fell back to the band that
        # holds the rear wheel, which then took a model leg for 2 s
        lo, hi = SHIN_BAND_M
        sel = pb[(pb[:, 2] > lo) & (pb[:, 2] < hi)]
        if sel.shape[0] < max(50, pb.shape[0] // 50):
            sel = pb[(pb[:, 2] > 0.03) & (pb[:, 2] < hi)]
        if sel.shape[0] < 10:
            sel = pb
        y = sel[:, 1]
        c = np.percentile(y, [25.0, 75.0])
        for _ in range(10):
            lab = np.abs(y - c[0]) > np.abs(y - c[1])  # True = +y cluster = LEFT
            if lab.all() or (~lab).all():
                break
            c = np.array([y[~lab].mean(), y[lab].mean()])
        return sel, c

    def _detect(self, frame: _Frame) -> FloatArray:
        """A standing-pose state fitted to the two leg blobs of the foreground (body frame)."""
        sel, c = self._leg_blobs(frame)
        y = sel[:, 1]
        mid = 0.5 * (c[0] + c[1])
        sep = float(np.clip(c[1] - c[0], 0.14, 0.26))
        y_right, y_left = mid - 0.5 * sep, mid + 0.5 * sep
        lab = y > mid
        x_front_r = float(np.median(sel[~lab, 0])) if np.any(~lab) else float(np.median(sel[:, 0]))
        x_front_l = float(np.median(sel[lab, 0])) if np.any(lab) else float(np.median(sel[:, 0]))
        # the observed surface faces the camera (anatomical front for facing_user, back otherwise)
        toward_cam = 1.0 if self.mounting == "facing_user" else -1.0
        x_r = x_front_r - toward_cam * 0.05
        x_l = x_front_l - toward_cam * 0.05
        state = lm.neutral_state(right_hip_xy=(0.5 * (x_r + x_l), y_right), hip_dist=sep)
        # legs at different depth: hip flexion of each leg towards its blob (standing pelvis)
        hip_h = float(lm.MEAN_SHAPE[0] + lm.MEAN_SHAPE[1]) * 0.7
        for side, xs in ((0, x_l), (1, x_r)):
            flex = math.atan2(xs - state[L.ROOT_X], hip_h)
            state[L.leg(side).start + L.HIP_FLEX] = float(np.clip(flex, -0.5, 0.8))
        state[L.HIP_DIST] = sep
        _ = y_left
        if self.config.detect_calf_radius and bool(np.all(sel[:, 2] > SHIN_BAND_M[0])):  # the band itself, no fallback
            radius = _shin_radius(sel, lab, float(c[1] - c[0]))
            if radius is not None and radius >= SHIN_FABRIC_RADIUS:
                state[L.RAD_CALF] = radius
        return lm.enforce_constraints(state[None])[0][0]

    def _forget_parts(self) -> None:
        """A new particle set's hidden-part state, footprints and recent estimates: nothing hidden, none."""
        self._hidden = _HiddenState()
        self._footprints = _Footprints(direction=-1.0 if self.time_reversed else 1.0)
        self._recent: list[tuple[float, FloatArray, FloatArray]] = []  # (stamp, (2, 3) toes, mean state) of the last frames

    def _initialise(self, frame: _Frame) -> None:
        self._forget_parts()
        x = self._search_fresh(frame)
        self._x = x
        self._x_prev = x.copy()
        self._low_conf = 0

    def _search_fresh(self, frame: _Frame, rounds: int | None = None) -> FloatArray:
        """Particles of a search from scratch: around the detection's standing pose, ``rounds`` (default
        ``init_rounds``) rounds of every partition with shrinking noise.  Reads the hidden-part state (a fresh one
        on (re-)init)."""
        cfg = self.config
        base = self._detect(frame)
        p = cfg.n_particles
        spread = np.zeros(lm.STATE_DIM)
        spread[L.ROOT_X] = 0.06
        spread[L.ROOT_Y] = 0.03
        spread[L.HIP_DIST] = 0.02
        spread[L.HIP_AZ] = 0.1
        spread[L.HIP_EL] = 0.03
        spread[L.SHAPE] = 0.06 * lm.MEAN_SHAPE
        for leg in (L.LEFT, L.RIGHT):
            spread[leg] = [0.25, 0.06, 0.12, 0.25, 0.15, 0.06]
        x = base + self.rng.standard_normal((p, lm.STATE_DIM)) * spread
        for leg in (L.LEFT, L.RIGHT):
            k = leg.start + L.KNEE_FLEX
            x[:, k] = np.abs(x[:, k])
        x, _, _ = lm.enforce_constraints(x, fallback=np.broadcast_to(base, x.shape).copy())
        self._x_prev = x.copy()
        layers = max(cfg.n_layers, 2)
        betas = tuple(np.linspace(0.3, 1.0, layers))
        for r in range(cfg.init_rounds if rounds is None else rounds):
            g = cfg.init_noise_gain * (0.6**r)
            x = self._run_stages(frame, x, gain=max(g, 1.0), layers=layers, betas=betas)
        return x

    def _redetect(self, frame: _Frame) -> bool:
        """A fresh search on this frame; its particles replace the track's where its mean state scores
        ``redetect_margin`` higher than the track's (both legs' every segment, as :meth:`score`).  Returns
        whether they did."""
        assert self._x is not None and self._logw is not None
        track_x, track_prev, hidden, main_rng = self._x, self._x_prev, self._hidden, self.rng
        self._hidden = _HiddenState()  # the search and the comparison see every part
        self.rng = self._redetect_rng
        try:
            fresh = self._search_fresh(frame, self.config.redetect_rounds or None)
            means = np.stack([self._weighted_mean(track_x, self._logw), fresh.mean(axis=0)])
            means, _, _ = lm.enforce_constraints(means)
            ll = self._compare(frame, means)
        finally:
            self._hidden = hidden
            self._x_prev = track_prev
            self.rng = main_rng
        if not ll[1] > ll[0] + self.config.redetect_margin:
            return False
        self._forget_parts()
        self._x = fresh
        self._x_prev = fresh.copy()
        self._logw = self._evaluate(frame, fresh, legs=(0, 1), ref=None)
        return True

    def _compare(self, frame: _Frame, states: FloatArray) -> FloatArray:
        """Log likelihood of a few ``states`` with every segment of both legs in it (none left out as hidden) and
        all the frame's foreground points (up to ``_REDETECT_POINTS``): few states make them all affordable, so the
        comparison does not hang on the particles' sub-sample of them."""
        every = frame.fg_all_body[:: max(1, math.ceil(frame.fg_all_body.shape[0] / _REDETECT_POINTS))]
        full = dataclasses.replace(frame, fg=frame.body.to_camera(every)) if every.shape[0] else frame
        hidden = self._hidden
        self._hidden = _HiddenState()
        try:
            return self._evaluate(full, states, legs=(0, 1), ref=None)
        finally:
            self._hidden = hidden

    # -- estimate, visibility, confidence ----------------------------------------------
    def _estimate(self, frame: _Frame, stamp: float) -> tuple[LegPose, float, float, BoolArray]:
        """Pose estimate, its confidence, the fraction of foreground it explains and, per leg, whether
        its calf and foot lie over nothing (see :meth:`_visibility`)."""
        assert self._x is not None and self._logw is not None
        w = normalise_log_weights(self._logw)
        mean = w @ self._x
        kin_all = lm.forward_kinematics(self._x)
        points = kin_all.points
        if self.config.flat_feet_report[1] > 0.0:
            below, blend = self.config.flat_feet_report
            points = lm.flatten_feet(points, lm.sole_heights(kin_all), flat_below=below, blend_to=blend,
                                     floor_tol=self.config.flat_feet_floor_tol)
        pts_body = np.einsum("p,pijk->ijk", w, points)
        mean_c, kin_mean, _ = lm.enforce_constraints(mean[None])
        self._mean = mean_c[0]
        if math.isfinite(self.config.passing_jump):  # what the passing check reads
            self._recent = [*self._recent[1 - _PASSING_HISTORY:],
                            (float(stamp), kin_mean.points[0, :, TOE].copy(), self._mean.copy())]
        seg_c, rad, _ = self._cam_segments(frame, kin_mean, (0, 1))
        visibility, unsupported = self._visibility(frame, seg_c, rad)
        conf, explained = self._confidence(frame, seg_c, rad)
        if self.config.hidden_parts:
            self._update_hidden(visibility)
        if math.isfinite(self.config.footprint_sigma):  # only that prior reads the footprints
            seen = (visibility[:, 2] >= self.config.show_above) & ~self._hidden.hidden[:, 2]
            self._footprints.update(stamp, pts_body, seen, release_s=self.config.footprint_release_s)
        rise = turn = None
        if self.defer_feet:
            self.pending_feet = pts_body.copy()
        else:
            pts_body, rise, turn = self._feet.measure(pts_body, body=frame.body, fg_all_body=frame.fg_all_body,
                                                      no_depth=frame.no_depth)
        pose = LegPose(
            stamp=stamp,
            points=frame.body.to_camera(pts_body),
            angles=lm.joint_angles(mean),
            segments=seg_c[0].reshape(2, 3, 2, 3),
            radii=rad[0].reshape(2, 3, 2),
            visibility=visibility,
            status=self.status,
            confidence=conf,
            ess=effective_sample_size(self._logw),
            shoe_rise=rise,
            shoe_turn=turn,
        )
        return pose, conf, explained, unsupported

    def _visibility(self, frame: _Frame, seg_c: FloatArray, rad: FloatArray) -> tuple[FloatArray, BoolArray]:
        """``(2, 3)`` fraction of each segment's axis points whose pixel shows its surface, and ``(2,)``
        whether each leg's calf and foot lie over nothing.

        A point (12 per segment, on the axis, with the local radius) counts as seen when it
        projects into the image onto foreground whose depth is not clearly in front of the
        model's front surface (``obs >= z - r - 5 cm``); points whose surface lies below the
        segmentation's floor cut are unobservable and not counted.  This is the per-pixel
        comparison of seed 003 §III-D sampled along the axis instead of over rendered pixels
        (no rendering per frame).
        """
        cue = frame.cue
        pts, wd = skeleton_points(seg_c, rad, n=_VIS_POINTS)  # (1, 6, K, 3), (1, 6, K)
        pts, wd = pts[0], wd[0]
        inside, obs, unknown = cue.sample(pts)
        seen = inside & (obs > 0) & (obs >= pts[..., 2] - wd - 0.05)
        counted = ~cue.below_cut(pts, wd) if cue.min_height > 0 else np.ones_like(seen)
        # A segment nobody can see is either hidden (observed surface in front of it: the other leg, an
        # object) or it is where the data say there is no leg (out of the image, over background).  The
        # lower leg of a user at the walker is in view (ankles in 100 % of the frames of every synthetic
        # scenario), so a calf and foot that lie over nothing mean the estimate has left the data
        # (the hidden-part machine would otherwise take them out of the likelihood and let them stay there).
        # A point holds the leg where its pixel shows observed surface (it is seen, or hidden behind it) or has
        # no depth (it may be hidden there: a shin nearer than the sensor's range blanks the view around it, and
        # a leg mostly in such a hole, with a few points out of the image above its knee, is not over nothing).
        held = inside & counted & ((obs > 0) | unknown)
        n_low = counted.reshape(2, 3, -1)[:, 1:].sum(axis=(1, 2))
        held_low = held.reshape(2, 3, -1)[:, 1:].sum(axis=(1, 2))
        counted &= ~unknown  # nothing was measured there: neither seen nor hidden
        n = counted.sum(axis=1)
        vis = np.where(n > 0, (seen & counted).sum(axis=1) / np.maximum(n, 1), 0.0)
        unsupported = (n_low > 0) & (held_low <= _UNSUPPORTED_MAX * n_low)
        return vis.reshape(2, 3), unsupported

    def _confidence(self, frame: _Frame, seg_c: FloatArray, rad: FloatArray) -> tuple[float, float]:
        """``(confidence, explained)``: ``explained`` = fraction of foreground explained (surface
        distance < support_tol); the confidence averages it with the fraction of unoccluded model
        skeleton points supported by foreground."""
        tol = self.config.support_tol
        fg_cost = foreground_costs(seg_c, rad, fg=frame.fg, n=self.config.n_skeleton)[0]
        explained = float(np.mean(fg_cost < tol)) if fg_cost.size else 0.0
        pts, wd = skeleton_points(seg_c, rad, n=self.config.n_skeleton)
        pts = pts.reshape(-1, 3)
        wd = wd.ravel()
        occ = frame.cue.occluded(pts, wd, tol=0.04)
        if frame.fg.shape[0] == 0 or np.all(occ):
            return explained, explained
        d = np.sqrt(((pts[~occ, None, :] - frame.fg[None, :, :]) ** 2).sum(-1)).min(axis=1)
        supported = float(np.mean(np.abs(d - wd[~occ]) < tol))
        return 0.5 * (explained + supported), explained

    def _update_hidden(self, visibility: FloatArray) -> None:
        cfg = self.config
        hs = self._hidden
        low = visibility < cfg.hide_below
        hs.low_count = np.where(low, hs.low_count + 1, 0)
        newly_hidden = ~hs.hidden & (hs.low_count >= 2)
        reappear = hs.hidden & (visibility > cfg.show_above)
        hs.hidden = (hs.hidden | newly_hidden) & ~reappear
        for side in (0, 1):
            if np.any(reappear[side]):
                hs.boost[side] = cfg.reappear_frames
