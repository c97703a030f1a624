"""Physics of the synthetic gait: planted feet, steps, stand-still, walker motion."""

from __future__ import annotations

import numpy as np
import pytest

from walker_gait.core.types import EventKind, Side
from walker_gait.synth.kinematics import normative_angle
from walker_gait.synth.session import SCENARIOS, Session, SessionSpec, generate_session


def _session(scenario: str, seed: int, duration: float = 8.0) -> Session:
    # scale only matters for rendering, which these tests do not do
    return generate_session(SessionSpec.preset(scenario, duration=duration, scale=0.1), rng=np.random.default_rng(seed))


@pytest.fixture(scope="module", params=["normal", "asymmetric", "slow_elderly", "stop_and_go", "absent_start", "occlusion"])
def session(request: pytest.FixtureRequest) -> Session:
    return _session(request.param, seed=7, duration=10.0)


def test_stance_contact_point_fixed_in_world(session: Session) -> None:
    """Heel fixed from HS to heel-off, toe fixed from heel-off to TO (within 2 mm; exact by construction)."""
    kin = session.kinematics
    t = np.arange(0.0, session.spec.duration, 1.0 / 400.0)
    st = kin.evaluate(t)
    checked = 0
    for side in (0, 1):
        f = kin.f[side]
        for k in range(1, len(f["hs"])):
            hs, to = f["hs"][k], f["to"][k]
            sel = (t >= hs) & (t < min(to, t[-1]))
            if sel.sum() < 5:
                continue
            heel0 = np.array([*f["heel"][k], 0.0])
            yaw = f["yaw"][k]
            toe0 = heel0 + kin.dims.foot_length * np.array([np.cos(yaw), np.sin(yaw), 0.0])
            heel = st.heel[sel, side]
            toe = st.toe[sel, side]
            assert np.all(st.stance[sel, side])
            heel_down = heel[:, 2] < 1e-9
            # heel-strike -> heel-off: heel planted at the footfall position
            assert np.max(np.linalg.norm(heel[heel_down] - heel0, axis=-1), initial=0) < 2e-3
            # heel-off -> toe-off: toe planted
            assert np.max(np.linalg.norm(toe[~heel_down] - toe0, axis=-1), initial=0) < 2e-3
            # heel-off happens once: the heel never comes back down before toe-off
            first_up = np.argmax(~heel_down) if np.any(~heel_down) else len(heel_down)
            assert np.all(~heel_down[first_up:])
            checked += 1
    if session.spec.scenario != "absent_start":
        assert checked >= 6


def test_feet_never_below_floor_and_swing_clears(session: Session) -> None:
    t = np.arange(0.0, session.spec.duration, 1.0 / 200.0)
    st = session.kinematics.evaluate(t)
    assert st.heel[..., 2].min() > -1e-9
    assert st.toe[..., 2].min() > -1e-9
    swing = ~st.stance
    if np.any(swing):
        low = np.minimum(st.heel[..., 2], st.toe[..., 2])[swing]
        assert np.median(low) > 0.003  # feet are lifted during swing (shuffling elderly: ~5 mm)
        assert np.percentile(st.heel[..., 2][swing], 90) > 0.04  # the heel rises


def test_gt_steps_consistent_with_heel_positions(session: Session) -> None:
    """Recompute the steps from GT heel world positions at the heel-strike times (GAIT_METRICS.md)."""
    kin = session.kinematics
    hs_events = [e for e in session.events if e.kind == EventKind.HEEL_STRIKE]
    assert len(session.steps) == len(hs_events)  # one step per heel strike
    if session.spec.scenario != "absent_start":
        assert len(hs_events) >= 6
    start = kin.evaluate(np.array([0.0])).heel[0]  # standing start footprints (both planted)
    # footprints measured from the kinematics: (time, side, heel xy)
    prints = [(-np.inf, 0, start[0, :2]), (-np.inf, 1, start[1, :2])]
    strides: list[tuple[int, np.ndarray]] = []  # (walking bout, stride)
    for e, s in zip(hs_events, session.steps, strict=True):
        heel = kin.evaluate(np.array([e.stamp])).heel[0, e.side]
        assert abs(heel[2]) < 1e-9
        np.testing.assert_allclose(heel, e.position_world, atol=1e-9)
        np.testing.assert_allclose(heel, s.heel_world, atol=1e-9)
        same = [p for p in prints if p[1] == e.side][-1]
        opp = [p for p in prints if p[1] != e.side][-1]
        strides.append((e.bout, heel[:2] - same[2]))
        # the line of progression from this bout's strides only (a walk in from the side, a stop, a walk on)
        assert s.bout == e.bout
        u = np.sum([v for b, v in strides if b == e.bout][-4:], axis=0)
        u = u / np.linalg.norm(u)
        d = heel[:2] - opp[2]
        assert s.stamp == e.stamp and s.side == e.side
        assert s.step_length == pytest.approx(d @ u, abs=1e-6)
        assert s.step_width == pytest.approx(abs(d[0] * u[1] - d[1] * u[0]), abs=1e-6)
        assert s.stride_length == pytest.approx(strides[-1][1] @ u, abs=1e-6)
        if np.isfinite(opp[0]):
            assert s.step_time == pytest.approx(e.stamp - opp[0], abs=1e-9)
        else:
            assert np.isnan(s.step_time)
        if np.isfinite(s.stance_time) and np.isfinite(s.stride_time):
            assert s.stance_time + s.swing_time == pytest.approx(s.stride_time, abs=1e-9)
        if np.isfinite(s.double_support_time):
            assert 0 < s.double_support_time < s.stance_time
        prints.append((e.stamp, int(e.side), heel[:2]))


def test_step_parameters_follow_spec() -> None:
    s = _session("normal", seed=3, duration=12.0)
    g = s.params.gait
    full = [x for x in s.steps if np.isfinite(x.stride_time)][1:]
    lengths = np.array([x.step_length for x in full])
    widths = np.array([x.step_width for x in full])
    times = np.array([x.step_time for x in full])
    assert abs(np.mean(lengths) - g.step_length) < 0.03
    assert abs(np.mean(widths) - g.step_width) < 0.03
    assert abs(np.mean(times) - g.step_time) < 0.05
    assert np.std(lengths) > 0.003  # step-to-step variability


def test_asymmetric_steps_differ_by_side() -> None:
    s = _session("asymmetric", seed=5, duration=12.0)
    ln = {side: np.mean([x.step_length for x in s.steps if x.side == side and np.isfinite(x.stride_time)]) for side in Side}
    rel = abs(ln[Side.LEFT] - ln[Side.RIGHT]) / np.mean(list(ln.values()))
    assert rel > 0.15


def test_stand_still_has_no_steps_and_fixed_feet() -> None:
    spec = SessionSpec.preset("normal", duration=4.0, scale=0.1, stand_only=True)
    s = generate_session(spec, rng=np.random.default_rng(0))
    assert s.steps == []
    assert s.events == []
    assert np.all(s.body.stance)
    world = s.body.leg_points()
    assert np.ptp(world[:, :, 3:], axis=0).max() < 1e-9  # heels and toes do not move
    assert np.ptp(s.walker_pose[:, 0]) < 1e-9  # walker does not move either


def test_stop_and_go_has_stand_still_periods() -> None:
    s = _session("stop_and_go", seed=2, duration=12.0)
    both = np.all(s.body.stance, axis=1)
    # longest run of double stance (stand-still) must be > 1 s
    runs, cur = [], 0
    for b in both:
        cur = cur + 1 if b else 0
        runs.append(cur)
    assert max(runs) / s.spec.fps > 1.0
    assert len({x.bout for x in s.steps}) >= 2


def test_walker_follows_user_and_planted_feet_recede() -> None:
    s = _session("normal", seed=4, duration=10.0)
    # pelvis-to-camera horizontal distance stays near the preferred distance while walking
    cam_x = s.walker_pose[:, 0]
    dist = cam_x - s.body.pelvis[:, 0]
    walking = s.stamps > 3.0
    assert np.all(np.abs(dist[walking] - s.params.user_distance) < 0.2)
    # during stance (walker moving), the planted heel moves away from the camera (z grows)
    moved = []
    for side in (0, 1):
        st = s.body.stance[:, side]
        for i in range(1, len(st)):
            if st[i] and st[i - 1] and s.stamps[i] > 3.0 and s.body.heel[i, side, 2] < 1e-9 and s.body.heel[i - 1, side, 2] < 1e-9:
                moved.append(s.leg_points[i, side, 3, 2] - s.leg_points[i - 1, side, 3, 2])
    assert np.mean(moved) > 0.005  # ~ walking speed / fps


def test_joint_angles_plausible() -> None:
    s = _session("normal", seed=6, duration=8.0)
    a = np.rad2deg(s.body.angles[s.stamps > 2.5])
    knee = a[:, [3, 9]]
    assert knee.min() > -1.0 and knee.max() < 85.0
    assert knee.max() > 40.0  # swing knee flexion
    hip = a[:, [0, 6]]
    assert hip.max() > 15.0 and hip.min() < 5.0
    # normative curves: knee peaks in swing around 60-65 deg
    phi = np.linspace(0, 1, 101)
    assert 55 < np.rad2deg(normative_angle("knee", phi)).max() < 68


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_every_scenario_generates(scenario: str) -> None:
    s = _session(scenario, seed=11, duration=3.0)
    assert s.leg_points.shape == (len(s), 2, 5, 3)
    assert np.all(np.isfinite(s.leg_points))
    assert s.body.ik_clamped.mean() < 0.05


def _axis_distances(world: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-frame distance between the left and right calf axes and between the heel-toe axes (m)."""
    from walker_gait.core.leg_model import segment_distances

    calf = segment_distances(world[:, 0, 1], world[:, 0, 2], world[:, 1, 1], world[:, 1, 2])
    foot = segment_distances(world[:, 0, 3], world[:, 0, 4], world[:, 1, 3], world[:, 1, 4])
    return calf, foot


@pytest.mark.parametrize("scenario", ["occlusion", "normal", "stop_and_go"])
def test_legs_never_pass_through_each_other(scenario: str) -> None:
    """Narrow-base gait (occlusion: step width 0-4 cm) stands with the feet apart and swings around the
    stance leg: calves and feet keep ~ a limb's thickness between their axes in every frame."""
    for seed in (1, 2):
        s = _session(scenario, seed=seed, duration=10.0)
        calf, foot = _axis_distances(s.body.leg_points())
        assert calf.min() > 0.085, (seed, calf.min())
        assert foot.min() > 0.085, (seed, foot.min())


def test_narrow_steps_keep_their_width_at_heel_strike() -> None:
    """The swing clearance changes the path, not the footfall: GT step widths stay narrow."""
    s = _session("occlusion", seed=4, duration=12.0)
    widths = [x.step_width for x in s.steps if np.isfinite(x.stride_time)][1:-1]
    assert len(widths) >= 8 and np.mean(widths) < 0.05


def test_a_walk_after_a_stop_takes_its_own_line_of_progression() -> None:
    """``absent_start``: the user walks in diagonally from the side, stops at the walker and walks off with it.
    The first step of the walk measures along the walk's own direction, not the approach's: with the approach
    strides in the line of progression that step came out 32 cm wide and 24 cm long (session 963)."""
    s = _session("absent_start", seed=963, duration=14.0)
    walk = [x for x in s.steps if x.bout == 1]
    assert len(walk) >= 6
    assert all(x.step_width < 0.2 for x in walk), [round(x.step_width, 3) for x in walk]
    # the approach itself (bout 0) runs diagonally in the world: its line is its own as well
    approach = [x for x in s.steps if x.bout == 0][2:]
    assert approach and all(x.step_width < 0.2 for x in approach)


def _swing_progress(session: Session) -> list[tuple[float, np.ndarray]]:
    """Per swing (toe off to the next heel strike, both feet): its horizontal length and its ankle's progress along it
    at 200 samples (world frame)."""
    kin = session.kinematics
    out = []
    for side in (0, 1):
        f = kin.f[side]
        for k in range(len(f["hs"]) - 1):
            t_to, t_hs = float(f["to"][k]), float(f["hs"][k + 1])
            if not t_hs - t_to > 0.05 or t_hs > session.spec.duration:
                continue
            ankle = kin.evaluate(np.linspace(t_to, t_hs, 200)).ankle[:, side, :2]
            d = ankle[-1] - ankle[0]
            length = float(np.linalg.norm(d))
            if length > 0.02:
                out.append((length, (ankle - ankle[0]) @ (d / length)))
    return out


@pytest.mark.parametrize("over", [{"step_length": (0.15, 0.2), "cadence": (62.0, 70.0)},
                                  {"step_length": (0.25, 0.3), "cadence": (75.0, 85.0)}])
def test_short_strides_swing_forwards_without_stopping(over: dict[str, tuple[float, float]]) -> None:
    """A frail user's short steps and every first step from standing: the swing ankle never stops or slides back
    mid-swing (the normative curves' excursion, made for a normal stride, did: by up to 2-3 cm, and went on)."""
    session = generate_session(SessionSpec.preset("normal", duration=8.0, scale=0.1, **over),
                               rng=np.random.default_rng(3))
    swings = _swing_progress(session)
    assert len(swings) >= 6 and min(length for length, _ in swings) < 0.3
    for length, along in swings:
        mid = along[20:180]  # 10-90 % of the swing
        assert np.all(np.diff(mid) > 0.0), f"a {length:.2f} m swing stops or slides back"
        assert along[-1] - along[0] == pytest.approx(length)


def test_normal_strides_keep_the_normative_swing() -> None:
    """Strides of ordinary length are left as the normative curves make them (not the min-jerk stand-in)."""
    session = _session("normal", seed=7, duration=10.0)
    kin = session.kinematics
    long_ones = [(side, k) for side in (0, 1) for k in range(len(kin.f[side]["hs"]) - 1)
                 if np.linalg.norm(kin.f[side]["heel"][k + 1] - kin.f[side]["heel"][k]) > 0.6]
    assert len(long_ones) >= 6
    assert not any(kin._stalls(side, k) for side, k in long_ones)
