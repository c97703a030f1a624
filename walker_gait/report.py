"""Self-contained HTML gait report (``report.html``) of one processed session (issue 5).

:func:`write_report` renders the session's steps, gait events, tracked leg poses and the
summary into a single HTML file: inline CSS, figures rendered with matplotlib's Agg canvas
and embedded as base64 PNG, no scripts and no network resources, so the file can be mailed
or archived and opened anywhere.  Sections:

1. header: input file, processing metadata, what was detected;
2. summary table: clinical parameter names and units, left / right / both columns, the
   left/right ratio, and ground truth when given;
3. step length and step width per step and side (ground truth overlaid when given);
4. sagittal joint angles (hip flexion, knee flexion, ankle dorsiflexion) over time;
5. gait-cycle averages: the same angles time-normalised to 0-100 % of the gait cycle
   between consecutive heel strikes of each foot, mean ± 1 SD, mean toe-off marked;
6. heel and toe height above the floor over time with heel-strike / toe-off markers;
7. tracking quality (confidence and tracker status over time);
8. the table of steps.

Lengths are shown in centimetres and angles in degrees (the CSV files stay SI).  Empty
inputs and NaNs are handled: a section without data says so instead of failing.  The file
is written with :func:`walker_gait.io.outputs.atomic_write`.
"""

from __future__ import annotations

import base64
import html
import io
import math
import os
import time
import warnings
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Ellipse

from walker_gait import __version__
from walker_gait.core.gait import GaitConfig
from walker_gait.core.types import (
    HEEL,
    JOINT_NAMES,
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
from walker_gait.io.outputs import REPORT_HTML, atomic_write, summary_to_json

__all__ = ["SIDE_COLOURS", "footprint_chain", "gait_cycles", "estimate_floor_from_events", "write_report"]

DPI = 80
"""Resolution of the embedded figures (pixels per inch); figures are ~11 in wide."""

SIDE_COLOURS: dict[Side, str] = {Side.LEFT: "#c62828", Side.RIGHT: "#1565c0"}
"""Left = red, right = blue (gait-lab convention; distinguishable with red-green colour blindness)."""

_SIDE_MARKERS: dict[Side, str] = {Side.LEFT: "o", Side.RIGHT: "s"}
_FOOT_LENGTH_M = 0.25  # the footprint drawn on the walkway map (a shoe, heel at the footfall)
_FOOT_WIDTH_M = 0.09
_WALKWAY_ROW_M = 4.0  # m of walkway per row of the footprint map (at equal scale)
_WALKWAY_ROWS = 6  # rows drawn at most (a longer walk shows its first 24 m)

_SAGITTAL: tuple[tuple[str, str], ...] = (
    ("hip_flexion", "Hip flexion (+) / extension (−)"),
    ("knee_flexion", "Knee flexion"),
    ("ankle_flexion", "Ankle dorsiflexion (+) / plantarflexion (−)"),
)
"""Joint angles plotted: JOINT_NAMES suffix, clinical label (all in degrees)."""

CYCLE_MIN_S = 0.3
"""Shortest heel-strike to heel-strike interval accepted as a gait cycle (s)."""
CYCLE_MAX_S = 6.0
"""Longest heel-strike to heel-strike interval accepted as a gait cycle (s) - walker users are slow."""


# --------------------------------------------------------------------------------------------
# Data helpers
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, kw_only=True)
class _GtStep:
    stamp: float
    side: Side
    step_length: float
    step_width: float


def _side_of(value: Any) -> Side:
    if isinstance(value, str):
        return Side[value.strip().upper()]
    return Side(int(value))


def _gt_steps(ground_truth: Mapping[str, Any] | None) -> list[_GtStep]:
    """Ground-truth steps from ``ground_truth["steps"]`` (Step objects or mappings)."""
    if not ground_truth:
        return []
    out: list[_GtStep] = []
    for item in ground_truth.get("steps") or ():
        if isinstance(item, Step):
            out.append(_GtStep(stamp=item.stamp, side=Side(item.side),
                               step_length=item.step_length, step_width=item.step_width))
            continue
        if not isinstance(item, Mapping):
            msg = f"ground_truth['steps'] items must be Step objects or mappings, got {type(item).__name__}"
            raise TypeError(msg)
        stamp = item.get("stamp", item.get("time"))
        side = item.get("side", item.get("foot"))
        if stamp is None or side is None:
            msg = f"ground-truth step needs 'stamp'/'time' and 'side'/'foot': {dict(item)!r}"
            raise ValueError(msg)
        out.append(
            _GtStep(
                stamp=float(stamp),
                side=_side_of(side),
                step_length=_num(item.get("step_length")),
                step_width=_num(item.get("step_width")),
            )
        )
    return out


def _num(value: Any) -> float:
    if value is None:
        return math.nan
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def _joint_index(side: Side, suffix: str) -> int:
    return JOINT_NAMES.index(f"{side.label}_{suffix}")


def _pose_arrays(poses: Sequence[LegPose]) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, np.ndarray]:
    """Stamps (N,), points (N,2,5,3), angles (N,12), confidence (N,), status (N,) sorted by time."""
    if not poses:
        return (np.zeros(0), np.zeros((0, 2, 5, 3)), np.zeros((0, len(JOINT_NAMES))), np.zeros(0),
                np.zeros(0, dtype=int))
    stamps = np.array([p.stamp for p in poses], dtype=np.float64)
    points = np.stack([np.asarray(p.points, dtype=np.float64).reshape(2, 5, 3) for p in poses])
    angles = np.stack([np.asarray(p.angles, dtype=np.float64).reshape(len(JOINT_NAMES)) for p in poses])
    conf = np.array([p.confidence for p in poses], dtype=np.float64)
    status = np.array([int(p.status) for p in poses], dtype=int)
    order = np.argsort(stamps, kind="stable")
    return stamps[order], points[order], angles[order], conf[order], status[order]


def _heel_strikes(events: Sequence[GaitEvent], steps: Sequence[Step], side: Side) -> FloatArray:
    """Sorted heel-strike times of ``side``: from the events, else from the steps."""
    hs = [e.stamp for e in events if e.kind == EventKind.HEEL_STRIKE and e.side == side]
    if not hs and not any(e.kind == EventKind.HEEL_STRIKE for e in events):
        hs = [s.stamp for s in steps if s.side == side]
    arr = np.array(hs, dtype=np.float64)
    arr = arr[np.isfinite(arr)]
    return np.unique(arr)


def gait_cycles(
    stamps: FloatArray,
    values: FloatArray,
    heel_strikes: FloatArray,
    *,
    n_points: int = 101,
    min_duration: float = CYCLE_MIN_S,
    max_duration: float = CYCLE_MAX_S,
) -> tuple[FloatArray, FloatArray]:
    """Time-normalise ``values`` to 0-100 % of each gait cycle.

    A cycle runs from one heel strike to the next of the same foot.  It is used only when
    its duration is within ``[min_duration, max_duration]`` and the finite samples of
    ``values`` cover it: at least 5 samples, the first and last within 10 % of the cycle of
    its ends, and no gap longer than 20 % of the cycle.

    Args:
        stamps: (N,) sample times, increasing.
        values: (N,) samples (NaN = missing).
        heel_strikes: sorted heel-strike times of one foot.
        n_points: samples per normalised cycle (101 gives 0, 1, ..., 100 %).

    Returns:
        ``(cycles (C, n_points), bounds (C, 2) [start, end] times)``; ``C`` may be 0.
    """
    pct = np.linspace(0.0, 1.0, n_points)
    ok = np.isfinite(stamps) & np.isfinite(values)
    t, v = stamps[ok], values[ok]
    cycles: list[FloatArray] = []
    bounds: list[tuple[float, float]] = []
    for a, b in zip(heel_strikes[:-1], heel_strikes[1:], strict=True):
        dur = b - a
        if not (min_duration <= dur <= max_duration):
            continue
        tol = 0.1 * dur
        sel = (t >= a - tol) & (t <= b + tol)
        if np.count_nonzero(sel) < 5:
            continue
        ts = t[sel]
        if ts[0] > a + tol or ts[-1] < b - tol:
            continue
        inner = ts[(ts >= a) & (ts <= b)]
        edges = np.concatenate([[a], inner, [b]])
        if np.max(np.diff(edges)) > 0.2 * dur + 1e-9:
            continue
        cycles.append(np.interp(a + pct * dur, ts, v[sel]))
        bounds.append((float(a), float(b)))
    if not cycles:
        return np.zeros((0, n_points)), np.zeros((0, 2))
    return np.stack(cycles), np.array(bounds)


def estimate_floor_from_events(events: Sequence[GaitEvent]) -> FloorPlane | None:
    """Least-squares floor plane through the heel-strike / toe-off positions, or ``None``.

    Heels at heel strike and toes at toe off touch the floor, so when both feet have events
    the positions span the floor.  Returns ``None`` when there are fewer than 4 finite
    positions, they are (nearly) collinear (spread < 3 cm across the second principal
    direction) or the fitted normal is implausible (not within ~70° of the camera's up, -y).
    """
    pos = np.array([np.asarray(e.position, dtype=np.float64).reshape(3) for e in events]).reshape(-1, 3)
    pos = pos[np.all(np.isfinite(pos), axis=1)]
    if len(pos) < 4:
        return None
    centre = pos.mean(axis=0)
    _, sing, vt = np.linalg.svd(pos - centre, full_matrices=False)
    if sing[1] / math.sqrt(len(pos)) < 0.03:
        return None
    normal = vt[2]
    offset = -float(normal @ centre)
    if offset < 0:  # orient "up": the camera (origin) is above the floor
        normal, offset = -normal, -offset
    if normal @ np.array([0.0, -1.0, 0.0]) < 0.35:
        return None
    return FloorPlane(normal=normal, offset=offset, valid=True)


# --------------------------------------------------------------------------------------------
# Formatting helpers
# --------------------------------------------------------------------------------------------


def _esc(value: Any) -> str:
    return html.escape(str(value), quote=True)


def _fmt(value: Any, decimals: int = 2, *, scale: float = 1.0) -> str:
    """Number for a table cell; NaN / None / non-numbers -> an em dash."""
    if value is None or isinstance(value, bool):
        return "—"
    try:
        v = float(value) * scale
    except (TypeError, ValueError):
        return _esc(value)
    if not math.isfinite(v):
        return "—"
    return f"{v:.{decimals}f}"


def _figure(width: float, height: float) -> Figure:
    fig = Figure(figsize=(width, height), dpi=DPI, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _png_b64(fig: Figure) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI)
    fig.clear()
    return base64.b64encode(buf.getvalue()).decode("ascii")


def _img(b64: str, alt: str) -> str:
    return f'<img src="data:image/png;base64,{b64}" alt="{_esc(alt)}">'


def _empty(message: str) -> str:
    return f'<p class="empty">{_esc(message)}</p>'


def _top_legend(ax: Any, *, extra_axes: Sequence[Any] = ()) -> None:
    """One legend above ``ax`` (outside the data) with the unique entries of ``ax`` and ``extra_axes``."""
    seen: dict[str, Any] = {}
    for a in (ax, *extra_axes):
        for handle, label in zip(*a.get_legend_handles_labels(), strict=True):
            seen.setdefault(label, handle)
    if seen:
        ax.legend(list(seen.values()), list(seen.keys()), loc="lower right", bbox_to_anchor=(1.0, 1.0),
                  ncol=min(6, len(seen)), fontsize=8, frameon=False, borderaxespad=0.2)


@dataclass(frozen=True)
class Footfall:
    """One footfall of :func:`footprint_chain`: the heel's place on a straightened walkway (m)."""

    side: Side
    along: float  # along the walking direction, from the run's first footfall
    across: float  # across it, towards the user's left
    confidence: float  # the step's (nan for a run's first, trailing, footfall)


def footprint_chain(steps: Sequence[Step]) -> list[list[Footfall]]:
    """Footfalls rebuilt from ``steps`` (time order) as a walkway would show them: each step puts its foot
    ``step_length`` ahead of the other foot's last footfall and ``step_width`` to its own side (the user's left
    for the left foot).  A run starts with the first step's trailing foot at (0, 0) and breaks at a step whose
    length or width is unknown; the next run starts where the last one ended, so the runs follow each other."""
    runs: list[list[Footfall]] = []
    last: dict[Side, Footfall] = {}
    start = 0.0
    for s in sorted(steps, key=lambda s: (s.stamp, s.index)):
        if not (math.isfinite(s.step_length) and math.isfinite(s.step_width)):
            if last:
                start = max(f.along for f in last.values()) + 0.3
            last = {}
            continue
        other = Side.RIGHT if s.side == Side.LEFT else Side.LEFT
        lateral = 1.0 if s.side == Side.LEFT else -1.0
        if other not in last:
            last = {other: Footfall(other, start, -lateral * s.step_width / 2.0, math.nan)}
            runs.append([last[other]])
        base = last[other]
        foot = Footfall(s.side, base.along + s.step_length, base.across + lateral * s.step_width, s.confidence)
        last[s.side] = foot
        runs[-1].append(foot)
    return runs


# --------------------------------------------------------------------------------------------
# Figures
# --------------------------------------------------------------------------------------------


def _fig_steps(steps: Sequence[Step], gt: Sequence[_GtStep], t0: float) -> str:
    fig = _figure(11, 5.2)
    axes = fig.subplots(2, 1, sharex=True)
    for ax, attr, label in ((axes[0], "step_length", "Step length (cm)"),
                            (axes[1], "step_width", "Step width (cm)")):
        for side in Side:
            mine = [s for s in steps if s.side == side]
            if mine:
                t = np.array([s.stamp for s in mine]) - t0
                v = np.array([getattr(s, attr) for s in mine], dtype=np.float64) * 100.0
                ax.plot(t, v, color=SIDE_COLOURS[side], marker=_SIDE_MARKERS[side], ms=5, lw=1.2,
                        label=f"{side.label}")
            truth = [g for g in gt if g.side == side]
            if truth:
                t = np.array([g.stamp for g in truth]) - t0
                v = np.array([getattr(g, attr) for g in truth], dtype=np.float64) * 100.0
                ax.plot(t, v, color=SIDE_COLOURS[side], marker=_SIDE_MARKERS[side], ms=7, lw=0.8,
                        ls=":", mfc="none", label=f"{side.label} – ground truth")
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    _top_legend(axes[0])
    axes[1].set_xlabel("time (s, heel-strike time from start of recording)")
    return _png_b64(fig)


def _fig_footprints(runs: Sequence[Sequence[Footfall]]) -> tuple[str, float, float]:
    """The footprint map (PNG, base64) in rows of ``_WALKWAY_ROW_M`` at equal scale, at most ``_WALKWAY_ROWS`` of them,
    the length of walkway shown and the whole walk's (m).  Steps below the summaries' confidence are drawn hollow."""
    min_confidence = GaitConfig.summary_min_confidence
    feet = [f for run in runs for f in run]
    a0 = min(f.along for f in feet)
    a1 = max(f.along for f in feet)
    n_rows = min(_WALKWAY_ROWS, int((a1 - a0) // _WALKWAY_ROW_M) + 1)
    lo = min(f.across for f in feet) - 0.12
    hi = max(f.across for f in feet) + 0.12
    row_h = 11.0 * (hi - lo) / (_WALKWAY_ROW_M + 0.4) + 0.35
    fig = _figure(11, min(row_h * n_rows + 0.6, 12.0))
    axes = fig.subplots(n_rows, 1, squeeze=False)[:, 0]
    for r, ax in enumerate(axes):
        x0 = a0 + r * _WALKWAY_ROW_M
        for f in feet:
            if not x0 <= f.along < x0 + _WALKWAY_ROW_M:
                continue
            doubted = not (f.confidence >= min_confidence)  # nan (a run's first footfall) counts as doubted
            ax.add_patch(Ellipse((f.along + _FOOT_LENGTH_M / 2, f.across), _FOOT_LENGTH_M, _FOOT_WIDTH_M,
                                 facecolor="none" if doubted else SIDE_COLOURS[f.side], alpha=1.0 if doubted else 0.6,
                                 edgecolor=SIDE_COLOURS[f.side], lw=1.0, ls="--" if doubted else "-"))
            ax.plot([f.along], [f.across], marker="|", color="black", ms=6)
        ax.set_xlim(x0 - 0.1, x0 + _WALKWAY_ROW_M + 0.3)
        ax.set_ylim(lo, hi)
        ax.set_aspect("equal")
        ax.grid(True, alpha=0.3)
        ax.set_ylabel("across (m)", fontsize=8)
        ax.tick_params(labelsize=8)
    axes[-1].set_xlabel("along the walking direction (m)")
    handles = [Line2D([], [], color=SIDE_COLOURS[side], marker="o", ls="", ms=8, alpha=0.6, label=side.label)
               for side in Side]
    handles.append(Line2D([], [], color="grey", marker="o", ls="", ms=8, mfc="none", label="doubted / first"))
    axes[0].legend(handles=handles, loc="lower right", bbox_to_anchor=(1.0, 1.0), ncol=3, fontsize=8, frameon=False)
    return _png_b64(fig), min(a1 - a0, n_rows * _WALKWAY_ROW_M), a1 - a0


def _fig_joint_angles(stamps: FloatArray, angles: FloatArray, t0: float) -> str:
    fig = _figure(11, 6.6)
    axes = fig.subplots(len(_SAGITTAL), 1, sharex=True)
    t = stamps - t0
    for ax, (suffix, label) in zip(axes, _SAGITTAL, strict=True):
        for side in Side:
            ax.plot(t, np.degrees(angles[:, _joint_index(side, suffix)]), color=SIDE_COLOURS[side],
                    lw=1.1, label=side.label)
        ax.set_ylabel(f"{label} (°)", fontsize=9)
        ax.axhline(0.0, color="0.6", lw=0.6)
        ax.grid(True, alpha=0.3)
    _top_legend(axes[0])
    axes[-1].set_xlabel("time (s from start of recording)")
    return _png_b64(fig)


def _fig_cycle_average(
    stamps: FloatArray,
    angles: FloatArray,
    hs: Mapping[Side, FloatArray],
    events: Sequence[GaitEvent],
) -> tuple[str | None, dict[Side, int]]:
    """Gait-cycle average figure (None when no side has a usable cycle) and cycles per side."""
    pct = np.linspace(0.0, 100.0, 101)
    data: dict[tuple[Side, str], FloatArray] = {}
    counts: dict[Side, int] = {}
    toe_off_pct: dict[Side, float] = {}
    for side in Side:
        n_side = 0
        all_bounds: list[FloatArray] = []
        for suffix, _ in _SAGITTAL:
            cyc, bounds = gait_cycles(stamps, np.degrees(angles[:, _joint_index(side, suffix)]), hs[side])
            data[(side, suffix)] = cyc
            n_side = max(n_side, len(cyc))
            if len(bounds):
                all_bounds.append(bounds)
        counts[side] = n_side
        # mean toe-off as % of the cycle, over the cycles that have a toe off of this foot
        to_times = np.array([e.stamp for e in events if e.kind == EventKind.TOE_OFF and e.side == side])
        pcts: list[float] = []
        if all_bounds and len(to_times):
            for a, b in np.unique(np.concatenate(all_bounds), axis=0):
                inside = to_times[(to_times > a) & (to_times < b)]
                if len(inside):
                    pcts.append(100.0 * (inside[0] - a) / (b - a))
        if pcts:
            toe_off_pct[side] = float(np.mean(pcts))
    if not any(counts.values()):
        return None, counts
    fig = _figure(11, 3.6)
    axes = fig.subplots(1, len(_SAGITTAL))
    for ax, (suffix, label) in zip(axes, _SAGITTAL, strict=True):
        for side in Side:
            cyc = data[(side, suffix)]
            if not len(cyc):
                continue
            colour = SIDE_COLOURS[side]
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                mean = np.nanmean(cyc, axis=0)
                sd = np.nanstd(cyc, axis=0) if len(cyc) > 1 else np.zeros_like(mean)
            ax.fill_between(pct, mean - sd, mean + sd, color=colour, alpha=0.18, lw=0)
            ax.plot(pct, mean, color=colour, lw=1.6, label=f"{side.label} (n={len(cyc)})")
            if side in toe_off_pct:
                ax.axvline(toe_off_pct[side], color=colour, ls="--", lw=1.0)
        ax.set_title(label, fontsize=10)
        ax.set_xlabel("% gait cycle (heel strike to heel strike)")
        ax.set_xlim(0, 100)
        ax.axhline(0.0, color="0.6", lw=0.6)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8, frameon=False, loc="best", handlelength=1.5)
    axes[0].set_ylabel("angle (°), mean ± 1 SD")
    return _png_b64(fig), counts


def _fig_foot_heights(
    stamps: FloatArray,
    points: FloatArray,
    events: Sequence[GaitEvent],
    floor: FloorPlane | None,
    t0: float,
) -> str:
    fig = _figure(11, 5.4)
    axes = fig.subplots(2, 1, sharex=True, sharey=True)
    t = stamps - t0
    if floor is not None:
        heights = floor.height(points) * 100.0  # (N, 2, 5) cm
        ylabel = "height above floor (cm)"
    else:  # camera -y, relative to the lowest heel/toe sample: approximate when the camera is pitched
        rel = -points[..., 1]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            base = np.nanmin(rel[:, :, [HEEL, TOE]]) if np.isfinite(rel[:, :, [HEEL, TOE]]).any() else 0.0
        heights = (rel - base) * 100.0
        ylabel = "height, relative (cm)"
    for ax, side in zip(axes, Side, strict=True):
        colour = SIDE_COLOURS[side]
        ax.plot(t, heights[:, side, HEEL], color=colour, lw=1.3, label="heel")
        ax.plot(t, heights[:, side, TOE], color=colour, lw=1.0, ls="--", alpha=0.8, label="toe")
        for kind, point, marker, name in ((EventKind.HEEL_STRIKE, HEEL, "v", "heel strike"),
                                          (EventKind.TOE_OFF, TOE, "^", "toe off")):
            ev_t = np.array([e.stamp for e in events if e.side == side and e.kind == kind], dtype=np.float64)
            if not len(ev_t):
                continue
            ax.vlines(ev_t - t0, 0.0, 1.0, transform=ax.get_xaxis_transform(), colors="0.55", lw=0.7,
                      linestyles="solid" if kind == EventKind.HEEL_STRIKE else "dotted")
            if len(t):
                y = np.interp(ev_t - t0, t, heights[:, side, point], left=np.nan, right=np.nan)
                ax.plot(ev_t - t0, y, ls="none", marker=marker, ms=7, color="k", label=name)
        ax.set_ylabel(f"{side.label.capitalize()} foot\n{ylabel}", fontsize=9)
        ax.grid(True, alpha=0.3)
    proxies = [Line2D([], [], color="0.2", lw=1.3, label="heel"),
               Line2D([], [], color="0.2", lw=1.0, ls="--", label="toe"),
               Line2D([], [], color="k", ls="none", marker="v", ms=7, label="heel strike"),
               Line2D([], [], color="k", ls="none", marker="^", ms=7, label="toe off")]
    axes[0].legend(handles=proxies, loc="lower right", bbox_to_anchor=(1.0, 1.0), ncol=4, fontsize=8,
                   frameon=False, borderaxespad=0.2)
    axes[-1].set_xlabel("time (s from start of recording)")
    return _png_b64(fig)


_STATUS_COLOURS = {
    TrackStatus.NO_USER: "#9e9e9e",
    TrackStatus.SEARCHING: "#ef6c00",
    TrackStatus.TRACKING: "#2e7d32",
    TrackStatus.DEGRADED: "#f9a825",
}


def _fig_quality(stamps: FloatArray, conf: FloatArray, status: np.ndarray, t0: float) -> str:
    """Confidence over time with the tracker status as a coloured band (needs at least one pose)."""
    fig = _figure(11, 2.4)
    ax = fig.subplots(1, 1)
    t = stamps - t0
    # status as a band of runs of equal status (one rectangle per run, not per frame); a run also
    # ends at a gap of more than 3 frame intervals, so that dropped frames show as a gap
    dt = np.diff(t)
    frame_dt = float(np.median(dt)) if len(dt) else 1.0 / 30.0
    gap = dt > 3.0 * frame_dt
    ends = np.append(np.where(gap, t[:-1] + frame_dt, t[1:]), t[-1] + frame_dt)
    change = np.flatnonzero((np.diff(status) != 0) | gap) + 1
    starts_idx = np.concatenate([[0], change]).astype(int)
    stops_idx = np.concatenate([change, [len(status)]]).astype(int)
    for st, colour in _STATUS_COLOURS.items():
        runs = [(t[a], ends[b - 1] - t[a]) for a, b in zip(starts_idx, stops_idx, strict=True)
                if status[a] == int(st)]
        if runs:
            ax.broken_barh(runs, (-0.12, 0.08), facecolors=colour, lw=0,
                           label=st.name.lower().replace("_", " "))
    ax.plot(t, conf, color="k", lw=1.0, label="confidence")
    ax.set_ylim(-0.15, 1.05)
    ax.set_ylabel("confidence (0–1)", fontsize=9)
    ax.set_xlabel("time (s from start of recording)  ·  coloured band: tracker status")
    ax.grid(True, alpha=0.3)
    _top_legend(ax)
    return _png_b64(fig)


# --------------------------------------------------------------------------------------------
# HTML sections
# --------------------------------------------------------------------------------------------

# (label, unit, display scale, decimals, left key, right key, both key); keys are summary.json keys.
_SUMMARY_ROWS: tuple[tuple[str, str, float, int, str | None, str | None, str | None], ...] = (
    ("Steps", "count", 1.0, 0, None, None, "step_count"),
    ("Walking time analysed", "s", 1.0, 1, None, None, "duration_s"),
    ("Cadence", "steps/min", 1.0, 1, None, None, "cadence_steps_per_min"),
    ("Gait speed", "m/s", 1.0, 2, None, None, "gait_speed_m_per_s"),
    ("Step length, mean", "cm", 100.0, 1, "step_length_mean_left_m", "step_length_mean_right_m",
     "step_length_mean_m"),
    ("Step length, SD", "cm", 100.0, 1, "step_length_sd_left_m", "step_length_sd_right_m", None),
    ("Step length, CV", "%", 1.0, 1, "step_length_cv_left_percent", "step_length_cv_right_percent", None),
    ("Step width, mean", "cm", 100.0, 1, "step_width_mean_left_m", "step_width_mean_right_m",
     "step_width_mean_m"),
    ("Step width, SD", "cm", 100.0, 1, "step_width_sd_left_m", "step_width_sd_right_m", None),
    ("Step width, CV", "%", 1.0, 1, "step_width_cv_left_percent", "step_width_cv_right_percent", None),
    ("Step time, mean", "s", 1.0, 3, "step_time_mean_left_s", "step_time_mean_right_s", "step_time_mean_s"),
    ("Step time, SD", "s", 1.0, 3, "step_time_sd_left_s", "step_time_sd_right_s", None),
    ("Step time, CV", "%", 1.0, 1, "step_time_cv_left_percent", "step_time_cv_right_percent", None),
    ("Stance", "% gait cycle", 1.0, 1, "stance_left_percent", "stance_right_percent", None),
    ("Swing", "% gait cycle", 1.0, 1, "swing_left_percent", "swing_right_percent", None),
    ("Double support", "% gait cycle", 1.0, 1, None, None, "double_support_percent"),
    ("Step length symmetry", "ratio L/R", 1.0, 2, None, None, "step_length_symmetry_ratio"),
    ("Swing time symmetry", "ratio L/R", 1.0, 2, None, None, "swing_time_symmetry_ratio"),
    ("Mean step confidence", "0–1", 1.0, 2, None, None, "mean_confidence"),
)

# rows whose left/right ratio is shown in the "L/R" column
_RATIO_ROWS = {"Step length, mean", "Step width, mean", "Step time, mean", "Stance", "Swing"}


def _ratio(left: Any, right: Any) -> float:
    lv, rv = _num(left), _num(right)
    if not (math.isfinite(lv) and math.isfinite(rv)) or rv == 0.0:
        return math.nan
    return lv / rv


def _summary_table(summary: Mapping[str, Any], gt_summary: Mapping[str, Any] | None) -> str:
    has_gt = gt_summary is not None
    head = ["Parameter", "Unit", "Left", "Right", "Both", "L/R"]
    if has_gt:
        head += ["Truth left", "Truth right", "Truth both"]
    rows = ["<tr>" + "".join(f"<th>{_esc(h)}</th>" for h in head) + "</tr>"]
    for label, unit, scale, dec, lk, rk, bk in _SUMMARY_ROWS:
        def cell(src: Mapping[str, Any], key: str | None, scale: float = scale, dec: int = dec) -> str:
            return _fmt(src.get(key), dec, scale=scale) if key else ""
        ratio = _fmt(_ratio(summary.get(lk), summary.get(rk)), 2) if label in _RATIO_ROWS and lk and rk else ""
        cells = [f'<th scope="row">{_esc(label)}</th>', f'<td class="unit">{_esc(unit)}</td>',
                 f'<td class="left">{cell(summary, lk)}</td>', f'<td class="right">{cell(summary, rk)}</td>',
                 f"<td>{cell(summary, bk)}</td>", f"<td>{ratio}</td>"]
        if gt_summary is not None:
            cells += [f'<td class="gt">{cell(gt_summary, lk)}</td>', f'<td class="gt">{cell(gt_summary, rk)}</td>',
                      f'<td class="gt">{cell(gt_summary, bk)}</td>']
        rows.append("<tr>" + "".join(cells) + "</tr>")
    return '<table class="summary">' + "".join(rows) + "</table>"


_STEP_TABLE_COLS: tuple[tuple[str, str, float, int], ...] = (
    ("step_length", "Step length (cm)", 100.0, 1),
    ("step_width", "Step width (cm)", 100.0, 1),
    ("step_time", "Step time (s)", 1.0, 3),
    ("stride_length", "Stride length (cm)", 100.0, 1),
    ("stride_time", "Stride time (s)", 1.0, 3),
    ("stance_time", "Stance (s)", 1.0, 3),
    ("swing_time", "Swing (s)", 1.0, 3),
    ("single_support_time", "Single support (s)", 1.0, 3),
    ("double_support_time", "Double support (s)", 1.0, 3),
    ("confidence", "Confidence", 1.0, 2),
)


def _steps_table(steps: Sequence[Step], t0: float) -> str:
    head = ["#", "Time (s)", "Foot"] + [h for _, h, _, _ in _STEP_TABLE_COLS]
    rows = ["<tr>" + "".join(f"<th>{_esc(h)}</th>" for h in head) + "</tr>"]
    for s in steps:
        side = Side(s.side)
        cells = [f"<td>{int(s.index)}</td>", f"<td>{_fmt(s.stamp - t0, 2)}</td>", f"<td>{side.label}</td>"]
        cells += [f"<td>{_fmt(getattr(s, attr), dec, scale=scale)}</td>" for attr, _, scale, dec in _STEP_TABLE_COLS]
        rows.append(f'<tr class="{side.label}">' + "".join(cells) + "</tr>")
    table = '<table class="steps">' + "".join(rows) + "</table>"
    if len(steps) > 60:
        return f"<details><summary>Show all {len(steps)} steps</summary>{table}</details>"
    return table


_META_LABELS: tuple[tuple[str, str], ...] = (
    ("input_file", "Input recording"),
    ("preset", "Tracker preset"),
    ("seed", "Random seed"),
    ("passes", "Tracking passes"),
    ("frames_processed", "Frames processed"),
    ("frames_from_backward_pass", "Frames from the backward pass"),
    ("steps_unconfirmed", "Steps the two passes did not confirm"),
    ("frames_legs_exchanged_back", "Frames whose legs a pass had exchanged (taken back)"),
    ("report_pelvis_window_s", "Hips placed over the feet, window (s; 0 = as tracked)"),
    ("leg_length_m", "Leg length given (m)"),
    ("reported_segment_lengths_m", "Reported lengths (m, median): thigh, calf, shoe; hip height"),
    ("frames_skipped_total", "Frames skipped"),
    ("processing_time_s", "Processing time (s)"),
    ("walker_gait_version", "walker_gait version"),
    ("created_utc", "Processed (UTC)"),
)


def _metadata_table(metadata: Mapping[str, Any], extra_rows: Sequence[tuple[str, str]]) -> str:
    rows: list[tuple[str, str]] = []
    shown = set()
    for key, label in _META_LABELS:
        if key not in metadata and key != "walker_gait_version":
            continue
        value = metadata.get(key, __version__ if key == "walker_gait_version" else None)
        shown.add(key)
        if key == "processing_time_s":
            rows.append((label, _fmt(value, 1)))
        elif key == "reported_segment_lengths_m" and isinstance(value, Mapping):
            hem = " (under a trouser hem: at least the typical adult's)" if value.get("foot_under_hem") else ""
            rows.append((label, ", ".join(_fmt(value.get(k), 3) for k in ("thigh", "calf", "foot"))
                         + f"{hem}; {_fmt(value.get('leg'), 3)}"))
        elif value is None:
            rows.append((label, "—"))
        else:
            rows.append((label, _esc(value)))
    skipped = metadata.get("frames_skipped")
    shown.add("frames_skipped")
    if isinstance(skipped, Mapping) and skipped:
        if "frames_skipped_total" not in metadata:
            rows.append(("Frames skipped", _esc(sum(int(v) for v in skipped.values()))))
        reasons = ", ".join(f"{_esc(k)}: {_esc(v)}" for k, v in skipped.items())
        rows.append(("Skipped, by reason", reasons))
    for key, value in metadata.items():
        if key in shown:
            continue
        text = _fmt(value, 3) if isinstance(value, float) else _esc(value)
        rows.append((_esc(key.replace("_", " ")), text))
    rows.extend(extra_rows)
    return '<table class="meta">' + "".join(f"<tr><th>{k}</th><td>{v}</td></tr>" for k, v in rows) + "</table>"


_CSS = """
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,Helvetica,Arial,sans-serif;margin:0;
 color:#1b1b1b;background:#fafafa;line-height:1.4}
main{max-width:1000px;margin:0 auto;padding:16px 24px 48px;background:#fff}
h1{font-size:1.6em;margin:0.4em 0 0.1em}
h2{font-size:1.2em;border-bottom:2px solid #e0e0e0;padding-bottom:3px;margin-top:1.8em}
p.sub{color:#555;margin-top:0}
nav{font-size:0.9em;margin:0.6em 0 1em}
nav a{margin-right:1em;color:#1565c0;text-decoration:none}
table{border-collapse:collapse;font-size:0.9em;font-variant-numeric:tabular-nums}
th,td{padding:3px 9px;border-bottom:1px solid #e6e6e6;text-align:right}
th{background:#f2f2f2}
table.meta th,table.meta td,table.summary th[scope=row],table.summary th:first-child{text-align:left}
table.summary th[scope=row]{background:none;font-weight:600}
table.meta th{background:none;font-weight:600;padding-right:18px}
table.summary td.unit{text-align:left;color:#555}
table.summary td.left,table.summary th.left{color:#c62828}
table.summary td.right{color:#1565c0}
td.gt{color:#555;font-style:italic}
table.steps tr.left td:nth-child(3){color:#c62828;font-weight:600}
table.steps tr.right td:nth-child(3){color:#1565c0;font-weight:600}
table.steps tr:nth-child(even) td{background:#fafafa}
img{max-width:100%;height:auto;display:block;margin:6px 0}
p.empty{padding:10px 14px;background:#fff8e1;border-left:4px solid #f9a825}
p.note,div.note{font-size:0.85em;color:#555}
.key{display:inline-block;width:0.9em;height:0.9em;vertical-align:-0.1em;border-radius:2px}
@media print{body{background:#fff}main{max-width:none;padding:0}h2{break-after:avoid}
 img,table{break-inside:avoid}nav{display:none}}
"""


def _section(anchor: str, title: str, body: str) -> str:
    return f'<section id="{anchor}"><h2>{_esc(title)}</h2>{body}</section>'


def _draw(jobs: Mapping[str, tuple[Any, tuple[Any, ...]]], *, processes: int = 1) -> dict[str, Any]:
    """``{name: fn(*args)}`` for the figure ``jobs``; with ``processes`` >= 2 (and ``os.fork``) every other one of
    them is drawn in a forked child and sent back pickled, the rest here meanwhile (each figure is its own
    ``Figure``: nothing is shared).  A child that fails is not fatal: its figures are drawn here instead."""
    names = list(jobs)
    theirs = names[::2] if processes >= 2 and len(names) >= 2 and hasattr(os, "fork") else []
    if not theirs:
        return {k: fn(*args) for k, (fn, args) in jobs.items()}
    import pickle

    read_fd, write_fd = os.pipe()
    pid = os.fork()
    if pid == 0:  # pragma: no cover - the child (its coverage is not collected); tested through its results
        code = 1
        try:
            os.close(read_fd)
            with os.fdopen(write_fd, "wb") as fh:
                pickle.dump({k: jobs[k][0](*jobs[k][1]) for k in theirs}, fh, protocol=pickle.HIGHEST_PROTOCOL)
            code = 0
        finally:
            os._exit(code)
    os.close(write_fd)
    out = {k: jobs[k][0](*jobs[k][1]) for k in names if k not in theirs}
    with os.fdopen(read_fd, "rb") as fh:
        data = fh.read()
    _, status = os.waitpid(pid, 0)
    drawn: dict[str, Any] = {}
    if status == 0:
        try:
            drawn = pickle.loads(data)
        except Exception:  # noqa: BLE001 - drawn again below
            drawn = {}
    for k in theirs:
        out[k] = drawn[k] if k in drawn else jobs[k][0](*jobs[k][1])
    return {k: out[k] for k in names}


def write_report(
    path: str | os.PathLike[str],
    *,
    steps: Iterable[Step],
    events: Iterable[GaitEvent],
    poses: Iterable[LegPose],
    summary: Mapping[str, Any],
    metadata: Mapping[str, Any],
    ground_truth: Mapping[str, Any] | None = None,
    floor: FloorPlane | None = None,
    processes: int = 1,
) -> Path:
    """Write the self-contained HTML report of one session.

    Args:
        path: output file; when it is an existing directory, ``report.html`` is written in it.
        steps: detected steps (any order; shown in time order).
        events: heel strikes and toe offs.
        poses: tracked leg poses, one per processed frame.
        summary: session summary, GaitSummary field names (``GaitSummaryData.to_dict()``)
            or ``summary.json`` keys (see :func:`walker_gait.io.outputs.summary_to_json`).
        metadata: processing metadata as in ``summary.json`` (``input_file``, ``preset``,
            ``seed``, ``frames_processed``, ``frames_skipped`` {reason: count},
            ``processing_time_s``, ...); other keys are listed as they are.
        ground_truth: optional, for synthetic sessions: ``"steps"`` (Step objects or
            mappings with ``stamp``/``time``, ``side``/``foot``, ``step_length``,
            ``step_width``) is overlaid on the step plot; ``"summary"`` (same forms as
            ``summary``) adds "truth" columns to the summary table.  Other keys are ignored.
        floor: floor plane for the heel/toe height plot.  When ``None`` the floor is fitted
            to the event positions (:func:`estimate_floor_from_events`); failing that,
            heights are shown relative to the lowest foot sample along the camera's -y axis.
        processes: 2 draws half of the figures in a forked process (:func:`_draw`; where ``fork`` exists): about
            half a second less for a 10 s session where a second core is idle (``walker-gait process``).

    Returns:
        The path of the written report.
    """
    started = time.perf_counter()
    out = Path(path)
    if out.is_dir():
        out = out / REPORT_HTML
    steps_l = sorted(steps, key=lambda s: (s.stamp, s.index))
    events_l = sorted(events, key=lambda e: e.stamp)
    poses_l = list(poses)
    stamps, points, angles, conf, status = _pose_arrays(poses_l)
    gt_steps = _gt_steps(ground_truth)
    summ = summary_to_json(summary)
    gt_summary = summary_to_json(ground_truth["summary"]) if ground_truth and ground_truth.get("summary") else None

    all_t = np.concatenate([stamps, [s.stamp for s in steps_l], [e.stamp for e in events_l],
                            [g.stamp for g in gt_steps]]).astype(np.float64)
    all_t = all_t[np.isfinite(all_t)]
    t0 = float(all_t.min()) if len(all_t) else 0.0
    span = float(all_t.max() - t0) if len(all_t) else 0.0

    floor_note = ""
    if floor is None and len(stamps):
        floor = estimate_floor_from_events(events_l)
        if floor is None:
            floor_note = ("No floor plane was available, so heights are relative to the lowest heel/toe "
                          "position along the camera's vertical axis (approximate when the camera is tilted).")
        else:
            floor_note = "Floor plane fitted to the heel-strike and toe-off positions."

    n_hs = sum(1 for e in events_l if e.kind == EventKind.HEEL_STRIKE)
    n_to = len(events_l) - n_hs
    span_text = f"{span:.1f} s (time 0 = image stamp {t0:.3f} s)" if len(all_t) else "—"
    detected = [
        ("Recording span analysed", span_text),
        ("Detected", f"{len(poses_l)} leg poses, {n_hs} heel strikes, {n_to} toe offs, {len(steps_l)} steps"),
    ]

    # the figures (most of the time here), drawn first, in two processes where asked
    runs = footprint_chain(steps_l)
    have_angles = bool(len(stamps)) and bool(np.isfinite(angles).any())
    hs = {side: _heel_strikes(events_l, steps_l, side) for side in Side}
    jobs: dict[str, tuple[Any, tuple[Any, ...]]] = {}
    if have_angles:
        jobs["cycle"] = (_fig_cycle_average, (stamps, angles, hs, events_l))
        jobs["angles"] = (_fig_joint_angles, (stamps, angles, t0))
    if steps_l or gt_steps:
        jobs["steps"] = (_fig_steps, (steps_l, gt_steps, t0))
    if runs:
        jobs["footprints"] = (_fig_footprints, (runs,))
    if len(stamps):
        jobs["quality"] = (_fig_quality, (stamps, conf, status, t0))
        jobs["heights"] = (_fig_foot_heights, (stamps, points, events_l, floor, t0))
    figs = _draw(jobs, processes=processes)

    sections: list[str] = []
    # summary
    summ_body = _summary_table(summ, gt_summary)
    if not steps_l:
        summ_body = _empty("No steps detected: the summary parameters could not be computed.") + summ_body
    summ_body += ('<p class="note">Left/right: the foot whose heel strike ends the step. L/R = left ÷ right '
                  "(1.00 = symmetric). CV = 100 × SD / mean. — = not available.</p>")
    no_double = sum(1 for st in steps_l if not math.isfinite(st.double_support_time))
    if no_double:
        summ_body += (f'<p class="note">{no_double} of {len(steps_l)} steps have no double-support time (and '
                      "stance, swing and single support are unknown for some): a step's durations are left unknown "
                      "where the camera did not see the toe off that bounds them (the trailing foot hidden behind "
                      "the leading leg or under a trouser hem; timed from the tracker's model such toe offs were "
                      "50-100 ms off), and for the first steps after a start or a gap. The percentages above come "
                      "from the steps that have them (— where none has).</p>")
    sections.append(_section("summary", "Gait summary", summ_body))

    # steps figure
    if steps_l or gt_steps:
        body = _img(figs["steps"], "Step length and step width per step, left and right")
        if not steps_l:
            body = _empty("No steps detected (ground truth only).") + body
        body += ('<p class="note">Step length: distance along the walking direction between the two heels at '
                 "heel strike. Step width: distance between the heels across the walking direction. "
                 "Each point is one step, placed at its heel-strike time"
                 + ("; hollow markers / dotted lines: ground truth." if gt_steps else ".") + "</p>")
    else:
        body = _empty("No steps detected.")
    sections.append(_section("steps-plot", "Step length and width", body))

    # footprints
    if runs:
        b64, shown, total = figs["footprints"]
        body = _img(b64, "Footprints on a straightened walkway, left and right")
        if shown < total:
            body += f'<p class="note">The first {shown:.0f} m of {total:.0f} m are shown.</p>'
        body += ('<p class="note">Each footprint is placed from the steps, as a walkway mat shows them: a step '
                 "puts its foot one step length ahead of the other foot's last footprint and one step width to "
                 "its side (the walking direction straightened out; the tick marks the heel). Hollow, dashed: "
                 f"a step the analyzer doubts (confidence below {GaitConfig.summary_min_confidence:g}) or the first, "
                 "trailing foot of a run. A "
                 "step whose length or width is unknown breaks the chain.</p>")
    else:
        body = _empty("No steps with a known length and width: no footprints to draw.")
    sections.append(_section("footprints", "Footprints", body))

    # joint angles
    if have_angles:
        body = _img(figs["angles"], "Hip, knee and ankle sagittal angles over time")
    else:
        body = _empty("No leg poses were tracked." if not len(stamps) else "No joint angles available.")
    sections.append(_section("joint-angles", "Joint angles over time", body))

    # gait-cycle averages
    if have_angles:
        b64, counts = figs["cycle"]
    else:
        b64, counts = None, dict.fromkeys(Side, 0)
    if b64 is not None:
        body = _img(b64, "Joint angles averaged over the gait cycle")
        body += ('<p class="note">Each cycle runs from a heel strike to the next heel strike of the same foot '
                 f"and is time-normalised to 0–100 %. Cycles used: left {counts[Side.LEFT]}, right "
                 f"{counts[Side.RIGHT]} (cycles of {CYCLE_MIN_S:g}–{CYCLE_MAX_S:g} s with tracked angles "
                 "throughout). Line: mean; band: ± 1 SD; dashed vertical line: mean toe off.</p>")
    else:
        body = _empty("No complete gait cycle (two consecutive heel strikes of the same foot with tracked "
                      "joint angles in between) was found.")
    sections.append(_section("gait-cycle", "Gait-cycle averages", body))

    # foot heights
    if len(stamps):
        body = _img(figs["heights"], "Heel and toe height over time")
        body += ('<p class="note">Solid line: heel; dashed: toe. ▼ / solid vertical line: heel strike; '
                 f"▲ / dotted vertical line: toe off. {_esc(floor_note)}</p>")
    else:
        body = _empty("No leg poses were tracked.")
    sections.append(_section("foot-heights", "Heel and toe height", body))

    # tracking quality
    if len(stamps):
        body = _img(figs["quality"], "Tracking confidence and status over time")
        frac = {st: float(np.mean(status == int(st))) for st in TrackStatus}
        body += '<p class="note">Share of frames: ' + ", ".join(
            f'<span class="key" style="background:{_STATUS_COLOURS[st]}"></span> '
            f"{st.name.lower().replace('_', ' ')} {100 * frac[st]:.0f} %" for st in TrackStatus) + "</p>"
    else:
        body = _empty("No leg poses were tracked.")
    sections.append(_section("quality", "Tracking quality", body))

    # steps table
    if steps_l:
        body = _steps_table(steps_l, t0) + ('<p class="note">Time: heel-strike time in seconds from the start of '
                                            "the recording. Stride, stance, swing and support times refer to the "
                                            "gait cycle of the foot ending the step. — = not available.</p>")
    else:
        body = _empty("No steps detected.")
    sections.append(_section("steps-table", "Steps", body))

    nav = "".join(
        f'<a href="#{a}">{_esc(t)}</a>'
        for a, t in (("summary", "Summary"), ("steps-plot", "Steps"), ("footprints", "Footprints"),
                     ("joint-angles", "Joint angles"),
                     ("gait-cycle", "Gait cycle"), ("foot-heights", "Foot heights"), ("quality", "Quality"),
                     ("steps-table", "Step table"))
    )
    input_name = metadata.get("input_file")
    subtitle = f"Recording: {_esc(Path(str(input_name)).name)}" if input_name else "Recording: (not given)"
    render_s = time.perf_counter() - started
    doc = (
        "<!DOCTYPE html>\n"
        '<html lang="en"><head><meta charset="utf-8">'
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        f"<title>Gait report – {_esc(Path(str(input_name)).name if input_name else 'session')}</title>"
        f"<style>{_CSS}</style></head><body><main>"
        '<header id="header"><h1>Gait analysis report</h1>'
        f'<p class="sub">{subtitle}</p>'
        f"{_metadata_table(metadata, detected)}</header>"
        f"<nav>{nav}</nav>"
        + "".join(sections)
        + f'<footer><p class="note">Generated by walker_gait {_esc(__version__)} in {render_s:.1f} s. '
        "Lengths in cm, angles in degrees; the CSV and JSON outputs use SI units (m, s, rad). "
        "Positions are measured by a depth camera on the walker; values are estimates, check the "
        "tracking-quality section before relying on them.</p></footer>"
        "</main></body></html>\n"
    )
    with atomic_write(out, mode="w") as fh:
        fh.write(doc)
    return out
