"""The probe battery (``walker_gait.bench.probes``): its probes, its table and how it runs the sweeps."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from walker_gait.bench import probes, sweep
from walker_gait.synth import SessionSpec, generate_session


def _session(spec: dict[str, Any]) -> Any:
    ov = sweep.spec_overrides(json.dumps(spec))
    return generate_session(SessionSpec.preset("normal", duration=1.0, **ov), rng=np.random.default_rng(3))


def _fingerprint(s: Any) -> tuple[Any, ...]:
    """What a probe may change: the resolved parameters (camera, mount, sensor, gait, body), the frames, the legs'
    motion and the walker's rocking."""
    return (repr(s.params), len(s.stamps), np.asarray(s.leg_points).round(6).tobytes(),
            None if s.walker_tilt is None else np.asarray(s.walker_tilt).round(6).tobytes())


def test_every_probe_is_a_valid_condition_that_changes_the_session() -> None:
    names = [p.name for p in probes.PROBES]
    assert len(names) == len(set(names)) and names[0] == "base" and not probes.PROBES[0].spec
    base = _session({})
    for p in probes.PROBES[1:]:
        assert p.spec and p.what, p.name
        s = _session(dict(p.spec))  # the sweep's own check of every field and value, then the generator
        assert _fingerprint(s) != _fingerprint(base), f"probe {p.name} generates the base session"


def _summary(**kw: Any) -> dict[str, Any]:
    s: dict[str, Any] = {"joint_err_cm": {"heel": 1.234, "toe": 1.5, "ankle": 2.0, "knee": 3.04, "hip": 4.46},
                         "frames_over_10cm_at_walker_pct": 0.25, "swapped_frames_pct": 0.0, "matched_in_view": 44,
                         "gt_steps_in_view": 45, "precision": 1.0, "step_length_mae_cm": 0.7,
                         "step_width_mae_cm": 0.54, "step_width_bias_cm": -0.2, "cadence_abs_err_pct": 0.6,
                         "speed_abs_err_pct": 1.5, "tracker_ms": 18.71}
    s.update(kw)
    return s


def test_the_table_has_a_row_per_probe_run_in_the_battery_order_and_marks_missing_figures() -> None:
    results = {"thin": _summary(cadence_abs_err_pct=float("nan")), "base": _summary(),
               "roll": {k: v for k, v in _summary().items() if k != "tracker_ms"}}
    lines = probes.format_probes(results).splitlines()
    assert len(lines) == 2 + 3
    rows = [[c.strip() for c in line.strip("|").split("|")] for line in lines[2:]]
    assert [r[0] for r in rows] == ["base", "thin", "roll"]  # PROBES' order, not the results'
    head = [c.strip() for c in lines[0].strip("|").split("|")]
    assert len(head) == len(rows[0])
    base = dict(zip(head, rows[0]))
    assert base["heel cm"] == "1.23" and base["knee cm"] == "3.0" and base["steps matched / true (in view)"] == "44 / 45"
    assert base["step width MAE cm (bias)"] == "0.54 (-0.20)"
    assert dict(zip(head, rows[1]))["cadence err %"] == "n/a"  # NaN: no figure
    assert dict(zip(head, rows[2]))["tracker ms/frame"] == "n/a"  # a sweep written before the figure existed


def test_main_runs_one_sweep_per_probe_keeps_them_and_resumes(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                              capsys: pytest.CaptureFixture[str]) -> None:
    calls: list[list[str]] = []

    def fake_sweep(argv: list[str]) -> int:
        calls.append(argv)
        a = dict(zip(argv[::2], argv[1::2]))  # every argument takes a value
        spec = sweep.spec_overrides(a["--spec-override"])
        out = Path(a["--out"])
        out.mkdir(parents=True, exist_ok=True)
        config = {"override": json.loads(a["--override"]), "spec_override": spec, "scenarios": [a["--scenarios"]],
                  "per_scenario": int(a["--per-scenario"]), "base_seed": int(a["--base-seed"]),
                  "tracker_seeds": [int(a["--tracker-seeds"])], "duration": float(a["--duration"]),
                  "passes": a["--passes"]}
        heel = 1.0 + len(calls)
        (out / "summary.json").write_text(json.dumps({"config": config, "per_tracker_seed": {
            a["--tracker-seeds"]: _summary(joint_err_cm={"heel": heel})}}))
        return 0

    monkeypatch.setattr(sweep, "main", fake_sweep)
    md, out = tmp_path / "P.md", tmp_path / "kept"
    args = ["--probes", "thin", "base", "--out", str(out), "--md", str(md), "--per-probe", "2", "--jobs", "1",
            "--cache", str(tmp_path / "cache")]
    assert probes.main(args) == 0
    assert len(calls) == 2
    thin = dict(zip(calls[0][::2], calls[0][1::2]))
    assert thin["--scenarios"] == "normal" and thin["--per-scenario"] == "2" and thin["--out"] == str(out / "thin")
    assert json.loads(thin["--spec-override"]) == {"girth": [0.75, 0.85]}
    text = md.read_text()
    assert "| base |" in text and "| thin |" in text and "session seeds 900-901" in text
    assert text.index("| base |") < text.index("| thin |")
    assert not [p for p in tmp_path.rglob("*") if ".tmp" in p.name]  # written through a temporary file, renamed
    capsys.readouterr()
    # --resume: the kept sweeps ran with these settings and are read back, not run again
    assert probes.main([*args, "--resume"]) == 0
    assert len(calls) == 2 and "kept" in capsys.readouterr().err
    assert "2 of them kept from an earlier run" in md.read_text()
    # ... but not with other settings
    assert probes.main([*args, "--resume", "--tracker-seed", "1"]) == 0
    assert len(calls) == 4 and "| thin |" in md.read_text()
    # ... nor with a tracker change, which reaches the sweeps and the table's text
    assert probes.main([*args, "--resume", "--override", '{"n_particles": 100}']) == 0
    assert len(calls) == 6 and json.loads(dict(zip(calls[-1][::2], calls[-1][1::2]))["--override"]) == {"n_particles": 100}
    assert '{"n_particles": 100}' in md.read_text()


def test_main_refuses_unknown_probes_and_reports_a_failed_sweep(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                                capsys: pytest.CaptureFixture[str]) -> None:
    md = tmp_path / "P.md"
    assert probes.main(["--probes", "base", "no_such", "--md", str(md)]) == 2
    assert "no_such" in capsys.readouterr().err and not md.exists()
    assert probes.main(["--probes", "base", "--md", str(md), "--override", '{"no_such_field": 1}']) == 2
    assert "no_such_field" in capsys.readouterr().err and not md.exists()
    monkeypatch.setattr(sweep, "main", lambda argv: 2)
    assert probes.main(["--probes", "base", "--md", str(md), "--out", str(tmp_path / "k")]) == 2
    assert "base" in capsys.readouterr().err and not md.exists()
    assert probes.main(["--list"]) == 0
    listed = capsys.readouterr().out
    assert all(p.name in listed for p in probes.PROBES)


def test_two_battery_runs_side_by_side(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    before = {"base": _summary(), "thin": _summary(step_length_mae_cm=1.1), "roll": _summary()}
    after = {"base": _summary(), "thin": _summary(step_length_mae_cm=0.65)}  # roll not run again
    lines = probes.format_comparison(before, after).splitlines()
    head = [c.strip() for c in lines[0].strip("|").split("|")]
    rows = {r[0]: dict(zip(head, r)) for r in ([c.strip() for c in line.strip("|").split("|")] for line in lines[2:])}
    assert list(rows) == ["base", "thin"]  # probes run in both, in the battery's order
    assert rows["thin"]["step length MAE cm"] == "1.10 -> 0.65" and rows["base"]["heel cm"] == "1.23 -> 1.23"
    # from the kept sweeps' summary.json files
    for name, run in (("a", before), ("b", after)):
        for probe, fig in run.items():
            (tmp_path / name / probe).mkdir(parents=True)
            (tmp_path / name / probe / "summary.json").write_text(json.dumps({"per_tracker_seed": {"0": fig}}))
    assert probes.main(["--compare", str(tmp_path / "a"), str(tmp_path / "b")]) == 0
    assert "| thin | " in capsys.readouterr().out
    assert probes.main(["--compare", str(tmp_path / "a"), str(tmp_path / "none")]) == 2
    assert "none" in capsys.readouterr().err
