"""numba kernels of the likelihood; import through :func:`walker_gait.core.kernels.compiled` (needs numba).

All three kernels are compiled with numpy's error model (a division by zero gives inf / NaN as in numpy, and
leaves the loops free of Python's exception checks, which would stop their vectorisation), without fast-math
(no reassociation, no fused multiply-add: results do not depend on the CPU's vector width), and release the
GIL.  Every inner loop runs over a contiguous slice indexed from 0, which lets LLVM vectorise it.
"""

from __future__ import annotations

import numpy as np
from numba import njit

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
