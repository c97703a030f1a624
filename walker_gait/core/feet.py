"""Toe tips measured from the foreground near each tracked foot.

The particle filter places each foot as the end of a kinematic chain (hip, thigh, calf, ankle): with a
couple of hundred particles in 23 dimensions it settles a few centimetres from the shoe it sees, and the
foot's end moves with every error up the chain (segment lengths, hip position).  The shoe itself, seen
from the walker, is the best-observed part of the leg: the camera looks at the toe box.  So once the
filter has placed the foot, the toe it reports is measured from the foreground around it:

* the foreground points between ``min_height`` (the segmentation's floor cut) and ``max_height`` above the
  floor (the shoe; a trouser hem hangs above the toe box, not ahead of it), horizontally within ``radius``
  of the tracked foot's heel-to-toe line and nearer to it than to the other foot's;
* along the tracked foot's direction (on the floor) the toe is the ``percentile`` of those points'
  positions, up to ``reach`` ahead of the tracked toe (beyond, the other leg's trouser hem swinging past
  a foot in its heel rise): the front of the toe box; across it, the median of the lateral positions of those within
  ``toe_box`` of that front (the toe box's centre line: the whole shoe's centre lies half a foot back, where a yaw
  error of the tracked foot has moved it half as far);
* a foot pitched up on its toes (late stance) leans its toe box forward over the sole's tip: the points are
  turned back flat about the tip by the tracked foot's heel-up pitch beyond ``pitch_deadband`` (the filter holds
  flat feet a few degrees heel-up), the tip on the floor (where a foot in its heel rise keeps it, whatever height
  the filter holds it at) unless the tracked one is above ``min_height`` (a foot in the air), and the front is
  taken from the points at least ``min_height`` above the sole: what the floor cut leaves of the same shoe flat;
* the toe's height stays the tracked one, and nothing else of the pose moves;
* a foot whose tracked or measured toe lies at the image's border (:func:`toes_in_view`) keeps its tracked toe
  along the foot and only the measured offset across it (:func:`across_only`): the shoe may be cut there, and the
  front of what is left of it is the border, while its centre line is still the shoe's.

This is done only for a foot that points towards the camera (its toe box faces the lens: a camera on the
walker looking back at its user), with at least ``min_points`` such points.  The particles are left as they
are: this changes what the tracker reports, not what it tracks (pulling the particles' toes towards the
measured ones with a Gaussian prior made the tracking worse: DEVELOPERS.md, twenty-ninth session).

Measured with ``make sweep`` (32 synthetic sessions x 2 tracker seeds, sets C and A; DEVELOPERS.md): toe error
4.50 / 4.66, 4.35 / 4.76 -> 3.77 / 3.91, 3.63 / 4.04 cm, step length median |error| 2.40 / 2.36, 2.15 / 2.55
-> 1.22 / 1.26, 1.26 / 1.07 cm and mean 3.52 / 4.04, 3.06 / 4.33 -> 2.91 / 3.23, 2.94 / 3.87 cm.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from walker_gait.core import kernels
from walker_gait.core.types import HEEL, TOE, CameraIntrinsics

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

_MAX_PITCH = 0.8  # rad: the heel-up pitch beyond which the toe box's lean is not corrected further


@dataclass(frozen=True, kw_only=True)
class ToeFit:
    """Parameters of :func:`measure_toes` (metres)."""

    min_height: float = 0.03  # lowest point used: the segmentation's floor cut
    max_height: float = 0.12  # highest: the shoe (a heel counter is ~10 cm high)
    radius: float = 0.10  # horizontal distance from the tracked foot's heel-to-toe line
    percentile: float = 99.0  # of the points' positions along the foot: its front
    reach: float = 0.04  # points further than this ahead of the tracked toe (along the foot) are not the shoe
    pitch_deadband: float = 0.1  # rad: heel-up pitch of the tracked foot below which it counts as flat
    min_points: int = 20  # fewer points near a foot leave its toe as tracked
    border_px: float = 4.0  # a tracked or measured toe this near the image's border (pixels): the shoe may be cut there
    toe_box: float = 0.08  # the toe's offset across the foot is the median of the points this far behind the front (the toe box; the whole shoe's centre turns with a yaw error of the tracked foot: its middle is half a foot back)

    def __post_init__(self) -> None:
        if not (0.0 <= self.min_height < self.max_height and self.radius > 0.0):
            raise ValueError(f"need 0 <= min_height < max_height and radius > 0, got {self.min_height}, "
                             f"{self.max_height}, {self.radius}")
        if not self.reach > 0.0:
            raise ValueError(f"reach must be > 0, got {self.reach}")
        if not self.pitch_deadband >= 0.0:
            raise ValueError(f"pitch_deadband must be >= 0, got {self.pitch_deadband}")
        if not 0.0 < self.percentile <= 100.0:
            raise ValueError(f"percentile must be in (0, 100], got {self.percentile}")
        if not self.toe_box > 0.0:
            raise ValueError(f"toe_box must be > 0, got {self.toe_box}")
        if not self.border_px >= 0.0:
            raise ValueError(f"border_px must be >= 0, got {self.border_px}")
        if self.min_points < 1:
            raise ValueError(f"min_points must be >= 1, got {self.min_points}")


def _distance_to_segment_xy(q: FloatArray, a: FloatArray, b: FloatArray, *, squared: bool = False) -> FloatArray:
    """Horizontal distance of points ``q`` (N, 3) to the segment ``a``-``b`` projected on the floor (its square with
    ``squared``)."""
    ab = (b - a)[:2]
    den = float(ab @ ab)
    rel = q[:, :2] - a[:2]
    t = np.zeros(q.shape[0]) if den < 1e-12 else np.clip((rel @ ab) / den, 0.0, 1.0)
    d = rel - t[:, None] * ab
    d2 = np.einsum("ij,ij->i", d, d)
    return d2 if squared else np.sqrt(d2)


def _toe_points(legs: FloatArray, pts: FloatArray, lo: FloatArray, hi: FloatArray,
                fit: ToeFit) -> Callable[[int], FloatArray] | None:
    """The foreground ``pts`` each foot's toe is measured from (:func:`measure_toes`), as a function of the side: those
    between the fit's heights, inside the box ``lo``-``hi`` (x, y) and within ``radius`` of that foot's heel-to-toe
    line and nearer to it than to the other's, in their order; None where the band holds fewer than ``min_points``.
    One compiled pass over the points where numba is installed (:mod:`walker_gait.core.kernels`), else numpy's."""
    jit = kernels.compiled()
    if jit is not None:
        pts = np.ascontiguousarray(pts, dtype=np.float64)
        side_of = np.empty(pts.shape[0], dtype=np.int8)
        n_band = jit.toe_sides(pts, fit.min_height, fit.max_height, float(lo[0]), float(lo[1]), float(hi[0]),
                               float(hi[1]), np.ascontiguousarray(legs[:, HEEL]), np.ascontiguousarray(legs[:, TOE]),
                               fit.radius, side_of)
        if n_band < fit.min_points:
            return None
        return lambda side: pts[side_of == side]
    z = pts[:, 2]
    band = pts[(z > fit.min_height) & (z < fit.max_height)]
    band = band[np.all((band[:, :2] > lo) & (band[:, :2] < hi), axis=1)]
    if band.shape[0] < fit.min_points:
        return None
    dist = np.stack([_distance_to_segment_xy(band, legs[s, HEEL], legs[s, TOE]) for s in (0, 1)])
    return lambda side: band[(dist[side] < fit.radius) & (dist[side] < dist[1 - side])]


def measure_toes(
    legs: FloatArray, points: FloatArray, *, camera: FloatArray, fit: ToeFit = ToeFit()
) -> tuple[FloatArray, BoolArray]:
    """Toe tips measured from the foreground ``points`` near each tracked foot.

    ``legs`` ``(2, 5, 3)``: tracked ``LEG_POINTS`` per side; ``points`` ``(N, 3)``: foreground; ``camera``
    ``(3,)``: the camera's position; all in one floor-aligned frame (z = height above the floor, metres).
    Returns the ``(2, 3)`` toes (the tracked ones where nothing was measured) and which sides were measured.
    """
    legs = np.asarray(legs, dtype=np.float64)
    pts = np.asarray(points, dtype=np.float64)
    if legs.shape != (2, 5, 3) or pts.ndim != 2 or pts.shape[1] != 3:
        raise ValueError(f"need legs (2, 5, 3) and points (N, 3), got {legs.shape} and {pts.shape}")
    toes = legs[:, TOE].copy()
    measured = np.zeros(2, dtype=bool)
    if not np.all(np.isfinite(legs[:, (HEEL, TOE)])):
        return toes, measured
    # the shoe band, within the feet's horizontal reach (a box around both heel-to-toe lines: cheap, and most of
    # the foreground, the shins above, is gone before the distances)
    ends = legs[:, (HEEL, TOE), :2].reshape(-1, 2)
    lo, hi = ends.min(axis=0) - fit.radius - fit.reach, ends.max(axis=0) + fit.radius + fit.reach
    near_sides = _toe_points(legs, pts, lo, hi, fit)
    if near_sides is None:
        return toes, measured
    cam = np.asarray(camera, dtype=np.float64)
    for side in (0, 1):
        heel, toe = legs[side, HEEL], legs[side, TOE]
        u = (toe - heel)[:2]
        norm = float(np.linalg.norm(u))
        if norm < 1e-6:
            continue
        u = u / norm
        if float(u @ (cam[:2] - heel[:2])) <= 0.0:
            continue  # the foot points away from the camera: its toe box is not what the camera sees
        near = near_sides(side)
        if near.shape[0] < fit.min_points:
            continue
        v = np.array([-u[1], u[0]])
        rel = near[:, :2] - heel[:2]
        s = rel @ u
        # what lies well ahead of the tracked toe is something else: the other leg's trouser hem swinging past
        # (baggy trousers hang 11 cm around the ankle, down to a few cm above the floor), the other shoe
        shoe = s < float((toe[:2] - heel[:2]) @ u) + fit.reach
        if int(shoe.sum()) < fit.min_points:
            continue
        near, rel, s = near[shoe], rel[shoe], s[shoe]
        # a foot up on its toes (late stance) leans its toe box forward over the sole's tip, which stays on the
        # floor (rigid shoe)
        pitch = math.atan2(float(heel[2] - toe[2]), norm) - fit.pitch_deadband
        front = s
        if pitch > 0.0:
            # into the shoe's own frame: turned back flat about its tip (on the floor, where a foot in its heel rise
            # keeps it, unless the tracked tip is above the floor cut: a foot in the air), along the sole and height
            # above it; the front is taken from what stands `min_height` above the sole, what the floor cut leaves of
            # the same shoe flat.  Leaned about the tracked tip's own height, the toe moved with it: the filter holds
            # a quarter of the tips in heel rise over a centimetre up, and their toes read about 1 cm further forward
            # than the same shoe's flat, so steps from a trailing foot in heel rise to a flat landing one came out
            # short (DEVELOPERS.md, thirty-third session)
            p = min(pitch, _MAX_PITCH)
            ds = s - norm
            z_tip = float(toe[2]) if float(toe[2]) >= fit.min_height else 0.0
            dz = np.maximum(near[:, 2] - z_tip, 0.0)
            s = norm + ds * math.cos(p) - dz * math.sin(p)
            above = ds * math.sin(p) + dz * math.cos(p) >= fit.min_height
            front = s[above] if int(above.sum()) >= fit.min_points else s
        along = float(np.percentile(front, fit.percentile))
        lat = rel @ v
        box = s >= along - fit.toe_box
        across = float(np.median(lat[box] if int(box.sum()) >= fit.min_points else lat))
        toes[side, :2] = heel[:2] + along * u + across * v
        measured[side] = True
    return toes, measured


def toes_in_view(
    legs: FloatArray, toes: FloatArray, *, intrinsics: CameraIntrinsics, fit: ToeFit = ToeFit(),
    no_depth: NDArray[np.bool_] | None = None,
) -> BoolArray:
    """Per side, whether the front of the shoe can be in the image: the tracked toe and the measured one both
    project at least ``border_px`` inside the image's border, and (with ``no_depth``, ``(H, W)`` pixels without a
    depth measurement) most pixels within ``border_px`` of the tracked toe's were measured: a toe box nearer to
    the camera than the sensor's near limit is a hole in the image, and what is left of the shoe ends there.

    ``legs`` ``(2, 5, 3)`` tracked ``LEG_POINTS`` and ``toes`` ``(2, 3)`` measured toes, camera optical frame.  A
    foot that leaves the image (a user close to the camera lands their leading foot below the image's bottom
    edge) shows only the part of its shoe still in view, whose front is the border, not the toe box: measured
    there, the toe sat 12-15 cm behind the real one while the model foot had gone on with its swing (DEVELOPERS.md,
    thirty-first session).  Testing a point ``reach`` ahead of the tracked toe as well (a shoe front just past the
    border) made no difference on the sweeps (step length within 0.03 cm).
    """
    legs = np.asarray(legs, dtype=np.float64)
    toe = legs[:, TOE]
    probe = np.stack([toe, np.asarray(toes, dtype=np.float64)], axis=1)  # (2, 2, 3)
    uv = intrinsics.project(probe)
    m = fit.border_px
    with np.errstate(invalid="ignore"):
        inside = ((uv[..., 0] >= m) & (uv[..., 0] <= intrinsics.width - 1 - m)
                  & (uv[..., 1] >= m) & (uv[..., 1] <= intrinsics.height - 1 - m))
    ok = np.all(inside, axis=1)
    if no_depth is not None:
        r = max(int(round(m)), 1)
        for side in np.flatnonzero(ok):
            u, v = (int(round(float(c))) for c in uv[side, 0])
            win = no_depth[max(v - r, 0): v + r + 1, max(u - r, 0): u + r + 1]
            ok[side] = not (win.size and np.count_nonzero(win) * 2 > win.size)
    return ok


def across_only(legs: FloatArray, toes: FloatArray, sides: BoolArray) -> FloatArray:
    """``toes`` ``(2, 3)`` with, for the ``sides`` ``(2,)`` given, only their offset across the tracked foot (floor
    plane) kept: along the foot those toes are the tracked ones of ``legs`` ``(2, 5, 3)`` again.

    A shoe cut by the image's border ends at the border along the foot, but what is left of it still gives its
    centre line across the foot (on the sweeps the step width was worse without it: DEVELOPERS.md, thirty-first
    session).  All in one floor-aligned frame (z up)."""
    legs = np.asarray(legs, dtype=np.float64)
    out = np.array(toes, dtype=np.float64)
    for side in np.flatnonzero(np.asarray(sides, dtype=bool)):
        toe = legs[side, TOE]
        u = (toe - legs[side, HEEL])[:2]
        norm = float(np.hypot(*u))
        if not norm > 1e-9:
            out[side] = toe
            continue
        u = u / norm
        d = out[side, :2] - toe[:2]
        out[side, :2] = toe[:2] + d - float(d @ u) * u
        out[side, 2] = toe[2]
    return out


@dataclass(frozen=True, kw_only=True)
class ShoeStretch:
    """The stretch of a shoe behind its tracked toe whose points a line is fitted to (metres):
    :class:`ShoeRiseFit`, :class:`ShoeTurnFit`."""

    min_height: float = 0.03  # lowest point used: the segmentation's floor cut
    above_toe: float = 0.14  # highest: this far above the tracked toe (the shoe's upper, below a trouser's hem) ...
    sole_from: float | None = None  # ... or, once the tracked heel is more than this above its toe, this far above the
    # foot's heel-to-toe line lowered by this: a heel-up foot's upper rises with it, and a limit level with the toe cuts
    # the back of a steep one off (None: level; a heel held a few cm up on a flat foot leaves it level)
    behind: float = 0.14  # the stretch of the shoe measured: this far behind the tracked toe along the foot ...
    ahead: float = 0.03  # ... to this far ahead of it
    half_width: float = 0.06  # and this far either side of the foot's line
    min_points: int = 15  # fewer points leave a foot unmeasured

    def __post_init__(self) -> None:
        if not (0.0 <= self.min_height and self.above_toe > 0.0 and self.behind > 0.0 and self.ahead >= 0.0
                and self.half_width > 0.0):
            raise ValueError(f"need min_height >= 0, above_toe > 0, behind > 0, ahead >= 0 and half_width > 0, got "
                             f"{self.min_height}, {self.above_toe}, {self.behind}, {self.ahead}, {self.half_width}")
        if self.min_points < 3:
            raise ValueError(f"min_points must be >= 3, got {self.min_points}")
        if self.sole_from is not None and not self.sole_from >= 0.0:
            raise ValueError(f"sole_from must be None or >= 0, got {self.sole_from}")

    @property
    def reach(self) -> float:
        """How far (x and y) from the toe a point of the stretch can lie."""
        return self.behind + self.half_width


@dataclass(frozen=True, kw_only=True)
class ShoeRiseFit(ShoeStretch):
    """Parameters of :func:`measure_shoe_rise` (metres): the upper behind the toe, up to ``above_toe`` over the tracked
    foot's heel-to-toe line once its heel is more than ``sole_from`` above its toe.  A heel-up
    shoe's back rises past a limit level with its toe, and the least-squares slope of what is left reads the rise
    short: on synthetic sessions with feet turned out 14-20 deg the pitch read 8 deg short at 30-45 deg heel-up, and
    the heels in heel rise were 3.6 cm off (2.8 with the limit along the sole; DEVELOPERS.md, sixty-third session)."""

    sole_from: float | None = 0.04  # the filter holds flat feet 0-3 cm heel-up: their shoes measured as before


def _tops(legs: FloatArray, sole_from: float | None) -> FloatArray:
    """``(2,)`` per side, the height the highest point of a stretch can reach (less its ``above_toe``): the tracked
    toe's, or the higher of its toe's and its heel's less ``sole_from`` (:class:`ShoeStretch`)."""
    top = legs[:, TOE, 2]
    return top if sole_from is None else np.maximum(top, legs[:, HEEL, 2] - sole_from)


def _near_limits(legs: FloatArray, *, above_toe: float, reach: float,
                 sole_from: float | None) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Where the points of either shoe's upper can lie: the box ``lo``-``hi`` (x, y) within ``reach`` of both toes, and
    ``(2,)`` per side the height ``above_toe`` over its top (:func:`_tops`)."""
    toes = legs[:, TOE]
    return toes[:, :2].min(axis=0) - reach, toes[:, :2].max(axis=0) + reach, _tops(legs, sole_from) + above_toe


def _shoe_band(pts: FloatArray, *, min_height: float, lo: FloatArray, hi: FloatArray, zmax: FloatArray) -> FloatArray:
    """The foreground ``pts`` that can be on either shoe's upper (:func:`_near_limits`): between ``min_height`` and the
    higher ``zmax``, inside the box ``lo``-``hi`` (most of the foreground, the shins above, is gone before the
    distances)."""
    x, y, z = pts[:, 0], pts[:, 1], pts[:, 2]
    return pts[(z > min_height) & (z < float(zmax.max()))
               & (x > lo[0]) & (x < hi[0]) & (y > lo[1]) & (y < hi[1])]


def _near_toes(toes: FloatArray, band: FloatArray, *, zmax: FloatArray, reach: float) -> list[FloatArray]:
    """Per side, the points of ``band`` (:func:`_shoe_band`) below its ``zmax`` and within ``reach`` of its toe
    (``toes`` ``(2, 3)``) in x and y."""
    bx, by, bz = band[:, 0], band[:, 1], band[:, 2]
    return [band[(bz < top) & (np.abs(bx - toe[0]) < reach) & (np.abs(by - toe[1]) < reach)]
            for toe, top in zip(toes, zmax)]


def _shoe_strips(legs: FloatArray, near: list[FloatArray],
                 fit: ShoeStretch) -> list[tuple[FloatArray, FloatArray, FloatArray] | None]:
    """Per side, the points of ``near`` (:func:`_near_toes`, at least the stretch's ``reach``) on the stretch of the
    shoe behind its tracked toe: their position along the tracked foot and across it (metres from the toe, the foot's
    left positive) and their height, or None where fewer than ``min_points``: from ``behind`` the toe to ``ahead`` of
    it along the foot, within ``half_width`` of its line, and nearer this foot's heel-to-toe line than the other's (the
    other shoe)."""
    behind, ahead, half_width, min_points = fit.behind, fit.ahead, fit.half_width, fit.min_points
    out: list[tuple[FloatArray, FloatArray, FloatArray] | None] = [None, None]
    toes = legs[:, TOE]
    jit = kernels.compiled()
    for side in (0, 1):
        toe = toes[side]
        u = (toe - legs[side, HEEL])[:2]
        norm = float(np.hypot(*u))
        if norm < 1e-6 or near[side].shape[0] < min_points:
            continue
        u = u / norm
        up = 0.0 if fit.sole_from is None else max(float(legs[side, HEEL, 2] - toe[2]) - fit.sole_from, 0.0)
        if jit is not None:  # the same in one compiled pass
            m = near[side].shape[0]
            sc, cc, zc = np.empty(m), np.empty(m), np.empty(m)
            k = jit.shoe_strip(np.ascontiguousarray(near[side]), np.ascontiguousarray(toe),
                               np.ascontiguousarray(legs[1 - side, HEEL]), np.ascontiguousarray(toes[1 - side]),
                               float(u[0]), float(u[1]), norm, ahead, behind, half_width, up, fit.above_toe, sc, cc, zc)
            if k >= min_points:
                out[side] = (sc[:k], cc[:k], zc[:k])
            continue
        rel = near[side][:, :2] - toe[:2]
        s = rel @ u
        c = rel @ np.array([-u[1], u[0]])
        strip = (s < ahead) & (s > -behind) & (np.abs(c) < half_width)
        # up to above_toe over the toe, or over the heel-to-toe line of a heel-up foot (the points near the toes may
        # reach higher: cut for another fit along the sole)
        rise = up * np.clip(-s / norm, 0.0, 1.0) if up > 0.0 else 0.0
        strip &= near[side][:, 2] < toe[2] + rise + fit.above_toe
        pts, s, c = near[side][strip], s[strip], c[strip]
        # squared distance to this foot's heel-to-toe line (s from the toe, c across it: the strip's own frame), and
        # to the other's
        own = c * c + np.maximum(s, 0.0) ** 2 + np.maximum(-norm - s, 0.0) ** 2
        keep = own < _distance_to_segment_xy(pts, legs[1 - side, HEEL], toes[1 - side], squared=True)
        if int(keep.sum()) < min_points:
            continue
        out[side] = (s[keep], c[keep], pts[keep, 2])
    return out


def _slope(x: FloatArray, y: FloatArray) -> float:
    """The least-squares slope of ``y`` against ``x``; NaN where ``x`` does not spread (a single column of points)."""
    dx = x - x.mean()
    var = float(dx @ dx)
    return float(dx @ (y - y.mean())) / var if var >= 1e-8 else math.nan


def _near_shoes(legs: FloatArray, points: FloatArray, *fits: ShoeStretch) -> tuple[FloatArray, list[FloatArray] | None]:
    """``legs`` as float and, per side, the foreground ``points`` near its toe that the ``fits``' stretches can take
    (:func:`_near_toes`, cut once for all of them: they share their heights); None without both feet's heels and toes or
    with fewer points than the fits need."""
    legs = np.asarray(legs, dtype=np.float64)
    pts = np.asarray(points, dtype=np.float64)
    if legs.shape != (2, 5, 3) or pts.ndim != 2 or pts.shape[1] != 3:
        raise ValueError(f"need legs (2, 5, 3) and points (N, 3), got {legs.shape} and {pts.shape}")
    if not np.all(np.isfinite(legs[:, (HEEL, TOE)])) or pts.shape[0] < min(f.min_points for f in fits):
        return legs, None
    reach = max(f.reach for f in fits)
    sole_from = min((f.sole_from for f in fits if f.sole_from is not None), default=None)  # the highest reach
    lo, hi, zmax = _near_limits(legs, above_toe=fits[0].above_toe, reach=reach, sole_from=sole_from)
    jit = kernels.compiled()
    if jit is None:
        band = _shoe_band(pts, min_height=fits[0].min_height, lo=lo, hi=hi, zmax=zmax)
        return legs, _near_toes(legs[:, TOE], band, zmax=zmax, reach=reach)
    # the same points in one compiled pass: the band of both shoes, then each toe's
    pts = np.ascontiguousarray(pts)
    near = np.empty((pts.shape[0], 2), dtype=bool)
    jit.shoe_near(pts, fits[0].min_height, float(zmax.max()), float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]),
                  np.ascontiguousarray(legs[:, TOE]), zmax, reach, near)
    return legs, [pts[near[:, 0]], pts[near[:, 1]]]


def measure_shoe_rise(legs: FloatArray, points: FloatArray, *, fit: ShoeRiseFit = ShoeRiseFit()) -> FloatArray:
    """``(2,)`` per side, the rise (rad) of the visible upper of the shoe backwards from its toe: the slope of a
    straight line fitted (least squares) to the height of the foreground ``points`` against their position along the
    tracked foot, over the stretch of the shoe behind its toe (:class:`ShoeRiseFit`); NaN where too few points.

    ``legs`` ``(2, 5, 3)``: tracked ``LEG_POINTS`` per side and ``points`` ``(N, 3)`` foreground, in one floor-aligned
    frame (z = height above the floor).  Seen from a camera on the walker the shoe's upper is the foot's best-seen
    surface: it rises from the toe box to the instep at the shoe's own angle, and a rigid shoe turned heel-up by ``p``
    rises by ``p`` more.  So the rise measured on a flat foot calibrates the shoe, and the difference measures the
    foot's pitch in heel rise and swing (:func:`walker_gait.core.pelvis.place_poses`), which the particle filter
    holds several degrees off (its foot is fitted to the whole leg's data).  A point nearer the other foot's
    heel-to-toe line than this one's belongs to the other shoe."""
    legs, near = _near_shoes(legs, points, fit)
    return np.full(2, np.nan) if near is None else _rise_in(legs, near, fit)


def _rise_in(legs: FloatArray, near: list[FloatArray], fit: ShoeRiseFit) -> FloatArray:
    rise = np.full(2, np.nan)
    strips = _shoe_strips(legs, near, fit)
    for side, strip in enumerate(strips):
        if strip is not None:
            rise[side] = math.atan(-_slope(strip[0], strip[2]))
    return rise


@dataclass(frozen=True, kw_only=True)
class ShoeTurnFit(ShoeStretch):
    """Parameters of :func:`measure_shoe_turn` (metres): a wider stretch than the rise's, the whole shoe's width
    (a shoe is about 10 cm wide) around a tracked line a few centimetres off it."""

    behind: float = 0.16
    half_width: float = 0.08
    fits: int = 2  # lines fitted, each around the foot turned to the one before: a line fitted across-against-along
    # reads part of the shoe's width, turned with it, as along the tracked foot, which pulls it towards the tracked
    # heading by the ratio of the spreads across and along (a third for a 9 cm x 16 cm upper), less so each fit

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.fits < 1:
            raise ValueError(f"fits must be >= 1, got {self.fits}")


def measure_shoe_turn(legs: FloatArray, points: FloatArray, *, fit: ShoeTurnFit = ShoeTurnFit()) -> FloatArray:
    """``(2,)`` per side, how far (rad, anticlockwise seen from above: towards the foot's left) the shoe's centre line
    is turned from the tracked foot's heading: the angle of a straight line fitted (least squares) to the foreground
    ``points``' position across the tracked foot against their position along it, over the stretch of the shoe behind
    its toe (:class:`ShoeTurnFit`); NaN where too few points.  Frames as :func:`measure_shoe_rise`'s.

    A shoe is about as wide on either side of its centre line, so the points of its upper lie about that line; the
    particle filter holds a foot's heading several degrees off (the foot's yaw is the end of the leg's chain, fitted
    to the whole leg's data).  Flat on the floor the measured line is within a degree of the true heading on the
    synthetic sessions where the tracker's is 2-6 deg off (DEVELOPERS.md, sixtieth session); a trouser hem over the
    shoe turns it anywhere, which the placement tells by how it jumps from frame to frame
    (:func:`walker_gait.core.pelvis.shoe_heading`)."""
    legs, near = _near_shoes(legs, points, fit)
    return np.full(2, np.nan) if near is None else _turn_in(legs, near, fit)


def _turn_in(legs: FloatArray, near: list[FloatArray], fit: ShoeTurnFit) -> FloatArray:
    legs = legs.copy()
    done = np.zeros(2)  # the turn so far, per side (NaN: unmeasured)
    for _ in range(fit.fits):
        strips = _shoe_strips(legs, near, fit)
        for side, strip in enumerate(strips):
            if strip is None:
                done[side] = math.nan
                continue
            step = math.atan(_slope(strip[0], strip[1]))
            done[side] += step
            if math.isfinite(step):  # the foot turned about its toe to the line found, for the next fit
                c, s_ = math.cos(step), math.sin(step)
                back = legs[side, HEEL, :2] - legs[side, TOE, :2]
                legs[side, HEEL, :2] = legs[side, TOE, :2] + np.array([c * back[0] - s_ * back[1],
                                                                        s_ * back[0] + c * back[1]])
        if not np.any(np.isfinite(done)):
            break
    return done


def measure_shoes(legs: FloatArray, points: FloatArray, *, rise_fit: ShoeRiseFit = ShoeRiseFit(),
                  turn_fit: ShoeTurnFit = ShoeTurnFit()) -> tuple[FloatArray, FloatArray]:
    """:func:`measure_shoe_rise` and :func:`measure_shoe_turn` of the same frame, the foreground's band around the
    shoes cut once (the tracker's report: the same results as the two apart, in less time)."""
    if rise_fit.min_height != turn_fit.min_height or rise_fit.above_toe != turn_fit.above_toe:
        return measure_shoe_rise(legs, points, fit=rise_fit), measure_shoe_turn(legs, points, fit=turn_fit)
    legs, near = _near_shoes(legs, points, rise_fit, turn_fit)
    n = np.asarray(points).shape[0]
    rise = _rise_in(legs, near, rise_fit) if near is not None and n >= rise_fit.min_points else np.full(2, np.nan)
    turn = _turn_in(legs, near, turn_fit) if near is not None and n >= turn_fit.min_points else np.full(2, np.nan)
    return rise, turn
