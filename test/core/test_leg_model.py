"""Tests of walker_gait.core.leg_model (geometry, constraints, frames)."""

from __future__ import annotations

import numpy as np
import pytest

from walker_gait.core import _jit, kernels, leg_model as lm
from walker_gait.core.leg_model import BodyFrame, StateLayout as L
from walker_gait.core.types import ANKLE, HEEL, HIP, KNEE, TOE, FloorPlane


@pytest.fixture(params=["numpy", "compiled"])
def kinematics_code(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    """Run a test with the leg model's numpy kinematics and with its compiled kernel (numba is pinned: imported
    directly, so a broken install fails here rather than testing numpy twice)."""
    monkeypatch.setattr(kernels, "compiled", (lambda: None) if request.param == "numpy" else (lambda: _jit))
    return str(request.param)


def _random_states(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    x = np.tile(lm.neutral_state(), (n, 1))
    x[:, L.ANGLES] += rng.normal(0.0, 0.2, (n, 12))
    x[:, L.SHAPE] *= 1.0 + 0.05 * rng.standard_normal((n, 5))
    x[:, L.HIP_AZ] += rng.normal(0, 0.1, n)
    x, _, _ = lm.enforce_constraints(x, fallback=np.tile(lm.neutral_state(), (n, 1)))
    return x


def test_state_layout_has_23_elements() -> None:
    assert lm.STATE_DIM == 23
    assert len(L.NAMES) == 23
    assert lm.STATE_LOWER.shape == lm.STATE_UPPER.shape == (23,)
    assert L.NAMES[11].startswith("left_hip_flexion") and L.NAMES[22] == "right_ankle_inversion"


def test_segment_lengths_and_foot_points() -> None:
    x = _random_states(50)
    kin = lm.forward_kinematics(x)
    p = kin.points
    np.testing.assert_allclose(np.linalg.norm(p[:, :, KNEE] - p[:, :, HIP], axis=-1), x[:, [L.LEN_THIGH] * 2], atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(p[:, :, ANKLE] - p[:, :, KNEE], axis=-1), x[:, [L.LEN_CALF] * 2], atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(p[:, :, TOE] - p[:, :, HEEL], axis=-1), x[:, [L.LEN_FOOT] * 2], atol=1e-9)
    # the foot segment lies on the heel-toe sole axis, inset by its end radii so that the capsule's
    # rounded ends reach exactly the heel and toe points
    fwd = (p[:, :, TOE] - p[:, :, HEEL]) / x[:, [L.LEN_FOOT] * 2, None]
    r = kin.radii[:, :, 2]
    np.testing.assert_allclose(kin.segments[:, :, 2, 0], p[:, :, HEEL] + fwd * r[..., 0, None] * lm.FOOT_CAP_INSET,
                               atol=1e-12)
    np.testing.assert_allclose(kin.segments[:, :, 2, 1], p[:, :, TOE] - fwd * r[..., 1, None] * lm.FOOT_CAP_INSET,
                               atol=1e-12)
    assert np.all(r[..., 0] + r[..., 1] < x[:, [L.LEN_FOOT] * 2])  # the inset axis keeps a positive length
    # the ankle is above the sole: distance from ankle to heel fixed by the foot length
    d = np.linalg.norm(p[:, :, ANKLE] - p[:, :, HEEL], axis=-1)
    np.testing.assert_allclose(d, np.hypot(lm.ANKLE_HEIGHT, lm.HEEL_BACK) * x[:, [L.LEN_FOOT] * 2], atol=1e-9)


def test_neutral_pose_geometry() -> None:
    x = lm.neutral_state(right_hip_xy=(0.0, -0.09), hip_dist=0.18)
    kin = lm.forward_kinematics(x)
    p = kin.points[0]
    # left hip at +y (anatomical left), feet point forward (+x), flat on the floor
    assert p[0, HIP, 1] > p[1, HIP, 1]
    assert p[0, TOE, 0] > p[0, HEEL, 0]
    np.testing.assert_allclose(p[:, HEEL, 2], 0.0, atol=1e-9)
    np.testing.assert_allclose(p[:, TOE, 2], 0.0, atol=1e-9)
    # heel is the posterior-most sole point: behind the ankle by HEEL_BACK * length
    np.testing.assert_allclose(p[:, ANKLE, 0] - p[:, HEEL, 0], lm.HEEL_BACK * x[L.LEN_FOOT], atol=1e-9)
    assert not lm.constraint_violations(x[None])[0]


def test_angle_signs() -> None:
    base = lm.neutral_state()
    for side in (0, 1):
        o = L.leg(side).start
        x = base.copy()
        x[o + L.HIP_FLEX] = 0.4
        p = lm.forward_kinematics(x).points[0, side]
        assert p[KNEE, 0] > p[HIP, 0]  # flexion: thigh forward
        x = base.copy()
        x[o + L.KNEE_FLEX] = 0.6
        p = lm.forward_kinematics(x).points[0, side]
        assert p[ANKLE, 0] < p[KNEE, 0]  # knee flexion: calf backwards
        x = base.copy()
        x[o + L.ANKLE_FLEX] = 0.3
        p = lm.forward_kinematics(x).points[0, side]
        assert p[TOE, 2] > p[HEEL, 2]  # dorsiflexion lifts the toes
        x = base.copy()
        x[o + L.HIP_ABD] = 0.3
        p = lm.forward_kinematics(x).points[0, side]
        away = 1.0 if side == 0 else -1.0  # left leg abducts towards +y
        assert away * (p[KNEE, 1] - p[HIP, 1]) > 0


def test_floor_contact_and_constraints_after_enforcement() -> None:
    rng = np.random.default_rng(3)
    x = _random_states(200)
    noisy = x + rng.normal(0, 0.1, x.shape)
    y, kin, _ = lm.enforce_constraints(noisy, fallback=x)
    assert not np.any(lm.constraint_violations(y))
    low = lm.sole_heights(kin)
    np.testing.assert_allclose(low.min(axis=1), 0.0, atol=1e-9)  # >= 1 foot on the floor
    assert np.all(low >= -1e-9)  # none below
    np.testing.assert_allclose(kin.points, lm.forward_kinematics(y).points, atol=1e-9)


def test_collision_detected() -> None:
    x = lm.neutral_state(hip_dist=0.12)
    x[L.LEFT.start + L.HIP_ABD] = -0.3  # adduct both legs: they cross
    x[L.RIGHT.start + L.HIP_ABD] = -0.3
    kin = lm.forward_kinematics(x)
    assert lm.collisions(kin)[0]
    assert lm.constraint_violations(lm.apply_floor_contact(x))[0]


def test_loose_fabric_hangs_straight_and_gives_way() -> None:
    """A calf radius wider than any calf (baggy trousers) makes a straight tube down to the ankle, and the
    collision test sees the leg inside: two such legs may pass each other as closely as bare legs."""
    lo, hi = lm.LOOSE_CALF_RADIUS
    r = np.array([0.04, lo, 0.5 * (lo + hi), hi, 0.13])
    np.testing.assert_allclose(lm.calf_taper(r), [lm.CALF_TAPER, lm.CALF_TAPER, 0.5 * (1 + lm.CALF_TAPER), 1.0, 1.0])
    x = np.tile(lm.neutral_state(hip_dist=0.16), (3, 1))
    x[:, L.RAD_CALF] = [0.05, 0.10, 0.13]
    kin = lm.forward_kinematics(x)
    taper = kin.radii[:, :, 1, 1] / x[:, L.RAD_CALF, None]
    np.testing.assert_allclose(taper, np.repeat(lm.calf_taper(x[:, L.RAD_CALF])[:, None], 2, axis=1))
    # calves 16 cm apart: 13 cm fabric tubes overlap, the legs inside them do not
    assert not lm.collisions(kin).any()
    x[:, L.HIP_DIST] = 0.12
    x[:, [L.LEFT.start + L.HIP_ABD, L.RIGHT.start + L.HIP_ABD]] = -0.08  # ankles 2 cm apart: legs overlap in any trousers
    assert lm.collisions(lm.forward_kinematics(x)).all()


def _foot_top_heights(kin: lm.Kinematics, along: np.ndarray) -> np.ndarray:
    """Height of the model foot's surface (half-cylinder on its sole axis, rounded ends) over the sole points
    ``along`` (m from the heel towards the toe) of each foot of a flat-footed pose, ``(P, 2, K)``."""
    start, end = kin.segments[:, :, 2, 0], kin.segments[:, :, 2, 1]  # (P, 2, 3) sole axis ends
    r0, r1 = kin.radii[:, :, 2, 0, None], kin.radii[:, :, 2, 1, None]
    heel = kin.points[:, :, HEEL]
    a = np.linalg.norm(start - heel, axis=-1)[..., None]  # axis start, m from the heel
    b = np.linalg.norm(end - heel, axis=-1)[..., None]
    t = np.clip((along - a) / (b - a), 0.0, 1.0)
    on_axis = r0 + (r1 - r0) * t
    behind = np.sqrt(np.maximum(r0**2 - (a - along) ** 2, 0.0))
    ahead = np.sqrt(np.maximum(r1**2 - (along - b) ** 2, 0.0))
    return np.where(along < a, behind, np.where(along > b, ahead, on_axis))


def test_foot_top_follows_a_shoe_from_the_instep_to_the_toe() -> None:
    """Where the camera sees a shoe from the front (its top from the instep to the toe box), the model foot's
    surface stands within 1.5 cm of a shoe's height profile (the synthetic generator's shoe: heel counter
    8.5 cm, 10-10.5 cm over the heel and instep, 4 cm toe box), so the filter need not pitch a flat foot
    heel-up onto its toes to reach the instep (it did with a 7.5 cm heel radius: up to 2.3 cm short there)."""
    from walker_gait.synth.body import _SHOE_H, _SHOE_HS

    x = np.tile(lm.neutral_state(), (2, 1))
    x[:, L.LEN_FOOT] = [0.24, 0.29]
    kin = lm.forward_kinematics(lm.apply_floor_contact(x))
    np.testing.assert_allclose(kin.points[:, :, HEEL, 2], 0.0, atol=1e-12)  # flat on the floor
    np.testing.assert_allclose(kin.points[:, :, TOE, 2], 0.0, atol=1e-12)
    s = np.linspace(0.3, 0.95, 14)  # fraction of the foot length from the heel
    for p, length in enumerate(x[:, L.LEN_FOOT]):
        model = _foot_top_heights(kin, s * length)[p]
        shoe = length / 0.27 * np.interp(s, _SHOE_HS, _SHOE_H)  # the generator's 27 cm shoe, scaled
        assert np.abs(model - shoe[None]).max() < 0.015, (length, np.round(100 * (model - shoe), 1))


def test_segment_distance_known_cases() -> None:
    p1, q1 = np.array([0.0, 0, 0]), np.array([1.0, 0, 0])
    p2, q2 = np.array([0.5, 1, -1]), np.array([0.5, 1, 1])
    assert lm.segment_distances(p1, q1, p2, q2) == np.float64(1.0)
    p2, q2 = np.array([2.0, 0, 0]), np.array([3.0, 0, 0])  # collinear, disjoint
    np.testing.assert_allclose(lm.segment_distances(p1, q1, p2, q2), 1.0)


def test_body_frame_left_right_mapping() -> None:
    floor = FloorPlane.from_camera_pose(height=0.7, pitch=0.5)
    x = lm.neutral_state(right_hip_xy=(-0.9, -0.09))
    pts = lm.forward_kinematics(x).points[0]
    cam_user = BodyFrame.from_floor(floor, mounting="facing_user").to_camera(pts)
    # facing the user: anatomical left leg appears on the image's right (+x camera), in front of the camera
    assert np.all(cam_user[0, :, 0] > cam_user[1, :, 0])
    assert np.all(cam_user[..., 2] > 0.3)
    x_fwd = lm.neutral_state(right_hip_xy=(0.9, -0.09))
    pts_f = lm.forward_kinematics(x_fwd).points[0]
    cam_fwd = BodyFrame.from_floor(floor, mounting="facing_forward").to_camera(pts_f)
    assert np.all(cam_fwd[0, :, 0] < cam_fwd[1, :, 0])
    assert np.all(cam_fwd[..., 2] > 0.3)
    # round trip and floor height = body z
    bf = BodyFrame.from_floor(floor, mounting="facing_user")
    np.testing.assert_allclose(bf.to_body(cam_user), pts, atol=1e-9)
    np.testing.assert_allclose(floor.height(cam_user), pts[..., 2], atol=1e-9)


def test_joint_angles_order() -> None:
    x = lm.neutral_state()
    x[L.ANGLES] = np.arange(12) * 0.01
    np.testing.assert_allclose(lm.joint_angles(x), np.arange(12) * 0.01)


def _reference_kinematics(x: np.ndarray) -> lm.Kinematics:
    """Per-particle forward kinematics written out with explicit 3x3 matrices (module docstring chain)."""

    def rot(axis: int, a: float) -> np.ndarray:
        i, j = [(1, 2), (2, 0), (0, 1)][axis]
        m = np.eye(3)
        m[i, i] = m[j, j] = np.cos(a)
        m[i, j], m[j, i] = -np.sin(a), np.sin(a)
        return m

    p = x.shape[0]
    seg, rad = np.empty((p, 2, 3, 2, 3)), np.empty((p, 2, 3, 2))
    pts, lat = np.empty((p, 2, 5, 3)), np.empty((p, 2, 3))
    for k, st in enumerate(x):
        dist, az, el = st[L.HIP_DIST], st[L.HIP_AZ], st[L.HIP_EL]
        l_th, l_ca, l_ft, r_th, r_ca = st[L.SHAPE]
        right = st[L.ROOT]
        left = right + dist * np.array([-np.sin(az) * np.cos(el), np.cos(az) * np.cos(el), np.sin(el)])
        for side, hip in ((0, left), (1, right)):
            s = 1.0 if side == 0 else -1.0
            flex, abd, hrot, knee_a, dorsi, inv = st[L.leg(side)]
            r_thigh = rot(2, az) @ rot(1, -flex) @ rot(0, s * abd) @ rot(2, -s * hrot)
            r_calf = r_thigh @ rot(1, knee_a)
            r_foot = r_calf @ rot(1, -dorsi) @ rot(0, -s * inv)
            knee = hip - l_th * r_thigh[:, 2]
            ankle = knee - l_ca * r_calf[:, 2]
            heel = ankle + r_foot @ np.array([-lm.HEEL_BACK * l_ft, 0.0, -lm.ANKLE_HEIGHT * l_ft])
            toe = heel + l_ft * r_foot[:, 0]
            r_heel, r_toe = lm.FOOT_HEEL_RADIUS * l_ft, lm.FOOT_TOE_RADIUS * l_ft
            inset = lm.FOOT_CAP_INSET * np.array([r_heel, -r_toe])
            pts[k, side] = hip, knee, ankle, heel, toe
            seg[k, side] = [hip, knee], [knee, ankle], [heel, toe] + inset[:, None] * r_foot[:, 0]
            lo, hi = lm.LOOSE_CALF_RADIUS  # loose fabric: the taper relaxes linearly to a straight tube
            taper = lm.CALF_TAPER + (1.0 - lm.CALF_TAPER) * min(max((r_ca - lo) / (hi - lo), 0.0), 1.0)
            rad[k, side] = [r_th, lm.THIGH_TAPER * r_th], [r_ca, taper * r_ca], [r_heel, r_toe]
            lat[k, side] = r_foot[:, 1]
    return lm.Kinematics(segments=seg, radii=rad, points=pts, foot_lateral=lat)


def _reference_segment_distance(p1: np.ndarray, q1: np.ndarray, p2: np.ndarray, q2: np.ndarray) -> float:
    """Exact minimum of the convex |r + s d1 - t d2| over [0, 1]^2: interior stationary point or edge minima."""
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    cands = []
    for s in (0.0, 1.0):  # edges s = const: clamped 1-D minimum over t
        t = np.clip((r + s * d1) @ d2 / (d2 @ d2), 0.0, 1.0) if d2 @ d2 > 0 else 0.0
        cands.append((s, t))
    for t in (0.0, 1.0):
        s = np.clip((t * d2 - r) @ d1 / (d1 @ d1), 0.0, 1.0) if d1 @ d1 > 0 else 0.0
        cands.append((s, t))
    m = np.array([[d1 @ d1, -(d1 @ d2)], [-(d1 @ d2), d2 @ d2]])
    if abs(np.linalg.det(m)) > 1e-12:
        s, t = np.linalg.solve(m, [-(d1 @ r), d2 @ r])
        if 0.0 <= s <= 1.0 and 0.0 <= t <= 1.0:
            cands.append((s, t))
    return min(float(np.linalg.norm(r + s * d1 - t * d2)) for s, t in cands)


def _box_states(n: int, seed: int) -> np.ndarray:
    """States uniform in the box limits, plus legs crossed towards each other (collisions)."""
    rng = np.random.default_rng(seed)
    x = lm.STATE_LOWER + rng.random((n, lm.STATE_DIM)) * (lm.STATE_UPPER - lm.STATE_LOWER)
    crossed = np.tile(lm.neutral_state(hip_dist=0.12), (n, 1))
    crossed[:, [L.LEFT.start + L.HIP_ABD, L.RIGHT.start + L.HIP_ABD]] = rng.uniform(-0.35, 0.05, (n, 2))
    return np.concatenate([x, crossed])


def test_forward_kinematics_matches_per_particle_reference(kinematics_code: str) -> None:
    x = _box_states(40, seed=11)
    kin, ref = lm.forward_kinematics(x), _reference_kinematics(x)
    for name in ("segments", "radii", "points", "foot_lateral"):
        np.testing.assert_allclose(getattr(kin, name), getattr(ref, name), rtol=0, atol=1e-12, err_msg=name)
    np.testing.assert_allclose(lm.forward_kinematics(x[3]).points, ref.points[3:4], rtol=0, atol=1e-12)
    np.testing.assert_allclose(lm.hip_positions(x), ref.points[:, :, HIP], rtol=0, atol=1e-12)


def test_sole_heights_and_collisions_match_per_pair_reference(kinematics_code: str) -> None:
    x = _box_states(40, seed=12)
    kin = lm.forward_kinematics(x)
    # sole corners: both ends of the foot axis +- the sole's half-width (FOOT_HALF_WIDTH * foot length) along
    # the lateral axis
    half = (x[:, L.LEN_FOOT] * lm.FOOT_HALF_WIDTH)[:, None, None, None]
    z = kin.segments[:, :, 2, :, 2, None] + half * kin.foot_lateral[:, :, None, None, 2] * [-1, 1]
    np.testing.assert_allclose(lm.sole_heights(kin), z.min(axis=(2, 3)), rtol=0, atol=1e-12)
    radii = kin.radii.copy()
    radii[:, :, 1] = np.minimum(radii[:, :, 1], lm.COLLISION_CALF_RADIUS)  # fabric gives way
    radii[:, :, 2, 0] = lm.COLLISION_FOOT_RADIUS * x[:, None, L.LEN_FOOT]  # feet meet by their width
    mean_r = radii.mean(axis=-1)
    expected = np.zeros(len(x), dtype=bool)
    for k in range(len(x)):
        for i in range(3):
            for j in range(3):
                (p1, q1), (p2, q2) = kin.segments[k, 0, i], kin.segments[k, 1, j]
                d = _reference_segment_distance(p1, q1, p2, q2)
                np.testing.assert_allclose(lm.segment_distances(p1, q1, p2, q2), d, rtol=0, atol=1e-12)
                expected[k] |= d < lm.COLLISION_SLACK * (mean_r[k, 0, i] + mean_r[k, 1, j])
    assert 0 < expected.sum() < len(x)
    np.testing.assert_array_equal(lm.collisions(kin), expected)
    # segment_distances broadcasts like the (P, 3, 3) pair layout
    pair = lm.segment_distances(
        kin.segments[:, 0, :, None, 0], kin.segments[:, 0, :, None, 1], kin.segments[:, 1, None, :, 0],
        kin.segments[:, 1, None, :, 1],
    )
    assert pair.shape == (len(x), 3, 3)


def test_segment_distance_degenerate_and_parallel_segments() -> None:
    rng = np.random.default_rng(13)
    for _ in range(200):
        p1, q1, p2, q2 = rng.normal(size=(4, 3))
        kind = rng.integers(4)
        if kind == 1:  # parallel
            q2 = p2 + rng.uniform(-2, 2) * (q1 - p1)
        elif kind == 2:  # first segment is a point
            q1 = p1
        elif kind == 3:  # both points
            q1, q2 = p1, p2
        expected = _reference_segment_distance(p1, q1, p2, q2)
        np.testing.assert_allclose(lm.segment_distances(p1, q1, p2, q2), expected, rtol=0, atol=1e-9)


def test_enforce_constraints_replaces_only_bad_particles(kinematics_code: str) -> None:
    x = _box_states(40, seed=14)
    fb = np.tile(lm.neutral_state(), (len(x), 1))
    y, kin, replaced = lm.enforce_constraints(x, fallback=fb)
    y0, kin0, flagged = lm.enforce_constraints(x)
    np.testing.assert_array_equal(replaced, flagged)
    assert 0 < replaced.sum() < len(x)
    np.testing.assert_array_equal(y[replaced], fb[replaced])
    np.testing.assert_array_equal(y[~replaced], y0[~replaced])
    ref = _reference_kinematics(y)
    for name in ("segments", "radii", "points", "foot_lateral"):
        np.testing.assert_allclose(getattr(kin, name), getattr(ref, name), rtol=0, atol=1e-12, err_msg=name)
        np.testing.assert_array_equal(getattr(kin, name)[~replaced], getattr(kin0, name)[~replaced])


def test_compiled_kinematics_are_numpys_bit_for_bit(monkeypatch: pytest.MonkeyPatch) -> None:
    # states anywhere in the box, most of them breaking a constraint (legs through each other, roots off their
    # limits), some near the collision test's threshold: the same states, kinematics and decisions either way
    rng = np.random.default_rng(21)
    n = 400
    x = lm.STATE_LOWER + (lm.STATE_UPPER - lm.STATE_LOWER) * rng.random((n, lm.STATE_DIM))
    x[:, L.ROOT_X : L.ROOT_Y + 1] = rng.normal(0.0, 0.3, (n, 2))
    x[:, L.ANGLES] += rng.normal(0.0, 0.3, (n, 12))  # some outside their limits: clipped
    x = np.concatenate([x, _box_states(40, seed=22)])
    fb = _random_states(len(x), seed=23)
    got = {}
    for name, jit in (("numpy", None), ("compiled", _jit)):
        with monkeypatch.context() as mp:
            mp.setattr(kernels, "compiled", lambda jit=jit: jit)
            got[name] = (lm.forward_kinematics(x), lm.enforce_constraints(x, fallback=fb),
                         lm.enforce_constraints(np.asfortranarray(x)))  # any memory layout
    (kin_a, (xa, ka, ba), (xa0, ka0, ba0)), (kin_b, (xb, kb, bb), (xb0, kb0, bb0)) = got["numpy"], got["compiled"]
    assert 0.2 * len(x) < ba.sum() < len(x)
    for a, b in ((xa, xb), (ba, bb), (xa0, xb0), (ba0, bb0)):
        np.testing.assert_array_equal(a, b)
    for name in ("segments", "radii", "points", "foot_lateral"):
        for a, b in ((kin_a, kin_b), (ka, kb), (ka0, kb0)):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


def _pitches(points: np.ndarray) -> np.ndarray:
    """Heel-up pitch (rad) of each foot of ``points`` (..., 2, 5, 3)."""
    d = points[..., TOE, :2] - points[..., HEEL, :2]
    return np.arctan2(points[..., HEEL, 2] - points[..., TOE, 2], np.linalg.norm(d, axis=-1))


def _feet_pitched(ankle_flex: np.ndarray, *, lift: float = 0.0) -> lm.Kinematics:
    """Standing poses whose right ankle is flexed by ``ankle_flex`` (P,), on the floor (raised by ``lift``)."""
    x = np.tile(lm.neutral_state(), (ankle_flex.size, 1))
    x[:, L.RIGHT.start + L.ANKLE_FLEX] = ankle_flex
    x = lm.apply_floor_contact(x)
    x[:, L.ROOT_Z] += lift
    return lm.forward_kinematics(x)


def test_flatten_feet_lays_a_nearly_flat_foot_on_the_floor_rigidly() -> None:
    flex = np.array([-0.12, -0.05, 0.0, 0.05, 0.12])
    kin = _feet_pitched(flex)
    before = kin.points
    out = lm.flatten_feet(before, lm.sole_heights(kin), flat_below=0.14, blend_to=0.28, floor_tol=0.03)
    # flat: heel and toe at one height, that of the sole's lowest point (on the floor; a pitched foot's end
    # point dips below the sole's contact, where its rounded end meets the sole axis)
    np.testing.assert_allclose(_pitches(out)[:, 1], 0.0, atol=1e-9)
    np.testing.assert_allclose(out[:, 1, HEEL, 2], lm.sole_heights(kin)[:, 1], atol=1e-9)
    # rigid: the foot's points keep their distances; hips, knees and the other foot are untouched
    for i, j in ((HEEL, TOE), (ANKLE, HEEL), (ANKLE, TOE)):
        np.testing.assert_allclose(np.linalg.norm(out[:, 1, i] - out[:, 1, j], axis=-1),
                                   np.linalg.norm(before[:, 1, i] - before[:, 1, j], axis=-1), atol=1e-9)
    np.testing.assert_array_equal(out[:, :, (HIP, KNEE)], before[:, :, (HIP, KNEE)])
    np.testing.assert_array_equal(out[:, 0], before[:, 0])
    # a foot pitched heel-up turns about its toe end, one pitched toe-up about its heel end: the sole axis keeps
    # that point
    up, down = _pitches(before)[:, 1] > 0.01, _pitches(before)[:, 1] < -0.01
    assert up.any() and down.any()
    for sel, end in ((up, 1), (down, 0)):
        contact = kin.segments[sel, 1, 2, end]
        ax = out[sel, 1, TOE] - out[sel, 1, HEEL]
        t = np.einsum("ij,ij->i", contact - out[sel, 1, HEEL], ax) / np.einsum("ij,ij->i", ax, ax)
        np.testing.assert_allclose(out[sel, 1, HEEL] + t[:, None] * ax, contact, atol=1e-9)
    # the input is not modified
    np.testing.assert_array_equal(kin.points, before)


def test_flatten_feet_leaves_heel_rises_landings_and_feet_in_the_air() -> None:
    kin = _feet_pitched(np.array([-0.6, 0.5]))  # well heel-up / toe-up
    out = lm.flatten_feet(kin.points, lm.sole_heights(kin), flat_below=0.14, blend_to=0.28, floor_tol=0.03)
    np.testing.assert_array_equal(out, kin.points)
    air = _feet_pitched(np.array([-0.05, 0.05]), lift=0.05)  # both feet 5 cm up: no foot on the floor
    out = lm.flatten_feet(air.points, lm.sole_heights(air), flat_below=0.14, blend_to=0.28, floor_tol=0.03)
    np.testing.assert_array_equal(out, air.points)


def test_flatten_feet_pitch_map_is_continuous_and_monotonic() -> None:
    flex = np.linspace(-0.5, 0.5, 401)
    kin = _feet_pitched(flex)
    p_in = _pitches(kin.points)[:, 1]
    p_out = _pitches(lm.flatten_feet(kin.points, lm.sole_heights(kin), flat_below=0.1, blend_to=0.2,
                                     floor_tol=0.03))[:, 1]
    order = np.argsort(p_in)
    p_in, p_out = p_in[order], p_out[order]
    assert np.all(np.diff(p_out) >= -1e-9)  # monotonic
    assert np.max(np.abs(np.diff(p_out))) < 5 * np.max(np.diff(p_in))  # no jump
    np.testing.assert_allclose(p_out[np.abs(p_in) <= 0.1], 0.0, atol=1e-9)
    far = np.abs(p_in) >= 0.2
    np.testing.assert_allclose(p_out[far], p_in[far], atol=1e-9)


def test_flatten_feet_takes_the_pitch_spread_out_of_a_mean_heel() -> None:
    """Particles each standing on the floor at their lowest point with a spread of pitch average to a heel
    above the floor; flattened, their mean heel is where their soles are (on the floor, or a few millimetres
    above it where the other foot is the lower one)."""
    rng = np.random.default_rng(3)
    kin = _feet_pitched(rng.normal(0.0, 0.05, 400))
    w = np.full(400, 1 / 400)
    heel_before = w @ kin.points[:, 1, HEEL, 2]
    out = lm.flatten_feet(kin.points, lm.sole_heights(kin), flat_below=0.14, blend_to=0.28, floor_tol=0.03)
    heel_after = w @ out[:, 1, HEEL, 2]
    assert heel_before > 0.002
    np.testing.assert_allclose(heel_after, w @ lm.sole_heights(kin)[:, 1], atol=1e-5)  # the soles' own height (a few pitched past the band)
    assert 0.0 <= heel_after < 0.25 * heel_before


def test_flatten_feet_rejects_a_bad_band() -> None:
    kin = _feet_pitched(np.array([0.0]))
    with pytest.raises(ValueError, match="flat_below"):
        lm.flatten_feet(kin.points, lm.sole_heights(kin), flat_below=0.2, blend_to=0.1, floor_tol=0.03)
