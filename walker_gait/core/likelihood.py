"""Measurement model of the seed paper (§4.4): 3D cue (eq. 4-7), 2D cue (eq. 8-9), product (eq. 10).

Everything here works in the camera optical frame, metres, and returns **log** likelihoods
``(P,)`` vectorised over particles.

Units.  The paper measures distances in millimetres with ``λ1 = 1/5`` (eq. 7) and
``λ2 = 1/3`` (eq. 9).  We keep metres internally, so the equivalent rates are
``λ1 = 1000/5 = 200 m⁻¹`` and ``λ2 = 1000/3 ≈ 333 m⁻¹`` (:data:`PAPER_LAMBDA_3D`,
:data:`PAPER_LAMBDA_2D`): ``exp(-λ_mm · d_mm) = exp(-λ_m · d_m)``.

3D cue.  Each model segment (tapered cylinder, or the foot half-cylinder whose axis lies in
the sole) is represented by ``n + 2`` skeleton points on its axis with the local radius
``w_m``.  ``d_MF`` (eq. 5) = mean over model points of ``|w_m - min_f ||f - m|| |``; ``d_FM``
(eq. 4) = mean over (sub-sampled) foreground points of ``min_m |w_m - ||f - m|| |`` (the
model point nearest to ``f`` in the *surface* sense, which is what the paper's figure 3
describes for tapered segments); ``d1 = (d_FM + d_MF) / 2`` (eq. 6).

Extensions used by the ``default`` preset (all off for ``paper``): occlusion-aware
``d_MF`` (a skeleton point whose pixel shows an observed surface clearly *in front* of it,
or that projects outside the image, costs a constant ``occluded_cost`` instead of its
distance), segment masks (hidden segments left out of ``d_MF``), and a truncated per-pixel
cost in the 2D cue.

2D cue.  The model is rendered to a depth image (z-buffer over segments; pixels outside the
model are background) and compared pixel-wise with the observed foreground depth (eq. 8,
background = 0 in both images so a foreground/background mismatch costs the foreground
depth).  ``d2`` is the per-pixel mean over the *whole* cue image (as in the paper's
``640 × 480`` normaliser), but only a region of interest containing every foreground pixel
and every rendered particle is actually evaluated (the rest contributes 0 exactly).
Renderer: each tapered cylinder is rasterised analytically per pixel as a "projected
capsule" — distance of the pixel to the projected axis, radius and depth interpolated along
it, front-surface depth ``z(t) - r(t) sqrt(1 - (d/ρ)²)``; foot pixels whose surface point
would lie below the floor are dropped (the foot is a half-cylinder on its flat sole).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from walker_gait.core import kernels
from walker_gait.core.types import CameraIntrinsics, FloorPlane

FloatArray = NDArray[np.float64]
F32 = NDArray[np.float32]
BoolArray = NDArray[np.bool_]

PAPER_LAMBDA_3D = 1000.0 / 5.0
"""Eq. 7 rate ``λ1 = 1/5 mm⁻¹`` expressed per metre."""
PAPER_LAMBDA_2D = 1000.0 / 3.0
"""Eq. 9 rate ``λ2 = 1/3 mm⁻¹`` expressed per metre."""


MIN_THREAD_PARTICLES = 16
"""Fewest particles a thread of a :class:`Workspace` with ``threads`` > 1 is given: a smaller batch (a single scored
state, a reference render) runs on the calling thread alone, where handing it over would cost more than it saves."""


class Workspace:
    """Reusable scratch buffers of the likelihood kernels (one per tracker; not thread-safe), and the threads the
    compiled kernels spread their particles over.

    The kernels' ``(P, M, N)`` / ``(P, Npix)`` temporaries are several hundred KiB each; freshly
    allocated ones are page-faulted in on first touch, which costs about as much as the
    arithmetic on them.  A workspace kept across frames hands out the same memory again.
    Buffers only ever hold intermediate values (every element used is written first), so
    results do not depend on what a buffer held before.

    ``threads`` > 1: the 3D cue's terms, the 2D cue's renderer and its pixel costs (the compiled kernels, which release
    the GIL and work particle by particle) each run over ``threads`` consecutive slices of the particles at once, the
    first on the calling thread (:meth:`spread`).  Each particle's arithmetic is the same wherever it runs, so the
    likelihoods are the same bit for bit.  On the 2-core VM with two threads the 3D cue of 192 particles took 0.9-1.0
    ms instead of 1.4 and the 2D cue 1.7-2.0 instead of 2.3; a whole tracker frame gains only where the second core
    is otherwise idle (DEVELOPERS.md, eighty-seventh session).
    """

    def __init__(self, *, threads: int = 1) -> None:
        if isinstance(threads, bool) or not isinstance(threads, int) or threads < 1:
            raise ValueError(f"threads must be an integer >= 1, got {threads!r}")
        self.threads = threads
        self._bufs: dict[tuple[str, type], np.ndarray] = {}
        self._pool: ThreadPoolExecutor | None = None
        self._pool_pid = 0

    def __getstate__(self) -> dict[str, object]:
        # buffers and threads stay with their process
        return {"threads": self.threads, "_bufs": {}, "_pool": None, "_pool_pid": 0}

    def chunks(self, n: int) -> list[tuple[int, int]]:
        """``[start, stop)`` slices of ``n`` particles, one per thread: as many as ``threads`` allows with at least
        :data:`MIN_THREAD_PARTICLES` each (one slice of all of them otherwise)."""
        k = max(1, min(self.threads, n // MIN_THREAD_PARTICLES))
        bounds = [n * i // k for i in range(k + 1)]
        return list(zip(bounds[:-1], bounds[1:]))

    def spread(self, work: Callable[[int, int, int], None], n: int) -> None:
        """``work(i, start, stop)`` for each slice ``i`` of :meth:`chunks` ``(n)``: the first on the calling thread,
        the others at the same time on the workspace's own threads; returns when all are done (an exception in any
        is raised here, after the others finished)."""
        parts = self.chunks(n)
        if len(parts) == 1:
            work(0, 0, n)
            return
        if self._pool is None or self._pool_pid != os.getpid():  # a forked child has none of its parent's threads
            self._pool = ThreadPoolExecutor(max_workers=self.threads - 1, thread_name_prefix="walker-gait-kernels")
            self._pool_pid = os.getpid()
        futures = [self._pool.submit(work, i, a, b) for i, (a, b) in enumerate(parts) if i > 0]
        try:
            work(0, *parts[0])
        finally:
            for f in futures:
                f.exception()  # wait for every slice before any buffer is handed out again
        for f in futures:
            f.result()

    def buffer(self, name: str, shape: tuple[int, ...], dtype: type = np.float32) -> np.ndarray:
        """Uninitialised C-contiguous ``shape`` array of ``dtype``, reused for ``(name, dtype)``."""
        n = math.prod(shape)
        buf = self._bufs.get((name, dtype))
        if buf is None or buf.size < n:
            # some headroom so that slowly growing sizes do not re-allocate every call
            buf = np.empty(n if buf is None else max(n, buf.size + buf.size // 4), dtype=dtype)
            self._bufs[(name, dtype)] = buf
        return buf[:n].reshape(shape)


def _spread(work: Workspace | None, fn: Callable[[int, int, int], None], n: int) -> None:
    """``fn`` over ``n`` particles as the workspace spreads them (:meth:`Workspace.spread`); all at once without one."""
    if work is None:
        fn(0, 0, n)
    else:
        work.spread(fn, n)


def _scratch(work: Workspace | None, name: str, shape: tuple[int, ...], dtype: type = np.float32) -> np.ndarray:
    """A workspace buffer, or a fresh array when there is no workspace."""
    if work is None:
        return np.empty(shape, dtype=dtype)
    return work.buffer(name, shape, dtype)


BELOW_CUT_MARGIN = 0.01
"""m: a skeleton point whose surface cannot reach this much above the segmentation's floor cut is left out of the
3D cue's d_MF (:meth:`CueImage.below_cut`)."""


# --------------------------------------------------------------------------------------
# 3D cue
# --------------------------------------------------------------------------------------
def skeleton_points(
    segments: FloatArray, radii: FloatArray, *, n: int
) -> tuple[FloatArray, FloatArray]:
    """Skeleton points of segments ``(P, S, 2, 3)`` with end radii ``(P, S, 2)``.

    Returns points ``(P, S, n + 2, 3)`` (end points plus ``n`` evenly spaced interior points)
    and their widths ``(P, S, n + 2)`` (radius interpolated linearly, paper fig. 3).
    """
    t = np.linspace(0.0, 1.0, n + 2)
    p, s = segments.shape[:2]
    a = segments[:, :, 0, :]
    # pts = a + (b - a) t, evaluated as (n + 2, P*S*3) rows (one long loop per t instead of P*S*(n+2)
    # loops of 3 coordinates), then laid out as (P, S, n + 2, 3)
    tmp = (segments[:, :, 1, :] - a).reshape(1, p * s * 3) * t[:, None]
    tmp += a.reshape(1, p * s * 3)
    pts = np.ascontiguousarray(tmp.reshape(n + 2, p, s, 3).transpose(1, 2, 0, 3))
    w = radii[:, :, 0, None] + (radii[:, :, 1, None] - radii[:, :, 0, None]) * t
    return pts, w


def _cross(a: FloatArray, b: FloatArray) -> FloatArray:
    """``np.cross(a, b)`` of ``(..., 3)`` arrays, the same arithmetic without its axis shuffling (several times
    faster on the tracker's small arrays)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape), dtype=np.result_type(a, b))
    np.multiply(a1, b2, out=out[..., 0])
    out[..., 0] -= a2 * b1
    np.multiply(a2, b0, out=out[..., 1])
    out[..., 1] -= a0 * b2
    np.multiply(a0, b1, out=out[..., 2])
    out[..., 2] -= a1 * b0
    return out


def elliptic_section_radii(
    segments: FloatArray, lateral: FloatArray, heights: FloatArray, half_widths: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """View-dependent radii of segments with an elliptical cross-section, as seen from the camera.

    ``segments`` ``(P, S, 2, 3)`` camera frame; ``lateral`` ``(P, S, 3)`` unit axis of the
    section's ``half_widths`` semi-axis (perpendicular to the segment); ``heights`` and
    ``half_widths`` ``(P, S, 2)`` the two semi-axes at the segment ends (``heights`` along
    ``axis x lateral``).  Returns ``(silhouette, toward)`` ``(P, S, 2)``: the section's extent
    perpendicular to both the axis and the line of sight (the half-width of the projected
    capsule), and its extent towards the camera (how far the visible surface stands out of the
    axis).  A circular section (equal semi-axes) gives its radius for both.
    """
    a, b = segments[:, :, 0, :], segments[:, :, 1, :]
    axis = b - a
    axis /= np.maximum(np.linalg.norm(axis, axis=-1, keepdims=True), 1e-9)
    up = _cross(axis, lateral)
    sight = 0.5 * (a + b)  # camera at the origin: line of sight to the segment's middle
    sight /= np.maximum(np.linalg.norm(sight, axis=-1, keepdims=True), 1e-9)
    perp = _cross(axis, sight)  # image-perpendicular direction of the projected axis
    norm = np.linalg.norm(perp, axis=-1, keepdims=True)
    perp = np.where(norm > 1e-6, perp / np.maximum(norm, 1e-9), lateral)  # axis along the line of sight
    toward = _cross(perp, axis)  # in the section plane, perpendicular to perp, facing the camera

    def extent(d: FloatArray) -> FloatArray:
        cl = np.einsum("psk,psk->ps", d, lateral)[..., None]
        cu = np.einsum("psk,psk->ps", d, up)[..., None]
        return np.sqrt((half_widths * cl) ** 2 + (heights * cu) ** 2)
    return extent(perp), extent(toward)


def _pairwise_distances(model: F32, fg: F32, fg_sq: F32, *, work: Workspace | None = None) -> F32:
    """Euclidean distances ``(P, M, N)`` between model points ``(P, M, 3)`` and ``fg (N, 3)``.

    With ``work`` the result lives in the workspace buffer ``"dist"`` (valid until its next use).
    """
    p, m, _ = model.shape
    flat = model.reshape(p * m, 3)
    sq = _scratch(work, "dist", (p * m, fg.shape[0]))
    np.matmul(flat, -2.0 * fg.T, out=sq)
    sq += np.einsum("ij,ij->i", flat, flat)[:, None]
    sq += fg_sq[None, :]
    # = np.maximum(sq, 0) (sq is a sum ending in fg_sq >= +0, so never -0.0, the one input where
    # the two differ); clip with both bounds has a SIMD loop, maximum with a scalar does not
    np.clip(sq, 0.0, np.inf, out=sq)
    np.sqrt(sq, out=sq)
    return sq.reshape(p, m, -1)


def _surface_costs(model: F32, widths: F32, fg: F32, *, work: Workspace | None = None) -> tuple[F32, F32]:
    """The 3D cue's minima of the distances between model points ``(P, M, 3)`` (radii ``widths`` ``(P, M)``)
    and foreground points ``fg (N, 3)`` (all float32, finite): ``(row_min (P, M), fm (P, N))`` with
    ``row_min = min_n ||f_n - m||`` (eq. 5) and ``fm = min_m | ||f_n - m|| - w_m |`` (eq. 4).

    Compiled when numba is available (:mod:`walker_gait.core.kernels`), else numpy.  With ``work`` the results
    may live in workspace buffers (valid until their next use)."""
    p, m, _ = model.shape
    n = fg.shape[0]
    jit = kernels.compiled()
    if jit is not None:
        row_min = _scratch(work, "row_min", (p, m))
        fm = _scratch(work, "fm", (p, n))
        fg_t = np.ascontiguousarray(np.asarray(fg, dtype=np.float32).T)
        jit.surface_costs(np.ascontiguousarray(model, dtype=np.float32), np.ascontiguousarray(widths, dtype=np.float32),
                          fg_t[0], fg_t[1], fg_t[2], row_min.view(np.int32), fm, _scratch(work, "fm_scratch", (n,)))
        return row_min, fm
    d = _pairwise_distances(model, fg, np.einsum("ij,ij->i", fg, fg), work=work)  # (P, M, N)
    # row minima d.min(axis=2) as a reduceat over the row starts: same values, about twice as fast (no per-row
    # reduction set-up)
    row_min = np.minimum.reduceat(d.reshape(-1), np.arange(0, d.size, n)).reshape(p, m) if n else np.full((p, m), np.inf, np.float32)
    d -= widths[:, :, None]
    np.abs(d, out=d)
    return row_min, d.min(axis=1) if m else np.full((p, n), np.inf, np.float32)


def foreground_costs(
    segments: FloatArray, radii: FloatArray, *, fg: FloatArray, n: int
) -> F32:
    """Per-foreground-point surface costs ``min_m |w_m - ||f - m|| |`` ``(P, N)`` (eq. 4 terms)."""
    pts, w = skeleton_points(segments, radii, n=n)
    p = pts.shape[0]
    _, fm = _surface_costs(pts.reshape(p, -1, 3).astype(np.float32), w.reshape(p, -1).astype(np.float32),
                           np.asarray(fg, dtype=np.float32))
    return fm


@dataclass(frozen=True)
class Cue3DParams:
    """Parameters of the 3D cue (eq. 4-7)."""

    lam: float = PAPER_LAMBDA_3D  # rate, 1/m
    n_skeleton: int = 10  # interior skeleton points per segment (paper n = 10)
    occlusion_aware: bool = False  # occluded/out-of-image skeleton points cost `occluded_cost`
    occluded_cost: float = 0.01  # m
    occlusion_tol: float = 0.04  # m: observed surface must be this much in front of the model surface
    truncate: float = np.inf  # m: per-point distance cap (robustness to clutter)


def log_likelihood_3d(
    segments: FloatArray,
    radii: FloatArray,
    *,
    fg: FloatArray,
    params: Cue3DParams,
    ref_fg_costs: F32 | None = None,
    active: BoolArray | None = None,
    cue_image: CueImage | None = None,
    work: Workspace | None = None,
) -> FloatArray:
    """Log likelihood ``-λ1 d1`` (eq. 6-7) of ``(P, S, 2, 3)`` camera-frame segments.

    ``fg``: ``(N, 3)`` (sub-sampled) foreground points, camera frame.
    ``ref_fg_costs``: ``(N,)`` surface costs of the foreground w.r.t. model parts that are
    held fixed (partitioned sampling: the other leg); combined by ``min`` into ``d_FM``.
    ``active``: ``(S,)`` segments that contribute to ``d_MF`` (hidden ones are left out).
    ``cue_image``: needed when ``params.occlusion_aware`` (observed depth for the test); its
    ``min_height`` also removes skeleton points whose surface lies entirely below the
    segmentation's floor cut from ``d_MF``.
    ``work``: scratch buffers reused across calls (same results, less allocation).
    """
    p, s = segments.shape[:2]
    n_fg = fg.shape[0]
    if n_fg == 0:
        return np.zeros(p)
    jit = kernels.compiled()
    if jit is not None:
        return _log_likelihood_3d_compiled(jit, segments, radii, fg=fg, params=params, ref_fg_costs=ref_fg_costs,
                                           active=active, cue_image=cue_image, work=work)
    pts, w = skeleton_points(segments, radii, n=params.n_skeleton)
    k = params.n_skeleton + 2
    w32 = w.reshape(p, s * k).astype(np.float32)
    row_min, fm = _surface_costs(pts.reshape(p, s * k, 3).astype(np.float32), w32,
                                 np.asarray(fg, dtype=np.float32), work=work)
    mf = np.abs(row_min - w32)  # (P, M): d_MF terms (eq. 5); fm (P, N): d_FM terms (eq. 4)
    if ref_fg_costs is not None:
        np.minimum(fm, ref_fg_costs[None, :], out=fm)
    if np.isfinite(params.truncate):
        np.minimum(fm, params.truncate, out=fm)
        np.minimum(mf, params.truncate, out=mf)
    mask = np.ones((p, s * k), dtype=bool)
    if active is not None:
        mask &= np.repeat(np.asarray(active, dtype=bool), k)[None, :]
    if cue_image is not None and cue_image.min_height > 0:
        mask &= ~cue_image.below_cut(pts.reshape(p, s * k, 3), w.reshape(p, s * k))
    if params.occlusion_aware and cue_image is not None:
        occ = cue_image.occluded(pts.reshape(p, s * k, 3), w.reshape(p, s * k), tol=params.occlusion_tol)
        mf = np.where(occ, np.float32(params.occluded_cost), mf)
    cnt = np.maximum(mask.sum(axis=1), 1)
    d_mf = np.where(mask, mf, 0.0).sum(axis=1) / cnt
    d_fm = fm.mean(axis=1)
    d1 = 0.5 * (d_fm + d_mf)
    return -params.lam * d1.astype(np.float64)


def _log_likelihood_3d_compiled(
    jit: object, segments: FloatArray, radii: FloatArray, *, fg: FloatArray, params: Cue3DParams,
    ref_fg_costs: F32 | None, active: BoolArray | None, cue_image: CueImage | None, work: Workspace | None,
) -> FloatArray:
    """:func:`log_likelihood_3d` with its terms from one compiled pass (:func:`walker_gait.core._jit.cue3d_terms`:
    numpy's arithmetic term by term, the same log likelihoods, tested); the sums stay numpy's."""
    p, s = segments.shape[:2]
    n = fg.shape[0]
    k = params.n_skeleton + 2
    m = s * k
    mf, fm = _scratch(work, "mf", (p, m)), _scratch(work, "fm", (p, n))
    count = np.empty(p, dtype=np.int64)
    fg_t = np.ascontiguousarray(np.asarray(fg, dtype=np.float32).T)
    cue = cue_image
    occ_on = bool(params.occlusion_aware and cue is not None)
    cut_level = cue.min_height + BELOW_CUT_MARGIN if cue is not None and cue.min_height > 0 else -np.inf
    intr = cue.intrinsics if cue is not None else None
    unknown = cue.unknown if cue is not None else None
    seg = np.ascontiguousarray(segments, dtype=np.float64)
    rad = np.ascontiguousarray(radii, dtype=np.float64)
    t = np.linspace(0.0, 1.0, k)
    ref = _NO_REF if ref_fg_costs is None else np.ascontiguousarray(ref_fg_costs, dtype=np.float32)
    act = np.ones(s, dtype=bool) if active is None else np.ascontiguousarray(active, dtype=bool)
    normal = _NO_NORMAL if cue is None else np.asarray(cue.floor_normal, dtype=np.float64)
    camera = ((intr.fx, intr.fy, intr.cx, intr.cy, int(intr.width), int(intr.height)) if intr is not None
              else (1.0, 1.0, 0.0, 0.0, 0, 0))
    depth = _NO_DEPTH if cue is None else cue.depth.reshape(-1)
    unknown_flat = _NO_UNKNOWN if unknown is None else unknown.reshape(-1)
    pts32, w32 = _scratch(work, "pts32", (p, m, 3)), _scratch(work, "w32", (p, m))
    row_min = _scratch(work, "row_min", (p, m), np.int32)

    def terms(i: int, a: int, b: int) -> None:  # particles a..b (each particle's terms are its own)
        jit.cue3d_terms(  # type: ignore[attr-defined]
            seg[a:b], rad[a:b], t, fg_t[0], fg_t[1], fg_t[2], ref, ref_fg_costs is not None,
            np.float32(params.truncate), act, normal, 0.0 if cue is None else float(cue.floor_offset),
            float(cut_level), occ_on, *camera, depth, unknown_flat, unknown is not None, float(params.occlusion_tol),
            np.float32(params.occluded_cost), mf[a:b], fm[a:b], count[a:b], pts32[a:b], w32[a:b], row_min[a:b],
            _scratch(work, f"fm_scratch{i}" if i else "fm_scratch", (n,)),
        )

    _spread(work, terms, p)
    d_mf = mf.sum(axis=1) / count
    d_fm = fm.mean(axis=1)
    d1 = 0.5 * (d_fm + d_mf)
    return -params.lam * d1.astype(np.float64)


_NO_REF = np.zeros(1, dtype=np.float32)
_NO_NORMAL = np.array([0.0, 0.0, 1.0])
_NO_DEPTH = np.zeros(1, dtype=np.float32)
_NO_UNKNOWN = np.zeros(1, dtype=bool)


# --------------------------------------------------------------------------------------
# 2D cue
# --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class CueImage:
    """Observed foreground depth at the 2D-cue resolution (camera frame, metres).

    ``depth``: ``(h, w)`` float32, 0 where background/invalid (paper convention);
    ``intrinsics``: of the cue image; ``ray_up``: ``(h, w)`` float32, floor normal · pixel
    ray ``(x/z, y/z, 1)`` so a surface point at depth ``z`` has floor height
    ``z * ray_up + floor_offset``; ``unknown``: ``(h, w)`` bool, pixels without a depth measurement
    (closer than the sensor's near limit, IR shadow, dropouts), or None when every pixel was measured or
    missing depth counts as background (paper).  Neither cue holds anything against a model surface there:
    a leg closer to the camera than the sensor's near limit is a hole in the image, not background.
    """

    depth: F32
    intrinsics: CameraIntrinsics
    ray_up: F32
    floor_offset: float
    floor_normal: FloatArray
    min_height: float  # m: the segmentation drops points lower than this above the floor
    fg_bbox: tuple[int, int, int, int] | None  # (v0, v1, u0, u1) half-open, None if empty
    unknown: BoolArray | None = None

    @staticmethod
    def from_depth(
        depth_fg: NDArray[np.floating],
        *,
        intrinsics: CameraIntrinsics,
        stride: int,
        floor: FloorPlane,
        min_height: float = 0.0,
        unknown: NDArray[np.bool_] | None = None,
    ) -> CueImage:
        """Sub-sample the full-resolution foreground depth (NaN = background) by ``stride``.

        ``min_height`` (m): height above the floor under which the segmentation removed points;
        model surface lower than that is treated as unobservable by both cues.  ``unknown``:
        full-resolution ``(H, W)`` bool, pixels without a depth measurement (see the class), or None.

        Pixel centres are kept aligned with :meth:`CameraIntrinsics.scaled` (``1/stride``).
        """
        if stride < 1:
            raise ValueError(f"stride must be >= 1, got {stride}")
        if depth_fg.shape != (intrinsics.height, intrinsics.width):
            msg = f"depth_fg shape {depth_fg.shape} != intrinsics {intrinsics.height}x{intrinsics.width}"
            raise ValueError(msg)
        intr = intrinsics if stride == 1 else intrinsics.scaled(1.0 / stride)
        off = stride // 2
        sub = np.asarray(depth_fg, dtype=np.float32)[off::stride, off::stride][: intr.height, : intr.width]
        if sub.shape != (intr.height, intr.width):
            pad = np.full((intr.height, intr.width), np.nan, np.float32)
            pad[: sub.shape[0], : sub.shape[1]] = sub
            sub = pad
        measured = np.isfinite(sub) & (sub > 0)
        unk = None
        if unknown is not None:
            if unknown.shape != depth_fg.shape:
                raise ValueError(f"unknown shape {unknown.shape} != depth_fg shape {depth_fg.shape}")
            cut = np.asarray(unknown, dtype=bool)[off::stride, off::stride][: intr.height, : intr.width]
            unk = np.zeros((intr.height, intr.width), dtype=bool)
            unk[: cut.shape[0], : cut.shape[1]] = cut
            unk &= ~measured  # a foreground pixel was measured
            if not unk.any():
                unk = None
        depth = np.where(measured, sub, 0.0).astype(np.float32)
        u = (np.arange(intr.width, dtype=np.float64) - intr.cx) / intr.fx
        v = (np.arange(intr.height, dtype=np.float64) - intr.cy) / intr.fy
        nrm = np.asarray(floor.normal, dtype=np.float64)
        ray_up = (nrm[0] * u[None, :] + nrm[1] * v[:, None] + nrm[2]).astype(np.float32)
        rows = np.flatnonzero(depth.any(axis=1))
        cols = np.flatnonzero(depth.any(axis=0))
        bbox = None if rows.size == 0 else (int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1)
        return CueImage(
            depth=depth,
            intrinsics=intr,
            ray_up=ray_up,
            floor_offset=float(floor.offset),
            floor_normal=nrm / np.linalg.norm(nrm),
            min_height=float(min_height),
            fg_bbox=bbox,
            unknown=unk,
        )

    def below_cut(self, pts: FloatArray, widths: FloatArray, *, margin: float = BELOW_CUT_MARGIN) -> BoolArray:
        """True where a skeleton point's surface cannot reach above ``min_height + margin``."""
        h = pts @ self.floor_normal + self.floor_offset
        return h + widths < self.min_height + margin

    def _pixels(self, pts: FloatArray) -> tuple[BoolArray, NDArray[np.intp]]:
        """``(inside, index)`` for camera-frame points ``(..., 3)``: whether each projects into the cue image
        (in front of the camera), and its row-major pixel index (0 outside)."""
        intr = self.intrinsics
        z = pts[..., 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            u = np.multiply(intr.fx, pts[..., 0])
            u /= z
            u += intr.cx
            np.rint(u, out=u)
            v = np.multiply(intr.fy, pts[..., 1])
            v /= z
            v += intr.cy
            np.rint(v, out=v)
        inside = z > 0.05
        inside &= u >= 0
        inside &= u < intr.width
        inside &= v >= 0
        inside &= v < intr.height
        # row-major pixel index (exact in float64), 0 outside; one flat gather instead of a 2D one
        v *= intr.width
        v += u
        return inside, np.where(inside, v, 0).astype(np.intp)

    def sample(self, pts: FloatArray) -> tuple[BoolArray, F32, BoolArray]:
        """``(inside, obs, unknown)`` for camera-frame points ``(..., 3)``: whether each projects into the cue
        image (in front of the camera), the observed depth at its pixel (0 = background/outside), and whether
        that pixel has no depth measurement (see the class)."""
        inside, idx = self._pixels(pts)
        obs = np.where(inside, np.take(self.depth, idx), np.float32(0.0))
        unknown = inside & np.take(self.unknown, idx) if self.unknown is not None else np.zeros_like(inside)
        return inside, obs, unknown

    def occluded(self, pts: FloatArray, widths: FloatArray, *, tol: float) -> BoolArray:
        """``(...)`` True where camera-frame skeleton points are out of the image, hidden, or over a
        pixel without a depth measurement (``unknown``).

        Hidden: the observed depth at the point's pixel is smaller than the model's front
        surface ``z - width`` by more than ``tol`` (something observed is in front of it).
        """
        inside, obs, unknown = self.sample(pts)
        out = (obs > 0) & (obs < pts[..., 2] - widths - tol)  # hidden
        out |= ~inside
        out |= unknown
        return out


def project_bbox(
    segments: FloatArray, radii: FloatArray, *, intrinsics: CameraIntrinsics
) -> tuple[int, int, int, int]:
    """Half-open pixel bbox ``(v0, v1, u0, u1)`` covering all rendered segments (clipped)."""
    pts = segments.reshape(-1, 3)
    z = np.maximum(pts[:, 2], 0.05)
    rmax = float(np.max(radii)) if radii.size else 0.0
    u = intrinsics.fx * pts[:, 0] / z + intrinsics.cx
    v = intrinsics.fy * pts[:, 1] / z + intrinsics.cy
    pad_u = intrinsics.fx * rmax / float(np.min(z)) + 1
    pad_v = intrinsics.fy * rmax / float(np.min(z)) + 1
    u0 = int(np.clip(np.floor(u.min() - pad_u), 0, intrinsics.width))
    u1 = int(np.clip(np.ceil(u.max() + pad_u) + 1, 0, intrinsics.width))
    v0 = int(np.clip(np.floor(v.min() - pad_v), 0, intrinsics.height))
    v1 = int(np.clip(np.ceil(v.max() + pad_v) + 1, 0, intrinsics.height))
    return v0, v1, u0, u1


def union_bbox(
    a: tuple[int, int, int, int] | None, b: tuple[int, int, int, int] | None
) -> tuple[int, int, int, int] | None:
    """Union of two half-open bboxes (None = empty)."""
    if a is None:
        return b
    if b is None:
        return a
    return min(a[0], b[0]), max(a[1], b[1]), min(a[2], b[2]), max(a[3], b[3])


def render_depth(
    segments: FloatArray,
    radii: FloatArray,
    *,
    cue: CueImage,
    bbox: tuple[int, int, int, int],
    floor_clip: BoolArray | None = None,
    depth_radii: FloatArray | None = None,
    work: Workspace | None = None,
    out: F32 | None = None,
) -> F32:
    """Render ``(P, S, 2, 3)`` camera-frame segments into the bbox; ``(P, Npix)`` depth, inf = empty.

    Row-major pixels of ``bbox``.  Each segment is only evaluated inside the union (over
    particles) of its own projected bbox; the per-pixel terms that are linear in the pixel
    coordinates (axis parameter, perpendicular distance) are built from separable row/column
    terms.  ``floor_clip``: ``(S,)`` segments (feet) whose surface points below the floor are
    dropped.  ``radii`` ``(P, S, 2)`` are the half-widths of the projected capsules;
    ``depth_radii`` (same shape, default ``radii``: circular sections) how far each segment's
    surface stands out of its axis towards the camera (see :func:`elliptic_section_radii`).
    ``work``: scratch buffers reused across calls; ``out``: optional C-contiguous ``(P, Npix)``
    float32 array to render into (overwritten and returned).
    """
    intr = cue.intrinsics
    v0, v1, u0, u1 = bbox
    p, s = segments.shape[:2]
    hh, ww = max(v1 - v0, 0), max(u1 - u0, 0)
    if out is None:
        out = np.full((p, hh * ww), np.inf, dtype=np.float32)
    else:
        if out.shape != (p, hh * ww) or out.dtype != np.float32 or not out.flags.c_contiguous:
            raise ValueError(f"out must be a C-contiguous float32 ({p}, {hh * ww}) array")
        out.fill(np.inf)
    if hh == 0 or ww == 0:
        return out
    img = out.reshape(p, hh, ww)
    fx, fy = float(intr.fx), float(intr.fy)
    seg = np.asarray(segments, dtype=np.float64)
    rad = np.asarray(radii, dtype=np.float64)
    za = np.maximum(seg[:, :, 0, 2], 0.05)
    zb = np.maximum(seg[:, :, 1, 2], 0.05)
    ax = fx * seg[:, :, 0, 0] / za + intr.cx
    ay = fy * seg[:, :, 0, 1] / za + intr.cy
    bx = fx * seg[:, :, 1, 0] / zb + intr.cx
    by = fy * seg[:, :, 1, 1] / zb + intr.cy
    rmax_px = fx * np.maximum(rad[:, :, 0] / za, rad[:, :, 1] / zb)
    # union bbox of each segment over particles (all segments at once), clipped to the render bbox
    lo_u = np.floor(np.min(np.minimum(ax, bx) - rmax_px, axis=0)) - 1
    hi_u = np.ceil(np.max(np.maximum(ax, bx) + rmax_px, axis=0)) + 2
    lo_v = np.floor(np.min(np.minimum(ay, by) - rmax_px, axis=0)) - 1
    hi_v = np.ceil(np.max(np.maximum(ay, by) + rmax_px, axis=0)) + 2
    boxes = []
    for j in range(s):
        su0, su1 = max(int(lo_u[j]), u0), min(int(hi_u[j]), u1)
        sv0, sv1 = max(int(lo_v[j]), v0), min(int(hi_v[j]), v1)
        if su1 > su0 and sv1 > sv0:
            boxes.append((j, sv0, sv1, su0, su1))
    if not boxes:
        return out
    drad = None if depth_radii is None else np.asarray(depth_radii, dtype=np.float64)
    jit = kernels.compiled()
    if jit is not None:
        clip = np.zeros(s, dtype=np.bool_) if floor_clip is None else np.asarray(floor_clip, dtype=np.bool_)
        cont = np.ascontiguousarray
        box_rows = np.array(boxes, dtype=np.int64)
        ax, ay, bx, by, za, zb = (cont(a) for a in (ax, ay, bx, by, za, zb))
        rad_c, drad_c = cont(rad), cont(rad if drad is None else drad)
        clip_s, ray_up = cont(clip[:s]), np.ascontiguousarray(cue.ray_up, dtype=np.float32)
        threshold = float(np.float32(max(cue.min_height, 0.0) - 0.005))

        def draw(i: int, a: int, b: int) -> None:  # particles a..b, into their own rows of the image
            jit.render_boxes(img[a:b], v0, u0, box_rows, ax[a:b], ay[a:b], bx[a:b], by[a:b], rad_c[a:b], za[a:b],
                             zb[a:b], drad_c[a:b], fx, clip_s, ray_up, float(cue.floor_offset), threshold)

        _spread(work, draw, p)
        return out
    # scratch shared by all segments, sized for the largest segment bbox
    size = p * max((b[2] - b[1]) * (b[4] - b[3]) for b in boxes)
    bufs = [_scratch(work, f"render_{i}", (size,)) for i in range(5)]
    elliptic = [drad is not None and not np.array_equal(drad[:, j], rad[:, j]) for j in range(s)]
    buf_rd = _scratch(work, "render_rd", (size,)) if any(elliptic) else None
    buf_in = _scratch(work, "render_in", (size,), np.bool_)
    fx32 = np.float32(fx)
    for j, sv0, sv1, su0, su1 in boxes:
        shape = (p, sv1 - sv0, su1 - su0)
        n = p * shape[1] * shape[2]
        t_raw, t, d2, r, z = (b[:n].reshape(shape) for b in bufs)
        uu = np.arange(su0, su1, dtype=np.float64)
        vv = np.arange(sv0, sv1, dtype=np.float64)
        dx, dy = bx[:, j] - ax[:, j], by[:, j] - ay[:, j]
        len2 = np.maximum(dx * dx + dy * dy, 1e-6)
        ln = np.sqrt(len2)
        # t_raw = ((u-ax) dx + (v-ay) dy) / len2 ; perpendicular distance = ((u-ax)(-dy) + (v-ay) dx) / len
        du = uu[None, :] - ax[:, j, None]
        dv = vv[None, :] - ay[:, j, None]
        tu = (du * (dx / len2)[:, None]).astype(np.float32)
        tv = (dv * (dy / len2)[:, None]).astype(np.float32)
        pu = (du * (-dy / ln)[:, None]).astype(np.float32)
        pv = (dv * (dx / ln)[:, None]).astype(np.float32)
        np.add(tv[:, :, None], tu[:, None, :], out=t_raw)  # (P, h, w)
        np.clip(t_raw, 0.0, 1.0, out=t)
        t_raw -= t
        t_raw *= ln.astype(np.float32)[:, None, None]  # along-axis excess (px)
        np.add(pv[:, :, None], pu[:, None, :], out=d2)  # perpendicular distance (px)
        d2 *= d2
        t_raw *= t_raw
        d2 += t_raw
        ra = rad[:, j, 0].astype(np.float32)[:, None, None]
        dr = (rad[:, j, 1] - rad[:, j, 0]).astype(np.float32)[:, None, None]
        z0 = za[:, j].astype(np.float32)[:, None, None]
        dz = (zb[:, j] - za[:, j]).astype(np.float32)[:, None, None]
        np.multiply(t, dr, out=r)
        r += ra
        np.multiply(t, dz, out=z)
        z += z0
        rd = r
        if elliptic[j]:
            assert drad is not None and buf_rd is not None
            rd = np.multiply(t, (drad[:, j, 1] - drad[:, j, 0]).astype(np.float32)[:, None, None],
                             out=buf_rd[:n].reshape(shape))
            rd += drad[:, j, 0].astype(np.float32)[:, None, None]
        # q = 1 - d2 / rho^2 with rho = r fx / z
        rho = np.multiply(r, fx32, out=t)
        rho /= z
        rho *= rho
        d2 /= rho
        q = np.subtract(1.0, d2, out=d2)
        # The surface covers the pixels with q > 0.  They are marked by their depth being a number:
        # sqrt(q) * (q / q) is sqrt(q) exactly where q > 0 (q / q = 1) and NaN elsewhere (sqrt of a
        # negative, 0 / 0, or q NaN); the NaN carries through to z and `fmin` below skips it, which
        # is the masked z-buffer without building and applying a mask (with finite segments z is
        # never NaN on the surface; non-finite ones already fail in the bbox above).
        with np.errstate(invalid="ignore"):
            unit = np.divide(q, q, out=t_raw)
            np.sqrt(q, out=q)
            q *= unit
            q *= rd
            np.subtract(z, q, out=z)  # front-surface depth
            if floor_clip is not None and floor_clip[j]:
                up = cue.ray_up[sv0:sv1, su0:su1]
                h = np.multiply(z, up[None], out=t_raw)
                h += np.float32(cue.floor_offset)
                above = np.greater_equal(h, np.float32(max(cue.min_height, 0.0) - 0.005), out=buf_in[:n].reshape(shape))
                # drop points below the floor: z * 1 where above, z * NaN (0 / 0) elsewhere
                np.copyto(t, above)
                np.divide(t, t, out=t)
                z *= t
        view = img[:, sv0 - v0 : sv1 - v0, su0 - u0 : su1 - u0]
        np.fmin(view, z, out=view)
    return out


@dataclass(frozen=True)
class Cue2DParams:
    """Parameters of the 2D cue (eq. 8-9)."""

    lam: float = PAPER_LAMBDA_2D  # rate, 1/m
    stride: int = 1  # cue image = full resolution / stride (paper: 1 = 640x480)
    truncate: float = np.inf  # m: per-pixel cost cap (paper: none; mismatch costs the full depth)
    occlusion_aware: bool = False  # observed surface in front of the model costs `occluded_cost`
    occluded_cost: float = 0.02  # m
    occlusion_tol: float = 0.05  # m


def depth_costs(
    model: F32, observed: F32, *, params: Cue2DParams, overwrite: bool = False, work: Workspace | None = None
) -> F32:
    """Per-pixel ``|z_P - z_K|`` (eq. 8 terms), background = 0 in both images; ``(P, Npix)``.

    ``overwrite``: compute in ``model``'s memory (then returned; ``model`` is destroyed).
    ``work``: scratch buffers reused across calls.
    """
    if model.dtype != np.float32 or observed.dtype != np.float32 or not model.flags.c_contiguous:
        return _depth_costs_generic(model, observed, params=params)
    c = model if overwrite else model.copy()
    k = observed[None, :]
    seen = np.isfinite(c, out=_scratch(work, "costs_seen", c.shape, np.bool_))  # model pixel rendered
    # m = where(seen, c, 0): AND of the float32 bit patterns with all ones / all zeros (exact, and much
    # faster than a masked copy)
    keep = _scratch(work, "costs_keep", c.shape, np.int32)
    np.copyto(keep, seen)
    np.negative(keep, out=keep)
    np.bitwise_and(c.view(np.int32), keep, out=c.view(np.int32))
    occ = None
    if params.occlusion_aware:
        # observed surface in front of the model: (k > 0) & seen & (k < m - tol), before m is overwritten
        front = np.subtract(c, np.float32(params.occlusion_tol), out=_scratch(work, "costs_tmp", c.shape))
        occ = np.less(k, front, out=_scratch(work, "costs_occ", c.shape, np.bool_))
        occ &= seen
        occ &= k > 0
    np.subtract(c, k, out=c)
    np.abs(c, out=c)
    if occ is not None:
        np.copyto(c, np.float32(params.occluded_cost), where=occ)
    if np.isfinite(params.truncate):
        # = np.minimum(c, truncate) (same values, signed zeros included), faster SIMD loop
        np.clip(c, -np.inf, np.float32(params.truncate), out=c)
    return c


def _depth_costs_generic(model: NDArray[np.floating], observed: NDArray[np.floating], *, params: Cue2DParams) -> NDArray[np.floating]:
    """:func:`depth_costs` for other dtypes / layouts (straightforward, allocating)."""
    empty = ~np.isfinite(model)
    m = np.where(empty, np.float32(0.0), model)
    k = observed[None, :]
    c = m - k
    np.abs(c, out=c)
    if params.occlusion_aware:
        occ = (k > 0) & ~empty & (k < m - np.float32(params.occlusion_tol))
        c[occ] = np.float32(params.occluded_cost)
    if np.isfinite(params.truncate):
        np.minimum(c, np.float32(params.truncate), out=c)
    return c


def log_likelihood_2d(
    segments: FloatArray,
    radii: FloatArray,
    *,
    cue: CueImage,
    params: Cue2DParams,
    bbox: tuple[int, int, int, int] | None = None,
    ref_render: F32 | None = None,
    floor_clip: BoolArray | None = None,
    depth_radii: FloatArray | None = None,
    chunk: int = 256,
    work: Workspace | None = None,
) -> FloatArray:
    """Log likelihood ``-λ2 d2`` (eq. 8-9) of ``(P, S, 2, 3)`` camera-frame segments.

    ``bbox``: pixels evaluated (must contain every foreground pixel and all rendered model
    pixels for the normalisation to be exact); default = union of the foreground bbox and the
    particles' projected bbox.  ``ref_render``: ``(Npix,)`` depth of fixed model parts rendered
    in the same bbox (z-buffered with each particle).  ``radii`` / ``depth_radii``: as in
    :func:`render_depth`.  Particles are processed in chunks.
    ``work``: scratch buffers reused across calls (same results, less allocation).
    """
    p = segments.shape[0]
    if bbox is None:
        bbox = union_bbox(cue.fg_bbox, project_bbox(segments, radii, intrinsics=cue.intrinsics))
    assert bbox is not None
    v0, v1, u0, u1 = bbox
    obs = cue.depth[v0:v1, u0:u1].ravel()
    # pixels without a depth measurement cost nothing: the compiled sums skip them; the numpy code takes their
    # costs back out of each particle's sum (a gather over those pixels, cheaper than masking every pixel when
    # they are a minority)
    unknown_mask = None if cue.unknown is None else np.ascontiguousarray(cue.unknown[v0:v1, u0:u1], dtype=np.bool_).ravel()
    total = float(cue.intrinsics.width * cue.intrinsics.height)
    out = np.empty(p)
    jit = kernels.compiled()
    if jit is not None:
        obs = np.ascontiguousarray(obs, dtype=np.float32)
        ref32 = obs if ref_render is None else np.ascontiguousarray(ref_render, dtype=np.float32)
        skip = np.zeros(obs.size, np.bool_) if unknown_mask is None else unknown_mask
        sums = np.empty(min(p, chunk))
    else:
        unknown = None if unknown_mask is None else np.flatnonzero(unknown_mask)
    for c0 in range(0, p, chunk):
        sl = slice(c0, min(p, c0 + chunk))
        model = render_depth(
            segments[sl],
            radii[sl],
            cue=cue,
            bbox=bbox,
            floor_clip=floor_clip,
            depth_radii=None if depth_radii is None else depth_radii[sl],
            work=work,
            out=_scratch(work, "model", (sl.stop - sl.start, obs.size)),
        )
        if jit is not None:  # the costs summed in one compiled pass (z-buffered with ref_render there)
            rows = sums[: sl.stop - sl.start]

            def costs(i: int, a: int, b: int, model: F32 = model, rows: FloatArray = rows) -> None:
                jit.depth_cost_sums(model[a:b], ref32, ref_render is not None, obs, skip,
                                    bool(params.occlusion_aware), np.float32(params.occlusion_tol),
                                    np.float32(params.occluded_cost), np.float32(params.truncate), rows[a:b],
                                    _scratch(work, f"cost_row{i}" if i else "cost_row", (obs.size,)))

            _spread(work, costs, len(rows))
            out[sl] = rows / total
            continue
        if ref_render is not None:
            np.minimum(model, ref_render[None, :], out=model)
        cost = depth_costs(model, obs, params=params, overwrite=True, work=work)
        d2 = cost.sum(axis=1, dtype=np.float64)
        if unknown is not None and unknown.size:
            d2 -= np.take(cost, unknown, axis=1).sum(axis=1, dtype=np.float64)
        out[sl] = d2 / total
    return -params.lam * out


def combine_log_likelihoods(*logs: FloatArray) -> FloatArray:
    """Eq. 10 in log space: the product of independent cues is the sum of their logs."""
    total = np.zeros_like(np.asarray(logs[0], dtype=np.float64))
    for lg in logs:
        total = total + lg
    return total
