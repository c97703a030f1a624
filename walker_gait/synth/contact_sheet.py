"""Contact sheet: a grid of colour-mapped depth frames with the projected ground-truth points."""

from __future__ import annotations

import os
from pathlib import Path

import cv2
import numpy as np

from walker_gait.core.types import LEG_POINTS
from walker_gait.synth.session import Session

# BGR colours: left leg warm, right leg cool; point order hip, knee, ankle, heel, toe
_LEFT = [(0, 0, 255), (0, 128, 255), (0, 220, 255), (255, 0, 255), (180, 105, 255)]
_RIGHT = [(255, 0, 0), (255, 160, 0), (255, 255, 0), (0, 200, 0), (128, 255, 128)]


def colourise_depth(depth_m: np.ndarray, *, z_min: float = 0.4, z_max: float = 1.9) -> np.ndarray:
    """BGR uint8 image of a float depth map (NaN invalid -> black), near = warm (TURBO)."""
    z = np.asarray(depth_m, dtype=np.float32)
    valid = np.isfinite(z)
    norm = np.clip((z_max - np.where(valid, z, z_max)) / (z_max - z_min), 0, 1)
    img = cv2.applyColorMap((norm * 255).astype(np.uint8), cv2.COLORMAP_TURBO)
    img[~valid] = 0
    return img


def render_tile(session: Session, i: int, *, tile_width: int = 320) -> np.ndarray:
    """One annotated tile (BGR) for frame ``i``."""
    depth = session.depth_m(i)
    img = colourise_depth(depth)
    h, w = img.shape[:2]
    s = tile_width / w
    img = cv2.resize(img, (tile_width, int(round(h * s))), interpolation=cv2.INTER_NEAREST)
    uv = session.intrinsics.project(session.leg_points[i])  # (2,5,2)
    for side, cols in ((0, _LEFT), (1, _RIGHT)):
        pts = []
        for j in range(len(LEG_POINTS)):
            u, v = uv[side, j]
            if not (np.isfinite(u) and np.isfinite(v)):
                pts.append(None)
                continue
            p = (int(round((u + 0.5) * s - 0.5)), int(round((v + 0.5) * s - 0.5)))
            pts.append(p)
        for a, b in ((0, 1), (1, 2), (2, 3), (2, 4), (3, 4)):
            if pts[a] is not None and pts[b] is not None:
                cv2.line(img, pts[a], pts[b], (255, 255, 255), 1, cv2.LINE_AA)
        for j, p in enumerate(pts):
            if p is not None:
                cv2.circle(img, p, 3, cols[j], -1, cv2.LINE_AA)
    stance = session.body.stance[i]
    label = f"#{i} t={session.stamps[i]:.2f}s L{'S' if stance[0] else 'w'} R{'S' if stance[1] else 'w'}"
    cv2.putText(img, label, (4, 14), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (255, 255, 255), 1, cv2.LINE_AA)
    return img


def write_contact_sheet(
    session: Session,
    path: str | os.PathLike[str],
    *,
    n_frames: int = 12,
    columns: int = 4,
    tile_width: int = 320,
    frames: list[int] | None = None,
) -> Path:
    """Write a PNG grid of ``n_frames`` evenly spaced frames (or ``frames``) to ``path``.

    Left-leg points are drawn red/orange/yellow/magenta/pink (hip, knee, ankle, heel, toe),
    right-leg points blue/azure/cyan/green/light green; header: frame, time, stance (S) / swing (w).
    """
    n = len(session)
    idx = frames if frames is not None else [int(round(x)) for x in np.linspace(0, n - 1, min(n_frames, n))]
    tiles = [render_tile(session, i, tile_width=tile_width) for i in idx]
    th, tw = tiles[0].shape[:2]
    rows = int(np.ceil(len(tiles) / columns))
    sheet = np.zeros((rows * th, columns * tw, 3), np.uint8)
    for k, t in enumerate(tiles):
        r, c = divmod(k, columns)
        sheet[r * th : (r + 1) * th, c * tw : (c + 1) * tw] = t
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(f".{out.name}.tmp.png")
    if not cv2.imwrite(str(tmp), sheet):
        msg = f"could not write contact sheet {out}"
        raise OSError(msg)
    os.replace(tmp, out)
    return out
