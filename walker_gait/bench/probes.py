"""Probe battery: the pipeline on users, clothes, cameras and mounts unlike the bench's sessions.

``make bench`` scores nine scenarios as the synthetic generator samples them; ``make sweep`` scores many sessions of
the same scenarios.  Recordings from other subjects, trousers, cameras and mounts fall outside those samples.  Each
probe here is the ``normal`` scenario with a few of the generator's ranges moved (``SessionSpec`` overrides, as
``python -m walker_gait.bench.sweep --spec-override``): a tall user seen by a RealSense, a camera mounted high and
pitched steeply, dark trousers that return little depth, a walker that rocks on its wheels, a user who shuffles.
Every probe tracks the same session seeds, so a probe's row against the ``base`` row is the condition's effect.

Usage::

    python -m walker_gait.bench.probes                     # all probes -> PROBES.md (10-20 min on 2 cores)
    python -m walker_gait.bench.probes --probes base thin  # some of them
    python -m walker_gait.bench.probes --list              # what each probe varies
    python -m walker_gait.bench.probes --override '{"n_particles": 288}' --out out/probes_new --md out/probes_new.md
    python -m walker_gait.bench.probes --compare out/probes out/probes_new   # a tracker change, probe by probe

Each probe's sweep (``summary.json``, ``table.md``, ``runs.pkl``) is kept under ``--out``; ``--resume`` reuses a
probe whose kept sweep ran with the same settings.  The table is written atomically.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import sys
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = ["PROBES", "Probe", "format_comparison", "format_probes", "main", "probe_argv"]


@dataclass(frozen=True, kw_only=True)
class Probe:
    """One condition: ``SessionSpec`` overrides of the ``normal`` scenario (JSON-able: lists for ranges)."""

    name: str
    what: str  # what it varies, for the table
    spec: Mapping[str, Any] = field(default_factory=dict)


PROBES: tuple[Probe, ...] = (
    Probe(name="base", what="the `normal` scenario as sampled (the reference row)"),
    # users
    Probe(name="child", what="a small user: legs 0.78-0.86 of the average, thin, short steps",
          spec={"body_scale": [0.78, 0.86], "girth": [0.75, 0.85], "step_length": [0.32, 0.42]}),
    Probe(name="tallrs", what="a tall user (1.10-1.18) seen by a RealSense 424x240",
          spec={"body_scale": [1.1, 1.18], "camera": ["realsense_424x240"]}),
    Probe(name="heavy", what="thick legs (girth 1.20-1.35)", spec={"girth": [1.2, 1.35]}),
    Probe(name="thin", what="thin legs (girth 0.75-0.85)", spec={"girth": [0.75, 0.85]}),
    Probe(name="close", what="the user 0.62-0.72 m from the camera (0.78-0.95)", spec={"user_distance": [0.62, 0.72]}),
    Probe(name="far", what="the user 1.00-1.15 m from the camera (a longer walker frame)",
          spec={"user_distance": [1.0, 1.15]}),
    # gaits
    Probe(name="crouch", what="a crouched gait: knees bent 20-28 deg at least, slow, short steps",
          spec={"knee_min_flex_deg": [20, 28], "cadence": [80, 95], "step_length": [0.35, 0.45]}),
    Probe(name="hemi", what="an asymmetric gait: step lengths 25-35 % and step times 15-25 % unequal",
          spec={"asym_length": [0.25, 0.35], "asym_time": [0.15, 0.25]}),
    Probe(name="shuffle", what="a shuffle: 20-30 cm steps at 70-85 steps/min, toes 5-10 mm off the floor",
          spec={"step_length": [0.2, 0.3], "cadence": [70, 85], "toe_clearance": [0.005, 0.01]}),
    Probe(name="irregular", what="irregular steps: step time CV 8-12 %, length / width SD 4-6 / 3-5 cm",
          spec={"step_time_cv": [0.08, 0.12], "step_length_sd": [0.04, 0.06], "step_width_sd": [0.03, 0.05]}),
    Probe(name="fast", what="a brisk walk: 115-125 steps/min, 60-70 cm steps",
          spec={"cadence": [115, 125], "step_length": [0.6, 0.7]}),
    Probe(name="wide", what="a wide base: step width 16-22 cm", spec={"step_width": [0.16, 0.22]}),
    Probe(name="lag", what="a walker that lags 0.6-0.9 s behind its user (0.25-0.45)", spec={"walker_lag": [0.6, 0.9]}),
    # clothes
    Probe(name="kv2baggy", what="baggy trousers seen by a Kinect v2 512x424",
          spec={"camera": ["kinect_v2_512x424"], "clothing": ["baggy"]}),
    Probe(name="darkfabric", what="trousers that return no depth over 50-70 % of their area (dark, shiny fabric)",
          spec={"fabric_dropout": [0.5, 0.7]}),
    # cameras and mounts
    Probe(name="lowres", what="a 320x240 depth image", spec={"scale": 0.5}),
    Probe(name="fps15", what="15 frames a second", spec={"fps": 15}),
    Probe(name="highmount", what="the camera 0.66-0.74 m up, pitched down 40-48 deg (0.42-0.58 m, 22-38 deg)",
          spec={"cam_height": [0.66, 0.74], "cam_pitch_deg": [40, 48]}),
    Probe(name="lowmount", what="the camera 0.32-0.38 m up, pitched down 14-20 deg",
          spec={"cam_height": [0.32, 0.38], "cam_pitch_deg": [14, 20]}),
    Probe(name="roll", what="the camera rolled 7-10 deg", spec={"cam_roll_deg": [7, 10]}),
    Probe(name="yaw", what="the camera turned 5-8 deg", spec={"cam_yaw_deg": [5, 8]}),
    Probe(name="offmount", what="rolled, turned and 5-8 cm off the walker's centre line",
          spec={"cam_roll_deg": [-9, -6], "cam_yaw_deg": [-7, -4], "cam_lateral": [-0.08, -0.05]}),
    Probe(name="vibration", what="a walker that rocks on its wheels: camera tilt 0.8-1.5 deg RMS",
          spec={"vibration_deg": [0.8, 1.5]}),
)
"""The battery, ``base`` first.  Ranges outside the generator's defaults (``walker_gait.synth.SessionSpec``) by
design; each was run in a development session first (DEVELOPERS.md)."""

_COLUMNS: tuple[tuple[str, tuple[tuple[str, ...], ...], str], ...] = (
    ("heel cm", (("joint_err_cm", "heel"),), "{:.2f}"), ("toe cm", (("joint_err_cm", "toe"),), "{:.2f}"),
    ("ankle cm", (("joint_err_cm", "ankle"),), "{:.2f}"), ("knee cm", (("joint_err_cm", "knee"),), "{:.1f}"),
    ("hip cm", (("joint_err_cm", "hip"),), "{:.1f}"),
    ("frames > 10 cm at the walker %", (("frames_over_10cm_at_walker_pct",),), "{:.1f}"),
    ("swapped frames %", (("swapped_frames_pct",),), "{:.2f}"),
    ("steps matched / true (in view)", (("matched_in_view",), ("gt_steps_in_view",)), "{} / {}"),
    ("precision", (("precision",),), "{:.2f}"),
    ("step length MAE cm", (("step_length_mae_cm",),), "{:.2f}"),
    ("step width MAE cm (bias)", (("step_width_mae_cm",), ("step_width_bias_cm",)), "{:.2f} ({:+.2f})"),
    ("cadence err %", (("cadence_abs_err_pct",),), "{:.1f}"),
    ("gait speed err %", (("speed_abs_err_pct",),), "{:.1f}"),
    ("tracker ms/frame", (("tracker_ms",),), "{:.1f}"),
)
"""The table's columns: label, the figures' paths in a sweep's per-seed summary, their format."""


def _cell(summary: Mapping[str, Any], paths: tuple[tuple[str, ...], ...], fmt: str) -> str:
    vals = []
    for path in paths:
        v: Any = summary
        for key in path:
            v = v.get(key) if isinstance(v, Mapping) else None  # a sweep written before a figure existed lacks it
        if not isinstance(v, (int, float)) or v != v:  # missing or NaN
            return "n/a"
        vals.append(v)
    return fmt.format(*vals)


def format_probes(results: Mapping[str, Mapping[str, Any]], *, probes: Sequence[Probe] = PROBES) -> str:
    """Markdown table, one row per probe run: ``results`` maps a probe's name to its sweep's figures (one tracker
    seed's ``summary.json`` ``per_tracker_seed`` entry); probes without results are left out."""
    head = ["probe", "what it varies", *(c[0] for c in _COLUMNS)]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for p in probes:
        s = results.get(p.name)
        if s is None:
            continue
        lines.append("| " + " | ".join([p.name, p.what, *(_cell(s, paths, fmt) for _, paths, fmt in _COLUMNS)]) + " |")
    return "\n".join(lines)


_COMPARED = ("heel cm", "ankle cm", "knee cm", "frames > 10 cm at the walker %", "swapped frames %",
             "steps matched / true (in view)", "step length MAE cm", "step width MAE cm (bias)", "cadence err %")
"""The columns :func:`format_comparison` sets side by side."""


def format_comparison(before: Mapping[str, Mapping[str, Any]], after: Mapping[str, Mapping[str, Any]], *,
                      probes: Sequence[Probe] = PROBES) -> str:
    """Markdown table of two runs of the battery (each as :func:`format_probes` takes them), one row per probe run in
    both, each figure as ``before -> after``."""
    cols = [c for c in _COLUMNS if c[0] in _COMPARED]
    head = ["probe", *(c[0] for c in cols)]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for p in probes:
        b, a = before.get(p.name), after.get(p.name)
        if b is None or a is None:
            continue
        cells = [f"{_cell(b, paths, fmt)} -> {_cell(a, paths, fmt)}" for _, paths, fmt in cols]
        lines.append("| " + " | ".join([p.name, *cells]) + " |")
    return "\n".join(lines)


def _read_battery(out: Path, tracker_seed: int) -> dict[str, Mapping[str, Any]]:
    """The kept sweeps of a battery run under ``out`` (``NAME/summary.json``), one tracker seed's figures by probe."""
    res: dict[str, Mapping[str, Any]] = {}
    for p in PROBES:
        rep = _kept(out / p.name, {})  # whatever settings it ran with
        if rep is None:
            continue
        fig = rep.get("per_tracker_seed", {}).get(str(tracker_seed))
        if fig is not None:
            res[p.name] = fig
    return res


def probe_argv(probe: Probe, *, out: Path, per_probe: int, base_seed: int, tracker_seed: int, passes: str,
               jobs: int, cache: Path, duration: float, override: Mapping[str, Any] | None = None) -> list[str]:
    """The ``walker_gait.bench.sweep`` arguments of one probe's run (``override``: ``TrackerConfig`` fields of the
    ``default`` preset, as the sweep's ``--override``)."""
    return ["--scenarios", "normal", "--per-scenario", str(per_probe), "--base-seed", str(base_seed),
            "--tracker-seeds", str(tracker_seed), "--passes", passes, "--jobs", str(jobs), "--cache", str(cache),
            "--duration", f"{duration:g}", "--out", str(out / probe.name), "--spec-override", json.dumps(dict(probe.spec)),
            "--override", json.dumps(dict(override or {}))]


def _kept(path: Path, config: Mapping[str, Any]) -> Mapping[str, Any] | None:
    """A kept sweep's ``summary.json`` when it ran with ``config`` (the sweep's own record of its settings)."""
    try:
        rep = json.loads((path / "summary.json").read_text())
    except (OSError, json.JSONDecodeError):
        return None
    got = rep.get("config", {})
    if any(got.get(k) != v for k, v in config.items()):
        return None
    return rep


def main(argv: list[str] | None = None) -> int:
    from walker_gait.bench import sweep
    from walker_gait.bench.__main__ import machine
    from walker_gait.io.outputs import atomic_write

    ap = argparse.ArgumentParser(prog="python -m walker_gait.bench.probes", description=__doc__.split("\n\n")[0])
    ap.add_argument("--probes", nargs="+", metavar="NAME", help="probes to run (default: all; see --list)")
    ap.add_argument("--list", action="store_true", help="print the probes and what each varies, and exit")
    ap.add_argument("--out", type=Path, default=Path("out/probes"), help="kept sweeps, one folder per probe")
    ap.add_argument("--md", type=Path, default=Path("PROBES.md"), help="the table (written atomically)")
    ap.add_argument("--per-probe", type=int, default=4, help="sessions per probe (default 4)")
    ap.add_argument("--base-seed", type=int, default=900, help="session seeds base .. base+per_probe-1 (default 900)")
    ap.add_argument("--tracker-seed", type=int, default=0)
    ap.add_argument("--duration", type=float, default=8.0, help="s per session")
    ap.add_argument("--passes", choices=("both", "forward"), default="both",
                    help="both (default): as `walker-gait process`; forward: the live graph's one pass")
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--cache", type=Path, default=Path("out/sweep/cache"), help="rendered sessions (reused)")
    ap.add_argument("--override", default="{}",
                    help="TrackerConfig field overrides of the default preset, JSON (a tracker change judged on the "
                         "probes: run once without, once with, each with its own --out and --md)")
    ap.add_argument("--resume", action="store_true", help="reuse a probe's kept sweep that ran with the same settings")
    ap.add_argument("--compare", type=Path, nargs=2, metavar=("BEFORE", "AFTER"),
                    help="print two kept battery runs (their --out folders) side by side, and exit")
    a = ap.parse_args(argv)
    if a.compare:
        runs = [_read_battery(d, a.tracker_seed) for d in a.compare]
        for d, r in zip(a.compare, runs):
            if not r:
                print(f"probes: no kept probe sweeps (NAME/summary.json, tracker seed {a.tracker_seed}) under {d}",
                      file=sys.stderr)
                return 2
        print(format_comparison(*runs))
        return 0
    if a.list:
        for p in PROBES:
            print(f"{p.name:12s} {p.what}\n{'':12s} {json.dumps(dict(p.spec))}")
        return 0
    known = {p.name: p for p in PROBES}
    names = a.probes or list(known)
    unknown = [n for n in names if n not in known]
    if unknown:
        print(f"probes: unknown probe(s) {', '.join(unknown)}; known: {', '.join(known)}", file=sys.stderr)
        return 2
    if a.per_probe < 1 or a.jobs < 1 or not a.duration > 0:
        print("probes: --per-probe and --jobs must be >= 1 and --duration > 0", file=sys.stderr)
        return 2
    try:
        override = json.loads(a.override)
        if not isinstance(override, dict):
            raise TypeError("expected a JSON object of TrackerConfig fields")
        from walker_gait.core.tracker import preset

        preset("default", **override)
    except (json.JSONDecodeError, TypeError, ValueError) as exc:
        print(f"probes: bad --override {a.override!r}: {exc}", file=sys.stderr)
        return 2
    chosen = [known[n] for n in dict.fromkeys(names)]
    results: dict[str, Mapping[str, Any]] = {}
    kept: list[str] = []
    t0 = time.perf_counter()
    for k, p in enumerate(chosen, 1):
        config = {"spec_override": sweep.spec_overrides(json.dumps(dict(p.spec))), "scenarios": ["normal"],
                  "per_scenario": a.per_probe, "base_seed": a.base_seed, "tracker_seeds": [a.tracker_seed],
                  "duration": a.duration, "passes": a.passes, "override": override}
        config = json.loads(json.dumps(config))  # as the kept summary.json has it (tuples as lists)
        rep = _kept(a.out / p.name, config) if a.resume else None
        if rep is None:
            print(f"[probes] {k}/{len(chosen)} {p.name}: {p.what}", file=sys.stderr, flush=True)
            with contextlib.redirect_stdout(io.StringIO()):  # the sweep prints its own table; ours comes at the end
                rc = sweep.main(probe_argv(p, out=a.out, per_probe=a.per_probe, base_seed=a.base_seed,
                                           tracker_seed=a.tracker_seed, passes=a.passes, jobs=a.jobs, cache=a.cache,
                                           duration=a.duration, override=override))
            if rc != 0:
                print(f"probes: the sweep of probe {p.name} failed (exit {rc})", file=sys.stderr)
                return rc
            rep = _kept(a.out / p.name, config)
            if rep is None:
                print(f"probes: {a.out / p.name / 'summary.json'} was not written as expected", file=sys.stderr)
                return 1
        else:
            print(f"[probes] {k}/{len(chosen)} {p.name}: kept ({a.out / p.name})", file=sys.stderr, flush=True)
            kept.append(p.name)
        results[p.name] = rep["per_tracker_seed"][str(a.tracker_seed)]
    table = format_probes(results)
    resumed = (f"; {len(kept)} of them kept from an earlier run with the same settings (`--resume`), their tracker "
               "times that run's" if kept else "")
    tracker = f" changed by `{json.dumps(override)}`" if override else ""
    seeds = f"{a.base_seed}-{a.base_seed + a.per_probe - 1}" if a.per_probe > 1 else str(a.base_seed)
    passes = ("both passes merged, as `walker-gait process`" if a.passes == "both"
              else "the forward pass alone, as the live graph")
    text = "\n".join([
        "# walker_gait probe battery",
        "",
        f"Measured {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())} by `python -m walker_gait.bench.probes` "
        f"({len(chosen)} probes, {time.perf_counter() - t0:.0f} s{resumed}) on: {machine()}.",
        "",
        f"Each probe: {a.per_probe} synthetic `normal` session{'s' if a.per_probe > 1 else ''} of {a.duration:g} s "
        f"(session seed{'s' if a.per_probe > 1 else ''} {seeds}, the same in every probe) with the generator's ranges "
        "moved as named, tracked "
        f"with the `default` preset{tracker} (tracker seed {a.tracker_seed}; {passes}). Figures as in `make sweep` "
        "(`walker_gait.bench.sweep`): joint errors are mean 3D distances over the frames with both legs in view; "
        "steps are matched to the true ones as in BENCHMARKS.md. Compare a row with `base`: the same sessions "
        "otherwise. The kept sweeps (per-session figures, tracked poses) are under "
        f"`{a.out}`.",
        "",
        table,
        "",
    ])
    a.md.parent.mkdir(parents=True, exist_ok=True)
    with atomic_write(a.md) as f:
        f.write(text)
    print(table)
    print(f"[probes] {len(chosen)} probes in {time.perf_counter() - t0:.0f} s -> {a.md}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
