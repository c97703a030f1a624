"""Tests of walker_gait.core.feet."""

from __future__ import annotations

import math

import numpy as np
import pytest

from walker_gait.core.feet import (
    ShoeRiseFit,
    ShoeTurnFit,
    ToeFit,
    across_only,
    measure_shoe_rise,
    measure_shoe_turn,
    measure_shoes,
    measure_toes,
    toes_in_view,
)
from walker_gait.core.types import ANKLE, HEEL, TOE, CameraIntrinsics

CAMERA = np.array([1.0, 0.0, 0.45])  # body frame: the walker's camera ahead of the user, 45 cm up


def _shoe(heel: np.ndarray, toe: np.ndarray, rng: np.random.Generator, n: int = 600) -> np.ndarray:
    """Points on the top and front of a shoe from ``heel`` to ``toe`` (on the floor): width 9 cm,
    height 10 cm at the heel falling to 4.5 cm at the toe, as a camera in front of it sees them."""
    u = (toe - heel)[:2] / np.linalg.norm((toe - heel)[:2])
    v = np.array([-u[1], u[0]])
    length = float(np.linalg.norm((toe - heel)[:2]))
    s = rng.uniform(0.0, 1.0, n) ** 0.5  # denser towards the toe, which faces the camera
    w = rng.uniform(-0.045, 0.045, n) * np.where(s > 0.9, (1.0 - s) * 8.0 + 0.2, 1.0)
    h = 0.10 - 0.055 * s
    xy = heel[:2] + (s * length)[:, None] * u + w[:, None] * v
    return np.column_stack([xy, rng.uniform(0.75, 1.0, n) * h])


def _legs(heels: np.ndarray, toes: np.ndarray) -> np.ndarray:
    legs = np.zeros((2, 5, 3))
    legs[:, HEEL] = heels
    legs[:, TOE] = toes
    legs[:, ANKLE] = heels + np.array([0.05, 0.0, 0.08])
    legs[:, 0] = heels + np.array([0.05, 0.0, 0.9])
    legs[:, 1] = heels + np.array([0.05, 0.0, 0.45])
    return legs


def _scene(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    heels = np.array([[0.0, 0.06, 0.0], [0.15, -0.06, 0.0]])  # narrow gait: left foot behind, right foot ahead
    toes = heels + np.array([0.26, 0.0, 0.0])
    pts = np.vstack([_shoe(heels[s], toes[s], rng) for s in (0, 1)])
    return heels, toes, pts


def test_toes_come_from_the_shoes_front() -> None:
    rng = np.random.default_rng(3)
    heels, toes, pts = _scene(rng)
    # tracked feet: the left one 3 cm short and 2 cm outward, the right one 3 cm long
    tracked = _legs(heels + [[0.0, 0.02, 0.0], [0.0, 0.0, 0.0]], toes + [[-0.03, 0.02, 0.0], [0.03, 0.0, 0.0]])
    got, measured = measure_toes(tracked, pts, camera=CAMERA)
    assert measured.all()
    err = np.linalg.norm(got[:, :2] - toes[:, :2], axis=1)
    assert np.all(err < 0.012), err
    tracked_err = np.linalg.norm(tracked[:, TOE, :2] - toes[:, :2], axis=1)
    assert np.all(err < 0.5 * tracked_err)
    np.testing.assert_array_equal(got[:, 2], tracked[:, TOE, 2])  # heights stay the tracked ones


def test_other_foot_and_high_points_are_not_the_toe() -> None:
    rng = np.random.default_rng(4)
    heels, toes, pts = _scene(rng)
    # a trouser leg hanging in front of the left shoe's upper part, above the shoe band
    hem = np.column_stack([rng.uniform(0.2, 0.34, 200), rng.uniform(0.02, 0.10, 200), rng.uniform(0.13, 0.4, 200)])
    # the right leg's baggy trouser hem, swinging past 6-12 cm ahead of the left toe, a few cm above the floor
    flare = np.column_stack([rng.uniform(0.32, 0.38, 150), rng.uniform(0.02, 0.10, 150), rng.uniform(0.04, 0.09, 150)])
    got, measured = measure_toes(_legs(heels, toes), np.vstack([pts, hem, flare]), camera=CAMERA)
    assert measured.all()
    # the right shoe reaches 15 cm further forward than the left one: its points must not move the left toe
    assert abs(got[0, 0] - toes[0, 0]) < 0.012
    assert abs(got[1, 0] - toes[1, 0]) < 0.012


def test_a_foot_tracked_with_the_wrong_toe_out_takes_the_toe_box_centre_line() -> None:
    """Across the foot the toe is the centre line of the toe box (``toe_box``), not of the whole shoe: with the tracked
    foot turned by a yaw error, the whole shoe's centre sits half a foot back and turns the measured toe by half the
    error (synthetic sweeps: toes 1.5 cm too close together)."""
    import math

    rng = np.random.default_rng(7)
    heels, toes, pts = _scene(rng)
    a = math.radians(10.0)  # each tracked foot turned 10 degrees outward about its heel
    turned = toes.copy()
    for side, sign in ((0, 1.0), (1, -1.0)):
        length = toes[side, 0] - heels[side, 0]
        turned[side, :2] = heels[side, :2] + length * np.array([math.cos(a), sign * math.sin(a)])
    legs = _legs(heels, turned)
    got, measured = measure_toes(legs, pts, camera=CAMERA)
    whole, _ = measure_toes(legs, pts, camera=CAMERA, fit=ToeFit(toe_box=1.0))
    assert measured.all()
    lateral = np.abs(got[:, 1] - toes[:, 1])
    assert np.all(lateral < 0.007), lateral  # measured 0.5 cm (tracked: 4.5 cm)
    assert np.all(lateral < 0.6 * np.abs(whole[:, 1] - toes[:, 1]))  # the whole shoe's centre: 1.1 cm


def test_unmeasured_feet_keep_their_toes() -> None:
    rng = np.random.default_rng(5)
    heels, toes, pts = _scene(rng)
    legs = _legs(heels, toes + [[-0.03, 0.0, 0.0], [-0.03, 0.0, 0.0]])
    # too few points near the feet
    got, measured = measure_toes(legs, pts[:10], camera=CAMERA)
    assert not measured.any()
    np.testing.assert_array_equal(got, legs[:, TOE])
    # the feet point away from the camera: the camera sees their heels, not their toe boxes
    got, measured = measure_toes(legs, pts, camera=np.array([-1.0, 0.0, 0.45]))
    assert not measured.any()
    np.testing.assert_array_equal(got, legs[:, TOE])
    # a foot without a pose
    broken = legs.copy()
    broken[0, HEEL] = np.nan
    got, measured = measure_toes(broken, pts, camera=CAMERA)
    assert not measured.any()
    np.testing.assert_array_equal(got, legs[:, TOE])


def test_rejects_bad_input() -> None:
    with pytest.raises(ValueError, match="legs"):
        measure_toes(np.zeros((2, 4, 3)), np.zeros((5, 3)), camera=CAMERA)
    with pytest.raises(ValueError, match="max_height"):
        ToeFit(min_height=0.2, max_height=0.1)
    with pytest.raises(ValueError, match="percentile"):
        ToeFit(percentile=0.0)
    with pytest.raises(ValueError, match="min_points"):
        ToeFit(min_points=0)
    with pytest.raises(ValueError, match="reach"):
        ToeFit(reach=0.0)
    with pytest.raises(ValueError, match="pitch_deadband"):
        ToeFit(pitch_deadband=-0.1)
    with pytest.raises(ValueError, match="border_px"):
        ToeFit(border_px=-1.0)
    with pytest.raises(ValueError, match="toe_box"):
        ToeFit(toe_box=0.0)


def test_a_foot_on_its_toes_is_measured_at_the_sole_tip() -> None:
    """Late stance: a rigid shoe pivots on its toe, heel up; its toe box leans forward over the tip."""
    rng = np.random.default_rng(6)
    length, pitch = 0.26, 0.5
    flat = _shoe(np.zeros(3), np.array([length, 0.0, 0.0]), rng)
    # rotate about the tip (y axis): heel up by `pitch`, the tip stays on the floor
    c, s = np.cos(pitch), np.sin(pitch)
    rel = flat - [length, 0.0, 0.0]
    pts = np.column_stack([length + c * rel[:, 0] + s * rel[:, 2], rel[:, 1], -s * rel[:, 0] + c * rel[:, 2]])
    pts = pts[pts[:, 2] > 0.03]
    tip = np.array([length, 0.0, 0.0])
    heel = np.array([length - c * length, 0.0, s * length])
    other = np.array([[-0.5, -0.3, 0.0], [-0.24, -0.3, 0.0]])  # the other foot, far away
    legs = _legs(np.array([heel, other[0]]), np.array([tip, other[1]]))
    got, measured = measure_toes(legs, pts, camera=CAMERA)
    assert measured[0]
    assert abs(got[0, 0] - tip[0]) < 0.01
    # without the lean correction the toe box's top front reads as the toe, well ahead of the tip
    plain, _ = measure_toes(legs, pts, camera=CAMERA, fit=ToeFit(pitch_deadband=10.0))
    assert plain[0, 0] - tip[0] > 0.015



def _low_nosed_shoe(rng: np.random.Generator, length: float = 0.26, n: int = 3000) -> np.ndarray:
    """Top and front of a shoe in its own frame (x from the heel along the sole, z above it): 10 cm high at the
    heel, its toe box falling from 4 cm to 2.2 cm over the last 1.3 cm, closed by a 2.2 cm high front at the tip."""
    s = np.sort(rng.uniform(0.0, 1.0, n)) ** 0.5 * length
    h = np.interp(s, [0.0, length - 0.013, length], [0.10, 0.04, 0.022])
    top = np.column_stack([s, rng.uniform(-0.04, 0.04, n) * np.where(s > length - 0.013, 0.5, 1.0), h])
    m = n // 10
    front = np.column_stack([np.full(m, length), rng.uniform(-0.017, 0.017, m), rng.uniform(0.0, 0.022, m)])
    return np.vstack([top, front])


def test_a_raised_shoe_is_measured_the_same_wherever_its_tracked_tip_floats() -> None:
    """Late stance: the filter often holds a raised foot's tip a centimetre or more above the floor.  The toe box is
    leaned back about that tip and its front taken from what stands ``min_height`` above the sole through it, as the
    floor cut leaves of a flat shoe; leaning it back by height above the floating tip instead kept the low front of
    the toe box, and the toe read 0.5-1 cm further forward (DEVELOPERS.md, thirty-third session)."""
    rng = np.random.default_rng(11)
    length, cut = 0.26, ToeFit().min_height
    shoe = _low_nosed_shoe(rng, length)
    other = np.array([[-0.5, -0.3, 0.0], [-0.24, -0.3, 0.0]])  # the other foot, far away
    for pitch in (0.35, 0.6):
        c, s = np.cos(pitch), np.sin(pitch)
        rel = shoe - [length, 0.0, 0.0]  # about the tip, which stays on the floor
        pts = np.column_stack([length + c * rel[:, 0] + s * rel[:, 2], rel[:, 1], -s * rel[:, 0] + c * rel[:, 2]])
        pts = pts[pts[:, 2] > cut]  # the segmentation's floor cut
        tip = np.array([length, 0.0, 0.0])
        heel = np.array([length - c * length, 0.0, s * length])
        got = []
        for lift in (0.0, 0.012, 0.02):  # the tracked foot, its tip on the floor or floating above it
            legs = _legs(np.array([heel + [0, 0, lift], other[0]]), np.array([tip + [0, 0, lift], other[1]]))
            toes, measured = measure_toes(legs, pts, camera=CAMERA)
            assert measured[0]
            got.append(float(toes[0, 0]))
        assert max(got) - min(got) < 0.003, (pitch, got)
        assert abs(got[0] - tip[0]) < 0.01


INTR = CameraIntrinsics(width=640, height=480, fx=525.0, fy=525.0, cx=319.5, cy=239.5)


def _camera_pose(pitch: float) -> tuple[np.ndarray, np.ndarray]:
    """``(R, C)`` of a camera at ``CAMERA`` looking back at the user (-x), pitched down by ``pitch`` rad:
    camera-frame points are ``(p - C) @ R.T`` (optical frame: z along the view, y down the image)."""
    z = np.array([-np.cos(pitch), 0.0, -np.sin(pitch)])
    down = np.array([0.0, 0.0, -1.0])
    y = down - (down @ z) * z
    y /= np.linalg.norm(y)
    return np.stack([np.cross(y, z), y, z]), CAMERA


def test_a_shoe_cut_by_the_image_border_is_not_measured() -> None:
    """A user close to the camera lands the leading foot below the image's bottom edge: the part of the shoe
    still in view ends at the border, and its front is not the toe box."""
    rng = np.random.default_rng(8)
    heels = np.array([[0.20, 0.07, 0.0], [0.62, -0.07, 0.0]])  # the right foot leads, close to the walker
    toes = heels + np.array([0.26, 0.0, 0.0])
    pts = np.vstack([_shoe(heels[s], toes[s], rng, n=3000) for s in (0, 1)])
    rot, cam = _camera_pose(np.radians(35.0))
    to_cam = lambda p: (np.asarray(p) - cam) @ rot.T  # noqa: E731
    uv = INTR.project(to_cam(pts))
    seen = (uv[:, 0] >= 0) & (uv[:, 0] < INTR.width) & (uv[:, 1] >= 0) & (uv[:, 1] < INTR.height)
    assert 0.2 < seen[3000:].mean() < 0.9  # the leading shoe is partly out of the image, the other in it
    assert seen[:3000].all()
    legs = _legs(heels, toes)
    got, measured = measure_toes(legs, pts[seen], camera=CAMERA)
    assert measured.all()
    assert got[1, 0] < toes[1, 0] - 0.05  # measured at the border, far behind the real toe
    assert abs(got[0, 0] - toes[0, 0]) < 0.012
    legs_cam = to_cam(legs.reshape(-1, 3)).reshape(2, 5, 3)
    np.testing.assert_array_equal(toes_in_view(legs_cam, to_cam(got), intrinsics=INTR), [True, False])
    # the same feet further from the camera: both in view
    back = np.array([-0.3, 0.0, 0.0])
    legs_back = to_cam((legs + back).reshape(-1, 3)).reshape(2, 5, 3)
    np.testing.assert_array_equal(toes_in_view(legs_back, to_cam(toes + back), intrinsics=INTR), [True, True])
    # a measured toe on the border row itself is a cut shoe even when the tracked toe is in view
    edge = INTR.backproject(np.array([300.0, 300.0]), np.array([479.0, 200.0]), legs_back[:, TOE, 2])
    np.testing.assert_array_equal(toes_in_view(legs_back, edge, intrinsics=INTR), [False, True])
    # nor are points behind the camera in view
    behind = legs_back.copy()
    behind[1, :, 2] = -0.1
    assert not toes_in_view(behind, to_cam(toes + back), intrinsics=INTR)[1]


def test_a_cut_shoe_keeps_its_tracked_toe_along_the_foot_and_its_measured_centre_line() -> None:
    heels = np.array([[0.0, 0.06, 0.0], [0.15, -0.06, 0.0]])
    toes = heels + np.array([[0.26, 0.03, 0.0], [0.26, 0.0, 0.0]])  # the left foot toed out
    legs = _legs(heels, toes)
    measured = toes + np.array([[-0.10, 0.015, 0.01], [-0.02, 0.01, 0.0]])  # the left shoe measured at a border
    got = across_only(legs, measured, np.array([True, False]))
    np.testing.assert_array_equal(got[1], measured[1])  # an uncut side keeps its measurement
    u = (toes[0] - heels[0])[:2] / np.linalg.norm((toes[0] - heels[0])[:2])
    v = np.array([-u[1], u[0]])
    assert (got[0, :2] - toes[0, :2]) @ u == pytest.approx(0.0, abs=1e-12)  # along the foot: the tracked toe
    assert (got[0, :2] - toes[0, :2]) @ v == pytest.approx((measured[0, :2] - toes[0, :2]) @ v)  # across: measured
    assert got[0, 2] == toes[0, 2]
    np.testing.assert_array_equal(across_only(legs, measured, np.array([False, False])), measured)


def test_a_toe_box_nearer_than_the_sensor_reaches_is_not_measured() -> None:
    """A toe box closer to the camera than the sensor's near limit is a hole in the depth image: what is left of the
    shoe ends at the hole, and its front is not the toe box."""
    rng = np.random.default_rng(9)
    heels = np.array([[0.0, 0.07, 0.0], [0.25, -0.07, 0.0]])
    toes = heels + np.array([0.26, 0.0, 0.0])
    rot, cam = _camera_pose(np.radians(35.0))
    to_cam = lambda p: (np.asarray(p) - cam) @ rot.T  # noqa: E731
    legs_cam = to_cam(_legs(heels, toes).reshape(-1, 3)).reshape(2, 5, 3)
    toes_cam = to_cam(toes)
    assert toes_in_view(legs_cam, toes_cam, intrinsics=INTR).all()
    no_depth = np.zeros((INTR.height, INTR.width), dtype=bool)
    np.testing.assert_array_equal(toes_in_view(legs_cam, toes_cam, intrinsics=INTR, no_depth=no_depth), [True, True])
    u, v = (int(round(c)) for c in INTR.project(legs_cam[0, TOE][None])[0])
    no_depth[v - 20: v + 20, u - 20: u + 20] = True  # the left toe box unmeasured
    np.testing.assert_array_equal(toes_in_view(legs_cam, toes_cam, intrinsics=INTR, no_depth=no_depth), [False, True])
    # a few unmeasured pixels at the shoe's outline (IR shadow, speckle) do not cut it
    speckle = np.zeros_like(no_depth)
    speckle[v - 4: v + 5: 3, u - 4: u + 5: 3] = True
    assert toes_in_view(legs_cam, toes_cam, intrinsics=INTR, no_depth=speckle)[0]


def _upper(toe: np.ndarray, heading: float, pitch: float, rng: np.random.Generator, n: int = 700) -> np.ndarray:
    """Points on a shoe's upper seen from the front (1 mm depth noise): 26 cm long, 9 cm wide, rising from 3 cm over
    the sole at the toe box to 10 cm at the instep 16 cm back (25 deg), the shoe turned about its toe tip (on the
    floor) heel-up by ``pitch`` (rad) and headed ``heading`` (rad) on the floor."""
    s = rng.uniform(0.0, 0.16, n)  # behind the toe tip, along the sole
    w = rng.uniform(-0.045, 0.045, n)
    h = 0.03 + 0.07 * s / 0.16 + rng.normal(0.0, 0.001, n)
    back = -s * np.cos(pitch) + h * np.sin(pitch)  # along the foot, towards the toe positive
    up = s * np.sin(pitch) + h * np.cos(pitch)
    c, si = np.cos(heading), np.sin(heading)
    return np.column_stack([toe[0] + back * c - w * si, toe[1] + back * si + w * c, up])


def test_a_shoe_turned_heel_up_rises_by_its_pitch() -> None:
    """The rise of the visible upper behind the toe is the shoe's own flat and that plus the pitch heel-up: a rigid
    shoe turns with its foot.  It does not depend on where along the foot the tracker put the heel, and the other
    shoe beside it is not taken for this one."""
    rng = np.random.default_rng(7)
    toes = np.array([[0.30, 0.08, 0.0], [0.25, -0.05, 0.0]])  # side by side, 1.5-4 cm apart: in each other's strip
    flat_rise = math.atan(0.07 / 0.16)
    for pitch_deg in (0.0, 10.0, 25.0, 40.0):
        p = np.radians(pitch_deg)
        pts = np.vstack([_upper(toes[0], 0.1, p, rng), _upper(toes[1], 0.0, 0.0, rng)])
        heels = toes - 0.26 * np.array([[np.cos(0.1), np.sin(0.1), 0.0], [1.0, 0.0, 0.0]])
        heels[0, 2] = 0.26 * np.sin(p) * 0.5  # the tracker's heel: half as high as the real one
        got = measure_shoe_rise(_legs(heels, toes), pts)
        assert abs(got[0] - (flat_rise + p)) < np.radians(1.0), np.degrees(got[0])
        assert abs(got[1] - flat_rise) < np.radians(1.0), np.degrees(got[1])


def _thick_upper(toe: np.ndarray, heading: float, pitch: float, rng: np.random.Generator, n: int = 3000) -> np.ndarray:
    """Points on a shoe's upper as a depth camera above its front sees it: 24 cm long, 9 cm wide, its top rising from
    3 cm over the sole at the toe box by 7 cm every 16 cm, each cross-section a half ellipse down to the sole (its
    sides), the shoe turned about its toe tip heel-up by ``pitch`` and headed ``heading`` (rad) on the floor."""
    s = rng.uniform(0.0, 0.24, n)
    w = rng.uniform(-0.045, 0.045, n)
    h = (0.03 + 0.07 * s / 0.16) * np.sqrt(1.0 - (w / 0.045) ** 2) + rng.normal(0.0, 0.001, n)
    back = -s * np.cos(pitch) + h * np.sin(pitch)
    up = s * np.sin(pitch) + h * np.cos(pitch)
    c, si = np.cos(heading), np.sin(heading)
    return np.column_stack([toe[0] + back * c - w * si, toe[1] + back * si + w * c, up])


def test_a_heel_up_shoes_upper_is_taken_up_to_its_limit_over_the_tracked_sole() -> None:
    """A shoe heel-up lifts the back of its upper past a height limit level with its toe; cut off there, the slope
    fitted to what is left reads the rise short (and the more so the higher the heel).  The limit runs along the
    tracked foot's heel-to-toe line instead (lowered by ``sole_from``): with the tracked heel where the real one is,
    the rise is the flat shoe's plus the pitch within a degree at 20 deg heel-up and 2.5 at 25 (the lowered limit
    still cuts the back), where a level limit reads it 3 and 6 deg short or more.  A flat or toe-up foot is measured
    as with the level limit, and the shoe's turn whatever the limit of the rise."""
    rng = np.random.default_rng(12)
    toes = np.array([[0.30, 0.08, 0.0], [0.25, -0.05, 0.0]])
    heading = np.array([0.1, 0.0])
    flat_heels = toes - 0.26 * np.column_stack([np.cos(heading), np.sin(heading), np.zeros(2)])
    level = ShoeRiseFit(sole_from=None)
    pts = np.vstack([_thick_upper(toes[0], 0.1, 0.0, rng), _thick_upper(toes[1], 0.0, 0.0, rng)])
    flat = measure_shoe_rise(_legs(flat_heels, toes), pts)
    np.testing.assert_array_equal(flat, measure_shoe_rise(_legs(flat_heels, toes), pts, fit=level))
    for pitch_deg, within, short in ((20.0, 1.0, 3.0), (25.0, 2.5, 6.0)):
        p = np.radians(pitch_deg)
        pts = np.vstack([_thick_upper(toes[0], 0.1, p, rng), _thick_upper(toes[1], 0.0, 0.0, rng)])
        heels = flat_heels.copy()
        heels[0, 2] = 0.26 * np.sin(p)
        legs = _legs(heels, toes)
        along = measure_shoe_rise(legs, pts)
        cut = measure_shoe_rise(legs, pts, fit=level)
        err_along, err_cut = along[0] - (flat[0] + p), cut[0] - (flat[0] + p)
        assert abs(err_along) < np.radians(within), np.degrees(err_along)
        assert err_cut < -np.radians(short), np.degrees(err_cut)
        assert along[1] == cut[1]  # the flat shoe beside it
        _, turn = measure_shoes(legs, pts)
        np.testing.assert_array_equal(turn, measure_shoe_turn(legs, pts))
    held_up = flat_heels + np.array([[0.0, 0.0, 0.03], [0.0, 0.0, 0.0]])  # a flat foot whose heel the tracker holds up
    np.testing.assert_array_equal(measure_shoe_rise(_legs(held_up, toes), pts),
                                  measure_shoe_rise(_legs(held_up, toes), pts, fit=level))
    with pytest.raises(ValueError, match="sole_from"):
        ShoeRiseFit(sole_from=-0.01)
    toe_up = _legs(flat_heels, toes + np.array([[0.0, 0.0, 0.05], [0.0, 0.0, 0.0]]))
    pts = np.vstack([_thick_upper(toes[0], 0.1, -0.2, rng), _thick_upper(toes[1], 0.0, 0.0, rng)])
    np.testing.assert_array_equal(measure_shoe_rise(toe_up, pts), measure_shoe_rise(toe_up, pts, fit=level))


def test_a_shoe_without_enough_upper_in_view_is_not_measured() -> None:
    rng = np.random.default_rng(8)
    toes = np.array([[0.30, 0.08, 0.0], [0.05, -0.08, 0.0]])
    heels = toes - np.array([0.26, 0.0, 0.0])
    few = _upper(toes[0], 0.0, 0.0, rng, n=10)
    got = measure_shoe_rise(_legs(heels, toes), few)
    assert np.all(np.isnan(got))
    legs = _legs(heels, toes)
    legs[1, TOE] = np.nan
    assert np.all(np.isnan(measure_shoe_rise(legs, _upper(toes[0], 0.0, 0.0, rng))))
    with pytest.raises(ValueError, match="legs"):
        measure_shoe_rise(np.zeros((2, 4, 3)), few)
    with pytest.raises(ValueError, match="min_points"):
        ShoeRiseFit(min_points=2)


def _upper_grid(toe: np.ndarray, heading: float, rng: np.random.Generator) -> np.ndarray:
    """:func:`_upper`'s shoe flat, its points on a regular grid as a depth image's pixels are (4-5 mm apart)."""
    s, w = (a.ravel() for a in np.meshgrid(np.arange(0.0, 0.16, 0.004), np.arange(-0.045, 0.0451, 0.005)))
    h = 0.03 + 0.07 * s / 0.16 + rng.normal(0.0, 0.001, s.size)
    c, si = np.cos(heading), np.sin(heading)
    return np.column_stack([toe[0] - s * c - w * si, toe[1] - s * si + w * c, h])


def test_a_shoe_measures_how_far_the_tracked_foot_is_turned_from_it() -> None:
    """The turn is the flat shoe's heading less the tracked foot's, whichever way the tracked foot is turned or moved
    across (within the stretch), and the other shoe beside it is not taken for this one.  One line alone is pulled
    towards the tracked foot (it reads part of the turned shoe's width as along the foot); a second one, fitted around
    the foot turned to the first, comes nearer."""
    rng = np.random.default_rng(9)
    toes = np.array([[0.30, 0.08, 0.0], [0.25, -0.05, 0.0]])
    true_heading = np.array([0.12, -0.05])
    pts = np.vstack([_upper_grid(toes[0], true_heading[0], rng), _upper_grid(toes[1], true_heading[1], rng)])
    for err_deg in (-6.0, -2.0, 0.0, 3.0, 6.0):
        tracked = true_heading + np.radians([err_deg, -err_deg])
        tracked_toes = toes + np.array([[0.0, 0.01, 0.0], [0.005, -0.01, 0.0]])  # the line a centimetre off
        heels = tracked_toes - 0.26 * np.column_stack([np.cos(tracked), np.sin(tracked), np.zeros(2)])
        got = measure_shoe_turn(_legs(heels, tracked_toes), pts)
        np.testing.assert_allclose(np.degrees(got), [-err_deg, err_deg], atol=0.5 + 0.15 * abs(err_deg))
        if abs(err_deg) > 5.0:  # two lines come nearer than one
            one = measure_shoe_turn(_legs(heels, tracked_toes), pts, fit=ShoeTurnFit(fits=1))
            assert np.all(np.abs(np.degrees(one) - [-err_deg, err_deg]) > np.abs(np.degrees(got) - [-err_deg, err_deg]) + 0.5)


def test_a_shoe_without_enough_in_view_is_not_turned() -> None:
    rng = np.random.default_rng(10)
    toes = np.array([[0.30, 0.08, 0.0], [0.05, -0.08, 0.0]])
    heels = toes - np.array([0.26, 0.0, 0.0])
    assert np.all(np.isnan(measure_shoe_turn(_legs(heels, toes), _upper(toes[0], 0.0, 0.0, rng, n=10))))
    # a single column of points along the foot's line has no width to find its centre line with, but a line
    column = np.column_stack([np.full(40, 0.25), np.full(40, 0.08), np.linspace(0.04, 0.1, 40)])
    assert np.isnan(measure_shoe_turn(_legs(heels, toes), column)[0])
    with pytest.raises(ValueError, match="legs"):
        measure_shoe_turn(np.zeros((2, 4, 3)), column)
    with pytest.raises(ValueError, match="half_width"):
        ShoeTurnFit(half_width=0.0)
    with pytest.raises(ValueError, match="fits"):
        ShoeTurnFit(fits=0)


def test_both_shoe_measures_at_once_are_the_two_apart() -> None:
    rng = np.random.default_rng(11)
    toes = np.array([[0.30, 0.08, 0.0], [0.25, -0.05, 0.0]])
    heels = toes - 0.26 * np.array([[np.cos(0.2), np.sin(0.2), 0.0], [1.0, 0.0, 0.0]])
    pts = np.vstack([_upper(toes[0], 0.1, 0.3, rng), _upper(toes[1], 0.0, 0.0, rng), rng.uniform(-1.0, 1.0, (500, 3))])
    legs = _legs(heels, toes)
    rise, turn = measure_shoes(legs, pts)
    np.testing.assert_array_equal(rise, measure_shoe_rise(legs, pts))
    np.testing.assert_array_equal(turn, measure_shoe_turn(legs, pts))
    assert np.all(np.isfinite(rise)) and np.all(np.isfinite(turn))
    other = ShoeRiseFit(min_height=0.05)  # bands cut differently: measured apart
    rise, turn = measure_shoes(legs, pts, rise_fit=other)
    np.testing.assert_array_equal(rise, measure_shoe_rise(legs, pts, fit=other))
    np.testing.assert_array_equal(turn, measure_shoe_turn(legs, pts))


def test_the_compiled_point_selection_measures_as_numpy_does(monkeypatch) -> None:  # noqa: ANN001
    # the toes' and the shoes' points picked in one compiled pass (numba) or by numpy's masks: the same measures, on
    # shoes turned, raised heel-up and moved, among shins and clutter (a pinned dependency: the compiled case runs)
    from walker_gait.core import _jit, kernels

    rng = np.random.default_rng(7)
    results: dict[str, list[np.ndarray]] = {}
    scenes = []
    for _ in range(40):
        heels, toes, pts = _scene(rng)
        clutter = np.column_stack([rng.uniform(-0.3, 0.6, 3000), rng.uniform(-0.4, 0.4, 3000),
                                   rng.uniform(0.0, 0.4, 3000)])
        legs = _legs(heels, toes)
        legs[:, :, :2] += rng.normal(0.0, 0.03, (2, 1, 2))
        legs[:, HEEL, 2] += rng.uniform(0.0, 0.12, 2)
        legs[:, TOE, 2] += rng.uniform(0.0, 0.02, 2)
        scenes.append((legs, np.vstack([pts, clutter])))
    for name, jit in (("numpy", None), ("compiled", _jit)):
        monkeypatch.setattr(kernels, "compiled", lambda jit=jit: jit)
        out = []
        for legs, pts in scenes:
            toes, measured = measure_toes(legs, pts, camera=CAMERA)
            rise, turn = measure_shoes(legs, pts)
            out.append(np.concatenate([toes.ravel(), measured, rise, turn]))
        results[name] = out
    got, want = np.array(results["compiled"]), np.array(results["numpy"])
    assert np.isfinite(want).mean() > 0.9  # most feet measured: the comparison means something
    np.testing.assert_array_equal(np.isnan(got), np.isnan(want))
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
