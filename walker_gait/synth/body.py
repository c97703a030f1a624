"""Triangle-mesh surfaces of the legs, shoes and trousers (world frame, metres).

The surfaces are deliberately *not* cylinders:

* thigh / shank: generalised cylinders with elliptical cross-sections whose mediolateral and
  anteroposterior semi-axes and centre offsets vary along the segment (quadriceps, posterior
  calf bulge peaking at ~30 % of the shank, narrow ankle, malleoli);
* shoe: a boxy super-ellipse section (exponent 4) swept along the foot, wider than the ankle,
  flat sole, heel counter ~10 cm high, toe box ~4 cm, closed at the heel and toe so that the
  posterior-most sole point is the GT heel and the anterior sole tip is the GT toe;
* trousers: ``"fitted"`` inflates thigh/shank by a few cm of ease with small wrinkles and a
  hem above the shoe; ``"baggy"`` is a separate, wide, open tube (flared hem 2-6 cm above the
  floor, vertical folds increasing towards the hem, horizontal folds at the flexed knee) whose
  lower centre line hangs with gravity and lags behind the shank (cloth inertia), so the
  trouser surface does not follow the leg exactly and partly hides ankle and shoe;
  ``"none"`` shows skin (shorts).

Every mesh has a material id (:data:`MAT_SKIN`, ...) and a side (0 left, 1 right) per face.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int32]

MAT_NONE, MAT_FLOOR, MAT_SKIN, MAT_TROUSERS, MAT_SHOE, MAT_WALKER, MAT_CLUTTER = range(7)
MATERIAL_NAMES = ("none", "floor", "skin", "trousers", "shoe", "walker", "clutter")
CLOTHING = ("none", "fitted", "baggy")

# profile tables along the segment, s = 0 proximal ... 1 distal (metres, medium adult)
_THIGH_S = np.array([-0.08, 0.0, 0.15, 0.4, 0.7, 0.9, 1.0, 1.06])
_THIGH_ML = np.array([0.070, 0.080, 0.082, 0.074, 0.062, 0.052, 0.050, 0.040])
_THIGH_AP = np.array([0.065, 0.075, 0.078, 0.070, 0.058, 0.050, 0.048, 0.038])
_THIGH_MLOFF = np.array([0.020, 0.020, 0.018, 0.012, 0.005, 0.0, 0.0, 0.0])
_THIGH_APOFF = np.array([0.0, 0.0, 0.005, 0.010, 0.006, 0.0, 0.0, 0.0])
_SHANK_S = np.array([-0.04, 0.0, 0.08, 0.25, 0.35, 0.6, 0.85, 0.95, 1.0, 1.03])
_SHANK_ML = np.array([0.045, 0.050, 0.048, 0.054, 0.055, 0.045, 0.035, 0.037, 0.033, 0.025])
_SHANK_AP = np.array([0.045, 0.050, 0.050, 0.058, 0.060, 0.048, 0.036, 0.035, 0.034, 0.025])
_SHANK_APOFF = np.array([0.0, 0.0, -0.005, -0.015, -0.018, -0.010, -0.003, 0.0, 0.0, 0.0])
_SHOE_S = np.array([0.0, 0.05, 0.2, 0.5, 0.7, 0.85, 0.95, 1.0])
_SHOE_W = np.array([0.060, 0.074, 0.080, 0.090, 0.100, 0.095, 0.075, 0.035])
_SHOE_HS = np.array([0.0, 0.1, 0.3, 0.45, 0.6, 0.8, 0.95, 1.0])
_SHOE_H = np.array([0.085, 0.105, 0.100, 0.085, 0.065, 0.050, 0.040, 0.022])


@dataclass(frozen=True, kw_only=True)
class BodyShape:
    """Per-session surface parameters (dimensionless factors scale the profile tables)."""

    girth: float = 1.0  # scales thigh/shank radii
    calf_bulge: float = 1.0  # scales the calf bulge above the ankle-knee baseline
    shoe_scale: float = 1.0  # scales shoe width/height
    clothing: str = "fitted"  # "none" | "fitted" | "baggy"
    ease: float = 0.012  # fitted trousers: radial ease (m)
    baggy_radius: float = 0.11  # baggy trousers: hem radius (m)
    hem_height: float = 0.04  # baggy: hem height above the floor with the foot flat (m)
    fold_amp: float = 0.06  # relative amplitude of trouser folds
    fold_phase: tuple[float, ...] = (0.0, 1.0, 2.0, 3.0, 4.0, 5.0)  # random phases of fold harmonics
    hem_lag: float = 0.06  # baggy hem time constant (s)

    def __post_init__(self) -> None:
        if self.clothing not in CLOTHING:
            msg = f"clothing must be one of {CLOTHING}, got {self.clothing!r}"
            raise ValueError(msg)


@dataclass
class Mesh:
    """Triangle soup: vertices (N,3), faces (M,3) int32, per-face material and side."""

    vertices: FloatArray
    faces: IntArray
    material: NDArray[np.int8]
    side: NDArray[np.int8]

    @staticmethod
    def concat(meshes: list[Mesh]) -> Mesh:
        if not meshes:
            return Mesh(np.zeros((0, 3)), np.zeros((0, 3), np.int32), np.zeros(0, np.int8), np.zeros(0, np.int8))
        offs = np.cumsum([0] + [len(m.vertices) for m in meshes[:-1]])
        return Mesh(
            np.concatenate([m.vertices for m in meshes]),
            np.concatenate([m.faces + o for m, o in zip(meshes, offs, strict=True)]).astype(np.int32),
            np.concatenate([m.material for m in meshes]),
            np.concatenate([m.side for m in meshes]),
        )

    def transformed(self, rot: FloatArray, trans: FloatArray) -> Mesh:
        """Mesh with vertices ``rot @ v + trans``."""
        return Mesh(self.vertices @ rot.T + trans, self.faces, self.material, self.side)


def orient_faces(vertices: FloatArray, faces: IntArray, interior: FloatArray) -> IntArray:
    """Flip faces so that their normal ``(p1-p0) x (p2-p0)`` points away from ``interior`` (M,3)."""
    p0, p1, p2 = vertices[faces[:, 0]], vertices[faces[:, 1]], vertices[faces[:, 2]]
    n = np.cross(p1 - p0, p2 - p0)
    out = (p0 + p1 + p2) / 3.0 - interior
    flip = np.sum(n * out, axis=-1) < 0
    f = faces.copy()
    f[flip, 1], f[flip, 2] = faces[flip, 2], faces[flip, 1]
    return f


def grid_faces(n_rings: int, n_theta: int, *, closed_theta: bool = True) -> IntArray:
    """Two triangles per quad of an ``n_rings x n_theta`` vertex grid (row-major)."""
    r = np.arange(n_rings - 1)[:, None]
    t = np.arange(n_theta if closed_theta else n_theta - 1)[None, :]
    t1 = (t + 1) % n_theta
    a = r * n_theta + t
    b = r * n_theta + t1
    c = (r + 1) * n_theta + t
    d = (r + 1) * n_theta + t1
    f = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([b, d, c], -1).reshape(-1, 3)])
    return f.astype(np.int32)


def _cap(ring_idx: NDArray[np.intp], centre_idx: int) -> IntArray:
    n = len(ring_idx)
    return np.stack([ring_idx, ring_idx[(np.arange(n) + 1) % n], np.full(n, centre_idx)], -1).astype(np.int32)


def tube(
    centres: FloatArray,
    e_lat: FloatArray,
    e_ap: FloatArray,
    r_lat: FloatArray,
    r_ap: FloatArray,
    *,
    n_theta: int,
    radial: FloatArray | None = None,
    cap_start: bool = True,
    cap_end: bool = True,
    material: int,
    side: int,
) -> Mesh:
    """Generalised cylinder: rings at ``centres`` (S,3) with axes ``e_lat``/``e_ap`` (S,3) and
    semi-axes ``r_lat``/``r_ap`` (S,); ``radial`` (S, n_theta) multiplies the radius (folds)."""
    theta = np.linspace(0.0, 2 * np.pi, n_theta, endpoint=False)
    c, s = np.cos(theta), np.sin(theta)
    mult = np.ones((len(centres), n_theta)) if radial is None else radial
    v = (
        centres[:, None, :]
        + (r_lat[:, None] * c[None, :] * mult)[..., None] * e_lat[:, None, :]
        + (r_ap[:, None] * s[None, :] * mult)[..., None] * e_ap[:, None, :]
    ).reshape(-1, 3)
    side_faces = grid_faces(len(centres), n_theta)
    ring = side_faces[:, 0] // n_theta
    ring_next = np.minimum(ring + 1, len(centres) - 1)
    interiors = [0.5 * (centres[ring] + centres[ring_next])]
    faces = [side_faces]
    verts = [v]
    n = len(v)
    axis0 = centres[min(1, len(centres) - 1)] - centres[0]
    axis1 = centres[-1] - centres[max(0, len(centres) - 2)]
    if cap_start:
        verts.append(centres[:1])
        faces.append(_cap(np.arange(n_theta), n))
        interiors.append(np.tile(centres[0] + axis0, (n_theta, 1)))
        n += 1
    if cap_end:
        verts.append(centres[-1:])
        faces.append(_cap(np.arange(n_theta) + (len(centres) - 1) * n_theta, n))
        interiors.append(np.tile(centres[-1] - axis1, (n_theta, 1)))
    allv = np.concatenate(verts)
    f = orient_faces(allv, np.concatenate(faces), np.concatenate(interiors))
    return Mesh(allv, f, np.full(len(f), material, np.int8), np.full(len(f), side, np.int8))


def _segment_axes(p: FloatArray, d: FloatArray, fwd: FloatArray, sgn: float) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Unit axis (proximal->distal), anterior and outward-lateral directions of a segment."""
    a = d - p
    a = a / np.linalg.norm(a)
    ap = fwd - (fwd @ a) * a
    nap = np.linalg.norm(ap)
    if nap < 1e-9:
        ap = np.array([1.0, 0.0, 0.0])
    else:
        ap = ap / nap
    left = np.cross(ap, a)
    return a, ap, sgn * left


def leg_meshes(
    *,
    hip: FloatArray,
    knee: FloatArray,
    ankle: FloatArray,
    heel: FloatArray,
    foot_rot: FloatArray,
    side: int,
    shape: BodyShape,
    hem_centre: FloatArray | None = None,
    knee_flex: float = 0.0,
    foot_length: float = 0.27,
    detail: float = 1.0,
) -> list[Mesh]:
    """Meshes of one leg (world frame).

    ``foot_rot`` (3,3) has columns forward, left, up of the shoe; ``heel`` is the GT heel point;
    ``hem_centre`` is the baggy-trouser hem centre (world), default: below the ankle.
    ``detail`` scales the tessellation (1.0: ~1.5k vertices per leg).
    """
    sgn = 1.0 if side == 0 else -1.0
    n_th = max(8, int(round(20 * detail)))
    fwd = foot_rot[:, 0]
    meshes: list[Mesh] = []
    g = shape.girth
    cloth = shape.clothing
    ph = np.asarray(shape.fold_phase, float)
    theta = np.linspace(0.0, 2 * np.pi, n_th, endpoint=False)

    # ---------------------------------------------------------------- thigh
    a, ap, lat = _segment_axes(hip, knee, fwd, sgn)
    L = np.linalg.norm(knee - hip)
    ns = max(5, int(round(12 * detail)))
    s = np.linspace(_THIGH_S[0], _THIGH_S[-1], ns)
    rl = g * np.interp(s, _THIGH_S, _THIGH_ML)
    ra = g * np.interp(s, _THIGH_S, _THIGH_AP)
    c = hip + np.outer(s * L, a) + np.outer(np.interp(s, _THIGH_S, _THIGH_MLOFF), lat) + np.outer(
        np.interp(s, _THIGH_S, _THIGH_APOFF), ap
    )
    radial = None
    mat = MAT_SKIN
    if cloth == "fitted":
        rl, ra = rl + shape.ease, ra + shape.ease
        radial = 1.0 + 0.25 * shape.fold_amp * np.sin(3 * theta[None, :] + ph[0] + 9.0 * s[:, None])
        mat = MAT_TROUSERS
    if cloth != "baggy":
        meshes.append(tube(c, np.tile(lat, (ns, 1)), np.tile(ap, (ns, 1)), rl, ra, n_theta=n_th, radial=radial, material=mat, side=side))

    # ---------------------------------------------------------------- shank
    a2, ap2, lat2 = _segment_axes(knee, ankle, fwd, sgn)
    L2 = np.linalg.norm(ankle - knee)
    ns2 = max(6, int(round(16 * detail)))
    s2 = np.linspace(_SHANK_S[0], _SHANK_S[-1], ns2)
    base_ml = np.interp(s2, [0.0, 1.0], [_SHANK_ML[1], _SHANK_ML[-2]])
    base_ap = np.interp(s2, [0.0, 1.0], [_SHANK_AP[1], _SHANK_AP[-2]])
    rl2 = g * (base_ml + shape.calf_bulge * (np.interp(s2, _SHANK_S, _SHANK_ML) - base_ml))
    ra2 = g * (base_ap + shape.calf_bulge * (np.interp(s2, _SHANK_S, _SHANK_AP) - base_ap))
    c2 = knee + np.outer(s2 * L2, a2) + np.outer(shape.calf_bulge * np.interp(s2, _SHANK_S, _SHANK_APOFF), ap2)
    if cloth == "fitted":
        hem_s = 0.86
        covered = s2 <= hem_s
        rl2 = np.where(covered, rl2 + shape.ease, rl2)
        ra2 = np.where(covered, ra2 + shape.ease, ra2)
        radial2 = 1.0 + 0.3 * shape.fold_amp * np.sin(4 * theta[None, :] + ph[1] + 7.0 * s2[:, None]) * covered[:, None]
        # split into trousers (upper) and sock/skin (lower) tubes sharing the hem ring
        k = int(np.searchsorted(s2, hem_s))
        up = slice(0, k + 1)
        lo = slice(k, ns2)
        meshes.append(tube(c2[up], np.tile(lat2, (k + 1, 1)), np.tile(ap2, (k + 1, 1)), rl2[up], ra2[up], n_theta=n_th, radial=radial2[up], material=MAT_TROUSERS, side=side))
        meshes.append(tube(c2[lo], np.tile(lat2, (ns2 - k, 1)), np.tile(ap2, (ns2 - k, 1)), rl2[lo], ra2[lo], n_theta=n_th, material=MAT_SKIN, side=side))
    else:
        meshes.append(tube(c2, np.tile(lat2, (ns2, 1)), np.tile(ap2, (ns2, 1)), rl2, ra2, n_theta=n_th, material=MAT_SKIN, side=side))

    # ---------------------------------------------------------------- shoe
    meshes.append(shoe_mesh(heel=heel, foot_rot=foot_rot, length=foot_length, scale=shape.shoe_scale, detail=detail, side=side))

    # ---------------------------------------------------------------- baggy trousers
    if cloth == "baggy":
        meshes.append(
            baggy_trouser_mesh(
                hip=hip, knee=knee, ankle=ankle, fwd=fwd, sgn=sgn, side=side, shape=shape,
                hem_centre=hem_centre, knee_flex=knee_flex, detail=detail,
            )
        )
    return meshes


def shoe_mesh(
    *,
    heel: FloatArray,
    foot_rot: FloatArray,
    length: float,
    scale: float,
    detail: float,
    side: int,
) -> Mesh:
    """Closed, boxy shoe of ``length`` m from the heel point along ``foot_rot`` (columns fwd/left/up)."""
    L = length
    n_th = max(8, int(round(16 * detail)))
    ns = max(6, int(round(14 * detail)))
    s = np.linspace(0.0, 1.0, ns)
    w = scale * np.interp(s, _SHOE_S, _SHOE_W) / 2
    h = scale * np.interp(s, _SHOE_HS, _SHOE_H)
    theta = np.linspace(0.0, 2 * np.pi, n_th, endpoint=False)
    ct, st = np.cos(theta), np.sin(theta)
    ex = 2.0 / 4.0  # super-ellipse exponent 4
    yy = w[:, None] * np.sign(ct) * np.abs(ct) ** ex
    zz = h[:, None] / 2 * (1.0 + np.sign(st) * np.abs(st) ** ex)
    xx = np.broadcast_to((s * L)[:, None], yy.shape)
    local = np.stack([xx, yy, zz], -1).reshape(-1, 3)
    side_faces = grid_faces(ns, n_th)
    n = len(local)
    centres = np.array([[0.0, 0.0, h[0] / 2], [L, 0.0, h[-1] / 2]])
    ring = side_faces[:, 0] // n_th
    mid = np.stack([(s[ring] + 0.5 / (ns - 1)) * L, np.zeros(len(ring)), 0.5 * (h[ring] + h[np.minimum(ring + 1, ns - 1)]) / 2], -1)
    faces = [side_faces, _cap(np.arange(n_th), n), _cap(np.arange(n_th) + (ns - 1) * n_th, n + 1)]
    interior = np.concatenate([mid, np.tile([0.3 * L, 0.0, h[0] / 2], (n_th, 1)), np.tile([0.7 * L, 0.0, h[-1] / 2], (n_th, 1))])
    local_all = np.concatenate([local, centres])
    f = orient_faces(local_all, np.concatenate(faces), interior)
    verts = local_all @ foot_rot.T + heel
    return Mesh(verts, f, np.full(len(f), MAT_SHOE, np.int8), np.full(len(f), side, np.int8))


def baggy_trouser_mesh(
    *,
    hip: FloatArray,
    knee: FloatArray,
    ankle: FloatArray,
    fwd: FloatArray,
    sgn: float,
    side: int,
    shape: BodyShape,
    hem_centre: FloatArray | None,
    knee_flex: float,
    detail: float,
) -> Mesh:
    """Wide open tube from the upper thigh to a flared hem with folds (world frame)."""
    n_th = max(10, int(round(26 * detail)))
    n_up = max(4, int(round(8 * detail)))
    n_lo = max(6, int(round(16 * detail)))
    a, ap, lat = _segment_axes(hip, knee, fwd, sgn)
    L = np.linalg.norm(knee - hip)
    s_up = np.linspace(0.0, 1.0, n_up, endpoint=False)
    c_up = hip + np.outer(s_up * L, a) + np.outer(0.02 * (1 - s_up), lat)
    if hem_centre is None:
        hem_centre = ankle + np.array([0.0, 0.0, -0.05])
    s_lo = np.linspace(0.0, 1.0, n_lo)
    # lower leg: bend from the shank direction towards the hanging hem (quadratic Bezier)
    mid = knee + 0.55 * (ankle - knee)
    c_lo = (
        ((1 - s_lo) ** 2)[:, None] * knee
        + (2 * s_lo * (1 - s_lo))[:, None] * mid
        + (s_lo**2)[:, None] * hem_centre
    )
    centres = np.concatenate([c_up, c_lo])
    s_all = np.concatenate([s_up * 0.5, 0.5 + 0.5 * s_lo])  # 0 hip .. 0.5 knee .. 1 hem
    # ring axes from the local centre-line tangent
    tang = np.gradient(centres, axis=0)
    tang /= np.linalg.norm(tang, axis=-1, keepdims=True)
    e_ap = fwd[None, :] - np.sum(fwd[None, :] * tang, -1, keepdims=True) * tang
    e_ap /= np.maximum(np.linalg.norm(e_ap, axis=-1, keepdims=True), 1e-9)
    e_lat = sgn * np.cross(e_ap, tang)
    g = shape.girth
    r_knee = 0.085 * g + 0.01
    r_hem = shape.baggy_radius
    r = np.interp(s_all, [0.0, 0.25, 0.5, 0.75, 1.0], [0.10 * g + 0.02, 0.095 * g + 0.02, r_knee, 0.5 * (r_knee + r_hem), r_hem])
    theta = np.linspace(0.0, 2 * np.pi, n_th, endpoint=False)
    ph = np.asarray(shape.fold_phase, float)
    vert_amp = shape.fold_amp * np.clip((s_all - 0.45) / 0.55, 0.0, 1.0) ** 1.5
    folds = (
        np.sin(5 * theta[None, :] + ph[2]) * 0.6
        + np.sin(7 * theta[None, :] + ph[3] + 2.0 * s_all[:, None]) * 0.4
        + np.sin(3 * theta[None, :] + ph[4]) * 0.5
    )
    horiz = 0.5 * shape.fold_amp * np.clip(knee_flex / 1.0, 0.0, 1.0) * np.sin(2 * np.pi * 7 * s_all + ph[5])[:, None] * np.exp(
        -(((s_all - 0.52) / 0.1) ** 2)
    )[:, None] * np.ones_like(theta)[None, :]
    radial = 1.0 + vert_amp[:, None] * folds + horiz
    m = tube(centres, e_lat, e_ap, r * 1.03, r * 0.97, n_theta=n_th, radial=radial, cap_start=True, cap_end=False, material=MAT_TROUSERS, side=side)
    m.vertices[:, 2] = np.maximum(m.vertices[:, 2], 0.004)  # fabric piles on the floor, never below
    return m


def box_mesh(centre: FloatArray, half: FloatArray, rot: FloatArray, *, material: int, tiles: int = 1) -> Mesh:
    """Axis-aligned box (in ``rot`` frame) with faces tessellated ``tiles x tiles`` (for near clipping)."""
    verts = []
    faces = []
    n = 0
    lin = np.linspace(-1.0, 1.0, tiles + 1)
    uu, vv = np.meshgrid(lin, lin, indexing="ij")
    quad = grid_faces(tiles + 1, tiles + 1, closed_theta=False)
    for axis in range(3):
        for sgn in (-1.0, 1.0):
            o = [(axis + 1) % 3, (axis + 2) % 3]
            p = np.zeros((tiles + 1, tiles + 1, 3))
            p[..., axis] = sgn
            p[..., o[0]] = uu
            p[..., o[1]] = vv
            verts.append(p.reshape(-1, 3) * half)
            faces.append(quad + n)
            n += (tiles + 1) ** 2
    local = np.concatenate(verts)
    f = orient_faces(local, np.concatenate(faces), np.zeros((sum(len(x) for x in faces), 3)))
    v = local @ rot.T + centre
    return Mesh(v, f, np.full(len(f), material, np.int8), np.full(len(f), -1, np.int8))


def cylinder_mesh(p0: FloatArray, p1: FloatArray, radius: float, *, material: int, n_theta: int = 16, n_len: int = 4) -> Mesh:
    """Closed circular cylinder between ``p0`` and ``p1`` (walker tubes, wheels)."""
    a = p1 - p0
    a = a / np.linalg.norm(a)
    helper = np.array([0.0, 0.0, 1.0]) if abs(a[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    e1 = np.cross(a, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    s = np.linspace(0.0, 1.0, n_len)
    c = p0 + np.outer(s, p1 - p0)
    r = np.full(n_len, radius)
    m = tube(c, np.tile(e1, (n_len, 1)), np.tile(e2, (n_len, 1)), r, r, n_theta=n_theta, material=material, side=-1)
    return m
