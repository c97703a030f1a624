"""numba kernels of the tracker (likelihood, leg model, priors, feet measures) and the segmentation; import
through :func:`walker_gait.core.kernels.compiled` (needs numba), whose docstring lists them.

All kernels are compiled with numpy's error model (a division by zero gives inf / NaN as in numpy, and
leaves the loops free of Python's exception checks, which would stop their vectorisation), without fast-math
(no reassociation, no fused multiply-add: results do not depend on the CPU's vector width), and release the
GIL.  Every inner loop runs over a contiguous slice indexed from 0, which lets LLVM vectorise it.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numba import types as nt

_F0 = np.float32(0.0)
_F1 = np.float32(1.0)
_INF_BITS = np.int32(0x7F800000)  # bit pattern of float32 +inf


# Signatures given: compiled (or loaded from the cache) when this module is imported, never again at a call.
# The callers in `likelihood` pass exactly these types.
_RENDER_SIG = ("void(float32[:, :, ::1], int64, int64, int64[:, ::1], float64[:, ::1], float64[:, ::1], "
               "float64[:, ::1], float64[:, ::1], float64[:, :, ::1], float64[:, ::1], float64[:, ::1], "
               "float64[:, :, ::1], float64, boolean[::1], float32[:, ::1], float64, float64)")
_COSTS_SIG = ("void(float32[:, :, ::1], float32[:, ::1], float32[::1], float32[::1], float32[::1], int32[:, ::1], "
              "float32[:, ::1], float32[::1])")


@njit(_RENDER_SIG, cache=True, nogil=True, error_model="numpy")
def render_boxes(img, v0, u0, boxes, ax, ay, bx, by, rad, za, zb, drad, fx, clip, ray_up, floor_offset,
                 threshold):  # pragma: no cover - compiled (tested against the numpy renderer)
    """z-buffer the capsules of segments ``boxes[:, 0]`` into ``img`` ``(P, h, w)`` (top-left pixel ``(v0, u0)``).

    ``boxes`` ``(B, 5)`` int64 rows ``(segment, v_start, v_stop, u_start, u_stop)``: each segment's pixel box;
    ``ax, ay, bx, by`` ``(P, S)`` projected end points (px), ``za, zb`` their depths, ``rad`` / ``drad``
    ``(P, S, 2)`` projected half-widths / depth radii at the ends (float64); ``fx`` focal length; ``clip``
    ``(S,)`` segments whose surface below the floor (``z * ray_up + floor_offset < threshold``) is dropped.
    The arithmetic is the numpy renderer's (:func:`walker_gait.core.likelihood.render_depth`), step by step.
    """
    n_p = img.shape[0]
    fx32 = np.float32(fx)
    off = np.float32(floor_offset)
    thr = np.float32(threshold)
    width = 0
    for b in range(boxes.shape[0]):
        width = max(width, boxes[b, 4] - boxes[b, 3])
    tu = np.empty(width, np.float32)
    pu = np.empty(width, np.float32)
    for b in range(boxes.shape[0]):
        j, sv0, sv1, su0, su1 = boxes[b, 0], boxes[b, 1], boxes[b, 2], boxes[b, 3], boxes[b, 4]
        nu = su1 - su0
        keep_all = not clip[j]
        for p in range(n_p):
            axp, ayp = ax[p, j], ay[p, j]
            dx, dy = bx[p, j] - axp, by[p, j] - ayp
            len2 = max(dx * dx + dy * dy, 1e-6)
            ln = np.sqrt(len2)
            cu, cv, ku, kv = dx / len2, dy / len2, -dy / ln, dx / ln
            ln32 = np.float32(ln)
            ra = np.float32(rad[p, j, 0])
            dr = np.float32(rad[p, j, 1] - rad[p, j, 0])
            rd0 = np.float32(drad[p, j, 0])
            drd = np.float32(drad[p, j, 1] - drad[p, j, 0])
            z0 = np.float32(za[p, j])
            dz = np.float32(zb[p, j] - za[p, j])
            for k in range(nu):
                du = (su0 + k) - axp
                tu[k] = np.float32(du * cu)  # along-axis parameter, column term
                pu[k] = np.float32(du * ku)  # perpendicular distance, column term
            for v in range(sv0, sv1):
                dv = v - ayp
                tv = np.float32(dv * cv)
                pv = np.float32(dv * kv)
                row = img[p, v - v0, su0 - u0 : su1 - u0]
                up = ray_up[v, su0:su1]
                for k in range(nu):
                    t_raw = tv + tu[k]
                    t = t_raw if t_raw > _F0 else _F0
                    t = t if t < _F1 else _F1
                    e = (t_raw - t) * ln32  # along-axis excess (px)
                    d = pv + pu[k]  # perpendicular distance (px)
                    d2 = d * d
                    d2 += e * e
                    r = t * dr + ra
                    z = t * dz + z0
                    rho = r * fx32 / z
                    rho = rho * rho
                    q = _F1 - d2 / rho
                    zs = z - np.sqrt(q if q > _F0 else _F0) * (t * drd + rd0)  # front-surface depth
                    h = zs * up[k] + off
                    cur = row[k]
                    row[k] = zs if (q > _F0) & ((h >= thr) | keep_all) & (zs < cur) else cur


@njit(_COSTS_SIG, cache=True, nogil=True, error_model="numpy")
def surface_costs(pts, widths, fgx, fgy, fgz, row_min_bits, fm, scratch):  # pragma: no cover - compiled
    """The 3D cue's two minima over ``(P, M, N)`` distances, without building them.

    ``pts`` ``(P, M, 3)`` and ``widths`` ``(P, M)`` skeleton points and radii, ``fgx, fgy, fgz`` ``(N,)``
    foreground coordinates (float32).  Writes ``row_min_bits`` ``(P, M)`` (the float32 bit pattern, as int32,
    of ``min_n ||f_n - m||``) and ``fm`` ``(P, N)`` (``min_m | ||f_n - m|| - w_m |``); ``scratch`` ``(N,)``
    float32.  Distances are non-negative, and non-negative floats order as their bit patterns do: the row
    minimum is an integer minimum, which vectorises (a float one does not without fast-math).
    """
    n_p, n_m = widths.shape
    n = fgx.shape[0]
    bits = scratch.view(np.int32)
    for p in range(n_p):
        f = fm[p]
        for i in range(n):
            f[i] = np.inf
        for m in range(n_m):
            x, y, z, w = pts[p, m, 0], pts[p, m, 1], pts[p, m, 2], widths[p, m]
            for i in range(n):
                a = x - fgx[i]
                b = y - fgy[i]
                c = z - fgz[i]
                d = np.sqrt(a * a + b * b + c * c)
                scratch[i] = d
                e = abs(d - w)
                g = f[i]
                f[i] = e if e < g else g
            r = _INF_BITS
            for i in range(n):
                s = bits[i]
                r = s if s < r else r
            row_min_bits[p, m] = r


_COST_SUMS_SIG = ("void(float32[:, ::1], float32[::1], boolean, float32[::1], boolean[::1], boolean, float32, float32, "
                  "float32, float64[::1], float32[::1])")


@njit(_COST_SUMS_SIG, cache=True, nogil=True, error_model="numpy")
def depth_cost_sums(model, ref, use_ref, obs, unknown, occlusion_aware, tol, occluded_cost, truncate, out,
                    scratch):  # pragma: no cover - compiled (tested against depth_costs)
    """Per-particle sums of the 2D cue's pixel costs (eq. 8) over the pixels not ``unknown``: ``out`` ``(P,)``.

    ``model`` ``(P, Npix)`` rendered depth (inf = nothing rendered), z-buffered with ``ref`` ``(Npix,)`` when
    ``use_ref``; ``obs`` ``(Npix,)`` observed depth (0 = background); ``scratch`` ``(Npix,)``.  Each cost is
    :func:`walker_gait.core.likelihood.depth_costs`'s float32 value; they are summed in float64, in eight
    interleaved partial sums (pixel ``i`` into sum ``i % 8``) added up at the end.
    """
    n_p, n = model.shape
    occ_on = occlusion_aware
    for p in range(n_p):
        row = model[p]
        for i in range(n):
            m = row[i]
            r = ref[i] if use_ref else m
            m = r if r < m else m
            seen = m < np.inf
            mv = m if seen else _F0
            k = obs[i]
            c = abs(mv - k)
            c = occluded_cost if occ_on & seen & (k > _F0) & (k < mv - tol) else c
            c = truncate if c > truncate else c
            scratch[i] = _F0 if unknown[i] else c
        a0 = a1 = a2 = a3 = a4 = a5 = a6 = a7 = 0.0
        n8 = n - n % 8
        for i in range(0, n8, 8):
            a0 += scratch[i]
            a1 += scratch[i + 1]
            a2 += scratch[i + 2]
            a3 += scratch[i + 3]
            a4 += scratch[i + 4]
            a5 += scratch[i + 5]
            a6 += scratch[i + 6]
            a7 += scratch[i + 7]
        for i in range(n8, n):
            a0 += scratch[i]
        out[p] = ((a0 + a1) + (a2 + a3)) + ((a4 + a5) + (a6 + a7))


# The feet's measures (:mod:`walker_gait.core.feet`) pick a few thousand of the tens of thousands of foreground points
# per frame: in numpy each test is a pass over all of them.  These kernels make one pass and keep the points in their
# order; what follows (percentiles, medians, line fits) stays numpy's.  Their arithmetic is numpy's term by term
# (numpy's 2-vector dot products may go through BLAS, which can fuse a multiply-add: they agree to rounding, tested).

_TOE_SIDES_SIG = ("int64(float64[:, ::1], float64, float64, float64, float64, float64, float64, float64[:, ::1], "
                  "float64[:, ::1], float64, int8[::1])")


@njit(inline="always")
def _segment_dist2_xy(x, y, ax, ay, abx, aby, den):  # pragma: no cover - compiled
    """Squared horizontal distance of ``(x, y)`` to the segment from ``(ax, ay)`` along ``(abx, aby)`` (``den`` its
    squared length), as :func:`walker_gait.core.feet._distance_to_segment_xy`."""
    rx = x - ax
    ry = y - ay
    t = 0.0
    if not den < 1e-12:
        t = (rx * abx + ry * aby) / den
        t = 0.0 if t < 0.0 else (1.0 if t > 1.0 else t)
    dx = rx - t * abx
    dy = ry - t * aby
    return dx * dx + dy * dy


@njit(_TOE_SIDES_SIG, cache=True, nogil=True, error_model="numpy")
def toe_sides(pts, zlo, zhi, lo0, lo1, hi0, hi1, heel, toe, radius, side):  # pragma: no cover - compiled
    """Which foot's toe measure each of the points ``pts`` ``(N, 3)`` belongs to (:func:`walker_gait.core.feet.
    measure_toes`): ``side`` ``(N,)`` gets 0 or 1 for a point between heights ``zlo`` and ``zhi``, inside the box
    ``lo0 < x < hi0``, ``lo1 < y < hi1``, within ``radius`` of that foot's heel-to-toe line (``heel``, ``toe``
    ``(2, 3)``, on the floor) and nearer to it than to the other's, else -1.  Returns how many points the band and
    box hold."""
    n = pts.shape[0]
    ax0, ay0 = heel[0, 0], heel[0, 1]
    ax1, ay1 = heel[1, 0], heel[1, 1]
    bx0, by0 = toe[0, 0] - ax0, toe[0, 1] - ay0
    bx1, by1 = toe[1, 0] - ax1, toe[1, 1] - ay1
    den0 = bx0 * bx0 + by0 * by0
    den1 = bx1 * bx1 + by1 * by1
    count = 0
    for i in range(n):
        side[i] = -1
        x, y, z = pts[i, 0], pts[i, 1], pts[i, 2]
        if not ((z > zlo) & (z < zhi) & (x > lo0) & (x < hi0) & (y > lo1) & (y < hi1)):
            continue
        count += 1
        d0 = np.sqrt(_segment_dist2_xy(x, y, ax0, ay0, bx0, by0, den0))
        d1 = np.sqrt(_segment_dist2_xy(x, y, ax1, ay1, bx1, by1, den1))
        if (d0 < radius) & (d0 < d1):
            side[i] = 0
        elif (d1 < radius) & (d1 < d0):
            side[i] = 1
    return count


_SHOE_NEAR_SIG = ("void(float64[:, ::1], float64, float64, float64, float64, float64, float64, float64[:, ::1], "
                  "float64[::1], float64, boolean[:, ::1])")


@njit(_SHOE_NEAR_SIG, cache=True, nogil=True, error_model="numpy")
def shoe_near(pts, zlo, zhi, lo0, lo1, hi0, hi1, toe, zmax, reach, near):  # pragma: no cover - compiled
    """Which of the points ``pts`` ``(N, 3)`` lie near each toe (:func:`walker_gait.core.feet._near_shoes`): ``near``
    ``(N, 2)`` is True for a point between heights ``zlo`` and ``zhi``, inside the box ``lo0 < x < hi0``,
    ``lo1 < y < hi1``, below that side's ``zmax`` ``(2,)`` and within ``reach`` of its ``toe`` ``(2, 3)`` in x and
    y."""
    for i in range(pts.shape[0]):
        x, y, z = pts[i, 0], pts[i, 1], pts[i, 2]
        band = (z > zlo) & (z < zhi) & (x > lo0) & (x < hi0) & (y > lo1) & (y < hi1)
        for s in range(2):
            near[i, s] = band & (z < zmax[s]) & (abs(x - toe[s, 0]) < reach) & (abs(y - toe[s, 1]) < reach)


_SHOE_STRIP_SIG = ("int64(float64[:, ::1], float64[::1], float64[::1], float64[::1], float64, float64, float64, "
                   "float64, float64, float64, float64, float64, float64[::1], float64[::1], float64[::1])")


@njit(_SHOE_STRIP_SIG, cache=True, nogil=True, error_model="numpy")
def shoe_strip(near, toe, other_heel, other_toe, u0, u1, norm, ahead, behind, half_width, up, above_toe, s_out,
               c_out, z_out):  # pragma: no cover - compiled (tested against the numpy code)
    """The points of ``near`` ``(M, 3)`` on the stretch of a shoe behind its ``toe`` ``(3,)`` (:func:`walker_gait.
    core.feet._shoe_strips`): along the foot's unit heading ``(u0, u1)`` (``norm`` its heel-to-toe length) from
    ``behind`` to ``ahead`` of the toe, within ``half_width`` of its line, below ``above_toe`` over the toe raised by
    ``up`` along the sole towards the heel, and nearer this foot's heel-to-toe line than the other foot's
    (``other_heel``, ``other_toe``).  Writes their position along and across the foot (from the toe) and their height
    into ``s_out``, ``c_out``, ``z_out``, in order, and returns how many."""
    tx, ty, tz = toe[0], toe[1], toe[2]
    ox, oy = other_heel[0], other_heel[1]
    obx, oby = other_toe[0] - ox, other_toe[1] - oy
    oden = obx * obx + oby * oby
    k = 0
    for i in range(near.shape[0]):
        x, y, z = near[i, 0], near[i, 1], near[i, 2]
        rx = x - tx
        ry = y - ty
        s = rx * u0 + ry * u1
        c = rx * -u1 + ry * u0
        if not ((s < ahead) & (s > -behind) & (abs(c) < half_width)):
            continue
        rise = 0.0
        if up > 0.0:
            f = -s / norm
            rise = up * (0.0 if f < 0.0 else (1.0 if f > 1.0 else f))
        if not z < tz + rise + above_toe:
            continue
        a = s if s > 0.0 else 0.0
        b = -norm - s
        b = b if b > 0.0 else 0.0
        own = c * c + a * a + b * b
        if own < _segment_dist2_xy(x, y, ox, oy, obx, oby, oden):
            s_out[k] = s
            c_out[k] = c
            z_out[k] = z
            k += 1
    return k


# The leg model's forward kinematics and constraints (:mod:`walker_gait.core.leg_model`) run a dozen times a frame on
# every particle; in numpy they are some 150 whole-array operations on arrays of a few hundred elements each, so
# call overhead, not arithmetic, is their cost.  This kernel makes one pass over the particles with numpy's arithmetic
# term by term (the same products, sums and their order; the cosines and sines come from numpy): the same kinematics
# and the same constraint decisions, bit for bit (tested).

_CHAIN_SIG = ("void(float64[:, ::1], float64[:, ::1], float64[:, ::1], float64[::1], boolean, "
              "float64[:, :, :, :, ::1], float64[:, :, :, ::1], float64[:, :, :, ::1], float64[:, :, ::1], boolean[::1])")


@njit(inline="always")
def _nmax(a, b):  # pragma: no cover - compiled
    """``np.maximum`` of two floats (NaN propagates)."""
    return a if (a >= b) | (a != a) else b


@njit(inline="always")
def _nmin(a, b):  # pragma: no cover - compiled
    """``np.minimum`` of two floats (NaN propagates)."""
    return a if (a <= b) | (a != a) else b


@njit(inline="always")
def _turn(ax, i, j, c, s):  # pragma: no cover - compiled
    """``R <- R E`` for frame axes ``ax`` ``(3 axes, 3 xyz)``: :func:`walker_gait.core.leg_model._turn_axes`."""
    for k in range(3):
        a_i = ax[i, k]
        a_j = ax[j, k]
        ax[i, k] = a_i * c + a_j * s
        ax[j, k] = a_j * c - a_i * s


@njit(_CHAIN_SIG, cache=True, nogil=True, error_model="numpy")
def leg_chain(x, cs, sn, k, constrain, seg, radii, points, lateral, bad):  # pragma: no cover - compiled
    """Forward kinematics of states ``x`` ``(P, 23)`` into the :class:`walker_gait.core.leg_model.Kinematics` arrays
    ``seg`` ``(P, 2, 3, 2, 3)``, ``radii`` ``(P, 2, 3, 2)``, ``points`` ``(P, 2, 5, 3)``, ``lateral`` ``(P, 2, 3)``.

    ``cs`` / ``sn`` ``(14, P)``: cosines / sines of the rotation angles (pelvis azimuth, elevation, then the 12 signed
    joint angles joint-major, as :func:`walker_gait.core.leg_model._chain` makes them); ``k``: the model's constants
    (:data:`walker_gait.core.leg_model._CHAIN_CONSTANTS`).  With ``constrain`` (``x`` already clipped to its box) the
    root height of each state is shifted, in place, to put its lowest sole on the floor, the kinematics with it, and
    ``bad`` ``(P,)`` flags states whose left and right segments intersect or whose root height leaves its limits
    (:func:`walker_gait.core.leg_model.enforce_constraints`); without, ``bad`` is left alone.
    """
    back_k, down_k, heel_r, toe_r, inset = k[0], k[1], k[2], k[3], k[4]
    thigh_taper, calf_lo, calf_span, calf_taper, calf_rise = k[5], k[6], k[7], k[8], k[9]
    half_width_k, coll_calf, coll_foot, slack, z_lo, z_hi = k[10], k[11], k[12], k[13], k[14], k[15]
    n_p = x.shape[0]
    ax = np.empty((3, 3))
    ends = np.empty((2, 7, 3))
    crad = np.empty((2, 3, 2))
    for p in range(n_p):
        d = x[p, 0]
        rx, ry, rz = x[p, 3], x[p, 4], x[p, 5]
        l_thigh, l_calf, l_foot = x[p, 6], x[p, 7], x[p, 8]
        c_az, s_az, c_el, s_el = cs[0, p], sn[0, p], cs[1, p], sn[1, p]
        # hips: the left one at a spherical offset from the right one
        ends[0, 0, 0] = -(s_az * c_el) * d + rx
        ends[0, 0, 1] = (c_az * c_el) * d + ry
        ends[0, 0, 2] = s_el * d + rz
        ends[1, 0, 0] = rx
        ends[1, 0, 1] = ry
        ends[1, 0, 2] = rz
        back = back_k * l_foot
        down = down_k * l_foot
        fwd_toe = back + l_foot
        start = inset * (heel_r * l_foot)
        end = inset * (toe_r * l_foot)
        for side in range(2):
            ax[0, 0] = c_az
            ax[0, 1] = s_az
            ax[0, 2] = 0.0
            ax[1, 0] = -s_az
            ax[1, 1] = c_az
            ax[1, 2] = 0.0
            ax[2, 0] = 0.0
            ax[2, 1] = 0.0
            ax[2, 2] = 1.0
            r = 2 + side
            _turn(ax, 2, 0, cs[r, p], sn[r, p])  # hip flexion
            _turn(ax, 1, 2, cs[r + 2, p], sn[r + 2, p])  # abduction
            _turn(ax, 0, 1, cs[r + 4, p], sn[r + 4, p])  # rotation
            e = ends[side]
            for q in range(3):
                e[1, q] = e[0, q] - ax[2, q] * l_thigh
            _turn(ax, 2, 0, cs[r + 6, p], sn[r + 6, p])  # knee
            for q in range(3):
                e[2, q] = e[1, q] - ax[2, q] * l_calf
            _turn(ax, 2, 0, cs[r + 8, p], sn[r + 8, p])  # ankle flexion
            _turn(ax, 1, 2, cs[r + 10, p], sn[r + 10, p])  # inversion
            for q in range(3):
                dn = ax[2, q] * down
                e[3, q] = (ax[0, q] * back + dn) + e[2, q]
                e[4, q] = (ax[0, q] * fwd_toe + dn) + e[2, q]
                e[5, q] = ax[0, q] * start + e[3, q]
                e[6, q] = e[4, q] - ax[0, q] * end
                lateral[p, side, q] = ax[1, q]
        rc = x[p, 10]
        t = _nmin(_nmax((rc - calf_lo) / calf_span, 0.0), 1.0)
        for side in range(2):
            radii[p, side, 0, 0] = x[p, 9] * 1.0
            radii[p, side, 0, 1] = x[p, 9] * thigh_taper
            radii[p, side, 1, 0] = rc * 1.0
            radii[p, side, 1, 1] = rc * (calf_taper + calf_rise * t)
            radii[p, side, 2, 0] = l_foot * heel_r
            radii[p, side, 2, 1] = l_foot * toe_r
        if constrain:
            low = 0.0
            for side in range(2):
                drop = abs(radii[p, side, 2, 0] * half_width_k * lateral[p, side, 2])
                h = _nmin(ends[side, 5, 2], ends[side, 6, 2]) - drop
                low = h if side == 0 else _nmin(low, h)
            dz = -low
            x[p, 5] = x[p, 5] + dz
            for side in range(2):
                for j in range(7):
                    ends[side, j, 2] = ends[side, j, 2] + dz
            for side in range(2):
                for s in range(3):
                    for j in range(2):
                        crad[side, s, j] = radii[p, side, s, j]
                for j in range(2):
                    crad[side, 1, j] = _nmin(crad[side, 1, j], coll_calf)
                crad[side, 2, 0] = crad[side, 2, 0] * coll_foot
            hit = False
            for i in range(3):
                a0 = 0 if i == 0 else (1 if i == 1 else 5)
                a1 = 1 if i == 0 else (2 if i == 1 else 6)
                for j in range(3):
                    b0 = 0 if j == 0 else (1 if j == 1 else 5)
                    b1 = 1 if j == 0 else (2 if j == 1 else 6)
                    p1x, p1y, p1z = ends[0, a0, 0], ends[0, a0, 1], ends[0, a0, 2]
                    p2x, p2y, p2z = ends[1, b0, 0], ends[1, b0, 1], ends[1, b0, 2]
                    d1x, d1y, d1z = ends[0, a1, 0] - p1x, ends[0, a1, 1] - p1y, ends[0, a1, 2] - p1z
                    d2x, d2y, d2z = ends[1, b1, 0] - p2x, ends[1, b1, 1] - p2y, ends[1, b1, 2] - p2z
                    rrx, rry, rrz = p1x - p2x, p1y - p2y, p1z - p2z
                    aa = (d1x * d1x + d1y * d1y) + d1z * d1z
                    bb = (d1x * d2x + d1y * d2y) + d1z * d2z
                    cc = (d1x * rrx + d1y * rry) + d1z * rrz
                    ee = (d2x * d2x + d2y * d2y) + d2z * d2z
                    ff = (d2x * rrx + d2y * rry) + d2z * rrz
                    eps = 1e-12
                    denom = aa * ee - bb * bb
                    sv = _nmin(_nmax((bb * ff - cc * ee) / _nmax(denom, eps), 0.0), 1.0)
                    sv = sv if denom > eps else 0.0
                    t_free = (bb * sv + ff) / _nmax(ee, eps)
                    tv = _nmin(_nmax(t_free, 0.0), 1.0)
                    if tv != t_free:
                        sv = _nmin(_nmax((bb * tv - cc) / _nmax(aa, eps), 0.0), 1.0)
                    qx = (p1x + d1x * sv) - (p2x + d2x * tv)
                    qy = (p1y + d1y * sv) - (p2y + d2y * tv)
                    qz = (p1z + d1z * sv) - (p2z + d2z * tv)
                    dist = np.sqrt((qx * qx + qy * qy) + qz * qz)
                    thresh = (crad[0, i, 0] + crad[0, i, 1]) / 2.0
                    thresh = (thresh + (crad[1, j, 0] + crad[1, j, 1]) / 2.0) * slack
                    hit = hit | (dist < thresh)
            z = x[p, 5]
            bad[p] = hit | (z < z_lo) | (z > z_hi)
        for side in range(2):
            e = ends[side]
            for q in range(3):
                for j in range(5):
                    points[p, side, j, q] = e[j, q]
                seg[p, side, 0, 0, q] = e[0, q]
                seg[p, side, 0, 1, q] = e[1, q]
                seg[p, side, 1, 0, q] = e[1, q]
                seg[p, side, 1, 1, q] = e[2, q]
                seg[p, side, 2, 0, q] = e[5, q]
                seg[p, side, 2, 1, q] = e[6, q]


_CAM_SIG = ("void(float64[:, :, :, :, ::1], float64[:, :, :, ::1], float64[:, :, ::1], int64[::1], float64[:, ::1], "
            "float64[::1], boolean, float64, float64[:, :, :, ::1], float64[:, :, ::1], float64[:, :, ::1])")


@njit(_CAM_SIG, cache=True, nogil=True, error_model="numpy")
def camera_segments(seg, radii, lateral, legs, rot, trans, elliptic, half_width_k, seg_c, toward,
                    sil):  # pragma: no cover - compiled (tested against the numpy code)
    """:func:`walker_gait.core.tracker.camera_segments` in one pass: the segments of ``legs`` moved to the camera
    frame (``p rot.T + trans``) into ``seg_c`` ``(P, S, 2, 3)``, their radii towards the camera and silhouette
    half-widths into ``toward`` / ``sil`` ``(P, S, 2)``; with ``elliptic`` the feet's by
    :func:`walker_gait.core.likelihood.elliptic_section_radii` (half-width ``half_width_k`` times the heel radius).
    The rotation's sums are taken in order (numpy's matrix product may fuse multiply-adds: the two agree to
    rounding)."""
    n_p = seg.shape[0]
    for p in range(n_p):
        for li in range(legs.shape[0]):
            leg = legs[li]
            for s in range(3):
                o = 3 * li + s
                for e in range(2):
                    x, y, z = seg[p, leg, s, e, 0], seg[p, leg, s, e, 1], seg[p, leg, s, e, 2]
                    for i in range(3):
                        seg_c[p, o, e, i] = ((x * rot[i, 0] + y * rot[i, 1]) + z * rot[i, 2]) + trans[i]
                    toward[p, o, e] = radii[p, leg, s, e]
                    sil[p, o, e] = radii[p, leg, s, e]
            if not elliptic:
                continue
            o = 3 * li + 2
            lx, ly, lz = lateral[p, leg, 0], lateral[p, leg, 1], lateral[p, leg, 2]
            cl0 = (lx * rot[0, 0] + ly * rot[0, 1]) + lz * rot[0, 2]
            cl1 = (lx * rot[1, 0] + ly * rot[1, 1]) + lz * rot[1, 2]
            cl2 = (lx * rot[2, 0] + ly * rot[2, 1]) + lz * rot[2, 2]
            ax, ay, az = seg_c[p, o, 0, 0], seg_c[p, o, 0, 1], seg_c[p, o, 0, 2]
            bx, by, bz = seg_c[p, o, 1, 0], seg_c[p, o, 1, 1], seg_c[p, o, 1, 2]
            a0, a1, a2 = bx - ax, by - ay, bz - az
            n = max(np.sqrt((a0 * a0 + a1 * a1) + a2 * a2), 1e-9)
            a0, a1, a2 = a0 / n, a1 / n, a2 / n
            u0, u1, u2 = a1 * cl2 - a2 * cl1, a2 * cl0 - a0 * cl2, a0 * cl1 - a1 * cl0  # up = axis x lateral
            s0, s1, s2 = 0.5 * (ax + bx), 0.5 * (ay + by), 0.5 * (az + bz)
            n = max(np.sqrt((s0 * s0 + s1 * s1) + s2 * s2), 1e-9)
            s0, s1, s2 = s0 / n, s1 / n, s2 / n
            q0, q1, q2 = a1 * s2 - a2 * s1, a2 * s0 - a0 * s2, a0 * s1 - a1 * s0  # perp = axis x sight
            n = np.sqrt((q0 * q0 + q1 * q1) + q2 * q2)
            if n > 1e-6:
                q0, q1, q2 = q0 / n, q1 / n, q2 / n
            else:  # the axis along the line of sight
                q0, q1, q2 = cl0, cl1, cl2
            w0, w1, w2 = q1 * a2 - q2 * a1, q2 * a0 - q0 * a2, q0 * a1 - q1 * a0  # toward = perp x axis
            hw = radii[p, leg, 2, 0] * half_width_k
            pl = (q0 * cl0 + q1 * cl1) + q2 * cl2
            pu = (q0 * u0 + q1 * u1) + q2 * u2
            wl = (w0 * cl0 + w1 * cl1) + w2 * cl2
            wu = (w0 * u0 + w1 * u1) + w2 * u2
            for e in range(2):
                h = radii[p, leg, 2, e]
                sil[p, o, e] = np.sqrt((hw * pl) ** 2 + (h * pu) ** 2)
                toward[p, o, e] = np.sqrt((hw * wl) ** 2 + (h * wu) ** 2)


_CUE3D_SIG = ("void(float64[:, :, :, ::1], float64[:, :, ::1], float64[::1], float32[::1], float32[::1], float32[::1], "
              "float32[::1], boolean, float32, boolean[::1], float64[::1], float64, float64, boolean, float64, "
              "float64, float64, float64, int64, int64, float32[::1], boolean[::1], boolean, float64, float32, "
              "float32[:, ::1], "
              "float32[:, ::1], int64[::1], float32[:, :, ::1], float32[:, ::1], int32[:, ::1], float32[::1])")


@njit(inline="always")
def _segment_axis(seg, rad, p, s):  # pragma: no cover - compiled
    """Start point, start-to-end vector, start radius and radius change of segment ``s`` of particle ``p``: the skeleton
    point at ``t`` along it is ``d t + a`` with width ``r0 + dr t`` (:func:`walker_gait.core.likelihood.
    skeleton_points`'s arithmetic)."""
    ax, ay, az = seg[p, s, 0, 0], seg[p, s, 0, 1], seg[p, s, 0, 2]
    r0 = rad[p, s, 0]
    return ax, ay, az, seg[p, s, 1, 0] - ax, seg[p, s, 1, 1] - ay, seg[p, s, 1, 2] - az, r0, rad[p, s, 1] - r0


@njit(_CUE3D_SIG, cache=True, nogil=True, error_model="numpy")
def cue3d_terms(seg, rad, t, fgx, fgy, fgz, ref, use_ref, truncate, active, normal, offset, cut_level, occ_on, fx,
                fy, cx, cy, width, height, depth, unknown, has_unknown, tol, occ_cost, mf, fm, count, pts32, w32,
                row_min_bits, scratch):  # pragma: no cover - compiled (tested against the numpy code)
    """The terms of :func:`walker_gait.core.likelihood.log_likelihood_3d` in one pass, numpy's arithmetic term by
    term: ``mf`` ``(P, M)`` the d_MF terms (0 for a skeleton point left out), ``fm`` ``(P, N)`` the d_FM terms,
    ``count`` ``(P,)`` the points counted in d_MF (at least 1); numpy then takes their sum and mean as before.

    ``seg`` ``(P, S, 2, 3)`` camera-frame segments, ``rad`` ``(P, S, 2)`` their radii, ``t`` ``(K,)`` the skeleton
    points' positions along them (``M = S K``); ``fgx, fgy, fgz`` ``(N,)`` the foreground; ``ref`` ``(N,)`` the fixed
    parts' costs (``use_ref``); ``truncate`` the distance cap (inf: none); ``active`` ``(S,)`` segments in d_MF; a point
    whose surface stays under ``cut_level`` over the floor plane (``normal``, ``offset``; -inf: no cut) is left out;
    with ``occ_on`` a point out of the ``width x height`` cue image (``fx, fy, cx, cy``), over a pixel without depth
    (``unknown``, flat, ``has_unknown``) or behind observed depth (flat ``depth``) by more than ``tol`` costs
    ``occ_cost``.  ``pts32``, ``w32``, ``row_min_bits``, ``scratch``: work arrays.
    """
    n_p, n_s = rad.shape[0], rad.shape[1]
    k = t.shape[0]
    for p in range(n_p):
        for s in range(n_s):
            ax, ay, az, dx, dy, dz, r0, dr = _segment_axis(seg, rad, p, s)
            for j in range(k):
                pts32[p, s * k + j, 0] = np.float32(dx * t[j] + ax)
                pts32[p, s * k + j, 1] = np.float32(dy * t[j] + ay)
                pts32[p, s * k + j, 2] = np.float32(dz * t[j] + az)
                w32[p, s * k + j] = np.float32(r0 + dr * t[j])
    surface_costs(pts32, w32, fgx, fgy, fgz, row_min_bits, fm, scratch)
    row_min = row_min_bits.view(np.float32)
    n = fgx.shape[0]
    for p in range(n_p):
        f = fm[p]
        if use_ref:
            for i in range(n):
                f[i] = ref[i] if ref[i] < f[i] else f[i]
        for i in range(n):
            f[i] = truncate if truncate < f[i] else f[i]
        cnt = 0
        for s in range(n_s):
            ax, ay, az, dx, dy, dz, r0, dr = _segment_axis(seg, rad, p, s)
            for j in range(k):
                m = s * k + j
                v = abs(row_min[p, m] - w32[p, m])
                v = truncate if truncate < v else v
                x, y, z = dx * t[j] + ax, dy * t[j] + ay, dz * t[j] + az
                w = r0 + dr * t[j]
                keep = active[s] & (not (((x * normal[0] + y * normal[1]) + z * normal[2]) + offset + w < cut_level))
                if occ_on:
                    u = np.rint((fx * x) / z + cx)
                    vv = np.rint((fy * y) / z + cy)
                    inside = (z > 0.05) & (u >= 0) & (u < width) & (vv >= 0) & (vv < height)
                    occ = not inside
                    if inside:
                        idx = int(vv * width + u)
                        obs = depth[idx]
                        occ = ((obs > 0) & (obs < z - w - tol)) | (has_unknown and unknown[idx])
                    if occ:
                        v = occ_cost
                mf[p, m] = v if keep else np.float32(0.0)
                cnt += 1 if keep else 0
        count[p] = cnt if cnt > 1 else 1


# The tracker's pose priors (:meth:`walker_gait.core.tracker.LegTracker._evaluate`): numpy's arithmetic term by term, in
# two passes around numpy's arctangents and arcsines (numpy's own, which may differ from the C library's in the last
# bit): the same log priors, bit for bit (tested).

_PRIOR_ARGS_SIG = "void(float64[:, :, :, ::1], int64[::1], float64[:, :, ::1])"


@njit(_PRIOR_ARGS_SIG, cache=True, nogil=True, error_model="numpy")
def prior_angle_args(points, legs, out):  # pragma: no cover - compiled (tested against the numpy code)
    """The arguments of the foot pitch and shank lean arctangents of the feet of ``legs`` from ``points``
    ``(P, 2, 5, 3)`` (``LEG_POINTS``, body frame): ``out`` ``(5, nl, P)`` rows [toe - heel height, its horizontal
    length, the shank's lean along the foot, its height, the other ankle's distance ahead along the foot]."""
    for li in range(legs.shape[0]):
        leg = legs[li]
        for p in range(points.shape[0]):
            v0 = points[p, leg, 4, 0] - points[p, leg, 3, 0]
            v1 = points[p, leg, 4, 1] - points[p, leg, 3, 1]
            v2 = points[p, leg, 4, 2] - points[p, leg, 3, 2]
            flat = np.hypot(v0, v1)
            den = max(flat, 1e-9)
            s0 = points[p, leg, 1, 0] - points[p, leg, 2, 0]
            s1 = points[p, leg, 1, 1] - points[p, leg, 2, 1]
            s2 = points[p, leg, 1, 2] - points[p, leg, 2, 2]
            o0 = points[p, 1 - leg, 2, 0] - points[p, leg, 2, 0]
            o1 = points[p, 1 - leg, 2, 1] - points[p, leg, 2, 1]
            out[0, li, p] = v2
            out[1, li, p] = flat
            out[2, li, p] = (s0 * v0 + s1 * v1) / den
            out[3, li, p] = s2
            out[4, li, p] = (o0 * v0 + o1 * v1) / den


_PRIOR_SIG = ("void(float64[:, ::1], float64[:, :, :, ::1], int64[::1], float64, float64[:, ::1], float64[:, ::1], "
              "float64[:, :, ::1], boolean[::1], float64, float64, float64, float64, boolean[::1], float64[:, ::1], "
              "float64[::1], float64[:, ::1], float64, float64, float64, boolean, float64, float64[::1])")


@njit(_PRIOR_SIG, cache=True, nogil=True, error_model="numpy")
def prior_terms(states, points, legs, ankle_sigma, pitch, lean, args, rise_on, dorsiflexion, behind_full, rise_max,
                pitch_sigma, footprint_on, footprint_xy, footprint_scale, roll, roll_sigma, pelvis_x, pelvis_y,
                pelvis_on, crossing_sigma, total):  # pragma: no cover - compiled (tested against the numpy code)
    """``total`` ``(P,)`` minus the log priors of :meth:`walker_gait.core.tracker.LegTracker._evaluate`, in its order:
    ankle flexion (``ankle_sigma``), foot pitch (``pitch`` / ``lean`` ``(nl, P)`` the arctangents of
    :func:`prior_angle_args`'s ``args``; the heel-rise allowance where ``rise_on``; ``pitch_sigma``), the hidden feet's
    footprints (``footprint_on`` ``(nl,)``, ``footprint_xy`` ``(nl, 2)``, ``footprint_scale`` ``(nl,)``), foot roll
    (``roll`` ``(nl, P)`` arcsines), the pelvis over the feet (``pelvis_on``; ``pelvis_x`` / ``pelvis_y`` sigmas) and
    feet crossing (``crossing_sigma``); a sigma of inf leaves its prior out."""
    n_p = states.shape[0]
    nl = legs.shape[0]
    for p in range(n_p):
        t = total[p]
        if ankle_sigma < np.inf:
            for li in range(nl):
                a = states[p, 11 + 6 * legs[li] + 4] / ankle_sigma
                t -= 0.5 * a * a
        if pitch_sigma < np.inf:
            for li in range(nl):
                a = pitch[li, p]
                if rise_on[li]:
                    gate = min(max(args[4, li, p] / behind_full, 0.0), 1.0)
                    a = a + gate * min(max(lean[li, p] - dorsiflexion, 0.0), rise_max)
                a /= pitch_sigma
                t -= 0.5 * a * a
        for li in range(nl):
            if footprint_on[li]:
                leg = legs[li]
                d0 = (points[p, leg, 4, 0] - footprint_xy[li, 0]) / footprint_scale[li]
                d1 = (points[p, leg, 4, 1] - footprint_xy[li, 1]) / footprint_scale[li]
                t -= 0.5 * (d0 * d0 + d1 * d1)
        if roll_sigma < np.inf:
            for li in range(nl):
                r = roll[li, p] / roll_sigma
                t -= 0.5 * r * r
        if pelvis_on:
            d0 = ((points[p, 0, 0, 0] + points[p, 1, 0, 0]) / 2.0
                  - (((points[p, 0, 3, 0] + points[p, 0, 4, 0]) + points[p, 1, 3, 0]) + points[p, 1, 4, 0]) / 4.0)
            d1 = ((points[p, 0, 0, 1] + points[p, 1, 0, 1]) / 2.0
                  - (((points[p, 0, 3, 1] + points[p, 0, 4, 1]) + points[p, 1, 3, 1]) + points[p, 1, 4, 1]) / 4.0)
            d0 /= pelvis_x
            d1 /= pelvis_y
            t -= 0.5 * (d0 * d0 + d1 * d1)
        if crossing_sigma < np.inf:
            a0 = points[p, 0, 0, 0] - points[p, 1, 0, 0]
            a1 = points[p, 0, 0, 1] - points[p, 1, 0, 1]
            n = max(np.sqrt(a0 * a0 + a1 * a1), 1e-9)
            a0 /= n
            a1 /= n
            f0 = ((points[p, 0, 2, 0] + points[p, 0, 3, 0]) + points[p, 0, 4, 0]) / 3.0 - (
                ((points[p, 1, 2, 0] + points[p, 1, 3, 0]) + points[p, 1, 4, 0]) / 3.0)
            f1 = ((points[p, 0, 2, 1] + points[p, 0, 3, 1]) + points[p, 0, 4, 1]) / 3.0 - (
                ((points[p, 1, 2, 1] + points[p, 1, 3, 1]) + points[p, 1, 4, 1]) / 3.0)
            c = max(-(f0 * a0 + f1 * a1), 0.0) / crossing_sigma
            t -= 0.5 * c * c
        total[p] = t


# The segmentation's and the back-projection's kernels take their inputs as read-only arrays, which writable ones
# also match: a caller's depth image may be a read-only buffer (a message's bytes), a one-row camera's ray image a
# broadcast view.
def _ro(dtype: nt.Type, ndim: int) -> nt.Array:
    return nt.Array(dtype, ndim, "C", readonly=True)


def _rw(dtype: nt.Type, ndim: int) -> nt.Array:
    return nt.Array(dtype, ndim, "C")


_F4 = nt.float32
_WALKER_BOX_SIG = nt.int64(_ro(_F4, 2), _ro(nt.boolean, 1), _ro(_F4, 1), _ro(_F4, 1), _ro(_F4, 2), *[_F4] * 10,
                           _rw(_F4, 1), _rw(_F4, 1), _rw(_F4, 1), _rw(nt.boolean, 1), _rw(nt.boolean, 1))


@njit(_WALKER_BOX_SIG, cache=True, nogil=True, error_model="numpy")
def walker_box(z, valid, rx, ry, rot, off, forward, near, max_height, reach_left, reach_right, box_left, box_right,
               k_m2, min_height, xw, yw, h, mask, reach):  # pragma: no cover - compiled (tested against numpy's)
    """The segmentation's pixel pass (:meth:`walker_gait.core.segmentation.Segmenter._process`, its floor-plane
    branch), float32 as numpy computes it: each pixel's flat walker x, y and height (``xw``, ``yw``, ``h``: ``z``
    times the row's and column's ray coefficients of ``rot``'s rows, ``off`` added to the height), then ``mask``:
    valid, above the floor's threshold (``k_m2`` z² + ``min_height``) and inside the box (``near <= x <= forward``,
    ``box_right <= y <= box_left``, ``h <= max_height``), and ``reach``: the same in the band ``reach_right <= y <=
    reach_left``.  Branch-free, so that it vectorises: the caller passes ``k_m2`` 0 for a plain height threshold and
    ``max_height`` inf for none, which decide every valid pixel (finite depth) as the numpy code's branches do.
    Returns how many valid pixels lie above the floor's threshold."""
    rows, cols = z.shape
    n_not_floor = 0
    b0 = np.empty(cols, dtype=np.float32)
    b1 = np.empty(cols, dtype=np.float32)
    b2 = np.empty(cols, dtype=np.float32)
    for u in range(cols):  # numpy: np.add.outer(rot[k, 1] * ry + rot[k, 2], rot[k, 0] * rx)
        b0[u] = rot[0, 0] * rx[u]
        b1[u] = rot[1, 0] * rx[u]
        b2[u] = rot[2, 0] * rx[u]
    for v in range(rows):
        a0 = rot[0, 1] * ry[v] + rot[0, 2]
        a1 = rot[1, 1] * ry[v] + rot[1, 2]
        a2 = rot[2, 1] * ry[v] + rot[2, 2]
        zr = z[v]
        base = v * cols
        xr = xw[base:base + cols]
        yr = yw[base:base + cols]
        hr = h[base:base + cols]
        vr = valid[base:base + cols]
        mr = mask[base:base + cols]
        rr = reach[base:base + cols]
        count = 0
        for u in range(cols):
            zz = zr[u]
            x = (a0 + b0[u]) * zz
            y = (a1 + b1[u]) * zz
            hh = (a2 + b2[u]) * zz + off
            xr[u] = x
            yr[u] = y
            hr[u] = hh
            above = (hh > (zz * zz * k_m2 + min_height)) & vr[u]
            count += above
            box = above & (x <= forward) & (x >= near) & (hh <= max_height)
            rr[u] = box & (y <= reach_left) & (y >= reach_right)
            mr[u] = box & (y <= box_left) & (y >= box_right)
        n_not_floor += count
    return n_not_floor


_STATIC_PIXELS_SIG = nt.void(_ro(_F4, 2), _ro(_F4, 2), _ro(nt.boolean, 2), nt.int64, _F4, _F4, _rw(nt.boolean, 2))


@njit(_STATIC_PIXELS_SIG, cache=True, nogil=True, error_model="numpy")
def static_pixels(grown, depth, mask, stride, tol, tol_per_m2, out):  # pragma: no cover - compiled (tested)
    """:meth:`walker_gait.core.segmentation.StaticStructureMask.static_pixels` after its dilation, float32 as numpy
    computes it: ``out`` is ``mask`` where the reference depth ``grown`` of the pixel's grid cell (``stride`` pixels
    a side) is positive and the pixel's ``depth`` lies within ``tol + tol_per_m2 * ref²`` of it."""
    rows, cols = depth.shape
    ref = np.empty(cols, dtype=np.float32)  # a grid row's references and tolerances at full resolution
    tr = np.empty(cols, dtype=np.float32)
    for v in range(rows):
        if v % stride == 0:
            g = grown[v // stride]
            for u in range(cols):
                r = g[u // stride]
                ref[u] = r
                tr[u] = tol + tol_per_m2 * r * r
        dr = depth[v]
        mr = mask[v]
        outr = out[v]
        for u in range(cols):
            outr[u] = mr[u] & (ref[u] > 0) & (abs(dr[u] - ref[u]) <= tr[u])


@njit(inline="always")
def _row_runs(mask, out):  # pragma: no cover - compiled
    """``out[i, j]``: the length of the run of True along row ``i`` of ``mask`` that pixel ``j`` belongs to (0 where
    False, as left)."""
    rows, cols = mask.shape
    for i in range(rows):
        j = 0
        while j < cols:
            if mask[i, j]:
                k = j
                while k < cols and mask[i, k]:
                    k += 1
                for t in range(j, k):
                    out[i, t] = k - j
                j = k
            else:
                j += 1


_THIN_SIG = nt.void(_ro(nt.boolean, 2), _ro(nt.boolean, 2), _ro(_F4, 2), nt.float64, nt.float64, nt.float64,
                    _ro(nt.boolean, 2), nt.int64, nt.int64, nt.int64, _rw(nt.boolean, 2))


@njit(_THIN_SIG, cache=True, nogil=True, error_model="numpy")
def thin_parts(closed, m, z, kx, ky, min_width, mask, r0, c0, stride, out):  # pragma: no cover - compiled (tested)
    """:func:`walker_gait.core.segmentation.thin_parts` after its closing, in float64 as numpy computes it: on the
    sub-sampled grid, each pixel of ``m`` whose run of ``closed`` along its row times its depth ``z`` times ``kx``,
    or along its column times ``ky``, is under ``min_width`` is thin; ``out`` (full resolution, False on entry)
    gets each pixel of ``mask`` from ``r0``, ``c0`` on its grid cell's verdict (``stride`` pixels a side)."""
    rows, cols = closed.shape
    across = np.zeros((rows, cols), dtype=np.int64)
    _row_runs(closed, across)
    along = np.zeros((cols, rows), dtype=np.int64)  # transposed: the columns' runs
    _row_runs(closed.T, along)
    thin = np.zeros((rows, cols), dtype=np.bool_)
    for i in range(rows):
        for j in range(cols):
            if m[i, j]:
                zz = np.float64(z[i, j])
                thin[i, j] = (np.float64(across[i, j]) * zz * kx < min_width) | \
                    (np.float64(along[j, i]) * zz * ky < min_width)
    h, w = mask.shape
    r1 = min(h, r0 + rows * stride)
    c1 = min(w, c0 + cols * stride)
    for r in range(r0, r1):
        tr = thin[(r - r0) // stride]
        mr = mask[r]
        outr = out[r]
        for c in range(c0, c1):
            outr[c] = tr[(c - c0) // stride] & mr[c]


_NO_DEPTH_SIG = nt.void(_ro(nt.boolean, 1), _rw(_F4, 1), _F4, _F4, _F4, _rw(nt.boolean, 1))


@njit(_NO_DEPTH_SIG, cache=True, nogil=True, error_model="numpy")
def transient_no_depth(valid, rate, decay, gain, persistent, out):  # pragma: no cover - compiled (tested)
    """:meth:`walker_gait.core.segmentation.Segmenter._transient_no_depth`'s running average, float32 as numpy
    computes it: each pixel's ``rate`` of frames without depth times ``decay`` plus ``gain`` where this frame has
    none (not ``valid``), and ``out``: no depth now and a ``rate`` under ``persistent``."""
    for i in range(valid.shape[0]):
        missing = not valid[i]
        r = rate[i] * decay + gain * np.float32(missing)
        rate[i] = r
        out[i] = missing & (r < persistent)


_POINTS_SIG = nt.void(_ro(_F4, 2), _ro(_F4, 2), _ro(_F4, 2), _rw(_F4, 3))


@njit(_POINTS_SIG, cache=True, nogil=True, error_model="numpy")
def back_project(z, rx, ry, out):  # pragma: no cover - compiled (tested against numpy's)
    """:meth:`walker_gait.core.depth.DepthProjector.points` in one pass, float32 as numpy computes it: ``out[v, u]``
    is ``(z rx, z ry, z)`` of the pixel's depth ``z`` and ray images ``rx``, ``ry``."""
    rows, cols = z.shape
    for v in range(rows):
        for u in range(cols):
            zz = z[v, u]
            out[v, u, 0] = zz * rx[v, u]
            out[v, u, 1] = zz * ry[v, u]
            out[v, u, 2] = zz
