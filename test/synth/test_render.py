"""Rendering + sensor model: camera round trip, floor consistency, determinism, Kinect model."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from walker_gait.core.types import ANKLE, CameraIntrinsics
from walker_gait.synth import body as B
from walker_gait.synth.sensor import (
    KINECT_INVALID,
    SensorModel,
    apply_sensor,
    kinect_depth_to_raw,
    kinect_raw_to_m,
    rasterize,
    shadow_mask,
)
from walker_gait.synth.session import Session, SessionSpec, generate_session


@pytest.fixture(scope="module")
def session() -> Session:
    spec = SessionSpec.preset("normal", duration=2.0, scale=0.5, stand_start=(0.3, 0.3))
    return generate_session(spec, rng=np.random.default_rng(21))


def test_kinect_equation_round_trip() -> None:
    z = np.array([0.5, 1.0, 2.0, 3.5])
    raw = kinect_depth_to_raw(z)
    np.testing.assert_allclose(1000.0 / (-0.00307 * raw + 3.33), z * 1000.0)
    zq = kinect_raw_to_m(np.rint(raw).astype(np.uint16))
    step = 0.00307 * z**2  # quantisation step grows as z^2
    assert np.all(np.abs(zq - z) <= step)
    assert np.isnan(kinect_raw_to_m(np.array([KINECT_INVALID], np.uint16))[0])


def test_rasterize_plane_exact_depth() -> None:
    intr = CameraIntrinsics(width=64, height=48, fx=50.0, fy=50.0, cx=31.5, cy=23.5)
    # tilted quad in front of the camera: z = 2 + 0.5 x
    v = np.array([[-2.0, -2.0, 0.0], [2.0, -2.0, 2.0], [2.0, 2.0, 2.0], [-2.0, 2.0, 0.0]])
    v[:, 2] += 1.0
    f = np.array([[0, 1, 2], [0, 2, 3]], np.int32)
    depth, face, cos = rasterize(v, f, intr, cull_backfaces=False)
    uu, _ = np.meshgrid(np.arange(64), np.arange(48))
    x_over_z = (uu - intr.cx) / intr.fx
    expected = 2.0 / (1.0 - 0.5 * x_over_z)  # z = 2 + 0.5 x with x = z * (u-cx)/fx
    hit = np.isfinite(depth)
    assert hit.mean() > 0.95
    np.testing.assert_allclose(depth[hit], expected[hit], rtol=1e-9)
    assert np.all(face[hit] >= 0)


def test_shadow_band_on_left_of_foreground() -> None:
    intr = CameraIntrinsics(width=100, height=4, fx=100.0, fy=100.0, cx=49.5, cy=1.5)
    z = np.full((4, 100), 2.0)
    z[:, 50:70] = 0.8
    m = shadow_mask(z, intr, 0.075)
    width = 100 * 0.075 * (1 / 0.8 - 1 / 2.0)  # ~5.6 px
    cols = np.nonzero(m[0])[0]
    assert cols.max() == 49 and cols.min() == 50 - int(np.floor(width))
    assert not m[:, 50:].any()


def test_sensor_noise_grows_with_distance() -> None:
    intr = CameraIntrinsics(width=200, height=200, fx=200.0, fy=200.0, cx=99.5, cy=99.5)
    model = SensorModel(grazing_cos=(0.0, 1e-9), edge_dropout=0.0, speckle_dropout=0.0, fabric_dropout=0.0, baseline=0.0)
    errs = []
    for z0 in (0.8, 1.6, 3.2):
        z = np.full((200, 200), z0)
        raw = apply_sensor(z, np.ones_like(z), np.zeros(z.shape, bool), intr, model, rng=np.random.default_rng(1))
        zz = kinect_raw_to_m(raw)
        errs.append(np.nanstd(zz - z0))
    ratio = np.array(errs[1:]) / np.array(errs[:-1])
    assert np.all(ratio > 3.0) and np.all(ratio < 5.5)  # ~ 4x per doubling: sigma_z ~ z^2
    assert 0.5e-3 < errs[0] < 3e-3


def test_frames_basic(session: Session) -> None:
    fr = session.frame(10)
    intr = session.intrinsics
    assert fr.data.shape == (intr.height, intr.width) and fr.data.dtype == np.uint16
    assert fr.data.max() <= KINECT_INVALID
    assert 0.02 < np.mean(fr.data == KINECT_INVALID) < 0.6
    assert np.any(fr.material == B.MAT_FLOOR) and np.any(fr.side == 0) and np.any(fr.side == 1)
    z = session.depth_m(10)
    near = np.nanmin(z)
    assert near >= session.params.sensor.near - 0.01


def test_rendered_floor_matches_gt_plane(session: Session) -> None:
    intr = session.intrinsics
    hs = []
    zs = []
    for i in (0, 20, 40):
        fr = session.frame(i)
        z = session.depth_m(i).astype(np.float64)
        ok = (fr.material == B.MAT_FLOOR) & np.isfinite(z)
        v, u = np.nonzero(ok)
        p = intr.backproject(u, v, z[ok])
        hs.append(session.floor.height(p))
        zs.append(z[ok])
    h = np.concatenate(hs)
    zz = np.concatenate(zs)
    assert len(h) > 1000
    sigma = 0.0015 * zz**2 + 0.004 * zz**2  # noise + one quantisation step, grows ~z^2
    assert np.median(np.abs(h)) < 0.004
    assert np.mean(np.abs(h) < 4 * sigma + 0.002) > 0.99
    # ideal depth is exact
    fr = session.frame(0)
    ok = fr.material == B.MAT_FLOOR
    v, u = np.nonzero(ok)
    p = intr.backproject(u, v, fr.ideal_depth[ok].astype(np.float64))
    assert np.max(np.abs(session.floor.height(p))) < 1e-4


def test_camera_round_trip_gt_points(session: Session) -> None:
    """Project GT ankles to pixels, back-project with the rendered depth: lands on the leg surface."""
    intr = session.intrinsics
    dists = []
    for i in range(0, len(session), 3):
        fr = session.frame(i)
        z = session.depth_m(i)
        for side in (0, 1):
            p = session.leg_points[i, side, ANKLE]
            u, v = intr.project(p)
            ui, vi = int(round(u)), int(round(v))
            if not (0 <= ui < intr.width and 0 <= vi < intr.height):
                continue
            if fr.side[vi, ui] != side or not np.isfinite(z[vi, ui]):
                continue  # occluded by the other leg / dropout
            q = intr.backproject(np.float64(ui), np.float64(vi), np.float64(z[vi, ui]))
            dists.append(np.linalg.norm(q - p))
    assert len(dists) >= 10
    d = np.array(dists)
    # the visible surface is the front of the shank/shoe: 2-8 cm in front of the ankle centre
    assert np.median(d) < 0.08
    assert np.all(d < 0.15)


def test_determinism() -> None:
    spec = SessionSpec.preset("baggy_trousers", duration=0.5, scale=0.25)
    a = generate_session(spec, rng=np.random.default_rng(5))
    b = generate_session(spec, rng=np.random.default_rng(5))
    c = generate_session(spec, rng=np.random.default_rng(6))
    np.testing.assert_array_equal(a.leg_points, b.leg_points)
    for i in (0, 7, 14):
        np.testing.assert_array_equal(a.frame(i).data, b.frame(i).data)
    # lazy rendering order does not matter
    np.testing.assert_array_equal(b.frame(3).data, a.frame(3).data)
    assert not np.array_equal(a.leg_points, c.leg_points)


@pytest.mark.parametrize("scenario", ["different_camera", "baggy_trousers", "absent_start"])
def test_scenario_frames(scenario: str) -> None:
    spec = SessionSpec.preset(scenario, duration=1.0, scale=0.25)
    s = generate_session(spec, rng=np.random.default_rng(3))
    z = s.depth_m(len(s) - 1)
    assert np.isfinite(z).mean() > 0.2
    if scenario == "different_camera":
        assert s.params.camera_name != "kinect_v1" and s.depth_format == "mm"
    if scenario == "baggy_trousers":
        assert np.any(s.frame(0).material == B.MAT_TROUSERS)
    if scenario == "absent_start":
        fr = s.frame(0)
        assert not np.any(fr.side >= 0)  # nobody in view at the start


@pytest.fixture(scope="module")
def rocking() -> tuple[Session, Session]:
    """The same session drawn rigid and on a walker that rocks 1 deg RMS (pitch and roll)."""
    spec = SessionSpec.preset("normal", duration=3.0, scale=0.5, stand_start=(0.6, 0.6))
    rigid = generate_session(spec, rng=np.random.default_rng(8))
    rocking = generate_session(dataclasses.replace(spec, vibration_deg=(1.0, 1.0)), rng=np.random.default_rng(8))
    return rigid, rocking


def test_a_rocking_walker_moves_the_camera_not_the_user(rocking: tuple[Session, Session]) -> None:
    rigid, rock = rocking
    assert rigid.walker_tilt is None and rock.walker_tilt is not None
    # the user, the walker's path and the footfalls are the same draws
    np.testing.assert_array_equal(rigid.body.leg_points(), rock.body.leg_points())
    np.testing.assert_array_equal(rigid.walker_pose, rock.walker_pose)
    assert [(s.stamp, s.step_length, s.step_width) for s in rigid.steps] == [(s.stamp, s.step_length, s.step_width) for s in rock.steps]
    # ... seen from a camera that rocks: still while the walker stands, about the asked RMS once it rolls
    tilt = np.degrees(rock.walker_tilt)
    speed = np.abs(np.gradient(rock.walker_pose[:, 0], rock.stamps))
    assert np.abs(tilt[speed < 1e-6]).max() < 0.05
    rms = np.sqrt(np.mean(tilt[speed > 0.3] ** 2, axis=0))
    assert np.all((rms > 0.5) & (rms < 1.6)), rms
    moved = np.linalg.norm(rock.leg_points - rigid.leg_points, axis=-1)[speed > 0.3]
    assert np.median(moved) > 0.003
    # the camera frame points are the world points seen from the rocking camera
    i = int(np.argmax(np.abs(tilt[:, 0])))
    seen = rock.world_to_camera(rock.body.leg_points()[i][None], rock.stamps[i : i + 1])[0]
    np.testing.assert_allclose(seen, rock.leg_points[i], atol=1e-9)


def test_a_rocking_walkers_floor_is_rendered_where_floor_at_puts_it(rocking: tuple[Session, Session]) -> None:
    rigid, rock = rocking
    intr = rock.intrinsics
    i = int(np.argmax(np.abs(np.degrees(rock.walker_tilt)).max(axis=1)))
    fr = rock.frame(i)
    ok = fr.material == B.MAT_FLOOR
    v, u = np.nonzero(ok)
    p = intr.backproject(u, v, fr.ideal_depth[ok].astype(np.float64))
    assert np.max(np.abs(rock.floor_at(i).height(p))) < 1e-4
    assert np.max(np.abs(rock.floor.height(p))) > 0.01  # the nominal floor is not it
    # the walker's own parts stay put in the image; a rigid session's floor_at is its floor
    parts_rigid = rigid.frame(i).material == B.MAT_WALKER
    parts_rock = fr.material == B.MAT_WALKER
    assert np.mean(parts_rigid == parts_rock) > 0.99
    assert rigid.floor_at(i) is rigid.floor
